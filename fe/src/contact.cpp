// Contact with rigid analytic obstacles (contact.hpp): the obstacles' gap functions, the regularized
// contact law of one point, and the integration-point contribution over a surface's faces.
#include "softhom/fe/contact.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "softhom/materials/errors.hpp"

namespace softhom::fe {
namespace {

Mat3 outer(const Vec3& a, const Vec3& b) { return a * b.transpose(); }

/// Quadrature on the reference face: 3×3 Gauss on [-1, 1]² (quads), Dunavant's 7-point degree-5 rule
/// on the triangle ξ, η ≥ 0, ξ + η ≤ 1 (weights sum to its area 1/2). More points than the follower
/// pressure's rules: the integrand is only piecewise smooth across a contact patch's edge.
struct FaceRulePoint {
  double xi, eta, w;
};

std::vector<FaceRulePoint> quad_rule() {
  const double a = std::sqrt(0.6);
  const double x[3] = {-a, 0.0, a}, w[3] = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
  std::vector<FaceRulePoint> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.push_back({x[i], x[j], w[i] * w[j]});
  return r;
}

std::vector<FaceRulePoint> tri_rule() {
  const double a1 = 0.059715871789770, b1 = 0.470142064105115, a2 = 0.797426985353087, b2 = 0.101286507323456;
  const double w0 = 0.225, w1 = 0.132394152788506, w2 = 0.125939180544827;
  // (L1, L2) = (ξ, η) of each point; L0 = 1 − ξ − η.
  return {{1.0 / 3, 1.0 / 3, 0.5 * w0}, {b1, b1, 0.5 * w1}, {a1, b1, 0.5 * w1}, {b1, a1, 0.5 * w1},
          {b2, b2, 0.5 * w2},           {a2, b2, 0.5 * w2}, {b2, a2, 0.5 * w2}};
}

/// Shape functions and their ξ, η derivatives of a bilinear quad (mesh.hpp's node order).
void quad_shape(double xi, double eta, ObstacleContact::Point& p) {
  static const double s[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
  for (int k = 0; k < 4; ++k) {
    p.N[k] = 0.25 * (1 + s[k][0] * xi) * (1 + s[k][1] * eta);
    p.dN_xi[k] = 0.25 * s[k][0] * (1 + s[k][1] * eta);
    p.dN_eta[k] = 0.25 * (1 + s[k][0] * xi) * s[k][1];
  }
}

/// The same for a 6-node triangle (kTet10Faces order: corners, then mid-edges 01, 12, 20; ξ = L1, η = L2).
void tri_shape(double xi, double eta, ObstacleContact::Point& p) {
  const double L0 = 1.0 - xi - eta, L1 = xi, L2 = eta;
  p.N = {L0 * (2 * L0 - 1), L1 * (2 * L1 - 1), L2 * (2 * L2 - 1), 4 * L0 * L1, 4 * L1 * L2, 4 * L2 * L0};
  p.dN_xi = {-(4 * L0 - 1), 4 * L1 - 1, 0.0, 4 * (L0 - L1), 4 * L2, -4 * L2};
  p.dN_eta = {-(4 * L0 - 1), 0.0, 4 * L2 - 1, -4 * L1, 4 * L1, 4 * (L0 - L2)};
}

/// x_ξ × x_η of a face point in the configuration `pos(node)`.
template <class Position>
Vec3 area_density(const ObstacleContact::Point& p, const int* nodes, int nf, const Position& pos) {
  Vec3 x_xi = Vec3::Zero(), x_eta = Vec3::Zero();
  for (int a = 0; a < nf; ++a) {
    const Vec3 x = pos(nodes[a]);
    x_xi += p.dN_xi[a] * x;
    x_eta += p.dN_eta[a] * x;
  }
  return x_xi.cross(x_eta);
}

/// Point k's two states (solved with, next) into a contribution's state array.
void write_state(double* state, int k, const ObstacleContact::PointState& solved,
                 const ObstacleContact::PointState& next) {
  double* s = state + 2 * std::size_t(k) * ObstacleContact::kPointStateSize;
  for (const auto* p : {&solved, &next}) {
    for (int i = 0; i < 3; ++i) s[i] = p->stick[i];
    s[3] = p->multiplier;
    s += ObstacleContact::kPointStateSize;
  }
}

}  // namespace

std::string RigidObstacle::shape_name() const {
  switch (shape) {
    case Shape::plane: return "plane";
    case Shape::sphere: return "sphere";
    case Shape::cylinder: return "cylinder";
  }
  return "plane";
}

ObstacleGap obstacle_gap(const RigidObstacle& o, const Vec3& x, double t) {
  ObstacleGap g;
  const Vec3 c = o.point + o.translation(t);
  const Vec3 d = x - c;
  if (o.shape == RigidObstacle::Shape::plane) {
    g.normal = o.direction;
    g.gap = d.dot(g.normal);
    g.closest = x - g.gap * g.normal;
    return g;
  }
  // Sphere: the distance to the centre; cylinder: to the axis (w: d without its axial part).
  const bool cylinder = o.shape == RigidObstacle::Shape::cylinder;
  const Vec3 w = cylinder ? Vec3(d - o.direction * o.direction.dot(d)) : d;
  const double r = w.norm();
  if (!(r > 1e-300)) {  // on the centre or the axis: any normal; the penetration limit refuses it anyway
    g.normal = cylinder ? o.direction.unitOrthogonal() : Vec3::UnitZ();
    g.gap = -o.radius;
    g.closest = x + o.radius * g.normal;
    return g;
  }
  g.normal = w / r;
  g.gap = r - o.radius;
  g.closest = x - g.gap * g.normal;
  Mat3 tangential = Mat3::Identity() - outer(g.normal, g.normal);
  if (cylinder) tangential -= outer(o.direction, o.direction);
  g.dnormal = tangential / r;
  return g;
}

PointTraction contact_traction(const ObstacleGap& g, const Vec3& x, const Vec3& stick, double multiplier,
                               const ContactLaw& law) {
  PointTraction out;
  const double p = multiplier - law.penalty * g.gap;
  if (!(p > 0.0)) return out;
  const Vec3& n = g.normal;
  out.active = true;
  out.pressure = p;
  const Vec3 dp = -law.penalty * n;  // ∂p/∂x (∂g/∂x = n)
  out.traction = p * n;
  out.dtraction = outer(n, dp) + p * g.dnormal;
  if (!(law.friction > 0.0)) return out;
  // Trial stick traction −ε_T P v (v = x − stick), with d(P v) = P dx − (n·v) ∂n dx − n (∂n v)·dx.
  const Vec3 v = x - stick;
  const Mat3 P = Mat3::Identity() - outer(n, n);
  const Vec3 trial = -law.tangential_penalty * (P * v);
  const Mat3 dtrial = -law.tangential_penalty * (P - n.dot(v) * g.dnormal - outer(n, g.dnormal * v));
  const CoulombReturn c = coulomb_return(trial, law.friction, p);
  out.slip = c.slip;
  out.tangential = c.traction;
  out.traction += c.traction;
  out.dtraction += c.d_trial * dtrial + outer(c.d_pressure, dp);
  return out;
}

CoulombReturn coulomb_return(const Vec3& trial, double friction, double pressure) {
  CoulombReturn c;
  const double norm = trial.norm(), limit = friction * pressure;
  if (norm <= limit) {
    c.traction = trial;
    return c;
  }
  // Slip: on the cone, along the trial direction s; the cone's radius follows the pressure.
  const Vec3 s = trial / norm;
  c.slip = true;
  c.traction = limit * s;
  c.d_trial = (limit / norm) * (Mat3::Identity() - outer(s, s));
  c.d_pressure = friction * s;
  return c;
}

double default_contact_penalty(double shear_modulus, double face_size) { return 100.0 * shear_modulus / face_size; }

double pressure_depth_limit(double shear_modulus, double penalty, double allowance) {
  if (!(shear_modulus > 0.0)) return std::numeric_limits<double>::infinity();
  return kMaxContactPressureOverShear * shear_modulus / penalty + allowance;
}

std::vector<double> face_sizes(const Mesh& mesh, const std::vector<Quad>& quads, const std::vector<Tri6>& tris) {
  auto ref = [&](int node) { return mesh.nodes[node]; };
  auto area = [&](const int* nodes, bool quad) {
    double a = 0.0;
    for (const auto& r : quad ? quad_rule() : tri_rule()) {
      ObstacleContact::Point p;
      if (quad) quad_shape(r.xi, r.eta, p);
      else tri_shape(r.xi, r.eta, p);
      a += r.w * area_density(p, nodes, quad ? 4 : 6, ref).norm();
    }
    return a;
  };
  std::vector<double> h;
  for (const Quad& q : quads) h.push_back(std::sqrt(area(q.data(), true)));
  for (const Tri6& q : tris) h.push_back(std::sqrt(2.0 * area(q.data(), false)));
  return h;
}

double mean_face_size(const Mesh& mesh, const std::vector<Quad>& quads, const std::vector<Tri6>& tris) {
  const std::vector<double> h = face_sizes(mesh, quads, tris);
  double sum = 0.0;
  for (double v : h) sum += v;
  return h.empty() ? 0.0 : sum / double(h.size());
}

ObstacleContact::ObstacleContact(const Mesh& mesh, std::vector<Quad> quads, std::vector<Tri6> tris,
                                 RigidObstacle obstacle, Options options)
    : quads_(std::move(quads)), tris_(std::move(tris)), obstacle_(std::move(obstacle)), options_(std::move(options)) {
  if (obstacle_.direction.norm() > 0.0) obstacle_.direction.normalize();
  const int nfaces = int(quads_.size() + tris_.size());
  // validate() refuses node ids out of range; until then the geometry is left out (zero sizes, weights).
  bool nodes_ok = true;
  for (int f = 0; f < nfaces; ++f)
    for (int a = 0; a < face_nodes(f); ++a) nodes_ok = nodes_ok && face_node_ids(f)[a] >= 0 && face_node_ids(f)[a] < mesh.num_nodes();
  face_size_ = nodes_ok ? face_sizes(mesh, quads_, tris_) : std::vector<double>(nfaces, 0.0);
  for (int f = 0; f < nfaces; ++f) {
    ContactLaw law = options_.law;
    if (!(law.penalty > 0.0)) law.penalty = default_contact_penalty(options_.shear_modulus, face_size_[f]);
    if (!(law.tangential_penalty > 0.0)) law.tangential_penalty = law.penalty;
    face_law_.push_back(law);
    const bool quad = f < int(quads_.size());
    for (const auto& r : quad ? quad_rule() : tri_rule()) {
      Point p;
      p.face = f;
      if (quad) quad_shape(r.xi, r.eta, p);
      else tri_shape(r.xi, r.eta, p);
      p.rule_weight = r.w;
      points_.push_back(p);
    }
  }
  // Reference weights, and the first stick points: the closest points at t = 0.
  initial_.resize(points_.size());
  if (!nodes_ok) return;
  for (std::size_t k = 0; k < points_.size(); ++k) {
    Point& p = points_[k];
    const int* nodes = face_node_ids(p.face);
    const int nf = face_nodes(p.face);
    p.weight = p.rule_weight * area_density(p, nodes, nf, [&](int n) { return mesh.nodes[n]; }).norm();
    Vec3 X = Vec3::Zero();
    for (int a = 0; a < nf; ++a) X += p.N[a] * mesh.nodes[nodes[a]];
    initial_[k].stick = gap_at(X, 0.0).closest - obstacle_.translation(0.0);
  }
}

void ObstacleContact::init_state(double* state) const {
  for (std::size_t k = 0; k < initial_.size(); ++k)
    for (int set = 0; set < 2; ++set) {
      double* s = state + (2 * k + set) * kPointStateSize;
      for (int i = 0; i < 3; ++i) s[i] = initial_[k].stick[i];
      s[3] = initial_[k].multiplier;
    }
}

ObstacleContact::PointState ObstacleContact::read_state(const Iterate& it, int k, int set) const {
  if (!it.state_old) return initial_[k];
  const double* s = it.state_old + (2 * std::size_t(k) + set) * kPointStateSize;
  return PointState{Vec3(s[0], s[1], s[2]), s[3]};
}

double ObstacleContact::penetration_limit(int face, const Iterate& it) const {
  // Deeper than its face (or half a curved obstacle's radius, past which its normal field folds) is no
  // state Newton should linearize about; nor is a penalty pressure ε (−g) above ten times the surface's
  // shear modulus (0.1 h under the default penalty) beyond what the obstacle's own motion over the step
  // pushes in (the step's first iterate, the body where it was): a soft solid carries no such pressure,
  // and an iterate that reaches it is one whose tangent did not yet see the contact (the step that
  // first touches a curved obstacle: the whole increment of the step goes into it). Refused, the line
  // search backtracks to a shallower iterate instead of bouncing off a stiff penalty (the gripper
  // closing on a sphere: 25 iterations without convergence, then an inverted element, without it).
  const double h = face_size_[face];
  double limit = obstacle_.shape == RigidObstacle::Shape::plane ? h : std::min(h, 0.5 * obstacle_.radius);
  const double moved = (obstacle_.translation(it.t) - obstacle_.translation(it.t - it.dt)).norm();
  return std::min(limit, pressure_depth_limit(options_.shear_modulus, face_law_[face].penalty, moved));
}

void ObstacleContact::validate(const Mesh& mesh) const {
  const std::string& f = options_.field;
  if (points_.empty()) throw InputError(f + ".surface", "", "the contact surface has no faces");
  for (int face = 0; face < int(quads_.size() + tris_.size()); ++face) {
    const int* nodes = face_node_ids(face);
    for (int a = 0; a < face_nodes(face); ++a)
      if (nodes[a] < 0 || nodes[a] >= mesh.num_nodes())
        throw InputError(f + ".surface", std::to_string(nodes[a]), "node id out of range");
  }
  for (const ContactLaw& law : face_law_)
    if (!(law.penalty > 0.0 && std::isfinite(law.penalty) && law.tangential_penalty > 0.0 &&
          std::isfinite(law.tangential_penalty)))
      throw InputError(f + ".penalty", format_number(law.penalty),
                       "must be positive (or automatic, from a positive shear modulus and face size)");
  const ContactLaw& law = options_.law;
  if (!(law.friction >= 0.0 && law.friction <= kMaxContactFriction))
    throw InputError(f + ".friction", format_number(law.friction), "Coulomb coefficient must lie in [0, 3]");
  if (obstacle_.shape != RigidObstacle::Shape::sphere && !(std::abs(obstacle_.direction.norm() - 1.0) < 1e-12))
    throw InputError(f + ".normal", "", "direction must be a non-zero vector");
  if (obstacle_.shape != RigidObstacle::Shape::plane && !(obstacle_.radius > 0.0))
    throw InputError(f + ".radius", format_number(obstacle_.radius), "must be positive");
  // A body that starts inside the obstacle has no admissible reference state: refuse it, naming the
  // deepest point (a contact that starts just touching, within round-off of h, is fine).
  const std::vector<double> u(mesh.num_dofs(), 0.0);
  const Iterate at_rest{0.0, 0.0, 0.0, &u, 0.0};
  double deepest = 0.0;
  Vec3 where = Vec3::Zero();
  for (const Point& p : points_) {
    const Vec3 X = point_position(mesh, at_rest, p);
    const double depth = -gap_at(X, 0.0).gap;
    if (depth > 1e-6 * face_size_[p.face] && depth > deepest) {
      deepest = depth;
      where = X;
    }
  }
  if (deepest > 0.0)
    throw InputError(f, obstacle_.shape_name(),
                     "the obstacle overlaps the body at the start: the surface point " + point_text(where) + " lies " +
                         format_number(deepest) + " mm inside it (move the obstacle or its path's start)");
}

void ObstacleContact::declare_couplings(Couplings& couplings) const {
  for (const Quad& q : quads_) couplings.add(q.data(), 4);
  for (const Tri6& q : tris_) couplings.add(q.data(), 6);
}

ObstacleGap ObstacleContact::gap_at(const Vec3& x, double t) const {
  // The contact surface lies `offset` from the faces towards the obstacle: the gap to the obstacle grown
  // by that much (exact for the plane, the sphere and the cylinder), its closest point moved out as far.
  ObstacleGap g = obstacle_gap(obstacle_, x, t);
  g.gap -= options_.offset;
  g.closest += options_.offset * g.normal;
  return g;
}

Vec3 ObstacleContact::point_position(const Mesh& mesh, const Iterate& it, const Point& p) const {
  const int* nodes = face_node_ids(p.face);
  Vec3 x = Vec3::Zero();
  for (int a = 0; a < face_nodes(p.face); ++a) x += p.N[a] * it.position(mesh, nodes[a]);
  return x;
}

double ObstacleContact::current_weight(const Mesh& mesh, const Iterate& it, const Point& p) const {
  return p.rule_weight *
         area_density(p, face_node_ids(p.face), face_nodes(p.face), [&](int n) { return it.position(mesh, n); }).norm();
}

PointTraction ObstacleContact::point_traction(const Mesh& mesh, const Iterate& it, int k, const PointState& s,
                                              ObstacleGap& g) const {
  const Vec3 x = point_position(mesh, it, points_[k]);
  g = gap_at(x, it.t);
  const Vec3 stick = s.stick + obstacle_.translation(it.t);
  return contact_traction(g, x, stick, options_.augmented ? s.multiplier : 0.0, face_law_[points_[k].face]);
}

ObstacleContact::PointState ObstacleContact::advanced_state(const Iterate& it, int k, const PointState& s,
                                                            const PointTraction& pt, const ObstacleGap& g) const {
  PointState next = s;
  next.multiplier = options_.augmented ? pt.pressure : 0.0;
  // A sticking point keeps its stick point; a slipping one moves it so that the trial traction of the
  // converged state is the returned one (−ε_T P(x − stick) = t_T); a free one takes its closest point.
  if (pt.active && !pt.slip && options_.law.friction > 0.0) return next;
  const double eps_t = face_law_[points_[k].face].tangential_penalty;
  const Vec3 world = pt.slip ? Vec3(g.closest + pt.tangential / eps_t) : g.closest;
  next.stick = world - obstacle_.translation(it.t);
  return next;
}

MaterialStatus ObstacleContact::assemble(const Mesh& mesh, const Iterate& it, AssemblySink& sink) const {
  // A point beyond penetration_limit is refused: the line search backtracks or the step is cut back.
  Eigen::Matrix<double, 18, 1> r;
  Eigen::Matrix<double, 18, 18> K;
  std::array<int, 18> dofs;
  for (std::size_t k0 = 0; k0 < points_.size();) {
    const int face = points_[k0].face, nf = face_nodes(face);
    const int* nodes = face_node_ids(face);
    r.setZero();
    K.setZero();
    bool any = false;
    std::size_t k = k0;
    for (; k < points_.size() && points_[k].face == face; ++k) {
      ObstacleGap g;
      const PointState s = solving_state(it, int(k));
      const PointTraction pt = point_traction(mesh, it, int(k), s, g);
      if (-g.gap > penetration_limit(face, it)) return MaterialStatus::penetration;
      if (it.state_new) write_state(it.state_new, int(k), s, advanced_state(it, int(k), s, pt, g));
      if (!pt.active) continue;
      any = true;
      const Point& p = points_[k];
      for (int a = 0; a < nf; ++a) {
        r.segment<3>(3 * a) -= p.weight * p.N[a] * pt.traction;
        if (!sink.tangent()) continue;
        for (int b = 0; b < nf; ++b) K.block<3, 3>(3 * a, 3 * b) -= p.weight * p.N[a] * p.N[b] * pt.dtraction;
      }
    }
    k0 = k;
    if (!any) continue;
    for (int a = 0; a < nf; ++a)
      for (int i = 0; i < 3; ++i) dofs[3 * a + i] = 3 * nodes[a] + i;
    sink.add_residual(3 * nf, dofs.data(), r.data());
    if (!sink.tangent()) continue;
    if (nf == 6) {
      sink.add_tangent(18, dofs.data(), 18, dofs.data(), K.data());
    } else {  // a quad's 12 × 12 block, contiguous (column-major) for the sink
      const Eigen::Matrix<double, 12, 12> K12 = K.topLeftCorner<12, 12>();
      sink.add_tangent(12, dofs.data(), 12, dofs.data(), K12.data());
    }
  }
  return MaterialStatus::ok;
}

ContactTotals ObstacleContact::totals(const Mesh& mesh, const Iterate& it) const {
  ContactTotals t;
  Vec3 tangential = Vec3::Zero();
  for (std::size_t k = 0; k < points_.size(); ++k) {
    ObstacleGap g;
    const PointTraction pt = point_traction(mesh, it, int(k), reported_state(it, int(k)), g);
    t.max_penetration = std::max(t.max_penetration, -g.gap);
    if (!pt.active) continue;
    const double w = points_[k].weight;
    t.normal_force += w * pt.pressure;
    tangential += w * pt.tangential;
    t.force += w * pt.traction;
    t.area += current_weight(mesh, it, points_[k]);
    ++t.active_points;
    if (pt.slip) ++t.slipping_points;
  }
  t.tangential_force = tangential.norm();
  return t;
}

std::vector<Vec3> ObstacleContact::active_positions(const Mesh& mesh, const Iterate& it) const {
  std::vector<Vec3> out;
  for (std::size_t k = 0; k < points_.size(); ++k) {
    ObstacleGap g;
    if (point_traction(mesh, it, int(k), reported_state(it, int(k)), g).active) out.push_back(point_position(mesh, it, points_[k]));
  }
  return out;
}

void ObstacleContact::face_values(const Mesh& mesh, const Iterate& it, std::vector<double>& pressure,
                                  std::vector<double>& gap) const {
  const std::size_t nfaces = quads_.size() + tris_.size();
  pressure.assign(nfaces, 0.0);
  gap.assign(nfaces, std::numeric_limits<double>::infinity());
  std::vector<int> count(nfaces, 0);
  for (std::size_t k = 0; k < points_.size(); ++k) {
    ObstacleGap g;
    const PointTraction pt = point_traction(mesh, it, int(k), reported_state(it, int(k)), g);
    const Point& p = points_[k];
    const double da = current_weight(mesh, it, p);
    if (pt.active && da > 0.0) pressure[p.face] += pt.pressure * p.weight / da;  // Cauchy: per current area
    gap[p.face] = std::min(gap[p.face], g.gap);
    ++count[p.face];
  }
  for (std::size_t f = 0; f < nfaces; ++f)
    if (count[f]) pressure[f] /= count[f];
}

}  // namespace softhom::fe

namespace softhom::fe {

std::vector<ObstacleContact::Point> contact_rule_points(bool quad) {
  std::vector<ObstacleContact::Point> out;
  for (const auto& r : quad ? quad_rule() : tri_rule()) {
    ObstacleContact::Point p;
    if (quad) quad_shape(r.xi, r.eta, p);
    else tri_shape(r.xi, r.eta, p);
    p.rule_weight = r.w;
    out.push_back(p);
  }
  return out;
}

}  // namespace softhom::fe
