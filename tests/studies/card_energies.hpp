#pragma once
// Independent implementations of the strain energies that FEBio and Abaqus document for the material
// cards of studies/material_cards.hpp, written from their manuals' formulas (not from softhom's laws),
// with the first Piola stress by central differences of the energy in long double. The tests compare
// them with softhom's stresses at the same F.
//
// FEBio 4 (User Manual: "Gent", "Holzapfel-Gasser-Ogden", "uncoupled solid mixture", pressure_model):
//   W = -(G Jm/2) ln(1 - (Ī1 - 3)/Jm) + U(J) + Σ_HGO { c/2 (Ī1 - 3) + k1/(2k2) Σ_± [exp(k2 E±²) - 1] (E± ≥ 0) }
//   U(J) = K/4 (J² - 1 - 2 ln J) ("NIKE3D"),  E± = κ(Ī1 - 3) + (1 - 3κ)(Ī4± - 1),
//   a± = cos γ n1 ± sin γ n2 with n1 = a/|a|, n3 = a×d/|a×d|, n2 = n3×n1 (mat_axis type "vector").
// Abaqus (Analysis User's Guide, "Hyperelastic behavior of rubberlike materials", "Anisotropic
// hyperelastic behavior"):
//   Yeoh:      U = Σ_{i=1..3} C_i0 (Ī1 - 3)^i + Σ_{i=1..3} (1/D_i)(J - 1)^{2i}   (D_i = 0: term absent)
//   HOLZAPFEL: U = C10 (Ī1 - 3) + (1/D)((J² - 1)/2 - ln J) + k1/(2k2) Σ_α [exp(k2 <E_α>²) - 1],
//              E_α = κ(Ī1 - 3) + (1 - 3κ)(Ī4(αα) - 1), <x> = max(x, 0).
#include <cmath>
#include <functional>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace card_energies {

using LMat3 = Eigen::Matrix<long double, 3, 3>;
using LVec3 = Eigen::Matrix<long double, 3, 1>;
using Energy = std::function<long double(const LMat3&)>;

struct Kinematics {
  long double J, I1b;
  LMat3 Cb;  // isochoric C
};
inline Kinematics kinematics(const LMat3& F) {
  Kinematics k;
  k.J = F.determinant();
  k.Cb = std::pow(k.J, -2.0L / 3.0L) * (F.transpose() * F);
  k.I1b = k.Cb.trace();
  return k;
}

/// P = ∂W/∂F by central differences (h = 1e-6: truncation h² W''' ≈ 1e-12 K, rounding ε_ld W / h).
inline Eigen::Matrix3d piola_by_differences(const Energy& W, const Eigen::Matrix3d& F) {
  const long double h = 1e-6L;
  Eigen::Matrix3d P;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      LMat3 Fp = F.cast<long double>(), Fm = Fp;
      Fp(i, j) += h;
      Fm(i, j) -= h;
      P(i, j) = double((W(Fp) - W(Fm)) / (2.0L * h));
    }
  return P;
}

// --- FEBio -----------------------------------------------------------------------------------------

struct FebioHGO {
  long double c = 0, k1 = 0, k2 = 0, kappa = 0, gamma_deg = 0;
  LVec3 a{1, 0, 0}, d{0, 1, 0};
};
struct FebioCard {
  std::string top_type;
  long double k = 0;
  std::string pressure_model;
  long double G = 0, Jm = 0;
  std::vector<FebioHGO> fibers;
  long double g0 = 1;
  std::vector<long double> g, t;
};

inline long double gent_energy(long double G, long double Jm, long double I1b) {
  return -0.5L * G * Jm * std::log(1.0L - (I1b - 3.0L) / Jm);
}

inline long double hgo_fiber_energy(long double k1, long double k2, long double E) {
  if (!(E >= 0.0L)) return 0.0L;
  return k2 > 0 ? 0.5L * k1 / k2 * (std::exp(k2 * E * E) - 1.0L) : 0.5L * k1 * E * E;
}

