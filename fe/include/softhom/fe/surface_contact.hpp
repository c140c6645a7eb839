#pragma once
// Contact between deformable surfaces, and self-contact of one surface: penalty with one augmentation of
// the multiplier per converged step and regularized Coulomb friction, as the rigid obstacles' law
// (contact.hpp).
//
// Formulation: the quadrature points of the slave surface's faces each see the master surface around one master face
// (a hex8 quad or a tet10 6-node triangle), the one the step paired it with: its closest point over that
// face and the faces sharing a corner with it (its ring), each by Newton in the face's parametric
// coordinates clamped to the face. Inside a face the gap is g = (x_s − x_m)·n along the face's unit
// normal n (outward of the master body: g > 0 apart); where an edge or a corner holds the closest point
// it is the distance to it, signed by the side of the pseudo-normal there (the normals of the faces
// around the edge or corner at that point, a corner's weighted by the faces' angles at it: Bærentzen and
// Aanæs 2005). That is the signed distance to the surface: continuous, with its first derivative, as a
// point slides past a face's edge, crosses a face's plane beside an edge, or comes nearer a neighbour
// across a concave edge (where its gradient turns from one face's normal to the other's). Past a free
// edge or corner of the master surface (its end, or a body's cut by a mirror plane) the face continues
// by its shape functions: the gap is along the normal at the closest point of the face so extended, the
// mirror half's face for a face square to the plane (the distance to the edge would grow with the
// point's offset past it: false depths). The nominal
// pressure is p = ⟨λ + ε (−g)⟩ per reference slave area. The residual is the variation of the penalty
// energy: R = −Σ w p ∂g/∂u over the slave face's and the master face's nodes, and its tangent the exact
// second variation, w (ε ∂g⊗∂g − p ∂²g), including the motion of the closest point over the master face
// and the rotation of its normal, or at an edge of the distance's direction (symmetric without
// friction). A point held at an edge farther than half a face beside the face nearest to it (past the
// ring of its paired face, or paired across a corner) bears nothing until the next step pairs it again.
// In a self-contact the faces within two rings of the point's own face are never its master (its own
// surface beside it).
//
// Pairing: at the start of every step (Contribution::pair) each slave point takes the nearest master
// face within two face sizes whose normal opposes the slave face's and which the point lies in front
// of, or at most half a face behind (deeper is the far side of a wall, never a contact: a wall must be
// thicker than half a face to be told from a penetration). A uniform grid over the master faces' boxes
// finds the candidates (linear in the surfaces' size); no point pairs with its own face or one sharing
// a node with it (a self-contact's neighbours). The pairing, the parametric start of the projection,
// the multiplier, the stick anchor and the point's place on its slave face are the contribution's
// history (state_size: kStateSize per slot, kSegmentSlots slots per slave face with segments),
// so a cut-back step is retried with the pairing and the anchors of the converged state. The couplings are the (slave face, paired
// face, face of its ring) triples: the driver rebuilds the stiffness pattern when they change.
//
// Quadrature (Options::integration): with `segments` (the default here and for a scene's pairs; a
// scene's self-contact defaults to `points`, macro/surface_contact_keys.cpp) the pairing cuts each slave face
// into the pieces that lie over one master face each: the master faces near it (the ones its Gauss
// points pair with, and their rings) are projected onto the slave face's parameter plane by their
// corners, joined by straight lines, each outline clips the face's parametric domain, and every piece
// (a triangle, or the fan of triangles from its centroid, so that mirror-image faces get mirror-image
// points) carries the 3-point rule of degree 2 on each triangle, each point paired with its piece's master
// face where that holds its closest point inside, else as a Gauss point is, with its nearest admissible
// master face (surfaces meeting at an angle). A master
// shape function is then smooth over every piece, so the master's loads are the exact quadrature of its
// shape functions (for parallel flat faces: straight-sided triangles, parallelogram quads): a uniform
// pressure crosses between non-matching meshes (the contact patch test, tests/fe/test_surface_contact.cpp). A slave face that
// the master faces do not tile (part of it lies past the master surface's free edge, their outlines
// overlap or one is not convex) or whose pieces need more than kSegmentSlots points keeps its Gauss
// points (ObstacleContact's rules: 3×3 Gauss on quads, Dunavant's 7 points on 6-node triangles), each
// paired with its nearest master face, as does every face with `points`. The layout is part of the
// history (each slot stores its parametric place and weight) and changes at pairings only; a new
// slot takes the multiplier and the stick offset (x_s − x_a) of the old slot of its face nearest to
// it in the parameter plane. With Gauss points a uniform pressure crosses exactly only where every
// slave face lies within one master face (the slave side finer, nested).
//
// Self-contact is two-pass: every point of the surface is a slave, each weighted by one half, so both
// sides of a fold carry the same pressure. A (slave, master) pair is one-pass unless `two_pass` (then
// both surfaces are slaves, each weighted by one half).
//
// Friction (μ > 0): every slave point keeps a stick anchor, a material point of its paired master face
// given by its parametric coordinates (ξ_a, η_a), so the anchor moves with the master surface (within a
// step it stays on the paired face where the closest point lies on a neighbour). The slip is the
// tangential part of the offset from the anchor, v_T = P (x_s − x_a) with P = I − ν⊗ν (ν the contact
// normal: the master face's, or at an edge the direction of the distance), the trial stick traction
// −ε_T v_T, returned onto the cone |t_T| ≤ μ p (fe::coulomb_return, the obstacles' law). The slave
// point bears t_T, the master face's closest point −t_T; the tangent is the exact derivative,
// including the anchor's and the closest point's motion and the normal's rotation (non-symmetric in
// slip, and in stick where the normal turns: the direct solver then preconditions GMRES with the
// factor of the symmetric part, the petsc path runs GMRES anyway). A converged sticking point keeps its
// anchor; a slipping one moves it to where the converged trial traction is the returned one (the
// closest point + t_T/ε_T, in the face's extended parametric coordinates); a free one takes its
// closest point. When the pairing gives a point another master face, its anchor is carried over to
// the new face's (extended) parametric coordinates at the same place.
//
// Tangential penalty (default): ε_T = ε_N / 10 = 10 G/h. Ten times a surface element's own shear
// stiffness G/h, so a sticking contact slides elastically by μ p h/(10 G) at most before it slips (3 %
// of a face at μ = 0.3, p = G), and a tenth of the normal penalty: the whole patch going from stick to
// slip in one step (a drag starting, a rigid die starting to slide: bench/ironing.cpp needed this ratio)
// then changes the tangent by a tenth of the normal stiffness only, which Newton crosses in a few
// iterations. The slip force μ p does not depend on it.
//
// Penalty (default as the rigid law's): ε = 100 G/h per slave face, G the softer surface's initial
// shear modulus (Options::shear_modulus). An iterate is refused with MaterialStatus::penetration (the
// line search backtracks, or the step is cut back) where a slave point lies deeper than its master
// face's size, or where its penalty pressure ε (−g) exceeds 10 G (kMaxContactPressureOverShear, the
// obstacles' bound) above what the point carried at the step's start (the pressure it converged with:
// the multiplier λ of an augmented step, its penetration's pressure in pure penalty; or its depth
// against the face the pairing gave it, if deeper, as where a point slid off an edge): the bound is on the step's increment, since a
// converged state legitimately carries any pressure, while an iterate adding more than 10 G in one step
// is one whose tangent did not yet see the contact (the step that first touches pushes its whole
// increment into the softer body and inverts its elements). Without a modulus (G = 0, an explicit
// penalty) only the face-size bound holds. A point's
// search reaches two face sizes from the converged state: a step must not move the surfaces towards
// each other by more than that.
#include <array>
#include <string>
#include <unordered_map>
#include <vector>

