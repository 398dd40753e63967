/* test_sparse.c: triplet assembly, CSC kernels, CHOLMOD and UMFPACK solves against dense
   references. */
#include "config.h"
#include <moreau/sparse.h>
#include "tap.h"

int main(void)
{
  mo_ctx ctx;
  mo_triplet T;
  mo_csc *A, *B, *C, *AT, *S;
  mo_linsolver *ls;
  double x[5] = {1, -2, 3, 0.5, 4}, y[5], z[5], b[10], X[10];
  int i, j, n = 5, k;
  double dense[25];
  mo_ctx_init(&ctx);
  /* a random SPD tridiagonal-plus matrix assembled with duplicates */
  mo_triplet_init(&T, n, n, 4, &ctx);
  memset(dense, 0, sizeof dense);
  for (i = 0; i < n; i++) {
    mo_triplet_add(&T, i, i, 2.0, &ctx);
    mo_triplet_add(&T, i, i, 2.0 + i, &ctx); /* duplicate: summed */
    dense[i * n + i] += 4.0 + i;
    if (i + 1 < n) {
      mo_triplet_add(&T, i, i + 1, -1.0, &ctx);
      mo_triplet_add(&T, i + 1, i, -1.0, &ctx);
      dense[i * n + i + 1] -= 1;
      dense[(i + 1) * n + i] -= 1;
    }
  }
  mo_triplet_add(&T, 0, 4, 0.5, &ctx);
  mo_triplet_add(&T, 4, 0, 0.5, &ctx);
  dense[4] += 0.5;
  dense[20] += 0.5;
  ok(mo_triplet_to_csc(&T, 1, &A, &ctx) == MO_OK, "triplets converted through CHOLMOD");
  ok(mo_csc_nnz(A) == 5 + 8 + 2, "duplicates summed: %d entries", mo_csc_nnz(A));
  is_close(mo_csc_get(A, 2, 2), 6.0, 0, "summed diagonal entry");
  mo_csc_gaxpy(A, 1, x, 0, y);
  for (i = 0, k = 1; i < n; i++) {
    double s = 0;
    for (j = 0; j < n; j++) s += dense[i * n + j] * x[j];
    if (fabs(s - y[i]) > 1e-14) k = 0;
  }
  ok(k, "A x matches the dense product");
  mo_csc_gatxpy(A, 1, x, 0, z);
  for (i = 0, k = 1; i < n; i++) if (fabs(z[i] - y[i]) > 1e-14) k = 0;
  ok(k, "A^T x equals A x for a symmetric A");
  mo_csc_transpose(A, &AT, &ctx);
  ok(mo_csc_asymmetry(A) == 0 && mo_csc_nnz(AT) == mo_csc_nnz(A), "transpose");
  mo_csc_add(A, AT, 2, -1, &C, &ctx);
  is_close(mo_csc_get(C, 0, 4), 0.5, 1e-15, "2A - A^T = A entrywise");
  {
    int map[5] = {0, -1, 1, 2, -1};
    mo_csc_extract(A, map, 3, map, 3, &S, &ctx);
    ok(S->nrow == 3 && fabs(mo_csc_get(S, 1, 1) - 6) < 1e-15 && mo_csc_get(S, 0, 1) == 0,
       "extract rows/cols 0, 2, 3");
  }
  /* CHOLMOD: two right-hand sides, then a refactorization with the same pattern */
  for (i = 0; i < n; i++) { b[i] = 1.0 + i; b[n + i] = (double)(i * i); }
  ok(mo_linsolver_create(&mo_linsolver_cholmod, &ls, &ctx) == MO_OK && mo_linsolver_factor(ls, A, &ctx) == MO_OK,
     "CHOLMOD factor");
  mo_linsolver_solve_multi(ls, 2, b, X, &ctx);
  mo_csc_gaxpy(A, 1, X, 0, y);
  mo_csc_gaxpy(A, 1, X + n, 0, z);
  for (i = 0, k = 1; i < n; i++) if (fabs(y[i] - b[i]) > 1e-13 || fabs(z[i] - b[n + i]) > 1e-12) k = 0;
  ok(k, "CHOLMOD solves both right-hand sides");
  mo_csc_copy(A, &B, &ctx);
  for (i = 0; i < mo_csc_nnz(B); i++) B->x[i] *= 3;
  mo_linsolver_factor(ls, B, &ctx);
  {
    long nf, ns, nsol;
    mo_linsolver_stats(ls, &nf, &ns, &nsol);
    ok(nf == 2 && ns == 1, "same pattern: one symbolic analysis for two factorizations");
  }
  mo_linsolver_solve(ls, b, X, &ctx);
  mo_csc_gaxpy(B, 1, X, 0, y);
  for (i = 0, k = 1; i < n; i++) if (fabs(y[i] - b[i]) > 1e-12) k = 0;
  ok(k, "solve after refactorization uses the new values");
  mo_linsolver_free(ls);
  /* not positive definite: a clear error */
  for (i = 0; i < mo_csc_nnz(B); i++) B->x[i] = -B->x[i];
  mo_linsolver_create(&mo_linsolver_cholmod, &ls, &ctx);
  ok(mo_linsolver_factor(ls, B, &ctx) == MO_ESINGULAR && strstr(ctx.errmsg, "not positive definite"),
     "indefinite matrix reported: %s", ctx.errmsg);
  mo_ctx_clear_error(&ctx);
  mo_linsolver_free(ls);
  /* UMFPACK on an unsymmetric matrix */
  {
    mo_triplet U;
    mo_csc *N;
    double r[3] = {1, 2, 3}, s[3], t[3];
    mo_triplet_init(&U, 3, 3, 4, &ctx);
    mo_triplet_add(&U, 0, 0, 2, &ctx); mo_triplet_add(&U, 0, 2, 1, &ctx);
    mo_triplet_add(&U, 1, 1, 3, &ctx); mo_triplet_add(&U, 2, 0, -1, &ctx);
    mo_triplet_add(&U, 2, 2, 4, &ctx); mo_triplet_add(&U, 1, 0, 5, &ctx);
    mo_triplet_to_csc(&U, 0, &N, &ctx);
    mo_linsolver_create(&mo_linsolver_umfpack, &ls, &ctx);
    ok(mo_linsolver_factor(ls, N, &ctx) == MO_OK && mo_linsolver_solve(ls, r, s, &ctx) == MO_OK, "UMFPACK factor and solve");
    mo_csc_gaxpy(N, 1, s, 0, t);
    ok(fabs(t[0] - 1) + fabs(t[1] - 2) + fabs(t[2] - 3) < 1e-14, "UMFPACK residual");
    memcpy(t, r, sizeof t);
    mo_linsolver_solve(ls, t, t, &ctx);
    ok(fabs(t[0] - s[0]) + fabs(t[1] - s[1]) + fabs(t[2] - s[2]) == 0, "UMFPACK solves in place");
    mo_linsolver_free(ls);
    mo_csc_free(N);
    mo_triplet_release(&U);
  }
  {
    /* the pattern of two 2x2 blocks kept whatever their values (a block of zeros, a block with
       a zero), then the zeros dropped: what add_block gives (scene.c over MPI ranks) */
    mo_triplet P, Q;
    mo_csc *Pc = NULL, *Qc = NULL;
    int r0[2] = {0, 2}, r1[2] = {2, -1}, same;
    double blk[4] = {1, 0, 0, 3}, blk1[4] = {5, 7, 0, 0};
    mo_triplet_init(&P, 3, 3, 1, &ctx);
    mo_triplet_init(&Q, 3, 3, 1, &ctx);
    mo_triplet_add_pattern(&P, r0, 2, r0, 2, NULL, &ctx);
    mo_triplet_add_pattern(&P, r0, 2, r0, 2, blk, &ctx);
    mo_triplet_add_pattern(&P, r1, 2, r1, 2, blk1, &ctx);
    mo_triplet_add_block(&Q, r0, 2, r0, 2, blk, &ctx);
    mo_triplet_add_block(&Q, r1, 2, r1, 2, blk1, &ctx);
    same = mo_triplet_to_csc(&P, 1, &Pc, &ctx) == MO_OK;
    ok(same && mo_csc_nnz(Pc) == 4 && mo_csc_get(Pc, 0, 2) == 0, "pattern kept with its zeros (4 entries: %d)",
       same ? mo_csc_nnz(Pc) : -1);
    mo_triplet_to_csc(&Q, 1, &Qc, &ctx);
    mo_csc_drop_zeros(Pc);
    same = mo_csc_nnz(Pc) == mo_csc_nnz(Qc) && mo_csc_nnz(Pc) == 2;
    for (i = 0; same && i <= 3; i++) same = Pc->p[i] == Qc->p[i];
    for (i = 0; same && i < 2; i++) same = Pc->i[i] == Qc->i[i] && Pc->x[i] == Qc->x[i];
    ok(same && mo_csc_get(Pc, 0, 0) == 1 && mo_csc_get(Pc, 2, 2) == 8,
       "zeros dropped: the matrix of add_block (entries (0,0) 1 and (2,2) 3 + 5)");
    mo_csc_free(Pc);
    mo_csc_free(Qc);
    mo_triplet_release(&P);
    mo_triplet_release(&Q);
  }
  mo_csc_free(A); mo_csc_free(B); mo_csc_free(C); mo_csc_free(AT); mo_csc_free(S);
  mo_triplet_release(&T);
  return done_testing();
}
