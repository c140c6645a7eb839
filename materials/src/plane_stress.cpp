// Plane-stress condensation of a 3D law (S33 = 0) at a shell point, in the local frame of
// shell_section.hpp. The law is evaluated at F = U ⊕ λ3 (U the in-plane right stretch): laws are
// objective, so S depends on C = U² ⊕ λ3² only and the rotation of the actual deformation is irrelevant.
#include <cmath>
#include <limits>

#include "softhom/materials/shell_section.hpp"

namespace softhom {
namespace {

using Mat4 = Eigen::Matrix4d;

/// Accepted |S33| relative to max(|S|, G0). The round-off floor of S33 is ≈ ε K (a pressure K (J − 1)
/// from a J known to ε), 2e-11 G at K/G = 1e5: the bound leaves a factor 5 above it.
constexpr double kTolerance = 1e-10;
/// Below this the iteration stops without a further step (quadratic convergence gets there in one).
constexpr double kTight = 1e-13;
constexpr int kMaxEvaluations = 60;
/// Compressible mode: an equilibrium within this Material::limit_margin of the law's limit is refused
/// as locking, like the material-point driver's default (PointSolverOptions::limit_margin). Beyond the
/// incompressible limit the compressible Gent law still balances S33 = 0, but only by dilating (J − 1
/// of order 1 at a margin of order G/K): a state where only the bulk modulus resists.
constexpr double kLimitMargin = 1e-3;

/// Symmetric basis matrix of the Voigt coordinate b: 0 = E11, 1 = E22, 2 = 2E12 (engineering), 3 = E33.
Mat3 voigt_basis(int b) {
  Mat3 B = Mat3::Zero();
  if (b == 0) B(0, 0) = 1.0;
  if (b == 1) B(1, 1) = 1.0;
  if (b == 2) B(0, 1) = B(1, 0) = 0.5;
  if (b == 3) B(2, 2) = 1.0;
  return B;
}
/// Stress component of Voigt index a (0 = 11, 1 = 22, 2 = 12, 3 = 33).
double voigt_component(const Mat3& S, int a) {
  if (a == 0) return S(0, 0);
  if (a == 1) return S(1, 1);
  if (a == 2) return 0.5 * (S(0, 1) + S(1, 0));
  return S(2, 2);
}

Mat3 block_F(const Mat2& U, double lambda3) {
  Mat3 F = Mat3::Zero();
  F.topLeftCorner<2, 2>() = U;
  F(2, 2) = lambda3;
  return F;
}

/// CC = dS/dE = 2 dS/dC from A = ∂P/∂F, inverting A_iJkL = δ_ik S_JL + F_iM CC_MJNL F_kN.
Mat9 material_tangent(const Mat3& F, const Mat3& S, const Mat9& A) {
  Mat9 X = A;
  for (int i = 0; i < 3; ++i)
    for (int J = 0; J < 3; ++J)
      for (int L = 0; L < 3; ++L) X(voigt9(i, J), voigt9(i, L)) -= S(J, L);
  Mat9 CC;
  piola_tangent_from_material(F.inverse(), Mat3::Zero(), X, CC);
  return CC;
}

/// dS_a/dE_b for a, b ∈ {11, 22, 12 (engineering strain), 33}.
Mat4 voigt_tangent(const Mat9& CC) {
  Mat4 D;
  for (int b = 0; b < 4; ++b) {
    const Mat3 dS = contract(CC, voigt_basis(b));
    for (int a = 0; a < 4; ++a) D(a, b) = voigt_component(dS, a);
  }
  return D;
}

Vec3v in_plane_voigt(const Mat3& S) { return {S(0, 0), S(1, 1), 0.5 * (S(0, 1) + S(1, 0))}; }

double stress_scale(const Material& law, const Mat3& S) {
  return std::max(in_plane_voigt(S).norm(), law.initial_shear_modulus());
}

/// In-plane kinematics from E: C2 = I + 2E, its right stretch U = sqrt(C2) (closed form for 2x2 SPD).
struct InPlane {
  Mat2 C, U;
  double detC = 0.0;
};
MaterialStatus in_plane_kinematics(const Vec3v& E, InPlane& k) {
  if (!E.allFinite()) return MaterialStatus::not_finite;
  k.C << 1.0 + 2.0 * E[0], E[2], E[2], 1.0 + 2.0 * E[1];
  k.detC = k.C.determinant();
  if (!(k.detC > 0.0) || !(k.C.trace() > 0.0)) return MaterialStatus::inverted;
  const double s = std::sqrt(k.detC);
  k.U = (k.C + s * Mat2::Identity()) / std::sqrt(k.C.trace() + 2.0 * s);
  return MaterialStatus::ok;
}

/// Next λ3 when Newton leaves the bracket (lo, hi) of the root: its geometric midpoint, or a doubling /
/// halving while one side is still open.
double safeguarded(double lo, double hi, double lambda) {
  if (!std::isfinite(hi)) return 2.0 * std::max(lambda, lo);
  if (!(lo > 0.0)) return 0.5 * std::min(lambda, hi);
  return std::sqrt(lo * hi);
}

/// Solves S33(λ3) = 0 (Newton on P33 = λ3 S33, safeguarded by the bracket of sign changes seen so far).
/// On ok, F, P, A hold the law's last evaluation, at the returned λ3.
MaterialStatus solve_thickness(const Material& law, const InPlane& k, const double* state_old, double* state_new,
                               double dt, PlaneStressPoint& out, Mat3& F, Mat3& P, Mat9& A) {
  const double incompressible_guess = 1.0 / std::sqrt(k.detC);
  const auto given = [](double v) { return v > 0.0 && std::isfinite(v); };
  const double guess = given(out.J)         ? out.J * incompressible_guess
                       : given(out.lambda3) ? out.lambda3
                                            : incompressible_guess;
  // Starting points tried in turn while none is admissible: the caller's guess, J = 1, the λ3 of least
  // Ī1 (λ3² = tr C2 / 2, the point farthest from a Gent limit), the reference.
  const double starts[] = {guess, incompressible_guess, std::sqrt(0.5 * k.C.trace()), 1.0};
  int start = 0;
  double lambda = starts[0], lo = 0.0, hi = std::numeric_limits<double>::infinity(), good = 0.0;
  double good_margin = 1.0;
  bool locked = false;  // some iterate hit the law's limit
  out.iterations = 0;
  while (out.iterations < kMaxEvaluations) {
    ++out.iterations;
    F = block_F(k.U, lambda);
    const MaterialStatus st = law.evaluate(F, state_old, state_new, dt, P, &A);
    if (st != MaterialStatus::ok) {
      locked = locked || st == MaterialStatus::locking;
      // The root lies between an iterate at the limit and one within kLimitMargin of it: refused anyway.
      if (locked && good > 0.0 && good_margin < kLimitMargin) return MaterialStatus::locking;
      if (good > 0.0) {
        lambda = std::sqrt(lambda * good);  // back towards the last admissible iterate
      } else if (++start < int(std::size(starts))) {
        lambda = starts[start];
      } else {
        return st;
      }
      continue;
    }
    good = lambda;
    good_margin = law.limit_margin(F);
    const double S33 = P(2, 2) / lambda, scale = stress_scale(law, F.inverse() * P);
    out.lambda3 = lambda;
    out.residual = std::abs(S33) / scale;
    const double step = -P(2, 2) / A(8, 8);
    // Converged: tight, or at round-off level (Newton cannot improve λ3 by more than its last bits; the
    // floor of S33 is then ~ε K, above kTolerance · G only beyond K/G ≈ 1e5).
    const double eps = std::numeric_limits<double>::epsilon();
    if (out.residual <= kTight || (out.residual <= kTolerance + 32.0 * eps * law.initial_bulk_modulus() / scale &&
                                   !(std::abs(step) > 8.0 * eps * lambda)))
      return good_margin < kLimitMargin ? MaterialStatus::locking : MaterialStatus::ok;
    (S33 > 0.0 ? hi : lo) = lambda;
    const double next = lambda + step;
    lambda = (A(8, 8) > 0.0 && next > lo && next < hi) ? next : safeguarded(lo, hi, lambda);
  }
  return locked ? MaterialStatus::locking : MaterialStatus::not_finite;
}

/// Condensed tangent of the compressible mode: D_ab − D_a3 D_3b / D_33.
bool condense_compressible(const Mat4& D4, Mat3v& D) {
  if (!(D4(3, 3) > 0.0)) return false;
  D = D4.topLeftCorner<3, 3>() - D4.topRightCorner<3, 1>() * D4.bottomLeftCorner<1, 3>() / D4(3, 3);
  return true;
}

MaterialStatus compressible(const Material& law, const InPlane& k, const double* state_old, double* state_new,
                            double dt, PlaneStressPoint& out) {
  Mat3 F, P;
  Mat9 A;
  const MaterialStatus st = solve_thickness(law, k, state_old, state_new, dt, out, F, P, A);
  if (st != MaterialStatus::ok) return st;
  const Mat3 S = F.inverse() * P;
  out.S = in_plane_voigt(S);
  out.J = F.determinant();
  out.pressure = 0.0;
  out.converged = true;
  if (!condense_compressible(voigt_tangent(material_tangent(F, S, A)), out.D)) return MaterialStatus::not_finite;
  return MaterialStatus::ok;
}

/// J = 1: λ3 = 1/sqrt(det C2); S = S_rest(C) − p C⁻¹ with p from S33 = 0, S_rest the law without its
/// W_V(J). With c = Voigt(C2⁻¹) and g_b = dE33/dE_b = −λ3² c_b (from det C = 1), differentiating
/// S_a = S_rest,a(E, E33(E)) + q C⁻¹_a, q = −p = −λ3² S_rest,33, gives
///   D_ab = R_ab + R_a3 g_b + c_a dq_b + q dC⁻¹_a/dE_b,   dq_b = −2 g_b S_rest,33 − λ3² (R_3b + R_33 g_b).
MaterialStatus incompressible(const Material& law, const InPlane& k, const double* state_old, double* state_new,
                              double dt, PlaneStressPoint& out) {
  const double l3 = 1.0 / std::sqrt(k.detC);
  const Mat3 F = block_F(k.U, l3);
  Mat3 P;
  Mat9 A;
  out.iterations = 1;
  const MaterialStatus st = law.evaluate(F, state_old, state_new, dt, P, &A);
  if (st != MaterialStatus::ok) return st;
  const Mat3 Finv = F.inverse(), Cinv = Finv * Finv.transpose();
  Mat3 S = Finv * P;
  Mat9 CC = material_tangent(F, S, A);
  // Remove W_V: S_V = J W_V′ C⁻¹, dS_V/dE = J (W_V′ + J W_V″) C⁻¹⊗C⁻¹ − 2 J W_V′ C⁻¹⊙C⁻¹. J is 1 to
  // round-off; subtracting the terms at the law's own J removes them to round-off as well.
  const double K = law.volumetric_modulus(), J = F.determinant();
  const double dU = volumetric_dU(K, J), d2U = volumetric_d2U(K, J);
  S -= J * dU * Cinv;
  add_dyad(CC, -J * (dU + J * d2U), Cinv, Cinv);
  add_sym_product(CC, 2.0 * J * dU, Cinv);
  const Mat4 R = voigt_tangent(CC);

  const Mat2 C2inv = k.C.inverse();
  const Vec3v c(C2inv(0, 0), C2inv(1, 1), C2inv(0, 1));
  const double l2 = l3 * l3, Sr33 = S(2, 2), q = -l2 * Sr33;
  const Vec3v g = -l2 * c;
  out.S = in_plane_voigt(S) + q * c;
  out.pressure = -q;
  for (int b = 0; b < 3; ++b) {
    const Mat2 Eb = voigt_basis(b).topLeftCorner<2, 2>();
    const Mat2 dCinv = -2.0 * C2inv * Eb * C2inv;
    const Vec3v dc(dCinv(0, 0), dCinv(1, 1), dCinv(0, 1));
    const double dq = -2.0 * g[b] * Sr33 - l2 * (R(3, b) + R(3, 3) * g[b]);
    for (int a = 0; a < 3; ++a) out.D(a, b) = R(a, b) + R(a, 3) * g[b] + c[a] * dq + q * dc[a];
  }
  out.lambda3 = l3;
  out.J = 1.0;
  out.residual = 0.0;  // S33 = S_rest,33 + q / λ3² = 0 by construction
  out.converged = true;
  return out.S.allFinite() && out.D.allFinite() ? MaterialStatus::ok : MaterialStatus::not_finite;
}

}  // namespace

MaterialStatus plane_stress(const Material& law, const Vec3v& E, const double* state_old, double* state_new,
                            double dt, PlaneStressMode mode, PlaneStressPoint& out) {
  InPlane k;
  out.converged = false;
  MaterialStatus st = in_plane_kinematics(E, k);
  if (st == MaterialStatus::ok)
    st = mode == PlaneStressMode::compressible ? compressible(law, k, state_old, state_new, dt, out)
                                               : incompressible(law, k, state_old, state_new, dt, out);
  if (st != MaterialStatus::ok) {
    out.S.setZero();
    out.D.setZero();
    out.pressure = 0.0;
    out.converged = false;
    if (!std::isfinite(out.lambda3)) out.lambda3 = 0.0;
    if (!std::isfinite(out.J)) out.J = 0.0;
    if (!std::isfinite(out.residual)) out.residual = 0.0;
  }
  return st;
}

Mat3 shell_cauchy_stress(const Vec3v& S, const Mat32& F, double lambda3) {
  Mat2 Sm;
  Sm << S[0], S[2], S[2], S[1];
  const double J = lambda3 * std::sqrt((F.transpose() * F).determinant());
  return F * Sm * F.transpose() / J;
}

Mat3 shell_cauchy_stress(const Vec3v& S, const Mat2& F, double lambda3) {
  Mat32 F3 = Mat32::Zero();
  F3.topRows<2>() = F;
  return shell_cauchy_stress(S, F3, lambda3);
}

}  // namespace softhom
