// Macro FE benchmark: DOFs versus wall time of a double-helix tube inflation, split into
// assembly, symbolic analysis, numeric factorization and solve, with Newton iterations, factor fill,
// achieved factorization rate and peak memory. Plain program (one run is seconds to minutes).
//
//   bench_macro [options] DOFS...       one inflation per requested size (nearest structured mesh)
//     --steps N        load steps of the pressure ramp (default 20)
//     --threads LIST   comma-separated OpenMP thread counts to run each size with (default 2)
//     --solver S       auto | cholmod | umfpack (default auto: the symmetric-preconditioned path)
//     --pressure P     final pressure [MPa] (default 0.01, the ecoflex scenes)
//     --policy P       current (default) | basic: the plain Newton/Krylov policy (condensed GMRES,
//                      secant predictor, no per-step refactorization, no residual-first test)
//     --only K         run only the first K of the load steps (cost of one step at sizes where the
//                      whole ramp takes too long)
//   bench_macro --orderings DOFS...    CHOLMOD symbolic analysis only (no factorization): fill nnz(L),
//                                      flops per factorization and analysis time for AMD, METIS and
//                                      NESDIS on the tube's stiffness pattern (what the direct solver
//                                      would cost at 1e6 DOFs without running it)
//   bench_macro --factor DOFS...      CHOLMOD numeric factorization + one solve (METIS) of an SPD matrix with
//                                      the tube's pattern for several supernode amalgamation settings
//   bench_macro --factor-once DOFS...  one numeric factorization + one solve (METIS, the solver's settings), lean
//                                      in memory (1e6 dofs: ≈ 11 GiB peak, 10 GiB of it the factor): the
//                                      unit costs of the 1e6 estimate
//   bench_macro --kernel [N]           micro benchmark of the hex8 kernel: µs per element evaluation
//                                      (residual + F-bar/three-field tangent) and per material call, on a
//                                      distorted, loaded element of the helix material, N repetitions
//
// The tube is the one of studies/scenes/macro_tube_helix45_ecoflex.toml (R_i 5, R_o 7.5, L 50 mm,
// cap 2.5 mm, ecoflex-anisotropic with fibers at ±45° from the axis, clamped at z = 0, follower
// pressure), meshed with cubes of edge h chosen to hit the requested number of DOFs. Sizes run in
// the order given, so the peak memory column (VmHWM) is that of the largest run so far.
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <stdexcept>
#include <sstream>
#include <string>
#include <vector>

#include <cholmod.h>

#include "softhom/io/files.hpp"
#include "softhom/macro/structures.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/laws.hpp"

using namespace softhom;
using namespace softhom::macro;

