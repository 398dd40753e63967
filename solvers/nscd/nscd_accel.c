/* nscd_accel.c: the status-set step of the nscd back end (doc/theory.md §8.7, (T83)-(T84)): when
   the Gauss-Seidel sweeps stall with a stable set of statuses, the linear problem those
   statuses define is solved directly on the closed contacts, its rank measured (redundant
   constraints), and its solution kept when it satisfies the law; the round-off floor of the
   stopping rule (T85). */
#include "config.h"
#include "nscd.h"

#include <float.h>
#include <math.h>
#include <string.h>

extern void dgetrf_(const int *m, const int *n, double *a, const int *lda, int *ipiv, int *info);
extern void dgetrs_(const char *tr, const int *n, const int *nrhs, const double *a, const int *lda,
                    const int *ipiv, double *b, const int *ldb, int *info);
extern void dgecon_(const char *norm, const int *n, const double *a, const int *lda, const double *anorm,
                    double *rcond, double *work, int *iwork, int *info);
extern void dgelsd_(const int *m, const int *n, const int *nrhs, double *a, const int *lda, double *b,
                    const int *ldb, double *s, const double *rcond, int *rank, double *work,
                    const int *lwork, int *iwork, int *info);

/* The kind of a closed contact in the status-set problem: which reaction components are
   unknown (E_a, the columns) and which local velocities vanish (R_a, the rows). */
enum { K_OPEN = 0, K_NORMAL, K_STICK, K_SLIDE };

/* Reciprocal condition number (1-norm estimate) of the LU-factored A, A's 1-norm given. */
static double lu_rcond(int n, const double *LU, double anorm, double *w4, int *iw)
{
  double rc = 0;
  int info = 0;
  dgecon_("1", &n, LU, &n, &anorm, &rc, w4, iw, &info);
  return info ? 0 : rc;
}

