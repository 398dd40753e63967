/* levelset_linalg.c: the two linear-algebra paths of the levelset back end (doc/theory.md §6.4):
   the Schur complement on the contact set with the shared factorization (through W), and the
   saddle-point system over the free dofs solved by UMFPACK. */
#include "config.h"
#include "levelset.h"

#include <math.h>
#include <string.h>

extern void dgetrf_(const int *m, const int *n, double *a, const int *lda, int *ipiv, int *info);
extern void dgetrs_(const char *trans, const int *n, const int *nrhs, const double *a, const int *lda,
                    const int *ipiv, double *b, const int *ldb, int *info);
extern void dgecon_(const char *norm, const int *n, const double *a, const int *lda, const double *anorm,
                    double *rcond, double *work, int *iwork, int *info);
extern void dgelsy_(const int *m, const int *n, const int *nrhs, double *a, const int *lda, double *b,
                    const int *ldb, int *jpvt, const double *rcond, int *rank, double *work,
                    const int *lwork, int *info);

/* The minimum-norm least-squares solution of a singular J x = b (J column-major, overwritten) by
   LAPACK's complete orthogonal factorization (dgelsy: QR with column pivoting, rank where the
   condition estimate of R passes 1e14; on these small systems cheaper than the SVD solver
   dgelsd, the same solution to round-off): redundant constraints (two points of one edge on an
   edge, both sticking, leave the tangential impulses non-unique) have many solutions, all giving
   the same velocities; this one is the smallest. */
static int min_norm_solve(int n, double *J, double *b, int *rank, mo_ctx *ctx)
{
  int nrhs = 1, info = 0, lwork = -1, *jpvt = NULL;
  double rcond = 1e-14, wq = 0, *work = NULL;
  dgelsy_(&n, &n, &nrhs, J, &n, b, &n, &info, &rcond, rank, &wq, &lwork, &info);
  lwork = (int)wq + 1;
  jpvt = mo_calloc(ctx, (size_t)n + 1, sizeof *jpvt);
  work = mo_malloc(ctx, (size_t)lwork * sizeof *work);
  if (!jpvt || !work) {
    mo_free(jpvt); mo_free(work);
    return MO_ENOMEM;
  }
  dgelsy_(&n, &n, &nrhs, J, &n, b, &n, jpvt, &rcond, rank, work, &lwork, &info);
  mo_free(jpvt); mo_free(work);
  if (info != 0)
    return mo_error(ctx, MO_ESINGULAR, "levelset: the frozen-status system is singular and its complete "
                    "orthogonal factorization failed (LAPACK dgelsy info %d)", info);
  return MO_OK;
}

/* The LU factors (into S, pivots piv) of J scaled to unit rows and columns, S = R^-1 J C^-1 with
   rs, cs the rows' and columns' largest magnitudes (1 for an empty one), and the reciprocal
   condition number of S (1-norm estimate): the scales of the unknowns (impulses, pressures,
   semi-multipliers) and of the equations differ by orders of magnitude, so the condition of J
   itself says little; scaled, a redundant system (rank-deficient whatever the units) stands out
   from an ill-scaled one. The same factors solve J x = b as x = C^-1 S^-1 R^-1 b: one LU for the
   test and the solve. 0 when S is exactly singular, -1 when out of memory. */
static double scaled_lu(int n, const double *A, double *S, int *piv, double *rs, double *cs, mo_ctx *ctx)
{
  double *w4 = mo_malloc(ctx, (4 * (size_t)n + 1) * sizeof *w4);
  int *iw = mo_malloc(ctx, ((size_t)n + 1) * sizeof *iw);
  double rc = -1, anorm = 0;
  int i, j, info = 0;
  if (!w4 || !iw) goto done;
  rc = 1;
  memcpy(S, A, (size_t)n * (size_t)n * sizeof *S);
  for (j = 0; j < n; j++) { /* columns (column-major) */
    double c = 0;
    for (i = 0; i < n; i++) c = fmax(c, fabs(S[(size_t)j * n + i]));
    cs[j] = c > 0 ? c : 1;
    for (i = 0; c > 0 && i < n; i++) S[(size_t)j * n + i] /= c;
  }
  for (i = 0; i < n; i++) { /* then rows */
    double r = 0;
    for (j = 0; j < n; j++) r = fmax(r, fabs(S[(size_t)j * n + i]));
    rs[i] = r > 0 ? r : 1;
    for (j = 0; r > 0 && j < n; j++) S[(size_t)j * n + i] /= r;
  }
  for (j = 0; j < n; j++) {
    double csum = 0;
    for (i = 0; i < n; i++) csum += fabs(S[(size_t)j * n + i]);
    anorm = fmax(anorm, csum);
  }
  dgetrf_(&n, &n, S, &n, piv, &info);
  if (info > 0) rc = 0;
  else if (info == 0) dgecon_("1", &n, S, &n, &anorm, &rc, w4, iw, &info);
done:
  mo_free(w4); mo_free(iw);
  return rc;
}

