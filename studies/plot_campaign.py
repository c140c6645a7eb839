#!/usr/bin/env python3
"""PNG plots of a `softhom sweep` store in the style of the dissertation's chapter IV.

    python3 studies/plot_campaign.py DIR [--out PNGDIR]

DIR is a sweep output directory (DIR/cases.csv, the tidy table written next to DIR/campaign.h5 with
one row per case and step and every parameter as a column). Needs only python3 and matplotlib
(Debian: python3-matplotlib). Figures whose cases are not in the store are skipped with a note.

  fig19_tension_circle.png      Fig. 19: nominal stress vs stretch, circular fibers, alpha = 30/45/60,
                                ecoflex and PDMS (+ pure matrix)
  fig22_tension_square.png      Fig. 21/22: the same with square fibers
  fig23_volume_fraction.png     Fig. 23: alpha = 45, VF 0.12 vs 0.23, circular and square
  fig24_compression.png         Fig. 24: uniaxial compression by angle (+ pure matrix)
  fig25_relaxation.png          Fig. 25: ramp-hold: stretch and stress vs time
  table1_fiber_rotation.png     Table 1: fiber rotation at the end of tension, with the dissertation values
  table14_fiber_rotation.png    Table 14: the same in compression
  tables.md                     Tables 1 and 14 as Markdown
"""
import argparse
import csv
import math
import os
import sys
from collections import OrderedDict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

# Dissertation values (delta alpha in degrees), Tables 1 and 14: circular fibers, VF ~0.23.
TABLE1 = {("pdms", 30): 15.54, ("pdms", 45): 25.93, ("pdms", 60): 21.55,
          ("ecoflex", 30): 30.6, ("ecoflex", 45): 30.47, ("ecoflex", 60): 26.73}
TABLE14 = {("pdms", 30): -11.5, ("pdms", 45): -17.3, ("pdms", 60): -15.6,
           ("ecoflex", 30): -13.6, ("ecoflex", 45): -14.7, ("ecoflex", 60): -15.5}
ANGLE_COLORS = {30.0: "tab:blue", 45.0: "tab:orange", 60.0: "tab:green"}


def load_cases(path):
    """case id -> {"params": {...}, "status": str, "rows": [dict of floats]} in file order."""
    cases = OrderedDict()
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        first = reader.fieldnames
        params = first[2:first.index("step")]
        for row in reader:
            c = cases.setdefault(row["case"], {"params": {}, "status": row["status"], "rows": []})
            for p in params:
                v = row[p]
                try:
                    c["params"][p] = float(v)
                except ValueError:
                    c["params"][p] = v
            if row["step"] == "":
                continue
            c["rows"].append({k: float(v) for k, v in row.items() if k not in params and k not in ("case", "status") and v != ""})
    return cases


def base_matrix(name):
    return name.split("_")[0]


def select(cases, **want):
    out = []
    for cid, c in cases.items():
        ok = True
        for k, v in want.items():
            have = c["params"].get(k)
            if callable(v):
                ok = ok and v(have)
            elif isinstance(v, float) and isinstance(have, float):
                ok = ok and math.isclose(v, have, rel_tol=1e-9, abs_tol=1e-12)
            else:
                ok = ok and have == v
        if ok and c["rows"]:
            out.append((cid, c))
    return out


def col(c, name):
    return [r[name] for r in c["rows"]]


def label_of(c, extra=""):
    p = c["params"]
    if p.get("volume_fraction", 0.0) == 0.0:
        return "matrix" + extra
    s = "α = %g°" % p["angle"]
    if c["status"] != "ok":
        s += " (failed)"
    return s + extra


