/* levelset_system.c: the multiplier spaces (P1 at nodes, P0 per slave facet, P1 at Gauss points)
   and the frozen-status system of the levelset back end, its residual and Jacobians
   (doc/theory.md §6.3, (T17)-(T20)). */
#include "config.h"
#include "levelset.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* --- multiplier spaces ------------------------------------------------------------------------- */

void ls_space_free(ls_space *A)
{
  if (!A) return;
  mo_free(A->rp); mo_free(A->ri); mo_free(A->rx);
  mo_free(A->cp); mo_free(A->ci); mo_free(A->cx);
  mo_free(A->pair); mo_free(A->kind);
  memset(A, 0, sizeof *A);
}

static int cmp_int(const void *a, const void *b)
{
  int x = *(const int *)a, y = *(const int *)b;
  return (x > y) - (x < y);
}

/* The slave facets and the slave nodes of pair k's Gauss points: P0 has one multiplier per facet,
   P1 one per node; P0 on triangles has about twice as many multipliers as the slave surface has
   nodes, more constraints than the normal displacements there can meet (the inf-sup condition
   fails, doc/theory.md (T195)). */
static int pair_counts(const mo_contact *C, int k, int *nfacet, int *nnode, mo_ctx *ctx)
{
  int nc = mo_contact_ncandidates(C), j, q, n = 0, nf = 0, *ids;
  *nfacet = *nnode = 0;
  if (!(ids = mo_malloc(ctx, ((size_t)nc * MO_FNODE_MAX + 1) * sizeof *ids))) return MO_ENOMEM;
  for (j = 0; j < nc; j++) {
    const mo_candidate *cd = mo_contact_candidate(C, j);
    const mo_cpoint *pt = mo_contact_point(C, cd->point);
    if (cd->pair != k || cd->point < 0 || pt->facet < 0) continue;
    for (q = 0; q < pt->nn; q++) ids[n++] = pt->node[q];
  }
  qsort(ids, (size_t)n, sizeof *ids, cmp_int);
  for (j = 0; j < n; j++) *nnode += j == 0 || ids[j] != ids[j - 1];
  n = 0;
  for (j = 0; j < nc; j++) {
    const mo_candidate *cd = mo_contact_candidate(C, j);
    const mo_cpoint *pt = mo_contact_point(C, cd->point);
    if (cd->pair == k && cd->point >= 0 && pt->facet >= 0) ids[n++] = pt->facet;
  }
  qsort(ids, (size_t)n, sizeof *ids, cmp_int);
  for (j = 0; j < n; j++) nf += j == 0 || ids[j] != ids[j - 1];
  *nfacet = nf;
  mo_free(ids);
  return MO_OK;
}

/* Build lambda_h(p_j) = sum_k A_jk lambda_k for every candidate (BDZ07 (65) collocated at the
   candidates, (66)-(67)):
   P1 at nodes (node collocation, concentrated or weighted reactions): one multiplier per
     candidate, A = I (the nodal values of a P1 field, or the dual-cell densities of J88);
   P0 per facet (Gauss collocation): one multiplier per slave facet, A_jk = 1 when Gauss point j
     lies on facet k (the patch test's space, BDZ07 §6.4);
   P1 at Gauss points: one multiplier per slave node, A_jk = N_k(p_j), the facet's shape values;
   auto takes it for Gauss collocation when P0 would have more multipliers than slave nodes
   (triangular facets, (T195)). */
