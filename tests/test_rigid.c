/* test_rigid.c: rigid bodies against their closed forms (doc/architecture.md §11, doc/theory.md §12), for nscd
   and levelset: the bouncing ball, the block on a slope, the rolling disk and sphere, Newton's
   cradle, Housner's rocking block, the struck bar, the masonry arch; momentum and energy in
   impacts between free bodies; a resting stack over 10^4 steps; bodies of a mesh held rigid; a
   disk on a deformable block. */
#include "config.h"
#include "testlib.h"

#include <math.h>

#define G 9.81

static const char *solvers[] = {"nscd", "levelset"};

/* Run a shipped case (a folder or a file under cases/) with a back end and overrides; its history
   read into T. 0 on success. */
static int run_case(const char *name, const char *solver, const char *const *sets, int nset, const char *out,
                    tl_table *T)
{
  char path[4200], hist[4300];
  tl_case_path(path, sizeof path, name);
  if (tl_run(path, solver, sets, nset, out, name, NULL)) return -1;
  snprintf(hist, sizeof hist, "%s/history.csv", out);
  return tl_table_read(hist, T);
}

static int run_text(const char *text, const char *out, tl_table *T)
{
  char hist[4300];
  if (tl_run_text(text, out, "inline case", NULL)) return -1;
  snprintf(hist, sizeof hist, "%s/history.csv", out);
  return tl_table_read(hist, T);
}

/* A metric of summary.json (metrics.NAME.KEY). */
static double metric(const char *out, const char *name, const char *key)
{
  json_t *j = tl_summary(out);
  double v = tl_jnum(j, "metrics", name, key, NULL);
  json_decref(j);
  return v;
}

/* energy.max_growth of summary.json: for a scene at rest at t = 0 over the larger of the work given
   and the loads' scale (doc/theory.md (T49a)) */
static double growth(const char *out)
{
  json_t *j = tl_summary(out);
  double v = tl_jnum(j, "energy", "max_growth", NULL);
  json_decref(j);
  return v;
}

static double last(const tl_table *T, const char *col) { return tl_num(T, T->nrow - 1, tl_col(T, col)); }

/* --- the bouncing ball (T73) --------------------------------------------------------------- */

static void bounce(const char *file, const char *solver, const char *out)
{
  const double h0 = 1, e = 0.8, R = 0.05, h = 1e-3, v1 = sqrt(2 * G * h0), t1 = v1 / G;
  double tk = t1, vk = v1, worst_t = 0, worst_h = 0, m, ymin = HUGE_VAL, ymax = -HUGE_VAL;
  int i, k = 0, na = 0, cy, cv, ct, cf;
  tl_table T;
  if (run_case(file, solver, NULL, 0, out, &T)) {
    ok(0, "ball-bounce %s (%s) runs", file, solver);
    return;
  }
  cy = tl_col(&T, "ball.y");
  cv = tl_col(&T, "ball.vy");
  ct = tl_col(&T, "t");
  cf = tl_col(&T, "contact.force_n");
  /* impacts (vy from - to +) and apexes (vy from + to -) of the first four bounces */
  for (i = 1; i < T.nrow && k < 4; i++) {
    double va = tl_num(&T, i - 1, cv), vb = tl_num(&T, i, cv);
    if (va < 0 && vb > 0) {
      worst_t = fmax(worst_t, fabs(tl_num(&T, i, ct) - tk));
      vk *= e;
      tk += 2 * vk / G;
      k++;
    }
    if (va > 0 && vb <= 0 && na < 3) {
      double apex = fmax(tl_num(&T, i - 1, cy), tl_num(&T, i, cy)) - R, want = h0 * pow(e, 2 * (na + 1));
      worst_h = fmax(worst_h, fabs(apex - want) / want);
      na++;
    }
  }
  /* the impact is seen at the end of the step where vy turns, and the index set closes the contact
     up to half a step early: first order, a step or so per impact */
  ok(k == 4 && worst_t <= 3 * h, "ball-bounce %s (%s): the first 4 impact times within 3 h of t_k (worst %.2e s)",
     file, solver, worst_t);
  ok(na == 3 && worst_h <= 5e-3, "ball-bounce %s (%s): the first 3 apex heights e^2k h0 within 0.5 %% (worst %.2e)",
     file, solver, worst_h);
  /* at rest after t_inf = t1 (1 + e) / (1 - e) = 4.06 s: on the plane, the weight carried, no drift */
  for (i = 0; i < T.nrow; i++)
    if (tl_num(&T, i, ct) >= 4.3) {
      ymin = fmin(ymin, tl_num(&T, i, cy));
      ymax = fmax(ymax, tl_num(&T, i, cy));
    }
  m = !strcmp(file, "ball-bounce") ? 7800 * M_PI * R * R : 7800 * 4.0 / 3.0 * M_PI * R * R * R;
  ok(ymax - ymin < 1e-12 && fabs(ymin - R) < 1e-5 && fabs(last(&T, "ball.vy")) < 1e-12,
     "ball-bounce %s (%s): at rest from t = 4.3 s, y = R - %.2e m, no drift (%.1e m), vy = %.1e", file, solver, R - ymin,
     ymax - ymin, last(&T, "ball.vy"));
  is_close(tl_num(&T, T.nrow - 1, cf), m * G, 1e-9 * m * G, "ball-bounce %s (%s): at rest the contact carries m g", file,
           solver);
  tl_table_free(&T);
  tl_remove_dir(out);
}

