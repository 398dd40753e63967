/* test_stepper.c: energy behaviour of the theta-scheme and Newmark on linear free vibration, the
   wave-bar case against d'Alembert under refinement, and What^-1's rigid blocks (diagonal or full
   storage) against the closed-form masses and inertias. */
#include "config.h"
#include <moreau/moreau.h>
#include "tap.h"

static const char *plate =
  "bodies = ( { name = \"plate\";\n"
  "  mesh = { generator = \"rectangle\"; size = [1.0, 0.2]; elements = [6, 2]; };\n"
  "  material = { E = 2.0e11; nu = 0.3; rho = 7800.0; hypothesis = \"plane_stress\"; };\n"
  "  fix = ( { set = \"left\"; } );\n"
  "  initial = { velocity = [\"0.0\", \"x * x\"]; displacement = [\"1e-4 * x\", \"0.0\"]; };\n"
  "} );\n"
  "time = { scheme = \"theta\"; dt = 1e-5; steps = 10000; };\n";

/* Energies over `steps` steps of the plate with the given time settings; returns the largest
   relative drift and whether the energy decreased at every step. */
static int energies(const char *const *sets, int nset, double *drift, int *monotone, double *ratio)
{
  mo_ctx ctx;
  mo_case *cs = NULL;
  mo_scene *sc = NULL;
  mo_stepper *S = NULL;
  mo_state s;
  double *w, e0, eprev, e = 0;
  int k, st;
  mo_ctx_init(&ctx);
  memset(&s, 0, sizeof s);
  st = mo_case_load_string(plate, "plate.cfg", &cs, &ctx);
  for (k = 0; !st && k < nset; k++) st = mo_case_set(cs, sets[k], &ctx);
  if (!st) st = mo_case_validate(cs, &ctx);
  if (!st) st = mo_scene_build(cs, &sc, &ctx);
  if (!st) st = mo_stepper_create(sc, &S, &ctx);
  if (!st) st = mo_state_alloc(sc, &s, &ctx);
  if (!st) st = mo_stepper_init_state(S, &s, &ctx);
  if (st) {
    diag("%s", ctx.errmsg);
    return st;
  }
  w = malloc((size_t)sc->ndof * sizeof *w);
  e0 = eprev = mo_energy_kinetic(sc, &s, w) + mo_energy_elastic(sc, s.u, w);
  *drift = 0;
  *monotone = 1;
  for (k = 0; k < sc->time.steps && !st; k++) {
    st = mo_stepper_step(S, &s, &ctx);
    e = mo_energy_kinetic(sc, &s, w) + mo_energy_elastic(sc, s.u, w);
    if (fabs(e - e0) / e0 > *drift) *drift = fabs(e - e0) / e0;
    if (!(e < eprev)) *monotone = 0;
    eprev = e;
  }
  *ratio = e / e0;
  free(w);
  mo_state_release(&s);
  mo_stepper_free(S);
  mo_scene_free(sc);
  mo_case_free(cs);
  return st;
}

/* Run cases/wave-bar at n elements with dt = L / (n c) (Courant 1); L2 relative error of the tip
   displacement history against d'Alembert. */
static double wave_bar(int n, double theta)
{
  char path[4096], s1[64], s2[64], s3[64], out[256];
  const char *sets[3] = {s1, s2, s3};
  mo_run_options o;
  mo_run_result r;
  mo_ctx ctx;
  int k;
  mo_ctx_init(&ctx);
  ctx.verbosity = 0;
  snprintf(path, sizeof path, "%s/cases/wave-bar", getenv("MOREAU_SRCDIR") ? getenv("MOREAU_SRCDIR") : "..");
  snprintf(s1, sizeof s1, "bodies.bar.mesh.elements=%d", n);
  snprintf(s2, sizeof s2, "time.dt=%.17g", 1.0 / n);
  snprintf(s3, sizeof s3, "time.theta=%g", theta);
  snprintf(out, sizeof out, "tests/out/wave-bar-%d", n);
  memset(&o, 0, sizeof o);
  o.case_path = path;
  o.sets = sets;
  o.nset = 3;
  o.outdir = out;
  if (mo_run(&o, &r, &ctx)) {
    diag("%s", ctx.errmsg);
    return NAN;
  }
  for (k = 0; k < r.nmetric; k++)
    if (!strcmp(r.metric_name[k], "tip.ux")) return r.metric_l2[k];
  return NAN;
}

