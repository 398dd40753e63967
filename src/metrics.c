/* metrics.c: space-time errors against the closed forms, and the contact measures every back
   end is compared on: penetration, normal velocity jump in contact, oscillation index, status
   flips, release time, impulse, energy after each impact (doc/theory.md §10). */
#include "config.h"
#include "metrics.h"
#include <moreau/parallel.h>

#include <math.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>

#define MAX_IMPACTS 64

/* One candidate's history, carried from set to set by its key: what the contact measures of every
   law read, its two values (16 bytes) and its counts and flags in one word (4 bytes) beside them
   (doc/theory.md (T242)). */
typedef struct {
  double Unprev;             /* the normal relative velocity of the previous step */
  double tv;                 /* the total variation of U_n while closed */
} cand_hist;
#define MO_NSIGN_MAX ((1u << 28) - 1) /* at most one sign change a step: reached after 2.7e8 steps */
typedef struct {
  unsigned nsign : 28;       /* the sign changes of U_n while closed (T97), up to MO_NSIGN_MAX */
  unsigned prevstatus : 2;   /* the status of the previous step (MO_CS_*: 0, 1, 2) */
  unsigned incontact : 1;    /* in contact at the previous step */
  unsigned landed : 1;       /* it has borne once (its first landing is behind) */
} cand_flags;

struct mo_metrics {
  const mo_scene *sc;
  const mo_contact *C;
  double *work;              /* ndof: the run's scratch, or its own (own_work) */
  int own_work;
  double e0, eshift;         /* E(0), and the shift to the reference's exact energy */
  /* field errors (1D bars against a bar reference) */
  int fields;
  double eu2, ru2, ev2, rv2, eh2, rh2;     /* sums over steps of squared L2 (H1) norms */
  double eumax, rumax, evmax, rvmax;      /* max over steps of the L2 norms */
  long nfield;
  /* contact */
  int nc, d;                 /* candidates: those of the last step (static ones first) */
  int cap;                   /* capacity of the per-candidate arrays: detected ones come and go */
  cand_hist *hist;           /* per candidate */
  cand_flags *hf;            /* per candidate: its counts and flags */
  /* the chatter detector's (T93), for the laws it watches (Signorini, the gap law) only: NULL
     when no pair has one of them (granular scenes under Moreau's impact law) */
  int watch_any;
  double *dUp;               /* the last increment of U_n between bearing steps (0: none) (T93) */
  double *alt;               /* per candidate: alternations of the sign of that increment (T93) */
  long cset;                 /* the candidate set the arrays follow (mo_contact_set_version) */
  int bydrv;                 /* the set is followed by the driver's remap (mo_contact_driver_remap):
                                no keys, key map nor map of their own */
  long restarts;             /* new sets the driver's remap did not reach: the histories restarted */
  int *keys;                 /* without the driver: its keys, to carry a detected candidate's history
                                to the next set */
  mo_keymap kmap;
  int *map;                  /* remapping: each candidate's place in the old set (-1: new) */
  double tv_gone;            /* the largest variation of the candidates that left the set */
  long unmeasured;           /* steps left out of the contact measures (no memory to follow the set) */
  double max_pen, max_vn_closed, vscale, impulse, first_release, t_prev;
  double uscale;             /* the largest |U| (every component) of a candidate at a step (T50) */
  double lscale;             /* the smallest element edge, or without one the smallest rigid body */
  double vround;             /* the largest round-off speed 1e-9 lscale / h of the steps (T50) */
  double final_pen;          /* the largest penetration of the last step measured */
  double vland;              /* the largest approach speed |U_n| of a step before any landing of a watched
                                candidate (T93); the chatter verdict's V is vimpact (T97) */
  double alt_max;            /* the most alternations of one candidate, including those gone (T93) */
  double max_vn_watch, vscale_watch; /* max_vn_in_contact and velocity_scale over the watched laws */
  double vfloor;             /* the round-off speed 1e-9 h_min / h of the last step (T93) */
  double vimpact;            /* the largest approach |U_n| of a candidate's first landing (the
                                step before it bears) */
  int nsign_gone;            /* the most sign changes of the candidates that left the set */
  long flips;
  int closed_prev;           /* number of candidates in contact at the previous step */
  double gtol;               /* a gap above this is open (1e-9 of the smallest element) */
  int nimpact, nimpact_total;    /* the first MAX_IMPACTS are listed, all are counted */
  double impact_energy[MAX_IMPACTS], impact_time[MAX_IMPACTS], last_impact_energy, last_impact_time;
  int started;
};

