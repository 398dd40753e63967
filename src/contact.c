/* contact.c: the contact step (the seam between the core and a back end), back-end options,
   and the accuracy measures common to every back end. */
#include "config.h"
#include <moreau/contact.h>
#include <moreau/backend.h>
#include "case_internal.h"
#include "contact_internal.h"
#include "parallel_detect.h"
#include <moreau/parallel.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Candidate a's law: its pair's. */
static inline mo_contact_law law_of(const mo_contact *C, int a) { return C->pair[mo_contact_pair_of(C, a)].law; }

/* --- measures ------------------------------------------------------------------------------ */

/* The cone projection and the unit term, inline for the sums over contacts (the exported
   functions below are these). */
static inline void project_cone(int d, double mu, double *z)
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

static inline double natural_map_unit(int d, double mu, const double *r, const double *U)
{
  double z[3], ut2 = 0, e = 0;
  int i;
  for (i = 1; i < d; i++) ut2 += U[i] * U[i];
  /* z = r - (U + mu |U_t| e_n), projected; the residual is r - P_K(z) */
  z[0] = r[0] - (U[0] + mu * sqrt(ut2));
  for (i = 1; i < d; i++) z[i] = r[i] - U[i];
  project_cone(d, mu, z);
  for (i = 0; i < d; i++) e += (r[i] - z[i]) * (r[i] - z[i]);
  return e;
}

void mo_fc_project_cone(int d, double mu, double *z) { project_cone(d, mu, z); }

double mo_fc_natural_map_unit(int d, double mu, const double *r, const double *U)
{
  return natural_map_unit(d, mu, r, U);
}

double mo_fc_natural_map_subset(int d, int n, const int *idx, const double *mu, const double *scale,
                                const double *r, const double *U, double qnorm)
{
  return mo_fc_natural_map_subset_pairs(d, n, idx, mu, NULL, NULL, scale, r, U, qnorm);
}

void mo_fc_natural_map_parts(int d, int n, const int *idx, const double *mu, const int *key, const double *pmu,
                             const double *scale, const double *r, const double *U, double *out)
{
  double e = 0, rn = 0, un = 0;
  int k, i;
  for (k = 0; k < n; k++) {
    int a = idx ? idx[k] : k;
    const double *ra = r + a * d, *Ua = U + a * d;
    double Us[3];
    if (scale) {
      for (i = 0; i < d; i++) Us[i] = scale[a] * Ua[i];
      Ua = Us;
    }
    e += natural_map_unit(d, mu ? mu[a] : pmu ? pmu[key[(size_t)a * MO_KEY]] : 0, ra, Ua);
    for (i = 0; i < d; i++) {
      rn += ra[i] * ra[i];
      un += Ua[i] * Ua[i];
    }
  }
  out[0] = e;
  out[1] = rn;
  out[2] = un;
}

double mo_fc_natural_map_join(const double *parts, double qnorm)
{
  /* relative to the largest of |q|, |r|, |U|: what Debian's Siconos 4.4 does */
  double den = qnorm;
  if (sqrt(parts[1]) > den) den = sqrt(parts[1]);
  if (sqrt(parts[2]) > den) den = sqrt(parts[2]);
  return den > 1e-300 ? sqrt(parts[0]) / den : sqrt(parts[0]);
}

double mo_fc_natural_map_subset_pairs(int d, int n, const int *idx, const double *mu, const int *key, const double *pmu,
                                      const double *scale, const double *r, const double *U, double qnorm)
{
  double parts[3];
  mo_fc_natural_map_parts(d, n, idx, mu, key, pmu, scale, r, U, parts);
  return mo_fc_natural_map_join(parts, qnorm);
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
  const mo_contact_solver_type *T = mo_contact_solver_lookup(C->solver, ctx);
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
    mo_note_skip(ctx, "the case's %s scheme: back end %s runs %s (beta = %g, gamma = %g)%s",
                 old.scheme == MO_SCHEME_THETA ? (old.explicit_cd ? "explicit" : "theta")
                 : old.scheme == MO_SCHEME_NEWMARK ? "newmark" : "quasistatic",
                 T->name, sc->time.scheme == MO_SCHEME_NEWMARK ? "newmark" : "its own scheme",
                 sc->time.beta, sc->time.gamma, old.explicit_cd ? ", with the lumped mass the explicit scheme set" : "");
    sc->time.explicit_cd = 0; /* (T100) is the theta-scheme's */
  }
  return MO_OK;
}

/* A key with the position it had, sorted to find the old candidate of a new one. */

struct mo_contact_driver {
  const mo_scene *sc;
  mo_contact *C;
  mo_stepper *S;
  const mo_contact_solver_type *T;
  void *params, *state;
  int initialised;
  int reinit;                /* the set changed since the back end's init: its reinit is due */
  double *pforce;            /* 3 per pair: the resultant force of the last step on the slaves */
  double fn_step;            /* the sum of the normal forces of the last step */
  long cset;                 /* the candidate set the arrays and the back end were set up for */
  mo_delassus *W;
  int wused;                 /* the last solve was given W (else a back end on the bodies' blocks) */
  int wkeep;                 /* W wanted at every step even where the back end works without (FCLIB) */
  mo_contact_problem P;
  mo_contact_vars x;
  mo_contact_report rep;
  int nc, m, d, cap;         /* candidates, m = d nc, capacity (candidates) of the arrays */
  double *q, *U, *Uprev, *r, *rprev, *mu, *gk, *w;
  double *pmu;               /* per pair its friction coefficient, on the granular path (the back end
                                sweeps the compact records): there a candidate's is its pair's, read
                                through its key, and mu is NULL (doc/theory.md (T189)) */
  double *bn;                /* nc: the normal component of b (q's tangential ones are b's); on the
                                granular path q - b's normal component as rounded, the law's offset
                                (doc/theory.md (T240)) */
  int qu;                    /* the granular path this step: q is formed in U (the back end reads it
                                before it writes U) and D->q is not kept (T240) */
  int qb;                    /* some pair's index set reads b (Signorini): q kept in its own array */
  double qn2;                /* the granular path: |q|^2 over the index set, summed as q is formed */
  double *ukin;              /* W r of the last solve (with W), then U without the Signorini
                                offsets: W r + b (contact_finish); allocated by the first solve on W */
  int ukcap;
  unsigned char *active;
  int *act, nact;            /* the active candidates of the last solve, in increasing order */
  int *status;
  int *key;                  /* nc * MO_KEY: the candidates the arrays hold; NULL when the detection
                                writes the remap itself (the granular path, on one rank or several:
                                T220, T270) */
  int dmap;                  /* the detection writes the remap: follow_set reads it (T222) */
  double *xfull, *xf, *dx, *dxfull, *xnl, *gnl;
  double *tmp;               /* the general path's remapping scratch (2 m + nc values) and the position
                                correction's; NULL on the granular path */
  int *itmp;                 /* fit: each candidate's place in the old set */
  long map_from, map_to;     /* the sets itmp maps from and to (-1: none): the metrics read it
                                (mo_contact_driver_remap) instead of keeping keys of their own */
  long anchor;               /* the set at the end of the last step completed: the remaps of a step
                                taken again (a restore, then the step's own) are composed from it */
  mo_keymap kmap;            /* fit: the old keys' positions */
  int any_step, it_step, loops_step[4]; /* nonlinear steps: totals over the Newton iterations */
  /* the problem of the last solve on its index set, kept when wkeep (FCLIB dumps): sv_n
     candidates sv_idx of sv_ncand, their q, mu, r, U; the set's W stays in D->W until the next
     solve */
  int sv_n, sv_ncand, sv_cap, sv_valid, sv_newton, sv_reason, sv_nlaw[3];
  int *sv_idx;
  double *sv_q, *sv_mu, *sv_r, *sv_U, sv_residual;
  long steps, iterations, max_iterations, wbuilds, failures;
  long factorizations, factor_reuses;
  long sweeps;               /* smoother sweeps inside the back end's Newton method (levelset's hybrid) */
  long index_added;          /* candidates added to velocity-level index sets after a solve (§5) */
  int nc_max;                /* the most candidates a step had */
  long nc_all, nc_all_max;   /* the distributed set: every rank's candidates of the last step, the most */
  long bearing_all;          /* the distributed set: every rank's candidates with r_n > 0 at the last step */
  double max_residual;
  double *eqf, *eqk;         /* quasi-static linear scenes: f + H r and K u (the equilibrium check, T82) */
  double eq_residual, max_eq_residual;
  int redundant_max, redundant_steps, constraints_last, redundant_last; /* (T84), when the back end measures it */
  double rcond_last, rcond_min;
  int min_norm_last;
  /* the position correction (T95): steps corrected, the largest penetration it removed, the
     largest left after it, sweeps of its projected Gauss-Seidel (most in a step), steps whose
     sweeps ran out */
  long pc_steps, pc_sweeps_max, pc_unconverged;
  double pc_max, pc_left, ptol;
  double pc_energy_paid;     /* energy the shifts would have added, taken from the kinetic energy (T96) */
  double pc_energy_added;    /* what the kinetic energy could not pay */
  double *pcwork;            /* 2 ndof */
  double *pc_momentum;       /* 3 per body: the linear momentum the energy compensation took */
  /* the granular path (doc/theory.md §12.9): per body its first free dof (-1 none) and its centre */
  mo_grains grains;
  int *gvel;
  double *gcentre;
  /* the state the detected candidates' Uprev were last computed at (mo_contact_driver_uprev) */
  long up_step;
  const double *up_v;
  int free_alias;            /* every dof free and no mesh (rigid bodies and obstacles): xf is xfull and
                                dx is dxfull, one array each (doc/theory.md (T236)) */
  int split;                 /* this step is split (doc/theory.md (T153)): x_free known on the contact
                                dofs only until the correction's backward solve */
};

const mo_contact_report *mo_contact_last_report(const mo_contact_driver *D) { return &D->rep; }
double mo_contact_driver_dt(const mo_contact_driver *D) { return mo_stepper_dt(D->S); }

/* --- the arrays of the candidate set ---------------------------------------------------------
   A scene with rigid shapes detects its candidates at every step: the arrays follow the set,
   carrying a candidate's reaction (the warm start), status and local velocity over by its key
   (pair, bodies, features; doc/theory.md §12.3). */

/* Candidate a's friction coefficient: the driver's copy, or on the granular path its pair's (T189). */
static inline double mu_of(const mo_contact_driver *D, int a)
{
  return D->mu ? D->mu[a] : D->pmu[mo_contact_pair_of(D->C, a)];
}

static int grow(mo_contact_driver *D, int nc, mo_ctx *ctx)
{
  int cap = D->cap, d = D->d;
  void *p;
  if (nc <= cap) return MO_OK;
  cap = (int)mo_contact_room(D->C, (size_t)nc); /* the contact set's capacity (T252) */
#define GROW(ptr, n) if (!(p = mo_realloc(ctx, ptr, (size_t)(n) * sizeof *(ptr)))) return MO_ENOMEM; ptr = p
  GROW(D->bn, cap); GROW(D->U, (size_t)cap * d);
  if (!D->pmu || D->q) { /* the granular path forms q in U (T240) */
    GROW(D->q, (size_t)cap * d);
  }
  GROW(D->Uprev, (size_t)cap * d); GROW(D->r, (size_t)cap * d);
  if (!D->pmu || D->mu) {
    GROW(D->mu, cap);
  }
  if (D->C->act_of == D->active) D->C->act_of = NULL; /* moved: the detection's next cut reads none (T341) */
  GROW(D->active, cap); GROW(D->act, cap + 1);
  GROW(D->status, cap); GROW(D->itmp, (size_t)cap + 1);
  if (!D->dmap) {
    GROW(D->key, (size_t)cap * MO_KEY);
  }
  /* the reactions of the previous step for Newton's iterates (nonlinear scenes), the gaps of the
     step's start (the compact records keep theirs through the solve), W r (the Delassus path) */
  if (D->S && mo_stepper_nonlinear(D->S)) {
    GROW(D->rprev, (size_t)cap * d);
  }
  if (!mo_contact_is_compact(D->C)) { /* the compact records' measures are all 1: P->w NULL */
    GROW(D->gk, cap);
    GROW(D->w, cap);
    /* the remap's scratch and the position correction's (T95); the compact records' remap is in
       place (fit) */
    GROW(D->tmp, (size_t)cap * d * 2 + cap + 1);
  }
#undef GROW
  D->cap = cap;
  return MO_OK;
}

