// The compiled part of the Python package `softhom` (python/softhom/__init__.py is the public API).
//
// Scenes come in as Python dicts (converted key by key into the TOML table the scene parsers read, so
// every refusal names the same TOML path as on the command line), TOML text or a file. Jobs are the
// `softhom` program's (softhom/jobs/jobs.hpp: parse, then run into a sink): their rows and summary come
// back from a memory sink as arrays and JSON, with no file written unless `out` is given (then a file
// sink writes the program's files there too). While a job runs, the GIL is released and SIGINT asks
// softhom's loops to stop (materials/interrupt.hpp), which becomes KeyboardInterrupt here.
#include <omp.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <csignal>
#include <iostream>
#include <sstream>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "softhom/io/fields.hpp"
#include "softhom/io/files.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/io/summary.hpp"
#include "softhom/jobs/examples.hpp"
#include "softhom/jobs/jobs.hpp"
#include "softhom/jobs/run_control.hpp"
#include "softhom/jobs/thread_defaults.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/interrupt.hpp"
#include "softhom/materials/library.hpp"
#include "softhom/materials/scene_keys.hpp"
#include "softhom/studies/calibration.hpp"
#include "softhom/studies/campaign.hpp"
#include "softhom/studies/cell.hpp"

namespace py = pybind11;
namespace fs = std::filesystem;

namespace softhom::python {
namespace {

// ---------------------------------------------------------------------------------------------
// Python values → TOML. Errors name the TOML path the value would have in a scene file.

std::string repr_text(py::handle v) { return py::str(py::repr(v)).cast<std::string>(); }

template <class Sink>
void put_value(py::handle v, const std::string& path, Sink&& sink);

// A scene is a tree of tables: deeper than this it is no hand-written scene, and the conversion (a
// recursion) must end before the C++ stack does.
constexpr std::size_t kMaxNesting = 64;

/// For its lifetime, marks a dict or list as being converted: one met again inside itself is a cycle
/// (d['self'] = d), refused like any bad value, as is nesting deeper than kMaxNesting. (The GIL is held
/// during the conversion, so one stack serves.)
class Nesting {
 public:
  Nesting(py::handle container, const std::string& path) {
    std::vector<PyObject*>& s = open();
    const std::string field = path.empty() ? "scene" : path;
    if (std::find(s.begin(), s.end(), container.ptr()) != s.end())
      throw InputError(field, repr_text(container), "contains itself (a cycle); a scene is a tree of tables and lists");
    if (s.size() >= kMaxNesting)
      throw InputError(field, "", "nested deeper than " + std::to_string(kMaxNesting) + " tables and lists");
    s.push_back(container.ptr());
  }
  ~Nesting() { open().pop_back(); }
  Nesting(const Nesting&) = delete;
  Nesting& operator=(const Nesting&) = delete;

