/* contact_geom.c: contact pairs from the case, slave points and candidates, closest-point
   pairing, frames, gaps, the P* matrices of dual cells and the H operators (doc/theory.md §4). */
#include "config.h"
#include <moreau/contact.h>
#include "case_internal.h"
#include "contact_internal.h"
#include "parallel_detect.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *mo_contact_status_name(int s)
{
  return s == MO_CS_STICK ? "stick" : s == MO_CS_SLIDE ? "slide" : "open";
}

/* The entries of one candidate's columns (at most 3), gathered before they are sorted into H
   (contact_internal.h keeps one in the contact set). */
typedef __typeof__(((mo_contact *)0)->hb) hbuf;

static void hbuf_free(hbuf *B)
{
  int k;
  for (k = 0; k < 3; k++) {
    mo_free(B->row[k]);
    mo_free(B->val[k]);
  }
}

static unsigned key_hash(const int *k)
{
  unsigned h = 2166136261u;
  int j;
  for (j = 0; j < MO_KEY; j++) h = (h ^ (unsigned)k[j]) * 16777619u; /* FNV-1a on the ints */
  return h ^ h >> 15;
}

int mo_keymap_build(mo_keymap *M, const int *keys, int n, mo_ctx *ctx)
{
  int size = 16, a;
  /* at most three quarters full (T187): 1.33 to 2.67 slots a key, against 2 to 4 at half full;
     a lookup probes 2.5 slots on average instead of 1.5 (linear probing, a key present) */
  while (size < n + n / 3 + 1) size *= 2;
  if (size - 1 > M->mask || !M->tab) {
    int *p = mo_realloc(ctx, M->tab, (size_t)size * sizeof *p);
    if (!p) return MO_ENOMEM;
    M->tab = p;
    M->mask = size - 1;
  }
  M->keys = keys;
  for (a = 0; a <= M->mask; a++) M->tab[a] = -1;
  for (a = 0; a < n; a++) {
    unsigned h = key_hash(keys + (size_t)a * MO_KEY) & (unsigned)M->mask;
    while (M->tab[h] >= 0) h = (h + 1) & (unsigned)M->mask;
    M->tab[h] = a;
  }
  return MO_OK;
}

int mo_keymap_find(const mo_keymap *M, const int *k)
{
  unsigned h;
  if (!M->tab) return -1;
  for (h = key_hash(k) & (unsigned)M->mask; M->tab[h] >= 0; h = (h + 1) & (unsigned)M->mask)
    if (!memcmp(M->keys + (size_t)M->tab[h] * MO_KEY, k, MO_KEY * sizeof *k)) return M->tab[h];
  return -1;
}

void mo_keymap_free(mo_keymap *M)
{
  mo_free(M->tab);
  memset(M, 0, sizeof *M);
}

/* Whether pair k is the first to hold the body list l (its sides share the lists of the same bodies,
   side_bodies): the list is freed once, by its first holder. */
static int side_owner(const mo_contact *C, int k, const int *l)
{
  int j;
  for (j = 0; j < k; j++)
    if (C->pair[j].sb == l || C->pair[j].mb == l) return 0;
  return 1;
}

void mo_contact_free(mo_contact *C)
{
  int k;
  if (!C) return;
  for (k = 0; k < C->npair; k++) {
    mo_free(C->pair[k].name);
    mo_free(C->pair[k].sset);
    mo_free(C->pair[k].mset);
    mo_free(C->pair[k].exclude);
    if (side_owner(C, k, C->pair[k].sb)) mo_free(C->pair[k].sb);
    if (side_owner(C, k, C->pair[k].mb) && C->pair[k].mb != C->pair[k].sb) mo_free(C->pair[k].mb);
    mo_free(C->pp[k].cand);
    mo_free(C->pp[k].P);
  }
  mo_free(C->pair);
  mo_free(C->pp);
  mo_free(C->pt);
  mo_free(C->cand);
  mo_free(C->cpt);
  mo_free(C->ccoef);
  mo_free(C->g);
  mo_free(C->frame);
  mo_free(C->U0);
  mo_free(C->active);
  mo_free(C->key);
  mo_free(C->x);
  mo_contact_detect_free(C);
  hbuf_free(&C->hb);
  if (C->H != C->Hfull) mo_csc_free(C->H);
  mo_csc_free(C->Hfull);
  mo_free(C->solver);
  mo_free(C);
}

int mo_contact_dim(const mo_contact *C) { return C->dim; }
int mo_contact_ncandidates(const mo_contact *C) { return C->nc; }
int mo_contact_capacity(const mo_contact *C) { return C->nalloc > C->nc ? C->nalloc : C->nc; }
size_t mo_contact_room(const mo_contact *C, size_t n)
{
  size_t cap = C ? (size_t)mo_contact_capacity(C) : 0;
  return cap >= n ? cap : n + n / 4; /* a quarter more where the set is short of it */
}
int mo_contact_npairs(const mo_contact *C) { return C->npair; }
const mo_contact_pair *mo_contact_pair_get(const mo_contact *C, int k) { return &C->pair[k]; }
const mo_candidate *mo_contact_candidate(const mo_contact *C, int a) { return &C->cand[a]; }
const mo_cpoint *mo_contact_point(const mo_contact *C, int k) { return &C->pt[k]; }
const int *mo_contact_cand_points(const mo_contact *C) { return C->cpt; }
const double *mo_contact_cand_coefs(const mo_contact *C) { return C->ccoef; }
long mo_contact_h_version(const mo_contact *C) { return C->hversion; }
const double *mo_contact_gaps(const mo_contact *C) { return C->g; }
const double *mo_contact_frames(const mo_contact *C) { return C->compact ? NULL : C->frame; }
const double *mo_contact_normals(const mo_contact *C) { return C->compact ? C->frame : NULL; }

const double *mo_contact_frame_of(const mo_contact *C, int a, double *buf)
{
  if (!C->compact) return C->frame + (size_t)a * (size_t)(C->dim * C->dim);
  mo_frame_of_normal(C->dim, C->frame + (size_t)a * (size_t)C->dim, buf); /* (T225) */
  return buf;
}
const mo_csc *mo_contact_H(const mo_contact *C) { return C->H; }
const mo_csc *mo_contact_H_full(const mo_contact *C) { return C->Hfull; }
const double *mo_contact_U0(const mo_contact *C) { return C->U0; }
long mo_contact_set_version(const mo_contact *C) { return C->cset_version; }
int mo_contact_nstatic(const mo_contact *C) { return C->nc_static; }
double mo_contact_alert(const mo_contact *C) { return C->ndyn ? C->alert : 0; }
const int *mo_contact_key(const mo_contact *C, int a) { return C->key + (size_t)a * MO_KEY; }
mo_contact_law mo_contact_law_of(const mo_contact *C, int a) { return C->pair[mo_contact_pair_of(C, a)].law; }
double mo_contact_restitution_of(const mo_contact *C, int a) { return C->pair[mo_contact_pair_of(C, a)].e; }

int mo_contact_pair_P(const mo_contact *C, int pair, const double **P, int *n, const int **cands)
{
  if (pair < 0 || pair >= C->npair || !C->pp[pair].P) return MO_EINPUT;
  *P = C->pp[pair].P;
  *n = C->pp[pair].n;
  *cands = C->pp[pair].cand;
  return MO_OK;
}

/* --- frames ---------------------------------------------------------------------------------- */

/* Frame rows n, t(, s) from the unit normal n: mo_frame_of_normal's (moreau/contact.h). */
void mo_contact_frame_from_normal(int dim, const double *n, double *F) { mo_frame_of_normal(dim, n, F); }

/* --- positions -------------------------------------------------------------------------------- */

/* Node a of mesh body b at state u (NULL: the reference configuration): a deformable body's
   nodes move with their dofs, a rigid mesh's with the body (T68). */
void mo_contact_node_pos(const mo_scene *sc, int b, int a, const mo_state *u, double *x)
{
  const mo_body *B = &sc->body[b];
  int D = sc->dim, i;
  if (B->type->flags & MO_BODY_F_RIGID) {
    double X[3] = {0, 0, 0};
    for (i = 0; i < D; i++) X[i] = B->mesh->x[a * D + i] - B->xc0[i];
    mo_rigid_point(sc, B, u, X, x);
    return;
  }
  for (i = 0; i < D; i++) x[i] = B->mesh->x[a * D + i] + (u ? u->u[B->dof0 + a * D + i] : 0);
}
#define node_pos mo_contact_node_pos

static void point_pos(const mo_contact *C, const mo_cpoint *p, const mo_state *u, double *x)
{
  const mo_scene *sc = C->sc;
  int D = sc->dim, i, k;
  double y[3];
  for (i = 0; i < D; i++) x[i] = 0;
  for (k = 0; k < p->nn; k++) {
    node_pos(sc, C->pair[p->pair].sbody, p->node[k], u, y);
    for (i = 0; i < D; i++) x[i] += p->N[k] * y[i];
  }
}

/* Facet factor of the measure: thickness, 2 pi r, cross-section area, or 1 (3D). */
double mo_contact_facet_factor(const mo_material *mat, const double *x)
{
  switch (mat->hyp) {
  case MO_HYP_BAR: return mat->area;
  case MO_HYP_PLANE_STRAIN:
  case MO_HYP_PLANE_STRESS: return mat->thickness;
  case MO_HYP_AXISYMMETRIC: return 2 * M_PI * x[0];
  default: return 1;
  }
}

/* Position, tangents and measure density of a facet at reference coordinates s. */
#define facet_eval mo_contact_facet_eval
#define facet_factor mo_contact_facet_factor
double mo_contact_facet_eval(const mo_scene *sc, int b, const mo_facetset *fs, int f, const double *s,
                             const mo_state *u, double *N, double *x, double *n)
{
  int D = sc->dim, nfn = fs->nfn, fd = mo_facet_kind_dim(fs->kind), a, i;
  double dN[2 * MO_FNODE_MAX], t1[3] = {0, 0, 0}, t2[3] = {0, 0, 0}, y[3], len = 1;
  mo_facet_shape_kind(fs->kind, s, N, dN);
  for (i = 0; i < D; i++) x[i] = 0;
  for (a = 0; a < nfn; a++) {
    node_pos(sc, b, fs->node[f * nfn + a], u, y);
    for (i = 0; i < D; i++) {
      x[i] += N[a] * y[i];
      if (fd >= 1) t1[i] += dN[a * fd] * y[i];
      if (fd == 2) t2[i] += dN[2 * a + 1] * y[i];
    }
  }
  if (fd == 0) {
    if (n) n[0] = fs->lface[f] == 0 ? -1 : 1;
    return 1;
  }
  if (fd == 1) {
    len = sqrt(t1[0] * t1[0] + t1[1] * t1[1]);
    if (n) { n[0] = t1[1] / len; n[1] = -t1[0] / len; }
    return len;
  }
  {
    double c[3] = {t1[1] * t2[2] - t1[2] * t2[1], t1[2] * t2[0] - t1[0] * t2[2],
                   t1[0] * t2[1] - t1[1] * t2[0]};
    len = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    if (n) for (i = 0; i < 3; i++) n[i] = c[i] / len;
  }
  return len;
}

/* --- pairing ---------------------------------------------------------------------------------- */

/* The closest point of x on segment a-b: its parameter t in [0, 1] (clamped). */
static double segment_param(int D, const double *xa, const double *xb, const double *x)
{
  double tt = 0, s = 0;
  int i;
  for (i = 0; i < D; i++) {
    tt += (xb[i] - xa[i]) * (xb[i] - xa[i]);
    s += (x[i] - xa[i]) * (xb[i] - xa[i]);
  }
  s = tt > 0 ? s / tt : 0;
  return s < 0 ? 0 : s > 1 ? 1 : s;
}

/* Closest point of x on the flat triangle X[0..2] (T193): the barycentric solution of the normal
   equations (s0, s1) when it lies on the triangle (inside within 1e-9), else the nearest of the
   closest points on its three edges. Returns whether the unclamped projection lies on it. */