/* W r of the last solve on W: room for the set (allocated when a step first uses W). */
static int ukin_room(mo_contact_driver *D, mo_ctx *ctx)
{
  void *p;
  if (D->ukin && D->ukcap >= D->cap) return MO_OK;
  if (!(p = mo_realloc(ctx, D->ukin, ((size_t)D->cap * D->d + 1) * sizeof *D->ukin))) return MO_ENOMEM;
  D->ukin = p;
  D->ukcap = D->cap;
  return MO_OK;
}

/* U- = H^T v + U0 of candidate range [a0, a1) at state s (the relative velocity at the start of
   the step where the contact is now). */
static void fresh_uprev(mo_contact_driver *D, const mo_state *s, int a0, int a1)
{
  if (a1 > a0) mo_contact_Htx(D->C, s, s->v, a0, a1, mo_contact_U0(D->C), D->Uprev);
  if (a1 == D->nc || a1 == mo_contact_ncandidates(D->C)) { /* the detected ones are of s now */
    D->up_step = s->step;
    D->up_v = s->v;
  }
}

/* U- of candidates [a0, a1) (a1: the set's end) after the geometry at state s: over MPI ranks the
   detection's, each formed by the rank that found the candidate and gathered with the set (T300:
   fresh_uprev's sums), the others (the static part, or a detection not split) here. */
static void detected_uprev(mo_contact_driver *D, const mo_state *s, int a0, int a1)
{
  const int d = D->d;
  int p0 = a1;
  const double *up = mo_contact_detect_uprev(D->C, s, &p0);
  if (!up || p0 < a0) p0 = a1;
  fresh_uprev(D, s, a0, p0);
  if (p0 < a1) {
    memcpy(D->Uprev + (size_t)p0 * d, up + (size_t)p0 * d, (size_t)(a1 - p0) * d * sizeof *up);
    D->up_step = s->step; /* the detected ones are of s now */
    D->up_v = s->v;
  }
}

/* Fit the arrays to the contact set of the last geometry at state s. The old set is described
   by okey (nold keys; NULL: the detection's remap from set oset, T222) and its r, U, status (the
   driver's own arrays, or a snapshot's). */
static int fit(mo_contact_driver *D, const mo_state *s, long oset, const int *okey, int nold, const double *orr,
               const double *oU, const int *ost, mo_ctx *ctx)
{
  const mo_contact *C = D->C;
  int nc = mo_contact_ncandidates(C), d = D->d, a, i, st, ns = mo_contact_nstatic(C);
  int *map, *prev = NULL, own = orr && orr == D->r, mono = 1, last = -1;
  const int *dmap = NULL;
  double *spare = NULL;
  const double *ostd = NULL; /* the old statuses, when copied aside */
  if ((st = grow(D, nc > nold ? nc : nold, ctx))) return st;
  if (own) { /* grow may have moved the driver's own arrays (their contents kept) */
    if (okey) okey = D->key;
    orr = D->r;
    oU = D->U;
    ost = D->status;
  }
  /* the last remap went from the set of the last completed step to the old one (a step taken
     again after a restore): this one is composed with it (doc/theory.md (T185)), from a copy */
  if (oset >= 0 && oset != D->anchor && D->map_from == D->anchor && D->map_to == oset) {
    if (!(prev = mo_malloc(ctx, ((size_t)nold + 1) * sizeof *prev))) return MO_ENOMEM;
    memcpy(prev, D->itmp, (size_t)nold * sizeof *prev);
  }
  /* each new candidate's place in the old set (-1: new), in increasing order so far: the
     detection keeps its order from set to set; written by the detection itself (T222), or
     found by the old keys */
  if (!okey && nold && !(dmap = mo_contact_detect_map(C, oset, mo_contact_set_version(C)))) {
    mo_free(prev);
    return mo_error(ctx, MO_EINTERNAL, "contact driver: no remap from set %ld to set %ld (T222)", oset,
                    mo_contact_set_version(C));
  }
  if (okey && (st = mo_keymap_build(&D->kmap, okey, nold, ctx))) {
    mo_free(prev);
    return st;
  }
  map = D->itmp;
  for (a = 0; a < nc; a++) {
    int o = map[a] = dmap ? dmap[a] : okey ? mo_keymap_find(&D->kmap, mo_contact_key(C, a)) : -1;
    if (o >= 0 && o <= last) mono = 0;
    if (o >= 0) last = o;
  }
  if (own && nold && (D->tmp || !mono)) {
    /* the old values aside, the arrays about to be rewritten: in the scratch of the general path,
       or for a map out of order in a copy of the moment */
    double *nr = D->tmp;
    if (!nr && !(nr = spare = mo_malloc(ctx, ((size_t)nold * (2 * (size_t)d + 1) + 1) * sizeof *nr))) {
      mo_free(prev);
      return MO_ENOMEM;
    }
    memcpy(nr, orr, (size_t)nold * d * sizeof *nr);
    memcpy(nr + (size_t)nold * d, oU, (size_t)nold * d * sizeof *nr);
    for (a = 0; a < nold; a++) nr[(size_t)nold * 2 * d + a] = ost[a]; /* statuses (0, 1, 2) exactly */
    orr = nr;
    oU = nr + (size_t)nold * d;
    ostd = nr + (size_t)nold * 2 * d;
    own = 0;
  }
  detected_uprev(D, s, ns, nc);
  if (own) {
    /* in place (an increasing map): the candidates that move down first, from the front, then
       those that move up, from the back, so that each reads its old values before they are
       overwritten; then the new ones */
    for (a = 0; a < nc; a++)
      if (map[a] > a) {
        memcpy(D->r + (size_t)a * d, D->r + (size_t)map[a] * d, (size_t)d * sizeof *D->r);
        memcpy(D->U + (size_t)a * d, D->U + (size_t)map[a] * d, (size_t)d * sizeof *D->U);
        D->status[a] = D->status[map[a]];
      }
    for (a = nc - 1; a >= 0; a--)
      if (map[a] >= 0 && map[a] < a) {
        memcpy(D->r + (size_t)a * d, D->r + (size_t)map[a] * d, (size_t)d * sizeof *D->r);
        memcpy(D->U + (size_t)a * d, D->U + (size_t)map[a] * d, (size_t)d * sizeof *D->U);
        D->status[a] = D->status[map[a]];
      }
    for (a = 0; a < nc; a++)
      if (map[a] < 0) {
        for (i = 0; i < d; i++) {
          D->r[a * d + i] = 0;
          D->U[a * d + i] = D->Uprev[a * d + i];
        }
        D->status[a] = MO_CS_OPEN;
      }
  } else
    for (a = 0; a < nc; a++) {
      int o = map[a];
      for (i = 0; i < d; i++) {
        D->r[a * d + i] = o >= 0 ? orr[o * d + i] : 0;
        D->U[a * d + i] = o >= 0 ? oU[o * d + i] : D->Uprev[a * d + i];
      }
      D->status[a] = o < 0 ? MO_CS_OPEN : ostd ? (int)ostd[o] : ost[o];
    }
  mo_free(spare);
  for (a = 0; a < nc && (D->mu || D->w); a++) {
    mo_candidate cb;
    const mo_candidate *c = mo_contact_cand_get(C, a, &cb);
    if (D->mu) D->mu[a] = c->mu;
    if (D->w) D->w[a] = c->w;
  }
  /* the key list after the remap: okey may be D->key itself, read above */
  if (nc && D->key) memcpy(D->key, mo_contact_key(C, 0), (size_t)nc * MO_KEY * sizeof *D->key);
  D->nc = nc;
  if (nc > D->nc_max) D->nc_max = nc;
  D->m = nc * d;
  if (D->initialised && D->cset != mo_contact_set_version(C)) {
    /* the back end derived its state from the old set: set it up again at the next solve */
    if (D->T->reinit) D->reinit = 1;
    else {
      if (D->T->free) D->T->free(D->state);
      memset(D->state, 0, D->T->state_size ? D->T->state_size : 1);
      D->initialised = 0;
    }
  }
  D->cset = mo_contact_set_version(C);
  D->map_from = oset;
  D->map_to = D->cset;
  if (prev) {
    for (a = 0; a < nc; a++) map[a] = map[a] >= 0 ? prev[map[a]] : -1;
    D->map_from = D->anchor;
    mo_free(prev);
  }
  return MO_OK;
}

/* After a geometry: follow the candidate set when it changed, and refresh U- of the candidates
   under Newton's law (their contact point moved with the bodies). */
static int follow_set(mo_contact_driver *D, const mo_state *s, mo_ctx *ctx)
{
  const mo_contact *C = D->C;
  int a, ns = mo_contact_nstatic(C);
  if (D->cset != mo_contact_set_version(C))
    return fit(D, s, D->cset, D->key, D->nc, D->r, D->U, D->status, ctx); /* D->key NULL: T222 */
  /* the same set: U- of the rigid candidates at the new contact points */
  for (a = 0; a < ns; a++)
    if (law_of(C, a) != MO_LAW_SIGNORINI) fresh_uprev(D, s, a, a + 1);
  detected_uprev(D, s, ns, D->nc);
  return MO_OK;
}

/* --- snapshots for step cutting ------------------------------------------------------------
   What a step changes in the driver and needs back to be taken again: the candidate set's keys,
   the reactions (warm start, and the index set's "carried a compressive impulse"), the previous
   local velocities, the statuses; the geometry is recomputed from the restored state. */
struct mo_contact_snapshot {
  int nc, cap;
  long cset;                 /* the set its keys are of */
  double *r, *Uprev, *U;
  int *status, *key;
};

int mo_contact_snapshot_create(const mo_contact_driver *D, mo_contact_snapshot **out, mo_ctx *ctx)
{
  mo_contact_snapshot *X = mo_calloc(ctx, 1, sizeof *X);
  *out = NULL;
  if (!X) return MO_ENOMEM;
  (void)D;
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
  mo_free(X->key);
  mo_free(X);
}

int mo_contact_snapshot_save(const mo_contact_driver *D, mo_contact_snapshot *X, mo_ctx *ctx)
{
  size_t m = (size_t)D->m * sizeof(double);
  if (D->nc > X->cap || !X->r) { /* made at the first save, even of an empty set (memcpy's pointers) */
    int cap = D->nc + 16;
    void *p;
#define GROW(ptr, n) if (!(p = mo_realloc(ctx, ptr, (size_t)(n) * sizeof *(ptr)))) return MO_ENOMEM; ptr = p
    GROW(X->r, (size_t)cap * D->d); GROW(X->Uprev, (size_t)cap * D->d); GROW(X->U, (size_t)cap * D->d);
    GROW(X->status, cap); GROW(X->key, (size_t)cap * MO_KEY);
#undef GROW
    X->cap = cap;
  }
  X->nc = D->nc;
  X->cset = D->cset;
  memcpy(X->r, D->r, m);
  memcpy(X->Uprev, D->Uprev, m);
  memcpy(X->U, D->U, m);
  memcpy(X->status, D->status, (size_t)D->nc * sizeof(int));
  /* the driver's keys, or those of the set, of the same set when the driver keeps none (T222) */
  if (!D->key && D->cset != mo_contact_set_version(D->C))
    return mo_error(ctx, MO_EINTERNAL, "contact snapshot: the set moved on from the driver's (T222)");
  if (D->nc)
    memcpy(X->key, D->key ? D->key : mo_contact_key(D->C, 0), (size_t)D->nc * MO_KEY * sizeof(int));
  return MO_OK;
}