 private:
  static std::vector<PyObject*>& open() {
    static std::vector<PyObject*> containers;
    return containers;
  }
};

toml::table to_table(py::handle mapping, const std::string& path) {
  const Nesting nesting(mapping, path);
  toml::table t;
  for (auto item : py::reinterpret_borrow<py::object>(mapping).attr("items")()) {
    const py::tuple kv = py::reinterpret_borrow<py::tuple>(item);
    if (!py::isinstance<py::str>(kv[0]))
      throw InputError(path.empty() ? "scene" : path, repr_text(kv[0]), "a table key must be a string");
    const std::string key = kv[0].cast<std::string>();
    const std::string child = path.empty() ? key : path + "." + key;
    put_value(kv[1], child, [&](auto&& value) { t.insert_or_assign(key, std::forward<decltype(value)>(value)); });
  }
  return t;
}

toml::array to_array(py::handle sequence, const std::string& path) {
  const Nesting nesting(sequence, path);
  toml::array a;
  std::size_t i = 0;
  for (py::handle item : py::reinterpret_borrow<py::iterable>(sequence)) {
    put_value(item, path + "[" + std::to_string(i++) + "]",
              [&](auto&& value) { a.push_back(std::forward<decltype(value)>(value)); });
  }
  return a;
}

template <class Sink>
void put_value(py::handle v, const std::string& path, Sink&& sink) {
  if (v.is_none()) throw InputError(path, "None", "no value; leave the key out for its default");
  // numpy scalars and arrays: their Python equivalents (numbers, nested lists).
  if (py::hasattr(v, "tolist") && !py::isinstance<py::str>(v)) return put_value(v.attr("tolist")(), path, sink);
  if (py::isinstance<py::bool_>(v)) return sink(v.cast<bool>());
  if (py::isinstance<py::int_>(v)) return sink(v.cast<std::int64_t>());
  if (py::isinstance<py::float_>(v)) return sink(v.cast<double>());
  if (py::isinstance<py::str>(v)) return sink(v.cast<std::string>());
  if (py::hasattr(v, "items")) return sink(to_table(v, path));
  if (py::isinstance<py::list>(v) || py::isinstance<py::tuple>(v)) return sink(to_array(v, path));
  throw InputError(path, repr_text(v), "not a TOML value (use a number, string, bool, list or dict)");
}

/// A scene given as ("dict", mapping), ("toml", text) or ("file", path); `base` (may be empty) is the
/// directory relative paths in a dict or text scene are resolved against.
jobs::LoadedScene load_scene(const std::string& kind, py::handle scene, const std::string& base) {
  jobs::LoadedScene s;
  if (kind == "file") {
    s.file = scene.cast<std::string>();
    s.name = s.file.stem().string();
    s.table = io::load_scene(s.file);
    return s;
  }
  s.name = "python";
  if (!base.empty()) s.file = fs::path(base) / "python-scene.toml";
  if (kind == "toml") s.table = io::parse_scene(scene.cast<std::string>(), "<scene text>");
  else s.table = to_table(scene, "");
  return s;
}

// ---------------------------------------------------------------------------------------------
// Running a job: GIL released, SIGINT → softhom's stop flag, OpenMP threads as asked.

extern "C" void request_stop_on_signal(int signal) { request_stop(signal); }

/// Whether OpenMP was loaded before the module could ask for passive waiting (numpy, pandas or matplotlib
/// imported first: their OpenBLAS loads libgomp, which reads OMP_WAIT_POLICY once, at its loading), so
/// that its idle threads spin at every barrier; softhom/__init__.py sets it at import.
bool openmp_threads_spin = false;

/// For the lifetime of the object: SIGINT asks softhom's loops to stop (instead of Python's handler,
/// which would only be run after the job), and at most `threads` OpenMP threads (0: the defaults; one
/// thread where OpenMP threads spin, since a spinning second thread costs 2-4x on a busy machine
/// and gains at most 1.4x on an idle one: BENCHMARKS.md, "Default threads").
class JobScope {
 public:
  explicit JobScope(int threads) : threads_before_(omp_get_max_threads()) {
    clear_stop_request();
    struct sigaction action {};
    action.sa_handler = request_stop_on_signal;
    sigemptyset(&action.sa_mask);
    sigaction(SIGINT, &action, &previous_);
    if (threads > 0)
      omp_set_num_threads(threads);
    else if (openmp_threads_spin && !jobs::thread_count_given(0))
      omp_set_num_threads(1);
  }
  ~JobScope() {
    sigaction(SIGINT, &previous_, nullptr);
    omp_set_num_threads(threads_before_);
  }
  JobScope(const JobScope&) = delete;
  JobScope& operator=(const JobScope&) = delete;

