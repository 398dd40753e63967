/* test_reference.c: the closed forms of src/reference.c (doc/theory.md §3: (T5), (T6), (T43),
   (T44)) at points worked out by hand from the physics (doc/architecture.md §11), their energy and
   their internal consistency (v = du/dt, eps = du/dx), and the reference block of the shipped
   cases. */
#include "config.h"
#include <moreau/moreau.h>
#include "testlib.h"

/* The closed form at (x, t): one call per value, so that no ok(...) both calls and prints. */
static double ref_u(const mo_reference *R, double x, double t)
{
  double u, v, e;
  mo_reference_field(R, x, t, &u, &v, &e);
  return u;
}
static double ref_v(const mo_reference *R, double x, double t)
{
  double u, v, e;
  mo_reference_field(R, x, t, &u, &v, &e);
  return v;
}
static double ref_eps(const mo_reference *R, double x, double t)
{
  double u, v, e;
  mo_reference_field(R, x, t, &u, &v, &e);
  return e;
}
static double ref_p(const mo_reference *R, double t)
{
  double p;
  mo_reference_contact(R, t, &p);
  return p;
}

/* u, v and eps at (x, t) against hand values, to tol * scale for u, tol * vscale for v and
   tol * escale for eps. */
static void check_point(const mo_reference *R, const char *what, double x, double t, double u, double v,
                        double eps, double uscale, double vscale, double escale)
{
  double gu = ref_u(R, x, t), gv = ref_v(R, x, t), ge = ref_eps(R, x, t);
  is_close(gu, u, 1e-12 * uscale, "%s: u(%g, %g) = %.10g", what, x, t, u);
  is_close(gv, v, 1e-12 * vscale, "%s: v(%g, %g) = %.10g", what, x, t, v);
  is_close(ge, eps, 1e-12 * escale, "%s: eps(%g, %g) = %.10g", what, x, t, eps);
}

/* Energy of the closed form along the bar [x0, x0 + s L] at time t: 1/2 rho A v^2 + 1/2 E A
   eps^2 integrated by the midpoint rule on n cells (E = rho c^2). A front inside a cell costs
   O(1/n) of the energy. */
static double ref_energy(const mo_reference *R, double x0, double s, double t, int n)
{
  double E = R->density * R->c * R->c, dx = R->length / n, sum = 0;
  int k;
  for (k = 0; k < n; k++) {
    double x = x0 + s * (k + 0.5) * dx, u, v, e;
    mo_reference_field(R, x, t, &u, &v, &e);
    sum += 0.5 * R->density * R->area * v * v + 0.5 * E * R->area * e * e;
  }
  return sum * dx;
}

/* v against the central difference of u in t, eps against that in x, at a point away from
   every front; returns the larger mismatch relative to the scales of v and eps. */
static double consistency(const mo_reference *R, double x, double t, double dx, double dt, double vs, double es)
{
  double dudt = (ref_u(R, x, t + dt) - ref_u(R, x, t - dt)) / (2 * dt);
  double dudx = (ref_u(R, x + dx, t) - ref_u(R, x - dx, t)) / (2 * dx);
  double a = fabs(dudt - ref_v(R, x, t)) / vs, b = fabs(dudx - ref_eps(R, x, t)) / es;
  return a > b ? a : b;
}

/* The reference block of a shipped case (its scene built, so that the block is validated and
   the body resolved). */
static int case_reference(const char *name, mo_reference *R)
{
  char path[4096];
  mo_ctx ctx;
  mo_case *cs = NULL;
  mo_scene *sc = NULL;
  int st;
  mo_ctx_init(&ctx);
  tl_case_path(path, sizeof path, name);
  st = mo_case_load(path, &cs, &ctx);
  if (!st) st = mo_case_validate(cs, &ctx);
  if (!st) st = mo_scene_build(cs, &sc, &ctx);
  if (!st) *R = sc->ref;
  else diag("%s: %s", name, ctx.errmsg);
  mo_scene_free(sc);
  mo_case_free(cs);
  return st;
}

