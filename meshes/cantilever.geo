// A 2D cantilever strip of structured quadrilaterals (nx along, ny through the
// depth), for bending and near-incompressible checks. Groups: solid, left, right.
If (!Exists(L)) L = 0.1; EndIf
If (!Exists(H)) H = 0.01; EndIf
If (!Exists(nx)) nx = 40; EndIf
If (!Exists(ny)) ny = 4; EndIf
Point(1) = {0, 0, 0};  Point(2) = {L, 0, 0};  Point(3) = {L, H, 0};  Point(4) = {0, H, 0};
Line(1) = {1, 2};  Line(2) = {2, 3};  Line(3) = {3, 4};  Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1, 3} = nx + 1;
Transfinite Curve{2, 4} = ny + 1;
Transfinite Surface{1};
Recombine Surface{1};
Physical Surface("solid") = {1};
Physical Curve("left") = {4};
Physical Curve("right") = {2};
