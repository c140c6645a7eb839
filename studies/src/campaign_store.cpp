// The campaign store (HDF5: an index table and one group per case), the tidy cases.csv, and the
// ownership of an output directory (the lock file, stale temporaries). The layout is described in
// softhom/studies/campaign.hpp.
//
// Every HDF5 call is checked and HDF5's own error printing is off: a failure becomes one exception
// naming the file and the reason (the innermost message of HDF5's error stack, which carries errno).
// The store is written under a temporary name, synced and renamed into place, so a kill or a failed
// write at any moment leaves the previous complete store (and no temporary, unless killed).
#include <fcntl.h>
#include <hdf5.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <map>
#include <mutex>
#include <set>
#include <stdexcept>

#include "softhom/core/input_error.hpp"
#include "softhom/io/files.hpp"
#include "softhom/io/summary.hpp"
#include "softhom/studies/campaign.hpp"

namespace softhom::studies {

std::mutex& hdf5_mutex();  // campaign.cpp: the Debian HDF5 build is not thread-safe

namespace {

namespace fs = std::filesystem;

constexpr const char* kFormat = "softhom-campaign-2";
constexpr const char* kFormatV1 = "softhom-campaign-1";

std::function<void(const fs::path&)>& write_fault() {
  static std::function<void(const fs::path&)> hook;
  return hook;
}

void quiet_hdf5() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

/// The reason of the last HDF5 failure: the system's message when HDF5 recorded an errno ("No space
/// left on device"), else the innermost description of the error stack.
std::string hdf5_reason() {
  std::vector<std::string> descs;
  H5Ewalk2(
      H5E_DEFAULT, H5E_WALK_DOWNWARD,
      [](unsigned, const H5E_error2_t* e, void* data) -> herr_t {
        if (e && e->desc && *e->desc) static_cast<std::vector<std::string>*>(data)->push_back(e->desc);
        return 0;
      },
      &descs);
  H5Eclear2(H5E_DEFAULT);
  for (auto it = descs.rbegin(); it != descs.rend(); ++it) {
    const std::string key = "error message = '";
    if (const auto p = it->find(key); p != std::string::npos) {
      const auto q = it->find('\'', p + key.size());
      if (q != std::string::npos) return it->substr(p + key.size(), q - p - key.size());
    }
  }
  return descs.empty() ? std::string("HDF5 error") : descs.back();
}

[[noreturn]] void hdf5_fail(const std::string& what) { throw std::runtime_error(what + " (" + hdf5_reason() + ")"); }

struct H {
  hid_t id = -1;
  herr_t (*close_fn)(hid_t) = nullptr;
  H(hid_t i, herr_t (*c)(hid_t)) : id(i), close_fn(c) {}
  H(const H&) = delete;
  H& operator=(const H&) = delete;
  ~H() {
    if (id >= 0 && close_fn) close_fn(id);
  }
  operator hid_t() const { return id; }
  /// Closes now and checks (closing the file is where buffered data reaches the disk).
  void close(const std::string& what) {
    const hid_t i = id;
    id = -1;
    if (close_fn(i) < 0) hdf5_fail(what);
  }
};

hid_t check(hid_t id, const std::string& what) {
  if (id < 0) hdf5_fail(what);
  return id;
}
void check_status(herr_t s, const std::string& what) {
  if (s < 0) hdf5_fail(what);
}

hid_t vlen_string_type() {
  const hid_t t = check(H5Tcopy(H5T_C_S1), "string type");
  if (H5Tset_size(t, H5T_VARIABLE) < 0 || H5Tset_cset(t, H5T_CSET_UTF8) < 0) {
    H5Tclose(t);
    hdf5_fail("string type");
  }
  return t;
}

void attr_strings(hid_t loc, const std::string& name, const std::vector<std::string>& values, bool scalar) {
  H type(vlen_string_type(), H5Tclose);
  const hsize_t n = values.size();
  H space(check(scalar ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, &n, nullptr), "dataspace"), H5Sclose);
  H a(check(H5Acreate2(loc, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT), "creating attribute " + name), H5Aclose);
  std::vector<const char*> ptr;
  for (const auto& v : values) ptr.push_back(v.c_str());
  if (ptr.empty()) ptr.push_back("");
  check_status(H5Awrite(a, type, ptr.data()), "writing attribute " + name);
}

void attr_string(hid_t loc, const std::string& name, const std::string& value) { attr_strings(loc, name, {value}, true); }

void attr_scalar(hid_t loc, const std::string& name, hid_t file_type, hid_t mem_type, const void* value) {
  H space(check(H5Screate(H5S_SCALAR), "dataspace"), H5Sclose);
  H a(check(H5Acreate2(loc, name.c_str(), file_type, space, H5P_DEFAULT, H5P_DEFAULT), "creating attribute " + name), H5Aclose);
  check_status(H5Awrite(a, mem_type, value), "writing attribute " + name);
}
void attr_double(hid_t loc, const std::string& name, double v) { attr_scalar(loc, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, &v); }
void attr_int(hid_t loc, const std::string& name, std::int64_t v) { attr_scalar(loc, name, H5T_STD_I64LE, H5T_NATIVE_INT64, &v); }

struct Attr {
  bool is_string = false;
  std::vector<std::string> strings;
  double number = 0.0;
};

Attr read_attr(hid_t loc, const char* name) {
  Attr out;
  H a(check(H5Aopen(loc, name, H5P_DEFAULT), std::string("opening attribute ") + name), H5Aclose);
  H ftype(check(H5Aget_type(a), std::string("type of attribute ") + name), H5Tclose);
  H space(check(H5Aget_space(a), std::string("dataspace of attribute ") + name), H5Sclose);
  const hssize_t n = H5Sget_simple_extent_npoints(space);
  if (n < 0) hdf5_fail(std::string("size of attribute ") + name);
  if (H5Tget_class(ftype) == H5T_STRING) {
    out.is_string = true;
    if (H5Tis_variable_str(ftype) > 0) {
      H mtype(vlen_string_type(), H5Tclose);
      std::vector<char*> buf(std::size_t(std::max<hssize_t>(n, 1)), nullptr);
      check_status(H5Aread(a, mtype, buf.data()), std::string("reading attribute ") + name);
      for (hssize_t i = 0; i < n; ++i) {
        out.strings.emplace_back(buf[i] ? buf[i] : "");
        if (buf[i]) H5free_memory(buf[i]);
      }
    } else {
      const std::size_t len = H5Tget_size(ftype);
      std::vector<char> buf(len * std::size_t(n) + 1, '\0');
      H mtype(check(H5Tcopy(ftype), "string type"), H5Tclose);
      check_status(H5Aread(a, mtype, buf.data()), std::string("reading attribute ") + name);
      for (hssize_t i = 0; i < n; ++i) {
        std::string s(buf.data() + i * len, len);
        s.resize(s.find('\0') == std::string::npos ? s.size() : s.find('\0'));
        out.strings.push_back(s);
      }
    }
  } else if (H5Tget_class(ftype) == H5T_INTEGER) {
    std::int64_t v = 0;
    check_status(H5Aread(a, H5T_NATIVE_INT64, &v), std::string("reading attribute ") + name);
    out.number = double(v);
  } else {
    check_status(H5Aread(a, H5T_NATIVE_DOUBLE, &out.number), std::string("reading attribute ") + name);
  }
  return out;
}

std::vector<std::string> attribute_names(hid_t loc) {
  std::vector<std::string> names;
  check_status(H5Aiterate2(
                   loc, H5_INDEX_NAME, H5_ITER_INC, nullptr,
                   [](hid_t, const char* name, const H5A_info_t*, void* data) -> herr_t {
                     static_cast<std::vector<std::string>*>(data)->push_back(name);
                     return 0;
                   },
                   &names),
               "listing attributes");
  return names;
}

const std::set<std::string>& reserved_attributes() {
  static const std::set<std::string> r{"parameters", "status", "error", "scene", "scene_hash", "columns"};
  return r;
}

/// Counts (steps, iterations, voxels or mesh elements and equations, threads) are stored as int64;
/// everything else as float64.
bool is_count_stat(const std::string& name) {
  static const std::set<std::string> counts{"steps",  "newton_iterations", "krylov_iterations", "cutbacks",
                                            "voxels", "elements", "equations", "threads"};
  return counts.count(name) > 0;
}

/// Whole-number parameters (the grid resolution) are int64 too.
bool is_count_parameter(const std::string& name) { return name == "resolution"; }

bool whole(double v) { return std::isfinite(v) && v == std::round(v) && std::abs(v) < 9e15; }

void write_case(hid_t cases, const CaseRecord& r) {
  if (const std::string problem = case_id_problem(r.id); !problem.empty())
    throw std::runtime_error("case id '" + r.id + "' " + problem);
  H g(check(H5Gcreate2(cases, r.id.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), "creating group " + r.id), H5Gclose);
  std::vector<std::string> names;
  for (const auto& p : r.parameters) names.push_back(p.name);
  attr_strings(g, "parameters", names, false);
  for (const auto& p : r.parameters) {
    if (reserved_attributes().count(p.name) || r.stats.count(p.name) || r.info.count(p.name))
      throw std::runtime_error("parameter name clashes with an attribute: " + p.name);
    if (p.is_string()) attr_string(g, p.name, std::get<std::string>(p.value));
    else if (is_count_parameter(p.name) && whole(std::get<double>(p.value))) attr_int(g, p.name, std::int64_t(std::get<double>(p.value)));
    else attr_double(g, p.name, std::get<double>(p.value));
  }
  attr_string(g, "status", r.status);
  attr_string(g, "error", r.error);
  attr_string(g, "scene", r.scene_text);
  attr_string(g, "scene_hash", r.scene_hash);
  for (const auto& [k, v] : r.stats) {
    if (is_count_stat(k) && whole(v)) attr_int(g, k, std::int64_t(v));
    else attr_double(g, k, v);
  }
  for (const auto& [k, v] : r.info) attr_string(g, k, v);
  // Always a dataset (0 rows for a case that failed before its first converged state), so the
  // column names have one place: the dataset's "columns" attribute.
  const hsize_t dims[2] = {r.rows(), r.columns.size()};
  H space(check(H5Screate_simple(2, dims, nullptr), "dataspace"), H5Sclose);
  H d(check(H5Dcreate2(g, "response", H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
            "creating response of " + r.id),
      H5Dclose);
  if (!r.data.empty())
    check_status(H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, r.data.data()), "writing response of " + r.id);
  attr_strings(d, "columns", r.columns, false);
}

/// A column of the index table. Row layout: fixed slots of 8 bytes (char* or double or int64), so
/// offsets are simple.
enum class IndexKind { text, number, count };
struct IndexField {
  std::string name;
  IndexKind kind;
};

/// The columns of the index table: case, status, every parameter (union in first-seen order; text
/// when any case gives a string, int64 for whole-number count parameters), rows, steps,
/// newton_iterations, error, scene_hash.
std::vector<IndexField> index_fields(const std::map<std::string, CaseRecord>& records) {
  struct Param {
    std::string name;
    bool is_string = false;
  };
  std::vector<Param> params;
  for (const auto& [id, r] : records)
    for (const auto& p : r.parameters) {
      auto it = std::find_if(params.begin(), params.end(), [&](const Param& q) { return q.name == p.name; });
      if (it == params.end()) params.push_back({p.name, p.is_string()});
      else it->is_string = it->is_string || p.is_string();
    }
  std::vector<IndexField> fields{{"case", IndexKind::text}, {"status", IndexKind::text}};
  for (const auto& p : params) {
    bool all_whole = true;
    for (const auto& [id, r] : records)
      for (const auto& q : r.parameters)
        if (q.name == p.name && (q.is_string() || !whole(std::get<double>(q.value)))) all_whole = false;
    fields.push_back({p.name, p.is_string                                ? IndexKind::text
                              : is_count_parameter(p.name) && all_whole ? IndexKind::count
                                                                        : IndexKind::number});
  }
  for (const char* c : {"rows", "steps", "newton_iterations"}) fields.push_back({c, IndexKind::count});
  fields.push_back({"error", IndexKind::text});
  fields.push_back({"scene_hash", IndexKind::text});
  for (std::size_t i = 0; i < fields.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (fields[i].name == fields[j].name) throw std::runtime_error("index column named twice: " + fields[i].name);
  return fields;
}

/// One case's row of the index table at `base`; its strings are kept alive in `keep` (reserved, so
/// the row pointers stay valid).
void fill_index_row(unsigned char* base, const CaseRecord& r, const std::vector<IndexField>& fields,
                    std::vector<std::string>& keep) {
  auto put_text = [&](std::size_t k, std::string s) {
    keep.push_back(std::move(s));
    const char* p = keep.back().c_str();
    std::memcpy(base + 8 * k, &p, 8);
  };
  auto put_number = [&](std::size_t k, double v) { std::memcpy(base + 8 * k, &v, 8); };
  auto put_count = [&](std::size_t k, std::int64_t v) { std::memcpy(base + 8 * k, &v, 8); };
  auto stat = [&](const char* n) {
    const auto it = r.stats.find(n);
    return it == r.stats.end() || !std::isfinite(it->second) ? std::int64_t(0) : std::int64_t(it->second);
  };
  for (std::size_t k = 0; k < fields.size(); ++k) {
    const IndexField& f = fields[k];
    if (f.name == "case") put_text(k, r.id);
    else if (f.name == "status") put_text(k, r.status);
    else if (f.name == "error") put_text(k, r.error);
    else if (f.name == "scene_hash") put_text(k, r.scene_hash);
    else if (f.name == "rows") put_count(k, std::int64_t(r.rows()));
    else if (f.kind == IndexKind::count && !is_count_parameter(f.name)) put_count(k, stat(f.name.c_str()));
    else {
      const auto it = std::find_if(r.parameters.begin(), r.parameters.end(), [&](const CaseParameter& p) { return p.name == f.name; });
      if (f.kind == IndexKind::text) put_text(k, it == r.parameters.end() ? std::string() : it->text());
      else if (f.kind == IndexKind::count) put_count(k, it == r.parameters.end() ? 0 : std::int64_t(std::get<double>(it->value)));
      else put_number(k, it == r.parameters.end() ? std::nan("") : std::get<double>(it->value));
    }
  }
}

/// The index table: one row per case (sorted by id), columns as index_fields() (missing parameters:
/// "" / NaN). A compound dataset: `pandas.DataFrame(h5py.File(p)["index"][()])`.
void write_index(hid_t file, const std::map<std::string, CaseRecord>& records) {
  const std::vector<IndexField> fields = index_fields(records);
  static_assert(sizeof(char*) == 8 && sizeof(double) == 8 && sizeof(std::int64_t) == 8);
  const std::size_t row_size = 8 * fields.size();
  H str(vlen_string_type(), H5Tclose);
  H mem(check(H5Tcreate(H5T_COMPOUND, row_size), "index type"), H5Tclose);
  H disk(check(H5Tcreate(H5T_COMPOUND, row_size), "index type"), H5Tclose);
  for (std::size_t k = 0; k < fields.size(); ++k) {
    const IndexField& f = fields[k];
    const hid_t mt = f.kind == IndexKind::text ? hid_t(str) : f.kind == IndexKind::number ? H5T_NATIVE_DOUBLE : H5T_NATIVE_INT64;
    const hid_t dt = f.kind == IndexKind::text ? hid_t(str) : f.kind == IndexKind::number ? H5T_IEEE_F64LE : H5T_STD_I64LE;
    check_status(H5Tinsert(mem, f.name.c_str(), 8 * k, mt), "index column " + f.name);
    check_status(H5Tinsert(disk, f.name.c_str(), 8 * k, dt), "index column " + f.name);
  }
  std::vector<unsigned char> buf(row_size * std::max<std::size_t>(records.size(), 1));
  std::vector<std::string> keep;  // owns the strings the row pointers point to
  keep.reserve(records.size() * fields.size());
  std::size_t row = 0;
  for (const auto& [id, r] : records) fill_index_row(buf.data() + row++ * row_size, r, fields, keep);
  const hsize_t n = records.size();
  H space(check(H5Screate_simple(1, &n, nullptr), "dataspace"), H5Sclose);
  H d(check(H5Dcreate2(file, "index", disk, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), "creating /index"), H5Dclose);
  if (n > 0) check_status(H5Dwrite(d, mem, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()), "writing /index");
}

/// The matrix alone has no fiber angle: NaN (stores of the first layout wrote 0).
void normalise_matrix_angle(std::vector<CaseParameter>& parameters) {
  bool matrix_only = false;
  for (const auto& p : parameters)
    if (p.name == "volume_fraction" && !p.is_string() && std::get<double>(p.value) == 0.0) matrix_only = true;
  if (!matrix_only) return;
  for (auto& p : parameters)
    if (p.name == "angle" && !p.is_string()) p.value = std::nan("");
}

CaseRecord read_case(hid_t cases, const std::string& id) {
  CaseRecord r;
  r.id = id;
  H g(check(H5Gopen2(cases, id.c_str(), H5P_DEFAULT), "opening group " + id), H5Gclose);
  const std::vector<std::string> names = attribute_names(g);
  const std::vector<std::string> params = read_attr(g, "parameters").strings;
  const std::set<std::string> param_set(params.begin(), params.end());
  std::map<std::string, Attr> attrs;
  for (const auto& n : names) attrs[n] = read_attr(g, n.c_str());
  auto str = [&](const char* n) { return attrs.count(n) && !attrs[n].strings.empty() ? attrs[n].strings.front() : std::string(); };
  for (const auto& p : params) {
    const auto it = attrs.find(p);
    if (it == attrs.end()) throw std::runtime_error("case " + id + " lists parameter " + p + " but does not have it");
    const Attr& a = it->second;
    if (a.is_string) r.parameters.push_back({p, a.strings.empty() ? std::string() : a.strings.front()});
    else r.parameters.push_back({p, a.number});
  }
  normalise_matrix_angle(r.parameters);
  r.status = str("status");
  r.error = str("error");
  r.scene_text = str("scene");
  r.scene_hash = str("scene_hash");
  if (attrs.count("columns")) r.columns = attrs["columns"].strings;  // first layout: on the group
  for (const auto& [n, a] : attrs) {
    if (reserved_attributes().count(n) || param_set.count(n)) continue;
    if (a.is_string) r.info[n] = a.strings.empty() ? std::string() : a.strings.front();
    else r.stats[n] = a.number;
  }
  const htri_t has_response = H5Lexists(g, "response", H5P_DEFAULT);
  if (has_response < 0) hdf5_fail("looking up response of " + id);
  if (has_response > 0) {
    H d(check(H5Dopen2(g, "response", H5P_DEFAULT), "opening response of " + id), H5Dclose);
    if (H5Aexists(d, "columns") > 0) r.columns = read_attr(d, "columns").strings;
    H space(check(H5Dget_space(d), "dataspace of response of " + id), H5Sclose);
    hsize_t dims[2] = {0, 0};
    if (H5Sget_simple_extent_ndims(space) != 2) throw std::runtime_error("response of " + id + " is not 2D");
    check_status(H5Sget_simple_extent_dims(space, dims, nullptr), "dimensions of response of " + id);
    if (dims[1] != r.columns.size()) throw std::runtime_error("response of " + id + " does not match its columns");
    r.data.resize(dims[0] * dims[1]);
    if (!r.data.empty())
      check_status(H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, r.data.data()), "reading response of " + id);
  }
  return r;
}

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c == '\n' ? ' ' : c);
  return q + "\"";
}

