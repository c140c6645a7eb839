// The outputs of contacts: the probes and the face fields every contact reports, and those of a contact
// with a rigid obstacle (contact.hpp).
#include <map>
#include <utility>

#include "softhom/fe/contact.hpp"

namespace softhom::fe {
namespace {

template <class Faces>
std::vector<std::vector<int>> node_lists(const Faces& faces) {
  std::vector<std::vector<int>> lists;
  for (const auto& face : faces) lists.emplace_back(face.begin(), face.end());
  return lists;
}

}  // namespace

void add_contact_probes(const std::string& label, const ContactTotals& t, ContributionReport& out) {
  const std::pair<const char*, double> columns[] = {{"_normal_force [N]", t.normal_force},
                                                    {"_tangential_force [N]", t.tangential_force},
                                                    {"_area [mm^2]", t.area},
                                                    {"_active_points [1]", double(t.active_points)},
                                                    {"_max_penetration [mm]", t.max_penetration}};
  for (const auto& [column, value] : columns) out.probes.emplace_back(label + column, value);
}

ReportField contact_face_field(const Mesh& mesh, const Iterate& it, const std::string& stem, ReportCells::Type type,
                               const std::vector<std::vector<int>>& faces, std::vector<double> pressure,
                               std::vector<double> gap) {
  ReportField f;
  f.cells.stem = stem;
  f.cells.type = type;
  std::map<int, int> local;
  ReportArray u{"displacement", "mm", 3, false, {}};
  for (const std::vector<int>& face : faces)
    for (int n : face) {
      const auto [at, added] = local.emplace(n, int(local.size()));
      if (added) {
        f.cells.points.push_back(mesh.nodes[n]);
        for (int i = 0; i < 3; ++i) u.values.push_back(it.u ? (*it.u)[3 * n + i] : 0.0);
      }
      f.cells.connectivity.push_back(at->second);
    }
  f.arrays = {ReportArray{"contact_pressure", "MPa", 1, true, std::move(pressure)},
              ReportArray{"gap", "mm", 1, true, std::move(gap)}, std::move(u)};
  return f;
}

void ObstacleContact::report(const Mesh& mesh, const Iterate& it, ContributionReport& out) const {
  const std::string& s = options_.label;
  add_contact_probes(s, totals(mesh, it), out);
  std::vector<double> pressure, gap;
  face_values(mesh, it, pressure, gap);
  // One field per face kind: a surface is quads or 6-node triangles (both only on a mixed mesh).
  const auto nq = long(quads_.size());
  if (!quads_.empty())
    out.fields.push_back(contact_face_field(mesh, it, s, ReportCells::Type::quad4, node_lists(quads_),
                                            {pressure.begin(), pressure.begin() + nq}, {gap.begin(), gap.begin() + nq}));
  if (!tris_.empty())
    out.fields.push_back(contact_face_field(mesh, it, quads_.empty() ? s : s + "_tri", ReportCells::Type::triangle6,
                                            node_lists(tris_), {pressure.begin() + nq, pressure.end()},
                                            {gap.begin() + nq, gap.end()}));
}

}  // namespace softhom::fe
