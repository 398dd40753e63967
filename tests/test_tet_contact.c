/* test_tet_contact.c: contact on the facets of tetrahedra and quadratic triangles (doc/theory.md
   §2.4, (T193)-(T195)): the closest point on flat and curved triangular faces and on curved 3-node
   edges against a brute-force search, the P* of triangular faces (J88 Proposition 2, partition of
   unity, a uniform density giving the consistent forces of the facet loads), weighted reactions
   refused on quadratic facets, and the columns of H at the Gauss points and nodes of T10 faces
   against rigid motions and measures. */
#include "config.h"
#include <moreau/moreau.h>
#include "contact_internal.h" /* the closest point and facet maps of the pairing */
#include "testlib.h"

static const char *block_fmt =
  "bodies = (\n"
  "  { name = \"m\";\n"
  "    mesh = { generator = \"%s\"; size = %s; elements = %s; element = \"%s\"; };\n"
  "    material = { E = 2.0e11; nu = 0.3; rho = 7800.0; }; fix = ( { set = \"%s\"; } ); },\n"
  "  { name = \"ground\"; type = \"plane\"; point = %s; normal = %s; }\n"
  ");\n"
  "time = { scheme = \"quasistatic\"; steps = 1; };\n"
  "contact = { pairs = ( { name = \"p\"; slave = \"m\"; slave_set = \"%s\"; master = \"ground\"; %s } ); };\n";

/* A block of the element type with its contact pair on the plane below (extra: more pair keys). */
static int block(const char *el, const char *extra, mo_case **cs, mo_scene **sc, mo_contact **C, mo_ctx *ctx)
{
  char text[4096];
  int d3 = strcmp(el, "T6") != 0, st;
  snprintf(text, sizeof text, block_fmt, d3 ? "box" : "rectangle", d3 ? "[1.0, 1.0, 0.5]" : "[1.0, 0.5]",
           d3 ? "[3, 2, 1]" : "[4, 1]", el, d3 ? "zmax" : "top", d3 ? "[0.0, 0.0, 0.0]" : "[0.0, 0.0]",
           d3 ? "[0.0, 0.0, 1.0]" : "[0.0, 1.0]", d3 ? "zmin" : "bottom", extra);
  mo_ctx_init(ctx);
  ctx->verbosity = 0;
  *C = NULL;
  st = tl_scene(text, "tet.cfg", cs, sc, ctx);
  if (!st) st = mo_contact_build(*sc, C, ctx);
  return st;
}

static void release(mo_case *cs, mo_scene *sc, mo_contact *C)
{
  mo_contact_free(C);
  mo_scene_free(sc);
  mo_case_free(cs);
}

/* The point of facet f at reference coordinates s (reference configuration) and its distance
   to x. */
static double facet_dist(const mo_scene *sc, const mo_facetset *fs, int f, const double *s, const double *x)
{
  double N[MO_FNODE_MAX], q[3], d = 0;
  int i;
  mo_contact_facet_eval(sc, 0, fs, f, s, NULL, N, q, NULL);
  for (i = 0; i < sc->dim; i++) d += (x[i] - q[i]) * (x[i] - q[i]);
  return sqrt(d);
}

/* Brute force: the smallest distance from x to facet f over a grid of 60 intervals per direction
   of its reference domain (the projection must be at least as near as every point of it). */
static double facet_dist_bf(const mo_scene *sc, const mo_facetset *fs, int f, const double *x)
{
  const int n = 60;
  double best = HUGE_VAL, s[2];
  int i, j;
  for (i = 0; i <= n; i++)
    for (j = 0; j <= (mo_facet_kind_dim(fs->kind) == 2 ? n : 0); j++) {
      if (fs->kind == MO_FK_TRI3 || fs->kind == MO_FK_TRI6) {
        if (i + j > n) continue;
        s[0] = (double)i / n;
        s[1] = (double)j / n;
      } else {
        s[0] = -1 + 2.0 * i / n;
        s[1] = fs->kind == MO_FK_QUAD4 ? -1 + 2.0 * j / n : 0;
      }
      best = fmin(best, facet_dist(sc, fs, f, s, x));
    }
  return best;
}

/* The middle nodes of the top facets raised by a bump (the facets curved), then points above and
   beside the top projected on every facet: each projection at least as near as the brute force's
   best point, and orthogonal to the facet where it lies on it. */
