#!/usr/bin/env python3
"""The long closed tube of a homogenized tube scene, solved exactly through its thick wall.

Far from the clamp and the cap a long tube under internal pressure p is in a helically uniform state:
every point of reference radius R moves to r(R), turns by τ Z and stretches axially by λz. For an
incompressible wall r² = r_i² + (R² − R_i²)/λz, and with the fibers in the wall's plane the deformation
gradient in the (axis, hoop, radial) frame is F = [[λz, 0, 0], [r τ, r/R, 0], [0, 0, R/(r λz)]]: no
transverse shear is needed, the law gives σ_rz = σ_rθ = 0. Three conditions fix (λz, r_i, τ):
radial equilibrium dσ_rr/dr = (σ_θθ − σ_rr)/r from σ_rr(r_i) = −p to σ_rr(r_o) = 0, the axial force
2π ∫ σ_zz r dr = p π r_i² (the closed end) and no torque, ∫ σ_θz r² dr = 0 (the free cap). The law
is the scene's `[material]` (evaluated by the softhom module at J = 1, σ − σ_rr I from its
deviatoric part).

Two walls:
- `smeared`: the law at every radius: the homogenized tube of the scene, in the limit of a fine mesh
  and a long tube (its gauge section).
- `fiber-layer`: the law's fiber-stretch term (Ef, docs/model.md §2.1) weighted through the thickness
  by the fiber fraction at each depth of ONE layer of circular fibers of radius r_f at mid-wall
  (2 √(r_f² − (R − R_m)²) t / (π r_f²), which integrates to t), the matrix and shear terms at every
  radius: the wall of the resolved tube, with the fibers' stiffness where the fibers are.

    PYTHONPATH=build/python /usr/bin/python3 studies/structures/thick_tube.py \\
        studies/structures/calibrated_plate_ecoflex_a60_long.toml [--fiber-radius 0.2] [--gauge 4.5] \\
        [--compare OUT/device.csv ...]

prints for each output pressure of the scene's load path λz, the inner and outer radial stretch, the
twist over the gauge length (device.csv's twist_gauge_deg: the middle half of the tube), and the
fiber stretch at the inner face, mid-wall and outer face; --compare prints the same columns of
device.csv files (resolved or homogenized runs) at those pressures.
"""
import argparse
import csv
import math
import pathlib
import tomllib

import numpy as np
from scipy.optimize import fsolve

import softhom

POINTS = 201  # radial points (trapezoid rule); 801 changes the stretches by < 3e-5, the twist rate by 1e-5


def split_law(material, angle):
    """The scene's law with its fiber at `angle` from the axis in the (axis, hoop, radial) frame, and the
    same law without its fiber-stretch term (Ef = 0)."""
    spec = dict(material, fibers=[{"direction": [math.cos(angle), math.sin(angle), 0.0]}])
    return softhom.material(spec), softhom.material(dict(spec, Ef=0.0))


def in_plane_stress(law, lz, lt, gamma):
    """σ − σ_rr I (Cauchy, the radial stress shifted out) at J = 1, per radius: n × 3 × 3."""
    n = len(lt)
    F = np.zeros((n, 3, 3))
    F[:, 0, 0], F[:, 1, 1], F[:, 1, 0], F[:, 2, 2] = lz, lt, gamma, 1.0 / (lz * lt)
    P, _, _ = law.evaluate(F, tangent=False)
    s = np.einsum("nij,nkj->nik", P, F)
    return s - s[:, 2, 2][:, None, None] * np.eye(3)


