/* step.c: the theta-scheme, Newmark and quasi-static steps on free dofs with a factored
   iteration matrix (nonlinear steps: newton.c). */
#include "config.h"
#include <moreau/body.h>
#include <moreau/material.h>
#include <moreau/parallel.h>
#include <moreau/step.h>
#include "step_internal.h"
#include "metrics.h"

#include <gsl/gsl_eigen.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

int mo_state_alloc(const mo_scene *sc, mo_state *s, mo_ctx *ctx)
{
  size_t n = (size_t)(sc->ndof ? sc->ndof : 1);
  memset(s, 0, sizeof *s);
  s->u = mo_calloc(ctx, n, sizeof(double));
  s->v = mo_calloc(ctx, n, sizeof(double));
  s->f = mo_calloc(ctx, n, sizeof(double));
  /* the reactions live on prescribed dofs: none on a scene of rigid bodies and obstacles without
     any (T245), where nothing reads them (a probe observes a deformable body) */
  if (sc->npresc || sc->nfe_dof) s->reac = mo_calloc(ctx, n, sizeof(double));
  if (sc->time.scheme == MO_SCHEME_NEWMARK) s->a = mo_calloc(ctx, n, sizeof(double));
  if (sc->nq) s->q = mo_calloc(ctx, sc->nq, sizeof(double));
  if (sc->norient) s->orient = mo_calloc(ctx, 4 * (size_t)sc->norient, sizeof(double));
  if (!s->u || !s->v || !s->f || ((sc->npresc || sc->nfe_dof) && !s->reac) ||
      (sc->time.scheme == MO_SCHEME_NEWMARK && !s->a) || (sc->nq && !s->q) || (sc->norient && !s->orient)) {
    mo_state_release(s);
    return MO_ENOMEM;
  }
  return MO_OK;
}

void mo_state_release(mo_state *s)
{
  mo_free(s->u);
  mo_free(s->v);
  mo_free(s->a);
  mo_free(s->f);
  mo_free(s->reac);
  mo_free(s->q);
  mo_free(s->orient);
  memset(s, 0, sizeof *s);
}

int mo_state_copy(const mo_scene *sc, const mo_state *src, mo_state *dst)
{
  size_t n = (size_t)sc->ndof * sizeof(double);
  dst->t = src->t;
  dst->step = src->step;
  dst->wext = src->wext;
  dst->wsupport = src->wsupport;
  dst->wcontact = src->wcontact;
  dst->psi = src->psi;
  dst->wplastic = src->wplastic;
  if (sc->nq && src->q && dst->q) memcpy(dst->q, src->q, sc->nq * sizeof(double));
  if (sc->norient && src->orient && dst->orient) memcpy(dst->orient, src->orient, 4 * (size_t)sc->norient * sizeof(double));
  memcpy(dst->u, src->u, n);
  memcpy(dst->v, src->v, n);
  memcpy(dst->f, src->f, n);
  if (src->reac && dst->reac) memcpy(dst->reac, src->reac, n);
  if (src->a && dst->a) memcpy(dst->a, src->a, n);
  return MO_OK;
}

static double dot(const double *a, const double *b, int n)
{
  double s = 0;
  int i;
  for (i = 0; i < n; i++) s += a[i] * b[i];
  return s;
}

/* Whether products with K and M are summed over the ranks: K and M in parts, and some nodal dofs
   (a scene of rigid bodies only has K and M empty on every rank, the sums all zeros: (T233)). */
static inline int parts_summed(const mo_scene *sc) { return sc->kpart && sc->nfe_dof > 0; }

/* x^T A x / 2 over the first n rows; with K and M in parts (T200) the sum over the ranks of the
   parts' (one sum of one value): work then holds this rank's A_r x only. */
static double half_form(const mo_scene *sc, const mo_csc *A, const double *x, int n, double *work)
{
  double e;
  mo_csc_gaxpy(A, 1, x, 0, work);
  e = 0.5 * dot(x, work, n);
  if (parts_summed(sc)) mo_par_sum(&e, 1, sc->pctx);
  return e;
}

double mo_energy_kinetic(const mo_scene *sc, const mo_state *s, double *work)
{
  double e = 0;
  if (!sc->M) return 0;
  if (sc->nfe_dof) e = half_form(sc, sc->M, s->v, sc->nfe_dof, work);
  return e + mo_rigid_kinetic(sc, s);
}

int mo_energy_needs_work(const mo_scene *sc)
{
  return sc->nfe_dof || sc->kpart || (sc->K && mo_csc_nnz(sc->K));
}

double mo_energy_elastic(const mo_scene *sc, const double *u, double *work)
{
  if (!mo_energy_needs_work(sc)) {
    /* K has no entry (T249): K u is +0 everywhere, and x^T (K u) / 2 its sum, u_i 0 in turn
       (a non-finite u_i gives NaN, as the product with K would). Every term u_i 0 of a finite u_i
       is +0 or -0 and a sum from +0 of such terms stays +0 (round to nearest), so the sum is formed
       from the first non-finite u_i on, found by a scan without the chain of dependent additions
       that made this a pass of one addition's latency a dof at 10^5 grains (T314) */
    double e = 0;
    int i = 0;
    while (i < sc->ndof && isfinite(u[i])) i++;
    for (; i < sc->ndof; i++) e += u[i] * 0.0;
    return 0.5 * e;
  }
  return half_form(sc, sc->K, u, sc->ndof, work);
}

double mo_energy_stored(const mo_scene *sc, const mo_state *s, double *work)
{
  return mo_energy_elastic(sc, s->u, work) + (sc->nonlinear ? s->psi : 0);
}

void mo_stepper_free(mo_stepper *S)
{
  if (!S) return;
  mo_csc_free(S->Wfull);
  mo_csc_free(S->W);
  mo_linsolver_free(S->ls);
  if (S->rhs != S->w1) mo_free(S->rhs);
  mo_free(S->xf);
  mo_free(S->w1);
  mo_free(S->w2);
  mo_free(S->w3);
  mo_free(S->uprev);
  mo_free(S->ld_lo);
  mo_free(S->hd0);
  mo_free(S->fconst);
  mo_free(S->ld_l);
  mo_free(S->ld_v);
  mo_free(S->ld_a);
  mo_free(S->ld_a0);
  mo_free(S->vprev);
  mo_free(S->fprev);
  mo_tangent_release(S);
  mo_free(S->blk_body);
  mo_free(S->blk_rig);
  mo_free(S->blk_of);
  mo_free(S->blk_off);
  mo_free(S->blk_loc);
  mo_free(S->blk_ioff);
  mo_free(S->blk_inv);
  mo_free(S->rig_M);
  mo_free(S->gyro);
  mo_csc_free(S->Wall);
  mo_free(S->last);
  mo_free(S->islast);
  mo_free(S->ysplit);
  mo_free(S->cw);
  mo_free(S);
}

/* --- the rigid blocks of What (doc/theory.md (T70)) ------------------------------------------ */

/* Invert the SPD n x n matrix A (row-major) into X by Gauss-Jordan with partial pivoting;
   MO_ESINGULAR when a pivot vanishes. */
static int small_inverse(int n, const double *A, double *X)
{
  double a[36], piv;
  int i, j, k;
  memcpy(a, A, (size_t)(n * n) * sizeof *a);
  for (i = 0; i < n; i++)
    for (j = 0; j < n; j++) X[i * n + j] = i == j;
  for (k = 0; k < n; k++) {
    int p = k;
    for (i = k + 1; i < n; i++)
      if (fabs(a[i * n + k]) > fabs(a[p * n + k])) p = i;
    if (!(fabs(a[p * n + k]) > 0)) return MO_ESINGULAR;
    for (j = 0; j < n && p != k; j++) {
      double t = a[k * n + j]; a[k * n + j] = a[p * n + j]; a[p * n + j] = t;
      t = X[k * n + j]; X[k * n + j] = X[p * n + j]; X[p * n + j] = t;
    }
    piv = a[k * n + k];
    for (j = 0; j < n; j++) { a[k * n + j] /= piv; X[k * n + j] /= piv; }
    for (i = 0; i < n; i++) {
      double f = a[i * n + k];
      if (i == k || f == 0) continue;
      for (j = 0; j < n; j++) { a[i * n + j] -= f * a[k * n + j]; X[i * n + j] -= f * X[k * n + j]; }
    }
  }
  return MO_OK;
}

/* 1 when a 3D body's inertia is not a multiple of the identity (its block turns with it). */
static int anisotropic(const mo_body *B)
{
  const double *J = B->J;
  double t = fabs(J[0]) + fabs(J[4]) + fabs(J[8]);
  return fabs(J[1]) + fabs(J[2]) + fabs(J[3]) + fabs(J[5]) + fabs(J[6]) + fabs(J[7]) > 1e-14 * t ||
         fabs(J[0] - J[4]) > 1e-14 * t || fabs(J[0] - J[8]) > 1e-14 * t;
}

/* 1 when the n x n matrix M (row-major) is diagonal. */
static int is_diagonal(int n, const double *M)
{
  int i, j;
  for (i = 0; i < n; i++)
    for (j = 0; j < n; j++)
      if (i != j && M[i * n + j] != 0) return 0;
  return 1;
}

/* Diagonal entry i of the mass block of rigid body r (scene order), B, with diagonal storage: in
   2D the body's own mass and inertia, mo_rigid_mass's diag(m, m, I), and rig_M is not kept (24
   bytes a grain, T267); they are read from the scene's (m, I) per rigid body, not from the body
   record (T311). */
static inline double rig_diag(const mo_stepper *S, const mo_body *B, int r, int nd, int i)
{
  if (S->rig_M) return S->rig_M[(size_t)r * (size_t)nd + (size_t)i];
  if (S->sc->rigid_md) return S->sc->rigid_md[2 * (size_t)r + (i < 2 ? 0 : 1)];
  return i < 2 ? B->mass : B->J[0];
}

/* Entry (i, j) of the mass block of rigid body r (scene order), full or diagonal storage. */
static inline double rig_mass(const mo_stepper *S, int r, int nd, int i, int j)
{
  if (S->blk_diag) return i == j ? rig_diag(S, &S->sc->body[S->sc->rigid[r]], r, nd, i) : 0;
  return S->rig_M[(size_t)r * (size_t)(nd * nd) + (size_t)(i * nd + j)];
}

/* Block k's body and its rank in sc->rigid (its mass block in rig_M): the k-th rigid body when
   every rigid body has a block (blk_body and blk_rig NULL, T260). */
static inline int blk_bodyof(const mo_stepper *S, int k)
{
  return S->blk_body ? S->blk_body[k] : S->sc->rigid[k];
}
static inline int blk_rank(const mo_stepper *S, int k)
{
  return S->blk_rig ? S->blk_rig[k] : k;
}

/* The local dofs (in its body) of the block whose first free index is o: the identity when every
   block is full (blk_loc NULL, T260). */
static inline const int *blk_local(const mo_stepper *S, int o)
{
  static const int ident[6] = {0, 1, 2, 3, 4, 5};
  return S->blk_loc ? S->blk_loc + (o - S->nfe) : ident;
}

