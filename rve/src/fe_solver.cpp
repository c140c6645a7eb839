// FE RVE engine on periodic conforming T6 section meshes (see fe_solver.hpp).
#include "softhom/rve/fe_solver.hpp"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>

#include <Eigen/Dense>

#include "softhom/fe/line_search.hpp"
#include "softhom/fe/sparse.hpp"
#include "softhom/fe/tet10.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/interrupt.hpp"
#include "softhom/materials/volumetric.hpp"
#include "step_driver.hpp"

namespace softhom::rve {
namespace {

using Clock = std::chrono::steady_clock;

// Dunavant degree-4 rule on the reference triangle (weights sum to 1; area 1/2).
constexpr double kT6Qa = 0.445948490915965, kT6Qb = 0.091576213509771;
constexpr double kT6Wa = 0.223381589678011, kT6Wb = 0.109951743655322;
constexpr double kQuad[6][3] = {{kT6Qa, kT6Qa, kT6Wa}, {1 - 2 * kT6Qa, kT6Qa, kT6Wa}, {kT6Qa, 1 - 2 * kT6Qa, kT6Wa},
                                {kT6Qb, kT6Qb, kT6Wb}, {1 - 2 * kT6Qb, kT6Qb, kT6Wb}, {kT6Qb, 1 - 2 * kT6Qb, kT6Wb}};

// The element families. Everything else (assembly, periodic dof map, condensation, Newton, macro
// control, outputs) is shared and written once against these traits:
//   kNodes, kDim, kQp      nodes, spatial dimension of the mesh (∂/∂y3 = 0 when kDim = 2), points
//   kHasBubble             the P2+bubble / discontinuous-P1 pressure pair is available
//   geometry(mesh, e)      ∂N/∂y, bubble gradient, weights at the quadrature points
//   p1_basis(q)            the P1 pressure basis at point q (only with kHasBubble)
//   position(mesh, i)      node position as a 3-vector, measure(mesh) the cell area / volume

template <int NodesT, int DimT, int QpT>
struct ElementGeometryT {
  std::array<Eigen::Matrix<double, NodesT, DimT>, QpT> dN;
  std::array<Eigen::Matrix<double, DimT, 1>, QpT> dB;  // bubble gradient (zero without bubble)
  std::array<double, QpT> w;
  double area = 0.0;  // element measure (area or volume)
};

/// 6-node triangles of the section, 6-point degree-4 rule, cubic bubble 27 L0 L1 L2.
struct TriElement {
  using Mesh = SectionMesh;
  static constexpr int kNodes = 6, kDim = 2, kQp = 6;
  static constexpr bool kHasBubble = true;
  using Geometry = ElementGeometryT<kNodes, kDim, kQp>;
  static Geometry geometry(const Mesh& m, int e) {
    Geometry g;
    for (int q = 0; q < kQp; ++q) {
      const Eigen::Matrix<double, 6, 2> dR = tri6_shape_derivatives(kQuad[q][0], kQuad[q][1]);
      Eigen::Matrix2d J = Eigen::Matrix2d::Zero();  // J(i, r) = ∂y_i/∂ξ_r
      for (int a = 0; a < 6; ++a) J += m.nodes[m.elements[e][a]] * dR.row(a);
      const double det = J.determinant();
      if (!(det > 0.0))
        throw std::runtime_error("FE RVE mesh: element " + std::to_string(e) + " has a non-positive Jacobian");
      const Eigen::Matrix2d Ji = J.inverse();
      g.dN[q] = dR * Ji;
      const double l0 = 1.0 - kQuad[q][0] - kQuad[q][1], l1 = kQuad[q][0], l2 = kQuad[q][1];
      g.dB[q] = (Eigen::RowVector2d(27.0 * l2 * (l0 - l1), 27.0 * l1 * (l0 - l2)) * Ji).transpose();
      g.w[q] = 0.5 * kQuad[q][2] * det;
      g.area += g.w[q];
    }
    return g;
  }
  static std::array<double, 3> p1_basis(int q) {
    return {1.0 - kQuad[q][0] - kQuad[q][1], kQuad[q][0], kQuad[q][1]};
  }
  static Vec3 position(const Mesh& m, int i) { return Vec3(m.nodes[i].x(), m.nodes[i].y(), 0.0); }
  static double measure(const Mesh& m) { return m.L1 * m.L2; }
  static bool plate(const Mesh& m) { return !m.periodic_y2; }
};

/// Positive-weight 14-point rule on the reference tetrahedron, exact for degree 5 (Walkington's rule;
/// weights sum to 1/6). Points in barycentric orbits (a, a, a, 1 − 3a) and (c, c, ½ − c, ½ − c).
std::array<fe::TetRulePoint, 14> tet_rule_degree5() {
  constexpr double a1 = 0.0927352503108912264, w1 = 0.01224884051939365826;
  constexpr double a2 = 0.3108859192633006097, w2 = 0.01878132095300264180;
  constexpr double c = 0.0455037041256496494, d = 0.5 - c, w3 = 0.007091003462846911;
  std::array<fe::TetRulePoint, 14> r;
  int n = 0;
  for (const auto& [a, w] : {std::pair{a1, w1}, std::pair{a2, w2}})
    for (int k = 0; k < 4; ++k) {
      double b[4] = {a, a, a, a};
      b[k] = 1.0 - 3.0 * a;
      r[n++] = {Eigen::Vector3d(b[1], b[2], b[3]), w};
    }
  constexpr int pairs[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  for (const auto& pr : pairs) {
    double b[4] = {d, d, d, d};
    b[pr[0]] = b[pr[1]] = c;
    r[n++] = {Eigen::Vector3d(b[1], b[2], b[3]), w3};
  }
  return r;
}

/// 10-node tetrahedra of the 3D cell (fe/tet10.hpp); P2/P0 only (no bubble). QpT = 4: the standard
/// degree-2 rule; QpT = 14: the degree-5 rule above. The degree-2 rule integrates the stiffness of
/// straight elements at small strain exactly, but not the cubic Jacobian of the curved interface
/// elements (their volumes, hence the phase volumes and the P0 mean dilatation) nor the rational
/// finite-strain integrand.
template <int QpT>
struct TetElementT {
  using Mesh = CellMesh;
  static constexpr int kNodes = 10, kDim = 3, kQp = QpT;
  static constexpr bool kHasBubble = false;
  using Geometry = ElementGeometryT<kNodes, kDim, kQp>;
  static const std::array<fe::TetRulePoint, QpT>& rule() {
    if constexpr (QpT == 4) {
      static const auto r = fe::tet_rule_degree2();
      return r;
    } else {
      static const auto r = tet_rule_degree5();
      return r;
    }
  }
  static Geometry geometry(const Mesh& m, int e) {
    Geometry g;
    const auto& rl = rule();
    for (int q = 0; q < kQp; ++q) {
      const fe::Tet10Grad dR = fe::tet10_shape_derivatives(rl[q].xi);
      Eigen::Matrix3d J = Eigen::Matrix3d::Zero();
      for (int a = 0; a < 10; ++a) J += m.nodes[m.elements[e][a]] * dR.row(a);
      const double det = J.determinant();
      if (!(det > 0.0))
        throw std::runtime_error("FE RVE mesh: element " + std::to_string(e) + " has a non-positive Jacobian");
      g.dN[q] = dR * J.inverse();
      g.dB[q].setZero();
      g.w[q] = rl[q].w * det;
      g.area += g.w[q];
    }
    return g;
  }
  static std::array<double, 3> p1_basis(int) { return {1.0, 0.0, 0.0}; }
  static Vec3 position(const Mesh& m, int i) { return m.nodes[i]; }
  static double measure(const Mesh& m) { return m.L1 * m.L2 * m.L3; }
  static bool plate(const Mesh&) { return false; }
};
using TetElement4 = TetElementT<4>;
using TetElement14 = TetElementT<14>;

/// Internal (condensed) unknowns of a mixed element, at most 9: bubble displacement (3, P2+/P1 only),
/// dilatation θ and pressure p coefficients (1 each for P0, 3 each for P1 in the basis L0, L1, L2).
constexpr int kMaxInternal = 9;
using VecI = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxInternal, 1>;
using MatI = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxInternal, kMaxInternal>;

/// Sums over one evaluation pass (per thread, then reduced): the phase sums and Σ w P (grid).
struct PassSums : detail::PhaseSums {
  Mat3 P = Mat3::Zero();
  void add(const PassSums& o) {
    add_phases(o);
    P += o.P;
  }
};

}  // namespace

const char* to_string(FePressure p) { return p == FePressure::p0 ? "p0" : "p1-bubble"; }

namespace {
/// A plate's normal column in the load frame: F13, F23, F33 (row-major indices of F̄).
constexpr std::array<int, 3> kPlateNormalColumn{2, 5, 8};
}  // namespace

void check_plate_control(const MixedControl& control) {
  for (int c : kPlateNormalColumn) {
    const std::string name = "F" + std::to_string(c / 3 + 1) + "3";
    bool zero = control.kind[c] == ControlKind::stress;
    if (zero)
      for (double v : control.value[c].v) zero = zero && v == 0.0;
    if (!zero)
      throw InputError("load", control.name,
                       "the plate cell (microstructure.cell = \"plate\") has traction-free faces: its normal column must be "
                       "free and stress-free (F13, F23, F33 \"free\" with P13 = P23 = P33 = 0, a type = \"mixed\" load), but " +
                           name + (control.kind[c] == ControlKind::stress ? " has a non-zero stress target" : " is prescribed"));
  }
}

namespace {

template <class E>
struct Model {
  static constexpr int kNodes = E::kNodes, kDim = E::kDim, kQp = E::kQp;
  static constexpr int kNU = 3 * kNodes;  // element fluctuation dofs
  static constexpr int ND = kNU + 9;      // + the 9 load-frame components of F̄
  using MatD = Eigen::Matrix<double, ND, ND>;
  using VecD = Eigen::Matrix<double, ND, 1>;
  using Mat9xD = Eigen::Matrix<double, 9, ND>;
  using MatIq = Eigen::Matrix<double, Eigen::Dynamic, ND, 0, kMaxInternal, ND>;
  using Geometry = typename E::Geometry;
  using Mesh = typename E::Mesh;

