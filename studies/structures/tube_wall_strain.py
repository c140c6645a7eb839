#!/usr/bin/env python3
"""The membrane state of a pressurized tube's wall, from a `softhom macro` run with fields.

Reads <out>/fields.h5 of a tube scene (quadratic tets, `[output] fields = [t]`) and averages over the
gauge section (reference z in [z0, z1], the whole circumference) and over slices of the wall's reference
radius R: the deformation gradient at the tet10 Gauss points, in the cylindrical frames of the reference
(E_R, E_Θ, E_Z) and current (e_r, e_θ, e_z) points, and the first Piola-Kirchhoff stress P = J σ F⁻ᵀ of
each element (σ the element's Cauchy stress of the fields, F its mean). The columns are those of a
plate cell whose load frame is e1 = axis, e2 = hoop: F11 = ∂z/∂Z (axial stretch), F22 = r/R (hoop),
F21 = r ∂θ/∂Z (the twist's in-plane shear), F12 = ∂z/(R∂Θ), F33 = ∂r/∂R.

Averaging over the whole circumference of a slice of the helically periodic wall is averaging over its
unit cell. The wall's own forces are checked against the closed tube's equilibrium (current inner
radius r_i, pressure p): hoop ∫ P22 dR = p r_i λz, axial 2π ∫ P11 R dR = p π r_i², torque 0.

    /usr/bin/python3 studies/structures/tube_wall_strain.py OUT/fields.h5 --inner-radius 1.5 \\
        --wall 0.74 --gauge 2.25 6.75 --pressure 0.01 [--slices 8] [--step -1]

Needs numpy and h5py.
"""
import argparse

import h5py
import numpy as np

# 4-point Gauss rule on the unit tetrahedron (exact for quadratics).
_A, _B = 0.5854101966249685, 0.1381966011250105
GAUSS = np.array([[_B, _B, _B], [_A, _B, _B], [_B, _A, _B], [_B, _B, _A]])
GAUSS_W = np.full(4, 1.0 / 24.0)
# Edge nodes of a 10-node tet in the fields' (VTK) order.
EDGES = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]


