/* contact.c: the contact step (the seam between the core and a back end), back-end options,
   and the accuracy measures common to every back end. */
#include "config.h"
#include <moreau/contact.h>
#include "case_internal.h"
#include "contact_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* --- measures ------------------------------------------------------------------------------ */

void mo_fc_project_cone(int d, double mu, double *z)
{
  double zt2 = 0, zt, pn;
  int i;
  if (d == 1) {
    if (z[0] < 0) z[0] = 0;
    return;
  }
  for (i = 1; i < d; i++) zt2 += z[i] * z[i];
  zt = sqrt(zt2);
  /* inside the cone (z_n >= 0 first: with mu = 0 and z_t = 0, 0 <= mu z_n holds for z_n < 0) */
  if (z[0] >= 0 && zt <= mu * z[0]) return;
  if (mu * zt <= -z[0]) {                          /* inside the polar cone */
    for (i = 0; i < d; i++) z[i] = 0;
    return;
  }
  pn = (z[0] + mu * zt) / (1 + mu * mu);           /* onto the cone's surface */
  z[0] = pn;
  for (i = 1; i < d; i++) z[i] = zt > 0 ? mu * pn * z[i] / zt : 0;
}

double mo_fc_natural_map_unit(int d, double mu, const double *r, const double *U)
{
  double z[3], ut2 = 0, e = 0;
  int i;
  for (i = 1; i < d; i++) ut2 += U[i] * U[i];
  /* z = r - (U + mu |U_t| e_n), projected; the residual is r - P_K(z) */
  z[0] = r[0] - (U[0] + mu * sqrt(ut2));
  for (i = 1; i < d; i++) z[i] = r[i] - U[i];
  mo_fc_project_cone(d, mu, z);
  for (i = 0; i < d; i++) e += (r[i] - z[i]) * (r[i] - z[i]);
  return e;
}

double mo_fc_natural_map_subset(int d, int n, const int *idx, const double *mu, const double *scale,
                                const double *r, const double *U, double qnorm)
{
  double e = 0, rn = 0, un = 0, den;
  int k, i;
  for (k = 0; k < n; k++) {
    int a = idx ? idx[k] : k;
    const double *ra = r + a * d, *Ua = U + a * d;
    double Us[3];
    if (scale) {
      for (i = 0; i < d; i++) Us[i] = scale[a] * Ua[i];
      Ua = Us;
    }
    e += mo_fc_natural_map_unit(d, mu ? mu[a] : 0, ra, Ua);
    for (i = 0; i < d; i++) {
      rn += ra[i] * ra[i];
      un += Ua[i] * Ua[i];
    }
  }
  /* relative to the largest of |q|, |r|, |U|: what Debian's Siconos 4.4 does */
  den = qnorm;
  if (sqrt(rn) > den) den = sqrt(rn);
  if (sqrt(un) > den) den = sqrt(un);
  return den > 1e-300 ? sqrt(e) / den : sqrt(e);
}

double mo_fc_natural_map(int d, int nc, const double *mu, const double *r, const double *U,
                         double qnorm)
{
  return mo_fc_natural_map_subset(d, nc, NULL, mu, NULL, r, U, qnorm);
}

void mo_fc_jean_norms(const mo_delassus *W, int nc, const double *r0, const double *r1,
                      double *quad, double *maxm)
{
  int d = mo_delassus_dim(W), a, i, j, nact = 0;
  double sdd = 0, swrr = 0, mx = 0;
  for (a = 0; a < nc; a++) {
    const double *Waa = mo_delassus_block(W, a, a);
    double dU[3] = {0, 0, 0}, dU2 = 0, rr = 0, wrr = 0;
    if (!Waa) continue;
    for (i = 0; i < d; i++) {
      for (j = 0; j < d; j++) {
        dU[i] += Waa[i * d + j] * (r1[a * d + j] - r0[a * d + j]);
        wrr += r1[a * d + i] * Waa[i * d + j] * r1[a * d + j];
      }
      rr += r1[a * d + i] * r1[a * d + i];
    }
    for (i = 0; i < d; i++) dU2 += dU[i] * dU[i];
    if (rr > 0) nact++;
    sdd += dU2 * rr;
    swrr += wrr;
    if (sqrt(dU2 * rr) > mx) mx = sqrt(dU2 * rr);
  }
  *quad = swrr > 0 ? sqrt(sdd) / swrr : 0;
  *maxm = swrr > 0 && nact ? mx / (swrr / nact) : 0;
}

const char *mo_contact_reason_name(int reason)
{
  switch (reason) {
  case MO_CR_CONVERGED: return "converged";
  case MO_CR_NOCONTACT: return "no contact";
  case MO_CR_MAXITER: return "iteration limit";
  case MO_CR_CYCLING: return "status cycling";
  case MO_CR_BREAKDOWN: return "breakdown";
  case MO_CR_NAN: return "NaN";
  default: return "unknown";
  }
}

