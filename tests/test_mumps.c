/* test_mumps.c: MUMPS's Schur path (doc/theory.md (T180)): on small scenes (H8 boxes on a plane
   and on a box, 2D Q4 and T3 blocks, concentrated and weighted reactions, friction), the Delassus
   operator built from MUMPS's Schur complement on the contact dofs (G = S^-1, no solve per
   column) equals the one from CHOLMOD's trailing block to 1e-12 of its largest entry, and the
   correction What^-1 H r (whole solves through the Schur complement) equals CHOLMOD's split one.
   PETSc builds only (one rank: PETSc 3.18 has no Schur complement over several). */
#include "config.h"
#include "testlib.h"

#include <math.h>

/* One side: the scene (CHOLMOD's or PETSc's linear solver), its contact, the stepper with the
   contact dofs last, W. */
typedef struct {
  mo_case *cs;
  mo_scene *sc;
  mo_contact *C;
  mo_stepper *S;
  mo_delassus *D;
  mo_state s;
} side;

static void side_free(side *X)
{
  mo_delassus_free(X->D);
  mo_stepper_free(X->S);
  mo_state_release(&X->s);
  mo_contact_free(X->C);
  mo_scene_free(X->sc);
  mo_case_free(X->cs);
  memset(X, 0, sizeof *X);
}

static int side_open(side *X, const char *name, const char *text, mo_ctx *ctx)
{
  int st;
  memset(X, 0, sizeof *X);
  st = tl_scene(text, name, &X->cs, &X->sc, ctx);
  if (!st) st = mo_contact_build(X->sc, &X->C, ctx);
  if (!st) st = mo_stepper_create_contact(X->sc, X->C, 1, &X->S, ctx);
  if (!st) st = mo_delassus_create(&X->D, ctx);
  if (!st) st = mo_state_alloc(X->sc, &X->s, ctx);
  if (!st) st = mo_stepper_init_state(X->S, &X->s, ctx);
  if (!st) st = mo_contact_geometry(X->C, &X->s, 0, 1, ctx);
  return st;
}