  FeSolverOptions opt;
  Mesh mesh;
  int ne = 0, nn = 0;
  std::vector<Geometry> geo;
  Mat3 R;         // grid axes in the load frame
  Mat9 Tg;        // vec(F_grid) = Tg vec(F_load)
  Vec3 a0_load;
  MaterialPtr mat[2];
  int state_size[2] = {0, 0};
  bool mixed[2] = {false, false};
  double K_vol[2] = {0.0, 0.0};
  double G_min = 1.0, K_max = 0.0;
  double cell_area = 1.0;
  double achieved_vf = 0.0;
  // Plate cell (SectionMesh::periodic_y2 false): ũ is not periodic across the faces y2 = 0, L2, so it
  // absorbs the grid column F̄_i2 = −(load column F̄_i3, rotated): that column is no control. It is
  // held at the identity's values, the control must leave it traction-free (P̄_i3 = 0, which the free
  // faces give by the divergence theorem), and the output F̄ is the section mean of F.
  bool plate = false;

  // Dofs: node → 3 equations of its master (−1 for the anchor node, fixed against translation).
  std::vector<int> node_eq;   // 3 per node
  int n_u = 0;
  std::array<int, 9> macro_eq{};  // load-frame component → equation (−1 when prescribed)
  int n_eq = 0;
  fe::CscMatrix K;
  std::unique_ptr<fe::LinearSolver> cholmod, umfpack;
  bool cholmod_analyzed = false, umfpack_analyzed = false;
  std::string last_solver = "none";
  double assembly_time = 0.0;

  // State (current and committed).
  std::vector<double> ut, ut_c;          // fluctuation, 3 per node (slaves copy their master)
  Mat3 Fbar = Mat3::Identity(), Fbar_c = Mat3::Identity();
  // Internal unknowns per element (stride kMaxInternal): [bubble (nb), θ (np), p (np)].
  int nb = 0, np = 1, ni = 2;
  std::vector<double> internal, internal_c;
  std::vector<int> hist_offset;          // per element into hist arrays (−1: elastic)
  std::vector<double> hist_old, hist_new;
  std::vector<double> hist_prev;         // history before the last commit (fields of that step)
  // Linearization data of the last evaluation (mixed elements), for the recovery of the internal
  // increments δi = −K_ii⁻¹ (R_i + K_iq δq).
  std::vector<MatI> lin_Kinv;
  std::vector<MatIq> lin_Kiq;
  std::vector<VecI> lin_Ri;
  // Assembled vectors of the last evaluation (n_eq): true residual, Newton right-hand side part,
  // prescribed-increment predictor K_{:,p} ΔF_p.
  std::vector<double> r_true, r_eff, r_pred;
  double max_mismatch = 0.0;       // max pressure mismatch over mixed elements (stress units)
  double bubble_residual_sq = 0.0;  // Σ |bubble residual|² (forces)
  PassSums sums;

  Model(Mesh m, MaterialPtr matrix, MaterialPtr fiber, double angle, const Mat3& frame, const FeSolverOptions& o)
      : opt(o), mesh(std::move(m)) {
    ne = mesh.num_elements();
    nn = mesh.num_nodes();
    if (ne == 0) throw InputError("solver.mesh_size", "", "the mesh has no elements");
    geo.resize(ne);
    for (int e = 0; e < ne; ++e) geo[e] = E::geometry(mesh, e);
    cell_area = E::measure(mesh);
    plate = E::plate(mesh);
    R = grid_rotation(angle);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k)
          for (int l = 0; l < 3; ++l) Tg(3 * i + j, 3 * k + l) = R(k, i) * R(l, j);
    a0_load = R.col(2);
    const Mat3 Q = R.transpose() * frame.transpose();
    mat[0] = MaterialPtr(matrix->rotated(Q));
    mat[1] = MaterialPtr(fiber->rotated(Q));
    G_min = std::min(mat[0]->initial_shear_modulus(), mat[1]->initial_shear_modulus());
    K_max = std::max(mat[0]->initial_bulk_modulus(), mat[1]->initial_bulk_modulus());
    for (int x = 0; x < 2; ++x) {
      state_size[x] = mat[x]->state_size();
      K_vol[x] = mat[x]->volumetric_modulus();
      mixed[x] = opt.mixed_pressure && K_vol[x] > 0.0 && K_vol[x] >= opt.mixed_pressure_ratio * mat[x]->initial_shear_modulus();
    }
    double fiber_area = 0.0;
    for (int e = 0; e < ne; ++e)
      if (mesh.phase[e] == 1) fiber_area += geo[e].area;
    achieved_vf = fiber_area / cell_area;