std::string shortest(double v) {
  if (std::isnan(v)) return "NaN";
  char buf[32];
  const auto res = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, res.ptr);
}

std::string parameter_csv(const CaseParameter& p) {
  return p.is_string() ? csv_field(std::get<std::string>(p.value)) : shortest(std::get<double>(p.value));
}

/// The whole store as an HDF5 file image, built in memory (core driver without backing store): HDF5
/// never writes to the disk, so a full disk or a read-only directory shows up in our own checked
/// write(2) calls, never as a half-closed HDF5 file (whose close HDF5 retries, and crashes in, at exit).
std::vector<unsigned char> store_image(const fs::path& store, const std::map<std::string, CaseRecord>& records,
                                       const std::string& description) {
  H fapl(check(H5Pcreate(H5P_FILE_ACCESS), "file access properties"), H5Pclose);
  check_status(H5Pset_fapl_core(fapl, 1 << 20, 0), "in-memory file driver");
  H f(check(H5Fcreate(store.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl), "creating the image of " + store.string()), H5Fclose);
  attr_string(f, "format", kFormat);
  attr_string(f, "description", description);
  attr_string(f, "softhom_version", io::softhom_version());
  write_index(f, records);
  {
    H cases(check(H5Gcreate2(f, "cases", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), "creating /cases"), H5Gclose);
    for (const auto& [id, r] : records) write_case(cases, r);
  }
  check_status(H5Fflush(f, H5F_SCOPE_GLOBAL), "flushing the image");
  const ssize_t size = H5Fget_file_image(f, nullptr, 0);
  if (size <= 0) hdf5_fail("size of the image");
  std::vector<unsigned char> image(static_cast<std::size_t>(size));
  if (H5Fget_file_image(f, image.data(), image.size()) != size) hdf5_fail("copying the image");
  f.close("closing the image");
  return image;
}

