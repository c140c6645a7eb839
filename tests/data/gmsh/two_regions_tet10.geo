// Two unit cubes side by side (x in [0,1] "soft", [1,2] "stiff"), quadratic tetrahedra, shared
// interface meshed conformally. Regenerate with
//   gmsh -3 -format msh41 two_regions_tet10.geo -o two_regions_tet10.msh
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 1, 1, 1};
Box(2) = {1, 0, 0, 1, 1, 1};
BooleanFragments{ Volume{1}; Delete; }{ Volume{2}; Delete; }
Mesh.MeshSizeMin = 0.6;
Mesh.MeshSizeMax = 0.6;
Mesh.ElementOrder = 2;
Physical Volume("soft") = {1};
Physical Volume("stiff") = {2};
Physical Surface("xmin") = Surface In BoundingBox{-0.1, -0.1, -0.1, 0.1, 1.1, 1.1};
Physical Surface("top") = Surface In BoundingBox{-0.1, -0.1, 0.9, 2.1, 1.1, 1.1};
