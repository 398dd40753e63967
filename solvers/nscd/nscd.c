/* nscd.c: the nscd back end: Jean's nonlinear Gauss-Seidel over contacts on U = W r + q
   (J88 §3.3, (3.3)_5-6; doc/theory.md §8), its options, and its type object. */
#include "config.h"
#include "nscd.h"
#include <moreau/parallel.h>

#include <gsl/gsl_randist.h>
#include <gsl/gsl_rng.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

/* --- options ----------------------------------------------------------------------------------- */

static const mo_option_spec nscd_options[] = {
  {"tol", MO_OPT_DOUBLE, offsetof(nscd_params, tol), NULL, 0, 1, "1e-8",
   "Tolerance of the stopping rule."},
  {"stop", MO_OPT_ENUM, offsetof(nscd_params, stop), "scaled|natural|quad|maxm|sweeps", NAN, NAN, "\"scaled\"",
   "Stopping rule: the natural-map residual of the problem scaled contact by contact (T42), the natural-map "
   "residual as the core measures it (T10, Siconos' definition, which depends on the units), Jean's norms "
   "of the change over a sweep (T11), or exactly max_sweeps sweeps (to replay a published run)."},
  {"max_sweeps", MO_OPT_INT, offsetof(nscd_params, max_sweeps), NULL, 1, 1e9, "1000",
   "Sweep limit; reaching it is a non-converged solve (contact.on_failure decides)."},
  {"relax", MO_OPT_DOUBLE, offsetof(nscd_params, relax), NULL, 0.01, 2, "1",
   "Relaxation omega: each contact takes omega r_local + (1 - omega) r (T37)."},
  {"order", MO_OPT_ENUM, offsetof(nscd_params, order), "natural|reverse|shuffled", NAN, NAN, "\"natural\"",
   "Order in which a sweep visits the contacts (shuffled: a GSL random permutation seeded by the run)."},
  {"reshuffle", MO_OPT_BOOL, offsetof(nscd_params, reshuffle), NULL, NAN, NAN, "false",
   "With order = \"shuffled\": a new permutation at every sweep."},
  {"warm_start", MO_OPT_BOOL, offsetof(nscd_params, warm_start), NULL, NAN, NAN, "true",
   "Start from the previous step's reactions (false: from zero)."},
  {"local_tol", MO_OPT_DOUBLE, offsetof(nscd_params, local_tol), NULL, 1e-16, 1e-2, "1e-13",
   "3D local solver: Newton stops when |phi| <= local_tol (|r| + |q_n| / W_nn) (T39)."},
  {"local_iter", MO_OPT_INT, offsetof(nscd_params, local_iter), NULL, 1, 1000, "20",
   "3D local solver: Newton iterations before the fallbacks (T40), (T41)."},
  {"accelerate", MO_OPT_BOOL, offsetof(nscd_params, accelerate), NULL, NAN, NAN, "true",
   "When the sweeps stall (less than a factor 2 over 10 sweeps) with stable statuses, solve the linear problem "
   "of the closed contacts directly and keep its solution if it satisfies the law (T83); with the residual "
   "rules only."},
  {"split_min", MO_OPT_INT, offsetof(nscd_params, split_min), NULL, 0, 1e9, "128",
   "Over MPI ranks, granular scenes: the sweep is split over the ranks only when the solve has at least this many "
   "active contacts a rank; a smaller set is swept whole on every rank, as one process sweeps it (T333). 0: "
   "split every solve."},
};

void nscd_params_default(nscd_params *p)
{
  p->tol = 1e-8;
  p->stop = NSCD_STOP_SCALED;
  p->max_sweeps = 1000;
  p->relax = 1;
  p->order = NSCD_ORDER_NATURAL;
  p->reshuffle = 0;
  p->warm_start = 1;
  p->local_tol = 1e-13;
  p->local_iter = 20;
  p->accelerate = 1;
  p->split_min = NSCD_SPLIT_MIN;
}

static void nscd_defaults(void *params) { nscd_params_default(params); }

/* --- state --------------------------------------------------------------------------------------- */



static void nscd_free(void *state)
{
  nscd_state *S = state;
  if (!S) return;
  mo_free(S->rcnt);
  mo_free(S->rcol);
  mo_free(S->rval);
  mo_free(S->diag);
  mo_free(S->cp);
  mo_free(S->cb);
  mo_free(S->cv);
  mo_free(S->aux);
  mo_free(S->actown);
  mo_free(S->ordown);
  mo_free(S->Uown);
  mo_free(S->rold);
  mo_free(S->scale);
  mo_free(S->muown);
  mo_free(S->rng_state);
  mo_free(S->sprev);
  mo_free(S->wnown);
  mo_free(S->wnc);
  mo_free(S->wnp);
  nscd_status_cache_free(S);
  nscd_bodies_free(S);
  nscd_grains_free(S);
  memset(S, 0, sizeof *S);
}

/* The state brought to P's contact set: sizes, the arrays grown when the set grew (kept
   otherwise), nothing derived from an older set's W. */
static int fit_set(nscd_state *S, const mo_contact_problem *P, mo_ctx *ctx)
{
  size_t nc = (size_t)P->nc + 1, m = (size_t)P->m + 1;
  void *q;
  S->nc = P->nc;
  S->d = P->dim;
  S->m = P->m;
  S->wsrc = NULL;
  S->wver = -1;
  S->lu.valid = 0; /* its kinds are those of the old set's candidates */
  /* without W, every contact joins rigid bodies (and obstacles): the sweep on body velocities */
  S->bodies = !P->W;
  S->grains = S->bodies && P->grains;
  if (S->bodies && ((!P->H && !P->grains) || !P->Wi || !P->xfree))
    return mo_error(ctx, MO_EINTERNAL, "nscd: the core gave neither W nor the blocks of H and What");
#define GROW(ptr, n) if (!(q = mo_realloc(ctx, ptr, (n) * sizeof *(ptr)))) return MO_ENOMEM; ptr = q
  if (nc > S->cap) S->cap = mo_contact_room(P->contact, nc); /* the contact set's capacity (T252) */
  /* the index set: the granular path reads the problem's (T250) */
  if (!S->grains && S->cap > S->aocap) {
    GROW(S->actown, S->cap);
    S->aocap = S->cap;
  }
  /* the friction coefficients: the granular path's are the problem's own until a contact differs
     (nscd_grains_prepare makes them then) */
  if ((!S->grains || S->muown) && S->cap > S->mucap) {
    GROW(S->muown, S->cap);
    S->mucap = S->cap;
  }
  /* W_aa's pointers and the scaling: the granular path reads them from its records */
  if (S->grains) {
    mo_free(S->diag);
    mo_free(S->scale);
    S->diag = NULL;
    S->scale = NULL;
    S->dcap = 0;
  } else if (S->cap > S->dcap) {
    GROW(S->diag, S->cap); GROW(S->scale, S->cap);
    S->dcap = S->cap;
  }
  /* what the sweep on W keeps per contact (its rows, the statuses of the previous sweep), and the
     local solvers' data outside the records of the granular path */
  if (!S->bodies && S->cap > S->wcap) {
    GROW(S->rcnt, S->cap); GROW(S->rcol, S->cap); GROW(S->rval, S->cap); GROW(S->sprev, S->cap);
    S->wcap = S->cap;
  }
  if (!S->grains && S->cap > S->acap) {
    GROW(S->aux, S->cap * NSCD_AUX);
    S->acap = S->cap;
  }
  if (m > S->mcap) {
    m += m / 2;
    S->mcap = m;
  }
  /* the reactions before a sweep, for Jean's norms: the granular sweep sums their parts as it
     goes (S->jp), on one rank and over several (T273) */
  if (S->grains) {
    mo_free(S->rold);
    S->rold = NULL;
    S->rcap = 0;
  } else if (S->mcap > S->rcap) {
    GROW(S->rold, S->mcap);
    S->rcap = S->mcap;
  }
  if (!S->grains && S->mcap > S->ucap) {
    GROW(S->Uown, S->mcap);
    S->ucap = S->mcap;
  }
#undef GROW
  return MO_OK;
}

