// Periodic conforming 10-node tetrahedral meshes of a fiber cell with CGAL's Periodic_3_mesh_3
// (see fe_mesh.hpp). The only translation unit that includes CGAL's 3D mesher (slow to compile).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <tuple>
#include <unordered_map>

#include <Eigen/Dense>

// Must come first: turns off structural filtering, which the periodic traits do not support.
#include <CGAL/Periodic_3_mesh_3/config.h>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Labeled_mesh_domain_3.h>
#include <CGAL/Mesh_complex_3_in_triangulation_3.h>
#include <CGAL/Mesh_criteria_3.h>
#include <CGAL/Periodic_3_mesh_triangulation_3.h>
#include <CGAL/make_periodic_3_mesh_3.h>

#include "fiber_placement.hpp"
#include "softhom/fe/tet10.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/rve/fe_mesh.hpp"

#include "memory_budget.hpp"

namespace softhom::rve {
namespace {

using Vec2 = Eigen::Vector2d;
using Vec3d = Eigen::Vector3d;
using detail::PlacedFiber;
using detail::signed_distance;
constexpr double kPi3d = 3.14159265358979323846;

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Domain = CGAL::Labeled_mesh_domain_3<Kernel>;
using Tr = CGAL::Periodic_3_mesh_triangulation_3<Domain>::type;
using C3t3 = CGAL::Mesh_complex_3_in_triangulation_3<Tr>;
using Criteria = CGAL::Mesh_criteria_3<Tr>;
using FacetCriteria = Criteria::Facet_criteria;
using CellCriteria = Criteria::Cell_criteria;

/// Position-dependent element size for CGAL (in the coordinates of CGAL's unit cube).
struct SizeField {
  const std::function<double(const Vec3d&)>* h;
  Kernel::FT operator()(const Kernel::Point_3& p, int, const Domain::Index&) const {
    return (*h)(Vec3d(p.x(), p.y(), p.z()));
  }
};

double wrap(double x, double L) {
  double y = std::fmod(x, L);
  if (y < 0.0) y += L;
  return y;
}

/// Degree-3 rule on the reference tetrahedron (5 points, one negative weight; weights sum to 1/6):
/// the Jacobian of a P2 tetrahedron is cubic, so volumes of curved elements are exact with it.
struct Rule3 {
  std::array<Vec3d, 5> xi{Vec3d(0.25, 0.25, 0.25), Vec3d(0.5, 1.0 / 6, 1.0 / 6), Vec3d(1.0 / 6, 0.5, 1.0 / 6),
                          Vec3d(1.0 / 6, 1.0 / 6, 0.5), Vec3d(1.0 / 6, 1.0 / 6, 1.0 / 6)};
  std::array<double, 5> w{-2.0 / 15.0, 3.0 / 40.0, 3.0 / 40.0, 3.0 / 40.0, 3.0 / 40.0};
};

Eigen::Matrix3d tet10_jacobian(const CellMesh& m, int e, const Vec3d& xi) {
  const fe::Tet10Grad dN = fe::tet10_shape_derivatives(xi);
  Eigen::Matrix3d J = Eigen::Matrix3d::Zero();  // J(i, r) = ∂x_i/∂ξ_r
  for (int a = 0; a < 10; ++a) J += m.nodes[m.elements[e][a]] * dN.row(a);
  return J;
}

/// Smallest Jacobian determinant of an element over the vertices, mid-edge nodes and the rules.
double min_jacobian(const CellMesh& m, int e) {
  static const std::array<Vec3d, 11> pts{Vec3d(0, 0, 0), Vec3d(1, 0, 0), Vec3d(0, 1, 0), Vec3d(0, 0, 1),
                                         Vec3d(0.5, 0, 0), Vec3d(0.5, 0.5, 0), Vec3d(0, 0.5, 0), Vec3d(0, 0, 0.5),
                                         Vec3d(0, 0.5, 0.5), Vec3d(0.5, 0, 0.5), Vec3d(0.25, 0.25, 0.25)};
  double d = std::numeric_limits<double>::infinity();
  for (const Vec3d& xi : pts) d = std::min(d, tet10_jacobian(m, e, xi).determinant());
  for (const auto& q : fe::tet_rule_degree2()) d = std::min(d, tet10_jacobian(m, e, q.xi).determinant());
  return d;
}

}  // namespace

int CellMesh::num_masters() const {
  int n = 0;
  for (int i = 0; i < num_nodes(); ++i) n += master[i] == i;
  return n;
}

double CellMesh::volume(int phase_id) const {
  const Rule3 r;
  double v = 0.0;
  for (int e = 0; e < num_elements(); ++e) {
    if (phase[e] != phase_id) continue;
    for (int q = 0; q < 5; ++q) v += r.w[q] * tet10_jacobian(*this, e, r.xi[q]).determinant();
  }
  return v;
}

double verify_periodic_cell_mesh(const CellMesh& m) {
  const Vec3d L(m.L1, m.L2, m.L3);
  const double tol = 1e-9 * L.maxCoeff();
  double worst = 0.0;
  for (int i = 0; i < m.num_nodes(); ++i) {
    const int k = m.master[i];
    if (k < 0 || k >= m.num_nodes() || m.master[k] != k)
      throw std::runtime_error("periodic cell mesh: node " + std::to_string(i) + " has an invalid master");
    Vec3d d = m.nodes[i] - m.nodes[k];
    for (int c = 0; c < 3; ++c) d[c] -= L[c] * std::round(d[c] / L[c]);
    worst = std::max(worst, d.cwiseAbs().maxCoeff());
  }
  if (worst > tol) throw std::runtime_error("periodic cell mesh: a node is not at a periodic image of its master");
  // Faces of the torus mesh: each (sorted master triple) twice, with opposite orientations.
  std::map<std::array<int, 3>, std::pair<int, int>> faces;  // → (count, orientation sum)
  for (const auto& el : m.elements)
    for (const auto& f : fe::kTetFaces) {
      std::array<int, 3> v{m.master[el[f[0]]], m.master[el[f[1]]], m.master[el[f[2]]]};
      // Orientation sign of the cyclic order relative to the sorted order.
      int swaps = 0;
      for (int a = 0; a < 3; ++a)
        for (int b = a + 1; b < 3; ++b) swaps += v[a] > v[b];
      std::sort(v.begin(), v.end());
      if (v[0] == v[1] || v[1] == v[2]) throw std::runtime_error("periodic cell mesh: degenerate face");
      auto& s = faces[v];
      s.first += 1;
      s.second += swaps % 2 ? -1 : 1;
    }
  for (const auto& kv : faces)
    if (kv.second.first != 2 || kv.second.second != 0)
      throw std::runtime_error("periodic cell mesh: a face is shared by " + std::to_string(kv.second.first) +
                               " elements (expected 2, opposite orientations)");
  // Mid-edge nodes: the master of a mid-edge node is the mid-edge node of the master edge.
  double total = m.volume(0) + m.volume(1);
  if (std::abs(total - m.L1 * m.L2 * m.L3) > 1e-9 * m.L1 * m.L2 * m.L3)
    throw std::runtime_error("periodic cell mesh: element volumes do not add up to the cell volume");
  return worst;
}

namespace {
constexpr const char* kFoldedElement = "periodic cell mesh: an element has a non-positive Jacobian";
CellMesh mesh_cell_with_seed(const Section& section, const CellMeshOptions& options);
}  // namespace

CellMesh mesh_cell(const Section& section, const CellMeshOptions& options) {
  if (options.seed_retries < 0)
    throw InputError("solver.seed_retries", std::to_string(options.seed_retries), "must be >= 0");
  CellMeshOptions o = options;
  for (int attempt = 0;; ++attempt, ++o.seed) {
    try {
      CellMesh m = mesh_cell_with_seed(section, o);
      m.quality.seed_used = o.seed;
      return m;
    } catch (const std::runtime_error& e) {
      if (std::string(e.what()) != kFoldedElement || attempt >= options.seed_retries) throw;
    }
  }
}

namespace {
/// Tet10 elements CGAL makes for the cell (an estimate before meshing): the bulk at mesh_size plus,
/// on both sides of every fiber surface, the band where the size grows from interface_size with
/// `grading` per unit distance: ∫ dd / (0.118 (h_i + g d)³) = 1 / (0.236 g h_i²) per unit area
/// (0.118 h³ is the volume of a regular tetrahedron of edge h).
double estimated_cell_elements(const Section& section, const CellMeshOptions& o) {
  constexpr double kTetVolume = 0.1178511;  // regular tetrahedron of unit edge
  const double V = section.L1 * section.L2 * o.length;
  const double perimeter = detail::fiber_perimeter(section);
  const double g = std::max(o.grading, 1e-3), hi = o.interface_size;
  const double band = 2.0 * perimeter * o.length / (2.0 * g * kTetVolume * hi * hi);
  return V / (kTetVolume * std::pow(o.mesh_size, 3)) + band;
}

/// Refuses (InputError naming solver.mesh_size) a 3D cell whose FE solve cannot fit: bytes of the
/// mesh, the element data and the sparse Cholesky factor of its tangent, estimated from the element
/// count (unknowns per element measured; nested-dissection fill of a 3D P2 mesh
/// ≈ c n^(4/3) nonzeros for n dofs, 8 B each plus indices), against the available memory, and a
/// factor beyond the 32-bit indices of the sparse solver (which otherwise fails in its symbolic
/// analysis after minutes of meshing).
void refuse_unsolvable_cell(const Section& section, const CellMeshOptions& o) {
  const double elements = estimated_cell_elements(section, o);
  // Unknowns per estimated element, measured: the cell of rve_ecoflex_circ45_fe.toml with
  // fe_mesh = "3d" is estimated at 144 180 elements and has 1 043 084 unknowns (the regular-tetrahedron
  // volume in the element estimate overstates what a Delaunay mesh's elements hold).
  const double dofs = 7.2 * elements;
  // c from measured factors: the 1.1e6-dof macro tube has nnz(L) = 1.34e9 (c ≈ 11, a thin shell);
  // the periodic Tet10 cell above (1.04e6 unknowns) overflows 2^31 factor entries (c > 20). A compact
  // periodic cell has larger separators than a shell, so c = 25 here.
  const double factor_nnz = 25.0 * std::pow(dofs, 4.0 / 3.0);
  const double bytes = 12.0 * factor_nnz + 2.0 * 12.0 * 40.0 * dofs + 3000.0 * elements;
  std::ostringstream size;
  size << o.mesh_size << " (interface_size " << o.interface_size << ")";
  if (factor_nnz > double(std::numeric_limits<int>::max())) {
    std::ostringstream why;
    why.precision(2);
    why << "about " << elements << " elements: the Cholesky factor of the tangent (about " << factor_nnz
        << " nonzeros) exceeds the 32-bit indices of the sparse solver; coarsen the mesh";
    throw InputError("solver.mesh_size", size.str(), why.str());
  }
  detail::refuse_if_too_big(detail::saturating_product({bytes}), "solver.mesh_size", size.str());
}
}  // namespace

namespace {
/// Dihedral angles, edge lengths and radius ratios (3 r_in / r_circ) of the straight-sided (vertex)
/// tetrahedra of `m`.
void measure_tet_quality(const CellMesh& m, CellMeshQuality& q) {
  q.min_dihedral_deg = 180.0;
  q.max_dihedral_deg = 0.0;
  q.min_radius_ratio = 1.0;
  q.min_edge = std::numeric_limits<double>::infinity();
  double sum_rr = 0.0;
  for (const auto& el : m.elements) {
    const std::array<Vec3d, 4> x{m.nodes[el[0]], m.nodes[el[1]], m.nodes[el[2]], m.nodes[el[3]]};
    // Area-weighted outward normals of the faces opposite each vertex.
    std::array<Vec3d, 4> n;
    double area_sum = 0.0;
    for (int k = 0; k < 4; ++k) {
      const Vec3d &a = x[(k + 1) % 4], &b = x[(k + 2) % 4], &c = x[(k + 3) % 4];
      n[k] = 0.5 * (b - a).cross(c - a);
      if (n[k].dot(x[k] - a) > 0.0) n[k] = -n[k];
      area_sum += n[k].norm();
    }
    for (int k = 0; k < 4; ++k)
      for (int l = k + 1; l < 4; ++l) {
        const double c = std::clamp(n[k].dot(n[l]) / (n[k].norm() * n[l].norm()), -1.0, 1.0);
        const double ang = 180.0 - std::acos(c) * 180.0 / kPi3d;
        q.min_dihedral_deg = std::min(q.min_dihedral_deg, ang);
        q.max_dihedral_deg = std::max(q.max_dihedral_deg, ang);
        const double len = (x[k] - x[l]).norm();
        q.min_edge = std::min(q.min_edge, len);
        q.max_edge = std::max(q.max_edge, len);
      }
    const double V = std::abs((x[1] - x[0]).cross(x[2] - x[0]).dot(x[3] - x[0])) / 6.0;
    const double r_in = 3.0 * V / area_sum;
    Eigen::Matrix3d A;
    Vec3d rhs;
    for (int k = 0; k < 3; ++k) {
      const Vec3d d = x[k + 1] - x[0];
      A.row(k) = 2.0 * d.transpose();
      rhs[k] = d.squaredNorm();
    }
    const double R = A.fullPivLu().solve(rhs).norm();
    const double rr = 3.0 * r_in / R;
    q.min_radius_ratio = std::min(q.min_radius_ratio, rr);
    sum_rr += rr;
  }
  q.mean_radius_ratio = m.elements.empty() ? 0.0 : sum_rr / double(m.elements.size());
}

/// The options with their defaults filled in, checked (InputError naming the key), and the cell
/// refused before meshing when its FE solve cannot fit (refuse_unsolvable_cell).
CellMeshOptions normalized_cell_options(const Section& section, const CellMeshOptions& options) {
  CellMeshOptions o = options;
  const double L1 = section.L1, L2 = section.L2;
  if (o.length == 0.0) o.length = L1;
  if (!(o.length > 0.0)) throw InputError("solver.length", format_number(o.length), "must be positive");
  if (o.mesh_size == 0.0) o.mesh_size = L1 / 6.0;
  if (!(o.mesh_size > 0.0)) throw InputError("solver.mesh_size", format_number(o.mesh_size), "must be positive");
  if (o.interface_size == 0.0) o.interface_size = o.mesh_size / 2.0;
  if (!(o.interface_size > 0.0))
    throw InputError("solver.interface_size", format_number(o.interface_size), "must be positive");
  o.interface_size = std::min(o.interface_size, o.mesh_size);
  if (L1 * L2 * o.length / std::pow(o.interface_size, 3) > 2e6)
    throw InputError("solver.interface_size", format_number(o.interface_size),
                     "too small for the cell (3D mesh > ~1e7 elements)");
  refuse_unsolvable_cell(section, o);
  return o;
}

/// The cell as the 3D mesher sees it: the options (defaults filled in), the cell's lengths and the
/// placed fibers of the section (circles and rectangles in the plane, extruded along e3).
struct CellGeometry {
  CellMeshOptions o;
  double L1, L2, L3;
  Vec3d L;
  double Lmax;
  std::vector<PlacedFiber> fibers;

