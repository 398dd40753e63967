/* test_levelset.c: the levelset back end against independent references: the rods impact against
   its closed form (doc/architecture.md §11), the GRECO examples against a projected Gauss-Seidel reference
   written here and against Jean's published tables, the patch test (uniform pressure with k_n = 0
   and the projected k_n, perturbed by the pointwise k_n), Signorini-Moreau and Coulomb at every
   step of 2D and 3D frictional runs, status cycling, and allocation failures. */
#include "config.h"
#include <moreau/moreau.h>
#include "testlib.h"

/* --- running a scene step by step ---------------------------------------------------------------- */

typedef tl_steps run_t;
#define run_free tl_steps_free

/* Load a case (a path, or the text itself when `text` is set), apply the overrides, build the
   scene, the contact set, the stepper and the contact driver. */
static int run_open(run_t *R, const char *src, int text, const char *const *sets, int nset)
{
  int st = tl_steps_open(R, src, text ? "test.cfg" : NULL, sets, nset);
  if (st) diag("setup: %s", R->ctx.errmsg);
  return st;
}

static char case_path[1024];
static const char *case_dir(const char *name)
{
  const char *src = getenv("MOREAU_SRCDIR");
  snprintf(case_path, sizeof case_path, "%s/cases/%s", src ? src : ".", name);
  return case_path;
}

/* Total momentum along axis i of every deformable body (M v). */
static double momentum(const run_t *R, int i)
{
  const mo_scene *sc = R->sc;
  double *Mv = calloc((size_t)sc->ndof, sizeof *Mv), p = 0;
  int k;
  mo_csc_gaxpy(sc->M, 1, R->s.v, 0, Mv);
  for (k = i; k < sc->ndof; k += sc->dim) p += Mv[k];
  free(Mv);
  return p;
}

/* --- 1. the rods impact (doc/architecture.md §11): 1D bar elements, theta = 1, h = 2e-6 ------------------------- */

static void test_rods(void)
{
  run_t R;
  const double E = 2e11, rho = 7800, A = 4e-4, v0 = 10, c = sqrt(E / rho);
  const double F0 = rho * c * v0 * A, t1 = 50e-6 + 2 / c;
  double h, t_first = -1, t_last = -1, maxjump = 0, maxF = 0, ming = 1, p0;
  int st = 0, intervals = 0, was = 0, bad_sign = 0, bad_open = 0, plateau_ok = 1, nplateau = 0;
  int loops_ok = 1, conv_ok = 1;
  if (run_open(&R, case_dir("rods-1d"), 0, NULL, 0)) { ok(0, "rods-1d scene"); return; }
  h = R.sc->time.dt;
  p0 = momentum(&R, 0);
  while (R.s.step < R.sc->time.steps && !st) {
    const mo_contact_report *rep;
    const double *r, *U;
    const int *status;
    double t0 = R.s.t;
    st = mo_contact_step(R.D, &R.s, &R.ctx);
    if (st) break;
    rep = mo_contact_last_report(R.D);
    r = mo_contact_reactions(R.D);
    U = mo_contact_local_velocity(R.D);
    status = mo_contact_statuses(R.D);
    if (r[0] < 0) bad_sign = 1;
    if (status[0] == MO_CS_OPEN) {
      if (r[0] != 0) bad_open = 1;
      was = 0;
      continue;
    }
    /* in contact: the velocity jump, the loop counts, the force plateau */
    if (!was) intervals++;
    was = 1;
    if (t_first < 0) t_first = t0;
    t_last = R.s.t;
    if (fabs(U[0]) > maxjump) maxjump = fabs(U[0]);
    if (r[0] / h > maxF) maxF = r[0] / h;
    if (rep->reason != MO_CR_CONVERGED) conv_ok = 0;
    if (rep->loops[0] != 1 || rep->loops[1] != 1 || rep->loops[2] < 1 || rep->loops[3] < rep->loops[2] ||
        rep->iterations != rep->loops[3])
      loops_ok = 0;
    if (R.s.t >= 60e-6 && R.s.t <= 300e-6) {
      nplateau++;
      if (fabs(r[0] / h - F0) > 1e-6 * F0) plateau_ok = 0;
    }
    /* d_n <= 0 (g >= 0) at the end of the step */
    mo_contact_geometry(R.C, &R.s, R.s.t, 0, &R.ctx);
    if (mo_contact_gaps(R.C)[0] < ming) ming = mo_contact_gaps(R.C)[0];
  }
  ok(!st, "rods: 300 steps at h = 2e-6 s with the levelset back end %s", st ? R.ctx.errmsg : "");
  ok(intervals == 1, "rods: one contact interval, no chattering (%d)", intervals);
  is_close(t_first, 50e-6, 0.5 * h, "rods: the first contact step starts at t0 = 50 us (%.3f us)", t_first * 1e6);
  ok(fabs(t_last - t1) <= 2 * h, "rods: release within two steps of t1 = %.2f us (last contact step ends at %.2f us)",
     t1 * 1e6, t_last * 1e6);
  ok(maxjump < 1e-8 * v0, "rods: contact-end normal velocity jump below 1e-8 v0 while in contact (max %.2e m/s)", maxjump);
  ok(plateau_ok && nplateau > 100, "rods: contact force F0 = rho c v0 A = %.6e N to 1e-6 from 60 to 300 us (%d steps)", F0, nplateau);
  ok(maxF < F0 * (1 + 1e-3), "rods: the force never exceeds F0 (max %.6e N)", maxF);
  ok(!bad_sign && !bad_open, "rods: Signorini-Moreau: r_n >= 0, and r_n = 0 where open");
  ok(ming > -1e-12, "rods: d_n <= 0 at the end of every contact step (min gap %.2e m)", ming);
  ok(conv_ok && loops_ok, "rods: every contact step converged; loops: geometry 1, threshold 1 (no friction), level sets >= 1, Newton >= level sets");
  is_close(momentum(&R, 0), p0, 1e-9 * 3.12 * v0, "rods: total momentum conserved (action and reaction through H)");
  run_free(&R);
}

/* --- 2. GRECO (J88 §4.5, shared/data/greco): quasi-static, concentrated ------------------------------ */