static int triangle_closest(const double X[3][3], const double *x, double *s)
{
  double t1[3], t2[3], r[3], A11 = 0, A12 = 0, A22 = 0, b1 = 0, b2 = 0, det, best = HUGE_VAL;
  int i, k;
  for (i = 0; i < 3; i++) {
    t1[i] = X[1][i] - X[0][i];
    t2[i] = X[2][i] - X[0][i];
    r[i] = x[i] - X[0][i];
    A11 += t1[i] * t1[i];
    A12 += t1[i] * t2[i];
    A22 += t2[i] * t2[i];
    b1 += r[i] * t1[i];
    b2 += r[i] * t2[i];
  }
  det = A11 * A22 - A12 * A12;
  s[0] = (A22 * b1 - A12 * b2) / det;
  s[1] = (A11 * b2 - A12 * b1) / det;
  if (s[0] >= -1e-9 && s[1] >= -1e-9 && s[0] + s[1] <= 1 + 1e-9) return 1;
  for (k = 0; k < 3; k++) { /* edges 01, 12, 20 */
    double t = segment_param(3, X[k], X[(k + 1) % 3], x), q[3], d = 0, L[3] = {0, 0, 0};
    for (i = 0; i < 3; i++) {
      q[i] = (1 - t) * X[k][i] + t * X[(k + 1) % 3][i];
      d += (x[i] - q[i]) * (x[i] - q[i]);
    }
    if (d < best) {
      best = d;
      L[k] = 1 - t;
      L[(k + 1) % 3] = t;
      s[0] = L[1];
      s[1] = L[2];
    }
  }
  return 0;
}

/* The facet's point y(s), its tangents dy/ds_i and second derivatives d2y/ds_i ds_j (00, 01, 11)
   at reference coordinates s (the shape functions' second derivatives are constant on T6 faces
   and 3-node lines, d2/ds0 ds1 = +-1/4 on the bilinear face). */
static void facet_jet(const mo_scene *sc, int b, const mo_facetset *fs, int f, const mo_state *u, const double *s,
                      double *y, double t[2][3], double h[3][3])
{
  static const double sx[4] = {-1, 1, 1, -1}, sy[4] = {-1, -1, 1, 1};
  static const int mid[3][2] = {{0, 1}, {1, 2}, {2, 0}};
  static const double dL[3][2] = {{-1, -1}, {1, 0}, {0, 1}};
  int D = sc->dim, fd = mo_facet_kind_dim(fs->kind), nfn = fs->nfn, a, i;
  double N[MO_FNODE_MAX], dN[2 * MO_FNODE_MAX], x[3];
  mo_facet_shape_kind(fs->kind, s, N, dN);
  memset(t, 0, 6 * sizeof(double));
  memset(h, 0, 9 * sizeof(double));
  for (i = 0; i < 3; i++) y[i] = 0;
  for (a = 0; a < nfn; a++) {
    double d2[3] = {0, 0, 0};
    if (fs->kind == MO_FK_LINE3) d2[0] = a < 2 ? 1 : -2;
    else if (fs->kind == MO_FK_QUAD4) d2[1] = 0.25 * sx[a] * sy[a];
    else if (fs->kind == MO_FK_TRI6) {
      if (a < 3) {
        d2[0] = 4 * dL[a][0] * dL[a][0];
        d2[1] = 4 * dL[a][0] * dL[a][1];
        d2[2] = 4 * dL[a][1] * dL[a][1];
      } else {
        const double *P = dL[mid[a - 3][0]], *Q = dL[mid[a - 3][1]];
        d2[0] = 8 * P[0] * Q[0];
        d2[1] = 4 * (P[0] * Q[1] + P[1] * Q[0]);
        d2[2] = 8 * P[1] * Q[1];
      }
    }
    node_pos(sc, b, fs->node[f * nfn + a], u, x);
    for (i = 0; i < D; i++) {
      y[i] += N[a] * x[i];
      t[0][i] += dN[a * fd] * x[i];
      if (fd == 2) t[1][i] += dN[2 * a + 1] * x[i];
      h[0][i] += d2[0] * x[i];
      h[1][i] += d2[1] * x[i];
      h[2][i] += d2[2] * x[i];
    }
  }
}

static double half_dist2(int D, const double *y, const double *x)
{
  double r = 0;
  int i;
  for (i = 0; i < D; i++) r += (y[i] - x[i]) * (y[i] - x[i]);
  return 0.5 * r;
}

/* Newton on f(s) = |y(s) - x|^2 / 2 over the parameters of a curved facet (a 3-node line, a T6
   face; the bilinear face keeps Gauss-Newton, as before), its Hessian J^T J - (x - y).y'' (its
   Gauss-Newton part where that is not positive definite), with backtracking so that f decreases:
   the foot of the perpendicular nearest the start (T193). With lo < hi the parameters move along
   the segment s = A + tau (B - A), tau in [lo, hi] (projected onto it): an edge of the reference
   triangle. xi holds the start and receives the result; returns f there. */
static double facet_newton(const mo_scene *sc, int b, const mo_facetset *fs, int f, const double *x, const mo_state *u,
                           double *xi, const double *A, const double *B)
{
  int D = sc->dim, fd = mo_facet_kind_dim(fs->kind), it, i, edge = A != NULL, n = edge ? 1 : fd;
  double y[3], t[2][3], h[3][3], fcur;
  facet_jet(sc, b, fs, f, u, xi, y, t, h);
  fcur = half_dist2(D, y, x);
  for (it = 0; it < 60; it++) {
    double g[2] = {0, 0}, H[3] = {0, 0, 0}, d[2] = {0, 0}, r[3], Jt[2][3], Hd[3] = {0, 0, 0}, step = 1;
    int k, full = 0;
    for (i = 0; i < D; i++) r[i] = y[i] - x[i];
    if (edge) { /* d y / d tau along the edge, and its second derivative */
      double e0 = B[0] - A[0], e1 = B[1] - A[1];
      for (i = 0; i < D; i++) {
        Jt[0][i] = t[0][i] * e0 + (fd == 2 ? t[1][i] * e1 : 0);
        Hd[0] += r[i] * (h[0][i] * e0 * e0 + 2 * h[1][i] * e0 * e1 + h[2][i] * e1 * e1);
      }
    } else
      for (i = 0; i < D; i++) {
        Jt[0][i] = t[0][i];
        Jt[1][i] = t[1][i];
        Hd[0] += r[i] * h[0][i];
        Hd[1] += r[i] * h[1][i];
        Hd[2] += r[i] * h[2][i];
      }
    for (i = 0; i < D; i++) {
      g[0] += Jt[0][i] * r[i];
      H[0] += Jt[0][i] * Jt[0][i];
      if (n == 2) {
        g[1] += Jt[1][i] * r[i];
        H[1] += Jt[0][i] * Jt[1][i];
        H[2] += Jt[1][i] * Jt[1][i];
      }
    }
    if (fs->kind != MO_FK_QUAD4) { /* the full Hessian when positive definite */
      double F0 = H[0] + Hd[0], F1 = H[1] + Hd[1], F2 = H[2] + Hd[2];
      if (n == 1 ? F0 > 0 : F0 > 0 && F0 * F2 - F1 * F1 > 0) { H[0] = F0; H[1] = F1; H[2] = F2; full = 1; }
    }
    if (n == 1) {
      if (!(H[0] > 0)) break;
      d[0] = -g[0] / H[0];
    } else {
      double det = H[0] * H[2] - H[1] * H[1];
      if (!(det > 0)) break;
      d[0] = -(H[2] * g[0] - H[1] * g[1]) / det;
      d[1] = -(H[0] * g[1] - H[1] * g[0]) / det;
    }
    if (fs->kind == MO_FK_QUAD4 && !edge) { /* Gauss-Newton without a line search, as before */
      xi[0] += d[0];
      xi[1] += d[1];
      facet_jet(sc, b, fs, f, u, xi, y, t, h);
      fcur = half_dist2(D, y, x);
      if (fabs(d[0]) + fabs(d[1]) < 1e-13 || fabs(xi[0]) > 10 || fabs(xi[1]) > 10) break;
      continue;
    }
    for (k = 0; k < 40; k++, step *= 0.5) {
      double s2[2], y2[3], t2[2][3], h2[3][3], f2, tau = 0;
      /* near the foot a Newton step on the exact Hessian is taken whole: its decrease of f is
         below f's round-off there, and the line search would stop short of it */
      int near = full && k == 0 && fabs(d[0]) + fabs(d[1]) < 1e-6;
      if (edge) {
        /* tau of the current point, stepped and kept on [0, 1] */
        double e0 = B[0] - A[0], e1 = B[1] - A[1], ee = e0 * e0 + e1 * e1;
        tau = ((xi[0] - A[0]) * e0 + (xi[1] - A[1]) * e1) / ee + step * d[0];
        tau = fmax(0, fmin(1, tau));
        s2[0] = A[0] + tau * e0;
        s2[1] = A[1] + tau * e1;
      } else {
        s2[0] = xi[0] + step * d[0];
        s2[1] = xi[1] + step * d[1];
      }
      facet_jet(sc, b, fs, f, u, s2, y2, t2, h2);
      f2 = half_dist2(D, y2, x);
      if (near || f2 <= fcur + 1e-4 * step * (g[0] * d[0] + g[1] * d[1]) || k == 39) {
        double moved = fabs(s2[0] - xi[0]) + fabs(s2[1] - xi[1]);
        if (!near && f2 > fcur) { step = 0; break; } /* no descent left: at round-off */
        xi[0] = s2[0];
        xi[1] = s2[1];
        memcpy(y, y2, sizeof y2);
        memcpy(t, t2, sizeof t2);
        memcpy(h, h2, sizeof h2);
        fcur = f2;
        if (moved < 1e-14) step = 0;
        break;
      }
    }
    if (step == 0 || fabs(d[0]) + fabs(d[1]) < 1e-14) break;
    if (fabs(xi[0]) > 10 || fabs(xi[1]) > 10) break;
  }
  return fcur;
}

/* The nearest point of a curved triangle (T6) to x when the foot of the perpendicular is off it:
   Newton along each of its three edges (T193). */
static void tri6_boundary(const mo_scene *sc, int b, const mo_facetset *fs, int f, const double *x, const mo_state *u,
                          double *xi)
{
  static const double V[3][2] = {{0, 0}, {1, 0}, {0, 1}};
  double best = HUGE_VAL, s[2];
  int k, j;
  for (k = 0; k < 3; k++)
    for (j = 0; j < 3; j++) { /* three starts per edge: its ends and its middle */
      double fk;
      s[0] = V[k][0] + 0.5 * j * (V[(k + 1) % 3][0] - V[k][0]);
      s[1] = V[k][1] + 0.5 * j * (V[(k + 1) % 3][1] - V[k][1]);
      fk = facet_newton(sc, b, fs, f, x, u, s, V[k], V[(k + 1) % 3]);
      if (fk < best) {
        best = fk;
        xi[0] = s[0];
        xi[1] = s[1];
      }
    }
}

/* Closest point of x on master facet f: facet coordinates xi, shape values, distance,
   and whether the unclamped projection lies on the facet (doc/theory.md §4.1, (T193)). */