namespace {

TubeSpec tube_for_dofs(double dofs) {
  TubeSpec t;
  t.inner_radius = 5.0;
  t.outer_radius = 7.5;
  t.length = 50.0;
  t.sweep_deg = 360.0;
  t.cap_thickness = 2.5;
  // Nodes ≈ (nr + 1) nc (na + 1) with nr = 2.5/h, nc = 2π·6.25/h, na = 50/h: solve for h by bisection.
  auto count = [&](double h, TubeSpec& s) {
    s.radial_cells = std::max(1, int(std::lround(2.5 / h)));
    s.circumferential_cells = std::max(8, int(std::lround(2 * M_PI * 6.25 / h / 4)) * 4);
    s.axial_cells = std::max(1, int(std::lround(50.0 / h)));
    s.cap_axial_cells = std::max(1, int(std::lround(2.5 / h)));
    s.cap_core_cells = std::max(1, int(std::lround(5.0 / h)));
    return 3.0 * (s.radial_cells + 1) * s.circumferential_cells * (s.axial_cells + 1);
  };
  double lo = 0.01, hi = 10.0;
  for (int k = 0; k < 60; ++k) {
    const double mid = std::sqrt(lo * hi);
    TubeSpec s = t;
    (count(mid, s) > dofs ? lo : hi) = mid;
  }
  count(hi, t);
  return t;
}

StructureSpec helix_spec(double dofs, double pressure) {
  StructureSpec spec;
  spec.kind = StructureKind::tube;
  spec.tube = tube_for_dofs(dofs);
  GentHGOParams p;
  p.G = 0.017;  // ecoflex-anisotropic (spec §6)
  p.Jm = 14.0;
  p.K = 2000.0;
  const double a = 45.0 * M_PI / 180.0;
  p.fibers = {{Vec3(std::sin(a), std::cos(a), 0.0), 0.8, 18.0}, {Vec3(-std::sin(a), std::cos(a), 0.0), 0.8, 18.0}};
  spec.material = make_material(make_gent_hgo(p));
  spec.fiber_frame = FiberFrame::cylindrical;
  spec.control = LoadControl::pressure;
  spec.load = {{0.0, 180.0}, {0.0, pressure}};  // (times, values)
  return spec;
}

/// µs per call of the element kernel (one thread), of the residual only and of the 8 material calls.
int kernel_benchmark(int n) {
  const StructureSpec spec = helix_spec(1e4, 0.01);
  const Material& m = *spec.material;
  fe::Mat83 X;
  const double sign[8][3] = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1}, {-1, -1, 1}, {1, -1, 1}, {1, 1, 1}, {-1, 1, 1}};
  for (int a = 0; a < 8; ++a)
    for (int i = 0; i < 3; ++i) X(a, i) = 0.25 * sign[a][i] + 0.02 * std::sin(3.0 * a + 7.0 * i);  // distorted
  const fe::Hex8Geometry g = fe::hex8_geometry(X);
  Mat3 F;
  F << 1.25, 0.08, -0.03, 0.05, 0.9, 0.04, -0.02, 0.06, 0.93;  // loaded: stretch + shear, fibers in tension
  fe::Mat83 u;
  for (int a = 0; a < 8; ++a) u.row(a) = ((F - Mat3::Identity()) * X.row(a).transpose()).transpose() + 0.003 * Vec3(std::cos(a), std::sin(2.0 * a), std::cos(5.0 * a)).transpose();
  fe::Vec24 r;
  fe::Mat24 K;
  Mat3 sigma, P;
  Mat9 A;
  double sink = 0.0;
  auto time_it = [&](auto&& body) {
    body();  // warm up
    const auto t0 = std::chrono::steady_clock::now();
    const std::clock_t c0 = std::clock();
    for (int k = 0; k < n; ++k) body();
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / n * 1e6;
    const double cpu = double(std::clock() - c0) / CLOCKS_PER_SEC / n * 1e6;
    return std::pair<double, double>{wall, cpu};
  };
  auto element = [&](bool tangent) {
    fe::MixedVolume mv;
    mv.bulk = m.volumetric_modulus();
    mv.theta = 1.01;
    mv.p = 0.3;
    const MaterialStatus st = fe::hex8_internal_force(g, u, m, nullptr, nullptr, 0.0, fe::Formulation::fbar, r,
                                                      tangent ? &K : nullptr, tangent ? &sigma : nullptr, &mv);
    if (st != MaterialStatus::ok) throw std::runtime_error("kernel benchmark: material call failed");
    sink += r[0] + (tangent ? K(3, 5) : 0.0);
  };
  const auto kt = time_it([&] { element(true); });
  const auto kr = time_it([&] { element(false); });
  const auto mt = time_it([&] {
    for (int q = 0; q < 8; ++q) {
      m.evaluate(F * (1.0 + 1e-3 * q), nullptr, nullptr, 0.0, P, &A);
      sink += A(0, 0);
    }
  });
  std::printf("# hex8 kernel (F-bar, three-field, helix Gent+HGO material), %d repetitions, one thread\n", n);
  std::printf("  element residual + tangent : %8.2f us wall %8.2f us cpu\n", kt.first, kt.second);
  std::printf("  element residual only      : %8.2f us wall %8.2f us cpu\n", kr.first, kr.second);
  std::printf("  8 material calls (P, A)    : %8.2f us wall %8.2f us cpu\n", mt.first, mt.second);
  std::printf("  checksum |K| = %.12e (sink %g)\n", K.norm(), sink);
  return 0;
}

/// Sparsity pattern of the tube's stiffness on its free (not Dirichlet-constrained) dofs.
fe::CscMatrix free_dof_pattern(const Structure& s) {
  const fe::Mesh& mesh = s.model.mesh;
  std::vector<char> constrained(mesh.num_dofs(), 0);
  for (const auto& g : s.model.dirichlet)
    for (int d : g.dofs) constrained[d] = 1;
  return fe::build_pattern(mesh, fe::DofMap::from_constrained(mesh.num_dofs(), constrained));
}