/* --- options ------------------------------------------------------------------------------------- */

static int enum_index(const char *enums, const char *v)
{
  const char *p = enums;
  int k = 0;
  size_t lv = strlen(v);
  while (*p) {
    const char *bar = strchr(p, '|');
    size_t len = bar ? (size_t)(bar - p) : strlen(p);
    if (len == lv && !strncmp(p, v, len)) return k;
    if (!bar) break;
    p = bar + 1;
    k++;
  }
  return -1;
}

int mo_option_set(const mo_option_spec *opts, int nopt, void *params, const char *key,
                  const char *val, mo_ctx *ctx)
{
  int k;
  for (k = 0; k < nopt; k++) {
    const mo_option_spec *o = &opts[k];
    char *end;
    void *dst = (char *)params + o->offset;
    if (strcmp(o->name, key)) continue;
    switch (o->type) {
    case MO_OPT_INT: {
      long v = strtol(val, &end, 10);
      if (*end || end == val) return mo_error(ctx, MO_EINPUT, "option '%s' takes an integer, not '%s'", key, val);
      if ((!isnan(o->lo) && v < o->lo) || (!isnan(o->hi) && v > o->hi))
        return mo_error(ctx, MO_EINPUT, "option '%s' = %ld is out of range [%g, %g]", key, v, o->lo, o->hi);
      *(int *)dst = (int)v;
      return MO_OK;
    }
    case MO_OPT_DOUBLE: {
      double v = strtod(val, &end);
      if (*end || end == val || !isfinite(v)) return mo_error(ctx, MO_EINPUT, "option '%s' takes a number, not '%s'", key, val);
      if ((!isnan(o->lo) && v < o->lo) || (!isnan(o->hi) && v > o->hi))
        return mo_error(ctx, MO_EINPUT, "option '%s' = %g is out of range [%g, %g]", key, v, o->lo, o->hi);
      *(double *)dst = v;
      return MO_OK;
    }
    case MO_OPT_BOOL:
      if (!strcmp(val, "true") || !strcmp(val, "1")) *(int *)dst = 1;
      else if (!strcmp(val, "false") || !strcmp(val, "0")) *(int *)dst = 0;
      else return mo_error(ctx, MO_EINPUT, "option '%s' takes true or false, not '%s'", key, val);
      return MO_OK;
    case MO_OPT_ENUM: {
      int i = enum_index(o->enums, val);
      if (i < 0) return mo_error(ctx, MO_EINPUT, "option '%s' takes one of %s, not '%s'", key, o->enums, val);
      *(int *)dst = i;
      return MO_OK;
    }
    }
  }
  return mo_error(ctx, MO_EINPUT, "no option '%s'", key);
}

/* Options of the back end from the case group contact.<name> (already validated by type). */
static int apply_case_options(const mo_contact_solver_type *T, void *params, const mo_case *cs,
                              mo_ctx *ctx)
{
  char path[128], val[64];
  const config_setting_t *g;
  int i, n, st;
  snprintf(path, sizeof path, "contact.%s", T->name);
  g = config_lookup(&cs->cfg, path);
  if (!g) return MO_OK;
  n = config_setting_length(g);
  for (i = 0; i < n; i++) {
    const config_setting_t *s = config_setting_get_elem(g, (unsigned)i);
    switch (config_setting_type(s)) {
    case CONFIG_TYPE_INT: snprintf(val, sizeof val, "%d", config_setting_get_int(s)); break;
    case CONFIG_TYPE_INT64: snprintf(val, sizeof val, "%lld", config_setting_get_int64(s)); break;
    case CONFIG_TYPE_FLOAT: snprintf(val, sizeof val, "%.17g", config_setting_get_float(s)); break;
    case CONFIG_TYPE_BOOL: snprintf(val, sizeof val, "%s", config_setting_get_bool(s) ? "true" : "false"); break;
    case CONFIG_TYPE_STRING: snprintf(val, sizeof val, "%s", config_setting_get_string(s)); break;
    default: return mo_case_error(cs, s, ctx, "must be a value");
    }
    if ((st = mo_option_set(T->options, T->noptions, params, config_setting_name(s), val, ctx))) {
      char msg[MO_ERRMSG_MAX];
      snprintf(msg, sizeof msg, "%s", ctx->errmsg);
      mo_ctx_clear_error(ctx);
      return mo_case_error(cs, s, ctx, "%s", msg);
    }
  }
  return MO_OK;
}

/* --- the driver ---------------------------------------------------------------------------------- */

