// Periodic fiber cells (square, hexagonal, random) and their sub-pixel-exact voxel images.
//
// Every pixel gets its true fiber area fraction: circles by exact piecewise integration of the
// circle–rectangle intersection, rectangles by Sutherland–Hodgman clipping of the pixel square in the
// rectangle's own frame (exact polygon area). Only pixels crossed by a fiber boundary do that work, so
// the cost is O(pixels in the fiber bounding boxes) + O(boundary pixels).
#include "softhom/rve/geometry.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <numeric>
#include <random>
#include <sstream>
#include <stdexcept>
#include <Eigen/Eigenvalues>

#include "softhom/materials/errors.hpp"
#include "memory_budget.hpp"

namespace softhom::rve {
namespace {

using Vec2 = Eigen::Vector2d;
constexpr double kPiGeometry = 3.14159265358979323846;
constexpr double kSquareCircleLimit = kPiGeometry / 4.0;                // square array of circles
constexpr double kHexCircleLimit = kPiGeometry / (2.0 * 1.7320508075688772);  // hexagonal array of circles
const double kSqrt3 = std::sqrt(3.0);

std::string num(double v) {
  std::ostringstream os;
  os << std::setprecision(6) << v;
  return os.str();
}

// ---------------------------------------------------------------------------------------------------
// Single-fiber primitives.

double fiber_area(const FiberSection& f) {
  return f.shape == SectionShape::circle ? kPiGeometry * f.radius * f.radius : f.width * f.height;
}

/// Radius of the circle around the centre that contains the whole fiber (cheap broad phase).
double bounding_radius(const FiberSection& f) {
  return f.shape == SectionShape::circle ? f.radius : 0.5 * std::hypot(f.width, f.height);
}

/// A rectangle as centre + unit axes + half side lengths.
struct OrientedRect {
  Vec2 c, u, v;
  double a = 0.0, b = 0.0;  // half width along u, half height along v
  std::array<Vec2, 4> corners() const {
    return {c - a * u - b * v, c + a * u - b * v, c + a * u + b * v, c - a * u + b * v};
  }
};

OrientedRect make_rect(const FiberSection& f, const Vec2& shift = Vec2::Zero()) {
  const double t = f.rotation_deg * kPiGeometry / 180.0;
  OrientedRect r;
  r.c = f.center + shift;
  r.u = Vec2(std::cos(t), std::sin(t));
  r.v = Vec2(-std::sin(t), std::cos(t));
  r.a = 0.5 * f.width;
  r.b = 0.5 * f.height;
  return r;
}

/// Signed distance from point p to a rectangle (negative inside).
double point_rect_signed_distance(const OrientedRect& r, const Vec2& p) {
  const Vec2 q = p - r.c;
  const double du = std::abs(q.dot(r.u)) - r.a, dv = std::abs(q.dot(r.v)) - r.b;
  if (du > 0.0 || dv > 0.0) return std::hypot(std::max(du, 0.0), std::max(dv, 0.0));
  return std::max(du, dv);
}

double point_segment_distance(const Vec2& p, const Vec2& s0, const Vec2& s1) {
  const Vec2 d = s1 - s0;
  const double len2 = d.squaredNorm();
  double t = len2 > 0.0 ? (p - s0).dot(d) / len2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  return (p - (s0 + t * d)).norm();
}

/// Surface distance between two rectangles: exact when disjoint (min vertex–edge distance), and the
/// negated smallest penetration along the separating-axis candidates when they overlap (≤ 0).
double rect_rect_distance(const OrientedRect& P, const OrientedRect& Q) {
  const Vec2 axes[4] = {P.u, P.v, Q.u, Q.v};
  double best_gap = -std::numeric_limits<double>::infinity();
  for (const Vec2& n : axes) {
    const double rp = P.a * std::abs(P.u.dot(n)) + P.b * std::abs(P.v.dot(n));
    const double rq = Q.a * std::abs(Q.u.dot(n)) + Q.b * std::abs(Q.v.dot(n));
    const double gap = std::abs((Q.c - P.c).dot(n)) - rp - rq;
    best_gap = std::max(best_gap, gap);
  }
  if (best_gap <= 0.0) return best_gap;  // no separating axis: the rectangles overlap (or touch)
  const auto pc = P.corners(), qc = Q.corners();
  double d = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      d = std::min(d, point_segment_distance(pc[i], qc[j], qc[(j + 1) % 4]));
      d = std::min(d, point_segment_distance(qc[i], pc[j], pc[(j + 1) % 4]));
    }
  return d;
}

/// Surface-to-surface distance between fiber a and fiber b shifted by `shift` (≤ 0: overlap/touch).
double surface_distance(const FiberSection& a, const FiberSection& b, const Vec2& shift) {
  const bool ca = a.shape == SectionShape::circle, cb = b.shape == SectionShape::circle;
  if (ca && cb) return (b.center + shift - a.center).norm() - a.radius - b.radius;
  if (ca) return point_rect_signed_distance(make_rect(b, shift), a.center) - a.radius;
  if (cb) return point_rect_signed_distance(make_rect(a), b.center + shift) - b.radius;
  return rect_rect_distance(make_rect(a), make_rect(b, shift));
}

/// True if fiber b (or, when `same`, a's own periodic images) comes closer to a than `gap` in the
/// periodic cell L1 × L2. With gap == 0, touching counts as a conflict (a zero-width matrix ligament
/// would connect the fiber phase).
bool periodic_conflict(const FiberSection& a, const FiberSection& b, bool same, double L1, double L2,
                       double gap) {
  Vec2 d = b.center - a.center;
  d.x() -= L1 * std::round(d.x() / L1);
  d.y() -= L2 * std::round(d.y() / L2);
  const double cutoff = bounding_radius(a) + bounding_radius(b) + gap;
  // After the minimum-image wrap |d_i| <= L_i / 2, so image k is at least (|k| - 1/2) L_i away.
  const int K1 = int(std::ceil(cutoff / L1 + 0.5)), K2 = int(std::ceil(cutoff / L2 + 0.5));
  const double tol = 1e-12 * cutoff;  // relative roundoff of the distance evaluation
  for (int k1 = -K1; k1 <= K1; ++k1)
    for (int k2 = -K2; k2 <= K2; ++k2) {
      const Vec2 off = d + Vec2(k1 * L1, k2 * L2);
      if (same && k1 == 0 && k2 == 0) continue;
      if (off.norm() >= cutoff) continue;  // bounding circles already `gap` apart
      const double dist = surface_distance(a, b, off - (b.center - a.center));
      if (gap > 0.0 ? dist < gap : dist <= tol) return true;
    }
  return false;
}

bool section_conflicts(const Section& s, double gap) {
  for (std::size_t i = 0; i < s.fibers.size(); ++i)
    for (std::size_t j = i; j < s.fibers.size(); ++j)
      if (periodic_conflict(s.fibers[i], s.fibers[j], i == j, s.L1, s.L2, gap)) return true;
  return false;
}

double section_fraction(const Section& s) {
  double area = 0.0;
  for (const auto& f : s.fibers) area += fiber_area(f);
  return area / (s.L1 * s.L2);
}

// ---------------------------------------------------------------------------------------------------
// Generation.

FiberSection prototype(const FiberCellSpec& spec, double radius, double width, double height) {
  FiberSection f;
  f.shape = spec.shape;
  f.radius = spec.shape == SectionShape::circle ? radius : 0.0;
  f.width = spec.shape == SectionShape::rectangle ? width : 0.0;
  f.height = spec.shape == SectionShape::rectangle ? height : 0.0;
  f.rotation_deg = spec.shape == SectionShape::rectangle ? spec.section_rotation_deg : 0.0;
  return f;
}

/// Square (one fiber at the centre) or hexagonal (centre + corner of an L1 × √3 L1 cell) lattice.
Section lattice_section(const FiberSection& proto, Arrangement arr, double L1) {
  Section s;
  s.L1 = L1;
  s.L2 = arr == Arrangement::hexagonal ? kSqrt3 * L1 : L1;
  FiberSection f = proto;
  f.center = Vec2(0.5 * s.L1, 0.5 * s.L2);
  s.fibers.push_back(f);
  if (arr == Arrangement::hexagonal) {
    f.center = Vec2(0.0, 0.0);
    s.fibers.push_back(f);
  }
  s.volume_fraction = section_fraction(s);
  return s;
}

/// Largest volume fraction of a lattice of `proto` fibers without overlap. Overlap of a lattice is
/// monotone in the scale (K ∩ (K + L z) ≠ ∅ ⇔ L z ∈ 2K for a centrally symmetric convex K), so
/// bisection on L1 is exact to roundoff.
double lattice_packing_limit(const FiberSection& proto, Arrangement arr, double L1_conflicting) {
  double lo = L1_conflicting, hi = 2.0 * L1_conflicting;
  while (section_conflicts(lattice_section(proto, arr, hi), 0.0)) hi *= 2.0;
  for (int it = 0; it < 200 && hi - lo > 1e-15 * hi; ++it) {
    const double mid = 0.5 * (lo + hi);
    (section_conflicts(lattice_section(proto, arr, mid), 0.0) ? lo : hi) = mid;
  }
  return lattice_section(proto, arr, hi).volume_fraction;
}

std::string shape_text(const FiberCellSpec& spec, const FiberSection& f) {
  if (spec.shape == SectionShape::circle) return "circles";
  return num(f.width) + " x " + num(f.height) + " rectangles rotated " + num(spec.section_rotation_deg) +
         " deg";
}

/// Uniform double in [0, 1) from the raw 64-bit stream: identical on every standard library
/// (std::uniform_real_distribution is implementation-defined).
double unit_uniform(std::mt19937_64& rng) { return double(rng() >> 11) * 0x1.0p-53; }

/// The checks of a cell description that need no geometry (InputError naming the key).
void check_cell_spec(const FiberCellSpec& spec, const std::string& p) {
  const bool circle = spec.shape == SectionShape::circle;
  const double vf = spec.volume_fraction;
  if (!std::isfinite(vf) || vf <= 0.0 || vf >= 1.0)
    throw InputError(p + "volume_fraction", num(vf), "must be in (0, 1)");
  if (!std::isfinite(spec.section_rotation_deg))
    throw InputError(p + "section_rotation_deg", num(spec.section_rotation_deg), "must be finite");
  if (spec.arrangement == Arrangement::random) {
    if (spec.fiber_count < 1)
      throw InputError(p + "fiber_count", std::to_string(spec.fiber_count), "must be at least 1");
    if (!std::isfinite(spec.min_gap) || spec.min_gap < 0.0)
      throw InputError(p + "min_gap", num(spec.min_gap), "must be a finite value >= 0");
  }

  // Exactly one of fiber size and cell size.
  const bool size_given = circle ? spec.radius != 0.0 : (spec.width != 0.0 || spec.height != 0.0);
  if (spec.cell_size) {
    const double L = *spec.cell_size;
    if (size_given)
      throw InputError(p + "cell_size", num(L),
                       std::string("both ") + (circle ? p + "radius" : p + "width/height") +
                           " and cell_size were given; give one and the volume fraction derives the "
                           "other");
    if (!std::isfinite(L) || L <= 0.0) throw InputError(p + "cell_size", num(L), "must be positive");
  } else if (circle) {
    if (!std::isfinite(spec.radius) || spec.radius <= 0.0)
      throw InputError(p + "radius", num(spec.radius), "must be positive (or give cell_size instead)");
  } else {
    if (!std::isfinite(spec.width) || spec.width <= 0.0)
      throw InputError(p + "width", num(spec.width), "must be positive (or give cell_size instead)");
    if (!std::isfinite(spec.height) || spec.height <= 0.0)
      throw InputError(p + "height", num(spec.height), "must be positive (or give cell_size instead)");
  }
}

/// The fiber's size and the cell's L1, one given and the other from the volume fraction:
/// nf · A = vf · cell_shape · L1² (cell area per unit L1²: square, random 1; hexagonal √3).
struct CellSizes {
  double L1 = 0.0, radius = 0.0, width = 0.0, height = 0.0;
};
CellSizes cell_sizes(const FiberCellSpec& spec, int nf) {
  const bool circle = spec.shape == SectionShape::circle;
  const double vf = spec.volume_fraction;
  const double cell_shape = spec.arrangement == Arrangement::hexagonal ? kSqrt3 : 1.0;
  CellSizes c;
  if (spec.cell_size) {
    c.L1 = *spec.cell_size;
    const double A = vf * cell_shape * c.L1 * c.L1 / nf;
    if (circle) c.radius = std::sqrt(A / kPiGeometry);
    else c.width = c.height = std::sqrt(A);  // cell size given: square fibers (no aspect ratio to keep)
  } else {
    c.radius = spec.radius;
    c.width = spec.width;
    c.height = spec.height;
    const double A = circle ? kPiGeometry * c.radius * c.radius : c.width * c.height;
    c.L1 = std::sqrt(nf * A / (vf * cell_shape));
  }
  return c;
}

/// A square or hexagonal lattice cell, refused above its packing limit.
Section lattice_cell(const FiberCellSpec& spec, const FiberSection& proto, double L1, const std::string& p) {
  const double vf = spec.volume_fraction;
  const char* arr_name = spec.arrangement == Arrangement::square ? "square" : "hexagonal";
  if (spec.shape == SectionShape::circle) {
    const double limit = spec.arrangement == Arrangement::square ? kSquareCircleLimit : kHexCircleLimit;
    if (vf >= limit)
      throw InputError(p + "volume_fraction", num(vf),
                       "at or above the packing limit " + num(limit) + " of a " + arr_name + " array of circles");
    return lattice_section(proto, spec.arrangement, L1);
  }
  Section s = lattice_section(proto, spec.arrangement, L1);
  if (section_conflicts(s, 0.0)) {
    const double limit = lattice_packing_limit(proto, spec.arrangement, L1);
    throw InputError(p + "volume_fraction", num(vf),
                     "the fibers overlap their periodic images: above the packing limit " + num(limit) + " of a " +
                         arr_name + " array of " + shape_text(spec, proto) +
                         " (change section_rotation_deg or lower the volume fraction)");
  }
  return s;
}

/// Refuses a random cell of side L that no placement can achieve: a fiber that does not clear its own
/// images, or (circles) gap-inflated circles above the densest (hexagonal) packing.
void refuse_impossible_random_cell(const FiberCellSpec& spec, const FiberSection& proto, double L,
                                   const std::string& p) {
  const double vf = spec.volume_fraction, gap = spec.min_gap;
  if (spec.shape == SectionShape::circle) {
    const double radius = proto.radius;
    if (2.0 * radius + gap >= L)
      throw InputError(p + "volume_fraction", num(vf),
                       "a fiber of radius " + num(radius) + " with min_gap " + num(gap) +
                           " does not fit in the random cell of side " + num(L) +
                           " (increase fiber_count or lower the volume fraction or gap)");
    const double inflated = vf * std::pow(1.0 + 0.5 * gap / radius, 2);
    if (inflated >= kHexCircleLimit)
      throw InputError(p + "volume_fraction", num(vf),
                       "with min_gap " + num(gap) + " the gap-inflated fibers would fill " + num(inflated) +
                           ", above the densest packing " + num(kHexCircleLimit) + " of circles");
  } else {
    FiberSection f = proto;
    f.center = Vec2(0.5 * L, 0.5 * L);
    if (periodic_conflict(f, f, true, L, L, gap))
      throw InputError(p + "volume_fraction", num(vf),
                       "a " + shape_text(spec, proto) + " fiber with min_gap " + num(gap) +
                           " overlaps its own periodic images in the random cell of side " + num(L));
  }
}

/// Random sequential addition of nf fibers in a square L × L cell (restarted from scratch when a fiber
/// finds no place).
Section random_cell(const FiberCellSpec& spec, const FiberSection& proto, int nf, double L, const std::string& p) {
  const double gap = spec.min_gap;
  Section s;
  s.L1 = s.L2 = L;
  constexpr int kAttemptsPerFiber = 20000, kRestarts = 10;
  std::mt19937_64 rng(spec.seed);
  int worst_fiber = 0;
  for (int restart = 0; restart < kRestarts; ++restart) {
    s.fibers.clear();
    bool failed = false;
    for (int k = 0; k < nf && !failed; ++k) {
      FiberSection f = proto;
      bool placed = false;
      for (int attempt = 0; attempt < kAttemptsPerFiber && !placed; ++attempt) {
        f.center = Vec2(unit_uniform(rng) * L, unit_uniform(rng) * L);
        placed = std::none_of(s.fibers.begin(), s.fibers.end(), [&](const FiberSection& o) {
          return periodic_conflict(o, f, false, L, L, gap);
        });
      }
      if (placed) s.fibers.push_back(f);
      else {
        failed = true;
        worst_fiber = std::max(worst_fiber, k + 1);
      }
    }
    if (!failed) {
      s.volume_fraction = section_fraction(s);
      return s;
    }
  }
  throw InputError(p + "volume_fraction", num(spec.volume_fraction),
                   "random placement failed: could not place fiber " + std::to_string(worst_fiber) + " of " +
                       std::to_string(nf) + " with min_gap " + num(gap) + " after " +
                       std::to_string(kAttemptsPerFiber) + " attempts (" + std::to_string(kRestarts) +
                       " restarts); the volume fraction / gap is too high for random sequential addition "
                       "(equal circles jam near 0.547); lower volume_fraction or min_gap");
}

}  // namespace