int mo_stepper_rigid_update(mo_stepper *S, const mo_state *s, mo_ctx *ctx)
{
  const mo_scene *sc = S->sc;
  int nd = mo_rigid_ndof(sc->dim), k, r, i, j;
  for (r = 0; r < sc->nrigid; r++) {
    const mo_body *B = &sc->body[sc->rigid[r]];
    double Md[36];
    if (!S->blk_diag) mo_rigid_mass(sc, B, s, S->rig_M + (size_t)r * (size_t)(nd * nd));
    else {
      mo_rigid_mass(sc, B, s, Md);
      if (!is_diagonal(nd, Md))
        return mo_error(ctx, MO_EINTERNAL, "rigid body '%s': its mass block is not diagonal", B->name);
      for (i = 0; i < nd && S->rig_M; i++) S->rig_M[(size_t)r * (size_t)nd + (size_t)i] = Md[i * nd + i];
    }
    if (s && S->gyro) mo_rigid_gyroscopic(sc, B, s, s->v + B->dof0, S->gyro + B->dof0);
  }
  for (k = 0; k < S->nblk; k++) {
    int b = blk_bodyof(S, k), nk = S->blk_off[k + 1] - S->blk_off[k], ri;
    const int *loc = blk_local(S, S->blk_off[k]);
    double Mff[36];
    const double *M;
    ri = blk_rank(S, k);
    if (S->blk_diag) { /* small_inverse's Gauss-Jordan on a diagonal block: 1 / M_ii to the bit */
      for (i = 0; i < nk; i++) {
        double piv = rig_diag(S, &sc->body[b], ri, nd, loc[i]);
        if (!(fabs(piv) > 0))
          return mo_error(ctx, MO_ESINGULAR, "rigid body '%s': its mass matrix is singular (zero mass or "
                          "inertia on a free dof)", sc->body[b].name);
        S->blk_inv[S->blk_off[k] - S->nfe + i] = 1 / piv;
      }
      continue;
    }
    M = S->rig_M + (size_t)ri * (size_t)(nd * nd);
    for (i = 0; i < nk; i++)
      for (j = 0; j < nk; j++) Mff[i * nk + j] = M[loc[i] * nd + loc[j]];
    if (small_inverse(nk, Mff, S->blk_inv + S->blk_ioff[k]))
      return mo_error(ctx, MO_ESINGULAR, "rigid body '%s': its mass matrix is singular (zero mass or inertia "
                      "on a free dof)", sc->body[b].name);
  }
  S->blk_version++;
  S->Wi.version = S->blk_version;
  return MO_OK;
}

/* Blocks of the rigid bodies that have free dofs, at the reference orientation. */
static int rigid_setup(mo_stepper *S, mo_ctx *ctx)
{
  const mo_scene *sc = S->sc;
  int r, k = 0, nfree_r = sc->nfree - sc->nfe_free, ninv = 0, i, nd = mo_rigid_ndof(sc->dim), full;
  S->nfe = sc->nfe_free;
  /* diagonal storage when every body's block is diagonal at the reference and never turns (2D;
     3D with isotropic inertia): nd values a body instead of nd^2, and as many inverses */
  S->blk_diag = 1;
  for (r = 0; r < sc->nrigid && S->blk_diag; r++) {
    const mo_body *B = &sc->body[sc->rigid[r]];
    double M[36];
    mo_rigid_mass(sc, B, NULL, M);
    S->blk_diag = !(sc->dim == 3 && anisotropic(B)) && is_diagonal(nd, M);
  }
  S->blk_body = mo_malloc(ctx, ((size_t)sc->nrigid + 1) * sizeof *S->blk_body);
  S->blk_rig = mo_malloc(ctx, ((size_t)sc->nrigid + 1) * sizeof *S->blk_rig);
  S->blk_off = mo_malloc(ctx, ((size_t)sc->nrigid + 2) * sizeof *S->blk_off);
  S->blk_ioff = S->blk_diag ? NULL : mo_malloc(ctx, ((size_t)sc->nrigid + 1) * sizeof *S->blk_ioff);
  S->blk_loc = mo_malloc(ctx, ((size_t)nfree_r + 1) * sizeof *S->blk_loc);
  /* nd x nd per body (nd with blk_diag); the gyroscopic forces exist in 3D only */
  /* 2D diagonal blocks are read from the bodies (rig_diag) */
  S->rig_M = S->blk_diag && sc->dim == 2
                 ? NULL
                 : mo_calloc(ctx, (size_t)(S->blk_diag ? nd : nd * nd) * (size_t)sc->nrigid + 1, sizeof *S->rig_M);
  S->gyro = sc->dim == 3 ? mo_calloc(ctx, (size_t)sc->ndof + 1, sizeof *S->gyro) : NULL;
  if (!S->blk_body || !S->blk_rig || !S->blk_off || (!S->blk_diag && !S->blk_ioff) || !S->blk_loc ||
      (!S->rig_M && !(S->blk_diag && sc->dim == 2)) ||
      (sc->dim == 3 && !S->gyro))
    return MO_ENOMEM;
  S->blk_off[0] = S->nfe;
  for (r = 0; r < sc->nrigid; r++) {
    const mo_body *B = &sc->body[sc->rigid[r]];
    int nk = 0;
    for (i = 0; i < B->ndof; i++)
      if (sc->free_of[B->dof0 + i] >= 0) S->blk_loc[sc->free_of[B->dof0 + i] - S->nfe] = i, nk++;
    if (sc->dim == 3 && anisotropic(B) && nk) S->blk_varies = 1;
    if (!nk) continue;
    S->blk_body[k] = sc->rigid[r];
    S->blk_rig[k] = r;
    if (!S->blk_diag) S->blk_ioff[k] = ninv;
    ninv += S->blk_diag ? nk : nk * nk;
    S->blk_off[k + 1] = S->blk_off[k] + nk;
    k++;
  }
  S->nblk = k;
  /* every block full (nk <= nd each, nblk nd dofs in all: a pack of free grains): a dof's local
     index and its block follow from its index, (i - nfe) mod nd and (i - nfe) / nd, and neither
     map is kept (8 bytes a dof, T260) */
  full = nfree_r == S->nblk * nd;
  if (full) {
    mo_free(S->blk_loc);
    S->blk_loc = NULL;
  }
  /* a block for every rigid body: block k is body rigid[k], the k-th of rigid_M (blk_bodyof) */
  if (S->nblk == sc->nrigid) {
    mo_free(S->blk_body);
    mo_free(S->blk_rig);
    S->blk_body = S->blk_rig = NULL;
  }
  S->blk_inv = mo_malloc(ctx, ((size_t)ninv + 1) * sizeof *S->blk_inv);
  S->blk_of = full ? NULL : mo_malloc(ctx, ((size_t)nfree_r + 1) * sizeof *S->blk_of);
  if (!S->blk_inv || (!full && !S->blk_of)) return MO_ENOMEM;
  for (k = 0; k < S->nblk && !full; k++)
    for (i = S->blk_off[k]; i < S->blk_off[k + 1]; i++) S->blk_of[i - S->nfe] = k;
  if (!S->blk_varies && sc->nrigid)
    mo_note_skip(ctx, "rigid mass blocks updates (2D bodies, or 3D bodies with isotropic inertia)");
  S->Wi.n = sc->nfree;
  S->Wi.nfe = S->nfe;
  S->Wi.ls = S->ls;
  S->Wi.nblk = S->nblk;
  S->Wi.off = S->blk_off;
  S->Wi.ioff = S->blk_ioff;
  S->Wi.inv = S->blk_diag ? NULL : S->blk_inv;
  S->Wi.dinv = S->blk_diag ? S->blk_inv : NULL;
  S->Wi.blkof = S->blk_of;
  S->Wi.bsize = nd;
  S->Wi.last = mo_stepper_contact_dofs(S, &S->Wi.nlast);
  return mo_stepper_rigid_update(S, NULL, ctx);
}

const mo_what_inverse *mo_stepper_inverse(const mo_stepper *S) { return &S->Wi; }

/* Block k's rows of x = (add ? x : 0) + What^-1 b: the full block's sums, or with the diagonal
   storage their value to the bit for finite b: a sum s + 0 b_j of the full block leaves s unless
   s is a zero, and only a -0 start depends on the signs of the zero products (then summed as the
   full block does, zeros included). */
static inline void block_apply(const mo_what_inverse *Wi, int k, const double *b, double *x, int add)
{
  int o = Wi->off[k], nk = Wi->off[k + 1] - o, i, j;
  double y[6];
  if (Wi->dinv) {
    const double *dv = Wi->dinv + (o - Wi->off[0]);
    for (i = 0; i < nk; i++) {
      double acc = add ? x[o + i] : 0;
      if (acc != 0 || !signbit(acc)) acc += dv[i] * b[o + i];
      else
        for (j = 0; j < nk; j++) acc += (j == i ? dv[i] : 0.0) * b[o + j];
      y[i] = acc;
    }
  } else {
    const double *Ai = Wi->inv + Wi->ioff[k];
    for (i = 0; i < nk; i++) {
      y[i] = add ? x[o + i] : 0;
      for (j = 0; j < nk; j++) y[i] += Ai[i * nk + j] * b[o + j];
    }
  }
  memcpy(x + o, y, (size_t)nk * sizeof *y);
}

int mo_what_solve(const mo_what_inverse *Wi, int nrhs, const double *B, double *X, mo_ctx *ctx)
{
  int n = Wi->n, nfe = Wi->nfe, c, k, st;
  if (nfe > 0) {
    if (n == nfe) {
      if ((st = mo_linsolver_solve_multi(Wi->ls, nrhs, B, X, ctx))) return st;
    } else
      for (c = 0; c < nrhs; c++)
        if ((st = mo_linsolver_solve(Wi->ls, B + (size_t)c * n, X + (size_t)c * n, ctx))) return st;
  }
  for (c = 0; c < nrhs; c++) {
    const double *b = B + (size_t)c * n;
    double *x = X + (size_t)c * n;
    for (k = 0; k < Wi->nblk; k++) block_apply(Wi, k, b, x, 0);
  }
  return MO_OK;
}

int mo_stepper_what_solve(mo_stepper *S, int nrhs, const double *B, double *X, mo_ctx *ctx)
{
  return mo_what_solve(&S->Wi, nrhs, B, X, ctx);
}

void mo_stepper_mass_apply(const mo_stepper *S, const double *x, double *y)
{
  const mo_scene *sc = S->sc;
  int nd = mo_rigid_ndof(sc->dim), r, i, j;
  if (sc->M) mo_scene_gaxpy(sc, sc->M, 1, x, 0, y);
  else memset(y, 0, (size_t)sc->ndof * sizeof *y); /* quasi-static: no inertia */
  for (r = 0; r < sc->nrigid; r++) {
    const mo_body *B = &sc->body[sc->rigid[r]];
    const double *xb = x + B->dof0;
    for (i = 0; i < nd; i++) {
      double acc = 0;
      for (j = 0; j < nd; j++) acc += rig_mass(S, r, nd, i, j) * xb[j];
      y[B->dof0 + i] = acc;
    }
  }
}

