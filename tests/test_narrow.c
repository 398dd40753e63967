/* test_narrow.c: the narrow phases against gaps, normals and points computed by hand, the polygon
   utilities against closed forms, and the broad phase against brute force. */
#include "config.h"
#include "narrow.h"
#include "broad.h"
#include "vblocks.h"
#include "tap.h"

#include <stdint.h>

/* M_PI and M_SQRT1_2 are POSIX, not C99 */
static const double pi = 3.14159265358979323846, sqrt1_2 = 0.70710678118654752440;

/* One contact against the expected x, n (3 components each), g and features. */
static int is_contact(const mo_narrow *o, const double *x, const double *n, double g, int fa, int fb,
                      double tol, const char *what)
{
  int k, pass = fabs(o->g - g) <= tol && o->fa == fa && o->fb == fb;
  for (k = 0; k < 3; k++) pass = pass && fabs(o->x[k] - x[k]) <= tol && fabs(o->n[k] - n[k]) <= tol;
  ok(pass, "%s", what);
  if (!pass) {
    diag("got  x (%.17g, %.17g, %.17g) n (%.17g, %.17g, %.17g) g %.17g f (%d, %d)", o->x[0], o->x[1], o->x[2],
         o->n[0], o->n[1], o->n[2], o->g, o->fa, o->fb);
    diag("want x (%.17g, %.17g, %.17g) n (%.17g, %.17g, %.17g) g %.17g f (%d, %d)", x[0], x[1], x[2], n[0],
         n[1], n[2], g, fa, fb);
  }
  return pass;
}

/* The contact of out[0..m) whose point is nearest to x (contacts come in no promised order). */
static const mo_narrow *near_x(const mo_narrow *out, int m, double x0, double x1)
{
  const mo_narrow *best = out;
  int k;
  for (k = 1; k < m; k++)
    if (hypot(out[k].x[0] - x0, out[k].x[1] - x1) < hypot(best->x[0] - x0, best->x[1] - x1)) best = &out[k];
  return best;
}

static int finite_contact(const mo_narrow *o)
{
  int k, f = isfinite(o->g);
  for (k = 0; k < 3; k++) f = f && isfinite(o->x[k]) && isfinite(o->n[k]);
  return f;
}

static void test_plane_ball(void)
{
  static const double p2[2] = {0, 0}, n2[2] = {0, 1}, p3[3] = {1, 2, 3}, n3[3] = {0, 0.6, 0.8};
  double c[3];
  mo_narrow o;
  int m;
  c[0] = 1, c[1] = 2;
  ok(mo_narrow_plane_ball(2, p2, n2, c, 0.5, 1.0, &o) == 0, "plane-ball: open by 1.5, beyond alert 1: none");
  m = mo_narrow_plane_ball(2, p2, n2, c, 0.5, 2.0, &o);
  ok(m == 1, "plane-ball: open by 1.5 within alert 2: one contact");
  is_contact(&o, (double[]){1, 0.75, 0}, (double[]){0, 1, 0}, 1.5, -1, -1, 1e-15,
             "plane-ball: open, x midway");
  c[1] = 0.5;
  m = mo_narrow_plane_ball(2, p2, n2, c, 0.5, 0.0, &o);
  ok(m == 1 && o.g == 0, "plane-ball: touching, g = 0 exactly, kept with alert 0");
  /* 3D tilted plane; the centre 0.3 above it, shifted along (1, 0.8, -0.6), orthogonal to n */
  c[0] = 1 + 1, c[1] = 2 + 0.3 * 0.6 + 0.8, c[2] = 3 + 0.3 * 0.8 - 0.6;
  m = mo_narrow_plane_ball(3, p3, n3, c, 0.5, 0.0, &o);
  ok(m == 1, "plane-ball 3D: overlap");
  is_contact(&o, (double[]){c[0], c[1] - 0.4 * 0.6, c[2] - 0.4 * 0.8}, n3, -0.2, -1, -1, 1e-14,
             "plane-ball 3D: tilted plane, g = -0.2, x = c - 0.4 n");
  c[0] = 5, c[1] = -1, c[2] = 7;
  m = mo_narrow_plane_ball(2, p2, n2, c, 0.0, 0.0, &o);
  ok(m == 1 && o.g == -1 && o.x[1] == -0.5 && o.x[2] == 0 && o.n[2] == 0,
     "plane-ball: a node (r = 0) below the plane; unused components 0");
}

static void test_ball_ball(void)
{
  mo_narrow o;
  int m;
  ok(mo_narrow_ball_ball(3, (double[]){0, 0, 0}, 1, (double[]){3, 4, 0}, 1.5, 2.0, &o) == 0,
     "ball-ball 3D: open by 2.5, beyond alert 2: none");
  m = mo_narrow_ball_ball(3, (double[]){0, 0, 0}, 1, (double[]){3, 4, 0}, 1.5, 3.0, &o);
  ok(m == 1, "ball-ball 3D: within alert 3");
  is_contact(&o, (double[]){1.35, 1.8, 0}, (double[]){0.6, 0.8, 0}, 2.5, -1, -1, 1e-15,
             "ball-ball 3D: g = 2.5, n = (0.6, 0.8, 0), x midway between the surfaces");
  m = mo_narrow_ball_ball(2, (double[]){0, 0}, 1, (double[]){2, 0}, 1, 0.0, &o);
  ok(m == 1, "ball-ball 2D: touching kept with alert 0");
  is_contact(&o, (double[]){1, 0, 0}, (double[]){1, 0, 0}, 0, -1, -1, 0,
             "ball-ball 2D: touching, g = 0 exactly");
  m = mo_narrow_ball_ball(2, (double[]){0, 0}, 1, (double[]){0, 1.5}, 1, 0.0, &o);
  ok(m == 1, "ball-ball 2D: overlap");
  is_contact(&o, (double[]){0, 0.75, 0}, (double[]){0, 1, 0}, -0.5, -1, -1, 1e-15,
             "ball-ball 2D: overlap 0.5");
  m = mo_narrow_ball_ball(3, (double[]){1, 1, 1}, 0.3, (double[]){1, 1, 1}, 0.2, 0.0, &o);
  ok(m == 1 && finite_contact(&o), "ball-ball: coincident centres, no NaN");
  is_contact(&o, (double[]){1, 1.05, 1}, (double[]){0, 1, 0}, -0.5, -1, -1, 1e-15,
             "ball-ball: coincident centres, normal +y, g = -(ra + rb)");
  m = mo_narrow_ball_ball(2, (double[]){0, 0}, 0, (double[]){0, 0}, 0, 0.0, &o);
  ok(m == 1 && o.g == 0 && o.n[1] == 1, "ball-ball: two coincident points touch with normal +y");
  m = mo_narrow_ball_ball(2, (double[]){0, 0}, 1, (double[]){0.6, -0.8}, 0, 0.0, &o);
  ok(m == 1 && fabs(o.g + 0) < 1e-15 && fabs(o.x[0] - 0.6) < 1e-15 && fabs(o.n[1] + 0.8) < 1e-15,
     "ball-ball: a node (r = 0) on the surface of a disk");
  m = mo_narrow_ball_ball(2, (double[]){NAN, 0}, 1, (double[]){0, 0}, 1, 1.0, &o);
  ok(m == 0, "ball-ball: a NaN centre gives no contact");
}

