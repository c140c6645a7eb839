// The exact gradient of the enclosed-volume flux Φ = ∫ (c ⊙ x)·n da of a face (cavity-volume control):
// central differences on distorted quads and 6-node triangles, with full and in-plane masks.
#include <gtest/gtest.h>

#include "softhom/fe/hex8.hpp"
#include "softhom/fe/tet10_element.hpp"

using namespace softhom;
using namespace softhom::fe;

namespace {

template <class X, class V, class F>
void check_gradient(X x, const Vec3& mask, F face) {
  V a, g;
  double flux = 0.0;
  face(x, mask, a, flux, &g);
  double scale = 0.0;
  for (int k = 0; k < g.size(); ++k) scale = std::max(scale, std::abs(g[k]));
  const double h = 1e-6;
  for (int r = 0; r < x.rows(); ++r)
    for (int i = 0; i < 3; ++i) {
      X xp = x, xm = x;
      xp(r, i) += h;
      xm(r, i) -= h;
      double fp = 0.0, fm = 0.0;
      face(xp, mask, a, fp, nullptr);
      face(xm, mask, a, fm, nullptr);
      // Φ is a polynomial of degree 3 in the coordinates: the central difference is exact up to
      // h² (third derivatives O(1)) and round-off 1e-16/h: 1e-8 relative to the largest entry.
      EXPECT_NEAR(g[3 * r + i], (fp - fm) / (2 * h), 1e-8 * scale) << "node " << r << " component " << i;
    }
}

}  // namespace

TEST(VolumeGradient, QuadAndTri6FluxGradientsMatchFiniteDifferences) {
  Mat43 q;
  q << 0.1, -0.2, 1.0, 1.3, 0.1, 1.2, 1.1, 0.9, 0.8, -0.1, 1.2, 1.1;
  Mat63 t;
  t << 0, 0, 1, 1, 0.1, 1.2, 0.1, 1, 0.9, 0.55, 0.02, 1.15, 0.6, 0.6, 1.0, 0.03, 0.5, 0.93;
  for (const Vec3& mask : {Vec3(1, 1, 1), Vec3(1, 1, 0)}) {
    check_gradient<Mat43, Vec12>(q, mask, [](const Mat43& x, const Vec3& m, Vec12& a, double& f, Vec12* g) {
      quad4_pressure(x, m, a, nullptr, f, g);
    });
    check_gradient<Mat63, Vec18>(t, mask, [](const Mat63& x, const Vec3& m, Vec18& a, double& f, Vec18* g) {
      tri6_pressure(x, m, a, nullptr, f, g);
    });
  }
}