/* A case text with only a bar and a reference block: mo_reference_build's checks. */
static int build_reference(const char *block, mo_reference *R, char *msg, size_t n)
{
  char text[2048];
  mo_ctx ctx;
  mo_case *cs = NULL;
  mo_scene *sc = NULL;
  int st;
  mo_ctx_init(&ctx);
  snprintf(text, sizeof text,
           "bodies = ( { name = \"bar\"; mesh = { generator = \"bar\"; length = 1.0; elements = 4; };\n"
           "  material = { E = 1.0; rho = 1.0; area = 1.0; }; fix = ( { set = \"left\"; } ); } );\n"
           "time = { scheme = \"theta\"; dt = 0.1; end = 1.0; };\n%s\n",
           block);
  st = tl_scene(text, "ref.cfg", &cs, &sc, &ctx);
  if (!st) *R = sc->ref;
  snprintf(msg, n, "%s", st ? ctx.errmsg : "");
  mo_scene_free(sc);
  mo_case_free(cs);
  return st;
}

/* --- rods_impact (doc/architecture.md §11, BDZ07 §6.1) ----------------------------------------------------- */

static void test_rods(void)
{
  mo_reference R, Rr;
  double c, L, v0, g, t0, t1, F0, ec, val;
  if (case_reference("rods-1d", &R)) {
    ok(0, "rods-1d: the reference builds");
    return;
  }
  ok(R.type == MO_REF_RODS_IMPACT && !strcmp(mo_reference_name(R.type), "rods_impact"),
     "rods-1d: reference type rods_impact");
  c = R.c;
  L = R.length;
  v0 = R.velocity;
  g = R.gap;
  /* c = sqrt(E / rho) = sqrt(2e11 / 7800) = 5063.696835 m/s */
  is_close(c, sqrt(2e11 / 7800.0), 1e-9, "rods-1d: c = sqrt(E / rho) = 5063.6968 m/s");
  ok(R.x0 == -0.0005 && R.direction == 1 && L == 1 && v0 == 10 && g == 0.0005,
     "rods-1d: the left rod, contact end at x = -0.5 mm, moving toward +x at 10 m/s, gap 0.5 mm");
  t0 = 5e-5;                      /* impact: g / v0 = 0.5 mm / 10 m/s = 50 us */
  t1 = t0 + 3.9496835316263e-4;   /* release: t0 + 2L/c = 50 us + 394.968 us = 444.968 us */
  F0 = 157987.341265052;          /* rho c v0 A = 7800 * 5063.6968 * 10 * 4e-4 N */
  ec = 1.97484176581315e-3;       /* strain behind the wave: v0 / c */

  /* before the impact: the rod translates rigidly, u = v0 t (t = 30 us: 0.3 mm) */
  check_point(&R, "rods, before impact, contact end", -0.0005, 3e-5, 3e-4, v0, 0, 1e-3, v0, ec);
  check_point(&R, "rods, before impact, free end", -1.0005, 3e-5, 3e-4, v0, 0, 1e-3, v0, ec);
  /* in contact (t = 200 us): the contact end stays at g, at rest, compressed by v0 / c */
  check_point(&R, "rods, in contact, contact end", -0.0005, 2e-4, g, 0, -ec, 1e-3, v0, ec);
  /* xi = 0.5 m from the contact end: the wave arrives at t0 + 0.5 / c = 148.742 us and the
     unloading wave at t0 + 1.5 / c = 346.226 us */
  check_point(&R, "rods, xi = 0.5 before the wave (t = 100 us)", -0.5005, 1e-4, 1e-3, v0, 0, 1e-3, v0, ec);
  /* behind the wave: stopped where it was at 148.742 us, u = v0 * 148.742 us = 1.48742 mm */
  check_point(&R, "rods, xi = 0.5 behind the wave (t = 200 us)", -0.5005, 2e-4, 1.4874208829065748e-3, 0, -ec,
              1e-3, v0, ec);
  /* behind the unloading wave (t = 400 us): -v0, unstrained; u = 1.48742 mm - 10 m/s *
     (400 - 346.226) us = 0.94968 mm */
  check_point(&R, "rods, xi = 0.5 behind the unloading wave (t = 400 us)", -0.5005, 4e-4, 9.496835316263e-4, -v0, 0,
              1e-3, v0, ec);
  /* xi = 0.25: wave at t0 + 0.25 / c = 99.371 us, unloading at t0 + 1.75 / c = 395.597 us */
  check_point(&R, "rods, xi = 0.25 in compression (t = 300 us)", -0.2505, 3e-4, v0 * (t0 + 0.25 / c), 0, -ec, 1e-3,
              v0, ec);
  /* free end: +v0 until t0 + L/c = 247.484 us, then -v0; peak g + v0 L / c = 2.47484 mm */
  is_close(ref_u(&R, -1.0005, t0 + L / c), 2.47484176581315e-3, 1e-15,
           "rods, free end: peak displacement g + v0 L / c = 2.475 mm at t0 + L/c");
  is_close(ref_v(&R, -1.0005, 2.4e-4), v0, 0, "rods, free end: +v0 at 240 us");
  is_close(ref_v(&R, -1.0005, 2.6e-4), -v0, 0, "rods, free end: -v0 at 260 us");
  is_close(ref_eps(&R, -1.0005, 2.47e-4), 0, 0, "rods, free end: stress free at every time");
  /* after the release (t = 500 us): the whole rod at -v0, the contact end at g - v0 (t - t1)
     = 0.5 mm - 10 * 55.032 us = -0.0503 mm */
  check_point(&R, "rods, after release, contact end", -0.0005, 5e-4, -5.031646837369997e-05, -v0, 0, 1e-3, v0, ec);
  check_point(&R, "rods, after release, middle", -0.5005, 5e-4, 9.496835316263e-4 - v0 * (5e-4 - 4e-4), -v0, 0, 1e-3,
              v0, ec);

  /* force and pressure */
  is_close(ref_p(&R, 2e-4), 3.9496835316262996e8, 1e-3, "rods: contact stress rho c v0 = 3.9497e8 Pa during contact");
  ok(mo_reference_contact(&R, 4e-5, &val) == 0 && val == 0, "rods: open before the impact (40 us)");
  ok(mo_reference_contact(&R, 2e-4, &val) == 1, "rods: closed at 200 us");
  ok(mo_reference_contact(&R, 4.5e-4, &val) == 0 && val == 0, "rods: open after the release (450 us)");
  ok(mo_reference_eval(&R, MO_Q_CX, -0.0005, 2e-4, &val) == 1 && fabs(val + F0) <= 1e-9 * F0,
     "rods: force on the left rod at its contact end -rho c v0 A = -1.5799e5 N (toward -x)");
  ok(mo_reference_eval(&R, MO_Q_CX, -0.5005, 2e-4, &val) == 0, "rods: no contact force away from the contact end");
  ok(mo_reference_eval(&R, MO_Q_PN, -0.0005, 2e-4, &val) == 1 && fabs(val - F0 / 4e-4) <= 1e-9 * F0 / 4e-4,
     "rods: probe pn = rho c v0");
  ok(mo_reference_eval(&R, MO_Q_VX, -0.5005, 4e-4, &val) == 1 && val == -v0, "rods: probe vx from the field");
  is_close(mo_reference_release_time(&R), t1, 1e-15, "rods: release at t0 + 2L/c = 444.968 us");
  /* impulse: 0 before the impact; F0 (200 - 50) us = 23.6981 N s; after the release
     F0 2L/c = 2 rho A L v0 = 2 m v0 = 2 * 3.12 * 10 = 62.4 N s */
  is_close(mo_reference_impulse(&R, 4e-5), 0, 0, "rods: no impulse before the impact");
  is_close(mo_reference_impulse(&R, 2e-4), 23.698101189757804, 1e-10, "rods: impulse to 200 us F0 * 150 us = 23.698 N s");
  is_close(mo_reference_impulse(&R, 6e-4), 62.4, 1e-10, "rods: impulse per rod 2 m v0 = 62.4 N s");
  /* energy: 1/2 m v0^2 = 1/2 * 3.12 * 100 = 156 J per rod, before, during and after */
  {
    double e1 = ref_energy(&R, -0.0005, -1, 3e-5, 100000), e2 = ref_energy(&R, -0.0005, -1, 2e-4, 100000),
           e3 = ref_energy(&R, -0.0005, -1, 3.5e-4, 100000), e4 = ref_energy(&R, -0.0005, -1, 5e-4, 100000);
    ok(fabs(e1 - 156) <= 1e-3 && fabs(e2 - 156) <= 1e-3 && fabs(e3 - 156) <= 1e-3 && fabs(e4 - 156) <= 1e-3,
       "rods: energy of the closed form 156 J before (%.6f), during (%.6f, %.6f) and after (%.6f) the contact", e1, e2, e3,
       e4);
  }
  {
    double w = consistency(&R, -0.3, 1e-4, 1e-6, 1e-9, v0, ec), w2 = consistency(&R, -0.3, 3e-4, 1e-6, 1e-9, v0, ec),
           w3 = consistency(&R, -0.3, 5e-4, 1e-6, 1e-9, v0, ec);
    ok(w < 1e-6 && w2 < 1e-6 && w3 < 1e-6, "rods: v = du/dt and eps = du/dx away from the fronts (%.1e, %.1e, %.1e)", w, w2,
       w3);
  }

  /* the right rod: direction -1, contact end at +0.5 mm; mirror image of the left one */
  Rr = R;
  Rr.direction = -1;
  Rr.x0 = 0.0005;
  check_point(&Rr, "rods, right rod, xi = 0.5 behind the wave", 0.5005, 2e-4, -1.4874208829065748e-3, 0, -ec, 1e-3,
              v0, ec);
  check_point(&Rr, "rods, right rod, before impact", 0.7, 3e-5, -3e-4, -v0, 0, 1e-3, v0, ec);
  ok(mo_reference_eval(&Rr, MO_Q_CX, 0.0005, 2e-4, &val) == 1 && fabs(val - F0) <= 1e-9 * F0,
     "rods, right rod: contact force +rho c v0 A (toward +x)");
}

