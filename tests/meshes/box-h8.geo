// box-h8.geo: a 1 x 2 x 3 m box, structured 2 x 3 x 4 hexahedra (extruded, recombined).
// gmsh -3 -format msh41 box-h8.geo -o box-h8.msh
Point(1) = {0, 0, 0};
Point(2) = {1, 0, 0};
Point(3) = {1, 2, 0};
Point(4) = {0, 2, 0};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1, 3} = 3;
Transfinite Curve{2, 4} = 4;
Transfinite Surface{1};
Recombine Surface{1};
out[] = Extrude {0, 0, 3} { Surface{1}; Layers{4}; Recombine; };
// out[0] = top face, out[1] = volume, out[2..5] = the lateral faces on lines 1..4
Physical Surface("zmin") = {1};
Physical Surface("zmax") = {out[0]};
Physical Surface("ymin") = {out[2]};
Physical Surface("xmax") = {out[3]};
Physical Surface("ymax") = {out[4]};
Physical Surface("xmin") = {out[5]};
Physical Curve("edge") = {1};
Physical Point("corner") = {1};
Physical Volume("box") = {out[1]};
