// The gap of a deformable surface contact across the common edge of two master faces at an angle
// (fe/surface_contact.hpp): a slave point moved over a convex and a concave edge, beside it and through
// the face's plane, must see the signed distance to the two-face surface, continuous (a distance is
// 1-Lipschitz), whichever face the step paired it with; and the tangent near the edge is exact.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "surface_contact_tangent.hpp"
#include "softhom/fe/surface_contact.hpp"

using namespace softhom;
using namespace softhom::fe;

namespace {

/// Two unit master quads sharing the edge x = 0 (along y): face A flat (z = 0, x ∈ [−1, 0]), face B
/// turned by `angle` about the edge (downwards: a convex edge; upwards, negative angle: a concave one),
/// both facing +z; and a slave quad of half-width `half`, facing −z, centred at `centre`.
struct Hinge {
  Mesh mesh;
  double angle = 0.0;
  Vec3 centre = Vec3::Zero();
};

Hinge hinge(double angle, double half, const Vec3& centre) {
  Hinge h;
  h.angle = angle;
  h.centre = centre;
  const double c = std::cos(angle), s = std::sin(angle);
  h.mesh.nodes = {{-1, -0.5, 0}, {0, -0.5, 0}, {0, 0.5, 0}, {-1, 0.5, 0}, {c, -0.5, -s}, {c, 0.5, -s}};
  for (const auto& [dx, dy] : {std::pair{-1, -1}, {-1, 1}, {1, 1}, {1, -1}})
    h.mesh.nodes.push_back(centre + Vec3(dx * half, dy * half, 0.0));
  return h;
}

ContactSurface master_faces() { return {{{0, 1, 2, 3}, {1, 4, 5, 2}}, {}, "hinge"}; }
ContactSurface slave_face() { return {{{6, 7, 8, 9}}, {}, "slider"}; }

/// The slave face moved by `to` − its centre.
std::vector<double> displaced_to(const Hinge& h, const Vec3& to) {
  std::vector<double> u(h.mesh.num_dofs(), 0.0);
  for (int n = 6; n < 10; ++n)
    for (int i = 0; i < 3; ++i) u[3 * n + i] = (to - h.centre)[i];
  return u;
}

/// Signed distance of (x, z) to the hinge's profile (it does not vary along y): negative below it.
double reference_gap(double angle, double x, double z) {
  const Eigen::Vector2d p(x, z), a(-1, 0), o(0, 0), b(std::cos(angle), -std::sin(angle));
  auto to_segment = [&](const Eigen::Vector2d& u, const Eigen::Vector2d& v) {
    const double t = std::clamp((p - u).dot(v - u) / (v - u).squaredNorm(), 0.0, 1.0);
    return (p - (u + t * (v - u))).norm();
  };
  const double profile = x <= 0.0 ? 0.0 : -x * std::tan(angle);
  const double d = std::min(to_segment(a, o), to_segment(o, b));
  return z < profile ? -d : d;
}

/// The least gap of the slave face's points at u (the pairing of `state`).
double face_gap(const SurfaceContact& c, const Hinge& h, const std::vector<double>& u, const std::vector<double>& state) {
  Iterate it;
  it.u = &u;
  it.state_old = state.data();
  return c.face_values(h.mesh, it).gap[0];
}

/// Moves a tiny slave face (its points within 1e-7 of its centre) along a line from `from` to `to` with
/// the pairing of the start (as within one step; on face A, `on_a`, as a point the step paired with A
/// before it slid off), and returns the largest deviation of its gap from the
/// signed distance and the largest jump of the gap beyond the move's length (a distance's bound).
struct Sweep {
  double deviation = 0.0, excess_jump = 0.0;
};
Sweep sweep(double angle, const Vec3& from, const Vec3& to, bool on_a) {
  const Hinge h = hinge(angle, 1e-7, from);
  const SurfaceContact c(h.mesh, slave_face(), master_faces(), test::contact_options(1.0));
  std::vector<double> state = test::paired_state(c, h.mesh, displaced_to(h, from), 0.0);
  for (int k = 0; on_a && k < c.num_points(); ++k) {  // faces(): the slave, then A, then B
    double* s = state.data() + SurfaceContact::kStateSize * k;
    s[2] = 1.0;
    s[3] = s[4] = 0.0;
  }
  Sweep out;
  const int n = 200;
  double last = 0.0;
  for (int i = 0; i <= n; ++i) {
    const Vec3 at = from + (to - from) * (double(i) / n);
    const double g = face_gap(c, h, displaced_to(h, at), state);
    out.deviation = std::max(out.deviation, std::abs(g - reference_gap(angle, at[0], at[2])));
    if (i > 0) out.excess_jump = std::max(out.excess_jump, std::abs(g - last) - (to - from).norm() / n);
    last = g;
  }
  return out;
}

}  // namespace

// Over a convex edge (B turned down by 30°) and a concave one (up by 30°): a slave point slightly
// inside A slides across the edge (pairing with A at the start), and a point beside the edge crosses
// A's plane, paired at the start with the nearest face or with A. The reference is the distance to the two segments of the profile, signed by its side;
// the projection is Newton's to round-off and the slave face's points lie within 1e-7 of its centre,
// so 1e-6 bounds the deviation; a jump of the gap beyond the move itself (1-Lipschitz) is a
// discontinuity (a sign flip or a switch between faces: of the order of the distance, 1e-2 here).
TEST(SurfaceContactEdges, GapIsTheSignedDistanceAcrossConvexAndConcaveEdges) {
  for (double angle : {0.5236, -0.5236}) {
    const char* kind = angle > 0 ? "convex" : "concave";
    for (bool on_a : {false, true}) {
      const Sweep across = sweep(angle, Vec3(-0.1, 0.05, -0.01), Vec3(0.1, 0.05, -0.01), on_a);
      EXPECT_LT(across.deviation, 1e-6) << kind << ": sliding across the edge, on A " << on_a;
      EXPECT_LT(across.excess_jump, 1e-6) << kind << ": sliding across the edge, on A " << on_a;
      const Sweep beside = sweep(angle, Vec3(0.05, -0.05, 0.06), Vec3(0.05, -0.05, -0.06), on_a);
      EXPECT_LT(beside.deviation, 1e-6) << kind << ": through A's plane beside the edge, on A " << on_a;
      EXPECT_LT(beside.excess_jump, 1e-6) << kind << ": through A's plane beside the edge, on A " << on_a;
    }
  }
}

