// The campaign store (HDF5, one group per case) and the tidy cases.csv.
//
// Layout of DIR/campaign.h5:
//   /                attributes: description, softhom_version, format = "softhom-campaign-1"
//   /cases/<id>      attributes: parameters (string list, in column order), one attribute per parameter
//                    (string or float64), status, error, scene (the case's TOML), scene_hash, and the
//                    run statistics (float64) and notes (strings); dataset "response" (rows x columns
//                    float64) with attribute "columns" (string list).
// The whole file is rewritten under a temporary name and renamed into place, so a kill at any moment
// leaves either the previous or the new store, never a damaged one.
#include <hdf5.h>

#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <map>
#include <cstdio>
#include <set>
#include <stdexcept>

#include "softhom/io/files.hpp"
#include "softhom/io/summary.hpp"
#include "softhom/studies/campaign.hpp"

namespace softhom::studies {
namespace {

struct H {
  hid_t id = -1;
  herr_t (*close)(hid_t) = nullptr;
  H(hid_t i, herr_t (*c)(hid_t)) : id(i), close(c) {}
  H(const H&) = delete;
  H& operator=(const H&) = delete;
  ~H() {
    if (id >= 0 && close) close(id);
  }
  operator hid_t() const { return id; }
};

hid_t check(hid_t id, const std::string& what) {
  if (id < 0) throw std::runtime_error("campaign store: " + what);
  return id;
}

hid_t vlen_string_type() {
  const hid_t t = H5Tcopy(H5T_C_S1);
  H5Tset_size(t, H5T_VARIABLE);
  H5Tset_cset(t, H5T_CSET_UTF8);
  return t;
}

void attr_strings(hid_t loc, const std::string& name, const std::vector<std::string>& values, bool scalar) {
  H type(vlen_string_type(), H5Tclose);
  const hsize_t n = values.size();
  H space(scalar ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, &n, nullptr), H5Sclose);
  H a(check(H5Acreate2(loc, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT), "attribute " + name), H5Aclose);
  std::vector<const char*> ptr;
  for (const auto& v : values) ptr.push_back(v.c_str());
  if (ptr.empty()) ptr.push_back("");
  if (H5Awrite(a, type, ptr.data()) < 0) throw std::runtime_error("campaign store: writing attribute " + name);
}

void attr_string(hid_t loc, const std::string& name, const std::string& value) { attr_strings(loc, name, {value}, true); }

void attr_double(hid_t loc, const std::string& name, double value) {
  H space(H5Screate(H5S_SCALAR), H5Sclose);
  H a(check(H5Acreate2(loc, name.c_str(), H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT), "attribute " + name), H5Aclose);
  if (H5Awrite(a, H5T_NATIVE_DOUBLE, &value) < 0) throw std::runtime_error("campaign store: writing attribute " + name);
}

struct Attr {
  bool is_string = false;
  std::vector<std::string> strings;
  double number = 0.0;
};

Attr read_attr(hid_t loc, const char* name) {
  Attr out;
  H a(check(H5Aopen(loc, name, H5P_DEFAULT), std::string("opening attribute ") + name), H5Aclose);
  H ftype(H5Aget_type(a), H5Tclose);
  H space(H5Aget_space(a), H5Sclose);
  const hssize_t n = H5Sget_simple_extent_npoints(space);
  if (H5Tget_class(ftype) == H5T_STRING) {
    out.is_string = true;
    if (H5Tis_variable_str(ftype) > 0) {
      H mtype(vlen_string_type(), H5Tclose);
      std::vector<char*> buf(std::size_t(std::max<hssize_t>(n, 1)), nullptr);
      if (H5Aread(a, mtype, buf.data()) < 0) throw std::runtime_error(std::string("campaign store: reading ") + name);
      for (hssize_t i = 0; i < n; ++i) {
        out.strings.emplace_back(buf[i] ? buf[i] : "");
        if (buf[i]) H5free_memory(buf[i]);
      }
    } else {
      const std::size_t len = H5Tget_size(ftype);
      std::vector<char> buf(len * std::size_t(n) + 1, '\0');
      H mtype(H5Tcopy(ftype), H5Tclose);
      if (H5Aread(a, mtype, buf.data()) < 0) throw std::runtime_error(std::string("campaign store: reading ") + name);
      for (hssize_t i = 0; i < n; ++i) {
        std::string s(buf.data() + i * len, len);
        s.resize(s.find('\0') == std::string::npos ? s.size() : s.find('\0'));
        out.strings.push_back(s);
      }
    }
  } else {
    if (H5Aread(a, H5T_NATIVE_DOUBLE, &out.number) < 0) throw std::runtime_error(std::string("campaign store: reading ") + name);
  }
  return out;
}

std::vector<std::string> attribute_names(hid_t loc) {
  std::vector<std::string> names;
  H5Aiterate2(
      loc, H5_INDEX_NAME, H5_ITER_INC, nullptr,
      [](hid_t, const char* name, const H5A_info_t*, void* data) -> herr_t {
        static_cast<std::vector<std::string>*>(data)->push_back(name);
        return 0;
      },
      &names);
  return names;
}

const std::set<std::string>& reserved_attributes() {
  static const std::set<std::string> r{"parameters", "status", "error", "scene", "scene_hash", "columns"};
  return r;
}

void write_case(hid_t cases, const CaseRecord& r) {
  H g(check(H5Gcreate2(cases, r.id.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), "creating group " + r.id), H5Gclose);
  std::vector<std::string> names;
  for (const auto& p : r.parameters) names.push_back(p.name);
  attr_strings(g, "parameters", names, false);
  for (const auto& p : r.parameters) {
    if (reserved_attributes().count(p.name) || r.stats.count(p.name) || r.info.count(p.name))
      throw std::runtime_error("campaign store: parameter name clashes with an attribute: " + p.name);
    if (p.is_string()) attr_string(g, p.name, std::get<std::string>(p.value));
    else attr_double(g, p.name, std::get<double>(p.value));
  }
  attr_string(g, "status", r.status);
  attr_string(g, "error", r.error);
  attr_string(g, "scene", r.scene_text);
  attr_string(g, "scene_hash", r.scene_hash);
  for (const auto& [k, v] : r.stats) attr_double(g, k, v);
  for (const auto& [k, v] : r.info) attr_string(g, k, v);
  attr_strings(g, "columns", r.columns, false);
  if (r.rows() > 0) {
    const hsize_t dims[2] = {r.rows(), r.columns.size()};
    H space(H5Screate_simple(2, dims, nullptr), H5Sclose);
    H d(check(H5Dcreate2(g, "response", H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), "dataset"), H5Dclose);
    if (H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, r.data.data()) < 0)
      throw std::runtime_error("campaign store: writing response of " + r.id);
  }
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
    const Attr& a = attrs.at(p);
    if (a.is_string) r.parameters.push_back({p, a.strings.empty() ? std::string() : a.strings.front()});
    else r.parameters.push_back({p, a.number});
  }
  r.status = str("status");
  r.error = str("error");
  r.scene_text = str("scene");
  r.scene_hash = str("scene_hash");
  if (attrs.count("columns")) r.columns = attrs["columns"].strings;
  for (const auto& [n, a] : attrs) {
    if (reserved_attributes().count(n) || param_set.count(n)) continue;
    if (a.is_string) r.info[n] = a.strings.empty() ? std::string() : a.strings.front();
    else r.stats[n] = a.number;
  }
  if (H5Lexists(g, "response", H5P_DEFAULT) > 0) {
    H d(check(H5Dopen2(g, "response", H5P_DEFAULT), "opening response of " + id), H5Dclose);
    H space(H5Dget_space(d), H5Sclose);
    hsize_t dims[2] = {0, 0};
    if (H5Sget_simple_extent_ndims(space) != 2) throw std::runtime_error("campaign store: response of " + id + " is not 2D");
    H5Sget_simple_extent_dims(space, dims, nullptr);
    if (dims[1] != r.columns.size()) throw std::runtime_error("campaign store: response of " + id + " does not match its columns");
    r.data.resize(dims[0] * dims[1]);
    if (H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, r.data.data()) < 0)
      throw std::runtime_error("campaign store: reading response of " + id);
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
  char buf[32];
  const auto res = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, res.ptr);
}

}  // namespace