 private:
  struct sigaction previous_ {};
  int threads_before_;
};

/// After a job: a SIGINT during it becomes KeyboardInterrupt (the converged rows are on disk in `out`).
void raise_if_interrupted() {
  if (!stop_requested()) return;
  const int signal = stop_signal();
  clear_stop_request();
  if (signal == SIGINT || signal == 0) {
    PyErr_SetNone(PyExc_KeyboardInterrupt);
    throw py::error_already_set();
  }
}

template <class Run>
int run_job(const std::string& out, int threads, Run&& run) {
  jobs::check_thread_count(threads, "threads");  // the bound of --threads, and of OMP_NUM_THREADS with 0
  io::mark_run_started();
  int code = 1;
  {
    JobScope scope(threads);
    py::gil_scoped_release release;
    try {
      code = run();
    } catch (...) {
      if (!out.empty()) io::remove_own_temporaries(out);
      throw;
    }
    if (!out.empty()) io::remove_own_temporaries(out);
  }
  raise_if_interrupted();
  return code;
}

/// Whether every value of column `c` is written as a plain integer in response.csv (std::to_chars'
/// shortest form without '.', 'e'): pandas reads such a column of the program's file as int64.
bool written_as_integers(const io::CsvTable& t, std::size_t c) {
  const std::size_t width = t.columns().size();
  char buf[32];
  for (std::size_t i = c; i < t.values().size(); i += width) {
    const auto r = std::to_chars(buf, buf + sizeof buf, t.values()[i]);
    if (std::find_if(buf, r.ptr, [](char ch) { return ch != '-' && (ch < '0' || ch > '9'); }) != r.ptr) return false;
  }
  return t.rows() > 0;
}

/// {"columns", "data" [rows, columns], "integer_columns", "summary" (summary.json's text)} of a run.
py::dict run_result(const jobs::MemorySink& sink) {
  py::dict r;
  std::vector<std::string> columns, integers;
  py::array_t<double> data(std::vector<py::ssize_t>{0, 0});
  if (const io::CsvTable* t = sink.table("response")) {
    columns = t->columns();
    data = py::array_t<double>(std::vector<py::ssize_t>{py::ssize_t(t->rows()), py::ssize_t(columns.size())});
    std::copy(t->values().begin(), t->values().end(), data.mutable_data());
    for (std::size_t c = 0; c < columns.size(); ++c)
      if (written_as_integers(*t, c)) integers.push_back(columns[c]);
  }
  r["columns"] = columns;
  r["data"] = data;
  r["integer_columns"] = integers;
  r["summary"] = sink.summary_text();
  return r;
}

/// Runs `job(sink)` into memory, and with `out` into the program's files there too; returns run_result.
template <class Job>
py::dict run_into_sinks(const std::string& out, int threads, Job&& job) {
  jobs::MemorySink memory;
  std::optional<jobs::FileSink> files;
  std::optional<jobs::TeeSink> both;
  if (!out.empty()) both.emplace(files.emplace(out), memory);
  jobs::Sink& sink = both ? static_cast<jobs::Sink&>(*both) : memory;
  run_job(out, threads, [&] {
    job(sink);
    return 0;
  });
  return run_result(memory);
}

jobs::RunOptions run_options(int threads, bool quiet) {
  jobs::RunOptions o;
  o.threads = threads;
  o.quiet = quiet;
  return o;
}

py::dict run_point(const std::string& kind, py::handle scene, const std::string& base, const std::string& out,
                   int threads, bool quiet) {
  jobs::LoadedScene s = load_scene(kind, scene, base);
  return run_into_sinks(out, threads, [&](jobs::Sink& sink) {
    jobs::run_point(jobs::parse_point(std::move(s)), sink, run_options(threads, quiet));
  });
}

py::dict run_rve(const std::string& kind, py::handle scene, const std::string& base, const std::string& out,
                 int threads, bool quiet, bool resume) {
  jobs::LoadedScene s = load_scene(kind, scene, base);
  return run_into_sinks(out, threads, [&](jobs::Sink& sink) {
    jobs::RveJob job = jobs::parse_rve(std::move(s), {out, resume});
    jobs::run_rve(job, sink, run_options(threads, quiet));
  });
}

py::dict run_macro(const std::string& kind, py::handle scene, const std::string& base, const std::string& out,
                   int threads, bool quiet) {
  jobs::LoadedScene s = load_scene(kind, scene, base);
  return run_into_sinks(out, threads, [&](jobs::Sink& sink) {
    jobs::MacroJob job = jobs::parse_macro(std::move(s), out);
    jobs::run_macro(job, sink, run_options(threads, quiet));
  });
}

// ---------------------------------------------------------------------------------------------
// Materials.

const toml::table& material_table(const toml::table& t) {
  // A whole `[material]` table (TOML text "[material]\npreset = ...") or its contents.
  if (t.size() == 1 && t.contains("material") && t["material"].is_table()) return *t["material"].as_table();
  return t;
}

class PyMaterial {
 public:
  explicit PyMaterial(MaterialPtr m) : m_(std::move(m)) {}
  const Material& get() const { return *m_; }