Section generate_section(const FiberCellSpec& spec, const std::string& field_prefix) {
  const std::string p = field_prefix.empty() ? std::string() : field_prefix + ".";
  check_cell_spec(spec, p);
  const int nf = spec.arrangement == Arrangement::square      ? 1
                 : spec.arrangement == Arrangement::hexagonal ? 2
                                                              : spec.fiber_count;
  const CellSizes c = cell_sizes(spec, nf);
  const FiberSection proto = prototype(spec, c.radius, c.width, c.height);
  if (spec.arrangement != Arrangement::random) return lattice_cell(spec, proto, c.L1, p);
  refuse_impossible_random_cell(spec, proto, c.L1, p);
  return random_cell(spec, proto, nf, c.L1, p);
}

// ---------------------------------------------------------------------------------------------------
// Voxelisation.

namespace {

/// ∫ sqrt(r² − x²) dx.
double half_chord_primitive(double r, double x) {
  const double s = std::sqrt(std::max(r * r - x * x, 0.0));
  return 0.5 * (x * s + r * r * std::asin(std::clamp(x / r, -1.0, 1.0)));
}

/// Exact area of the disc |x| ≤ r (centre at the origin) ∩ [x0, x1] × [y0, y1]: integral over x of
/// min(y1, s(x)) − max(y0, −s(x)), split where s(x) = √(r² − x²) crosses |y0| or |y1|; on each piece
/// both bounds are a constant or ±s(x) and the integrand keeps its sign.
double disc_box_area(double r, double x0, double x1, double y0, double y1) {
  const double a = std::max(x0, -r), b = std::min(x1, r);
  if (a >= b || y0 >= y1) return 0.0;
  double bp[6];  // a, b and ±t for y0 and y1
  int n = 0;
  bp[n++] = a;
  bp[n++] = b;
  for (double y : {y0, y1})
    if (std::abs(y) < r) {
      const double t = std::sqrt(r * r - y * y);
      if (t > a && t < b) bp[n++] = t;
      if (-t > a && -t < b) bp[n++] = -t;
    }
  for (int i = 1; i < n; ++i)  // insertion sort of ≤ 6 breakpoints
    for (int j = i; j > 0 && bp[j - 1] > bp[j]; --j) std::swap(bp[j - 1], bp[j]);
  double area = 0.0;
  for (int i = 0; i + 1 < n; ++i) {
    const double lo = bp[i], hi = bp[i + 1];
    if (hi <= lo) continue;
    const double m = 0.5 * (lo + hi), sm = std::sqrt(std::max(r * r - m * m, 0.0));
    const bool upper_const = y1 < sm, lower_const = y0 > -sm;
    const double up = upper_const ? y1 : sm, low = lower_const ? y0 : -sm;
    if (up <= low) continue;
    const double S = half_chord_primitive(r, hi) - half_chord_primitive(r, lo);
    area += (upper_const ? y1 * (hi - lo) : S) - (lower_const ? y0 * (hi - lo) : -S);
  }
  return area;
}

/// Area of the polygon pts (any orientation) clipped to the box [-a, a] × [-b, b] (Sutherland–Hodgman).
double clipped_area(std::array<Vec2, 4> const& quad, double a, double b) {
  // A convex quadrilateral clipped by 4 half-planes has at most 8 vertices.
  Vec2 buf0[12], buf1[12];
  int n = 4;
  for (int i = 0; i < 4; ++i) buf0[i] = quad[i];
  Vec2* in = buf0;
  Vec2* out = buf1;
  for (int plane = 0; plane < 4 && n > 0; ++plane) {
    const int axis = plane / 2;
    const double sign = plane % 2 == 0 ? 1.0 : -1.0, lim = axis == 0 ? a : b;
    auto inside = [&](const Vec2& q) { return sign * q[axis] <= lim; };
    int m = 0;
    for (int i = 0; i < n; ++i) {
      const Vec2& P = in[i];
      const Vec2& Q = in[(i + 1) % n];
      const bool pin = inside(P), qin = inside(Q);
      if (pin) out[m++] = P;
      if (pin != qin) {
        const double t = (sign * lim - P[axis]) / (Q[axis] - P[axis]);
        Vec2 X = P + t * (Q - P);
        X[axis] = sign * lim;  // exactly on the clip line
        out[m++] = X;
      }
    }
    n = m;
    std::swap(in, out);
  }
  double twice = 0.0;
  for (int i = 0; i < n; ++i) {
    const Vec2& P = in[i];
    const Vec2& Q = in[(i + 1) % n];
    twice += P.x() * Q.y() - P.y() * Q.x();
  }
  return 0.5 * std::abs(twice);
}

struct Grid {
  int n1, n2;
  double dx, dy;
  std::vector<double>& frac;
  /// Candidate normal (x, y) of each pixel; z temporarily holds |distance| from the pixel centre to
  /// the boundary that proposed it (no extra per-pixel array: at 1024² first-touching memory is
  /// the dominant cost).
  std::vector<Eigen::Vector3d>& nrm;
  void offer_normal(std::size_t idx, double dist, const Vec2& n) {
    if (std::abs(dist) < nrm[idx].z()) nrm[idx] = Eigen::Vector3d(n.x(), n.y(), std::abs(dist));
  }
  /// Pixel index range [lo, hi] that the interval [xmin, xmax] touches along one axis, or lo > hi.
  static std::pair<int, int> range(double xmin, double xmax, double h, int n) {
    return {std::max(0, int(std::floor(xmin / h))), std::min(n - 1, int(std::floor(xmax / h)))};
  }
};

void paint_circle(Grid& g, const Vec2& c, double r) {
  const auto [i_lo, i_hi] = Grid::range(c.x() - r, c.x() + r, g.dx, g.n1);
  const auto [j_lo, j_hi] = Grid::range(c.y() - r, c.y() + r, g.dy, g.n2);
  const double r2 = r * r, pixel_area = g.dx * g.dy;
  for (int j = j_lo; j <= j_hi; ++j) {
    const double Y0 = j * g.dy - c.y(), Y1 = (j + 1) * g.dy - c.y();
    const double ny = std::clamp(0.0, Y0, Y1), fy = std::max(Y0 * Y0, Y1 * Y1);
    for (int i = i_lo; i <= i_hi; ++i) {
      const double X0 = i * g.dx - c.x(), X1 = (i + 1) * g.dx - c.x();
      const double nx = std::clamp(0.0, X0, X1);
      if (nx * nx + ny * ny >= r2) continue;  // pixel outside the disc
      const std::size_t idx = std::size_t(i) + std::size_t(g.n1) * j;
      if (std::max(X0 * X0, X1 * X1) + fy <= r2) {  // farthest corner inside: full pixel
        g.frac[idx] += 1.0;
        continue;
      }
      g.frac[idx] += disc_box_area(r, X0, X1, Y0, Y1) / pixel_area;
      const Vec2 pc(0.5 * (X0 + X1), 0.5 * (Y0 + Y1));
      const double rho = pc.norm();
      g.offer_normal(idx, rho - r, rho > 0.0 ? Vec2(pc / rho) : Vec2(1.0, 0.0));
    }
  }
}

/// Length of the segment p0 → p1 inside the box [−a, a] × [−b, b] (Liang–Barsky clipping).
double segment_length_in_box(const Vec2& p0, const Vec2& p1, double a, double b) {
  const Vec2 d = p1 - p0;
  double t0 = 0.0, t1 = 1.0;
  const double pk[4] = {-d.x(), d.x(), -d.y(), d.y()};
  const double qk[4] = {p0.x() + a, a - p0.x(), p0.y() + b, b - p0.y()};
  for (int k = 0; k < 4; ++k) {
    if (pk[k] == 0.0) {
      if (qk[k] < 0.0) return 0.0;  // parallel to this side and outside it
      continue;
    }
    const double t = qk[k] / pk[k];
    if (pk[k] < 0.0) t0 = std::max(t0, t);
    else t1 = std::min(t1, t);
  }
  return t1 > t0 ? (t1 - t0) * d.norm() : 0.0;
}

/// ∫ n ds over the part of the boundary of [−a, a] × [−b, b] inside the convex quad `q`
/// (counter-clockwise): −Σ_edges (length inside the box) · (outward edge normal).
Vec2 mean_boundary_normal(const std::array<Vec2, 4>& q, double a, double b) {
  Vec2 m = Vec2::Zero();
  for (int k = 0; k < 4; ++k) {
    const Vec2& p0 = q[k];
    const Vec2& p1 = q[(k + 1) % 4];
    const Vec2 d = p1 - p0;
    const double len = d.norm();
    if (!(len > 0.0)) continue;
    const Vec2 outward(d.y() / len, -d.x() / len);  // right of a counter-clockwise edge
    m -= segment_length_in_box(p0, p1, a, b) * outward;
  }
  return m;
}

void paint_rect(Grid& g, const OrientedRect& R) {
  const auto cs = R.corners();
  double xmin = cs[0].x(), xmax = xmin, ymin = cs[0].y(), ymax = ymin;
  for (const auto& q : cs) {
    xmin = std::min(xmin, q.x()), xmax = std::max(xmax, q.x());
    ymin = std::min(ymin, q.y()), ymax = std::max(ymax, q.y());
  }
  const auto [i_lo, i_hi] = Grid::range(xmin, xmax, g.dx, g.n1);
  const auto [j_lo, j_hi] = Grid::range(ymin, ymax, g.dy, g.n2);
  const double pixel_area = g.dx * g.dy;
  auto local = [&](double x, double y) {
    const Vec2 q(x - R.c.x(), y - R.c.y());
    return Vec2(q.dot(R.u), q.dot(R.v));
  };
  for (int j = j_lo; j <= j_hi; ++j)
    for (int i = i_lo; i <= i_hi; ++i) {
      const double x0 = i * g.dx, x1 = (i + 1) * g.dx, y0 = j * g.dy, y1 = (j + 1) * g.dy;
      // Pixel corners in the rectangle frame (counter-clockwise; rotation keeps areas).
      const std::array<Vec2, 4> q{local(x0, y0), local(x1, y0), local(x1, y1), local(x0, y1)};
      bool all_in = true;
      int out_mask = 0xF;  // bit k set while every corner is outside half-plane k
      for (const Vec2& z : q) {
        const bool o0 = z.x() > R.a, o1 = z.x() < -R.a, o2 = z.y() > R.b, o3 = z.y() < -R.b;
        all_in = all_in && !(o0 || o1 || o2 || o3);
        out_mask &= (o0 ? 1 : 0) | (o1 ? 2 : 0) | (o2 ? 4 : 0) | (o3 ? 8 : 0);
      }
      if (out_mask) continue;  // one rectangle side separates the pixel
      const std::size_t idx = std::size_t(i) + std::size_t(g.n1) * j;
      if (all_in) {
        g.frac[idx] += 1.0;
        continue;
      }
      const double area = clipped_area(q, R.a, R.b);
      if (area <= 0.0) continue;
      g.frac[idx] += area / pixel_area;
      // Outward normal at the boundary point closest to the pixel centre: the distance-field gradient
      // (face normal, or the corner-to-point direction in a corner's Voronoi region). `dist` ranks the
      // offers of several fibers; the direction is replaced below by the interface average.
      const Vec2 pc = local(0.5 * (x0 + x1), 0.5 * (y0 + y1));
      const double su = pc.x() >= 0.0 ? 1.0 : -1.0, sv = pc.y() >= 0.0 ? 1.0 : -1.0;
      const double du = std::abs(pc.x()) - R.a, dv = std::abs(pc.y()) - R.b;
      Vec2 nl;
      double dist;
      if (du > 0.0 || dv > 0.0) {
        nl = Vec2(su * std::max(du, 0.0), sv * std::max(dv, 0.0));
        dist = nl.norm();
        nl /= dist;
      } else if (du > dv) {
        nl = Vec2(su, 0.0), dist = du;
      } else {
        nl = Vec2(0.0, sv), dist = dv;
      }
      // Laminate normal: the mean outward normal of the fiber boundary inside the pixel,
      // ∫_{∂R ∩ pixel} n ds = −∫_{∂pixel ∩ R} n_pixel ds (divergence theorem on R ∩ pixel), i.e. minus
      // the pixel edges' lengths inside the rectangle times their outward normals. It equals the face
      // normal on a face pixel and is the length-weighted bisector of the two faces on a corner pixel.
      // The distance gradient alone is ambiguous on a corner pixel whose centre lies inside the fiber
      // on the corner's diagonal (equidistant faces): its tie was broken by round-off, differently at
      // different corners, which gave mirror-image corners different laminates, broke the mirror
      // symmetry of the cell and left a spurious soft mode (ecoflex square fibers, 32²).
      const Vec2 mean = mean_boundary_normal(q, R.a, R.b);
      if (mean.norm() > 1e-6 * (g.dx + g.dy)) nl = mean.normalized();
      g.offer_normal(idx, dist, nl.x() * R.u + nl.y() * R.v);
    }
}

/// Bytes of a phase image of `voxels` voxels (fraction and normal per voxel).
std::size_t image_bytes(std::size_t voxels) { return voxels * (sizeof(double) + sizeof(Eigen::Vector3d)); }

}  // namespace

