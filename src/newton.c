/* newton.c: Newton on the momentum balance of a nonlinear step (doc/theory.md §11.2, (T60)-(T64)),
   driven by its caller so that the contact layer's constraint solve sits inside every iteration
   without a callback; and the step without contact. It calls down into the stepper (step.c) and
   the element kernels (tangent.c), which never call it. */
#include "config.h"
#include <moreau/material.h>
#include "step_internal.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

int mo_stepper_nonlinear(const mo_stepper *S) { return S->nl; }
const mo_newton_report *mo_stepper_newton_report(const mo_stepper *S) { return &S->rep; }

/* The displacement at t+ of the iterate x: (T2), Newmark's u+, or x itself; prescribed dofs on
   their path. */
static void kinematics(const mo_stepper *S, const mo_state *s, const double *x, int path, double *u)
{
  const mo_scene *sc = S->sc;
  int n = sc->ndof, i, k;
  double h = S->h, th = S->theta, b = S->beta;
  switch (S->scheme) {
  case MO_SCHEME_THETA:
    for (i = 0; i < n; i++) u[i] = s->u[i] + h * (th * x[i] + (1 - th) * s->v[i]);
    break;
  case MO_SCHEME_NEWMARK:
    for (i = 0; i < n; i++) u[i] = s->u[i] + h * s->v[i] + h * h * ((0.5 - b) * s->a[i] + b * x[i]);
    break;
  case MO_SCHEME_QUASISTATIC:
    memcpy(u, x, (size_t)n * sizeof *u);
    break;
  }
  for (k = 0; path && k < sc->npresc; k++) {
    double pu, pv;
    mo_scene_presc_eval(sc, k, s->t + h, &pu, &pv);
    u[sc->presc[k].dof] = pu;
  }
}

void mo_stepper_guess(mo_stepper *S, const mo_state *s, double *x)
{
  const mo_scene *sc = S->sc;
  int n = sc->ndof;
  int i;
  /* constant velocity: u+ = u + h v, the kinematics of a free flight (theta: v+ = v; Newmark:
     the a+ that cancels the h^2 terms, not a+ = a, which extrapolates an impact's acceleration
     over the next step; quasi-static: u+ = u) */
  switch (S->scheme) {
  case MO_SCHEME_THETA: memcpy(x, s->v, (size_t)n * sizeof *x); break;
  case MO_SCHEME_NEWMARK:
    for (i = 0; i < n; i++) x[i] = -(0.5 - S->beta) / S->beta * s->a[i];
    break;
  case MO_SCHEME_QUASISTATIC: memcpy(x, s->u, (size_t)n * sizeof *x); break;
  }
}

static double norm_free(const mo_scene *sc, const double *v)
{
  double s = 0;
  int i;
  for (i = 0; i < sc->nfree; i++) s += v[sc->full_of[i]] * v[sc->full_of[i]];
  return sqrt(s);
}

/* The terms' scale is taken over every dof: a body held by its supports balances its internal
   forces there (a quasi-static column), and the free rows alone would make the scale the
   residual itself. */
static double norm_all(int n, const double *v)
{
  double s = 0;
  int i;
  for (i = 0; i < n; i++) s += v[i] * v[i];
  return sqrt(s);
}

/* The relative residuals of the step so far, "r0, r1, ..." (at most the last 12). */
static void history(const mo_newton_report *R, char *buf, size_t n)
{
  size_t len = 0;
  int k, k0 = R->nres > 12 ? R->nres - 12 : 0;
  buf[0] = '\0';
  for (k = k0; k < R->nres; k++) {
    int w = snprintf(buf + len, n - len, "%s%.2e", k > k0 ? ", " : k0 ? "..., " : "", R->res[k]);
    if (w < 0 || (size_t)w >= n - len) break;
    len += (size_t)w;
  }
}

/* Consecutive halvings of an update whose end is not admissible (inverted elements) or not
   definite (the tangent), before the step fails. */
#define MAX_HALVINGS 8

/* Halve the last update: x and its constraint term back toward the last linearization point;
   the prescribed dofs stay at their values of t+ (the first linearization point has them at
   the prediction's). */
static void halve(mo_stepper *S, double *x, double *g, double tn)
{
  int i, n = S->sc->ndof;
  for (i = 0; i < n; i++) {
    x[i] = S->xk[i] + 0.5 * (x[i] - S->xk[i]);
    g[i] = S->gk[i] + 0.5 * (g[i] - S->gk[i]);
  }
  mo_stepper_presc_unknown(S, tn, x);
}