    // Equations of the fluctuation: one triple per master node, the anchor (master of node 0) fixed.
    node_eq.assign(3 * nn, -1);
    std::vector<int> master_eq(nn, -1);
    const int anchor = mesh.master[0];
    for (int i = 0; i < nn; ++i)
      if (mesh.master[i] == i && i != anchor) {
        master_eq[i] = n_u;
        n_u += 3;
      }
    for (int i = 0; i < nn; ++i) {
      const int b = master_eq[mesh.master[i]];
      if (b >= 0)
        for (int c = 0; c < 3; ++c) node_eq[3 * i + c] = b + c;
    }
    ut.assign(3 * nn, 0.0);
    ut_c = ut;
    if (opt.pressure == FePressure::p1_bubble) {
      if (!E::kHasBubble)
        throw InputError("solver.pressure", "p1", "the 3D tetrahedral mesh supports p0 (P2/P0) only");
      nb = 3;
      np = 3;
    }
    ni = nb + 2 * np;
    internal.assign(std::size_t(kMaxInternal) * ne, 0.0);
    for (int e = 0; e < ne; ++e)
      for (int j = 0; j < np; ++j) internal[kMaxInternal * e + nb + j] = 1.0;  // θ = 1
    internal_c = internal;
    hist_offset.assign(ne, -1);
    std::size_t off = 0;
    for (int e = 0; e < ne; ++e) {
      const int s = state_size[mesh.phase[e]];
      if (s > 0) {
        hist_offset[e] = int(off);
        off += std::size_t(kQp) * s;
      }
    }
    hist_old.assign(off, 0.0);
    for (int e = 0; e < ne; ++e)
      if (hist_offset[e] >= 0) {
        const int x = mesh.phase[e];
        for (int q = 0; q < kQp; ++q) mat[x]->init_state(hist_old.data() + hist_offset[e] + q * state_size[x]);
      }
    hist_new = hist_old;
    bool any_mixed = false;
    for (int e = 0; e < ne; ++e) any_mixed = any_mixed || mixed[mesh.phase[e]];
    if (any_mixed) {
      lin_Kinv.assign(ne, MatI::Zero(ni, ni));
      lin_Kiq.assign(ne, MatIq::Zero(ni, ND));
      lin_Ri.assign(ne, VecI::Zero(ni));
    }
  }

  Mat3 to_grid(const Mat3& X) const { return R.transpose() * X * R; }
  Mat3 to_load(const Mat3& X) const { return R * X * R.transpose(); }

  /// Global equation of element-local dof d (0..kNU−1 fluctuation node-major, then load-frame F̄).
  int element_eq(int e, int d) const {
    if (d < kNU) return node_eq[3 * mesh.elements[e][d / 3] + d % 3];
    return macro_eq[d - kNU];
  }

  /// Sparsity pattern on the current equation numbering (fluctuation + free macro components).
  void build_pattern() {
    std::vector<std::vector<int>> cols(n_eq);
    std::vector<int> eqs;
    for (int e = 0; e < ne; ++e) {
      eqs.clear();
      for (int d = 0; d < ND; ++d) {
        const int g = element_eq(e, d);
        if (g >= 0) eqs.push_back(g);
      }
      for (int c : eqs)
        for (int r : eqs) cols[c].push_back(r);
    }
    K = fe::CscMatrix{};
    K.n = n_eq;
    K.colptr.assign(n_eq + 1, 0);
    for (int c = 0; c < n_eq; ++c) {
      auto& v = cols[c];
      std::sort(v.begin(), v.end());
      v.erase(std::unique(v.begin(), v.end()), v.end());
      K.colptr[c + 1] = K.colptr[c] + int(v.size());
    }
    K.rowind.reserve(K.colptr[n_eq]);
    for (int c = 0; c < n_eq; ++c) K.rowind.insert(K.rowind.end(), cols[c].begin(), cols[c].end());
    K.values.assign(K.rowind.size(), 0.0);
    cholmod.reset();
    umfpack.reset();
    cholmod_analyzed = umfpack_analyzed = false;
  }

  void set_control(const std::array<bool, 9>& free) {
    n_eq = n_u;
    for (int c = 0; c < 9; ++c) macro_eq[c] = free[c] ? n_eq++ : -1;
    build_pattern();
  }

  /// Per-element work of one evaluation: element residual and tangent, the blocks of the mixed
  /// (bubble, θ, p) unknowns, the output sums and the smallest limit margin of its points.
  struct ElementWork {
    Mat9xD B;  // A·B of the current point
    MatD Ke;
    VecD re;
    // Mixed-element blocks: bubble rows (3), pressure coupling G = ∫ Bᵀ cof ψ_j.
    Eigen::Matrix<double, ND, 3> Kqb, Gq;
    Eigen::Matrix3d Kbb, Gb, H, M;
    Eigen::Vector3d rb, Rth, Rp;
    Mat3 Pe_sum, Fe_sum, PFt_sum;
    double Je_sum = 0.0;
    double margin = 1.0;
    void reset(bool with_tangent, bool mx) {
      re.setZero();
      if (with_tangent) Ke.setZero();
      if (mx) {
        Kqb.setZero();
        Gq.setZero();
        Kbb.setZero();
        Gb.setZero();
        H.setZero();
        M.setZero();
        rb.setZero();
        Rth.setZero();
        Rp.setZero();
      }
      Pe_sum.setZero();
      Fe_sum.setZero();
      PFt_sum.setZero();
      Je_sum = 0.0;
      margin = 1.0;
    }
  };

  /// out += s Bᵀ X, B = ∂vec(F)/∂(ũ_e, F̄_load): column 3a+i has dN_a/dy_J at row 3i+J (J < kDim; on
  /// the section ∂/∂y3 = 0); the macro columns are Tg. Formed with that sparsity.
  template <class DN>
  void add_BtX(const DN& dN, const Vec9& X, double s, VecD& out) const {
    for (int a = 0; a < kNodes; ++a)
      for (int i = 0; i < 3; ++i) {
        double v = 0.0;
        for (int J = 0; J < kDim; ++J) v += dN(a, J) * X[3 * i + J];
        out[3 * a + i] += s * v;
      }
    out.template tail<9>().noalias() += s * Tg.transpose() * X;
  }

  /// F at quadrature point q of element e: F̄_grid + ∇ũ (+ the bubble of a mixed section element).
  Mat3 point_gradient(const Mat3& Fg, int e, int q, const double* in, int nbe) const {
    const auto& el = mesh.elements[e];
    const Geometry& g = geo[e];
    const auto& dN = g.dN[q];
    Mat3 F = Fg;
    for (int a = 0; a < kNodes; ++a)
      for (int i = 0; i < 3; ++i) {
        const double u = ut[3 * el[a] + i];
        for (int J = 0; J < kDim; ++J) F(i, J) += u * dN(a, J);
      }
    for (int i = 0; i < nbe; ++i) {
      F(i, 0) += in[i] * g.dB[q][0];
      F(i, 1) += in[i] * g.dB[q][1];
    }
    return F;
  }

