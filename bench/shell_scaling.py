#!/usr/bin/env python3
"""Time per Newton iteration of the shell against unknowns on the linear-solver routes (bench_shell_scaling,
one process per size and route) and its figure for BENCHMARKS.md "Thin shells".

    python3 bench/shell_scaling.py --bench build/bench/bench_shell_scaling --cells 80,256,450,816 \
        --routes cholmod,petsc --csv shell_scaling.csv --figure docs/figures/shell_scaling
    python3 bench/shell_scaling.py --csv shell_scaling.csv --figure docs/figures/shell_scaling   # figure only

Rows are appended to the CSV as they come (a size that runs out of time or memory leaves the others);
the figure (PNG and SVG) needs matplotlib.
"""
import argparse
import csv
import os
import subprocess

FIELDS = ["cells", "dofs", "route", "newton", "wall_per_iteration", "cpu_per_iteration", "assembly_per_iteration",
          "factorization", "solve_per_iteration", "factorizations", "krylov", "peak_gib", "setup", "description"]


def run(bench, cells, route, timeout):
    env = dict(os.environ, OMP_WAIT_POLICY="passive")
    out = subprocess.run(["nice", bench, str(cells), route], capture_output=True, text=True, timeout=timeout, env=env)
    line = [l for l in out.stdout.splitlines() if l and not l.startswith("#")][-1].split(" ", len(FIELDS) - 1)
    return dict(zip(FIELDS, line))


def draw(rows, stem):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for route, marker in (("cholmod", "o"), ("umfpack", "s"), ("petsc", "^")):
        mine = sorted((r for r in rows if r["route"] == route), key=lambda r: int(r["dofs"]))
        if not mine:
            continue
        dofs = [int(r["dofs"]) for r in mine]
        ax.loglog(dofs, [float(r["cpu_per_iteration"]) for r in mine], marker + "-", label=f"{route}: CPU per iteration")
        ax.loglog(dofs, [float(r["wall_per_iteration"]) for r in mine], marker + ":", label=f"{route}: wall per iteration (loaded)")
    ax.set_xlabel("free dofs [-]")
    ax.set_ylabel("time per Newton iteration [s]")
    ax.set_title("Shell sphere octant under follower pressure")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    for ext in ("png", "svg"):
        fig.savefig(f"{stem}.{ext}", dpi=120)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--bench", help="bench_shell_scaling (omit: draw the CSV only)")
    p.add_argument("--cells", default="80,256", help="cells per octant edge, comma separated (~1.5 cells² dofs)")
    p.add_argument("--routes", default="cholmod,petsc")
    p.add_argument("--timeout", type=float, default=3600.0, help="seconds per run")
    p.add_argument("--csv", required=True)
    p.add_argument("--figure", help="figure stem (writes STEM.png and STEM.svg)")
    a = p.parse_args()
    if a.bench:
        new = not os.path.exists(a.csv)
        with open(a.csv, "a", newline="") as f:
            w = csv.DictWriter(f, FIELDS)
            if new:
                w.writeheader()
            for cells in (int(c) for c in a.cells.split(",")):
                for route in a.routes.split(","):
                    try:
                        row = run(a.bench, cells, route, a.timeout)
                    except (subprocess.TimeoutExpired, IndexError) as e:
                        print(f"{cells} {route}: no result ({type(e).__name__})", flush=True)
                        continue
                    print(" ".join(row[k] for k in FIELDS), flush=True)
                    w.writerow(row)
                    f.flush()
    if a.figure:
        with open(a.csv, newline="") as f:
            draw(list(csv.DictReader(f)), a.figure)


if __name__ == "__main__":
    main()
