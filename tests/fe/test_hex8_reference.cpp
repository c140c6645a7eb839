// The structured hex8 kernel (Bᵀ A B by 8x8 blocks, rank-2 F-bar terms, H added once per element)
// against the dense textbook form K = Σ_g w (Mᵀ A M + geometric terms), M = ∂vec(F̄)/∂u
// written out as a 9x24 matrix. Both are exact expressions of the same tangent, so they agree to
// round-off (1e-12 relative, ~1e4 × machine epsilon for sums of a few hundred terms), including an
// unsymmetric material tangent (viscoelastic laws) and the three-field (mixed) terms.
#include <gtest/gtest.h>

#include <cmath>

#include "softhom/fe/hex8.hpp"
#include "fe/local_law.hpp"

using namespace softhom;
using namespace softhom::fe;

namespace {

/// Adds a fixed unsymmetric part to the tangent (the residual is unchanged): exercises Bᵀ Aᵀ f.
class SkewTangent final : public Material {
 public:
  explicit SkewTangent(MaterialPtr inner) : inner_(std::move(inner)) {
    for (int i = 0; i < 9; ++i)
      for (int j = 0; j < 9; ++j) skew_(i, j) = 0.01 * std::sin(1.0 + 3.0 * i + 7.0 * j);
  }
  std::string describe() const override { return "skew tangent"; }
  double initial_shear_modulus() const override { return inner_->initial_shear_modulus(); }
  double initial_bulk_modulus() const override { return inner_->initial_bulk_modulus(); }
  double volumetric_modulus() const override { return inner_->volumetric_modulus(); }
  std::unique_ptr<Material> rotated(const Mat3&) const override { return nullptr; }
  MaterialStatus evaluate(const Mat3& F, const double* so, double* sn, double dt, Mat3& P, Mat9* A) const override {
    const MaterialStatus st = inner_->evaluate(F, so, sn, dt, P, A);
    if (A) *A += skew_;
    return st;
  }

 private:
  MaterialPtr inner_;
  Mat9 skew_;
};

/// Dense reference of hex8_internal_force's tangent (F-bar with optional three-field terms, or standard).
Mat24 reference_tangent(const Hex8Geometry& g, const Mat83& u, const Material& m, Formulation f, const MixedVolume* mixed) {
  const bool fbar = f == Formulation::fbar;
  std::array<Mat3, 8> F;
  std::array<double, 8> J;
  double v = 0.0;
  for (int q = 0; q < 8; ++q) {
    F[q] = Mat3::Identity() + u.transpose() * g.dN[q];
    J[q] = F[q].determinant();
    v += g.w[q] * J[q];
  }
  const double theta = v / g.volume;
  auto B_of = [&](int q) {
    Eigen::Matrix<double, 9, 24> B = Eigen::Matrix<double, 9, 24>::Zero();
    for (int i = 0; i < 3; ++i)
      for (int Jc = 0; Jc < 3; ++Jc)
        for (int a = 0; a < 8; ++a) B(3 * i + Jc, 3 * a + i) = g.dN[q](a, Jc);
    return B;
  };
  std::array<Vec24, 8> l;
  std::array<Mat24, 8> Q;
  Vec24 d = Vec24::Zero();
  Mat24 H = Mat24::Zero();
  for (int q = 0; q < 8; ++q) {
    const Mat83 gs = g.dN[q] * F[q].inverse();
    for (int a = 0; a < 8; ++a)
      for (int i = 0; i < 3; ++i) l[q][3 * a + i] = gs(a, i);
    for (int a = 0; a < 8; ++a)
      for (int b = 0; b < 8; ++b)
        for (int i = 0; i < 3; ++i)
          for (int k = 0; k < 3; ++k) Q[q](3 * a + i, 3 * b + k) = gs(b, i) * gs(a, k);
    const double c = g.w[q] * J[q] / g.volume;
    d += c * l[q];
    H += c * (l[q] * l[q].transpose() - Q[q]);
  }
  Mat24 K = Mat24::Zero();
  double coef_H = 0.0;
  for (int q = 0; q < 8; ++q) {
    const double alpha = fbar ? std::cbrt(theta / J[q]) : 1.0;
    Mat3 P;
    Mat9 A;
    EXPECT_EQ(m.evaluate(alpha * F[q], nullptr, nullptr, 0.0, P, &A), MaterialStatus::ok);
    const Eigen::Matrix<double, 9, 24> B = B_of(q);
    const double w = g.w[q];
    if (!fbar) {
      K += w * B.transpose() * A * B;
      continue;
    }
    const Vec9 p = flatten(P), fv = flatten(F[q]);
    const Vec24 b = B.transpose() * p, c = d / theta - l[q];
    const double s = p.dot(fv), ws = w * alpha * s;
    const Eigen::Matrix<double, 9, 24> M = alpha * (B + (1.0 / 3.0) * fv * c.transpose());
    K += w * M.transpose() * A * M;
    K += (w * alpha / 3.0) * (b * c.transpose() + c * b.transpose()) + (ws / 9.0) * c * c.transpose();
    K -= (ws / (3.0 * theta * theta)) * d * d.transpose();
    K += (ws / 3.0) * Q[q];
    coef_H += ws / (3.0 * theta);
  }
  if (fbar && mixed) {
    const double V = g.volume, Kv = mixed->bulk, th = mixed->theta;
    coef_H += V * (mixed->p - volumetric_dU(Kv, theta));
    K += (V * (volumetric_d2U(Kv, th) - volumetric_d2U(Kv, theta))) * d * d.transpose();
  }
  if (fbar) K += coef_H * H;
  return K;
}

Mat83 loaded_element(const Mat83& X) {
  Mat3 F;
  F << 1.3, 0.1, -0.05, 0.04, 0.85, 0.07, -0.03, 0.05, 0.95;
  Mat83 u;
  for (int a = 0; a < 8; ++a)
    u.row(a) = ((F - Mat3::Identity()) * X.row(a).transpose()).transpose() +
               0.01 * Vec3(std::cos(1.0 + a), std::sin(2.0 * a), std::cos(5.0 * a)).transpose();
  return u;
}

}  // namespace