/* An iterate that cannot be linearized (inverted elements, or a tangent not definite): its
   error cleared, the update halved toward the last linearization point, counted as one of the
   MAX_HALVINGS in a row and as a damped iterate. */
static void retreat(mo_stepper *S, double *x, double *g, double tn, mo_ctx *ctx)
{
  mo_ctx_clear_error(ctx);
  halve(S, x, g, tn);
  S->ndamp = 1;
  S->nhalf++;
  S->rep.damped++;
}

int mo_newton_begin(mo_stepper *S, const mo_state *s, double *x, double *g, mo_ctx *ctx)
{
  const mo_scene *sc = S->sc;
  int n = sc->ndof, i, st;
  double tn = s->t + S->h;
  if (!S->nl) return mo_error(ctx, MO_EINTERNAL, "mo_newton_begin: the scene is linear");
  if (S->blk_varies && (st = mo_stepper_rigid_update(S, s, ctx))) return st;
  mo_scene_fext(sc, tn, S->w1);
  /* the prescribed dofs: x holds their continuation (the guess); dxp their increment to t+,
     which the first linearization carries into the free rows through the tangent's coupling
     (a Dirichlet predictor: iterate 0 is the start configuration moving on, never a
     configuration with the supports already displaced and the rest not) */
  memcpy(S->xk, x, (size_t)n * sizeof *x);
  mo_stepper_presc_unknown(S, tn, S->xk);
  memset(S->dxp, 0, (size_t)n * sizeof *S->dxp);
  S->any_dxp = 0;
  for (i = 0; i < sc->npresc; i++) {
    int d = sc->presc[i].dof;
    S->dxp[d] = S->xk[d] - x[d];
    S->any_dxp |= S->dxp[d] != 0;
  }
  memset(g, 0, (size_t)n * sizeof *g);
  S->rep.iterations = S->rep.nres = 0;
  S->nit = S->nhalf = S->ninv = S->ndamp = 0;
  S->prev = HUGE_VAL;
  S->inverted[0] = '\0';
  return MO_OK;
}

/* The residual of the balance at iterate x with constraint term g: cm M (x - xm) + cf [theta_f
   (f_int - f_ext+) + (1 - theta_f) (f_int0 - f_ext)] - cf g_rigid - g (T60)-(T62), its norm over
   the free dofs and its scale (T64), recorded in the report. S->w2 receives R - g. */
static void residual(mo_stepper *S, const mo_state *s, const double *x, const double *g, double *res,
                     double *scale)
{
  const mo_scene *sc = S->sc;
  mo_newton_report *rep = &S->rep;
  int n = sc->ndof, i;
  double tf = S->scheme == MO_SCHEME_THETA ? S->theta_f : 1, cf = S->scheme == MO_SCHEME_THETA ? S->h : 1;
  double *fext = S->w1, *u = S->w2, *mx = S->w3, *R = S->R, a1 = 0, a2, a3, r;
  if (S->cm != 0) {
    if (S->scheme == MO_SCHEME_THETA)
      for (i = 0; i < n; i++) R[i] = x[i] - s->v[i];
    else
      memcpy(R, x, (size_t)n * sizeof *R);
    mo_stepper_mass_apply(S, R, mx);
    a1 = norm_all(n, mx);
  } else
    memset(mx, 0, (size_t)n * sizeof *mx);
  for (i = 0; i < n; i++) u[i] = cf * (tf * S->fint[i] + (1 - tf) * S->fint0[i]);
  a2 = norm_all(n, u);
  for (i = 0; i < n; i++) R[i] = u[i] + mx[i];
  /* the loads and the rigid bodies' explicit gyroscopic forces */
  for (i = 0; i < n; i++) u[i] = cf * (tf * fext[i] + (1 - tf) * s->f[i] + (S->gyro ? S->gyro[i] : 0));
  a3 = norm_all(n, u);
  for (i = 0; i < n; i++) {
    R[i] -= u[i];
    u[i] = R[i] - g[i];
  }
  *res = norm_free(sc, u);
  *scale = fmax(fmax(a1, a2), fmax(a3, norm_all(n, g)));
  rep->scale = *scale;
  r = *scale > 0 ? *res / *scale : *res;
  if (rep->nres < MO_NEWTON_HISTORY) rep->res[rep->nres++] = r;
  else {
    memmove(rep->res, rep->res + 1, (MO_NEWTON_HISTORY - 1) * sizeof *rep->res);
    rep->res[MO_NEWTON_HISTORY - 1] = r;
  }
}

