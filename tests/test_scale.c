/* test_scale.c: linear algebra at scale (doc/theory.md §13, issue 16). On small scenes of every
   element type, with concentrated, weighted and Gauss-point reactions, plane and mesh masters, the
   three time schemes: the Delassus operator from the trailing block of a factorization that
   orders the contact dofs last equals the one built by a solve per column (T151); the correction
   What^-1 H r and the split step (T153) equal the unsplit ones; the factor has long indices and
   solves against a dense LU; the memory check refuses, or falls back to CHOLMOD's order, with its
   figures (T154); the phases of a run add up to its wall time (T158). */
#include "config.h"
#include "testlib.h"

#include <math.h>

extern void dgesv_(const int *n, const int *nrhs, double *a, const int *lda, int *ipiv, double *b, const int *ldb,
                   int *info);

/* A deterministic random number in [-1, 1]. */
static double rnd(unsigned long *s)
{
  *s = *s * 6364136223846793005UL + 1442695040888963407UL;
  return (double)(*s >> 11) / (double)(1UL << 53) * 2 - 1;
}

/* One scene: the stepper without (0) and with (1) the contact dofs last, W, the correction and
   the split step compared. */
typedef struct {
  mo_ctx ctx;
  mo_case *cs;
  mo_scene *sc;
  mo_contact *C;
  mo_stepper *S[2];
  mo_delassus *D[2];
  mo_state s;
} scene;

static void scene_free(scene *X)
{
  int k;
  for (k = 0; k < 2; k++) {
    mo_delassus_free(X->D[k]);
    mo_stepper_free(X->S[k]);
  }
  mo_state_release(&X->s);
  mo_contact_free(X->C);
  mo_scene_free(X->sc);
  mo_case_free(X->cs);
}

static int scene_open(scene *X, const char *name, const char *text)
{
  int st, k;
  memset(X, 0, sizeof *X);
  mo_ctx_init(&X->ctx);
  X->ctx.verbosity = 0;
  st = tl_scene(text, name, &X->cs, &X->sc, &X->ctx);
  if (!st) st = mo_contact_build(X->sc, &X->C, &X->ctx);
  for (k = 0; k < 2 && !st; k++) {
    st = mo_stepper_create_contact(X->sc, X->C, k, &X->S[k], &X->ctx);
    if (!st) st = mo_delassus_create(&X->D[k], &X->ctx);
  }
  if (!st) st = mo_state_alloc(X->sc, &X->s, &X->ctx);
  if (!st) st = mo_stepper_init_state(X->S[0], &X->s, &X->ctx);
  if (!st) st = mo_contact_geometry(X->C, &X->s, 0, 1, &X->ctx);
  return st;
}

/* W r + beta y (mo_delassus_mult) against the dense product with W by one solve per column (Wd):
   r without tangential components (frictionless impulses: the normal column's contiguous copies,
   T176) and r in full (friction: every entry of the blocks), beta 0 and 1. */
static void check_mult(const char *name, const mo_delassus *D, const double *Wd, const double *r, int m, int d)
{
  double *x = malloc((size_t)m * sizeof *x), *y = malloc((size_t)m * sizeof *y), *ref = malloc((size_t)m * sizeof *ref);
  int pass, i, j;
  for (pass = 0; pass < 2 * (d > 1 ? 2 : 1); pass++) {
    const int nonly = d > 1 && pass < 2, beta = pass % 2;
    double ymax, dy;
    for (i = 0; i < m; i++) x[i] = nonly && i % d ? 0 : r[i];
    for (i = 0; i < m; i++) {
      double acc = 0;
      for (j = 0; j < m; j++) acc += Wd[(size_t)i * m + j] * x[j];
      y[i] = 0.5 + 0.25 * r[(i + 1) % m];
      ref[i] = acc + beta * y[i];
    }
    mo_delassus_mult(D, x, beta, y);
    ymax = maxabs(ref, m);
    dy = maxdiff(ref, y, m);
    ok(ymax > 0 && dy <= 1e-12 * ymax, "%s: W r + %d y (%s) equals the dense product: max difference %.2e of %.3e",
       name, beta, d == 1 ? "1D" : nonly ? "r_t = 0: the normal column's copies" : "r_t != 0: the whole blocks", dy, ymax);
  }
  free(x);
  free(y);
  free(ref);
}