 private:
  MaterialPtr m_;
};

PyMaterial make_material(const std::string& kind, py::handle spec) {
  // A dict is the table's contents (errors at "material.G"), unless it is {"material": {...}}.
  const bool wrapped = kind == "dict" && py::len(spec) == 1 && py::reinterpret_borrow<py::object>(spec).contains("material");
  const toml::table t = kind == "dict" && !wrapped ? to_table(spec, "material") : load_scene(kind, spec, "").table;
  return PyMaterial(build_material(parse_material(material_table(t), "material")));
}

py::array_t<double> initial_state(const PyMaterial& pm, py::ssize_t n) {
  if (n < 0) throw InputError("n", std::to_string(n), "must be >= 0");
  const Material& m = pm.get();
  py::array_t<double> state({n, py::ssize_t(m.state_size())});
  double* data = state.mutable_data();
  for (py::ssize_t i = 0; i < n && m.state_size() > 0; ++i) m.init_state(data + i * m.state_size());
  return state;
}

/// P[n,3,3], A[n,9,9] (or None), state_new[n,state_size] at F[n,3,3]; a point the law refuses (locking,
/// inverted, not finite) raises softhom.EvaluationError naming it.
py::tuple evaluate(const PyMaterial& pm, py::array_t<double, py::array::c_style | py::array::forcecast> F,
                   py::object state, double dt, bool tangent) {
  const Material& m = pm.get();
  if (F.ndim() != 3 || F.shape(1) != 3 || F.shape(2) != 3)
    throw InputError("F", "shape " + repr_text(py::cast(std::vector<py::ssize_t>(F.shape(), F.shape() + F.ndim()))),
                     "must be [n, 3, 3]");
  if (!std::isfinite(dt) || dt < 0.0) throw InputError("dt", format_number(dt), "must be finite and >= 0");
  const py::ssize_t n = F.shape(0);
  const int ns = m.state_size();
  using CArray = py::array_t<double, py::array::c_style | py::array::forcecast>;
  const CArray old_state = state.is_none() ? CArray(initial_state(pm, n)) : state.cast<CArray>();
  if (old_state.ndim() != 2 || old_state.shape(0) != n || old_state.shape(1) != ns)
    throw InputError("state", "shape [" + std::to_string(old_state.ndim() > 0 ? old_state.shape(0) : 0) + ", ...]",
                     "must be [n, state_size] = [" + std::to_string(n) + ", " + std::to_string(ns) + "]");
  py::array_t<double> P({n, py::ssize_t(3), py::ssize_t(3)});
  py::array_t<double> new_state({n, py::ssize_t(ns)});
  py::array_t<double> A = tangent ? py::array_t<double>({n, py::ssize_t(9), py::ssize_t(9)}) : py::array_t<double>();
  const double* f = F.data();
  const double* so = old_state.data();
  double* p = P.mutable_data();
  double* sn = new_state.mutable_data();
  double* a = tangent ? A.mutable_data() : nullptr;
  std::vector<MaterialStatus> status(std::size_t(n), MaterialStatus::ok);
  {
    py::gil_scoped_release release;
#pragma omp parallel for schedule(static)
    for (py::ssize_t i = 0; i < n; ++i) {
      Mat3 Fi, Pi;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) Fi(r, c) = f[9 * i + 3 * r + c];
      Mat9 Ai;
      const double* old_i = ns ? so + i * ns : nullptr;
      double* new_i = ns ? sn + i * ns : nullptr;
      status[i] = m.evaluate(Fi, old_i, new_i, dt, Pi, a ? &Ai : nullptr);
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) p[9 * i + 3 * r + c] = Pi(r, c);
      if (a)
        for (int r = 0; r < 9; ++r)
          for (int c = 0; c < 9; ++c) a[81 * i + 9 * r + c] = Ai(r, c);  // row 3i+j, column 3k+l
    }
  }
  for (py::ssize_t i = 0; i < n; ++i)
    if (status[i] != MaterialStatus::ok) {
      const py::object error = py::module_::import("softhom").attr("EvaluationError");
      PyErr_SetObject(error.ptr(), py::str("F[" + std::to_string(i) + "]: " + to_string(status[i])).ptr());
      throw py::error_already_set();
    }
  return py::make_tuple(P, tangent ? py::object(A) : py::object(py::none()), new_state);
}

