/* test_contact.c: the core's half of contact: P* (J88 §4.4), Proposition 2, H against rigid
   motions and uniform densities, pairing on tilted, curved and 3D masters, the Delassus operator
   against a dense reference, the natural-map residual, and the FCLIB round trip. */
#include "config.h"
#include <moreau/moreau.h>
#include "testlib.h"

#include <unistd.h>

/* The GRECO block of shared/data/greco/README.md: 16 x 8 T3 cells, bottom on the plane y = 0,
   symmetry at x = 0.04, corner held; reactions and ends as asked. */
static const char *greco_fmt =
  "bodies = (\n"
  "  { name = \"block\";\n"
  "    mesh = { generator = \"rectangle\"; size = [0.04, 0.04]; elements = [16, 8]; element = \"T3\"; diagonal = \"right\"; };\n"
  "    material = { E = 1.3e11; nu = 0.2; rho = 1.0; };\n"
  "    fix = ( { set = \"right\"; dofs = [\"x\"]; }, { set = \"right&bottom\"; dofs = [\"y\"]; } );\n"
  "  },\n"
  "  { name = \"ground\"; type = \"plane\"; point = [0.0, 0.0]; normal = [0.0, 1.0]; }\n"
  ");\n"
  "time = { scheme = \"quasistatic\"; steps = 1; };\n"
  "contact = { pairs = ( { slave = \"block\"; slave_set = \"bottom\"; master = \"ground\"; mu = 1.0;\n"
  "                        reactions = \"%s\"; ends = \"%s\"; } ); };\n";

static int build(const char *text, mo_case **cs, mo_scene **sc, mo_contact **C, mo_ctx *ctx)
{
  int st = tl_scene(text, "test.cfg", cs, sc, ctx);
  if (!st) st = mo_contact_build(*sc, C, ctx);
  if (st) diag("%s", ctx->errmsg);
  return st;
}

static void release(mo_case *cs, mo_scene *sc, mo_contact *C)
{
  mo_contact_free(C);
  mo_scene_free(sc);
  mo_case_free(cs);
}

static void test_P(void)
{
  char text[4096];
  const char *ends[3] = {"dual", "half", "extend"};
  int e;
  for (e = 0; e < 3; e++) {
    mo_ctx ctx;
    mo_case *cs = NULL;
    mo_scene *sc = NULL;
    mo_contact *C = NULL;
    const double *P;
    const int *cands;
    int n, i, j, ok1 = 1, nonneg = 1, rows = 1;
    mo_ctx_init(&ctx);
    snprintf(text, sizeof text, greco_fmt, "weighted", ends[e]);
    if (build(text, &cs, &sc, &C, &ctx)) { ok(0, "GRECO scene (%s)", ends[e]); continue; }
    ok(mo_contact_ncandidates(C) == 16, "ends = %s: 16 candidates (the held corner is not one)", ends[e]);
    mo_contact_pair_P(C, 0, &P, &n, &cands);
    for (i = 0; i < n; i++) {
        int pos = 0;
      for (j = 0; j < n; j++) {
        double want = 0;
        if (j == i) want = 0.75;
        else if (abs(j - i) == 1) want = (i == 0 || (i == n - 1 && e == 1)) ? 0.25 : 0.125;
        /* extend: the last row is checked below */
        if ((e != 2 || i != n - 1) && fabs(P[i * n + j] - want) > 1e-14) ok1 = 0;
        if (P[i * n + j] < 0) nonneg = 0;
        pos |= P[i * n + j] > 0;
      }
      if (!pos) rows = 0;
    }
    if (e == 0) ok(ok1, "P* for 16 uniform candidates, ends = dual: [3/4 1/4], [1/8 3/4 1/8], last row [1/8 3/4] (Jean's runs)");
    if (e == 1) ok(ok1, "P* for 16 uniform candidates, ends = half: Jean's printed P* (last row [1/4 3/4])");
    if (e == 2) {
      /* node 16 owns [36.25, 40] mm: averages over 1.5 cells of f15 and f16 */
      /* lengths in mm: int f15 = 0.25 x 1.25, int f16 = 0.75 x 1.25 + 0.5 x 2.5, cell 3.75 */
      double p1615 = 0.3125 / 3.75, p1616 = 2.1875 / 3.75;
      ok(ok1 && fabs(P[15 * n + 14] - p1615) < 1e-14 && fabs(P[15 * n + 15] - p1616) < 1e-14,
         "ends = extend: node 16's cell takes the held corner's half edge (%.6f %.6f)", P[15 * n + 14], P[15 * n + 15]);
    }
    ok(nonneg && rows, "ends = %s: P* has non-negative entries and non-zero rows (J88 Proposition 2)", ends[e]);
    release(cs, sc, C);
  }
}