/* The square [0, 2]^2, counter-clockwise from the origin: edges 0 bottom, 1 right, 2 top, 3 left,
   feature codes 4 + k. */
static const double square2[8] = {0, 0, 2, 0, 2, 2, 0, 2};

static void test_polygon_ball(void)
{
  static const double tri[6] = {0, 0, 4, 0, 0, 3};
  mo_narrow o;
  double c[2];
  int m;
  m = mo_narrow_polygon_ball(4, square2, (double[]){1, 3}, 0.5, 0.0, &o);
  ok(m == 0, "polygon-ball: above the top edge by 0.5, alert 0: none");
  m = mo_narrow_polygon_ball(4, square2, (double[]){1, 3}, 0.5, 0.5, &o);
  ok(m == 1, "polygon-ball: within alert 0.5");
  is_contact(&o, (double[]){1, 2.25, 0}, (double[]){0, 1, 0}, 0.5, 6, -1, 1e-15,
             "polygon-ball: edge region, top edge (code 6), x midway");
  m = mo_narrow_polygon_ball(4, square2, (double[]){1, 2.5}, 0.5, 0.0, &o);
  ok(m == 1 && o.g == 0, "polygon-ball: touching the top edge, g = 0 exactly");
  ok(mo_narrow_polygon_ball(4, square2, (double[]){1, 4}, 0.5, 1.0, &o) == 0,
     "polygon-ball: open by 1.5, beyond alert 1: none");
  m = mo_narrow_polygon_ball(4, square2, (double[]){2.3, 2.4}, 0.25, 0.3, &o);
  ok(m == 1, "polygon-ball: vertex region within alert");
  is_contact(&o, (double[]){2.075, 2.1, 0}, (double[]){0.6, 0.8, 0}, 0.25, 2, -1, 1e-14,
             "polygon-ball: vertex 2, normal from the vertex to the centre");
  ok(mo_narrow_polygon_ball(4, square2, (double[]){2.3, 2.4}, 0.25, 0.2, &o) == 0,
     "polygon-ball: vertex region, the edge lines say 0.15 but the vertex 0.25 > alert 0.2: none");
  m = mo_narrow_polygon_ball(4, square2, (double[]){1.5, 1}, 0.2, 0.0, &o);
  ok(m == 1, "polygon-ball: centre inside");
  is_contact(&o, (double[]){1.65, 1, 0}, (double[]){1, 0, 0}, -0.7, 5, -1, 1e-15,
             "polygon-ball: centre inside, out through the nearest edge, g = -depth - r");
  m = mo_narrow_polygon_ball(4, square2, (double[]){2, 2}, 0.1, 0.0, &o);
  ok(m == 1 && finite_contact(&o), "polygon-ball: centre on a vertex, finite");
  is_contact(&o, (double[]){1.95, 2, 0}, (double[]){1, 0, 0}, -0.1, 5, -1, 1e-15,
             "polygon-ball: centre on vertex 2, the lower edge of the tie (1)");
  m = mo_narrow_polygon_ball(4, square2, (double[]){2, 1}, 0.1, 0.0, &o);
  is_contact(&o, (double[]){1.95, 1, 0}, (double[]){1, 0, 0}, -0.1, 5, -1, 1e-15,
             "polygon-ball: centre on the right edge");
  m = mo_narrow_polygon_ball(4, square2, (double[]){1, 1}, 0.5, 0.0, &o);
  is_contact(&o, (double[]){1, 0.75, 0}, (double[]){0, -1, 0}, -1.5, 4, -1, 1e-15,
             "polygon-ball: centre at the centroid, four edges tie, edge 0");
  m = mo_narrow_polygon_ball(4, square2, (double[]){0, 2}, 0.0, 0.0, &o);
  ok(m == 1 && o.g == 0 && finite_contact(&o), "polygon-ball: a node (r = 0) exactly on vertex 3");
  /* triangle: beyond the hypotenuse (edge 1, (4,0) to (0,3), outward normal (0.6, 0.8)) */
  c[0] = 2 + 0.6, c[1] = 1.5 + 0.8;
  m = mo_narrow_polygon_ball(3, tri, c, 0.5, 0.5, &o);
  ok(m == 1, "polygon-ball: triangle, hypotenuse");
  is_contact(&o, (double[]){c[0] - 0.75 * 0.6, c[1] - 0.75 * 0.8, 0}, (double[]){0.6, 0.8, 0}, 0.5, 4, -1,
             1e-14, "polygon-ball: triangle, slanted edge normal and gap");
  m = mo_narrow_polygon_ball(3, tri, (double[]){-1, -1}, 0.0, 2.0, &o);
  is_contact(&o, (double[]){-0.5, -0.5, 0}, (double[]){-sqrt1_2, -sqrt1_2, 0}, sqrt(2.0), 0, -1, 1e-15,
             "polygon-ball: triangle, vertex 0 seen diagonally");
}

static void test_plane_polygon(void)
{
  static const double p[2] = {0, 0}, n[2] = {0, 1};
  static const double rect[8] = {0, 0.1, 2, 0.1, 2, 1.1, 0, 1.1}, diamond[8] = {0, 0, 1, 1, 0, 2, -1, 1};
  mo_narrow o[4];
  int m;
  ok(mo_narrow_plane_polygon(p, n, 4, rect, 0.0, o) == 0,
     "plane-polygon: rectangle 0.1 above, alert 0: none");
  m = mo_narrow_plane_polygon(p, n, 4, rect, 0.2, o);
  ok(m == 2, "plane-polygon: rectangle resting (0.1 above, alert 0.2): two contacts");
  is_contact(&o[0], (double[]){0, 0.05, 0}, (double[]){0, 1, 0}, 0.1, -1, 0, 1e-15,
             "plane-polygon: vertex 0");
  is_contact(&o[1], (double[]){2, 0.05, 0}, (double[]){0, 1, 0}, 0.1, -1, 1, 1e-15,
             "plane-polygon: vertex 1");
  m = mo_narrow_plane_polygon(p, n, 4, diamond, 0.5, o);
  ok(m == 1, "plane-polygon: diamond on its corner: one contact");
  is_contact(&o[0], (double[]){0, 0, 0}, (double[]){0, 1, 0}, 0, -1, 0, 0, "plane-polygon: corner touching");
  m = mo_narrow_plane_polygon((double[]){1, 0}, (double[]){-0.6, 0.8}, 4, rect, 0.0, o);
  ok(m == 1 && fabs(o[0].g - (-0.6 * 1 + 0.8 * 0.1)) < 1e-15 && o[0].fb == 1,
     "plane-polygon: tilted plane, only vertex 1 below it");
}

/* Rectangles as counter-clockwise polygons. */
static void rect(double x0, double y0, double x1, double y1, double *v)
{
  v[0] = x0, v[1] = y0, v[2] = x1, v[3] = y0, v[4] = x1, v[5] = y1, v[6] = x0, v[7] = y1;
}

