/* levelset_reduced.c: the levelset back end's frozen-status system with one multiplier per
   candidate (A = I), solved on its constrained components through the kept factor of W_XX
   (doc/theory.md §6.4.2, (T130)-(T133)). */
#include "config.h"
#include "levelset.h"

#include <float.h>
#include <math.h>
#include <string.h>

extern void dpotrf_(const char *uplo, const int *n, double *a, const int *lda, int *info);
extern void dpotrs_(const char *uplo, const int *n, const int *nrhs, const double *a, const int *lda,
                    double *b, const int *ldb, int *info);
extern void dsyev_(const char *jobz, const char *uplo, const int *n, double *a, const int *lda, double *w,
                   double *work, const int *lwork, int *info);
extern void dgetrf_(const int *m, const int *n, double *a, const int *lda, int *ipiv, int *info);
extern void dgetrs_(const char *trans, const int *n, const int *nrhs, const double *a, const int *lda,
                    const int *ipiv, double *b, const int *ldb, int *info);
extern void dgesv_(const int *n, const int *nrhs, double *a, const int *lda, int *ipiv, double *b,
                   const int *ldb, int *info);

/* a pivot of the equilibrated matrix below this makes it singular: the threshold of the dense
   path's test on the scaled Newton matrix (§12.7) */
#define LS_RED_RCOND 1e-13

void ls_reduced_free(ls_reduced *R)
{
  if (!R) return;
  mo_free(R->cls); mo_free(R->xc); mo_free(R->xg); mo_free(R->sc); mo_free(R->scode); mo_free(R->es);
  mo_free(R->key); mo_free(R->keys); mo_free(R->f); mo_free(R->kval); mo_free(R->ds); mo_free(R->cs); mo_free(R->ev);
  mo_free(R->piv); mo_free(R->zkey); mo_free(R->Z); mo_free(R->Wred);
  mo_free(R->up); mo_free(R->bx); mo_free(R->t1); mo_free(R->m2); mo_free(R->wk); mo_free(R->ipiv); mo_free(R->iwk);
  memset(R, 0, sizeof *R);
}

int ls_reduced_applies(const ls_space *A)
{
  int j;
  if (A->nm != A->nc) return 0;
  for (j = 0; j < A->nc; j++)
    if (A->rp[j + 1] - A->rp[j] != 1 || A->rx[A->rp[j]] != 1) return 0;
  for (j = 0; j < A->nm; j++)
    if (A->cp[j + 1] - A->cp[j] != 1) return 0;
  return 1;
}

/* Grow a double buffer to n entries (kept between calls). */
static int grow(double **p, size_t *cap, size_t n, mo_ctx *ctx)
{
  double *a;
  if (n <= *cap && *p) return MO_OK;
  if (!(a = mo_realloc(ctx, *p, (n + 1) * sizeof *a))) return MO_ENOMEM;
  *p = a;
  *cap = n;
  return MO_OK;
}

static int grow_int(int **p, size_t *cap, size_t n, mo_ctx *ctx)
{
  int *a;
  if (n <= *cap && *p) return MO_OK;
  if (!(a = mo_realloc(ctx, *p, (n + 1) * sizeof *a))) return MO_ENOMEM;
  *p = a;
  *cap = n;
  return MO_OK;
}

int ls_reduced_classify(ls_reduced *R, const ls_system *S, const ls_space *A, int coupled, int *ok,
                        mo_ctx *ctx)
{
  const int nr = S->nr, dt = S->dt, nu = S->nC * nr;
  int jc, t, e, st;
  *ok = 0;
  if ((size_t)nu > R->cap_c || !R->cls) {
    unsigned char *c = mo_realloc(ctx, R->cls, (size_t)nu + 1);
    size_t cap;
    if (!c) return MO_ENOMEM;
    R->cls = c;
    cap = R->cap_c;
    if ((st = grow_int(&R->xc, &cap, (size_t)nu, ctx))) return st;
    cap = R->cap_c;
    if ((st = grow_int(&R->xg, &cap, (size_t)nu, ctx))) return st;
    cap = R->cap_c;
    if ((st = grow_int(&R->sc, &cap, (size_t)nu, ctx))) return st;
    cap = R->cap_c;
    if ((st = grow_int(&R->scode, &cap, (size_t)nu, ctx))) return st;
    cap = R->cap_c;
    if ((st = grow(&R->es, &cap, (size_t)nu, ctx))) return st;
    R->cap_c = (size_t)nu;
  }
  R->nu = nu;
  R->nX = R->nS = 0;
  R->coupled = coupled && (dt == 1 || S->edir); /* 3D: the damped loop's frozen directions (T143) */
  for (jc = 0; jc < S->nC; jc++) {
    int j = S->cset[jc], q = A->rp[j], phi;
    /* A = I with the multipliers numbered as the candidates of Cset (ls_system_setup) */
    if (A->rp[j + 1] - q != 1 || S->mpos[A->ri[q]] != jc) return MO_OK;
    R->cls[jc * nr] = S->sv[j] ? LS_CLS_X : LS_CLS_FIXED;
    phi = ls_phi(S, j);
    for (t = 0; t < dt; t++) R->cls[jc * nr + 1 + t] = !phi ? LS_CLS_FIXED : S->sf[j] ? LS_CLS_X : LS_CLS_SLIDE;
    if (phi && !S->sf[j]) R->sc[R->nS++] = jc;
  }
  for (e = 0; e < nu; e++)
    if (R->cls[e] == LS_CLS_X) {
      R->xc[R->nX] = e;
      R->xg[R->nX++] = S->cset[e / nr] * S->d + e % nr;
    }
  *ok = 1;
  return MO_OK;
}