/* A uniform pressure as weighted reactions rho_h = p |cell_h| gives the consistent nodal forces
   of the pressure (what the facet loads compute). */
static void test_uniform_density(void)
{
  char text[4096];
  mo_ctx ctx;
  mo_case *cs = NULL;
  mo_scene *sc = NULL;
  mo_contact *C = NULL;
  int a, i, nc, d, ok1 = 1;
  double p = 5e7, *r, *F;
  mo_ctx_init(&ctx);
  snprintf(text, sizeof text, greco_fmt, "weighted", "half");
  if (build(text, &cs, &sc, &C, &ctx)) { ok(0, "scene"); return; }
  nc = mo_contact_ncandidates(C);
  d = mo_contact_dim(C);
  r = calloc((size_t)(nc * d), sizeof *r);
  F = calloc((size_t)sc->ndof, sizeof *F);
  for (a = 0; a < nc; a++) r[a * d] = p * mo_contact_candidate(C, a)->w; /* rho = density x measure */
  mo_csc_gaxpy(mo_contact_H_full(C), 1, r, 0, F);
  /* consistent forces of p on the 15 edges between candidates 1..16 (2.5 mm, thickness 1) */
  for (i = 0; i < 16; i++) {
    double want = p * 0.0025 * ((i == 0 || i == 15) ? 0.5 : 1);
    if (fabs(F[2 * i + 1] - want) > 1e-6 * want) ok1 = 0;
  }
  ok(ok1, "a uniform density gives the exact consistent nodal forces (p L / 2 at the ends, p L inside)");
  free(r);
  free(F);
  release(cs, sc, C);
}

/* H^T v reproduces a rigid translation and a rigid rotation (relative to a fixed plane). */
static void test_rigid(void)
{
  char text[4096];
  mo_ctx ctx;
  mo_case *cs = NULL;
  mo_scene *sc = NULL;
  mo_contact *C = NULL;
  int a, k, nc, d, okt = 1, okr = 1;
  double *v, *U;
  const char *reac[2] = {"concentrated", "weighted"};
  for (k = 0; k < 2; k++) {
    mo_ctx_init(&ctx);
    snprintf(text, sizeof text, greco_fmt, reac[k], "dual");
    /* free the symmetry plane so that rigid motions are admissible for H_full */
    if (build(text, &cs, &sc, &C, &ctx)) { ok(0, "scene"); return; }
    nc = mo_contact_ncandidates(C);
    d = mo_contact_dim(C);
    v = calloc((size_t)sc->ndof, sizeof *v);
    U = calloc((size_t)(nc * d), sizeof *U);
    for (a = 0; a < sc->ndof / 2; a++) { v[2 * a] = 0.3; v[2 * a + 1] = -0.7; }
    mo_csc_gatxpy(mo_contact_H_full(C), 1, v, 0, U);
    for (a = 0; a < nc; a++)
      if (fabs(U[a * d] + 0.7) > 1e-14 || fabs(U[a * d + 1] - 0.3) > 1e-14) okt = 0;
    ok(okt, "%s: H^T v of a rigid translation is (U_n, U_t) = (v_y, v_x) at every candidate", reac[k]);
    /* rotation omega about the origin: v = omega (-y, x); on y = 0: U_n = omega x, U_t = 0 */
    for (a = 0; a < sc->ndof / 2; a++) {
      const double *x = &sc->body[0].mesh->x[2 * a];
      v[2 * a] = -2.0 * x[1];
      v[2 * a + 1] = 2.0 * x[0];
    }
    mo_csc_gatxpy(mo_contact_H_full(C), 1, v, 0, U);
    for (a = 0; a < nc; a++) {
      /* concentrated: omega x at the node; weighted: the mean over the dual cell, omega times
         its centroid (dual cells: half cell [0, 1.25 mm] at the free end, full cells else) */
      double xa = mo_contact_point(C, mo_contact_candidate(C, a)->point)->x0[0], xc = xa;
      if (k == 1 && a == 0) xc = 0.000625;
      if (fabs(U[a * d] - 2.0 * xc) > 1e-14 || fabs(U[a * d + 1]) > 1e-14) okr = 0;
    }
    ok(okr, "%s: H^T v of a rigid rotation is (omega x, 0), x the %s", reac[k],
       k ? "dual cell's centroid (P averages over the cell)" : "node");
    free(v);
    free(U);
    release(cs, sc, C);
  }
}

