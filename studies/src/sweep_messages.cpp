// Byte layouts of the sweep's MPI messages: a finished case (CaseRecord) and a chain assignment. A
// record is written field by field in a fixed order: sizes as uint64, numbers as their 8 raw bytes
// (bitwise: NaN angles and every double of the response arrive unchanged), strings as size + bytes.
// Ranks of one job run the same build on the same kind of machine, so the native byte order is used.
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>

#include "sweep_messages.hpp"

namespace softhom::studies {

namespace {

class MessageWriter {
 public:
  void u64(std::uint64_t v) { raw(&v, sizeof v); }
  void f64(double v) { raw(&v, sizeof v); }
  void str(const std::string& s) {
    u64(s.size());
    raw(s.data(), s.size());
  }
  std::vector<char> bytes;

 private:
  void raw(const void* p, std::size_t n) {
    const char* c = static_cast<const char*>(p);
    bytes.insert(bytes.end(), c, c + n);
  }
};

class Reader {
 public:
  Reader(const char* data, std::size_t size) : p_(data), end_(data + size) {}
  std::uint64_t u64() {
    std::uint64_t v;
    raw(&v, sizeof v);
    return v;
  }
  double f64() {
    double v;
    raw(&v, sizeof v);
    return v;
  }
  std::string str() {
    const std::uint64_t n = count(1);
    std::string s(p_, p_ + n);
    p_ += n;
    return s;
  }
  /// A count of items of at least `item_bytes` each: refused when the rest of the buffer cannot hold them.
  std::uint64_t count(std::size_t item_bytes) {
    const std::uint64_t n = u64();
    if (n > std::uint64_t(end_ - p_) / item_bytes) fail();
    return n;
  }
  bool done() const { return p_ == end_; }
  [[noreturn]] static void fail() { throw std::runtime_error("campaign case message: truncated or malformed record"); }

 private:
  void raw(void* out, std::size_t n) {
    if (std::size_t(end_ - p_) < n) fail();
    std::memcpy(out, p_, n);
    p_ += n;
  }
  const char* p_;
  const char* end_;
};

constexpr std::uint64_t kRecordMagic = 0x31434853'4D4F4853ull;  // "SHOMSHC1": guards against a stray message

}  // namespace

std::vector<char> encode_case_record(const CaseRecord& r) {
  MessageWriter w;
  w.u64(kRecordMagic);
  w.str(r.id);
  w.u64(r.parameters.size());
  for (const auto& p : r.parameters) {
    w.str(p.name);
    w.u64(p.is_string() ? 1 : 0);
    if (p.is_string()) w.str(std::get<std::string>(p.value));
    else w.f64(std::get<double>(p.value));
  }
  w.str(r.status);
  w.str(r.error);
  w.str(r.scene_text);
  w.str(r.scene_hash);
  w.u64(r.columns.size());
  for (const auto& c : r.columns) w.str(c);
  w.u64(r.data.size());
  for (double x : r.data) w.f64(x);
  w.u64(r.stats.size());
  for (const auto& [k, v] : r.stats) {
    w.str(k);
    w.f64(v);
  }
  w.u64(r.info.size());
  for (const auto& [k, v] : r.info) {
    w.str(k);
    w.str(v);
  }
  return std::move(w.bytes);
}

CaseRecord decode_case_record(const char* data, std::size_t size) {
  Reader in(data, size);
  if (in.u64() != kRecordMagic) Reader::fail();
  CaseRecord r;
  r.id = in.str();
  for (std::uint64_t n = in.count(16), i = 0; i < n; ++i) {
    CaseParameter p;
    p.name = in.str();
    const std::uint64_t kind = in.u64();
    if (kind == 1) p.value = in.str();
    else if (kind == 0) p.value = in.f64();
    else Reader::fail();
    r.parameters.push_back(std::move(p));
  }
  r.status = in.str();
  r.error = in.str();
  r.scene_text = in.str();
  r.scene_hash = in.str();
  for (std::uint64_t n = in.count(8), i = 0; i < n; ++i) r.columns.push_back(in.str());
  const std::uint64_t values = in.count(8);
  r.data.resize(values);
  for (auto& x : r.data) x = in.f64();
  for (std::uint64_t n = in.count(16), i = 0; i < n; ++i) {
    std::string k = in.str();
    r.stats[k] = in.f64();
  }
  for (std::uint64_t n = in.count(16), i = 0; i < n; ++i) {
    std::string k = in.str();
    r.info[k] = in.str();
  }
  if (!in.done()) Reader::fail();
  if (!r.columns.empty() && r.data.size() % r.columns.size() != 0) Reader::fail();
  return r;
}

namespace sweep_detail {

std::vector<int> encode_assignment(int index, const Chain& chain) {
  std::vector<int> m{index, chain.last, int(chain.members.size())};
  m.insert(m.end(), chain.members.begin(), chain.members.end());
  for (bool s : chain.store) m.push_back(s ? 1 : 0);
  return m;
}

Chain decode_assignment(const std::vector<int>& m, int& index) {
  const auto bad = [] { return std::runtime_error("campaign chain message: malformed assignment"); };
  if (m.size() < 3) throw bad();
  index = m[0];
  Chain c;
  c.last = m[1];
  const int n = m[2];
  if (n < 1 || m.size() != 3 + 2 * std::size_t(n) || c.last < 0 || c.last >= n) throw bad();
  c.members.assign(m.begin() + 3, m.begin() + 3 + n);
  for (int k = 0; k < n; ++k) c.store.push_back(m[3 + n + k] != 0);
  return c;
}

}  // namespace sweep_detail

}  // namespace softhom::studies
