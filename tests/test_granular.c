/* test_granular.c: small versions of the granular scenes (doc/theory.md §12.8): the detection of a
   pack against a brute-force search as its grains move (the Verlet list kept and rebuilt), the
   momentum balance of a deposit with the walls' and floor's reactions, the floor carrying the
   weight at rest, no growth of the overlaps of a resting pile, the same final state for nscd's
   natural, reverse and shuffled orders (exactly for a determinate stack, statistically for a
   pile), the gap law leaving no overlap, and the gate of the column collapse. */
#include "config.h"
#include "testlib.h"

#include <math.h>

#define G 9.81

/* A deposit of n grains in a box 10 lattice cells wide (0.132 m), as cases/disk-pile, nscd with
   Jean's quad criterion at tol (a pile has steps where Gauss-Seidel stalls before the criterion:
   they are counted, failed_solves, and the run goes on, as LMGC90 users run piles). */
static void pile_text(char *buf, size_t len, int n, double end, double tol, const char *extra)
{
  snprintf(buf, len,
           "title = \"small pile\";\n"
           "bodies = (\n"
           "  { name = \"floor\"; type = \"plane\"; point = [0.0, 0.0]; normal = [0.0, 1.0]; },\n"
           "  { name = \"left\"; type = \"plane\"; point = [0.0, 0.0]; normal = [1.0, 0.0]; },\n"
           "  { name = \"right\"; type = \"plane\"; point = [0.132, 0.0]; normal = [-1.0, 0.0]; },\n"
           "  { name = \"grains\"; type = \"disk\"; density = 2600.0; body_force = [0.0, -9.81];\n"
           "    pack = { count = %d; radius = 0.005; dispersion = 0.2; box = [0.0, 0.132, 0.0, 2.0]; seed = 3; }; }\n"
           ");\n"
           "time = { scheme = \"theta\"; theta = 0.5; dt = 1.0e-3; end = %g; };\n"
           "contact = {\n"
           "  solver = \"nscd\";\n"
           "  on_failure = \"continue\";\n"
           "  nscd = { tol = %g; stop = \"quad\"; max_sweeps = 5000; %s };\n"
           "  pairs = ( { name = \"grains\"; master = \"grains\"; slave = \"grains\"; mu = 0.5; },\n"
           "            { name = \"floor\"; master = \"floor\"; slave = \"grains\"; mu = 0.5; },\n"
           "            { name = \"left\"; master = \"left\"; slave = \"grains\"; mu = 0.5; },\n"
           "            { name = \"right\"; master = \"right\"; slave = \"grains\"; mu = 0.5; } );\n"
           "};\n"
           "output = { every = 1; };\n",
           n, end, tol, extra ? extra : "");
}

/* Sum over the rows of history columns, times h. */
static double col_sum(const tl_table *T, const char *name, double h)
{
  int i, c = tl_col(T, name);
  double s = 0;
  if (c < 0) return NAN;
  for (i = 0; i < T->nrow; i++) s += tl_num(T, i, c);
  return s * h;
}

/* The final momentum and total mass of the grains, from bodies.csv. */
static int grains_momentum(const char *out, double *M, double *P)
{
  char path[4300];
  tl_table B;
  int i, cm, cvx, cvy;
  snprintf(path, sizeof path, "%s/bodies.csv", out);
  if (tl_table_read(path, &B)) return -1;
  cm = tl_col(&B, "mass");
  cvx = tl_col(&B, "vx");
  cvy = tl_col(&B, "vy");
  *M = P[0] = P[1] = 0;
  for (i = 0; i < B.nrow; i++) {
    double m = tl_num(&B, i, cm);
    *M += m;
    P[0] += m * tl_num(&B, i, cvx);
    P[1] += m * tl_num(&B, i, cvy);
  }
  tl_table_free(&B);
  return 0;
}

/* The deepest overlap of the last step's candidates (contact.csv), >= 0. */
static double deepest_overlap(const char *out)
{
  char path[4300];
  tl_table T;
  int i, cg;
  double o = 0;
  snprintf(path, sizeof path, "%s/contact.csv", out);
  if (tl_table_read(path, &T)) return NAN;
  cg = tl_col(&T, "gap");
  for (i = 0; i < T.nrow; i++) o = fmax(o, -tl_num(&T, i, cg));
  tl_table_free(&T);
  return o;
}

