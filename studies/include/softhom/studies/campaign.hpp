#pragma once
// Sweep campaigns (`softhom sweep CAMPAIGN.toml --out DIR`): a Cartesian product (and explicit lists)
// of RVE cases over matrix, fiber section, fiber angle, volume fraction, arrangement, resolution
// and load case; each case is an `softhom rve` scene, run on the engine its [solver] names: the FFT
// engine (the default) or the FE engine (engine = "fe": section, 3D and plate cells, mesh keys in
// [solver]; the resolution axis is the FFT grid, so FE cases take none and their ids have no "-nN").
// engine = "auto" is refused: a campaign compares cases at the resolution it gives. FE cases of one
// process run one at a time (concurrent FE solves differ in round-off); spread them over MPI ranks.
//
// Campaign file:
//   description = "..."
//   [base]                 an RVE scene (same tables as studies/scenes/rve_*.toml) giving everything
//                          the axes do not set: [base.phases.fiber], [base.solver], ... Keys set by an
//                          axis override it. (Or base_scene = "file.toml", relative to the campaign.)
//   [matrices.NAME]        a [phases.matrix] table; an axis value that is not defined here is a preset
//                          name ({preset = NAME}).
//   [sections.NAME]        [microstructure] keys of a fiber section: shape, radius, width, height,
//                          section_rotation_deg, fiber_count, min_gap, seed. Built in: "circle"
//                          (r = 0.2 mm) and "square" (0.07 x 0.07 mm), spec §7.
//   [loads.NAME]           a [load] table. Built in: tension (λ = 1.8), compression (λ = 0.6),
//                          equibiaxial (λ = 1.3), shear (simple shear γ = 0.5), relaxation (ramp to
//                          λ = 1.5 in 20 s, hold 20 s).
//   [sweep] / [[sweep]]    axes → lists; each [[sweep]] table is one Cartesian product, the campaign is
//                          their union: matrix, section, angle, volume_fraction, arrangement,
//                          resolution (n → grid [n, n], or [n1, n2] / [n1, n2, n3]), load.
//   [[cases]]              explicit cases: one value per axis, optional name (the case id) and
//                          override = {table merged into the case scene last, e.g. solver limits}.
//   Axes missing from a product or case: the [base] scene's value, else section "circle", angle 45,
//   volume_fraction 0.23, arrangement "square", resolution 32 (matrix and load are required).
//   volume_fraction = 0 is the matrix alone (section and arrangement then do not matter).
//   [campaign] warm_start = true   see below.
//
// Output directory (one writer at a time: `campaign.lock` holds an advisory flock for the whole run
// and the holder's pid and host; a second writer is refused at once, StoreBusy, exit code 1).
// Every file is written under a temporary name (.NAME.tmp-PID), synced and renamed, after every
// finished case; temporaries of dead writers are removed when the next writer takes the lock.
// A case whose id and scene hash are in the store is skipped on a rerun; cases of other campaigns
// run into the same directory stay (the store merges, never replaces).
//
// DIR/campaign.h5 (format "softhom-campaign-2"; stores of format 1 are read for resume and
// rewritten in format 2):
//   /                 attributes format, description (of the last campaign written), softhom_version
//   /index            compound dataset, one row per case sorted by id: case, status, one column per
//                     parameter (strings, float64; resolution int64), rows, steps, newton_iterations
//                     (int64), error, scene_hash. pandas: pd.DataFrame(h5py.File(p)["index"][()]) (strings as bytes).
//   /cases/<id>       group per case. Attributes: parameters (names in column order), one attribute
//                     per parameter (string, float64, int64 for resolution; angle NaN for the matrix
//                     alone), status ("ok" or "failed"), error, scene (the case's TOML), scene_hash, counts as int64 (steps,
//                     newton_iterations, krylov_iterations, cutbacks, voxels, elements, equations, threads), other statistics
//                     as float64 (timings, volume_fraction_achieved), notes as strings (geometry, fft,
//                     log, warm_start_from, on_path_of). FFT cases: voxels, fft_planning_s, note fft; FE cases:
//                     elements, equations, mesh_time_s, notes mesh and linear_solver. Note engine: "fft" or "fe".
//   /cases/<id>/response  float64 rows x columns (the `softhom rve` response.csv table, 0 rows for a
//                     case that failed before its first converged state); attribute columns.
// DIR/cases.csv: one row per case and step (the campaign's cases in campaign order, then the store's
// other cases by id) with every parameter as a column; angle "NaN" for the matrix alone.
// Case ids are HDF5 group names: no control characters, no '/', not empty, "." or "..".

// Warm starts (on by default; --no-warm-start or [campaign] warm_start = false): cases of one
// microstructure (same scene but [load]) whose load paths lie on each other's form a chain and the
// longest path is run once. Elastic phases: the response depends on the path of the controlled values
// only, so "tension to λ = 1.5" lies on "tension to λ = 1.8" whatever the durations and step counts;
// the path is run with the union of the members' output points and each case reads its rows off it
// (equal to a cold run to the solver tolerance). History-dependent phases (QLV): only exact prefixes
// (same output times up to the shorter case's end), which add no steps. Each segment of the path
// continues from the converged state at the end of the previous case (the solver object keeps it
// between runs, on either engine; rve::FftRveState is the FFT one made explicit, for restarts). An FE
// chain meshes its cell once, for its first member. A chain is
// always recomputed from its start (its finished members are not stored again), so a resumed run gives
// the same numbers as an uninterrupted one.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include <toml++/toml.h>

