// FieldWriter: HDF5 datasets read back bit-exact, the XDMF sidecar describes them consistently, and an
// unfinished writer leaves nothing behind.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <regex>
#include <sstream>

#include <sys/wait.h>
#include <unistd.h>

#include "io/io_test_helpers.hpp"
#include "softhom/io/fields.hpp"

using namespace softhom;
using softhom::test::listing;
using softhom::test::slurp;
namespace fs = std::filesystem;

namespace {

std::vector<double> ramp(std::size_t n, double scale) {
  std::vector<double> v(n);
  for (std::size_t i = 0; i < n; ++i) v[i] = scale * (static_cast<double>(i) + 1.0 / 3.0);
  return v;
}

template <class T>
std::vector<double> as_double(const std::vector<T>& v) {
  return std::vector<double>(v.begin(), v.end());
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

// Every HDF dataset referenced by the XDMF must exist with exactly the dimensions the XDMF states: this
// is what ParaView relies on. Returns how many references were checked.
std::size_t check_xdmf_references(const std::string& xdmf, const fs::path& dir) {
  static const std::regex item(R"re(<DataItem Dimensions="([0-9 ]+)"[^>]*Format="HDF">([^:<]+):([^<]+)</DataItem>)re");
  std::size_t n = 0;
  for (auto it = std::sregex_iterator(xdmf.begin(), xdmf.end(), item); it != std::sregex_iterator(); ++it) {
    const std::string dims = (*it)[1], file = (*it)[2], dataset = (*it)[3];
    const auto d = io::read_dataset(dir / file, dataset);
    std::string actual;
    for (std::size_t i = 0; i < d.dims.size(); ++i) {
      if (i) actual += ' ';
      actual += std::to_string(d.dims[i]);
    }
    EXPECT_EQ(actual, dims) << dataset;
    ++n;
  }
  return n;
}

}  // namespace

TEST(FieldWriter, VoxelGridTwoStepsRoundTrip) {
  test::TempDir tmp{"fields"};
  io::VoxelGrid grid;
  grid.cells = {4, 3, 2};
  grid.spacing = {0.5, 1.0, 2.0};
  grid.origin = {1.0, 2.0, 3.0};
  constexpr std::size_t cells = 4 * 3 * 2, nodes = 5 * 4 * 3;
  const auto stress0 = ramp(9 * cells, 1.0), stress1 = ramp(9 * cells, -0.1);
  const auto u = ramp(3 * nodes, 1e-3);
  std::vector<int> phase(cells);
  for (std::size_t i = 0; i < cells; ++i) phase[i] = static_cast<int>(i % 3) - 1;
  const auto energy = ramp(cells, 7.0);

  {
    io::FieldWriter w(tmp.path / "fields", grid);
    w.begin_step(0.0);
    w.add("stress", stress0, 9, io::Centering::cell);
    w.add("phase", phase, io::Centering::cell);
    w.add("displacement", u, 3, io::Centering::node);
    w.end_step();
    w.begin_step(0.5);
    w.add("stress", stress1, 9, io::Centering::cell);
    w.add("energy", energy, 1, io::Centering::cell);
    w.end_step();
    w.close();
  }
  EXPECT_EQ(listing(tmp.path), (std::vector<std::string>{"fields.h5", "fields.xdmf"}));  // no temporaries

  const fs::path h5 = tmp.path / "fields.h5";
  // Values are stored as IEEE doubles: read back exactly.
  auto s0 = io::read_dataset(h5, "/step_000000/stress");
  EXPECT_EQ(s0.dims, (std::vector<std::size_t>{2, 3, 4, 9}));  // z y x, component fastest
  EXPECT_EQ(s0.values, stress0);
  auto s1 = io::read_dataset(h5, "/step_000001/stress");
  EXPECT_EQ(s1.values, stress1);
  auto p = io::read_dataset(h5, "/step_000000/phase");
  EXPECT_EQ(p.dims, (std::vector<std::size_t>{2, 3, 4}));
  EXPECT_EQ(p.values, as_double(phase));
  auto d = io::read_dataset(h5, "/step_000000/displacement");
  EXPECT_EQ(d.dims, (std::vector<std::size_t>{3, 4, 5, 3}));  // node dims = cells + 1
  EXPECT_EQ(d.values, u);
  EXPECT_EQ(io::read_dataset(h5, "/step_000001/energy").values, energy);

  // Planes of the slowest dimension, taken periodically: what one rank of a distributed cell reads.
  // Rows of s0 are planes of 3·4·9 values; [-1, 3) of 2 planes is planes 1, 0, 1, 0 (wrapped twice).
  const std::size_t plane = 3 * 4 * 9;
  const auto wrapped = io::read_dataset_planes(h5, "/step_000000/stress", -1, 4);
  EXPECT_EQ(wrapped.dims, s0.dims);  // the whole dataset's dims
  ASSERT_EQ(wrapped.values.size(), 4 * plane);
  for (std::size_t k = 0; k < 4; ++k) {
    const std::size_t from = (k % 2 == 0 ? 1 : 0) * plane;
    EXPECT_TRUE(std::equal(stress0.begin() + std::ptrdiff_t(from), stress0.begin() + std::ptrdiff_t(from + plane),
                           wrapped.values.begin() + std::ptrdiff_t(k * plane))) << "plane " << k;
  }
  EXPECT_EQ(io::read_dataset_planes(h5, "/step_000000/stress", 1, 1).values,
            std::vector<double>(stress0.begin() + std::ptrdiff_t(plane), stress0.end()));
  const auto header = io::read_dataset_planes(h5, "/step_000000/phase", 0, 0);  // dims and type only
  EXPECT_EQ(header.dims, p.dims);
  EXPECT_TRUE(header.values.empty());

  const std::string x = slurp(tmp.path / "fields.xdmf");
  EXPECT_NE(x.find(R"(GridType="Collection" CollectionType="Temporal")"), std::string::npos) << x;
  EXPECT_EQ(count(x, R"(TopologyType="3DCoRectMesh" Dimensions="3 4 5")"), 2u) << x;
  EXPECT_EQ(count(x, "<Time Value="), 2u);
  EXPECT_NE(x.find(R"(<Time Value="0.5"/>)"), std::string::npos);
  // ORIGIN_DXDYDZ in z y x order, like the dimensions.
  EXPECT_NE(x.find(">3 2 1</DataItem>"), std::string::npos) << x;
  EXPECT_NE(x.find(">2 1 0.5</DataItem>"), std::string::npos) << x;
  EXPECT_NE(x.find(R"(Name="stress" AttributeType="Tensor" Center="Cell")"), std::string::npos);
  EXPECT_NE(x.find(R"(Name="displacement" AttributeType="Vector" Center="Node")"), std::string::npos);
  EXPECT_NE(x.find(R"(Name="phase" AttributeType="Scalar" Center="Cell")"), std::string::npos);
  EXPECT_NE(x.find(R"(Name="energy" AttributeType="Scalar" Center="Cell")"), std::string::npos);
  EXPECT_NE(x.find("fields.h5:/step_000001/stress"), std::string::npos);
  EXPECT_EQ(x.find(".tmp-"), std::string::npos);  // refers to the final name, not the temporary
  EXPECT_EQ(check_xdmf_references(x, tmp.path), 5u);

  // Independent well-formedness check with a real XML parser, where python3 exists (exit 127: absent).
  const std::string cmd =
      "python3 -c \"import sys, xml.etree.ElementTree as E; r = E.parse(sys.argv[1]).getroot(); "
      "c = r.find('Domain/Grid'); assert c.get('CollectionType') == 'Temporal'; "
      "assert len(c.findall('Grid')) == 2\" '" + (tmp.path / "fields.xdmf").string() + "' 2>&1";
  const int rc = std::system(cmd.c_str());
  if (!(WIFEXITED(rc) && WEXITSTATUS(rc) == 127)) {
    EXPECT_EQ(rc, 0) << cmd;
  }
}

TEST(FieldWriter, StepGroupsSortInTimeOrder) {
  // Names compared as strings (h5ls, h5py's keys, ParaView's tree) order steps 0..11 by time only when
  // zero-padded: unpadded, step_10 would sort between step_1 and step_2.
  std::vector<std::string> names;
  for (int k = 0; k < 12; ++k) names.push_back(io::step_group_name(k));
  EXPECT_TRUE(std::is_sorted(names.begin(), names.end()));
  EXPECT_EQ(io::step_group_name(0), "step_000000");
  EXPECT_EQ(io::step_group_name(123456), "step_123456");
  EXPECT_EQ(io::step_group_name(1234567), "step_1234567");  // beyond 6 digits: longer, still unique
}

TEST(FieldWriter, UnstructuredTetraMeshRoundTrip) {
  test::TempDir tmp{"fields"};
  io::UnstructuredMesh mesh;
  mesh.cell_type = io::CellType::tetra4;
  mesh.coordinates = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1};
  mesh.connectivity = {0, 1, 2, 3, 1, 2, 3, 4};
  const std::vector<double> u = {0, 0, 0, 0.1, 0, 0, 0, 0.2, 0, 0, 0, 0.3, 0.1, 0.2, 0.3};
  const std::vector<double> j = {1.01, 0.99};
  const std::vector<int> phase = {0, 1};
  {
    io::FieldWriter w(tmp.path / "sub" / "mesh", mesh);  // creates the directory
    for (int step = 0; step < 2; ++step) {
      w.begin_step(step);
      w.add("displacement", u, 3, io::Centering::node);
      w.add("J", j, 1, io::Centering::cell);
      w.add("phase", phase, io::Centering::cell);
      w.end_step();
    }
    w.close();
  }
  const fs::path dir = tmp.path / "sub";
  EXPECT_EQ(listing(dir), (std::vector<std::string>{"mesh.h5", "mesh.xdmf"}));
  const auto c = io::read_dataset(dir / "mesh.h5", "/mesh/coordinates");
  EXPECT_EQ(c.dims, (std::vector<std::size_t>{5, 3}));
  EXPECT_EQ(c.values, mesh.coordinates);
  const auto k = io::read_dataset(dir / "mesh.h5", "/mesh/connectivity");
  EXPECT_EQ(k.dims, (std::vector<std::size_t>{2, 4}));
  EXPECT_EQ(k.values, as_double(mesh.connectivity));
  EXPECT_EQ(io::read_dataset(dir / "mesh.h5", "/step_000001/displacement").values, u);
  EXPECT_EQ(io::read_dataset(dir / "mesh.h5", "/step_000001/J").values, j);