std::map<std::string, CaseRecord> read_store(const std::filesystem::path& store) {
  std::map<std::string, CaseRecord> records;
  if (!std::filesystem::exists(store)) return records;
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  H f(H5Fopen(store.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (f.id < 0)
    throw std::runtime_error("campaign store " + store.string() +
                             " cannot be opened as HDF5 (not written by softhom sweep? remove it to start over)");
  if (H5Lexists(f, "cases", H5P_DEFAULT) <= 0) return records;
  H cases(check(H5Gopen2(f, "cases", H5P_DEFAULT), "opening /cases"), H5Gclose);
  std::vector<std::string> ids;
  H5Literate(
      cases, H5_INDEX_NAME, H5_ITER_INC, nullptr,
      [](hid_t, const char* name, const H5L_info_t*, void* data) -> herr_t {
        static_cast<std::vector<std::string>*>(data)->push_back(name);
        return 0;
      },
      &ids);
  for (const auto& id : ids) records[id] = read_case(cases, id);
  return records;
}

void write_store(const std::filesystem::path& store, const std::map<std::string, CaseRecord>& records,
                 const std::string& description) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const std::filesystem::path tmp = io::temporary_path(store);
  std::filesystem::create_directories(store.parent_path().empty() ? "." : store.parent_path());
  {
    H f(check(H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), "creating " + tmp.string()), H5Fclose);
    attr_string(f, "format", "softhom-campaign-1");
    attr_string(f, "description", description);
    attr_string(f, "softhom_version", io::softhom_version());
    H cases(check(H5Gcreate2(f, "cases", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), "creating /cases"), H5Gclose);
    for (const auto& [id, r] : records) write_case(cases, r);
    if (H5Fflush(f, H5F_SCOPE_GLOBAL) < 0) throw std::runtime_error("campaign store: flush failed");
  }
  // fsync before the rename so that a crash cannot leave a renamed but empty file.
  if (FILE* fp = std::fopen(tmp.c_str(), "rb")) {
    fflush(fp);
    fsync(fileno(fp));
    std::fclose(fp);
  }
  std::filesystem::rename(tmp, store);
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
        if (q.name == p) head += csv_field(q.text());
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

}  // namespace softhom::studies
