// Seed 003 §2 bar: 0.32 m x 2.4 mm (2D, plane stress, thickness 0.32 mm in the
// scene). Structured quadrilaterals, 1 mm x 0.6 mm, so nodes lie on a lattice
// and the probes at mid-height (1.2 mm) hit nodes. Groups: solid, left, right.
L = 0.32;  H = 0.0024;  nx = 320;  ny = 4;
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
