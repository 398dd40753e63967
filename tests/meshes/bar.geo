// bar.geo: a 2 m bar of 20 two-node elements along x (1D body).
// gmsh -1 -format msh41 bar.geo -o bar.msh
Point(1) = {0, 0, 0};
Point(2) = {2, 0, 0};
Line(1) = {1, 2};
Transfinite Curve{1} = 21;
Physical Point("left") = {1};
Physical Point("right") = {2};
Physical Curve("bar") = {1};