[[noreturn]] void sys_fail(const std::string& what, int err) { throw std::runtime_error(what + " (" + std::strerror(err) + ")"); }

/// Writes `bytes` to `tmp` (created), fsyncs and closes it, every call checked. The fault hook runs
/// half way, with the temporary open and partly written.
void write_temporary(const fs::path& tmp, const std::vector<unsigned char>& bytes) {
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) sys_fail("creating " + tmp.string(), errno);
  try {
    std::size_t done = 0;
    auto write_up_to = [&](std::size_t end) {
      while (done < end) {
        const ssize_t n = ::write(fd, bytes.data() + done, end - done);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) sys_fail("writing " + tmp.string(), errno);
        done += std::size_t(n);
      }
    };
    write_up_to(bytes.size() / 2);
    if (write_fault()) write_fault()(tmp);
    write_up_to(bytes.size());
    // fsync before the rename, so that a crash cannot leave a renamed but empty file.
    if (::fsync(fd) != 0) sys_fail("fsync of " + tmp.string(), errno);
  } catch (...) {
    ::close(fd);
    throw;
  }
  if (::close(fd) != 0) sys_fail("closing " + tmp.string(), errno);
}

void sync_directory(const fs::path& dir) {  // best effort: makes the rename durable
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
}

std::string host_name() {
  char buf[256] = {};
  if (::gethostname(buf, sizeof buf - 1) != 0) return "unknown";
  return buf;
}

