// The shell triangle's kinematics in closed form (shell.hpp: shell_kinematics): strains, their first
// derivatives, and the stress-weighted sum of their second derivatives that the tangent needs.
//
// Membrane: a_α = Σ_c N_c,α x_c, ε_αβ = ½ (a_α·a_β − δ_αβ); its second derivatives are the constant
// blocks N_c,α N_d,β I. Curvature: κ_k = c_k t·w_k + const, c = (−1, −1, −2), with t = n/ℓ, n = a1 × a2,
// ℓ = |n|, and w_k = Σ_i Q_ki d_i linear in the positions (d_i = x_{3+i} − x_0 across a neighbour's
// edge, the constant 2 δ T across a clamped one). The stress-weighted sum Σ_k μ_k ∂²κ_k is then the
// Hessian of the one function t·W, W = Σ_k μ_k c_k w_k:
//   ∂²(t·W) = J_cᵀ G J_d + M_cd  (triangle nodes c, d; W held)  +  (∂t/∂x)ᵀ ∂W/∂x + (∂W/∂x)ᵀ ∂t/∂x,
//   J_c = ∂n/∂x_c = −N_c,1 [a2]× + N_c,2 [a1]×,   ∂t/∂x_c = P J_c / ℓ,   P = I − t tᵀ,
//   G = ∂²(t·W)/∂n² = −(P W tᵀ + t Wᵀ P + (t·W) P) / ℓ²,   M_cd = −(N_c,1 N_d,2 − N_d,1 N_c,2) [P W / ℓ]×.
// One Hessian of a 3-vector function instead of six 18 × 18 second derivatives carried through every
// operation (the forward jets of shell_strains) is what makes the tangent cheap.
#include "softhom/fe/shell.hpp"

