/* finite.c: no NaN or infinity leaves a run (issue 19, doc/theory.md §10.3): the check of a
   state and of a history row, and the diagnosis that names the quantity, the step and the case
   key most likely behind it. */
#include "config.h"
#include <moreau/body.h>
#include <moreau/case.h>
#include <moreau/expr.h>
#include "case_internal.h"
#include "metrics.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* An input this far from 1 (or its inverse) is what the diagnosis blames first (T104): a
   double holds 1e308, so a force of 1e150 squared (an energy) or integrated over 1e150 steps
   already overflows. */
#define MO_FINITE_EXTREME 1e100

/* The body (index) owning full dof d, or -1. */
static int dof_body(const mo_scene *sc, int d)
{
  int b;
  for (b = 0; b < sc->nbody; b++)
    if (d >= sc->body[b].dof0 && d < sc->body[b].dof0 + sc->body[b].ndof) return b;
  return -1;
}

/* The case-file name of body b's entry (a group's name for its bodies). */
static const char *entry_name(const mo_scene *sc, int b)
{
  const mo_body *B = &sc->body[b];
  return B->group ? B->group : B->name;
}

static int extreme(double x)
{
  return !isfinite(x) || fabs(x) > MO_FINITE_EXTREME;
}

int mo_finite_initial(const mo_scene *sc)
{
  int k;
  for (k = 0; sc->u0 && sc->v0 && k < sc->ndof; k++)
    if (extreme(sc->u0[k]) || extreme(sc->v0[k])) return k;
  return -1;
}

void mo_finite_cause(const mo_scene *sc, double t, char *buf, size_t n)
{
  const config_setting_t *bl = config_lookup(&sc->cs->cfg, "bodies");
  int l, k, b;
  /* 1. the loads at t: the largest nodal force */
  for (l = 0; l < sc->nload; l++) {
    const mo_load *L = &sc->load[l];
    double a = L->amp ? mo_expr_eval(L->amp, &t) : 1;
    for (k = 0; k < L->n; k++) {
      double f = a * L->val[k];
      if (extreme(f) || (L->amp && extreme(a))) {
        const config_setting_t *bg;
        const char *key = "loads";
        b = dof_body(sc, L->dof[k]);
        if (b < 0) continue;
        bg = bl ? config_setting_get_elem(bl, (unsigned)sc->body[b].entry) : NULL;
        if (bg && !mo_cfg_member(bg, "loads")) key = "body_force";
        else if (bg && mo_cfg_member(bg, "body_force") && !L->amp && !extreme(L->val[k])) key = "body_force";
        if (L->amp)
          snprintf(buf, n, "The likely cause: bodies.%s.%s: amplitude \"%s\" = %g at t = %.6g times %g makes a "
                   "nodal force of %g", entry_name(sc, b), key, mo_expr_source(L->amp), a, t, L->val[k], f);
        else
          snprintf(buf, n, "The likely cause: bodies.%s.%s: a nodal force of %g", entry_name(sc, b), key, f);
        return;
      }
    }
  }
  /* 2. the initial fields */
  if ((k = mo_finite_initial(sc)) >= 0) {
    b = dof_body(sc, k);
    snprintf(buf, n, "The likely cause: bodies.%s.initial.%s: %g", b >= 0 ? entry_name(sc, b) : "?",
             extreme(sc->v0[k]) ? "velocity" : "displacement", extreme(sc->v0[k]) ? sc->v0[k] : sc->u0[k]);
    return;
  }
  /* 3. the materials: a modulus or a density far from any material, a wave speed past 1e100 */
  for (b = 0; b < sc->nbody; b++) {
    const mo_body *B = &sc->body[b];
    double E, rho;
    if (B->kind != MO_BODY_DEFORMABLE) continue; /* (the others have no material) */
    E = B->mat->E;
    rho = B->mat->rho;
    if (extreme(E) || extreme(1 / rho) || extreme(rho) || (rho > 0 && extreme(sqrt(E / rho)))) {
      snprintf(buf, n, "The likely cause: bodies.%s.material: E = %g, rho = %g (wave speed %g m/s)",
               entry_name(sc, b), E, rho, rho > 0 ? sqrt(E / rho) : HUGE_VAL);
      return;
    }
  }
  /* 4. the time step */
  if (extreme(sc->time.dt) || extreme(1 / sc->time.dt)) {
    snprintf(buf, n, "The likely cause: time.dt = %g", sc->time.dt);
    return;
  }
  snprintf(buf, n, "No input is extreme (loads, initial fields, materials, time.dt), so the step itself "
           "diverged: check the material constants and time.dt (a smaller step, or theta closer to 1)");
}

