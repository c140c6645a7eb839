// The bending actuator's gauge (bending_gauge.hpp): end rotation, chord angle, tip displacement.
#include "softhom/macro/bending_gauge.hpp"

#include <Eigen/SVD>
#include <cmath>
#include <numbers>

#include "softhom/core/input_error.hpp"

namespace softhom::macro {
namespace {

Vec3 centroid(const std::vector<int>& nodes, const std::vector<Vec3>& y) {
  Vec3 c = Vec3::Zero();
  for (int n : nodes) c += y[n];
  return c / double(nodes.size());
}

constexpr double kDeg = 180.0 / std::numbers::pi;

}  // namespace

double end_rotation_deg(const std::vector<int>& end, const std::vector<Vec3>& X, const std::vector<Vec3>& x,
                        double chord_angle_deg) {
  const Vec3 C = centroid(end, X), c = centroid(end, x);
  Mat3 H = Mat3::Zero();
  for (int n : end) H += (x[n] - c) * (X[n] - C).transpose();
  // R = U Vᵀ (with the sign that makes it a rotation): the rotation nearest the end's deformation.
  const Eigen::JacobiSVD<Mat3> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 D = Mat3::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0) D(2, 2) = -1.0;
  const Vec3 axis = svd.matrixU() * D * svd.matrixV().transpose() * Vec3::UnitZ();
  const double theta = std::atan2(std::hypot(axis[0], axis[1]), axis[2]) * kDeg;
  return chord_angle_deg > 90.0 ? 360.0 - theta : theta;
}

BendingGauge::BendingGauge(const fe::Mesh& mesh, const std::string& field) {
  for (const char* name : {"zmin", "zmax"})
    if (!mesh.has_surface(name))
      throw InputError(field, "\"bending\"", std::string("the bending gauge needs the physical surface \"") + name + "\"");
  clamp_ = fe::surface_nodes(mesh, "zmin");
  end_ = fe::surface_nodes(mesh, "zmax");
  if (end_.size() < 3) throw InputError(field, "\"bending\"", "the free end \"zmax\" has fewer than 3 nodes");
}

std::vector<std::string> BendingGauge::columns() {
  return {"bending_angle_deg", "chord_angle_deg", "tip_ux_mm", "tip_uy_mm", "tip_uz_mm"};
}

std::vector<double> BendingGauge::values(const std::vector<Vec3>& X, const std::vector<Vec3>& x) const {
  const Vec3 root = centroid(clamp_, x), tip = centroid(end_, x), u = tip - centroid(end_, X);
  const Vec3 chord = tip - root;
  const double phi = std::atan2(std::hypot(chord[0], chord[1]), chord[2]) * kDeg;
  return {end_rotation_deg(end_, X, x, phi), phi, u[0], u[1], u[2]};
}

}  // namespace softhom::macro