/* W (the solve per column) against W (the trailing block), the correction What^-1 H r, and the
   split step against predict + correct, on the scene `text`. schur: whether the new path must
   be taken (0 for scenes whose contact rows change, where both are the old path). */
static void check_scene(const char *name, const char *text, int schur)
{
  scene X;
  const mo_csc *H, *Hf;
  double *W[2] = {NULL, NULL}, *r = NULL, *dx[2] = {NULL, NULL}, *x[2] = {NULL, NULL}, *imp = NULL, *xs = NULL;
  int k, d, m, n, nd, rebuilt, i, nlast;
  unsigned long seed = 12345;
  double wmax, wd, cmax, cd, xmax, xd;
  if (scene_open(&X, name, text)) {
    ok(0, "%s: set-up: %s", name, X.ctx.errmsg);
    scene_free(&X);
    return;
  }
  H = mo_contact_H(X.C);
  Hf = mo_contact_H_full(X.C);
  d = mo_contact_dim(X.C);
  m = H->ncol;
  n = H->nrow;
  nd = X.sc->ndof;
  mo_stepper_contact_dofs(X.S[1], &nlast);
  for (k = 0; k < 2; k++)
    if (mo_delassus_update(X.D[k], H, mo_contact_h_version(X.C), mo_stepper_inverse(X.S[k]), 1.0, d, &rebuilt, &X.ctx) ||
        mo_delassus_dense(X.D[k], &W[k], &X.ctx)) {
      ok(0, "%s: W: %s", name, X.ctx.errmsg);
      goto done;
    }
  wmax = maxabs(W[0], m * m);
  wd = maxdiff(W[0], W[1], m * m);
  ok(!mo_delassus_from_schur(X.D[0]) && mo_delassus_from_schur(X.D[1]) == schur && (!schur || nlast > 0),
     "%s: W by %s (%d contact dofs last of %d nodal free dofs)", name, schur ? "the trailing block" : "solves (no fixed contact rows)",
     nlast, X.sc->nfe_free);
  ok(wmax > 0 && wd <= 1e-12 * wmax, "%s: W (%d x %d) from the trailing block equals W by one solve per column: "
     "max difference %.2e of max |W| %.3e", name, m, m, wd, wmax);
  /* W's normal entries kept contiguous (T164): every block's W_ab,nn, against W by one solve per
     column */
  {
    double nd_max = 0;
    int a, p, cnt, got = 1, nblk = 0;
    for (a = 0; a < m / d && got; a++) {
      const int *beta;
      const double *wn;
      cnt = mo_delassus_row_normal(X.D[1], a, &beta, &wn);
      got = wn != NULL;
      for (p = 0; p < cnt && got; p++, nblk++)
        nd_max = fmax(nd_max, fabs(wn[p] - W[0][(size_t)a * d * m + (size_t)beta[p] * d]));
    }
    ok(got && nblk > 0 && nd_max <= 1e-12 * wmax, "%s: W's normal entries alone (%d blocks) equal W_nn by one solve "
       "per column: max difference %.2e of %.3e", name, nblk, nd_max, wmax);
  }
  /* the correction What^-1 H r for a random r */
  r = malloc((size_t)m * sizeof *r);
  for (i = 0; i < m; i++) r[i] = rnd(&seed);
  check_mult(name, X.D[1], W[0], r, m, d);
  for (k = 0; k < 2; k++) {
    dx[k] = calloc((size_t)n + 1, sizeof *dx[k]);
    if (mo_delassus_apply_Cinv(X.D[k], H, mo_stepper_inverse(X.S[k]), r, dx[k], &X.ctx)) {
      ok(0, "%s: correction: %s", name, X.ctx.errmsg);
      goto done;
    }
  }
  cmax = maxabs(dx[0], n);
  cd = maxdiff(dx[0], dx[1], n);
  ok(cmax > 0 && cd <= 1e-12 * cmax, "%s: What^-1 H r equal: max difference %.2e of %.3e", name, cd, cmax);
  /* the split step against predict + correct with the impulse H r over full dofs */
  imp = calloc((size_t)nd + 1, sizeof *imp);
  xs = calloc((size_t)nd + 1, sizeof *xs);
  mo_csc_gaxpy(Hf, 1, r, 0, imp);
  for (k = 0; k < 2; k++) x[k] = calloc((size_t)nd + 1, sizeof *x[k]);
  if (mo_stepper_predict(X.S[0], &X.s, x[0], &X.ctx) || mo_stepper_correct(X.S[0], imp, xs, &X.ctx)) {
    ok(0, "%s: predict, correct: %s", name, X.ctx.errmsg);
    goto done;
  }
  for (i = 0; i < nd; i++) x[0][i] += xs[i];
  if (!schur) {
    ok(!mo_stepper_split_ready(X.S[1]), "%s: no split step without contact dofs last", name);
    goto done;
  }
  if (mo_stepper_predict_split(X.S[1], &X.s, x[1], &X.ctx) || mo_stepper_correct_split(X.S[1], imp, x[1], &X.ctx)) {
    ok(0, "%s: split step: %s", name, X.ctx.errmsg);
    goto done;
  }
  xmax = maxabs(x[0], nd);
  xd = maxdiff(x[0], x[1], nd);
  ok(xmax > 0 && xd <= 1e-12 * xmax, "%s: the split step (forward solve, contact dofs, correction, one backward solve) "
     "equals predict + correct: max difference %.2e of %.3e", name, xd, xmax);
done:
  for (k = 0; k < 2; k++) {
    mo_free(W[k]);
    free(dx[k]);
    free(x[k]);
  }
  free(r);
  free(imp);
  free(xs);
  scene_free(&X);
}

