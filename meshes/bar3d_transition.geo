// A short 3D bar with a transition zone: 8 mm x 1.2 mm x 1.2 mm, the DEM region
// x in [x1, x2] filled with a simple cubic lattice of spacing a; its outer `layers`
// particle layers on each side lie in one slab of band cells (layers - 1) a thick.
// FE cells are cubes of that size (hexahedra; tet = 1: tetrahedra).  Groups:
// solid, fem (FE + band), band, dem (core), left, right.
If (!Exists(L)) L = 0.008; EndIf
If (!Exists(H)) H = 0.0012; EndIf
If (!Exists(x1)) x1 = 0.0032; EndIf
If (!Exists(x2)) x2 = 0.0048; EndIf
If (!Exists(a)) a = 0.0002; EndIf
If (!Exists(layers)) layers = 3; EndIf
If (!Exists(tet)) tet = 0; EndIf
w = (layers - 1) * a;
xs[] = {0, x1, x1 + w, x2 - w, x2, L};
For i In {0:5}
  Point(i + 1) = {xs[i], 0, 0};
  Point(i + 7) = {xs[i], H, 0};
EndFor
For i In {0:4}
  Line(i + 1) = {i + 1, i + 2};
  Line(i + 6) = {i + 7, i + 8};
EndFor
For i In {0:5}
  Line(i + 11) = {i + 1, i + 7};
EndFor
For i In {0:4}
  Curve Loop(i + 1) = {i + 1, i + 12, -(i + 6), -(i + 11)};
  Plane Surface(i + 1) = {i + 1};
  n = Round((xs[i + 1] - xs[i]) / w);
  If (n < 1) n = 1; EndIf
  Transfinite Curve{i + 1, i + 6} = n + 1;
EndFor
Transfinite Curve{11:16} = Round(H / w) + 1;
Transfinite Surface{1:5};
If (tet == 0)
  Recombine Surface{1:5};
  out[] = Extrude {0, 0, H} { Surface{1:5}; Layers{Round(H / w)}; Recombine; };
Else
  out[] = Extrude {0, 0, H} { Surface{1:5}; Layers{Round(H / w)}; };
EndIf
// out[]: for each surface, [top, volume, 4 sides]
Physical Volume("solid") = {out[1], out[7], out[13], out[19], out[25]};
Physical Volume("fem") = {out[1], out[7], out[19], out[25]};
Physical Volume("band") = {out[7], out[19]};
Physical Volume("dem") = {out[13]};
Physical Surface("left") = {out[5]};
Physical Surface("right") = {out[27]};
