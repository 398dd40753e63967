/* test_compact.c: the granular path (doc/theory.md §12.9) against the general one. A deposit of
   disks, one of spheres and one of polygons with disks, each run with the compact contact records
   (contact.compact = true, the default) and with points, candidates and H at every step
   (contact.compact = false): the final states, the histories and contact.csv agree to the bit
   (the records' sweep does the arithmetic of the sweep on H; under Jean's Quad rule too, whose
   parts it sums as it sweeps), and so do the gap law and a run that
   dumps FCLIB problems (W built from H on demand) against contact.delassus = "always"; a
   coefficient of friction per pair (T189) as well. The memory
   of the contact set: the records hold a bounded number of bytes per candidate, a fraction of the
   points, candidates and columns of H. levelset, which reads candidates and H, runs the same
   scene on the general path. Jean's norms in nscd's report under the residual rules: the sweep on
   H computes them, the records' sweep reports them as not measured (-1), not NaN. The remap the
   detection writes as it overwrites the keys (T220-T222) against the key map's over every set of
   two deposits, and against brute force on random sets in the detection's order; the same sets
   dealt to several ranks, each rank's part mapped over its copy of the old set and the parts'
   maps merged with the set (T270-T271). */
#include "config.h"
#include "testlib.h"
#include "metrics.h"
#include "contact_internal.h" /* the detection's remap (mo_setmap, T220-T222) */

#include <jansson.h>
#include <math.h>

static const char *const pairs2 =
    "  pairs = ( { name = \"grains\"; master = \"grains\"; slave = \"grains\"; mu = 0.5; %s },\n"
    "            { name = \"floor\"; master = \"floor\"; slave = \"grains\"; mu = 0.5; %s },\n"
    "            { name = \"left\"; master = \"left\"; slave = \"grains\"; mu = 0.5; %s },\n"
    "            { name = \"right\"; master = \"right\"; slave = \"grains\"; mu = 0.5; %s } );\n";

/* The same pairs with a coefficient of their own: the floor's and the walls' differ from the
   grains' (T189: a candidate's is its pair's, read through its key on the granular path). */
static const char *const pairs_mu =
    "  pairs = ( { name = \"grains\"; master = \"grains\"; slave = \"grains\"; mu = 0.5; %s },\n"
    "            { name = \"floor\"; master = \"floor\"; slave = \"grains\"; mu = 0.05; %s },\n"
    "            { name = \"left\"; master = \"left\"; slave = \"grains\"; mu = 1.0; %s },\n"
    "            { name = \"right\"; master = \"right\"; slave = \"grains\"; mu = 0.8; %s } );\n";
static const char *pairs_fmt = NULL; /* pairs2 unless set */

/* A deposit of n disks in a box 10 lattice cells wide (as cases/disk-pile), to end, nscd held to
   12 sweeps a step (the stop rule does not change the comparison; a fixed count keeps it short);
   law: extra keys of every pair ("" for Moreau's impact law). */
static const char *nscd_opts = "stop = \"sweeps\"; max_sweeps = 12;";
static void disks_text(char *buf, size_t len, int n, double end, const char *law, const char *contact_extra)
{
  char pairs[2048];
  snprintf(pairs, sizeof pairs, pairs_fmt ? pairs_fmt : pairs2, law, law, law, law);
  snprintf(buf, len,
           "title = \"disk deposit\";\n"
           "bodies = (\n"
           "  { name = \"floor\"; type = \"plane\"; point = [0.0, 0.0]; normal = [0.0, 1.0]; },\n"
           "  { name = \"left\"; type = \"plane\"; point = [0.0, 0.0]; normal = [1.0, 0.0]; },\n"
           "  { name = \"right\"; type = \"plane\"; point = [0.132, 0.0]; normal = [-1.0, 0.0]; },\n"
           "  { name = \"grains\"; type = \"disk\"; density = 2600.0; body_force = [0.0, -9.81];\n"
           "    pack = { count = %d; radius = 0.005; dispersion = 0.2; box = [0.0, 0.132, 0.0, 2.0]; jitter = 0.5; seed = 5; }; }\n"
           ");\n"
           "time = { scheme = \"theta\"; theta = 0.5; dt = 1.0e-3; end = %g; };\n"
           "contact = {\n"
           "  solver = \"nscd\"; on_failure = \"continue\"; %s\n"
           "  nscd = { %s };\n"
           "%s"
           "};\n"
           "output = { every = 1; vtk = { every = 50; }; };\n",
           n, end, contact_extra, nscd_opts, pairs);
}

/* A deposit of n spheres in a square box of side 0.0792 m (6 x 6 lattice), as cases/sphere-deposit. */
static void spheres_text(char *buf, size_t len, int n, double end)
{
  snprintf(buf, len,
           "title = \"sphere deposit\";\n"
           "bodies = (\n"
           "  { name = \"floor\"; type = \"plane\"; point = [0.0, 0.0, 0.0]; normal = [0.0, 1.0, 0.0]; },\n"
           "  { name = \"x0\"; type = \"plane\"; point = [0.0, 0.0, 0.0]; normal = [1.0, 0.0, 0.0]; },\n"
           "  { name = \"x1\"; type = \"plane\"; point = [0.0792, 0.0, 0.0]; normal = [-1.0, 0.0, 0.0]; },\n"
           "  { name = \"z0\"; type = \"plane\"; point = [0.0, 0.0, 0.0]; normal = [0.0, 0.0, 1.0]; },\n"
           "  { name = \"z1\"; type = \"plane\"; point = [0.0, 0.0, 0.0792]; normal = [0.0, 0.0, -1.0]; },\n"
           "  { name = \"grains\"; type = \"sphere\"; density = 2600.0; body_force = [0.0, -9.81, 0.0];\n"
           "    pack = { count = %d; radius = 0.005; dispersion = 0.2; box = [0.0, 0.0792, 0.0, 2.0, 0.0, 0.0792]; jitter = 0.5; seed = 2; }; }\n"
           ");\n"
           "time = { scheme = \"theta\"; theta = 0.5; dt = 1.0e-3; end = %g; };\n"
           "contact = {\n"
           "  solver = \"nscd\"; on_failure = \"continue\";\n"
           "  nscd = { stop = \"sweeps\"; max_sweeps = 12; };\n"
           "  pairs = ( { name = \"grains\"; master = \"grains\"; slave = \"grains\"; mu = 0.5; },\n"
           "            { name = \"floor\"; master = \"floor\"; slave = \"grains\"; mu = 0.5; },\n"
           "            { name = \"x0\"; master = \"x0\"; slave = \"grains\"; mu = 0.5; },\n"
           "            { name = \"x1\"; master = \"x1\"; slave = \"grains\"; mu = 0.5; },\n"
           "            { name = \"z0\"; master = \"z0\"; slave = \"grains\"; mu = 0.5; },\n"
           "            { name = \"z1\"; master = \"z1\"; slave = \"grains\"; mu = 0.5; } );\n"
           "};\n"
           "output = { every = 1; };\n",
           n, end);
}

