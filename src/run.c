/* run.c: running a case: load, override, validate, build, step, write histories, fields and
   the summary. */
#include "config.h"
#if defined HAVE_MALLOC_H && defined HAVE_MALLOPT
#include <malloc.h>
#endif
#include <moreau/run.h>
#include <moreau/parallel.h>
#include <moreau/body.h>
#include <moreau/case.h>
#include <moreau/contact.h>
#include <moreau/material.h>
#include <moreau/output.h>
#include <moreau/scene.h>
#include <moreau/step.h>
#include "case_internal.h"
#include "draw.h"
#include "metrics.h"

#include <jansson.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>

static int load_case(const mo_run_options *opt, mo_case **cs, mo_ctx *ctx)
{
  int st, k;
  double t0 = mo_clock();
  if ((st = mo_case_load(opt->case_path, cs, ctx))) return st;
  if ((st = mo_case_validate(*cs, ctx))) goto fail;
  if (opt->solver) {
    /* BACKEND[:PRESET][[KEY=VALUE;...]]: the preset, then --set, then the bracket (preset.c) */
    if ((st = mo_solver_spec_apply(*cs, opt->solver, opt->sets, opt->nset, ctx))) goto fail;
  } else {
    for (k = 0; k < opt->nset; k++)
      if ((st = mo_case_set(*cs, opt->sets[k], ctx))) goto fail;
  }
  if ((st = mo_case_validate(*cs, ctx))) goto fail;
  mo_phase_add(ctx, MO_PH_SETUP, t0);
  return MO_OK;
fail:
  mo_case_free(*cs);
  *cs = NULL;
  return st;
}

int mo_check(const mo_run_options *opt, mo_ctx *ctx)
{
  mo_case *cs = NULL;
  mo_scene *sc = NULL;
  mo_contact *C = NULL;
  mo_contact_driver *D = NULL;
  int st = load_case(opt, &cs, ctx);
  /* everything a run checks before its first factorization: scene, contact set, back end and
     its options, time scheme */
  if (!st) st = mo_scene_build(cs, &sc, ctx);
  if (!st) st = mo_contact_build(sc, &C, ctx);
  if (!st && C) st = mo_contact_time_scheme(sc, C, ctx);
  if (!st && C) st = mo_contact_driver_create(sc, C, NULL, &D, ctx);
  mo_contact_driver_free(D);
  mo_contact_free(C);
  mo_scene_free(sc);
  mo_case_free(cs);
  return st;
}

/* Default output folder: out/<case name>. */
static void default_outdir(const char *case_path, char *buf, size_t n)
{
  char tmp[4096];
  char *base, *dot;
  size_t len;
  snprintf(tmp, sizeof tmp, "%s", case_path);
  len = strlen(tmp);
  while (len > 1 && tmp[len - 1] == '/') tmp[--len] = '\0';
  base = strrchr(tmp, '/');
  base = base ? base + 1 : tmp;
  if (!strcmp(base, "case.cfg") && base != tmp) { /* folder/case.cfg: use the folder */
    base[-1] = '\0';
    base = strrchr(tmp, '/');
    base = base ? base + 1 : tmp;
  }
  dot = strrchr(base, '.');
  if (dot && !strcmp(dot, ".cfg")) *dot = '\0';
  snprintf(buf, n, "out/%s", base[0] ? base : "run");
}

/* --- probes and metrics ------------------------------------------------------------------------ */

typedef struct {
  int probe, q;          /* column source: a probe's quantity, or (probe -1) rigid body `body`'s
                            component q (rigid_value) */
  int body;
  int exact_col;         /* column of the exact value, or -1 */
  double x;              /* position for the reference */
  int has_ref;
  double se2, sr2, emax, rmax;
  long n;
} column;

/* Contact data the probes read: nodal contact forces H r (full dofs), and per candidate. */
typedef struct {
  const mo_contact *C;
  const mo_contact_driver *D;
  double *Rfull;  /* ndof, contact forces at nodes */
  int need_R;
} contact_view;

static double probe_value(const mo_scene *sc, const mo_probe *P, mo_quantity q, const mo_state *s,
                          const contact_view *cv)
{
  const mo_body *B = &sc->body[P->body];
  int comp = (int)q % 3, kind = (int)q / 3, k, D = sc->dim;
  double acc = 0;
  if (q == MO_Q_PN || q == MO_Q_GN || q == MO_Q_LAM) {
    /* candidates whose representative node is one of the probe's nodes */
    int a, n = 0, d;
    const double *r, *g;
    if (!cv->C || !cv->D) return NAN;
    d = mo_contact_dim(cv->C);
    r = mo_contact_reactions(cv->D);
    g = mo_contact_gaps(cv->C);
    for (a = 0; a < mo_contact_ncandidates(cv->C); a++) {
      mo_candidate cb;
      const mo_candidate *c = mo_contact_cand_get(cv->C, a, &cb);
      if (c->node < 0 || mo_contact_pair_get(cv->C, c->pair)->sbody != P->body) continue;
      for (k = 0; k < P->nnode; k++)
        if (P->node[k] == c->node) {
          double f = r[a * d] / (sc->time.scheme == MO_SCHEME_THETA ? mo_contact_driver_dt(cv->D) : 1);
          if (q == MO_Q_PN) acc += c->w > 0 ? f / c->w : f;
          else if (q == MO_Q_GN) acc += g[a];
          else acc += mo_contact_friction_ratio(d, c->mu, r + a * d);
          n++;
        }
    }
    return n ? acc / n : NAN;
  }
  for (k = 0; k < P->nnode; k++) {
    int d = B->dof0 + P->node[k] * D + comp;
    acc += kind == 0 ? s->u[d] : kind == 1 ? s->v[d] : kind == 2 ? s->reac[d] : (cv->Rfull ? cv->Rfull[d] : 0);
  }
  return kind >= 2 ? acc : acc / P->nnode;
}

/* The rigid bodies' columns (doc/case-format.md, "Output"): 2D x, y, theta, vx, vy, omega; 3D x, y, z, q0..q3, vx,
   vy, vz, wx, wy, wz. At most this many moving rigid bodies get them; larger scenes write the
   aggregate columns (rigid.*). */
#define MO_RIGID_COLUMNS_MAX 32
static const char *const rigid2[] = {"x", "y", "theta", "vx", "vy", "omega"};
static const char *const rigid3[] = {"x", "y", "z", "q0", "q1", "q2", "q3", "vx", "vy", "vz", "wx", "wy", "wz"};

static double rigid_value(const mo_scene *sc, const mo_state *s, int b, int comp)
{
  const mo_body *B = &sc->body[b];
  if (sc->dim == 2) {
    if (comp < 2) return B->xc0[comp] + s->u[B->dof0 + comp];
    if (comp == 2) return B->theta0 + s->u[B->dof0 + 2];
    return s->v[B->dof0 + comp - 3];
  }
  if (comp < 3) return B->xc0[comp] + s->u[B->dof0 + comp];
  if (comp < 7) return s->orient[4 * B->orient + comp - 3];
  return s->v[B->dof0 + comp - 7];
}

/* The rigid bodies that move (not held fixed): the ones with history columns. */
static int moving_rigid(const mo_scene *sc)
{
  int k, n = 0;
  for (k = 0; k < sc->nrigid; k++) n += !sc->body[sc->rigid[k]].fixed;
  return n;
}

/* Aggregates of the rigid bodies for scenes with many (columns rigid.kinetic, rigid.vmax,
   rigid.coordination: closed contacts per moving rigid body, a contact with two of them counted
   for both; rigid.xmax, .ymax (, .zmax): the extent of the moving bodies, centre plus bounding
   radius: a pile's height, a collapse's front). */
