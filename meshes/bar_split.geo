// A 2D bar in two structured halves that share the middle line, so two
// partitions can own a half each. Groups: solid (both), west, east, left, right.
L = 0.032;  H = 0.0024;  nx = 20;  ny = 3;
Point(1) = {0, 0, 0};  Point(2) = {L/2, 0, 0};  Point(3) = {L, 0, 0};
Point(4) = {L, H, 0};  Point(5) = {L/2, H, 0};  Point(6) = {0, H, 0};
Line(1) = {1, 2};  Line(2) = {2, 3};  Line(3) = {3, 4};  Line(4) = {4, 5};
Line(5) = {5, 6};  Line(6) = {6, 1};  Line(7) = {2, 5};
Curve Loop(1) = {1, 7, 5, 6};  Plane Surface(1) = {1};
Curve Loop(2) = {2, 3, 4, -7}; Plane Surface(2) = {2};
Transfinite Curve{1, 2, 4, 5} = nx + 1;
Transfinite Curve{3, 6, 7} = ny + 1;
Transfinite Surface{1, 2};
Recombine Surface{1, 2};
Physical Surface("solid") = {1, 2};
Physical Surface("west") = {1};
Physical Surface("east") = {2};
Physical Curve("left") = {6};
Physical Curve("right") = {3};
