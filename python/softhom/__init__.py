"""softhom from Python: materials, material-point, RVE and macro runs, campaign stores, calibration.

Scenes are what the `softhom` program reads, given as a dict (the TOML tables as nested dicts and
lists), as TOML text, or as a path (pathlib.Path or os.PathLike) to a scene file. A job runs through
the same code as the program, so its response is the program's response.csv, returned as a pandas
DataFrame (units in ``df.attrs["units"]``), and its summary is summary.json as a dict. Both come back
in memory: no file is written unless ``out=DIR`` is given (then DIR holds the program's output files).

Errors in input raise :class:`InputError` (a ValueError) with the program's message
``"field = value: reason"`` and the attributes ``field`` and ``value``. Ctrl-C during a run stops it
at the next step and raises KeyboardInterrupt. See docs/python.md.
"""
from __future__ import annotations

import functools
import io as _io
import json
import os
import pathlib
import tempfile
import warnings
from typing import Any, Mapping, NamedTuple

def _prefer_passive_openmp_waiting() -> bool:
    """OMP_WAIT_POLICY=passive unless the user set it: OpenMP threads that spin at barriers take the
    cores the working threads need on a busy machine (a 32² cell 6.8 s on two threads against 0.6 s on
    one). libgomp reads the variable once, when it is loaded: when something imported before softhom
    (numpy, pandas, matplotlib: their OpenBLAS) has loaded it already, it is too late, and this returns
    True: the jobs then run on one thread unless given threads= (docs/python.md)."""
    if "OMP_WAIT_POLICY" in os.environ:
        return False
    try:
        with open("/proc/self/maps", encoding="utf-8", errors="replace") as maps:
            if "libgomp" in maps.read():
                return True
    except OSError:
        pass
    os.environ["OMP_WAIT_POLICY"] = "passive"
    return False


_OPENMP_THREADS_SPIN = _prefer_passive_openmp_waiting()


import numpy as np  # noqa: E402  (numpy's OpenBLAS may load libgomp)
import pandas as pd  # noqa: E402


from . import _softhom  # noqa: E402  (after the OpenMP environment is set)
from ._softhom import CellState, InputError, Material  # noqa: E402

_softhom._set_openmp_threads_spin(_OPENMP_THREADS_SPIN)

__all__ = [
    "InputError", "EvaluationError", "PlausibilityWarning", "Material", "Cell", "CellState", "RunResult", "CalibrationResult", "material", "presets",
    "default_scene", "to_toml", "examples", "example_path", "copy_example", "run_point", "run_rve", "run_macro", "open_campaign", "calibrate", "__version__",
]

__version__ = _softhom.version()



class PlausibilityWarning(UserWarning):
    """Input that is valid but probably not meant: a modulus that looks like Pa where softhom reads MPa,
    a negative Poisson's ratio, a compressible rubber matrix. The run goes on; the same text is in
    ``summary["warnings"]``."""


def _warn_plausibility(summary: dict) -> None:
    for w in summary.get("warnings", []):
        if isinstance(w, str) and w.startswith("plausibility: "):
            warnings.warn(w[len("plausibility: "):], PlausibilityWarning, stacklevel=3)


class EvaluationError(ArithmeticError):
    """A material refused a deformation (Gent locking, J <= 0, non-finite values); names the point."""


class RunResult(NamedTuple):
    """``response``: one row per converged output step; ``summary``: summary.json as a dict
    (``summary["status"]`` says whether the run completed and why not)."""
    response: pd.DataFrame
    summary: dict


class CalibrationResult(NamedTuple):
    """``summary``: the fit (parameters with standard errors, correlations, per-curve R² / NRMSE);
    ``material_toml``: the fitted [material] table; ``comparison``: columns curve, index, x, data, model."""
    summary: dict
    material_toml: str
    comparison: pd.DataFrame
    success: bool


def _input_error(field: str, value: Any, reason: str) -> InputError:
    """An InputError raised on the Python side, in the message form of the C++ ones."""
    e = InputError(f"{field} = {value}: {reason}")
    e.field, e.value = field, str(value)
    return e


def _looks_like_file_name(text: str) -> bool:
    """One line without '=' or '[' that names a .toml file or an existing file: no scene is that."""
    if not text or any(c in text for c in "=[\n"):
        return False
    return text.endswith(".toml") or os.path.isfile(text)


