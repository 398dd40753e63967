/* test_taylor.c: nonlinear steps in the core (doc/theory.md §11): the axisymmetric Taylor bar by
   every back end against the benchmark and against an explicit integrator on the same mesh,
   its energy balance; the plane-strain rod's self-convergence; Newton's quadratic convergence on
   a smooth step; linear scenes on their old path (the same history to the last bit, one
   factorization). */
#include "config.h"
#include <moreau/moreau.h>
#include <sys/stat.h>
#include <unistd.h>
#include "testlib.h"
#include "taylor_explicit.h"

/* Run cases/<name> with the given overrides into tests/out/taylor-<tag>; the summary in *sum
   (NULL when the run did not write it). Returns the run's status. */
static int run_case(const char *name, const char *tag, const char *const *sets, int nset, json_t **sum,
                    double *wall)
{
  char path[2300], outdir[512];
  mo_run_result res;
  int st;
  tl_case_path(path, sizeof path, name);
  snprintf(outdir, sizeof outdir, "tests/out/taylor-%s-%ld", tag, (long)getpid());
  st = tl_run(path, NULL, sets, nset, outdir, tag, &res);
  if (wall) *wall = res.wall;
  *sum = tl_summary(outdir);
  return st;
}

static const char *jstr(json_t *root, const char *key)
{
  json_t *j = root ? json_object_get(root, key) : NULL;
  return j && json_is_string(j) ? json_string_value(j) : "";
}

/* --- the axisymmetric Taylor bar (doc/architecture.md §11) ----------------------------------------------- */

static void test_axisymmetric(void)
{
  /* the CI mesh: 5 x 50 Q4 (the case's own is 10 x 100, README) */
  const char *sets[] = {"bodies.bar.mesh.elements=[5, 50]", "output.vtk.every=100000", "output.every=50"};
  const char *solvers[] = {"levelset", "nscd", "newmark"};
  double Le, Re, epe, gap, wall, t0 = mo_clock(), texp, L[3] = {NAN, NAN, NAN}, R[3] = {NAN, NAN, NAN};
  size_t k;
  taylor_explicit(0, 5, 50, &Le, &Re, &epe, &gap, &wall);
  texp = mo_clock() - t0;
  diag("explicit central differences, 5 x 50 Q4: L = %.4f mm, footprint %.4f mm, max epsp %.3f (%.1f s)",
       1e3 * Le, 1e3 * Re, epe, texp);
  for (k = 0; k < MO_COUNT(solvers); k++) {
    char solver[64];
    const char *s2[4];
    json_t *sum = NULL;
    double w, ep, bal, wp, wc, e0;
    int st;
    snprintf(solver, sizeof solver, "contact.solver=%s", solvers[k]);
    s2[0] = sets[0]; s2[1] = sets[1]; s2[2] = sets[2]; s2[3] = solver;
    st = run_case("taylor-axisymmetric", solvers[k], s2, 4, &sum, &w);
    ok(st == 0 && !strcmp(jstr(sum, "status"), "complete"), "axisymmetric Taylor bar, %s: 400 steps in %.1f s "
       "(%.2f Newton iterations per step, %.0f halved)", solvers[k], w,
       tl_jnum(sum, "newton", "iterations_mean", NULL), tl_jnum(sum, "newton", "damped", NULL));
    L[k] = tl_jnum(sum, "metrics", "extents", "bar", "ymax", NULL);
    R[k] = tl_jnum(sum, "metrics", "extents", "face", "xmax", NULL);
    ep = tl_jnum(sum, "metrics", "plasticity", "bar", "max_eps_p", NULL);
    bal = tl_jnum(sum, "energy", "balance_relative", NULL);
    wp = tl_jnum(sum, "energy", "plastic", NULL);
    wc = tl_jnum(sum, "energy", "contact_work", NULL);
    e0 = tl_jnum(sum, "energy", "initial", NULL);
    ok(fabs(L[k] - 21.45e-3) <= 0.02 * 21.45e-3, "%s: final length %.4f mm within 2%% of 21.45 mm", solvers[k], 1e3 * L[k]);
    ok(fabs(R[k] - 7.15e-3) <= 0.03 * 7.15e-3, "%s: footprint radius %.4f mm within 3%% of 7.15 mm", solvers[k], 1e3 * R[k]);
    if (k == 2) {
      /* the baseline's own scheme, Newmark (0.49, 0.9), dissipates: no balance to close */
      diag("newmark (0.49, 0.9): energy balance %.2f%%, max epsp %.2f", 100 * bal, ep);
      json_decref(sum);
      continue;
    }
    ok(fabs(bal) <= 0.01, "%s: kinetic + elastic + plastic dissipation - contact work closes to %.2f%% of the "
       "initial kinetic energy %.2f J (plastic %.2f J, contact work %.2f J, max epsp %.2f)", solvers[k],
       100 * bal, e0, wp, wc, ep);
    ok(fabs(e0 - 239.8) < 0.1, "%s: initial kinetic energy %.3f J (doc/architecture.md §11: 239.8 J)", solvers[k], e0);
    ok(fabs(L[k] - Le) <= 5e-3 * Le && fabs(R[k] - Re) <= 5e-3 * Re,
       "%s: within 0.5%% of the explicit integrator on the same mesh (length %+.2f%%, footprint %+.2f%%)",
       solvers[k], 100 * (L[k] / Le - 1), 100 * (R[k] / Re - 1));
    json_decref(sum);
  }
  /* the same discrete problem (velocity-level Signorini, frictionless): the same solution */
  ok(fabs(L[0] - L[1]) <= 1e-6 * L[0] && fabs(R[0] - R[1]) <= 1e-6 * R[0],
     "levelset and nscd agree: length %.2e, footprint %.2e relative", fabs(L[0] - L[1]) / L[0],
     fabs(R[0] - R[1]) / R[0]);
}