double mo_contact_project_facet(const mo_scene *sc, int b, const mo_facetset *fs, int f,
                            const double *x, const mo_state *u, double *xi, double *N, double *q,
                            double *n, int *inside)
{
  int D = sc->dim, nfn = fs->nfn, i;
  double d2 = 0;
  switch (fs->kind) {
  case MO_FK_POINT:
    facet_eval(sc, b, fs, f, xi, u, N, q, n);
    xi[0] = xi[1] = 0;
    *inside = 1;
    break;
  case MO_FK_LINE2:
  case MO_FK_LINE3: {
    double xa[3], xb[3], tt = 0, s = 0;
    node_pos(sc, b, fs->node[nfn * f], u, xa);
    node_pos(sc, b, fs->node[nfn * f + 1], u, xb);
    for (i = 0; i < D; i++) { tt += (xb[i] - xa[i]) * (xb[i] - xa[i]); s += (x[i] - xa[i]) * (xb[i] - xa[i]); }
    s /= tt;                                   /* along the chord: 0 at a, 1 at b */
    xi[0] = 2 * s - 1;
    xi[1] = 0;
    if (fs->kind == MO_FK_LINE3) {
      static const double A[2] = {-1, 0}, B[2] = {1, 0};
      xi[0] = fmax(-1, fmin(1, xi[0]));
      facet_newton(sc, b, fs, f, x, u, xi, NULL, NULL);
      *inside = xi[0] >= -1 - 2e-9 && xi[0] <= 1 + 2e-9;
      if (!*inside) { /* the nearest point of the arc: Newton kept on [-1, 1] from either end */
        double e[2] = {-1, 0}, g[2] = {1, 0};
        double fa = facet_newton(sc, b, fs, f, x, u, e, A, B), fb = facet_newton(sc, b, fs, f, x, u, g, A, B);
        xi[0] = fa <= fb ? e[0] : g[0];
      }
    } else
      *inside = xi[0] >= -1 - 2e-9 && xi[0] <= 1 + 2e-9;
    xi[0] = fmax(-1, fmin(1, xi[0]));
    facet_eval(sc, b, fs, f, xi, u, N, q, n);
    break;
  }
  case MO_FK_TRI3:
  case MO_FK_TRI6: {
    double X[3][3];
    int a;
    for (a = 0; a < 3; a++) node_pos(sc, b, fs->node[nfn * f + a], u, X[a]);
    *inside = triangle_closest(X, x, xi);
    if (fs->kind == MO_FK_TRI6) {
      facet_newton(sc, b, fs, f, x, u, xi, NULL, NULL);
      *inside = xi[0] >= -1e-9 && xi[1] >= -1e-9 && xi[0] + xi[1] <= 1 + 1e-9;
      if (!*inside) tri6_boundary(sc, b, fs, f, x, u, xi);
      else {
        xi[0] = fmax(0, xi[0]);
        xi[1] = fmax(0, xi[1]);
      }
    }
    facet_eval(sc, b, fs, f, xi, u, N, q, n);
    break;
  }
  default: /* the bilinear face */
    xi[0] = xi[1] = 0;
    facet_newton(sc, b, fs, f, x, u, xi, NULL, NULL);
    *inside = fabs(xi[0]) <= 1 + 1e-9 && fabs(xi[1]) <= 1 + 1e-9;
    for (i = 0; i < 2; i++) xi[i] = fmax(-1, fmin(1, xi[i]));
    facet_eval(sc, b, fs, f, xi, u, N, q, n);
  }
  for (i = 0; i < D; i++) d2 += (x[i] - q[i]) * (x[i] - q[i]);
  return sqrt(d2);
}

/* Pair point p (slave position x) with its master; frame and gap. */
static void pair_point(mo_contact *C, mo_cpoint *p, const mo_state *u, double t, int repair)
{
  const mo_scene *sc = C->sc;
  const mo_contact_pair *P = &C->pair[p->pair];
  int D = sc->dim, i;
  double x[3];
  point_pos(C, p, u, x);
  p->sb = P->sbody;
  p->mb = P->mbody;
  memcpy(p->xs, x, sizeof x);
  if (P->master == MO_MASTER_PLANE) {
    const mo_body *B = &sc->body[P->mbody];
    double g = 0;
    for (i = 0; i < D; i++) g += (x[i] - (B->point[i] + B->velocity[i] * t)) * B->normal[i];
    mo_contact_frame_from_normal(D, B->normal, p->frame);
    for (i = 0; i < D; i++) p->xm[i] = x[i] - g * B->normal[i];
    p->g = g;
    p->off = 0;
    return;
  }
  {
    const mo_facetset *fs = mo_mesh_find_facetset(sc->body[P->mbody].mesh, P->mset);
    double q[3], n[3], N[MO_FNODE_MAX], xi[2];
    if (p->mseg > 0 && p->mfacet < 0) {
      /* a point of a segment: its master facet is the segment's (doc/theory.md (T90)) */
      int inside;
      p->mfacet = p->mseg - 1;
      mo_contact_project_facet(sc, P->mbody, fs, p->mfacet, x, u, xi, N, q, n, &inside);
      p->off = !inside;
    } else if (repair || p->mfacet < 0) {
      double best = HUGE_VAL, bestin = HUGE_VAL;
      int f, fbest = -1, fin = -1, inside;
      for (f = 0; f < fs->n; f++) {
        double d = mo_contact_project_facet(sc, P->mbody, fs, f, x, u, xi, N, q, n, &inside);
        if (d < best) { best = d; fbest = f; }
        if (inside && d < bestin) { bestin = d; fin = f; }
      }
      p->mfacet = fin >= 0 ? fin : fbest;
      p->off = fin < 0;
    }
    {
      int inside;
      mo_contact_project_facet(sc, P->mbody, fs, p->mfacet, x, u, p->xi, N, q, n, &inside);
      /* with a frozen pairing the projection stays on the chosen facet */
    }
    p->mn = fs->nfn;
    for (i = 0; i < fs->nfn; i++) {
      p->mnode[i] = fs->node[p->mfacet * fs->nfn + i];
      p->mN[i] = N[i];
    }
    mo_contact_frame_from_normal(D, n, p->frame);
    p->g = 0;
    for (i = 0; i < D; i++) p->g += (x[i] - q[i]) * n[i];
    memcpy(p->xm, q, sizeof q);
  }
}

/* --- H ----------------------------------------------------------------------------------------- */

static inline int hbuf_add(hbuf *B, int col, int row, double v, mo_ctx *ctx)
{
  if (v == 0) return MO_OK;
  if (B->n[col] == B->cap) {
    int cap = B->cap ? 2 * B->cap : 64, k;
    void *p;
    for (k = 0; k < 3; k++) {
      if (!(p = mo_realloc(ctx, B->row[k], (size_t)cap * sizeof *B->row[k]))) return MO_ENOMEM;
      B->row[k] = p;
      if (!(p = mo_realloc(ctx, B->val[k], (size_t)cap * sizeof *B->val[k]))) return MO_ENOMEM;
      B->val[k] = p;
    }
    B->cap = cap;
  }
  B->row[col][B->n[col]] = row;
  B->val[col][B->n[col]++] = v;
  return MO_OK;
}

/* The entries of one side of a point in the candidate's columns, scaled by cf (the side's sign
   and the point's coefficient): a mesh body's nodes (shape values N at nodes), a rigid body's
   dofs through its velocity Jacobian at the material point x (T68), nothing for a plane. */
static int side_H(mo_contact *C, hbuf *B, int b, int nn, const int *node, const double *N, const double *x,
                  const double *F, double cf, mo_ctx *ctx)
{
  const mo_scene *sc = C->sc;
  const mo_body *Bd = &sc->body[b];
  int D = sc->dim, d = C->dim, i, j, q, st;
  if (Bd->type->flags & MO_BODY_F_NODAL) {
    for (q = 0; q < nn; q++) {
      int dof0 = Bd->dof0 + node[q] * D;
      for (i = 0; i < d; i++)
        for (j = 0; j < D; j++)
          if ((st = hbuf_add(B, i, dof0 + j, cf * N[q] * F[i * d + j], ctx))) return st;
    }
  } else if (Bd->type->flags & MO_BODY_F_RIGID) {
    /* row i of F times the velocity Jacobian at x (T68): the translation dofs take F_i, the
       rotation dofs (x - xc) x F_i (2D: its z component) */
    double r[3] = {0, 0, 0};
    const double *u = C->hstate ? C->hstate->u + Bd->dof0 : NULL;
    for (q = 0; q < D; q++) r[q] = x[q] - (Bd->xc0[q] + (u ? u[q] : 0));
    for (i = 0; i < d && d == D; i++) {
      const double *Fi = F + i * d;
      for (j = 0; j < D; j++)
        if ((st = hbuf_add(B, i, Bd->dof0 + j, cf * Fi[j], ctx))) return st;
      if (D == 2) {
        if ((st = hbuf_add(B, i, Bd->dof0 + 2, cf * (r[0] * Fi[1] - r[1] * Fi[0]), ctx))) return st;
      } else {
        double w[3] = {r[1] * Fi[2] - r[2] * Fi[1], r[2] * Fi[0] - r[0] * Fi[2], r[0] * Fi[1] - r[1] * Fi[0]};
        for (j = 0; j < 3; j++)
          if ((st = hbuf_add(B, i, Bd->dof0 + 3 + j, cf * w[j], ctx))) return st;
      }
    }
  }
  return MO_OK;
}

/* Room for nnz more entries in A (grown by doubling). */
static int csc_room(mo_csc *A, int nnz, int *cap, mo_ctx *ctx)
{
  void *p;
  if (nnz <= *cap) return MO_OK;
  while (*cap < nnz) *cap = *cap ? 2 * *cap : 256;
  if (!(p = mo_realloc(ctx, A->i, (size_t)*cap * sizeof *A->i))) return MO_ENOMEM;
  A->i = p;
  if (!(p = mo_realloc(ctx, A->x, (size_t)*cap * sizeof *A->x))) return MO_ENOMEM;
  A->x = p;
  return MO_OK;
}

/* The candidate's d columns from its gathered entries, rows sorted (the sides' dofs come in
   runs: usually in order already) and duplicates summed, into Hf (every dof) and H (free). */
static int flush_columns(const mo_scene *sc, hbuf *B, int d, int col0, mo_csc *Hf, int *capf, mo_csc *H, int *caph,
                         mo_ctx *ctx)
{
  int i, k, st;
  for (i = 0; i < d; i++) {
    int j = col0 + i, n = B->n[i], *row = B->row[i], nf = Hf->p[j], nh = H->p[j];
    double *val = B->val[i];
    if ((st = csc_room(Hf, nf + n, capf, ctx)) || (H != Hf && (st = csc_room(H, nh + n, caph, ctx)))) return st;
    for (k = 1; k < n; k++) /* insertion sort: already sorted in the common case */
      if (row[k] < row[k - 1]) {
        int r = row[k], q = k;
        double v = val[k];
        for (; q > 0 && row[q - 1] > r; q--) {
          row[q] = row[q - 1];
          val[q] = val[q - 1];
        }
        row[q] = r;
        val[q] = v;
      }
    for (k = 0; k < n; k++) {
      if (nf > Hf->p[j] && Hf->i[nf - 1] == row[k]) { /* the same dof from both sides (self-contact) */
        Hf->x[nf - 1] += val[k];
        continue;
      }
      Hf->i[nf] = row[k];
      Hf->x[nf++] = val[k];
    }
    if (H != Hf) {
      for (k = Hf->p[j]; k < nf; k++)
        if (sc->free_of[Hf->i[k]] >= 0) {
          H->i[nh] = sc->free_of[Hf->i[k]];
          H->x[nh++] = Hf->x[k];
        }
      H->p[j + 1] = nh;
    }
    Hf->p[j + 1] = nf;
    B->n[i] = 0;
  }
  return MO_OK;
}

/* H over every dof and over the free dofs, column by column (the candidates' columns are
   independent: no triplets, no sort of the whole). */
/* A matrix of the previous geometry, its arrays kept and resized for ncol columns. */
static int csc_reuse(mo_csc **A, int nrow, int ncol, int *pcap, mo_ctx *ctx)
{
  if (!*A) {
    int st = mo_csc_alloc(nrow, ncol, 0, A, ctx);
    if (st) return st;
    *pcap = ncol + 1;
  } else if (ncol + 1 > *pcap) {
    int *p = mo_realloc(ctx, (*A)->p, (size_t)(2 * ncol + 2) * sizeof *p);
    if (!p) return MO_ENOMEM;
    (*A)->p = p;
    *pcap = 2 * ncol + 2;
  }
  (*A)->nrow = nrow;
  (*A)->ncol = ncol;
  (*A)->p[0] = 0;
  return MO_OK;
}

