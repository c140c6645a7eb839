// The volumetric energy every law shares (docs/model.md §2), W_V(J) = (K/4)(J² − 1 − 2 ln J), its
// derivatives, and the derivative of the cofactor cof F = J F⁻ᵀ through which a pressure acts: written
// once for the laws, the element kernels and the cell solvers' mixed (u, p) iterations.
#pragma once

#include <cmath>

#include "softhom/materials/tensor.hpp"

namespace softhom {

/// W_V(J), written in δ = J − 1 so that its absolute rounding error is ε K δ instead of ε K (matters for
/// K/G ~ 10⁵).
inline double volumetric_energy(double K, double J) {
  const double d = J - 1.0;
  return 0.25 * K * (d * (2.0 + d) - 2.0 * std::log1p(d));
}
/// W_V′(J) = (K/2)(J − 1/J): the pressure of the law.
inline double volumetric_dU(double K, double J) { return 0.5 * K * (J - 1.0 / J); }
/// W_V″(J) = (K/2)(1 + 1/J²).
inline double volumetric_d2U(double K, double J) { return 0.5 * K * (1.0 + 1.0 / (J * J)); }

/// A += w J ∂(cof F)/∂F (9×9, flattened row-major), from ∂cof_iJ/∂F_kL = (cof_iJ cof_kL − cof_iL cof_kJ) / J:
/// with w = p / J the geometric stiffness of a pressure p acting through cof F.
inline void add_cofactor_derivative(double w, const Mat3& cof, Mat9& A) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k)
        for (int l = 0; l < 3; ++l) A(3 * i + j, 3 * k + l) += w * (cof(i, j) * cof(k, l) - cof(i, l) * cof(k, j));
}

}  // namespace softhom
