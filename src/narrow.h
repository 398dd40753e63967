/* narrow.h: narrow phases of contact detection between planes, balls and convex polygons (pure geometry). */
#ifndef MOREAU_NARROW_H
#define MOREAU_NARROW_H

#include <stddef.h>

/* One contact between a master shape A and a slave shape B (doc/theory.md §12.1, §12.3).
   x: the point midway between the two surfaces; n: unit normal from A toward B; g: the signed
   distance between the surfaces along n (g >= 0 open, g < 0 overlap). Components beyond the
   dimension are 0.

   Features (fa on the master, fb on the slave) say which parts of the shapes touch, so that a
   caller can match a contact with the previous step's by the pair (fa, fb):
     -1            a ball or a plane (one feature only);
     k, 0 <= k < nv        vertex k of a polygon of nv vertices;
     nv + k                 edge k of that polygon, from vertex k to vertex (k + 1) mod nv.
   Edge-edge contacts of two polygons come as (edge, vertex) for an end of the incident edge
   and (vertex, edge) for a point where a side of the reference edge cut the incident edge, so
   the two contacts of one configuration never share their pair. */
typedef struct {
  double x[3]; /* contact point, midway between the surfaces (unused components 0) */
  double n[3]; /* unit normal from master to slave */
  double g;    /* gap */
  int fa, fb;  /* features on the master and the slave */
} mo_narrow;

/* Feature code of edge k of a polygon with nv vertices, and the converse tests. */
#define MO_NARROW_EDGE(nv, k) ((nv) + (k))
#define MO_NARROW_IS_EDGE(nv, f) ((f) >= (nv))

/* All the narrow phases below: inputs are read only, at most the stated number of contacts is
   written to out, and the return value is how many were written: 0 when the shapes are farther
   apart than alert (alert >= 0). Non-finite inputs give 0 contacts or non-finite fields, never
   a crash. Polygons are 2D, convex, counter-clockwise (mo_polygon_check), vertex k at
   (v[2k], v[2k+1]); balls are disks in 2D and spheres in 3D, radius r >= 0 (r = 0: a point, as
   for finite-element nodes). */

/* Plane through p with unit normal n (pointing to the side the bodies stay on) as master, ball
   (c, r) as slave, in dim 2 or 3. At most 1 contact, normal n, features (-1, -1). */
int mo_narrow_plane_ball(int dim, const double *p, const double *n, const double *c, double r, double alert,
                         mo_narrow *out);

/* Ball (ca, ra) as master, ball (cb, rb) as slave, in dim 2 or 3. At most 1 contact, normal along
   cb - ca. Coincident centres: normal +y and g = -(ra + rb), so the result is never NaN. */
int mo_narrow_ball_ball(int dim, const double *ca, double ra, const double *cb, double rb, double alert,
                        mo_narrow *out);

/* Polygon (nv >= 3 vertices v) as master, disk (c, r) as slave. At most 1 contact with the
   closest feature: an edge (its outward normal, fa = edge code) or a vertex (normal from the
   vertex to c, fa = vertex index); fb = -1. Centre inside the polygon or on its boundary: the edge
   of least penetration depth, g = -depth - r; ties (centre on a vertex, at the centre of a
   square) go to the lowest edge index. */
int mo_narrow_polygon_ball(int nv, const double *v, const double *c, double r, double alert, mo_narrow *out);

/* 2D plane through p with unit normal n as master, polygon as slave. One contact per vertex
   within alert (out holds nv), normal n, fa = -1, fb = the vertex index, in vertex order. */
int mo_narrow_plane_polygon(const double *p, const double *n, int nv, const double *v, double alert,
                            mo_narrow *out);

/* Polygon A (na vertices va) as master, polygon B (nb vertices vb) as slave: at most 2 contacts,
   normal from A to B. Separating axes over the edge normals of both polygons choose the
   reference edge (least penetration or largest separation; A's edge unless B's separates by
   more than 1e-3 of the shorter of the two edges, so a resting pile keeps its references); the
   incident edge of the other polygon, the one most opposed to the reference normal, is clipped
   to the sides of the reference edge, and each clipped point within alert of the reference
   line is a contact, g its distance along the reference normal, x midway; two clipped points
   closer than 1e-9 of the reference edge (corner on corner) are one contact. When clipping leaves
   nothing within alert (corner facing corner), the closest vertex-to-polygon pair is the one
   contact. The gap of a point clipped at a corner of the reference edge may exceed the true
   distance by a bounded factor (it tends to 0 with it); it is never below it. */
int mo_narrow_polygon_polygon(int na, const double *va, int nb, const double *vb, double alert,
                              mo_narrow out[2]);

/* Signed area of the polygon (> 0 counter-clockwise), any nv >= 0 (0 below 3 vertices). */
double mo_polygon_area(int nv, const double *v);

/* Centroid c[2] of the polygon's area; the mean of the vertices when the area is 0. */
void mo_polygon_centroid(int nv, const double *v, double *c);

/* Second polar moment of area about the point c, integral of |x - c|^2 over the polygon (for a
   rigid body: I = density * thickness * this). Its sign follows the orientation, like the area. */
double mo_polygon_inertia(int nv, const double *v, const double *c);

/* 0 when the polygon is valid for the narrow phases: at least 3 finite vertices, none repeated,
   non-zero area, counter-clockwise, convex and turning once. Else non-zero, with a sentence in
   why (n bytes, may be NULL): "fewer than 3 vertices", "non-finite vertex k", "repeated vertex
   k", "degenerate (zero area)", "clockwise", "not convex at vertex k", "not simple (turns more
   than once)". tol >= 0 is relative to the polygon's size L (largest side of its bounding box):
   vertices within tol L are repeated, an area below tol L^2 is zero, and a turn whose cross
   product is below -tol L^2 is not convex (collinear vertices pass). */
int mo_polygon_check(int nv, const double *v, double tol, char *why, size_t n);

#endif