/* --- the kept factor ------------------------------------------------------------------------- */

static double tau_of(const ls_system *S, int j) { return S->c * S->w[j] * S->mu[j] * S->pg[j]; }

/* The dense kernels of the small systems: with n up to a few tens, LAPACK's and OpenBLAS's calls
   cost more than their arithmetic (measured, instructions per call: dpotrf 1.7e3 and dpotrs 1.9e3
   at n = 1 to 4, dgetrf 2.2e3 at n = 4, against 3e2 for the loops below; the loops lose to LAPACK
   above n = 16 for Cholesky and n = 32 for LU), so these sizes are factored by the loops (doc/theory.md
   (T131)) and the larger ones by LAPACK. Column-major; a pivot of the equilibrated matrix below
   `tol` stops them (returned as its index + 1). */
#define LS_SMALL_CHOL 16
#define LS_SMALL_LU 32

static int chol_small(int n, double *a, double tol)
{
  int i, j, k;
  for (k = 0; k < n; k++) {
    double *ck = a + (size_t)k * n, l;
    if (!(ck[k] >= tol)) return k + 1;
    l = sqrt(ck[k]);
    ck[k] = l;
    for (i = k + 1; i < n; i++) ck[i] /= l;
    for (j = k + 1; j < n; j++) {
      double *cj = a + (size_t)j * n, f = ck[j];
      for (i = j; i < n; i++) cj[i] -= ck[i] * f;
    }
  }
  return 0;
}

static int lu_small(int n, double *a, int *piv, double tol)
{
  int i, j, k;
  for (k = 0; k < n; k++) {
    double *ck = a + (size_t)k * n, m = fabs(ck[k]), d;
    int p = k;
    for (i = k + 1; i < n; i++)
      if (fabs(ck[i]) > m) { m = fabs(ck[i]); p = i; }
    piv[k] = p;
    if (p != k)
      for (j = 0; j < n; j++) {
        double t = a[(size_t)j * n + k];
        a[(size_t)j * n + k] = a[(size_t)j * n + p];
        a[(size_t)j * n + p] = t;
      }
    if (!(m >= tol)) return k + 1;
    d = 1 / ck[k];
    for (i = k + 1; i < n; i++) ck[i] *= d;
    for (j = k + 1; j < n; j++) {
      double *cj = a + (size_t)j * n, f = cj[k];
      if (f != 0)
        for (i = k + 1; i < n; i++) cj[i] -= ck[i] * f;
    }
  }
  return 0;
}

/* x = (L L^T)^-1 x, L from chol_small. */
static void chol_solve_small(int n, const double *l, double *x)
{
  int i, k;
  for (k = 0; k < n; k++) {
    const double *ck = l + (size_t)k * n;
    x[k] /= ck[k];
    for (i = k + 1; i < n; i++) x[i] -= ck[i] * x[k];
  }
  for (k = n - 1; k >= 0; k--) {
    const double *ck = l + (size_t)k * n;
    double v = x[k];
    for (i = k + 1; i < n; i++) v -= ck[i] * x[i];
    x[k] = v / ck[k];
  }
}

/* x = (P^T L U)^-1 x, from lu_small (whole rows swapped: P x first, then L and U). */
static void lu_solve_small(int n, const double *a, const int *piv, double *x)
{
  int i, k;
  for (k = 0; k < n; k++)
    if (piv[k] != k) {
      double t = x[k];
      x[k] = x[piv[k]];
      x[piv[k]] = t;
    }
  for (k = 0; k < n; k++) {
    const double *ck = a + (size_t)k * n;
    for (i = k + 1; i < n; i++) x[i] -= ck[i] * x[k];
  }
  for (k = n - 1; k >= 0; k--) {
    const double *ck = a + (size_t)k * n;
    x[k] /= ck[k];
    for (i = 0; i < k; i++) x[i] -= ck[i] * x[k];
  }
}

/* The matrix of the frozen status, unscaled, column-major into a: W_XX, plus W_XS C_e for the
   coupled sliders (C_e: r_t,s = -mu_s e_s r_n,s, T134). */