static void check_scene(const char *name, const char *text, mo_ctx *ctx)
{
  side X[2];
  char ptext[4200];
  double *W[2] = {NULL, NULL}, *r = NULL, *dx[2] = {NULL, NULL};
  int k, m = 0, n, i, nlast[2];
  unsigned long seed = 4242;
  double wmax, wd, cmax, cd;
  snprintf(ptext, sizeof ptext, "linear_solver = { type = \"petsc\"; };\n%s", text);
  memset(X, 0, sizeof X);
  for (k = 0; k < 2; k++)
    if (side_open(&X[k], name, k ? ptext : text, ctx)) {
      ok(0, "%s: set-up (%s): %s", name, k ? "MUMPS" : "CHOLMOD", ctx->errmsg);
      goto done;
    }
  for (k = 0; k < 2; k++) {
    const mo_csc *H = mo_contact_H(X[k].C);
    int rebuilt;
    m = H->ncol;
    mo_stepper_contact_dofs(X[k].S, &nlast[k]);
    if (mo_delassus_update(X[k].D, H, mo_contact_h_version(X[k].C), mo_stepper_inverse(X[k].S), 1.0,
                           mo_contact_dim(X[k].C), &rebuilt, ctx) ||
        mo_delassus_dense(X[k].D, &W[k], ctx)) {
      ok(0, "%s: W (%s): %s", name, k ? "MUMPS" : "CHOLMOD", ctx->errmsg);
      goto done;
    }
  }
  wmax = maxabs(W[0], m * m);
  wd = maxdiff(W[0], W[1], m * m);
  ok(mo_delassus_from_schur(X[0].D) && mo_delassus_from_schur(X[1].D) && nlast[1] == nlast[0] && nlast[1] > 0 &&
         !mo_stepper_split_ready(X[1].S),
     "%s: W from MUMPS's Schur complement on %d contact dofs (no split solves)", name, nlast[1]);
  ok(wmax > 0 && wd <= 1e-12 * wmax, "%s: W (%d x %d) from MUMPS's Schur complement = CHOLMOD's trailing block: "
     "max |dW| = %.3g of max |W| = %.3g", name, m, m, wd, wmax);
  {
    /* MUMPS took CHOLMOD's order with the contact dofs last (PERM_IN, INFOG(7) = 1, (T183)) */
    mo_linsolver_info I[2];
    char want[128];
    memset(I, 0, sizeof I);
    for (k = 0; k < 2; k++) mo_linsolver_info_get(mo_stepper_solver(X[k].S), &I[k]);
    snprintf(want, sizeof want, "%s, given to mumps (INFOG(7) = 1)", I[0].ordering ? I[0].ordering : "?");
    ok(I[1].ordering && !strcmp(I[1].ordering, want), "%s: MUMPS factors in CHOLMOD's order: '%s' (CHOLMOD: '%s')", name,
       I[1].ordering ? I[1].ordering : "?", I[0].ordering ? I[0].ordering : "?");
  }
  /* the correction What^-1 H r: whole solves (MUMPS) against the split ones (CHOLMOD) */
  n = mo_contact_H(X[0].C)->nrow;
  r = malloc((size_t)m * sizeof *r);
  dx[0] = malloc((size_t)n * sizeof *dx[0]);
  dx[1] = malloc((size_t)n * sizeof *dx[1]);
  if (!r || !dx[0] || !dx[1]) {
    ok(0, "%s: memory", name);
    goto done;
  }
  for (i = 0; i < m; i++) {
    seed = seed * 6364136223846793005UL + 1442695040888963407UL;
    r[i] = (double)(seed >> 11) / (double)(1UL << 53) * 2 - 1;
  }
  for (k = 0; k < 2; k++)
    if (mo_delassus_apply_Cinv(X[k].D, mo_contact_H(X[k].C), mo_stepper_inverse(X[k].S), r, dx[k], ctx)) {
      ok(0, "%s: correction (%s): %s", name, k ? "MUMPS" : "CHOLMOD", ctx->errmsg);
      goto done;
    }
  cmax = maxabs(dx[0], n);
  cd = maxdiff(dx[0], dx[1], n);
  ok(cmax > 0 && cd <= 1e-12 * cmax, "%s: What^-1 H r by MUMPS's whole solves = CHOLMOD's split ones: max diff %.3g of %.3g",
     name, cd, cmax);
done:
  mo_ctx_clear_error(ctx);
  free(r);
  for (k = 0; k < 2; k++) {
    free(W[k]);
    free(dx[k]);
    side_free(&X[k]);
  }
}

int main(int argc, char **argv)
{
  mo_ctx ctx;
  char text[4096];
  mo_ctx_init(&ctx);
  ctx.verbosity = 0;
  if (!mo_parallel_available()) {
    printf("1..0 # SKIP this build has no PETSc (configure --with-petsc)\n");
    return 0;
  }
  if (mo_parallel_start(&argc, &argv, &ctx)) {
    printf("1..1\nnot ok 1 - MPI starts: %s\n", ctx.errmsg);
    return 1;
  }
  snprintf(text, sizeof text, tl_box_3d, "");
  check_scene("3D H8 on a plane, concentrated", text, &ctx);
  snprintf(text, sizeof text, tl_box_3d, "reactions = \"weighted\"; mu = 0.3;");
  check_scene("3D H8 on a plane, weighted reactions, friction", text, &ctx);
  check_scene("3D H8 on H8 (mesh master)", tl_boxes_3d, &ctx);
  snprintf(text, sizeof text, tl_block_2d, "Q4", "plane_strain", "scheme = \"theta\"; dt = 1.0e-5; steps = 1;", "mu = 0.3;");
  check_scene("2D Q4 plane strain, concentrated, friction", text, &ctx);
  snprintf(text, sizeof text, tl_block_2d, "T3", "plane_strain", "scheme = \"theta\"; dt = 1.0e-5; steps = 1;",
           "reactions = \"weighted\";");
  check_scene("2D T3, weighted reactions", text, &ctx);
  printf("1..%d\n", tap_n);
  mo_parallel_finish(&ctx);
  return tap_failed != 0;
}