/* Polygons (a triangle, a square, a pentagon, a hexagon, a rectangle) and two disks dropped in a
   box 0.12 m wide: polygon-polygon (two points on an edge against an edge), polygon-disk,
   polygon-plane and disk-plane contacts, every pair of bodies named (no groups). */
static void polygons_text(char *buf, size_t len, double end)
{
  static const char *const name[7] = {"tri", "sq", "pent", "hex", "rect", "d1", "d2"};
  char bodies[3000], pairs[12000];
  int i, j, nb = 0, np = 0;
  nb += snprintf(bodies + nb, sizeof bodies - (size_t)nb,
                 "  { name = \"floor\"; type = \"plane\"; point = [0.0, 0.0]; normal = [0.0, 1.0]; },\n"
                 "  { name = \"left\"; type = \"plane\"; point = [0.0, 0.0]; normal = [1.0, 0.0]; },\n"
                 "  { name = \"right\"; type = \"plane\"; point = [0.12, 0.0]; normal = [-1.0, 0.0]; },\n"
                 "  { name = \"tri\"; type = \"polygon\"; sides = 3; radius = 0.012; center = [0.030, 0.020]; angle = 0.3; density = 2600.0; body_force = [0.0, -9.81]; },\n"
                 "  { name = \"sq\"; type = \"polygon\"; sides = 4; radius = 0.011; center = [0.062, 0.016]; angle = 0.1; density = 2600.0; body_force = [0.0, -9.81]; },\n"
                 "  { name = \"pent\"; type = \"polygon\"; sides = 5; radius = 0.011; center = [0.094, 0.030]; angle = 0.2; density = 2600.0; body_force = [0.0, -9.81]; },\n"
                 "  { name = \"hex\"; type = \"polygon\"; sides = 6; radius = 0.011; center = [0.045, 0.052]; angle = 0.0; density = 2600.0; body_force = [0.0, -9.81]; },\n"
                 "  { name = \"rect\"; type = \"polygon\"; size = [0.03, 0.012]; center = [0.080, 0.068]; angle = -0.25; density = 2600.0; body_force = [0.0, -9.81]; },\n"
                 "  { name = \"d1\"; type = \"disk\"; radius = 0.008; center = [0.020, 0.080]; density = 2600.0; body_force = [0.0, -9.81]; },\n"
                 "  { name = \"d2\"; type = \"disk\"; radius = 0.007; center = [0.102, 0.095]; density = 2600.0; body_force = [0.0, -9.81]; }\n");
  for (i = 0; i < 7; i++) {
    for (j = i + 1; j < 7; j++)
      np += snprintf(pairs + np, sizeof pairs - (size_t)np, "%s{ name = \"%s-%s\"; master = \"%s\"; slave = \"%s\"; mu = 0.4; }",
                     np ? ",\n  " : "", name[i], name[j], name[i], name[j]);
    np += snprintf(pairs + np, sizeof pairs - (size_t)np,
                   ",\n  { name = \"floor-%s\"; master = \"floor\"; slave = \"%s\"; mu = 0.4; },\n"
                   "  { name = \"left-%s\"; master = \"left\"; slave = \"%s\"; mu = 0.4; },\n"
                   "  { name = \"right-%s\"; master = \"right\"; slave = \"%s\"; mu = 0.4; }",
                   name[i], name[i], name[i], name[i], name[i], name[i]);
  }
  snprintf(buf, len,
           "title = \"polygons and disks\";\n"
           "bodies = (\n%s);\n"
           "time = { scheme = \"theta\"; theta = 0.5; dt = 5.0e-4; end = %g; };\n"
           "contact = {\n"
           "  solver = \"nscd\"; on_failure = \"continue\";\n"
           "  nscd = { stop = \"sweeps\"; max_sweeps = 20; };\n"
           "  pairs = ( %s );\n"
           "};\n"
           "output = { every = 1; };\n",
           bodies, end, pairs);
}

/* The largest difference between the numeric cells of two CSV files of one layout, relative to
   the largest magnitude of their column (absolute when it is 0); -1 when they do not compare
   (missing, other rows or columns, a text cell that differs). */
static double csv_diff(const char *a, const char *b)
{
  tl_table A, B;
  double worst = 0;
  int i, j;
  if (tl_table_read(a, &A)) return -1;
  if (tl_table_read(b, &B)) {
    tl_table_free(&A);
    return -1;
  }
  if (A.nrow != B.nrow || A.ncol != B.ncol) worst = -1;
  for (j = 0; j < A.ncol && worst >= 0; j++) {
    double scale = 0;
    for (i = 0; i < A.nrow; i++) {
      char *e;
      double x = strtod(A.cell[i][j], &e);
      if (*e || e == A.cell[i][j]) continue;
      if (fabs(x) > scale) scale = fabs(x);
    }
    for (i = 0; i < A.nrow && worst >= 0; i++) {
      char *ea, *eb;
      double x = strtod(A.cell[i][j], &ea), y = strtod(B.cell[i][j], &eb);
      if (*ea || ea == A.cell[i][j] || *eb || eb == B.cell[i][j]) {
        if (strcmp(A.cell[i][j], B.cell[i][j])) worst = -1; /* text, or a number against text */
        continue;
      }
      if (fabs(x - y) / (scale > 0 ? scale : 1) > worst) worst = fabs(x - y) / (scale > 0 ? scale : 1);
    }
  }
  tl_table_free(&A);
  tl_table_free(&B);
  return worst;
}

