// Campaign cases on the FE engine ([solver] engine = "fe"): a section cell and a plate cell through the
// campaign API give the FE solver's rows for the same scene (the setup `softhom rve` uses), FFT and FE
// cases share one store, a finished FE case is skipped on a rerun, FE chains warm-start, and bad FE
// keys are refused before anything runs, naming the case and the key; FE cases of concurrent jobs
// give the lone run's numbers. Coarse PDMS cells (mesh_size = cell side / 3, 1-2 load steps) keep
// each test well under 2 s.
#include <gtest/gtest.h>

#include <omp.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "softhom/materials/errors.hpp"
#include "softhom/rve/fe_solver.hpp"
#include "softhom/studies/campaign.hpp"
#include "softhom/studies/rve_fe_scene.hpp"
#include "softhom/studies/rve_scene.hpp"
#include "studies/studies_test_helpers.hpp"

namespace fs = std::filesystem;
using namespace softhom;
using namespace softhom::studies;
using softhom::studies::testing::expand;
using softhom::studies::testing::fresh_dir;

namespace {

// PDMS + glass (VF 0.23, cell side 0.739 mm): a periodic section in uniaxial tension and the plate cell
// (free faces) in membrane tension along e1.
const char* kCellAndLoads = R"(
[base.microstructure]
shape = "circle"
radius = 0.2
[loads.pull]
type = "uniaxial"
stretch = 1.1
steps = 2
[loads.membrane]
type = "mixed"
F = [[1.1, 0.0, "free"], ["free", "free", "free"], [0.0, 0.0, "free"]]
path = 1.0
steps = 1
)";

/// The coarse FE mesh (mesh_size = cell side / 3).
const std::string kFeSolver = "engine = \"fe\", mesh_size = 0.25, interface_size = 0.1";

/// The section and the plate case; `solver` (when given) is merged into each one's [solver].
std::string section_and_plate(const std::string& solver) {
  const std::string merged = solver.empty() ? "" : "solver = {" + solver + "}";
  return "[[cases]]\nname = \"section\"\nmatrix = \"pdms\"\nangle = 30\nload = \"pull\"\n" +
         (merged.empty() ? "" : "override = {" + merged + "}\n") +
         "[[cases]]\nname = \"plate\"\nmatrix = \"pdms\"\nangle = 45\nload = \"membrane\"\noverride = {" +
         (merged.empty() ? "" : merged + ", ") + "microstructure = {cell = \"plate\"}}\n";
}

/// Both cases on the FE engine of [base.solver].
std::string fe_campaign() {
  return std::string(kCellAndLoads) + "[base]\nsolver = {" + kFeSolver + ", tolerance = 1e-8}\n" + section_and_plate("");
}

SweepOptions one_thread() {
  SweepOptions o;
  o.jobs = 1;
  o.threads = 1;  // one OpenMP thread: the same sums as the direct run below
  o.quiet = true;
  return o;
}

/// The FE solver's rows for a scene, set up as `softhom rve` sets it up (parse, mesh, solver), on one thread.
std::vector<double> fe_solver_rows(const toml::table& scene) {
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const FeRveSetup setup = parse_fe_rve_setup(scene, true);
  const auto solver = make_fe_rve_solver(mesh_fe_rve(setup), setup);
  const rve::RveRunResult result = solver->run(setup.control);
  omp_set_num_threads(threads);
  EXPECT_TRUE(result.completed) << result.error;
  std::vector<double> rows;
  for (const auto& s : result.steps) {
    const auto row = rve_response_row(s);
    rows.insert(rows.end(), row.begin(), row.end());
  }
  return rows;
}

/// Largest difference of two row tables relative to the largest stress magnitude of `b`.
double max_relative_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double scale = 0.0, diff = 0.0;
  for (double v : b) scale = std::max(scale, std::abs(v));
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) diff = std::max(diff, std::abs(a[i] - b[i]));
  return diff / scale;
}

std::string refused_field(const std::string& text) {
  try {
    expand(text);
  } catch (const InputError& e) {
    return e.field();
  }
  return "(accepted)";
}

}  // namespace