class Wall:
    def __init__(self, scene, fiber_radius):
        tube = scene["helix_tube"]
        self.Ri, self.t = tube["inner_radius"], tube["wall_thickness"]
        self.R = np.linspace(self.Ri, self.Ri + self.t, POINTS)
        angle = math.radians(scene["material"]["fibers"][0]["angle_deg"])  # from the axis (fiber_frame cylindrical)
        self.full, self.matrix = split_law(scene["material"], angle)
        d = self.R - (self.Ri + 0.5 * self.t)
        chord = 2.0 * np.sqrt(np.clip(fiber_radius ** 2 - d * d, 0.0, None))
        self.weights = {"smeared": np.ones(POINTS), "fiber-layer": chord * self.t / (math.pi * fiber_radius ** 2)}
        self.a = np.array([math.cos(angle), math.sin(angle)])  # (axis, hoop)

    def kinematics(self, lz, ri, tau):
        r = np.sqrt(ri * ri + (self.R ** 2 - self.Ri ** 2) / lz)
        return r, r / self.R, r * tau, self.R / (r * lz)

    def stress(self, wall, lz, ri, tau):
        r, lt, gamma, drdR = self.kinematics(lz, ri, tau)
        m = in_plane_stress(self.matrix, lz, lt, gamma)
        f = in_plane_stress(self.full, lz, lt, gamma) - m
        return r, drdR, m + self.weights[wall][:, None, None] * f

    def residual(self, x, wall, p):
        lz, ri, tau = x
        r, drdR, s = self.stress(wall, lz, ri, tau)
        g = s[:, 1, 1] / r * drdR  # dσ_rr/dR
        srr = -p + np.concatenate([[0.0], np.cumsum(0.5 * (g[1:] + g[:-1]) * np.diff(self.R))])
        axial = np.trapz((s[:, 0, 0] + srr) * 2 * math.pi * r * drdR, self.R) - p * math.pi * ri * ri
        torque = np.trapz(s[:, 1, 0] * 2 * math.pi * r * r * drdR, self.R)
        return [srr[-1] / p, axial / (p * math.pi * self.Ri ** 2), torque / (p * self.Ri ** 3)]

    def solve(self, wall, p, guess):
        x, info, ok, msg = fsolve(self.residual, guess, args=(wall, p), xtol=1e-11, full_output=True)
        if ok != 1:
            raise SystemExit(f"thick_tube: {wall} wall at p = {p}: {msg}")
        return x

    def fiber_stretch(self, lz, ri, tau):
        _, lt, gamma, _ = self.kinematics(lz, ri, tau)
        v = np.stack([np.full_like(lt, lz * self.a[0]), gamma * self.a[0] + lt * self.a[1]], 1)
        lf = np.linalg.norm(v, axis=1)
        return lf[0], np.interp(self.Ri + 0.5 * self.t, self.R, lf), lf[-1]


def pressures(scene):
    path = scene["load"]["path"]
    steps = scene["load"].get("steps", 1)
    t1, p1 = path[-1]
    return [p1 * k / steps for k in range(1, steps + 1)]


def device_rows(path, ps):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    out = []
    for p in ps:
        r = min(rows, key=lambda row: abs(float(row["pressure_kPa"]) - 1e3 * p))
        out.append((float(r["axial_stretch"]), float(r["radial_stretch_inner"]), float(r["radial_stretch_outer"]),
                    float(r["twist_gauge_deg"])))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", type=pathlib.Path, help="a homogenized tube scene ([helix_tube], [material], [load])")
    ap.add_argument("--fiber-radius", type=float, default=0.2, help="mm, for the fiber-layer wall")
    ap.add_argument("--gauge", type=float, help="reference gauge length for the twist (default: half the tube)")
    ap.add_argument("--compare", nargs="*", default=[], help="device.csv files to print beside")
    a = ap.parse_args()
    scene = tomllib.loads(a.scene.read_text())
    wall = Wall(scene, a.fiber_radius)
    gauge = a.gauge or 0.5 * scene["helix_tube"]["length"]
    ps = pressures(scene)
    print(f"{'wall':28s} {'p [kPa]':>8s} {'λz':>8s} {'λr inner':>9s} {'λr outer':>9s} {'twist gauge':>12s}   "
          "fiber stretch inner / mid / outer")
    for kind in ("smeared", "fiber-layer"):
        x = np.array([1.0, wall.Ri, 0.0])
        for p in ps:
            x = wall.solve(kind, p, x)
            lz, ri, tau = x
            ro = math.sqrt(ri * ri + ((wall.Ri + wall.t) ** 2 - wall.Ri ** 2) / lz)
            lf = wall.fiber_stretch(lz, ri, tau)
            print(f"{kind:28s} {1e3 * p:8.3f} {lz:8.5f} {ri / wall.Ri:9.5f} {ro / (wall.Ri + wall.t):9.5f} "
                  f"{math.degrees(tau) * gauge:+11.2f}°   {lf[0]:.4f} / {lf[1]:.4f} / {lf[2]:.4f}")
    for path in a.compare:
        for p, (lz, li, lo, tw) in zip(ps, device_rows(path, ps)):
            print(f"{str(path)[-28:]:28s} {1e3 * p:8.3f} {lz:8.5f} {li:9.5f} {lo:9.5f} {tw:+11.2f}°")


if __name__ == "__main__":
    main()