def _scene(scene: Any) -> tuple[str, Any]:
    """(kind, payload) for the compiled module: "file" (a path), "toml" (text) or "dict"."""
    if isinstance(scene, os.PathLike):
        return "file", os.fspath(scene)
    if isinstance(scene, str):
        if _looks_like_file_name(scene):
            raise _input_error("scene", scene, "is a file name, not TOML text: pass pathlib.Path(...) "
                               "(or Cell.from_file for a Cell)")
        return "toml", scene
    if isinstance(scene, Mapping):
        return "dict", scene
    raise TypeError(f"a scene is a dict, TOML text or a path, not {type(scene).__name__}")


def _base(scene: Any, base_dir: Any) -> str:
    return "" if base_dir is None else os.fspath(os.path.abspath(base_dir))


def material(spec: Any) -> Material:
    """A material from a [material] table: e.g. ``{"preset": "ecoflex"}`` or ``{"law": "neo-hookean",
    "mu": 0.5, "K": 50}``, with ``fibers`` / ``viscoelastic`` as in a scene (docs/keys.md), or the
    table as TOML text (with or without its ``[material]`` header)."""
    kind, payload = _scene(spec)
    return _softhom.make_material(kind, payload)


class Cell:
    """One periodic RVE cell (FFT engine) as a constitutive law, for FE² quadrature points.

    Built from an RVE scene (dict, TOML text or path; its [load] table is not used). ``solve(F)``
    solves the cell at the macroscopic F̄ ([3, 3]) from the committed state and returns a dict with
    ``converged``, ``error``, ``F``, ``P`` (P̄ [MPa]) and ``tangent`` (∂P̄/∂F̄ [9, 9], row 3i+j = P̄_ij,
    column 3k+l = F̄_kl; the solver's own linearization) plus iteration counts and seconds.
    ``stress_prescribed`` ([3, 3] booleans) with ``P_target`` gives mixed control. ``solve`` never
    commits: ``commit()`` makes its result the start of the next solve, ``state()`` copies the
    committed state out, ``restore(state)`` puts one back (one Cell serves many points)."""

    def __init__(self, scene: Any, tangent_tolerance: float = 1e-6):
        kind, payload = _scene(scene)
        self._cell = _softhom.Cell(kind, payload, tangent_tolerance)

    @classmethod
    def from_file(cls, path: str | os.PathLike, tangent_tolerance: float = 1e-6) -> "Cell":
        """The cell of an RVE scene file (what ``softhom rve PATH`` runs); relative paths in it are
        relative to the file."""
        return cls(pathlib.Path(path), tangent_tolerance)

    @classmethod
    def from_toml(cls, text: str, tangent_tolerance: float = 1e-6) -> "Cell":
        """The cell of an RVE scene given as TOML text."""
        if not isinstance(text, str):
            raise TypeError(f"from_toml takes TOML text (str), not {type(text).__name__}")
        return cls(text, tangent_tolerance)

    @classmethod
    def from_dict(cls, scene: Mapping, tangent_tolerance: float = 1e-6) -> "Cell":
        """The cell of an RVE scene given as nested dicts (the TOML tables)."""
        if not isinstance(scene, Mapping):
            raise TypeError(f"from_dict takes a dict of the scene's tables, not {type(scene).__name__}")
        return cls(scene, tangent_tolerance)

    def solve(self, F: Any, dt: float = 0.0, tangent: bool = True, stress_prescribed: Any = None,
              P_target: Any = None) -> dict:
        """Solves the cell at the macroscopic F̄ (array [3, 3]) after a time step ``dt`` [s] from the
        committed state; returns a dict with ``converged``, ``error``, ``F``, ``P`` (P̄ [MPa], [3, 3]),
        ``tangent`` (∂P̄/∂F̄ [9, 9], with ``tangent=True``), iteration counts and seconds. Mixed control:
        ``stress_prescribed`` ([3, 3] booleans) takes those components of P̄ from ``P_target``. Never
        commits; a cell that does not converge returns ``converged=False`` (no exception)."""
        return self._cell.solve(np.asarray(F, dtype=float), dt, tangent,
                                None if stress_prescribed is None else np.asarray(stress_prescribed, dtype=bool),
                                None if P_target is None else np.asarray(P_target, dtype=float))

    def commit(self) -> None:
        """Makes the last converged solve's state the start of the next solve (the macro step is accepted)."""
        self._cell.commit()

    def state(self) -> CellState:
        """A copy of the committed state (keep one per quadrature point)."""
        return self._cell.state()

    def trial_state(self) -> CellState:
        """The state of the last converged solve (the committed one when there is none)."""
        return self._cell.trial_state()

    def initial_state(self) -> CellState:
        """The undeformed state (F̄ = I, initial history): what a new quadrature point starts from."""
        return self._cell.initial_state()

    def restore(self, state: CellState) -> None:
        """Makes ``state`` (from this cell's scene) the committed state and drops the trial."""
        self._cell.restore(state)

    @property
    def has_history(self) -> bool:
        """Whether a phase has history (QLV): then ``solve`` needs ``dt > 0``."""
        return self._cell.has_history

    @property
    def memory_bytes(self) -> int:
        """Bytes the cell's solver holds (grid, FFT plans, tangent storage)."""
        return self._cell.memory_bytes

    def describe(self) -> str:
        """One line: geometry, phases, grid and fiber angle."""
        return self._cell.describe()