PhaseImage voxelize_section(const Section& section, int n1, int n2) {
  const std::string grid_text = "[" + std::to_string(n1) + ", " + std::to_string(n2) + "]";
  if (n1 < 1 || n2 < 1) throw InputError("microstructure.grid", grid_text, "must have at least one pixel per direction");
  const double L1 = section.L1, L2 = section.L2;
  if (!(L1 > 0.0) || !(L2 > 0.0) || !std::isfinite(L1) || !std::isfinite(L2))
    throw InputError("microstructure.cell_size", num(L1) + " x " + num(L2), "the cell sides must be positive and finite");
  detail::refuse_if_too_big(image_bytes(std::size_t(n1) * std::size_t(n2)), "microstructure.grid", grid_text);

  PhaseImage img;
  img.n = {n1, n2, 1};
  img.size = {L1, L2, L1 / n1};
  const std::size_t N = std::size_t(n1) * n2;
  img.fiber_fraction.assign(N, 0.0);
  img.normal.assign(N, Eigen::Vector3d(0.0, 0.0, std::numeric_limits<double>::infinity()));
  Grid g{n1, n2, L1 / n1, L2 / n2, img.fiber_fraction, img.normal};

  for (const FiberSection& f : section.fibers) {
    const double R = bounding_radius(f);
    if (!(R > 0.0)) continue;
    // Every periodic image whose bounding box meets the cell (fibers crossing the boundary wrap).
    const int k1_lo = int(std::floor(-(f.center.x() + R) / L1)), k1_hi = int(std::ceil((L1 - f.center.x() + R) / L1));
    const int k2_lo = int(std::floor(-(f.center.y() + R) / L2)), k2_hi = int(std::ceil((L2 - f.center.y() + R) / L2));
    for (int k2 = k2_lo; k2 <= k2_hi; ++k2)
      for (int k1 = k1_lo; k1 <= k1_hi; ++k1) {
        const Vec2 shift(k1 * L1, k2 * L2), c = f.center + shift;
        if (c.x() + R <= 0.0 || c.x() - R >= L1 || c.y() + R <= 0.0 || c.y() - R >= L2) continue;
        if (f.shape == SectionShape::circle) paint_circle(g, c, f.radius);
        else paint_rect(g, make_rect(f, shift));
      }
  }

  // Snap roundoff-level slivers (|f| or |1 − f| ≤ 1e-12 of a pixel) so that composite pixels are real
  // interfaces; the volume fraction moves by at most 1e-12 per boundary pixel.
  for (std::size_t k = 0; k < N; ++k) {
    double& fk = img.fiber_fraction[k];
    Eigen::Vector3d& nk = img.normal[k];
    if (fk <= 1e-12) fk = 0.0;
    else if (fk >= 1.0 - 1e-12) fk = 1.0;  // also clamps overlapping fibers (not produced here)
    if (fk == 0.0 || fk == 1.0) nk.setZero();
    else nk.z() = 0.0;
  }
  return img;
}

