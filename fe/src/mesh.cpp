#include "softhom/fe/mesh.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "softhom/fe/hex8.hpp"
#include "softhom/fe/tet10.hpp"
#include "softhom/fe/tet10_element.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::fe {

const std::vector<Quad>& Mesh::surface(const std::string& name) const {
  static const std::vector<Quad> kNone;
  const auto it = surfaces.find(name);
  if (it != surfaces.end()) return it->second;
  if (tri_surfaces.count(name)) return kNone;
  throw InputError("surface", name, "no surface of that name in the mesh");
}

const std::vector<Tri6>& Mesh::tri_surface(const std::string& name) const {
  static const std::vector<Tri6> kNone;
  const auto it = tri_surfaces.find(name);
  return it == tri_surfaces.end() ? kNone : it->second;
}

int orient_tets(Mesh& mesh) {
  int flipped = 0;
  for (Tet10& t : mesh.tets) {
    const Vec3 &x0 = mesh.nodes[t[0]], &x1 = mesh.nodes[t[1]], &x2 = mesh.nodes[t[2]], &x3 = mesh.nodes[t[3]];
    if ((x1 - x0).cross(x2 - x0).dot(x3 - x0) >= 0.0) continue;
    // Swapping vertices 1 and 2 maps edge (0,1) ↔ (2,0) and (3,2) ↔ (3,1); (1,2) and (3,0) stay.
    std::swap(t[1], t[2]);
    std::swap(t[4], t[6]);
    std::swap(t[8], t[9]);
    ++flipped;
  }
  return flipped;
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
  for (Tet10& tet : mesh.tets)
    for (int& n : tet) n = map[n];
  for (auto& [name, faces] : mesh.surfaces)
    for (Quad& q : faces)
      for (int& n : q) n = map[n];
  for (auto& [name, faces] : mesh.tri_surfaces)
    for (Tri6& q : faces)
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

std::vector<Tri6> boundary_tri_faces(const Mesh& mesh) {
  std::vector<std::pair<std::array<int, 3>, Tri6>> all;
  all.reserve(4 * mesh.tets.size());
  for (const Tet10& tet : mesh.tets)
    for (const auto& lf : kTet10Faces) {
      Tri6 f;
      for (int k = 0; k < 6; ++k) f[k] = tet[lf[k]];
      std::array<int, 3> key{f[0], f[1], f[2]};
      std::sort(key.begin(), key.end());
      all.push_back({key, f});
    }
  std::sort(all.begin(), all.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<Tri6> out;
  for (std::size_t i = 0; i < all.size();) {
    std::size_t j = i + 1;
    while (j < all.size() && all[j].first == all[i].first) ++j;
    if (j - i == 1) out.push_back(all[i].second);
    i = j;
  }
  return out;
}

void name_boundary_faces(Mesh& mesh, const std::function<std::string(const Vec3&, const Vec3&)>& classify) {
  for (const Tri6& f : boundary_tri_faces(mesh)) {
    const Vec3 c = (mesh.nodes[f[0]] + mesh.nodes[f[1]] + mesh.nodes[f[2]]) / 3.0;
    Vec3 n = (mesh.nodes[f[1]] - mesh.nodes[f[0]]).cross(mesh.nodes[f[2]] - mesh.nodes[f[0]]);
    if (n.norm() == 0.0) continue;
    n.normalize();
    const std::string name = classify(c, n);
    if (!name.empty()) mesh.tri_surfaces[name].push_back(f);
  }
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

Mesh hex_to_tet10(const Mesh& hm, const std::function<Vec3(const Vec3&, const Vec3&)>& midpoint) {
  // Local hex vertex of the binary corner (bx, by, bz), see the node order in this header.
  static const int kCorner[2][2][2] = {{{0, 4}, {3, 7}}, {{1, 5}, {2, 6}}};  // [bx][by][bz]
  static const int kPerm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  Mesh out;
  out.nodes = hm.nodes;
  out.region_names = hm.region_names;
  std::map<std::pair<int, int>, int> mid;
  auto mid_node = [&](int a, int b) {
    const std::pair<int, int> key{std::min(a, b), std::max(a, b)};
    const auto it = mid.find(key);
    if (it != mid.end()) return it->second;
    const int id = int(out.nodes.size());
    out.nodes.push_back(midpoint ? midpoint(hm.nodes[a], hm.nodes[b]) : Vec3(0.5 * (hm.nodes[a] + hm.nodes[b])));
    mid.emplace(key, id);
    return id;
  };
  for (int e = 0; e < hm.num_hexes(); ++e) {
    const Hex& h = hm.hexes[e];
    for (const auto& p : kPerm) {
      int b[3] = {0, 0, 0};
      Tet10 t;
      t[0] = h[kCorner[0][0][0]];
      for (int s = 0; s < 3; ++s) {
        b[p[s]] = 1;
        t[s + 1] = h[kCorner[b[0]][b[1]][b[2]]];
      }
      const Vec3 &x0 = hm.nodes[t[0]], &x1 = hm.nodes[t[1]], &x2 = hm.nodes[t[2]], &x3 = hm.nodes[t[3]];
      const double vol = (x1 - x0).cross(x2 - x0).dot(x3 - x0);
      const double scale = (x1 - x0).norm() * (x2 - x0).norm() * (x3 - x0).norm();
      if (!(std::abs(vol) > 1e-12 * scale)) continue;  // collapsed (wedge at an axis)
      for (int k = 0; k < 6; ++k) t[4 + k] = mid_node(t[kTet10Edges[k][0]], t[kTet10Edges[k][1]]);
      out.tets.push_back(t);
      if (!hm.region.empty()) out.region.push_back(hm.region[e]);
    }
  }
  orient_tets(out);
  // A boundary triangle belongs to the surface of the quad holding its three vertices.
  std::map<std::array<int, 3>, std::string> names;
  for (const auto& [name, quads] : hm.surfaces)
    for (const Quad& q : quads)
      for (int skip = 0; skip < 4; ++skip) {
        std::array<int, 3> k;
        for (int i = 0, j = 0; i < 4; ++i)
          if (i != skip) k[j++] = q[i];
        std::sort(k.begin(), k.end());
        names.emplace(k, name);
      }
  for (const Tri6& f : boundary_tri_faces(out)) {
    std::array<int, 3> k{f[0], f[1], f[2]};
    std::sort(k.begin(), k.end());
    const auto it = names.find(k);
    if (it != names.end()) out.tri_surfaces[it->second].push_back(f);
  }
  return out;
}

std::vector<int> surface_nodes(const Mesh& mesh, const std::string& name) {
  std::vector<int> out;
  for (const Quad& q : mesh.surface(name)) out.insert(out.end(), q.begin(), q.end());
  for (const Tri6& q : mesh.tri_surface(name)) out.insert(out.end(), q.begin(), q.end());
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
  for (const Tet10& tet : mesh.tets) {
    Tet10Coords X;
    for (int a = 0; a < 10; ++a) X.row(a) = mesh.nodes[tet[a]].transpose();
    const Tet10Geometry g = tet10_geometry(X);
    const double mean = g.volume / 4.0;
    for (double w : g.w) worst = std::min(worst, mean > 0 ? w / mean : -1.0);
  }
  return worst;
}

}  // namespace softhom::fe
