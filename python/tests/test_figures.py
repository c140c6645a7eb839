"""The calibration figure (studies/plot_calibration.py) is fit for a paper: PNG at 300 dpi and an SVG,
axes with units, curves named in words."""
import importlib.util
import json
import struct
import subprocess
import sys

import pytest

from conftest import SOURCE_DIR

pytest.importorskip("matplotlib")
SCRIPT = SOURCE_DIR / "studies" / "plot_calibration.py"


def plot_module():
    spec = importlib.util.spec_from_file_location("plot_calibration", SCRIPT)
    m = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(m)
    return m


def test_case_ids_and_columns_read_as_words_with_units():
    m = plot_module()
    assert m.curve_title("ecoflex-circle-a30-vf0.23-square-n24x24-tension") == \
        "Ecoflex, circular fibers at 30°, VF 0.23, uniaxial tension"
    assert m.curve_title("pdms-matrix-n16x16-shear") == "PDMS alone, simple shear"
    assert m.curve_title("my curve") == "my curve"
    assert m.axis_label("P11") == "engineering stress P11 [MPa]"
    assert m.axis_label("F11") == "stretch F11 [1]"
    assert m.axis_label("t") == "time t [s]"


def png_dpi(path):
    """Pixels per metre of the PNG's pHYs chunk, as dots per inch."""
    data = path.read_bytes()
    at = data.find(b"pHYs")
    assert at > 0, "no pHYs chunk"
    ppm = struct.unpack(">I", data[at + 4:at + 8])[0]
    return ppm * 0.0254


def test_fit_figure_is_a_300_dpi_png_and_an_svg(tmp_path):
    name = "ecoflex-circle-a45-vf0.23-square-n24x24-tension"
    summary = {"curves": [{"index": 0, "name": name, "role": "fit", "x": "F11", "y": "P11", "r2": 0.99, "nrmse": 0.02}],
               "parameters": [{"name": "G", "value": 0.027, "std_error": 0.001, "free": True},
                              {"name": "k2", "value": 0.5, "free": True}]}
    (tmp_path / "summary.json").write_text(json.dumps(summary))
    rows = ["curve,index,x,data,model"] + ["%s,0,%g,%g,%g" % (name, 1 + 0.1 * k, 0.01 * k, 0.011 * k) for k in range(5)]
    (tmp_path / "response.csv").write_text("\n".join(rows) + "\n")
    subprocess.run([sys.executable, str(SCRIPT), str(tmp_path)], check=True, capture_output=True)
    assert abs(png_dpi(tmp_path / "fit.png") - 300) < 1
    svg = (tmp_path / "fit.svg").read_text()
    # Matplotlib writes text as paths with the string in a comment or as <text>: look for the words.
    for words in ("engineering stress P11 [MPa]", "Ecoflex, circular fibers at 45°", "G = 0.027 ± 0.001 MPa"):
        assert words in svg, words
    assert not list(tmp_path.glob("*.tmp*"))
