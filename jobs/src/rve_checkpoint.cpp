#include "rve_checkpoint.hpp"

#include <chrono>
#include <cstring>
#include <set>
#include <sstream>
#include <system_error>

#include "rve_output.hpp"
#include "softhom/fft/slab.hpp"
#include "softhom/io/fields.hpp"
#include "softhom/io/files.hpp"
#include "softhom/core/input_error.hpp"

namespace softhom::jobs {

namespace fs = std::filesystem;

namespace {

constexpr int kFormat = 1;
constexpr double kCostRatio = 20.0;  // a write waits 20× its own cost: at most ≈ 5 % of the run
// Before the first write its cost is taken as 50 ms (a small cell's fsync'd HDF5 file takes 10–50 ms
// here), so the first checkpoint comes after 1 s of run: a shorter run loses little when killed.
constexpr double kFirstCostGuess = 0.05;

double now_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

fs::path record_path(const fs::path& out) { return out / "checkpoint.json"; }
fs::path state_dir(const fs::path& out) { return out / "checkpoint"; }
std::string state_file(long step, int rank) {
  return "step" + std::to_string(step) + "-rank" + std::to_string(rank) + ".h5";
}

nlohmann::json read_record(const fs::path& out) {
  std::error_code ec;
  if (!fs::exists(record_path(out), ec))
    throw InputError("--resume", out.string(), "no checkpoint of an unfinished run in this directory");
  const std::string text = io::read_input_file(record_path(out), "--resume", io::kJsonFile);
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw InputError("--resume", record_path(out).string(), std::string("not a checkpoint record (") + e.what() + ")");
  }
}

// "/load/stretch" → "load.stretch"
std::string dotted(const std::string& pointer) {
  std::string s = pointer.empty() || pointer[0] != '/' ? pointer : pointer.substr(1);
  for (char& c : s)
    if (c == '/') c = '.';
  return s;
}

std::string value_at(const nlohmann::json& j, const std::string& pointer) {
  const nlohmann::json::json_pointer p(pointer);
  return j.contains(p) ? j.at(p).dump() : std::string("absent");
}

// Complex arrays as interleaved (re, im) reals: std::complex<T> is laid out as T[2].
template <class T>
std::span<const T> interleaved(std::span<const std::complex<T>> z) {
  return {reinterpret_cast<const T*>(z.data()), 2 * z.size()};
}

std::vector<double> read_array(const fs::path& file, const std::string& name) {
  io::check_input_file(file, "--resume", io::kDataFile);
  try {
    return io::read_dataset(file, name).values;
  } catch (const std::exception& e) {
    throw InputError("--resume", file.string(), std::string("unreadable checkpoint state (") + e.what() + ")");
  }
}

}  // namespace

nlohmann::json checkpoint_fingerprint(const toml::table& scene) {
  std::ostringstream text;
  text << toml::json_formatter{scene};
  nlohmann::json j = nlohmann::json::parse(text.str());
  j.erase("output");
  j.erase("description");
  if (j.contains("solver") && j["solver"].is_object())
    for (const char* key : {"max_newton_iterations", "max_krylov_iterations", "max_fixed_point_iterations",
                            "max_cutbacks", "max_step_seconds", "max_continuation_iterations", "composite_tangent", "fftw",
                            "fftw_wisdom"})
      j["solver"].erase(key);
  return j;
}

RveCheckpoint::RveCheckpoint(fs::path out, const toml::table& scene, int rank, int ranks)
    : out_(std::move(out)), fingerprint_(checkpoint_fingerprint(scene)), rank_(rank), ranks_(ranks),
      last_cost_s_(kFirstCostGuess), last_end_s_(now_seconds()) {}

bool RveCheckpoint::exists() const {
  std::error_code ec;
  return fs::is_regular_file(record_path(out_), ec);
}

std::string RveCheckpoint::describe() const {
  const nlohmann::json r = read_record(out_);
  const auto number = [&](const char* key) { return r.is_object() && r.contains(key) && r[key].is_number() ? r[key].get<double>() : 0.0; };
  return "t = " + format_number(number("t")) + ", " + format_number(number("output_steps")) + " output steps converged";
}

