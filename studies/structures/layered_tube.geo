// The helix tube's wall as three layers (studies/README.md, "Why the long 60° tube is off"): an inner and an
// outer skin and a core of thickness core_thickness centred on the mid-wall radius, where a one-layer fiber
// wall has its fibers; closed at z = length by an end cap as meshes/helix_tube.geo. Meshed with quadratic
// tets at run time; a scene passes the parameters by [geometry] geo_parameters.
//
// Physical groups: volumes "skin" (both skins), "core", "cap"; surfaces "inner" (the wall's inner face and
// the cap's inner disc), "zmin" (z = 0), "zmax" (the cap's top face), "outer" (the rest of the boundary).
SetFactory("OpenCASCADE");
DefineConstant[ mesh_size = 0.25, inner_radius = 1.5, wall_thickness = 0.74, length = 9.0, cap_thickness = 0.5,
                core_thickness = 0.3464 ];
Ri = inner_radius; Ro = inner_radius + wall_thickness; Rm = 0.5 * (Ri + Ro); L = length;
Ra = Rm - 0.5 * core_thickness; Rb = Rm + 0.5 * core_thickness;
e = 1e-3 * wall_thickness;

Cylinder(1) = {0, 0, 0, 0, 0, L, Ro};
Cylinder(2) = {0, 0, 0, 0, 0, L, Rb};
BooleanDifference(3) = { Volume{1}; Delete; }{ Volume{2}; };          // outer skin
Cylinder(4) = {0, 0, 0, 0, 0, L, Ra};
BooleanDifference(5) = { Volume{2}; Delete; }{ Volume{4}; };          // core
Cylinder(6) = {0, 0, 0, 0, 0, L, Ri};
BooleanDifference(7) = { Volume{4}; Delete; }{ Volume{6}; Delete; };  // inner skin
Cylinder(8) = {0, 0, L, 0, 0, cap_thickness, Ro};

all[] = BooleanFragments{ Volume{3, 5, 7, 8}; Delete; }{};
// The fragments' tags, found by the boxes that hold them.
skin_in[] = Volume In BoundingBox{-Ra - e, -Ra - e, -e, Ra + e, Ra + e, L + e};
core[] = Volume In BoundingBox{-Rb - e, -Rb - e, -e, Rb + e, Rb + e, L + e};
core[] -= {skin_in[]};
skin[] = Volume In BoundingBox{-Ro - e, -Ro - e, -e, Ro + e, Ro + e, L + e};
skin[] -= {core[]};
cap[] = Volume In BoundingBox{-Ro - e, -Ro - e, L - e, Ro + e, Ro + e, L + cap_thickness + e};
Physical Volume("skin") = {skin[]};
Physical Volume("core") = {core[]};
Physical Volume("cap") = {cap[]};

bnd[] = Abs(CombinedBoundary{ Volume{all[]}; });
zmin[] = Surface In BoundingBox{-Ro - 1, -Ro - 1, -e, Ro + 1, Ro + 1, e};
zmax[] = Surface In BoundingBox{-Ro - 1, -Ro - 1, L + cap_thickness - e, Ro + 1, Ro + 1, L + cap_thickness + e};
inner[] = Surface In BoundingBox{-Ri - e, -Ri - e, -e, Ri + e, Ri + e, L + e};
inner[] -= {zmin[]};
notbnd[] = inner[];
notbnd[] -= {bnd[]};
inner[] -= {notbnd[]};  // inner ∩ boundary
outer[] = bnd[];
outer[] -= {zmin[], zmax[], inner[]};
Physical Surface("inner") = {inner[]};
Physical Surface("zmin") = {zmin[]};
Physical Surface("zmax") = {zmax[]};
Physical Surface("outer") = {outer[]};

Mesh.MeshSizeMax = mesh_size;
Mesh.MeshSizeMin = 0.25 * mesh_size;
Mesh.MeshSizeFromCurvature = 0;
Mesh.ElementOrder = 2;
Mesh.HighOrderOptimize = 0;
Mesh.Optimize = 1;
