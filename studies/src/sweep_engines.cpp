// The engines of campaign cases (sweep_internal.hpp): a case runs on the engine its scene names, the FFT
// engine (the default) or the FE engine ([solver] engine = "fe"), with the same setup as `softhom rve`.
#include <chrono>
#include <mutex>

#include "softhom/rve/fe_solver.hpp"
#include "softhom/studies/rve_fe_scene.hpp"
#include "softhom/studies/rve_scene.hpp"
#include "sweep_internal.hpp"

namespace softhom::studies {

std::mutex& hdf5_mutex();  // campaign.cpp

namespace sweep_detail {
namespace {

class FftCaseSolver final : public CaseSolver {
 public:
  FftCaseSolver(const ChainContext& ctx, const CampaignCase& c, CaseRecord& r) {
    RveSceneSetup setup;
    {
      // Imported phase images are read with HDF5.
      std::lock_guard<std::mutex> lock(hdf5_mutex());
      setup = parse_rve_scene(c.scene);
    }
    setup.solver.plan.threads = ctx.threads_per_job;
    // FFTW_MEASURE picks plans by timing, so two runs can differ in round-off; the campaign's
    // wisdom file makes a resumed run reuse the plans of the first one (and skips measuring).
    if (setup.solver.plan.wisdom_file.empty())
      setup.solver.plan.wisdom_file = ctx.wisdom_file.empty() ? ctx.dir / "fftw.wisdom" : ctx.wisdom_file;
    solver_ = std::make_unique<rve::FftRveSolver>(setup.image, setup.matrix, setup.fiber, setup.fiber_angle_deg,
                                                  setup.control.frame, setup.solver);
    r.stats["fft_planning_s"] = solver_->planning_seconds();
    r.info["geometry"] = setup.geometry_note;
    r.info["fft"] = solver_->fft_description();
  }
  rve::RveRunResult run(const MixedControl& segment, const std::function<void(const rve::RveStep&)>& progress) override {
    if (!progress) return solver_->run(segment);
    return solver_->run(segment, [&](const rve::RveStep& s, const rve::RveFields*) { progress(s); });
  }
  void describe_cell(CaseRecord& r) const override {
    r.stats["voxels"] = double(solver_->grid().voxels());
    r.stats["volume_fraction_achieved"] = solver_->achieved_volume_fraction();
  }

 private:
  std::unique_ptr<rve::FftRveSolver> solver_;
};

/// FE cases of one process mesh and solve one at a time. Two FE solves running at once in one process
/// (--jobs 2) gave results that differ from a lone run's in round-off (up to 5e-12 relative in P̄,
/// measured; with OpenBLAS or the reference BLAS alike), so a resumed or rerun campaign would not
/// reproduce its stored cases bit for bit, as it does for FFT cases. Serialized, every FE case equals
/// `softhom rve` on its scene exactly; FE cases run in parallel over MPI ranks (processes).
std::mutex& fe_case_mutex() {
  static std::mutex m;
  return m;
}

/// The FE engine: the cell meshed once per chain (the mesh is the case's discretization, as the grid is
/// the FFT engine's). The solver keeps the fluctuation, F̄, the element pressures and the history
/// between runs, so a segment continues from the end of the previous one as on the FFT engine.
class FeCaseSolver final : public CaseSolver {
 public:
  explicit FeCaseSolver(const CampaignCase& c, CaseRecord& r) {
    const FeRveSetup setup = parse_fe_rve_setup(c.scene, true);
    std::lock_guard<std::mutex> lock(fe_case_mutex());
    const auto mesh_start = std::chrono::steady_clock::now();
    solver_ = make_fe_rve_solver(mesh_fe_rve(setup), setup);
    r.stats["mesh_time_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - mesh_start).count();
    r.info["geometry"] = setup.geometry_note;
    r.info["mesh"] = std::string(solver_->is_3d() ? "Tet10 cell" : setup.plate ? "T6 plate section" : "T6 section") +
                     ", mesh_size " + format_number(setup.settings.mesh.mesh_size) + ", interface_size " +
                     format_number(setup.settings.mesh.interface_size);
  }
  rve::RveRunResult run(const MixedControl& segment, const std::function<void(const rve::RveStep&)>& progress) override {
    std::lock_guard<std::mutex> lock(fe_case_mutex());
    if (!progress) return solver_->run(segment);
    return solver_->run(segment, [&](const rve::RveStep& s, const rve::FeFields*) { progress(s); });
  }
  void describe_cell(CaseRecord& r) const override {
    r.stats["elements"] = double(solver_->num_elements());
    r.stats["equations"] = double(solver_->num_equations());
    r.stats["volume_fraction_achieved"] = solver_->achieved_volume_fraction();
    r.info["linear_solver"] = solver_->linear_solver();
  }

 private:
  std::unique_ptr<rve::FeRveSolver> solver_;
};

}  // namespace

std::unique_ptr<CaseSolver> make_case_solver(const ChainContext& ctx, const CampaignCase& c, CaseRecord& r) {
  r.info["engine"] = c.engine;
  if (c.engine == "fe") return std::make_unique<FeCaseSolver>(c, r);
  return std::make_unique<FftCaseSolver>(ctx, c, r);
}

}  // namespace sweep_detail
}  // namespace softhom::studies
