#pragma once
// Closed forms of spec §5 (incompressible Gent) evaluated by composite Gauss–Legendre quadrature.
#include <cmath>

namespace softhom::macro::test_support {

inline double mu_eff(double G, double Jm, double I1) { return G * Jm / (Jm - I1 + 3.0); }

/// ∫_a^b f(x) dx with 200 panels of 3-point Gauss (smooth integrands: error ≪ 1e-10 relative).
template <class F>
double integrate(F f, double a, double b) {
  const int panels = 200;
  const double g[3] = {-std::sqrt(0.6), 0.0, std::sqrt(0.6)}, w[3] = {5.0 / 9, 8.0 / 9, 5.0 / 9};
  double sum = 0.0, h = (b - a) / panels;
  for (int k = 0; k < panels; ++k)
    for (int q = 0; q < 3; ++q) sum += w[q] * f(a + h * (k + 0.5 + 0.5 * g[q])) * 0.5 * h;
  return sum;
}

/// Thick tube in plane strain inflated to inner radius r_i.
inline double tube_pressure(double G, double Jm, double Ri, double Ro, double ri) {
  const double ro = std::sqrt(ri * ri + Ro * Ro - Ri * Ri);
  return integrate(
      [&](double r) {
        const double R = std::sqrt(r * r - ri * ri + Ri * Ri), l = r / R;
        return mu_eff(G, Jm, l * l + 1 / (l * l) + 1) * (l * l - 1 / (l * l)) / r;
      },
      ri, ro);
}

/// Thick sphere inflated to inner radius r_i.
inline double sphere_pressure(double G, double Jm, double Ri, double Ro, double ri) {
  const double ro = std::cbrt(ri * ri * ri + Ro * Ro * Ro - Ri * Ri * Ri);
  return integrate(
      [&](double r) {
        const double R = std::cbrt(r * r * r - ri * ri * ri + Ri * Ri * Ri), l = r / R;
        return 2 * mu_eff(G, Jm, 2 * l * l + std::pow(l, -4)) * (l * l - std::pow(l, -4)) / r;
      },
      ri, ro);
}

/// Thin balloon, eq. 3.7.
inline double thin_balloon_pressure(double G, double Jm, double r0, double t0, double l) {
  return 2 * G * t0 / r0 * Jm * (1 / l - std::pow(l, -7)) / (Jm + 3 - std::pow(l, -4) - 2 * l * l);
}

}  // namespace softhom::macro::test_support