  CellGeometry(const Section& section, const CellMeshOptions& options)
      : o(normalized_cell_options(section, options)), L1(section.L1), L2(section.L2), L3(o.length), L(L1, L2, L3),
        Lmax(L.maxCoeff()), fibers(detail::placed_fibers(section, o.mesh_size + 0.5 * Lmax)) {}

  /// The fiber whose boundary is nearest to x (-1 without fibers), its distance in `dist`.
  int nearest(const Vec2& x, double& dist) const {
    int best = -1;
    dist = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < fibers.size(); ++k) {
      const double d = std::abs(signed_distance(fibers[k], x));
      if (d < dist) {
        dist = d;
        best = int(k);
      }
    }
    return best;
  }
  bool inside(const Vec2& x) const {
    for (const auto& p : fibers)
      if (signed_distance(p, x) < 0.0) return true;
    return false;
  }
  /// Physical point of CGAL's unit cube, wrapped into the cell.
  Vec3d physical(const Vec3d& X) const {
    return Vec3d(wrap(X[0], 1.0) * L1, wrap(X[1], 1.0) * L2, wrap(X[2], 1.0) * L3);
  }
  /// The element size CGAL bounds at a point of its unit cube.
  double cgal_size(const Vec3d& X) const {
    double h = o.mesh_size;
    if (!fibers.empty()) {
      const Vec3d x = physical(X);
      double d;
      nearest(Vec2(x[0], x[1]), d);
      h = std::min(o.mesh_size, o.interface_size + o.grading * d);
    }
    // CGAL bounds circumradii (cells) and surface Delaunay ball radii (facets); the options give
    // edge lengths as in the section mesher: a regular tetrahedron of edge h has circumradius
    // h √(3/8) = 0.61 h. The affine map stretches cube lengths by at most Lmax.
    return 0.61 * h / Lmax;
  }
  /// CGAL's subdomain label of a point of its unit cube: 2 in a fiber, 1 in the matrix.
  int label(const Kernel::Point_3& p) const {
    const Vec3d x = physical(Vec3d(p.x(), p.y(), p.z()));
    return inside(Vec2(x[0], x[1])) ? 2 : 1;
  }
  /// A vertex copy's position: the canonical one shifted by whole cells.
  Vec3d shifted(const Vec3d& x, const std::array<int, 3>& off) const {
    return x + Vec3d(off[0] * L1, off[1] * L2, off[2] * L3);
  }
  /// The circular fiber on whose surface x lies (to 1e-6 of its radius), else -1.
  int surface_circle(const Vec3d& x) const {
    const Vec2 w(wrap(x[0], L1), wrap(x[1], L2));
    double d;
    const int k = nearest(w, d);
    return k >= 0 && fibers[k].f.shape == SectionShape::circle && d <= 1e-6 * fibers[k].f.radius ? k : -1;
  }
  /// In-plane projection onto the nearest circular fiber when within max_distance · r (points given
  /// unwrapped: wrapped first, the same shift added back, so every periodic copy moves identically).
  bool project(Vec3d& x, double max_distance) const {
    Vec3d w(wrap(x[0], L1), wrap(x[1], L2), x[2]);
    const Vec3d shift = x - w;
    double d;
    const int k = nearest(Vec2(w[0], w[1]), d);
    if (k < 0 || fibers[k].f.shape != SectionShape::circle) return false;
    if (d > max_distance * fibers[k].f.radius) return false;
    const Vec2 c = fibers[k].f.center, r = Vec2(w[0], w[1]) - c;
    if (r.norm() == 0.0) return false;
    const Vec2 q = c + fibers[k].f.radius * r.normalized();
    x = Vec3d(q[0], q[1], w[2]) + shift;
    return true;
  }
};

/// CGAL's periodic mesh of the cell (in its unit cube).
C3t3 run_cgal_mesher(const CellGeometry& g) {
  const CellMeshOptions& o = g.o;
  const std::function<double(const Vec3d&)> size = [&g](const Vec3d& X) { return g.cgal_size(X); };
  std::function<int(const Kernel::Point_3&)> label = [&g](const Kernel::Point_3& p) { return g.label(p); };
  CGAL::Random rng(o.seed);
  Domain domain(label, Kernel::Iso_cuboid_3(0, 0, 0, 1, 1, 1), 1e-10, CGAL::Null_subdomain_index(), &rng);
  const SizeField sf{&size};
  // Facet distance: a fraction of the interface size (the curved mid-edge nodes then make the
  // geometry error O(h³)); facet angle and radius-edge ratio: CGAL's usual quality bounds.
  const FacetCriteria facet(o.facet_angle_deg, sf, 0.1 * o.interface_size / g.Lmax);
  const CellCriteria cell(o.radius_edge_ratio, sf);
  const Criteria criteria(facet, cell);
  CGAL::get_default_random() = CGAL::Random(o.seed);
  namespace P = CGAL::parameters;
  if (o.smoothing_iterations < 0)
    throw InputError("solver.smoothing_iterations", std::to_string(o.smoothing_iterations), "must be ≥ 0");
  // Smoothers with an iteration cap and no time limit (reproducible); perturber and exuder as CGAL's
  // defaults (no sliver bound: improve the smallest dihedral angles as long as they can).
  return CGAL::make_periodic_3_mesh_3<C3t3>(
      domain, criteria, o.odt ? P::odt(P::max_iteration_number = o.smoothing_iterations) : P::no_odt(),
      o.lloyd ? P::lloyd(P::max_iteration_number = o.smoothing_iterations) : P::no_lloyd(),
      o.perturb ? P::perturb() : P::no_perturb(), o.exude ? P::exude() : P::no_exude());
}

/// CGAL's periodic triangulation turned into the Tet10 mesh of the cell: canonical vertices, phase
/// labels (with geometric repairs), interface vertices and mid-edge nodes moved onto the fiber surfaces.
class Tet10Builder {
 public:
  Tet10Builder(const CellGeometry& g, const C3t3& c3t3);

