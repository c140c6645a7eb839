#include "simulation_impl.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <iostream>
#include <sstream>
#include <tuple>
#include <type_traits>

#include <Eigen/Dense>

#include "softhom/materials/errors.hpp"

namespace softhom::fe {
using namespace detail;

Simulation::Impl::Impl(FeModel model, NewtonOptions options) : model_(std::move(model)), options_(options) {
  model_.validate();
  contributions_ = {&solids_};
  for (const Contribution* c : model_.assembly_order()) {
    contributions_.push_back(c);
    c->declare_couplings(couplings_);
    pairing_ = pairing_ || c->couplings_change();
  }
  build_dofs();
  build_partition();
  build_geometry();
  build_history();
  build_linear_solvers();
  if (pairing_ && linear_choice_.preconditioner == Preconditioner::bddc)
    throw InputError("solver.petsc_preconditioner", "bddc",
                     "BDDC's subdomains are fixed when the run starts and cannot follow a contact between deformable "
                     "surfaces: use field_split or lu");
  build_colouring();
  build_scatter();
  build_mixed();
  build_distributed_system();
  const Mesh& mesh = model_.mesh;
  const int ndof = mesh.num_dofs();
  u_.assign(ndof, 0.0);
  u_prev_step_ = u_;
  u_prev2_step_ = u_;
  if (model_.cavity)
    cavity_v0_ = cavity_volume(mesh.nodes, model_.cavity->faces, model_.cavity->mask, model_.cavity->tris);
  if (model_.cavity && !(cavity_v0_ > 0.0))
    throw InputError("cavity", format_number(cavity_v0_), "enclosed volume must be positive (check face orientation)");
}

void Simulation::Impl::build_dofs() {
  const Mesh& mesh = model_.mesh;
  const int ndof = mesh.num_dofs();
  std::vector<char> constrained(ndof, 0);
  for (const Contribution* c : contributions_) c->prescribe(0.0, [&](int dof, double) { constrained[dof] = 1; });
  dofs_ = DofMap::from_constrained(ndof, constrained);
  if (dofs_.num_free == 0) throw InputError("boundary", "", "every degree of freedom is prescribed");
  // A free rigid-body motion makes every tangent singular (the first factorization would fail, or a
  // nearly singular one would let the body drift until a material limit): refuse it here, by name.
  const std::vector<std::string> free_motions = free_rigid_motions(mesh, constrained, couplings_);
  const bool held_otherwise = std::any_of(contributions_.begin(), contributions_.end(),
                                          [](const Contribution* c) { return c->holds_rigid_motion(); });
  if (!free_motions.empty() && !held_otherwise) {
    std::string list;
    for (const auto& m : free_motions) list += (list.empty() ? "" : ", ") + m;
    throw InputError("boundary", "", "the body is not constrained against " + list +
                                         " (its stiffness is singular); prescribe displacements that hold it, e.g. a [[boundary]] with fix");
  }
  if (!petsc_distributed()) K_ = build_pattern(mesh, dofs_, couplings_);  // else the matrix is PETSc's alone
}

void Simulation::Impl::build_geometry() {
  const Mesh& mesh = model_.mesh;
  // Every element is checked (an inverted one is refused on every rank alike); only those this rank
  // evaluates are kept.
  geometry_slot_.assign(mesh.num_elements(), -1);
  geometry_.clear();
  tet_geometry_.clear();
  int bad = -1;
  for (int e = 0; e < mesh.num_elements(); ++e) {
    bool valid = false;
    if (mesh.is_tet(e)) {
      const Tet10Geometry g = tet10_geometry(element_coords<10>(mesh, e));
      valid = g.valid;
      if (owns(e)) {
        geometry_slot_[e] = int(tet_geometry_.size());
        tet_geometry_.push_back(g);
      }
    } else {
      const Hex8Geometry g = hex8_geometry(element_coords<8>(mesh, e));
      valid = g.valid;
      if (owns(e)) {
        geometry_slot_[e] = int(geometry_.size());
        geometry_.push_back(g);
      }
    }
    if (!valid && bad < 0) bad = e;
  }
  if (bad >= 0) throw InputError("mesh", "element " + std::to_string(bad), "non-positive Jacobian at a Gauss point");
}

const Hex8Geometry& Simulation::Impl::hex_geometry(int e, Hex8Geometry& scratch) const {
  if (geometry_slot_[e] >= 0) return geometry_[geometry_slot_[e]];
  scratch = hex8_geometry(element_coords<8>(model_.mesh, e));
  return scratch;
}

const Tet10Geometry& Simulation::Impl::tet_geometry(int e, Tet10Geometry& scratch) const {
  if (geometry_slot_[e] >= 0) return tet_geometry_[geometry_slot_[e]];
  scratch = tet10_geometry(element_coords<10>(model_.mesh, e));
  return scratch;
}

void Simulation::Impl::build_history() {
  const Mesh& mesh = model_.mesh;
  state_offset_.assign(mesh.num_elements(), -1);
  std::size_t total = 0;
  for (int e = 0; e < mesh.num_elements(); ++e) {
    const int ns = model_.element_material[e]->state_size();
    if (ns > 0 && owns(e)) {
      state_offset_[e] = int(total);
      total += gauss_points(mesh, e) * std::size_t(ns);
    }
  }
  state_old_.assign(total, 0.0);
  for (int e = 0; e < mesh.num_elements(); ++e)
    if (state_offset_[e] >= 0) {
      const auto& m = *model_.element_material[e];
      for (int q = 0; q < gauss_points(mesh, e); ++q) m.init_state(state_old_.data() + state_offset_[e] + q * m.state_size());
    }
  state_new_ = state_old_;
  // The contributions' history (elastic ones allocate nothing).
  contribution_state_offset_.assign(contributions_.size(), -1);
  std::size_t ctotal = 0;
  for (std::size_t k = 0; k < contributions_.size(); ++k)
    if (const int ns = contributions_[k]->state_size(); ns > 0) {
      contribution_state_offset_[k] = long(ctotal);
      ctotal += std::size_t(ns);
    }
  contribution_state_old_.assign(ctotal, 0.0);
  for (std::size_t k = 0; k < contributions_.size(); ++k)
    if (contribution_state_offset_[k] >= 0) contributions_[k]->init_state(contribution_state_old_.data() + contribution_state_offset_[k]);
  contribution_state_new_ = contribution_state_old_;
}

void Simulation::Impl::build_linear_solvers() {
  const Mesh& mesh = model_.mesh;
  LinearSystemFacts facts;
  facts.free_dofs = dofs_.num_free;
  facts.quadratic_tets_only = mesh.hexes.empty() && !mesh.tets.empty();
  facts.any_tets = !mesh.tets.empty();
  facts.cavity_control = model_.cavity.has_value();
  // Three-field elements (build_mixed): the F-bar formulation's laws with a volumetric modulus.
  facts.three_field = model_.formulation == Formulation::fbar && options_.mixed &&
                      std::any_of(model_.element_material.begin(), model_.element_material.end(),
                                  [](const auto& m) { return m->volumetric_modulus() > 0.0; });
  linear_choice_ = choose_linear_solver(options_, facts);
  // A preconditioner chosen for the petsc solver while another solves (e.g. auto's CHOLMOD below its
  // PETSc sizes) is said once, not silently dropped.
  const PetscPreconditioner asked = options_.petsc_preconditioner;
  if (linear_choice_.route != LinearRoute::petsc && asked != PetscPreconditioner::automatic &&
      asked != PetscPreconditioner::field_split)
    note_once("petsc preconditioner", std::string("[solver] petsc_preconditioner applies to linear_solver = \"petsc\"; this run solves with ") +
                                          to_string(linear_choice_.route));
  // The petsc solver's system is laid out by the distributed assembly (build_distributed_system).
  solver_ = make_macro_linear_solver(linear_choice_, mesh, dofs_);
  direct_ = dynamic_cast<SparseDirectSolver*>(solver_.get());
  petsc_ = dynamic_cast<PetscSolver*>(solver_.get());
}

void Simulation::Impl::build_colouring() {
  const Mesh& mesh = model_.mesh;
  if (distributed_ && mpi_ranks_ > 1) {  // one thread per rank fills PETSc's matrix: the owned elements in one list
    colors_ = {owned_elements_};
    return;
  }
  // Greedy element colouring: elements of one colour share no node, so assembly needs no atomics.
  {
    std::vector<std::vector<int>> node_elems(mesh.num_nodes());
    for (int e = 0; e < mesh.num_elements(); ++e)
      for (int a = 0; a < mesh.element_size(e); ++a) node_elems[mesh.element_nodes(e)[a]].push_back(e);
    std::vector<int> color(mesh.num_elements(), -1), mark;
    for (int e = 0; e < mesh.num_elements(); ++e) {
      for (int a = 0; a < mesh.element_size(e); ++a)
        for (int o : node_elems[mesh.element_nodes(e)[a]])
          if (color[o] >= 0) {
            if (int(mark.size()) <= color[o]) mark.resize(color[o] + 1, -1);
            mark[color[o]] = e;
          }
      int c = 0;
      while (c < int(mark.size()) && mark[c] == e) ++c;
      color[e] = c;
      if (int(colors_.size()) <= c) colors_.resize(c + 1);
      colors_[c].push_back(e);
    }
  }
}

void Simulation::Impl::build_scatter() {
  if (distributed_) return;  // no K_
  const Mesh& mesh = model_.mesh;
  // Scatter positions: build_pattern stores the rows of the three columns of node b identically
  // (node-major, components ascending), so one offset per node pair locates a 3x3 block.
  free_rank_.resize(mesh.num_nodes());
  for (int n = 0; n < mesh.num_nodes(); ++n) {
    signed char r = 0;
    for (int i = 0; i < 3; ++i) free_rank_[n][i] = dofs_.eq[3 * n + i] >= 0 ? r++ : -1;
  }
  // Per element type: block[n * a + b] for the n nodes of the element.
  auto block_offsets = [&](const int* nodes, int n, long* block) {
    for (int b = 0; b < n; ++b) {
      int col = -1;  // any free column of node b
      for (int j = 0; j < 3 && col < 0; ++j) col = dofs_.eq[3 * nodes[b] + j];
      for (int a = 0; a < n; ++a) {
        long pos = -1;
        if (col >= 0)
          for (int i = 0; i < 3 && pos < 0; ++i) {
            const int row = dofs_.eq[3 * nodes[a] + i];
            if (row >= 0) pos = K_.find(row, col) - free_rank_[nodes[a]][i] - K_.colptr[col];
          }
        block[n * a + b] = pos;  // offset within the column
      }
    }
  };
  block_.resize(mesh.num_hexes());
  for (int e = 0; e < mesh.num_hexes(); ++e) block_offsets(mesh.hexes[e].data(), 8, block_[e].data());
  tet_block_.resize(mesh.tets.size());
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) block_offsets(mesh.tets[t].data(), 10, tet_block_[t].data());
}

