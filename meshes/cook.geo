// Cook's membrane (Cook 1974): the tapered panel (0, 0), (48, 44), (48, 60),
// (0, 44), n x n structured cells (quads = 1: quadrilaterals, 0: triangles,
// each quad split on one diagonal). Groups: solid, left (x = 0, clamped),
// right (x = 48, the shear load).
If (!Exists(n)) n = 8; EndIf
If (!Exists(quads)) quads = 1; EndIf
Point(1) = {0, 0, 0}; Point(2) = {48, 44, 0}; Point(3) = {48, 60, 0}; Point(4) = {0, 44, 0};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1, 2, 3, 4} = n + 1;
Transfinite Surface{1};
If (quads) Recombine Surface{1}; EndIf
Physical Surface("solid") = {1};
Physical Curve("left") = {4};
Physical Curve("right") = {2};
