// Campaigns over MPI ranks: rank 0 schedules and writes, every rank computes.
//
// The unit of work is a chain (sweep_internal.hpp): cases on one load path run on one solver, so a
// warm-start chain never leaves its rank. Rank 0 orders the chains longest first (voxels, or an FE
// mesh's voxel equivalent, x output steps) and hands them out one at a time to whichever job slot
// asks: its own compute threads take them directly, other ranks ask with a message (pull model, so a
// slow rank simply asks less often).
// Finished cases come back to rank 0 as bytes (encode_case_record: no memory is shared, ranks may run
// on different hosts) and rank 0 stores them exactly as the one-process runner does (CampaignStore:
// lock, atomic rewrite of campaign.h5 and cases.csv after each batch). Only the main thread of a rank
// calls MPI (MPI_THREAD_FUNNELED); compute threads talk to it through a queue.
//
// Equal numbers: a chain is computed by run_chain with the same threads per case whatever rank runs
// it, so the store equals a one-process run's (bitwise with one thread per case and the FFTW wisdom
// of DIR/fftw.wisdom, which every rank starts from). Ranks other than 0 plan with a private copy of
// the wisdom (DIR/.fftw.wisdom.tmp-PID, removed at the end): FFTW rewrites its wisdom file after
// every plan, and two processes rewriting one file can leave a half file for a third to read.
#include <mpi.h>
#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <exception>
#include <iostream>
#include <memory>
#include <mutex>
#include <numeric>
#include <thread>

#include "softhom/io/files.hpp"
#include "softhom/core/mpi.hpp"
#include "softhom/materials/interrupt.hpp"
#include "softhom/studies/campaign.hpp"
#include "softhom/studies/rve_fe_scene.hpp"
#include "sweep_internal.hpp"
#include "sweep_messages.hpp"

namespace softhom::studies {

namespace {

using namespace sweep_detail;
using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

/// The work of one output step of an FE case in voxels of an FFT case: the mesh's elements, estimated
/// from the sizes as the mesher's density (A / (0.2 h²), rve/fe_mesh.cpp) at the geometric mean of
/// mesh_size and interface_size (times the cell length over it for a 3D cell), each worth about 4
/// voxels (the helix-tube plate cell, 2 562 T6 elements, takes about 7 s for 12 steps on one thread; a
/// 32² FFT case about 1 s for 16).
double fe_case_voxels(const CampaignCase& c) {
  const FeRveSetup setup = parse_fe_rve_setup(c.scene, false);
  const double h = std::sqrt(setup.settings.mesh.mesh_size * setup.settings.mesh.interface_size);
  double elements = setup.section.L1 * setup.section.L2 / (0.2 * h * h);
  if (setup.settings.three_d) elements *= (setup.settings.mesh3d.length > 0.0 ? setup.settings.mesh3d.length : setup.section.L1) / h;
  return 4.0 * elements;
}

/// Relative cost of a chain for longest-first scheduling: voxels of its cell (FE cases: their voxel
/// equivalent) x the output steps of the members it runs (an upper bound of the steps of a shared path).
double chain_cost(const Campaign& campaign, const Chain& chain) {
  const CampaignCase& first = campaign.cases[chain.members.front()];
  double voxels = 1.0;
  if (first.engine == "fe") voxels = fe_case_voxels(first);
  else if (const toml::array* grid = first.scene.at_path("microstructure.grid").as_array())
    for (const auto& n : *grid) voxels *= double(n.value_or<std::int64_t>(1));
  std::size_t steps = 0;
  for (int k = 0; k <= chain.last; ++k) steps += campaign.cases[chain.members[k]].control.times.size();
  return voxels * double(std::max<std::size_t>(steps, 1));
}

/// FNV-1a 64 of the case ids and scene hashes in order: every rank must have expanded the same campaign.
std::uint64_t campaign_fingerprint(const Campaign& campaign) {
  std::uint64_t h = 1469598103934665603ull;
  const auto mix = [&h](const std::string& s) {
    for (unsigned char c : s) h = (h ^ c) * 1099511628211ull;
    h = (h ^ 0xff) * 1099511628211ull;
  };
  for (const auto& c : campaign.cases) {
    mix(c.id);
    mix(c.scene_hash);
  }
  return h;
}

/// The compute threads of one rank: `jobs` threads run chains from a local queue; finished cases and
/// ends of chains go to an outbox that the rank's main thread (the one that calls MPI) empties.
class LocalJobs {
 public:
  struct Event {
    bool is_record = false;
    CaseRecord record;
    int chain = -1;  // the chain that ended (is_record false)
  };

