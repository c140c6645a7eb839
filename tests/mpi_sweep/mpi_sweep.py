#!/usr/bin/env python3
"""Campaigns over MPI: `mpirun -n 2 softhom sweep` against the one-process sweep.

    mpi_sweep.py --softhom BIN --mpirun MPIRUN --work DIR TEST

TEST is one of the names in TESTS. Exit 0: passed; 1: failed (the reasons on stderr).

The campaign is tests/faults/campaign_small.toml (six 16^2 cases). Every MPI run starts from the FFTW
wisdom of the one-process reference run (copied into its --out), so that both plan the same FFTs: with
one thread per rank the stores must then be equal value for value (h5dump with 17 digits, cases.csv
byte for byte), not just to a tolerance, since every case runs the same code with the same threads on
whichever rank it lands. The one-process reference is run once by the test `reference` (a ctest fixture
of the others) into WORK/reference/store, stamped with the program that made it; a test that finds no
reference of this program runs its own.
"""
import argparse
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "faults"))
import faults  # noqa: E402  (Run, check, store_values, check_outputs)

from faults import Failed, check, tail  # noqa: E402

CAMPAIGN = HERE.parent / "faults" / "campaign_small.toml"
CASES = 6
ENV = faults.ENV  # OMP_NUM_THREADS=1, passive OpenMP waits


def mpirun(a, ranks, *args):
    return [a.mpirun, "--allow-run-as-root", "--oversubscribe", "-n", str(ranks), a.softhom] + [str(x) for x in args]


def sweep_args(out, *extra):
    return ["sweep", CAMPAIGN, "--out", out, "--threads", 1, "--jobs", 1] + list(extra)