int mo_contact_snapshot_restore(mo_contact_driver *D, const mo_contact_snapshot *X, const mo_state *s,
                                mo_ctx *ctx)
{
  int st;
  if ((st = mo_contact_geometry(D->C, s, s->t, D->C->repair, ctx))) return st;
  if ((st = fit(D, s, X->cset, X->key, X->nc, X->r, X->U, X->status, ctx))) return st;
  /* the mesh candidates take their saved U- (the static part is the same set) */
  memcpy(D->Uprev, X->Uprev, (size_t)mo_contact_nstatic(D->C) * D->d * sizeof(double));
  follow_set(D, s, ctx);
  return MO_OK;
}

const double *mo_contact_reactions(const mo_contact_driver *D) { return D->r; }
const double *mo_contact_local_velocity(const mo_contact_driver *D) { return D->U; }
const double *mo_contact_driver_uprev(const mo_contact_driver *D, const mo_state *s)
{
  return D->cset == mo_contact_set_version(D->C) && D->nc == mo_contact_ncandidates(D->C) && D->up_step == s->step &&
                 D->up_v == s->v
             ? D->Uprev
             : NULL;
}
const double *mo_contact_pair_forces(const mo_contact_driver *D) { return D->pforce; }
double mo_contact_normal_force(const mo_contact_driver *D) { return D->fn_step; }
const int *mo_contact_statuses(const mo_contact_driver *D) { return D->status; }
const mo_contact_solver_type *mo_contact_driver_type(const mo_contact_driver *D) { return D->T; }
const mo_delassus *mo_contact_driver_delassus(const mo_contact_driver *D) { return D->wused ? D->W : NULL; }
void mo_contact_driver_keep_delassus(mo_contact_driver *D) { D->wkeep = 1; }

/* 1 when the back end may work without W this step: it can (MO_NEEDS_BODIES) and every candidate
   joins rigid bodies and obstacles only (no row of H in the nodal block). */
static int bodies_only(const mo_contact_driver *D, const mo_what_inverse *Wi)
{
  const mo_csc *H = D->C->H;
  int p;
  if (!(D->T->needs & MO_NEEDS_BODIES) || D->wkeep || D->C->delassus_always) return 0;
  if (mo_contact_is_compact(D->C)) return 1; /* rigid shapes and obstacles only, by construction */
  for (p = 0; p < H->p[H->ncol]; p++)
    if (H->i[p] < Wi->nfe) return 0;
  return 1;
}
long mo_contact_driver_failures(const mo_contact_driver *D) { return D->failures; }

size_t mo_contact_driver_bytes(const mo_contact_driver *D, size_t *per_dof)
{
  const size_t d = (size_t)D->d, cap = (size_t)D->cap, sd = sizeof(double);
  size_t c = cap * ((D->q ? 4 : 3) * d * sd + (D->mu ? 2 : 1) * sd + 1 + 4 * sizeof(int) + (D->key ? MO_KEY : 0) * sizeof(int));
  size_t n = (size_t)D->sc->ndof, nf = (size_t)D->sc->nfree, dof = (2 * n + 2 * nf) * sd;
  if (D->rprev) c += cap * d * sd;
  if (D->pmu) c += (size_t)D->C->npair * sd;
  if (D->gk) c += cap * sd;
  if (D->w) c += cap * sd;
  if (D->tmp) c += (cap * (2 * d + 1) + 1) * sd;
  if (D->ukin) c += (size_t)D->ukcap * d * sd;
  if (D->kmap.tab) c += ((size_t)D->kmap.mask + 1) * sizeof(int);
  if (D->gvel) dof += (size_t)D->sc->nbody * sizeof(int);
  if (D->gcentre) dof += (size_t)D->sc->nbody * (size_t)D->sc->dim * sd;
  if (per_dof) *per_dof = dof;
  return c + dof;
}
const int *mo_contact_driver_remap(const mo_contact_driver *D, long from, long to)
{
  return D->map_from >= 0 && D->map_from == from && D->map_to == to ? D->itmp : NULL;
}

long mo_contact_driver_index_added(const mo_contact_driver *D) { return D->index_added; }
long mo_contact_driver_bearing_all(const mo_contact_driver *D) { return D->bearing_all; }

int mo_contact_driver_candidates_max(const mo_contact_driver *D)
{
  if (D->grains.dist) return (int)D->nc_all_max; /* every rank's, summed at the end of each step */
  return D->nc_max > D->nc ? D->nc_max : D->nc;
}

int mo_contact_driver_redundancy(const mo_contact_driver *D, int *constraints, int *redundant, int *redundant_max,
                                 int *redundant_steps, double *rcond, double *rcond_min, int *min_norm)
{
  if (constraints) *constraints = D->constraints_last;
  if (redundant) *redundant = D->redundant_last;
  if (redundant_max) *redundant_max = D->redundant_max;
  if (redundant_steps) *redundant_steps = D->redundant_steps;
  if (rcond) *rcond = D->rcond_last;
  if (rcond_min) *rcond_min = D->rcond_min;
  if (min_norm) *min_norm = D->min_norm_last;
  return D->constraints_last >= 0;
}

double mo_contact_driver_equilibrium(const mo_contact_driver *D) { return D->eqf ? D->max_eq_residual : NAN; }

void mo_contact_driver_correction(const mo_contact_driver *D, int *on, long *steps, double *max_removed,
                                  double *max_left, long *sweeps_max, long *unconverged, double *energy_paid,
                                  double *energy_added, double *momentum)
{
  int i;
  for (i = 0; momentum && i < 3 * D->sc->nbody; i++) momentum[i] = D->pc_momentum ? D->pc_momentum[i] : 0;
  *energy_paid = D->pc_energy_paid;
  *energy_added = D->pc_energy_added;
  *on = D->C->signorini == MO_SIGNORINI_VELOCITY && D->sc->time.scheme == MO_SCHEME_THETA ? D->C->poscorr : 0;
  *steps = D->pc_steps;
  *max_removed = D->pc_max;
  *max_left = D->pc_left;
  *sweeps_max = D->pc_sweeps_max;
  *unconverged = D->pc_unconverged;
}

void mo_contact_driver_factor_totals(const mo_contact_driver *D, long *factorizations, long *reuses)
{
  if (factorizations) *factorizations = D->factorizations;
  if (reuses) *reuses = D->factor_reuses;
}

long mo_contact_driver_sweeps(const mo_contact_driver *D)
{
  return D->sweeps;
}

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
  mo_free(D->bn); mo_free(D->q); mo_free(D->U); mo_free(D->Uprev); mo_free(D->r); mo_free(D->rprev);
  mo_free(D->eqf); mo_free(D->eqk);
  if (!D->free_alias) {
    mo_free(D->xf);
    mo_free(D->dx);
  }
  mo_free(D->xfull); mo_free(D->dxfull); mo_free(D->mu); mo_free(D->pmu); mo_free(D->gk);
  mo_free(D->pforce);
  mo_free(D->sv_idx); mo_free(D->sv_mu); mo_free(D->sv_q); mo_free(D->sv_r); mo_free(D->sv_U);
  mo_free(D->w); mo_free(D->ukin); mo_free(D->xnl); mo_free(D->gnl); mo_free(D->tmp); mo_free(D->itmp);
  mo_free(D->pcwork); mo_free(D->pc_momentum);
  mo_free(D->gvel); mo_free(D->gcentre);
  mo_keymap_free(&D->kmap);
  if (D->C && D->C->act_of == D->active) D->C->act_of = NULL; /* the driver goes before its set */
  mo_free(D->active);
  mo_free(D->act);
  mo_free(D->status);
  mo_free(D->key);
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
  if (D) {
    D->constraints_last = D->redundant_last = -1;
    D->rcond_last = D->rcond_min = NAN;
  }
  if (!D) return MO_ENOMEM;
  D->sc = sc;
  D->C = C;
  D->S = S;
  D->T = mo_contact_solver_lookup(C->solver, ctx);
  if (!D->T) {
    char list[256];
    int len = 0;
    const config_setting_t *s = config_lookup(&cs->cfg, "contact.solver");
    for (k = 0; k < mo_contact_solver_total(ctx) && len < 200; k++)
      len += snprintf(list + len, sizeof list - (size_t)len, "%s%s", k ? ", " : "", mo_contact_solver_nth(k, ctx)->name);
    if (!len) snprintf(list, sizeof list, "none in this build");
    st = mo_case_error(cs, s ? s : config_lookup(&cs->cfg, "contact"), ctx,
                       "unknown contact back end '%s' (registered: %s%s%s)", C->solver, list,
                       mo_plugin_failures(ctx)[0] ? "; plug-ins refused: " : "", mo_plugin_failures(ctx));
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
  D->d = C->dim;
  D->dmap = mo_contact_writes_map(C, ctx); /* no keys of its own then (T222) */
  D->params = mo_calloc(ctx, 1, D->T->params_size ? D->T->params_size : 1);
  D->state = mo_calloc(ctx, 1, D->T->state_size ? D->T->state_size : 1);
  D->pforce = mo_calloc(ctx, 3 * (size_t)C->npair + 1, sizeof(double));
  D->xfull = mo_calloc(ctx, (size_t)n + 1, sizeof(double));
  D->dxfull = mo_calloc(ctx, (size_t)n + 1, sizeof(double));
  /* (T236): with every dof free (rigid bodies between obstacles) the free numbering is the full
     one, and x_free and the correction need no arrays of their own: 48 bytes a 2D grain */
  D->free_alias = mo_scene_all_free_rigid(sc);
  D->xf = D->free_alias ? D->xfull : mo_calloc(ctx, (size_t)nf + 1, sizeof(double));
  D->dx = D->free_alias ? D->dxfull : mo_calloc(ctx, (size_t)nf + 1, sizeof(double));
  if (sc->time.scheme == MO_SCHEME_QUASISTATIC && !sc->nonlinear && sc->nfe_free) {
    D->eqf = mo_calloc(ctx, (size_t)n + 1, sizeof(double));
    D->eqk = mo_calloc(ctx, (size_t)n + 1, sizeof(double));
    if (!D->eqf || !D->eqk) {
      mo_contact_driver_free(D);
      return MO_ENOMEM;
    }
  }
  /* the Newton iterates of nonlinear scenes (S is NULL for `moreau check`) */
  if (S && mo_stepper_nonlinear(S)) {
    D->xnl = mo_calloc(ctx, (size_t)n + 1, sizeof(double));
    D->gnl = mo_calloc(ctx, (size_t)n + 1, sizeof(double));
  }
  if (!D->params || !D->state || !D->pforce || !D->xfull || !D->dxfull || !D->xf || !D->dx ||
      (S && mo_stepper_nonlinear(S) && (!D->xnl || !D->gnl))) {
    mo_contact_driver_free(D);
    return MO_ENOMEM;
  }
  if (D->T->defaults) D->T->defaults(D->params);
  if ((st = apply_case_options(D->T, D->params, cs, ctx))) {
    mo_contact_driver_free(D);
    return st;
  }
  if (mo_contact_is_compact(C)) {
    /* the granular path: each body's first free dof (-1: a plane, or a body held fixed) */
    int b;
    /* where the free numbering is the full one on the rigid bodies (every dof free), these are the
       detection's first dofs of the rigid bodies (its bdof, -1 elsewhere): read there, not copied
       (4 bytes a grain, T261) */
    int same = C->bdof != NULL;
    for (b = 0; b < sc->nbody && same; b++) {
      const mo_body *B = &sc->body[b];
      same = C->bdof[b] == ((B->type->flags & MO_BODY_F_RIGID) && B->ndof ? sc->free_of[B->dof0] : -1);
    }
    if (same)
      D->grains.vel = C->bdof;
    else {
      D->gvel = mo_malloc(ctx, ((size_t)sc->nbody + 1) * sizeof *D->gvel);
      if (!D->gvel) {
        mo_contact_driver_free(D);
        return MO_ENOMEM;
      }
      for (b = 0; b < sc->nbody; b++) {
        const mo_body *B = &sc->body[b];
        D->gvel[b] = (B->type->flags & MO_BODY_F_RIGID) && B->ndof ? sc->free_of[B->dof0] : -1;
      }
      D->grains.vel = D->gvel;
    }
    D->grains.D = sc->dim;
    D->grains.key = NULL; /* the set's, at each solve */
    if (D->T->needs & MO_NEEDS_GRAINS) { /* the back end reads the pairs' friction coefficients (T189) */
      if (!(D->pmu = mo_malloc(ctx, ((size_t)C->npair + 1) * sizeof *D->pmu))) {
        mo_contact_driver_free(D);
        return MO_ENOMEM;
      }
      for (k = 0; k < C->npair; k++) D->pmu[k] = C->pair[k].mu;
      D->grains.pmu = D->pmu;
    }
  }
  if ((D->T->needs & MO_NEEDS_DELASSUS) && (st = mo_delassus_create(&D->W, ctx))) {
    mo_contact_driver_free(D);
    return st;
  }
  for (k = 0; k < C->npair; k++) D->qb |= C->pair[k].law == MO_LAW_SIGNORINI; /* (none on the granular path) */
  for (k = 0; k < C->npair; k++)
    if (C->pair[k].law == MO_LAW_NEWTON && C->pair[k].e > 0 && sc->time.scheme != MO_SCHEME_THETA) {
      mo_note_skip(ctx, "restitution (the %s scheme is displacement-based: it has no velocity impact law, e is "
                   "not applied)", sc->time.scheme == MO_SCHEME_NEWMARK ? "newmark" : "quasistatic");
      break;
    }
  /* the arrays of the set at t = 0, U- = H^T v0 + U0 */
  {
    mo_state s0;
    memset(&s0, 0, sizeof s0);
    s0.u = sc->u0;
    s0.v = sc->v0;
    D->cset = mo_contact_set_version(C);
    if ((st = grow(D, C->nc + 1, ctx)) || (st = fit(D, &s0, -1, NULL, 0, NULL, NULL, NULL, ctx))) {
      mo_contact_driver_free(D);
      return st;
    }
    fresh_uprev(D, &s0, 0, D->nc);
    D->anchor = D->cset;
    /* U before the first step is U- (the outputs of t = 0 show it; fit took the mesh points' from
       Uprev before it was computed) */
    memcpy(D->U, D->Uprev, (size_t)D->nc * D->d * sizeof *D->U);
  }
  *out = D;
  return MO_OK;
}