int ls_space_build(ls_space *A, const mo_contact *C, int mode, mo_ctx *ctx)
{
  int nc = mo_contact_ncandidates(C), np = mo_contact_npairs(C), j, k, st = MO_OK, cap;
  int *key = NULL, *owner = NULL, nkey;
  memset(A, 0, sizeof *A);
  A->nc = nc;
  A->kind = mo_calloc(ctx, (size_t)np + 1, sizeof(int));
  A->rp = mo_calloc(ctx, (size_t)nc + 1, sizeof(int));
  cap = MO_FNODE_MAX * nc + 1;
  A->ri = mo_malloc(ctx, (size_t)cap * sizeof(int));
  A->rx = mo_malloc(ctx, (size_t)cap * sizeof(double));
  A->pair = mo_malloc(ctx, (size_t)cap * sizeof(int));
  key = mo_malloc(ctx, (size_t)cap * sizeof(int));
  owner = mo_malloc(ctx, (size_t)cap * sizeof(int));
  if (!A->kind || !A->rp || !A->ri || !A->rx || !A->pair || !key || !owner) { st = MO_ENOMEM; goto done; }
  /* the space of each pair */
  for (k = 0; k < np; k++) {
    const mo_contact_pair *pr = mo_contact_pair_get(C, k);
    int gauss = pr->colloc == MO_COLLOC_GAUSS;
    if (mode == LS_MULT_P0 && !gauss) {
      st = mo_error(ctx, MO_EINPUT, "contact.levelset.multipliers = \"p0\": pair '%s' collocates at "
                    "its nodes; P0 multipliers live on slave facets and need collocation = \"gauss\"",
                    pr->name);
      goto done;
    }
    A->kind[k] = mode == LS_MULT_AUTO ? (gauss ? LS_MULT_P0 : LS_MULT_P1) : mode;
    if (mode == LS_MULT_AUTO && gauss) {
      int nf, nn;
      if ((st = pair_counts(C, k, &nf, &nn, ctx))) goto done;
      if (nf > nn) A->kind[k] = LS_MULT_P1;
    }
  }
  /* rows, numbering the multipliers on the fly by (pair, key): key = candidate (P1 at nodes),
     slave facet (P0) or slave node (P1 at Gauss points); a linear search per pair is enough for
     the sizes the dense frozen-status system allows */
  nkey = 0;
  for (j = 0; j < nc; j++) {
    const mo_candidate *cd = mo_contact_candidate(C, j);
    const mo_cpoint *pt = mo_contact_point(C, cd->point);
    int kind = A->kind[cd->pair], n = 0, keys[MO_FNODE_MAX], q, m;
    double vals[MO_FNODE_MAX];
    if (cd->point < 0) { st = mo_error(ctx, MO_EINTERNAL, "levelset: candidate %d has no point", j); goto done; }
    if (kind == LS_MULT_P0) { keys[0] = pt->facet; vals[0] = 1; n = 1; }
    else if (pt->facet >= 0) { /* P1 at a Gauss point: the slave shape values */
      for (q = 0; q < pt->nn; q++) if (pt->N[q] != 0) { keys[n] = pt->node[q]; vals[n++] = pt->N[q]; }
    } else { keys[0] = -1 - j; vals[0] = 1; n = 1; } /* P1 at nodes: its own multiplier */
    if (kind == LS_MULT_P0 && pt->facet < 0) {
      st = mo_error(ctx, MO_EINTERNAL, "levelset: Gauss candidate %d has no slave facet", j);
      goto done;
    }
    for (q = 0; q < n; q++) {
      int found = -1;
      if (keys[q] >= 0)
        for (m = nkey - 1; m >= 0; m--)
          if (key[m] == keys[q] && owner[m] == cd->pair) { found = m; break; }
      if (found < 0) {
        if (nkey == cap) { st = mo_error(ctx, MO_EINTERNAL, "levelset: multiplier table overflow"); goto done; }
        key[nkey] = keys[q];
        owner[nkey] = cd->pair;
        found = nkey++;
      }
      A->ri[A->rp[j] + q] = found;
      A->rx[A->rp[j] + q] = vals[q];
    }
    A->rp[j + 1] = A->rp[j] + n;
  }
  A->nm = nkey;
  for (k = 0; k < nkey; k++) A->pair[k] = owner[k];
  /* columns (the transpose) */
  A->cp = mo_calloc(ctx, (size_t)nkey + 1, sizeof(int));
  A->ci = mo_malloc(ctx, ((size_t)A->rp[nc] + 1) * sizeof(int));
  A->cx = mo_malloc(ctx, ((size_t)A->rp[nc] + 1) * sizeof(double));
  if (!A->cp || !A->ci || !A->cx) { st = MO_ENOMEM; goto done; }
  for (j = 0; j < A->rp[nc]; j++) A->cp[A->ri[j] + 1]++;
  for (k = 0; k < nkey; k++) A->cp[k + 1] += A->cp[k];
  {
    int *next = owner, q; /* reuse: next free slot of each column */
    for (k = 0; k < nkey; k++) next[k] = A->cp[k];
    for (j = 0; j < nc; j++)
      for (q = A->rp[j]; q < A->rp[j + 1]; q++) {
        int p = next[A->ri[q]]++;
        A->ci[p] = j;
        A->cx[p] = A->rx[q];
      }
  }
done:
  mo_free(key);
  mo_free(owner);
  if (st) ls_space_free(A);
  return st;
}