int mo_contact_time_scheme(mo_scene *sc, const mo_contact *C, mo_ctx *ctx)
{
  const mo_contact_solver_type *T = mo_contact_solver_find(C->solver);
  void *params;
  mo_time_settings old = sc->time;
  int st;
  if (!T || !T->time_scheme) return MO_OK; /* unknown names are reported by the driver */
  params = mo_calloc(ctx, 1, T->params_size ? T->params_size : 1);
  if (!params) return MO_ENOMEM;
  if (T->defaults) T->defaults(params);
  st = apply_case_options(T, params, sc->cs, ctx);
  if (!st) st = T->time_scheme(params, &sc->time, ctx);
  mo_free(params);
  if (st) return st;
  if (sc->time.scheme != old.scheme) {
    if (sc->time.scheme != MO_SCHEME_QUASISTATIC && !sc->M)
      return mo_error(ctx, MO_EUNSUPPORTED, "contact back end %s runs a dynamic scheme, but the case is "
                      "quasi-static (no mass matrix)", T->name);
    mo_note_skip(ctx, "the case's %s scheme: back end %s runs %s (beta = %g, gamma = %g)",
                 old.scheme == MO_SCHEME_THETA ? "theta" : old.scheme == MO_SCHEME_NEWMARK ? "newmark" : "quasistatic",
                 T->name, sc->time.scheme == MO_SCHEME_NEWMARK ? "newmark" : "its own scheme",
                 sc->time.beta, sc->time.gamma);
  }
  return MO_OK;
}

struct mo_contact_driver {
  const mo_scene *sc;
  mo_contact *C;
  mo_stepper *S;
  const mo_contact_solver_type *T;
  void *params, *state;
  int initialised;
  mo_delassus *W;
  mo_contact_problem P;
  mo_contact_vars x;
  mo_contact_report rep;
  int nc, m, d;
  double *b, *q, *U, *Uprev, *r, *rprev, *xfull, *xf, *dx, *dxfull, *mu, *gk, *w;
  double *ukin;              /* W r of the last solve (with W), then U without the Signorini
                                offsets: W r + b (contact_finish) */
  double *xnl;               /* nonlinear steps: Newton's iterate (full) */
  int any_step, it_step, loops_step[4]; /* nonlinear steps: totals over the Newton iterations */
  unsigned char *active;
  int *act, nact;            /* the active candidates of the last solve, in increasing order */
  int *status;
  long steps, iterations, max_iterations, wbuilds, failures;
  double max_residual;
  long fversion;
};

const mo_contact_report *mo_contact_last_report(const mo_contact_driver *D) { return &D->rep; }
double mo_contact_driver_dt(const mo_contact_driver *D) { return mo_stepper_dt(D->S); }

/* --- snapshots for step cutting ------------------------------------------------------------
   What a step changes in the driver and needs back to be taken again: the reactions (warm
   start, and the index set's "carried a compressive impulse"), the previous local velocities,
   the statuses; the geometry is recomputed from the restored displacements. D->rprev is not
   saved: a nonlinear step sets it from D->r before reading it. */
struct mo_contact_snapshot {
  double *r, *Uprev, *U;
  int *status;
};

int mo_contact_snapshot_create(const mo_contact_driver *D, mo_contact_snapshot **out, mo_ctx *ctx)
{
  mo_contact_snapshot *X = mo_calloc(ctx, 1, sizeof *X);
  size_t m = (size_t)D->m + 1;
  *out = NULL;
  if (!X) return MO_ENOMEM;
  X->r = mo_malloc(ctx, m * sizeof(double));
  X->Uprev = mo_malloc(ctx, m * sizeof(double));
  X->U = mo_malloc(ctx, m * sizeof(double));
  X->status = mo_malloc(ctx, ((size_t)D->nc + 1) * sizeof(int));
  if (!X->r || !X->Uprev || !X->U || !X->status) {
    mo_contact_snapshot_free(X);
    return MO_ENOMEM;
  }
  *out = X;
  return MO_OK;
}

void mo_contact_snapshot_free(mo_contact_snapshot *X)
{
  if (!X) return;
  mo_free(X->r);
  mo_free(X->Uprev);
  mo_free(X->U);
  mo_free(X->status);
  mo_free(X);
}

void mo_contact_snapshot_save(const mo_contact_driver *D, mo_contact_snapshot *X)
{
  size_t m = (size_t)D->m * sizeof(double);
  memcpy(X->r, D->r, m);
  memcpy(X->Uprev, D->Uprev, m);
  memcpy(X->U, D->U, m);
  memcpy(X->status, D->status, (size_t)D->nc * sizeof(int));
}

