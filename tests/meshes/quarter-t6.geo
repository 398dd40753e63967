// quarter-t6.geo: the quarter of the unit disk x, y >= 0 in 6-node triangles, the middle nodes of the arc
// on the circle (Gmsh places them on the geometry):
//   gmsh -2 -order 2 -format msh41 quarter-t6.geo -o quarter-t6.msh
Point(1) = {0, 0, 0, 0.25};
Point(2) = {1, 0, 0, 0.25};
Point(3) = {0, 1, 0, 0.25};
Line(1) = {1, 2};
Circle(2) = {2, 1, 3};
Line(3) = {3, 1};
Curve Loop(1) = {1, 2, 3};
Plane Surface(1) = {1};
Physical Surface("quarter") = {1};
Physical Curve("xaxis") = {1};
Physical Curve("arc") = {2};
Physical Curve("yaxis") = {3};