/* Rotate the polygon by angle a about (cx, cy). */
static void rotate(int nv, double *v, double a, double cx, double cy)
{
  int k;
  for (k = 0; k < nv; k++) {
    double x = v[2 * k] - cx, y = v[2 * k + 1] - cy;
    v[2 * k] = cx + cos(a) * x - sin(a) * y;
    v[2 * k + 1] = cy + sin(a) * x + cos(a) * y;
  }
}

static void test_polygon_rest(void)
{
  double a[8], b[8];
  mo_narrow o[2];
  int m;
  rect(0, 0, 2, 1, a);
  rect(0.5, 1, 1.5, 2, b);
  m = mo_narrow_polygon_polygon(4, a, 4, b, 0.0, o);
  ok(m == 2, "polygon-polygon: block resting flat on a block: two contacts");
  ok(o[0].g == 0 && o[1].g == 0, "polygon-polygon: resting, both gaps exactly 0");
  ok(o[0].n[0] == 0 && o[0].n[1] == 1 && o[1].n[0] == 0 && o[1].n[1] == 1,
     "polygon-polygon: resting, normal exactly (0, 1)");
  is_contact(near_x(o, m, 0.5, 1), (double[]){0.5, 1, 0}, (double[]){0, 1, 0}, 0, 6, 0, 0,
             "polygon-polygon: resting, left corner (top edge of A, vertex 0 of B)");
  is_contact(near_x(o, m, 1.5, 1), (double[]){1.5, 1, 0}, (double[]){0, 1, 0}, 0, 6, 1, 0,
             "polygon-polygon: resting, right corner (top edge of A, vertex 1 of B)");
  rect(-0.3, 0.2, 0.4, 0.7, a); /* widths and heights that are not dyadic */
  rect(0.1, 0.7, 0.2, 0.8, b);
  m = mo_narrow_polygon_polygon(4, a, 4, b, 0.0, o);
  ok(m == 2 && o[0].g == 0 && o[1].g == 0 && o[0].n[0] == 0 && o[0].n[1] == 1 && o[1].n[1] == 1,
     "polygon-polygon: a 0.1 block on a 0.7 x 0.5 block: gaps and normal exact");
  rect(0, 0, 1, 1, a);
  rect(0, 1, 1, 2, b);
  m = mo_narrow_polygon_polygon(4, a, 4, b, 0.0, o);
  ok(m == 2 && o[0].g == 0 && o[1].g == 0 && (o[0].fa != o[1].fa || o[0].fb != o[1].fb),
     "polygon-polygon: equal blocks stacked, coincident edges: two contacts, distinct features");
  rect(0, 1.05, 1, 2.05, b);
  ok(mo_narrow_polygon_polygon(4, a, 4, b, 0.01, o) == 0, "polygon-polygon: 0.05 apart, alert 0.01: none");
  m = mo_narrow_polygon_polygon(4, a, 4, b, 0.1, o);
  ok(m == 2 && fabs(o[0].g - 0.05) < 1e-15 && fabs(o[1].g - 0.05) < 1e-15 && fabs(o[0].x[1] - 1.025) < 1e-15,
     "polygon-polygon: 0.05 apart within alert 0.1: two contacts, x midway");
  rect(0, 0, 2, 1, a);
  rect(0.5, 0.9, 1.5, 1.9, b);
  m = mo_narrow_polygon_polygon(4, a, 4, b, 0.0, o);
  ok(m == 2 && fabs(o[0].g + 0.1) < 1e-15 && fabs(o[1].g + 0.1) < 1e-15 && o[0].n[1] == 1,
     "polygon-polygon: block sunk 0.1 into a block: two contacts, g = -0.1");
}

static void test_polygon_vertex(void)
{
  double a[8], b[8];
  static const double diamond[8] = {0.2, 0, 1.2, 1, 0.2, 2, -0.8, 1};
  static const double tri[6] = {1, 0.9, 2, 2.5, 0, 2.5};
  mo_narrow o[2];
  int m, k;
  rect(-1, -1, 1, 0, a);
  m = mo_narrow_polygon_polygon(4, a, 4, diamond, 0.5, o);
  ok(m == 1, "polygon-polygon: a block on its corner (rotated 45 degrees): one contact");
  is_contact(&o[0], (double[]){0.2, 0, 0}, (double[]){0, 1, 0}, 0, 6, 0, 1e-15,
             "polygon-polygon: corner on the top edge, g = 0");
  for (k = 0; k < 4; k++) b[2 * k] = diamond[2 * k], b[2 * k + 1] = diamond[2 * k + 1] + 0.1;
  m = mo_narrow_polygon_polygon(4, a, 4, b, 0.5, o);
  is_contact(&o[0], (double[]){0.2, 0.05, 0}, (double[]){0, 1, 0}, 0.1, 6, 0, 1e-15,
             "polygon-polygon: corner 0.1 above the edge");
  m = mo_narrow_polygon_polygon(4, diamond, 4, a, 0.5, o);
  ok(m == 1, "polygon-polygon: the cornered block as master");
  is_contact(&o[0], (double[]){0.2, 0, 0}, (double[]){0, -1, 0}, 0, 0, 6, 1e-15,
             "polygon-polygon: reference edge on the slave, normal turned to (0, -1), features swapped");
  rect(0, 0, 2, 1, a);
  m = mo_narrow_polygon_polygon(4, a, 3, tri, 0.0, o);
  ok(m == 1, "polygon-polygon: a triangle's vertex into an edge");
  is_contact(&o[0], (double[]){1, 0.95, 0}, (double[]){0, 1, 0}, -0.1, 6, 0, 1e-15,
             "polygon-polygon: vertex 0.1 deep, x midway");
  /* corner facing corner: B's corner at (1.3, 1.4) from A's (1, 1), distance 0.5 */
  rect(0, 0, 1, 1, a);
  rect(1.3, 1.4, 2.3, 2.4, b);
  ok(mo_narrow_polygon_polygon(4, a, 4, b, 0.45, o) == 0,
     "polygon-polygon: corner to corner at 0.5, axes say 0.4 but alert 0.45: none");
  m = mo_narrow_polygon_polygon(4, a, 4, b, 0.6, o);
  ok(m == 1, "polygon-polygon: corner to corner within alert 0.6");
  is_contact(&o[0], (double[]){1.15, 1.2, 0}, (double[]){0.6, 0.8, 0}, 0.5, 2, 0, 1e-14,
             "polygon-polygon: corner to corner, normal along the corners, vertex 2 against vertex 0");
  rect(1, 1, 2, 2, b);
  m = mo_narrow_polygon_polygon(4, a, 4, b, 0.0, o);
  ok(m == 1, "polygon-polygon: corners touching: one contact, not two at the same point");
  is_contact(&o[0], (double[]){1, 1, 0}, (double[]){1, 0, 0}, 0, 5, 0, 0,
             "polygon-polygon: corners touching, g = 0 (A's edge 1 against B's vertex 0)");
}

