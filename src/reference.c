/* reference.c: the closed-form solutions the core measures runs against (doc/theory.md §3). */
#include "config.h"
#include <moreau/scene.h>
#include <moreau/body.h>
#include "case_internal.h"

#include <math.h>
#include <string.h>

const char *mo_reference_name(mo_reference_type t)
{
  switch (t) {
  case MO_REF_BAR_RELEASE: return "bar_release";
  case MO_REF_BAR_STEP_VELOCITY: return "bar_step_velocity";
  case MO_REF_RODS_IMPACT: return "rods_impact";
  case MO_REF_BAR_OBSTACLE: return "bar_obstacle";
  case MO_REF_ENERGY: return "energy";
  case MO_REF_BOUNCE: return "bounce";
  case MO_REF_INCLINE: return "incline";
  case MO_REF_STRUCK_BAR: return "struck_bar";
  default: return "none";
  }
}

/* The rigid references (doc/theory.md §12.6): the body they describe and what follows from the
   case (the incline's regime and accelerations). */
static int rigid_reference(mo_reference *R, const mo_scene *sc, const config_setting_t *rg, mo_ctx *ctx)
{
  const mo_case *cs = sc->cs;
  const char *bname = mo_cfg_string(rg, "body", NULL);
  const mo_body *B;
  int k;
  R->body = -1;
  for (k = 0; k < sc->nbody && R->body < 0; k++)
    if (bname ? !strcmp(sc->body[k].name, bname) : (sc->body[k].type->flags & MO_BODY_F_RIGID) && !sc->body[k].fixed)
      R->body = k;
  if (R->body < 0 || !(sc->body[R->body].type->flags & MO_BODY_F_RIGID))
    return mo_case_error(cs, mo_cfg_member(rg, "body") ? mo_cfg_member(rg, "body") : rg, ctx,
                         "no rigid body named '%s'", bname ? bname : "");
  B = &sc->body[R->body];
  for (k = 0; k < 3; k++) R->x1[k] = B->xc0[k];
  R->gravity = mo_cfg_float(rg, "gravity", 9.81);
  R->height = mo_cfg_float(rg, "height", 1);
  R->restitution = mo_cfg_float(rg, "restitution", 0);
  R->radius = B->radius;
  R->angle = mo_cfg_float(rg, "angle", 0) * M_PI / 180;
  R->mu = mo_cfg_float(rg, "mu", 0);
  if (R->type == MO_REF_INCLINE) {
    /* (T74): a block sticks when tan alpha <= mu, else slides at g (sin - mu cos); a disk (a
       sphere) rolls without slip when mu >= tan alpha / 3 (2/7 tan alpha) at a = g sin alpha /
       (1 + I / (m R^2)), else slips with friction mu g cos alpha driving the spin */
    double g = R->gravity, sa = sin(R->angle), ca = cos(R->angle), ta = sa / ca;
    if (B->kind == MO_BODY_POLYGON || B->kind == MO_BODY_RIGID_MESH) {
      R->regime = ta <= R->mu ? 0 : 1;
      R->accel = R->regime ? g * (sa - R->mu * ca) : 0;
      R->alpha = 0;
    } else {
      double k2 = B->kind == MO_BODY_SPHERE ? 0.4 : 0.5; /* I / (m R^2) */
      if (R->mu >= ta * k2 / (1 + k2)) {
        R->regime = 2;
        R->accel = g * sa / (1 + k2);
        R->alpha = -R->accel / R->radius;
      } else {
        R->regime = 1;
        R->accel = g * (sa - R->mu * ca);
        R->alpha = -R->mu * g * ca / (k2 * R->radius);
      }
    }
  }
  return MO_OK;
}

