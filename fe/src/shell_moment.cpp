// A follower end moment on a rotation-free shell edge (shell.hpp: ShellEdgeMoment): a couple on the
// chord from each edge node to its inner partner, work-conjugate to the chord's rotation about an axis.
#include <algorithm>
#include <cmath>
#include <map>
#include <string>

#include "softhom/fe/shell.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::fe {
namespace {

/// The angle θ of a chord d about the axis (basis p, q of its normal plane): its gradient g = ∂θ/∂d and
/// Hessian H = ∂²θ/∂d². With d1 = d·p, d2 = d·q, ρ² = d1² + d2²: ∂θ/∂d = (−d2 p + d1 q) / ρ², and
/// ∂²θ/∂d1² = 2 d1 d2 / ρ⁴ = −∂²θ/∂d2², ∂²θ/∂d1∂d2 = (d2² − d1²) / ρ⁴.
void chord_angle_derivatives(const Vec3& d, const Vec3& p, const Vec3& q, Vec3& g, Mat3& H) {
  const double d1 = d.dot(p), d2 = d.dot(q), rho2 = d1 * d1 + d2 * d2, rho4 = rho2 * rho2;
  g = (-d2 * p + d1 * q) / rho2;
  const double h11 = 2.0 * d1 * d2 / rho4, h12 = (d2 * d2 - d1 * d1) / rho4;
  H = h11 * (p * p.transpose() - q * q.transpose()) + h12 * (p * q.transpose() + q * p.transpose());
}

}  // namespace

ShellEdgeMoment::ShellEdgeMoment(std::vector<Pair> pairs, const Vec3& axis, PiecewiseLinear moment, const std::string& field)
    : pairs_(std::move(pairs)), moment_(std::move(moment)) {
  if (!(axis.norm() > 0.0)) throw InputError(field + ".axis", "[0, 0, 0]", "the moment's axis needs a direction");
  axis_ = axis.normalized();
  // p: the global axis least aligned with the moment's, made normal to it.
  Vec3 seed = Vec3::Zero();
  int k = 0;
  axis_.cwiseAbs().minCoeff(&k);
  seed[k] = 1.0;
  p_ = (seed - seed.dot(axis_) * axis_).normalized();
  q_ = axis_.cross(p_);
  for (std::size_t i = 0; i < pairs_.size(); ++i)
    if (pairs_[i].edge < 0 || pairs_[i].inner < 0 || pairs_[i].edge == pairs_[i].inner)
      throw InputError(field, "pair " + std::to_string(i), "needs an edge node and a distinct inner node");
}

void ShellEdgeMoment::validate(const Mesh& mesh) const {
  for (const Pair& pr : pairs_)
    if (pr.edge >= mesh.num_nodes() || pr.inner >= mesh.num_nodes())
      throw InputError("shell_edge_moment", std::to_string(std::max(pr.edge, pr.inner)), "node id out of range");
}

void ShellEdgeMoment::declare_couplings(Couplings& couplings) const {
  for (const Pair& pr : pairs_) {
    const int nodes[2] = {pr.edge, pr.inner};
    couplings.add(nodes, 2);
  }
}

MaterialStatus ShellEdgeMoment::assemble(const Mesh& mesh, const Iterate& it, AssemblySink& sink) const {
  const double M = moment_(it.t), M_tangent = moment_(it.t_stiffness);
  for (const Pair& pr : pairs_) {
    const Vec3 d = it.position(mesh, pr.edge) - it.position(mesh, pr.inner);
    Vec3 g;
    Mat3 H;
    chord_angle_derivatives(d, p_, q_, g, H);
    // R = f_int − f_ext with f_ext = ∂(M θ)/∂x: −M g on the edge node, +M g on the inner one.
    int dofs[6];
    double r[6];
    for (int i = 0; i < 3; ++i) {
      dofs[i] = 3 * pr.edge + i;
      dofs[3 + i] = 3 * pr.inner + i;
      r[i] = -pr.share * M * g[i];
      r[3 + i] = -r[i];
    }
    sink.add_residual(6, dofs, r);
    if (!sink.tangent()) continue;
    const Mat3 K = -pr.share * M_tangent * H;
    double k[36];  // column-major [K, −K; −K, K]
    for (int c = 0; c < 6; ++c)
      for (int rr = 0; rr < 6; ++rr) k[rr + 6 * c] = ((rr < 3) == (c < 3) ? 1.0 : -1.0) * K(rr % 3, c % 3);
    sink.add_tangent(6, dofs, 6, dofs, k);
  }
  return MaterialStatus::ok;
}