// ---------------------------------------------------------------------------------------------
// Campaign stores and calibration.

/// The tidy table of DIR/campaign.h5 as columns (the layout of cases.csv): {"columns": [...],
/// "data": {name: list}}; numbers as floats (NaN where a case has no value), text as str.
py::dict read_campaign(const std::string& store_path) {
  std::map<std::string, studies::CaseRecord> records;
  {
    py::gil_scoped_release release;
    records = studies::read_store(store_path);
  }
  std::vector<std::string> params, columns;
  for (const auto& [id, r] : records) {
    for (const auto& p : r.parameters)
      if (std::find(params.begin(), params.end(), p.name) == params.end()) params.push_back(p.name);
    for (const auto& c : r.columns)
      if (std::find(columns.begin(), columns.end(), c) == columns.end()) columns.push_back(c);
  }
  std::vector<std::string> case_col, status_col, error_col;
  std::vector<double> step_col;
  std::map<std::string, std::vector<py::object>> param_cols;
  std::map<std::string, std::vector<double>> data_cols;
  for (const auto& [id, r] : records) {
    const std::size_t rows = std::max<std::size_t>(1, r.rows()), ncols = r.columns.size();
    for (std::size_t i = 0; i < rows; ++i) {
      case_col.push_back(r.id);
      status_col.push_back(r.status);
      error_col.push_back(r.error);
      step_col.push_back(r.rows() ? double(i) : std::nan(""));
      for (const auto& name : params) {
        py::object v = py::float_(std::nan(""));
        for (const auto& q : r.parameters)
          if (q.name == name) v = q.is_string() ? py::object(py::str(std::get<std::string>(q.value))) : py::object(py::float_(std::get<double>(q.value)));
        param_cols[name].push_back(v);
      }
      for (const auto& c : columns) {
        const auto it = std::find(r.columns.begin(), r.columns.end(), c);
        data_cols[c].push_back(r.rows() && it != r.columns.end() ? r.data[i * ncols + std::size_t(it - r.columns.begin())]
                                                                 : std::nan(""));
      }
    }
  }
  py::dict data;
  data["case"] = case_col;
  data["status"] = status_col;
  for (const auto& name : params) data[py::str(name)] = param_cols[name];
  data["step"] = step_col;
  for (const auto& c : columns) data[py::str(c)] = py::array_t<double>(py::ssize_t(data_cols[c].size()), data_cols[c].data());
  std::vector<std::string> order{"case", "status"};
  order.insert(order.end(), params.begin(), params.end());
  order.push_back("step");
  order.insert(order.end(), columns.begin(), columns.end());
  py::dict errors;
  for (const auto& [id, r] : records)
    if (!r.error.empty()) errors[py::str(id)] = r.error;
  py::dict result;
  result["columns"] = order;
  result["parameters"] = params;
  result["data"] = data;
  result["errors"] = errors;
  return result;
}