/* x = C^-1 S^-1 R^-1 b in place, with the LU factors of S = R^-1 J C^-1. */
static int scaled_solve(int n, const double *S, const int *piv, const double *rs, const double *cs,
                        double *b)
{
  int nrhs = 1, info = 0, i;
  for (i = 0; i < n; i++) b[i] /= rs[i];
  dgetrs_("N", &n, &nrhs, S, &n, piv, b, &n, &info);
  for (i = 0; i < n; i++) b[i] /= cs[i];
  return info;
}

void ls_lu_cache_free(ls_lu_cache *C)
{
  if (!C) return;
  mo_free(C->key);
  mo_free(C->lu);
  mo_free(C->piv);
  mo_free(C->rs);
  mo_free(C->cs);
  C->key = C->lu = C->rs = C->cs = NULL;
  C->piv = NULL;
  C->cap = 0;
  C->valid = 0;
}

static int finite_or_error(int n, const double *b, mo_ctx *ctx)
{
  int i;
  for (i = 0; i < n; i++)
    if (!isfinite(b[i]))
      return mo_error(ctx, MO_ENAN, "levelset: the frozen-status system gave a non-finite value "
                      "(unknown %d of %d)", i, n);
  return MO_OK;
}

int ls_lu_lookup(ls_lu_cache *C, int n, const double *J, double *b, int *hit, mo_ctx *ctx)
{
  int info = 0;
  *hit = 0;
  if (!C || !C->valid || C->n != n || n == 0 ||
      memcmp(C->key, J, (size_t)n * (size_t)n * sizeof *J) != 0)
    return MO_OK;
  if ((info = scaled_solve(n, C->lu, C->piv, C->rs, C->cs, b)) != 0)
    return mo_error(ctx, MO_EINTERNAL, "levelset: dgetrs argument %d", -info);
  C->reuses++;
  *hit = 1;
  return finite_or_error(n, b, ctx);
}

/* Keep the row-major matrix J (before the transposition), the LU factors of its scaled transpose
   and the scales. */
static int lu_store(ls_lu_cache *C, int n, const double *key, const double *lu, const int *ipiv,
                    const double *rs, const double *cs, mo_ctx *ctx)
{
  size_t nn = (size_t)n * (size_t)n;
  if (nn + 1 > C->cap) {
    double *a = mo_realloc(ctx, C->key, (nn + 1) * sizeof *a);
    if (!a) return MO_ENOMEM;
    C->key = a;
    if (!(a = mo_realloc(ctx, C->lu, (nn + 1) * sizeof *a))) return MO_ENOMEM;
    C->lu = a;
    if (!(a = mo_realloc(ctx, C->rs, ((size_t)n + 1) * sizeof *a))) return MO_ENOMEM;
    C->rs = a;
    if (!(a = mo_realloc(ctx, C->cs, ((size_t)n + 1) * sizeof *a))) return MO_ENOMEM;
    C->cs = a;
    {
      int *p = mo_realloc(ctx, C->piv, ((size_t)n + 1) * sizeof *p);
      if (!p) return MO_ENOMEM;
      C->piv = p;
    }
    C->cap = nn + 1;
  }
  memcpy(C->key, key, nn * sizeof *key);
  memcpy(C->lu, lu, nn * sizeof *lu);
  memcpy(C->rs, rs, (size_t)n * sizeof *rs);
  memcpy(C->cs, cs, (size_t)n * sizeof *cs);
  memcpy(C->piv, ipiv, (size_t)n * sizeof *ipiv);
  C->n = n;
  C->valid = 1;
  return MO_OK;
}

