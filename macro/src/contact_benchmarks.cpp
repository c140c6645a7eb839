// The shared contact problems (contact_benchmarks.hpp).
#include "softhom/macro/contact_benchmarks.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Dense>

#include "softhom/macro/geometry.hpp"
#include "softhom/materials/laws.hpp"

namespace softhom::macro {
namespace {

/// Node coordinates 0 … length: `fine` equal cells over fine_length, then `coarse` cells growing by a
/// common ratio (found by bisection) to length.
std::vector<double> graded(int fine, double fine_length, int coarse, double length) {
  const double h = fine_length / fine;
  std::vector<double> x;
  for (int i = 0; i <= fine; ++i) x.push_back(i * h);
  if (coarse == 0) return x;
  auto span = [&](double r) {  // h r + h r² + … + h r^coarse
    double s = 0.0, c = h;
    for (int k = 0; k < coarse; ++k) s += (c *= r);
    return s;
  };
  double lo = 1.0, hi = 10.0;
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    (span(mid) < length - fine_length ? lo : hi) = mid;
  }
  double c = h;
  for (int k = 0; k < coarse; ++k) x.push_back(x.back() + (c *= lo));
  x.back() = length;
  return x;
}

}  // namespace

double HertzProblem::force(double d) const { return 4.0 / 3.0 * effective_modulus * std::sqrt(radius) * std::pow(d, 1.5); }

double HertzProblem::contact_radius(double f) const { return std::cbrt(3.0 * f * radius / (4.0 * effective_modulus)); }

HertzProblem make_hertz_problem(int fine, int coarse, double depth) {
  HertzProblem p;
  p.depth = depth;
  const double G = 1.0, nu = 0.3, K = 2.0 * G * (1 + nu) / (3 * (1 - 2 * nu));
  p.effective_modulus = 2.0 * G * (1 + nu) / (1 - nu * nu);
  const double a = std::sqrt(p.radius * depth), L = 20.0 * a;
  const std::vector<double> xs = graded(fine, 1.25 * a, coarse, L);
  const int n = int(xs.size());
  fe::Mesh& m = p.model.mesh;
  auto id = [&](int i, int j, int k) { return i + n * (j + n * k); };
  for (int k = 0; k < n; ++k)  // z from −L (k = 0) up to the surface z = 0 (k = n − 1), fine at the top
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) m.nodes.emplace_back(xs[i], xs[j], -xs[n - 1 - k]);
  for (int k = 0; k + 1 < n; ++k)
    for (int j = 0; j + 1 < n; ++j)
      for (int i = 0; i + 1 < n; ++i)
        m.hexes.push_back({id(i, j, k), id(i + 1, j, k), id(i + 1, j + 1, k), id(i, j + 1, k), id(i, j, k + 1),
                           id(i + 1, j, k + 1), id(i + 1, j + 1, k + 1), id(i, j + 1, k + 1)});
  fe::name_boundary_faces(m, [](const Vec3&, const Vec3& nrm) -> std::string {
    if (nrm[2] > 0.9) return "top";
    if (nrm[2] < -0.9) return "bottom";
    if (nrm[0] < -0.9) return "xmin";
    if (nrm[1] < -0.9) return "ymin";
    return "";
  });
  p.model.element_material.assign(m.num_elements(), make_material(make_neo_hookean({G, K})));
  const std::pair<const char*, int> supports[3] = {{"xmin", 0}, {"ymin", 1}, {"bottom", 2}};
  for (const auto& [surface, comp] : supports) {
    fe::DirichletGroup g;
    for (int node : fe::surface_nodes(m, surface)) g.dofs.push_back(3 * node + comp);
    p.model.dirichlet.push_back(g);
  }
  fe::RigidObstacle sphere;
  sphere.shape = fe::RigidObstacle::Shape::sphere;
  sphere.point = Vec3(0, 0, p.radius);
  sphere.radius = p.radius;
  sphere.path[2] = PiecewiseLinear{{0.0, 1.0}, {0.0, -depth}};
  fe::ObstacleContact::Options opt;
  opt.shear_modulus = G;
  opt.field = "hertz";
  auto contact = std::make_shared<fe::ObstacleContact>(m, m.surfaces.at("top"), std::vector<fe::Tri6>{}, sphere, opt);
  p.contact = contact;
  p.model.add(contact);
  return p;
}