void Simulation::Impl::build_mixed() {
  const Mesh& mesh = model_.mesh;
  if (model_.formulation == Formulation::fbar && options_.mixed) {
    mix_bulk_.assign(mesh.num_elements(), 0.0);
    bool any = false;
    for (int e = 0; e < mesh.num_elements(); ++e) {
      mix_bulk_[e] = model_.element_material[e]->volumetric_modulus();
      any |= mix_bulk_[e] > 0.0;
    }
    if (!any) {
      mix_bulk_.clear();
    } else {
      mix_theta_conv_.assign(mesh.num_elements(), 1.0);
      mix_p_conv_.assign(mesh.num_elements(), 0.0);
      mix_theta_ = mix_theta_conv_;
      mix_p_ = mix_p_conv_;
      mix_theta_u_ = mix_theta_conv_;
      // ∂θ/∂u of the elements this rank evaluates, at their geometry slots (built above).
      mix_d_.assign(geometry_.size(), Vec24::Zero());
      mix_d_tet_.assign(tet_geometry_.size(), Vec30::Zero());
      // Element pressure unknowns of the uncondensed Krylov space (linear_solve). The petsc path needs
      // the element list alone (its matrix holds the element pressures; no equation lists).
      sad_off_.push_back(0);
      for (int e = 0; e < mesh.num_elements(); ++e) {
        if (mix_bulk_[e] <= 0.0) continue;
        sad_elem_.push_back(e);
        if (distributed_) continue;
        const int* en = mesh.element_nodes(e);
        for (int a = 0; a < mesh.element_size(e); ++a)
          for (int i = 0; i < 3; ++i) sad_eq_.push_back(dofs_.eq[3 * en[a] + i]);
        sad_off_.push_back(int(sad_eq_.size()));
      }
      if (distributed_) {
        sad_off_.clear();
        return;
      }
      // The element colouring carried over to them: race-free parallel scatters of Σ_e d_e a_e.
      std::vector<int> index(mesh.num_elements(), -1);
      for (std::size_t k = 0; k < sad_elem_.size(); ++k) index[sad_elem_[k]] = int(k);
      for (const auto& color : colors_) {
        sad_colors_.emplace_back();
        for (int e : color)
          if (index[e] >= 0) sad_colors_.back().push_back(index[e]);
      }
    }
  }

}



