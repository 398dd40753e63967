/* narrow.c: narrow phases of contact detection: plane, ball and convex polygon pairs (doc/theory.md §12.3). */
#include "config.h"
#include "narrow.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>

/* A's reference edge is kept unless B's separates by more than this fraction of the shorter of
   the two edges: near ties (a block resting flat on a block) then keep their reference from one
   step to the next, and with it the (fa, fb) pairs the caller matches. */
static const double ref_bias = 1e-3;

/* Clipped points closer than this fraction of the reference edge are one contact (corner on
   corner, the end of a block sliding off another), not two making a singular pair. */
static const double merge_tol = 1e-9;

/* |d| for a vector of dimension dim, without overflow or underflow on the way. */
static inline double norm(int dim, const double *d)
{
  double s = d[0] * d[0] + d[1] * d[1] + (dim == 3 ? d[2] * d[2] : 0);
  /* the plain sum when it neither overflowed nor lost its digits to underflow */
  if (s < 1e300 && s > 1e-290) return sqrt(s);
  return dim == 3 ? hypot(hypot(d[0], d[1]), d[2]) : hypot(d[0], d[1]);
}

/* Write one contact; components beyond dim are 0. */
static void put(mo_narrow *o, int dim, const double *x, const double *n, double g, int fa, int fb)
{
  int k;
  for (k = 0; k < 3; k++) {
    o->x[k] = k < dim ? x[k] : 0.0;
    o->n[k] = k < dim ? n[k] : 0.0;
  }
  o->g = g;
  o->fa = fa;
  o->fb = fb;
}

/* Edge k of a counter-clockwise polygon: unit tangent t (may be NULL) and outward unit normal n
   = t turned clockwise. Returns the edge length, 0 for a degenerate edge (then t = n = 0). */
static double edge_frame(int nv, const double *v, int k, double *t, double *n)
{
  int j = (k + 1) % nv;
  double e[2], len;
  e[0] = v[2 * j] - v[2 * k];
  e[1] = v[2 * j + 1] - v[2 * k + 1];
  len = norm(2, e);
  if (len > 0) { /* a division, not a product by 1 / len: edges along the axes give exact normals */
    e[0] /= len;
    e[1] /= len;
  } else {
    e[0] = e[1] = len = 0;
  }
  n[0] = e[1];
  n[1] = 0.0 - e[0]; /* not -e[0]: no -0 components */
  if (t) {
    t[0] = e[0];
    t[1] = e[1];
  }
  return len;
}

int mo_narrow_plane_ball(int dim, const double *p, const double *n, const double *c, double r, double alert,
                         mo_narrow *out)
{
  double d = 0, x[3];
  int k;
  for (k = 0; k < dim; k++) d += (c[k] - p[k]) * n[k]; /* height of the centre above the plane */
  if (!(d - r <= alert)) return 0;
  /* midway between the plane's point c - d n and the ball's point c - r n */
  for (k = 0; k < dim; k++) x[k] = c[k] - 0.5 * (d + r) * n[k];
  put(out, dim, x, n, d - r, -1, -1);
  return 1;
}

/* The ball pair's narrow phase with dim a constant of each call site (2 or 3): inlined there, its
   loops unroll; the same operations in the same order as for any dim (T295). */
static inline __attribute__((always_inline)) int ball_ball(const int dim, const double *ca, double ra,
                                                           const double *cb, double rb, double alert,
                                                           mo_narrow *out)
{
  double d[3] = {0, 0, 0}, n[3] = {0, 0, 0}, x[3] = {0, 0, 0}, L, g; /* x: put reads its first dim entries */
  int k;
  for (k = 0; k < dim; k++) d[k] = cb[k] - ca[k];
  L = norm(dim, d);
  g = L - ra - rb;
  if (!(g <= alert)) return 0;
  if (L > 0) {
    for (k = 0; k < dim; k++) n[k] = d[k] / L;
  } else {
    n[1] = 1; /* coincident centres: any direction is as good, take one the caller can predict */
  }
  /* midway between A's surface point ca + ra n and B's ca + (L - rb) n */
  for (k = 0; k < dim; k++) x[k] = ca[k] + (ra + 0.5 * g) * n[k];
  put(out, dim, x, n, g, -1, -1);
  return 1;
}