#include "softhom/fe/contact.hpp"
#include "softhom/fe/contribution.hpp"
#include "softhom/fe/mesh.hpp"

namespace softhom::fe {

/// Faces of a contact surface with outward normals (quads of hex8 meshes, 6-node triangles of tet10).
struct ContactSurface {
  std::vector<Quad> quads;
  std::vector<Tri6> tris;
  std::string name;  ///< the scene's name, for messages
};

/// The closest point of a master face to a point: parametric coordinates and the geometry there.
struct FaceProjection {
  double xi = 0.0, eta = 0.0;
  /// Directions in (ξ, η) left free by the face's bounds at the closest point (2 inside, 1 on an edge,
  /// 0 at a corner), as columns.
  int free = 2;
  std::array<double, 4> free_basis{1, 0, 0, 1};
  Vec3 x = Vec3::Zero();   ///< the closest point
  Vec3 normal = Vec3::UnitZ();
  double gap = 0.0;        ///< (point − x)·normal
  double distance = 0.0;   ///< |point − x|
};

class FaceGrid;

class SurfaceContact final : public Contribution {
 public:
  struct Options {
    double penalty = 0.0;        ///< ε [MPa/mm] > 0 on every face; 0: 100 G/h per slave face
    double shear_modulus = 0.0;  ///< G of the surfaces' elements, for the default penalty
    double friction = 0.0;       ///< Coulomb coefficient μ ∈ [0, 3]
    double tangential_penalty = 0.0;  ///< ε_T [MPa/mm] > 0 on every face; 0: ε_N / 10 per slave face
    bool augmented = true;       ///< λ ← p at every converged step (false: pure penalty)
    bool two_pass = false;       ///< pairs: the master's points against the slave's faces too
    /// The slave faces' quadrature: on the pieces over each master face, or the Gauss points.
    enum class Integration { segments, points };
    Integration integration = Integration::segments;
    std::string field = "contact.pairs[0]";  ///< its TOML path, for messages
    std::string label = "pair";  ///< its outputs: response.csv columns <label>_..., field <label>.h5
  };
  /// A pair: the slave surface's points against the master surface's faces.
  SurfaceContact(const Mesh& mesh, ContactSurface slave, ContactSurface master, Options options);
  /// Self-contact of one surface (two-pass).
  SurfaceContact(const Mesh& mesh, ContactSurface surface, Options options);

