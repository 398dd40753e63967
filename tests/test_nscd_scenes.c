/* test_nscd_scenes.c: nscd on whole scenes: Jean's four GRECO tables (J88 Figs. 3-4, the
   decoded tables of shared/data/greco), a mass dropped on a plane (impact on the grid step, no
   rebound), and a block on an incline (stick below tan(theta) = mu, sliding above it with the
   exact acceleration). */
#include "config.h"
#include <moreau/moreau.h>
#include "testlib.h"

/* Run a case (a path, or the text itself when path is NULL) with overrides into
   tests/out/nscd-<tag>-<pid>; 0 on success. */
static int run_case(const char *path, const char *text, const char *tag, const char **sets, int nset, char *outdir,
                    size_t n)
{
  snprintf(outdir, n, "tests/out/nscd-%s-%ld", tag, (long)getpid());
  return path ? tl_run(path, NULL, sets, nset, outdir, tag, NULL) : tl_run_text(text, outdir, tag, NULL);
}

/* --- Jean's GRECO tables ---------------------------------------------------------------------- */

typedef struct {
  const char *example, *reactions;
  int sweeps;                  /* Jean's sweep count (IS) */
  double Rx, Ry;               /* printed resultants (shared/data/greco/README.md) */
} greco;

static const greco tables[4] = {
  {"jean-mu1", "concentrated", 62, -1.1691e6, 1.8583e6},
  {"jean-mu1", "weighted", 85, -1.1729e6, 1.8946e6},
  {"jean-mu01", "concentrated", 42, -1.9286e5, 1.9286e6},
  {"jean-mu01", "weighted", 146, -1.9483e5, 1.9483e6},
};

/* The decoded table's D2 at node 7 of the mu = 1 weighted example reads -1.18140e-08. With
   weighted reactions the law holds on the cell's mean gap (P* D2)_h = (D2_h-1 + 6 D2_h +
   D2_h+1) / 8, which vanishes on closed cells up to Jean's convergence; Jean's own neighbours
   make (P* D2)_7 and (P* D2)_8 an order of magnitude smaller with +1.18140e-08: a minus sign the
   decoding added (README: others were lost). The comparison uses the corrected sign, after
   checking this argument on Jean's numbers. */
static double jean_d2_fix(const tl_table *J, int row0, int check)
{
  int c = tl_col(J, "D2_m");
  double d6 = tl_num(J, row0 + 5, c), d7 = tl_num(J, row0 + 6, c), d8 = tl_num(J, row0 + 7, c), d9 = tl_num(J, row0 + 8, c);
  double a_as = fabs(d6 + 6 * d7 + d8), a_fix = fabs(d6 - 6 * d7 + d8);
  double b_as = fabs(d7 + 6 * d8 + d9), b_fix = fabs(-d7 + 6 * d8 + d9);
  if (check)
    ok(d7 < 0 && a_fix < 0.1 * a_as && b_fix < 0.5 * b_as,
       "mu = 1 weighted, node 7: Jean's D2 = %.5e makes the weighted gaps of cells 7, 8 %.2e, %.2e; with the "
       "opposite sign %.2e, %.2e (a sign lost in decoding)", d7, a_as / 8, b_as / 8, a_fix / 8, b_fix / 8);
  return -d7;
}

/* Compare a run's contact.csv with Jean's table; returns the worst deviation over the
   tolerance (1 = at the limit). */
