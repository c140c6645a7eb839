// Contact between deformable surfaces and self-contact (surface_contact.hpp): the master faces'
// geometry and closest-point projection, the grid that finds candidate faces, the exact first and
// second variation of the gap, and the contribution's pairing and assembly.
#include "softhom/fe/surface_contact.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <unordered_map>

#include <Eigen/Dense>

#include "softhom/materials/errors.hpp"

namespace softhom::fe {

/// Uniform grid over the master faces' boxes, each widened by the search distance: the faces a point
/// may pair with are those listed in its cell (expected O(1) per point, O(n) to build).
class FaceGrid {
 public:
  FaceGrid(const std::vector<SurfaceContact::Face>& faces, int begin, int end, const std::vector<Vec3>& x, double reach) {
    double extent = reach;
    std::vector<std::pair<Vec3, Vec3>> boxes;
    for (int f = begin; f < end; ++f) {
      Vec3 lo = x[faces[f].nodes[0]], hi = lo;
      for (int a = 1; a < faces[f].nodes_count; ++a) {
        lo = lo.cwiseMin(x[faces[f].nodes[a]]);
        hi = hi.cwiseMax(x[faces[f].nodes[a]]);
      }
      lo.array() -= reach;
      hi.array() += reach;
      extent = std::max(extent, (hi - lo).maxCoeff() / 2.0);
      boxes.emplace_back(lo, hi);
      origin_ = f == begin ? lo : Vec3(origin_.cwiseMin(lo));
    }
    cell_ = extent > 0.0 ? extent : 1.0;
    for (int f = begin; f < end; ++f) {
      const auto [lo, hi] = boxes[f - begin];
      const std::array<long, 3> a = cell_of(lo), b = cell_of(hi);
      for (long i = a[0]; i <= b[0]; ++i)
        for (long j = a[1]; j <= b[1]; ++j)
          for (long k = a[2]; k <= b[2]; ++k) cells_[key({i, j, k})].push_back(f);
    }
  }
  /// The faces whose widened box may hold `point` (ascending).
  const std::vector<int>& candidates(const Vec3& point) const {
    static const std::vector<int> none;
    const auto it = cells_.find(key(cell_of(point)));
    return it == cells_.end() ? none : it->second;
  }

