// Ogden law, N terms, isochoric principal stretches (Abaqus convention, dissertation eq. 3.9):
//   W = Σ_p (2 μ_p/α_p²)(λ̄1^α_p + λ̄2^α_p + λ̄3^α_p − 3) + (K/4)(J² − 1 − 2 ln J),   λ̄_a = J^(-1/3) λ_a.
//
// Spectral form in the eigenvalues c_a = λ_a² of C with eigenprojections E_a = v_a ⊗ v_a. With the
// logarithmic stretches e_a = ½ ln c_a, ē_a = e_a − (ln J)/3 and b_a = exp(α ē_a) = λ̄_a^α:
//   τ_a  = ∂W/∂e_a      = Σ_p (2μ_p/α_p)(b_a − Σb/3) + (K/2)(J² − 1)             (principal Kirchhoff)
//   D_ab = ∂²W/∂e_a∂e_b = Σ_p 2μ_p (δ_ab b_a − b_a/3 − b_b/3 + Σb/9) + K J²
//   S    = Σ_a s_a E_a,  s_a = 2 ∂W/∂c_a = τ_a / c_a
//   CC   = Σ_ab d_ab E_a⊗E_b + Σ_{a≠b} 2 θ_ab E_a⊡E_b,   (E_a⊡E_b)_ijkl = ½(E_a,ik E_b,jl + E_a,il E_b,jk)
//          d_ab = 2 ∂s_a/∂c_b = D_ab/(c_a c_b) − 2 δ_ab τ_a/c_a²,   θ_ab = (s_a − s_b)/(c_a − c_b)
// (Miehe 1993 / Simo–Taylor 1991). At coincident eigenvalues θ_ab is 0/0; its limit follows from the
// symmetry of W: θ_ab = ∫_0^1 (∂s_a/∂c_a − ∂s_a/∂c_b) along the segment that swaps c_a and c_b, so
//   θ_ab → ½[(∂s_a/∂c_a − ∂s_a/∂c_b) + (∂s_b/∂c_b − ∂s_b/∂c_a)] = ¼(d_aa − d_ab + d_bb − d_ba)
// (exact when c_a = c_b, second-order accurate in c_a − c_b). With that limit the sum is independent of
// the basis chosen inside a repeated eigenspace, so any orthonormal eigenvectors will do.
#include <cmath>
#include <sstream>

#include <Eigen/Eigenvalues>

#include "softhom/materials/laws.hpp"

namespace softhom {
namespace {

// Switch to the limit formula when |c_a − c_b| ≤ kCoincident max(c_a, c_b). The quotient's rounding error
// is ≈ ε/1e-5 = 1e-11 relative at the switch, the limit formula's truncation ≈ (1e-5)² α²: both ≪ 1e-8.
constexpr double kCoincident = 1e-5;

class OgdenLaw final : public ElasticLaw {
 public:
  explicit OgdenLaw(const OgdenParams& p) : p_(p) {}

  std::string describe() const override {
    std::ostringstream s;
    s.precision(6);
    s << "Ogden N=" << p_.mu.size() << " (mu=(";
    for (std::size_t i = 0; i < p_.mu.size(); ++i) s << (i ? ", " : "") << p_.mu[i];
    s << ") MPa, alpha=(";
    for (std::size_t i = 0; i < p_.alpha.size(); ++i) s << (i ? ", " : "") << p_.alpha[i];
    s << "), K=" << p_.K << " MPa)";
    return s.str();
  }