int nscd_status_step(nscd_state *S, const mo_contact_problem *P, double *r, int *status, double tol,
                     double *res, nscd_accel_info *info, mo_ctx *ctx)
{
  const int d = S->d, dd = d * d;
  int k, a, i, j, n = 0, st = MO_OK, rank = 0, lu_info = 0;
  int *kind = NULL, *off = NULL, *ipiv = NULL, *iw = NULL;
  double *A = NULL, *rhs = NULL, *E = NULL, *LU = NULL, *w = NULL, *rnew = NULL, *sv = NULL;
  double anorm = 0, rc = 0, res1, rscale = 0, qscale = 0;
  /* 1. the kinds, from the current iterate, and the unknowns' offsets */
  kind = mo_malloc(ctx, ((size_t)S->nc + 1) * sizeof *kind);
  off = mo_malloc(ctx, ((size_t)S->nc + 1) * sizeof *off);
  E = mo_malloc(ctx, ((size_t)S->nc * (size_t)d + 1) * sizeof *E); /* slide: the fixed direction (1, mu e) */
  if (!kind || !off || !E) { st = MO_ENOMEM; goto done; }
  for (a = 0; a < S->nc; a++) kind[a] = K_OPEN;
  /* the scale of the reactions, for the contacts closed with a zero reaction */
  for (k = 0; k < S->nact; k++)
    for (i = 0; i < d; i++) {
      a = S->act[k];
      rscale += r[(size_t)a * d + i] * r[(size_t)a * d + i];
      qscale += S->scale[a] * S->scale[a] * P->b[(size_t)a * d + i] * P->b[(size_t)a * d + i];
    }
  rscale = fmax(sqrt(rscale), sqrt(qscale)) * fmax(NSCD_WEAK, 100 * S->p.tol);
  for (k = 0; k < S->nact; k++) {
    const double *ra = r + (size_t)(a = S->act[k]) * d, *Ua = S->U + (size_t)a * d;
    double rt = 0, mu = S->mu[a], ut = 0;
    for (i = 1; i < d; i++) {
      rt += ra[i] * ra[i];
      ut += Ua[i] * Ua[i];
    }
    rt = sqrt(rt);
    ut = sqrt(ut);
    /* closed: a compressive reaction, or none on a contact the kinematics hold closed (U_n = 0,
       and U_t = 0 with friction): a redundant constraint the sweeps left unloaded, which the
       minimum-norm selection may load (T84) */
    if (!(ra[0] > 0) && !(S->scale[a] * fabs(Ua[0]) <= rscale &&
                          (d == 1 || mu == 0 || S->scale[a] * ut <= rscale)))
      continue;
    off[a] = n;
    if (d == 1 || mu == 0) {
      kind[a] = K_NORMAL;
      n += 1;
    } else if (!(ra[0] > 0) || rt < mu * ra[0] * (1 - 1e-9)) {
      kind[a] = K_STICK;
      n += d;
    } else {
      kind[a] = K_SLIDE;
      E[(size_t)a * d] = 1;
      for (i = 1; i < d; i++) E[(size_t)a * d + i] = rt > 0 ? mu * ra[i] / rt : 0;
      n += 1;
    }
  }
  info->rows = n;
  info->rank = n;
  info->rcond = 1;
  info->accepted = 0;
  if (n == 0 || n > NSCD_ACCEL_MAX) goto done; /* nothing to do, or too large for a dense step */
  info->tried = 1;
  /* 2. A x = rhs: R_a (sum_b W_ab E_b x_b + q_a) = 0 over the closed contacts (column-major A) */
  A = mo_calloc(ctx, (size_t)n * (size_t)n, sizeof *A);
  LU = mo_malloc(ctx, (size_t)n * (size_t)n * sizeof *LU);
  rhs = mo_malloc(ctx, (size_t)n * sizeof *rhs);
  ipiv = mo_malloc(ctx, (size_t)n * sizeof *ipiv);
  iw = mo_malloc(ctx, (size_t)n * sizeof *iw);
  w = mo_malloc(ctx, 4 * (size_t)n * sizeof *w);
  rnew = mo_malloc(ctx, (size_t)S->m * sizeof *rnew);
  if (!A || !LU || !rhs || !ipiv || !iw || !w || !rnew) { st = MO_ENOMEM; goto done; }
  for (k = 0; k < S->nact; k++) {
    int nrow, row0;
    a = S->act[k];
    if (kind[a] == K_OPEN) continue;
    nrow = kind[a] == K_STICK ? d : 1;
    row0 = off[a];
    for (i = 0; i < nrow; i++) rhs[row0 + i] = -P->b[(size_t)a * d + i];
    for (j = 0; j < S->rcnt[a]; j++) {
      int b = S->rcol[a][j], c, ncol;
      const double *B = S->rval[a] + (size_t)j * (size_t)dd;
      if (kind[b] == K_OPEN) continue;
      ncol = kind[b] == K_STICK ? d : 1;
      for (i = 0; i < nrow; i++)
        for (c = 0; c < ncol; c++) {
          double v;
          if (kind[b] == K_STICK) v = B[i * d + c];
          else if (kind[b] == K_NORMAL) v = B[i * d];
          else {
            int l;
            v = 0;
            for (l = 0; l < d; l++) v += B[i * d + l] * E[(size_t)b * d + l];
          }
          A[(size_t)(off[b] + c) * n + row0 + i] = v;
        }
    }
  }
  for (j = 0; j < n; j++) {
    double cs = 0;
    for (i = 0; i < n; i++) cs += fabs(A[(size_t)j * n + i]);
    anorm = fmax(anorm, cs);
  }
  /* 3. LU when the matrix is well conditioned, else the minimum-norm solution (SVD) with its
     numerical rank: the closed constraints the bodies' dofs make independent (T84) */
  memcpy(LU, A, (size_t)n * (size_t)n * sizeof *LU);
  dgetrf_(&n, &n, LU, &n, ipiv, &lu_info);
  rc = lu_info ? 0 : lu_rcond(n, LU, anorm, w, iw);
  info->rcond = rc;
  if (rc > NSCD_RANK_TOL) {
    int one = 1, inf = 0;
    dgetrs_("N", &n, &one, LU, &n, ipiv, rhs, &n, &inf);
  } else {
    int one = 1, inf = 0, lwork = -1, liwork;
    double wq = 0, rcond = NSCD_RANK_TOL, *work;
    int *iwork;
    memcpy(LU, A, (size_t)n * (size_t)n * sizeof *LU);
    sv = mo_malloc(ctx, (size_t)n * sizeof *sv);
    if (!sv) { st = MO_ENOMEM; goto done; }
    dgelsd_(&n, &n, &one, LU, &n, rhs, &n, sv, &rcond, &rank, &wq, &lwork, &liwork, &inf);
    lwork = (int)wq + 1;
    liwork = 3 * n * (int)(log2((double)n + 1) + 2) + 11 * n + 1;
    work = mo_malloc(ctx, (size_t)lwork * sizeof *work);
    iwork = mo_malloc(ctx, (size_t)liwork * sizeof *iwork);
    if (!work || !iwork) { mo_free(work); mo_free(iwork); st = MO_ENOMEM; goto done; }
    dgelsd_(&n, &n, &one, LU, &n, rhs, &n, sv, &rcond, &rank, work, &lwork, iwork, &inf);
    mo_free(work);
    mo_free(iwork);
    if (inf) goto done;
    info->rank = rank;
    info->rcond = sv[0] > 0 ? sv[rank > 0 ? rank - 1 : 0] / sv[0] : 0;
    info->min_norm = 1;
  }
  /* 4. the reactions of the solution, checked against the law on the exact U */
  memcpy(rnew, r, (size_t)S->m * sizeof *rnew);
  for (k = 0; k < S->nact; k++) {
    double *rb = rnew + (size_t)(a = S->act[k]) * d;
    switch (kind[a]) {
    case K_OPEN: for (i = 0; i < d; i++) rb[i] = 0; break;
    case K_NORMAL: rb[0] = rhs[off[a]]; for (i = 1; i < d; i++) rb[i] = 0; break;
    case K_STICK: for (i = 0; i < d; i++) rb[i] = rhs[off[a] + i]; break;
    default: for (i = 0; i < d; i++) rb[i] = rhs[off[a]] * E[(size_t)a * d + i]; break;
    }
    if (!isfinite(rb[0]) || rb[0] < 0) goto rejected;
  }
  mo_delassus_mult(P->W, rnew, 0, S->U);
  for (i = 0; i < S->m; i++) S->U[i] += P->b[i];
  res1 = mo_fc_natural_map_subset(d, S->nact, S->act, S->mu, S->scale, rnew, S->U, sqrt(S->qs2));
  if (tol >= 0 && (res1 <= tol || res1 <= nscd_roundoff_floor(S, P, rnew))) {
    memcpy(r, rnew, (size_t)S->m * sizeof *r);
    for (k = 0; k < S->nact; k++) {
      a = S->act[k];
      status[a] = kind[a] == K_OPEN ? MO_CS_OPEN : kind[a] == K_STICK ? MO_CS_STICK : MO_CS_SLIDE;
    }
    *res = res1;
    info->accepted = 1;
  } else {
  rejected:
    /* not the solution (the statuses were not the final ones, or a reaction came out
       negative): the sweeps go on from where they were */
    mo_delassus_mult(P->W, r, 0, S->U);
    for (i = 0; i < S->m; i++) S->U[i] += P->b[i];
    info->accepted = 0;
  }
done:
  mo_free(kind); mo_free(off); mo_free(E); mo_free(A); mo_free(LU); mo_free(rhs); mo_free(ipiv);
  mo_free(iw); mo_free(w); mo_free(rnew); mo_free(sv);
  return st;
}