int mo_stepper_matrix_full(mo_stepper *S, const mo_csc **W, mo_ctx *ctx)
{
  const mo_scene *sc = S->sc;
  long ver = S->blk_version * 1000003L + (S->ls ? 0 : 1);
  mo_triplet T;
  mo_csc *Wsum = NULL;
  const mo_csc *Wn = S->W;
  int k, i, j, p, st;
  *W = S->W;
  if (!S->nblk && S->W && !sc->kpart) return MO_OK;
  if (S->ls) {
    long nf;
    mo_linsolver_stats(S->ls, &nf, NULL, NULL);
    ver += nf * 7919L;
  }
  if (S->Wall && S->Wall_version == ver) { *W = S->Wall; return MO_OK; }
  /* What in parts over the ranks: its nodal block summed and gathered, whole on every rank
     (for the back ends that ask for What itself: MO_NEEDS_GLOBAL) */
  if (sc->kpart && S->W) {
    if ((st = mo_csc_sum_parts(S->W, NULL, &Wsum, ctx))) return st;
    Wn = Wsum;
  }
  if ((st = mo_triplet_init(&T, sc->nfree, sc->nfree, (size_t)(Wn ? mo_csc_nnz(Wn) : 0) + 36 * (size_t)S->nblk + 1,
                            ctx))) {
    mo_csc_free(Wsum);
    return st;
  }
  for (j = 0; Wn && j < Wn->ncol; j++)
    for (p = Wn->p[j]; p < Wn->p[j + 1]; p++)
      if ((st = mo_triplet_add(&T, Wn->i[p], j, Wn->x[p], ctx))) goto done;
  for (k = 0; k < S->nblk; k++) {
    int o = S->blk_off[k], nk = S->blk_off[k + 1] - o, r, nd = mo_rigid_ndof(sc->dim);
    const int *loc = blk_local(S, o);
    r = blk_rank(S, k);
    for (i = 0; i < nk; i++)
      for (j = 0; j < nk; j++) {
        double Mij = rig_mass(S, r, nd, loc[i], loc[j]);
        if (Mij != 0 && (st = mo_triplet_add(&T, o + i, o + j, Mij, ctx))) goto done;
      }
  }
  mo_csc_free(S->Wall);
  S->Wall = NULL;
  if ((st = mo_triplet_to_csc(&T, 1, &S->Wall, ctx))) goto done;
  S->Wall_version = ver;
  *W = S->Wall;
done:
  mo_triplet_release(&T);
  mo_csc_free(Wsum);
  return st;
}

/* A solver of What (or of M_ff) that linear_solver asks for (CHOLMOD, or PETSc over the ranks;
   with K and M in parts, the matrix it is given is this rank's part of the sum). */
static int new_solver(const mo_scene *sc, mo_linsolver **ls, mo_ctx *ctx)
{
  const mo_linear_settings *L = &sc->lin;
  mo_linsolver_settings set;
  const mo_linsolver_type *T;
  int st;
  if (!L->petsc) return mo_linsolver_create(&mo_linsolver_cholmod, ls, ctx);
  if (!(T = mo_linsolver_petsc(ctx))) return mo_error_prefix(ctx, "linear_solver.type = \"petsc\"");
  memset(&set, 0, sizeof set);
  set.ksp = L->ksp;
  set.pc = L->pc;
  set.package = L->package;
  set.options = L->options;
  set.rtol = L->rtol;
  set.spd = 1;
  set.parts = sc->kpart;
  set.out_of_core = L->out_of_core;
  set.ooc_dir = L->ooc_dir[0] ? L->ooc_dir : NULL;
  if ((st = mo_linsolver_create(T, ls, ctx))) return st;
  return mo_linsolver_configure(*ls, &set, ctx);
}

static int make_solver(mo_stepper *S, mo_ctx *ctx) { return new_solver(S->sc, &S->ls, ctx); }

/* Virgin states of every finite-strain body. */
static void init_material(const mo_scene *sc, double *q)
{
  int b;
  for (b = 0; b < sc->nbody; b++)
    if (sc->body[b].nl)
      mo_j2_state_init(sc->body[b].mat->hyp, q + sc->body[b].q0, sc->body[b].mesh->nelem * sc->body[b].npoint);
}

/* A nonlinear scene: the tangent pattern, then What at the initial state (u0, a virgin
   material), factored so that the solver is usable before the first step; Newton refactors it
   at every iterate (same pattern: numeric factorizations only). */
static int create_nonlinear(mo_stepper *S, mo_ctx *ctx)
{
  const mo_scene *sc = S->sc;
  double *q = NULL, t0;
  int st;
  t0 = mo_clock();
  st = mo_tangent_setup(S, ctx);
  mo_phase_add(ctx, MO_PH_ASSEMBLY, t0);
  if (st) return st;
  if (!(q = mo_malloc(ctx, (sc->nq + 1) * sizeof *q))) return MO_ENOMEM;
  init_material(sc, q);
  st = mo_tangent_forces(S, sc->u0, q, S->fint0, 1, NULL, NULL, ctx);
  mo_free(q);
  if (st) return mo_error_prefix(ctx, "the initial configuration");
  t0 = mo_clock();
  st = make_solver(S, ctx);
  if (!st) st = mo_linsolver_set_last(S->ls, S->nlast, S->last, S->reserve, ctx);
  if (!st) st = mo_linsolver_factor(S->ls, S->W, ctx);
  mo_phase_add(ctx, MO_PH_FACTOR, t0);
  if (st)
    return mo_error_prefix(ctx, "tangent iteration matrix (%s) at the initial state",
                           S->scheme == MO_SCHEME_QUASISTATIC ? "K_t" : "M + c K_t");
  return MO_OK;
}

/* What = cm M + ck K (K_t for nonlinear scenes) for the scheme and the current step h. */
static void coefficients(mo_stepper *S)
{
  switch (S->scheme) {
  case MO_SCHEME_THETA: S->cm = 1; S->ck = S->h * S->h * S->theta * S->theta_f; break;
  case MO_SCHEME_NEWMARK: S->cm = 1; S->ck = S->beta * S->h * S->h; break;
  case MO_SCHEME_QUASISTATIC: S->cm = 0; S->ck = 1; break;
  }
}

/* A linear scene's iteration matrix for the current h: M + c K (K when quasi-static) over full
   dofs, and its free-free restriction. */
static int linear_matrix(const mo_stepper *S, mo_csc **Wf, mo_csc **W, mo_ctx *ctx)
{
  const mo_scene *sc = S->sc;
  double t0 = mo_clock();
  int st;
  *Wf = *W = NULL;
  if (S->scheme == MO_SCHEME_QUASISTATIC) st = mo_csc_copy(sc->K, Wf, ctx);
  else st = mo_csc_add(sc->M, sc->K, S->cm, S->ck, Wf, ctx);
  /* the nodal block: rigid dofs have no row in M or K, so free_of maps into 0 .. nfe_free-1 */
  if (!st) st = mo_csc_extract(*Wf, sc->free_of, sc->nfe_free, sc->free_of, sc->nfe_free, W, ctx);
  mo_phase_add(ctx, MO_PH_ASSEMBLY, t0);
  if (st) {
    mo_csc_free(*Wf);
    *Wf = NULL;
  }
  return st;
}

/* A quasi-static scene has no inertia: a deformable body whose supports leave it a rigid motion
   (K singular in that mode) is held only by contact, which acts after K is factored. The factor
   is then exact (zero pivot: CHOLMOD stops) or arbitrary in that mode (a round-off pivot: the
   answer looks converged and is not, issue 15). The rigid modes of each body (T82): translations
   and, about its centroid scaled by its size, rotations (the axisymmetric ring: axial translation
   only); those its prescribed dofs leave free are the null space of G = Z_p^T Z_p, Z_p the
   modes' values at the prescribed dofs. Any: refuse with the body and the motion. */
static int quasistatic_rigid_modes(const mo_scene *sc, mo_ctx *ctx)
{
  int b;
  for (b = 0; b < sc->nbody; b++) {
    const mo_body *B = &sc->body[b];
    const mo_mesh *me = B->mesh;
    int dim = sc->dim, nm, a, i, k, l, nfree = 0;
    double G[36], xc[3] = {0, 0, 0}, L = 0, ev[6], V[36];
    char what[400];
    size_t len = 0;
    if (B->kind != MO_BODY_DEFORMABLE || !me || !me->nnode) continue;
    nm = dim == 1 ? 1 : dim == 2 ? (B->mat->hyp == MO_HYP_AXISYMMETRIC ? 1 : 3) : 6;
    for (a = 0; a < me->nnode; a++)
      for (i = 0; i < dim; i++) xc[i] += me->x[a * dim + i] / me->nnode;
    for (a = 0; a < me->nnode; a++) {
      double r2 = 0;
      for (i = 0; i < dim; i++) r2 += (me->x[a * dim + i] - xc[i]) * (me->x[a * dim + i] - xc[i]);
      if (r2 > L * L) L = sqrt(r2);
    }
    if (!(L > 0)) L = 1;
    memset(G, 0, sizeof G);
    for (a = 0; a < me->nnode; a++)
      for (i = 0; i < dim; i++) {
        double z[6], y[3];
        int dof = B->dof0 + a * dim + i;
        if (sc->free_of[dof] >= 0) continue;
        for (k = 0; k < dim; k++) y[k] = (me->x[a * dim + k] - xc[k]) / L;
        memset(z, 0, sizeof z);
        if (dim == 2 && nm == 1) z[0] = i == 1;          /* axisymmetric: u_z = 1 */
        else {
          for (k = 0; k < dim; k++) z[k] = i == k;       /* translations */
          if (dim == 2) z[2] = i == 0 ? -y[1] : y[0];    /* rotation: (-y, x) */
          if (dim == 3) {                                /* omega_k x y, component i */
            z[3] = i == 1 ? -y[2] : i == 2 ? y[1] : 0;   /* about x: (0, -z, y) */
            z[4] = i == 0 ? y[2] : i == 2 ? -y[0] : 0;   /* about y: (z, 0, -x) */
            z[5] = i == 0 ? -y[1] : i == 1 ? y[0] : 0;   /* about z: (-y, x, 0) */
          }
        }
        for (k = 0; k < nm; k++)
          for (l = 0; l < nm; l++) G[k * nm + l] += z[k] * z[l];
      }
    {
      gsl_matrix_view Gv = gsl_matrix_view_array(G, (size_t)nm, (size_t)nm);
      gsl_vector_view ew = gsl_vector_view_array(ev, (size_t)nm);
      gsl_matrix_view Vv = gsl_matrix_view_array(V, (size_t)nm, (size_t)nm);
      gsl_eigen_symmv_workspace *wk = gsl_eigen_symmv_alloc((size_t)nm);
      if (!wk) return mo_error(ctx, MO_ENOMEM, "the rigid modes of body '%s'", B->name);
      gsl_eigen_symmv(&Gv.matrix, &ew.vector, &Vv.matrix, wk);
      gsl_eigen_symmv_free(wk);
    }
    /* a prescribed dof holds about 1 in G's units: 1e-9 of one is no support */
    for (k = 0; k < nm; k++) {
      static const char *const name3[6] = {"x", "y", "z", "rx", "ry", "rz"}, *const name2[3] = {"x", "y", "rz"};
      int first = 1;
      double big = 0;
      if (!(ev[k] <= 1e-9)) continue;
      nfree++;
      for (l = 0; l < nm; l++)
        if (fabs(V[l * nm + k]) > fabs(big)) big = V[l * nm + k];
      for (l = 0; big < 0 && l < nm; l++) V[l * nm + k] = -V[l * nm + k]; /* its largest component positive */
      len += (size_t)snprintf(what + len, len < sizeof what ? sizeof what - len : 0, "%s(", nfree > 1 ? ", " : "");
      for (l = 0; l < nm && len < sizeof what; l++) {
        double c = V[l * nm + k];
        if (fabs(c) < 1e-6) continue;
        len += (size_t)snprintf(what + len, sizeof what - len, "%s%.3g %s", first ? "" : " + ", c,
                                nm == 1 ? (dim == 1 ? "x" : "z (axial)") : dim == 2 ? name2[l] : name3[l]);
        first = 0;
      }
      if (len < sizeof what) len += (size_t)snprintf(what + len, sizeof what - len, ")");
    }
    if (nfree)
      return mo_error(ctx, MO_ESINGULAR,
                      "quasi-static scene: body '%s' has %d rigid motion%s that no support holds: %s (translations "
                      "in m, rotations in rad times the body's radius %.3g m). Its stiffness K is singular in "
                      "%s; contact alone cannot hold %s, because the quasi-static step factors K before contact "
                      "acts (doc/theory.md (T82)): the answer would be arbitrary in %s. Hold %s with "
                      "supports (fix the dofs of a point or a plane of symmetry), or run the scene dynamically "
                      "(time.scheme = \"theta\")",
                      B->name, nfree, nfree > 1 ? "s" : "", what, L, nfree > 1 ? "those modes" : "that mode",
                      nfree > 1 ? "them" : "it", nfree > 1 ? "those motions" : "that motion", nfree > 1 ? "them" : "it");
  }
  return MO_OK;
}