/* --- the frozen-status system ---------------------------------------------------------------------- */

void ls_system_free(ls_system *S)
{
  if (!S) return;
  mo_free(S->cset); mo_free(S->mset); mo_free(S->cpos); mo_free(S->mpos);
  mo_free(S->Z); mo_free(S->F); mo_free(S->Jy); mo_free(S->JU); mo_free(S->Fmag);
  S->cset = S->mset = S->cpos = S->mpos = NULL;
  S->Z = S->F = S->Jy = S->JU = S->Fmag = NULL;
  S->cap_c = S->cap_cp = S->cap_m = S->cap_mp = S->cap_f = S->cap_fm = S->cap_jy = S->cap_ju = 0;
  S->jac = 0;
}

/* The projection of Remark 4 restricted to Cset (T19): Z = A_C G^-1 A_C^T Omega_C with
   G = A_C^T Omega_C A_C, so that (Z U)_j is the Omega-weighted L2 projection of U on the
   multiplier space over the contact set, evaluated at candidate j. */
static int build_projection(ls_system *S, const ls_space *A, mo_ctx *ctx)
{
  int nC = S->nC, nM = S->nM, jc, mi, q, q2, st = MO_OK;
  double *G = NULL, *B = NULL;
  int *ipiv = NULL;
  mo_free(S->Z);
  S->Z = mo_calloc(ctx, (size_t)nC * (size_t)nC + 1, sizeof(double));
  G = mo_calloc(ctx, (size_t)nM * (size_t)nM + 1, sizeof(double));
  B = mo_calloc(ctx, (size_t)nM * (size_t)nC + 1, sizeof(double));
  ipiv = mo_malloc(ctx, ((size_t)nM + 1) * sizeof(int));
  if (!S->Z || !G || !B || !ipiv) { st = MO_ENOMEM; goto done; }
  /* G and B = A_C^T Omega_C (nM x nC, column-major so that each column is a right-hand side) */
  for (jc = 0; jc < nC; jc++) {
    int j = S->cset[jc];
    if (!S->sv[j]) continue; /* Omega S: the closed candidates only */
    for (q = A->rp[j]; q < A->rp[j + 1]; q++) {
      int a = S->mpos[A->ri[q]];
      if (a < 0) continue;
      B[(size_t)jc * nM + a] += A->rx[q] * S->w[j];
      for (q2 = A->rp[j]; q2 < A->rp[j + 1]; q2++) {
        int b = S->mpos[A->ri[q2]];
        if (b >= 0) G[(size_t)a * nM + b] += A->rx[q] * S->w[j] * A->rx[q2];
      }
    }
  }
  for (mi = 0; mi < nM; mi++)
    if (G[(size_t)mi * nM + mi] == 0) G[(size_t)mi * nM + mi] = 1; /* no contact point: unused */
  /* B <- G^-1 B: G is symmetric, so its row-major storage is its column-major one */
  {
    extern void dgesv_(const int *n, const int *nrhs, double *a, const int *lda, int *ipiv,
                       double *b, const int *ldb, int *info);
    int n = nM, nrhs = nC, info = 0;
    if (n > 0 && nrhs > 0) dgesv_(&n, &nrhs, G, &n, ipiv, B, &n, &info);
    if (info != 0) {
      st = mo_error(ctx, MO_ESINGULAR, "levelset: the multiplier mass matrix over the contact set is "
                    "singular (LAPACK dgesv info %d)", info);
      goto done;
    }
  }
  /* Z = A_C (G^-1 A_C^T Omega_C) */
  for (jc = 0; jc < nC; jc++) {
    int j = S->cset[jc], kc;
    if (!S->sv[j]) continue;
    for (q = A->rp[j]; q < A->rp[j + 1]; q++) {
      int a = S->mpos[A->ri[q]];
      if (a < 0) continue;
      for (kc = 0; kc < nC; kc++) S->Z[(size_t)jc * nC + kc] += A->rx[q] * B[(size_t)kc * nM + a];
    }
  }
done:
  mo_free(G);
  mo_free(B);
  mo_free(ipiv);
  return st;
}

