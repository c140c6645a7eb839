#!/usr/bin/env python3
"""Tied fibers against resolved fibers on the same tube, as the fibers get thinner.

The short Ecoflex tube of resolved_coarse.toml (R_i = 1.5 mm, wall 0.74 mm, 1.5 mm long, glass cap,
clamped at z = 0, internal pressure: 1 kPa in one step by default) with 11 fibers on a 45° helix at mid-wall, of radius r. For each r
the one mesh of studies/meshes/helix_tube.geo (fiber regions conforming, fiber_mesh_size = c r in and
near them) carries four models:
  resolved   the fiber regions glass (neo-Hookean, E = 10 MPa, nu = 0.3),
  tied       the fiber regions Ecoflex, plus [[fibers]] along the same centrelines: area pi r^2,
             law "neo-hookean" (N = (E/3) A (lambda - lambda^-2), the glass rod's uniaxial response
             within 0.8 % to 10 % stretch; the linear law is 5-10 % stiffer), E = 10 MPa,
  tied_vc    the same with volume_correction = true (the matrix's own uniaxial stress removed over A),
  matrix     the fiber regions Ecoflex, no fibers.
It prints axial stretch, outer radial stretch and end twist (device.csv of [device] kind = "tube"), and
the tied models' difference from the resolved one relative to the fibers' effect (resolved - matrix),
with its observed order in r between neighbouring radii. Finished runs are kept in OUT/<name>/.

    OMP_NUM_THREADS=1 nice python3 studies/structures/tied_vs_resolved.py --softhom build/apps/softhom \\
        --out out/tied-thin --radii 0.28 0.2 0.14 0.1 --refine 0.2 --vc 0.2   # --refine: that r on h 0.25, 0.7 r
    python3 studies/structures/tied_vs_resolved.py --out out/tied-thin --table      # the table only
"""
import argparse
import csv
import json
import math
import os
import pathlib
import re
import subprocess

HERE = pathlib.Path(__file__).resolve().parent
GEO = HERE.parent / "meshes" / "helix_tube.geo"
RI, WALL, LENGTH, ANGLE, COUNT = 1.5, 0.74, 1.5, 45.0, 11
RM = RI + 0.5 * WALL
QUANTITIES = [("axial_stretch", "λz − 1", 1.0), ("radial_stretch_outer", "λr − 1", 1.0), ("twist_end_deg", "twist°", 0.0)]
MODELS = ["resolved", "tied", "tied_vc", "matrix"]
BASIC = ["resolved", "tied", "matrix"]  # tied_vc at the radii of --vc only: it moves by ~E_matrix / E_fiber

SCENE = """description = "Tied against resolved fibers: {model}, r = {r} mm (studies/structures/tied_vs_resolved.py)"
[geometry]
type = "gmsh"
geo = "{geo}"
mesh_size = {h}
fiber_frame = "cylindrical"
[helix_tube]
inner_radius = {ri}
wall_thickness = {wall}
length = {length}
cap_thickness = 0.5
helix_angle_deg = {angle}
fibers = {count}
fiber_radius = {r}
fiber_mesh_size = {hf}
[material]
preset = "ecoflex"
[regions.fibers]
preset = "{fiber_region}"
[regions.cap]
preset = "glass"
[[boundary]]
surface = "zmin"
fix = ["x", "y", "z"]
[load]
control = "pressure"
surface = "inner"
cavity_mask = [1, 1, 0]
path = [[0.0, 0.0], [1.0, {p_mpa}]]
steps = {steps}
[solver]
linear_solver = "cholmod"   # every run on the direct route (auto takes GMRES from 1e5 dofs, slow with tied fibers)
[output]
fields = false
[device]
kind = "tube"
{fibers}"""

FIBERS = """[[fibers]]
geometry = "helix"
angle_deg = {angle}
radius = {rm}
start_deg = [{starts}]
z_from = 0.0
z_to = {length}
elements = {elements}
law = "neo-hookean"
modulus = 10.0
area = {area:.6g}
volume_correction = {vc}
"""


