// The built-in contributions of model.hpp: prescribed displacements, follower pressures, nodal forces
// and the cavity-volume control, each adding its residual and tangent through the AssemblySink.
#include <array>
#include <tuple>
#include <type_traits>

#include "softhom/fe/model.hpp"
#include "softhom/fe/tet10_element.hpp"

namespace softhom::fe {
namespace {

/// The pressure p a(x) of quads or 6-node triangles (nf nodes per face) on the solid, with the load
/// stiffness pk ∂a/∂x (pk: the pressure of the tangent) and, with `border`, the enclosed-volume
/// constraint of the cavity: ∂R/∂p = a, ∂V/∂u and V (see CavityControl).
template <class Faces>
void add_faces(const Mesh& mesh, const Iterate& it, const Faces& faces, const Vec3& mask, double p, double pk,
               bool border, AssemblySink& sink) {
  constexpr int nf = std::tuple_size_v<typename Faces::value_type>;
  static_assert(nf == 4 || nf == 6);
  using FaceVec = std::conditional_t<nf == 4, Vec12, Vec18>;
  using FaceMat = std::conditional_t<nf == 4, Mat12, Mat18>;
  FaceVec a, dflux, r, g;
  FaceMat da, k;
  std::array<int, 3 * nf> dofs;
  const bool tangent = sink.tangent() && pk != 0.0;
  for (const auto& q : faces) {
    std::conditional_t<nf == 4, Mat43, Mat63> xe;
    for (int n = 0; n < nf; ++n) xe.row(n) = it.position(mesh, q[n]).transpose();
    double flux = 0.0;
    if constexpr (nf == 4) quad4_pressure(xe, mask, a, sink.tangent() ? &da : nullptr, flux, border ? &dflux : nullptr);
    else tri6_pressure(xe, mask, a, sink.tangent() ? &da : nullptr, flux, border ? &dflux : nullptr);
    for (int n = 0; n < nf; ++n)
      for (int i = 0; i < 3; ++i) dofs[3 * n + i] = 3 * q[n] + i;
    r = p * a;
    sink.add_residual(3 * nf, dofs.data(), r.data());
    if (border) {
      sink.add_constraint_value(-flux / mask.sum());
      g = -dflux / mask.sum();
      sink.add_border(3 * nf, dofs.data(), a.data(), g.data());
    }
    if (!tangent) continue;
    k = pk * da;
    sink.add_tangent(3 * nf, dofs.data(), 3 * nf, dofs.data(), k.data());
  }
}

template <class Faces>
void declare_faces(const Faces& faces, Couplings& couplings) {
  for (const auto& q : faces) couplings.add(q.data(), int(q.size()));
}

}  // namespace

void DirichletGroup::prescribe(double t, const std::function<void(int, double)>& set) const {
  const double v = value(t);
  for (std::size_t k = 0; k < dofs.size(); ++k) set(dofs[k], (scale.empty() ? 1.0 : scale[k]) * v);
}

void PressureLoad::declare_couplings(Couplings& couplings) const {
  declare_faces(faces, couplings);
  declare_faces(tris, couplings);
}

MaterialStatus PressureLoad::assemble(const Mesh& mesh, const Iterate& it, AssemblySink& sink) const {
  const double p = pressure(it.t), pk = pressure(it.t_stiffness);
  add_faces(mesh, it, faces, Vec3::Ones(), p, pk, false, sink);
  add_faces(mesh, it, tris, Vec3::Ones(), p, pk, false, sink);
  return MaterialStatus::ok;
}

MaterialStatus NodalLoad::assemble(const Mesh&, const Iterate& it, AssemblySink& sink) const {
  const double v = value(it.t);
  for (std::size_t k = 0; k < dofs.size(); ++k) {
    const double r = -(scale[k] * v);
    sink.add_residual(1, &dofs[k], &r);
  }
  return MaterialStatus::ok;
}

void CavityControl::declare_couplings(Couplings& couplings) const {
  declare_faces(faces, couplings);
  declare_faces(tris, couplings);
}

MaterialStatus CavityControl::assemble(const Mesh& mesh, const Iterate& it, AssemblySink& sink) const {
  add_faces(mesh, it, faces, mask, it.bordered, it.bordered, true, sink);
  add_faces(mesh, it, tris, mask, it.bordered, it.bordered, true, sink);
  return MaterialStatus::ok;
}

}  // namespace softhom::fe
