/* contact_mortar.c: segmented integration of Gauss collocation on non-matching meshes (mortar
   segmentation, doc/theory.md §4.7, (T90)-(T92)). A slave facet is cut by the master facets
   that face it: in 2D its segment is cut at the projections of the master nodes, in 3D the
   slave facet and each master facet are projected on the slave facet's plane and the first is
   clipped by the second (Sutherland-Hodgman; the master polygon is convex). Gauss points are
   placed on every part, so that the integrals of the contact terms, products of slave and master
   shape functions that are smooth on each part only, are exact wherever the rule is. */
#include "config.h"
#include <moreau/contact.h>
#include "contact_internal.h"

#include <gsl/gsl_integration.h>
#include <math.h>
#include <string.h>

#define MAXV 16 /* vertices of a clipped polygon: 4 + one per clipping edge, with room */

typedef struct {
  int m;             /* master facet */
  double dn;         /* distance of its centre from the slave facet's plane, along n_s */
  double lo, hi;     /* 2D: its part of the slave segment, s in [0, 1] */
  int nv;            /* 3D: the part of the slave facet it covers, in the plane's coordinates */
  double z[MAXV][2];
} piece;

static double dot3(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

/* Twice the signed area of polygon z (n vertices). */
static double area2(int n, double z[][2])
{
  double s = 0;
  int k;
  for (k = 0; k < n; k++) {
    int l = (k + 1) % n;
    s += z[k][0] * z[l][1] - z[l][0] * z[k][1];
  }
  return s;
}

/* The part of convex polygon S (counter-clockwise) inside convex polygon M (counter-clockwise):
   Sutherland-Hodgman, one edge of M at a time. */
static int clip(int ns, double S[][2], int nm, double M[][2], double out[][2])
{
  double a[MAXV][2], b[MAXV][2];
  int n = ns, e, k;
  memcpy(a, S, (size_t)ns * sizeof a[0]);
  for (e = 0; e < nm && n > 0; e++) {
    const double *p = M[e], *q = M[(e + 1) % nm];
    double ex = q[0] - p[0], ey = q[1] - p[1];
    int nb = 0;
    for (k = 0; k < n; k++) {
      const double *c = a[k], *d = a[(k + 1) % n];
      double sc = ex * (c[1] - p[1]) - ey * (c[0] - p[0]), sd = ex * (d[1] - p[1]) - ey * (d[0] - p[0]);
      if (sc >= 0 && nb < MAXV) { b[nb][0] = c[0]; b[nb][1] = c[1]; nb++; }
      if (((sc >= 0) != (sd >= 0)) && nb < MAXV) {
        double t = sc / (sc - sd);
        b[nb][0] = c[0] + t * (d[0] - c[0]);
        b[nb][1] = c[1] + t * (d[1] - c[1]);
        nb++;
      }
    }
    memcpy(a, b, (size_t)nb * sizeof a[0]);
    n = nb;
  }
  /* drop vertices that repeat their predecessor or lie on the line of their neighbours (the
     clipped parts of matching edges): they would make triangles of zero area */
  for (;;) {
    int removed = 0;
    double size = 0;
    for (k = 0; k < n; k++) size = fmax(size, fabs(a[k][0]) + fabs(a[k][1]));
    for (k = 0; k < n && n > 2; k++) {
      const double *pr = a[(k + n - 1) % n], *c = a[k], *nx = a[(k + 1) % n];
      double cr = (c[0] - pr[0]) * (nx[1] - c[1]) - (c[1] - pr[1]) * (nx[0] - c[0]);
      double l1 = hypot(c[0] - pr[0], c[1] - pr[1]), l2 = hypot(nx[0] - c[0], nx[1] - c[1]);
      if (l1 <= 1e-12 * size || fabs(cr) <= 1e-12 * l1 * l2) {
        memmove(a[k], a[k + 1], (size_t)(n - k - 1) * sizeof a[0]);
        n--;
        removed = 1;
        break;
      }
    }
    if (!removed) break;
  }
  if (n < 3) return 0;
  memcpy(out, a, (size_t)n * sizeof a[0]);
  return n;
}

/* Append a point of the slave facet (reference coordinates xi, weight w, master facet m). */
static int push(mo_segpt **pts, int *n, int *cap, const double *xi, double w, int m, mo_ctx *ctx)
{
  if (*n == *cap) {
    int c = *cap ? 2 * *cap : 64;
    mo_segpt *p = mo_realloc(ctx, *pts, (size_t)c * sizeof *p);
    if (!p) return MO_ENOMEM;
    *pts = p;
    *cap = c;
  }
  (*pts)[*n].xi[0] = xi[0];
  (*pts)[*n].xi[1] = xi[1];
  (*pts)[*n].w = w;
  (*pts)[*n].mfacet = m;
  (*n)++;
  return MO_OK;
}

/* Reference coordinates xi of the slave facet whose projection on the plane is z: the affine
   map of a triangle's projected corners zs, or Newton on the bilinear map of a quadrilateral's. */
static void invert_bilinear(int nvs, double zs[4][2], const double *z, double *xi)
{
  int it, a;
  if (nvs == 3) {
    double J00 = zs[1][0] - zs[0][0], J01 = zs[2][0] - zs[0][0], J10 = zs[1][1] - zs[0][1], J11 = zs[2][1] - zs[0][1];
    double r0 = z[0] - zs[0][0], r1 = z[1] - zs[0][1], det = J00 * J11 - J01 * J10;
    xi[0] = (J11 * r0 - J01 * r1) / det;
    xi[1] = (J00 * r1 - J10 * r0) / det;
    return;
  }
  xi[0] = xi[1] = 0;
  for (it = 0; it < 50; it++) {
    double N[4], dN[8], r0 = -z[0], r1 = -z[1], J00 = 0, J01 = 0, J10 = 0, J11 = 0, det, d0, d1;
    mo_facet_shape(4, xi, N, dN);
    for (a = 0; a < 4; a++) {
      r0 += N[a] * zs[a][0];
      r1 += N[a] * zs[a][1];
      J00 += dN[2 * a] * zs[a][0];
      J01 += dN[2 * a + 1] * zs[a][0];
      J10 += dN[2 * a] * zs[a][1];
      J11 += dN[2 * a + 1] * zs[a][1];
    }
    det = J00 * J11 - J01 * J10;
    if (det == 0) break;
    d0 = (J11 * r0 - J01 * r1) / det;
    d1 = (J00 * r1 - J10 * r0) / det;
    xi[0] -= d0;
    xi[1] -= d1;
    if (fabs(d0) + fabs(d1) < 1e-15) break;
  }
  for (a = 0; a < 2; a++) xi[a] = fmax(-1, fmin(1, xi[a]));
}

int mo_contact_segment_masters(const mo_scene *sc, int mb, const mo_facetset *mfs, const mo_state *u, double **mg,
                               mo_ctx *ctx)
{
  const int D = sc->dim, nfn = mfs->nfn;
  double xi0[2] = {0, 0}, N[MO_FNODE_MAX], x[3];
  int m, a, i;
  if (mfs->kind == MO_FK_TRI3 || mfs->kind == MO_FK_TRI6) xi0[0] = xi0[1] = 1.0 / 3;
  *mg = mo_malloc(ctx, (size_t)(mfs->n ? mfs->n : 1) * 7 * sizeof **mg);
  if (!*mg) return MO_ENOMEM;
  for (m = 0; m < mfs->n; m++) {
    double *g = *mg + 7 * m, Y[MO_FNODE_MAX][3], r = 0;
    memset(g, 0, 7 * sizeof *g);
    for (a = 0; a < nfn; a++) {
      mo_contact_node_pos(sc, mb, mfs->node[m * nfn + a], u, Y[a]);
      if (D == 2) Y[a][2] = 0;
      for (i = 0; i < 3; i++) g[i] += Y[a][i] / nfn;
    }
    mo_contact_facet_eval(sc, mb, mfs, m, xi0, u, N, x, g + 3);
    if (D == 2) g[5] = 0;
    for (a = 0; a < nfn; a++)
      r = fmax(r, sqrt((Y[a][0] - g[0]) * (Y[a][0] - g[0]) + (Y[a][1] - g[1]) * (Y[a][1] - g[1]) +
                       (Y[a][2] - g[2]) * (Y[a][2] - g[2])));
    g[6] = r;
  }
  return MO_OK;
}

int mo_contact_segment_facet(const mo_scene *sc, int sb, const mo_facetset *sfs, int f, int mb,
                             const mo_facetset *mfs, const double *mg, const mo_state *u, int gauss, mo_segpt **pts,
                             int *npts, int *cap, int *whole, mo_ctx *ctx)
{
  const int D = sc->dim, nfn = sfs->nfn;
  const int nvs = sfs->kind == MO_FK_TRI3 ? 3 : 4, nvm = mfs->kind == MO_FK_TRI3 ? 3 : 4;
  const mo_material *mat = sc->body[sb].mat;
  double X[4][3], c[3] = {0, 0, 0}, ns[3] = {0, 0, 0}, e1[3] = {0, 0, 0}, e2[3] = {0, 0, 0}, zs[4][2];
  double N[MO_FNODE_MAX], x[3], xi0[2] = {0, 0}, diam = 0, reach, As, covered = 0, dmin = HUGE_VAL;
  piece *pc = NULL;
  int npc = 0, a, i, m, k, q, st = MO_OK, n0 = *npts;
  gsl_integration_glfixed_table *T1 = NULL, *T2 = NULL;
  *whole = 0;
  if (sfs->kind != MO_FK_LINE2 && sfs->kind != MO_FK_TRI3 && sfs->kind != MO_FK_QUAD4) return MO_OK;
  if (mfs->kind != MO_FK_LINE2 && mfs->kind != MO_FK_TRI3 && mfs->kind != MO_FK_QUAD4) {
    *whole = 1; /* a quadratic master: its facets are curved (T195) */
    return MO_OK;
  }
  if (nvs == 3) xi0[0] = xi0[1] = 1.0 / 3;
  /* the slave facet: its vertices, centre, normal at the centre and a basis of its plane */
  for (a = 0; a < nfn; a++) {
    mo_contact_node_pos(sc, sb, sfs->node[f * nfn + a], u, X[a]);
    if (D == 2) X[a][2] = 0;
    for (i = 0; i < 3; i++) c[i] += X[a][i] / nfn;
  }
  mo_contact_facet_eval(sc, sb, sfs, f, xi0, u, N, x, ns);
  if (D == 2) {
    ns[2] = 0;
    for (i = 0; i < 2; i++) e1[i] = X[1][i] - X[0][i];
    As = sqrt(dot3(e1, e1)); /* its length: s = (y - X0).e1 / |e1|^2 in [0, 1] */
    diam = As;
  } else {
    double l;
    for (i = 0; i < 3; i++) e1[i] = X[1][i] - X[0][i];
    l = dot3(e1, ns);
    for (i = 0; i < 3; i++) e1[i] -= l * ns[i];
    l = sqrt(dot3(e1, e1));
    for (i = 0; i < 3; i++) e1[i] /= l;
    e2[0] = ns[1] * e1[2] - ns[2] * e1[1];
    e2[1] = ns[2] * e1[0] - ns[0] * e1[2];
    e2[2] = ns[0] * e1[1] - ns[1] * e1[0];
    for (a = 0; a < nvs; a++) {
      double r[3] = {X[a][0] - c[0], X[a][1] - c[1], X[a][2] - c[2]};
      zs[a][0] = dot3(r, e1);
      zs[a][1] = dot3(r, e2);
      diam = fmax(diam, 2 * hypot(zs[a][0], zs[a][1]));
    }
    As = 0.5 * area2(nvs, zs);
    for (a = 0; a < nvs; a++) { /* a convex polygon, counter-clockwise seen from n_s */
      double cr = (zs[(a + 1) % nvs][0] - zs[a][0]) * (zs[(a + 2) % nvs][1] - zs[(a + 1) % nvs][1]) -
                  (zs[(a + 1) % nvs][1] - zs[a][1]) * (zs[(a + 2) % nvs][0] - zs[(a + 1) % nvs][0]);
      if (!(cr > 0) || !(As > 0)) { *whole = 1; return MO_OK; }
    }
  }
  reach = diam;
  pc = mo_malloc(ctx, (size_t)(2 * mfs->n + 1) * sizeof *pc); /* the parts, and in 2D the gaps between */
  if (!pc) return MO_ENOMEM;
  /* the master facets facing it whose projections overlap it */
  for (m = 0; m < mfs->n; m++) {
    const double *cm = mg + 7 * m, *nm = mg + 7 * m + 3;
    double Y[MO_FNODE_MAX][3], dm = 0, r[3], lat;
    piece *P = &pc[npc];
    if (!(dot3(nm, ns) < -0.5)) continue; /* not facing the slave facet */
    P->m = m;
    for (i = 0; i < 3; i++) r[i] = cm[i] - c[i];
    P->dn = dot3(r, ns);
    for (i = 0; i < 3; i++) r[i] -= P->dn * ns[i];
    lat = sqrt(dot3(r, r));
    if (lat > 0.5 * diam + mg[7 * m + 6] + 1e-9 * diam) continue; /* its projection is away from the facet */
    for (a = 0; a < mfs->nfn; a++) {
      mo_contact_node_pos(sc, mb, mfs->node[m * mfs->nfn + a], u, Y[a]);
      if (D == 2) Y[a][2] = 0;
    }
    if (D == 2) {
      double s[2];
      for (a = 0; a < 2; a++) {
        double y[3] = {Y[a][0] - X[0][0], Y[a][1] - X[0][1], 0};
        s[a] = dot3(y, e1) / (As * As);
      }
      P->lo = fmax(0, fmin(s[0], s[1]));
      P->hi = fmin(1, fmax(s[0], s[1]));
      dm = fabs(s[1] - s[0]) * As;
      if (!(P->hi - P->lo > 1e-10)) continue;
    } else {
      double zm[4][2], A;
      dm = 2 * mg[7 * m + 6];
      for (a = 0; a < nvm; a++) {
        double y[3] = {Y[a][0] - c[0], Y[a][1] - c[1], Y[a][2] - c[2]};
        zm[a][0] = dot3(y, e1);
        zm[a][1] = dot3(y, e2);
      }
      if (area2(nvm, zm) < 0) /* seen from the slave side, the master facet turns the other way */
        for (a = 0; a < nvm / 2; a++) {
          double t0 = zm[a][0], t1 = zm[a][1];
          zm[a][0] = zm[nvm - 1 - a][0]; zm[a][1] = zm[nvm - 1 - a][1];
          zm[nvm - 1 - a][0] = t0; zm[nvm - 1 - a][1] = t1;
        }
      {
        /* bounding boxes apart: no overlap (and then its shape does not matter) */
        double lo0 = HUGE_VAL, hi0 = -HUGE_VAL, lo1 = HUGE_VAL, hi1 = -HUGE_VAL, sl0 = HUGE_VAL, sh0 = -HUGE_VAL,
               sl1 = HUGE_VAL, sh1 = -HUGE_VAL;
        for (a = 0; a < nvm; a++) {
          lo0 = fmin(lo0, zm[a][0]); hi0 = fmax(hi0, zm[a][0]); lo1 = fmin(lo1, zm[a][1]); hi1 = fmax(hi1, zm[a][1]);
        }
        for (a = 0; a < nvs; a++) {
          sl0 = fmin(sl0, zs[a][0]); sh0 = fmax(sh0, zs[a][0]); sl1 = fmin(sl1, zs[a][1]); sh1 = fmax(sh1, zs[a][1]);
        }
        if (hi0 <= sl0 || lo0 >= sh0 || hi1 <= sl1 || lo1 >= sh1) continue;
      }
      for (a = 0; a < nvm; a++) { /* Sutherland-Hodgman needs a convex clipping polygon */
        double cr = (zm[(a + 1) % nvm][0] - zm[a][0]) * (zm[(a + 2) % nvm][1] - zm[(a + 1) % nvm][1]) -
                    (zm[(a + 1) % nvm][1] - zm[a][1]) * (zm[(a + 2) % nvm][0] - zm[(a + 1) % nvm][0]);
        if (!(cr > 0)) goto not_covered;
      }
      P->nv = clip(nvs, zs, nvm, zm, P->z);
      if (P->nv < 3) continue;
      A = 0.5 * area2(P->nv, P->z);
      if (!(A > 1e-10 * As)) continue;
    }
    if (dm > reach) reach = dm;
    if (fabs(P->dn) < dmin) dmin = fabs(P->dn);
    npc++;
  }
  /* the nearest layer of them (a master set around a thin body has a second layer behind) */
  for (k = 0, i = 0; k < npc; k++)
    if (fabs(pc[k].dn) <= dmin + reach) pc[i++] = pc[k];
  npc = i;
  if (npc == 0) goto done; /* no master in front of it: the points of the whole facet, searched */
  if (D == 2) {
    /* segments in order along the facet; one covered twice is a master of several layers; the
       parts no master facet covers (past the master's edge) are segments of their own, whose
       points pair with the nearest master facet as any point does (contact.pairs.[].off_master) */
    mo_quad Q;
    int ng;
    for (k = 1; k < npc; k++) {
      piece t = pc[k];
      for (i = k; i > 0 && pc[i - 1].lo > t.lo; i--) pc[i] = pc[i - 1];
      pc[i] = t;
    }
    for (k = 1; k < npc; k++)
      if (pc[k].lo < pc[k - 1].hi - 1e-10) goto not_covered;
    for (k = 0, ng = npc; k <= npc; k++) {
      double lo = k ? pc[k - 1].hi : 0, hi = k < npc ? pc[k].lo : 1;
      if (hi - lo > 1e-10) {
        piece *G = &pc[ng++];
        memset(G, 0, sizeof *G);
        G->m = -1;
        G->lo = lo;
        G->hi = hi;
      }
    }
    npc = ng;
    if ((st = mo_quad_facet(1, gauss, &Q, ctx))) goto done;
    for (k = 0; k < npc; k++) {
      double x0 = 2 * pc[k].lo - 1, x1 = 2 * pc[k].hi - 1;
      for (q = 0; q < Q.n; q++) {
        double xi[2] = {0.5 * (x0 + x1) + 0.5 * (x1 - x0) * Q.xi[q][0], 0}, jac;
        jac = mo_contact_facet_eval(sc, sb, sfs, f, xi, u, N, x, NULL);
        if ((st = push(pts, npts, cap, xi, Q.w[q] * 0.5 * (x1 - x0) * jac * mo_contact_facet_factor(mat, x),
                       pc[k].m, ctx)))
          goto done;
      }
    }
    goto done;
  }
  /* 3D: the parts must cover the facet exactly once, else it keeps the Gauss points of the whole
     facet (the rest of a facet past the master's edge is not a convex polygon) */
  for (k = 0; k < npc; k++) covered += 0.5 * area2(pc[k].nv, pc[k].z);
  if (fabs(covered / As - 1) > 1e-9) goto not_covered;
  /* a quadrilateral part takes the gauss x gauss rule of its bilinear map; any other polygon
     is cut into triangles, each with the collapsed (Duffy) product rule of gauss + 1 points per
     direction (exact to degree 2 gauss on the triangle) */
  T1 = gsl_integration_glfixed_table_alloc((size_t)gauss);
  T2 = gsl_integration_glfixed_table_alloc((size_t)gauss + 1);
  if (!T1 || !T2) { st = mo_error(ctx, MO_ENOMEM, "GSL could not build a Gauss rule"); goto done; }
  for (k = 0; k < npc; k++) {
    const piece *P = &pc[k];
    int t, j, l;
    if (P->nv == 4) {
      double zq[4][2];
      memcpy(zq, P->z, sizeof zq);
      for (j = 0; j < gauss; j++)
        for (l = 0; l < gauss; l++) {
          double g0, w0, g1, w1, s[2], Nq[4], dN[8], z[2] = {0, 0}, J00 = 0, J01 = 0, J10 = 0, J11 = 0;
          double xi[2], nq[3], wp;
          gsl_integration_glfixed_point(-1, 1, (size_t)j, &g0, &w0, T1);
          gsl_integration_glfixed_point(-1, 1, (size_t)l, &g1, &w1, T1);
          s[0] = g0;
          s[1] = g1;
          mo_facet_shape(4, s, Nq, dN);
          for (a = 0; a < 4; a++) {
            z[0] += Nq[a] * zq[a][0];
            z[1] += Nq[a] * zq[a][1];
            J00 += dN[2 * a] * zq[a][0];
            J01 += dN[2 * a + 1] * zq[a][0];
            J10 += dN[2 * a] * zq[a][1];
            J11 += dN[2 * a + 1] * zq[a][1];
          }
          wp = w0 * w1 * fabs(J00 * J11 - J01 * J10);
          invert_bilinear(nvs, zs, z, xi);
          mo_contact_facet_eval(sc, sb, sfs, f, xi, u, N, x, nq);
          if ((st = push(pts, npts, cap, xi, wp / fabs(dot3(nq, ns)) * mo_contact_facet_factor(mat, x), P->m, ctx)))
            goto done;
        }
      continue;
    }
    for (t = 1; t + 1 < P->nv; t++) {
      const double *A = P->z[0], *B = P->z[t], *Cc = P->z[t + 1];
      double at = 0.5 * ((B[0] - A[0]) * (Cc[1] - A[1]) - (B[1] - A[1]) * (Cc[0] - A[0]));
      if (!(at > 1e-12 * As)) continue;
      for (j = 0; j <= gauss; j++)
        for (l = 0; l <= gauss; l++) {
          double gu, wu, gv, wv, z[2], xi[2], nq[3];
          gsl_integration_glfixed_point(0, 1, (size_t)j, &gu, &wu, T2);
          gsl_integration_glfixed_point(0, 1, (size_t)l, &gv, &wv, T2);
          for (i = 0; i < 2; i++) z[i] = (1 - gu) * A[i] + gu * ((1 - gv) * B[i] + gv * Cc[i]);
          invert_bilinear(nvs, zs, z, xi);
          mo_contact_facet_eval(sc, sb, sfs, f, xi, u, N, x, nq);
          if ((st = push(pts, npts, cap, xi, wu * wv * 2 * at * gu / fabs(dot3(nq, ns)) * mo_contact_facet_factor(mat, x),
                         P->m, ctx)))
            goto done;
        }
    }
  }
  goto done;
not_covered:
  *npts = n0;
  *whole = 1;
done:
  if (T1) gsl_integration_glfixed_table_free(T1);
  if (T2) gsl_integration_glfixed_table_free(T2);
  mo_free(pc);
  if (st) *npts = n0;
  return st;
}