/* --- a body on a slope (T74): errors of summary.json against the closed form ---------------- */

static void incline(const char *file, const char *body, double mu, const char *solver, const char *out, const char *what)
{
  char s1[64], s2[64], col[64];
  const char *sets[3];
  tl_table T;
  double ex, eo;
  snprintf(s1, sizeof s1, "contact.pairs.[0].mu=%g", mu);
  snprintf(s2, sizeof s2, "reference.mu=%g", mu);
  sets[0] = s1;
  sets[1] = s2;
  /* nscd's spin error is its tolerance times the velocity scale (8.5e-10 rad/s sliding at 1e-8):
     round-off is asked of a solve to 1e-12 */
  sets[2] = "contact.nscd.tol=1e-12";
  if (run_case(file, solver, sets, 3, out, &T)) {
    ok(0, "%s (%s) runs", what, solver);
    return;
  }
  snprintf(col, sizeof col, "%s.x", body);
  ex = metric(out, col, "linf_abs");
  snprintf(col, sizeof col, "%s.omega", body);
  if (tl_col(&T, col) < 0) snprintf(col, sizeof col, "%s.wz", body);
  eo = metric(out, col, "linf_abs");
  ok(ex < 1e-10 && eo < 1e-9, "%s (%s, mu = %g): x and the spin match the closed form to round-off (%.1e m, %.1e rad/s)",
     what, solver, mu, ex, eo);
  tl_table_free(&T);
  tl_remove_dir(out);
}

/* --- Newton's cradle -------------------------------------------------------------------------- */

static void cradle(const char *file, const double *want, const char *solver, const char *out)
{
  static const char *sets[] = {"contact.nscd.tol=1e-13", "output.precision=17"};
  tl_table T;
  double v[3], p, E;
  int k;
  if (run_case(file, solver, sets, 2, out, &T)) {
    ok(0, "newton-cradle %s (%s) runs", file, solver);
    return;
  }
  for (k = 0; k < 3; k++) {
    char col[32];
    snprintf(col, sizeof col, "b%d.vx", k + 1);
    v[k] = last(&T, col);
  }
  p = v[0] + v[1] + v[2];
  E = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
  ok(fabs(v[0] - want[0]) < 1e-9 && fabs(v[1] - want[1]) < 1e-9 && fabs(v[2] - want[2]) < 1e-9,
     "newton-cradle %s (%s): velocities after (%.10f, %.10f, %.10f) v0, Moreau's law gives (%g, %g, %g)", file, solver,
     v[0], v[1], v[2], want[0], want[1], want[2]);
  ok(fabs(p - 1) < 1e-12 && fabs(E - 1) < 1e-10, "newton-cradle %s (%s): momentum (%.1e) and energy (%.1e) conserved",
     file, solver, p - 1, E - 1);
  tl_table_free(&T);
  tl_remove_dir(out);
}

/* --- two free disks in an oblique, frictionless impact ----------------------------------------- */

