// `softhom macro` names its linear-solver route, the preconditioner and their counts in summary.json.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "app/cli_helpers.hpp"

using namespace softhom::test;

namespace {

/// A 2 × 2 × 1 hex8 ecoflex block (three-field elements) stretched in two steps, with `solver` keys.
std::string stretched_block(const std::string& solver) {
  return "[geometry]\ntype = \"plate\"\nsize = [2.0, 2.0, 0.5]\ncells = [2, 2, 1]\n"
         "[material]\npreset = \"ecoflex\"\n"
         "[load]\ncontrol = \"stretch\"\npath = [[0.0, 1.0], [1.0, 1.2]]\nsteps = 2\n"
         "[output]\nfields = false\n"
         "[solver]\n" +
         solver;
}

nlohmann::json run_block(const std::string& name, const std::string& solver) {
  const auto out = fresh_dir(name);
  const auto r = run_softhom("macro " + write_temp_scene(name, stretched_block(solver)) + " --out " + out.string() + " -q");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(out / "summary.json");
  return nlohmann::json::parse(in);
}

}  // namespace

TEST(MacroSummaryCli, NamesTheRouteAndPreconditioner) {
  // Below auto's PETSc sizes: CHOLMOD, its factor a direct solve (a fresh factor per tangent of this
  // small, symmetric system: no GMRES), one factorization per Newton iteration at least.
  const nlohmann::json direct = run_block("summary-direct", "");
  ASSERT_TRUE(direct.contains("linear_solver")) << direct.dump();
  const nlohmann::json& d = direct["linear_solver"];
  EXPECT_EQ(d["route"], "cholmod");
  EXPECT_EQ(d["preconditioner"], "sparse-factor");
  EXPECT_EQ(d["krylov_iterations"], 0);
  EXPECT_GE(d["factorizations"].get<int>(), direct["newton_iterations"].get<int>());
  EXPECT_GE(d["solves"].get<int>(), direct["newton_iterations"].get<int>());
  // PETSc on the hex mesh with three-field elements: GMRES with the (u, p) field split and BoomerAMG on
  // the displacement block, a preconditioner set up per tangent.
  const nlohmann::json split = run_block("summary-petsc", "linear_solver = \"petsc\"\n");
  const nlohmann::json& s = split["linear_solver"];
  EXPECT_EQ(s["route"], "petsc");
  EXPECT_EQ(s["preconditioner"], "field-split-boomeramg");
  EXPECT_NE(s["description"].get<std::string>().find("fieldsplit"), std::string::npos) << s.dump();
  EXPECT_GT(s["krylov_iterations"].get<int>(), 0);
  EXPECT_GE(s["factorizations"].get<int>(), 1);
  // MUMPS by the typed key, applied by PETSc calls (not the options string).
  const nlohmann::json lu = run_block("summary-lu", "linear_solver = \"petsc\"\npetsc_preconditioner = \"lu\"\n");
  EXPECT_EQ(lu["linear_solver"]["preconditioner"], "mumps-lu");
  EXPECT_NE(lu["linear_solver"]["description"].get<std::string>().find("+ lu"), std::string::npos) << lu.dump();
}
