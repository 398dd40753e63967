/* test_qs_contact.c: quasi-static contact scenes that once returned wrong answers or stalled
   (issue 15): a box held vertically only by its contact with a plane is refused with the motion
   no support holds (2D and 3D, every back end) (T82); the same box with a corner held is solved
   exactly (closed form: uniform uniaxial stress) by nscd within a bounded number of sweeps and by
   levelset; nscd on the patch test converges to the dense solution of its local problem, with the
   facet-mean pressure at the exact value (T83); on matching meshes (redundant constraints) it
   reports the redundancy and the minimum-norm reactions, the exact uniform pressure (T84); a
   factor that does not solve K u = f + H r fails the step on the global equilibrium (T82); a
   tolerance below round-off is met at the round-off floor (T85); the sweep on rigid bodies reports
   redundancy by counting (T84). */
#include "config.h"
#include <moreau/moreau.h>
#include "testlib.h"

extern void dgesv_(const int *n, const int *nrhs, double *a, const int *lda, int *ipiv, double *b, const int *ldb,
                   int *info);

/* --- a run through mo_run, keeping its error message ------------------------------------------------ */

static int run(const char *name, const char *solver, const char *const *sets, int nset, const char *tag, char *outdir,
               size_t n, char *err, size_t nerr)
{
  char path[1024];
  mo_run_options o;
  tl_case_path(path, sizeof path, name);
  snprintf(outdir, n, "tests/out/qs-%s-%ld", tag, (long)getpid());
  memset(&o, 0, sizeof o);
  o.case_path = path;
  o.solver = solver;
  o.sets = sets;
  o.nset = nset;
  o.outdir = outdir;
  return tl_run_options(&o, NULL, err, nerr);
}

/* --- 1. the box held only by the plane: refused -------------------------------------------------- */

static void test_singular(void)
{
  static const char *solvers[2] = {"nscd", "levelset"};
  const char *box[] = {"bodies.box.fix=({ set = \"xmin\"; dofs = [\"x\"]; }, { set = \"ymin\"; dofs = [\"y\"]; })"};
  /* the patch test's upper block under a pressure instead of a prescribed displacement */
  const char *patch[] = {"bodies.upper.prescribed=()",
                         "bodies.upper.loads=({ type = \"pressure\"; set = \"top\"; value = 1.0e7; })"};
  char out[256], err[MO_ERRMSG_MAX];
  int k, st;
  for (k = 0; k < 2; k++) {
    st = run("box-on-plane", solvers[k], box, 1, "sing", out, sizeof out, err, sizeof err);
    ok(st != 0 && strstr(err, "body 'box' has 1 rigid motion that no support holds: (1 z)") &&
           strstr(err, "quasi-static"),
       "box held vertically only by the plane, %s: refused with the motion no support holds (%.160s)", solvers[k],
       st ? err : "the run completed");
    tl_remove_dir(out);
  }
  st = run("patch-test", "nscd", patch, 2, "sing2", out, sizeof out, err, sizeof err);
  ok(st != 0 && strstr(err, "body 'upper' has 1 rigid motion that no support holds: (1 y)"),
     "2D: the patch test's upper block under a pressure (held by the contact only): refused (%.120s)",
     st ? err : "the run completed");
  tl_remove_dir(out);
}

/* --- 2. the box with a corner held: the closed form -------------------------------------------------- */

/* The consistent nodal force of p on the bottom of the tetrahedral box at (x, y): Kuhn's split
   cuts every bottom cell (i, j) along its diagonal from (i, j) to (i + 1, j + 1); a flat T3 face
   gives p A / 3 to each corner, a flat T6 face 0 to its corners and p A / 3 to each edge middle. */
static double tet_bottom_force(int t10, double x, double y, double p, double h, int n)
{
  double f = 0;
  int i, j, k, a;
  for (i = 0; i < n; i++)
    for (j = 0; j < n; j++)
      for (k = 0; k < 2; k++) {
        double v[3][2] = {{i * h, j * h}, {(i + 1) * h, (j + 1) * h}, {(i + !k) * h, (j + k) * h}};
        for (a = 0; a < 3; a++) {
          const double *P = v[a], *Q = v[(a + 1) % 3];
          double mx = 0.5 * (P[0] + Q[0]), my = 0.5 * (P[1] + Q[1]);
          if (!t10 && fabs(x - P[0]) < 1e-9 && fabs(y - P[1]) < 1e-9) f += p * h * h / 6;
          if (t10 && fabs(x - mx) < 1e-9 && fabs(y - my) < 1e-9) f += p * h * h / 6;
        }
      }
  return f;
}