static const char *greco_fmt =
  "bodies = (\n"
  "  { name = \"block\";\n"
  "    mesh = { generator = \"rectangle\"; size = [0.04, 0.04]; elements = [%s]; element = \"T3\"; diagonal = \"right\"; };\n"
  "    material = { E = 1.3e11; nu = 0.2; rho = 1.0; };\n"
  "    fix = ( { set = \"right\"; dofs = [\"x\"]; }, { set = \"right&bottom\"; dofs = [\"y\"]; } );\n"
  "    loads = ( { type = \"pressure\"; set = \"top\"; value = 5.0e7; },\n"
  "              { %s } );\n"
  "  },\n"
  "  { name = \"ground\"; type = \"plane\"; point = [0.0, 0.0]; normal = [0.0, 1.0]; }\n"
  ");\n"
  "time = { scheme = \"quasistatic\"; steps = 1; };\n"
  "contact = { solver = \"%s\"; pairs = ( { slave = \"block\"; slave_set = \"bottom\"; master = \"ground\"; mu = %s; } ); };\n";

/* Jean's two examples, and a refined block (64 x 32 cells, 64 candidates) under a side traction
   growing with y, where stick and slip alternate along coupled candidates near the loaded edge
   (simultaneous sign updates cycled there, see (T22)) */
static const char *greco_elements[4] = {"16, 8", "16, 8", "64, 32", "64, 32"};
static const char *greco_left[4] = {
  "type = \"nodal\"; set = \"left\"; values = [2.5e5, 5.5e5, 6.5e5, 7.5e5, 8.5e5, 9.5e5, 1.05e6, 1.15e6, 6.0e5]; direction = [1.0, 0.0];",
  "type = \"nodal\"; set = \"left\"; values = [1.25e5, 2.5e5, 2.5e5, 2.5e5, 2.5e5, 2.5e5, 2.5e5, 2.5e5, 1.25e5]; direction = [1.0, 0.0];",
  "type = \"traction\"; set = \"left\"; value = [\"1.0e6 * (1.0 + y / 0.04)\", \"0.0\"];",
  "type = \"traction\"; set = \"left\"; value = [\"1.0e6 * (1.0 + y / 0.04)\", \"0.0\"];"};
static const char *greco_mu[4] = {"1.0", "0.1", "1.0", "0.2"};
static const char *greco_name[4] = {"jean-mu1", "jean-mu01", "refined-64-mu1", "refined-64-mu0.2"};

/* The exact 2D local solver of one contact (open, stick, slide in either direction) for
   U = Waa r + qt, Coulomb |r_t| <= mu r_n: the first consistent case. */
static int local2d(const double *Waa, const double *qt, double mu, double *r)
{
  double det = Waa[0] * Waa[3] - Waa[1] * Waa[2], rn, rt, s;
  if (qt[0] >= 0) { r[0] = r[1] = 0; return MO_CS_OPEN; }
  rn = -(Waa[3] * qt[0] - Waa[1] * qt[1]) / det;
  rt = -(-Waa[2] * qt[0] + Waa[0] * qt[1]) / det;
  if (rn > 0 && fabs(rt) <= mu * rn) { r[0] = rn; r[1] = rt; return MO_CS_STICK; }
  for (s = 1; s >= -1; s -= 2) {
    double ut;
    rn = -qt[0] / (Waa[0] - s * mu * Waa[1]);
    if (!(rn > 0)) continue;
    rt = -s * mu * rn;
    ut = Waa[2] * rn + Waa[3] * rt + qt[1];
    if (s * ut >= 0) { r[0] = rn; r[1] = rt; return MO_CS_SLIDE; }
  }
  return -1;
}

/* Projected (nonlinear) Gauss-Seidel on U = W r + q with the exact local solver, to round-off:
   the independent reference (W dense m x m row-major, d = 2). */
static int pgs2d(int nc, const double *W, const double *q, const double *mu, double *r, int *status,
                 int *sweeps)
{
  int m = 2 * nc, a, b, it;
  memset(r, 0, (size_t)m * sizeof *r);
  for (it = 1; it <= 50000; it++) {
    double change = 0, rmax = 0;
    for (a = 0; a < nc; a++) {
      double qt[2] = {q[2 * a], q[2 * a + 1]}, Waa[4], rn[2];
      int i;
      for (b = 0; b < nc; b++) {
        if (b == a) continue;
        for (i = 0; i < 2; i++)
          qt[i] += W[(size_t)(2 * a + i) * m + 2 * b] * r[2 * b] + W[(size_t)(2 * a + i) * m + 2 * b + 1] * r[2 * b + 1];
      }
      Waa[0] = W[(size_t)(2 * a) * m + 2 * a];
      Waa[1] = W[(size_t)(2 * a) * m + 2 * a + 1];
      Waa[2] = W[(size_t)(2 * a + 1) * m + 2 * a];
      Waa[3] = W[(size_t)(2 * a + 1) * m + 2 * a + 1];
      if ((status[a] = local2d(Waa, qt, mu[a], rn)) < 0) return -1;
      for (i = 0; i < 2; i++) {
        if (fabs(rn[i] - r[2 * a + i]) > change) change = fabs(rn[i] - r[2 * a + i]);
        r[2 * a + i] = rn[i];
        if (fabs(rn[i]) > rmax) rmax = fabs(rn[i]);
      }
    }
    if (change <= 1e-12 * rmax) { *sweeps = it; return 0; }
  }
  *sweeps = it;
  return -1;
}

/* Jean's table column for an example: values (NAN where the text lost them) and statuses. */
static int jean_table(const char *example, double tab[16][4], int stat[16])
{
  const char *sh = getenv("MOREAU_SHARED");
  char path[1024], line[512];
  FILE *f;
  int n = 0;
  if (!sh) return 0;
  snprintf(path, sizeof path, "%s/data/greco/jean-1988-tables.csv", sh);
  if (!(f = fopen(path, "r"))) return 0;
  while (fgets(line, sizeof line, f)) {
    char *fld[9], *p = line;
    int k = 0, node;
    while (k < 9 && p) { fld[k++] = p; p = strchr(p, ','); if (p) *p++ = '\0'; }
    if (k < 9 || strcmp(fld[0], example) || strcmp(fld[1], "concentrated")) continue;
    node = atoi(fld[2]) - 1;
    if (node < 0 || node >= 16) continue;
    tab[node][0] = *fld[4] ? atof(fld[4]) : NAN; /* D1 */
    tab[node][1] = *fld[5] ? atof(fld[5]) : NAN; /* D2 */
    tab[node][2] = *fld[6] ? atof(fld[6]) : NAN; /* RT */
    tab[node][3] = *fld[7] ? atof(fld[7]) : NAN; /* RN */
    stat[node] = !strncmp(fld[8], "open", 4) ? MO_CS_OPEN : !strncmp(fld[8], "stick", 5) ? MO_CS_STICK : MO_CS_SLIDE;
    n++;
  }
  fclose(f);
  return n == 16;
}