static double restitution(const mo_metrics *M);

void mo_metrics_free(mo_metrics *M)
{
  if (!M) return;
  if (M->own_work) mo_free(M->work);
  mo_free(M->hist);
  mo_free(M->hf);
  mo_free(M->dUp);
  mo_free(M->alt);
  mo_free(M->keys);
  mo_free(M->map);
  mo_keymap_free(&M->kmap);
  mo_free(M);
}

double mo_metrics_hmin(const mo_scene *sc)
{
  double hmin = HUGE_VAL, h;
  int b;
  for (b = 0; b < sc->nbody; b++)
    if (sc->body[b].kind == MO_BODY_DEFORMABLE) {
      mo_mesh_edge_range(sc->body[b].mesh, &h, NULL);
      if (h < hmin) hmin = h;
    }
  return hmin;
}

/* Room for nc candidates in the per-candidate arrays (contents kept); 0 on failure. */
static int room(mo_metrics *M, int nc, mo_ctx *ctx)
{
  size_t n, old = (size_t)M->cap;
  void *p;
  if (nc <= M->cap && M->hist) return 1;
  n = mo_contact_room(M->C, (size_t)nc) + 1; /* the contact set's capacity (T252); one slot over it (cap is n - 1) */
#define GROW(ptr, k) if (!(p = mo_realloc(ctx, ptr, (k) * sizeof *(ptr)))) return 0; ptr = p
  GROW(M->hist, n); GROW(M->hf, n);
  if (!M->bydrv) {
    GROW(M->map, n); GROW(M->keys, n * MO_KEY);
  }
  if (M->watch_any) {
    GROW(M->dUp, n); GROW(M->alt, n);
    memset(M->dUp + old, 0, (n - old) * sizeof *M->dUp);
    memset(M->alt + old, 0, (n - old) * sizeof *M->alt);
  }
#undef GROW
  memset(M->hist + old, 0, (n - old) * sizeof *M->hist);
  memset(M->hf + old, 0, (n - old) * sizeof *M->hf); /* MO_CS_OPEN is 0 */
  M->cap = (int)n - 1;
  return 1;
}

/* Candidate o's history to place a. */
static void move_hist(mo_metrics *M, int a, int o)
{
  M->hist[a] = M->hist[o];
  M->hf[a] = M->hf[o];
  if (M->dUp) {
    M->dUp[a] = M->dUp[o];
    M->alt[a] = M->alt[o];
  }
}

/* After a new detection: the per-candidate histories carried to the new set by key (a new
   candidate starts open, with no history; one that left keeps its variation in tv_gone), through
   the driver's remap of the same two sets (bydrv) or the metrics' own key map. 0 on failure (the
   histories are then restarted). */
