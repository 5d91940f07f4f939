// A short cylinder (a ring) of radius R and width b about the z axis, as a
// shell surface of triangles: n elements around, nb across the width.
// Groups: ring (surface), edge0 (the circle z = 0).
If (!Exists(R)) R = 1.0; EndIf
If (!Exists(b)) b = 0.05; EndIf
If (!Exists(n)) n = 48; EndIf
If (!Exists(nb)) nb = 1; EndIf
Point(1) = {0, 0, 0};
Point(2) = {R, 0, 0}; Point(3) = {0, R, 0}; Point(4) = {-R, 0, 0}; Point(5) = {0, -R, 0};
Circle(1) = {2, 1, 3}; Circle(2) = {3, 1, 4}; Circle(3) = {4, 1, 5}; Circle(4) = {5, 1, 2};
Transfinite Curve{1, 2, 3, 4} = n / 4 + 1;
s1[] = Extrude {0, 0, b} { Curve{1}; Layers{nb}; };
s2[] = Extrude {0, 0, b} { Curve{2}; Layers{nb}; };
s3[] = Extrude {0, 0, b} { Curve{3}; Layers{nb}; };
s4[] = Extrude {0, 0, b} { Curve{4}; Layers{nb}; };
Physical Surface("ring") = {s1[1], s2[1], s3[1], s4[1]};
Physical Curve("edge0") = {1, 2, 3, 4};