/* "candidate 12 (pair 'p', node 13)" or, for a detected contact, its bodies. */
static int describe(const mo_contact_driver *D, int a, char *buf, size_t n)
{
  mo_candidate cb;
  mo_cpoint pb;
  const mo_candidate *c = mo_contact_cand_get(D->C, a, &cb);
  const mo_cpoint *p = mo_contact_cand_point(D->C, a, &pb);
  const mo_contact_pair *P = mo_contact_pair_get(D->C, c->pair);
  if (P->dynamic)
    return snprintf(buf, n, "%d (pair '%s', '%s' on '%s')", a, P->name, D->sc->body[p->sb].name, D->sc->body[p->mb].name);
  return snprintf(buf, n, "%d (pair '%s', %s %d)", a, P->name, c->node >= 0 ? "node" : "Gauss point of facet",
                  c->node >= 0 ? c->node : p->facet);
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
    const double *Waa = D->wused ? mo_delassus_block(D->W, a, a) : NULL;
    int i;
    if (!D->active[a]) continue;
    if (Waa && Waa[0] > 0) w = Waa[0];
    for (i = 0; i < d; i++) Us[i] = D->U[a * d + i] / w;
    e = mo_fc_natural_map_unit(d, mu_of(D, a), D->r + a * d, Us);
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
    char who[200];
    int w;
    describe(D, best[k], who, sizeof who);
    w = snprintf(buf + len, n - len, "%s%s", k ? ", " : "", who);
    if (w < 0 || (size_t)w >= n - len) break;
    len += (size_t)w;
  }
  if (!len) snprintf(buf, n, "none active");
}

/* Candidate a's law on q_a (qa: d values, b_a on entry): the offset its law adds to the normal
   component (the index set's prediction reads b_n = bn), and whether it is in the index set. */
/* Inlined in its loops over the candidates, which read h = mo_stepper_dt once (T291). */
static inline __attribute__((always_inline)) int law_offset(const mo_contact_driver *D, int a, const double *g,
                                                            const double *rstep, double bn, double dtpos, double h,
                                                            double *qa)
{
  const mo_contact *C = D->C;
  const int d = D->d;
  const mo_scheme scheme = D->sc->time.scheme;
  const double theta = D->sc->time.theta;
  int act = C->active[a];
  if (scheme == MO_SCHEME_THETA && law_of(C, a) == MO_LAW_NEWTON) {
    /* Moreau's impact law (T71): U_n+ + e U_n- >= 0 _|_ r_n >= 0 on the contacts closed at the
       predicted position g + h (1 - theta) U_n- (doc/theory.md (T71), Jean/LMGC90 practice) */
    if (g[a] + h * (1 - theta) * D->Uprev[a * d] > C->gtol) act = 0;
    qa[0] += C->pair[mo_contact_pair_of(C, a)].e * D->Uprev[a * d];
  } else if (scheme == MO_SCHEME_THETA && (law_of(C, a) == MO_LAW_GAP || C->signorini == MO_SIGNORINI_POSITION))
    /* g_k+1 = g_k + h (theta U+ + (1 - theta) U-) >= 0  (J88 (3.2)_1 with theta) */
    qa[0] += (g[a] + h * (1 - theta) * D->Uprev[a * d]) / dtpos;
  else if (scheme == MO_SCHEME_THETA) {
    /* velocity level on the index set: the candidates predicted closed (the end-of-step gap
       of (T2) if no contact impulse acted this step, g_k + h (theta U_free + (1 - theta) U-))
       and those that carried a compressive impulse in the previous step (doc/theory.md §5):
       a theta = 1 landing step leaves the gap it started with, and the contact must stay
       in the set until the back end releases it (r = 0), not drop out on that gap */
    if (g[a] + h * (theta * bn + (1 - theta) * D->Uprev[a * d]) > 0 && !(rstep[a * d] > 0))
      act = 0;
  } else
    qa[0] += g[a];
  return act;
}

/* The granular path's q (T240): formed in U, which the back end reads as b before it writes its
   solution there; bn keeps q_n - b_n as rounded (contact_finish's U without the offsets), and qn2
   |q|^2 over the index set in the core's order (the residual's scale). A step with no candidate in
   the index set has no solve, and U keeps the values the step started with: q_a is formed aside,
   for bn. The index set does not read b here: a granular candidate's law is Moreau's or the gap's
   (rigid shapes only), whose prediction reads g and U- alone. */
static int granular_q(mo_contact_driver *D, const mo_state *s, const double *x, double u0h, const double *rstep,
                      double dtpos, int *any_out, mo_ctx *ctx)
{
  mo_contact *C = D->C;
  const double *U0 = mo_contact_U0(C), *g = mo_contact_gaps(C), h = mo_stepper_dt(D->S);
  int d = D->d, nc = D->nc, a, i, any = 0, st;
  D->nact = 0;
  D->qn2 = 0;
  for (a = 0; a < nc && !any; a++) {
    double qa[3] = {0, 0, 0};
    any = law_offset(D, a, g, rstep, 0, dtpos, h, qa);
  }
  if (D->grains.dist) {
    /* the distributed set: a solve when some rank's candidate is in its index set; a rank with none
       takes part in it with its q formed (its candidates' U at the end read it) */
    double g1 = any;
    if ((st = mo_par_max(&g1, 1, ctx))) return st;
    any = g1 > 0;
  }
  *any_out = any;
  if (!any) {
    for (a = 0; a < nc; a++) {
      double qa[3], bn;
      mo_contact_Htx1(C, s, x, a, NULL, qa);
      if (U0)
        for (i = 0; i < d; i++) qa[i] += U0[a * d + i] * u0h;
      bn = qa[0];
      D->active[a] = (unsigned char)law_offset(D, a, g, rstep, bn, dtpos, h, qa);
      D->bn[a] = qa[0] - bn;
    }
    return MO_OK;
  }
  mo_contact_Htx(C, s, x, 0, nc, NULL, D->U);
  if (U0)
    for (i = 0; i < D->m; i++) D->U[i] += U0[i] * u0h;
  for (a = 0; a < nc; a++) {
    double *qa = D->U + (size_t)a * d, bn = qa[0];
    int act = law_offset(D, a, g, rstep, bn, dtpos, h, qa);
    D->bn[a] = qa[0] - bn;
    D->active[a] = (unsigned char)act;
    if (act) {
      D->act[D->nact++] = a;
      for (i = 0; i < d; i++) D->qn2 += qa[i] * qa[i];
    }
  }
  return MO_OK;
}

/* Steps 3-4 (doc/theory.md §5, §12.4): the local free kinematics b from the unconstrained
   iterate, then q = b with the offset of each candidate's law, and the index set. rstep: the
   reactions of the previous step. Returns the scale c of W (du = c dx). */
static double local_problem(mo_contact_driver *D, const mo_state *s, const double *rstep, int *any_out, int *st_out,
                            mo_ctx *ctx)
{
  const mo_scene *sc = D->sc;
  mo_contact *C = D->C;
  const double *U0 = mo_contact_U0(C);
  int d = D->d, m = D->m, nc = D->nc, n = sc->ndof, a, i, any = 0;
  double h = mo_stepper_dt(D->S), theta = sc->time.theta, c, dtpos, u0h;
  const double *g = mo_contact_gaps(C), *x;
  mo_scheme scheme = sc->time.scheme;
  *st_out = MO_OK;
  if (D->gk) memcpy(D->gk, g, (size_t)nc * sizeof(double));
  if (scheme == MO_SCHEME_THETA) {
    x = D->xfull;
    u0h = 1; /* (U0 times 1 is U0 to the bit) */
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
    x = du;
    u0h = h;
    dtpos = 1;
  }
  if (D->qu) {
    *st_out = granular_q(D, s, x, u0h, rstep, dtpos, any_out, ctx);
    C->act_of = D->active; /* the points of the split detection's next boxes (T341) */
    C->act_set = mo_contact_set_version(C);
    return c;
  }
  mo_contact_Htx(C, s, x, 0, nc, NULL, D->q);
  if (U0) /* (q is never -0 here: adding U0 = 0 would not change a bit) */
    for (i = 0; i < m; i++) D->q[i] += U0[i] * u0h;
  /* q = b, then the laws' offsets on the normal components: b's normal ones kept aside */
  for (a = 0; a < nc; a++) D->bn[a] = D->q[a * d];
  D->nact = 0;
  for (a = 0; a < nc; a++) {
    int act = law_offset(D, a, g, rstep, D->bn[a], dtpos, h, D->q + (size_t)a * d);
    D->active[a] = (unsigned char)act;
    if (act) D->act[D->nact++] = a;
    any |= act;
  }
  *any_out = any;
  return c;
}