static int follow(mo_metrics *M, const mo_contact_driver *D)
{
  const mo_contact *C = M->C;
  int nold = M->nc, nc = mo_contact_ncandidates(C), a, ok, mono = 1, last = -1, lost = 0;
  const int *dmap = NULL;
  cand_hist *copy = NULL;
  cand_flags *fcopy = NULL;
  double *wcopy = NULL;
#define OLD(a) (lost ? -1 : dmap ? dmap[a] : M->map[a])
  ok = room(M, nc > nold ? nc : nold, NULL);
  if (ok && M->bydrv) {
    dmap = D ? mo_contact_driver_remap(D, M->cset, mo_contact_set_version(C)) : NULL;
    if (!dmap && nold) M->restarts++;
    lost = !dmap;
  } else if (ok)
    ok = !mo_keymap_build(&M->kmap, M->keys, nold, NULL);
  if (!ok) nold = 0, lost = 1;
  for (a = 0; a < nold; a++) {
    if (M->hist[a].tv > M->tv_gone) M->tv_gone = M->hist[a].tv;
    if ((int)M->hf[a].nsign > M->nsign_gone) M->nsign_gone = (int)M->hf[a].nsign;
    if (M->alt && M->alt[a] > M->alt_max) M->alt_max = M->alt[a];
  }
  if (lost) nold = 0;
  nc = nc < M->cap ? nc : M->cap;
  /* each candidate's place in the old set, in increasing order so far (the detection's) */
  for (a = 0; a < nc; a++) {
    int o;
    if (!M->bydrv) M->map[a] = nold ? mo_keymap_find(&M->kmap, mo_contact_key(C, a)) : -1;
    o = OLD(a);
    if (o >= 0 && o <= last) mono = 0;
    if (o >= 0) last = o;
  }
  if (nold && !mono) {
    /* out of order: from a copy of the moment (none: the histories restart) */
    copy = mo_malloc(NULL, (size_t)nold * sizeof *copy);
    fcopy = mo_malloc(NULL, (size_t)nold * sizeof *fcopy);
    wcopy = M->dUp ? mo_malloc(NULL, 2 * (size_t)nold * sizeof *wcopy) : NULL;
    if (!copy || !fcopy || (M->dUp && !wcopy)) {
      ok = 0;
      lost = 1;
    } else {
      memcpy(copy, M->hist, (size_t)nold * sizeof *copy);
      memcpy(fcopy, M->hf, (size_t)nold * sizeof *fcopy);
      if (M->dUp) {
        memcpy(wcopy, M->dUp, (size_t)nold * sizeof *wcopy);
        memcpy(wcopy + nold, M->alt, (size_t)nold * sizeof *wcopy);
      }
      for (a = 0; a < nc; a++) {
        int o = OLD(a);
        if (o < 0) continue;
        M->hist[a] = copy[o];
        M->hf[a] = fcopy[o];
        if (M->dUp) {
          M->dUp[a] = wcopy[o];
          M->alt[a] = wcopy[nold + o];
        }
      }
    }
  } else {
    /* in place: those that move down from the front, those that move up from the back */
    for (a = 0; a < nc; a++)
      if (OLD(a) > a) move_hist(M, a, OLD(a));
    for (a = nc - 1; a >= 0; a--)
      if (OLD(a) >= 0 && OLD(a) < a) move_hist(M, a, OLD(a));
  }
  /* a new candidate starts open, with no history */
  for (a = 0; a < nc; a++)
    if (OLD(a) < 0) {
      memset(&M->hist[a], 0, sizeof M->hist[a]);
      memset(&M->hf[a], 0, sizeof M->hf[a]);
      if (M->dUp) M->dUp[a] = M->alt[a] = 0;
    }
#undef OLD
  mo_free(copy);
  mo_free(fcopy);
  mo_free(wcopy);
  if (nc && !M->bydrv) memcpy(M->keys, mo_contact_key(C, 0), (size_t)nc * MO_KEY * sizeof *M->keys);
  M->nc = nc;
  M->cset = mo_contact_set_version(C);
  return ok;
}

/* The smallest element edge of the deformable bodies, else the smallest rigid body (radius or
   bounding radius), else 1: the length whose 1e-9 part a step moves by round-off (T50). */
static double length_scale(const mo_scene *sc)
{
  double L = mo_metrics_hmin(sc);
  int k;
  if (isfinite(L) && L > 0) return L;
  L = HUGE_VAL;
  for (k = 0; k < sc->nrigid; k++) {
    const mo_body *B = &sc->body[sc->rigid[k]];
    double r = B->kind == MO_BODY_DISK || B->kind == MO_BODY_SPHERE ? B->radius : B->bound;
    if (r > 0 && r < L) L = r;
  }
  return isfinite(L) ? L : 1;
}

/* The oscillation index's velocity scale (T50): the largest relative velocity of a contact
   point, every component, not below the round-off speed (a sliding or resting contact whose
   U_n is round-off does not make its own round-off the scale). */
static double oscillation_scale(const mo_metrics *M)
{
  return M->uscale > M->vround ? M->uscale : M->vround;
}

static double oscillation_index(const mo_metrics *M)
{
  double osc = M->tv_gone, V = oscillation_scale(M);
  int a;
  for (a = 0; a < M->nc; a++) if (M->hist[a].tv > osc) osc = M->hist[a].tv;
  return V > 0 ? osc / V : 0;
}

