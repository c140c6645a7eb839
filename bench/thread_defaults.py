#!/usr/bin/env python3
"""Default threading against 1 and 2 threads, on an idle machine and beside a competing load.

Runs `softhom rve` (and optionally `softhom macro`, and `softhom.run_rve` from Python) with the default
thread count and with -j 1 / -j 2, each with the OpenMP environment cleared (no OMP_WAIT_POLICY,
GOMP_SPINCOUNT, OMP_NUM_THREADS: what a new user has), then the same beside LOAD busy loops that this
script starts itself. The measured program and the busy loops run at the same `nice` level, so they
compete as equals while other users of the machine are disturbed less. Prints the median wall time of
REPEATS runs per variant and, per case and load, the default's ratio to the best variant.

    python3 bench/thread_defaults.py --softhom build/apps/softhom [--load 2] [--repeats 3]
        [--grid 32 --grid 96] [--macro studies/scenes/macro_tube_plane_strain.toml] [--python build/python]
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
    ap.add_argument("--python", help="directory holding the built Python package (build/python)")
    ap.add_argument("--load", type=int, default=2, help="busy loops of the loaded runs (0: idle only)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--nice", type=int, default=10)
    ap.add_argument("--env", action="append", default=[], help="NAME=VALUE added to every measured run")
    args = ap.parse_args()
    extra = dict(e.split("=", 1) for e in args.env)
    env = clean_env(extra)
    with tempfile.TemporaryDirectory(prefix="softhom-threads-") as tmp:
        out = os.path.join(tmp, "out")
        cases = []
        for g in args.grid or [32]:
            scene = rve_scene(g, tmp)
            cases.append((f"rve {g}^2", lambda a, s=scene: [args.softhom, "rve", s, "--out", out, "-q"] + a, timed))
            if args.python:
                cases.append((f"python run_rve {g}^2",
                              lambda a, s=scene: python_cmd(args.python, s, int(a[1]) if a else None), timed_python))
        for m in args.macro:
            cases.append((f"macro {os.path.basename(m)}", lambda a, s=m: [args.softhom, "macro", s, "--out", out, "-q"] + a, timed))
        loads = [0] + ([args.load] if args.load > 0 else [])
        print(f"# {os.cpu_count()} CPUs; load average at start {os.getloadavg()}; medians of {args.repeats}; env {extra}")
        print(f"{'case':28} {'load':>4} " + " ".join(f"{v:>9}" for v, _ in VARIANTS) + "  default/best")
        for load in loads:
            procs = start_load(load, args.nice)
            try:
                for name, cmd, timer in cases:
                    med = {}
                    for label, a in VARIANTS:
                        med[label] = statistics.median(timer(cmd(a), env, args.nice) for _ in range(args.repeats))
                    ratio = med["default"] / min(med.values())
                    print(f"{name:28} {load:>4} " + " ".join(f"{med[v]:9.2f}" for v, _ in VARIANTS) + f"  {ratio:.2f}",
                          flush=True)
            finally:
                for p in procs:
                    p.kill()
                    p.wait()


if __name__ == "__main__":
    main()