  MaterialStatus second_piola(const Mat3& /*F*/, const Mat3& C, double J, Mat3& S, Mat9* CC) const override {
    const Eigen::SelfAdjointEigenSolver<Mat3> es(C);
    if (es.info() != Eigen::Success) return MaterialStatus::not_finite;
    const Vec3 c = es.eigenvalues();
    const Mat3& V = es.eigenvectors();
    if (!(c.minCoeff() > 0.0) || !c.allFinite()) return MaterialStatus::not_finite;

    const double third_lnJ = std::log(J) / 3.0;
    Vec3 tau = Vec3::Constant(0.5 * p_.K * (J * J - 1.0));
    Mat3 D = Mat3::Constant(p_.K * J * J);
    const Vec3 e_bar = 0.5 * c.array().log() - third_lnJ;
    for (std::size_t k = 0; k < p_.mu.size(); ++k) {
      const double mu = p_.mu[k], al = p_.alpha[k];
      const Vec3 b = (al * e_bar).array().exp();
      const double sb = b.sum();
      tau += (2.0 * mu / al) * (b.array() - sb / 3.0).matrix();
      if (CC)
        for (int a = 0; a < 3; ++a)
          for (int d = 0; d < 3; ++d)
            D(a, d) += 2.0 * mu * ((a == d ? b[a] : 0.0) - (b[a] + b[d]) / 3.0 + sb / 9.0);
    }
    const Vec3 s = tau.cwiseQuotient(c);
    if (!s.allFinite() || (CC && !D.allFinite())) return MaterialStatus::not_finite;

    Mat3 E[3];
    for (int a = 0; a < 3; ++a) E[a] = V.col(a) * V.col(a).transpose();
    S = s[0] * E[0] + s[1] * E[1] + s[2] * E[2];
    if (!CC) return MaterialStatus::ok;

    Mat3 d;  // d_ab = 2 ∂s_a/∂c_b
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) d(a, b) = D(a, b) / (c[a] * c[b]) - (a == b ? 2.0 * tau[a] / (c[a] * c[a]) : 0.0);

    CC->setZero();
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) add_dyad(*CC, d(a, b), E[a], E[b]);
    for (int a = 0; a < 3; ++a)
      for (int b = a + 1; b < 3; ++b) {
        const double gap = c[a] - c[b];
        const double theta = std::abs(gap) > kCoincident * std::max(c[a], c[b])
                                 ? (s[a] - s[b]) / gap
                                 : 0.25 * (d(a, a) - d(a, b) + d(b, b) - d(b, a));
        // 2θ (E_a⊡E_b + E_b⊡E_a), written out: θ (Ea_ik Eb_jl + Ea_il Eb_jk + Eb_ik Ea_jl + Eb_il Ea_jk)
        const Mat3 &Ea = E[a], &Eb = E[b];
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j)
            for (int k = 0; k < 3; ++k)
              for (int l = 0; l < 3; ++l)
                (*CC)(voigt9(i, j), voigt9(k, l)) +=
                    theta * (Ea(i, k) * Eb(j, l) + Ea(i, l) * Eb(j, k) + Eb(i, k) * Ea(j, l) + Eb(i, l) * Ea(j, k));
      }
    if (!CC->allFinite()) return MaterialStatus::not_finite;
    return MaterialStatus::ok;
  }

  double energy(const Mat3& C, double J) const override {
    if (!(J > 0.0)) return std::nan("");
    const Eigen::SelfAdjointEigenSolver<Mat3> es(C, Eigen::EigenvaluesOnly);
    const Vec3 e_bar = 0.5 * es.eigenvalues().array().log() - std::log(J) / 3.0;
    double W = volumetric_energy(p_.K, J);
    for (std::size_t k = 0; k < p_.mu.size(); ++k) {
      const double al = p_.alpha[k];
      // Σ (b_a − 1) with expm1: avoids cancellation near the reference state
      W += 2.0 * p_.mu[k] / (al * al) *
           (std::expm1(al * e_bar[0]) + std::expm1(al * e_bar[1]) + std::expm1(al * e_bar[2]));
    }
    return W;
  }

  double initial_shear_modulus() const override {
    double mu = 0.0;
    for (const double m : p_.mu) mu += m;
    return mu;
  }
  double initial_bulk_modulus() const override { return p_.K; }
  std::unique_ptr<ElasticLaw> rotated(const Mat3& /*Q*/) const override { return std::make_unique<OgdenLaw>(p_); }

 private:
  OgdenParams p_;
};

}  // namespace

ElasticLawPtr make_ogden(const OgdenParams& p) { return std::make_shared<OgdenLaw>(p); }

}  // namespace softhom