/* --- the plane-strain rod (BDZ07 §6.3): self-convergence under mesh refinement --------------- */

static void test_plane_strain_convergence(void)
{
  const char *mesh[3] = {"bodies.rod.mesh.elements=[2, 20]", "bodies.rod.mesh.elements=[4, 40]",
                         "bodies.rod.mesh.elements=[8, 80]"};
  double L[3], R[3], E[3], w[3], total = 0;
  int k, good = 1;
  for (k = 0; k < 3; k++) {
    const char *sets[] = {mesh[k], "contact.solver=nscd", "output.vtk.every=100000", "output.every=50"};
    char tag[32];
    json_t *sum = NULL;
    snprintf(tag, sizeof tag, "ps%d", k);
    good &= run_case("taylor-plane-strain", tag, sets, 4, &sum, &w[k]) == 0;
    L[k] = tl_jnum(sum, "metrics", "extents", "rod", "ymax", NULL);
    R[k] = tl_jnum(sum, "metrics", "extents", "face", "xmax", NULL);
    E[k] = tl_jnum(sum, "metrics", "plasticity", "rod", "max_eps_p", NULL);
    total += w[k];
    json_decref(sum);
  }
  ok(good, "plane strain, theta = 1, 80 us: three meshes ran (%.1f s)", total);
  for (k = 0; k < 3; k++)
    diag("  %d x %d Q4: final length %.4f mm, footprint half-width %.4f mm, max epsp %.3f (%.1f s)", 2 << k,
         20 << k, 1e3 * L[k], 1e3 * R[k], E[k], w[k]);
  diag("  differences of the final length: %.4f mm, %.4f mm (ratio %.2f)", 1e3 * (L[0] - L[1]), 1e3 * (L[1] - L[2]),
       (L[0] - L[1]) / (L[1] - L[2]));
  /* theta = 1 with h fixed: the numerical damping changes with the mesh too, so the change per
     halving falls slowly (by 1.5, README); it must fall, and stay in one direction */
  ok((L[0] - L[1]) * (L[1] - L[2]) > 0 && fabs(L[1] - L[2]) < 0.8 * fabs(L[0] - L[1]),
     "plane strain: the final length self-converges (%.2f%% then %.2f%% change per halving, same sign)",
     100 * fabs(L[0] - L[1]) / L[1], 100 * fabs(L[1] - L[2]) / L[2]);
}

/* --- Newton on a smooth step ---------------------------------------------------------------- */

/* A Hencky block sheared and compressed by its initial velocity: one large step, no contact, so
   that the iteration is Newton's on a smooth function. */