double nscd_roundoff_floor(const nscd_state *S, const mo_contact_problem *P, const double *r)
{
  const int d = S->d, dd = d * d;
  double f2 = 0, rn = 0, un = 0, den;
  int k, j, i, l;
  if (S->bodies) return 0;
  for (k = 0; k < S->nact; k++) {
    int a = S->act[k];
    double acc[3] = {0, 0, 0};
    for (i = 0; i < d; i++) acc[i] = fabs(P->b[(size_t)a * d + i]);
    for (j = 0; j < S->rcnt[a]; j++) {
      const double *B = S->rval[a] + (size_t)j * (size_t)dd, *rb = r + (size_t)S->rcol[a][j] * d;
      for (i = 0; i < d; i++)
        for (l = 0; l < d; l++) acc[i] += fabs(B[i * d + l] * rb[l]);
    }
    for (i = 0; i < d; i++) {
      double s = S->scale[a] * acc[i], u = S->scale[a] * S->U[(size_t)a * d + i];
      f2 += s * s;
      un += u * u;
      rn += r[(size_t)a * d + i] * r[(size_t)a * d + i];
    }
  }
  den = fmax(sqrt(S->qs2), fmax(sqrt(rn), sqrt(un)));
  /* U = W r + q is summed over the blocks of a row: its rounding error is a few units of
     DBL_EPSILON times |W| |r| + |q| (T85) */
  return den > 0 ? NSCD_ROUNDOFF * DBL_EPSILON * sqrt(f2) / den : 0;
}