  const std::string x = slurp(dir / "mesh.xdmf");
  EXPECT_EQ(count(x, R"(TopologyType="Tetrahedron" NumberOfElements="2" NodesPerElement="4")"), 2u) << x;
  EXPECT_EQ(count(x, R"(GeometryType="XYZ")"), 2u);
  EXPECT_NE(x.find("mesh.h5:/mesh/coordinates"), std::string::npos);
  EXPECT_NE(x.find("mesh.h5:/mesh/connectivity"), std::string::npos);
  EXPECT_NE(x.find(R"(Name="displacement" AttributeType="Vector" Center="Node")"), std::string::npos);
  // 2 steps × (connectivity + coordinates + 3 fields).
  EXPECT_EQ(check_xdmf_references(x, dir), 10u);
}

TEST(FieldWriter, PolylinesOfFibersAndTheLayoutOfAnUnstructuredMesh) {
  // Fibers' segments are XDMF polylines of two nodes (quadratic ones Edge_3); an unstructured file's
  // layout attribute speaks of its connectivity, not of a voxel grid.
  test::TempDir tmp{"fields"};
  io::UnstructuredMesh mesh;
  mesh.cell_type = io::CellType::line2;
  mesh.coordinates = {0, 0, 0, 1, 0, 0, 2, 0, 0};
  mesh.connectivity = {0, 1, 1, 2};
  {
    io::FieldWriter w(tmp.path / "fibers", mesh);
    w.begin_step(0.0);
    w.add("stretch", std::vector<double>{1.0, 1.1}, 1, io::Centering::cell, "1");
    w.end_step();
    w.close();
  }
  const std::string x = slurp(tmp.path / "fibers.xdmf");
  EXPECT_EQ(count(x, R"(TopologyType="Polyline" NumberOfElements="2" NodesPerElement="2")"), 1u) << x;
  // The attribute's string is stored as it is in the HDF5 file's bytes.
  const std::string h5 = slurp(tmp.path / "fibers.h5");
  EXPECT_EQ(h5.find("voxel grid"), std::string::npos);
  EXPECT_NE(h5.find("cell data in the order of /mesh/connectivity"), std::string::npos);
}

