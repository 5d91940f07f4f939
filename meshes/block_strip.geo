// A shell strip welded to a solid block: the block [-d, 0] x [0, b] x [-h/2, h/2]
// (structured hexahedra, n across) holds along its face x = 0 the line z = 0,
// from which a strip of shell triangles (quads = 1: quadrilaterals) runs to
// x = L (nl along, the block's n / 2 across the width).  Groups: block (volume), root (the block's face
// x = -d), strip (surface), tip (the strip's end line).
If (!Exists(L)) L = 1.0; EndIf
If (!Exists(b)) b = 0.1; EndIf
If (!Exists(d)) d = 0.1; EndIf
If (!Exists(h)) h = 0.1; EndIf
If (!Exists(n)) n = 4; EndIf
If (!Exists(nl)) nl = 20; EndIf
If (!Exists(quads)) quads = 0; EndIf
Point(1) = {0, 0, -h / 2}; Point(2) = {0, b, -h / 2}; Point(3) = {0, b, 0}; Point(4) = {0, 0, 0};
Point(5) = {0, b, h / 2}; Point(6) = {0, 0, h / 2};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Line(5) = {3, 5}; Line(6) = {5, 6}; Line(7) = {6, 4};
Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};
Curve Loop(2) = {-3, 5, 6, 7}; Plane Surface(2) = {2};
Transfinite Curve{1, 3, 6} = n + 1;
Transfinite Curve{2, 4, 5, 7} = n / 2 + 1;
Transfinite Surface{1, 2};
Recombine Surface{1, 2};
v1[] = Extrude {-d, 0, 0} { Surface{1}; Layers{n}; Recombine; };
v2[] = Extrude {-d, 0, 0} { Surface{2}; Layers{n}; Recombine; };
If (quads)
  s[] = Extrude {L, 0, 0} { Curve{3}; Layers{nl}; Recombine; };
Else
  s[] = Extrude {L, 0, 0} { Curve{3}; Layers{nl}; };
EndIf
Physical Volume("block") = {v1[1], v2[1]};
Physical Surface("root") = {v1[0], v2[0]};
Physical Surface("strip") = {s[1]};
Physical Curve("tip") = {s[0]};
