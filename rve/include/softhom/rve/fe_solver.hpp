#pragma once
// Finite-element homogenization of a periodic cell of straight continuous fibers on a conforming
// section mesh (fe_mesh.hpp): the accuracy reference of the FFT engine (fft_solver.hpp).
//
// Two element families share one implementation (assembly, periodic dof map, condensation, Newton,
// macro control, outputs): 6-node triangles on a section mesh and 10-node tetrahedra on a 3D cell
// mesh (fe_mesh.hpp, mesh_cell). The 3D variant has the full fluctuation ũ(y1, y2, y3) (no
// restriction on ∂ũ/∂y3) and the P2/P0 pressure; everything below about the section applies to it
// with "area" read as "volume".
//
// Kinematics (as the FFT engine's section grids): the fluctuation ũ(y1, y2) has three components and
// does not depend on y3, so at every point F = F̄_grid + ∇ũ with (∇ũ)_i3 = 0 and F̄_grid = Rᵀ F̄_load R
// (R = grid_rotation(α)). ũ is periodic: paired boundary nodes share their degrees of freedom, and
// one node is fixed against translation.
//
// Elements: 6-node isoparametric triangles (curved fiber boundaries), 6-point (degree 4) quadrature.
// Phases with a volumetric energy W_V(J) stiff against their shear modulus (K ≥ mixed_pressure_ratio
// · G) use a mixed three-field treatment: the law's stress P = P_rest + W_V′(J) cof F is replaced by
// P_rest + p cof F, with element fields θ (dilatation) and p (pressure) satisfying, weakly per
// element, θ = J and p = W_V′(θ). Default pressure space: the Crouzeix–Raviart pair (P2 + cubic bubble
// displacement, discontinuous P1 θ and p; inf-sup stable, O(h²) in the energy norm, homogenized
// stress measured at O(h^3.3)); option P2/P0 (one θ, p per element, O(h)). Bubble, θ and p are
// element unknowns carried between Newton iterations and condensed out of the tangent, so there is
// no locking at K/G = 1.2e5 and the Newton steps see the linearized volumetric constraint (no K θ²
// pressure spikes from finite rotations). Other phases use the plain displacement form.
//
// Plate cell (a section mesh after make_plate(), fe_mesh.hpp): one layer of fibers with free faces,
// periodic along y1 only. Grid y2 is the plate normal (−e3 of the load frame, grid_rotation), and ũ is
// not paired across y2 = 0, L2, so ũ carries the whole column F_i2 (grid): the load-frame column F̄_i3
// is held at the identity's values and the control must leave it free with P̄_i3 = 0 (anything else is
// an InputError on "load"). The free faces make the section mean of P_i2 (grid) vanish (divergence
// theorem), which is P̄_i3 = 0 in the load frame: the law side of the same control is plane stress.
// Reported: P̄ = the section mean of P (no void: the in-plane membrane force per unit thickness L2),
// F̄ = the section mean of F (its column 3 is the mean through-thickness stretch and shear). Rigid
// modes: the anchor node fixes the translation; no rotation is left, since ũ(y1, y2) cannot rotate the
// controlled columns F̄_i1, F̄_i3 (grid).
//
// Unknowns of the global Newton system: the independent fluctuation dofs and the free components of
// F̄ (load frame) of the mixed control; the system is the Hessian of the potential and is solved with
// CHOLMOD (UMFPACK when the tangent is not positive definite). Prescribed increments enter through
// the tangent predictor, steps are cut back and retried on failure, as in the FFT engine.
#include <array>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "softhom/materials/loading.hpp"
#include "softhom/materials/material.hpp"
#include "softhom/rve/fe_mesh.hpp"
#include "softhom/rve/fft_solver.hpp"

namespace softhom::rve {

/// Pressure space of the mixed elements: P0 (one dilatation and pressure per element, P2/P0, O(h) in
/// the energy norm) or the Crouzeix–Raviart pair P2+bubble / discontinuous P1 (O(h²)); both are
/// inf-sup stable and condensed per element.
enum class FePressure { p0, p1_bubble };
const char* to_string(FePressure p);

struct FeSolverOptions {
  /// Newton: ‖force residual‖₂ / (stress scale · √area), the macro stress error and the element
  /// pressure mismatch, all relative to the stress scale of the FFT engine (max |P̄_ij| prescribed or
  /// targeted, floored at 1e-6 G_min).
  double tolerance = 1e-8;
  int max_newton_iterations = 30;
  int max_cutbacks = 12;
  bool mixed_pressure = true;
  double mixed_pressure_ratio = 100.0;
  FePressure pressure = FePressure::p1_bubble;
  bool use_umfpack = false;  ///< force the unsymmetric solver (default: CHOLMOD, UMFPACK fallback)
  /// Quadrature of the 3D Tet10 elements: 4 (the degree-2 rule) or 14 (a positive degree-5 rule).
  int tet_quadrature_points = 4;
  /// Wall-time budget of one output step's cut-backs [s] (StepControlOptions::max_step_seconds; 0: none).
  double max_step_seconds = 0.0;
};

/// Per-element fields of a converged step (quadrature-point means), tensors in the load frame;
/// displacement per node (3 per node, grid frame: total u = (F̄_grid − I) y + ũ).
struct FeFields {
  std::vector<double> F, P, sigma, von_mises, J;
  std::vector<int> phase;
  std::vector<double> displacement;
};

/// Refuses (InputError on "load") a control a plate cell cannot take: F13, F23, F33 (load frame) must
/// be free with P13 = P23 = P33 = 0 at all times (the faces are traction-free).
void check_plate_control(const MixedControl& control);

class FeRveSolver {
 public:
  /// `mesh` in the grid frame (y3 = fiber axis); materials in the global frame of `load_frame`.
  FeRveSolver(SectionMesh mesh, MaterialPtr matrix, MaterialPtr fiber, double fiber_angle_deg,
              const Mat3& load_frame, const FeSolverOptions& options = {});
  /// 3D variant on a periodic tetrahedral cell mesh (Tet10, P2/P0 mixed pressure only: the 3D
  /// fluctuation ũ(y1, y2, y3) is unrestricted).
  FeRveSolver(CellMesh mesh, MaterialPtr matrix, MaterialPtr fiber, double fiber_angle_deg,
              const Mat3& load_frame, const FeSolverOptions& options = {});
  ~FeRveSolver();
  FeRveSolver(const FeRveSolver&) = delete;
  FeRveSolver& operator=(const FeRveSolver&) = delete;

  RveRunResult run(const MixedControl& control,
                   const std::function<void(const RveStep&, const FeFields*)>& on_step = {},
                   const std::function<bool(double)>& want_fields = {});

  bool is_3d() const;
  const SectionMesh& mesh() const;   ///< section solver only (std::logic_error otherwise)
  const CellMesh& cell_mesh() const; ///< 3D solver only
  int num_elements() const;
  int num_equations() const;       ///< fluctuation + free macro unknowns of the last step
  double achieved_volume_fraction() const;
  std::size_t memory_bytes() const;
  /// Linear-solver statistics: factorizations and their total time [s], the nonzeros of the factor
  /// pattern's matrix, which solver was used last.
  int factorizations() const;
  double factorization_seconds() const;  ///< analysis + factorization + solve
  /// {symbolic analysis, numeric factorization, triangular solves} seconds.
  std::array<double, 3> linear_seconds() const;
  double assembly_seconds() const;
  long matrix_nonzeros() const;
  std::string linear_solver() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace softhom::rve