 private:
  std::array<long, 3> cell_of(const Vec3& p) const {
    std::array<long, 3> c{};
    for (int i = 0; i < 3; ++i) c[i] = long(std::floor(std::clamp((p[i] - origin_[i]) / cell_, -1.0, 1e6)));
    return c;
  }
  static long long key(const std::array<long, 3>& c) {
    return ((long long)(c[0] + 1) << 42) ^ ((long long)(c[1] + 1) << 21) ^ (long long)(c[2] + 1);
  }
  Vec3 origin_ = Vec3::Zero();
  double cell_ = 1.0;
  std::unordered_map<long long, std::vector<int>> cells_;
};

namespace {

// A point's dofs: its slave face's, the master face's and (with friction, where the closest point
// lies on a neighbour of the paired face) the paired face's, which carries the stick anchor.
constexpr int kMaxDofs = 54;
using VecN = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxDofs, 1>;
using MatN = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxDofs, kMaxDofs>;
using Mat3N = Eigen::Matrix<double, 3, Eigen::Dynamic, 0, 3, kMaxDofs>;
using Mat2N = Eigen::Matrix<double, 2, Eigen::Dynamic, 0, 2, kMaxDofs>;
using Face = SurfaceContact::Face;

/// Search reach in face sizes: a point pairs with faces within this many sizes of it.
constexpr double kReach = 2.0;
/// The default stick penalty's share of the normal one (surface_contact.hpp).
constexpr double kTangentialPenaltyRatio = 0.1;

/// Shape functions of a master face at (ξ, η) with their first and second derivatives: the bilinear
/// quad on [-1, 1]² (mesh.hpp's order), or the 6-node triangle (ξ = L1, η = L2; kTet10Faces' order).
struct FaceShape {
  std::array<double, 6> N{}, d1{}, d2{}, d11{}, d12{}, d22{};
};

FaceShape face_shape(bool quad, double xi, double eta) {
  FaceShape s;
  if (quad) {
    static const double sx[4] = {-1, 1, 1, -1}, sy[4] = {-1, -1, 1, 1};
    for (int k = 0; k < 4; ++k) {
      s.N[k] = 0.25 * (1 + sx[k] * xi) * (1 + sy[k] * eta);
      s.d1[k] = 0.25 * sx[k] * (1 + sy[k] * eta);
      s.d2[k] = 0.25 * sy[k] * (1 + sx[k] * xi);
      s.d12[k] = 0.25 * sx[k] * sy[k];
    }
    return s;
  }
  // Each node's function as a quadratic in the barycentric L = (1 − ξ − η, ξ, η): corners L(2L − 1),
  // mid-edges 4 L_i L_j; the ξ and η derivatives of L are (−1, 1, 0) and (−1, 0, 1).
  const double L[3] = {1 - xi - eta, xi, eta};
  const double dx[3] = {-1, 1, 0}, dy[3] = {-1, 0, 1};
  for (int c = 0; c < 3; ++c) {
    s.N[c] = L[c] * (2 * L[c] - 1);
    s.d1[c] = (4 * L[c] - 1) * dx[c];
    s.d2[c] = (4 * L[c] - 1) * dy[c];
    s.d11[c] = 4 * dx[c] * dx[c];
    s.d12[c] = 4 * dx[c] * dy[c];
    s.d22[c] = 4 * dy[c] * dy[c];
  }
  static const int edge[3][2] = {{0, 1}, {1, 2}, {2, 0}};
  for (int e = 0; e < 3; ++e) {
    const int i = edge[e][0], j = edge[e][1];
    s.N[3 + e] = 4 * L[i] * L[j];
    s.d1[3 + e] = 4 * (dx[i] * L[j] + L[i] * dx[j]);
    s.d2[3 + e] = 4 * (dy[i] * L[j] + L[i] * dy[j]);
    s.d11[3 + e] = 8 * dx[i] * dx[j];
    s.d12[3 + e] = 4 * (dx[i] * dy[j] + dy[i] * dx[j]);
    s.d22[3 + e] = 8 * dy[i] * dy[j];
  }
  return s;
}

/// A master face's position, tangents and second derivatives at one parametric point.
struct FaceGeometry {
  FaceShape shape;
  Vec3 x = Vec3::Zero(), a1 = Vec3::Zero(), a2 = Vec3::Zero(), x11 = Vec3::Zero(), x12 = Vec3::Zero(),
       x22 = Vec3::Zero();
  Vec3 normal() const { return a1.cross(a2).normalized(); }
};

FaceGeometry face_geometry(const Face& f, const std::vector<Vec3>& x, double xi, double eta) {
  FaceGeometry g;
  g.shape = face_shape(f.quad(), xi, eta);
  for (int a = 0; a < f.nodes_count; ++a) {
    const Vec3& p = x[f.nodes[a]];
    g.x += g.shape.N[a] * p;
    g.a1 += g.shape.d1[a] * p;
    g.a2 += g.shape.d2[a] * p;
    g.x11 += g.shape.d11[a] * p;
    g.x12 += g.shape.d12[a] * p;
    g.x22 += g.shape.d22[a] * p;
  }
  return g;
}

/// (ξ, η) clamped to the face's parameter domain.
void clamp_to_face(bool quad, double& xi, double& eta) {
  if (quad) {
    xi = std::clamp(xi, -1.0, 1.0);
    eta = std::clamp(eta, -1.0, 1.0);
    return;
  }
  if (xi + eta > 1.0) {  // back onto the long edge along (1, 1), then into the corners' range
    const double s = 0.5 * (xi + eta - 1.0);
    xi -= s;
    eta -= s;
  }
  xi = std::max(xi, 0.0);
  eta = std::max(eta, 0.0);
  if (xi + eta > 1.0) (xi > eta ? xi : eta) = 1.0 - std::min(xi, eta);
}

/// The directions the face's bounds leave free at (ξ, η): a bound holds the point where it lies on it and
/// the distance's descent direction leaves the face there (a positive multiplier).
void free_directions(bool quad, double xi, double eta, const Eigen::Vector2d& descent, FaceProjection& p) {
  constexpr double on = 1e-12;
  std::array<Eigen::Vector2d, 3> blocked;  // outward normals of the bounds in force
  int count = 0;
  auto block = [&](bool holds, double nx, double ny) {
    if (holds) blocked[count++] = Eigen::Vector2d(nx, ny);
  };
  if (quad) {
    block(xi >= 1 - on && descent[0] > 0, 1, 0);
    block(xi <= -1 + on && descent[0] < 0, -1, 0);
    block(eta >= 1 - on && descent[1] > 0, 0, 1);
    block(eta <= -1 + on && descent[1] < 0, 0, -1);
  } else {
    block(xi <= on && descent[0] < 0, -1, 0);
    block(eta <= on && descent[1] < 0, 0, -1);
    block(xi + eta >= 1 - on && descent[0] + descent[1] > 0, 1, 1);
  }
  p.free = count == 0 ? 2 : count == 1 ? 1 : 0;
  p.free_basis = {1, 0, 0, 1};
  if (count == 1) {
    const Eigen::Vector2d t = Eigen::Vector2d(-blocked[0][1], blocked[0][0]).normalized();
    p.free_basis = {t[0], t[1], 0, 0};
  }
}

/// The projection's Hessian m − d·x_αβ and gradient −d·a_α at a face geometry.
void distance_derivatives(const FaceGeometry& g, const Vec3& d, Eigen::Matrix2d& A, Eigen::Vector2d& grad) {
  A << g.a1.dot(g.a1) - d.dot(g.x11), g.a1.dot(g.a2) - d.dot(g.x12), g.a1.dot(g.a2) - d.dot(g.x12),
      g.a2.dot(g.a2) - d.dot(g.x22);
  grad << -d.dot(g.a1), -d.dot(g.a2);
}

bool shares_node(const Face& a, const Face& b) {
  for (int i = 0; i < a.nodes_count; ++i)
    for (int j = 0; j < b.nodes_count; ++j)
      if (a.nodes[i] == b.nodes[j]) return true;
  return false;
}

/// The kinematics of one slave point against its master face (surface_contact.hpp): dofs are the
/// slave face's nodes, then the master face's. D, B_α map nodal increments to Δ(x_s − x_m) and Δa_α at
/// fixed (ξ, η); Ξ = ∂ξ/∂u from the stationarity of the distance; ν the contact normal and Nν = ∂ν/∂u.
/// Inside the face ν is the face's normal n; where an edge or a corner holds the closest point it is the
/// distance's direction ±d/|d|, the sign the side of the surface's pseudo-normal there (the gap is the
/// signed distance, equal to d·n where the closest point leaves the face's inside, so the gap and its
/// derivative are continuous). The gap's variation is then ∂g = Dᵀν in both cases (+ Nνᵀ d, which
/// vanishes: d ∥ ν and Nν ⊥ ν) and its second variation Dᵀ Nν − (B_αᵀ ν) Ξ_α. The dofs may extend
/// beyond the two faces' (n columns, the others zero: the stick anchor's face).
struct GapKinematics {
  Mat3N D, B1, B2;
  Mat2N Xi;
  Vec3 nu = Vec3::UnitZ();
  Mat3N Nnu;
  VecN gradient() const { return D.transpose() * nu; }
  /// (∂D/∂u)ᵀ f for a force f at the closest point: the master's shape functions move with ξ.
  MatN moving_point(const Vec3& f) const { return -(B1.transpose() * f) * Xi.row(0) - (B2.transpose() * f) * Xi.row(1); }
  MatN hessian() const { return D.transpose() * Nnu + moving_point(nu); }
};

GapKinematics gap_kinematics(const std::array<double, 6>& Ns, int ns, const FaceGeometry& g, int nm,
                             const FaceProjection& proj, const Vec3& d, double sign, int n, bool derivatives) {
  const Mat3 I = Mat3::Identity();
  GapKinematics k;
  k.D = Mat3N::Zero(3, n);
  for (int b = 0; b < ns; ++b) k.D.block<3, 3>(0, 3 * b) = Ns[b] * I;
  for (int a = 0; a < nm; ++a) k.D.block<3, 3>(0, 3 * (ns + a)) = -g.shape.N[a] * I;
  const double r = d.norm();
  const bool held = proj.free < 2 && r > 0.0;
  k.nu = held ? Vec3(sign * d / r) : proj.normal;
  if (!derivatives) return k;
  k.B1 = k.B2 = Mat3N::Zero(3, n);
  for (int a = 0; a < nm; ++a) {
    k.B1.block<3, 3>(0, 3 * (ns + a)) = g.shape.d1[a] * I;
    k.B2.block<3, 3>(0, 3 * (ns + a)) = g.shape.d2[a] * I;
  }
  Eigen::Matrix2d A, m;
  Eigen::Vector2d grad;
  distance_derivatives(g, d, A, grad);
  m << g.a1.dot(g.a1), g.a1.dot(g.a2), g.a1.dot(g.a2), g.a2.dot(g.a2);
  Mat2N rhs(2, n);
  rhs.row(0) = g.a1.transpose() * k.D + d.transpose() * k.B1;
  rhs.row(1) = g.a2.transpose() * k.D + d.transpose() * k.B2;
  k.Xi = Mat2N::Zero(2, n);
  if (proj.free == 2) {
    k.Xi = A.inverse() * rhs;
  } else if (proj.free == 1) {
    const Eigen::Vector2d t(proj.free_basis[0], proj.free_basis[1]);
    k.Xi = t * ((t.transpose() * rhs) / (t.dot(A * t)));
  }
  if (held) {  // Δν = (I − ν⊗ν) Δd / |d|, Δd = Δ(x_s − x_m) with the closest point moving
    const Mat3N Dd = k.D - g.a1 * k.Xi.row(0) - g.a2 * k.Xi.row(1);
    k.Nnu = sign * (I - k.nu * k.nu.transpose()) * Dd / r;
    return k;
  }
  const Mat3N T1 = k.B1 + g.x11 * k.Xi.row(0) + g.x12 * k.Xi.row(1);
  const Mat3N T2 = k.B2 + g.x12 * k.Xi.row(0) + g.x22 * k.Xi.row(1);
  const Eigen::Matrix2d minv = m.inverse();
  const Vec3 c1 = minv(0, 0) * g.a1 + minv(0, 1) * g.a2, c2 = minv(1, 0) * g.a1 + minv(1, 1) * g.a2;
  k.Nnu = -(c1 * (k.nu.transpose() * T1) + c2 * (k.nu.transpose() * T2));
  return k;
}

/// The parametric coordinates of the point of a face's surface, extended beyond its bounds by its shape
/// functions, nearest to y (Gauss–Newton from (ξ, η)): where a stick anchor lies on that face.
std::array<double, 2> extended_coordinates(const Face& f, const std::vector<Vec3>& x, const Vec3& y, double xi, double eta) {
  for (int iter = 0; iter < 20; ++iter) {
    const FaceGeometry g = face_geometry(f, x, xi, eta);
    Eigen::Matrix2d m;
    m << g.a1.dot(g.a1), g.a1.dot(g.a2), g.a1.dot(g.a2), g.a2.dot(g.a2);
    const Vec3 d = y - g.x;
    const Eigen::Vector2d step = m.ldlt().solve(Eigen::Vector2d(d.dot(g.a1), d.dot(g.a2)));
    if (!step.allFinite()) break;
    xi += step[0];
    eta += step[1];
    if (step.cwiseAbs().sum() < 1e-14) break;
  }
  return {xi, eta};
}

/// The unconstrained Newton step towards the distance's stationary point; where its Hessian A is not
/// positive, a gradient step scaled by the tangents' lengths.
Eigen::Vector2d free_step(const FaceGeometry& g, const Eigen::Matrix2d& A, const Eigen::Vector2d& grad) {
  return A(0, 0) > 0 && A.determinant() > 0 ? Eigen::Vector2d(-A.ldlt().solve(grad))
                                            : Eigen::Vector2d(-grad[0] / std::max(g.a1.squaredNorm(), 1e-300),
                                                              -grad[1] / std::max(g.a2.squaredNorm(), 1e-300));
}

/// The projection's closest point (ξ, η) of a face, at geometry g there, and its gap and distance.
void set_closest_point(const FaceGeometry& g, const Vec3& point, double xi, double eta, FaceProjection& p) {
  p.xi = xi;
  p.eta = eta;
  p.x = g.x;
  p.normal = g.normal();
  p.gap = (point - g.x).dot(p.normal);
  p.distance = (point - g.x).norm();
}

}  // namespace

FaceProjection project_on_face(const Face& face, const std::vector<Vec3>& x, const Vec3& point, double xi0, double eta0) {
  // Newton on the bounds in force (active set): a bound holds the point where the distance decreases
  // out of the face (its multiplier is positive); the step then moves along the free directions alone,
  // so the iteration ends at the constrained minimum, not where a clamped full step stalls.
  const bool quad = face.quad();
  double xi = xi0, eta = eta0;
  clamp_to_face(quad, xi, eta);
  FaceProjection p;
  for (int iter = 0; iter < 40; ++iter) {
    const FaceGeometry g = face_geometry(face, x, xi, eta);
    Eigen::Matrix2d A;
    Eigen::Vector2d grad;
    distance_derivatives(g, point - g.x, A, grad);
    free_directions(quad, xi, eta, -grad, p);
    Eigen::Vector2d step = Eigen::Vector2d::Zero();
    if (p.free == 2) {
      step = free_step(g, A, grad);
    } else if (p.free == 1) {
      const Eigen::Vector2d t(p.free_basis[0], p.free_basis[1]);
      const double curvature = t.dot(A * t), slope = t.dot(grad);
      step = -(slope / (curvature > 0 ? curvature : std::max((g.a1 * t[0] + g.a2 * t[1]).squaredNorm(), 1e-300))) * t;
    }
    if (!step.allFinite()) step.setZero();
    const double xi_old = xi, eta_old = eta;
    xi += step[0];
    eta += step[1];
    clamp_to_face(quad, xi, eta);
    if (std::abs(xi - xi_old) + std::abs(eta - eta_old) < 1e-15) break;
  }
  const FaceGeometry g = face_geometry(face, x, xi, eta);
  Eigen::Matrix2d A;
  Eigen::Vector2d grad;
  distance_derivatives(g, point - g.x, A, grad);
  free_directions(quad, xi, eta, -grad, p);
  set_closest_point(g, point, xi, eta, p);
  return p;
}

namespace {

/// The closest point of a face with no better start than its centre (ξ = η = 0 on a quad, 1/3 on a
/// triangle): a face met for the first time in a search.
FaceProjection project_from_centre(const Face& face, const std::vector<Vec3>& x, const Vec3& point) {
  const double centre = face.quad() ? 0.0 : 1.0 / 3;
  return project_on_face(face, x, point, centre, centre);
}

}  // namespace

FaceProjection project_on_extended_face(const Face& face, const std::vector<Vec3>& x, const Vec3& point, double xi,
                                        double eta) {
  // Newton on the distance's stationarity, with no bounds (the free steps of project_on_face).
  for (int iter = 0; iter < 40; ++iter) {
    const FaceGeometry g = face_geometry(face, x, xi, eta);
    Eigen::Matrix2d A;
    Eigen::Vector2d grad;
    distance_derivatives(g, point - g.x, A, grad);
    const Eigen::Vector2d step = free_step(g, A, grad);
    if (!step.allFinite()) break;
    xi += step[0];
    eta += step[1];
    if (step.cwiseAbs().sum() < 1e-15) break;
  }
  FaceProjection p;
  set_closest_point(face_geometry(face, x, xi, eta), point, xi, eta, p);
  return p;
}

SurfaceContact::SurfaceContact(const Mesh& mesh, ContactSurface slave, ContactSurface master, Options options)
    : options_(std::move(options)) {
  surface_names_ = {slave.name, master.name};
  for (const ContactSurface* s : {&slave, &master}) {
    const bool is_slave = s == &slave;
    for (const Quad& q : s->quads) faces_.push_back({4, {q[0], q[1], q[2], q[3], 0, 0}, 0.0, is_slave});
    for (const Tri6& t : s->tris) faces_.push_back({6, {t[0], t[1], t[2], t[3], t[4], t[5]}, 0.0, is_slave});
  }
  const int nslave = int(slave.quads.size() + slave.tris.size());
  slave_faces_ = nslave;
  if (options_.two_pass)
    for (Face& f : faces_) f.slave = true;
  build(mesh, nslave, false);
}

SurfaceContact::SurfaceContact(const Mesh& mesh, ContactSurface surface, Options options) : options_(std::move(options)) {
  surface_names_ = {surface.name};
  self_ = true;
  for (const Quad& q : surface.quads) faces_.push_back({4, {q[0], q[1], q[2], q[3], 0, 0}, 0.0, true});
  for (const Tri6& t : surface.tris) faces_.push_back({6, {t[0], t[1], t[2], t[3], t[4], t[5]}, 0.0, true});
  slave_faces_ = int(faces_.size());
  build(mesh, int(faces_.size()), true);
}

void SurfaceContact::build(const Mesh& mesh, int nslave, bool self) {
  const int nfaces = int(faces_.size());
  // validate() refuses node ids out of range; until then the geometry is left out (no points).
  for (const Face& f : faces_)
    for (int a = 0; a < f.nodes_count; ++a)
      if (f.nodes[a] < 0 || f.nodes[a] >= mesh.num_nodes()) return;
  std::vector<Quad> quads;
  std::vector<Tri6> tris;
  for (const Face& f : faces_) {
    if (f.quad()) quads.push_back({f.nodes[0], f.nodes[1], f.nodes[2], f.nodes[3]});
    else tris.push_back({f.nodes[0], f.nodes[1], f.nodes[2], f.nodes[3], f.nodes[4], f.nodes[5]});
  }
  const std::vector<double> h = face_sizes(mesh, quads, tris);  // quads first, then triangles
  for (int f = 0, q = 0, t = 0; f < nfaces; ++f) faces_[f].size = faces_[f].quad() ? h[q++] : h[quads.size() + t++];
  build_topology();
  if (self) add_points(mesh, 0, nfaces, 0, nfaces, 0.5);
  else if (!options_.two_pass) add_points(mesh, 0, nslave, nslave, nfaces, 1.0);
  else {
    add_points(mesh, 0, nslave, nslave, nfaces, 0.5);
    add_points(mesh, nslave, nfaces, 0, nslave, 0.5);
  }
}

namespace {

int corner_count(const Face& f) { return f.quad() ? 4 : 3; }
long long corner_key(int node, int surface) { return 2LL * node + surface; }

/// Parametric coordinates of a face's corners: the quad's (±1, ±1), the triangle's (0, 0), (1, 0), (0, 1).
Eigen::Vector2d corner_coordinates(bool quad, int c) {
  static const double q[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}}, t[3][2] = {{0, 0}, {1, 0}, {0, 1}};
  return quad ? Eigen::Vector2d(q[c][0], q[c][1]) : Eigen::Vector2d(t[c][0], t[c][1]);
}

/// The corners of a face spanning the bounds (ξ, η) lies on: two at an edge, one at a corner.
std::vector<int> feature_corners(const Face& f, double xi, double eta) {
  // Bounds a ξ + b η = c: the quad's ξ = ±1, η = ±1; the triangle's ξ = 0, η = 0, ξ + η = 1.
  static const double qb[4][3] = {{1, 0, -1}, {1, 0, 1}, {0, 1, -1}, {0, 1, 1}}, tb[3][3] = {{1, 0, 0}, {0, 1, 0}, {1, 1, 1}};
  constexpr double on = 1e-9;
  std::vector<int> corners;
  for (int c = 0; c < corner_count(f); ++c) {
    const Eigen::Vector2d cc = corner_coordinates(f.quad(), c);
    bool spans = true;
    for (int b = 0; b < (f.quad() ? 4 : 3); ++b) {
      const double* B = f.quad() ? qb[b] : tb[b];
      if (std::abs(B[0] * xi + B[1] * eta - B[2]) < on && std::abs(B[0] * cc[0] + B[1] * cc[1] - B[2]) > on) spans = false;
    }
    if (spans) corners.push_back(c);
  }
  return corners;
}

bool has_corner(const Face& f, int node) {
  for (int c = 0; c < corner_count(f); ++c)
    if (f.nodes[c] == node) return true;
  return false;
}

/// The corner nodes next to corner `node` along the face's boundary.
std::array<int, 2> neighbour_corners(const Face& f, int node) {
  const int n = corner_count(f);
  int c = 0;
  while (f.nodes[c] != node) ++c;
  return {f.nodes[(c + 1) % n], f.nodes[(c + n - 1) % n]};
}

}  // namespace