  /// Quadrature of element e into `w`: residual, tangent (when asked), mixed blocks, output sums.
  MaterialStatus integrate_element(int e, const Mat3& Fg, double dt, bool with_tangent, ElementWork& w) {
    const int x = mesh.phase[e];
    const Material& m = *mat[x];
    const bool mx = mixed[x];
    const double Kv = K_vol[x];
    const Geometry& g = geo[e];
    const double* in = internal.data() + std::size_t(kMaxInternal) * e;
    const int nbe = mx ? nb : 0;  // bubble only in mixed elements (section elements only)
    w.reset(with_tangent, mx);
    for (int q = 0; q < kQp; ++q) {
      const auto& dN = g.dN[q];
      const double wq = g.w[q];
      const Mat3 F = point_gradient(Fg, e, q, in, nbe);
      const double J = F.determinant();
      if (!(J > 0.0)) return MaterialStatus::inverted;
      Mat3 P;
      Mat9 A;
      const int ss = state_size[x];
      const double* ho = ss ? hist_old.data() + hist_offset[e] + q * ss : nullptr;
      double* hn = ss ? hist_new.data() + hist_offset[e] + q * ss : nullptr;
      const MaterialStatus status = m.evaluate(F, ho, hn, dt, P, with_tangent || mx ? &A : nullptr);
      if (status != MaterialStatus::ok) return status;
      w.margin = std::min(w.margin, m.limit_margin(F));
      const Mat3 cof = J * F.inverse().transpose();
      // Pressure basis ψ_j at this point (P0: 1; P1: area coordinates), θ_q, p_q.
      double psi[3] = {1.0, 0.0, 0.0};
      if (np == 3) {
        const auto b = E::p1_basis(q);
        psi[0] = b[0];
        psi[1] = b[1];
        psi[2] = b[2];
      }
      double th_q = 0.0, p_q = 0.0;
      if (mx)
        for (int j = 0; j < np; ++j) {
          th_q += psi[j] * in[nbe + j];
          p_q += psi[j] * in[nbe + np + j];
        }
      if (mx) {
        // Replace the law's volumetric stress W_V′(J) cof F by the interpolated pressure p cof F.
        const double dq = p_q - volumetric_dU(Kv, J);
        P += dq * cof;
        const Vec9 c9 = flatten(cof);
        A.noalias() -= volumetric_d2U(Kv, J) * c9 * c9.transpose();
        add_cofactor_derivative(dq / J, cof, A);
        if (!(th_q > 0.0)) return MaterialStatus::inverted;
      }
      if (!P.allFinite()) return MaterialStatus::not_finite;
      const Vec9 Pv = flatten(P);
      add_BtX(dN, Pv, wq, w.re);
      if (with_tangent) add_point_tangent(dN, A, wq, w);
      if (mx) add_mixed_point(g, q, nbe, P, A, cof, J, psi, th_q, p_q, Kv, w);
      w.Pe_sum += wq * P;
      w.Fe_sum += wq * F;
      w.PFt_sum += wq * P * F.transpose();
      w.Je_sum += wq * J;
    }
    return MaterialStatus::ok;
  }

  /// Ke += w Bᵀ A B at one point (B·A formed with the sparsity of B, into w.B).
  template <class DN>
  void add_point_tangent(const DN& dN, const Mat9& A, double wq, ElementWork& w) const {
    for (int a = 0; a < kNodes; ++a)
      for (int i = 0; i < 3; ++i) {
        w.B.col(3 * a + i) = dN(a, 0) * A.col(3 * i);
        for (int J = 1; J < kDim; ++J) w.B.col(3 * a + i) += dN(a, J) * A.col(3 * i + J);
      }
    w.B.template rightCols<9>().noalias() = A * Tg;  // B now holds A·B
    for (int a = 0; a < kNodes; ++a)
      for (int i = 0; i < 3; ++i) {
        auto row = w.Ke.row(3 * a + i);
        for (int J = 0; J < kDim; ++J) row.noalias() += (wq * dN(a, J)) * w.B.row(3 * i + J);
      }
    w.Ke.template bottomRows<9>().noalias() += wq * Tg.transpose() * w.B;
  }

  /// The bubble and (θ, p) terms of a mixed element at one point (nbe > 0 on the section only,
  /// where ∂/∂y3 = 0: two gradient components).
  void add_mixed_point(const Geometry& g, int q, int nbe, const Mat3& P, const Mat9& A, const Mat3& cof, double J,
                       const double psi[3], double th_q, double p_q, double Kv, ElementWork& w) const {
    const auto& dN = g.dN[q];
    const double wq = g.w[q];
    const double gb0 = g.dB[q][0], gb1 = g.dB[q][1];
    const Vec9 c9 = flatten(cof);
    for (int i = 0; i < nbe; ++i) {
      w.rb[i] += wq * (gb0 * P(i, 0) + gb1 * P(i, 1));
      const Vec9 ABk = gb0 * A.col(3 * i) + gb1 * A.col(3 * i + 1);  // A · B_bubble,i
      VecD col = VecD::Zero();
      add_BtX(dN, ABk, wq, col);
      w.Kqb.col(i) += col;
      for (int k = 0; k < nbe; ++k) w.Kbb(k, i) += wq * (gb0 * ABk[3 * k] + gb1 * ABk[3 * k + 1]);
    }
    VecD gcol = VecD::Zero();
    add_BtX(dN, c9, wq, gcol);
    const double U1 = volumetric_dU(Kv, th_q), U2 = volumetric_d2U(Kv, th_q);
    for (int j = 0; j < np; ++j) {
      w.Gq.col(j) += psi[j] * gcol;
      for (int i = 0; i < nbe; ++i) w.Gb(i, j) += wq * psi[j] * (gb0 * cof(i, 0) + gb1 * cof(i, 1));
      w.Rth[j] += wq * psi[j] * (U1 - p_q);
      w.Rp[j] += wq * psi[j] * (J - th_q);
      for (int k = 0; k < np; ++k) {
        w.H(j, k) += wq * psi[j] * psi[k] * U2;
        w.M(j, k) += wq * psi[j] * psi[k];
      }
    }
  }

