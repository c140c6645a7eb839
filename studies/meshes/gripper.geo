// Pneumatic three-finger micro-gripper of the micro-hand kind (dissertation §3.6, Fig. 16-18), half
// model y >= 0 (the mirror plane y = 0 through finger 0; the device is also mirror-symmetric about the
// planes of the other fingers, which are skew and so not used), meshed with quadratic tetrahedra at
// run time ([geometry] geo = ".../gripper.geo", mesh_size = h passes -setnumber mesh_size h).
//
// The text gives the material (PDMS), the three fingers on a pneumatic channel, the base bonded to a
// plate (bottom fixed) and the angle alpha; the dimensions are chosen here:
//   base: disc of radius 4.5 mm, 1.5 mm thick (z = 0 ... 1.5);
//   fingers at azimuths 0, 120, 240 deg (the half model holds half of finger 0 and all of finger 120):
//   in the finger's frame radial x = 2.0 ... 3.5 mm, tangential y = -0.75 ... 0.75 mm, z = 1.5 ... 7.5 mm
//   (1.5 x 1.5 mm section, 6 mm long, standing vertically);
//   the pneumatic channel: one blind channel per finger, x = 2.5 ... 3.2 mm, y = -0.45 ... 0.45 mm,
//   z = 0 ... 7.0 mm, fed through the bonded plate at z = 0 (all at one pressure). Its walls are
//   0.5 mm on the axis side, 0.3 mm on the outer side and the flanks, 0.5 mm under the fingertip: the
//   thin outer wall lengthens more under pressure, so the fingers bend towards the axis and close.
// Mesh: mesh_size everywhere (the walls are 0.3 mm: mesh_size <= 0.3 puts a full quadratic element
// through them).
//
// Physical groups: volume "pdms"; surfaces "bottom" (z = 0), "ysym" (y = 0), "channel" (the walls of
// the channels), "tip_0" and "tip_120" (the fingertips' top faces), "inner_0" and "inner_120" (the
// fingers' faces towards the axis, at radius 2.0: where they grip a sample), "flank_0" and "flank_120"
// (their side faces, y = ±0.75 in the finger's frame: where neighbouring fingers would touch), "outer"
// (the rest). Finger 0 is cut by the mirror plane: inner_0 is half its face, flank_0 one of its flanks.
// "skin_0", "skin_120" (inner, flank and tip faces of one finger) and "fingers" (both): where the
// fingers touch each other as they close past first contact.
//
// A held sample (sample_radius > 0, [geometry] geo_parameters): a separate body, not joined to the
// gripper, a sphere of that radius on the axis centred at z = sample_z, its bottom cut flat where the
// cut's radius is sample_flat (the flat is bonded to a holder: "sample_base", fixed by the scene, while the
// rest of the sphere is free); volume "sample", surfaces "sample_surface" (the sphere) and "sample_base";
// its cut by the mirror plane joins "ysym". Its mesh size is min(mesh_size, sample_radius / 3).
SetFactory("OpenCASCADE");
DefineConstant[ mesh_size = 0.5, sample_radius = 0, sample_z = 7.0, sample_flat = 0.2 ];
Rb = 4.5; tb = 1.5;
f_x0 = 2.0; f_x1 = 3.5; f_w = 1.5; f_len = 6.0;
c_x0 = 2.5; c_x1 = 3.2; c_w = 0.9; c_z1 = 7.0;
H = tb + f_len;

Cylinder(1) = {0, 0, 0, 0, 0, tb, Rb};
parts[] = {};
chans[] = {};
For k In {0:2}
  Box(10 + k) = {f_x0, -f_w / 2, tb, f_x1 - f_x0, f_w, f_len};
  Box(20 + k) = {c_x0, -c_w / 2, 0, c_x1 - c_x0, c_w, c_z1};
  Rotate {{0, 0, 1}, {0, 0, 0}, k * 2 * Pi / 3} { Volume{10 + k, 20 + k}; }
  parts[] += {10 + k};
  chans[] += {20 + k};
EndFor
BooleanUnion(30) = { Volume{1}; Delete; }{ Volume{parts[]}; Delete; };
BooleanDifference(31) = { Volume{30}; Delete; }{ Volume{chans[]}; Delete; };
Box(40) = {-Rb - 1, 0, -1, 2 * Rb + 2, Rb + 1, H + 2};
BooleanIntersection(41) = { Volume{31}; Delete; }{ Volume{40}; Delete; };

e = 1e-4;
sample_h = mesh_size;
If (sample_radius > 0)
  sample_h = Min(mesh_size, sample_radius / 3);
  Sphere(50) = {0, 0, sample_z, sample_radius};
  z_cut = sample_z - Sqrt(sample_radius^2 - sample_flat^2);
  Box(51) = {-sample_radius - 1, 0, z_cut, 2 * sample_radius + 2, sample_radius + 1, 2 * sample_radius + 1};
  BooleanIntersection(52) = { Volume{50}; Delete; }{ Volume{51}; Delete; };
  Physical Volume("sample") = {52};
  sample_all[] = Abs(Boundary{ Volume{52}; });
  sample_base[] = Surface In BoundingBox{-sample_radius, -e, z_cut - e, sample_radius, sample_radius, z_cut + e};
  sample_ysym[] = Surface In BoundingBox{-sample_radius - e, -e, z_cut - e, sample_radius + e, e, sample_z + sample_radius + e};
  sample_surface[] = sample_all[];
  sample_surface[] -= {sample_base[], sample_ysym[]};
  Physical Surface("sample_surface") = {sample_surface[]};
  Physical Surface("sample_base") = {sample_base[]};
  MeshSize{ PointsOf{ Volume{52}; } } = sample_h;