static void test_polygon_clip(void)
{
  double a[8], b[8], big[8], tiny[8];
  mo_narrow o[2];
  int m;
  rect(0, 0, 2, 1, a);
  rect(1.5, 1.1, 3.5, 2.1, b);
  m = mo_narrow_polygon_polygon(4, a, 4, b, 0.2, o);
  ok(m == 2, "polygon-polygon: edges overlapping on [1.5, 2]: two contacts");
  is_contact(near_x(o, m, 1.5, 1.05), (double[]){1.5, 1.05, 0}, (double[]){0, 1, 0}, 0.1, 6, 0, 1e-14,
             "polygon-polygon: B's corner on A's top edge (edge 6, vertex 0)");
  is_contact(near_x(o, m, 2, 1.05), (double[]){2, 1.05, 0}, (double[]){0, 1, 0}, 0.1, 2, 4, 1e-14,
             "polygon-polygon: clipped at A's corner (vertex 2, edge 4)");
  m = mo_narrow_polygon_polygon(4, b, 4, a, 0.2, o);
  ok(m == 2, "polygon-polygon: the same, upper block as master");
  is_contact(near_x(o, m, 1.5, 1.05), (double[]){1.5, 1.05, 0}, (double[]){0, -1, 0}, 0.1, 0, 6, 1e-14,
             "polygon-polygon: upper master, normal (0, -1), B's vertex 0 on A's edge 2");
  is_contact(near_x(o, m, 2, 1.05), (double[]){2, 1.05, 0}, (double[]){0, -1, 0}, 0.1, 4, 2, 1e-14,
             "polygon-polygon: upper master, clipped point (edge 0 of the master, vertex 2 of the slave)");
  rect(0, 0, 10, 10, big);
  rect(8, 4, 9, 5, tiny);
  m = mo_narrow_polygon_polygon(4, big, 4, tiny, 0.0, o);
  ok(m == 2 && fabs(o[0].g + 2) < 1e-15 && fabs(o[1].g + 2) < 1e-15 && o[0].n[0] == 1 && o[0].n[1] == 0,
     "polygon-polygon: tiny block inside a big one: out through the nearest edge, g = -2, n = (1, 0)");
  m = mo_narrow_polygon_polygon(4, tiny, 4, big, 0.0, o);
  ok(m == 2 && fabs(o[0].g + 2) < 1e-15 && o[0].n[0] == -1 && o[0].n[1] == 0,
     "polygon-polygon: tiny block as master inside the big one: n = (-1, 0) from master to slave");
  m = mo_narrow_polygon_polygon(4, a, 4, a, 0.0, o);
  ok(m == 2 && finite_contact(&o[0]) && finite_contact(&o[1]) && fabs(o[0].g + 1) < 1e-15,
     "polygon-polygon: coincident polygons, finite, g = -(height)");
}

/* Equal blocks, the upper one turned by +-1e-7 about its centre and lifted so that its low
   corner is 1e-9 above: either way the reference stays A's top edge, normal exactly (0, 1). */
static void test_polygon_parallel(void)
{
  double a[8], b[8];
  mo_narrow o[2];
  int m, s, k;
  rect(0, 0, 1, 1, a);
  for (s = -1; s <= 1; s += 2) {
    double lift = HUGE_VAL;
    rect(0, 1, 1, 2, b);
    rotate(4, b, s * 1e-7, 0.5, 1.5);
    for (k = 0; k < 4; k++) lift = fmin(lift, b[2 * k + 1]);
    for (k = 0; k < 4; k++) b[2 * k + 1] += 1 + 1e-9 - lift;
    m = mo_narrow_polygon_polygon(4, a, 4, b, 1e-3, o);
    ok(m == 2 && o[0].n[0] == 0 && o[0].n[1] == 1 && o[1].n[0] == 0 && o[1].n[1] == 1 &&
           fabs(fmin(o[0].g, o[1].g) - 1e-9) < 1e-15,
       "polygon-polygon: nearly parallel edges (turned %+g): reference kept on A", s * 1e-7);
  }
}

typedef struct {
  uint64_t s;
} rng;

static double rnd(rng *g) /* xorshift64*, uniform in [0, 1) */
{
  g->s ^= g->s >> 12;
  g->s ^= g->s << 25;
  g->s ^= g->s >> 27;
  return (double)((g->s * UINT64_C(2685821657736338717)) >> 11) / 9007199254740992.0;
}

/* A random convex polygon of nv vertices at random angles on the circle of radius R about (x, y). */
static void random_polygon(rng *g, int nv, double R, double x, double y, double *v)
{
  double a = 7 * rnd(g);
  int k;
  for (k = 0; k < nv; k++) {
    double th = a + (k + 0.8 * rnd(g)) * 2 * pi / nv;
    v[2 * k] = x + R * cos(th);
    v[2 * k + 1] = y + R * sin(th);
  }
}

/* Distance from p to the segment ab. */
static double seg_dist(const double *p, const double *a, const double *b)
{
  double e[2] = {b[0] - a[0], b[1] - a[1]}, d[2] = {p[0] - a[0], p[1] - a[1]};
  double t = (d[0] * e[0] + d[1] * e[1]) / (e[0] * e[0] + e[1] * e[1]);
  t = t < 0 ? 0 : t > 1 ? 1 : t;
  return hypot(d[0] - t * e[0], d[1] - t * e[1]);
}

/* 1 when the convex polygons overlap: a vertex of one inside the other or two edges crossing. */
static int overlap(int na, const double *va, int nb, const double *vb)
{
  int k, j, ina = 1, inb = 1;
  for (k = 0; k < na; k++) {
    const double *a = va + 2 * k, *b = va + 2 * ((k + 1) % na);
    ina = ina && (b[0] - a[0]) * (vb[1] - a[1]) - (b[1] - a[1]) * (vb[0] - a[0]) > 0;
    for (j = 0; j < nb; j++) {
      const double *c = vb + 2 * j, *d = vb + 2 * ((j + 1) % nb);
      double d1 = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
      double d2 = (b[0] - a[0]) * (d[1] - a[1]) - (b[1] - a[1]) * (d[0] - a[0]);
      double d3 = (d[0] - c[0]) * (a[1] - c[1]) - (d[1] - c[1]) * (a[0] - c[0]);
      double d4 = (d[0] - c[0]) * (b[1] - c[1]) - (d[1] - c[1]) * (b[0] - c[0]);
      if (d1 * d2 < 0 && d3 * d4 < 0) return 1;
    }
  }
  for (j = 0; j < nb; j++) {
    const double *c = vb + 2 * j, *d = vb + 2 * ((j + 1) % nb);
    inb = inb && (d[0] - c[0]) * (va[1] - c[1]) - (d[1] - c[1]) * (va[0] - c[0]) > 0;
  }
  return ina || inb;
}

/* Random pairs of convex polygons against brute-force distances: every contact finite with a
   unit normal and g <= alert; disjoint polygons within alert never missed and their gap never
   below the distance (SAT and clipping bound it from above); overlapping ones always found with
   a negative gap. */