/* --- the scenes -------------------------------------------------------------------------------- */

static const char *bars_1d =
  "bodies = (\n"
  "  { name = \"left\"; mesh = { generator = \"bar\"; origin = -1.0005; length = 1.0; elements = 30; };\n"
  "    material = { E = 2.0e11; rho = 7800.0; area = 4.0e-4; }; initial = { velocity = [10.0]; }; },\n"
  "  { name = \"right\"; mesh = { generator = \"bar\"; origin = 0.0005; length = 1.0; elements = 20; };\n"
  "    material = { E = 2.0e11; rho = 7800.0; area = 4.0e-4; }; initial = { velocity = [-10.0]; }; fix = ( { set = \"right\"; } ); }\n"
  ");\n"
  "time = { scheme = \"theta\"; theta = 1.0; dt = 2.0e-6; steps = 1; };\n"
  "contact = { pairs = ( { slave = \"left\"; slave_set = \"right\"; master = \"right\"; master_set = \"left\"; } ); };\n";

static const char *blocks_2d =
  "bodies = (\n"
  "  { name = \"lower\"; mesh = { generator = \"rectangle\"; size = [1.0, 0.5]; elements = [4, 2]; };\n"
  "    material = { E = 2.0e11; nu = 0.3; rho = 7800.0; }; fix = ( { set = \"bottom\"; } ); },\n"
  "  { name = \"upper\"; mesh = { generator = \"rectangle\"; origin = [0.0, 0.5]; size = [1.0, 0.5]; elements = [6, 3]; };\n"
  "    material = { E = 1.0e11; nu = 0.3; rho = 7800.0; }; body_force = [0.0, -9.81]; }\n"
  ");\n"
  "time = { scheme = \"theta\"; dt = 1.0e-5; steps = 1; };\n"
  "contact = { pairs = ( { slave = \"lower\"; slave_set = \"top\"; master = \"upper\"; master_set = \"bottom\"; collocation = \"gauss\"; mu = 0.2; } ); };\n";