namespace softhom::fe {
namespace {

Mat3 skew(const Vec3& v) {
  Mat3 s;
  s << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return s;
}

constexpr double kCurvatureSign[3] = {-1.0, -1.0, -2.0};  // κ11 = −b11, κ22 = −b22, 2κ12 = −2 b12

/// The deformed triangle: tangents, normal and what the derivatives share.
struct Deformed {
  Vec3 a1 = Vec3::Zero(), a2 = Vec3::Zero(), t;
  double l;
  Mat3 P, J[3];
  Vec3 d[3];  ///< across edge i: the vector whose height above the triangle is h_i
};

Deformed deformed(const ShellPatch& p, const std::array<Vec3, 6>& x) {
  Deformed f;
  for (int c = 0; c < 3; ++c) {
    f.a1 += p.dN[c][0] * x[c];
    f.a2 += p.dN[c][1] * x[c];
  }
  const Vec3 n = f.a1.cross(f.a2);
  f.l = n.norm();
  f.t = n / f.l;
  f.P = Mat3::Identity() - f.t * f.t.transpose();
  for (int c = 0; c < 3; ++c) f.J[c] = -p.dN[c][0] * skew(f.a2) + p.dN[c][1] * skew(f.a1);
  for (int i = 0; i < 3; ++i)
    f.d[i] = p.kind[i] == 1 ? Vec3(x[3 + i] - x[0]) : p.kind[i] == 2 ? p.clamp[i] : Vec3::Zero();
  return f;
}

}  // namespace

void shell_kinematics(const ShellPatch& p, const std::array<Vec3, 6>& x, Vec6v& strains, Eigen::Matrix<double, 6, 18>& B) {
  const Deformed f = deformed(p, x);
  strains[0] = 0.5 * (f.a1.dot(f.a1) - 1.0);
  strains[1] = 0.5 * (f.a2.dot(f.a2) - 1.0);
  strains[2] = f.a1.dot(f.a2);
  B.setZero();
  for (int c = 0; c < 3; ++c) {
    B.block<1, 3>(0, 3 * c) = p.dN[c][0] * f.a1.transpose();
    B.block<1, 3>(1, 3 * c) = p.dN[c][1] * f.a2.transpose();
    B.block<1, 3>(2, 3 * c) = (p.dN[c][0] * f.a2 + p.dN[c][1] * f.a1).transpose();
  }
  for (int k = 0; k < 3; ++k) {
    Vec3 w = Vec3::Zero();
    for (int i = 0; i < 3; ++i) w += p.Q[k][i] * f.d[i];
    const double ck = kCurvatureSign[k];
    strains[3 + k] = ck * (f.t.dot(w) - p.B[k]);
    const Vec3 v = f.P * w / f.l;
    for (int c = 0; c < 3; ++c) B.block<1, 3>(3 + k, 3 * c) = ck * (f.J[c].transpose() * v).transpose();
    for (int i = 0; i < 3; ++i)
      if (p.kind[i] == 1) {
        B.block<1, 3>(3 + k, 3 * (3 + i)) += ck * p.Q[k][i] * f.t.transpose();
        B.block<1, 3>(3 + k, 0) -= ck * p.Q[k][i] * f.t.transpose();
      }
  }
}

void shell_geometric_stiffness(const ShellPatch& p, const std::array<Vec3, 6>& x, const Vec6v& s,
                               Eigen::Matrix<double, 18, 18>& K) {
  const Deformed f = deformed(p, x);
  K.setZero();
  // Membrane: Σ N_αβ ∂²ε_αβ, blocks of the identity.
  for (int c = 0; c < 3; ++c)
    for (int e = 0; e < 3; ++e) {
      const double m = s[0] * p.dN[c][0] * p.dN[e][0] + s[1] * p.dN[c][1] * p.dN[e][1] +
                       s[2] * (p.dN[c][0] * p.dN[e][1] + p.dN[c][1] * p.dN[e][0]);
      K.block<3, 3>(3 * c, 3 * e).diagonal().array() += m;
    }
  // Curvature: the Hessian of t·W with W = Σ_k μ_k c_k w_k = Σ_i ω_i d_i.
  double omega[3] = {0.0, 0.0, 0.0};
  Vec3 W = Vec3::Zero();
  for (int i = 0; i < 3; ++i) {
    for (int k = 0; k < 3; ++k) omega[i] += s[3 + k] * kCurvatureSign[k] * p.Q[k][i];
    W += omega[i] * f.d[i];
  }
  const Vec3 PW = f.P * W;
  const Mat3 Gnn = -(PW * f.t.transpose() + f.t * PW.transpose() + f.t.dot(W) * f.P) / (f.l * f.l);
  const Mat3 vx = skew(PW / f.l);
  Mat3 dt[3];
  for (int c = 0; c < 3; ++c) dt[c] = f.P * f.J[c] / f.l;
  for (int c = 0; c < 3; ++c)
    for (int e = 0; e < 3; ++e)
      K.block<3, 3>(3 * c, 3 * e) +=
          f.J[c].transpose() * Gnn * f.J[e] - (p.dN[c][0] * p.dN[e][1] - p.dN[e][0] * p.dN[c][1]) * vx;
  // Cross terms: W moves with the neighbours (ω_i I at slot 3 + i) and with node 0 (−Σ ω_i I).
  double omega0 = 0.0;
  for (int i = 0; i < 3; ++i) {
    if (p.kind[i] != 1) continue;
    omega0 -= omega[i];
    for (int c = 0; c < 3; ++c) {
      K.block<3, 3>(3 * c, 3 * (3 + i)) += omega[i] * dt[c].transpose();
      K.block<3, 3>(3 * (3 + i), 3 * c) += omega[i] * dt[c];
    }
  }
  for (int c = 0; c < 3; ++c) {
    K.block<3, 3>(3 * c, 0) += omega0 * dt[c].transpose();
    K.block<3, 3>(0, 3 * c) += omega0 * dt[c];
  }
}

}  // namespace softhom::fe