int mo_metrics_create(const mo_scene *sc, const mo_contact *C, const mo_contact_driver *D, double *work,
                      mo_metrics **out, mo_ctx *ctx)
{
  mo_metrics *M = mo_calloc(ctx, 1, sizeof *M);
  const mo_reference *R = &sc->ref;
  *out = NULL;
  if (!M) return MO_ENOMEM;
  M->sc = sc;
  M->C = C;
  /* the energies' work vector: none on a scene of rigid bodies and obstacles (T249) */
  M->own_work = !work && mo_energy_needs_work(sc);
  M->work = work ? work : M->own_work ? mo_calloc(ctx, (size_t)sc->ndof + 1, sizeof(double)) : NULL;
  if (M->own_work && !M->work) { mo_metrics_free(M); return MO_ENOMEM; }
  M->first_release = NAN;
  M->fields = R->type != MO_REF_NONE && R->type != MO_REF_ENERGY && R->type < MO_REF_BOUNCE && R->body >= 0 &&
              sc->body[R->body].kind == MO_BODY_DEFORMABLE && sc->body[R->body].mesh->dim == 1;
  if (C) {
    int k;
    M->d = mo_contact_dim(C);
    M->nc = mo_contact_ncandidates(C);
    for (k = 0; k < mo_contact_npairs(C); k++) {
      mo_contact_law law = mo_contact_pair_get(C, k)->law;
      M->watch_any |= law == MO_LAW_SIGNORINI || law == MO_LAW_GAP;
    }
    M->cset = mo_contact_set_version(C);
    M->bydrv = D != NULL;
    if (!room(M, M->nc, ctx)) { mo_metrics_free(M); return MO_ENOMEM; }
    if (M->nc && !M->bydrv) memcpy(M->keys, mo_contact_key(C, 0), (size_t)M->nc * MO_KEY * sizeof *M->keys);
    M->gtol = 1e-9 * mo_metrics_hmin(sc);
    M->lscale = length_scale(sc);
  }
  *out = M;
  return MO_OK;
}

static double mech_energy(const mo_metrics *M, const mo_state *s)
{
  const mo_scene *sc = M->sc;
  double e = mo_energy_kinetic(sc, s, M->work) + mo_energy_elastic(sc, s->u, M->work);
  /* finite-strain bodies: their stored energy and the plastic work they took (T65) */
  if (sc->nonlinear) e += s->psi + s->wplastic;
  return e - s->wext - s->wsupport;
}

double mo_metrics_energy_ratio(const mo_metrics *M, const mo_state *s)
{
  double e = mech_energy(M, s) + M->eshift, e0 = M->e0 + M->eshift;
  return e0 != 0 ? e / e0 : NAN;
}

void mo_metrics_energies(const mo_metrics *M, const mo_state *s, double *ek, double *ee, double *ratio, double *excess)
{
  double e0 = M->e0 + M->eshift, e;
  if (isnan(*ek)) *ek = mo_energy_kinetic(M->sc, s, M->work);
  if (isnan(*ee)) *ee = mo_energy_stored(M->sc, s, M->work); /* elastic, and finite-strain bodies' stored */
  /* the plastic work is energy the bodies took (T65), as in mech_energy */
  e = *ek + *ee + (M->sc->nonlinear ? s->wplastic : 0) - s->wext - s->wsupport + M->eshift;
  *ratio = e0 != 0 ? e / e0 : NAN;
  if (excess) *excess = e - e0;
}

/* Squared L2 norms over the reference body (2-point Gauss per bar element) of u_h - u, u,
   v_h - v, v, and of the strain difference (H1 seminorm). */
static void field_step(mo_metrics *M, const mo_state *s)
{
  const mo_scene *sc = M->sc;
  const mo_reference *R = &sc->ref;
  const mo_body *B = &sc->body[R->body];
  const mo_mesh *m = B->mesh;
  static const double gp[2] = {-0.5773502691896257645, 0.5773502691896257645};
  double eu = 0, ru = 0, ev = 0, rv = 0, eh = 0, rh = 0;
  int e, q;
  for (e = 0; e < m->nelem; e++) {
    int a = m->conn[2 * e], b = m->conn[2 * e + 1];
    double xa = m->x[a], xb = m->x[b], Le = xb - xa;
    double ua = s->u[B->dof0 + a], ub = s->u[B->dof0 + b], va = s->v[B->dof0 + a], vb = s->v[B->dof0 + b];
    double eps_h = (ub - ua) / Le;
    for (q = 0; q < 2; q++) {
      double w = 0.5 * fabs(Le), Na = 0.5 * (1 - gp[q]), Nb = 0.5 * (1 + gp[q]);
      double x = Na * xa + Nb * xb, u, v, ep, uh = Na * ua + Nb * ub, vh = Na * va + Nb * vb;
      mo_reference_field(R, x, s->t, &u, &v, &ep);
      eu += w * (uh - u) * (uh - u);
      ru += w * u * u;
      ev += w * (vh - v) * (vh - v);
      rv += w * v * v;
      eh += w * (eps_h - ep) * (eps_h - ep);
      rh += w * ep * ep;
    }
  }
  M->eu2 += eu; M->ru2 += ru; M->ev2 += ev; M->rv2 += rv; M->eh2 += eh; M->rh2 += rh;
  if (sqrt(eu) > M->eumax) M->eumax = sqrt(eu);
  if (sqrt(ru) > M->rumax) M->rumax = sqrt(ru);
  if (sqrt(ev) > M->evmax) M->evmax = sqrt(ev);
  if (sqrt(rv) > M->rvmax) M->rvmax = sqrt(rv);
  M->nfield++;
}

