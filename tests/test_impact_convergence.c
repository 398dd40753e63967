/* test_impact_convergence.c: the errors of nscd and levelset against the closed forms of
   rods-1d (doc/architecture.md §11) and bar-obstacle (§2) decrease when h is halved, three halvings, at the
   rates the regularity of the solutions allows; the rates are printed.

   What converges and how fast (measured; the mechanism in brackets):
   - Both solutions have jumps in velocity and strain, kinks in displacement. theta = 1 (the
     paper's scheme on the rods) smears every front over a width w of order sqrt(c^2 h t):
     velocity, strain and contact-stress errors, a jump smeared over w measured in L2, go as
     w^(1/2) = h^(1/4) (measured 0.24-0.29); the energy dissipated goes as w, h^(1/2)
     (measured 0.50), and so does the rebound velocity's deficit, which the displacements
     integrate (measured 0.36-0.50; 0.89 at the free end).
     theta = 1/2 (bar-obstacle) disperses instead of dissipating: a jump spreads over
     (h^2 t)^(1/3), so velocities and stresses go as h^(1/3) (measured 0.33-0.38), and each
     landing loses O(h) of energy (measured 0.96); displacements measured 0.68-0.75. The
     asserted rates are these with a margin; the landing's phase within a step (penetration or
     stand-off of order h |v| / 2) makes single halvings uneven on the bar.
   - Pointwise (L-infinity in time) errors of a velocity or a force do not converge: at a jump
     the discrete history is one step late by the whole jump. They are printed, not asserted.
   - The mesh and the step are halved together at a fixed Courant number (c h / dx = 1.01 on the
     rods, 1 on the bar): halving the step alone converges to the semi-discrete solution, whose
     error against the closed form stays. On bar-obstacle (100 elements, h = 0.02 to 0.0025)
     the errors stall and then grow at the last halving; on rods-1d at the case's 1 mm mesh
     the time error dominates over the paper's steps (1e-5 to 1.25e-6 s), and that chain, the
     paper's refinement, is run as well.
   - The release time is quantized to the step grid: metrics.contact.release_time is the end of
     the first step without reaction. theta = 1 releases within one step of the exact time on
     the rods; theta = 1/2 on the bar oscillates at the release and is 2 to 4 steps late.
   - Velocity-level Signorini never corrects a position: a landing step leaves at most
     (1 - theta) h |U-_n| of penetration (none for theta = 1); that bound is asserted. */
#include "config.h"
#include <moreau/moreau.h>
#include "testlib.h"

#define NLEV 4

enum { PLAIN = 0, ABS = 1, ONE_MINUS = 2 };

typedef struct {
  const char *label;      /* as printed */
  const char *path[3];    /* keys under summary.json: metrics.<path[0]>.<path[1]>..., or energy.<...> */
  int how;                /* PLAIN, ABS (|value|), ONE_MINUS (1 - value: the energy lost) */
  double min_rate;        /* asserted rate log2(e_0 / e_3) / 3; 0: printed only (does not converge) */
} metric;

typedef struct {
  const char *label;
  const char *case_name;
  const char *body[2];     /* bodies whose mesh is refined with the step (NULL: the case's mesh) */
  int n0;                  /* elements per body at the coarsest level */
  double dt0;              /* coarsest step */
  double theta;            /* the case's theta (the penetration bound) */
  const metric *m;
  int nm;
  int release_within_step; /* the release time within two steps of the exact one (else: its
                              error does not grow under refinement and falls by 4 over the
                              chain) */
} chain;

/* rods-1d, theta = 1: displacements h^(1/2), velocities and stresses h^(1/4) */
static const metric rods_metrics[] = {
  {"u L2(0,T;L2)", {"field", "u_l2l2_rel"}, PLAIN, 0.4},
  {"u Linf(0,T;L2)", {"field", "u_linfl2_rel"}, PLAIN, 0.3},
  {"u L2(0,T;H1)", {"field", "u_l2h1_rel"}, PLAIN, 0.15},
  {"v L2(0,T;L2)", {"field", "v_l2l2_rel"}, PLAIN, 0.15},
  {"v Linf(0,T;L2)", {"field", "v_linfl2_rel"}, PLAIN, 0.15},
  {"contact-end u L2(0,T)", {"cend.ux", "l2_rel"}, PLAIN, 0.3},
  {"contact-end v L2(0,T)", {"cend.vx", "l2_rel"}, PLAIN, 0.15},
  {"contact stress L2(0,T)", {"cend.pn", "l2_rel"}, PLAIN, 0.15},
  {"free-end u L2(0,T)", {"free.ux", "l2_rel"}, PLAIN, 0.4},
  {"free-end v L2(0,T)", {"free.vx", "l2_rel"}, PLAIN, 0.15},
  {"impulse error", {"contact", "impulse_error"}, ABS, 0.4},
  {"energy lost 1 - E(T)/E0", {"@energy", "ratio"}, ONE_MINUS, 0.4},
  {"contact-end v Linf(0,T)", {"cend.vx", "linf_rel"}, PLAIN, 0},
  {"contact stress Linf(0,T)", {"cend.pn", "linf_rel"}, PLAIN, 0},
  {"free-end v Linf(0,T)", {"free.vx", "linf_rel"}, PLAIN, 0},
};