/* One GRECO run by back end `solver` (overrides appended), its reactions, statuses and node
   displacements (D1, D2 of the 16 candidates). */
#define GMAX 64
typedef struct {
  double r[2 * GMAX], U[2 * GMAX], D[2 * GMAX];
  int status[GMAX];
  double *W, *q, *mu;
  int nc, d, loops[4];
} greco_result;

static int greco_run(int ex, const char *solver, const char *const *sets, int nset, greco_result *G)
{
  char text[4096];
  run_t R;
  int a, st;
  memset(G, 0, sizeof *G);
  snprintf(text, sizeof text, greco_fmt, greco_elements[ex], greco_left[ex], solver, greco_mu[ex]);
  if (run_open(&R, text, 1, sets, nset)) return -1;
  st = mo_contact_step(R.D, &R.s, &R.ctx);
  if (st) {
    diag("%s: %s", solver, R.ctx.errmsg);
    run_free(&R);
    return st;
  }
  G->nc = mo_contact_ncandidates(R.C);
  if (G->nc > GMAX) { run_free(&R); return -1; }
  memcpy(G->r, mo_contact_reactions(R.D), (size_t)(2 * G->nc) * sizeof(double));
  memcpy(G->U, mo_contact_local_velocity(R.D), (size_t)(2 * G->nc) * sizeof(double));
  memcpy(G->status, mo_contact_statuses(R.D), (size_t)G->nc * sizeof(int));
  memcpy(G->loops, mo_contact_last_report(R.D)->loops, sizeof G->loops);
  for (a = 0; a < G->nc; a++) {
    int node = mo_contact_candidate(R.C, a)->node;
    G->D[2 * a] = R.s.u[2 * node];
    G->D[2 * a + 1] = R.s.u[2 * node + 1];
  }
  st = mo_contact_driver_local_problem(R.D, &G->W, &G->q, &G->mu, &G->nc, &G->d, &R.ctx);
  run_free(&R);
  return st;
}

static void greco_result_free(greco_result *G)
{
  mo_free(G->W);
  mo_free(G->q);
  mo_free(G->mu);
  G->W = G->q = G->mu = NULL;
}

/* Coulomb and Signorini of a quasi-static solution (U' = end gap, slip increment). */
static void greco_laws(const char *who, const greco_result *G, double mu)
{
  int a, lam_ok = 1, slide_ok = 1, stick_ok = 1, sig_ok = 1, nslide = 0, nstick = 0;
  /* U' scale: the free motion |q| (U' itself vanishes where everything sticks) */
  double rmax = maxabs(G->r, 2 * G->nc), umax = maxabs(G->q, 2 * G->nc);
  for (a = 0; a < G->nc; a++) {
    const double *r = G->r + 2 * a, *U = G->U + 2 * a;
    if (r[0] < 0 || U[0] < -1e-12 * umax || fabs(r[0] * U[0]) > 1e-12 * rmax * umax) sig_ok = 0;
    if (G->status[a] == MO_CS_OPEN) {
      if (r[0] != 0 || r[1] != 0) sig_ok = 0;
      continue;
    }
    {
      double lam = -r[1] / (mu * r[0]); /* (T13): r_t = -mu r_n Lam */
      if (fabs(lam) > 1 + 1e-9) lam_ok = 0;
      if (G->status[a] == MO_CS_SLIDE) {
        nslide++;
        if (fabs(fabs(lam) - 1) > 1e-9 || !(r[1] * U[1] < 0)) slide_ok = 0;
      } else {
        nstick++;
        if (fabs(U[1]) > 1e-10 * umax) stick_ok = 0;
      }
    }
  }
  ok(sig_ok, "%s: Signorini: end gap >= 0, r_n >= 0, r_n gap = 0, r = 0 where open", who);
  ok(lam_ok, "%s: Coulomb: |Lambda| <= 1 at every closed candidate", who);
  ok(slide_ok, "%s: Coulomb: |Lambda| = 1 where sliding (%d), the friction force opposite to the slip", who, nslide);
  ok(stick_ok, "%s: Coulomb: no slip where sticking (%d)", who, nstick);
}