/* The stepper of a scene text (no contact), or NULL with a diagnostic. */
static mo_stepper *stepper_of(const char *text, mo_case **cs, mo_scene **sc, mo_ctx *ctx)
{
  mo_stepper *S = NULL;
  int st = mo_case_load_string(text, "blocks.cfg", cs, ctx);
  if (!st) st = mo_case_validate(*cs, ctx);
  if (!st) st = mo_scene_build(*cs, sc, ctx);
  if (!st) st = mo_stepper_create(*sc, &S, ctx);
  if (st) diag("%s", ctx->errmsg);
  return st ? NULL : S;
}

/* Largest relative difference between block k of What^-1 and diag(1 / M), exact zeros off the
   diagonal (a non-zero there counts 1). */
static double block_error(const mo_what_inverse *Wi, int k, const double *M)
{
  double A[36], e = 0;
  int nk = Wi->off[k + 1] - Wi->off[k], i, j;
  mo_what_block(Wi, k, A);
  for (i = 0; i < nk; i++)
    for (j = 0; j < nk; j++) {
      double d = i == j ? fabs(A[i * nk + i] * M[i] - 1) : (A[i * nk + j] != 0);
      if (d > e) e = d;
    }
  return e;
}

/* What^-1 of disks and spheres is stored as the blocks' diagonals (doc/theory.md (T70)): the
   blocks, What^-1 b and a sphere's block against m = rho V, I = m R^2 / 2 (disk) and
   2 m R^2 / 5 (sphere); a box of unequal sides keeps full blocks, its sphere the same values. */
static void what_blocks(void)
{
  static const char *disks =
    "bodies = ( { name = \"a\"; type = \"disk\"; center = [0.0, 0.0]; radius = 0.1; density = 1000.0; },\n"
    "  { name = \"b\"; type = \"disk\"; center = [1.0, 0.0]; radius = 0.2; density = 500.0; } );\n"
    "time = { scheme = \"theta\"; dt = 1.0e-3; steps = 1; };\n";
  static const char *spheres =
    "bodies = ( { name = \"s\"; type = \"sphere\"; center = [0.0, 0.0, 0.0]; radius = 0.05; density = 7800.0; } );\n"
    "time = { scheme = \"theta\"; dt = 1.0e-3; steps = 1; };\n";
  static const char *mixed =
    "bodies = ( { name = \"s\"; type = \"sphere\"; center = [0.0, 0.0, 0.0]; radius = 0.05; density = 7800.0; },\n"
    "  { name = \"box\"; type = \"rigid_mesh\"; density = 1000.0;\n"
    "    mesh = { generator = \"box\"; origin = [1.0, 0.0, 0.0]; size = [0.1, 0.2, 0.3]; elements = [1, 1, 1]; }; } );\n"
    "time = { scheme = \"theta\"; dt = 1.0e-3; steps = 1; };\n";
  const double pi = 3.14159265358979323846, ma = 1000 * pi * 0.01, mb = 500 * pi * 0.04;
  const double M2[2][3] = {{ma, ma, ma * 0.01 / 2}, {mb, mb, mb * 0.04 / 2}};
  const double ms = 7800 * 4 * pi * 0.05 * 0.05 * 0.05 / 3, Is = 2 * ms * 0.05 * 0.05 / 5;
  const double M3[6] = {ms, ms, ms, Is, Is, Is};
  double b[6] = {1.0, -2.0, 3.0, -0.5, 0.25, 7.0}, x[6], e = 0, A[36], Af[36];
  mo_ctx ctx;
  mo_case *cs = NULL;
  mo_scene *sc = NULL;
  mo_stepper *S;
  const mo_what_inverse *Wi;
  int k, i, same = 1;

  mo_ctx_init(&ctx);
  if (!(S = stepper_of(disks, &cs, &sc, &ctx))) { ok(0, "two disks: the stepper"); return; }
  Wi = mo_stepper_inverse(S);
  ok(Wi->dinv && !Wi->inv && !Wi->ioff && Wi->nblk == 2, "two disks: What^-1 stores the diagonals only");
  for (k = 0; k < 2; k++) e = fmax(e, block_error(Wi, k, M2[k]));
  ok(e < 1e-15, "two disks: the blocks are diag(1/m, 1/m, 1/I), I = m R^2 / 2 (largest difference %.1e)", e);
  e = 0;
  if (mo_what_solve(Wi, 1, b, x, &ctx)) diag("%s", ctx.errmsg);
  for (i = 0; i < 6; i++) e = fmax(e, fabs(x[i] * M2[i / 3][i % 3] / b[i] - 1));
  ok(e < 1e-15, "two disks: What^-1 b = b_i / M_ii (largest difference %.1e)", e);
  mo_stepper_free(S); mo_scene_free(sc); mo_case_free(cs);

  mo_ctx_init(&ctx);
  if (!(S = stepper_of(spheres, &cs, &sc, &ctx))) { ok(0, "a sphere: the stepper"); return; }
  Wi = mo_stepper_inverse(S);
  e = block_error(Wi, 0, M3);
  ok(Wi->dinv && Wi->nblk == 1 && e < 1e-15, "a sphere: the diagonal diag(1/m Id, 1/I Id), I = 2 m R^2 / 5 (%.1e)", e);
  mo_what_block(Wi, 0, A);
  mo_stepper_free(S); mo_scene_free(sc); mo_case_free(cs);

  mo_ctx_init(&ctx);
  if (!(S = stepper_of(mixed, &cs, &sc, &ctx))) { ok(0, "a sphere and a box: the stepper"); return; }
  Wi = mo_stepper_inverse(S);
  ok(!Wi->dinv && Wi->inv && Wi->nblk == 2, "a sphere and a box of unequal sides: full blocks (the box's turns)");
  mo_what_block(Wi, 0, Af);
  for (i = 0; i < 36; i++) same = same && A[i] == Af[i];
  ok(same, "the sphere's block is the same to the bit in full and diagonal storage");
  mo_stepper_free(S); mo_scene_free(sc); mo_case_free(cs);
}