/* bar-obstacle, theta = 1/2: displacements h^(2/3), velocities and stresses h^(1/3) */
static const metric obstacle_metrics[] = {
  {"u L2(0,T;L2)", {"field", "u_l2l2_rel"}, PLAIN, 0.5},
  {"u Linf(0,T;L2)", {"field", "u_linfl2_rel"}, PLAIN, 0.5},
  {"u L2(0,T;H1)", {"field", "u_l2h1_rel"}, PLAIN, 0.25},
  {"v L2(0,T;L2)", {"field", "v_l2l2_rel"}, PLAIN, 0.25},
  {"v Linf(0,T;L2)", {"field", "v_linfl2_rel"}, PLAIN, 0.25},
  {"end u L2(0,T)", {"end.ux", "l2_rel"}, PLAIN, 0.5},
  {"end v L2(0,T)", {"end.vx", "l2_rel"}, PLAIN, 0.25},
  {"contact stress L2(0,T)", {"end.pn", "l2_rel"}, PLAIN, 0.25},
  {"contact force L2(0,T)", {"end.cx", "l2_rel"}, PLAIN, 0.25},
  {"impulse error", {"contact", "impulse_error"}, ABS, 0.5},
  {"energy lost 1 - E(T)/E0", {"@energy", "ratio"}, ONE_MINUS, 0.7},
  {"end v Linf(0,T)", {"end.vx", "linf_rel"}, PLAIN, 0},
  {"contact stress Linf(0,T)", {"end.pn", "linf_rel"}, PLAIN, 0},
};

static const chain chains[] = {
  /* c h / dx = 5063.7 * 5e-6 * 40 = 1.01; the impact at 50 us on every grid */
  {"rods-1d, mesh and step", "rods-1d", {"left", "right"}, 40, 5e-6, 1, rods_metrics, MO_COUNT(rods_metrics), 1},
  /* the paper's refinement: the step alone, on the case's 1000 elements per rod */
  {"rods-1d, step alone", "rods-1d", {NULL, NULL}, 0, 1e-5, 1, rods_metrics, MO_COUNT(rods_metrics), 1},
  /* c h / dx = 1: 25 elements and h = 0.04 to 200 and 0.005, T = 12 (four periods) */
  {"bar-obstacle, mesh and step", "bar-obstacle", {"bar", NULL}, 25, 0.04, 0.5, obstacle_metrics,
   MO_COUNT(obstacle_metrics), 0},
};

static const char *solvers[] = {"nscd", "levelset"};

/* A number in summary.json: root.metrics.path[0].path[1] (a path starting with '@' from the
   root instead); NaN when absent. */
static double summary_value(json_t *root, const char *const path[3])
{
  if (path[0][0] == '@') return tl_jnum(root, path[0] + 1, path[1], path[2], NULL);
  return tl_jnum(root, "metrics", path[0], path[1], path[2], NULL);
}

static double metric_value(json_t *root, const metric *m)
{
  double v = summary_value(root, m->path);
  return m->how == ABS ? fabs(v) : m->how == ONE_MINUS ? 1 - v : v;
}

/* Run one level of a chain; the summary comes back parsed (NULL on failure). */
static json_t *run_level(const chain *ch, const char *solver, int level, double *wall)
{
  char path[4096], out[512], sets[4][128], who[256];
  const char *setp[4];
  mo_run_result res;
  json_t *root = NULL;
  int nset = 0, b, st;
  double dt = ch->dt0 / (1 << level);
  tl_case_path(path, sizeof path, ch->case_name);
  snprintf(out, sizeof out, "tests/out/conv-%s-%s-%d-%ld", ch->case_name, solver, level, (long)getpid());
  snprintf(sets[nset++], sizeof sets[0], "time.dt=%.17g", dt);
  for (b = 0; b < 2 && ch->body[b]; b++)
    snprintf(sets[nset++], sizeof sets[0], "bodies.%s.mesh.elements=%d", ch->body[b], ch->n0 << level);
  for (b = 0; b < nset; b++) setp[b] = sets[b];
  snprintf(who, sizeof who, "%s, %s, h = %g", ch->label, solver, dt);
  st = tl_run(path, solver, setp, nset, out, who, &res);
  *wall = res.wall;
  if (!st) root = tl_summary(out);
  tl_remove_dir(out);
  return root;
}