int mo_narrow_ball_ball(int dim, const double *ca, double ra, const double *cb, double rb, double alert,
                        mo_narrow *out)
{
  if (dim == 2) return ball_ball(2, ca, ra, cb, rb, alert, out);
  if (dim == 3) return ball_ball(3, ca, ra, cb, rb, alert, out);
  return ball_ball(dim, ca, ra, cb, rb, alert, out);
}

/* The closest feature of a convex polygon to a point c outside it (largest edge distance smax >
   0 at edge kmax with normal n): an edge whose Voronoi slab holds c (distance = its distance to
   the line), else the nearest vertex. Writes the feature code in *f, the unit normal from the
   feature toward c in n, and returns the distance. */
static double closest_outside(int nv, const double *v, const double *c, double smax, int kmax, double *n,
                              int *f)
{
  double t[2], m[2], d[2], s, u, len, best = HUGE_VAL;
  int k, kv = -1;
  for (k = 0; k < nv; k++) {
    if (!(len = edge_frame(nv, v, k, t, m))) continue;
    d[0] = c[0] - v[2 * k];
    d[1] = c[1] - v[2 * k + 1];
    s = d[0] * m[0] + d[1] * m[1];
    u = d[0] * t[0] + d[1] * t[1];
    if (s > 0 && u >= 0 && u <= len) { /* the polygon lies behind this edge's line: distance s */
      n[0] = m[0];
      n[1] = m[1];
      *f = MO_NARROW_EDGE(nv, k);
      return s;
    }
    s = norm(2, d);
    if (s < best) {
      best = s;
      kv = k;
    }
  }
  if (kv >= 0 && best > 0) {
    n[0] = (c[0] - v[2 * kv]) / best;
    n[1] = (c[1] - v[2 * kv + 1]) / best;
    *f = kv;
    return best;
  }
  /* c on a vertex up to rounding: the edge that saw it outside gives a defined normal */
  *f = MO_NARROW_EDGE(nv, kmax);
  return smax;
}

int mo_narrow_polygon_ball(int nv, const double *v, const double *c, double r, double alert, mo_narrow *out)
{
  double smax = -HUGE_VAL, nmax[2] = {0, 0}, m[2], s, dist, x[2];
  int k, kmax = -1, f;
  if (nv < 3) return 0;
  /* signed distances of c to the edge lines: the largest is the least penetration inside, and
     a lower bound of the distance outside */
  for (k = 0; k < nv; k++) {
    if (!edge_frame(nv, v, k, NULL, m)) continue;
    s = (c[0] - v[2 * k]) * m[0] + (c[1] - v[2 * k + 1]) * m[1];
    if (s > smax) {
      smax = s;
      kmax = k;
      nmax[0] = m[0];
      nmax[1] = m[1];
    }
  }
  if (kmax < 0 || !(smax - r <= alert)) return 0;
  if (smax > 0) {
    dist = closest_outside(nv, v, c, smax, kmax, nmax, &f);
  } else {
    dist = smax; /* inside or on the boundary: out through the edge of least penetration */
    f = MO_NARROW_EDGE(nv, kmax);
  }
  if (!(dist - r <= alert)) return 0;
  /* midway between the polygon's point c - dist n and the disk's point c - r n */
  x[0] = c[0] - 0.5 * (dist + r) * nmax[0];
  x[1] = c[1] - 0.5 * (dist + r) * nmax[1];
  put(out, 2, x, nmax, dist - r, f, -1);
  return 1;
}

int mo_narrow_plane_polygon(const double *p, const double *n, int nv, const double *v, double alert,
                            mo_narrow *out)
{
  double d, x[2];
  int k, m = 0;
  for (k = 0; k < nv; k++) {
    d = (v[2 * k] - p[0]) * n[0] + (v[2 * k + 1] - p[1]) * n[1];
    if (!(d <= alert)) continue;
    x[0] = v[2 * k] - 0.5 * d * n[0]; /* midway between the vertex and its projection */
    x[1] = v[2 * k + 1] - 0.5 * d * n[1];
    put(&out[m++], 2, x, n, d, -1, k);
  }
  return m;
}

/* Separating axes of P's edges against Q: max over P's edges k of min over Q's vertices w of
   (w - p_k) . n_k, the largest separation (or least penetration) along P's edge normals, in *s.
   Returns the edge reaching it (-1 when P has no proper edge). */