MaterialStatus Simulation::Impl::element_force(int e, const Tet10Coords& u, Vec30& r, Mat30* K) const {
  const int off = state_offset_[e];
  std::vector<double> scratch(off >= 0 ? 4 * model_.element_material[e]->state_size() : 0);
  Tet10Geometry scratch_geometry;
  return tet10_internal_force(tet_geometry(e, scratch_geometry), u, *model_.element_material[e],
                              off >= 0 ? state_old_.data() + off : nullptr, off >= 0 ? scratch.data() : nullptr,
                              last_dt_, model_.formulation, r, K);
}

MaterialStatus Simulation::Impl::element_force(int e, const Mat83& u, Vec24& r, Mat24* K) const {
  const int off = state_offset_[e];
  std::vector<double> scratch(off >= 0 ? 8 * model_.element_material[e]->state_size() : 0);
  Hex8Geometry scratch_geometry;
  return hex8_internal_force(hex_geometry(e, scratch_geometry), u, *model_.element_material[e], off >= 0 ? state_old_.data() + off : nullptr,
                             off >= 0 ? scratch.data() : nullptr, last_dt_, model_.formulation, r, K);
}

std::vector<Vec3> Simulation::Impl::current_positions() const {
  std::vector<Vec3> x(model_.mesh.nodes);
  for (std::size_t n = 0; n < x.size(); ++n) x[n] += Vec3(u_[3 * n], u_[3 * n + 1], u_[3 * n + 2]);
  return x;
}

void Simulation::Impl::reset_mixed_iterate() {
  if (mix_bulk_.empty()) return;
  mix_theta_ = mix_theta_conv_;
  mix_p_ = mix_p_conv_;
  const int ne = model_.mesh.num_elements();
  mix_theta_base_.assign(ne, 1.0);
  mix_p_base_.assign(ne, 0.0);
  mix_dtheta_.assign(ne, 0.0);
  mix_dp_.assign(ne, 0.0);
}

std::vector<double> Simulation::Impl::prescribed_increment(double t_new) const {
  // Predictor: linearize about the converged state with the new prescribed values,
  // K_ff Δu_f = −R_f − K_fc Δu_c, which keeps boundary layers from being crushed by a jump.
  std::vector<double> du_c(model_.mesh.num_dofs(), 0.0);
  bool any_jump = false;
  for (const Contribution* c : contributions_)
    c->prescribe(t_new, [&](int dof, double target) {
      du_c[dof] = target - u_[dof];
      any_jump |= target != u_[dof];
    });
  if (!any_jump) du_c.clear();
  return du_c;
}

void Simulation::Impl::extrapolate(double t_new, std::vector<double>& u) {
  // Secant predictor: start from u_n + ρ (u_n − u_{n−1}), ρ the ratio of this step's load increment to
  // the last one's (the load vector of pressures and nodal forces, so a ramp gives ρ = dt/dt_n and a hold
  // gives no extrapolation). Newton then starts O(Δ²) from the solution instead of O(Δ): the F-bar
  // residual after the first correction (dominated by the O(K ε²) volume mismatch of the step) drops,
  // and the tube steps need one Newton iteration fewer. Only without prescribed-displacement jumps (the
  // Dirichlet predictor covers those) and cavity control; attempt_substep retries a failed step without it.
  extrapolated_ = false;
  if (!options_.extrapolate || !extrapolate_step_ || model_.cavity || !(time_ > prev_step_time_)) return;
  const int ndof = model_.mesh.num_dofs();
  std::vector<double> l_new, l_now, l_old;
  auto loads = [&](double t, std::vector<double>& out) {
    out.clear();
    for (const Contribution* c : contributions_) c->load_levels(t, out);
  };
  loads(t_new, l_new);
  loads(time_, l_now);
  loads(prev_step_time_, l_old);
  double num = 0.0, den = 0.0, nn = 0.0;
  for (std::size_t k = 0; k < l_new.size(); ++k) {
    num += (l_new[k] - l_now[k]) * (l_now[k] - l_old[k]);
    den += (l_now[k] - l_old[k]) * (l_now[k] - l_old[k]);
    nn += (l_new[k] - l_now[k]) * (l_new[k] - l_now[k]);
  }
  // Proportional load increments of at most the last one's size: a secant stretched over a longer step
  // than it was measured on amplifies its curvature error by ρ², and after a cut-back the sub-steps grow
  // exactly where the response turns (through Gent's locking every such start overshot the limit).
  if (!(den > 0.0 && num > 0.999 * std::sqrt(nn * den) && num <= 1.0001 * den)) return;
  extrapolated_ = true;
  const double rho = num / den;
  // Quadratic extrapolation (Lagrange through the last three converged states, in the load parameter
  // s along the last increment, s = 0 at u_{n−1} and 1 at u_n): the predictor error drops from O(Δ²)
  // to O(Δ³). At K/G ~ 1e5 the predictor's volume mismatch θ_e(u) − θ (O(Δ²) for the secant) is what
  // the first Newton correction spends itself on, and the force error left after it sets the number
  // of further iterations.
  double a = 0.0;
  if (options_.extrapolate_order >= 2 && stored_steps_ >= 2 && prev2_step_time_ < prev_step_time_) {
    std::vector<double> l_old2;
    loads(prev2_step_time_, l_old2);
    double num2 = 0.0, nn2 = 0.0;
    for (std::size_t k = 0; k < l_new.size(); ++k) {
      num2 += (l_old[k] - l_old2[k]) * (l_now[k] - l_old[k]);
      nn2 += (l_old[k] - l_old2[k]) * (l_old[k] - l_old2[k]);
    }
    if (nn2 > 0.0 && num2 > 0.999 * std::sqrt(nn2 * den)) a = -num2 / den;  // s of u_{n−2}
    if (a < -4.0 || a > -0.25) a = 0.0;  // very uneven steps: secant
  }
  if (a < 0.0) {
    const double tau = 1.0 + rho;
    // Lagrange weights of u_{n−1} (s = 0) and u_{n−2} (s = a) at s = τ; u_n's is 1 minus both.
    const double c1 = (tau - a) * (tau - 1.0) / a, c2 = tau * (tau - 1.0) / (a * (a - 1.0));
    for (int d = 0; d < ndof; ++d)
      if (dofs_.eq[d] >= 0) u[d] += c1 * (u_prev_step_[d] - u_[d]) + c2 * (u_prev2_step_[d] - u_[d]);
  } else {
    for (int d = 0; d < ndof; ++d)
      if (dofs_.eq[d] >= 0) u[d] += rho * (u_[d] - u_prev_step_[d]);
  }
}

