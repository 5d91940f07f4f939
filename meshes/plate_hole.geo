// Rectangular plate [0, L] x [0, W] with a circular hole of radius r at its
// centre, meshed with triangles of size h_min at the hole growing to h_max at
// a distance d from it (a gmsh Distance + Threshold size field): a mesh whose
// element steps spread over h_max / h_min.  Groups: solid, left, right,
// bottom, top, hole.  mesh_parameters: L, W, r, h_min, h_max, d.
If (!Exists(L)) L = 0.2; EndIf
If (!Exists(W)) W = 0.1; EndIf
If (!Exists(r)) r = 0.01; EndIf
If (!Exists(h_min)) h_min = 0.001; EndIf
If (!Exists(h_max)) h_max = 0.008; EndIf
If (!Exists(d)) d = 0.05; EndIf
cx = L / 2; cy = W / 2;
Point(1) = {0, 0, 0, h_max};
Point(2) = {L, 0, 0, h_max};
Point(3) = {L, W, 0, h_max};
Point(4) = {0, W, 0, h_max};
Point(5) = {cx, cy, 0, h_min};
Point(6) = {cx + r, cy, 0, h_min};
Point(7) = {cx, cy + r, 0, h_min};
Point(8) = {cx - r, cy, 0, h_min};
Point(9) = {cx, cy - r, 0, h_min};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Circle(5) = {6, 5, 7};
Circle(6) = {7, 5, 8};
Circle(7) = {8, 5, 9};
Circle(8) = {9, 5, 6};
Curve Loop(1) = {1, 2, 3, 4};
Curve Loop(2) = {5, 6, 7, 8};
Plane Surface(1) = {1, 2};
Field[1] = Distance;
Field[1].CurvesList = {5, 6, 7, 8};
Field[1].Sampling = 200;
Field[2] = Threshold;
Field[2].InField = 1;
Field[2].SizeMin = h_min;
Field[2].SizeMax = h_max;
Field[2].DistMin = 0;
Field[2].DistMax = d;
Background Field = 2;
Mesh.MeshSizeExtendFromBoundary = 0;
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeFromCurvature = 0;
Physical Surface("solid") = {1};
Physical Curve("bottom") = {1};
Physical Curve("right") = {2};
Physical Curve("top") = {3};
Physical Curve("left") = {4};
Physical Curve("hole") = {5, 6, 7, 8};