// The campaign runs each FE case through the same setup, mesh and solver as `softhom rve` on its scene:
// the stored rows are the solver's to 1e-10 (relative to the largest entry; bitwise equal in fact, one
// thread both ways). The plate's mean P̄_13..P̄_33 vanish with its free faces, to the Newton tolerance
// (1e-8 relative; measured 2e-14).
TEST(CampaignFe, SectionAndPlateCasesEqualTheFeSolver) {
  const fs::path dir = fresh_dir("fe");
  const Campaign c = expand(fe_campaign());
  ASSERT_EQ(c.cases.size(), 2u);
  EXPECT_EQ(c.cases[0].engine, "fe");
  const SweepReport r = run_campaign(c, dir, one_thread());
  EXPECT_EQ(r.finished, 2);
  EXPECT_EQ(r.failed, 0);
  const auto store = read_store(dir / "campaign.h5");
  for (const CampaignCase& cc : c.cases) {
    const CaseRecord& rec = store.at(cc.id);
    ASSERT_EQ(rec.status, "ok") << cc.id << ": " << rec.error;
    EXPECT_EQ(rec.info.at("engine"), "fe");
    EXPECT_GT(rec.stats.at("elements"), 10.0);
    EXPECT_EQ(rec.stats.count("voxels"), 0u);  // FFT-only statistics are absent
    EXPECT_EQ(rec.stats.count("fft_planning_s"), 0u);
    const std::vector<double> direct = fe_solver_rows(cc.scene);
    ASSERT_EQ(rec.data.size(), direct.size()) << cc.id;
    EXPECT_LE(max_relative_difference(rec.data, direct), 1e-10) << cc.id;
  }
  const CaseRecord& plate = store.at("plate");
  const std::size_t nc = plate.columns.size(), last = (plate.rows() - 1) * nc;
  ASSERT_EQ(plate.columns[10], "P11");
  EXPECT_GT(plate.data[last + 10], 0.0);
  for (std::size_t k : {12u, 15u, 18u}) EXPECT_LE(std::abs(plate.data[last + k]), 1e-6 * plate.data[last + 10]) << plate.columns[k];
  fs::remove_all(dir);
}

// Two jobs in one process: the FE cases run one at a time (concurrent FE solves differed from lone
// ones in round-off, ~1e-12), so the store equals the one-job run's value for value.
TEST(CampaignFe, TwoJobsStoreTheOneJobNumbers) {
  const Campaign c = expand(fe_campaign());
  const fs::path one = fresh_dir("fe-one"), two = fresh_dir("fe-two");
  run_campaign(c, one, one_thread());
  SweepOptions jobs = one_thread();
  jobs.jobs = jobs.threads = 2;  // one thread per job, as one_thread()
  EXPECT_EQ(run_campaign(c, two, jobs).threads_per_job, 1);
  const auto a = read_store(one / "campaign.h5"), b = read_store(two / "campaign.h5");
  for (const CampaignCase& cc : c.cases) EXPECT_EQ(a.at(cc.id).data, b.at(cc.id).data) << cc.id;
  fs::remove_all(one);
  fs::remove_all(two);
}

// FFT and FE cases in one campaign share the store and cases.csv; a rerun skips the finished FE case
// (and the FFT one), and a removed FE case is the only one recomputed, to the same rows.
TEST(CampaignFe, MixedCampaignAndResumeSkipsFinishedFeCase) {
  // The FFT engine by default; the FE cases name theirs (deep-merged into [base.solver]).
  const std::string mixed = std::string(kCellAndLoads) + "[base.solver]\ntolerance = 1e-8\n" + section_and_plate(kFeSolver) +
                            "[[cases]]\nname = \"fft\"\nmatrix = \"pdms\"\nangle = 30\nresolution = 8\nload = \"pull\"\n";
  // An FE key in an FFT case is refused as `softhom rve` refuses it.
  EXPECT_EQ(refused_field(mixed + "override = {solver = {mesh_size = 0.1}}\n"), "case fft: solver.mesh_size");
  const Campaign c = expand(mixed);
  ASSERT_EQ(c.cases.size(), 3u);
  EXPECT_EQ(c.cases[0].engine, "fe");
  EXPECT_EQ(c.cases[1].engine, "fe");
  EXPECT_EQ(c.cases[2].engine, "fft");

  const fs::path dir = fresh_dir("fe-mixed");
  SweepOptions first = one_thread();
  first.max_new_cases = 1;  // a simulated kill after the first stored case (the section, campaign order)
  run_campaign(c, dir, first);
  const auto partial = read_store(dir / "campaign.h5");
  ASSERT_EQ(partial.size(), 1u);
  ASSERT_TRUE(partial.count("section"));
  const SweepReport r = run_campaign(c, dir, one_thread());
  EXPECT_EQ(r.skipped, 1);
  EXPECT_EQ(r.finished, 2);
  EXPECT_EQ(r.failed, 0);
  auto store = read_store(dir / "campaign.h5");
  EXPECT_EQ(store.at("section").data, partial.at("section").data);  // kept, not recomputed
  EXPECT_EQ(store.at("fft").info.at("engine"), "fft");
  EXPECT_GT(store.at("fft").stats.at("voxels"), 0.0);
  EXPECT_EQ(store.at("plate").stats.count("voxels"), 0u);
  // The FFT 8² and FE section curves of the same cell agree to their discretization errors (the 8²
  // grid's, about 1 % here; measured 0.6 %).
  const CaseRecord &fe = store.at("section"), &fft = store.at("fft");
  const std::size_t P11 = (fe.rows() - 1) * fe.columns.size() + 10;
  EXPECT_NEAR(fft.data[P11] / fe.data[P11], 1.0, 0.02);

  // Nothing left to run; a removed FE case is recomputed alone, to the same rows.
  EXPECT_EQ(run_campaign(c, dir, one_thread()).finished, 0);
  const auto plate_rows = store.at("plate").data;
  store.erase("plate");
  write_store(dir / "campaign.h5", store, c.description);
  const SweepReport again = run_campaign(c, dir, one_thread());
  EXPECT_EQ(again.skipped, 2);
  EXPECT_EQ(again.finished, 1);
  EXPECT_EQ(read_store(dir / "campaign.h5").at("plate").data, plate_rows);
  fs::remove_all(dir);
}