/* summary.json's contact object of a run. */
static json_t *contact_summary(const char *out, json_t **root)
{
  char path[4300];
  snprintf(path, sizeof path, "%s/summary.json", out);
  *root = json_load_file(path, 0, NULL);
  return *root ? json_object_get(*root, "contact") : NULL;
}

/* Run text (a case with `%s` where the compact key goes) both ways and compare the outputs. */
static void compare(const char *what, const char *compact_text, const char *general_text, const char *dir, int vtk)
{
  char a[300], b[300], fa[400], fb[400];
  static const char *const files[] = {"bodies.csv", "history.csv", "contact.csv"};
  int k, ra, rb;
  snprintf(a, sizeof a, "tests/out/compact/%s-records", dir);
  snprintf(b, sizeof b, "tests/out/compact/%s-general", dir);
  ra = tl_run_text(compact_text, a, what, NULL);
  rb = tl_run_text(general_text, b, what, NULL);
  if (ra || rb) {
    ok(0, "%s: both runs complete", what);
    return;
  }
  {
    json_t *ja, *jb, *ca = contact_summary(a, &ja), *cb = contact_summary(b, &jb);
    json_t *ba = ca ? json_object_get(ca, "broad") : NULL, *bb = cb ? json_object_get(cb, "broad") : NULL;
    ok(ba && bb && json_is_true(json_object_get(ba, "compact")) && json_is_false(json_object_get(bb, "compact")),
       "%s: the first run on the compact records, the second on points, candidates and H (%d candidates at the end)",
       what, ca ? (int)json_integer_value(json_object_get(ca, "candidates")) : -1);
    json_decref(ja);
    json_decref(jb);
  }
  for (k = 0; k < 3; k++) {
    double d;
    snprintf(fa, sizeof fa, "%s/%s", a, files[k]);
    snprintf(fb, sizeof fb, "%s/%s", b, files[k]);
    d = csv_diff(fa, fb);
    ok(d >= 0 && d <= 1e-13, "%s: %s of the two runs agree (largest difference %.1e of its column's scale)", what,
       files[k], d);
  }
  if (vtk) {
    /* the contact network of the last VTK file: the same lines */
    FILE *f1, *f2;
    int same = 0;
    snprintf(fa, sizeof fa, "%s/contacts.pvd", a);
    if ((f1 = fopen(fa, "r"))) {
      char l1[512], l2[512], last[300] = "";
      while (fgets(l1, sizeof l1, f1)) {
        char *p = strstr(l1, "file=\"");
        if (p) sscanf(p + 6, "%299[^\"]", last);
      }
      fclose(f1);
      snprintf(fa, sizeof fa, "%s/%s", a, last);
      snprintf(fb, sizeof fb, "%s/%s", b, last);
      f1 = fopen(fa, "r");
      f2 = fopen(fb, "r");
      same = f1 && f2 && last[0];
      while (same) {
        char *x = fgets(l1, sizeof l1, f1), *y = fgets(l2, sizeof l2, f2);
        if (!x || !y) {
          same = !x && !y;
          break;
        }
        same = !strcmp(l1, l2);
      }
      if (f1) fclose(f1);
      if (f2) fclose(f2);
    }
    ok(same, "%s: the contact network of the last VTK file is the same", what);
  }
  tl_remove_dir(a);
  tl_remove_dir(b);
}

static void disks(void)
{
  static char t1[8192], t2[8192];
  disks_text(t1, sizeof t1, 80, 0.4, "", "");
  disks_text(t2, sizeof t2, 80, 0.4, "", "compact = false;");
  compare("80 disks, 0.4 s", t1, t2, "disks", 1);
  disks_text(t1, sizeof t1, 60, 0.3, "law = \"gap\";", "");
  disks_text(t2, sizeof t2, 60, 0.3, "law = \"gap\";", "compact = false;");
  compare("60 disks, gap law (T78), 0.3 s", t1, t2, "gap", 0);
  /* Jean's Quad rule (T11): the records' sweep sums its parts as it updates each contact, the
     sweep on H from the reactions kept before the sweep; the same sweeps end every step */
  nscd_opts = "stop = \"quad\"; tol = 1.0e-4; max_sweeps = 1000;";
  disks_text(t1, sizeof t1, 60, 0.3, "", "");
  disks_text(t2, sizeof t2, 60, 0.3, "", "compact = false;");
  compare("60 disks, stop = quad, 0.3 s", t1, t2, "quad", 0);
  nscd_opts = "stop = \"sweeps\"; max_sweeps = 12;";
}

/* A coefficient per pair (T189): the records' sweep reads a candidate's through its key, the
   general path from its candidate record; the two runs agree, and differ from the run whose pairs
   all have the grains' coefficient (the floor's and the walls' reach the solve). */
static void pair_friction(void)
{
  static char t1[8192], t2[8192];
  const char *a = "tests/out/compact/pairmu-uniform", *b = "tests/out/compact/pairmu-own";
  char fa[400], fb[400];
  double d = -1;
  pairs_fmt = pairs_mu;
  disks_text(t1, sizeof t1, 80, 0.4, "", "");
  disks_text(t2, sizeof t2, 80, 0.4, "", "compact = false;");
  compare("80 disks, the floor's friction 0.05 and the walls' 1.0 and 0.8 (T189), 0.4 s", t1, t2, "pairmu", 0);
  if (!tl_run_text(t1, b, "pair coefficients", NULL)) {
    pairs_fmt = NULL;
    disks_text(t2, sizeof t2, 80, 0.4, "", "");
    if (!tl_run_text(t2, a, "uniform coefficients", NULL)) {
      snprintf(fa, sizeof fa, "%s/bodies.csv", a);
      snprintf(fb, sizeof fb, "%s/bodies.csv", b);
      d = csv_diff(fa, fb);
    }
  }
  pairs_fmt = NULL;
  ok(d > 1e-6, "80 disks, 0.4 s: the pairs' own coefficients change the deposit (bodies.csv differs by %.1e of its "
     "column's scale from the run with 0.5 everywhere)", d);
  tl_remove_dir(a);
  tl_remove_dir(b);
}