/* Keep the problem the solve just solved (--dump-fclib, doc/theory.md (T80)): its index set
   and, on it, q, mu, r and U = W r + q. W itself stays in D->W until the next solve. */
static int keep_solved(mo_contact_driver *D, int newton, mo_ctx *ctx)
{
  int d = D->d, k, i;
  D->sv_valid = 0;
  if (!D->wused || !D->nact) return MO_OK;
  if (D->nact > D->sv_cap) {
    int cap = D->nact + 16;
    void *p;
#define GROW(ptr, n) if (!(p = mo_realloc(ctx, ptr, (size_t)(n) * sizeof *(ptr)))) return MO_ENOMEM; ptr = p
    GROW(D->sv_idx, cap); GROW(D->sv_mu, cap);
    GROW(D->sv_q, (size_t)cap * d); GROW(D->sv_r, (size_t)cap * d); GROW(D->sv_U, (size_t)cap * d);
#undef GROW
    D->sv_cap = cap;
  }
  for (k = 0; k < D->nact; k++) {
    int a = D->act[k];
    D->sv_idx[k] = a;
    D->sv_mu[k] = mu_of(D, a);
    for (i = 0; i < d; i++) {
      D->sv_q[k * d + i] = D->q[a * d + i];
      D->sv_r[k * d + i] = D->r[a * d + i];
      D->sv_U[k * d + i] = D->U[a * d + i];
    }
  }
  D->sv_nlaw[0] = D->sv_nlaw[1] = D->sv_nlaw[2] = 0;
  for (k = 0; k < D->nact; k++) D->sv_nlaw[law_of(D->C, D->act[k])]++;
  D->sv_n = D->nact;
  D->sv_ncand = D->nc;
  D->sv_newton = newton;
  D->sv_reason = D->rep.reason;
  D->sv_residual = D->rep.residual;
  D->sv_valid = 1;
  return MO_OK;
}

/* The equilibrium of the global problem after a quasi-static linear step (doc/theory.md (T82)):
   e = f(t+) + H r - K u over the free nodal dofs, relative to the forces in play (the loads,
   the contact forces, the support reactions: max_i |f_i| + |(H r)_i| over every nodal dof and
   |(K u)_i| over the prescribed ones). The back ends check only their local problem U = W r + q;
   this is what says whether u and r solve K u = f + H r, which a singular or badly factored K
   (a body held only by contact) does not. A step whose e exceeds MO_EQUILIBRIUM_TOL fails with
   the dof that carries the largest imbalance. */
#define MO_EQUILIBRIUM_TOL 1e-8
static int equilibrium_check(mo_contact_driver *D, const mo_state *s, mo_ctx *ctx)
{
  const mo_scene *sc = D->sc;
  int n = sc->nfe_dof, i, worst = -1, b;
  double h = mo_stepper_dt(D->S), emax = 0, scale = 0;
  mo_scene_fext(sc, s->t + h, D->eqf);
  mo_csc_gaxpy(D->C->Hfull, 1, D->r, 1, D->eqf);
  mo_scene_gaxpy(sc, sc->K, 1, D->xfull, 0, D->eqk);
  for (i = 0; i < n; i++) {
    double f = fabs(D->eqf[i]);
    if (sc->free_of[i] < 0) {
      if (fabs(D->eqk[i]) > scale) scale = fabs(D->eqk[i]);
      continue;
    }
    if (f > scale) scale = f;
    if (fabs(D->eqf[i] - D->eqk[i]) > emax) {
      emax = fabs(D->eqf[i] - D->eqk[i]);
      worst = i;
    }
  }
  D->eq_residual = scale > 0 ? emax / scale : emax;
  if (D->eq_residual > D->max_eq_residual) D->max_eq_residual = D->eq_residual;
  mo_log(ctx, 3, "step %ld: global equilibrium |f + H r - K u| / forces = %.3e\n", s->step + 1, D->eq_residual);
  if (!(D->eq_residual <= MO_EQUILIBRIUM_TOL)) {
    char where[160] = "";
    for (b = 0; b < sc->nbody && worst >= 0; b++) {
      const mo_body *B = &sc->body[b];
      if (B->kind == MO_BODY_DEFORMABLE && worst >= B->dof0 && worst < B->dof0 + B->ndof) {
        snprintf(where, sizeof where, " at body '%s', node %d, component %c", B->name, (worst - B->dof0) / sc->dim,
                 "xyz"[(worst - B->dof0) % sc->dim]);
        break;
      }
    }
    return mo_error(ctx, MO_ENOCONV,
                    "step %ld (t = %.6g): the %s solution is not in equilibrium: |f + H r - K u| = %.3e of the "
                    "forces in play%s (tolerance %.0e; the contact residual was %.3e, reason %s). The local problem "
                    "was solved, the global one was not: the stiffness factor is not accurate for this scene "
                    "(a body held only by contact, or a nearly singular K; doc/theory.md (T82))",
                    (long)s->step + 1, s->t + h, D->T->name, D->eq_residual, where, MO_EQUILIBRIUM_TOL,
                    D->rep.residual, mo_contact_reason_name(D->rep.reason));
  }
  return MO_OK;
}

/* Step 7 of a split step (doc/theory.md (T153)): x = What^-1 (rhs + H r) by the trailing forward
   solve of H r and one backward solve, into D->xfull; a back end that wrote dx itself (the KKT
   path) has x_free completed by the backward solve, then dx added. */
static int split_correction(mo_contact_driver *D, const mo_state *s, mo_ctx *ctx)
{
  const mo_scene *sc = D->sc;
  int i, st;
  if (D->x.dx_set) {
    if ((st = mo_stepper_complete_split(D->S, D->xfull, ctx))) return st;
    for (i = 0; i < sc->nfree; i++) D->xfull[sc->full_of[i]] += D->dx[i];
  } else {
    mo_csc_gaxpy(D->C->Hfull, 1, D->r, 0, D->dxfull);
    if ((st = mo_stepper_correct_split(D->S, D->dxfull, D->xfull, ctx))) return st;
  }
  return D->eqf ? equilibrium_check(D, s, ctx) : MO_OK;
}

/* Whether the step splits (T153): the factorization holds the contact dofs last and every row
   of H is among them, and the back end works on W (not on the bodies' blocks, which read x_free
   in full). */
static int split_step(const mo_contact_driver *D)
{
  return D->W && !bodies_only(D, mo_stepper_inverse(D->S)) && mo_stepper_split_covers(D->S, D->C->H);
}

/* The statuses after a solve: open outside the index set; their counts in the report. */
static void count_statuses(mo_contact_driver *D, mo_contact_report *rep)
{
  int a;
  for (a = 0; a < D->nc; a++) {
    if (!D->active[a]) D->status[a] = MO_CS_OPEN;
    rep->nopen += D->status[a] == MO_CS_OPEN;
    rep->nstick += D->status[a] == MO_CS_STICK;
    rep->nslide += D->status[a] == MO_CS_SLIDE;
  }
}

/* A non-finite reaction of this rank's candidates, or (elsewhere) of another rank's, fails the
   step: no NaN leaves the back end. */
static int check_finite(const mo_contact_driver *D, int elsewhere, long step, double t, mo_ctx *ctx)
{
  char who[200] = "on another rank";
  int i;
  for (i = 0; i < D->m; i++)
    if (!isfinite(D->r[i])) {
      describe(D, i / D->d, who, sizeof who);
      break;
    }
  if (i == D->m && !elsewhere) return MO_OK;
  return mo_error(ctx, MO_ENAN, "step %ld (t = %.6g): contact back end %s returned a non-finite reaction at "
                  "candidate %s", step, t, D->T->name, who);
}

/* Steps 2-7 of a step (doc/theory.md §5): from the unconstrained iterate D->xfull (full; D->xf
   its free part) and the gaps at the start of the step, the local problem, the back end's
   solve, the core's measure, and the correction dx (free dofs) added to D->xfull. rstep: the
   reactions of the previous step (the velocity-level index set). newton: the Newton iterate of a
   nonlinear step (-1 for a linear one), for diagnoses. *any: some candidate was active. */
