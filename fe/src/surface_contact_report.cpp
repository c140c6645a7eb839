// The outputs of a contact between deformable surfaces (surface_contact.hpp): its probes for
// response.csv and the contact pressure, gap, tangential traction and slip on its slave faces as a
// field of its own.
#include <cmath>
#include <utility>

#include "softhom/fe/surface_contact.hpp"

namespace softhom::fe {

void SurfaceContact::report(const Mesh& mesh, const Iterate& it, ContributionReport& out) const {
  const std::string& s = options_.label;
  const ContactTotals totals = this->totals(mesh, it);
  add_contact_probes(s, totals, out);
  const bool friction = options_.friction > 0.0;
  if (friction) out.probes.emplace_back(s + "_slipping_points [1]", double(totals.slipping_points));
  const FaceValues v = face_values(mesh, it);
  // One field per face kind on the slave faces (quads, then 6-node triangles on a mixed surface). A face
  // with no master face within the search reach (two face sizes) has its gap written as that reach: the
  // gap is at least that.
  bool first = true;
  for (const bool quads : {true, false}) {
    std::vector<std::vector<int>> faces;
    std::vector<double> p, g, t, slip;
    for (std::size_t k = 0; k < faces_.size(); ++k) {
      const Face& face = faces_[k];
      if (!face.slave || face.quad() != quads) continue;
      faces.emplace_back(face.nodes.begin(), face.nodes.begin() + face.nodes_count);
      p.push_back(v.pressure[k]);
      g.push_back(std::isfinite(v.gap[k]) ? v.gap[k] : 2.0 * face.size);
      t.push_back(v.tangential[k]);
      slip.push_back(v.slip[k]);
    }
    if (faces.empty()) continue;
    out.fields.push_back(contact_face_field(mesh, it, first ? s : s + "_tri",
                                            quads ? ReportCells::Type::quad4 : ReportCells::Type::triangle6, faces,
                                            std::move(p), std::move(g)));
    if (friction) {
      out.fields.back().arrays.push_back(ReportArray{"tangential_traction", "MPa", 1, true, std::move(t)});
      out.fields.back().arrays.push_back(ReportArray{"slip", "1", 1, true, std::move(slip)});
    }
    first = false;
  }
}

}  // namespace softhom::fe