static int rigid_aggregates(const mo_scene *sc, const mo_state *s, const contact_view *cv, const int *hlist, int nh,
                            const unsigned char *count, double ek, double *out, mo_ctx *ctx)
{
  int k, i, n = 0, D = sc->dim, err;
  double vmax = 0, z = 0, ext[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  /* the bodies' state per rank: each rank its counted bodies among those it holds, joined below */
  for (k = 0; k < (count ? nh : sc->nrigid); k++) {
    const int b = count ? hlist[k] : sc->rigid[k];
    const mo_body *B = &sc->body[b];
    double v2 = 0, xc[3];
    if (B->fixed || (count && (!count[b] || !(B->type->flags & MO_BODY_F_RIGID)))) continue;
    n++;
    for (i = 0; i < D; i++) v2 += s->v[B->dof0 + i] * s->v[B->dof0 + i];
    vmax = fmax(vmax, sqrt(v2));
    mo_rigid_center(sc, B, s, xc);
    for (i = 0; i < D; i++) ext[i] = fmax(ext[i], xc[i] + B->bound);
  }
  if (count) {
    double sm[1] = {n}, mx[4] = {vmax, ext[0], ext[1], ext[2]};
    if ((err = mo_par_sum(sm, 1, ctx)) || (err = mo_par_max(mx, 4, ctx))) return err;
    n = (int)sm[0];
    vmax = mx[0];
    for (i = 0; i < 3; i++) ext[i] = mx[1 + i];
  }
  if (cv->C && cv->D) {
    const int *st = mo_contact_statuses(cv->D);
    for (k = 0; k < mo_contact_ncandidates(cv->C); k++) {
      int sb, mb;
      if (st[k] == MO_CS_OPEN) continue;
      mo_contact_cand_bodies(cv->C, k, &sb, &mb);
      z += (sc->body[sb].type->flags & MO_BODY_F_RIGID) && !sc->body[sb].fixed;
      z += mb >= 0 && (sc->body[mb].type->flags & MO_BODY_F_RIGID) && !sc->body[mb].fixed;
    }
    /* the distributed set: each rank's contacts counted, summed (every rank writes the row) */
    if (mo_contact_distributed(cv->C) && (err = mo_par_sum(&z, 1, ctx))) return err;
  }
  out[0] = count ? ek : mo_rigid_kinetic(sc, s);
  out[1] = vmax;
  out[2] = n ? z / n : 0;
  for (i = 0; i < D; i++) out[3 + i] = n ? ext[i] : 0;
  return MO_OK;
}

/* The energies of a step, finite or the run stops (finite.c). */
static int check_energies(const mo_scene *sc, const mo_state *s, double ek, double ee, mo_ctx *ctx)
{
  const char *what[] = {"energy.kinetic", "energy.elastic", "energy.external_work", "energy.support_work",
                        "energy.contact_work", "energy.plastic"};
  double v[6];
  int k;
  v[0] = ek;
  v[1] = ee;
  v[2] = s->wext;
  v[3] = s->wsupport;
  v[4] = s->wcontact;
  v[5] = s->wplastic;
  for (k = 0; k < 6; k++)
    if (!isfinite(v[k])) return mo_finite_error(sc, s->step, s->t, what[k], v[k], ctx);
  return MO_OK;
}

/* A number for summary.json: null when it is not finite (an undefined ratio; jansson would
   drop the key) */
static json_t *jnum(double x)
{
  return isfinite(x) ? json_real(x) : json_null();
}

/* --- progress ---------------------------------------------------------------------------------- */

typedef struct {
  int on;
  double start, last;
} progress;

/* The bar, the step and time, steps per second, and for scenes with contact the contacts closed
   and the sweeps (iterations) of the last solve. */
static void progress_draw(progress *p, long step, long steps, double t, int final, const mo_contact_driver *drv)
{
  double now = mo_clock(), frac = steps > 0 ? (double)step / (double)steps : 1, eta;
  int w = 24, k, fill;
  if (!p->on || (!final && now - p->last < 0.1)) return;
  p->last = now;
  fill = (int)(frac * w + 0.5);
  eta = frac > 0 ? (now - p->start) * (1 - frac) / frac : 0;
  fputc('\r', stderr);
  fputc('[', stderr);
  for (k = 0; k < w; k++) fputc(k < fill ? '#' : '.', stderr);
  fprintf(stderr, "] %3.0f%%  step %ld/%ld  t = %-9.4g %6.0f steps/s", 100 * frac, step, steps, t,
          now > p->start ? step / (now - p->start) : 0.0);
  if (drv && step > 0) {
    const mo_contact_report *rep = mo_contact_last_report(drv);
    fprintf(stderr, "  %d contacts  %d sweeps", rep->nstick + rep->nslide, rep->iterations);
  }
  fprintf(stderr, "  %s %.1fs   ", final ? "wall" : "eta", final ? now - p->start : eta);
  if (final) fputc('\n', stderr);
  fflush(stderr);
}

/* --- summary ------------------------------------------------------------------------------------ */

static json_t *timings_json(const mo_ctx *ctx, double wall, double steps, double first)
{
  json_t *j = json_object(), *calls = json_object();
  int p;
  for (p = 0; p < MO_PH_N; p++) {
    json_object_set_new(j, mo_phase_name((mo_phase)p), jnum(ctx->phase_time[p]));
    json_object_set_new(calls, mo_phase_name((mo_phase)p), json_integer(ctx->phase_calls[p]));
  }
  json_object_set_new(j, "wall", jnum(wall));
  /* the time of the steps alone (setup, the t = 0 state and every output left out): what
     `moreau compare` times a run by (doc/theory.md (T99)) */
  json_object_set_new(j, "steps", jnum(steps));
  /* of which the first step (its Delassus build and status iterations: a linear scene's later
     steps reuse both), so that the steady step is (steps - first_step) / (n - 1) */
  if (first >= 0) json_object_set_new(j, "first_step", jnum(first));
  json_object_set_new(j, "calls", calls);
  return j;
}

/* How the run was spread over MPI ranks (doc/parallel.md): the ranks, the solver of What, and
   rank 0's collective calls outside PETSc (their count, seconds and the bytes it sent). */
static json_t *parallel_json(const mo_ctx *ctx, const mo_scene *sc)
{
  json_t *j = json_object();
  json_object_set_new(j, "ranks", json_integer(ctx->nranks));
  json_object_set_new(j, "linear_solver", json_string(sc->lin.petsc ? "petsc" : "cholmod"));
  if (sc->lin.petsc) {
    char desc[160];
    snprintf(desc, sizeof desc, "%s/%s%s%s", sc->lin.ksp, sc->lin.pc,
             strcmp(sc->lin.pc, "lu") && strcmp(sc->lin.pc, "cholesky") ? "" : "/", 
             strcmp(sc->lin.pc, "lu") && strcmp(sc->lin.pc, "cholesky") ? "" : sc->lin.package);
    json_object_set_new(j, "petsc", json_string(desc));
  }
  if (sc->asm_elems) {
    /* the element matrices each rank computed, and its seconds in that loop (doc/parallel.md §3) */
    json_t *a = json_array(), *t = json_array();
    int r;
    for (r = 0; r < ctx->nranks; r++) {
      json_array_append_new(a, json_integer((json_int_t)sc->asm_elems[r]));
      json_array_append_new(t, jnum(sc->asm_seconds[r]));
    }
    json_object_set_new(j, "elements_assembled", a);
    json_object_set_new(j, "element_seconds", t);
  }
  if (sc->asm_entries) {
    /* the entries of K and M on each rank: their parts (linear scenes), or K and M whole */
    json_t *a = json_array();
    int r;
    for (r = 0; r < ctx->nranks; r++) json_array_append_new(a, json_integer((json_int_t)sc->asm_entries[r]));
    json_object_set_new(j, "matrix_entries", a);
    json_object_set_new(j, "matrices", json_string(sc->kpart ? "parts" : "whole"));
  }
  if (ctx->par_column_dofs) {
    /* the Delassus build's columns What^-1 H^T: the largest rank's rows of them, of the rows
       whole (doc/parallel.md §2, (T210): by rows over the ranks) */
    json_t *c = json_object();
    json_object_set_new(c, "rows_largest_rank", json_integer((json_int_t)ctx->par_column_rows));
    json_object_set_new(c, "rows", json_integer((json_int_t)ctx->par_column_dofs));
    json_object_set_new(c, "columns", json_integer((json_int_t)ctx->par_columns));
    json_object_set_new(j, "delassus_columns", c);
  }
  json_object_set_new(j, "collective_calls", json_integer(ctx->par_calls));
  json_object_set_new(j, "collective_seconds", jnum(ctx->par_time));
  json_object_set_new(j, "collective_bytes", jnum(ctx->par_bytes));
  if (ctx->par_grain_whole)
    /* the granular solves swept whole on every rank, too small to split (doc/theory.md (T333)) */
    json_object_set_new(j, "grain_whole_solves", json_integer(ctx->par_grain_whole));
  if (ctx->par_grain_solves) {
    /* the granular sweep over the ranks: Gauss-Seidel within each rank's part of the contacts */
    double n = (double)ctx->par_grain_solves;
    json_object_set_new(j, "grain_solves", json_integer(ctx->par_grain_solves));
    json_object_set_new(j, "grain_sweeps", json_integer(ctx->par_grain_sweeps));
    json_object_set_new(j, "grain_serial_fallbacks", json_integer(ctx->par_grain_serial));
    json_object_set_new(j, "grain_interface_bodies_mean", jnum(ctx->par_grain_interface / n));
    json_object_set_new(j, "grain_slab_imbalance_mean", jnum(ctx->par_grain_imbalance / n));
    /* the interface velocities after each sweep: one sum on 2 ranks, point to point between the
       ranks that share bodies on more (doc/theory.md (T331)) */
    json_object_set_new(j, "grain_interface_exchange",
                        json_string(ctx->nranks > 2 || ctx->par_dset ? "point to point" : "sum"));
    /* of them, those of more than 2 ranks: swept as bodies of mass 2 m / k (T332) */
    json_object_set_new(j, "grain_interface_bodies_over_2_ranks_mean", jnum(ctx->par_grain_multi / n));
    /* of them, those swept in the detection's parts, each contact by the rank that detected it
       (doc/theory.md (T341)); the others cut at the solve */
    json_object_set_new(j, "grain_solves_in_detection_parts", json_integer(ctx->par_grain_detparts));
  }
  if (ctx->par_detect_total) {
    /* the detection split over the ranks (doc/parallel.md §4, (T215)): the candidates the largest
       rank detected itself over the run, and every rank's */
    json_object_set_new(j, "grain_detected_largest_rank", json_integer(ctx->par_detect_largest));
    json_object_set_new(j, "grain_detected", json_integer(ctx->par_detect_total));
    /* the pair list's builds over the ranks, and those whose boxes were cut from the points of
       the last solve's active contacts (T341; the others from the bodies' centres) */
    json_object_set_new(j, "grain_detect_builds", json_integer(ctx->par_detect_builds));
    json_object_set_new(j, "grain_detect_builds_on_contacts", json_integer(ctx->par_detect_boxpts));
    /* the distributed set (doc/scaling.md §4): each rank held the candidates it detected only */
    json_object_set_new(j, "contact_set", json_string(ctx->par_dset ? "distributed" : "whole on every rank"));
    /* the bodies' state (doc/theory.md §13.18): each rank its box's and halo's bodies, the records
       of the bodies sent at the builds to the ranks that hold them next (this rank's), and the
       joins of every body's state for the outputs */
    json_object_set_new(j, "bodies_state", json_string(ctx->par_held ? "per rank" : "whole on every rank"));
    if (ctx->par_held) {
      json_object_set_new(j, "state_records_sent", json_integer(ctx->par_state_moved));
      json_object_set_new(j, "state_joins", json_integer(ctx->par_state_joins));
    }
  }
  return j;
}

static const char *scheme_name(mo_scheme s)
{
  return s == MO_SCHEME_NEWMARK ? "newmark" : s == MO_SCHEME_QUASISTATIC ? "quasistatic" : "theta";
}

/* The scheme a run took: "explicit" is the theta-scheme at theta = 1, theta_f = 0 (T100). */
static const char *time_scheme_name(const mo_time_settings *T)
{
  return T->explicit_cd && T->scheme == MO_SCHEME_THETA ? "explicit" : scheme_name(T->scheme);
}

#define TIME_WARN_MAX 2
/* A run warns when its mechanical energy exceeds this many times its initial value (minus the
   work given to it): no physical scene gains that much, an unstable scheme does in a few steps */
#define MO_BLOWUP_GROWTH 1e12
/* Blow-up of a scene at rest at t = 0 (E_ref = 0), where no ratio is defined: its bodies hold
   more than this many times the larger of the work given them and load_scale (T49a) */
#define MO_BLOWUP_GIVEN 1e3
/* The energy scale of a scene at rest at t = 0, the floor of its growth's denominator (T49a):
   the loads at t = 0 on the free dofs (every load is a force on translations), summed in
   magnitude, times the diagonal of the bodies' bounding box: a pile's or an arch's weight times
   its size. An arch that only settles is given almost no work (3.5e-9 J, its blocks rising by
   the contact solve's round-off) and would read a growth of 1 over that. 0 when nothing is
   loaded at t = 0 (a ramped load: the work given is the scale then). */
static double load_scale(const mo_scene *sc)
{
  double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL}, f = 0, d2 = 0;
  int b, l, k, a, i, D = sc->dim;
  for (l = 0; l < sc->nload; l++) {
    const mo_load *L = &sc->load[l];
    double t = 0, amp = L->amp ? fabs(mo_expr_eval(L->amp, &t)) : 1, sum = 0;
    for (k = 0; k < L->n; k++)
      if (sc->free_of[L->dof[k]] >= 0) sum += fabs(L->val[k]);
    f += amp * sum;
  }
  if (!(f > 0) || !isfinite(f)) return 0;
  for (b = 0; b < sc->nbody; b++) {
    const mo_body *B = &sc->body[b];
    if (B->kind == MO_BODY_PLANE) continue;
    if (B->kind == MO_BODY_DEFORMABLE) {
      for (a = 0; a < B->mesh->nnode; a++)
        for (i = 0; i < D; i++) {
          lo[i] = fmin(lo[i], B->mesh->x[(size_t)a * D + i]);
          hi[i] = fmax(hi[i], B->mesh->x[(size_t)a * D + i]);
        }
    } else
      for (i = 0; i < D; i++) {
        lo[i] = fmin(lo[i], B->xc0[i] - B->bound);
        hi[i] = fmax(hi[i], B->xc0[i] + B->bound);
      }
  }
  for (i = 0; i < D; i++)
    if (hi[i] >= lo[i]) d2 += (hi[i] - lo[i]) * (hi[i] - lo[i]);
  return isfinite(d2) ? f * sqrt(d2) : 0;
}

/* Warnings on the stability of the time scheme (doc/theory.md (T101)-(T103)), for the log and
   summary.json: a theta-scheme that is only conditionally stable (or not at all), and an
   explicit step above the critical one. Returns how many were written into w. */
static int time_warnings(const mo_scene *sc, char w[TIME_WARN_MAX][512])
{
  const mo_time_settings *T = &sc->time;
  double wh, dtc;
  int n = 0, b, e, stab;
  if (T->scheme != MO_SCHEME_THETA) return 0;
  dtc = mo_scene_dt_crit(sc, &b, &e);
  stab = mo_theta_stability(T->theta, T->theta_f, &wh);
  if (T->explicit_cd) {
    if (isfinite(dtc) && T->dt > dtc * (1 + 1e-9))
      snprintf(w[n++], 512, "dt = %.6g exceeds the critical time step dt_crit = %.6g of central differences (element %d "
               "of body '%s', doc/theory.md (T102)): dt / dt_crit = %.4g, the explicit scheme is unstable",
               T->dt, dtc, e, sc->body[b].name, T->dt / dtc);
  } else if (stab == MO_STAB_UNSTABLE)
    snprintf(w[n++], 512, "theta = %g, theta_f = %g: theta + theta_f < 1, the theta-scheme is unstable at every time "
             "step (doc/theory.md (T101))", T->theta, T->theta_f);
  else if (stab == MO_STAB_CONDITIONAL)
    snprintf(w[n++], 512, "theta = %g, theta_f = %g: the theta-method is only conditionally stable, h omega_max <= %.4g "
             "(doc/theory.md (T101))%s", T->theta, T->theta_f, wh,
             isfinite(dtc) ? "; with omega_max near 2 / dt_crit (T103) that is dt <= about" : "");
  if (stab == MO_STAB_CONDITIONAL && !T->explicit_cd && isfinite(dtc))
    snprintf(w[n - 1] + strlen(w[n - 1]), 512 - strlen(w[n - 1]), " %.4g", 0.5 * wh * dtc);
  return n;
}

static json_t *contact_json(const mo_contact *C, const mo_contact_driver *D, long ncand);

/* contact.signorini = "position" in the case (the default is velocity level). */
static int position_level(const mo_case *cs)
{
  const char *v = NULL;
  return config_lookup_string(&cs->cfg, "contact.signorini", &v) == CONFIG_TRUE && v && !strcmp(v, "position");
}

/* metrics.extents: the bounding box of each output.extents node set in the current
   configuration x = X + u. */