static int max_separation(int np, const double *vp, int nq, const double *vq, double *s)
{
  double n[2], d, dmin;
  int k, j, best = -1;
  *s = -HUGE_VAL;
  for (k = 0; k < np; k++) {
    if (!edge_frame(np, vp, k, NULL, n)) continue;
    dmin = HUGE_VAL;
    for (j = 0; j < nq; j++) {
      d = (vq[2 * j] - vp[2 * k]) * n[0] + (vq[2 * j + 1] - vp[2 * k + 1]) * n[1];
      if (d < dmin) dmin = d;
    }
    if (dmin > *s) {
      *s = dmin;
      best = k;
    }
  }
  return best;
}

/* The edge of a polygon whose outward normal is most opposed to n (lowest index on ties). */
static int incident_edge(int nv, const double *v, const double *n)
{
  double m[2], d, dmin = HUGE_VAL;
  int k, best = 0;
  for (k = 0; k < nv; k++) {
    if (!edge_frame(nv, v, k, NULL, m)) continue;
    d = m[0] * n[0] + m[1] * n[1];
    if (d < dmin) {
      dmin = d;
      best = k;
    }
  }
  return best;
}

/* Keep the part of segment p[0]p[1] (parameters u[] along the reference tangent) where side (u -
   u0) >= 0. A moved end becomes the point where the segment crosses u = u0 and its features the
   reference vertex fv and the incident edge fe. Returns 0 when nothing is left. */
static int clip_side(double p[2][2], double u[2], int fr[2], int fi[2], double u0, double side, int fv,
                     int fe, double eps)
{
  double d0 = side * (u[0] - u0), d1 = side * (u[1] - u0), l, q[2];
  int k;
  /* a vertex outside by round-off only is on the side line: kept with its own feature, so that
     flush joints of equal faces (the arch's voussoirs) keep their keys from step to step */
  if (d0 < 0 && d0 > -eps) d0 = 0;
  if (d1 < 0 && d1 > -eps) d1 = 0;
  if (d0 < 0 && d1 < 0) return 0;
  if (!(d0 < 0 || d1 < 0)) return 1;
  k = d0 < 0 ? 0 : 1;
  l = d0 / (d0 - d1); /* d0 and d1 of opposite signs: no division by 0 */
  q[0] = p[0][0] + l * (p[1][0] - p[0][0]);
  q[1] = p[0][1] + l * (p[1][1] - p[0][1]);
  p[k][0] = q[0];
  p[k][1] = q[1];
  u[k] = u0;
  fr[k] = fv;
  fi[k] = fe;
  return 1;
}

/* Contacts of the incident edge of polygon I against reference edge er of polygon R: clip to the
   side lines of the reference edge, keep the points within alert of its line. flip: R is the
   slave (B), so the normal is turned to go from A to B and the features swapped. */
static int clip_incident(int nr, const double *vr, int er, int ni, const double *vi, double alert, int flip,
                         mo_narrow *out)
{
  double t[2], n[2], nab[2], p[2][2], u[2], len, sep, x[2];
  int k, ei, m = 0, one, fr[2], fi[2], r2 = (er + 1) % nr;
  len = edge_frame(nr, vr, er, t, n);
  ei = incident_edge(ni, vi, n);
  for (k = 0; k < 2; k++) {
    int j = (ei + k) % ni;
    p[k][0] = vi[2 * j];
    p[k][1] = vi[2 * j + 1];
    u[k] = (p[k][0] - vr[2 * er]) * t[0] + (p[k][1] - vr[2 * er + 1]) * t[1];
    fr[k] = MO_NARROW_EDGE(nr, er);
    fi[k] = j;
  }
  if (!clip_side(p, u, fr, fi, 0.0, 1.0, er, MO_NARROW_EDGE(ni, ei), merge_tol * len)) return 0;
  if (!clip_side(p, u, fr, fi, len, -1.0, r2, MO_NARROW_EDGE(ni, ei), merge_tol * len)) return 0;
  one = hypot(p[1][0] - p[0][0], p[1][1] - p[0][1]) <= merge_tol * len;
  if (one && fr[0] != MO_NARROW_EDGE(nr, er)) { /* one point left: keep an end of the incident edge */
    p[0][0] = p[1][0];
    p[0][1] = p[1][1];
    fr[0] = fr[1];
    fi[0] = fi[1];
  }
  /* 0.0 - n rather than -n: a flipped (0, 1) reads (0, -1), not (-0, -1) */
  nab[0] = flip ? 0.0 - n[0] : n[0];
  nab[1] = flip ? 0.0 - n[1] : n[1];
  for (k = 0; k < 2 - one; k++) {
    sep = (p[k][0] - vr[2 * er]) * n[0] + (p[k][1] - vr[2 * er + 1]) * n[1];
    if (!(sep <= alert)) continue;
    x[0] = p[k][0] - 0.5 * sep * n[0]; /* midway between the point and the reference line */
    x[1] = p[k][1] - 0.5 * sep * n[1];
    put(&out[m++], 2, x, nab, sep, flip ? fi[k] : fr[k], flip ? fr[k] : fi[k]);
  }
  return m;
}

