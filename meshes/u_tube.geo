// Seed 002 §4's U-tube, half model, as a shell surface of triangles.
// The tube (radius r, SPEC: 1 m) bends by 180 degrees about the z axis with
// centre-line radius Rb, between two straight legs of length L along -x.
// The half model is y >= 0: the cut through the bend's apex (x = Rb, y = 0)
// is the symmetry plane, the impact acts on top of the apex cross-section
// (point (Rb, 0, r)), the leg's far end is clamped.
// The cross-section circle has nc elements around; the sweep is layered:
// explicit sector (0..ae degrees from the apex) at the circle's element size,
// the rest of the bend at 1.5x, the leg at 3x.
// Groups: tube (all), explicit (the sector around the impact), implicit (the
// rest), symmetry (the apex circle), clamped (the leg's end circle).
If (!Exists(r)) r = 1.0; EndIf
If (!Exists(Rb)) Rb = 3.0; EndIf
If (!Exists(L)) L = 6.0; EndIf
If (!Exists(nc)) nc = 120; EndIf
If (!Exists(ae)) ae = 30; EndIf
h = 2 * Pi * r / nc;
Point(1) = {Rb, 0, 0};
Point(2) = {Rb + r, 0, 0}; Point(3) = {Rb, 0, r}; Point(4) = {Rb - r, 0, 0}; Point(5) = {Rb, 0, -r};
Circle(1) = {2, 1, 3}; Circle(2) = {3, 1, 4}; Circle(3) = {4, 1, 5}; Circle(4) = {5, 1, 2};
Transfinite Curve{1, 2, 3, 4} = nc / 4 + 1;
a1 = ae * Pi / 180;
n1 = Ceil(Rb * a1 / h);
n2 = Ceil(Rb * (Pi / 2 - a1) / (1.5 * h));
n3 = Ceil(L / (3 * h));
e[] = {};
For k In {1:4}
  s[] = Extrude {{0, 0, 1}, {0, 0, 0}, a1} { Curve{k}; Layers{n1}; };
  e[] += s[1];
  c1[k - 1] = s[0];
EndFor
i[] = {};
For k In {1:4}
  s[] = Extrude {{0, 0, 1}, {0, 0, 0}, Pi / 2 - a1} { Curve{c1[k - 1]}; Layers{n2}; };
  i[] += s[1];
  c2[k - 1] = s[0];
EndFor
For k In {1:4}
  s[] = Extrude {-L, 0, 0} { Curve{c2[k - 1]}; Layers{n3}; };
  i[] += s[1];
  c3[k - 1] = s[0];
EndFor
Physical Surface("tube") = {e[], i[]};
Physical Surface("explicit") = {e[]};
Physical Surface("implicit") = {i[]};
Physical Curve("symmetry") = {1, 2, 3, 4};
Physical Curve("clamped") = {c3[]};
