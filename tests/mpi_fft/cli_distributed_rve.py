#!/usr/bin/env python3
"""`softhom rve` on a 3D cell under `mpirun -n 2` against the one-process run: one fields.h5 with the
same datasets (every step, every field, to 1e-10 relative: the distributed solve differs only in the
order of floating-point sums, see tests/mpi_fft/test_distributed_fft_cell.cpp), the same response.csv,
summary.json with "ranks": 2 from rank 0 alone, the phase image held per rank as a slab (plus halo
planes) and the achieved volume fraction reduced over the ranks; and the clear error (exit 2 naming microstructure.grid
and the rank count) for a section grid or fewer planes i3 than ranks. A 2-rank run stopped after its
first step continues with --resume on 2 ranks to the uninterrupted 2-rank response.csv, byte for byte;
a 1-process resume of its checkpoint is refused, and so is a resume with one rank's state file
missing (exit 2 on both ranks, none left waiting).

usage: cli_distributed_rve.py --softhom BIN --mpiexec MPIEXEC --work DIR
"""
import argparse
import csv
import json
import os
import shutil
import subprocess
import sys

import h5py
import numpy as np

SCENE = """description = "distributed FFT cell test: circle fiber, 10 x 8 x 7 voxels"
[microstructure]
shape = "circle"
arrangement = "square"
volume_fraction = 0.23
radius = 0.2
fiber_angle_deg = 60
grid = {grid}
[phases.matrix]
law = "neo-hookean"
mu = 0.5
K = 5.0
[phases.fiber]
law = "neo-hookean"
mu = 5.0
K = 40.0
[load]
type = "uniaxial"
stretch = 1.1
duration = 1.0
steps = 2
[solver]
discretization = "rotated"
tolerance = 1e-7
fftw = "estimate"
[output]
fields = "all"
"""