/* Corner facing corner, where no clipped point is within alert: the closest vertex-to-polygon
   pair of either polygon, exact for disjoint polygons. At most 1 contact. */
static int closest_vertex_pair(int na, const double *va, int nb, const double *vb, double alert,
                               mo_narrow *out)
{
  mo_narrow c;
  int k, m = 0;
  for (k = 0; k < na; k++) /* vertex k of A against B: the narrow phase runs B to A, turn it */
    if (mo_narrow_polygon_ball(nb, vb, va + 2 * k, 0.0, alert, &c) && (!m || c.g < out->g)) {
      c.n[0] = 0.0 - c.n[0];
      c.n[1] = 0.0 - c.n[1];
      c.fb = c.fa;
      c.fa = k;
      *out = c;
      m = 1;
    }
  for (k = 0; k < nb; k++)
    if (mo_narrow_polygon_ball(na, va, vb + 2 * k, 0.0, alert, &c) && (!m || c.g < out->g)) {
      c.fb = k;
      *out = c;
      m = 1;
    }
  return m;
}

int mo_narrow_polygon_polygon(int na, const double *va, int nb, const double *vb, double alert,
                              mo_narrow out[2])
{
  double sa, sb, n[2], tol;
  int ea, eb, m;
  if (na < 3 || nb < 3) return 0;
  ea = max_separation(na, va, nb, vb, &sa);
  eb = max_separation(nb, vb, na, va, &sb);
  if (ea < 0 || eb < 0) return 0;
  if (!(sa <= alert && sb <= alert)) return 0; /* an axis separates them by more than alert */
  tol = ref_bias * fmin(edge_frame(na, va, ea, NULL, n), edge_frame(nb, vb, eb, NULL, n));
  if (sb > sa + tol)
    m = clip_incident(nb, vb, eb, na, va, alert, 1, out);
  else
    m = clip_incident(na, va, ea, nb, vb, alert, 0, out);
  if (!m) m = closest_vertex_pair(na, va, nb, vb, alert, out);
  return m;
}

double mo_polygon_area(int nv, const double *v)
{
  double a = 0;
  int k;
  /* fan of triangles from vertex 0, coordinates relative to it against cancellation */
  for (k = 1; k + 1 < nv; k++)
    a += (v[2 * k] - v[0]) * (v[2 * k + 3] - v[1]) - (v[2 * k + 1] - v[1]) * (v[2 * k + 2] - v[0]);
  return 0.5 * a;
}

void mo_polygon_centroid(int nv, const double *v, double *c)
{
  double a = 0, sx = 0, sy = 0, ak, p[2], q[2];
  int k;
  /* fan from vertex 0: the area-weighted centroids (v0 + vk + vk+1) / 3 of its triangles */
  for (k = 1; k + 1 < nv; k++) {
    p[0] = v[2 * k] - v[0];
    p[1] = v[2 * k + 1] - v[1];
    q[0] = v[2 * k + 2] - v[0];
    q[1] = v[2 * k + 3] - v[1];
    ak = p[0] * q[1] - p[1] * q[0];
    a += ak;
    sx += ak * (p[0] + q[0]);
    sy += ak * (p[1] + q[1]);
  }
  if (a != 0) {
    c[0] = v[0] + sx / (3 * a);
    c[1] = v[1] + sy / (3 * a);
    return;
  }
  c[0] = c[1] = 0; /* no area: the vertices' mean is still a point of the figure */
  for (k = 0; k < nv; k++) {
    c[0] += v[2 * k] / nv;
    c[1] += v[2 * k + 1] / nv;
  }
}

