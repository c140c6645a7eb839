#!/usr/bin/env python3
"""Fault tests: softhom under a full disk, a read-only output directory, SIGTERM, kill -9 and resume,
two sweeps on one output directory, and named files that are no regular files (FIFOs, devices,
directories, a symbolic link as the lock), out-of-range thread counts and an empty --out.

    faults.py --softhom BIN --work DIR TEST

TEST is one of the names in TESTS. Exit 0: passed; 1: failed (the reasons on stderr); 77: skipped (the
test needs root to mount a tmpfs, or the mount failed).

The contract checked everywhere: no signal, no temporary (`.NAME.tmp-PID`) left in --out, every output
file that exists is complete (JSON parses, CSV rows have the header's width, HDF5 opens), and no nan/inf.
"""
import argparse
import contextlib
import json
import os
import re
import resource
import shutil
import signal
import subprocess
import sys
import threading
import time
import tomllib
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "corpus"))
import tomlwrite  # noqa: E402

SKIP = 77
TEMPORARY = re.compile(r"\.tmp-\d+$|\.tmp$")
NONFINITE = re.compile(r"(?<![A-Za-z_])[-+]?(nan|inf|infinity)(?![A-Za-z_])", re.I)
ENV = dict(os.environ, OMP_NUM_THREADS="1", OMP_WAIT_POLICY="passive")
# Seconds a run may take to stop after SIGTERM: one solver step of these small cells takes well under a
# second; the rest is writing the converged rows.
STOP_SECONDS = 20


class Failed(Exception):
    pass


def check(cond, msg):
    if not cond:
        raise Failed(msg)


class Run:
    """softhom in the background, its stderr collected by a thread (progress lines end in \\r)."""

    def __init__(self, softhom, args):
        self.p = subprocess.Popen([str(softhom)] + [str(a) for a in args], stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, env=ENV, start_new_session=True)
        self.err = b""
        self.out = b""
        self._t = [threading.Thread(target=self._read, args=("err", self.p.stderr)),
                   threading.Thread(target=self._read, args=("out", self.p.stdout))]
        for t in self._t:
            t.start()

    def _read(self, which, pipe):
        for chunk in iter(lambda: pipe.read1(4096), b""):
            setattr(self, which, getattr(self, which) + chunk)

    def stderr(self):
        return self.err.decode(errors="replace")

    def wait_for(self, pattern, seconds):
        """True once stderr matches `pattern`; False if the process ends or time runs out first."""
        t0 = time.monotonic()
        while time.monotonic() - t0 < seconds:
            if re.search(pattern, self.stderr()):
                return True
            if self.p.poll() is not None:
                return bool(re.search(pattern, self.stderr()))
            time.sleep(0.05)
        return False

    def wait(self, seconds):
        try:
            rc = self.p.wait(timeout=seconds)
        except subprocess.TimeoutExpired:
            os.killpg(self.p.pid, signal.SIGKILL)
            self.p.wait()
            for t in self._t:
                t.join()
            raise Failed("no exit within %g s; stderr: %s" % (seconds, tail(self.stderr())))
        for t in self._t:
            t.join()
        return rc


def tail(text, n=400):
    text = text.replace("\r", "\n").strip()
    return text[-n:]


def run(softhom, args, seconds=120):
    r = Run(softhom, args)
    return r.wait(seconds), r.stderr()


def check_outputs(out):
    """Every file in --out complete, no temporary, no nan/inf."""
    if not out.exists():
        return
    for p in sorted(out.rglob("*")):
        if not p.is_file():
            continue
        check(not TEMPORARY.search(p.name), "temporary left in --out: %s" % p)
        if p.suffix == ".json":
            text = p.read_text(errors="replace")
            try:
                json.loads(text)
            except ValueError as e:
                raise Failed("%s is not complete JSON (%s)" % (p, e))
            check(not NONFINITE.search(text), "nan/inf in %s" % p)
        elif p.suffix == ".csv":
            lines = p.read_text(errors="replace").splitlines()
            if lines:
                width = lines[0].count(",")
                bad = [i for i, l in enumerate(lines) if l.count(",") != width]
                check(not bad, "%s: rows %s do not have the header's %d columns (half-written?)" % (p, bad[:5], width + 1))
            m = NONFINITE.search("\n".join(lines[1:]))
            check(not m, "nan/inf in %s" % p)
        elif p.suffix == ".h5" and shutil.which("h5ls"):
            r = subprocess.run(["h5ls", "-r", str(p)], capture_output=True, text=True)
            check(r.returncode == 0, "%s does not open as HDF5: %s" % (p, r.stderr.strip()[:200]))


