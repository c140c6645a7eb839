#!/usr/bin/env python3
"""Default threading against 1 and 2 threads, on an idle machine and beside a competing load.

Runs `softhom rve` (and optionally `softhom macro`, and `softhom.run_rve` from Python) with the default
thread count and with -j 1 / -j 2, each with the OpenMP environment cleared (no OMP_WAIT_POLICY,
GOMP_SPINCOUNT, OMP_NUM_THREADS: what a new user has), then the same beside LOAD busy loops that this
script starts itself. The measured program and the busy loops run at the same `nice` level, so they
compete as equals while other users of the machine are disturbed less. Prints the median wall time of
REPEATS runs per variant and, per case and load, the default's ratio to the best variant.

    python3 bench/thread_defaults.py --softhom build/apps/softhom [--load 2] [--repeats 3]
        [--grid 32 --grid 96 | --grid 0] [--macro studies/scenes/macro_tube_plane_strain.toml]
        [--tube-cells 32x128] [--python build/python] [--variants "-j 1" "-j 2"]

Every case runs once untimed first (a gmsh scene meshes into its --out cache then); the variants run
interleaved. Each line ends with the 1-minute load average before and after it: the machine may be shared.
"""
from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time

SOURCE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CLEARED = ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT", "OMP_NUM_THREADS", "OMP_DYNAMIC", "SOFTHOM_REEXEC")
# The interpreter that has numpy and pandas as Debian installs them.
PYTHON = "/usr/bin/python3" if os.path.exists("/usr/bin/python3") else sys.executable
VARIANTS = [("default", []), ("-j 1", ["-j", "1"]), ("-j 2", ["-j", "2"])]


def clean_env(extra: dict | None = None) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in CLEARED}
    env.update(extra or {})
    return env


def rve_scene(grid: int, directory: str) -> str:
    """rve_ecoflex_circ45.toml with its cross-section grid set to grid²."""
    with open(os.path.join(SOURCE, "studies/scenes/rve_ecoflex_circ45.toml"), encoding="utf-8") as f:
        text = re.sub(r"grid = \[32, 32\]", f"grid = [{grid}, {grid}]", f.read())
    path = os.path.join(directory, f"rve_{grid}.toml")
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)
    return path


def tube_scene(cells: str, directory: str) -> str:
    """macro_tube_plane_strain.toml with RADIALxCIRCUMFERENTIAL cells (8x32 shipped: 1 152 free dofs)."""
    radial, circumferential = (int(c) for c in cells.split("x"))
    with open(os.path.join(SOURCE, "studies/scenes/macro_tube_plane_strain.toml"), encoding="utf-8") as f:
        text = re.sub(r"radial_cells = 8\b", f"radial_cells = {radial}", f.read())
    text = re.sub(r"circumferential_cells = 32\b", f"circumferential_cells = {circumferential}", text)
    path = os.path.join(directory, f"macro_tube_{cells}.toml")
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)
    return path


def timed(cmd: list[str], env: dict, nice: int) -> float:
    start = time.perf_counter()
    r = subprocess.run(["nice", "-n", str(nice)] + cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    seconds = time.perf_counter() - start
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)} exited {r.returncode}: {r.stderr.decode()[-400:]}")
    return seconds


def python_cmd(python_dir: str, scene: str, threads: int | None) -> list[str]:
    """The Python run_rve, timed inside the interpreter (import excluded) and printed; -c returns it."""
    code = (f"import sys,time; sys.path.insert(0, {python_dir!r}); import softhom; t=time.perf_counter(); "
            f"softhom.run_rve(__import__('pathlib').Path({scene!r}), threads={threads!r}); "
            f"sys.stderr.write('SECONDS %r' % (time.perf_counter()-t))")
    return [PYTHON, "-c", code]