static json_t *extents_json(const mo_scene *sc, const double *u)
{
  static const char *lo[3] = {"xmin", "ymin", "zmin"}, *hi[3] = {"xmax", "ymax", "zmax"};
  json_t *j = json_object();
  int k, a, i, D = sc->dim;
  for (k = 0; k < sc->out.nextent; k++) {
    const mo_extent *X = &sc->out.extent[k];
    const mo_body *B = &sc->body[X->body];
    double mn[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, mx[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    json_t *e = json_object();
    for (a = 0; a < X->nnode; a++)
      for (i = 0; i < D; i++) {
        double x = B->mesh->x[X->node[a] * D + i] + u[B->dof0 + X->node[a] * D + i];
        if (x < mn[i]) mn[i] = x;
        if (x > mx[i]) mx[i] = x;
      }
    for (i = 0; i < D; i++) {
      json_object_set_new(e, lo[i], jnum(mn[i]));
      json_object_set_new(e, hi[i], jnum(mx[i]));
    }
    json_object_set_new(j, X->name, e);
  }
  return j;
}

/* metrics.plasticity: per finite-strain body, the largest equivalent plastic strain (of the
   element means, as the VTK field shows it), the plastic work and the stored energy. */
static json_t *plasticity_json(const mo_scene *sc, const mo_state *s)
{
  json_t *j = json_object();
  int b, e;
  for (b = 0; b < sc->nbody; b++) {
    const mo_body *B = &sc->body[b];
    double epmax = 0, psi = 0, wp = 0;
    json_t *o;
    size_t ns;
    if (!B->nl) continue;
    ns = (size_t)B->npoint * MO_J2_NSTATE;
    for (e = 0; e < B->mesh->nelem; e++) {
      const double *q = s->q + B->q0 + (size_t)e * ns;
      double vm, ep, p, w;
      if (mo_elem_nl_fields(B->mesh, e, B->mat, q, NULL, &vm, &ep) == MO_OK && ep > epmax) epmax = ep;
      if (mo_elem_nl_energy(B->mesh, e, B->mat, q, &p, &w) == MO_OK) {
        psi += p;
        wp += w;
      }
    }
    o = json_object();
    json_object_set_new(o, "max_eps_p", jnum(epmax));
    json_object_set_new(o, "plastic_work", jnum(wp));
    json_object_set_new(o, "stored_energy", jnum(psi));
    json_object_set_new(j, B->name, o);
  }
  return j;
}

/* Linear momentum of every body, p_b = sum over its dofs of (M v) per direction, into
   p[3 b + i] (zero for rigid planes and quasi-static scenes). work: ndof. The balance
   p(T) - p(0) = external impulse + contact impulse + support reactions is the check of a
   scene without a closed form (doc/architecture.md §11). */
static void body_momenta(const mo_scene *sc, const double *v, double *work, double *p)
{
  int b, a, i;
  for (i = 0; i < 3 * sc->nbody; i++) p[i] = 0;
  if (!sc->M || !v) return;
  mo_scene_gaxpy(sc, sc->M, 1, v, 0, work);
  for (b = 0; b < sc->nbody; b++) {
    const mo_body *B = &sc->body[b];
    if (B->type->flags & MO_BODY_F_RIGID) /* m v of the centroid */
      for (i = 0; i < sc->dim; i++) p[3 * b + i] = B->mass * v[B->dof0 + i];
    if (B->kind != MO_BODY_DEFORMABLE) continue;
    for (a = 0; a < B->mesh->nnode; a++)
      for (i = 0; i < sc->dim; i++) p[3 * b + i] += work[B->dof0 + a * sc->dim + i];
  }
}

/* A rigid body's entry of summary.json: mass, inertia, and where it ended. */
static void rigid_json(json_t *jb, const mo_scene *sc, const mo_body *B, const mo_state *s)
{
  json_t *J = json_array(), *x = json_array(), *v = json_array(), *w = json_array();
  int i, nr = sc->dim == 2 ? 1 : 3;
  double xc[3];
  json_object_set_new(jb, "mass", jnum(B->mass));
  if (sc->dim == 2) json_array_append_new(J, jnum(B->J[0]));
  else for (i = 0; i < 9; i++) json_array_append_new(J, jnum(B->J[i]));
  json_object_set_new(jb, "inertia", J);
  json_object_set_new(jb, "fixed", json_boolean(B->fixed));
  mo_rigid_center(sc, B, s, xc);
  for (i = 0; i < sc->dim; i++) {
    json_array_append_new(x, jnum(xc[i]));
    json_array_append_new(v, jnum(s ? s->v[B->dof0 + i] : 0));
  }
  for (i = 0; i < nr; i++) json_array_append_new(w, jnum(s ? s->v[B->dof0 + sc->dim + i] : 0));
  json_object_set_new(jb, "center_final", x);
  json_object_set_new(jb, "velocity_final", v);
  json_object_set_new(jb, "omega_final", w);
}

/* The number of bodies of B's group (1 for a body of its own). */
static int group_size(const mo_scene *sc, const mo_body *B)
{
  int b, n = 0;
  if (!B->group) return 1;
  /* a group's bodies are consecutive (one entry makes them) */
  for (b = (int)(B - sc->body); b < sc->nbody && sc->body[b].group && !strcmp(sc->body[b].group, B->group); b++) n++;
  return n;
}

/* One entry for the n bodies of a large group from B on (their table is bodies.csv): count,
   total mass, the box of their centres, the largest speed. */
static json_t *group_json(const mo_scene *sc, const mo_body *B, int n, const mo_state *s)
{
  json_t *jb = json_object(), *lo = json_array(), *hi = json_array();
  double mass = 0, xmin[3], xmax[3], vmax = 0;
  int k, i;
  for (i = 0; i < 3; i++) {
    xmin[i] = HUGE_VAL;
    xmax[i] = -HUGE_VAL;
  }
  for (k = 0; k < n; k++) {
    const mo_body *G = B + k;
    double xc[3], v2 = 0;
    mass += G->mass;
    mo_rigid_center(sc, G, s, xc);
    for (i = 0; i < sc->dim; i++) {
      xmin[i] = fmin(xmin[i], xc[i]);
      xmax[i] = fmax(xmax[i], xc[i]);
      if (s) v2 += s->v[G->dof0 + i] * s->v[G->dof0 + i];
    }
    vmax = fmax(vmax, sqrt(v2));
  }
  for (i = 0; i < sc->dim; i++) {
    json_array_append_new(lo, jnum(xmin[i]));
    json_array_append_new(hi, jnum(xmax[i]));
  }
  json_object_set_new(jb, "name", json_string(B->group));
  json_object_set_new(jb, "type", json_string(B->type->name));
  json_object_set_new(jb, "count", json_integer(n));
  json_object_set_new(jb, "mass", jnum(mass));
  json_object_set_new(jb, "center_min_final", lo);
  json_object_set_new(jb, "center_max_final", hi);
  json_object_set_new(jb, "speed_max_final", jnum(vmax));
  json_object_set_new(jb, "table", json_string("bodies.csv"));
  return jb;
}

/* bodies.csv: every rigid body's final state, one row each (name, group, mass, bounding radius,
   centre, velocity, angular velocity), the table of a granular scene. */
static int write_bodies_csv(const char *dir, const mo_scene *sc, const mo_state *s, mo_ctx *ctx)
{
  static const char *ax[3] = {"x", "y", "z"};
  char path[4200];
  mo_atomic_file A;
  int b, i, st, D = sc->dim, nr = D == 2 ? 1 : 3;
  snprintf(path, sizeof path, "%s/bodies.csv", dir);
  if ((st = mo_atomic_open(&A, path, ctx))) return st;
  fprintf(A.f, "name,group,mass,radius");
  for (i = 0; i < D; i++) fprintf(A.f, ",%s", ax[i]);
  for (i = 0; i < D; i++) fprintf(A.f, ",v%s", ax[i]);
  if (D == 2) fprintf(A.f, ",omega\n");
  else fprintf(A.f, ",wx,wy,wz\n");
  for (b = 0; b < sc->nbody; b++) {
    const mo_body *B = &sc->body[b];
    double xc[3];
    if (!(B->type->flags & MO_BODY_F_RIGID)) continue;
    mo_rigid_center(sc, B, s, xc);
    fprintf(A.f, "%s,%s,%.12g,%.12g", B->name, B->group ? B->group : "", B->mass, B->bound);
    for (i = 0; i < D; i++) fprintf(A.f, ",%.12g", xc[i]);
    for (i = 0; i < D + nr; i++) fprintf(A.f, ",%.12g", s ? s->v[B->dof0 + i] : 0.0);
    fputc('\n', A.f);
  }
  return mo_atomic_commit(&A, 1, ctx);
}

static int write_summary(const char *dir, const mo_case *cs, const mo_scene *sc,
                         const mo_stepper *S, const mo_state *s, const mo_contact *C,
                         const mo_contact_driver *drv, const mo_metrics *met, const column *cols, int ncol,
                         const char *const *names, double e0, double e1, double drift,
                         double balance, double growth, int complete, const char *reason,
                         double wall, double steps_wall, double first_step, const double *p0, const double *pend,
                         double eratio_end, long cuts, double dtmin, const char *blowup, double *work, long ncand,
                         mo_ctx *ctx)
{
  double *pw = NULL, *p1 = NULL, *pcm = NULL;
  int pw_fail = 0;
  json_t *root = json_object(), *scene = json_object(), *bodies = json_array(), *time = json_object();
  json_t *energy = json_object(), *metrics = json_object(), *skipped = json_array(), *ls = json_object();
  char path[4200];
  mo_atomic_file A;
  int b, k, st;
  long nf = 0, nsym = 0, nsol = 0;
  json_object_set_new(root, "moreau", json_string(PACKAGE_VERSION));
  json_object_set_new(root, "case", json_string(mo_case_file(cs)));
  json_object_set_new(root, "title", json_string(sc ? sc->title : ""));
  json_object_set_new(root, "status", json_string(complete ? "complete" : "incomplete"));
  if (!complete) json_object_set_new(root, "reason", json_string(reason ? reason : "unknown"));
  json_object_set_new(root, "settings", mo_case_to_json(cs));
  if (sc) {
    json_object_set_new(scene, "dim", json_integer(sc->dim));
    json_object_set_new(scene, "dofs", json_integer(sc->ndof));
    json_object_set_new(scene, "free_dofs", json_integer(sc->nfree));
    json_object_set_new(scene, "mass", jnum(sc->mass_total));
    json_object_set_new(scene, "hmin", jnum(mo_metrics_hmin(sc)));
    /* nnz(K) + nnz(M) of one process (over the ranks: parallel.matrix_entries) */
    if (sc->asm_entries && ctx->nranks == 1)
      json_object_set_new(scene, "matrix_entries", json_integer((json_int_t)sc->asm_entries[0]));
    if (p0 && s && sc->M) {
      /* the bodies' momenta at the end, beside p0 at the start (made when a body is deformable:
         only theirs are written) */
      pw = work ? work : mo_malloc(ctx, ((size_t)sc->ndof + 1) * sizeof *pw); /* the run's scratch */
      p1 = mo_malloc(ctx, (3 * (size_t)sc->nbody + 1) * sizeof *p1);
      /* pend: the momenta at the end, computed by every rank (a product with M) */
      if (pw && p1 && pend) memcpy(p1, pend, 3 * (size_t)sc->nbody * sizeof *p1);
      else pw_fail = 1;
      if (drv && pw && p1) {
        int on;
        long x1, x2, x3;
        double y1, y2, y3, y4;
        mo_contact_driver_correction(drv, &on, &x1, &y1, &y2, &x2, &x3, &y3, &y4, NULL);
        if (on == 1 && (pcm = mo_malloc(ctx, (3 * (size_t)sc->nbody + 1) * sizeof *pcm)))
          mo_contact_driver_correction(drv, &on, &x1, &y1, &y2, &x2, &x3, &y3, &y4, pcm);
      }
    }
    for (b = 0; b < sc->nbody; b++) {
      const mo_body *B = &sc->body[b];
      json_t *jb;
      int ng = group_size(sc, B);
      if (ng > MO_RIGID_COLUMNS_MAX && (B->type->flags & MO_BODY_F_RIGID)) {
        /* a pack of grains: one entry, the bodies in bodies.csv */
        json_array_append_new(bodies, group_json(sc, B, ng, s));
        b += ng - 1;
        continue;
      }
      jb = json_object();
      json_object_set_new(jb, "name", json_string(B->name));
      json_object_set_new(jb, "type", json_string(B->type->name));
      if (B->group) json_object_set_new(jb, "group", json_string(B->group));
      if (B->type->flags & MO_BODY_F_RIGID) rigid_json(jb, sc, B, s);
      if (B->kind == MO_BODY_DEFORMABLE) {
        json_object_set_new(jb, "element", json_string(mo_eltype_get(B->mesh->type)->name));
        json_object_set_new(jb, "nodes", json_integer(B->mesh->nnode));
        json_object_set_new(jb, "elements", json_integer(B->mesh->nelem));
        json_object_set_new(jb, "hypothesis", json_string(mo_hyp_name(B->mat->hyp)));
        json_object_set_new(jb, "mass", jnum(B->mass));
        if (pw && p1) {
          json_t *ji = json_array(), *jf = json_array();
          int i;
          for (i = 0; i < sc->dim; i++) {
            json_array_append_new(ji, jnum(p0[3 * b + i]));
            json_array_append_new(jf, jnum(p1[3 * b + i]));
          }
          json_object_set_new(jb, "momentum_initial", ji);
          json_object_set_new(jb, "momentum_final", jf);
          if (pcm) {
            /* what the position correction's energy compensation took (doc/theory.md (T96)):
               momentum_final - momentum_initial = contact impulses + external and support
               impulses + this */
            json_t *jc = json_array();
            for (i = 0; i < sc->dim; i++) json_array_append_new(jc, json_real(pcm[3 * b + i]));
            json_object_set_new(jb, "momentum_position_correction", jc);
          }
        }
      }
      json_array_append_new(bodies, jb);
    }
    json_object_set_new(scene, "bodies", bodies);
    json_object_set_new(root, "scene", scene);
    json_object_set_new(time, "scheme", json_string(time_scheme_name(&sc->time)));
    json_object_set_new(time, "dt", jnum(sc->time.dt));
    {
      /* the critical step of central differences (T102) and the scheme's stability (T101) */
      double dtc = mo_scene_dt_crit(sc, NULL, NULL), wh;
      char w[TIME_WARN_MAX][512];
      int nw = time_warnings(sc, w), stab, i;
      if (isfinite(dtc)) {
        json_object_set_new(time, "dt_crit", json_real(dtc));
        json_object_set_new(scene, "dt_crit", json_real(dtc));
        json_object_set_new(time, "dt_over_dt_crit", json_real(sc->time.dt / dtc));
        if (isfinite(mo_scene_dt_bound(sc))) json_object_set_new(time, "dt_bound", json_real(mo_scene_dt_bound(sc)));
      }
      if (sc->time.scheme == MO_SCHEME_THETA) {
        stab = mo_theta_stability(sc->time.theta, sc->time.theta_f, &wh);
        json_object_set_new(time, "stability", json_string(stab == MO_STAB_UNCONDITIONAL ? "unconditional"
                                                           : stab == MO_STAB_CONDITIONAL ? "conditional" : "unstable"));
        if (stab == MO_STAB_CONDITIONAL) json_object_set_new(time, "omega_h_max", json_real(wh));
      }
      if (nw || (blowup && blowup[0])) {
        json_t *jw = json_array();
        for (i = 0; i < nw; i++) json_array_append_new(jw, json_string(w[i]));
        if (blowup && blowup[0]) json_array_append_new(jw, json_string(blowup));
        json_object_set_new(root, "warnings", jw);
      }
    }
    json_object_set_new(time, "steps", json_integer(sc->time.steps));
    json_object_set_new(time, "end", jnum(sc->time.end));
    if (sc->time.scheme == MO_SCHEME_THETA) {
      json_object_set_new(time, "theta", jnum(sc->time.theta));
      json_object_set_new(time, "theta_f", jnum(sc->time.theta_f));
    } else if (sc->time.scheme == MO_SCHEME_NEWMARK) {
      json_object_set_new(time, "beta", jnum(sc->time.beta));
      json_object_set_new(time, "gamma", jnum(sc->time.gamma));
    }
    json_object_set_new(time, "steps_done", json_integer(s ? s->step : 0));
    if (sc->time.max_cuts > 0) {
      /* step cutting: how many steps were taken again in halves, and the smallest step */
      json_object_set_new(time, "cuts", json_integer(cuts));
      json_object_set_new(time, "smallest_dt", jnum(dtmin));
    }
    json_object_set_new(time, "t_reached", jnum(s ? s->t : 0));
    json_object_set_new(root, "time", time);
  } else {
    json_decref(scene);
    json_decref(bodies);
    json_decref(time);
  }
  json_object_set_new(energy, "initial", jnum(e0));
  json_object_set_new(energy, "final", jnum(e1));
  json_object_set_new(energy, "ratio", jnum(e0 != 0 ? e1 / e0 : NAN));
  if (!(e0 != 0))
    json_object_set_new(energy, "ratios", json_string("undefined: the initial energy is 0 (ratio and "
                                                      "balance_relative are null)"));
  json_object_set_new(energy, "max_relative_drift", jnum(drift));
  json_object_set_new(energy, "balance_error", jnum(balance));
  json_object_set_new(energy, "balance_relative", jnum(e0 != 0 ? balance / e0 : NAN));
  json_object_set_new(energy, "max_growth", jnum(growth));
  if (s) {
    json_object_set_new(energy, "external_work", jnum(s->wext));
    json_object_set_new(energy, "support_work", jnum(s->wsupport));
    json_object_set_new(energy, "contact_work", jnum(s->wcontact));
    if (sc && sc->nonlinear) {
      json_object_set_new(energy, "plastic", jnum(s->wplastic));
      json_object_set_new(energy, "stored", jnum(s->psi));
    }
  }
  json_object_set_new(root, "energy", energy);
  if (C && drv) json_object_set_new(root, "contact", contact_json(C, drv, ncand));
  for (k = 0; k < ncol; k++) {
    json_t *m;
    if (!cols[k].has_ref || cols[k].n == 0) continue;
    m = json_object();
    json_object_set_new(m, "l2_rel", jnum(cols[k].sr2 > 0 ? sqrt(cols[k].se2 / cols[k].sr2) : NAN));
    json_object_set_new(m, "linf_rel", jnum(cols[k].rmax > 0 ? cols[k].emax / cols[k].rmax : NAN));
    json_object_set_new(m, "linf_abs", jnum(cols[k].emax));
    json_object_set_new(m, "samples", json_integer(cols[k].n));
    json_object_set_new(metrics, names[k + 1], m);
  }
  if (sc && sc->ref.type != MO_REF_NONE) json_object_set_new(root, "reference", json_string(mo_reference_name(sc->ref.type)));
  if (met) {
    json_t *mj = mo_metrics_json(met);
    json_object_update(metrics, mj);
    json_decref(mj);
    if (s) json_object_set_new(energy, "ratio_mechanical", jnum(eratio_end));
  }
  if (sc && s && sc->out.nextent) json_object_set_new(metrics, "extents", extents_json(sc, s->u));
  if (sc && s && sc->nonlinear) json_object_set_new(metrics, "plasticity", plasticity_json(sc, s));
  json_object_set_new(root, "metrics", metrics);
  {
    const config_setting_t *rl = config_lookup(&cs->cfg, "output.report");
    if (rl) {
      json_t *r = json_array();
      int n = config_setting_type(rl) == CONFIG_TYPE_STRING ? 1 : config_setting_length(rl);
      for (k = 0; k < n; k++)
        json_array_append_new(r, json_string(config_setting_type(rl) == CONFIG_TYPE_STRING
                                                 ? config_setting_get_string(rl)
                                                 : config_setting_get_string_elem(rl, (unsigned)k)));
      json_object_set_new(root, "report", r);
    }
  }
  if (S && sc && sc->nonlinear) {
    const mo_newton_report *nr = mo_stepper_newton_report(S);
    json_t *nj = json_object();
    json_object_set_new(nj, "tol", jnum(sc->time.newton_tol));
    json_object_set_new(nj, "max_iter", json_integer(sc->time.newton_max));
    json_object_set_new(nj, "steps", json_integer(nr->steps));
    json_object_set_new(nj, "iterations_total", json_integer(nr->total));
    json_object_set_new(nj, "iterations_max", json_integer(nr->max));
    json_object_set_new(nj, "iterations_mean", jnum(nr->steps ? (double)nr->total / (double)nr->steps : 0));
    json_object_set_new(nj, "damped", json_integer(nr->damped));
    json_object_set_new(root, "newton", nj);
  }
  if (S && mo_stepper_solver((mo_stepper *)S)) {
    /* the nodal block of What (the deformable bodies); rigid bodies have their mass blocks */
    mo_linsolver_stats(mo_stepper_solver((mo_stepper *)S), &nf, &nsym, &nsol);
    json_object_set_new(ls, "name", json_string(mo_linsolver_name(mo_stepper_solver((mo_stepper *)S))));
    json_object_set_new(ls, "n", json_integer(sc->nfe_free));
    json_object_set_new(ls, "nnz", json_integer(mo_csc_nnz(mo_stepper_matrix(S))));
    json_object_set_new(ls, "factorizations", json_integer(nf));
    json_object_set_new(ls, "symbolic_analyses", json_integer(nsym));
    json_object_set_new(ls, "solves", json_integer(nsol));
    {
      /* what the factorization measured of itself (doc/theory.md (T154)) */
      mo_linsolver_info I;
      mo_linsolver_info_get(mo_stepper_solver((mo_stepper *)S), &I);
      if (I.nnz_L == I.nnz_L) {
        json_object_set_new(ls, "nnz_L", jnum(I.nnz_L));
        json_object_set_new(ls, "flops", jnum(I.flops));
        json_object_set_new(ls, "ordering", json_string(I.ordering ? I.ordering : "?"));
        json_object_set_new(ls, "supernodal", json_boolean(I.supernodal));
        json_object_set_new(ls, "long_indices", json_boolean(I.long_indices));
        json_object_set_new(ls, "contact_dofs_last", json_integer(I.trailing ? I.nlast : 0));
        json_object_set_new(ls, "analyze_seconds", jnum(I.t_analyze));
        json_object_set_new(ls, "numeric_seconds", jnum(I.t_numeric));
        if (I.two_solves == I.two_solves) json_object_set_new(ls, "two_solves_seconds", jnum(I.two_solves));
        json_object_set_new(ls, "bytes_factor", jnum(I.bytes_factor));
        json_object_set_new(ls, "bytes_workspace", jnum(I.bytes_work));
        json_object_set_new(ls, "bytes_delassus", jnum(I.bytes_reserve));
        json_object_set_new(ls, "bytes_before_factor", jnum(I.bytes_before));
        json_object_set_new(ls, "bytes_limit", jnum(I.bytes_limit));
        if (I.bytes_trailing > 0) json_object_set_new(ls, "bytes_contact_last_refused", jnum(I.bytes_trailing));
        if (I.bytes_in_core > 0) {
          /* MUMPS's own estimates (doc/theory.md (T181)) */
          json_object_set_new(ls, "bytes_mumps_in_core", jnum(I.bytes_in_core));
          json_object_set_new(ls, "bytes_mumps_out_of_core", jnum(I.bytes_out_of_core));
          json_object_set_new(ls, "out_of_core", json_boolean(I.out_of_core));
        }
      }
    }
    json_object_set_new(root, "linear_solver", ls);
  } else
    json_decref(ls);
  json_object_set_new(root, "timings", timings_json(ctx, wall, steps_wall, first_step));
  json_object_set_new(root, "parallel", parallel_json(ctx, sc));
  for (k = 0; k < ctx->nskip; k++) json_array_append_new(skipped, json_string(ctx->skipped[k]));
  json_object_set_new(root, "skipped", skipped);
  {
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru) == 0)
      json_object_set_new(root, "peak_rss_bytes", json_integer((json_int_t)ru.ru_maxrss * 1024));
    /* what the case was estimated at before building (T165) */
    json_object_set_new(root, "bytes_estimate", jnum(sc->bytes_estimate));
  }
  if (pw != work) mo_free(pw);
  mo_free(p1);
  mo_free(pcm);
  if (pw_fail) {
    json_decref(root);
    return mo_error(ctx, MO_ENOMEM, "cannot format summary.json");
  }
  /* bodies.csv first: summary.json is the last file a run writes */
  if (sc && sc->nrigid && (st = write_bodies_csv(dir, sc, s, ctx))) {
    json_decref(root);
    return st;
  }
  /* streamed to the file: a scene of 10^5 grains has a large summary */
  snprintf(path, sizeof path, "%s/summary.json", dir);
  if (!(st = mo_atomic_open(&A, path, ctx))) {
    int ok = json_dumpf(root, A.f, JSON_INDENT(2) | JSON_PRESERVE_ORDER | JSON_REAL_PRECISION(12)) == 0;
    if (ok) fputc('\n', A.f);
    st = mo_atomic_commit(&A, ok, ctx);
    if (!st && !ok) st = mo_error(ctx, MO_EOUTPUT, "cannot write '%s'", path);
  }
  json_decref(root);
  return st;
}