double Simulation::Impl::volume_residual(const Assembly& a, double v_target) const {
  return model_.cavity ? std::abs(a.volume - v_target) / cavity_v0_ : 0.0;
}

bool Simulation::Impl::converged_at(double rc, const Assembly& a, int iter, const NewtonIterate& n,
                                    double v_target) const {
  // Newton's convergence test on the residual norm rc of assembly `a` at iteration `iter`: below
  // tolerance, or stagnating within 100× of it (round-off floor of a nearly incompressible tangent,
  // K/G ~ 1e5, where ‖R‖/scale cannot drop much below 1e-8), or the last correction was at round-off
  // level of the displacement (the residual then only measures the noise of K·(J − 1) in double
  // precision); and the cavity volume on target.
  const double scale = force_scale(a);
  const bool floor = iter > 1 && ((rc <= 100 * options_.tolerance * scale && rc >= 0.5 * n.r_prev) ||
                                  (rc <= 1e-4 * scale && n.last_du <= 1e-10 * n.u_max));
  return std::isfinite(rc) && (rc <= options_.tolerance * scale || floor) && volume_residual(a, v_target) <= 1e-9;
}

MaterialStatus Simulation::Impl::evaluate_iterate(int it, bool predictor, double t_new, double dt, double v_target,
                                                  const NewtonIterate& n, Assembly& as) {
  const int ndof = model_.mesh.num_dofs();
  const bool mixed = !mix_bulk_.empty();
  if (predictor) as.dirichlet_rhs = n.du_c;
  else as.dirichlet_rhs.clear();
  // A step started at the converged state u_n linearizes there with the load stiffness of the converged
  // pressure p_n: K(u_n, p_n) is the tangent of an equilibrium and so positive definite on a stable path,
  // while the new pressure on the old stress field (K(u_n, p_{n+1})) is indefinite for a slender soft
  // tube (bending modes of stiffness ~ G (t/L)² against p: the capped ecoflex tube at p/G = 0.03), which
  // forced UMFPACK LU for the whole first step. From a secant start the new pressure belongs there.
  stiffness_time_ = (it == 0 && !extrapolated_) ? time_ : -1.0;
  // Late iterations (it ≥ 2, where most steps converge) first evaluate the residual alone: the element
  // tangent and its scatter are ~85 % of an assembly (hex8 kernel 12 µs with the tangent, 1.6 µs
  // without), and the converging iteration needs no tangent. When the residual does not pass, the
  // tangent assembly follows at the same point (the residual pass is then ~15 % extra).
  bool converged_early = false;
  if (options_.residual_first && it >= 2 && !predictor) {
    if (assemble(t_new, dt, false, n.u, n.p, as) == MaterialStatus::ok) {
      double r2 = 0.0;
      for (int d = 0; d < ndof; ++d)
        if (dofs_.eq[d] >= 0) {
          const double v = mixed ? as.R_true[d] : as.R[d];
          r2 += v * v;
        }
      converged_early = converged_at(std::sqrt(r2), as, it, n, v_target);
    }
  }
  const MaterialStatus st = converged_early ? MaterialStatus::ok : assemble(t_new, dt, true, n.u, n.p, as);
  stiffness_time_ = -1.0;
  return st;
}

MaterialStatus Simulation::Impl::line_search(double t_new, double dt, MaterialStatus st, NewtonIterate& n,
                                             Assembly& as) {
  // Line search on the assembly of the full step, with its tangent (most steps accept α = 1, so no extra
  // residual evaluation): backtrack when the trial is inadmissible (material failure) or, without a
  // cavity constraint, when s(α) = Δu·R(u + αΔu) is not reduced enough (energy criterion).
  const int ndof = model_.mesh.num_dofs();
  const bool mixed = !mix_bulk_.empty();
  // Backtracked trials evaluate the residual alone; the accepted one then gets its tangent. Through the
  // Gent locking of the fine aneurysm a third of the Newton iterations backtrack (77 trials in 99
  // iterations), each a tangent assembly before (~85 % of its cost is the tangent).
  auto with_tangent = [&](MaterialStatus status) {
    if (n.backtracks == 0 || status != MaterialStatus::ok) return status;
    return assemble(t_new, dt, true, n.u, n.p, as);
  };
  for (;;) {
    bool ok = st == MaterialStatus::ok;
    double s = 0.0;
    // Three-field iteration: backtrack only on inadmissible trials. Its steps are full Newton steps
    // of the saddle-point system; an energy or residual criterion on u alone cuts good steps (one
    // to two extra iterations per load step on the capped tube).
    if (ok && !model_.cavity && n.s0 < 0.0 && !mixed) {
      for (int d = 0; d < ndof; ++d)
        if (dofs_.eq[d] >= 0) s += n.x1[dofs_.eq[d]] * as.R[d];
      ok = std::abs(s) <= 0.9 * std::abs(n.s0);
    }
    if (ok || n.backtracks >= 6 || n.alpha < 0.05) return with_tangent(st);
    ++n.backtracks;
    ++stats_.line_search_backtracks;
    double next = 0.5 * n.alpha;
    if (st == MaterialStatus::ok && s > 0.0) next = std::clamp(n.alpha * n.s0 / (n.s0 - s), 0.1 * n.alpha, 0.5 * n.alpha);
    n.alpha = next;
    for (int d = 0; d < ndof; ++d) {
      const int k = dofs_.eq[d];
      if (k >= 0) n.u[d] = n.u_base[d] + n.alpha * n.x1[k];
    }
    n.p = n.p_base + n.alpha * n.dp;
    if (mixed) mixed_update({}, n.alpha);
    st = assemble(t_new, dt, false, n.u, n.p, as);
  }
}

