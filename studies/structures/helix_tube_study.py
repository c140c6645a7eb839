#!/usr/bin/env python3
"""Structure-level error of the homogenized tube models against the fully resolved tube.

Runs the scenes of this folder (resolved_*, calibrated_*, dissertation_*) with `softhom macro`, one at
a time, at the mesh sizes asked for, and prints from the device.csv and summary.json of every finished
run: the resolved tube's mesh convergence (observed order of each quantity), the errors of the
calibrated (b) and dissertation (c) homogenized models against the finest resolved mesh in axial
stretch, radial stretch and twist at the three output pressures, and the cost of each (wall time, free
dofs). Finished runs are kept in OUT/<scene>-h<size>/ and not run again.

    OMP_NUM_THREADS=1 nice python3 studies/structures/helix_tube_study.py --softhom build/apps/softhom \\
        --out out/helix --cases ecoflex_a45 pdms_a45 --resolved 0.4 0.3 0.22 --homogenized 0.3 0.7 \\
        [--models calibrated dissertation calibrated_biaxial_shear calibrated_fiber_composite]
        [--reference published]     # against the README's finest resolved tubes, without running them
    python3 studies/structures/helix_tube_study.py --out out/helix --table      # the table only
"""
import argparse
import csv
import json
import math
import os
import pathlib
import re
import subprocess
import sys

HERE = pathlib.Path(__file__).resolve().parent
QUANTITIES = [("axial_stretch", "λz", "strain"), ("radial_stretch_outer", "λr", "strain"), ("twist_end_deg", "twist°", "angle")]


def run(softhom, out, scene, size):
    dest = out / f"{scene}-h{size}"
    if (dest / "summary.json").exists():
        return
    text = (HERE / f"{scene}.toml").read_text()
    text = re.sub(r"mesh_size = [0-9.]+", f"mesh_size = {size}", text, count=1)
    text = text.replace('geo = "../meshes/', f'geo = "{HERE.parent / "meshes"}/')
    out.mkdir(parents=True, exist_ok=True)
    scene_file = out / f"{scene}-h{size}.toml"
    scene_file.write_text(text)
    env = dict(os.environ, SOFTHOM_MESH_CACHE=str(out / "mesh-cache"))
    print(f"running {scene} at h = {size}", flush=True)
    subprocess.run([softhom, "macro", str(scene_file), "--out", str(dest), "-q"], env=env, check=False)


def load(out, scene, size):
    dest = out / f"{scene}-h{size}"
    try:
        summary = json.loads((dest / "summary.json").read_text())
        with open(dest / "device.csv") as f:
            rows = list(csv.DictReader(f))
    except (OSError, ValueError):
        return None
    return {"rows": rows[1:], "summary": summary}


# The finest resolved tubes of studies/README.md (Ecoflex 45°: h = 0.22 mm; PDMS 45°: h = 0.3 mm), as
# (pressure [kPa], λz, λr outer, twist [°]): `--reference published` compares against these instead of
# running the resolved tube again (7.5 min for Ecoflex at h = 0.22).
PUBLISHED = {
    "ecoflex_a45": [(3.33, 1.0307, 1.0147, -2.93), (6.67, 1.0647, 1.0301, -6.19), (10.0, 1.1012, 1.0464, -9.74)],
    "pdms_a45": [(66.7, 1.0233, 1.0190, -0.62), (133.0, 1.0495, 1.0392, -1.30), (200.0, 1.0796, 1.0604, -2.04)],
}


def published(case):
    """The published resolved run of a case in the form load() returns (no cost: wall time and dofs 0)."""
    rows = [{"pressure_kPa": p, **{q: v for (q, _, _), v in zip(QUANTITIES, vals)}} for p, *vals in PUBLISHED[case]]
    return {"rows": rows, "summary": {}}


def cost(summary):
    text = json.dumps(summary)
    wall = re.search(r'"wall_time_s": ([0-9.eE+-]+)', text)
    dofs = re.search(r'"dofs": ([0-9]+)', text)
    return (float(wall.group(1)) if wall else float("nan"), int(dofs.group(1)) if dofs else 0)


def value(rows, k, q):
    return float(rows[k][q]) if k < len(rows) else float("nan")


def error(model, ref, kind):
    """Relative error of the strain λ − 1, or of the twist angle."""
    zero = 0.0 if kind == "angle" else 1.0
    return (model - ref) / (ref - zero) if ref != zero else float("nan")