/// Fits the calibration; returns summary.json's fields (as JSON text), material.toml and the
/// comparison table (response.csv text). With `out`, writes the files `softhom calibrate` writes
/// (no fit.png: plot from Python).
py::dict calibrate(const std::string& kind, py::handle calibration, const std::string& base, const std::string& out,
                   int threads, bool quiet) {
  jobs::LoadedScene s = load_scene(kind, calibration, base);
  const fs::path base_dir = kind == "file" ? fs::path() : fs::path(base.empty() ? "." : base);
  const jobs::CalibrationJob job = jobs::parse_calibration(std::move(s), base_dir);
  jobs::CalibrationOutcome outcome;
  jobs::MemorySink memory;
  std::optional<jobs::FileSink> files;
  if (!out.empty()) files.emplace(out);
  run_job(out, threads, [&] {
    outcome = jobs::run_calibration(job, files ? static_cast<jobs::Sink&>(*files) : memory, run_options(threads, quiet),
                                    false);
    return 0;
  });
  py::dict r;
  r["summary"] = outcome.summary.dump();
  r["material_toml"] = outcome.material_toml;
  r["comparison_csv"] = outcome.comparison_csv;
  r["success"] = outcome.result.success;
  return r;
}

// ---------------------------------------------------------------------------------------------
// One RVE cell as a constitutive law (softhom/studies/cell.hpp): F̄ in, P̄ and ∂P̄/∂F̄ out, state kept.

using Array33 = py::array_t<double, py::array::c_style | py::array::forcecast>;

Mat3 to_mat3(const Array33& a, const char* name) {
  if (a.ndim() != 2 || a.shape(0) != 3 || a.shape(1) != 3) throw InputError(name, "an array of another shape", "must be [3, 3]");
  Mat3 m;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m(r, c) = a.at(r, c);
  return m;
}

py::array_t<double> from_mat3(const Mat3& m) {
  py::array_t<double> a({py::ssize_t(3), py::ssize_t(3)});
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) a.mutable_at(r, c) = m(r, c);
  return a;
}

std::unique_ptr<studies::Cell> make_cell(const std::string& kind, py::handle scene, double tangent_tolerance) {
  studies::CellOptions o;
  o.tangent_tolerance = tangent_tolerance;
  return std::make_unique<studies::Cell>(load_scene(kind, scene, "").table, o);
}

/// {"converged", "error", "F", "P", "tangent" ([9, 9], row 3i+j = P̄_ij, column 3k+l = F̄_kl; None
/// without), iteration counts and seconds}. `stress_prescribed` ([3, 3] bools, or None): those components
/// take P̄ = P_target, the others F̄ = F. GIL released; Ctrl-C stops the solve (KeyboardInterrupt).
py::dict solve_cell(studies::Cell& cell, const Array33& F, double dt, bool tangent, py::object stress_prescribed,
                    py::object P_target) {
  const Mat3 Fm = to_mat3(F, "F");
  std::array<bool, 9> prescribed{};
  Mat3 Pm = Mat3::Zero();
  if (!stress_prescribed.is_none()) {
    const auto mask = stress_prescribed.cast<py::array_t<bool, py::array::c_style | py::array::forcecast>>();
    if (mask.ndim() != 2 || mask.shape(0) != 3 || mask.shape(1) != 3)
      throw InputError("stress_prescribed", "an array of another shape", "must be [3, 3] booleans");
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) prescribed[std::size_t(3 * r + c)] = mask.at(r, c);
  }
  if (!P_target.is_none()) Pm = to_mat3(P_target.cast<Array33>(), "P_target");
  studies::CellResult r;
  run_job("", 0, [&] {
    r = cell.solve_mixed(Fm, Pm, prescribed, dt, tangent);
    return 0;
  });
  py::dict d;
  d["converged"] = r.converged;
  d["error"] = r.error;
  d["F"] = from_mat3(r.F);
  d["P"] = from_mat3(r.P);
  if (tangent && r.converged) {
    py::array_t<double> A({py::ssize_t(9), py::ssize_t(9)});
    for (int i = 0; i < 9; ++i)
      for (int j = 0; j < 9; ++j) A.mutable_at(i, j) = r.tangent(i, j);
    d["tangent"] = A;
  } else {
    d["tangent"] = py::none();
  }
  d["newton_iterations"] = r.counts.newton_iterations;
  d["krylov_iterations"] = r.counts.krylov_iterations;
  d["cutbacks"] = r.counts.cutbacks;
  d["tangent_krylov_iterations"] = r.tangent_krylov_iterations;
  d["solve_seconds"] = r.solve_seconds;
  d["tangent_seconds"] = r.tangent_seconds;
  return d;
}

