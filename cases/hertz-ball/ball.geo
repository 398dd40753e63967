// cases/hertz-ball/ball.geo: an octant of a ball, the quarter (x, y >= 0) of the hemisphere of radius R
// whose pole touches the plane z = 0 at the origin, its flat face at z = R. The spherical face is
// split at the circle of radius rcap about the axis: "cap" (the contact candidates) and "sphere".
// Refined to lmin within rfine of the pole, lmax away from it. The case's meshes (Gmsh 4.8.4):
//   gmsh -3 -order 2 -format msh41 -bin ball.geo -o ball-t10.msh
//   gmsh -3 -format msh41 -bin ball.geo -o ball-t4.msh
R = 0.01;
rcap = 2.2e-3;
lmin = 0.3e-3;
lmax = 3.0e-3;
rfine = 2.0e-3;
c = Sqrt(R * R - rcap * rcap);     // the cap circle lies at z = R - c
Point(1) = {0, 0, R, lmax};        // the centre
Point(2) = {0, 0, 0, lmin};        // the pole
Point(3) = {R, 0, R, lmax};
Point(4) = {0, R, R, lmax};
Point(5) = {rcap, 0, R - c, lmin};
Point(6) = {0, rcap, R - c, lmin};
Point(7) = {0, 0, R - c, lmin};    // the cap circle's centre
Circle(1) = {3, 1, 5};
Circle(2) = {5, 1, 2};             // in the plane y = 0
Circle(3) = {4, 1, 6};
Circle(4) = {6, 1, 2};             // in the plane x = 0
Circle(5) = {3, 1, 4};             // the equator's quarter, z = R
Circle(6) = {5, 7, 6};             // the cap's edge
Line(7) = {1, 3};
Line(8) = {1, 4};
Line(9) = {1, 2};
Curve Loop(1) = {6, 4, -2};
Surface(1) = {1} In Sphere {1};    // the cap
Curve Loop(2) = {5, 3, -6, -1};
Surface(2) = {2} In Sphere {1};    // the rest of the spherical face
Curve Loop(3) = {7, 5, -8};
Plane Surface(3) = {3};            // the flat face z = R
Curve Loop(4) = {9, -2, -1, -7};
Plane Surface(4) = {4};            // the symmetry plane y = 0
Curve Loop(5) = {8, 3, 4, -9};
Plane Surface(5) = {5};            // the symmetry plane x = 0
Surface Loop(1) = {1, 2, 3, 4, 5};
Volume(1) = {1};
Field[1] = Distance;
Field[1].PointsList = {2};
Field[2] = Threshold;
Field[2].InField = 1;
Field[2].SizeMin = lmin;
Field[2].SizeMax = lmax;
Field[2].DistMin = rfine;
Field[2].DistMax = 3 * rfine;
Background Field = 2;
Mesh.MeshSizeExtendFromBoundary = 0;
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeFromCurvature = 0;
Mesh.Algorithm3D = 1;
Physical Volume("ball") = {1};
Physical Surface("cap") = {1};
Physical Surface("sphere") = {2};
Physical Surface("top") = {3};
Physical Surface("ymin") = {4};
Physical Surface("xmin") = {5};
Physical Point("pole") = {2};
