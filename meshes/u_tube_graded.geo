// Ma et al.'s (2018) U-tube, half model, graded as they describe it: finer at
// the impact and at the bend, coarser elsewhere, in both directions (around the
// tube and along it).  The geometry, the groups and the orientation are those
// of meshes/u_tube.geo: the tube (radius r) bends by 90 degrees about the z axis
// with centre-line radius Rb from the apex cross-section (x = Rb, y = 0: the
// symmetry plane; the impact acts on its top, point (Rb, 0, r)) to the circle
// x = 0, where the straight leg of length L along -x begins; the leg's far end
// is clamped.
// Unstructured triangles sized by a field instead of extrusion layers:
//   size = min(threshold(distance to the impact point), threshold(distance to
//   the bend-leg circle)), each threshold its small size (h_min at the impact,
//   h_bend at the circle) up to d_min, growing linearly to h_max at d_max
//   (straight-line distances, metres).  h_bend > h_min keeps the smallest
//   triangles at the impact.  Defaults: 13,115 nodes, 26,060 triangles, largest
//   / smallest estimated step 13.5 (docs/shells.md, "The graded mesh").
// quads = 1 recombines the triangles into quadrilaterals (Blossom; the few
// left over stay triangles), at the same sizes.
// Groups: tube (all), explicit (the ae-degree sector of the bend around the
// impact), implicit (the rest), symmetry (the apex circle), clamped (the leg's
// end circle).
If (!Exists(r)) r = 1.0; EndIf
If (!Exists(Rb)) Rb = 3.0; EndIf
If (!Exists(L)) L = 6.0; EndIf
If (!Exists(ae)) ae = 30; EndIf
If (!Exists(h_min)) h_min = 0.0125; EndIf   // triangle size at the impact
If (!Exists(h_bend)) h_bend = 2 * h_min; EndIf   // at the bend-leg circle
If (!Exists(h_max)) h_max = 0.1; EndIf      // far from both
If (!Exists(d_min)) d_min = 0.05; EndIf     // h_min up to this distance
If (!Exists(d_max)) d_max = 0.8; EndIf      // h_max from this distance on
Point(1) = {Rb, 0, 0};
Point(2) = {Rb + r, 0, 0}; Point(3) = {Rb, 0, r}; Point(4) = {Rb - r, 0, 0}; Point(5) = {Rb, 0, -r};
Circle(1) = {2, 1, 3}; Circle(2) = {3, 1, 4}; Circle(3) = {4, 1, 5}; Circle(4) = {5, 1, 2};
a1 = ae * Pi / 180;
e[] = {};
For k In {1:4}
  s[] = Extrude {{0, 0, 1}, {0, 0, 0}, a1} { Curve{k}; };
  e[] += s[1];
  c1[k - 1] = s[0];
EndFor
i[] = {};
For k In {1:4}
  s[] = Extrude {{0, 0, 1}, {0, 0, 0}, Pi / 2 - a1} { Curve{c1[k - 1]}; };
  i[] += s[1];
  c2[k - 1] = s[0];
EndFor
For k In {1:4}
  s[] = Extrude {-L, 0, 0} { Curve{c2[k - 1]}; };
  i[] += s[1];
  c3[k - 1] = s[0];
EndFor
Physical Surface("tube") = {e[], i[]};
Physical Surface("explicit") = {e[]};
Physical Surface("implicit") = {i[]};
Physical Curve("symmetry") = {1, 2, 3, 4};
Physical Curve("clamped") = {c3[]};

Field[1] = Distance;
Field[1].PointsList = {3};
Field[2] = Distance;
Field[2].CurvesList = {c2[]};
Field[2].Sampling = Ceil(2 * Pi * r / (4 * h_bend)) + 1;   // per quarter circle: h_bend apart
Field[3] = Threshold;
Field[3].InField = 1;
Field[3].SizeMin = h_min; Field[3].SizeMax = h_max;
Field[3].DistMin = d_min; Field[3].DistMax = d_max;
Field[4] = Threshold;
Field[4].InField = 2;
Field[4].SizeMin = h_bend; Field[4].SizeMax = h_max;
Field[4].DistMin = d_min; Field[4].DistMax = d_max;
Field[5] = Min;
Field[5].FieldsList = {3, 4};
Background Field = 5;
Mesh.Algorithm = 6;                       // Frontal-Delaunay: the best-shaped triangles here
Mesh.MeshSizeExtendFromBoundary = 0;
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeFromCurvature = 0;
Mesh.MeshSizeMin = Min(h_min, h_bend);
Mesh.MeshSizeMax = h_max;
If (!Exists(quads)) quads = 0; EndIf
If (quads)
  Mesh.RecombineAll = 1;
  Mesh.RecombinationAlgorithm = 1;        // Blossom
EndIf