def run(cmd, env):
    p = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)
    return p.returncode, p.stdout, p.stderr


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--softhom", required=True)
    ap.add_argument("--mpiexec", required=True)
    ap.add_argument("--work", required=True)
    a = ap.parse_args()
    shutil.rmtree(a.work, ignore_errors=True)
    os.makedirs(a.work)
    env = dict(os.environ, OMP_NUM_THREADS="1")
    mpi = [a.mpiexec, "-n", "2", "--allow-run-as-root", "--oversubscribe"]
    failures = []

    scene = os.path.join(a.work, "cell.toml")
    with open(scene, "w") as f:
        f.write(SCENE.format(grid="[10, 8, 7]"))
    one, two = os.path.join(a.work, "one"), os.path.join(a.work, "two")
    rc, _, err = run([a.softhom, "rve", scene, "--out", one], env)
    if rc != 0:
        sys.exit("one-process run failed: " + err)
    rc, _, err = run(mpi + [a.softhom, "rve", scene, "--out", two], env)
    if rc != 0:
        sys.exit("mpirun -n 2 run failed: " + err)

    with h5py.File(os.path.join(one, "fields.h5"), "r") as f1, h5py.File(os.path.join(two, "fields.h5"), "r") as f2:
        steps = sorted(k for k in f1.keys() if k.startswith("step_"))
        if steps != sorted(k for k in f2.keys() if k.startswith("step_")) or not steps:
            failures.append("steps differ: %s vs %s" % (list(f1.keys()), list(f2.keys())))
        for s in steps:
            for name in f1[s].keys():
                x, y = np.asarray(f1[s][name]), np.asarray(f2[s][name])
                if x.shape != y.shape:
                    failures.append("%s/%s: shape %s vs %s" % (s, name, x.shape, y.shape))
                    continue
                scale = max(np.abs(x).max(), 1e-300)
                d = np.abs(x - y).max() / scale
                print("%s/%-15s %-18s max rel difference %.2e" % (s, name, x.shape, d))
                if not d <= 1e-10:
                    failures.append("%s/%s differs by %.3e relative" % (s, name, d))
                if name in f1[s] and dict(f1[s][name].attrs) != dict(f2[s][name].attrs):
                    failures.append("%s/%s: attributes differ" % (s, name))
    for ext in ("xdmf",):
        if not os.path.exists(os.path.join(two, "fields." + ext)):
            failures.append("no fields.%s from the distributed run" % ext)

    def rows(d):
        with open(os.path.join(d, "response.csv")) as f:
            r = list(csv.reader(f))
        return r[0], np.array([[float(v) for v in row] for row in r[1:]])

    h1, r1 = rows(one)
    h2, r2 = rows(two)
    if h1 != h2 or r1.shape != r2.shape:
        failures.append("response.csv columns/rows differ")
    else:
        counts = [i for i, c in enumerate(h1) if c.endswith("_iterations") or c == "substeps"]
        if not np.array_equal(r1[:, counts], r2[:, counts]):
            failures.append("response.csv iteration counts differ")
        skip = counts + [i for i, c in enumerate(h1) if "wall" in c or c.endswith("_s")]
        keep = [i for i in range(len(h1)) if i not in skip]
        d = np.abs(r1[:, keep] - r2[:, keep]).max() / max(np.abs(r1[:, keep]).max(), 1e-300)
        print("response.csv max rel difference %.2e" % d)
        if not d <= 1e-10:
            failures.append("response.csv differs by %.3e" % d)
    s1 = json.load(open(os.path.join(one, "summary.json")))
    s2 = json.load(open(os.path.join(two, "summary.json")))
    if s1.get("ranks") != 1 or s2.get("ranks") != 2:
        failures.append("summary ranks: %s / %s" % (s1.get("ranks"), s2.get("ranks")))
    for k in ("newton_iterations", "krylov_iterations"):
        if s1[k] != s2[k]:
            failures.append("summary %s: %s vs %s" % (k, s1[k], s2[k]))
    # The phase image as a rank holds it: whole on one process; on 2 ranks the largest slab (⌈7/2⌉ = 4
    # planes) and one halo plane each side, 32 B per voxel (fraction + normal). Exact byte counts: a
    # rank holding the whole image shows 7 planes.
    plane = 10 * 8 * 32
    if s1.get("phase_image_bytes_per_rank") != 7 * plane or s2.get("phase_image_bytes_per_rank") != (4 + 2) * plane:
        failures.append("phase image bytes per rank: %s (one process, expected %d) / %s (2 ranks, expected %d)" % (
            s1.get("phase_image_bytes_per_rank"), 7 * plane, s2.get("phase_image_bytes_per_rank"), 6 * plane))
    if abs(s1["volume_fraction_achieved"] - s2["volume_fraction_achieved"]) > 1e-14:
        failures.append("achieved volume fraction: %r vs %r" % (s1["volume_fraction_achieved"], s2["volume_fraction_achieved"]))
    print("Newton / Krylov: %s / %s (one process), %s / %s (2 ranks)" % (
        s1["newton_iterations"], s1["krylov_iterations"], s2["newton_iterations"], s2["krylov_iterations"]))

    # A 2-rank run stopped after its first step (SIGTERM) continues with --resume on 2 ranks: the same
    # response.csv byte for byte as the uninterrupted 2-rank run (one thread per rank); on 1 process the
    # resume is refused, naming the 2 processes that wrote the checkpoint.
    part = os.path.join(a.work, "resumed")
    rc, _, err = run(mpi + ["-x", "SOFTHOM_TEST_SIGTERM_AFTER_STEPS=1", a.softhom, "rve", scene, "--out", part], env)
    record = os.path.join(part, "checkpoint.json")
    if rc == 0 or not os.path.exists(record) or json.load(open(record)).get("ranks") != 2:
        failures.append("stopped 2-rank run: exit %d, checkpoint.json %s; stderr %r" % (
            rc, "present" if os.path.exists(record) else "missing", err[-400:]))
    # One rank's state file missing: both ranks stop with exit 2 (none left waiting), naming the file.
    broken = os.path.join(a.work, "broken")
    shutil.copytree(part, broken)
    lost = os.path.join(broken, "checkpoint", "step1-rank1.h5")
    if os.path.exists(lost):
        os.remove(lost)
    rc, _, err = run(mpi + [a.softhom, "rve", scene, "--out", broken, "--resume"], env)
    print("resume with a rank's state file missing: exit %d" % rc)
    if rc != 2 or "step1-rank1.h5" not in err:
        failures.append("resume with a missing state file: exit %d, stderr %r" % (rc, err[-400:]))
    rc, _, err = run([a.softhom, "rve", scene, "--out", part, "--resume"], env)
    print("resume of a 2-rank checkpoint on 1 process: exit %d" % rc)
    if rc != 2 or "--resume" not in err or "2 processes" not in err:
        failures.append("1-process resume of a 2-rank checkpoint: exit %d, stderr %r" % (rc, err[-400:]))
    rc, _, err = run(mpi + [a.softhom, "rve", scene, "--out", part, "--resume"], env)
    print("resume on 2 ranks: exit %d" % rc)
    if rc != 0:
        failures.append("2-rank resume: exit %d, stderr %r" % (rc, err[-400:]))
    else:
        same = open(os.path.join(two, "response.csv")).read() == open(os.path.join(part, "response.csv")).read()
        print("resumed response.csv equal to the uninterrupted run's: %s" % same)
        if not same:
            failures.append("the resumed 2-rank response.csv differs from the uninterrupted 2-rank run's")
        if os.path.exists(record) or os.path.exists(os.path.join(part, "checkpoint")):
            failures.append("checkpoint left after the resumed run completed")
        if not os.path.exists(os.path.join(part, "fields_resumed_1.xdmf")):
            failures.append("the resumed run's fields are not in fields_resumed_1.xdmf: %s" % os.listdir(part))

    # Clear errors: a section grid, and fewer planes than ranks.
    for grid, ranks in (("[10, 8]", 2), ("[10, 8, 2]", 3)):
        bad = os.path.join(a.work, "bad.toml")
        with open(bad, "w") as f:
            f.write(SCENE.format(grid=grid))
        cmd = [a.mpiexec, "-n", str(ranks), "--allow-run-as-root", "--oversubscribe", a.softhom, "rve", bad, "--out",
               os.path.join(a.work, "bad")]
        rc, out, err = run(cmd, env)
        ok = rc == 2 and "microstructure.grid" in err and ("%d ranks" % ranks) in err
        print("grid %s on %d ranks: exit %d" % (grid, ranks, rc))
        if not ok:
            failures.append("grid %s on %d ranks: exit %d, stderr %r" % (grid, ranks, rc, err[-400:]))

    if failures:
        print("\n".join("FAIL: " + f for f in failures))
        print("0 passed, %d failed" % len(failures))
        sys.exit(1)
    print("1 passed, 0 failed")


if __name__ == "__main__":
    main()