def check_exit(rc, stderr, allowed=(1, 2)):
    check(rc >= 0, "killed by signal %s; stderr: %s" % (signal.Signals(-rc).name if rc < 0 else rc, tail(stderr)))
    check(rc in allowed, "exit %d, expected one of %s; stderr: %s" % (rc, allowed, tail(stderr)))


def data_rows(csv):
    check(csv.is_file(), "%s missing: the converged rows must be kept" % csv)
    return len(csv.read_text().splitlines()) - 1


# --- inputs -----------------------------------------------------------------------------------------------
def scene_variant(src, dst, **changes):
    """A copy of one of the TOML files next to this script with some values changed ("load.steps")."""
    doc = tomllib.loads((HERE / src).read_text())
    for dotted, v in changes.items():
        node = doc
        *parents, last = dotted.split("__")
        for k in parents:
            node = node.setdefault(k, {})
        node[last] = v
    dst.write_text(tomlwrite.dumps(doc))
    return dst


@contextlib.contextmanager
def tmpfs(where, options):
    """A tmpfs mounted at `where` (root only); raises Skip when it cannot be mounted."""
    if os.geteuid() != 0:
        raise Skip("not root: cannot mount a tmpfs")
    where.mkdir(parents=True, exist_ok=True)
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(where)], capture_output=True, text=True)
    if r.returncode != 0:
        raise Skip("mount -t tmpfs failed: %s" % r.stderr.strip())
    try:
        yield where
    finally:
        subprocess.run(["umount", "-l", str(where)], capture_output=True)


class Skip(Exception):
    pass


def fill(mount, leave_bytes):
    """Fills a mounted file system up to `leave_bytes` free."""
    st = os.statvfs(mount)
    free = st.f_bavail * st.f_frsize
    if free > leave_bytes:
        with open(mount / "filler", "wb") as f:
            f.write(b"\0" * (free - leave_bytes))


# --- the tests --------------------------------------------------------------------------------------------
def full_disk(softhom, work, sub):
    """A 1 MB tmpfs as --out, nearly full: the write fails; the run must say so and leave no temporary
    and no half-written file."""
    if sub == "rve":
        inp = scene_variant("rve_small.toml", work / "scene.toml", load__steps=20)
    else:
        inp = HERE / "campaign_small.toml"
    with tmpfs(work / "mnt", "size=1m") as mnt:
        fill(mnt, 24 * 1024)
        out = mnt / "out"
        rc, err = run(softhom, [sub, inp, "--out", out, "--threads", 1] + (["--jobs", 1] if sub == "sweep" else []))
        check_exit(rc, err)
        check(re.search(r"space|ENOSPC|write|%s" % re.escape(str(mnt)), err, re.I),
              "the error does not say that writing failed or where: %s" % tail(err))
        check_outputs(out)


def read_only(softhom, work, sub):
    """--out on a read-only file system (root ignores permissions, a ro mount it does not)."""
    inp = scene_variant("rve_small.toml", work / "scene.toml", load__steps=4) if sub == "rve" \
        else HERE / "campaign_small.toml"
    with tmpfs(work / "ro", "ro,size=1m") as mnt:
        for out in (mnt, mnt / "sub"):
            t0 = time.monotonic()
            rc, err = run(softhom, [sub, inp, "--out", out, "--threads", 1], seconds=60)
            check_exit(rc, err)
            check(str(out) in err or "read-only" in err.lower(),
                  "the error names neither the directory %s nor the cause: %s" % (out, tail(err)))


def sigterm_rve(softhom, work):
    inp = scene_variant("rve_small.toml", work / "scene.toml", load__steps=4000, output__fields="none")
    out = work / "out"
    r = Run(softhom, ["rve", inp, "--out", out, "--threads", 1])
    check(r.wait_for(r"t = 0\.0[1-9]", 60), "the run ended or showed no progress: %s" % tail(r.stderr()))
    r.p.send_signal(signal.SIGTERM)
    rc = r.wait(STOP_SECONDS)
    check_exit(rc, r.stderr(), allowed=(128 + signal.SIGTERM,))  # interrupted by signal N: 128 + N
    check(data_rows(out / "response.csv") >= 2, "fewer than two converged rows kept")
    check("interrupt" in (out / "summary.json").read_text().lower() if (out / "summary.json").is_file() else False,
          "summary.json missing or does not say the run was interrupted")
    check_outputs(out)