std::string read_small_file(int fd) {
  std::string s;
  char buf[512];
  if (::lseek(fd, 0, SEEK_SET) < 0) return s;
  for (ssize_t n; (n = ::read(fd, buf, sizeof buf)) > 0 && s.size() < 4096;) s.append(buf, std::size_t(n));
  return s;
}

std::string lock_field(const std::string& text, const std::string& key) {
  std::size_t p = 0;
  while (p < text.size()) {
    std::size_t e = text.find('\n', p);
    if (e == std::string::npos) e = text.size();
    const std::string line = text.substr(p, e - p);
    if (line.rfind(key + "=", 0) == 0) return line.substr(key.size() + 1);
    p = e + 1;
  }
  return {};
}

struct FileStamp {
  bool exists = false;
  dev_t dev = 0;
  ino_t ino = 0;
  off_t size = 0;
  long long mtime_ns = 0;
  bool operator==(const FileStamp&) const = default;
};

FileStamp stamp_of(const fs::path& p) {
  struct stat st {};
  FileStamp s;
  if (::stat(p.c_str(), &st) != 0) return s;
  s.exists = true;
  s.dev = st.st_dev;
  s.ino = st.st_ino;
  s.size = st.st_size;
  s.mtime_ns = (long long)st.st_mtim.tv_sec * 1000000000LL + st.st_mtim.tv_nsec;
  return s;
}

}  // namespace