/* Grow an array kept in S to n entries of `size` bytes. */
static int sys_grow(void **p, size_t *cap, size_t n, size_t size, mo_ctx *ctx)
{
  void *a;
  if (n <= *cap && *p) return MO_OK;
  if (!(a = mo_realloc(ctx, *p, (n + 1) * size))) return MO_ENOMEM;
  *p = a;
  *cap = n;
  return MO_OK;
}

int ls_system_setup(ls_system *S, const ls_space *A, int nc, mo_ctx *ctx)
{
  int j, q, st;
  size_t ny, nu;
  if ((st = sys_grow((void **)&S->cset, &S->cap_c, (size_t)nc, sizeof(int), ctx)) ||
      (st = sys_grow((void **)&S->cpos, &S->cap_cp, (size_t)nc, sizeof(int), ctx)) ||
      (st = sys_grow((void **)&S->mset, &S->cap_m, (size_t)A->nm, sizeof(int), ctx)) ||
      (st = sys_grow((void **)&S->mpos, &S->cap_mp, (size_t)A->nm, sizeof(int), ctx)))
    return st;
  mo_free(S->Z);
  S->Z = NULL;
  S->nC = S->nM = 0;
  for (q = 0; q < A->nm; q++) S->mpos[q] = -1;
  for (j = 0; j < nc; j++) {
    S->cpos[j] = -1;
    if (!S->su[j]) continue;
    /* every multiplier seen by a candidate of S_u = 1 is an unknown (T18) */
    for (q = A->rp[j]; q < A->rp[j + 1]; q++)
      if (S->mpos[A->ri[q]] < 0) {
        S->mpos[A->ri[q]] = S->nM;
        S->mset[S->nM++] = A->ri[q];
      }
    S->cpos[j] = S->nC;
    S->cset[S->nC++] = j;
  }
  S->ny = S->nC * S->nr + S->nM * (1 + S->dt);
  ny = (size_t)S->ny;
  nu = (size_t)S->nC * (size_t)S->nr;
  S->jac = 0;
  if ((st = sys_grow((void **)&S->F, &S->cap_f, ny, sizeof(double), ctx)) ||
      (st = sys_grow((void **)&S->Fmag, &S->cap_fm, ny, sizeof(double), ctx)))
    return st;
  (void)nu;
  if (S->projected && S->k_n != 0 && S->nC > 0 && (st = build_projection(S, A, ctx))) return st;
  return MO_OK;
}

int ls_system_jacobians(ls_system *S, mo_ctx *ctx)
{
  size_t ny = (size_t)S->ny, nu = (size_t)S->nC * (size_t)S->nr;
  int st;
  if ((st = sys_grow((void **)&S->Jy, &S->cap_jy, ny * ny, sizeof(double), ctx)) ||
      (st = sys_grow((void **)&S->JU, &S->cap_ju, ny * nu, sizeof(double), ctx)))
    return st;
  S->jac = 1;
  return MO_OK;
}