/* The highest grain top and the mean centre height, from bodies.csv. */
static int pile_shape(const char *out, double *top, double *ymean)
{
  char path[4300];
  tl_table B;
  int i, cy, cr;
  snprintf(path, sizeof path, "%s/bodies.csv", out);
  if (tl_table_read(path, &B)) return -1;
  cy = tl_col(&B, "y");
  cr = tl_col(&B, "radius");
  *top = -HUGE_VAL;
  *ymean = 0;
  for (i = 0; i < B.nrow; i++) {
    *top = fmax(*top, tl_num(&B, i, cy) + tl_num(&B, i, cr));
    *ymean += tl_num(&B, i, cy) / B.nrow;
  }
  tl_table_free(&B);
  return 0;
}

/* --- detection against brute force ---------------------------------------------------------- */

static unsigned long long lcg(unsigned long long *s)
{
  *s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
  return *s >> 11;
}
static double urand(unsigned long long *s) { return (double)lcg(s) * (1.0 / 9007199254740992.0); }

/* A dense pack of 400 disks moved at random, by small steps (the Verlet list kept) and a few large
   ones (rebuilt): after each move, the grain-grain candidates are exactly the pairs a brute-force
   search finds closer than the alert distance. */
static void detection_vs_brute(const char *verlet)
{
  char text[1024];
  static const char fmt[] =
      "bodies = (\n"
      "  { name = \"floor\"; type = \"plane\"; point = [0.0, 0.0]; normal = [0.0, 1.0]; },\n"
      "  { name = \"grains\"; type = \"disk\"; density = 2600.0;\n"
      "    pack = { count = 400; radius = 0.005; dispersion = 0.3; spacing = 0.0131; box = [0.0, 0.262, 0.0, 0.4]; jitter = 1.0; seed = 7; }; }\n"
      ");\n"
      "time = { dt = 1.0e-3; end = 1.0e-3; };\n"
      "contact = { verlet = \"%s\";\n"
      "            pairs = ( { name = \"gg\"; master = \"grains\"; slave = \"grains\"; mu = 0.5; },\n"
      "                      { name = \"floor\"; master = \"floor\"; slave = \"grains\"; mu = 0.5; } ); };\n";
  mo_ctx ctx;
  mo_case *cs = NULL;
  mo_scene *sc = NULL;
  mo_contact *C = NULL;
  mo_state s;
  unsigned long long seed = 12345;
  int st, move, bad = 0, nmove = 60, worst_missing = 0, worst_extra = 0;
  long checked = 0;
  double alert;
  snprintf(text, sizeof text, fmt, verlet);
  mo_ctx_init(&ctx);
  ctx.verbosity = 0;
  memset(&s, 0, sizeof s);
  st = tl_scene(text, "detect.cfg", &cs, &sc, &ctx);
  if (!st) st = mo_contact_build(sc, &C, &ctx);
  if (!st) st = mo_state_alloc(sc, &s, &ctx);
  if (st) {
    ok(0, "detection: the scene builds (%s)", ctx.errmsg);
    goto done;
  }
  alert = mo_contact_alert(C);
  for (move = 0; move < nmove && !bad; move++) {
    /* 1 move in 10 is large (a third of a radius per grain: the list is rebuilt), the others a
       fiftieth of the alert distance (the list is kept) */
    double amp = move % 10 == 9 ? 0.0017 : alert / 50;
    int k, i, j, nb = 0, nd = 0, a;
    for (k = 0; k < sc->nrigid; k++) {
      const mo_body *B = &sc->body[sc->rigid[k]];
      if (B->kind != MO_BODY_DISK) continue;
      for (i = 0; i < 2; i++) s.u[B->dof0 + i] += amp * (2 * urand(&seed) - 1);
    }
    if ((st = mo_contact_geometry(C, &s, 0, 0, &ctx))) break;
    for (a = mo_contact_nstatic(C); a < mo_contact_ncandidates(C); a++) nd += mo_contact_key(C, a)[0] == 0;
    for (i = 0; i < sc->nrigid; i++)
      for (j = i + 1; j < sc->nrigid; j++) {
        const mo_body *A = &sc->body[sc->rigid[i]], *B = &sc->body[sc->rigid[j]];
        double ca[3], cb[3];
        mo_rigid_center(sc, A, &s, ca);
        mo_rigid_center(sc, B, &s, cb);
        nb += hypot(ca[0] - cb[0], ca[1] - cb[1]) - A->radius - B->radius <= alert;
      }
    checked += nb;
    if (nd != nb) {
      bad = 1;
      if (nd < nb) worst_missing = nb - nd;
      else worst_extra = nd - nb;
      diag("move %d: %d candidates detected, %d pairs within the alert distance by brute force", move, nd, nb);
    }
  }
  ok(!st && !bad && checked > 1000,
     "detection (list %s): after %d random moves of 400 disks the candidates are the %ld pairs brute force finds (%d "
     "missing, %d extra)", verlet, move, checked, worst_missing, worst_extra);
done:
  mo_state_release(&s);
  mo_contact_free(C);
  mo_scene_free(sc);
  mo_case_free(cs);
}