static void test_greco(void)
{
  int ex, b;
  for (ex = 0; ex < 4; ex++) {
    greco_result ref, L, K;
    double rref[2 * GMAX], tab[16][4];
    int sref[GMAX], sweeps = 0, jstat[16], a, i, nc, m;
    double mu = atof(greco_mu[ex]);
    static const char *kkt[] = {"contact.levelset.path=\"kkt\""};
    /* the levelset run and the reference from its own local problem (W, q, mu of the step) */
    if (greco_run(ex, "levelset", NULL, 0, &L)) { ok(0, "%s: levelset run", greco_name[ex]); continue; }
    nc = L.nc;
    m = 2 * nc;
    {
      int pst = pgs2d(nc, L.W, L.q, L.mu, rref, sref, &sweeps);
      ok(pst == 0, "%s: projected Gauss-Seidel reference converged (change below 1e-12 relative in %d sweeps)", greco_name[ex], sweeps);
    }
    memset(&ref, 0, sizeof ref);
    ref.nc = nc;
    memcpy(ref.r, rref, (size_t)m * sizeof(double));
    memcpy(ref.status, sref, (size_t)nc * sizeof(int));
    greco_laws(greco_name[ex], &L, mu);
    if (ex == 0) {
      /* the coupled threshold (doc/theory.md (T134), the default here) takes one threshold pass;
         BDZ07's loop (threshold = "loop") several, to the same solution within its threshold_tol */
      static const char *loop[] = {"contact.levelset.threshold=\"loop\""};
      greco_result T;
      ok(L.loops[0] == 1 && L.loops[1] == 1 && L.loops[2] >= 1 && L.loops[3] >= L.loops[2],
         "%s: loop counts: geometry %d, friction threshold %d, level sets %d, Newton %d", greco_name[ex],
         L.loops[0], L.loops[1], L.loops[2], L.loops[3]);
      if (!greco_run(ex, "levelset", loop, 1, &T)) {
        double e = 0;
        int same = 1;
        for (a = 0; a < nc; a++) same &= T.status[a] == L.status[a];
        for (i = 0; i < m; i++) if (fabs(T.r[i] - L.r[i]) > e) e = fabs(T.r[i] - L.r[i]);
        ok(T.loops[0] == 1 && T.loops[1] > 1 && T.loops[2] >= T.loops[1] && T.loops[3] >= T.loops[2],
           "%s, threshold loop: loop counts: geometry %d, friction threshold %d, level sets %d, Newton %d",
           greco_name[ex], T.loops[0], T.loops[1], T.loops[2], T.loops[3]);
        ok(same && e <= 1e-9 * maxabs(L.r, m), "%s: threshold loop = coupled threshold (statuses, reactions "
           "to %.1e relative; the loop stops at threshold_tol 1e-10)", greco_name[ex], e / maxabs(L.r, m));
        greco_result_free(&T);
      } else ok(0, "%s: threshold loop run", greco_name[ex]);
    }
    /* every registered back end that runs quasi-static steps against the reference, and against
       each other (levelset against nscd once both are registered) */
    for (b = 0; b < mo_contact_solver_count(); b++) {
      const mo_contact_solver_type *T = mo_contact_solver_at(b);
      greco_result X;
      double e = 0;
      int same = 1, o, ntol = 0;
      char tolset[96];
      const char *sets[1] = {tolset};
      if (!(T->schemes & (1u << MO_SCHEME_QUASISTATIC))) continue;
      /* iterative back ends to a tolerance well inside the comparison's 1e-6 */
      for (o = 0; o < T->noptions; o++)
        if (!strcmp(T->options[o].name, "tol")) {
          snprintf(tolset, sizeof tolset, "contact.%s.tol=1e-12", T->name);
          ntol = 1;
        }
      if (greco_run(ex, T->name, sets, ntol, &X)) { ok(0, "%s: %s run", greco_name[ex], T->name); continue; }
      for (a = 0; a < nc; a++) same &= X.status[a] == ref.status[a];
      for (i = 0; i < m; i++) if (fabs(X.r[i] - ref.r[i]) > e) e = fabs(X.r[i] - ref.r[i]);
      ok(same, "%s: %s gives the reference's statuses", greco_name[ex], T->name);
      ok(e <= 1e-6 * maxabs(ref.r, m), "%s: %s reactions agree with the reference to %.1e relative (<= 1e-6)",
         greco_name[ex], T->name, e / maxabs(ref.r, m));
      if (strcmp(T->name, "levelset")) {
        double e2 = 0;
        int same2 = 1;
        for (a = 0; a < nc; a++) same2 &= X.status[a] == L.status[a];
        for (i = 0; i < m; i++) if (fabs(X.r[i] - L.r[i]) > e2) e2 = fabs(X.r[i] - L.r[i]);
        ok(same2 && e2 <= 1e-6 * maxabs(L.r, m), "%s: %s and levelset: same statuses, reactions to %.1e relative",
           greco_name[ex], T->name, e2 / maxabs(L.r, m));
      }
      greco_result_free(&X);
    }
    /* the saddle-point path gives the same solution */
    if (!greco_run(ex, "levelset", kkt, 1, &K)) {
      double e = 0;
      int same = 1;
      for (a = 0; a < nc; a++) same &= K.status[a] == L.status[a];
      for (i = 0; i < m; i++) if (fabs(K.r[i] - L.r[i]) > e) e = fabs(K.r[i] - L.r[i]);
      ok(same && e <= 1e-9 * maxabs(L.r, m), "%s: KKT path (UMFPACK) = Schur path (%.1e relative)", greco_name[ex],
         e / maxabs(L.r, m));
      greco_result_free(&K);
    } else ok(0, "%s: KKT path run", greco_name[ex]);
    /* Jean's published table (1e-3 of each column's largest magnitude, doc/architecture.md §11) */
    if (ex >= 2) ok(1, "# SKIP %s: no published table", greco_name[ex]);
    else if (jean_table(greco_name[ex], tab, jstat)) {
      double cmax[4] = {0, 0, 0, 0}, emax[4] = {0, 0, 0, 0};
      int same = 1, k;
      for (a = 0; a < 16; a++)
        for (k = 0; k < 4; k++) if (!isnan(tab[a][k]) && fabs(tab[a][k]) > cmax[k]) cmax[k] = fabs(tab[a][k]);
      for (a = 0; a < 16; a++) {
        double mine[4] = {L.D[2 * a], L.D[2 * a + 1], L.r[2 * a + 1], L.r[2 * a]};
        same &= jstat[a] == L.status[a];
        for (k = 0; k < 4; k++)
          if (!isnan(tab[a][k]) && fabs(mine[k] - tab[a][k]) > emax[k]) emax[k] = fabs(mine[k] - tab[a][k]);
      }
      ok(same, "%s: statuses identical to Jean's table", greco_name[ex]);
      for (k = 0; k < 4; k++) {
        static const char *col[4] = {"D1", "D2", "RT", "RN"};
        if (cmax[k] == 0) continue;
        ok(emax[k] <= 1e-3 * cmax[k], "%s: %s within 1e-3 of Jean's column maximum (%.1e)", greco_name[ex], col[k],
           emax[k] / cmax[k]);
      }
    } else ok(1, "# SKIP %s: Jean's table not found (MOREAU_SHARED)", greco_name[ex]);
    greco_result_free(&L);
  }
}

/* --- 3. the patch test (BDZ07 §6.4) --------------------------------------------------------------- */

typedef struct {
  double r[16], w[16];
  int nc;
  double syy_min, syy_max;  /* lower (slave) block */
  double *u;
  int ndof;
} patch_result;