TEST(Hex8Kernel, StructuredTangentEqualsDenseReference) {
  Mat83 X;
  X << 0, 0, 0, 1, 0, 0, 1.1, 0.9, 0, 0, 1, 0.1, 0, 0.05, 1, 1, 0, 1.2, 1, 1, 1, -0.1, 1, 0.9;
  const Hex8Geometry g = hex8_geometry(X);
  ASSERT_TRUE(g.valid);
  const Mat83 u = loaded_element(X);
  // Nearly incompressible (K/G = 1e4, the macro scenes' order), fibers in tension.
  const auto law = std::make_shared<test_support::LocalGentHGO>(0.017, 14.0, 170.0, std::vector<Vec3>{Vec3(1, 1, 0.3), Vec3(-1, 1, 0.3)}, 0.8, 18.0);
  const SkewTangent skew(law);
  for (const Material* m : {static_cast<const Material*>(law.get()), static_cast<const Material*>(&skew)})
    for (int variant = 0; variant < 3; ++variant) {
      const Formulation f = variant == 0 ? Formulation::standard : Formulation::fbar;
      MixedVolume mv;
      mv.bulk = 170.0;
      mv.theta = 1.02;  // iterate off θ_e(u): the three-field terms do not vanish
      mv.p = 0.4;
      MixedVolume* mixed = variant == 2 ? &mv : nullptr;
      Vec24 r;
      Mat24 K;
      ASSERT_EQ(hex8_internal_force(g, u, *m, nullptr, nullptr, 0.0, f, r, &K, nullptr, mixed), MaterialStatus::ok);
      MixedVolume mv_ref = mv;
      const Mat24 Kref = reference_tangent(g, u, *m, f, variant == 2 ? &mv_ref : nullptr);
      const double err = (K - Kref).cwiseAbs().maxCoeff() / Kref.cwiseAbs().maxCoeff();
      EXPECT_LT(err, 1e-12) << "variant " << variant << (m == &skew ? " (unsymmetric A)" : "");
    }
}