void Simulation::Impl::commit(NewtonIterate& n, Assembly& as, int iterations) {
  if (options_.extrapolate_order >= 2) {
    u_prev2_step_.swap(u_prev_step_);
    prev2_step_time_ = prev_step_time_;
  }
  u_prev_step_.swap(u_);
  prev_step_time_ = time_;
  stored_steps_ = std::min(stored_steps_ + 1, 2);
  u_ = std::move(n.u);
  cavity_pressure_ = n.p;
  std::swap(state_old_, state_new_);
  std::swap(contribution_state_old_, contribution_state_new_);
  reduce_cauchy(as.cauchy);
  cauchy_.swap(as.cauchy);
  fint_.swap(as.fint);
  if (!mix_bulk_.empty()) {
    // Restart the next step from the consistent pair θ = θ_e(u), p = U′(θ).
    for (std::size_t e = 0; e < mix_bulk_.size(); ++e)
      if (mix_bulk_[e] > 0.0) {
        mix_theta_conv_[e] = mix_theta_u_[e];
        mix_p_conv_[e] = volumetric_dU(mix_bulk_[e], mix_theta_u_[e]);
      }
  }
  stats_.newton_iterations += iterations;
}

bool Simulation::Impl::newton_correction(int it, bool predictor, double rc, double rc_last, double rn, double scale,
                                         double v_target, const Assembly& as, NewtonIterate& n, std::string& why) {
  const int ndof = model_.mesh.num_dofs();
  const int nf = dofs_.num_free;
  // Inexact Newton: the linear tolerance follows the residual (superlinear convergence), but is never
  // tighter than the next iterate needs: r_{k+1} ≈ η r_k + O(r_k²), so η = 0.1 tol·scale / r_k already
  // puts the next residual a decade below the tolerance (Kelley's safeguard). Without it the last
  // iteration of a step asked 1e-10 of a lagged-factor GMRES and paid a refactorization for it.
  const double eta_fast = std::clamp(1e-2 * rc / scale, 1e-10, 1e-4);
  // (Not under cavity control: its pressure increment comes from the same solves, and the volume
  // tolerance 1e-9 needs them accurate.)
  const double eta = model_.cavity ? eta_fast
                                   : std::max(eta_fast, std::min(0.1, options_.forcing_safeguard * options_.tolerance * scale / std::max(rn, rc)));
  // A lagged factor that failed at the first iteration of the last step (the tangent moved too far
  // over a load step) is not tried again there: its wasted GMRES iterations (5 to 30 at 1e5 dofs)
  // cost up to a factorization. Every fourth step it is tried again, in case the steps got smaller.
  if (it == 0 && refactor_first_ && (stats_.steps % 4) != 0 && factor_valid_ && factor_version_ != k_version_)
    factor_stale_ = true;
  // From a (quadratic) extrapolated start the tangent of iteration 0 is within the predictor error of the
  // step's solution: its fresh factor solves iteration 0 directly and preconditions the remaining two or
  // three corrections in a few GMRES iterations each, while the previous step's factor needs 10–30
  // there and fails at iteration 1 (κ/G ~ 1e5: the tangent moves by κ × the strain of a load step).
  if (it == 0 && extrapolated_ && options_.refactor_each_step && factor_valid_ && factor_version_ != k_version_)
    factor_stale_ = true;
  // Nor while Newton is far from its quadratic phase (the residual did not halve: the tangent still
  // moves a lot, e.g. the first load step of the tube, whose lagged GMRES ran 15 iterations per solve
  // before refactorizing anyway).
  if (it > 0 && rc > 0.5 * rc_last && factor_valid_ && factor_version_ != k_version_) factor_stale_ = true;
  // (Counted on the factorization holding the factor, Cholesky's or LU's, as the lagged-factor rules
  // have always counted them.)
  auto factorizations = [&] { return direct_ ? direct_->current_factorizations() : solver_->times().factorizations; };
  const int factorizations_before = factorizations();
  const bool lagged_before = factor_valid_ && !factor_stale_ && factor_version_ != k_version_;
  if (!linear_solve(n.rhs, n.x1, eta, why, it == 0 && extrapolated_)) return false;
  if (it == 0 && last_factor_flops_ >= options_.lag_flops) {
    if (lagged_before && factorizations() > factorizations_before) refactor_first_ = true;
    else if (lagged_before) refactor_first_ = false;
  }
  n.dp = 0.0;
  if (model_.cavity) {
    for (int d = 0; d < ndof; ++d)
      if (dofs_.eq[d] >= 0) n.afree[dofs_.eq[d]] = as.a[d];
    if (!linear_solve(n.afree, n.x2, eta, why)) return false;
    // Bordered system: K Δu + a Δp = −R, g·Δu = V̄ − V (− g_c·Δu_c of a prescribed jump), with g = ∂V/∂u
    // the exact gradient of the volume formula. On faces that close the cavity (up to fixed symmetry
    // planes) g = −a and the system is symmetric; an open end that moves (an uncapped tube's free end,
    // closed by the moving plane z = z_end through the mask) makes g ≠ −a, and using −a there left
    // Newton linear (tests/macro/test_cavity_newton.cpp: 54 iterations for 5 steps of the uncapped
    // tube, 30 with g).
    double g1 = 0.0, g2 = 0.0, jump = 0.0;
    for (int d = 0; d < ndof; ++d) {
      const int k = dofs_.eq[d];
      if (k >= 0) {
        g1 += as.g[d] * n.x1[k];
        g2 += as.g[d] * n.x2[k];
      } else if (predictor) {
        jump += as.g[d] * n.du_c[d];
      }
    }
    if (g2 == 0.0) {
      why = "cavity constraint is singular";
      return false;
    }
    n.dp = (g1 - (v_target - as.volume - jump)) / g2;
    for (int k = 0; k < nf; ++k) n.x1[k] -= n.dp * n.x2[k];
  }
  return true;
}