/* The contact dofs to order last: free nodal indices, each once. */
static int set_contact_dofs(mo_stepper *S, int nlast, const int *last, double reserve, mo_ctx *ctx)
{
  const mo_scene *sc = S->sc;
  unsigned char *seen;
  int k;
  if (!nlast || !sc->nfe_free) return MO_OK;
  if (!(seen = mo_calloc(ctx, (size_t)sc->nfe_free, 1))) return MO_ENOMEM;
  for (k = 0; k < nlast; k++) {
    if (last[k] < 0 || last[k] >= sc->nfe_free || seen[last[k]]) {
      mo_free(seen);
      return mo_error(ctx, MO_EINTERNAL, "contact dof %d (free index %d) is not a nodal free dof, or twice", k, last[k]);
    }
    seen[last[k]] = 1;
  }
  S->islast = seen;
  S->last = mo_malloc(ctx, (size_t)nlast * sizeof *S->last);
  S->ysplit = mo_malloc(ctx, (size_t)sc->nfe_free * sizeof *S->ysplit);
  S->cw = mo_malloc(ctx, (size_t)nlast * sizeof *S->cw);
  if (!S->last || !S->ysplit || !S->cw) return MO_ENOMEM;
  memcpy(S->last, last, (size_t)nlast * sizeof *last);
  S->nlast = nlast;
  S->reserve = reserve;
  return MO_OK;
}

int mo_stepper_create(const mo_scene *sc, mo_stepper **out, mo_ctx *ctx)
{
  return mo_stepper_create_ordered(sc, 0, NULL, 0, out, ctx);
}

int mo_stepper_create_ordered(const mo_scene *sc, int nlast, const int *last, double reserve, mo_stepper **out,
                              mo_ctx *ctx)
{
  mo_stepper *S;
  mo_csc *Wf = NULL;
  int st, n = sc->ndof, need_w2, keep_uprev;
  double t0;
  *out = NULL;
  S = mo_calloc(ctx, 1, sizeof *S);
  if (!S) return MO_ENOMEM;
  S->sc = sc;
  if ((st = set_contact_dofs(S, nlast, last, reserve, ctx))) {
    mo_stepper_free(S);
    return st;
  }
  S->scheme = sc->time.scheme;
  S->h = sc->time.dt;
  S->theta = sc->time.theta;
  S->theta_f = sc->time.theta_f;
  S->beta = sc->time.beta;
  S->gamma = sc->time.gamma;
  coefficients(S);
  /* every dof free and no mesh (T246): the free numbering is the full one, rhs is w1 and What^-1
     is solved into the caller's full vector; w2 holds u + c v for K's product alone */
  S->alias = mo_scene_all_free_rigid(sc) && !sc->nonlinear && !sc->kpart;
  S->w1 = mo_calloc(ctx, (size_t)(n ? n : 1), sizeof(double));
  S->rhs = S->alias ? S->w1 : mo_calloc(ctx, (size_t)(sc->nfree ? sc->nfree : 1), sizeof(double));
  S->xf = S->alias ? NULL : mo_calloc(ctx, (size_t)(sc->nfree ? sc->nfree : 1), sizeof(double));
  need_w2 = !(S->alias && S->scheme == MO_SCHEME_THETA && (!sc->K || !mo_csc_nnz(sc->K)));
  if (need_w2) S->w2 = mo_calloc(ctx, (size_t)(n ? n : 1), sizeof(double));
  /* w3: Newton's work, or the unknown of a step without contact (mo_stepper_step, made there) */
  S->w3 = sc->nonlinear ? mo_calloc(ctx, (size_t)(n ? n : 1), sizeof(double)) : NULL;
  /* the displacements of the step's start, for the increments of the load work, the reactions
     and the 3D rotations; with alias under the theta-scheme and no prescribed dof the increments
     are formed from the step's own terms before u moves (T247) */
  keep_uprev = !(S->alias && S->scheme == MO_SCHEME_THETA && !sc->npresc);
  if (keep_uprev) S->uprev = mo_calloc(ctx, (size_t)(n ? n : 1), sizeof(double));
  /* the velocities and forces of the step's start: the reactions of prescribed dofs only */
  if (sc->npresc) {
    S->vprev = mo_calloc(ctx, (size_t)(n ? n : 1), sizeof(double));
    S->fprev = mo_calloc(ctx, (size_t)(n ? n : 1), sizeof(double));
  }
  if (!S->rhs || (!S->alias && !S->xf) || !S->w1 || (need_w2 && !S->w2) || (sc->nonlinear && !S->w3) ||
      (keep_uprev && !S->uprev) || (sc->npresc && (!S->vprev || !S->fprev))) {
    mo_stepper_free(S);
    return MO_ENOMEM;
  }
  if (sc->nonlinear) {
    if ((S->scheme == MO_SCHEME_QUASISTATIC && (st = quasistatic_rigid_modes(sc, ctx))) ||
        (st = create_nonlinear(S, ctx)) || (st = rigid_setup(S, ctx))) {
      mo_stepper_free(S);
      return st;
    }
    *out = S;
    return MO_OK;
  }
  mo_note_skip(ctx, "Newton iterations and refactorizations (every material is linear)");
  if (!sc->nfe_free) {
    /* rigid bodies only: What is their mass blocks, no factorization */
    if ((st = rigid_setup(S, ctx))) {
      mo_stepper_free(S);
      return st;
    }
    *out = S;
    return MO_OK;
  }
  if (S->scheme == MO_SCHEME_QUASISTATIC && (st = quasistatic_rigid_modes(sc, ctx))) {
    mo_stepper_free(S);
    return st;
  }
  if ((st = linear_matrix(S, &Wf, &S->W, ctx))) {
    mo_stepper_free(S);
    return st;
  }
  if (sc->has_moving_presc) S->Wfull = Wf;
  else {
    mo_csc_free(Wf);
    mo_note_skip(ctx, "coupling with prescribed motion (every prescribed dof is fixed)");
  }
  t0 = mo_clock();
  st = make_solver(S, ctx);
  if (!st) st = mo_linsolver_set_last(S->ls, S->nlast, S->last, S->reserve, ctx);
  if (!st) st = mo_linsolver_factor(S->ls, S->W, ctx);
  mo_phase_add(ctx, MO_PH_FACTOR, t0);
  if (st) {
    char cause[600];
    mo_error_prefix(ctx, "iteration matrix (%s)",
                    S->scheme == MO_SCHEME_QUASISTATIC ? "stiffness K" : "M + c K");
    /* the case key behind it, when the data say (finite.c) */
    mo_matrix_cause(sc, cause, sizeof cause);
    if (cause[0]) {
      /* the data explain it: not the generic guess of the factorization */
      char *g = strstr(ctx->errmsg, ": a body free to move rigidly");
      if (g) *g = '\0';
      if (strlen(ctx->errmsg) + strlen(cause) < sizeof ctx->errmsg) strcat(ctx->errmsg, cause);
    }
    mo_stepper_free(S);
    return st;
  }
  if ((st = rigid_setup(S, ctx))) {
    mo_stepper_free(S);
    return st;
  }
  *out = S;
  return MO_OK;
}

void mo_stepper_gather(const mo_stepper *S, const double *full, double *fr)
{
  const int *fo = S->sc->full_of;
  int i;
  for (i = 0; i < S->sc->nfree; i++) fr[i] = full[fo[i]];
}

void mo_stepper_scatter(const mo_stepper *S, const double *fr, double *full)
{
  const int *fo = S->sc->full_of;
  int i;
  for (i = 0; i < S->sc->nfree; i++) full[fo[i]] = fr[i];
}

mo_linsolver *mo_stepper_solver(mo_stepper *S) { return S->ls; }
const mo_csc *mo_stepper_matrix(const mo_stepper *S) { return S->W; }
const mo_scene *mo_stepper_scene(const mo_stepper *S) { return S->sc; }

double mo_stepper_dt(const mo_stepper *S) { return S->h; }

int mo_stepper_restart(mo_stepper *S, const mo_state *s, mo_ctx *ctx)
{
  int st;
  if (!S->nl) return MO_OK;
  /* the internal forces at the start of the step, from the state's committed material */
  if ((st = mo_tangent_forces(S, s->u, s->q, S->fint0, 0, NULL, NULL, ctx)))
    return mo_error_prefix(ctx, "restarting step %ld", s->step + 1);
  return MO_OK;
}

int mo_stepper_set_dt(mo_stepper *S, double h, mo_ctx *ctx)
{
  mo_csc *Wf = NULL, *W = NULL;
  double t0;
  int st;
  if (h == S->h) return MO_OK;
  if (!(h > 0) || !isfinite(h)) return mo_error(ctx, MO_EINTERNAL, "step change to h = %g", h);
  S->h = h;
  coefficients(S);
  if (S->nl) return mo_tangent_set_dt(S, ctx);
  if (S->scheme == MO_SCHEME_QUASISTATIC) return MO_OK; /* K does not depend on the load step */
  if (!S->ls) return MO_OK; /* rigid bodies only: What = M whatever h */
  /* What = M + c K for the new h, on the same pattern: the factorization keeps its analysis */
  if ((st = linear_matrix(S, &Wf, &W, ctx))) return st;
  mo_csc_free(S->W);
  S->W = W;
  if (S->Wfull) {
    mo_csc_free(S->Wfull);
    S->Wfull = Wf;
  } else
    mo_csc_free(Wf);
  t0 = mo_clock();
  st = mo_linsolver_factor(S->ls, S->W, ctx);
  mo_phase_add(ctx, MO_PH_FACTOR, t0);
  if (st) return mo_error_prefix(ctx, "iteration matrix (M + c K) for h = %g", h);
  return MO_OK;
}

