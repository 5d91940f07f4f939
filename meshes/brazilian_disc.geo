// Brazilian disc (tensile splitting, ISRM curved jaws): a disc of radius R whose
// outer ring of width h is one layer of coarse band cells around the DEM region
// (the disc of radius R - h), loaded through two curved jaws: FE
// annular sectors R..R+p over the arcs 90 +- alpha and 270 +- alpha degrees,
// pushed along y on their outer arcs.  Groups: solid (all cells), fem (jaws and
// band), band, dem (the inner disc), top, bottom (the jaws' outer arcs).
// mesh_parameters: R, h, p, alpha (degrees), a (the DEM region's mesh size).
If (!Exists(R)) R = 0.02; EndIf
If (!Exists(h)) h = 0.002; EndIf
If (!Exists(p)) p = 0.002; EndIf
If (!Exists(alpha)) alpha = 10; EndIf
If (!Exists(a)) a = 0.002; EndIf
r1 = R - h;
r2 = R + p;
ang[] = {90 - alpha, 90 + alpha, 270 - alpha, 270 + alpha};
Point(1) = {0, 0, 0, a};
For k In {0:3}
  t = ang[k] * Pi / 180;
  Point(10 + k) = {r1 * Cos(t), r1 * Sin(t), 0, a};
  Point(20 + k) = {R * Cos(t), R * Sin(t), 0, a};
  Point(30 + k) = {r2 * Cos(t), r2 * Sin(t), 0, a};
EndFor
// arcs: sector k runs from ang[k] to ang[k+1] (k = 0: top jaw, 1: left, 2: bottom jaw, 3: right)
For k In {0:3}
  k1 = (k + 1) % 4;
  Circle(10 + k) = {10 + k, 1, 10 + k1};
  Circle(20 + k) = {20 + k, 1, 20 + k1};
  Line(40 + k) = {10 + k, 20 + k};        // radial, band
EndFor
Circle(30) = {30, 1, 31};                  // top jaw's outer arc
Circle(32) = {32, 1, 33};                  // bottom jaw's outer arc
Line(50) = {20, 30};
Line(51) = {21, 31};
Line(52) = {22, 32};
Line(53) = {23, 33};
Curve Loop(1) = {10, 11, 12, 13};
Plane Surface(1) = {1};                    // the DEM region
For k In {0:3}
  k1 = (k + 1) % 4;
  Curve Loop(10 + k) = {40 + k, 20 + k, -(40 + k1), -(10 + k)};
  Plane Surface(10 + k) = {10 + k};
  n = Round((ang[k1] - ang[k] + 360 * (k == 3)) * Pi / 180 * (R - h / 2) / h);
  If (n < 1) n = 1; EndIf
  Transfinite Curve{10 + k, 20 + k} = n + 1;
  Transfinite Curve{40 + k} = 2;
  Transfinite Surface{10 + k};
EndFor
Curve Loop(20) = {50, 30, -51, -20};
Plane Surface(20) = {20};
Curve Loop(22) = {52, 32, -53, -22};
Plane Surface(22) = {22};
Transfinite Curve{30} = Round(2 * alpha * Pi / 180 * (R - h / 2) / h) + 1;
Transfinite Curve{32} = Round(2 * alpha * Pi / 180 * (R - h / 2) / h) + 1;
Transfinite Curve{50:53} = 2;
Transfinite Surface{20, 22};
Recombine Surface{10:13, 20, 22};
Physical Surface("solid") = {1, 10, 11, 12, 13, 20, 22};
Physical Surface("fem") = {10, 11, 12, 13, 20, 22};
Physical Surface("band") = {10, 11, 12, 13};
Physical Surface("dem") = {1};
Physical Surface("jaws") = {20, 22};
Physical Curve("top") = {30};
Physical Curve("bottom") = {32};
