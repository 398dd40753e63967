/* levelset_sparse.c: the reduced path of the levelset back end on contact sets too large for dense
   algebra (doc/theory.md §6.4.2, (T137)): W restricted to the contact set is never formed; its
   products come from the Delassus operator's block rows, and the matrix of a frozen status is
   assembled sparse and factored by CHOLMOD (W_XX + eps D) or UMFPACK (coupled sliders), or, dense by
   fill, assembled dense and factored as the reduced path's (T137a). */
#include "config.h"
#include "levelset.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

int ls_dense_max(void)
{
  const char *v = getenv("MOREAU_LEVELSET_DENSE_MAX");
  char *end;
  long n;
  if (!v || !*v) return LS_DENSE_MAX;
  n = strtol(v, &end, 10);
  return *end || n < 0 || n > 1000000000L ? LS_DENSE_MAX : (int)n;
}

double ls_dense_fill(void)
{
  const char *v = getenv("MOREAU_LEVELSET_DENSE_FILL");
  char *end;
  double f;
  if (!v || !*v) return LS_DENSE_FILL;
  f = strtod(v, &end);
  return *end || !(f >= 0) ? LS_DENSE_FILL : f;
}

void ls_sparse_free(ls_sparse *Z)
{
  if (!Z) return;
  mo_linsolver_free(Z->chol);
  mo_linsolver_free(Z->umf);
  mo_csc_free(Z->M);
  mo_free(Z->pos);
  mo_free(Z->x);
  memset(Z, 0, sizeof *Z);
}

/* U' = W_CC y + b over Cset (and the magnitudes of its terms), from W's block rows; eps D on the
   diagonal with the proximal term (T136). */
void ls_sparse_velocity(const ls_system *S, const mo_delassus *W, const double *b, double eps,
                        const double *dW, const double *y, double *U, double *Umag)
{
  const int nr = S->nr, d = S->d;
  int jc, p, i, k;
  for (jc = 0; jc < S->nC; jc++) {
    const int *beta;
    const double *blk = NULL, *wn = NULL;
    int j = S->cset[jc], n = 0;
    double s[3] = {0, 0, 0}, m[3] = {0, 0, 0};
    /* frictionless (one row a contact): W's normal entries alone, contiguous (T164) */
    if (nr == 1) n = mo_delassus_row_normal(W, j, &beta, &wn);
    if (wn) {
      for (p = 0; p < n; p++) {
        int kc = S->cpos[beta[p]];
        double t;
        if (kc < 0) continue;
        t = wn[p] * y[kc];
        s[0] += t;
        m[0] += fabs(t);
      }
      n = 0;
    } else
      n = mo_delassus_row(W, j, &beta, &blk);
    for (p = 0; p < n; p++) {
      int kc = S->cpos[beta[p]];
      if (kc < 0) continue;
      for (i = 0; i < nr; i++)
        for (k = 0; k < nr; k++) {
          double t = blk[(size_t)p * d * d + (size_t)(i * d + k)] * y[kc * nr + k];
          s[i] += t;
          m[i] += fabs(t);
        }
    }
    for (i = 0; i < nr; i++) {
      double t = eps > 0 ? eps * dW[j * d + i] * y[jc * nr + i] : 0;
      U[jc * nr + i] = b[j * d + i] + s[i] + t;
      Umag[jc * nr + i] = fabs(b[j * d + i]) + m[i] + fabs(t);
    }
  }
}

/* U += W_C,e delta: component e's column of W over Cset (W's row, W symmetric). */
static void add_column(const ls_system *S, const mo_delassus *W, double eps, const double *dW, int e,
                       double delta, double *U)
{
  const int nr = S->nr, d = S->d, jc = e / nr, i = e % nr, j = S->cset[jc];
  const int *beta;
  const double *blk = NULL, *wn = NULL;
  int n = 0, p, k;
  if (nr == 1) n = mo_delassus_row_normal(W, j, &beta, &wn);
  if (wn) {
    /* frictionless: the normal entries alone (T164) */
    for (p = 0; p < n; p++) {
      int kc = S->cpos[beta[p]];
      if (kc >= 0) U[kc] += wn[p] * delta;
    }
    n = 0;
  } else
    n = mo_delassus_row(W, j, &beta, &blk);
  for (p = 0; p < n; p++) {
    int kc = S->cpos[beta[p]];
    if (kc < 0) continue;
    for (k = 0; k < nr; k++) U[kc * nr + k] += blk[(size_t)p * d * d + (size_t)(i * d + k)] * delta;
  }
  if (eps > 0) U[e] += eps * dW[j * d + i] * delta;
}

/* The entries of W_XX from W's block rows (the fill of the frozen status's matrix without its
   coupled sliders' columns), without assembling it. */
static double count_fill(const ls_sparse *Z, const ls_reduced *R, const ls_system *S, const mo_delassus *W)
{
  const int nr = S->nr;
  double nnz = 0;
  int b, p, k;
  for (b = 0; b < R->nX; b++) {
    const int *beta;
    const double *blk;
    int e = R->xc[b], cnt = mo_delassus_row(W, S->cset[e / nr], &beta, &blk);
    for (p = 0; p < cnt; p++) {
      int kc = S->cpos[beta[p]];
      if (kc < 0) continue;
      for (k = 0; k < nr; k++) nnz += Z->pos[kc * nr + k] >= 0;
    }
  }
  return nnz;
}