static void oblique(const char *solver, double e, const char *out)
{
  char text[2000];
  const double m1 = 1000 * M_PI * 0.05 * 0.05, m2 = 1000 * M_PI * 0.03 * 0.03;
  double p0[2], p1[2], L0, L1, E0, E1, n[2], Un, W = 1 / m1 + 1 / m2, dE;
  tl_table T;
  int i;
  /* disk a at the origin moving at (1, 0.3), spinning; disk b ahead and above, at rest: they meet
     off the line of centres */
  snprintf(text, sizeof text,
           "title = \"oblique\";\n"
           "bodies = ( { name = \"a\"; type = \"disk\"; center = [0.0, 0.0]; radius = 0.05; density = 1000.0;\n"
           "             initial = { velocity = [1.0, 0.3]; omega = 4.0; }; },\n"
           "           { name = \"b\"; type = \"disk\"; center = [0.1, 0.06]; radius = 0.03; density = 1000.0; } );\n"
           "time = { dt = 1.0e-4; end = 0.05; };\n"
           "output = { precision = 17; };\n"
           "contact = { solver = \"%s\"; nscd = { tol = 1e-13; }; pairs = ( { master = \"a\"; slave = \"b\"; e = %g; } ); };\n",
           solver, e);
  if (run_text(text, out, &T)) {
    ok(0, "oblique impact (%s, e = %g) runs", solver, e);
    return;
  }
  for (i = 0; i < 2; i++) {
    p0[i] = m1 * tl_num(&T, 0, tl_col(&T, i ? "a.vy" : "a.vx")) + m2 * tl_num(&T, 0, tl_col(&T, i ? "b.vy" : "b.vx"));
    p1[i] = m1 * last(&T, i ? "a.vy" : "a.vx") + m2 * last(&T, i ? "b.vy" : "b.vx");
  }
  /* angular momentum about the origin: sum m (x vy - y vx) + I omega */
#define LMOM(row) (m1 * (tl_num(&T, row, tl_col(&T, "a.x")) * tl_num(&T, row, tl_col(&T, "a.vy")) -                   \
                         tl_num(&T, row, tl_col(&T, "a.y")) * tl_num(&T, row, tl_col(&T, "a.vx"))) +                  \
                   m2 * (tl_num(&T, row, tl_col(&T, "b.x")) * tl_num(&T, row, tl_col(&T, "b.vy")) -                   \
                         tl_num(&T, row, tl_col(&T, "b.y")) * tl_num(&T, row, tl_col(&T, "b.vx"))) +                  \
                   0.5 * m1 * 0.0025 * tl_num(&T, row, tl_col(&T, "a.omega")) +                                      \
                   0.5 * m2 * 0.0009 * tl_num(&T, row, tl_col(&T, "b.omega")))
  L0 = LMOM(0);
  L1 = LMOM(T.nrow - 1);