#define MO_INDEX_ROUNDS 4 /* solves added to a step for candidates its index set missed */
static int contact_solve(mo_contact_driver *D, const mo_state *s, const double *rstep, int newton,
                         int *any_out, mo_ctx *ctx)
{
  const mo_scene *sc = D->sc;
  mo_contact *C = D->C;
  mo_stepper *S = D->S;
  mo_contact_problem *P = &D->P;
  mo_contact_report *rep = &D->rep;
  const mo_what_inverse *Wi = mo_stepper_inverse(S);
  int d = D->d, m = D->m, nc = D->nc, n = sc->ndof, st, a, i, any = 0, rebuilt = 0, rounds = 0, grains;
  double h = mo_stepper_dt(S), t0, c;
  mo_scheme scheme = sc->time.scheme;

  D->wused = D->W && !bodies_only(D, Wi);
  if (D->W && !D->wused)
    mo_note_skip(ctx, "the Delassus operator (every contact joins rigid bodies: back end %s sweeps on their velocities)",
                 D->T->name);
  /* the compact records go to a back end that reads them; any other use builds H from them */
  grains = mo_contact_is_compact(C) && (D->T->needs & MO_NEEDS_GRAINS) && !D->wused;
  /* q formed in U on the granular path (T240), in an array of its own elsewhere */
  D->qu = grains && !D->qb && !mo_stepper_nonlinear(S);
  if (!D->qu && !D->q && !(D->q = mo_malloc(ctx, ((size_t)D->cap * d + 1) * sizeof *D->q))) return MO_ENOMEM;
  /* the distributed set (doc/scaling.md §4) on the granular path only */
  D->grains.dist = mo_contact_distributed(C);
  if (!mo_contact_held(C, &D->grains.hold, &D->grains.hlist, &D->grains.nhlist, NULL) ||
      !mo_contact_held_shared(C, &D->grains.sh_off, &D->grains.sh_b)) {
    D->grains.hold = NULL;
    D->grains.hlist = NULL;
    D->grains.nhlist = 0;
    D->grains.sh_off = D->grains.sh_b = NULL;
  }
  if (D->grains.dist && !D->qu)
    return mo_error(ctx, MO_EUNSUPPORTED, "contact.distributed_set needs the granular path (rigid shapes, back end "
                    "nscd, a linear step)");
  c = local_problem(D, s, rstep, &any, &st, ctx);
  if (st) return st;
  *any_out = any;
  if (grains) {
    const int D3 = sc->dim;
    int b, k;
    int q;
    /* the detection's centres of this state (the same sums), current for every body of a dynamic
       pair, which holds every body of a candidate: no copy of them (16 bytes a 2D grain, T261) */
    D->grains.centre = mo_contact_centres(C, s);
    if (!D->grains.centre) { /* over several ranks: a copy of its own */
      if (!D->gcentre && !(D->gcentre = mo_calloc(ctx, (size_t)D3 * sc->nbody + 1, sizeof *D->gcentre)))
        return MO_ENOMEM;
      if (D->grains.hlist) /* the bodies' state per rank: the held bodies' */
        for (k = 0; k < D->grains.nhlist; k++) {
          b = D->grains.hlist[k];
          if (D->grains.vel[b] >= 0)
            for (q = 0; q < D3; q++) D->gcentre[(size_t)D3 * b + q] = sc->body[b].xc0[q] + s->u[sc->body[b].dof0 + q];
        }
      else
        for (b = 0; b < sc->nbody; b++)
          if (D->grains.vel[b] >= 0) /* as mo_rigid_center, D values */
            for (q = 0; q < D3; q++) D->gcentre[(size_t)D3 * b + q] = sc->body[b].xc0[q] + s->u[sc->body[b].dof0 + q];
      D->grains.centre = D->gcentre;
    }
    D->grains.key = C->key;
    D->grains.x = C->x;
    D->grains.n = mo_contact_normals(C); /* the frames' normals alone (T225) */
    D->grains.cown = mo_contact_detect_owners(C); /* the detection's owners: the sweep's parts (T341) */
  } else if ((st = mo_contact_H_ensure(C, s, ctx)))
    return st;
  if (D->wused) {
    if ((st = mo_delassus_update(D->W, C->H, mo_contact_h_version(C), Wi, c, d, &rebuilt, ctx))) return st;
    if (rebuilt) D->wbuilds++;
    else if (D->steps) mo_note_skip(ctx, "Delassus rebuilds (H and What unchanged)");
  }
  /* 5. the back end */
  memset(P, 0, sizeof *P);
  P->dim = d;
  P->nc = nc;
  P->m = m;
  if (!D->mu && !grains) {
    /* the compact records on H after all (W kept for FCLIB dumps, contact.delassus = "always"): the
       coefficients per candidate from now on */
    if (!(D->mu = mo_malloc(ctx, ((size_t)D->cap + 1) * sizeof *D->mu))) return MO_ENOMEM;
    for (a = 0; a < nc; a++) D->mu[a] = D->pmu[mo_contact_pair_of(C, a)];
  }
  P->mu = D->mu;              /* NULL on the granular path: the pairs' (grains.pmu, (T189)) */
  P->g = D->gk ? D->gk : mo_contact_gaps(C);
  P->Uprev = D->Uprev;
  P->frame = mo_contact_frames(C);
  P->contact = C;
  P->W = D->wused ? D->W : NULL;
  P->b = D->qu ? D->U : D->q; /* the granular path: q in U, read before the solution is written (T240) */
  P->active = D->active;
  /* the index set as listed by the forming of q, in increasing order: on the granular path no
     round adds to it (its laws are Moreau's and the gap's), and the back end reads it (T250) */
  P->act = grains ? D->act : NULL;
  P->nact = D->nact;
  P->scheme = scheme;
  P->h = h;
  P->theta = sc->time.theta;
  P->theta_f = sc->time.theta_f;
  P->beta = sc->time.beta;
  P->gamma = sc->time.gamma;
  P->signorini = C->signorini;
  P->nfree = sc->nfree;
  P->H = grains ? NULL : C->H;
  P->grains = grains ? &D->grains : NULL;
  P->What = NULL;
  if ((D->T->needs & MO_NEEDS_GLOBAL) && (st = mo_stepper_matrix_full(S, &P->What, ctx))) return st;
  P->Wi = Wi;
  P->xfree = D->xf;
  P->du_dx = c;
  P->step = s->step + 1;
  P->t = s->t;
  P->w = D->w;
  P->cset = D->cset;
  P->u_measured = D->wused; /* step 6 recomputes U = W r + q */
  memset(rep, 0, sizeof *rep);
  rep->constraints = rep->redundant = -1;
  rep->rcond = NAN;
  D->x.r = D->r;
  D->x.U = D->U;
  D->x.status = D->status;
  D->x.dx = D->dx;
  D->x.dx_set = 0;
  for (a = 0; a < nc; a++)
    if (!D->active[a]) for (i = 0; i < d; i++) D->r[a * d + i] = 0;
  t0 = mo_clock();
  /* (a rank of the distributed set with no candidate takes part in the solves: its back end set up) */
  if (!D->initialised && (nc || D->grains.dist)) {
    if (D->T->init && (st = D->T->init(D->state, D->params, P, ctx))) {
      mo_phase_add(ctx, MO_PH_CONTACT, t0);
      return st;
    }
    D->initialised = 1;
    D->reinit = 0;
  } else if (D->reinit && (nc || D->grains.dist)) {
    if ((st = D->T->reinit(D->state, P, ctx))) {
      mo_phase_add(ctx, MO_PH_CONTACT, t0);
      return st;
    }
    D->reinit = 0;
  }
  /* a velocity-level index set predicted without contact impulse can miss a candidate that
     the impulses of its neighbours push into the obstacle within the step (a bulging contact
     zone): such a candidate joins the set and the step is solved again (doc/theory.md §5) */
resolve:
  D->sv_valid = 0;
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
  D->factorizations += rep->factorizations;
  D->factor_reuses += rep->factor_reuses;
  D->sweeps += rep->sweeps;
  if (D->grains.dist && any) {
    /* the distributed set: the solve's measures over every rank's candidates, in one sum (a
       non-finite reaction anywhere fails every rank) */
    double v[8];
    int bad = 0;
    for (i = 0; i < m && !bad; i++) bad = !isfinite(D->r[i]);
    count_statuses(D, rep);
    mo_fc_natural_map_parts(d, D->nact, D->act, D->mu, D->C->key, D->pmu, NULL, D->r, D->U, v);
    v[3] = D->qn2;
    v[4] = bad;
    v[5] = rep->nopen;
    v[6] = rep->nstick;
    v[7] = rep->nslide;
    if ((st = mo_par_sum(v, 8, ctx)) || (st = check_finite(D, v[4] > 0, P->step, s->t + h, ctx))) return st;
    rep->residual = mo_fc_natural_map_join(v, sqrt(v[3]));
    rep->nopen = (int)v[5];
    rep->nstick = (int)v[6];
    rep->nslide = (int)v[7];
    goto measured;
  }
  if ((st = check_finite(D, 0, P->step, s->t + h, ctx))) return st;
  /* 6. the core's measure: U' = W r + q when W is known, else the back end's U; W r is kept
     for contact_finish */
  if (D->wused) {
    if ((st = ukin_room(D, ctx))) return st;
    mo_delassus_mult(D->W, D->r, 0, D->ukin);
    for (i = 0; i < m; i++) D->U[i] = D->ukin[i] + D->q[i];
  }
  if (any && scheme == MO_SCHEME_THETA && C->signorini == MO_SIGNORINI_VELOCITY && rounds < MO_INDEX_ROUNDS) {
      const double theta = sc->time.theta;
    int added = 0;
    for (a = 0; a < nc; a++)
      if (!D->active[a] && law_of(C, a) == MO_LAW_SIGNORINI &&
          D->gk[a] + h * (theta * D->U[a * d] + (1 - theta) * D->Uprev[a * d]) < -C->gtol) {
        D->active[a] = 1;
        D->act[D->nact++] = a;
        added++;
      }
    if (added) {
      P->act = NULL; /* appended out of order: the back end lists the set itself */
      rounds++;
      D->index_added += added;
      mo_log(ctx, 3, "step %ld: %d candidate%s outside the index set would end inside the obstacle: solved again\n",
             P->step, added, added > 1 ? "s" : "");
      goto resolve;
    }
  }
  {
    /* over the active candidates only (the others are out of the problem this step) */
    double qn = 0;
    int k;
    if (D->qu) /* summed as q was formed, in the same order (no candidate joined the set since) */
      qn = D->qn2;
    else
      for (k = 0; k < D->nact; k++)
        for (i = 0; i < d; i++) qn += D->q[D->act[k] * d + i] * D->q[D->act[k] * d + i];
    rep->residual = mo_fc_natural_map_subset_pairs(d, D->nact, D->act, D->mu, D->C->key, D->pmu, NULL, D->r, D->U,
                                                   sqrt(qn));
  }
  if (D->wkeep && (st = keep_solved(D, newton, ctx))) return st;
  count_statuses(D, rep);
measured:
  if (any) {
    if (newton < 0) { /* a nonlinear step counts its Newton iterations' solves as one */
      D->steps++;
      D->iterations += rep->iterations;
      if (rep->iterations > D->max_iterations) D->max_iterations = rep->iterations;
    }
    if (rep->residual > D->max_residual) D->max_residual = rep->residual;
  }
  if (any && rep->constraints >= 0) {
    /* redundancy (T84): once in the log, every step in summary.json */
    D->constraints_last = rep->constraints;
    D->redundant_last = rep->redundant;
    D->rcond_last = rep->rcond;
    if (!(rep->rcond >= D->rcond_min)) D->rcond_min = rep->rcond; /* NaN at first */
    if (rep->redundant > 0 && !D->redundant_steps++)
      mo_log(ctx, 1, "moreau: step %ld: %d of the %d unknowns of the closed contacts are redundant (rank %s%d): "
             "their reactions are not unique; %s reports %s (doc/theory.md (T84))\n", P->step,
             rep->redundant, rep->constraints, rep->rcond == rep->rcond ? "" : "at most ",
             rep->constraints - rep->redundant, D->T->name,
             rep->min_norm ? "the minimum-norm ones" : "the ones its iteration reached");
    D->min_norm_last = rep->min_norm;
    if (rep->redundant > D->redundant_max) D->redundant_max = rep->redundant;
  }
  if (rep->reason < 0) {
    D->failures++;
    if (!C->on_failure_continue) {
      char worst[700], it[48] = "";
      worst_candidates(D, worst, sizeof worst);
      if (newton >= 0) snprintf(it, sizeof it, ", Newton iterate %d", newton);
      return mo_error(ctx, MO_ENOCONV,
                      "step %ld (t = %.6g%s): the %s contact solve stopped on %s after %d iterations "
                      "(residual %.3e; %d closed of %d candidates)%s%s. Candidates furthest from the "
                      "contact law: %s. %sa smaller time step (time.dt, or time.max_cuts), a larger iteration "
                      "limit (contact.%s options), or contact.on_failure = \"continue\"",
                      P->step, s->t + h, it, D->T->name, mo_contact_reason_name(rep->reason), rep->iterations,
                      rep->residual, nc - rep->nopen, nc, rep->message[0] ? ": " : "", rep->message, worst,
                      /* cycling between rigid bodies: more contacts than the bodies have dofs, the
                         impulses are not unique and no step size changes that */
                      rep->reason == MO_CR_CYCLING && mo_contact_ncandidates(C) > mo_contact_nstatic(C)
                          ? "The statuses cycle: between rigid bodies this is the mark of redundant contacts, whose "
                            "impulses are not unique (doc/theory.md §12.7); nscd solves such scenes. Otherwise: "
                          : "Remedies: ",
                      D->T->name);
    }
  }
  /* 7. correction */
  if (D->split) return split_correction(D, s, ctx);
  if (!D->x.dx_set) {
    if (D->wused) {
      if ((st = mo_delassus_apply_Cinv(D->W, C->H, Wi, D->r, D->dx, ctx))) return st;
    } else {
      double *rhs = D->dxfull;
      if ((st = mo_contact_H_ensure(C, s, ctx))) return st;
      memset(rhs, 0, (size_t)n * sizeof(double));
      mo_csc_gaxpy(C->Hfull, 1, D->r, 0, rhs);
      if ((st = mo_stepper_correct(S, rhs, D->dxfull, ctx))) return st;
      if (!D->free_alias) mo_stepper_gather(S, D->dxfull, D->dx);
    }
  }
  if (D->grains.hold) {
    /* the bodies' state per rank: the held bodies' (every dof free, doc/theory.md §13.18) */
    const int *vel = D->grains.vel, nd = mo_rigid_ndof(sc->dim);
    int k, j;
    for (k = 0; k < D->grains.nhlist; k++) {
      const int o = vel[D->grains.hlist[k]];
      for (j = 0; j < nd && o >= 0; j++) D->xfull[o + j] += D->dx[o + j];
    }
  } else
    for (i = 0; i < sc->nfree; i++) D->xfull[sc->full_of[i]] += D->dx[i];
  if (D->eqf && (st = equilibrium_check(D, s, ctx))) return st;
  return MO_OK;
}

/* The position correction of velocity-level Signorini (doc/theory.md (T94)-(T95)): the end-of-step
   gaps of the Signorini candidates, linear in the step, g_e = g_k + h (theta U+_n + (1 - theta)
   U-_n) (ge, one per candidate), are projected onto g >= 0 in the norm of What: the normal
   "position impulses" p >= 0 solve g_e + W_nn p >= 0 _|_ p >= 0 with the step's Delassus operator
   (projected Gauss-Seidel), and u += What^-1 H p. Velocities are not touched. Called after the
   stepper's finish, before the end-of-step geometry. */
