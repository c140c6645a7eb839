#!/usr/bin/env python3
"""Bending angle against pressure of the fiber-wrapped bending actuator, tied fibers against homogenized walls.

Runs bending_actuator_{tied,homogenized,dissertation}.toml of this folder with `softhom macro`, one at a
time, at the mesh of the scene and at finer ones (--refine: the circumferential, axial and radial cell
counts times each factor), and prints from each run's device.csv (kind = "bending") the end rotation
(bending angle) at every output pressure, the homogenized models' difference from the tied one, and the
cost of each run (wall time, Newton iterations). Finished runs are kept in OUT/<scene>-r<factor>/.

    OMP_NUM_THREADS=1 nice python3 studies/structures/bending_actuator_study.py --softhom build/apps/softhom \\
        --out out/bending --refine 1 1.5 [--plot studies/figures/bending_actuator]   # writes .png and .svg
    python3 studies/structures/bending_actuator_study.py --out out/bending --table   # the table only
"""
import argparse
import csv
import json
import pathlib
import re
import subprocess
import sys

HERE = pathlib.Path(__file__).resolve().parent
MODELS = [("tied", "tied fibers"), ("homogenized", "calibrated Gent + HGO"), ("dissertation", "dissertation's anisotropic law")]


def refined(text, factor):
    """The scene with its cell counts times `factor` (at least the original count)."""
    def scale(m):
        return f"{m.group(1)} = {max(int(m.group(2)), round(int(m.group(2)) * factor))}"
    return re.sub(r"^(radial_cells|circumferential_cells|axial_cells) = ([0-9]+)", scale, text, flags=re.M)


def run(softhom, out, model, factor):
    dest = out / f"bending_actuator_{model}-r{factor:g}"
    if (dest / "summary.json").exists():
        return
    out.mkdir(parents=True, exist_ok=True)
    scene = out / f"bending_actuator_{model}-r{factor:g}.toml"
    scene.write_text(refined((HERE / f"bending_actuator_{model}.toml").read_text(), factor))
    print(f"running {model} at refinement {factor:g}", flush=True)
    subprocess.run([softhom, "macro", str(scene), "--out", str(dest), "-q"], check=False)


def load(out, model, factor):
    dest = out / f"bending_actuator_{model}-r{factor:g}"
    try:
        summary = json.loads((dest / "summary.json").read_text())
        with open(dest / "device.csv") as f:
            rows = [{k: float(v) for k, v in r.items()} for r in csv.DictReader(f)]
    except (OSError, ValueError):
        return None
    return {"rows": rows, "summary": summary}


def table(out, factors):
    runs = {(m, f): load(out, m, f) for m, _ in MODELS for f in factors}
    ref = runs.get(("tied", factors[-1]))
    print("| model | cells ×| " + " | ".join(f"θ at {r['pressure_kPa']:g} kPa [°]" for r in (ref or {"rows": []})["rows"][1:]) +
          " | wall [s] | Newton |")
    for (model, factor), r in runs.items():
        if not r:
            continue
        angles = [row["bending_angle_deg"] for row in r["rows"][1:]]
        cells = []
        for k, a in enumerate(angles):
            gap = "" if model == "tied" or not ref or k >= len(ref["rows"]) - 1 else \
                f" ({100 * (a / ref['rows'][k + 1]['bending_angle_deg'] - 1):+.0f} %)"
            cells.append(f"{a:.1f}{gap}")
        s = r["summary"]
        print(f"| {model} | {factor:g} | " + " | ".join(cells) +
              f" | {s.get('wall_time_s', float('nan')):.1f} | {s.get('newton_iterations', 0)} |")


def plot(out, factors, stem):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(5.2, 3.8))
    for (model, label), color in zip(MODELS, ("k", "C0", "C1")):
        for factor, style in zip(factors, ("o-", "s--", "^:")):
            r = load(out, model, factor)
            if r:
                ax.plot([row["pressure_kPa"] for row in r["rows"]], [row["bending_angle_deg"] for row in r["rows"]],
                        color + style, ms=4, label=f"{label} (cells ×{factor:g})")
    ax.set_xlabel("pressure p [kPa]")
    ax.set_ylabel("bending angle θ (end rotation) [°]")
    ax.set_title("fiber-wrapped bending actuator, fibers ±80°", fontsize=10)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    for ext in ("png", "svg"):
        fig.savefig(f"{stem}.{ext}", dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--softhom", default="softhom")
    ap.add_argument("--out", type=pathlib.Path, required=True)
    ap.add_argument("--refine", nargs="+", type=float, default=[1.0])
    ap.add_argument("--models", nargs="+", default=[m for m, _ in MODELS])
    ap.add_argument("--plot", help="figure stem: writes STEM.png and STEM.svg")
    ap.add_argument("--table", action="store_true", help="print the table from finished runs only")
    a = ap.parse_args()
    if not a.table:
        for factor in a.refine:
            for model in a.models:
                run(a.softhom, a.out, model, factor)
    table(a.out, a.refine)
    if a.plot:
        plot(a.out, a.refine, a.plot)


if __name__ == "__main__":
    sys.exit(main())
