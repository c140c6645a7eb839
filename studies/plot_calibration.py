#!/usr/bin/env python3
"""Plots a `softhom calibrate` result: data vs fitted model, one panel per curve.

    python3 studies/plot_calibration.py DIR        # reads DIR/response.csv + DIR/summary.json, writes DIR/fit.png

response.csv columns: curve (the curve's name), index (into summary.json "curves"), x, data, model.
"""
import csv
import json
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


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
            title = f"{c['name']} ({c['role']})\nR² = {c['r2']:.4f}, NRMSE = {c['nrmse']:.2%}"
        else:
            title = f"{c['name']} ({c['role']})\nnot evaluable"
        ax.set_title(title, fontsize=9)
        ax.set_xlabel(c["x"])
        ax.set_ylabel(c["y"])
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    for k in range(n, nrows * cols):
        axes[k // cols][k % cols].axis("off")
    free = [p for p in summary["parameters"] if p["free"]]
    text = ",  ".join(
        f"{p['name']} = {p['value']:.4g}" + (f" ± {p['std_error']:.2g}" if p.get("std_error") is not None else "")
        for p in free)
    fig.suptitle(text, fontsize=9)
    fig.tight_layout()
    path = os.path.join(out, "fit.png")
    fig.savefig(path, dpi=120)
    print(path)


if __name__ == "__main__":
    main()
