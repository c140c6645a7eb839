#pragma once
// The macro model as a list of contributions. Every part of a structure-scale problem — an element
// domain, a surface load, a constraint, an interface between surfaces — declares the nodes it couples
// and adds its residual and consistent tangent at a Newton iterate through one AssemblySink. The Newton
// driver (solver.hpp) knows no contribution by name: it builds the stiffness pattern (the CSC matrix of
// the factorizing path, the PETSc preallocation of the distributed one) from the declared couplings
// and the mesh's elements, and assembles every contribution in one loop, on either linear-solver path.
//
// Contributions are const during assembly (their state is the iterate they are given, with their own
// history slice when they keep one), so a model may be copied and solved twice. A new element family or interface is a new subclass added to
// FeModel::contributions; a tie maps its own dofs through an interpolation onto host nodes by declaring
// the host nodes as its couplings and scattering Nᵀ r and Nᵀ K N onto them.
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "softhom/fe/mesh.hpp"
#include "softhom/materials/material.hpp"

namespace softhom::fe {

/// Groups of nodes whose dofs a contribution couples: every dof of a group's nodes with every other
/// (node-major, 3 dofs per node), as an element's node list does.
struct Couplings {
  std::vector<int> offsets{0};  ///< group g is nodes[offsets[g] .. offsets[g + 1])
  std::vector<int> nodes;
  void add(const int* group, int count) {
    nodes.insert(nodes.end(), group, group + count);
    offsets.push_back(int(nodes.size()));
  }
  int size() const { return int(offsets.size()) - 1; }
  bool empty() const { return size() == 0; }
  bool operator==(const Couplings& o) const { return offsets == o.offsets && nodes == o.nodes; }
};

/// The state a contribution is evaluated at.
struct Iterate {
  double t = 0.0;             ///< time of the residual
  double t_stiffness = 0.0;   ///< time of the load magnitudes in the tangent (the converged one at a step's
                              ///< first iteration from the converged state: see Simulation's try_step)
  double dt = 0.0;            ///< step size (history-dependent laws)
  const std::vector<double>* u = nullptr;  ///< displacement of every mesh dof (3 per node)
  double bordered = 0.0;      ///< the bordered unknown (the cavity pressure) at this iterate
  /// The contribution's own history (its state_size() values): the converged one, and where this
  /// evaluation writes its new one (the driver keeps it only when the step converges). Null without.
  const double* state_old = nullptr;
  double* state_new = nullptr;
  /// Current position of `node`.
  Vec3 position(const Mesh& mesh, int node) const {
    return mesh.nodes[node] + Vec3((*u)[3 * node], (*u)[3 * node + 1], (*u)[3 * node + 2]);
  }
};

/// Where contributions put what they compute: the residual R = f_int − f_ext on mesh dofs, its tangent
/// ∂R/∂u (the driver keeps the free rows and columns, and moves the prescribed columns' increments to
/// the predictor's right-hand side), and the border of one extra unknown λ with its scalar constraint.
class AssemblySink {
 public:
  virtual ~AssemblySink() = default;
  /// Whether the tangent is wanted (residual-only evaluations skip it).
  bool tangent() const { return tangent_; }
  /// R[dofs[i]] += r[i].
  virtual void add_residual(int n, const int* dofs, const double* r) = 0;
  /// ∂R/∂u[rows[i], cols[j]] += k[i + nr · j] (column-major, Eigen's storage). Every (row, col) node pair
  /// must have been declared among the contribution's couplings (or lie in one element).
  virtual void add_tangent(int nr, const int* rows, int nc, const int* cols, const double* k) = 0;
  /// The extra unknown λ: ∂R/∂λ at dofs and ∂c/∂u of its constraint c(u) = target at dofs.
  virtual void add_border(int n, const int* dofs, const double* dR_dlambda, const double* dc_du) = 0;
  /// c(u) += value.
  virtual void add_constraint_value(double value) = 0;