inline Energy febio_energy(const FebioCard& c) {
  return [c](const LMat3& F) {
    const Kinematics k = kinematics(F);
    long double W = gent_energy(c.G, c.Jm, k.I1b) + 0.25L * c.k * (k.J * k.J - 1.0L - 2.0L * std::log(k.J));
    for (const auto& f : c.fibers) {
      const LVec3 n1 = f.a.normalized();
      const LVec3 n3 = f.a.cross(f.d).normalized();
      const LVec3 n2 = n3.cross(n1);
      const long double g = f.gamma_deg * 3.14159265358979323846264338327950288L / 180.0L;
      W += 0.5L * f.c * (k.I1b - 3.0L);
      for (int s : {1, -1}) {
        const LVec3 ar = std::cos(g) * n1 + static_cast<long double>(s) * std::sin(g) * n2;
        const long double I4b = ar.dot(k.Cb * ar);
        const long double E = f.kappa * (k.I1b - 3.0L) + (1.0L - 3.0L * f.kappa) * (I4b - 1.0L);
        W += hgo_fiber_energy(f.k1, f.k2, E);
      }
    }
    return W;
  };
}

/// Text between <tag> and </tag> (first occurrence at or after `from`), or "" when absent.
inline std::string xml_value(const std::string& text, const std::string& tag, std::size_t from = 0,
                             std::size_t* end = nullptr) {
  const std::string open = "<" + tag + ">", close = "</" + tag + ">";
  const std::size_t a = text.find(open, from);
  if (a == std::string::npos) return "";
  const std::size_t b = text.find(close, a);
  if (end) *end = b;
  return text.substr(a + open.size(), b - a - open.size());
}
inline LVec3 parse_vec(const std::string& s) {
  LVec3 v;
  char comma;
  std::istringstream in(s);
  in >> v[0] >> comma >> v[1] >> comma >> v[2];
  return v;
}

/// Reads a card written by febio_material_block (tags only; the XML well-formedness is checked by
/// the python3 xml.etree test).
inline FebioCard parse_febio_card(const std::string& text) {
  FebioCard c;
  const std::size_t body = text.find("<Material>");
  const std::smatch m = [&] {
    std::smatch r;
    static const std::regex type_re("<material id=\"1\" name=\"[^\"]*\" type=\"([^\"]+)\">");
    std::regex_search(text.begin() + long(body), text.end(), r, type_re);
    return r;
  }();
  c.top_type = m.size() > 1 ? m[1].str() : "";
  c.k = std::stold(xml_value(text, "k", body));
  c.pressure_model = xml_value(text, "pressure_model", body);
  const std::size_t gent = text.find("<solid type=\"Gent\">", body);
  c.G = std::stold(xml_value(text, "G", gent));
  c.Jm = std::stold(xml_value(text, "Jm", gent));
  if (c.top_type == "uncoupled viscoelastic") {
    c.g0 = std::stold(xml_value(text, "g0", body));
    for (int i = 1; i <= 6; ++i) {
      const std::string g = xml_value(text, "g" + std::to_string(i), body);
      if (g.empty()) break;
      c.g.push_back(std::stold(g));
      c.t.push_back(std::stold(xml_value(text, "t" + std::to_string(i), body)));
    }
  }
  for (std::size_t p = text.find("<solid type=\"Holzapfel-Gasser-Ogden\">", body); p != std::string::npos;
       p = text.find("<solid type=\"Holzapfel-Gasser-Ogden\">", p + 1)) {
    FebioHGO f;
    f.c = std::stold(xml_value(text, "c", p));
    f.k1 = std::stold(xml_value(text, "k1", p));
    f.k2 = std::stold(xml_value(text, "k2", p));
    f.kappa = std::stold(xml_value(text, "kappa", p));
    f.gamma_deg = std::stold(xml_value(text, "gamma", p));
    f.a = parse_vec(xml_value(text, "a", p));
    f.d = parse_vec(xml_value(text, "d", p));
    c.fibers.push_back(f);
  }
  return c;
}

