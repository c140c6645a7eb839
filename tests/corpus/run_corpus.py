#!/usr/bin/env python3
"""Runs softhom on every case of the bad-input corpus and checks the input contract.

    run_corpus.py --softhom BIN --source-dir SRC --work DIR [--jobs 2] [--timeout 6] [--report FILE]

Generates the cases (generate.py) into DIR/cases, runs each as
`softhom SUB input --out <case>/out --threads 1 [extra]` with a timeout, two at a time, and asserts for
each: the expected exit code; for exit 2 one of the expected field names in stderr; no signal, no
sanitizer report; no timeout; no nan/inf in any output CSV or JSON; no temporary (`.NAME.tmp-PID`) left
in --out. Prints a table by class and the failures; exits 1 when any case fails.
"""
import argparse
import concurrent.futures
import json
import os
import re
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
NONFINITE = re.compile(r"(?<![A-Za-z_])[-+]?(nan|inf|infinity)(?![A-Za-z_])", re.I)
TEMPORARY = re.compile(r"\.tmp-\d+$|\.tmp$")
# A number printed by std::to_string ("2.500000", "-1.000000") instead of as the user wrote it.
TO_STRING_NUMBER = re.compile(r"(?<![0-9.])-?[0-9]+\.[0-9]{6}(?![0-9])")
SANITIZER = re.compile(r"ERROR: AddressSanitizer|ERROR: LeakSanitizer|runtime error:|UndefinedBehaviorSanitizer")
# Per-process address-space limit: an absurd size must be refused, not allocated; without a limit an
# accepted one would take the machine's memory from everyone else.
ADDRESS_SPACE = 3 * 1024**3


def limit_resources(limit_memory):
    def apply():
        os.setsid()
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
        if limit_memory:
            resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE, ADDRESS_SPACE))
    return apply


def scan_outputs(out):
    """(temporaries left, files with nan/inf, files that are not valid JSON)."""
    left, nonfinite, broken = [], [], []
    if not out.exists():
        return left, nonfinite, broken
    for p in out.rglob("*"):
        if not p.is_file():
            continue
        if TEMPORARY.search(p.name):
            left.append(p.name)
            continue
        if p.suffix in (".csv", ".json"):
            text = p.read_text(errors="replace")
            m = NONFINITE.search(text)
            if m:
                nonfinite.append("%s: ...%s..." % (p.name, text[max(0, m.start() - 30):m.end() + 10].replace("\n", " ")))
            if p.suffix == ".json":
                try:
                    json.loads(text)
                except ValueError:
                    broken.append(p.name)
    return left, nonfinite, broken


def run_case(case_dir, softhom, timeout, limit_memory):
    meta = json.loads((case_dir / "case.json").read_text())
    out = case_dir / "out"
    cmd = [str(softhom), meta["subcommand"], str(case_dir / meta["input"]), "--out", str(out), "--threads", "1"] \
        + meta["extra"]
    # No calibration figure: the cases test the program's answers to bad input, and drawing (a second or
    # more of matplotlib) would take most of a case's time budget.
    env = dict(os.environ, OMP_NUM_THREADS="1", OMP_WAIT_POLICY="passive", SOFTHOM_PLOT_CALIBRATION="off")
    t0 = time.monotonic()
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, cwd=case_dir,
                         preexec_fn=limit_resources(limit_memory))
    try:
        stdout, stderr = p.communicate(timeout=max(timeout, meta.get("timeout") or 0))
        rc, hung = p.returncode, False
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        stdout, stderr = p.communicate()
        rc, hung = None, True
    seconds = time.monotonic() - t0
    err = stderr.decode(errors="replace")
    left, nonfinite, broken = scan_outputs(out)
    if hung:
        left = []  # killed by the runner with SIGKILL: a temporary is then unavoidable, the hang is the fault
    r = dict(meta, rc=rc, seconds=round(seconds, 2), stderr=err[-2000:], leftovers=left, nonfinite=nonfinite,
             broken_json=broken, cmd=" ".join(cmd))
    r["outcome"], r["why"] = classify(meta, rc, hung, err, out)
    return r


def classify(meta, rc, hung, err, out):
    expect = meta["expect_exit"]
    if hung:
        return "hang", "no exit within the timeout"
    if rc < 0:
        return "crash", "killed by signal %s" % signal.Signals(-rc).name
    if SANITIZER.search(err):
        return "crash", "sanitizer: " + SANITIZER.search(err).group(0)
    if rc not in (0, 1, 2):
        return "crash", "exit code %d" % rc
    if rc == 0 and 0 not in expect:
        return "accepted", "exit 0, expected %s" % expect
    if rc not in expect:
        return "wrong", "exit %d, expected %s" % (rc, expect)
    if rc == 2 and meta["fields"] and not any(f in err for f in meta["fields"]):
        return "unnamed", "exit 2 but stderr names none of %s" % meta["fields"]
    missing = [f for f in meta.get("expect_files", []) if rc == 1 and not (out / f).is_file()]
    if missing:
        return "wrong", "exit 1 without the converged rows (%s)" % ", ".join(missing)
    return "clear", ""