void SurfaceContact::build_topology() {
  const int nfaces = int(faces_.size());
  corner_faces_.clear();
  ring_.assign(nfaces, {});
  for (int f = 0; f < nfaces; ++f)
    for (int c = 0; c < corner_count(faces_[f]); ++c) corner_faces_[corner_key(faces_[f].nodes[c], surface_of(f))].push_back(f);
  for (int f = 0; f < nfaces; ++f) {
    for (int c = 0; c < corner_count(faces_[f]); ++c) {
      const std::vector<int>& around = corner_faces_[corner_key(faces_[f].nodes[c], surface_of(f))];
      ring_[f].insert(ring_[f].end(), around.begin(), around.end());
    }
    std::sort(ring_[f].begin(), ring_[f].end());
    ring_[f].erase(std::unique(ring_[f].begin(), ring_[f].end()), ring_[f].end());
  }
}

void SurfaceContact::closest_in_ring(const Point& p, const Vec3& xs, const std::vector<Vec3>& x, Evaluation& e) const {
  const Face& own = faces_[p.face];
  // In a self-contact the surface around the point itself is no contact: the faces within two rings of
  // its own face (the pairing skips one ring: faces sharing a node) lie beside it in its own surface,
  // where its distance to them would be a false gap.
  const std::vector<int>& own_ring = ring_[p.face];
  auto beside_own = [&](int f) {
    if (!self_) return false;
    for (int g : own_ring)
      if (std::binary_search(ring_[g].begin(), ring_[g].end(), f)) return true;
    return false;
  };
  for (int f : ring_[e.paired]) {
    const Face& face = faces_[f];
    if (f == e.paired || f == p.face || shares_node(own, face) || beside_own(f)) continue;
    // A sphere around the face's nodes (widened for a curved side's bulge) farther than the best
    // distance holds no nearer point.
    Vec3 centre = Vec3::Zero();
    for (int a = 0; a < face.nodes_count; ++a) centre += x[face.nodes[a]] / face.nodes_count;
    double radius = 0.0;
    for (int a = 0; a < face.nodes_count; ++a) radius = std::max(radius, (x[face.nodes[a]] - centre).norm());
    if ((xs - centre).norm() - 1.5 * radius > e.projection.distance) continue;
    const FaceProjection q = project_from_centre(face, x, xs);
    // Ties (the same closest point on a shared edge) stay with the paired face.
    if (q.distance < e.projection.distance - 1e-12 * face.size) {
      e.master = f;
      e.projection = q;
    }
  }
}