static double compare_table(const tl_table *J, const greco *G, const tl_table *R, const char *what, int check_fix)
{
  static const char *jc[4] = {"D1_m", "D2_m", "RT_N_per_m", "RN_N_per_m"}, *rc[4] = {"D1", "D2", "RT", "RN"};
  int rows[16], nrow = 0, i, k, status_ok = 1, weighted = !strcmp(G->reactions, "weighted");
  double worst = 0, Rx = 0, Ry = 0, colworst[4] = {0, 0, 0, 0};
  int worstrow[4] = {0, 0, 0, 0};
  for (i = 0; i < J->nrow && nrow < 16; i++)
    if (!strcmp(J->cell[i][tl_col(J, "example")], G->example) && !strcmp(J->cell[i][tl_col(J, "reactions")], G->reactions))
      rows[nrow++] = i;
  if (nrow != 16 || R->nrow != 16) {
    ok(0, "%s %s %s: 16 rows in both tables (%d, %d)", G->example, G->reactions, what, nrow, R->nrow);
    return INFINITY;
  }
  for (k = 0; k < 4; k++) {
    double mx = 0;
    int cj = tl_col(J, jc[k]), cr = tl_col(R, rc[k]);
    for (i = 0; i < 16; i++)
      if (isfinite(tl_num(J, rows[i], cj)) && fabs(tl_num(J, rows[i], cj)) > mx) mx = fabs(tl_num(J, rows[i], cj));
    if (mx == 0) continue;
    for (i = 0; i < 16; i++) {
      double want = tl_num(J, rows[i], cj), got = tl_num(R, i, cr), lim, e;
      if (!isfinite(want)) continue;                                   /* a value the text lost */
      if (k == 1 && i == 6 && weighted && !strcmp(G->example, "jean-mu1")) want = jean_d2_fix(J, rows[0], check_fix);
      lim = (weighted && k >= 2 && (i == 0 || i == 15) ? 5e-3 : 1e-3) * mx;
      e = fabs(got - want) / lim;
      if (!(e <= colworst[k])) { colworst[k] = e; worstrow[k] = i + 1; }
    }
    if (colworst[k] > worst || isnan(colworst[k])) worst = colworst[k];
  }
  for (i = 0; i < 16; i++) {
    if (strcmp(J->cell[rows[i]][tl_col(J, "status")], R->cell[i][tl_col(R, "status")])) status_ok = 0;
    Rx += tl_num(R, i, tl_col(R, "RT"));    /* frame (n, t) = (e_y, e_x) on the plane y = 0 */
    Ry += tl_num(R, i, tl_col(R, "RN"));
  }
  {
    char msg[4][48];
    for (k = 0; k < 4; k++) {
      if (worstrow[k]) snprintf(msg[k], sizeof msg[k], "%s %.2f at node %d", rc[k], colworst[k], worstrow[k]);
      else snprintf(msg[k], sizeof msg[k], "%s: the text lost this column", rc[k]);
    }
    ok(worst <= 1, "%s %s, %s: every D1, D2, RT, RN within tolerance of Jean's table (worst/tolerance: %s, %s, %s, %s)",
       G->example, G->reactions, what, msg[0], msg[1], msg[2], msg[3]);
  }
  ok(status_ok, "%s %s, %s: statuses identical to Jean's", G->example, G->reactions, what);
  ok(fabs(Rx - G->Rx) <= 5e-4 * fabs(G->Rx) && fabs(Ry - G->Ry) <= 5e-4 * fabs(G->Ry),
     "%s %s, %s: Rx = %.5g, Ry = %.5g (Jean: %.5g, %.5g) to 4 significant digits", G->example, G->reactions, what,
     Rx, Ry, G->Rx, G->Ry);
  return worst;
}

/* The "equivalent weighted" column of Jean's mu = 1 concentrated table (J88 Fig. 3, first table,
   last column "Whei. reac.", the RT component; decoded from the seed's text: that column is not
   shifted, unlike RT and RN): the P^-1 images of the concentrated reactions, nodes 1-7. Nodes
   1-5 are open (r = 0) and Jean prints non-zero values there: rho = (P*^T)^-1 r is not zero on
   open nodes, it satisfies (P*^T rho)_h = r_h = 0 there (P*'s rows [3/4 1/4], [1/8 3/4 1/8] ...),
   so rho_2 = -6 rho_1, rho_3 = -6 rho_2 - 2 rho_1, rho_h+1 = -6 rho_h - rho_h-1 (doc/theory.md
   (T81)): |rho| grows by about 3 + 2 sqrt(2) per node toward the first closed node. Jean's replayed run must give his numbers (to 0.5 %: his reactions are
   those of his 1e-4 iterate, printed to 5 digits), and the recurrence must hold to round-off. */
