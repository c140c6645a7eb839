"""What a new Python user meets: cells from files and TOML text, the shipped examples, plausibility
warnings, the presets, passive OpenMP waiting, and help() on every public name."""
import os
import pathlib
import subprocess
import sys
import warnings

import numpy as np
import pytest

import softhom

from conftest import SOURCE_DIR

SCENE = SOURCE_DIR / "studies" / "scenes" / "rve_pdms_circ45.toml"
F = np.diag([1.05, 1.0, 1.0])


def small(text: str) -> str:
    return text.replace("grid = [32, 32]", "grid = [8, 8]")


def test_cell_from_file_and_from_toml_agree(tmp_path):
    path = tmp_path / "cell.toml"
    path.write_text(small(SCENE.read_text()))
    a = softhom.Cell.from_file(path).solve(F, tangent=False)
    b = softhom.Cell.from_toml(path.read_text()).solve(F, tangent=False)
    c = softhom.Cell.from_file(str(path)).solve(F, tangent=False)  # a str path works in from_file
    assert a["converged"] and b["converged"]
    # The same scene through the same solver: the same doubles.
    assert np.array_equal(a["P"], b["P"]) and np.array_equal(a["P"], c["P"])
    assert a["P"][0, 0] > 0.0


def test_a_path_given_as_text_names_from_file():
    with pytest.raises(softhom.InputError) as e:
        softhom.Cell(str(SCENE))
    assert e.value.field == "scene" and "from_file" in str(e.value)
    with pytest.raises(softhom.InputError) as e:
        softhom.run_rve("studies/scenes/rve_ecoflex_circ45.toml")
    assert "pathlib.Path" in str(e.value)
    with pytest.raises(TypeError):
        softhom.Cell.from_toml(SCENE)


def test_examples_are_found_and_copied(tmp_path):
    table = softhom.examples()
    assert {"scenes/rve_ecoflex_circ45", "calibrations/example_point", "python/fiber_angle_sweep"} <= set(table.name)
    path = softhom.example_path("rve_ecoflex_circ45")
    assert path.is_file() and path.name == "rve_ecoflex_circ45.toml"
    copied = softhom.copy_example("example_qlv", tmp_path)
    assert tmp_path / "calibrations" / "example_qlv.toml" in copied
    assert (tmp_path / "calibrations" / "data" / "relax_ramp2s.csv").is_file()
    with pytest.raises(softhom.InputError):
        softhom.example_path("no_such_example")


def test_implausible_moduli_warn_and_run():
    scene = {"material": {"law": "neo-hookean", "mu": 17000, "K": 2000},
             "load": {"type": "uniaxial", "stretch": 1.01, "steps": 1}}
    with pytest.warns(softhom.PlausibilityWarning, match=r"Poisson's ratio -0\.6087"):
        r = softhom.run_point(scene, threads=1)
    assert r.summary["status"] == "completed"
    assert any("plausibility: material" in w for w in r.summary["warnings"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # Ecoflex: nothing to say
        softhom.run_point({"material": {"preset": "ecoflex"}, "load": {"type": "uniaxial", "stretch": 1.01, "steps": 1}},
                          threads=1)


def test_glass_presets():
    assert {"glass", "e-glass"} <= set(softhom.presets())
    # E = 10 MPa, ν = 0.3 (the dissertation's fiber): G = E / (2 (1 + ν)) = 3.846 MPa; E-glass E = 72 GPa, ν = 0.22.
    assert softhom.material({"preset": "glass"}).initial_shear_modulus == pytest.approx(10 / 2.6, rel=1e-12)
    assert softhom.material({"preset": "e-glass"}).initial_shear_modulus == pytest.approx(72000 / 2.44, rel=1e-12)


def test_import_sets_passive_waiting_unless_the_user_chose():
    code = "import os, softhom; print(os.environ.get('OMP_WAIT_POLICY'))"
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout
    assert out.strip() == "passive"
    env["OMP_WAIT_POLICY"] = "active"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout
    assert out.strip() == "active"


def test_numpy_imported_first_runs_on_one_thread():
    # numpy first: libgomp is loaded with spinning waits before softhom can ask for passive ones, so a run
    # without threads= takes one thread (summary "threads"); softhom first: passive waits, all cores.
    code = ("import os, sys\n{first}\nimport softhom\n"
            "r = softhom.run_point(softhom.default_scene('point'))\nprint(r.summary['threads'], len(os.sched_getaffinity(0)))")
    env = {k: v for k, v in os.environ.items() if k not in ("OMP_WAIT_POLICY", "OMP_NUM_THREADS")}
    def threads(first):
        out = subprocess.run([sys.executable, "-c", code.format(first=first)], env=env, capture_output=True, text=True,
                             check=True).stdout.split()
        return int(out[0]), int(out[1])
    assert threads("import numpy")[0] == 1
    used, cores = threads("pass")
    assert used == cores
    two = subprocess.run([sys.executable, "-c", "import numpy, softhom; print(softhom.run_point(softhom.default_scene("
                          "'point'), threads=2).summary['threads'])"], env=env, capture_output=True, text=True, check=True)
    assert two.stdout.strip() == "2"  # threads= given: as asked


def test_every_public_name_has_a_docstring():
    missing = [n for n in softhom.__all__ if n != "__version__" and not (getattr(softhom, n).__doc__ or "").strip()]
    assert not missing, missing
    for name in ("solve", "commit", "state", "restore", "from_file", "from_toml"):
        assert (getattr(softhom.Cell, name).__doc__ or "").strip(), name


def test_type_stubs_ship_with_the_package():
    package = pathlib.Path(softhom.__file__).parent
    assert (package / "py.typed").is_file()
    stub = (package / "__init__.pyi").read_text()
    for name in softhom.__all__:
        assert name in stub, name