TEST(FieldWriter, UnfinishedWriterLeavesNothingAndKeepsPreviousResult) {
  test::TempDir tmp{"fields"};
  io::VoxelGrid grid;
  grid.cells = {2, 2, 1};
  {
    io::FieldWriter w(tmp.path / "fields", grid);
    w.begin_step(0.0);
    w.add("a", std::vector<double>{1, 2, 3, 4}, 1, io::Centering::cell);
    // no end_step, no close: e.g. an exception unwinding through the solver
  }
  EXPECT_TRUE(listing(tmp.path).empty()) << listing(tmp.path).front();

  {
    io::FieldWriter w(tmp.path / "fields", grid);
    w.begin_step(0.0);
    w.add("a", std::vector<double>{1, 2, 3, 4}, 1, io::Centering::cell);
    w.end_step();
    w.close();
  }
  const std::string xdmf_before = slurp(tmp.path / "fields.xdmf");
  {
    io::FieldWriter w(tmp.path / "fields", grid);
    w.begin_step(0.0);
    w.add("a", std::vector<double>{5, 6, 7, 8}, 1, io::Centering::cell);
    w.end_step();
    // destroyed without close(): the finished result of the previous run must survive untouched
  }
  EXPECT_EQ(listing(tmp.path), (std::vector<std::string>{"fields.h5", "fields.xdmf"}));
  EXPECT_EQ(io::read_dataset(tmp.path / "fields.h5", "/step_000000/a").values, (std::vector<double>{1, 2, 3, 4}));
  EXPECT_EQ(slurp(tmp.path / "fields.xdmf"), xdmf_before);
}

