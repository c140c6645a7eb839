// Plausibility warnings of a material's moduli (plausibility.hpp).
#include "softhom/materials/plausibility.hpp"

#include <cstdio>

namespace softhom {

namespace {

// Moduli as written (6 significant digits: 17000, 0.017), ratios to 4.
std::string modulus(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.6g", x);
  return b;
}
std::string ratio(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.4g", x);
  return b;
}

}  // namespace

std::vector<std::string> plausibility_warnings(double G, double K, MaterialRole role, const std::string& field) {
  std::vector<std::string> w;
  if (!(G > 0.0) || !(K > 0.0)) return w;  // refused by validation already
  const std::string head = "plausibility: " + field + ": ";
  const std::string moduli = "G = " + modulus(G) + " MPa, K = " + modulus(K) + " MPa";
  const double nu = (3.0 * K - 2.0 * G) / (2.0 * (3.0 * K + G));
  if (nu < 0.0)
    w.push_back(head + moduli + " give Poisson's ratio " + ratio(nu) +
                " < 0 (K < 2G/3); check the moduli and that they are in MPa");
  const double soft_limit = role == MaterialRole::any ? 1000.0 : 100.0;
  if (role != MaterialRole::fiber && G > soft_limit)
    w.push_back(head + "shear modulus G = " + modulus(G) + " MPa is that of a hard solid, not of a soft matrix " +
                "(elastomers: 0.01-10 MPa); moduli are in MPa: " + modulus(G) + " Pa would be " +
                modulus(G * 1e-6) + " MPa");
  if (role == MaterialRole::matrix && nu >= 0.0 && K < 100.0 * G)
    w.push_back(head + moduli + ": K/G = " + ratio(K / G) + " (Poisson's ratio " + ratio(nu) +
                ") makes the matrix compressible; rubbers are near-incompressible (K/G >= 1000)");
  return w;
}

std::vector<std::string> plausibility_warnings(const Material& material, MaterialRole role, const std::string& field) {
  return plausibility_warnings(material.initial_shear_modulus(), material.initial_bulk_modulus(), role, field);
}

}  // namespace softhom