/// Symbolic CHOLMOD analysis of the tube's free-dof pattern with one ordering at a time.
void ordering_benchmark(double target) {
  const Structure s = build_structure(helix_spec(target, 0.01));
  const fe::Mesh& mesh = s.model.mesh;
  const fe::CscMatrix K = free_dof_pattern(s);
  std::vector<int> colptr(K.n + 1, 0), rows;
  for (int c = 0; c < K.n; ++c) {
    for (int k = K.colptr[c]; k < K.colptr[c + 1]; ++k)
      if (K.rowind[k] <= c) rows.push_back(K.rowind[k]);
    colptr[c + 1] = int(rows.size());
  }
  const std::pair<int, const char*> methods[] = {{CHOLMOD_AMD, "AMD"}, {CHOLMOD_METIS, "METIS"}, {CHOLMOD_NESDIS, "NESDIS"}};
  for (const auto& [ordering, name] : methods) {
    cholmod_common cm;
    cholmod_start(&cm);
    cm.supernodal = CHOLMOD_SUPERNODAL;
    cm.nmethods = 1;
    cm.method[0].ordering = ordering;
    cm.postorder = 1;
    cholmod_sparse* A = cholmod_allocate_sparse(K.n, K.n, rows.size(), 1, 1, 1, CHOLMOD_PATTERN, &cm);
    std::copy(colptr.begin(), colptr.end(), static_cast<int*>(A->p));
    std::copy(rows.begin(), rows.end(), static_cast<int*>(A->i));
    const auto t0 = std::chrono::steady_clock::now();
    cholmod_factor* L = cholmod_analyze(A, &cm);
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("  %8d %7d %-7s | nnz(L) %9.2f M  %9.2f GFlop/factorization  L %8.0f MiB  analysis %6.2f s  peak %6.0f MiB\n",
                K.n, mesh.num_elements(), name, cm.lnz / 1e6, cm.fl / 1e9, cm.lnz * 8.0 / (1 << 20), t,
                double(io::peak_memory_bytes()) / (1 << 20));
    std::fflush(stdout);
    if (L) cholmod_free_factor(&L, &cm);
    cholmod_free_sparse(&A, &cm);
    cholmod_finish(&cm);
  }
}