TEST(FieldWriter, RefusesBadFieldsNamingThem) {
  test::TempDir tmp{"fields"};
  io::VoxelGrid grid;
  grid.cells = {2, 1, 1};
  io::FieldWriter w(tmp.path / "fields", grid);
  const std::vector<double> two = {1.0, 2.0};
  EXPECT_THROW(w.add("early", two, 1, io::Centering::cell), std::logic_error);  // no step begun
  w.begin_step(0.0);
  auto message = [&](auto&& call) -> std::string {
    try {
      call();
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  };
  const std::vector<double> nan = {1.0, std::nan("")};
  const std::vector<double> inf = {HUGE_VAL, 1.0};
  EXPECT_NE(message([&] { w.add("sigma_nan", nan, 1, io::Centering::cell); }).find("sigma_nan"), std::string::npos);
  EXPECT_NE(message([&] { w.add("sigma_inf", inf, 1, io::Centering::cell); }).find("sigma_inf"), std::string::npos);
  EXPECT_NE(message([&] { w.add("short", two, 3, io::Centering::cell); }).find("short"), std::string::npos);
  EXPECT_NE(message([&] { w.add("comp", two, 2, io::Centering::cell); }).find("comp"), std::string::npos);
  EXPECT_NE(message([&] { w.add("nodes", two, 1, io::Centering::node); }).find("nodes"), std::string::npos);
  EXPECT_NE(message([&] { w.add("bad/name", two, 1, io::Centering::cell); }).find("bad/name"), std::string::npos);
  w.add("ok", two, 1, io::Centering::cell);
  EXPECT_NE(message([&] { w.add("ok", two, 1, io::Centering::cell); }).find("ok"), std::string::npos);
  EXPECT_THROW(w.close(), std::logic_error);  // step not ended
  w.end_step();
  w.close();
  // Refused fields were not written.
  EXPECT_THROW(io::read_dataset(tmp.path / "fields.h5", "/step_000000/sigma_nan"), std::runtime_error);
  EXPECT_EQ(io::read_dataset(tmp.path / "fields.h5", "/step_000000/ok").values, two);
  EXPECT_THROW(w.begin_step(1.0), std::logic_error);  // closed
}

TEST(FieldWriter, RefusesInconsistentMesh) {
  test::TempDir tmp{"fields"};
  io::UnstructuredMesh mesh;
  mesh.cell_type = io::CellType::tetra4;
  mesh.coordinates = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  mesh.connectivity = {0, 1, 2, 4};  // node 4 does not exist
  EXPECT_THROW(io::FieldWriter(tmp.path / "m", mesh), std::invalid_argument);
  mesh.connectivity = {0, 1, 2};  // not a multiple of 4
  EXPECT_THROW(io::FieldWriter(tmp.path / "m", mesh), std::invalid_argument);
  EXPECT_TRUE(listing(tmp.path).empty());
}

TEST(ReadDataset, MissingDatasetOrFileNamesIt) {
  test::TempDir tmp{"fields"};
  io::VoxelGrid grid;
  {
    io::FieldWriter w(tmp.path / "f", grid);
    w.begin_step(0.0);
    w.add("x", std::vector<double>{1.0}, 1, io::Centering::cell);
    w.end_step();
    w.close();
  }
  for (const std::string name : {"/step_000000/nonexistent_field", "/step_000007/x", "/step_000000"}) {
    try {
      io::read_dataset(tmp.path / "f.h5", name);
      ADD_FAILURE() << "expected std::runtime_error for " << name;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  }
  try {
    io::read_dataset(tmp.path / "missing.h5", "/x");
    ADD_FAILURE() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.h5"), std::string::npos) << e.what();
  }
  // Not an HDF5 file at all.
  std::ofstream(tmp.path / "text.h5") << "hello";
  EXPECT_THROW(io::read_dataset(tmp.path / "text.h5", "/x"), std::runtime_error);
}