static void test_polygon_random(void)
{
  rng g = {2463534242u};
  int it, bad = 0, miss = 0, under = 0, ovmiss = 0, nov = 0, ntest = 0, nnear = 0;
  for (it = 0; it < 4000; it++) {
    int na = 3 + it % 6, nb = 3 + it / 6 % 6, m, k, j;
    double va[16], vb[16], d = HUGE_VAL, alert = 0.3 * rnd(&g), gmin = HUGE_VAL;
    mo_narrow o[2];
    random_polygon(&g, na, 0.5 + rnd(&g), 0, 0, va);
    random_polygon(&g, nb, 0.2 + rnd(&g), 3 * rnd(&g) - 1.5, 3 * rnd(&g) - 1.5, vb);
    if (mo_polygon_check(na, va, 1e-9, NULL, 0) || mo_polygon_check(nb, vb, 1e-9, NULL, 0)) continue;
    ntest++;
    for (k = 0; k < na; k++)
      for (j = 0; j < nb; j++) {
        d = fmin(d, seg_dist(va + 2 * k, vb + 2 * j, vb + 2 * ((j + 1) % nb)));
        d = fmin(d, seg_dist(vb + 2 * j, va + 2 * k, va + 2 * ((k + 1) % na)));
      }
    m = mo_narrow_polygon_polygon(na, va, nb, vb, alert, o);
    for (k = 0; k < m; k++) {
      bad += !finite_contact(&o[k]) || fabs(hypot(o[k].n[0], o[k].n[1]) - 1) > 1e-12 || o[k].g > alert;
      gmin = fmin(gmin, o[k].g);
    }
    if (overlap(na, va, nb, vb)) {
      nov++;
      ovmiss += !(gmin < 0);
      continue;
    }
    nnear += d <= alert;
    miss += d <= alert && !m;
    under += m && gmin < d - 1e-12;
  }
  ok(bad == 0, "polygon-polygon random: %d pairs, every contact finite, unit normal, g <= alert", ntest);
  ok(miss == 0 && under == 0, "polygon-polygon random: %d disjoint pairs (%d within alert), none missed, "
     "gap >= distance", ntest - nov, nnear);
  ok(ovmiss == 0, "polygon-polygon random: %d overlapping pairs, all found with g < 0", nov);
}

static void test_polygon_utils(void)
{
  static const double unit[8] = {0, 0, 1, 0, 1, 1, 0, 1}, cw[8] = {0, 0, 0, 1, 1, 1, 1, 0};
  static const double tri[6] = {0, 0, 3, 0, 0, 4};
  double hex[12], c[2];
  int k;
  is_close(mo_polygon_area(4, unit), 1, 1e-15, "unit square: area 1");
  mo_polygon_centroid(4, unit, c);
  ok(fabs(c[0] - 0.5) < 1e-15 && fabs(c[1] - 0.5) < 1e-15, "unit square: centroid (0.5, 0.5)");
  is_close(mo_polygon_inertia(4, unit, c), 1.0 / 6, 1e-15,
           "unit square: polar moment (a^2 + b^2) A / 12 = 1/6");
  is_close(mo_polygon_inertia(4, unit, (double[]){0, 0}), 2.0 / 3, 1e-15,
           "unit square: about a corner, + A d^2 (parallel axes) = 2/3");
  is_close(mo_polygon_area(4, cw), -1, 1e-15, "clockwise unit square: area -1");
  is_close(mo_polygon_area(3, tri), 6, 1e-15, "right triangle 3 x 4: area 6");
  mo_polygon_centroid(3, tri, c);
  ok(fabs(c[0] - 1) < 1e-15 && fabs(c[1] - 4.0 / 3) < 1e-15, "right triangle: centroid (1, 4/3)");
  is_close(mo_polygon_inertia(3, tri, c), 3.0 * 4 * (9 + 16) / 36, 1e-14,
           "right triangle: polar moment b h (b^2 + h^2) / 36 = 25/3");
  for (k = 0; k < 6; k++) { /* regular hexagon, circumradius 2, centre (2, -1), turned by 0.3 */
    hex[2 * k] = 2 + 2 * cos(0.3 + k * pi / 3);
    hex[2 * k + 1] = -1 + 2 * sin(0.3 + k * pi / 3);
  }
  is_close(mo_polygon_area(6, hex), 1.5 * sqrt(3.0) * 4, 1e-14,
           "regular hexagon R = 2: area (3 sqrt 3 / 2) R^2");
  mo_polygon_centroid(6, hex, c);
  ok(fabs(c[0] - 2) < 1e-14 && fabs(c[1] + 1) < 1e-14, "regular hexagon: centroid at its centre");
  is_close(mo_polygon_inertia(6, hex, c), 5 * sqrt(3.0) / 8 * 16, 1e-13,
           "regular hexagon: polar moment (5 sqrt 3 / 8) R^4");
  mo_polygon_centroid(3, (double[]){0, 0, 1, 0, 2, 0}, c);
  ok(c[0] == 1 && c[1] == 0, "centroid of a degenerate polygon: the vertices' mean, no NaN");
}

static void test_polygon_check(void)
{
  static const double unit[8] = {0, 0, 1, 0, 1, 1, 0, 1}, cw[8] = {0, 0, 0, 1, 1, 1, 1, 0};
  static const double dart[10] = {0, 0, 2, 0, 2, 2, 1, 0.5, 0, 2}, rep[8] = {0, 0, 1, 0, 1, 0, 0, 1};
  static const double flat[6] = {0, 0, 1, 0, 2, 0}, closed[10] = {0, 0, 1, 0, 1, 1, 0, 1, 0, 0};
  static const double line5[10] = {0, 0, 1, 0, 2, 0, 2, 1, 0, 1};
  double star[10], bad[8];
  char why[80];
  int k;
  ok(mo_polygon_check(4, unit, 1e-12, why, sizeof why) == 0 && why[0] == '\0', "check: unit square valid");
  ok(mo_polygon_check(5, line5, 0, why, sizeof why) == 0, "check: collinear vertices on an edge pass");
  ok(mo_polygon_check(4, cw, 1e-12, why, sizeof why) != 0, "check: clockwise rejected");
  is_str(why, "clockwise", "check: says clockwise");
  ok(mo_polygon_check(5, dart, 1e-12, why, sizeof why) != 0, "check: dart rejected");
  is_str(why, "not convex at vertex 3", "check: names the reflex vertex");
  ok(mo_polygon_check(4, rep, 1e-12, why, sizeof why) != 0, "check: repeated vertex rejected");
  is_str(why, "repeated vertex 2", "check: names the repeated vertex");
  mo_polygon_check(5, closed, 1e-12, why, sizeof why);
  is_str(why, "repeated vertex 4", "check: last vertex repeating the first");
  ok(mo_polygon_check(3, flat, 1e-12, why, sizeof why) != 0, "check: collinear triangle rejected");
  is_str(why, "degenerate (zero area)", "check: says degenerate");
  ok(mo_polygon_check(2, unit, 1e-12, why, sizeof why) != 0, "check: two vertices rejected");
  is_str(why, "fewer than 3 vertices", "check: says fewer than 3");
  for (k = 0; k < 5; k++) { /* pentagram {5/2}: every turn left, twice around */
    star[2 * k] = cos(k * 4 * pi / 5);
    star[2 * k + 1] = sin(k * 4 * pi / 5);
  }
  ok(mo_polygon_check(5, star, 1e-12, why, sizeof why) != 0, "check: pentagram rejected");
  is_str(why, "not simple (turns more than once)", "check: says it turns more than once");
  for (k = 0; k < 8; k++) bad[k] = unit[k];
  bad[3] = NAN;
  mo_polygon_check(4, bad, 1e-12, why, sizeof why);
  is_str(why, "non-finite vertex 1", "check: names a non-finite vertex");
  ok(mo_polygon_check(4, cw, 0, NULL, 0) != 0, "check: why may be NULL");
}