static void test_scenes(void)
{
  char text[4096], src[4096];
  char path[4200];
  check_scene("1D bars (bar2), mesh master", bars_1d, 1);
  snprintf(text, sizeof text, tl_block_2d, "Q4", "plane_strain", "scheme = \"theta\"; dt = 1.0e-5; steps = 1;", "mu = 0.3;");
  check_scene("2D Q4 plane strain, concentrated, friction", text, 1);
  snprintf(text, sizeof text, tl_block_2d, "T3", "plane_stress", "scheme = \"theta\"; dt = 1.0e-5; steps = 1;",
           "reactions = \"weighted\";");
  check_scene("2D T3 plane stress, weighted reactions", text, 1);
  snprintf(text, sizeof text, tl_block_2d, "Q4", "axisymmetric", "scheme = \"theta\"; dt = 1.0e-5; steps = 1;",
           "collocation = \"gauss\"; gauss = 2;");
  check_scene("2D Q4 axisymmetric, Gauss points", text, 1);
  snprintf(text, sizeof text, tl_block_2d, "Q4", "plane_strain", "scheme = \"newmark\"; beta = 0.3025; gamma = 0.6; dt = 1.0e-5; steps = 1;",
           "mu = 0.3; reactions = \"weighted\";");
  check_scene("2D Q4, Newmark, weighted reactions, friction", text, 1);
  check_scene("2D Q4 on Q4 (mesh master, Gauss points on segments)", blocks_2d, 1);
  snprintf(text, sizeof text, tl_box_3d, "mu = 0.3;");
  check_scene("3D H8 on a plane, concentrated, friction", text, 1);
  snprintf(text, sizeof text, tl_box_3d, "reactions = \"weighted\";");
  check_scene("3D H8 on a plane, weighted reactions", text, 1);
  check_scene("3D H8 on H8 (mesh master)", tl_boxes_3d, 1);
  /* the quasi-static box of the shipped case (W = H^T K^-1 H) */
  tl_case_path(path, sizeof path, "box-on-plane/case.cfg");
  {
    FILE *f = fopen(path, "r");
    size_t len = f ? fread(src, 1, sizeof src - 1, f) : 0;
    if (f) fclose(f);
    src[len] = '\0';
    if (len) check_scene("3D H8 quasi-static (cases/box-on-plane)", src, 1);
    else ok(0, "cases/box-on-plane/case.cfg not read");
  }
  /* a rigid shape detected at every step: no fixed contact rows, the old path on both sides */
  tl_case_path(path, sizeof path, "rod-struck-by-mass/case.cfg");
  {
    FILE *f = fopen(path, "r");
    size_t len = f ? fread(src, 1, sizeof src - 1, f) : 0;
    if (f) fclose(f);
    src[len] = '\0';
    if (len) check_scene("rigid block on a Q4 bar (detected contacts)", src, 0);
    else ok(0, "cases/rod-struck-by-mass/case.cfg not read");
  }
}

/* --- a whole run: rods-1d through the split step against its history of the unsplit path ----- */

static void test_history(void)
{
  const char *sets[] = {"output.precision=17", "output.every=10"};
  char ref[2300], out[600], csv[700];
  tl_table A, B;
  int st, i, j, ok_rows = 0;
  double worst = 0;
  tl_case_path(ref, sizeof ref, "rods-1d");
  snprintf(out, sizeof out, "tests/out/scale-rods-%ld", (long)getpid());
  st = tl_run(ref, NULL, sets, 2, out, "rods-1d", NULL);
  snprintf(ref, sizeof ref, "%s/tests/ref/rods-1d-history.csv", tl_srcdir());
  snprintf(csv, sizeof csv, "%s/history.csv", out);
  memset(&A, 0, sizeof A);
  memset(&B, 0, sizeof B);
  if (st || tl_table_read(ref, &A) || tl_table_read(csv, &B) || A.nrow != B.nrow || A.ncol != B.ncol) {
    ok(0, "rods-1d: the run and its reference history (%d x %d against %d x %d rows x columns)", B.nrow, B.ncol,
       A.nrow, A.ncol);
    goto done;
  }
  /* every column to 1e-10 of its largest value (the unsplit path's history: tests/test_taylor;
     the rounding of 300 steps of 2002 dofs adds up to a few 1e-12);
     the contact residual, a round-off measure (0 to 2e-16), to 1e-12 itself */
  for (j = 0; j < A.ncol; j++) {
    double scale = 0, diff = 0;
    for (i = 0; i < A.nrow; i++) {
      scale = fmax(scale, fabs(tl_num(&A, i, j)));
      diff = fmax(diff, fabs(tl_num(&A, i, j) - tl_num(&B, i, j)));
    }
    if (!strcmp(A.name[j], "contact.residual")) scale = 1;
    if (scale > 0) worst = fmax(worst, diff / scale);
  }
  ok_rows = A.nrow;
  ok(worst <= 1e-10, "rods-1d through the split step: its %d history rows equal those of CHOLMOD's order (the history "
     "the linear stepper has always written) to %.2e of each column's scale", ok_rows, worst);
done:
  tl_table_free(&A);
  tl_table_free(&B);
  tl_remove_dir(out);
}

/* --- long indices: the factor against a dense LU ------------------------------------------------ */