static const char *tilted =
  "bodies = (\n"
  "  { name = \"b\"; mesh = { generator = \"rectangle\"; size = [1.0, 0.5]; elements = [4, 2]; };\n"
  "    material = { E = 1.0e6; nu = 0.3; rho = 1.0; }; },\n"
  "  { name = \"p\"; type = \"plane\"; point = [0.0, -0.1]; normal = [-0.6, 0.8]; }\n"
  ");\n"
  "time = { dt = 1.0e-3; steps = 1; };\n"
  "contact = { pairs = ( { slave = \"b\"; slave_set = \"bottom\"; master = \"p\"; } ); };\n";

static const char *circle =
  "bodies = (\n"
  "  { name = \"pad\"; mesh = { generator = \"rectangle\"; origin = [-0.01, 0.0301]; size = [0.02, 0.005]; elements = [4, 1]; };\n"
  "    material = { E = 1.0e9; nu = 0.3; rho = 1.0; }; fix = ( { set = \"top\"; } ); },\n"
  "  { name = \"disk\"; mesh = { generator = \"disk\"; radius = 0.03; core = 8; rings = 4; };\n"
  "    material = { E = 1.0e9; nu = 0.3; rho = 1.0; }; fix = ( { set = \"all\"; } ); }\n"
  ");\n"
  "time = { dt = 1.0e-3; steps = 1; };\n"
  "contact = { pairs = ( { slave = \"pad\"; slave_set = \"bottom\"; master = \"disk\"; master_set = \"boundary\"; } ); };\n";

static const char *faces =
  "bodies = (\n"
  "  { name = \"top\"; mesh = { generator = \"box\"; origin = [0.1, 0.15, 1.002]; size = [0.5, 0.5, 0.5]; elements = [3, 3, 2]; };\n"
  "    material = { E = 1.0e6; nu = 0.3; rho = 1.0; }; },\n"
  "  { name = \"base\"; mesh = { generator = \"box\"; size = [1.0, 1.0, 1.0]; elements = [2, 2, 2]; };\n"
  "    material = { E = 1.0e6; nu = 0.3; rho = 1.0; }; fix = ( { set = \"zmin\"; } ); }\n"
  ");\n"
  "time = { dt = 1.0e-3; steps = 1; };\n"
  "contact = { pairs = ( { slave = \"top\"; slave_set = \"zmin\"; master = \"base\"; master_set = \"zmax\"; mu = 0.3; } ); };\n";

