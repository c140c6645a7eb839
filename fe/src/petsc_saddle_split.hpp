#pragma once
// The augmented-Lagrangian split of the three-field elements' volumetric stiffness for the PETSc field
// split (petsc_solve.cpp). No PETSc type here.
//
// The condensed tangent is K = A + Σ_k c_k d_k d_kᵀ (c_k = V_k U″(θ_k) ~ V_k κ, d_k = ∂θ_k/∂u). Its
// part γ_k ≤ c_k stays in the displacement block, A_γ = A + Σ_k γ_k d_k d_kᵀ, and the rest c̃_k = c_k − γ_k
// is carried by the element pressure. By the Sherman–Morrison–Woodbury identity the Schur complement
// of the pressure block (in the scaling of petsc_solve.cpp) is
//     S = −I − C̃ Dᵀ A_γ⁻¹ D,   Dᵀ A_γ⁻¹ D = ((Dᵀ A⁻¹ D)⁻¹ + Γ)⁻¹,
// which tends to the diagonal −(1 + c̃_k/γ_k) as γ grows, whatever the inf-sup constant of the
// element pair (Q1/P0 has none uniform in h; its small eigenvalues of Dᵀ A⁻¹ D are what make the
// counts of a mass-matrix-like Schur approximation grow with the mesh). With x_k = d_kᵀ diag(A)⁻¹ d_k
// (the element's diagonal estimate of Dᵀ A⁻¹ D) and γ_k = α / x_k the displacement block is that of a
// compressible solid with a bulk modulus ~ α G: AMG on it stays cheap for α = O(10), and the Schur
// diagonal used is −1 − c̃_k x_k / (1 + γ_k x_k). α = 0 is the plain split (γ = 0, the diagonal of
// selfp).
#include <vector>

#include "softhom/fe/sparse.hpp"

namespace softhom::fe {

struct AugmentedSplit {
  std::vector<double> kept;         ///< c̃_k: the volumetric stiffness carried by the element pressure
  std::vector<double> schur_diag;   ///< −1 − c̃_k x_k / (1 + γ_k x_k)
};

/// K: the condensed tangent on the free dofs (replicated); element k's free equations eq[off[k] ..
/// off[k+1]) (−1: prescribed; repeated ones for degenerate elements), d at the same positions, c per
/// element; alpha ≥ 0. γ_k is capped at c_k / 2, so the pressure keeps at least half of the volumetric
/// stiffness (the compressibility term −1 then still bounds the Schur complement away from zero).
AugmentedSplit augmented_split(const CscMatrix& K, const std::vector<int>& off, const std::vector<int>& eq,
                               const std::vector<double>& d, const std::vector<double>& c, double alpha);

}  // namespace softhom::fe