EndIf
Physical Volume("pdms") = {41};
bottom[] = Surface In BoundingBox{-Rb - e, -e, -e, Rb + e, Rb + e, e};
ysym[] = Surface In BoundingBox{-Rb - e, -e, -e, Rb + e, e, H + e};
tip0[] = Surface In BoundingBox{-e, -e, H - e, Rb + e, Rb + e, H + e};
tip120[] = Surface In BoundingBox{-Rb - e, -e, H - e, e, Rb + e, H + e};
// Channel walls: the surfaces all of whose vertices lie on the closed channel boxes (tested in each
// finger's frame); every other surface has a vertex on the outer boundary.
all[] = Abs(Boundary{ Volume{41}; });
channel[] = {};
For i In {0:#all[]-1}
  pts[] = PointsOf{ Surface{all[i]}; };
  inside = 1;
  For j In {0:#pts[]-1}
    xyz[] = Point{pts[j]};
    hit = 0;
    For k In {0:1}
      phi = k * 2 * Pi / 3;
      xr = xyz[0] * Cos(phi) + xyz[1] * Sin(phi);
      yr = -xyz[0] * Sin(phi) + xyz[1] * Cos(phi);
      If (xr > c_x0 - e && xr < c_x1 + e && Fabs(yr) < c_w / 2 + e && xyz[2] > -e && xyz[2] < c_z1 + e)
        hit = 1;
      EndIf
    EndFor
    If (hit == 0)
      inside = 0;
    EndIf
  EndFor
  If (inside == 1)
    channel[] += {all[i]};
  EndIf
EndFor
// The fingers' inner faces and flanks: the surfaces all of whose vertices lie on the finger's face
// x = f_x0 (inner) or all on one of y = ±f_w/2 (flank) of its box above the base, tested in finger k's
// frame (the inner face's and the tip's corners lie on both flank planes).
inner0[] = {}; inner120[] = {}; flank0[] = {}; flank120[] = {};
For i In {0:#all[]-1}
  pts[] = PointsOf{ Surface{all[i]}; };
  For k In {0:1}
    phi = k * 2 * Pi / 3;
    on_inner = 1;
    on_plus = 1;
    on_minus = 1;
    For j In {0:#pts[]-1}
      xyz[] = Point{pts[j]};
      xr = xyz[0] * Cos(phi) + xyz[1] * Sin(phi);
      yr = -xyz[0] * Sin(phi) + xyz[1] * Cos(phi);
      If (xyz[2] < tb - e || xr < f_x0 - e || xr > f_x1 + e || Fabs(yr) > f_w / 2 + e)
        on_inner = 0;
        on_plus = 0;
        on_minus = 0;
      EndIf
      If (Fabs(xr - f_x0) > e)
        on_inner = 0;
      EndIf
      If (Fabs(yr - f_w / 2) > e)
        on_plus = 0;
      EndIf
      If (Fabs(yr + f_w / 2) > e)
        on_minus = 0;
      EndIf
    EndFor
    on_flank = on_plus + on_minus;
    If (on_inner == 1 && k == 0)
      inner0[] += {all[i]};
    EndIf
    If (on_inner == 1 && k == 1)
      inner120[] += {all[i]};
    EndIf
    If (on_flank == 1 && k == 0)
      flank0[] += {all[i]};
    EndIf
    If (on_flank == 1 && k == 1)
      flank120[] += {all[i]};
    EndIf
  EndFor
EndFor
outer[] = all[];
outer[] -= {bottom[], ysym[], tip0[], tip120[], channel[], inner0[], inner120[], flank0[], flank120[]};
Physical Surface("bottom") = {bottom[]};
Physical Surface("ysym") = {ysym[]};
Physical Surface("channel") = {channel[]};
Physical Surface("tip_0") = {tip0[]};
Physical Surface("tip_120") = {tip120[]};
Physical Surface("inner_0") = {inner0[]};
Physical Surface("inner_120") = {inner120[]};
Physical Surface("flank_0") = {flank0[]};
Physical Surface("flank_120") = {flank120[]};
Physical Surface("outer") = {outer[]};
Physical Surface("skin_0") = {inner0[], flank0[], tip0[]};
Physical Surface("skin_120") = {inner120[], flank120[], tip120[]};
Physical Surface("fingers") = {inner0[], flank0[], tip0[], inner120[], flank120[], tip120[]};

Mesh.MeshSizeMax = mesh_size;
Mesh.MeshSizeMin = 0.5 * sample_h;
Mesh.MeshSizeFromCurvature = 0;
Mesh.ElementOrder = 2;
// Curved quadratic tets can invert at the base's rim: optimise the high-order nodes.
Mesh.HighOrderOptimize = 1;
Mesh.Optimize = 1;
