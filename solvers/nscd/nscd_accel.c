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
extern void dlaswp_(const int *n, double *a, const int *lda, const int *k1, const int *k2, const int *ipiv,
                    const int *incx);
extern void dtrsm_(const char *side, const char *uplo, const char *transa, const char *diag, const int *m,
                   const int *n, const double *alpha, const double *a, const int *lda, double *b, const int *ldb);
extern void dgemm_(const char *ta, const char *tb, const int *m, const int *n, const int *k, const double *alpha,
                   const double *a, const int *lda, const double *b, const int *ldb, const double *beta, double *c,
                   const int *ldc);
extern void dpotrf_(const char *uplo, const int *n, double *a, const int *lda, int *info);
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

/* LAPACK's LU layout (unit lower L, upper U, pivots ipiv) of the n x n column-major A in F (nscd.h). A
   symmetric positive definite A (a frictionless closed set: W_nn on it) is factored by Cholesky,
   A = C C^T (n^3/3 flops against dgetrf's 2n^3/3), and written as L = C D^-1, U = D C^T, D = diag(C),
   no pivots: what dgetrs, dgecon and the border (T160) read (T163). Otherwise, or when the
   Cholesky factorization breaks down, dgetrf. *info as dgetrf's. */
void nscd_factor_closed(int n, const double *A, double *F, int *ipiv, int sym, int *info)
{
  int i, j;
  memcpy(F, A, (size_t)n * (size_t)n * sizeof *F);
  if (sym) {
    dpotrf_("L", &n, F, &n, info);
    if (*info == 0) {
      for (j = 0; j < n; j++) {
        double *cj = F + (size_t)j * n, dj = cj[j];
        ipiv[j] = j + 1;
        for (i = j + 1; i < n; i++) {
          F[(size_t)i * n + j] = dj * cj[i]; /* U_ji = D_j C_ij */
          cj[i] /= dj;                       /* L_ij = C_ij / D_j */
        }
        cj[j] = dj * dj;
      }
      return;
    }
    memcpy(F, A, (size_t)n * (size_t)n * sizeof *F);
  }
  dgetrf_(&n, &n, F, &n, ipiv, info);
}

/* The closed contacts' kinds from a point (r, U). From the sweeps: closed when compressive, or
   with no reaction on a contact the kinematics hold closed (U_n = 0, and U_t = 0 with friction, to
   `tiny`): a redundant constraint the sweeps left unloaded, which the minimum-norm selection may
   load (T84); sticking inside the cone, sliding on its edge along r_t. From a status-set solution
   (`from_slip`): a closed contact opens when its reaction came out negative, an open one closes
   when it penetrates; sticking when it does not slip and r_t is in the cone, else sliding against
   the slip U_t (along r_t when it does not slip). Returns 1 when a kind or a direction changed. */
static int set_kinds(const nscd_state *S, const double *r, const double *U, double tiny, int from_slip, int *kind,
                     double *E)
{
  const int d = S->d;
  int k, i, changed = 0;
  for (k = 0; k < S->nact; k++) {
    const int a = S->act[k];
    const double *ra = r + (size_t)a * d, *Ua = U + (size_t)a * d, mu = nscd_mu(S, a);
    double rt = 0, ut = 0, e[3] = {1, 0, 0};
    int kd;
    for (i = 1; i < d; i++) {
      rt += ra[i] * ra[i];
      ut += Ua[i] * Ua[i];
    }
    rt = sqrt(rt);
    ut = sqrt(ut);
    if (from_slip ? (kind[a] != K_OPEN ? ra[0] < 0 : !(S->scale[a] * Ua[0] < -tiny))
                  : !(ra[0] > 0) && !(S->scale[a] * fabs(Ua[0]) <= tiny && (d == 1 || mu == 0 || S->scale[a] * ut <= tiny)))
      kd = K_OPEN;
    else if (d == 1 || mu == 0)
      kd = K_NORMAL;
    else if (from_slip ? !(S->scale[a] * ut > tiny) && !(rt > mu * ra[0]) : !(ra[0] > 0) || rt < mu * ra[0] * (1 - 1e-9))
      kd = K_STICK;
    else {
      /* sliding: r_t = mu r_n e, e along r_t, or (from a solution) against the slip U_t */
      kd = K_SLIDE;
      for (i = 1; i < d; i++)
        e[i] = from_slip && S->scale[a] * ut > tiny ? -mu * Ua[i] / ut : rt > 0 ? mu * ra[i] / rt : 0;
    }
    if (kd != kind[a]) changed = 1;
    else if (kd == K_SLIDE)
      for (i = 1; i < d; i++) changed |= fabs(e[i] - E[(size_t)a * d + i]) > 1e-12 * mu;
    kind[a] = kd;
    if (kd == K_SLIDE) for (i = 0; i < d; i++) E[(size_t)a * d + i] = e[i];
  }
  return changed;
}