// Two FE loads whose paths lie on each other (tension to 1.05 in one step, to 1.1 in two) form one
// chain: the cell is meshed once and the longer case continues from the shorter one's end state, so it
// computes only its second step. That step starts from the state the cold run has after its first step
// and takes the same sub-step, so the rows are equal exactly (a solver restarted from F = I would step
// to 1.1 at once: other iterates, rows equal only to the Newton tolerance).
TEST(CampaignFe, FeChainWarmStartsAlongTheLoadPath) {
  const std::string text = R"(
[base.microstructure]
shape = "circle"
radius = 0.2
[base.solver]
engine = "fe"
mesh_size = 0.25
interface_size = 0.1
tolerance = 1e-8
[loads.short]
type = "uniaxial"
stretch = [[0.0, 1.0], [1.0, 1.05]]
dt = 1.0
[loads.long]
type = "uniaxial"
stretch = [[0.0, 1.0], [2.0, 1.1]]
dt = 1.0
[sweep]
matrix = ["pdms"]
angle = [30]
load = ["short", "long"]
)";
  const Campaign c = expand(text);
  ASSERT_EQ(c.cases.size(), 2u);
  EXPECT_EQ(c.cases[1].id, "pdms-circle-a30-vf0.23-square-long");  // FE ids have no grid
  const fs::path warm = fresh_dir("fe-warm"), cold = fresh_dir("fe-cold");
  const SweepReport rw = run_campaign(c, warm, one_thread());
  EXPECT_EQ(rw.warm_started, 1);
  SweepOptions no_warm = one_thread();
  no_warm.warm_start = false;
  EXPECT_EQ(run_campaign(c, cold, no_warm).warm_started, 0);
  const auto warm_store = read_store(warm / "campaign.h5"), cold_store = read_store(cold / "campaign.h5");
  const CaseRecord& w = warm_store.at(c.cases[1].id);
  const CaseRecord& k = cold_store.at(c.cases[1].id);
  ASSERT_EQ(w.status, "ok") << w.error;
  EXPECT_EQ(w.info.at("warm_start_from"), c.cases[0].id);
  ASSERT_EQ(w.rows(), 3u);
  ASSERT_EQ(k.rows(), 3u);
  EXPECT_EQ(w.data, k.data);
  EXPECT_LT(w.stats.at("newton_iterations"), k.stats.at("newton_iterations"));  // its own segment only
  const std::size_t nc = w.columns.size();
  EXPECT_GT(k.data[2 * nc + 10], k.data[nc + 10]);  // P11 grows: the run is not a no-op
  fs::remove_all(warm);
  fs::remove_all(cold);
}

// Bad FE input is refused at expansion (so by --dry-run too), naming the case and the key, as
// `softhom rve` names the key: a bad FE key, a plate cell in 3D, a resolution axis on the FE engine
// (it has no grid), and engine = "auto" (a campaign runs the engine it names).
TEST(CampaignFe, BadFeKeysNameTheCaseAndTheKey) {
  const std::string base = "[base.microstructure]\nshape = \"circle\"\nradius = 0.2\n[base.solver]\nengine = \"fe\"\n";
  const std::string cases = "[[cases]]\nname = \"c\"\nmatrix = \"pdms\"\nload = \"tension\"\n";
  EXPECT_EQ(refused_field(base + "mesh_size = -0.1\n" + cases), "case c: solver.mesh_size");
  EXPECT_EQ(refused_field(base + "pressure = \"p2\"\n" + cases), "case c: solver.pressure");
  EXPECT_EQ(refused_field(base + cases + "override = {solver = {fe_mesh = \"3d\"}, microstructure = {cell = \"plate\"}}\n"),
            "case c: microstructure.cell");
  EXPECT_EQ(refused_field(base + cases + "override = {solver = {discretization = \"hex\"}}\n"), "case c: solver.discretization");
  EXPECT_EQ(refused_field(base + cases + "resolution = 16\n"), "cases[0].resolution");
  EXPECT_EQ(refused_field(base + "[sweep]\nmatrix = [\"pdms\"]\nresolution = [8, 16]\nload = [\"tension\"]\n"),
            "sweep.resolution");
  EXPECT_EQ(refused_field("[base.solver]\nengine = \"auto\"\ntarget_error = 1e-3\n" + cases), "case c: solver.engine");
  EXPECT_EQ(refused_field("[base.solver]\nengine = \"fem\"\n" + cases), "case c: solver.engine");
}