static int nscd_init(void *state, const void *params, const mo_contact_problem *P, mo_ctx *ctx)
{
  nscd_state *S = state;
  int st;
  memset(S, 0, sizeof *S);
  S->p = *(const nscd_params *)params;
  if ((st = fit_set(S, P, ctx))) {
    nscd_free(S);
    return st;
  }
  if (!(S->rng_state = mo_calloc(ctx, 1, gsl_rng_mt19937->size + 1))) {
    nscd_free(S);
    return MO_ENOMEM;
  }
  S->rng.type = gsl_rng_mt19937;
  S->rng.state = S->rng_state;
  gsl_rng_mt19937->set(S->rng_state, ctx->seed);
  return MO_OK;
}

/* A new contact set (detected contacts between rigid bodies change it at most steps): the
   memory is kept, the generator goes on. */
static int nscd_reinit(void *state, const mo_contact_problem *P, mo_ctx *ctx)
{
  return fit_set(state, P, ctx);
}

void nscd_prepare_local(nscd_state *S, const mo_contact_problem *P)
{
  int d = S->d, a, t;
  S->mu = S->muown;
  for (a = 0; a < S->nc; a++) {
    double wtt = 0;
    for (t = 1; t < d; t++) wtt += S->diag[a][t * d + t];
    S->muown[a] = P->mu && !(d > 1 && !(wtt > 1e-12 * S->diag[a][0])) ? P->mu[a] : 0;
    nscd_local_prepare(d, S->diag[a], S->mu[a], S->aux + (size_t)a * NSCD_AUX);
    S->scale[a] = S->diag[a][0] > 0 ? 1 / S->diag[a][0] : 0;
  }
}

/* S->wn and wnp from W's own normal entries (T164), 1 when every row has them where nscd reads
   its row (the whole block row, W's order). */
static int W_normal_rows(nscd_state *S)
{
  const double *w0 = NULL;
  int a;
  for (a = 0; a < S->nc; a++) {
    const int *beta;
    const double *wa;
    int n = mo_delassus_row_normal(S->wsrc, a, &beta, &wa);
    if (!wa || n != S->rcnt[a] || beta != S->rcol[a]) return 0;
    if (!a) w0 = wa;
    S->wnp[a] = (size_t)(wa - w0);
  }
  S->wnp[S->nc] = S->nc ? S->wnp[S->nc - 1] + (size_t)S->rcnt[S->nc - 1] : 0;
  S->wn = w0;
  return 1;
}

/* Frictionless contacts (T156): the normal entries of W's rows (and of the transposed copy), one
   double per block, for the sweeps on r_n alone. */
static int prepare_normal(nscd_state *S, mo_ctx *ctx)
{
  int a, k, nb = S->nc, dd = S->d * S->d;
  size_t nnz = 0, q = 0;
  void *p;
  S->nonly = S->d > 1 && nb > 0;
  for (a = 0; a < nb && S->nonly; a++) S->nonly = nscd_mu(S, a) == 0;
  if (!S->nonly) return MO_OK;
  for (a = 0; a < nb; a++) nnz += (size_t)S->rcnt[a];
  if ((size_t)nb + 1 > S->wnccap || !S->wnp) {
    if (!(p = mo_realloc(ctx, S->wnp, ((size_t)nb + 1) * sizeof *S->wnp))) return MO_ENOMEM;
    S->wnp = p;
  }
  S->wnccap = (size_t)nb + 1;
  if (W_normal_rows(S)) {
    /* W's own copy of its normal entries (T164): no second one (T178) */
    mo_free(S->wnown);
    S->wnown = NULL;
  } else {
    if (nnz + 1 > S->wncap || !S->wnown) {
      if (!(p = mo_realloc(ctx, S->wnown, (nnz + 1) * sizeof *S->wnown))) return MO_ENOMEM;
      S->wnown = p;
      S->wncap = nnz + 1;
    }
    for (a = 0; a < nb; a++) {
      S->wnp[a] = q;
      for (k = 0; k < S->rcnt[a]; k++) S->wnown[q++] = S->rval[a][(size_t)k * dd];
    }
    S->wnp[nb] = q;
    S->wn = S->wnown;
  }
  if (!S->sym) {
    if (!(p = mo_realloc(ctx, S->wnc, (nnz + 1) * sizeof *S->wnc))) return MO_ENOMEM;
    S->wnc = p;
  }
  if (!S->sym)
    for (q = 0; q < (size_t)S->cp[nb]; q++) S->wnc[q] = S->cv[q * dd]; /* W_ba,nn of the transposed blocks */
  return MO_OK;
}