#undef LMOM
  /* the theta-scheme keeps L about a point exactly but for the impact step's position update,
     x+ = x- + h (v- + v+) / 2, which adds h/2 sum m v- x v+ (doc/theory.md §12.4) */
  for (i = 1; i < T.nrow; i++) {
    double dv = fabs(tl_num(&T, i, tl_col(&T, "a.vx")) - tl_num(&T, i - 1, tl_col(&T, "a.vx")));
    if (dv > 1e-9) {
      int k;
      for (k = 0; k < 2; k++) {
        const char *vx = k ? "b.vx" : "a.vx", *vy = k ? "b.vy" : "a.vy";
        double mk = k ? m2 : m1;
        L0 += 0.5 * 1e-4 * mk * (tl_num(&T, i - 1, tl_col(&T, vx)) * tl_num(&T, i, tl_col(&T, vy)) -
                                 tl_num(&T, i - 1, tl_col(&T, vy)) * tl_num(&T, i, tl_col(&T, vx)));
      }
    }
  }
  E0 = tl_num(&T, 0, tl_col(&T, "energy.kinetic"));
  E1 = last(&T, "energy.kinetic");
  ok(fabs(p1[0] - p0[0]) < 1e-12 * fabs(p0[0]) && fabs(p1[1] - p0[1]) < 1e-12 * fabs(p0[0]) &&
     fabs(L1 - L0) < 1e-12 * fabs(L0), "oblique impact (%s, e = %g): linear momentum, and angular momentum with the "
     "scheme's h/2 m v- x v+ of the impact step, conserved (%.1e, %.1e)",
     solver, e, fabs(p1[0] - p0[0]) / fabs(p0[0]), fabs(L1 - L0) / fabs(L0));
  /* frictionless: the spins are untouched, and the energy lost is (1 - e^2) U_n-^2 / (2 W_nn), U_n-
     the approach speed along the line of centres at the impact */
  {
    /* the centres when the impact is solved: the start of the step whose predicted gap g + h/2 U_n
       closes (T71); a moves at (1, 0.3), b at rest */
    double dx = 0.1, dy = 0.06, d = 0, t;
    int k;
    for (k = 0;; k++) {
      double tn = k * 1e-4, gx = dx - tn, gy = dy - 0.3 * tn, dd = sqrt(gx * gx + gy * gy), un = -(gx + 0.3 * gy) / dd;
      if (dd - 0.08 + 0.5e-4 * un <= 0 || k > 1000) {
        t = tn;
        d = dd;
        break;
      }
    }
    n[0] = (dx - t) / d;
    n[1] = (dy - 0.3 * t) / d;
    Un = -(1.0 * n[0] + 0.3 * n[1]); /* b at rest: U_n = (v_b - v_a) . n */
    dE = -(1 - e * e) * Un * Un / (2 * W);
  }
  ok(fabs((E1 - E0) - dE) < 1e-6 * E0 && fabs(last(&T, "a.omega") - 4) < 1e-12 && fabs(last(&T, "b.omega")) < 1e-12,
     "oblique impact (%s, e = %g): energy change %.9f J against (1 - e^2) U_n^2 / (2 W_nn) = %.9f J, spins kept", solver,
     e, E1 - E0, dE);
  tl_table_free(&T);
  tl_remove_dir(out);
}

/* --- Housner's rocking block ------------------------------------------------------------------ */

static void rocking(const char *solver, const char *out)
{
  static const char *sets[] = {"output.every=1", "time.end=2.0"};
  const double alpha = atan(0.2), want = 1 - 1.5 * sin(alpha) * sin(alpha);
  double worst = 0;
  int i, n = 0, cth, com;
  tl_table T;
  if (run_case("rocking-block", solver, sets, 2, out, &T)) {
    ok(0, "rocking-block (%s) runs", solver);
    return;
  }
  cth = tl_col(&T, "block.theta");
  com = tl_col(&T, "block.omega");
  /* an impact: theta crosses 0 (the block lands flat); omega just after over omega just before */
  for (i = 1; i + 1 < T.nrow; i++)
    if (tl_num(&T, i - 1, cth) * tl_num(&T, i, cth) < 0) {
      double r = fabs(tl_num(&T, i, com)) / fabs(tl_num(&T, i - 1, com));
      worst = fmax(worst, fabs(r - want));
      n++;
    }
  ok(n >= 4 && worst < 1e-3, "rocking-block (%s): %d impacts, |omega+| / |omega-| = 1 - 3/2 sin^2 alpha = %.5f within "
     "1e-3 at h = 1e-4 (worst %.2e)", solver, n, want, worst);
  tl_table_free(&T);
  tl_remove_dir(out);
}

/* --- the struck bar (T75) ------------------------------------------------------------------------ */

static void struck(const char *solver, const char *out)
{
  tl_table T;
  double ef, ev;
  if (run_case("rod-struck-by-mass", solver, NULL, 0, out, &T)) {
    ok(0, "rod-struck-by-mass (%s) runs", solver);
    return;
  }
  ef = metric(out, "end.cx", "l2_rel");
  ev = metric(out, "block.vx", "l2_rel");
  ok(ef < 0.06 && ev < 5e-3, "rod-struck-by-mass (%s): contact force (L2 %.3f) and striker velocity (L2 %.2e) follow "
     "Saint-Venant's exponential", solver, ef, ev);
  tl_table_free(&T);
  tl_remove_dir(out);
}

/* --- the masonry arch ---------------------------------------------------------------------------- */

