// The FE section mesher estimates its elements before meshing: A / (0.2 h²) at a uniform size h
// (measured), the graded band along the fiber boundaries otherwise; a mesh that cannot be solved in the
// available memory is refused naming solver.interface_size.
#include <gtest/gtest.h>

#include <chrono>
#include <string>

#include "softhom/materials/errors.hpp"
#include "softhom/materials/system_memory.hpp"
#include "softhom/rve/fe_mesh.hpp"

using namespace softhom;
using namespace softhom::rve;

namespace {

Section ecoflex_cell() {  // the cell of rve_ecoflex_circ45_fe.toml: r = 0.2, VF 0.23, side 0.739
  FiberCellSpec s;
  s.shape = SectionShape::circle;
  s.radius = 0.2;
  s.volume_fraction = 0.23;
  return generate_section(s);
}

}  // namespace

// grading 1e-9 keeps interface_size everywhere: 0.546 mm² / (0.2 · 0.0005²) = 1.1e7 elements at
// 29 kB each, 317 GB. Before, CGAL meshed it (19 GB in 90 s at interface_size 0.001, then bad_alloc).
TEST(MeshEstimates, UniformlyFineSectionIsRefusedBeforeMeshing) {
  if (available_memory_bytes() == 0) GTEST_SKIP() << "available memory unknown";
  SectionMeshOptions o;
  o.mesh_size = 0.05;
  o.interface_size = 0.0005;
  o.grading = 1e-9;
  const auto start = std::chrono::steady_clock::now();
  std::string message;
  try {
    mesh_section(ecoflex_cell(), o);
  } catch (const InputError& e) {
    message = e.what();
  }
  EXPECT_NE(message.find("solver.interface_size = 5e-04: about 1.1e+07 elements at mesh_size 0.05, grading 1e-09: needs about"),
            std::string::npos)
      << message;
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 5.0);  // no meshing
}

// The estimate against the mesh CGAL makes: the shipped scene's sizes (0.05, 0.015, grading 0.3) and a
// uniform 0.02. The band formula assumes sizes growing linearly to mesh_size; the measured element
// counts must lie within a factor 2 of the estimate for it to serve as a refusal bound either way.
TEST(MeshEstimates, ShippedSizesAreAcceptedAndMeshed) {
  const Section cell = ecoflex_cell();
  for (const auto& [h, hi, g, estimate] : {std::tuple{0.05, 0.015, 0.3, 3048.0}, std::tuple{0.02, 0.02, 0.3, 6826.0}}) {
    SectionMeshOptions o;
    o.mesh_size = h;
    o.interface_size = hi;
    o.grading = g;
    const SectionMesh m = mesh_section(cell, o);
    EXPECT_GT(double(m.elements.size()), 0.5 * estimate) << h << " " << hi;
    EXPECT_LT(double(m.elements.size()), 2.0 * estimate) << h << " " << hi;
  }
}