/* Broad phase: random sets against brute force. */

/* All pairs by testing every one, in the order mo_broad_pairs promises. */
static int *brute(int dim, int n, const double *c, const double *r, const unsigned char *mask, double alert,
                  long *np)
{
  size_t cap = 1024;
  int i, j, k, *p = malloc(2 * sizeof(int) * cap);
  *np = 0;
  for (i = 0; i < n; i++)
    for (j = i + 1; j < n; j++) {
      double d2 = 0;
      if (mask && (!mask[i] || !mask[j])) continue;
      for (k = 0; k < dim; k++) d2 += (c[dim * j + k] - c[dim * i + k]) * (c[dim * j + k] - c[dim * i + k]);
      if (sqrt(d2) - r[i] - r[j] <= alert) {
        if ((size_t)*np == cap) p = realloc(p, 2 * sizeof(int) * (cap *= 2));
        p[2 * *np] = i;
        p[2 * *np + 1] = j;
        ++*np;
      }
    }
  return p;
}

static int same_pairs(mo_broad *B, int dim, int n, const double *c, const double *r,
                      const unsigned char *mask,
                      double alert, long *np, mo_ctx *ctx)
{
  const int *p;
  long nb, k;
  int *q = brute(dim, n, c, r, mask, alert, &nb), st, pass;
  st = mo_broad_pairs(B, dim, n, c, r, mask, alert, &p, np, ctx);
  pass = !st && *np == nb;
  for (k = 0; pass && k < 2 * nb; k++) pass = p[k] == q[k];
  if (!pass) diag("status %d (%s), %ld pairs, brute force %ld", st, ctx->errmsg, *np, nb);
  free(q);
  return pass;
}

static void random_set(rng *g, int dim, int n, double L, double *c, double *r)
{
  int i, k;
  for (i = 0; i < n; i++) {
    for (k = 0; k < dim; k++) c[dim * i + k] = L * rnd(g);
    r[i] = 0.8 + 0.4 * rnd(g);
  }
}

static void test_broad_random(void)
{
  enum { N = 2000 };
  static const double alerts[3] = {0, 0.3, 2.5};
  double *c = malloc(3 * N * sizeof *c), *r = malloc(N * sizeof *r);
  unsigned char *mask = malloc(N);
  rng g = {88172645463325252u};
  mo_ctx ctx;
  mo_broad *B;
  long np, calls, npmax = 0;
  int dim, a, mk, i, pass;
  mo_ctx_init(&ctx);
  ok(mo_broad_create(&B, &ctx) == 0, "broad: create");
  for (i = 0; i < N; i++) mask[i] = rnd(&g) < 0.7;
  for (dim = 2; dim <= 3; dim++) {
    /* area fraction about 0.5 in 2D, volume fraction about 0.3 in 3D, overlaps allowed */
    random_set(&g, dim, N, dim == 2 ? 112 : 30, c, r);
    for (a = 0; a < 3; a++)
      for (mk = 0; mk < 2; mk++) {
        pass = same_pairs(B, dim, N, c, r, mk ? mask : NULL, alerts[a], &np, &ctx);
        if (np > npmax) npmax = np;
        ok(pass, "broad %dD: %d balls, alert %g, %s: %ld pairs as brute force", dim, N, alerts[a],
           mk ? "masked" : "no mask", np);
      }
    calls = ctx.alloc_calls;
    same_pairs(B, dim, N, c, r, mask, alerts[2], &np, &ctx);
    ok(ctx.alloc_calls == calls, "broad %dD: a second call with the same sizes allocates nothing", dim);
    c[dim * 7] = 1e6; /* one body far away: hashed grid, memory still O(N) */
    ok(same_pairs(B, dim, N, c, r, NULL, alerts[1], &np, &ctx), "broad %dD: a far outlier (1e6)", dim);
    c[dim * 7] = -1e300;
    c[dim * 8 + 1] = 1e300;
    ok(same_pairs(B, dim, N, c, r, NULL, alerts[1], &np, &ctx), "broad %dD: outliers at +-1e300", dim);
    /* O(balls + pairs): the grid, the gathered positions and the sort's scratch per ball, the pair
       list (with its growth) per pair of the largest call (alert 2.5) */
    ok(mo_broad_bytes(B) < 100 * (size_t)N + 16 * (size_t)npmax, "broad %dD: %zu bytes held for %d balls and %ld pairs "
       "(under 100 a ball plus 16 a pair)", dim, mo_broad_bytes(B), N, npmax);
    random_set(&g, dim, N, dim == 2 ? 1e4 : 2e3, c, r); /* a sparse gas: more than 4 cells a body */
    pass = same_pairs(B, dim, N, c, r, NULL, 50, &np, &ctx) && np > 0;
    ok(pass, "broad %dD: sparse set, alert 50 (%ld pairs)", dim, np);
  }
  for (dim = 2; dim <= 3; dim++) {
    /* a few balls much larger than the others (fast grains grown by their speed, or big bodies):
       the cells are sized for the others, the large ones search their own reach */
    random_set(&g, dim, N, dim == 2 ? 112 : 30, c, r);
    for (i = 0; i < N; i += 97) r[i] = 3 + 6 * rnd(&g);
    r[5] = 40;
    for (a = 0; a < 3; a++) {
      pass = same_pairs(B, dim, N, c, r, a == 1 ? mask : NULL, alerts[a], &np, &ctx);
      ok(pass, "broad %dD: %d balls, %d of them 3 to 40 times larger, alert %g%s: %ld pairs as brute force", dim, N,
         N / 97 + 1, alerts[a], a == 1 ? ", masked" : "", np);
    }
  }
  random_set(&g, 3, 100, 10, c, r);
  ok(same_pairs(B, 3, 100, c, r, NULL, 1e3, &np, &ctx) && np == 4950,
     "broad: alert larger than the set: all pairs");
  mo_broad_free(B);
  free(c);
  free(r);
  free(mask);
}