def _examples_root() -> str:
    # Installed: PREFIX/lib/pythonX.Y/{dist,site}-packages/softhom next to PREFIX/share/softhom/examples.
    guess = pathlib.Path(__file__).resolve().parents[4] / "share" / "softhom" / "examples"
    root = _softhom.examples_directory(str(guess))
    if not root:
        raise FileNotFoundError("the softhom examples were not found (share/softhom/examples of the install); "
                                "set SOFTHOM_EXAMPLES to that directory")
    return root


def examples() -> pd.DataFrame:
    """The shipped examples (what ``softhom examples list`` prints): columns name ("scenes/rve_ecoflex_circ45",
    "calibrations/example_point", "python/fiber_angle_sweep", ...), path (absolute) and description."""
    root = _examples_root()
    rows = [(n, os.path.join(root, f), d) for n, f, d in _softhom.list_examples(root)]
    return pd.DataFrame(rows, columns=["name", "path", "description"])


def example_path(name: str) -> pathlib.Path:
    """The installed file of an example, by name or stem: ``example_path("rve_ecoflex_circ45")`` is the
    scene file, ready for ``run_rve`` or ``Cell.from_file`` (read it, do not write into it: copy with
    :func:`copy_example`)."""
    for n, path, _ in examples().itertuples(index=False):
        if name in (n, pathlib.Path(path).stem, pathlib.Path(path).name):
            return pathlib.Path(path)
    raise _input_error("name", name, "is no example (softhom.examples() lists them)")


def copy_example(name: str, directory: str | os.PathLike) -> list[pathlib.Path]:
    """Copies an example (or ``"all"``) with the files it names into ``directory``, in the layout of
    ``softhom examples copy``; returns the copied files."""
    d = os.fspath(directory)
    return [pathlib.Path(d) / p for p in _softhom.copy_example(_examples_root(), name, d)]


def presets() -> list[str]:
    """Names of the parameter sets (docs/model.md §6)."""
    return list(_softhom.presets())


def default_scene(command: str) -> str:
    """The embedded default scene of ``point``, ``rve`` or ``macro`` as TOML text (a starting point)."""
    return _softhom.default_scene(command)


def to_toml(scene: Mapping) -> str:
    """A scene dict as the TOML text the program would read."""
    return _softhom.to_toml(scene)


def _units(columns) -> dict:
    return {c: _softhom.column_unit(c) for c in columns}


def _read_run(directory: str) -> RunResult:
    """The result of a run from the files it left in ``directory`` (e.g. after an interruption)."""
    with open(os.path.join(directory, "summary.json"), encoding="utf-8") as f:
        summary = json.load(f)
    path = os.path.join(directory, "response.csv")
    response = pd.read_csv(path, float_precision="round_trip") if os.path.exists(path) else pd.DataFrame()
    response.attrs["units"] = _units(response.columns)
    return RunResult(response, summary)


def _result(r: dict) -> RunResult:
    """A RunResult from the compiled module's arrays: the columns pandas would read from response.csv
    as integers (every value written without a decimal point or exponent) are int64, as there."""
    columns = list(r["columns"])
    response = pd.DataFrame(np.asarray(r["data"]), columns=columns) if columns else pd.DataFrame()
    for c in r["integer_columns"]:
        response[c] = response[c].astype("int64")
    response.attrs["units"] = _units(response.columns)
    return RunResult(response, json.loads(r["summary"]))


def _run(job, scene: Any, out: Any, threads: int | None, quiet: bool, base_dir: Any) -> RunResult:
    kind, payload = _scene(scene)
    if threads is not None and (not isinstance(threads, int) or threads < 0):
        raise _input_error("threads", threads, "must be a whole number >= 0 (0: all cores)")
    directory = "" if out is None else os.fspath(out)
    if directory:
        os.makedirs(directory, exist_ok=True)
    result = _result(job(kind, payload, _base(scene, base_dir), directory, threads or 0, quiet))
    _warn_plausibility(result.summary)
    return result