double SurfaceContact::feature_side(int w, const FaceProjection& q, const Vec3& d, const std::vector<Vec3>& x,
                                    int paired, bool& interior, bool& open) const {
  // The pseudo-normal of the edge or corner (the faces' normals there, a corner's weighted by the
  // faces' angles at it: Bærentzen and Aanæs 2005) gives the side of the surface continuously: a point
  // held there changes sides only through the surface itself, where its distance vanishes.
  const Face& f = faces_[w];
  const std::vector<int> corners = feature_corners(f, q.xi, q.eta);
  if (corners.empty()) {
    interior = false;
    return d.dot(q.normal) < 0.0 ? -1.0 : 1.0;
  }
  const int v = f.nodes[corners[0]];
  const auto it = corner_faces_.find(corner_key(v, surface_of(w)));
  Vec3 pseudo = Vec3::Zero();
  std::unordered_map<int, int> rim;  // around a corner: each neighbour corner's count (2 on a closed fan)
  int count = 0;
  bool in_ring = true;
  for (int g : it->second) {
    const Face& face = faces_[g];
    if (corners.size() > 1 && !has_corner(face, f.nodes[corners[1]])) continue;
    ++count;
    in_ring = in_ring && std::binary_search(ring_[paired].begin(), ring_[paired].end(), g);
    const Vec3 n = g == w ? q.normal : project_from_centre(face, x, q.x).normal;
    double weight = 1.0;
    if (corners.size() == 1) {
      const std::array<int, 2> r = neighbour_corners(face, v);
      const Vec3 a = (x[r[0]] - x[v]).normalized(), b = (x[r[1]] - x[v]).normalized();
      weight = std::acos(std::clamp(a.dot(b), -1.0, 1.0));
      ++rim[r[0]];
      ++rim[r[1]];
    }
    pseudo += weight * n;
  }
  bool closed = corners.size() > 1 ? count == 2 : count > 0;
  for (const auto& [node, times] : rim) closed = closed && times == 2;
  interior = closed && in_ring;
  open = !closed;
  return d.dot(pseudo) < 0.0 ? -1.0 : 1.0;
}

int SurfaceContact::response_nodes(const Point& p, const Evaluation& e, std::array<int, 18>& nodes) const {
  int count = 0;
  for (int f : {p.face, e.master}) {
    const Face& face = faces_[f];
    for (int a = 0; a < face.nodes_count; ++a) nodes[count++] = face.nodes[a];
  }
  if (options_.friction > 0.0 && e.paired != e.master) {
    const Face& face = faces_[e.paired];
    for (int a = 0; a < face.nodes_count; ++a) nodes[count++] = face.nodes[a];
  }
  return count;
}

void SurfaceContact::add_points(const Mesh& mesh, int slave_begin, int slave_end, int master_begin, int master_end,
                                double factor) {
  static const std::vector<ObstacleContact::Point> quad_rule = contact_rule_points(true);
  static const std::vector<ObstacleContact::Point> tri_rule = contact_rule_points(false);
  const bool segments = options_.integration == Options::Integration::segments;
  for (int f = slave_begin; f < slave_end; ++f) {
    const Face& face = faces_[f];
    const std::vector<ObstacleContact::Point>& rule = face.quad() ? quad_rule : tri_rule;
    const int slots = segments ? std::max(kSegmentSlots, int(rule.size())) : int(rule.size());
    for (int j = 0; j < slots; ++j) {
      // Spare slots (segments) start as copies of the last Gauss point, unused (init_state).
      const ObstacleContact::Point& r = rule[std::min<std::size_t>(j, rule.size() - 1)];
      Point p;
      p.face = f;
      p.master_begin = master_begin;
      p.master_end = master_end;
      p.slot = j;
      p.slots = slots;
      p.home_count = int(rule.size());
      p.N = r.N;
      p.dN_xi = r.dN_xi;
      p.dN_eta = r.dN_eta;
      p.rule_weight = r.rule_weight;
      // The place from the shape functions (they reproduce the parametric coordinates of the nodes).
      static const double qxi[4] = {-1, 1, 1, -1}, qeta[4] = {-1, -1, 1, 1};
      static const double txi[6] = {0, 1, 0, 0.5, 0.5, 0}, teta[6] = {0, 0, 1, 0, 0.5, 0.5};
      for (int a = 0; a < face.nodes_count; ++a) {
        p.xi += r.N[a] * (face.quad() ? qxi[a] : txi[a]);
        p.eta += r.N[a] * (face.quad() ? qeta[a] : teta[a]);
      }
      Vec3 x_xi = Vec3::Zero(), x_eta = Vec3::Zero();
      for (int a = 0; a < face.nodes_count; ++a) {
        x_xi += r.dN_xi[a] * mesh.nodes[face.nodes[a]];
        x_eta += r.dN_eta[a] * mesh.nodes[face.nodes[a]];
      }
      p.factor = factor;
      p.weight = factor * r.rule_weight * x_xi.cross(x_eta).norm();
      p.penalty = options_.penalty != 0.0 ? options_.penalty : default_contact_penalty(options_.shear_modulus, face.size);
      p.tangential_penalty =
          options_.tangential_penalty != 0.0 ? options_.tangential_penalty : kTangentialPenaltyRatio * p.penalty;
      points_.push_back(p);
    }
  }
}

void SurfaceContact::init_state(double* state) const {
  for (std::size_t k = 0; k < points_.size(); ++k) {
    const Point& p = points_[k];
    double* s = state + kStateSize * k;
    s[0] = s[1] = 0.0;
    s[2] = -1.0;
    std::fill(s + 3, s + kStateSize, 0.0);
    s[kPlace] = p.xi;
    s[kPlace + 1] = p.eta;
    const bool home = p.slot < p.home_count;  // the Gauss points, until a pairing lays out segments
    s[kWeight] = home ? p.weight : 0.0;
    s[kRuleWeight] = home ? p.rule_weight : 0.0;
  }
}

SurfaceContact::Point SurfaceContact::located(const Point& p, const double* s) const {
  Point q = p;
  if (s[kPlace] == p.xi && s[kPlace + 1] == p.eta && s[kRuleWeight] == p.rule_weight) {
    q.weight = s[kWeight];  // the home place: its shape functions as built
    return q;
  }
  q = at_place(p, s[kPlace], s[kPlace + 1]);
  q.rule_weight = s[kRuleWeight];
  q.weight = s[kWeight];
  return q;
}