int mo_reference_build(mo_reference *R, const mo_scene *sc, mo_ctx *ctx)
{
  const mo_case *cs = sc->cs;
  const config_setting_t *rg = config_lookup(&cs->cfg, "reference");
  const char *type, *bname;
  static const char *need[9][6] = {{NULL},
                                   {"length", "wave_speed", "strain", NULL},
                                   {"length", "wave_speed", "velocity", NULL},
                                   {"length", "wave_speed", "velocity", "gap", "contact_end"},
                                   {"length", "wave_speed", "amplitude", NULL},
                                   {"energy", NULL},
                                   {"height", "restitution", NULL},
                                   {"angle", "mu", NULL},
                                   {"length", "wave_speed", "velocity", "mass", "density", "area"}};
  int k;
  memset(R, 0, sizeof *R);
  R->energy = NAN;
  if (!rg) return MO_OK;
  type = mo_cfg_string(rg, "type", "");
  R->type = !strcmp(type, "bar_release") ? MO_REF_BAR_RELEASE
            : !strcmp(type, "bar_step_velocity") ? MO_REF_BAR_STEP_VELOCITY
            : !strcmp(type, "rods_impact") ? MO_REF_RODS_IMPACT
            : !strcmp(type, "bar_obstacle") ? MO_REF_BAR_OBSTACLE
            : !strcmp(type, "bounce") ? MO_REF_BOUNCE
            : !strcmp(type, "incline") ? MO_REF_INCLINE
            : !strcmp(type, "struck_bar") ? MO_REF_STRUCK_BAR : MO_REF_ENERGY;
  for (k = 0; k < 6 && need[R->type][k]; k++)
    if (!mo_cfg_member(rg, need[R->type][k]))
      return mo_case_error(cs, rg, ctx, "reference '%s' needs '%s'", type, need[R->type][k]);
  R->length = mo_cfg_float(rg, "length", 1);
  R->c = mo_cfg_float(rg, "wave_speed", 1);
  R->strain = mo_cfg_float(rg, "strain", 0);
  R->velocity = mo_cfg_float(rg, "velocity", 0);
  R->x0 = mo_cfg_float(rg, R->type == MO_REF_RODS_IMPACT ? "contact_end" : "origin", 0);
  R->direction = mo_cfg_float(rg, "direction", 1) >= 0 ? 1 : -1;
  R->gap = mo_cfg_float(rg, "gap", 0);
  R->amplitude = mo_cfg_float(rg, "amplitude", 0);
  R->density = mo_cfg_float(rg, "density", 1);
  R->area = mo_cfg_float(rg, "area", 1);
  R->mass = mo_cfg_float(rg, "mass", 1);
  R->energy = mo_cfg_member(rg, "energy") ? mo_cfg_float(rg, "energy", 0) : NAN;
  if (R->type == MO_REF_BOUNCE || R->type == MO_REF_INCLINE) return rigid_reference(R, sc, rg, ctx);
  bname = mo_cfg_string(rg, "body", NULL);
  R->body = -1;
  for (k = 0; k < sc->nbody; k++)
    if (bname ? !strcmp(sc->body[k].name, bname) : sc->body[k].kind == MO_BODY_DEFORMABLE) {
      R->body = k;
      break;
    }
  if (R->body < 0 || sc->body[R->body].kind != MO_BODY_DEFORMABLE)
    return mo_case_error(cs, mo_cfg_member(rg, "body") ? mo_cfg_member(rg, "body") : rg, ctx,
                         "no deformable body named '%s'", bname ? bname : "");
  if (R->type == MO_REF_RODS_IMPACT && !(R->velocity > 0 && R->gap >= 0))
    return mo_case_error(cs, rg, ctx, "rods_impact needs a positive velocity (speed toward the "
                         "obstacle) and a gap >= 0");
  return MO_OK;
}

/* --- rigid bodies (doc/theory.md §12.6) --------------------------------------------------------- */