std::string default_scene(const std::string& command) {
  const std::string name = jobs::default_scene_name(command);
  const auto& scenes = jobs::embedded_scenes();
  const auto it = scenes.find(name);
  if (name.empty() || it == scenes.end()) throw InputError("command", command, "has no embedded default scene");
  return it->second;
}

}  // namespace
}  // namespace softhom::python

PYBIND11_MODULE(_softhom, m) {
  using namespace softhom;
  using namespace softhom::python;
  m.doc() = "softhom compiled core; use the package `softhom` (python/softhom/__init__.py)";
  io::silence_hdf5_errors();

  // softhom.InputError(ValueError): message "field = value: reason", attributes field and value.
  static py::exception<InputError> input_error(m, "InputError", PyExc_ValueError);
  input_error.attr("__doc__") =
      "Bad input (a ValueError): the message is \"field = value: reason\"; the attributes field (the TOML path, "
      "e.g. 'load.stretch') and value name what to change.";
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const InputError& e) {
      py::object exc = py::reinterpret_borrow<py::object>(py::handle(input_error))(e.what());
      exc.attr("field") = e.field();
      exc.attr("value") = e.value();
      PyErr_SetObject(input_error.ptr(), exc.ptr());
    } catch (const io::WriteError& e) {
      PyErr_SetString(PyExc_OSError, e.what());
    }
  });

  m.def("version", &io::softhom_version);
  m.def("_set_openmp_threads_spin", [](bool spin) { openmp_threads_spin = spin; });
  m.def("presets", &preset_names, "names of the parameter sets (docs/model.md §6)");
  m.def("default_scene", &softhom::python::default_scene, py::arg("command"), "the embedded default scene of a subcommand (TOML)");
  m.def("column_unit", [](const std::string& c) { return io::column_info(c).unit; }, py::arg("column"));
  m.def("column_description", [](const std::string& c) { return io::column_info(c).description; }, py::arg("column"));

  py::class_<PyMaterial>(m, "Material",
                         "A constitutive law with its parameters (softhom.material(spec)): evaluate(F) gives P, the "
                         "tangent dP/dF and the history for arrays of deformation gradients.")
      .def("describe", [](const PyMaterial& pm) { return pm.get().describe(); })
      .def_property_readonly("state_size", [](const PyMaterial& pm) { return pm.get().state_size(); })
      .def_property_readonly("initial_shear_modulus", [](const PyMaterial& pm) { return pm.get().initial_shear_modulus(); })
      .def_property_readonly("initial_bulk_modulus", [](const PyMaterial& pm) { return pm.get().initial_bulk_modulus(); })
      .def_property_readonly("fiber_directions",
                             [](const PyMaterial& pm) {
                               std::vector<std::array<double, 3>> d;
                               for (const Vec3& a : pm.get().fiber_directions()) d.push_back({a[0], a[1], a[2]});
                               return d;
                             })
      .def("initial_state", &softhom::python::initial_state, py::arg("n"),
           "[n, state_size] array: the undeformed, unloaded history of n points")
      .def("evaluate", &softhom::python::evaluate, py::arg("F"), py::arg("state") = py::none(), py::arg("dt") = 0.0,
           py::arg("tangent") = true,
           "(P [n, 3, 3] MPa, A [n, 9, 9] = dP/dF or None, state [n, state_size]) at deformation gradients F "
           "[n, 3, 3] after a step dt from state (None: initial_state(n)); EvaluationError names a refused point");
  m.def("make_material", &softhom::python::make_material, py::arg("kind"), py::arg("spec"));

  m.def("run_point", &softhom::python::run_point, py::arg("kind"), py::arg("scene"), py::arg("base"), py::arg("out"), py::arg("threads"),
        py::arg("quiet"));
  m.def("run_rve", &softhom::python::run_rve, py::arg("kind"), py::arg("scene"), py::arg("base"), py::arg("out"), py::arg("threads"),
        py::arg("quiet"), py::arg("resume") = false);
  m.def("run_macro", &softhom::python::run_macro, py::arg("kind"), py::arg("scene"), py::arg("base"), py::arg("out"), py::arg("threads"),
        py::arg("quiet"));
  m.def("read_campaign", &softhom::python::read_campaign, py::arg("store"));
  m.def("calibrate", &softhom::python::calibrate, py::arg("kind"), py::arg("calibration"), py::arg("base"), py::arg("out"),
        py::arg("threads"), py::arg("quiet"));
  m.def("examples_directory", [](const std::string& extra) { return jobs::examples_directory(extra).string(); },
        py::arg("extra"), "the shipped examples' directory (\"\" when none is found)");
  m.def("list_examples", [](const std::string& root) {
    std::vector<std::array<std::string, 3>> out;
    for (const auto& e : jobs::list_examples(root)) out.push_back({e.name, e.file.string(), e.description});
    return out;
  }, py::arg("root"), "(name, relative file, description) of every example under root");
  m.def("copy_example", [](const std::string& root, const std::string& name, const std::string& dir) {
    std::vector<std::string> out;
    for (const auto& p : jobs::copy_example(root, name, dir)) out.push_back(p.string());
    return out;
  }, py::arg("root"), py::arg("name"), py::arg("dir"), "copies an example (or all) into dir; the copied paths");
  m.def("to_toml", [](py::handle d) {
    std::ostringstream s;
    s << softhom::python::to_table(d, "");
    return s.str();
  }, py::arg("scene"), "a scene dict as TOML text");

  // One RVE cell (softhom/studies/cell.hpp). States are values: copy one out per quadrature point.
  py::class_<studies::CellState>(m, "CellState",
                                  "The committed state of a Cell (F̄, fluctuations, history, P̄): a value to keep per "
                                  "quadrature point and hand back with Cell.restore.")
      .def("copy", [](const studies::CellState& s) { return s; })
      .def("__copy__", [](const studies::CellState& s) { return s; })
      .def("__deepcopy__", [](const studies::CellState& s, py::dict) { return s; }, py::arg("memo"))
      .def_property_readonly("P", [](const studies::CellState& s) { return from_mat3(s.P); })
      .def_property_readonly("time", [](const studies::CellState& s) { return s.time; });
  py::class_<studies::Cell>(m, "Cell")
      .def(py::init(&softhom::python::make_cell), py::arg("kind"), py::arg("scene"), py::arg("tangent_tolerance"))
      .def("solve", &softhom::python::solve_cell, py::arg("F"), py::arg("dt") = 0.0, py::arg("tangent") = true,
           py::arg("stress_prescribed") = py::none(), py::arg("P_target") = py::none())
      .def("commit", &studies::Cell::commit)
      .def("state", &studies::Cell::state)
      .def("trial_state", &studies::Cell::trial_state)
      .def("initial_state", &studies::Cell::initial_state)
      .def("restore", &studies::Cell::restore, py::arg("state"))
      .def_property_readonly("has_history", &studies::Cell::has_history)
      .def_property_readonly("memory_bytes", &studies::Cell::memory_bytes)
      .def_property_readonly("achieved_volume_fraction", &studies::Cell::achieved_volume_fraction)
      .def("describe", &studies::Cell::describe);
}