SurfaceContact::Point SurfaceContact::at_place(const Point& p, double xi, double eta) const {
  Point q = p;
  const FaceShape shape = face_shape(faces_[p.face].quad(), xi, eta);
  q.xi = xi;
  q.eta = eta;
  q.N = shape.N;
  q.dN_xi = shape.d1;
  q.dN_eta = shape.d2;
  return q;
}

std::vector<Vec3> SurfaceContact::positions(const Mesh& mesh, const Iterate& it) const {
  std::vector<Vec3> x(mesh.nodes);
  if (it.u)
    for (std::size_t n = 0; n < x.size(); ++n) x[n] += Vec3((*it.u)[3 * n], (*it.u)[3 * n + 1], (*it.u)[3 * n + 2]);
  return x;
}

Vec3 SurfaceContact::point_position(const Point& p, const std::vector<Vec3>& x) const {
  const Face& f = faces_[p.face];
  Vec3 xs = Vec3::Zero();
  for (int a = 0; a < f.nodes_count; ++a) xs += p.N[a] * x[f.nodes[a]];
  return xs;
}

Vec3 SurfaceContact::slave_normal(const Point& p, const std::vector<Vec3>& x) const {
  const Face& own = faces_[p.face];
  Vec3 x_xi = Vec3::Zero(), x_eta = Vec3::Zero();
  for (int a = 0; a < own.nodes_count; ++a) {
    x_xi += p.dN_xi[a] * x[own.nodes[a]];
    x_eta += p.dN_eta[a] * x[own.nodes[a]];
  }
  return x_xi.cross(x_eta).normalized();
}

SurfaceContact::Candidate SurfaceContact::admissible(const Point& p, const Vec3& xs, const Vec3& n_slave, int f,
                                                     const std::vector<Vec3>& x) const {
  const Face& own = faces_[p.face];
  const Face& face = faces_[f];
  Candidate c;
  if (f < p.master_begin || f >= p.master_end || f == p.face || shares_node(own, face)) return c;
  const FaceProjection proj = project_from_centre(face, x, xs);
  // Admissible: facing it (normals opposed), within reach, and not behind the face by more than half
  // its size: a converged state penetrates by (p/G) h/100, so a point deeper than that is the far side
  // of a wall (a plate's two faces), not a contact.
  if (!(proj.normal.dot(n_slave) < 0.0)) return c;
  if (proj.distance > kReach * std::max(face.size, own.size) || proj.gap < -0.5 * face.size) return c;
  c.face = f;
  c.projection = proj;
  return c;
}

SurfaceContact::Candidate SurfaceContact::nearest_face(const Point& p, const std::vector<Vec3>& x,
                                                       const FaceGrid& grid) const {
  const Vec3 xs = point_position(p, x), n_slave = slave_normal(p, x);
  Candidate best;
  for (int f : grid.candidates(xs)) {
    const Candidate c = admissible(p, xs, n_slave, f, x);
    if (c.face >= 0 && (best.face < 0 || c.projection.distance < best.projection.distance)) best = c;
  }
  return best;
}

void SurfaceContact::carry_anchor(const Candidate& c, const std::vector<Vec3>& x, const double* old, const Vec3& shift,
                                  double* s) const {
  // A point paired anew anchors at its closest point; one that changes faces (or takes over another
  // slot's history) keeps its anchor's place relative to itself, in the new face's parametric
  // coordinates (extended beyond the face: the anchor may lie just past its edge, within the elastic
  // slip of the point).
  const int from = int(old[2]);
  if (c.face < 0 || (c.face == from && shift.squaredNorm() == 0.0)) return;
  double* a = s + kNextAnchor;
  if (from < 0) {
    a[0] = c.projection.xi;
    a[1] = c.projection.eta;
    return;
  }
  const Vec3 place = face_geometry(faces_[from], x, old[kNextAnchor], old[kNextAnchor + 1]).x + shift;
  const std::array<double, 2> moved =
      extended_coordinates(faces_[c.face], x, place, c.projection.xi, c.projection.eta);
  a[0] = moved[0];
  a[1] = moved[1];
}