  /// Static condensation of the internal unknowns i = [bubble, θ, p] of mixed element e:
  ///   K_ii = [Kbb 0 Gb; 0 H −M; Gbᵀ −M 0], K_iq = [Kqbᵀ; 0; Gqᵀ], R_i = [rb; Rθ; Rp].
  /// Returns the effective residual, condenses Ke, keeps the linearization for the recovery of the
  /// internal increments, raises `mismatch` (pressure mismatch, stress units) and `bubble_sq`.
  VecD condense_element(int e, bool with_tangent, ElementWork& w, double& mismatch, double& bubble_sq) {
    VecD reff = w.re;
    const int nbe = nb;
    MatI Kii = MatI::Zero(ni, ni);
    MatIq Kiq = MatIq::Zero(ni, ND);
    VecI Ri(ni);
    const int o_t = nbe, o_p = nbe + np;
    Kii.block(0, 0, nbe, nbe) = w.Kbb.topLeftCorner(nbe, nbe);
    Kii.block(0, o_p, nbe, np) = w.Gb.topLeftCorner(nbe, np);
    Kii.block(o_p, 0, np, nbe) = w.Gb.topLeftCorner(nbe, np).transpose();
    Kii.block(o_t, o_t, np, np) = w.H.topLeftCorner(np, np);
    Kii.block(o_t, o_p, np, np) = -w.M.topLeftCorner(np, np);
    Kii.block(o_p, o_t, np, np) = -w.M.topLeftCorner(np, np);
    Kiq.topRows(nbe) = w.Kqb.leftCols(nbe).transpose();
    Kiq.middleRows(o_p, np) = w.Gq.leftCols(np).transpose();
    for (int i = 0; i < nbe; ++i) Ri[i] = w.rb[i];
    for (int j = 0; j < np; ++j) {
      Ri[o_t + j] = w.Rth[j];
      Ri[o_p + j] = w.Rp[j];
    }
    const MatI Kinv = Kii.fullPivLu().inverse();
    const VecI KinvR = Kinv * Ri;
    reff.noalias() -= Kiq.transpose() * KinvR;
    if (with_tangent) w.Ke.noalias() -= Kiq.transpose() * (Kinv * Kiq);
    lin_Kinv[e] = Kinv;
    lin_Kiq[e] = Kiq;
    lin_Ri[e] = Ri;
    // Pressure mismatch in stress units: (Rθ + U″ Rp)_j / ∫ψ_j (P0: U″(J̄ − θ) + U′(θ) − p).
    for (int j = 0; j < np; ++j) {
      double mass = 0.0;
      for (int k = 0; k < np; ++k) mass += w.M(j, k);
      double u2 = 0.0;
      for (int k = 0; k < np; ++k) u2 += w.H(j, k);
      u2 /= mass;
      mismatch = std::max(mismatch, std::abs(w.Rth[j] + u2 * w.Rp[j]) / mass);
    }
    // The bubble residual is a force: it joins the force residual norm.
    for (int i = 0; i < nbe; ++i) bubble_sq += w.rb[i] * w.rb[i];
    return reff;
  }

  /// Adds element e's residuals, predictor and tangent to the global arrays (atomic: elements of
  /// different threads share nodes).
  void scatter_element(int e, const ElementWork& w, const VecD& reff, bool with_tangent, bool any_prescribed_step,
                       const Vec9& dFp) {
    int eq[ND];
    for (int d = 0; d < ND; ++d) eq[d] = element_eq(e, d);
    VecD pred = VecD::Zero();
    if (with_tangent && any_prescribed_step) pred = w.Ke.template rightCols<9>() * dFp;
    for (int d = 0; d < ND; ++d) {
      if (eq[d] < 0) continue;
#pragma omp atomic
      r_true[eq[d]] += w.re[d];
#pragma omp atomic
      r_eff[eq[d]] += reff[d];
      if (any_prescribed_step && with_tangent) {
#pragma omp atomic
        r_pred[eq[d]] += pred[d];
      }
    }
    if (!with_tangent) return;
    for (int cl = 0; cl < ND; ++cl) {
      if (eq[cl] < 0) continue;
      // Rows come in runs of consecutive equations (the 3 components of a node, the free macro
      // components): one binary search per run.
      for (int rw = 0; rw < ND;) {
        if (eq[rw] < 0) {
          ++rw;
          continue;
        }
        const long pos = K.find(eq[rw], eq[cl]);
        int len = 1;
        while (rw + len < ND && eq[rw + len] == eq[rw] + len && (rw + len) % 3 != 0 && rw + len < kNU) ++len;
        if (rw >= kNU)
          while (rw + len < ND && eq[rw + len] == eq[rw] + len) ++len;
        for (int k = 0; k < len; ++k) {
#pragma omp atomic
          K.values[pos + k] += w.Ke(rw + k, cl);
        }
        rw += len;
      }
    }
  }

  /// Evaluates every element at the current state: residuals (true and Newton right-hand side part),
  /// tangent (when asked), the predictor K_{:,p} dFp, the linearization data and the output sums.
  MaterialStatus evaluate(double dt, bool with_tangent, const Vec9& dFp) {
    const auto t0 = Clock::now();
    r_true.assign(n_eq, 0.0);
    r_eff.assign(n_eq, 0.0);
    r_pred.assign(n_eq, 0.0);
    if (with_tangent) K.set_zero();
    const Mat3 Fg = to_grid(Fbar);
    const bool any_prescribed_step = dFp.cwiseAbs().maxCoeff() > 0.0;
    int failure = 0;
    double mismatch = 0.0, bubble_sq = 0.0;
    PassSums total;
#pragma omp parallel
    {
      PassSums local;
      double local_mismatch = 0.0, local_bubble = 0.0;
      ElementWork w;
#pragma omp for schedule(dynamic, 64)
      for (int e = 0; e < ne; ++e) {
        int seen;
#pragma omp atomic read
        seen = failure;
        if (seen) continue;
        const int x = mesh.phase[e];
        const MaterialStatus status = integrate_element(e, Fg, dt, with_tangent, w);
        if (status != MaterialStatus::ok) {
#pragma omp atomic write
          failure = int(status);
          continue;
        }
        const VecD reff = mixed[x] ? condense_element(e, with_tangent, w, local_mismatch, local_bubble) : VecD(w.re);
        scatter_element(e, w, reff, with_tangent, any_prescribed_step, dFp);
        local.P += w.Pe_sum;
        local.add_phase(x, geo[e].area, w.Pe_sum, w.Fe_sum, w.PFt_sum, w.Je_sum);
        local.see_margin(x, w.margin, std::size_t(e));
      }
#pragma omp critical
      {
        total.add(local);
        mismatch = std::max(mismatch, local_mismatch);
        bubble_sq += local_bubble;
      }
    }
    sums = total;
    max_mismatch = mismatch;
    bubble_residual_sq = bubble_sq;
    assembly_time += std::chrono::duration<double>(Clock::now() - t0).count();
    return MaterialStatus(failure);
  }

  /// Subtracts the macro stress targets from the free macro rows.
  void apply_targets(const Vec9& P_target) {
    for (int c = 0; c < 9; ++c)
      if (macro_eq[c] >= 0) {
        r_true[macro_eq[c]] -= cell_area * P_target[c];
        r_eff[macro_eq[c]] -= cell_area * P_target[c];
      }
  }

  double stress_scale(const std::array<bool, 9>& free, const Vec9& P_target) const {
    const Mat3 Pl = to_load(sums.P) / cell_area;
    double s = 1e-6 * G_min;
    for (int c = 0; c < 9; ++c) s = std::max(s, free[c] ? std::abs(P_target[c]) : std::abs(Pl(c / 3, c % 3)));
    return s;
  }