/* Rows of W, and what depends on W only when it changed: its columns and the local data. */
static int prepare_matrix(nscd_state *S, const mo_contact_problem *P, mo_ctx *ctx)
{
  const mo_delassus *W = P->W;
  static const double zero[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  int nb = S->nc, d = S->d, dd = d * d, a, k, sorted = 1;
  long ver = mo_delassus_version(P->W);
  for (a = 0; a < nb; a++) {
    S->rcnt[a] = mo_delassus_row(W, a, &S->rcol[a], &S->rval[a]);
    /* a candidate W does not couple to anything (no free dof moves it): it can only stay open */
    S->diag[a] = zero;
    for (k = 0; k < S->rcnt[a]; k++) {
      if (S->rcol[a][k] == a) S->diag[a] = S->rval[a] + (size_t)k * (size_t)dd;
      if (k && S->rcol[a][k] <= S->rcol[a][k - 1]) sorted = 0;
    }
  }
  /* what follows depends on W's blocks and mu (fixed per scene) only: W keeps its version until it is rebuilt (the core
     rebuilds it when H, the factorization or the scale changed) */
  if (P->W == S->wsrc && ver == S->wver) return MO_OK;
  S->wsrc = P->W;
  S->wver = ver;
  nscd_prepare_local(S, P);
  /* Symmetric W (the Delassus operator of a symmetric What): column a is row a transposed.
     Rows are sorted by block column, so one cursor per row finds W_ba in O(nnz). */
  S->sym = sorted;
  if (sorted) {
    int *cur = S->actown; /* scratch */
    double wmax = 0, asym = 0;
    for (a = 0; a < nb; a++) cur[a] = 0;
    for (a = 0; a < nb && S->sym; a++)
      for (k = 0; k < S->rcnt[a]; k++) {
        int b = S->rcol[a][k], i, j;
        const double *B = S->rval[a] + (size_t)k * (size_t)dd, *T;
        for (i = 0; i < dd; i++) if (fabs(B[i]) > wmax) wmax = fabs(B[i]);
        if (b < a) continue;
        while (cur[b] < S->rcnt[b] && S->rcol[b][cur[b]] < a) cur[b]++;
        if (cur[b] >= S->rcnt[b] || S->rcol[b][cur[b]] != a) { S->sym = 0; break; }
        T = S->rval[b] + (size_t)cur[b] * (size_t)dd;
        for (i = 0; i < d; i++)
          for (j = 0; j < d; j++)
            if (fabs(B[i * d + j] - T[j * d + i]) > asym) asym = fabs(B[i * d + j] - T[j * d + i]);
      }
    if (S->sym && asym > 1e-14 * wmax) S->sym = 0;
  }
  if (!S->sym) {
    /* the transposed block structure: for each block column a, its blocks W_ba (stored
       transposed, as sweep reads them) */
    size_t nnz = 0, need;
    int *cnt;
    for (a = 0; a < nb; a++) nnz += (size_t)S->rcnt[a];
    need = nnz + 1;
    if ((size_t)nb + 1 > S->cpcap) {
      int *cp = mo_realloc(ctx, S->cp, ((size_t)nb + 1) * sizeof *cp);
      if (!cp) return MO_ENOMEM;
      S->cp = cp;
      S->cpcap = (size_t)nb + 1;
    }
    if (need > S->ccap) {
      int *cb = mo_realloc(ctx, S->cb, need * sizeof *cb);
      double *cv;
      if (!cb) return MO_ENOMEM;
      S->cb = cb;
      cv = mo_realloc(ctx, S->cv, need * (size_t)dd * sizeof *cv);
      if (!cv) return MO_ENOMEM;
      S->cv = cv;
      S->ccap = need;
    }
    cnt = S->actown; /* scratch */
    for (a = 0; a <= nb; a++) S->cp[a] = 0;
    for (a = 0; a < nb; a++)
      for (k = 0; k < S->rcnt[a]; k++) S->cp[S->rcol[a][k] + 1]++;
    for (a = 0; a < nb; a++) S->cp[a + 1] += S->cp[a];
    for (a = 0; a < nb; a++) cnt[a] = S->cp[a];
    for (a = 0; a < nb; a++)
      for (k = 0; k < S->rcnt[a]; k++) {
        int b = S->rcol[a][k], pos = cnt[b]++, i, j;
        const double *B = S->rval[a] + (size_t)k * (size_t)dd;
        double *T = S->cv + (size_t)pos * (size_t)dd;
        S->cb[pos] = a;
        for (i = 0; i < d; i++)
          for (j = 0; j < d; j++) T[j * d + i] = B[i * d + j];
      }
    mo_log(ctx, 3, "nscd: W is not symmetric; columns copied (%zu blocks)\n", nnz);
  }
  return prepare_normal(S, ctx);
}

/* U = W r + q over every candidate (exact; also resets the drift of the column updates). */
void nscd_normal_mult(const nscd_state *S, const mo_contact_problem *P, const double *r, double *U)
{
  const int d = S->d;
  int a, k;
  for (a = 0; a < S->nc; a++) {
    const double *w = S->wn + S->wnp[a];
    const int *cb = S->rcol[a];
    double acc = P->b[(size_t)a * d];
    int i;
    for (k = 0; k < S->rcnt[a]; k++) acc += w[k] * r[(size_t)cb[k] * d];
    U[(size_t)a * d] = acc;
    for (i = 1; i < d; i++) U[(size_t)a * d + i] = P->b[(size_t)a * d + i]; /* finite, not exact */
  }
}

/* U = W r + q over every candidate (exact; also resets the drift of the column updates). Without
   friction (T156) and full = 0: its normal components only, the tangential ones are made exact
   before the solve returns (S->u_full says which). */
static void exact_U(nscd_state *S, const mo_contact_problem *P, const double *r, int full)
{
  int i, zero = 1;
  if (S->grains) {
    nscd_grains_velocities(S, P, r);
    nscd_grains_exact_U(S, P);
    return;
  }
  if (S->bodies) { /* from the body velocities, which follow r */
    nscd_bodies_velocities(S, P, r);
    nscd_bodies_exact_U(S, P);
    return;
  }
  for (i = 0; i < S->m && zero; i++) zero = r[i] == 0;
  S->u_full = 1;
  if (zero) { /* a cold start: U = q */
    memcpy(S->U, P->b, (size_t)S->m * sizeof *S->U);
    return;
  }
  if (S->nonly && !full) {
    nscd_normal_mult(S, P, r, S->U);
    S->u_full = 0;
    return;
  }
  mo_delassus_mult(P->W, r, 0, S->U);
  for (i = 0; i < S->m; i++) S->U[i] += P->b[i];
}

/* The natural-map residual over the active candidates: as the core computes it (T10), or of the
   problem whose local velocities are scaled contact by contact by 1 / W_aa,nn (T42). */
static void natural_parts_rk(const nscd_state *S, const int *list, int n, const double *r, const double *rk,
                             const double *Uk, int scaled, double *parts);
static inline void natural_parts(const nscd_state *S, const int *list, int n, const double *r, int scaled,
                                 double *parts)
{
  natural_parts_rk(S, list, n, r, NULL, NULL, scaled, parts);
}
static inline void natural_parts_at(const nscd_state *S, const int *list, int n, const double *rk, const double *Uk,
                                    int scaled, double *parts)
{
  natural_parts_rk(S, list, n, NULL, rk, Uk, scaled, parts);
}
static double residual(const nscd_state *S, const double *r, int scaled)
{
  if (scaled && !S->scale) { /* the granular path: the scaling from the records (the same sums) */
    double parts[3], den = sqrt(S->qs2);
    natural_parts(S, S->act, S->nact, r, 1, parts);
    if (sqrt(parts[1]) > den) den = sqrt(parts[1]);
    if (sqrt(parts[2]) > den) den = sqrt(parts[2]);
    return den > 1e-300 ? sqrt(parts[0]) / den : sqrt(parts[0]);
  }
  return mo_fc_natural_map_subset_pairs(S->d, S->nact, S->act, S->mu, S->gkey, S->gpmu, scaled ? S->scale : NULL, r, S->U,
                                        sqrt(scaled ? S->qs2 : S->qn2));
}

/* One sweep over the active contacts in S->order (J88 (3.3)_5-6 solved contact by contact,
   doc/theory.md (T36)-(T37)). U is kept equal to W r + q by adding column a of W times the
   change of r_a, so that the next contact reads its local free term from U, and a contact whose
   reaction does not change (open and staying open) costs only its local test. Returns the
   contact that broke down, or -1. */
static inline int sweep(nscd_state *S, const mo_contact_problem *P, double *r, int *status,
                        const int d)
{
  const int dd = d * d, sym = S->sym;
  const double omega = S->p.relax, *mu = S->mu;
  int k, i, j;
  for (k = 0; k < S->nact; k++) {
    const int a = S->order[k];
    const double *Waa = S->diag[a];
    double *ra = r + a * d, *Ua = S->U + a * d, ql[3], rl[3], dr[3];
    int s, nz = 0;
    /* local free term: q_a + sum_{b != a} W_ab r_b = U_a - W_aa r_a */
    for (i = 0; i < d; i++) {
      double acc = Ua[i];
      for (j = 0; j < d; j++) acc -= Waa[i * d + j] * ra[j];
      ql[i] = acc;
      rl[i] = ra[i];
    }
    s = nscd_local_solve(d, Waa, S->aux + (size_t)a * NSCD_AUX, ql, mu ? mu[a] : 0, rl, &S->lp, &S->lst);
    if (s < 0) return a;
    status[a] = s;
    for (i = 0; i < d; i++) {
      if (omega != 1) rl[i] = omega * rl[i] + (1 - omega) * ra[i];     /* (T37) */
      dr[i] = rl[i] - ra[i];
      nz |= dr[i] != 0;
    }
    if (nz) {
      /* U += (column a of W) dr, U_b += (W_ba^T)^T dr with W_ba^T = W_ab from row a (symmetric
         W) or from the transposed copy */
      const int n = sym ? S->rcnt[a] : S->cp[a + 1] - S->cp[a];
      const int *cb = sym ? S->rcol[a] : S->cb + S->cp[a];
      const double *B = sym ? S->rval[a] : S->cv + (size_t)S->cp[a] * (size_t)dd;
      for (j = 0; j < n; j++, B += dd) {
        double *Ub = S->U + cb[j] * d;
        if (d == 3) {
          Ub[0] += B[0] * dr[0] + B[3] * dr[1] + B[6] * dr[2];
          Ub[1] += B[1] * dr[0] + B[4] * dr[1] + B[7] * dr[2];
          Ub[2] += B[2] * dr[0] + B[5] * dr[1] + B[8] * dr[2];
        } else if (d == 2) {
          Ub[0] += B[0] * dr[0] + B[2] * dr[1];
          Ub[1] += B[1] * dr[0] + B[3] * dr[1];
        } else
          Ub[0] += B[0] * dr[0];
      }
      for (i = 0; i < d; i++) ra[i] = rl[i];
    }
  }
  return -1;
}

/* One sweep of frictionless contacts on r_n alone (T156): r_t stays 0, U_n is kept equal to W r +
   q through the normal column of each change; U_t is left behind (exact_U after the sweeps). The
   local solution is the frictionless one of nscd_local_2d and nscd_local_3d: r_n = -q_n / W_nn
   when q_n < 0, a closed contact being "sliding". */
static int sweep_normal(nscd_state *S, const mo_contact_problem *P, double *r, int *status)
{
  const int d = S->d, sym = S->sym;
  const double omega = S->p.relax;
  int k, j;
  (void)P;
  for (k = 0; k < S->nact; k++) {
    const int a = S->order[k];
    const double wnn = S->diag[a][0];
    double *ra = r + (size_t)a * d, ql = S->U[(size_t)a * d] - wnn * ra[0], rl, dr;
    int s;
    if (ql >= 0) {
      rl = 0;
      s = MO_CS_OPEN;
    } else if (!(wnn > 0))
      return a;
    else {
      rl = -ql / wnn;
      s = MO_CS_SLIDE;
    }
    status[a] = s;
    if (omega != 1) rl = omega * rl + (1 - omega) * ra[0];       /* (T37) */
    dr = rl - ra[0];
    if (dr != 0) {
      const int n = sym ? S->rcnt[a] : S->cp[a + 1] - S->cp[a];
      const int *cb = sym ? S->rcol[a] : S->cb + S->cp[a];
      const double *w = sym ? S->wn + S->wnp[a] : S->wnc + S->cp[a];
      for (j = 0; j < n; j++) S->U[(size_t)cb[j] * d] += w[j] * dr;
      ra[0] = rl;
    }
  }
  return -1;
}

static int sweep1(nscd_state *S, const mo_contact_problem *P, double *r, int *st) { return sweep(S, P, r, st, 1); }
static int sweep2(nscd_state *S, const mo_contact_problem *P, double *r, int *st) { return sweep(S, P, r, st, 2); }
static int sweep3(nscd_state *S, const mo_contact_problem *P, double *r, int *st) { return sweep(S, P, r, st, 3); }

/* Jean's norms (T11) of the change of a sweep, from the reactions before and after it:
   dU_a = W_aa (r_a - rold_a), weighted by |r_a|, over the active contacts. */
/* The parts of Jean's norms over the contacts list[0 .. n-1]: sum |dU|^2 |r|^2, sum (W r).r, the
   contacts with a reaction, the largest |dU| |r| (over the ranks: the sums summed, the largest
   maximized). */
static void jean_parts(const nscd_state *S, const int *list, int n, const double *rold, const double *r, double *sdd_,
                       double *swrr_, double *nact_, double *mx_)
{
  int d = S->d, k, i, j, nact = 0;
  double sdd = 0, swrr = 0, mx = 0;
  for (k = 0; k < n; k++) {
    int a = list[k];
    const double *Waa = nscd_waa(S, a), *ra = r + a * d, *ro = rold + a * d;
    double dU2 = 0, rr = 0, wrr = 0;
    for (i = 0; i < d; i++) {
      double wi = 0, di = 0;
      for (j = 0; j < d; j++) {
        di += Waa[i * d + j] * (ra[j] - ro[j]);
        wi += Waa[i * d + j] * ra[j];
      }
      dU2 += di * di;
      rr += ra[i] * ra[i];
      wrr += wi * ra[i];
    }
    if (rr > 0) nact++;
    sdd += dU2 * rr;
    swrr += wrr;
    if (sqrt(dU2 * rr) > mx) mx = sqrt(dU2 * rr);
  }
  *sdd_ = sdd;
  *swrr_ = swrr;
  *nact_ = nact;
  *mx_ = mx;
}

/* Jean's norms (T11) from their parts. */
static void jean_from_parts(double sdd, double swrr, double nact, double mx, double *quad, double *maxm)
{
  *quad = swrr > 0 ? sqrt(sdd) / swrr : 0;
  *maxm = swrr > 0 && nact > 0 ? mx / (swrr / nact) : 0;
}

static void jean_norms(const nscd_state *S, const double *rold, const double *r, double *quad, double *maxm)
{
  double sdd, swrr, nact, mx;
  jean_parts(S, S->act, S->nact, rold, r, &sdd, &swrr, &nact, &mx);
  jean_from_parts(sdd, swrr, nact, mx, quad, maxm);
}

/* Jean's norms of the sweep just done: from the reactions kept before it, or the parts the
   granular sweep summed (jwant). */
static void sweep_jean(const nscd_state *S, const double *r, double *quad, double *maxm)
{
  if (S->jwant) jean_from_parts(S->jp[0], S->jp[1], S->jp[2], S->jp[3], quad, maxm);
  else jean_norms(S, S->rold, r, quad, maxm);
}

/* The parts of the natural-map residual (T10) over list[0 .. n-1]: the units' sum, |r|^2, |U|^2
   (U scaled by (T42) when scaled). */
/* The residual's parts over list[0 .. n-1]: with rk and Uk, contact list[k]'s reaction and U at
   rk + k d and Uk + k d. */
static void natural_parts_rk(const nscd_state *S, const int *list, int n, const double *r, const double *rk,
                             const double *Uk, int scaled, double *parts)
{
  int d = S->d, k, i;
  parts[0] = parts[1] = parts[2] = 0;
  for (k = 0; k < n; k++) {
    int a = list[k];
    const double *ra = rk ? rk + (size_t)k * d : r + (size_t)a * d;
    const double *Ua = Uk ? Uk + (size_t)k * d : S->U + (size_t)a * d;
    double Us[3], sa = scaled ? nscd_scale(S, a) : 1;
    for (i = 0; i < d; i++) Us[i] = scaled ? sa * Ua[i] : Ua[i];
    parts[0] += mo_fc_natural_map_unit(d, nscd_mu(S, a), ra, Us);
    for (i = 0; i < d; i++) {
      parts[1] += ra[i] * ra[i];
      parts[2] += Us[i] * Us[i];
    }
  }
}

/* One sweep of the granular path split over the MPI ranks (doc/parallel.md §4): the owned
   contacts, then the interface velocities and the stopping rule's parts over every rank. Sets
   *broke (a contact that broke down on some rank, or -1), *stop (an interrupt on some rank), and
   the rule's values (quad, maxm or the residual). */
static int sweep_ranks(nscd_state *S, const mo_contact_problem *P, double *r, int *status, int scaled, int *broke,
                       int *stop, double *quad, double *maxm, double *res, mo_ctx *ctx)
{
  const nscd_params *p = &S->p;
  double parts[7] = {0, 0, 0, 0, 0, 0, 0}, mx[2];
  int st, natural = p->stop == NSCD_STOP_NATURAL || scaled, nparts = 5, joined = 0;
  double xn[3] = {0, 0, 0};
  *broke = nscd_grains_sweep_owned(S, P, r, status);
  if (!natural) { /* Jean's parts over the rank's contacts, summed by its sweep (T273) */
    parts[0] = S->jp[0];
    parts[1] = S->jp[1];
    parts[2] = S->jp[2];
    mx[1] = S->jp[3];
  } else
    mx[1] = 0;
  parts[3] = ctx->interrupt && *ctx->interrupt;
  /* the ranks that broke down, counted in the sum: the maximum below only when one did or the
     rule stops on Jean's maximum; the reported maximum of the quad rule is taken once, after the
     last sweep (T334) */
  parts[4] = *broke >= 0;
  mx[0] = *broke;
  S->jmax = mx[1];
  if (S->qs2part) { /* the first sync: the ranks' parts of |S q|^2 (T276), and of |q|^2 where each rank
                       holds its own contacts only (the distributed set) */
    parts[5] = S->qs2;
    parts[6] = S->qn2;
    nparts = S->dist ? 7 : 6;
  }
  /* on more than 2 ranks the interface goes point to point before the parts' sum: the residual's
     parts of the rank's contacts, from the synced velocities, join that sum (T339) */
  if ((st = nscd_grains_exchange(S, ctx))) return st;
  if (natural && S->xchg) {
    nscd_grains_owned_U(S, P);
    natural_parts(S, S->oorder, S->noact, r, scaled, parts);
    joined = 1;
  }
  if (natural && !S->xchg) {
    /* (T340) on 2 ranks the sum syncs the velocities: the residual's parts of the rank's contacts
       off the interface (their U final already: only its own contacts move their bodies) and the
       reactions of its interface contacts join it; after it every rank forms the interface
       contacts' parts, the same on each (their records made on both ranks) */
    double *ex = S->nbuf;
    nscd_grains_list_U(S, P, S->onil, S->nonil);
    natural_parts(S, S->onil, S->nonil, r, scaled, ex);
    nscd_grains_ifc_pack(S, P, r, ex + 3);
    if ((st = nscd_grains_sync(S, parts, nparts, ex, 3 + nscd_grains_ifc_count(S), ctx))) return st;
    nscd_grains_ifc_unpack(S, P, ex + 3);
    {
      /* the reactions as summed (the same on both ranks), read in place of r */
      double pi[3];
      double *Uk = ex + 3 + nscd_grains_ifc_count(S);
      nscd_grains_ifc_U(S, P, Uk);
      natural_parts_at(S, S->ilist, S->nilist, ex + 3, Uk, scaled, pi);
      xn[0] = ex[0] + pi[0];
      xn[1] = ex[1] + pi[1];
      xn[2] = ex[2] + pi[2];
    }
    joined = 2;
  } else if ((st = nscd_grains_sync(S, parts, nparts, NULL, 0, ctx)))
    return st;
  if (S->qs2part) {
    S->qs2 = parts[5];
    if (S->dist) S->qn2 = parts[6];
    S->qs2part = 0;
  }
  if (parts[4] > 0 || p->stop == NSCD_STOP_MAXM) {
    if ((st = mo_par_max(mx, 2, ctx))) return st;
  } else
    mx[0] = -1;
  *broke = (int)mx[0];
  *stop = parts[3] > 0;
  if (natural) {
    /* the residual of the state every rank now holds: U of the owned contacts from the summed
       interface velocities (on 2 ranks a second, 3-number sum: U taken before the first would
       miss the other rank's last increments and could declare convergence early) */
    double den = sqrt(scaled ? S->qs2 : S->qn2);
    if (!joined) {
      nscd_grains_owned_U(S, P);
      natural_parts(S, S->oorder, S->noact, r, scaled, parts);
      if ((st = mo_par_sum(parts, 3, ctx))) return st;
    } else if (joined == 2)
      memcpy(parts, xn, sizeof xn);
    if (sqrt(parts[1]) > den) den = sqrt(parts[1]);
    if (sqrt(parts[2]) > den) den = sqrt(parts[2]);
    *res = den > 1e-300 ? sqrt(parts[0]) / den : sqrt(parts[0]);
  } else {
    jean_from_parts(parts[0], parts[1], parts[2], mx[1], quad, maxm);
    S->jparts[0] = parts[0];
    S->jparts[1] = parts[1];
    S->jparts[2] = parts[2];
  }
  return MO_OK;
}

/* "candidate 12 (node 13)" */
static int name_candidate(const mo_contact_problem *P, int a, char *buf, size_t n)
{
  mo_candidate cb;
  const mo_candidate *c = P->contact ? mo_contact_cand_get(P->contact, a, &cb) : NULL;
  if (c && c->node >= 0) return snprintf(buf, n, "candidate %d (node %d)", a, c->node);
  return snprintf(buf, n, "candidate %d", a);
}

/* The message of a non-converged solve: the three candidates farthest from the law. */
static void worst_candidates(const nscd_state *S, const mo_contact_problem *P, const double *r,
                             mo_contact_report *rep, double res, int scaled)
{
  int worst[3] = {-1, -1, -1}, k, i, len, nbad = 0, bad = -1;
  double we[3] = {-1, -1, -1};
  for (k = 0; k < S->nact; k++) {
    int a = S->act[k];
    double e = sqrt(mo_fc_natural_map_unit(S->d, nscd_mu(S, a), r + a * S->d, S->U + a * S->d));
    if (!isfinite(e)) { /* a NaN or an infinity: the culprit before any finite residual */
      if (!nbad++) bad = a;
      continue;
    }
    if (!(e > 0)) continue; /* on the law: not among the culprits */
    for (i = 0; i < 3; i++)
      if (e > we[i]) {
        int j;
        for (j = 2; j > i; j--) { we[j] = we[j - 1]; worst[j] = worst[j - 1]; }
        we[i] = e;
        worst[i] = a;
        break;
      }
  }
  if (nbad) {
    char nm[64];
    name_candidate(P, bad, nm, sizeof nm);
    snprintf(rep->message, sizeof rep->message, "local residuals not finite at %d contact%s, the first %s (the "
             "problem's data W, q or the reactions overflowed)", nbad, nbad > 1 ? "s" : "", nm);
    return;
  }
  if (worst[0] < 0) {
    snprintf(rep->message, sizeof rep->message, "no local residual stands out");
    return;
  }
  /* the stopping rule's own measure first: the core's (T10) depends on the units */
  len = snprintf(rep->message, sizeof rep->message, "%s residual %.2e against tol %.0e; largest local residuals at",
                 scaled ? "scaled (T42)" : "natural-map", res, S->p.tol);
  for (i = 0; i < 3 && worst[i] >= 0 && len < (int)sizeof rep->message - 1; i++) {
    char nm[64];
    name_candidate(P, worst[i], nm, sizeof nm);
    len += snprintf(rep->message + len, sizeof rep->message - (size_t)len, "%s %s (%.2e)", i ? "," : "", nm, we[i]);
  }
}

static int nscd_solve(void *state, const mo_contact_problem *P, mo_contact_vars *x,
                      mo_contact_report *rep, mo_ctx *ctx)
{
  nscd_state *S = state;
  const nscd_params *p = &S->p;
  int d = S->d, m = S->m, a, k, i, st, sweeps = 0, broke = -1, conv = 0, tried = -1000, wait = 10, rold_at = -1;
  double *r = x->r, quad = 0, maxm = 0, res = HUGE_VAL, rhist[10] = {HUGE_VAL, HUGE_VAL, HUGE_VAL, HUGE_VAL, HUGE_VAL, HUGE_VAL, HUGE_VAL, HUGE_VAL, HUGE_VAL, HUGE_VAL};
  const int scaled = p->stop == NSCD_STOP_SCALED;
  int repl = 0;        /* the split sweep stalled: the serial sweep replicated on every rank */
  int whole = 0;       /* over the ranks, a set too small to split: the serial sweep on every rank (T333) */
  int pnu = 0, pnd = 0; /* the split solve's redundancy count, from its gather (T279) */
  double pstall = HUGE_VAL;
  int (*do_sweep)(nscd_state *, const mo_contact_problem *, double *, int *) =
      d == 3 ? sweep3 : d == 2 ? sweep2 : sweep1;
  if (P->nc != S->nc || P->dim != S->d || (!P->W) != S->bodies || (S->bodies && !P->grains != !S->grains))
    return mo_error(ctx, MO_EINTERNAL, "nscd: the problem changed size (%d x %d, was %d x %d)", P->nc, P->dim, S->nc, S->d);
  /* U = W r + q: the granular path keeps it in the caller's array, the others in their own */
  S->U = S->grains ? x->U : S->Uown;
  /* the granular path makes its records after the slabs are cut (below) */
  if (!S->grains && (st = S->bodies ? nscd_bodies_prepare(S, P, ctx) : prepare_matrix(S, P, ctx))) return st;
  if (!S->bodies && S->nonly) do_sweep = sweep_normal;
  /* the active contacts, in the chosen order: on the granular path the problem's list of them,
     the same candidates in the same increasing order (T250) */
  {
    const int listed = S->grains && P->act;
    if (listed) {
      S->act = P->act;
      S->nact = P->nact;
    } else {
      if (S->aocap < S->cap) {
        void *q = mo_realloc(ctx, S->actown, S->cap * sizeof *S->actown);
        if (!q) return MO_ENOMEM;
        S->actown = q;
        S->aocap = S->cap;
      }
      S->act = S->actown;
      S->nact = 0;
    }
    for (a = 0; a < S->nc; a++) {
      if (P->active && !P->active[a]) {
        for (i = 0; i < d; i++) r[a * d + i] = 0;
        x->status[a] = MO_CS_OPEN;
        continue;
      }
      if (!listed) S->actown[S->nact++] = a;
    }
  }
  if (p->order == NSCD_ORDER_NATURAL)
    S->order = S->act;
  else {
    if (S->cap > S->ocap) {
      void *q = mo_realloc(ctx, S->ordown, S->cap * sizeof *S->ordown);
      if (!q) return MO_ENOMEM;
      S->ordown = q;
      S->ocap = S->cap;
    }
    S->order = S->ordown;
    for (k = 0; k < S->nact; k++) S->ordown[k] = S->act[p->order == NSCD_ORDER_REVERSE ? S->nact - 1 - k : k];
    if (p->order == NSCD_ORDER_SHUFFLED) gsl_ran_shuffle(&S->rng, S->ordown, (size_t)S->nact, sizeof(int));
  }
  /* over MPI ranks: each rank's slab of the contacts (doc/parallel.md §4), cut before the records
     so that each rank makes its own contacts' only (T274) */
  S->par = 0;
  if (S->grains) {
    /* a set of fewer than split_min active contacts a rank is swept whole on every rank, as one
       process sweeps it (T333): a split sweep pays a sync a sweep and converges slower than the
       whole one, and on a hundred contacts a rank the sweep it splits costs about the sync */
    /* (the distributed set is split whatever its size: no rank holds the others' contacts) */
    S->dist = P->grains->dist && ctx->nranks > 1;
    whole = !S->dist && ctx->nranks > 1 && (double)S->nact < (double)p->split_min * ctx->nranks;
    if (whole) ctx->par_grain_whole++;
    else if (S->dist && (st = nscd_grains_partition_dist(S, P, ctx))) return st;
    else if (!S->dist && ctx->nranks > 1 && (st = nscd_grains_partition(S, P, ctx))) return st;
    if ((st = nscd_grains_prepare(S, P, ctx))) return st;
  }
  /* |q|^2 and the scaled |S q|^2 of the active contacts: over the ranks, the second over the rank's
     own contacts (their records), summed by the first sweep's sync (T276) */
  S->qn2 = S->qs2 = 0;
  S->qs2part = S->par;
  for (k = 0; k < S->nact; k++) {
    double q2 = 0, sa;
    a = S->act[k];
    for (i = 0; i < d; i++) q2 += P->b[a * d + i] * P->b[a * d + i];
    S->qn2 += q2;
    if (S->par && !S->own[a]) continue;
    sa = nscd_scale(S, a);
    S->qs2 += sa * sa * q2;
  }
  if (!p->warm_start) memset(r, 0, (size_t)m * sizeof *r);
  for (i = 0; i < m; i++)
    if (!isfinite(r[i])) { memset(r, 0, (size_t)m * sizeof *r); break; }
  if (!S->bodies && S->nonly) /* frictionless: no tangential reaction, whatever the warm start */
    for (a = 0; a < S->nc; a++)
      for (i = 1; i < d; i++) r[(size_t)a * d + i] = 0;
  if (S->par || (S->bodies && p->stop != NSCD_STOP_SCALED && p->stop != NSCD_STOP_NATURAL)) {
    /* the sweeps on body velocities read U from the velocities; the rules that do not stop on U
       need it exact only at the end; the split sweep's rule forms U of the rank's contacts after
       each sync, and a serial sweep after a switch forms its own (T278) */
    if (S->grains && S->dist) {
      if ((st = nscd_grains_velocities_dist(S, P, r, ctx))) return st;
    } else if (S->grains && S->par)
      nscd_grains_velocities_part(S, P, r); /* the rank's bodies' (T336) */
    else if (S->grains) nscd_grains_velocities(S, P, r);
    else nscd_bodies_velocities(S, P, r);
  } else
    exact_U(S, P, r, 0);
  memset(&S->lst, 0, sizeof S->lst);
  memset(&S->ai, 0, sizeof S->ai);
  S->accel_tries = 0;
  S->lp = *p;
  if (scaled && p->accelerate && !S->bodies && S->lu.valid && S->nact) {
    /* the statuses of the warm start are those of the kept LU (T157): the direct solve first */
    nscd_accel_info ai;
    memset(&ai, 0, sizeof ai);
    if ((st = nscd_status_step(S, P, r, x->status, p->tol, &res, &ai, NSCD_STEP_CACHED, ctx))) return st;
    if (ai.tried) { S->ai = ai; S->accel_tries++; }
    if (ai.accepted) conv = 1;
  } else if (scaled && p->accelerate && !S->bodies && S->nonly && !S->lu.builds && S->nact >= NSCD_GUESS_LU) {
    /* the first LU of a run on a large frictionless set (T163): on the statuses the predictor
       gives (a contact it drives into the obstacle closed), before any sweep; its status
       iteration settles them, and the sweeps run only when that fails */
    nscd_accel_info ai;
    memset(&ai, 0, sizeof ai);
    tried = 0;
    if ((st = nscd_status_step(S, P, r, x->status, p->tol, &res, &ai, NSCD_STEP_PREDICT, ctx))) return st;
    if (ai.tried) { S->ai = ai; S->accel_tries++; }
    if (ai.accepted) conv = 1;
    else res = HUGE_VAL;
  }
  while (!conv && sweeps < p->max_sweeps) {
    /* the ranks sweeping the same data stop together: not on a signal one of them may see first */
    if (!S->par && !repl && !whole && ctx->interrupt && *ctx->interrupt) break;
    /* (a set swept whole on every rank draws its permutations as one process does: one seed, the
       same draws on every rank) */
    if (sweeps && p->order == NSCD_ORDER_SHUFFLED && p->reshuffle && !S->par && !repl)
      gsl_ran_shuffle(&S->rng, S->ordown, (size_t)S->nact, sizeof(int));
    /* the 3D Newton solves to 1e-2 of the last residual (never looser than 1e-4, never tighter
       than local_tol): early sweeps need no exact local solve, the last ones get it */
    if (res < HUGE_VAL) S->lp.local_tol = fmax(p->local_tol, fmin(1e-4, 1e-2 * res));
    /* the reactions before the sweep, for Jean's norms (T11): at every sweep for the rules that
       stop on them and (but on the granular path) those that may stop at any sweep, before the
       last one for "sweeps"; the granular sweep on one rank sums the norms' parts itself instead
       (S->jwant) */
    if (p->stop == NSCD_STOP_SWEEPS ? sweeps == p->max_sweeps - 1
                                    : !(S->grains && (p->stop == NSCD_STOP_NATURAL || scaled)))
      rold_at = sweeps;
    /* the granular sweep sums Jean's parts as it goes, on one rank and over several (each rank
       its own contacts', summed by the sync: no copy of the whole set's r on every rank every
       sweep, (T273)) */
    S->jwant = rold_at == sweeps && S->grains;
    if (rold_at == sweeps && !S->jwant && S->rold) memcpy(S->rold, r, (size_t)m * sizeof *r);
    if (S->par) {
      /* the sweep split over the ranks: its rule decided on every rank's contacts */
      int stop = 0;
      if ((st = sweep_ranks(S, P, r, x->status, scaled, &broke, &stop, &quad, &maxm, &res, ctx))) return st;
      sweeps++;
      if (broke >= 0 || stop) break;
      if (p->stop == NSCD_STOP_NATURAL || scaled) {
        if (res <= p->tol) { conv = 1; break; }
        if (!isfinite(res)) break;
      } else if ((p->stop == NSCD_STOP_QUAD && quad <= p->tol) || (p->stop == NSCD_STOP_MAXM && maxm <= p->tol)) {
        conv = 1;
        break;
      }
      /* (the distributed set has no serial sweep to go on with: no rank holds the whole set) */
      if (!S->dist && p->stop != NSCD_STOP_SWEEPS && sweeps % NSCD_PAR_STALL == 0) {
        /* a split sweep that stalls (its measure, the same on every rank, not halved over the last
           NSCD_PAR_STALL sweeps: the slabs' interfaces on a hyperstatic set such as masonry-arch at
           1e-11, where the split sweep sat at 1.9e-9) goes on as the serial sweep on every rank,
           from the gathered reactions and velocities: the same sweep on the same data, so the
           ranks stay equal, and it converges wherever the serial run does (doc/parallel.md §4) */
        double now = p->stop == NSCD_STOP_NATURAL || scaled ? res : p->stop == NSCD_STOP_QUAD ? quad : maxm;
        if (!(now <= 0.5 * pstall)) {
          if ((st = nscd_grains_gather(S, P, r, x->status, 0, NULL, NULL, ctx))) return st;
          nscd_grains_complete(S, P); /* the serial sweep reads every contact's record (T277) */
          S->par = 0;
          repl = 1;
          ctx->par_grain_serial++;
        }
        pstall = now;
      }
      continue;
    }
    broke = S->grains ? nscd_grains_sweep(S, P, r, x->status)
            : S->bodies ? nscd_bodies_sweep(S, P, r, x->status) : do_sweep(S, P, r, x->status);
    sweeps++;
    if (broke >= 0) break;
    if (p->stop == NSCD_STOP_NATURAL || scaled) {
      res = residual(S, r, scaled);
      if (res <= p->tol || !isfinite(res) || (scaled && !S->bodies && sweeps % 10 == 0 && res < 1e-6)) {
        /* confirm on the exact U (the column updates drift by round-off); every 10 sweeps, whether
           the residual is at its round-off floor (T85): then no sweep can lower it further */
        exact_U(S, P, r, 1);
        res = residual(S, r, scaled);
        if (res <= p->tol || (scaled && !S->bodies && res <= nscd_roundoff_floor(S, P, r))) { conv = 1; break; }
        if (!isfinite(res)) break;
      }
      if (scaled && p->accelerate && !S->bodies) {
        /* the status-set step (T83) when the sweeps stall with stable statuses */
        int stable = sweeps > 1;
        for (k = 0; k < S->nact && stable; k++) stable = x->status[S->act[k]] == S->sprev[S->act[k]];
        /* its cost (a dense LU of one unknown per closed frictionless contact, at most d per
           frictional one) never above the sweeps' so far, and after a step that did not
           converge, twice as many sweeps before the next */
        double nclosed = 0, nb = 0;
        /* on a large contact set the first LU of a run (T157) is tried after 10 sweeps, without
           waiting for stable statuses and the stall of (T83) (its status iteration settles the
           statuses): the sweeps converge slowly there, and the LU serves the steps after */
        int early = !S->lu.builds && S->nact >= NSCD_EARLY_LU;
        if (sweeps >= 10 && ((stable && res > 0.5 * rhist[sweeps % 10]) || early) && sweeps - tried >= wait)
          for (k = 0; k < S->nact; k++) {
            nclosed += r[S->act[k] * d] > 0 ? (nscd_mu(S, S->act[k]) > 0 ? d : 1) : 0; /* unknowns, at most */
            nb += S->rcnt[S->act[k]];
          }
        /* a factorization kept for the next steps (T157) pays for itself while it is reused: the
           first one of a run, and more as long as each was reused once on average, whatever the
           sweeps cost so far */
        if (nb > 0 && (2.0 / 3.0 * pow(nclosed, 3) <= (double)sweeps * nb * 2 * (S->nonly ? 1 : d * d) ||
                       S->lu.builds == 0 || S->lu.hits >= S->lu.builds)) {
          nscd_accel_info ai;
          memset(&ai, 0, sizeof ai);
          tried = sweeps;
          exact_U(S, P, r, 0);
          if ((st = nscd_status_step(S, P, r, x->status, p->tol, &res, &ai, NSCD_STEP_FACTOR, ctx))) return st;
          if (ai.tried) { S->ai = ai; S->accel_tries++; }
          if (ai.accepted) { conv = 1; break; }
          wait *= 2;
          res = residual(S, r, scaled);
        }
        rhist[sweeps % 10] = res;
        for (k = 0; k < S->nact; k++) S->sprev[S->act[k]] = x->status[S->act[k]];
      }
    } else if (p->stop == NSCD_STOP_QUAD || p->stop == NSCD_STOP_MAXM) {
      sweep_jean(S, r, &quad, &maxm);
      if ((p->stop == NSCD_STOP_QUAD ? quad : maxm) <= p->tol) {
        conv = 1;
        break;
      }
    }
  }
  /* a fixed number of sweeps was asked for: done unless interrupted */
  if (p->stop == NSCD_STOP_SWEEPS && broke < 0 && sweeps == p->max_sweeps) conv = 1;
  /* Jean's Maxm of the last split sweep, reported: its maximum over the ranks once, here, unless
     that sweep's sync took it (a breakdown, the maxm rule) (T334; S->par, broke and the rule are
     the same on every rank) */
  if (S->par && sweeps && !(p->stop == NSCD_STOP_NATURAL || scaled) && broke < 0 && p->stop != NSCD_STOP_MAXM) {
    if ((st = mo_par_max(&S->jmax, 1, ctx))) return st;
    jean_from_parts(S->jparts[0], S->jparts[1], S->jparts[2], S->jmax, &quad, &maxm);
  }
  /* over MPI ranks: every contact's reaction, status and exact U, every body's exact velocity, on
     every rank, each rank forming its own part's (T336); with the redundancy count of the rank's
     contacts joined in the same gather (T279) */
  /* a breakdown's message and a failed solve's residual and culprits read other ranks' contacts'
     records (T277): made before the gather writes U where q was (T240) */
  if (S->par && (broke >= 0 || !conv)) nscd_grains_complete(S, P);
  if (S->par && S->dist) {
    if ((st = nscd_grains_gather_dist(S, P, r, broke < 0 ? &pnu : NULL, &pnd, ctx))) return st;
  } else if (S->par && (st = nscd_grains_gather(S, P, r, x->status, 1, broke < 0 ? &pnu : NULL, &pnd, ctx)))
    return st;
  /* U is exact already after the split solve's gather, and when a residual rule has just
     confirmed convergence; else the tangential U of frictionless contacts is, unless the core
     measures U itself (T156) */
  if (!S->par) {
    if (!(conv && (scaled || p->stop == NSCD_STOP_NATURAL))) exact_U(S, P, r, 1);
    else if (!S->u_full && !P->u_measured) exact_U(S, P, r, 1);
  }
  /* redundancy (T84): the rank of the closed set's problem, measured by the status-set step when
     it converged, else here for quasi-static solves (one or a few per run; dynamic steps would pay a
     dense factorization each) */
  if (!S->bodies && broke < 0 && !S->ai.accepted && P->scheme == MO_SCHEME_QUASISTATIC) {
    nscd_accel_info ai;
    double rdummy = res;
    memset(&ai, 0, sizeof ai);
    /* with the scaled rule and accelerate, the direct solution replaces the sweeps' when it
       satisfies the law: the minimum-norm reactions when they are not unique */
    if ((st = nscd_status_step(S, P, r, x->status, scaled && p->accelerate ? p->tol : -1, &rdummy, &ai, NSCD_STEP_FACTOR, ctx)))
      return st;
    if (ai.tried) S->ai = ai;
    if (ai.accepted) {
      res = rdummy;
      if (broke < 0) conv = 1;
    }
  }
  if (S->bodies && broke < 0) {
    /* redundancy on the sweep on bodies: closed unknowns against the dofs they move (T84) */
    int nu = pnu, nd = pnd;
    if (!S->par &&
        (st = S->grains ? nscd_grains_count(S, P, r, &nu, &nd, ctx) : nscd_bodies_count(S, P, r, &nu, &nd, ctx)))
      return st;
    memset(&S->ai, 0, sizeof S->ai);
    S->ai.tried = nu > 0;
    S->ai.rows = nu;
    S->ai.rank = nu < nd ? nu : nd;
    S->ai.rcond = NAN;
  }
  if (x->U != S->U) memcpy(x->U, S->U, (size_t)m * sizeof *x->U);
  if (S->bodies) { /* the correction is the body velocities' change: no solve left to the core */
    nscd_bodies_dx(S, P, x->dx);
    x->dx_set = 1;
  }
  /* Jean's norms of the last sweep (the quad and maxm rules have them already) */
  /* -1: not measured (contact.h): the residual rules on the granular path keep no reactions from
     before the last sweep, and summing the norms' parts in every sweep would cost about 8 % of a
     solve's instructions (doc/theory.md §12.11); "sweeps" interrupted before its last sweep */
  if (S->par && (p->stop == NSCD_STOP_NATURAL || scaled)) quad = maxm = -1;
  else if (sweeps && !S->par && p->stop != NSCD_STOP_QUAD && p->stop != NSCD_STOP_MAXM) {
    if (rold_at == sweeps - 1) sweep_jean(S, r, &quad, &maxm);
    else quad = maxm = -1;
  }
  rep->constraints = S->ai.tried ? S->ai.rows : -1;
  rep->redundant = S->ai.tried ? S->ai.rows - S->ai.rank : -1;
  rep->rcond = S->ai.tried ? S->ai.rcond : NAN;
  rep->min_norm = S->ai.tried && S->ai.accepted && S->ai.min_norm;
  if (S->ai.tried)
    mo_log(ctx, 3, "nscd: closed set of %d unknowns, rank %d, rcond %.2e; %d status-set steps%s\n", S->ai.rows,
           S->ai.rank, S->ai.rcond, S->accel_tries, S->ai.accepted ? ", the last one converged" : "");
  rep->iterations = sweeps;
  rep->quad = quad;
  rep->maxm = maxm;
  if (broke >= 0) {
    const double *Waa = nscd_waa(S, broke);
    char nm[64];
    name_candidate(P, broke, nm, sizeof nm);
    rep->reason = MO_CR_BREAKDOWN;
    snprintf(rep->message, sizeof rep->message,
             "the local problem of %s has no solution or broke down (W_nn = %.3e, friction %.3g): "
             "a candidate the scene cannot push back", nm, Waa[0], nscd_mu(S, broke));
  } else if (conv) {
    rep->reason = MO_CR_CONVERGED;
  } else {
    res = residual(S, r, scaled);
    rep->reason = isfinite(res) ? MO_CR_MAXITER : MO_CR_NAN;
    if (ctx->interrupt && *ctx->interrupt) snprintf(rep->message, sizeof rep->message, "interrupted");
    else worst_candidates(S, P, r, rep, res, scaled);
  }
  mo_log(ctx, 3, "nscd: %d sweeps of %d contacts, %ld Newton steps, %ld stalls (%ld slip-angle, %ld projection, "
         "%ld unsolved)\n", sweeps, S->nact, S->lst.newton, S->lst.fallbacks, S->lst.angle, S->lst.projection,
         S->lst.failures);
  if (S->lst.failures)
    mo_log(ctx, 2, "nscd: %ld 3D local solves met no tolerance (the candidate closest to the law was kept)\n",
           S->lst.failures);
  return MO_OK;
}

/* --- the type -------------------------------------------------------------------------------------- */

const mo_contact_solver_type mo_contact_solver_nscd = {
  "nscd",
  "Jean's nonsmooth contact dynamics: nonlinear Gauss-Seidel over contacts on the Delassus operator",
  sizeof(nscd_state),
  sizeof(nscd_params),
  MO_NEEDS_DELASSUS | MO_NEEDS_BODIES | MO_NEEDS_GRAINS,
  (1u << MO_SCHEME_THETA) | (1u << MO_SCHEME_NEWMARK) | (1u << MO_SCHEME_QUASISTATIC),
  nscd_options,
  (int)MO_COUNT(nscd_options),
  nscd_defaults,
  nscd_init,
  nscd_solve,
  nscd_free,
  NULL, /* the case's time scheme */
  nscd_reinit
};
