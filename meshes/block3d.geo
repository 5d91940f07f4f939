// A block of structured hexahedra for set-up and scaling benchmarks:
// L x W x H with nx x ny x nz cells (defaults: 65^3 = 274,625 hexahedra,
// 287,496 nodes, 862,488 DOF). Groups: solid, left (x = 0), right (x = L).
If (!Exists(L)) L = 0.065; EndIf
If (!Exists(W)) W = 0.065; EndIf
If (!Exists(H)) H = 0.065; EndIf
If (!Exists(nx)) nx = 65; EndIf
If (!Exists(ny)) ny = 65; EndIf
If (!Exists(nz)) nz = 65; EndIf
Point(1) = {0, 0, 0};
l[] = Extrude {L, 0, 0} { Point{1}; Layers{nx}; };
s[] = Extrude {0, W, 0} { Line{l[1]}; Layers{ny}; Recombine; };
v[] = Extrude {0, 0, H} { Surface{s[1]}; Layers{nz}; Recombine; };
Physical Volume("solid") = {v[1]};
Physical Surface("left") = Surface In BoundingBox {-1e-9, -1, -1, 1e-9, 1, 1};
Physical Surface("right") = Surface In BoundingBox {L - 1e-9, -1, -1, L + 1e-9, 1, 1};