COLUMNS = ["cases", "clear", "wrong/unnamed", "crashes", "hangs", "accepted", "leftovers", "nan/inf"]


def tally(results):
    rows = {}
    for r in results:
        row = rows.setdefault(r["class"], dict.fromkeys(COLUMNS, 0))
        row["cases"] += 1
        o = r["outcome"]
        row[{"clear": "clear", "wrong": "wrong/unnamed", "unnamed": "wrong/unnamed", "crash": "crashes",
             "hang": "hangs", "accepted": "accepted"}[o]] += 1
        row["leftovers"] += bool(r["leftovers"] or r["broken_json"])
        row["nan/inf"] += bool(r["nonfinite"])
    total = dict.fromkeys(COLUMNS, 0)
    for row in rows.values():
        for c in COLUMNS:
            total[c] += row[c]
    return rows, total


def table(rows, total):
    w = max([len(k) for k in rows] + [5])
    lines = ["%-*s " % (w, "class") + " ".join("%13s" % c for c in COLUMNS)]
    for k in sorted(rows):
        lines.append("%-*s " % (w, k) + " ".join("%13d" % rows[k][c] for c in COLUMNS))
    lines.append("%-*s " % (w, "total") + " ".join("%13d" % total[c] for c in COLUMNS))
    return "\n".join(lines)


def failed(r):
    return r["outcome"] != "clear" or r["leftovers"] or r["nonfinite"] or r["broken_json"]


def describe(r):
    parts = [r["outcome"] + ": " + r["why"] if r["outcome"] != "clear" else "exit as expected"]
    if r["leftovers"]:
        parts.append("temporaries left: " + ", ".join(r["leftovers"]))
    if r["broken_json"]:
        parts.append("invalid JSON: " + ", ".join(r["broken_json"]))
    if r["nonfinite"]:
        parts.append("nan/inf in " + "; ".join(r["nonfinite"][:2]))
    last = [l for l in r["stderr"].strip().splitlines() if l.strip()][-1:] or ["(no stderr)"]
    return "%s [%s, %s, exit %s, %.1f s]\n    %s\n    stderr: %s" % (
        r["name"], r["class"], r["subcommand"], r["rc"], r["seconds"], "; ".join(parts), last[0][:300])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--softhom", type=Path, required=True)
    ap.add_argument("--source-dir", type=Path, required=True)
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--timeout", type=float, default=6.0, help="seconds per case")
    ap.add_argument("--no-memory-limit", action="store_true",
                    help="no address-space limit (AddressSanitizer reserves terabytes of virtual memory)")
    ap.add_argument("--filter", default="", help="only cases whose name contains this")
    ap.add_argument("--report", type=Path, help="also write the table and the failures to this file")
    ap.add_argument("--no-generate", action="store_true", help="reuse the cases in WORK/cases")
    a = ap.parse_args()
    a.softhom = a.softhom.resolve()
    a.work.mkdir(parents=True, exist_ok=True)
    if not a.no_generate:
        subprocess.run([sys.executable, str(HERE / "generate.py"), "--source-dir", str(a.source_dir), "--work",
                        str(a.work), "--softhom", str(a.softhom)], check=True)
    cases = sorted(d for d in (a.work / "cases").iterdir() if (d / "case.json").is_file() and a.filter in d.name)
    t0 = time.monotonic()
    with concurrent.futures.ThreadPoolExecutor(max_workers=a.jobs) as pool:
        results = list(pool.map(lambda d: run_case(d, a.softhom, a.timeout, not a.no_memory_limit), cases))
    wall = time.monotonic() - t0
    (a.work / "results.json").write_text(json.dumps(results, indent=1))
    rows, total = tally(results)
    bad = [r for r in results if failed(r)]
    text = table(rows, total) + "\n\n%d of %d cases failed (%.0f s wall, %d workers)\n" % (
        len(bad), len(results), wall, a.jobs)
    if bad:
        text += "\nfailures:\n" + "\n".join(describe(r) for r in bad) + "\n"
    # Not a failure of the contract, but of its wording: values are to be shown as the user wrote them.
    reformatted = [r for r in results if r["rc"] == 2 and TO_STRING_NUMBER.search(r["stderr"])]
    if reformatted:
        text += "\nnote: %d error messages show a number reformatted (std::to_string), e.g.:\n" % len(reformatted)
        for r in reformatted[:8]:
            line = next(l for l in r["stderr"].splitlines() if TO_STRING_NUMBER.search(l))
            text += "    %s: %s\n" % (r["name"], line.strip()[:200])
    print(text)
    if a.report:
        a.report.write_text(text)
    print("%d passed, %d failed" % (len(results) - len(bad), len(bad)))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
