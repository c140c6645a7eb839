// Locating fiber nodes in their hosts (fibers.hpp): a uniform grid of bounding boxes and the inverse
// isoparametric map of hex8 and tet10 elements, or the closest point on quad4 and tri6 faces.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "softhom/fe/fibers.hpp"
#include "softhom/fe/hex8.hpp"
#include "softhom/fe/tet10.hpp"

namespace softhom::fe {
namespace {

/// Shape functions of a face at (ξ, η) and their derivatives: bilinear quad on [-1, 1]², or the
/// 6-node triangle (vertices, then the mid-edge nodes of v0v1, v1v2, v2v0) on ξ, η ≥ 0, ξ + η ≤ 1.
void face_shape(int n, const Eigen::Vector2d& s, Eigen::VectorXd& N, Eigen::MatrixXd& dN) {
  N.resize(n);
  dN.resize(n, 2);
  if (n == 4) {
    static constexpr int c[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    for (int a = 0; a < 4; ++a) {
      N[a] = 0.25 * (1 + c[a][0] * s[0]) * (1 + c[a][1] * s[1]);
      dN(a, 0) = 0.25 * c[a][0] * (1 + c[a][1] * s[1]);
      dN(a, 1) = 0.25 * (1 + c[a][0] * s[0]) * c[a][1];
    }
    return;
  }
  const double L[3] = {1 - s[0] - s[1], s[0], s[1]};
  const double dL[3][2] = {{-1, -1}, {1, 0}, {0, 1}};
  static constexpr int e[3][2] = {{0, 1}, {1, 2}, {2, 0}};
  for (int a = 0; a < 3; ++a) {
    N[a] = L[a] * (2 * L[a] - 1);
    for (int j = 0; j < 2; ++j) dN(a, j) = (4 * L[a] - 1) * dL[a][j];
  }
  for (int k = 0; k < 3; ++k) {
    const int i = e[k][0], m = e[k][1];
    N[3 + k] = 4 * L[i] * L[m];
    for (int j = 0; j < 2; ++j) dN(3 + k, j) = 4 * (dL[i][j] * L[m] + L[i] * dL[m][j]);
  }
}

bool inside_reference(bool tet, const Vec3& xi, double slack) {
  if (tet) return xi.minCoeff() >= -slack && xi.sum() <= 1.0 + slack;
  return xi.cwiseAbs().maxCoeff() <= 1.0 + slack;
}

std::array<Vec3, 2> box_of(const Mesh& mesh, const int* nodes, int count) {
  std::array<Vec3, 2> b{mesh.nodes[nodes[0]], mesh.nodes[nodes[0]]};
  for (int a = 1; a < count; ++a) {
    b[0] = b[0].cwiseMin(mesh.nodes[nodes[a]]);
    b[1] = b[1].cwiseMax(mesh.nodes[nodes[a]]);
  }
  // Curved quadratic edges and faceted surfaces may bulge past their nodes: pad by a tenth.
  const Vec3 pad = Vec3::Constant(0.1 * (b[1] - b[0]).norm());
  return {b[0] - pad, b[1] + pad};
}

}  // namespace

Vec3 HostPoint::position(const std::vector<Vec3>& x) const {
  Vec3 p = Vec3::Zero();
  for (int a = 0; a < count; ++a) p += weights[a] * x[nodes[a]];
  return p;
}

bool element_inverse_map(const Mesh& mesh, int e, const Vec3& X, double slack, Vec3& xi) {
  const bool tet = mesh.is_tet(e);
  const int n = mesh.element_size(e);
  const int* nodes = mesh.element_nodes(e);
  xi = tet ? Vec3::Constant(0.25) : Vec3::Zero();
  for (int iter = 0; iter < 30; ++iter) {
    Eigen::Matrix<double, 10, 1> N;
    Eigen::Matrix<double, 10, 3> dN;
    if (tet) {
      N = tet10_shape(xi);
      dN = tet10_shape_derivatives(xi);
    } else {
      N.head<8>() = hex8_shape(xi);
      dN.topRows<8>() = hex8_shape_derivatives(xi);
    }
    Vec3 x = Vec3::Zero();
    Mat3 J = Mat3::Zero();
    for (int a = 0; a < n; ++a) {
      x += N[a] * mesh.nodes[nodes[a]];
      J += mesh.nodes[nodes[a]] * dN.row(a);
    }
    const Vec3 step = J.lu().solve(X - x);
    if (!step.allFinite()) return false;
    xi += step;
    if (xi.cwiseAbs().maxCoeff() > 10.0) return false;  // far outside: not this element
    if (step.norm() < 1e-14) break;
  }
  return inside_reference(tet, xi, slack);
}

void HostLocator::bin(const std::vector<std::array<Vec3, 2>>& boxes) {
  if (boxes.empty()) {
    offsets_.assign(2, 0);
    return;
  }
  Vec3 lo = boxes[0][0], hi = boxes[0][1];
  double mean = 0.0;
  sizes_.clear();
  for (const auto& b : boxes) {
    lo = lo.cwiseMin(b[0]);
    hi = hi.cwiseMax(b[1]);
    sizes_.push_back((b[1] - b[0]).norm());
    mean += (b[1] - b[0]).maxCoeff() / double(boxes.size());
  }
  // About one box per bin along each direction, and no more bins than 8 per box in all.
  const Vec3 extent = (hi - lo).cwiseMax(1e-12);
  double h = std::max(mean, std::cbrt(extent.prod() / (8.0 * boxes.size())));
  for (int d = 0; d < 3; ++d) dims_[d] = std::max(1, int(std::ceil(extent[d] / h)));
  lo_ = lo;
  cell_ = Vec3(extent[0] / dims_[0], extent[1] / dims_[1], extent[2] / dims_[2]);
  auto index = [&](const Vec3& x, int d) { return std::clamp(int(std::floor((x[d] - lo_[d]) / cell_[d])), 0, dims_[d] - 1); };
  const int bins = dims_[0] * dims_[1] * dims_[2];
  std::vector<std::vector<int>> per_bin(bins);
  for (int k = 0; k < int(boxes.size()); ++k) {
    const auto& b = boxes[k];
    for (int z = index(b[0], 2); z <= index(b[1], 2); ++z)
      for (int y = index(b[0], 1); y <= index(b[1], 1); ++y)
        for (int x = index(b[0], 0); x <= index(b[1], 0); ++x) per_bin[x + dims_[0] * (y + dims_[1] * z)].push_back(k);
  }
  offsets_.assign(1, 0);
  items_.clear();
  for (const auto& v : per_bin) {
    items_.insert(items_.end(), v.begin(), v.end());
    offsets_.push_back(int(items_.size()));
  }
}

HostLocator::HostLocator(const Mesh& mesh) : mesh_(mesh) {
  std::vector<std::array<Vec3, 2>> boxes;
  for (int e = 0; e < mesh.num_elements(); ++e) boxes.push_back(box_of(mesh, mesh.element_nodes(e), mesh.element_size(e)));
  bin(boxes);
}

HostLocator::HostLocator(const Mesh& mesh, const std::vector<Quad>& quads, const std::vector<Tri6>& tris,
                         double relative_gap)
    : mesh_(mesh), faces_(true), quads_(quads), tris_(tris), relative_gap_(relative_gap) {
  std::vector<std::array<Vec3, 2>> boxes;
  for (const Quad& q : quads_) boxes.push_back(box_of(mesh, q.data(), 4));
  for (const Tri6& t : tris_) boxes.push_back(box_of(mesh, t.data(), 6));
  bin(boxes);
}

std::optional<HostPoint> HostLocator::locate_in_element(int e, const Vec3& X) const {
  Vec3 xi;
  if (!element_inverse_map(mesh_, e, X, 1e-8, xi)) return std::nullopt;
  HostPoint h;
  h.element = e;
  h.count = mesh_.element_size(e);
  const int* nodes = mesh_.element_nodes(e);
  Eigen::Matrix<double, 10, 1> N;
  if (mesh_.is_tet(e)) N = tet10_shape(xi);
  else N.head<8>() = hex8_shape(xi);
  for (int a = 0; a < h.count; ++a) {
    h.nodes[a] = nodes[a];
    h.weights[a] = N[a];
  }
  return h;
}

std::optional<HostPoint> HostLocator::locate_on_face(int f, const Vec3& X, double& distance) const {
  const bool quad = f < int(quads_.size());
  const int n = quad ? 4 : 6;
  const int* nodes = quad ? quads_[f].data() : tris_[f - quads_.size()].data();
  Eigen::Vector2d s = quad ? Eigen::Vector2d::Zero() : Eigen::Vector2d::Constant(1.0 / 3.0);
  Eigen::VectorXd N;
  Eigen::MatrixXd dN;
  Vec3 x = Vec3::Zero();
  // Gauss-Newton on the distance |x(ξ, η) − X|² (the closest point of a curved face).
  for (int iter = 0; iter < 40; ++iter) {
    face_shape(n, s, N, dN);
    x.setZero();
    Eigen::Matrix<double, 3, 2> J = Eigen::Matrix<double, 3, 2>::Zero();
    for (int a = 0; a < n; ++a) {
      x += N[a] * mesh_.nodes[nodes[a]];
      J += mesh_.nodes[nodes[a]] * dN.row(a);
    }
    const Eigen::Vector2d step = (J.transpose() * J).ldlt().solve(J.transpose() * (X - x));
    if (!step.allFinite()) return std::nullopt;
    s += step;
    if (s.cwiseAbs().maxCoeff() > 10.0) return std::nullopt;
    if (step.norm() < 1e-14) break;
  }
  face_shape(n, s, N, dN);
  x.setZero();
  for (int a = 0; a < n; ++a) x += N[a] * mesh_.nodes[nodes[a]];
  const double slack = 1e-8;
  const bool inside = quad ? s.cwiseAbs().maxCoeff() <= 1 + slack : s.minCoeff() >= -slack && s.sum() <= 1 + slack;
  distance = (x - X).norm();
  if (!inside || distance > relative_gap_ * sizes_[f]) return std::nullopt;
  HostPoint h;
  h.element = f;
  h.count = n;
  for (int a = 0; a < n; ++a) {
    h.nodes[a] = nodes[a];
    h.weights[a] = N[a];
  }
  return h;
}

std::optional<HostPoint> HostLocator::locate(const Vec3& X) const {
  int b = 0;
  for (int d = 2; d >= 0; --d) {
    const double t = (X[d] - lo_[d]) / cell_[d];
    if (!(t >= -1e-9 && t <= dims_[d] + 1e-9)) return std::nullopt;  // outside every box
    b = b * dims_[d] + std::clamp(int(std::floor(t)), 0, dims_[d] - 1);
  }
  std::optional<HostPoint> best;
  double best_distance = 0.0;
  for (int k = offsets_[b]; k < offsets_[b + 1]; ++k) {
    const int item = items_[k];
    if (!faces_) {
      if (auto h = locate_in_element(item, X)) return h;
      continue;
    }
    double distance = 0.0;
    auto h = locate_on_face(item, X, distance);
    if (h && (!best || distance < best_distance)) {
      best = h;
      best_distance = distance;
    }
  }
  return best;
}

}  // namespace softhom::fe
