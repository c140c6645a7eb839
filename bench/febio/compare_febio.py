#!/usr/bin/env python3
"""Compares a FEBio run of a model written by bench_febio_export with `softhom macro` on the same scene.

usage: compare_febio.py MODEL.feb SOFTHOM_MACRO_OUT [--point SOFTHOM_POINT_OUT]

Reads FEBio's logfiles next to MODEL.feb (MODEL.feb.nodes.csv: ux;uy;uz of every node at every step;
MODEL.feb.<set>.reactions.csv: Rx;Ry;Rz of the driven node sets) and MODEL.feb.probes.json, and
softhom's fields.h5 (nodal displacement per output step) and response.csv. Prints per step: the max
nodal displacement difference relative to max |u| (softhom), and the structure's probes from both codes
(plate: nominal stress, and P11 of `softhom point` when given; tube: inner radius, axial stretch,
twist). Needs /usr/bin/python3 with numpy and h5py (Debian python3-numpy, python3-h5py).
"""
import argparse
import csv
import json
import math
import pathlib
import sys

import h5py
import numpy as np


def read_febio_log(path):
    """FEBio logfile: '*Step = n', '*Time = t', '*Data = a;b;c' headers, then 'id,v1,v2,...' rows."""
    steps, time, rows = [], None, {}
    for line in pathlib.Path(path).read_text().splitlines():
        line = line.strip()
        if line.startswith("*Time"):
            if time is not None:
                steps.append((time, rows))
            time, rows = float(line.split("=")[1]), {}
        elif line and not line.startswith("*"):
            v = [float(x) for x in line.replace(" ", ",").split(",") if x]
            rows[int(v[0])] = v[1:]
    if time is not None:
        steps.append((time, rows))
    return steps


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("feb")
    ap.add_argument("softhom")
    ap.add_argument("--point")
    a = ap.parse_args()
    feb = pathlib.Path(a.feb)
    probes = json.loads(pathlib.Path(str(feb) + ".probes.json").read_text())
    X = np.array(probes["nodes"])
    log = read_febio_log(feb.parent / (feb.name + ".nodes.csv"))
    h5 = h5py.File(pathlib.Path(a.softhom) / "fields.h5", "r")
    with open(pathlib.Path(a.softhom) / "response.csv") as f:
        resp = list(csv.DictReader(f))
    point = None
    if a.point:
        with open(pathlib.Path(a.point) / "response.csv") as f:
            point = {round(float(r["t"]), 9): float(r["P11"]) for r in csv.DictReader(f)}
    reactions = {s: read_febio_log(feb.parent / f"{feb.name}.{s}.reactions.csv") for s in probes["driven_sets"]}
    kind = probes["kind"]  # macro::StructureKind: 0 plate, 1 tube
    worst = 0.0
    print("step  t        max|du|/max|u|  probes FEBio | softhom")
    times = probes["times"]
    react_at = {s: {round(t, 6): rows for t, rows in reactions[s]} for s in reactions}
    for t, rows in log:
        # softhom's step k is at times[k - 1]; FEBio's records are matched by time (t = 0 skipped).
        matches = [k for k, tk in enumerate(times, start=1) if abs(tk - t) <= 1e-6 * max(1.0, times[-1])]
        if not matches:
            continue
        k = matches[0]
        uf = np.array([rows[i + 1][:3] for i in range(len(X))])
        key = f"step_{k:06d}"  # io::step_group_name
        if key not in h5:
            break
        us = h5[key]["displacement"][()]
        rel = np.abs(uf - us).max() / max(np.abs(us).max(), 1e-300)
        worst = max(worst, rel)
        r = resp[k]
        if kind == 0:
            force = sum(sum(v[0] for v in react_at[s][round(t, 6)].values()) for s in reactions)
            s_f = force / probes["plate_section"]
            extra = f"nominal stress {s_f:.9g} | {float(r['nominal_stress']):.9g}"
            if point and round(t, 9) in point:
                extra += f" | point P11 {point[round(t, 9)]:.9g}"
        else:
            x = X + uf
            inner = probes["inner_nodes"]
            radius = np.mean([math.hypot(*x[n][:2]) for n in inner])
            z = Z = tw = 0.0
            cnt = 0
            for n in probes["end_nodes"]:
                if math.hypot(*X[n][:2]) < probes["inner_radius"] - 1e-9:
                    continue
                z += x[n][2]
                Z += X[n][2]
                tw += math.remainder(math.atan2(x[n][1], x[n][0]) - math.atan2(X[n][1], X[n][0]), 2 * math.pi)
                cnt += 1
            extra = (f"inner radius {radius:.9g} | {float(r['inner_radius']):.9g}, axial stretch {z / Z:.9g} | "
                     f"{float(r['axial_stretch']):.9g}, twist {math.degrees(tw / cnt):.6g} | {float(r['twist_deg']):.6g} deg")
        print(f"{k:4d}  {t:<8.4g} {rel:.3e}       {extra}")
    print(f"max over steps of max nodal |u_FEBio - u_softhom| / max |u_softhom|: {worst:.3e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