double mo_polygon_inertia(int nv, const double *v, const double *c)
{
  double J = 0, p[2], q[2];
  int k, j;
  /* fan from c: a triangle (c, p, q) has integral of |x - c|^2 = (p x q)(p.p + p.q + q.q) / 12 */
  for (k = 0; k < nv; k++) {
    j = (k + 1) % nv;
    p[0] = v[2 * k] - c[0];
    p[1] = v[2 * k + 1] - c[1];
    q[0] = v[2 * j] - c[0];
    q[1] = v[2 * j + 1] - c[1];
    J += (p[0] * q[1] - p[1] * q[0]) * (p[0] * p[0] + p[1] * p[1] + p[0] * q[0] + p[1] * q[1] + q[0] * q[0] +
                                         q[1] * q[1]);
  }
  return J / 12;
}

static int check_fail(char *why, size_t n, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static int check_fail(char *why, size_t n, const char *fmt, ...)
{
  va_list ap;
  if (why && n) {
    va_start(ap, fmt);
    vsnprintf(why, n, fmt, ap);
    va_end(ap);
  }
  return 1;
}

/* Largest side of the bounding box: the length scale of mo_polygon_check's tolerance. */
static double polygon_size(int nv, const double *v)
{
  double lo[2] = {v[0], v[1]}, hi[2] = {v[0], v[1]};
  int k, i;
  for (k = 1; k < nv; k++)
    for (i = 0; i < 2; i++) {
      lo[i] = fmin(lo[i], v[2 * k + i]);
      hi[i] = fmax(hi[i], v[2 * k + i]);
    }
  return fmax(hi[0] - lo[0], hi[1] - lo[1]);
}

/* Convexity at each vertex, then the total turning: a convex polygon turns once (2 pi); a star
   whose every turn is left turns twice or more. */
static int check_turns(int nv, const double *v, double eps2, char *why, size_t n)
{
  const double pi = 3.14159265358979323846;
  double a[2], b[2], cr, dot, turn = 0;
  int k, i, j;
  for (k = 0; k < nv; k++) {
    i = (k + nv - 1) % nv;
    j = (k + 1) % nv;
    a[0] = v[2 * k] - v[2 * i];
    a[1] = v[2 * k + 1] - v[2 * i + 1];
    b[0] = v[2 * j] - v[2 * k];
    b[1] = v[2 * j + 1] - v[2 * k + 1];
    cr = a[0] * b[1] - a[1] * b[0];
    dot = a[0] * b[0] + a[1] * b[1];
    if (cr < -eps2 || (cr <= eps2 && dot < 0)) /* a right turn, or a spike going back */
      return check_fail(why, n, "not convex at vertex %d", k);
    turn += atan2(cr, dot);
  }
  if (turn > 3 * pi) return check_fail(why, n, "not simple (turns more than once)");
  return 0;
}

int mo_polygon_check(int nv, const double *v, double tol, char *why, size_t n)
{
  double L, a, d[2];
  int k, j;
  if (why && n) why[0] = '\0';
  if (nv < 3) return check_fail(why, n, "fewer than 3 vertices");
  for (k = 0; k < nv; k++)
    if (!isfinite(v[2 * k]) || !isfinite(v[2 * k + 1])) return check_fail(why, n, "non-finite vertex %d", k);
  L = polygon_size(nv, v);
  for (k = 0; k < nv; k++) {
    j = (k + 1) % nv;
    d[0] = v[2 * j] - v[2 * k];
    d[1] = v[2 * j + 1] - v[2 * k + 1];
    if (norm(2, d) <= tol * L) return check_fail(why, n, "repeated vertex %d", j > k ? j : k);
  }
  a = mo_polygon_area(nv, v);
  if (fabs(a) <= tol * L * L) return check_fail(why, n, "degenerate (zero area)");
  if (a < 0) return check_fail(why, n, "clockwise");
  return check_turns(nv, v, tol * L * L, why, n);
}