static void gather(const ls_reduced *R, const ls_system *S, const double *WCC, int nks, double *a)
{
  const int n = R->nX, nu = R->nu, nr = S->nr;
  int i, k, s;
  for (k = 0; k < n; k++)
    for (i = 0; i < n; i++) a[(size_t)k * n + i] = WCC[(size_t)R->xc[i] * nu + R->xc[k]];
  for (s = 0; s < nks; s++) {
    int jc = R->sc[s], cn = jc * nr, b, t;
    for (b = 0; b < n && R->xc[b] != cn; b++) continue;
    for (t = 0; t < S->dt; t++) {
      int ct = cn + 1 + t;
      double c = -S->mu[S->cset[jc]] * R->es[s * S->dt + t];
      for (i = 0; b < n && i < n; i++) a[(size_t)b * n + i] += WCC[(size_t)R->xc[i] * nu + ct] * c;
    }
  }
}

/* 1 when the kept factor is that of the current matrix (T131): the same X and coupled sliders
   with their directions, and W the same, or rebuilt with the same values on these rows (a body
   that translates: the core rebuilds W at every step of a dynamic pair). */
static int same_key(const ls_reduced *R, int nks)
{
  const int n = R->nX;
  return R->kind != LS_RED_NONE && R->nkey == n && R->nkeys == nks && !memcmp(R->key, R->xg, (size_t)n * sizeof *R->key) &&
         !memcmp(R->keys, R->scode, (size_t)nks * sizeof *R->keys);
}

int ls_reduced_kept(const ls_reduced *R, const ls_system *S, const mo_delassus *W, int nks)
{
  return same_key(R, nks) && R->W == W && R->version == mo_delassus_version(W) && R->eps == S->eps;
}

/* 1 when the kept factor is current; *gathered = 1 when the matrix was gathered into wk to tell */
static int factor_current(ls_reduced *R, const ls_system *S, const mo_delassus *W, const double *WCC, int nks,
                          int *gathered)
{
  const int n = R->nX;
  size_t nn = (size_t)n * (size_t)n;
  *gathered = 0;
  if (!same_key(R, nks)) return 0;
  if (ls_reduced_kept(R, S, W, nks)) return 1;
  if (nn > R->cap_w) return 0;
  gather(R, S, WCC, nks, R->wk);
  *gathered = 1;
  if (memcmp(R->wk, R->kval, nn * sizeof *R->wk)) return 0;
  R->W = W;
  R->version = mo_delassus_version(W);
  R->eps = S->eps;
  return 1;
}

/* Factor W_XX (kval): the Cholesky factor of Ds W_XX Ds (Ds = diag(W_XX)^-1/2, unit diagonal) when
   no pivot falls below LS_RED_RCOND, else its eigen-decomposition (T132). */
static int factor_spd(ls_reduced *R, int nr, mo_ctx *ctx)
{
  const int n = R->nX;
  int info = 0, i, k, st, lwork = -1;
  double wq = 0;
  for (i = 0; i < n; i++) {
    double w = R->kval[(size_t)i * n + i];
    R->ds[i] = w > 0 ? 1 / sqrt(w) : 1;
  }
  for (k = 0; k < n; k++)
    for (i = 0; i < n; i++) R->f[(size_t)k * n + i] = R->ds[i] * R->kval[(size_t)k * n + i] * R->ds[k];
  /* the pivots l_kk^2 of the unit-diagonal matrix are the diagonals of its Schur complements:
     each at most 1 and at least its smallest eigenvalue; a redundant constraint leaves one at
     round-off */
  if (n <= LS_SMALL_CHOL) info = chol_small(n, R->f, LS_RED_RCOND);
  else {
    dpotrf_("L", &n, R->f, &n, &info);
    for (k = 0; info == 0 && k < n; k++)
      if (!(R->f[(size_t)k * n + k] * R->f[(size_t)k * n + k] >= LS_RED_RCOND)) info = k + 1;
  }
  if (info == 0) {
    R->kind = LS_RED_CHOL;
    R->rank = n;
    return MO_OK;
  }
  /* singular (redundant constraints): the eigenvectors of Ds W_XX Ds, eigenvalues ascending */
  for (k = 0; k < n; k++)
    for (i = 0; i < n; i++) R->f[(size_t)k * n + i] = R->ds[i] * R->kval[(size_t)k * n + i] * R->ds[k];
  dsyev_("V", "L", &n, R->f, &n, R->ev, &wq, &lwork, &info);
  lwork = (int)wq + 1;
  if ((st = grow(&R->wk, &R->cap_w, (size_t)lwork, ctx))) return st;
  dsyev_("V", "L", &n, R->f, &n, R->ev, R->wk, &lwork, &info);
  if (info != 0)
    return mo_error(ctx, MO_ESINGULAR, "levelset: the eigen-decomposition of the constrained block of W failed "
                    "(LAPACK dsyev info %d, %d components)", info, n);
  R->rank = 0;
  for (i = 0; i < n; i++) R->rank += R->ev[i] > LS_RED_RCOND * R->ev[n - 1];
  R->kind = LS_RED_PINV;
  R->singular++;
  /* a null vector that moves a normal impulse: (T76) chooses among friction impulses only */
  R->normal_null = 0;
  for (k = 0; k < n - R->rank && !R->normal_null; k++)
    for (i = 0; i < n; i++)
      if (R->xc[i] % nr == 0 && fabs(R->f[(size_t)k * n + i]) > 1e-6) R->normal_null = 1;
  mo_log(ctx, 3, "levelset: the constrained block of W has rank %d of %d: the impulses of smallest weighted norm\n",
         R->rank, n);
  return MO_OK;
}