/* The box of cases/box-on-plane in H8, T4 or T10 (element): the closed form holds exactly. */
static void test_box(const char *solver, const char *element, int max_iter)
{
  const double p = 1e6, E = 2.1e11, L = 0.05, h = 0.0125, side = 0.1;
  char out[256], err[MO_ERRMSG_MAX], path[300], set[64], tag[32];
  const char *sets[1];
  tl_table T, Hs;
  json_t *J;
  int st, i, bad = 0, n = 0, h8 = !strcmp(element, "H8"), t10 = !strcmp(element, "T10"), want_n = t10 ? 288 : 80;
  double worst = 0, uz, it, eq, total = 0;
  snprintf(set, sizeof set, "bodies.box.mesh.element=\"%s\"", element);
  snprintf(tag, sizeof tag, "%s-%s", solver, element);
  sets[0] = set;
  st = run("box-on-plane", solver, sets, 1, tag, out, sizeof out, err, sizeof err);
  ok(st == 0, "box with a corner held, %s, %s: runs (%s)", element, solver, err);
  if (st) { tl_remove_dir(out); return; }
  J = tl_summary(out);
  it = tl_jnum(J, "contact", "iterations_max", NULL);
  eq = tl_jnum(J, "contact", "equilibrium_residual_max", NULL);
  json_decref(J);
  /* nscd on 200 or more frictionless contacts (the T10 box's 288) solves its first step by the
     status LU from the predictor's statuses, without a sweep (doc/theory.md (T163)): 0 sweeps */
  ok(it >= (strcmp(solver, "nscd") ? 1 : 0) && it <= max_iter, "box, %s, %s: %g iterations (at most %d)", element,
     solver, it, max_iter);
  ok(eq <= 1e-10, "box, %s, %s: global equilibrium |f + H r - K u| = %.2e of the forces (T82)", element, solver, eq);
  snprintf(path, sizeof path, "%s/contact.csv", out);
  if (!tl_table_read(path, &T)) {
    int cx = tl_col(&T, "x"), cy = tl_col(&T, "y"), cr = tl_col(&T, "RN");
    for (i = 0; i < T.nrow; i++) {
      double x = tl_num(&T, i, cx), y = tl_num(&T, i, cy), want = p * h * h, e;
      /* consistent nodal forces of a uniform pressure: a quarter at corners, a half on edges */
      if (fabs(x) < 1e-9 || fabs(x - side) < 1e-9) want *= 0.5;
      if (fabs(y) < 1e-9 || fabs(y - side) < 1e-9) want *= 0.5;
      if (!h8) want = tet_bottom_force(t10, x, y, p, h, 8);
      e = fabs(tl_num(&T, i, cr) - want) / (p * h * h);
      if (e > worst) worst = e;
      bad += !(e <= 1e-9);
      total += tl_num(&T, i, cr);
      n++;
    }
    tl_table_free(&T);
  }
  if (h8)
    ok(n == 80 && !bad, "box, %s: the 80 reactions are the consistent forces of p (corner 39.0625, edge 78.125, "
       "interior 156.25 N) to %.1e", solver, worst);
  else
    ok(n == want_n && !bad, "box, %s, %s: the %d reactions are the consistent forces of p on the bottom's %s "
       "(sum %.7f N) to %.1e of p h^2", element, solver, want_n, t10 ? "6-node triangles (0 at corners)" : "triangles",
       total, worst);
  snprintf(path, sizeof path, "%s/history.csv", out);
  uz = NAN;
  if (!tl_table_read(path, &Hs)) {
    uz = tl_num(&Hs, Hs.nrow - 1, tl_col(&Hs, "top.uz"));
    tl_table_free(&Hs);
  }
  ok(fabs(uz + p * L / E) <= 1e-9 * p * L / E, "box, %s, %s: top u_z = %.10e = -p L / E = %.10e", element, solver, uz,
     -p * L / E);
  tl_remove_dir(out);
}

/* --- 3. the patch test by nscd, step by step: its reactions against a dense solve ------------------- */