void mo_metrics_step(mo_metrics *M, const mo_state *s, const mo_contact_driver *D)
{
  const mo_scene *sc = M->sc;
  int a, closed = 0;
  if (!M->started) {
    M->e0 = mech_energy(M, s);
    M->eshift = isnan(sc->ref.energy) ? 0 : sc->ref.energy - M->e0;
    M->started = 1;
  }
  if (M->fields) field_step(M, s);
  if (!M->C) return;
  {
    const mo_contact *C = M->C;
    const double *g = mo_contact_gaps(C), *U0 = mo_contact_U0(C);
    const int *st = D ? mo_contact_statuses(D) : NULL;
    double vfloor;
    const double *r = D ? mo_contact_reactions(D) : NULL, *Up;
    int ns;
    int d = M->d;
    double h = D ? mo_contact_driver_dt(D) : sc->time.dt;
    if (M->cset != mo_contact_set_version(C)) follow(M, D);
    /* U = H^T v + U0: the relative velocity at the end of the step, whatever the scheme */
    if (M->nc != mo_contact_ncandidates(C)) { /* out of memory in follow: the step is not measured */
      M->unmeasured++;
      return;
    }
    /* the detected candidates' U- of the next step, H^T v + U0 at this geometry, is the driver's
       (the same sum, to the bit, where U0 = 0): taken from it, the others computed candidate by
       candidate (Un below) */
    Up = D ? mo_contact_driver_uprev(D, s) : NULL;
    ns = mo_contact_nstatic(C);
    M->final_pen = 0;
    /* below this a velocity moves a point by less than the gap tolerance (1e-9 h_min) in a step:
       round-off, never an impact speed (T93) */
    vfloor = h > 0 && isfinite(M->gtol) ? M->gtol / h : 0;
    M->vfloor = vfloor;
    if (h > 0 && 1e-9 * M->lscale / h > M->vround) M->vround = 1e-9 * M->lscale / h;
    /* the impulse's factor of a reaction (theta: r is an impulse already), read once (T294) */
    const double fimp = sc->time.scheme == MO_SCHEME_THETA ? 1 : h;
    for (a = 0; a < M->nc; a++) {
      cand_hist *H = &M->hist[a];
      cand_flags *F = &M->hf[a];
      static const double none[3] = {0, 0, 0}; /* U0 when no obstacle moves */
      const double *u0 = U0 ? U0 + (size_t)a * d : none;
      double Un[3], un;
      int i, zero = Up && a >= ns;
      /* without U0 every obstacle is still: no entry to test (T294) */
      for (i = 0; U0 && i < d && zero; i++) zero = u0[i] == 0;
      if (zero)
        for (i = 0; i < d; i++) Un[i] = Up[a * d + i];
      else
        mo_contact_Htx1(C, s, s->v, a, NULL, Un);
      un = Un[0] + u0[0];
      /* bearing: a compressive reaction. The jump of the normal velocity and its variation
         are measured between two bearing steps (the landing step is the impact itself); a
         release is the first step with no reaction and an open gap after bearing. Detected
         candidates (rigid shapes) carry their history from set to set by key. */
      int inc = s->step > 0 && r && r[a * d] > 0;
      /* the chatter detector (T93) watches the position-level laws' candidates: Signorini pairs
         (deformable; position or velocity level, and Newmark's) and the gap law, not Moreau's
         impact law between rigid bodies, whose rattling grains are not this mode */
      int watch = 0;
      if (M->watch_any) {
        const mo_contact_law law = mo_contact_law_of(C, a);
        watch = law == MO_LAW_SIGNORINI || law == MO_LAW_GAP;
      }
      if (watch && fabs(un) > M->vscale_watch) M->vscale_watch = fabs(un);
      if (-g[a] > M->max_pen) M->max_pen = -g[a];
      if (-g[a] > M->final_pen) M->final_pen = -g[a];
      if (fabs(un) > M->vscale) M->vscale = fabs(un);
      {
        double u2 = 0;
        int l;
        for (l = 0; l < d; l++) u2 += (Un[l] + u0[l]) * (Un[l] + u0[l]);
        if (sqrt(u2) > M->uscale) M->uscale = sqrt(u2);
      }
      if (inc) {
        closed++;
        if (F->incontact) {
          /* chatter measures: the increments of U_n between bearing steps that exceed 1e-2 of
             the landing speed and how often their sign alternates (T93, reported); the sign
             changes of U_n itself above a floor (T97, the verdict's) */
          double du = un - H->Unprev, thr = 1e-2 * (M->vland > vfloor ? M->vland : vfloor);
          double floor = MO_CHATTER_VN_FLOOR * (M->vimpact > M->vscale ? M->vimpact : M->vscale);
          if (fabs(un) > M->max_vn_closed) M->max_vn_closed = fabs(un);
          if (watch && fabs(un) > M->max_vn_watch) M->max_vn_watch = fabs(un);
          H->tv += fabs(du);
          if (watch && fabs(du) > thr) {
            if (M->dUp[a] != 0 && (du > 0) != (M->dUp[a] > 0)) M->alt[a] += 1;
            M->dUp[a] = du;
          } else if (M->dUp)
            M->dUp[a] = 0;
          if ((un > floor && H->Unprev < -floor) || (un < -floor && H->Unprev > floor)) {
            if (F->nsign < MO_NSIGN_MAX) F->nsign++;
          }
        } else {
          /* a landing: the approach speed of the step before it (any landing: T93; the
             candidate's first landing: T97, later ones may be the chatter's own bounces) */
          if (watch && fabs(H->Unprev) > M->vland) M->vland = fabs(H->Unprev);
          if (!F->landed && -H->Unprev > M->vimpact) M->vimpact = -H->Unprev;
          if (M->dUp) M->dUp[a] = 0;
        }
        F->landed = 1;
      } else if (F->incontact && g[a] > M->gtol && isnan(M->first_release))
        M->first_release = s->t;
      if (s->step > 0 && st) {
        if (st[a] != (int)F->prevstatus) M->flips++;
        F->prevstatus = (unsigned)st[a] & 3u;
      }
      /* a bearing contact stays "in contact" through steps that close the gap without
         reaction (grazing), so that chatter at a closed gap is not a release */
      F->incontact = (unsigned)(inc || (F->incontact && g[a] <= M->gtol));
      H->Unprev = un;
      if (r && s->step > 0)
        M->impulse += r[a * d] * fimp;
    }
    /* the distributed set: every rank's bearing candidates, summed at the step's end (each rank
       measures its own candidates; doc/scaling.md §4) */
    if (D && mo_contact_distributed(C)) closed = s->step > 0 ? (int)mo_contact_driver_bearing_all(D) : 0;
    /* the end of an impact: every candidate open again after some were closed */
    if (M->closed_prev > 0 && closed == 0) {
      M->last_impact_energy = mo_metrics_energy_ratio(M, s);
      M->last_impact_time = s->t;
      M->nimpact_total++;
      if (M->nimpact < MAX_IMPACTS) {
        M->impact_energy[M->nimpact] = M->last_impact_energy;
        M->impact_time[M->nimpact++] = s->t;
      }
    }
    M->closed_prev = closed;
  }
}