/* The coupled threshold's matrix (kval) scaled to unit columns (cs) then rows (ds), and its LU;
   LS_RED_SINGULAR when a pivot falls below LS_RED_RCOND (T134). */
static void factor_coupled(ls_reduced *R)
{
  const int n = R->nX;
  int i, k, info = 0;
  double *a = R->f;
  memcpy(a, R->kval, (size_t)n * (size_t)n * sizeof *a);
  for (k = 0; k < n; k++) {
    double m = 0, *col = a + (size_t)k * n;
    for (i = 0; i < n; i++)
      if (fabs(col[i]) > m) m = fabs(col[i]);
    R->cs[k] = m > 0 ? m : 1;
    for (i = 0; i < n; i++) col[i] /= R->cs[k];
  }
  for (i = 0; i < n; i++) R->ds[i] = 0;
  for (k = 0; k < n; k++)
    for (i = 0; i < n; i++)
      if (fabs(a[(size_t)k * n + i]) > R->ds[i]) R->ds[i] = fabs(a[(size_t)k * n + i]);
  for (i = 0; i < n; i++)
    if (!(R->ds[i] > 0)) R->ds[i] = 1;
  for (k = 0; k < n; k++)
    for (i = 0; i < n; i++) a[(size_t)k * n + i] /= R->ds[i];
  R->kind = LS_RED_LU;
  R->rank = n;
  if (n <= LS_SMALL_LU) info = lu_small(n, a, R->piv, LS_RED_RCOND);
  else {
    /* the pivots of the equilibrated matrix (entries at most 1): one at round-off when singular */
    dgetrf_(&n, &n, a, &n, R->piv, &info);
    for (k = 0; info == 0 && k < n; k++)
      if (!(fabs(a[(size_t)k * n + k]) >= LS_RED_RCOND)) info = k + 1;
  }
  if (info != 0) {
    R->kind = LS_RED_SINGULAR;
    R->singular++;
  }
}

/* Room for the kept factor of the nX unknowns of the current partition with nks coupled sliders
   (wk: n^2 for a matrix to compare with the kept one, and LAPACK's work). */
static int red_reserve(ls_reduced *R, int nks, mo_ctx *ctx)
{
  const int n = R->nX;
  size_t nn = (size_t)n * (size_t)n;
  int st;
  if ((st = grow(&R->f, &R->cap_f, nn, ctx)) || (st = grow(&R->kval, &R->cap_kv, nn, ctx)) ||
      (st = grow(&R->ds, &R->cap_d, (size_t)n, ctx)) || (st = grow(&R->cs, &R->cap_cs, (size_t)n, ctx)) ||
      (st = grow(&R->ev, &R->cap_e, (size_t)n, ctx)) || (st = grow(&R->wk, &R->cap_w, nn + 4 * (size_t)n, ctx)) ||
      (st = grow_int(&R->iwk, &R->cap_i, (size_t)n, ctx)) || (st = grow_int(&R->piv, &R->cap_pv, (size_t)n, ctx)) ||
      (st = grow_int(&R->key, &R->cap_k, (size_t)n, ctx)) || (st = grow_int(&R->keys, &R->cap_ks, (size_t)nks, ctx)))
    return st;
  return MO_OK;
}

/* Factor kval, the matrix of the current partition, and key it to X, the coupled sliders and W. */
static int red_factor_kval(ls_reduced *R, const ls_system *S, const mo_delassus *W, int nks, mo_ctx *ctx)
{
  int st;
  R->kind = LS_RED_NONE;
  R->zvalid = 0;
  if (nks) factor_coupled(R);
  else if ((st = factor_spd(R, S->nr, ctx))) return st;
  memcpy(R->key, R->xg, (size_t)R->nX * sizeof *R->key);
  memcpy(R->keys, R->scode, (size_t)nks * sizeof *R->keys);
  R->nkey = R->nX;
  R->nkeys = nks;
  R->W = W;
  R->version = mo_delassus_version(W);
  R->eps = S->eps;
  return MO_OK;
}

/* Factor the current matrix and remember its key and values (in wk already when `gathered`). */
static int red_factor(ls_reduced *R, const ls_system *S, const mo_delassus *W, const double *WCC, int nks,
                      int gathered, mo_ctx *ctx)
{
  int st;
  R->kind = LS_RED_NONE;
  if ((st = red_reserve(R, nks, ctx))) return st;
  if (gathered) memcpy(R->kval, R->wk, (size_t)R->nX * (size_t)R->nX * sizeof *R->kval);
  else gather(R, S, WCC, nks, R->kval);
  return red_factor_kval(R, S, W, nks, ctx);
}