void Simulation::Impl::apply_correction(bool predictor, const Assembly& as, NewtonIterate& n) {
  const int ndof = model_.mesh.num_dofs();
  const int nf = dofs_.num_free;
  const bool mixed = !mix_bulk_.empty();
  n.last_du = 0.0;
  for (int k = 0; k < nf; ++k) n.last_du = std::max(n.last_du, std::abs(n.x1[k]));
  n.s0 = 0.0;
  if (mixed) {
    for (int d = 0; d < ndof; ++d)
      if (dofs_.eq[d] >= 0) n.s0 += n.x1[dofs_.eq[d]] * as.R_u[d];
  } else {
    for (int k = 0; k < nf; ++k) n.s0 -= n.x1[k] * n.rhs[k];  // Δu · R(u)
  }
  n.u_base = n.u;
  n.p_base = n.p;
  n.alpha = 1.0;
  n.backtracks = 0;
  if (mixed) n.du_full.assign(ndof, 0.0);
  for (int d = 0; d < ndof; ++d) {
    const int k = dofs_.eq[d];
    if (k >= 0) {
      n.u[d] += n.x1[k];
      if (mixed) n.du_full[d] = n.x1[k];
    } else if (predictor) {
      n.u[d] += n.du_c[d];
      if (mixed) n.du_full[d] = n.du_c[d];
    }
  }
  if (mixed) mixed_update(n.du_full, 1.0);
  n.u_max = 0.0;
  for (double v : n.u) n.u_max = std::max(n.u_max, std::abs(v));
  if (predictor) {
    // The prescribed jump is never backtracked: α scales only the free part of the predictor.
    n.u_base = n.u;
    for (int d = 0; d < ndof; ++d)
      if (dofs_.eq[d] >= 0) n.u_base[d] -= n.x1[dofs_.eq[d]];
    n.s0 = 0.0;
  }
  n.p += n.dp;
}

StepAttempt Simulation::Impl::try_step(double t_new, double dt) {
  const int ndof = model_.mesh.num_dofs();
  const int nf = dofs_.num_free;
  const bool mixed = !mix_bulk_.empty();
  const double v_target = model_.cavity ? model_.cavity->volume_ratio(t_new) * cavity_v0_ : 0.0;
  if (direct_) direct_->begin_step();  // Cholesky again after a step that needed LU
  reset_mixed_iterate();
  NewtonIterate n;
  n.u = u_;
  n.p = cavity_pressure_;
  n.du_c = prescribed_increment(t_new);
  extrapolated_ = false;
  if (n.du_c.empty()) extrapolate(t_new, n.u);
  n.rhs.assign(nf, 0.0);
  n.x1.assign(nf, 0.0);
  n.x2.assign(nf, 0.0);
  n.afree.assign(nf, 0.0);
  n.u_base = n.u;
  n.p_base = n.p;
  Assembly as;
  int it = 0;
  auto fail = [&](const std::string& msg) {
    attempt_counts_.newton_iterations += it;
    return StepAttempt{false, msg, singular_system_};
  };
  for (;; ++it) {
    // A stop request ends the step between iterations: the run keeps its converged steps.
    if (it > 0 && stop_requested()) return fail("stopped by a signal");
    const bool predictor = it == 0 && !n.du_c.empty();
    MaterialStatus st = evaluate_iterate(it, predictor, t_new, dt, v_target, n, as);
    if (it > 0 && options_.line_search) st = line_search(t_new, dt, st, n, as);
    if (st != MaterialStatus::ok)  // an element's material, or a contribution (a contact's penetration)
      return fail(as.failed_element >= 0 ? std::string("material call failed (") + to_string(st) + ") in element " +
                                               std::to_string(as.failed_element)
                                         : std::string("iterate refused (") + to_string(st) + ")");
    double rn = 0.0, rn_true = 0.0;
    for (int d = 0; d < ndof; ++d)
      if (dofs_.eq[d] >= 0) {
        const double v = as.R[d] + (predictor ? as.dirichlet_rhs[d] : 0.0);
        n.rhs[dofs_.eq[d]] = -v;
        rn += v * v;
        if (mixed) rn_true += as.R_true[d] * as.R_true[d];
      }
    rn = std::sqrt(rn);
    // Convergence is judged on the F-bar residual itself, so the converged state is the F-bar
    // solution whatever the iteration (the condensed residual differs by O(K (θ_e − θ)²)).
    const double rc = mixed ? std::sqrt(rn_true) : rn;
    const double scale = force_scale(as);
    if (!std::isfinite(rn) || !std::isfinite(rc)) return fail("non-finite residual");
    if (options_.verbose)
      std::cerr << "    it " << it << " |R| = " << rc << (mixed ? " (condensed " + format_number(rn) + ")" : "")
                << " scale " << scale
                << (model_.cavity ? " |dV|/V0 = " + format_number(volume_residual(as, v_target)) : "")
                << (n.alpha < 1 ? " alpha " + format_number(n.alpha) : "") << "\n";
    const bool converged = !predictor && it > 0 && converged_at(rc, as, it, n, v_target);
    const double rc_last = n.r_prev;
    n.r_prev = rc;
    if (converged) {
      commit(n, as, it);
      attempt_counts_.newton_iterations += it;
      return StepAttempt{true, {}};
    }
    // Divergence: the residual grows far above its value after the first correction.
    if (it == 1) n.r0 = rc;
    if (it >= 2 && rc > 1e4 * std::max(n.r0, options_.tolerance * scale)) return fail("Newton diverged");
    if (it >= options_.max_iterations)
      return fail("no convergence in " + std::to_string(options_.max_iterations) +
                  " iterations (|R|/scale = " + format_number(rc / scale) + ")");
    std::string why;
    if (!newton_correction(it, predictor, rc, rc_last, rn, scale, v_target, as, n, why)) return fail(why);
    apply_correction(predictor, as, n);
  }
}

void Simulation::Impl::note_once(const std::string& key, const std::string& message) {
  if (options_.verbose) std::cerr << message << "\n";
  if (std::find(noted_.begin(), noted_.end(), key) != noted_.end()) return;
  noted_.push_back(key);
  stats_.log.push_back(message);
}