static int patch_run(const char *const *sets, int nset, patch_result *P)
{
  run_t R;
  const mo_body *B;
  int a, e, st;
  memset(P, 0, sizeof *P);
  if (run_open(&R, case_dir("patch-test"), 0, sets, nset)) return -1;
  if ((st = mo_contact_step(R.D, &R.s, &R.ctx))) { diag("%s", R.ctx.errmsg); run_free(&R); return st; }
  P->nc = mo_contact_ncandidates(R.C);
  for (a = 0; a < P->nc && a < 16; a++) {
    P->r[a] = mo_contact_reactions(R.D)[2 * a];
    P->w[a] = mo_contact_candidate(R.C, a)->w;
  }
  B = &R.sc->body[0];
  P->syy_min = HUGE_VAL;
  P->syy_max = -HUGE_VAL;
  for (e = 0; e < B->mesh->nelem; e++) {
    double ue[8], eps[4], sig[4];
    int k, i;
    for (k = 0; k < 4; k++)
      for (i = 0; i < 2; i++) ue[2 * k + i] = R.s.u[B->dof0 + 2 * B->mesh->conn[4 * e + k] + i];
    mo_elem_stress(B->mesh, e, B->mat, ue, eps, sig);
    if (sig[1] < P->syy_min) P->syy_min = sig[1];
    if (sig[1] > P->syy_max) P->syy_max = sig[1];
  }
  P->ndof = R.sc->ndof;
  P->u = malloc((size_t)P->ndof * sizeof(double));
  memcpy(P->u, R.s.u, (size_t)P->ndof * sizeof(double));
  run_free(&R);
  return 0;
}

static void pressure_range(const patch_result *P, double *pmin, double *pmax, double *pmean)
{
  int a;
  *pmin = HUGE_VAL;
  *pmax = -HUGE_VAL;
  *pmean = 0;
  for (a = 0; a < P->nc; a++) {
    double p = P->r[a] / P->w[a];
    if (p < *pmin) *pmin = p;
    if (p > *pmax) *pmax = p;
    *pmean += p / P->nc;
  }
}

static void test_patch(void)
{
  static const char *proj[] = {"contact.levelset.k_n=1.0e12"};
  static const char *unproj[] = {"contact.levelset.k_n=1.0e12", "contact.levelset.stabilization=\"unprojected\""};
  static const char *kkt[] = {"contact.levelset.k_n=1.0e12", "contact.levelset.path=\"kkt\""};
  patch_result P0, P1, P2, P3;
  double lo, hi, mean, lo1, hi1, mean1, lo2, hi2, mean2, du = 0, dr = 0;
  /* closed form: p = delta / (H_l / M_l + H_u / M_u), M = E (1 - nu) / ((1 + nu)(1 - 2 nu)) */
  double Ml = 2e11 * 0.7 / (1.3 * 0.4), Mu = 1e11 * 0.7 / (1.3 * 0.4), p = 1e-4 / (0.5 / Ml + 0.5 / Mu);
  int i;
  if (patch_run(NULL, 0, &P0) || patch_run(proj, 1, &P1) || patch_run(unproj, 2, &P2) || patch_run(kkt, 2, &P3)) {
    ok(0, "patch-test runs");
    return;
  }
  ok(P0.nc == 8, "patch: 8 collocation points (2 Gauss points on 4 slave facets, P0 multipliers)");
  pressure_range(&P0, &lo, &hi, &mean);
  ok((hi - lo) <= 1e-8 * mean, "patch, k_n = 0: uniform transmitted pressure (spread %.1e relative, <= 1e-8)", (hi - lo) / mean);
  ok(fabs(mean / p - 1) < 2e-4, "patch, k_n = 0: pressure %.8e against the closed form %.8e (%.1e; the master side's Gauss integration)",
     mean, p, mean / p - 1);
  ok((P0.syy_max - P0.syy_min) <= 1e-8 * fabs(P0.syy_min) && fabs(P0.syy_min + mean) <= 1e-8 * mean,
     "patch, k_n = 0: the slave block's sigma_yy is uniform and equal to -p (spread %.1e)",
     (P0.syy_max - P0.syy_min) / fabs(P0.syy_min));
  pressure_range(&P1, &lo1, &hi1, &mean1);
  for (i = 0; i < P0.ndof; i++) if (fabs(P1.u[i] - P0.u[i]) > du) du = fabs(P1.u[i] - P0.u[i]);
  for (i = 0; i < 8; i++) if (fabs(P1.r[i] - P0.r[i]) > dr) dr = fabs(P1.r[i] - P0.r[i]);
  ok((hi1 - lo1) <= 1e-8 * mean1, "patch, projected k_n > 0: uniform transmitted pressure (spread %.1e relative)", (hi1 - lo1) / mean1);
  ok(dr <= 1e-10 * mean * 0.125 && du <= 1e-10 * 1e-4,
     "patch, projected k_n > 0: the Lagrangian solution unchanged (reactions %.1e, displacements %.1e m)", dr, du);
  pressure_range(&P2, &lo2, &hi2, &mean2);
  du = 0;
  for (i = 0; i < P0.ndof; i++) if (fabs(P2.u[i] - P0.u[i]) > du) du = fabs(P2.u[i] - P0.u[i]);
  ok((hi2 - lo2) > 1e-3 * mean2, "patch, unprojected k_n > 0: the transmitted pressure is perturbed (spread %.1e relative)",
     (hi2 - lo2) / mean2);
  ok(du > 1e-3 * 1e-4, "patch, unprojected k_n > 0: the displacements move (%.2e m against delta = 1e-4 m)", du);
  dr = 0;
  for (i = 0; i < 8; i++) if (fabs(P3.r[i] - P1.r[i]) > dr) dr = fabs(P3.r[i] - P1.r[i]);
  ok(dr <= 1e-9 * mean * 0.125, "patch: KKT path = Schur path with the projection (%.1e)", dr / (mean * 0.125));
  free(P0.u); free(P1.u); free(P2.u); free(P3.u);
}

/* --- 4. status cycling: BDZ07 (53) literally at an off-grid landing --------------------------------- */

static const char *gauss_cycle =
  "bodies = (\n"
  "  { name = \"block\";\n"
  "    mesh = { generator = \"rectangle\"; size = [0.04, 0.02]; elements = [8, 4]; element = \"T3\"; };\n"
  "    material = { E = 1.0e10; nu = 0.3; rho = 1.0; };\n"
  "    fix = ( { set = \"right\"; dofs = [\"x\"]; }, { set = \"right&bottom\"; dofs = [\"y\"]; } );\n"
  "    loads = ( { type = \"pressure\"; set = \"top\"; value = 1.0e7; },\n"
  "              { type = \"traction\"; set = \"left\"; value = [3.0e6, 0.0]; } ); },\n"
  "  { name = \"ground\"; type = \"plane\"; point = [0.0, 0.0]; normal = [0.0, 1.0]; }\n"
  ");\n"
  "time = { scheme = \"quasistatic\"; steps = 1; };\n"
  "contact = { solver = \"levelset\"; pairs = ( { slave = \"block\"; slave_set = \"bottom\"; master = \"ground\";\n"
  "            mu = 0.3; collocation = \"gauss\"; } ); };\n";