/* A ball dropped from rest with its bottom at h0 above a plane, Newton's law with e (T73): the
   height of the bottom and the vertical velocity at t. t_1 = sqrt(2 h0 / g), bounce k leaves at
   e^k v_1 and lands 2 e^k v_1 / g later; at rest after t_1 (1 + e) / (1 - e). */
static void bounce(const mo_reference *R, double t, double *h, double *v)
{
  double g = R->gravity, e = R->restitution, v1 = sqrt(2 * g * R->height), tk = v1 / g, vk = v1;
  *h = 0;
  *v = 0;
  if (t < tk) {
    *h = R->height - 0.5 * g * t * t;
    *v = -g * t;
    return;
  }
  for (;;) {
    double dur;
    vk *= e;
    dur = 2 * vk / g;
    if (!(dur > 1e-15 * tk) || vk <= 0) return; /* at rest (Zeno point passed) */
    if (t < tk + dur) {
      double tau = t - tk;
      *h = vk * tau - 0.5 * g * tau * tau;
      *v = vk - g * tau;
      return;
    }
    tk += dur;
  }
}

int mo_reference_rigid(const mo_reference *R, const mo_scene *sc, int b, int comp, double t, double *val)
{
  int D = sc->dim, vy = D == 2 ? 4 : 8, wz = D == 2 ? 5 : 12;
  if (R->type == MO_REF_STRUCK_BAR && (sc->body[b].type->flags & MO_BODY_F_RIGID) && comp == (D == 2 ? 3 : 7)) {
    /* the striker slows down as the force of (T75) says, v = v0 exp(-rho c A t / M), until 2 L / c */
    double z = R->density * R->c * R->area, t0 = R->gap / (R->velocity > 0 ? R->velocity : 1);
    if (t < t0 || t >= t0 + 2 * R->length / R->c) return 0;
    *val = R->velocity * exp(-z * (t - t0) / R->mass);
    return 1;
  }
  if (b != R->body) return 0;
  if (R->type == MO_REF_BOUNCE) {
    double h, v;
    bounce(R, t, &h, &v);
    if (comp == 1) *val = h + R->radius;
    else if (comp == vy) *val = v;
    else return 0;
    return 1;
  }
  if (R->type == MO_REF_INCLINE) {
    /* along the slope s = (cos a, -sin a), descending toward +x; the spin about z */
    double sdist = 0.5 * R->accel * t * t, sv = R->accel * t;
    if (comp == 0) *val = R->x1[0] + sdist * cos(R->angle);
    else if (comp == 1) *val = R->x1[1] - sdist * sin(R->angle);
    else if (comp == (D == 2 ? 3 : 7)) *val = sv * cos(R->angle);
    else if (comp == vy) *val = -sv * sin(R->angle);
    else if (comp == wz) *val = R->alpha * t;
    else return 0;
    return 1;
  }
  return 0;
}

/* Triangle wave: the odd (about 0), even (about L) extension of s -> s on [0, L], period 4L. */
static double tri(double s, double L, double *slope)
{
  double p = fmod(s, 4 * L);
  if (p < 0) p += 4 * L;
  if (p < L) { *slope = 1; return p; }
  if (p < 3 * L) { *slope = -1; return 2 * L - p; }
  *slope = 1;
  return p - 4 * L;
}

/* Rod of length L moving at v0 toward an obstacle a distance `gap` away (T43), in rod
   coordinates: xi is the distance from the contact end, u along the motion. */
static void rods(const mo_reference *R, double xi, double t, double *u, double *v, double *eps)
{
  double v0 = R->velocity, c = R->c, L = R->length, t0 = R->gap / v0;
  double arrive = t0 + xi / c, leave = t0 + (2 * L - xi) / c;
  *u = v0 * (t < arrive ? t : arrive) - v0 * (t > leave ? t - leave : 0);
  *v = (t < arrive ? v0 : 0) - (t > leave ? v0 : 0);
  /* compression (negative strain along the motion) between the two waves */
  *eps = t > arrive && t < leave ? -v0 / c : 0;
}