  /// The Tet10 mesh into m. repair = true: the geometric repairs of classify(); interface vertices
  /// projected from up to vertex_limit · r. False if an element folds (the caller then retries with
  /// a safer choice).
  bool build(double vertex_limit, bool repair, CellMesh& m);

  int unlabeled = 0;  // cells outside CGAL's complex (phase from the centroid)
  int relabeled = 0, facets_not_in_complex = 0;  // of the last build
  double max_offset = 0.0;  // largest interface vertex distance from its circle / r, of the last build

 private:
  using Key3 = std::tuple<int, int, int>;
  using EdgeNodes = std::map<std::pair<int, int>, int>;  // vertex copies (sorted) → mid-edge node
  struct Corner {
    int v;
    std::array<int, 3> off;
  };

  static Key3 edge_key(int va, std::array<int, 3> oa, int vb, std::array<int, 3> ob) {
    if (va > vb) {
      std::swap(va, vb);
      std::swap(oa, ob);
    }
    const int code = (ob[0] - oa[0] + 1) + 3 * (ob[1] - oa[1] + 1) + 9 * (ob[2] - oa[2] + 1);
    return Key3(va, vb, code);
  }
  std::array<int, 3> offset_of(Tr::Cell_handle c, int i) const {
    const auto off = tr_.int_to_off(c->offset(i));
    return std::array<int, 3>{off.x(), off.y(), off.z()};
  }
  int vertex_id(Tr::Cell_handle c, int i) const { return vid_.at(c->vertex(i)); }

