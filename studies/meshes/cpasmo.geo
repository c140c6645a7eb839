// cPASMO micromold (dissertation §3.4.2, Fig. 9): a cylinder of three layers, quarter model with the
// symmetry planes x = 0 and y = 0, meshed with quadratic tetrahedra at run time by the scene
// ([geometry] geo = ".../cpasmo.geo", mesh_size = h passes -setnumber mesh_size h).
//
// Given by the text: bottom layer 1 mm (stiff, the Ecoflex-cloth resistance layer), middle layer 7 mm
// (Ecoflex) with a circular air channel 4 mm high, top layer 1 mm (Ecoflex) with wells of 1 mm
// diameter and 0.3 mm depth on its top surface.
// Chosen here (the text does not give them):
//   outer radius R = 12 mm;
//   the circular channel is a ring of rectangular section, radii 6 … 9 mm (centred on r = 7.5 mm),
//   z = 3.5 … 7.5 mm: 2.5 mm of Ecoflex below it, a 1.5 mm roof (0.5 mm middle + 1 mm top layer);
//   wells on seven rings r_k = R − 1.5 k (k = 1 … 7: 10.5, 9, 7.5, 6, 4.5, 3, 1.5 mm) = regions 1 … 7
//   from outside in (Fig. 12a); ring k has n_k = round(r_k (π/2) / 2.5) wells in the quarter
//   (7, 6, 5, 4, 3, 2, 1: arc pitch ≈ 2.5 mm) at angles (j + 1/2) 90°/n_k, a pattern symmetric about
//   the diagonal x = y. Region 3 lies above the channel centre, regions 2 and 4 over its edges.
// Mesh: size mesh_size in the bulk, min(mesh_size, 0.5 mm · well_refinement) on the well edges
// (distance field, growing to mesh_size over 3 mm).
//
// Physical groups: volumes "bottom_layer" (z < 1) and "ecoflex" (the rest); surfaces "bottom"
// (z = 0, fixed), "xsym" (x = 0), "ysym" (y = 0), "channel" (the pressurized channel walls),
// "top" (z = 9 without the wells), "wells_region1" … "wells_region7" (side walls of the wells of a
// ring) and "well_floors".
SetFactory("OpenCASCADE");
DefineConstant[ mesh_size = 1.0, well_refinement = 1.0 ];
R = 12.0; t_bottom = 1.0; t_middle = 7.0; t_top = 1.0;
H = t_bottom + t_middle + t_top;
ch_r0 = 6.0; ch_r1 = 9.0; ch_z0 = 3.5; ch_z1 = 7.5;
well_r = 0.5; well_depth = 0.3;
rings = 7; ring_pitch = 1.5; arc_pitch = 2.5;

// Body: the bottom layer and the Ecoflex part as two volumes sharing the interface z = 1.
Cylinder(1) = {0, 0, 0, 0, 0, t_bottom, R, Pi/2};
Cylinder(2) = {0, 0, t_bottom, 0, 0, H - t_bottom, R, Pi/2};
// Channel ring and the wells (each a short cylinder reaching above the top surface).
Cylinder(3) = {0, 0, ch_z0, 0, 0, ch_z1 - ch_z0, ch_r1, Pi/2};
Cylinder(4) = {0, 0, ch_z0, 0, 0, ch_z1 - ch_z0, ch_r0, Pi/2};
BooleanDifference(5) = { Volume{3}; Delete; }{ Volume{4}; Delete; };
cut[] = {5};
nw = 0;
For k In {1:rings}
  rk = R - ring_pitch * k;
  nk = Round(rk * (Pi / 2) / arc_pitch);
  If (nk < 1)
    nk = 1;
  EndIf
  For j In {0:nk-1}
    th = (j + 0.5) * (Pi / 2) / nk;
    nw += 1;
    wx[nw] = rk * Cos(th); wy[nw] = rk * Sin(th); wk[nw] = k;
    Cylinder(100 + nw) = {wx[nw], wy[nw], H - well_depth, 0, 0, 2 * well_depth, well_r};
    cut[] += {100 + nw};
  EndFor
EndFor
BooleanDifference(10) = { Volume{2}; Delete; }{ Volume{cut[]}; Delete; };
// Conformal interface between the two layers.
v[] = BooleanFragments{ Volume{1, 10}; Delete; }{};

e = 1e-4;
bottom_layer[] = Volume In BoundingBox{-e, -e, -e, R + e, R + e, t_bottom + e};
all_vol[] = Volume{:};
ecoflex[] = all_vol[];
ecoflex[] -= bottom_layer[];
Physical Volume("bottom_layer") = {bottom_layer[]};
Physical Volume("ecoflex") = {ecoflex[]};

Physical Surface("bottom") = Surface In BoundingBox{-e, -e, -e, R + e, R + e, e};
Physical Surface("xsym") = Surface In BoundingBox{-e, -e, -e, e, R + e, H + e};
Physical Surface("ysym") = Surface In BoundingBox{-e, -e, -e, R + e, e, H + e};
Physical Surface("channel") = Surface In BoundingBox{-e, -e, ch_z0 - e, ch_r1 + e, ch_r1 + e, ch_z1 + e};
Physical Surface("top") = Surface In BoundingBox{-e, -e, H - e, R + e, R + e, H + e};
floors[] = Surface In BoundingBox{-e, -e, H - well_depth - e, R + e, R + e, H - well_depth + e};
Physical Surface("well_floors") = {floors[]};
For k In {1:rings}
  walls[] = {};
  For i In {1:nw}
    If (wk[i] == k)
      in[] = Surface In BoundingBox{wx[i] - well_r - e, wy[i] - well_r - e, H - well_depth - e,
                                    wx[i] + well_r + e, wy[i] + well_r + e, H + e};
      in[] -= floors[];
      walls[] += in[];
    EndIf
  EndFor
  Physical Surface(Sprintf("wells_region%g", k)) = {walls[]};
EndFor

// Sizes: fine along the wells' edges, mesh_size elsewhere.
well_curves[] = {};
For i In {1:nw}
  c[] = Curve In BoundingBox{wx[i] - well_r - e, wy[i] - well_r - e, H - well_depth - e,
                             wx[i] + well_r + e, wy[i] + well_r + e, H + e};
  well_curves[] += c[];
EndFor
h_well = 0.5 * well_refinement;
If (mesh_size < h_well)
  h_well = mesh_size;
EndIf
Field[1] = Distance;
Field[1].CurvesList = {well_curves[]};
Field[1].NumPointsPerCurve = 40;
Field[2] = Threshold;
Field[2].InField = 1;
Field[2].SizeMin = h_well;
Field[2].SizeMax = mesh_size;
Field[2].DistMin = 0.2;
Field[2].DistMax = 3.0;
Background Field = 2;
Mesh.MeshSizeExtendFromBoundary = 0;
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeFromCurvature = 0;
Mesh.MeshSizeMax = mesh_size;
Mesh.ElementOrder = 2;
// Curved quadratic tets next to the small wells can invert: optimise the high-order nodes.
Mesh.HighOrderOptimize = 1;
Mesh.Optimize = 1;