int ls_reduced_matrix(ls_reduced *R, int nks, double **A, mo_ctx *ctx)
{
  int st = red_reserve(R, nks, ctx);
  *A = st ? NULL : R->wk;
  return st;
}

int ls_reduced_factor(ls_reduced *R, const ls_system *S, const mo_delassus *W, int nks, int *fresh, mo_ctx *ctx)
{
  const int n = R->nX;
  size_t nn = (size_t)n * (size_t)n;
  *fresh = 0;
  if (same_key(R, nks) && !memcmp(R->wk, R->kval, nn * sizeof *R->wk)) {
    R->W = W;
    R->version = mo_delassus_version(W);
    R->eps = S->eps;
    return MO_OK;
  }
  *fresh = 1;
  memcpy(R->kval, R->wk, nn * sizeof *R->kval);
  return red_factor_kval(R, S, W, nks, ctx);
}

/* x = M^-1 b in place for nrhs right-hand sides (leading dimension ld): Cholesky or LU, the
   scalings undone around them. */
static void factor_solve(const ls_reduced *R, double *x, int nrhs, int ld)
{
  const int n = R->nX, lu = R->kind == LS_RED_LU;
  int i, k, info = 0;
  if (n == 0 || nrhs == 0) return;
  for (k = 0; k < nrhs; k++)
    for (i = 0; i < n; i++) x[(size_t)k * ld + i] *= lu ? 1 / R->ds[i] : R->ds[i];
  if (lu && n <= LS_SMALL_LU)
    for (k = 0; k < nrhs; k++) lu_solve_small(n, R->f, R->piv, x + (size_t)k * ld);
  else if (lu)
    dgetrs_("N", &n, &nrhs, R->f, &n, R->piv, x, &ld, &info);
  else if (n <= LS_SMALL_CHOL)
    for (k = 0; k < nrhs; k++) chol_solve_small(n, R->f, x + (size_t)k * ld);
  else
    dpotrs_("L", &n, &nrhs, R->f, &n, x, &ld, &info);
  for (k = 0; k < nrhs; k++)
    for (i = 0; i < n; i++) x[(size_t)k * ld + i] *= lu ? 1 / R->cs[i] : R->ds[i];
}

/* The solution of W_XX x = b (least squares when b is outside its range) of smallest
   sum_i x_i^2 / m_i, m the weights (T132): the minimum-norm solution in the scaled unknowns
   Ds^-1 x first, then moved along the null space N = Ds V0 to the smallest weighted norm,
   a = -(N^T M^-1 N)^-1 N^T M^-1 x. b is overwritten by x. */
static int pinv_solve(ls_reduced *R, const double *m, double *b, mo_ctx *ctx)
{
  const int n = R->nX, k0 = n - R->rank;
  int i, k, l, info = 0, st, one = 1;
  double *z, *g, *a;
  if ((st = grow(&R->wk, &R->cap_w, (size_t)n + (size_t)k0 * (size_t)k0 + (size_t)k0, ctx)) ||
      (st = grow_int(&R->iwk, &R->cap_i, (size_t)n, ctx)))
    return st;
  z = R->wk;
  g = z + n;
  a = g + (size_t)k0 * k0;
  for (k = 0; k < n; k++) {
    double s = 0;
    if (k < k0) { z[k] = 0; continue; }
    for (i = 0; i < n; i++) s += R->f[(size_t)k * n + i] * R->ds[i] * b[i];
    z[k] = s / R->ev[k];
  }
  for (i = 0; i < n; i++) {
    double s = 0;
    for (k = k0; k < n; k++) s += R->f[(size_t)k * n + i] * z[k];
    b[i] = R->ds[i] * s;
  }
  if (k0 == 0) return MO_OK;
  /* N = Ds V0: the eigenvectors of the k0 smallest eigenvalues, scaled */
  for (k = 0; k < k0; k++) {
    double s = 0;
    for (l = 0; l < k0; l++) {
      double gl = 0;
      for (i = 0; i < n; i++) gl += R->ds[i] * R->f[(size_t)k * n + i] * R->ds[i] * R->f[(size_t)l * n + i] / m[i];
      g[(size_t)l * k0 + k] = gl;
    }
    for (i = 0; i < n; i++) s += R->ds[i] * R->f[(size_t)k * n + i] * b[i] / m[i];
    a[k] = -s;
  }
  if (k0 <= LS_SMALL_LU) {
    if ((info = lu_small(k0, g, R->iwk, DBL_MIN)) == 0) lu_solve_small(k0, g, R->iwk, a);
  } else
    dgesv_(&k0, &one, g, &k0, R->iwk, a, &k0, &info);
  if (info != 0) return MO_OK; /* the weights leave the choice open: keep the scaled minimum norm */
  for (i = 0; i < n; i++) {
    double s = 0;
    for (k = 0; k < k0; k++) s += R->ds[i] * R->f[(size_t)k * n + i] * a[k];
    b[i] += s;
  }
  return MO_OK;
}

