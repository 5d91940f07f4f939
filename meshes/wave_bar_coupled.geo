// Seed 003 §2 bar for the FEM-DEM coupled run: 0.32 m x 2.4 mm, the middle 4 mm
// (x in [0.158, 0.162]) is the DEM region. Structured quadrilaterals of 0.2 mm
// everywhere, so the FE nodes coincide with the lattice sites of spacing 0.2 mm
// in and around the DEM region. Groups: solid, fem, dem, left, right.
L = 0.32;
If (!Exists(H)) H = 0.0024; EndIf
If (!Exists(x1)) x1 = 0.158; EndIf   // DEM region [x1, x2]
If (!Exists(x2)) x2 = 0.162; EndIf
If (!Exists(a)) a = 0.0002; EndIf   // element size = lattice spacing (model.mesh_parameters)
Point(1) = {0, 0, 0};   Point(2) = {x1, 0, 0};  Point(3) = {x2, 0, 0};  Point(4) = {L, 0, 0};
Point(5) = {L, H, 0};   Point(6) = {x2, H, 0};  Point(7) = {x1, H, 0};  Point(8) = {0, H, 0};
Line(1) = {1, 2};  Line(2) = {2, 3};  Line(3) = {3, 4};  Line(4) = {4, 5};
Line(5) = {5, 6};  Line(6) = {6, 7};  Line(7) = {7, 8};  Line(8) = {8, 1};
Line(9) = {2, 7};  Line(10) = {3, 6};
Curve Loop(1) = {1, 9, 7, 8};    Plane Surface(1) = {1};
Curve Loop(2) = {2, 10, 6, -9};  Plane Surface(2) = {2};
Curve Loop(3) = {3, 4, 5, -10};  Plane Surface(3) = {3};
Transfinite Curve{1, 7} = Round(x1 / a) + 1;
Transfinite Curve{2, 6} = Round((x2 - x1) / a) + 1;
Transfinite Curve{3, 5} = Round((L - x2) / a) + 1;
Transfinite Curve{4, 8, 9, 10} = Round(H / a) + 1;
Transfinite Surface{1, 2, 3};
Recombine Surface{1, 2, 3};
Physical Surface("solid") = {1, 2, 3};
Physical Surface("fem") = {1, 3};
Physical Surface("dem") = {2};
Physical Curve("left") = {8};
Physical Curve("right") = {4};