  Kind kind() const override { return Kind::interface; }
  std::string name() const override { return options_.field; }
  const Options& options() const { return options_; }
  /// Refuses empty surfaces, nodes out of range, bad penalties, a friction coefficient outside [0, 3],
  /// and surfaces that overlap at t = 0 (naming the deepest point).
  void validate(const Mesh& mesh) const override;
  bool couplings_change() const override { return true; }
  void pair(const Mesh& mesh, const Iterate& converged, Couplings& couplings) const override;
  int state_size() const override { return kStateSize * int(points_.size()); }
  void init_state(double* state) const override;
  MaterialStatus assemble(const Mesh& mesh, const Iterate& it, AssemblySink& sink) const override;
  /// Probes <label>_normal_force [N], _tangential_force [N] (|Σ t_T dA|, the friction force on the
  /// slaves), _area [mm^2], _active_points [1], _max_penetration [mm]; with friction also
  /// _slipping_points [1]; the field <label> on the slave faces: contact_pressure (Cauchy), gap,
  /// tangential_traction (Cauchy, |t_T| averaged over the face's points) and slip (the fraction of its
  /// active points on the Coulomb cone).
  void report(const Mesh& mesh, const Iterate& it, ContributionReport& out) const override;

  /// Resultants at an iterate whose state_old holds the pairing.
  ContactTotals totals(const Mesh& mesh, const Iterate& it) const;
  /// Current positions of the slave quadrature points in contact (p > 0) at such an iterate.
  std::vector<Vec3> active_positions(const Mesh& mesh, const Iterate& it) const;
  /// Per face of faces() (slave ones filled): the mean Cauchy contact pressure and tangential traction
  /// over its points, the least gap (+inf where unpaired) and the fraction of its active points slipping.
  struct FaceValues {
    std::vector<double> pressure, gap, tangential, slip;
  };
  FaceValues face_values(const Mesh& mesh, const Iterate& it) const;
  int num_points() const { return int(points_.size()); }
  /// History per slot (a quadrature point of a slave face): the multiplier its step solves with, its
  /// pressure there (the next step's multiplier), master face (−1: none), ξ, η of the projection's
  /// start, the stick anchor's ξ_a, η_a on the master face the step solves with, the next step's, the
  /// point's depth against its master face where the pairing found it (the pressure bound's start), and
  /// its place on the slave face: ξ_s, η_s, its reference area weight (× the pass's factor; 0: an
  /// unused slot) and its weight in the parameter plane.
  static constexpr int kStateSize = 14;
  static constexpr int kStartDepth = 9;
  static constexpr int kAnchor = 5, kNextAnchor = 7;  ///< offsets of (ξ_a, η_a) in a point's state
  static constexpr int kPlace = 10, kWeight = 12, kRuleWeight = 13;
  /// Slots per slave face with segments: a quad over four master quads, each piece a pentagon, needs 60.
  static constexpr int kSegmentSlots = 64;