def sigterm_sweep(softhom, work):
    out = work / "out"
    r = Run(softhom, ["sweep", HERE / "campaign_small.toml", "--out", out, "--threads", 1, "--jobs", 1])
    check(r.wait_for(r"\[sweep\] \S+: ok", 60), "no case finished: %s" % tail(r.stderr()))
    r.p.send_signal(signal.SIGTERM)
    rc = r.wait(STOP_SECONDS)
    check_exit(rc, r.stderr(), allowed=(128 + signal.SIGTERM,))  # interrupted by signal N: 128 + N
    check(data_rows(out / "cases.csv") >= 1, "the finished case's rows are not in cases.csv")
    check((out / "summary.json").is_file() and "interrupt" in (out / "summary.json").read_text().lower(),
          "summary.json missing or does not say the sweep was interrupted")
    check_outputs(out)


def store_values(store):
    """Every dataset of a campaign store as h5dump prints it with 17 digits (the exact doubles)."""
    check(shutil.which("h5ls") and shutil.which("h5dump"), "h5ls/h5dump missing (scripts/install-deps.sh)")
    r = subprocess.run(["h5ls", "-r", str(store)], capture_output=True, text=True, check=True)
    datasets = sorted(l.split()[0] for l in r.stdout.splitlines() if "Dataset" in l)
    check(datasets, "no dataset in %s" % store)
    values = {}
    for d in datasets:
        r = subprocess.run(["h5dump", "-d", d, "-m", "%.17g", "--noindex", str(store)], capture_output=True,
                           text=True, check=True)
        values[d] = r.stdout.split("DATA {", 1)[-1]
    return values


def kill9_resume(softhom, work):
    """kill -9 in the middle of a sweep, then the same command again: the store must equal an
    uninterrupted run's, value for value (resume is bitwise with one thread per job)."""
    camp = HERE / "campaign_small.toml"
    ref, out = work / "reference", work / "out"
    rc, err = run(softhom, ["sweep", camp, "--out", ref, "--threads", 1, "--jobs", 1])
    check_exit(rc, err, allowed=(0,))
    r = Run(softhom, ["sweep", camp, "--out", out, "--threads", 1, "--jobs", 1])
    check(r.wait_for(r"\[sweep\] \S+: ok(.|\n)*\[sweep\] \S+: ok", 60), "two cases did not finish: %s" % tail(r.stderr()))
    os.killpg(r.p.pid, signal.SIGKILL)
    r.wait(10)
    # Whether the kill hit a store write is chance; make it certain: a kill -9 during the write leaves
    # exactly this, a partial temporary named after the dead process, which the rerun must not keep.
    if not any(TEMPORARY.search(p.name) for p in out.iterdir()):
        (out / (".campaign.h5.tmp-%d" % r.p.pid)).write_bytes(b"\x89HDF\r\n\x1a\n" + b"\0" * 100)
    rc, err = run(softhom, ["sweep", camp, "--out", out, "--threads", 1, "--jobs", 1])
    check_exit(rc, err, allowed=(0,))
    check(re.search(r"skipped [1-9]", err), "the rerun skipped no stored case: %s" % tail(err))
    a, b = (ref / "cases.csv").read_text(), (out / "cases.csv").read_text()
    check(a == b, "cases.csv after kill -9 and resume differs from the uninterrupted run's")
    va, vb = store_values(ref / "campaign.h5"), store_values(out / "campaign.h5")
    check(sorted(va) == sorted(vb), "datasets differ: %s vs %s" % (sorted(va), sorted(vb)))
    diff = [d for d in va if va[d] != vb[d]]
    check(not diff, "dataset values differ after resume: %s" % diff[:5])
    check_outputs(out)


