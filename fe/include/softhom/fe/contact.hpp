#pragma once
// Contact of a body's surface with rigid analytic obstacles (planes, spheres, infinite cylinders), each
// translated along a prescribed piecewise-linear path: frictionless, or with regularized Coulomb friction.
//
// Formulation: at every quadrature point of the body's surface faces (3×3 Gauss on the quads of hex8
// meshes, Dunavant's 7-point degree-5 rule on the 6-node triangles of tet10 meshes) the signed gap g
// to the obstacle gives a normal pressure p = ⟨λ + ε_N (−g)⟩ per reference area (ε_N the penalty, λ
// the multiplier augmented once per converged step), and a stick point on the obstacle gives the
// tangential traction: the trial −ε_T P (x − x_stick) (P the tangent projector), returned onto the
// Coulomb cone |t_T| ≤ μ p (slip). The face integral of these tractions is the residual, its exact
// derivative the tangent (symmetric without friction: then it is the Hessian of the penalty energy).
//
// Why at quadrature points and not at nodes: a uniform pressure on a 6-node triangle has no consistent
// load at its corners (∫ N_corner da = 0), so a node-to-surface scheme cannot transmit it; at quadrature
// points a uniform penetration gives exactly the consistent loads of a uniform pressure on quads and
// 6-node triangles alike (tests/fe/test_contact.cpp, the pressed block), and the rigid obstacle needs
// no segment pairing. The tangent couples only each face's own nodes, so the stiffness pattern is fixed.
//
// Penalty (documented default): ε_N = ε_T = 100 G / h per face, G the initial shear modulus of the
// elements on the surface and h the face's size (√area of a quad, √(2 area) of a triangle), so a
// converged contact pressure p penetrates a face by (p − λ)/ε_N ≤ (p / G) h / 100 — under 1 % of the face
// at pressures up to G, on graded meshes too — and the per-step augmentation λ ← p shrinks that to the
// pressure change of one step. An iterate deeper than its face's size (or half the radius of a curved
// obstacle), or whose penalty pressure exceeds 10 G (0.1 h deep under the default penalty) by more than
// the obstacle's own motion over the step, is refused
// with MaterialStatus::penetration: the line search backtracks, or the step is cut back and retried smaller.
//
// History: the stick point (in the obstacle's frame) and the multiplier of every point are the
// contribution's state (state_size(), Iterate::state_old/state_new), two sets per point: the one the
// step is solved with, and the one the next step starts from (λ ← p, the stick point moved by the
// slip), which every evaluation writes from its iterate; the driver keeps the converged iterate's only.
// The step's Newton iterates read the second set of the converged state; its reports (totals, fields)
// read the first, so they see the tractions the converged state was solved with. An iterate without
// a state (tests of the tangent) sees the initial one: no multiplier, the stick points at the closest
// points at t = 0.
#include <array>
#include <string>
#include <vector>

#include "softhom/fe/contribution.hpp"
#include "softhom/fe/mesh.hpp"
#include "softhom/materials/loading.hpp"