int ls_dense_solve(int n, double *J, double *b, const double *y, const double *D, int *ipiv,
                   ls_lu_cache *C, mo_ctx *ctx)
{
  int info = 0, i, j, st = MO_OK, rank = 0;
  double *A = NULL, *b0 = NULL, *key = NULL, *Sl = NULL, *rs = NULL, *cs = NULL, rc;
  if (n == 0) return MO_OK;
  if (C) {
    C->valid = 0;
    C->factorizations++;
    if (!(key = mo_malloc(ctx, (size_t)n * (size_t)n * sizeof *key))) return MO_ENOMEM;
    memcpy(key, J, (size_t)n * (size_t)n * sizeof *key);
  }
  /* LAPACK is column-major: transpose in place (J is square) */
  for (i = 0; i < n; i++)
    for (j = i + 1; j < n; j++) {
      double t = J[(size_t)i * n + j];
      J[(size_t)i * n + j] = J[(size_t)j * n + i];
      J[(size_t)j * n + i] = t;
    }
  Sl = mo_malloc(ctx, (size_t)n * (size_t)n * sizeof *Sl);
  rs = mo_malloc(ctx, (size_t)n * sizeof *rs);
  cs = mo_malloc(ctx, (size_t)n * sizeof *cs);
  if (!Sl || !rs || !cs || (rc = scaled_lu(n, J, Sl, ipiv, rs, cs, ctx)) < 0) { st = MO_ENOMEM; goto done; }
  if (rc >= 1e-13) {
    /* the LU of the scaled J that the condition test needed solves the step, and is kept for
       the next solves of the same J */
    info = scaled_solve(n, Sl, ipiv, rs, cs, b);
    if (info == 0 && C && (st = lu_store(C, n, key, Sl, ipiv, rs, cs, ctx))) goto done;
  } else {
    /* redundant constraints: the iterate y + dx of smallest |D^-1 (y + dx)| among the solutions of
       J (y + dx) = J y + b (least squares when the frozen status admits none) */
    A = mo_malloc(ctx, (size_t)n * (size_t)n * sizeof *A);
    b0 = mo_malloc(ctx, (size_t)n * sizeof *b0);
    if (!A || !b0) { st = MO_ENOMEM; goto done; }
    for (i = 0; i < n; i++) {
      double acc = b[i];
      for (j = 0; j < n; j++) acc += J[(size_t)j * n + i] * y[j];
      b0[i] = acc;
    }
    for (j = 0; j < n; j++)
      for (i = 0; i < n; i++) A[(size_t)j * n + i] = J[(size_t)j * n + i] * D[j];
    if ((st = min_norm_solve(n, A, b0, &rank, ctx))) goto done;
    for (i = 0; i < n; i++) b[i] = D[i] * b0[i] - y[i];
    mo_log(ctx, 3, "levelset: the frozen-status system has rank %d of %d: the iterate of smallest scaled norm\n", rank, n);
  }
  if (info < 0) st = mo_error(ctx, MO_EINTERNAL, "levelset: dgetrf/dgetrs argument %d", -info);
  if (!st) st = finite_or_error(n, b, ctx);
done:
  mo_free(Sl);
  mo_free(rs);
  mo_free(cs);
  mo_free(key);
  mo_free(A);
  mo_free(b0);
  return st;
}

/* --- Schur path ----------------------------------------------------------------------------------- */

int ls_schur_wcc(const ls_system *S, const mo_delassus *W, double *WCC)
{
  int nr = S->nr, d = S->d, nu = S->nC * nr, jc, p, i, k;
  memset(WCC, 0, (size_t)nu * (size_t)nu * sizeof(double));
  for (jc = 0; jc < S->nC; jc++) {
    const int *beta;
    const double *blk;
    int n = mo_delassus_row(W, S->cset[jc], &beta, &blk);
    for (p = 0; p < n; p++) {
      int kc = S->cpos[beta[p]];
      if (kc < 0) continue;
      for (i = 0; i < nr; i++)
        for (k = 0; k < nr; k++)
          WCC[(size_t)(jc * nr + i) * nu + (size_t)(kc * nr + k)] = blk[(size_t)p * d * d + (size_t)(i * d + k)];
    }
  }
  return MO_OK;
}

void ls_schur_velocity(const ls_system *S, const double *WCC, const double *q, const double *y,
                       double *U, double *Umag)
{
  int nr = S->nr, d = S->d, nu = S->nC * nr, e, k;
  for (e = 0; e < nu; e++) {
    int j = S->cset[e / nr], i = e % nr;
    double s = q[j * d + i], m = fabs(s);
    const double *row = WCC + (size_t)e * nu;
    for (k = 0; k < nu; k++) {
      s += row[k] * y[k];
      m += fabs(row[k] * y[k]);
    }
    U[e] = s;
    Umag[e] = m;
  }
}

/* --- KKT path ------------------------------------------------------------------------------------- */

void ls_kkt_free(ls_kkt *K)
{
  if (!K) return;
  mo_linsolver_free(K->ls);
  mo_free(K->rhs);
  mo_free(K->sol);
  memset(K, 0, sizeof *K);
}

