// Seed 003 Fig. 3 bar with a transition zone: 0.32 m x 2.4 mm; the DEM region is
// x in [x1, x2] (4 mm, lattice spacing a).  Its outer `layers` particle layers on
// each side lie inside one column of coarse band cells of width w = (layers - 1) a;
// the FE cells are squares of that size everywhere (or of size h, when given: a fixed
// FE mesh whose band alone changes), so the explicit FE step grows with the band
// (step ratio layers - 1, Zhang et al. 2009, Table 1).  The core cells inside
// the band only give the DEM region's shape.  Groups: solid (all cells), fem (FE +
// band cells), band, dem (core), left, right.  mesh_parameters: a, layers, h, tri, H, x1, x2.
If (!Exists(L)) L = 0.32; EndIf
If (!Exists(H)) H = 0.0024; EndIf
If (!Exists(x1)) x1 = 0.158; EndIf
If (!Exists(x2)) x2 = 0.162; EndIf
If (!Exists(a)) a = 0.0002; EndIf
If (!Exists(layers)) layers = 5; EndIf
If (!Exists(tri)) tri = 0; EndIf   // 1: triangles (seed 003 uses triangles), 0: quadrilaterals
w = (layers - 1) * a;
If (!Exists(h)) h = w; EndIf         // FE cell size (default: the band's width)
xs[] = {0, x1, x1 + w, x2 - w, x2, L};
For i In {0:5}
  Point(i + 1) = {xs[i], 0, 0};
  Point(i + 7) = {xs[i], H, 0};
EndFor
For i In {0:4}
  Line(i + 1) = {i + 1, i + 2};        // bottom
  Line(i + 6) = {i + 7, i + 8};        // top
EndFor
For i In {0:5}
  Line(i + 11) = {i + 1, i + 7};       // verticals
EndFor
For i In {0:4}
  Curve Loop(i + 1) = {i + 1, i + 12, -(i + 6), -(i + 11)};
  Plane Surface(i + 1) = {i + 1};
  s = h;
  If (i == 1 || i == 3) s = w; EndIf   // the band: one column of cells
  n = Round((xs[i + 1] - xs[i]) / s);
  If (n < 1) n = 1; EndIf
  Transfinite Curve{i + 1, i + 6} = n + 1;
EndFor
Transfinite Curve{11:16} = Round(H / h) + 1;
Transfinite Surface{1:5};
If (tri == 0)
  Recombine Surface{1:5};
EndIf
Physical Surface("solid") = {1, 2, 3, 4, 5};
Physical Surface("fem") = {1, 2, 4, 5};
Physical Surface("band") = {2, 4};
Physical Surface("dem") = {3};
Physical Curve("left") = {11};
Physical Curve("right") = {16};
