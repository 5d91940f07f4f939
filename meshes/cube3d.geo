// A unit-edge cube meshed with tetrahedra. Physical groups: solid, bottom, top.
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 1, 1, 1};
Mesh.MeshSizeMax = 0.34;
Physical Volume("solid") = {1};
Physical Surface("bottom") = {5};
Physical Surface("top") = {6};