double mo_stepper_du_dx(const mo_stepper *S)
{
  switch (S->scheme) {
  case MO_SCHEME_THETA: return S->h * S->theta;
  case MO_SCHEME_NEWMARK: return S->beta * S->h * S->h;
  default: return 1;
  }
}

/* Prescribed values at time t written into full vectors (u and/or v, a = 0 for moving
   supports at constant velocity; expressions differentiated twice numerically). */
static void presc_values(const mo_stepper *S, double t, double *u, double *v, double *a)
{
  const mo_scene *sc = S->sc;
  int k;
  for (k = 0; k < sc->npresc; k++) {
    double pu, pv;
    mo_scene_presc_eval(sc, k, t, &pu, &pv);
    if (u) u[sc->presc[k].dof] = pu;
    if (v) v[sc->presc[k].dof] = pv;
    if (a) {
      double acc = 0;
      if (sc->presc[k].kind == MO_PRESC_EXPR) {
        double h = 1e-5 * (sc->time.end > 0 ? sc->time.end : 1), up, vp, um, vm;
        mo_scene_presc_eval(sc, k, t + h, &up, &vp);
        mo_scene_presc_eval(sc, k, t - h, &um, &vm);
        acc = (vp - vm) / (2 * h);
      }
      a[sc->presc[k].dof] = acc;
    }
  }
}

void mo_stepper_presc_unknown(const mo_stepper *S, double t, double *x)
{
  switch (S->scheme) {
  case MO_SCHEME_THETA: presc_values(S, t, NULL, x, NULL); break;
  case MO_SCHEME_NEWMARK: presc_values(S, t, NULL, NULL, x); break;
  case MO_SCHEME_QUASISTATIC: presc_values(S, t, x, NULL, NULL); break;
  }
}

/* The rigid rows of the right-hand side (T70): theta: M_b v- + h g(v-) (the explicit
   gyroscopic force), Newmark: g; both minus M_fp x_p, the coupling with the body's prescribed
   dofs at their values x_p of t+. f1's rigid rows (added by the caller) hold the loads. */
/* Whether the 2D grains' path of rigid_rhs holds: every dof free, diagonal blocks from the scene's
   (m, I), theta without gyroscopic forces. */
static inline int rigid_rhs_fast(const mo_stepper *S)
{
  const double h0 = S->h * 0.0; /* h g, g = 0 without gyroscopic forces */
  return S->blk_diag && !S->rig_M && S->sc->rigid_md && !S->blk_loc && S->scheme == MO_SCHEME_THETA && !S->gyro &&
         h0 == 0 && !signbit(h0);
}

/* Block k's rows of rigid_rhs (fast: rigid_rhs_fast(S)). */
static inline void rigid_rhs_block(const mo_stepper *S, const mo_state *s, const double *x, double *rhs, int k,
                                   int fast)
{
  const mo_scene *sc = S->sc;
  const double h0 = S->h * 0.0;
  int nd = mo_rigid_ndof(sc->dim), i, j, r;
  if (fast) {
    /* 2D bodies with every dof free (the grains): each row's h g + m_i v_i below (its first
       branch), with (m, I) from the scene's rigid_md and the dofs number_dofs's, no body record
       read (T311) */
    const int o = S->blk_off[k];
    const size_t rk = (size_t)blk_rank(S, k);
    const double *v = s->v + sc->nfe_dof + 3 * rk, *md = sc->rigid_md + 2 * rk;
    rhs[o] += h0 + md[0] * v[0];
    rhs[o + 1] += h0 + md[0] * v[1];
    rhs[o + 2] += h0 + md[1] * v[2];
    return;
  }
  {
    const mo_body *B = &sc->body[blk_bodyof(S, k)];
    int o = S->blk_off[k], nk = S->blk_off[k + 1] - o, d0;
    const int *loc = blk_local(S, o);
    const double *v, *xb;
    r = blk_rank(S, k);
    /* the body's first dof as number_dofs gives it, nfe_dof + nd r (checked at the scene's build,
       rigid_diagonals): with rig_diag's (m, I) no body record is read on the 2D path (T311) */
    d0 = sc->nfe_dof + nd * r;
    v = s->v + d0;
    xb = x + d0;
    for (i = 0; i < nk; i++) {
      double g = S->gyro ? S->gyro[d0 + loc[i]] : 0;
      double acc = S->scheme == MO_SCHEME_THETA ? S->h * g : g;
      /* a diagonal block: the full row's sum to the bit for finite v (block_apply), its zeros'
         products summed only after a -0 start or with prescribed dofs */
      if (S->blk_diag && nk == nd && S->scheme == MO_SCHEME_THETA && (acc != 0 || !signbit(acc)))
        acc += rig_diag(S, B, r, nd, loc[i]) * v[loc[i]];
      else if (S->blk_diag) { /* the full row's sums, its zeros' products (signed zeros) kept */
        const int li = loc[i];
        const double mii = rig_diag(S, B, r, nd, li);
        for (j = 0; j < nd; j++) {
          double Mij = j == li ? mii : 0.0;
          if (S->scheme == MO_SCHEME_THETA) acc += Mij * v[j];
          if (sc->free_of[d0 + j] < 0) acc -= Mij * xb[j];
        }
      } else {
        const double *Mi = S->rig_M + (size_t)r * (size_t)(nd * nd) + (size_t)(loc[i] * nd);
        for (j = 0; j < nd; j++) {
          if (S->scheme == MO_SCHEME_THETA) acc += Mi[j] * v[j];
          if (sc->free_of[d0 + j] < 0) acc -= Mi[j] * xb[j];
        }
      }
      rhs[o + i] += acc;
    }
  }
}

/* The rigid rows of the right-hand side (T70): theta: M_b v- + h g(v-) (the explicit
   gyroscopic force), Newmark: g; both minus M_fp x_p, the coupling with the body's prescribed
   dofs at their values x_p of t+. f1's rigid rows (added by the caller) hold the loads. */
static void rigid_rhs(const mo_stepper *S, const mo_state *s, const double *x, double *rhs)
{
  const int fast = rigid_rhs_fast(S);
  int k;
  for (k = 0; k < S->nblk; k++) rigid_rhs_block(S, s, x, rhs, k, fast);
}

/* --- the bodies' state per rank (doc/theory.md §13.18) ------------------------------------------
   The step of the bodies this rank holds only: their free velocities and their update, each to the
   bit what the step of every body gives them, the others' state left as it is (not current here). */

/* Whether the held path applies: rigid bodies only, each with its own block of free dofs (block k
   rigid body k), the theta scheme without central differences, no stiffness term, no prescribed
   dof, a linear scene. */
static int held_path(const mo_stepper *S)
{
  const mo_scene *sc = S->sc;
  return S->hlist && S->alias && S->scheme == MO_SCHEME_THETA && !sc->time.explicit_cd && !S->nl && !sc->npresc &&
         !S->w2 && S->nblk == sc->nrigid && !S->blk_body && sc->nfe_dof == 0 && !S->Wfull;
}

/* The loads by dof (once): for dof d the entries lo[d] .. lo[d + 1] of (load, value), in the order
   mo_scene_fext sums them. */
static int loads_by_dof(mo_stepper *S, mo_ctx *ctx)
{
  const mo_scene *sc = S->sc;
  int l, k, n = 0, d;
  if (S->ld_lo) return MO_OK;
  for (l = 0; l < sc->nload; l++) n += sc->load[l].n;
  if (!(S->hd0 = mo_malloc(ctx, ((size_t)sc->nbody + 1) * sizeof *S->hd0))) return MO_ENOMEM;
  /* per body its first dof, -1 but for a rigid body with dofs: the held loops read no body record
     (T311) */
  for (d = 0; d < sc->nbody; d++)
    S->hd0[d] = (sc->body[d].type->flags & MO_BODY_F_RIGID) && sc->body[d].dof0 >= 0 ? sc->body[d].dof0 : -1;
  if (!(S->ld_lo = mo_calloc(ctx, (size_t)sc->ndof + 2, sizeof *S->ld_lo)) ||
      !(S->ld_l = mo_malloc(ctx, ((size_t)n + 1) * sizeof *S->ld_l)) ||
      !(S->ld_v = mo_malloc(ctx, ((size_t)n + 1) * sizeof *S->ld_v)) ||
      !(S->ld_a = mo_malloc(ctx, ((size_t)sc->nload + 1) * sizeof *S->ld_a)) ||
      !(S->ld_a0 = mo_malloc(ctx, ((size_t)sc->nload + 1) * sizeof *S->ld_a0)))
    return MO_ENOMEM;
  for (l = 0; l < sc->nload; l++)
    for (k = 0; k < sc->load[l].n; k++) S->ld_lo[sc->load[l].dof[k] + 2]++;
  for (d = 0; d < sc->ndof; d++) S->ld_lo[d + 2] += S->ld_lo[d + 1];
  for (l = 0; l < sc->nload; l++)
    for (k = 0; k < sc->load[l].n; k++) {
      const int e = S->ld_lo[sc->load[l].dof[k] + 1]++;
      S->ld_l[e] = l;
      S->ld_v[e] = sc->load[l].val[k];
    }
  /* every load constant (gravity): f_ext once, mo_scene_fext's values at any time */
  for (l = 0; l < sc->nload && !sc->load[l].amp; l++) {}
  if (l == sc->nload) {
    if (!(S->fconst = mo_malloc(ctx, ((size_t)sc->ndof + 1) * sizeof *S->fconst))) return MO_ENOMEM;
    mo_scene_fext(sc, 0, S->fconst);
  }
  return MO_OK;
}

/* The loads' amplitudes at t into a. */
static void load_amps(const mo_scene *sc, double t, double *a)
{
  int l;
  for (l = 0; l < sc->nload; l++) a[l] = sc->load[l].amp ? mo_expr_eval(sc->load[l].amp, &t) : 1;
}

/* f_ext at dof d with the amplitudes a: mo_scene_fext's sum, to the bit. */
static inline double fext_dof(const mo_stepper *S, const double *a, int d)
{
  double f = 0;
  int e;
  for (e = S->ld_lo[d]; e < S->ld_lo[d + 1]; e++)
    if (a[S->ld_l[e]] != 0) f += a[S->ld_l[e]] * S->ld_v[e];
  return f;
}

/* The unconstrained step of the held bodies (predict_rhs and the blocks' solve, theta path). */
static void predict_held(mo_stepper *S, const mo_state *s, double *x)
{
  const mo_scene *sc = S->sc;
  const int nd = mo_rigid_ndof(sc->dim), fast = rigid_rhs_fast(S);
  const double h = S->h, tf = S->theta_f;
  double *rhs = S->rhs;
  int k, i;
  load_amps(sc, s->t + h, S->ld_a);
  for (k = 0; k < S->nhl; k++) {
    const int d0 = S->hd0[S->hlist[k]], r = d0 / nd;
    if (d0 < 0) continue;
    for (i = 0; i < nd; i++)
      rhs[d0 + i] = h * (tf * (S->fconst ? S->fconst[d0 + i] : fext_dof(S, S->ld_a, d0 + i)) + (1 - tf) * s->f[d0 + i]);
    rigid_rhs_block(S, s, x, rhs, r, fast);
    block_apply(&S->Wi, r, rhs, x, 0);
  }
}