static void arch(double t, int stands, const char *out)
{
  char s1[64];
  const char *sets[2];
  tl_table T;
  snprintf(s1, sizeof s1, "bodies.arch.arch.thickness=%g", t);
  sets[0] = s1;
  sets[1] = "time.end=0.1";
  if (run_case("masonry-arch", "nscd", sets, 2, out, &T)) {
    ok(0, "masonry-arch t/R = %g runs", t);
    return;
  }
  if (stands)
    ok(last(&T, "rigid.vmax") < 1e-6, "masonry-arch: t/R = %g stands (voussoirs at %.1e m/s after 0.1 s)", t,
       last(&T, "rigid.vmax"));
  else
    ok(last(&T, "rigid.vmax") > 0.05, "masonry-arch: t/R = %g collapses (%.2f m/s after 0.1 s)", t, last(&T, "rigid.vmax"));
  /* at rest at t = 0: no energy made by the contacts beyond round-off of the arch's weight times
     its size (the standing arch is given 3.5e-9 J, against which round-off read a growth of 1) */
  ok(growth(out) >= 0 && growth(out) < 1e-9, "masonry-arch: t/R = %g makes no energy (energy.max_growth %.2e)", t,
     growth(out));
  tl_table_free(&T);
  tl_remove_dir(out);
}

/* --- a resting stack: no penetration growth over 10^4 steps ------------------------------------- */

static const char *stack_text =
    "title = \"stack\";\n"
    "bodies = (\n"
    "  { name = \"floor\"; type = \"plane\"; point = [0.0, 0.0]; normal = [0.0, 1.0]; },\n"
    "  { name = \"b1\"; type = \"polygon\"; size = [0.2, 0.1]; center = [0.0, 0.05]; density = 1000.0; body_force = [0.0, -9.81]; },\n"
    "  { name = \"b2\"; type = \"polygon\"; size = [0.2, 0.1]; center = [0.02, 0.15]; density = 1000.0; body_force = [0.0, -9.81]; },\n"
    "  { name = \"d\"; type = \"disk\"; center = [0.05, 0.25]; radius = 0.05; density = 1000.0; body_force = [0.0, -9.81]; }\n"
    ");\n"
    "time = { dt = 1.0e-3; steps = %d; };\n"
    "output = { every = 100; };\n"
    "contact = { solver = \"%s\"; pairs = ( { master = \"floor\"; slave = \"b1\"; mu = 0.5; },\n"
    "  { master = \"b1\"; slave = \"b2\"; mu = 0.5; }, { master = \"b2\"; slave = \"d\"; mu = 0.5; } ); };\n";

static void stack(const char *solver, const char *out)
{
  char text[2000];
  double pen[2], y[2], g[2];
  int k, steps[2] = {100, 10000};
  for (k = 0; k < 2; k++) {
    tl_table T;
    snprintf(text, sizeof text, stack_text, steps[k], solver);
    if (run_text(text, out, &T)) {
      ok(0, "resting stack (%s, %d steps) runs", solver, steps[k]);
      return;
    }
    pen[k] = metric(out, "contact", "max_penetration");
    y[k] = last(&T, "d.y");
    g[k] = growth(out);
    tl_table_free(&T);
    tl_remove_dir(out);
  }
  ok(pen[1] <= pen[0] + 1e-12 && fabs(y[1] - y[0]) < 1e-9,
     "resting stack (%s): after 10^4 steps the penetration is what it was after 100 (%.2e, %.2e m) and the top disk has "
     "not moved (%.1e m)", solver, pen[0], pen[1], y[1] - y[0]);
  ok(g[0] >= 0 && g[1] >= 0 && g[0] < 1e-9 && g[1] < 1e-9, "resting stack (%s): no energy made (energy.max_growth %.2e, "
     "%.2e)", solver, g[0], g[1]);
}

/* --- a mesh held rigid --------------------------------------------------------------------------- */

/* A rigid rectangle mesh: mass and inertia of the rectangle, and on the slope of incline-block it
   slides as the polygon does (its bottom nodes on the plane). */