namespace {

using Point2 = Eigen::Vector2d;

double cross2(const Point2& a, const Point2& b) { return a[0] * b[1] - a[1] * b[0]; }

double signed_area(const std::vector<Point2>& poly) {
  double a = 0.0;
  for (std::size_t i = 0; i < poly.size(); ++i) a += cross2(poly[i], poly[(i + 1) % poly.size()]);
  return 0.5 * a;
}

/// Counter-clockwise with every turn strictly to the left.
bool convex(const std::vector<Point2>& poly) {
  const std::size_t n = poly.size();
  for (std::size_t i = 0; i < n; ++i)
    if (!(cross2(poly[(i + 1) % n] - poly[i], poly[(i + 2) % n] - poly[(i + 1) % n]) > 0.0)) return false;
  return true;
}

/// The part of a convex polygon inside a convex counter-clockwise one (Sutherland–Hodgman).
std::vector<Point2> clip(std::vector<Point2> poly, const std::vector<Point2>& window) {
  for (std::size_t e = 0; e < window.size() && !poly.empty(); ++e) {
    const Point2 a = window[e], b = window[(e + 1) % window.size()];
    std::vector<Point2> kept;
    for (std::size_t i = 0; i < poly.size(); ++i) {
      const Point2 &p = poly[i], &q = poly[(i + 1) % poly.size()];
      const double dp = cross2(b - a, p - a), dq = cross2(b - a, q - a);
      if (dp >= 0.0) kept.push_back(p);
      if ((dp >= 0.0) != (dq >= 0.0)) kept.push_back(p + (dp / (dp - dq)) * (q - p));
    }
    poly = std::move(kept);
  }
  return poly;
}

/// A face's parametric domain, counter-clockwise in (ξ, η).
std::vector<Point2> parametric_domain(bool quad) {
  if (quad) return {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
  return {{0, 0}, {1, 0}, {0, 1}};
}

/// A point of a segment: its place on the slave face, its weight in the parameter plane and the index
/// of its piece's master face in the list the segments were cut from.
struct SegmentPoint {
  double xi = 0.0, eta = 0.0, weight = 0.0;
  int piece = -1;
};

/// The slave face's parametric domain cut by the outlines of the master faces (corners projected onto
/// the slave face's surface, in its parametric coordinates), each piece a triangle or the fan of
/// triangles from its centroid, each with the 3-point rule of degree 2. Empty where they do not tile
/// the domain (to 1e-9 of its area), an outline is not convex, or the points exceed `capacity`.
std::vector<SegmentPoint> segment_points(const Face& slave, const std::vector<Vec3>& x,
                                         const std::vector<const Face*>& masters, int capacity) {
  const std::vector<Point2> domain = parametric_domain(slave.quad());
  const double domain_area = signed_area(domain);
  const double centre = slave.quad() ? 0.0 : 1.0 / 3;
  std::vector<SegmentPoint> out;
  double covered = 0.0;
  for (std::size_t piece = 0; piece < masters.size(); ++piece) {
    const Face* face = masters[piece];
    std::vector<Point2> outline;
    for (int c = 0; c < corner_count(*face); ++c) {
      const FaceProjection q = project_on_extended_face(slave, x, x[face->nodes[c]], centre, centre);
      if (!std::isfinite(q.xi) || !std::isfinite(q.eta)) return {};
      outline.emplace_back(q.xi, q.eta);
    }
    if (signed_area(outline) < 0.0) std::reverse(outline.begin(), outline.end());
    if (!convex(outline)) return {};
    const std::vector<Point2> part = clip(domain, outline);
    if (part.size() < 3) continue;
    const double area = signed_area(part);
    covered += area;
    if (!(area > 1e-12 * domain_area)) continue;
    // A triangle as it is; a larger piece as the fan from its centroid, which does not depend on which
    // corner the clipping listed first: mirror-image faces get mirror-image points.
    std::vector<std::array<Point2, 3>> triangles;
    if (part.size() == 3) triangles.push_back({part[0], part[1], part[2]});
    else {
      Point2 centroid = Point2::Zero();
      for (const Point2& v : part) centroid += v / double(part.size());
      for (std::size_t t = 0; t < part.size(); ++t) triangles.push_back({centroid, part[t], part[(t + 1) % part.size()]});
    }
    for (const auto& [a, b, c] : triangles) {
      const double w = 0.5 * cross2(b - a, c - a) / 3.0;
      for (const auto& [la, lb, lc] : {std::array<double, 3>{4.0 / 6, 1.0 / 6, 1.0 / 6},
                                       std::array<double, 3>{1.0 / 6, 4.0 / 6, 1.0 / 6},
                                       std::array<double, 3>{1.0 / 6, 1.0 / 6, 4.0 / 6}}) {
        const Point2 at = la * a + lb * b + lc * c;
        out.push_back({at[0], at[1], w, int(piece)});
      }
    }
    if (int(out.size()) > capacity) return {};
  }
  if (std::abs(covered - domain_area) > 1e-9 * domain_area) return {};
  return out;
}

}  // namespace

namespace {

/// The used slot of a face's old layout (its `slots` states from `old`) nearest to (ξ, η) in the
/// parameter plane, whose history a new slot there takes (the slot itself where it stays); −1 if none.
int nearest_used_slot(const double* old, int slots, double xi, double eta) {
  constexpr int size = SurfaceContact::kStateSize, place = SurfaceContact::kPlace;
  int from = -1;
  double best = std::numeric_limits<double>::infinity();
  for (int o = 0; o < slots; ++o) {
    const double* so = old + size * o;
    if (!(so[SurfaceContact::kWeight] > 0.0)) continue;
    const double d = std::hypot(so[place] - xi, so[place + 1] - eta);
    if (d < best) {
      best = d;
      from = o;
    }
  }
  return from;
}

}  // namespace

std::vector<SurfaceContact::Slot> SurfaceContact::segment_layout(std::size_t g, const std::vector<Candidate>& home,
                                                                 const std::vector<Vec3>& x, const FaceGrid& grid) const {
  const Point& first = points_[g];
  const Face& own = faces_[first.face];
  // The master faces the Gauss points pair with and their rings, where they face the slave face (its
  // normal at the centre opposed) from within the search's reach and not deeper than half a face.
  const double centre = own.quad() ? 0.0 : 1.0 / 3;
  const FaceGeometry at = face_geometry(own, x, centre, centre);
  const Vec3 n_slave = at.normal();
  std::vector<int> near;
  for (const Candidate& c : home)
    if (c.face >= 0) near.insert(near.end(), ring_[c.face].begin(), ring_[c.face].end());
  std::sort(near.begin(), near.end());
  near.erase(std::unique(near.begin(), near.end()), near.end());
  std::vector<int> ids;
  std::vector<const Face*> masters;
  for (int m : near) {
    const Face& face = faces_[m];
    if (m < first.master_begin || m >= first.master_end || m == first.face || shares_node(own, face)) continue;
    const FaceProjection q = project_from_centre(face, x, at.x);
    if (!(q.normal.dot(n_slave) < 0.0) || q.gap < -0.5 * face.size) continue;
    ids.push_back(m);
    masters.push_back(&face);
  }
  if (masters.empty()) return {};
  // Each point pairs with its piece's face where that is admissible and holds its closest point
  // inside (surfaces facing each other: the patch test's exactness, and mirror-symmetric pairings
  // stay so); elsewhere as a Gauss point does, with its nearest admissible face (where the surfaces meet
  // at an angle, a corner pressed on a face, that may lie beyond the piece's ring).
  std::vector<Slot> layout;
  for (const SegmentPoint& sp : segment_points(own, x, masters, first.slots)) {
    const Point q = at_place(first, sp.xi, sp.eta);
    Candidate c = admissible(q, point_position(q, x), slave_normal(q, x), ids[sp.piece], x);
    if (c.face < 0 || c.projection.free < 2) c = nearest_face(q, x, grid);
    layout.push_back({sp.xi, sp.eta, sp.weight, c});
  }
  return layout;
}

void SurfaceContact::pair_face(const Mesh& mesh, std::size_t g, const std::vector<Vec3>& x, const FaceGrid& grid,
                               double* s, std::vector<std::pair<int, int>>& pairs) const {
  const Point& first = points_[g];
  const Face& own = faces_[first.face];
  std::vector<Candidate> home(first.home_count);
  for (int j = 0; j < first.home_count; ++j) home[j] = nearest_face(points_[g + j], x, grid);
  std::vector<Slot> layout;
  if (options_.integration == Options::Integration::segments) layout = segment_layout(g, home, x, grid);
  if (layout.empty())
    for (int j = 0; j < first.home_count; ++j) {
      const Point& p = points_[g + j];
      layout.push_back({p.xi, p.eta, p.rule_weight, home[j]});
    }
  // The old layout's history and places.
  const std::vector<double> old(s, s + std::size_t(kStateSize) * first.slots);
  std::vector<Vec3> old_x(first.slots);
  for (int j = 0; j < first.slots; ++j)
    old_x[j] = point_position(located(points_[g + j], old.data() + kStateSize * j), x);
  for (int j = 0; j < first.slots; ++j) {
    double* sj = s + kStateSize * j;
    const Point& p = points_[g + j];
    if (j >= int(layout.size())) {  // unused
      std::fill(sj, sj + kStateSize, 0.0);
      sj[2] = -1.0;
      continue;
    }
    const Slot& slot = layout[j];
    const int from = nearest_used_slot(old.data(), first.slots, slot.xi, slot.eta);
    const double* so = from >= 0 ? old.data() + kStateSize * from : nullptr;
    if (so) std::copy(so, so + kStateSize, sj);
    else {
      std::fill(sj, sj + kStateSize, 0.0);
      sj[2] = -1.0;
    }
    sj[kPlace] = slot.xi;
    sj[kPlace + 1] = slot.eta;
    sj[kRuleWeight] = slot.rule_weight;
    const FaceShape shape = face_shape(own.quad(), slot.xi, slot.eta);
    Vec3 X_xi = Vec3::Zero(), X_eta = Vec3::Zero(), xs = Vec3::Zero();
    for (int a = 0; a < own.nodes_count; ++a) {
      X_xi += shape.d1[a] * mesh.nodes[own.nodes[a]];
      X_eta += shape.d2[a] * mesh.nodes[own.nodes[a]];
      xs += shape.N[a] * x[own.nodes[a]];
    }
    sj[kWeight] = p.factor * slot.rule_weight * X_xi.cross(X_eta).norm();
    const Candidate& c = slot.pairing;
    if (so) carry_anchor(c, x, so, xs - old_x[from], sj);
    else if (c.face >= 0) {
      sj[kNextAnchor] = c.projection.xi;
      sj[kNextAnchor + 1] = c.projection.eta;
    }
    sj[2] = c.face;
    sj[3] = c.projection.xi;
    sj[4] = c.projection.eta;
    sj[kStartDepth] = 0.0;
    if (c.face < 0) {
      sj[0] = sj[1] = 0.0;  // out of reach: no multiplier to carry
      continue;
    }
    // Beside a free edge of the master surface the gap is ± the distance, its sign the side of the
    // face's plane: a point there may cross that plane in any iterate, so its whole distance is its start.
    const Evaluation e = evaluate(located(p, sj), sj, 0.0, x);
    sj[kStartDepth] = e.sided ? std::max(0.0, -e.gap) : std::abs(e.gap);
    pairs.emplace_back(first.face, c.face);
  }
}

void SurfaceContact::pair(const Mesh& mesh, const Iterate& converged, Couplings& couplings) const {
  if (!converged.state_new || points_.empty()) return;
  const std::vector<Vec3> x = positions(mesh, converged);
  double reach = 0.0;
  for (const Face& f : faces_) reach = std::max(reach, kReach * f.size);
  // One grid per master range (a pair's master surface; a self-contact's or a two-pass pair's whole
  // list, the range test in nearest_face keeping each pass to its own master faces).
  const FaceGrid grid(faces_, 0, int(faces_.size()), x, reach);
  std::vector<std::pair<int, int>> pairs;
  for (std::size_t g = 0; g < points_.size(); g += points_[g].slots)
    pair_face(mesh, g, x, grid, converged.state_new + kStateSize * g, pairs);
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  // A point may find its closest point on any face of its paired face's ring within the step (and
  // keeps its stick anchor on the paired face): the slave face couples with both.
  std::array<int, 18> group;
  for (const auto& [fs, fm] : pairs)
    for (int f : ring_[fm]) {
      int count = 0;
      for (int g : {fs, fm, f}) {
        if (g == f && f == fm) continue;
        std::copy(faces_[g].nodes.begin(), faces_[g].nodes.begin() + faces_[g].nodes_count, group.begin() + count);
        count += faces_[g].nodes_count;
      }
      couplings.add(group.data(), count);
    }
}

}  // namespace softhom::fe

