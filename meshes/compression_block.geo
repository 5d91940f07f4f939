// Uniaxial compression of a block W x H: the core [0, W] x [0, H] is the DEM region,
// a band of coarse cells of width h around it the transition zone, and two FE
// platens of thickness p across the whole width above and below, bonded to the
// band; the platens' outer edges are driven.  Structured quadrilaterals in a grid
// of 3 columns (band, core, band) and 5 rows (platen, band, core, band, platen).
// Groups: solid (all cells), fem (platens and band), band, dem (the core), platens,
// top, bottom (the platens' outer edges).  mesh_parameters: W, H, h, p.
If (!Exists(W)) W = 0.02; EndIf
If (!Exists(H)) H = 0.04; EndIf
If (!Exists(h)) h = 0.002; EndIf
If (!Exists(p)) p = 0.002; EndIf
xs[] = {-h, 0, W, W + h};
ys[] = {-h - p, -h, 0, H, H + h, H + h + p};
nx[] = {1, Round(W / h), 1};
ny[] = {1, 1, Round(H / h), 1, 1};
For j In {0:5}
  For i In {0:3}
    Point(100 + 10 * j + i) = {xs[i], ys[j], 0};
  EndFor
EndFor
For j In {0:5}
  For i In {0:2}
    Line(1000 + 10 * j + i) = {100 + 10 * j + i, 100 + 10 * j + i + 1};
    Transfinite Curve{1000 + 10 * j + i} = nx[i] + 1;
  EndFor
EndFor
For j In {0:4}
  For i In {0:3}
    Line(2000 + 10 * j + i) = {100 + 10 * j + i, 100 + 10 * (j + 1) + i};
    Transfinite Curve{2000 + 10 * j + i} = ny[j] + 1;
  EndFor
EndFor
For r In {0:4}
  For c In {0:2}
    Curve Loop(3000 + 10 * r + c) = {1000 + 10 * r + c, 2000 + 10 * r + c + 1,
                                     -(1000 + 10 * (r + 1) + c), -(2000 + 10 * r + c)};
    Plane Surface(3000 + 10 * r + c) = {3000 + 10 * r + c};
    Transfinite Surface{3000 + 10 * r + c};
    Recombine Surface{3000 + 10 * r + c};
  EndFor
EndFor
Physical Surface("solid") = {3000:3002, 3010:3012, 3020:3022, 3030:3032, 3040:3042};
Physical Surface("fem") = {3000:3002, 3010:3012, 3020, 3022, 3030:3032, 3040:3042};
Physical Surface("band") = {3010:3012, 3020, 3022, 3030:3032};
Physical Surface("dem") = {3021};
Physical Surface("platens") = {3000:3002, 3040:3042};
Physical Curve("top") = {1050:1052};
Physical Curve("bottom") = {1000:1002};