/* (T63): factor What_k at the iterate, x_free = x_k - What_k^-1 R(x_k) into S->xfr. Returns
   MO_ESINGULAR (message cleared) when the tangent is not definite, for the caller to halve. */
static int linearize(mo_stepper *S, const mo_state *s, const double *x, int it, mo_ctx *ctx)
{
  const mo_scene *sc = S->sc;
  int n = sc->ndof, i, st;
  double t0 = mo_clock(), *u = S->w2, *R = S->R;
  st = mo_linsolver_factor(S->ls, S->W, ctx);
  mo_phase_add(ctx, MO_PH_FACTOR, t0);
  if (st) return st;
  t0 = mo_clock();
  if (it == 0 && S->any_dxp) {
    /* R + What_fp dx_p: cm M dx_p, ck K dx_p of the linear bodies, the elements' part */
    if (S->cm != 0) mo_stepper_mass_apply(S, S->dxp, S->w3);
    for (i = 0; i < n; i++) u[i] = S->cfp[i] + (S->cm != 0 ? S->cm * S->w3[i] : 0) + R[i];
    mo_csc_gaxpy(sc->K, S->ck, S->dxp, 1, u);
    mo_stepper_gather(S, u, S->rhs);
  } else
    mo_stepper_gather(S, R, S->rhs);
  st = mo_stepper_what_solve(S, 1, S->rhs, S->xf, ctx);
  mo_phase_add(ctx, MO_PH_SOLVE, t0);
  if (st) return st;
  memcpy(S->xfr, x, (size_t)n * sizeof *x);
  for (i = 0; i < sc->nfree; i++) S->xfr[sc->full_of[i]] -= S->xf[i];
  if (it == 0) mo_stepper_presc_unknown(S, s->t + S->h, S->xfr);
  return MO_OK;
}

