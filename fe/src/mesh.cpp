#include "softhom/fe/mesh.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "softhom/fe/hex8.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::fe {

const std::vector<Quad>& Mesh::surface(const std::string& name) const {
  const auto it = surfaces.find(name);
  if (it == surfaces.end()) throw InputError("surface", name, "no surface of that name in the mesh");
  return it->second;
}

void merge_coincident_nodes(Mesh& mesh, double tolerance) {
  if (mesh.nodes.empty()) return;
  Vec3 lo = mesh.nodes[0], hi = mesh.nodes[0];
  for (const Vec3& x : mesh.nodes) {
    lo = lo.cwiseMin(x);
    hi = hi.cwiseMax(x);
  }
  const double h = std::max(tolerance * (hi - lo).norm(), 1e-300);
  // Hash on a grid of cell size 4h: coincident nodes land in the same or a neighbouring cell.
  const double cell = 4.0 * h;
  auto key = [&](long a, long b, long c) { return (a * 73856093L) ^ (b * 19349663L) ^ (c * 83492791L); };
  std::unordered_multimap<long, int> grid;
  grid.reserve(mesh.nodes.size());
  std::vector<int> map(mesh.nodes.size());
  std::vector<Vec3> kept;
  kept.reserve(mesh.nodes.size());
  for (std::size_t n = 0; n < mesh.nodes.size(); ++n) {
    const Vec3& x = mesh.nodes[n];
    const long ix = long(std::floor((x[0] - lo[0]) / cell)), iy = long(std::floor((x[1] - lo[1]) / cell)),
               iz = long(std::floor((x[2] - lo[2]) / cell));
    int found = -1;
    for (long a = ix - 1; a <= ix + 1 && found < 0; ++a)
      for (long b = iy - 1; b <= iy + 1 && found < 0; ++b)
        for (long c = iz - 1; c <= iz + 1 && found < 0; ++c) {
          auto range = grid.equal_range(key(a, b, c));
          for (auto it = range.first; it != range.second; ++it)
            if ((kept[it->second] - x).norm() <= h) {
              found = it->second;
              break;
            }
        }
    if (found < 0) {
      found = int(kept.size());
      kept.push_back(x);
      grid.emplace(key(ix, iy, iz), found);
    }
    map[n] = found;
  }
  mesh.nodes = std::move(kept);
  for (Hex& hex : mesh.hexes)
    for (int& n : hex) n = map[n];
  for (auto& [name, faces] : mesh.surfaces)
    for (Quad& q : faces)
      for (int& n : q) n = map[n];
}

std::vector<Quad> boundary_faces(const Mesh& mesh) {
  struct Entry {
    std::array<int, 4> key;
    Quad face;
  };
  std::vector<Entry> all;
  all.reserve(6 * mesh.hexes.size());
  for (const Hex& hex : mesh.hexes)
    for (const auto& lf : kHexFaces) {
      Quad q{hex[lf[0]], hex[lf[1]], hex[lf[2]], hex[lf[3]]};
      std::array<int, 4> k = q;
      std::sort(k.begin(), k.end());
      // Faces collapsed to a line or a point (at a degenerate axis) carry no area: skip them.
      if (k[0] == k[2] || k[1] == k[3]) continue;
      all.push_back({k, q});
    }
  std::sort(all.begin(), all.end(), [](const Entry& a, const Entry& b) { return a.key < b.key; });
  std::vector<Quad> out;
  for (std::size_t i = 0; i < all.size();) {
    std::size_t j = i + 1;
    while (j < all.size() && all[j].key == all[i].key) ++j;
    if (j - i == 1) out.push_back(all[i].face);
    i = j;
  }
  return out;
}

void name_boundary_faces(Mesh& mesh, const std::function<std::string(const Vec3&, const Vec3&)>& classify) {
  for (const Quad& q : boundary_faces(mesh)) {
    const Vec3 c = 0.25 * (mesh.nodes[q[0]] + mesh.nodes[q[1]] + mesh.nodes[q[2]] + mesh.nodes[q[3]]);
    // Area vector of a bilinear quad: half the cross product of the diagonals.
    Vec3 n = 0.5 * (mesh.nodes[q[2]] - mesh.nodes[q[0]]).cross(mesh.nodes[q[3]] - mesh.nodes[q[1]]);
    if (n.norm() == 0.0) continue;
    n.normalize();
    const std::string name = classify(c, n);
    if (!name.empty()) mesh.surfaces[name].push_back(q);
  }
}

std::vector<int> surface_nodes(const Mesh& mesh, const std::string& name) {
  std::vector<int> out;
  for (const Quad& q : mesh.surface(name)) out.insert(out.end(), q.begin(), q.end());
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

std::vector<int> select_nodes(const Mesh& mesh, const std::function<bool(const Vec3&)>& predicate) {
  std::vector<int> out;
  for (int n = 0; n < mesh.num_nodes(); ++n)
    if (predicate(mesh.nodes[n])) out.push_back(n);
  return out;
}

static Mat83 element_coordinates(const Mesh& mesh, const Hex& hex) {
  Mat83 X;
  for (int a = 0; a < 8; ++a) X.row(a) = mesh.nodes[hex[a]].transpose();
  return X;
}

int orient_hexes(Mesh& mesh) {
  int flipped = 0;
  for (Hex& hex : mesh.hexes) {
    const Mat83 X = element_coordinates(mesh, hex);
    // Jacobian at the centroid: dN/dξ = ±1/8 per node.
    Mat3 Jc = Mat3::Zero();
    static const int s[8][3] = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1},
                                {-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1}};
    for (int a = 0; a < 8; ++a)
      for (int J = 0; J < 3; ++J) Jc.row(J) += 0.125 * s[a][J] * X.row(a);
    if (Jc.determinant() < 0.0) {
      std::swap(hex[0], hex[1]);
      std::swap(hex[3], hex[2]);
      std::swap(hex[4], hex[5]);
      std::swap(hex[7], hex[6]);
      ++flipped;
    }
  }
  return flipped;
}

double min_scaled_jacobian(const Mesh& mesh) {
  double worst = 1.0;
  for (const Hex& hex : mesh.hexes) {
    const Hex8Geometry g = hex8_geometry(element_coordinates(mesh, hex));
    const double mean = g.volume / 8.0;
    for (double w : g.w) worst = std::min(worst, mean > 0 ? w / mean : -1.0);
  }
  return worst;
}

}  // namespace softhom::fe
