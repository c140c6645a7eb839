"""softhom.run_rve and run_point without out=: the results come back in memory and no file is written.
The jobs run in a child Python whose working directory has been removed, whose temporary directory
(TMPDIR and tempfile.tempdir), HOME and XDG_CACHE_HOME name a directory that does not exist, so a
temporary directory, a CSV to read back or a cache file would fail the run; where strace is installed,
the child's system calls are traced too and none may create, open for writing, rename or remove a file.
The results equal the program's files for the same scenes."""
import json
import os
import pathlib
import re
import shutil
import subprocess
import sys
import textwrap

import numpy as np
import pandas as pd

import softhom
from conftest import run_cli
from test_runs import RVE

CHILD = textwrap.dedent("""
    import json, os, sys, tempfile
    tempfile.tempdir = os.environ["TMPDIR"]
    import softhom
    rve = softhom.run_rve(json.loads(sys.argv[1]), threads=1)
    point = softhom.run_point(softhom.default_scene("point"), threads=1)
    cell = softhom.Cell(json.loads(sys.argv[1]))
    solved = cell.solve([[1.1, 0, 0], [0, 1, 0], [0, 0, 1]], tangent=False)
    json.dump({"rve": rve.response.to_dict("split"), "rve_status": rve.summary["status"],
               "point": point.response.to_dict("split"), "point_steps": point.summary["steps"],
               "cell_converged": bool(solved["converged"])}, sys.stdout)
""")


def test_cell_and_point_touch_no_file_system(tmp_path):
    gone = tmp_path / "gone"
    gone.mkdir()
    missing = str(tmp_path / "does-not-exist")
    env = dict(os.environ, TMPDIR=missing, HOME=missing, XDG_CACHE_HOME=missing, OMP_NUM_THREADS="1",
               PYTHONDONTWRITEBYTECODE="1", PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    # The child starts in `gone`, which is removed before it runs a job: relative paths lead nowhere.
    script = "import os; os.rmdir(os.getcwd()); " + "exec(" + repr(CHILD) + ")"
    trace = tmp_path / "trace.txt"
    strace = shutil.which("strace")
    tracer = [strace, "-f", "-qq", "-o", str(trace), "-e", "trace=openat,open,creat,mkdir,mkdirat,rename,renameat,"
              "renameat2,unlink,unlinkat"] if strace else []
    r = subprocess.run([*tracer, sys.executable, "-c", script, json.dumps(RVE)], cwd=gone, env=env,
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert not gone.exists() and not pathlib.Path(missing).exists()
    if strace and trace.exists():
        calls = [line for line in trace.read_text().splitlines() if "= -1" not in line]
        writes = [c for c in calls if re.search(r"O_WRONLY|O_RDWR|O_CREAT", c) or
                  re.search(r"\b(creat|mkdir|mkdirat|rename|renameat2?|unlink|unlinkat)\(", c)]
        # The child's own removal of its start directory is the one expected.
        writes = [c for c in writes if '"/dev/' not in c and str(gone) not in c]
        assert writes == [], writes[:5]
    got = json.loads(r.stdout)
    assert got["rve_status"] == "completed" and got["point_steps"] > 0 and got["cell_converged"]

    # The same scenes through the program's files: the same numbers.
    scene = tmp_path / "cell.toml"
    scene.write_text(softhom.to_toml(RVE))
    run_cli("rve", scene, "--out", tmp_path / "rve", "--threads", 1)
    run_cli("point", "--out", tmp_path / "point")
    for name in ("rve", "point"):
        expected = pd.read_csv(tmp_path / name / "response.csv", float_precision="round_trip")
        assert got[name]["columns"] == list(expected.columns)
        assert np.array_equal(np.asarray(got[name]["data"], dtype=float), expected.to_numpy(dtype=float))


def test_results_in_memory_equal_the_files_written_with_out(tmp_path):
    in_memory = softhom.run_rve(RVE, threads=1)
    with_files = softhom.run_rve(RVE, out=tmp_path, threads=1)
    from_disk = softhom._read_run(str(tmp_path))
    for result in (with_files, from_disk):
        assert list(result.response.columns) == list(in_memory.response.columns)
        assert list(result.response.dtypes) == list(in_memory.response.dtypes)
        assert np.array_equal(result.response.to_numpy(), in_memory.response.to_numpy())
    for key in ("status", "grid", "columns", "newton_iterations", "krylov_iterations", "volume_fraction_achieved"):
        assert in_memory.summary[key] == from_disk.summary[key]
