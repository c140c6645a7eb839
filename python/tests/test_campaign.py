"""softhom.open_campaign (campaign.h5 through softhom's store reader) against cases.csv, and
softhom.calibrate with curves given as arrays."""
import numpy as np
import pandas as pd
import pytest

import softhom
from conftest import run_cli

CAMPAIGN = """
description = "two angles and the matrix alone, 8x8 sections"
[base.microstructure]
grid = [8, 8]
[base.phases.fiber]
preset = "glass"
[base.solver]
tolerance = 1e-6
[loads.tension]
type = "uniaxial"
stretch = 1.2
steps = 3
[[sweep]]
matrix = ["ecoflex"]
section = ["circle"]
angle = [30, 60]
volume_fraction = [0.0, 0.23]
load = ["tension"]
"""


def test_open_campaign_equals_cases_csv(tmp_path):
    (tmp_path / "campaign.toml").write_text(CAMPAIGN)
    run_cli("sweep", tmp_path / "campaign.toml", "--out", tmp_path / "store", "--jobs", 1)
    df = softhom.open_campaign(tmp_path / "store")
    csv = pd.read_csv(tmp_path / "store" / "cases.csv", float_precision="round_trip")
    # The DataFrame lists cases by id (the store's order), cases.csv in the campaign's order.
    csv = csv.sort_values(["case", "step"], kind="stable").reset_index(drop=True)
    assert list(df.columns) == list(csv.columns)
    assert len(df) == len(csv) and len(df) > 0
    columns = list(csv.columns)
    assert df.attrs["parameters"] == columns[2:columns.index("step")]
    assert {"matrix", "angle", "volume_fraction", "load"} <= set(df.attrs["parameters"])
    assert len(set(df["case"])) == 3  # the matrix alone is one case whatever the angle
    for c in df.columns:
        if df[c].dtype == object:
            assert list(df[c]) == list(csv[c]), c
        else:
            a, b = df[c].to_numpy(float), csv[c].to_numpy(float)
            assert np.array_equal(a, b, equal_nan=True), c  # same doubles: both from the store's values
    assert set(df["status"]) == {"ok"}
    with pytest.raises(FileNotFoundError):
        softhom.open_campaign(tmp_path / "nothing")


def test_calibrate_recovers_parameters_from_arrays():
    # Data from the driver with G = 0.02, Jm = 12 (Gent, no fibers); the fit from G = 0.05, Jm = 5 must
    # recover them. Noise-free data: 1e-4 relative is far above the optimiser's tolerances and far below
    # any wrong wiring of the curve data (a wrong x column or load shifts G by tens of per cent).
    truth = {"law": "gent", "G": 0.02, "Jm": 12.0, "K": 2000.0}
    load = {"type": "uniaxial", "stretch": 2.0, "steps": 20}
    response, _ = softhom.run_point({"material": truth, "load": load})
    cal = {
        "model": {"G": {"value": 0.05, "min": 0.001, "max": 1.0}, "Jm": {"value": 5.0, "min": 1.0, "max": 100.0},
                  "K": 2000.0},
        "solver": {"starts": 2},
        "output": {"plot": False},
        "curves": [{"name": "tension", "x": "F11", "y": "P11", "load": load,
                    "data": (response["F11"].to_numpy(), response["P11"].to_numpy())}],
    }
    result = softhom.calibrate(cal)
    assert result.success
    values = {p["name"]: p["value"] for p in result.summary["parameters"]}
    assert abs(values["G"] / 0.02 - 1) < 1e-4 and abs(values["Jm"] / 12.0 - 1) < 1e-4
    assert "G = " in result.material_toml
    assert list(result.comparison.columns) == ["curve", "index", "x", "data", "model"]