static void test_pairing(void)
{
  mo_ctx ctx;
  mo_case *cs = NULL;
  mo_scene *sc = NULL;
  mo_contact *C = NULL;
  int a, good = 1;
  /* tilted plane: g = (x - p) . n */
  mo_ctx_init(&ctx);
  if (!build(tilted, &cs, &sc, &C, &ctx)) {
    const double *g = mo_contact_gaps(C), *F = mo_contact_frames(C);
    for (a = 0; a < mo_contact_ncandidates(C); a++) {
      const double *x = mo_contact_point(C, mo_contact_candidate(C, a)->point)->x0;
      double want = (x[0] - 0) * -0.6 + (x[1] + 0.1) * 0.8;
      if (fabs(g[a] - want) > 1e-14 || fabs(F[a * 4] + 0.6) > 1e-15 || fabs(F[a * 4 + 1] - 0.8) > 1e-15 ||
          fabs(F[a * 4 + 2] - 0.8) > 1e-15 || fabs(F[a * 4 + 3] - 0.6) > 1e-15)
        good = 0;
    }
    ok(good, "tilted plane: gaps (x - p).n and frames (n, t) = ((-0.6, 0.8), (0.8, 0.6))");
  } else ok(0, "tilted plane scene");
  release(cs, sc, C);
  /* curved master (a circle of 32 segments): gap = distance to the chord, normal of the chord */
  mo_ctx_init(&ctx);
  cs = NULL; sc = NULL; C = NULL;
  good = 1;
  if (!build(circle, &cs, &sc, &C, &ctx)) {
    const double *g = mo_contact_gaps(C), *F = mo_contact_frames(C);
    for (a = 0; a < mo_contact_ncandidates(C); a++) {
      const double *x = mo_contact_point(C, mo_contact_candidate(C, a)->point)->x0;
      /* the chords of the 32-gon (vertices at -pi/4 + k pi/16): the chord the point projects
         onto, or, in the dead zone above a vertex, the nearest chord clamped to the vertex */
      double best = 1e9, bestd = 1e9, bestc = 0, bn[2] = {0, 0}, cn[2] = {0, 0};
      int k, inside = 0;
      const mo_cpoint *pt = mo_contact_point(C, mo_contact_candidate(C, a)->point);
      for (k = 0; k < 32; k++) {
        double t0 = -M_PI / 4 + M_PI / 2 * k / 8.0, t1 = t0 + M_PI / 16;
        double ax = 0.03 * cos(t0), ay = 0.03 * sin(t0), bx = 0.03 * cos(t1), by = 0.03 * sin(t1);
        double tx = bx - ax, ty = by - ay, L = sqrt(tx * tx + ty * ty), s = ((x[0] - ax) * tx + (x[1] - ay) * ty) / (L * L);
        double nx = ty / L, ny = -tx / L, sc_ = s < 0 ? 0 : s > 1 ? 1 : s, qx = ax + sc_ * tx, qy = ay + sc_ * ty;
        double dist = hypot(x[0] - qx, x[1] - qy);
        if (s >= 0 && s <= 1 && dist < best) { best = dist; bn[0] = nx; bn[1] = ny; inside = 1; }
        if (dist < bestd - 1e-15) { /* nearest chord, clamped: gap along its normal */
          bestd = dist;
          bestc = (x[0] - qx) * nx + (x[1] - qy) * ny;
          cn[0] = nx;
          cn[1] = ny;
        }
      }
      if (!inside) { bn[0] = cn[0]; bn[1] = cn[1]; }
      if (pt->off == inside) good = 0;
      if (fabs(F[a * 4] - bn[0]) > 1e-12 || fabs(F[a * 4 + 1] - bn[1]) > 1e-12) good = 0;
      if (!(g[a] > 0) || fabs(g[a] - (inside ? best : bestc)) > 1e-12) good = 0;
    }
    ok(good, "circle-discretized master: gaps to the chords and chord normals (%d candidates; the one above a vertex is flagged off the master and paired with the nearest chord)", mo_contact_ncandidates(C));
  } else ok(0, "circle scene");
  release(cs, sc, C);
  /* 3D face: gap 2 mm above z = 1, normal +z, tangents x, y */
  mo_ctx_init(&ctx);
  cs = NULL; sc = NULL; C = NULL;
  good = 1;
  if (!build(faces, &cs, &sc, &C, &ctx)) {
    const double *g = mo_contact_gaps(C), *F = mo_contact_frames(C);
    ok(mo_contact_ncandidates(C) == 16 && mo_contact_dim(C) == 3, "3D faces: 16 candidates, local dimension 3");
    for (a = 0; a < mo_contact_ncandidates(C); a++) {
      const double *f = &F[a * 9];
      if (fabs(g[a] - 0.002) > 1e-14 || fabs(f[2] - 1) > 1e-14 || fabs(f[3] - 1) > 1e-14 || fabs(f[7] - 1) > 1e-14) good = 0;
    }
    ok(good, "3D face: gaps 2 mm, frame n = +z, t = +x, s = +y");
    /* H: U_n = v_slave,z - v_master,z interpolated on the master face */
    {
      double *v = calloc((size_t)sc->ndof, sizeof *v), *U = calloc((size_t)(16 * 3), sizeof *U);
      int b0 = sc->body[1].dof0, n;
      for (n = 0; n < sc->body[1].mesh->nnode; n++) v[b0 + 3 * n + 2] = sc->body[1].mesh->x[3 * n]; /* master v_z = x */
      mo_csc_gatxpy(mo_contact_H_full(C), 1, v, 0, U);
      good = 1;
      for (a = 0; a < 16; a++) {
        const double *x = mo_contact_point(C, mo_contact_candidate(C, a)->point)->x0;
        if (fabs(U[3 * a] + x[0]) > 1e-14) good = 0;
      }
      ok(good, "3D face: H interpolates the master velocity at the projection (U_n = -x)");
      free(v);
      free(U);
    }
  } else ok(0, "3D face scene");
  release(cs, sc, C);
}