void nscd_status_cache_free(nscd_state *S)
{
  mo_free(S->lu.kind);
  mo_free(S->lu.off);
  mo_free(S->lu.E);
  mo_free(S->lu.LU);
  mo_free(S->lu.ipiv);
  memset(&S->lu, 0, sizeof S->lu);
}

/* Whether the kept LU (T157) is the one of the kinds kind, E on P's W. */
static int cache_matches(const nscd_state *S, const mo_contact_problem *P, int n, const int *kind, const double *E)
{
  int a, i, d = S->d;
  if (!S->lu.valid || S->lu.n != n || S->lu.W != P->W || S->lu.wver != mo_delassus_version(P->W)) return 0;
  for (a = 0; a < S->nc; a++) {
    if (S->lu.kind[a] != kind[a]) return 0;
    if (kind[a] == K_SLIDE)
      for (i = 0; i < d; i++)
        if (S->lu.E[(size_t)a * d + i] != E[(size_t)a * d + i]) return 0;
  }
  return 1;
}

/* Keep the LU of the kinds kind, E (its factors are copied). */
static int cache_keep(nscd_state *S, const mo_contact_problem *P, int n, const int *kind, const int *off,
                      const double *E, const double *LU, const int *ipiv, double rcond, mo_ctx *ctx)
{
  size_t nn = (size_t)n * (size_t)n;
  void *q;
  S->lu.valid = 0;
  if (nn > S->lu.ncap) {
    mo_free(S->lu.LU);
    if (!(S->lu.LU = mo_malloc(ctx, nn * sizeof *S->lu.LU))) { S->lu.ncap = 0; return MO_ENOMEM; }
    if (!(q = mo_realloc(ctx, S->lu.ipiv, (size_t)n * sizeof *S->lu.ipiv))) return MO_ENOMEM;
    S->lu.ipiv = q;
    S->lu.ncap = nn;
  }
  if ((size_t)S->nc > S->lu.kcap) {
    if (!(q = mo_realloc(ctx, S->lu.kind, (size_t)S->nc * sizeof *S->lu.kind))) return MO_ENOMEM;
    S->lu.kind = q;
    if (!(q = mo_realloc(ctx, S->lu.off, (size_t)S->nc * sizeof *S->lu.off))) return MO_ENOMEM;
    S->lu.off = q;
    if (!(q = mo_realloc(ctx, S->lu.E, (size_t)S->nc * (size_t)S->d * sizeof *S->lu.E))) return MO_ENOMEM;
    S->lu.E = q;
    S->lu.kcap = (size_t)S->nc;
  }
  memcpy(S->lu.LU, LU, nn * sizeof *LU);
  memcpy(S->lu.ipiv, ipiv, (size_t)n * sizeof *ipiv);
  memcpy(S->lu.kind, kind, (size_t)S->nc * sizeof *kind);
  memcpy(S->lu.off, off, (size_t)S->nc * sizeof *off);
  memcpy(S->lu.E, E, (size_t)S->nc * (size_t)S->d * sizeof *E);
  S->lu.n = n;
  S->lu.W = P->W;
  S->lu.wver = mo_delassus_version(P->W);
  S->lu.rcond = rcond;
  S->lu.valid = 1;
  S->lu.builds++;
  return MO_OK;
}

/* The bordered LU (T160):
     P0 A11 = L11 U11,  U12 = L11^-1 P0 A12,  L21 = A21 U11^-1,  P2 (A22 - L21 U12) = L22 U22. */