static void jean_equivalent_weighted(const tl_table *R)
{
  static const double jean[7] = {3.3656, -20.209, 114.43, -666.38, 3883.9, -22637, -89416};
  int i, ct = tl_col(R, "RT_other"), cn = tl_col(R, "RN_other"), open = 1;
  double worst = 0, rec = 0, mx = 0, x[16];
  for (i = 0; i < 7; i++) {
    double got = tl_num(R, i, ct), e = fabs(got - jean[i]) / fabs(jean[i]);
    if (!(e <= worst)) worst = e;
  }
  for (i = 0; i < 5; i++)
    if (strcmp(R->cell[i][tl_col(R, "status")], "open") || tl_num(R, i, tl_col(R, "RT")) != 0 ||
        tl_num(R, i, tl_col(R, "RN")) != 0)
      open = 0;
  ok(open && worst <= 5e-3,
     "mu = 1 concentrated, Jean's run replayed: the equivalent weighted RT of nodes 1-7 (nodes 1-5 open, r = 0) are "
     "Jean's printed %.5g, %.5g, %.5g, %.5g, %.5g, %.5g, %.5g within %.2f %% (moreau: %.5g, %.5g, %.5g, %.5g, %.5g, "
     "%.5g, %.5g)", jean[0], jean[1], jean[2], jean[3], jean[4], jean[5], jean[6], 100 * worst, tl_num(R, 0, ct),
     tl_num(R, 1, ct), tl_num(R, 2, ct), tl_num(R, 3, ct), tl_num(R, 4, ct), tl_num(R, 5, ct), tl_num(R, 6, ct));
  for (i = 0; i < 16; i++) x[i] = tl_num(R, i, ct);
  for (i = 0; i < 16; i++) mx = fmax(mx, fabs(x[i]));
  /* columns of P* (ends = dual): (3/4, 1/8), (1/4, 3/4, 1/8), then (1/8, 3/4, 1/8) */
  rec = fmax(fabs(0.75 * x[0] + 0.125 * x[1]), fabs(0.25 * x[0] + 0.75 * x[1] + 0.125 * x[2]));
  for (i = 2; i < 5; i++) rec = fmax(rec, fabs(0.125 * x[i - 1] + 0.75 * x[i] + 0.125 * x[i + 1]));
  for (i = 0; i < 16; i++) x[i] = tl_num(R, i, cn);
  rec = fmax(rec, fmax(fabs(0.75 * x[0] + 0.125 * x[1]), fabs(0.25 * x[0] + 0.75 * x[1] + 0.125 * x[2])));
  for (i = 2; i < 5; i++) rec = fmax(rec, fabs(0.125 * x[i - 1] + 0.75 * x[i] + 0.125 * x[i + 1]));
  ok(rec <= 1e-9 * mx, "the open nodes' equivalent weighted reactions are the exact P^-1 images of r = 0 there: "
     "(P*^T rho)_h = 0 for h = 1..5 to %.1e of max |rho| = %.4g (T81)", rec / mx, mx);
}