def stress_panels(cases, out, title, load, section, vf, matrices, fname, xlabel="stretch λ [1]"):
    fig, axes = plt.subplots(1, len(matrices), figsize=(5.2 * len(matrices), 4.2), squeeze=False)
    drawn = 0
    for ax, m in zip(axes[0], matrices):
        for cid, c in select(cases, matrix=m, load=load, section=section, volume_fraction=vf):
            ax.plot(col(c, "F11"), col(c, "P11"), "-o", ms=3, color=ANGLE_COLORS.get(c["params"]["angle"]),
                    label=label_of(c))
            drawn += 1
        for cid, c in select(cases, matrix=m, load=load, volume_fraction=0.0):
            ax.plot(col(c, "F11"), col(c, "P11"), "k--", label="pure " + m)
        ax.set_title("%s matrix" % m)
        ax.set_xlabel(xlabel)
        ax.set_ylabel("engineering stress P11 [MPa]")
        ax.grid(alpha=0.3)
        if ax.lines:
            ax.legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    return save(fig, out, fname, drawn)


def save(fig, out, fname, drawn):
    if drawn == 0:
        plt.close(fig)
        print("plot_campaign: %s skipped (no cases in the store)" % fname)
        return None
    path = os.path.join(out, fname)
    # PNG at 300 dpi for documents and the same figure as SVG for papers, each written whole first.
    for target, options in ((path, {"dpi": 300}), (os.path.splitext(path)[0] + ".svg", {})):
        ext = os.path.splitext(target)[1]
        tmp = target + ".tmp" + ext
        fig.savefig(tmp, **options)
        os.replace(tmp, target)
    plt.close(fig)
    print("plot_campaign: " + path)
    return path


def fig23(cases, out, matrices):
    sections = [s for s in ("circle", "square") if select(cases, section=s, angle=45.0, load="tension")]
    if not sections:
        return save(plt.figure(), out, "fig23_volume_fraction.png", 0)
    fig, axes = plt.subplots(1, len(sections), figsize=(5.2 * len(sections), 4.2), squeeze=False)
    styles = {0.12: "--", 0.23: "-"}
    colors = {"ecoflex": "tab:red", "pdms": "tab:blue"}
    drawn = 0
    for ax, s in zip(axes[0], sections):
        for m in matrices:
            for cid, c in select(cases, matrix=m, section=s, angle=45.0, load="tension"):
                vf = c["params"]["volume_fraction"]
                ax.plot(col(c, "F11"), col(c, "P11"), styles.get(round(vf, 2), ":"), color=colors.get(m),
                        label="%s, VF %g" % (m, vf))
                drawn += 1
        ax.set_title("%s fibers, α = 45°" % s)
        ax.set_xlabel("stretch λ [1]")
        ax.set_ylabel("engineering stress P11 [MPa]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Fig. 23 style: volume fraction (uniaxial tension)")
    fig.tight_layout()
    return save(fig, out, "fig23_volume_fraction.png", drawn)


