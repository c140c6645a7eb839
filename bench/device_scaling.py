#!/usr/bin/python3
"""Cost of a device scene versus its number of dofs on the direct (CHOLMOD) and the PETSc path.

Runs `softhom macro` on a gmsh device scene (default studies/devices/cpasmo_gent_fine.toml) at several
mesh sizes, each run a separate process under /usr/bin/time -v (peak RSS is per process), and prints per
run: free dofs, Newton and Krylov iterations, CPU and wall time per Newton iteration, peak RSS and bytes
per dof. Then the fitted growth exponents (least squares of log cost on log dofs, per path) and the
model of a larger run on many ranks (--model-dofs, --model-ranks) from those fits.

    /usr/bin/python3 bench/device_scaling.py --softhom build/apps/softhom --sizes 2 1 0.5 \
        --solvers cholmod petsc --pressure 0.001 --steps 1

--pressure P --steps N replace the load path by a ramp to P MPa in N steps (the first load step of the
scene's ramp is enough for costs per Newton iteration). The PETSc options are the scene's
`[solver] petsc_options` unless --options is given. CHOLMOD runs below --direct-min-size are skipped:
bench_device_direct predicts their factor from the symbolic analysis.
"""
import argparse
import json
import math
import os
import re
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def scene_text(path, mesh_size, solver, options, pressure, steps):
    """The scene with [geometry] mesh_size, [load] and [solver] replaced; a relative geo made absolute."""
    base = os.path.dirname(os.path.abspath(path))
    out, section, solver_written = [], "", False
    for line in open(path, encoding="utf-8"):
        s = line.strip()
        if s.startswith("["):
            section = s.strip("[]")
            if section == "solver":
                continue
        if section == "solver":
            m = re.match(r"petsc_options\s*=\s*\"(.*)\"", s)
            if m and options is None:
                options = m.group(1)
            continue
        if section == "geometry" and s.startswith("geo "):
            geo = re.search(r"\"(.*?)\"", s).group(1)
            line = 'geo = "%s"\n' % os.path.normpath(os.path.join(base, geo))
        if section == "geometry" and s.startswith("mesh_size") and mesh_size:
            line = "mesh_size = %r\n" % mesh_size
        if section == "load" and pressure is not None and s.startswith("path"):
            line = "path = [[0.0, 0.0], [1.0, %r]]\n" % pressure
        if section == "load" and steps and s.startswith("steps"):
            line = "steps = %d\n" % steps
        out.append(line)
    out.append('[solver]\nlinear_solver = "%s"\n' % solver)
    if solver == "petsc" and options:
        out.append('petsc_options = "%s"\n' % options)
    return "".join(out)


def time_v(text, key):
    m = re.search(re.escape(key) + r".*?:\s*(\S+)\s*$", text, re.M)
    return m.group(1) if m else None


def wall_seconds(s):
    parts = [float(p) for p in s.split(":")]
    return sum(p * 60 ** i for i, p in enumerate(reversed(parts)))


def run(args, h, solver, workdir):
    scene = os.path.join(workdir, "scene_%s_h%s.toml" % (solver, h))
    with open(scene, "w", encoding="utf-8") as f:
        f.write(scene_text(args.scene, h, solver, args.options, args.pressure, args.steps))
    out = os.path.join(workdir, "out_%s_h%s" % (solver, h))
    env = dict(os.environ, OMP_NUM_THREADS=str(args.threads), OMP_WAIT_POLICY="passive")
    env.setdefault("SOFTHOM_MESH_CACHE", os.path.join(workdir, "mesh"))
    cmd = ["/usr/bin/time", "-v", args.softhom, "macro", scene, "--out", out, "-q"]
    p = subprocess.run(cmd, env=env, capture_output=True, text=True)
    summary = os.path.join(out, "summary.json")
    if not os.path.exists(summary):
        sys.stderr.write(p.stderr[-2000:])
        return None
    s = json.load(open(summary, encoding="utf-8"))
    cpu = float(time_v(p.stderr, "User time (seconds)")) + float(time_v(p.stderr, "System time (seconds)"))
    row = {
        "h": h, "solver": solver, "dofs": s["dofs"], "elements": s["elements"], "status": s["status"],
        "newton": s["newton_iterations"], "krylov": s["krylov_iterations"], "factorizations": s["factorizations"],
        "cpu_s": cpu, "wall_s": wall_seconds(time_v(p.stderr, "Elapsed (wall clock) time (h:mm:ss or m:ss)")),
        "rss_bytes": 1024.0 * float(time_v(p.stderr, "Maximum resident set size (kbytes)")),
        "assembly_s": s["assembly_time_s"], "setup_s": s["factorization_time_s"], "solve_s": s["solve_time_s"],
        "max_height_mm": s.get("device", {}).get("final", {}).get("max_height_mm"),
        "device_final": s.get("device", {}).get("final", {}),
    }
    return row


