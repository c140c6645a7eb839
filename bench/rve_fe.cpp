// Which RVE engine for which accuracy: FE (conforming T6 section mesh) vs FFT (voxel section grid) on
// the chapter-IV circular-fiber cell (VF 0.23, α = 45°, uniaxial tension). Prints wall time against the
// error of the homogenized P11 relative to a Richardson-extrapolated FE reference. Plain program (one
// solve is seconds). Usage:
//   bench_rve_fe MATRIX LAMBDA STEPS "FE divisions" "FFT grids"
//   e.g. bench_rve_fe pdms 1.5 5 "4 8 16 32 64" "16 32 64 128"
//   optional 6th argument "square": square fibers 0.07 mm, VF 0.12 (the dissertation's sharp-corner cell),
//     "square-nocorner": the same without corner refinement, "circle": the default cell
//   optional 7th/8th arguments: 3D FE divisions (Tet10 P2/P0 on a cube cell, mesh_size = L/d,
//     interface_size = L/(2d)) and 3D FFT grids n (n³ voxels, the section image extruded), e.g. "2 3" "16 32"
//   optional 9th argument: reference P11 (skips the Richardson reference, e.g. from an earlier run)
//   MATRIX may carry comma-separated variants: "ecoflex,K=170" (matrix bulk modulus, same G: the K/G
//     sweep of the FFT–FE comparison), ",p0" (section FE with P2/P0 instead of P2+bubble/P1),
//     ",spectral" / ",hex" (FFT discretization; default rotated), ",tol=1e-10" (both engines' tolerance);
//     3D FE: ",q4" / ",q14" (Tet10 quadrature points, default the solver's), ",odt" / ",lloyd" (CGAL
//     smoothing before the sliver perturber/exuder), ",r3=3" (3D interface size L/(r3·d), default 2),
//     ",seed=N" (CGAL's random seed)
// Times: wall and process CPU seconds (the box is shared: CPU time is the less noisy measure).
// FE division d: mesh_size = L/d, interface_size = L/(3d) (graded, quasi-uniform away from fibers).
// The reference is extrapolated from the three finest FE meshes with their observed order
// (h = √(area / elements)).
#include <chrono>
#include <ctime>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "softhom/materials/library.hpp"
#include "softhom/rve/fe_solver.hpp"
#include "softhom/rve/fft_solver.hpp"
#include "softhom/rve/geometry.hpp"

using namespace softhom;
using namespace softhom::rve;