static void test_projection(const char *el)
{
  mo_ctx ctx;
  mo_case *cs = NULL;
  mo_scene *sc = NULL;
  mo_contact *C = NULL;
  const mo_facetset *fs;
  mo_mesh *m;
  int D, f, k, a, worse = 0, nin = 0, nout = 0, curved = 0;
  double orth = 0, excess = 0;
  if (block(el, "", &cs, &sc, &C, &ctx)) {
    ok(0, "%s block: %s", el, ctx.errmsg);
    release(cs, sc, C);
    return;
  }
  m = sc->body[0].mesh;
  D = m->dim;
  fs = mo_mesh_find_facetset(m, D == 3 ? "zmax" : "top");
  if (mo_eltype_get(m->type)->order == 2)
    for (f = 0; f < fs->n; f++)
      for (a = mo_eltype_get(m->type)->nfv; a < fs->nfn; a++) {
        double *x = &m->x[fs->node[f * fs->nfn + a] * D];
        x[D - 1] += 0.08 * sin(M_PI * x[0]) * (D == 3 ? sin(M_PI * x[1]) + 0.3 : 1);
        curved = 1;
      }
  for (k = 0; k < 24; k++) {
    double x[3];
    /* points over the top and past its edges, above and below it */
    x[0] = -0.2 + 1.4 * fmod(0.6180339887 * (k + 1), 1.0);
    x[1] = D == 3 ? -0.2 + 1.4 * fmod(0.7548776662 * (k + 1), 1.0) : 0.5 + 0.3 * sin(3.0 * k);
    if (D == 3) x[2] = 0.5 + 0.3 * sin(3.0 * k);
    for (f = 0; f < fs->n; f++) {
      double xi[2], N[MO_FNODE_MAX], q[3], n[3], d, dbf;
      int inside;
      d = mo_contact_project_facet(sc, 0, fs, f, x, NULL, xi, N, q, n, &inside);
      dbf = facet_dist_bf(sc, fs, f, x);
      excess = fmax(excess, (d - dbf) / dbf);
      worse += d > dbf * (1 + 1e-12);
      if (inside) {
        /* (x - q) normal to both tangents: central differences of x(s) */
        double t[2][3], s1[2], s2[2], q1[3], q2[3], r = 0, tn[2] = {0, 0};
        int c, i, fd = mo_facet_kind_dim(fs->kind);
        for (c = 0; c < fd; c++) {
          double Nn[MO_FNODE_MAX], len = 0;
          s1[0] = xi[0]; s1[1] = xi[1]; s2[0] = xi[0]; s2[1] = xi[1];
          s1[c] -= 1e-6; s2[c] += 1e-6;
          mo_contact_facet_eval(sc, 0, fs, f, s1, NULL, Nn, q1, NULL);
          mo_contact_facet_eval(sc, 0, fs, f, s2, NULL, Nn, q2, NULL);
          for (i = 0; i < D; i++) { t[c][i] = q2[i] - q1[i]; len += t[c][i] * t[c][i]; }
          for (i = 0; i < D; i++) tn[c] += t[c][i] * (x[i] - q[i]) / sqrt(len);
        }
        for (i = 0; i < D; i++) r += (x[i] - q[i]) * (x[i] - q[i]);
        for (c = 0; c < fd; c++) orth = fmax(orth, fabs(tn[c]) / sqrt(r));
        nin++;
      } else
        nout++;
    }
  }
  ok(worse == 0 && nin > 12 && nout > 12, "%s%s: %d projections on the facets, %d on them and %d clamped, none farther "
     "than the best point of a grid of 60 intervals per direction (excess %.1e)", el, curved ? " (curved facets)" : "", nin + nout,
     nin, nout, excess);
  ok(orth < 1e-8, "%s: x - q is normal to the facet where the projection lies on it (|cos| %.1e)", el, orth);
  release(cs, sc, C);
}

static void up_cb(const double *x, const double *n, void *data, double *t)
{
  (void)x;
  (void)n;
  t[0] = t[1] = 0;
  t[2] = *(const double *)data;
}

/* P* of T3 faces (the bottom of a T4 block, every candidate's cell whole: ends = half). */
static void test_weighted_t4(void)
{
  mo_ctx ctx;
  mo_case *cs = NULL;
  mo_scene *sc = NULL;
  mo_contact *C = NULL;
  const double *P;
  const int *cands;
  const mo_facetset *fs;
  int n, i, j, nonneg = 1, rows = 1, nc, d, a, f;
  double rowsum = 0, p = 3e6, *r, *F, *Fref, ferr = 0, fbig = 0, wsum = 0;
  if (block("T4", "reactions = \"weighted\"; ends = \"half\";", &cs, &sc, &C, &ctx)) {
    ok(0, "T4 weighted: %s", ctx.errmsg);
    release(cs, sc, C);
    return;
  }
  mo_contact_pair_P(C, 0, &P, &n, &cands);
  for (i = 0; i < n; i++) {
    double s = 0;
    int pos = 0;
    for (j = 0; j < n; j++) {
      nonneg &= P[i * n + j] >= 0;
      pos |= P[i * n + j] > 0;
      s += P[i * n + j];
    }
    rows &= pos;
    rowsum = fmax(rowsum, fabs(s - 1));
  }
  ok(n == 12 && nonneg && rows && rowsum < 1e-14, "T4 faces, weighted: P* of the 12 candidates has non-negative "
     "entries, non-zero rows (J88 Proposition 2) and rows summing to 1 (%.1e)", rowsum);
  /* a uniform density rho_h = p |cell_h| gives the facet loads' consistent forces of p */
  nc = mo_contact_ncandidates(C);
  d = mo_contact_dim(C);
  r = calloc((size_t)(nc * d), sizeof *r);
  F = calloc((size_t)sc->ndof, sizeof *F);
  Fref = calloc((size_t)sc->ndof, sizeof *Fref);
  for (a = 0; a < nc; a++) {
    r[a * d] = p * mo_contact_candidate(C, a)->w;
    wsum += mo_contact_candidate(C, a)->w;
  }
  mo_csc_gaxpy(mo_contact_H_full(C), 1, r, 0, F);
  fs = mo_mesh_find_facetset(sc->body[0].mesh, "zmin");
  for (f = 0; f < fs->n; f++) {
    double fe[3 * MO_FNODE_MAX]; /* the plane's push p along +z on the bottom */
    mo_facet_load(sc->body[0].mesh, fs, f, sc->body[0].mat, up_cb, &p, fe, &ctx);
    for (a = 0; a < fs->nfn; a++) Fref[fs->node[f * fs->nfn + a] * 3 + 2] += fe[3 * a + 2];
  }
  for (i = 0; i < sc->ndof; i++) {
    ferr = fmax(ferr, fabs(F[i] - Fref[i]));
    fbig = fmax(fbig, fabs(Fref[i]));
  }
  ok(ferr <= 1e-12 * fbig && fabs(wsum - 1) < 1e-14, "T4 faces, weighted: a uniform density gives the consistent "
     "forces of the facet loads (max error %.1e of %.3g N), the cells cover the bottom (%.15g)", ferr, fbig, wsum);
  free(r);
  free(F);
  free(Fref);
  release(cs, sc, C);
}

