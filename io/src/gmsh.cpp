#include "softhom/io/gmsh.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <unordered_map>

#include "softhom/fe/hex8.hpp"
#include "softhom/fe/tet10_element.hpp"
#include "softhom/io/files.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::io {
namespace {

using namespace softhom::fe;

/// Whitespace-separated tokens with line numbers (for error messages); quoted strings are one token.
class Tokens {
 public:
  Tokens(std::string text, std::string source) : text_(std::move(text)), source_(std::move(source)) {}

  bool at_end() {
    skip_space();
    return pos_ >= text_.size();
  }
  int line() const { return line_; }
  /// Next token (empty at the end of the text).
  std::string_view next() {
    skip_space();
    token_line_ = line_;
    if (pos_ >= text_.size()) return {};
    const std::size_t start = pos_;
    if (text_[pos_] == '"') {
      const std::size_t close = text_.find('"', pos_ + 1);
      if (close == std::string::npos) fail(text_.substr(start, 20), "unterminated quoted name");
      pos_ = close + 1;
      return std::string_view(text_).substr(start + 1, close - start - 1);
    }
    while (pos_ < text_.size() && !std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
    return std::string_view(text_).substr(start, pos_ - start);
  }
  std::string_view expect_token(const char* what) {
    const std::string_view t = next();
    if (t.empty()) fail("", std::string("unexpected end of file, expected ") + what);
    return t;
  }
  long integer(const char* what) {
    const std::string_view t = expect_token(what);
    long v = 0;
    const auto res = std::from_chars(t.data(), t.data() + t.size(), v);
    if (res.ec != std::errc() || res.ptr != t.data() + t.size())
      fail(std::string(t), std::string("expected an integer (") + what + ")");
    return v;
  }
  double real(const char* what) {
    const std::string_view t = expect_token(what);
    const std::string s(t);
    char* end = nullptr;
    const double v = std::strtod(s.c_str(), &end);
    if (end != s.c_str() + s.size() || !std::isfinite(v))
      fail(s, std::string("expected a finite number (") + what + ")");
    return v;
  }
  /// Binary sections (file-type 1): the data starts right after the line break that ends the header line.
  void begin_binary() {
    if (pos_ < text_.size() && text_[pos_] == '\r') ++pos_;
    if (pos_ >= text_.size() || text_[pos_] != '\n') fail("", "expected a line break before binary data");
    ++pos_;
    ++line_;
  }
  /// Next sizeof(T) bytes as a T, byte-swapped when the file's endianness differs from ours.
  template <class T>
  T raw(const char* what) {
    if (text_.size() - pos_ < sizeof(T)) fail("", std::string("unexpected end of binary data (") + what + ")");
    unsigned char b[sizeof(T)];
    std::memcpy(b, text_.data() + pos_, sizeof(T));
    if (swap_bytes) std::reverse(b, b + sizeof(T));
    T v;
    std::memcpy(&v, b, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  /// Bytes left (a bound for counts read from the file, so that a corrupt count fails cleanly instead
  /// of allocating).
  std::size_t remaining() const { return text_.size() - pos_; }
  bool swap_bytes = false;
  void expect(std::string_view word) {
    const std::string_view t = next();
    if (t != word) fail(std::string(t), "expected " + std::string(word));
  }
  /// Skips to the line after `$End<name>`.
  void skip_section(const std::string& name) {
    const std::string end = "$End" + name;
    while (true) {
      const std::string_view t = next();
      if (t.empty()) fail("", "missing " + end);
      if (t == end) return;
    }
  }
  [[noreturn]] void fail(const std::string& token, const std::string& why) const {
    throw InputError(source_ + ":" + std::to_string(token_line_), token, why);
  }
  [[noreturn]] void fail_at(int line, const std::string& token, const std::string& why) const {
    throw InputError(source_ + ":" + std::to_string(line), token, why);
  }
  const std::string& source() const { return source_; }

 private:
  void skip_space() {
    while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) {
      if (text_[pos_] == '\n') ++line_;
      ++pos_;
    }
  }
  std::string text_, source_;
  std::size_t pos_ = 0;
  int line_ = 1, token_line_ = 1;
};

/// Nodes per element of the Gmsh types this reader knows (0 when unknown).
int gmsh_nodes(long type) {
  switch (type) {
    case 15: return 1;   // point
    case 1: return 2;    // line
    case 8: return 3;    // line3
    case 2: return 3;    // triangle
    case 9: return 6;    // triangle6
    case 3: return 4;    // quadrangle
    case 16: return 8;   // quadrangle8
    case 10: return 9;   // quadrangle9
    case 4: return 4;    // tetrahedron
    case 11: return 10;  // tetrahedron10
    case 5: return 8;    // hexahedron
    case 17: return 20;  // hexahedron20
    case 12: return 27;  // hexahedron27
    case 6: return 6;    // prism
    case 7: return 5;    // pyramid
    case 29: return 20;  // tetrahedron20
    default: return 0;
  }
}

const char* gmsh_name(long type) {
  switch (type) {
    case 16: return "8-node quadrangle";
    case 10: return "9-node quadrangle";
    case 17: return "20-node hexahedron";
    case 12: return "27-node hexahedron";
    case 6: return "prism";
    case 7: return "pyramid";
    case 29: return "20-node tetrahedron";
    default: return "element";
  }
}

struct SurfaceElement {
  long tag;
  int line;
  int entity;
  std::vector<int> nodes;  ///< mesh node indices (3, 4 or 6)
};

/// A 2- or 3-node line (Gmsh types 1 and 8) of a curve entity: fiber polylines (read_gmsh_line_group)
/// and named shell edges (read_gmsh_surface).
struct LineElement {
  long entity;
  std::vector<int> nodes;  ///< mesh node indices: the two ends, then the middle
};

struct VolumeElement {
  long tag;
  int line;
  long entity;
  long type;
  std::vector<int> nodes;
};

struct ArrayHash {
  template <std::size_t N>
  std::size_t operator()(const std::array<int, N>& k) const {
    std::size_t h = 1469598103934665603ull;
    for (int v : k) h = (h ^ std::size_t(v)) * 1099511628211ull;
    return h;
  }
};

/// The sections of one MSH 4.1 file as read so far, and the field readers of its encoding.
struct GmshReader {
  GmshReader(std::string text, std::string source) : tk(std::move(text), std::move(source)) {}

  Tokens tk;
  // Binary files (MSH 4.1 file-type 1): the same fields as the ASCII ones, as int (tags, dimensions,
  // types, flags), size_t of `size_bytes` (counts, node and element tags) or double, in the writer's
  // byte order; $PhysicalNames stays text.
  bool binary = false;
  int size_bytes = 8;
  bool have_format = false, have_nodes = false, have_elements = false, have_entities = false;
  std::map<long, std::string> physical_names[4];          // by dimension: tag → name
  std::map<long, std::vector<long>> entity_physicals[4];  // by dimension: entity tag → physical tags
  std::vector<Vec3> nodes;
  std::unordered_map<long, int> node_index;
  std::vector<VolumeElement> volumes;
  std::vector<SurfaceElement> surfaces;
  std::vector<LineElement> lines;

  long int_field(const char* what) { return binary ? long(tk.raw<std::int32_t>(what)) : tk.integer(what); }
  long size_field(const char* what) {
    if (!binary) return tk.integer(what);
    const std::uint64_t v = size_bytes == 8 ? tk.raw<std::uint64_t>(what) : tk.raw<std::uint32_t>(what);
    if (v > (std::uint64_t(1) << 53)) tk.fail(std::to_string(v), std::string("implausible value in binary data (") + what + ")");
    return long(v);
  }
  double real_field(const char* what) {
    if (!binary) return tk.real(what);
    const double v = tk.raw<double>(what);
    if (!std::isfinite(v)) tk.fail("", std::string("non-finite number in binary data (") + what + ")");
    return v;
  }
  /// A count read from the file: non-negative and not more items than bytes left (each takes at least
  /// one), so a corrupt or truncated file is an InputError, not a huge allocation.
  long count_field(const char* what, bool size_type) {
    const long n = size_type ? size_field(what) : int_field(what);
    if (n < 0 || std::size_t(n) > tk.remaining())
      tk.fail(std::to_string(n), std::string("invalid count (") + what + "): negative or beyond the end of the file");
    return n;
  }
  int node_of(long tag) {
    const auto it = node_index.find(tag);
    if (it == node_index.end()) tk.fail(std::to_string(tag), "element refers to a node that is not in $Nodes");
    return it->second;
  }
  std::string physical_name(int dim, long tag) const {
    const auto it = physical_names[dim].find(tag);
    return it != physical_names[dim].end() ? it->second : std::to_string(tag);
  }

  void read_sections();
  void read_format();
  void read_physical_names();
  void read_entities();
  void read_nodes();
  void read_elements();
};

void GmshReader::read_sections() {
  while (!tk.at_end()) {
    const std::string section(tk.next());
    if (section == "$MeshFormat") read_format();
    else if (!have_format) tk.fail(section, "the file must start with $MeshFormat (is this a Gmsh .msh file?)");
    else if (section == "$PhysicalNames") read_physical_names();
    else if (section == "$Entities") read_entities();
    else if (section == "$Nodes") read_nodes();
    else if (section == "$Elements") read_elements();
    else if (!section.empty() && section[0] == '$' && section.rfind("$End", 0) != 0)
      tk.skip_section(section.substr(1));  // $NodeData, $Periodic, $PartitionedEntities, ...
    else tk.fail(section, "expected a section name ($Nodes, $Elements, ...)");
  }
  if (!have_format) tk.fail("", "empty file or no $MeshFormat");
  if (!have_nodes || !have_elements) tk.fail("", "missing $Nodes or $Elements");
}

void GmshReader::read_format() {
  const std::string version(tk.expect_token("version"));
  const int line = tk.line();
  const long file_type = tk.integer("file-type");
  const long data_size = tk.integer("data-size");
  if (version.rfind("4.1", 0) != 0)
    tk.fail_at(line, version,
               "unsupported MSH version (only 4.1 is read): re-export with Mesh.MshFileVersion = 4.1 "
               "(gmsh -format msh41)");
  if (file_type != 0 && file_type != 1)
    tk.fail_at(line, std::to_string(file_type), "file-type must be 0 (ASCII) or 1 (binary)");
  binary = file_type == 1;
  if (binary) {
    if (data_size != 4 && data_size != 8)
      tk.fail_at(line, std::to_string(data_size), "data-size (bytes of size_t) must be 4 or 8 in a binary file");
    size_bytes = int(data_size);
    // The integer 1 written in the writer's byte order tells the endianness.
    tk.begin_binary();
    const std::int32_t one = tk.raw<std::int32_t>("endianness marker");
    if (one != 1) {
      std::int32_t swapped;
      unsigned char b[4];
      std::memcpy(b, &one, 4);
      std::reverse(b, b + 4);
      std::memcpy(&swapped, b, 4);
      if (swapped != 1) tk.fail_at(line, std::to_string(one), "binary MSH: endianness marker is not the integer 1");
      tk.swap_bytes = true;
    }
  }
  tk.expect("$EndMeshFormat");
  have_format = true;
}

void GmshReader::read_physical_names() {
  const long n = tk.integer("number of physical names");
  for (long k = 0; k < n; ++k) {
    const long dim = tk.integer("physical dimension");
    const long tag = tk.integer("physical tag");
    if (dim < 0 || dim > 3) tk.fail(std::to_string(dim), "physical dimension must be 0..3");
    physical_names[dim][tag] = std::string(tk.expect_token("physical name"));
  }
  tk.expect("$EndPhysicalNames");
}

void GmshReader::read_entities() {
  if (binary) tk.begin_binary();
  long count[4];
  for (long& c : count) c = count_field("number of entities", true);
  for (int dim = 0; dim < 4; ++dim)
    for (long k = 0; k < count[dim]; ++k) {
      const long tag = int_field("entity tag");
      for (int c = 0; c < (dim == 0 ? 3 : 6); ++c) real_field("entity bounding box");
      const long np = count_field("number of physical tags", true);
      auto& phys = entity_physicals[dim][tag];
      for (long p = 0; p < np; ++p) phys.push_back(std::labs(int_field("physical tag")));
      if (dim > 0) {
        const long nb = count_field("number of bounding entities", true);
        for (long b = 0; b < nb; ++b) int_field("bounding entity tag");
      }
    }
  tk.expect("$EndEntities");
  have_entities = true;
}

void GmshReader::read_nodes() {
  if (binary) tk.begin_binary();
  const long blocks = count_field("number of node blocks", true);
  const long total = count_field("number of nodes", true);
  size_field("min node tag");
  size_field("max node tag");
  nodes.reserve(total);
  node_index.reserve(total);
  for (long b = 0; b < blocks; ++b) {
    const long dim = int_field("entity dimension");
    int_field("entity tag");
    const long parametric = int_field("parametric flag");
    const long n = count_field("nodes in block", true);
    std::vector<long> tags(n);
    for (long& t : tags) t = size_field("node tag");
    for (long k = 0; k < n; ++k) {
      Vec3 x;
      for (int i = 0; i < 3; ++i) x[i] = real_field("node coordinate");
      if (parametric)
        for (long i = 0; i < dim; ++i) real_field("parametric coordinate");
      if (!node_index.emplace(tags[k], int(nodes.size())).second)
        tk.fail(std::to_string(tags[k]), "node tag defined twice");
      nodes.push_back(x);
    }
  }
  if (long(nodes.size()) != total) tk.fail(std::to_string(total), "node count does not match the blocks");
  tk.expect("$EndNodes");
  have_nodes = true;
}

void GmshReader::read_elements() {
  if (!have_nodes) tk.fail("$Elements", "$Elements before $Nodes");
  if (binary) tk.begin_binary();
  const long blocks = count_field("number of element blocks", true);
  count_field("number of elements", true);
  size_field("min element tag");
  size_field("max element tag");
  for (long b = 0; b < blocks; ++b) {
    const long dim = int_field("entity dimension");
    const long entity = int_field("entity tag");
    const long type = int_field("element type");
    const int type_line = tk.line();
    const long n = count_field("elements in block", true);
    const int nn = gmsh_nodes(type);
    if (nn == 0)
      tk.fail_at(type_line, std::to_string(type), "unknown Gmsh element type");
    const bool line_ok = dim == 1 && (type == 1 || type == 8);
    const bool ignored = dim < 2 && !line_ok;
    const bool volume_ok = dim == 3 && (type == 4 || type == 11 || type == 5);
    const bool surface_ok = dim == 2 && (type == 2 || type == 9 || type == 3);
    if (!ignored && !line_ok && !volume_ok && !surface_ok)
      tk.fail_at(type_line, std::to_string(type),
                 std::string("unsupported element type (") + gmsh_name(type) + ", dimension " +
                     std::to_string(dim) + "): volumes must be tetrahedra (4, 11) or hexahedra (5), " +
                     "surfaces triangles (2, 9) or quadrangles (3)");
    if (dim == 3 && have_entities && !entity_physicals[3].count(entity))
      tk.fail_at(type_line, std::to_string(entity), "volume entity not listed in $Entities");
    for (long k = 0; k < n; ++k) {
      const long tag = size_field("element tag");
      const int line = tk.line();
      std::vector<int> en(nn);
      for (int& v : en) v = ignored ? (size_field("node tag"), 0) : node_of(size_field("node tag"));
      if (ignored) continue;
      if (dim == 1) lines.push_back({entity, std::move(en)});
      else if (dim == 3) volumes.push_back({tag, line, entity, type, std::move(en)});
      else surfaces.push_back({tag, line, int(entity), std::move(en)});
    }
  }
  tk.expect("$EndElements");
  have_elements = true;
}

bool valid_tet(const Mesh& mesh, const Tet10& t) {
  Tet10Coords X;
  for (int a = 0; a < 10; ++a) X.row(a) = mesh.nodes[t[a]].transpose();
  return tet10_geometry(X).valid;
}

/// Straight edges for the tets that curved ones invert (parse_gmsh); a few passes, as a straightened
/// edge changes its neighbours too.
void straighten_inverted_tets(Mesh& mesh) {
  for (int pass = 0; pass < 3; ++pass) {
    bool found = false;
    for (const Tet10& t : mesh.tets) {
      if (valid_tet(mesh, t)) continue;
      for (int k = 0; k < 6; ++k)
        mesh.nodes[t[4 + k]] = 0.5 * (mesh.nodes[t[kTet10Edges[k][0]]] + mesh.nodes[t[kTet10Edges[k][1]]]);
      found = true;
    }
    if (!found) return;
  }
}

/// The volume elements as a Mesh: regions, tets promoted to tet10, orientation, Jacobian check.
Mesh volume_mesh(GmshReader& r, bool straighten_inverted) {
  Tokens& tk = r.tk;
  const std::vector<VolumeElement>& volumes = r.volumes;
  Mesh mesh;
  mesh.nodes = std::move(r.nodes);
  // Regions: volume physical groups in order of first appearance ("" for volumes without one).
  std::map<long, int> region_of_physical;
  auto region_of_entity = [&](long entity) {
    const auto it = r.entity_physicals[3].find(entity);
    const long phys = (it == r.entity_physicals[3].end() || it->second.empty()) ? 0 : it->second.front();
    auto known = region_of_physical.find(phys);
    if (known == region_of_physical.end()) {
      known = region_of_physical.emplace(phys, int(mesh.region_names.size())).first;
      mesh.region_names.push_back(phys == 0 ? std::string() : r.physical_name(3, phys));
    }
    return known->second;
  };
  // Mid-edge nodes: those of tet10 elements first, then new straight ones for promoted tet4s (shared
  // between neighbours through the edge map).
  std::unordered_map<std::array<int, 2>, int, ArrayHash> mid;
  auto edge_key = [](int a, int b) { return a < b ? std::array<int, 2>{a, b} : std::array<int, 2>{b, a}; };
  for (const VolumeElement& v : volumes)
    if (v.type == 11)
      for (int e = 0; e < 6; ++e)
        mid.emplace(edge_key(v.nodes[kTet10Edges[e][0]], v.nodes[kTet10Edges[e][1]]), v.nodes[4 + e]);
  auto mid_node = [&](int a, int b) {
    const auto key = edge_key(a, b);
    const auto it = mid.find(key);
    if (it != mid.end()) return it->second;
    const int id = int(mesh.nodes.size());
    mesh.nodes.push_back(0.5 * (mesh.nodes[a] + mesh.nodes[b]));
    mid.emplace(key, id);
    return id;
  };
  // Volume elements: hexes first, then tets (the Mesh numbering); lines kept for messages.
  std::vector<int> hex_line, tet_line, hex_region, tet_region;
  for (const VolumeElement& v : volumes) {
    const int region = region_of_entity(v.entity);
    if (v.type == 5) {
      Hex h;
      std::copy(v.nodes.begin(), v.nodes.end(), h.begin());
      mesh.hexes.push_back(h);
      hex_line.push_back(v.line);
      hex_region.push_back(region);
    } else {
      Tet10 t;
      for (int a = 0; a < 4; ++a) t[a] = v.nodes[a];
      for (int e = 0; e < 6; ++e)
        t[4 + e] = v.type == 11 ? v.nodes[4 + e] : mid_node(t[kTet10Edges[e][0]], t[kTet10Edges[e][1]]);
      mesh.tets.push_back(t);
      tet_line.push_back(v.line);
      tet_region.push_back(region);
    }
  }
  mesh.region = hex_region;
  mesh.region.insert(mesh.region.end(), tet_region.begin(), tet_region.end());
  orient_hexes(mesh);
  orient_tets(mesh);
  if (straighten_inverted) straighten_inverted_tets(mesh);
  for (std::size_t k = 0; k < mesh.hexes.size(); ++k) {
    Mat83 X;
    for (int a = 0; a < 8; ++a) X.row(a) = mesh.nodes[mesh.hexes[k][a]].transpose();
    if (!hex8_geometry(X).valid)
      tk.fail_at(hex_line[k], "", "hexahedron with a non-positive Jacobian (distorted or wrongly numbered)");
  }
  for (std::size_t k = 0; k < mesh.tets.size(); ++k) {
    if (!valid_tet(mesh, mesh.tets[k]))
      tk.fail_at(tet_line[k], "",
                 "tetrahedron with a non-positive Jacobian (degenerate, or mid-edge nodes far off their edges)");
  }

  return mesh;
}

/// Surface physical groups: each face matched to a volume element's face, in that element's orientation.
void attach_surfaces(GmshReader& r, Mesh& mesh) {
  Tokens& tk = r.tk;
  // Element faces by their sorted vertices → (element, local face); interior faces keep the first.
  std::unordered_map<std::array<int, 3>, std::pair<int, int>, ArrayHash> tri_faces;
  std::unordered_map<std::array<int, 4>, std::pair<int, int>, ArrayHash> quad_faces;
  for (std::size_t t = 0; t < mesh.tets.size(); ++t)
    for (int f = 0; f < 4; ++f) {
      std::array<int, 3> k;
      for (int i = 0; i < 3; ++i) k[i] = mesh.tets[t][kTetFaces[f][i]];
      std::sort(k.begin(), k.end());
      tri_faces.emplace(k, std::pair<int, int>(int(t), f));
    }
  for (std::size_t h = 0; h < mesh.hexes.size(); ++h)
    for (int f = 0; f < 6; ++f) {
      std::array<int, 4> k;
      for (int i = 0; i < 4; ++i) k[i] = mesh.hexes[h][kHexFaces[f][i]];
      std::sort(k.begin(), k.end());
      quad_faces.emplace(k, std::pair<int, int>(int(h), f));
    }
  for (const SurfaceElement& s : r.surfaces) {
    const auto it = r.entity_physicals[2].find(s.entity);
    if (r.have_entities && it == r.entity_physicals[2].end())
      tk.fail_at(s.line, std::to_string(s.entity), "surface entity not listed in $Entities");
    if (it == r.entity_physicals[2].end() || it->second.empty()) continue;  // not in a physical group
    if (s.nodes.size() == 4) {
      std::array<int, 4> k{s.nodes[0], s.nodes[1], s.nodes[2], s.nodes[3]};
      std::sort(k.begin(), k.end());
      const auto f = quad_faces.find(k);
      if (f == quad_faces.end())
        tk.fail_at(s.line, std::to_string(s.tag), "quadrangle is not the face of any hexahedron");
      Quad q;
      for (int i = 0; i < 4; ++i) q[i] = mesh.hexes[f->second.first][kHexFaces[f->second.second][i]];
      for (long phys : it->second) mesh.surfaces[r.physical_name(2, phys)].push_back(q);
      continue;
    }
    std::array<int, 3> k{s.nodes[0], s.nodes[1], s.nodes[2]};
    std::sort(k.begin(), k.end());
    const auto f = tri_faces.find(k);
    if (f == tri_faces.end())
      tk.fail_at(s.line, std::to_string(s.tag), "triangle is not the face of any tetrahedron");
    Tri6 q;
    for (int i = 0; i < 6; ++i) q[i] = mesh.tets[f->second.first][kTet10Faces[f->second.second][i]];
    if (s.nodes.size() == 6) {
      // Its mid-edge nodes must be the tetrahedron's (same edges, same nodes).
      std::array<int, 3> given{s.nodes[3], s.nodes[4], s.nodes[5]}, own{q[3], q[4], q[5]};
      std::sort(given.begin(), given.end());
      std::sort(own.begin(), own.end());
      if (given != own)
        tk.fail_at(s.line, std::to_string(s.tag), "6-node triangle's mid-edge nodes differ from its tetrahedron's");
    }
    for (long phys : it->second) mesh.tri_surfaces[r.physical_name(2, phys)].push_back(q);
  }
}

/// Drops nodes no volume element uses (geometry points, nodes of unsaved entities): they would carry
/// degrees of freedom without stiffness.
void drop_unused_nodes(Mesh& mesh) {
  std::vector<int> renumber(mesh.nodes.size(), -1);
  int used = 0;
  for (int e = 0; e < mesh.num_elements(); ++e)
    for (int a = 0; a < mesh.element_size(e); ++a) {
      int& r = renumber[mesh.element_nodes(e)[a]];
      if (r < 0) r = used++;
    }
  if (used < int(mesh.nodes.size())) {
    std::vector<Vec3> kept(used);
    for (std::size_t n = 0; n < mesh.nodes.size(); ++n)
      if (renumber[n] >= 0) kept[renumber[n]] = mesh.nodes[n];
    mesh.nodes = std::move(kept);
    for (Hex& h : mesh.hexes)
      for (int& n : h) n = renumber[n];
    for (Tet10& t : mesh.tets)
      for (int& n : t) n = renumber[n];
    for (auto& [name, faces] : mesh.surfaces)
      for (Quad& q : faces)
        for (int& n : q) n = renumber[n];
    for (auto& [name, faces] : mesh.tri_surfaces)
      for (Tri6& q : faces)
        for (int& n : q) n = renumber[n];
  }
}

}  // namespace

Mesh parse_gmsh(std::istream& in, const std::string& source, bool straighten_inverted) {
  std::ostringstream buffer;
  buffer << in.rdbuf();
  GmshReader reader(buffer.str(), source);
  reader.read_sections();
  if (reader.volumes.empty())
    reader.tk.fail("", "no volume elements (tetrahedra or hexahedra): mesh the volume (gmsh -3) and make sure its "
                       "physical group is saved");
  Mesh mesh = volume_mesh(reader, straighten_inverted);
  attach_surfaces(reader, mesh);
  drop_unused_nodes(mesh);
  return mesh;
}

namespace {

/// The physical groups (of dimension dim) an entity belongs to, by name.
std::vector<std::string> group_names(const GmshReader& r, int dim, int entity) {
  std::vector<std::string> out;
  const auto it = r.entity_physicals[dim].find(entity);
  if (it != r.entity_physicals[dim].end())
    for (long phys : it->second) out.push_back(r.physical_name(dim, phys));
  return out;
}

/// The triangles of a 3- or 6-node triangle element; a 6-node one (vertices 0, 1, 2, then the mid-edge
/// nodes of 01, 12, 20) as its four 3-node triangles, in the parent's orientation.
void append_triangles(const std::vector<int>& n, std::vector<std::array<int, 3>>& out) {
  if (n.size() == 3) {
    out.push_back({n[0], n[1], n[2]});
    return;
  }
  out.push_back({n[0], n[3], n[5]});
  out.push_back({n[3], n[1], n[4]});
  out.push_back({n[5], n[4], n[2]});
  out.push_back({n[3], n[4], n[5]});
}

/// Keeps the nodes the triangles use (renumbered in order of first use) and the curve segments whose
/// nodes both stay.
void compact_surface(GmshSurface& s) {
  std::vector<int> id(s.nodes.size(), -1);
  std::vector<Vec3> kept;
  for (auto& t : s.triangles)
    for (int& n : t) {
      if (id[n] < 0) {
        id[n] = int(kept.size());
        kept.push_back(s.nodes[n]);
      }
      n = id[n];
    }
  s.nodes = std::move(kept);
  for (auto it = s.curves.begin(); it != s.curves.end();) {
    std::vector<std::array<int, 2>> segments;
    for (const auto& e : it->second)
      if (id[e[0]] >= 0 && id[e[1]] >= 0) segments.push_back({id[e[0]], id[e[1]]});
    if (segments.empty()) it = s.curves.erase(it);
    else (it++)->second = std::move(segments);
  }
}

}  // namespace

GmshSurface parse_gmsh_surface(std::istream& in, const std::string& source, const std::vector<std::string>& groups,
                               const std::string& field) {
  std::ostringstream buffer;
  buffer << in.rdbuf();
  GmshReader r(buffer.str(), source);
  r.read_sections();
  std::set<std::string> available, wanted(groups.begin(), groups.end());
  for (const auto& [tag, name] : r.physical_names[2]) available.insert(name);
  for (const auto& [entity, phys] : r.entity_physicals[2])
    for (long p : phys) available.insert(r.physical_name(2, p));
  for (std::size_t k = 0; k < groups.size(); ++k)
    if (!available.count(groups[k])) {
      std::string names;
      for (const std::string& a : available) names += (names.empty() ? "" : ", ") + ("\"" + a + "\"");
      throw InputError(groups.size() > 1 ? field + "[" + std::to_string(k) + "]" : field, "\"" + groups[k] + "\"",
                       "no physical surface of that name in " + source + " (it has " + (names.empty() ? "none" : names) + ")");
    }
  GmshSurface s;
  s.nodes = std::move(r.nodes);
  for (const SurfaceElement& e : r.surfaces) {
    const std::vector<std::string> of = group_names(r, 2, e.entity);
    // No group named: the triangles of every physical surface (or all of them when the file has none).
    const bool take = wanted.empty() ? (available.empty() || !of.empty())
                                     : std::any_of(of.begin(), of.end(), [&](const std::string& g) { return wanted.count(g) > 0; });
    if (!take) continue;
    if (e.nodes.size() == 4)
      throw InputError(field, source + ":" + std::to_string(e.line),
                       "element " + std::to_string(e.tag) + " is a quadrangle: a shell surface is made of 3- or 6-node triangles");
    const int first = int(s.triangles.size());
    append_triangles(e.nodes, s.triangles);
    s.split_quadratic += e.nodes.size() == 6;
    for (const std::string& g : of)
      for (int t = first; t < int(s.triangles.size()); ++t) s.groups[g].push_back(t);
  }
  for (const std::string& g : groups)
    if (!s.groups.count(g))
      throw InputError(field, "\"" + g + "\"", "the physical surface holds no triangles in " + source +
                                                   " (mesh it in 2D: gmsh -2, and save its group)");
  if (s.triangles.empty())
    throw InputError(field, source, "no triangles on physical surfaces: mesh the surface (gmsh -2) and save its physical group");
  for (const LineElement& e : r.lines)
    for (const std::string& g : group_names(r, 1, e.entity)) {
      auto& list = s.curves[g];
      if (e.nodes.size() == 2) list.push_back({e.nodes[0], e.nodes[1]});
      else list.insert(list.end(), {{e.nodes[0], e.nodes[2]}, {e.nodes[2], e.nodes[1]}});  // line3: ends, then middle
    }
  compact_surface(s);
  return s;
}

GmshSurface read_gmsh_surface(const std::filesystem::path& file, const std::vector<std::string>& groups,
                              const std::string& field, const std::string& groups_field) {
  std::istringstream in(read_input_file(file, field, kMeshFile));
  return parse_gmsh_surface(in, file.string(), groups, groups_field);
}

Mesh read_gmsh(const std::filesystem::path& file, const std::string& field, bool straighten_inverted) {
  std::istringstream in(read_input_file(file, field, kMeshFile));
  return parse_gmsh(in, file.string(), straighten_inverted);
}

namespace {

/// The lines of the group (by name, or by tag when it has none), InputError on group_field when none.
std::vector<const LineElement*> group_lines(const GmshReader& r, const std::string& group, const std::string& group_field,
                                            const std::string& source) {
  std::vector<long> tags;
  std::string known;
  std::map<long, bool> seen;
  for (const auto& [entity, physicals] : r.entity_physicals[1])
    for (long p : physicals) seen.emplace(p, true);
  for (const auto& [p, name] : r.physical_names[1]) seen.emplace(p, true);
  for (const auto& [p, unused] : seen) {
    const std::string name = r.physical_name(1, p);
    known += (known.empty() ? "" : ", ") + ("\"" + name + "\"");
    if (name == group || std::to_string(p) == group) tags.push_back(p);
  }
  if (tags.empty())
    throw InputError(group_field, "\"" + group + "\"",
                     "no physical curve group of that name in " + source +
                         (known.empty() ? " (it has none)" : " (its curve groups: " + known + ")"));
  std::vector<const LineElement*> out;
  for (const LineElement& l : r.lines) {
    const auto it = r.entity_physicals[1].find(l.entity);
    if (it == r.entity_physicals[1].end()) continue;
    if (std::any_of(it->second.begin(), it->second.end(), [&](long p) { return std::find(tags.begin(), tags.end(), p) != tags.end(); }))
      out.push_back(&l);
  }
  if (out.empty())
    throw InputError(group_field, "\"" + group + "\"",
                     "the physical curve group has no line elements in " + source + " (mesh its curves and save the group)");
  for (const LineElement* l : out)
    if (l->nodes.size() != out.front()->nodes.size())
      throw InputError(group_field, "\"" + group + "\"", "the group mixes 2-node and 3-node lines");
  return out;
}

/// Chains lines sharing end nodes into polylines (see GmshLineGroup): first from every node where the
/// chain cannot continue (not two lines), then the closed loops left.
std::vector<std::vector<Vec3>> chain_lines(const std::vector<const LineElement*>& lines, const std::vector<Vec3>& x) {
  std::unordered_map<int, std::vector<int>> at;  // end node → lines
  for (int e = 0; e < int(lines.size()); ++e)
    for (int end = 0; end < 2; ++end) at[lines[e]->nodes[end]].push_back(e);
  std::vector<bool> used(lines.size(), false);
  std::vector<std::vector<Vec3>> out;
  auto walk = [&](int e, int node) {
    std::vector<Vec3> points{x[node]};
    while (!used[e]) {
      used[e] = true;
      const std::vector<int>& n = lines[e]->nodes;
      const int next = n[0] == node ? n[1] : n[0];
      if (n.size() == 3) points.push_back(x[n[2]]);
      points.push_back(x[next]);
      node = next;
      const std::vector<int>& there = at[node];
      if (there.size() != 2) break;
      e = there[0] == e ? there[1] : there[0];
    }
    out.push_back(std::move(points));
  };
  for (int e = 0; e < int(lines.size()); ++e)
    for (int end = 0; end < 2; ++end) {
      const int node = lines[e]->nodes[end];
      if (!used[e] && at[node].size() != 2) walk(e, node);
    }
  for (int e = 0; e < int(lines.size()); ++e)
    if (!used[e]) walk(e, lines[e]->nodes[0]);
  return out;
}

}  // namespace

GmshLineGroup parse_gmsh_line_group(std::istream& in, const std::string& source, const std::string& group,
                                    const std::string& group_field) {
  std::ostringstream buffer;
  buffer << in.rdbuf();
  GmshReader reader(buffer.str(), source);
  reader.read_sections();
  const std::vector<const LineElement*> lines = group_lines(reader, group, group_field, source);
  GmshLineGroup out;
  out.nodes_per_line = int(lines.front()->nodes.size());
  out.polylines = chain_lines(lines, reader.nodes);
  return out;
}

GmshLineGroup read_gmsh_line_group(const std::filesystem::path& file, const std::string& group,
                                   const std::string& group_field, const std::string& file_field) {
  std::istringstream in(read_input_file(file, file_field, kMeshFile));
  return parse_gmsh_line_group(in, file.string(), group, group_field);
}

}  // namespace softhom::io
