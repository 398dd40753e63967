/* test_explicit.c: the explicit scheme (central differences with lumped mass, doc/theory.md
   (T100)) against d'Alembert and its order in dt, its critical time step (T102) on both sides,
   and the theta-method below theta = 1/2 on both sides of its limit (T101). */
#include "config.h"
#include <moreau/moreau.h>
#include "tap.h"

/* A clamped-free bar (E = rho = A = 1, c = 1) of n elements, first mode as initial displacement:
   u = A sin(pi x / 2L) cos(pi c t / 2L), the sum of d'Alembert's two waves. */
static char bar[2048];
static void bar_case(int n, const char *mass)
{
  snprintf(bar, sizeof bar,
           "bodies = ( { name = \"bar\"; mesh = { generator = \"bar\"; length = 1.0; elements = %d; };\n"
           "  material = { E = 1.0; rho = 1.0; area = 1.0; };%s\n"
           "  fix = ( { set = \"left\"; dofs = [\"x\"]; } );\n"
           "  initial = { displacement = [\"0.01 * sin(1.5707963267948966 * x)\"]; }; } );\n"
           "time = { scheme = \"explicit\"; dt = 0.01; steps = 1; };\n",
           n, mass ? mass : "");
}

typedef struct {
  int st;           /* status of the run */
  long steps;       /* steps done */
  double err;       /* max over steps and nodes of |u - u_exact| / 0.01 */
  double emax;      /* max over steps of E / E0 */
  double efinal;    /* E / E0 at the end */
  double dtc;       /* mo_scene_dt_crit */
  double dtb;       /* mo_scene_dt_bound */
  double *u;        /* final displacements (caller frees) */
  int ndof;
} outcome;

static outcome run(const char *text, const char *const *sets, int nset, double T)
{
  mo_ctx ctx;
  mo_case *cs = NULL;
  mo_scene *sc = NULL;
  mo_stepper *S = NULL;
  mo_state s;
  outcome o;
  double *w = NULL, e0 = 0;
  long k, nsteps;
  int i;
  memset(&o, 0, sizeof o);
  mo_ctx_init(&ctx);
  ctx.verbosity = 0;
  memset(&s, 0, sizeof s);
  o.st = mo_case_load_string(text, "bar.cfg", &cs, &ctx);
  for (i = 0; !o.st && i < nset; i++) o.st = mo_case_set(cs, sets[i], &ctx);
  if (!o.st) o.st = mo_case_validate(cs, &ctx);
  if (!o.st) o.st = mo_scene_build(cs, &sc, &ctx);
  if (!o.st) o.st = mo_stepper_create(sc, &S, &ctx);
  if (!o.st) o.st = mo_state_alloc(sc, &s, &ctx);
  if (!o.st) o.st = mo_stepper_init_state(S, &s, &ctx);
  if (o.st) {
    diag("%s", ctx.errmsg);
    goto out;
  }
  o.dtc = mo_scene_dt_crit(sc, NULL, NULL);
  o.dtb = mo_scene_dt_bound(sc);
  w = malloc((size_t)sc->ndof * sizeof *w);
  e0 = mo_energy_kinetic(sc, &s, w) + mo_energy_elastic(sc, s.u, w);
  nsteps = (long)floor(T / sc->time.dt + 0.5);
  for (k = 0; k < nsteps; k++) {
    double e;
    if ((o.st = mo_stepper_step(S, &s, &ctx))) break;
    e = (mo_energy_kinetic(sc, &s, w) + mo_energy_elastic(sc, s.u, w)) / e0;
    if (!(e <= o.emax)) o.emax = e;
    o.efinal = e;
    o.steps++;
    for (i = 0; i < sc->ndof; i++) {
      double x = sc->body[0].mesh->x[i];
      double ue = 0.01 * sin(M_PI / 2 * x) * cos(M_PI / 2 * s.t), d = fabs(s.u[i] - ue) / 0.01;
      if (!(d <= o.err)) o.err = d;
    }
  }
  o.ndof = sc->ndof;
  o.u = malloc((size_t)sc->ndof * sizeof *o.u);
  memcpy(o.u, s.u, (size_t)sc->ndof * sizeof *o.u);
out:
  free(w);
  mo_state_release(&s);
  mo_stepper_free(S);
  mo_scene_free(sc);
  mo_case_free(cs);
  return o;
}