static void rigid_mesh(const char *solver, const char *out)
{
  char text[3000];
  const double a = 20 * M_PI / 180, mu = 0.2, acc = G * (sin(a) - mu * cos(a));
  tl_table T;
  json_t *j;
  double m, x0, x1;
  /* the block 0.1 x 0.1 of density 100 rotated by -20 degrees is placed by a mesh generated axis
     aligned: instead, a slope along x (normal (0, 1)) with gravity turned by 20 degrees */
  snprintf(text, sizeof text,
           "title = \"rigid mesh on a slope\";\n"
           "bodies = ( { name = \"slope\"; type = \"plane\"; point = [0.0, 0.0]; normal = [0.0, 1.0]; },\n"
           "  { name = \"block\"; type = \"rigid_mesh\"; density = 100.0; body_force = [%.17g, %.17g];\n"
           "    mesh = { generator = \"rectangle\"; origin = [0.0, 0.0]; size = [0.1, 0.1]; elements = [4, 3]; }; } );\n"
           "time = { dt = 1.0e-3; end = 0.5; };\n"
           "contact = { solver = \"%s\"; pairs = ( { slave = \"block\"; slave_set = \"bottom\"; master = \"slope\"; mu = %g; } ); };\n",
           G * sin(a), -G * cos(a), solver, mu);
  if (run_text(text, out, &T)) {
    ok(0, "rigid mesh on a slope (%s) runs", solver);
    return;
  }
  j = tl_summary(out);
  m = 0;
  {
    json_t *bs = json_object_get(json_object_get(j, "scene"), "bodies");
    size_t k;
    for (k = 0; k < json_array_size(bs); k++)
      if (!strcmp(json_string_value(json_object_get(json_array_get(bs, k), "name")), "block"))
        m = json_number_value(json_object_get(json_array_get(bs, k), "mass"));
  }
  json_decref(j);
  x0 = tl_num(&T, 0, tl_col(&T, "block.x"));
  x1 = last(&T, "block.x");
  is_close(m, 1.0, 1e-12, "rigid mesh: the mass of a 0.1 x 0.1 mesh of density 100 is 1 kg");
  ok(fabs((x1 - x0) - 0.5 * acc * 0.25) < 1e-10 && fabs(last(&T, "block.omega")) < 1e-12 &&
     fabs(last(&T, "block.y") - 0.05) < 1e-9,
     "rigid mesh on a slope (%s): slides %.12f m in 0.5 s, g (sin - mu cos) t^2 / 2 = %.12f m, without turning", solver,
     x1 - x0, 0.5 * acc * 0.25);
  tl_table_free(&T);
  tl_remove_dir(out);
}

/* A free box held rigid in 3D, spinning about an axis near its major one: the gyroscopic term
   keeps the world angular momentum R J R^T omega (to O(h)) and the kinetic energy. */
static void free_box(const char *out)
{
  static const char *text =
      "title = \"free box\";\n"
      "bodies = ( { name = \"box\"; type = \"rigid_mesh\"; density = 1000.0;\n"
      "  mesh = { generator = \"box\"; origin = [0.0, 0.0, 0.0]; size = [0.1, 0.2, 0.3]; elements = [1, 1, 1]; };\n"
      "  initial = { omega = [0.5, 0.3, 10.0]; }; } );\n"
      "time = { dt = 1.0e-4; end = 2.0; };\n"
      "output = { every = 100; };\n";
  const double m = 6, J[3] = {m * (0.04 + 0.09) / 12, m * (0.01 + 0.09) / 12, m * (0.01 + 0.04) / 12};
  double L0[3] = {J[0] * 0.5, J[1] * 0.3, J[2] * 10}, worst = 0, E0 = 0.5 * (J[0] * 0.25 + J[1] * 0.09 + J[2] * 100);
  tl_table T;
  int i, k;
  if (run_text(text, out, &T)) {
    ok(0, "free box runs");
    return;
  }
  for (i = 0; i < T.nrow; i++) {
    double q[4], R[9], w[3], b[3], L[3];
    for (k = 0; k < 4; k++) {
      char c[16];
      snprintf(c, sizeof c, "box.q%d", k);
      q[k] = tl_num(&T, i, tl_col(&T, c));
    }
    for (k = 0; k < 3; k++) {
      char c[16];
      snprintf(c, sizeof c, "box.w%c", "xyz"[k]);
      w[k] = tl_num(&T, i, tl_col(&T, c));
    }
    mo_quat_matrix(q, R);
    for (k = 0; k < 3; k++) b[k] = J[k] * (R[0 + k] * w[0] + R[3 + k] * w[1] + R[6 + k] * w[2]);
    for (k = 0; k < 3; k++) L[k] = R[3 * k] * b[0] + R[3 * k + 1] * b[1] + R[3 * k + 2] * b[2];
    for (k = 0; k < 3; k++) worst = fmax(worst, fabs(L[k] - L0[k]) / L0[2]);
  }
  ok(worst < 2e-3, "free box: world angular momentum kept to %.1e over 2 s (h = 1e-4)", worst);
  is_close(last(&T, "energy.kinetic"), E0, 1e-8 * E0, "free box: kinetic energy kept");
  tl_table_free(&T);
  tl_remove_dir(out);
}