def kill9_resume_rve(softhom, work):
    """kill -9 in the middle of an RVE run, then --resume: the response must equal an uninterrupted
    run's byte for byte (one thread), the checkpoint is gone afterwards, and a plain rerun into the
    stopped run's --out is refused (exit 2 naming --resume) instead of overwriting what converged."""
    # 400 steps (≈ 3 s on one thread): the first checkpoint comes after 1 s of run.
    inp = scene_variant("rve_small.toml", work / "scene.toml", load__steps=400, output__fields="none")
    ref, out = work / "reference", work / "out"
    rc, err = run(softhom, ["rve", inp, "--out", ref, "--threads", 1])
    check_exit(rc, err, allowed=(0,))
    r = Run(softhom, ["rve", inp, "--out", out, "--threads", 1])
    check(r.wait_for(r"t = 0\.[6-9]", 60), "the run ended or showed no progress: %s" % tail(r.stderr()))
    os.killpg(r.p.pid, signal.SIGKILL)
    r.wait(10)
    check((out / "checkpoint.json").is_file(), "no checkpoint.json after kill -9 past t = 0.6")
    saved_t = json.loads((out / "checkpoint.json").read_text())["t"]
    check(0.0 < saved_t < 1.0, "checkpoint at t = %r" % saved_t)
    # A kill -9 during a state write leaves a temporary named after the dead process: make it certain.
    (out / "checkpoint" / (".step9999-rank0.h5.tmp-%d" % r.p.pid)).write_bytes(b"\x89HDF\r\n\x1a\n" + b"\0" * 100)
    rc, err = run(softhom, ["rve", inp, "--out", out, "--threads", 1])
    check_exit(rc, err, allowed=(2,))
    check("--resume" in err, "a rerun into a stopped run's --out does not point to --resume: %s" % tail(err))
    # A damaged record (a hand edit, another tool): exit 2 naming it, nothing run.
    record = (out / "checkpoint.json").read_text()
    for damaged in ("[1, 2", '{"format": "one"}'):
        (out / "checkpoint.json").write_text(damaged)
        rc, err = run(softhom, ["rve", inp, "--out", out, "--threads", 1, "--resume"])
        check_exit(rc, err, allowed=(2,))
        check("checkpoint.json" in err, "a damaged record is not named: %s" % tail(err))
    (out / "checkpoint.json").write_text(record)
    rc, err = run(softhom, ["rve", inp, "--out", out, "--threads", 1, "--resume"])
    check_exit(rc, err, allowed=(0,))
    a, b = (ref / "response.csv").read_text(), (out / "response.csv").read_text()
    check(a == b, "response.csv after kill -9 and --resume differs from the uninterrupted run's")
    sa, sb = json.loads((ref / "summary.json").read_text()), json.loads((out / "summary.json").read_text())
    for k in ("newton_iterations", "krylov_iterations", "cutbacks"):
        check(sa[k] == sb[k], "summary %s: %s uninterrupted, %s resumed" % (k, sa[k], sb[k]))
    check(len(sb["steps"]) == len(sa["steps"]), "summary step log: %d entries, expected %d" % (len(sb["steps"]), len(sa["steps"])))
    check(sb.get("resumed", {}).get("from_t") == saved_t, "summary.json does not say where the run resumed")
    check(not (out / "checkpoint.json").exists() and not (out / "checkpoint").exists(), "checkpoint left after completion")
    check_outputs(out)


def sbatch_rve_resume(softhom, work):
    """scripts/softhom-rve.sbatch submitted three times (srun replaced by a shim that runs the command):
    stopped by SIGTERM after two steps, continued to the uninterrupted rows, then left alone."""
    script = HERE.parent.parent / "scripts" / "softhom-rve.sbatch"
    inp = scene_variant("rve_small.toml", work / "scene.toml", load__steps=6, output__fields="none")
    ref, out = work / "reference", work / "out"
    rc, err = run(softhom, ["rve", inp, "--out", ref, "--threads", 1])
    check_exit(rc, err, allowed=(0,))
    shim = work / "bin"
    shim.mkdir()
    (shim / "srun").write_text('#!/bin/sh\nexec "$@"\n')
    (shim / "srun").chmod(0o755)
    env = dict(ENV, SOFTHOM=str(softhom), PATH=str(shim) + os.pathsep + ENV.get("PATH", ""))

    def submit(extra):
        p = subprocess.run(["bash", str(script), str(inp), str(out)], env=dict(env, **extra), capture_output=True,
                           text=True, timeout=120)
        return p.returncode, p.stdout + p.stderr

    rc, log = submit({"SOFTHOM_TEST_SIGTERM_AFTER_STEPS": "2"})
    check(rc == 128 + signal.SIGTERM, "first submission: exit %d, expected 143: %s" % (rc, tail(log)))
    check((out / "checkpoint.json").is_file(), "first submission left no checkpoint")
    rc, log = submit({})
    check(rc == 0, "second submission: exit %d: %s" % (rc, tail(log)))
    check((ref / "response.csv").read_text() == (out / "response.csv").read_text(),
          "the resubmitted run's response.csv differs from the uninterrupted run's")
    before = (out / "summary.json").read_text()
    rc, log = submit({})
    check(rc == 0 and "nothing to do" in log, "third submission: exit %d: %s" % (rc, tail(log)))
    check((out / "summary.json").read_text() == before, "the third submission rewrote the completed run")
    check_outputs(out)