  LocalJobs(const Campaign& campaign, const fs::path& dir, const fs::path& wisdom, int jobs, int threads_per_job,
            std::atomic<long>& newton)
      : ctx_{campaign, dir, threads_per_job, [] { return stop_requested(); }, [this] { started(); },
             [this](CaseRecord&& r) { finished(std::move(r)); }, &newton, wisdom},
        jobs_(jobs),
        alive_(jobs) {
    for (int j = 0; j < jobs; ++j) threads_.emplace_back([this, threads_per_job] { work(threads_per_job); });
  }
  ~LocalJobs() {
    close(true);
    join();
  }
  LocalJobs(const LocalJobs&) = delete;
  LocalJobs& operator=(const LocalJobs&) = delete;

  /// Job slots with neither a chain running nor one queued.
  int free_slots() {
    std::lock_guard<std::mutex> lock(mu_);
    return closed_ ? 0 : jobs_ - busy_ - int(queue_.size());
  }
  void push(int index, Chain chain) {
    {
      std::lock_guard<std::mutex> lock(mu_);
      queue_.emplace_back(index, std::move(chain));
    }
    work_cv_.notify_one();
  }
  /// No more chains: the threads end once the queue is empty (`drop`: drop the queued ones first).
  void close(bool drop) {
    {
      std::lock_guard<std::mutex> lock(mu_);
      closed_ = true;
      if (drop) queue_.clear();
    }
    work_cv_.notify_all();
  }
  /// Moves the outbox to `out` (waiting at most `poll` for something); `exited`: every thread had
  /// ended before the outbox was taken, so nothing more will come.
  void collect(std::vector<Event>& out, bool& exited, std::chrono::milliseconds poll) {
    std::unique_lock<std::mutex> lock(mu_);
    if (poll.count() > 0) event_cv_.wait_for(lock, poll, [&] { return !events_.empty() || alive_ == 0; });
    exited = alive_ == 0;
    out.clear();
    while (!events_.empty()) {
      out.push_back(std::move(events_.front()));
      events_.pop_front();
    }
  }
  /// Members being computed now.
  int running() {
    std::lock_guard<std::mutex> lock(mu_);
    return running_;
  }
  void join() {
    for (auto& t : threads_)
      if (t.joinable()) t.join();
  }

 private:
  void started() {
    std::lock_guard<std::mutex> lock(mu_);
    ++running_;
  }
  void finished(CaseRecord&& r) {
    std::lock_guard<std::mutex> lock(mu_);
    --running_;
    // As in the one-process runner: on a stop the case in flight is dropped unless it finished (the
    // engine's interruption must not be stored as a failure).
    if (stop_requested() && r.status != "ok") return;
    Event e;
    e.is_record = true;
    e.record = std::move(r);
    events_.push_back(std::move(e));
    event_cv_.notify_all();
  }
  void work(int threads_per_job) {
    omp_set_num_threads(threads_per_job);
    while (true) {
      std::pair<int, Chain> job;
      {
        std::unique_lock<std::mutex> lock(mu_);
        work_cv_.wait(lock, [&] { return !queue_.empty() || closed_; });
        if (queue_.empty()) break;
        job = std::move(queue_.front());
        queue_.pop_front();
        ++busy_;
      }
      if (!stop_requested()) run_chain(ctx_, job.second.members, job.second.store, job.second.last);
      std::lock_guard<std::mutex> lock(mu_);
      --busy_;
      Event e;
      e.chain = job.first;
      events_.push_back(std::move(e));
      event_cv_.notify_all();
    }
    std::lock_guard<std::mutex> lock(mu_);
    --alive_;
    event_cv_.notify_all();
  }

