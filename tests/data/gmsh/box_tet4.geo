// Box [0,2]x[0,1]x[0,1], linear tetrahedra (promoted to tet10 on import). Regenerate with
//   gmsh -3 -format msh41 box_tet4.geo -o box_tet4.msh
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 2, 1, 1};
Mesh.MeshSizeMin = 0.5;
Mesh.MeshSizeMax = 0.5;
Mesh.ElementOrder = 1;
Physical Volume("solid") = {1};
// OpenCASCADE box faces: 1 x=0, 2 x=2, 3 y=0, 4 y=1, 5 z=0, 6 z=1
Physical Surface("xmin") = {1};
Physical Surface("xmax") = {2};
Physical Surface("ymin") = {3};
Physical Surface("zmin") = {5};
