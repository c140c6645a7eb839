// Batch evaluation of a material over many points (see batch.hpp).
#include "softhom/materials/batch.hpp"

#include <sstream>
#include <stdexcept>

#include "softhom/materials/errors.hpp"
#include "softhom/materials/library.hpp"
#include "softhom/materials/scene_keys.hpp"

namespace softhom {

MaterialBatch::MaterialBatch(MaterialPtr material) : material_(std::move(material)) {
  if (!material_) throw std::invalid_argument("MaterialBatch: null material");
  state_size_ = material_->state_size();
}

MaterialBatch MaterialBatch::from_table(const toml::table& material_table, const std::string& path) {
  return MaterialBatch(build_material(parse_material(material_table, path)));
}

MaterialBatch MaterialBatch::from_toml(const std::string& toml_text, const std::string& table) {
  toml::table doc;
  const std::string source = table.empty() ? std::string("material") : table;
  try {
    doc = toml::parse(toml_text, source);
  } catch (const toml::parse_error& e) {
    std::ostringstream s;
    s << "line " << e.source().begin.line << ", column " << e.source().begin.column;
    throw InputError(source, s.str(), std::string("TOML syntax error: ") + std::string(e.description()));
  }
  if (table.empty()) return from_table(doc, "material");
  auto node = doc.at_path(table);
  if (!node) throw InputError(table, "", "missing material table");
  const toml::table* t = node.as_table();
  if (!t) throw InputError(table, "", "must be a table");
  return from_table(*t, table);
}

std::vector<double> MaterialBatch::initial_state(std::size_t n) const {
  std::vector<double> s(n * std::size_t(state_size_), 0.0);
  for (std::size_t k = 0; k < n; ++k) material_->init_state(s.data() + k * state_size_);
  return s;
}

BatchStatus MaterialBatch::evaluate(std::size_t n, const double* F, const double* state_old, double dt, double* P,
                                    double* A, double* state_new) const {
  const Material& mat = *material_;
  const std::size_t ns = std::size_t(state_size_);
  if (ns > 0 && (!state_old || !state_new))
    throw std::invalid_argument("MaterialBatch::evaluate: the law has history; state_old and state_new are required");
  std::size_t failed = 0;
  long first = -1;
  int first_status = 0;
  // Static schedule: equal work per point (the laws have no data-dependent loops worth balancing).
#pragma omp parallel for schedule(static) reduction(+ : failed)
  for (long k = 0; k < long(n); ++k) {
    const std::size_t p = std::size_t(k);
    Mat3 Fp, Pp;
    Mat9 Ap;
    for (int c = 0; c < 9; ++c) Fp(c / 3, c % 3) = F[9 * p + c];
    const double* so = ns ? state_old + p * ns : nullptr;
    double* sn = ns ? state_new + p * ns : nullptr;
    MaterialStatus s = mat.evaluate(Fp, so, sn, dt, Pp, A ? &Ap : nullptr);
    if (s == MaterialStatus::ok && (!Pp.allFinite() || (A && !Ap.allFinite()))) s = MaterialStatus::not_finite;
    if (s != MaterialStatus::ok) {
      ++failed;
      Pp.setZero();
      Ap.setZero();
      for (std::size_t i = 0; i < ns; ++i) sn[i] = so[i];
#pragma omp critical(softhom_batch_first_failure)
      if (first < 0 || k < first) {
        first = k;
        first_status = int(s);
      }
    }
    for (int c = 0; c < 9; ++c) P[9 * p + c] = Pp(c / 3, c % 3);
    if (A)
      for (int a = 0; a < 9; ++a)
        for (int b = 0; b < 9; ++b) A[81 * p + 9 * a + b] = Ap(a, b);
  }
  BatchStatus out;
  out.failed_points = failed;
  out.first_failed_point = first;
  out.first_status = MaterialStatus(first_status);
  return out;
}

BatchStatus MaterialBatch::evaluate(const std::vector<double>& F, const std::vector<double>& state_old, double dt,
                                    std::vector<double>& P, std::vector<double>* A,
                                    std::vector<double>& state_new) const {
  if (F.size() % 9 != 0)
    throw InputError("F", std::to_string(F.size()) + " values", "not a multiple of 9 (one row-major 3×3 per point)");
  const std::size_t n = F.size() / 9;
  const std::size_t ns = n * std::size_t(state_size_);
  if (state_old.size() != ns)
    throw InputError("state_old", std::to_string(state_old.size()) + " values",
                     "this law needs " + std::to_string(state_size_) + " per point, " + std::to_string(ns) + " for " +
                         std::to_string(n) + " points");
  if (P.size() != 9 * n) P.resize(9 * n);
  if (A && A->size() != 81 * n) A->resize(81 * n);
  if (state_new.size() != ns) state_new.resize(ns);
  return evaluate(n, F.data(), state_old.data(), dt, P.data(), A ? A->data() : nullptr, state_new.data());
}

}  // namespace softhom
