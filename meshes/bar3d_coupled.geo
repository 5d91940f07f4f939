// A short 3D bar of structured hexahedra (cubes of side a) with a DEM region
// [x1, x2] in the middle, for 3D mesh-lattice coupling. Groups: solid, fem, dem,
// left (x = 0), right (x = L).
If (!Exists(a)) a = 0.0004; EndIf
If (!Exists(L)) L = 0.02; EndIf
If (!Exists(H)) H = 0.0024; EndIf
If (!Exists(T)) T = 0.0008; EndIf
If (!Exists(x1)) x1 = 0.008; EndIf
If (!Exists(x2)) x2 = 0.012; EndIf
Point(1) = {0, 0, 0};  Point(2) = {x1, 0, 0};  Point(3) = {x2, 0, 0};  Point(4) = {L, 0, 0};
Line(1) = {1, 2};  Line(2) = {2, 3};  Line(3) = {3, 4};
Transfinite Curve{1} = Round(x1 / a) + 1;
Transfinite Curve{2} = Round((x2 - x1) / a) + 1;
Transfinite Curve{3} = Round((L - x2) / a) + 1;
s[] = Extrude {0, H, 0} { Line{1, 2, 3}; Layers{Round(H / a)}; Recombine; };
v[] = Extrude {0, 0, T} { Surface{s[1], s[5], s[9]}; Layers{Round(T / a)}; Recombine; };
Physical Volume("solid") = {v[1], v[7], v[13]};
Physical Volume("fem") = {v[1], v[13]};
Physical Volume("dem") = {v[7]};
Physical Surface("left") = Surface In BoundingBox {-1e-9, -1, -1, 1e-9, 1, 1};
Physical Surface("right") = Surface In BoundingBox {L - 1e-9, -1, -1, L + 1e-9, 1, 1};