int mo_metrics_join(mo_metrics *M, mo_ctx *ctx)
{
  /* maxima (a minimum as its negation, none as -inf), then sums; the per-candidate maxima of the
     reports folded into their "gone" fields first, so that each rank's own candidates count */
  double x[16], y[4];
  int a, st;
  if (!M->C || !mo_contact_distributed(M->C)) return MO_OK;
  for (a = 0; a < M->nc; a++) {
    if (M->hist[a].tv > M->tv_gone) M->tv_gone = M->hist[a].tv;
    if ((int)M->hf[a].nsign > M->nsign_gone) M->nsign_gone = (int)M->hf[a].nsign;
    if (M->alt && M->alt[a] > M->alt_max) M->alt_max = M->alt[a];
  }
  {
    /* the maxima of doubles, through one table */
    double *const mx[] = {&M->max_pen, &M->final_pen, &M->max_vn_closed, &M->vscale, &M->uscale, &M->vround,
                          &M->vland, &M->alt_max, &M->max_vn_watch, &M->vscale_watch, &M->vfloor, &M->vimpact,
                          &M->tv_gone};
    const int nm = (int)(sizeof mx / sizeof *mx);
    for (a = 0; a < nm; a++) x[a] = *mx[a];
    x[nm] = M->nsign_gone;
    x[nm + 1] = isnan(M->first_release) ? -HUGE_VAL : -M->first_release;
    y[0] = M->impulse;
    y[1] = (double)M->flips;
    y[2] = (double)M->unmeasured;
    y[3] = (double)M->restarts;
    if ((st = mo_par_max(x, nm + 2, ctx)) || (st = mo_par_sum(y, 4, ctx))) return st;
    for (a = 0; a < nm; a++) *mx[a] = x[a];
    M->nsign_gone = (int)x[nm];
    M->first_release = x[nm + 1] == -HUGE_VAL ? NAN : -x[nm + 1];
  }
  M->impulse = y[0];
  M->flips = (long)y[1];
  M->unmeasured = (long)y[2];
  M->restarts = (long)y[3];
  return MO_OK;
}