/* --- a deposit ------------------------------------------------------------------------------- */

static void deposit(void)
{
  static char text[4096];
  const char *out = "tests/out/granular/pile";
  tl_table T;
  double M, P[2], Ix, Iy, Tend, fy = 0, floor_share = 0, wall = 0;
  int i, n = 0, cfy, clx, crx;
  pile_text(text, sizeof text, 200, 1.5, 1e-4, NULL);
  if (tl_run_text(text, out, "pile", NULL) || grains_momentum(out, &M, P)) {
    ok(0, "a pile of 200 grains runs");
    return;
  }
  {
    char hist[4300];
    snprintf(hist, sizeof hist, "%s/history.csv", out);
    if (tl_table_read(hist, &T)) {
      ok(0, "the pile's history reads");
      return;
    }
  }
  Tend = tl_num(&T, T.nrow - 1, tl_col(&T, "t"));
  /* the grain-grain pair's forces are internal: the grains' momentum changes by the weight and
     the forces of the box alone */
  Ix = col_sum(&T, "floor.fx", 1e-3) + col_sum(&T, "left.fx", 1e-3) + col_sum(&T, "right.fx", 1e-3);
  Iy = col_sum(&T, "floor.fy", 1e-3) + col_sum(&T, "left.fy", 1e-3) + col_sum(&T, "right.fy", 1e-3);
  ok(fabs(P[0] - Ix) < 1e-10 * M * G * Tend && fabs(P[1] - (Iy - M * G * Tend)) < 1e-10 * M * G * Tend,
     "pile: momentum balance with the box's reactions: |P_x - I_x| = %.1e, |P_y - (I_y - M g T)| = %.1e N s (M g T = %.3g)",
     fabs(P[0] - Ix), fabs(P[1] - (Iy - M * G * Tend)), M * G * Tend);
  /* at rest over the last 0.1 s: the floor and the walls' friction carry the weight (the walls
     take a few per cent: Janssen), the walls' pushes balance */
  cfy = tl_col(&T, "floor.fy");
  clx = tl_col(&T, "left.fx");
  crx = tl_col(&T, "right.fx");
  for (i = 0; i < T.nrow; i++)
    if (tl_num(&T, i, 0) > Tend - 0.1 + 1e-9) {
      fy += tl_num(&T, i, cfy) + tl_num(&T, i, tl_col(&T, "left.fy")) + tl_num(&T, i, tl_col(&T, "right.fy"));
      floor_share += tl_num(&T, i, cfy);
      wall += tl_num(&T, i, clx) + tl_num(&T, i, crx);
      n++;
    }
  fy /= n;
  floor_share /= n * M * G;
  wall /= n;
  /* the tolerance: a solve to Jean's quad 1e-4 leaves the pile creeping at 1e-5 m/s */
  ok(fabs(fy - M * G) < 1e-3 * M * G && fabs(wall) < 1e-3 * M * G && floor_share > 0.8 && floor_share < 1,
     "pile at rest: the box carries %.6g N of the weight %.6g N (%.1e; the floor %.1f %%, the walls' friction the rest), "
     "the walls' pushes balance to %.1e N", fy, M * G, fabs(fy / (M * G) - 1), 100 * floor_share, fabs(wall));
  tl_table_free(&T);
  /* the overlaps of a resting pile do not grow: the deepest one at 1.5 s against 1.0 s (the same
     run, stopped earlier; at rest from about 1 s) */
  {
    const char *out1 = "tests/out/granular/pile10";
    double o15 = deepest_overlap(out), o10;
    pile_text(text, sizeof text, 200, 1.0, 1e-4, NULL);
    o10 = tl_run_text(text, out1, "pile to 1 s", NULL) ? NAN : deepest_overlap(out1);
    ok(o15 <= o10 + 1e-8, "pile at rest: no overlap grows (deepest %.4f mm at 1 s, %.4f mm at 1.5 s)", 1e3 * o10,
       1e3 * o15);
    tl_remove_dir(out1);
  }
  {
    /* the list kept by blocks in their own frames (contact.verlet, doc/theory.md §12.26): the list
       is another superset of the candidates, the candidates and so the run the same to the bit */
    const char *outb = "tests/out/granular/pileb", *files[] = {"bodies.csv", "history.csv", "contact.csv"};
    const char ins[] = "  verlet = \"blocks\";\n";
    char *at;
    int f, same = 1;
    pile_text(text, sizeof text, 200, 1.5, 1e-4, NULL);
    at = strstr(text, "  solver = ");
    memmove(at + strlen(ins), at, strlen(at) + 1);
    memcpy(at, ins, strlen(ins));
    if (tl_run_text(text, outb, "pile, list by blocks", NULL)) same = 0;
    for (f = 0; f < 3 && same; f++) {
      char pa[512], pb[512];
      FILE *fa, *fb;
      int ca, cb;
      snprintf(pa, sizeof pa, "%s/%s", out, files[f]);
      snprintf(pb, sizeof pb, "%s/%s", outb, files[f]);
      fa = fopen(pa, "rb");
      fb = fopen(pb, "rb");
      if (!fa || !fb) same = 0;
      while (same && ((ca = getc(fa)) != EOF) | ((cb = getc(fb)) != EOF) && (same = ca == cb)) {}
      if (fa) fclose(fa);
      if (fb) fclose(fb);
      if (!same) diag("%s differs", files[f]);
    }
    ok(same, "pile: the list kept by blocks gives the run of the global list to the bit (bodies, history, contacts)");
    tl_remove_dir(outb);
  }
  tl_remove_dir(out);
}