void ls_system_eval(ls_system *S, const ls_space *A, const double *y, const double *U,
                    const double *Umag)
{
  const int nr = S->nr, dt = S->dt, nC = S->nC, nM = S->nM, ny = S->ny, nu = nC * nr;
  const int offp = nC * nr, offl = offp + nM;
  const double c = S->c;
  double *F = S->F, *Jy = S->jac ? S->Jy : NULL, *JU = S->jac ? S->JU : NULL, *Fm = S->Fmag;
  int jc, mi, q, q2, t, s, k;
  memset(F, 0, (size_t)ny * sizeof(double));
  memset(Fm, 0, (size_t)ny * sizeof(double));
  if (Jy) {
    memset(Jy, 0, (size_t)ny * (size_t)ny * sizeof(double));
    memset(JU, 0, (size_t)ny * (size_t)nu * sizeof(double));
  }
  /* without Jacobians (S->jac = 0: the reduced path needs the residual only) their entries are
     neither computed nor stored */
#define JY(e, col, v) do { if (Jy) Jy[(size_t)(e) * (size_t)ny + (size_t)(col)] += (v); } while (0)
#define JUU(e, col, v) do { if (JU) JU[(size_t)(e) * (size_t)nu + (size_t)(col)] += (v); } while (0)
  /* impulses of the contact set: (T17) */
  for (jc = 0; jc < nC; jc++) {
    int j = S->cset[jc], e = jc * nr;
    double wj = S->w[j], ph = 0, phm = 0, zu = 0, zm = 0;
    if (!S->sv[j]) { /* S_v = 0: no normal impulse (BDZ07 (66)) */
      F[e] = y[e];
      Fm[e] = fabs(y[e]);
      JY(e, e, 1);
      goto tangent;
    }
    for (q = A->rp[j]; q < A->rp[j + 1]; q++) {
      int a = S->mpos[A->ri[q]];
      if (a < 0) continue;
      ph += A->rx[q] * y[offp + a];
      phm += fabs(A->rx[q] * y[offp + a]);
      JY(e, offp + a, -(c * wj * A->rx[q]));
    }
    if (S->k_n != 0) {
      if (S->Z) {
        for (k = 0; k < nC; k++) {
          double z = S->Z[(size_t)jc * nC + k];
          zu += z * U[k * nr];
          zm += fabs(z) * Umag[k * nr];
          JUU(e, k * nr, c * wj * S->k_n * z);
        }
      } else {
        zu = U[e];
        zm = Umag[e];
        JUU(e, e, c * wj * S->k_n);
      }
    }
    /* r_n = c w (lambda_h - k_n (Z U'_n))  (BDZ07 (66) with (37); core signs, (T13)) */
    F[e] = y[e] - c * wj * (ph - S->k_n * zu);
    Fm[e] = fabs(y[e]) + c * wj * (phm + S->k_n * zm);
    JY(e, e, 1);
  tangent:
    if (!dt) continue;
    {
      double mu = S->mu[j], pg = S->pg[j], lam[2], ev[2], D[4], tau;
      int phi = ls_phi(S, j);
      ls_lam_at(S, A, y, j, lam);
      tau = c * wj * mu * pg;
      if (phi && !S->sf[j]) ls_slide_dir(dt, lam, U + e + 1, S->h2_t, ev, D);
      for (t = 0; t < dt; t++) {
        int e2 = e + 1 + t;
        JY(e2, e2, 1);
        if (!phi) { /* no threshold: no friction force */
          F[e2] = y[e2];
          Fm[e2] = fabs(y[e2]);
          continue;
        }
        if (S->sf[j]) {
          /* stick: r_t = -c w mu p^g (Lam_h + k_t U'_t)  (BDZ07 (42) with (49)) */
          F[e2] = y[e2] + tau * (lam[t] + S->k_t * U[e + 1 + t]);
          Fm[e2] = fabs(y[e2]) + fabs(tau) * (fabs(lam[t]) + S->k_t * Umag[e + 1 + t]);
          for (q = A->rp[j]; q < A->rp[j + 1]; q++) {
            int a = S->mpos[A->ri[q]];
            if (a >= 0) JY(e2, offl + a * dt + t, tau * A->rx[q]);
          }
          JUU(e2, e + 1 + t, tau * S->k_t);
        } else {
          /* slide: r_t = -c w mu p^g G / |G|  (BDZ07 (42)) */
          F[e2] = y[e2] + tau * ev[t];
          Fm[e2] = fabs(y[e2]) + fabs(tau);
          for (s = 0; s < dt; s++) {
            for (q = A->rp[j]; q < A->rp[j + 1]; q++) {
              int a = S->mpos[A->ri[q]];
              if (a >= 0) JY(e2, offl + a * dt + s, tau * D[t * dt + s] * A->rx[q]);
            }
            JUU(e2, e + 1 + s, tau * D[t * dt + s] * S->h2_t);
          }
        }
      }
    }
  }
  /* the weak Signorini-Moreau equation of every multiplier: (T18), BDZ07 (67) */
  for (mi = 0; mi < nM; mi++) {
    int m = S->mset[mi], e = offp + mi;
    for (q = A->cp[m]; q < A->cp[m + 1]; q++) {
      int j = A->ci[q], kc = S->cpos[j];
      double wa = S->w[j] * A->cx[q];
      if (kc >= 0 && S->sv[j]) {
        F[e] += wa * U[kc * nr];
        Fm[e] += fabs(wa) * Umag[kc * nr];
        JUU(e, kc * nr, wa);
      } else {
        double ph = 0, phm = 0;
        for (q2 = A->rp[j]; q2 < A->rp[j + 1]; q2++) {
          int b = S->mpos[A->ri[q2]];
          if (b < 0) continue;
          ph += A->rx[q2] * y[offp + b];
          phm += fabs(A->rx[q2] * y[offp + b]);
          JY(e, offp + b, wa * A->rx[q2] / S->h_n);
        }
        F[e] += wa * ph / S->h_n;
        Fm[e] += fabs(wa) * phm / S->h_n;
      }
    }
  }
  /* the weak Coulomb equation of every friction semi-multiplier: (T20), BDZ07 (44) */
  for (mi = 0; dt && mi < nM; mi++) {
    int m = S->mset[mi];
    for (q = A->cp[m]; q < A->cp[m + 1]; q++) {
      int j = A->ci[q], kc = S->cpos[j];
      double wa = S->w[j] * A->cx[q], mu = S->mu[j], pg = S->pg[j], lam[2], ev[2], D[4];
      int phi = kc >= 0 && ls_phi(S, j);
      ls_lam_at(S, A, y, j, lam);
      if (phi && !S->sf[j]) ls_slide_dir(dt, lam, U + kc * nr + 1, S->h2_t, ev, D);
      for (t = 0; t < dt; t++) {
        int e = offl + mi * dt + t;
        if (!phi) { /* free of friction: Lam = 0 */
          F[e] += wa * lam[t];
          Fm[e] += fabs(wa * lam[t]);
          for (q2 = A->rp[j]; q2 < A->rp[j + 1]; q2++) {
            int b = S->mpos[A->ri[q2]];
            if (b >= 0) JY(e, offl + b * dt + t, wa * A->rx[q2]);
          }
        } else if (S->sf[j]) {
          /* stick: (S_f / h1) (Lam - (Lam + h1 U'_t)) = -U'_t, weighted by mu p^g */
          double wg = wa * mu * pg;
          F[e] -= wg * U[kc * nr + 1 + t];
          Fm[e] += fabs(wg) * Umag[kc * nr + 1 + t];
          JUU(e, kc * nr + 1 + t, -(wg));
        } else {
          /* slide: ((1 - S_f) / h2) (Lam - G / |G|), weighted by mu p^g */
          double wg = wa * mu * pg / S->h2_t;
          F[e] += wg * (lam[t] - ev[t]);
          Fm[e] += fabs(wg) * (fabs(lam[t]) + 1);
          for (s = 0; s < dt; s++) {
            for (q2 = A->rp[j]; q2 < A->rp[j + 1]; q2++) {
              int b = S->mpos[A->ri[q2]];
              if (b >= 0) JY(e, offl + b * dt + s, wg * ((t == s) - D[t * dt + s]) * A->rx[q2]);
            }
            JUU(e, kc * nr + 1 + s, -(wg * D[t * dt + s] * S->h2_t));
          }
        }
      }
    }
  }
#undef JY
#undef JUU
}

int ls_system_converged(const ls_system *S, double tol)
{
  /* the equations of y's three blocks (impulses, pressures, semi-multipliers) have their own
     units; an equation whose terms are all at round-off of its block's largest (an open
     candidate's r_n = 0, reached to 1e-35 rather than 0 through the Schur complement) passes:
     a relative test alone would never pass it */
  int nu = S->nC * S->nr, lo[4], b, e;
  lo[0] = 0;
  lo[1] = nu;
  lo[2] = nu + S->nM;
  lo[3] = S->ny;
  for (b = 0; b < 3; b++) {
    double fmax = 0, floor;
    for (e = lo[b]; e < lo[b + 1]; e++)
      if (S->Fmag[e] > fmax) fmax = S->Fmag[e];
    floor = 1e-14 * fmax;
    for (e = lo[b]; e < lo[b + 1]; e++)
      if (!(fabs(S->F[e]) <= tol * S->Fmag[e] || fabs(S->F[e]) <= floor)) return 0;
  }
  return 1;
}