class Job(faults.Run):
    """A command (mpirun ... or softhom ...) in the background in its own session."""

    def __init__(self, argv):
        self.p = subprocess.Popen([str(x) for x in argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=ENV,
                                  start_new_session=True)
        self.err = b""
        self.out = b""
        self._t = [threading.Thread(target=self._read, args=("err", self.p.stderr)),
                   threading.Thread(target=self._read, args=("out", self.p.stdout))]
        for t in self._t:
            t.start()


def run(argv, seconds=120):
    j = Job(argv)
    rc = j.wait(seconds)
    return rc, j.stderr(), j.out.decode(errors="replace")


def binary_stamp(softhom):
    """What identifies the program that made a shared reference: a rebuilt binary makes it stale."""
    st = softhom.stat()
    return "%s %d %d" % (softhom, st.st_size, st.st_mtime_ns)


def shared_reference_dir(a):
    return a.work.resolve() / "reference" / "store"


def make_shared_reference(a, work):
    """The one-process sweep once for every test of this file (the ctest fixture mpi_sweep_reference),
    stamped with the program that made it."""
    ref = work / "store"
    rc, err, _ = run([a.softhom] + sweep_args(ref))
    faults.check_exit(rc, err, allowed=(0,))
    (ref / "made-by.txt").write_text(binary_stamp(a.softhom))


def reference(a, work):
    """The one-process sweep (no mpirun): the store every MPI run must reproduce. Read only: the shared
    one when this program made it, else run here."""
    shared = shared_reference_dir(a)
    stamp = shared / "made-by.txt"
    if stamp.is_file() and stamp.read_text() == binary_stamp(a.softhom):
        return shared
    ref = work / "reference"
    rc, err, _ = run([a.softhom] + sweep_args(ref))
    faults.check_exit(rc, err, allowed=(0,))
    return ref


def fresh_out(work, name, ref):
    out = work / name
    out.mkdir()
    shutil.copy(ref / "fftw.wisdom", out / "fftw.wisdom")
    return out


def check_same_store(ref, out):
    a, b = (ref / "cases.csv").read_bytes(), (out / "cases.csv").read_bytes()
    check(a == b, "cases.csv of %s differs from the one-process run's" % out.name)
    va, vb = faults.store_values(ref / "campaign.h5"), faults.store_values(out / "campaign.h5")
    check(sorted(va) == sorted(vb), "datasets differ: %s vs %s" % (sorted(va), sorted(vb)))
    diff = [d for d in va if va[d] != vb[d]]
    check(not diff, "dataset values differ from the one-process run's: %s" % diff[:5])
    faults.check_outputs(out)


def summary(out):
    return json.loads((out / "summary.json").read_text())


def rank_pids(job):
    """The pids of the softhom ranks mpirun started (its children on this host)."""
    r = subprocess.run(["pgrep", "-P", str(job.p.pid)], capture_output=True, text=True)
    return [int(x) for x in r.stdout.split()]


def wait_gone(pids, seconds=30):
    """Until every pid has ended (and been reaped: a zombie still counts as a live process to kill(pid, 0),
    which is how a resume decides that a temporary is stale)."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < seconds:
        if not any(Path("/proc/%d" % p).exists() for p in pids):
            return
        time.sleep(0.05)
    raise Failed("ranks %s still run %g s after the job was killed" % (pids, seconds))


def lock_holder(out):
    m = re.search(r"pid=(\d+)", (out / "campaign.lock").read_text())
    check(m, "campaign.lock names no pid")
    return int(m.group(1))


def two_ranks_equal_serial(a, work):
    """2 ranks: the same store as the one-process run; both ranks ran cases; rank 0 alone printed."""
    ref = reference(a, work)
    out = fresh_out(work, "mpi", ref)
    rc, err, _ = run(mpirun(a, 2, *sweep_args(out)))
    faults.check_exit(rc, err, allowed=(0,))
    check_same_store(ref, out)
    s = summary(out)
    check(s.get("mpi_ranks") == 2, "summary.json mpi_ranks = %s, expected 2" % s.get("mpi_ranks"))
    per_rank = s.get("cases_per_rank")
    check(per_rank and len(per_rank) == 2 and sum(per_rank) == CASES and min(per_rank) >= 1,
          "cases_per_rank %s: expected both ranks to run cases, %d in all" % (per_rank, CASES))
    check(len(re.findall(r"^softhom sweep: ", err, re.M)) == 1, "the final line is not printed once: %s" % tail(err))
    check(len(re.findall(r"^\[sweep\] \d+ cases:", err, re.M)) == 1, "the schedule line is not printed once")
    # A rerun on 2 ranks skips everything and leaves the store as it is.
    rc, err, _ = run(mpirun(a, 2, *sweep_args(out)))
    faults.check_exit(rc, err, allowed=(0,))
    check(re.search(r"%d already in the store, 0 to run" % CASES, err), "the rerun did not skip all: %s" % tail(err))
    check_same_store(ref, out)
    # --dry-run: rank 0 alone lists the cases.
    rc, err, text = run(mpirun(a, 2, *sweep_args(out, "--dry-run")))
    faults.check_exit(rc, err, allowed=(0,))
    check(text.count("%d cases" % CASES) == 1 and len(re.findall(r"  ok$", text, re.M)) == CASES,
          "--dry-run on 2 ranks did not list the %d cases once: %s" % (CASES, tail(text)))


def serial_then_two_ranks(a, camp, work):
    """The campaign in one process, then on 2 ranks from its FFTW wisdom: the same store. Returns both
    output directories."""
    ref, out = work / "reference", work / "mpi"
    args = lambda d: ["sweep", camp, "--out", d, "--threads", 1, "--jobs", 1]
    rc, err, _ = run([a.softhom] + args(ref))
    faults.check_exit(rc, err, allowed=(0,))
    out.mkdir()
    shutil.copy(ref / "fftw.wisdom", out / "fftw.wisdom")
    rc, err, _ = run(mpirun(a, 2, *args(out)))
    faults.check_exit(rc, err, allowed=(0,))
    check_same_store(ref, out)
    return ref, out


def warm_chains_equal_serial(a, work):
    """Warm-start chains (studies/campaigns/bench_levels.toml: 3 microstructures x 4 tension levels, each
    level's path on the next) stay on one rank: 2 ranks store what the one-process run stores, with the
    same warm starts and the same Newton iterations (a chain split over ranks would recompute its path)."""
    ref, out = serial_then_two_ranks(a, HERE.parent.parent / "studies" / "campaigns" / "bench_levels.toml", work)
    sr, so = summary(ref), summary(out)
    for k in ("warm_started", "newton_iterations"):
        check(sr[k] == so[k], "%s: %s on 2 ranks, %s in one process" % (k, so[k], sr[k]))
    check(sr["warm_started"] > 0, "the campaign has no warm start: the test checks nothing")


# FE-engine cases (a coarse section cell, a plate cell) beside an FFT case: every case's numbers are the
# one-process run's on whichever rank it lands.
FE_CAMPAIGN = """description = "FE and FFT cases over ranks"
[base.microstructure]
shape = "circle"
radius = 0.2
grid = [8, 8]
[base.phases.fiber]
preset = "glass"
[base.solver]
tolerance = 1e-8
[loads.pull]
type = "uniaxial"
stretch = 1.1
steps = 2
[loads.membrane]
type = "mixed"
F = [[1.1, 0.0, "free"], ["free", "free", "free"], [0.0, 0.0, "free"]]
path = 1.0
steps = 2
[[cases]]
name = "fe-section"
matrix = "pdms"
load = "pull"
override = {solver = {engine = "fe", mesh_size = 0.25, interface_size = 0.1}}
[[cases]]
name = "fe-plate"
matrix = "pdms"
load = "membrane"
override = {solver = {engine = "fe", mesh_size = 0.25, interface_size = 0.1}, microstructure = {cell = "plate"}}
[[cases]]
name = "fft"
matrix = "pdms"
load = "pull"
"""


def fe_cases_equal_serial(a, work):
    """FE cases (section and plate cells) and an FFT case on 2 ranks: the one-process store, both ranks
    ran cases, the FE records say so."""
    camp = work / "fe.toml"
    camp.write_text(FE_CAMPAIGN)
    _, out = serial_then_two_ranks(a, camp, work)
    per_rank = summary(out).get("cases_per_rank")
    check(per_rank and len(per_rank) == 2 and sum(per_rank) == 3 and min(per_rank) >= 1,
          "cases_per_rank %s: expected both ranks to run cases, 3 in all" % per_rank)
    index = (out / "cases.csv").read_text()
    check(index.count("fe-plate,ok,") == 3 and index.count("fe-section,ok,") == 3,
          "the FE cases are not stored ok with 3 rows each: %s" % index[:400])


def errors_from_rank0_only(a, work):
    """Bad input (exit 2) and a campaign directory held by another sweep (exit 1): one message, from
    rank 0, not one per rank."""
    bad = work / "bad.toml"
    bad.write_text('description = "bad"\n[[sweep]]\nmatrix = ["no-such-matrix"]\nload = ["tension"]\n')
    rc, err, _ = run(mpirun(a, 2, "sweep", bad, "--out", work / "bad-out"))
    check(rc == 2, "bad input on 2 ranks: exit %d, expected 2: %s" % (rc, tail(err)))
    check(len(re.findall(r"input error: .*no-such-matrix", err)) == 1,
          "the input error is not printed exactly once: %s" % tail(err, 1200))
    out = work / "busy"
    first = Job([a.softhom] + sweep_args(out))
    check(first.wait_for(r"\[sweep\]", 60), "the one-process sweep shows no progress: %s" % tail(first.stderr()))
    # Paused, the first sweep holds the lock however fast the machine is (no race with its end).
    os.kill(first.p.pid, signal.SIGSTOP)
    try:
        rc, err, _ = run(mpirun(a, 2, *sweep_args(out)), seconds=60)
        still_running = first.p.poll() is None
    finally:
        os.kill(first.p.pid, signal.SIGCONT)
    faults.check_exit(first.wait(120), first.stderr(), allowed=(0,))
    check(still_running, "the first sweep ended before the MPI one was refused")
    check(rc == 1, "a busy directory on 2 ranks: exit %d, expected 1: %s" % (rc, tail(err)))
    check(len(re.findall(r"in use by another softhom sweep", err)) == 1 and str(first.p.pid) in err,
          "the refusal is not printed once naming pid %d: %s" % (first.p.pid, tail(err, 1200)))


def wait_stored(job, n, seconds=60):
    pattern = r"(\[sweep\] \S+: ok(.|\n)*){%d}" % n
    check(job.wait_for(pattern, seconds), "%d cases were not stored: %s" % (n, tail(job.stderr())))


def kill9_rank_resume(a, work):
    """kill -9 of rank 1 mid-campaign: mpirun ends the job; the cases rank 0 stored survive; a resume
    on 2 ranks computes only the rest and the store equals the one-process run's."""
    ref = reference(a, work)
    out = fresh_out(work, "mpi", ref)
    job = Job(mpirun(a, 2, *sweep_args(out)))
    wait_stored(job, 2)
    writer = lock_holder(out)
    others = [p for p in rank_pids(job) if p != writer]
    check(len(others) == 1, "expected one rank besides rank 0 (pid %d), found %s" % (writer, others))
    ranks = rank_pids(job)
    os.kill(others[0], signal.SIGKILL)
    rc = job.wait(60)
    wait_gone(ranks)
    check(rc != 0, "mpirun exited 0 after a rank was killed")
    stored = len({l.split(",")[0] for l in (out / "cases.csv").read_text().splitlines()[1:]})
    check(2 <= stored < CASES, "%d cases stored when rank 1 was killed (expected 2 to %d)" % (stored, CASES - 1))
    rc, err, _ = run(mpirun(a, 2, *sweep_args(out)))
    faults.check_exit(rc, err, allowed=(0,))
    m = re.search(r"(\d+) already in the store", err)
    check(m and int(m.group(1)) >= 2, "the resume did not skip the stored cases: %s" % tail(err))
    check_same_store(ref, out)


def kill9_job_resume_serial(a, work):
    """kill -9 of the whole job (every rank and mpirun), then a one-process resume: equal store."""
    ref = reference(a, work)
    out = fresh_out(work, "mpi", ref)
    job = Job(mpirun(a, 2, *sweep_args(out)))
    wait_stored(job, 2)
    ranks = rank_pids(job)
    check(len(ranks) == 2, "expected 2 ranks under mpirun, found %s" % ranks)
    for p in ranks:
        os.kill(p, signal.SIGKILL)
    os.killpg(job.p.pid, signal.SIGKILL)
    job.wait(30)
    wait_gone(ranks)
    rc, err, _ = run([a.softhom] + sweep_args(out))
    faults.check_exit(rc, err, allowed=(0,))
    check(re.search(r"skipped [1-9]", err), "the resume skipped no stored case: %s" % tail(err))
    check_same_store(ref, out)


def sigterm_ranks(a, work):
    """SIGTERM to every rank (as Slurm's scancel sends it): rank 0 stops handing out work, stores what
    finished, exits 128 + 15; the summary says interrupted; a resume on 2 ranks completes the store."""
    ref = reference(a, work)
    out = fresh_out(work, "mpi", ref)
    job = Job(mpirun(a, 2, *sweep_args(out)))
    wait_stored(job, 1)
    for p in rank_pids(job):
        os.kill(p, signal.SIGTERM)
    rc = job.wait(faults.STOP_SECONDS)
    faults.check_exit(rc, job.stderr(), allowed=(128 + signal.SIGTERM,))
    check(summary(out).get("interrupted") is True, "summary.json does not say interrupted")
    faults.check_outputs(out)
    rc, err, _ = run(mpirun(a, 2, *sweep_args(out)))
    faults.check_exit(rc, err, allowed=(0,))
    check_same_store(ref, out)


TESTS = {
    "reference": make_shared_reference,
    "two-ranks-equal-serial": two_ranks_equal_serial,
    "warm-chains-equal-serial": warm_chains_equal_serial,
    "fe-cases-equal-serial": fe_cases_equal_serial,
    "errors-from-rank0-only": errors_from_rank0_only,
    "kill9-rank-resume": kill9_rank_resume,
    "kill9-job-resume-serial": kill9_job_resume_serial,
    "sigterm-ranks": sigterm_ranks,
}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--softhom", type=Path, required=True)
    ap.add_argument("--mpirun", required=True)
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("test", choices=sorted(TESTS))
    a = ap.parse_args()
    a.softhom = a.softhom.resolve()
    work = a.work.resolve() / a.test
    if work.exists():
        shutil.rmtree(work)
    work.mkdir(parents=True)
    t0 = time.monotonic()
    try:
        TESTS[a.test](a, work)
    except Failed as e:
        print("FAILED %s: %s" % (a.test, e), file=sys.stderr)
        return 1
    print("PASSED %s (%.1f s)" % (a.test, time.monotonic() - t0))
    return 0


if __name__ == "__main__":
    sys.exit(main())