StepAttempt Simulation::Impl::attempt_substep(double t_new, double dt) {
  attempt_counts_ = StepCounts{};
  const SolverTimes linear_before = linear_times();
  const int krylov_before = stats_.krylov_iterations;
  // After k sub-steps in a row whose secant start failed, the next 2^k − 1 (at most 7) start from the
  // converged state: where increments shrink from step to step (a stiffening response, Gent's locking)
  // every extrapolation overshoots, and each failed one cost an iteration and a factorization (the
  // fine aneurysm: 99 → 94 Newton iterations, 70 → 55 factorizations with the Cholesky back-off).
  extrapolate_step_ = extrapolation_backoff_.take_chance();
  update_pairing();  // from the converged state: the same pairing for a retry after a cut-back
  StepAttempt a = try_step(t_new, dt);
  if (extrapolated_ && (a.ok || a.fatal)) extrapolation_backoff_.succeeded();
  if (extrapolated_ && !a.ok && !a.fatal) extrapolation_backoff_.failed();
  // A failed attempt's last factor is of an iterate off the path (an overshoot into a material limit):
  // the retry, or the cut-back's smaller step, starts with a fresh one (on the fine aneurysm a lagged
  // factor wasted five GMRES iterations on every cut-back before it was refreshed anyway).
  if (!a.ok) factor_stale_ = true;
  if (!a.ok && !a.fatal && extrapolated_ && !stop_requested()) {
    // The secant start may overshoot where the response stiffens or softens abruptly: retry the same
    // step from the converged state before cutting it back (an expected event: noted once).
    note_once("secant retry", "t = " + format_number(time_) + " + " + format_number(dt) + ": " + a.why +
                                  " from the secant predictor; retried from the converged state (noted once)");
    extrapolate_step_ = false;
    a = try_step(t_new, dt);
    if (!a.ok) factor_stale_ = true;
  }
  const SolverTimes linear_after = linear_times();
  attempt_counts_.factorizations = linear_after.factorizations - linear_before.factorizations;
  attempt_counts_.solves = linear_after.solves - linear_before.solves;
  attempt_counts_.krylov_iterations = stats_.krylov_iterations - krylov_before;
  return a;
}

/// The kind of a failed sub-step, for logging each kind of cut-back once: the reason up to its first
/// number or parenthesis ("material call failed", "Newton diverged", "no convergence in").
static std::string failure_kind(const std::string& why) {
  const std::size_t cut = why.find_first_of("0123456789(");
  return why.substr(0, cut);
}

AdvanceResult Simulation::Impl::advance_to(double t_end) {
  AdvanceResult result;
  if (!(t_end > time_)) return result;
  StepControlOptions control;
  control.max_cutbacks = options_.max_cutbacks;
  control.max_step_seconds = options_.max_step_seconds;
  // A converged sub-step after a cut-back doubles at once: the cut-back was needed where the response
  // turned (Gent's locking), and the sub-steps after it converge as fast at twice their size (the fine
  // aneurysm: 28 instead of 32 Newton iterations to the first output, 74 instead of 94 in all).
  control.successes_to_grow = 1;
  // initial_substeps splits the interval into equal parts, each reached by the shared sub-step loop.
  const int parts = std::max(1, options_.initial_substeps);
  const double t0 = time_;
  // Start at the whole part unless the last interval needed cut-backs (then resume where it was).
  double first_dt = recent_cutback_ ? next_dt_ : 0.0;
  bool cut_back = false;
  auto attempt = [&](double t_new, double dt) { return attempt_substep(t_new, dt); };
  auto accept = [&](double t_new, double dt, const StepAttempt&) {
    time_ = t_new;
    last_dt_ = dt;
    ++stats_.steps;
    petsc_lag_failures_ = 0;  // the petsc path tries a lagged preconditioner again in the next step
    last_step_ = attempt_counts_;
    result.counts += attempt_counts_;
  };
  auto reject = [&](double t_from, double, double dt_failed, double dt_next, const StepAttempt& a) {
    // try_step left u_, history and pressure at the last converged state.
    cut_back = true;
    ++stats_.cutbacks;
    attempt_counts_.cutbacks = 1;
    result.counts += attempt_counts_;
    if (dt_next <= 0.0) return;  // the interval gives up: its result says why
    // A cut-back that the smaller step then passes is an expected event: each kind is logged once.
    note_once("cut-back " + failure_kind(a.why), "cut-back at t = " + format_number(t_from) + " + " +
                                                     format_number(dt_failed) + ": " + a.why +
                                                     " (the step was halved; further cut-backs of this kind are counted, not listed)");
  };
  for (int k = 1; k <= parts; ++k) {
    const double t1 = k == parts ? t_end : t0 + (t_end - t0) * double(k) / parts;
    const IntervalOutcome o = advance_interval(time_, t1, first_dt, control, attempt, accept, reject);
    result.substeps += o.substeps;
    first_dt = o.cutbacks > 0 || first_dt > 0.0 ? o.next_dt : 0.0;
    if (!o.reached()) {
      result.status = o.status;
      result.message = describe_interval_failure(o, t1, options_.max_cutbacks, options_.max_step_seconds,
                                                 [](double v) { return format_number(v); });
      recent_cutback_ = true;
      next_dt_ = o.next_dt;
      return result;
    }
  }
  time_ = t_end;
  recent_cutback_ = cut_back || first_dt > 0.0;
  next_dt_ = first_dt;
  return result;
}

double Simulation::Impl::reaction(const std::vector<int>& dofs) const {
  // Internal force at the converged state (no pressure contribution on these dofs is assumed), taken
  // from the assembly that passed the convergence test. Re-evaluating the elements here would run the
  // material from the converged history over another time step: for a viscoelastic (QLV) law that is
  // one relaxation interval too many (the QLV plate's reaction then lagged the material point).
  double sum = 0.0;
  if (!fint_.empty()) {
    for (int d : dofs) sum += fint_[d];
    return sum;
  }
  // Before the first step: the undeformed state (no history has been advanced yet, state_old_ is the
  // initial one and the elements' stress is that of u = 0).
  Vec24 r;
  std::vector<char> want(model_.mesh.num_dofs(), 0);
  for (int d : dofs) want[d] = 1;
  for (int e = 0; e < model_.mesh.num_elements(); ++e) {
    if (!owns(e)) continue;  // distributed: each rank its own elements, summed below
    const int* en = model_.mesh.element_nodes(e);
    const int nen = model_.mesh.element_size(e);
    bool touches = false;
    for (int a = 0; a < nen && !touches; ++a)
      for (int i = 0; i < 3; ++i) touches |= want[3 * en[a] + i] != 0;
    if (!touches) continue;
    if (model_.mesh.is_tet(e)) {
      Vec30 r10;
      const Tet10& tet = model_.mesh.tets[e - model_.mesh.num_hexes()];
      if (element_force(e, gather(u_, tet), r10, nullptr) != MaterialStatus::ok) continue;
      for (int a = 0; a < 10; ++a)
        for (int i = 0; i < 3; ++i)
          if (want[3 * tet[a] + i]) sum += r10[3 * a + i];
      continue;
    }
    const Hex& hex = model_.mesh.hexes[e];
    if (element_force(e, gather(u_, hex), r, nullptr) != MaterialStatus::ok) continue;
    for (int a = 0; a < 8; ++a)
      for (int i = 0; i < 3; ++i)
        if (want[3 * hex[a] + i]) sum += r[3 * a + i];
  }
  return sum_over_ranks(sum);
}

