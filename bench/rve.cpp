// FFT RVE benchmark: Newton/Krylov iterations versus stiffness contrast, matrix K/G and resolution;
// cost per Krylov iteration versus the FFTs alone. Plain program (no timing loop of Google
// Benchmark: one solve is already seconds). Usage:
//   bench_rve contrast [n ...]     fiber/matrix shear contrast 10 … 1e6, one load step λ = 1.05
//   bench_rve bulk [n ...]         matrix K/G 10 … 1.2e5 at contrast 230, λ = 1.5 in 8 steps, mixed (u,p)
//                                  Newton iteration on and off
//   bench_rve fftcost [disc ...] [grid ...] [threads=1|2 ...] [operator=fourier|stencil ...] [repeat=N] [compact=off]
//                    [precision=double|single ...] [fftw_threads=N] [fftw=estimate|measure|patient]
//                                  cost of one Krylov iteration (time in the linear solves / iterations)
//                                  vs a 9-field FFT round trip (ratio-9) and vs the round trip of the fields
//                                  the operator transforms (ratio-own), memory per voxel, 1 and 2 threads and
//                                  both Krylov operators in one run. grid: "256" (256² section) or "64x64x64";
//                                  disc: rotated|hex|spectral (default all); repeat: best of N measurements;
//                                  precision: tangent storage of the stencil operator (default double);
//                                  fftw_threads: FFTW plan threads of the solver (default = OpenMP threads);
//                                  fftw: planning rigor of the solver's and the timed transforms (default measure)
//   bench_rve fftpasses [grid ...] [threads=1|2 ...] [calls=N]
//                                  the passes of one stencil Krylov iteration (rotated) timed alone, min over
//                                  N calls each (robust on a loaded box): gradient + tangent product + store
//                                  with double and float tangents, gather (adjoint), 3-field FFT round trip
//                                  with FFTW planned for the OpenMP thread count and for 1 thread
//   bench_rve timeerror pdms|ecoflex 2|3 [disc ...] [n ...]
//                                  time (CPU and wall) versus error of P11 at λ = 1.5 (preset materials,
//                                  as bench_rve_fe) on n² sections (2) or n³ cells (3, the section extruded),
//                                  error against the FE reference and against each discretization's own
//                                  Richardson extrapolation; cheapest setting reaching 1 % and 0.1 %
//   bench_rve freefiber [n ...] [case=0..5 ...] [fe=D ...] [disc=D] [kg=K/G] [binary] [plain] [homogeneous] [fbar]
//                       [minres_below=X] [fe_p0] [reference=geometric]
//                                  glass fiber in a Gent matrix along / across the fiber with the fiber
//                                  stretch free (BENCHMARKS.md "FFT solver cost"); fe=D: the FE engine on
//                                  the same cell and control (mesh L/D) as the reference
//   bench_rve eigen [n ...] [case=0|1] [k=K] [disc=D] [binary] [mixed=0]
//                                  negative and zero eigenvalues of the dense fluctuation Newton operator
//                                  at the converged states of that cell (small n)
//   bench_rve resolution pdms|ecoflex [n ...]
//                                  time versus error of P11 at λ = 1.5 (8 steps) for each discretization,
//                                  error against the Richardson extrapolation of the two finest grids
#include <omp.h>
#include <Eigen/Eigenvalues>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "softhom/fft/gradient.hpp"
#include "softhom/fft/stencil.hpp"
#include "softhom/io/files.hpp"
#include "softhom/materials/laws.hpp"
#include "softhom/materials/library.hpp"
#include "softhom/rve/fe_mesh.hpp"
#include "softhom/rve/fe_solver.hpp"
#include "softhom/rve/fft_solver.hpp"
#include "softhom/rve/geometry.hpp"

using namespace softhom;
using namespace softhom::rve;

namespace {

PhaseImage circle_cell(int n) {
  FiberCellSpec spec;
  spec.shape = SectionShape::circle;
  spec.arrangement = Arrangement::square;
  spec.volume_fraction = 0.23;
  spec.radius = 0.2;
  return voxelize_section(generate_section(spec), n, n);
}

std::string load_average() {
  std::ifstream in("/proc/loadavg");
  std::string a;
  in >> a;
  return a;
}

double cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

/// Resident set size now (VmRSS), bytes.
std::size_t resident_bytes() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::size_t(std::atol(line.c_str() + 6)) * 1024;
  return 0;
}

/// "256" → 256² section; "64x64x64" → 64³.
fft::Grid parse_grid(const std::string& s) {
  int a = 0, b = 0, c = 0;
  if (std::sscanf(s.c_str(), "%dx%dx%d", &a, &b, &c) == 3) return fft::Grid{{a, b, c}, {1.0, 1.0, double(c) / a}};
  a = std::atoi(s.c_str());
  return fft::Grid{{a, a, 1}, {1.0, 1.0, 1.0 / a}};
}

PhaseImage cell_image(const fft::Grid& g) {
  const PhaseImage section = circle_cell(g.n[0]);
  return g.n[2] > 1 ? extrude(section, g.n[2]) : section;
}

bool is_discretization(const std::string& s) { return s == "rotated" || s == "hex" || s == "spectral"; }

MixedControl ramp(double lambda, int steps) {
  MixedControl c = uniaxial_control(PiecewiseLinear{{0.0, 1.0}, {1.0, lambda}});
  c.times.clear();
  for (int s = 1; s <= steps; ++s) c.times.push_back(double(s) / steps);
  return c;
}
MixedControl one_step(double lambda) { return ramp(lambda, 1); }

