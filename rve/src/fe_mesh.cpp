// Periodic conforming T6 meshes of fiber sections with CGAL (see fe_mesh.hpp).
#include "softhom/rve/fe_mesh.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <queue>
#include <set>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

#include <Eigen/LU>

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Delaunay_mesh_criteria_2.h>
#include <CGAL/Delaunay_mesh_face_base_2.h>
#include <CGAL/Delaunay_mesh_vertex_base_2.h>
#include <CGAL/Delaunay_mesher_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include "softhom/materials/errors.hpp"
#include "fiber_placement.hpp"
#include "memory_budget.hpp"

namespace softhom::rve {
namespace {

using Vec2 = Eigen::Vector2d;
constexpr double kPi = 3.14159265358979323846;

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Vb = CGAL::Delaunay_mesh_vertex_base_2<Kernel>;
using Fb = CGAL::Delaunay_mesh_face_base_2<Kernel>;
using Tds = CGAL::Triangulation_data_structure_2<Vb, Fb>;
using CDT = CGAL::Constrained_Delaunay_triangulation_2<Kernel, Tds, CGAL::Exact_predicates_tag>;
using Point = CDT::Point;

using detail::PlacedFiber;
using detail::placed_fibers;
using detail::signed_distance;

/// Refinement criteria: CGAL's minimum-angle test plus a size bound that depends on the position
/// (the size criteria of CGAL take one global bound only).
template <class Tr>
class SizedCriteria : public CGAL::Delaunay_mesh_criteria_2<Tr> {
 public:
  using Base = CGAL::Delaunay_mesh_criteria_2<Tr>;
  using Sizing = std::function<double(double, double)>;
  SizedCriteria(double aspect_bound, Sizing h) : Base(aspect_bound), h_(std::move(h)) {}

  /// first: squared sine of the smallest angle, second: (longest edge / local size)².
  struct Quality : public std::pair<double, double> {
    Quality() : std::pair<double, double>() {}
    Quality(double s, double z) : std::pair<double, double>(s, z) {}
    const double& size() const { return second; }
    const double& sine() const { return first; }
    bool operator<(const Quality& q) const {  // q1 < q2: q1 is refined first
      if (size() > 1) return q.size() > 1 ? size() > q.size() : true;
      if (q.size() > 1) return false;
      return sine() < q.sine();
    }
  };

  class Is_bad : public Base::Is_bad {
   public:
    Is_bad(double bound, const typename Tr::Geom_traits& traits, const Sizing* h)
        : Base::Is_bad(bound, traits), h_(h) {}
    CGAL::Mesh_2::Face_badness operator()(const Quality q) const {
      if (q.size() > 1) return CGAL::Mesh_2::IMPERATIVELY_BAD;
      return q.sine() < this->B ? CGAL::Mesh_2::BAD : CGAL::Mesh_2::NOT_BAD;
    }
    CGAL::Mesh_2::Face_badness operator()(const typename Tr::Face_handle& fh, Quality& q) const {
      const Point& pa = fh->vertex(0)->point();
      const Point& pb = fh->vertex(1)->point();
      const Point& pc = fh->vertex(2)->point();
      const double a = CGAL::to_double(CGAL::squared_distance(pb, pc));
      const double b = CGAL::to_double(CGAL::squared_distance(pc, pa));
      const double c = CGAL::to_double(CGAL::squared_distance(pa, pb));
      std::array<double, 3> e{a, b, c};
      std::sort(e.begin(), e.end());
      const double cx = (pa.x() + pb.x() + pc.x()) / 3.0, cy = (pa.y() + pb.y() + pc.y()) / 3.0;
      const double h = (*h_)(cx, cy);
      q.second = e[2] / (h * h);
      if (q.size() > 1) {
        q.first = 1;
        return CGAL::Mesh_2::IMPERATIVELY_BAD;
      }
      const double area = 2.0 * CGAL::to_double(CGAL::area(pa, pb, pc));
      q.first = area * area / (e[2] * e[1]);
      return q.sine() < this->B ? CGAL::Mesh_2::BAD : CGAL::Mesh_2::NOT_BAD;
    }

   private:
    const Sizing* h_;
  };
  Is_bad is_bad_object() const { return Is_bad(this->bound(), this->traits, &h_); }