def concurrent_sweeps(softhom, work):
    """A second sweep on the same --out while the first runs: refused at once, naming the directory and
    the first one's pid; the first finishes with every case stored."""
    camp = HERE / "campaign_small.toml"
    out = work / "out"
    first = Run(softhom, ["sweep", camp, "--out", out, "--threads", 1, "--jobs", 1])
    check(first.wait_for(r"\[sweep\]", 60), "the first sweep shows no progress: %s" % tail(first.stderr()))
    t0 = time.monotonic()
    rc, err = run(softhom, ["sweep", camp, "--out", out, "--threads", 1, "--jobs", 1], seconds=60)
    seconds = time.monotonic() - t0
    still_running = first.p.poll() is None
    rc1 = first.wait(120)
    check(still_running, "the first sweep ended before the second was refused: make the campaign longer")
    check(rc != 0 and rc > 0, "the second sweep was not refused (exit %d): %s" % (rc, tail(err)))
    check(seconds < 5, "the second sweep took %.1f s to be refused (expected at once)" % seconds)
    check(str(out) in err or out.name in err, "the refusal does not name the directory %s: %s" % (out, tail(err)))
    check(str(first.p.pid) in err, "the refusal does not name the running sweep's pid %d: %s" % (first.p.pid, tail(err)))
    check_exit(rc1, first.stderr(), allowed=(0,))
    ids = {l.split(",")[0] for l in (out / "cases.csv").read_text().splitlines()[1:]}
    check(len(ids) == 6, "%d of 6 cases in cases.csv after both runs" % len(ids))
    check_outputs(out)


# --- files a scene names, thread counts, --out --------------------------------------------------------------
def limit_memory():
    """3 GiB of address space, as the corpus gives each case: reading /dev/zero whole (12 GB before) ends
    in an allocation failure instead of taking the machine's memory."""
    resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30))


