// disk-t3.geo: a disk of radius 1 m meshed by Gmsh's default 2D algorithm (unstructured T3),
// with 32 equal boundary segments (4 arcs of 8), so that its area is the inscribed polygon's,
// 16 sin(pi / 16) = 3.1214451522580524 m^2.
// gmsh -2 -format msh41 disk-t3.geo -o disk-t3.msh
lc = 0.2;
Point(1) = {0, 0, 0, lc};
Point(2) = {1, 0, 0, lc};
Point(3) = {0, 1, 0, lc};
Point(4) = {-1, 0, 0, lc};
Point(5) = {0, -1, 0, lc};
Circle(1) = {2, 1, 3};
Circle(2) = {3, 1, 4};
Circle(3) = {4, 1, 5};
Circle(4) = {5, 1, 2};
Transfinite Curve{1, 2, 3, 4} = 9;
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Physical Curve("boundary") = {1, 2, 3, 4};
Physical Point("bottom_point") = {5};
Physical Surface("disk") = {1};