/* Doyen-Ern-Piperno's benchmark in reduced variables (T44): x, t in units of L, L/c; the
   solution for amplitude 1/2, period 3. */
static void obstacle(double x, double t, double *u, double *v, double *eps)
{
  double p = fmod(t, 3);
  if (p < 0) p += 3;
  if (p <= 1) {
    *u = 0.5 * (1 - (x > p ? x : p));
    *v = x < p ? -0.5 : 0;
    *eps = x > p ? -0.5 : 0;
  } else if (p <= 2) {
    /* both ends fixed from u = 0, v = -1/2: d'Alembert with V the odd 2-periodic extension of
       -1/2 and its antiderivative F(s) = -|s - 2 round(s/2)| / 2 */
    double tau = p - 1, a = x + tau, b = x - tau;
    double ra = a - 2 * floor(a / 2 + 0.5), rb = b - 2 * floor(b / 2 + 0.5);
    double Va = ra > 0 ? -0.5 : 0.5, Vb = rb > 0 ? -0.5 : 0.5;
    if (ra == 0) Va = 0;
    if (rb == 0) Vb = 0;
    *u = 0.5 * (-0.5 * fabs(ra) + 0.5 * fabs(rb));
    *v = 0.5 * (Va + Vb);
    *eps = 0.5 * (Va - Vb);
  } else {
    double tau = p - 2;
    *u = tau / 2 < (1 - x) / 2 ? tau / 2 : (1 - x) / 2;
    *v = x + tau < 1 ? 0.5 : 0;
    *eps = x + tau > 1 ? -0.5 : 0;
  }
}

void mo_reference_field(const mo_reference *R, double x, double t, double *u, double *v,
                        double *eps)
{
  double L = R->length, c = R->c;
  *u = *v = *eps = 0;
  switch (R->type) {
  case MO_REF_BAR_RELEASE: {
    /* d'Alembert: u = (g(xi - ct) + g(xi + ct)) / 2, g the extension of eps * xi (T5) */
    double xi = x - R->x0, s1, s2, g1 = tri(xi - c * t, L, &s1), g2 = tri(xi + c * t, L, &s2);
    *u = R->strain * 0.5 * (g1 + g2);
    *v = R->strain * 0.5 * c * (s2 - s1);
    *eps = R->strain * 0.5 * (s1 + s2);
    break;
  }
  case MO_REF_BAR_STEP_VELOCITY: {
    /* u = V t xi / L + w, w fixed-fixed with w_t(., 0) = -V xi / L (T6) */
    double V = R->velocity, xi = x - R->x0, a = xi + c * t, b = xi - c * t, r1, r2;
    r1 = a - 2 * L * floor((a + L) / (2 * L));
    r2 = b - 2 * L * floor((b + L) / (2 * L));
    *u = V * t * xi / L + (-V * r1 * r1 / (2 * L) + V * r2 * r2 / (2 * L)) / (2 * c);
    *v = V * xi / L + 0.5 * (-V * r1 / L - V * r2 / L);
    *eps = V * t / L + (-V * r1 / L + V * r2 / L) / (2 * c);
    break;
  }
  case MO_REF_RODS_IMPACT: {
    double ur, vr, er, xi = fabs(x - R->x0);
    rods(R, xi, t, &ur, &vr, &er);
    *u = R->direction * ur;
    *v = R->direction * vr;
    *eps = er;
    break;
  }
  case MO_REF_BAR_OBSTACLE: {
    /* scaled: u = 2a u~(x/L, ct/L), v = 2a c/L v~, eps = 2a/L eps~ */
    double ur, vr, er, a = R->amplitude;
    obstacle((x - R->x0) / L, c * t / L, &ur, &vr, &er);
    *u = 2 * a * ur;
    *v = 2 * a * c / L * vr;
    *eps = 2 * a / L * er;
    break;
  }
  default: break;
  }
}