static int position_correction(mo_contact_driver *D, mo_state *s, const double *ge, mo_ctx *ctx)
{
  mo_contact *C = D->C;
  const mo_scene *sc = D->sc;
  int nc = D->nc, d = D->d, a, k, it, st, conv = 0;
  double *p = D->tmp + nc, worst = 0, left = 0;
  const int maxit = 1000;
  if (D->ptol == 0) {
    /* 1e-9 of the smallest element edge: below this a gap is round-off of a resting contact */
    double hmin = HUGE_VAL, hb;
    int b;
    for (b = 0; b < sc->nbody; b++)
      if (sc->body[b].kind == MO_BODY_DEFORMABLE) {
        mo_mesh_edge_range(sc->body[b].mesh, &hb, NULL);
        if (hb < hmin) hmin = hb;
      }
    D->ptol = 1e-9 * (isfinite(hmin) ? hmin : 1);
  }
  for (a = 0; a < nc; a++)
    if (law_of(C, a) == MO_LAW_SIGNORINI && -ge[a] > worst) worst = -ge[a];
  if (worst <= D->ptol) return MO_OK;
  memset(p, 0, (size_t)D->m * sizeof *p);
  for (it = 0; it < maxit && !conv; it++) {
    double change = 0;
    for (a = 0; a < nc; a++) {
      const int *beta;
      const double *blk;
      double y = ge[a], waa = 0, pn;
      int nb;
      if (law_of(C, a) != MO_LAW_SIGNORINI) continue;
      nb = mo_delassus_row(D->W, a, &beta, &blk);
      for (k = 0; k < nb; k++) {
        double wn = blk[(size_t)k * (size_t)(d * d)];
        if (beta[k] == a) waa = wn;
        y += wn * p[beta[k] * d];
      }
      if (!(waa > 0)) continue;
      pn = p[a * d] - y / waa;
      if (pn < 0) pn = 0;
      if (fabs(pn - p[a * d]) * waa > change) change = fabs(pn - p[a * d]) * waa;
      p[a * d] = pn;
    }
    conv = change <= 1e-12 * worst;
  }
  if (!conv) D->pc_unconverged++;
  if (it > D->pc_sweeps_max) D->pc_sweeps_max = it;
  /* what is left: g_e + W_nn p over the Signorini candidates */
  for (a = 0; a < nc; a++) {
    const int *beta;
    const double *blk;
    double y = ge[a];
    int nb;
    if (law_of(C, a) != MO_LAW_SIGNORINI) continue;
    nb = mo_delassus_row(D->W, a, &beta, &blk);
    for (k = 0; k < nb; k++) y += blk[(size_t)k * (size_t)(d * d)] * p[beta[k] * d];
    if (-y > left) left = -y;
  }
  if ((st = mo_delassus_apply_Cinv(D->W, C->H, mo_stepper_inverse(D->S), p, D->dx, ctx))) return st;
  {
    /* (T96): the shift changes the elastic energy and the work of the loads, dE = E_el(u + du) -
       E_el(u) - f . du (the velocities are those of the step). A positive dE is taken from the
       kinetic energy of the bodies the shift moved, v <- lambda v with lambda^2 = 1 - dE / E_kin
       (the velocity-level constraints U+_n >= 0, = 0 against obstacles keep their signs), so that
       the correction never creates energy; what the bodies' kinetic energy cannot pay is counted. */
    int n = sc->ndof, b, i;
    double e0, e1, w0 = s->wext, dE, ek;
    mo_state sm;
    if (!D->pcwork && !(D->pcwork = mo_malloc(ctx, 2 * (size_t)n * sizeof(double) + 1))) return MO_ENOMEM;
    if (!D->pc_momentum && !(D->pc_momentum = mo_calloc(ctx, 3 * (size_t)sc->nbody + 1, sizeof(double))))
      return MO_ENOMEM;
    e0 = mo_energy_elastic(sc, s->u, D->pcwork);
    if ((st = mo_stepper_shift(D->S, s, D->dx, ctx))) return st;
    e1 = mo_energy_elastic(sc, s->u, D->pcwork);
    dE = (e1 - e0) - (s->wext - w0);
    if (dE > 0 && C->poscorr == 1) {
      double *vm = D->pcwork + n;
      memset(vm, 0, (size_t)n * sizeof *vm);
      for (b = 0; b < sc->nbody; b++) {
        const mo_body *B = &sc->body[b];
        int moved = 0;
        if (B->kind != MO_BODY_DEFORMABLE) continue;
        for (i = B->dof0; i < B->dof0 + B->ndof && !moved; i++)
          moved = sc->free_of[i] >= 0 && D->dx[sc->free_of[i]] != 0;
        if (moved)
          for (i = B->dof0; i < B->dof0 + B->ndof; i++)
            if (sc->free_of[i] >= 0) vm[i] = s->v[i];
      }
      sm = *s;
      sm.v = vm;
      ek = mo_energy_kinetic(sc, &sm, D->pcwork);   /* leaves M vm in pcwork (deformable dofs) */
      if (sc->kpart) mo_scene_gaxpy(sc, sc->M, 1, vm, 0, D->pcwork); /* there, this rank's part: the sum */
      if (ek > 0) {
        double lam = dE < ek ? sqrt(1 - dE / ek) : 0;
        for (b = 0; b < sc->nbody; b++) {
          /* the linear momentum the scaling takes, (lambda - 1) 1_i^T M v per direction */
          const mo_body *B = &sc->body[b];
          if (B->kind != MO_BODY_DEFORMABLE) continue;
          for (i = B->dof0; i < B->dof0 + B->ndof; i++) /* M is block diagonal by body */
            D->pc_momentum[3 * b + (i - B->dof0) % sc->dim] += (lam - 1) * D->pcwork[i];
        }
        for (i = 0; i < n; i++)
          if (vm[i] != 0) s->v[i] = lam * vm[i];
        fresh_uprev(D, s, 0, nc); /* U- of the next step from the scaled velocities */
      }
      D->pc_energy_paid += dE < ek ? dE : ek;
      if (dE > ek) D->pc_energy_added += dE - ek;
    } else if (dE > 0)
      D->pc_energy_added += dE; /* "shift": the velocities are left alone */
  }
  D->pc_steps++;
  if (worst > D->pc_max) D->pc_max = worst;
  if (left > D->pc_left) D->pc_left = left;
  return MO_OK;
}

/* The end of a step: the work of the contact impulses, impulse . mean local velocity (theta),
   force . increment (others), the local velocities U- of the next step, then the stepper's
   finish at x, the geometry of the end of the step (the detection of rigid shapes included) and
   the arrays of its candidate set. With W, D->ukin holds W r of the step's last contact_solve
   (r, b and W are those of that solve). */
static int contact_finish(mo_contact_driver *D, mo_state *s, const double *x, mo_ctx *ctx)
{
  int m = D->m, d = D->d, i, st, corr;
  mo_scheme scheme = D->sc->time.scheme;
  double w = 0;
  /* U without the offsets of the laws (Signorini, restitution): W r + b, or the back end's U' - (q - b) */
  const double *Ukin = D->ukin;
  if (!D->wused) {
    /* without W: U+ computed, its work added and (theta) taken as U- at once */
    for (i = 0; i < m; i++) {
      /* the granular path: bn holds q_n - b_n, and q_t - b_t is q_t - q_t, 0 (T240) */
      double uk = D->qu ? (i % d ? D->U[i] : D->U[i] - D->bn[i / d])
                        : D->U[i] - (D->q[i] - (i % d ? D->q[i] : D->bn[i / d]));
      w += D->r[i] * (scheme == MO_SCHEME_THETA ? 0.5 * (uk + D->Uprev[i]) : uk);
      if (scheme == MO_SCHEME_THETA) D->Uprev[i] = uk;
    }
    Ukin = D->Uprev;
  } else {
    for (i = 0; i < m; i++) D->ukin[i] += i % d ? D->q[i] : D->bn[i / d];
    for (i = 0; i < m; i++)
      w += D->r[i] * (scheme == MO_SCHEME_THETA ? 0.5 * (Ukin[i] + D->Uprev[i]) : Ukin[i]);
  }
  /* the end-of-step gaps of the Signorini candidates for the position correction (T94): g_k +
     h (theta U+_n + (1 - theta) U-_n), before U- becomes U+ */
  corr = D->C->poscorr && D->C->signorini == MO_SIGNORINI_VELOCITY && scheme == MO_SCHEME_THETA && D->wused &&
         D->nc && !mo_stepper_nonlinear(D->S) && D->gk; /* (compact records: no Signorini candidate) */
  if (corr) {
    double h = mo_stepper_dt(D->S), th = D->sc->time.theta;
    for (i = 0; i < D->nc; i++)
      D->tmp[i] = D->gk[i] + h * (th * Ukin[i * D->d] + (1 - th) * D->Uprev[i * D->d]);
  }
  if (scheme == MO_SCHEME_THETA && D->wused) memcpy(D->Uprev, Ukin, (size_t)m * sizeof(double));
  {
    /* the step's resultants, before the end-of-step geometry replaces the candidate set: per pair,
       the force the master exerts on the slaves (world frame), and the sum of normal forces */
    const double fs = scheme == MO_SCHEME_THETA ? 1 / mo_stepper_dt(D->S) : 1;
    int a, j, dim = D->sc->dim;
    memset(D->pforce, 0, 3 * (size_t)D->C->npair * sizeof *D->pforce);
    D->fn_step = 0;
    const mo_contact *C = D->C;
    for (a = 0; a < D->nc; a++) {
      /* the candidate's pair from its key or record, its frame formed from its normal on the
         granular path (T225), without a call for each (T291) */
      double *f = D->pforce + 3 * (size_t)mo_contact_pair_of(C, a), Fb[9];
      const double *F = C->compact ? Fb : C->frame + (size_t)a * (size_t)(C->dim * C->dim);
      if (C->compact) mo_frame_of_normal(C->dim, C->frame + (size_t)a * (size_t)C->dim, Fb);
      D->fn_step += D->r[a * d] * fs;
      for (i = 0; i < d; i++)
        for (j = 0; j < dim && d == dim; j++) f[j] += D->r[a * d + i] * fs * F[(size_t)i * d + j];
    }
    if (D->grains.dist && D->C->npair < 64) {
      /* the distributed set: the work and the resultants summed over the ranks' candidates */
      double v[4 + 3 * 64], nb = 0;
      for (a = 0; a < D->nc; a++) nb += D->r[a * d] > 0;
      v[0] = w;
      v[1] = D->fn_step;
      v[2] = D->nc;
      v[3] = nb;
      memcpy(v + 4, D->pforce, 3 * (size_t)D->C->npair * sizeof *v);
      if ((st = mo_par_sum(v, 4 + 3 * (long)D->C->npair, ctx))) return st;
      w = v[0];
      D->fn_step = v[1];
      D->nc_all = (long)v[2];
      if (D->nc_all > D->nc_all_max) D->nc_all_max = D->nc_all;
      D->bearing_all = (long)v[3];
      memcpy(D->pforce, v + 4, 3 * (size_t)D->C->npair * sizeof *v);
    } else if (D->grains.dist)
      return mo_error(ctx, MO_ELIMIT, "contact.distributed_set with %d contact pairs (at most 63)", D->C->npair);
  }
  s->wcontact += w;
  if ((st = mo_stepper_finish(D->S, s, x, ctx))) return st;
  if (corr && (st = position_correction(D, s, D->tmp, ctx))) return st;
  if ((st = mo_contact_geometry(D->C, s, s->t, D->C->repair, ctx))) return st;
  return follow_set(D, s, ctx);
}