/* Entry (a, b) of the matrix: into the dense column-major A when given, else into T. */
static int put(mo_triplet *T, double *A, int n, int a, int b, double v, mo_ctx *ctx)
{
  if (A) {
    A[(size_t)b * n + a] += v;
    return MO_OK;
  }
  return mo_triplet_add(T, a, b, v, ctx);
}

/* The matrix of the frozen status over X: W_XX (+ eps D), and for the coupled sliders (T134)
   W_XS C_e added to their normals' columns; into the dense column-major n x n matrix A (zeroed
   here) when A is given, else into the CSC *out (both triangles). */
static int assemble(ls_sparse *Z, const ls_reduced *R, const ls_system *S, const mo_delassus *W, double eps,
                    const double *dW, int nks, mo_csc **out, double *A, mo_ctx *ctx)
{
  const int nr = S->nr, d = S->d, n = R->nX;
  mo_triplet T;
  int b, p, k, s, st = MO_OK;
  memset(&T, 0, sizeof T);
  if (A) memset(A, 0, (size_t)n * (size_t)n * sizeof *A);
  else if ((st = mo_triplet_init(&T, n, n, (size_t)n * 9 + 1, ctx))) return st;
  for (b = 0; b < n; b++) {
    int e = R->xc[b], jc = e / nr, i = e % nr, j = S->cset[jc], cnt;
    const int *beta;
    const double *blk;
    cnt = mo_delassus_row(W, j, &beta, &blk);
    for (p = 0; p < cnt; p++) {
      int kc = S->cpos[beta[p]];
      if (kc < 0) continue;
      for (k = 0; k < nr; k++) {
        int a = Z->pos[kc * nr + k];
        double v = blk[(size_t)p * d * d + (size_t)(i * d + k)];
        if (a < 0) continue;
        if (a == b && eps > 0) v += eps * dW[j * d + i];
        if (v != 0 && (st = put(&T, A, n, a, b, v, ctx))) goto done;
      }
    }
  }
  for (s = 0; s < nks; s++) {
    int jc = R->sc[s], j = S->cset[jc], bn = Z->pos[jc * nr], cnt, t;
    const int *beta;
    const double *blk;
    cnt = mo_delassus_row(W, j, &beta, &blk);
    for (p = 0; p < cnt && bn >= 0; p++) {
      int kc = S->cpos[beta[p]];
      if (kc < 0) continue;
      for (k = 0; k < nr; k++) {
        int a = Z->pos[kc * nr + k];
        double v = 0;
        /* W(t(s), x_a) = W(x_a, t(s)), times -mu e_t (T134, T143) */
        for (t = 0; t < S->dt; t++) v += blk[(size_t)p * d * d + (size_t)((1 + t) * d + k)] * -S->mu[j] * R->es[s * S->dt + t];
        if (a >= 0 && v != 0 && (st = put(&T, A, n, a, bn, v, ctx))) goto done;
      }
    }
  }
  if (!A) st = mo_triplet_to_csc(&T, nks == 0, out, ctx);
done:
  if (!A) mo_triplet_release(&T);
  return st;
}

static int same_matrix(const mo_csc *A, const mo_csc *B)
{
  int nnz;
  if (!A || !B || A->nrow != B->nrow || A->ncol != B->ncol || (nnz = mo_csc_nnz(A)) != mo_csc_nnz(B)) return 0;
  return !memcmp(A->p, B->p, ((size_t)A->ncol + 1) * sizeof *A->p) && !memcmp(A->i, B->i, (size_t)nnz * sizeof *A->i) &&
         !memcmp(A->x, B->x, (size_t)nnz * sizeof *A->x);
}

