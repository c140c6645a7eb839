// Tied fibers (fibers.hpp): set-up (location of every fiber node, the host nodes each fiber element
// couples), the residual and tangent scattered through the hosts' interpolation, and the per-element
// state for the outputs.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <map>

#include "softhom/core/input_error.hpp"
#include "softhom/fe/fibers.hpp"

namespace softhom::fe {
namespace {

/// Gauss points of a fiber element on s ∈ [-1, 1]: one for 2-node elements (the force is constant),
/// three for 3-node ones (exact for the element's quadratic length terms; the law's nonlinearity is
/// what the rule leaves approximate).
struct LinePoint {
  double s, w;
};
std::vector<LinePoint> line_rule(int order) {
  if (order == 1) return {{0.0, 2.0}};
  const double a = std::sqrt(0.6);
  return {{-a, 5.0 / 9.0}, {0.0, 8.0 / 9.0}, {a, 5.0 / 9.0}};
}

/// dM_i/ds of the element's nodes in its storage order (end, end, middle).
std::array<double, 3> line_derivatives(int order, double s) {
  if (order == 1) return {-0.5, 0.5, 0.0};
  return {s - 0.5, s + 0.5, -2.0 * s};
}

/// The current angle of a chord d at x from the z axis in the cylindrical frame about z, in (-90, 90]
/// deg (positive toward the hoop direction e_θ = e_z × e_r); a fiber drawn either way gives one angle.
double angle_from_axis_deg(const Vec3& x, const Vec3& d) {
  const double r = std::hypot(x[0], x[1]);
  const Vec3 e_theta = r > 0 ? Vec3(-x[1] / r, x[0] / r, 0.0) : Vec3::UnitY();
  double a = std::atan2(d.dot(e_theta), d[2]) * 180.0 / M_PI;
  if (a > 90.0) a -= 180.0;
  if (a <= -90.0) a += 180.0;
  return a;
}

}  // namespace

TiedFibers::TiedFibers(const Mesh& mesh, const FiberLines& lines, FiberOptions options,
                       const std::vector<MaterialPtr>& element_material)
    : options_(std::move(options)) {
  const std::string& f = options_.field;
  const FiberLaw& law = options_.law;
  if (!(law.area > 0.0)) throw InputError(f + ".area", format_number(law.area), "must be positive");
  if (!(law.modulus > 0.0)) throw InputError(f + ".modulus", format_number(law.modulus), "must be positive");
  if (options_.order != 1 && options_.order != 2)
    throw InputError(f + ".order", std::to_string(options_.order), "must be 1 (2-node) or 2 (3-node)");
  std::optional<HostLocator> locator;
  if (options_.tie == FiberTie::surface) {
    if (!mesh.has_surface(options_.surface))
      throw InputError(f + ".surface", "\"" + options_.surface + "\"", "no surface of that name in the mesh");
    if (options_.volume_correction)
      throw InputError(f + ".volume_correction", "true", "needs tie = \"embedded\" (a fiber on a surface displaces no host volume)");
    const auto q = mesh.surfaces.find(options_.surface);
    locator.emplace(mesh, q == mesh.surfaces.end() ? std::vector<Quad>{} : q->second, mesh.tri_surface(options_.surface));
  } else {
    locator.emplace(mesh);
  }
  if (options_.volume_correction && int(element_material.size()) != mesh.num_elements())
    throw InputError(f + ".volume_correction", "true", "the host materials are not known");
  for (int k = 0; k < int(lines.lines.size()); ++k) {
    const auto& line = lines.lines[k];
    if (line.size() < 2 || (options_.order == 2 && line.size() % 2 == 0))
      throw InputError(f, "fiber " + std::to_string(k) + " with " + std::to_string(line.size()) + " points",
                       options_.order == 2 ? "3-node elements need an odd number of points (at least 3)" : "needs at least 2 points");
    const int first = int(reference_.size());
    for (const Vec3& X : line) {
      const auto h = locator->locate(X);
      if (!h)
        throw InputError(f, "point " + point_text(X) + " of fiber " + std::to_string(k),
                         options_.tie == FiberTie::surface ? "not on surface \"" + options_.surface + "\""
                                                           : "outside every host element");
      hosts_.push_back(*h);
      reference_.push_back(h->position(mesh.nodes));
    }
    const int step = options_.order;
    for (int a = 0; a + step < int(line.size()); a += step) {
      connectivity_.insert(connectivity_.end(), {first + a, first + a + step});
      if (step == 2) connectivity_.push_back(first + a + 1);
      fiber_.push_back(k);
    }
  }
  const int m = nodes_per_element();
  for (int e = 0; e < int(fiber_.size()); ++e) {
    Element el;
    std::map<int, int> slot;
    for (int i = 0; i < m; ++i) {
      const HostPoint& h = hosts_[connectivity_[m * e + i]];
      for (int a = 0; a < h.count; ++a)
        if (slot.emplace(h.nodes[a], int(el.nodes.size())).second) el.nodes.push_back(h.nodes[a]);
    }
    el.weights.assign(el.nodes.size() * m, 0.0);
    for (int i = 0; i < m; ++i) {
      const HostPoint& h = hosts_[connectivity_[m * e + i]];
      for (int a = 0; a < h.count; ++a) el.weights[slot[h.nodes[a]] + el.nodes.size() * i] += h.weights[a];
    }
    if (options_.volume_correction) {
      const MaterialPtr& host = element_material[hosts_[connectivity_[m * e + (m == 3 ? 2 : 0)]].element];
      el.host = host.get();
      if (std::find(materials_.begin(), materials_.end(), host) == materials_.end()) materials_.push_back(host);
    }
    if (el.host && el.host->state_size() > 0) {
      el.state = state_size_;
      state_size_ += int(line_rule(options_.order).size()) * el.host->state_size();
    }
    elements_.push_back(std::move(el));
  }
  if (elements_.empty()) throw InputError(f, "no fibers", "the fiber geometry gives no fiber element");
}

void TiedFibers::validate(const Mesh& mesh) const {
  for (const Element& el : elements_)
    for (int n : el.nodes)
      if (n < 0 || n >= mesh.num_nodes()) throw InputError(options_.field, std::to_string(n), "host node out of range");
}

void TiedFibers::init_state(double* state) const {
  const int points = int(line_rule(options_.order).size());
  for (const Element& el : elements_)
    if (el.state >= 0)
      for (int q = 0; q < points; ++q) el.host->init_state(state + el.state + q * el.host->state_size());
}

void TiedFibers::declare_couplings(Couplings& couplings) const {
  for (const Element& el : elements_) couplings.add(el.nodes.data(), int(el.nodes.size()));
}

namespace {

/// One Gauss point of a fiber element: its reference and current tangents, the stretch and the force.
struct FiberPoint {
  double J0 = 0.0, length = 0.0, stretch = 1.0;
  Vec3 e = Vec3::Zero(), T = Vec3::Zero();
  FiberForce force;
};

}  // namespace

namespace {

/// Where a Gauss point's host history is read and written (the volume correction in a host with one).
struct PointHistory {
  const double* old = nullptr;
  double* next = nullptr;
  double dt = 0.0;
};

}  // namespace

/// The history of Gauss point q of an element at the iterate: its committed values, and the iterate's
/// new ones or `scratch` when it keeps none (a report). None without a host history.
static PointHistory point_history(long offset, int q, const Material* host, const Iterate& it, double dt,
                                  std::vector<double>& scratch) {
  if (offset < 0 || !it.state_old) return {};
  const int n = host->state_size();
  scratch.resize(std::size_t(n));
  return {it.state_old + offset + q * n, it.state_new ? it.state_new + offset + q * n : scratch.data(), dt};
}

/// The fiber's force at one Gauss point (the host's uniaxial stress subtracted with the correction:
/// a viscoelastic host's from its history when there is one, else its elastic response).
static MaterialStatus point_force(const FiberOptions& o, const Material* host, FiberPoint& p, const PointHistory& h) {
  p.force = fiber_force(o.law, p.stretch);
  if (!host) return MaterialStatus::ok;
  FiberForce m;
  const MaterialStatus s = h.old ? uniaxial_nominal_stress(*host, p.T, p.stretch, m, h.old, h.next, h.dt)
                                 : uniaxial_nominal_stress(*host, p.T, p.stretch, m);
  if (s != MaterialStatus::ok) return s;
  p.force.force -= o.law.area * m.force;
  p.force.stiffness -= o.law.area * m.stiffness;
  return MaterialStatus::ok;
}

MaterialStatus TiedFibers::assemble(const Mesh& mesh, const Iterate& it, AssemblySink& sink) const {
  const int m = nodes_per_element();
  const auto rule = line_rule(options_.order);
  std::vector<int> dofs;
  std::vector<double> scratch;
  Eigen::VectorXd r, g;
  Eigen::MatrixXd K;
  for (int e = 0; e < num_elements(); ++e) {
    const Element& el = elements_[e];
    const int n = int(el.nodes.size());
    std::array<Vec3, 3> X, x;
    for (int i = 0; i < m; ++i) {
      X[i] = reference_[connectivity_[m * e + i]];
      x[i].setZero();
      for (int k = 0; k < n; ++k) x[i] += el.weights[k + n * i] * it.position(mesh, el.nodes[k]);
    }
    dofs.resize(3 * n);
    for (int k = 0; k < n; ++k)
      for (int c = 0; c < 3; ++c) dofs[3 * k + c] = 3 * el.nodes[k] + c;
    r.setZero(3 * n);
    if (sink.tangent()) K.setZero(3 * n, 3 * n);
    g.resize(n);
    for (int qi = 0; qi < int(rule.size()); ++qi) {
      const LinePoint& q = rule[qi];
      const auto dM = line_derivatives(options_.order, q.s);
      FiberPoint p;
      Vec3 Xs = Vec3::Zero(), xs = Vec3::Zero();
      for (int i = 0; i < m; ++i) {
        Xs += dM[i] * X[i];
        xs += dM[i] * x[i];
      }
      p.J0 = Xs.norm();
      p.length = xs.norm();
      if (!(p.length > 0.0) || !std::isfinite(p.length)) return MaterialStatus::inverted;
      p.T = Xs / p.J0;
      p.e = xs / p.length;
      p.stretch = p.length / p.J0;
      const PointHistory h = point_history(el.state, qi, el.host, it, it.dt, scratch);
      if (const MaterialStatus s = point_force(options_, el.host, p, h); s != MaterialStatus::ok) return s;
      // g_k = Σ_i W(k, i) dM_i/ds: host node k's share of the current tangent x_s.
      for (int k = 0; k < n; ++k) {
        g[k] = 0.0;
        for (int i = 0; i < m; ++i) g[k] += el.weights[k + n * i] * dM[i];
      }
      // ∂Π/∂x_k = w N g_k e;  ∂(N e)/∂x_s = (dN/dλ / J0) e eᵀ + (N / l)(I − e eᵀ).
      const Vec3 f = q.w * p.force.force * p.e;
      for (int k = 0; k < n; ++k) r.segment<3>(3 * k) += g[k] * f;
      if (!sink.tangent()) continue;
      const Mat3 eeT = p.e * p.e.transpose();
      const Mat3 D = q.w * (p.force.stiffness / p.J0 * eeT + p.force.force / p.length * (Mat3::Identity() - eeT));
      for (int l = 0; l < n; ++l)
        for (int k = 0; k < n; ++k) K.block<3, 3>(3 * k, 3 * l) += (g[k] * g[l]) * D;
    }
    sink.add_residual(3 * n, dofs.data(), r.data());
    if (sink.tangent()) sink.add_tangent(3 * n, dofs.data(), 3 * n, dofs.data(), K.data());
  }
  return MaterialStatus::ok;
}

std::vector<Vec3> TiedFibers::current_points(const Mesh& mesh, const Iterate& it) const {
  std::vector<Vec3> x(hosts_.size(), Vec3::Zero());
  for (std::size_t p = 0; p < hosts_.size(); ++p)
    for (int a = 0; a < hosts_[p].count; ++a) x[p] += hosts_[p].weights[a] * it.position(mesh, hosts_[p].nodes[a]);
  return x;
}

std::vector<FiberElementState> TiedFibers::states(const Mesh& mesh, const Iterate& it) const {
  const std::vector<Vec3> x = current_points(mesh, it);
  const int m = nodes_per_element();
  const auto rule = line_rule(options_.order);
  std::vector<FiberElementState> out(elements_.size());
  std::vector<double> scratch;
  for (int e = 0; e < num_elements(); ++e) {
    FiberElementState& st = out[e];
    st.stretch = st.force = 0.0;
    for (int qi = 0; qi < int(rule.size()); ++qi) {
      const LinePoint& q = rule[qi];
      const auto dM = line_derivatives(options_.order, q.s);
      Vec3 Xs = Vec3::Zero(), xs = Vec3::Zero();
      for (int i = 0; i < m; ++i) {
        Xs += dM[i] * reference_[connectivity_[m * e + i]];
        xs += dM[i] * x[connectivity_[m * e + i]];
      }
      FiberPoint p;
      p.J0 = Xs.norm();
      p.T = Xs / p.J0;
      p.stretch = xs.norm() / p.J0;
      // dt = 0 from the committed history: the converged state's stress (no further relaxation).
      const PointHistory h = point_history(elements_[e].state, qi, elements_[e].host, it, 0.0, scratch);
      if (point_force(options_, elements_[e].host, p, h) != MaterialStatus::ok) p.force.force = 0.0;
      st.stretch += 0.5 * q.w * p.stretch;  // the weights sum to 2
      st.force += 0.5 * q.w * p.force.force;
    }
    const Vec3& a = x[connectivity_[m * e]];
    const Vec3& b = x[connectivity_[m * e + 1]];
    st.angle_deg = angle_from_axis_deg(0.5 * (a + b), b - a);
  }
  return out;
}

namespace {

/// The output stem of a [[fibers]] table: "fibers" for fibers[0] (or a field without index), "fibers_k".
std::string fiber_stem(const std::string& field) {
  const auto open = field.find('[');
  if (open == std::string::npos) return field;
  const std::string index = field.substr(open + 1, field.find(']') - open - 1);
  return field.substr(0, open) + (index == "0" ? "" : "_" + index);
}

}  // namespace

void TiedFibers::report(const Mesh& mesh, const Iterate& it, ContributionReport& out) const {
  const std::vector<FiberElementState> st = states(mesh, it);
  const std::vector<Vec3> x = current_points(mesh, it);
  const std::string stem = fiber_stem(options_.field);
  ReportField f;
  f.cells = {stem, options_.order == 2 ? ReportCells::Type::line3 : ReportCells::Type::line2, reference_, connectivity_};
  ReportArray stretch{"stretch", "1", 1, true, {}}, force{"force", "N", 1, true, {}}, angle{"angle", "deg", 1, true, {}};
  ReportArray displacement{"displacement", "mm", 3, false, {}};
  double max_stretch = 0.0, max_force = 0.0, mean_angle = 0.0;
  for (const FiberElementState& s : st) {
    stretch.values.push_back(s.stretch);
    force.values.push_back(s.force);
    angle.values.push_back(s.angle_deg);
    max_stretch = std::max(max_stretch, s.stretch);
    max_force = std::max(max_force, s.force);
    mean_angle += std::abs(s.angle_deg) / double(st.size());
  }
  for (std::size_t p = 0; p < x.size(); ++p)
    for (int c = 0; c < 3; ++c) displacement.values.push_back(x[p][c] - reference_[p][c]);
  f.arrays = {stretch, force, angle, displacement};
  out.fields.push_back(std::move(f));
  out.probes.emplace_back(stem + "_max_stretch", max_stretch);
  out.probes.emplace_back(stem + "_max_force [N]", max_force);
  out.probes.emplace_back(stem + "_mean_abs_angle [deg]", mean_angle);
}

}  // namespace softhom::fe