/* One chain with one back end: assertions per metric; the values go to val[metric][level]. */
static void check_chain(const chain *ch, const char *solver, double val[][NLEV])
{
  json_t *root[NLEV];
  int lev, k, ran = 1;
  double wall = 0, w;
  for (lev = 0; lev < NLEV; lev++) {
    root[lev] = run_level(ch, solver, lev, &w);
    wall += w;
    ran &= root[lev] != NULL;
  }
  if (!ok(ran, "%s, %s: the four runs complete (%.2f s)", ch->label, solver, wall)) {
    for (lev = 0; lev < NLEV; lev++) json_decref(root[lev]);
    return;
  }
  for (k = 0; k < ch->nm; k++) {
    const metric *m = &ch->m[k];
    double *e = val[k], rate[NLEV - 1], overall;
    int dec = 1;
    char line[256];
    for (lev = 0; lev < NLEV; lev++) e[lev] = metric_value(root[lev], m);
    for (lev = 0; lev + 1 < NLEV; lev++) {
      rate[lev] = log2(e[lev] / e[lev + 1]);
      dec &= e[lev + 1] < e[lev];
    }
    overall = log2(e[0] / e[NLEV - 1]) / (NLEV - 1);
    snprintf(line, sizeof line, "%.4g %.4g %.4g %.4g, rates %.2f %.2f %.2f", e[0], e[1], e[2], e[3], rate[0], rate[1],
             rate[2]);
    if (m->min_rate > 0)
      ok(dec && overall >= m->min_rate, "%s, %s: %s decreases at every halving, rate %.2f >= %.2f (%s)", ch->label,
         solver, m->label, overall, m->min_rate, line);
    else
      diag("%s, %s: %s (a jump in time: does not converge pointwise): %s", ch->label, solver, m->label, line);
  }
  {
    /* penetration: at most (1 - theta) h |U-_n| per landing, velocity-level Signorini */
    int good = 1;
    char line[256] = "";
    for (lev = 0; lev < NLEV; lev++) {
      const char *pp[3] = {"contact", "max_penetration", NULL}, *pv[3] = {"contact", "velocity_scale", NULL};
      double pen = summary_value(root[lev], pp), vs = summary_value(root[lev], pv), h = ch->dt0 / (1 << lev);
      double bound = (1 - ch->theta) * h * vs;
      good &= pen <= bound * (1 + 1e-9) + 1e-15;
      snprintf(line + strlen(line), sizeof line - strlen(line), "%s%.3g <= %.3g", lev ? ", " : "", pen, bound);
    }
    ok(good, "%s, %s: penetration within (1 - theta) h max|U_n| at every level (%s)", ch->label, solver, line);
  }
  {
    const char *pr[3] = {"contact", "release_time_error", NULL};
    double r[NLEV];
    int good = 1;
    for (lev = 0; lev < NLEV; lev++) r[lev] = summary_value(root[lev], pr);
    if (ch->release_within_step) {
      /* metrics.contact.release_time is the end of the first step without reaction: one step
         of resolution on top of the step in which the scheme releases */
      for (lev = 0; lev < NLEV; lev++) good &= fabs(r[lev]) <= 2 * ch->dt0 / (1 << lev) * (1 + 1e-9);
      ok(good, "%s, %s: release time within two steps of 444.968 us (errors %.3g %.3g %.3g %.3g s: %.2f %.2f %.2f %.2f steps)",
         ch->label, solver, r[0], r[1], r[2], r[3], r[0] / ch->dt0, r[1] / (ch->dt0 / 2), r[2] / (ch->dt0 / 4),
         r[3] / (ch->dt0 / 8));
    } else {
      for (lev = 0; lev + 1 < NLEV; lev++) good &= fabs(r[lev + 1]) <= fabs(r[lev]) + 1e-9;
      ok(good && fabs(r[NLEV - 1]) <= fabs(r[0]) / 4,
         "%s, %s: release time error never grows and falls by 4 over the chain (%.3g %.3g %.3g %.3g; "
         "steps late: %.0f %.0f %.0f %.0f)",
         ch->label, solver, r[0], r[1], r[2], r[3], r[0] / ch->dt0, r[1] / (ch->dt0 / 2), r[2] / (ch->dt0 / 4),
         r[3] / (ch->dt0 / 8));
    }
  }
  for (lev = 0; lev < NLEV; lev++) json_decref(root[lev]);
}

int main(void)
{
  static double val[2][MO_COUNT(rods_metrics)][NLEV];
  size_t c, k;
  int s, lev;
  mo_ctx ctx;
  mo_ctx_init(&ctx);
  mo_mkdir_p("tests/out", &ctx);
  for (c = 0; c < MO_COUNT(chains); c++) {
    const chain *ch = &chains[c];
    double worst = 0;
    for (s = 0; s < 2; s++) check_chain(ch, solvers[s], val[s]);
    /* one candidate: nscd and levelset solve the same scalar complementarity problem */
    for (k = 0; k < (size_t)ch->nm; k++)
      for (lev = 0; lev < NLEV; lev++) {
        double a = val[0][k][lev], b = val[1][k][lev], d;
        if (a == b) continue;
        d = fabs(a - b) / (fabs(a) > fabs(b) ? fabs(a) : fabs(b));
        if (!(d <= worst)) worst = d;
      }
    ok(worst <= 1e-8, "%s: nscd and levelset agree on every error at every level (largest relative difference %.1e)",
       ch->label, worst);
  }
  return done_testing();
}
