// A square plate a x a as a shell surface: triangles, n elements per side
// (structured, diagonals alternating with the gmsh "Alternate" option), or
// with quads = 1 n x n quadrilaterals (recombined), in the plane through the
// origin tilted by `tilt` degrees about the x axis (0: the xy plane).  Groups: plate (surface), edges (its four edges), x0 (edge x = 0),
// centre (the node at the middle; n even).
If (!Exists(a)) a = 1.0; EndIf
If (!Exists(n)) n = 8; EndIf
If (!Exists(tilt)) tilt = 0; EndIf
If (!Exists(quads)) quads = 0; EndIf
Point(1) = {0, 0, 0}; Point(2) = {a, 0, 0}; Point(3) = {a, a, 0}; Point(4) = {0, a, 0};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1, 2, 3, 4} = n + 1;
Transfinite Surface{1} Alternate;
If (quads) Recombine Surface{1}; EndIf
Rotate {{1, 0, 0}, {0, 0, 0}, tilt * Pi / 180} { Surface{1}; }
Physical Surface("plate") = {1};
Physical Curve("edges") = {1, 2, 3, 4};
Physical Curve("x0") = {4};
Physical Curve("x1") = {2};
