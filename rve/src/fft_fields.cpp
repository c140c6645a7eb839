// Field output of the FFT solver: F, P, σ and von Mises per voxel, node displacements (fft_solver_impl.hpp).
#include "fft_solver_impl.hpp"

#include "laminate.hpp"

namespace softhom::rve {

void FftRveSolver::Impl::put_voxel_fields(RveFields& f, std::size_t v, const Mat3& Fm, const Mat3& Pm, const Mat3& Sm) {
  const Mat3 dev = Sm - Sm.trace() / 3.0 * Mat3::Identity();
  f.von_mises[v] = std::sqrt(1.5 * ddot(dev, dev));
  for (int c = 0; c < 9; ++c) {
    f.F[9 * v + c] = Fm(c / 3, c % 3);
    f.P[9 * v + c] = Pm(c / 3, c % 3);
    f.sigma[9 * v + c] = Sm(c / 3, c % 3);
  }
}

Mat3 FftRveSolver::Impl::evaluated_stress(std::size_t v, const Mat3& F) const {
  Mat3 P = Mat3::Zero();
  if (comp_id[v] < 0) {
    const int x = pure_phase(v);
    mat[x]->evaluate(F, nullptr, nullptr, 0.0, P, nullptr);
    const double ratio = pressures.mixed[x] ? double(pressures.dP_ratio[v]) : 0.0;
    if (ratio != 0.0) {
      const detail::VolumetricState vs = detail::volumetric_state(pressures.K[x], F);
      P += ratio * (pressures.slope(x, v, compact.get()) - vs.ddU * vs.cof);
    }
    return P;
  }
  const double f = fraction(v);
  const Vec3& n = comp_normal[comp_id[v]];
  Mat3 Px[2], Fx[2];
  if (n.squaredNorm() == 0.0) {
    mat[1]->evaluate(F, nullptr, nullptr, 0.0, Px[1], nullptr);
    mat[0]->evaluate(F, nullptr, nullptr, 0.0, Px[0], nullptr);
    return f * Px[1] + (1.0 - f) * Px[0];
  }
  const std::size_t c = std::size_t(comp_id[v]);
  Vec3 a(lam_a_trial[3 * c], lam_a_trial[3 * c + 1], lam_a_trial[3 * c + 2]);
  laminate(F, f, n, a, v, 0.0, P, nullptr, Px, Fx);
  return P;
}

RveFields FftRveSolver::Impl::fields() {
  RveFields f;
  f.F.assign(9 * N, 0.0);
  f.P.assign(9 * N, 0.0);
  f.sigma.assign(9 * N, 0.0);
  f.von_mises.assign(N, 0.0);
  f.fiber_fraction.resize(N);
  for (std::size_t v = 0; v < N; ++v) f.fiber_fraction[v] = fraction(v);
  if (streamed) {
    displacement_to_real(u);
    const Mat3 Fg = to_grid(Fbar);
#pragma omp parallel
    stencil->gradient_pass(fft3->real(0), nullptr, [&](std::size_t p0, int count, const double* grad, double*) {
      for (int l = 0; l < count; ++l) {
        const std::size_t v = p0 + std::size_t(l);
        const Mat3 F = lane_F(Fg, grad, l);
        const Mat3 Fm = to_load(F), Pm = to_load(evaluated_stress(v, F));
        put_voxel_fields(f, v, Fm, Pm, cauchy_from_piola(Fm, Pm));
      }
    });
    f.displacement = node_displacement();
    return f;
  }
  // P of the last evaluation is in the real buffer, which ∇ũ overwrites next. One point per voxel
  // (rotated, spectral): P goes straight into the field and σ follows from the voxel's F and P; several
  // points (hex): σ is the mean of the points' σ, so the points' P are copied (9·nq fields).
  const bool one_point = nq == 1;
  std::vector<double> P;
  if (one_point) {
#pragma omp parallel for schedule(static)
    for (std::size_t v = 0; v < N; ++v) {
      Mat3 Pq;
      for (int c = 0; c < 9; ++c) Pq(c / 3, c % 3) = fft->real(c)[v];
      const Mat3 Pl = to_load(Pq);
      for (int c = 0; c < 9; ++c) f.P[9 * v + c] = Pl(c / 3, c % 3);
    }
  } else {
    P.assign(fft->real(0), fft->real(0) + 9 * NP);
  }
  gradient_to_real(u);
  const Mat3 Fg = to_grid(Fbar);
#pragma omp parallel for schedule(static)
  for (std::size_t v = 0; v < N; ++v) {
    Mat3 Fm = Mat3::Zero(), Pm = Mat3::Zero(), Sm = Mat3::Zero();
    for (int q = 0; q < nq; ++q) {
      const Mat3 Fq = point_F(Fg, v, q);
      const double w = op.quadrature()[q].weight;
      Fm += w * to_load(Fq);
      if (one_point) continue;
      Mat3 Pq;
      for (int c = 0; c < 9; ++c) Pq(c / 3, c % 3) = P[std::size_t(9 * q + c) * N + v];
      Pm += w * to_load(Pq);
      Sm += w * to_load(cauchy_from_piola(Fq, Pq));
    }
    if (one_point) {
      for (int c = 0; c < 9; ++c) Pm(c / 3, c % 3) = f.P[9 * v + c];
      Sm = cauchy_from_piola(Fm, Pm);  // frame-covariant: the same as in the grid frame, rotated
    }
    put_voxel_fields(f, v, Fm, Pm, Sm);
  }
  f.displacement = node_displacement();
  return f;
}

std::vector<double> FftRveSolver::Impl::node_displacement() {
  const auto [t, step] = vector_to_real(u);
  const Mat3 G = to_grid(Fbar) - Mat3::Identity();
  if (dist) return slab_node_displacement(*t, step, G);
  const std::array<int, 3>& n = grid.n;
  const std::size_t m1 = n[0] + 1, m2 = n[1] + 1, m3 = n[2] + 1;
  std::vector<double> out(3 * m1 * m2 * m3);
  for (std::size_t i3 = 0; i3 < m3; ++i3)
    for (std::size_t i2 = 0; i2 < m2; ++i2)
      for (std::size_t i1 = 0; i1 < m1; ++i1) {
        const std::size_t v = t->real_index(i1 % n[0] + std::size_t(n[0]) * (i2 % n[1] + std::size_t(n[1]) * (i3 % n[2])));
        const Vec3 y(double(i1) * grid.spacing(0), double(i2) * grid.spacing(1), double(i3) * grid.spacing(2));
        const Vec3 uy = G * y + Vec3(t->real(0)[v], t->real(step)[v], t->real(2 * step)[v]);
        double* o = &out[3 * (i1 + m1 * (i2 + m2 * i3))];
        for (int c = 0; c < 3; ++c) o[c] = uy[c];
      }
  return out;
}

}  // namespace softhom::rve
