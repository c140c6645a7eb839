#!/usr/bin/env python3
"""Regenerates the example calibration data in this folder.

    python3 studies/calibrations/data/generate.py [path/to/softhom]

For every [[curves]] entry of the example calibration files it runs `softhom point` with the known
("true") material below and the curve's own [load] table, keeps a few columns of response.csv, and adds
1 % (of the curve's P11 range) seeded Gaussian noise to P11 (the fitted column; row t = 0 stays exact).
"""
import csv
import os
import subprocess
import sys
import tempfile

import tomllib

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ELASTIC = """[material]
law = "gent"
G = 0.02
Jm = 12
K = 2000
k1 = 0.1
k2 = 1.5
fiber_invariant = "full"
[[material.fibers]]
angle_deg = 45
"""
TRUTH = {
    "example_point.toml": ELASTIC,
    "example_qlv.toml": ELASTIC + "[material.viscoelastic]\ng_inf = 0.5\ntau = 5.0\n",
}
KEEP = ["t", "F11", "F22", "P11", "P22", "sigma11", "fiber1_angle_deg"]
NOISE = 0.01


def toml_value(v):
    if isinstance(v, str):
        return '"' + v + '"'
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    return repr(v)


def main():
    softhom = sys.argv[1] if len(sys.argv) > 1 else "softhom"
    rng = np.random.default_rng(20240611)
    for example, material in TRUTH.items():
        with open(os.path.join(HERE, "..", example), "rb") as f:
            cal = tomllib.load(f)
        for curve in cal["curves"]:
            with tempfile.TemporaryDirectory() as tmp:
                scene = os.path.join(tmp, "scene.toml")
                with open(scene, "w") as f:
                    f.write(material + "\n[load]\n")
                    f.writelines(f"{k} = {toml_value(v)}\n" for k, v in curve["load"].items())
                subprocess.run([softhom, "point", scene, "--out", tmp, "--quiet"], check=True)
                with open(os.path.join(tmp, "response.csv")) as f:
                    rows = list(csv.DictReader(f))
            p11 = np.array([float(r["P11"]) for r in rows])
            noisy = p11 + NOISE * (p11.max() - p11.min()) * rng.standard_normal(len(p11))
            noisy[0] = p11[0]
            out = os.path.join(HERE, os.path.basename(curve["file"]))
            with open(out, "w") as f:
                f.write(f"# softhom point, {example} curve '{curve['name']}': true material of data/generate.py,\n")
                f.write(f"# {NOISE:.0%} Gaussian noise (of the P11 range) on P11\n")
                f.write(",".join(KEEP) + "\n")
                for r, p in zip(rows, noisy):
                    vals = [float(r[k]) if k != "P11" else p for k in KEEP]
                    f.write(",".join(repr(v) for v in vals) + "\n")
            print(out, len(rows), "rows")


if __name__ == "__main__":
    main()