void mo_metrics_chatter(const mo_metrics *M, mo_chatter *ch)
{
  double alt = M->alt_max;
  int a;
  memset(ch, 0, sizeof *ch);
  if (!M->C) return;
  for (a = 0; M->alt && a < M->nc; a++) if (M->alt[a] > alt) alt = M->alt[a];
  /* no landing seen (the run started in contact): the largest |U_n| stands for it */
  ch->vimpact = M->vland > 0 ? M->vland : M->vscale_watch;
  if (ch->vimpact < M->vfloor) ch->vimpact = M->vfloor;
  ch->alternations = (long)alt;
  ch->ratio = ch->vimpact > 0 ? M->max_vn_watch / ch->vimpact : 0;
  {
    /* the verdict is compare's (T97): one criterion for the warning of a run and the class of
       a comparison */
    mo_chatter_input in;
    mo_metrics_chatter_input(M, &in);
    ch->chatter = mo_chatter_verdict(&in, ch->why, sizeof ch->why);
  }
}

json_t *mo_metrics_json(const mo_metrics *M)
{
  json_t *j = json_object();
  const mo_reference *R = &M->sc->ref;
  if (M->fields && M->nfield) {
    json_t *f = json_object();
    json_object_set_new(f, "u_l2l2_rel", json_real(M->ru2 > 0 ? sqrt(M->eu2 / M->ru2) : NAN));
    json_object_set_new(f, "v_l2l2_rel", json_real(M->rv2 > 0 ? sqrt(M->ev2 / M->rv2) : NAN));
    json_object_set_new(f, "u_linfl2_rel", json_real(M->rumax > 0 ? M->eumax / M->rumax : NAN));
    json_object_set_new(f, "v_linfl2_rel", json_real(M->rvmax > 0 ? M->evmax / M->rvmax : NAN));
    json_object_set_new(f, "u_l2h1_rel", json_real(M->rh2 > 0 ? sqrt(M->eh2 / M->rh2) : NAN));
    json_object_set_new(j, "field", f);
  }
  if (M->C) {
    json_t *c = json_object(), *imp = json_array(), *impt = json_array();
    double tref = mo_reference_release_time(R);
    int a, k;
    json_object_set_new(c, "max_penetration", json_real(M->max_pen));
    json_object_set_new(c, "final_penetration", json_real(M->final_pen));
    {
      double hmin = mo_metrics_hmin(M->sc);
      if (isfinite(hmin) && hmin > 0) {
        json_object_set_new(c, "max_penetration_elements", json_real(M->max_pen / hmin));
        json_object_set_new(c, "final_penetration_elements", json_real(M->final_pen / hmin));
      }
    }
    json_object_set_new(c, "max_vn_in_contact", json_real(M->max_vn_closed));
    {
      mo_chatter ch;
      mo_metrics_chatter(M, &ch);
      json_object_set_new(c, "chatter_alternations", json_integer((json_int_t)ch.alternations));
      json_object_set_new(c, "chatter_ratio", json_real(ch.ratio));
      json_object_set_new(c, "chatter", json_boolean(ch.chatter));
    }
    json_object_set_new(c, "velocity_scale", json_real(M->vscale));
    json_object_set_new(c, "oscillation_index", json_real(oscillation_index(M)));
    json_object_set_new(c, "oscillation_scale", json_real(oscillation_scale(M)));
    json_object_set_new(c, "impact_velocity", json_real(M->vimpact));
    json_object_set_new(c, "restitution", json_real(restitution(M)));
    {
      int ns = M->nsign_gone;
      for (a = 0; a < M->nc; a++) if ((int)M->hf[a].nsign > ns) ns = (int)M->hf[a].nsign;
      json_object_set_new(c, "vn_sign_changes", json_integer(ns));
    }
    json_object_set_new(c, "status_flips", json_integer(M->flips));
    if (M->unmeasured) json_object_set_new(c, "steps_not_measured", json_integer(M->unmeasured));
    if (M->restarts) json_object_set_new(c, "history_restarts", json_integer(M->restarts));
    json_object_set_new(c, "release_time", json_real(M->first_release));
    if (!isnan(tref)) {
      json_object_set_new(c, "release_time_exact", json_real(tref));
      json_object_set_new(c, "release_time_error", json_real(M->first_release - tref));
    }
    json_object_set_new(c, "impulse", json_real(M->impulse));
    {
      double iref = mo_reference_impulse(R, M->sc->time.end);
      if (!isnan(iref) && iref != 0) {
        json_object_set_new(c, "impulse_exact", json_real(iref));
        json_object_set_new(c, "impulse_error", json_real((M->impulse - iref) / iref));
      }
    }
    for (k = 0; k < M->nimpact; k++) {
      json_array_append_new(imp, json_real(M->impact_energy[k]));
      json_array_append_new(impt, json_real(M->impact_time[k]));
    }
    json_object_set_new(c, "energy_after_impacts", imp);
    json_object_set_new(c, "impact_end_times", impt);
    /* a chattering contact ends many impacts: the lists hold the first MAX_IMPACTS */
    json_object_set_new(c, "impacts", json_integer(M->nimpact_total));
    if (M->nimpact_total) {
      json_object_set_new(c, "energy_after_last_impact", json_real(M->last_impact_energy));
      json_object_set_new(c, "last_impact_end_time", json_real(M->last_impact_time));
    }
    json_object_set_new(j, "contact", c);
  }
  return j;
}

