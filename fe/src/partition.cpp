#include "partition.hpp"

#include <algorithm>
#include <numeric>

namespace softhom::fe {

std::vector<int> partition_elements_rcb(const Mesh& mesh, int parts) {
  const int ne = mesh.num_elements();
  std::vector<int> part(ne, 0);
  if (parts <= 1 || ne == 0) return part;
  std::vector<Vec3> centroid(ne, Vec3::Zero());
  for (int e = 0; e < ne; ++e) {
    const int* en = mesh.element_nodes(e);
    const int n = mesh.element_size(e);
    for (int a = 0; a < n; ++a) centroid[e] += mesh.nodes[en[a]];
    centroid[e] /= double(n);
  }
  std::vector<int> order(ne);
  std::iota(order.begin(), order.end(), 0);
  // Split [lo, hi) of `order` into parts [p0, p0 + np).
  auto split = [&](auto&& self, int lo, int hi, int p0, int np) -> void {
    if (np == 1) {
      for (int k = lo; k < hi; ++k) part[order[k]] = p0;
      return;
    }
    Vec3 mn = Vec3::Constant(1e300), mx = Vec3::Constant(-1e300);
    for (int k = lo; k < hi; ++k) {
      mn = mn.cwiseMin(centroid[order[k]]);
      mx = mx.cwiseMax(centroid[order[k]]);
    }
    int axis = 0;
    (mx - mn).maxCoeff(&axis);
    const int left = np / 2;
    const int mid = lo + int((long(hi - lo) * left) / np);
    std::nth_element(order.begin() + lo, order.begin() + mid, order.begin() + hi, [&](int a, int b) {
      const double xa = centroid[a][axis], xb = centroid[b][axis];
      return xa < xb || (xa == xb && a < b);
    });
    self(self, lo, mid, p0, left);
    self(self, mid, hi, p0 + left, np - left);
  };
  split(split, 0, ne, 0, parts);
  return part;
}

std::vector<int> node_owners(const Mesh& mesh, const std::vector<int>& element_part) {
  std::vector<int> owner(mesh.num_nodes(), -1);
  for (int e = 0; e < mesh.num_elements(); ++e) {
    const int* en = mesh.element_nodes(e);
    for (int a = 0; a < mesh.element_size(e); ++a)
      if (owner[en[a]] < 0 || element_part[e] < owner[en[a]]) owner[en[a]] = element_part[e];
  }
  for (int& o : owner) o = std::max(o, 0);
  return owner;
}

}  // namespace softhom::fe