static void test_long_indices(void)
{
  scene X;
  mo_linsolver_info I;
  mo_linsolver *ls;
  const mo_csc *A;
  double *Ad = NULL, *b = NULL, *x = NULL, *xr = NULL;
  int n, i, info, *piv = NULL, one = 1;
  unsigned long seed = 7;
  char text[4096];
  snprintf(text, sizeof text, tl_block_2d, "Q4", "plane_strain", "scheme = \"theta\"; dt = 1.0e-5; steps = 1;", "");
  if (scene_open(&X, "long indices", text)) {
    ok(0, "long indices: set-up: %s", X.ctx.errmsg);
    scene_free(&X);
    return;
  }
  ls = mo_stepper_solver(X.S[1]);
  A = mo_stepper_matrix(X.S[1]);
  n = A->ncol;
  mo_linsolver_info_get(ls, &I);
  ok(I.long_indices && I.trailing && I.nlast > 0 && I.nnz_L > 0,
     "the factor has long indices (CHOLMOD's _l interface), %d dofs last, nnz(L) = %.0f, ordering %s", I.nlast, I.nnz_L,
     I.ordering ? I.ordering : "?");
  mo_csc_to_dense(A, &Ad, &X.ctx);
  b = malloc((size_t)n * sizeof *b);
  x = malloc((size_t)n * sizeof *x);
  xr = malloc((size_t)n * sizeof *xr);
  piv = malloc((size_t)n * sizeof *piv);
  for (i = 0; i < n; i++) xr[i] = b[i] = rnd(&seed);
  mo_linsolver_solve(ls, b, x, &X.ctx);
  dgesv_(&n, &one, Ad, &n, piv, xr, &n, &info);
  ok(!info && maxdiff(x, xr, n) <= 1e-11 * maxabs(xr, n),
     "its solve equals LAPACK's dense LU to %.2e (%d dofs)", maxdiff(x, xr, n) / maxabs(xr, n), n);
  mo_free(Ad);
  free(b);
  free(x);
  free(xr);
  free(piv);
  scene_free(&X);
}

/* --- the memory check (T154) ----------------------------------------------------------------- */

static const char *box_mem =
  "bodies = (\n"
  "  { name = \"box\"; mesh = { generator = \"box\"; size = [0.1, 0.1, 0.1]; elements = [12, 12, 12]; };\n"
  "    material = { E = 2.1e11; nu = 0.3; rho = 7800.0; } },\n"
  "  { name = \"ground\"; type = \"plane\"; point = [0.0, 0.0, 0.0]; normal = [0.0, 0.0, 1.0]; }\n"
  ");\n"
  "time = { scheme = \"theta\"; dt = 1.0e-5; steps = 1; };\n"
  "contact = { pairs = ( { slave = \"box\"; slave_set = \"zmin\"; master = \"ground\"; } ); };\n";

