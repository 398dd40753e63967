/* test_alloc.c: allocation failures injected at every allocation of a whole run (case reading,
   scene, assembly, factorization, contact set, back end, steps) end in MO_ENOMEM with the
   message, never a crash; leaks are caught by the sanitizer build and valgrind. */
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

/* The whole pipeline of a run without files; returns the status. */
static int pipeline(mo_ctx *ctx, int *steps)
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
  st = mo_case_load_string(scene, "alloc.cfg", &cs, ctx);
  if (!st) st = mo_case_validate(cs, ctx);
  if (!st) st = mo_case_set(cs, "contact.newmark.max_iter=50", ctx);
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

int main(void)
{
  mo_ctx ctx;
  long total, k, bad = 0, msg = 0;
  int steps, st;
  mo_ctx_init(&ctx);
  ctx.verbosity = 0;
  st = pipeline(&ctx, &steps);
  total = ctx.alloc_calls;
  ok(st == MO_OK && steps == 4, "the pipeline runs without injection (%ld allocations, %d steps) %s", total, steps, ctx.errmsg);
  for (k = 1; k <= total; k++) {
    mo_ctx_init(&ctx);
    ctx.verbosity = 0;
    ctx.alloc_fail_at = k;
    st = pipeline(&ctx, &steps);
    if (st != MO_ENOMEM) {
      bad++;
      if (bad <= 5) diag("allocation %ld: status %d (%s)", k, st, ctx.errmsg);
    } else if (strstr(ctx.errmsg, "out of memory"))
      msg++;
  }
  ok(bad == 0, "every one of the %ld allocations, failing, ends the run with MO_ENOMEM (%ld did not)", total, bad);
  ok(msg == total, "and the message says out of memory (%ld of %ld)", msg, total);
  return done_testing();
}