static void print_log(const mo_ctx *ctx, double wall)
{
  int p;
  fprintf(stderr, "\n%-10s %12s %7s %10s\n", "phase", "seconds", "share", "calls");
  for (p = 0; p < MO_PH_N; p++)
    fprintf(stderr, "%-10s %12.6f %6.1f%% %10ld\n", mo_phase_name((mo_phase)p), ctx->phase_time[p],
            wall > 0 ? 100 * ctx->phase_time[p] / wall : 0, ctx->phase_calls[p]);
  fprintf(stderr, "%-10s %12.6f\n", "wall", wall);
  fprintf(stderr, "\nwork this scene did not need:\n");
  if (!ctx->nskip) fprintf(stderr, "  (none)\n");
  for (p = 0; p < ctx->nskip; p++) fprintf(stderr, "  - %s\n", ctx->skipped[p]);
}

/* Export the problem the step's contact solve solved as an FCLIB file (--dump-fclib): its
   index set only (doc/theory.md (T80)), with that solve's solution, so that any FCLIB solver
   finds the reactions the step applied. */
static int dump_fclib(const char *dir, const mo_contact_driver *D, long step, mo_ctx *ctx)
{
  mo_solved_problem P;
  int st;
  char path[4200], title[128];
  const mo_contact_report *rep = mo_contact_last_report(D);
  if (rep->reason == MO_CR_NOCONTACT) return MO_OK;
  if ((st = mo_contact_driver_solved_problem(D, &P, ctx))) return st;
  if (P.d < 2) {
    mo_solved_problem_release(&P);
    mo_note_skip(ctx, "FCLIB export (1D frictionless contacts: FCLIB holds 2D and 3D problems)");
    return MO_OK;
  }
  snprintf(path, sizeof path, "%s/step-%06ld.hdf5", dir, step);
  snprintf(title, sizeof title, "moreau step %ld: %d of %d candidates (the index set)", step, P.n, P.ncand);
  st = mo_fclib_write_csc(path, P.d, P.n, P.W, P.q, P.mu, P.r, P.U, title, P.desc,
                          "U = W r + q, W = c H_A^T What^-1 H_A on the index set A (c = 1, or beta h^2 for Newmark); "
                          "r in K_mu, U + mu |U_t| e_n in K_mu^*, orthogonal (FCLIB's local Coulomb problem); "
                          "normal component first in every contact's frame",
                          ctx);
  mo_solved_problem_release(&P);
  return st;
}