  /// Relative error of the current evaluation (see FeSolverOptions::tolerance).
  double error(const std::array<bool, 9>& free, const Vec9& P_target) const {
    const double s = stress_scale(free, P_target);
    double fu = 0.0, fm = 0.0;
    for (int i = 0; i < n_u; ++i) fu += r_true[i] * r_true[i];
    fu += bubble_residual_sq;
    for (int i = n_u; i < n_eq; ++i) fm = std::max(fm, std::abs(r_true[i]));
    return std::max({std::sqrt(fu) / (s * std::sqrt(cell_area)), fm / (cell_area * s), max_mismatch / s});
  }

  double merit() const {
    double s = 0.0;
    for (double v : r_eff) s += v * v;
    return std::sqrt(s);
  }

  /// Solves K x = b; CHOLMOD first, UMFPACK when the tangent is not positive definite.
  bool solve(const std::vector<double>& b, std::vector<double>& x) {
    // The factorizations run on one BLAS thread: 2D supernodes are small, and a threaded BLAS
    // (OpenBLAS-OpenMP) on a loaded machine spends its time spinning (measured 15x slower on 2 cores).
    struct OneThread {
      int n = omp_get_max_threads();
      OneThread() { omp_set_num_threads(1); }
      ~OneThread() { omp_set_num_threads(n); }
    } one_thread;
    if (!opt.use_umfpack) {
      if (!cholmod) cholmod = fe::make_linear_solver(fe::SolverKind::cholmod);
      if (!cholmod_analyzed) {
        cholmod->analyze(K);
        cholmod_analyzed = true;
      }
      if (cholmod->factorize(K)) {
        cholmod->solve(b, x);
        last_solver = "cholmod";
        return true;
      }
    }
    if (!umfpack) umfpack = fe::make_linear_solver(fe::SolverKind::umfpack);
    if (!umfpack_analyzed) {
      umfpack->analyze(K);
      umfpack_analyzed = true;
    }
    if (!umfpack->factorize(K)) return false;
    umfpack->solve(b, x);
    last_solver = "umfpack";
    return true;
  }

  // Newton directions of the internal unknowns: δi = −K_ii⁻¹ (R_i + K_iq δq), from the global
  // increment and the linearization data of the last evaluation.
  void element_increments(const std::vector<double>& dx, const Vec9& dF_load, std::vector<double>& di) const {
    di.assign(internal.size(), 0.0);
#pragma omp parallel for schedule(static)
    for (int e = 0; e < ne; ++e) {
      if (!mixed[mesh.phase[e]]) continue;
      VecD dq;
      for (int d = 0; d < kNU; ++d) {
        const int g = element_eq(e, d);
        dq[d] = g >= 0 ? dx[g] : 0.0;
      }
      dq.template tail<9>() = dF_load;
      const VecI d = -(lin_Kinv[e] * (lin_Ri[e] + lin_Kiq[e] * dq));
      for (int k = 0; k < ni; ++k) di[std::size_t(kMaxInternal) * e + k] = d[k];
    }
  }

  using StepOutcome = detail::SubstepOutcome;

  /// A converged sub-step: ok unless a phase is at its material limit there (fatal).
  StepOutcome& converged(StepOutcome& out) const {
    const std::string where[2] = {"element " + std::to_string(sums.margin_at[0]),
                                  "element " + std::to_string(sums.margin_at[1])};
    out.why = detail::phase_limit_reached(sums.margin, where, Fbar);
    out.fatal = !out.why.empty();
    out.ok = !out.fatal;
    return out;
  }

  /// What a sub-step prescribes: the mixed control at t_new.
  struct StepTargets {
    std::array<bool, 9> free{};
    Vec9 P_target = Vec9::Zero();
    Mat3 target;  // prescribed components of F̄ (the others as F̄ at the start)
  };
  /// The last accepted iterate (ũ, internal unknowns, F̄) and the Newton direction from it.
  struct NewtonDirection {
    std::vector<double> ut0, in0, dx, di;
    Mat3 F0;
    Vec9 dF = Vec9::Zero();
    bool had_prescribed_step = false;
    /// The line search takes any admissible trial: the step's first direction, which carries the load
    /// increment (prescribed components or stress targets). Its merit is not comparable with the
    /// previous state's: a nearly incompressible phase's K (J − 1) at second order in the increment
    /// would otherwise cut every step of a stress-controlled load to the last trial (measured: 0.5 %
    /// of the stress residual removed per Newton iteration at K/G = 1.2e5).
    bool accept_any = false;
  };

  /// F̄_target − F̄ on the prescribed components (zero on the free ones).
  Vec9 prescribed_gap(const StepTargets& s) const {
    Vec9 dFp = Vec9::Zero();
    for (int c = 0; c < 9; ++c)
      if (!s.free[c]) dFp[c] = s.target(c / 3, c % 3) - Fbar(c / 3, c % 3);
    return dFp;
  }

  /// Backtracking line search along the Newton direction; false (out.why set) when it fails.
  bool search_line(const StepTargets& s, const NewtonDirection& n, double dt, StepOutcome& out) {
    MaterialStatus last = MaterialStatus::ok;
    auto trial = [&](double scale) -> std::optional<double> {
      for (int i = 0; i < nn; ++i)
        for (int c = 0; c < 3; ++c) {
          const int g = node_eq[3 * i + c];
          ut[3 * i + c] = n.ut0[3 * i + c] + (g >= 0 ? scale * n.dx[g] : 0.0);
        }
      Fbar = n.F0 + scale * unflatten(n.dF);
      for (std::size_t k = 0; k < internal.size(); ++k) internal[k] = n.in0[k] + scale * n.di[k];
      // Prescribed components reached exactly (no round-off drift).
      if (n.had_prescribed_step && scale == 1.0)
        for (int c = 0; c < 9; ++c)
          if (!s.free[c]) Fbar(c / 3, c % 3) = s.target(c / 3, c % 3);
      last = evaluate(dt, true, prescribed_gap(s));
      if (last != MaterialStatus::ok) return std::nullopt;
      apply_targets(s.P_target);
      return merit();
    };
    if (fe::backtracking_line_search(merit(), n.accept_any, trial).accepted) return true;
    out.why = last != MaterialStatus::ok ? std::string("material call failed (") + to_string(last) + ")"
                                         : std::string("line search failed");
    return false;
  }

  /// Newton direction: K dx = −r_eff − K_{:,p} ΔF_p, from the current iterate (which becomes the
  /// accepted one); false when the tangent is singular.
  bool newton_direction(const StepTargets& s, bool reached, bool first_of_step, NewtonDirection& n) {
    const Vec9 dFp_now = prescribed_gap(s);
    std::vector<double> b(n_eq);
    for (int i = 0; i < n_eq; ++i) b[i] = -r_eff[i] - (reached ? 0.0 : r_pred[i]);
    if (!solve(b, n.dx)) return false;
    n.dF = dFp_now;
    for (int c = 0; c < 9; ++c)
      if (macro_eq[c] >= 0) n.dF[c] = n.dx[macro_eq[c]];
    element_increments(n.dx, n.dF, n.di);
    n.ut0 = ut;
    n.in0 = internal;
    n.F0 = Fbar;
    n.had_prescribed_step = !reached;
    n.accept_any = !reached || first_of_step;
    return true;
  }

