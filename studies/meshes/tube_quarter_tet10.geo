// Quarter of a thick-walled tube (R_i = 5, R_o = 7.5 mm, length 2 mm along z) meshed with quadratic
// tetrahedra, for studies/scenes/macro_gmsh_tube.toml. Regenerate with
//   gmsh -3 -format msh41 tube_quarter_tet10.geo -o tube_quarter_tet10.msh
// Mid-edge nodes of the curved faces lie on the cylinders (Gmsh places high-order nodes on the CAD).
SetFactory("OpenCASCADE");
Ri = 5.0; Ro = 7.5; L = 2.0; h = 1.0;
Cylinder(1) = {0, 0, 0, 0, 0, L, Ro, Pi/2};
Cylinder(2) = {0, 0, 0, 0, 0, L, Ri, Pi/2};
BooleanDifference(3) = { Volume{1}; Delete; }{ Volume{2}; Delete; };
Mesh.MeshSizeMin = h;
Mesh.MeshSizeMax = h;
Mesh.ElementOrder = 2;
e = 1e-3;
inner[] = Surface In BoundingBox{-e, -e, -e, Ri + e, Ri + e, L + e};
zmin[] = Surface In BoundingBox{-e, -e, -e, Ro + e, Ro + e, e};
zmax[] = Surface In BoundingBox{-e, -e, L - e, Ro + e, Ro + e, L + e};
ysym[] = Surface In BoundingBox{-e, -e, -e, Ro + e, e, L + e};
xsym[] = Surface In BoundingBox{-e, -e, -e, e, Ro + e, L + e};
outer[] = Surface{:};
outer[] -= {inner[], zmin[], zmax[], ysym[], xsym[]};
Physical Volume("wall") = {3};
Physical Surface("inner") = {inner[]};
Physical Surface("outer") = {outer[]};
Physical Surface("zmin") = {zmin[]};
Physical Surface("zmax") = {zmax[]};
Physical Surface("ysym") = {ysym[]};
Physical Surface("xsym") = {xsym[]};