static void test_greco(void)
{
  const char *src = getenv("MOREAU_SRCDIR"), *shared = getenv("MOREAU_SHARED");
  char path[1024], csv[1100], out[1024], cases[2][1024];
  tl_table J, conc01, R;
  int k, st;
  if (!src || !shared) {
    ok(1, "# SKIP MOREAU_SRCDIR and MOREAU_SHARED are needed");
    return;
  }
  snprintf(path, sizeof path, "%s/data/greco/jean-1988-tables.csv", shared);
  if (access(path, R_OK)) {
    ok(1, "# SKIP no shared data (%s)", path);
    return;
  }
  if (tl_table_read(path, &J)) {
    ok(0, "read %s", path);
    return;
  }
  snprintf(cases[0], sizeof cases[0], "%s/cases/greco-jean-mu1", src);
  snprintf(cases[1], sizeof cases[1], "%s/cases/greco-jean-mu01", src);
  memset(&conc01, 0, sizeof conc01);
  for (k = 0; k < 4; k++) {
    const greco *G = &tables[k];
    const char *cs = cases[!strcmp(G->example, "jean-mu01")];
    char react[64], sweeps[64];
    const char *replay[] = {react, "nscd.stop=sweeps", sweeps};
    const char *conv[] = {react};
    snprintf(react, sizeof react, "contact.reactions=%s", G->reactions);
    snprintf(sweeps, sizeof sweeps, "nscd.max_sweeps=%d", G->sweeps);
    /* Jean's run replayed: natural order from r = 0, his number of sweeps */
    st = run_case(cs, NULL, "greco", replay, 3, out, sizeof out);
    snprintf(csv, sizeof csv, "%s/contact.csv", out);
    if (st || tl_table_read(csv, &R)) { ok(0, "%s %s: run", G->example, G->reactions); continue; }
    compare_table(&J, G, &R, "Jean's run replayed", 1);
    if (k == 0) jean_equivalent_weighted(&R);
    tl_table_free(&R);
    tl_remove_dir(out);
    /* converged (the case as shipped) */
    st = run_case(cs, NULL, "greco", conv, 1, out, sizeof out);
    snprintf(csv, sizeof csv, "%s/contact.csv", out);
    if (st || tl_table_read(csv, &R)) { ok(0, "%s %s: run", G->example, G->reactions); continue; }
    if (!strcmp(G->reactions, "concentrated")) compare_table(&J, G, &R, "converged", 0);
    else {
      /* Jean's weighted tables stop short of convergence (he asked 1e-4 of the reactions), so the
         converged run is held to what must hold exactly: his resultants, his statuses, and for
         the fully sliding mu = 0.1 example his remark that both computations coincide through P */
      int i, same = 1, cs_ = tl_col(&R, "status");
      double Rx = 0, Ry = 0, e = 0, mx = 0;
      for (i = 0; i < R.nrow; i++) {
        Rx += tl_num(&R, i, tl_col(&R, "RT"));
        Ry += tl_num(&R, i, tl_col(&R, "RN"));
      }
      for (i = 0; i < 16; i++) {
        int ji, found = 0;
        for (ji = 0; ji < J.nrow; ji++)
          if (!strcmp(J.cell[ji][0], G->example) && !strcmp(J.cell[ji][1], G->reactions) && atoi(J.cell[ji][2]) == i + 1) {
            found = 1;
            if (strcmp(J.cell[ji][tl_col(&J, "status")], R.cell[i][cs_])) same = 0;
          }
        if (!found) same = 0;
      }
      ok(same, "%s weighted, converged: statuses identical to Jean's", G->example);
      ok(fabs(Rx - G->Rx) <= 5e-4 * fabs(G->Rx) && fabs(Ry - G->Ry) <= 5e-4 * fabs(G->Ry),
         "%s weighted, converged: Rx = %.5g, Ry = %.5g (Jean: %.5g, %.5g) to 4 significant digits", G->example, Rx, Ry, G->Rx, G->Ry);
      if (!strcmp(G->example, "jean-mu01") && conc01.nrow == 16) {
        for (i = 0; i < 16; i++) {
          e = fmax(e, fabs(tl_num(&R, i, tl_col(&R, "RN")) - tl_num(&conc01, i, tl_col(&conc01, "RN_other"))));
          e = fmax(e, fabs(tl_num(&R, i, tl_col(&R, "RT")) - tl_num(&conc01, i, tl_col(&conc01, "RT_other"))));
          e = fmax(e, 1e11 * fabs(tl_num(&R, i, tl_col(&R, "D1")) - tl_num(&conc01, i, tl_col(&conc01, "D1"))));
          mx = fmax(mx, fabs(tl_num(&R, i, tl_col(&R, "RN"))));
        }
        ok(e <= 1e-6 * mx, "mu = 0.1, full sliding: the weighted reactions are the P^-1 images of the concentrated "
           "ones and the displacements are the same (J88 §4.5; difference %.2e of %.3e)", e, mx);
      }
    }
    if (!strcmp(G->example, "jean-mu01") && !strcmp(G->reactions, "concentrated")) conc01 = R;
    else tl_table_free(&R);
    tl_remove_dir(out);
  }
  tl_table_free(&conc01);
  tl_table_free(&J);
}

