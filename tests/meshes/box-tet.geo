// box-tet.geo: a 1 x 2 x 3 m box meshed in tetrahedra (Delaunay, size 0.6), for T4 and T10:
//   gmsh -3 -format msh41 box-tet.geo -o box-t4.msh
//   gmsh -3 -format msh41 -bin box-tet.geo -o box-t4-bin.msh
//   gmsh -3 -order 2 -format msh41 box-tet.geo -o box-t10.msh
//   gmsh -3 -order 2 -format msh41 -bin box-tet.geo -o box-t10-bin.msh
// (Gmsh 4.8.4; Mesh.Algorithm3D = 1 is Delaunay; the box is flat-faced, so the T10 are straight.)
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 1, 2, 3};
Mesh.MeshSizeMin = 0.6;
Mesh.MeshSizeMax = 0.6;
Mesh.Algorithm3D = 1;
Physical Volume("box") = {1};
Physical Surface("xmin") = {1};
Physical Surface("xmax") = {2};
Physical Surface("ymin") = {3};
Physical Surface("ymax") = {4};
Physical Surface("zmin") = {5};
Physical Surface("zmax") = {6};
Physical Point("origin") = {2};