std::string case_id_problem(const std::string& id) {
  if (id.empty()) return "is empty";
  if (id == "." || id == "..") return "is not a name";
  for (unsigned char c : id) {
    if (c < 0x20 || c == 0x7f) return "contains a control character (byte " + std::to_string(int(c)) + ")";
    if (c == '/') return "contains '/' (the HDF5 path separator)";
  }
  return {};
}

std::string escape_control_characters(const std::string& s) {
  static const char* hex = "0123456789abcdef";
  std::string out;
  for (unsigned char c : s) {
    if (c < 0x20 || c == 0x7f) {
      out += "\\x";
      out += hex[c >> 4];
      out += hex[c & 15];
    } else {
      out += char(c);
    }
  }
  return out;
}

std::map<std::string, CaseRecord> read_store(const std::filesystem::path& store) {
  std::map<std::string, CaseRecord> records;
  if (!std::filesystem::exists(store)) return records;
  quiet_hdf5();
  const std::string where = "campaign store '" + store.string() + "'";
  H f(H5Fopen(store.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (f.id < 0)
    throw std::runtime_error(where + " cannot be opened as HDF5 (" + hdf5_reason() +
                             "; not written by softhom sweep? remove it to start over)");
  try {
    std::string format;
    if (H5Aexists(f, "format") > 0) {
      const Attr a = read_attr(f, "format");
      if (!a.strings.empty()) format = a.strings.front();
    }
    if (format != kFormat && format != kFormatV1)
      throw std::runtime_error("unknown format '" + format + "' (this softhom reads " + kFormat + " and " + kFormatV1 +
                               "; remove the store or use another --out)");
    const htri_t has_cases = H5Lexists(f, "cases", H5P_DEFAULT);
    if (has_cases < 0) hdf5_fail("looking up /cases");
    if (has_cases == 0) return records;
    H cases(check(H5Gopen2(f, "cases", H5P_DEFAULT), "opening /cases"), H5Gclose);
    std::vector<std::string> ids;
    check_status(H5Literate(
                     cases, H5_INDEX_NAME, H5_ITER_INC, nullptr,
                     [](hid_t, const char* name, const H5L_info_t*, void* data) -> herr_t {
                       static_cast<std::vector<std::string>*>(data)->push_back(name);
                       return 0;
                     },
                     &ids),
                 "listing /cases");
    for (const auto& id : ids) records[id] = read_case(cases, id);
  } catch (const std::exception& e) {
    throw std::runtime_error(where + ": " + e.what());
  }
  return records;
}

void write_store(const std::filesystem::path& store, const std::map<std::string, CaseRecord>& records,
                 const std::string& description) {
  quiet_hdf5();
  const fs::path dir = store.parent_path().empty() ? fs::path(".") : store.parent_path();
  const fs::path tmp = io::temporary_path(store);
  try {
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) throw std::runtime_error("cannot create directory '" + dir.string() + "' (" + ec.message() + ")");
    const std::vector<unsigned char> image = store_image(store, records, description);
    write_temporary(tmp, image);
    fs::rename(tmp, store, ec);
    if (ec) throw std::runtime_error("renaming " + tmp.string() + " into place (" + ec.message() + ")");
    sync_directory(dir);
  } catch (const std::exception& e) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    H5Eclear2(H5E_DEFAULT);
    throw std::runtime_error("cannot write campaign store '" + store.string() + "': " + e.what() +
                             "; the previous store is unchanged");
  }
}