/* Jean's norms in nscd's report under the residual rules (scaled, natural), whose stopping test
   reads none of them: the sweep on H computes them from the reactions kept before its last sweep;
   the granular sweep keeps no such copy and does not sum them (it would cost about 8 % of a solve's
   instructions), so that its report says "not measured" (-1, contact.h), never NaN. Stepped side
   by side, the two runs take the same sweeps. */
static void report_norms(const char *rule)
{
  static char t1[8192], t2[8192];
  char opts[128];
  tl_steps A, B;
  int steps = 0, withc = 0, unmeasured = 1, measured = 1, same = 1, st = 0;
  double qmax = 0;
  snprintf(opts, sizeof opts, "stop = \"%s\"; tol = 1.0e-6; max_sweeps = 200;", rule);
  nscd_opts = opts;
  disks_text(t1, sizeof t1, 60, 0.15, "", "");
  disks_text(t2, sizeof t2, 60, 0.15, "", "compact = false;");
  nscd_opts = "stop = \"sweeps\"; max_sweeps = 12;";
  if (tl_steps_open(&A, t1, "records.cfg", NULL, 0)) {
    ok(0, "stop = %s: the compact run opens (%s)", rule, A.ctx.errmsg);
    return;
  }
  if (tl_steps_open(&B, t2, "general.cfg", NULL, 0)) {
    ok(0, "stop = %s: the general run opens (%s)", rule, B.ctx.errmsg);
    tl_steps_free(&A);
    return;
  }
  ok(mo_contact_is_compact(A.C) && !mo_contact_is_compact(B.C), "stop = %s: one run on the records, one on H", rule);
  while (A.s.step < A.sc->time.steps && !st) {
    const mo_contact_report *ra, *rb;
    if ((st = mo_contact_step(A.D, &A.s, &A.ctx)) || (st = mo_contact_step(B.D, &B.s, &B.ctx))) break;
    steps++;
    ra = mo_contact_last_report(A.D);
    rb = mo_contact_last_report(B.D);
    same &= ra->iterations == rb->iterations;
    if (ra->iterations <= 0) continue;
    withc++;
    unmeasured &= ra->quad == -1 && ra->maxm == -1;
    measured &= isfinite(rb->quad) && isfinite(rb->maxm) && rb->quad >= 0 && rb->maxm >= 0;
    if (rb->quad > qmax) qmax = rb->quad;
  }
  ok(!st && steps == 150 && withc > 50 && same, "stop = %s: 150 steps side by side, %d with contact, the same sweeps %s",
     rule, withc, st ? A.ctx.errmsg : "");
  ok(unmeasured, "stop = %s: the records' report gives Quad and Maxm as not measured (-1) at every step with contact",
     rule);
  ok(measured && qmax > 0, "stop = %s: the sweep on H's report gives them, finite (largest Quad %.2e)", rule, qmax);
  tl_steps_free(&A);
  tl_steps_free(&B);
}

/* The same text with `compact = false;` after the back end's name. */
static void general_of(const char *text, char *out, size_t len)
{
  const char *k = "solver = \"nscd\";", *q = strstr(text, k);
  size_t at = (size_t)(q - text) + strlen(k);
  snprintf(out, len, "%.*s compact = false;%s", (int)at, text, text + at);
}

/* The granular path keeps each frame as its normal alone (doc/theory.md (T225)): stepped side by
   side with the general path, which stores the detection's whole frames, every candidate's frame
   formed from its normal (mo_contact_frame_of) is the stored one to the bit, an orthonormal frame
   whose first row is the normal kept. */
static void frames_of_normals(int dim)
{
  static char t1[8192], t2[8192];
  tl_steps A, B;
  int st = 0, steps = 0, cands = 0, same = 1, nulls = 1, ortho = 1, a, i, j, k;
  if (dim == 2) disks_text(t1, sizeof t1, 60, 0.1, "", "");
  else spheres_text(t1, sizeof t1, 40, 0.1);
  general_of(t1, t2, sizeof t2);
  if (tl_steps_open(&A, t1, "records.cfg", NULL, 0)) {
    ok(0, "%dD frames: the compact run opens (%s)", dim, A.ctx.errmsg);
    return;
  }
  if (tl_steps_open(&B, t2, "general.cfg", NULL, 0)) {
    ok(0, "%dD frames: the general run opens (%s)", dim, B.ctx.errmsg);
    tl_steps_free(&A);
    return;
  }
  while (A.s.step < A.sc->time.steps && !st) {
    const int n = mo_contact_ncandidates(A.C);
    const double *nr = mo_contact_normals(A.C), *FB = mo_contact_frames(B.C);
    nulls &= !mo_contact_frames(A.C) && nr && FB && !mo_contact_normals(B.C);
    if (n != mo_contact_ncandidates(B.C) || !nr || !FB) {
      same = 0;
      break;
    }
    for (a = 0; a < n; a++) {
      double buf[9];
      const double *F = mo_contact_frame_of(A.C, a, buf), *G = FB + (size_t)a * dim * dim;
      same &= F == buf && !memcmp(F, G, (size_t)(dim * dim) * sizeof *F) &&
              !memcmp(nr + (size_t)a * dim, F, (size_t)dim * sizeof *F) && mo_contact_frame_of(B.C, a, buf) == G;
      for (i = 0; i < dim; i++)
        for (j = 0; j < dim; j++) {
          double dot = 0;
          for (k = 0; k < dim; k++) dot += F[i * dim + k] * F[j * dim + k];
          ortho &= fabs(dot - (i == j)) < 1e-14;
        }
    }
    cands += n;
    if ((st = mo_contact_step(A.D, &A.s, &A.ctx)) || (st = mo_contact_step(B.D, &B.s, &B.ctx))) break;
    steps++;
  }
  ok(!st && steps == 100 && cands > 1000 && nulls, "%dD frames: 100 steps side by side, %d candidates; the records "
     "keep normals alone (no frames), the general path frames %s", dim, cands, st ? A.ctx.errmsg : "");
  ok(same, "%dD frames: every frame formed from its normal is the general path's stored frame to the bit", dim);
  ok(ortho, "%dD frames: orthonormal to 1e-14", dim);
  tl_steps_free(&A);
  tl_steps_free(&B);
}

