"""softhom.run_point / run_rve / run_macro: the program's responses, as DataFrames, without files
unless asked; errors as softhom.InputError with the program's message; Ctrl-C → KeyboardInterrupt."""
import os
import signal
import threading
import time

import numpy as np
import pandas as pd
import pytest

import softhom
from conftest import run_cli

# A small FFT cell (12² section, 4 steps to λ = 1.2): a second or two on one thread.
RVE = {
    "microstructure": {"shape": "circle", "arrangement": "square", "volume_fraction": 0.23, "radius": 0.2,
                       "fiber_angle_deg": 45, "grid": [12, 12]},
    "phases": {"matrix": {"preset": "ecoflex"}, "fiber": {"preset": "glass"}},
    "load": {"type": "uniaxial", "stretch": 1.2, "steps": 4},
    "solver": {"tolerance": 1e-6},
    "output": {"fields": "none"},
}


def cli_response(directory):
    return pd.read_csv(directory / "response.csv", float_precision="round_trip")


def test_run_rve_is_the_program_bitwise(tmp_path):
    # Same scene, same code, one thread each: every number of response.csv (round-trip digits) equal.
    scene = tmp_path / "cell.toml"
    scene.write_text(softhom.to_toml(RVE))
    run_cli("rve", scene, "--out", tmp_path / "cli", "--threads", 1)
    response, summary = softhom.run_rve(RVE, threads=1)
    expected = cli_response(tmp_path / "cli")
    assert list(response.columns) == list(expected.columns)
    assert np.array_equal(response.to_numpy(), expected.to_numpy())
    assert summary["status"] == "completed"
    assert summary["grid"] == [12, 12, 1]
    assert response.attrs["units"]["P11"] == "MPa"


def test_run_point_from_file_text_and_dict_agree(tmp_path, scenes):
    path = scenes / "point_uniaxial_fiber.toml"
    from_file = softhom.run_point(path)
    from_text = softhom.run_point(path.read_text())
    run_cli("point", path, "--out", tmp_path)
    assert np.array_equal(from_file.response.to_numpy(), cli_response(tmp_path).to_numpy())
    assert np.array_equal(from_text.response.to_numpy(), from_file.response.to_numpy())
    assert from_file.summary["steps"] == 50


def test_no_files_unless_out(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    softhom.run_point(softhom.default_scene("point"))
    assert list(tmp_path.iterdir()) == []
    result = softhom.run_rve(RVE, out=tmp_path / "kept", threads=1)
    assert sorted(p.name for p in (tmp_path / "kept").iterdir()) == ["response.csv", "summary.json"]
    assert np.array_equal(cli_response(tmp_path / "kept").to_numpy(), result.response.to_numpy())


def test_run_macro_plane_strain_tube():
    # The embedded default: a Gent tube inflated to r_i = 2 R_i under volume control; the last row
    # must reach the prescribed inner-radius stretch 2 (volume control prescribes V/V0 = 4).
    response, summary = softhom.run_macro(softhom.default_scene("macro"), threads=1)
    assert summary["status"] == "completed"
    assert "pressure" in response.columns and response.attrs["units"]["pressure"] == "MPa"
    assert abs(response["stretch"].iloc[-1] - 2.0) < 1e-3


def test_input_error_names_the_field_as_the_program_does(tmp_path):
    bad = {**RVE, "load": {"type": "uniaxal", "stretch": 1.2}}
    with pytest.raises(softhom.InputError) as e:
        softhom.run_rve(bad)
    assert e.value.field == "load.type"
    scene = tmp_path / "bad.toml"
    scene.write_text(softhom.to_toml(bad))
    r = run_cli("rve", scene, "--out", tmp_path / "out", check=False)
    assert r.returncode == 2 and str(e.value) in r.stderr
    with pytest.raises(softhom.InputError, match=r"microstructure.grid\[1\]"):
        softhom.run_rve({**RVE, "microstructure": {**RVE["microstructure"], "grid": [12, None]}})


def test_ctrl_c_stops_the_run_with_keyboard_interrupt(tmp_path):
    # A run of many steps; SIGINT after 1 s arrives while the module is in C++ with the GIL released.
    # It must end the run at the next step as KeyboardInterrupt (the files in out= say so: the stop
    # went through softhom's stop flag, not Python's handler), restore Python's handler, and leave the
    # module usable.
    long_run = {**RVE, "microstructure": {**RVE["microstructure"], "grid": [24, 24]},
                "load": {"type": "uniaxial", "stretch": 1.8, "steps": 400}}
    timer = threading.Timer(1.0, os.kill, (os.getpid(), signal.SIGINT))
    start = time.monotonic()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        softhom.run_rve(long_run, out=tmp_path, threads=1)
    timer.join()
    assert time.monotonic() - start < 60
    response, summary = softhom._read_run(str(tmp_path))
    assert summary["status"] == "interrupted" and summary["signal"] == "SIGINT"
    assert 1 <= len(response) < 401
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    assert softhom.run_rve(RVE, threads=1).summary["status"] == "completed"


def test_a_run_that_stops_early_is_a_result(tmp_path, scenes):
    # point_locking.toml stretches Gent to its locking limit: the program exits 1 with the converged
    # rows kept; the module returns those rows with status "stopped" and the reason, as summary.json.
    r = run_cli("point", scenes / "point_locking.toml", "--out", tmp_path, check=False)
    assert r.returncode == 1
    response, summary = softhom.run_point(scenes / "point_locking.toml")
    assert summary["status"] == "stopped" and "lock" in summary["error"].lower()
    assert len(response) > 1
    assert np.array_equal(response.to_numpy(), cli_response(tmp_path).to_numpy())


def test_run_rve_resumes_a_stopped_run(tmp_path):
    # The program stopped by SIGTERM after two steps keeps a checkpoint; resume=True continues it to
    # the uninterrupted run's rows, bit for bit (one thread), and removes the checkpoint.
    scene = tmp_path / "cell.toml"
    scene.write_text(softhom.to_toml(RVE))
    run_cli("rve", scene, "--out", tmp_path / "whole", "--threads", 1)
    stopped = run_cli("rve", scene, "--out", tmp_path / "part", "--threads", 1,
                      env={"SOFTHOM_TEST_SIGTERM_AFTER_STEPS": "2"}, check=False)
    assert stopped.returncode == 128 + signal.SIGTERM
    assert (tmp_path / "part" / "checkpoint.json").is_file()
    with pytest.raises(softhom.InputError, match="--resume"):
        softhom.run_rve(RVE, out=tmp_path / "part", threads=1)  # would overwrite the converged part
    result = softhom.run_rve(RVE, out=tmp_path / "part", threads=1, resume=True)
    assert np.array_equal(result.response.to_numpy(), cli_response(tmp_path / "whole").to_numpy())
    assert result.summary["resumed"]["from_t"] == 0.5
    assert not (tmp_path / "part" / "checkpoint.json").exists()
    with pytest.raises(softhom.InputError, match="--resume"):
        softhom.run_rve(RVE, out=tmp_path / "empty", threads=1, resume=True)
    with pytest.raises(softhom.InputError, match="out"):
        softhom.run_rve(RVE, resume=True)