/* --- bar_obstacle (doc/architecture.md §11, Doyen-Ern-Piperno benchmark 1) -------------------------------- */

static void test_obstacle(void)
{
  mo_reference R, S;
  double val;
  if (case_reference("bar-obstacle", &R)) {
    ok(0, "bar-obstacle: the reference builds");
    return;
  }
  ok(R.type == MO_REF_BAR_OBSTACLE && R.length == 1 && R.c == 1 && R.amplitude == 0.5 && R.x0 == 0,
     "bar-obstacle: reference bar_obstacle, L = c = 1, amplitude 1/2, contact end at 0");
  /* t = 0: u0 = 1/2 - x/2 at rest, strain -1/2 */
  check_point(&R, "obstacle, t = 0", 0.4, 0, 0.3, 0, -0.5, 1, 1, 1);
  /* phase 1, the end approaches (t = 0.5): behind the release wave from x = 0 (x < t) the bar
     is unstrained and moves at -1/2 with u = (1 - t)/2 = 0.25; ahead (x > t) it is still at
     u0, at rest, strain -1/2 */
  check_point(&R, "obstacle, approach (t = 0.5), end x = 0", 0, 0.5, 0.25, -0.5, 0, 1, 1, 1);
  check_point(&R, "obstacle, approach (t = 0.5), x = 0.25", 0.25, 0.5, 0.25, -0.5, 0, 1, 1, 1);
  check_point(&R, "obstacle, approach (t = 0.5), x = 0.75", 0.75, 0.5, 0.125, 0, -0.5, 1, 1, 1);
  check_point(&R, "obstacle, approach (t = 0.5), clamp x = 1", 1, 0.5, 0, 0, -0.5, 1, 1, 1);
  /* t = 1: the end reaches the obstacle, u = 0 everywhere, v = -1/2 */
  check_point(&R, "obstacle, impact (t = 1), x = 0.5", 0.5, 1, 0, -0.5, 0, 1, 1, 1);
  /* phase 2, contact (t = 1.5): the end held, stress 1/2 at x = 0. Behind the wave from the
     obstacle (x < 0.5): at rest, strain -1/2, u = -x/2 (x = 0.25: -0.125) */
  check_point(&R, "obstacle, contact (t = 1.5), end x = 0", 0, 1.5, 0, 0, -0.5, 1, 1, 1);
  check_point(&R, "obstacle, contact (t = 1.5), x = 0.25", 0.25, 1.5, -0.125, 0, -0.5, 1, 1, 1);
  /* t = 1.25: the middle not yet reached by either wave, still at -1/2 since t = 1: u =
     -0.25/2 = -0.125, unstrained; near the clamp (x = 0.9 > 1 - 0.25) the wave from the clamp
     stopped it: at rest, tension +1/2, u = -(1 - x)/2 = -0.05 */
  check_point(&R, "obstacle, contact (t = 1.25), x = 0.5", 0.5, 1.25, -0.125, -0.5, 0, 1, 1, 1);
  check_point(&R, "obstacle, contact (t = 1.25), x = 0.9", 0.9, 1.25, -0.05, 0, 0.5, 1, 1, 1);
  check_point(&R, "obstacle, contact (t = 1.25), clamp x = 1", 1, 1.25, 0, 0, 0.5, 1, 1, 1);
  /* t = 2: the waves have crossed: u = 0, v = +1/2 everywhere, the end leaves */
  check_point(&R, "obstacle, release (t = 2), x = 0.3", 0.3, 2, 0, 0.5, 0, 1, 1, 1);
  check_point(&R, "obstacle, release (t = 2), end x = 0", 0, 2, 0, 0.5, 0, 1, 1, 1);
  /* phase 3, flight back (t = 2.5): ahead of the wave from the clamp (x < 0.5) u = (t - 2)/2
     = 0.25 at +1/2; behind it (x > 0.5) at rest with strain -1/2, u = (1 - x)/2 */
  check_point(&R, "obstacle, leaving (t = 2.5), end x = 0", 0, 2.5, 0.25, 0.5, 0, 1, 1, 1);
  check_point(&R, "obstacle, leaving (t = 2.5), x = 0.25", 0.25, 2.5, 0.25, 0.5, 0, 1, 1, 1);
  check_point(&R, "obstacle, leaving (t = 2.5), x = 0.75", 0.75, 2.5, 0.125, 0, -0.5, 1, 1, 1);
  check_point(&R, "obstacle, leaving (t = 2.5), clamp x = 1", 1, 2.5, 0, 0, -0.5, 1, 1, 1);
  /* period 3: t = 3.5 and 9.5 as t = 0.5; t = 12 (end of the standard run) as t = 0 */
  check_point(&R, "obstacle, period 3 (t = 9.5), x = 0.25", 0.25, 9.5, 0.25, -0.5, 0, 1, 1, 1);
  check_point(&R, "obstacle, period 3 (t = 10.5), x = 0.25", 0.25, 10.5, -0.125, 0, -0.5, 1, 1, 1);
  check_point(&R, "obstacle, t = 12 back to u0, x = 0.6", 0.6, 12, 0.2, 0, -0.5, 1, 1, 1);
  /* contact stress 1/2 during [1, 2] (mod 3), zero otherwise */
  is_close(ref_p(&R, 1.5), 0.5, 1e-15, "obstacle: contact stress 1/2 at t = 1.5");
  is_close(ref_p(&R, 10.9), 0.5, 1e-15, "obstacle: contact stress 1/2 at t = 10.9 (fourth period)");
  ok(mo_reference_contact(&R, 0.5, &val) == 0 && mo_reference_contact(&R, 2.5, &val) == 0,
     "obstacle: open during the approach and the flight back");
  ok(mo_reference_eval(&R, MO_Q_CX, 0, 1.5, &val) == 1 && fabs(val - 0.5) < 1e-15,
     "obstacle: force on the bar at x = 0: +1/2 (toward +x)");
  is_close(mo_reference_release_time(&R), 2, 1e-15, "obstacle: release at t = 2");
  /* impulse: 1/2 per unit time of contact: [0, 1.5] 0.25; [0, 2.5] 0.5; [0, 4.25] 0.625;
     [0, 12] four contacts, 2 */
  is_close(mo_reference_impulse(&R, 1.5), 0.25, 1e-14, "obstacle: impulse over [0, 1.5] = 1/2 * 1/2");
  is_close(mo_reference_impulse(&R, 2.5), 0.5, 1e-14, "obstacle: impulse over [0, 2.5] = 1/2");
  is_close(mo_reference_impulse(&R, 4.25), 0.625, 1e-14, "obstacle: impulse over [0, 4.25] = 1/2 + 1/8");
  is_close(mo_reference_impulse(&R, 12), 2, 1e-14, "obstacle: impulse over [0, 12] = 2");
  {
    /* exact energy 1/8 = 1/2 E A (1/2)^2 L in every phase */
    double e[5], ts[5] = {0.3, 1.2, 1.75, 2.6, 11.1};
    int k, good = 1;
    for (k = 0; k < 5; k++) {
      e[k] = ref_energy(&R, 0, 1, ts[k], 100000);
      good &= fabs(e[k] - 0.125) <= 1e-5;
    }
    ok(good, "obstacle: energy 1/8 at t = 0.3, 1.2, 1.75, 2.6, 11.1 (%.7f %.7f %.7f %.7f %.7f)", e[0], e[1], e[2], e[3],
       e[4]);
  }
  {
    double w1 = consistency(&R, 0.6, 0.3, 1e-7, 1e-7, 0.5, 0.5), w2 = consistency(&R, 0.3, 1.6, 1e-7, 1e-7, 0.5, 0.5),
           w3 = consistency(&R, 0.6, 1.25, 1e-7, 1e-7, 0.5, 0.5), w4 = consistency(&R, 0.2, 2.6, 1e-7, 1e-7, 0.5, 0.5);
    ok(w1 < 1e-6 && w2 < 1e-6 && w3 < 1e-6 && w4 < 1e-6,
       "obstacle: v = du/dt and eps = du/dx in each phase (%.1e %.1e %.1e %.1e)", w1, w2, w3, w4);
  }

  /* scaled: L = 2, c = 4, amplitude 0.1, rho = 3, A = 0.5, so E = rho c^2 = 48, period 3L/c
     = 1.5, contact during [L/c, 2L/c] = [0.5, 1], stress E a / L = 2.4, force 1.2 */
  S = R;
  S.length = 2;
  S.c = 4;
  S.amplitude = 0.1;
  S.density = 3;
  S.area = 0.5;
  /* t = 0.25 (ct/L = 0.5): the release wave at x = 1; x = 0.5 behind it: u = a (1 - 0.5) =
     0.05, v = -c a / L = -0.2; x = 1.5 ahead: u = a (1 - 1.5/2) = 0.025, strain -a/L = -0.05 */
  check_point(&S, "obstacle scaled, approach, x = 0.5", 0.5, 0.25, 0.05, -0.2, 0, 0.1, 0.2, 0.05);
  check_point(&S, "obstacle scaled, approach, x = 1.5", 1.5, 0.25, 0.025, 0, -0.05, 0.1, 0.2, 0.05);
  /* t = 0.75 (contact): the end held, strain -a/L */
  check_point(&S, "obstacle scaled, contact, end", 0, 0.75, 0, 0, -0.05, 0.1, 0.2, 0.05);
  is_close(ref_p(&S, 0.75), 2.4, 1e-13, "obstacle scaled: contact stress E a / L = 48 * 0.1 / 2 = 2.4");
  ok(mo_reference_contact(&S, 1.2, &val) == 0, "obstacle scaled: open at t = 1.2 (> 2L/c = 1)");
  is_close(mo_reference_release_time(&S), 1, 1e-15, "obstacle scaled: release at 2L/c = 1");
  is_close(mo_reference_impulse(&S, 1.5), 0.6, 1e-13, "obstacle scaled: impulse over one period 2.4 * 0.5 * 0.5 = 0.6");
  is_close(ref_energy(&S, 0, 1, 0.9, 100000), 0.06, 1e-6,
           "obstacle scaled: energy 1/2 E A (a/L)^2 L = 0.5 * 48 * 0.5 * 0.0025 * 2 = 0.06");
}