typedef tl_steps run_t;
#define run_free tl_steps_free

static int run_open_case(run_t *R, const char *name, const char *const *sets, int nset, int step)
{
  char path[1024];
  int st;
  tl_case_path(path, sizeof path, name);
  st = tl_steps_open(R, path, NULL, sets, nset);
  if (!st && step) st = mo_contact_step(R->D, &R->s, &R->ctx);
  if (st) diag("%s: %s", name, R->ctx.errmsg);
  return st;
}

static int run_open(run_t *R, const char *const *sets, int nset)
{
  return run_open_case(R, "patch-test", sets, nset, 1);
}

/* The exact uniform pressure of the patch test (cases/patch-test/README.md). */
static double patch_pressure(void)
{
  const double nu = 0.3, Ml = 2e11 * (1 - nu) / ((1 + nu) * (1 - 2 * nu)), Mu = 1e11 * (1 - nu) / ((1 + nu) * (1 - 2 * nu));
  return 1e-4 / (0.5 / Ml + 0.5 / Mu);
}

static void test_patch(void)
{
  const char *sets[] = {"contact.solver=\"nscd\""};
  const double p = patch_pressure(), w = 0.125; /* the Gauss weight of a point on a 0.25 m facet */
  run_t R;
  const mo_contact_report *rep;
  const double *r;
  double *W = NULL, *q = NULL, *mu = NULL, A[64], b[8], worst = 0, fworst = 0;
  int nc = 0, d = 0, i, j, piv[8], one = 1, info = 1, n;
  if (run_open(&R, sets, 1)) {
    ok(0, "patch test by nscd: the step succeeds");
    run_free(&R);
    return;
  }
  rep = mo_contact_last_report(R.D);
  ok(rep->reason == MO_CR_CONVERGED && rep->iterations <= 100,
     "patch test by nscd: converged in %d sweeps (at most 100; 1000 without the status-set step (T83))",
     rep->iterations);
  ok(rep->constraints == 8 && rep->redundant == 0 && rep->rcond > 1e-6,
     "patch test: 8 closed constraints, none redundant (rank 8, rcond %.2e): the reactions are unique",
     rep->rcond);
  r = mo_contact_reactions(R.D);
  if (!mo_contact_driver_local_problem(R.D, &W, &q, &mu, &nc, &d, &R.ctx) && nc == 8) {
    /* frictionless: the normal rows, W_nn r_n = -q_n on the 8 closed points (LAPACK) */
    n = nc;
    for (i = 0; i < n; i++) {
      b[i] = -q[i * d];
      for (j = 0; j < n; j++) A[j * n + i] = W[(size_t)(i * d) * (size_t)(nc * d) + (size_t)(j * d)];
    }
    dgesv_(&n, &one, A, &n, piv, b, &n, &info);
    for (i = 0; i < n; i++) worst = fmax(worst, fabs(r[i * d] - b[i]) / b[i]);
    /* the candidates come facet by facet, two Gauss points each */
    for (i = 0; i < n; i += 2) fworst = fmax(fworst, fabs((r[i * d] + r[(i + 1) * d]) / (2 * w) - p) / p);
  }
  ok(info == 0 && worst <= 1e-9, "patch test: nscd's reactions = the dense solution of W r = -q to %.1e", worst);
  ok(info == 0 && fworst <= 1e-4, "patch test: facet-mean pressure within %.1e of the exact p = %.8e Pa", fworst, p);
  mo_free(W); mo_free(q); mo_free(mu);
  run_free(&R);
}

/* --- 4. matching meshes: 8 points on a P1 gap of 5 nodes, 3 redundant ------------------------------- */

static void test_redundant(void)
{
  const char *sets[] = {"contact.solver=\"nscd\"", "bodies.upper.mesh.elements=[4,3]"};
  const double p = patch_pressure(), w = 0.125;
  run_t R;
  const mo_contact_report *rep;
  const double *r;
  double worst = 0;
  int i;
  if (run_open(&R, sets, 2)) {
    ok(0, "matching patch test by nscd: the step succeeds");
    run_free(&R);
    return;
  }
  rep = mo_contact_last_report(R.D);
  ok(rep->reason == MO_CR_CONVERGED && rep->constraints == 8 && rep->redundant == 3 && rep->min_norm,
     "matching meshes: 8 closed constraints of rank 5, 3 redundant (got %d of %d), reported; the minimum-norm "
     "reactions (T84)", rep->redundant, rep->constraints);
  r = mo_contact_reactions(R.D);
  for (i = 0; i < 8; i++) worst = fmax(worst, fabs(r[2 * i] - p * w) / (p * w));
  ok(worst <= 1e-9, "matching meshes: the minimum-norm reactions are the exact uniform pressure p w = %.8e N to %.1e",
     p * w, worst);
  run_free(&R);
}

