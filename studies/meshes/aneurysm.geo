// Idealized cerebral saccular aneurysm for the shell engine (geometry.type = "shell", shape = "gmsh"):
// the mid-surface of a curved parent artery with a spherical sac on its outer bend, neck fused,
// meshed at run time into 3-node triangles ([geometry] geo = ".../aneurysm.geo", mesh_size = h passes
// -setnumber mesh_size h to `gmsh -2`). Lengths in mm.
//
// Dimensions (chosen from the literature; the dissertation's vessel is patient-specific):
//   parent artery: diameter 4 mm (r = 2 mm), that of the intracranial internal carotid artery
//     (about 4 mm: Rai, Hogg, Cline & Hobbs 2013, J NeuroIntervent Surg 5:371–375), bent on a
//     radius Rc = 8 mm through 120° (a siphon-like bend: a torus segment in the plane z = 0,
//     symmetric about the y axis, its outer bend toward +y);
//   sac: a sphere of diameter 6 mm (a = 3 mm), the size of most unruptured aneurysms (below 7 mm in
//     the International Study of Unruptured Intracranial Aneurysms: Wiebers et al. 2003, Lancet
//     362:103–110), its centre on the y axis 3.8 mm outside the artery's axis: neck ≈ 4.8 mm wide,
//     dome height ≈ 4.8 mm above the neck, aspect ratio ≈ 1.0 and size ratio 6/4 = 1.5 (the
//     morphology indices of Dhar et al. 2008, Neurosurgery 63:185–197).
//   The wall thickness is the scene's ([[shell.layers]]).
// Sizes: mesh_size = 0.8 gives 1 226 triangles (tests), 0.094 gives 79 226 (the dissertation's ≈ 80 000).
//
// Physical groups: surfaces "artery" (the parent vessel), "neck" (the 1 mm fillet that joins the sac to
// it) and "sac" (the aneurysm beyond the neck);
// curves "end0" (the artery's end at x > 0) and "end1" (at x < 0), to be clamped or held.
SetFactory("OpenCASCADE");
DefineConstant[ mesh_size = 0.8 ];
Rc = 8.0; r = 2.0; sweep = 120 * Pi / 180;
a = 3.0; d = r + a - 1.2;  // sac radius; its centre's distance from the artery's axis
rf = 1.0;                   // fillet radius of the neck

Torus(1) = {0, 0, 0, Rc, r, sweep};
Rotate {{0, 0, 1}, {0, 0, 0}, Pi / 2 - sweep / 2} { Volume{1}; }
Sphere(2) = {0, Rc + d, 0, a};
v() = BooleanUnion{ Volume{1}; Delete; }{ Volume{2}; Delete; };

// The neck: the curves the sac shares with the artery, rounded by a fillet of radius rf (a sharp
// crease would concentrate the bending stress: the dissertation smoothed its vessel's corners too).
// The sac is the surface reaching beyond the sphere's centre; the artery's wall reaches y > Rc (its
// end caps do not) and, once filleted, x > 5 (the fillet does not). OpenCASCADE's boxes are loose by
// up to ~0.5 mm, below these margins.
s() = Boundary{ Volume{v()}; };
For i In {0:#s()-1}
  bb() = BoundingBox Surface{s(i)};
  If (bb(4) > Rc + d)
    sac0 = s(i);
  ElseIf (bb(4) > Rc)
    wall0 = s(i);
  EndIf
EndFor
bs() = Abs(Boundary{ Surface{sac0}; });
bw() = Abs(Boundary{ Surface{wall0}; });
neck() = {};
For i In {0:#bs()-1}
  For j In {0:#bw()-1}
    If (bs(i) == bw(j))
      neck() += bs(i);
    EndIf
  EndFor
EndFor
f() = Fillet{ v() }{ Unique(neck()) }{ rf };
s() = Boundary{ Volume{f()}; };
Delete { Volume{f()}; }  // the wall only

// The end caps are the plane disks at the torus' ends.
e = r + 0.1;
c0 = Pi / 2 - sweep / 2; c1 = Pi / 2 + sweep / 2;
cap0() = Surface In BoundingBox{Rc*Cos(c0) - e, Rc*Sin(c0) - e, -e, Rc*Cos(c0) + e, Rc*Sin(c0) + e, e};
cap1() = Surface In BoundingBox{Rc*Cos(c1) - e, Rc*Sin(c1) - e, -e, Rc*Cos(c1) + e, Rc*Sin(c1) + e, e};
sac() = {}; artery() = {}; fillet() = {};
For i In {0:#s()-1}
  bb() = BoundingBox Surface{s(i)};
  If (s(i) != cap0(0) && s(i) != cap1(0))
    If (bb(4) > Rc + d)
      sac() += s(i);
    ElseIf (bb(3) > 5)
      artery() += s(i);
    Else
      fillet() += s(i);
    EndIf
  EndIf
EndFor
end0() = Boundary{ Surface{cap0(0)}; };
end1() = Boundary{ Surface{cap1(0)}; };
Recursive Delete { Surface{cap0(0), cap1(0)}; }

Physical Surface("artery") = artery();
Physical Surface("neck") = fillet();
Physical Surface("sac") = sac();
Physical Curve("end0") = end0();
Physical Curve("end1") = end1();
Mesh.MeshSizeMax = mesh_size;
Mesh.MeshSizeMin = mesh_size;