void solve_and_print(const char* label, double value, int n, fft::Discretization d, MaterialPtr m, MaterialPtr f,
                     bool mixed = true, const MixedControl& control = one_step(1.05)) {
  FftSolverOptions o;
  o.mixed_pressure = mixed;
  o.discretization = d;
  o.tolerance = 1e-6;
  o.plan.rigor = fft::PlanRigor::measure;
  FftRveSolver solver(circle_cell(n), m, f, 45.0, Mat3::Identity(), o);
  const auto t0 = std::chrono::steady_clock::now();
  const RveRunResult r = solver.run(control);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const int newton = r.newton_iterations, krylov = r.krylov_iterations;
  std::printf("%-8s %10.3g %5d %-9s %-5s %4s newton %4d krylov %6d krylov/newton %7.1f cutbacks %d shifted %d time %7.2f s P11 %.6g\n",
              label, value, n, fft::to_string(d), mixed ? "mixed" : "plain", r.completed ? "ok" : "FAIL", newton, krylov,
              newton ? double(krylov) / newton : 0.0, r.cutbacks, r.shifted_solves, s, r.steps.back().P(0, 0));
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  const std::string mode = argc > 1 ? argv[1] : "contrast";
  std::vector<int> sizes;
  for (int i = 2; i < argc; ++i) sizes.push_back(std::atoi(argv[i]));
  if (sizes.empty()) sizes = {32, 64, 128};
  std::printf("# threads %d\n", omp_get_max_threads());
  if (mode == "contrast") {
    // Matrix neo-Hookean μ = 1, K = 10 (K/G = 10); fiber μ = c, K = 10 c.
    for (double c : {10.0, 230.0, 1e3, 1e4, 1e6})
      for (int n : sizes)
        for (auto d : {fft::Discretization::rotated, fft::Discretization::hex, fft::Discretization::spectral})
          solve_and_print("contrast", c, n, d, make_material(make_neo_hookean({1.0, 10.0})),
                          make_material(make_neo_hookean({c, 10.0 * c})));
  } else if (mode == "bulk") {
    // Matrix Gent G = 0.017, Jm = 14, K = KG · G; glass fiber (contrast ≈ 230). Optional arguments
    // "kg=V" (K/G values, default 10 … 1.2e5) and "mixed" (mixed iteration only).
    std::vector<double> kgs;
    bool mixed_only = false;
    sizes.clear();
    for (int i = 2; i < argc; ++i) {
      const std::string a = argv[i];
      if (a.rfind("kg=", 0) == 0)
        kgs.push_back(std::atof(a.c_str() + 3));
      else if (a == "mixed")
        mixed_only = true;
      else
        sizes.push_back(std::atoi(a.c_str()));
    }
    if (kgs.empty()) kgs = {10.0, 1e2, 1e3, 1e4, 1.2e5};
    if (sizes.empty()) sizes = {32};
    for (double kg : kgs)
      for (int n : sizes)
        for (bool mixed : {true, false})
          if (mixed || !mixed_only)
          solve_and_print("K/G", kg, n, fft::Discretization::rotated,
                          make_material(make_gent_hgo({0.017, 14.0, 0.017 * kg, {}, FiberInvariant::full, true})),
                          make_material(make_neo_hookean(NeoHookeanParams::from_young(10.0, 0.3))), mixed, ramp(1.5, 8));
  } else if (mode == "freefiber") {
    // Gent matrix K/G = 1.2e5 + glass fiber along e1 (α = 90°), λ = 1.5 in 8 steps: uniaxial stress
    // along the fiber, then transverse (F22 = λ) with the fiber stretch F11 free (P11 = 0); and the
    // transverse case with the fiber along e2 (α = 0°, F22 free) for comparison.
    // "fe=D" arguments: the same cell and control on the conforming FE mesh (mesh_size = L/D,
    // interface L/(3D)), the independent reference of the FFT answer.
    std::vector<int> cases;  // "case=K" arguments (0–5) select cases; "reference=geometric" the medium
    std::vector<double> fe_divisions;
    bool geometric = false;
    fft::Discretization disc = fft::Discretization::rotated;  // "disc=rotated|hex|spectral"
    bool binary = false;
    bool homogeneous = false;  // "homogeneous": the fiber phase made of the matrix law (closed-form check)
    double minres_below = -1.0;
    double matrix_kg = 1.2e5;  // "kg=X": matrix K/G
    bool plain = false;        // "plain": FFT without the mixed (u, p) iteration
    bool fbar = false;         // "fbar": hex with [solver] volumetric = "mean-dilatation"
    bool fe_p0 = false;        // "fe_p0": FE with the P2/P0 pressure space instead of P2+bubble/P1  // "minres_below=X": FftSolverOptions::minres_below (default: the solver's)  // "binary": voxels rounded to one phase (no composite voxels / laminate rule)
    sizes.clear();
    for (int i = 2; i < argc; ++i) {
      if (std::strncmp(argv[i], "case=", 5) == 0)
        cases.push_back(std::atoi(argv[i] + 5));
      else if (std::strncmp(argv[i], "fe=", 3) == 0)
        fe_divisions.push_back(std::atof(argv[i] + 3));
      else if (std::strcmp(argv[i], "reference=geometric") == 0)
        geometric = true;
      else if (std::strncmp(argv[i], "minres_below=", 13) == 0)
        minres_below = std::atof(argv[i] + 13);
      else if (std::strcmp(argv[i], "binary") == 0)
        binary = true;
      else if (std::strcmp(argv[i], "homogeneous") == 0)
        homogeneous = true;
      else if (std::strcmp(argv[i], "plain") == 0)
        plain = true;
      else if (std::strcmp(argv[i], "fbar") == 0)
        fbar = true;
      else if (std::strcmp(argv[i], "fe_p0") == 0)
        fe_p0 = true;
      else if (std::strncmp(argv[i], "kg=", 3) == 0)
        matrix_kg = std::atof(argv[i] + 3);
      else if (std::strncmp(argv[i], "disc=", 5) == 0)
        disc = fft::parse_discretization(argv[i] + 5);
      else
        sizes.push_back(std::atoi(argv[i]));
    }
    if (sizes.empty() && fe_divisions.empty()) sizes = {32};
    const auto matrix = [&] { return make_material(make_gent_hgo({0.017, 14.0, 0.017 * matrix_kg, {}, FiberInvariant::full, true})); };
    const auto glass = [&] {
      return homogeneous ? matrix() : make_material(make_neo_hookean(NeoHookeanParams::from_young(10.0, 0.3)));
    };
    for (int n : sizes.empty() ? std::vector<int>{0} : sizes)
      for (int c = 0; c < 6; ++c) {
        if (!cases.empty() && std::find(cases.begin(), cases.end(), c) == cases.end()) continue;
        MixedControl control = ramp(1.5, 8);
        double angle = 90.0;
        if (c == 1 || c >= 3) {
          const auto zero = PiecewiseLinear::constant(0.0);
          for (int k = 0; k < 9; ++k) {
            control.kind[k] = ControlKind::stress;
            control.value[k] = zero;
          }
          control.kind[4] = ControlKind::deformation;
          control.value[4] = PiecewiseLinear{{0.0, 1.0}, {1.0, 1.5}};
          for (int k : {3, 5, 2}) control.kind[k] = ControlKind::deformation;  // F21 = F23 = F13 = 0
          control.name = "transverse, F11 free";
          if (c == 3) control.kind[6] = control.kind[7] = ControlKind::deformation;  // F31 = F32 = 0
          if (c == 5) {  // F11 prescribed on (about) the path the free case follows: 1 → 0.98995
            control.kind[0] = ControlKind::deformation;
            control.value[0] = PiecewiseLinear{{0.0, 1.0}, {1.0, 0.98995}};
          }
        }
        if (c == 2) angle = 0.0;
        const char* name[6] = {"along-fiber", "transverse-F11-free", "transverse-a0", "transverse-no-shear", "transverse-minres",
                               "transverse-F11-given"};
        for (double d : fe_divisions) {
          FiberCellSpec spec;
          spec.shape = SectionShape::circle;
          spec.arrangement = Arrangement::square;
          spec.volume_fraction = 0.23;
          spec.radius = 0.2;
          const Section section = generate_section(spec);
          SectionMeshOptions mo;
          mo.mesh_size = section.L1 / d;
          mo.interface_size = mo.mesh_size / 3.0;
          FeSolverOptions fo;
          fo.tolerance = 1e-8;
          if (fe_p0) fo.pressure = FePressure::p0;
          FeRveSolver fe(mesh_section(section, mo), matrix(), glass(), angle, Mat3::Identity(), fo);
          const auto t0 = std::chrono::steady_clock::now();
          const RveRunResult r = fe.run(control);
          const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
          std::printf("freefiber-fe %-20s L/%-3g elements %6d %4s newton %4d cutbacks %d time %7.2f s P %.9g %.9g F11 %.9g solver %s\n",
                      name[c], d, fe.num_elements(), r.completed ? "ok" : "FAIL", r.newton_iterations, r.cutbacks, sec,
                      r.steps.back().P(0, 0), r.steps.back().P(1, 1), r.steps.back().F(0, 0), fe.linear_solver().c_str());
          std::fflush(stdout);
        }
        if (n == 0) continue;
        FftSolverOptions o;
        o.tolerance = 1e-6;
        if (c == 4) o.minres_below = 1e300;  // MINRES on every negative curvature
        if (minres_below >= 0.0) o.minres_below = minres_below;
        if (geometric) o.reference = ReferenceMedium::geometric;
        o.discretization = disc;
        if (plain) o.mixed_pressure = false;
        if (fbar) {
          o.discretization = fft::Discretization::hex;
          o.volumetric = VolumetricKinematics::mean_dilatation;
        }
        PhaseImage image = circle_cell(n);
        if (binary)
          for (std::size_t v = 0; v < image.voxels(); ++v) {
            image.fiber_fraction[v] = image.fiber_fraction[v] >= 0.5 ? 1.0 : 0.0;
            image.normal[v].setZero();
          }
        FftRveSolver solver(image, matrix(), glass(), angle, Mat3::Identity(), o);
        const auto t0 = std::chrono::steady_clock::now();
        const RveRunResult r = solver.run(control);
        const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::printf("freefiber %-20s n %4d %4s newton %4d krylov %7d krylov/newton %7.1f cutbacks %d shifted %d minres %d discarded %d time %7.2f s P %.6g %.6g F11 %.6g\n",
                    name[c], n, r.completed ? "ok" : "FAIL", r.newton_iterations, r.krylov_iterations,
                    r.newton_iterations ? double(r.krylov_iterations) / r.newton_iterations : 0.0, r.cutbacks,
                    r.shifted_solves, r.minres_solves, r.discarded_krylov_iterations, sec, r.steps.back().P(0, 0), r.steps.back().P(1, 1), r.steps.back().F(0, 0));
        for (const std::string& l : r.log) std::printf("  log: %s\n", l.c_str());
        std::fflush(stdout);
      }
  } else if (mode == "eigen") {
    // bench_rve eigen [n ...] [case=0|1] [binary] [mixed=0] [k=K] [disc=D]: the freefiber cell loaded to λ_k = 1 +
    // k/16 (k = 1 … 8, k steps); at each converged state the fluctuation Newton operator assembled
    // densely (FftRveSolver::dense_fluctuation_operator) and its negative eigenvalues counted, with the
    // frequency of the most negative eigenvector (Σ |D_k|² v² / max |D_k|²: 1 = the grid's highest
    // frequency, small = long waves).
    int c = 1;
    bool binary = false, mixed = true;
    fft::Discretization disc = fft::Discretization::rotated;  // "disc=..."
    int only_k = 0;  // "k=K": only the state after K steps
    sizes.clear();
    for (int i = 2; i < argc; ++i) {
      if (std::strncmp(argv[i], "case=", 5) == 0) c = std::atoi(argv[i] + 5);
      else if (std::strcmp(argv[i], "binary") == 0) binary = true;
      else if (std::strcmp(argv[i], "mixed=0") == 0) mixed = false;
      else if (std::strncmp(argv[i], "k=", 2) == 0) only_k = std::atoi(argv[i] + 2);
      else if (std::strncmp(argv[i], "disc=", 5) == 0) disc = fft::parse_discretization(argv[i] + 5);
      else sizes.push_back(std::atoi(argv[i]));
    }
    if (sizes.empty()) sizes = {8};
    for (int n : sizes)
      for (int k = 1; k <= 8; ++k) {
        if (only_k > 0 && k != only_k) continue;
        const double lambda = 1.0 + k / 16.0;
        MixedControl control = ramp(lambda, k);
        if (c == 1) {
          const auto zero = PiecewiseLinear::constant(0.0);
          for (int q = 0; q < 9; ++q) {
            control.kind[q] = ControlKind::stress;
            control.value[q] = zero;
          }
          control.kind[4] = ControlKind::deformation;
          control.value[4] = PiecewiseLinear{{0.0, 1.0}, {1.0, lambda}};
          for (int q : {3, 5, 2}) control.kind[q] = ControlKind::deformation;
        }
        FftSolverOptions o;
        o.tolerance = 1e-8;
        o.mixed_pressure = mixed;
        o.tangent_precision = TangentPrecision::double_precision;
        o.discretization = disc;
        PhaseImage image = circle_cell(n);
        if (binary)
          for (std::size_t v = 0; v < image.voxels(); ++v) {
            image.fiber_fraction[v] = image.fiber_fraction[v] >= 0.5 ? 1.0 : 0.0;
            image.normal[v].setZero();
          }
        FftRveSolver solver(image, make_material(make_gent_hgo({0.017, 14.0, 0.017 * 1.2e5, {}, FiberInvariant::full, true})),
                            make_material(make_neo_hookean(NeoHookeanParams::from_young(10.0, 0.3))), 90.0, Mat3::Identity(), o);
        const RveRunResult r = solver.run(control);
        const FftRveSolver::DenseOperator d = solver.dense_fluctuation_operator();
        const Eigen::MatrixXd S = 0.5 * (d.K + d.K.transpose());
        const double asym = (d.K - d.K.transpose()).norm() / d.K.norm();
        Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(S);
        const Eigen::VectorXd& ev = es.eigenvalues();
        const double top = ev.cwiseAbs().maxCoeff();
        int negative = 0, zero = 0;  // zero: |λ| ≤ 1e-12 max, the mean mode, the imaginary parts of the
                                     // self-conjugate modes and the null modes of the gradient (rotated: (π, π))
        for (Eigen::Index i = 0; i < ev.size(); ++i) {
          negative += ev[i] < -1e-12 * top;
          zero += std::abs(ev[i]) <= 1e-12 * top;
        }
        const double lap_max = *std::max_element(d.laplacian.begin(), d.laplacian.end());
        double freq = 0.0;
        const Eigen::VectorXd v = es.eigenvectors().col(0);
        for (Eigen::Index i = 0; i < v.size(); ++i) freq += d.laplacian[std::size_t(i)] / lap_max * v[i] * v[i] / v.squaredNorm();
        // the smallest eigenvalue above the zero rows (|λ| < 1e-12 top)
        double smallest_positive = top;
        for (Eigen::Index i = 0; i < ev.size(); ++i)
          if (ev[i] > 1e-12 * top) smallest_positive = std::min(smallest_positive, ev[i]);
        std::printf("eigen case %d n %3d %s%s lambda %.4f %4s newton %4d P22 %.6g F11 %.6g unknowns %zu asym %.1e negative %d zero %d "
                    "min %.3e (freq %.2f) min positive %.3e max %.3e\n",
                    c, n, binary ? "binary " : "", mixed ? "mixed" : "plain", lambda, r.completed ? "ok" : "FAIL",
                    r.newton_iterations, r.steps.back().P(1, 1), r.steps.back().F(0, 0), d.laplacian.size(), asym,
                    negative, zero, ev[0], freq, smallest_positive, top);
        std::fflush(stdout);
      }
  } else if (mode == "resolution") {
    const std::string matrix = argc > 2 ? argv[2] : "pdms";
    sizes.clear();
    for (int i = 3; i < argc; ++i) sizes.push_back(std::atoi(argv[i]));
    if (sizes.empty()) sizes = {16, 32, 64, 128};
    const double G = matrix == "ecoflex" ? 0.017 : 0.65, Jm = matrix == "ecoflex" ? 14.0 : 5.0;
    const MaterialPtr m = make_material(make_gent_hgo({G, Jm, 2000.0, {}, FiberInvariant::full, true}));
    const MaterialPtr f = make_material(make_neo_hookean(NeoHookeanParams::from_young(10.0, 0.3)));
    for (auto d : {fft::Discretization::rotated, fft::Discretization::hex, fft::Discretization::spectral}) {
      std::vector<double> p11, secs;
      for (int n : sizes) {
        FftSolverOptions o;
        o.discretization = d;
        o.tolerance = 1e-7;
        FftRveSolver solver(circle_cell(n), m, f, 45.0, Mat3::Identity(), o);
        const auto t0 = std::chrono::steady_clock::now();
        const RveRunResult r = solver.run(ramp(1.5, 8));
        secs.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
        p11.push_back(r.completed ? r.steps.back().P(0, 0) : std::nan(""));
        std::printf("resolution %-8s %-9s n %4d %s P11 %.8g newton %d krylov %d time %.2f s mem/voxel %.0f B\n", matrix.c_str(),
                    fft::to_string(d), n, r.completed ? "ok" : "FAIL", p11.back(), r.newton_iterations,
                    r.krylov_iterations, secs.back(), double(solver.memory_bytes()) / double(n) / n);
        std::fflush(stdout);
      }
      const std::size_t k = p11.size();
      if (k >= 3) {
        // Observed order from the three finest grids (ratio 2), Richardson limit from the two finest.
        const double e1 = p11[k - 3] - p11[k - 2], e2 = p11[k - 2] - p11[k - 1];
        const double order = std::log2(std::abs(e1 / e2));
        const double limit = p11[k - 1] + (p11[k - 1] - p11[k - 2]) / (std::pow(2.0, order) - 1.0);
        for (std::size_t i = 0; i < k; ++i)
          std::printf("error %-8s %-9s n %4d rel.error %.3e time %.2f s\n", matrix.c_str(), fft::to_string(d), sizes[i],
                      std::abs(p11[i] - limit) / std::abs(limit), secs[i]);
        std::printf("order %-8s %-9s observed %.2f limit %.8g\n", matrix.c_str(), fft::to_string(d), order, limit);
      }
    }
  } else if (mode == "fftcost") {
    std::vector<fft::Discretization> discs;
    std::vector<fft::Grid> grids;
    std::vector<int> thread_counts;
    std::vector<KrylovOperator> ops;
    std::vector<TangentPrecision> precisions;
    int repeats = 1, fftw_threads = 0;
    fft::PlanRigor rigor = fft::PlanRigor::measure;  // "fftw=estimate|measure|patient"
    Preconditioner preconditioner = Preconditioner::green;  // "preconditioner=jacobi-green" | "=green-local-bulk": the others
    bool compact = true;  // "compact=off": the stored 9×9 float tangents instead of compact ones
    bool stream = true;   // "stream=off": the stored 9-field evaluation instead of the streamed one
    for (int i = 2; i < argc; ++i) {
      if (std::strcmp(argv[i], "compact=off") == 0)
        compact = false;
      else if (std::strcmp(argv[i], "stream=off") == 0)
        stream = false;
      else if (std::strcmp(argv[i], "preconditioner=jacobi-green") == 0)
        preconditioner = Preconditioner::jacobi_green;
      else if (std::strcmp(argv[i], "preconditioner=green-local-bulk") == 0)
        preconditioner = Preconditioner::green_local_bulk;
      else if (std::strncmp(argv[i], "threads=", 8) == 0)
        thread_counts.push_back(std::atoi(argv[i] + 8));
      else if (std::strncmp(argv[i], "fftw_threads=", 13) == 0)
        fftw_threads = std::max(1, std::atoi(argv[i] + 13));
      else if (std::strncmp(argv[i], "fftw=", 5) == 0) {
        rigor = std::strcmp(argv[i] + 5, "estimate") == 0  ? fft::PlanRigor::estimate
                : std::strcmp(argv[i] + 5, "patient") == 0 ? fft::PlanRigor::patient
                                                           : fft::PlanRigor::measure;
      } else if (std::strncmp(argv[i], "repeat=", 7) == 0)
        repeats = std::max(1, std::atoi(argv[i] + 7));
      else if (std::strcmp(argv[i], "operator=fourier") == 0)
        ops.push_back(KrylovOperator::fourier);
      else if (std::strcmp(argv[i], "operator=stencil") == 0)
        ops.push_back(KrylovOperator::stencil);
      else if (std::strcmp(argv[i], "precision=double") == 0)
        precisions.push_back(TangentPrecision::double_precision);
      else if (std::strcmp(argv[i], "precision=single") == 0)
        precisions.push_back(TangentPrecision::single_precision);
      else if (is_discretization(argv[i]))
        discs.push_back(fft::parse_discretization(argv[i]));
      else
        grids.push_back(parse_grid(argv[i]));
    }
    if (discs.empty()) discs = {fft::Discretization::rotated, fft::Discretization::hex, fft::Discretization::spectral};
    if (grids.empty()) grids = {parse_grid("64"), parse_grid("256")};
    if (thread_counts.empty()) thread_counts = {1, 2};
    if (ops.empty()) ops = {KrylovOperator::fourier, KrylovOperator::stencil};
    if (precisions.empty()) precisions = {TangentPrecision::double_precision};
    const int max_threads = omp_get_max_threads();
    for (const fft::Grid& g : grids)
      for (auto d : discs) {
        // per [operator: fourier, stencil double, stencil single][threads]
        double per_krylov[3][3] = {}, per_total[3][3] = {};
        const char* op_name[3] = {"fourier", "stencil", "stencil-single"};
        for (int threads : thread_counts) {
          if (threads < 1 || threads > 2) continue;
          omp_set_num_threads(threads);
          fft::GradientOperator op(g, d);
          const int reps = 10;
          // FFT round trip (forward + backward) of `fields` fields, wall and CPU ms, best of 3 × reps.
          auto roundtrip = [&](int fields, int columns, double& cpu_ms) {
            fft::BatchedFFT fftw(g, fields, {rigor, threads, {}}, columns);
            fftw.forward();
            fftw.backward();
            double best = 1e300;
            cpu_ms = 1e300;
            for (int trial = 0; trial < 3; ++trial) {
              const double c0 = cpu_seconds();
              const auto t0 = std::chrono::steady_clock::now();
              for (int i = 0; i < reps; ++i) {
                fftw.forward();
                fftw.backward();
              }
              cpu_ms = std::min(cpu_ms, 1e3 * (cpu_seconds() - c0) / reps);
              best = std::min(best, 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / reps);
            }
            return best;
          };
          double cpu9 = 0, cpu_used = 0, cpu3 = 0;
          const double fft9_ms = roundtrip(9, 3, cpu9);  // the floor: a 9-component round trip
          const int used_fields = 3 * op.points() * op.columns();
          const double fft_used_ms = roundtrip(9 * op.points(), op.columns(), cpu_used);
          const double fft3_ms = roundtrip(3, 3, cpu3);
          for (KrylovOperator kop : ops)
          for (TangentPrecision prec : precisions) {
            const bool stencil = kop == KrylovOperator::stencil && d != fft::Discretization::spectral;
            if (kop == KrylovOperator::stencil && !stencil) continue;  // spectral: Fourier form only
            // The Fourier operator always stores double: run it once.
            if (!stencil && prec != precisions.front()) continue;
            // One Newton step with a fixed number of Krylov iterations (tolerance unreachable), twice: 10 and
            // 60 iterations. The difference is the cost of 50 Krylov iterations alone (the two material
            // evaluations and the setup cancel); CPU time as well as wall time, since the box is shared.
            // `repeat`: the best of that many such pairs.
            double kry_ms = 1e300, kry_cpu_ms = 1e300, kry_wall = 0.0, whole = 1e300;
            int its1 = 0;
            std::size_t mem = 0;
            double rss = 0.0;
            for (int rep = 0; rep < repeats; ++rep) {
              double wall[2], cpu[2];
              int its[2];
              for (int pass = 0; pass < 2; ++pass) {
                FftSolverOptions o;
                o.discretization = d;
                o.krylov_operator = kop;
                o.tangent_precision = prec;
                o.preconditioner = preconditioner;
                o.compact_tangent = compact;
                o.stream_evaluation = stream;
                o.max_newton_iterations = 1;
                o.max_cutbacks = 0;
                o.krylov_tolerance = 1e-30;
                o.max_krylov_iterations = pass == 0 ? 10 : 60;
                o.plan.threads = fftw_threads > 0 ? std::min(fftw_threads, threads) : threads;
                o.plan.rigor = rigor;
                const std::size_t rss0 = resident_bytes();
                FftRveSolver solver(cell_image(g), make_material(make_neo_hookean({1.0, 10.0})),
                                    make_material(make_neo_hookean({100.0, 1000.0})), 45.0, Mat3::Identity(), o);
                const double c0 = cpu_seconds();
                const auto t1 = std::chrono::steady_clock::now();
                const RveRunResult r = solver.run(one_step(1.05));
                wall[pass] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
                cpu[pass] = cpu_seconds() - c0;
                its[pass] = r.krylov_iterations;
                kry_wall = r.krylov_seconds / std::max(1, r.krylov_iterations);
                mem = solver.memory_bytes();
                const std::size_t rss1 = resident_bytes();
                rss = double(rss1 - std::min(rss0, rss1));
              }
              const int dk = std::max(1, its[1] - its[0]);
              kry_ms = std::min(kry_ms, 1e3 * (wall[1] - wall[0]) / dk);
              kry_cpu_ms = std::min(kry_cpu_ms, 1e3 * (cpu[1] - cpu[0]) / dk);
              whole = std::min(whole, wall[1]);
              its1 = its[1];
            }
            const int o = stencil ? (prec == TangentPrecision::single_precision ? 2 : 1) : 0;
            per_krylov[o][threads] = kry_ms;
            per_total[o][threads] = whole;
            const double nv = double(g.voxels());
            // Transformed fields per Krylov iteration: stencil 3 back + 3 forward; Fourier 3·nq·columns each way.
            const double own_ms = stencil ? fft3_ms : fft_used_ms, own_cpu = stencil ? cpu3 : cpu_used;
            std::printf("fftcost %4dx%4dx%4d %-9s %-8s %-6s %s compact=%s stream=%s fftw=%s threads %d per-krylov %8.3f ms (cpu %8.3f, in-solver %8.3f) | "
                        "fft9 %7.3f ms (cpu %7.3f) ratio-9 %5.2f (cpu %5.2f) | own fft %7.3f ms (%d fields) ratio-own %5.2f "
                        "(cpu %5.2f) | whole step %.3f s (%d its) mem/voxel %5.0f B (rss %5.0f B) peak-rss %.0f MB load %s\n",
                        g.n[0], g.n[1], g.n[2], fft::to_string(d), stencil ? "stencil" : "fourier",
                        stencil ? to_string(prec) : "double", to_string(stencil ? preconditioner : Preconditioner::green), compact ? "on" : "off",
                        stream ? "on" : "off",
                        fft::to_string(rigor), threads, kry_ms, kry_cpu_ms,
                        1e3 * kry_wall, fft9_ms, cpu9, kry_ms / fft9_ms, kry_cpu_ms / cpu9, own_ms,
                        stencil ? 3 : used_fields, kry_ms / own_ms, kry_cpu_ms / own_cpu, whole, its1, double(mem) / nv,
                        rss / nv, double(io::peak_memory_bytes()) / 1048576.0, load_average().c_str());
            std::fflush(stdout);
          }
        }
        for (int o = 0; o < 3; ++o)
          if (per_krylov[o][1] > 0 && per_krylov[o][2] > 0)
            std::printf("speedup %4dx%4dx%4d %-9s %-14s 2 threads: per-krylov %.2f, whole step %.2f\n", g.n[0], g.n[1],
                        g.n[2], fft::to_string(d), op_name[o], per_krylov[o][1] / per_krylov[o][2],
                        per_total[o][1] / per_total[o][2]);
        for (int t = 1; t <= 2; ++t) {
          if (per_krylov[1][t] > 0 && per_krylov[2][t] > 0)
            std::printf("single/double %4dx%4dx%4d %-9s %d thread(s): per-krylov %.2fx faster, whole step %.2fx\n",
                        g.n[0], g.n[1], g.n[2], fft::to_string(d), t, per_krylov[1][t] / per_krylov[2][t],
                        per_total[1][t] / per_total[2][t]);
          if (per_krylov[0][t] > 0 && per_krylov[1][t] > 0)
            std::printf("stencil/fourier %4dx%4dx%4d %-9s %d thread(s): per-krylov %.2fx faster, whole step %.2fx\n",
                        g.n[0], g.n[1], g.n[2], fft::to_string(d), t, per_krylov[0][t] / per_krylov[1][t],
                        per_total[0][t] / per_total[1][t]);
        }
      }
    omp_set_num_threads(max_threads);
  } else if (mode == "fftpasses") {
    std::vector<fft::Grid> grids;
    std::vector<int> thread_counts;
    int calls = 50;
    for (int i = 2; i < argc; ++i) {
      if (std::strncmp(argv[i], "threads=", 8) == 0)
        thread_counts.push_back(std::atoi(argv[i] + 8));
      else if (std::strncmp(argv[i], "calls=", 6) == 0)
        calls = std::max(1, std::atoi(argv[i] + 6));
      else
        grids.push_back(parse_grid(argv[i]));
    }
    if (grids.empty()) grids = {parse_grid("64"), parse_grid("256")};
    if (thread_counts.empty()) thread_counts = {1, 2};
    const int max_threads = omp_get_max_threads();
    for (const fft::Grid& g : grids)
      for (int threads : thread_counts) {
        omp_set_num_threads(threads);
        fft::GradientOperator op(g, fft::Discretization::rotated);
        fft::StencilGradient st(op);
        const std::size_t N = g.voxels(), NB = (N + 7) / 8 * 8;
        std::vector<double> u(3 * N), store(std::size_t(st.stored_values()) * N), f(3 * N), T(45 * NB);
        std::vector<float> Tf(45 * NB);
        unsigned seed = 1;
        auto rnd = [&seed] { return (seed = seed * 1664525u + 1013904223u) * (1.0 / 4294967296.0) - 0.5; };
        for (auto& x : u) x = rnd();
        for (std::size_t i = 0; i < T.size(); ++i) Tf[i] = float(T[i] = rnd());
        fft::BatchedFFT f3(g, 3, {fft::PlanRigor::measure, threads, {}}), f3one(g, 3, {fft::PlanRigor::measure, 1, {}});
        fft::BatchedFFT f3in(g, 3, {fft::PlanRigor::measure, threads, {}}, 3, true);  // the solver's layout
        auto best_of = [calls](auto&& fn) {
          double best = 1e300;
          for (int c = 0; c < calls; ++c) {
            const auto t0 = std::chrono::steady_clock::now();
            fn();
            best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
          }
          return 1e3 * best;
        };
        double sink = 0.0;
        const double grad_d = best_of([&] {
#pragma omp parallel
          st.gradient_pass(u.data(), store.data(), [&](std::size_t p0, int, const double* grad, double* dP) {
            fft::symmetric_product_batch(T.data() + 45 * p0, grad, dP);
          });
        });
        const double grad_f = best_of([&] {
#pragma omp parallel
          st.gradient_pass(u.data(), store.data(), [&](std::size_t p0, int, const double* grad, double* dP) {
            fft::symmetric_product_batch(Tf.data() + 45 * p0, grad, dP);
          });
        });
        const double gather = best_of([&] { sink += st.divergence_pass(store.data(), f.data(), u.data()); });
        // The streamed pass (gradient, float tangent product and adjoint in place, no store) on a copy of
        // u restored before each call (its nodal forces overwrite it); the copy is timed alone and taken off.
        std::vector<double> uf(u), scratch(st.stream_scratch_values(threads));
        const double copy = best_of([&] { std::copy(u.begin(), u.end(), uf.begin()); });
        const double streamed = !st.streams() ? 0.0 : best_of([&] {
          std::copy(u.begin(), u.end(), uf.begin());
          double d = 0.0;
#pragma omp parallel reduction(+ : d)
          d += st.streamed_pass(uf.data(), scratch.data(), [&](std::size_t p0, int, const double* grad, double* dP) {
            fft::symmetric_product_batch(Tf.data() + 45 * p0, grad, dP);
          }, true, true);
          sink += d;
        }) - copy;  // 0: the grid does not stream (slices not whole batches)
        const double fft_rt = best_of([&] {
          f3.forward();
          f3.backward();
        });
        const double fft_rt1 = best_of([&] {
          f3one.forward();
          f3one.backward();
        });
        const double fft_in = best_of([&] {
          f3in.forward();
          f3in.backward();
        });
        std::printf("fftpasses %4dx%4dx%4d threads %d: grad+tangent double %.4f ms, float %.4f ms | gather %.4f ms | "
                    "streamed (float) %.4f ms = %.2f of stored float | "
                    "fft3 round trip %.4f ms (fftw 1 thread: %.4f ms; in place: %.4f ms) | tangent %0.f/%0.f B per point | load %s (%.3g)\n",
                    g.n[0], g.n[1], g.n[2], threads, grad_d, grad_f, gather, streamed, streamed / (grad_f + gather), fft_rt,
                    fft_rt1, fft_in, 360.0, 180.0, load_average().c_str(), sink);
        std::fflush(stdout);
      }
    omp_set_num_threads(max_threads);
  } else if (mode == "timeerror") {
    // Preset materials and cell of bench_rve_fe; λ = 1.5 in 5 (PDMS) or 8 (ecoflex) steps.
    const std::string matrix = argc > 2 ? argv[2] : "pdms";
    const int dim = argc > 3 ? std::atoi(argv[3]) : 2;
    std::vector<fft::Discretization> discs;
    sizes.clear();
    for (int i = 4; i < argc; ++i) {
      if (is_discretization(argv[i]))
        discs.push_back(fft::parse_discretization(argv[i]));
      else
        sizes.push_back(std::atoi(argv[i]));
    }
    if (discs.empty()) discs = {fft::Discretization::rotated, fft::Discretization::hex, fft::Discretization::spectral};
    if (sizes.empty()) sizes = dim == 3 ? std::vector<int>{16, 32, 64} : std::vector<int>{32, 64, 128, 256, 512};
    // FE reference (BENCHMARKS.md, FE RVE: Richardson extrapolation of the P2+bubble/P1 meshes L/16 … L/64).
    const double P11_ref = matrix == "ecoflex" ? 0.13691696 : 1.2015139;
    const int steps = matrix == "ecoflex" ? 8 : 5;
    const MaterialPtr m = build_material(preset_spec(matrix)), f = build_material(preset_spec("glass"));
    std::printf("# timeerror %s %dD, lambda 1.5 in %d steps, tolerance 1e-7, reference P11 %.8g (FE), load %s\n",
                matrix.c_str(), dim, steps, P11_ref, [] {
                  static char buf[64] = "?";
                  std::ifstream in("/proc/loadavg");
                  in.getline(buf, sizeof buf);
                  return buf;
                }());
    struct Run {
      fft::Discretization d;
      int n;
      double P11, cpu, wall, error;
    };
    std::vector<Run> runs;
    for (auto d : discs) {
      std::vector<double> p11;
      for (int n : sizes) {
        FftSolverOptions o;
        o.discretization = d;
        o.tolerance = 1e-7;
        const fft::Grid g{{n, n, dim == 3 ? n : 1}, {1.0, 1.0, 1.0}};
        const double c0 = cpu_seconds();
        const auto t0 = std::chrono::steady_clock::now();
        FftRveSolver solver(cell_image(g), m, f, 45.0, Mat3::Identity(), o);
        const RveRunResult r = solver.run(ramp(1.5, steps));
        const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        const double cpu = cpu_seconds() - c0;
        p11.push_back(r.completed ? r.steps.back().P(0, 0) : std::nan(""));
        const double err = std::abs(p11.back() - P11_ref) / P11_ref;
        runs.push_back({d, n, p11.back(), cpu, wall, err});
        std::printf("timeerror %-8s %dD %-9s n %4d %s P11 %.9f error(FE) %.3e newton %5d krylov %7d cpu %8.2f s "
                    "wall %8.2f s (planning %.2f s, krylov %.2f s) mem/voxel %.0f B\n",
                    matrix.c_str(), dim, fft::to_string(d), n, r.completed ? "ok  " : "FAIL", p11.back(), err,
                    r.newton_iterations, r.krylov_iterations, cpu, wall, solver.planning_seconds(),
                    r.krylov_seconds, double(solver.memory_bytes()) / double(g.voxels()));
        std::fflush(stdout);
      }
      const std::size_t k = p11.size();
      if (k >= 3) {
        const double e1 = p11[k - 3] - p11[k - 2], e2 = p11[k - 2] - p11[k - 1];
        const double order = std::log2(std::abs(e1 / e2));
        const double limit = p11[k - 1] + (p11[k - 1] - p11[k - 2]) / (std::pow(2.0, order) - 1.0);
        std::printf("richardson %-8s %dD %-9s observed order %.2f limit %.9f (vs FE %.2e)\n", matrix.c_str(), dim,
                    fft::to_string(d), order, limit, std::abs(limit - P11_ref) / P11_ref);
      }
    }
    for (double target : {1e-2, 1e-3, 1e-4}) {
      const Run* best = nullptr;
      for (const Run& r : runs)
        if (r.error <= target && (!best || r.cpu < best->cpu)) best = &r;
      if (best)
        std::printf("cheapest %-8s %dD error <= %.0e: %s n %d (error %.2e, cpu %.2f s)\n", matrix.c_str(), dim, target,
                    fft::to_string(best->d), best->n, best->error, best->cpu);
      else
        std::printf("cheapest %-8s %dD error <= %.0e: none of the runs\n", matrix.c_str(), dim, target);
    }
  }
  return 0;
}