int mo_reference_contact(const mo_reference *R, double t, double *pressure)
{
  double E = R->density * R->c * R->c;
  *pressure = 0;
  if (R->type == MO_REF_RODS_IMPACT) {
    double t0 = R->gap / R->velocity, t1 = t0 + 2 * R->length / R->c;
    if (t < t0 || t > t1) return 0;
    *pressure = R->density * R->c * R->velocity; /* rho c v0 */
    return 1;
  }
  if (R->type == MO_REF_BAR_OBSTACLE) {
    double p = fmod(R->c * t / R->length, 3);
    if (p < 1 || p > 2) return 0;
    *pressure = E * R->amplitude / R->length;
    return 1;
  }
  return 0;
}

double mo_reference_release_time(const mo_reference *R)
{
  if (R->type == MO_REF_RODS_IMPACT) return R->gap / R->velocity + 2 * R->length / R->c;
  if (R->type == MO_REF_BAR_OBSTACLE) return 2 * R->length / R->c;
  return NAN;
}

double mo_reference_impulse(const mo_reference *R, double T)
{
  double p, closed = 0;
  if (R->type == MO_REF_RODS_IMPACT) {
    double t0 = R->gap / R->velocity, t1 = t0 + 2 * R->length / R->c;
    closed = T <= t0 ? 0 : (T < t1 ? T - t0 : t1 - t0);
  } else if (R->type == MO_REF_BAR_OBSTACLE) {
    double per = 3 * R->length / R->c, n = floor(T / per), rem = T - n * per, dur = R->length / R->c;
    closed = n * dur + (rem > dur ? (rem < 2 * dur ? rem - dur : dur) : 0);
  } else
    return NAN;
  mo_reference_contact(R, R->type == MO_REF_RODS_IMPACT ? R->gap / R->velocity : 1.5 * R->length / R->c, &p);
  return p * R->area * closed;
}

int mo_reference_eval(const mo_reference *R, mo_quantity q, double x, double t, double *val)
{
  double u, v, e, p;
  if (R->type == MO_REF_NONE || R->type == MO_REF_ENERGY || R->type == MO_REF_BOUNCE || R->type == MO_REF_INCLINE)
    return 0;
  if (R->type == MO_REF_STRUCK_BAR && q != MO_Q_CX) return 0;
  switch (q) {
  case MO_Q_UX: mo_reference_field(R, x, t, &u, &v, &e); *val = u; return 1;
  case MO_Q_VX: mo_reference_field(R, x, t, &u, &v, &e); *val = v; return 1;
  case MO_Q_PN:
    if (R->type != MO_REF_RODS_IMPACT && R->type != MO_REF_BAR_OBSTACLE) return 0;
    mo_reference_contact(R, t, &p);
    *val = p;
    return 1;
  case MO_Q_CX:
    if (R->type == MO_REF_STRUCK_BAR) {
      /* Saint-Venant (T75): F = rho c A v0 exp(-rho c A t / M) on the struck end, +x, until the
         wave reflected at the far end comes back at 2 L / c */
      double z = R->density * R->c * R->area, t0 = R->gap / (R->velocity > 0 ? R->velocity : 1);
      if (fabs(x - R->x0) > 1e-9 * R->length || t < t0 || t >= t0 + 2 * R->length / R->c) return 0;
      *val = z * R->velocity * exp(-z * (t - t0) / R->mass);
      return 1;
    }
    /* contact force on the body at the contact end: toward the body, away from the obstacle */
    if (R->type != MO_REF_RODS_IMPACT && R->type != MO_REF_BAR_OBSTACLE) return 0;
    if (fabs(x - R->x0) > 1e-9 * R->length) return 0;
    mo_reference_contact(R, t, &p);
    *val = (R->type == MO_REF_RODS_IMPACT ? -R->direction : 1) * p * R->area + 0.0;
    return 1;
  default: return 0;
  }
}
