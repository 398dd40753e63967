// cylinder.geo: the cylinder of cases/cylinder-wall (radius 30 mm), drawn in millimetres (the
// case reads it with mesh.scale = 1e-3 and moves it with mesh.translate), meshed by Gmsh in
// quadrangles: Frontal-Delaunay triangles (Mesh.Algorithm = 6; not 8, on which Gmsh 4.8.4
// crashes) recombined by Blossom and subdivided, so that every element is a quadrangle. The
// four quarter arcs get 4 segments each, 32 boundary nodes after subdivision: the candidates of
// the generator's disk (core 8), at the same places. 296 quadrangles, 313 nodes.
//   gmsh -2 -format msh41 cylinder.geo -o cylinder.msh
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
Mesh.MeshSizeExtendFromBoundary = 0;
Mesh.MeshSizeMax = 6.5;
Physical Curve("boundary") = {1, 2, 3, 4};
Physical Point("bottom_point") = {5};
Physical Surface("cylinder") = {1};