def start_angles(r):
    """The geo's fiber k starts at azimuth 2 pi k / n at z0 = -ext below the wall (its pipe is swept past
    both ends), so at z = 0 it has turned by ext tan(alpha) / R_m."""
    tan = math.tan(math.radians(ANGLE))
    ext = r * (1.0 + tan) + 0.1 * WALL
    phi0 = math.degrees(ext * tan / RM)
    return ", ".join(f"{phi0 + 360.0 * k / COUNT:.9g}" for k in range(COUNT))


def scene_text(model, r, h, c, p_kpa, steps):
    hf = c * r
    fibers = ""
    if model in ("tied", "tied_vc"):
        length = LENGTH / math.cos(math.radians(ANGLE))
        fibers = FIBERS.format(angle=ANGLE, rm=RM, starts=start_angles(r), length=LENGTH,
                               elements=math.ceil(length / hf), area=math.pi * r * r,
                               vc="true" if model == "tied_vc" else "false")
    return SCENE.format(model=model, r=r, geo=GEO, h=h, ri=RI, wall=WALL, length=LENGTH, angle=ANGLE, count=COUNT,
                        hf=f"{hf:.6g}", fiber_region="glass" if model == "resolved" else "ecoflex",
                        p_mpa=p_kpa / 1000.0, steps=steps, fibers=fibers)


def name(model, r, h, c):
    return f"{model}-r{r}-h{h}-c{c}"


def run(args, model, r, h, c):
    dest = args.out / name(model, r, h, c)
    if (dest / "summary.json").exists():
        return
    args.out.mkdir(parents=True, exist_ok=True)
    scene = args.out / f"{name(model, r, h, c)}.toml"
    scene.write_text(scene_text(model, r, h, c, args.pressure, args.steps))
    env = dict(os.environ, SOFTHOM_MESH_CACHE=str(args.out / "mesh-cache"))
    print(f"running {name(model, r, h, c)}", flush=True)
    subprocess.run([args.softhom, "macro", str(scene), "--out", str(dest), "-q"], env=env, check=False)


def load(out, model, r, h, c):
    dest = out / name(model, r, h, c)
    try:
        text = (dest / "summary.json").read_text()
        with open(dest / "device.csv") as f:
            last = list(csv.DictReader(f))[-1]
    except (OSError, ValueError, IndexError):
        return None
    wall = re.search(r'"wall_time_s": ([0-9.eE+-]+)', text)
    dofs = re.search(r'"dofs": ([0-9]+)', text)
    values = [float(last[q]) - base for q, _, base in QUANTITIES]
    return {"values": values, "wall": float(wall.group(1)) if wall else float("nan"),
            "dofs": int(dofs.group(1)) if dofs else 0}


def relative_differences(runs, models=("tied", "tied_vc")):
    """(tied − resolved) / (resolved − matrix) per quantity, for each tied model."""
    res, mat = runs["resolved"]["values"], runs["matrix"]["values"]
    return {m: [(t - a) / (a - b) for t, a, b in zip(runs[m]["values"], res, mat)] for m in models}