/* Z = W_XX^-1 W_XS and Wred = W_SS - W_SX Z over the sliders' tangents (3D), for the kept
   factor and the current slider set. */
static int slider_blocks(ls_reduced *R, const ls_system *S, const double *WCC, mo_ctx *ctx)
{
  const int n = R->nX, nr = S->nr, ns = 2 * R->nS, nu = R->nu;
  int s, i, k, st;
  if (R->zvalid && R->nzkey == R->nS && !memcmp(R->zkey, R->sc, (size_t)R->nS * sizeof *R->sc)) return MO_OK;
  if ((st = grow(&R->Z, &R->cap_z, (size_t)n * (size_t)ns, ctx)) ||
      (st = grow(&R->Wred, &R->cap_r, (size_t)ns * (size_t)ns, ctx)) ||
      (st = grow_int(&R->zkey, &R->cap_zk, (size_t)R->nS, ctx)))
    return st;
  for (s = 0; s < ns; s++) {
    int cs = R->sc[s / 2] * nr + 1 + s % 2;
    for (i = 0; i < n; i++) R->Z[(size_t)s * n + i] = WCC[(size_t)R->xc[i] * nu + cs];
  }
  factor_solve(R, R->Z, ns, n);
  for (s = 0; s < ns; s++) {
    int cs = R->sc[s / 2] * nr + 1 + s % 2;
    for (k = 0; k < ns; k++) {
      int ck = R->sc[k / 2] * nr + 1 + k % 2;
      double v = WCC[(size_t)cs * nu + ck];
      for (i = 0; i < n; i++) v -= WCC[(size_t)cs * nu + R->xc[i]] * R->Z[(size_t)k * n + i];
      R->Wred[(size_t)k * ns + s] = v; /* column-major */
    }
  }
  memcpy(R->zkey, R->sc, (size_t)R->nS * sizeof *R->sc);
  R->nzkey = R->nS;
  R->zvalid = 1;
  return MO_OK;
}

int ls_reduced_solve(ls_reduced *R, const ls_system *S, const double *y, double *b, mo_ctx *ctx)
{
  const int n = R->nX, nr = S->nr;
  int i, k, st;
  double *m;
  if (R->kind != LS_RED_PINV) {
    factor_solve(R, b, 1, n);
    return MO_OK;
  }
  /* the impulses themselves, of smallest weighted norm: W_XX x = W_XX r_X - U'_X (kval is W_XX:
     no coupled sliders with this factor) */
  if ((st = grow(&R->t1, &R->cap_t1, (size_t)n, ctx))) return st;
  m = R->t1;
  for (i = 0; i < n; i++) {
    int j = S->cset[R->xc[i] / nr];
    for (k = 0; k < n; k++) b[i] += R->kval[(size_t)k * n + i] * y[R->xc[k]];
    m[i] = R->xc[i] % nr == 0 ? S->c * S->w[j] : tau_of(S, j);
    if (!(m[i] > 0)) m[i] = 1;
  }
  if ((st = pinv_solve(R, m, b, ctx))) return st;
  for (i = 0; i < n; i++) b[i] -= y[R->xc[i]];
  return MO_OK;
}

/* --- one Newton step ------------------------------------------------------------------------------ */

/* The 3D sliders' Newton corrections dLam (into b2, 2 nS) from the Schur complement on the
   sliding directions (T133):
     [(I - D) + h2 D Wred T] dLam = -F_L + h2 D (U'_S - U_S) + h2 D W_SX t1,   t1 = W_XX^-1 b_X. */