/* W = H^T What^-1 H: symmetric, positive semi-definite, equal to a dense reference. */
extern void dsyev_(const char *jobz, const char *uplo, const int *n, double *a, const int *lda,
                   double *w, double *work, const int *lwork, int *info);
extern void dgesv_(const int *n, const int *nrhs, double *a, const int *lda, int *ipiv, double *b,
                   const int *ldb, int *info);

static void test_delassus(void)
{
  char text[4096];
  mo_ctx ctx;
  mo_case *cs = NULL;
  mo_scene *sc = NULL;
  mo_contact *C = NULL;
  mo_stepper *S = NULL;
  mo_delassus *D = NULL;
  const mo_csc *H, *Wh;
  double *Wd = NULL, *A, *B, *Wref, *ev, work[4096], maxd = 0, maxw = 0, asym = 0;
  int m, n, i, j, k, info, lwork = 4096, *ipiv, rebuilt;
  mo_ctx_init(&ctx);
  snprintf(text, sizeof text, greco_fmt, "weighted", "dual");
  /* a coarse dynamic version of the block so that What = M + h^2 theta^2 K */
  {
    char *p = strstr(text, "elements = [16, 8]");
    memcpy(p, "elements = [ 4, 2]", 18);
    p = strstr(text, "scheme = \"quasistatic\"; steps = 1;");
    memcpy(p, "dt = 1.0e-6;        steps = 1;     ", 34);
  }
  if (build(text, &cs, &sc, &C, &ctx) || mo_stepper_create(sc, &S, &ctx) || mo_delassus_create(&D, &ctx)) {
    ok(0, "Delassus scene: %s", ctx.errmsg);
    return;
  }
  H = mo_contact_H(C);
  Wh = mo_stepper_matrix(S);
  m = H->ncol;
  n = H->nrow;
  ok(mo_delassus_update(D, H, mo_contact_h_version(C), mo_stepper_inverse(S), 1.0, 2, &rebuilt, &ctx) == MO_OK && rebuilt,
     "W built (%d x %d from %d free dofs)", m, m, n);
  mo_delassus_update(D, H, mo_contact_h_version(C), mo_stepper_inverse(S), 1.0, 2, &rebuilt, &ctx);
  ok(!rebuilt, "W reused while H and What are unchanged");
  mo_delassus_dense(D, &Wd, &ctx);
  /* dense reference: What \ H by LAPACK, then H^T (.) */
  A = malloc((size_t)n * n * sizeof *A);
  B = calloc((size_t)n * m, sizeof *B);
  Wref = calloc((size_t)m * m, sizeof *Wref);
  ipiv = malloc((size_t)n * sizeof *ipiv);
  mo_csc_to_dense(Wh, &ev, &ctx);
  memcpy(A, ev, (size_t)n * n * sizeof *A);
  mo_free(ev);
  for (j = 0; j < m; j++)
    for (k = H->p[j]; k < H->p[j + 1]; k++) B[(size_t)j * n + H->i[k]] = H->x[k];
  dgesv_(&n, &m, A, &n, ipiv, B, &n, &info);
  for (i = 0; i < m; i++)
    for (j = 0; j < m; j++) {
      double s = 0;
      for (k = H->p[i]; k < H->p[i + 1]; k++) s += H->x[k] * B[(size_t)j * n + H->i[k]];
      Wref[i * m + j] = s;
    }
  for (i = 0; i < m * m; i++) {
    if (fabs(Wd[i] - Wref[i]) > maxd) maxd = fabs(Wd[i] - Wref[i]);
    if (fabs(Wref[i]) > maxw) maxw = fabs(Wref[i]);
  }
  for (i = 0; i < m; i++)
    for (j = 0; j < m; j++) if (fabs(Wd[i * m + j] - Wd[j * m + i]) > asym) asym = fabs(Wd[i * m + j] - Wd[j * m + i]);
  ok(maxd < 1e-12 * maxw, "W matches the dense LAPACK reference (max diff %.2e of %.2e)", maxd, maxw);
  ok(asym < 1e-12 * maxw, "W is symmetric (%.2e)", asym);
  {
    /* W x by blocks against the dense product: x in full, and x without tangential components
       (the normal columns alone, T160) */
    double *x = malloc((size_t)m * sizeof *x), *y = malloc((size_t)m * sizeof *y), e[2] = {0, 0}, ymax[2] = {0, 0};
    int pass, d = mo_delassus_dim(D);
    for (pass = 0; pass < 2; pass++) {
      for (i = 0; i < m; i++) x[i] = pass == 1 && i % d ? 0 : sin(1.0 + i) * 1e-3;
      mo_delassus_mult(D, x, 0, y);
      for (i = 0; i < m; i++) {
        double s = 0;
        for (j = 0; j < m; j++) s += Wd[i * m + j] * x[j];
        e[pass] = fmax(e[pass], fabs(y[i] - s));
        ymax[pass] = fmax(ymax[pass], fabs(s));
      }
    }
    ok(d > 1 && e[0] <= 1e-14 * ymax[0] && e[1] <= 1e-14 * ymax[1],
       "W x by blocks = the dense product, x full (%.2e of %.2e) and normal only (%.2e of %.2e)", e[0], ymax[0], e[1],
       ymax[1]);
    free(x);
    free(y);
  }
  ev = malloc((size_t)m * sizeof *ev);
  memcpy(A, Wd, (size_t)m * m * sizeof *A);
  dsyev_("N", "U", &m, A, &m, ev, work, &lwork, &info);
  ok(info == 0 && ev[0] > -1e-12 * ev[m - 1], "W is positive semi-definite (eigenvalues %.3e .. %.3e)", ev[0], ev[m - 1]);
  /* the correction What^-1 H r from the stored columns equals a direct solve */
  {
    double *r = calloc((size_t)m, sizeof *r), *dx = calloc((size_t)n, sizeof *dx), *hr = calloc((size_t)n, sizeof *hr);
    double *dx2 = calloc((size_t)n, sizeof *dx2), e = 0, mx = 0;
    for (i = 0; i < m; i++) r[i] = sin(1.0 + i);
    mo_delassus_apply_Cinv(D, H, mo_stepper_inverse(S), r, dx, &ctx);
    mo_csc_gaxpy(H, 1, r, 0, hr);
    mo_linsolver_solve(mo_stepper_solver(S), hr, dx2, &ctx);
    for (i = 0; i < n; i++) { if (fabs(dx[i] - dx2[i]) > e) e = fabs(dx[i] - dx2[i]); if (fabs(dx2[i]) > mx) mx = fabs(dx2[i]); }
    ok(e < 1e-13 * mx, "What^-1 H r from the kept columns equals a solve (%.2e)", e);
    free(r); free(dx); free(hr); free(dx2);
  }
  free(A); free(B); free(Wref); free(ipiv); free(ev);
  mo_free(Wd);
  mo_delassus_free(D);
  mo_stepper_free(S);
  release(cs, sc, C);
}