namespace softhom::fe {

/// A rigid analytic obstacle. The body must lie on the side the normal points to (plane), outside the
/// sphere, or outside the cylinder.
struct RigidObstacle {
  enum class Shape { plane, sphere, cylinder };
  Shape shape = Shape::plane;
  Vec3 point = Vec3::Zero();       ///< at t = 0: a point of the plane, the sphere's centre, a point of the cylinder's axis
  Vec3 direction = Vec3::UnitZ();  ///< unit: the plane's normal (towards the body), the cylinder's axis
  double radius = 0.0;             ///< sphere and cylinder
  /// Translation of the obstacle u(t) (components x, y, z), piecewise linear; zero by default.
  std::array<PiecewiseLinear, 3> path{PiecewiseLinear::constant(0.0), PiecewiseLinear::constant(0.0),
                                      PiecewiseLinear::constant(0.0)};
  Vec3 translation(double t) const { return Vec3(path[0](t), path[1](t), path[2](t)); }
  /// "plane", "sphere", "cylinder".
  std::string shape_name() const;
};

/// A point x against an obstacle at time t: the signed distance g (> 0 apart, < 0 penetrating), the unit
/// normal n = ∂g/∂x at the closest point (from the obstacle towards x), its derivative ∂n/∂x (symmetric;
/// zero for a plane) and the closest point of the obstacle's surface.
struct ObstacleGap {
  double gap = 0.0;
  Vec3 normal = Vec3::UnitZ();
  Mat3 dnormal = Mat3::Zero();
  Vec3 closest = Vec3::Zero();
};
ObstacleGap obstacle_gap(const RigidObstacle& obstacle, const Vec3& x, double t);

/// Coulomb coefficients above this are refused as a unit or typing slip: measured rubber-on-glass
/// coefficients reach about 3 (Roberts 1977), so the bound leaves room for every real pairing.
constexpr double kMaxContactFriction = 3.0;

/// The regularized contact law of one surface point.
struct ContactLaw {
  double penalty = 0.0;             ///< ε_N: pressure per penetration [MPa/mm]
  double tangential_penalty = 0.0;  ///< ε_T: stick traction per tangential slip [MPa/mm]
  double friction = 0.0;            ///< Coulomb coefficient μ (0: frictionless)
};

/// The traction of the obstacle on the body at one point, per reference area, and its derivative.
struct PointTraction {
  Vec3 traction = Vec3::Zero();    ///< p n + t_T
  Mat3 dtraction = Mat3::Zero();   ///< ∂traction/∂x
  double pressure = 0.0;           ///< p ≥ 0 (nominal: per reference area)
  Vec3 tangential = Vec3::Zero();  ///< t_T
  bool active = false;             ///< p > 0
  bool slip = false;               ///< on the Coulomb cone
};

/// The regularized Coulomb law on a trial stick traction: kept when |trial| ≤ μ p (stick), else returned
/// onto the cone as μ p trial/|trial| (slip); its derivative is Δt = d_trial Δtrial + d_pressure Δp.
/// Shared by the rigid obstacles and the contact between deformable surfaces (surface_contact.hpp).
struct CoulombReturn {
  Vec3 traction = Vec3::Zero();
  Mat3 d_trial = Mat3::Identity();
  Vec3 d_pressure = Vec3::Zero();
  bool slip = false;
};
CoulombReturn coulomb_return(const Vec3& trial, double friction, double pressure);

/// p = ⟨λ + ε_N (−g)⟩ along n; with friction the trial t_T = −ε_T P (x − stick) (P = I − n⊗n), kept when
/// |t_T| ≤ μ p (stick), else μ p t_T/|t_T| (slip); and their exact derivative with respect to x.
PointTraction contact_traction(const ObstacleGap& g, const Vec3& x, const Vec3& stick, double multiplier,
                               const ContactLaw& law);

/// ε = 100 G / h (see the file comment).
double default_contact_penalty(double shear_modulus, double face_size);

/// Iterates whose penalty pressure exceeds this multiple of the softer surface's shear modulus, beyond
/// what the step legitimately adds, are refused (a soft solid carries no such pressure increment).
constexpr double kMaxContactPressureOverShear = 10.0;

/// The deepest penetration the pressure bound admits for a point with penalty ε on a surface of shear
/// modulus G: 10 G/ε plus `allowance` (the depth the step may add beyond it: the obstacle's motion, a
/// converged pressure's depth); +∞ without a modulus (G ≤ 0: an explicit penalty on no solid).
double pressure_depth_limit(double shear_modulus, double penalty, double allowance);

/// Size of each face in the reference configuration (quads first): √area of a quad, √(2 area) of a
/// 6-node triangle (the cell size of a hex split into tets).
std::vector<double> face_sizes(const Mesh& mesh, const std::vector<Quad>& quads, const std::vector<Tri6>& tris);
/// Their mean.
double mean_face_size(const Mesh& mesh, const std::vector<Quad>& quads, const std::vector<Tri6>& tris);

/// Resultants of a contact at an iterate.
struct ContactTotals {
  double normal_force = 0.0;      ///< Σ p dA [N]
  double tangential_force = 0.0;  ///< |Σ t_T dA| [N]
  Vec3 force = Vec3::Zero();      ///< Σ (p n + t_T) dA: the obstacle's force on the body [N]
  double area = 0.0;              ///< current area of the active points [mm²]
  int active_points = 0;
  int slipping_points = 0;
  double max_penetration = 0.0;   ///< max(−g, 0) [mm]
};

/// The five probes of a contact's totals: <label>_normal_force [N], _tangential_force [N], _area [mm^2],
/// _active_points [1], _max_penetration [mm].
void add_contact_probes(const std::string& label, const ContactTotals& totals, ContributionReport& out);
/// A contact's faces (their node lists) as cells of their own, named `stem`: the nodes they use at their
/// reference positions, the nodes' displacement, and per face contact_pressure [MPa] and gap [mm].
ReportField contact_face_field(const Mesh& mesh, const Iterate& it, const std::string& stem, ReportCells::Type type,
                               const std::vector<std::vector<int>>& faces, std::vector<double> pressure,
                               std::vector<double> gap);

/// Contact of one surface (quads and/or 6-node triangles, outward normals) with one rigid obstacle.
class ObstacleContact final : public Contribution {
 public:
  struct Options {
    /// Penalties > 0 apply to every face; 0: default_contact_penalty(shear_modulus, h) per face.
    ContactLaw law;
    double shear_modulus = 0.0;    ///< G of the surface's elements, for the default penalties
    bool augmented = true;         ///< λ ← p at every converged step (false: pure penalty)
    /// The contact surface lies this far from the faces towards the obstacle [mm] (a shell's mid-surface
    /// faces: half its thickness); the gap is measured to the obstacle grown by it.
    double offset = 0.0;
    std::string field = "contact"; ///< the scene's name of this pair, for messages
    std::string label = "contact"; ///< its outputs' name: response.csv columns <label>_..., fields <label>.h5
  };
  ObstacleContact(const Mesh& mesh, std::vector<Quad> quads, std::vector<Tri6> tris, RigidObstacle obstacle,
                  Options options);

