"""Inputs the module refuses as the program does, with softhom.InputError (a ValueError) instead of
blocking or crashing: a scene path that is no regular file, thread counts beyond the bound of
--threads (from the argument or OMP_NUM_THREADS), and dicts that contain themselves or nest too deep."""
import os
import subprocess
import sys
import time

import pytest

import softhom


def test_a_fifo_as_scene_file_is_refused_at_once(tmp_path):
    fifo = tmp_path / "scene.toml"
    os.mkfifo(fifo)
    start = time.monotonic()
    with pytest.raises(softhom.InputError, match="FIFO") as e:
        softhom.run_point(fifo)  # a plain open blocks until a writer appears
    assert e.value.field == "scene"
    assert time.monotonic() - start < 5.0  # a few stat calls; the blocking open would never return
    with pytest.raises(ValueError, match="directory"):
        softhom.run_point(tmp_path)


def test_threads_beyond_the_bound_of_the_program_are_refused():
    with pytest.raises(softhom.InputError, match="out of range") as e:
        softhom.run_point(softhom.default_scene("point"), threads=100000)
    assert e.value.field == "threads"


def test_omp_num_threads_is_bounded_as_threads():
    # In a process of its own: OpenMP reads OMP_NUM_THREADS when it starts, and 100000 threads crashed it.
    code = "import softhom; softhom.run_point(softhom.default_scene('point'))"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                       env=dict(os.environ, OMP_NUM_THREADS="100000"))
    assert r.returncode == 1, r.stderr  # an uncaught exception, not a signal (negative code)
    assert "InputError" in r.stderr and "OMP_NUM_THREADS = 100000" in r.stderr, r.stderr


def test_a_dict_that_contains_itself_is_a_value_error():
    d = {"preset": "ecoflex"}
    d["self"] = d
    with pytest.raises(ValueError, match="contains itself") as e:
        softhom.material(d)
    assert e.value.field == "material.self"
    lst = [1.0]
    lst.append(lst)
    with pytest.raises(ValueError, match="contains itself"):
        softhom.run_point({"material": {"preset": "ecoflex"}, "load": {"type": "uniaxial", "stretch": lst}})


def test_nesting_deeper_than_a_scene_is_a_value_error():
    deep = {"preset": "ecoflex"}
    node = deep
    for _ in range(10000):  # would exhaust the C++ stack of the conversion
        node["x"] = {}
        node = node["x"]
    with pytest.raises(ValueError, match="nested deeper"):
        softhom.material(deep)