 private:
  Sizing h_;
};

/// Chains of points along the fiber boundaries inside the cell (interface constraints).
struct Chains {
  std::vector<std::vector<Vec2>> lines;
};

bool inside_open_box(const Vec2& p, double L1, double L2) {
  return p.x() > 0.0 && p.x() < L1 && p.y() > 0.0 && p.y() < L2;
}

/// Snaps a point within `tol` of a cell edge exactly onto it.
Vec2 snap(Vec2 p, double L1, double L2, double tol) {
  if (std::abs(p.x()) < tol) p.x() = 0.0;
  if (std::abs(p.x() - L1) < tol) p.x() = L1;
  if (std::abs(p.y()) < tol) p.y() = 0.0;
  if (std::abs(p.y() - L2) < tol) p.y() = L2;
  return p;
}

void circle_chains(const PlacedFiber& p, double L1, double L2, double h, double tol, Chains& out) {
  const Vec2 c = p.f.center;
  const double r = p.f.radius;
  std::vector<double> breaks;
  auto add = [&](double a) {
    a = std::fmod(a, 2.0 * kPi);
    if (a < 0.0) a += 2.0 * kPi;
    breaks.push_back(a);
  };
  for (double X : {0.0, L1}) {
    const double d = (X - c.x()) / r;
    if (std::abs(d) < 1.0) {
      add(std::acos(d));
      add(-std::acos(d));
    }
  }
  for (double Y : {0.0, L2}) {
    const double d = (Y - c.y()) / r;
    if (std::abs(d) < 1.0) {
      add(std::asin(d));
      add(kPi - std::asin(d));
    }
  }
  std::sort(breaks.begin(), breaks.end());
  breaks.erase(std::unique(breaks.begin(), breaks.end(), [](double a, double b) { return b - a < 1e-12; }), breaks.end());
  auto at = [&](double a) { return Vec2(c.x() + r * std::cos(a), c.y() + r * std::sin(a)); };
  if (breaks.empty()) {
    if (!inside_open_box(c, L1, L2)) return;
    const int n = std::max(12, int(std::ceil(2.0 * kPi * r / h)));
    std::vector<Vec2> line;
    for (int k = 0; k <= n; ++k) line.push_back(at(2.0 * kPi * (k % n) / n));
    out.lines.push_back(std::move(line));
    return;
  }
  const std::size_t nb = breaks.size();
  for (std::size_t k = 0; k < nb; ++k) {
    const double a0 = breaks[k], a1 = k + 1 < nb ? breaks[k + 1] : breaks[0] + 2.0 * kPi;
    if (!inside_open_box(at(0.5 * (a0 + a1)), L1, L2)) continue;
    const int n = std::max(2, int(std::ceil(r * (a1 - a0) / h)));
    std::vector<Vec2> line;
    for (int i = 0; i <= n; ++i) {
      Vec2 q = at(a0 + (a1 - a0) * i / n);
      if (i == 0 || i == n) q = snap(q, L1, L2, tol);
      line.push_back(q);
    }
    out.lines.push_back(std::move(line));
  }
}

void rectangle_chains(const PlacedFiber& p, double L1, double L2, double h, double tol, Chains& out) {
  const double a = 0.5 * p.f.width, b = 0.5 * p.f.height;
  const Vec2 c = p.f.center;
  const std::array<Vec2, 4> corner{c - a * p.u - b * p.v, c + a * p.u - b * p.v, c + a * p.u + b * p.v,
                                   c - a * p.u + b * p.v};
  for (int s = 0; s < 4; ++s) {
    const Vec2 p0 = corner[s], p1 = corner[(s + 1) % 4], d = p1 - p0;
    std::vector<double> ts{0.0, 1.0};
    for (int axis = 0; axis < 2; ++axis)
      for (double X : {0.0, axis == 0 ? L1 : L2})
        if (std::abs(d[axis]) > 0.0) {
          const double t = (X - p0[axis]) / d[axis];
          if (t > 1e-12 && t < 1.0 - 1e-12) ts.push_back(t);
        }
    std::sort(ts.begin(), ts.end());
    for (std::size_t k = 0; k + 1 < ts.size(); ++k) {
      const double t0 = ts[k], t1 = ts[k + 1];
      if (t1 - t0 < 1e-12) continue;
      if (!inside_open_box(p0 + 0.5 * (t0 + t1) * d, L1, L2)) continue;
      const int n = std::max(1, int(std::ceil((t1 - t0) * d.norm() / h)));
      std::vector<Vec2> line;
      for (int i = 0; i <= n; ++i) line.push_back(snap(p0 + (t0 + (t1 - t0) * i / n) * d, L1, L2, tol));
      out.lines.push_back(std::move(line));
    }
  }
}

/// Clusters values within tol and returns the representative of each input value.
std::map<double, double> cluster(std::vector<double> v, double tol) {
  std::sort(v.begin(), v.end());
  std::map<double, double> rep;
  double current = std::numeric_limits<double>::quiet_NaN();
  for (double x : v) {
    if (!(std::abs(x - current) <= tol)) current = x;
    rep[x] = current;
  }
  return rep;
}

double triangle_area(const Vec2& a, const Vec2& b, const Vec2& c) {
  return 0.5 * ((b - a).x() * (c - a).y() - (b - a).y() * (c - a).x());
}

// Dunavant degree-4 rule (6 points), weights sum to 1.
constexpr double kQa = 0.445948490915965, kQb = 0.091576213509771;
constexpr double kWa = 0.223381589678011, kWb = 0.109951743655322;

}  // namespace

std::array<double, 6> tri6_shape(double xi, double eta) {
  const double l0 = 1.0 - xi - eta, l1 = xi, l2 = eta;
  return {l0 * (2 * l0 - 1), l1 * (2 * l1 - 1), l2 * (2 * l2 - 1), 4 * l0 * l1, 4 * l1 * l2, 4 * l2 * l0};
}

Eigen::Matrix<double, 6, 2> tri6_shape_derivatives(double xi, double eta) {
  const double l0 = 1.0 - xi - eta, l1 = xi, l2 = eta;
  Eigen::Matrix<double, 6, 2> d;
  d << -(4 * l0 - 1), -(4 * l0 - 1),  //
      4 * l1 - 1, 0.0,                //
      0.0, 4 * l2 - 1,                //
      4 * (l0 - l1), -4 * l1,         //
      4 * l2, 4 * l1,                 //
      -4 * l2, 4 * (l0 - l2);
  return d;
}

int SectionMesh::num_masters() const {
  int n = 0;
  for (int i = 0; i < num_nodes(); ++i) n += master[i] == i;
  return n;
}

double SectionMesh::area(int phase_id) const {
  static const double qp[6][3] = {{kQa, kQa, kWa}, {1 - 2 * kQa, kQa, kWa}, {kQa, 1 - 2 * kQa, kWa},
                                  {kQb, kQb, kWb}, {1 - 2 * kQb, kQb, kWb}, {kQb, 1 - 2 * kQb, kWb}};
  double a = 0.0;
  for (int e = 0; e < num_elements(); ++e) {
    if (phase[e] != phase_id) continue;
    for (const auto& q : qp) {
      const auto dN = tri6_shape_derivatives(q[0], q[1]);
      Eigen::Matrix2d J = Eigen::Matrix2d::Zero();
      for (int a6 = 0; a6 < 6; ++a6) J += nodes[elements[e][a6]] * dN.row(a6);
      a += 0.5 * q[2] * J.determinant();
    }
  }
  return a;
}

namespace {

/// Nodes of opposite edges pair where their coordinates agree to this: the boundary points are
/// clustered to one parameter per pair of edges, so they agree to round-off of the cell's size.
double pairing_tolerance(double L1, double L2) { return 1e-9 * std::max(L1, L2); }

/// Periodic masters by coordinate matching: a node on y1 = L1 maps to the node at (0, y2), one on
/// y2 = L2 to (y1, 0), chains resolved (corners → (0, 0)); a plate (periodic_y2 false) pairs the y1
/// edges only. Returns the largest mismatch.
double assign_masters(SectionMesh& m, double tol) {
  const int n = m.num_nodes();
  m.master.resize(n);
  std::map<double, int> left, bottom;  // y2 → node on y1 = 0; y1 → node on y2 = 0
  for (int i = 0; i < n; ++i) {
    m.master[i] = i;
    if (std::abs(m.nodes[i].x()) <= tol) left[m.nodes[i].y()] = i;
    if (std::abs(m.nodes[i].y()) <= tol) bottom[m.nodes[i].x()] = i;
  }
  double worst = 0.0;
  auto find = [&](const std::map<double, int>& side, double key, int node) {
    auto it = side.lower_bound(key - tol);
    if (it == side.end() || std::abs(it->first - key) > tol)
      throw std::runtime_error("periodic mesh: boundary node " + std::to_string(node) + " at (" +
                               format_number(m.nodes[node].x()) + ", " + format_number(m.nodes[node].y()) +
                               ") has no partner on the opposite edge");
    worst = std::max(worst, std::abs(it->first - key));
    return it->second;
  };
  for (int i = 0; i < n; ++i) {
    const Vec2 p = m.nodes[i];
    const bool right = std::abs(p.x() - m.L1) <= tol, top = std::abs(p.y() - m.L2) <= tol;
    if (right) m.master[i] = find(left, top && m.periodic_y2 ? 0.0 : p.y(), i);  // (L1, L2) → (0, 0)
    else if (top && m.periodic_y2) m.master[i] = find(bottom, p.x(), i);
  }
  return worst;
}

/// Corner size field of mesh_section (h(r) = max(h_min, min(h_i (r/R)^β, h_min + r/2)) for r < R).
double corner_size(double r, double R, double h_i, double h_min, double beta) {
  return std::max(h_min, std::min(h_i * std::pow(r / R, beta), h_min + 0.5 * r));
}

}  // namespace

double verify_periodic_pairing(const SectionMesh& mesh) {
  SectionMesh copy = mesh;
  const double worst = assign_masters(copy, pairing_tolerance(mesh.L1, mesh.L2));
  for (int i = 0; i < mesh.num_nodes(); ++i)
    if (copy.master[i] != mesh.master[i]) throw std::runtime_error("periodic mesh: stored master differs");
  // Every master lies on the cell and every node maps to a node at the same position modulo (L1, L2).
  for (int i = 0; i < mesh.num_nodes(); ++i) {
    Vec2 d = mesh.nodes[i] - mesh.nodes[mesh.master[i]];
    d.x() -= mesh.L1 * std::round(d.x() / mesh.L1);
    d.y() -= mesh.L2 * std::round(d.y() / mesh.L2);
    if (d.norm() > pairing_tolerance(mesh.L1, mesh.L2)) throw std::runtime_error("periodic mesh: master at another position");
  }
  return worst;
}

void make_plate(SectionMesh& mesh) {
  mesh.periodic_y2 = false;
  mesh.quality.max_pairing_error = assign_masters(mesh, pairing_tolerance(mesh.L1, mesh.L2));
}

void check_plate_section(const Section& section) {
  for (std::size_t k = 0; k < section.fibers.size(); ++k) {
    const FiberSection& f = section.fibers[k];
    const double a = f.rotation_deg * kPi / 180.0;
    const double half = f.shape == SectionShape::circle
                            ? f.radius
                            : 0.5 * (f.width * std::abs(std::sin(a)) + f.height * std::abs(std::cos(a)));
    if (f.center.y() - half < 0.0 || f.center.y() + half > section.L2)
      throw InputError("microstructure.cell", "\"plate\"",
                       "fiber " + std::to_string(k) + " (y2 from " + format_number(f.center.y() - half) + " to " +
                           format_number(f.center.y() + half) + ") cuts a free face of the plate (y2 = 0 or " +
                           format_number(section.L2) + "): a plate is one layer of whole fibers (arrangement = \"square\")");
  }
}

namespace {

/// The options with their defaults filled in, checked (InputError naming the key).
SectionMeshOptions normalized_options(const Section& section, const SectionMeshOptions& options) {
  const double L1 = section.L1, L2 = section.L2;
  SectionMeshOptions o = options;
  if (o.mesh_size == 0.0) o.mesh_size = L1 / 16.0;
  if (!(o.mesh_size > 0.0)) throw InputError("solver.mesh_size", format_number(o.mesh_size), "must be positive");
  if (o.interface_size == 0.0) o.interface_size = o.mesh_size / 3.0;
  if (!(o.interface_size > 0.0))
    throw InputError("solver.interface_size", format_number(o.interface_size), "must be positive");
  o.interface_size = std::min(o.interface_size, o.mesh_size);
  if (L1 * L2 / (o.interface_size * o.interface_size) > 4e7)
    throw InputError("solver.interface_size", format_number(o.interface_size), "too small for the cell (mesh > 1e7 elements)");
  if (!(o.min_angle_deg > 0.0 && o.min_angle_deg <= 30.0))
    throw InputError("solver.min_angle_deg", format_number(o.min_angle_deg), "must lie in (0, 30]");
  if (o.corner_refinement) {
    if (!(o.corner_exponent > 0.0 && o.corner_exponent < 1.0))
      throw InputError("solver.corner_exponent", format_number(o.corner_exponent), "must lie in (0, 1)");
    if (!(o.corner_min_size_ratio > 0.0 && o.corner_min_size_ratio <= 1.0))
      throw InputError("solver.corner_min_size_ratio", format_number(o.corner_min_size_ratio), "must lie in (0, 1]");
  }
  return o;
}

/// T6 elements CGAL makes for the section (an estimate before meshing). Measured: a section meshed at a
/// uniform size h has A / (0.2 h²) triangles (the ecoflex FE cell, 0.546 mm² at h = 0.01: 27 258). The
/// size grows from interface_size with `grading` per unit distance on both sides of every fiber boundary:
/// ∫ dd / (0.2 (h_i + g d)²) = (1/h_i − 1/h_m) / (0.2 g) per unit length of boundary; never more than the
/// whole section at interface_size (grading → 0).
double estimated_section_elements(const Section& section, const SectionMeshOptions& o) {
  constexpr double kTriangleArea = 0.2;  // mesh triangles per h², measured above
  const double A = section.L1 * section.L2, hi = o.interface_size, hm = o.mesh_size;
  const double band = 2.0 * detail::fiber_perimeter(section) * (1.0 / hi - 1.0 / hm) / (kTriangleArea * o.grading);
  return std::min(A / (kTriangleArea * hi * hi), A / (kTriangleArea * hm * hm) + band);
}

/// Refuses (InputError naming solver.interface_size) a section whose FE solve cannot fit, before
/// meshing. Bytes per element measured (peak of a one-step run): uniform meshes of that cell at h = 0.01
/// (27 258 elements) and 0.005 (108 982) peak at 0.80 and 3.15 GB, 29 kB per element (mesh, element
/// state, the mixed system and its factor).
void refuse_unsolvable_section(const Section& section, const SectionMeshOptions& o) {
  constexpr double kBytesPerElement = 29e3;
  const double elements = estimated_section_elements(section, o);
  std::ostringstream why;
  why.precision(2);
  why << "about " << elements << " elements at mesh_size " << format_number(o.mesh_size) << ", grading "
      << format_number(o.grading);
  detail::refuse_if_too_big(detail::saturating_product({elements, kBytesPerElement}), "solver.interface_size",
                            format_number(o.interface_size), 0, why.str());
}

/// A corner of a rectangular fiber (stress singularity) refined by power grading within radius R.
struct CornerRefinement {
  Vec2 x;
  double R, h_min;
};

/// The corners of rectangular fibers that are real corners of the fiber union (not shared with a
/// touching periodic image) and near the cell, with their grading radius and smallest size.
std::vector<CornerRefinement> corner_refinements(const std::vector<PlacedFiber>& fibers, const SectionMeshOptions& o,
                                                 double L1, double L2) {
  std::vector<CornerRefinement> corners;
  if (!o.corner_refinement) return corners;
  for (std::size_t k = 0; k < fibers.size(); ++k) {
    if (fibers[k].f.shape != SectionShape::rectangle) continue;
    const double R = 0.5 * std::min(fibers[k].f.width, fibers[k].f.height);
    for (const Vec2& c : detail::rectangle_corners(fibers[k])) {
      bool shared = false;
      for (std::size_t j = 0; j < fibers.size(); ++j)
        if (j != k && signed_distance(fibers[j], c) <= 1e-9 * std::max(L1, L2)) shared = true;
      if (shared || c.x() < -R || c.x() > L1 + R || c.y() < -R || c.y() > L2 + R) continue;
      const double ratio = std::min(1.0, o.interface_size / R);
      const double h_min = std::max({R * std::pow(ratio, 1.0 / (1.0 - o.corner_exponent)), 1e-5 * std::max(L1, L2),
                                     o.corner_min_size_ratio * o.interface_size});
      corners.push_back({c, R, h_min});
    }
  }
  return corners;
}

/// The interface chains of all fibers, with their end points on the cell boundary made
/// periodic-consistent (points of opposite edges clustered to one parameter). Returns the clustered
/// parameters of the boundary points: y2 of points on y1 = 0 / L1 (rep_x), y1 on y2 = 0 / L2 (rep_y).
Chains periodic_interface_chains(const std::vector<PlacedFiber>& fibers, double L1, double L2, double h, double tol,
                                 std::map<double, double>& rep_x, std::map<double, double>& rep_y) {
  Chains chains;
  for (const auto& p : fibers) {
    if (p.f.shape == SectionShape::circle) circle_chains(p, L1, L2, h, tol, chains);
    else rectangle_chains(p, L1, L2, h, tol, chains);
  }
  std::vector<double> on_x, on_y;  // y2 of points on y1 = 0 / L1; y1 of points on y2 = 0 / L2
  for (const auto& line : chains.lines)
    for (const Vec2& q : line) {
      if (q.x() == 0.0 || q.x() == L1) on_x.push_back(q.y());
      if (q.y() == 0.0 || q.y() == L2) on_y.push_back(q.x());
    }
  rep_x = cluster(on_x, 1e3 * tol);
  rep_y = cluster(on_y, 1e3 * tol);
  for (auto& line : chains.lines)
    for (Vec2& q : line) {
      if (q.x() == 0.0 || q.x() == L1) q.y() = rep_x.at(q.y());
      if (q.y() == 0.0 || q.y() == L2) q.x() = rep_y.at(q.x());
    }
  return chains;
}

using SizeFunction = std::function<double(double, double)>;
using EdgeNodes = std::map<std::pair<int, int>, int>;  // vertex pair (sorted) → mid-side node

/// Parameters along one cell edge (0 … L, the interface crossings `reps` included) at the local size;
/// the same on opposite edges.
std::vector<double> edge_parameters(const std::map<double, double>& reps, double L, bool vertical,
                                    const SizeFunction& size) {
  std::vector<double> br{0.0, L};
  for (const auto& kv : reps)
    if (kv.second > 0.0 && kv.second < L) br.push_back(kv.second);
  std::sort(br.begin(), br.end());
  br.erase(std::unique(br.begin(), br.end()), br.end());
  std::vector<double> t;
  for (std::size_t k = 0; k + 1 < br.size(); ++k) {
    const double a = br[k], b = br[k + 1], mid = 0.5 * (a + b);
    const double h = vertical ? size(0.0, mid) : size(mid, 0.0);
    const int n = std::max(1, int(std::ceil((b - a) / h)));
    for (int i = 0; i < n; ++i) t.push_back(a + (b - a) * i / n);
  }
  t.push_back(L);
  return t;
}

/// The constraints of the section: the cell boundary (the same parameters on opposite edges) and the
/// interface chains.
void insert_constraints(CDT& cdt, const Chains& chains, const std::map<double, double>& rep_x,
                        const std::map<double, double>& rep_y, double L1, double L2, double tol,
                        const SizeFunction& size) {
  const std::vector<double> ty = edge_parameters(rep_x, L2, true, size), tx = edge_parameters(rep_y, L1, false, size);
  for (std::size_t k = 0; k + 1 < ty.size(); ++k) {
    cdt.insert_constraint(Point(0.0, ty[k]), Point(0.0, ty[k + 1]));
    cdt.insert_constraint(Point(L1, ty[k]), Point(L1, ty[k + 1]));
  }
  for (std::size_t k = 0; k + 1 < tx.size(); ++k) {
    cdt.insert_constraint(Point(tx[k], 0.0), Point(tx[k + 1], 0.0));
    cdt.insert_constraint(Point(tx[k], L2), Point(tx[k + 1], L2));
  }
  for (const auto& line : chains.lines)
    for (std::size_t k = 0; k + 1 < line.size(); ++k)
      if ((line[k] - line[k + 1]).norm() > tol)
        cdt.insert_constraint(Point(line[k].x(), line[k].y()), Point(line[k + 1].x(), line[k + 1].y()));
}

/// Boundary vertices without a partner on the opposite edge, mirrored there (exact coordinates: the
/// edges are the lines y1 = 0, L1 and y2 = 0, L2, which every Steiner point on them satisfies exactly).
std::vector<Point> unpaired_boundary_mirrors(const CDT& cdt, double L1, double L2) {
  std::vector<double> x0, x1, y0, y1;
  for (auto v = cdt.finite_vertices_begin(); v != cdt.finite_vertices_end(); ++v) {
    const double x = v->point().x(), y = v->point().y();
    if (x == 0.0) x0.push_back(y);
    if (x == L1) x1.push_back(y);
    if (y == 0.0) y0.push_back(x);
    if (y == L2) y1.push_back(x);
  }
  for (auto* a : {&x0, &x1, &y0, &y1}) std::sort(a->begin(), a->end());
  std::vector<Point> add;
  auto mirror = [&](const std::vector<double>& from, const std::vector<double>& to, bool vertical, double c) {
    for (double v : from)
      if (!std::binary_search(to.begin(), to.end(), v)) add.push_back(vertical ? Point(c, v) : Point(v, c));
  };
  mirror(x0, x1, true, L1);
  mirror(x1, x0, true, 0.0);
  mirror(y0, y1, false, L2);
  mirror(y1, y0, false, 0.0);
  return add;
}

/// Refines until every boundary vertex has its periodic partner (the refinement passes and mirrored
/// points counted in `quality`).
void refine_periodic(CDT& cdt, const SizedCriteria<CDT>& criteria, double L1, double L2, SectionMeshQuality& quality) {
  for (int pass = 0;; ++pass) {
    if (pass > 20) throw std::runtime_error("periodic mesh: boundary vertices did not pair up after 20 passes");
    CGAL::Delaunay_mesher_2<CDT, SizedCriteria<CDT>> mesher(cdt, criteria);
    mesher.refine_mesh();
    quality.refinement_passes = pass + 1;
    const std::vector<Point> add = unpaired_boundary_mirrors(cdt, L1, L2);
    if (add.empty()) break;
    quality.mirrored_points += int(add.size());
    for (const Point& p : add) cdt.insert(p);
  }
}

/// Phase of every face: components of faces connected across unconstrained edges, classified by an
/// area-weighted vote of their centroids (robust to the polygonal approximation of the circles).
std::vector<int> face_phases(const CDT& cdt, const std::vector<CDT::Face_handle>& faces,
                             const std::vector<PlacedFiber>& fibers) {
  const int ne = int(faces.size());
  std::unordered_map<CDT::Face_handle, int> fid;
  for (int e = 0; e < ne; ++e) fid[faces[e]] = e;
  std::vector<int> comp(ne, -1);
  int ncomp = 0;
  std::vector<double> comp_in, comp_all;
  for (int e0 = 0; e0 < ne; ++e0) {
    if (comp[e0] >= 0) continue;
    comp_in.push_back(0.0);
    comp_all.push_back(0.0);
    std::queue<int> q;
    q.push(e0);
    comp[e0] = ncomp;
    while (!q.empty()) {
      const int e = q.front();
      q.pop();
      const auto f = faces[e];
      const Vec2 a(f->vertex(0)->point().x(), f->vertex(0)->point().y());
      const Vec2 b(f->vertex(1)->point().x(), f->vertex(1)->point().y());
      const Vec2 c(f->vertex(2)->point().x(), f->vertex(2)->point().y());
      const double A = triangle_area(a, b, c);
      const Vec2 g = (a + b + c) / 3.0;
      bool inside = false;
      for (const auto& p : fibers) inside = inside || signed_distance(p, g) < 0.0;
      comp_all[ncomp] += A;
      if (inside) comp_in[ncomp] += A;
      for (int i = 0; i < 3; ++i) {
        if (f->is_constrained(i)) continue;
        const auto n = f->neighbor(i);
        if (cdt.is_infinite(n)) continue;
        const int en = fid.at(n);
        if (comp[en] < 0) {
          comp[en] = ncomp;
          q.push(en);
        }
      }
    }
    ++ncomp;
  }
  std::vector<int> phase(ne);
  for (int e = 0; e < ne; ++e) phase[e] = comp_in[comp[e]] > 0.5 * comp_all[comp[e]] ? 1 : 0;
  return phase;
}

/// The T6 elements of the triangulation (all finite faces: the domain is the whole cell): vertices
/// numbered in CGAL's order, then one mid-side node per edge (`mid`); `constrained` gets the edges on
/// constraints (interfaces and cell boundary).
void add_t6_elements(const CDT& cdt, const std::vector<PlacedFiber>& fibers, SectionMesh& m, EdgeNodes& mid,
                     std::set<std::pair<int, int>>& constrained) {
  std::unordered_map<CDT::Vertex_handle, int> vid;
  for (auto v = cdt.finite_vertices_begin(); v != cdt.finite_vertices_end(); ++v) {
    vid[v] = int(m.nodes.size());
    m.nodes.emplace_back(v->point().x(), v->point().y());
  }
  m.vertices = int(m.nodes.size());
  std::vector<CDT::Face_handle> faces;
  for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) faces.push_back(f);
  const int ne = int(faces.size());
  m.phase = face_phases(cdt, faces, fibers);
  m.elements.resize(ne);
  auto midnode = [&](int a, int b) {
    const auto key = std::minmax(a, b);
    auto it = mid.find(key);
    if (it != mid.end()) return it->second;
    const int id = int(m.nodes.size());
    m.nodes.push_back(0.5 * (m.nodes[a] + m.nodes[b]));
    mid.emplace(key, id);
    return id;
  };
  for (int e = 0; e < ne; ++e) {
    const auto f = faces[e];
    std::array<int, 6> t;
    for (int i = 0; i < 3; ++i) t[i] = vid.at(f->vertex(i));
    for (int i = 0; i < 3; ++i)
      if (f->is_constrained(i)) constrained.insert(std::minmax(t[(i + 1) % 3], t[(i + 2) % 3]));
    t[3] = midnode(t[0], t[1]);
    t[4] = midnode(t[1], t[2]);
    t[5] = midnode(t[2], t[0]);
    m.elements[e] = t;
  }
}

/// Curved interfaces. The mesher splits interface constraints at chord midpoints (inside the
/// circle by the sagitta h²/8r), so first every vertex of an interface edge goes back onto its
/// circle (except the chain ends on the cell edges, which are exact intersections), then the
/// mid-side node of the edge follows.
void curve_interfaces(SectionMesh& m, const EdgeNodes& mid, const std::set<std::pair<int, int>>& constrained,
                      const std::vector<PlacedFiber>& fibers) {
  std::vector<int> on_circle(m.vertices, -1);
  std::vector<std::pair<std::pair<int, int>, int>> curved_edges;
  for (const auto& key : constrained) {
    const Vec2 a = m.nodes[key.first], b = m.nodes[key.second];
    int best = -1;
    double best_d = 0.25 * (a - b).norm();
    for (std::size_t k = 0; k < fibers.size(); ++k) {
      if (fibers[k].f.shape != SectionShape::circle) continue;
      const double d = std::max(std::abs(signed_distance(fibers[k], a)), std::abs(signed_distance(fibers[k], b)));
      if (d < best_d) {
        best_d = d;
        best = int(k);
      }
    }
    if (best < 0) continue;
    on_circle[key.first] = on_circle[key.second] = best;
    curved_edges.push_back({key, best});
  }
  auto project = [&](Vec2& x, int k) {
    const Vec2 c = fibers[k].f.center, d = x - c;
    if (d.norm() > 0.0) x = c + fibers[k].f.radius * d.normalized();
  };
  for (int v = 0; v < m.vertices; ++v) {
    Vec2& x = m.nodes[v];
    if (on_circle[v] < 0 || x.x() == 0.0 || x.x() == m.L1 || x.y() == 0.0 || x.y() == m.L2) continue;
    project(x, on_circle[v]);
  }
  for (const auto& kv : mid) m.nodes[kv.second] = 0.5 * (m.nodes[kv.first.first] + m.nodes[kv.first.second]);
  for (const auto& ce : curved_edges) project(m.nodes[mid.at(ce.first)], ce.second);
}

/// Angles, edge lengths and radius ratios (2 r_in / r_circ) of the straight-sided (vertex) triangles.
void measure_triangle_quality(const SectionMesh& m, SectionMeshQuality& quality) {
  quality.min_angle_deg = 180.0;
  quality.max_angle_deg = 0.0;
  quality.min_radius_ratio = 1.0;
  quality.min_edge = std::numeric_limits<double>::infinity();
  double sum_rr = 0.0;
  for (const auto& t : m.elements) {
    const Vec2 p[3] = {m.nodes[t[0]], m.nodes[t[1]], m.nodes[t[2]]};
    double len[3];
    for (int i = 0; i < 3; ++i) len[i] = (p[(i + 1) % 3] - p[(i + 2) % 3]).norm();  // opposite vertex i
    for (int i = 0; i < 3; ++i) {
      const Vec2 u = p[(i + 1) % 3] - p[i], v = p[(i + 2) % 3] - p[i];
      const double ang = std::acos(std::clamp(u.dot(v) / (u.norm() * v.norm()), -1.0, 1.0)) * 180.0 / kPi;
      quality.min_angle_deg = std::min(quality.min_angle_deg, ang);
      quality.max_angle_deg = std::max(quality.max_angle_deg, ang);
      quality.min_edge = std::min(quality.min_edge, len[i]);
      quality.max_edge = std::max(quality.max_edge, len[i]);
    }
    const double A = std::abs(triangle_area(p[0], p[1], p[2]));
    const double sp = 0.5 * (len[0] + len[1] + len[2]);
    const double r_in = A / sp, r_circ = len[0] * len[1] * len[2] / (4.0 * A);
    const double rr = 2.0 * r_in / r_circ;
    quality.min_radius_ratio = std::min(quality.min_radius_ratio, rr);
    sum_rr += rr;
  }
  quality.mean_radius_ratio = m.elements.empty() ? 0.0 : sum_rr / double(m.elements.size());
}

}  // namespace

