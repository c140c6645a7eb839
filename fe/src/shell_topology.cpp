// Surface topology of shells (shell.hpp): edge neighbours, orientation, closedness; and the triangles
// as the load faces of PressureLoad and CavityControl.
#include <algorithm>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "softhom/fe/shell.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::fe {
namespace {

struct EdgeUse {
  int tri, k;
};

long long edge_key(int a, int b) { return (long long)std::min(a, b) << 32 | (unsigned)std::max(a, b); }

/// Nodes of edge k (opposite vertex k) in the triangle's order.
std::pair<int, int> edge_nodes(const Tri3& t, int k) { return {t[(k + 1) % 3], t[(k + 2) % 3]}; }

std::string element_name(int e) { return "element " + std::to_string(e); }

std::unordered_map<long long, std::vector<EdgeUse>> edge_map(const std::vector<Tri3>& tris, const std::string& field) {
  std::unordered_map<long long, std::vector<EdgeUse>> edges;
  edges.reserve(3 * tris.size());
  for (int e = 0; e < int(tris.size()); ++e)
    for (int k = 0; k < 3; ++k) {
      const auto [a, b] = edge_nodes(tris[e], k);
      auto& uses = edges[edge_key(a, b)];
      uses.push_back({e, k});
      if (uses.size() > 2)
        throw InputError(field, element_name(e),
                         "non-manifold surface: the edge of nodes " + std::to_string(a) + ", " + std::to_string(b) +
                             " is shared by three or more triangles (" + element_name(uses[0].tri) + ", " +
                             element_name(uses[1].tri) + ", " + element_name(e) + ")");
    }
  return edges;
}

/// Whether the two uses of a shared edge run opposite ways (a consistent orientation).
bool opposite_ways(const std::vector<Tri3>& tris, const EdgeUse& u, const EdgeUse& v) {
  return edge_nodes(tris[u.tri], u.k).first == edge_nodes(tris[v.tri], v.k).second;
}

/// Flips triangles so that every connected part follows its first triangle; throws for a
/// non-orientable part. Returns the number flipped.
int orient_parts(std::vector<Tri3>& tris, const std::unordered_map<long long, std::vector<EdgeUse>>& edges,
                 const std::string& field) {
  const int nt = int(tris.size());
  std::vector<signed char> flip(nt, -1);
  std::vector<int> queue;
  int flipped = 0;
  for (int start = 0; start < nt; ++start) {
    if (flip[start] >= 0) continue;
    flip[start] = 0;
    queue.assign(1, start);
    while (!queue.empty()) {
      const int t = queue.back();
      queue.pop_back();
      for (int k = 0; k < 3; ++k) {
        const auto [a, b] = edge_nodes(tris[t], k);
        const auto& uses = edges.at(edge_key(a, b));
        if (uses.size() != 2) continue;
        const EdgeUse self = uses[0].tri == t && uses[0].k == k ? uses[0] : uses[1];
        const EdgeUse other = uses[0].tri == t && uses[0].k == k ? uses[1] : uses[0];
        const signed char want = flip[t] ^ (opposite_ways(tris, self, other) ? 0 : 1);
        if (flip[other.tri] < 0) {
          flip[other.tri] = want;
          queue.push_back(other.tri);
        } else if (flip[other.tri] != want) {
          throw InputError(field, element_name(other.tri),
                           "the surface is not orientable (a Möbius-like part): no consistent normal through " +
                               element_name(t) + " and " + element_name(other.tri));
        }
      }
    }
  }
  for (int t = 0; t < nt; ++t)
    if (flip[t] == 1) {
      std::swap(tris[t][1], tris[t][2]);
      ++flipped;
    }
  return flipped;
}

}  // namespace

ShellTopology shell_topology(std::vector<Tri3>& tris, int num_nodes, bool orient, const std::string& field) {
  for (int e = 0; e < int(tris.size()); ++e) {
    const Tri3& t = tris[e];
    for (int n : t)
      if (n < 0 || n >= num_nodes) throw InputError(field, element_name(e), "node id " + std::to_string(n) + " out of range");
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) throw InputError(field, element_name(e), "a triangle repeats a node");
  }
  ShellTopology top;
  auto edges = edge_map(tris, field);
  if (orient) {
    top.flipped = orient_parts(tris, edges, field);
    if (top.flipped > 0) edges = edge_map(tris, field);
  }
  const int nt = int(tris.size());
  top.neighbour.assign(nt, {-1, -1, -1});
  top.opposite.assign(nt, {-1, -1, -1});
  for (int e = 0; e < nt; ++e)
    for (int k = 0; k < 3; ++k) {
      const auto [a, b] = edge_nodes(tris[e], k);
      const auto& uses = edges.at(edge_key(a, b));
      if (uses.size() == 1) {
        ++top.boundary_edges;
        continue;
      }
      const EdgeUse& other = uses[0].tri == e && uses[0].k == k ? uses[1] : uses[0];
      if (!opposite_ways(tris, uses[0], uses[1]))
        throw InputError(field, element_name(e),
                         "inconsistently oriented triangles: " + element_name(e) + " and " + element_name(other.tri) +
                             " run their shared edge the same way (orient the surface, or let softhom orient it)");
      top.neighbour[e][k] = other.tri;
      top.opposite[e][k] = tris[other.tri][other.k];
    }
  return top;
}

void check_closed(const ShellTopology& topology, const std::string& field) {
  for (int e = 0; e < int(topology.neighbour.size()); ++e)
    for (int k = 0; k < 3; ++k)
      if (topology.neighbour[e][k] < 0)
        throw InputError(field, element_name(e), "the surface is open (this triangle has a boundary edge) where a closed one is needed");
}

std::vector<Quad> shell_load_faces(const std::vector<Tri3>& tris) {
  std::vector<Quad> faces;
  faces.reserve(tris.size());
  for (const Tri3& t : tris) faces.push_back({t[0], t[2], t[1], t[1]});
  return faces;
}

}  // namespace softhom::fe