void nscd_lu_border(int n, int n0, const double *A, const double *F0, double *LU, int *ipiv, int *lu_info)
{
  const int k = n - n0, one = 1;
  const double p1 = 1, m1 = -1;
  int j;
  for (j = 0; j < n0; j++) {
    memcpy(LU + (size_t)j * n, F0 + (size_t)j * n0, (size_t)n0 * sizeof *LU);
    memcpy(LU + (size_t)j * n + n0, A + (size_t)j * n + n0, (size_t)k * sizeof *LU);
  }
  for (j = n0; j < n; j++) memcpy(LU + (size_t)j * n, A + (size_t)j * n, (size_t)n * sizeof *LU);
  *lu_info = 0;
  if (k == 0 || n0 == 0) {
    if (n0 == 0) dgetrf_(&n, &n, LU, &n, ipiv, lu_info);
    return;
  }
  dlaswp_(&k, LU + (size_t)n0 * n, &n, &one, &n0, ipiv, &one);
  dtrsm_("L", "L", "N", "U", &n0, &k, &p1, LU, &n, LU + (size_t)n0 * n, &n);
  dtrsm_("R", "U", "N", "N", &k, &n0, &p1, LU, &n, LU + n0, &n);
  dgemm_("N", "N", &k, &k, &n0, &m1, LU + n0, &n, LU + (size_t)n0 * n, &n, &p1, LU + (size_t)n0 * n + n0, &n);
  dgetrf_(&k, &k, LU + (size_t)n0 * n + n0, &n, ipiv + n0, lu_info);
  if (*lu_info > 0) *lu_info += n0;
  dlaswp_(&n0, LU + n0, &n, &one, &k, ipiv + n0, &one);
  for (j = n0; j < n; j++) ipiv[j] += n0;
}