static int step_body(mo_contact_driver *D, mo_state *s, mo_ctx *ctx);

int mo_contact_step(mo_contact_driver *D, mo_state *s, mo_ctx *ctx)
{
  int st = step_body(D, s, ctx);
  if (!st) D->anchor = D->cset;
  return st;
}

static int step_body(mo_contact_driver *D, mo_state *s, mo_ctx *ctx)
{
  mo_stepper *S = D->S;
  const mo_scene *sc = D->sc;
  int st, any, k, n = sc->ndof;
  const double *xfree;
  double t0, inner0;

  if (mo_stepper_nonlinear(S)) {
    /* Newton on the smooth part (doc/theory.md §11.2), the contact problem solved on the
       linearized step of every iterate; the reactions of the previous step set the index set
       and the warm start */
    memcpy(D->rprev, D->r, (size_t)D->m * sizeof(double));
    D->split = 0;
    D->any_step = D->it_step = 0;
    memset(D->loops_step, 0, sizeof D->loops_step);
    mo_stepper_guess(S, s, D->xnl);
    if ((st = mo_newton_begin(S, s, D->xnl, D->gnl, ctx))) return st;
    while ((st = mo_newton_iterate(S, s, D->xnl, D->gnl, &xfree, ctx)) == MO_NEWTON_LINEARIZED) {
      int iter = mo_stepper_newton_report(S)->iterations - 1;
      t0 = mo_clock();
      inner0 = mo_phase_total(ctx);
      memcpy(D->xfull, xfree, (size_t)n * sizeof *D->xfull);
      if (!D->free_alias) mo_stepper_gather(S, D->xfull, D->xf);
      st = contact_solve(D, s, D->rprev, iter, &any, ctx);
      mo_phase_rest(ctx, MO_PH_LOCAL, t0, inner0);
      if (st) return st;
      memcpy(D->xnl, D->xfull, (size_t)n * sizeof *D->xnl);
      /* g = What (x - x_free) = H r over free dofs (the KKT path's dv solves What dv = H_C r) */
      mo_csc_gaxpy(D->C->Hfull, 1, D->r, 0, D->gnl);
      for (k = 0; k < sc->npresc; k++) D->gnl[sc->presc[k].dof] = 0;
      D->any_step |= any;
      D->it_step += D->rep.iterations;
      for (k = 0; k < 4; k++) D->loops_step[k] += D->rep.loops[k];
    }
    if (st) return st;
    D->rep.iterations = D->it_step;
    for (k = 0; k < 4; k++) D->rep.loops[k] = D->loops_step[k];
    if (D->any_step) {
      D->steps++;
      D->iterations += D->it_step;
      if (D->it_step > D->max_iterations) D->max_iterations = D->it_step;
    }
    t0 = mo_clock();
    inner0 = mo_phase_total(ctx);
    st = contact_finish(D, s, D->xnl, ctx);
    mo_phase_rest(ctx, MO_PH_LOCAL, t0, inner0);
    return st;
  }
  /* 1. the unconstrained step (bodies), 2-7. the contact problem, its solve and the correction;
     split (T153): the forward solve and the contact dofs first, one backward solve at the end */
  D->split = split_step(D);
  {
    /* the bodies' state per rank (doc/theory.md §13.18): the step of the bodies this rank holds,
       the external work of those it counts; the list is the last build's (the step's end may build
       the list again: it keeps its own until the next step) */
    const int *hl;
    const unsigned char *cnt;
    int nh;
    if (mo_contact_held(D->C, NULL, &hl, &nh, &cnt)) mo_stepper_hold(S, hl, nh, cnt);
    else mo_stepper_hold(S, NULL, 0, NULL);
  }
  if ((st = D->split ? mo_stepper_predict_split(S, s, D->xfull, ctx) : mo_stepper_predict(S, s, D->xfull, ctx)))
    return st;
  t0 = mo_clock();
  inner0 = mo_phase_total(ctx);
  if (!D->free_alias) mo_stepper_gather(S, D->xfull, D->xf);
  st = contact_solve(D, s, D->r, -1, &any, ctx);
  if (!st) st = contact_finish(D, s, D->xfull, ctx);
  mo_phase_rest(ctx, MO_PH_LOCAL, t0, inner0); /* the core's own part of the contact step */
  return st;
}

int mo_contact_driver_local_problem(const mo_contact_driver *D, double **W, double **q, double **mu,
                                    int *nc, int *d, mo_ctx *ctx)
{
  int st, a;
  *W = *q = *mu = NULL;
  if (!D->wused)
    return mo_error(ctx, MO_EUNSUPPORTED, "back end %s did not use the Delassus operator at this step%s", D->T->name,
                    D->W ? " (mo_contact_driver_keep_delassus asks for it)" : "");
  if ((st = mo_delassus_dense(D->W, W, ctx))) return st;
  *q = mo_malloc(ctx, (size_t)D->m * sizeof(double) + 1);
  *mu = mo_malloc(ctx, (size_t)D->nc * sizeof(double) + 1);
  if (!*q || !*mu) {
    mo_free(*W); mo_free(*q); mo_free(*mu);
    return MO_ENOMEM;
  }
  memcpy(*q, D->q, (size_t)D->m * sizeof(double));
  for (a = 0; a < D->nc; a++) (*mu)[a] = mu_of(D, a);
  *nc = D->nc;
  *d = D->d;
  return MO_OK;
}

void mo_solved_problem_release(mo_solved_problem *P)
{
  if (!P) return;
  mo_free(P->idx);
  mo_csc_free(P->W);
  mo_free(P->q);
  mo_free(P->mu);
  mo_free(P->r);
  mo_free(P->U);
  memset(P, 0, sizeof *P);
}

/* "3-5, 9, 12-30" into buf (cut with "..." when it does not fit). */
static void index_ranges(const int *idx, int n, char *buf, size_t len)
{
  size_t at = 0;
  int k = 0;
  buf[0] = '\0';
  while (k < n) {
    int j = k, w;
    while (j + 1 < n && idx[j + 1] == idx[j] + 1) j++;
    if (j > k) w = snprintf(buf + at, len - at, "%s%d-%d", k ? ", " : "", idx[k], idx[j]);
    else w = snprintf(buf + at, len - at, "%s%d", k ? ", " : "", idx[k]);
    if (w < 0 || (size_t)w >= len - at - 4) {
      snprintf(buf + (at < len - 5 ? at : len - 5), 5, "...");
      return;
    }
    at += (size_t)w;
    k = j + 1;
  }
}

int mo_contact_driver_solved_problem(const mo_contact_driver *D, mo_solved_problem *P, mo_ctx *ctx)
{
  int d = D->d, n = D->sv_n, k, i, j, st, *pos = NULL;
  mo_triplet T;
  const mo_contact_problem *Pb = &D->P;
  char law[600], cands[400];
  memset(P, 0, sizeof *P);
  memset(&T, 0, sizeof T);
  if (!D->sv_valid)
    return mo_error(ctx, MO_EUNSUPPORTED, "no solved contact problem to export (%s)",
                    !D->wkeep ? "mo_contact_driver_keep_delassus was not called"
                              : "the last solve had no candidate in its index set, or no Delassus operator");
  P->d = d;
  P->n = n;
  P->ncand = D->sv_ncand;
  P->residual = D->sv_residual;
  P->reason = D->sv_reason;
  P->idx = mo_malloc(ctx, (size_t)n * sizeof *P->idx + 1);
  P->q = mo_malloc(ctx, (size_t)n * d * sizeof *P->q + 1);
  P->mu = mo_malloc(ctx, (size_t)n * sizeof *P->mu + 1);
  P->r = mo_malloc(ctx, (size_t)n * d * sizeof *P->r + 1);
  P->U = mo_malloc(ctx, (size_t)n * d * sizeof *P->U + 1);
  pos = mo_malloc(ctx, (size_t)D->sv_ncand * sizeof *pos + 1);
  if (!P->idx || !P->q || !P->mu || !P->r || !P->U || !pos) { st = MO_ENOMEM; goto done; }
  memcpy(P->idx, D->sv_idx, (size_t)n * sizeof *P->idx);
  memcpy(P->mu, D->sv_mu, (size_t)n * sizeof *P->mu);
  memcpy(P->q, D->sv_q, (size_t)n * d * sizeof *P->q);
  memcpy(P->r, D->sv_r, (size_t)n * d * sizeof *P->r);
  memcpy(P->U, D->sv_U, (size_t)n * d * sizeof *P->U);
  /* W_AA: the blocks of the solve's W between candidates of its index set */
  for (k = 0; k < D->sv_ncand; k++) pos[k] = -1;
  for (k = 0; k < n; k++) pos[D->sv_idx[k]] = k;
  if ((st = mo_triplet_init(&T, n * d, n * d, (size_t)n * d * d * 4 + 1, ctx))) goto done;
  for (k = 0; k < n; k++) {
    const int *beta;
    const double *blk;
    int nb = mo_delassus_row(D->W, D->sv_idx[k], &beta, &blk), b;
    for (b = 0; b < nb; b++) {
      int l = pos[beta[b]];
      if (l < 0) continue;
      for (i = 0; i < d; i++)
        for (j = 0; j < d; j++)
          if (blk[(size_t)b * d * d + (size_t)(i * d + j)] != 0 &&
              (st = mo_triplet_add(&T, k * d + i, l * d + j, blk[(size_t)b * d * d + (size_t)(i * d + j)], ctx)))
            goto done;
    }
  }
  if ((st = mo_triplet_to_csc(&T, 0, &P->W, ctx))) goto done;
  /* what it is, in words */
  if (Pb->scheme == MO_SCHEME_THETA)
    snprintf(law, sizeof law,
             "theta-scheme (h = %.6g, theta = %g): r are impulses over the step, U the local velocities; the normal "
             "part of q holds the offset of each candidate's law: %d Signorini at the %s level%s, %d Moreau's "
             "impact law (e U-_n, T71), %d gap law ((g + h (1 - theta) U-_n) / (h theta))",
             Pb->h, Pb->theta, D->sv_nlaw[MO_LAW_SIGNORINI],
             D->C->signorini == MO_SIGNORINI_VELOCITY ? "velocity" : "position",
             D->C->signorini == MO_SIGNORINI_VELOCITY ? " (U+_n >= 0, no offset)" : " ((g + h (1 - theta) U-_n) / (h theta))",
             D->sv_nlaw[MO_LAW_NEWTON], D->sv_nlaw[MO_LAW_GAP]);
  else
    snprintf(law, sizeof law,
             "%s step: r are forces, U the increments of the local displacements over the step (W scaled by %g); "
             "the normal part of q holds the gap, so that U_n is the end-of-step gap",
             Pb->scheme == MO_SCHEME_NEWMARK ? "Newmark" : "quasi-static", Pb->du_dx);
  index_ranges(P->idx, n, cands, sizeof cands);
  snprintf(P->desc, sizeof P->desc,
           "The contact problem moreau solved at step %ld (t = %.9g%s): U = W r + q over the %d candidates of "
           "the step's index set, of %d (0-based candidates %s); the others were out of the problem (r = 0, "
           "unconstrained) and are left out (doc/theory.md (T80)). %s. Back end %s: %s, natural-map residual "
           "%.3e (T10); the solution (r, U = W r + q) is the one the step applied.",
           Pb->step, Pb->t + Pb->h, D->sv_newton >= 0 ? ", last Newton iterate" : "", n, D->sv_ncand, cands, law,
           D->T->name, mo_contact_reason_name(D->sv_reason), D->sv_residual);
done:
  mo_triplet_release(&T);
  mo_free(pos);
  if (st) mo_solved_problem_release(P);
  return st;
}