/* The largest restitution of the pairs under Newton's impact law (T71), 0 without one. */
static double restitution(const mo_metrics *M)
{
  double e = 0;
  int k;
  if (!M->C) return 0;
  for (k = 0; k < mo_contact_npairs(M->C); k++) {
    const mo_contact_pair *p = mo_contact_pair_get(M->C, k);
    if (p->law == MO_LAW_NEWTON && p->e > e) e = p->e;
  }
  return e;
}

void mo_metrics_chatter_input(const mo_metrics *M, mo_chatter_input *in)
{
  int a, ns = M->nsign_gone;
  for (a = 0; a < M->nc; a++)
    if ((int)M->hf[a].nsign > ns) ns = (int)M->hf[a].nsign;
  in->impact_velocity = M->vimpact;
  in->velocity_scale = M->vscale;
  in->max_vn_in_contact = M->max_vn_closed;
  in->oscillation_index = oscillation_index(M);
  in->oscillation_scale = oscillation_scale(M);
  in->vn_sign_changes = ns;
  in->restitution = restitution(M);
}

/* (T97): the contact chatters when, between two bearing steps, the normal velocity reaches
   MO_CHATTER_VN_REL of the impact velocity, or changes sign MO_CHATTER_SIGN_CHANGES times (each
   side above MO_CHATTER_VN_FLOOR of it). The exact solution of a bearing contact has [v_n] = 0:
   both vanish. */
int mo_chatter_verdict(const mo_chatter_input *in, char *why, size_t n)
{
  double V = in->impact_velocity;
  double vn, osc, ns = in->vn_sign_changes;
  int chatter;
  if (why && n) why[0] = '\0';
  if (in->restitution > 0) {
    if (why && n)
      snprintf(why, n, "Newton's restitution e = %.3g: a bearing step leaves U_n = -e U_n- by the law, no chatter "
               "verdict", in->restitution);
    return 0;
  }
  if (!(in->impact_velocity > 0) || !isfinite(V)) {
    /* no landing (a contact closed from the start, a quasi-static scene): no impact velocity
       to judge the bearing steps against */
    if (why && n) snprintf(why, n, "no landing: no chatter verdict");
    return 0;
  }
  vn = in->max_vn_in_contact / V;
  osc = in->oscillation_index * (isnan(in->oscillation_scale) ? in->velocity_scale : in->oscillation_scale) / V;
  if (isnan(vn)) vn = 0;
  if (isnan(osc)) osc = 0;
  if (isnan(ns)) ns = 0;
  chatter = vn > MO_CHATTER_VN_REL || ns >= MO_CHATTER_SIGN_CHANGES;
  if (why && n)
    snprintf(why, n, "max |v_n| while closed %.3g of the impact velocity %.3g m/s%s, %.0f sign changes%s, "
             "variation %.3g", vn, V,
             vn > MO_CHATTER_VN_REL ? " (> " MO_STR(MO_CHATTER_VN_REL) ")" : "", ns,
             ns >= MO_CHATTER_SIGN_CHANGES ? " (>= " MO_STR(MO_CHATTER_SIGN_CHANGES) ")" : "", osc);
  return chatter;
}