PhaseImage matrix_only_section(int n1, int n2) {
  const std::string grid_text = "[" + std::to_string(n1) + ", " + std::to_string(n2) + "]";
  if (n1 < 1 || n2 < 1) throw InputError("microstructure.grid", grid_text, "must have at least one pixel per direction");
  detail::refuse_if_too_big(image_bytes(std::size_t(n1) * std::size_t(n2)), "microstructure.grid", grid_text);
  PhaseImage section;
  section.n = {n1, n2, 1};
  const double h = 1.0 / n1;
  section.size = {1.0, n2 * h, h};
  section.fiber_fraction.assign(section.voxels(), 0.0);
  return section;
}

void refuse_oversized_image(double voxels, double extra_bytes_per_voxel, const std::string& field, const std::string& value) {
  const double per_voxel = double(image_bytes(1)) + extra_bytes_per_voxel;
  detail::refuse_if_too_big(detail::saturating_product({voxels, per_voxel}), field, value);
}

PhaseImage extrude(const PhaseImage& s, int n3) {
  const std::string grid_text = "[" + std::to_string(s.n[0]) + ", " + std::to_string(s.n[1]) + ", " + std::to_string(n3) + "]";
  if (n3 < 1) throw InputError("microstructure.grid", grid_text, "n3 must be at least 1");
  if (s.n[2] != 1) throw std::invalid_argument("extrude: the input must be a single-layer section image");
  detail::refuse_if_too_big(image_bytes(std::size_t(s.n[0]) * std::size_t(s.n[1]) * std::size_t(n3)), "microstructure.grid",
                            grid_text);
  PhaseImage out;
  out.n = {s.n[0], s.n[1], n3};
  out.size = {s.size[0], s.size[1], n3 * (s.size[0] / s.n[0])};
  const std::size_t layer = std::size_t(s.n[0]) * s.n[1];
  out.fiber_fraction.reserve(layer * n3);
  out.normal.reserve(layer * n3);
  for (int k = 0; k < n3; ++k) {
    out.fiber_fraction.insert(out.fiber_fraction.end(), s.fiber_fraction.begin(), s.fiber_fraction.end());
    out.normal.insert(out.normal.end(), s.normal.begin(), s.normal.end());
    if (!s.fiber_direction.empty())
      out.fiber_direction.insert(out.fiber_direction.end(), s.fiber_direction.begin(), s.fiber_direction.end());
  }
  return out;
}