void RveCheckpoint::check_resumable() const {
  const nlohmann::json r = read_record(out_);
  if (!r.is_object() || !r.contains("format") || !r["format"].is_number_integer() || !r.contains("ranks") ||
      !r["ranks"].is_number_integer() || !r.contains("scene"))
    throw InputError("--resume", record_path(out_).string(), "an incomplete checkpoint record");
  if (r.value("format", 0) != kFormat)
    throw InputError("--resume", record_path(out_).string(), "a checkpoint of another format (written by another softhom version)");
  const int ranks = r.value("ranks", 0);
  if (ranks != ranks_)
    throw InputError("--resume", out_.string(),
                     "the checkpoint was written by " + std::to_string(ranks) + " process" + (ranks == 1 ? "" : "es") +
                         " and continues on as many (this run has " + std::to_string(ranks_) +
                         "): the state is saved per slab");
  const nlohmann::json& saved = r.at("scene");
  if (saved != fingerprint_) {
    const nlohmann::json patch = nlohmann::json::diff(saved, fingerprint_);
    const std::string pointer = patch.empty() ? std::string() : patch[0].value("path", std::string());
    throw InputError("--resume", out_.string(),
                     "the scene's " + dotted(pointer) + " (" + value_at(fingerprint_, pointer) +
                         ") differs from the checkpoint's (" + value_at(saved, pointer) +
                         "): a checkpoint continues only the run that wrote it (iteration limits, "
                         "cut-backs, max_step_seconds, FFTW planning and [output] may change)");
  }
}

RveResumePoint RveCheckpoint::load(rve::FftRveSolver& solver) {
  const nlohmann::json r = read_record(out_);
  try {
    RveResumePoint point = load_state(r, solver);
    saved_t_ = point.t;  // what is on disk already
    return point;
  } catch (const nlohmann::json::exception& e) {
    throw InputError("--resume", record_path(out_).string(), std::string("an incomplete checkpoint record (") + e.what() + ")");
  }
}

RveResumePoint RveCheckpoint::load_state(const nlohmann::json& r, rve::FftRveSolver& solver) const {
  const long step = r.at("output_steps").get<long>();
  const fs::path file = state_dir(out_) / state_file(step, rank_);
  rve::FftRveState s;
  {
    const std::vector<double> macro = read_array(file, "macro");  // F̄ (9), ΔF̄ of the last step (9), its Δt
    if (macro.size() != 19) throw InputError("--resume", file.string(), "a macro record of " + std::to_string(macro.size()) + " values, not 19");
    for (int c = 0; c < 9; ++c) {
      s.F(c / 3, c % 3) = macro[c];
      s.dF_last(c / 3, c % 3) = macro[9 + c];
    }
    s.dt_last = macro[18];
  }
  auto complex_array = [&](const std::string& name) {
    const std::vector<double> v = read_array(file, name);
    std::vector<fft::Complex> z(v.size() / 2);
    for (std::size_t i = 0; i < z.size(); ++i) z[i] = {v[2 * i], v[2 * i + 1]};
    return z;
  };
  s.u = complex_array("u");
  s.du_last = complex_array("du_last");  // float in the file: exact in double, rounded back exactly
  s.history_matrix = read_array(file, "history_matrix");
  s.history_fiber = read_array(file, "history_fiber");
  s.laminate = read_array(file, "laminate");
  rve::FftRveSolver::MixedPressures p;
  for (auto [name, to] : {std::pair{"pressure", &p.committed}, std::pair{"pressure_increment", &p.increment}}) {
    const std::vector<double> v = read_array(file, name);
    to->assign(v.begin(), v.end());
  }
  try {
    solver.set_state(s);
    solver.set_mixed_pressures(std::move(p));
  } catch (const InputError& e) {
    throw InputError("--resume", file.string(), std::string("the saved state does not fit this cell (") + e.what() + ")");
  }
  RveResumePoint point;
  point.t = r.at("t").get<double>();
  point.step_log = r.at("step_log");
  point.totals = rve_counts_from_json(r.at("counts"));
  point.wall_seconds = r.value("wall_time_s", 0.0);
  point.field_steps = r.value("field_steps", 0);
  if (rank_ == 0) {
    const std::vector<double> flat = read_array(file, "response_rows");
    const std::size_t width = r.at("row_width").get<std::size_t>();
    if (width == 0 || flat.size() % width != 0 || flat.size() / width != std::size_t(step) + 1)
      throw InputError("--resume", file.string(), "response rows do not match the checkpoint record");
    for (std::size_t i = 0; i < flat.size(); i += width) point.rows.emplace_back(flat.begin() + long(i), flat.begin() + long(i + width));
  }
  return point;
}