int mo_contact_snapshot_restore(mo_contact_driver *D, const mo_contact_snapshot *X, const mo_state *s,
                                mo_ctx *ctx)
{
  size_t m = (size_t)D->m * sizeof(double);
  memcpy(D->r, X->r, m);
  memcpy(D->Uprev, X->Uprev, m);
  memcpy(D->U, X->U, m);
  memcpy(D->status, X->status, (size_t)D->nc * sizeof(int));
  return mo_contact_geometry(D->C, s->u, s->t, D->C->repair, ctx);
}
const double *mo_contact_reactions(const mo_contact_driver *D) { return D->r; }
const double *mo_contact_local_velocity(const mo_contact_driver *D) { return D->U; }
const int *mo_contact_statuses(const mo_contact_driver *D) { return D->status; }
const mo_contact_solver_type *mo_contact_driver_type(const mo_contact_driver *D) { return D->T; }
const mo_delassus *mo_contact_driver_delassus(const mo_contact_driver *D) { return D->W; }

void mo_contact_driver_totals(const mo_contact_driver *D, long *steps, long *iterations,
                              long *max_iterations, long *wbuilds, double *max_residual)
{
  if (steps) *steps = D->steps;
  if (iterations) *iterations = D->iterations;
  if (max_iterations) *max_iterations = D->max_iterations;
  if (wbuilds) *wbuilds = D->wbuilds;
  if (max_residual) *max_residual = D->max_residual;
}

void mo_contact_driver_free(mo_contact_driver *D)
{
  if (!D) return;
  if (D->T && D->T->free && D->state) D->T->free(D->state);
  mo_free(D->state);
  mo_free(D->params);
  mo_delassus_free(D->W);
  mo_free(D->b); mo_free(D->q); mo_free(D->U); mo_free(D->Uprev); mo_free(D->r); mo_free(D->rprev);
  mo_free(D->xfull); mo_free(D->xf); mo_free(D->dx); mo_free(D->dxfull); mo_free(D->mu); mo_free(D->gk); mo_free(D->w); mo_free(D->ukin); mo_free(D->xnl);
  mo_free(D->active);
  mo_free(D->act);
  mo_free(D->status);
  mo_free(D);
}

int mo_contact_driver_create(const mo_scene *sc, mo_contact *C, mo_stepper *S,
                             mo_contact_driver **out, mo_ctx *ctx)
{
  mo_contact_driver *D;
  const mo_case *cs = sc->cs;
  int st, k, n = sc->ndof, nf = sc->nfree;
  *out = NULL;
  D = mo_calloc(ctx, 1, sizeof *D);
  if (!D) return MO_ENOMEM;
  D->sc = sc;
  D->C = C;
  D->S = S;
  D->T = mo_contact_solver_find(C->solver);
  if (!D->T) {
    char list[256];
    int len = 0;
    const config_setting_t *s = config_lookup(&cs->cfg, "contact.solver");
    for (k = 0; k < mo_contact_solver_count() && len < 200; k++)
      len += snprintf(list + len, sizeof list - (size_t)len, "%s%s", k ? ", " : "", mo_contact_solver_at(k)->name);
    if (!len) snprintf(list, sizeof list, "none in this build");
    st = mo_case_error(cs, s ? s : config_lookup(&cs->cfg, "contact"), ctx,
                       "unknown contact back end '%s' (registered: %s)", C->solver, list);
    mo_free(D);
    return st;
  }
  if (!(D->T->schemes & (1u << sc->time.scheme))) {
    const config_setting_t *s = config_lookup(&cs->cfg, "time.scheme");
    st = mo_case_error(cs, s ? s : config_lookup(&cs->cfg, "time"), ctx,
                       "contact back end '%s' does not support the %s scheme", D->T->name,
                       sc->time.scheme == MO_SCHEME_NEWMARK ? "newmark" : sc->time.scheme == MO_SCHEME_QUASISTATIC ? "quasistatic" : "theta");
    mo_free(D);
    return st;
  }
  D->nc = C->nc;
  D->d = C->dim;
  D->m = C->nc * C->dim;
  D->params = mo_calloc(ctx, 1, D->T->params_size ? D->T->params_size : 1);
  D->state = mo_calloc(ctx, 1, D->T->state_size ? D->T->state_size : 1);
  D->b = mo_calloc(ctx, (size_t)D->m, sizeof(double));
  D->q = mo_calloc(ctx, (size_t)D->m, sizeof(double));
  D->U = mo_calloc(ctx, (size_t)D->m, sizeof(double));
  D->Uprev = mo_calloc(ctx, (size_t)D->m, sizeof(double));
  D->r = mo_calloc(ctx, (size_t)D->m, sizeof(double));
  D->rprev = mo_calloc(ctx, (size_t)D->m, sizeof(double));
  D->mu = mo_calloc(ctx, (size_t)D->nc, sizeof(double));
  D->gk = mo_calloc(ctx, (size_t)D->nc, sizeof(double));
  D->w = mo_calloc(ctx, (size_t)D->nc, sizeof(double));
  D->ukin = mo_calloc(ctx, (size_t)D->m, sizeof(double));
  D->active = mo_calloc(ctx, (size_t)D->nc, 1);
  D->act = mo_calloc(ctx, (size_t)D->nc + 1, sizeof(int));
  D->status = mo_calloc(ctx, (size_t)D->nc, sizeof(int));
  D->xfull = mo_calloc(ctx, (size_t)n + 1, sizeof(double));
  D->dxfull = mo_calloc(ctx, (size_t)n + 1, sizeof(double));
  D->xf = mo_calloc(ctx, (size_t)nf + 1, sizeof(double));
  D->dx = mo_calloc(ctx, (size_t)nf + 1, sizeof(double));
  D->xnl = mo_calloc(ctx, (size_t)n + 1, sizeof(double));
  if (!D->params || !D->state || !D->b || !D->q || !D->U || !D->Uprev || !D->r || !D->rprev || !D->mu ||
      !D->gk || !D->w || !D->ukin || !D->active || !D->act || !D->status || !D->xfull || !D->dxfull || !D->xf || !D->dx || !D->xnl) {
    mo_contact_driver_free(D);
    return MO_ENOMEM;
  }
  if (D->T->defaults) D->T->defaults(D->params);
  if ((st = apply_case_options(D->T, D->params, cs, ctx))) {
    mo_contact_driver_free(D);
    return st;
  }
  if ((D->T->needs & MO_NEEDS_DELASSUS) && (st = mo_delassus_create(&D->W, ctx))) {
    mo_contact_driver_free(D);
    return st;
  }
  for (k = 0; k < D->nc; k++) {
    D->mu[k] = C->cand[k].mu;
    D->w[k] = C->cand[k].w;
  }
  /* U- at t = 0: H^T v0 + U0 */
  mo_csc_gatxpy(C->Hfull, 1, sc->v0, 0, D->Uprev);
  for (k = 0; k < D->m; k++) D->Uprev[k] += C->U0[k];
  *out = D;
  return MO_OK;
}