def fig25(cases, out):
    rel = [(cid, c) for cid, c in cases.items() if c["params"].get("load") == "relaxation" and c["rows"]]
    if not rel:
        return save(plt.figure(), out, "fig25_relaxation.png", 0)
    mats = list(OrderedDict.fromkeys(c["params"]["matrix"] for _, c in rel))
    fig, axes = plt.subplots(1, 1 + len(mats), figsize=(4.6 * (1 + len(mats)), 4.0), squeeze=False)
    first = rel[0][1]
    axes[0][0].plot(col(first, "t"), col(first, "F11"), "k-")
    axes[0][0].set_title("(a) applied stretch")
    axes[0][0].set_xlabel("time [s]")
    axes[0][0].set_ylabel("stretch λ")
    axes[0][0].grid(alpha=0.3)
    for k, m in enumerate(mats):
        ax = axes[0][k + 1]
        for sec, style in (("circle", "-"), ("square", "-.")):
            for cid, c in select(cases, matrix=m, load="relaxation", section=sec):
                ax.plot(col(c, "t"), col(c, "P11"), style, color=ANGLE_COLORS.get(c["params"]["angle"]),
                        label=label_of(c, ", " + sec))
        for cid, c in select(cases, matrix=m, load="relaxation", volume_fraction=0.0):
            ax.plot(col(c, "t"), col(c, "P11"), "k--", label="pure matrix")
        ax.set_title("(%s) %s" % ("bcdefg"[k], m))
        ax.set_xlabel("time [s]")
        ax.set_ylabel("engineering stress P11 [MPa]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("Fig. 25 style: ramp to λ = 1.5 and hold (QLV matrix, elastic fibers)")
    fig.tight_layout()
    return save(fig, out, "fig25_relaxation.png", len(rel))


def rotation_table(cases, out, load, reference, number, fname):
    rows = []
    for angle in (30.0, 45.0, 60.0):
        row = ["%g°" % angle]
        for m in ("pdms", "ecoflex"):
            got = select(cases, matrix=m, load=load, section="circle", volume_fraction=0.23, angle=angle)
            if got:
                c = got[0][1]
                last = c["rows"][-1]
                row.append("%.1f° (λ = %.2f)%s" % (last["delta_fiber_angle_deg"], last["F11"],
                                                   "" if c["status"] == "ok" else " failed"))
            else:
                row.append("—")
            row.append("%.2f°" % reference[(m, angle)])
        rows.append(row)
    header = ["initial α", "PDMS (RVE)", "PDMS (diss.)", "Ecoflex (RVE)", "Ecoflex (diss.)"]
    drawn = sum(1 for r in rows for x in (r[1], r[3]) if x != "—")
    md = ["### Table %d style: fiber rotation Δα at the end of %s (circular, VF 0.23)" % (number, load), "",
          "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    md += ["| " + " | ".join(r) + " |" for r in rows]
    fig, ax = plt.subplots(figsize=(8.5, 1.9))
    ax.axis("off")
    t = ax.table(cellText=rows, colLabels=header, loc="center", cellLoc="center")
    t.auto_set_font_size(False)
    t.set_fontsize(9)
    t.scale(1, 1.5)
    ax.set_title("Table %d style: fiber rotation Δα at the end of %s (circular fibers, VF 0.23)" % (number, load),
                 fontsize=10)
    fig.tight_layout()
    save(fig, out, fname, drawn)
    return "\n".join(md) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dir", help="softhom sweep output directory (with cases.csv)")
    ap.add_argument("--out", help="where to write the PNGs (default: DIR/plots)")
    a = ap.parse_args()
    src = os.path.join(a.dir, "cases.csv")
    if not os.path.exists(src):
        sys.exit("plot_campaign: %s not found (run softhom sweep first)" % src)
    out = a.out or os.path.join(a.dir, "plots")
    os.makedirs(out, exist_ok=True)
    cases = load_cases(src)
    # Elastic matrices first, by their base name (ecoflex_qlv → ecoflex family).
    matrices = [m for m in ("ecoflex", "pdms") if any(c["params"].get("matrix") == m for c in cases.values())]
    if not matrices:
        matrices = list(OrderedDict.fromkeys(c["params"].get("matrix") for c in cases.values()))
    stress_panels(cases, out, "Fig. 19 style: uniaxial tension, circular fibers, VF 0.23", "tension", "circle", 0.23,
                  matrices, "fig19_tension_circle.png")
    stress_panels(cases, out, "Fig. 21/22 style: uniaxial tension, square fibers, VF 0.23", "tension", "square", 0.23,
                  matrices, "fig22_tension_square.png")
    fig23(cases, out, matrices)
    stress_panels(cases, out, "Fig. 24 style: uniaxial compression, circular fibers, VF 0.23", "compression", "circle",
                  0.23, matrices, "fig24_compression.png")
    fig25(cases, out)
    md = rotation_table(cases, out, "tension", TABLE1, 1, "table1_fiber_rotation.png")
    md += "\n" + rotation_table(cases, out, "compression", TABLE14, 14, "table14_fiber_rotation.png")
    with open(os.path.join(out, "tables.md.tmp"), "w") as f:
        f.write(md)
    os.replace(os.path.join(out, "tables.md.tmp"), os.path.join(out, "tables.md"))
    print("plot_campaign: " + os.path.join(out, "tables.md"))


if __name__ == "__main__":
    main()