  Kind kind() const override { return Kind::interface; }
  std::string name() const override { return options_.field; }
  /// Refuses an empty surface, nodes out of range, bad law values, and a body overlapping the obstacle
  /// at t = 0 (naming the point).
  void validate(const Mesh& mesh) const override;
  void declare_couplings(Couplings& couplings) const override;
  MaterialStatus assemble(const Mesh& mesh, const Iterate& it, AssemblySink& sink) const override;
  /// Two point states per quadrature point (see the file comment).
  int state_size() const override { return 2 * kPointStateSize * num_points(); }
  void init_state(double* state) const override;
  /// Probes <label>_normal_force [N], _tangential_force [N], _area [mm^2], _active_points [1],
  /// _max_penetration [mm]; the field <label> (its faces: contact_pressure, gap, displacement of their nodes).
  void report(const Mesh& mesh, const Iterate& it, ContributionReport& out) const override;

  ContactTotals totals(const Mesh& mesh, const Iterate& it) const;
  /// Per face (quads first, then triangles): the mean contact pressure (Cauchy: per current area) over
  /// its quadrature points and the least gap.
  void face_values(const Mesh& mesh, const Iterate& it, std::vector<double>& pressure, std::vector<double>& gap) const;

  /// Current positions of the quadrature points in contact (p > 0).
  std::vector<Vec3> active_positions(const Mesh& mesh, const Iterate& it) const;

  const RigidObstacle& obstacle() const { return obstacle_; }
  const Options& options() const { return options_; }
  const std::vector<Quad>& quads() const { return quads_; }
  const std::vector<Tri6>& tris() const { return tris_; }
  int num_points() const { return int(points_.size()); }

  /// One quadrature point: its face, shape functions and reference area weight.
  struct Point {
    int face = 0;                    ///< quads first, then triangles
    std::array<double, 6> N{};       ///< shape functions (4 or 6 used)
    std::array<double, 6> dN_xi{}, dN_eta{};
    double rule_weight = 0.0;        ///< weight of the rule on the reference face
    double weight = 0.0;             ///< rule weight × reference area density (dA)
  };
  /// History of one point: its stick point in the obstacle's frame and its multiplier.
  struct PointState {
    Vec3 stick = Vec3::Zero();
    double multiplier = 0.0;
  };
  static constexpr int kPointStateSize = 4;  ///< stick point (3), multiplier
  /// The state point k of a converged state was solved with (reports), and the one its next step's
  /// iterates are solved with: from the iterate's state_old, or the initial one without.
  PointState reported_state(const Iterate& it, int k) const { return read_state(it, k, 0); }
  PointState solving_state(const Iterate& it, int k) const { return read_state(it, k, 1); }

 private:
  int face_nodes(int face) const { return face < int(quads_.size()) ? 4 : 6; }
  const int* face_node_ids(int face) const {
    return face < int(quads_.size()) ? quads_[face].data() : tris_[face - quads_.size()].data();
  }
  Vec3 point_position(const Mesh& mesh, const Iterate& it, const Point& p) const;
  /// The gap of a point at x to the obstacle at time t, less Options::offset.
  ObstacleGap gap_at(const Vec3& x, double t) const;
  /// Current area density |x_ξ × x_η| × rule weight of a point.
  double current_weight(const Mesh& mesh, const Iterate& it, const Point& p) const;
  PointTraction point_traction(const Mesh& mesh, const Iterate& it, int k, const PointState& s, ObstacleGap& g) const;
  /// The state the next step starts from, after point k converged with traction pt at gap g.
  PointState advanced_state(const Iterate& it, int k, const PointState& s, const PointTraction& pt,
                            const ObstacleGap& g) const;
  PointState read_state(const Iterate& it, int k, int set) const;
  /// Deepest admissible penetration of a face's point in an iterate.
  double penetration_limit(int face, const Iterate& it) const;

  std::vector<Quad> quads_;
  std::vector<Tri6> tris_;
  RigidObstacle obstacle_;
  Options options_;
  std::vector<Point> points_;
  std::vector<double> face_size_;            ///< h per face
  std::vector<ContactLaw> face_law_;         ///< the law with each face's penalties
  std::vector<PointState> initial_;         ///< no multiplier, stick points at the closest points at t = 0
};

/// The quadrature points of ObstacleContact's rule on one face kind (quad: 3×3 Gauss; 6-node triangle:
/// Dunavant's 7 points): shape functions, their derivatives and the rule weights (face 0, weight 0).
std::vector<ObstacleContact::Point> contact_rule_points(bool quad);

}  // namespace softhom::fe