/* The three candidates furthest from the contact law (natural map with U in force units,
   U / W_aa), named by pair and node, for diagnoses. */
static void worst_candidates(const mo_contact_driver *D, char *buf, size_t n)
{
  int d = D->d, a, k, best[3] = {-1, -1, -1};
  double val[3] = {-1, -1, -1};
  size_t len = 0;
  for (a = 0; a < D->nc; a++) {
    double Us[3], w = 1, e;
    const double *Waa = D->W ? mo_delassus_block(D->W, a, a) : NULL;
    int i;
    if (!D->active[a]) continue;
    if (Waa && Waa[0] > 0) w = Waa[0];
    for (i = 0; i < d; i++) Us[i] = D->U[a * d + i] / w;
    e = mo_fc_natural_map_unit(d, D->mu[a], D->r + a * d, Us);
    for (k = 0; k < 3; k++)
      if (e > val[k]) {
        int j;
        for (j = 2; j > k; j--) { val[j] = val[j - 1]; best[j] = best[j - 1]; }
        val[k] = e;
        best[k] = a;
        break;
      }
  }
  buf[0] = '\0';
  for (k = 0; k < 3 && best[k] >= 0; k++) {
    const mo_candidate *c = &D->C->cand[best[k]];
    int w = snprintf(buf + len, n - len, "%s%d (pair '%s', %s %d)", k ? ", " : "", best[k], D->C->pair[c->pair].name,
                     c->node >= 0 ? "node" : "Gauss point of facet", c->node >= 0 ? c->node : D->C->pt[c->point].facet);
    if (w < 0 || (size_t)w >= n - len) break;
    len += (size_t)w;
  }
  if (!len) snprintf(buf, n, "none active");
}

/* Steps 2-7 of a step (doc/theory.md §5): from the unconstrained iterate D->xfull (full; D->xf
   its free part) and the gaps at the start of the step, the local problem, the back end's
   solve, the core's measure, and the correction dx (free dofs) added to D->xfull. rstep: the
   reactions of the previous step (the velocity-level index set). newton: the Newton iterate of a
   nonlinear step (-1 for a linear one), for diagnoses. *any: some candidate was active. */