  ChainContext ctx_;
  std::mutex mu_;
  std::condition_variable work_cv_, event_cv_;
  std::deque<std::pair<int, Chain>> queue_;
  std::deque<Event> events_;
  int jobs_ = 0, busy_ = 0, running_ = 0, alive_ = 0;
  bool closed_ = false;
  std::vector<std::thread> threads_;
};

// How long the main thread of a rank waits for its compute threads between two looks at the MPI
// queue: short against a case (>= 0.1 s) and long enough that polling costs nothing measurable.
constexpr std::chrono::milliseconds kPoll{2};

/// A store write that failed on rank 0, passed on once every rank has ended (not a reason to abort).
struct WriteFailed {
  std::exception_ptr error;
};

struct Threads {
  int per_job = 1, jobs = 1;
};

/// Threads per case from the requested jobs, as run_campaign does (a resumed run then computes every
/// case with the same thread count as an uninterrupted one).
Threads rank_threads(const SweepOptions& options) {
  const int total = options.threads > 0 ? options.threads : omp_get_max_threads();
  Threads t;
  t.jobs = options.jobs > 0 ? options.jobs : total;
  t.per_job = std::max(1, total / t.jobs);
  return t;
}

void send_ints(const std::vector<int>& m, int to, int tag) {
  MPI_Send(m.data(), int(m.size()), MPI_INT, to, tag, MPI_COMM_WORLD);
}

// ---------------------------------------------------------------------------------------------
// Rank 0: scheduler and writer.

/// Rank 0 during a run: the chains in the order they are handed out, what each worker holds, the
/// finished cases not yet stored, and the report.
class Writer {
 public:
  Writer(const Campaign& campaign, const SweepOptions& options, CampaignStore& store, Clock::time_point start);
  SweepReport run(const fs::path& dir);

 private:
  /// The next chain to hand out, -1 when there is none or the run stops.
  int take() {
    if (stop_requested() || write_error_ || next_ >= order_.size()) return -1;
    return order_[next_++];
  }
  void plan();
  /// Every message waiting from the workers; true if there was one.
  bool receive_messages();
  void receive(const MPI_Status& st);
  /// The cases received and finished here, added to the store and written (a failure ends the run).
  void store_incoming(LocalJobs& local);
  SweepReport finish();