static const char *smooth =
  "bodies = ( { name = \"block\";\n"
  "  mesh = { generator = \"rectangle\"; size = [1.0e-2, 1.0e-2]; elements = [4, 4]; };\n"
  "  material = { model = \"hencky\"; E = 1.17e11; nu = 0.35; rho = 8930.0; hypothesis = \"plane_strain\"; };\n"
  "  fix = ( { set = \"bottom\"; } );\n"
  "  initial = { velocity = [\"300.0 * y / 1.0e-2\", \"-200.0 * y / 1.0e-2\"]; };\n"
  "} );\n"
  "time = { scheme = \"theta\"; theta = 1.0; dt = 2.0e-6; steps = 1; newton = { tol = 1.0e-13; }; };\n";

static void test_newton_quadratic(void)
{
  mo_ctx ctx;
  mo_case *cs = NULL;
  mo_scene *sc = NULL;
  mo_stepper *S = NULL;
  mo_state s;
  const mo_newton_report *R;
  int st, k, quad = 1, n = 0;
  char hist[512] = "";
  size_t len = 0;
  mo_ctx_init(&ctx);
  memset(&s, 0, sizeof s);
  st = tl_scene(smooth, "smooth.cfg", &cs, &sc, &ctx);
  if (!st) st = mo_stepper_create(sc, &S, &ctx);
  if (!st) st = mo_state_alloc(sc, &s, &ctx);
  if (!st) st = mo_stepper_init_state(S, &s, &ctx);
  if (!st) st = mo_stepper_step(S, &s, &ctx);
  if (st) diag("%s", ctx.errmsg);
  ok(st == 0 && S && mo_stepper_nonlinear(S), "a Hencky block, one step of 2 us with 30 %% shear: Newton converged");
  R = S ? mo_stepper_newton_report(S) : NULL;
  for (k = 0; R && k < R->nres; k++) {
    int w = snprintf(hist + len, sizeof hist - len, "%s%.2e", k ? ", " : "", R->res[k]);
    if (w > 0 && (size_t)w < sizeof hist - len) len += (size_t)w;
  }
  /* quadratic: each residual in the asymptotic range (below 1e-2, above round-off) is at most a
     modest constant times the square of the previous one */
  for (k = 1; R && k < R->nres; k++)
    if (R->res[k - 1] < 1e-2 && R->res[k] > 1e-13) {
      n++;
      quad &= R->res[k] <= 10 * R->res[k - 1] * R->res[k - 1];
    }
  ok(R && R->nres >= 4 && n >= 1 && quad, "Newton converges quadratically: relative residuals %s", hist);
  mo_state_release(&s);
  mo_stepper_free(S);
  mo_scene_free(sc);
  mo_case_free(cs);
}

/* --- quasi-static load steps: a J2 column under uniaxial compression ------------------------- */

/* An H8 column, 2 x 2 x 4, on rollers (symmetry planes x = 0, y = 0, the base z = 0), its top
   pushed down 20 % in 10 load steps: a homogeneous uniaxial stress. */
static const char *column =
  "bodies = ( { name = \"col\";\n"
  "  mesh = { generator = \"box\"; size = [1.0e-2, 1.0e-2, 2.0e-2]; elements = [2, 2, 4]; };\n"
  "  material = { model = \"j2\"; E = 1.17e11; nu = 0.35; rho = 8930.0; sigma_y = 4.0e8; Et = 1.0e8; };\n"
  "  fix = ( { set = \"xmin\"; dofs = [\"x\"]; }, { set = \"ymin\"; dofs = [\"y\"]; }, { set = \"zmin\"; dofs = [\"z\"]; } );\n"
  "  prescribed = ( { set = \"zmax\"; dof = \"z\"; displacement = \"-4.0e-3 * t\"; } );\n"
  "} );\n"
  "time = { scheme = \"quasistatic\"; steps = 10; end = 1.0; };\n";

