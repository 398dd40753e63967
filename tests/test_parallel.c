/* test_parallel.c: the PETSc linear-solver type on one or more MPI ranks against CHOLMOD on the
   same matrices (doc/parallel.md §2), and the collective calls. Run alone, or under mpirun by
   tests/test_mpi.sh; every rank checks, rank 0 prints. */
#include "config.h"
#include <moreau/parallel.h>
#include <moreau/sparse.h>
#include "tap.h"

/* A 2D Laplacian on an nx x ny grid plus a mass-like diagonal: SPD, with the pattern of a
   stiffness matrix (rows coupled across the ranks' row blocks). */
static mo_csc *laplacian(int nx, int ny, double shift, mo_ctx *ctx)
{
  mo_triplet T;
  mo_csc *A = NULL;
  int i, j, n = nx * ny;
  mo_triplet_init(&T, n, n, (size_t)5 * n, ctx);
  for (j = 0; j < ny; j++)
    for (i = 0; i < nx; i++) {
      int a = j * nx + i;
      mo_triplet_add(&T, a, a, 4 + shift * (1 + 0.1 * (a % 7)), ctx);
      if (i + 1 < nx) {
        mo_triplet_add(&T, a, a + 1, -1, ctx);
        mo_triplet_add(&T, a + 1, a, -1, ctx);
      }
      if (j + 1 < ny) {
        mo_triplet_add(&T, a, a + nx, -1, ctx);
        mo_triplet_add(&T, a + nx, a, -1, ctx);
      }
    }
  mo_triplet_to_csc(&T, 1, &A, ctx);
  mo_triplet_release(&T);
  return A;
}

/* max |x - y| / max |y| */
static double rel(const double *x, const double *y, long n)
{
  double d = 0, m = 0;
  long k;
  for (k = 0; k < n; k++) {
    if (fabs(x[k] - y[k]) > d) d = fabs(x[k] - y[k]);
    if (fabs(y[k]) > m) m = fabs(y[k]);
  }
  return m > 0 ? d / m : d;
}

static int agree_all(int pass, mo_ctx *ctx)
{
  double f = pass ? 0 : 1;
  mo_par_max(&f, 1, ctx);
  return f == 0;
}

static void solver_checks(mo_ctx *ctx, const char *ksp, const char *pc, double tol)
{
  mo_csc *A = laplacian(23, 17, 0.5, ctx), *A2 = laplacian(23, 17, 2.0, ctx);
  int n = A->nrow, k, nrhs = 3;
  double *B = malloc(sizeof(double) * n * nrhs), *X = malloc(sizeof(double) * n * nrhs),
         *Y = malloc(sizeof(double) * n * nrhs);
  mo_linsolver *chol = NULL, *ps = NULL;
  mo_linsolver_settings set = {ksp, pc, "mumps", "", 1e-13, 1};
  long nf = 0, ns = 0;
  for (k = 0; k < n * nrhs; k++) B[k] = sin(0.37 * k) + (k % 5 == 0);
  mo_linsolver_create(&mo_linsolver_cholmod, &chol, ctx);
  mo_linsolver_factor(chol, A, ctx);
  mo_linsolver_solve_multi(chol, nrhs, B, Y, ctx);
  ok(mo_linsolver_create(mo_linsolver_petsc(ctx), &ps, ctx) == MO_OK && mo_linsolver_configure(ps, &set, ctx) == MO_OK,
     "petsc %s/%s: created on %d rank(s)", ksp, pc, ctx->nranks);
  ok(agree_all(mo_linsolver_factor(ps, A, ctx) == MO_OK, ctx), "petsc %s/%s: factored (%s)", ksp, pc, ctx->errmsg);
  ok(agree_all(mo_linsolver_solve_multi(ps, nrhs, B, X, ctx) == MO_OK, ctx), "petsc %s/%s: solved", ksp, pc);
  {
    double e = rel(X, Y, (long)n * nrhs);
    ok(agree_all(e < tol, ctx), "petsc %s/%s: 3 solutions equal CHOLMOD's to %.1e (tol %.0e)", ksp, pc, e, tol);
  }
  /* new values on the same pattern: the symbolic analysis kept, the answer the new matrix's */
  mo_linsolver_factor(chol, A2, ctx);
  mo_linsolver_solve_multi(chol, 1, B, Y, ctx);
  {
    int done = agree_all(mo_linsolver_factor(ps, A2, ctx) == MO_OK && mo_linsolver_solve(ps, B, X, ctx) == MO_OK, ctx);
    double e = rel(X, Y, n);
    ok(done && agree_all(e < tol, ctx), "petsc %s/%s: refactored with new values, solution equal to CHOLMOD's to %.1e",
       ksp, pc, e);
  }
  mo_linsolver_stats(ps, &nf, NULL, &ns);
  ok(nf == 2 && ns == 4, "petsc %s/%s: 2 factorizations, 4 right-hand sides counted (%ld, %ld)", ksp, pc, nf, ns);
  mo_linsolver_free(ps);
  mo_linsolver_free(chol);
  mo_csc_free(A);
  mo_csc_free(A2);
  free(B);
  free(X);
  free(Y);
}

int main(int argc, char **argv)
{
  mo_ctx ctx;
  mo_ctx_init(&ctx);
  if (!mo_parallel_available()) {
    printf("1..0 # SKIP this build has no PETSc (configure --with-petsc)\n");
    return 0;
  }
  if (mo_parallel_start(&argc, &argv, &ctx)) {
    printf("1..1\nnot ok 1 - MPI starts: %s\n", ctx.errmsg);
    return 1;
  }
  /* rank 0 speaks for all: each check above is agreed over the ranks */
  if (ctx.rank != 0 && !freopen("/dev/null", "w", stdout)) return 1;
  {
    double x[2] = {1.0 + ctx.rank, -(double)ctx.rank};
    int n[64], r;
    double all[64];
    mo_par_sum(x, 2, &ctx);
    ok(x[0] == ctx.nranks + ctx.nranks * (ctx.nranks - 1) / 2.0 && x[1] == -ctx.nranks * (ctx.nranks - 1) / 2.0,
       "sum over %d rank(s)", ctx.nranks);
    for (r = 0; r < ctx.nranks && r < 64; r++) n[r] = 1;
    x[0] = 10.0 * ctx.rank;
    mo_par_gatherv(x, n, all, &ctx);
    for (r = 0; r < ctx.nranks && r < 64; r++)
      if (all[r] != 10.0 * r) break;
    ok(r == ctx.nranks, "gather of one value per rank in rank order");
    ok(mo_par_agree(ctx.rank == ctx.nranks - 1 ? MO_EIO : MO_OK, &ctx) == MO_EIO &&
           (ctx.nranks == 1 || ctx.rank == ctx.nranks - 1 || strstr(ctx.errmsg, "rank")),
       "a status of one rank reaches every rank (%s)", ctx.errmsg);
    mo_ctx_clear_error(&ctx);
  }
  solver_checks(&ctx, "preonly", "cholesky", 1e-12);
  solver_checks(&ctx, "preonly", "lu", 1e-12);
  solver_checks(&ctx, "cg", "jacobi", 1e-9);
  printf("1..%d\n", tap_n);
  mo_parallel_finish(&ctx);
  return tap_failed != 0;
}