std::string cases_csv(const std::vector<const CaseRecord*>& records) {
  std::vector<std::string> params;
  std::vector<std::string> columns;
  for (const CaseRecord* r : records) {
    for (const auto& p : r->parameters)
      if (std::find(params.begin(), params.end(), p.name) == params.end()) params.push_back(p.name);
    for (const auto& c : r->columns)
      if (std::find(columns.begin(), columns.end(), c) == columns.end()) columns.push_back(c);
  }
  std::string out = "case,status";
  for (const auto& p : params) {
    out += ',';
    out += csv_field(p);
  }
  out += ",step";
  for (const auto& c : columns) {
    out += ',';
    out += csv_field(c);
  }
  out += "\n";
  for (const CaseRecord* r : records) {
    std::string head = csv_field(r->id) + "," + csv_field(r->status);
    for (const auto& p : params) {
      head += ",";
      for (const auto& q : r->parameters)
        if (q.name == p) head += parameter_csv(q);
    }
    std::vector<int> col_of;
    for (const auto& c : columns) {
      const auto it = std::find(r->columns.begin(), r->columns.end(), c);
      col_of.push_back(it == r->columns.end() ? -1 : int(it - r->columns.begin()));
    }
    const std::size_t nrows = r->rows(), ncols = r->columns.size();
    if (nrows == 0) {
      out += head + ",";
      for (std::size_t k = 0; k < columns.size(); ++k) out += ",";
      out += "\n";
    }
    for (std::size_t i = 0; i < nrows; ++i) {
      out += head + "," + std::to_string(i);
      for (int j : col_of) {
        out += ",";
        if (j >= 0) out += shortest(r->data[i * ncols + std::size_t(j)]);
      }
      out += "\n";
    }
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Ownership of an output directory.

StoreBusy::StoreBusy(const std::filesystem::path& dir, const std::string& holder)
    : std::runtime_error("campaign directory '" + dir.string() + "' is in use by another softhom sweep (" + holder +
                         "); wait for it to finish or use another --out") {}

StoreLock::StoreLock(const std::filesystem::path& dir) : path_(dir / "campaign.lock") {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw std::runtime_error("cannot create campaign directory '" + dir.string() + "' (" + ec.message() + ")");
  // Not following a symbolic link planted as the lock: the sweep would then write outside --out.
  fd_ = ::open(path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK, 0644);
  if (fd_ < 0 && errno == ELOOP)
    throw InputError("--out", dir.string(), path_.string() + " is a symbolic link; the lock is a regular file the sweep creates (remove the link)");
  if (fd_ < 0) sys_fail("cannot lock campaign directory '" + dir.string() + "': cannot open " + path_.string(), errno);
  struct stat st {};
  if (::fstat(fd_, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd_);
    fd_ = -1;
    throw InputError("--out", dir.string(), path_.string() + " is not a regular file; the lock is a regular file the sweep creates (remove it)");
  }
  while (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    if (errno == EINTR) continue;
    const int err = errno;
    const std::string text = read_small_file(fd_);
    ::close(fd_);
    fd_ = -1;
    if (err == EWOULDBLOCK) {
      const std::string pid = lock_field(text, "pid"), host = lock_field(text, "host");
      throw StoreBusy(dir, "pid " + (pid.empty() ? std::string("?") : pid) + " on host " + (host.empty() ? std::string("?") : host));
    }
    sys_fail("cannot lock campaign directory '" + dir.string() + "'", err);
  }
  const std::string previous = read_small_file(fd_);
  previous_pid_ = std::atol(lock_field(previous, "pid").c_str());
  previous_host_ = lock_field(previous, "host");
  const std::string mine = "pid=" + std::to_string(::getpid()) + "\nhost=" + host_name() + "\n";
  // The holder's identity is for the message of a refused writer; failing to write it (full disk)
  // does not weaken the lock itself, which is the flock.
  if (::ftruncate(fd_, 0) == 0 && ::pwrite(fd_, mine.data(), mine.size(), 0) == ssize_t(mine.size())) ::fsync(fd_);
}

StoreLock::~StoreLock() {
  if (fd_ >= 0) ::close(fd_);  // releases the flock; the file stays (removing it would race a waiter)
}

std::vector<std::filesystem::path> remove_stale_temporaries(const std::filesystem::path& dir, const std::string& writer_host) {
  // Another host's pids cannot be checked from here.
  if (!writer_host.empty() && writer_host != host_name()) return {};
  return io::remove_stale_temporaries(dir);
}

void set_store_write_fault_for_testing(std::function<void(const std::filesystem::path&)> fault) {
  write_fault() = std::move(fault);
}

// ---------------------------------------------------------------------------------------------
// The store of one directory as its one writer holds it.

struct CampaignStore::Stamp {
  FileStamp store;
};

CampaignStore::CampaignStore(const std::filesystem::path& dir)
    : dir_(dir), lock_(dir), store_path_(dir / "campaign.h5"), csv_path_(dir / "cases.csv"), stamp_(std::make_unique<Stamp>()) {
  removed_temporaries_ = remove_stale_temporaries(dir_, lock_.previous_host());
  std::lock_guard<std::mutex> guard(hdf5_mutex());
  stamp_->store = stamp_of(store_path_);
  records_ = read_store(store_path_);
}

CampaignStore::~CampaignStore() = default;

void CampaignStore::add(CaseRecord record) {
  mine_.insert(record.id);
  records_[record.id] = std::move(record);
}

void CampaignStore::write(const Campaign& campaign) {
  std::lock_guard<std::mutex> guard(hdf5_mutex());
  // Merge with what is on disk when it changed behind our back (a writer that ignored the lock):
  // its cases stay, ours (recorded by this process) win for the ids we computed.
  if (!(stamp_of(store_path_) == stamp_->store)) {
    for (auto& [id, r] : read_store(store_path_))
      if (!mine_.count(id)) records_[id] = std::move(r);
  }
  write_store(store_path_, records_, campaign.description);
  stamp_->store = stamp_of(store_path_);
  // cases.csv: the campaign's cases in campaign order, then the store's other cases (other campaigns
  // run into the same directory) by id.
  std::vector<const CaseRecord*> ordered;
  std::set<std::string> listed;
  for (const auto& c : campaign.cases)
    if (const auto it = records_.find(c.id); it != records_.end() && listed.insert(c.id).second) ordered.push_back(&it->second);
  for (const auto& [id, r] : records_)
    if (!listed.count(id)) ordered.push_back(&r);
  io::write_file_atomic(csv_path_, cases_csv(ordered));
}

}  // namespace softhom::studies
