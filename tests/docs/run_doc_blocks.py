#!/usr/bin/env python3
"""Runs every fenced ```sh and ```python block of README.md and docs/*.md, indented ones inside lists
too, as a user would: from an empty directory (one per Markdown file, the blocks of a file in order, so a
block may use what an earlier one made), with `softhom` on PATH and the Python module importable.

A block is changed or left out only by a marker on the line before its fence:

    <!-- doc-test: skip: REASON -->              not run (a sketch, a cluster job, hours of work)
    <!-- doc-test: small: OLD => NEW; ... -->    run with OLD replaced by NEW (a smaller size)

    python3 tests/docs/run_doc_blocks.py --softhom build/apps/softhom --python-path build/python \
        --source-dir . [--only README.md] [--list]

Prints one line per block and closes with "N passed, N failed, N skipped"; exits 1 when one failed.
"""
from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time

# A fence may be indented (a block inside a list item): its body is indented alike, and that indent is
# taken off every line (Python would refuse it; the shell would keep heredocs' indentation).
FENCE = re.compile(r"^( *)```(sh|bash|shell|python)\s*$")
CLOSE = re.compile(r"^ *```\s*$")
MARKER = re.compile(r"^\s*<!--\s*doc-test:\s*(skip|small):\s*(.*?)\s*-->\s*$")


def dedent(line: str, indent: int) -> str:
    """`line` without the fence's indent (or without what blanks it has, when fewer)."""
    blanks = len(line) - len(line.lstrip(" "))
    return line[min(blanks, indent):]


def blocks_of_text(text: str):
    """(line, language, code, marker kind, marker text) of every sh/python fenced block of a text."""
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        marker = MARKER.match(lines[i - 1]) if i > 0 else None
        indent = len(m.group(1))
        start, i = i, i + 1
        body = []
        while i < len(lines) and not CLOSE.match(lines[i]):
            body.append(dedent(lines[i], indent))
            i += 1
        i += 1
        language = "sh" if m.group(2) == "shell" else m.group(2)
        yield start + 1, language, "\n".join(body) + "\n", marker.group(1) if marker else "", marker.group(2) if marker else ""


def blocks(path: str):
    return blocks_of_text(open(path, encoding="utf-8").read())


def self_test() -> None:
    """The extraction on a text with a top-level block and an indented one inside a list item."""
    text = ("```sh\necho top\n```\n- a step:\n\n  <!-- doc-test: skip: sketch -->\n  ```python\n"
            "  if True:\n      print(1)\n  ```\n1. then:\n   ```sh\n   echo listed\n   ```\n")
    got = [(line, lang, code, kind) for line, lang, code, kind, _ in blocks_of_text(text)]
    want = [(1, "sh", "echo top\n", ""), (7, "python", "if True:\n    print(1)\n", "skip"), (12, "sh", "echo listed\n", "")]
    if got != want:
        raise SystemExit(f"self-test: extracted {got}, expected {want}")


def smaller(code: str, spec: str, where: str) -> str:
    for pair in filter(None, (p.strip() for p in spec.split(";"))):
        old, sep, new = pair.partition("=>")
        old, new = old.strip(), new.strip()
        if not sep or old not in code:
            raise SystemExit(f"{where}: small marker '{pair}' does not match the block")
        code = code.replace(old, new)
    return code


def run_block(language: str, code: str, cwd: str, env: dict, python: str, timeout: float):
    cmd = ["bash", "-euo", "pipefail", "-c", code] if language in ("sh", "bash") else [python, "-c", code]
    return subprocess.run(cmd, cwd=cwd, env=env, stdin=subprocess.DEVNULL, capture_output=True, text=True,
                          timeout=timeout)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--softhom", required=True)
    ap.add_argument("--python-path", required=True, help="directory holding the softhom package")
    ap.add_argument("--python", default="/usr/bin/python3" if os.path.exists("/usr/bin/python3") else sys.executable)
    ap.add_argument("--source-dir", required=True)
    ap.add_argument("--only", action="append", help="Markdown files (relative to the source dir)")
    ap.add_argument("--timeout", type=float, default=120.0, help="seconds per block")
    ap.add_argument("--list", action="store_true", help="list the blocks, run nothing")
    args = ap.parse_args()
    self_test()
    src = os.path.abspath(args.source_dir)
    files = args.only or ["README.md"] + sorted(os.path.join("docs", f) for f in os.listdir(os.path.join(src, "docs"))
                                                if f.endswith(".md"))
    bindir = os.path.dirname(os.path.abspath(args.softhom))
    env = dict(os.environ, PATH=bindir + os.pathsep + os.environ.get("PATH", ""),
               PYTHONPATH=os.path.abspath(args.python_path), MPLBACKEND="Agg")
    # `python3` in a block is the interpreter the module is built for (a user's python3 after the install).
    with tempfile.TemporaryDirectory(prefix="softhom-doc-bin-") as shim:
        os.symlink(args.python, os.path.join(shim, "python3"))
        env["PATH"] = shim + os.pathsep + env["PATH"]
        passed = failed = skipped = 0
        for name in files:
            with tempfile.TemporaryDirectory(prefix="softhom-doc-") as cwd:
                for line, language, code, kind, text in blocks(os.path.join(src, name)):
                    where = f"{name}:{line}"
                    if kind == "skip":
                        skipped += 1
                        print(f"skip {where} ({text})")
                        continue
                    if kind == "small":
                        code = smaller(code, text, where)
                    if args.list:
                        print(f"{language} {where}\n{code}")
                        continue
                    start = time.perf_counter()
                    try:
                        r = run_block(language, code, cwd, env, args.python, args.timeout)
                        ok, output = r.returncode == 0, (r.stdout + r.stderr)[-3000:]
                        status = f"exit {r.returncode}"
                    except subprocess.TimeoutExpired:
                        ok, output, status = False, "", f"timeout {args.timeout} s"
                    seconds = time.perf_counter() - start
                    if ok:
                        passed += 1
                        print(f"ok   {where} ({seconds:.1f} s)")
                    else:
                        failed += 1
                        print(f"FAIL {where} ({status}, {seconds:.1f} s)\n--- block:\n{code}--- output:\n{output}")
    print(f"{passed} passed, {failed} failed, {skipped} skipped")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