/// Numeric CHOLMOD factorizations (METIS ordering) of an SPD matrix with the tube's free-dof pattern
/// (diagonally dominant values: supernodal LLᵀ does no pivoting, so its cost depends on the pattern
/// only), for several supernode amalgamation settings (nrelax, zrelax): achieved GFlop/s vs fill.
void factor_benchmark(double target) {
  const Structure s = build_structure(helix_spec(target, 0.01));
  const fe::CscMatrix K = free_dof_pattern(s);
  std::vector<int> colptr(K.n + 1, 0), rows;
  std::vector<double> vals;
  for (int c = 0; c < K.n; ++c) {
    for (int k = K.colptr[c]; k < K.colptr[c + 1]; ++k)
      if (K.rowind[k] <= c) {
        rows.push_back(K.rowind[k]);
        vals.push_back(K.rowind[k] == c ? double(K.colptr[c + 1] - K.colptr[c]) + 1.0 : -1.0);
      }
    colptr[c + 1] = int(rows.size());
  }
  struct Relax {
    std::size_t n[3];
    double z[3];
  };
  const Relax settings[] = {{{4, 16, 48}, {0.8, 0.1, 0.05}},  // CHOLMOD's defaults
                            {{8, 32, 96}, {0.8, 0.2, 0.1}},
                            {{16, 64, 192}, {0.9, 0.3, 0.15}},
                            {{32, 128, 384}, {0.9, 0.4, 0.2}}};
  for (const Relax& r : settings) {
    cholmod_common cm;
    cholmod_start(&cm);
    cm.supernodal = CHOLMOD_SUPERNODAL;
    cm.nmethods = 1;
    cm.method[0].ordering = CHOLMOD_METIS;
    cm.postorder = 1;
    for (int k = 0; k < 3; ++k) {
      cm.nrelax[k] = r.n[k];
      cm.zrelax[k] = r.z[k];
    }
    cholmod_sparse* A = cholmod_allocate_sparse(K.n, K.n, rows.size(), 1, 1, 1, CHOLMOD_REAL, &cm);
    std::copy(colptr.begin(), colptr.end(), static_cast<int*>(A->p));
    std::copy(rows.begin(), rows.end(), static_cast<int*>(A->i));
    std::copy(vals.begin(), vals.end(), static_cast<double*>(A->x));
    cholmod_factor* L = cholmod_analyze(A, &cm);
    double best = 1e300, solve = 1e300;
    for (int rep = 0; rep < 2; ++rep) {
      const auto t0 = std::chrono::steady_clock::now();
      cholmod_factorize(A, L, &cm);
      best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    cholmod_dense* B = cholmod_ones(K.n, 1, CHOLMOD_REAL, &cm);
    for (int rep = 0; rep < 3; ++rep) {
      const auto t0 = std::chrono::steady_clock::now();
      cholmod_dense* X = cholmod_solve(CHOLMOD_A, L, B, &cm);
      solve = std::min(solve, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      cholmod_free_dense(&X, &cm);
    }
    std::printf("  %8d nrelax %3zu %3zu %3zu zrelax %.2f %.2f %.2f | nnz(L) %7.2f M  %8.2f GFlop  factorize %6.2f s  %6.2f GFlop/s"
                "  solve %6.3f s  status %d\n",
                K.n, r.n[0], r.n[1], r.n[2], r.z[0], r.z[1], r.z[2], cm.lnz / 1e6, cm.fl / 1e9, best, cm.fl / best / 1e9, solve,
                cm.status);
    std::fflush(stdout);
    cholmod_free_dense(&B, &cm);
    cholmod_free_factor(&L, &cm);
    cholmod_free_sparse(&A, &cm);
    cholmod_finish(&cm);
  }
}

/// One CHOLMOD numeric factorization and one solve (METIS, the amalgamation of fe::CholmodSolver) of an SPD
/// matrix with the tube's free-dof pattern, built lean for the largest sizes: the mesh and the full
/// pattern are released before the analysis, so the peak is the factor (1e6 dofs: 1.34e9 entries,
/// 10 GiB) plus the upper-triangle matrix (≈ 0.5 GB) and CHOLMOD's workspace. Times the unit costs the
/// ramp estimate at 1e6 needs (factorization, triangular solve) without running the ramp.
void factor_once_benchmark(double target) {
  std::vector<int> colptr, rows;
  std::vector<double> diagonal;
  int n = 0, elements = 0;
  {
    const Structure s = build_structure(helix_spec(target, 0.01));
    elements = s.model.mesh.num_elements();
    const fe::CscMatrix K = free_dof_pattern(s);
    n = K.n;
    colptr.assign(n + 1, 0);
    long nnz_upper = 0;
    for (int c = 0; c < n; ++c)
      for (int k = K.colptr[c]; k < K.colptr[c + 1]; ++k) nnz_upper += K.rowind[k] <= c;
    rows.reserve(nnz_upper);
    diagonal.resize(n);
    for (int c = 0; c < n; ++c) {
      diagonal[c] = double(K.colptr[c + 1] - K.colptr[c]) + 1.0;  // > the row's off-diagonal sum: SPD
      for (int k = K.colptr[c]; k < K.colptr[c + 1]; ++k)
        if (K.rowind[k] <= c) rows.push_back(K.rowind[k]);
      colptr[c + 1] = int(rows.size());
    }
  }
  std::printf("  %8d dofs %7d elements | pattern built, peak %6.0f MiB\n", n, elements,
              double(io::peak_memory_bytes()) / (1 << 20));
  std::fflush(stdout);
  cholmod_common cm;
  cholmod_start(&cm);
  cm.supernodal = CHOLMOD_SUPERNODAL;
  cm.nmethods = 1;
  cm.method[0].ordering = CHOLMOD_METIS;
  cm.postorder = 1;
  const std::size_t nrelax[3] = {16, 64, 192};  // the amalgamation of fe::CholmodSolver (fe/src/sparse.cpp)
  const double zrelax[3] = {0.9, 0.3, 0.15};
  for (int k = 0; k < 3; ++k) {
    cm.nrelax[k] = nrelax[k];
    cm.zrelax[k] = zrelax[k];
  }
  cholmod_sparse* A = cholmod_allocate_sparse(n, n, rows.size(), 1, 1, 1, CHOLMOD_REAL, &cm);
  if (!A) throw std::runtime_error("CHOLMOD: out of memory allocating the matrix");
  std::copy(colptr.begin(), colptr.end(), static_cast<int*>(A->p));
  std::copy(rows.begin(), rows.end(), static_cast<int*>(A->i));
  double* x = static_cast<double*>(A->x);
  for (int c = 0; c < n; ++c)  // strictly diagonally dominant (the cap's axis nodes have > 100 neighbours' dofs)
    for (int k = colptr[c]; k < colptr[c + 1]; ++k) x[k] = rows[k] == c ? diagonal[c] : -1.0;
  std::vector<double>().swap(diagonal);
  std::vector<int>().swap(rows);
  std::vector<int>().swap(colptr);
  auto t0 = std::chrono::steady_clock::now();
  cholmod_factor* L = cholmod_analyze(A, &cm);
  const double t_analysis = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!L || cm.status != CHOLMOD_OK) throw std::runtime_error("CHOLMOD: analysis failed (status " + std::to_string(cm.status) + ")");
  std::printf("  %8d dofs | METIS nnz(L) %9.2f M (%.0f MiB)  %9.2f GFlop/factorization  analysis %7.2f s  peak %6.0f MiB\n", n,
              cm.lnz / 1e6, cm.lnz * 8.0 / (1 << 20), cm.fl / 1e9, t_analysis, double(io::peak_memory_bytes()) / (1 << 20));
  std::fflush(stdout);
  t0 = std::chrono::steady_clock::now();
  const std::clock_t c0 = std::clock();
  cholmod_factorize(A, L, &cm);
  const double t_fac = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu_fac = double(std::clock() - c0) / CLOCKS_PER_SEC;
  if (cm.status != CHOLMOD_OK) throw std::runtime_error("CHOLMOD: factorization failed (status " + std::to_string(cm.status) + ")");
  cholmod_dense* B = cholmod_ones(n, 1, CHOLMOD_REAL, &cm);
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);  // as fe::CholmodSolver::solve
  t0 = std::chrono::steady_clock::now();
  cholmod_dense* X = cholmod_solve(CHOLMOD_A, L, B, &cm);
  omp_set_num_threads(threads);
  const double t_solve = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("  %8d dofs | factorize %8.2f s wall %8.2f s cpu  %6.2f GFlop/s | solve %6.3f s | peak %6.0f MiB | %d threads\n", n,
              t_fac, cpu_fac, cm.fl / t_fac / 1e9, t_solve, double(io::peak_memory_bytes()) / (1 << 20), omp_get_max_threads());
  std::fflush(stdout);
  cholmod_free_dense(&X, &cm);
  cholmod_free_dense(&B, &cm);
  cholmod_free_factor(&L, &cm);
  cholmod_free_sparse(&A, &cm);
  cholmod_finish(&cm);
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  std::string item;
  while (std::getline(in, item, ',')) out.push_back(item);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  int steps = 20, only = 0;
  bool basic_policy = false;
  double pressure = 0.01;
  std::vector<int> threads{2};
  fe::SolverKind solver = fe::SolverKind::automatic;
  std::vector<double> sizes;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--orderings") {
      std::printf("# CHOLMOD symbolic analysis of the helix tube (free dofs, elements, ordering)\n");
      for (int k = i + 1; k < argc; ++k) ordering_benchmark(std::atof(argv[k]));
      return 0;
    }
    if (a == "--factor") {
      std::printf("# CHOLMOD numeric factorization (METIS) of the helix tube pattern, %d threads\n", omp_get_max_threads());
      for (int k = i + 1; k < argc; ++k) factor_benchmark(std::atof(argv[k]));
      return 0;
    }
    if (a == "--factor-once") {
      std::printf("# one CHOLMOD factorization + one solve (METIS, the solver's amalgamation) of the helix tube pattern\n");
      for (int k = i + 1; k < argc; ++k) factor_once_benchmark(std::atof(argv[k]));
      return 0;
    }
    if (a == "--kernel") return kernel_benchmark(i + 1 < argc ? std::atoi(argv[i + 1]) : 20000);
    if (a == "--steps" && i + 1 < argc) steps = std::atoi(argv[++i]);
    else if (a == "--only" && i + 1 < argc) only = std::atoi(argv[++i]);
    else if (a == "--pressure" && i + 1 < argc) pressure = std::atof(argv[++i]);
    else if (a == "--threads" && i + 1 < argc) {
      threads.clear();
      for (const auto& t : split(argv[++i])) threads.push_back(std::atoi(t.c_str()));
    } else if (a == "--policy" && i + 1 < argc) {
      basic_policy = std::string(argv[++i]) == "basic";
    } else if (a == "--solver" && i + 1 < argc) {
      const std::string s = argv[++i];
      solver = s == "cholmod" ? fe::SolverKind::cholmod : s == "umfpack" ? fe::SolverKind::umfpack : fe::SolverKind::automatic;
    } else {
      sizes.push_back(std::atof(a.c_str()));
    }
  }
  if (sizes.empty()) sizes = {1e4, 3e4, 1e5};
  std::printf("# helix tube +/-45 deg, ecoflex-anisotropic, p = %g MPa in %d load steps, solver %s\n", pressure, steps,
              fe::to_string(solver));
  std::printf("# %8s %7s %3s %5s %5s %4s | %8s %8s %8s %8s %8s %8s | %4s %6s %6s %7s | %7s %9s %7s %8s %s\n", "dofs",
              "elems", "thr", "steps", "newton", "cut", "wall_s", "assem_s", "analys_s", "factor_s", "solve_s", "krylov_s",
              "nfac", "solves", "gmres", "asm_K/R", "nnzL/M", "GFlop/fac", "GFlop/s", "peak_MiB", "result");
  for (double target : sizes)
    for (int nt : threads) {
      omp_set_num_threads(nt);
      const auto t0 = std::chrono::steady_clock::now();
      const Structure s = build_structure(helix_spec(target, pressure));
      fe::NewtonOptions o;
      o.solver = solver;
      o.verbose = std::getenv("SOFTHOM_VERBOSE") != nullptr;
      if (basic_policy) {  // the plain iteration, for side-by-side timings with one binary
        o.saddle_krylov = false;
        o.extrapolate_order = 1;
        o.refactor_each_step = false;
        o.residual_first = false;
      }
      fe::Simulation sim(s.model, o);
      std::string result = "ok";
      try {
        for (int k = 1; k <= (only > 0 ? std::min(only, steps) : steps); ++k) {
          const fe::AdvanceResult step = sim.advance_to(180.0 * k / steps);
          if (!step.reached()) throw std::runtime_error(step.message);
        }
        const auto v = probe_values(s, sim);  // time, pressure, volume, inner_radius, stretch, axial, twist
        std::ostringstream r;
        r.precision(9);
        r << "ok axial_stretch " << v[5] << " stretch " << v[4];
        result = r.str();
      } catch (const std::exception& e) {
        result = std::string("FAILED: ") + e.what();
      }
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const fe::RunStats st = sim.stats();
      const double fac = st.linear.factorizations ? st.linear.flops / st.linear.factorizations : 0.0;
      const std::string asm_counts = std::to_string(st.tangent_assemblies) + "/" + std::to_string(st.residual_assemblies);
      std::printf("  %8d %7d %3d %5d %5d %4d | %8.2f %8.2f %8.2f %8.2f %8.2f %8.2f | %4d %6d %6d %7s | %7.2f %9.3f %7.2f %8.0f %s\n",
                  sim.num_free_dofs(), s.model.mesh.num_elements(), nt, st.steps, st.newton_iterations, st.cutbacks, wall,
                  st.assembly_time, st.linear.analysis, st.linear.factorization, st.linear.solve, st.krylov_time,
                  st.linear.factorizations, st.linear.solves, st.krylov_iterations, asm_counts.c_str(), st.linear.factor_nnz / 1e6,
                  fac / 1e9, st.linear.factorization > 0 ? st.linear.flops / st.linear.factorization / 1e9 : 0.0,
                  double(io::peak_memory_bytes()) / (1 << 20), result.c_str());
      std::fflush(stdout);
    }
  return 0;
}