static int build_H(mo_contact *C, mo_ctx *ctx)
{
  const mo_scene *sc = C->sc;
  int d = C->dim, m = d * C->nc, a, k, st = MO_OK;
  /* the arrays of the previous H are reused: a scene of detected contacts builds H at every
     step, and fresh arrays would fault their pages in each time */
  if ((st = csc_reuse(&C->Hfull, sc->ndof, m, &C->hpcapf, ctx))) return st;
  if (C->h_alias) C->H = C->Hfull; /* every dof free, numbered in order: H over the free dofs is H */
  else if ((st = csc_reuse(&C->H, sc->nfree, m, &C->hpcap, ctx))) return st;
  for (a = 0; a < C->nc; a++) {
    double Fb[9];
    const double *F = mo_contact_frame_of(C, a, Fb);
    if (C->compact && a >= C->nc_static) { /* a compact record: one point, coefficient 1 */
      mo_cpoint pb;
      const mo_cpoint *p = mo_contact_cand_point(C, a, &pb);
      if ((st = side_H(C, &C->hb, p->sb, 0, NULL, NULL, p->xs, F, 1, ctx)) ||
          (p->mb >= 0 && (st = side_H(C, &C->hb, p->mb, 0, NULL, NULL, p->xm, F, -1, ctx))))
        goto fail;
    } else {
      const mo_candidate *c = &C->cand[a];
      for (k = 0; k < c->np; k++) {
        const mo_cpoint *p = &C->pt[C->cpt[c->first + k]];
        double cf = C->ccoef[c->first + k];
        if ((st = side_H(C, &C->hb, p->sb, p->nn, p->node, p->N, p->xs, F, cf, ctx))) goto fail;
        if (p->mb >= 0 && !p->off && (st = side_H(C, &C->hb, p->mb, p->mn, p->mnode, p->mN, p->xm, F, -cf, ctx)))
          goto fail;
      }
    }
    if ((st = flush_columns(sc, &C->hb, d, a * d, C->Hfull, &C->hcapf, C->H, &C->hcap, ctx))) goto fail;
  }
  C->hversion++;
  C->hbuilt = C->cset_version;
  return MO_OK;
fail:
  /* no half-built H left behind */
  if (C->H != C->Hfull) mo_csc_free(C->H);
  mo_csc_free(C->Hfull);
  C->Hfull = C->H = NULL;
  C->hcapf = C->hcap = C->hpcapf = C->hpcap = 0;
  return st;
}

/* Candidate frames, gaps and obstacle velocities from the points. */
static void candidates_update(mo_contact *C, const mo_state *u, double t)
{
  const mo_scene *sc = C->sc;
  int d = C->dim, D = sc->dim, a, k, i, j;
  for (a = 0; a < C->nc_static; a++) {
    const mo_candidate *c = &C->cand[a];
    const mo_cpoint *rep = &C->pt[c->point];
    const mo_contact_pair *P = &C->pair[c->pair];
    double *F = &C->frame[a * d * d], g = 0, csum = 0;
    int off = 0;
    memcpy(F, rep->frame, (size_t)(d * d) * sizeof(double));
    for (k = 0; k < c->np; k++) {
      const mo_cpoint *p = &C->pt[C->cpt[c->first + k]];
      double cf = C->ccoef[c->first + k], x[3], q[3], gk = 0;
      /* the gap of each point along the candidate's normal */
      point_pos(C, p, u, x);
      if (P->master == MO_MASTER_PLANE) {
        const mo_body *B = &sc->body[P->mbody];
        for (i = 0; i < D; i++) gk += (x[i] - (B->point[i] + B->velocity[i] * t)) * F[i];
      } else {
        for (i = 0; i < D; i++) {
          q[i] = 0;
          for (j = 0; j < p->mn; j++) {
            double y[3];
            node_pos(sc, P->mbody, p->mnode[j], u, y);
            q[i] += p->mN[j] * y[i];
          }
          gk += (x[i] - q[i]) * F[i];
        }
      }
      g += cf * gk;
      csum += cf;
      off |= p->off && P->off == MO_OFF_INACTIVE;
    }
    C->g[a] = g; /* P* rows sum to 1 (partition of unity over the cell) */
    /* a plane that is gone (bodies.[].until) holds nothing */
    C->active[a] = !off && !(P->master == MO_MASTER_PLANE && t > sc->body[P->mbody].until);
    for (i = 0; i < d; i++) {
      double s = 0;
      if (P->master == MO_MASTER_PLANE)
        for (j = 0; j < D; j++) s -= F[i * d + j] * sc->body[P->mbody].velocity[j];
      if (C->U0) C->U0[a * d + i] = s * csum;
    }
  }
}

/* 1 when a point sits on a rigid body: its pairing, frame and columns of H follow the body. */
static int on_rigid(const mo_contact *C, const mo_cpoint *p)
{
  const mo_body *S = &C->sc->body[C->pair[p->pair].sbody], *M = &C->sc->body[C->pair[p->pair].mbody];
  return ((S->type->flags | M->type->flags) & MO_BODY_F_RIGID) != 0;
}

int mo_contact_geometry(mo_contact *C, const mo_state *u, double t, int repair, mo_ctx *ctx)
{
  int k, changed = 0, st = MO_OK;
  long cset = C->cset_version;
  double t0 = mo_clock(), broad0 = ctx->phase_time[MO_PH_BROAD];
  C->hstate = u;
  for (k = 0; k < C->npt_static; k++) {
    mo_cpoint old = C->pt[k];
    if (!(repair || !C->H || on_rigid(C, &C->pt[k]))) continue;
    pair_point(C, &C->pt[k], u, t, repair || !C->H);
    if (old.mfacet != C->pt[k].mfacet || memcmp(old.frame, C->pt[k].frame, sizeof old.frame) ||
        memcmp(old.mN, C->pt[k].mN, sizeof old.mN))
      changed = 1;
  }
  candidates_update(C, u, t);
  /* the detected candidates of the dynamic pairs (rigid shapes), replaced at every geometry */
  if (C->ndyn) st = mo_contact_detect(C, u, t, ctx);
  /* the granular path builds H only when asked (mo_contact_H_ensure) */
  if (!st && !C->compact && (!C->H || changed || C->moving_h || C->cset_version != cset)) st = build_H(C, ctx);
  if (!st && C->compact) {
    C->hbuilt = -1; /* H, if any, is of an earlier geometry */
    C->hversion++;
  }
  C->hstate = NULL;
  mo_phase_add(ctx, MO_PH_GEOMETRY, t0);
  /* the broad phase is its own phase */
  ctx->phase_time[MO_PH_GEOMETRY] -= ctx->phase_time[MO_PH_BROAD] - broad0;
  return st;
}

int mo_contact_H_ensure(mo_contact *C, const mo_state *s, mo_ctx *ctx)
{
  int st;
  if (!C->compact || (C->H && C->hbuilt == C->cset_version)) return MO_OK;
  C->hstate = s;
  st = build_H(C, ctx);
  C->hstate = NULL;
  return st;
}

int mo_contact_is_compact(const mo_contact *C) { return C->compact; }

size_t mo_contact_bytes(const mo_contact *C, size_t *per_candidate)
{
  const int d = C->dim, D = C->sc->dim;
  size_t cand = (size_t)C->nalloc * (sizeof(double) * (size_t)(1 + mo_contact_fstride(C) + (C->U0 ? d : 0) + D) + 1 + MO_KEY * sizeof(int));
  size_t pts = (size_t)C->ptcap * sizeof(mo_cpoint) + (size_t)C->ccap * sizeof(mo_candidate) +
               (size_t)C->coefcap * (sizeof(int) + sizeof(double));
  size_t h = 0, body = 0;
  if (C->Hfull) h += (size_t)C->hcapf * (sizeof(int) + sizeof(double)) + (size_t)C->hpcapf * sizeof(int);
  if (C->H && C->H != C->Hfull) h += (size_t)C->hcap * (sizeof(int) + sizeof(double)) + (size_t)C->hpcap * sizeof(int);
  if (C->ndyn) /* the detection's per-body arrays (detect.c) and the broad phase */
    body = (size_t)C->sc->nbody * (2 * sizeof(unsigned long long) + (3 + 3 + (size_t)D + 5) * sizeof(double) + 2) +
           mo_contact_broad_bytes(C);
  /* the detection's remap (T222) and the old keys it held aside */
  if (C->krr) cand += (size_t)C->smap.mcap * sizeof(int) + (C->smap.hold ? ((size_t)C->smap.hmask + 1) * MO_KEY * sizeof(int) : 0);
  if (per_candidate) *per_candidate = cand + pts + h;
  return cand + pts + h + body;
}

const mo_cpoint *mo_contact_cand_point(const mo_contact *C, int a, mo_cpoint *buf)
{
  const int *key;
  int D = C->sc->dim, i;
  if (!C->compact || a < C->nc_static) return &C->pt[C->cand[a].point];
  /* a compact record: the point detect.c would have written (a shape's contact, no nodes) */
  key = C->key + (size_t)a * MO_KEY;
  memset(buf, 0, sizeof *buf);
  buf->pair = key[0];
  buf->facet = buf->mfacet = -1;
  buf->sb = key[1];
  buf->mb = key[2];
  buf->sfeat = key[3];
  buf->mfeat = key[4];
  for (i = 0; i < D; i++) buf->xs[i] = buf->xm[i] = buf->x0[i] = C->x[(size_t)a * D + i];
  mo_frame_of_normal(C->dim, C->frame + (size_t)a * C->dim, buf->frame); /* (T225) */
  buf->g = C->g[a];
  return buf;
}

void mo_contact_cand_bodies(const mo_contact *C, int a, int *sb, int *mb)
{
  if (C->compact && a >= C->nc_static) {
    *sb = C->key[(size_t)a * MO_KEY + 1];
    *mb = C->key[(size_t)a * MO_KEY + 2];
  } else {
    const mo_cpoint *p = &C->pt[C->cand[a].point];
    *sb = p->sb;
    *mb = p->mb;
  }
}

const mo_candidate *mo_contact_cand_get(const mo_contact *C, int a, mo_candidate *buf)
{
  const int *key;
  if (!C->compact || a < C->nc_static) return &C->cand[a];
  key = C->key + (size_t)a * MO_KEY;
  memset(buf, 0, sizeof *buf);
  buf->pair = key[0];
  buf->first = buf->point = -1;
  buf->np = 1;
  buf->node = -1;
  buf->w = 1;
  buf->mu = C->pair[key[0]].mu;
  return buf;
}

/* The d columns of H^T x of compact record a (every dof), added to acc: the entries side_H writes
   for the rigid shapes at the contact point (T68), summed in increasing dof order as mo_csc_gatxpy
   sums a column of Hfull. A side's sign (slave +, master -) is applied to the products, which IEEE
   arithmetic makes the same as applying it to the entries; an entry H does not store (zero) adds a
   zero product (the sums differ at most by the sign of a zero). */
/* here: s is the state of this geometry, whose centres detect.c formed (bcur, the same sums):
   C_HERE(C, s), one test for all the records of a product (T296). */
#define C_HERE(C, s) ((s)->u == (C)->bcur_u && (s)->step == (C)->bcur_step)
static inline __attribute__((always_inline)) void compact_columns(const mo_contact *C, int a, const mo_state *s,
                                                                  const double *x, double *acc, const int here,
                                                                  const int D)
{
  const mo_scene *sc = C->sc;
  const int *key = C->key + (size_t)a * MO_KEY;
  const double *xp = C->x + (size_t)a * D;
  double F[9];
  int side[2], dof[2], ns = 0, k, i, q;
  double cf[2];
  mo_frame_of_normal(D, C->frame + (size_t)a * D, F); /* the normal's frame (T225) */
  if (C->bdof[key[1]] >= 0) { side[ns] = key[1]; dof[ns] = C->bdof[key[1]]; cf[ns++] = 1; }
  if (key[2] >= 0 && C->bdof[key[2]] >= 0) { side[ns] = key[2]; dof[ns] = C->bdof[key[2]]; cf[ns++] = -1; }
  if (ns == 2 && dof[1] < dof[0]) {
    int b = side[0], o = dof[0];
    side[0] = side[1];
    dof[0] = dof[1];
    side[1] = b;
    dof[1] = o;
    cf[0] = -1;
    cf[1] = 1;
  }
  for (k = 0; k < ns; k++) {
    const double *xb = x + dof[k];
    double r[3];
    if (here)
      for (q = 0; q < D; q++) r[q] = xp[q] - C->bcur[(size_t)D * side[k] + q];
    else
      for (q = 0; q < D; q++) r[q] = xp[q] - (sc->body[side[k]].xc0[q] + s->u[dof[k] + q]);
    for (i = 0; i < D; i++) {
      const double *Fi = F + i * D;
      double t = 0;
      if (D == 2) {
        double p0 = Fi[0] * xb[0], p1 = Fi[1] * xb[1], p2 = (r[0] * Fi[1] - r[1] * Fi[0]) * xb[2];
        if (cf[k] > 0) t = ((acc[i] + p0) + p1) + p2;
        else t = ((acc[i] - p0) - p1) - p2;
      } else {
        double w0 = r[1] * Fi[2] - r[2] * Fi[1], w1 = r[2] * Fi[0] - r[0] * Fi[2], w2 = r[0] * Fi[1] - r[1] * Fi[0];
        double p[6] = {Fi[0] * xb[0], Fi[1] * xb[1], Fi[2] * xb[2], w0 * xb[3], w1 * xb[4], w2 * xb[5]};
        int j;
        t = acc[i];
        if (cf[k] > 0) for (j = 0; j < 6; j++) t += p[j];
        else for (j = 0; j < 6; j++) t -= p[j];
      }
      acc[i] = t;
    }
  }
}