/* The orders of the sweep on a pile: its final state depends on its history (the grains' paths
   diverge at the first difference between two runs), its statistics do not, once the solves are
   tight. Stated tolerance: at Jean's quad 1e-6, the mean height of the grains within 1.5 % and
   the top within a grain diameter of the natural order's (measured: 0.8 % and 3 mm; at 1e-4 the
   reverse order packs 2.8 % looser). */
static void pile_orders(void)
{
  static const char *orders[] = {"natural", "reverse", "shuffled"};
  static char text[4096];
  double top[3], ymean[3];
  int k;
  for (k = 0; k < 3; k++) {
    char extra[64], o[200];
    snprintf(extra, sizeof extra, "order = \"%s\";", orders[k]);
    snprintf(o, sizeof o, "tests/out/granular/pile-%s", orders[k]);
    pile_text(text, sizeof text, 200, 1.5, 1e-6, extra);
    if (tl_run_text(text, o, orders[k], NULL) || pile_shape(o, &top[k], &ymean[k])) {
      ok(0, "pile with the %s order runs", orders[k]);
      return;
    }
    tl_remove_dir(o);
  }
  for (k = 1; k < 3; k++)
    ok(fabs(ymean[k] / ymean[0] - 1) < 0.015 && fabs(top[k] - top[0]) < 0.01,
       "pile at rest, %s order against natural (quad 1e-6): mean height %.5f / %.5f m (%.1f %%), top %.4f / %.4f m",
       orders[k], ymean[k], ymean[0], 100 * fabs(ymean[k] / ymean[0] - 1), top[k], top[0]);
}

