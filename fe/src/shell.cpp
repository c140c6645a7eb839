// The rotation-free shell triangle (shell.hpp): frames, the reference patches, the kinematics with
// their exact derivatives, and the shell domain's residual and tangent.
#include "softhom/fe/shell.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <string>

#include <Eigen/Dense>

#include "shell_jet.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::fe {
namespace {

using detail::Jet;
using Mat18 = Eigen::Matrix<double, 18, 18>;
using Vec18s = Eigen::Matrix<double, 18, 1>;

std::string element(int e) { return "element " + std::to_string(e); }

template <class T>
using V3 = std::array<T, 3>;

template <class T>
T dot(const V3<T>& a, const V3<T>& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
template <class T>
T dot(const V3<T>& a, const Vec3& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
template <class T>
V3<T> cross(const V3<T>& a, const V3<T>& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

/// [ε11, ε22, 2ε12, κ11, κ22, 2κ12] of the patch at positions x (see shell.hpp for the formulas).
template <class T>
std::array<T, 6> patch_strains(const ShellPatch& p, const std::array<V3<T>, 6>& x) {
  using std::sqrt;
  using detail::sqrt;
  using detail::reciprocal;
  V3<T> a1{0.0, 0.0, 0.0}, a2{0.0, 0.0, 0.0};
  for (int c = 0; c < 3; ++c)
    for (int i = 0; i < 3; ++i) {
      a1[i] += p.dN[c][0] * x[c][i];
      a2[i] += p.dN[c][1] * x[c][i];
    }
  const V3<T> n = cross(a1, a2);
  const T inv = reciprocal(sqrt(dot(n, n)));
  const V3<T> t{n[0] * inv, n[1] * inv, n[2] * inv};
  std::array<T, 6> s;
  s[0] = 0.5 * (dot(a1, a1) - 1.0);
  s[1] = 0.5 * (dot(a2, a2) - 1.0);
  s[2] = dot(a1, a2);
  std::array<T, 3> b{0.0, 0.0, 0.0};
  for (int i = 0; i < 3; ++i) {
    if (p.kind[i] == 0) continue;
    T h;
    if (p.kind[i] == 1) {
      const V3<T> d{x[3 + i][0] - x[0][0], x[3 + i][1] - x[0][1], x[3 + i][2] - x[0][2]};
      h = dot(t, d);
    } else {
      h = dot(t, p.clamp[i]);
    }
    for (int k = 0; k < 3; ++k) b[k] += p.Q[k][i] * h;
  }
  s[3] = (-1.0) * b[0] + p.B[0];
  s[4] = (-1.0) * b[1] + p.B[1];
  s[5] = (-2.0) * b[2] + 2.0 * p.B[2];
  return s;
}

std::array<V3<double>, 6> positions(const ShellPatch& p, const std::array<Vec3, 6>& x) {
  std::array<V3<double>, 6> v{};
  for (int s = 0; s < 6; ++s)
    if (p.nodes[s] >= 0) v[s] = {x[s][0], x[s][1], x[s][2]};
  return v;
}

/// 2D coordinates of X in the frame (e1, e2) about the origin o.
Eigen::Vector2d in_plane(const Mat3& frame, const Vec3& o, const Vec3& X) {
  return {(X - o).dot(frame.col(0)), (X - o).dot(frame.col(1))};
}

}  // namespace

Mat3 shell_frame(const ShellFrameRule& rule, const Vec3& n, const Vec3& c, bool& fallback) {
  fallback = false;
  Vec3 dir = rule.axis;
  if (rule.kind == ShellFrameRule::Kind::cylindrical) dir = rule.axis.cross(c - rule.origin);
  auto projected = [&](const Vec3& d) { return Vec3(d - d.dot(n) * n); };
  Vec3 e1 = projected(dir);
  // Within 1e-3 (sine) of the normal the projection's direction is ill-defined (it turns by O(1) over
  // a small move): fall back to the first global axis that is not (y, then z; documented in docs/macro.md).
  if (!(e1.norm() > 1e-3 * dir.norm())) {
    fallback = true;
    for (int a = 1; a < 3 && !(e1.norm() > 1e-3); ++a) e1 = projected(Vec3::Unit(a));
    if (!(e1.norm() > 1e-3)) e1 = projected(Vec3::Unit(0));
  }
  e1.normalize();
  Mat3 f;
  f.col(0) = e1;
  f.col(1) = n.cross(e1);
  f.col(2) = n;
  return f;
}

void shell_strains(const ShellPatch& p, const std::array<Vec3, 6>& x, Vec6v& strains, Eigen::Matrix<double, 6, 18>* B,
                   std::array<Eigen::Matrix<double, 18, 18>, 6>* H) {
  if (!B && !H) {
    const std::array<double, 6> s = patch_strains<double>(p, positions(p, x));
    for (int k = 0; k < 6; ++k) strains[k] = s[k];
    return;
  }
  std::array<V3<Jet>, 6> xj;
  for (int s = 0; s < 6; ++s)
    for (int i = 0; i < 3; ++i)
      xj[s][i] = p.nodes[s] >= 0 ? Jet::variable(x[s][i], 3 * s + i) : Jet(0.0);
  const std::array<Jet, 6> s = patch_strains<Jet>(p, xj);
  for (int k = 0; k < 6; ++k) {
    strains[k] = s[k].v;
    if (B) B->row(k) = s[k].g.transpose();
    if (H) (*H)[k] = s[k].h;
  }
}

namespace {

/// The reference patch of triangle e (its frame, shape derivatives, curvature weights and B).
ShellPatch make_patch(const Mesh& mesh, const std::vector<Tri3>& tris, const ShellTopology& top, int e,
                      const std::map<std::pair<int, int>, ShellEdge>& edges, const ShellFrameRule& rule, bool& fallback) {
  ShellPatch p;
  const Tri3& tri = tris[e];
  const Vec3 X0 = mesh.nodes[tri[0]], X1 = mesh.nodes[tri[1]], X2 = mesh.nodes[tri[2]];
  const Vec3 nv = (X1 - X0).cross(X2 - X0);
  const double scale = std::max({(X1 - X0).norm(), (X2 - X0).norm(), (X2 - X1).norm()});
  if (!(nv.norm() > 1e-12 * scale * scale)) throw InputError("shell", element(e), "degenerate triangle (zero area)");
  p.area = 0.5 * nv.norm();
  const Vec3 c = (X0 + X1 + X2) / 3.0;
  p.frame = shell_frame(rule, nv.normalized(), c, fallback);
  std::array<Eigen::Vector2d, 6> P;
  for (int k = 0; k < 3; ++k) {
    p.nodes[k] = tri[k];
    P[k] = in_plane(p.frame, c, mesh.nodes[tri[k]]);
  }
  const double twoA = (P[1] - P[0]).x() * (P[2] - P[0]).y() - (P[1] - P[0]).y() * (P[2] - P[0]).x();
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector2d& Pj = P[(k + 1) % 3];
    const Eigen::Vector2d& Pk = P[(k + 2) % 3];
    p.dN[k][0] = (Pj.y() - Pk.y()) / twoA;
    p.dN[k][1] = (Pk.x() - Pj.x()) / twoA;
  }
  for (int i = 0; i < 3; ++i) {
    const int a = tri[(i + 1) % 3], b = tri[(i + 2) % 3];
    const Eigen::Vector2d Pa = P[(i + 1) % 3], Pb = P[(i + 2) % 3];
    const Eigen::Vector2d t2 = (Pb - Pa).normalized();
    Eigen::Vector2d nu(t2.y(), -t2.x());
    if ((P[i] - Pa).dot(nu) > 0.0) nu = -nu;  // outward: away from the opposite vertex
    const int o = top.opposite[e][i];
    if (o >= 0) {
      // Unfolded about the edge: the neighbour keeps its shape, turned into the triangle's plane.
      const Vec3 T = (mesh.nodes[b] - mesh.nodes[a]).normalized();
      const Vec3 d = mesh.nodes[o] - mesh.nodes[a];
      const double s = d.dot(T);
      P[3 + i] = Pa + s * t2 + (d - s * T).norm() * nu;
      p.nodes[3 + i] = o;
      p.kind[i] = 1;
    } else {
      const double delta = -(P[i] - Pa).dot(nu);
      P[3 + i] = P[i] + 2.0 * delta * nu;  // the mirror image of the opposite vertex
      const auto found = edges.find({std::min(a, b), std::max(a, b)});
      const bool clamped = found != edges.end() && found->second == ShellEdge::clamped;
      p.kind[i] = clamped ? 2 : 0;
      if (clamped) p.clamp[i] = 2.0 * delta * (nu.x() * p.frame.col(0) + nu.y() * p.frame.col(1));
    }
  }
  // The 6-point quadratic interpolation in coordinates scaled by h (conditioning); b from its
  // constant second derivatives: ∂²/∂X² of c (X/h)² is 2c/h².
  const double h = std::sqrt(twoA);
  Eigen::Matrix<double, 6, 6> V;
  for (int j = 0; j < 6; ++j) {
    const double u = P[j].x() / h, v = P[j].y() / h;
    V.row(j) << 1.0, u, v, u * u, u * v, v * v;
    if (j < 3 || p.kind[j - 3] != 0) continue;
    // A free edge has no point across it: its row says instead that the surface has no curvature
    // across the edge (∂²q/∂ν² = 0, BST's free edge), in the reference and in every deformation, so the
    // fit stays exact for surfaces curved along the edge only (a cantilever's bending).
    const Eigen::Vector2d nu = (P[j] - P[j - 3]).normalized();
    V.row(j) << 0.0, 0.0, 0.0, nu.x() * nu.x(), nu.x() * nu.y(), nu.y() * nu.y();
  }
  const Eigen::FullPivLU<Eigen::Matrix<double, 6, 6>> lu(V);
  const Eigen::Matrix<double, 6, 6> Vinv = lu.inverse();
  if (!lu.isInvertible() || !(Vinv.cwiseAbs().maxCoeff() < 1e8))
    throw InputError("shell", element(e), "the patch of this triangle and its neighbours is degenerate (its six nodes lie on a conic)");
  for (int i = 0; i < 3; ++i) {
    p.Q[0][i] = 2.0 * Vinv(3, 3 + i) / (h * h);
    p.Q[1][i] = 2.0 * Vinv(5, 3 + i) / (h * h);
    p.Q[2][i] = Vinv(4, 3 + i) / (h * h);
  }
  // The reference curvature: the same heights at the reference positions (κ = 0 there).
  std::array<Vec3, 6> X;
  for (int s = 0; s < 6; ++s) X[s] = p.nodes[s] >= 0 ? mesh.nodes[p.nodes[s]] : Vec3::Zero();
  Vec6v s0;
  shell_strains(p, X, s0);
  p.B[0] = -s0[3];
  p.B[1] = -s0[4];
  p.B[2] = -0.5 * s0[5];
  return p;
}

}  // namespace

ShellDomain::ShellDomain(const Mesh& mesh, ShellSpec spec) : spec_(std::move(spec)), section_(spec_.section) {
  if (!section_) throw InputError("shell.layers", "", "a shell needs a section (its layers)");
  if (spec_.triangles.empty()) throw InputError("shell", "", "no triangles");
  topology_ = shell_topology(spec_.triangles, mesh.num_nodes(), spec_.orient, "shell");
  for (const auto& [name, tris] : spec_.groups)
    for (int t : tris)
      if (t < 0 || t >= int(spec_.triangles.size()))
        throw InputError("shell", name, "group refers to triangle " + std::to_string(t) + " of " + std::to_string(spec_.triangles.size()));
  std::map<std::pair<int, int>, ShellEdge> edges;
  for (const auto& [nodes, kind] : spec_.edges)
    edges[{std::min(nodes[0], nodes[1]), std::max(nodes[0], nodes[1])}] = kind;
  patches_.resize(spec_.triangles.size());
  for (int e = 0; e < int(patches_.size()); ++e) {
    bool fallback = false;
    patches_[e] = make_patch(mesh, spec_.triangles, topology_, e, edges, spec_.frame, fallback);
    frame_fallbacks_ += fallback;
    for (int k = 0; k < 3; ++k) has_clamped_ |= patches_[e].kind[k] == 2;
  }
}

void ShellDomain::validate(const Mesh& mesh) const {
  for (const ShellPatch& p : patches_)
    for (int n : p.nodes)
      if (n >= mesh.num_nodes()) throw InputError("shell", std::to_string(n), "node id out of range");
}

void ShellDomain::declare_couplings(Couplings& couplings) const {
  for (const ShellPatch& p : patches_) {
    std::array<int, 6> present;
    int n = 0;
    for (int s : p.nodes)
      if (s >= 0) present[n++] = s;
    couplings.add(present.data(), n);
  }
}

void ShellDomain::init_state(double* state) const {
  const int ss = section_->state_size();
  if (ss == 0) return;
  for (std::size_t e = 0; e < patches_.size(); ++e) section_->init_state(state + e * ss);
}

namespace {

/// One triangle's share of the residual and tangent, its patch dofs compacted to the present ones.
struct TriangleTerms {
  int nd = 0;
  std::array<int, 18> dofs;
  Eigen::Matrix<double, 18, 1> r;
  Mat18 K;
};

}  // namespace

MaterialStatus ShellDomain::assemble(const Mesh& mesh, const Iterate& it, AssemblySink& sink) const {
  // The triangles' terms are computed in parallel a chunk at a time and added to the sink in triangle
  // order by one thread (sinks are not thread-safe; the order keeps the sums deterministic). The chunk
  // bounds the buffer (2.7 kB per triangle) and lets a failed material call stop the loop early.
  const int ss = section_->state_size();
  const bool tangent = sink.tangent();
  const int ne = int(patches_.size());
  constexpr int kChunk = 2048;
  std::vector<TriangleTerms> terms(std::min(ne, kChunk));
  std::vector<MaterialStatus> status(terms.size());
  for (int begin = 0; begin < ne; begin += kChunk) {
    const int count = std::min(kChunk, ne - begin);
#pragma omp parallel if (count >= 256)
    {
      SectionResponse resp;  // per thread: its points warm-start the next triangle's
      Eigen::Matrix<double, 6, 18> B;
      Mat18 G;
      std::array<int, 18> local;  // patch dof of each present dof
#pragma omp for schedule(static)
      for (int k = 0; k < count; ++k) {
        const int e = begin + k;
        const ShellPatch& p = patches_[e];
        TriangleTerms& out = terms[k];
        std::array<Vec3, 6> x;
        out.nd = 0;
        for (int s = 0; s < 6; ++s) {
          if (p.nodes[s] < 0) continue;
          x[s] = it.position(mesh, p.nodes[s]);
          for (int i = 0; i < 3; ++i) {
            out.dofs[out.nd] = 3 * p.nodes[s] + i;
            local[out.nd++] = 3 * s + i;
          }
        }
        Vec6v strains;
        shell_kinematics(p, x, strains, B);
        const double* so = ss > 0 && it.state_old ? it.state_old + std::size_t(e) * ss : nullptr;
        double* sn = ss > 0 && it.state_new ? it.state_new + std::size_t(e) * ss : nullptr;
        status[k] = section_->evaluate(strains.head<3>(), strains.tail<3>(), so, sn, it.dt, tangent, resp);
        if (status[k] != MaterialStatus::ok) continue;
        Vec6v NM;
        NM << resp.N, resp.M;
        const Vec18s rp = p.area * (B.transpose() * NM);
        for (int q = 0; q < out.nd; ++q) out.r[q] = rp[local[q]];
        if (!tangent) continue;
        shell_geometric_stiffness(p, x, NM, G);
        G.noalias() += B.transpose() * resp.tangent * B;
        for (int b = 0; b < out.nd; ++b)
          for (int a = 0; a < out.nd; ++a) out.K(a, b) = p.area * G(local[a], local[b]);
      }
    }
    for (int k = 0; k < count; ++k)
      if (status[k] != MaterialStatus::ok) return status[k];
    for (int k = 0; k < count; ++k) {
      TriangleTerms& t = terms[k];
      sink.add_residual(t.nd, t.dofs.data(), t.r.data());
      if (!tangent) continue;
      // Column-major nd × nd: compact the leading block in place (column b starts at b · nd).
      for (int b = 0; b < t.nd; ++b)
        for (int a = 0; a < t.nd; ++a) t.K.data()[a + t.nd * b] = t.K(a, b);
      sink.add_tangent(t.nd, t.dofs.data(), t.nd, t.dofs.data(), t.K.data());
    }
  }
  return MaterialStatus::ok;
}

}  // namespace softhom::fe