void mo_contact_Htx1(const mo_contact *C, const mo_state *s, const double *x, int a, const double *start, double *y)
{
  const int d = C->dim;
  double acc[3] = {0, 0, 0};
  int i, j, p;
  for (i = 0; i < d; i++) acc[i] = start ? start[i] : 0;
  if (C->compact && a >= C->nc_static) {
    if (d == 2) compact_columns(C, a, s, x, acc, C_HERE(C, s), 2);
    else compact_columns(C, a, s, x, acc, C_HERE(C, s), 3);
  } else {
    const mo_csc *H = C->Hfull;
    for (i = 0; i < d; i++)
      for (j = a * d + i, p = H->p[j]; p < H->p[j + 1]; p++) acc[i] += H->x[p] * x[H->i[p]];
  }
  for (i = 0; i < d; i++) y[i] = start ? acc[i] : 1 * acc[i] + 0;
}

/* The records a0..a1 of H^T x (+ start), d a constant of each call site and the test of start and
   of the state's centres made once for all of them (T296): mo_contact_Htx1's operations. */
static inline __attribute__((always_inline)) void compact_Htx(const mo_contact *C, const mo_state *s, const double *x,
                                                              int a0, int a1, const double *start, double *y,
                                                              const int d)
{
  const int here = C_HERE(C, s);
  int a, i;
  if (start)
    for (a = a0; a < a1; a++) {
      double acc[3] = {0, 0, 0};
      for (i = 0; i < d; i++) acc[i] = start[(size_t)a * d + i];
      compact_columns(C, a, s, x, acc, here, d);
      for (i = 0; i < d; i++) y[(size_t)a * d + i] = acc[i];
    }
  else
    for (a = a0; a < a1; a++) {
      double acc[3] = {0, 0, 0};
      compact_columns(C, a, s, x, acc, here, d);
      for (i = 0; i < d; i++) y[(size_t)a * d + i] = 1 * acc[i] + 0;
    }
}

void mo_contact_Htx(const mo_contact *C, const mo_state *s, const double *x, int a0, int a1, const double *start,
                    double *y)
{
  const int d = C->dim;
  int a;
  if (C->compact && a0 >= C->nc_static && (d == 2 || d == 3)) { /* the records, without a call each */
    if (d == 2) compact_Htx(C, s, x, a0, a1, start, y, 2);
    else compact_Htx(C, s, x, a0, a1, start, y, 3);
    return;
  }
  for (a = a0; a < a1; a++) mo_contact_Htx1(C, s, x, a, start ? start + (size_t)a * d : NULL, y + (size_t)a * d);
}

/* --- dual cells and P* -------------------------------------------------------------------------- */

/* Integrals over the part of facet f nearest to each of its nodes: A[a][s] = int_{cell a} f_s,
   meas[a] = int_{cell a} 1 (measure with thickness / 2 pi r / area factor). The cells: half
   intervals (lines), quadrants of the reference square, and on triangles the barycentric cells
   (corner a, the middles of its two edges and the centroid: a third of the triangle, (T194)),
   each as two triangles with the 3-point rule (exact for the linear integrands of flat T3). A
   quadratic facet (T6 edges, T10 faces) has no cells of positive P* (its corner functions change
   sign): meas[a] is its HRZ share of the facet's measure (T191, T194), A is left zero. */
static int facet_cells(const mo_scene *sc, int b, const mo_facetset *fs, int f, double A[MO_FNODE_MAX][MO_FNODE_MAX],
                       double meas[MO_FNODE_MAX], mo_ctx *ctx)
{
  int nfn = fs->nfn, a, s, q, r;
  static const double gp[2] = {-0.5773502691896257645, 0.5773502691896257645};
  const mo_material *mat = sc->body[b].mat;
  memset(A, 0, MO_FNODE_MAX * MO_FNODE_MAX * sizeof(double));
  memset(meas, 0, MO_FNODE_MAX * sizeof(double));
  if (nfn == 1) {
    double x[3], N[1];
    double xi[2] = {0, 0};
    facet_eval(sc, b, fs, f, xi, NULL, N, x, NULL);
    A[0][0] = meas[0] = facet_factor(mat, x);
    return MO_OK;
  }
  if (fs->kind == MO_FK_LINE3 || fs->kind == MO_FK_TRI6) {
    double dsum = 0, total = 0;
    mo_quad Q;
    int st = mo_quad_facet_kind(fs->kind, 3, &Q, ctx);
    if (st) return st;
    for (q = 0; q < Q.n; q++) {
      double N[MO_FNODE_MAX], x[3], w = facet_eval(sc, b, fs, f, Q.xi[q], NULL, N, x, NULL) * Q.w[q];
      w *= facet_factor(mat, x);
      total += w;
      for (a = 0; a < nfn; a++) meas[a] += w * N[a] * N[a];
    }
    for (a = 0; a < nfn; a++) dsum += meas[a];
    for (a = 0; a < nfn; a++) meas[a] *= total / dsum;
    return MO_OK;
  }
  if (fs->kind == MO_FK_TRI3) {
    static const double V[3][2] = {{0, 0}, {1, 0}, {0, 1}}, g[2] = {1.0 / 3, 1.0 / 3};
    static const double rule[3][2] = {{1.0 / 6, 1.0 / 6}, {2.0 / 3, 1.0 / 6}, {1.0 / 6, 2.0 / 3}};
    for (a = 0; a < 3; a++) {
      double mab[2], mac[2];
      int h, k;
      for (k = 0; k < 2; k++) {
        mab[k] = 0.5 * (V[a][k] + V[(a + 1) % 3][k]);
        mac[k] = 0.5 * (V[a][k] + V[(a + 2) % 3][k]);
      }
      for (h = 0; h < 2; h++) { /* triangles (V_a, m_ab, g) and (V_a, g, m_ac) */
        const double *P0 = V[a], *P1 = h ? g : mab, *P2 = h ? mac : g;
        double area2 = fabs((P1[0] - P0[0]) * (P2[1] - P0[1]) - (P1[1] - P0[1]) * (P2[0] - P0[0]));
        for (q = 0; q < 3; q++) {
          double xi[2], N[MO_FNODE_MAX], x[3], w;
          for (k = 0; k < 2; k++) xi[k] = P0[k] + rule[q][0] * (P1[k] - P0[k]) + rule[q][1] * (P2[k] - P0[k]);
          w = facet_eval(sc, b, fs, f, xi, NULL, N, x, NULL) * area2 / 6 * facet_factor(mat, x);
          meas[a] += w;
          for (s = 0; s < 3; s++) A[a][s] += w * N[s];
        }
      }
    }
    return MO_OK;
  }
  for (a = 0; a < nfn; a++) {
    /* the sub-cell of node a: half interval or quadrant of the reference facet */
    double lo0, hi0, lo1 = 0, hi1 = 0;
    if (nfn == 2) { lo0 = a == 0 ? -1 : 0; hi0 = a == 0 ? 0 : 1; }
    else {
      static const double sx[4] = {-1, 1, 1, -1}, sy[4] = {-1, -1, 1, 1};
      lo0 = sx[a] < 0 ? -1 : 0; hi0 = sx[a] < 0 ? 0 : 1;
      lo1 = sy[a] < 0 ? -1 : 0; hi1 = sy[a] < 0 ? 0 : 1;
    }
    for (q = 0; q < 2; q++)
      for (r = 0; r < (nfn == 4 ? 2 : 1); r++) {
        double xi[2], N[MO_FNODE_MAX], x[3], jac, w;
        xi[0] = 0.5 * (lo0 + hi0) + 0.5 * (hi0 - lo0) * gp[q];
        xi[1] = nfn == 4 ? 0.5 * (lo1 + hi1) + 0.5 * (hi1 - lo1) * gp[r] : 0;
        jac = facet_eval(sc, b, fs, f, xi, NULL, N, x, NULL);
        w = jac * 0.5 * (hi0 - lo0) * (nfn == 4 ? 0.5 * (hi1 - lo1) : 1) * facet_factor(mat, x);
        meas[a] += w;
        for (s = 0; s < nfn; s++) A[a][s] += w * N[s];
      }
  }
  return MO_OK;
}

/* --- building from the case --------------------------------------------------------------------- */

int mo_contact_reserve(mo_contact *C, int nc, mo_ctx *ctx)
{
  int cap = C->nalloc, d = C->dim;
  void *q;
  if (nc <= cap) return MO_OK;
  while (cap < nc) cap = cap ? cap + cap / 8 + 1 : 16; /* an eighth more: the set grows a little at a time (T253) */
#define GROW(ptr, n) if (!(q = mo_realloc(ctx, ptr, (size_t)(n) * sizeof *(ptr)))) return MO_ENOMEM; ptr = q
  GROW(C->g, cap);
  GROW(C->frame, (size_t)cap * (size_t)mo_contact_fstride(C));
  if (C->u0_any) { GROW(C->U0, (size_t)cap * (size_t)d); }
  GROW(C->active, cap);
  GROW(C->key, (size_t)cap * MO_KEY);
  GROW(C->x, (size_t)cap * (size_t)C->sc->dim);
#undef GROW
  C->nalloc = cap;
  return MO_OK;
}

int mo_contact_point_room(mo_contact *C, mo_ctx *ctx)
{
  if (C->npt == C->ptcap) {
    int cap = C->ptcap ? 2 * C->ptcap : 64;
    mo_cpoint *q = mo_realloc(ctx, C->pt, (size_t)cap * sizeof *q);
    if (!q) return MO_ENOMEM;
    C->pt = q;
    C->ptcap = cap;
  }
  return MO_OK;
}

int mo_contact_add_point(mo_contact *C, const mo_cpoint *p, mo_ctx *ctx)
{
  int st = mo_contact_point_room(C, ctx);
  if (st) return st;
  C->pt[C->npt++] = *p;
  return MO_OK;
}

int mo_contact_add_candidate(mo_contact *C, const mo_candidate *c, const int *pts, const double *coef,
                             mo_ctx *ctx)
{
  int k;
  if (C->nc == C->ccap) {
    int cap = C->ccap ? 2 * C->ccap : 64;
    mo_candidate *q = mo_realloc(ctx, C->cand, (size_t)cap * sizeof *q);
    if (!q) return MO_ENOMEM;
    C->cand = q;
    C->ccap = cap;
  }
  if (C->ncoef + c->np > C->coefcap) {
    int cap = C->coefcap ? 2 * C->coefcap : 256;
    int *ip;
    double *dp;
    while (cap < C->ncoef + c->np) cap *= 2;
    ip = mo_realloc(ctx, C->cpt, (size_t)cap * sizeof *ip);
    if (!ip) return MO_ENOMEM;
    C->cpt = ip;
    dp = mo_realloc(ctx, C->ccoef, (size_t)cap * sizeof *dp);
    if (!dp) return MO_ENOMEM;
    C->ccoef = dp;
    C->coefcap = cap;
  }
  C->cand[C->nc] = *c;
  C->cand[C->nc].first = C->ncoef;
  for (k = 0; k < c->np; k++) {
    C->cpt[C->ncoef + k] = pts[k];
    C->ccoef[C->ncoef + k] = coef[k];
  }
  C->ncoef += c->np;
  C->nc++;
  return MO_OK;
}

