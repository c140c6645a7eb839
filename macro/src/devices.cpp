#include "softhom/macro/devices.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "softhom/core/keys.hpp"
#include "softhom/fe/surface_contact.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::macro {
namespace {

/// Components of the nodes of `tris` connected through shared triangles (union-find).
std::vector<std::vector<int>> connected_node_sets(const std::vector<fe::Tri6>& tris) {
  std::map<int, int> parent;
  auto find = [&](int a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  for (const auto& t : tris)
    for (int n : t) parent.emplace(n, n);
  for (const auto& t : tris)
    for (int k = 1; k < 6; ++k) {
      const int a = find(t[0]), b = find(t[k]);
      if (a != b) parent[b] = a;
    }
  std::map<int, std::vector<int>> groups;
  for (const auto& [n, p] : parent) groups[find(n)].push_back(n);
  std::vector<std::vector<int>> out;
  for (auto& [root, nodes] : groups) out.push_back(std::move(nodes));
  return out;
}

Vec3 centroid(const std::vector<Vec3>& x, const std::vector<int>& nodes) {
  Vec3 c = Vec3::Zero();
  for (int n : nodes) c += x[n];
  return nodes.empty() ? c : Vec3(c / double(nodes.size()));
}

double mean_distance(const std::vector<Vec3>& x, const std::vector<int>& nodes) {
  const Vec3 c = centroid(x, nodes);
  double sum = 0.0;
  for (int n : nodes) sum += (x[n] - c).norm();
  return nodes.empty() ? 0.0 : sum / double(nodes.size());
}

/// A fixed plane through the z axis (normal horizontal, the origin on it): a mirror plane of the gripper.
bool is_axial_mirror_plane(const fe::RigidObstacle& o) {
  const double tol = 1e-9 * (1.0 + o.point.norm());
  bool fixed = true;
  for (const PiecewiseLinear& u : o.path)
    for (double v : u.v) fixed = fixed && v == 0.0;
  return o.shape == fe::RigidObstacle::Shape::plane && fixed && std::abs(o.direction[2]) < 1e-9 &&
         std::abs(o.point.dot(o.direction)) < tol;
}

void require_surface(const fe::Mesh& mesh, const std::string& name, const std::string& field) {
  if (!mesh.has_surface(name))
    throw InputError(field, "\"" + name + "\"", "no physical surface of that name in the mesh");
}

}  // namespace

DeviceProbe::DeviceProbe(const DeviceSpec& spec, const Structure& structure) : spec_(spec), structure_(&structure) {
  const fe::Mesh& mesh = structure.model.mesh;
  const auto& X = mesh.nodes;
  if (spec.kind == DeviceKind::cpasmo) {
    require_surface(mesh, spec.top_surface, "device.top_surface");
    top_ = fe::surface_nodes(mesh, spec.top_surface);
    top_z0_ = -1e300;
    for (int n : top_) top_z0_ = std::max(top_z0_, X[n][2]);
    for (int k = 1; k <= spec.regions; ++k) {
      const std::string name = spec.well_prefix + std::to_string(k);
      require_surface(mesh, name, "device.well_prefix");
      std::vector<Well> wells;
      for (const auto& nodes : connected_node_sets(mesh.tri_surface(name))) {
        // The rim: the wall's nodes at its top (the opening in the top surface).
        double zmax = -1e300;
        for (int n : nodes) zmax = std::max(zmax, X[n][2]);
        Well w;
        for (int n : nodes)
          if (X[n][2] > zmax - 1e-9 * (1.0 + std::abs(zmax))) w.rim.push_back(n);
        w.r0 = mean_distance(X, w.rim);
        if (w.rim.size() >= 3 && w.r0 > 0.0) wells.push_back(std::move(w));
      }
      if (wells.empty()) throw InputError("device.well_prefix", "\"" + name + "\"", "the surface holds no well wall");
      regions_.push_back(std::move(wells));
    }
  } else if (spec.kind == DeviceKind::gripper) {
    const double pitch = 2.0 * M_PI / spec.fingers;
    for (std::size_t i = 0; i < spec.tips.size(); ++i) {
      const std::string field = keys::index_field("device.tips", i);
      require_surface(mesh, spec.tips[i], field);
      Finger f;
      f.tip = fe::surface_nodes(mesh, spec.tips[i]);
      const Vec3 c = centroid(X, f.tip);
      // The finger's radial direction: its centroid's azimuth snapped to the finger pitch (a finger cut
      // by a symmetry plane has its centroid off its mid-plane).
      const double azimuth = std::atan2(c[1], c[0]), phi = pitch * std::round(azimuth / pitch);
      f.radial = Vec3(std::cos(phi), std::sin(phi), 0.0);
      const Vec3 tangent(-f.radial[1], f.radial[0], 0.0);
      double r_lo = 1e300, r_hi = -1e300, t_lo = 1e300, t_hi = -1e300;
      for (int n : f.tip) {
        r_lo = std::min(r_lo, X[n].dot(f.radial)), r_hi = std::max(r_hi, X[n].dot(f.radial));
        t_lo = std::min(t_lo, X[n].dot(tangent)), t_hi = std::max(t_hi, X[n].dot(tangent));
      }
      // Cut by a mirror plane through its middle: its tip reaches out on one side of the finger's
      // mid-plane only (an unstructured mesh's nodal centroid is never exactly on it).
      f.share = std::abs(t_hi + t_lo) > 0.25 * (t_hi - t_lo) ? 0.5 : 1.0;
      const double tol = 1e-6 * (1.0 + r_hi - r_lo);
      for (int n = 0; n < int(X.size()); ++n) {
        const double r = X[n].dot(f.radial), t = X[n].dot(tangent);
        if (std::abs(X[n][2] - spec.root_z) < tol && r > r_lo - tol && r < r_hi + tol && t > t_lo - tol && t < t_hi + tol)
          f.root.push_back(n);
      }
      if (f.root.empty())
        throw InputError("device.root_z", format_number(spec.root_z),
                         "no mesh node at that height under the fingertip \"" + spec.tips[i] + "\"");
      const Vec3 d = centroid(X, f.tip) - centroid(X, f.root);
      f.angle0 = std::atan2(-d.dot(f.radial), d[2]);
      fingers_.push_back(std::move(f));
    }
    if (!spec.sample_surface.empty()) {
      require_surface(mesh, spec.sample_surface, "device.sample_surface");
      sample_ = fe::surface_nodes(mesh, spec.sample_surface);
      sample_reach0_ = sample_reach(X);
      if (!(sample_reach0_ > 0.0))
        throw InputError("device.sample_surface", "\"" + spec.sample_surface + "\"",
                         "the sample does not reach out from the axis towards the fingers");
    }
    for (const auto& c : structure.model.contributions) {
      if (const auto* contact = dynamic_cast<const fe::ObstacleContact*>(c.get()))
        contacts_.push_back({contact->options().label, contact, is_axial_mirror_plane(contact->obstacle())});
      else if (const auto* pair = dynamic_cast<const fe::SurfaceContact*>(c.get()))
        contacts_.push_back({pair->options().label, pair, false});
    }
    for (const GripContact& contact : contacts_)
      if (contact.between_fingers && spec.stop_distance > 0.0)
        throw InputError("device.stop_distance", format_number(spec.stop_distance),
                         "the stop before the fingers touch is for scenes without their contact; " + contact.label +
                             " is a mirror plane through the axis, where the fingers touch (give 0)");
  } else if (spec.kind == DeviceKind::tube) {
    tube_ = std::make_shared<const TubeGauge>(mesh, "device.kind");
  } else if (spec.kind == DeviceKind::bending) {
    bending_ = std::make_shared<const BendingGauge>(mesh, "device.kind");
  }
  volume0_ = channel_volume(X);
}

double DeviceProbe::sample_reach(const std::vector<Vec3>& x) const {
  double sum = 0.0;
  for (const Finger& f : fingers_) {
    double reach = -1e300;
    for (int n : sample_) reach = std::max(reach, x[n].dot(f.radial));
    sum += reach;
  }
  return fingers_.empty() ? 0.0 : sum / double(fingers_.size());
}

double DeviceProbe::channel_volume(const std::vector<Vec3>& x) const {
  const fe::FeModel& m = structure_->model;
  if (m.cavity) return fe::cavity_volume(x, m.cavity->faces, m.cavity->mask, m.cavity->tris);
  if (m.pressures.empty()) return 0.0;
  return fe::cavity_volume(x, m.pressures[0].faces, structure_->spec.imported.cavity_mask, m.pressures[0].tris);
}

std::vector<std::string> DeviceProbe::columns() const {
  std::vector<std::string> c{"t_s", "pressure_kPa", "channel_volume_mm3", "channel_volume_change_mm3"};
  if (spec_.kind == DeviceKind::cpasmo) {
    for (const char* n : {"max_height_mm", "max_height_theta_below45_mm", "max_height_theta_above45_mm"}) c.push_back(n);
    for (int k = 1; k <= spec_.regions; ++k) c.push_back("well_expansion_region" + std::to_string(k) + "_percent");
  } else if (spec_.kind == DeviceKind::gripper) {
    c.push_back("finger_angle_deg");
    for (const auto& t : spec_.tips) c.push_back("finger_angle_" + t + "_deg");
    c.push_back("tip_axis_distance_mm");
    bool fingers = false, sample = false;
    for (const GripContact& contact : contacts_) {
      c.push_back(contact.label + "_normal_force_N");
      (contact.between_fingers ? fingers : sample) = true;
    }
    if (fingers) c.push_back("finger_contact_force_N");
    if (sample) c.push_back("grip_force_N");
    if (!sample_.empty()) c.insert(c.end(), {"sample_reach_mm", "sample_compression_percent"});
  } else if (spec_.kind == DeviceKind::tube) {
    for (const std::string& n : TubeGauge::columns()) c.push_back(n);
  } else if (spec_.kind == DeviceKind::bending) {
    for (const std::string& n : BendingGauge::columns()) c.push_back(n);
  }
  return c;
}

std::vector<double> DeviceProbe::values(const fe::Simulation& sim) const {
  const double t = sim.time();
  const auto x = sim.current_positions();
  const auto& X = structure_->model.mesh.nodes;
  const fe::FeModel& m = structure_->model;
  const double p = m.cavity ? sim.cavity_pressure() : (m.pressures.empty() ? 0.0 : m.pressures[0].pressure(t));
  const double v = channel_volume(x);
  std::vector<double> row{t, 1e3 * p, v, v - volume0_};
  if (spec_.kind == DeviceKind::cpasmo) {
    double all = -1e300, below = -1e300, above = -1e300;
    for (int n : top_) {
      const double h = x[n][2] - top_z0_;
      all = std::max(all, h);
      const double theta = std::atan2(X[n][1], X[n][0]);
      if (theta < M_PI / 4 - 1e-9) below = std::max(below, h);
      if (theta > M_PI / 4 + 1e-9) above = std::max(above, h);
    }
    row.insert(row.end(), {all, below, above});
    for (const auto& wells : regions_) {
      double sum = 0.0;
      for (const Well& w : wells) {
        const double r = mean_distance(x, w.rim);
        sum += 100.0 * ((r * r) / (w.r0 * w.r0) - 1.0);
      }
      row.push_back(sum / double(wells.size()));
    }
  } else if (spec_.kind == DeviceKind::gripper) {
    std::vector<double> angles;
    double distance = 1e300;
    for (const Finger& f : fingers_) {
      const Vec3 d = centroid(x, f.tip) - centroid(x, f.root);
      angles.push_back((std::atan2(-d.dot(f.radial), d[2]) - f.angle0) * 180.0 / M_PI);
      for (int n : f.tip) distance = std::min(distance, std::hypot(x[n][0], x[n][1]));
    }
    row.push_back(std::accumulate(angles.begin(), angles.end(), 0.0) / double(std::max<std::size_t>(1, angles.size())));
    row.insert(row.end(), angles.begin(), angles.end());
    row.push_back(distance);
    for (double f : grip_forces(sim)) row.push_back(f);
    if (!sample_.empty()) {
      const double reach = sample_reach(x);
      row.insert(row.end(), {reach, 100.0 * (1.0 - reach / sample_reach0_)});
    }
  } else if (tube_) {
    for (double q : tube_->values(X, x)) row.push_back(q);
  } else if (bending_) {
    for (double q : bending_->values(X, x)) row.push_back(q);
  }
  return row;
}

std::vector<double> DeviceProbe::grip_forces(const fe::Simulation& sim) const {
  if (contacts_.empty()) return {};
  std::vector<double> out;
  double sample = 0.0, between = 0.0, fingers = 0.0;
  int planes = 0;
  const fe::Mesh& mesh = structure_->model.mesh;
  for (const GripContact& c : contacts_) {
    const fe::Iterate it = sim.converged_iterate(*c.contribution);
    const auto* obstacle = dynamic_cast<const fe::ObstacleContact*>(c.contribution);
    out.push_back(obstacle ? obstacle->totals(mesh, it).normal_force
                           : static_cast<const fe::SurfaceContact*>(c.contribution)->totals(mesh, it).normal_force);
    if (c.between_fingers) between += out.back(), ++planes;
    else sample += out.back();
  }
  for (const Finger& f : fingers_) fingers += f.share;
  if (planes > 0) out.push_back(between / planes);
  if (planes < int(contacts_.size())) out.push_back(fingers > 0.0 ? sample / fingers : 0.0);
  return out;
}

std::string DeviceProbe::stop_reason(const std::vector<double>& row, const std::vector<double>* previous,
                                     double next_time) const {
  if (spec_.kind != DeviceKind::gripper || !(spec_.stop_distance > 0.0)) return "";
  const std::string why = " (device.stop_distance = " + format_number(spec_.stop_distance) +
                          " mm; contact between the fingers is not modelled)";
  const double distance = row[distance_column()], t = row.front();
  if (distance < spec_.stop_distance)
    return "stopped before the fingers touch: a fingertip node is " + format_number(distance) + " mm from the axis" + why;
  // Extrapolated in the controlled load value (pressure or volume ratio), not in time: a hold after a
  // ramp closes the gap only by creep, which the test on the reached distance catches.
  const PiecewiseLinear& load = structure_->spec.load;
  const double c_prev = previous ? load(previous->front()) : 0.0, c = load(t), c_next = load(next_time);
  if (previous && next_time > t && std::abs(c - c_prev) > 0.0) {
    const double rate = (distance - (*previous)[distance_column()]) / (c - c_prev);
    const double predicted = distance + rate * (c_next - c);
    if (predicted < spec_.stop_distance)
      return "stopped before the fingers touch: a fingertip node is " + format_number(distance) +
             " mm from the axis and the next step would bring it to about " + format_number(predicted) + " mm" + why;
  }
  return "";
}

}  // namespace softhom::macro
