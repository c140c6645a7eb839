#!/usr/bin/env python3
"""ctest material_cards_xml: `softhom calibrate` on a calibration whose parameters are all fixed, then
material.feb must parse as XML (xml.etree) with FEBio's structure and carry exactly the calibration's
values, and material.inp must carry them in Abaqus' data lines (round trip of every parameter).

usage: check_material_cards.py --softhom BIN --calibration TOML --work DIR
"""
import argparse
import math
import pathlib
import shutil
import subprocess
import sys
import tomllib
import xml.etree.ElementTree as ET

failures = []


def check(cond, what):
    if not cond:
        failures.append(what)


def close(a, b, tol=0.0):
    return abs(a - b) <= tol * max(1.0, abs(b))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--softhom", required=True)
    ap.add_argument("--calibration", required=True)
    ap.add_argument("--work", required=True)
    a = ap.parse_args()
    work = pathlib.Path(a.work)
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    r = subprocess.run([a.softhom, "calibrate", a.calibration, "--out", str(work), "--quiet"], capture_output=True, text=True)
    if r.returncode != 0:
        print(r.stdout, r.stderr)
        print(f"softhom calibrate exited {r.returncode}")
        return 1
    model = tomllib.loads(pathlib.Path(a.calibration).read_text())["model"]
    G, Jm, K, k1, k2, kappa = (float(model[k]) for k in ("G", "Jm", "K", "k1", "k2", "kappa"))
    terms = model["viscoelastic"]["terms"]
    angle = math.radians(float(model["fibers"][0]["angle_deg"]))
    directions = [(math.sin(angle), math.cos(angle), 0.0), (-math.sin(angle), math.cos(angle), 0.0)]

    # --- FEBio: well-formed XML (ET.parse raises otherwise) and the structure FEBio 4 reads.
    root = ET.parse(work / "material.feb").getroot()
    check(root.tag == "Material", f"root tag {root.tag!r}")
    mats = root.findall("material")
    check(len(mats) == 1, f"{len(mats)} <material> elements")
    m = mats[0]
    check(m.get("type") == "uncoupled viscoelastic", f"top type {m.get('type')!r}")
    check(float(m.findtext("k")) == K, "k")
    check(m.findtext("pressure_model") == "NIKE3D", "pressure_model")
    check(close(float(m.findtext("g0")), 1.0 - sum(t["g"] for t in terms), 1e-15), "g0")
    for i, t in enumerate(terms, start=1):
        check(float(m.findtext(f"g{i}")) == t["g"], f"g{i}")
        check(float(m.findtext(f"t{i}")) == t["tau"], f"t{i}")
    elastic = m.find("elastic")
    check(elastic is not None and elastic.get("type") == "uncoupled solid mixture", "elastic type")
    solids = elastic.findall("solid")
    check([s.get("type") for s in solids] == ["Gent", "Holzapfel-Gasser-Ogden", "Holzapfel-Gasser-Ogden"],
          f"solids {[s.get('type') for s in solids]}")
    check(float(solids[0].findtext("G")) == G and float(solids[0].findtext("Jm")) == Jm, "Gent G, Jm")
    for s, d in zip(solids[1:], directions):
        check(float(s.findtext("c")) == 0.0, "HGO c")
        check(float(s.findtext("k1")) == k1 / 2, "HGO k1 (= k1/2: two fibers at gamma = 0)")
        check(float(s.findtext("k2")) == k2 and float(s.findtext("kappa")) == kappa, "HGO k2, kappa")
        check(float(s.findtext("gamma")) == 0.0, "HGO gamma")
        ax = s.find("mat_axis")
        check(ax is not None and ax.get("type") == "vector", "mat_axis type")
        av = [float(x) for x in ax.findtext("a").split(",")]
        dv = [float(x) for x in ax.findtext("d").split(",")]
        check(all(close(x, y, 1e-15) for x, y in zip(av, d)), f"fiber direction {av} != {d}")
        check(abs(sum(x * y for x, y in zip(av, dv))) < 1e-15, "mat_axis d not perpendicular to a")

    # --- Abaqus: data lines after the keywords.
    lines = [l for l in (work / "material.inp").read_text().splitlines() if not l.startswith("**")]
    def data(keyword):
        i = next(k for k, l in enumerate(lines) if l.startswith(keyword))
        return i, lines[i]
    i, kw = data("*HYPERELASTIC, YEOH")
    check("MODULI=INSTANTANEOUS" in kw, "Yeoh moduli are the instantaneous ones (Prony g_i normalised by them)")
    yeoh = [float(x) for x in lines[i + 1].split(",")]
    check(yeoh[0] == G / 2, "Yeoh C10 = G/2")
    check(yeoh[2] > 0.0, "Yeoh C30 > 0")
    check(yeoh[3] == 2.0 / K and yeoh[4] == 0.0 and yeoh[5] == 0.0, "Yeoh D1 = 2/K, D2 = D3 = 0")
    check(lines[i + 2] == "*VISCOELASTIC, TIME=PRONY", "matrix Prony follows")
    for k, t in enumerate(terms):
        g, kb, tau = (float(x) for x in lines[i + 3 + k].split(","))
        check(g == t["g"] and kb == 0.0 and tau == t["tau"], f"Prony line {k + 1}")
    i, kw = data("*ANISOTROPIC HYPERELASTIC, HOLZAPFEL")
    check(kw.endswith("LOCAL DIRECTIONS=2"), kw)
    h = [float(x) for x in lines[i + 1].split(",")]
    check(h[0] < 1e-9 * G and h[1] > 1e3 / K, "HOLZAPFEL C10 and 1/D negligible")
    check(h[2:] == [k1, k2, kappa], f"HOLZAPFEL k1, k2, kappa {h[2:]}")
    i, kw = data("*ORIENTATION")
    for k, d in enumerate(directions):
        v = [float(x) for x in lines[i + 3 + k].split(",")]
        check(all(close(x, y, 1e-15) for x, y in zip(v, d)), f"orientation direction {k + 1}: {v}")

    for f in failures:
        print("FAIL:", f)
    print(f"{1 if not failures else 0} passed, {1 if failures else 0} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
