// softhom sweep CAMPAIGN.toml --out DIR [--jobs N] [-j THREADS] [--retry-failed] [--no-warm-start] [--dry-run]
//
// Runs every case of a campaign (studies/campaign.hpp: Cartesian products and explicit lists of RVE
// scenes) with the FFT RVE engine into DIR/campaign.h5 (one group per case) and DIR/cases.csv (one
// row per case and step). Rerunning the same command skips the finished cases. Writes
// DIR/summary.json (counts, timings). Exit code 0 when every case is ok; 1 when some failed, when
// another sweep holds DIR (campaign.lock) or when a file cannot be written (the previous files stay);
// 128 + N when signal N (SIGINT, SIGTERM) interrupted the run (finished cases are stored,
// "interrupted": true in the summary; rerun to complete); 2 for bad input.
// Under mpirun / srun with several ranks the cases are spread over the ranks (run_campaign_mpi); rank 0
// alone prints, writes DIR and summary.json.
#include <iostream>

#include "commands.hpp"
#include "run_control.hpp"
#include "softhom/core/mpi.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/io/summary.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/studies/campaign.hpp"

namespace softhom::app {

int run_sweep(const CommandOptions& options) {
  if (options.scene.empty())
    throw InputError("scene", "", "sweep needs a campaign file: softhom sweep CAMPAIGN.toml --out DIR "
                                  "(example: studies/campaigns/chapter4.toml)");
  // Over MPI (mpirun, srun) rank 0 alone prints, schedules and writes DIR; the others compute (and
  // leave messages about bad input, the same on every rank, to rank 0).
  const bool writer = mpi::world_rank() == 0;
  toml::table table;
  studies::Campaign campaign;
  try {
    table = io::load_scene(options.scene);
    campaign = studies::expand_campaign(table, std::filesystem::absolute(options.scene).parent_path());
  } catch (const InputError&) {
    if (writer) throw;
    return 2;
  }
  if (options.dry_run) {
    if (!writer) return 0;
    const auto stored = studies::read_store(options.out / "campaign.h5");
    for (const auto& c : campaign.cases) {
      const auto it = stored.find(c.id);
      std::cout << c.id << "  "
                << (it == stored.end() ? "todo" : it->second.scene_hash != c.scene_hash ? "changed" : it->second.status)
                << "\n";
    }
    std::cout << campaign.cases.size() << " cases\n";
    return 0;
  }
  studies::SweepOptions so;
  so.jobs = options.jobs;
  so.threads = options.threads;
  so.warm_start = !options.no_warm_start;
  so.retry_failed = options.retry_failed;
  so.quiet = options.quiet || !writer;
  const studies::SweepReport r = mpi::world_size() > 1 ? studies::run_campaign_mpi(campaign, options.out, so)
                                                       : studies::run_campaign(campaign, options.out, so);
  if (!r.writer) return run_exit_code(!stop_requested());

  nlohmann::json summary = io::summary_base("sweep", options.scene, table);
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
  // Status over the whole store (earlier runs included).
  int ok = 0, failed = 0;
  const auto stored = studies::read_store(r.store);
  for (const auto& c : campaign.cases)
    if (const auto it = stored.find(c.id); it != stored.end()) (it->second.status == "ok" ? ok : failed)++;
  summary["stored_ok"] = ok;
  summary["stored_failed"] = failed;
  const bool all_ok = !r.interrupted && failed == 0 && ok == r.total;
  io::set_run_status(summary, all_ok, all_ok ? "" : stop_requested() ? interruption_message() : "some cases failed");
  io::write_summary(options.out, summary);
  if (!options.quiet)
    std::cerr << "softhom sweep: " << (r.interrupted ? "interrupted, " : "") << ok << " ok, " << failed << " failed of " << r.total << " cases ("
              << r.finished << " run now in " << r.wall_time_s << " s) → " << r.store.string() << ", "
              << r.csv.string() << "\n";
  return run_exit_code(all_ok);
}

}  // namespace softhom::app