#include "softhom/materials/loading.hpp"

namespace softhom::studies {

/// A case parameter: a string (matrix, section, load, ...) or a number (angle, fraction, ...).
struct CaseParameter {
  std::string name;
  std::variant<std::string, double> value;
  bool is_string() const { return std::holds_alternative<std::string>(value); }
  std::string text() const;  ///< value as written in ids and CSV files
};

struct CampaignCase {
  std::string id;                          ///< unique, also the HDF5 group name
  std::vector<CaseParameter> parameters;   ///< axis values in axis order
  toml::table scene;                       ///< the full `softhom rve` scene of the case
  std::string scene_text;                  ///< canonical TOML text of `scene`
  std::string scene_hash;                  ///< FNV-1a 64 of scene_text (hex); a changed case is rerun
  std::string microstructure_hash;         ///< hash of the scene without [load] (warm-start groups)
  MixedControl control;                    ///< parsed [load]
  bool elastic = true;                     ///< no phase has history (warm starts allowed)
  std::string engine = "fft";              ///< [solver] engine of the scene: "fft" or "fe"
};

struct Campaign {
  std::string description;
  std::vector<CampaignCase> cases;
  bool warm_start = true;
};

/// The axis names, in column order.
const std::vector<std::string>& campaign_axes();

/// Expands a campaign table; every case scene is validated (materials, load, section geometry,
/// solver options) so a bad campaign stops before anything runs. Errors are InputErrors naming the
/// campaign field ("sweep[0].angle[2]") or the case and its scene field.
Campaign expand_campaign(const toml::table& table, const std::filesystem::path& base_dir);

/// One stored case (a group of the HDF5 store).
struct CaseRecord {
  std::string id;
  std::vector<CaseParameter> parameters;
  std::string status;   ///< "ok" or "failed"
  std::string error;
  std::string scene_text, scene_hash;
  std::vector<std::string> columns;
  std::vector<double> data;  ///< rows x columns, row-major
  std::map<std::string, double> stats;      ///< iterations, voxels, achieved fraction, threads, timings
  std::map<std::string, std::string> info;  ///< geometry note, warm-start source, solver description
  std::size_t rows() const { return columns.empty() ? 0 : data.size() / columns.size(); }
};

/// Stats that vary between identical runs (timings); a resumed store equals an uninterrupted one
/// except for these.
bool is_timing_stat(const std::string& name);

/// Why `id` cannot be a case id (an HDF5 group name), or "" when it can.
std::string case_id_problem(const std::string& id);
/// `s` with control characters written as \xNN (for messages).
std::string escape_control_characters(const std::string& s);

/// Reads DIR/campaign.h5 (empty map when absent). Throws std::runtime_error naming the file on a
/// corrupt store or one of an unknown format.
std::map<std::string, CaseRecord> read_store(const std::filesystem::path& store);
/// Writes all records (sorted by id) to `store` atomically (temporary file + fsync + rename). On any
/// failure (full disk, read-only directory, HDF5 error) throws std::runtime_error with the path and
/// the reason, after removing the temporary: the previous store is unchanged.
void write_store(const std::filesystem::path& store, const std::map<std::string, CaseRecord>& records,
                 const std::string& description);
/// The tidy table: case, status, every parameter (union over cases, first-seen order), step, then the
/// response columns. A failed case without a converged row still has one row (empty response).
std::string cases_csv(const std::vector<const CaseRecord*>& records);

/// A second writer of a campaign directory: names the directory and the holder (pid, host).
struct StoreBusy : std::runtime_error {
  StoreBusy(const std::filesystem::path& dir, const std::string& holder);
};

/// The advisory lock of a campaign directory (flock on DIR/campaign.lock, which records pid and
/// host), held while the object lives. Throws StoreBusy when another open file holds it (another
/// process, or another StoreLock of this one), std::runtime_error when it cannot be created.
class StoreLock {
 public:
  explicit StoreLock(const std::filesystem::path& dir);
  ~StoreLock();
  StoreLock(const StoreLock&) = delete;
  StoreLock& operator=(const StoreLock&) = delete;
  const std::filesystem::path& path() const { return path_; }
  long previous_pid() const { return previous_pid_; }               ///< the last holder (0: none)
  const std::string& previous_host() const { return previous_host_; }

