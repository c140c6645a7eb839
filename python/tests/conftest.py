"""Paths of the build under test: the `softhom` program (SOFTHOM_BINARY) and the source tree
(SOFTHOM_SOURCE_DIR), both set by ctest (python/CMakeLists.txt); the module is found on PYTHONPATH."""
import os
import pathlib
import subprocess

import pytest

SOURCE_DIR = pathlib.Path(os.environ.get("SOFTHOM_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
BINARY = os.environ.get("SOFTHOM_BINARY", str(SOURCE_DIR / "build" / "apps" / "softhom"))


def run_cli(*args, env=None, check=True):
    """Runs the softhom program with one OpenMP thread (as the module calls below use threads=1)."""
    e = dict(os.environ, OMP_NUM_THREADS="1")
    e.update(env or {})
    r = subprocess.run([BINARY, *map(str, args), "--quiet"], capture_output=True, text=True, env=e)
    if check and r.returncode != 0:
        raise AssertionError(f"softhom {' '.join(map(str, args))}: exit {r.returncode}\n{r.stderr}")
    return r


@pytest.fixture
def scenes():
    return SOURCE_DIR / "studies" / "scenes"
