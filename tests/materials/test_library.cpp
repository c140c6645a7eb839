// Parameter sets of spec §6 and validation errors that name the field.
#include <gtest/gtest.h>

#include "softhom/materials/errors.hpp"
#include "softhom/materials/library.hpp"

using namespace softhom;

namespace {
std::string error_of(const MaterialSpec& s) {
  try {
    build_material(s);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(MaterialLibrary, EveryPresetBuildsWithItsSmallStrainModuli) {
  for (const auto& name : preset_names()) {
    MaterialSpec s = preset_spec(name);
    if (!s.gent.fibers.empty()) s.gent.fibers.front().direction = Vec3::UnitX();
    const auto m = build_material(s);
    EXPECT_GT(m->initial_shear_modulus(), 0.0) << name;
    EXPECT_GT(m->initial_bulk_modulus(), 0.0) << name;
  }
  EXPECT_DOUBLE_EQ(build_material(preset_spec("ecoflex"))->initial_shear_modulus(), 0.017);
  // glass: E = 10, ν = 0.3 → μ = 10 / 2.6, K = 10 / 1.2
  EXPECT_NEAR(build_material(preset_spec("glass"))->initial_shear_modulus(), 10.0 / 2.6, 1e-12);
  EXPECT_NEAR(build_material(preset_spec("glass"))->initial_bulk_modulus(), 10.0 / 1.2, 1e-12);
  EXPECT_THROW(preset_spec("rubber"), InputError);
}

TEST(MaterialLibrary, InvalidParametersNameTheField) {
  MaterialSpec s = preset_spec("ecoflex", "phases.matrix");
  s.gent.G = -1.0;
  EXPECT_NE(error_of(s).find("phases.matrix.G = -1"), std::string::npos) << error_of(s);
  s = preset_spec("ecoflex");
  s.gent.Jm = 0.0;
  EXPECT_NE(error_of(s).find("material.Jm"), std::string::npos);
  s = preset_spec("ecoflex");
  s.gent.K = 0.0;
  EXPECT_NE(error_of(s).find("material.K"), std::string::npos);
  s = preset_spec("ecoflex");
  s.gent.fibers = {{Vec3::Zero(), 0.8, 18.0}};
  EXPECT_NE(error_of(s).find("material.fibers[0].direction"), std::string::npos);
  s = preset_spec("ecoflex");
  s.prony = PronySeries{1.5, {}};
  EXPECT_NE(error_of(s).find("material.viscoelastic.g_inf = 1.5"), std::string::npos);
  s.prony = PronySeries{0.5, {{0.3, 1.0}}};
  EXPECT_NE(error_of(s).find("sum to 1"), std::string::npos);
  s.prony = PronySeries{0.5, {{0.5, -1.0}}};
  EXPECT_NE(error_of(s).find("material.viscoelastic.terms[0].tau"), std::string::npos);
  s = preset_spec("cpasmo-ogden");
  s.ogden.alpha.pop_back();
  EXPECT_NE(error_of(s).find("material.alpha"), std::string::npos);
}

TEST(MaterialLibrary, ElasticMaterialsStoreNoHistory) {
  EXPECT_EQ(build_material(preset_spec("ecoflex"))->state_size(), 0);
  MaterialSpec s = preset_spec("ecoflex");
  s.prony = PronySeries{0.5, {{0.3, 1.0}, {0.2, 10.0}}};
  EXPECT_GT(build_material(s)->state_size(), 0);
}