static void test_broad_small(void)
{
  double c[10] = {0, 0, 2, 0, 0, 0, 0, 0, 0, 0}, r[5] = {1, 1, 0, 0, 0};
  unsigned char mask[2] = {1, 0};
  const int *p;
  long np;
  mo_ctx ctx;
  mo_broad *B;
  mo_ctx_init(&ctx);
  mo_broad_create(&B, &ctx);
  ok(mo_broad_pairs(B, 2, 0, NULL, NULL, NULL, 0, &p, &np, &ctx) == 0 && np == 0, "broad: n = 0");
  ok(mo_broad_pairs(B, 2, 1, c, r, NULL, 0, &p, &np, &ctx) == 0 && np == 0, "broad: n = 1");
  ok(mo_broad_pairs(B, 2, 2, c, r, NULL, 0, &p, &np, &ctx) == 0 && np == 1 && p[0] == 0 && p[1] == 1,
     "broad: n = 2 touching, alert 0: the pair (0, 1)");
  ok(mo_broad_pairs(B, 2, 2, c, r, mask, 0, &p, &np, &ctx) == 0 && np == 0, "broad: n = 2, one masked out");
  c[2] = 2.5;
  ok(mo_broad_pairs(B, 2, 2, c, r, NULL, 0.4, &p, &np, &ctx) == 0 && np == 0,
     "broad: n = 2, 0.5 apart, alert 0.4");
  ok(mo_broad_pairs(B, 2, 2, c, r, NULL, 0.5, &p, &np, &ctx) == 0 && np == 1,
     "broad: n = 2, 0.5 apart, alert 0.5");
  ok(mo_broad_pairs(B, 2, 5, (double[10]){0}, (double[5]){0}, NULL, 0, &p, &np, &ctx) == 0 && np == 10,
     "broad: 5 coincident points, r = 0, alert 0: all 10 pairs");
  c[2] = NAN;
  ok(mo_broad_pairs(B, 2, 2, c, r, NULL, 0, &p, &np, &ctx) == MO_EINPUT && strstr(ctx.errmsg,
     "body 1") && np == 0,
     "broad: a non-finite coordinate is an input error naming the body");
  mo_ctx_clear_error(&ctx);
  ok(mo_broad_pairs(B, 2, 2, c, r, mask, 0, &p, &np, &ctx) == 0, "broad: a masked body is not read");
  ok(mo_broad_pairs(B, 2, 2, c, r, NULL, -1, &p, &np, &ctx) == MO_EINPUT, "broad: negative alert refused");
  mo_ctx_clear_error(&ctx);
  ok(mo_broad_pairs(B, 4, 2, c, r, NULL, 0, &p, &np, &ctx) == MO_EINPUT, "broad: dimension 4 refused");
  mo_broad_free(B);
  mo_broad_free(NULL);
}

/* The list kept by blocks (vblocks.c) against brute force, step by step, on a column of balls
   (radii 4-6 mm) thrown down at 1.5 m/s under gravity onto a bed that rises through it: balls above the bed fall
   together (the right half also drifting sideways), balls that reach it stop, a few at rest are
   kicked at random, some spin. At every step every pair within its alert distance,
   alert + 2 h (|v_i - v_j| + w_i + w_j), must be in the list, and the list sorted without repeats. */
static void vblocks_column(int dim, int n, int steps, int masked)
{
  const double h = 1e-3, grav = 9.81, alert = 4e-4, skin = 2e-3;
  double *x = malloc(3 * n * sizeof *x), *v = calloc(3 * n, sizeof *v), *w = calloc(n, sizeof *w);
  double *bound = malloc(n * sizeof *bound), ybed = 0.05, t = 0;
  unsigned char *mask = malloc(n), *fall = malloc(n);
  rng g = {0x9E3779B97F4A7C15u + (unsigned)(dim * 7 + masked)};
  mo_ctx ctx;
  mo_vblocks *V;
  mo_broad *B;
  long miss = 0, unsorted = 0, whole = 0, made, nblock, maxpairs = 0, nwide, loose = 0;
  int i, j, k, step, per_row = dim == 2 ? 40 : 10;
  const int up = dim - 1; /* the vertical axis */
  mo_ctx_init(&ctx);
  mo_vblocks_create(&V, &ctx);
  mo_broad_create(&B, &ctx);
  for (i = 0; i < n; i++) { /* a loose lattice with a little jitter, 12.5 mm apart */
    int row = i / (dim == 2 ? per_row : per_row * per_row), col = i % per_row, col2 = i / per_row % per_row;
    x[dim * i] = 0.0125 * (col + 0.5) + 0.002 * (rnd(&g) - 0.5);
    if (dim == 3) x[dim * i + 1] = 0.0125 * (col2 + 0.5) + 0.002 * (rnd(&g) - 0.5);
    x[dim * i + up] = 0.01 + 0.0125 * row + 0.002 * (rnd(&g) - 0.5);
    bound[i] = 0.004 + 0.002 * rnd(&g);
    mask[i] = !masked || rnd(&g) < 0.8;
    fall[i] = x[dim * i + up] > ybed;
    v[dim * i + up] = fall[i] ? -1.5 : 0; /* thrown down: the bed meets the column at several m/s */
    w[i] = rnd(&g) < 0.1 ? 0.05 * rnd(&g) : 0;
  }
  for (step = 0; step < steps; step++) {
    mo_vblocks_in in = {dim, n, mask, x, v, w, bound, t, h, alert, skin};
    const int *p;
    long np, q;
    int built = 0, st = mo_vblocks_update(V, &in, B, &p, &np, &built, &ctx);
    if (st) {
      ok(0, "vblocks %dD: update at step %d: %s", dim, step, ctx.errmsg);
      break;
    }
    whole += built;
    nwide = 0;
    for (q = 1; q < np; q++)
      if (!(p[2 * q - 2] < p[2 * q] || (p[2 * q - 2] == p[2 * q] && p[2 * q - 1] < p[2 * q + 1])) || p[2 * q] >= p[2 * q + 1])
        unsorted++;
    for (i = 0; i < n; i++)
      for (j = i + 1; j < n; j++) {
        double d2 = 0, dv2 = 0, gap;
        long lo = 0, hi = np;
        if (!mask[i] || !mask[j]) continue;
        for (k = 0; k < dim; k++) {
          d2 += (x[dim * i + k] - x[dim * j + k]) * (x[dim * i + k] - x[dim * j + k]);
          dv2 += (v[dim * i + k] - v[dim * j + k]) * (v[dim * i + k] - v[dim * j + k]);
        }
        gap = sqrt(d2) - bound[i] - bound[j];
        nwide += gap <= alert + 3 * skin + 2 * h * (sqrt(dv2) + w[i] + w[j]);
        if (gap > alert + 2 * h * (sqrt(dv2) + w[i] + w[j])) continue;
        while (lo < hi) {
          long mid = (lo + hi) / 2;
          if (p[2 * mid] < i || (p[2 * mid] == i && p[2 * mid + 1] < j)) lo = mid + 1;
          else hi = mid;
        }
        if (!(lo < np && p[2 * lo] == i && p[2 * lo + 1] == j) && miss++ < 3)
          diag("step %d: pair (%d, %d) at gap %g not in the list", step, i, j, gap);
      }
    if (np > maxpairs) maxpairs = np;
    if (np > 2 * nwide + n / 10) loose++;
    /* the motion over the step: the theta-scheme's free flight (x += h (v + v') / 2), the outer
       thirds drifting sideways towards the middle one (frames of different velocities meeting),
       the balls that reach the rising bed slowing down to rest, kicks; halfway, every ball of the
       bed kicked at once */
    t += h;
    ybed += 0.4 * h;
    for (i = 0; i < n; i++) {
      double *xi = x + dim * i, *vi = v + dim * i, x0[3];
      for (k = 0; k < dim; k++) x0[k] = xi[k];
      if (fall[i]) {
        const double third = xi[0] < 0.15 ? 1 : xi[0] > 0.35 ? -1 : 0, v0 = vi[up];
        vi[up] -= grav * h;
        vi[0] = dim == 2 ? 0.4 * third : vi[0];
        xi[up] += 0.5 * h * (v0 + vi[up]);
        if (dim == 2) xi[0] += h * vi[0];
        if (xi[up] <= ybed) fall[i] = 0;
      } else if (rnd(&g) < 0.003) /* a kick */
        for (k = 0; k < dim; k++) vi[k] += 0.5 * (rnd(&g) - 0.5);
      else
        for (k = 0; k < dim; k++) vi[k] *= 0.3;
      if (step == steps / 2 && !fall[i])
        for (k = 0; k < dim; k++) vi[k] += 2 * (rnd(&g) - 0.5);
      if (!fall[i])
        for (k = 0; k < dim; k++) xi[k] = x0[k] + h * vi[k];
    }
  }
  mo_vblocks_stats(V, &made, &nblock);
  ok(miss == 0 && unsorted == 0, "vblocks %dD: %d balls%s, %d steps of a column landing on a rising bed: every pair "
     "within its alert distance in the list, sorted (%ld missed, %ld out of order)", dim, n, masked ? " (a fifth masked out)" : "",
     steps, miss, unsorted);
  ok(whole <= 3 + steps / 20 && made > nblock, "vblocks %dD: the list kept by blocks: %ld whole builds in %d steps, %ld blocks "
     "made again of %ld", dim, whole, steps, made, nblock);
  ok(loose == 0, "vblocks %dD: at every step at most twice the pairs within alert + 3 skins + 2 h (|v_i - v_j| + w_i + "
     "w_j) listed, plus a tenth of the balls (at most %ld pairs for %d balls; %ld steps over)", dim, maxpairs, n, loose);
  mo_vblocks_free(V);
  mo_broad_free(B);
  free(x);
  free(v);
  free(w);
  free(bound);
  free(mask);
  free(fall);
}

