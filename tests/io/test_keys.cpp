// Key declarations: every refusal class names the field, the value as written and what was expected;
// a valid table fills exactly the declared members and nothing else.
#include <gtest/gtest.h>

#include <cstdint>

#include "softhom/core/keys.hpp"

using namespace softhom;

namespace {

enum class Mode { fast, careful };

struct Options {
  double tolerance = 1e-6;
  double ratio = 2.0;
  int grid = 64;
  int max_cutbacks = 12;
  std::uint64_t seed = 1;
  bool warm_start = true;
  std::string label = "none";
  Mode mode = Mode::fast;
  std::vector<double> weights{1.0, 2.0};
  std::vector<int> shape{8, 8};
  std::optional<double> cell_size;
  int untouched = 7;  // not declared: a read must never change it
};

const keys::KeyTable<Options>& table() {
  using O = Options;
  static const keys::KeyTable<Options> t = [] {
    keys::KeyTable<Options> k("solver", "test table");
    k.number("tolerance", &O::tolerance, keys::open_range(0, 1), "-", "relative tolerance")
        .number("ratio", &O::ratio, keys::at_least(1), "-", "a ratio")
        .integer("grid", &O::grid, keys::at_least(1), "-", "points per side")
        .integer("max_cutbacks", &O::max_cutbacks, keys::at_least(0), "-", "halvings")
        .renamed("cutbacks")
        .integer("seed", &O::seed, keys::at_least(0), "-", "random seed")
        .flag("warm_start", &O::warm_start, "start from the last step")
        .text("label", &O::label, "a name")
        .choice("mode", &O::mode, keys::Choices<Mode>{{{"fast", Mode::fast}, {"careful", Mode::careful}}, {{"quick", "fast"}}}, "how")
        .numbers("weights", &O::weights, keys::above(0), 1, 3, "-", "weights")
        .integers("shape", &O::shape, keys::at_least(1), 2, 3, "-", "grid shape")
        .number("cell_size", &O::cell_size, keys::above(0), "mm", "cell side");
    return k;
  }();
  return t;
}

/// The InputError message of reading `text` as [solver], or "" when it reads.
std::string refusal(const std::string& text) {
  try {
    const toml::table doc = toml::parse("[solver]\n" + text + "\n");
    Options o;
    table().read(*doc["solver"].as_table(), "solver", o);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Keys, ValidTableFillsExactlyTheDeclaredMembers) {
  const toml::table doc = toml::parse(
      "[solver]\ntolerance = 1e-9\nratio = 3\ngrid = 1e2\nmax_cutbacks = 0\nseed = 42\nwarm_start = false\n"
      "label = \"x\"\nmode = \"careful\"\nweights = [0.5, 1]\nshape = [4, 5, 6]\ncell_size = 2.5\n");
  Options o;
  const auto present = table().read(*doc["solver"].as_table(), "solver", o);
  EXPECT_EQ(present.size(), 11u);
  EXPECT_EQ(o.tolerance, 1e-9);  // exact: read without arithmetic
  EXPECT_EQ(o.ratio, 3.0);
  EXPECT_EQ(o.grid, 100);  // an integral float is an integer
  EXPECT_EQ(o.max_cutbacks, 0);
  EXPECT_EQ(o.seed, 42u);
  EXPECT_FALSE(o.warm_start);
  EXPECT_EQ(o.label, "x");
  EXPECT_EQ(o.mode, Mode::careful);
  EXPECT_EQ(o.weights, (std::vector<double>{0.5, 1.0}));
  EXPECT_EQ(o.shape, (std::vector<int>{4, 5, 6}));
  ASSERT_TRUE(o.cell_size);
  EXPECT_EQ(*o.cell_size, 2.5);
  EXPECT_EQ(o.untouched, 7);
}

TEST(Keys, AbsentKeysKeepTheDefaults) {
  const toml::table doc = toml::parse("[solver]\ngrid = 32\n");
  Options o;
  table().read(*doc["solver"].as_table(), "solver", o);
  const Options d;
  EXPECT_EQ(o.grid, 32);
  EXPECT_EQ(o.tolerance, d.tolerance);
  EXPECT_EQ(o.weights, d.weights);
  EXPECT_FALSE(o.cell_size);
}

TEST(Keys, WrongTypeIsRefusedNeverDefaulted) {
  EXPECT_EQ(refusal("warm_start = \"no\""), "solver.warm_start = \"no\": must be true or false");
  EXPECT_EQ(refusal("tolerance = \"1e-6\""), "solver.tolerance = \"1e-6\": must be a number");
  EXPECT_EQ(refusal("label = 3"), "solver.label = 3: must be a string");
  EXPECT_EQ(refusal("weights = 0.5"), "solver.weights = 0.5: must be a list [...]");
}

TEST(Keys, IntegersOutsideTheirTypeOrRangeAreRefused) {
  EXPECT_NE(refusal("grid = 1e12").find("solver.grid = 1e+12: must be a whole number from"), std::string::npos);
  EXPECT_NE(refusal("shape = [8, 3e9]").find("solver.shape[1] = 3e+09: must be a whole number from"), std::string::npos);
  EXPECT_NE(refusal("max_cutbacks = 1e12").find("solver.max_cutbacks = 1e+12"), std::string::npos);
  EXPECT_EQ(refusal("seed = -1"), "solver.seed = -1: must be >= 0");
  EXPECT_NE(refusal("seed = 1e300").find("solver.seed = 1e+300: must be a whole number"), std::string::npos);
  EXPECT_EQ(refusal("grid = 0.5"), "solver.grid = 0.5: must be a whole number");
  EXPECT_EQ(refusal("grid = -16"), "solver.grid = -16: must be >= 1");
  EXPECT_EQ(refusal("grid = nan"), "solver.grid = nan: must be a whole number");
  EXPECT_EQ(refusal("shape = [8, 0]"), "solver.shape[1] = 0: must be >= 1");
}

TEST(Keys, NumbersMustBeFiniteAndInRange) {
  EXPECT_EQ(refusal("tolerance = 1"), "solver.tolerance = 1: must lie in (0, 1)");
  EXPECT_EQ(refusal("tolerance = 0"), "solver.tolerance = 0: must lie in (0, 1)");
  EXPECT_EQ(refusal("tolerance = nan"), "solver.tolerance = nan: must be a finite number");
  EXPECT_EQ(refusal("ratio = inf"), "solver.ratio = inf: must be a finite number");
  EXPECT_EQ(refusal("ratio = 0.999"), "solver.ratio = 0.999: must be >= 1");
  EXPECT_EQ(refusal("ratio = 1"), "");  // closed end
  EXPECT_EQ(refusal("cell_size = 0"), "solver.cell_size = 0: must be > 0");
}

TEST(Keys, ListsCheckLengthAndEachEntry) {
  EXPECT_EQ(refusal("weights = [1, -2]"), "solver.weights[1] = -2: must be > 0");
  EXPECT_EQ(refusal("weights = [1, 2, 3, 4]"), "solver.weights = [1, 2, 3, 4]: must be a list of 1 to 3 numbers");
  EXPECT_EQ(refusal("shape = [8]"), "solver.shape = [8]: must be a list of 2 to 3 integers");
  EXPECT_EQ(refusal("weights = [1, \"a\"]"), "solver.weights[1] = \"a\": must be a number");
}

TEST(Keys, UnknownKeysSuggestTheClosestName) {
  EXPECT_EQ(refusal("tolerence = 1e-6"), "solver.tolerence = 1e-06: unknown key (did you mean 'tolerance'?)");
  EXPECT_EQ(refusal("max_cutback = 3"), "solver.max_cutback = 3: unknown key (did you mean 'max_cutbacks'?)");
  EXPECT_EQ(refusal("completely_different = 3"), "solver.completely_different = 3: unknown key");
}

TEST(Keys, RenamedKeysAndValuesNameTheNewSpelling) {
  EXPECT_EQ(refusal("cutbacks = 3"), "solver.cutbacks = 3: renamed to solver.max_cutbacks");
  EXPECT_EQ(refusal("mode = \"quick\""), "solver.mode = \"quick\": renamed to \"fast\"");
  EXPECT_EQ(refusal("mode = \"carefull\""), "solver.mode = \"carefull\": must be \"fast\" or \"careful\" (did you mean 'careful'?)");
}

TEST(Keys, StringsRefuseControlCharacters) {
  EXPECT_EQ(refusal("label = \"a\\u0000b\""), "solver.label = \"a\\x00b\": must not contain NUL or control characters");
  EXPECT_EQ(refusal("label = \"a\\tb\""), "solver.label = \"a\\x09b\": must not contain NUL or control characters");
}

TEST(Keys, RequiredKeysAreMissingByName) {
  struct R {
    double g = 0.0;
  };
  keys::KeyTable<R> t("visco", "");
  t.number("g", &R::g, keys::closed_range(0, 1), "-", "relative modulus").required();
  const toml::table doc = toml::parse("[visco]\n");
  R r;
  try {
    t.read(*doc["visco"].as_table(), "visco", r);
    FAIL() << "read without a required key";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "visco.g: missing: relative modulus");
  }
}

TEST(Keys, DescribePrintsDefaultsFromTheStruct) {
  const keys::TableDoc d = table().describe();
  EXPECT_EQ(d.path, "solver");
  ASSERT_EQ(d.keys.size(), 11u);
  auto row = [&](const std::string& name) {
    for (const auto& k : d.keys)
      if (k.name == name) return k;
    ADD_FAILURE() << name;
    return keys::KeyDoc{};
  };
  EXPECT_EQ(row("tolerance").default_value, "1e-06");
  EXPECT_EQ(row("tolerance").range, "(0, 1)");
  EXPECT_EQ(row("grid").default_value, "64");
  EXPECT_EQ(row("grid").type, "integer");
  EXPECT_EQ(row("warm_start").default_value, "true");
  EXPECT_EQ(row("mode").default_value, "\"fast\"");
  EXPECT_EQ(row("mode").range, "\"fast\", \"careful\"");
  EXPECT_EQ(row("weights").default_value, "[1, 2]");
  EXPECT_EQ(row("cell_size").default_value, "unset");
  EXPECT_EQ(row("cell_size").unit, "mm");
  EXPECT_EQ(row("max_cutbacks").renamed_from, std::vector<std::string>{"cutbacks"});
}

TEST(Keys, IncludedTablesReadIntoTheMember) {
  struct Outer {
    Options inner;
    double extra = 0.0;
  };
  keys::KeyTable<Outer> t("outer", "");
  t.include(table(), &Outer::inner).number("extra", &Outer::extra, keys::any_value(), "-", "");
  const toml::table doc = toml::parse("[outer]\ngrid = 16\nextra = -1\n");
  Outer o;
  t.read(*doc["outer"].as_table(), "outer", o);
  EXPECT_EQ(o.inner.grid, 16);
  EXPECT_EQ(o.extra, -1.0);
  EXPECT_EQ(t.describe().keys.size(), 12u);
}

TEST(Keys, ChoiceWithoutOldSpellings) {
  struct C {
    Mode mode = Mode::careful;
  };
  keys::KeyTable<C> t("c", "");
  t.choice("mode", &C::mode, {{"fast", Mode::fast}, {"careful", Mode::careful}}, "how");
  const toml::table doc = toml::parse("[c]\nmode = \"fast\"\n");
  C c;
  t.read(*doc["c"].as_table(), "c", c);
  EXPECT_EQ(c.mode, Mode::fast);
  EXPECT_EQ(t.describe().keys.front().default_value, "\"careful\"");
}

TEST(Keys, EditDistance) {
  EXPECT_EQ(keys::edit_distance("kitten", "sitting"), 3u);
  EXPECT_EQ(keys::edit_distance("", "abc"), 3u);
  EXPECT_EQ(keys::edit_distance("same", "same"), 0u);
}