/* --- bar_release (doc/theory.md (T5)) ---------------------------------------------------------- */

static void test_release(void)
{
  mo_reference R;
  double val;
  memset(&R, 0, sizeof R);
  R.type = MO_REF_BAR_RELEASE;
  R.length = 2;
  R.c = 3;
  R.strain = 1e-3;
  R.x0 = 0;
  R.density = 1;
  R.area = 1;
  /* clamped at 0, free at L = 2, released from u = eps x. At t = 1/3 the unloading wave from
     the free end is at x = L - c t = 1. x = 0.5 ahead of it: still u = eps x = 5e-4, at rest,
     strain eps. x = 1.5 behind it: unstrained, u = eps * 1 = 1e-3, v = -eps c = -3e-3 */
  check_point(&R, "bar_release, ahead of the wave", 0.5, 1.0 / 3, 5e-4, 0, 1e-3, 1e-3, 3e-3, 1e-3);
  check_point(&R, "bar_release, behind the wave", 1.5, 1.0 / 3, 1e-3, -3e-3, 0, 1e-3, 3e-3, 1e-3);
  /* free end: u(L, t) = g(L - ct), a triangle wave of amplitude eps L = 2e-3, period 4L/c */
  is_close(ref_u(&R, 2, 2.0 / 3), 0, 1e-18, "bar_release: free end at 0 at t = L/c");
  is_close(ref_u(&R, 2, 4.0 / 3), -2e-3, 1e-15, "bar_release: free end at -eps L at t = 2L/c");
  is_close(ref_u(&R, 2, 8.0 / 3), 2e-3, 1e-15, "bar_release: free end back at eps L at t = 4L/c");
  is_close(ref_v(&R, 2, 1.0), -3e-3, 1e-15, "bar_release: free end at -eps c = -3e-3 during (0, 2L/c)");
  is_close(ref_u(&R, 0, 1.1), 0, 1e-18, "bar_release: the clamp does not move");
  ok(mo_reference_eval(&R, MO_Q_PN, 1, 1, &val) == 0 && mo_reference_eval(&R, MO_Q_CX, 0, 1, &val) == 0,
     "bar_release: no contact quantities");
  ok(isnan(mo_reference_release_time(&R)) && isnan(mo_reference_impulse(&R, 1)), "bar_release: no release, no impulse");
  {
    /* energy 1/2 E A eps^2 L = 1/2 * 9 * 1e-6 * 2 = 9e-6, conserved */
    double e1 = ref_energy(&R, 0, 1, 0.1, 100000), e2 = ref_energy(&R, 0, 1, 1.7, 100000);
    ok(fabs(e1 - 9e-6) <= 1e-10 && fabs(e2 - 9e-6) <= 1e-10,
       "bar_release: energy 1/2 E A eps^2 L = 9e-6 at t = 0.1 (%.9g) and 1.7 (%.9g)", e1, e2);
  }
  {
    double w1 = consistency(&R, 0.5, 0.2, 1e-7, 1e-7, 3e-3, 1e-3), w2 = consistency(&R, 1.5, 0.9, 1e-7, 1e-7, 3e-3, 1e-3);
    ok(w1 < 1e-6 && w2 < 1e-6, "bar_release: v = du/dt and eps = du/dx (%.1e, %.1e)", w1, w2);
  }
}

