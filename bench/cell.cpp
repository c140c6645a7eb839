// Embedding facade benchmark: cost of the homogenized consistent tangent ∂P̄/∂F̄ (9 linear cell
// problems with the converged tangent field, FftRveSolver::homogenized_tangent) relative to one
// Newton solve of the cell, as in an FE² quadrature-point call. Plain program. Usage:
//   bench_cell [pdms|ecoflex] [n ...] [repeat=N] [threads=T]
// Cell: circular glass fiber (VF 0.23, α = 45°) in the preset matrix, n² section (rotated
// discretization, scene defaults otherwise: tolerance 1e-6 as the shipped scenes). Macro step: F̄1 =
// isochoric stretch 1.2 solved and committed, then the measured call: a solve at F̄2 = (I + 0.005
// e1⊗e2) · (isochoric stretch 1.01) · F̄1 (the extrapolation predictor warm-starts it) and the
// tangent at tangent tolerances 1e-6 and 1e-10. Prints medians over `repeat` calls: wall time, Newton and Krylov iterations, the
// tangent/solve time ratio, the relative asymmetry of C̄ and the difference between the two tangent
// tolerances, the solver's memory.
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "softhom/studies/cell.hpp"

using namespace softhom;
using namespace softhom::studies;

namespace {

std::string load_average() {
  std::ifstream in("/proc/loadavg");
  std::string a;
  in >> a;
  return a;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

std::string scene(const std::string& matrix, int n) {
  return "[microstructure]\nshape = \"circle\"\narrangement = \"square\"\nvolume_fraction = 0.23\nradius = 0.2\n"
         "fiber_angle_deg = 45\ngrid = [" + std::to_string(n) + ", " + std::to_string(n) +
         "]\n[phases.matrix]\npreset = \"" + matrix + "\"\n[phases.fiber]\npreset = \"glass\"\n"
         "[solver]\ndiscretization = \"rotated\"\ntolerance = 1e-6\n";
}

}  // namespace

int main(int argc, char** argv) {
  std::string matrix = "pdms";
  std::vector<int> grids;
  int repeat = 3;
  for (int a = 1; a < argc; ++a) {
    const std::string s = argv[a];
    if (s == "pdms" || s == "ecoflex") matrix = s;
    else if (s.rfind("repeat=", 0) == 0) repeat = std::max(1, std::stoi(s.substr(7)));
    else if (s.rfind("threads=", 0) == 0) omp_set_num_threads(std::stoi(s.substr(8)));
    else grids.push_back(std::stoi(s));
  }
  if (grids.empty()) grids = {32, 64, 128};
  std::printf("# bench_cell %s, threads %d, load %s\n", matrix.c_str(), omp_get_max_threads(), load_average().c_str());
  std::printf("%6s %9s %8s %7s %8s | %9s %7s %7s | %9s %7s %7s | %9s %9s\n", "grid", "MB", "solve_s", "newton",
              "krylov", "tan6_s", "krylov", "ratio", "tan10_s", "krylov", "ratio", "asym", "d(6,10)");
  for (int n : grids) {
    CellOptions o6, o10;
    o6.tangent_tolerance = 1e-6;
    o10.tangent_tolerance = 1e-10;
    Cell cell(scene(matrix, n), "bench", o10), cell6(scene(matrix, n), "bench", o6);
    // Isochoric macro states (J̄ = 1: the matrices are nearly incompressible, K/G = 3000 for pdms).
    auto isochoric_stretch = [](double l) {
      Mat3 F = Mat3::Identity();
      F(0, 0) = l;
      F(1, 1) = F(2, 2) = 1.0 / std::sqrt(l);
      return F;
    };
    const Mat3 F1 = isochoric_stretch(1.2);
    Mat3 shear = Mat3::Identity();
    shear(0, 1) = 0.005;
    const Mat3 F2 = shear * isochoric_stretch(1.01) * F1;
    for (Cell* c : {&cell, &cell6}) {
      const CellResult r1 = c->solve(F1, 0.0, false);
      if (!r1.converged) {
        std::printf("%6d first step failed: %s\n", n, r1.error.c_str());
        return 1;
      }
      c->commit();
    }
    std::vector<double> ts, t6, t10, newton, krylov, k6, k10;
    double asym = 0.0, diff = 0.0;
    for (int r = 0; r < repeat; ++r) {
      const CellResult a = cell.solve(F2, 0.0, true);
      const CellResult b = cell6.solve(F2, 0.0, true);
      if (!a.converged || !b.converged) {
        std::printf("%6d solve failed: %s %s\n", n, a.error.c_str(), b.error.c_str());
        return 1;
      }
      ts.push_back(a.solve_seconds);
      ts.push_back(b.solve_seconds);
      newton.push_back(a.counts.newton_iterations);
      krylov.push_back(a.counts.krylov_iterations);
      t10.push_back(a.tangent_seconds);
      k10.push_back(a.tangent_krylov_iterations);
      t6.push_back(b.tangent_seconds);
      k6.push_back(b.tangent_krylov_iterations);
      asym = (a.tangent - a.tangent.transpose()).norm() / a.tangent.norm();
      diff = (a.tangent - b.tangent).norm() / a.tangent.norm();
    }
    const double s = median(ts);
    std::printf("%6d %9.1f %8.3f %7.0f %8.0f | %9.3f %7.0f %7.2f | %9.3f %7.0f %7.2f | %9.1e %9.1e\n", n,
                double(cell.memory_bytes()) / 1e6, s, median(newton), median(krylov), median(t6), median(k6),
                median(t6) / s, median(t10), median(k10), median(t10) / s, asym, diff);
    std::fflush(stdout);
  }
  std::printf("# load after: %s\n", load_average().c_str());
  return 0;
}
