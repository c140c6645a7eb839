// bench_febio_export SCENE.toml OUT.feb [--steps N]
//
// Writes a complete FEBio 4 model of a `softhom macro` scene: the same hex8 mesh (node and face order
// are FEBio's), the material as the card of studies/material_cards.hpp (uncoupled solid mixture:
// Gent + HGO, FEBio's three-field hex8 = softhom's mean-dilatation F-bar hex8), the element fiber frames
// as ElementData mat_axis (cylindrical/spherical frames of the scene, at the element centroid as
// softhom does), the scene's prescribed displacements and follower pressures with their load curves,
// and a node displacement log (OUT.nodes.csv) at every step. Also writes OUT.probes.json (the probe
// node ids and reference positions) for bench/compare_febio.py, which compares FEBio's result with
// softhom's response.csv. Used to verify the FEBio card by running FEBio (BENCHMARKS.md, "Material
// cards: FEBio and Abaqus"); FEBio itself is not part of softhom.
#include <cmath>
#include <fstream>
#include <iostream>
#include <map>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "softhom/io/scene.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/scene_keys.hpp"
#include "softhom/macro/scene.hpp"
#include "softhom/macro/structures.hpp"
#include "softhom/studies/material_cards.hpp"

using namespace softhom;

namespace {

std::string num(double x) { return format_number(x); }

/// The <material ...> ... </material> element of a card (without the comment and <Material> tags).
std::string material_element(const std::string& card) {
  const std::size_t a = card.find("\t<material"), b = card.find("</Material>");
  return card.substr(a, b - a);
}

std::string curve_points(const PiecewiseLinear& f, double scale = 1.0) {
  std::ostringstream s;
  for (std::size_t k = 0; k < f.t.size(); ++k) s << "\t\t\t\t<pt>" << num(f.t[k]) << "," << num(scale * f.v[k]) << "</pt>\n";
  return s.str();
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::cerr << "usage: bench_febio_export SCENE.toml OUT.feb\n";
    return 2;
  }
  try {
    const std::filesystem::path scene_path = argv[1], out = argv[2];
    const toml::table scene = io::load_scene(scene_path);
    const macro::MacroScene ms = macro::parse_macro_scene(scene, scene_path);
    if (ms.spec.tet10 || ms.spec.kind == macro::StructureKind::actuator || ms.spec.control == macro::LoadControl::volume)
      throw InputError("geometry", "", "the FEBio export handles hex8 plates, tubes, spheres under pressure or stretch control");
    const MaterialSpec mspec = parse_material(keys::read_table(*scene.get("material"), "material"), "material");
    const macro::Structure st = macro::build_structure(ms.spec);
    const fe::Mesh& mesh = st.model.mesh;

    std::ostringstream f;
    f.precision(17);
    f << "<?xml version=\"1.0\" encoding=\"ISO-8859-1\"?>\n"
      << "<!-- FEBio 4 model of the softhom scene " << scene_path.filename().string() << " (bench_febio_export) -->\n"
      << "<febio_spec version=\"4.0\">\n\t<Module type=\"solid\"/>\n";
    const double T = ms.times.back();
    const int steps = int(ms.times.size());
    f << "\t<Control>\n\t\t<analysis>STATIC</analysis>\n\t\t<time_steps>" << 4 * steps << "</time_steps>\n\t\t<step_size>"
      << num(T / steps / 4) << "</step_size>\n\t\t<plot_level>PLOT_MAJOR_ITRS</plot_level>\n"
      // Quarter steps with cut-backs; the output times are must points (the load curve of dtmax, id
      // 1), so FEBio's log has records at softhom's output times.
      << "\t\t<time_stepper type=\"default\">\n\t\t\t<max_retries>10</max_retries>\n\t\t\t<opt_iter>10</opt_iter>\n"
      << "\t\t\t<dtmin>" << num(1e-6 * T / steps) << "</dtmin>\n\t\t\t<dtmax lc=\"1\">" << num(T / steps)
      << "</dtmax>\n\t\t\t<aggressiveness>0</aggressiveness>\n\t\t\t<cutback>0.5</cutback>\n\t\t\t<dtforce>0</dtforce>\n"
      << "\t\t</time_stepper>\n"
      << "\t\t<solver type=\"solid\">\n\t\t\t<max_refs>50</max_refs>\n\t\t\t<dtol>1e-6</dtol>\n\t\t\t<etol>1e-8</etol>\n"
      << "\t\t\t<rtol>0</rtol>\n\t\t\t<lstol>0.9</lstol>\n\t\t\t<symmetric_stiffness>symmetric</symmetric_stiffness>\n"
      << "\t\t\t<qn_method type=\"BFGS\"><max_ups>0</max_ups></qn_method>\n\t\t</solver>\n\t</Control>\n";
    // Material: the card, id 1.
    f << "\t<Material>\n" << material_element(studies::febio_material_block(mspec, "softhom")) << "\t</Material>\n";

    // Mesh: nodes, hexes (softhom's hex8 node order is FEBio's), surfaces (outward normals both).
    f << "\t<Mesh>\n\t\t<Nodes name=\"all\">\n";
    for (int n = 0; n < mesh.num_nodes(); ++n)
      f << "\t\t\t<node id=\"" << n + 1 << "\">" << num(mesh.nodes[n].x()) << "," << num(mesh.nodes[n].y()) << ","
        << num(mesh.nodes[n].z()) << "</node>\n";
    f << "\t\t</Nodes>\n\t\t<Elements type=\"hex8\" name=\"Part1\">\n";
    for (int e = 0; e < mesh.num_hexes(); ++e) {
      f << "\t\t\t<elem id=\"" << e + 1 << "\">";
      for (int a = 0; a < 8; ++a) f << (a ? "," : "") << mesh.hexes[e][a] + 1;
      f << "</elem>\n";
    }
    f << "\t\t</Elements>\n";
    std::vector<std::string> load_surfaces;
    for (std::size_t p = 0; p < st.model.pressures.size(); ++p) {
      const std::string name = "pressure" + std::to_string(p + 1);
      load_surfaces.push_back(name);
      f << "\t\t<Surface name=\"" << name << "\">\n";
      int id = 0;
      for (const auto& q : st.model.pressures[p].faces)
        f << "\t\t\t<quad4 id=\"" << ++id << "\">" << q[0] + 1 << "," << q[1] + 1 << "," << q[2] + 1 << "," << q[3] + 1 << "</quad4>\n";
      f << "\t\t</Surface>\n";
    }
    // Prescribed displacements: one node set per (group, component, scale).
    struct Bc {
      std::string set, dof;
      double scale;
      std::size_t group;
    };
    std::vector<Bc> bcs;
    std::ostringstream sets;
    for (std::size_t g = 0; g < st.model.dirichlet.size(); ++g) {
      const auto& grp = st.model.dirichlet[g];
      std::map<std::pair<int, double>, std::vector<int>> split;
      for (std::size_t k = 0; k < grp.dofs.size(); ++k)
        split[{grp.dofs[k] % 3, grp.scale.empty() ? 1.0 : grp.scale[k]}].push_back(grp.dofs[k] / 3);
      for (const auto& [key, nodes] : split) {
        const std::string name = "bc" + std::to_string(bcs.size() + 1);
        bcs.push_back({name, std::string(1, "xyz"[key.first]), key.second, g});
        sets << "\t\t<NodeSet name=\"" << name << "\">";
        for (std::size_t i = 0; i < nodes.size(); ++i) sets << (i ? "," : "") << nodes[i] + 1;
        sets << "</NodeSet>\n";
      }
    }
    f << sets.str() << "\t</Mesh>\n";
    f << "\t<MeshDomains>\n\t\t<SolidDomain name=\"Part1\" mat=\"softhom\"/>\n\t</MeshDomains>\n";
    // Element fiber frames (local material axes relative to the global system).
    if (ms.spec.fiber_frame != macro::FiberFrame::global) {
      const auto centroids = macro::element_centroids(mesh);
      f << "\t<MeshData>\n\t\t<ElementData type=\"mat_axis\" elem_set=\"Part1\">\n";
      for (int e = 0; e < mesh.num_hexes(); ++e) {
        const Mat3 Q = ms.spec.fiber_frame == macro::FiberFrame::cylindrical ? macro::cylindrical_frame(centroids[e])
                                                                            : macro::spherical_frame(centroids[e]);
        f << "\t\t\t<elem lid=\"" << e + 1 << "\"><a>" << num(Q(0, 0)) << "," << num(Q(1, 0)) << "," << num(Q(2, 0))
          << "</a><d>" << num(Q(0, 1)) << "," << num(Q(1, 1)) << "," << num(Q(2, 1)) << "</d></elem>\n";
        // The card's directions composed with this frame must be softhom's element fibers.
        const auto dirs = st.model.element_material[e]->fiber_directions();
        for (std::size_t k = 0; k < dirs.size(); ++k)
          if ((Q * mspec.gent.fibers[k].direction.normalized() - dirs[k]).norm() > 1e-12)
            throw std::runtime_error("element " + std::to_string(e) + ": fiber frame does not reproduce softhom's fiber");
      }
      f << "\t\t</ElementData>\n\t</MeshData>\n";
    }
    // Boundary conditions and loads; load controllers: 1.. for displacement groups, then pressures.
    int lc = 1;  // 1: the must points of the time stepper
    std::map<std::size_t, int> group_lc;
    std::ostringstream curves;
    f << "\t<Boundary>\n";
    for (const Bc& b : bcs) {
      const auto& grp = st.model.dirichlet[b.group];
      bool zero = true;
      for (double v : grp.value.v) zero = zero && v == 0.0;
      if (zero || b.scale == 0.0) {
        f << "\t\t<bc name=\"" << b.set << "\" node_set=\"" << b.set << "\" type=\"zero displacement\">\n\t\t\t<x_dof>"
          << (b.dof == "x") << "</x_dof>\n\t\t\t<y_dof>" << (b.dof == "y") << "</y_dof>\n\t\t\t<z_dof>" << (b.dof == "z")
          << "</z_dof>\n\t\t</bc>\n";
        continue;
      }
      if (!group_lc.count(b.group)) {
        group_lc[b.group] = ++lc;
        curves << "\t\t<load_controller id=\"" << lc << "\" type=\"loadcurve\">\n\t\t\t<interpolate>LINEAR</interpolate>\n"
               << "\t\t\t<points>\n" << curve_points(grp.value) << "\t\t\t</points>\n\t\t</load_controller>\n";
      }
      f << "\t\t<bc name=\"" << b.set << "\" node_set=\"" << b.set << "\" type=\"prescribed displacement\">\n\t\t\t<dof>"
        << b.dof << "</dof>\n\t\t\t<value lc=\"" << group_lc[b.group] << "\">" << num(b.scale)
        << "</value>\n\t\t\t<relative>0</relative>\n\t\t</bc>\n";
    }
    f << "\t</Boundary>\n\t<Loads>\n";
    for (std::size_t p = 0; p < st.model.pressures.size(); ++p) {
      ++lc;
      curves << "\t\t<load_controller id=\"" << lc << "\" type=\"loadcurve\">\n\t\t\t<interpolate>LINEAR</interpolate>\n"
             << "\t\t\t<points>\n" << curve_points(st.model.pressures[p].pressure) << "\t\t\t</points>\n\t\t</load_controller>\n";
      // FEBio's pressure acts against the facet normal (outward normal of the solid): −p n da, as softhom's.
      f << "\t\t<surface_load name=\"" << load_surfaces[p] << "\" type=\"pressure\" surface=\"" << load_surfaces[p]
        << "\">\n\t\t\t<pressure lc=\"" << lc << "\">1</pressure>\n\t\t\t<linear>0</linear>\n"
        << "\t\t\t<symmetric_stiffness>1</symmetric_stiffness>\n\t\t</surface_load>\n";
    }
    std::ostringstream must;
    must << "\t\t<load_controller id=\"1\" type=\"loadcurve\">\n\t\t\t<interpolate>STEP</interpolate>\n\t\t\t<points>\n"
         << "\t\t\t\t<pt>0," << num(T / steps / 4) << "</pt>\n";
    for (double t : ms.times) must << "\t\t\t\t<pt>" << num(t) << "," << num(T / steps / 4) << "</pt>\n";
    must << "\t\t\t</points>\n\t\t</load_controller>\n";
    f << "\t</Loads>\n\t<LoadData>\n" << must.str() << curves.str() << "\t</LoadData>\n";
    const std::string log = out.filename().string() + ".nodes.csv";
    f << "\t<Output>\n\t\t<plotfile type=\"febio\">\n\t\t\t<var type=\"displacement\"/>\n\t\t</plotfile>\n"
      << "\t\t<logfile>\n\t\t\t<node_data data=\"ux;uy;uz\" delim=\",\" file=\"" << log << "\"/>\n";
    // Reaction forces on the driven node sets (the plate's force probe).
    std::vector<std::string> driven;
    for (const Bc& b : bcs)
      if (group_lc.count(b.group)) {
        driven.push_back(b.set);
        f << "\t\t\t<node_data data=\"Rx;Ry;Rz\" delim=\",\" node_set=\"" << b.set << "\" file=\""
          << out.filename().string() << "." << b.set << ".reactions.csv\"/>\n";
      }
    f << "\t\t</logfile>\n\t</Output>\n";
    f << "</febio_spec>\n";
    std::ofstream(out) << f.str();

    nlohmann::json probes;
    probes["kind"] = int(ms.spec.kind);
    probes["inner_nodes"] = st.inner_nodes;
    probes["end_nodes"] = st.end_nodes;
    probes["load_dofs"] = st.load_dofs;
    probes["inner_radius"] = ms.spec.tube.inner_radius;
    probes["times"] = ms.times;
    probes["driven_sets"] = driven;
    probes["plate_section"] = ms.spec.plate.size[1] * ms.spec.plate.size[2];
    std::vector<std::array<double, 3>> X;
    for (const auto& x : mesh.nodes) X.push_back({x.x(), x.y(), x.z()});
    probes["nodes"] = X;
    std::ofstream(out.string() + ".probes.json") << probes.dump();
    std::cerr << "bench_febio_export: " << out.string() << " (" << mesh.num_nodes() << " nodes, " << mesh.num_hexes()
              << " hex8, " << bcs.size() << " node sets, " << st.model.pressures.size() << " pressure surfaces)\n";
    return 0;
  } catch (const InputError& e) {
    std::cerr << "bench_febio_export: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "bench_febio_export: " << e.what() << "\n";
    return 1;
  }
}