namespace softhom::fe {

SurfaceContact::Evaluation SurfaceContact::evaluate(const Point& p, const double* s, double multiplier,
                                                    const std::vector<Vec3>& x) const {
  Evaluation e;
  e.paired = e.master = int(s[2]);
  if (e.paired < 0) return e;
  const Vec3 xs = point_position(p, x);
  e.projection = project_on_face(faces_[e.paired], x, xs, s[3], s[4]);
  closest_in_ring(p, xs, x, e);
  const Face& fm = faces_[e.master];
  const FaceProjection& q = e.projection;
  // Inside the face the gap along its normal; at an edge or corner the signed distance, its side the
  // pseudo-normal's (gap_kinematics).
  bool open = false;
  if (q.free < 2) e.sign = feature_side(e.master, q, xs - q.x, x, e.paired, e.sided, open);
  // A point held at an edge of the face nearest to it farther aside than half the face has slid off
  // the surface around its paired face within the step (or was paired across a corner): it bears
  // nothing until the next step pairs it again. Its gap there is at least that, unless it lies deep
  // inside, which the face-size bound refuses anyway.
  const double aside = std::sqrt(std::max(0.0, q.distance * q.distance - q.gap * q.gap));
  e.engaged = q.free == 2 || aside <= 0.5 * fm.size;
  // Past a free edge of the master surface (a mirror plane's cut, or the surface's end) the face
  // continues by its own shape functions: the gap is along its normal at the closest point of that
  // extension, smooth as the point crosses the edge, where the distance to the edge would grow with
  // the point's offset along the face (a point 0.02 mm past a finger's cut by its mirror plane, 5e-4
  // mm inside the finger, would lie 0.02 mm deep).
  if (open) {
    e.projection = project_on_extended_face(fm, x, xs, q.xi, q.eta);
    e.sign = 1.0;
  }
  e.gap = e.projection.free == 2 ? e.projection.gap : e.sign * e.projection.distance;
  if (e.engaged) e.pressure = std::max(0.0, multiplier - p.penalty * e.gap);
  return e;
}

double SurfaceContact::current_weight(const Point& p, const std::vector<Vec3>& x) const {
  const Face& f = faces_[p.face];
  Vec3 x_xi = Vec3::Zero(), x_eta = Vec3::Zero();
  for (int a = 0; a < f.nodes_count; ++a) {
    x_xi += p.dN_xi[a] * x[f.nodes[a]];
    x_eta += p.dN_eta[a] * x[f.nodes[a]];
  }
  return p.factor * p.rule_weight * x_xi.cross(x_eta).norm();
}

void SurfaceContact::validate(const Mesh& mesh) const {
  const std::string& f = options_.field;
  const int nfaces = int(faces_.size());
  const std::string slave_key = f + (self_ ? ".self" : ".slave"), master_key = f + ".master";
  if (slave_faces_ == 0) throw InputError(slave_key, "\"" + surface_names_[0] + "\"", "the surface has no faces");
  if (!self_ && nfaces == slave_faces_)
    throw InputError(master_key, "\"" + surface_names_[1] + "\"", "the surface has no faces");
  for (int k = 0; k < nfaces; ++k)
    for (int a = 0; a < faces_[k].nodes_count; ++a)
      if (faces_[k].nodes[a] < 0 || faces_[k].nodes[a] >= mesh.num_nodes())
        throw InputError(k < slave_faces_ ? slave_key : master_key, std::to_string(faces_[k].nodes[a]), "node id out of range");
  for (const Point& p : points_)
    if (!(p.penalty > 0.0 && std::isfinite(p.penalty)))
      throw InputError(f + ".penalty", format_number(p.penalty),
                       "must be positive (or automatic, from a positive shear modulus and face size)");
  const double mu = options_.friction;
  if (!(mu >= 0.0 && mu <= kMaxContactFriction))
    throw InputError(f + ".friction", format_number(mu), "Coulomb coefficient must lie in [0, 3]");
  for (const Point& p : points_)
    if (!(p.tangential_penalty > 0.0 && std::isfinite(p.tangential_penalty)))
      throw InputError(f + ".tangential_penalty", format_number(p.tangential_penalty),
                       "must be positive (or automatic: a tenth of the normal penalty)");
  // Surfaces that overlap in the reference configuration have no admissible start: refuse them, naming
  // the deepest point (touching within round-off of a face size is fine).
  std::vector<double> state(static_cast<std::size_t>(state_size()));
  init_state(state.data());
  const std::vector<double> u(mesh.num_dofs(), 0.0);
  Iterate at_rest{0.0, 0.0, 0.0, &u, 0.0};
  at_rest.state_new = state.data();
  at_rest.state_old = state.data();
  Couplings unused;
  pair(mesh, at_rest, unused);
  double deepest = 0.0;
  Vec3 where = Vec3::Zero();
  for (std::size_t k = 0; k < points_.size(); ++k) {
    const double* s = state.data() + kStateSize * k;
    if (!(s[kWeight] > 0.0)) continue;
    const Point p = located(points_[k], s);
    const Evaluation e = evaluate(p, s, 0.0, mesh.nodes);
    if (e.engaged && -e.gap > 1e-6 * faces_[e.master].size && -e.gap > deepest) {
      deepest = -e.gap;
      where = point_position(p, mesh.nodes);
    }
  }
  if (deepest > 0.0)
    throw InputError(f, self_ ? surface_names_[0] : surface_names_[0] + ", " + surface_names_[1],
                     "the surfaces overlap at the start: the slave point " + point_text(where) + " lies " +
                         format_number(deepest) + " mm inside a master face (separate the bodies)");
}

/// A point's tractions: the normal pressure p along ν and the friction traction t_T, per reference area
/// of the slave, with the residual −w Dᵀ(p ν + t_T) and its derivative over the point's dofs.
struct SurfaceContact::Response {
  int dofs = 0;
  VecN r;
  MatN K;
  Vec3 normal = Vec3::UnitZ();
  Vec3 tangential = Vec3::Zero();
  bool slip = false;
};

SurfaceContact::Response SurfaceContact::respond(const Point& p, const Evaluation& e, const double* anchor,
                                                 const std::vector<Vec3>& x, bool tangent) const {
  const Face &fs = faces_[p.face], &fm = faces_[e.master], &fa = faces_[e.paired];
  const FaceGeometry g = face_geometry(fm, x, e.projection.xi, e.projection.eta);
  const Vec3 xs = point_position(p, x);
  std::array<int, 18> nodes;
  Response out;
  out.dofs = 3 * response_nodes(p, e, nodes);
  const GapKinematics k =
      gap_kinematics(p.N, fs.nodes_count, g, fm.nodes_count, e.projection, xs - g.x, e.sign, out.dofs, tangent);
  out.normal = k.nu;
  const VecN G = k.gradient();
  if (tangent) out.K = p.weight * (p.penalty * G * G.transpose() - e.pressure * k.hessian());
  const double mu = options_.friction;
  if (!(mu > 0.0)) {
    out.r = -p.weight * e.pressure * G;
    return out;
  }
  // The trial stick traction −ε_T P v, v = x_s − x_a (the anchor a material point of the paired face).
  const std::array<double, 6> Na = face_shape(fa.quad(), anchor[0], anchor[1]).N;
  Vec3 xa = Vec3::Zero();
  for (int a = 0; a < fa.nodes_count; ++a) xa += Na[a] * x[fa.nodes[a]];
  const Vec3 v = xs - xa, &nu = k.nu;
  const Mat3 P = Mat3::Identity() - nu * nu.transpose();
  const CoulombReturn c = coulomb_return(-p.tangential_penalty * (P * v), mu, e.pressure);
  out.tangential = c.traction;
  out.slip = c.slip;
  out.r = -p.weight * (e.pressure * G + k.D.transpose() * c.traction);
  if (!tangent) return out;
  // Δ(P v) = P Δv − (ν·v) Δν − ν (v·Δν); Δp = −ε_N ∂g; the force −t_T acts at the moving closest point.
  Mat3N Dv = Mat3N::Zero(3, out.dofs);
  Dv.leftCols(3 * fs.nodes_count) = k.D.leftCols(3 * fs.nodes_count);
  const int anchor_at = fs.nodes_count + (e.paired == e.master ? 0 : fm.nodes_count);
  for (int a = 0; a < fa.nodes_count; ++a) Dv.block<3, 3>(0, 3 * (anchor_at + a)) = -Na[a] * Mat3::Identity();
  const Mat3N dtrial =
      -p.tangential_penalty * (P * Dv - nu.dot(v) * k.Nnu - nu * (v.transpose() * k.Nnu));
  const Mat3N dt = c.d_trial * dtrial - p.penalty * c.d_pressure * G.transpose();
  out.K -= p.weight * (k.D.transpose() * dt + k.moving_point(c.traction));
  return out;
}

void SurfaceContact::advance_anchor(const Point& p, const Evaluation& e, const Response& r,
                                    const std::vector<Vec3>& x, double* next) const {
  // Sticking: the anchor stays. Slipping: it moves to where the trial traction of the converged state is
  // the returned one, −ε_T P (x_s − x_a) = t_T, i.e. the closest point + t_T/ε_T. Free: the closest point.
  // The anchor lies on the paired face: where the closest point is a neighbour's, in the paired face's
  // extended coordinates.
  const bool free = !e.engaged || !(e.pressure > 0.0) || !(options_.friction > 0.0);
  if (!free && !r.slip) return;
  const bool same = e.paired == e.master;
  if (free && same) {
    next[0] = e.projection.xi;
    next[1] = e.projection.eta;
    return;
  }
  const Vec3 place = free ? e.projection.x : Vec3(e.projection.x + r.tangential / p.tangential_penalty);
  const std::array<double, 2> a = extended_coordinates(faces_[e.paired], x, place, same ? e.projection.xi : next[0],
                                                       same ? e.projection.eta : next[1]);
  next[0] = a[0];
  next[1] = a[1];
}

double SurfaceContact::penetration_limit(const Point& p, const Face& master, const double* s) const {
  // Deeper than the master face is no state to linearize about; nor is a penalty pressure ε (−g) more
  // than 10 G of the softer side beyond what the point carried at the step's start: its converged
  // pressure s[1] (the step's multiplier when augmented, its penetration's pressure in pure penalty),
  // or its depth against the face the step pairs it with (kStartDepth), if deeper (a point paired anew
  // may start inside a face it bore nothing on; beside a free edge of the surface the whole distance).
  // That is the step's own increment: a converged state legitimately carries any pressure, but an
  // iterate adding more than 10 G within one step is one whose tangent did not yet see the contact (the
  // step that first touches: the whole increment goes into the softer body, inverting its elements).
  // Refused, the line search backtracks to a shallower iterate.
  const double start = std::max(s[1] / p.penalty, s[kStartDepth]);
  return std::min(master.size, pressure_depth_limit(options_.shear_modulus, p.penalty, start));
}

MaterialStatus SurfaceContact::assemble(const Mesh& mesh, const Iterate& it, AssemblySink& sink) const {
  if (!it.state_old) return MaterialStatus::ok;  // no history, no pairing
  const std::vector<Vec3> x = positions(mesh, it);
  std::array<int, kMaxDofs> dofs;
  std::array<int, 18> nodes;
  for (std::size_t k = 0; k < points_.size(); ++k) {
    const double* so = it.state_old + kStateSize * k;
    const double lambda = options_.augmented ? so[1] : 0.0;  // the last converged pressure
    double* sn = it.state_new ? it.state_new + kStateSize * k : nullptr;
    if (sn) {  // the step solves with the multiplier and the anchor the converged state passed on
      std::copy(so, so + kStateSize, sn);
      sn[0] = lambda;
      sn[1] = 0.0;
      std::copy(so + kNextAnchor, so + kNextAnchor + 2, sn + kAnchor);
    }
    if (!(so[kWeight] > 0.0)) continue;  // an unused slot
    const Point p = located(points_[k], so);
    const Evaluation e = evaluate(p, so, lambda, x);
    if (e.master < 0) continue;
    const Face& fm = faces_[e.master];
    if (e.engaged && -e.gap > penetration_limit(p, fm, so)) return MaterialStatus::penetration;
    if (!e.engaged || !(e.pressure > 0.0)) {
      if (sn) advance_anchor(p, e, Response{}, x, sn + kNextAnchor);
      continue;
    }
    const Response r = respond(p, e, so + kNextAnchor, x, sink.tangent());
    if (sn) {
      sn[1] = e.pressure;
      advance_anchor(p, e, r, x, sn + kNextAnchor);
    }
    const int count = response_nodes(p, e, nodes);
    for (int a = 0; a < count; ++a)
      for (int i = 0; i < 3; ++i) dofs[3 * a + i] = 3 * nodes[a] + i;
    sink.add_residual(r.dofs, dofs.data(), r.r.data());
    if (sink.tangent()) sink.add_tangent(r.dofs, dofs.data(), r.dofs, dofs.data(), r.K.data());
  }
  return MaterialStatus::ok;
}

ContactTotals SurfaceContact::totals(const Mesh& mesh, const Iterate& it) const {
  ContactTotals t;
  if (!it.state_old) return t;
  const std::vector<Vec3> x = positions(mesh, it);
  Vec3 tangential = Vec3::Zero();
  for (std::size_t k = 0; k < points_.size(); ++k) {
    const double* s = it.state_old + kStateSize * k;
    if (!(s[kWeight] > 0.0)) continue;
    const Point p = located(points_[k], s);
    const Evaluation e = evaluate(p, s, options_.augmented ? s[0] : 0.0, x);
    if (!e.engaged) continue;
    t.max_penetration = std::max(t.max_penetration, -e.gap);
    if (!(e.pressure > 0.0)) continue;
    const Response r = respond(p, e, s + kAnchor, x, false);
    const double w = p.weight;
    t.normal_force += w * e.pressure;
    tangential += w * r.tangential;
    t.force += w * (e.pressure * r.normal + r.tangential);
    t.area += current_weight(p, x);
    ++t.active_points;
    if (r.slip) ++t.slipping_points;
  }
  t.tangential_force = tangential.norm();
  return t;
}

std::vector<Vec3> SurfaceContact::active_positions(const Mesh& mesh, const Iterate& it) const {
  std::vector<Vec3> out;
  if (!it.state_old) return out;
  const std::vector<Vec3> x = positions(mesh, it);
  for (std::size_t k = 0; k < points_.size(); ++k) {
    const double* s = it.state_old + kStateSize * k;
    if (!(s[kWeight] > 0.0)) continue;
    const Point p = located(points_[k], s);
    const Evaluation e = evaluate(p, s, options_.augmented ? s[0] : 0.0, x);
    if (e.engaged && e.pressure > 0.0) out.push_back(point_position(p, x));
  }
  return out;
}

SurfaceContact::FaceValues SurfaceContact::face_values(const Mesh& mesh, const Iterate& it) const {
  FaceValues v;
  const std::size_t nf = faces_.size();
  v.pressure.assign(nf, 0.0);
  v.tangential.assign(nf, 0.0);
  v.slip.assign(nf, 0.0);
  v.gap.assign(nf, std::numeric_limits<double>::infinity());
  if (!it.state_old) return v;
  const std::vector<Vec3> x = positions(mesh, it);
  // Per face the force over its current area (Cauchy), and the slipping share of its active points.
  std::vector<double> area(nf, 0.0);
  std::vector<int> active(nf, 0);
  for (std::size_t k = 0; k < points_.size(); ++k) {
    const double* s = it.state_old + kStateSize * k;
    if (!(s[kWeight] > 0.0)) continue;
    const Point p = located(points_[k], s);
    const Evaluation e = evaluate(p, s, options_.augmented ? s[0] : 0.0, x);
    const double da = current_weight(p, x);
    area[p.face] += da;
    if (!e.engaged) continue;
    v.gap[p.face] = std::min(v.gap[p.face], e.gap);
    if (!(e.pressure > 0.0 && da > 0.0)) continue;
    const Response r = respond(p, e, s + kAnchor, x, false);
    v.pressure[p.face] += e.pressure * p.weight;
    v.tangential[p.face] += r.tangential.norm() * p.weight;
    ++active[p.face];
    if (r.slip) v.slip[p.face] += 1.0;
  }
  for (std::size_t f = 0; f < nf; ++f) {
    if (area[f] > 0.0) {
      v.pressure[f] /= area[f];
      v.tangential[f] /= area[f];
    }
    if (active[f]) v.slip[f] /= active[f];
  }
  return v;
}

}  // namespace softhom::fe