int nscd_status_step(nscd_state *S, const mo_contact_problem *P, double *r, int *status, double tol,
                     double *res, nscd_accel_info *info, int mode, mo_ctx *ctx)
{
  const int d = S->d, dd = d * d;
  int k, a, i, j, n, it, st = MO_OK, nmax = S->nact * d;
  int *kind = NULL, *off = NULL, *ipiv = NULL, *iw = NULL, *pkind = NULL, n0 = 0;
  double *A = NULL, *rhs = NULL, *E = NULL, *LU = NULL, *w = NULL, *rnew = NULL, *Unew = NULL, *sv = NULL;
  double *pE = NULL, *LU0 = NULL;
  double res1 = HUGE_VAL, resprev = HUGE_VAL, tiny = 0, qscale = 0;
  size_t acap = 0;
  info->accepted = 0;
  if (!nmax) return MO_OK;
  kind = mo_malloc(ctx, ((size_t)S->nc + 1) * sizeof *kind);
  off = mo_malloc(ctx, ((size_t)S->nc + 1) * sizeof *off);
  pkind = mo_malloc(ctx, ((size_t)S->nc + 1) * sizeof *pkind);
  E = mo_calloc(ctx, (size_t)S->nc * (size_t)d + 1, sizeof *E);
  pE = mo_malloc(ctx, ((size_t)S->nc * (size_t)d + 1) * sizeof *pE);
  rnew = mo_malloc(ctx, (size_t)S->m * sizeof *rnew);
  Unew = mo_malloc(ctx, (size_t)S->m * sizeof *Unew);
  if (!kind || !off || !pkind || !E || !pE || !rnew || !Unew) { st = MO_ENOMEM; goto done; }
  for (a = 0; a < S->nc; a++) kind[a] = K_OPEN;
  /* the scale of the reactions: a velocity below 100 tol of it (1e-9 at least), scaled, is zero */
  for (k = 0; k < S->nact; k++)
    for (i = 0; i < d; i++) {
      a = S->act[k];
      tiny += r[(size_t)a * d + i] * r[(size_t)a * d + i];
      qscale += S->scale[a] * S->scale[a] * P->b[(size_t)a * d + i] * P->b[(size_t)a * d + i];
    }
  tiny = fmax(sqrt(tiny), sqrt(qscale)) * fmax(NSCD_WEAK, 100 * S->p.tol);
  set_kinds(S, r, S->U, tiny, 0, kind, E);
  /* from the predictor (T163): the open contacts that U = W r + q drives into the obstacle close */
  if (mode == NSCD_STEP_PREDICT) set_kinds(S, r, S->U, tiny, 1, kind, E);
  memcpy(rnew, r, (size_t)S->m * sizeof *rnew);
  /* the status iteration: solve (T83) for the kinds, take the kinds of the solution, again, until
     the law holds or the kinds stop changing (a semismooth Newton on the closed set) */
  for (it = 0; it < NSCD_STATUS_ITER; it++) {
    double anorm = 0, rc;
    int rank = 0, lu_info = 0, border = n0 > 0, sym = 1;
    /* the last iteration's LU is bordered (T160) when this one only closes contacts: the kinds
       and directions of the contacts closed there unchanged; their unknowns keep their places,
       the new ones follow */
    for (k = 0; k < S->nact && border; k++) {
      a = S->act[k];
      if (pkind[a] == K_OPEN) continue;
      border = kind[a] == pkind[a];
      for (i = 0; border && kind[a] == K_SLIDE && i < d; i++) border = E[(size_t)a * d + i] == pE[(size_t)a * d + i];
    }
    for (n = border ? n0 : 0, k = 0; k < S->nact; k++) {
      a = S->act[k];
      if (border && pkind[a] != K_OPEN) continue;
      off[a] = n;
      n += kind[a] == K_OPEN ? 0 : kind[a] == K_STICK ? d : 1;
    }
    if (!border) n0 = 0;
    info->rows = n;
    info->rank = n;
    info->rcond = 1;
    info->min_norm = 0;
    if (n == 0 || n > NSCD_ACCEL_MAX) break; /* nothing to do, or too large for a dense step */
    if (cache_matches(S, P, n, kind, E)) {
      /* the closed set of the kept LU (T157): its right-hand side alone */
      int one = 1, inf = 0;
      info->tried = 1;
      info->rcond = S->lu.rcond;
      S->lu.hits++;
      n0 = 0;
      if (!rhs && !(rhs = mo_malloc(ctx, (size_t)nmax * sizeof *rhs))) { st = MO_ENOMEM; goto done; }
      /* its unknowns in its own order (a bordered LU's new contacts last) */
      for (k = 0; k < S->nact; k++) off[S->act[k]] = S->lu.off[S->act[k]];
      for (k = 0; k < S->nact; k++) {
        a = S->act[k];
        if (kind[a] == K_OPEN) continue;
        for (i = 0; i < (kind[a] == K_STICK ? d : 1); i++) rhs[off[a] + i] = -P->b[(size_t)a * d + i];
      }
      dgetrs_("N", &n, &one, S->lu.LU, &n, S->lu.ipiv, rhs, &n, &inf);
      goto solved;
    }
    if (mode == NSCD_STEP_CACHED) break;
    info->tried = 1;
    if ((size_t)n * (size_t)n > acap) {
      /* the closed set's matrix and its LU, n x n (grown when a status iteration closes more),
         and the last iteration's LU to border */
      double *L1;
      mo_free(A);
      acap = (size_t)n * (size_t)n;
      A = mo_malloc(ctx, acap * sizeof *A);
      L1 = mo_malloc(ctx, acap * sizeof *L1);
      if (L1 && n0) memcpy(L1, LU, (size_t)n0 * (size_t)n0 * sizeof *L1);
      mo_free(LU);
      mo_free(LU0);
      LU = mo_malloc(ctx, acap * sizeof *LU);
      LU0 = L1;
      if (!A || !LU || !LU0) { st = MO_ENOMEM; goto done; }
    } else if (n0) {
      double *t = LU0;
      LU0 = LU;
      LU = t;
    }
    if (!ipiv) {
      if (!rhs) rhs = mo_malloc(ctx, (size_t)nmax * sizeof *rhs);
      ipiv = mo_malloc(ctx, (size_t)nmax * sizeof *ipiv);
      iw = mo_malloc(ctx, (size_t)nmax * sizeof *iw);
      w = mo_malloc(ctx, 4 * (size_t)nmax * sizeof *w);
      sv = mo_malloc(ctx, (size_t)nmax * sizeof *sv);
      if (!rhs || !ipiv || !iw || !w || !sv) { st = MO_ENOMEM; goto done; }
    }
    /* A x = rhs: R_a (sum_b W_ab E_b x_b + q_a) = 0 over the closed contacts (column-major A);
       without friction A = W_nn over them, read from W's normal entries (T177) */
    memset(A, 0, (size_t)n * (size_t)n * sizeof *A);
    for (k = 0; k < S->nact && S->nonly; k++) {
      const double *wn;
      a = S->act[k];
      if (kind[a] == K_OPEN) continue;
      wn = S->wn + S->wnp[a];
      rhs[off[a]] = -P->b[(size_t)a * d];
      for (j = 0; j < S->rcnt[a]; j++) {
        int b = S->rcol[a][j];
        if (kind[b] != K_OPEN) A[(size_t)off[b] * n + off[a]] = wn[j];
      }
    }
    for (k = 0; k < S->nact && !S->nonly; k++) {
      int nrow, row0;
      a = S->act[k];
      if (kind[a] == K_OPEN) continue;
      sym &= kind[a] == K_NORMAL;
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
    /* LU when the matrix is well conditioned, else the minimum-norm solution (SVD) with its
       numerical rank: the closed constraints the bodies' dofs make independent (T84) */
    if (n0) nscd_lu_border(n, n0, A, LU0, LU, ipiv, &lu_info);
    else nscd_factor_closed(n, A, LU, ipiv, sym, &lu_info);
    rc = lu_info ? 0 : lu_rcond(n, LU, anorm, w, iw);
    n0 = 0;
    info->rcond = rc;
    if (rc > NSCD_RANK_TOL) {
      int one = 1, inf = 0;
      dgetrs_("N", &n, &one, LU, &n, ipiv, rhs, &n, &inf);
      if ((st = cache_keep(S, P, n, kind, off, E, LU, ipiv, rc, ctx))) goto done;
      n0 = n;
    } else {
      int one = 1, inf = 0, lwork = -1, liwork = 0, *iwork;
      double wq = 0, rcond = NSCD_RANK_TOL, *work;
      memcpy(LU, A, (size_t)n * (size_t)n * sizeof *LU);
      dgelsd_(&n, &n, &one, LU, &n, rhs, &n, sv, &rcond, &rank, &wq, &lwork, &liwork, &inf);
      lwork = (int)wq + 1;
      liwork = 3 * n * (int)(log2((double)n + 1) + 2) + 11 * n + 1;
      work = mo_malloc(ctx, (size_t)lwork * sizeof *work);
      iwork = mo_malloc(ctx, (size_t)liwork * sizeof *iwork);
      if (!work || !iwork) { mo_free(work); mo_free(iwork); st = MO_ENOMEM; goto done; }
      dgelsd_(&n, &n, &one, LU, &n, rhs, &n, sv, &rcond, &rank, work, &lwork, iwork, &inf);
      mo_free(work);
      mo_free(iwork);
      if (inf) break;
      info->rank = rank;
      info->rcond = sv[0] > 0 ? sv[rank > 0 ? rank - 1 : 0] / sv[0] : 0;
      info->min_norm = 1;
    }
  solved:
    /* the reactions of the solution, checked against the law on the exact U */
    for (k = 0; k < S->nact; k++) {
      double *rb = rnew + (size_t)(a = S->act[k]) * d;
      switch (kind[a]) {
      case K_OPEN: for (i = 0; i < d; i++) rb[i] = 0; break;
      case K_NORMAL: rb[0] = rhs[off[a]]; for (i = 1; i < d; i++) rb[i] = 0; break;
      case K_STICK: for (i = 0; i < d; i++) rb[i] = rhs[off[a] + i]; break;
      default: for (i = 0; i < d; i++) rb[i] = rhs[off[a]] * E[(size_t)a * d + i]; break;
      }
    }
    for (i = 0; i < S->m && isfinite(rnew[i]); i++) {}
    if (i < S->m) break;
    if (S->nonly) /* frictionless: the law reads U_n alone (T156) */
      nscd_normal_mult(S, P, rnew, Unew);
    else {
      mo_delassus_mult(P->W, rnew, 0, Unew);
      for (i = 0; i < S->m; i++) Unew[i] += P->b[i];
    }
    res1 = mo_fc_natural_map_subset_pairs(d, S->nact, S->act, S->mu, S->gkey, S->gpmu, S->scale, rnew, Unew, sqrt(S->qs2));
    if (tol >= 0 && (res1 <= tol || res1 <= nscd_roundoff_floor(S, P, rnew))) {
      info->accepted = 1;
      break;
    }
    /* the kinds of this solution: a negative reaction opens, a penetrating open contact closes,
       a sticking reaction outside the cone slides, a sliding one whose slip reverses sticks; as
       long as the residual decreases (undamped, the iteration can wander: on the box with
       friction 0.3 it went from 7.5e-5 to 6.1e-3 in 8 iterations) */
    memcpy(pkind, kind, (size_t)S->nc * sizeof *pkind);
    memcpy(pE, E, (size_t)S->nc * (size_t)d * sizeof *pE);
    if (tol < 0 || !(res1 < resprev) || !set_kinds(S, rnew, Unew, tiny, 1, kind, E)) break;
    resprev = res1;
  }
  if (info->accepted) {
    memcpy(r, rnew, (size_t)S->m * sizeof *r);
    memcpy(S->U, Unew, (size_t)S->m * sizeof *S->U);
    S->u_full = !S->nonly;
    for (k = 0; k < S->nact; k++) {
      a = S->act[k];
      status[a] = kind[a] == K_OPEN ? MO_CS_OPEN : kind[a] == K_STICK ? MO_CS_STICK : MO_CS_SLIDE;
    }
    *res = res1;
  } else {
    /* not the solution: the sweeps go on from where they were */
    mo_delassus_mult(P->W, r, 0, S->U);
    for (i = 0; i < S->m; i++) S->U[i] += P->b[i];
  }
done:
  mo_free(kind); mo_free(off); mo_free(pkind); mo_free(E); mo_free(pE); mo_free(A); mo_free(LU); mo_free(LU0);
  mo_free(rhs); mo_free(ipiv);
  mo_free(iw); mo_free(w); mo_free(rnew); mo_free(Unew); mo_free(sv);
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
