#pragma once
// The pieces of the sweep runner (campaign.cpp) that the MPI runner (sweep_mpi.cpp) shares: the
// schedule (chains of cases on one load path), running one chain, and the progress lines. Both runners
// compute a chain with exactly this code, so a case's numbers do not depend on which rank ran it.
#include <atomic>
#include <chrono>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "softhom/rve/fft_solver.hpp"
#include "softhom/studies/campaign.hpp"

namespace softhom::studies::sweep_detail {

struct Chain {
  std::vector<int> members;  // indices into campaign.cases; each one's path is the beginning of the next's
  std::vector<bool> store;   // member must be (re)stored
  int last = 0;              // run up to this member (the last one to store)
};

/// What a chain needs besides its members: where results go and whether to stop.
struct ChainContext {
  const Campaign& campaign;
  std::filesystem::path dir;
  int threads_per_job = 1;
  std::function<bool()> stopping;                   // abandon the chain before its next member
  std::function<void()> case_started;               // a member to be stored starts
  std::function<void(CaseRecord&&)> case_finished;  // ... and ends (its record)
  std::atomic<long>* newton_computed = nullptr;
  std::filesystem::path wisdom_file;                // FFTW wisdom (empty: DIR/fftw.wisdom)
  bool case_progress = false;                       // a line per output step of a long case (stderr)
};

/// The engine of a chain's microstructure ([solver] engine of its scene), made for its first member and
/// kept along the chain: each run continues from the converged state at the end of the previous one
/// (the warm start). Both engines keep that state in their solver object between runs.
class CaseSolver {
 public:
  virtual ~CaseSolver() = default;
  /// Runs `segment` from the current state; `progress` (may be empty) sees every converged output step.
  virtual rve::RveRunResult run(const MixedControl& segment, const std::function<void(const rve::RveStep&)>& progress) = 0;
  /// What the record says of the cell: its size (voxels, or mesh elements and nodes) and achieved
  /// volume fraction.
  virtual void describe_cell(CaseRecord& r) const = 0;
};
/// The solver of case `c`; notes of its setup (engine, geometry, FFT plans or mesh) go into `r`.
std::unique_ptr<CaseSolver> make_case_solver(const ChainContext& ctx, const CampaignCase& c, CaseRecord& r);

/// "1.5s", "2m05s", "1h02m".
std::string hms(double seconds);
/// Case ids are HDF5 group names: InputError naming the first one that cannot be.
void check_case_ids(const Campaign& campaign);
/// What must run: absent, changed, or failed with --retry-failed.
std::vector<bool> cases_to_run(const Campaign& campaign, const std::map<std::string, CaseRecord>& stored, bool retry_failed);
/// Chains in campaign order (deterministic from the campaign and `todo` alone).
std::vector<Chain> plan_chains(const Campaign& campaign, const std::vector<bool>& todo, bool warm);
/// Runs one chain: members to be stored are announced by ctx.case_started / ctx.case_finished.
void run_chain(const ChainContext& ctx, const std::vector<int>& members, const std::vector<bool>& store, int last);
/// A report for `campaign` on the opened store (its files, the stale temporaries it removed, printed
/// unless quiet) and the cases to run, counting the stored ones as skipped.
SweepReport start_report(const Campaign& campaign, const CampaignStore& store, bool retry_failed, bool quiet,
                         std::vector<bool>& todo);
/// Counts a stored record in the report and prints its "[sweep] id: ok, ..." line (unless quiet).
void count_and_log(SweepReport& report, const CaseRecord& r, bool quiet);
/// "[sweep] done 3/6 (failed 0), running 2, skipped 0 | elapsed ..., ETA ...".
void log_progress(const SweepReport& report, int to_run, int running, std::chrono::steady_clock::time_point start);

}  // namespace softhom::studies::sweep_detail