/* A determinate stack: 8 disks in a well one grain wide fall and come to rest on each other; the
   solution is unique, so every order of the sweep gives the same final state. */
static void stack_orders(void)
{
  static const char *orders[] = {"natural", "reverse", "shuffled"};
  double y[3][8];
  int k, i, okall = 1;
  double worst = 0;
  for (k = 0; k < 3; k++) {
    char text[4096], out[200], path[4300];
    tl_table B;
    snprintf(text, sizeof text,
             "bodies = (\n"
             "  { name = \"floor\"; type = \"plane\"; point = [0.0, 0.0]; normal = [0.0, 1.0]; },\n"
             "  { name = \"left\"; type = \"plane\"; point = [0.0, 0.0]; normal = [1.0, 0.0]; },\n"
             "  { name = \"right\"; type = \"plane\"; point = [0.0101, 0.0]; normal = [-1.0, 0.0]; },\n"
             "  { name = \"g\"; type = \"disk\"; density = 2600.0; body_force = [0.0, -9.81];\n"
             "    pack = { count = 8; radius = 0.005; spacing = 0.0101; box = [0.0, 0.0101, 0.002, 0.2]; jitter = 0.0; }; }\n"
             ");\n"
             "time = { dt = 1.0e-3; end = 0.5; };\n"
             "contact = { nscd = { tol = 1.0e-12; max_sweeps = 100000; order = \"%s\"; };\n"
             "  pairs = ( { name = \"gg\"; master = \"g\"; slave = \"g\"; mu = 0.5; },\n"
             "            { name = \"floor\"; master = \"floor\"; slave = \"g\"; mu = 0.5; },\n"
             "            { name = \"left\"; master = \"left\"; slave = \"g\"; mu = 0.5; },\n"
             "            { name = \"right\"; master = \"right\"; slave = \"g\"; mu = 0.5; } ); };\n",
             orders[k]);
    snprintf(out, sizeof out, "tests/out/granular/stack-%s", orders[k]);
    snprintf(path, sizeof path, "%s/bodies.csv", out);
    if (tl_run_text(text, out, orders[k], NULL) || tl_table_read(path, &B) || B.nrow != 8) {
      ok(0, "stack with the %s order runs", orders[k]);
      return;
    }
    for (i = 0; i < 8; i++) y[k][i] = tl_num(&B, i, tl_col(&B, "y"));
    tl_table_free(&B);
    tl_remove_dir(out);
  }
  for (k = 1; k < 3; k++)
    for (i = 0; i < 8; i++) worst = fmax(worst, fabs(y[k][i] - y[0][i]));
  /* at rest, each disk on the one below: centres 2R apart up to the overlaps of the landings */
  for (i = 1; i < 8; i++) okall &= fabs(y[0][i] - y[0][i - 1] - 0.01) < 1e-3;
  ok(worst < 1e-9 && okall, "stack of 8 disks: the natural, reverse and shuffled orders end %.1e m apart; the disks rest "
     "on each other", worst);
}

/* The gap law (T78): a deposit leaves no overlap deeper than the solver's tolerance lets. */
static void gap_law(void)
{
  char text[4096];
  const char *out = "tests/out/granular/gap";
  double o;
  {
    snprintf(text, sizeof text,
             "bodies = (\n"
             "  { name = \"floor\"; type = \"plane\"; point = [0.0, 0.0]; normal = [0.0, 1.0]; },\n"
             "  { name = \"left\"; type = \"plane\"; point = [0.0, 0.0]; normal = [1.0, 0.0]; },\n"
             "  { name = \"right\"; type = \"plane\"; point = [0.132, 0.0]; normal = [-1.0, 0.0]; },\n"
             "  { name = \"grains\"; type = \"disk\"; density = 2600.0; body_force = [0.0, -9.81];\n"
             "    pack = { count = 100; radius = 0.005; dispersion = 0.2; box = [0.0, 0.132, 0.0, 2.0]; seed = 3; }; }\n"
             ");\n"
             "time = { dt = 1.0e-3; end = 0.4; };\n"
             "contact = { on_failure = \"continue\"; nscd = { tol = 1.0e-6; max_sweeps = 20000; };\n"
             "  pairs = ( { name = \"gg\"; master = \"grains\"; slave = \"grains\"; mu = 0.5; law = \"gap\"; },\n"
             "            { name = \"floor\"; master = \"floor\"; slave = \"grains\"; mu = 0.5; law = \"gap\"; },\n"
             "            { name = \"left\"; master = \"left\"; slave = \"grains\"; mu = 0.5; law = \"gap\"; },\n"
             "            { name = \"right\"; master = \"right\"; slave = \"grains\"; mu = 0.5; law = \"gap\"; } ); };\n");
  }
  if (tl_run_text(text, out, "gap law", NULL)) {
    ok(0, "a deposit under the gap law runs");
    return;
  }
  o = deepest_overlap(out);
  ok(o < 1e-7, "gap law: the deposit's deepest overlap is %.2e m (grains of 5 mm falling at up to 3 m/s)", o);
  tl_remove_dir(out);
}