static void spheres(void)
{
  static char t1[8192], t2[8192];
  spheres_text(t1, sizeof t1, 72, 0.3);
  general_of(t1, t2, sizeof t2);
  compare("72 spheres (3D), 0.3 s", t1, t2, "spheres", 0);
}

static void polygons(void)
{
  static char t1[24000], t2[24000];
  polygons_text(t1, sizeof t1, 0.25);
  general_of(t1, t2, sizeof t2);
  compare("5 polygons and 2 disks, 0.25 s", t1, t2, "polygons", 0);
}

/* FCLIB dumps need W: built from H, itself built from the records on demand. The same iterates
   as contact.delassus = "always" (which builds points, candidates and H at every step). */
static void fclib_dump(void)
{
  static char t1[8192], t2[8192];
  const char *a = "tests/out/compact/dump-records", *b = "tests/out/compact/dump-always";
  char cfg[400], dumpdir[400], fa[400], fb[400];
  mo_run_options o;
  char err[MO_ERRMSG_MAX];
  FILE *f;
  double d;
  int st;
  if (!mo_fclib_available()) {
    ok(1, "# SKIP this build does not write FCLIB files");
    return;
  }
  disks_text(t1, sizeof t1, 40, 0.15, "", "");
  disks_text(t2, sizeof t2, 40, 0.15, "", "delassus = \"always\";");
  snprintf(cfg, sizeof cfg, "%s.cfg", a);
  snprintf(dumpdir, sizeof dumpdir, "%s-fclib", a);
  {
    mo_ctx ctx;
    mo_ctx_init(&ctx);
    mo_mkdir_p("tests/out/compact", &ctx);
    mo_mkdir_p(dumpdir, &ctx);
  }
  f = fopen(cfg, "w");
  if (f) {
    fputs(t1, f);
    fclose(f);
  }
  memset(&o, 0, sizeof o);
  o.case_path = cfg;
  o.outdir = a;
  o.dump_fclib = dumpdir;
  st = tl_run_options(&o, NULL, err, sizeof err);
  unlink(cfg);
  if (st) diag("%s", err);
  if (st || tl_run_text(t2, b, "delassus always", NULL)) {
    ok(0, "a dump of FCLIB problems runs on the compact records");
    return;
  }
  snprintf(fa, sizeof fa, "%s/bodies.csv", a);
  snprintf(fb, sizeof fb, "%s/bodies.csv", b);
  d = csv_diff(fa, fb);
  ok(d >= 0 && d <= 1e-13, "a dump of FCLIB problems on the compact records (W from H built on demand) ends where "
     "contact.delassus = \"always\" does (largest difference %.1e)", d);
  tl_remove_dir(dumpdir);
  tl_remove_dir(a);
  tl_remove_dir(b);
}

/* The bytes the contact set holds for its candidates: the records (g, frame, U0, x, e, key, law,
   active: 102 bytes a candidate in 2D) at a capacity at most twice the count, against what the
   points, candidates and columns of H take besides them on the general path. levelset reads
   candidates and H: its run is on the general path. */
static void memory(void)
{
  static char t1[8192], t2[8192];
  const char *a = "tests/out/compact/mem-records", *b = "tests/out/compact/mem-general",
             *c = "tests/out/compact/mem-levelset";
  json_t *ja, *jb, *jc, *ca, *cb, *cc;
  double pa, pb;
  int n;
  disks_text(t1, sizeof t1, 80, 0.3, "", "");
  disks_text(t2, sizeof t2, 80, 0.3, "", "compact = false;");
  if (tl_run_text(t1, a, "records", NULL) || tl_run_text(t2, b, "general", NULL)) {
    ok(0, "the memory runs complete");
    return;
  }
  ca = contact_summary(a, &ja);
  cb = contact_summary(b, &jb);
  n = (int)json_integer_value(json_object_get(ca, "candidates"));
  pa = (double)json_integer_value(json_object_get(json_object_get(ca, "memory"), "set_candidates")) / n;
  pb = (double)json_integer_value(json_object_get(json_object_get(cb, "memory"), "set_candidates")) / n;
  /* gap 8, the frame's normal 16 (T225), point 16, key 20, active 1 (no obstacle moves: no U0;
     the law and restitution are the pair's) */
  ok(n > 50 && pa > 0 && pa <= 2 * 61 + 1e-9, "the compact records hold %.0f bytes a candidate (%d candidates; at most "
     "2 x 61 at their capacity)", pa, n);
  ok(pb >= 4 * pa, "points, candidates and H take %.0f bytes a candidate on the general path, %.1f times the records",
     pb, pb / pa);
  json_decref(ja);
  json_decref(jb);
  {
    /* levelset on a few disks of the same kind: the general path */
    static char t3[8192];
    char cfg[300];
    FILE *f;
    disks_text(t3, sizeof t3, 6, 0.05, "", "");
    snprintf(cfg, sizeof cfg, "%s.cfg", c);
    if ((f = fopen(cfg, "w"))) {
      fputs(t3, f);
      fclose(f);
    }
    if (tl_run(cfg, "levelset", NULL, 0, c, "levelset", NULL)) ok(0, "the levelset run completes");
    else {
      cc = contact_summary(c, &jc);
      ok(cc && !json_is_true(json_object_get(json_object_get(cc, "broad"), "compact")) &&
             !strcmp(json_string_value(json_object_get(cc, "solver")), "levelset"),
         "levelset (it reads candidates and H) runs a pile of disks on the general path");
      json_decref(jc);
    }
    unlink(cfg);
  }
  tl_remove_dir(a);
  tl_remove_dir(b);
  tl_remove_dir(c);
}

/* One step of h as mo_run takes it (run.c's advance): kept, taken, and on a failure taken again
   from the snapshot as two halves, down to two halvings; the metrics follow each step taken.
   Returns the status of the step (non-zero: failed at the last level). */