def run_point(scene: Any, out: Any = None, threads: int | None = None, quiet: bool = True,
              base_dir: Any = None) -> RunResult:
    """`softhom point` on a scene ([material], [load], optional [solver]): columns t, F11..F33,
    P11..P33, sigma11..sigma33, fiber<k>_angle_deg."""
    return _run(_softhom.run_point, scene, out, threads, quiet, base_dir)


def run_rve(scene: Any, out: Any = None, threads: int | None = None, quiet: bool = True,
            base_dir: Any = None, resume: bool = False) -> RunResult:
    """`softhom rve` on a scene (FFT or FE engine, [solver] engine): the homogenized response.
    ``resume=True`` continues the stopped run whose checkpoint is in ``out`` (``softhom rve --resume``);
    the result then holds the whole run's rows."""
    if resume and out is None:
        raise _input_error("out", None, "resume=True continues the run in an output directory: give out")
    job = functools.partial(_softhom.run_rve, resume=True) if resume else _softhom.run_rve
    return _run(job, scene, out, threads, quiet, base_dir)


def run_macro(scene: Any, out: Any = None, threads: int | None = None, quiet: bool = True,
              base_dir: Any = None) -> RunResult:
    """`softhom macro` on a scene (built-in structure or Gmsh mesh): the probe response."""
    return _run(_softhom.run_macro, scene, out, threads, quiet, base_dir)


def open_campaign(directory: Any) -> pd.DataFrame:
    """Every case and step of a campaign store (DIR/campaign.h5, or the .h5 file itself) as one
    DataFrame in the layout of cases.csv: case, status, one column per campaign parameter, step, the
    `softhom rve` response columns. Read with softhom's own store reader (no h5py). ``attrs``: units,
    parameters (the parameter column names), errors (case id → error of failed cases)."""
    path = os.fspath(directory)
    if os.path.isdir(path):
        path = os.path.join(path, "campaign.h5")
    if not os.path.exists(path):
        raise FileNotFoundError(f"campaign store '{path}' does not exist")
    t = _softhom.read_campaign(path)
    df = pd.DataFrame({c: t["data"][c] for c in t["columns"]}, columns=list(t["columns"]))
    if len(df):
        df["step"] = df["step"].astype("Int64")
    df.attrs["units"] = _units(df.columns)
    df.attrs["parameters"] = list(t["parameters"])
    df.attrs["errors"] = dict(t["errors"])
    return df


def _curve_csv(name: str, data: Any, directory: str) -> str:
    """Writes curve data (x, y) to directory/<n>.csv with columns x, y; returns the path."""
    if isinstance(data, pd.DataFrame):
        x, y = data.iloc[:, 0].to_numpy(float), data.iloc[:, 1].to_numpy(float)
    else:
        x, y = (np.asarray(a, dtype=float) for a in data)
    if x.ndim != 1 or x.shape != y.shape:
        raise _input_error(f"curves.{name}.data", f"arrays of shapes {x.shape} and {y.shape}",
                           "x and y must be 1-D arrays of one length")
    path = os.path.join(directory, f"curve{len(os.listdir(directory))}.csv")
    pd.DataFrame({"x": x, "y": y}).to_csv(path, index=False, float_format="%.17g")
    return path


def calibrate(calibration: Any, out: Any = None, threads: int | None = None, quiet: bool = True,
              base_dir: Any = None) -> CalibrationResult:
    """`softhom calibrate` on a calibration ([model], [[curves]], [solver]; docs/keys.md). In a dict,
    a curve may carry its data as arrays: ``{"name": "t45", "x": "F11", "y": "P11", "data": (x, y),
    "load": {...}}`` instead of a file, run or campaign. With ``out``, writes material.toml,
    summary.json, response.csv and curves/*.csv there."""
    kind, payload = _scene(calibration)
    with tempfile.TemporaryDirectory(prefix="softhom-curves-") as curves_dir:
        if kind == "dict" and "curves" in payload:
            payload = dict(payload)
            curves = []
            for i, c in enumerate(payload["curves"]):
                c = dict(c)
                if "data" in c:
                    c["file"] = _curve_csv(str(c.get("name", i)), c.pop("data"), curves_dir)
                    c.setdefault("x_column", "x")
                    c.setdefault("y_column", "y")
                curves.append(c)
            payload["curves"] = curves
        directory = "" if out is None else os.fspath(out)
        r = _softhom.calibrate(kind, payload, _base(calibration, base_dir), directory, threads or 0, quiet)
    comparison = pd.read_csv(_io.StringIO(r["comparison_csv"]), float_precision="round_trip")
    return CalibrationResult(json.loads(r["summary"]), r["material_toml"], comparison, bool(r["success"]))