double HertzSpheresProblem::force(double d) const {
  return 4.0 / 3.0 * effective_modulus * std::sqrt(effective_radius) * std::pow(d, 1.5);
}

double HertzSpheresProblem::contact_radius(double f) const {
  return std::cbrt(3.0 * f * effective_radius / (4.0 * effective_modulus));
}

namespace {

/// One body of the sphere pair: the graded quarter block over xs (x, y) and xs (depth from the contact
/// plane), its facing surface on the sphere of radius R, on the side `side` (+1: above z = 0).
void add_sphere_body(fe::Mesh& m, const std::vector<double>& xs, double R, double side) {
  const int n = int(xs.size()), base = m.num_nodes();
  const double L = xs.back();
  auto id = [&](int i, int j, int k) { return base + i + n * (j + n * k); };
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const double r2 = xs[i] * xs[i] + xs[j] * xs[j], cap = R - std::sqrt(R * R - r2);
        m.nodes.emplace_back(xs[i], xs[j], side * (xs[k] + cap * (1.0 - xs[k] / L)));
      }
  for (int k = 0; k + 1 < n; ++k)
    for (int j = 0; j + 1 < n; ++j)
      for (int i = 0; i + 1 < n; ++i)
        m.hexes.push_back({id(i, j, k), id(i + 1, j, k), id(i + 1, j + 1, k), id(i, j + 1, k), id(i, j, k + 1),
                           id(i + 1, j, k + 1), id(i + 1, j + 1, k + 1), id(i, j + 1, k + 1)});
}

}  // namespace

HertzSpheresProblem make_hertz_spheres_problem(int fine, int coarse, double approach) {
  HertzSpheresProblem p;
  p.approach = approach;
  const double nu = 0.3, G1 = 1.0, G2 = 2.0;
  const double E1 = 2.0 * G1 * (1 + nu), E2 = 2.0 * G2 * (1 + nu);
  p.effective_radius = 1.0 / (1.0 / p.radius1 + 1.0 / p.radius2);
  p.effective_modulus = 1.0 / ((1 - nu * nu) / E1 + (1 - nu * nu) / E2);
  const double a = std::sqrt(p.effective_radius * approach), L = 10.0 * a;
  p.fine_size = 1.25 * a / fine;
  const std::vector<double> xs = graded(fine, 1.25 * a, coarse, L);
  fe::Mesh& m = p.model.mesh;
  add_sphere_body(m, xs, p.radius1, 1.0);
  const int upper_hexes = int(m.hexes.size());
  add_sphere_body(m, xs, p.radius2, -1.0);
  fe::orient_hexes(m);
  const double tol = 1e-9 * L;
  fe::name_boundary_faces(m, [&](const Vec3& c, const Vec3&) -> std::string {
    if (c[0] < tol) return "xmin";
    if (c[1] < tol) return "ymin";
    if (c[0] > L - tol || c[1] > L - tol) return "";
    if (c[2] > L - tol) return "upper_far";
    if (c[2] < -L + tol) return "lower_far";
    return c[2] > 0.0 ? "upper_contact" : "lower_contact";
  });
  const auto law = [](double G, double nu_) {
    return make_material(make_neo_hookean({G, 2.0 * G * (1 + nu_) / (3 * (1 - 2 * nu_))}));
  };
  p.model.element_material.assign(m.num_elements(), law(G2, nu));
  std::fill(p.model.element_material.begin(), p.model.element_material.begin() + upper_hexes, law(G1, nu));
  const std::pair<const char*, int> supports[3] = {{"xmin", 0}, {"ymin", 1}, {"lower_far", 2}};
  for (const auto& [surface, comp] : supports) {
    fe::DirichletGroup g;
    for (int node : fe::surface_nodes(m, surface)) g.dofs.push_back(3 * node + comp);
    p.model.dirichlet.push_back(g);
  }
  fe::DirichletGroup press;
  for (int node : fe::surface_nodes(m, "upper_far")) press.dofs.push_back(3 * node + 2);
  press.value = PiecewiseLinear{{0.0, 1.0}, {0.0, -approach}};
  p.model.dirichlet.push_back(press);
  fe::SurfaceContact::Options opt;
  opt.shear_modulus = G1;  // the softer body's
  opt.field = "hertz_spheres";
  opt.label = "spheres";
  fe::ContactSurface upper{m.surfaces.at("upper_contact"), {}, "upper_contact"};
  fe::ContactSurface lower{m.surfaces.at("lower_contact"), {}, "lower_contact"};
  auto contact = std::make_shared<fe::SurfaceContact>(m, std::move(upper), std::move(lower), opt);
  p.contact = contact;
  p.model.add(contact);
  return p;
}

