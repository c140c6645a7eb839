#!/usr/bin/env python3
"""Cost of the Python module over the program: Material.evaluate per point (numpy in and out) and
run_rve against `softhom rve` on the same scene, one thread each.

    PYTHONPATH=build/python OMP_NUM_THREADS=1 /usr/bin/python3 bench/python_module.py \
        --softhom build/apps/softhom [--repeat 3]

Prints medians of --repeat runs: ns per material point (with and without the 9x9 tangent), the
wall time of the RVE job in the module and as a subprocess, their ratio, and the largest difference
of the two responses (0: bitwise equal).
"""
import argparse
import os
import statistics
import subprocess
import tempfile
import time

import numpy as np
import pandas as pd

import softhom

SCENE = {
    "microstructure": {"shape": "circle", "arrangement": "square", "volume_fraction": 0.23, "radius": 0.2,
                       "fiber_angle_deg": 45, "grid": [32, 32]},
    "phases": {"matrix": {"preset": "ecoflex"}, "fiber": {"preset": "glass"}},
    "load": {"type": "uniaxial", "stretch": 1.5, "steps": 10},
    "solver": {"tolerance": 1e-6},
    "output": {"fields": "none"},
}


def median_time(fn, repeat):
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), result


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--softhom", default="build/apps/softhom")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--points", type=int, default=200_000)
    a = ap.parse_args()

    m = softhom.material({"preset": "ecoflex-anisotropic", "fiber_invariant": "full", "fibers": [{"angle_deg": 45}]})
    rng = np.random.default_rng(1)
    F = np.eye(3) + 0.1 * rng.standard_normal((a.points, 3, 3))
    for tangent in (False, True):
        t, _ = median_time(lambda: m.evaluate(F, tangent=tangent), a.repeat)
        print(f"evaluate {a.points} points, tangent={tangent}: {t * 1e9 / a.points:.0f} ns/point "
              f"(median of {a.repeat}, {os.environ.get('OMP_NUM_THREADS', 'all')} threads)")

    with tempfile.TemporaryDirectory() as d:
        scene = os.path.join(d, "cell.toml")
        with open(scene, "w") as f:
            f.write(softhom.to_toml(SCENE))
        cli = [a.softhom, "rve", scene, "--out", os.path.join(d, "cli"), "--threads", "1", "--quiet"]
        t_cli, _ = median_time(lambda: subprocess.run(cli, check=True), a.repeat)
        t_py, result = median_time(lambda: softhom.run_rve(SCENE, threads=1), a.repeat)
        expected = pd.read_csv(os.path.join(d, "cli", "response.csv"), float_precision="round_trip")
        diff = np.max(np.abs(result.response.to_numpy() - expected.to_numpy()))
    print(f"rve 32x32, 10 steps: module {t_py:.3f} s, program {t_cli:.3f} s, ratio {t_py / t_cli:.3f}, "
          f"max |difference| {diff:g} (median of {a.repeat})")


if __name__ == "__main__":
    main()