double ShellEdgeMoment::rotation(const Mesh& mesh, const std::vector<double>& u) const {
  double c = 0.0, s = 0.0;
  for (const Pair& pr : pairs_) {
    const Vec3 D = mesh.nodes[pr.edge] - mesh.nodes[pr.inner];
    const Vec3 d = D + Vec3(u[3 * pr.edge] - u[3 * pr.inner], u[3 * pr.edge + 1] - u[3 * pr.inner + 1],
                            u[3 * pr.edge + 2] - u[3 * pr.inner + 2]);
    const double turn = std::atan2(d.dot(q_), d.dot(p_)) - std::atan2(D.dot(q_), D.dot(p_));
    c += pr.share * std::cos(turn);
    s += pr.share * std::sin(turn);
  }
  return std::atan2(s, c);
}

void ShellEdgeMoment::report(const Mesh& mesh, const Iterate& it, ContributionReport& out) const {
  out.probes.emplace_back("shell edge moment [N mm]", moment_(it.t));
  out.probes.emplace_back("shell edge rotation [rad]", rotation(mesh, *it.u));
}

std::vector<ShellEdgeMoment::Pair> shell_edge_moment_pairs(const Mesh& mesh, const std::vector<Tri3>& tris,
                                                           const std::vector<std::array<int, 2>>& segments,
                                                           const std::string& field) {
  // Each edge node's share (half of each of its segments) and inward conormal (summed over its segments:
  // the in-plane normal of the segment toward its triangle's third vertex, weighted by length).
  std::map<int, double> share;
  std::map<int, Vec3> inward;
  std::map<int, std::vector<int>> candidates;  // nodes of the edge node's triangles
  double length = 0.0;
  for (std::size_t k = 0; k < segments.size(); ++k) {
    const int a = segments[k][0], b = segments[k][1];
    const auto t = std::find_if(tris.begin(), tris.end(), [&](const Tri3& tri) {
      return std::count(tri.begin(), tri.end(), a) + std::count(tri.begin(), tri.end(), b) == 2;
    });
    if (t == tris.end()) throw InputError(field, "segment " + std::to_string(k), "is no triangle's edge");
    const int c = (*t)[0] != a && (*t)[0] != b ? (*t)[0] : ((*t)[1] != a && (*t)[1] != b ? (*t)[1] : (*t)[2]);
    const Vec3 e = mesh.nodes[b] - mesh.nodes[a], w = mesh.nodes[c] - mesh.nodes[a];
    const Vec3 nu = (w - w.dot(e) / e.squaredNorm() * e).normalized() * e.norm();
    for (int n : {a, b}) {
      share[n] += 0.5 * e.norm();
      inward.try_emplace(n, Vec3::Zero()).first->second += nu;  // (a default Vec3 is uninitialized)
    }
    length += e.norm();
  }
  for (const Tri3& tri : tris)
    for (int n : tri)
      if (share.count(n))
        for (int m : tri)
          if (!share.count(m)) candidates[n].push_back(m);
  std::vector<ShellEdgeMoment::Pair> pairs;
  for (const auto& [n, s] : share) {
    const Vec3 nu = inward[n].normalized();
    int best = -1;
    double best_cos = -2.0;
    for (int m : candidates[n]) {
      const double c = (mesh.nodes[m] - mesh.nodes[n]).normalized().dot(nu);
      if (c > best_cos) best_cos = c, best = m;
    }
    if (best < 0) throw InputError(field, "node " + std::to_string(n), "has no triangle off the edge");
    pairs.push_back({n, best, s / length});
  }
  return pairs;
}

}  // namespace softhom::fe