namespace {

int periodic(int i, int n) { return ((i % n) + n) % n; }

/// A slab image's frame (n, size, planes) with empty arrays; checks the planes.
PhaseImage slab_frame(const std::array<int, 3>& n, const std::array<double, 3>& size, int begin, int count, int halo) {
  if (count < 0 || begin < 0 || begin + count > n[2] || halo < 0)
    throw std::invalid_argument("slab image: planes [" + std::to_string(begin) + ", " + std::to_string(begin + count) +
                                ") with halo " + std::to_string(halo) + " do not fit n3 = " + std::to_string(n[2]));
  PhaseImage out;
  out.n = n;
  out.size = size;
  out.slab = true;
  out.plane_begin = begin;
  out.plane_count = count;
  out.halo = count > 0 ? halo : 0;  // a rank without planes reads none
  return out;
}

}  // namespace

PhaseImage extrude_planes(const PhaseImage& s, int n3, int begin, int count, int halo) {
  const std::string grid_text = "[" + std::to_string(s.n[0]) + ", " + std::to_string(s.n[1]) + ", " + std::to_string(n3) + "]";
  if (n3 < 1) throw InputError("microstructure.grid", grid_text, "n3 must be at least 1");
  if (s.n[2] != 1 || s.is_slab()) throw std::invalid_argument("extrude_planes: the input must be a single-layer section image");
  PhaseImage out = slab_frame({s.n[0], s.n[1], n3}, {s.size[0], s.size[1], n3 * (s.size[0] / s.n[0])}, begin, count, halo);
  const std::size_t layer = std::size_t(s.n[0]) * s.n[1], planes = std::size_t(count) + 2 * std::size_t(out.halo);
  detail::refuse_if_too_big(image_bytes(layer * planes), "microstructure.grid", grid_text);
  out.fiber_fraction.reserve(layer * planes);
  out.normal.reserve(layer * planes);
  for (std::size_t k = 0; k < planes; ++k) {
    out.fiber_fraction.insert(out.fiber_fraction.end(), s.fiber_fraction.begin(), s.fiber_fraction.end());
    out.normal.insert(out.normal.end(), s.normal.begin(), s.normal.end());
    if (!s.fiber_direction.empty())
      out.fiber_direction.insert(out.fiber_direction.end(), s.fiber_direction.begin(), s.fiber_direction.end());
  }
  return out;
}