/* --- a mass dropped on a plane ------------------------------------------------------------------

   A stiff square (E = 1e12, 0.1 m, 10 kg per unit thickness) falls under g = 10 from rest, with
   theta = 1 (the implicit scheme stops the internal vibration within a step, so the square acts
   as a rigid mass at impact). The scheme's free fall is exact in velocity, v_k = -g t_k, and
   reaches u_k = -g h^2 k (k + 1) / 2.
   Position level: from H = g h^2 N (N + 1) / 2 the gap closes exactly at t_N; Signorini on
   the end-of-step gap then stops the mass in the next step (impulse m g t_N + m g h), with no
   rebound and the weight carried ever after.
   Velocity level (doc/theory.md §5): a candidate enters the index set in the step whose
   end-of-step gap, predicted without contact, is not positive. From H = g h^2 N^2 / 2 the
   prediction at step N is -g h^2 N / 2, well clear of round-off: the mass stops in step N
   (impulse m g t_N), where it was at t_N-1, and the gap g h^2 N / 2 it had then stays open (a
   velocity-level scheme never corrects a position; the error is O(h)).
   Either way the impact is perfectly inelastic: the contact impulses take all the work the
   weight did on the way down. */
static void test_drop(const char *signorini)
{
  const int N = 20, steps = 40, vel = !strcmp(signorini, "velocity");
  const double g = 10, h = 1e-3, m = 10;
  const double H = vel ? g * h * h * N * N / 2 : g * h * h * N * (N + 1) / 2;
  /* the step that stops the mass, where it rests, and the gap it rests at */
  const int K = vel ? N : N + 1;
  const double u_rest = vel ? -g * h * h * N * (N - 1) / 2 : -H, gap_rest = H + u_rest;
  char text[2048], out[1024], csv[1100];
  tl_table T;
  int i, cu, cv, cg, cf, ctv, early = 0, rebound = 0;
  /* velocity-level Signorini never corrects a position: the free flight's round-off (1e-9 H)
     stays in the gap */
  const double ptol = vel ? 1e-8 * H : 1e-9 * H;
  double worst_gap = 0, worst_v = 0, worst_f = 0, f_imp, u_K;
  snprintf(text, sizeof text,
           "bodies = (\n"
           "  { name = \"mass\"; mesh = { generator = \"rectangle\"; origin = [0.0, %#.17g]; size = [0.1, 0.1]; elements = [1, 1]; };\n"
           "    material = { E = 1.0e12; nu = 0.3; rho = 1000.0; }; body_force = [0.0, %#.17g]; },\n"
           "  { name = \"floor\"; type = \"plane\"; point = [0.0, 0.0]; normal = [0.0, 1.0]; }\n"
           ");\n"
           "time = { scheme = \"theta\"; theta = 1.0; dt = %#.17g; steps = %d; };\n"
           "contact = { signorini = \"%s\"; pairs = ( { slave = \"mass\"; slave_set = \"bottom\"; master = \"floor\"; } );\n"
           "            nscd = { tol = 1.0e-12; }; };\n"
           "output = { precision = 17; probes = ( { name = \"bot\"; set = \"bottom\"; quantities = [\"uy\", \"vy\", \"gn\"]; },\n"
           "                                     { name = \"top\"; set = \"top\"; quantities = [\"vy\"]; } ); };\n",
           H, -g, h, steps, signorini);
  if (run_case(NULL, text, "drop", NULL, 0, out, sizeof out)) { ok(0, "drop: run"); return; }
  snprintf(csv, sizeof csv, "%s/history.csv", out);
  tl_table_read(csv, &T);
  cu = tl_col(&T, "bot.uy");
  cv = tl_col(&T, "bot.vy");
  cg = tl_col(&T, "bot.gn");
  ctv = tl_col(&T, "top.vy");
  cf = tl_col(&T, "contact.force_n");
  for (i = 1; i < N; i++) {
    if (tl_num(&T, i, cg) <= 0 || tl_num(&T, i, cf) != 0) early++;
    if (fabs(tl_num(&T, i, cv) + g * i * h) > 1e-8 * g * i * h) early++;
  }
  diag("drop, %s-level Signorini", signorini);
  ok(!early, "free fall: v = -g t exactly at every step before t_N = %g s, gap open, no contact force", N * h);
  if (!vel) {
    u_K = tl_num(&T, N, cu);
    ok(fabs(u_K + H) <= ptol && fabs(tl_num(&T, N, cf)) <= 1e-6 * m * g && fabs(tl_num(&T, N + 1, cu) + H) <= ptol,
       "the gap closes at t_N: u = %.12g (H = %.12g), contact force %.2e N (round-off)", u_K, -H, tl_num(&T, N, cf));
  } else {
    u_K = tl_num(&T, K, cu);
    ok(fabs(u_K - u_rest) <= ptol && fabs(tl_num(&T, K - 1, cf)) <= 1e-6 * m * g,
       "the candidate enters the index set in step %d (predicted gap -g h^2 N / 2) and the mass stays at "
       "u = %.12g (u_N-1 = %.12g)", K, u_K, u_rest);
  }
  f_imp = tl_num(&T, K, cf);
  ok(fabs(f_imp - m * g * K) <= 1e-5 * m * g * K, "the mass stops in one step: impulse / h = %.8g N "
     "(m g %d = %g: the impact impulse m g t_%d plus the weight)", f_imp, K, m * g * K, K - 1);
  for (i = K; i <= steps; i++) {
    worst_gap = fmax(worst_gap, fabs(tl_num(&T, i, cg) - gap_rest));
    worst_v = fmax(worst_v, fmax(fabs(tl_num(&T, i, cv)), fabs(tl_num(&T, i, ctv))));
    if (tl_num(&T, i, cv) > 1e-9 || tl_num(&T, i, ctv) > 1e-5 * g * N * h) rebound++;
    if (i > K + 2) worst_f = fmax(worst_f, fabs(tl_num(&T, i, cf) - m * g));
  }
  ok(!rebound && worst_gap <= ptol && worst_v <= 1e-5 * g * N * h,
     "no rebound: after impact the gap stays %.3g m to %.1e m and the velocities %.1e m/s (impact speed %g m/s)",
     gap_rest, worst_gap, worst_v, g * (K - 1) * h);
  ok(worst_f <= 1e-6 * m * g, "resting: the contact force is the weight m g = %g N (largest difference %.1e N)", m * g, worst_f);
  tl_table_free(&T);
  {
    /* energy: the weight does m g |u_rest|, the contact impulses take it all */
    json_t *sum = tl_summary(out);
    double wc = tl_jnum(sum, "energy", "contact_work", NULL), wx = tl_jnum(sum, "energy", "external_work", NULL);
    double w = -m * g * u_rest;
    json_decref(sum);
    ok(fabs(wx - w) <= 1e-6 * w && fabs(wc + w) <= 1e-5 * w,
       "perfectly inelastic impact: external work %.9g J = m g |u_rest| = %.9g J, contact work %.9g J", wx, w, wc);
  }
  tl_remove_dir(out);
}