SectionMesh mesh_section(const Section& section, const SectionMeshOptions& options) {
  const double L1 = section.L1, L2 = section.L2;
  const SectionMeshOptions o = normalized_options(section, options);
  refuse_unsolvable_section(section, o);
  const double tol = 1e-10 * std::max(L1, L2);

  const std::vector<PlacedFiber> fibers = placed_fibers(section);
  auto distance = [&](double x, double y) {
    double d = std::numeric_limits<double>::infinity();
    for (const auto& p : fibers) d = std::min(d, std::abs(signed_distance(p, Vec2(x, y))));
    return d;
  };
  const std::vector<CornerRefinement> corners = corner_refinements(fibers, o, L1, L2);
  const SizeFunction size = [&](double x, double y) {
    if (fibers.empty()) return o.mesh_size;
    double h = std::min(o.mesh_size, o.interface_size + o.grading * distance(x, y));
    for (const auto& c : corners) {
      const double r = (Vec2(x, y) - c.x).norm();
      if (r >= c.R) continue;
      // Power grading, and at most 0.5 growth per unit distance so neighbours stay comparable.
      h = std::min(h, corner_size(r, c.R, o.interface_size, c.h_min, o.corner_exponent));
    }
    return h;
  };

  std::map<double, double> rep_x, rep_y;
  const Chains chains = periodic_interface_chains(fibers, L1, L2, o.interface_size, tol, rep_x, rep_y);
  CDT cdt;
  insert_constraints(cdt, chains, rep_x, rep_y, L1, L2, tol, size);
  const double s = std::sin(o.min_angle_deg * kPi / 180.0);
  const SizedCriteria<CDT> criteria(s * s, size);
  SectionMeshQuality quality;
  refine_periodic(cdt, criteria, L1, L2, quality);

  SectionMesh m;
  m.L1 = L1;
  m.L2 = L2;
  EdgeNodes mid;
  std::set<std::pair<int, int>> constrained;
  add_t6_elements(cdt, fibers, m, mid, constrained);
  if (o.curved_interfaces) curve_interfaces(m, mid, constrained, fibers);
  quality.max_pairing_error = assign_masters(m, pairing_tolerance(L1, L2));
  measure_triangle_quality(m, quality);
  const double exact = detail::fiber_area(section);
  quality.fiber_area_error = exact > 0.0 ? std::abs(m.area(1) - exact) / exact : 0.0;
  quality.refined_corners = int(corners.size());
  for (const auto& c : corners)
    quality.min_corner_size = quality.min_corner_size == 0.0 ? c.h_min : std::min(quality.min_corner_size, c.h_min);
  m.quality = quality;
  return m;
}

}  // namespace softhom::rve
