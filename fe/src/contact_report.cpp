// The outputs of a contact with a rigid obstacle (contact.hpp): its probes for response.csv and the
// contact pressure and gap on its faces as a field of its own.
#include <map>

#include "softhom/fe/contact.hpp"

namespace softhom::fe {
namespace {

/// The faces [first, first + faces.size()) of the surface as cells of their own: the nodes they use at
/// their reference positions (local numbering), their displacement, and the per-face arrays.
template <class Faces>
ReportField face_field(const Mesh& mesh, const Iterate& it, const std::string& stem, ReportCells::Type type,
                       const Faces& faces, std::size_t first, const std::vector<double>& pressure,
                       const std::vector<double>& gap) {
  ReportField f;
  f.cells.stem = stem;
  f.cells.type = type;
  std::map<int, int> local;
  ReportArray u{"displacement", "mm", 3, false, {}};
  for (const auto& q : faces)
    for (int n : q) {
      const auto [at, added] = local.emplace(n, int(local.size()));
      if (added) {
        f.cells.points.push_back(mesh.nodes[n]);
        for (int i = 0; i < 3; ++i) u.values.push_back((*it.u)[3 * n + i]);
      }
      f.cells.connectivity.push_back(at->second);
    }
  ReportArray p{"contact_pressure", "MPa", 1, true, {}}, g{"gap", "mm", 1, true, {}};
  p.values.assign(pressure.begin() + long(first), pressure.begin() + long(first + faces.size()));
  g.values.assign(gap.begin() + long(first), gap.begin() + long(first + faces.size()));
  f.arrays = {std::move(p), std::move(g), std::move(u)};
  return f;
}

}  // namespace

void ObstacleContact::report(const Mesh& mesh, const Iterate& it, ContributionReport& out) const {
  const ContactTotals t = totals(mesh, it);
  const std::string& s = options_.label;
  out.probes.emplace_back(s + "_normal_force [N]", t.normal_force);
  out.probes.emplace_back(s + "_tangential_force [N]", t.tangential_force);
  out.probes.emplace_back(s + "_area [mm^2]", t.area);
  out.probes.emplace_back(s + "_active_points [1]", double(t.active_points));
  out.probes.emplace_back(s + "_max_penetration [mm]", t.max_penetration);
  std::vector<double> pressure, gap;
  face_values(mesh, it, pressure, gap);
  // One field per face kind: a surface is quads or 6-node triangles (both only on a mixed mesh).
  if (!quads_.empty()) out.fields.push_back(face_field(mesh, it, s, ReportCells::Type::quad4, quads_, 0, pressure, gap));
  if (!tris_.empty())
    out.fields.push_back(face_field(mesh, it, quads_.empty() ? s : s + "_tri", ReportCells::Type::triangle6, tris_,
                                    quads_.size(), pressure, gap));
}

}  // namespace softhom::fe
