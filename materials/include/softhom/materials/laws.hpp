#pragma once
// The constitutive laws of spec §2–§4 (docs/model.md; "spec §N" is its section N). Units: MPa, mm, s.
// Every law shares the volumetric energy W_V(J) = (K/4)(J² − 1 − 2 ln J), so K is the small-strain
// bulk modulus for all of them.
#include <optional>
#include <vector>

#include "softhom/materials/hyperelastic.hpp"

namespace softhom {

/// Which invariant the HGO fiber energy uses (spec §2): the full I4 = a0·C a0 (recommended for
/// compressible use) or the isochoric Ī4 = J^(-2/3) I4 (dissertation, original HGO).
enum class FiberInvariant { full, isochoric };

struct FiberFamily {
  Vec3 direction{1.0, 0.0, 0.0};  ///< reference direction a0 (normalised on construction)
  double k1 = 0.0;                ///< stress-like [MPa]
  double k2 = 0.0;                ///< dimensionless
  /// Fiber dispersion of Gasser, Ogden & Holzapfel (2006), 0 ≤ κ ≤ 1/3: the family's invariant is
  /// κ I1 + (1 − 3κ) I4 (isochoric variant: of the isochoric invariants). 0 = perfectly aligned (HGO),
  /// 1/3 = isotropic distribution.
  double kappa = 0.0;
};

/// Compressible Gent matrix + any number of HGO fiber families (spec §2, dissertation eq. 2.4).
struct GentHGOParams {
  double G = 0.0;    ///< initial shear modulus
  double Jm = 0.0;   ///< locking parameter (Ī1 − 3 < Jm)
  double K = 0.0;    ///< bulk modulus
  std::vector<FiberFamily> fibers;
  FiberInvariant invariant = FiberInvariant::full;
  bool tension_only = true;  ///< a family contributes only while I*_i > 1
};

/// Transversely isotropic fiber composite (materials/src/fiber_composite.cpp): Gent + HGO plus, per fiber
/// family, a fiber–matrix shear term (GL/2)(I5 − I4²) and a transverse shear term GT (τ − 1),
/// τ = (I1 I4 − I5)/(2 J √I4), and a fiber term linear in the fiber stretch, (Ef/2)(√I4 − 1)². Small-strain
/// shear moduli: G + GL along the fibers, G + GT across them.
struct FiberCompositeParams {
  GentHGOParams base;  ///< the Gent matrix and the HGO families (at least one)
  double GL = 0.0;     ///< added longitudinal (fiber–matrix) shear modulus [MPa]
  double GT = 0.0;     ///< added transverse shear modulus [MPa]
  double Ef = 0.0;     ///< stretch-linear fiber term (Ef/2)(√I4 − 1)², tension and compression [MPa]
};

/// Energy form of the compressible neo-Hookean law. Both have the small-strain moduli (μ, K).
///   isochoric: W = (μ/2)(Ī1 − 3) + W_V(J)                       (spec §3, the default)
///   lame_log:  W = (μ/2)(I1 − 3 − 2 ln J) + (λ/2)(ln J)², λ = K − 2μ/3
///              (S = μ(I − C⁻¹) + λ ln J C⁻¹: the CompressibleNeoHookean of FANS, Bonet & Wood),
///              used to solve exactly the problem of that code in side-by-side runs.
enum class NeoHookeanForm { isochoric, lame_log };

/// Compressible neo-Hookean (form above; default W = (μ/2)(Ī1 − 3) + W_V(J)).
struct NeoHookeanParams {
  double mu = 0.0;
  double K = 0.0;
  NeoHookeanForm form = NeoHookeanForm::isochoric;
  static NeoHookeanParams from_young(double E, double nu) {
    return {E / (2.0 * (1.0 + nu)), E / (3.0 * (1.0 - 2.0 * nu))};
  }
};

/// Yeoh (3 terms): W = Σ_{i=1..3} C_i (Ī1 − 3)^i + W_V(J). Initial shear modulus 2 C1.
struct YeohParams {
  double C1 = 0.0, C2 = 0.0, C3 = 0.0;
  double K = 0.0;
};

/// Ogden (N terms, Abaqus convention of dissertation eq. 3.9):
/// W = Σ_i (2 μ_i / α_i²)(λ̄1^α_i + λ̄2^α_i + λ̄3^α_i − 3) + W_V(J). Initial shear modulus Σ μ_i.
struct OgdenParams {
  std::vector<double> mu, alpha;
  double K = 0.0;
};

/// One Prony term of D(t) = g∞ + Σ g_k exp(−t/τ_k).
struct PronyTerm {
  double g = 0.0;
  double tau = 0.0;
};
struct PronySeries {
  double g_inf = 1.0;
  std::vector<PronyTerm> terms;
};

// Factories. Parameters are assumed validated (see library.hpp for the validating front end).
ElasticLawPtr make_gent_hgo(const GentHGOParams& p);
ElasticLawPtr make_fiber_composite(const FiberCompositeParams& p);
ElasticLawPtr make_neo_hookean(const NeoHookeanParams& p);
ElasticLawPtr make_yeoh(const YeohParams& p);
ElasticLawPtr make_ogden(const OgdenParams& p);

/// Wraps an elastic law as a Material: the plain adapter when `prony` is empty (no history storage),
/// the QLV wrapper of spec §4 otherwise (deviatoric relaxation of S_D^e, exponential integrator).
MaterialPtr make_material(ElasticLawPtr law, const std::optional<PronySeries>& prony = std::nullopt);

}  // namespace softhom
