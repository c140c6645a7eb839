#!/usr/bin/env python3
"""Plots a `softhom calibrate` result: data vs fitted model, one panel per curve.

    python3 studies/plot_calibration.py DIR        # reads DIR/response.csv + DIR/summary.json,
                                                   # writes DIR/fit.png (300 dpi) and DIR/fit.svg

response.csv columns: curve (the curve's name), index (into summary.json "curves"), x, data, model.
"""
import csv
import json
import math
import os
import re
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


# Axis labels of the response vocabulary (docs/outputs.md): name, symbol and unit.
QUANTITIES = {"F": ("stretch", "1"), "P": ("engineering stress", "MPa"), "sigma": ("Cauchy stress", "MPa"),
              "S": ("second Piola–Kirchhoff stress", "MPa"), "t": ("time", "s"), "J": ("volume ratio", "1")}
MATRICES = {"ecoflex": "Ecoflex", "pdms": "PDMS"}
LOADS = {"tension": "uniaxial tension", "compression": "uniaxial compression", "equibiaxial": "equibiaxial tension",
         "shear": "simple shear", "relaxation": "relaxation"}


def axis_label(column):
    """'P11' -> 'engineering stress P11 [MPa]'; an unknown column stays as it is."""
    m = re.fullmatch(r"([A-Za-z]+?)(\d*)", column)
    if m and m.group(1) in QUANTITIES:
        name, unit = QUANTITIES[m.group(1)]
        return "%s %s [%s]" % (name, column, unit)
    return column


def curve_title(name):
    """A campaign case id ('ecoflex-circle-a30-vf0.23-square-n24x24-tension') in words: 'Ecoflex, circular
    fibers at 30°, VF 0.23, uniaxial tension'; other names stay as they are."""
    m = re.fullmatch(r"([a-z0-9_]+)-(circle|ellipse|rectangle|square)-a([-0-9.e]+)-vf([0-9.e-]+)-[a-z]+-n[0-9x]+-([a-z]+)", name)
    if m:
        matrix = MATRICES.get(m.group(1).split("_")[0], m.group(1))
        shape = {"circle": "circular", "ellipse": "elliptical", "rectangle": "rectangular", "square": "square"}[m.group(2)]
        return "%s, %s fibers at %s°, VF %s, %s" % (matrix, shape, m.group(3), m.group(4), LOADS.get(m.group(5), m.group(5)))
    m = re.fullmatch(r"([a-z0-9_]+)-matrix-n[0-9x]+-([a-z]+)", name)
    if m:
        return "%s alone, %s" % (MATRICES.get(m.group(1).split("_")[0], m.group(1)), LOADS.get(m.group(2), m.group(2)))
    return name


def parameter_unit(name):
    """Moduli (G, K, E, k1, mu_i, C_i) in MPa; exponents, Jm, dispersion and times as they are."""
    if re.fullmatch(r"(G|K|E|k1|mu\d*|C\d+|g\d*)", name):
        return " MPa"
    if re.fullmatch(r"tau\d*", name):
        return " s"
    return ""


def save(fig, out, stem):
    """PNG at 300 dpi and SVG, each written whole under a temporary name first."""
    paths = []
    for ext, options in (("png", {"dpi": 300}), ("svg", {})):
        path = os.path.join(out, stem + "." + ext)
        tmp = path + ".tmp." + ext
        fig.savefig(tmp, **options)
        os.replace(tmp, path)
        paths.append(path)
    return paths


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    rows = {}
    with open(os.path.join(out, "response.csv")) as f:
        for r in csv.DictReader(f):
            rows.setdefault(int(r["index"]), []).append((float(r["x"]), float(r["data"]), float(r["model"])))
    curves = summary["curves"]
    n = len(curves)
    cols = min(3, n)
    nrows = math.ceil(n / cols)
    fig, axes = plt.subplots(nrows, cols, figsize=(4.2 * cols, 3.4 * nrows), squeeze=False)
    for k, c in enumerate(curves):
        ax = axes[k // cols][k % cols]
        pts = rows.get(c["index"], [])
        holdout = c["role"] == "holdout"
        if pts:
            x, d, m = zip(*pts)
            ax.plot(x, d, "o", ms=3.5, mfc="none", color="0.35", label="data")
            ax.plot(x, m, "-", lw=1.6, color="tab:orange" if holdout else "tab:blue",
                    label="prediction" if holdout else "fit")
            title = f"{curve_title(c['name'])}\n{c['role']}: R² = {c['r2']:.4f}, NRMSE = {c['nrmse']:.2%}"
        else:
            title = f"{curve_title(c['name'])}\n{c['role']}: not evaluable"
        ax.set_title(title, fontsize=8.5)
        ax.set_xlabel(axis_label(c["x"]))
        ax.set_ylabel(axis_label(c["y"]))
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    for k in range(n, nrows * cols):
        axes[k // cols][k % cols].axis("off")
    free = [p for p in summary["parameters"] if p["free"]]
    text = ",  ".join(
        f"{p['name']} = {p['value']:.4g}" + (f" ± {p['std_error']:.2g}" if p.get("std_error") is not None else "")
        + parameter_unit(p["name"]) for p in free)
    fig.suptitle(text, fontsize=9)
    fig.tight_layout()
    print(save(fig, out, "fit")[0])


if __name__ == "__main__":
    main()
