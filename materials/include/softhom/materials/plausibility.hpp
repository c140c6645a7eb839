#pragma once
// Plausibility of a material's moduli: input that is valid but probably not what was meant (a modulus
// in Pa where softhom reads MPa, a negative Poisson's ratio, a compressible rubber). Warnings, not
// errors: such a material may be intended, and the run goes on; the jobs put them in summary.json
// "warnings" and on stderr.
#include <string>
#include <vector>

#include "softhom/materials/material.hpp"

namespace softhom {

/// What the material is in its scene: the soft matrix of a cell, its fiber, or not known (point, macro).
enum class MaterialRole { any, matrix, fiber };

/// Warnings for initial shear modulus G and bulk modulus K [MPa] of the material at `field` ("material",
/// "phases.matrix"), each starting with "plausibility: <field>":
/// - ν = (3K − 2G) / (2 (3K + G)) < 0 (K < 2G/3): a negative Poisson's ratio;
/// - G above 100 MPa for a matrix (1000 MPa when the role is not known): elastomers have G of
///   0.01–10 MPa; 17000 looks like 17 kPa written in Pa;
/// - a matrix with K/G < 100 (ν < 0.495): softhom's matrices are near-incompressible rubbers (K/G ≈ 1e5
///   for Ecoflex at K = 2000 MPa), and a small K/G changes the composite's response qualitatively.
std::vector<std::string> plausibility_warnings(double G, double K, MaterialRole role, const std::string& field);
/// The same for a built material (its initial moduli).
std::vector<std::string> plausibility_warnings(const Material& material, MaterialRole role, const std::string& field);

}  // namespace softhom
