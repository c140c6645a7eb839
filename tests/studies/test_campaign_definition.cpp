// Campaign definitions: declared keys (warm_start must be a flag), every named definition validated
// whether a case uses it or not, a bound on the number of cases, names without control characters,
// and every shipped campaign expands.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "softhom/io/scene.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/studies/campaign.hpp"
#include "softhom/studies/campaign_definition.hpp"
#include "studies/studies_test_helpers.hpp"

namespace fs = std::filesystem;
using namespace softhom;
using namespace softhom::studies;
using softhom::studies::testing::expand;

namespace {

const char* kOne = R"(
[base.solver]
tolerance = 1e-6
[base.microstructure]
grid = [8, 8]
[loads.t12]
type = "uniaxial"
stretch = 1.2
steps = 2
[sweep]
matrix = ["pdms"]
angle = [30, 60]
load = ["t12"]
)";

std::string error_of(const std::string& text) {
  try {
    expand(text);
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

}  // namespace

TEST(CampaignDefinition, EveryShippedCampaignExpands) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(fs::path(SOFTHOM_SOURCE_DIR) / "studies/campaigns")) {
    if (e.path().extension() != ".toml") continue;
    SCOPED_TRACE(e.path().filename().string());
    Campaign c;
    EXPECT_NO_THROW(c = expand_campaign(io::load_scene(e.path()), e.path().parent_path()));
    EXPECT_FALSE(c.cases.empty());
    ++n;
  }
  EXPECT_GE(n, 6);
}

TEST(CampaignDefinition, WarmStartIsAFlag) {
  EXPECT_TRUE(expand(kOne).warm_start);
  EXPECT_FALSE(expand(std::string(kOne) + "[campaign]\nwarm_start = false\n").warm_start);
  const std::string msg = error_of(std::string(kOne) + "[campaign]\nwarm_start = \"no\"\n");
  EXPECT_NE(msg.find("campaign.warm_start = \"no\": must be true or false"), std::string::npos) << msg;
  EXPECT_NE(error_of(std::string(kOne) + "[campaign]\nwarmstart = false\n").find("did you mean 'warm_start'"),
            std::string::npos);
}

TEST(CampaignDefinition, UnusedDefinitionsAreValidated) {
  // Only t12 and pdms are used; the typos in the others must surface now.
  std::string msg = error_of(std::string(kOne) + "[loads.spare]\ntype = \"uniaxial\"\nstretch = 1.3\nstpes = 2\n");
  EXPECT_NE(msg.find("loads.spare"), std::string::npos) << msg;
  EXPECT_NE(msg.find("stpes"), std::string::npos) << msg;
  msg = error_of(std::string(kOne) + "[matrices.soft]\nlaw = \"gent\"\nG = 0.01\nJm = -3\nK = 10\n");
  EXPECT_NE(msg.find("matrices.soft"), std::string::npos) << msg;
  EXPECT_NE(msg.find("Jm"), std::string::npos) << msg;
  msg = error_of(std::string(kOne) + "[sections.thin]\nshape = \"circle\"\nradus = 0.1\n");
  EXPECT_NE(msg.find("sections.thin.radus"), std::string::npos) << msg;
  msg = error_of(std::string(kOne) + "[sections.thin]\nshape = \"circle\"\nradius = -0.1\n");
  EXPECT_NE(msg.find("sections.thin"), std::string::npos) << msg;
  // A valid unused definition is fine and adds no case.
  EXPECT_EQ(expand(std::string(kOne) + "[loads.spare]\ntype = \"uniaxial\"\nstretch = 1.3\nsteps = 2\n").cases.size(), 2u);
}

TEST(CampaignDefinition, TooManyCasesAreRefusedWithACount) {
  // 10 x 100 x 100 x 10 = 1e6 cases: refused before any case scene is built.
  std::string text = "[sweep]\nmatrix = [\"pdms\"]\nload = [\"tension\"]\n";
  auto list = [](int n, double step) {
    std::string s = "[";
    for (int i = 0; i < n; ++i) s += (i ? ", " : "") + format_number(step * (i + 1));
    return s + "]";
  };
  text += "angle = " + list(100, 0.5) + "\nvolume_fraction = " + list(100, 0.001) + "\nresolution = " + list(10, 8) +
          "\narrangement = " + "[\"square\", \"hexagonal\", \"a\", \"b\", \"c\", \"d\", \"e\", \"f\", \"g\", \"h\"]\n";
  const std::string msg = error_of(text);
  EXPECT_NE(msg.find("sweep = 1e+06 cases: more than 1e+05 cases"), std::string::npos) << msg;
  EXPECT_NE(msg.find("core-hours"), std::string::npos) << msg;
}

TEST(CampaignDefinition, NamesWithControlCharactersAreRefused) {
  std::string msg = error_of(std::string(kOne) + "[[cases]]\nname = \"a\\u0000b\"\nmatrix = \"pdms\"\nload = \"t12\"\n");
  EXPECT_NE(msg.find("cases[0].name"), std::string::npos) << msg;
  EXPECT_NE(msg.find("control characters"), std::string::npos) << msg;
  msg = error_of(std::string(kOne) + "[loads.\"t\\u0007\"]\ntype = \"uniaxial\"\nstretch = 1.2\n");
  EXPECT_NE(msg.find("control characters"), std::string::npos) << msg;
  msg = error_of("[sweep]\nmatrix = [\"pd\\nms\"]\nload = [\"tension\"]\n");
  EXPECT_NE(msg.find("sweep.matrix[0]"), std::string::npos) << msg;
}

TEST(CampaignDefinition, KeyTablesForTheSweepCommand) {
  const std::vector<keys::TableDoc> tables = campaign_tables();
  ASSERT_GE(tables.size(), 2u);
  EXPECT_EQ(tables[1].path, "campaign");
  EXPECT_EQ(tables[1].keys.at(0).name, "warm_start");
  EXPECT_EQ(tables[1].keys.at(0).default_value, "true");
}