// --- Abaqus ----------------------------------------------------------------------------------------

struct AbaqusCard {
  long double C10 = 0, C20 = 0, C30 = 0, D1 = 0, D2 = 0, D3 = 0;  // *HYPERELASTIC, YEOH
  bool holzapfel = false;
  long double h_C10 = 0, h_D = 0, k1 = 0, k2 = 0, kappa = 0;        // *ANISOTROPIC HYPERELASTIC, HOLZAPFEL
  std::vector<LVec3> directions;                                     // *ORIENTATION local directions
  std::vector<std::vector<long double>> prony;                       // *VISCOELASTIC lines (g, k, tau)
};

inline std::vector<long double> numbers(const std::string& line) {
  std::vector<long double> v;
  std::string s = line;
  for (char& ch : s)
    if (ch == ',') ch = ' ';
  std::istringstream in(s);
  long double x;
  while (in >> x) v.push_back(x);
  return v;
}

inline AbaqusCard parse_abaqus_card(const std::string& text) {
  AbaqusCard c;
  std::istringstream in(text);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);)
    if (l.rfind("**", 0) != 0) lines.push_back(l);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string& l = lines[i];
    if (l.rfind("*HYPERELASTIC, YEOH", 0) == 0) {
      const auto v = numbers(lines.at(i + 1));
      c.C10 = v.at(0), c.C20 = v.at(1), c.C30 = v.at(2), c.D1 = v.at(3), c.D2 = v.at(4), c.D3 = v.at(5);
    } else if (l.rfind("*ANISOTROPIC HYPERELASTIC, HOLZAPFEL", 0) == 0) {
      const auto v = numbers(lines.at(i + 1));
      c.holzapfel = true;
      c.h_C10 = v.at(0), c.h_D = v.at(1), c.k1 = v.at(2), c.k2 = v.at(3), c.kappa = v.at(4);
    } else if (l.rfind("*ORIENTATION", 0) == 0) {
      for (std::size_t j = i + 3; j < lines.size() && lines[j].rfind("*", 0) != 0; ++j) {
        const auto v = numbers(lines[j]);
        c.directions.push_back(LVec3(v.at(0), v.at(1), v.at(2)));
      }
    } else if (l.rfind("*VISCOELASTIC, TIME=PRONY", 0) == 0 && c.prony.empty()) {
      for (std::size_t j = i + 1; j < lines.size() && lines[j].rfind("*", 0) != 0; ++j) c.prony.push_back(numbers(lines[j]));
    }
  }
  return c;
}

inline Energy abaqus_energy(const AbaqusCard& c) {
  return [c](const LMat3& F) {
    const Kinematics k = kinematics(F);
    const long double x = k.I1b - 3.0L, dJ = k.J - 1.0L;
    long double U = c.C10 * x + c.C20 * x * x + c.C30 * x * x * x;
    const long double D[3] = {c.D1, c.D2, c.D3};
    for (int i = 0; i < 3; ++i)
      if (D[i] != 0.0L) U += std::pow(dJ, 2 * (i + 1)) / D[i];
    if (c.holzapfel) {
      U += c.h_C10 * x + (0.5L * (k.J * k.J - 1.0L) - std::log(k.J)) / c.h_D;
      for (const LVec3& a0 : c.directions) {
        const LVec3 a = a0.normalized();
        const long double E = c.kappa * x + (1.0L - 3.0L * c.kappa) * (a.dot(k.Cb * a) - 1.0L);
        const long double Ep = std::max(E, 0.0L);
        U += 0.5L * c.k1 / c.k2 * (std::exp(c.k2 * Ep * Ep) - 1.0L);
      }
    }
    return U;
  };
}

}  // namespace card_energies