typedef struct {
  tl_steps R;
  mo_metrics *M[2];
  mo_state save[3];
  mo_contact_snapshot *X[3];
  int cuts, steps, changes, moved;
} follow_run;

static int follow_step(follow_run *F, double h, int level)
{
  tl_steps *R = &F->R;
  long v = mo_contact_set_version(R->C);
  int st, k;
  if ((st = mo_stepper_set_dt(R->S, h, &R->ctx))) return st;
  mo_state_copy(R->sc, &R->s, &F->save[level]);
  if ((st = mo_contact_snapshot_save(R->D, F->X[level], &R->ctx))) return st;
  /* a step that fails after a new candidate set (every other grain moved 6 mm sideways, a geometry, a
     NaN velocity for the attempt): the state is taken again from the copy above, the driver's
     arrays from the snapshot, and its remaps composed from the set of the last step taken */
  if (level == 0 && R->s.step % 13 == 5) {
    const mo_body *B = &R->sc->body[R->sc->nbody - 1];
    for (k = 3; k < R->sc->nbody; k += 2) R->s.u[R->sc->body[k].dof0] += 0.006;
    /* the new set and the driver's arrays fitted to it, as a step's end would leave them */
    if ((st = mo_contact_snapshot_restore(R->D, F->X[level], &R->s, &R->ctx))) return st;
    F->moved += mo_contact_set_version(R->C) != v;
    R->s.v[B->dof0] = NAN;
  }
  if (!(st = mo_contact_step(R->D, &R->s, &R->ctx))) {
    if (level > 0) R->s.step--; /* the substeps of a cut step keep its number */
    F->steps++;
    F->changes += mo_contact_set_version(R->C) != v;
    for (k = 0; k < 2; k++) mo_metrics_step(F->M[k], &R->s, R->D);
    return MO_OK;
  }
  if (level >= 2 || (st != MO_ENOCONV && st != MO_ENAN)) return st;
  mo_ctx_clear_error(&R->ctx);
  mo_state_copy(R->sc, &F->save[level], &R->s);
  if ((st = mo_stepper_restart(R->S, &R->s, &R->ctx)) ||
      (st = mo_contact_snapshot_restore(R->D, F->X[level], &R->s, &R->ctx)))
    return st;
  F->cuts++;
  for (k = 0; k < 2; k++)
    if ((st = follow_step(F, h / 2, level + 1))) return st;
  if (level == 0) R->s.step++;
  return MO_OK;
}

/* The metrics follow the candidate set through the driver's remaps (mo_contact_driver_remap,
   doc/theory.md (T185)) instead of keys, a key map and a map of their own: stepped side by side
   with metrics that keep their keys (created without the driver) on a deposit whose set changes
   at most steps, with steps that fail (a NaN velocity in the attempt) and are cut as mo_run cuts
   them (a restore, then the halves), the two give the same summary (oscillation index, flips,
   chatter, impacts) at every tenth step and at the end. */
static void metrics_follow(void)
{
  static char t[8192];
  follow_run F;
  const char *saved = nscd_opts;
  int st = 0, k, same = 1, checks = 0;
  char *ja = NULL, *jb = NULL;
  memset(&F, 0, sizeof F);
  nscd_opts = "stop = \"quad\"; tol = 1.0e-6; max_sweeps = 100;";
  disks_text(t, sizeof t, 80, 0.3, "", "");
  nscd_opts = saved;
  if (tl_steps_open(&F.R, t, "follow.cfg", NULL, 0)) {
    ok(0, "metrics through the driver's remaps: the deposit opens (%s)", F.R.ctx.errmsg);
    return;
  }
  st = mo_metrics_create(F.R.sc, F.R.C, F.R.D, NULL, &F.M[0], &F.R.ctx);
  if (!st) st = mo_metrics_create(F.R.sc, F.R.C, NULL, NULL, &F.M[1], &F.R.ctx);
  for (k = 0; k < 3 && !st; k++) {
    st = mo_state_alloc(F.R.sc, &F.save[k], &F.R.ctx);
    if (!st) st = mo_contact_snapshot_create(F.R.D, &F.X[k], &F.R.ctx);
  }
  for (k = 0; k < 2 && !st; k++) mo_metrics_step(F.M[k], &F.R.s, NULL);
  while (!st && F.R.s.step < F.R.sc->time.steps) {
    if ((st = follow_step(&F, F.R.sc->time.dt, 0))) break;
    if (F.R.s.step % 10 == 0 || F.R.s.step == F.R.sc->time.steps) {
      json_t *a = mo_metrics_json(F.M[0]), *b = mo_metrics_json(F.M[1]);
      free(ja);
      free(jb);
      ja = json_dumps(a, JSON_SORT_KEYS);
      jb = json_dumps(b, JSON_SORT_KEYS);
      json_decref(a);
      json_decref(b);
      checks++;
      if (!ja || !jb || strcmp(ja, jb)) {
        same = 0;
        break;
      }
    }
  }
  ok(!st && F.R.s.step == 300, "metrics through the driver's remaps: 300 steps of 80 disks (%d taken, %d cut) %s",
     F.steps, F.cuts, st ? F.R.ctx.errmsg : "");
  ok(F.changes > 150 && F.cuts >= 10 && F.moved >= 10, "the candidate set changed at %d steps taken; %d steps were cut, "
     "%d of them after a new set", F.changes, F.cuts, F.moved);
  ok(same && checks >= 30, "the metrics through the remaps and through their own keys agree at %d checks%s%s", checks,
     same ? "" : ": ", same ? "" : (ja ? ja : "(none)"));
  ok(ja && !strstr(ja, "history_restarts"), "no history restarted");
  ok(ja && !strstr(ja, "steps_not_measured"), "every candidate measured (the metrics' room, the contact set's "
     "capacity and one slot over it, holds every set)");
  free(ja);
  free(jb);
  for (k = 0; k < 3; k++) {
    mo_state_release(&F.save[k]);
    mo_contact_snapshot_free(F.X[k]);
  }
  mo_metrics_free(F.M[0]);
  mo_metrics_free(F.M[1]);
  tl_steps_free(&F.R);
}