def table(args):
    rows, diffs = {}, {}
    print(f"\np = {args.pressure} kPa, mesh_size {args.h} mm, fiber_mesh_size {args.c} r")
    print("| r [mm] | VF | model | " + " | ".join(label for _, label, _ in QUANTITIES) + " | dofs | wall [s] |")
    print("|---|---|---|---|---|---|---|---|")
    spacing = 2.0 * math.pi * RM * math.cos(math.radians(ANGLE)) / COUNT
    for r in args.radii:
        runs = {m: load(args.out, m, r, args.h, args.c) for m in MODELS}
        runs = {m: v for m, v in runs.items() if v is not None or m != "tied_vc"}
        if any(v is None for v in runs.values()):
            print(f"| {r} | missing runs: {[m for m, v in runs.items() if v is None]} |")
            continue
        rows[r] = relative_differences(runs, [m for m in ("tied", "tied_vc") if m in runs])
        diffs[r] = [t - a for t, a in zip(runs["tied"]["values"], runs["resolved"]["values"])]
        for m in runs:
            v = runs[m]
            print(f"| {r} | {math.pi * r * r / (spacing * WALL):.3f} | {m} | " +
                  " | ".join(f"{x:.5f}" for x in v["values"]) + f" | {v['dofs']} | {v['wall']:.1f} |")
    print("\n(tied − resolved) / (resolved − matrix), observed order between neighbouring radii:")
    print("| r [mm] | model | " + " | ".join(label for _, label, _ in QUANTITIES) + " |")
    print("|---|---|---|---|---|")
    radii = [r for r in args.radii if r in rows]
    for i, r in enumerate(radii):
        for m in rows[r]:
            cells = []
            for k in range(len(QUANTITIES)):
                e = rows[r][m][k]
                text = f"{100 * e:+.1f} %"
                if i > 0 and m in rows[radii[i - 1]] and rows[radii[i - 1]][m][k] * e > 0:
                    order = math.log(rows[radii[i - 1]][m][k] / e) / math.log(radii[i - 1] / r)
                    text += f" (order {order:.2f})"
                cells.append(text)
            print(f"| {r} | {m} | " + " | ".join(cells) + " |")
    print("\ntied − resolved (absolute), observed order between neighbouring radii:")
    print("| r [mm] | " + " | ".join(label for _, label, _ in QUANTITIES) + " |")
    print("|---|---|---|---|")
    for i, r in enumerate(radii):
        cells = []
        for k in range(len(QUANTITIES)):
            d = diffs[r][k]
            text = f"{d:+.5f}"
            if i > 0 and diffs[radii[i - 1]][k] * d > 0:
                text += f" (order {math.log(diffs[radii[i - 1]][k] / d) / math.log(radii[i - 1] / r):.2f})"
            cells.append(text)
        print(f"| {r} | " + " | ".join(cells) + " |")
    for r in args.refine:
        base = {m: load(args.out, m, r, args.h, args.c) for m in BASIC}
        fine = {m: load(args.out, m, r, args.fine_h, args.fine_c) for m in BASIC}
        if any(v is None for v in base.values()) or fine["resolved"] is None:
            continue
        effect = [a - b for a, b in zip(base["resolved"]["values"], base["matrix"]["values"])]
        print(f"\nmesh sensitivity at r = {r}: mesh_size {args.fine_h}, fiber_mesh_size {args.fine_c} r; in brackets "
              "the change from the mesh above relative to the fibers' effect")
        for m, v in fine.items():
            if v is None:
                continue
            change = [(f - b) / e for f, b, e in zip(v["values"], base[m]["values"], effect)]
            print(f"| {m} | " + " | ".join(f"{x:.5f} ({100 * d:+.1f} %)" for x, d in zip(v["values"], change)) +
                  f" | {v['dofs']} | {v['wall']:.1f} |")
        if all(v is not None for v in fine.values()):
            rel = relative_differences(fine, ("tied",))["tied"]
            print("| tied rel. diff | " + " | ".join(f"{100 * e:+.1f} %" for e in rel) + " |")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--softhom", default="softhom")
    ap.add_argument("--out", type=pathlib.Path, required=True)
    ap.add_argument("--radii", type=float, nargs="+", default=[0.28, 0.2, 0.14, 0.1])
    ap.add_argument("--h", type=float, default=0.3, help="mesh_size away from the fibers [mm]")
    ap.add_argument("--c", type=float, default=1.0, help="fiber_mesh_size / r")
    ap.add_argument("--vc", type=float, nargs="*", default=[], help="radii also run with the volume correction")
    ap.add_argument("--refine", type=float, nargs="*", default=[], help="radii run again on the finer mesh")
    ap.add_argument("--fine-h", type=float, default=0.25)
    ap.add_argument("--fine-c", type=float, default=0.7)
    ap.add_argument("--pressure", type=float, default=1.0, help="kPa (resolved_coarse.toml's: the fibers' effect is linear there)")
    ap.add_argument("--steps", type=int, default=1)
    ap.add_argument("--table", action="store_true", help="print the table of the finished runs only")
    args = ap.parse_args()
    if not args.table:
        for r in args.radii:
            for m in BASIC:
                run(args, m, r, args.h, args.c)
        for r in args.refine:
            for m in BASIC:
                run(args, m, r, args.fine_h, args.fine_c)
        for r in args.vc:
            run(args, "tied_vc", r, args.h, args.c)
    table(args)


if __name__ == "__main__":
    main()