static int contact_solve(mo_contact_driver *D, const mo_state *s, const double *rstep, int newton,
                         int *any_out, mo_ctx *ctx)
{
  const mo_scene *sc = D->sc;
  mo_contact *C = D->C;
  mo_stepper *S = D->S;
  mo_contact_problem *P = &D->P;
  mo_contact_report *rep = &D->rep;
  int d = D->d, m = D->m, nc = D->nc, n = sc->ndof, st, a, i, any = 0, rebuilt = 0;
  double h = mo_stepper_dt(S), theta = sc->time.theta, t0, c, dtpos;
  const double *g;
  mo_scheme scheme = sc->time.scheme;

  /* 2. geometry at the start of the step: computed at the end of the previous step (or by
     mo_contact_build at t = 0), so that reported gaps are end-of-step values */
  g = mo_contact_gaps(C);
  memcpy(D->gk, g, (size_t)nc * sizeof(double));
  /* 3. the local free kinematics b: velocity (theta) or displacement increment */
  if (scheme == MO_SCHEME_THETA) {
    mo_csc_gatxpy(C->Hfull, 1, D->xfull, 0, D->b);
    for (i = 0; i < m; i++) D->b[i] += C->U0[i];
    c = 1;
    dtpos = h * theta;
  } else {
    double *du = D->dxfull;
    if (scheme == MO_SCHEME_NEWMARK) {
      double beta = sc->time.beta;
      for (i = 0; i < n; i++) du[i] = h * s->v[i] + h * h * ((0.5 - beta) * s->a[i] + beta * D->xfull[i]);
      c = beta * h * h;
    } else {
      for (i = 0; i < n; i++) du[i] = D->xfull[i] - s->u[i];
      c = 1;
    }
    mo_csc_gatxpy(C->Hfull, 1, du, 0, D->b);
    for (i = 0; i < m; i++) D->b[i] += C->U0[i] * h;
    dtpos = 1;
  }
  /* 4. the complementarity problem U' = W r + q, with the Signorini offsets in q */
  memcpy(D->q, D->b, (size_t)m * sizeof(double));
  D->nact = 0;
  for (a = 0; a < nc; a++) {
    int act = C->active[a];
    if (scheme == MO_SCHEME_THETA && C->signorini == MO_SIGNORINI_POSITION)
      /* g_k+1 = g_k + h (theta U+ + (1 - theta) U-) >= 0  (J88 (3.2)_1 with theta) */
      D->q[a * d] += (g[a] + h * (1 - theta) * D->Uprev[a * d]) / dtpos;
    else if (scheme == MO_SCHEME_THETA) {
      /* velocity level on the index set: the candidates predicted closed (the end-of-step gap
         of (T2) if no contact impulse acted this step, g_k + h (theta U_free + (1 - theta) U-))
         and those that carried a compressive impulse in the previous step (doc/theory.md §5):
         a theta = 1 landing step leaves the gap it started with, and the contact must stay
         in the set until the back end releases it (r = 0), not drop out on that gap */
      if (g[a] + h * (theta * D->b[a * d] + (1 - theta) * D->Uprev[a * d]) > 0 && !(rstep[a * d] > 0))
        act = 0;
    } else
      D->q[a * d] += g[a];
    D->active[a] = (unsigned char)act;
    if (act) D->act[D->nact++] = a;
    any |= act;
  }
  *any_out = any;
  if (D->W) {
    long fv = 0;
    mo_linsolver_stats(mo_stepper_solver(S), &fv, NULL, NULL);
    if ((st = mo_delassus_update(D->W, C->H, mo_contact_h_version(C), mo_stepper_solver(S), fv, c, d,
                                 &rebuilt, ctx)))
      return st;
    if (rebuilt) D->wbuilds++;
    else if (D->steps) mo_note_skip(ctx, "Delassus rebuilds (H and What unchanged)");
  }
  /* 5. the back end */
  memset(P, 0, sizeof *P);
  P->dim = d;
  P->nc = nc;
  P->m = m;
  P->mu = D->mu;
  P->g = D->gk;
  P->Uprev = D->Uprev;
  P->frame = mo_contact_frames(C);
  P->contact = C;
  P->W = D->W;
  P->b = D->q;
  P->active = D->active;
  P->scheme = scheme;
  P->h = h;
  P->theta = theta;
  P->theta_f = sc->time.theta_f;
  P->beta = sc->time.beta;
  P->gamma = sc->time.gamma;
  P->signorini = C->signorini;
  P->nfree = sc->nfree;
  P->H = C->H;
  P->What = mo_stepper_matrix(S);
  P->ls = mo_stepper_solver(S);
  P->xfree = D->xf;
  P->du_dx = c;
  P->step = s->step + 1;
  P->t = s->t;
  P->w = D->w;
  memset(rep, 0, sizeof *rep);
  D->x.r = D->r;
  D->x.U = D->U;
  D->x.status = D->status;
  D->x.dx = D->dx;
  D->x.dx_set = 0;
  for (a = 0; a < nc; a++)
    if (!D->active[a]) for (i = 0; i < d; i++) D->r[a * d + i] = 0;
  t0 = mo_clock();
  if (!D->initialised) {
    if (D->T->init && (st = D->T->init(D->state, D->params, P, ctx))) return st;
    D->initialised = 1;
  }
  if (!any) {
    memset(D->r, 0, (size_t)m * sizeof(double));
    for (a = 0; a < nc; a++) D->status[a] = MO_CS_OPEN;
    rep->reason = MO_CR_NOCONTACT;
  } else if ((st = D->T->solve(D->state, P, &D->x, rep, ctx))) {
    mo_phase_add(ctx, MO_PH_CONTACT, t0);
    if (newton >= 0)
      return mo_error_prefix(ctx, "step %ld (t = %.6g), Newton iterate %d: contact back end %s", P->step,
                             s->t + h, newton, D->T->name);
    return mo_error_prefix(ctx, "step %ld (t = %.6g): contact back end %s", P->step, s->t + h, D->T->name);
  }
  mo_phase_add(ctx, MO_PH_CONTACT, t0);
  for (i = 0; i < m; i++)
    if (!isfinite(D->r[i]))
      return mo_error(ctx, MO_ENAN, "step %ld (t = %.6g): contact back end %s returned a non-finite "
                      "reaction at candidate %d", P->step, s->t + h, D->T->name, i / d);
  /* 6. the core's measure: U' = W r + q when W is known, else the back end's U; W r is kept
     for contact_finish */
  if (D->W) {
    mo_delassus_mult(D->W, D->r, 0, D->ukin);
    for (i = 0; i < m; i++) D->U[i] = D->ukin[i] + D->q[i];
  }
  {
    /* over the active candidates only (the others are out of the problem this step) */
    double qn = 0;
    int k;
    for (k = 0; k < D->nact; k++)
      for (i = 0; i < d; i++) qn += D->q[D->act[k] * d + i] * D->q[D->act[k] * d + i];
    rep->residual = mo_fc_natural_map_subset(d, D->nact, D->act, D->mu, NULL, D->r, D->U, sqrt(qn));
  }
  for (a = 0; a < nc; a++) {
    if (!D->active[a]) D->status[a] = MO_CS_OPEN;
    rep->nopen += D->status[a] == MO_CS_OPEN;
    rep->nstick += D->status[a] == MO_CS_STICK;
    rep->nslide += D->status[a] == MO_CS_SLIDE;
  }
  if (any) {
    if (newton < 0) { /* a nonlinear step counts its Newton iterations' solves as one */
      D->steps++;
      D->iterations += rep->iterations;
      if (rep->iterations > D->max_iterations) D->max_iterations = rep->iterations;
    }
    if (rep->residual > D->max_residual) D->max_residual = rep->residual;
  }
  if (rep->reason < 0) {
    D->failures++;
    if (!C->on_failure_continue) {
      char worst[400], it[48] = "";
      worst_candidates(D, worst, sizeof worst);
      if (newton >= 0) snprintf(it, sizeof it, ", Newton iterate %d", newton);
      return mo_error(ctx, MO_ENOCONV,
                      "step %ld (t = %.6g%s): the %s contact solve stopped on %s after %d iterations "
                      "(residual %.3e; %d closed of %d candidates)%s%s. Candidates furthest from the "
                      "contact law: %s. Remedies: a smaller time step (time.dt, or time.max_cuts), a larger iteration limit "
                      "(contact.%s options), or contact.on_failure = \"continue\"",
                      P->step, s->t + h, it, D->T->name, mo_contact_reason_name(rep->reason), rep->iterations,
                      rep->residual, nc - rep->nopen, nc, rep->message[0] ? ": " : "", rep->message, worst,
                      D->T->name);
    }
  }
  /* 7. correction */
  if (!D->x.dx_set) {
    if (D->W) {
      if ((st = mo_delassus_apply_Cinv(D->W, C->H, mo_stepper_solver(S), D->r, D->dx, ctx))) return st;
    } else {
      double *rhs = D->dxfull;
      memset(rhs, 0, (size_t)n * sizeof(double));
      mo_csc_gaxpy(C->Hfull, 1, D->r, 0, rhs);
      if ((st = mo_stepper_correct(S, rhs, D->dxfull, ctx))) return st;
      mo_stepper_gather(S, D->dxfull, D->dx);
    }
  }
  for (i = 0; i < sc->nfree; i++) D->xfull[sc->full_of[i]] += D->dx[i];
  return MO_OK;
}

