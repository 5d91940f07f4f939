// Rectangular plate [0, L] x [0, W] of structured quadrilaterals of size about h
// (tri = 1: triangles).  Groups: solid, left, right, bottom, top.
// mesh_parameters: L, W, h, tri.
If (!Exists(L)) L = 0.08; EndIf
If (!Exists(W)) W = 0.08; EndIf
If (!Exists(h)) h = 0.002; EndIf
If (!Exists(tri)) tri = 0; EndIf
Point(1) = {0, 0, 0};
Point(2) = {L, 0, 0};
Point(3) = {L, W, 0};
Point(4) = {0, W, 0};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1, 3} = Round(L / h) + 1;
Transfinite Curve{2, 4} = Round(W / h) + 1;
Transfinite Surface{1};
If (tri == 0)
  Recombine Surface{1};
EndIf
Physical Surface("solid") = {1};
Physical Curve("bottom") = {1};
Physical Curve("right") = {2};
Physical Curve("top") = {3};
Physical Curve("left") = {4};