 private:
  int fd_ = -1;
  std::filesystem::path path_;
  long previous_pid_ = 0;
  std::string previous_host_;
};

/// Removes DIR/.NAME.tmp-PID files whose process is gone; only when `writer_host` (the host of the
/// last lock holder) is this host or unknown, since other hosts' pids cannot be checked. Call with
/// the lock held. Returns the removed paths.
std::vector<std::filesystem::path> remove_stale_temporaries(const std::filesystem::path& dir, const std::string& writer_host);

/// The store of one campaign directory, owned by this object: takes the lock, removes stale
/// temporaries, reads the store. add() then write() rewrites campaign.h5 and cases.csv; a store that
/// changed on disk meanwhile is merged (its cases kept, the ones added here win).
class CampaignStore {
 public:
  explicit CampaignStore(const std::filesystem::path& dir);
  ~CampaignStore();
  const std::map<std::string, CaseRecord>& records() const { return records_; }
  void add(CaseRecord record);
  void write(const Campaign& campaign);
  const std::filesystem::path& store_path() const { return store_path_; }
  const std::filesystem::path& csv_path() const { return csv_path_; }
  const std::vector<std::filesystem::path>& removed_temporaries() const { return removed_temporaries_; }

 private:
  struct Stamp;
  std::filesystem::path dir_;
  StoreLock lock_;
  std::filesystem::path store_path_, csv_path_;
  std::map<std::string, CaseRecord> records_;
  std::set<std::string> mine_;
  std::unique_ptr<Stamp> stamp_;
  std::vector<std::filesystem::path> removed_temporaries_;
};

/// Tests only: called with the temporary's path half way through writing the store (the temporary
/// exists, open and partly written; before fsync and rename): a throwing fault simulates a full
/// disk. An empty function: no fault.
void set_store_write_fault_for_testing(std::function<void(const std::filesystem::path&)> fault);

struct SweepOptions {
  int jobs = 1;           ///< cases in parallel (threads); 0: one single-threaded job per thread
  int threads = 0;        ///< total OpenMP threads (0: omp_get_max_threads()); split evenly between jobs
  bool warm_start = true; ///< and the campaign's own switch
  bool retry_failed = false;
  bool quiet = false;     ///< no progress on stderr
  /// Stop after this many newly finished cases (0: no limit); simulates an interrupted run in tests
  /// (this and the two hooks below: run_campaign only).
  int max_new_cases = 0;
  /// Called in the writing thread after each finished case is in the store (tests: request_stop()).
  std::function<void(const CaseRecord&)> on_case_stored;
  /// Called in the worker thread as each case finishes, before the worker takes the next one (tests:
  /// request_stop() here stops a one-job run after exactly that case).
  std::function<void(const CaseRecord&)> on_case_finished;
};

struct SweepReport {
  int total = 0, skipped = 0, finished = 0, failed = 0;
  int warm_started = 0;
  int threads_per_job = 1;
  double wall_time_s = 0.0;
  double case_time_s = 0.0;  ///< sum of the wall times of the cases run now
  long newton_iterations = 0; ///< Newton iterations computed now (a shared load path counts once)
  bool interrupted = false;   ///< stop_requested() (SIGINT/SIGTERM): finished cases are stored
  std::vector<std::filesystem::path> removed_temporaries;  ///< stale ones of killed runs
  std::filesystem::path store, csv;
  double store_time_s = 0.0;  ///< spent adding finished cases to the store and writing it (the writer)
  int ranks = 1;              ///< MPI ranks that ran cases (run_campaign_mpi)
  std::vector<int> cases_per_rank;  ///< cases stored now, by the rank that computed them (run_campaign_mpi)
  bool writer = true;         ///< this process wrote the store (false on MPI ranks other than 0)
};

/// Runs the campaign's unfinished cases into DIR/campaign.h5 and DIR/cases.csv, holding the
/// directory's lock. Failed cases are recorded with their error. Throws InputError for bad input
/// (a case id that cannot be a group name) before anything runs, StoreBusy when another writer holds
/// the directory, std::runtime_error when a file cannot be written (the previous files stay). On
/// stop_requested() the cases in flight are abandoned and the report says interrupted.
SweepReport run_campaign(const Campaign& campaign, const std::filesystem::path& dir, const SweepOptions& options);

/// The same over MPI ranks (call on every rank of MPI_COMM_WORLD, under an MPI launcher). Rank 0
/// schedules: it hands out chains (a warm-start chain stays on one rank) longest first to whichever
/// rank asks (pull model), runs chains itself too, and is the only writer of DIR (lock, store, CSV,
/// progress). The other ranks run the chains they are given with `options.jobs` threads and send each
/// finished case to rank 0 as a message (no shared memory; DIR only needs to be reachable for the
/// campaign's input files and FFTW wisdom). A case's numbers are those of run_campaign (same code,
/// same threads per case). On stop_requested() on rank 0 no more work is handed out and every rank
/// ends after its case in flight; what finished is stored. The report of rank 0 is run_campaign's;
/// other ranks return writer = false and counts of their own cases. With one rank: run_campaign.
SweepReport run_campaign_mpi(const Campaign& campaign, const std::filesystem::path& dir, const SweepOptions& options);

/// A finished case as bytes (the message a rank sends to the writer) and back. decode_case_record
/// throws std::runtime_error on a buffer that is not a whole record.
std::vector<char> encode_case_record(const CaseRecord& record);
CaseRecord decode_case_record(const char* data, std::size_t size);

}  // namespace softhom::studies