/* mo_stepper_finish for the held bodies (theta path, no uprev: ahead_of_update's). */
static int finish_held(mo_stepper *S, mo_state *s, const double *x, mo_ctx *ctx);

void mo_stepper_hold(mo_stepper *S, const int *hlist, int n, const unsigned char *count)
{
  S->hlist = hlist;
  S->nhl = n;
  S->bcount = count;
}

int mo_stepper_init_state(mo_stepper *S, mo_state *s, mo_ctx *ctx)
{
  const mo_scene *sc = S->sc;
  int n = sc->ndof, st;
  s->t = 0;
  s->step = 0;
  s->wext = s->wsupport = s->wcontact = 0;
  memcpy(s->u, sc->u0, (size_t)n * sizeof(double));
  memcpy(s->v, sc->v0, (size_t)n * sizeof(double));
  presc_values(S, 0, s->u, s->v, NULL);
  mo_scene_fext(sc, 0, s->f);
  if (s->reac) memset(s->reac, 0, (size_t)n * sizeof(double));
  s->psi = s->wplastic = 0;
  /* 3D rigid bodies start in their reference orientation (the body frame is the world's) */
  for (st = 0; st < sc->norient; st++) {
    s->orient[4 * st] = 1;
    s->orient[4 * st + 1] = s->orient[4 * st + 2] = s->orient[4 * st + 3] = 0;
  }
  if (S->nl) {
    /* the material at u0: one update from the virgin state, committed (T65) */
    init_material(sc, s->q);
    if ((st = mo_tangent_forces(S, s->u, s->q, S->fint0, 0, NULL, NULL, ctx)))
      return mo_error_prefix(ctx, "the initial configuration");
    memcpy(s->q, S->qt, sc->nq * sizeof *s->q);
    mo_tangent_energies(S, s->q, &s->psi, &s->wplastic);
  }
  if (S->scheme == MO_SCHEME_NEWMARK) {
    /* M_ff a0 = [f0 - K u0 - M z0]_f, z0 the prescribed accelerations */
    mo_linsolver *Ml = NULL;
    mo_csc *Mff = NULL;
    memset(s->a, 0, (size_t)n * sizeof(double));
    presc_values(S, 0, NULL, NULL, s->a);
    memcpy(S->w1, s->f, (size_t)n * sizeof(double));
    if (S->nl) { /* f_int(u0), K u0 of the linear bodies included */
      int i;
      for (i = 0; i < n; i++) S->w1[i] -= S->fint0[i];
    } else
      mo_scene_gaxpy(sc, sc->K, -1, s->u, 1, S->w1);
    mo_scene_gaxpy(sc, sc->M, -1, s->a, 1, S->w1); /* once a run: two sums */
    if (!S->alias) mo_stepper_gather(S, S->w1, S->rhs);
    st = MO_OK;
    if (sc->nfe_free) {
      /* the nodal rows through M_ff; the rigid rows' mass blocks are What's (What = M + beta h^2 K) */
      st = mo_csc_extract(sc->M, sc->free_of, sc->nfe_free, sc->free_of, sc->nfe_free, &Mff, ctx);
      if (!st && sc->kpart) st = new_solver(sc, &Ml, ctx); /* M_ff in parts: PETSc sums them */
      else if (!st) st = mo_linsolver_create(&mo_linsolver_cholmod, &Ml, ctx);
      if (!st) st = mo_linsolver_factor(Ml, Mff, ctx);
      if (!st) st = mo_linsolver_solve(Ml, S->rhs, S->xf, ctx);
    }
    if (!st && S->nblk) {
      mo_what_inverse Wr = S->Wi;
      if (S->blk_varies) st = mo_stepper_rigid_update(S, s, ctx);
      rigid_rhs(S, s, s->a, S->rhs);
      Wr.nfe = 0; /* the rigid blocks alone */
      if (sc->nfe_free) memcpy(S->w2, S->xf, (size_t)sc->nfe_free * sizeof(double));
      if (!st) st = mo_what_solve(&Wr, 1, S->rhs, S->alias ? s->a : S->xf, ctx);
      if (sc->nfe_free) memcpy(S->xf, S->w2, (size_t)sc->nfe_free * sizeof(double));
    }
    if (!st && !S->alias) mo_stepper_scatter(S, S->xf, s->a);
    mo_linsolver_free(Ml);
    mo_csc_free(Mff);
    if (st) return mo_error_prefix(ctx, "initial acceleration (mass matrix)");
  }
  return MO_OK;
}

/* Products with K and M added to y (T201): into y itself, or with K and M in parts into the
   scene's accumulator, summed over the ranks once for all of them (parts_end). */
static double *parts_begin(const mo_scene *sc, double *y)
{
  if (!parts_summed(sc)) return y;
  memset(sc->pwork, 0, (size_t)sc->ndof * sizeof *sc->pwork);
  return sc->pwork;
}

static void parts_end(const mo_scene *sc, double *y)
{
  int i;
  if (!parts_summed(sc)) return;
  mo_par_sum(sc->pwork, sc->ndof, sc->pctx);
  for (i = 0; i < sc->ndof; i++) y[i] += sc->pwork[i];
}

/* The right-hand side of the unconstrained step at s (S->rhs over free dofs, rigid rows
   included) and the prescribed values of the unknown at t+ in x (full, 0 elsewhere). */
static int predict_rhs(mo_stepper *S, const mo_state *s, double *x, mo_ctx *ctx)
{
  const mo_scene *sc = S->sc;
  int n = sc->ndof, i, st;
  double h = S->h, tn = s->t + h;
  double *f1 = S->w1, *w = S->w2, *acc;
  if (S->nl)
    return mo_error(ctx, MO_EUNSUPPORTED, "mo_stepper_predict: a nonlinear scene's step is "
                    "mo_stepper_solve (Newton)");
  if (S->blk_varies && (st = mo_stepper_rigid_update(S, s, ctx))) return st;
  mo_scene_fext(sc, tn, f1);
  switch (S->scheme) {
  case MO_SCHEME_THETA: {
    /* J88 (3.3)_1 with the theta-scheme of doc/theory.md §1:
       What v+ = M v - h K (u + h theta_f (1 - theta) v) + h (theta_f f+ + (1 - theta_f) f)
                 - What_fp v+_p */
    double tf = S->theta_f, c = h * tf * (1 - S->theta), hf = h;
    /* central differences (T100): s->v is the velocity at t_k, the unknown v+ the one at
       t_k+1/2, reached by half the step's kick: M v+ = M v_k + h/2 f(t_k, u_k) (+ H r) */
    if (sc->time.explicit_cd) hf = 0.5 * h;
    if (w)
      for (i = 0; i < n; i++) {
        w[i] = s->u[i] + c * s->v[i];
        f1[i] = hf * (tf * f1[i] + (1 - tf) * s->f[i]);
      }
    else /* K has no entry (T246): its product adds nothing */
      for (i = 0; i < n; i++) f1[i] = hf * (tf * f1[i] + (1 - tf) * s->f[i]);
    acc = parts_begin(sc, f1);
    mo_csc_gaxpy(sc->M, 1, s->v, 1, acc);
    if (w) mo_csc_gaxpy(sc->K, -hf, w, 1, acc);
    memset(x, 0, (size_t)n * sizeof(double));
    presc_values(S, tn, NULL, x, NULL);
    if (S->Wfull) mo_csc_gaxpy(S->Wfull, -1, x, 1, acc);
    parts_end(sc, f1);
    break;
  }
  case MO_SCHEME_NEWMARK: {
    /* (M + beta h^2 K) a+ = f+ - K w - M z, w = u + h v + h^2 (1/2 - beta) a on free dofs and
       u+ on prescribed ones, z the prescribed accelerations */
    double b = S->beta;
    for (i = 0; i < n; i++) w[i] = s->u[i] + h * s->v[i] + h * h * (0.5 - b) * s->a[i];
    presc_values(S, tn, w, NULL, NULL);
    memset(x, 0, (size_t)n * sizeof(double));
    presc_values(S, tn, NULL, NULL, x);
    acc = parts_begin(sc, f1);
    mo_csc_gaxpy(sc->K, -1, w, 1, acc);
    if (S->Wfull) {
      /* w_p already holds u+_p: K w includes K_fp u+_p; remove the beta h^2 K a_p part that
         Wfull would add, by using M only for the accelerations */
      mo_csc_gaxpy(sc->M, -1, x, 1, acc);
    }
    parts_end(sc, f1);
    break;
  }
  case MO_SCHEME_QUASISTATIC:
    /* K u+ = f+ - K_fp u+_p */
    memset(w, 0, (size_t)n * sizeof(double));
    presc_values(S, tn, w, NULL, NULL);
    mo_scene_gaxpy(sc, sc->K, -1, w, 1, f1);
    memcpy(x, w, (size_t)n * sizeof(double));
    break;
  }
  if (!S->alias) mo_stepper_gather(S, f1, S->rhs); /* with alias rhs is f1 itself */
  if (S->nblk) rigid_rhs(S, s, x, S->rhs);
  return MO_OK;
}

int mo_stepper_predict(mo_stepper *S, const mo_state *s, double *x, mo_ctx *ctx)
{
  double t0 = mo_clock();
  int st;
  if (held_path(S)) {
    if ((st = loads_by_dof(S, ctx))) return st;
    predict_held(S, s, x);
    S->split_state = 0;
    mo_phase_add(ctx, MO_PH_SOLVE, t0);
    return MO_OK;
  }
  st = predict_rhs(S, s, x, ctx);
  S->split_state = 0;
  if (!st) st = mo_stepper_what_solve(S, 1, S->rhs, S->alias ? x : S->xf, ctx);
  if (!st && !S->alias) mo_stepper_scatter(S, S->xf, x);
  mo_phase_add(ctx, MO_PH_SOLVE, t0);
  return st;
}

/* --- the split step (doc/theory.md (T153)) ---------------------------------------------------- */

int mo_stepper_split_ready(const mo_stepper *S)
{
  /* MUMPS's Schur path orders the contact dofs last without the split solves (T180) */
  return S->ls && !S->nl && S->nlast > 0 && mo_linsolver_nlast(S->ls) == S->nlast && mo_linsolver_has_split(S->ls);
}

int mo_stepper_split_covers(const mo_stepper *S, const mo_csc *H)
{
  int p;
  if (!mo_stepper_split_ready(S)) return 0;
  for (p = 0; p < H->p[H->ncol]; p++)
    if (H->i[p] < S->nfe && !S->islast[H->i[p]]) return 0;
  return 1;
}

const int *mo_stepper_contact_dofs(const mo_stepper *S, int *nlast)
{
  *nlast = S->ls && mo_linsolver_nlast(S->ls) == S->nlast ? S->nlast : 0;
  return *nlast ? S->last : NULL;
}

/* The rigid rows of x = What^-1 b (free vectors): their blocks. */
static void rigid_rows(const mo_stepper *S, const double *b, double *x, int add)
{
  int k;
  for (k = 0; k < S->nblk; k++) block_apply(&S->Wi, k, b, x, add);
}