/* The end of a step: the work of the contact impulses, impulse . mean local velocity (theta),
   force . increment (others), the local velocities U- of the next step, then the stepper's
   finish at x and the geometry of the end of the step. With W, D->ukin holds W r of the step's
   last contact_solve (r, b and W are those of that solve). */
static int contact_finish(mo_contact_driver *D, mo_state *s, const double *x, mo_ctx *ctx)
{
  int m = D->m, i, st;
  mo_scheme scheme = D->sc->time.scheme;
  double w = 0;
  const double *Ukin = D->W ? D->ukin : D->U; /* without W: the back end's U, read in place */
  if (D->W) for (i = 0; i < m; i++) D->ukin[i] += D->b[i];
  for (i = 0; i < m; i++)
    w += D->r[i] * (scheme == MO_SCHEME_THETA ? 0.5 * (Ukin[i] + D->Uprev[i]) : Ukin[i]);
  s->wcontact += w;
  if (scheme == MO_SCHEME_THETA) memcpy(D->Uprev, Ukin, (size_t)m * sizeof(double));
  if ((st = mo_stepper_finish(D->S, s, x, ctx))) return st;
  return mo_contact_geometry(D->C, s->u, s->t, D->C->repair, ctx);
}

/* The contact layer inside a Newton iteration of a nonlinear step (mo_constraint_fn): the same
   local problem as a linear step's, on What_k and x_free of the iterate (doc/theory.md (T63)). */