def table(out, cases, resolved, homogenized, models, reference="run"):
    for case in cases:
        if reference == "published":
            runs = {"published": published(case)}
        else:
            runs = {h: load(out, f"resolved_{case}", h) for h in resolved}
            runs = {h: r for h, r in runs.items() if r and r["rows"]}
        if not runs:
            print(f"\n{case}: no resolved run finished")
            continue
        sizes = sorted(runs)
        fine = runs[sizes[0]]
        if reference == "published":
            homogenized_table(out, case, homogenized, models, fine, "the published resolved tube")
            continue
        print(f"\n## {case}: resolved tube, mesh convergence (last pressure)")
        print("| h [mm] | free dofs | wall [s] | " + " | ".join(n for _, n, _ in QUANTITIES) + " |")
        print("|---|---|---|" + "---|" * len(QUANTITIES))
        for h in sizes:
            w, d = cost(runs[h]["summary"])
            vals = " | ".join(f"{value(runs[h]['rows'], len(runs[h]['rows']) - 1, q):.5f}" for q, _, _ in QUANTITIES)
            print(f"| {h} | {d} | {w:.1f} | {vals} |")
        if len(sizes) >= 3:
            a, b, c = (runs[h]["rows"] for h in sizes[:3])
            for q, n, _ in QUANTITIES:
                k = min(len(a), len(b), len(c)) - 1
                d1 = value(b, k, q) - value(a, k, q)
                d2 = value(c, k, q) - value(b, k, q)
                if d1 != 0 and d2 / d1 > 0:
                    order = math.log(abs(d2 / d1)) / math.log(sizes[1] / sizes[0])
                    print(f"observed order of {n}: {order:.2f}")
        homogenized_table(out, case, homogenized, models, fine, f"the resolved tube at h = {sizes[0]}")


def homogenized_table(out, case, homogenized, models, fine, what):
    print(f"\n## {case}: homogenized models against {what}")
    print("| model | p [kPa] | " + " | ".join(f"{n} (resolved)" for _, n, _ in QUANTITIES) + " | " +
          " | ".join(f"err {n}" for _, n, _ in QUANTITIES) + " | wall [s] | free dofs | cost ratio |")
    print("|---|---|" + "---|" * (2 * len(QUANTITIES) + 3))
    wf, df = cost(fine["summary"])
    for model in models:
        for h in homogenized:
            r = load(out, f"{model}_{case}", h)
            if not r:
                continue
            w, d = cost(r["summary"])
            for k in range(len(fine["rows"])):
                p = float(fine["rows"][k]["pressure_kPa"])
                refs = [value(fine["rows"], k, q) for q, _, _ in QUANTITIES]
                errs = []
                for (q, _, kind), ref in zip(QUANTITIES, refs):
                    errs.append(f"{100 * error(value(r['rows'], k, q), ref, kind):+.1f} %")
                print(f"| {model} h={h} | {p:g} | " + " | ".join(f"{v:.4f}" for v in refs) + " | " +
                      " | ".join(errs) + f" | {w:.1f} | {d} | " + (f"{wf / w:.2g}×" if wf > 0 else "-") + " |")


def plot(out, case, resolved, homogenized, models, png):
    """Mesh convergence of the resolved tube (last pressure) with the homogenized models as lines."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    runs = {h: load(out, f"resolved_{case}", h) for h in resolved}
    runs = {h: r for h, r in runs.items() if r and r["rows"]}
    fig, axes = plt.subplots(1, len(QUANTITIES), figsize=(4 * len(QUANTITIES), 3.4))
    for ax, (q, name, kind) in zip(axes, QUANTITIES):
        zero = 0.0 if kind == "angle" else 1.0
        hs = sorted(runs)
        ax.plot(hs, [value(runs[h]["rows"], len(runs[h]["rows"]) - 1, q) - zero for h in hs], "ko-", label="resolved")
        for model, style in zip(models, ("C0--", "C1:", "C2-.")):
            r = load(out, f"{model}_{case}", homogenized[0])
            if r:
                ax.axhline(value(r["rows"], len(r["rows"]) - 1, q) - zero, color=style[:2], ls=style[2:], label=model)
        ax.set_xlabel("mesh size h [mm]")
        ax.set_ylabel(name if kind == "angle" else f"{name} − 1")
        ax.invert_xaxis()
    axes[0].legend(fontsize=8)
    fig.suptitle(f"{case}: resolved tube against homogenized models (last pressure)")
    fig.tight_layout()
    fig.savefig(png, dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--softhom", default="softhom")
    ap.add_argument("--out", type=pathlib.Path, required=True)
    ap.add_argument("--cases", nargs="+", default=["ecoflex_a45", "pdms_a45"])
    ap.add_argument("--resolved", nargs="+", type=float, default=[0.4, 0.3, 0.22])
    ap.add_argument("--homogenized", nargs="+", type=float, default=[0.3])
    ap.add_argument("--models", nargs="+", default=["calibrated", "dissertation"],
                    help="homogenized models: the scenes <model>_<case>.toml")
    ap.add_argument("--plot", type=pathlib.Path, help="PNG of the first case's mesh convergence")
    ap.add_argument("--table", action="store_true", help="print the table from finished runs only")
    ap.add_argument("--reference", choices=["run", "published"], default="run",
                    help="compare against the resolved runs of --resolved, or the published finest ones (no run)")
    a = ap.parse_args()
    if a.reference == "published":
        a.resolved = []
    if not a.table:
        for case in a.cases:
            for model in a.models:
                for h in a.homogenized:
                    run(a.softhom, a.out, f"{model}_{case}", h)
            for h in sorted(a.resolved, reverse=True):
                run(a.softhom, a.out, f"resolved_{case}", h)
    table(a.out, a.cases, a.resolved, a.homogenized, a.models, a.reference)
    if a.plot:
        plot(a.out, a.cases[0], a.resolved, a.homogenized, a.models, a.plot)


if __name__ == "__main__":
    sys.exit(main())
