// `softhom rve` voxel-image path: microstructure-only output (HDF5 + XDMF) read back as an image gives the
// same homogenized response as the generated cell, and every malformed image is a named input error.
#include <gtest/gtest.h>

#include <hdf5.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <tuple>
#include <vector>

#include "app/cli_helpers.hpp"
#include "softhom/io/fields.hpp"

namespace fs = std::filesystem;
using softhom::test::fresh_dir;
using softhom::test::read_csv;
using softhom::test::run_softhom;
using softhom::test::write_temp_scene;

namespace {

// Moderate contrast (G ratio 20) and two load steps keep each solve well under a second on 20².
const char* kPhasesAndLoad = R"(
[phases.matrix]
law = "neo-hookean"
mu = 0.5
K = 5.0

[phases.fiber]
law = "neo-hookean"
mu = 10.0
K = 30.0

[load]
type = "uniaxial"
stretch = 1.2
duration = 1.0
steps = 2

[solver]
tolerance = 1e-9

[output]
fields = "none"
)";

// Writes one dataset (any rank, native type `mem_type`) to a fresh HDF5 file.
void write_h5(const fs::path& file, const std::string& name, hid_t file_type, hid_t mem_type, const void* data,
              const std::vector<hsize_t>& dims) {
  const hid_t f = H5Fcreate(file.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  const hid_t s = H5Screate_simple(int(dims.size()), dims.data(), nullptr);
  const hid_t d = H5Dcreate2(f, name.c_str(), file_type, s, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(H5Dwrite(d, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), 0);
  H5Dclose(d);
  H5Sclose(s);
  H5Fclose(f);
}

// A 2D section [n2][n1] of phase ids: a centered disc of fiber (id 1) in matrix (id 0).
std::vector<int> disc_ids(int n, double r) {
  std::vector<int> ids(std::size_t(n) * n);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double x = (i + 0.5) / n - 0.5, y = (j + 0.5) / n - 0.5;
      ids[std::size_t(i) + std::size_t(n) * j] = x * x + y * y < r * r ? 1 : 0;
    }
  return ids;
}

double max_relative_difference(const softhom::test::Csv& a, const softhom::test::Csv& b) {
  double worst = 0.0;
  const std::size_t last = a.rows.size() - 1;
  for (const char* c : {"P11", "P22", "P33", "P12", "sigma11", "F22", "F33", "fiber_angle_deg"}) {
    const double x = a.at(last, c), y = b.at(last, c);
    const double scale = std::max({std::abs(a.at(last, "P11")), 1e-300});
    const bool angle = std::string(c) == "fiber_angle_deg";
    worst = std::max(worst, std::abs(x - y) / (angle ? std::max(std::abs(x), 1.0) : c[0] == 'F' ? 1.0 : scale));
  }
  return worst;
}

}  // namespace