  void label_cells();
  void classify(bool repair);
  void relabel_surface_cells();
  void collect_interface(bool repair);
  double interface_offset() const;
  std::vector<std::array<Corner, 4>> add_vertex_nodes(CellMesh& m) const;
  void add_mid_edge_nodes(CellMesh& m, const std::vector<std::array<Corner, 4>>& cells, EdgeNodes& mid,
                          std::vector<char>& curved) const;
  void straighten_folded(CellMesh& m, const EdgeNodes& mid, std::vector<char>& curved) const;

  const CellGeometry& g_;
  const C3t3& c3t3_;
  const Tr& tr_;
  std::unordered_map<Tr::Vertex_handle, int> vid_;
  std::vector<Vec3d> canon_raw_, canon_;  // canonical vertex positions: as CGAL gives them, as built
  std::unordered_map<Tr::Cell_handle, int> cgal_phase_, cell_phase_;  // 1 fiber, 0 matrix
  std::vector<char> on_surface_;
  std::map<Key3, char> interface_edges_;
};

Tet10Builder::Tet10Builder(const CellGeometry& g, const C3t3& c3t3) : g_(g), c3t3_(c3t3), tr_(c3t3.triangulation()) {
  for (auto v = tr_.finite_vertices_begin(); v != tr_.finite_vertices_end(); ++v) {
    vid_[v] = int(canon_raw_.size());
    const auto& p = tr_.point(v);
    canon_raw_.emplace_back(p.x() * g.L1, p.y() * g.L2, p.z() * g.L3);
  }
  canon_ = canon_raw_;
  label_cells();
}

/// Phase of every cell: CGAL's subdomain; cells CGAL left out of its complex (dummy-point cells of
/// the periodic triangulation) get the label at their centroid.
void Tet10Builder::label_cells() {
  for (auto c = tr_.finite_cells_begin(); c != tr_.finite_cells_end(); ++c) {
    int sd = int(c3t3_.subdomain_index(c));
    if (sd == 0) {
      ++unlabeled;
      Vec3d x = Vec3d::Zero();
      for (int i = 0; i < 4; ++i) x += 0.25 * g_.shifted(canon_raw_[vertex_id(c, i)], offset_of(c, i));
      x = Vec3d(wrap(x[0], g_.L1), wrap(x[1], g_.L2), x[2]);
      sd = g_.inside(Vec2(x[0], x[1])) ? 2 : 1;
    }
    cgal_phase_[c] = sd == 2 ? 1 : 0;
  }
  cell_phase_ = cgal_phase_;
}

/// Phase labels and interface (curved) facets. repair = true: the geometric repairs; false: CGAL's
/// labels and surface facets as they are (the fallback when a repaired mesh folds).
void Tet10Builder::classify(bool repair) {
  cell_phase_ = cgal_phase_;
  relabeled = facets_not_in_complex = 0;
  on_surface_.assign(canon_.size(), 0);
  interface_edges_.clear();
  if (repair) relabel_surface_cells();
  collect_interface(repair);
}

/// A matrix cell whose four vertices all lie on one circular fiber surface is inside that fiber (the
/// convex hull of points on a convex surface): CGAL labels cells by their circumcentre, which for
/// such flat surface cells can lie outside. Relabelled as fiber, so the phase volumes follow the
/// geometry (measured: up to 4e-4 of the fiber volume in 1–4 such cells at L/3–L/5).
void Tet10Builder::relabel_surface_cells() {
  for (auto c = tr_.finite_cells_begin(); c != tr_.finite_cells_end(); ++c) {
    if (cell_phase_.at(c) != 0) continue;
    const int k0 = g_.surface_circle(canon_[vertex_id(c, 0)]);
    bool all = k0 >= 0;
    for (int i = 1; i < 4 && all; ++i) all = g_.surface_circle(canon_[vertex_id(c, i)]) == k0;
    if (all) {
      cell_phase_[c] = 1;
      ++relabeled;
    }
  }
}

/// Interface facets: every facet between a fiber and a matrix cell (not only CGAL's complex facets:
/// the centroid-labelled cells and the sliver exuder's relabelled cells also bound the phases, and
/// the curved geometry must follow the phase boundary the solver sees); without repair only the
/// mesher's own surface facets.
void Tet10Builder::collect_interface(bool repair) {
  for (auto c = tr_.finite_cells_begin(); c != tr_.finite_cells_end(); ++c) {
    if (cell_phase_.at(c) != 1) continue;
    for (int fi = 0; fi < 4; ++fi) {
      if (cell_phase_.at(c->neighbor(fi)) != 0) continue;
      if (!c3t3_.is_in_complex(c, fi)) {
        ++facets_not_in_complex;
        if (!repair) continue;
      }
      std::array<int, 3> idx;
      int n = 0;
      for (int i = 0; i < 4; ++i)
        if (i != fi) idx[n++] = i;
      for (int a = 0; a < 3; ++a) {
        on_surface_[vertex_id(c, idx[a])] = 1;
        const int b = (a + 1) % 3;
        interface_edges_[edge_key(vertex_id(c, idx[a]), offset_of(c, idx[a]), vertex_id(c, idx[b]),
                                  offset_of(c, idx[b]))] = 1;
      }
    }
  }
}

/// Largest distance of an interface vertex from the fiber surface (relative to the radius; circles):
/// CGAL puts surface vertices on the surface, so anything above round-off is a vertex of a phase
/// boundary facet that is not a surface facet (a geometry error of the phase volumes).
double Tet10Builder::interface_offset() const {
  double worst = 0.0;
  for (std::size_t v = 0; v < canon_.size(); ++v) {
    if (!on_surface_[v]) continue;
    const Vec2 w(wrap(canon_[v][0], g_.L1), wrap(canon_[v][1], g_.L2));
    double d;
    const int k = g_.nearest(w, d);
    if (k >= 0 && g_.fibers[k].f.shape == SectionShape::circle) worst = std::max(worst, d / g_.fibers[k].f.radius);
  }
  return worst;
}

/// The vertex nodes: one per vertex copy an element uses (master = the vertex's first copy), and the
/// elements' corners (CGAL's cells are positively oriented by exact predicates; a floating-point
/// determinant of a flat cell may have either sign, so the order is kept as CGAL gives it).
std::vector<std::array<Tet10Builder::Corner, 4>> Tet10Builder::add_vertex_nodes(CellMesh& m) const {
  std::unordered_map<long, int> copy_node;  // vertex * 27 + offset code → node
  std::vector<int> first_copy(canon_.size(), -1);
  auto vertex_node = [&](int v, const std::array<int, 3>& off) {
    const long key = long(v) * 27 + (off[0] + 1) + 3 * (off[1] + 1) + 9 * (off[2] + 1);
    auto it = copy_node.find(key);
    if (it != copy_node.end()) return it->second;
    const int id = int(m.nodes.size());
    m.nodes.push_back(g_.shifted(canon_[v], off));
    if (first_copy[v] < 0) first_copy[v] = id;
    m.master.push_back(first_copy[v]);
    copy_node.emplace(key, id);
    return id;
  };
  std::vector<std::array<Corner, 4>> cells;
  for (auto c = tr_.finite_cells_begin(); c != tr_.finite_cells_end(); ++c) {
    std::array<Corner, 4> cs;
    for (int i = 0; i < 4; ++i) cs[i] = {vertex_id(c, i), offset_of(c, i)};
    std::array<int, 10> el;
    for (int i = 0; i < 4; ++i) el[i] = vertex_node(cs[i].v, cs[i].off);
    m.elements.push_back(el);
    m.phase.push_back(cell_phase_.at(c) == 1 ? 1 : 0);
    cells.push_back(cs);
  }
  return cells;
}

/// Mid-edge nodes: one per unwrapped edge (pair of vertex copies), master = the first mid-edge node of
/// the same periodic edge; on an interface edge projected onto the circle (`curved`: per node). Mid-edge
/// nodes of an interface chord are inside by the sagitta ≤ h²/(8r); anything farther than 0.25 r is not
/// an interface node.
void Tet10Builder::add_mid_edge_nodes(CellMesh& m, const std::vector<std::array<Corner, 4>>& cells, EdgeNodes& mid,
                                      std::vector<char>& curved) const {
  std::map<Key3, int> periodic_mid;
  for (std::size_t e = 0; e < m.elements.size(); ++e) {
    auto& el = m.elements[e];
    for (int k = 0; k < 6; ++k) {
      const int a = fe::kTet10Edges[k][0], b = fe::kTet10Edges[k][1];
      const auto key = std::minmax(el[a], el[b]);
      auto it = mid.find(key);
      if (it != mid.end()) {
        el[4 + k] = it->second;
        continue;
      }
      const int id = int(m.nodes.size());
      m.nodes.push_back(0.5 * (m.nodes[el[a]] + m.nodes[el[b]]));
      const Key3 pk = edge_key(cells[e][a].v, cells[e][a].off, cells[e][b].v, cells[e][b].off);
      auto pm = periodic_mid.find(pk);
      if (pm == periodic_mid.end()) pm = periodic_mid.emplace(pk, id).first;
      m.master.push_back(pm->second);
      curved.resize(m.nodes.size(), 0);
      if (g_.o.curved_interfaces && interface_edges_.count(pk)) curved[id] = g_.project(m.nodes[id], 0.25);
      mid.emplace(key, id);
      el[4 + k] = id;
    }
  }
}

/// An element folded by the curved mid-edge nodes (possible where CGAL leaves a flat element on a
/// strongly curved surface patch) gets those mid-edge nodes back on the chords, for every periodic
/// copy of the edge.
void Tet10Builder::straighten_folded(CellMesh& m, const EdgeNodes& mid, std::vector<char>& curved) const {
  for (int pass = 0; pass < 3; ++pass) {
    std::set<int> straighten;  // masters of mid-edge nodes
    for (int e = 0; e < m.num_elements(); ++e)
      if (min_jacobian(m, e) <= 0.0)
        for (int k = 0; k < 6; ++k)
          if (curved[m.elements[e][4 + k]]) straighten.insert(m.master[m.elements[e][4 + k]]);
    if (straighten.empty()) break;
    for (const auto& kv : mid)
      if (curved[kv.second] && straighten.count(m.master[kv.second])) {
        m.nodes[kv.second] = 0.5 * (m.nodes[kv.first.first] + m.nodes[kv.first.second]);
        curved[kv.second] = 0;
      }
  }
}

// Interface vertices: CGAL's surface vertices lie on the surface to its error bound, but a phase
// boundary facet can keep a vertex CGAL did not insert on the surface (measured: a vertex 0.27 r
// outside the cylinder shared by four fiber cells at mesh_size L/4, every seed, +1.3e-3 fiber
// volume, P11 6e-4 too stiff). Those are moved onto the surface as well (up to vertex_limit · r).
bool Tet10Builder::build(double vertex_limit, bool repair, CellMesh& m) {
  canon_ = canon_raw_;
  classify(repair);
  if (g_.o.curved_interfaces)
    for (std::size_t v = 0; v < canon_.size(); ++v)
      if (on_surface_[v]) g_.project(canon_[v], vertex_limit);
  max_offset = interface_offset();
  m = CellMesh{};
  m.L1 = g_.L1;
  m.L2 = g_.L2;
  m.L3 = g_.L3;
  m.vertices = int(canon_.size());
  const std::vector<std::array<Corner, 4>> cells = add_vertex_nodes(m);
  EdgeNodes mid;
  std::vector<char> curved;  // per node: mid-edge node on a circle
  add_mid_edge_nodes(m, cells, mid, curved);
  straighten_folded(m, mid, curved);
  for (int e = 0; e < m.num_elements(); ++e)
    if (!(min_jacobian(m, e) > 0.0)) return false;
  return true;
}

CellMesh mesh_cell_with_seed(const Section& section, const CellMeshOptions& options) {
  const CellGeometry g(section, options);
  const auto t_mesh = std::chrono::steady_clock::now();
  const C3t3 c3t3 = run_cgal_mesher(g);
  const double mesher_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_mesh).count();
  if (!c3t3.triangulation().is_1_cover())
    throw std::runtime_error("periodic cell mesh: CGAL's triangulation is not a 1-cover");
  Tet10Builder builder(g, c3t3);
  CellMesh m;
  // Repaired geometry first (far interface vertices projected up to 0.5 r, surface cells relabelled);
  // if that folds an element, the 0.25 r limit of the mid-edge nodes; then CGAL's labels and surface
  // facets unchanged (measured on the VF 0.23 cell, seeds 1–3, L/3–L/6: 4 of 12 meshes need a fallback).
  if (!builder.build(0.5, true, m) && !builder.build(0.25, true, m) && !builder.build(0.25, false, m))
    throw std::runtime_error(kFoldedElement);

  CellMeshQuality& q = m.quality;
  measure_tet_quality(m, q);
  q.aspect_stretch = g.Lmax / g.L.minCoeff();
  q.unlabeled_cells = builder.unlabeled;
  q.relabeled_cells = builder.relabeled;
  q.interface_facets_not_in_complex = builder.facets_not_in_complex;
  q.max_interface_offset = builder.max_offset;
  q.mesh_seconds = mesher_seconds;
  if (std::getenv("SOFTHOM_MESH3D_DEBUG"))
    std::fprintf(stderr, "mesh_cell: %d cells outside CGAL's complex (phase from the centroid)\n", builder.unlabeled);
  for (int i = 0; i < m.num_nodes(); ++i) q.periodic_copies += m.master[i] != i;
  q.max_pairing_error = verify_periodic_cell_mesh(m);
  const double exact = detail::fiber_area(section) * g.L3;
  q.fiber_volume_error = exact > 0.0 ? std::abs(m.volume(1) - exact) / exact : 0.0;
  return m;
}
}  // namespace

}  // namespace softhom::rve