/* --- free fall: the increments of a step formed before u moves (T247) ----------------------------
   A body falling from rest under its weight, spinning at a constant rate, with the theta-scheme at
   theta = 1/2 (the trapezoidal rule, exact for a constant acceleration): y(T) = y0 - g T^2 / 2, the
   external work m g^2 T^2 / 2, the turn omega T. Without a prescribed dof the scene takes the path
   without the start-of-step displacements (T245-T249); a second body with one fixed rotation, far
   away and without a load, puts the run on the general path: the same numbers to the bit. */
static void free_fall(int dim, const char *out)
{
  char text[2000], out2[600];
  const double g = 9.81, T = 0.5, w = 3.0, R = 0.05, rho = 1000.0;
  const double m = dim == 2 ? rho * M_PI * R * R : rho * 4.0 / 3 * M_PI * R * R * R;
  tl_table A, B;
  int k, same = 1, i;
  snprintf(out2, sizeof out2, "%s-fixed", out);
  for (k = 0; k < 2; k++) {
    const char *fix = k ? (dim == 2 ? "fix = ( { dofs = [\"theta\"]; } );" : "fix = ( { dofs = [\"rx\"]; } );") : "";
    if (dim == 2)
      snprintf(text, sizeof text,
               "title = \"free fall\";\n"
               "bodies = ( { name = \"a\"; type = \"disk\"; center = [0.0, 1.0]; radius = %g; density = %g;\n"
               "  body_force = [0.0, %g]; initial = { omega = %g; }; },\n"
               "  { name = \"b\"; type = \"disk\"; center = [5.0, 1.0]; radius = %g; density = %g; %s } );\n"
               "time = { scheme = \"theta\"; theta = 0.5; dt = 1.0e-3; end = %g; };\n"
               "output = { every = 10; };\n",
               R, rho, -g, w, R, rho, fix, T);
    else
      snprintf(text, sizeof text,
               "title = \"free fall\";\n"
               "bodies = ( { name = \"a\"; type = \"sphere\"; center = [0.0, 1.0, 0.0]; radius = %g; density = %g;\n"
               "  body_force = [0.0, %g, 0.0]; initial = { omega = [0.0, %.3f, 0.0]; }; },\n"
               "  { name = \"b\"; type = \"sphere\"; center = [5.0, 1.0, 0.0]; radius = %g; density = %g; %s } );\n"
               "time = { scheme = \"theta\"; theta = 0.5; dt = 1.0e-3; end = %g; };\n"
               "output = { every = 10; };\n",
               R, rho, -g, w, R, rho, fix, T);
    if (run_text(text, k ? out2 : out, k ? &B : &A)) {
      ok(0, "free fall (%dD) runs", dim);
      if (k) tl_table_free(&A);
      return;
    }
  }
  is_close(last(&A, "a.y"), 1.0 - 0.5 * g * T * T, 1e-12, "free fall (%dD): y(T) = y0 - g T^2 / 2", dim);
  is_close(last(&A, "energy.external_work"), 0.5 * m * g * g * T * T, 1e-11 * m * g * g * T * T,
           "free fall (%dD): the external work m g^2 T^2 / 2 = %.9g J", dim, 0.5 * m * g * g * T * T);
  if (dim == 2) is_close(last(&A, "a.theta"), w * T, 1e-12, "free fall (2D): the turn omega T");
  else /* a turn about y: q = (cos(omega T / 2), 0, sin(omega T / 2), 0) */
    is_close(last(&A, "a.q2"), sin(0.5 * w * T), 1e-9, /* the history's 10 digits */
             "free fall (3D): the quaternion's sin(omega T / 2)");
  for (i = 0; i < A.ncol && same; i++) {
    int j = tl_col(&B, A.name[i]), r;
    if (j < 0) continue;
    for (r = 0; r < A.nrow && r < B.nrow; r++)
      if (strcmp(A.cell[r][i], B.cell[r][j])) same = 0;
  }
  ok(same && A.nrow == B.nrow, "free fall (%dD): the same history to the bit with a prescribed dof elsewhere (the general path)", dim);
  tl_table_free(&A);
  tl_table_free(&B);
  tl_remove_dir(out);
  tl_remove_dir(out2);
}

