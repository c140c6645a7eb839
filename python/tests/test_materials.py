"""softhom.material: construction from dicts / TOML, evaluate() against the program's point driver,
the tangent against finite differences, and input errors as softhom.InputError."""
import numpy as np
import pandas as pd
import pytest

import softhom
from conftest import run_cli


def test_evaluate_matches_point_driver(tmp_path, scenes):
    # The driver's rows hold converged F and the P the same law computed at it; response.csv is written
    # with round-trip digits, so evaluating the law again at F must give P to round-off. 1e-12 relative
    # to max |P| allows a last-bit difference of the rotated-material path the driver takes.
    run_cli("point", scenes / "point_uniaxial_fiber.toml", "--out", tmp_path)
    rows = pd.read_csv(tmp_path / "response.csv", float_precision="round_trip")
    F = rows[[f"F{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]].to_numpy().reshape(-1, 3, 3)
    P_cli = rows[[f"P{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]].to_numpy().reshape(-1, 3, 3)
    m = softhom.material({"preset": "ecoflex-anisotropic", "fiber_invariant": "full",
                          "fibers": [{"direction": [1.0, 0.0, 0.0]}]})
    P, A, state = m.evaluate(F)
    assert P.shape == (len(rows), 3, 3) and A.shape == (len(rows), 9, 9) and state.shape == (len(rows), 0)
    assert np.max(np.abs(P - P_cli)) <= 1e-12 * np.max(np.abs(P_cli))


def test_toml_text_and_dict_agree():
    a = softhom.material({"law": "neo-hookean", "mu": 0.5, "K": 50})
    b = softhom.material("[material]\nlaw = \"neo-hookean\"\nmu = 0.5\nK = 50\n")
    F = np.eye(3)[None] + 0.1 * np.arange(9.0).reshape(1, 3, 3) / 9
    assert np.array_equal(a.evaluate(F)[0], b.evaluate(F)[0])
    assert a.initial_shear_modulus == 0.5 and a.initial_bulk_modulus == 50


def test_simple_shear_closed_form():
    # Isochoric neo-Hookean at F = I + γ e1⊗e2: J = 1, P12 = μ γ exactly (docs/model.md §3).
    m = softhom.material({"law": "neo-hookean", "mu": 0.5, "K": 50})
    F = np.eye(3)[None].repeat(3, axis=0)
    F[:, 0, 1] = [0.1, 0.2, 0.3]
    P, _, _ = m.evaluate(F, tangent=False)
    assert np.allclose(P[:, 0, 1], 0.5 * F[:, 0, 1], rtol=1e-13, atol=0)


def test_tangent_against_central_differences():
    # A = dP/dF with row 3i+j, column 3k+l. Central differences with h = 1e-6 have truncation error
    # O(h²|P'''|) ~ 1e-12 and round-off O(eps |P| / h) ~ 1e-10 relative: 1e-6 relative to max |A| fails
    # on any wrong entry but not on the differencing.
    m = softhom.material({"preset": "ecoflex-anisotropic", "fiber_invariant": "full",
                          "fibers": [{"angle_deg": 30}]})
    rng = np.random.default_rng(3)
    F0 = np.eye(3) + 0.2 * rng.standard_normal((3, 3))
    _, A, _ = m.evaluate(F0[None])
    h = 1e-6
    fd = np.zeros((9, 9))
    for c in range(9):
        dF = np.zeros(9)
        dF[c] = h
        Pp, _, _ = m.evaluate((F0 + dF.reshape(3, 3))[None], tangent=False)
        Pm, _, _ = m.evaluate((F0 - dF.reshape(3, 3))[None], tangent=False)
        fd[:, c] = (Pp - Pm).reshape(9) / (2 * h)
    assert np.max(np.abs(A[0] - fd)) <= 1e-6 * np.max(np.abs(A[0]))
    # The same numbers as a fourth-order tensor A[i, j, k, l].
    A4 = A.reshape(-1, 3, 3, 3, 3)
    assert A4[0, 0, 1, 2, 0] == A[0, 3 * 0 + 1, 3 * 2 + 0]


def test_viscoelastic_state_relaxes():
    # QLV (one Prony term): held at a constant stretch, the stress relaxes toward g_inf times the
    # instantaneous one (docs/model.md §4); the state carries the history between calls.
    m = softhom.material({"preset": "ecoflex", "viscoelastic": {"g_inf": 0.5, "tau": 1.0}})
    assert m.state_size > 0
    F = np.diag([1.2, 1 / np.sqrt(1.2), 1 / np.sqrt(1.2)])[None]
    state = m.initial_state(1)
    P_first, _, state = m.evaluate(F, state, dt=1e-3)
    P = P_first
    for _ in range(200):
        P, _, state = m.evaluate(F, state, dt=0.1)
    assert P[0, 0, 0] < 0.6 * P_first[0, 0, 0]
    assert P[0, 0, 0] > 0.4 * P_first[0, 0, 0]


def test_locking_raises_evaluation_error():
    m = softhom.material({"preset": "ecoflex"})
    F = np.eye(3)[None].repeat(2, axis=0)
    F[1] = np.diag([8.0, 1 / np.sqrt(8), 1 / np.sqrt(8)])
    with pytest.raises(softhom.EvaluationError, match=r"F\[1\]: locking"):
        m.evaluate(F)


def test_bad_parameter_is_input_error_with_the_cli_message(tmp_path):
    with pytest.raises(softhom.InputError) as e:
        softhom.material({"law": "gent", "G": -1.0, "Jm": 10, "K": 100})
    assert isinstance(e.value, ValueError)
    assert e.value.field == "material.G"
    scene = tmp_path / "bad.toml"
    scene.write_text('[material]\nlaw = "gent"\nG = -1.0\nJm = 10\nK = 100\n[load]\ntype = "uniaxial"\nstretch = 1.1\n')
    r = run_cli("point", scene, "--out", tmp_path / "out", check=False)
    assert r.returncode == 2
    assert str(e.value) in r.stderr


def test_unknown_preset_and_non_toml_values():
    with pytest.raises(softhom.InputError, match="material.preset"):
        softhom.material({"preset": "no-such-material"})
    with pytest.raises(softhom.InputError, match=r"material.G"):
        softhom.material({"law": "gent", "G": None})
    with pytest.raises(softhom.InputError, match="shape"):
        softhom.material({"preset": "ecoflex"}).evaluate(np.eye(3))