/* --- a block on an incline ----------------------------------------------------------------------

   The plane stays y = 0 and gravity is tilted by theta: g (sin theta, -cos theta). mu = 0.5.
   Below tan(theta) = mu the block sticks: its velocity vanishes once the elastic settling is
   over and the friction force is m g sin theta. Above, the centroid accelerates at
   g (sin theta - mu cos theta); the total friction impulse is mu times the normal one, so the
   velocity reached is exact whatever the settling. E = 1e8 keeps the two contacts' tangential
   coupling away from rigid (Gauss-Seidel converges at a rate set by the body's flexibility). */
static void test_incline(double tan_theta)
{
  const double g = 10, mu = 0.5, h = 1e-3, m = 10, th = atan(tan_theta), a = g * (sin(th) - mu * cos(th));
  const int steps = 100;
  char text[2048], out[1024], csv[1100];
  tl_table T;
  int cvx, cux, ccx, cf, i;
  double T_end = steps * h;
  snprintf(text, sizeof text,
           "bodies = (\n"
           "  { name = \"block\"; mesh = { generator = \"rectangle\"; size = [0.1, 0.1]; elements = [1, 1]; };\n"
           "    material = { E = 1.0e8; nu = 0.3; rho = 1000.0; }; body_force = [%#.17g, %#.17g]; },\n"
           "  { name = \"slope\"; type = \"plane\"; point = [0.0, 0.0]; normal = [0.0, 1.0]; }\n"
           ");\n"
           "time = { scheme = \"theta\"; theta = 1.0; dt = %#.17g; steps = %d; };\n"
           "contact = { pairs = ( { slave = \"block\"; slave_set = \"bottom\"; master = \"slope\"; mu = %#.17g; } );\n"
           "            nscd = { tol = 1.0e-10; max_sweeps = 100000; }; };\n"
           "output = { precision = 17; probes = ( { name = \"all\"; set = \"all\"; quantities = [\"ux\", \"vx\"]; },\n"
           "                                     { name = \"bot\"; set = \"bottom\"; quantities = [\"cx\"]; } ); };\n",
           g * sin(th), -g * cos(th), h, steps, mu);
  if (run_case(NULL, text, "incline", NULL, 0, out, sizeof out)) { ok(0, "incline: run"); return; }
  snprintf(csv, sizeof csv, "%s/history.csv", out);
  tl_table_read(csv, &T);
  cvx = tl_col(&T, "all.vx");
  cux = tl_col(&T, "all.ux");
  ccx = tl_col(&T, "bot.cx");
  cf = tl_col(&T, "contact.force_n");
  if (tan_theta < mu) {
    double vmax = 0, drift = fabs(tl_num(&T, steps, cux) - tl_num(&T, steps / 2, cux));
    for (i = steps / 2; i <= steps; i++) vmax = fmax(vmax, fabs(tl_num(&T, i, cvx)));
    ok(vmax <= 1e-9 && drift <= 1e-12, "tan(theta) = %.2f < mu = %.2f: the block sticks (|v| <= %.1e m/s, drift %.1e m over "
       "the second half; without friction it would have slid %.2e m)", tan_theta, mu, vmax, drift, 0.5 * g * sin(th) * T_end * T_end);
    ok(fabs(tl_num(&T, steps, ccx) + m * g * sin(th)) <= 1e-8 * m * g && fabs(tl_num(&T, steps, cf) - m * g * cos(th)) <= 1e-8 * m * g,
       "sticking: friction %.10g N = -m g sin(theta), normal %.10g N = m g cos(theta)", tl_num(&T, steps, ccx), tl_num(&T, steps, cf));
  } else {
    double v = tl_num(&T, steps, cvx), vh = tl_num(&T, steps / 2, cvx);
    ok(fabs(v - a * T_end) <= 1e-6 * a * T_end, "tan(theta) = %.2f > mu = %.2f: the block slides, v(T) = %.10g m/s = "
       "g (sin - mu cos) T = %.10g", tan_theta, mu, v, a * T_end);
    ok(fabs((v - vh) / (T_end / 2) - a) <= 1e-6 * a, "sliding: acceleration over the second half %.10g m/s^2 "
       "(exact %.10g)", (v - vh) / (T_end / 2), a);
    ok(fabs(tl_num(&T, steps, ccx) + mu * tl_num(&T, steps, cf)) <= 1e-8 * m * g, "sliding: friction %.10g N = -mu x normal",
       tl_num(&T, steps, ccx));
  }
  tl_table_free(&T);
  tl_remove_dir(out);
}

int main(void)
{
  test_greco();
  test_drop("position");
  test_drop("velocity");
  test_incline(0.4);
  test_incline(0.6);
  return done_testing();
}