ElementFields Simulation::Impl::element_fields() const {
  const Mesh& mesh = model_.mesh;
  const int ne = mesh.num_elements();
  ElementFields f;
  f.cauchy.assign(9 * std::size_t(ne), 0.0);
  f.von_mises.assign(ne, 0.0);
  f.J.assign(ne, 1.0);
  f.fiber.assign(3 * std::size_t(ne), 0.0);
#pragma omp parallel for schedule(static) if (ne >= 4000)
  for (int e = 0; e < ne; ++e) {
    Mat3 Fmean = Mat3::Zero();
    if (mesh.is_tet(e)) {
      const int t = e - mesh.num_hexes();
      Tet10Geometry scratch;
      const Tet10Geometry& g = tet_geometry(e, scratch);
      const Tet10Kinematics k = tet10_kinematics(g, gather(u_, mesh.tets[t]), model_.formulation);
      if (!k.ok) continue;
      f.J[e] = k.theta;
      for (int q = 0; q < 4; ++q) Fmean += (g.w[q] / g.volume) * k.F[q];
    } else {
      Hex8Geometry scratch;
      const Hex8Geometry& g = hex_geometry(e, scratch);
      const Hex8Kinematics k = hex8_kinematics(g, gather(u_, mesh.hexes[e]), model_.formulation);
      if (!k.ok) continue;
      f.J[e] = k.theta;
      for (int q = 0; q < 8; ++q) Fmean += (g.w[q] / g.volume) * k.F[q];
    }
    const Material& m = *model_.element_material[e];
    Mat3 sigma = Mat3::Zero();
    if (!cauchy_.empty())
      for (int c = 0; c < 9; ++c) sigma(c / 3, c % 3) = cauchy_[9 * std::size_t(e) + c];
    for (int c = 0; c < 9; ++c) f.cauchy[9 * std::size_t(e) + c] = sigma(c / 3, c % 3);
    const Mat3 dev = sigma - sigma.trace() / 3.0 * Mat3::Identity();
    f.von_mises[e] = std::sqrt(1.5 * (dev.array() * dev.array()).sum());
    const auto dirs = m.fiber_directions();
    if (!dirs.empty()) {
      const Vec3 a = (Fmean * dirs[0]).normalized();
      for (int i = 0; i < 3; ++i) f.fiber[3 * std::size_t(e) + i] = a[i];
    }
  }
  return f;
}

LinearSolverReport Simulation::Impl::linear_report() const {
  LinearSolverReport r;
  r.route = to_string(linear_choice_.route);
  r.preconditioner = to_string(linear_choice_.preconditioner);
  if (linear_choice_.preconditioner == Preconditioner::petsc_options) r.preconditioner += ": " + linear_choice_.user_pc_type;
  r.description = petsc_ ? petsc_->description() : direct_ ? direct_->description() : to_string(solver_->kind());
  const SolverTimes t = linear_times();
  r.krylov_iterations = stats_.krylov_iterations;
  r.factorizations = t.factorizations;
  r.solves = t.solves;
  return r;
}

RunStats Simulation::Impl::stats() const {
  RunStats s = stats_;
  s.linear = linear_times();
  s.linear_solver = linear_report();
  s.assembled_elements = distributed_ ? int(owned_elements_.size()) : model_.mesh.num_elements();
  return s;
}

// The public face: every call forwards to the implementation.
Simulation::Simulation(FeModel model, NewtonOptions options)
    : impl_(std::make_unique<Impl>(std::move(model), options)) {}
Simulation::~Simulation() = default;
AdvanceResult Simulation::advance_to(double t_end) { return impl_->advance_to(t_end); }
double Simulation::time() const { return impl_->time_; }
const std::vector<double>& Simulation::displacement() const { return impl_->u_; }
std::vector<Vec3> Simulation::current_positions() const { return impl_->current_positions(); }
double Simulation::cavity_pressure() const { return impl_->cavity_pressure_; }
double Simulation::reaction(const std::vector<int>& dofs) const { return impl_->reaction(dofs); }
ElementFields Simulation::element_fields() const { return impl_->element_fields(); }
Iterate Simulation::converged_iterate(const Contribution& c) const {
  Iterate it{impl_->time_, impl_->time_, 0.0, &impl_->u_, impl_->cavity_pressure_};
  for (std::size_t k = 0; k < impl_->contributions_.size(); ++k)
    if (impl_->contributions_[k] == &c) {
      // With the contribution's committed history (read only: state_new stays null).
      if (const long off = impl_->contribution_state_offset_[k]; off >= 0)
        it.state_old = impl_->contribution_state_old_.data() + off;
    }
  return it;
}
void Simulation::report(ContributionReport& out) const {
  for (const Contribution* c : impl_->contributions_) c->report(impl_->model_.mesh, converged_iterate(*c), out);
}
RunStats Simulation::stats() const { return impl_->stats(); }
const StepCounts& Simulation::last_step_counts() const { return impl_->last_step_; }

SolverKind automatic_solver(const NewtonOptions& o, long free_dofs, bool quadratic_tets_only, bool cavity_control) {
  if (o.solver != SolverKind::automatic) return o.solver;
  if (cavity_control) return SolverKind::cholmod;
  const long from = quadratic_tets_only ? o.petsc_min_dofs_tet10 : o.petsc_min_dofs;
  return free_dofs >= from ? SolverKind::petsc : SolverKind::cholmod;
}

SolverKind Simulation::Impl::resolved_solver() const {
  const Mesh& mesh = model_.mesh;
  return automatic_solver(options_, dofs_.num_free, mesh.hexes.empty() && !mesh.tets.empty(), model_.cavity.has_value());
}

SolverKind Simulation::solver_kind() const { return impl_->solver_->kind(); }
int Simulation::num_free_dofs() const { return impl_->dofs_.num_free; }
const FeModel& Simulation::model() const { return impl_->model_; }
MaterialStatus Simulation::element_force(int e, const Mat83& u, Vec24& r, Mat24* K) const {
  return impl_->element_force(e, u, r, K);
}
MaterialStatus Simulation::element_force(int e, const Tet10Coords& u, Vec30& r, Mat30* K) const {
  return impl_->element_force(e, u, r, K);
}

}  // namespace softhom::fe