/* Weighted reactions on quadratic facets are refused, naming why. */
static void test_weighted_quadratic(void)
{
  static const char *els[2] = {"T10", "T6"};
  int k;
  for (k = 0; k < 2; k++) {
    mo_ctx ctx;
    mo_case *cs = NULL;
    mo_scene *sc = NULL;
    mo_contact *C = NULL;
    int st = block(els[k], "reactions = \"weighted\";", &cs, &sc, &C, &ctx);
    ok(st == MO_EINPUT && strstr(ctx.errmsg, "weighted reactions need linear facets") &&
           strstr(ctx.errmsg, k ? "T6 elements' quadratic edges" : "T10 elements' quadratic faces") &&
           strstr(ctx.errmsg, "J88 Proposition 2") && strstr(ctx.errmsg, "tet.cfg:"),
       "%s: weighted reactions refused (%.200s)", els[k], ctx.errmsg);
    release(cs, sc, C);
  }
}

/* The columns of H at T10 faces' Gauss points and nodes: a rigid translation of the block gives
   every candidate U = F v; the Gauss weights add up to the bottom's area; the nodes' weights are
   their HRZ shares, positive, adding up to the area too. */
static void test_h_t10(void)
{
  static const char *colloc[2] = {"collocation = \"gauss\"; gauss = 3;", ""};
  int k;
  for (k = 0; k < 2; k++) {
    mo_ctx ctx;
    mo_case *cs = NULL;
    mo_scene *sc = NULL;
    mo_contact *C = NULL;
    int nc, d, a, i, j, minw = 1;
    double v[3] = {0.3, -0.2, 0.7}, *vf, *U, err = 0, wsum = 0;
    if (block("T10", colloc[k], &cs, &sc, &C, &ctx)) {
      ok(0, "T10 %s: %s", k ? "nodes" : "Gauss points", ctx.errmsg);
      release(cs, sc, C);
      continue;
    }
    nc = mo_contact_ncandidates(C);
    d = mo_contact_dim(C);
    vf = calloc((size_t)sc->ndof, sizeof *vf);
    U = calloc((size_t)(nc * d), sizeof *U);
    for (i = 0; i < sc->ndof; i++) vf[i] = v[i % 3];
    mo_csc_gatxpy(mo_contact_H_full(C), 1, vf, 0, U);
    for (a = 0; a < nc; a++) {
      const double *Fr = mo_contact_frames(C) + (size_t)a * 9;
      for (i = 0; i < 3; i++) {
        double want = 0;
        for (j = 0; j < 3; j++) want += Fr[i * 3 + j] * v[j];
        err = fmax(err, fabs(U[a * d + i] - want));
      }
      wsum += mo_contact_candidate(C, a)->w;
      minw &= mo_contact_candidate(C, a)->w > 0;
    }
    ok(err < 1e-14 && fabs(wsum - 1) < 1e-13 && minw,
       "T10 faces, %s: H^T v = F v for a rigid translation (%.1e) over %d candidates; weights positive, summing "
       "to the area (%.15g)", k ? "node collocation" : "Gauss collocation (gauss = 3)", err, nc, wsum);
    free(vf);
    free(U);
    release(cs, sc, C);
  }
}

int main(void)
{
  test_projection("T4");
  test_projection("T10");
  test_projection("T6");
  test_weighted_t4();
  test_weighted_quadratic();
  test_h_t10();
  return done_testing();
}
