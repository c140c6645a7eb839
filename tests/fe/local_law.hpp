#pragma once
// A self-contained compressible Gent + HGO law (spec §2, full fiber invariant, tension-only) used by
// the FE unit tests so that they depend only on the Material interface. The tangent is computed by
// complex-step differentiation of P(F), which is exact to round-off (no subtractive cancellation),
// so element tangent checks against finite differences test the element, not this law.
#include <complex>

#include "softhom/materials/material.hpp"

namespace softhom::fe::test_support {

class LocalGentHGO final : public Material {
 public:
  LocalGentHGO(double G, double Jm, double K, std::vector<Vec3> fibers = {}, double k1 = 0.0, double k2 = 0.0)
      : G_(G), Jm_(Jm), K_(K), fibers_(std::move(fibers)), k1_(k1), k2_(k2) {
    for (auto& a : fibers_) a.normalize();
  }
  std::string describe() const override { return "local test Gent+HGO"; }
  double initial_shear_modulus() const override { return G_; }
  double initial_bulk_modulus() const override { return K_; }
  double volumetric_modulus() const override { return K_; }  // W_V = (K/4)(J² − 1 − 2 ln J), as below
  std::vector<Vec3> fiber_directions() const override { return fibers_; }
  std::unique_ptr<Material> rotated(const Mat3& Q) const override {
    auto f = fibers_;
    for (auto& a : f) a = Q * a;
    return std::make_unique<LocalGentHGO>(G_, Jm_, K_, f, k1_, k2_);
  }

  MaterialStatus evaluate(const Mat3& F, const double*, double*, double, Mat3& P, Mat9* A) const override {
    const double J = F.determinant();
    if (!(J > 0.0)) return MaterialStatus::inverted;
    const double I1b = std::pow(J, -2.0 / 3.0) * (F.array() * F.array()).sum();
    if (!(I1b - 3.0 < Jm_)) return MaterialStatus::locking;
    P = piola<double>(F);
    if (A) {
      using C = std::complex<double>;
      const double h = 1e-30;
      for (int c = 0; c < 9; ++c) {
        Eigen::Matrix<C, 3, 3> Fc = F.cast<C>();
        Fc(c / 3, c % 3) += C(0.0, h);
        const Eigen::Matrix<C, 3, 3> Pc = piola<C>(Fc);
        for (int r = 0; r < 9; ++r) (*A)(r, c) = Pc(r / 3, r % 3).imag() / h;
      }
    }
    return P.allFinite() ? MaterialStatus::ok : MaterialStatus::not_finite;
  }

 private:
  template <class T>
  Eigen::Matrix<T, 3, 3> piola(const Eigen::Matrix<T, 3, 3>& F) const {
    using M = Eigen::Matrix<T, 3, 3>;
    const T J = F.determinant();
    const M FinvT = F.inverse().transpose();
    const T I1 = (F.array() * F.array()).sum();
    const T Jm23 = std::pow(J, -2.0 / 3.0);
    const T I1b = Jm23 * I1;
    const T wd = 0.5 * G_ * Jm_ / (Jm_ - I1b + 3.0);  // dW_D/dĪ1
    M P = wd * Jm23 * (2.0 * F - (2.0 / 3.0) * I1 * FinvT);
    P += (0.5 * K_ * (J - 1.0 / J)) * J * FinvT;
    for (const Vec3& a0 : fibers_) {
      const Eigen::Matrix<T, 3, 1> a = F * a0.cast<T>();
      const T I4 = (a.array() * a.array()).sum();  // not dot(): it conjugates, which breaks the complex step
      if (std::real(I4) <= 1.0) continue;
      const T psi = k1_ * (I4 - 1.0) * std::exp(k2_ * (I4 - 1.0) * (I4 - 1.0));
      P += 2.0 * psi * a * a0.cast<T>().transpose();
    }
    return P;
  }
  double G_, Jm_, K_;
  std::vector<Vec3> fibers_;
  double k1_, k2_;
};

}  // namespace softhom::fe::test_support
