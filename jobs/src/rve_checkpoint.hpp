#pragma once
// Checkpoints of `softhom rve` (FFT engine): the converged state of the latest output step on disk, so
// that a run ended by a signal, a wall-time limit, kill -9 or a failed step continues from there with
// `--resume` instead of from t = 0 (a 256³ cell takes hours).
//
// On disk, in --out:
//   checkpoint.json            the commit record: output time, rank count, the scene it belongs to, the
//                              summary's step log and iteration totals, the state files of its generation;
//   checkpoint/step<k>-rank<r>.h5   one state file per rank (its slab): ũ, the extrapolation increment,
//                              history, laminate vectors, the mixed iteration's pressures, F̄; rank 0's also
//                              the response rows.
// A checkpoint is written in two phases: every rank writes its state file atomically (temporary,
// fsync, rename), then rank 0 replaces checkpoint.json atomically and removes the older generation.
// A kill at any moment leaves the previous checkpoint or the new one, whole. With the state, the
// pressures and FFTW's plans the continued run repeats the uninterrupted one operation for operation
// (bitwise with one thread per rank).
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <toml++/toml.h>

#include "softhom/rve/fft_solver.hpp"

namespace softhom::fft {
class SlabDecomposition;
}

namespace softhom::jobs {

struct RveRecorder;

/// What a continued run takes over from the checkpoint besides the solver state.
struct RveResumePoint {
  double t = 0.0;                               ///< output time of the saved state
  std::vector<std::vector<double>> rows;        ///< response rows up to t (rank 0; t = 0 row first)
  nlohmann::json step_log = nlohmann::json::array();
  rve::RveCounts totals;                        ///< iteration totals of the run so far
  double wall_seconds = 0.0;                    ///< wall time of the run(s) so far
  int field_steps = 0;                          ///< field steps the earlier run(s) wrote
};

class RveCheckpoint {
 public:
  /// The checkpoint of --out `out` for `scene` on `ranks` processes (this one `rank`).
  RveCheckpoint(std::filesystem::path out, const toml::table& scene, int rank, int ranks);

  /// Whether --out holds the checkpoint of an unfinished run; `describe` then says which
  /// ("t = 0.5 of the load path, 12 output steps").
  bool exists() const;
  std::string describe() const;
  /// Checks that the checkpoint continues this scene on this many ranks; throws InputError naming
  /// --resume and the first scene key that differs, or the rank counts. Call before building the solver.
  void check_resumable() const;
  /// Loads this rank's saved state into `solver` (set_state, set_mixed_pressures) and returns the rest
  /// of the saved run. Throws InputError("--resume", ...) on an unreadable or foreign state.
  RveResumePoint load(rve::FftRveSolver& solver);

  /// After a converged output step at t: writes a checkpoint when one is due (the time since the last
  /// write, or since the start, is at least 20 times what that write took, taken as 50 ms before the
  /// first: checkpoints cost at most about 5 % of the run), or always with `force`. Collective over `slabs` (null: one process). A write that fails (full
  /// disk) leaves the previous checkpoint; the returned message says so (empty when written or not due).
  std::string save(const rve::FftRveSolver& solver, const fft::SlabDecomposition* slabs, double t,
                   const RveRecorder& record, const rve::RveCounts& totals, double wall_seconds, int field_steps,
                   bool force);
  /// Output time of the last checkpoint written or loaded (-1: none).
  double saved_t() const { return saved_t_; }
  /// This run's checkpoint writes, the wall time they took, and the bytes of the last one (all ranks'
  /// files; rank 0 knows them): summary.json "checkpoint".
  int writes() const { return writes_; }
  double write_seconds() const { return write_seconds_; }
  std::size_t last_bytes() const { return last_bytes_; }
  /// Removes the checkpoint (rank 0): the run completed, or it cannot be continued.
  void remove() const;

 private:
  RveResumePoint load_state(const nlohmann::json& record, rve::FftRveSolver& solver) const;

  std::filesystem::path out_;
  nlohmann::json fingerprint_;
  int rank_ = 0, ranks_ = 1;
  double saved_t_ = -1.0;
  double last_cost_s_ = 0.0;
  double last_end_s_ = 0.0;  // steady-clock seconds at the end of the last write (first: construction)
  int writes_ = 0;
  double write_seconds_ = 0.0;
  std::size_t last_bytes_ = 0;
};

/// The scene as a checkpoint identifies it: every table but [output], without `description` and the
/// [solver] keys that only limit or plan a run (iteration and cut-back limits, the step time budget,
/// FFTW planning), which a continued run may change.
nlohmann::json checkpoint_fingerprint(const toml::table& scene);

}  // namespace softhom::jobs