def tet10_gradients(xi):
    """∂N/∂ξ (10 × 3) of the quadratic tet at local point xi (VTK node order)."""
    l = np.array([1.0 - xi.sum(), xi[0], xi[1], xi[2]])
    dl = np.array([[-1.0, -1.0, -1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    dN = np.zeros((10, 3))
    for a in range(4):
        dN[a] = (4.0 * l[a] - 1.0) * dl[a]
    for k, (a, b) in enumerate(EDGES):
        dN[4 + k] = 4.0 * (l[a] * dl[b] + l[b] * dl[a])
    return dN


def tet10_values(xi):
    l = np.array([1.0 - xi.sum(), xi[0], xi[1], xi[2]])
    N = np.zeros(10)
    for a in range(4):
        N[a] = l[a] * (2.0 * l[a] - 1.0)
    for k, (a, b) in enumerate(EDGES):
        N[4 + k] = 4.0 * l[a] * l[b]
    return N


def cylindrical_basis(p):
    """Rows e_r, e_θ, e_z at the points p (n × 3) → n × 3 × 3."""
    th = np.arctan2(p[:, 1], p[:, 0])
    c, s = np.cos(th), np.sin(th)
    z, o = np.zeros_like(c), np.ones_like(c)
    return np.stack([np.stack([c, s, z], 1), np.stack([-s, c, z], 1), np.stack([z, z, o], 1)], 1)


def to_plate_frame(F_cyl):
    """(r, θ, z) components → the plate cell's (1 = axis, 2 = hoop, 3 = radial)."""
    order = [2, 1, 0]
    return F_cyl[..., order, :][..., :, order]


def read_fields(path, step):
    with h5py.File(path, "r") as h:
        X = h["mesh/coordinates"][...]
        conn = h["mesh/connectivity"][...]
        steps = sorted((k for k in h if k.startswith("step_")), key=lambda k: int(k.split("_")[1]))
        g = h[steps[step]]
        return X, conn, g["displacement"][...], g["sigma"][...].reshape(-1, 3, 3)


def gauss_points(X, conn, u):
    """Reference positions, weights and F at the 4 Gauss points of every tet10 (element-major)."""
    Xe, ue = X[conn], u[conn]  # ne × 10 × 3
    pos, wts, Fs = [], [], []
    for xi, w in zip(GAUSS, GAUSS_W):
        dN = tet10_gradients(xi)
        J = np.einsum("eai,aj->eij", Xe, dN)  # ∂X/∂ξ
        Jinv = np.linalg.inv(J)
        grad_u = np.einsum("eai,aj,ejk->eik", ue, dN, Jinv)
        Fs.append(np.eye(3) + grad_u)
        wts.append(w * np.linalg.det(J))
        pos.append(np.einsum("eai,a->ei", Xe, tet10_values(xi)))
    return np.stack(pos, 1), np.stack(wts, 1), np.stack(Fs, 1)


def wall_fields(X, conn, u, sigma):
    """Per Gauss point: reference position, weight, and in the plate frame F, P = J σ F⁻ᵀ and the
    plate-equivalent P_eq = J (σ − σ_rr I) F⁻ᵀ (the same deformation with the radial stress shifted
    out: equal for an incompressible material, which the matrix is; the stiff fibers hardly strain
    under it), and σ_rr. σ is the element's, F at the point; frames: Q(x) F Q(X)ᵀ."""
    pos, w, F = gauss_points(X, conn, u)
    ne = conn.shape[0]
    ucur = np.stack([np.einsum("eai,a->ei", u[conn], tet10_values(xi)) for xi in GAUSS], 1).reshape(-1, 3)
    Xg = pos.reshape(-1, 3)
    Qx, QX = cylindrical_basis(Xg + ucur), cylindrical_basis(Xg)
    Fg = F.reshape(-1, 3, 3)
    sg = np.repeat(sigma, 4, axis=0)
    srr = np.einsum("ni,nij,nj->n", Qx[:, 0], sg, Qx[:, 0])
    cof = np.linalg.det(Fg)[:, None, None] * np.transpose(np.linalg.inv(Fg), (0, 2, 1))
    P = np.einsum("nij,njk->nik", sg, cof)
    Peq = P - srr[:, None, None] * cof

    def frame(A):
        return to_plate_frame(np.einsum("nij,njk,nlk->nil", Qx, A, QX)).reshape(ne, 4, 3, 3)

    return pos, w, frame(Fg), frame(P), frame(Peq), srr.reshape(ne, 4)


def slice_means(R, w, in_wall, edges, fields):
    """Means of each field over the wall's slices R in [lo, hi) (weights: reference volume)."""
    rows = []
    for k, (lo, hi) in enumerate(zip(edges[:-1], edges[1:])):
        m = in_wall & (R >= lo) & ((R < hi) | (k == len(edges) - 2))
        rows.append([(w[m].reshape((-1,) + (1,) * (f.ndim - 2)) * f[m]).sum(0) / w[m].sum() for f in fields])
    return [np.array(c) for c in zip(*rows)]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("fields")
    ap.add_argument("--inner-radius", type=float, required=True)
    ap.add_argument("--wall", type=float, required=True, help="wall thickness")
    ap.add_argument("--gauge", type=float, nargs=2, required=True, help="reference z range")
    ap.add_argument("--pressure", type=float, required=True, help="internal pressure at that step [MPa]")
    ap.add_argument("--slices", type=int, default=8)
    ap.add_argument("--step", type=int, default=-1)
    a = ap.parse_args()

    X, conn, u, sigma = read_fields(a.fields, a.step)
    if conn.shape[1] != 10:
        raise SystemExit("tube_wall_strain: the fields' mesh must be 10-node tets")
    pos, w, F, P, Peq, srr = wall_fields(X, conn, u, sigma)
    Ri, t, p = a.inner_radius, a.wall, a.pressure
    R = np.hypot(pos[..., 0], pos[..., 1])
    in_wall = (pos[..., 2] >= a.gauge[0]) & (pos[..., 2] <= a.gauge[1]) & (R <= Ri + t + 1e-9)
    edges = np.linspace(Ri, Ri + t, a.slices + 1)
    Rs = 0.5 * (edges[:-1] + edges[1:])
    Fs, Ps, Peqs, srrs = slice_means(R, w, in_wall, edges, [F, P, Peq, srr])

    print(f"gauge Z = {a.gauge[0]} … {a.gauge[1]}, wall R = {Ri} … {Ri + t}, {a.slices} slices (reference-volume means); "
          "plate frame 1 = axis, 2 = hoop, 3 = radial")
    print("R        F11      F22      F21      F12      F33     | σrr       P11      P22      P21     | P_eq11   P_eq22   P_eq21  [MPa]")
    for r, f, pp, pe, s in zip(Rs, Fs, Ps, Peqs, srrs):
        print(f"{r:.4f}  {f[0, 0]:.5f}  {f[1, 1]:.5f}  {f[1, 0]:+.5f}  {f[0, 1]:+.5f}  {f[2, 2]:.5f} | {s:+.5f}  "
              f"{pp[0, 0]:.5f}  {pp[1, 1]:.5f}  {pp[1, 0]:+.5f} | {pe[0, 0]:.5f}  {pe[1, 1]:.5f}  {pe[1, 0]:+.5f}")

    # Thickness means: flat (the plate cell's section mean, weight dR) and by volume (weight R dR).
    def flat(A):
        return A.mean(0)

    def vol(A):
        return (Rs.reshape((-1,) + (1,) * (A.ndim - 1)) * A).sum(0) / Rs.sum()

    for name, mean in (("flat (dR)", flat), ("volume (R dR)", vol)):
        f = mean(Fs)
        print(f"thickness mean, {name}: F11 {f[0, 0]:.5f}  F22 {f[1, 1]:.5f}  F21 {f[1, 0]:+.5f}  F12 {f[0, 1]:+.5f}  "
              f"F33 {f[2, 2]:.5f};  σrr {mean(srrs):+.5f}")

    # The closed tube's equilibrium from the current inner radius and the gauge's axial stretch.
    inner = (np.abs(np.hypot(X[:, 0], X[:, 1]) - Ri) < 1e-6) & (X[:, 2] >= a.gauge[0]) & (X[:, 2] <= a.gauge[1])
    ri = np.hypot((X + u)[inner, 0], (X + u)[inner, 1]).mean()
    lz = flat(Fs)[0, 0]
    N22, N11 = p * ri * lz, p * ri * ri / (2.0 * (Ri + 0.5 * t))
    dP = flat(Peqs) - flat(Ps)  # the radial stress shifted out, hoop; axial by volume
    dP11 = vol(Peqs)[0, 0] - vol(Ps)[0, 0]
    print(f"current inner radius r_i = {ri:.5f} (λ_i {ri / Ri:.5f}); per unit reference length, N = t P̄:")
    print(f"  hoop  N22 = p r_i λz              = {N22:.6f} N/mm, P̄22 = {N22 / t:.6f};  the wall's ∫P22 dR / t = {flat(Ps)[1, 1]:.6f}")
    print(f"  axial N11 = p π r_i² / (2π R_m)   = {N11:.6f} N/mm, P̄11 = {N11 / t:.6f};  the wall's ∫P11 R dR / (R_m t) = {vol(Ps)[0, 0]:.6f}")
    print(f"  shear N21 = 0 (torque-free cap);  the wall's ∫P21 R dR / (R_m t) = {vol(Ps)[1, 0]:+.6f}")
    print(f"  plate-equivalent (σrr shifted out): P̄11 = {N11 / t + dP11:.6f}, P̄22 = {N22 / t + dP[1, 1]:.6f} "
          f"(equilibrium + ⟨−σrr J F⁻ᵀ⟩: +{dP11:.6f}, +{dP[1, 1]:.6f}); the wall's own P_eq: "
          f"{vol(Peqs)[0, 0]:.6f}, {flat(Peqs)[1, 1]:.6f}, P21 {vol(Peqs)[1, 0]:+.6f}")


if __name__ == "__main__":
    main()
