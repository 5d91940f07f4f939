// A unit-edge cube meshed with tetrahedra. Physical groups: solid, bottom, top.
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 1, 1, 1};
If (!Exists(h)) h = 0.34; EndIf
Mesh.MeshSizeMax = h;
Physical Volume("solid") = {1};
Physical Surface("bottom") = {5};
Physical Surface("top") = {6};