namespace {

std::vector<double> numbers(const char* s) {
  std::vector<double> v;
  std::istringstream in(s);
  for (double x; in >> x;) v.push_back(x);
  return v;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double cpu_seconds() { return double(std::clock()) / CLOCKS_PER_SEC; }

struct Row {
  std::string engine;
  double resolution = 0.0, h = 0.0, P11 = 0.0, seconds = 0.0, cpu = 0.0;
  long size = 0;  // elements or voxels
  int newton = 0;
  bool ok = false;
};

}  // namespace

int main(int argc, char** argv) {
  std::string matrix_name = argc > 1 ? argv[1] : "pdms";
  // Variants after the preset name (see the usage above).
  double bulk_override = 0.0, tol_override = 0.0;
  bool fe_p0 = false, odt = false, lloyd = false;
  unsigned seed = 1;
  int tet_qp = 0;
  double r3 = 2.0;
  fft::Discretization fft_disc = fft::Discretization::rotated;
  {
    std::istringstream in(matrix_name);
    std::string tok;
    std::getline(in, matrix_name, ',');
    while (std::getline(in, tok, ',')) {
      if (tok.rfind("K=", 0) == 0) bulk_override = std::atof(tok.c_str() + 2);
      else if (tok.rfind("tol=", 0) == 0) tol_override = std::atof(tok.c_str() + 4);
      else if (tok == "p0") fe_p0 = true;
      else if (tok == "q4" || tok == "q14") tet_qp = std::atoi(tok.c_str() + 1);
      else if (tok == "odt") odt = true;
      else if (tok == "lloyd") lloyd = true;
      else if (tok.rfind("r3=", 0) == 0) r3 = std::atof(tok.c_str() + 3);
      else if (tok.rfind("seed=", 0) == 0) seed = unsigned(std::atoi(tok.c_str() + 5));
      else fft_disc = fft::parse_discretization(tok);
    }
  }
  const double lambda = argc > 2 ? std::atof(argv[2]) : 1.5;
  const int steps = argc > 3 ? std::atoi(argv[3]) : 5;
  const std::vector<double> fe_div = numbers(argc > 4 ? argv[4] : "4 8 16 32");
  const std::vector<double> fft_n = numbers(argc > 5 ? argv[5] : "16 32 64");
  const std::string shape = argc > 6 ? argv[6] : "circle";
  const bool square = shape.rfind("square", 0) == 0;
  const std::vector<double> fe3_div = numbers(argc > 7 ? argv[7] : "");
  const std::vector<double> fft3_n = numbers(argc > 8 ? argv[8] : "");
  const double given_ref = argc > 9 ? std::atof(argv[9]) : 0.0;
  FiberCellSpec spec;
  spec.shape = square ? SectionShape::rectangle : SectionShape::circle;
  spec.radius = 0.2;
  spec.width = spec.height = 0.07;
  spec.volume_fraction = square ? 0.12 : 0.23;
  const Section section = generate_section(spec);
  MaterialSpec matrix_spec = preset_spec(matrix_name);
  if (bulk_override > 0.0) matrix_spec.gent.K = bulk_override;
  const MaterialPtr matrix = build_material(matrix_spec), glass = build_material(preset_spec("glass"));
  FeSolverOptions fe_opt;
  if (fe_p0) fe_opt.pressure = FePressure::p0;
  if (tol_override > 0.0) fe_opt.tolerance = tol_override;
  MixedControl control = uniaxial_control(PiecewiseLinear{{0.0, 1.0}, {1.0, lambda}});
  control.times.clear();
  for (int k = 1; k <= steps; ++k) control.times.push_back(double(k) / steps);
  std::printf("# matrix %s (G %.6g, K %.6g), glass %s fibers, VF %.2f, alpha 45, uniaxial lambda %.3g in %d steps, "
              "FE pressure %s, FFT %s, load %s\n",
              matrix_name.c_str(), matrix->initial_shear_modulus(), matrix->initial_bulk_modulus(),
              square ? "square" : "circular", spec.volume_fraction, lambda, steps, to_string(fe_opt.pressure),
              fft::to_string(fft_disc), [] {
                static char buf[64] = "?";
                std::FILE* f = std::fopen("/proc/loadavg", "r");
                if (f) {
                  if (!std::fgets(buf, sizeof buf, f)) buf[0] = 0;
                  std::fclose(f);
                  for (char* c = buf; *c; ++c)
                    if (*c == '\n') *c = 0;
                }
                return buf;
              }());
  std::vector<Row> rows;
  for (double d : fe_div) {
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = cpu_seconds();
    SectionMeshOptions mo;
    mo.mesh_size = section.L1 / d;
    mo.interface_size = mo.mesh_size / 3.0;
    mo.corner_refinement = shape != "square-nocorner";
    SectionMesh mesh = mesh_section(section, mo);
    Row r;
    r.engine = "fe";
    r.resolution = d;
    r.size = mesh.num_elements();
    r.h = std::sqrt(section.L1 * section.L2 / mesh.num_elements());
    FeRveSolver solver(std::move(mesh), matrix, glass, 45.0, control.frame, fe_opt);
    const RveRunResult res = solver.run(control);
    r.seconds = seconds_since(t0);
    r.cpu = cpu_seconds() - c0;
    r.ok = res.completed;
    r.newton = res.newton_iterations;
    r.P11 = res.steps.back().P(0, 0);
    std::printf("fe  L/%-4g elements %7ld eq %7d newton %4d time %8.2f s cpu %8.2f s (assembly %.2f, linear %.2f) "
                "VF %.8f (exact %.8f) P11 %.9f %s\n", d, r.size, solver.num_equations(), r.newton, r.seconds, r.cpu,
                solver.assembly_seconds(), solver.factorization_seconds(), solver.achieved_volume_fraction(),
                section.volume_fraction, r.P11, r.ok ? "" : res.error.c_str());
    std::fflush(stdout);
    rows.push_back(r);
  }
  for (double n : fft_n) {
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = cpu_seconds();
    FftSolverOptions o;
    o.tolerance = tol_override > 0.0 ? tol_override : 1e-8;
    o.discretization = fft_disc;
    o.plan.rigor = fft::PlanRigor::estimate;
    FftRveSolver solver(voxelize_section(section, int(n), int(n)), matrix, glass, 45.0, control.frame, o);
    const RveRunResult res = solver.run(control);
    Row r;
    r.engine = "fft";
    r.resolution = n;
    r.size = long(n * n);
    r.h = section.L1 / n;
    r.seconds = seconds_since(t0);
    r.cpu = cpu_seconds() - c0;
    r.ok = res.completed;
    r.newton = res.newton_iterations;
    r.P11 = res.steps.back().P(0, 0);
    std::printf("fft %4g^2 newton %4d krylov %7d time %8.2f s cpu %8.2f s VF %.8f P11 %.9f %s\n", n, r.newton,
                res.krylov_iterations, r.seconds, r.cpu, solver.achieved_volume_fraction(), r.P11,
                r.ok ? "" : res.error.c_str());
    std::fflush(stdout);
    rows.push_back(r);
  }
  // 3D: Tet10 P2/P0 on the cube cell (L3 = L1), and the FFT engine on the extruded image.
  for (double d : fe3_div) {
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = cpu_seconds();
    CellMeshOptions mo;
    mo.mesh_size = section.L1 / d;
    mo.interface_size = mo.mesh_size / r3;
    mo.odt = odt;
    mo.lloyd = lloyd;
    mo.seed = seed;
    CellMesh mesh = mesh_cell(section, mo);
    const double mesh_s = seconds_since(t0);
    Row r;
    r.engine = "fe3d";
    r.resolution = d;
    r.size = mesh.num_elements();
    r.h = std::cbrt(section.L1 * section.L2 * mesh.L3 / mesh.num_elements());
    const CellMeshQuality q = mesh.quality;
    FeSolverOptions so = fe_opt;
    so.pressure = FePressure::p0;
    if (tet_qp) so.tet_quadrature_points = tet_qp;
    FeRveSolver solver(std::move(mesh), matrix, glass, 45.0, control.frame, so);
    const RveRunResult res = solver.run(control);
    r.seconds = seconds_since(t0);
    r.cpu = cpu_seconds() - c0;
    r.ok = res.completed;
    r.newton = res.newton_iterations;
    r.P11 = res.steps.back().P(0, 0);
    std::printf("fe3d L/%-4g elements %7ld eq %7d newton %4d time %8.2f s cpu %8.2f s (mesh %.2f, assembly %.2f, linear %.2f) "
                "dihedral %.1f rr %.3f (mean %.3f) unlabeled %d offset %.1e qp %d VF %.8f (mesh fiber volume error %.2e) P11 %.9f %s\n",
                d, r.size, solver.num_equations(), r.newton, r.seconds, r.cpu, mesh_s, solver.assembly_seconds(),
                solver.factorization_seconds(), q.min_dihedral_deg, q.min_radius_ratio, q.mean_radius_ratio,
                q.unlabeled_cells, q.max_interface_offset, so.tet_quadrature_points, solver.achieved_volume_fraction(),
                q.fiber_volume_error, r.P11,
                r.ok ? "" : res.error.c_str());
    std::fflush(stdout);
    rows.push_back(r);
  }
  for (double n : fft3_n) {
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = cpu_seconds();
    FftSolverOptions o;
    o.tolerance = 1e-8;
    o.plan.rigor = fft::PlanRigor::estimate;
    FftRveSolver solver(extrude(voxelize_section(section, int(n), int(n)), int(n)), matrix, glass, 45.0, control.frame, o);
    const RveRunResult res = solver.run(control);
    Row r;
    r.engine = "fft3d";
    r.resolution = n;
    r.size = long(n * n * n);
    r.h = section.L1 / n;
    r.seconds = seconds_since(t0);
    r.cpu = cpu_seconds() - c0;
    r.ok = res.completed;
    r.newton = res.newton_iterations;
    r.P11 = res.steps.back().P(0, 0);
    std::printf("fft3d %4g^3 newton %4d krylov %7d time %8.2f s cpu %8.2f s P11 %.9f %s\n", n, r.newton,
                res.krylov_iterations, r.seconds, r.cpu, r.P11, r.ok ? "" : res.error.c_str());
    std::fflush(stdout);
    rows.push_back(r);
  }
  // Reference: given, or the Richardson extrapolation of the three finest section FE meshes.
  double ref = given_ref;
  if (ref == 0.0) {
    std::vector<Row> fe;
    for (const Row& r : rows)
      if (r.engine == "fe" && r.ok) fe.push_back(r);
    if (fe.size() < 3) return 0;
    const Row &a = fe[fe.size() - 3], &b = fe[fe.size() - 2], &c = fe[fe.size() - 1];
    const double order = std::log(std::abs(b.P11 - a.P11) / std::abs(c.P11 - b.P11)) / std::log(b.h / c.h);
    ref = c.P11 + (c.P11 - b.P11) / (std::pow(b.h / c.h, order) - 1.0);
    std::printf("# FE observed order %.2f, extrapolated P11 %.9f\n", order, ref);
  } else {
    std::printf("# reference P11 %.9f (given)\n", ref);
  }
  std::printf("| engine | resolution | elements / voxels | Newton | wall s | CPU s | P11 | rel. error |\n"
              "|---|---|---|---|---|---|---|---|\n");
  for (const Row& r : rows) {
    const bool fe_row = r.engine == "fe" || r.engine == "fe3d";
    std::printf("| %s | %s%g%s | %ld | %d | %.2f | %.2f | %.6f | %.2e |\n", r.engine.c_str(), fe_row ? "L/" : "",
                r.resolution, r.engine == "fft3d" ? "³" : r.engine == "fft" ? "²" : "", r.size, r.newton, r.seconds,
                r.cpu, r.P11, std::abs(r.P11 - ref) / std::abs(ref));
  }
  return 0;
}