int mo_finite_error(const mo_scene *sc, long step, double t, const char *what, double value, mo_ctx *ctx)
{
  char cause[700];
  mo_finite_cause(sc, t, cause, sizeof cause);
  return mo_error(ctx, MO_ENAN, "step %ld (t = %.6g): %s is not finite (%g); the run stops at the first "
                  "non-finite value. %s", step, t, what, value, cause);
}

int mo_finite_bodies(const mo_scene *sc, const mo_state *s, const int *list, int n, mo_ctx *ctx)
{
  int k, i, nd = sc->dim == 3 ? 6 : 3;
  char what[200];
  for (k = 0; k < n; k++) {
    const mo_body *B = &sc->body[list[k]];
    if (!(B->type->flags & MO_BODY_F_RIGID) || B->dof0 < 0) continue;
    for (i = B->dof0; i < B->dof0 + nd; i++)
      if (!isfinite(s->u[i]) || !isfinite(s->v[i])) {
        snprintf(what, sizeof what, "the %s of dof %d (body '%s')", !isfinite(s->u[i]) ? "displacement" : "velocity",
                 i, B->name);
        return mo_finite_error(sc, s->step, s->t, what, !isfinite(s->u[i]) ? s->u[i] : s->v[i], ctx);
      }
  }
  return MO_OK;
}

int mo_finite_state(const mo_scene *sc, const mo_state *s, mo_ctx *ctx)
{
  int k, b;
  char what[200];
  for (k = 0; k < sc->ndof; k++)
    if (!isfinite(s->u[k]) || !isfinite(s->v[k])) {
      b = dof_body(sc, k);
      snprintf(what, sizeof what, "the %s of dof %d (body '%s')", !isfinite(s->u[k]) ? "displacement" : "velocity",
               k, b >= 0 ? sc->body[b].name : "?");
      return mo_finite_error(sc, s->step, s->t, what, !isfinite(s->u[k]) ? s->u[k] : s->v[k], ctx);
    }
  return MO_OK;
}

int mo_finite_row(const mo_scene *sc, const mo_state *s, const double *row, const char *const *names, int ncol,
                  mo_ctx *ctx)
{
  int k;
  char what[160];
  for (k = 0; k < ncol; k++)
    if (!isfinite(row[k])) {
      snprintf(what, sizeof what, "history column '%s'", names[k]);
      return mo_finite_error(sc, s->step, s->t, what, row[k], ctx);
    }
  return MO_OK;
}

/* Why an iteration matrix M + c K failed to factor, when the data say (T106): a stiffness
   term that outweighs the mass past what a double resolves, c E / (rho h^2) > 1e15 (h the
   shortest edge, c = (theta dt)^2 or beta dt^2), or an extreme constant. Empty otherwise. */
void mo_matrix_cause(const mo_scene *sc, char *buf, size_t n)
{
  double h = mo_metrics_hmin(sc), dt = sc->time.dt, c;
  int b;
  buf[0] = '\0';
  c = sc->time.scheme == MO_SCHEME_NEWMARK ? sc->time.beta * dt * dt
      : sc->time.scheme == MO_SCHEME_THETA  ? sc->time.theta * sc->time.theta * dt * dt
                                            : 0;
  if (extreme(dt) || extreme(1 / dt)) {
    snprintf(buf, n, "; the likely cause: time.dt = %g", dt);
    return;
  }
  for (b = 0; b < sc->nbody; b++) {
    const mo_body *B = &sc->body[b];
    double E, rho, r;
    if (B->kind != MO_BODY_DEFORMABLE) continue; /* (the others have no material) */
    E = B->mat->E;
    rho = B->mat->rho;
    r = c > 0 && rho > 0 && h > 0 && isfinite(h) ? c * E / (rho * h * h) : 0;
    if (extreme(E) || extreme(rho) || extreme(1 / rho) || !isfinite(r) || r > 1e15) {
      snprintf(buf, n, "; the likely cause: bodies.%s.material: E = %g, rho = %g with time.dt = %g and elements "
               "of %g make the stiffness term outweigh the mass %.3g times, past the 1e15 a double resolves "
               "(a material in consistent units, a smaller time.dt)", entry_name(sc, b), E, rho, dt, h, r);
      return;
    }
  }
}