static int slider_step(ls_reduced *R, const ls_system *S, const double *WCC, const double *U, const double *y,
                       double *b2, mo_ctx *ctx)
{
  const int nr = S->nr, nu = R->nu, n = R->nX, ns = 2 * R->nS, offl = nu + S->nM;
  int s, t, u, k, v, info = 0, st, one = 1;
  double *m2, e[2], D[4];
  if ((st = grow(&R->m2, &R->cap_m2, (size_t)ns * (size_t)ns, ctx)) ||
      (st = grow_int(&R->ipiv, &R->cap_p, (size_t)ns, ctx)))
    return st;
  m2 = R->m2;
  for (s = 0; s < R->nS; s++) {
    int jc = R->sc[s];
    const double *lam = y + offl + jc * 2, *Ut = U + jc * nr + 1;
    ls_slide_dir(2, lam, Ut, S->h2_t, e, D);
    for (t = 0; t < 2; t++) {
      int row = 2 * s + t;
      double rhs = e[t] - lam[t];
      for (u = 0; u < 2; u++) {
        int cu = jc * nr + 1 + u;
        double wt1 = 0;
        for (k = 0; k < n; k++) wt1 += WCC[(size_t)cu * nu + R->xc[k]] * R->t1[k];
        rhs += S->h2_t * D[t * 2 + u] * (R->up[cu] - U[cu] + wt1);
      }
      b2[row] = rhs;
      for (k = 0; k < ns; k++) {
        double a = 0, tk = tau_of(S, S->cset[R->sc[k / 2]]);
        for (v = 0; v < 2; v++) a += D[t * 2 + v] * R->Wred[(size_t)k * ns + 2 * s + v];
        m2[(size_t)k * ns + row] = S->h2_t * a * tk + (k / 2 == s ? (k % 2 == t) - D[t * 2 + k % 2] : 0);
      }
    }
  }
  if (ns <= LS_SMALL_LU) {
    if ((info = lu_small(ns, m2, R->ipiv, DBL_MIN)) == 0) lu_solve_small(ns, m2, R->ipiv, b2);
  } else
    dgesv_(&ns, &one, m2, &ns, R->ipiv, b2, &ns, &info);
  if (info != 0)
    return mo_error(ctx, MO_ESINGULAR, "levelset: the sliding directions' Newton system is singular "
                    "(LAPACK dgesv info %d, %d sliding candidates)", info, R->nS);
  return MO_OK;
}

void ls_reduced_multipliers(const ls_reduced *R, const ls_system *S, const double *U, double *y, double *pg)
{
  const int nr = S->nr, dt = S->dt, nC = S->nC, nu = nC * nr, offp = nu, offl = nu + S->nM;
  int jc, t, k;
  for (jc = 0; jc < nC; jc++) {
    int j = S->cset[jc], e = jc * nr;
    double tau;
    if (S->sv[j]) {
      /* r_n = c w (p - k_n (Z U'_n)): p from r_n */
      double zu = 0;
      if (S->k_n != 0) {
        if (S->Z)
          for (k = 0; k < nC; k++) zu += S->Z[(size_t)jc * nC + k] * U[k * nr];
        else zu = U[e];
      }
      y[offp + jc] = y[e] / (S->c * S->w[j]) + S->k_n * zu;
    } else
      y[offp + jc] = 0;
    if (R->coupled) pg[j] = ls_phi(S, j) ? y[offp + jc] : 0;
    tau = tau_of(S, j);
    for (t = 0; t < dt; t++) {
      unsigned char c = R->cls[e + 1 + t];
      if (c == LS_CLS_FIXED) y[offl + jc * dt + t] = 0;
      else if (c == LS_CLS_X)
        /* stick: r_t = -tau (Lam + k_t U'_t); no threshold left (tau = 0): |Lam| beyond the cone */
        y[offl + jc * dt + t] = tau != 0 ? -y[e + 1 + t] / tau - S->k_t * U[e + 1 + t]
                                         : y[e + 1 + t] == 0 ? 0 : y[e + 1 + t] > 0 ? -2 : 2;
    }
  }
}