  StepOutcome step(const MixedControl& control, double t_new, double dt) {
    StepOutcome out;
    StepTargets s;
    s.target = Fbar;
    for (int c = 0; c < 9; ++c) {
      s.free[c] = control.kind[c] == ControlKind::stress;
      if (s.free[c]) s.P_target[c] = control.value[c](t_new);
      else s.target(c / 3, c % 3) = control.value[c](t_new);
    }
    if (plate)
      for (int c : kPlateNormalColumn) {
        s.free[c] = false;
        s.target(c / 3, c % 3) = c == 8 ? 1.0 : 0.0;
      }
    NewtonDirection n;
    n.F0 = Fbar;
    double err = 0.0, first_err = -1.0;
    if (std::string why = detail::target_inverts(control, t_new, Fbar_c); !why.empty()) {
      out.fatal = true;
      out.why = std::move(why);
      return out;
    }
    for (int it = 0; it <= opt.max_newton_iterations; ++it) {
      if (stop_requested()) {
        out.why = "stopped by a signal";
        return out;
      }
      if (it == 0) {
        const MaterialStatus status = evaluate(dt, true, prescribed_gap(s));
        if (status != MaterialStatus::ok) {
          out.why = std::string("material call failed (") + to_string(status) + ")";
          return out;
        }
        apply_targets(s.P_target);
      } else if (!search_line(s, n, dt, out)) {
        return out;
      }
      bool reached = true;
      for (int c = 0; c < 9; ++c)
        if (!s.free[c] && Fbar(c / 3, c % 3) != s.target(c / 3, c % 3)) reached = false;
      err = error(s.free, s.P_target);
      out.residuals.push_back(err);
      if (!std::isfinite(err)) {
        out.why = "non-finite residual";
        return out;
      }
      // Convergence, or stagnation at the round-off floor of stresses ~ K (J − 1) (K/G up to 1.2e5):
      // the residual of a nearly incompressible phase cannot drop below ~eps K.
      const double noise = 64.0 * std::numeric_limits<double>::epsilon() * K_max *
                           (1.0 + Fbar.cwiseAbs().maxCoeff()) / stress_scale(s.free, s.P_target);
      if (reached && (err <= opt.tolerance || (it >= 2 && err <= noise))) return converged(out);
      if (it == opt.max_newton_iterations) break;
      if (reached) {
        if (first_err < 0.0) first_err = err;
        if (err > 1e6 * std::max(first_err, opt.tolerance)) {
          out.why = "Newton diverged";
          return out;
        }
      }
      if (!newton_direction(s, reached, it == 0, n)) {
        out.why = "singular tangent";
        return out;
      }
      ++out.newton_iterations;
    }
    out.why = "no convergence in " + std::to_string(opt.max_newton_iterations) + " Newton iterations (residual " +
              format_number(err) + ")";
    return out;
  }

  void commit() {
    ut_c = ut;
    Fbar_c = Fbar;
    internal_c = internal;
    if (!hist_old.empty()) hist_prev = hist_old;
    hist_old.swap(hist_new);
  }
  void restore() {
    ut = ut_c;
    Fbar = Fbar_c;
    internal = internal_c;
  }

  /// The macro F̄ of the output: the controlled F̄, or a plate's section mean of F (its normal column
  /// is the mean through-thickness stretch and shear, which the fluctuation carries).
  Mat3 output_F() const {
    if (!plate) return Fbar;
    return to_load((sums.phase_F[0] + sums.phase_F[1]) / cell_area);
  }

  RveStep record(double t, double angle0) const {
    return detail::record_step(t, angle0, output_F(), to_load(sums.P) / cell_area, sums,
                               [this](const Mat3& A) { return to_load(A); }, a0_load);
  }

  /// Element fields of the current (converged) state; history is not advanced (state_new scratch).
  FeFields fields(double dt) {
    FeFields f;
    f.F.assign(9 * std::size_t(ne), 0.0);
    f.P.assign(9 * std::size_t(ne), 0.0);
    f.sigma.assign(9 * std::size_t(ne), 0.0);
    f.von_mises.assign(ne, 0.0);
    f.J.assign(ne, 0.0);
    f.phase = mesh.phase;
    const Mat3 Fg = to_grid(Fbar);
    std::vector<double> scratch(std::size_t(std::max(state_size[0], state_size[1])) * omp_get_max_threads() + 1);
#pragma omp parallel for schedule(static)
    for (int e = 0; e < ne; ++e) {
      const int x = mesh.phase[e];
      const auto& el = mesh.elements[e];
      const Geometry& g = geo[e];
      Mat3 Fm = Mat3::Zero(), Pm = Mat3::Zero(), Sm = Mat3::Zero();
      double Jm = 0.0;
      double* hn = scratch.data() + std::size_t(omp_get_thread_num()) * std::max(state_size[0], state_size[1]);
      const double* in = internal.data() + std::size_t(kMaxInternal) * e;
      const int nbe = mixed[x] ? nb : 0;
      for (int q = 0; q < kQp; ++q) {
        Mat3 F = Fg;
        for (int a = 0; a < kNodes; ++a)
          for (int i = 0; i < 3; ++i)
            for (int J = 0; J < kDim; ++J) F(i, J) += ut[3 * el[a] + i] * g.dN[q](a, J);
        for (int i = 0; i < nbe; ++i) {
          F(i, 0) += in[i] * g.dB[q][0];
          F(i, 1) += in[i] * g.dB[q][1];
        }
        double p_q = in[nbe + np];
        if (np == 3) {
          const auto b = E::p1_basis(q);
          p_q = b[0] * in[nbe + 3] + b[1] * in[nbe + 4] + b[2] * in[nbe + 5];
        }
        Mat3 P;
        const int ss = state_size[x];
        // History: the converged step went from hist_prev over dt (hist_old is already its end state).
        const std::vector<double>& h = dt > 0.0 ? hist_prev : hist_old;
        mat[x]->evaluate(F, ss ? h.data() + hist_offset[e] + q * ss : nullptr, ss ? hn : nullptr, dt, P, nullptr);
        const double J = F.determinant();
        if (mixed[x]) P += (p_q - volumetric_dU(K_vol[x], J)) * J * F.inverse().transpose();
        const double w = g.w[q] / g.area;
        Fm += w * F;
        Pm += w * P;
        Sm += w * cauchy_from_piola(F, P);
        Jm += w * J;
      }
      Fm = to_load(Fm);
      Pm = to_load(Pm);
      Sm = to_load(Sm);
      const Mat3 dev = Sm - Sm.trace() / 3.0 * Mat3::Identity();
      f.von_mises[e] = std::sqrt(1.5 * ddot(dev, dev));
      f.J[e] = Jm;
      for (int c = 0; c < 9; ++c) {
        f.F[9 * e + c] = Fm(c / 3, c % 3);
        f.P[9 * e + c] = Pm(c / 3, c % 3);
        f.sigma[9 * e + c] = Sm(c / 3, c % 3);
      }
    }
    f.displacement.assign(3 * std::size_t(nn), 0.0);
    const Mat3 H = Fg - Mat3::Identity();
    for (int i = 0; i < nn; ++i) {
      const Vec3 y = E::position(mesh, i);
      const Vec3 u = H * y + Vec3(ut[3 * i], ut[3 * i + 1], ut[3 * i + 2]);
      for (int c = 0; c < 3; ++c) f.displacement[3 * i + c] = u[c];
    }
    return f;
  }