static void test_natural_map(void)
{
  double mu[3] = {0.5, 0.3, 0.0};
  /* hand-made exact solutions, one of each kind (d = 2): */
  double r_open[2] = {0, 0}, U_open[2] = {0.2, -1.0};          /* separated: U_n > 0, r = 0 */
  double r_stick[2] = {2.0, 0.5}, U_stick[2] = {0, 0};         /* stick: U = 0, r inside the cone */
  double r_slide[2] = {2.0, -1.0}, U_slide[2] = {0, 3.0};      /* slide: r_t = -mu r_n sign(U_t) */
  double r3[3] = {1.0, 0.3 * 0.6, 0.3 * 0.8}, U3[3] = {0, -0.6, -0.8}; /* 3D slide */
  double U_wrong[2] = {0, -3.0};  /* slip in the direction of the friction force */
  is_close(mo_fc_natural_map_unit(2, 0.5, r_open, U_open), 0, 1e-30, "natural map: open contact exact");
  is_close(mo_fc_natural_map_unit(2, 0.5, r_stick, U_stick), 0, 1e-30, "natural map: sticking contact exact");
  is_close(mo_fc_natural_map_unit(2, 0.5, r_slide, U_slide), 0, 1e-30, "natural map: sliding contact exact");
  is_close(mo_fc_natural_map_unit(3, 0.3, r3, U3), 0, 1e-30, "natural map: 3D sliding contact exact");
  ok(mo_fc_natural_map_unit(2, 0.5, r_slide, U_wrong) > 0, "natural map: positive when the friction force does not oppose the slip");
  ok(mo_fc_natural_map_unit(2, 0.5, U_open, r_open) > 0, "natural map: positive for a penetrating gap velocity");
  {
    double r[2] = {1, 0}, U[2] = {0.1, 0};
    ok(mo_fc_natural_map_unit(2, 0.0, r, U) > 0, "natural map: positive when r_n > 0 and U_n > 0 (complementarity)");
    (void)mu;
  }
  {
    /* frictionless and separating with no tangential velocity at all: the cone degenerates to
       the half-line r_t = 0, r_n >= 0, and z = (-U_n, 0) projects to its apex */
    double r[3] = {0, 0, 0}, U[3] = {2.5e4, 0, 0}, z[2] = {-3.0, 0};
    is_close(mo_fc_natural_map_unit(2, 0.0, r, U), 0, 1e-30, "natural map: frictionless open contact, U_t = 0, exact");
    is_close(mo_fc_natural_map_unit(3, 0.0, r, U), 0, 1e-30, "natural map: 3D frictionless open contact, U_t = 0, exact");
    mo_fc_project_cone(2, 0.0, z);
    ok(z[0] == 0 && z[1] == 0, "cone projection: mu = 0, z_n < 0, z_t = 0 goes to the apex");
  }
  {
    double z[2] = {1.0, 2.0};
    mo_fc_project_cone(2, 0.5, z);
    is_close(z[0], (1.0 + 0.5 * 2.0) / 1.25, 1e-15, "cone projection onto the surface (normal)");
    is_close(z[1], 0.5 * z[0], 1e-15, "cone projection onto the surface (tangent)");
  }
}