static void test_cycling(void)
{
  static const char *sets[] = {"bodies.left.mesh.origin=-1.000505", "bodies.right.mesh.origin=0.000505",
                               "contact.levelset.su=\"end_gap\"", "bodies.left.mesh.elements=100",
                               "bodies.right.mesh.elements=100"};
  run_t R;
  int st = 0, steps = 0;
  const mo_contact_report *rep;
  if (run_open(&R, case_dir("rods-1d"), 0, sets, 5)) { ok(0, "cycling scene"); return; }
  while (!st && steps < 40) { st = mo_contact_step(R.D, &R.s, &R.ctx); steps++; }
  rep = mo_contact_last_report(R.D);
  ok(st == MO_ENOCONV && rep->reason == MO_CR_CYCLING, "su = end_gap: the landing step cycles and is reported (%s)",
     mo_contact_reason_name(rep->reason));
  ok(strstr(rep->message, "candidate 0") && strstr(rep->message, "S_u"), "the report names the candidate and the sign: %s",
     rep->message);
  ok(strstr(R.ctx.errmsg, "status cycling") != NULL, "the run stops with a diagnosis naming status cycling");
  run_free(&R);
  /* the index set (the default) lands on the same gap without cycling */
  if (run_open(&R, case_dir("rods-1d"), 0, sets, 2)) { ok(0, "index-set scene"); return; }
  st = 0;
  steps = 0;
  while (!st && steps < 40) { st = mo_contact_step(R.D, &R.s, &R.ctx); steps++; }
  ok(!st && mo_contact_statuses(R.D)[0] != MO_CS_OPEN, "su = index_set: the same landing converges and stays closed");
  run_free(&R);
  /* a cycle of S_v and S_f far from round-off: a pressed and pushed T3 block on a plane, Gauss
     collocation with P0 multipliers (one Lam per facet, one S_f per Gauss point), where the
     level-set loop alternates between sign vectors whose solutions both break the contact law by
     percents (nscd solves the pointwise problem). The tolerances of (T88) and the law's residual
     of (T89) must not take it for round-off: it is still reported as cycling. Should levelset
     learn to solve this scene, assert the solution instead. */
  if (run_open(&R, gauss_cycle, 1, NULL, 0)) { ok(0, "gauss cycling scene"); return; }
  st = mo_contact_step(R.D, &R.s, &R.ctx);
  rep = mo_contact_last_report(R.D);
  ok(st == MO_ENOCONV && rep->reason == MO_CR_CYCLING && (strstr(rep->message, "S_f") || strstr(rep->message, "S_v")),
     "a cycle of S_v, S_f with the law broken is still reported (%s, residual %.1e): %.120s",
     mo_contact_reason_name(rep->reason), rep->residual, rep->message);
  ok(rep->residual > 1e-3, "its residual (%.2e) is far above round-off: a genuine cycle", rep->residual);
  run_free(&R);
}

/* --- 5. Signorini-Moreau and Coulomb at every step of 2D and 3D frictional runs ---------------------- */

static const char *slide2d =
  "bodies = (\n"
  "  { name = \"block\"; mesh = { generator = \"rectangle\"; size = [0.1, 0.02]; elements = [4, 1]; };\n"
  "    material = { E = 1.0e8; nu = 0.3; rho = 1000.0; }; body_force = [0.0, -9.81];\n"
  "    initial = { velocity = [0.3, 0.0]; }; },\n"
  "  { name = \"floor\"; type = \"plane\"; point = [0.0, 0.0]; normal = [0.0, 1.0]; }\n"
  ");\n"
  "time = { theta = 1.0; theta_f = 1.0; dt = 1.0e-3; end = 0.2; };\n"
  "contact = { solver = \"levelset\"; signorini = \"velocity\";\n"
  "            pairs = ( { slave = \"block\"; slave_set = \"bottom\"; master = \"floor\"; mu = 0.3; } ); };\n";

static const char *slide3d =
  "bodies = (\n"
  "  { name = \"box\"; mesh = { generator = \"box\"; size = [0.1, 0.1, 0.02]; elements = [2, 2, 1]; };\n"
  "    material = { E = 1.0e8; nu = 0.3; rho = 1000.0; }; body_force = [0.0, 0.0, -9.81];\n"
  "    initial = { velocity = [0.2, 0.1, 0.0]; }; },\n"
  "  { name = \"floor\"; type = \"plane\"; point = [0.0, 0.0, 0.0]; normal = [0.0, 0.0, 1.0]; }\n"
  ");\n"
  "time = { theta = 1.0; theta_f = 1.0; dt = 1.0e-3; end = 0.2; };\n"
  "contact = { solver = \"levelset\"; signorini = \"velocity\";\n"
  "            pairs = ( { slave = \"box\"; slave_set = \"zmin\"; master = \"floor\"; mu = 0.3; } ); };\n";

