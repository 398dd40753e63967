/* test_alloc.c: allocation failures injected at every allocation of a whole run (case reading,
   scene, assembly, factorization, contact set, back end, steps; linear and nonlinear steps) end
   in MO_ENOMEM with the message, never a crash; leaks are caught by the sanitizer build and
   valgrind. */
#include "config.h"
#include <moreau/moreau.h>
#include "tap.h"

static const char *scene =
  "bodies = (\n"
  "  { name = \"block\"; mesh = { generator = \"rectangle\"; origin = [0.0, 0.001]; size = [0.02, 0.01]; elements = [4, 2]; };\n"
  "    material = { E = 2.0e11; nu = 0.3; rho = 7800.0; }; initial = { velocity = [1.0, -5.0]; };\n"
  "    body_force = [0.0, -9.81]; },\n"
  "  { name = \"floor\"; type = \"plane\"; point = [0.0, 0.0]; normal = [0.0, 1.0]; }\n"
  ");\n"
  "time = { dt = 1.0e-4; steps = 4; };\n"
  "contact = { solver = \"newmark\"; pairs = ( { slave = \"block\"; slave_set = \"bottom\"; master = \"floor\"; mu = 0.3; } ); };\n"
  "output = { probes = ( { name = \"c\"; set = \"bottom\"; quantities = [\"uy\", \"cy\"]; } ); };\n";

/* A finite-strain J2 block landing at 227 m/s: Newton steps with friction (doc/theory.md §11). */
static const char *nonlinear =
  "bodies = (\n"
  "  { name = \"block\"; mesh = { generator = \"rectangle\"; size = [0.004, 0.004]; elements = [2, 2]; };\n"
  "    material = { model = \"j2\"; E = 1.17e11; nu = 0.35; rho = 8930.0; sigma_y = 4.0e8; Et = 1.0e8; };\n"
  "    initial = { velocity = [0.0, -227.0]; }; },\n"
  "  { name = \"floor\"; type = \"plane\"; point = [0.0, 0.0]; normal = [0.0, 1.0]; }\n"
  ");\n"
  "time = { theta = 0.55; dt = 2.0e-7; steps = 3; };\n"
  "contact = { solver = \"levelset\"; signorini = \"velocity\";\n"
  "  pairs = ( { slave = \"block\"; slave_set = \"bottom\"; master = \"floor\"; mu = 0.25; } ); };\n";

/* The whole pipeline of a run without files; returns the status. */
static int pipeline(const char *text, mo_ctx *ctx, int *steps)
{
  mo_case *cs = NULL;
  mo_scene *sc = NULL;
  mo_contact *C = NULL;
  mo_stepper *S = NULL;
  mo_contact_driver *D = NULL;
  mo_state s;
  int st, k;
  memset(&s, 0, sizeof s);
  *steps = 0;
  st = mo_case_load_string(text, "alloc.cfg", &cs, ctx);
  if (!st) st = mo_case_validate(cs, ctx);
  if (!st && text == scene) st = mo_case_set(cs, "contact.newmark.max_iter=50", ctx);
  if (!st) st = mo_scene_build(cs, &sc, ctx);
  if (!st) st = mo_contact_build(sc, &C, ctx);
  if (!st) st = mo_contact_time_scheme(sc, C, ctx);
  if (!st) st = mo_stepper_create(sc, &S, ctx);
  if (!st) st = mo_contact_driver_create(sc, C, S, &D, ctx);
  if (!st) st = mo_state_alloc(sc, &s, ctx);
  if (!st) st = mo_stepper_init_state(S, &s, ctx);
  for (k = 0; !st && k < sc->time.steps; k++)
    if (!(st = mo_contact_step(D, &s, ctx))) (*steps)++;
  mo_state_release(&s);
  mo_contact_driver_free(D);
  mo_stepper_free(S);
  mo_contact_free(C);
  mo_scene_free(sc);
  mo_case_free(cs);
  return st;
}

static void inject(const char *name, const char *text, int nsteps)
{
  mo_ctx ctx;
  long total, k, bad = 0, msg = 0;
  int steps, st;
  mo_ctx_init(&ctx);
  ctx.verbosity = 0;
  st = pipeline(text, &ctx, &steps);
  total = ctx.alloc_calls;
  ok(st == MO_OK && steps == nsteps, "%s: the pipeline runs without injection (%ld allocations, %d steps) %s", name,
     total, steps, ctx.errmsg);
  for (k = 1; k <= total; k++) {
    mo_ctx_init(&ctx);
    ctx.verbosity = 0;
    ctx.alloc_fail_at = k;
    st = pipeline(text, &ctx, &steps);
    if (st != MO_ENOMEM) {
      bad++;
      if (bad <= 5) diag("allocation %ld: status %d (%s)", k, st, ctx.errmsg);
    } else if (strstr(ctx.errmsg, "out of memory"))
      msg++;
  }
  ok(bad == 0, "%s: every one of the %ld allocations, failing, ends the run with MO_ENOMEM (%ld did not)", name,
     total, bad);
  ok(msg == total, "%s: and the message says out of memory (%ld of %ld)", name, msg, total);
}

int main(void)
{
  inject("linear, newmark", scene, 4);
  inject("finite strains, levelset", nonlinear, 3);
  return done_testing();
}