  // ---- statistics and the run loop (shared by both element families) ----
  int factorizations() const {
    int n = 0;
    if (cholmod) n += cholmod->times().factorizations;
    if (umfpack) n += umfpack->times().factorizations;
    return n;
  }
  std::array<double, 3> linear_seconds() const {
    std::array<double, 3> t{0.0, 0.0, 0.0};
    for (const auto* s : {cholmod.get(), umfpack.get()})
      if (s) {
        t[0] += s->times().analysis;
        t[1] += s->times().factorization;
        t[2] += s->times().solve;
      }
    return t;
  }
  std::size_t memory_bytes() const {
    std::size_t b = geo.size() * sizeof(Geometry) + lin_Kinv.size() * (sizeof(MatI) + sizeof(MatIq) + sizeof(VecI));
    b += (ut.size() * 2 + internal.size() * 4 + hist_old.size() * 3 + node_eq.size()) * sizeof(double);
    b += K.values.size() * (sizeof(double) + sizeof(int)) * 2;  // matrix + solver copy of the upper part
    b += 3 * std::size_t(n_eq) * sizeof(double);
    return b;
  }

  RveRunResult run(const MixedControl& control, const std::function<void(const RveStep&, const FeFields*)>& on_step,
                   const std::function<bool(double)>& want_fields) {
    control.validate();
    if (plate) rve::check_plate_control(control);
    const auto run_start = Clock::now();
    RveRunResult result;
    std::array<bool, 9> free{};
    for (int c = 0; c < 9; ++c) free[c] = control.kind[c] == ControlKind::stress;
    if (plate)
      for (int c : kPlateNormalColumn) free[c] = false;
    set_control(free);
    if (evaluate(0.0, false, Vec9::Zero()) != MaterialStatus::ok) throw ConvergenceError("material call failed at F = I");
    const double angle0 = fiber_angle_deg(Mat3::Identity(), a0_load);
    struct Engine {
      Model& m;
      const MixedControl& control;
      double angle0;
      const std::function<void(const RveStep&, const FeFields*)>& on_step;
      const std::function<bool(double)>& want_fields;
      detail::SubstepOutcome step(double t_new, double dt) { return m.step(control, t_new, dt); }
      void commit(double) { m.commit(); }
      void restore() { m.restore(); }
      RveStep record(double t) const { return m.record(t, angle0); }
      void emit(const RveStep& s, double dt) {
        if (!on_step) return;
        if (want_fields && want_fields(s.t)) {
          const FeFields f = m.fields(dt);
          on_step(s, &f);
        } else {
          on_step(s, nullptr);
        }
      }
    } engine{*this, control, angle0, on_step, want_fields};
    StepControlOptions steps;
    steps.max_cutbacks = opt.max_cutbacks;
    steps.max_step_seconds = opt.max_step_seconds;
    detail::run_output_steps(control, steps, engine, result, run_start);
    return result;
  }
};

}  // namespace

/// One of the two element families (the other pointer is empty).
struct FeRveSolver::Impl {
  std::unique_ptr<Model<TriElement>> tri;
  std::unique_ptr<Model<TetElement4>> tet4;
  std::unique_ptr<Model<TetElement14>> tet14;
  template <class F>
  decltype(auto) visit(F&& f) const {
    return tri ? f(*tri) : tet4 ? f(*tet4) : f(*tet14);
  }
};

FeRveSolver::FeRveSolver(SectionMesh mesh, MaterialPtr matrix, MaterialPtr fiber, double fiber_angle_deg,
                         const Mat3& load_frame, const FeSolverOptions& options)
    : impl_(std::make_unique<Impl>()) {
  impl_->tri = std::make_unique<Model<TriElement>>(std::move(mesh), std::move(matrix), std::move(fiber),
                                                   fiber_angle_deg, load_frame, options);
}
FeRveSolver::FeRveSolver(CellMesh mesh, MaterialPtr matrix, MaterialPtr fiber, double fiber_angle_deg,
                         const Mat3& load_frame, const FeSolverOptions& options)
    : impl_(std::make_unique<Impl>()) {
  if (options.tet_quadrature_points != 4 && options.tet_quadrature_points != 14)
    throw InputError("solver.tet_quadrature_points", std::to_string(options.tet_quadrature_points),
                     "must be 4 (degree-2 rule) or 14 (degree-5 rule)");
  if (options.tet_quadrature_points == 4)
    impl_->tet4 = std::make_unique<Model<TetElement4>>(std::move(mesh), std::move(matrix), std::move(fiber),
                                                      fiber_angle_deg, load_frame, options);
  else
    impl_->tet14 = std::make_unique<Model<TetElement14>>(std::move(mesh), std::move(matrix), std::move(fiber),
                                                        fiber_angle_deg, load_frame, options);
}
FeRveSolver::~FeRveSolver() = default;

bool FeRveSolver::is_3d() const { return !impl_->tri; }
const SectionMesh& FeRveSolver::mesh() const {
  if (!impl_->tri) throw std::logic_error("FeRveSolver::mesh(): the solver runs on a 3D cell mesh (cell_mesh())");
  return impl_->tri->mesh;
}
const CellMesh& FeRveSolver::cell_mesh() const {
  if (impl_->tri) throw std::logic_error("FeRveSolver::cell_mesh(): the solver runs on a section mesh (mesh())");
  return impl_->tet4 ? impl_->tet4->mesh : impl_->tet14->mesh;
}
int FeRveSolver::num_elements() const {
  return impl_->visit([](const auto& m) { return m.ne; });
}
int FeRveSolver::num_equations() const {
  return impl_->visit([](const auto& m) { return m.n_eq; });
}
double FeRveSolver::achieved_volume_fraction() const {
  return impl_->visit([](const auto& m) { return m.achieved_vf; });
}
int FeRveSolver::factorizations() const {
  return impl_->visit([](const auto& m) { return m.factorizations(); });
}
std::array<double, 3> FeRveSolver::linear_seconds() const {
  return impl_->visit([](const auto& m) { return m.linear_seconds(); });
}
double FeRveSolver::factorization_seconds() const {
  const auto t = linear_seconds();
  return t[0] + t[1] + t[2];
}
double FeRveSolver::assembly_seconds() const {
  return impl_->visit([](const auto& m) { return m.assembly_time; });
}
long FeRveSolver::matrix_nonzeros() const {
  return impl_->visit([](const auto& m) { return long(m.K.nnz()); });
}
std::string FeRveSolver::linear_solver() const {
  return impl_->visit([](const auto& m) { return m.last_solver; });
}
std::size_t FeRveSolver::memory_bytes() const {
  return impl_->visit([](const auto& m) { return m.memory_bytes(); });
}

RveRunResult FeRveSolver::run(const MixedControl& control,
                              const std::function<void(const RveStep&, const FeFields*)>& on_step,
                              const std::function<bool(double)>& want_fields) {
  if (impl_->tri) return impl_->tri->run(control, on_step, want_fields);
  if (impl_->tet4) return impl_->tet4->run(control, on_step, want_fields);
  return impl_->tet14->run(control, on_step, want_fields);
}

}  // namespace softhom::rve