 protected:
  explicit AssemblySink(bool tangent) : tangent_(tangent) {}
  bool tangent_ = false;
};

/// Cells of a contribution's own, for its fields (a shell's triangles, a fiber's segments, contact faces).
struct ReportCells {
  enum class Type { line2, line3, triangle3, triangle6, quad4 };
  std::string stem;               ///< output file stem: <stem>.h5 + <stem>.xdmf ("shell", "fibers", "contact")
  Type type = Type::triangle3;
  std::vector<Vec3> points;       ///< reference positions, fixed through the run
  std::vector<int> connectivity;  ///< nodes per cell × cells, indices into points, in XDMF/VTK node order
};
/// One array on a ReportCells: components per cell (or per point) in cell (point) order.
struct ReportArray {
  std::string name, unit;
  int components = 1;  ///< 1, 3 or 9 (row-major tensor)
  bool per_cell = true;
  std::vector<double> values;
};
struct ReportField {
  ReportCells cells;
  std::vector<ReportArray> arrays;
};
/// What contributions report of a converged state beyond the solids' fields. The macro job appends the
/// probes to response.csv and writes each field as the time series <stem>.h5 + <stem>.xdmf; a
/// contribution gives the same probe names, stems and cells at every call (the columns and meshes are
/// fixed when the run starts).
struct ContributionReport {
  std::vector<std::pair<std::string, double>> probes;  ///< column "name [unit]" and its value
  std::vector<ReportField> fields;
};

class Contribution {
 public:
  /// What a contribution is, which fixes where the driver evaluates it: domains and interfaces first
  /// (internal forces: the reactions are taken from them), then constraints and loads (external forces).
  enum class Kind { domain, interface, constraint, load };
  virtual ~Contribution() = default;
  virtual Kind kind() const = 0;
  /// The scene's name of the part, for messages ("pressure", "dirichlet", ...).
  virtual std::string name() const = 0;
  /// Throws InputError when the contribution does not fit the mesh (node or dof out of range, ...).
  virtual void validate(const Mesh& mesh) const { (void)mesh; }
  /// The nodes whose dofs the contribution couples (its tangent's sparsity).
  virtual void declare_couplings(Couplings& couplings) const { (void)couplings; }
  /// Prescribed dofs: set(dof, value at t) for each (Dirichlet constraints).
  virtual void prescribe(double t, const std::function<void(int dof, double value)>& set) const {
    (void)t;
    (void)set;
  }
  /// Magnitudes of the loads it applies at time t (appended): the driver extrapolates the displacement
  /// from the last steps only where these change in proportion.
  virtual void load_levels(double t, std::vector<double>& levels) const {
    (void)t;
    (void)levels;
  }
  /// It holds some rigid-body motion by itself (a clamped shell edge's rotation, an elastic support):
  /// the driver then leaves a motion that the prescribed dofs leave free to the first factorization's
  /// singularity check instead of refusing the model.
  virtual bool holds_rigid_motion() const { return false; }
  /// Its residual counts as external force (the force scale's f_ext, never a reaction).
  virtual bool external_force() const { return kind() == Kind::load; }
  /// History values it keeps (e.g. per element and through-thickness point of a viscoelastic law): the
  /// driver allocates them, starts them with init_state and commits them after convergence only.
  virtual int state_size() const { return 0; }
  virtual void init_state(double* state) const { (void)state; }
  /// Its couplings follow the configuration (a contact between deformable surfaces: which master face
  /// each slave point sees). The driver then calls pair() at the start of every sub-step attempt and
  /// rebuilds the stiffness pattern (the CSC pattern and its symbolic factorization; on the petsc path
  /// the matrix takes the new entries at its next fill) whenever the couplings it declares change.
  virtual bool couplings_change() const { return false; }
  /// At the start of a sub-step attempt (a new step, or the retry after a cut-back), at the converged
  /// state: chooses the pairing the step keeps and declares its couplings (beyond declare_couplings').
  /// The pairing belongs to the contribution's history: `converged.state_new` (and state_old) point at
  /// the converged history, which it may rewrite in place; the step then reads it through state_old.
  /// Called on every rank alike; a deterministic function of the converged state, so that a retried
  /// step gets the same pairing.
  virtual void pair(const Mesh& mesh, const Iterate& converged, Couplings& couplings) const {
    (void)mesh;
    (void)converged;
    (void)couplings;
  }
  /// Adds its residual (and with sink.tangent() its consistent tangent) at the iterate. Evaluated on
  /// every rank alike (each rank's sink keeps what it owns of the matrix); a non-ok status cuts the step.
  virtual MaterialStatus assemble(const Mesh& mesh, const Iterate& it, AssemblySink& sink) const {
    (void)mesh;
    (void)it;
    (void)sink;
    return MaterialStatus::ok;
  }
  /// Appends its probes and fields at a converged state (see ContributionReport). Called on every rank.
  virtual void report(const Mesh& mesh, const Iterate& it, ContributionReport& out) const {
    (void)mesh;
    (void)it;
    (void)out;
  }

 protected:
  Contribution() = default;
  Contribution(const Contribution&) = default;
  Contribution& operator=(const Contribution&) = default;
};

using ContributionPtr = std::shared_ptr<const Contribution>;

}  // namespace softhom::fe