/* ncand: the set's candidates (with the set distributed, every rank's). */
static json_t *contact_json(const mo_contact *C, const mo_contact_driver *D, long ncand)
{
  json_t *j = json_object();
  long steps, it, maxit, wb;
  double maxres;
  const mo_contact_report *rep = mo_contact_last_report(D);
  const mo_delassus *W = mo_contact_driver_delassus(D);
  mo_contact_driver_totals(D, &steps, &it, &maxit, &wb, &maxres);
  json_object_set_new(j, "solver", json_string(mo_contact_driver_type(D)->name));
  json_object_set_new(j, "pairs", json_integer(mo_contact_npairs(C)));
  json_object_set_new(j, "candidates", json_integer(ncand));
  if (ncand > mo_contact_nstatic(C) || mo_contact_alert(C) > 0) {
    /* detected candidates (rigid shapes): the last step's, and the alert distance */
    json_object_set_new(j, "candidates_detected", json_integer(ncand - mo_contact_nstatic(C)));
    if (D) json_object_set_new(j, "candidates_max", json_integer(mo_contact_driver_candidates_max(D)));
    json_object_set_new(j, "alert", jnum(mo_contact_alert(C)));
    {
      /* the broad phase's pair list (doc/theory.md (T110)): builds over the run, pairs now */
      long builds, npairs;
      if (mo_contact_broad_stats(C, &builds, &npairs)) {
        json_t *bp = json_object();
        json_object_set_new(bp, "builds", json_integer(builds));
        json_object_set_new(bp, "pairs", json_integer(npairs));
        json_object_set_new(bp, "compact", json_boolean(mo_contact_is_compact(C)));
        {
          /* the list kept by blocks (doc/theory.md §12.26): the blocks, and how many times one
             was made again between the whole builds */
          long made, nblock;
          if (mo_contact_broad_blocks(C, &made, &nblock)) {
            json_object_set_new(bp, "blocks", json_integer(nblock));
            json_object_set_new(bp, "blocks_made", json_integer(made));
          }
        }
        json_object_set_new(j, "broad", bp);
      }
    }
    {
      /* what the contact set and the driver hold (bytes, at their capacities; doc/theory.md §12.9) */
      json_t *mem = json_object();
      size_t pc = 0, pd = 0, set = mo_contact_bytes(C, &pc);
      json_object_set_new(mem, "set", json_integer((json_int_t)set));
      json_object_set_new(mem, "set_candidates", json_integer((json_int_t)pc));
      if (D) {
        size_t dr = mo_contact_driver_bytes(D, &pd);
        json_object_set_new(mem, "driver", json_integer((json_int_t)dr));
        json_object_set_new(mem, "driver_candidates", json_integer((json_int_t)(dr - pd)));
      }
      /* the distributed set: rank 0's own part (the process that writes the summary) */
      if (mo_contact_distributed(C)) json_object_set_new(mem, "held", json_string("rank 0's part of the set"));
      json_object_set_new(j, "memory", mem);
    }
  }
  json_object_set_new(j, "steps_with_contact", json_integer(steps));
  json_object_set_new(j, "iterations_total", json_integer(it));
  json_object_set_new(j, "iterations_max", json_integer(maxit));
  json_object_set_new(j, "iterations_mean", jnum(steps ? (double)it / (double)steps : 0));
  json_object_set_new(j, "residual_max", jnum(maxres));
  json_object_set_new(j, "delassus_builds", json_integer(wb));
  {
    /* the back end's own factorizations (levelset's Newton matrices) and the solves that
       reused kept factors (T86); absent for a back end that factors nothing */
    long nf, nreuse;
    mo_contact_driver_factor_totals(D, &nf, &nreuse);
    if (nf + nreuse > 0) {
      json_object_set_new(j, "factorizations", json_integer(nf));
      json_object_set_new(j, "factor_reuses", json_integer(nreuse));
    }
    /* the smoother sweeps of levelset's hybrid globalization (T144); absent without */
    if (mo_contact_driver_sweeps(D) > 0)
      json_object_set_new(j, "smoother_sweeps", json_integer(mo_contact_driver_sweeps(D)));
  }
  /* solves that did not converge and that contact.on_failure = "continue" let the run go on */
  json_object_set_new(j, "failed_solves", json_integer(mo_contact_driver_failures(D)));
  json_object_set_new(j, "index_set_additions", json_integer(mo_contact_driver_index_added(D)));
  if (W) {
    json_object_set_new(j, "delassus_blocks", json_integer(mo_delassus_nblocks(W)));
    json_object_set_new(j, "delassus_columns_kept", json_boolean(mo_delassus_has_columns(W)));
  }
  {
    /* the position correction of velocity-level theta steps (doc/theory.md (T95)) */
    int on;
    long pst, psw, pun;
    double pmax, pleft, epaid, eadded;
    json_t *pc = json_object();
    mo_contact_driver_correction(D, &on, &pst, &pmax, &pleft, &psw, &pun, &epaid, &eadded, NULL);
    json_object_set_new(pc, "method", json_string(on == 1 ? "project" : on == 2 ? "shift" : "none"));
    json_object_set_new(pc, "steps", json_integer(pst));
    json_object_set_new(pc, "max_removed", json_real(pmax));
    json_object_set_new(pc, "max_left", json_real(pleft));
    json_object_set_new(pc, "sweeps_max", json_integer(psw));
    json_object_set_new(pc, "unconverged", json_integer(pun));
    json_object_set_new(pc, "energy_from_kinetic", json_real(epaid));
    json_object_set_new(pc, "energy_added", json_real(eadded));
    json_object_set_new(j, "position_correction", pc);
  }
  json_object_set_new(j, "last_iterations", json_integer(rep->iterations));
  json_object_set_new(j, "last_residual", jnum(rep->residual));
  json_object_set_new(j, "last_reason", json_string(mo_contact_reason_name(rep->reason)));
  json_object_set_new(j, "last_open", json_integer(rep->nopen));
  json_object_set_new(j, "last_stick", json_integer(rep->nstick));
  json_object_set_new(j, "last_slide", json_integer(rep->nslide));
  {
    /* the checks of (T82) and (T84) */
    int nk, red, redmax, redsteps, mn;
    double rc, rcmin, eq = mo_contact_driver_equilibrium(D);
    if (eq == eq) json_object_set_new(j, "equilibrium_residual_max", json_real(eq));
    if (mo_contact_driver_redundancy(D, &nk, &red, &redmax, &redsteps, &rc, &rcmin, &mn)) {
      json_t *r = json_object();
      json_object_set_new(r, "last_unknowns", json_integer(nk));
      json_object_set_new(r, "last_redundant", json_integer(red));
      json_object_set_new(r, "last_rcond", json_real(rc));
      json_object_set_new(r, "max_redundant", json_integer(redmax));
      json_object_set_new(r, "steps_redundant", json_integer(redsteps));
      json_object_set_new(r, "min_rcond", json_real(rcmin));
      /* the rank of the closed set's problem, or (no rcond) only the count of its unknowns against
         the dofs of the bodies they touch: a lower bound of the redundancy */
      json_object_set_new(r, "measure", json_string(rc == rc ? "rank" : "count"));
      json_object_set_new(r, "reactions", json_string(red > 0 ? (mn ? "not unique: the minimum-norm ones"
                                                                         : "not unique: the ones the back end reached")
                                                          : rc != rc ? "no redundancy found by the count"
                                                          : redmax > 0 ? "unique at the last step" : "unique"));
      json_object_set_new(j, "redundancy", r);
    }
  }
  return j;
}

/* --- one step of the run, cut on failure (time.max_cuts, doc/theory.md §1.5) -------------- */

typedef struct {
  const mo_scene *sc;
  mo_stepper *S;
  mo_contact_driver *drv;
  mo_metrics *met;
  const char *dump;             /* --dump-fclib folder, or NULL */
  int max_cuts;
  mo_state save[MO_MAX_CUTS];   /* the state each level started from (allocated on first use) */
  mo_contact_snapshot *csave[MO_MAX_CUTS];
  long cuts;                    /* steps taken again as two halves */
  double hmin;                  /* the smallest step taken */
} stepping;

static void stepping_free(stepping *T)
{
  int k;
  for (k = 0; k < MO_MAX_CUTS; k++) {
    mo_state_release(&T->save[k]);
    mo_contact_snapshot_free(T->csave[k]);
  }
}

/* Failures a smaller step may cure: a contact solve or Newton that did not converge (status
   cycling included), a NaN, an inverted element, an indefinite iteration matrix. */
static int curable(int st)
{
  return st == MO_ENOCONV || st == MO_ENAN || st == MO_ESINGULAR;
}

static int one_step(stepping *T, mo_state *s, int cut, mo_ctx *ctx)
{
  int st;
  double t0;
  if (T->drv) {
    if ((st = mo_contact_step(T->drv, s, ctx))) return st;
    /* a cut step's substeps share their step number: their problems are not dumped */
    if (T->dump && !cut && ctx->rank == 0 && (st = dump_fclib(T->dump, T->drv, s->step, ctx))) return st;
  } else if ((st = mo_stepper_step(T->S, s, ctx)))
    return st;
  t0 = mo_clock();
  mo_metrics_step(T->met, s, T->drv);
  mo_phase_add(ctx, MO_PH_METRICS, t0);
  return MO_OK;
}

/* The step from s over h at cut level `level` (h = the case's step / 2^level). */
static int advance(stepping *T, mo_state *s, int level, double h, mo_ctx *ctx)
{
  int st, k;
  if ((st = mo_stepper_set_dt(T->S, h, ctx))) return st;
  if (h < T->hmin) T->hmin = h;
  if (level < T->max_cuts) {
    /* the state kept for step cutting */
    double t0 = mo_clock();
    if (!T->save[level].u && (st = mo_state_alloc(T->sc, &T->save[level], ctx))) return st;
    if (T->drv && !T->csave[level] && (st = mo_contact_snapshot_create(T->drv, &T->csave[level], ctx))) return st;
    mo_state_copy(T->sc, s, &T->save[level]);
    if (T->drv && (st = mo_contact_snapshot_save(T->drv, T->csave[level], ctx))) return st;
    mo_phase_add(ctx, MO_PH_METRICS, t0);
  }
  st = one_step(T, s, level > 0, ctx);
  /* the substeps of a cut step keep its number (take_step sets it when they are done) */
  if (!st && level > 0) s->step--;
  if (!st || !curable(st)) return st;
  if (level >= T->max_cuts) {
    if (T->max_cuts > 0) {
      char msg[MO_ERRMSG_MAX];
      snprintf(msg, sizeof msg, "%s", ctx->errmsg);
      mo_ctx_clear_error(ctx);
      return mo_error(ctx, st, "%s; step cutting stopped at its limit: h = %.6g after %d halvings "
                      "(time.max_cuts)", msg, h, level);
    }
    return st;
  }
  mo_log(ctx, 1, "%s; taken again as two steps of h = %.6g\n", ctx->errmsg, h / 2);
  mo_ctx_clear_error(ctx);
  mo_state_copy(T->sc, &T->save[level], s);
  if ((st = mo_stepper_restart(T->S, s, ctx))) return st;
  if (T->drv && (st = mo_contact_snapshot_restore(T->drv, T->csave[level], s, ctx))) return st;
  T->cuts++;
  for (k = 0; k < 2; k++)
    if ((st = advance(T, s, level + 1, h / 2, ctx))) return st;
  return MO_OK;
}