PhaseImage slab_of(const PhaseImage& whole, int begin, int count, int halo) {
  if (whole.is_slab()) throw std::invalid_argument("slab_of: the input must be a whole image");
  PhaseImage out = slab_frame(whole.n, whole.size, begin, count, halo);
  const std::size_t layer = std::size_t(whole.n[0]) * whole.n[1];
  auto copy_planes = [&](const auto& from, auto& to) {
    if (from.size() != whole.voxels()) return;  // absent (normals, directions)
    to.reserve(out.held_voxels());
    for (int k = begin - out.halo; k < begin + count + out.halo; ++k) {
      const auto first = from.begin() + std::ptrdiff_t(layer * std::size_t(periodic(k, whole.n[2])));
      to.insert(to.end(), first, first + std::ptrdiff_t(layer));
    }
  };
  copy_planes(whole.fiber_fraction, out.fiber_fraction);
  copy_planes(whole.normal, out.normal);
  copy_planes(whole.fiber_direction, out.fiber_direction);
  return out;
}

std::size_t PhaseImage::held_voxels() const {
  return is_slab() ? std::size_t(n[0]) * n[1] * (std::size_t(plane_count) + 2 * std::size_t(halo)) : voxels();
}
std::size_t PhaseImage::owned_voxels() const { return is_slab() ? std::size_t(n[0]) * n[1] * std::size_t(plane_count) : voxels(); }
std::size_t PhaseImage::owned_offset() const { return is_slab() ? std::size_t(n[0]) * n[1] * std::size_t(halo) : 0; }