def timed_python(cmd: list[str], env: dict, nice: int) -> float:
    r = subprocess.run(["nice", "-n", str(nice)] + cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    m = re.search(r"SECONDS ([0-9.e-]+)", r.stderr.decode())
    if r.returncode != 0 or not m:
        sys.exit(f"python run_rve exited {r.returncode}: {r.stderr.decode()[-400:]}")
    return float(m.group(1))


def start_load(n: int, nice: int) -> list[subprocess.Popen]:
    return [subprocess.Popen(["nice", "-n", str(nice), "sh", "-c", "while :; do :; done"]) for _ in range(n)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--softhom", default="build/apps/softhom")
    ap.add_argument("--grid", type=int, action="append", help="rve cross-section grid sizes (default 32)")
    ap.add_argument("--macro", action="append", default=[], help="macro scenes to time as well")
    ap.add_argument("--tube-cells", action="append", default=[],
                    help="the plane-strain tube with RxC cells (e.g. 32x128) as a further macro case")
    ap.add_argument("--python", help="directory holding the built Python package (build/python)")
    ap.add_argument("--load", type=int, default=2, help="busy loops of the loaded runs (0: idle only)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--nice", type=int, default=10)
    ap.add_argument("--env", action="append", default=[], help="NAME=VALUE added to every measured run")
    ap.add_argument("--variants", nargs="+", default=[v for v, _ in VARIANTS], help="a subset of: default, '-j 1', '-j 2'")
    args = ap.parse_args()
    extra = dict(e.split("=", 1) for e in args.env)
    variants = [(label, a) for label, a in VARIANTS if label in args.variants]
    env = clean_env(extra)
    with tempfile.TemporaryDirectory(prefix="softhom-threads-") as tmp:
        def out(case: str) -> str:  # one --out per subcommand and scene (another's results are refused)
            return os.path.join(tmp, "out-" + re.sub(r"[^A-Za-z0-9_.]+", "-", case))
        cases = []
        for g in args.grid or [32]:
            scene = rve_scene(g, tmp)
            if g == 0:  # --grid 0: no RVE case
                continue
            cases.append((f"rve {g}^2", lambda a, s=scene, o=out(f"rve{g}"): [args.softhom, "rve", s, "--out", o, "-q"] + a, timed))
            if args.python:
                cases.append((f"python run_rve {g}^2",
                              lambda a, s=scene: python_cmd(args.python, s, int(a[1]) if a else None), timed_python))
        macros = [(os.path.basename(m), m) for m in args.macro]
        macros += [(f"tube {c}", tube_scene(c, tmp)) for c in args.tube_cells]
        for name, m in macros:
            cases.append((f"macro {name}", lambda a, s=m, o=out(name): [args.softhom, "macro", s, "--out", o, "-q"] + a, timed))
        loads = [0] + ([args.load] if args.load > 0 else [])
        print(f"# {os.cpu_count()} CPUs; load average at start {os.getloadavg()}; medians of {args.repeats}; env {extra}")
        print(f"{'case':28} {'load':>4} " + " ".join(f"{v:>9}" for v, _ in variants) + "  default/best  loadavg")
        for load in loads:
            procs = start_load(load, args.nice)
            try:
                for name, cmd, timer in cases:
                    timer(cmd([]), env, args.nice)  # warm-up: caches (gmsh mesh, FFTW wisdom, page cache)
                    loadavg = os.getloadavg()[0]
                    # Variants interleaved, repeat by repeat: a load that changes over minutes (others' work
                    # on a shared machine) then weighs on every variant alike.
                    seconds = {label: [] for label, _ in variants}
                    for _ in range(args.repeats):
                        for label, a in variants:
                            seconds[label].append(timer(cmd(a), env, args.nice))
                    med = {label: statistics.median(s) for label, s in seconds.items()}
                    ratio = med["default"] / min(med.values()) if "default" in med else float("nan")
                    print(f"{name:28} {load:>4} " + " ".join(f"{med[v]:9.2f}" for v, _ in variants) +
                          f"  {ratio:12.2f}  {loadavg:.1f}-{os.getloadavg()[0]:.1f}", flush=True)
            finally:
                for p in procs:
                    p.kill()
                    p.wait()


if __name__ == "__main__":
    main()
