/* local_problem.c: a back end on a given local problem U = W r + q (FCLIB files, benchmarks,
   tests), through the same seam as a run: the problem is handed over as a mo_contact_problem
   without geometry or global system. */
#include "config.h"
#include <moreau/contact.h>

#include <math.h>
#include <string.h>

struct mo_local_solver {
  const mo_contact_solver_type *T;
  void *params, *state;
  int ready;                  /* the state has been initialised with the current params */
  mo_contact_problem P;
  double *zeros;              /* m: gaps, previous velocities */
  double *ones;               /* nc: measures */
  unsigned char *active;      /* nc */
  int *status;                /* nc, when the caller gives none */
  double qnorm;
  int noverify;               /* mo_local_solver_verify(L, 0) */
};

void mo_local_solver_verify(mo_local_solver *L, int on)
{
  L->noverify = !on;
}

void mo_local_solver_free(mo_local_solver *L)
{
  if (!L) return;
  if (L->ready && L->T->free) L->T->free(L->state);
  mo_free(L->state);
  mo_free(L->params);
  mo_free(L->zeros);
  mo_free(L->ones);
  mo_free(L->active);
  mo_free(L->status);
  mo_free(L);
}

int mo_local_solver_create(const mo_contact_solver_type *T, const mo_delassus *W, const double *q,
                           const double *mu, mo_local_solver **out, mo_ctx *ctx)
{
  mo_local_solver *L;
  mo_contact_problem *P;
  int nc, m, d, i;
  *out = NULL;
  if (!(T->needs & MO_NEEDS_DELASSUS) || (T->needs & MO_NEEDS_GLOBAL))
    return mo_error(ctx, MO_EUNSUPPORTED, "back end %s does not solve local problems on the Delassus "
                    "operator alone", T->name);
  d = mo_delassus_dim(W);
  m = mo_delassus_m(W);
  nc = m / d;
  L = mo_calloc(ctx, 1, sizeof *L);
  if (!L) return MO_ENOMEM;
  L->T = T;
  L->params = mo_calloc(ctx, 1, T->params_size ? T->params_size : 1);
  L->state = mo_calloc(ctx, 1, T->state_size ? T->state_size : 1);
  L->zeros = mo_calloc(ctx, (size_t)m + 1, sizeof *L->zeros);
  L->ones = mo_malloc(ctx, ((size_t)nc + 1) * sizeof *L->ones);
  L->active = mo_malloc(ctx, (size_t)nc + 1);
  L->status = mo_calloc(ctx, (size_t)nc + 1, sizeof *L->status);
  if (!L->params || !L->state || !L->zeros || !L->ones || !L->active || !L->status) {
    mo_local_solver_free(L);
    return MO_ENOMEM;
  }
  for (i = 0; i < nc; i++) {
    L->ones[i] = 1;
    L->active[i] = 1;
  }
  for (i = 0; i < m; i++) L->qnorm += q[i] * q[i];
  L->qnorm = sqrt(L->qnorm);
  if (T->defaults) T->defaults(L->params);
  P = &L->P;
  P->dim = d;
  P->nc = nc;
  P->m = m;
  P->mu = mu;
  P->g = L->zeros;
  P->Uprev = L->zeros;
  P->w = L->ones;
  P->W = W;
  P->b = q;
  P->active = L->active;
  P->scheme = MO_SCHEME_THETA;
  P->h = P->theta = P->theta_f = 1;
  P->du_dx = 1;
  P->step = 1;
  *out = L;
  return MO_OK;
}

int mo_local_solver_set(mo_local_solver *L, const char *key, const char *val, mo_ctx *ctx)
{
  int st = mo_option_set(L->T->options, L->T->noptions, L->params, key, val, ctx);
  if (st) return st;
  /* the back end reads its parameters at init: start again with the new ones */
  if (L->ready && L->T->free) L->T->free(L->state);
  L->ready = 0;
  return MO_OK;
}

int mo_local_solver_solve(mo_local_solver *L, double *r, double *U, int *status,
                          mo_contact_report *rep, mo_ctx *ctx)
{
  mo_contact_vars x;
  int st, i;
  memset(rep, 0, sizeof *rep);
  rep->residual = NAN;
  if (!L->ready) {
    memset(L->state, 0, L->T->state_size ? L->T->state_size : 1);
    if (L->T->init && (st = L->T->init(L->state, L->params, &L->P, ctx))) return st;
    L->ready = 1;
  }
  L->P.u_measured = !L->noverify; /* U = W r + q is recomputed below */
  memset(&x, 0, sizeof x);
  x.r = r;
  x.U = U;
  x.status = status ? status : L->status;
  x.dx = NULL;
  if ((st = L->T->solve(L->state, &L->P, &x, rep, ctx)))
    return mo_error_prefix(ctx, "back end %s on a local problem", L->T->name);
  for (i = 0; i < L->P.m; i++)
    if (!isfinite(r[i]))
      return mo_error(ctx, MO_ENAN, "back end %s returned a non-finite reaction at contact %d", L->T->name, i / L->P.dim);
  if (L->noverify) return MO_OK;
  /* the core's measure (T10) on U = W r + q */
  mo_delassus_mult(L->P.W, r, 0, U);
  for (i = 0; i < L->P.m; i++) U[i] += L->P.b[i];
  rep->residual = mo_fc_natural_map(L->P.dim, L->P.nc, L->P.mu, r, U, L->qnorm);
  return MO_OK;
}