int ls_sparse_step(ls_sparse *Z, ls_reduced *R, const ls_system *S, const mo_delassus *W, double eps,
                   const double *dW, const double *b, const double *U, double *y, double *pg, long *nfact,
                   long *nreuse, int *fallback, mo_ctx *ctx)
{
  const int nr = S->nr, dt = S->dt, nu = R->nu, n = R->nX, offl = nu + S->nM;
  int e, i, s, st, nks = 0;
  mo_csc *M = NULL;
  *fallback = 0;
  if (R->nS > 0 && !R->coupled) {
    /* 3D sliding directions (or the threshold loop in 2D) need W_XS's products with W_XX^-1:
       dense algebra, which this set is too large for */
    *fallback = 1;
    return MO_OK;
  }
  if (!Z->pos || Z->cap < (size_t)nu) {
    int *a = mo_realloc(ctx, Z->pos, ((size_t)nu + 1) * sizeof *a);
    double *x;
    if (!a) return MO_ENOMEM;
    Z->pos = a;
    if (!(x = mo_realloc(ctx, Z->x, (2 * (size_t)nu + 1) * sizeof *x))) return MO_ENOMEM;
    Z->x = x;
    Z->cap = (size_t)nu;
  }
  for (e = 0; e < nu; e++) Z->pos[e] = -1;
  for (i = 0; i < n; i++) Z->pos[R->xc[i]] = i;
  if (R->coupled)
    for (s = 0; s < R->nS; s++) {
      int jc = R->sc[s];
      double G = y[offl + jc * dt] + S->h2_t * U[jc * nr + 1];
      int t;
      if (S->edir)
        for (t = 0; t < dt; t++) R->es[s * dt + t] = S->edir[2 * S->cset[jc] + t];
      else R->es[s] = G > 0 ? 1 : G < 0 ? -1 : 0;
      R->scode[s] = 3 * S->cset[jc] + 1 + (R->es[s * dt] > 0) - (R->es[s * dt] < 0);
      nks++;
    }
  /* dense by fill, not size (T137a): assembled dense and factored as the reduced path's, whose kept
     factor it shares; not even assembled when its key, W and eps say it is the kept one (T162; a 3D
     coupled slider's direction is not in the key) */
  Z->dense = n > 0 && !(dt == 2 && nks > 0) && ls_reduced_kept(R, S, W, nks);
  if (Z->dense) {
    if (R->kind == LS_RED_SINGULAR || (R->kind == LS_RED_PINV && R->normal_null)) {
      *fallback = 2;
      return MO_OK;
    }
    (*nreuse)++;
  } else if ((Z->dense = n > 0 && count_fill(Z, R, S, W) >= ls_dense_fill() * (double)n * (double)n)) {
    double *A;
    int fresh;
    if ((st = ls_reduced_matrix(R, nks, &A, ctx)) || (st = assemble(Z, R, S, W, eps, dW, nks, NULL, A, ctx)) ||
        (st = ls_reduced_factor(R, S, W, nks, &fresh, ctx)))
      return st;
    if (R->kind == LS_RED_SINGULAR || (R->kind == LS_RED_PINV && R->normal_null)) {
      /* redundant normal impulses, or a coupled matrix that friction makes singular */
      *fallback = 2;
      return MO_OK;
    }
    if (fresh) (*nfact)++;
    else (*nreuse)++;
  } else if ((st = assemble(Z, R, S, W, eps, dW, nks, &M, NULL, ctx))) {
    return st;
  } else if (Z->M && Z->kind == (nks > 0) && same_matrix(M, Z->M)) {
    mo_csc_free(M);
    (*nreuse)++;
  } else {
    mo_linsolver **ls = nks ? &Z->umf : &Z->chol;
    mo_csc_free(Z->M);
    Z->M = M;
    Z->kind = nks > 0;
    if (!*ls && (st = mo_linsolver_create(nks ? &mo_linsolver_umfpack : &mo_linsolver_cholmod, ls, ctx))) return st;
    if ((st = mo_linsolver_factor(*ls, M, ctx))) {
      /* singular: redundant impulses without the proximal term, or a coupled matrix that
         friction makes singular */
      mo_csc_free(Z->M);
      Z->M = NULL;
      if (st != MO_ESINGULAR) return st;
      mo_ctx_clear_error(ctx);
      *fallback = 2;
      return MO_OK;
    }
    (*nfact)++;
  }
  /* r': the fixed impulses at 0, the coupled sliders' at -mu e r_n; U' = U + W (r' - r) */
  {
    double *up = Z->x, *bx = Z->x + nu;
    memcpy(up, U, (size_t)nu * sizeof *up);
    for (e = 0, s = 0; e < nu; e++) {
      int jc = e / nr;
      double target, delta;
      if (R->cls[e] == LS_CLS_X) continue;
      if (R->cls[e] == LS_CLS_FIXED) target = 0;
      else {
        while (R->sc[s] != jc) s++;
        target = -S->mu[S->cset[jc]] * R->es[s * dt + (e % nr) - 1] * y[jc * nr];
      }
      delta = target - y[e];
      if (delta == 0) continue;
      add_column(S, W, eps, dW, e, delta, up);
      y[e] = target;
    }
    for (i = 0; i < n; i++) bx[i] = -up[R->xc[i]];
    if (Z->dense) st = ls_reduced_solve(R, S, y, bx, ctx);
    else st = mo_linsolver_solve(nks ? Z->umf : Z->chol, bx, bx, ctx);
    if (st) return st;
    for (i = 0; i < n; i++) y[R->xc[i]] += bx[i];
    for (e = 0, s = 0; e < nu; e++) {
      int jc = e / nr;
      if (R->cls[e] != LS_CLS_SLIDE) continue;
      while (R->sc[s] != jc) s++;
      y[offl + jc * dt + (e % nr) - 1] = R->es[s * dt + (e % nr) - 1];
      y[e] = -S->mu[S->cset[jc]] * R->es[s * dt + (e % nr) - 1] * y[jc * nr];
    }
    if (S->k_n != 0 || S->k_t != 0) ls_sparse_velocity(S, W, b, eps, dW, y, up, bx);
    ls_reduced_multipliers(R, S, up, y, pg);
  }
  return MO_OK;
}