def refused(softhom, args, names, env=None, seconds=STOP_SECONDS):
    """softhom refuses at once: exit 2 (no signal, no hang), stderr naming one of `names` and no
    internal message (a C++ library's text reaching the user)."""
    p = subprocess.Popen([str(softhom)] + [str(a) for a in args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         env=dict(ENV, **(env or {})), start_new_session=True, preexec_fn=limit_memory)
    try:
        _, err = p.communicate(timeout=seconds)
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        p.communicate()
        raise Failed("%s: no exit within %g s (blocked on a FIFO or reading a device?)" % (args, seconds))
    err = err.decode(errors="replace")
    check_exit(p.returncode, err, allowed=(2,))
    # The largest peak of the children so far: every earlier one here is a small run, so a larger peak
    # is this one's (a refusal needs a few MB; reading the file whole took GB).
    peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    check(peak_mb < 1024, "%s: %.0f MB resident before the refusal: the file was read" % (args, peak_mb))
    check(any(n in err for n in names), "%s: the message names none of %s: %s" % (args, names, tail(err)))
    check(not re.search(r"basic_|filesystem error|std::", err), "%s: an internal message: %s" % (args, tail(err)))


def special_files(work):
    """A FIFO, a directory, a device and a text file with a NUL byte, as named files."""
    fifo, directory, nul = work / "fifo", work / "a-directory", work / "nul.csv"
    os.mkfifo(fifo)
    directory.mkdir()
    nul.write_text("x,y\n1,\x002\n2,3\n")
    return {"FIFO": fifo, "directory": directory, "device": Path("/dev/zero"), "NUL byte": nul}


def named_files(softhom, work):
    special = special_files(work)
    # [[curves]] file: a FIFO blocked, /dev/zero took 12 GB, a NUL gave "basic_string::substr".
    cal = tomllib.loads((HERE.parents[1] / "studies/calibrations/example_point.toml").read_text())
    for what, f in special.items():
        cal["curves"][0]["file"] = str(f)
        scene = work / ("calibration-%s.toml" % what.replace(" ", "-"))
        scene.write_text(tomlwrite.dumps(cal))
        refused(softhom, ["calibrate", scene, "--out", work / "out-cal"], ["curves[0].file"])
    # base_scene: /dev/zero or a directory was silently ignored.
    camp = tomllib.loads((HERE / "campaign_small.toml").read_text())
    del camp["base"]
    for what, f in special.items():
        camp["base_scene"] = str(f)
        scene = work / ("campaign-%s.toml" % what.replace(" ", "-"))
        scene.write_text(tomlwrite.dumps(camp))
        refused(softhom, ["sweep", scene, "--out", work / "out-sweep", "--dry-run"], ["base_scene"])
    # [geometry] file of a macro scene: /dev/zero took 12.5 GB.
    macro = (HERE.parents[1] / "studies/scenes/macro_gmsh_tube.toml").read_text()
    for what, f in special.items():
        scene = work / "geometry.toml"
        scene.write_text(re.sub(r'(?m)^file *=.*$', 'file = "%s"' % f, macro))
        # A .msh may be binary: a NUL byte reaches the mesh reader, whose message names the file and line.
        refused(softhom, ["macro", scene, "--out", work / "out-macro"], ["geometry.file", "%s:1" % f])
    # [microstructure.image] file
    for what, f in special.items():
        scene = scene_variant("rve_small.toml", work / "image.toml", microstructure__image={"file": str(f), "dataset": "phase"})
        refused(softhom, ["rve", scene, "--out", work / "out-image"], ["microstructure.image.file", "image"])
    # checkpoint.json on --resume: a FIFO blocked, a directory gave "basic_filebuf::underflow".
    for what in ("FIFO", "directory"):
        out = work / ("out-resume-" + what)
        out.mkdir()
        os.mkfifo(out / "checkpoint.json") if what == "FIFO" else (out / "checkpoint.json").mkdir()
        refused(softhom, ["rve", HERE / "rve_small.toml", "--out", out, "--resume"], ["--resume"])


def lock_symlink(softhom, work):
    """A symbolic link planted as campaign.lock is not followed: the sweep writes nothing outside --out."""
    outside = work / "outside.txt"
    outside.write_text("untouched\n")
    out = work / "out"
    out.mkdir()
    (out / "campaign.lock").symlink_to(outside)
    refused(softhom, ["sweep", HERE / "campaign_small.toml", "--out", out, "--threads", 1, "--jobs", 1], ["campaign.lock"])
    check(outside.read_text() == "untouched\n", "the file the link points to was written: %r" % outside.read_text())


def thread_bounds(softhom, work):
    """OMP_NUM_THREADS is bounded like --threads (100000 crashed the thread start), and --out "" is refused
    (it wrote into the current directory or printed "filesystem error ... []")."""
    refused(softhom, ["rve", HERE / "rve_small.toml", "--out", work / "out"], ["OMP_NUM_THREADS"],
            env={"OMP_NUM_THREADS": "100000"})
    with contextlib.chdir(work):  # where an accepted --out "" would write
        for sub in ("point", "rve", "macro", "demo"):
            refused(softhom, [sub, "--out", ""], ["--out"])
        refused(softhom, ["sweep", HERE / "campaign_small.toml", "--out", ""], ["--out"])
        check(sorted(p.name for p in work.iterdir()) == [], "files written into the current directory: %s"
              % sorted(p.name for p in work.iterdir()))


def scene_reach(softhom, work):
    """A shared scene cannot write outside --out: PETSc viewers pointed at a file (-ksp_view ascii:F
    replaced F with a dump) and a .geo that runs a shell command (System "touch F") are refused before
    anything runs, naming the key, and F stays as it was."""
    victim = work / "victim.txt"
    victim.write_text("untouched\n")
    macro = (HERE.parents[1] / "studies/scenes/macro_balloon.toml").read_text()
    for option in ("-ksp_view ascii:%s" % victim, "-log_view :%s" % victim, "-viewer_binary_filename %s" % victim,
                   "-totally_unknown_option 5", "-ksp_rtol -1"):
        scene = work / "petsc.toml"
        scene.write_text(macro + '\n[solver]\nlinear_solver = "petsc"\npetsc_options = "%s"\n' % option)
        refused(softhom, ["macro", scene, "--out", work / "out-petsc"], ["solver.petsc_options"])
    pwned = work / "pwned"
    geo = work / "box.geo"
    geo.write_text('System "touch %s";\nSetFactory("OpenCASCADE");\nBox(1) = {0, 0, 0, 1, 1, 1};\n'
                   'Physical Volume("body") = {1};\n' % pwned)
    device = (HERE.parents[1] / "studies/devices/cpasmo_gent_coarse.toml").read_text()
    scene = work / "geo.toml"
    scene.write_text(re.sub(r'(?m)^geo *=.*$', 'geo = "%s"' % geo, device))
    refused(softhom, ["macro", scene, "--out", work / "out-geo"], ["geometry.geo"])
    check(not pwned.exists(), "the .geo's System command ran")
    check(victim.read_text() == "untouched\n", "the victim file was written")


def sigterm_calibrate(softhom, work):
    """SIGTERM during calibrate: exit 143, summary.json "status": "interrupted" and "success": false, and
    material.toml says its parameters are the best so far, not a fit (it exited 0 with success true)."""
    for f in ("example_point.toml", "data"):
        src = HERE.parents[1] / "studies/calibrations" / f
        (shutil.copytree if src.is_dir() else shutil.copy)(src, work / f)
    out = work / "out"
    r = Run(softhom, ["calibrate", work / "example_point.toml", "--out", out, "--threads", 1])
    check(r.wait_for(r"start 0: cost", 120), "no start finished: %s" % tail(r.stderr()))
    r.p.send_signal(signal.SIGTERM)
    rc = r.wait(STOP_SECONDS)
    check_exit(rc, r.stderr(), allowed=(128 + signal.SIGTERM,))
    summary = json.loads((out / "summary.json").read_text())
    check(summary.get("status") == "interrupted" and summary.get("success") is False,
          "summary.json: status %r, success %r" % (summary.get("status"), summary.get("success")))
    check("interrupted" in (out / "material.toml").read_text(), "material.toml does not say it was interrupted")
    check("Traceback" not in r.stderr(), "the plot of an unfinished fit was attempted: %s" % tail(r.stderr()))
    check_outputs(out)


TESTS = {
    "full-disk-rve": lambda s, w: full_disk(s, w, "rve"),
    "full-disk-sweep": lambda s, w: full_disk(s, w, "sweep"),
    "read-only-rve": lambda s, w: read_only(s, w, "rve"),
    "read-only-sweep": lambda s, w: read_only(s, w, "sweep"),
    "sigterm-rve": sigterm_rve,
    "sigterm-sweep": sigterm_sweep,
    "kill9-resume": kill9_resume,
    "kill9-resume-rve": kill9_resume_rve,
    "sbatch-rve-resume": sbatch_rve_resume,
    "concurrent-sweeps": concurrent_sweeps,
    "named-files": named_files,
    "lock-symlink": lock_symlink,
    "thread-bounds": thread_bounds,
    "sigterm-calibrate": sigterm_calibrate,
    "scene-reach": scene_reach,
}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--softhom", type=Path, required=True)
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("test", choices=sorted(TESTS))
    a = ap.parse_args()
    work = a.work.resolve() / a.test
    if work.exists():
        for m in sorted(work.rglob("*"), reverse=True):  # a mount left by a killed earlier run
            if m.is_dir() and os.path.ismount(m):
                subprocess.run(["umount", "-l", str(m)], capture_output=True)
        shutil.rmtree(work)
    work.mkdir(parents=True)
    try:
        TESTS[a.test](a.softhom.resolve(), work)
    except Skip as e:
        print("SKIPPED %s: %s" % (a.test, e))
        return SKIP
    except Failed as e:
        print("FAILED %s: %s" % (a.test, e), file=sys.stderr)
        return 1
    print("PASSED %s" % a.test)
    return 0


if __name__ == "__main__":
    sys.exit(main())