/* --- bar_step_velocity (doc/theory.md (T6)) ---------------------------------------------------- */

static void test_step_velocity(void)
{
  mo_reference R;
  memset(&R, 0, sizeof R);
  R.type = MO_REF_BAR_STEP_VELOCITY;
  R.length = 1;
  R.c = 1;
  R.velocity = 1;
  R.x0 = 0;
  R.density = 1;
  R.area = 1;
  /* clamped at 0, end x = 1 pulled at V = 1 from rest. t = 0.5: the wave from the end is at
     x = 0.5. x = 0.25 ahead of it: at rest, unstrained. x = 0.75 behind it: v = V, strain
     V/c = 1 (tension), u = V (t - (1 - x)/c) = 0.25 */
  check_point(&R, "bar_step_velocity, ahead of the wave", 0.25, 0.5, 0, 0, 0, 1, 1, 1);
  check_point(&R, "bar_step_velocity, behind the wave", 0.75, 0.5, 0.25, 1, 1, 1, 1, 1);
  /* t = 1.5: reflected at the clamp at t = 1, now at x = 0.5; x = 0.25 behind it: at rest,
     strain 2V/c = 2, u = 2 * 0.25 = 0.5 */
  check_point(&R, "bar_step_velocity, behind the reflected wave", 0.25, 1.5, 0.5, 0, 2, 1, 1, 1);
  check_point(&R, "bar_step_velocity, driven end", 1, 0.3, 0.3, 1, 1, 1, 1, 1);
  /* the clamp: unstrained until the wave reaches it at t = L/c = 1, then 2V/c */
  check_point(&R, "bar_step_velocity, clamp before the wave", 0, 0.7, 0, 0, 0, 1, 1, 1);
  check_point(&R, "bar_step_velocity, clamp after the reflection", 0, 1.5, 0, 0, 2, 1, 1, 1);
  {
    /* energy balance: at t = 0.5 the loaded half carries 1/2 rho v^2 + 1/2 E eps^2 = 1 per unit
       length over 0.5: E = 0.5 = work of the end force E A V/c at speed V over 0.5 */
    double e = ref_energy(&R, 0, 1, 0.5, 100000);
    is_close(e, 0.5, 1e-5, "bar_step_velocity: energy at t = 0.5 equals the end's work 0.5");
  }
  {
    double w1 = consistency(&R, 0.8, 0.5, 1e-7, 1e-7, 1, 1), w2 = consistency(&R, 0.2, 1.5, 1e-7, 1e-7, 1, 1);
    ok(w1 < 1e-6 && w2 < 1e-6, "bar_step_velocity: v = du/dt and eps = du/dx (%.1e, %.1e)", w1, w2);
  }
}