static void test_friction_dynamics(int dim)
{
  const double mu = 0.3, g = 9.81, v0 = dim == 2 ? 0.3 : hypot(0.2, 0.1), dir[2] = {dim == 2 ? 1 : 0.2 / v0, dim == 2 ? 0 : 0.1 / v0};
  run_t R;
  int st = 0, sig_ok = 1, lam_ok = 1, slide_ok = 1, stick_ok = 1, nslide = 0, nstick = 0, decel_ok = 1, dir_ok = 1;
  int conv_ok = 1;
  double vmax = 0, mass;
  const char *name = dim == 2 ? "2D block" : "3D box";
  if (run_open(&R, dim == 2 ? slide2d : slide3d, 1, NULL, 0)) { ok(0, "%s scene", name); return; }
  mass = R.sc->mass_total;
  while (R.s.step < R.sc->time.steps && !st) {
    const double *r, *U;
    const int *status;
    const mo_contact_report *rep;
    double vt[2], vn;
    int a, nc, d, k;
    st = mo_contact_step(R.D, &R.s, &R.ctx);
    if (st) break;
    rep = mo_contact_last_report(R.D);
    if (rep->reason != MO_CR_CONVERGED && rep->reason != MO_CR_NOCONTACT) conv_ok = 0;
    r = mo_contact_reactions(R.D);
    U = mo_contact_local_velocity(R.D);
    status = mo_contact_statuses(R.D);
    nc = mo_contact_ncandidates(R.C);
    d = mo_contact_dim(R.C);
    for (a = 0; a < nc; a++) {
      const double *ra = r + a * d, *Ua = U + a * d;
      double rt = 0, ut = 0, ru = 0;
      for (k = 1; k < d; k++) { rt += ra[k] * ra[k]; ut += Ua[k] * Ua[k]; ru += ra[k] * Ua[k]; }
      rt = sqrt(rt);
      ut = sqrt(ut);
      if (ut > vmax) vmax = ut;
      if (ra[0] < 0) sig_ok = 0;
      if (status[a] == MO_CS_OPEN) {
        for (k = 0; k < d; k++) if (ra[k] != 0) sig_ok = 0;
        continue;
      }
      /* closed: [v_n] = 0 (BDZ07 (27) with S_u S_v = 1), |Lambda| <= 1 */
      if (fabs(Ua[0]) > 1e-10 * v0) sig_ok = 0;
      if (rt > mu * ra[0] * (1 + 1e-9)) lam_ok = 0;
      if (status[a] == MO_CS_SLIDE) {
        nslide++;
        /* |Lambda| = 1 and the friction impulse antiparallel to the slip */
        if (fabs(rt - mu * ra[0]) > 1e-9 * mu * ra[0] || !(ut > 0) || fabs(ru + rt * ut) > 1e-9 * rt * ut) slide_ok = 0;
      } else {
        nstick++;
        if (ut > 1e-10 * v0) stick_ok = 0;
      }
    }
    /* the mean velocity of the body: (v0 - mu g t) along the initial direction, then rest */
    for (k = 0; k < 2; k++) vt[k] = momentum(&R, k) / mass;
    vn = vt[0] * dir[0] + vt[1] * dir[1];
    if (R.s.t < 0.8 * v0 / (mu * g) && fabs(vn - (v0 - mu * g * R.s.t)) > 1e-2 * v0) decel_ok = 0;
    if (R.s.t > 1.2 * v0 / (mu * g) && hypot(vt[0], vt[1]) > 1e-3 * v0) decel_ok = 0;
    if (dim == 3 && R.s.t < 0.8 * v0 / (mu * g) && fabs(vt[0] * dir[1] - vt[1] * dir[0]) > 1e-6 * v0) dir_ok = 0;
  }
  ok(!st && conv_ok, "%s: %ld steps, every contact solve converged %s", name, R.s.step, st ? R.ctx.errmsg : "");
  ok(sig_ok, "%s: Signorini-Moreau at every step: r_n >= 0, r = 0 where open, [v_n] = 0 where closed", name);
  ok(lam_ok, "%s: Coulomb: |Lambda| <= 1 at every closed candidate", name);
  ok(slide_ok && nslide > 0, "%s: sliding (%d candidate steps): |Lambda| = 1, friction opposite to [v_t]", name, nslide);
  ok(stick_ok && nstick > 0, "%s: sticking (%d candidate steps): [v_t] = 0", name, nstick);
  ok(decel_ok, "%s: the body slides at v0 - mu g t (to 1%% of v0) and then stays at rest", name);
  if (dim == 3) ok(dir_ok, "%s: it slides along its initial direction", name);
  run_free(&R);
}

/* --- 7. quasi-static load steps: a ramped load ends where one step does ------------------------------
   Jean's GRECO block with mu = 1 (J88 Fig. 3), both loads times an amplitude a(t) that grows from
   0 to 1 proportionally and then holds. For linear elasticity and Coulomb friction under a
   proportional, monotone load from a stress-free state, a(t) times the one-step solution solves
   every load step (slips grow along the final slips, sticking points stay stuck, no reversal), so
   the state after N steps is the one-step state: the reference here. The hold steps (a = 1 again)
   have no increment: slips of zero at candidates sliding at |Lam| = 1, where round-off decides a
   sign test unless the test is scaled (T88) and hysteretic, and the law's residual (T89) is heard.
   There the statuses of the last step are those of its increment (no slip: stick, at |Lam| = 1),
   so only open and closed are compared. The friction-threshold loop stops each step at
   threshold_tol of the largest pressure: with its default 1e-10 (the setting that cycled) the
   N-step and one-step states are compared to 1e-9; with 1e-12 to 1e-10, where the comparison is
   the path independence, not the loop's stopping rule. */

static const char *ramp_fmt =
  "bodies = (\n"
  "  { name = \"block\";\n"
  "    mesh = { generator = \"rectangle\"; size = [0.04, 0.04]; elements = [16, 8]; element = \"T3\"; diagonal = \"right\"; };\n"
  "    material = { E = 1.3e11; nu = 0.2; rho = 1.0; };\n"
  "    fix = ( { set = \"right\"; dofs = [\"x\"]; }, { set = \"right&bottom\"; dofs = [\"y\"]; } );\n"
  "    loads = ( { type = \"pressure\"; set = \"top\"; value = 5.0e7; amplitude = \"%s\"; },\n"
  "              { type = \"nodal\"; set = \"left\"; direction = [1.0, 0.0]; amplitude = \"%s\";\n"
  "                values = [2.5e5, 5.5e5, 6.5e5, 7.5e5, 8.5e5, 9.5e5, 1.05e6, 1.15e6, 6.0e5]; } );\n"
  "  },\n"
  "  { name = \"ground\"; type = \"plane\"; point = [0.0, 0.0]; normal = [0.0, 1.0]; }\n"
  ");\n"
  "time = { scheme = \"quasistatic\"; steps = %d; };\n"
  "contact = { solver = \"levelset\"; pairs = ( { slave = \"block\"; slave_set = \"bottom\"; master = \"ground\";\n"
  "            mu = 1.0; reactions = \"%s\"; } ); levelset = { threshold_tol = %s; }; };\n";

typedef struct {
  double *u, r[2 * GMAX];
  int status[GMAX], nc, ndof, failed_step, nslide;
  char why[512];
} ramp_result;

/* N load steps; the final displacements, reactions and statuses (failed_step: the first step
   whose contact solve did not converge, 0 if none). */
