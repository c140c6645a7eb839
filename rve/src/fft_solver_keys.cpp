// [solver] keys of the FFT engine: one declaration per FftSolverOptions member a scene may set.
#include "softhom/rve/fft_solver_keys.hpp"

namespace softhom::rve {

const keys::KeyTable<FftSolverOptions>& fft_solver_keys() {
  using O = FftSolverOptions;
  static const keys::KeyTable<FftSolverOptions> t = [] {
    keys::KeyTable<FftSolverOptions> k("solver", "RVE solver settings (engine = \"fft\", the default)");
    k.custom("engine", "choice", "RVE engine: FFT (\"fft\"), finite elements (\"fe\", its own keys below) or \"auto\" (from target_error)",
             [](const toml::node& n, const std::string& f, O&) {
               const std::string e = keys::read_text(n, f);
               if (e != "fft") throw InputError(f, keys::describe_value(n), "must be \"fft\", \"fe\" or \"auto\"");
             },
             "\"fft\"", "\"fft\", \"fe\", \"auto\"")
        .custom("target_error", "number", "engine = \"auto\": relative error of the homogenized stress to reach, in (0, 0.5)",
                [](const toml::node& n, const std::string& f, O&) {
                  throw InputError(f, keys::describe_value(n), "only with engine = \"auto\"");
                },
                "unset", "(0, 0.5)", "-")
        .choice("discretization", &O::discretization,
                {{"spectral", fft::Discretization::spectral}, {"rotated", fft::Discretization::rotated}, {"hex", fft::Discretization::hex}},
                "gradient discretization (rotated: staggered finite differences; hex: trilinear elements)")
        .choice("scheme", &O::scheme,
                keys::Choices<FftScheme>{{{"newton-cg", FftScheme::newton_cg}, {"moulinec-suquet", FftScheme::moulinec_suquet}},
                                       {{"newton_cg", "newton-cg"}, {"moulinec_suquet", "moulinec-suquet"}}},
                "nonlinear iteration")
        .choice("reference", &O::reference,
                keys::Choices<ReferenceMedium>{
                    {{"mean-tangent", ReferenceMedium::mean_tangent}, {"isotropic", ReferenceMedium::isotropic}, {"geometric", ReferenceMedium::geometric}},
                    {{"mean_tangent", "mean-tangent"}}},
                "reference medium of the preconditioner / fixed point")
        .number("tolerance", &O::tolerance, keys::open_range(0.0, 1.0), "-",
                "Newton: RMS incompatible stress and macro stress error relative to the stress scale")
        .number("krylov_tolerance", &O::krylov_tolerance, keys::right_open(0.0, 1.0), "-",
                "relative tolerance of each linear solve (0: adaptive forcing term)")
        .integer("max_newton_iterations", &O::max_newton_iterations, keys::closed_range(1, 10000), "-", "Newton iterations per sub-step")
        .integer("max_krylov_iterations", &O::max_krylov_iterations, keys::closed_range(1, 1000000), "-", "Krylov iterations per linear solve")
        .integer("max_fixed_point_iterations", &O::max_fixed_point_iterations, keys::closed_range(1, 100000000), "-",
                 "moulinec-suquet: iterations per sub-step")
        .integer("max_cutbacks", &O::max_cutbacks, keys::closed_range(0, 60), "-",
                 "times a step may be halved (60 halvings reach the resolution of a double)")
        .number("max_step_seconds", &O::max_step_seconds, keys::at_least(0.0), "s",
                "wall-time budget of one output step's cut-backs (0: unlimited)")
        .integer("max_continuation_iterations", &O::max_continuation_iterations, keys::closed_range(0, 100000), "-",
                 "pseudo-transient continuation iterations when Newton stagnates (0: off)")
        .choice("indefinite_solver", &O::indefinite_solver,
                {{"minres", IndefiniteSolver::minres}, {"shift", IndefiniteSolver::shift}},
                "Newton step at an indefinite tangent past a bifurcation")
        .number("minres_below", &O::minres_below, keys::at_least(0.0), "-", "residual below which negative curvature means an indefinite tangent")
        .flag("minres_fallback", &O::minres_fallback, "with shift: finish a stalled step with MINRES")
        .flag("mixed_pressure", &O::mixed_pressure, "mixed (u, p) Newton iteration in nearly incompressible phases")
        .choice("composite_tangent", &O::composite_tangent,
                {{"exact", CompositeTangent::exact}, {"projected", CompositeTangent::projected}},
                "composite voxels' laminate tangents in the Newton operator (projected: negative eigenvalues set to 0; "
                "for tension of fine 3D cells, not past fiber buckling)")
        .choice("krylov_operator", &O::krylov_operator, {{"stencil", KrylovOperator::stencil}, {"fourier", KrylovOperator::fourier}},
                "operator of the Krylov iteration")
        .choice("tangent_precision", &O::tangent_precision,
                {{"double", TangentPrecision::double_precision}, {"single", TangentPrecision::single_precision}},
                "storage of the stencil operator's tangents and of the preconditioner's Green table")
        .flag("compact_tangent", &O::compact_tangent,
              "single tangents: isotropic laws store F and five scalars per point instead of the 9x9 tangent (not with jacobi-green or volumetric = mean-dilatation)")
        .choice("preconditioner", &O::preconditioner,
                {{"auto", Preconditioner::automatic}, {"green", Preconditioner::green}, {"jacobi-green", Preconditioner::jacobi_green},
                 {"green-local-bulk", Preconditioner::green_local_bulk}},
                "Newton-CG preconditioner (green-local-bulk: the Green operator with each voxel's own bulk modulus, rotated and stencil "
                "operator only; auto: green-local-bulk where the phases' bulk moduli spread at least 3x as far as their shear moduli, "
                "e.g. PDMS/glass, else green; jacobi-green: the Green operator scaled by the real-space node diagonal, stencil operator only)")
        .choice("volumetric", &O::volumetric,
                {{"pointwise", VolumetricKinematics::pointwise}, {"mean-dilatation", VolumetricKinematics::mean_dilatation}},
                "volumetric kinematics of the quadrature points (mean-dilatation: one volume ratio per voxel, hex only; "
                "locking-free for nearly incompressible matrices)")
        .custom("fftw", "choice", "FFTW planning rigor",
                [](const toml::node& n, const std::string& f, O& o) {
                  static const keys::Choices<fft::PlanRigor> c{
                      {{"estimate", fft::PlanRigor::estimate}, {"measure", fft::PlanRigor::measure}, {"patient", fft::PlanRigor::patient}}, {}};
                  o.plan.rigor = keys::read_choice(n, f, c);
                },
                "\"measure\"", "\"estimate\", \"measure\", \"patient\"")
        .custom("fftw_wisdom", "string",
                "FFTW wisdom file: relative to --out (or the cache ${XDG_CACHE_HOME:-~/.cache}/softhom); absolute paths must lie in one of them",
                [](const toml::node& n, const std::string& f, O& o) { o.plan.wisdom_file = keys::read_text(n, f); }, "\"\" (none)");
    return k;
  }();
  return t;
}

}  // namespace softhom::rve