static int node_fully_prescribed(const mo_scene *sc, int b, int a)
{
  const mo_body *B = &sc->body[b];
  int i;
  if (B->type->flags & MO_BODY_F_RIGID) return B->fixed; /* a rigid mesh's nodes move with it */
  for (i = 0; i < sc->dim; i++)
    if (sc->free_of[B->dof0 + a * sc->dim + i] >= 0) return 0;
  return 1;
}

/* The bodies a pair names on one side: a body, or every body of a group (an entry that made
   several); *n = 0 when the name is neither. */
static int side_bodies(const mo_scene *sc, const char *name, int **list, int *n, mo_ctx *ctx)
{
  int b, k = 0;
  *n = 0;
  *list = NULL;
  if ((b = mo_scene_body_index(sc, name)) >= 0) {
    if (!(*list = mo_malloc(ctx, sizeof(int)))) return MO_ENOMEM;
    (*list)[0] = b;
    *n = 1;
    return MO_OK;
  }
  for (b = 0; b < sc->nbody; b++) k += sc->body[b].group && !strcmp(sc->body[b].group, name);
  if (!k) return MO_OK;
  if (!(*list = mo_malloc(ctx, (size_t)k * sizeof(int)))) return MO_ENOMEM;
  for (b = 0; b < sc->nbody; b++)
    if (sc->body[b].group && !strcmp(sc->body[b].group, name)) (*list)[(*n)++] = b;
  return MO_OK;
}

/* The bodies of one side of pair k (side_bodies), sharing the list of an earlier side that holds
   the same bodies: a pack is on both sides of its own pair and on the slave side of each wall's,
   one list of its bodies instead of five (16 bytes a 2D grain in a box). The lists are read
   only once built (mo_contact_free frees each once, side_owner; T265). */
static int pair_side(const mo_contact *C, int k, int master, const char *name, int **list, int *n, mo_ctx *ctx)
{
  int st, j, s;
  if ((st = side_bodies(C->sc, name, list, n, ctx))) return st;
  if (*n < 2) return MO_OK;
  for (j = 0; j <= k; j++) /* the earlier pairs' sides, and this pair's slave for its master */
    for (s = 0; s < 2 && (j < k || (master && !s)); s++) {
      const int *l = s ? C->pair[j].mb : C->pair[j].sb;
      int nl = s ? C->pair[j].nm : C->pair[j].ns;
      if (l && l != *list && nl == *n && !memcmp(l, *list, (size_t)*n * sizeof **list)) {
        mo_free(*list);
        *list = (int *)l;
        return MO_OK;
      }
    }
  return MO_OK;
}

/* A pair the detection serves (doc/theory.md §12.3): each side is rigid shapes (disks, spheres,
   polygons), a plane (master only), or one mesh body with its set (master: facets; slave:
   nodes). */
/* The error of a pair whose `key` names a set body b does not have (facets: a facet set),
   listing the sets it has. */
static int missing_set(const mo_contact *C, const config_setting_t *pg, const char *key, int b, const char *set,
                       int facets, mo_ctx *ctx)
{
  const mo_body *B = &C->sc->body[b];
  char names[512];
  mo_mesh_set_names(B->mesh, facets, names, sizeof names);
  return mo_case_error(C->sc->cs, mo_cfg_member(pg, key), ctx, "body '%s' has no %s set '%s' (its %s sets: %s)",
                       B->name, facets ? "facet" : "node or facet", set, facets ? "facet" : "node", names);
}

static int check_dynamic(const mo_contact *C, const mo_contact_pair *P, const config_setting_t *pg, mo_ctx *ctx)
{
  const mo_scene *sc = C->sc;
  const mo_case *cs = sc->cs;
  int k;
  for (k = 0; k < P->ns; k++) {
    const mo_body *B = &sc->body[P->sb[k]];
    if (B->type->flags & MO_BODY_F_OBSTACLE)
      return mo_case_error(cs, mo_cfg_member(pg, "slave"), ctx, "a plane is an obstacle: it is the master of its pairs");
    if (B->type->flags & MO_BODY_F_MESH) {
      if (P->ns > 1 || !P->sset[0])
        return mo_case_error(cs, mo_cfg_member(pg, "slave"), ctx, "mesh body '%s' takes part through a node set: "
                             "give 'slave_set'", B->name);
    } else if (P->sset[0])
      return mo_case_error(cs, mo_cfg_member(pg, "slave_set"), ctx, "a %s has no sets", B->type->name);
  }
  for (k = 0; k < P->nm; k++) {
    const mo_body *B = &sc->body[P->mb[k]];
    if (B->type->flags & MO_BODY_F_MESH) {
      if (P->nm > 1 || !P->mset)
        return mo_case_error(cs, mo_cfg_member(pg, "master"), ctx, "mesh body '%s' takes part through a facet set: "
                             "give 'master_set'", B->name);
    } else if (P->mset)
      return mo_case_error(cs, mo_cfg_member(pg, "master_set"), ctx, "a %s has no sets", B->type->name);
    if ((B->type->flags & MO_BODY_F_OBSTACLE) && P->nm > 1)
      return mo_case_error(cs, mo_cfg_member(pg, "master"), ctx, "a group of planes is not a master");
  }
  if (P->mset && P->sset[0])
    return mo_case_error(cs, pg, ctx, "a mesh against a mesh is a pair of sets; here one side is not a single mesh body");
  if (P->mset) {
    const mo_facetset *mfs = mo_mesh_find_facetset(sc->body[P->mb[0]].mesh, P->mset);
    if (!mfs) return missing_set(C, pg, "master_set", P->mb[0], P->mset, 1, ctx);
    if (mfs->n == 0)
      return mo_case_error(cs, mo_cfg_member(pg, "master_set"), ctx, "body '%s' has no facets in set '%s'",
                           sc->body[P->mb[0]].name, P->mset);
  }
  if (P->sset[0] && !mo_mesh_find_nodeset(sc->body[P->sb[0]].mesh, P->sset) &&
      !mo_mesh_find_facetset(sc->body[P->sb[0]].mesh, P->sset))
    return missing_set(C, pg, "slave_set", P->sb[0], P->sset, 0, ctx);
  return MO_OK;
}