IroningProblem make_ironing_problem(int cells, double friction) {
  IroningProblem p;
  p.friction = friction;
  const PlateSpec spec{Vec3(15.0, 3.0, 4.0), {15 * cells, 3 * cells, 4 * cells}};
  fe::Mesh m = make_plate(spec);
  p.model.mesh = m;
  p.model.element_material.assign(m.num_elements(), make_material(make_neo_hookean(NeoHookeanParams::from_young(1.0, 0.3))));
  const std::pair<const char*, std::vector<int>> supports[3] = {{"zmin", {0, 1, 2}}, {"ymin", {1}}, {"ymax", {1}}};
  for (const auto& [surface, comps] : supports) {
    fe::DirichletGroup g;
    for (int node : fe::surface_nodes(m, surface))
      for (int comp : comps) g.dofs.push_back(3 * node + comp);
    p.model.dirichlet.push_back(g);
  }
  fe::RigidObstacle die;
  die.shape = fe::RigidObstacle::Shape::cylinder;
  die.radius = 3.0;
  die.point = Vec3(2.5, 0.0, 4.0 + die.radius);
  die.direction = Vec3::UnitY();
  die.path[0] = PiecewiseLinear{{0.0, 1.0, 2.0}, {0.0, 0.0, p.slide}};
  die.path[2] = PiecewiseLinear{{0.0, 1.0, 2.0}, {0.0, -p.depth, -p.depth}};
  fe::ObstacleContact::Options opt;
  opt.shear_modulus = NeoHookeanParams::from_young(1.0, 0.3).mu;
  opt.law.friction = p.friction;
  // The stick penalty a tenth of the normal one: with ε_T = ε_N the die, which takes every point of its
  // patch from stick to slip at once as it starts to slide, stalled the coarse run (1 048 Newton
  // iterations in cut-backs pressing, then no convergence); the slip force μ p does not depend on it.
  opt.law.tangential_penalty = 0.1 * fe::default_contact_penalty(opt.shear_modulus, 1.0 / cells);
  opt.field = "ironing";
  auto contact = std::make_shared<fe::ObstacleContact>(m, m.surfaces.at("zmax"), std::vector<fe::Tri6>{}, die, opt);
  p.contact = contact;
  p.model.add(contact);
  return p;
}

double hertz_coefficient(const std::vector<double>& force, const std::vector<double>& indentation, double* compliance) {
  Eigen::MatrixXd A(force.size(), 2);
  Eigen::VectorXd d(force.size());
  for (std::size_t i = 0; i < force.size(); ++i) {
    A(Eigen::Index(i), 0) = std::pow(force[i], 2.0 / 3.0);
    A(Eigen::Index(i), 1) = force[i];
    d[Eigen::Index(i)] = indentation[i];
  }
  const Eigen::Vector2d c = A.colPivHouseholderQr().solve(d);
  if (compliance) *compliance = c[1];
  return c[0];
}

}  // namespace softhom::macro
