// The layered Kirchhoff–Love section (through-thickness integration of plane_stress) and the fiber
// directions of a layer.
#include <cmath>
#include <numbers>
#include <string>

#include "softhom/core/input_error.hpp"
#include "softhom/materials/shell_section.hpp"

namespace softhom {
namespace {

struct Rule1D {
  std::vector<double> x, w;  // nodes on [−1, 1], ascending, and weights
};

/// Gauss–Lobatto (n = 2..5) and Gauss–Legendre (n = 1..5) rules on [−1, 1]; empty when n is outside.
Rule1D thickness_rule(ThicknessRule rule, int n) {
  if (rule == ThicknessRule::lobatto) {
    switch (n) {
      case 2: return {{-1.0, 1.0}, {1.0, 1.0}};
      case 3: return {{-1.0, 0.0, 1.0}, {1.0 / 3.0, 4.0 / 3.0, 1.0 / 3.0}};
      case 4: {
        const double a = std::sqrt(0.2);
        return {{-1.0, -a, a, 1.0}, {1.0 / 6.0, 5.0 / 6.0, 5.0 / 6.0, 1.0 / 6.0}};
      }
      case 5: {
        const double a = std::sqrt(3.0 / 7.0);
        return {{-1.0, -a, 0.0, a, 1.0}, {0.1, 49.0 / 90.0, 32.0 / 45.0, 49.0 / 90.0, 0.1}};
      }
      default: return {};
    }
  }
  switch (n) {
    case 1: return {{0.0}, {2.0}};
    case 2: {
      const double a = 1.0 / std::sqrt(3.0);
      return {{-a, a}, {1.0, 1.0}};
    }
    case 3: {
      const double a = std::sqrt(0.6);
      return {{-a, 0.0, a}, {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0}};
    }
    case 4: {
      const double a = 0.3399810435848563, b = 0.8611363115940526;
      const double wa = 0.6521451548625461, wb = 0.3478548451374538;
      return {{-b, -a, a, b}, {wb, wa, wa, wb}};
    }
    case 5: {
      const double a = 0.5384693101056831, b = 0.9061798459386640;
      const double wa = 0.4786286704993665, wb = 0.2369268850561891;
      return {{-b, -a, 0.0, a, b}, {wb, wa, 128.0 / 225.0, wa, wb}};
    }
    default: return {};
  }
}

std::string number(double v) { return format_number(v); }

}  // namespace

ShellSection::ShellSection(std::vector<ShellLayer> layers, PlaneStressMode mode, ThicknessRule rule,
                           const std::string& field)
    : layers_(std::move(layers)), mode_(mode) {
  if (layers_.empty()) throw InputError(field, "[]", "a shell section needs at least one layer");
  for (std::size_t i = 0; i < layers_.size(); ++i) {
    const ShellLayer& L = layers_[i];
    const std::string at = field + "[" + std::to_string(i) + "]";
    if (!L.law) throw InputError(at + ".material", "", "missing material");
    if (!(L.thickness > 0.0) || !std::isfinite(L.thickness))
      throw InputError(at + ".thickness", number(L.thickness), "must be a finite thickness > 0");
    if (thickness_rule(rule, L.points).x.empty())
      throw InputError(at + ".points", std::to_string(L.points),
                       rule == ThicknessRule::lobatto ? "Gauss-Lobatto points through a layer: 2 to 5"
                                                      : "Gauss points through a layer: 1 to 5");
    thickness_ += L.thickness;
  }
  double bottom = -0.5 * thickness_;
  for (std::size_t i = 0; i < layers_.size(); ++i) {
    const ShellLayer& L = layers_[i];
    const Rule1D r = thickness_rule(rule, L.points);
    const double half = 0.5 * L.thickness, mid = bottom + half;
    for (std::size_t q = 0; q < r.x.size(); ++q) {
      z_.push_back(mid + half * r.x[q]);
      w_.push_back(half * r.w[q]);
      layer_.push_back(int(i));
      state_offset_.push_back(state_size_);
      state_size_ += L.law->state_size();
    }
    bottom += L.thickness;
  }
}

void ShellSection::init_state(double* state) const {
  for (int p = 0; p < num_points(); ++p) {
    const Material& law = *layers_[layer_[p]].law;
    if (law.state_size() > 0) law.init_state(state + state_offset_[p]);
  }
}

MaterialStatus ShellSection::evaluate(const Vec3v& eps, const Vec3v& kappa, const double* state_old,
                                      double* state_new, double dt, bool want_tangent,
                                      SectionResponse& out) const {
  const int n = num_points();
  const bool warm = int(out.points.size()) == n;
  if (!warm) out.points.assign(n, SectionPoint{});
  out.N.setZero();
  out.M.setZero();
  out.tangent.setZero();
  out.failed_point = -1;
  double stretch = 0.0;
  PlaneStressPoint pt;
  for (int p = 0; p < n; ++p) {
    const Material& law = *layers_[layer_[p]].law;
    const bool history = law.state_size() > 0;
    const double z = z_[p], w = w_[p];
    pt.lambda3 = 0.0;
    pt.J = warm ? out.points[p].J : 0.0;
    const MaterialStatus st =
        plane_stress(law, eps + z * kappa, history ? state_old + state_offset_[p] : nullptr,
                     history ? state_new + state_offset_[p] : nullptr, dt, mode_, pt);
    if (st != MaterialStatus::ok) {
      out.N.setZero();
      out.M.setZero();
      out.tangent.setZero();
      out.failed_point = p;
      return st;
    }
    out.points[p] = SectionPoint{layer_[p], z, pt.S, pt.lambda3, pt.J};
    out.N += w * pt.S;
    out.M += (w * z) * pt.S;
    stretch += w * pt.lambda3;
    if (want_tangent) {
      out.tangent.topLeftCorner<3, 3>() += w * pt.D;
      out.tangent.topRightCorner<3, 3>() += (w * z) * pt.D;
      out.tangent.bottomRightCorner<3, 3>() += (w * z * z) * pt.D;
    }
  }
  if (want_tangent) out.tangent.bottomLeftCorner<3, 3>() = out.tangent.topRightCorner<3, 3>();
  out.thickness_stretch = stretch / thickness_;
  return MaterialStatus::ok;
}

Vec3 in_plane_direction(double angle_deg) {
  const double a = angle_deg * std::numbers::pi / 180.0;
  return {std::cos(a), std::sin(a), 0.0};
}

Mat3 rotation_about_normal(double angle_deg) {
  const double a = angle_deg * std::numbers::pi / 180.0, c = std::cos(a), s = std::sin(a);
  Mat3 Q;
  Q << c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0;
  return Q;
}

MaterialPtr rotated_about_normal(const MaterialPtr& law, double angle_deg) {
  return MaterialPtr(law->rotated(rotation_about_normal(angle_deg)));
}

MaterialPtr layer_material(MaterialSpec spec, std::span<const double> angles_deg) {
  const std::string field = spec.field_prefix + ".fibers";
  if (!angles_deg.empty()) {
    if (!has_fiber_families(spec.law))
      throw InputError(field, "", "fiber angles need a law with fiber families (Gent-HGO, fiber-composite)");
    auto& fibers = spec.gent.fibers;
    if (fibers.empty()) throw InputError(field, "[]", "fiber angles given but no fiber family (k1, k2) to place");
    if (fibers.size() != 1 && fibers.size() != angles_deg.size())
      throw InputError(field, std::to_string(fibers.size()) + " families",
                       "one family for every angle, or as many families as angles (" +
                           std::to_string(angles_deg.size()) + ")");
    std::vector<FiberFamily> placed;
    for (std::size_t i = 0; i < angles_deg.size(); ++i) {
      if (!std::isfinite(angles_deg[i]))
        throw InputError(spec.field_prefix + ".fiber_angles", number(angles_deg[i]), "not a finite angle");
      FiberFamily f = fibers.size() == 1 ? fibers[0] : fibers[i];
      f.direction = in_plane_direction(angles_deg[i]);
      placed.push_back(f);
    }
    fibers = std::move(placed);
  }
  return build_material(spec);
}

}  // namespace softhom
