// Seed 003 §3 plate (Fig. 5): 100 x 59.2 mm, pulled along y.  The DEM region is a
// horizontal strip across the whole width around the laser spot (y in [y1, y2]);
// above and below it one row of band cells of height w = (layers - 1) a holds the
// lattice's outer `layers` particle rows (seed 003 transition zone), then `rows`
// rows of FE cells of the same height reach the loaded edges; nx cells across.
// The region's own cells (nx across, rows of height about hc) only give its shape
// and carry the heat.
// Groups: solid, fem (FE + band cells), band, dem, top, bottom.
// mesh_parameters: a, layers, rows, nx, hc, tri.
If (!Exists(L)) L = 0.1; EndIf
If (!Exists(W)) W = 0.0592; EndIf
If (!Exists(a)) a = 0.0008; EndIf
If (!Exists(layers)) layers = 5; EndIf
If (!Exists(rows)) rows = 4; EndIf
If (!Exists(nx)) nx = 31; EndIf        // FE and band cells across the width
If (!Exists(hc)) hc = 0.0016; EndIf    // heat-mesh row height inside the DEM region
If (!Exists(tri)) tri = 0; EndIf
w = (layers - 1) * a;
ys[] = {0, rows * w, (rows + 1) * w, W - (rows + 1) * w, W - rows * w, W};
For i In {0:5}
  Point(2 * i + 1) = {0, ys[i], 0};
  Point(2 * i + 2) = {L, ys[i], 0};
EndFor
For i In {0:5}
  Line(i + 1) = {2 * i + 1, 2 * i + 2};            // horizontals
EndFor
For i In {0:4}
  Line(i + 11) = {2 * i + 1, 2 * i + 3};           // left verticals
  Line(i + 21) = {2 * i + 2, 2 * i + 4};           // right verticals
  Curve Loop(i + 1) = {i + 1, i + 21, -(i + 2), -(i + 11)};
  Plane Surface(i + 1) = {i + 1};
EndFor
Transfinite Curve{1:6} = nx + 1;
Transfinite Curve{11, 21, 15, 25} = rows + 1;
Transfinite Curve{12, 22, 14, 24} = 2;
Transfinite Curve{13, 23} = Round((ys[3] - ys[2]) / hc) + 1;
Transfinite Surface{1:5};
If (tri == 0)
  Recombine Surface{1:5};
EndIf
Physical Surface("solid") = {1, 2, 3, 4, 5};
Physical Surface("fem") = {1, 2, 4, 5};
Physical Surface("band") = {2, 4};
Physical Surface("dem") = {3};
Physical Curve("bottom") = {1};
Physical Curve("top") = {6};
