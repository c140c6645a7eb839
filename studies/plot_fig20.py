#!/usr/bin/env python3
"""Dissertation Fig. 20 analogue: unit-cell (RVE) response vs the calibrated homogeneous macro model.

    softhom sweep studies/campaigns/chapter4.toml --out out/chapter4          # or bench_chapter4_subset.toml
    softhom calibrate studies/calibrations/chapter4_pdms.toml --out out/cal-pdms
    softhom calibrate studies/calibrations/chapter4_ecoflex.toml --out out/cal-ecoflex
    python3 studies/plot_fig20.py out/chapter4 out/cal-pdms out/cal-ecoflex [-o FILE.png] [--grid 32]

Top row: nominal stress P11 vs stretch in uniaxial tension, circular glass fibers, VF 0.23, fiber angle
30/45/60 deg — RVE cells from DIR/cases.csv (markers) and the Gent + HGO model fitted to those three
curves at once (lines, CAL/curves/<name>.csv, the model's response at the optimum). Bottom row: the
compression curve at 45 deg, held out of the fit. One column per calibration directory (its matrix from
the curve names). Writes FILE (default CAMPAIGN/plots/fig20_rve_vs_macro.png) and prints a table of the
per-curve NRMSE and the fitted parameters (Markdown).
"""
import csv
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

COLORS = {30: "tab:blue", 45: "tab:orange", 60: "tab:green"}


def read_cases(path):
    """cases.csv -> {case id: [(F11, P11), ...]} (ok and failed cases: the converged rows)."""
    cases = {}
    with open(path) as f:
        for r in csv.DictReader(f):
            if r.get("F11", "") == "":
                continue
            cases.setdefault(r["case"], []).append((float(r["F11"]), float(r["P11"])))
    return cases


def read_model(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return [float(r["F11"]) for r in rows], [float(r["P11"]) for r in rows]


def main(argv):
    out = None
    grid = 32  # section grid of the campaign cases (chapter4.toml: 32)
    if "--grid" in argv:
        k = argv.index("--grid")
        grid = int(argv[k + 1])
        argv = argv[:k] + argv[k + 2:]
    if "-o" in argv:
        k = argv.index("-o")
        out = argv[k + 1]
        argv = argv[:k] + argv[k + 2:]
    if len(argv) < 2:
        sys.exit(__doc__)
    campaign, cals = argv[0], argv[1:]
    cases = read_cases(os.path.join(campaign, "cases.csv"))
    if out is None:
        out = os.path.join(campaign, "plots", "fig20_rve_vs_macro.png")
    os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)

    fig, axes = plt.subplots(2, len(cals), figsize=(5.4 * len(cals), 7.6), squeeze=False,
                             gridspec_kw={"height_ratios": [3, 2]})
    table = ["| matrix | curve | role | NRMSE | R² |", "|---|---|---|---|---|"]
    params = []
    for j, cal in enumerate(cals):
        with open(os.path.join(cal, "summary.json")) as f:
            summary = json.load(f)
        matrix = summary["curves"][0]["name"].split("_a")[0]
        label = {"pdms": "PDMS", "ecoflex": "Ecoflex"}.get(matrix, matrix)
        for c in summary["curves"]:
            name = c["name"]
            # name: <matrix>_a<angle>_<load>; the case id is in the calibration file, rebuild it here.
            angle = int(name.split("_a")[1].split("_")[0])
            load = name.rsplit("_", 1)[1]
            case = f"{matrix}-circle-a{angle}-vf0.23-square-n{grid}x{grid}-{load}"
            ax = axes[0][j] if load == "tension" else axes[1][j]
            col = COLORS.get(angle, "k")
            if case in cases:
                x, y = zip(*cases[case])
                ax.plot(x, y, "o", ms=4, mfc="none", color=col, label=f"RVE α = {angle}°")
            mpath = os.path.join(cal, "curves", name + ".csv")
            if os.path.exists(mpath) and c.get("ok", False):
                mx, my = read_model(mpath)
                ax.plot(mx, my, "-" if c["role"] == "fit" else "--", lw=1.6, color=col,
                        label=f"model α = {angle}°" + (" (held out)" if c["role"] == "holdout" else ""))
            ok = c.get("ok", False)
            table.append(f"| {label} | {name} | {c['role']} | "
                         f"{100 * c['nrmse']:.2f} % | {c['r2']:.4f} |" if ok else
                         f"| {label} | {name} | {c['role']} | not evaluable | – |")
        free = [p for p in summary["parameters"] if p["free"]]
        ptxt = ", ".join(f"{p['name']} = {p['value']:.4g}" for p in free)
        params.append(f"- {label}: {ptxt} (fixed: " + ", ".join(
            f"{p['name']} = {p['value']:.4g}" for p in summary["parameters"] if not p["free"]) + ")")
        axes[0][j].set_title(f"({chr(97 + j)}) {label}: tension, RVE vs Gent + HGO\n{ptxt}", fontsize=9)
        axes[1][j].set_title(f"{label}: compression at 45° (held out of the fit)", fontsize=9)
        for ax in (axes[0][j], axes[1][j]):
            ax.set_xlabel("stretch λ = F11")
            ax.set_ylabel("engineering stress P11 [MPa]")
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7, ncol=2)
    fig.suptitle(f"Fig. 20 analogue: periodic unit cells ({grid}² sections, VF 0.23, circular glass fibers) "
                 "vs the calibrated homogeneous model", fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=300)
    print("\n".join(table))
    print()
    print("\n".join(params))
    print(f"\nwrote {out}")


if __name__ == "__main__":
    main(sys.argv[1:])
