// Tube whose wall holds one helical family of solid fibers, conforming to the matrix (fully resolved
// fibers), closed at z = length by a stiff end cap; meshed with quadratic tetrahedra at run time.
// A scene sets the parameters through its [helix_tube] table (macro/helix_tube.hpp), which checks
// them and passes each as -setnumber NAME VALUE; the defaults below are the coarse test tube.
//
//   wall:   inner_radius R_i ... R_i + wall_thickness, z = 0 ... length (open at z = 0);
//   cap:    solid disc of radius R_o, z = length ... length + cap_thickness;
//   fibers: `fibers` circular fibers of radius fiber_radius centred on the mid-wall radius
//           R_m = R_i + wall_thickness / 2, on helices at helix_angle_deg from the tube axis (fiber k
//           starts at azimuth 2 pi k / fibers), swept as pipes along an interpolating spline through
//           8 points per turn, trimmed to the wall (z = 0 ... length) and fragmented with the wall and
//           the cap, so the fiber-matrix interfaces are conforming. fibers = 0: the same tube
//           without fibers (the homogenized model's mesh).
//   fiber_mesh_size > 0: element size inside the fibers and within one fiber radius around them,
//           growing linearly to mesh_size over two more radii (a thin fiber resolved without refining
//           the whole wall); 0 (default): mesh_size everywhere.
//
// Physical groups: volumes "matrix", "fibers" (when fibers > 0), "cap"; surfaces "inner" (the cavity:
// the wall's inner face and the cap's inner disc), "zmin" (z = 0), "zmax" (the cap's top face),
// "outer" (the rest of the boundary).
SetFactory("OpenCASCADE");
DefineConstant[ mesh_size = 0.4, inner_radius = 1.5, wall_thickness = 0.74, length = 2.0, cap_thickness = 0.5,
                helix_angle_deg = 45.0, fibers = 12, fiber_radius = 0.2,
                fiber_mesh_size = 0 ];
Ri = inner_radius; Ro = inner_radius + wall_thickness; Rm = 0.5 * (Ri + Ro); L = length;
alpha = helix_angle_deg * Pi / 180;
rf = fiber_radius;
e = 1e-3 * wall_thickness;  // above OpenCASCADE's bounding-box tolerance on the fibers' spline faces

Cylinder(1) = {0, 0, 0, 0, 0, L, Ro};
Cylinder(2) = {0, 0, 0, 0, 0, L, Ri};
BooleanDifference(3) = { Volume{1}; Delete; }{ Volume{2}; Delete; };
Cylinder(4) = {0, 0, L, 0, 0, cap_thickness, Ro};

fib[] = {};
If (fibers > 0)
  // One fiber, swept past both ends (by what its tilted section needs) and trimmed to the wall's
  // length; the others are rotated copies of it.
  ext = rf * (1 + Fabs(Tan(alpha))) + 0.1 * wall_thickness;
  z0 = -ext; z1 = L + ext;
  turns = (z1 - z0) * Fabs(Tan(alpha)) / (2 * Pi * Rm);
  np = Ceil(8 * turns) + 3;
  pts[] = {};
  For i In {0:np}
    z = z0 + (z1 - z0) * i / np;
    phi = (z - z0) * Tan(alpha) / Rm;
    p = newp; Point(p) = {Rm * Cos(phi), Rm * Sin(phi), z};
    pts[] += {p};
  EndFor
  c = newc; Spline(c) = {pts[]};
  w = newll; Wire(w) = {c};
  d = news; Disk(d) = {0, 0, 0, rf};
  Rotate {{1, 0, 0}, {0, 0, 0}, -alpha} { Surface{d}; }  // normal along the helix tangent (0, sin a, cos a)
  Translate {Rm, 0, z0} { Surface{d}; }
  pipe[] = Extrude { Surface{d}; } Using Wire {w};
  clip = newv; Cylinder(clip) = {0, 0, 0, 0, 0, L, Ro + 1};
  f1[] = BooleanIntersection{ Volume{pipe[0]}; Delete; }{ Volume{clip}; Delete; };
  fib[] = {f1[0]};
  For k In {1:fibers-1}
    copy[] = Rotate {{0, 0, 1}, {0, 0, 0}, 2 * Pi * k / fibers} { Duplicata { Volume{f1[0]}; } };
    fib[] += {copy[0]};
  EndFor
EndIf

// Fragments keep the tags of the volumes they leave unchanged (the fibers and the cap, which the wall
// only touches) and give the cut wall a new one.
all[] = BooleanFragments{ Volume{3, 4}; Delete; }{ Volume{fib[]}; Delete; };
matrix[] = all[];
matrix[] -= {fib[], 4};
Physical Volume("matrix") = {matrix[]};
If (fibers > 0)
  Physical Volume("fibers") = {fib[]};
EndIf
Physical Volume("cap") = {4};

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
If (fibers > 0 && fiber_mesh_size > 0)
  Field[1] = Distance;
  Field[1].SurfacesList = {Abs(Boundary{ Volume{fib[]}; })};
  Field[2] = Threshold;
  Field[2].InField = 1;
  Field[2].SizeMin = fiber_mesh_size;
  Field[2].SizeMax = mesh_size;
  Field[2].DistMin = rf;
  Field[2].DistMax = 3 * rf;
  Background Field = 2;
  Mesh.MeshSizeMin = Min(0.25 * mesh_size, fiber_mesh_size);
EndIf
Mesh.MeshSizeFromCurvature = 0;
Mesh.ElementOrder = 2;
// gmsh's high-order optimisation takes minutes here; the few tets that curving onto the thin fibers
// inverts are straightened when softhom reads the mesh (macro/helix_tube.hpp).
Mesh.HighOrderOptimize = 0;
Mesh.Optimize = 1;
