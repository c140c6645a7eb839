// Contact between deformable surfaces (fe/surface_contact.hpp) at growing size: two stacked blocks
// (neo-Hookean G = 1, K = 20; the lower n × n × n/2 hex8 on [0, 1]² × [0, 1], the upper 2n × 2n × n/2 on
// [0, 1]² × [1, 2], its faces nested in the lower's) pressed by 0.05 in 4 steps on symmetry planes. Per
// size: dofs, contact points, the stiffness pattern's rebuilds and their cost (the pattern and scatter
// positions, then the symbolic analysis) against one numeric factorization, Newton iterations, time, and
// the patch test's worst face pressure against the applied traction.
//
//   build/bench/bench_contact_pairs [max_n]     (n = 2, 4, 8, … up to max_n, default 8)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>

#include "softhom/fe/solver.hpp"
#include "softhom/fe/surface_contact.hpp"
#include "softhom/materials/laws.hpp"

using namespace softhom;
using namespace softhom::fe;

namespace {

void add_block(Mesh& m, int n, int layers, double z0) {
  const int base = m.num_nodes();
  auto id = [&](int i, int j, int k) { return base + i + (n + 1) * (j + (n + 1) * k); };
  for (int k = 0; k <= layers; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) m.nodes.emplace_back(double(i) / n, double(j) / n, z0 + double(k) / layers);
  for (int k = 0; k < layers; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        m.hexes.push_back({id(i, j, k), id(i + 1, j, k), id(i + 1, j + 1, k), id(i, j + 1, k), id(i, j, k + 1),
                           id(i + 1, j, k + 1), id(i + 1, j + 1, k + 1), id(i, j + 1, k + 1)});
}

ContactSurface named(const Mesh& m, const std::string& name) { return {m.surfaces.at(name), {}, name}; }

}  // namespace

int main(int argc, char** argv) {
  const int max_n = argc > 1 ? std::atoi(argv[1]) : 8;
  std::printf("%4s %8s %8s %9s %11s %11s %11s %8s %8s %10s\n", "n", "dofs", "points", "rebuilds", "rebuild_s",
              "analysis_s", "factor_s", "newton", "time_s", "max_dev");
  for (int n = 2; n <= max_n; n *= 2) {
    const auto t0 = std::chrono::steady_clock::now();
    Mesh m;
    add_block(m, n, std::max(1, n / 2), 0.0);
    add_block(m, 2 * n, std::max(1, n / 2), 1.0);
    name_boundary_faces(m, [](const Vec3& c, const Vec3& nrm) -> std::string {
      if (nrm[2] < -0.9) return c[2] < 0.5 ? "base" : "upper_bottom";
      if (nrm[2] > 0.9) return c[2] < 1.5 ? "lower_top" : "press";
      if (nrm[0] < -0.9) return "xmin";
      if (nrm[1] < -0.9) return "ymin";
      return "";
    });
    FeModel model;
    model.mesh = m;
    model.element_material.assign(m.num_elements(), make_material(make_neo_hookean({1.0, 20.0})));
    const std::pair<const char*, int> holds[4] = {{"xmin", 0}, {"ymin", 1}, {"base", 2}, {"press", 2}};
    for (const auto& [surface, comp] : holds) {
      DirichletGroup g;
      for (int node : surface_nodes(m, surface)) g.dofs.push_back(3 * node + comp);
      if (std::string(surface) == "press") g.value = PiecewiseLinear{{0.0, 1.0}, {0.0, -0.05}};
      model.dirichlet.push_back(g);
    }
    SurfaceContact::Options o;
    o.shear_modulus = 1.0;
    o.label = "pair";
    auto contact = std::make_shared<SurfaceContact>(m, named(m, "upper_bottom"), named(m, "lower_top"), o);
    model.add(contact);
    Simulation sim(model);
    for (int s = 1; s <= 4; ++s)
      if (!sim.advance_to(s / 4.0).reached()) {
        std::printf("n = %d: stopped at step %d\n", n, s);
        return 1;
      }
    ContributionReport report;
    sim.report(report);
    std::vector<int> top;
    for (int node : surface_nodes(m, "press")) top.push_back(3 * node + 2);
    const std::vector<double>& u = sim.displacement();
    double area = 1.0;
    for (int node = 0; node < m.num_nodes(); ++node)
      if ((m.nodes[node] - Vec3(1, 1, 2)).norm() < 1e-12) area = (1 + u[3 * node]) * (1 + u[3 * node + 1]);
    const double applied = -sim.reaction(top) / area;
    double dev = 0.0;
    for (const ReportField& f : report.fields)
      for (const ReportArray& a : f.arrays)
        if (a.name == "contact_pressure")
          for (double p : a.values) dev = std::max(dev, std::abs(p - applied) / applied);
    const RunStats st = sim.stats();
    const double factor = st.linear.factorizations ? st.linear.factorization / st.linear.factorizations : 0.0;
    std::printf("%4d %8d %8d %9d %11.3g %11.3g %11.3g %8d %8.3g %10.2g\n", n, sim.num_free_dofs(), contact->num_points(),
                st.pattern_rebuilds, st.pattern_rebuild_time / std::max(1, st.pattern_rebuilds), st.linear.analysis, factor,
                st.newton_iterations,
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), dev);
  }
  return 0;
}
