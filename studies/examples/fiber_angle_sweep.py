#!/usr/bin/env python3
"""Fiber-angle sweep through the Python module: a small Ecoflex + glass cell (circular fibers, VF 0.23)
under uniaxial tension at several fiber angles (softhom.run_rve), the curves plotted with matplotlib,
and the homogeneous Gent + HGO macro model fitted to them (softhom.calibrate, curves as arrays).

    PYTHONPATH=build/python /usr/bin/python3 studies/examples/fiber_angle_sweep.py --out out/angle-sweep

Writes OUT/curves.png (RVE curves and the fitted model), OUT/sweep.csv (every angle's response) and
OUT/material.toml (the fitted [material] table). A 12² section and 8 steps per curve keep it to seconds;
raise --grid for converged numbers (BENCHMARKS.md "FFT RVE" gives the resolution error).
"""
import argparse
import math
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

import softhom  # noqa: E402

STRETCH, STEPS = 1.5, 8
REFERENCE_ANGLE = 45.0  # the model's fiber family; a cell at angle a is the model loaded at a - 45


def cell(angle, grid):
    return {
        "microstructure": {"shape": "circle", "arrangement": "square", "volume_fraction": 0.23, "radius": 0.2,
                           "fiber_angle_deg": angle, "grid": [grid, grid]},
        "phases": {"matrix": {"preset": "ecoflex"}, "fiber": {"preset": "glass"}},
        "load": {"type": "uniaxial", "stretch": STRETCH, "steps": STEPS},
        "solver": {"tolerance": 1e-6},
        "output": {"fields": "none"},
    }


def model_load(angle):
    # Turning the load direction by b about e3 puts the model's fibers (at 45°) at 45° + b in the load
    # frame (docs/model.md §7), so the model loaded at b = angle - 45 sees the cell's fiber angle.
    b = math.radians(angle - REFERENCE_ANGLE)
    return {"type": "uniaxial", "stretch": STRETCH, "steps": STEPS, "direction": [math.cos(b), math.sin(b), 0.0]}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="angle-sweep")
    parser.add_argument("--grid", type=int, default=12)
    parser.add_argument("--angles", type=float, nargs="+", default=[30.0, 45.0, 60.0])
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)

    curves = {}
    for angle in args.angles:
        response, summary = softhom.run_rve(cell(angle, args.grid))
        if summary["status"] != "completed":
            raise SystemExit(f"angle {angle}: {summary['error']}")
        curves[angle] = response
        print(f"fiber angle {angle:5.1f}°: P11 at λ = {STRETCH} is {response.P11.iloc[-1]:.5g} MPa "
              f"({summary['newton_iterations']} Newton iterations)")
    pd.concat([r.assign(fiber_angle_deg=a) for a, r in curves.items()]).to_csv(
        os.path.join(args.out, "sweep.csv"), index=False)

    calibration = {
        "model": {"G": {"value": 0.02, "min": 0.001, "max": 1.0}, "Jm": {"value": 12.0, "min": 2.0, "max": 100.0},
                  "K": 2000.0, "k1": {"value": 0.3, "min": 0.001, "max": 10.0},
                  "k2": {"value": 1.0, "min": 0.01, "max": 20.0}, "fiber_invariant": "full",
                  "fibers": [{"angle_deg": REFERENCE_ANGLE}]},
        "solver": {"starts": 2},
        "output": {"plot": False},
        "curves": [{"name": f"angle{a:g}", "x": "F11", "y": "P11", "load": model_load(a),
                    "data": (r.F11.to_numpy(), r.P11.to_numpy())} for a, r in curves.items()],
    }
    fit = softhom.calibrate(calibration)
    for p in fit.summary["parameters"]:
        if p["free"]:
            print(f"  {p['name']} = {p['value']:.5g}" + ("  (at bound)" if p["at_bound"] else ""))
    for c in fit.summary["curves"]:
        print(f"  {c['name']}: R² = {c['r2']:.5f}")
    with open(os.path.join(args.out, "material.toml"), "w", encoding="utf-8") as f:
        f.write(fit.material_toml)

    fig, ax = plt.subplots(figsize=(6, 4))
    for i, (angle, r) in enumerate(curves.items()):
        colour = f"C{i}"
        ax.plot(r.F11, r.P11, "o", color=colour, label=f"RVE, fibers at {angle:g}°")
        model = fit.comparison[fit.comparison.curve == f"angle{angle:g}"]
        ax.plot(model.x, model.model, "-", color=colour, label=f"fitted model, {angle:g}°")
    ax.set_xlabel("stretch F11 [1]")
    ax.set_ylabel("P11 [MPa]")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(args.out, "curves.png"), dpi=120)
    print(f"wrote {args.out}/curves.png, sweep.csv, material.toml")
    if not fit.success:
        raise SystemExit("calibration: no start converged")


if __name__ == "__main__":
    main()