void ls_kkt_velocity(const ls_system *S, const mo_contact_problem *P, const double *dv, double *U,
                     double *Umag)
{
  const mo_csc *H = P->H;
  int nr = S->nr, d = S->d, jc, i, p;
  for (jc = 0; jc < S->nC; jc++)
    for (i = 0; i < nr; i++) {
      int col = S->cset[jc] * d + i;
      double s = P->b[col], m = fabs(s);
      for (p = H->p[col]; p < H->p[col + 1]; p++) {
        s += H->x[p] * dv[H->i[p]];
        m += fabs(H->x[p] * dv[H->i[p]]);
      }
      U[jc * nr + i] = s;
      Umag[jc * nr + i] = m;
    }
}

/* One Newton step on the saddle-point system (T21):
     [ What           -H_C ] [ddv]     [ What dv - H_C r ]
     [ dF/dU' H_C^T   dF/dy ] [dy ] = - [ F(y, q + H_C^T dv) ]
   assembled as triplets over (free dofs, y) and solved by UMFPACK (the pattern is analysed again
   only when the contact set changes it). */
int ls_kkt_step(ls_kkt *K, const ls_system *S, const mo_contact_problem *P, const double *dv,
                const double *y, double *ddv, double *dy, mo_ctx *ctx)
{
  const mo_csc *Wh = P->What, *H = P->H;
  int nf = P->nfree, ny = S->ny, n = nf + ny, nr = S->nr, d = S->d, nu = S->nC * nr;
  int st, j, p, e, k;
  mo_triplet T;
  mo_csc *A = NULL;
  size_t hint = (size_t)mo_csc_nnz(Wh) + (size_t)ny * (size_t)ny + 16 * (size_t)nu + 1;
  if ((st = mo_triplet_init(&T, n, n, hint, ctx))) return st;
  /* What and -H_C, and the first residual block What dv - H_C r */
  if (K->cap < n) {
    double *a = mo_realloc(ctx, K->rhs, ((size_t)n + 1) * sizeof(double));
    double *b;
    if (!a) { st = MO_ENOMEM; goto done; }
    K->rhs = a;
    b = mo_realloc(ctx, K->sol, ((size_t)n + 1) * sizeof(double));
    if (!b) { st = MO_ENOMEM; goto done; }
    K->sol = b;
    K->cap = n;
  }
  memset(K->rhs, 0, (size_t)n * sizeof(double));
  for (j = 0; j < nf; j++)
    for (p = Wh->p[j]; p < Wh->p[j + 1]; p++) {
      if ((st = mo_triplet_add(&T, Wh->i[p], j, Wh->x[p], ctx))) goto done;
      K->rhs[Wh->i[p]] -= Wh->x[p] * dv[j];
    }
  for (e = 0; e < nu; e++) {
    int col = S->cset[e / nr] * d + e % nr;
    for (p = H->p[col]; p < H->p[col + 1]; p++) {
      if ((st = mo_triplet_add(&T, H->i[p], nf + e, -H->x[p], ctx))) goto done;
      K->rhs[H->i[p]] += H->x[p] * y[e];
    }
  }
  /* the local rows: dF/dU' H_C^T and dF/dy */
  for (e = 0; e < ny; e++) {
    const double *ju = S->JU + (size_t)e * (size_t)nu, *jy = S->Jy + (size_t)e * (size_t)ny;
    for (k = 0; k < nu; k++) {
      int col;
      if (ju[k] == 0) continue;
      col = S->cset[k / nr] * d + k % nr;
      for (p = H->p[col]; p < H->p[col + 1]; p++)
        if ((st = mo_triplet_add(&T, nf + e, H->i[p], ju[k] * H->x[p], ctx))) goto done;
    }
    for (k = 0; k < ny; k++)
      if (jy[k] != 0 && (st = mo_triplet_add(&T, nf + e, nf + k, jy[k], ctx))) goto done;
    K->rhs[nf + e] = -S->F[e];
  }
  if ((st = mo_triplet_to_csc(&T, 0, &A, ctx))) goto done;
  if (!K->ls && (st = mo_linsolver_create(&mo_linsolver_umfpack, &K->ls, ctx))) goto done;
  if ((st = mo_linsolver_factor(K->ls, A, ctx))) {
    mo_error_prefix(ctx, "levelset saddle-point system (%d free dofs, %d contact unknowns)", nf, ny);
    goto done;
  }
  if ((st = mo_linsolver_solve(K->ls, K->rhs, K->sol, ctx))) goto done;
  for (j = 0; j < n; j++)
    if (!isfinite(K->sol[j])) {
      st = mo_error(ctx, MO_ENAN, "levelset: the saddle-point solve gave a non-finite value (unknown %d of %d)", j, n);
      goto done;
    }
  memcpy(ddv, K->sol, (size_t)nf * sizeof(double));
  memcpy(dy, K->sol + nf, (size_t)ny * sizeof(double));
done:
  mo_csc_free(A);
  mo_triplet_release(&T);
  return st;
}