/* --- energy, and the checks of the reference block -------------------------------------------- */

static void test_energy_and_build(void)
{
  mo_reference R;
  char msg[MO_ERRMSG_MAX];
  double val;
  int st;
  if (case_reference("bouncing-bar", &R)) {
    ok(0, "bouncing-bar: the reference builds");
  } else {
    /* m g h of the centre of mass: m = rho A L = 10, g = 10, h = 5 + L/2 = 10 */
    ok(R.type == MO_REF_ENERGY && !strcmp(mo_reference_name(R.type), "energy") && R.energy == 1000,
       "bouncing-bar: reference energy 1000 = m g h_cm = 10 * 10 * 10");
    ok(mo_reference_eval(&R, MO_Q_UX, 1, 1, &val) == 0 && mo_reference_eval(&R, MO_Q_PN, 1, 1, &val) == 0,
       "energy reference: no probe values");
    ok(isnan(mo_reference_release_time(&R)) && isnan(mo_reference_impulse(&R, 5)), "energy reference: no release, no impulse");
  }
  st = build_reference("reference = { type = \"rods_impact\"; length = 1.0; wave_speed = 1.0; velocity = 1.0; "
                       "contact_end = 0.0; };", &R, msg, sizeof msg);
  ok(st == MO_EINPUT && strstr(msg, "needs 'gap'"), "rods_impact without a gap is refused: %s", msg);
  st = build_reference("reference = { type = \"rods_impact\"; length = 1.0; wave_speed = 1.0; velocity = -1.0; "
                       "gap = 0.1; contact_end = 0.0; };", &R, msg, sizeof msg);
  ok(st == MO_EINPUT && strstr(msg, "positive velocity"), "rods_impact with a negative speed is refused: %s", msg);
  st = build_reference("reference = { type = \"bar_release\"; length = 1.0; wave_speed = 1.0; strain = 0.01; "
                       "body = \"rod\"; };", &R, msg, sizeof msg);
  ok(st == MO_EINPUT && strstr(msg, "rod"), "a reference naming an unknown body is refused: %s", msg);
  st = build_reference("reference = { type = \"bar_release\"; length = 1.0; wave_speed = 1.0; strain = 0.01; };", &R,
                       msg, sizeof msg);
  ok(st == MO_OK && R.type == MO_REF_BAR_RELEASE && R.body == 0 && isnan(R.energy),
     "bar_release builds on the only deformable body, without an exact energy");
}

int main(void)
{
  test_rods();
  test_obstacle();
  test_release();
  test_step_velocity();
  test_energy_and_build();
  return done_testing();
}