static int ramp_run(const char *amp, int N, const char *reactions, const char *thr_tol, ramp_result *Z)
{
  char text[4096];
  run_t R;
  int st = 0, a;
  memset(Z, 0, sizeof *Z);
  snprintf(text, sizeof text, ramp_fmt, amp, amp, N, reactions, thr_tol);
  if (run_open(&R, text, 1, NULL, 0)) return -1;
  while (R.s.step < R.sc->time.steps) {
    st = mo_contact_step(R.D, &R.s, &R.ctx);
    if (st || mo_contact_last_report(R.D)->reason != MO_CR_CONVERGED) {
      Z->failed_step = (int)R.s.step + 1;
      snprintf(Z->why, sizeof Z->why, "%.500s", st ? R.ctx.errmsg : mo_contact_last_report(R.D)->message);
      break;
    }
  }
  Z->nc = mo_contact_ncandidates(R.C);
  Z->ndof = R.sc->ndof;
  if (Z->nc <= GMAX && !Z->failed_step) {
    Z->u = malloc((size_t)Z->ndof * sizeof(double));
    if (Z->u) memcpy(Z->u, R.s.u, (size_t)Z->ndof * sizeof(double));
    memcpy(Z->r, mo_contact_reactions(R.D), (size_t)(2 * Z->nc) * sizeof(double));
    memcpy(Z->status, mo_contact_statuses(R.D), (size_t)Z->nc * sizeof(int));
    for (a = 0; a < Z->nc; a++) Z->nslide += Z->status[a] == MO_CS_SLIDE;
  }
  run_free(&R);
  return Z->failed_step || !Z->u ? -1 : 0;
}

static void test_ramp(void)
{
  static const char *amps[2] = {"t", "min(1.0, 2.0 * t)"};
  static const char *reacts[2] = {"concentrated", "weighted"};
  static const char *thr[2] = {"1e-10", "1e-12"};
  static const double tol[2] = {1e-9, 1e-10};
  int ia, ir, it, N;
  for (it = 0; it < 2; it++)
    for (ir = 0; ir < 2; ir++)
      for (ia = 0; ia < 2; ia++) {
        ramp_result Z1, ZN;
        char fails[256] = "", who[128];
        double du_max = 0, dr_max = 0, umax, rmax;
        int len = 0, nfail = 0, stat_ok = 1;
        snprintf(who, sizeof who, "ramp %s, a(t) = %s, threshold_tol = %s", reacts[ir], amps[ia], thr[it]);
        if (ramp_run(amps[ia], 1, reacts[ir], thr[it], &Z1)) {
          ok(0, "%s: the single step converges (%s)", who, Z1.why);
          free(Z1.u);
          continue;
        }
        umax = maxabs(Z1.u, Z1.ndof);
        rmax = maxabs(Z1.r, 2 * Z1.nc);
        for (N = 2; N <= 10; N++) {
          int i;
          if (ramp_run(amps[ia], N, reacts[ir], thr[it], &ZN)) {
            nfail++;
            if (len < (int)sizeof fails - 40)
              len += snprintf(fails + len, sizeof fails - (size_t)len, " N = %d (step %d)", N, ZN.failed_step);
            if (nfail == 1) diag("%s, N = %d: %s", who, N, ZN.why);
            free(ZN.u);
            continue;
          }
          for (i = 0; i < Z1.ndof; i++) du_max = fmax(du_max, fabs(ZN.u[i] - Z1.u[i]));
          for (i = 0; i < 2 * Z1.nc; i++) dr_max = fmax(dr_max, fabs(ZN.r[i] - Z1.r[i]));
          for (i = 0; i < Z1.nc; i++)
            stat_ok &= ia == 0 ? ZN.status[i] == Z1.status[i]
                               : (ZN.status[i] == MO_CS_OPEN) == (Z1.status[i] == MO_CS_OPEN);
          free(ZN.u);
        }
        ok(nfail == 0, "%s: every step of N = 2 .. 10 load steps converges%s%s", who, nfail ? "; failed:" : "", fails);
        ok(nfail == 0 && du_max <= tol[it] * umax && dr_max <= tol[it] * rmax && stat_ok,
           "%s: after N = 2 .. 10 steps the state is the single step's to %.0e (displacements %.1e, reactions "
           "%.1e relative; %s %s; %d sliding)", who, tol[it], du_max / umax, dr_max / rmax,
           ia == 0 ? "statuses" : "open and closed sets", stat_ok ? "equal" : "differ", Z1.nslide);
        free(Z1.u);
      }
}

/* --- 6. option errors and allocation failures ------------------------------------------------------ */

static void test_errors(void)
{
  static const char *sets[] = {"contact.levelset.multipliers=\"p0\""};
  char text[4096];
  run_t R;
  int st;
  snprintf(text, sizeof text, greco_fmt, greco_elements[0], greco_left[0], "levelset", "1.0");
  if (run_open(&R, text, 1, sets, 1)) { ok(0, "p0 scene"); return; }
  st = mo_contact_step(R.D, &R.s, &R.ctx);
  ok(st == MO_EINPUT && strstr(R.ctx.errmsg, "collocation = \"gauss\""),
     "multipliers = p0 with node collocation is refused with a reason: %s", R.ctx.errmsg);
  run_free(&R);
}

static void test_alloc_failures(void)
{
  char text[4096];
  run_t R;
  long before, n, k;
  int st, clean = 1, enomem = 1;
  snprintf(text, sizeof text, greco_fmt, greco_elements[0], greco_left[0], "levelset", "1.0");
  if (run_open(&R, text, 1, NULL, 0)) { ok(0, "alloc scene"); return; }
  /* the allocations of one contact step */
  before = R.ctx.alloc_calls;
  st = mo_contact_step(R.D, &R.s, &R.ctx);
  n = R.ctx.alloc_calls - before;
  run_free(&R);
  ok(!st && n > 0, "GRECO step: %ld allocations through the context", n);
  for (k = 1; k <= n; k++) {
    if (run_open(&R, text, 1, NULL, 0)) { clean = 0; break; }
    R.ctx.alloc_fail_at = R.ctx.alloc_calls + k;
    st = mo_contact_step(R.D, &R.s, &R.ctx);
    if (st != MO_ENOMEM) enomem = 0;
    R.ctx.alloc_fail_at = 0;
    run_free(&R);
  }
  ok(clean && enomem, "every one of the %ld allocations of the step, failing, gives MO_ENOMEM (no crash, no leak under valgrind)", n);
}

int main(void)
{
  test_rods();
  test_greco();
  test_patch();
  test_cycling();
  test_friction_dynamics(2);
  test_friction_dynamics(3);
  test_ramp();
  test_errors();
  test_alloc_failures();
  return done_testing();
}