int mo_stepper_predict_split(mo_stepper *S, const mo_state *s, double *x, mo_ctx *ctx)
{
  const mo_scene *sc = S->sc;
  int nfe = S->nfe, nI = nfe - S->nlast, i, k, st;
  double t0 = mo_clock();
  if (!mo_stepper_split_ready(S)) return mo_error(ctx, MO_EINTERNAL, "split step without contact dofs last");
  if ((st = predict_rhs(S, s, x, ctx))) goto done;
  /* y = L^-1 P rhs, kept; the contact dofs of x_free from its trailing block alone */
  if ((st = mo_linsolver_split(S->ls, MO_SPLIT_FORWARD, S->rhs, S->ysplit, ctx))) goto done;
  if ((st = mo_linsolver_split(S->ls, MO_SPLIT_TRAIL_BACKWARD, S->ysplit + nI, S->cw, ctx))) goto done;
  for (i = 0; i < nfe; i++) S->xf[i] = NAN; /* not computed until the correction */
  for (k = 0; k < S->nlast; k++) S->xf[S->last[k]] = S->cw[k];
  rigid_rows(S, S->rhs, S->xf, 0);
  mo_stepper_scatter(S, S->xf, x);
  S->split_state = 1;
  (void)sc;
done:
  mo_phase_add(ctx, MO_PH_SOLVE, t0);
  return st;
}

/* x_free = What^-1 (rhs + imp) from the kept forward solve (imp_full NULL: no impulse). */
static int split_finish(mo_stepper *S, const double *imp_full, double *x, mo_ctx *ctx)
{
  int nfe = S->nfe, nI = nfe - S->nlast, i, k, st, inside = 1;
  if (S->split_state != 1) return mo_error(ctx, MO_EINTERNAL, "split correction without its prediction");
  S->split_state = 2;
  if (imp_full) {
    mo_stepper_gather(S, imp_full, S->rhs);
    for (k = 0; k < S->nlast; k++) {
      S->cw[k] = S->rhs[S->last[k]];
      S->rhs[S->last[k]] = 0;
    }
    for (i = 0; i < nfe && inside; i++) inside = S->rhs[i] == 0;
    if (inside) {
      /* the impulse lives on the contact dofs: its forward solve is L22's alone */
      if ((st = mo_linsolver_split(S->ls, MO_SPLIT_TRAIL_FORWARD, S->cw, S->cw, ctx))) return st;
      for (k = 0; k < S->nlast; k++) S->ysplit[nI + k] += S->cw[k];
    } else {
      double *y = S->w1; /* full-size work, free here */
      for (k = 0; k < S->nlast; k++) S->rhs[S->last[k]] = S->cw[k];
      if ((st = mo_linsolver_split(S->ls, MO_SPLIT_FORWARD, S->rhs, y, ctx))) return st;
      for (i = 0; i < nfe; i++) S->ysplit[i] += y[i];
    }
  }
  if ((st = mo_linsolver_split(S->ls, MO_SPLIT_BACKWARD, S->ysplit, S->xf, ctx))) return st;
  /* the rigid rows: x_free there (from the prediction) plus their blocks times the impulse */
  for (i = nfe; i < S->sc->nfree; i++) S->xf[i] = x[S->sc->full_of[i]];
  if (imp_full) rigid_rows(S, S->rhs, S->xf, 1);
  mo_stepper_scatter(S, S->xf, x);
  return MO_OK;
}

int mo_stepper_correct_split(mo_stepper *S, const double *imp_full, double *x, mo_ctx *ctx)
{
  double t0 = mo_clock();
  int st = split_finish(S, imp_full, x, ctx);
  mo_phase_add(ctx, MO_PH_CORRECT, t0);
  return st;
}

int mo_stepper_complete_split(mo_stepper *S, double *x, mo_ctx *ctx)
{
  double t0 = mo_clock();
  int st = split_finish(S, NULL, x, ctx);
  mo_phase_add(ctx, MO_PH_CORRECT, t0);
  return st;
}

int mo_stepper_correct(mo_stepper *S, const double *imp, double *dx, mo_ctx *ctx)
{
  int st;
  double t0 = mo_clock();
  if (S->alias) /* T246: the full numbering is the free one, What^-1 imp solved into dx */
    st = mo_stepper_what_solve(S, 1, imp, dx, ctx);
  else {
    mo_stepper_gather(S, imp, S->rhs);
    st = mo_stepper_what_solve(S, 1, S->rhs, S->xf, ctx);
    memset(dx, 0, (size_t)S->sc->ndof * sizeof(double));
    if (!st) mo_stepper_scatter(S, S->xf, dx);
  }
  mo_phase_add(ctx, MO_PH_SOLVE, t0);
  return st;
}

/* Support reactions over the step on prescribed dofs; K and M are symmetric, so row p is
   column p and only the prescribed columns are visited. */
/* The rigid body holding dof d (bodies are numbered in dof order): its rank in sc->rigid. */
static int rigid_of_dof(const mo_scene *sc, int d)
{
  int lo = 0, hi = sc->nrigid - 1;
  while (lo <= hi) {
    int mid = (lo + hi) / 2;
    const mo_body *B = &sc->body[sc->rigid[mid]];
    if (d < B->dof0) hi = mid - 1;
    else if (d >= B->dof0 + B->ndof) lo = mid + 1;
    else return mid;
  }
  return -1;
}

/* The inertia term of a prescribed rigid dof's reaction: [M_b (v+ - v-) / h]_d (theta) or
   [M_b a+]_d (Newmark). */
static double rigid_inertia(const mo_stepper *S, const mo_state *s, int d)
{
  const mo_scene *sc = S->sc;
  int r = rigid_of_dof(sc, d), nd = mo_rigid_ndof(sc->dim), j;
  const mo_body *B;
  double acc = 0;
  if (r < 0) return 0;
  B = &sc->body[sc->rigid[r]];
  for (j = 0; j < nd; j++)
    acc += rig_mass(S, r, nd, d - B->dof0, j) * (S->scheme == MO_SCHEME_NEWMARK ? s->a[B->dof0 + j]
                                                   : (s->v[B->dof0 + j] - S->vprev[B->dof0 + j]) / S->h);
  return acc;
}

static void reactions(const mo_stepper *S, mo_state *s)
{
  const mo_scene *sc = S->sc;
  const mo_csc *K = sc->K, *M = sc->M;
  /* central differences (T100): v_k+1 - v_k carries h/2 of the forces at both ends */
  double h = S->h, tf = sc->time.explicit_cd ? 0.5 : S->theta_f;
  int k, p;
  for (k = 0; k < sc->npresc; k++) {
    int d = sc->presc[k].dof;
    double r = 0;
    if (S->nl) {
      /* the internal forces at the two ends of the step (K u of linear bodies included) */
      switch (S->scheme) {
      case MO_SCHEME_THETA:
        r = tf * S->fint[d] + (1 - tf) * S->fint0[d];
        for (p = M->p[d]; p < M->p[d + 1]; p++) r += M->x[p] * (s->v[M->i[p]] - S->vprev[M->i[p]]) / h;
        r -= tf * s->f[d] + (1 - tf) * S->fprev[d];
        break;
      case MO_SCHEME_NEWMARK:
        r = S->fint[d] - s->f[d];
        for (p = M->p[d]; p < M->p[d + 1]; p++) r += M->x[p] * s->a[M->i[p]];
        break;
      case MO_SCHEME_QUASISTATIC:
        r = S->fint[d] - s->f[d];
        break;
      }
      s->reac[d] = r + (d >= sc->nfe_dof ? rigid_inertia(S, s, d) : 0);
      continue;
    }
    switch (S->scheme) {
    case MO_SCHEME_THETA:
      for (p = K->p[d]; p < K->p[d + 1]; p++)
        r += K->x[p] * (tf * s->u[K->i[p]] + (1 - tf) * S->uprev[K->i[p]]);
      for (p = M->p[d]; p < M->p[d + 1]; p++) r += M->x[p] * (s->v[M->i[p]] - S->vprev[M->i[p]]) / h;
      break;
    case MO_SCHEME_NEWMARK:
      for (p = K->p[d]; p < K->p[d + 1]; p++) r += K->x[p] * s->u[K->i[p]];
      for (p = M->p[d]; p < M->p[d + 1]; p++) r += M->x[p] * s->a[M->i[p]];
      break;
    case MO_SCHEME_QUASISTATIC:
      for (p = K->p[d]; p < K->p[d + 1]; p++) r += K->x[p] * s->u[K->i[p]];
      break;
    }
    s->reac[d] = r;
  }
  if (S->nl) return;
  /* K and M in parts over the ranks: the columns' products are the sums of the parts' */
  if (parts_summed(sc)) {
    for (k = 0; k < sc->npresc; k++) sc->pwork[k] = s->reac[sc->presc[k].dof];
    mo_par_sum(sc->pwork, sc->npresc, sc->pctx);
    for (k = 0; k < sc->npresc; k++) s->reac[sc->presc[k].dof] = sc->pwork[k];
  }
  for (k = 0; k < sc->npresc; k++) {
    int d = sc->presc[k].dof;
    double r = s->reac[d];
    switch (S->scheme) {
    case MO_SCHEME_THETA: r -= tf * s->f[d] + (1 - tf) * S->fprev[d]; break;
    case MO_SCHEME_NEWMARK:
    case MO_SCHEME_QUASISTATIC: r -= s->f[d]; break;
    }
    s->reac[d] = r + (d >= sc->nfe_dof && S->scheme != MO_SCHEME_QUASISTATIC ? rigid_inertia(S, s, d) : 0);
  }
}

/* A non-finite unknown: say where, and whether the data or the step produced it. */
static int nan_diagnosis(const mo_stepper *S, const mo_state *s, const double *x, int dof, mo_ctx *ctx)
{
  const mo_scene *sc = S->sc;
  double tn = s->t + S->h;
  int b, i, bad_load = -1, nbad = 0;
  char where[160] = "";
  for (i = 0; i < sc->ndof; i++) nbad += !isfinite(x[i]);
  for (b = 0; b < sc->nbody; b++) {
    const mo_body *B = &sc->body[b];
    if (B->kind == MO_BODY_DEFORMABLE && dof >= B->dof0 && dof < B->dof0 + B->ndof) {
      snprintf(where, sizeof where, " (body '%s', node %d, component %c)", B->name,
               (dof - B->dof0) / sc->dim, "xyz"[(dof - B->dof0) % sc->dim]);
      break;
    }
    if ((B->type->flags & MO_BODY_F_RIGID) && dof >= B->dof0 && dof < B->dof0 + B->ndof) {
      static const char *const n2[] = {"x", "y", "theta"}, *const n3[] = {"x", "y", "z", "rx", "ry", "rz"};
      snprintf(where, sizeof where, " (rigid body '%s', dof %s)", B->name,
               sc->dim == 2 ? n2[dof - B->dof0] : n3[dof - B->dof0]);
      break;
    }
  }
  for (i = 0; i < sc->nload && bad_load < 0; i++) {
    const mo_load *L = &sc->load[i];
    double a = L->amp ? mo_expr_eval(L->amp, &tn) : 1;
    if (!isfinite(a)) bad_load = i;
  }
  if (bad_load >= 0)
    return mo_error(ctx, MO_ENAN, "step %ld (t = %.6g): %d unknowns are not finite, the first dof %d%s. "
                    "The cause is in the data: the amplitude of load %d (\"%s\") is not finite at t = %.6g; "
                    "give it a value for every time of the run", s->step + 1, tn, nbad, dof, where, bad_load,
                    mo_expr_source(sc->load[bad_load].amp), tn);
  return mo_error(ctx, MO_ENAN, "step %ld (t = %.6g): %d unknowns are not finite, the first dof %d%s. "
                  "The data are finite at this time, so the step itself diverged: check the material "
                  "constants and the time step (a smaller step, or theta closer to 1, damps what the "
                  "scheme cannot resolve)", s->step + 1, tn, nbad, dof, where);
}

