// plate-cw.geo: the 8 x 4 plate of plate-q4.geo with its curve loop turned clockwise: Gmsh
// writes every quadrangle clockwise (negative Jacobian), which the reader reorients.
// gmsh -2 -format msh41 plate-cw.geo -o plate-cw.msh
Point(1) = {0, 0, 0};
Point(2) = {2, 0, 0};
Point(3) = {2, 1, 0};
Point(4) = {0, 1, 0};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Curve Loop(1) = {-4, -3, -2, -1};
Plane Surface(1) = {1};
Transfinite Curve{1, 3} = 9;
Transfinite Curve{2, 4} = 5;
Transfinite Surface{1};
Recombine Surface{1};
Physical Curve("bottom") = {1};
Physical Curve("top") = {3};
Physical Surface("plate") = {1};