/* The remap over p ranks (T270)-(T271), as the split detection writes it: the new set's nn keys
   (in the order of (T220)) dealt to p parts by the lower body of their group (a body pair, or a
   shape against a plane: every contact of a group in one part, as a slab owns a pair), each part
   written through mo_setmap_put over its own copy of the nold old keys (a rank's replicated set)
   from place 0 on, its map taken with its candidates to their places in the whole set. Returns
   the candidates whose map differs from want (or -1 on failure); *parts: the parts not empty. */
static int parts_map(const unsigned char *rr, const int *okey, int nold, const int *nkey, int nn, int p,
                     const int *want, int *parts)
{
  mo_setmap M;
  mo_ctx ctx;
  int *keys = malloc(((size_t)(nold > nn ? nold : nn) + 1) * MO_KEY * sizeof *keys), q, a, bad = 0, st = 0;
  memset(&M, 0, sizeof M);
  mo_ctx_init(&ctx);
  *parts = 0;
  for (q = 0; q < p && keys && !st; q++) {
    int n = 0;
    if (nold) memcpy(keys, okey, (size_t)nold * MO_KEY * sizeof *keys);
    if ((st = mo_setmap_begin(&M, rr, nold, 0, &ctx))) break;
    for (a = 0; a < nn && !st; a++) {
      const int *k = nkey + (size_t)a * MO_KEY;
      int lo = rr[k[0]] ? (k[1] < k[2] ? k[1] : k[2]) : k[1];
      if ((int)(((unsigned)lo * 2654435761u) >> 7) % p != q) continue;
      if ((st = mo_setmap_put(&M, keys, n, k, &ctx))) break;
      bad += M.map[n] != want[a];
      n++;
    }
    bad += M.bad;
    *parts += n > 0;
  }
  mo_setmap_free(&M);
  mo_ctx_release(&ctx);
  free(keys);
  return !keys || st ? -1 : bad;
}

/* The detection's remap (T222) against the key map's (the driver's way before it) and brute force
   over every set change of a deposit stepped by the driver: before each step the set's keys are
   copied, after it the detection's map from the old set to the new is checked candidate by
   candidate. Returns the sets compared; *bad counts the candidates mapped otherwise. */
static int remap_sets(const char *text, const char *name, int *bad, int *moved, int *pbad)
{
  tl_steps R;
  mo_keymap K;
  int *okey = NULL, ocap = 0, sets = 0, st = 0;
  memset(&K, 0, sizeof K);
  *bad = *moved = *pbad = 0;
  if (tl_steps_open(&R, text, name, NULL, 0)) {
    ok(0, "%s opens (%s)", name, R.ctx.errmsg);
    return 0;
  }
  if (!mo_contact_writes_map(R.C, &R.ctx)) {
    ok(0, "%s: the detection writes the remap", name);
    tl_steps_free(&R);
    return 0;
  }
  while (!st && R.s.step < R.sc->time.steps) {
    long v = mo_contact_set_version(R.C);
    int nold = mo_contact_ncandidates(R.C), nc, a, p;
    const int *map;
    if (nold > ocap) {
      ocap = nold + nold / 2;
      free(okey);
      if (!(okey = malloc((size_t)ocap * MO_KEY * sizeof *okey))) break;
    }
    if (nold) memcpy(okey, mo_contact_key(R.C, 0), (size_t)nold * MO_KEY * sizeof *okey);
    if ((st = mo_contact_step(R.D, &R.s, &R.ctx))) break;
    if (mo_contact_set_version(R.C) == v) continue;
    nc = mo_contact_ncandidates(R.C);
    map = mo_contact_detect_map(R.C, v, mo_contact_set_version(R.C));
    if (!map || mo_keymap_build(&K, okey, nold, &R.ctx)) {
      (*bad)++;
      break;
    }
    sets++;
    for (a = 0; a < nc; a++) {
      const int *k = mo_contact_key(R.C, a);
      int brute = -1;
      for (p = 0; p < nold && brute < 0; p++)
        if (!memcmp(okey + (size_t)p * MO_KEY, k, MO_KEY * sizeof *k)) brute = p;
      if (map[a] != mo_keymap_find(&K, k) || map[a] != brute) (*bad)++;
      if (map[a] >= 0 && map[a] != a) (*moved)++;
    }
    /* the same set split over 2 and 3 ranks, each its part's map (T270): the whole set's */
    for (p = 2; p <= 3; p++) {
      int parts, b = parts_map(R.C->krr, okey, nold, mo_contact_key(R.C, 0), nc, p, map, &parts);
      *pbad += b < 0 || (nc > 20 && parts < p) ? 1 : b;
    }
  }
  if (st) ok(0, "%s: %s", name, R.ctx.errmsg);
  free(okey);
  mo_keymap_free(&K);
  tl_steps_free(&R);
  return sets;
}

static void remap_deposits(void)
{
  static char t[16384];
  int sets, bad, moved, pbad;
  disks_text(t, sizeof t, 200, 0.3, "", "");
  sets = remap_sets(t, "remap200.cfg", &bad, &moved, &pbad);
  ok(sets >= 200 && !bad && moved > 100, "200 disks, 300 steps: the detection's remap is the key map's and brute "
     "force's at each of %d new sets (%d candidates otherwise; %d moved to another place)", sets, bad, moved);
  ok(sets >= 200 && !pbad, "200 disks: each set dealt to 2 and 3 ranks by body pair, the parts' maps merged are "
     "the whole set's (T270)-(T271) (%d candidates otherwise)", pbad);
  polygons_text(t, sizeof t, 0.3);
  sets = remap_sets(t, "remappoly.cfg", &bad, &moved, &pbad);
  ok(sets >= 20 && !bad, "polygons and disks (several contacts a pair), 600 steps: the same at each of %d new sets "
     "(%d candidates otherwise)", sets, bad);
  ok(sets >= 20 && !pbad, "polygons and disks: the parts' maps over 2 and 3 ranks, merged, the whole set's (%d "
     "candidates otherwise)", pbad);
}

/* Random sets in the detection's order (T220), independent of setmap.c's: pairs 0 and 1 of shapes
   against planes (body 1000 + k) by pair then slave, pairs 2 and 3 between shapes by the body
   pair's (lower, higher) index, a pair's contacts (features) in any order. The old set is written
   over by the new one through mo_setmap_put; its map against brute force (the first old key
   equal, -1 none) and the keys left against the new set. */