/* Whether dof i's body is counted on this rank (mo_stepper_hold: a scene of rigid bodies only, dof
   i of rigid body i / nd). */
static inline int counted(const mo_stepper *S, int i)
{
  return !S->bcount || S->bcount[S->sc->rigid[i / mo_rigid_ndof(S->sc->dim)]];
}

/* The theta-scheme's increment of u at dof i over the step, u_k+1 - u_k, formed before u moves
   from the same operations as the update (T247): the value u_k+1 - uprev gives, to the bit. */
static inline double theta_du(const mo_stepper *S, const mo_state *s, const double *x, int i)
{
  return (s->u[i] + S->h * (S->theta * x[i] + (1 - S->theta) * s->v[i])) - s->u[i];
}

/* Without uprev (T247): the load patterns' work over the step and the 3D rotations, from the
   increments before u moves (the same sums, in the same order, as after it with uprev). */
static double ahead_of_update(const mo_stepper *S, mo_state *s, const double *x)
{
  const mo_scene *sc = S->sc;
  double tn = s->t + S->h, dw = 0;
  int l, k, i;
  for (k = 0; k < sc->nrigid && sc->dim == 3; k++) {
    const mo_body *B = &sc->body[sc->rigid[k]];
    double phi[3];
    for (i = 0; i < 3; i++) phi[i] = theta_du(S, s, x, B->dof0 + 3 + i);
    mo_quat_rotate(s->orient + 4 * B->orient, phi);
  }
  for (l = 0; l < sc->nload; l++) {
    const mo_load *L = &sc->load[l];
    double a0 = L->amp ? mo_expr_eval(L->amp, &s->t) : 1, a1 = L->amp ? mo_expr_eval(L->amp, &tn) : 1;
    for (k = 0; k < L->n; k++)
      if (counted(S, L->dof[k])) dw += 0.5 * (a0 + a1) * L->val[k] * theta_du(S, s, x, L->dof[k]);
  }
  return dw;
}



static int finish_held(mo_stepper *S, mo_state *s, const double *x, mo_ctx *ctx)
{
  const mo_scene *sc = S->sc;
  const int nd = mo_rigid_ndof(sc->dim);
  const double h = S->h, tn = s->t + h, t0 = mo_clock(), th = S->theta;
  double dw = 0, *c = S->ld_a0;
  int k, i, l, st;
  if ((st = loads_by_dof(S, ctx))) return st;
  for (k = 0; k < S->nhl; k++) {
    const int d0 = S->hd0[S->hlist[k]];
    for (i = 0; i < nd && d0 >= 0; i++)
      if (!isfinite(x[d0 + i])) return nan_diagnosis(S, s, x, d0 + i, ctx);
  }
  /* the loads' amplitudes at t_k+1, and their trapezoid's factors 0.5 (a_k + a_k+1) */
  load_amps(sc, s->t, c);
  load_amps(sc, tn, S->ld_a);
  for (l = 0; l < sc->nload; l++) c[l] = 0.5 * (c[l] + S->ld_a[l]);
  for (k = 0; k < S->nhl; k++) {
    const int b = S->hlist[k], d0 = S->hd0[b], cnt = !S->bcount || S->bcount[b];
    int e;
    if (d0 < 0) continue;
    /* ahead_of_update's, before u moves: the 3D rotation, the loads' work over the step */
    if (sc->dim == 3) {
      double phi[3];
      for (i = 0; i < 3; i++) phi[i] = theta_du(S, s, x, d0 + 3 + i);
      mo_quat_rotate(s->orient + 4 * sc->body[b].orient, phi);
    }
    for (i = d0; i < d0 + nd; i++) {
      if (cnt && S->ld_lo[i] < S->ld_lo[i + 1]) {
        const double du = theta_du(S, s, x, i);
        for (e = S->ld_lo[i]; e < S->ld_lo[i + 1]; e++) dw += c[S->ld_l[e]] * S->ld_v[e] * du;
      }
      s->u[i] += h * (th * x[i] + (1 - th) * s->v[i]);
      s->v[i] = x[i];
      s->f[i] = S->fconst ? S->fconst[i] : fext_dof(S, S->ld_a, i);
    }
  }
  if (S->bcount && (st = mo_par_sum(&dw, 1, ctx))) return st;
  s->wext += dw;
  s->t = tn;
  s->step++;
  mo_phase_add(ctx, MO_PH_SOLVE, t0);
  return MO_OK;
}

int mo_stepper_finish(mo_stepper *S, mo_state *s, const double *x, mo_ctx *ctx)
{
  const mo_scene *sc = S->sc;
  int n = sc->ndof, i, l, k;
  double h = S->h, tn = s->t + h, t0 = mo_clock(), dw = 0, ws = 0;
  if (held_path(S) && !S->uprev) return finish_held(S, s, x, ctx);
  for (i = 0; i < n; i++)
    if (!isfinite(x[i])) return nan_diagnosis(S, s, x, i, ctx);
  if (S->uprev) memcpy(S->uprev, s->u, (size_t)n * sizeof(double));
  else dw = ahead_of_update(S, s, x);
  if (S->vprev) memcpy(S->vprev, s->v, (size_t)n * sizeof(double));
  if (S->fprev) memcpy(S->fprev, s->f, (size_t)n * sizeof(double));
  switch (S->scheme) {
  case MO_SCHEME_THETA:
    for (i = 0; i < n; i++) {
      s->u[i] += h * (S->theta * x[i] + (1 - S->theta) * s->v[i]);
      s->v[i] = x[i];
    }
    break;
  case MO_SCHEME_NEWMARK: {
    double b = S->beta, g = S->gamma;
    for (i = 0; i < n; i++) {
      s->u[i] += h * s->v[i] + h * h * ((0.5 - b) * s->a[i] + b * x[i]);
      s->v[i] += h * ((1 - g) * s->a[i] + g * x[i]);
      s->a[i] = x[i];
    }
    break;
  }
  case MO_SCHEME_QUASISTATIC:
    for (i = 0; i < n; i++) {
      s->v[i] = (x[i] - s->u[i]) / h;
      s->u[i] = x[i];
    }
    break;
  }
  /* prescribed dofs exactly on their path */
  presc_values(S, tn, s->u, S->scheme == MO_SCHEME_QUASISTATIC ? NULL : s->v, NULL);
  /* 3D rigid bodies turn by the increment of the integral of omega over the step (T69) */
  for (k = 0; k < sc->nrigid && sc->dim == 3 && S->uprev; k++) {
    const mo_body *B = &sc->body[sc->rigid[k]];
    double phi[3];
    for (i = 0; i < 3; i++) phi[i] = s->u[B->dof0 + 3 + i] - S->uprev[B->dof0 + 3 + i];
    mo_quat_rotate(s->orient + 4 * B->orient, phi);
  }
  mo_scene_fext(sc, tn, s->f);
  if (S->scheme == MO_SCHEME_THETA && sc->time.explicit_cd) {
    /* central differences (T100): the second half kick, v_k+1 = v+ + h/2 M^-1 f(t_k+1, u_k+1)
       on free dofs, so that the state holds velocities at the time of its displacements */
    int st;
    double *r = S->w1, *xf = S->alias ? S->w1 : S->xf; /* alias: solved in place (block_apply) */
    memcpy(r, s->f, (size_t)n * sizeof(double));
    mo_scene_gaxpy(sc, sc->K, -1, s->u, 1, r);
    if (!S->alias) mo_stepper_gather(S, r, S->rhs);
    if ((st = mo_stepper_what_solve(S, 1, S->rhs, xf, ctx))) return st;
    for (i = 0; i < sc->nfree; i++) xf[i] *= 0.5 * h;
    for (i = 0; i < sc->nfree; i++) s->v[sc->full_of[i]] += xf[i];
  }
  /* external work, trapezoidal in time, over the load patterns only */
  for (l = 0; l < sc->nload && S->uprev; l++) {
    const mo_load *L = &sc->load[l];
    double a0 = L->amp ? mo_expr_eval(L->amp, &s->t) : 1, a1 = L->amp ? mo_expr_eval(L->amp, &tn) : 1;
    for (k = 0; k < L->n; k++)
      if (counted(S, L->dof[k])) dw += 0.5 * (a0 + a1) * L->val[k] * (s->u[L->dof[k]] - S->uprev[L->dof[k]]);
  }
  if (S->bcount) {
    int st = mo_par_sum(&dw, 1, ctx);
    if (st) return st;
  }
  s->wext += dw;
  s->t = tn;
  s->step++;
  if (sc->npresc) {
    reactions(S, s);
    if (sc->has_moving_presc) {
      for (k = 0; k < sc->npresc; k++) {
        int d = sc->presc[k].dof;
        ws += s->reac[d] * (s->u[d] - S->uprev[d]);
      }
      s->wsupport += ws;
    }
  }
  if (S->nl) {
    /* commit: the trial states of the solution, its internal forces, its energies */
    memcpy(s->q, S->qt, sc->nq * sizeof *s->q);
    memcpy(S->fint0, S->fint, (size_t)n * sizeof *S->fint0);
    mo_tangent_energies(S, s->q, &s->psi, &s->wplastic);
  }
  mo_phase_add(ctx, MO_PH_SOLVE, t0);
  return MO_OK;
}

/* A position correction at the end of a step (doc/theory.md (T95)): u += du on the free dofs
   (du given on them), v unchanged; the load patterns' work over du at t_k+1 joins the external
   work and the support reactions follow u. Linear scenes only (a finite-strain body's committed
   material state belongs to the u it was computed at). */
int mo_stepper_shift(mo_stepper *S, mo_state *s, const double *du_free, mo_ctx *ctx)
{
  const mo_scene *sc = S->sc;
  int i, l, k;
  double dw = 0;
  if (S->nl) return mo_error(ctx, MO_EUNSUPPORTED, "a position correction on a finite-strain scene");
  for (i = 0; i < sc->nfree; i++) s->u[sc->full_of[i]] += du_free[i];
  for (l = 0; l < sc->nload; l++) {
    const mo_load *L = &sc->load[l];
    double a1 = L->amp ? mo_expr_eval(L->amp, &s->t) : 1;
    for (k = 0; k < L->n; k++) {
      int f = sc->free_of[L->dof[k]];
      if (f >= 0) dw += a1 * L->val[k] * du_free[f];
    }
  }
  s->wext += dw;
  if (sc->npresc) reactions(S, s);
  return MO_OK;
}
