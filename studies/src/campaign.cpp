// Sweep campaigns: expansion of the campaign file into RVE scenes, and the resumable parallel runner.
#include "softhom/studies/campaign.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <functional>
#include <iostream>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include "softhom/io/files.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/io/summary.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/interrupt.hpp"
#include "softhom/studies/rve_scene.hpp"
#include "sweep_internal.hpp"

namespace softhom::studies {

// The Debian HDF5 build is not thread-safe: the store and imported phase images go through this.
std::mutex& hdf5_mutex() {
  static std::mutex m;
  return m;
}

namespace {

using Clock = std::chrono::steady_clock;

}  // namespace

bool is_timing_stat(const std::string& name) {
  return name == "wall_time_s" || name == "solve_time_s" || name == "fft_planning_s" || name == "mesh_time_s";
}


// ---------------------------------------------------------------------------------------------
// Runner (sweep_detail: shared with the MPI runner, sweep_mpi.cpp).

namespace sweep_detail {

bool near(double a, double b) { return std::abs(a - b) <= 1e-12 * std::max({1.0, std::abs(a), std::abs(b)}); }

/// Where case A's load path lies on case B's: B passes A's state of time t at time c·t; returns c, or
/// nothing when A's path is not the beginning of B's. Same frame and control kinds, every component
/// agrees, A.value(t) = B.value(c t) on [0, t_A] (piecewise linear: checking both breakpoint sets and
/// A's output times suffices), and c t_A ≤ t_B.
/// rescale (elastic cells, whose response depends on the path of the controlled values only, not on
/// time or steps): c from the component that changes most along A, and A's output times may fall
/// anywhere on B's path ("tension to λ = 1.5 in 16 steps" lies on "tension to λ = 1.8 in 16 steps").
/// Otherwise (history-dependent phases) c = 1 and A's output times must be B's first ones, so that B
/// computes exactly A's time steps: other steps would change the time integration, not just round-off.
std::optional<double> path_scale(const MixedControl& A, const MixedControl& B, bool rescale) {
  if (A.times.empty() || B.times.empty()) return std::nullopt;
  if (!(A.frame - B.frame).isZero(0.0)) return std::nullopt;
  for (int k = 0; k < 9; ++k)
    if (A.kind[k] != B.kind[k]) return std::nullopt;
  const double tA = A.times.back(), tB = B.times.back();
  double c = 1.0;
  if (rescale) {
    int kmax = -1;
    double dmax = 0.0;
    for (int k = 0; k < 9; ++k) {
      const double d = std::abs(A.value[k](tA) - A.value[k](0.0));
      if (d > dmax) dmax = d, kmax = k;
    }
    if (kmax < 0) return std::nullopt;  // nothing changes along A: no path to share
    const PiecewiseLinear& f = B.value[kmax];
    const double target = A.value[kmax](tA);
    std::vector<double> ts{0.0};
    for (double t : f.t)
      if (t > 0.0 && t < tB) ts.push_back(t);
    ts.push_back(tB);
    double s = -1.0;  // first time at which B's component reaches A's end value
    for (std::size_t i = 1; i < ts.size() && s < 0.0; ++i) {
      const double v0 = f(ts[i - 1]), v1 = f(ts[i]);
      if (v1 != v0 && (target - v0) * (target - v1) <= 0.0)
        s = ts[i - 1] + (target - v0) / (v1 - v0) * (ts[i] - ts[i - 1]);
    }
    if (!(s > 0.0)) return std::nullopt;
    c = near(s, tA) ? 1.0 : s / tA;
  } else {
    if (B.times.size() < A.times.size()) return std::nullopt;
    for (std::size_t i = 0; i < A.times.size(); ++i)
      if (!near(A.times[i], B.times[i])) return std::nullopt;
  }
  if (c * tA > tB * (1.0 + 1e-12)) return std::nullopt;
  std::vector<double> ts = A.times;
  ts.push_back(0.0);
  for (int k = 0; k < 9; ++k) {
    for (double t : A.value[k].t)
      if (t <= tA) ts.push_back(t);
    for (double t : B.value[k].t)
      if (t <= c * tA) ts.push_back(t / c);
  }
  for (int k = 0; k < 9; ++k)
    for (double t : ts)
      if (!near(A.value[k](t), B.value[k](c * t))) return std::nullopt;
  return c;
}

/// Total variation of the controlled values along the path: orders the cases of one path.
double path_extent(const MixedControl& A) {
  double e = 0.0;
  const double tA = A.times.back();
  for (int k = 0; k < 9; ++k) {
    std::vector<double> ts{0.0};
    for (double t : A.value[k].t)
      if (t > 0.0 && t < tA) ts.push_back(t);
    ts.push_back(tA);
    for (std::size_t i = 1; i < ts.size(); ++i) e += std::abs(A.value[k](ts[i]) - A.value[k](ts[i - 1]));
  }
  return e;
}

/// B restarted at t0 (t ↦ t − t0), for continuing a solver that is at B's state at t0.
MixedControl shifted(const MixedControl& B, double t0) {
  MixedControl s = B;
  for (int c = 0; c < 9; ++c) {
    const PiecewiseLinear& f = B.value[c];
    PiecewiseLinear g{{0.0}, {f(t0)}};
    for (std::size_t k = 0; k < f.t.size(); ++k)
      if (f.t[k] > t0 && !near(f.t[k], t0)) {
        g.t.push_back(f.t[k] - t0);
        g.v.push_back(f.v[k]);
      }
    s.value[c] = g;
  }
  s.times.clear();
  for (double t : B.times)
    if (t > t0 && !near(t, t0)) s.times.push_back(t - t0);
  return s;
}

std::string hms(double s) {
  if (!(s >= 0) || !std::isfinite(s)) return "?";
  const long t = std::lround(s);
  char buf[32];
  if (t >= 3600) std::snprintf(buf, sizeof buf, "%ldh%02ldm", t / 3600, (t / 60) % 60);
  else if (t >= 60) std::snprintf(buf, sizeof buf, "%ldm%02lds", t / 60, t % 60);
  else std::snprintf(buf, sizeof buf, "%.1fs", s);
  return buf;
}

// ---------------------------------------------------------------------------------------------
// Schedule: which cases run, grouped into chains that share one load path.

/// Case ids are HDF5 group names and file-name-like keys: refused before anything runs or is written.
void check_case_ids(const Campaign& campaign) {
  for (const auto& c : campaign.cases)
    if (const std::string problem = case_id_problem(c.id); !problem.empty())
      throw InputError("case id", "\"" + escape_control_characters(c.id) + "\"",
                       problem + " (ids name HDF5 groups; rename the case or the axis value)");
}

/// What must run: absent, changed, or failed with --retry-failed.
std::vector<bool> cases_to_run(const Campaign& campaign, const std::map<std::string, CaseRecord>& stored, bool retry_failed) {
  std::vector<bool> todo(campaign.cases.size(), false);
  for (std::size_t i = 0; i < campaign.cases.size(); ++i) {
    const auto& c = campaign.cases[i];
    const auto it = stored.find(c.id);
    todo[i] = it == stored.end() || it->second.scene_hash != c.scene_hash || (retry_failed && it->second.status != "ok");
  }
  return todo;
}

/// Chains within one microstructure: cases whose load paths lie on each other's (path_scale) run as
/// one path. Deterministic from the campaign alone, so a resumed run computes each case the same way.
std::vector<Chain> plan_chains(const Campaign& campaign, const std::vector<bool>& todo, bool warm) {
  std::vector<Chain> chains;
  std::map<std::string, std::vector<int>> groups;
  std::vector<std::string> group_order;
  for (std::size_t i = 0; i < campaign.cases.size(); ++i) {
    const auto& c = campaign.cases[i];
    const std::string key = warm ? c.microstructure_hash : "single:" + c.id;
    if (!groups.count(key)) group_order.push_back(key);
    groups[key].push_back(int(i));
  }
  for (const auto& key : group_order) {
    std::vector<int> members = groups[key];
    std::vector<double> extent(campaign.cases.size(), 0.0);
    for (int m : members) extent[m] = path_extent(campaign.cases[m].control);
    std::stable_sort(members.begin(), members.end(), [&](int a, int b) {
      if (extent[a] != extent[b]) return extent[a] < extent[b];
      return campaign.cases[a].control.times.back() < campaign.cases[b].control.times.back();
    });
    std::vector<Chain> local;
    for (int m : members) {
      const CampaignCase& c = campaign.cases[m];
      bool placed = false;
      for (auto& ch : local) {
        const CampaignCase& last = campaign.cases[ch.members.back()];
        // Every member must lie on the final path: check against the chain's first member too.
        if (path_scale(last.control, c.control, c.elastic) &&
            path_scale(campaign.cases[ch.members.front()].control, c.control, c.elastic)) {
          ch.members.push_back(m);
          placed = true;
          break;
        }
      }
      if (!placed) local.push_back(Chain{{m}, {}, 0});
    }
    for (auto& ch : local) {
      // Run up to the last member that must be stored; earlier finished members are recomputed
      // (not stored) only because they are on the way. The later members still shape the path's
      // output steps, so a resumed run computes every case exactly as an uninterrupted one.
      int last = -1;
      for (std::size_t k = 0; k < ch.members.size(); ++k) {
        ch.store.push_back(todo[ch.members[k]]);
        if (todo[ch.members[k]]) last = int(k);
      }
      if (last < 0) continue;
      ch.last = last;
      chains.push_back(std::move(ch));
    }
  }
  std::stable_sort(chains.begin(), chains.end(),
                   [](const Chain& a, const Chain& b) { return a.members.front() < b.members.front(); });
  return chains;
}

// ---------------------------------------------------------------------------------------------
// Run one chain (and so one case).

/// The record's parameters: the case's, with the fiber angle NaN for the matrix alone (it has none).
std::vector<CaseParameter> record_parameters(const CampaignCase& c) {
  std::vector<CaseParameter> p = c.parameters;
  bool matrix_only = false;
  for (const auto& q : p)
    if (q.name == "volume_fraction" && !q.is_string() && std::get<double>(q.value) == 0.0) matrix_only = true;
  if (matrix_only)
    for (auto& q : p)
      if (q.name == "angle" && !q.is_string()) q.value = std::nan("");
  return p;
}

CaseRecord base_record(const CampaignCase& c) {
  CaseRecord r;
  r.id = c.id;
  r.parameters = record_parameters(c);
  r.scene_text = c.scene_text;
  r.scene_hash = c.scene_hash;
  r.columns = rve_response_columns();
  return r;
}

void finish_record(CaseRecord& r, const std::vector<rve::RveStep>& steps) {
  r.data.clear();
  double newton = 0, krylov = 0, cutbacks = 0;
  for (const auto& s : steps) {
    const auto row = rve_response_row(s);
    r.data.insert(r.data.end(), row.begin(), row.end());
    newton += s.newton_iterations;
    krylov += s.krylov_iterations;
    cutbacks += s.cutbacks;
  }
  r.stats["steps"] = steps.empty() ? 0.0 : double(steps.size() - 1);
  r.stats["newton_iterations"] = newton;
  r.stats["krylov_iterations"] = krylov;
  r.stats["cutbacks"] = cutbacks;
}

/// The output times of a chain on its final path (the union of all members', mapped by path_scale)
/// and, per member, the index in it of each of the member's own output times.
struct PathPlan {
  std::vector<double> times;                  // S
  std::vector<std::vector<std::size_t>> idx;  // idx[k][i]: S index of member k's i-th output time
};

std::optional<PathPlan> plan_path(const Campaign& campaign, const std::vector<int>& members) {
  const std::size_t K = members.size();
  const CampaignCase& fin = campaign.cases[members.back()];
  std::vector<double> scale(K, 1.0);
  for (std::size_t k = 0; k + 1 < K; ++k) {
    const CampaignCase& c = campaign.cases[members[k]];
    const auto sc = path_scale(c.control, fin.control, c.elastic);
    if (!sc) return std::nullopt;
    scale[k] = *sc;
  }
  PathPlan plan;
  std::vector<double> S;
  for (std::size_t k = 0; k < K; ++k)
    for (double t : campaign.cases[members[k]].control.times) S.push_back(k + 1 == K ? t : scale[k] * t);
  std::sort(S.begin(), S.end());
  for (double t : S)
    if (plan.times.empty() || !near(plan.times.back(), t)) plan.times.push_back(t);
  const auto& U = plan.times;
  plan.idx.resize(K);
  for (std::size_t k = 0; k < K; ++k)
    for (double t : campaign.cases[members[k]].control.times) {
      const double x = k + 1 == K ? t : scale[k] * t;
      std::size_t j = std::size_t(std::lower_bound(U.begin(), U.end(), x) - U.begin());
      if (j == U.size() || (j > 0 && std::abs(U[j - 1] - x) < std::abs(U[j] - x))) --j;
      plan.idx[k].push_back(j);
    }
  return plan;
}

/// The output-step callback of a case: a case that runs for long shows where it is ("[sweep] ID: step
/// 3 of 12, 25s"), from 10 s on and at most every 10 s, so a sweep is never silent for minutes. Empty
/// without ctx.case_progress.
std::function<void(const rve::RveStep&)> case_progress(const ChainContext& ctx, const std::string& id, int steps,
                                                      Clock::time_point start) {
  if (!ctx.case_progress) return {};
  constexpr double kEverySeconds = 10.0;
  return [id, steps, start, step = 0, last_line = start](const rve::RveStep& st) mutable {
    if (st.t <= 0.0) return;  // the segment's starting row
    ++step;
    const auto now = Clock::now();
    if (std::chrono::duration<double>(now - last_line).count() < kEverySeconds || step >= steps) return;
    last_line = now;
    std::cerr << ("[sweep] " + id + ": step " + std::to_string(step) + " of " + std::to_string(steps) + ", " +
                  hms(std::chrono::duration<double>(now - start).count()) + "\n");
  };
}

/// Member k of a chain: continues the shared path up to the member's last output time (if not
/// reached yet) and reads the member's rows off it. Returns its record; `failed` when the path ended
/// before the member's end.
CaseRecord run_member(const ChainContext& ctx, const std::vector<int>& members, const PathPlan& plan, int k,
                      std::unique_ptr<CaseSolver>& solver, std::vector<rve::RveStep>& path, bool& failed) {
  const Campaign& campaign = ctx.campaign;
  const CampaignCase& c = campaign.cases[members[k]];
  const CampaignCase& fin = campaign.cases[members.back()];
  const std::vector<double>& S = plan.times;
  const std::vector<std::size_t>& idx = plan.idx[k];
  CaseRecord r = base_record(c);
  r.stats["threads"] = ctx.threads_per_job;
  const auto t0 = Clock::now();
  std::vector<rve::RveStep> steps;
  double newton = 0, krylov = 0, cutbacks = 0;
  failed = false;
  try {
    const std::size_t done = path.empty() ? 0 : path.size() - 1;  // entries of S reached
    if (k > 0) r.info["warm_start_from"] = campaign.cases[members[k - 1]].id;
    if (members.size() > 1 && k + 1 < int(members.size())) r.info["on_path_of"] = fin.id;
    rve::RveRunResult result;
    result.completed = true;
    if (idx.back() + 1 > done) {
      MixedControl seg = done == 0 ? fin.control : shifted(fin.control, S[done - 1]);
      seg.times.clear();
      for (std::size_t j = done; j <= idx.back(); ++j) seg.times.push_back(done == 0 ? S[j] : S[j] - S[done - 1]);
      if (!solver) solver = make_case_solver(ctx, c, r);
      result = solver->run(seg, case_progress(ctx, c.id, int(idx.back() + 1 - done), t0));
      for (std::size_t st = done == 0 ? 0 : 1; st < result.steps.size(); ++st) {
        path.push_back(result.steps[st]);
        newton += result.steps[st].newton_iterations;
        krylov += result.steps[st].krylov_iterations;
        cutbacks += result.steps[st].cutbacks;
      }
      for (const auto& line : result.log) r.info["log"] += line + "\n";
    }
    solver->describe_cell(r);
    if (!path.empty()) steps.push_back(path[0]);
    for (std::size_t i = 0; i < idx.size() && idx[i] + 1 < path.size(); ++i) {
      rve::RveStep st = path[idx[i] + 1];
      st.t = c.control.times[i];  // the exact output time of a cold run
      steps.push_back(st);
    }
    failed = !result.completed || steps.size() != idx.size() + 1;
    r.status = failed ? "failed" : "ok";
    r.error = result.completed ? (failed ? "the shared load path ended early" : "") : result.error;
  } catch (const std::exception& e) {
    r.status = "failed";
    r.error = e.what();
    failed = true;
  }
  finish_record(r, steps);
  // Work done for this member (its segment of the path), not the rows it shares with others.
  r.stats["newton_iterations"] = newton;
  r.stats["krylov_iterations"] = krylov;
  r.stats["cutbacks"] = cutbacks;
  if (ctx.newton_computed) *ctx.newton_computed += long(newton);
  r.stats["wall_time_s"] = std::chrono::duration<double>(Clock::now() - t0).count();
  return r;
}

/// One chain: the final member's load path is run once, in segments that end at each member's last
/// output time. A segment continues from the solver's converged state at the end of the previous one
/// (the warm start). A member that fails ends the shared path; the members after it then run cold,
/// each on its own.
void run_chain(const ChainContext& ctx, const std::vector<int>& members, const std::vector<bool>& store, int last) {
  const std::optional<PathPlan> plan = plan_path(ctx.campaign, members);
  if (!plan) {  // not expected (chains are built with path_scale); run the members on their own
    for (int j = 0; j <= last; ++j) run_chain(ctx, {members[j]}, {store[j]}, 0);
    return;
  }
  std::unique_ptr<CaseSolver> solver;
  std::vector<rve::RveStep> path;  // path[0]: t = 0; path[j + 1]: at plan->times[j]
  for (int k = 0; k <= last; ++k) {
    if (ctx.stopping()) return;
    if (store[k]) ctx.case_started();
    bool failed = false;
    CaseRecord r = run_member(ctx, members, *plan, k, solver, path, failed);
    if (store[k]) ctx.case_finished(std::move(r));
    if (failed) {
      for (int j = k + 1; j <= last; ++j) run_chain(ctx, {members[j]}, {store[j]}, 0);
      return;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// The scheduler: `jobs` threads take chains in order; finished records queue up for the writer.

class ChainScheduler {
 public:
  ChainScheduler(const Campaign& campaign, const std::filesystem::path& dir, std::vector<Chain> chains, int jobs,
                 int threads_per_job, std::atomic<long>& newton,
                 std::function<void(const CaseRecord&)> on_case_finished = {}, bool case_progress = false)
      : chains_(std::move(chains)),
        on_case_finished_(std::move(on_case_finished)),
        ctx_{campaign, dir, threads_per_job, [this] { return stopping(); }, [this] { case_started(); },
             [this](CaseRecord&& r) { case_finished(std::move(r)); }, &newton, {}},
        workers_alive_(jobs) {
    ctx_.case_progress = case_progress;
    for (int j = 0; j < jobs; ++j) threads_.emplace_back([this, threads_per_job] { work(threads_per_job); });
  }
  ~ChainScheduler() {
    cancel();
    join();
  }
  ChainScheduler(const ChainScheduler&) = delete;
  ChainScheduler& operator=(const ChainScheduler&) = delete;

  /// Waits (at most `poll`) for finished records and moves them to `batch`; false once every worker
  /// ended and nothing is left. `running`: the members being computed.
  bool wait(std::vector<CaseRecord>& batch, int& running, std::chrono::milliseconds poll) {
    std::unique_lock<std::mutex> lock(mu_);
    cv_.wait_for(lock, poll, [&] { return !results_.empty() || workers_alive_ == 0; });
    batch.clear();
    while (!results_.empty()) {
      batch.push_back(std::move(results_.front()));
      results_.pop_front();
    }
    running = running_;
    return !batch.empty() || workers_alive_ > 0;
  }
  /// No new chain or member starts; records still arriving are dropped (a simulated kill, a write
  /// failure).
  void cancel() {
    std::lock_guard<std::mutex> lock(mu_);
    cancelled_ = true;
    results_.clear();
  }
  void join() {
    for (auto& t : threads_)
      if (t.joinable()) t.join();
  }

 private:
  bool stopping() {
    std::lock_guard<std::mutex> lock(mu_);
    return cancelled_ || stop_requested();
  }
  void case_started() {
    std::lock_guard<std::mutex> lock(mu_);
    ++running_;
  }
  void case_finished(CaseRecord&& r) {
    if (on_case_finished_) on_case_finished_(r);
    std::lock_guard<std::mutex> lock(mu_);
    --running_;
    // On a signal the case in flight is abandoned unless it finished (the engine stops at its next
    // check and reports the interruption, which must not be stored as a failure).
    const bool keep = !cancelled_ && !(stop_requested() && r.status != "ok");
    if (keep) results_.push_back(std::move(r));
    cv_.notify_all();
  }
  void work(int threads_per_job) {
    omp_set_num_threads(threads_per_job);
    while (true) {
      std::size_t ci;
      {
        std::lock_guard<std::mutex> lock(mu_);
        if (cancelled_ || stop_requested() || next_chain_ >= chains_.size()) break;
        ci = next_chain_++;
      }
      run_chain(ctx_, chains_[ci].members, chains_[ci].store, chains_[ci].last);
    }
    std::lock_guard<std::mutex> lock(mu_);
    --workers_alive_;
    cv_.notify_all();
  }

  std::vector<Chain> chains_;
  std::function<void(const CaseRecord&)> on_case_finished_;
  ChainContext ctx_;
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<CaseRecord> results_;
  std::size_t next_chain_ = 0;
  int running_ = 0, workers_alive_ = 0;
  bool cancelled_ = false;
  std::vector<std::thread> threads_;
};

// ---------------------------------------------------------------------------------------------
// Record: counts and progress lines of the finished cases.

SweepReport start_report(const Campaign& campaign, const CampaignStore& store, bool retry_failed, bool quiet,
                         std::vector<bool>& todo) {
  SweepReport report;
  report.total = int(campaign.cases.size());
  report.store = store.store_path();
  report.csv = store.csv_path();
  report.removed_temporaries = store.removed_temporaries();
  if (!quiet)
    for (const auto& p : report.removed_temporaries) std::cerr << "[sweep] removed stale temporary " << p.string() << "\n";
  todo = cases_to_run(campaign, store.records(), retry_failed);
  report.skipped = int(std::count(todo.begin(), todo.end(), false));
  return report;
}

void count_and_log(SweepReport& report, const CaseRecord& r, bool quiet) {
  ++report.finished;
  if (r.status != "ok") ++report.failed;
  if (r.info.count("warm_start_from")) ++report.warm_started;
  const auto wall = r.stats.find("wall_time_s");
  const double seconds = wall == r.stats.end() ? 0.0 : wall->second;
  report.case_time_s += seconds;
  if (quiet) return;
  std::cerr << "[sweep] " << r.id << ": " << r.status;
  if (r.status != "ok") std::cerr << " (" << r.error << ")";
  const auto warm = r.info.find("warm_start_from");
  std::cerr << ", " << r.rows() << " rows, " << hms(seconds) << (warm != r.info.end() ? ", warm from " + warm->second : "")
            << "\n";
}

void log_progress(const SweepReport& report, int to_run, int running, Clock::time_point start) {
  const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  const int left = to_run - report.finished;
  const double eta = report.finished > 0 ? elapsed / report.finished * left : -1.0;
  std::cerr << "[sweep] done " << report.finished << "/" << to_run << " (failed " << report.failed << "), running "
            << running << ", skipped " << report.skipped << " | elapsed " << hms(elapsed) << ", ETA "
            << (left == 0 ? "0s" : hms(eta)) << "\n";
}

}  // namespace sweep_detail

SweepReport run_campaign(const Campaign& campaign, const std::filesystem::path& dir, const SweepOptions& options) {
  using namespace sweep_detail;
  const auto start = Clock::now();
  check_case_ids(campaign);
  // Write: the directory is ours until `store` goes (lock, stale temporaries removed, store read).
  CampaignStore store(dir);

  // Schedule.
  std::vector<bool> todo;
  SweepReport report = start_report(campaign, store, options.retry_failed, options.quiet, todo);
  const bool warm = options.warm_start && campaign.warm_start;
  std::vector<Chain> chains = plan_chains(campaign, todo, warm);
  int to_run = 0;
  for (const auto& ch : chains)
    for (bool s : ch.store) to_run += s ? 1 : 0;
  const int total_threads = options.threads > 0 ? options.threads : omp_get_max_threads();
  // Threads per case from the requested jobs, not from the work left: a resumed run then computes
  // every case with the same thread count as an uninterrupted one (OpenMP sums are order dependent).
  // jobs = 0: one single-threaded job per thread — on small cells OpenMP inside a case gains little,
  // and on a loaded machine its spinning barriers cost far more (BENCHMARKS.md, Campaigns).
  const int requested_jobs = options.jobs > 0 ? options.jobs : total_threads;
  const int tpj = std::max(1, total_threads / requested_jobs);
  const int jobs = std::max(1, std::min(requested_jobs, std::max(1, int(chains.size()))));
  report.threads_per_job = tpj;
  if (!options.quiet)
    std::cerr << "[sweep] " << report.total << " cases: " << report.skipped << " already in the store, " << to_run
              << " to run in " << chains.size() << " chains, " << jobs << " job(s) x " << tpj << " thread(s)"
              << (warm ? ", warm starts on" : ", warm starts off") << "\n";
  if (chains.empty()) store.write(campaign);  // a finished campaign: refresh cases.csv (e.g. after edits)

  std::atomic<long> newton_computed{0};
  const bool stop_was_requested = stop_requested();
  {
    const int workers = chains.empty() ? 0 : jobs;
    ChainScheduler scheduler(campaign, dir, std::move(chains), workers, tpj, newton_computed, options.on_case_finished,
                             !options.quiet);
    try {
      int committed = 0, running = 0;
      std::vector<CaseRecord> batch;
      while (scheduler.wait(batch, running, std::chrono::milliseconds(100))) {
        if (batch.empty()) continue;
        const auto store_start = Clock::now();
        std::vector<std::string> ids;
        for (auto& r : batch) {
          count_and_log(report, r, options.quiet);
          ids.push_back(r.id);
          store.add(std::move(r));
        }
        store.write(campaign);
        report.store_time_s += std::chrono::duration<double>(Clock::now() - store_start).count();
        committed += int(batch.size());
        if (options.on_case_stored)
          for (const auto& id : ids) options.on_case_stored(store.records().at(id));
        if (!options.quiet) log_progress(report, to_run, running, start);
        if (options.max_new_cases > 0 && committed >= options.max_new_cases) scheduler.cancel();  // a simulated kill
      }
    } catch (...) {
      // A file that cannot be written ends the run: the engines stop at their next check (the
      // process-wide flag, restored afterwards unless a signal asked for the stop too).
      scheduler.cancel();
      if (!stop_was_requested) request_stop();
      scheduler.join();
      if (!stop_was_requested && stop_signal() == 0) clear_stop_request();
      throw;
    }
    scheduler.join();
  }
  report.interrupted = stop_requested() && report.finished < to_run;
  if (report.interrupted && !options.quiet)
    std::cerr << "[sweep] interrupted: " << report.finished << " of " << to_run
              << " cases finished and stored; rerun the same command to complete the campaign\n";
  report.wall_time_s = std::chrono::duration<double>(Clock::now() - start).count();
  report.newton_iterations = newton_computed;
  return report;
}

}  // namespace softhom::studies