int main(void)
{
  double drift, ratio, e100, e200, e400;
  int mono;
  {
    const char *s[] = {"time.theta=0.5"};
    ok(energies(s, 1, &drift, &mono, &ratio) == 0, "theta = theta_f = 1/2: 10^4 steps");
    ok(drift < 1e-11, "theta = theta_f = 1/2 conserves energy to round-off (max drift %.2e)", drift);
  }
  {
    const char *s[] = {"time.theta=1.0"};
    ok(energies(s, 1, &drift, &mono, &ratio) == 0, "theta = 1: 10^4 steps");
    ok(mono, "theta = 1 dissipates: energy decreases at every step (final ratio %.6f)", ratio);
    ok(ratio < 0.99, "theta = 1: the dissipation is visible (E/E0 = %.6f)", ratio);
  }
  {
    const char *s[] = {"time.theta=0.5", "time.theta_f=1.0"};
    int st = energies(s, 2, &drift, &mono, &ratio);
    ok(st == 0 && mono, "theta = 1/2, theta_f = 1 (Ben Dhia-Zammali) dissipates (E/E0 = %.6f)", ratio);
  }
  {
    const char *s[] = {"time.scheme=newmark", "time.beta=0.25", "time.gamma=0.5"};
    ok(energies(s, 3, &drift, &mono, &ratio) == 0, "Newmark (1/4, 1/2): 10^4 steps");
    ok(drift < 1e-11, "Newmark (1/4, 1/2) conserves energy (max drift %.2e)", drift);
  }
  {
    const char *s[] = {"time.scheme=newmark", "time.beta=0.3025", "time.gamma=0.6"};
    int st = energies(s, 3, &drift, &mono, &ratio);
    ok(st == 0 && ratio < 1 - 1e-6, "Newmark (0.3025, 0.6) dissipates (E/E0 = %.9f)", ratio);
  }
  e100 = wave_bar(100, 0.5);
  e200 = wave_bar(200, 0.5);
  e400 = wave_bar(400, 0.5);
  ok(e200 < 0.01, "wave-bar, 200 elements, theta = 1/2, Courant 1: tip displacement L2 error %.3e < 1%%", e200);
  ok(e400 < e200 && e200 < e100, "error decreases under refinement: %.3e (100) > %.3e (200) > %.3e (400)",
     e100, e200, e400);
  what_blocks();
  return done_testing();
}