// Generated cell → microstructure.h5 → image scene: the homogenized stress must be the same to 1e-12
// relative. The image carries the fractions and interface normals bit for bit and the voxel size as
// attributes, so both runs solve the identical discrete problem; what remains is rounding in the cell
// size (h·n vs L), far below 1e-12 after a Newton solve converged to 1e-9.
TEST(RveImage, MicrostructureOnlyOutputReadsBackToTheSameResponse) {
  const std::string cell = R"(
[microstructure]
shape = "circle"
arrangement = "square"
volume_fraction = 0.23
radius = 0.2
fiber_angle_deg = 30
grid = [20, 20]
)";
  const auto ms_dir = fresh_dir("img-ms");
  const auto gen_dir = fresh_dir("img-gen");
  const auto imp_dir = fresh_dir("img-imp");
  const std::string gen_scene = std::string(cell) + kPhasesAndLoad;
  std::string ms_scene = gen_scene;
  ms_scene.replace(ms_scene.find("fields = \"none\""), 15, "fields = \"none\"\nmicrostructure_only = true");
  auto r = run_softhom("rve " + write_temp_scene("img-ms", ms_scene) + " --out " + ms_dir.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  ASSERT_TRUE(fs::exists(ms_dir / "microstructure.h5"));
  ASSERT_TRUE(fs::exists(ms_dir / "microstructure.xdmf"));
  EXPECT_FALSE(fs::exists(ms_dir / "response.csv"));  // microstructure only: no solve

  // The file itself: binary phase ids (uint8), fractions, normals, voxel size attribute.
  const auto phase = softhom::io::read_dataset(ms_dir / "microstructure.h5", "/phase");
  EXPECT_TRUE(phase.integer);
  EXPECT_EQ(phase.dims, (std::vector<std::size_t>{1, 20, 20}));
  const auto frac = softhom::io::read_dataset(ms_dir / "microstructure.h5", "/fiber_fraction");
  double vf = 0.0;
  for (double f : frac.values) vf += f;
  EXPECT_NEAR(vf / 400.0, 0.23, 1e-6);  // sub-pixel exact fractions (geometry tolerance 1e-6)
  ASSERT_TRUE(frac.attributes.count("voxel_size"));
  EXPECT_EQ(frac.attributes.at("voxel_size").size(), 3u);
  const auto normals = softhom::io::read_dataset(ms_dir / "microstructure.h5", "/interface_normal");
  EXPECT_EQ(normals.dims, (std::vector<std::size_t>{1, 20, 20, 3}));

  r = run_softhom("rve " + write_temp_scene("img-gen", gen_scene) + " --out " + gen_dir.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string image_scene = "[microstructure]\nfiber_angle_deg = 30\n[microstructure.image]\nfile = \"" +
                                  (ms_dir / "microstructure.h5").string() +
                                  "\"\ndataset = \"/fiber_fraction\"\nnormal_dataset = \"/interface_normal\"\n" +
                                  kPhasesAndLoad;
  r = run_softhom("rve " + write_temp_scene("img-imp", image_scene) + " --out " + imp_dir.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto a = read_csv(gen_dir / "response.csv"), b = read_csv(imp_dir / "response.csv");
  ASSERT_EQ(a.rows.size(), 3u);
  ASSERT_EQ(b.rows.size(), a.rows.size());
  EXPECT_GT(a.at(2, "P11"), 0.0);
  EXPECT_LE(max_relative_difference(a, b), 1e-12);

  // Without the normals the solver estimates them from −∇φ: a different (but close) discrete problem,
  // which shows that the normals are what the round trip must carry.
  const auto est_dir = fresh_dir("img-est");
  std::string no_normals = image_scene;
  no_normals.erase(no_normals.find("normal_dataset"), std::string("normal_dataset = \"/interface_normal\"\n").size());
  r = run_softhom("rve " + write_temp_scene("img-est", no_normals) + " --out " + est_dir.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const double d = max_relative_difference(a, read_csv(est_dir / "response.csv"));
  EXPECT_GT(d, 1e-9);
  EXPECT_LT(d, 2e-2);  // same cell: within the interface-rule error at 20² (a few 1e-3)
}

// Phase ids (int32 section, uint8 volume): an extruded 3D image equals its 2D section (straight
// fibers), and the per-voxel fiber direction only sets the fiber axis the rotation is measured along.
TEST(RveImage, PhaseIdImagesSectionEqualsVolumeAndDirectionsAreRead) {
  const int n = 16;
  const auto dir = fresh_dir("img-ids");
  fs::create_directories(dir);
  const std::vector<int> ids = disc_ids(n, 0.27);
  write_h5(dir / "section.h5", "/phase", H5T_STD_I32LE, H5T_NATIVE_INT, ids.data(), {hsize_t(n), hsize_t(n)});
  std::vector<unsigned char> vol;
  for (int k = 0; k < 2; ++k)
    for (int id : ids) vol.push_back(static_cast<unsigned char>(id == 1 ? 7 : 3));  // custom ids
  write_h5(dir / "volume.h5", "/ms", H5T_STD_U8LE, H5T_NATIVE_UCHAR, vol.data(), {2, hsize_t(n), hsize_t(n)});
  // Fiber direction along y3 everywhere in the fiber, zero in the matrix (allowed there).
  std::vector<double> dirs;
  for (int id : ids)
    for (int c = 0; c < 3; ++c) dirs.push_back(id == 1 && c == 2 ? 2.0 : 0.0);  // normalized on read
  write_h5(dir / "dirs.h5", "/phase", H5T_STD_I32LE, H5T_NATIVE_INT, ids.data(), {hsize_t(n), hsize_t(n)});
  {
    const hid_t f = H5Fopen((dir / "dirs.h5").c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    const hsize_t dd[3] = {hsize_t(n), hsize_t(n), 3};
    const hid_t s = H5Screate_simple(3, dd, nullptr);
    const hid_t d = H5Dcreate2(f, "/direction", H5T_IEEE_F64LE, s, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, dirs.data());
    H5Dclose(d);
    H5Sclose(s);
    H5Fclose(f);
  }
  auto run = [&](const std::string& name, const std::string& image_table) {
    const auto out = fresh_dir("img-ids-" + name);
    const auto r = run_softhom("rve " + write_temp_scene("img-ids-" + name, "[microstructure]\nfiber_angle_deg = 60\n" + image_table + kPhasesAndLoad) +
                               " --out " + out.string());
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return read_csv(out / "response.csv");
  };
  const auto sec = run("sec", "[microstructure.image]\nfile = \"" + (dir / "section.h5").string() + "\"\n");
  const auto vol3 = run("vol", "[microstructure.image]\nfile = \"" + (dir / "volume.h5").string() +
                                   "\"\ndataset = \"/ms\"\nmatrix_id = 3\nfiber_id = 7\n");
  const auto withdir = run("dir", "[microstructure.image]\nfile = \"" + (dir / "dirs.h5").string() +
                                      "\"\ndirection_dataset = \"/direction\"\n");
  ASSERT_EQ(sec.rows.size(), 3u);
  ASSERT_EQ(vol3.rows.size(), 3u);
  ASSERT_EQ(withdir.rows.size(), 3u);
  // 2D section vs 3D extrusion: same solution up to the Newton tolerance 1e-9 (different FFT sizes).
  EXPECT_LE(max_relative_difference(sec, vol3), 1e-7);
  // Directions along y3 = the default axis: identical run.
  EXPECT_LE(max_relative_difference(sec, withdir), 1e-14);
  EXPECT_NEAR(sec.at(0, "fiber_angle_deg"), 60.0, 1e-9);
}

// Malformed images: exit code 2 and a message naming the key (and the offending value or voxel).
TEST(RveImage, BadImagesAreNamedInputErrors) {
  const auto dir = fresh_dir("img-bad");
  fs::create_directories(dir);
  const int n = 8;
  std::vector<int> ids = disc_ids(n, 0.3);
  write_h5(dir / "ok.h5", "/phase", H5T_STD_I32LE, H5T_NATIVE_INT, ids.data(), {hsize_t(n), hsize_t(n)});
  ids[5 + n * 2] = 4;
  write_h5(dir / "unknown.h5", "/phase", H5T_STD_I32LE, H5T_NATIVE_INT, ids.data(), {hsize_t(n), hsize_t(n)});
  const std::vector<int> line(n, 0);
  write_h5(dir / "rank1.h5", "/phase", H5T_STD_I32LE, H5T_NATIVE_INT, line.data(), {hsize_t(n)});
  std::vector<double> frac(n * n, 0.25);
  frac[3] = 1.5;
  write_h5(dir / "frac.h5", "/phase", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, frac.data(), {hsize_t(n), hsize_t(n)});
  frac[3] = std::numeric_limits<double>::quiet_NaN();
  write_h5(dir / "nan.h5", "/phase", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, frac.data(), {hsize_t(n), hsize_t(n)});
  // Direction datasets next to an all-fiber image: one with a zero vector, one with a NaN, one misshapen.
  {
    const std::vector<int> fiber(n * n, 1);
    write_h5(dir / "dirs.h5", "/phase", H5T_STD_I32LE, H5T_NATIVE_INT, fiber.data(), {hsize_t(n), hsize_t(n)});
    const hid_t f = H5Fopen((dir / "dirs.h5").c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    std::vector<double> d(3 * n * n, 0.0);
    for (int v = 0; v < n * n; ++v) d[3 * v + 2] = 1.0;
    d[3 * 9 + 2] = 0.0;  // zero direction in a fiber voxel
    std::vector<double> e(3 * n * n, 1.0);
    e[7] = std::numeric_limits<double>::quiet_NaN();
    const hsize_t dd[3] = {hsize_t(n), hsize_t(n), 3}, bad[3] = {hsize_t(n), hsize_t(n), 2};
    for (auto [name, data, dims] : {std::tuple{"/zero", d.data(), dd}, std::tuple{"/nan", e.data(), dd}, std::tuple{"/two", e.data(), bad}}) {
      const hid_t s = H5Screate_simple(3, dims, nullptr);
      const hid_t ds = H5Dcreate2(f, name, H5T_IEEE_F64LE, s, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
      H5Dwrite(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, data);
      H5Dclose(ds);
      H5Sclose(s);
    }
    H5Fclose(f);
  }
  std::ofstream(dir / "not.h5") << "not an HDF5 file\n";
  const std::string ok = (dir / "ok.h5").string();
  struct Case {
    std::string image, expect;
  };
  const Case cases[] = {
      {"file = \"" + (dir / "missing.h5").string() + "\"", "microstructure.image.file"},
      {"dataset = \"/phase\"", "microstructure.image.file"},
      {"file = \"" + (dir / "not.h5").string() + "\"", "microstructure.image.dataset"},
      {"file = \"" + ok + "\"\ndataset = \"/nope\"", "no dataset '/nope'"},
      {"file = \"" + (dir / "rank1.h5").string() + "\"", "must be 2D"},
      {"file = \"" + (dir / "unknown.h5").string() + "\"", "phase id 4 at voxel (i1, i2, i3) = (5, 2, 0)"},
      {"file = \"" + ok + "\"\nfiber_id = 0", "microstructure.image.fiber_id"},
      {"file = \"" + (dir / "frac.h5").string() + "\"", "fiber fractions must lie in [0, 1]"},
      {"file = \"" + (dir / "nan.h5").string() + "\"", "microstructure.image.dataset = nan"},
      {"file = \"" + (dir / "frac.h5").string() + "\"\nfiber_id = 2", "phase ids need an integer dataset"},
      {"file = \"" + ok + "\"\nvoxel_size = -1.0", "microstructure.image.voxel_size"},
      {"file = \"" + ok + "\"\nvoxel_size = 0.1\ncell_size = 1.0", "either voxel_size or cell_size"},
      {"file = \"" + ok + "\"\ncolour = 1", "microstructure.image.colour"},
      {"file = \"" + (dir / "dirs.h5").string() + "\"\ndirection_dataset = \"/zero\"", "zero vector at voxel (i1, i2, i3) = (1, 1, 0)"},
      {"file = \"" + (dir / "dirs.h5").string() + "\"\ndirection_dataset = \"/nan\"", "non-finite vector"},
      {"file = \"" + (dir / "dirs.h5").string() + "\"\ndirection_dataset = \"/two\"", "expected dims [8, 8, 3]"},
      {"file = \"" + ok + "\"\nnormal_dataset = \"/phase\"", "microstructure.image.normal_dataset"},
  };
  int k = 0;
  for (const auto& c : cases) {
    const auto out = fresh_dir("img-bad-" + std::to_string(k));
    const auto scene = write_temp_scene("img-bad-" + std::to_string(k++), "[microstructure.image]\n" + c.image + "\n" + kPhasesAndLoad);
    const auto r = run_softhom("rve " + scene + " --out " + out.string());
    EXPECT_EQ(r.exit_code, 2) << c.image << "\n" << r.output;
    EXPECT_NE(r.output.find(c.expect), std::string::npos) << "expected '" << c.expect << "' in: " << r.output;
    EXPECT_FALSE(fs::exists(out / "response.csv"));
  }
  // An explicit grid that contradicts the image.
  const auto out = fresh_dir("img-bad-grid");
  const auto r = run_softhom("rve " + write_temp_scene("img-bad-grid", "[microstructure]\ngrid = [16, 16]\n[microstructure.image]\nfile = \"" + ok + "\"\n" + kPhasesAndLoad) +
                             " --out " + out.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("microstructure.grid"), std::string::npos) << r.output;
}
