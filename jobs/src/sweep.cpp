// softhom sweep CAMPAIGN.toml --out DIR [--jobs N] [-j THREADS] [--retry-failed] [--no-warm-start] [--dry-run]
//
// Runs every case of a campaign (studies/campaign.hpp: Cartesian products and explicit lists of RVE
// scenes) on the engine its scene names — the FFT engine, or the FE engine for [solver] engine = "fe"
// (section, 3D and plate cells, set up as `softhom rve` sets them up) — into DIR/campaign.h5 (one group
// per case) and DIR/cases.csv (one row per case and step). Rerunning the same command skips the finished cases. Writes
// DIR/summary.json (counts, timings). Exit code 0 when every case is ok; 1 when some failed, when
// another sweep holds DIR (campaign.lock) or when a file cannot be written (the previous files stay);
// 128 + N when signal N (SIGINT, SIGTERM) interrupted the run (finished cases are stored,
// "interrupted": true in the summary; rerun to complete); 2 for bad input.
// Under mpirun / srun with several ranks the cases are spread over the ranks (run_campaign_mpi); rank 0
// alone prints, writes DIR and summary.json.
#include <iomanip>
#include <iostream>

#include "softhom/core/mpi.hpp"
#include "softhom/jobs/jobs.hpp"
#include "softhom/jobs/run_control.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/io/summary.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/studies/campaign.hpp"

namespace softhom::jobs {
namespace {

/// `--dry-run`: every case and whether the store in `out` holds it.
void list_cases(const SweepJob& job, const std::filesystem::path& out) {
  const auto stored = studies::read_store(out / "campaign.h5");
  for (const auto& c : job.campaign.cases) {
    const auto it = stored.find(c.id);
    std::cout << c.id << "  "
              << (it == stored.end() ? "todo" : it->second.scene_hash != c.scene_hash ? "changed" : it->second.status)
              << "\n";
  }
  std::cout << job.campaign.cases.size() << " cases\n";
}

nlohmann::json sweep_summary(const SweepJob& job, const studies::SweepReport& r, const RunOptions& options) {
  nlohmann::json summary = io::summary_base("sweep", job.file, job.table);
  summary["interrupted"] = r.interrupted;
  summary["removed_stale_temporaries"] = int(r.removed_temporaries.size());
  summary["cases"] = r.total;
  summary["skipped"] = r.skipped;
  summary["finished"] = r.finished;
  summary["failed_now"] = r.failed;
  summary["warm_started"] = r.warm_started;
  summary["newton_iterations"] = r.newton_iterations;  // computed now; a shared load path counts once
  summary["jobs"] = options.jobs;
  summary["threads_per_job"] = r.threads_per_job;
  summary["case_time_s"] = r.case_time_s;
  summary["wall_time_s"] = r.wall_time_s;
  summary["store_time_s"] = r.store_time_s;  // the writer adding cases and rewriting the store
  summary["mpi_ranks"] = r.ranks;
  if (!r.cases_per_rank.empty()) summary["cases_per_rank"] = r.cases_per_rank;
  summary["store"] = r.store.string();
  summary["cases_csv"] = r.csv.string();
  return summary;
}

}  // namespace

SweepJob parse_sweep(const std::filesystem::path& file) {
  if (file.empty())
    throw InputError("scene", "", "sweep needs a campaign file: softhom sweep CAMPAIGN.toml --out DIR "
                                  "(example: studies/campaigns/chapter4.toml)");
  SweepJob job;
  job.file = file;
  job.table = io::load_scene(file);
  job.campaign = studies::expand_campaign(job.table, std::filesystem::absolute(file).parent_path());
  return job;
}

bool run_sweep(const SweepJob& job, Sink& sink, const RunOptions& options) {
  // Over MPI (mpirun, srun) rank 0 alone prints, schedules and writes the store; the others compute.
  const bool writer = mpi::world_rank() == 0;
  const std::filesystem::path out = sink.directory();
  if (out.empty()) throw InputError("out", "", "a sweep writes its store into an output directory: give one");
  if (options.dry_run) {
    if (writer) list_cases(job, out);
    return true;
  }
  studies::SweepOptions so;
  so.jobs = options.jobs;
  so.threads = options.threads;
  so.warm_start = !options.no_warm_start;
  so.retry_failed = options.retry_failed;
  so.quiet = options.quiet || !writer;
  const studies::SweepReport r = mpi::world_size() > 1 ? studies::run_campaign_mpi(job.campaign, out, so)
                                                       : studies::run_campaign(job.campaign, out, so);
  if (!r.writer) return !stop_requested();
  nlohmann::json summary = sweep_summary(job, r, options);
  // Status over the whole store (earlier runs included).
  int ok = 0, failed = 0;
  const auto stored = studies::read_store(r.store);
  for (const auto& c : job.campaign.cases)
    if (const auto it = stored.find(c.id); it != stored.end()) (it->second.status == "ok" ? ok : failed)++;
  summary["stored_ok"] = ok;
  summary["stored_failed"] = failed;
  const bool all_ok = !r.interrupted && failed == 0 && ok == r.total;
  io::set_run_status(summary, all_ok, all_ok ? "" : stop_requested() ? interruption_message() : "some cases failed");
  sink.write_summary(summary);
  if (!options.quiet)
    std::cerr << "softhom sweep: " << (r.interrupted ? "interrupted, " : "") << ok << " ok, " << failed << " failed of "
              << r.total << " cases (" << r.finished << " run now in " << std::fixed << std::setprecision(1) << r.wall_time_s
              << std::defaultfloat << " s) → " << r.store.string()
              << ", " << r.csv.string() << "\n";
  return all_ok;
}

}  // namespace softhom::jobs