std::size_t PhaseImage::index_of(int i1, int i2, int i3) const {
  int l = periodic(i3, n[2]);
  if (is_slab()) {
    if (plane_count == 0) throw std::out_of_range("PhaseImage::index_of: the slab holds no planes");
    // The first held position of plane i3 (with n3 < held planes a plane is held twice, equal both times).
    l = periodic(i3 - (plane_begin - halo), n[2]);
    if (l >= plane_count + 2 * halo)
      throw std::out_of_range("PhaseImage::index_of: plane " + std::to_string(i3) + " is not held by the slab [" +
                              std::to_string(plane_begin) + ", " + std::to_string(plane_begin + plane_count) + ")");
  }
  return std::size_t(periodic(i1, n[0])) + std::size_t(n[0]) * (std::size_t(periodic(i2, n[1])) + std::size_t(n[1]) * std::size_t(l));
}

double PhaseImage::owned_fiber_sum() const {
  if (fiber_fraction.size() != held_voxels()) return 0.0;
  const auto first = fiber_fraction.begin() + std::ptrdiff_t(owned_offset());
  return std::accumulate(first, first + std::ptrdiff_t(owned_voxels()), 0.0);
}

Eigen::Matrix3d PhaseImage::owned_orientation_sum() const {
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  if (fiber_direction.size() != held_voxels() || fiber_fraction.size() != held_voxels()) return M;
  for (std::size_t v = owned_offset(); v < owned_offset() + owned_voxels(); ++v)
    M += fiber_fraction[v] * fiber_direction[v] * fiber_direction[v].transpose();
  return M;
}

Eigen::Vector3d principal_fiber_axis(const Eigen::Matrix3d& M) {
  if (!(M.trace() > 0.0)) return Eigen::Vector3d::UnitZ();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(M);
  Eigen::Vector3d a = es.eigenvectors().col(2);  // eigenvalues ascending
  Eigen::Index k;
  a.cwiseAbs().maxCoeff(&k);
  return a[k] < 0.0 ? Eigen::Vector3d(-a) : a;
}

Eigen::Vector3d PhaseImage::mean_fiber_direction() const { return principal_fiber_axis(owned_orientation_sum()); }

double PhaseImage::volume_fraction() const {
  if (fiber_fraction.empty()) return 0.0;
  if (!is_slab()) return std::accumulate(fiber_fraction.begin(), fiber_fraction.end(), 0.0) / double(fiber_fraction.size());
  return owned_voxels() ? owned_fiber_sum() / double(owned_voxels()) : 0.0;
}

}  // namespace softhom::rve
