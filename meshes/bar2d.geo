// A 2D bar, structured (transfinite, recombined into quadrilaterals) so that its
// nodes sit on a square lattice. Physical groups: solid (surface), left, right.
L = 0.032;  H = 0.0024;  nx = 40;  ny = 3;
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