int ls_reduced_step(ls_reduced *R, const ls_system *S, const mo_delassus *W, const double *WCC,
                    const double *U, double *y, double *pg, long *nfact, long *nreuse, int *fallback,
                    mo_ctx *ctx)
{
  const int nr = S->nr, dt = S->dt, nu = R->nu, n = R->nX, offl = nu + S->nM;
  int e, i, k, s, t, st, fresh, nks = 0, three = dt == 2 && R->nS > 0 && !R->coupled, gathered = 0;
  *fallback = 0;
  /* the coupled sliders' directions from the current iterate (or frozen by the damped loop):
     part of the matrix */
  if (R->coupled)
    for (s = 0; s < R->nS; s++) {
      int jc = R->sc[s];
      double D;
      if (dt == 1) ls_slide_dir(1, y + offl + jc, U + jc * nr + 1, S->h2_t, R->es + s, &D);
      for (t = 0; S->edir && t < dt; t++) R->es[s * dt + t] = S->edir[2 * S->cset[jc] + t];
      R->scode[s] = 3 * S->cset[jc] + 1 + (R->es[s * dt] > 0) - (R->es[s * dt] < 0);
      nks++;
    }
  /* a 3D direction is not in the key: a new factor for every matrix */
  fresh = (dt == 2 && nks > 0) || !factor_current(R, S, W, WCC, nks, &gathered);
  if (fresh && (st = red_factor(R, S, W, WCC, nks, gathered, ctx))) return st;
  if (R->kind == LS_RED_PINV && R->normal_null) {
    /* redundant normal impulses: the proximal term makes them unique (T136) */
    *fallback = 2;
    return MO_OK;
  }
  if ((R->kind == LS_RED_PINV && R->nS > 0) || R->kind == LS_RED_SINGULAR) {
    /* redundant constraints coupled to sliding directions: the dense path decides, or the
       proximal term when it is not on yet */
    *fallback = R->kind == LS_RED_SINGULAR && !(S->eps > 0) ? 2 : 1;
    return MO_OK;
  }
  if (fresh) (*nfact)++;
  else (*nreuse)++;
  if ((st = grow(&R->up, &R->cap_up, (size_t)nu, ctx)) || (st = grow(&R->bx, &R->cap_bx, (size_t)n, ctx)) ||
      (st = grow(&R->t1, &R->cap_t1, (size_t)n + 2 * (size_t)R->nS, ctx)))
    return st;
  /* r': the fixed impulses at 0, the sliders' at -tau Lam (2D: -tau e, coupled -mu e r_n: their
     Newton values), and U' = U + W_CC (r' - r) */
  memcpy(R->up, U, (size_t)nu * sizeof *R->up);
  for (e = 0, s = 0; e < nu; e++) {
    int jc = e / nr;
    double target, delta;
    if (R->cls[e] == LS_CLS_X) continue;
    if (R->cls[e] == LS_CLS_FIXED) target = 0;
    else if (R->coupled) {
      while (R->sc[s] != jc) s++;
      target = -S->mu[S->cset[jc]] * R->es[s * dt + (e % nr) - 1] * y[jc * nr];
    } else if (dt == 1) {
      double ev, D;
      ls_slide_dir(1, y + offl + jc, U + e, S->h2_t, &ev, &D);
      target = -tau_of(S, S->cset[jc]) * ev;
    } else
      target = -tau_of(S, S->cset[jc]) * y[offl + jc * 2 + (e % nr) - 1];
    delta = target - y[e];
    if (delta == 0) continue;
    for (i = 0; i < nu; i++) R->up[i] += WCC[(size_t)i * nu + e] * delta;
    y[e] = target;
  }
  for (i = 0; i < n; i++) R->bx[i] = -R->up[R->xc[i]];
  if (three) {
    double *b2 = R->t1 + n;
    if ((st = slider_blocks(R, S, WCC, ctx))) return st;
    memcpy(R->t1, R->bx, (size_t)n * sizeof *R->t1);
    factor_solve(R, R->t1, 1, n);
    if ((st = slider_step(R, S, WCC, U, y, b2, ctx))) return st;
    /* dr_X = t1 + Z T dLam */
    for (i = 0; i < n; i++) {
      double v = R->t1[i];
      for (k = 0; k < 2 * R->nS; k++) v += R->Z[(size_t)k * n + i] * tau_of(S, S->cset[R->sc[k / 2]]) * b2[k];
      R->bx[i] = v;
    }
    for (s = 0; s < R->nS; s++)
      for (t = 0; t < 2; t++) y[offl + R->sc[s] * 2 + t] += b2[2 * s + t];
  } else if ((st = ls_reduced_solve(R, S, y, R->bx, ctx)))
    return st;
  /* the new iterate: r_X += dr_X; the sliders' Lam (2D: e) and impulses (3D: -tau Lam_new,
     coupled: -mu e r_n of the new r_n) */
  for (i = 0; i < n; i++) y[R->xc[i]] += R->bx[i];
  for (e = 0, s = 0; e < nu; e++) {
    int jc = e / nr;
    if (R->cls[e] != LS_CLS_SLIDE) continue;
    if (R->coupled) {
      int t1 = (e % nr) - 1;
      while (R->sc[s] != jc) s++;
      y[offl + jc * dt + t1] = R->es[s * dt + t1];
      y[e] = -S->mu[S->cset[jc]] * R->es[s * dt + t1] * y[jc * nr];
    } else if (dt == 1) {
      double ev, D;
      ls_slide_dir(1, y + offl + jc, U + e, S->h2_t, &ev, &D); /* as for r' above: Lam = e */
      y[offl + jc] = ev;
    } else
      y[e] = -tau_of(S, S->cset[jc]) * y[offl + jc * 2 + (e % nr) - 1];
  }
  if (S->k_n != 0 || S->k_t != 0) {
    /* U at the new iterate: U' + W_CX dr_X (+ the 3D sliders' -tau dLam, the coupled sliders'
       -mu e dr_n) */
    for (i = 0; i < n; i++)
      for (e = 0; e < nu; e++) R->up[e] += WCC[(size_t)e * nu + R->xc[i]] * R->bx[i];
    for (s = 0; s < R->nS; s++)
      for (t = 0; t < dt; t++) {
        int c = R->sc[s] * nr + 1 + t;
        double dr = three ? -tau_of(S, S->cset[R->sc[s]]) * R->t1[n + 2 * s + t] : 0;
        if (R->coupled) {
          for (i = 0; i < n && R->xc[i] != R->sc[s] * nr; i++) continue;
          dr = -S->mu[S->cset[R->sc[s]]] * R->es[s * dt + t] * R->bx[i];
        }
        if (dr != 0)
          for (e = 0; e < nu; e++) R->up[e] += WCC[(size_t)e * nu + c] * dr;
      }
  }
  ls_reduced_multipliers(R, S, R->up, y, pg);
  return MO_OK;
}
