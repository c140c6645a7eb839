// The adapter ElasticLaw → Material, the common pre-checks, and the invariant assembler shared by the
// Gent + HGO, neo-Hookean and Yeoh laws (see hyperelastic.hpp for the formulas).
#include "softhom/materials/hyperelastic.hpp"

#include <cmath>

namespace softhom {

const char* to_string(MaterialStatus s) {
  switch (s) {
    case MaterialStatus::ok: return "ok";
    case MaterialStatus::locking: return "locking (Gent limit I1bar - 3 >= Jm reached)";
    case MaterialStatus::inverted: return "inverted element (det F <= 0)";
    case MaterialStatus::not_finite: return "non-finite value (input or overflow)";
    case MaterialStatus::penetration: return "penetration (a surface point passed through a contact obstacle)";
  }
  return "unknown";
}

MaterialStatus check_deformation(const Mat3& F, double& J) {
  if (!F.allFinite()) return MaterialStatus::not_finite;
  J = F.determinant();
  if (!std::isfinite(J)) return MaterialStatus::not_finite;
  if (!(J > 0.0)) return MaterialStatus::inverted;
  return MaterialStatus::ok;
}

MaterialStatus ElasticLaw::first_piola(const Mat3& F, const Mat3& C, double J, Mat3& P, Mat9* A) const {
  Mat3 S;
  Mat9 CC;
  const MaterialStatus st = second_piola(F, C, J, S, A ? &CC : nullptr);
  if (st != MaterialStatus::ok) return st;
  P.noalias() = F * S;
  if (A) piola_tangent_from_material(F, S, CC, *A);
  return MaterialStatus::ok;
}

MaterialStatus HyperelasticMaterial::evaluate(const Mat3& F, const double* /*state_old*/,
                                              double* /*state_new*/, double /*dt*/, Mat3& P,
                                              Mat9* A) const {
  double J = 0.0;
  const MaterialStatus st = check_deformation(F, J);
  if (st != MaterialStatus::ok) return st;
  const Mat3 C = F.transpose() * F;
  return law_->first_piola(F, C, J, P, A);
}

// ---------------------------------------------------------------------------------------------------
// InvariantAssembler

InvariantAssembler::InvariantAssembler(Form form, const Mat3& F, const Mat3& C_inv, Mat9* T)
    : form_(form), F_(F), Ci_(C_inv), T_(T) {}

void InvariantAssembler::add_fiber(const Vec3& a0, const Vec3& a, const Mat3& M, double sM, double cMM,
                                   double cMC) {
  // F M = (F a0) ⊗ a0 = a ⊗ a0.
  add_structure(M, a * a0.transpose(), sM, cMM, cMC);
}

void InvariantAssembler::add_structure(const Mat3& H, const Mat3& FH, double sH, double cHH, double cHC) {
  S_fibers_ += sH * H;
  if (!T_) return;
  Vec9 m;
  if (form_ == Form::material) {
    m = Eigen::Map<const Vec9>(H.data());  // symmetric
  } else {
    for (int i = 0; i < 3; ++i)
      for (int J = 0; J < 3; ++J) m[voigt9(i, J)] = FH(i, J);
  }
  if (T_written_) T_->noalias() += (cHH * m) * m.transpose();
  else T_->noalias() = (cHH * m) * m.transpose();
  T_written_ = true;
  z_ += cHC * m;
}

void InvariantAssembler::finish(double sI, double sC, double cII, double cIC, double cCC, double cS,
                                Mat3& stress) {
  // Material stress in every form: the Piola tangent needs it for the geometric term δ_ik S_JL.
  Mat3 S = S_fibers_ + sC * Ci_;
  S.diagonal().array() += sI;
  if (form_ == Form::material) {
    stress = S;
    if (!T_) return;
    Mat9& CC = *T_;
    const Vec9 c = Eigen::Map<const Vec9>(Ci_.data());  // symmetric
    Vec9 i = Vec9::Zero();
    i[0] = i[4] = i[8] = 1.0;
    if (!T_written_) CC.setZero();
    CC.noalias() += i * (cII * i + cIC * c).transpose();
    CC.noalias() += c * (cIC * i + cCC * c + z_).transpose();
    CC.noalias() += z_ * c.transpose();
    add_sym_product(CC, cS, Ci_);
    return;
  }
  stress.noalias() = F_ * S;
  if (!T_) return;
  Mat9& A = *T_;
  const Mat3 Fit = F_ * Ci_;  // F C⁻¹ = F⁻ᵀ
  Vec9 f, t;
  for (int i = 0; i < 3; ++i)
    for (int J = 0; J < 3; ++J) {
      f[voigt9(i, J)] = F_(i, J);
      t[voigt9(i, J)] = Fit(i, J);
    }
  // One pass over the columns (k, L) of A, summing
  //   dyads      cII f⊗f + cIC (f⊗t + t⊗f) + cCC t⊗t + z⊗t + t⊗z = f⊗u + t⊗v + z⊗t
  //   ½ cS F⁻ᵀ_iL F⁻ᵀ_kJ            (the "transposed" half of the push-forward of C⁻¹⊙C⁻¹)
  //   δ_ik (S_JL + ½ cS C⁻¹_JL)     (geometric term and the other half of C⁻¹⊙C⁻¹)
  // in registers and storing each column once.
  const Vec9 u = cII * f + cIC * t, v = cIC * f + cCC * t + z_;
  const double h = 0.5 * cS;
  const Mat3 G = S + h * Ci_;
  const Mat3 hFitT = h * Fit.transpose();  // hFitT(J, k) = h F⁻ᵀ_kJ, contiguous in J
  for (int k = 0; k < 3; ++k)
    for (int L = 0; L < 3; ++L) {
      const int c = voigt9(k, L);
      Vec9 col = f * u[c] + t * v[c] + z_ * t[c];
      for (int i = 0; i < 3; ++i) col.segment<3>(3 * i) += Fit(i, L) * hFitT.col(k);
      col.segment<3>(3 * k) += G.col(L);  // G symmetric: G(J, L) = G(L, J)
      if (T_written_) A.col(c) += col;
      else A.col(c) = col;
    }
}

}  // namespace softhom