/* Points and candidates of pair k. */
static int build_pair(mo_contact *C, int k, const config_setting_t *pg, mo_ctx *ctx)
{
  const mo_scene *sc = C->sc;
  const mo_case *cs = sc->cs;
  mo_contact_pair *P = &C->pair[k];
  const mo_mesh *m = sc->body[P->sbody].mesh;
  const mo_facetset *fs = mo_mesh_find_facetset(m, P->sset);
  int *snodes = NULL, nsn = 0, *excl = NULL, nexcl = 0, *ptof = NULL, *iscand = NULL;
  int i, a, f, st = MO_OK, D = sc->dim, dropped = 0;
  if ((P->reactions == MO_REACT_WEIGHTED || P->colloc == MO_COLLOC_GAUSS) && !fs)
    return mo_case_error(cs, mo_cfg_member(pg, "slave_set"), ctx,
                         "%s reactions and Gauss collocation need a facet set; '%s' is not one",
                         P->reactions == MO_REACT_WEIGHTED ? "weighted" : "concentrated", P->sset);
  if (P->reactions == MO_REACT_WEIGHTED && fs && (fs->kind == MO_FK_LINE3 || fs->kind == MO_FK_TRI6))
    /* a quadratic facet's corner functions change sign: P* would lose J88 Proposition 2 (T194) */
    return mo_case_error(cs, config_lookup(&cs->cfg, "contact.reactions") ? config_lookup(&cs->cfg, "contact.reactions")
                             : mo_cfg_member(pg, "reactions") ? mo_cfg_member(pg, "reactions") : pg, ctx, "weighted reactions need linear facets: the %s elements' quadratic %s have shape "
                         "functions that change sign, and P* would have negative entries (J88 Proposition 2); use "
                         "concentrated reactions (nodes or Gauss collocation)", m->type == MO_EL_T6 ? "T6" : "T10",
                         fs->kind == MO_FK_LINE3 ? "edges" : "faces");
  if (P->exclude && mo_mesh_nodeset_resolve(m, P->exclude, &excl, &nexcl, ctx)) {
    char msg[MO_ERRMSG_MAX];
    snprintf(msg, sizeof msg, "%s", ctx->errmsg);
    mo_ctx_clear_error(ctx);
    return mo_case_error(cs, mo_cfg_member(pg, "exclude"), ctx, "%s", msg);
  }
  /* slave surface nodes, sorted */
  if (fs) {
    snodes = mo_malloc(ctx, (size_t)(fs->n * fs->nfn + 1) * sizeof(int));
    if (!snodes) { st = MO_ENOMEM; goto done; }
    for (i = 0; i < fs->n * fs->nfn; i++) snodes[i] = fs->node[i];
    nsn = fs->n * fs->nfn;
    for (i = 1; i < nsn; i++) { /* insertion sort + unique */
      int v = snodes[i], j = i;
      while (j > 0 && snodes[j - 1] > v) { snodes[j] = snodes[j - 1]; j--; }
      snodes[j] = v;
    }
    for (i = 0, a = 0; i < nsn; i++)
      if (a == 0 || snodes[a - 1] != snodes[i]) snodes[a++] = snodes[i];
    nsn = a;
  } else {
    if (mo_mesh_nodeset_resolve(m, P->sset, &snodes, &nsn, ctx)) {
      char msg[MO_ERRMSG_MAX];
      snprintf(msg, sizeof msg, "%s", ctx->errmsg);
      mo_ctx_clear_error(ctx);
      return mo_case_error(cs, mo_cfg_member(pg, "slave_set"), ctx, "%s", msg);
    }
  }
  if (nsn == 0) {
    st = mo_case_error(cs, mo_cfg_member(pg, "slave_set"), ctx, "the slave set '%s' is empty", P->sset);
    goto done;
  }
  iscand = mo_calloc(ctx, (size_t)m->nnode, sizeof(int));
  ptof = mo_malloc(ctx, (size_t)m->nnode * sizeof(int));
  if (!iscand || !ptof) { st = MO_ENOMEM; goto done; }
  for (i = 0; i < m->nnode; i++) ptof[i] = -1;
  for (i = 0; i < nsn; i++) {
    int n = snodes[i], ex = 0, j;
    for (j = 0; j < nexcl; j++) ex |= excl[j] == n;
    if (ex) continue;
    if (node_fully_prescribed(sc, P->sbody, n)) { dropped++; continue; }
    iscand[n] = 1;
  }
  if (dropped)
    mo_note_skip(ctx, "pair '%s': %d fully prescribed slave node%s are not candidates", P->name,
                 dropped, dropped > 1 ? "s" : "");

  if (P->colloc == MO_COLLOC_GAUSS) {
    mo_quad Q;
    mo_segpt *seg = NULL;
    double *mg = NULL;
    int nseg = 0, segcap = 0, segment = P->integ == MO_INTEG_SEGMENTS && P->master == MO_MASTER_FACETS && fs->nfn > 1;
    const mo_facetset *mfs = segment ? mo_mesh_find_facetset(sc->body[P->mbody].mesh, P->mset) : NULL;
    if (mfs && (fs->kind == MO_FK_LINE3 || fs->kind == MO_FK_TRI6 || mfs->kind == MO_FK_LINE3 || mfs->kind == MO_FK_TRI6)) {
      /* the cuts of (T90) are made between straight facets (T195) */
      mo_note_skip(ctx, "segmented integration on pair '%s' (quadratic facets: Gauss points on whole facets, as "
                   "integration = \"facet\")", P->name);
      mfs = NULL;
    }
    mo_state s0;
    /* the segments are cut in the configuration of the first pairing (u0) */
    memset(&s0, 0, sizeof s0);
    s0.u = sc->u0;
    s0.v = sc->v0;
    if ((st = mo_quad_facet_kind(fs->kind, P->gauss, &Q, ctx))) goto done;
    if (mfs && (st = mo_contact_segment_masters(sc, P->mbody, mfs, &s0, &mg, ctx))) goto done;
    for (f = 0; f < fs->n && !st; f++) {
      int q, nq = Q.n, whole = 0;
      nseg = 0;
      if (mfs) {
        if ((st = mo_contact_segment_facet(sc, P->sbody, fs, f, P->mbody, mfs, mg, &s0, P->gauss, &seg, &nseg, &segcap,
                                           &whole, ctx)))
          break;
        if (nseg) nq = nseg;
        P->nseg_fallback += whole;
      }
      for (q = 0; q < nq; q++) {
        mo_cpoint p;
        mo_candidate c;
        double x[3], N[MO_FNODE_MAX], jac, one = 1;
        const double *xi = nseg ? seg[q].xi : Q.xi[q];
        int pi;
        memset(&p, 0, sizeof p);
        memset(&c, 0, sizeof c);
        p.pair = k;
        p.facet = f;
        p.nn = fs->nfn;
        p.mfacet = -1;
        p.mseg = nseg ? seg[q].mfacet + 1 : 0;
        jac = facet_eval(sc, P->sbody, fs, f, xi, NULL, N, x, NULL);
        for (a = 0; a < fs->nfn; a++) { p.node[a] = fs->node[f * fs->nfn + a]; p.N[a] = N[a]; }
        for (i = 0; i < D; i++) p.x0[i] = x[i];
        pi = C->npt;
        if ((st = mo_contact_add_point(C, &p, ctx))) break;
        c.pair = k;
        c.np = 1;
        c.node = -1;
        c.point = pi;
        c.w = nseg ? seg[q].w : jac * Q.w[q] * facet_factor(sc->body[P->sbody].mat, x);
        c.mu = P->mu;
        if ((st = mo_contact_add_candidate(C, &c, &pi, &one, ctx))) break;
      }
    }
    mo_free(seg);
    mo_free(mg);
    if (!st && P->nseg_fallback)
      mo_note_skip(ctx, "segmented integration on %d of the %d slave facets of pair '%s' (not covered exactly once by "
                   "the master: Gauss points on the whole facet)", P->nseg_fallback, fs->n, P->name);
    goto done;
  }

  /* node collocation: one point per surface node */
  for (i = 0; i < nsn; i++) {
    mo_cpoint p;
    memset(&p, 0, sizeof p);
    p.pair = k;
    p.facet = -1;
    p.nn = 1;
    p.node[0] = snodes[i];
    p.N[0] = 1;
    p.mfacet = -1;
    node_pos(sc, P->sbody, snodes[i], NULL, p.x0);
    ptof[snodes[i]] = C->npt;
    if ((st = mo_contact_add_point(C, &p, ctx))) goto done;
  }
  {
    /* dual cells: A[h][s] = int_{cell h} f_s, meas[h] (doc/theory.md §4.3) */
    double *meas = mo_calloc(ctx, (size_t)m->nnode, sizeof(double));
    int *cidx = mo_malloc(ctx, (size_t)m->nnode * sizeof(int)), ncand = 0;
    int pstar = fs && fs->kind != MO_FK_LINE3 && fs->kind != MO_FK_TRI6;
    int *rowpts = mo_malloc(ctx, (size_t)nsn * sizeof(int));
    double *rowcoef = mo_malloc(ctx, (size_t)nsn * sizeof(double));
    double *Arow = mo_calloc(ctx, (size_t)nsn * (size_t)nsn, sizeof(double));
    int *sidx = mo_malloc(ctx, (size_t)m->nnode * sizeof(int));
    if (!meas || !cidx || !rowpts || !rowcoef || !Arow || !sidx) {
      mo_free(meas); mo_free(cidx); mo_free(rowpts); mo_free(rowcoef); mo_free(Arow); mo_free(sidx);
      st = MO_ENOMEM;
      goto done;
    }
    for (i = 0; i < m->nnode; i++) { cidx[i] = -1; sidx[i] = -1; }
    for (i = 0; i < nsn; i++) {
      sidx[snodes[i]] = i;
      if (iscand[snodes[i]]) cidx[snodes[i]] = ncand++;
    }
    if (fs) {
      double Af[MO_FNODE_MAX][MO_FNODE_MAX], mf[MO_FNODE_MAX];
      for (f = 0; f < fs->n; f++) {
        const int *fn = &fs->node[f * fs->nfn];
        int allc = 1, s, owner[MO_FNODE_MAX];
        for (a = 0; a < fs->nfn; a++) allc &= iscand[fn[a]];
        if (P->ends == MO_ENDS_HALF && !allc) continue;
        if ((st = facet_cells(sc, P->sbody, fs, f, Af, mf, ctx))) break;
        for (a = 0; a < fs->nfn; a++) {
          owner[a] = iscand[fn[a]] ? fn[a] : -1;
          if (owner[a] < 0 && P->ends == MO_ENDS_EXTEND) { /* nearest candidate of the facet */
            double best = HUGE_VAL, xa[3], xb[3];
            int b2, dd;
            node_pos(sc, P->sbody, fn[a], NULL, xa);
            for (b2 = 0; b2 < fs->nfn; b2++) {
              double dist = 0;
              if (!iscand[fn[b2]]) continue;
              node_pos(sc, P->sbody, fn[b2], NULL, xb);
              for (dd = 0; dd < D; dd++) dist += (xa[dd] - xb[dd]) * (xa[dd] - xb[dd]);
              if (dist < best) { best = dist; owner[a] = fn[b2]; }
            }
          }
          if (owner[a] < 0) continue;
          meas[owner[a]] += mf[a];
          for (s = 0; s < fs->nfn; s++)
            Arow[(size_t)sidx[owner[a]] * (size_t)nsn + (size_t)sidx[fn[s]]] += Af[a][s];
        }
      }
    }
    /* the pair's P* over its candidates (square), for tables and the tests */
    C->pp[k].n = ncand;
    C->pp[k].cand = mo_malloc(ctx, (size_t)(ncand ? ncand : 1) * sizeof(int));
    /* (none on quadratic facets: they have no P*, and concentrated reactions no other representation) */
    C->pp[k].P = pstar ? mo_calloc(ctx, (size_t)(ncand ? ncand : 1) * (size_t)(ncand ? ncand : 1), sizeof(double)) : NULL;
    if (!C->pp[k].cand || (pstar && !C->pp[k].P)) st = MO_ENOMEM;
    for (i = 0; !st && i < nsn; i++) {
      int h = snodes[i], s, np = 0;
      mo_candidate c;
      if (!iscand[h]) continue;
      memset(&c, 0, sizeof c);
      c.pair = k;
      c.node = h;
      c.point = ptof[h];
      c.mu = P->mu;
      c.w = fs ? meas[h] : 1;
      if (fs && !(meas[h] > 0)) {
        st = mo_case_error(cs, pg, ctx, "candidate node %d of pair '%s' has an empty dual cell "
                           "(its facets were left out by ends = \"half\")", h, P->name);
        break;
      }
      C->pp[k].cand[cidx[h]] = C->nc;
      for (s = 0; s < nsn; s++) {
        double Ps = pstar ? Arow[(size_t)i * (size_t)nsn + (size_t)s] / meas[h] : (s == i);
        if (pstar && iscand[snodes[s]]) C->pp[k].P[(size_t)cidx[h] * (size_t)ncand + (size_t)cidx[snodes[s]]] = Ps;
        if (P->reactions == MO_REACT_WEIGHTED) {
          if (Ps != 0) { rowpts[np] = ptof[snodes[s]]; rowcoef[np++] = Ps; }
        }
      }
      if (P->reactions == MO_REACT_CONCENTRATED) { rowpts[0] = ptof[h]; rowcoef[0] = 1; np = 1; }
      c.np = np;
      st = mo_contact_add_candidate(C, &c, rowpts, rowcoef, ctx);
    }
    mo_free(meas); mo_free(cidx); mo_free(rowpts); mo_free(rowcoef); mo_free(Arow); mo_free(sidx);
  }
done:
  mo_free(snodes);
  mo_free(excl);
  mo_free(ptof);
  mo_free(iscand);
  return st;
}

/* 1 when every candidate will be a detected contact between rigid shapes (disks, spheres,
   polygons), or a shape and a plane, each shape's dofs all free or all prescribed: what the
   compact records describe (doc/theory.md §12.9). */
static int compact_eligible(const mo_contact *C)
{
  const mo_scene *sc = C->sc;
  int k, i, side;
  if (C->nc_static || !C->ndyn) return 0;
  for (k = 0; k < C->npair; k++) {
    const mo_contact_pair *P = &C->pair[k];
    if (!P->dynamic) return 0;
    for (side = 0; side < 2; side++)
      for (i = 0; i < (side ? P->nm : P->ns); i++) {
        const mo_body *B = &sc->body[side ? P->mb[i] : P->sb[i]];
        int j, nfree = 0;
        if (B->type->flags & MO_BODY_F_OBSTACLE) {
          if (!side) return 0;
          continue;
        }
        if (!(B->type->flags & (MO_BODY_F_BALL | MO_BODY_F_POLYGON)) || !(B->type->flags & MO_BODY_F_RIGID)) return 0;
        for (j = 0; j < B->ndof; j++) nfree += sc->free_of[B->dof0 + j] >= 0;
        if (nfree && nfree != B->ndof) return 0;
      }
  }
  return 1;
}