/* One step of the case's h; cut steps count as one (their time is set exactly). */
static int take_step(stepping *T, mo_state *s, mo_ctx *ctx)
{
  long n = s->step;
  double t = s->t, h = T->sc->time.dt;
  int st = advance(T, s, 0, h, ctx);
  if (!st && s->step != n + 1) {
    s->step = n + 1;
    s->t = t + h;
  }
  return st;
}

int mo_run(const mo_run_options *opt, mo_run_result *res, mo_ctx *ctx)
{
  mo_case *cs = NULL;
  mo_scene *sc = NULL;
  mo_stepper *S = NULL;
  mo_contact *C = NULL;
  mo_contact_driver *drv = NULL;
  mo_metrics *met = NULL;
  mo_state s;
  mo_csv *csv = NULL;
  mo_vtk *vtk = NULL;
  mo_vtk_contacts net;
  mo_vtk_points pts;
  mo_contact_history *chist = NULL;
  mo_draw *draw = NULL;
  column *cols = NULL;
  contact_view cv;
  char **names = NULL, *namebuf = NULL, outdir[4096], path[4200];
  double *row = NULL, *work = NULL, *p0 = NULL, *pend = NULL, eratio_end = NAN;
  double start = mo_clock(), e0 = 0, e1 = 0, drift = 0, balance = 0;
  double emax_growth = 0, egiven = 0, first_step = -1, eratio0 = 0, inner_start = mo_phase_total(ctx), tloop = 0, iloop = 0;
  int ratio_col = 1;
  int st, ncol = 0, nprobecol = 0, nexact = 0, k, p, complete = 0, ecol0 = 0, ccol0 = 0, table = 0, x0col;
  int nl = 0, necol = 0, ncol0 = 0, cutcol = 0, nvalcol = 0, nrigcol = 0, agcol = 0, pfcol = 0;
  int io = ctx->rank == 0, agreed = 0;
  long ncand = 0;                   /* the set's candidates at the end (summary.json) */
  int drawing = 0;                  /* the case draws (rank 0 decides the frames) */
  char reason[MO_ERRMSG_MAX] = "", blowup[512] = "";
  progress prog;
  stepping stepper;
  mo_outdir od;
  od.fd = -1;
  memset(&s, 0, sizeof s);
  memset(&stepper, 0, sizeof stepper);
  memset(res, 0, sizeof *res);
  memset(&prog, 0, sizeof prog);
  memset(&cv, 0, sizeof cv);
  memset(&net, 0, sizeof net);
  memset(&pts, 0, sizeof pts);

  if ((st = load_case(opt, &cs, ctx))) return st;
  if (opt->outdir) snprintf(outdir, sizeof outdir, "%s", opt->outdir);
  else default_outdir(opt->case_path, outdir, sizeof outdir);
  snprintf(res->outdir, sizeof res->outdir, "%s", outdir);
  if ((st = mo_scene_build(cs, &sc, ctx))) goto done;
  if ((st = mo_contact_build(sc, &C, ctx))) goto done;
  if (opt->solver && !C) mo_note_skip(ctx, "contact solve (--solver given, but the case has no contact pairs)");
  /* from here on the folder is this run's: locked, its old summary replaced by "running" */
  /* an MPI run: rank 0 writes every output, the other ranks compute the same steps with it
     (doc/parallel.md); they agree on the outcome before every collective step */
  if (io && (st = mo_outdir_claim(&od, outdir, mo_case_file(cs), ctx))) goto done;
  if (io && opt->dump_fclib && (st = mo_mkdir_p(opt->dump_fclib, ctx))) goto done;
  if ((st = mo_par_agree(st, ctx))) {
    agreed = 1;
    goto done;
  }
  if (C && (st = mo_contact_time_scheme(sc, C, ctx))) goto done;
  {
    /* the critical time step (T102) in the log; the explicit scheme warns above it (the
       theta-scheme's own warning was given when the case was read) */
    char w[TIME_WARN_MAX][512];
    int nw = time_warnings(sc, w), b, e, i;
    double dtc = mo_scene_dt_crit(sc, &b, &e);
    if (isfinite(dtc) && sc->time.scheme != MO_SCHEME_QUASISTATIC && (opt->log || ctx->verbosity >= 2))
      mo_log(ctx, 1, "critical time step of central differences dt_crit = %.6g (element %d of body '%s'); dt / dt_crit = %.4g\n",
             dtc, e, sc->body[b].name, sc->time.dt / dtc);
    for (i = 0; i < nw; i++)
      if (sc->time.explicit_cd) mo_log(ctx, 1, "%s: warning: %s\n", mo_case_file(cs), w[i]);
  }
  {
    /* the contact dofs last in the factorization (doc/theory.md §13) */
    const char *order = "contact_last";
    mo_case_lookup_string(cs, "contact.factor_order", &order);
    if (C && strcmp(order, "contact_last"))
      mo_note_skip(ctx, "the contact dofs last in the factorization (contact.factor_order = \"solver\")");
    if ((st = mo_stepper_create_contact(sc, C, !strcmp(order, "contact_last"), &S, ctx))) goto done;
  }
  if (C && (st = mo_contact_driver_create(sc, C, S, &drv, ctx))) goto done;
#if defined HAVE_MALLOC_H && defined HAVE_MALLOPT && defined M_MMAP_THRESHOLD
  /* (T235): the granular path's arrays over the candidates grow by a quarter as the set grows;
     glibc's mmap threshold, which rises to the largest mapped block freed, puts the grown blocks
     in the heap, where each old block stays resident as free space (about 50 bytes a candidate
     of the 10^4 pile's peak resident size). Mapped, a block grows by mremap and is returned whole
     when freed. Not for the FE paths: a Newton step's factorization allocates and frees blocks of
     this size at every iteration, which a fixed threshold would map and unmap each time (the
     system time of taylor-axisymmetric doubled). 16 kB rather than 64 (T280): at 10^3 grains the
     arrays of 8 to 20 bytes a candidate are 16 to 41 kB, and in the heap their grown blocks
     left 115 kB of free space resident at the peak. The environment's MALLOC_MMAP_THRESHOLD_
     wins. */
  if (opt->map_large && C && mo_contact_is_compact(C) && !getenv("MALLOC_MMAP_THRESHOLD_"))
    mallopt(M_MMAP_THRESHOLD, 16 * 1024);
#endif
  if (drv && opt->dump_fclib) mo_contact_driver_keep_delassus(drv);
  if ((st = mo_state_alloc(sc, &s, ctx))) goto done;
  if ((st = mo_stepper_init_state(S, &s, ctx))) goto done;
  /* (T248) a scene of rigid bodies and obstacles: the initial fields live in the state from here
     on; the scene's were read by the contact set's and the driver's first geometry (done) and by
     the cause of a non-finite value, which looks for an extreme one: released when there is none */
  if (!sc->nfe_dof && mo_finite_initial(sc) < 0) {
    mo_free(sc->u0);
    mo_free(sc->v0);
    sc->u0 = sc->v0 = NULL;
  }
  table = mo_case_lookup_bool(cs, "output.contact_table");
  /* the run's scratch, lent to the metrics too (their calls and the run's uses do not overlap):
     the energies' products with K and M, and the deformable bodies' momenta; none on a scene of
     rigid bodies and obstacles (T249) */
  if (mo_energy_needs_work(sc) && !(work = mo_calloc(ctx, (size_t)sc->ndof + 1, sizeof *work))) {
    st = MO_ENOMEM;
    goto done;
  }
  if ((st = mo_metrics_create(sc, C, drv, work, &met, ctx))) goto done;
  stepper.sc = sc;
  stepper.S = S;
  stepper.drv = drv;
  stepper.met = met;
  stepper.dump = opt->dump_fclib;
  stepper.max_cuts = sc->time.max_cuts;
  stepper.hmin = sc->time.dt;
  cv.C = C;
  cv.D = drv;

  /* columns: t, probes, rigid bodies (or their aggregates), the exact values, energies, contact */
  for (p = 0; p < sc->nprobe; p++) nprobecol += sc->probe[p].nq;
  if (moving_rigid(sc) <= MO_RIGID_COLUMNS_MAX) nrigcol = moving_rigid(sc) * (sc->dim == 2 ? 6 : 13);
  else mo_note_skip(ctx, "per-body history columns (%d moving rigid bodies, more than %d): rigid.* aggregates instead",
                    moving_rigid(sc), MO_RIGID_COLUMNS_MAX);
  nvalcol = nprobecol + nrigcol;
  if (!(cols = mo_calloc(ctx, (size_t)(nvalcol ? nvalcol : 1), sizeof *cols))) { st = MO_ENOMEM; goto done; }
  for (p = 0, k = 0; p < sc->nprobe; p++) {
    const mo_probe *P = &sc->probe[p];
    int q;
    for (q = 0; q < P->nq; q++, k++) {
      double dummy;
      cols[k].probe = p;
      cols[k].q = (int)P->q[q];
      cols[k].x = sc->body[P->body].mesh->x[P->node[0] * sc->dim];
      /* a closed form describes one body: compare the probes on it only */
      cols[k].has_ref = (sc->ref.body < 0 || P->body == sc->ref.body) &&
                        mo_reference_eval(&sc->ref, P->q[q], cols[k].x, 0, &dummy);
      nexact += cols[k].has_ref;
      if (P->q[q] >= MO_Q_CX && P->q[q] <= MO_Q_LAM && !C) {
        st = mo_error(ctx, MO_EINPUT, "%s: probe '%s' asks for '%s', but the case has no contact",
                      mo_case_file(cs), P->name, mo_quantity_name(P->q[q]));
        goto done;
      }
      if (P->q[q] >= MO_Q_CX && P->q[q] <= MO_Q_LAM && mo_contact_distributed(C)) {
        st = mo_error(ctx, MO_EUNSUPPORTED, "%s: probe '%s' asks for '%s', a contact value no rank holds whole "
                      "with contact.distributed_set (doc/scaling.md §4): drop the quantity, or the key",
                      mo_case_file(cs), P->name, mo_quantity_name(P->q[q]));
        goto done;
      }
      if (P->q[q] >= MO_Q_CX && P->q[q] <= MO_Q_CZ) cv.need_R = 1;
    }
  }
  if (C && mo_contact_distributed(C) && opt->dump_fclib) {
    st = mo_error(ctx, MO_EUNSUPPORTED, "%s: --dump-fclib writes the whole contact set's problems, which no rank "
                  "holds with contact.distributed_set (doc/scaling.md §4): run without one or the other",
                  mo_case_file(cs));
    goto done;
  }
  for (p = 0; nrigcol && p < sc->nrigid; p++) {
    int b = sc->rigid[p], q;
    if (sc->body[b].fixed) continue;
    for (q = 0; q < (sc->dim == 2 ? 6 : 13); q++, k++) {
      double dummy;
      cols[k].probe = -1;
      cols[k].body = b;
      cols[k].q = q;
      cols[k].has_ref = mo_reference_rigid(&sc->ref, sc, b, q, 0, &dummy);
      nexact += cols[k].has_ref;
    }
  }
  /* finite-strain scenes add energy.plastic and the Newton columns */
  nl = sc->nonlinear;
  /* energy.ratio only where it is defined: E0 != 0 (doc/case-format.md) */
  mo_metrics_step(met, &s, NULL);
  {
    double ek0 = NAN, ee0 = NAN;
    mo_metrics_energies(met, &s, &ek0, &ee0, &eratio0, NULL);
    ratio_col = isfinite(eratio0);
  }
  if (sc->out.energy && !ratio_col) mo_note_skip(ctx, "energy.ratio column (the initial energy is 0: no ratio)");
  necol = sc->out.energy ? 6 + ratio_col + nl : 0;
  ncol = 1 + nvalcol + nexact + necol + (C ? 8 : 0) + (nl ? 2 : 0);
  /* pairs with a rigid body: the force of each master on its slaves (a silo's walls, a floor) */
  if (C) {
    pfcol = ncol;
    for (k = 0; k < mo_contact_npairs(C); k++)
      if (mo_contact_pair_get(C, k)->law != MO_LAW_SIGNORINI) ncol += sc->dim;
    if (ncol == pfcol) pfcol = 0;
  }
  /* many rigid bodies: their aggregates */
  if (moving_rigid(sc) > MO_RIGID_COLUMNS_MAX) {
    agcol = ncol;
    ncol += 3 + sc->dim;
  }
  /* with step cutting, the steps cut so far (cumulative, so that output.every loses none) */
  if (sc->time.max_cuts > 0) cutcol = ncol++;
  names = mo_calloc(ctx, (size_t)ncol, sizeof *names);
  namebuf = mo_calloc(ctx, (size_t)ncol, 80);
  row = mo_calloc(ctx, (size_t)ncol, sizeof *row);
  if (!names || !namebuf || !row) { st = MO_ENOMEM; goto done; }
  for (k = 0; k < ncol; k++) names[k] = namebuf + 80 * k;
  snprintf(names[0], 80, "t");
  for (k = 0; k < nvalcol; k++)
    if (cols[k].probe >= 0)
      snprintf(names[1 + k], 80, "%s.%s", sc->probe[cols[k].probe].name, mo_quantity_name((mo_quantity)cols[k].q));
    else
      snprintf(names[1 + k], 80, "%.60s.%s", sc->body[cols[k].body].name, sc->dim == 2 ? rigid2[cols[k].q] : rigid3[cols[k].q]);
  if (agcol) {
    snprintf(names[agcol], 80, "rigid.kinetic");
    snprintf(names[agcol + 1], 80, "rigid.vmax");
    snprintf(names[agcol + 2], 80, "rigid.coordination");
    for (k = 0; k < sc->dim; k++) snprintf(names[agcol + 3 + k], 80, "rigid.%smax", k == 0 ? "x" : k == 1 ? "y" : "z");
  }
  if (pfcol)
    for (k = 0, p = pfcol; k < mo_contact_npairs(C); k++) {
      const mo_contact_pair *P = mo_contact_pair_get(C, k);
      int i;
      if (P->law == MO_LAW_SIGNORINI) continue;
      for (i = 0; i < sc->dim; i++) snprintf(names[p++], 80, "%.60s.f%c", P->name, "xyz"[i]);
    }
  if (cv.need_R && !(cv.Rfull = mo_calloc(ctx, (size_t)sc->ndof + 1, sizeof(double)))) { st = MO_ENOMEM; goto done; }
  x0col = 1 + nvalcol;
  for (k = 0, p = 0; k < nvalcol; k++)
    if (cols[k].has_ref) {
      cols[k].exact_col = x0col + p++;
      snprintf(names[cols[k].exact_col], 80, "%s.exact", names[1 + k]);
    } else
      cols[k].exact_col = -1;
  if (sc->out.energy) {
    ecol0 = 1 + nvalcol + nexact;
    snprintf(names[ecol0], 80, "energy.kinetic");
    snprintf(names[ecol0 + 1], 80, "energy.elastic");
    snprintf(names[ecol0 + 2], 80, "energy.total");
    snprintf(names[ecol0 + 3], 80, "energy.external_work");
    snprintf(names[ecol0 + 4], 80, "energy.support_work");
    snprintf(names[ecol0 + 5], 80, "energy.contact_work");
    if (ratio_col) snprintf(names[ecol0 + 6], 80, "energy.ratio");
    if (nl) snprintf(names[ecol0 + 6 + ratio_col], 80, "energy.plastic");
  }
  if (C) {
    ccol0 = 1 + nvalcol + nexact + necol;
    snprintf(names[ccol0], 80, "contact.closed");
    snprintf(names[ccol0 + 1], 80, "contact.iterations");
    snprintf(names[ccol0 + 2], 80, "contact.residual");
    snprintf(names[ccol0 + 3], 80, "contact.force_n");
    /* the back end's nested loops (contact.h: geometric, friction threshold, level set,
       Newton), zero for back ends without them */
    snprintf(names[ccol0 + 4], 80, "contact.loops_geometry");
    snprintf(names[ccol0 + 5], 80, "contact.loops_threshold");
    snprintf(names[ccol0 + 6], 80, "contact.loops_levelset");
    snprintf(names[ccol0 + 7], 80, "contact.loops_newton");
  }
  if (nl) {
    ncol0 = 1 + nvalcol + nexact + necol + (C ? 8 : 0);
    snprintf(names[ncol0], 80, "newton.iterations");
    snprintf(names[ncol0 + 1], 80, "newton.residual");
  } else
    mo_note_skip(ctx, "energy.plastic and newton.* columns (no finite-strain body)");
  if (cutcol) snprintf(names[cutcol], 80, "time.cuts");
  snprintf(path, sizeof path, "%s/history.csv", outdir);
  if (io && (st = mo_csv_open(path, (const char *const *)names, ncol, sc->out.precision, &csv, ctx))) goto done;
  res->outputs |= MO_OUT_HISTORY;
  /* VTK: every rank writes its pieces of the deformable bodies, rank 0 everything else */
  if (sc->out.vtk && (io || sc->nfe_dof > 0)) {
    if ((st = mo_vtk_open(outdir, sc, C != NULL, &vtk, ctx))) goto done;
  } else
    mo_note_skip(ctx, "field output (no output.vtk group)");
  if (sc->out.contact_history && C && mo_contact_distributed(C)) {
    st = mo_error(ctx, MO_EUNSUPPORTED, "%s: output.contact_history is not written with contact.distributed_set "
                  "(doc/scaling.md §4): leave one of them out", mo_case_file(cs));
    goto done;
  }
  if (sc->out.contact_history && C && io) {
    snprintf(path, sizeof path, "%s/contact_history.csv", outdir);
    if ((st = mo_contact_history_open(path, sc, C, sc->out.contact_history_closed, &chist, ctx))) goto done;
    res->outputs |= MO_OUT_CONTACT_HISTORY;
  } else if (sc->out.contact_history)
    mo_note_skip(ctx, "contact_history.csv (output.contact_history, but the case has no contact pairs)");
  if (opt->no_draw) {
    if (config_lookup(&cs->cfg, "output.draw"))
      mo_note_skip(ctx, "drawings (output.draw: left to single runs, not the runs of a comparison)");
  } else {
    if (io && (st = mo_draw_open(outdir, sc, cs, &draw, ctx))) goto done;
    drawing = config_lookup(&cs->cfg, "output.draw") != NULL; /* on every rank (draw: rank 0's) */
  }
  if (!sc->nprobe) mo_note_skip(ctx, "probe histories (no output.probes)");
  if (!C) mo_note_skip(ctx, "contact (no contact pairs)");
  /* the distributed set: the steps' outputs gather to rank 0 (collectives), so the ranks start only
     once rank 0's files are open (a rank 0 that failed to open one waits in done) */
  if (C && mo_contact_distributed(C) && (st = mo_par_agree(MO_OK, ctx))) {
    agreed = 1;
    goto done;
  }

  prog.on = io && opt->progress && isatty(2) && ctx->verbosity >= 1;
  /* everything before the first step that no phase took (reading and checking the case, the
     contact set, the output folder, the metrics) is set-up */
  mo_phase_rest(ctx, MO_PH_SETUP, start, inner_start);
  prog.start = prog.last = mo_clock();
  e0 = mo_energy_kinetic(sc, &s, work) + mo_energy_stored(sc, &s, work) + s.wplastic;
  egiven = load_scale(sc);
  /* the bodies' momenta at the start, for summary.json's deformable bodies (none: no p0, and no
     momenta at the end either) */
  for (k = 0; k < sc->nbody && sc->body[k].kind != MO_BODY_DEFORMABLE; k++) {}
  if (k < sc->nbody) {
    if (!(p0 = mo_malloc(ctx, (3 * (size_t)sc->nbody + 1) * sizeof *p0))) {
      st = MO_ENOMEM;
      goto done;
    }
    body_momenta(sc, s.v, work, p0);
  }

  for (;;) {
    int last = s.step == sc->time.steps, write_row = s.step % sc->out.every == 0 || last;
    double t0 = mo_clock(), ek = NAN, ee = NAN, eratio, excess, growth;
    int vframe = vtk && (s.step % sc->out.vtk_every == 0 || last), dframe = draw && mo_draw_wants(draw, s.step);
    const int *hlist = NULL;
    const unsigned char *hcount = NULL;
    int nhlist = 0;
    const int held = C && mo_contact_held(C, NULL, &hlist, &nhlist, &hcount);
    if (C && mo_contact_distributed(C)) {
      /* the distributed set: every rank's contacts gathered to rank 0's frames (doc/scaling.md §4),
         the series' frames the case's, the drawing's rank 0's (its schedule depends on its
         gnuplot), told to the others only where the case draws */
      vframe = sc->out.vtk && (s.step % sc->out.vtk_every == 0 || last);
      if (drawing && (st = mo_par_bcast(&dframe, (long)sizeof dframe, 0, ctx))) goto done;
    }
    if (held) {
      /* the bodies' state per rank (doc/theory.md §13.18): the kinetic energy summed over the
         ranks' counted bodies; every body's state joined where an output reads it (the frames, the
         probes' and the bodies' columns, the run's end) */
      ek = mo_rigid_kinetic_list(sc, &s, hlist, nhlist, hcount);
      ee = 0; /* rigid bodies only */
      if ((st = mo_par_sum(&ek, 1, ctx))) goto done;
      if ((last || vframe || dframe || ((write_row || nexact) && nvalcol)) && (st = mo_contact_state_join(C, &s, ctx)))
        goto done;
    }
    /* energies at every step, not only on the rows written: the growth and drift the summary
       reports (and `moreau compare` classifies runs on) must not depend on output.every */
    mo_metrics_energies(met, &s, &ek, &ee, &eratio, &excess);
    /* no NaN or infinity in the outputs: the state and the energies at every step, the row
       before it is written (finite.c, doc/theory.md §10.3) */
    if ((st = held ? mo_finite_bodies(sc, &s, hlist, nhlist, ctx) : mo_finite_state(sc, &s, ctx)) ||
        (st = check_energies(sc, &s, ek, ee, ctx)))
      goto done;
    e1 = ek + ee + s.wplastic; /* (T65): the plastic work is energy the body took */
    if (e0 > 0 && fabs(e1 - e0) / e0 > drift) drift = fabs(e1 - e0) / e0;
    /* an infinite growth is kept as the largest double: JSON has no infinity, and a blow-up
       must not read as "no growth" (doc/theory.md §1.7) */
    /* the growth over E_ref; a scene at rest at t = 0 (E_ref = 0: a deposit, a body loaded from
       rest) over the largest work given it so far, so that the energy its contacts or its scheme
       made is growth there too (doc/theory.md (T49a)): a pile whose contacts blew it up read 0 */
    if (fabs(s.wext) + fabs(s.wsupport) > egiven) egiven = fabs(s.wext) + fabs(s.wsupport);
    growth = isfinite(eratio) ? eratio - 1 : egiven > 0 ? excess / egiven : 0;
    if (growth > emax_growth) emax_growth = fmin(growth, DBL_MAX);
    balance = e1 - e0 - s.wext - s.wsupport - s.wcontact;
    if (!blowup[0] && (isfinite(eratio) ? eratio > MO_BLOWUP_GROWTH : growth > MO_BLOWUP_GIVEN)) {
      /* a scheme past its stability limit (T101)-(T102), or contacts that make energy: said
         once, in the log and summary.json (the run goes on until its end or the NaN the stepper
         refuses) */
      if (isfinite(eratio))
        snprintf(blowup, sizeof blowup, "blow-up at step %ld (t = %.6g): the energy reached %.3g times its initial "
                 "value (more than %.0e): the time scheme is unstable at this step (dt = %.6g%s)", s.step, s.t, eratio,
                 MO_BLOWUP_GROWTH, mo_stepper_dt(S), sc->time.explicit_cd ? "; see dt_crit, doc/theory.md (T102)"
                 : "; doc/theory.md (T101)");
      else
        snprintf(blowup, sizeof blowup, "blow-up at step %ld (t = %.6g): the bodies were at rest at t = 0, and the "
                 "energy they hold beyond the work given them reached %.3g times that work (more than %.0e): "
                 "energy made by the contact solves or the time scheme (dt = %.6g; doc/theory.md (T49a))",
                 s.step, s.t, growth, MO_BLOWUP_GIVEN, mo_stepper_dt(S));
      mo_log(ctx, 1, "%s: warning: %s\n", mo_case_file(cs), blowup);
    }
    /* the probes with an exact value at every step (their errors), the others on the rows
       written; the nodal contact forces when a probe reads them */
    if (cv.need_R && drv && (write_row || nexact)) {
      double sc_f = sc->time.scheme == MO_SCHEME_THETA ? 1 / mo_contact_driver_dt(drv) : 1;
      if ((st = mo_contact_H_ensure(C, &s, ctx))) goto done;
      mo_csc_gaxpy(mo_contact_H_full(C), sc_f, mo_contact_reactions(drv), 0, cv.Rfull);
    }
    for (k = 0; k < nvalcol; k++) {
      double v, r;
      int has;
      if (!write_row && !cols[k].has_ref) continue;
      if (cols[k].probe >= 0) {
        v = probe_value(sc, &sc->probe[cols[k].probe], (mo_quantity)cols[k].q, &s, &cv);
        has = cols[k].has_ref && mo_reference_eval(&sc->ref, (mo_quantity)cols[k].q, cols[k].x, s.t, &r);
      } else {
        v = rigid_value(sc, &s, cols[k].body, cols[k].q);
        has = cols[k].has_ref && mo_reference_rigid(&sc->ref, sc, cols[k].body, cols[k].q, s.t, &r);
      }
      row[1 + k] = v;
      row[1 + k] = v;
      /* a contact force is a step's impulse over its length: nothing to compare before the
         first step */
      if (has && s.step == 0 && cols[k].probe >= 0 && cols[k].q >= MO_Q_CX && cols[k].q <= MO_Q_LAM) {
        row[cols[k].exact_col] = r;
        has = 0;
      }
      if (has) {
        row[cols[k].exact_col] = r;
        double e = fabs(v - r);
        cols[k].se2 += e * e;
        cols[k].sr2 += r * r;
        if (e > cols[k].emax) cols[k].emax = e;
        if (fabs(r) > cols[k].rmax) cols[k].rmax = fabs(r);
        cols[k].n++;
      }
    }
    if (write_row) {
      row[0] = s.t;
      if (sc->out.energy) {
        row[ecol0] = ek;
        row[ecol0 + 1] = ee;
        row[ecol0 + 2] = ek + ee + s.wplastic;
        row[ecol0 + 3] = s.wext;
        row[ecol0 + 4] = s.wsupport;
        row[ecol0 + 5] = s.wcontact;
        if (ratio_col) row[ecol0 + 6] = eratio;
        if (nl) row[ecol0 + 6 + ratio_col] = s.wplastic;
      }
      if (nl) {
        const mo_newton_report *nr = mo_stepper_newton_report(S);
        row[ncol0] = s.step ? nr->iterations : 0;
        row[ncol0 + 1] = s.step && nr->nres ? nr->res[nr->nres - 1] : 0;
      }
      if (C) {
        const mo_contact_report *rep = drv ? mo_contact_last_report(drv) : NULL;
        /* the step's normal forces, not those its candidates carry to the next geometry */
        double fsum = drv ? mo_contact_normal_force(drv) : 0;
        row[ccol0] = rep && s.step ? rep->nstick + rep->nslide : 0;
        row[ccol0 + 1] = rep && s.step ? rep->iterations : 0;
        row[ccol0 + 2] = rep && s.step ? rep->residual : 0;
        row[ccol0 + 3] = fsum;
        for (k = 0; k < 4; k++) row[ccol0 + 4 + k] = rep && s.step ? rep->loops[k] : 0;
      }
      if (pfcol) {
        const double *pf = drv ? mo_contact_pair_forces(drv) : NULL;
        int i, q = pfcol;
        for (k = 0; k < mo_contact_npairs(C); k++)
          if (mo_contact_pair_get(C, k)->law != MO_LAW_SIGNORINI)
            for (i = 0; i < sc->dim; i++) row[q++] = pf && s.step ? pf[3 * k + i] : 0;
      }
      if (cutcol) row[cutcol] = (double)stepper.cuts;
      if (agcol && (st = rigid_aggregates(sc, &s, &cv, hlist, nhlist, held ? hcount : NULL, ek, row + agcol, ctx)))
        goto done;
      if ((st = mo_finite_row(sc, &s, row, (const char *const *)names, ncol, ctx))) goto done;
      if (csv && (st = mo_csv_row(csv, row, ctx))) goto done;
    }
    {
      /* fields and drawings (frames decided above), with the contact network of the step when
         they need it */
      int vpoints = vframe && (C && mo_contact_distributed(C) ? sc->out.vtk_contacts != MO_VTK_CONTACTS_NONE
                                                              : vtk && mo_vtk_wants_points(vtk));
      if ((vframe || dframe) && (st = mo_contact_network(sc, C, drv, &s, &net, ctx))) goto done;
      if (vpoints &&
          (st = mo_contact_points(sc, C, drv, &s, sc->out.vtk_contacts == MO_VTK_CONTACTS_CLOSED, &pts, ctx)))
        goto done;
      if (vframe && vtk && (st = mo_vtk_frame(vtk, sc, &s, &net, &pts, ctx))) goto done;
      /* the candidates of the step, every output.contact_history.every steps */
      if (chist && drv && (s.step % sc->out.contact_history_every == 0 || last) &&
          (st = mo_contact_history_write(chist, sc, C, drv, &s, ctx)))
        goto done;
      if (dframe && draw && (st = mo_draw_frame(draw, sc, &s, &net, ctx))) goto done;
      /* (the distributed set: the frame's gathered contacts freed once written) */
      mo_vtk_source_drop(&net.src);
      mo_vtk_source_drop(&pts.src);
    }
    progress_draw(&prog, s.step, sc->time.steps, s.t, last, drv);
    {
      /* every rank's outputs of the step went through (rank 0's disk may be full), and an
         interrupt stops every rank at the same step (mpirun passes SIGINT to each) */
      int mine = !last && ctx->interrupt && *ctx->interrupt ? MO_EINTERRUPT : MO_OK;
      if (mine) mo_error(ctx, MO_EINTERRUPT, "interrupted at step %ld (t = %.6g)", s.step, s.t);
      if ((st = mo_par_agree(mine, ctx))) {
        agreed = 1;
        goto done;
      }
    }
    /* the collections list a frame once every rank's pieces of it are there */
    if (vtk && (st = mo_vtk_index(vtk, sc, ctx))) goto done;
    mo_phase_add(ctx, MO_PH_OUTPUT, t0);
    if (last) break;
    {
      double ts = mo_clock();
      st = take_step(&stepper, &s, ctx);
      res->step_wall += mo_clock() - ts;
      if (first_step < 0) first_step = res->step_wall;
      if (st) goto done;
    }
  }
  complete = 1;
  tloop = mo_clock();
  iloop = mo_phase_total(ctx);

done:
  /* a rank that failed alone tells the others, which wait for it at the step's agreement */
  if (!agreed && ctx->nranks > 1) {
    st = mo_par_agree(st, ctx);
    if (st) complete = 0;
  }
  /* the bodies' state per rank: a run stopped early writes its summary and bodies.csv from every
     body's state too (every rank is here, past the agreement; a complete run joined at its last
     step) */
  if (!complete && C && mo_contact_held(C, NULL, NULL, NULL, NULL)) {
    int sj = mo_contact_state_join(C, &s, ctx);
    if (sj && !st) st = sj;
  }
  if (prog.on && !complete) fputc('\n', stderr);
  if (csv) mo_csv_close(csv, ctx);
  if (chist) {
    int stc = mo_contact_history_close(chist, ctx);
    if (stc && !st) st = stc;
  }
  if (tloop > 0) mo_phase_rest(ctx, MO_PH_OUTPUT, tloop, iloop); /* closing the histories */
  res->steps = s.step;
  res->t = s.t;
  res->wall = mo_clock() - start;
  res->energy0 = e0;
  res->energy1 = e1;
  res->complete = complete;
  for (k = 0; k < nvalcol && res->nmetric < 32; k++)
    if (cols && cols[k].has_ref && cols[k].n) {
      snprintf(res->metric_name[res->nmetric], 64, "%s", names[1 + k]);
      res->metric_l2[res->nmetric] = cols[k].sr2 > 0 ? sqrt(cols[k].se2 / cols[k].sr2) : NAN;
      res->metric_linf[res->nmetric] = cols[k].rmax > 0 ? cols[k].emax / cols[k].rmax : NAN;
      res->nmetric++;
    }
  /* the summary (and the contact table) are written whenever this run holds the output folder,
     also after a failure: they describe the last good step. summary.json comes last: until it
     is in place the folder's summary says "running" (mo_outdir_claim); when it cannot be
     written (a full disk) the folder is left without one, never with an old "complete". */
  /* what summary.json reports from products with K and M, by every rank (over the ranks they
     are sums: doc/parallel.md §3), before rank 0 writes it */
  if (sc && s.u && met) eratio_end = mo_metrics_energy_ratio(met, &s);
  ncand = C ? mo_contact_ncandidates(C) : 0;
  if (C && mo_contact_distributed(C)) {
    /* the distributed set (doc/scaling.md §4): the ranks' contact measures joined on every rank, the
       set's candidates summed, and their contacts sent to rank 0's contact.csv (rank 0 gathers them
       in mo_contact_write_csv) */
    double nsum = (double)ncand;
    int stj = met ? mo_metrics_join(met, ctx) : MO_OK;
    if (!stj) stj = mo_par_sum(&nsum, 1, ctx);
    ncand = (long)nsum;
    if (stj && !st) {
      st = stj;
      complete = 0;
    }
    if (!io && drv && s.u && s.step > 0) mo_contact_write_csv(NULL, sc, C, drv, &s, ctx);
  }
  if (sc && s.u && p0 && sc->M && work && (pend = mo_malloc(ctx, (3 * (size_t)sc->nbody + 1) * sizeof *pend)))
    body_momenta(sc, s.v, work, pend);
  if (cs && sc && od.fd >= 0) {
    int keep = ctx->status, st2 = MO_OK;
    char msg[MO_ERRMSG_MAX];
    snprintf(msg, sizeof msg, "%s", ctx->errmsg);
    mo_ctx_clear_error(ctx);
    if (drv && s.u && s.step > 0) {
      snprintf(path, sizeof path, "%s/contact.csv", outdir);
      st2 = mo_contact_write_csv(path, sc, C, drv, &s, ctx);
      if (!st2) res->outputs |= MO_OUT_CONTACT;
      if (!st2 && table && ctx->verbosity >= 1 && !mo_contact_distributed(C))
        mo_contact_print_table(stdout, sc, C, drv, &s, ctx);
    }
    /* the drawings of the frames taken, also after a failure (the error kept is the run's) */
    if (draw) {
      int st3 = mo_draw_finish(draw, sc, ctx);
      if (st3 && !st2) st2 = st3;
      if (!st3) res->outputs |= MO_OUT_DRAW;
    }
    if (st2 && !keep) {
      keep = st2;
      complete = res->complete = 0;
      snprintf(msg, sizeof msg, "%s", ctx->errmsg);
    }
    snprintf(reason, sizeof reason, "%s", msg);
    mo_ctx_clear_error(ctx);
    st2 = write_summary(outdir, cs, sc, S, s.u ? &s : NULL, C, drv, met, cols, cols ? nvalcol : 0,
                        (const char *const *)names, e0, e1, drift, balance, emax_growth, complete, reason,
                        res->wall, res->step_wall, first_step, p0, pend, eratio_end, stepper.cuts, stepper.hmin,
                        blowup, work, ncand, ctx);
    if (st2) {
      /* the "running" summary must not outlive the run */
      snprintf(path, sizeof path, "%s/summary.json", outdir);
      remove(path);
    } else {
      res->summary = 1;
      res->outputs |= MO_OUT_SUMMARY | (sc->nrigid ? MO_OUT_BODIES : 0u);
    }
    if (keep) {
      st = keep;
      ctx->status = keep;
      snprintf(ctx->errmsg, sizeof ctx->errmsg, "%s", msg);
    } else if (st2) {
      st = st2;
      res->complete = 0;
    }
  }
  if (met && C && s.step > 0) {
    /* a persistent contact that chatters (doc/theory.md (T93)): the displacements may look
       right while the contact velocity and pressure alternate every step */
    mo_chatter ch;
    mo_metrics_chatter(met, &ch);
    if (ch.chatter) {
      const char *bk = drv ? mo_contact_driver_type(drv)->name : "";
      mo_log(ctx, 1,
             "%s: warning: the contact chatters: %s; the normal velocity of a bearing candidate alternated %ld "
             "times (summary.json metrics.contact.chatter; doc/theory.md (T97), (T93)). %s\n",
             opt->case_path, ch.why, ch.alternations,
             !strcmp(bk, "newmark") ? "Newmark's displacement-level contact oscillates (BDZ07 Fig. 4); nscd and levelset "
                                      "with velocity-level Signorini keep [v_n] = 0"
             : sc->time.scheme == MO_SCHEME_THETA && position_level(cs)
                 ? "Position-level Signorini at theta near 1/2 answers a landing by its opposite velocity every step; "
                   "contact.signorini = \"velocity\" (the default) does not"
                 : "A smaller time step, or a larger theta, damps it");
    }
  }
  mo_outdir_release(&od);
  if (vtk) {
    res->vtk_frames = mo_vtk_frames(vtk);
    if (res->vtk_frames) res->outputs |= mo_vtk_outputs(vtk);
  }
  if (opt->log && sc) print_log(ctx, res->wall);
  mo_vtk_close(vtk);
  mo_vtk_contacts_release(&net);
  mo_vtk_points_release(&pts);
  mo_draw_free(draw);
  stepping_free(&stepper);
  mo_metrics_free(met);
  mo_free(cols);
  mo_free(names);
  mo_free(namebuf);
  mo_free(row);
  mo_free(work);
  mo_free(p0);
  mo_free(pend);
  mo_free(cv.Rfull);
  mo_state_release(&s);
  mo_contact_driver_free(drv);
  mo_contact_free(C);
  mo_stepper_free(S);
  mo_scene_free(sc);
  mo_case_free(cs);
  return st;
}
