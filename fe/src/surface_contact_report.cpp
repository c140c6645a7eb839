// The outputs of a contact between deformable surfaces (surface_contact.hpp): its probes for
// response.csv and the contact pressure and gap on its slave faces as a field of its own.
#include <cmath>
#include <map>
#include <utility>

#include "softhom/fe/surface_contact.hpp"

namespace softhom::fe {

void add_contact_probes(const std::string& label, const ContactTotals& t, ContributionReport& out) {
  const std::pair<const char*, double> columns[] = {{"_normal_force [N]", t.normal_force},
                                                    {"_tangential_force [N]", t.tangential_force},
                                                    {"_area [mm^2]", t.area},
                                                    {"_active_points [1]", double(t.active_points)},
                                                    {"_max_penetration [mm]", t.max_penetration}};
  for (const auto& [column, value] : columns) out.probes.emplace_back(label + column, value);
}

void SurfaceContact::report(const Mesh& mesh, const Iterate& it, ContributionReport& out) const {
  const std::string& s = options_.label;
  add_contact_probes(s, totals(mesh, it), out);
  std::vector<double> pressure, gap;
  face_values(mesh, it, pressure, gap);
  // One field per face kind on the slave faces (quads, then 6-node triangles on a mixed surface). A face
  // with no master face within the search reach (two face sizes) has its gap written as that reach: the
  // gap is at least that.
  bool first = true;
  for (const bool quads : {true, false}) {
    ReportField f;
    f.cells.type = quads ? ReportCells::Type::quad4 : ReportCells::Type::triangle6;
    std::map<int, int> local;
    ReportArray u{"displacement", "mm", 3, false, {}}, p{"contact_pressure", "MPa", 1, true, {}}, g{"gap", "mm", 1, true, {}};
    for (std::size_t k = 0; k < faces_.size(); ++k) {
      const Face& face = faces_[k];
      if (!face.slave || face.quad() != quads) continue;
      for (int a = 0; a < face.nodes_count; ++a) {
        const int n = face.nodes[a];
        const auto [at, added] = local.emplace(n, int(local.size()));
        if (added) {
          f.cells.points.push_back(mesh.nodes[n]);
          for (int i = 0; i < 3; ++i) u.values.push_back(it.u ? (*it.u)[3 * n + i] : 0.0);
        }
        f.cells.connectivity.push_back(at->second);
      }
      p.values.push_back(pressure[k]);
      g.values.push_back(std::isfinite(gap[k]) ? gap[k] : 2.0 * face.size);
    }
    if (p.values.empty()) continue;
    f.cells.stem = first ? s : s + "_tri";
    first = false;
    f.arrays = {std::move(p), std::move(g), std::move(u)};
    out.fields.push_back(std::move(f));
  }
}

}  // namespace softhom::fe