std::string RveCheckpoint::save(const rve::FftRveSolver& solver, const fft::SlabDecomposition* slabs, double t,
                                const RveRecorder& record, const rve::RveCounts& totals, double wall_seconds,
                                int field_steps, bool force) {
  const double start = now_seconds();
  int due = force || start - last_end_s_ >= kCostRatio * last_cost_s_;
  if (slabs) due = slabs->max(rank_ == 0 ? due : 0);  // rank 0's clock decides for all
  if (!due || t == saved_t_) return {};
  const long step = long(record.step_log.size()) - 1;
  const fs::path dir = state_dir(out_);
  std::string failure;
  try {
    // Temporaries a kill -9 left: only one process can tell (their pids may be of other hosts).
    if (ranks_ == 1) io::remove_stale_temporaries(dir);
    const rve::FftRveSolver::StateView v = solver.state_view();
    std::vector<double> macro(19);
    for (int c = 0; c < 9; ++c) {
      macro[c] = v.F(c / 3, c % 3);
      macro[9 + c] = v.dF_last(c / 3, c % 3);
    }
    macro[18] = v.dt_last;
    std::vector<io::ArrayToWrite> arrays{
        {"macro", macro, {}},
        {"u", interleaved(v.u), {}},
        {"du_last", {}, interleaved(v.du_last)},
        {"history_matrix", v.history_matrix, {}},
        {"history_fiber", v.history_fiber, {}},
        {"laminate", v.laminate, {}},
        {"pressure", {}, v.pressure},
        {"pressure_increment", {}, v.pressure_increment},
    };
    if (rank_ == 0) arrays.push_back({"response_rows", record.rows.values(), {}});
    io::write_array_file(dir / state_file(step, rank_), arrays);
  } catch (const std::exception& e) {
    failure = e.what();
  }
  const int failed = slabs ? slabs->max(failure.empty() ? 0 : 1) : (failure.empty() ? 0 : 1);
  if (rank_ == 0 && !failed) {
    nlohmann::json r;
    r["format"] = kFormat;
    r["t"] = t;
    r["output_steps"] = step;
    r["ranks"] = ranks_;
    r["row_width"] = record.rows.columns().size();
    r["scene"] = fingerprint_;
    r["step_log"] = record.step_log;
    r["counts"] = rve_counts_json(totals);
    r["wall_time_s"] = wall_seconds;
    r["field_steps"] = field_steps;
    std::vector<std::string> files;
    for (int k = 0; k < ranks_; ++k) files.push_back("checkpoint/" + state_file(step, k));
    r["files"] = files;
    try {
      std::size_t bytes = 0;
      for (const std::string& f : files) {
        std::error_code ec;
        const auto size = fs::file_size(out_ / f, ec);
        if (!ec) bytes += size;
      }
      last_bytes_ = bytes;
      io::write_file_atomic(record_path(out_), r.dump(1) + "\n");
      // The older generation (and anything a killed write left) goes once the record names the new one.
      std::error_code ec;
      const std::set<std::string> keep(files.begin(), files.end());
      for (const auto& e : fs::directory_iterator(dir, ec))
        if (!keep.count("checkpoint/" + e.path().filename().string()) && !io::temporary_owner(e.path())) fs::remove(e.path(), ec);
    } catch (const std::exception& e) {
      failure = e.what();
    }
  }
  const int committed = slabs ? 1 - slabs->max(failed || !failure.empty() ? 1 : 0) : (failed || !failure.empty() ? 0 : 1);
  last_end_s_ = now_seconds();
  last_cost_s_ = last_end_s_ - start;
  ++writes_;
  write_seconds_ += last_cost_s_;
  if (!committed) return "checkpoint at t = " + format_number(t) + " not written (the previous one is kept): " +
                         (failure.empty() ? std::string("a rank could not write its state") : failure);
  saved_t_ = t;
  return {};
}

void RveCheckpoint::remove() const {
  if (rank_ != 0) return;
  std::error_code ec;
  fs::remove(record_path(out_), ec);  // first: without the record the state files are no checkpoint
  fs::remove_all(state_dir(out_), ec);
}

}  // namespace softhom::jobs
