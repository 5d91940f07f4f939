// Seed 003 §2 bar in 3D: 0.32 m x 2.4 mm x 0.32 mm, structured hexahedra by
// extrusion (1 mm x 0.6 mm x 0.32 mm). Groups: solid, left (x = 0), right (x = L).
L = 0.32;  H = 0.0024;  T = 0.00032;
If (!Exists(nx)) nx = 320; EndIf
If (!Exists(ny)) ny = 4; EndIf
Point(1) = {0, 0, 0};
l[] = Extrude {L, 0, 0} { Point{1}; Layers{nx}; };
s[] = Extrude {0, H, 0} { Line{l[1]}; Layers{ny}; Recombine; };
v[] = Extrude {0, 0, T} { Surface{s[1]}; Layers{1}; Recombine; };
Physical Volume("solid") = {v[1]};
Physical Surface("left") = Surface In BoundingBox {-1e-9, -1, -1, 1e-9, 1, 1};
Physical Surface("right") = Surface In BoundingBox {L - 1e-9, -1, -1, L + 1e-9, 1, 1};