/* --- 5. the equilibrium check itself: a factor that is not K's --------------------------------------- */

static void test_equilibrium_check(void)
{
  run_t R;
  int k, st;
  if (run_open_case(&R, "box-on-plane", NULL, 0, 0)) {
    ok(0, "box-on-plane: setup");
    run_free(&R);
    return;
  }
  /* K as the check reads it 1 % stiffer than the K the stepper factored: the contact problem is
     solved on the factor, so only the global equilibrium (T82) can see it */
  for (k = 0; k < R.sc->K->p[R.sc->K->ncol]; k++) R.sc->K->x[k] *= 1.01;
  st = mo_contact_step(R.D, &R.s, &R.ctx);
  ok(st == MO_ENOCONV && strstr(R.ctx.errmsg, "not in equilibrium") && strstr(R.ctx.errmsg, "body 'box'"),
     "a factor that does not solve K u = f + H r: the step fails on the global equilibrium (T82) (%.200s)",
     st ? R.ctx.errmsg : "the step succeeded");
  run_free(&R);
}

/* --- 6. the round-off floor (T85): a tolerance no iteration can meet ---------------------------------- */

static void test_roundoff(void)
{
  const char *sets[] = {"contact.nscd.tol=1e-20", "contact.nscd.max_sweeps=5000", "contact.nscd.accelerate=false"};
  char out[256], err[MO_ERRMSG_MAX];
  double it = NAN;
  int st = run("greco-jean-mu1", "nscd", sets, 3, "roundoff", out, sizeof out, err, sizeof err);
  if (!st) {
    json_t *J = tl_summary(out);
    it = tl_jnum(J, "contact", "iterations_max", NULL);
    json_decref(J);
  }
  ok(!st && it <= 500, "GRECO mu = 1, tol = 1e-20, the sweeps alone: converged at the round-off floor (T85) in %g "
     "sweeps (the 5000-sweep limit without it) %s", it, err);
  tl_remove_dir(out);
}

/* --- 7. redundancy on the sweep on bodies: the count (T84) ------------------------------------------- */

static void test_count(void)
{
  /* Heyman's arch: voussoirs on two contact points per joint, most of them sticking: more closed
     unknowns than the blocks' 3 dofs each */
  const char *sets[] = {"time.end=0.005"};
  char out[256], err[MO_ERRMSG_MAX];
  double redmax = NAN, nk = NAN;
  const char *measure = "";
  json_t *J = NULL;
  int st = run("masonry-arch", NULL, sets, 1, "arch", out, sizeof out, err, sizeof err);
  if (!st && (J = tl_summary(out))) {
    json_t *r = json_object_get(json_object_get(J, "contact"), "redundancy");
    redmax = json_number_value(json_object_get(r, "max_redundant"));
    nk = json_number_value(json_object_get(r, "last_unknowns"));
    measure = json_string_value(json_object_get(r, "measure"));
    if (!measure) measure = "";
  }
  ok(!st && redmax >= 1 && nk > redmax && !strcmp(measure, "count"),
     "masonry-arch by nscd's sweep on bodies: redundancy reported by the count (%g of %g unknowns, measure '%s') %s",
     redmax, nk, measure, err);
  json_decref(J);
  tl_remove_dir(out);
}

int main(void)
{
  test_singular();
  test_box("nscd", "H8", 100);
  test_box("levelset", "H8", 10);
  /* the same on tetrahedra: triangular contact facets of T4 and T10 (T193) */
  test_box("nscd", "T4", 100);
  test_box("levelset", "T4", 10);
  test_box("nscd", "T10", 100);
  test_box("levelset", "T10", 10);
  test_patch();
  test_redundant();
  test_equilibrium_check();
  test_roundoff();
  test_count();
  return done_testing();
}