int mo_newton_iterate(mo_stepper *S, const mo_state *s, double *x, double *g, const double **xfree,
                      mo_ctx *ctx)
{
  const mo_scene *sc = S->sc;
  mo_newton_report *rep = &S->rep;
  int n = sc->ndof, st;
  double tn = s->t + S->h, tol = sc->time.newton_tol;
  char hist[400];
  *xfree = NULL;
  for (;; S->nit++) {
    int it = S->nit;
    double res, scale;
    kinematics(S, s, x, it > 0, S->w2);
    if (it == 0 && S->any_dxp) memset(S->cfp, 0, (size_t)n * sizeof *S->cfp);
    st = mo_tangent_forces(S, S->w2, s->q, S->fint, 1, it == 0 && S->any_dxp ? S->dxp : NULL, S->cfp, ctx);
    if (st == MO_ENAN && it > 0 && S->nhalf < MAX_HALVINGS) {
      /* an iterate that inverts elements: back toward the last linearization point */
      snprintf(S->inverted, sizeof S->inverted, "%s", ctx->errmsg);
      S->ninv++;
      retreat(S, x, g, tn, ctx);
      continue;
    }
    if (st == MO_ENAN) {
      char msg[MO_ERRMSG_MAX];
      snprintf(msg, sizeof msg, "%s", ctx->errmsg);
      mo_ctx_clear_error(ctx);
      history(rep, hist, sizeof hist);
      return mo_error(ctx, MO_ENOCONV, "step %ld (t = %.6g): Newton iterate %d is not admissible%s: %s. "
                      "Relative residuals of the step: %s. The step deforms the mesh beyond what its "
                      "elements can follow: a smaller time step (time.dt), a finer mesh where elements "
                      "are crushed, or a slower loading", s->step + 1, tn, it,
                      S->nhalf ? " (nor its update halved 8 times)" : "", msg, hist[0] ? hist : "none yet");
    }
    if (st) return mo_error_prefix(ctx, "step %ld (t = %.6g), Newton iterate %d", s->step + 1, tn, it);
    residual(S, s, x, g, &res, &scale);
    if (!isfinite(res)) {
      history(rep, hist, sizeof hist);
      return mo_error(ctx, MO_ENOCONV, "step %ld (t = %.6g): Newton iterate %d has a non-finite residual "
                      "(relative residuals: %s)", s->step + 1, tn, it, hist);
    }
    /* (T64): at least one linearization, so that the constraint layer sees every step; a
       damped iterate is only a new linearization point, its contact term is not a solution */
    if (it > 0 && !S->ndamp && res <= tol * scale) {
      rep->steps++;
      rep->total += rep->iterations;
      if (rep->iterations > rep->max) rep->max = rep->iterations;
      return MO_OK;
    }
    if (it >= 2 && !S->ndamp && !(res < S->prev)) {
      /* no decrease: a point of the material or a contact switching between two states from
         one linearization to the next (a 2-cycle); halve the update (T63) */
      halve(S, x, g, tn);
      S->ndamp = 1;
      rep->damped++;
      continue;
    }
    S->ndamp = 0;
    S->nhalf = 0;
    S->prev = res;
    if (it >= sc->time.newton_max) {
      char why[600] = "";
      history(rep, hist, sizeof hist);
      if (S->ninv) snprintf(why, sizeof why, "; %d iterates were not admissible, the last: %.400s", S->ninv, S->inverted);
      return mo_error(ctx, MO_ENOCONV, "step %ld (t = %.6g): Newton did not converge in %d iterations "
                      "(time.newton.max_iter = %d, %d updates halved): relative residuals %s, tolerance %g "
                      "(time.newton.tol)%s. Remedies: a smaller time step (time.dt, or time.max_cuts), more numerical damping "
                      "(time.theta above 1/2), more iterations, or a looser tolerance",
                      s->step + 1, tn, rep->iterations, sc->time.newton_max, it - rep->iterations, hist, tol, why);
    }
    st = linearize(S, s, x, it, ctx);
    if (st == MO_ESINGULAR && it > 0 && S->nhalf < MAX_HALVINGS) {
      /* the tangent is not definite here (crushed elements whose compressive geometric
         stiffness outweighs their mass): back toward the last linearization point */
      retreat(S, x, g, tn, ctx);
      continue;
    }
    if (st == MO_ESINGULAR) {
      mo_ctx_clear_error(ctx);
      history(rep, hist, sizeof hist);
      return mo_error(ctx, MO_ESINGULAR, "step %ld (t = %.6g), Newton iterate %d: the tangent iteration "
                      "matrix %s is not positive definite%s: the tangent stiffness of crushed elements "
                      "outweighs their mass. Relative residuals of the step: %s. Remedies: a smaller time "
                      "step (time.dt), more numerical damping, a finer mesh where elements are crushed",
                      s->step + 1, tn, it, S->cm != 0 ? "M + c K_t" : "K_t",
                      S->nhalf ? " (nor after halving the update 8 times)" : "", hist);
    }
    if (st)
      return mo_error_prefix(ctx, "step %ld (t = %.6g), Newton iterate %d: the tangent iteration matrix",
                             s->step + 1, tn, it);
    memcpy(S->xk, x, (size_t)n * sizeof *x);
    memcpy(S->gk, g, (size_t)n * sizeof *g);
    rep->iterations++;
    S->nit++;
    *xfree = S->xfr;
    return MO_NEWTON_LINEARIZED;
  }
}

int mo_stepper_solve(mo_stepper *S, const mo_state *s, double *x, mo_ctx *ctx)
{
  int n = S->sc->ndof, st;
  const double *xfree;
  if ((st = mo_newton_begin(S, s, x, S->g, ctx))) return st;
  while ((st = mo_newton_iterate(S, s, x, S->g, &xfree, ctx)) == MO_NEWTON_LINEARIZED) {
    memcpy(x, xfree, (size_t)n * sizeof *x);
    memset(S->g, 0, (size_t)n * sizeof *S->g);
  }
  return st;
}

/* One step without contact: predict and finish (linear scenes), Newton and finish (nonlinear). */
int mo_stepper_step(mo_stepper *S, mo_state *s, mo_ctx *ctx)
{
  double *x;
  int st;
  if (!S->w3 && !(S->w3 = mo_calloc(ctx, (size_t)S->sc->ndof + 1, sizeof(double)))) return MO_ENOMEM;
  x = S->w3;
  if (S->nl) {
    x = S->xs; /* w1..w3 are Newton's work */
    mo_stepper_guess(S, s, x);
    if ((st = mo_stepper_solve(S, s, x, ctx))) return st;
    return mo_stepper_finish(S, s, x, ctx);
  }
  st = mo_stepper_predict(S, s, x, ctx);
  if (st) return st;
  return mo_stepper_finish(S, s, x, ctx);
}