static void test_quasistatic(void)
{
  const double E = 1.17e11, sy = 4e8, Et = 1e8, A0 = 1e-4, L0 = 2e-2;
  mo_ctx ctx;
  mo_case *cs = NULL;
  mo_scene *sc = NULL;
  mo_stepper *S = NULL;
  mo_state s;
  int st, k, a, nz = 0;
  double err = 0, F = 0, Fx = 0, its = 0;
  mo_ctx_init(&ctx);
  memset(&s, 0, sizeof s);
  st = tl_scene(column, "column.cfg", &cs, &sc, &ctx);
  if (!st) st = mo_stepper_create(sc, &S, &ctx);
  if (!st) st = mo_state_alloc(sc, &s, &ctx);
  if (!st) st = mo_stepper_init_state(S, &s, &ctx);
  for (k = 0; !st && k < sc->time.steps; k++) {
    const mo_mesh *m = sc->body[0].mesh;
    double lam, eps, tau;
    if ((st = mo_stepper_step(S, &s, &ctx))) break;
    its += mo_stepper_newton_report(S)->iterations;
    /* the top's support reaction against the closed form: the uniaxial Kirchhoff stress is
       bilinear in the logarithmic strain (slopes E, then Et, (T27)); F = tau A0 / lambda */
    lam = 1 - 4e-3 * s.t / L0;
    eps = log(lam);
    tau = fabs(E * eps) <= sy ? E * eps : -(sy + Et * (fabs(eps) - sy / E));
    Fx = tau * A0 / lam;
    F = 0;
    nz = 0;
    for (a = 0; a < m->nnode; a++)
      if (m->x[3 * a + 2] > L0 * (1 - 1e-9)) {
        F += s.reac[3 * a + 2];
        nz++;
      }
    /* the support reaction of the top (the residual of its rows, doc/theory.md §1.4) is the
       column's axial force */
    if (fabs(F - Fx) / fabs(Fx) > err) err = fabs(F - Fx) / fabs(Fx);
  }
  if (st) diag("%s", ctx.errmsg);
  ok(st == 0 && nz == 9 && err < 1e-6, "quasi-static J2 column to 20 %% compression in 10 load steps (%.1f Newton "
     "iterations per step): the top's support reaction follows the uniaxial closed form to %.1e (last %.5g N, "
     "closed form %.5g N)", its / 10, err, F, Fx);
  mo_state_release(&s);
  mo_stepper_free(S);
  mo_scene_free(sc);
  mo_case_free(cs);
}

/* --- linear scenes: their old path ------------------------------------------------------------- */

static int file_equal(const char *a, const char *b, long *where)
{
  FILE *fa = fopen(a, "rb"), *fb = fopen(b, "rb");
  int ca = 0, cb = 0, eq = fa && fb;
  long k = 0;
  while (eq) {
    ca = fgetc(fa);
    cb = fgetc(fb);
    if (ca != cb) eq = 0;
    if (ca == EOF || cb == EOF) break;
    k++;
  }
  if (fa) fclose(fa);
  if (fb) fclose(fb);
  *where = k;
  return eq;
}

static void test_linear_unchanged(void)
{
  /* rods-1d's history at 17 digits, written by the build before nonlinear steps existed; with
     CHOLMOD's own order, the factorization it was written with (the contact dofs last round
     differently: tests/test_scale compares that path to this file to 1e-12) */
  const char *sets[] = {"output.precision=17", "output.every=10", "contact.factor_order=solver"};
  char ref[2300], out[600];
  json_t *sum = NULL;
  long at = 0;
  int st = run_case("rods-1d", "rods", sets, 3, &sum, NULL);
  snprintf(ref, sizeof ref, "%s/tests/ref/rods-1d-history.csv", tl_srcdir());
  snprintf(out, sizeof out, "tests/out/taylor-rods-%ld/history.csv", (long)getpid());
  ok(st == 0 && file_equal(ref, out, &at), "rods-1d (linear): history.csv at 17 digits is the one of the "
     "linear stepper before Newton (first difference at byte %ld)", at);
  ok(tl_jnum(sum, "linear_solver", "factorizations", NULL) == 1 && !json_object_get(sum, "newton"),
     "rods-1d: one factorization for the run, no Newton (%g factorizations)",
     tl_jnum(sum, "linear_solver", "factorizations", NULL));
  json_decref(sum);
}

int main(void)
{
  mkdir("tests/out", 0777);
  test_newton_quadratic();
  test_quasistatic();
  test_linear_unchanged();
  test_axisymmetric();
  test_plane_strain_convergence();
  return done_testing();
}