static void test_memory(void)
{
  mo_ctx ctx;
  mo_case *cs = NULL;
  mo_scene *sc = NULL;
  mo_contact *C = NULL;
  mo_stepper *S = NULL;
  mo_linsolver_info I0, I1, I2;
  double need0, need1, limit;
  int st;
  mo_ctx_init(&ctx);
  ctx.verbosity = 0;
  if (tl_scene(box_mem, "memory", &cs, &sc, &ctx) || mo_contact_build(sc, &C, &ctx)) {
    ok(0, "memory: set-up: %s", ctx.errmsg);
    goto done;
  }
  /* the figures of both orders */
  st = mo_stepper_create_contact(sc, C, 0, &S, &ctx);
  if (!st) mo_linsolver_info_get(mo_stepper_solver(S), &I0);
  mo_stepper_free(S);
  S = NULL;
  if (!st) st = mo_stepper_create_contact(sc, C, 1, &S, &ctx);
  if (st) {
    ok(0, "memory: factorizations: %s", ctx.errmsg);
    goto done;
  }
  mo_linsolver_info_get(mo_stepper_solver(S), &I1);
  mo_stepper_free(S);
  S = NULL;
  need0 = I0.bytes_factor + fmax(I0.bytes_work, I0.bytes_reserve); /* (T154) */
  need1 = I1.bytes_factor + fmax(I1.bytes_work, I1.bytes_reserve);
  ok(I1.trailing && I1.nnz_L > I0.nnz_L && need1 > need0,
     "the contact dofs last fill more (nnz(L) %.0f against %.0f) and need more (%.1f MB against %.1f MB with W and "
     "its Schur inverse)", I1.nnz_L, I0.nnz_L, need1 / 1e6, need0 / 1e6);
  if (getenv("MOREAU_SANITIZERS") && *getenv("MOREAU_SANITIZERS")) {
    /* the sanitizers' shadow memory and quarantine move the resident size by more than the
       limits below leave */
    printf("ok %d # SKIP the fallback under a limit: a sanitizer build's memory is not the program's\n", ++tap_n);
    ctx.max_bytes = 1; /* still refused, with its figures */
    st = mo_stepper_create_contact(sc, C, 1, &S, &ctx);
    ok(st == MO_ELIMIT && strstr(ctx.errmsg, "needs") && strstr(ctx.errmsg, "nnz(L)"), "under 1 byte refused: %.200s",
       ctx.errmsg);
    goto done;
  }
  /* a limit between the two: CHOLMOD's own order, said */
  limit = mo_memory_rss() + need0 + 0.5 * (need1 - need0);
  ctx.max_bytes = limit;
  st = mo_stepper_create_contact(sc, C, 1, &S, &ctx);
  if (!st) mo_linsolver_info_get(mo_stepper_solver(S), &I2);
  ok(!st && !I2.trailing && I2.bytes_trailing > 0 && fabs(I2.nnz_L - I0.nnz_L) <= 0.01 * I0.nnz_L,
     "under %.1f MB the factorization falls back to CHOLMOD's order (trailing %d, it would have needed %.1f MB)",
     limit / 1e6, st ? -1 : I2.trailing, st ? 0 : I2.bytes_trailing / 1e6);
  mo_stepper_free(S);
  S = NULL;
  /* under both: refused with the figures, nothing factored */
  ctx.max_bytes = mo_memory_rss() + 0.5 * need0;
  st = mo_stepper_create_contact(sc, C, 1, &S, &ctx);
  ok(st == MO_ELIMIT && strstr(ctx.errmsg, "needs") && strstr(ctx.errmsg, "nnz(L)") && strstr(ctx.errmsg, "GB"),
     "under %.1f MB refused: %.200s", ctx.max_bytes / 1e6, ctx.errmsg);
done:
  mo_stepper_free(S);
  mo_contact_free(C);
  mo_scene_free(sc);
  mo_case_free(cs);
}

/* --- every phase timed (T158) ------------------------------------------------------------------

   Each run's phases against its wall time: every piece of the run's work must be in a phase. The
   few microseconds between two timed sections of a step are not in any; a loaded machine that
   preempts the run there can leave a time slice out, so a case passes when one of three runs
   accounts for 95 % of its wall time (the attempts are printed). */

/* The phases' total and the wall time of one run of a case. */
static int phase_sums(const char *name, double *total, double *wall)
{
  char path[4200], out[512];
  json_t *sum, *t, *v;
  const char *key;
  tl_case_path(path, sizeof path, name);
  snprintf(out, sizeof out, "tests/out/scale-phases-%s-%ld", name, (long)getpid());
  *total = *wall = 0;
  if (tl_run(path, NULL, NULL, 0, out, name, NULL)) return -1;
  sum = tl_summary(out);
  t = sum ? json_object_get(sum, "timings") : NULL;
  json_object_foreach(t, key, v) {
    if (!strcmp(key, "wall")) *wall = json_real_value(v);
    else if (json_is_number(v) && strcmp(key, "steps") && strcmp(key, "first_step")) *total += json_number_value(v);
  }
  json_decref(sum);
  tl_remove_dir(out);
  return *wall > 0 ? 0 : -1;
}

static void test_phases(void)
{
  static const char *const cases[] = {"rods-1d", "cylinder-wall", "block-drop", "bar-obstacle", "ball-bounce",
                                      "box-on-plane", "wave-bar", "newton-cradle"};
  size_t k;
  for (k = 0; k < MO_COUNT(cases); k++) {
    double total, wall, best = 0;
    char tries[256] = "";
    size_t len = 0;
    int a, done = 0;
    for (a = 0; a < 3 && !done; a++) {
      if (phase_sums(cases[k], &total, &wall)) break;
      len += (size_t)snprintf(tries + len, sizeof tries - len, "%s%.4f of %.4f s", a ? ", " : "", total, wall);
      best = fmax(best, total / wall);
      done = fabs(total - wall) <= 0.05 * wall;
    }
    ok(done, "%s: the phases add up to %.1f %% of the wall time (%s)", cases[k], 100 * best, tries);
  }
}

int main(void)
{
  test_scenes();
  test_history();
  test_long_indices();
  test_memory();
  test_phases();
  printf("1..%d\n", tap_n);
  return tap_failed ? 1 : 0;
}
