// plate-t3.geo: a 2 m x 1 m plate meshed by Gmsh's default 2D algorithm (unstructured T3).
// gmsh -2 -format msh41 plate-t3.geo -o plate-t3.msh
lc = 0.25;
Point(1) = {0, 0, 0, lc};
Point(2) = {2, 0, 0, lc};
Point(3) = {2, 1, 0, lc};
Point(4) = {0, 1, 0, lc};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Physical Curve("bottom") = {1};
Physical Curve("right") = {2};
Physical Curve("top") = {3};
Physical Curve("left") = {4};
Physical Point("origin") = {1};
Physical Surface("plate") = {1};