/* A gate (a plane with `until`): it holds a column of grains, then is gone. */
static void gate(void)
{
  static const char text[] =
      "bodies = (\n"
      "  { name = \"floor\"; type = \"plane\"; point = [0.0, 0.0]; normal = [0.0, 1.0]; },\n"
      "  { name = \"left\"; type = \"plane\"; point = [0.0, 0.0]; normal = [1.0, 0.0]; },\n"
      "  { name = \"gate\"; type = \"plane\"; point = [0.0396, 0.0]; normal = [-1.0, 0.0]; until = 0.3; },\n"
      "  { name = \"grains\"; type = \"disk\"; density = 2600.0; body_force = [0.0, -9.81];\n"
      "    pack = { count = 60; radius = 0.005; dispersion = 0.2; box = [0.0, 0.0396, 0.0, 2.0]; seed = 5; }; }\n"
      ");\n"
      "time = { dt = 1.0e-3; end = 0.6; };\n"
      "contact = { on_failure = \"continue\"; nscd = { tol = 1.0e-4; stop = \"quad\"; max_sweeps = 1000; };\n"
      "  pairs = ( { name = \"gg\"; master = \"grains\"; slave = \"grains\"; mu = 0.3; },\n"
      "            { name = \"floor\"; master = \"floor\"; slave = \"grains\"; mu = 0.3; },\n"
      "            { name = \"left\"; master = \"left\"; slave = \"grains\"; mu = 0.3; },\n"
      "            { name = \"gate\"; master = \"gate\"; slave = \"grains\"; mu = 0.3; } ); };\n"
      "output = { every = 1; };\n";
  const char *out = "tests/out/granular/gate";
  char hist[4300];
  tl_table T;
  double fx_before = 0, fx_after = 0, x_before = 0, x_end;
  int i, cf, cx;
  snprintf(hist, sizeof hist, "%s/history.csv", out);
  if (tl_run_text(text, out, "gate", NULL) || tl_table_read(hist, &T)) {
    ok(0, "a column behind a gate runs");
    return;
  }
  cf = tl_col(&T, "gate.fx");
  cx = tl_col(&T, "rigid.xmax");
  for (i = 0; i < T.nrow; i++) {
    double t = tl_num(&T, i, 0);
    if (t > 0.2 && t <= 0.3 + 1e-9) {
      fx_before = fmin(fx_before, tl_num(&T, i, cf));
      x_before = fmax(x_before, tl_num(&T, i, cx));
    }
    if (t > 0.3 + 1e-9) fx_after = fmax(fx_after, fabs(tl_num(&T, i, cf)));
  }
  x_end = tl_num(&T, T.nrow - 1, cx);
  ok(fx_before < 0 && fx_after == 0 && x_before <= 0.0396 + 1e-3 && x_end > 0.0396 + 0.02,
     "gate: it pushes the column back (%.3g N) until t = 0.3 s, then holds nothing; the front goes from %.4f m to %.4f m",
     fx_before, x_before, x_end);
  tl_table_free(&T);
  tl_remove_dir(out);
}

int main(void)
{
  detection_vs_brute("global");
  detection_vs_brute("blocks");
  deposit();
  pile_orders();
  stack_orders();
  gap_law();
  gate();
  return done_testing();
}
