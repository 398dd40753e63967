// cylinder-q4.geo: the cylinder of cases/cylinder-wall, radius 30 mm, in millimetres (the case
// reads it with mesh.scale = 1e-3), meshed by Gmsh in quadrangles: Frontal-Delaunay triangles
// recombined (Blossom) and subdivided so that every element is a quadrangle. 32 boundary nodes
// like the generator's 8 x 8 core. Not Mesh.Algorithm = 8: Gmsh 4.8.4 crashes on it.
// gmsh -2 -format msh41 cylinder-q4.geo -o cylinder-q4.msh
lc = 6;
Point(1) = {0, 0, 0, lc};
Point(2) = {30, 0, 0, lc};
Point(3) = {0, 30, 0, lc};
Point(4) = {-30, 0, 0, lc};
Point(5) = {0, -30, 0, lc};
Circle(1) = {2, 1, 3};
Circle(2) = {3, 1, 4};
Circle(3) = {4, 1, 5};
Circle(4) = {5, 1, 2};
Transfinite Curve{1, 2, 3, 4} = 5;
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Mesh.Algorithm = 6;
Mesh.RecombineAll = 1;
Mesh.RecombinationAlgorithm = 1;
Mesh.SubdivisionAlgorithm = 1;
Physical Curve("boundary") = {1, 2, 3, 4};
Physical Point("bottom_point") = {5};
Physical Surface("cylinder") = {1};