/* --- a disk resting on a deformable block ---------------------------------------------------------- */

static void disk_on_block(const char *solver, const char *out)
{
  char text[2000];
  const double m = 1000 * M_PI * 0.05 * 0.05;
  tl_table T;
  snprintf(text, sizeof text,
           "title = \"disk on a deformable block\";\n"
           "bodies = ( { name = \"block\"; mesh = { generator = \"rectangle\"; origin = [-0.2, -0.1]; size = [0.4, 0.1]; "
           "elements = [8, 2]; };\n"
           "    material = { E = 1.0e7; nu = 0.3; rho = 1000.0; }; fix = ( { set = \"bottom\"; } ); },\n"
           "  { name = \"disk\"; type = \"disk\"; center = [0.013, 0.05]; radius = 0.05; density = 1000.0; "
           "body_force = [0.0, -9.81]; } );\n"
           "time = { theta = 1.0; dt = 1.0e-3; end = 1.0; };\n"
           "contact = { solver = \"%s\"; pairs = ( { slave = \"disk\"; master = \"block\"; master_set = \"top\"; mu = 0.5; } ); };\n",
           solver);
  if (run_text(text, out, &T)) {
    ok(0, "disk on a deformable block (%s) runs", solver);
    return;
  }
  /* theta = 1 damps the settling: the disk comes to rest on the block, its weight carried */
  is_close(last(&T, "contact.force_n"), m * G, 1e-6 * m * G, "disk on a deformable block (%s): the contact carries the "
           "disk's weight once settled", solver);
  ok(fabs(last(&T, "disk.vy")) < 1e-6 && last(&T, "disk.y") < 0.05 && last(&T, "disk.y") > 0.049,
     "disk on a deformable block (%s): at rest, the block compressed under it (y = %.6f m)", solver, last(&T, "disk.y"));
  tl_table_free(&T);
  tl_remove_dir(out);
}

int main(void)
{
  static const double touching[3] = {-1.0 / 3, 2.0 / 3, 2.0 / 3}, gapped[3] = {0, 0, 1};
  char out[512];
  int s;
  for (s = 0; s < 2; s++) {
    const char *S = solvers[s];
    snprintf(out, sizeof out, "tests/out/rigid-%s", S);
    bounce("ball-bounce", S, out);
    incline("incline-block", "block", 0.5, S, out, "incline-block (sticks)");
    incline("incline-block", "block", 0.2, S, out, "incline-block (slides)");
    incline("disk-roll", "disk", 0.3, S, out, "disk-roll (rolls)");
    incline("disk-roll", "disk", 0.1, S, out, "disk-roll (slips)");
    incline("disk-roll/sphere.cfg", "ball", 0.3, S, out, "disk-roll sphere (rolls)");
    incline("disk-roll/sphere.cfg", "ball", 0.1, S, out, "disk-roll sphere (slips)");
    cradle("newton-cradle", touching, S, out);
    cradle("newton-cradle/gapped.cfg", gapped, S, out);
    oblique(S, 0.5, out);
    oblique(S, 1.0, out);
    rocking(S, out);
    struck(S, out);
    stack(S, out);
    rigid_mesh(S, out);
    disk_on_block(S, out);
  }
  bounce("ball-bounce/sphere.cfg", "nscd", "tests/out/rigid-sphere");
  free_box("tests/out/rigid-box");
  free_fall(2, "tests/out/rigid-fall2");
  free_fall(3, "tests/out/rigid-fall3");
  arch(0.13, 1, "tests/out/rigid-arch");
  arch(0.09, 0, "tests/out/rigid-arch");
  done_testing();
}