#ifdef HAVE_SICONOS
#include <siconos/numerics/FrictionContactProblem.h>
#include <siconos/numerics/NumericsMatrix.h>
#include <siconos/numerics/fc3d_compute_error.h>
#include <siconos/numerics/SolverOptions.h>
#endif

static void test_fclib(void)
{
  mo_ctx ctx;
  int nc = 3, d = 3, m = 9, i, j, d2, nc2, good = 1;
  double W[81], q[9], mu[3] = {0.3, 0.5, 0.1}, r[9], U[9], *q2 = NULL, *mu2 = NULL, *Wd = NULL;
  mo_csc *W2 = NULL;
  char path[256];
  mo_ctx_init(&ctx);
  if (!mo_fclib_available()) {
    ok(1, "# SKIP this build has no FCLIB");
    return;
  }
  for (i = 0; i < m; i++)
    for (j = 0; j < m; j++) W[i * m + j] = (i == j ? 3.0 : 0) + 0.25 * cos(i + j);
  for (i = 0; i < m; i++) { q[i] = sin(2.0 * i) - 0.3; r[i] = 0.1 * i; U[i] = -0.2 * i; }
  mo_mkdir_p("tests/out", &ctx);
  snprintf(path, sizeof path, "tests/out/fclib-roundtrip-%ld.hdf5", (long)getpid());
  ok(mo_fclib_write(path, d, nc, W, q, mu, r, U, "round trip", &ctx) == MO_OK, "FCLIB write %s", ctx.errmsg);
  ok(mo_fclib_read(path, &d2, &nc2, &W2, &q2, &mu2, &ctx) == MO_OK && d2 == 3 && nc2 == 3, "FCLIB read back");
  if (W2) {
    mo_csc_to_dense(W2, &Wd, &ctx); /* column-major */
    for (i = 0; i < m; i++)
      for (j = 0; j < m; j++) if (Wd[(size_t)j * m + i] != W[i * m + j]) good = 0;
    for (i = 0; i < m; i++) if (q2[i] != q[i]) good = 0;
    for (i = 0; i < nc; i++) if (mu2[i] != mu[i]) good = 0;
  } else good = 0;
  ok(good, "FCLIB round trip is exact (W, q, mu bit for bit)");
#ifdef HAVE_SICONOS
  {
    /* our residual against Siconos' fc3d_compute_error on the same data */
    /* Debian's Siconos is built without FCLIB: hand it the data read back from the file */
    double *Wc = malloc((size_t)m * m * sizeof *Wc), *qc = malloc((size_t)m * sizeof *qc),
           *muc = malloc(3 * sizeof *muc), err = 0, ours, w[9];
    FrictionContactProblem *pb;
    for (i = 0; i < m; i++)
      for (j = 0; j < m; j++) Wc[(size_t)j * m + i] = Wd ? Wd[(size_t)j * m + i] : 0;
    memcpy(qc, q2 ? q2 : q, (size_t)m * sizeof *qc);
    memcpy(muc, mu2 ? mu2 : mu, 3 * sizeof *muc);
    pb = frictionContactProblem_new_with_data(3, 3, NM_create_from_data(NM_DENSE, m, m, Wc), qc, muc);
    if (pb) {
      double qn = 0;
      for (i = 0; i < m; i++) qn += q[i] * q[i];
      qn = sqrt(qn);
      fc3d_compute_error(pb, r, w, 1e-20, NULL, qn, &err);
      ours = mo_fc_natural_map(3, 3, mu, r, w, qn);
      {
        double e10;
        fc3d_compute_error(pb, r, w, 1e-20, NULL, 10.0, &e10);
        is_close(mo_fc_natural_map(3, 3, mu, r, w, 10.0), e10, 1e-13 * e10,
                 "relative to max(|q|, |r|, |U|): also with a larger |q| (%.6e)", e10);
      }
      ok(err > 0, "Siconos computes a residual for a non-solution (%.6e)", err);
      is_close(ours, err, 1e-13 * err, "natural-map residual equals Siconos' fc3d_compute_error (%.6e)", ours);
      frictionContactProblem_free(pb);
    } else ok(0, "Siconos problem from the FCLIB data");
  }
#endif
  unlink(path);
  mo_csc_free(W2);
  mo_free(q2);
  mo_free(mu2);
  mo_free(Wd);
}


