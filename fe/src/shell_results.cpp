// Output quantities of the shell domain (shell.hpp): stresses per layer, principal values, thickness
// stretch and fiber directions, from the section at a converged state.
#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

#include "softhom/fe/shell.hpp"

namespace softhom::fe {
namespace {

/// The in-plane right stretch U = sqrt(C) of C = I + 2E (E Voigt, engineering shear).
Mat2 right_stretch(const Vec3v& E) {
  Mat2 C;
  C << 1.0 + 2.0 * E[0], E[2], E[2], 1.0 + 2.0 * E[1];
  const double s = std::sqrt(std::max(C.determinant(), 0.0));
  return (C + s * Mat2::Identity()) / std::sqrt(std::max(C.trace() + 2.0 * s, 1e-300));
}

/// In-plane principal values of a symmetric 2x2 [a11, a22, a12], largest first.
std::array<double, 2> principal(double a11, double a22, double a12) {
  const double m = 0.5 * (a11 + a22), r = std::hypot(0.5 * (a11 - a22), a12);
  return {m + r, m - r};
}

}  // namespace

ShellDomain::Results ShellDomain::results(const Mesh& mesh, const std::vector<double>& u, const double* state) const {
  const int ne = int(patches_.size());
  const int nl = int(section_->layers().size());
  const int ss = section_->state_size();
  Results out;
  out.thickness_stretch.assign(ne, 1.0);
  out.cauchy.assign(std::size_t(ne) * nl * 9, 0.0);
  out.principal_stress.assign(2 * std::size_t(ne), 0.0);
  out.principal_stretch.assign(3 * std::size_t(ne), 1.0);
  out.fiber.assign(3 * std::size_t(ne), 0.0);
  out.max_stress.assign(ne, 0.0);
  out.max_principal = -std::numeric_limits<double>::infinity();
  std::vector<double> scratch(ss);
  std::vector<Vec3> fibers;  // of the first layer that has fibers
  for (const ShellLayer& l : section_->layers())
    if (fibers.empty()) fibers = l.law->fiber_directions();
  SectionResponse resp;
  Iterate it;
  it.u = &u;
  for (int e = 0; e < ne; ++e) {
    const ShellPatch& p = patches_[e];
    std::array<Vec3, 6> x;
    for (int s = 0; s < 6; ++s)
      if (p.nodes[s] >= 0) x[s] = it.position(mesh, p.nodes[s]);
    Vec6v strains;
    shell_strains(p, x, strains);
    const Vec3v eps = strains.head<3>(), kap = strains.tail<3>();
    if (section_->evaluate(eps, kap, state ? state + std::size_t(e) * ss : nullptr, ss ? scratch.data() : nullptr, 0.0,
                           false, resp) != MaterialStatus::ok)
      continue;
    out.thickness_stretch[e] = resp.thickness_stretch;
    const Mat2 U = right_stretch(eps);
    const auto stretch = principal(U(0, 0), U(1, 1), U(0, 1));
    out.principal_stretch[3 * e] = stretch[0];
    out.principal_stretch[3 * e + 1] = stretch[1];
    out.principal_stretch[3 * e + 2] = resp.thickness_stretch;
    // σ at every section point (the deformation at z: U(ε + z κ), the mid-surface's rotation), in the
    // local frame carried along by that rotation.
    std::vector<int> first(nl, -1), last(nl, -1), count(nl, 0);
    double best_mid = std::numeric_limits<double>::infinity();
    for (int q = 0; q < section_->num_points(); ++q) {
      const SectionPoint& sp = resp.points[q];
      const Mat3 sigma = shell_cauchy_stress(sp.S, right_stretch(eps + sp.z * kap), sp.lambda3);
      const auto pr = principal(sigma(0, 0), sigma(1, 1), sigma(0, 1));
      out.max_stress[e] = q == 0 ? pr[0] : std::max(out.max_stress[e], pr[0]);
      if (pr[0] > out.max_principal) {
        out.max_principal = pr[0];
        out.max_element = e;
      }
      if (std::abs(sp.z) < best_mid) {  // the point nearest the mid-surface
        best_mid = std::abs(sp.z);
        out.principal_stress[2 * e] = pr[0];
        out.principal_stress[2 * e + 1] = pr[1];
      }
      const int L = sp.layer;
      if (first[L] < 0) first[L] = q;
      last[L] = q;
      ++count[L];
    }
    for (int L = 0; L < nl; ++L) {
      if (first[L] < 0) continue;
      const int pick[3] = {first[L], first[L] + (count[L] - 1) / 2, last[L]};  // bottom, middle, top
      for (int k = 0; k < 3; ++k) {
        const SectionPoint& sp = resp.points[pick[k]];
        const Mat3 sigma = shell_cauchy_stress(sp.S, right_stretch(eps + sp.z * kap), sp.lambda3);
        double* c = &out.cauchy[(std::size_t(e) * nl + L) * 9 + 3 * k];
        c[0] = sigma(0, 0);
        c[1] = sigma(1, 1);
        c[2] = sigma(0, 1);
      }
    }
    if (!fibers.empty()) {
      Vec3 a1 = Vec3::Zero(), a2 = Vec3::Zero();
      for (int c = 0; c < 3; ++c) {
        a1 += p.dN[c][0] * x[c];
        a2 += p.dN[c][1] * x[c];
      }
      const Vec3 a = (fibers[0][0] * a1 + fibers[0][1] * a2).normalized();
      for (int i = 0; i < 3; ++i) out.fiber[3 * e + i] = a[i];
    }
  }
  if (out.max_element < 0) out.max_principal = 0.0;
  return out;
}

void ShellDomain::report(const Mesh& mesh, const Iterate& it, ContributionReport& out) const {
  const Results r = results(mesh, *it.u, it.state_old);
  out.probes.emplace_back("shell max principal stress [MPa]", r.max_principal);
  out.probes.emplace_back("shell max principal element [-]", double(r.max_element));
  // The largest in-plane principal stretch of the mid-surface, overall and per group.
  auto max_over = [](const std::vector<double>& v, int stride, const std::vector<int>* subset, int count) {
    double m = 0.0;
    for (int k = 0; k < (subset ? int(subset->size()) : count); ++k)
      m = std::max(m, v[std::size_t(stride) * (subset ? (*subset)[k] : k)]);
    return m;
  };
  const int ne = int(patches_.size());
  out.probes.emplace_back("shell max principal stretch [-]", max_over(r.principal_stretch, 3, nullptr, ne));
  for (const auto& [name, tris] : spec_.groups) {
    double stress = -std::numeric_limits<double>::infinity();
    for (int t : tris) stress = std::max(stress, r.max_stress[t]);
    out.probes.emplace_back("shell " + name + " max principal stress [MPa]", tris.empty() ? 0.0 : stress);
    out.probes.emplace_back("shell " + name + " max principal stretch [-]", max_over(r.principal_stretch, 3, &tris, ne));
  }
  ReportField f;
  f.cells.stem = "shell";
  f.cells.type = ReportCells::Type::triangle3;
  // The shell's own points: its triangles' nodes, renumbered in order of first use.
  std::vector<int> point_of(mesh.num_nodes(), -1), nodes;
  for (const Tri3& t : spec_.triangles)
    for (int n : t) {
      if (point_of[n] < 0) {
        point_of[n] = int(nodes.size());
        nodes.push_back(n);
        f.cells.points.push_back(mesh.nodes[n]);
      }
      f.cells.connectivity.push_back(point_of[n]);
    }
  const int nl = int(section_->layers().size());
  f.arrays.push_back({"thickness_stretch", "-", 1, true, r.thickness_stretch});
  const char* position[3] = {"bottom", "middle", "top"};
  for (int L = 0; L < nl; ++L)
    for (int k = 0; k < 3; ++k) {
      ReportArray a{"cauchy_layer" + std::to_string(L) + "_" + position[k], "MPa", 3, true, {}};
      for (std::size_t e = 0; e < patches_.size(); ++e)
        for (int c = 0; c < 3; ++c) a.values.push_back(r.cauchy[(e * nl + L) * 9 + 3 * k + c]);
      f.arrays.push_back(std::move(a));
    }
  ReportArray ps{"principal_stress", "MPa", 3, true, {}}, pl{"principal_stretch", "-", 3, true, {}};
  for (std::size_t e = 0; e < patches_.size(); ++e) {
    ps.values.insert(ps.values.end(), {r.principal_stress[2 * e], r.principal_stress[2 * e + 1], 0.0});
    pl.values.insert(pl.values.end(), r.principal_stretch.begin() + 3 * e, r.principal_stretch.begin() + 3 * e + 3);
  }
  f.arrays.push_back(std::move(ps));
  f.arrays.push_back(std::move(pl));
  f.arrays.push_back({"fiber_direction", "-", 3, true, r.fiber});
  ReportArray u{"displacement", "mm", 3, false, {}};
  for (int n : nodes)
    for (int i = 0; i < 3; ++i) u.values.push_back((*it.u)[3 * n + i]);
  f.arrays.push_back(std::move(u));
  out.fields.push_back(std::move(f));
}

}  // namespace softhom::fe