  const Campaign& campaign_;
  const SweepOptions& options_;
  CampaignStore& store_;
  const Clock::time_point start_;
  const int ranks_;
  SweepReport report_;
  bool warm_ = false;
  std::vector<Chain> chains_;
  std::vector<int> order_;  // longest first
  int to_run_ = 0;
  std::atomic<long> newton_{0};
  bool stop_was_requested_ = false;  // before this run's own stop requests
  std::exception_ptr write_error_;
  std::size_t next_ = 0;                // into order_
  std::vector<int> in_flight_;          // chains handed to each worker and not ended
  std::vector<bool> worker_done_;
  int workers_done_ = 0;
  std::vector<CaseRecord> incoming_;
};

Writer::Writer(const Campaign& campaign, const SweepOptions& options, CampaignStore& store, Clock::time_point start)
    : campaign_(campaign),
      options_(options),
      store_(store),
      start_(start),
      ranks_(mpi::world_size()),
      in_flight_(ranks_, 0),
      worker_done_(ranks_, false) {}

void Writer::plan() {
  std::vector<bool> todo;
  report_ = start_report(campaign_, store_, options_.retry_failed, options_.quiet, todo);
  report_.ranks = ranks_;
  report_.cases_per_rank.assign(ranks_, 0);
  warm_ = options_.warm_start && campaign_.warm_start;
  chains_ = plan_chains(campaign_, todo, warm_);
  for (const auto& ch : chains_)
    for (bool s : ch.store) to_run_ += s ? 1 : 0;
  // Longest first: the last chains handed out are the short ones, so the ranks end together.
  std::vector<double> cost(chains_.size());
  for (std::size_t i = 0; i < chains_.size(); ++i) cost[i] = chain_cost(campaign_, chains_[i]);
  order_.resize(chains_.size());
  std::iota(order_.begin(), order_.end(), 0);
  std::stable_sort(order_.begin(), order_.end(), [&](int a, int b) { return cost[a] > cost[b]; });
}

void Writer::receive(const MPI_Status& st) {
  const int from = st.MPI_SOURCE;
  if (st.MPI_TAG == kRequest) {
    MPI_Recv(nullptr, 0, MPI_BYTE, from, kRequest, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    const int c = take();
    send_ints(c < 0 ? std::vector<int>{-1} : encode_assignment(c, chains_[c]), from, kAssign);
    if (c >= 0) ++in_flight_[from];
  } else if (st.MPI_TAG == kRecord) {
    int bytes = 0;
    MPI_Get_count(&st, MPI_BYTE, &bytes);
    std::vector<char> buffer(std::size_t(std::max(bytes, 0)));
    MPI_Recv(buffer.data(), bytes, MPI_BYTE, from, kRecord, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    if (!write_error_) {
      incoming_.push_back(decode_case_record(buffer.data(), buffer.size()));
      ++report_.cases_per_rank[from];
    }
  } else if (st.MPI_TAG == kChainDone) {
    int c = -1;
    MPI_Recv(&c, 1, MPI_INT, from, kChainDone, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    in_flight_[from] = std::max(0, in_flight_[from] - 1);
  } else if (st.MPI_TAG == kFinished) {
    long n = 0;
    MPI_Recv(&n, 1, MPI_LONG, from, kFinished, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    newton_ += n;
    in_flight_[from] = 0;
    if (!worker_done_[from]) worker_done_[from] = true, ++workers_done_;
  } else {
    throw std::runtime_error("sweep over MPI: unexpected message tag " + std::to_string(st.MPI_TAG) + " from rank " +
                             std::to_string(from));
  }
}

bool Writer::receive_messages() {
  bool received = false;
  for (int flag = 1; flag;) {
    MPI_Status st;
    MPI_Iprobe(MPI_ANY_SOURCE, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &st);
    if (!flag) break;
    received = true;
    receive(st);
  }
  return received;
}

void Writer::store_incoming(LocalJobs& local) {
  try {
    const auto t0 = Clock::now();
    for (auto& r : incoming_) {
      count_and_log(report_, r, options_.quiet);
      store_.add(std::move(r));
    }
    store_.write(campaign_);
    report_.store_time_s += std::chrono::duration<double>(Clock::now() - t0).count();
    if (!options_.quiet) {
      int running = local.running();
      for (int n : in_flight_) running += n;
      // A worker's end of chain arrives after its last case: do not count that chain as running.
      log_progress(report_, to_run_, std::min(running, to_run_ - report_.finished), start_);
    }
  } catch (...) {
    // A file that cannot be written ends the run on every rank (the workers get kStop).
    write_error_ = std::current_exception();
    if (!stop_was_requested_) request_stop();
  }
}

SweepReport Writer::run(const fs::path& dir) {
  plan();
  const Threads threads = rank_threads(options_);
  report_.threads_per_job = threads.per_job;
  if (!options_.quiet)
    std::cerr << "[sweep] " << report_.total << " cases: " << report_.skipped << " already in the store, " << to_run_
              << " to run in " << chains_.size() << " chains on " << ranks_ << " MPI ranks, " << threads.jobs
              << " job(s) x " << threads.per_job << " thread(s) each" << (warm_ ? ", warm starts on" : ", warm starts off")
              << "\n";
  if (chains_.empty()) store_.write(campaign_);  // a finished campaign: refresh cases.csv
  stop_was_requested_ = stop_requested();
  bool stop_sent = false, local_closed = false;
  std::vector<LocalJobs::Event> events;
  {
    LocalJobs local(campaign_, dir, {}, threads.jobs, threads.per_job, newton_);
    while (true) {
      const bool stopping = stop_requested() || write_error_;
      // Own job slots first: they need no message.
      while (!stopping && local.free_slots() > 0) {
        const int c = take();
        if (c < 0) break;
        local.push(c, chains_[c]);
      }
      if (!local_closed && (stopping || next_ >= order_.size())) {
        local.close(stopping);
        local_closed = true;
      }
      const bool received = receive_messages();
      if (stopping && !stop_sent) {
        for (int w = 1; w < ranks_; ++w)
          if (!worker_done_[w]) MPI_Send(nullptr, 0, MPI_BYTE, w, kStop, MPI_COMM_WORLD);
        stop_sent = true;
      }
      // Own finished cases; the last look only after every thread ended, so nothing is missed.
      const bool all_ended = workers_done_ == ranks_ - 1 && local_closed;
      bool exited = false;
      local.collect(events, exited, received || !incoming_.empty() ? std::chrono::milliseconds(0) : kPoll);
      for (auto& e : events)
        if (e.is_record && !write_error_) {
          incoming_.push_back(std::move(e.record));
          ++report_.cases_per_rank[0];
        }
      if (!incoming_.empty() && !write_error_) store_incoming(local);
      incoming_.clear();
      if (all_ended && exited && events.empty()) break;
    }
    local.join();
  }
  return finish();
}

SweepReport Writer::finish() {
  if (write_error_) {
    if (!stop_was_requested_ && stop_signal() == 0) clear_stop_request();
    throw WriteFailed{write_error_};
  }
  report_.interrupted = stop_requested() && report_.finished < to_run_;
  if (report_.interrupted && !options_.quiet)
    std::cerr << "[sweep] interrupted: " << report_.finished << " of " << to_run_
              << " cases finished and stored; rerun the same command to complete the campaign\n";
  report_.wall_time_s = std::chrono::duration<double>(Clock::now() - start_).count();
  report_.newton_iterations = newton_;
  return report_;
}

SweepReport run_writer(const Campaign& campaign, const fs::path& dir, const SweepOptions& options, CampaignStore& store,
                       Clock::time_point start) {
  return Writer(campaign, options, store, start).run(dir);
}

// ---------------------------------------------------------------------------------------------
// Ranks 1...: ask for chains, run them, send the finished cases.

SweepReport run_worker(const Campaign& campaign, const fs::path& dir, const fs::path& wisdom, const SweepOptions& options,
                       Clock::time_point start) {
  SweepReport report;
  report.total = int(campaign.cases.size());
  report.ranks = mpi::world_size();
  report.writer = false;
  const Threads threads = rank_threads(options);
  report.threads_per_job = threads.per_job;
  std::atomic<long> newton{0};
  bool no_more = false, requested = false, closed = false;
  std::vector<LocalJobs::Event> events;
  {
    LocalJobs local(campaign, dir, wisdom, threads.jobs, threads.per_job, newton);
    while (true) {
      for (int flag = 1; flag;) {
        MPI_Status st;
        MPI_Iprobe(0, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &st);
        if (!flag) break;
        if (st.MPI_TAG == kAssign) {
          int n = 0;
          MPI_Get_count(&st, MPI_INT, &n);
          std::vector<int> m(std::size_t(std::max(n, 0)));
          MPI_Recv(m.data(), n, MPI_INT, 0, kAssign, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
          requested = false;
          if (m.empty() || m[0] < 0) {
            no_more = true;
          } else if (!stop_requested()) {
            int index = -1;
            Chain chain = decode_assignment(m, index);
            local.push(index, std::move(chain));
          }
        } else if (st.MPI_TAG == kStop) {
          MPI_Recv(nullptr, 0, MPI_BYTE, 0, kStop, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
          if (!stop_requested()) request_stop();  // the engines poll the process-wide flag
          no_more = true;
        } else {
          throw std::runtime_error("sweep over MPI: unexpected message tag " + std::to_string(st.MPI_TAG) +
                                   " from rank 0");
        }
      }
      if (stop_requested()) no_more = true;
      if (!no_more && !requested && local.free_slots() > 0) {
        MPI_Send(nullptr, 0, MPI_BYTE, 0, kRequest, MPI_COMM_WORLD);
        requested = true;
      }
      // An open request is always answered: wait for it before closing, so no message is left behind.
      if (no_more && !requested && !closed) {
        local.close(stop_requested());
        closed = true;
      }
      bool exited = false;
      local.collect(events, exited, kPoll);
      for (auto& e : events) {
        if (e.is_record) {
          ++report.finished;
          if (e.record.status != "ok") ++report.failed;
          const std::vector<char> bytes = encode_case_record(e.record);
          MPI_Send(bytes.data(), int(bytes.size()), MPI_BYTE, 0, kRecord, MPI_COMM_WORLD);
        } else {
          MPI_Send(&e.chain, 1, MPI_INT, 0, kChainDone, MPI_COMM_WORLD);
        }
      }
      if (closed && exited && events.empty()) break;
    }
    local.join();
  }
  long n = newton;
  MPI_Send(&n, 1, MPI_LONG, 0, kFinished, MPI_COMM_WORLD);
  report.newton_iterations = n;
  report.interrupted = stop_requested();
  report.wall_time_s = std::chrono::duration<double>(Clock::now() - start).count();
  return report;
}

}  // namespace

SweepReport run_campaign_mpi(const Campaign& campaign, const fs::path& dir, const SweepOptions& options) {
  if (!mpi::active() || mpi::world_size() == 1) return run_campaign(campaign, dir, options);
  const auto start = Clock::now();
  const int rank = mpi::world_rank();
  check_case_ids(campaign);  // the same campaign on every rank: the same InputError on every rank

  // Rank 0 takes the directory (lock, stale temporaries, store) before anyone computes; every rank
  // learns whether it could, and that all ranks expanded the same campaign.
  std::unique_ptr<CampaignStore> store;
  std::exception_ptr setup_error;
  if (rank == 0) {
    try {
      store = std::make_unique<CampaignStore>(dir);
    } catch (...) {
      setup_error = std::current_exception();
    }
  }
  std::uint64_t header[2] = {setup_error ? 1u : 0u, campaign_fingerprint(campaign)};
  MPI_Bcast(header, 2, MPI_UINT64_T, 0, MPI_COMM_WORLD);
  // A worker's private copy of the wisdom, made before rank 0 can plan (and rewrite the file): the
  // reduction below holds rank 0 until every rank has copied.
  fs::path wisdom;
  if (rank != 0 && header[0] == 0) {
    wisdom = io::temporary_path(dir / "fftw.wisdom");
    std::error_code ec;
    if (fs::exists(dir / "fftw.wisdom", ec)) fs::copy_file(dir / "fftw.wisdom", wisdom, fs::copy_options::overwrite_existing, ec);
  }
  int mismatch = header[1] != campaign_fingerprint(campaign) ? 1 : 0;
  MPI_Allreduce(MPI_IN_PLACE, &mismatch, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  // Rank 0 says what went wrong; the others end quietly (mpirun reports rank 0's exit code).
  SweepReport quiet_end;
  quiet_end.writer = false;
  quiet_end.ranks = mpi::world_size();
  std::error_code ec;
  if (setup_error) std::rethrow_exception(setup_error);
  if (rank != 0 && (header[0] != 0 || mismatch)) {
    fs::remove(wisdom, ec);
    return quiet_end;
  }
  if (mismatch)
    throw std::runtime_error("the ranks expanded different campaigns from '" + dir.string() +
                             "'s campaign file (is the campaign file, and its base scene, the same on every host?)");
  // From here on every rank is in the exchange: a rank that cannot go on (a malformed message, memory)
  // must end the job rather than leave the others waiting for it.
  try {
    if (rank == 0) return run_writer(campaign, dir, options, *store, start);
    SweepReport report = run_worker(campaign, dir, wisdom, options, start);
    fs::remove(wisdom, ec);
    return report;
  } catch (const WriteFailed& e) {
    std::rethrow_exception(e.error);  // rank 0, after every rank ended
  } catch (const std::exception& e) {
    std::cerr << "softhom sweep: rank " << rank << ": error: " << e.what() << "\n";
    mpi::abort_all(1);
  }
}

}  // namespace softhom::studies