int mo_contact_build(const mo_scene *sc, mo_contact **out, mo_ctx *ctx)
{
  const mo_case *cs = sc->cs;
  const config_setting_t *cg = config_lookup(&cs->cfg, "contact"), *pl;
  mo_contact *C;
  int k, st = MO_OK, np;
  *out = NULL;
  if (!cg) return MO_OK;
  pl = mo_cfg_member(cg, "pairs");
  np = config_setting_length(pl);
  C = mo_calloc(ctx, 1, sizeof *C);
  if (!C) return MO_ENOMEM;
  C->sc = sc;
  C->dim = sc->dim;
  /* the obstacles' local velocities U0 are stored only when some obstacle moves (else all 0) */
  for (k = 0; k < sc->nbody && !C->u0_any; k++)
    if (sc->body[k].type->flags & MO_BODY_F_OBSTACLE)
      for (np = 0; np < 3; np++) C->u0_any |= sc->body[k].velocity[np] != 0;
  np = config_setting_length(pl);
  C->pair = mo_calloc(ctx, (size_t)np, sizeof *C->pair);
  C->pp = mo_calloc(ctx, (size_t)np, sizeof *C->pp);
  C->solver = mo_strdup(ctx, mo_cfg_string(cg, "solver", "nscd"));
  if (!C->pair || !C->pp || !C->solver) { st = MO_ENOMEM; goto fail; }
  C->signorini = !strcmp(mo_cfg_string(cg, "signorini", "velocity"), "velocity") ? MO_SIGNORINI_VELOCITY : MO_SIGNORINI_POSITION;
  C->repair = !strcmp(mo_cfg_string(cg, "geometry", "reference"), "step");
  C->delassus_always = !strcmp(mo_cfg_string(cg, "delassus", "auto"), "always");
  {
    /* H over the free dofs is H itself when every dof is free and numbered in order */
    int i;
    C->h_alias = sc->nfree == sc->ndof;
    for (i = 0; i < sc->ndof && C->h_alias; i++) C->h_alias = sc->free_of[i] == i;
  }
  C->on_failure_continue = !strcmp(mo_cfg_string(cg, "on_failure", "stop"), "continue");
  {
    const char *pc = mo_cfg_string(cg, "position_correction", "none");
    C->poscorr = !strcmp(pc, "project") ? 1 : !strcmp(pc, "shift") ? 2 : 0;
  }
  for (k = 0; k < np; k++) {
    const config_setting_t *pg = config_setting_get_elem(pl, (unsigned)k);
    mo_contact_pair *P;
    const char *s;
    char name[32];
    int b, j;
    if (!mo_cfg_bool(pg, "active", 1)) {
      mo_note_skip(ctx, "contact pair %d (active = false)", k);
      continue;
    }
    P = &C->pair[C->npair];
    C->npair++;
    snprintf(name, sizeof name, "pair%d", k);
    P->name = mo_strdup(ctx, mo_cfg_string(pg, "name", name));
    P->sset = mo_strdup(ctx, mo_cfg_string(pg, "slave_set", ""));
    s = mo_cfg_string(pg, "master_set", NULL);
    P->mset = s ? mo_strdup(ctx, s) : NULL;
    s = mo_cfg_string(pg, "exclude", NULL);
    P->exclude = s ? mo_strdup(ctx, s) : NULL;
    if (!P->name || !P->sset) { st = MO_ENOMEM; goto fail; }
    for (j = 0; j < C->npair - 1; j++)
      if (!strcmp(C->pair[j].name, P->name)) {
        st = mo_case_error(cs, mo_cfg_member(pg, "name"), ctx, "pair name '%s' is used twice", P->name);
        goto fail;
      }
    P->mu = mo_cfg_float(pg, "mu", 0);
    /* contact.reactions, when given, applies to every pair */
    s = mo_cfg_string(cg, "reactions", NULL);
    P->reactions = !strcmp(s ? s : mo_cfg_string(pg, "reactions", "concentrated"), "weighted") ? MO_REACT_WEIGHTED : MO_REACT_CONCENTRATED;
    P->colloc = !strcmp(mo_cfg_string(pg, "collocation", "nodes"), "gauss") ? MO_COLLOC_GAUSS : MO_COLLOC_NODES;
    P->gauss = mo_cfg_int(pg, "gauss", 2);
    P->integ = !strcmp(mo_cfg_string(pg, "integration", "segments"), "facet") ? MO_INTEG_FACET : MO_INTEG_SEGMENTS;
    s = mo_cfg_string(pg, "ends", "dual");
    P->ends = !strcmp(s, "half") ? MO_ENDS_HALF : !strcmp(s, "extend") ? MO_ENDS_EXTEND : MO_ENDS_DUAL;
    P->off = !strcmp(mo_cfg_string(pg, "off_master", "nearest"), "inactive") ? MO_OFF_INACTIVE : MO_OFF_NEAREST;
    if (P->reactions == MO_REACT_WEIGHTED && P->colloc == MO_COLLOC_GAUSS) {
      st = mo_case_error(cs, mo_cfg_member(pg, "collocation"), ctx, "weighted reactions live on the dual cells of the slave nodes: use collocation = \"nodes\"");
      goto fail;
    }
    if ((st = pair_side(C, C->npair - 1, 0, mo_cfg_string(pg, "slave", ""), &P->sb, &P->ns, ctx)) ||
        (st = pair_side(C, C->npair - 1, 1, mo_cfg_string(pg, "master", ""), &P->mb, &P->nm, ctx)))
      goto fail;
    if (!P->ns) {
      st = mo_case_error(cs, mo_cfg_member(pg, "slave"), ctx, "no body or group named '%s'", mo_cfg_string(pg, "slave", ""));
      goto fail;
    }
    if (!P->nm) {
      st = mo_case_error(cs, mo_cfg_member(pg, "master"), ctx, "no body or group named '%s'", mo_cfg_string(pg, "master", ""));
      goto fail;
    }
    P->sbody = P->sb[0];
    P->mbody = P->mb[0];
    if (P->ns == 1 && P->nm == 1 && P->sbody == P->mbody && (sc->body[P->sbody].type->flags & MO_BODY_F_MESH) &&
        !strcmp(mo_cfg_string(pg, "slave_set", ""), mo_cfg_string(pg, "master_set", ""))) {
      /* every slave point lies on its own master facet: gap 0 everywhere, contact closed from the start */
      st = mo_case_error(cs, mo_cfg_member(pg, "master_set") ? mo_cfg_member(pg, "master_set") : mo_cfg_member(pg, "master"),
                         ctx, "the pair puts set '%s' of body '%s' against itself: a contact pair joins two surfaces",
                         mo_cfg_string(pg, "slave_set", ""), sc->body[P->sbody].name);
      goto fail;
    }
    P->e = mo_cfg_float(pg, "e", 0);
    {
      const mo_body *SB = &sc->body[P->sbody], *MB = &sc->body[P->mbody];
      unsigned sf = SB->type->flags, mf = MB->type->flags;
      int rigid = ((sf | mf) & MO_BODY_F_RIGID) != 0;
      /* a mesh body's set against a plane or another mesh body's facets: fixed slave points */
      int fixed = P->ns == 1 && P->nm == 1 && (sf & MO_BODY_F_MESH) && mo_cfg_member(pg, "slave_set") &&
                  (mf & (MO_BODY_F_OBSTACLE | MO_BODY_F_MESH));
      P->law = !rigid ? MO_LAW_SIGNORINI
               : !strcmp(mo_cfg_string(pg, "law", "impact"), "gap") ? MO_LAW_GAP : MO_LAW_NEWTON;
      if (!rigid && mo_cfg_member(pg, "e")) {
        st = mo_case_error(cs, mo_cfg_member(pg, "e"), ctx, "a restitution coefficient belongs to pairs with a rigid "
                           "body (Newton's impact law); deformable pairs follow contact.signorini");
        goto fail;
      }
      if (!rigid && mo_cfg_member(pg, "law")) {
        st = mo_case_error(cs, mo_cfg_member(pg, "law"), ctx, "a contact law belongs to pairs with a rigid body; "
                           "deformable pairs follow contact.signorini");
        goto fail;
      }
      if (P->law == MO_LAW_GAP && P->e > 0) {
        st = mo_case_error(cs, mo_cfg_member(pg, "e"), ctx, "the gap law has no restitution (e = 0): Newton's "
                           "impact law is law = \"impact\"");
        goto fail;
      }
      if (!fixed) {
        if (P->reactions == MO_REACT_WEIGHTED || P->colloc == MO_COLLOC_GAUSS)
          mo_note_skip(ctx, "weighted reactions and Gauss collocation on pair '%s' (detected contacts are points: "
                       "concentrated reactions)", P->name);
        P->dynamic = 1;
        P->master = (mf & MO_BODY_F_OBSTACLE) ? MO_MASTER_PLANE : MO_MASTER_FACETS;
        P->reactions = MO_REACT_CONCENTRATED;
        P->colloc = MO_COLLOC_NODES;
        if ((st = check_dynamic(C, P, pg, ctx))) goto fail;
        C->ndyn++;
        continue;
      }
      if (!(sf & MO_BODY_F_MESH)) {
        st = mo_case_error(cs, mo_cfg_member(pg, "slave"), ctx, "no mesh body named '%s'", mo_cfg_string(pg, "slave", ""));
        goto fail;
      }
      if (rigid) C->moving_h = 1;
    }
    b = P->sbody;
    if (!mo_mesh_find_facetset(sc->body[b].mesh, P->sset) && !mo_mesh_find_nodeset(sc->body[b].mesh, P->sset) && !strchr(P->sset, '&')) {
      st = missing_set(C, pg, "slave_set", b, P->sset, 0, ctx);
      goto fail;
    }
    b = P->mbody;
    if (sc->body[b].kind == MO_BODY_PLANE) {
      P->master = MO_MASTER_PLANE;
      if (P->mset) {
        st = mo_case_error(cs, mo_cfg_member(pg, "master_set"), ctx, "a plane master has no set");
        goto fail;
      }
    } else {
      const mo_facetset *mfs;
      P->master = MO_MASTER_FACETS;
      if (!P->mset) {
        st = mo_case_error(cs, pg, ctx, "a deformable master needs 'master_set' (a facet set of '%s')", sc->body[b].name);
        goto fail;
      }
      mfs = mo_mesh_find_facetset(sc->body[b].mesh, P->mset);
      if (!mfs || mfs->n == 0) {
        st = !mfs ? missing_set(C, pg, "master_set", b, P->mset, 1, ctx)
                  : mo_case_error(cs, mo_cfg_member(pg, "master_set"), ctx, "body '%s' has no facets in set '%s'",
                                  sc->body[b].name, P->mset);
        goto fail;
      }
      if (b == P->sbody) mo_note_skip(ctx, "self-contact search (pair '%s' pairs a body with itself)", P->name);
    }
    if ((st = build_pair(C, C->npair - 1, pg, ctx))) goto fail;
  }
  if (C->npair == 0) { /* every pair inactive: a scene without contact */
    mo_contact_free(C);
    return MO_OK;
  }
  if (C->nc == 0 && !C->ndyn) {
    st = mo_case_error(cs, pl, ctx, "the contact pairs have no candidate (every slave node is excluded or prescribed)");
    goto fail;
  }
  C->npt_static = C->npt;
  C->nc_static = C->nc;
  C->ncoef_static = C->ncoef;
  if ((st = mo_contact_reserve(C, C->nc + 1, ctx))) goto fail;
  for (k = 0; k < C->nc; k++) {
    const mo_contact_pair *P = &C->pair[C->cand[k].pair];
    int *key = C->key + (size_t)k * MO_KEY;
    (void)P;
    key[0] = -1; key[1] = k; key[2] = key[3] = key[4] = 0;
  }
  {
    int fr = 1;
    for (k = 0; k < C->npair; k++) fr &= C->pair[k].mu == 0;
    if (fr) mo_note_skip(ctx, "friction (mu = 0 on every pair)");
    fr = 1;
    for (k = 0; k < C->npair; k++) fr &= C->pair[k].master == MO_MASTER_PLANE && !C->pair[k].dynamic;
    if (fr && !C->repair && !C->moving_h)
      mo_note_skip(ctx, "geometric loop and H rebuilds (plane masters: the pairing and the frames do not change)");
  }
  /* eps_g of (T71): resting contacts of rigid bodies closed through the round-off of their gaps */
  for (k = 0; k < C->npair; k++)
    if (C->pair[k].law != MO_LAW_SIGNORINI) C->gtol = 1e-9 * mo_contact_smallest_size(C);
  if (C->ndyn) {
    C->moving_h = 1; /* detected contacts move with their bodies */
    C->alert = mo_cfg_float(cg, "alert", -1);
    C->skin = mo_cfg_float(cg, "skin", -1);
    {
      const char *vl = mo_cfg_string(cg, "verlet", "auto");
      C->verlet = !strcmp(vl, "global") ? 1 : !strcmp(vl, "blocks") ? 2 : 0;
    }
    C->pd_min = mo_cfg_int(cg, "detect_split_min", MO_PDETECT_MIN);
    C->pd_dist = mo_cfg_bool(cg, "distributed_set", 0);
    C->h = sc->time.dt;
    if ((st = mo_contact_detect_setup(C, ctx))) goto fail;
    C->compact_ok = compact_eligible(C);
    {
      /* the granular path, when the back end reads compact records (an unknown name is the
         driver's to report) and W is not wanted at every step */
      const mo_contact_solver_type *T = mo_contact_solver_find(C->solver);
      C->compact = C->compact_ok && T && (T->needs & MO_NEEDS_GRAINS) && !C->delassus_always &&
                   mo_cfg_bool(cg, "compact", 1);
      if (C->compact)
        mo_note_skip(ctx, "contact points and H (every candidate joins rigid shapes and obstacles: compact contact "
                     "records, doc/theory.md §12.9)");
    }
  } else
    mo_note_skip(ctx, "contact detection (no pair with a rigid shape: the candidates are fixed)");
  {
    /* the reference configuration: u0, the bodies at rest in their reference orientation */
    mo_state s0;
    memset(&s0, 0, sizeof s0);
    s0.u = sc->u0;
    s0.v = sc->v0;
    if ((st = mo_contact_geometry(C, &s0, 0, 1, ctx))) goto fail;
  }
  /* bodies that start inside one another: a mistake in the case (an overlap the first step would
     push apart violently), refused beyond a millionth of the smallest body */
  for (k = C->nc_static; k < C->nc; k++)
    if (C->g[k] < -1000 * C->gtol) {
      mo_cpoint pb;
      const mo_cpoint *p = mo_contact_cand_point(C, k, &pb);
      const config_setting_t *bl = config_lookup(&cs->cfg, "bodies");
      st = mo_case_error(cs, config_setting_get_elem(bl, (unsigned)sc->body[p->sb].entry), ctx,
                         "bodies '%s' and '%s' overlap by %.3g m at t = 0 (the tolerance is %.3g m): move them apart",
                         sc->body[p->sb].name, sc->body[p->mb].name, -C->g[k], 1000 * C->gtol);
      goto fail;
    }
  *out = C;
  return MO_OK;
fail:
  mo_contact_free(C);
  return st;
}