/* The shared FCLIB problems: local ones read as they are, global ones reduced to
   W = H^T M^-1 H, q = H^T M^-1 f + w (their stored "solutions" have v = 0 and do not satisfy
   M v = H r + f, so they are not used as references). */
static void test_fclib_shared(void)
{
  static const char *files[] = {"Box_Stacks-i0122-82-5", "Capsules-i125-1213",
                                "LMGC_100_PR_PerioBox-i00361-60-03000", "Spheres-i099-356-679"};
  const char *shared = getenv("MOREAU_SHARED");
  size_t k;
  char probe[1024];
  FILE *pf;
  if (shared) {
    snprintf(probe, sizeof probe, "%s/data/fclib/%s.hdf5", shared, files[0]);
    pf = fopen(probe, "rb");
    if (pf) fclose(pf);
    else shared = NULL;
  }
  if (!mo_fclib_available() || !shared) {
    ok(1, "# SKIP no FCLIB, or no ../shared/data/fclib beside the source tree");
    return;
  }
  for (k = 0; k < MO_COUNT(files); k++) {
    char path[1024];
    mo_ctx ctx;
    int d, nc;
    mo_csc *W = NULL;
    double *q = NULL, *mu = NULL;
    int st;
    mo_ctx_init(&ctx);
    snprintf(path, sizeof path, "%s/data/fclib/%s.hdf5", shared, files[k]);
    st = mo_fclib_read(path, &d, &nc, &W, &q, &mu, &ctx);
    ok(st == MO_OK && d == 3 && nc > 0, "%s: read (%d contacts; W asymmetry %.1e) %s", files[k], st ? 0 : nc,
       W ? mo_csc_asymmetry(W) : 0.0, ctx.errmsg);
    mo_csc_free(W);
    mo_free(q);
    mo_free(mu);
  }
}

int main(void)
{
  test_fclib_shared();
  test_P();
  test_uniform_density();
  test_rigid();
  test_pairing();
  test_delassus();
  test_natural_map();
  test_fclib();
  return done_testing();
}