static int newton_constraint(void *data, const mo_state *s, const double *x_free, double *x, double *g,
                             int iter, mo_ctx *ctx)
{
  mo_contact_driver *D = data;
  const mo_scene *sc = D->sc;
  int st, any, k, n = sc->ndof;
  memcpy(D->xfull, x_free, (size_t)n * sizeof *x);
  mo_stepper_gather(D->S, D->xfull, D->xf);
  if ((st = contact_solve(D, s, D->rprev, iter, &any, ctx))) return st;
  memcpy(x, D->xfull, (size_t)n * sizeof *x);
  /* g = What (x - x_free) = H r over free dofs (the KKT path's dv solves What dv = H_C r) */
  mo_csc_gaxpy(D->C->Hfull, 1, D->r, 0, g);
  for (k = 0; k < sc->npresc; k++) g[sc->presc[k].dof] = 0;
  D->any_step |= any;
  D->it_step += D->rep.iterations;
  for (k = 0; k < 4; k++) D->loops_step[k] += D->rep.loops[k];
  return MO_OK;
}

int mo_contact_step(mo_contact_driver *D, mo_state *s, mo_ctx *ctx)
{
  mo_stepper *S = D->S;
  int st, any, k;

  if (mo_stepper_nonlinear(S)) {
    /* Newton on the smooth part, the contact problem solved at every iteration on the
       linearized step; the reactions of the previous step set the index set and warm start */
    memcpy(D->rprev, D->r, (size_t)D->m * sizeof(double));
    D->any_step = D->it_step = 0;
    memset(D->loops_step, 0, sizeof D->loops_step);
    mo_stepper_guess(S, s, D->xnl);
    if ((st = mo_stepper_solve(S, s, D->xnl, newton_constraint, D, ctx))) return st;
    D->rep.iterations = D->it_step;
    for (k = 0; k < 4; k++) D->rep.loops[k] = D->loops_step[k];
    if (D->any_step) {
      D->steps++;
      D->iterations += D->it_step;
      if (D->it_step > D->max_iterations) D->max_iterations = D->it_step;
    }
    return contact_finish(D, s, D->xnl, ctx);
  }
  /* 1. the unconstrained step */
  if ((st = mo_stepper_predict(S, s, D->xfull, ctx))) return st;
  mo_stepper_gather(S, D->xfull, D->xf);
  if ((st = contact_solve(D, s, D->r, -1, &any, ctx))) return st;
  return contact_finish(D, s, D->xfull, ctx);
}

int mo_contact_driver_local_problem(const mo_contact_driver *D, double **W, double **q, double **mu,
                                    int *nc, int *d, mo_ctx *ctx)
{
  int st;
  *W = *q = *mu = NULL;
  if (!D->W) return mo_error(ctx, MO_EUNSUPPORTED, "back end %s does not use the Delassus operator", D->T->name);
  if ((st = mo_delassus_dense(D->W, W, ctx))) return st;
  *q = mo_malloc(ctx, (size_t)D->m * sizeof(double));
  *mu = mo_malloc(ctx, (size_t)D->nc * sizeof(double));
  if (!*q || !*mu) {
    mo_free(*W); mo_free(*q); mo_free(*mu);
    return MO_ENOMEM;
  }
  memcpy(*q, D->q, (size_t)D->m * sizeof(double));
  memcpy(*mu, D->mu, (size_t)D->nc * sizeof(double));
  *nc = D->nc;
  *d = D->d;
  return MO_OK;
}
