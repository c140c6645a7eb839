// Binary Gmsh MSH 4.1 import: the committed ASCII meshes (tests/data/gmsh) are rewritten here as binary
// files (file-type 1, little- and big-endian, size_t of 8 and 4 bytes) by a small writer that follows
// the format description field by field, and must parse to exactly the same Mesh as the ASCII text.
// Truncated or corrupt binary data must give an InputError, not a crash or a huge allocation.
#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>

#include "softhom/io/gmsh.hpp"
#include "softhom/materials/errors.hpp"

using namespace softhom;
using namespace softhom::fe;
using namespace softhom::io;

namespace {

std::string gmsh_file(const std::string& name) { return std::string(SOFTHOM_SOURCE_DIR) + "/tests/data/gmsh/" + name; }

std::string read_text(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// ASCII MSH 4.1 → binary MSH 4.1. Reads the ASCII tokens in the order of the format description and
/// writes each field with its binary type: int (tags, dimensions, types, flags), size_t (counts, node
/// and element tags) of `size_bytes`, double (coordinates, bounding boxes). $PhysicalNames stays text.
class BinaryWriter {
 public:
  BinaryWriter(const std::string& ascii, bool big_endian, int size_bytes)
      : in_(ascii), big_(big_endian), size_bytes_(size_bytes) {}

  std::string convert() {
    std::string word;
    while (in_ >> word) {
      if (word == "$MeshFormat") {
        std::string version;
        int type, size;
        in_ >> version >> type >> size >> word;  // ... $EndMeshFormat
        out_ += "$MeshFormat\n" + version + " 1 " + std::to_string(size_bytes_) + "\n";
        put_int(1);
        out_ += "\n$EndMeshFormat\n";
      } else if (word == "$PhysicalNames") {
        // Text in binary files too: copy up to and including $EndPhysicalNames.
        std::string line;
        out_ += "$PhysicalNames";
        while (std::getline(in_, line)) {
          out_ += line + "\n";
          if (line.rfind("$EndPhysicalNames", 0) == 0) break;
        }
      } else if (word == "$Entities") {
        out_ += "$Entities\n";
        long count[4];
        for (long& c : count) put_size(c = next_long());
        for (int dim = 0; dim < 4; ++dim)
          for (long k = 0; k < count[dim]; ++k) {
            put_int(next_long());
            for (int c = 0; c < (dim == 0 ? 3 : 6); ++c) put_double(next_double());
            const long np = next_long();
            put_size(np);
            for (long p = 0; p < np; ++p) put_int(next_long());
            if (dim > 0) {
              const long nb = next_long();
              put_size(nb);
              for (long b = 0; b < nb; ++b) put_int(next_long());
            }
          }
        in_ >> word;
        out_ += "\n$EndEntities\n";
      } else if (word == "$Nodes") {
        out_ += "$Nodes\n";
        const long blocks = next_long();
        put_size(blocks);
        for (int k = 0; k < 3; ++k) put_size(next_long());
        for (long b = 0; b < blocks; ++b) {
          const long dim = next_long();
          put_int(dim);
          put_int(next_long());
          const long parametric = next_long();
          put_int(parametric);
          const long n = next_long();
          put_size(n);
          for (long k = 0; k < n; ++k) put_size(next_long());
          for (long k = 0; k < n * (3 + (parametric ? dim : 0)); ++k) put_double(next_double());
        }
        in_ >> word;
        out_ += "\n$EndNodes\n";
      } else if (word == "$Elements") {
        out_ += "$Elements\n";
        const long blocks = next_long();
        put_size(blocks);
        for (int k = 0; k < 3; ++k) put_size(next_long());
        for (long b = 0; b < blocks; ++b) {
          put_int(next_long());
          put_int(next_long());
          const long type = next_long();
          put_int(type);
          const long n = next_long();
          put_size(n);
          const int nn = type == 15 ? 1 : type == 1 ? 2 : type == 2 ? 3 : type == 3 ? 4 : type == 4 ? 4
                       : type == 5 ? 8 : type == 9 ? 6 : type == 11 ? 10 : -1;
          if (nn < 0) throw std::runtime_error("test writer: element type " + std::to_string(type));
          for (long k = 0; k < n * (1 + nn); ++k) put_size(next_long());
        }
        in_ >> word;
        out_ += "\n$EndElements\n";
      } else {
        throw std::runtime_error("test writer: section " + word);
      }
    }
    return out_;
  }

 private:
  long next_long() {
    long v;
    if (!(in_ >> v)) throw std::runtime_error("test writer: expected an integer");
    return v;
  }
  double next_double() {
    double v;
    if (!(in_ >> v)) throw std::runtime_error("test writer: expected a number");
    return v;
  }
  template <class T>
  void put(T v) {
    unsigned char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    if (big_ == (std::endian::native == std::endian::little)) std::reverse(b, b + sizeof(T));
    out_.append(reinterpret_cast<const char*>(b), sizeof(T));
  }
  void put_int(long v) { put(std::int32_t(v)); }
  void put_size(long v) {
    if (size_bytes_ == 8) put(std::uint64_t(v));
    else put(std::uint32_t(v));
  }
  void put_double(double v) { put(v); }

  std::istringstream in_;
  bool big_;
  int size_bytes_;
  std::string out_;
};

Mesh parse(const std::string& text, const std::string& name) {
  std::istringstream in(text);
  return parse_gmsh(in, name);
}

void expect_same(const Mesh& a, const Mesh& b) {
  ASSERT_EQ(a.nodes.size(), b.nodes.size());
  for (std::size_t n = 0; n < a.nodes.size(); ++n) EXPECT_EQ(a.nodes[n], b.nodes[n]) << "node " << n;  // bit-exact
  EXPECT_EQ(a.hexes, b.hexes);
  EXPECT_EQ(a.tets, b.tets);
  EXPECT_EQ(a.region, b.region);
  EXPECT_EQ(a.region_names, b.region_names);
  EXPECT_EQ(a.surfaces, b.surfaces);
  EXPECT_EQ(a.tri_surfaces, b.tri_surfaces);
}

std::string binary_error_of(const std::string& text) {
  try {
    parse(text, "bin.msh");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(GmshBinary, SameMeshAsAsciiInBothByteOrders) {
  // Hexahedra with quadrangle surfaces, tet10 with two regions, and tet4 promoted to tet10.
  for (const char* file : {"hex_block.msh", "two_regions_tet10.msh", "box_tet4.msh"}) {
    const std::string ascii = read_text(gmsh_file(file));
    const Mesh reference = parse(ascii, file);
    ASSERT_GT(reference.num_elements(), 0) << file;
    for (const bool big : {false, true})
      for (const int size_bytes : {8, 4}) {
        SCOPED_TRACE(std::string(file) + (big ? " big-endian" : " little-endian") + " size_t " + std::to_string(size_bytes));
        const std::string bin = BinaryWriter(ascii, big, size_bytes).convert();
        ASSERT_NE(bin.find("4.1 1 " + std::to_string(size_bytes)), std::string::npos);
        expect_same(parse(bin, "bin.msh"), reference);
      }
  }
  // And from a file on disk (read_gmsh opens it in binary mode).
  const std::string ascii = read_text(gmsh_file("hex_block.msh"));
  const std::string path = testing::TempDir() + "softhom_hex_block_binary.msh";
  {
    std::ofstream out(path, std::ios::binary);
    out << BinaryWriter(ascii, false, 8).convert();
  }
  expect_same(read_gmsh(path), parse(ascii, "hex_block.msh"));
}

TEST(GmshBinary, TruncatedOrCorruptDataIsAnInputError) {
  const std::string bin = BinaryWriter(read_text(gmsh_file("hex_block.msh")), false, 8).convert();
  // Cut inside the node coordinates.
  const std::size_t nodes = bin.find("$Nodes\n");
  ASSERT_NE(nodes, std::string::npos);
  const std::string cut = bin.substr(0, nodes + 200);
  EXPECT_NE(binary_error_of(cut).find("binary"), std::string::npos) << binary_error_of(cut);
  // A node count of 2^40 (corrupt): refused before allocating.
  std::string corrupt = bin;
  const std::uint64_t huge = std::uint64_t(1) << 40;
  std::memcpy(&corrupt[nodes + 7 + 8], &huge, 8);  // second size_t after "$Nodes\n": number of nodes
  EXPECT_NE(binary_error_of(corrupt).find("invalid count"), std::string::npos) << binary_error_of(corrupt);
  // Endianness marker that is neither 1 nor byte-swapped 1.
  std::string marker = bin;
  const std::size_t m = marker.find("4.1 1 8\n") + 8;
  marker[m] = 7;
  EXPECT_NE(binary_error_of(marker).find("endianness"), std::string::npos) << binary_error_of(marker);
  // data-size other than 4 or 8.
  std::string size = bin;
  size.replace(size.find("4.1 1 8"), 7, "4.1 1 2");
  EXPECT_NE(binary_error_of(size).find("data-size"), std::string::npos) << binary_error_of(size);
}