/* One run of the bar: n elements, step dt, to time T, extra settings. */
static outcome bar_run(int n, double dt, double T, const char *mass, const char *set1, const char *set2)
{
  char sdt[64];
  const char *sets[3];
  int ns = 0;
  bar_case(n, mass);
  snprintf(sdt, sizeof sdt, "time.dt=%.17g", dt);
  sets[ns++] = sdt;
  if (set1) sets[ns++] = set1;
  if (set2) sets[ns++] = set2;
  return run(bar, sets, ns, T);
}

static double diffmax(const outcome *a, const outcome *b)
{
  double d = 0;
  int i;
  for (i = 0; i < a->ndof; i++)
    if (fabs(a->u[i] - b->u[i]) > d) d = fabs(a->u[i] - b->u[i]);
  return d;
}

int main(void)
{
  {
    /* (T102): a uniform bar of n elements: dt_crit = L / (n c) exactly */
    outcome o = bar_run(50, 0.01, 0.01, NULL, NULL, NULL);
    ok(o.st == 0 && fabs(o.dtc - 0.02) < 1e-15, "dt_crit of a 50-element bar (c = 1) is 1/50 (%.17g)", o.dtc);
    ok(o.st == 0 && fabs(o.dtb - 0.02) < 1e-12, "Gershgorin's dt_bound of the lumped bar is exact, 1/50 (%.17g)", o.dtb);
    free(o.u);
  }
  {
    /* against d'Alembert, h and dt refined together at Courant 1/2 (space and time both second
       order): the error falls by 4 at each halving */
    outcome a = bar_run(20, 0.025, 4.0, NULL, NULL, NULL), b = bar_run(40, 0.0125, 4.0, NULL, NULL, NULL),
            c = bar_run(80, 0.00625, 4.0, NULL, NULL, NULL);
    ok(a.st == 0 && b.st == 0 && c.st == 0 && a.steps == 160 && c.steps == 640, "explicit, Courant 1/2, 20/40/80 elements: runs complete");
    ok(c.st == 0 && c.steps == 640 && c.err < 2e-4, "explicit matches d'Alembert: max |u - u_exact| / A = %.3e (80 elements) < 2e-4", c.err);
    ok(a.err / b.err > 3.6 && b.err / c.err > 3.6 && a.err / b.err < 4.4 && b.err / c.err < 4.4,
       "second order: error ratios %.3f, %.3f (4 expected)", a.err / b.err, b.err / c.err);
    ok(c.st == 0 && c.steps == 640 && c.emax > 0.999 && c.emax < 1 + 1e-3, "energy bounded (max E/E0 = %.6f)", c.emax);
    free(a.u), free(b.u), free(c.u);
  }
  {
    /* second order in dt alone: on a fixed mesh of 40 elements, successive differences of the
       final displacements at dt, dt/2, dt/4 fall by 4 (Richardson) */
    outcome a = bar_run(40, 0.005, 4.0, NULL, NULL, NULL), b = bar_run(40, 0.0025, 4.0, NULL, NULL, NULL),
            c = bar_run(40, 0.00125, 4.0, NULL, NULL, NULL);
    double r = diffmax(&a, &b) / diffmax(&b, &c);
    ok(a.st == 0 && b.st == 0 && c.st == 0 && r > 3.7 && r < 4.3,
       "second order in dt at fixed mesh: |u_h - u_h/2| / |u_h/2 - u_h/4| = %.4f (4 expected)", r);
    free(a.u), free(b.u), free(c.u);
  }
  {
    /* (T102) both sides of dt_crit = 1/40 over 4000 steps; the smooth mode is not the unstable
       one, round-off seeds the highest mode, which grows by |lambda| = 2.43 per step at 1.1 */
    outcome s = bar_run(40, 0.99 / 40, 0.99 / 40 * 4000, NULL, NULL, NULL);
    outcome u = bar_run(40, 1.1 / 40, 1.1 / 40 * 4000, NULL, NULL, NULL);
    ok(s.st == 0 && s.steps == 4000 && s.emax < 1.001, "dt = 0.99 dt_crit: 4000 steps, energy bounded (max E/E0 = %.6f)", s.emax);
    ok(u.st == MO_ENAN || u.emax > 1e12, "dt = 1.1 dt_crit: blows up (status %d after %ld steps, max E/E0 = %.3g)", u.st,
       u.steps, u.emax);
    ok(u.st == MO_ENAN, "and the NaN is caught by the stepper (MO_ENAN), not left in the state (step %ld)", u.steps);
    free(s.u), free(u.u);
  }
  {
    /* (T101) theta = 0.3, theta_f = 1 on a linear oscillator: one element, clamped-free,
       consistent mass: K = EA/L, M = rho A L / 3, omega = sqrt(3) c / L; stable iff
       h omega <= 2 / sqrt(1 - 2 theta) */
    double om = sqrt(3.0), hs = 2 / (om * sqrt(1 - 2 * 0.3)), T = 4000 * hs;
    const char *cm = " mass = \"consistent\";";
    char bar1[2048];
    outcome a, b, c, d;
    bar_case(1, cm);
    snprintf(bar1, sizeof bar1, "%s", bar);
    /* the scheme key: theta instead of explicit */
    {
      char *p = strstr(bar1, "\"explicit\"");
      memcpy(p, "\"theta\"   ", 10);
    }
    {
      char sdt[64];
      const char *sets[3] = {sdt, "time.theta=0.3", "time.theta_f=1.0"};
      snprintf(sdt, sizeof sdt, "time.dt=%.17g", 0.97 * hs);
      a = run(bar1, sets, 3, T);
      snprintf(sdt, sizeof sdt, "time.dt=%.17g", 1.03 * hs);
      b = run(bar1, sets, 3, T);
      ok(a.st == 0 && a.steps >= 4000 && a.emax < 1.5,
         "theta = 0.3, theta_f = 1, h = 0.97 x 2/(omega sqrt(1 - 2 theta)): bounded (max E/E0 = %.4f)", a.emax);
      ok(b.emax > 1e6 || b.st == MO_ENAN,
         "theta = 0.3, theta_f = 1, h = 1.03 x the limit: energy grows (max E/E0 = %.3g, status %d)", b.emax, b.st);
      sets[2] = "time.theta_f=0.3";
      snprintf(sdt, sizeof sdt, "time.dt=%.17g", 0.1 * hs);
      c = run(bar1, sets, 3, 4000 * 0.1 * hs);
      ok(c.emax > 10, "theta = theta_f = 0.3 (theta + theta_f < 1): grows even at h = 0.1 x that limit (max E/E0 = %.3g)", c.emax);
      sets[1] = "time.theta=0.5";
      sets[2] = "time.theta_f=0.5";
      snprintf(sdt, sizeof sdt, "time.dt=%.17g", 10 * hs);
      d = run(bar1, sets, 3, 400 * 10 * hs);
      ok(d.st == 0 && d.emax < 1 + 1e-9, "theta = theta_f = 1/2 stays unconditionally stable (h = 10x, max E/E0 = %.12f)", d.emax);
    }
    free(a.u), free(b.u), free(c.u), free(d.u);
  }
  {
    /* the explicit scheme refuses a consistent mass */
    outcome o = bar_run(4, 0.01, 0.01, " mass = \"consistent\";", NULL, NULL);
    ok(o.st == MO_EINPUT, "scheme explicit with mass = consistent is refused (status %d)", o.st);
    free(o.u);
  }
  return done_testing();
}
