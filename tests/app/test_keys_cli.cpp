// `softhom keys` and `--print-default`: docs/keys.md is exactly what the declarations print, the
// embedded default scenes come out verbatim, and the front ends refuse bad keys by name (exit 2).
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "app/cli_helpers.hpp"

using softhom::test::fresh_dir;
using softhom::test::run_softhom;
using softhom::test::write_temp_scene;

namespace {
std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}
}  // namespace

TEST(KeysCli, DocsKeysMdMatchesTheDeclarations) {
  const auto r = run_softhom("keys --markdown all");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string committed = slurp(std::string(SOFTHOM_SOURCE_DIR) + "/docs/keys.md");
  // Exact equality: any change of a declaration must come with the regenerated file.
  EXPECT_TRUE(r.output == committed)
      << "docs/keys.md differs from the declarations: regenerate it with\n  softhom keys --markdown all > docs/keys.md";
}

TEST(KeysCli, ListsEveryTableOfASubcommand) {
  const auto r = run_softhom("keys rve");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* s : {"[microstructure]", "[microstructure.image]", "[phases.<name>]", "[load]", "[output]",
                        "[solver (engine = \"fft\")]", "[solver (engine = \"fe\")]", "tolerance (number) = 1e-07  in (0, 1)"})
    EXPECT_NE(r.output.find(s), std::string::npos) << s;
  const auto bad = run_softhom("keys nonsense");
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("keys = nonsense: unknown subcommand"), std::string::npos) << bad.output;
}

TEST(KeysCli, PrintDefaultWritesTheEmbeddedScene) {
  for (const auto& [command, stem] : {std::pair{"point", "point_uniaxial_ecoflex"}, std::pair{"rve", "rve_homogeneous"}}) {
    const auto r = run_softhom(std::string(command) + " --print-default");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_EQ(r.output, slurp(softhom::test::scene(stem))) << command;
  }
  EXPECT_EQ(run_softhom("sweep --print-default").exit_code, 2);
}

TEST(KeysCli, BadKeysExitWithTheirName) {
  const std::string point = "[material]\npreset = \"ecoflex\"\n[load]\ntype = \"uniaxial\"\nstretch = 1.2\nsteps = 2\n";
  struct Case {
    std::string extra, message;
  };
  for (const Case& c : {Case{"[solver]\nmax_iterations = 5\n", "solver.max_iterations = 5: renamed to solver.max_newton_iterations"},
                        Case{"[solver]\nmax_cutbacks = 1e12\n", "solver.max_cutbacks = 1e+12: must lie in [0, 60]"},
                        Case{"[solver]\ntolerence = 1e-6\n", "(did you mean 'tolerance'?)"}}) {
    const auto r = run_softhom("point " + write_temp_scene("keys-point", point + c.extra) + " -q --out " +
                               fresh_dir("keys-point").string());
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find(c.message), std::string::npos) << r.output;
  }
}