typedef struct {
  int o[3];
  int key[MO_KEY];
  unsigned r;
} rkey;

static int rkey_cmp(const void *x, const void *y)
{
  const rkey *a = x, *b = y;
  int i;
  for (i = 0; i < 3; i++)
    if (a->o[i] != b->o[i]) return a->o[i] < b->o[i] ? -1 : 1;
  return a->r < b->r ? -1 : a->r > b->r; /* a group's contacts shuffled */
}

static unsigned rnd(unsigned *s)
{
  *s = *s * 1103515245u + 12345u;
  return *s >> 8;
}

/* A random set of up to n keys over nb bodies, in the detection's order; p: the chance (per 1000)
   that a key of `like` (nl keys) is kept, q: that one of the universe is added. */
static int random_set(rkey *out, int nb, const rkey *like, int nl, int p, int q, unsigned *s)
{
  int n = 0, i, b, c, f;
  for (i = 0; i < nl; i++)
    if ((int)(rnd(s) % 1000) < p) out[n++] = like[i];
  for (b = 0; b < nb; b++)
    for (c = 0; c < nb + 2; c++)
      for (f = 0; f < 3; f++) {
        rkey k;
        int j, dup = 0;
        if ((int)(rnd(s) % 1000) >= q) continue;
        if (c >= nb) { /* b against plane c - nb (pair 0 or 1), feature f */
          k.o[0] = 0; k.o[1] = c - nb; k.o[2] = b;
          k.key[0] = c - nb; k.key[1] = b; k.key[2] = 1000 + c - nb; k.key[3] = f; k.key[4] = -1;
        } else {
          int lo = b < c ? b : c, hi = b < c ? c : b, flip = (int)(rnd(s) % 2);
          if (b == c) continue;
          k.o[0] = 1; k.o[1] = lo; k.o[2] = hi;
          k.key[0] = 2 + (lo + hi) % 2; k.key[1] = flip ? hi : lo; k.key[2] = flip ? lo : hi;
          k.key[3] = f; k.key[4] = (int)(rnd(s) % 2);
        }
        for (j = 0; j < n && !dup; j++) dup = !memcmp(out[j].key, k.key, sizeof k.key);
        if (!dup) out[n++] = k;
      }
  for (i = 0; i < n; i++) out[i].r = rnd(s);
  qsort(out, (size_t)n, sizeof *out, rkey_cmp);
  return n;
}

static void remap_random(void)
{
  static rkey A[4000], B[4000];
  static int keys[4000 * MO_KEY], okeys[4000 * MO_KEY], nkeys[4000 * MO_KEY], want[4000];
  static const unsigned char rr[4] = {0, 0, 1, 1};
  mo_setmap M;
  mo_ctx ctx;
  unsigned s = 7;
  int trial, bad = 0, mapped = 0, fresh = 0, gone = 0, grew = 0, st = 0, pbad = 0, split = 0;
  memset(&M, 0, sizeof M);
  mo_ctx_init(&ctx);
  for (trial = 0; trial < 400 && !st; trial++) {
    int nb = 2 + (int)(rnd(&s) % 40), mode = trial % 4, na, nn, a, p, kept0;
    /* old and new alike (a deposit's step), new sets much larger, much smaller, unrelated */
    int q1 = mode == 1 ? 20 : 150, keep = mode == 2 ? 300 : mode == 3 ? 0 : 900, q2 = mode == 1 ? 300 : 30;
    na = random_set(A, nb, NULL, 0, 0, q1, &s);
    nn = random_set(B, nb, A, na, keep, q2, &s);
    for (a = 0; a < na; a++) memcpy(keys + (size_t)a * MO_KEY, A[a].key, sizeof A[a].key);
    if ((st = mo_setmap_begin(&M, rr, na, 0, &ctx))) break;
    for (a = 0; a < nn && !st; a++) st = mo_setmap_put(&M, keys, a, B[a].key, &ctx);
    if (st || M.bad) {
      bad++;
      break;
    }
    grew += nn > na + 50;
    kept0 = mapped;
    for (a = 0; a < nn; a++) {
      int brute = -1;
      for (p = 0; p < na && brute < 0; p++)
        if (!memcmp(A[p].key, B[a].key, sizeof B[a].key)) brute = p;
      bad += M.map[a] != brute || memcmp(keys + (size_t)a * MO_KEY, B[a].key, sizeof B[a].key);
      want[a] = brute;
      mapped += brute >= 0;
      fresh += brute < 0;
    }
    gone += na - (mapped - kept0);
    /* the new set over 2 to 5 ranks (T270)-(T271), each part over its copy of the old keys */
    for (a = 0; a < na; a++) memcpy(okeys + (size_t)a * MO_KEY, A[a].key, sizeof A[a].key);
    for (a = 0; a < nn; a++) memcpy(nkeys + (size_t)a * MO_KEY, B[a].key, sizeof B[a].key);
    {
      int parts, b = parts_map(rr, okeys, na, nkeys, nn, 2 + trial % 4, want, &parts);
      pbad += b < 0 ? 1 : b;
      split += parts > 1;
    }
  }
  ok(!st && !bad && mapped > 10000 && fresh > 10000 && grew >= 50, "400 random sets written over the old (%d kept, %d "
     "new, %d gone; %d at least 50 larger): the map is brute force's and the keys the new set's (%d otherwise)",
     mapped, fresh, gone, grew, bad);
  ok(!st && !pbad && split >= 350, "the same sets dealt to 2 to 5 ranks by body (%d of them in 2 parts or more): the "
     "parts' maps, each over its copy of the old set, merged, are brute force's (%d otherwise)", split, pbad);
  mo_setmap_free(&M);
  mo_ctx_release(&ctx);
}

int main(void)
{
  disks();
  pair_friction();
  spheres();
  polygons();
  fclib_dump();
  memory();
  report_norms("natural");
  report_norms("scaled");
  metrics_follow();
  frames_of_normals(2);
  frames_of_normals(3);
  remap_deposits();
  remap_random();
  return done_testing();
}