// The tangent where the slave face straddles the edge (some of its points held by it, or closest to
// the other face than the one they were paired with) against central differences, with multipliers
// λ0 = 1 so every point presses: the tolerance of the pair's own tangent test (test_surface_contact.cpp).
// With friction (μ = 0.3, the stick anchors moved by 0.02 in ξ on the paired face: some points stick,
// some slip); and with every point paired with A and anchored on it near the edge, so that the anchor
// stays on the paired face while the closest point lies on its neighbour (the anchor's face's dofs).
TEST(SurfaceContactEdges, TangentAtAnEdgeMatchesCentralDifferences) {
  for (double mu : {0.0, 0.3})
    for (double angle : {0.5236, -0.5236}) {
      const Vec3 centre(0.01, 0.03, angle > 0 ? -0.004 : 0.002);
      const Hinge h = hinge(angle, 0.05, centre);
      SurfaceContact::Options o = test::contact_options(20.0);
      o.friction = mu;
      const SurfaceContact c(h.mesh, slave_face(), master_faces(), o);
      std::vector<double> u(h.mesh.num_dofs(), 0.0);
      u[3 * 1 + 2] = 0.003;  // the edge's nodes moved: A and B warped
      u[3 * 5 + 0] = -0.004;
      std::vector<double> state = test::paired_state(c, h.mesh, u, 1.0, 0.02);
      EXPECT_LT(test::contact_tangent_error(c, h.mesh, u, state), 1e-6) << (angle > 0 ? "convex" : "concave") << ", mu " << mu;
      for (int k = 0; k < c.num_points(); ++k) {  // all paired with A, anchored on it near the edge
        double* s = state.data() + SurfaceContact::kStateSize * k;
        s[2] = 1.0;
        s[3] = s[4] = 0.0;
        s[SurfaceContact::kAnchor] = s[SurfaceContact::kNextAnchor] = 0.95;
        s[SurfaceContact::kAnchor + 1] = s[SurfaceContact::kNextAnchor + 1] = 0.1;
      }
      EXPECT_LT(test::contact_tangent_error(c, h.mesh, u, state), 1e-6) << (angle > 0 ? "convex" : "concave") << " on A, mu " << mu;
    }
}

// Past a free edge of the master surface (A's edge x = −1, no face beyond it: the cut of a body by its
// mirror plane) the face continues by its extension, so a point sliding off it at a constant depth
// keeps the gap of A's plane: −0.01 from x = −0.9 to −1.1 (within half a face of the edge, where it
// stays engaged), exactly (a plane's extension; Newton's projection to round-off, the slave face's
// points within 1e-7 of its centre: 1e-6 bounds it). The distance to the edge would reach 0.1 there.
TEST(SurfaceContactEdges, GapPastAFreeEdgeIsTheFacePlanes) {
  const Vec3 from(-0.9, 0.05, -0.01), to(-1.1, 0.05, -0.01);
  const Hinge h = hinge(0.5236, 1e-7, from);
  const SurfaceContact c(h.mesh, slave_face(), master_faces(), test::contact_options(1.0));
  const std::vector<double> state = test::paired_state(c, h.mesh, displaced_to(h, from), 0.0);
  double worst = 0.0;
  for (int i = 0; i <= 100; ++i) {
    const Vec3 at = from + (to - from) * (i / 100.0);
    worst = std::max(worst, std::abs(face_gap(c, h, displaced_to(h, at), state) + 0.01));
  }
  EXPECT_LT(worst, 1e-6);
}

// The tangent where the slave face straddles A's free edge (its points on both sides, those past it
// on A's extension, warped by the moved edge nodes) against central differences, every point
// pressing (λ0 = 1), without and with friction. Measured 2.2e-11 and 2.3e-11 of the largest entry;
// central differences of step 1e-6 leave round-off of 1e-16/1e-6 = 1e-10 relative: 1e-9 asserted.
TEST(SurfaceContactEdges, TangentPastAFreeEdgeMatchesCentralDifferences) {
  for (double mu : {0.0, 0.3}) {
    const Hinge h = hinge(0.5236, 0.05, Vec3(-1.01, 0.03, -0.004));
    SurfaceContact::Options o = test::contact_options(20.0);
    o.friction = mu;
    const SurfaceContact c(h.mesh, slave_face(), master_faces(), o);
    std::vector<double> u(h.mesh.num_dofs(), 0.0);
    u[3 * 0 + 2] = 0.003;  // the free edge's nodes moved: A warped
    u[3 * 3 + 0] = -0.004;
    const std::vector<double> state = test::paired_state(c, h.mesh, u, 1.0, 0.02);
    int active = 0;
    const double error = test::contact_tangent_error(c, h.mesh, u, state, &active);
    std::printf("past a free edge, mu = %g: tangent error %.2g of the largest entry\n", mu, error);
    EXPECT_LT(error, 1e-9) << "mu " << mu;
    EXPECT_GT(active, 0);
  }
}