def fit(rows, key):
    """Exponent and prefactor of key ≈ c · dofs^a (least squares in logs); None below two sizes."""
    if len(rows) < 2:
        return None
    x = np.log([r["dofs"] for r in rows])
    y = np.log([key(r) for r in rows])
    a, b = np.polyfit(x, y, 1)
    return a, math.exp(b)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--softhom", default=os.path.join(ROOT, "build", "apps", "softhom"))
    ap.add_argument("--scene", default=os.path.join(ROOT, "studies", "devices", "cpasmo_gent_fine.toml"))
    ap.add_argument("--sizes", type=float, nargs="+", default=[2.0, 1.0, 0.5])
    ap.add_argument("--solvers", nargs="+", default=["cholmod", "petsc"], choices=["cholmod", "petsc"])
    ap.add_argument("--options", default=None, help="PETSc options (default: the scene's petsc_options)")
    ap.add_argument("--pressure", type=float, default=None, help="ramp to this pressure [MPa] instead of the scene's path")
    ap.add_argument("--steps", type=int, default=None)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--direct-min-size", type=float, default=0.5,
                    help="no CHOLMOD run below this mesh_size (cPASMO 0.3: 6.5e5 dofs, a 9.8 GiB factor)")
    ap.add_argument("--model-dofs", type=float, default=1e7)
    ap.add_argument("--model-ranks", type=int, default=64)
    ap.add_argument("--workdir", default=None)
    ap.add_argument("--json", default=None, help="also write the rows to this file")
    args = ap.parse_args()
    workdir = args.workdir or tempfile.mkdtemp(prefix="device-scaling-")
    os.makedirs(workdir, exist_ok=True)
    print("# %s, load average %s" % (os.path.basename(args.scene), open("/proc/loadavg").read().split()[:3]))
    print("# %6s %-7s %8s %8s %7s %7s %9s %10s %10s %9s %8s %9s" % ("h", "solver", "dofs", "elems", "newton", "kry/N",
          "CPU_s", "CPU_s/N", "wall_s/N", "peak_MiB", "kB/dof", "height_mm"))
    rows = []
    for h in args.sizes:
        for solver in args.solvers:
            if solver == "cholmod" and h < args.direct_min_size:
                print("  %6g %-7s skipped (mesh_size < --direct-min-size)" % (h, solver))
                continue
            r = run(args, h, solver, workdir)
            if r is None:
                print("  %6g %-7s failed" % (h, solver))
                continue
            rows.append(r)
            n = max(1, r["newton"])
            print("  %6g %-7s %8d %8d %7d %7.1f %9.1f %10.3f %10.3f %9.0f %8.2f %9.5f %s" % (
                h, solver, r["dofs"], r["elements"], r["newton"], r["krylov"] / n, r["cpu_s"], r["cpu_s"] / n,
                r["wall_s"] / n, r["rss_bytes"] / 2 ** 20, r["rss_bytes"] / r["dofs"] / 1e3, r["max_height_mm"] or 0.0,
                "" if r["status"] == "completed" else r["status"]), flush=True)
    if args.json:
        json.dump(rows, open(args.json, "w"), indent=1)
    print("# fits cost ≈ c · dofs^a over the sizes run (CPU time per Newton iteration, peak RSS)")
    for solver in args.solvers:
        rs = [r for r in rows if r["solver"] == solver and r["status"] == "completed"]
        ft = fit(rs, lambda r: r["cpu_s"] / max(1, r["newton"]))
        fm = fit(rs, lambda r: r["rss_bytes"])
        if not ft:
            continue
        print("  %-7s time/Newton a = %.2f   peak memory a = %.2f   (%d sizes)" % (solver, ft[0], fm[0], len(rs)))
        N, P = args.model_dofs, args.model_ranks
        t1, m1 = ft[1] * N ** ft[0], fm[1] * N ** fm[0]
        print("  %-7s at %.3g dofs, one process: %.3g s CPU per Newton iteration, %.3g GiB; on %d ranks with perfect "
              "distribution: %.3g s, %.3g GiB per rank" % (solver, N, t1, m1 / 2 ** 30, P, t1 / P, m1 / P / 2 ** 30))


if __name__ == "__main__":
    main()