/* Every allocation of the list kept by blocks failing in turn, over a few steps of moving balls:
   MO_ENOMEM, an empty list, no crash, no leak (valgrind, ASan), and the next call builds it whole. */
static void vblocks_nomem(void)
{
  enum { N = 120 };
  double x[2 * N], v[2 * N], w[N], r[N];
  unsigned char mask[N];
  rng g = {4242};
  long fail, nfail = 0, nok = 0;
  int i;
  for (fail = 1; fail < 400; fail++) {
    mo_ctx ctx;
    mo_vblocks *V = NULL;
    mo_broad *B = NULL;
    int step, st = MO_OK, bad = 0;
    random_set(&g, 2, N, 0.12, x, r);
    for (i = 0; i < N; i++) {
      r[i] *= 0.005;
      v[2 * i] = 0;
      v[2 * i + 1] = x[2 * i] > 0.06 ? -1 : 0; /* half the balls falling through the others */
      w[i] = 0;
      mask[i] = 1;
    }
    mo_ctx_init(&ctx);
    ctx.alloc_fail_at = fail;
    if (mo_vblocks_create(&V, &ctx) || mo_broad_create(&B, &ctx)) st = MO_ENOMEM;
    for (step = 0; !st && step < 20; step++) {
      mo_vblocks_in in = {2, N, mask, x, v, w, r, 1e-3 * step, 1e-3, 4e-4, 2e-3};
      const int *p;
      long np = -1;
      int built;
      st = mo_vblocks_update(V, &in, B, &p, &np, &built, &ctx);
      if (st) bad |= !(st == MO_ENOMEM && np == 0);
      for (i = 0; i < N; i++) x[2 * i + 1] += 1e-3 * v[2 * i + 1];
    }
    nfail += st == MO_ENOMEM && !bad;
    nok += st == MO_OK;
    mo_vblocks_free(V);
    mo_broad_free(B);
    if (st == MO_OK && ctx.alloc_calls < fail) break;
  }
  ok(nok == 1 && nfail == fail - 1, "vblocks: each of %ld allocations over 20 steps failing gives MO_ENOMEM and an "
     "empty list", fail - 1);
}

/* A non-finite coordinate after some steps: MO_EINPUT naming the body, an empty list. */
static void vblocks_nan(void)
{
  enum { N = 200 };
  double x[2 * N], v[2 * N] = {0}, w[N] = {0}, r[N];
  rng g = {777};
  mo_ctx ctx;
  mo_vblocks *V;
  mo_broad *B;
  const int *p;
  long np = 0;
  int built, step, st = 0, i;
  random_set(&g, 2, N, 0.2, x, r);
  for (i = 0; i < N; i++) r[i] *= 0.005;
  mo_ctx_init(&ctx);
  mo_vblocks_create(&V, &ctx);
  mo_broad_create(&B, &ctx);
  for (step = 0; step < 5 && !st; step++) {
    mo_vblocks_in in = {2, N, NULL, x, v, w, r, 1e-3 * step, 1e-3, 4e-4, 2e-3};
    if (step == 4) x[2 * 17 + 1] = NAN;
    st = mo_vblocks_update(V, &in, B, &p, &np, &built, &ctx);
  }
  ok(st == MO_EINPUT && step == 5 && np == 0 && strstr(ctx.errmsg, "body 17"),
     "vblocks: a non-finite coordinate is an input error naming the body (%s)", ctx.errmsg);
  mo_vblocks_free(V);
  mo_broad_free(B);
}

static void test_vblocks(void)
{
  vblocks_nan();
  vblocks_nomem();
  vblocks_column(2, 800, 250, 0);
  vblocks_column(2, 600, 150, 1);
  vblocks_column(3, 500, 200, 0);
  mo_vblocks_free(NULL);
}

/* Every allocation failing in turn: MO_ENOMEM, no crash, no leak (valgrind, ASan). */
static void test_broad_nomem(void)
{
  enum { N = 300 };
  double c[2 * N], r[N];
  rng g = {12345};
  const int *p;
  long np, fail, calls;
  int st = MO_ENOMEM, nfail = 0;
  mo_ctx ctx;
  mo_broad *B;
  random_set(&g, 2, N, 20, c, r);
  for (fail = 1; st == MO_ENOMEM && fail < 100; fail++) {
    mo_ctx_init(&ctx);
    ctx.alloc_fail_at = fail;
    np = 0;
    st = mo_broad_create(&B, &ctx);
    if (!st) st = mo_broad_pairs(B, 2, N, c, r, NULL, 0.5, &p, &np, &ctx);
    calls = ctx.alloc_calls;
    if (st == MO_ENOMEM) nfail += np == 0 && ctx.status == MO_ENOMEM;
    mo_broad_free(B);
    B = NULL;
  }
  ok(st == MO_OK && nfail == fail - 2, "broad: each of the %ld allocations failing gives MO_ENOMEM", calls);
}

int main(void)
{
  test_plane_ball();
  test_ball_ball();
  test_polygon_ball();
  test_plane_polygon();
  test_polygon_rest();
  test_polygon_vertex();
  test_polygon_clip();
  test_polygon_parallel();
  test_polygon_random();
  test_polygon_utils();
  test_polygon_check();
  test_broad_random();
  test_broad_small();
  test_broad_nomem();
  test_vblocks();
  return done_testing();
}