  /// One face of either surface.
  struct Face {
    int nodes_count = 4;
    std::array<int, 6> nodes{};
    double size = 0.0;  ///< h (contact.hpp's face_sizes)
    bool slave = false;
    bool quad() const { return nodes_count == 4; }
  };
  const std::vector<Face>& faces() const { return faces_; }

 private:
  /// One slot of a slave face in a pass against the master faces [master_begin, master_end): its Gauss
  /// point (the home place, its first `home_count` slots), or with segments a spare slot. The state
  /// holds where the slot is (located() reads it).
  struct Point {
    int face = 0;
    int master_begin = 0, master_end = 0;
    int slot = 0, slots = 1, home_count = 1;  ///< its index on the face, the face's slots and Gauss points
    double xi = 0.0, eta = 0.0;  ///< the home place
    std::array<double, 6> N{}, dN_xi{}, dN_eta{};
    double rule_weight = 0.0;
    double weight = 0.0;  ///< reference area weight × the pass's factor
    double penalty = 0.0;
    double tangential_penalty = 0.0;
    double factor = 1.0;  ///< the pass's weight (1/2 in two passes)
  };
  /// A point at positions x against its master face (history s): the projection and the pressure with
  /// multiplier λ; `engaged` when its closest point lies on the face (or within half a face beside it).
  struct Evaluation {
    int paired = -1;  ///< the master face of the step's pairing (the stick anchor's face)
    int master = -1;  ///< the face holding the closest point: the paired one or a neighbour of it
    bool engaged = false;
    /// The gap's sign is the master surface's side (inside a face, or at an edge or corner between
    /// faces), not only a face plane's (at a free edge of the master surface).
    bool sided = true;
    FaceProjection projection;
    double sign = 1.0;  ///< at an edge or corner: the side of the pseudo-normal
    double gap = 0.0;   ///< along the normal inside the face; ± the distance at an edge or corner
    double pressure = 0.0;
  };
  /// The side (±1) of a point at offset d from a closest point held at an edge or corner of face w,
  /// by the pseudo-normal of the faces around that edge or corner; `interior` whether they close
  /// around it (no free edge of the surface there) and lie within the paired face's neighbourhood;
  /// `open` whether it is a free edge or corner of the surface.
  double feature_side(int w, const FaceProjection& q, const Vec3& d, const std::vector<Vec3>& x, int paired,
                      bool& interior, bool& open) const;
  /// The nodes a point's response couples: its slave face's, the master face's, and the paired face's
  /// when it is another and carries a stick anchor. Returns their count.
  int response_nodes(const Point& p, const Evaluation& e, std::array<int, 18>& nodes) const;
  Evaluation evaluate(const Point& p, const double* s, double multiplier, const std::vector<Vec3>& x) const;
  /// Deepest admissible penetration of a point against `master` in an iterate (surface_contact.hpp).
  double penetration_limit(const Point& p, const Face& master, const double* s) const;
  /// The point's tractions at an evaluation, with the stick anchor (ξ_a, η_a) on its master face: the
  /// residual and (with `tangent`) the tangent over the slave face's then the master face's dofs.
  struct Response;
  Response respond(const Point& p, const Evaluation& e, const double* anchor, const std::vector<Vec3>& x,
                   bool tangent) const;
  /// The anchor the next step starts from, after the point converged with response r.
  void advance_anchor(const Point& p, const Evaluation& e, const Response& r, const std::vector<Vec3>& x,
                      double* next) const;
  /// Current area weight of a point (its rule weight × |x_ξ × x_η| × the pass's factor).
  double current_weight(const Point& p, const std::vector<Vec3>& x) const;
  void build(const Mesh& mesh, int surfaces, bool self);
  /// ring_ and corner_faces_ from the faces' corners.
  void build_topology();
  /// 0 for the (first) slave surface's faces or a self-contact's, 1 for a pair's master surface's.
  int surface_of(int face) const { return self_ || face < slave_faces_ ? 0 : 1; }
  /// The closest point of the faces around e.paired (its ring) to xs, if nearer than e.projection:
  /// a point the step paired with a face and which slid past its edge, or lies nearer a neighbour across
  /// a concave edge, measures its gap to the surface, not to the paired face's extension.
  void closest_in_ring(const Point& p, const Vec3& xs, const std::vector<Vec3>& x, Evaluation& e) const;
  void add_points(const Mesh& mesh, int slave_begin, int slave_end, int master_begin, int master_end, double factor);
  /// The point's pairing at positions x: the nearest admissible master face (−1: none) and its projection.
  struct Candidate {
    int face = -1;
    FaceProjection projection;
  };
  Candidate nearest_face(const Point& p, const std::vector<Vec3>& x, const FaceGrid& grid) const;
  /// Face f as the pairing of point p at xs (slave normal n_slave), if admissible (face −1 if not).
  Candidate admissible(const Point& p, const Vec3& xs, const Vec3& n_slave, int f, const std::vector<Vec3>& x) const;
  /// The unit normal of p's slave face at p.
  Vec3 slave_normal(const Point& p, const std::vector<Vec3>& x) const;
  /// The slot p with its place and weights as the state s has them (the home place for a Gauss point).
  Point located(const Point& p, const double* s) const;
  /// The slot p moved to (ξ, η) of its face (its shape functions there; weights unchanged).
  Point at_place(const Point& p, double xi, double eta) const;
  /// A slot of a face's new layout: its place, weight in the parameter plane and pairing.
  struct Slot {
    double xi = 0.0, eta = 0.0, rule_weight = 0.0;
    Candidate pairing;
  };
  /// The pieces of the slave face of the group starting at slot g over the master faces near it
  /// (surface_contact.hpp), from its Gauss points' pairing; empty where they do not tile it.
  std::vector<Slot> segment_layout(std::size_t g, const std::vector<Candidate>& home, const std::vector<Vec3>& x,
                                   const FaceGrid& grid) const;
  /// Pairs the slots of the face starting at slot g (state s): lays them out anew and carries the
  /// history of the old layout over (surface_contact.hpp); appends the (slave, master) face pairs.
  void pair_face(const Mesh& mesh, std::size_t g, const std::vector<Vec3>& x, const FaceGrid& grid, double* s,
                 std::vector<std::pair<int, int>>& pairs) const;
  /// Slot state s paired with c, from the history `old` of the slot at old_xs (the same slot where
  /// old_xs is its place): its next anchor on c's face, at the old anchor's place moved with the slot.
  void carry_anchor(const Candidate& c, const std::vector<Vec3>& x, const double* old, const Vec3& shift,
                    double* s) const;
  std::vector<Vec3> positions(const Mesh& mesh, const Iterate& it) const;
  Vec3 point_position(const Point& p, const std::vector<Vec3>& x) const;

  std::vector<Face> faces_;
  /// Per face: the faces of its surface sharing a corner with it (itself included), where a point
  /// paired with it may find its closest point within a step.
  std::vector<std::vector<int>> ring_;
  /// Per (corner node, surface): the faces having that corner.
  std::unordered_map<long long, std::vector<int>> corner_faces_;
  std::vector<Point> points_;
  std::vector<std::string> surface_names_;
  int slave_faces_ = 0;  ///< faces_[0, slave_faces_) are the (first) slave surface's
  Options options_;
  bool self_ = false;
};

/// The closest point of face (positions x of its nodes) to `point`, from the start (ξ0, η0): Newton in
/// the parametric coordinates, clamped to the face.
FaceProjection project_on_face(const SurfaceContact::Face& face, const std::vector<Vec3>& x, const Vec3& point,
                               double xi0, double eta0);

/// The closest point to `point` of the face's surface extended beyond its bounds by its shape functions,
/// from (ξ, η): unbounded Newton in the parametric coordinates (free = 2).
FaceProjection project_on_extended_face(const SurfaceContact::Face& face, const std::vector<Vec3>& x,
                                        const Vec3& point, double xi, double eta);

}  // namespace softhom::fe
