/* nscd.h: private header of the nscd back end (Jean's nonlinear Gauss-Seidel over contacts on
   the Delassus operator, doc/theory.md §8): parameters, the local solvers, the sweep kernel. */
#ifndef MOREAU_NSCD_H
#define MOREAU_NSCD_H

#include <moreau/contact.h>
#include <math.h>

/* --- parameters (case keys contact.nscd.<option>) -------------------------------------------- */

typedef enum {
  NSCD_STOP_SCALED = 0, NSCD_STOP_NATURAL, NSCD_STOP_QUAD, NSCD_STOP_MAXM, NSCD_STOP_SWEEPS
} nscd_stop;
typedef enum { NSCD_ORDER_NATURAL = 0, NSCD_ORDER_REVERSE, NSCD_ORDER_SHUFFLED } nscd_order;

typedef struct {
  double tol;          /* tolerance of the stopping rule */
  int stop;            /* nscd_stop: natural map of the scaled problem (T42) or as the core
                          measures it (T10), Jean's Quad or Maxm (T11), or
                          exactly max_sweeps sweeps */
  int max_sweeps;      /* sweep limit */
  double relax;        /* relaxation omega: r <- omega r_local + (1 - omega) r (T37) */
  int order;           /* nscd_order */
  int reshuffle;       /* shuffled order: a new permutation at every sweep */
  int warm_start;      /* start from the previous step's reactions */
  double local_tol;    /* 3D local Newton: |phi| <= local_tol (|r| + rho_n |q_n|) */
  int local_iter;      /* 3D local Newton iterations before the projection fallback */
  int accelerate;      /* the status-set step when the sweeps stall (T83) */
  int split_min;       /* over MPI ranks: the granular sweep is split only from this many active
                          contacts a rank, else run whole on every rank (T333) */
} nscd_params;

void nscd_params_default(nscd_params *p);

/* --- local solvers (nscd_local.c): one contact, U = W r + q, the law (T12) ----------------------

   W is the d x d diagonal block (row-major, normal first), q the local free term with the other
   contacts' reactions in it. nscd_local_prepare fills NSCD_AUX doubles of per-contact data that
   depend only on W and mu (inverse of W for the stick trial, slide denominators, Newton
   parameters); nscd_local_solve then writes r and returns the status (MO_CS_OPEN, MO_CS_STICK,
   MO_CS_SLIDE), or -1 when the block cannot carry a compressive reaction (W_nn <= 0 with q_n < 0)
   or the computation produced a non-finite number (r is then left unchanged). On entry r holds
   the previous iterate, the 3D Newton's starting point. */
#define NSCD_AUX 12
/* A d x d block is taken as singular below this relative determinant: |det W| against the
   product of its diagonal (Hadamard: det <= prod diag for SPD blocks). */
#define NSCD_SINGULAR 1e-13

typedef struct {
  long newton;         /* 3D Newton iterations */
  long fallbacks;      /* 3D solves the Newton did not finish (a local minimum of its merit) */
  long angle;          /* ... finished by the search on the slip angle */
  long projection;     /* ... finished by the projection */
  long failures;       /* 3D solves that met no tolerance (the best candidate is kept) */
} nscd_local_stats;

void nscd_local_prepare(int d, const double *W, double mu, double *aux);
/* Its 2D case, the entries aux[0 .. 6] the 2D solvers read, in two parts: the inverse of W for the
   stick trial (aux[0 .. 3], aux[6] = 1 when W is regular) and the slide denominators (aux[4 .. 5]).
   The granular sweep forms them at each visit, the second only when the stick trial fails (T188). */
static inline void nscd_local_inverse_2d(const double *W, double *aux)
{
  double a = W[0], b = W[1], c = W[2], e = W[3], det = a * e - b * c;
  aux[0] = aux[1] = aux[2] = aux[3] = aux[6] = 0;
  if (fabs(det) > NSCD_SINGULAR * fabs(a * e) && a * e != 0) {
    aux[0] = e / det;
    aux[1] = -b / det;
    aux[2] = -c / det;
    aux[3] = a / det;
    aux[6] = 1;
  }
}
static inline void nscd_local_slide_2d(const double *W, double mu, double *aux)
{
  double a = W[0], b = W[1];
  /* sliding: U_n = (W_nn -+ mu W_nt) r_n + q_n = 0  (T38) */
  aux[4] = a - mu * b > 0 ? 1 / (a - mu * b) : 0;
  aux[5] = a + mu * b > 0 ? 1 / (a + mu * b) : 0;
}
static inline void nscd_local_prepare_2d(const double *W, double mu, double *aux)
{
  nscd_local_inverse_2d(W, aux);
  nscd_local_slide_2d(W, mu, aux);
}
int nscd_local_solve(int d, const double *W, const double *aux, const double *q, double mu,
                     double *r, const nscd_params *p, nscd_local_stats *st);

/* The three local solvers (called by nscd_local_solve; exposed for the tests). */
int nscd_local_1d(const double *W, const double *q, double *r);
int nscd_local_2d(const double *W, const double *aux, const double *q, double mu, double *r);
/* nscd_local_2d with its two common cases inline (open; stick inside the cone), the others
   through it: the same result, without a call for most updates of a sweep. */
/* The stick trial of the 2D problem (q_n < 0): r = -W^-1 q when inside the cone (returns 1). */
static inline int nscd_local_2d_stick(const double *W, const double *aux, const double *q, double mu, double *r)
{
  double qn = q[0], qt = q[1];
  if (W[0] > 0 && aux[6] != 0) {
    double rn = -(aux[0] * qn + aux[1] * qt), rt = -(aux[2] * qn + aux[3] * qt);
    if (rn > 0 && (rt < 0 ? -rt : rt) <= mu * rn) {
      r[0] = rn;
      r[1] = rt;
      return 1;
    }
  }
  return 0;
}
static inline int nscd_local_2d_fast(const double *W, const double *aux, const double *q, double mu, double *r)
{
  if (q[0] >= 0) {
    r[0] = r[1] = 0;
    return MO_CS_OPEN;
  }
  if (nscd_local_2d_stick(W, aux, q, mu, r)) return MO_CS_STICK;
  return nscd_local_2d(W, aux, q, mu, r);
}
int nscd_local_3d(const double *W, const double *aux, const double *q, double mu, double *r,
                  const nscd_params *p, nscd_local_stats *st);
/* The 3D Alart-Curnier Newton, the search on the slip angle and the projection alone (tests).
   Return 0 when they met their tolerance. */
int nscd_ac_newton(const double *W, const double *q, double mu, double rho_n, double rho_t,
                   double *r, double tol, int maxit, long *iters);
int nscd_slide_angle(const double *W, const double *q, double mu, double *r, double tol);
int nscd_projection(const double *W, const double *q, double mu, double *r, double tol,
                    int maxit);

typedef struct {
  int tried;           /* a status-set problem was built and solved */
  int accepted;        /* its solution satisfies the law: the solve converged on it */
  int rows;            /* its unknowns (one per closed frictionless or sliding contact, d per sticking one) */
  int rank;            /* their numerical rank: rows - rank constraints are redundant (T84) */
  double rcond;        /* reciprocal condition (LU estimate, or s_min / s_max kept by the SVD) */
  int min_norm;        /* rank-deficient: the solution is the minimum-norm one */
} nscd_accel_info;

/* --- the solver's state (nscd.c; the sweep on body velocities in nscd_bodies.c) ----------------- */

#include <gsl/gsl_rng.h>

typedef struct {
  nscd_params p;
  int nc, d, m;
  /* rows of W (pointers into the core's Delassus operator, refreshed at every solve) */
  int *rcnt;
  const int **rcol;
  const double **rval;
  const double **diag;          /* W_aa (NULL on the granular path: nscd_waa reads its record) */
  /* columns: the rows transposed (sym) or a transposed copy (W not symmetric), whose blocks
     are stored transposed (W_ba^T) like the rows' blocks W_ab = W_ba^T of a symmetric W */
  int sym;
  int *cp, *cb;
  double *cv;
  size_t ccap, cpcap;
  size_t cap, mcap;             /* room of the per-contact arrays (contacts) and of U, rold (m) */
  size_t aocap;                 /* room of actown (contacts) */
  size_t wcap, acap, ucap;      /* room of the sweep on W's arrays (rcnt, rcol, rval, sprev), of aux, of Uown */
  size_t dcap, rcap;            /* room of diag and scale (contacts), of rold (m): not made on the
                                   granular path (rold: whatever the ranks, T273) */
  double *aux;                  /* nc * NSCD_AUX: per-contact data of the local solvers */
  const mo_delassus *wsrc;      /* the W the cached data were built for, and its version */
  long wver;
  const int *act;               /* the active contacts in increasing order: actown, or on the granular
                                   path the problem's own list (P->act, doc/theory.md (T250)) */
  int nact;
  int *actown;                  /* cap: listed here off the granular path (and scratch for prepare) */
  const int *order;             /* the sweep's order of the active contacts: act itself in the natural
                                   order (the granular path's many contacts), else ordown */
  int *ordown;
  size_t ocap;
  double *U;                    /* U = W r + q kept up to date by the column updates: Uown, or on the
                                   granular path the caller's array of the solve */
  double *Uown;
  double *rold;                 /* m: the reactions at the start of the sweep (Jean's norms); not on the
                                   granular path, whose sweep sums Jean's parts itself (over MPI ranks
                                   each rank its contacts', T273) */
  double *scale;                /* nc: 1 / W_aa,nn, the scaling of (T42) (0 when W_nn = 0); NULL on the
                                   granular path (nscd_scale computes it from the record's W_aa) */
  const double *mu;             /* nc: friction coefficients, 0 where no free dof moves the
                                   contact tangentially (W_tt = 0, e.g. on a symmetry axis: its
                                   friction impulse acts on nothing, any r_t in the cone would do);
                                   read for the active contacts only. muown, or on the granular
                                   path the problem's own P->mu while no active contact differs
                                   from it (doc/theory.md (T186)) */
  double *muown;
  size_t mucap;
  const int *gkey;              /* the granular path with mu NULL: contact a's coefficient is its pair's, */
  const double *gpmu;           /* gpmu[gkey[a MO_KEY]] (P->grains, doc/theory.md (T189)) */
  double qn2, qs2;              /* |q|^2 and |S q|^2 over the active contacts */
  /* a GSL generator on our own memory (gsl_rng_alloc aborts on failure) */
  gsl_rng rng;
  void *rng_state;
  nscd_local_stats lst;
  int *sprev;                   /* nc: the statuses after the previous sweep (the status-set step) */
  nscd_accel_info ai;           /* the last status-set step of the solve */
  int accel_tries;
  nscd_params lp;               /* the parameters the local solvers see in this sweep */
  /* frictionless contacts in 2D or 3D (every mu = 0): a sweep needs the normal entries W_ab,nn
     only, one double per block instead of d^2, read from W's own contiguous copy (wn, row a from
     wnp[a]; T164, T178) or else copied out of the rows (into wnown) and, for a W that is not
     symmetric, out of the transposed copy (wnc, parallel to cb); U_t is then left out of the
     sweeps and made exact after them (doc/theory.md (T156)) */
  int nonly, u_full;             /* u_full: U exact in every component (not only the normal) */
  const double *wn;
  double *wnown, *wnc;
  size_t *wnp;
  size_t wncap, wnccap;
  /* the status-set step's LU (T157), kept while W (its version) and the kinds of the closed
     contacts are the same, so that a step whose closed set did not change solves with it */
  struct {
    int valid, n;
    const mo_delassus *W;
    long wver;
    int *kind;                  /* nc: the kinds it was built for */
    int *off;                   /* nc: the first unknown of each closed contact (T160) */
    double *E;                  /* nc d: the sliding directions it was built for */
    double *LU, rcond;
    int *ipiv;
    size_t ncap, kcap;
    long builds, hits;
  } lu;
  /* the sweep on body velocities (nscd_bodies.c), when the core gave no W: every contact joins
     rigid bodies and obstacles (doc/theory.md §8.6) */
  int bodies;
  int *nsd, *sblk;              /* per contact: its rigid sides (0 to 2) and their blocks of What */
  int *soff;                    /* per contact and side: the side's first velocity in vb, or -1
                                   when its block has fewer dofs than a free body (a generic side) */
  double *G;                    /* per contact and side: the d x n_k rows of H on the block's dofs */
  double *MG;                   /* per contact and side: inv_k G^T (n_k x d), the velocity change
                                   of an impulse */
  double *Wd;                   /* nc d x d: W_aa = sum over sides G inv_k G^T */
  double *c;                    /* m: q - H^T v_free, so that U = c + sum G v */
  double *vb;                   /* nfree: v = v_free + What^-1 H r, kept up to date by the sweep */
  int *bmark;                   /* per rigid block: touched by a closed contact (the count of (T84)) */
  size_t bmcap;
  size_t bcap, vcap;
  /* the granular path (nscd_grains.c): the core gave compact records (P->grains), not H; the sweep
     on body velocities reads per contact its sides and the moments of its frame (vb above as in
     the sweep on H) */
  int grains;
  void *grec;                   /* per contact its record (nscd_grains.c): c_a, W_aa (the sides, the rows
                                   of H on the rotations and the local data formed at each visit, T188,
                                   T226) */
  double *giv;                  /* nfree: the diagonal of What^-1 on the rigid dofs, when the stepper's
                                   (What^-1's dinv) cannot serve */
  const double *gi;             /* the one the sweep reads (giv or dinv), indexed by free dof */
  long givver;                  /* the What^-1 version giv was taken from */
  size_t gcap, gvcap;
  const char *gw;               /* the first record's W_aa, and the records' size: nscd_waa */
  size_t gstride;
  /* Jean's norms (T11) of a sweep on the granular path, summed by the sweep itself when jwant (the
     reactions before it are not kept): sum |dU|^2 |r|^2, sum (W r).r, the contacts with a reaction,
     the largest |dU| |r| (jean_parts in nscd.c) */
  int jwant;
  double jp[4];
  /* over the ranks (T334): the rank's largest |dU| |r| of the last split sweep and the sums of
     its Jean's parts, for the Maxm reported after the last sweep */
  double jmax, jparts[3];
  /* the granular path over MPI ranks (nscd_grains.c, doc/parallel.md §4): each rank sweeps the
     contacts of its slab of space (`own`, in the sweep's order: `oorder`), the velocities of the
     bodies that contacts of several ranks touch (`ifc`, their first velocity in vb) are summed
     over the ranks after every sweep (Jacobi between the slabs, Gauss-Seidel within) */
  int par;                      /* 1 when the sweep is split over the ranks */
  int nranks, rank;
  unsigned char *own;           /* nc: the contact is swept here */
  int *oorder, noact;           /* the owned active contacts in the sweep's order */
  int *ifc, nifc;               /* interface bodies */
  int *bfirst;                  /* nfree (by first velocity): the lowest rank touching the body, -1 none */
  unsigned char *bmulti;        /* nfree: touched by contacts of more than one rank */
  /* (T336) per contact, whether it touches an interface body; the active contacts that do
     (ilist) and those whose reactions reach the rank's bodies, its own and the interface ones
     (vlist), both in the increasing order of act */
  unsigned char *cifc;
  int *ilist, nilist, *vlist, nvlist;
  int *aside;                   /* 2 per act[k]: its sides' first velocities (-1: none) */
  int *onil, nonil;             /* (T340) the rank's own contacts off the interface, in the sweep's order */
  double *nbuf;                 /* (T340) the residual's parts and the interface reactions joined to the sum */
  size_t nbcap;
  double *pbuf;                 /* the sums of a sweep: interface increments, then the norms' parts */
  double *ibase;                /* the interface velocities at the start of the sweep (by ifc index) */
  size_t pcap, pncap, pbcap;
  /* the parts are boxes of the active contacts' points (mo_rcb, (T330)): apart[k] the part of
     act[k]; ridx its scratch. On more than 2 ranks (xchg) the interface velocities go point to
     point, each rank sending its increments of the bodies it shares to the ranks that share them
     and summing them in rank order (T331): npeer ranks peer[], the values for peer[k] at
     poff[k] .. poff[k + 1] (nk a body; its bodies' ifc indices pj[], the same order on both
     sides); the rank's own interface bodies mj[0 .. nmine) and, for each, the ranks that touch it
     in increasing order as places msrc[msrc0[m] .. msrc0[m + 1]) in rbuf (-1: this rank's own) */
  int xchg;
  /* the split sweep's inverse masses (T332): gi with each interface body's multiplied by the
     number of ranks that touch it (gl, on the rank's own interface bodies), gs the one the
     records' W_aa and the pushes read: gl while the sweep is split, else gi */
  double *gl;
  size_t glcap;
  const double *gs;
  int *apart, *ridx, *ipos, *pcnt;
  long *pkey;
  int npeer, nmine, *peer, *poff, *pj, *mj, *msrc0, *msrc, *pe;
  double *sbuf, *rbuf;
  size_t xcap, xrcap;
  size_t kwant, kcap;           /* the pattern's entries wanted (the distributed set's), and their room */
  /* the distributed set (P->grains->dist, doc/scaling.md §4): per body (slot o / nk) the sum over the
     ranks whose active contacts touch it of 2^rank, then each rank's active contacts (bm[nslot + q]) */
  double *bm;
  size_t bmscap;
  int dist;
  /* the end-of-solve gather (T335): each rank's block (its active contacts' reactions and
     statuses, its first-touched bodies' velocity changes, the count's numbers), gcnt[q] values
     of rank q; gbuf every block in rank order, then the rank's own */
  int *gcnt;
  /* the end of a solve with the bodies' state per rank: counts, offsets, peers; the values */
  int *hx;
  size_t hxcap;
  int nifc_all;                 /* the interface bodies over every rank (held: nifc is this rank's) */
  double *hbuf;
  size_t hbcap;
  double *gbuf;
  size_t gbcap;
  long par_sweeps;              /* sweeps synchronized, for the run's log */
  /* the set-up over the slab (doc/theory.md (T274)-(T279)): gpart, the records are those of the
     rank's own active contacts only (the others' made by nscd_grains_complete when a serial sweep
     or a report needs them); qs2part, qs2 is the rank's part, summed by the first sweep's sync */
  int gpart, qs2part;
} nscd_state;

/* W_aa of contact a, and its scaling 1 / W_aa,nn of (T42) (0 when W_aa,nn = 0; the granular path
   computes it from its record: the same division, the same value). */
static inline const double *nscd_waa(const nscd_state *S, int a)
{
  return S->grains ? (const double *)(const void *)(S->gw + (size_t)a * S->gstride) : S->diag[a];
}
static inline double nscd_scale(const nscd_state *S, int a)
{
  const double *w;
  if (S->scale) return S->scale[a];
  w = nscd_waa(S, a);
  return w[0] > 0 ? 1 / w[0] : 0;
}

/* The local data of every contact from its diagonal block S->diag[a] and mu: the friction kept
   where a free dof moves the contact tangentially, the local solvers' data, the scaling (T42). */
void nscd_prepare_local(nscd_state *S, const mo_contact_problem *P);

/* The sweep on body velocities (nscd_bodies.c): the contacts' blocks of H by rigid block, W_aa
   and c = q - H^T v_free (prepare); v = v_free + What^-1 H r from r (velocities); U = c + H^T v
   (exact_U); one Gauss-Seidel sweep updating v contact by contact (sweep, the contact that broke
   down or -1); and the correction dx = v - v_free over the free dofs. */
int nscd_bodies_prepare(nscd_state *S, const mo_contact_problem *P, mo_ctx *ctx);
void nscd_bodies_velocities(nscd_state *S, const mo_contact_problem *P, const double *r);
void nscd_bodies_exact_U(nscd_state *S, const mo_contact_problem *P);
int nscd_bodies_sweep(nscd_state *S, const mo_contact_problem *P, double *r, int *status);
void nscd_bodies_dx(const nscd_state *S, const mo_contact_problem *P, double *dx);
void nscd_bodies_free(nscd_state *S);
/* The unknowns contact a adds to the count of (T84) with its impulse ra: none when open, one when
   frictionless or sliding (r_t follows r_n), d when sticking; for nscd_bodies_count and
   nscd_grains_count alike. */
/* Contact a's friction coefficient: S->mu's, or on the granular path without a copy its pair's (T189). */
static inline double nscd_mu(const nscd_state *S, int a)
{
  return S->mu ? S->mu[a] : S->gpmu[S->gkey[(size_t)a * MO_KEY]];
}

static inline int nscd_closed_unknowns(const nscd_state *S, int a, const double *ra, int d)
{
  double rt = 0;
  int i;
  if (!(ra[0] > 0)) return 0;
  for (i = 1; i < d; i++) rt += ra[i] * ra[i];
  return d == 1 || nscd_mu(S, a) == 0 || sqrt(rt) >= nscd_mu(S, a) * ra[0] * (1 - 1e-9) ? 1 : d;
}
/* S->bmark with room for n marks, every one cleared (the blocks or bodies the count has seen). */
int nscd_marks_clear(nscd_state *S, size_t n, mo_ctx *ctx);
/* The closed contacts' unknowns (1 per frictionless or sliding contact, d per sticking one) and
   the dofs of the bodies they touch: more unknowns than dofs is redundancy (T84), the count
   n - dofs a lower bound of it (the rank is not computed on the sweep on bodies). */
int nscd_bodies_count(nscd_state *S, const mo_contact_problem *P, const double *r, int *unknowns, int *dofs,
                      mo_ctx *ctx);

/* The same on the compact records of the granular path (nscd_grains.c, doc/theory.md §12.9), with
   the arithmetic of the sweep on H to the bit. */
int nscd_grains_prepare(nscd_state *S, const mo_contact_problem *P, mo_ctx *ctx);
/* vb = v_free: every body's, or with the bodies' state per rank the held bodies' only. */
void nscd_grains_free_velocities(nscd_state *S, const mo_contact_problem *P);
void nscd_grains_velocities(nscd_state *S, const mo_contact_problem *P, const double *r);
/* Over the ranks (T336): the velocities of the bodies the rank's contacts touch, from r, to the
   bit those of nscd_grains_velocities (the others' are left at v_free). */
void nscd_grains_velocities_part(nscd_state *S, const mo_contact_problem *P, const double *r);
void nscd_grains_exact_U(nscd_state *S, const mo_contact_problem *P);
int nscd_grains_sweep(nscd_state *S, const mo_contact_problem *P, double *r, int *status);
/* Over MPI ranks (doc/parallel.md §4): the slabs and their interface bodies for this solve
   (after the sweep order is set); a sweep of the owned contacts; after it, the interface
   velocities summed over the ranks with the `nparts` partial sums of the stopping rule (parts, in
   place; a breakdown's index and Jean's maximum are maximized by the caller only when needed,
   (T334)); U of the owned contacts from the synchronized velocities; at the end, the reactions,
   statuses and velocities of every contact and body on every rank (with fin, the end of the
   solve: the velocities and U exact, as nscd_grains_velocities and nscd_grains_exact_U make them
   on one process, each rank forming its own part's (T336)). */
int nscd_grains_partition(nscd_state *S, const mo_contact_problem *P, mo_ctx *ctx);
int nscd_grains_sweep_owned(nscd_state *S, const mo_contact_problem *P, double *r, int *status);
void nscd_grains_owned_U(nscd_state *S, const mo_contact_problem *P);
int nscd_grains_sync(nscd_state *S, double *parts, int nparts, double *extra, int nextra, mo_ctx *ctx);
/* U of the contacts list[0 .. n-1] from their records (2 ranks: the interface contacts' too, T340). */
void nscd_grains_list_U(nscd_state *S, const mo_contact_problem *P, const int *list, int n);
int nscd_grains_ifc_count(const nscd_state *S);
/* U of the interface contacts (ilist order, d each) from their records, into Uk (2 ranks, T340). */
void nscd_grains_ifc_U(nscd_state *S, const mo_contact_problem *P, double *Uk);
void nscd_grains_ifc_pack(const nscd_state *S, const mo_contact_problem *P, const double *r, double *x);
void nscd_grains_ifc_unpack(nscd_state *S, const mo_contact_problem *P, const double *x);
/* On more than 2 ranks, before nscd_grains_sync: the interface increments point to point, the
   rank's interface velocities synced ((T331); nothing on 2 ranks, whose sync carries them). */
int nscd_grains_exchange(nscd_state *S, mo_ctx *ctx);
/* The distributed set (doc/scaling.md §4): the parts (every active contact the rank's), the
   velocities of the rank's bodies from the reactions with the interface summed, and the end of the
   solve (the bodies' velocities gathered, U of the rank's candidates). */
int nscd_grains_partition_dist(nscd_state *S, const mo_contact_problem *P, mo_ctx *ctx);
int nscd_grains_velocities_dist(nscd_state *S, const mo_contact_problem *P, const double *r, mo_ctx *ctx);
int nscd_grains_gather_dist(nscd_state *S, const mo_contact_problem *P, double *r, int *unknowns, int *dofs,
                            mo_ctx *ctx);
/* The gather; with unknowns (not NULL), the redundancy count of nscd_grains_count over the rank's
   own contacts joined in the same sum (T279). */
int nscd_grains_gather(nscd_state *S, const mo_contact_problem *P, double *r, int *status, int fin, int *unknowns,
                       int *dofs, mo_ctx *ctx);
/* The records of the contacts other than the rank's own active ones (after a prepare over the
   slab: gpart), for a sweep over every contact or a report over them (T277); nothing otherwise. */
void nscd_grains_complete(nscd_state *S, const mo_contact_problem *P);
/* Closed unknowns and the dofs they move (T84), over every active contact (over the ranks: the
   gather's count). */
int nscd_grains_count(nscd_state *S, const mo_contact_problem *P, const double *r, int *unknowns, int *dofs,
                      mo_ctx *ctx);
void nscd_grains_free(nscd_state *S);

/* --- the status-set step and the round-off floor (nscd_accel.c, doc/theory.md (T83)-(T85)) ------ */

/* Largest status-set problem solved densely (unknowns), the relative singular value below which
   a direction of it is taken as redundant, and the multiple of DBL_EPSILON |W| |r| taken as the
   round-off of U. */
#define NSCD_ACCEL_MAX 5000
/* Active contacts from which the first LU of a run is taken without waiting for a stall (T157) */
#define NSCD_EARLY_LU 1000
/* split_min's default (T333): the disk pile on 2 ranks of one machine, whole against split: the
   whole sweep faster at 48 active contacts a rank, the two alike from 115 to 240, the split one
   1.5 x faster at 490 (a sync a sweep of about 1 us here; a network's 5-20 us moves the point up) */
#define NSCD_SPLIT_MIN 128
#define NSCD_PAR_STALL 500 /* sweeps over which a split sweep over the ranks must halve its measure */
/* Active frictionless contacts from which the first LU of a run is tried before any sweep, on the
   statuses the predictor's velocities give (T163) */
#define NSCD_GUESS_LU 200
#define NSCD_RANK_TOL 1e-10
#define NSCD_ROUNDOFF 64
/* The LU of the n x n matrix A (column-major) whose leading n0 x n0 block is the one the LU F0
   (leading dimension n0, pivots ipiv[0 .. n0)) factors, without factoring that block again: the
   unknowns of the contacts a status iteration closes follow the others (T160). LAPACK's layout
   (ipiv[n0 .. n) those of the trailing block, shifted by n0), read by dgetrs and dgecon as
   dgetrf's; *lu_info as dgetrf's. */
void nscd_lu_border(int n, int n0, const double *A, const double *F0, double *LU, int *ipiv, int *lu_info);
/* The LU of the n x n column-major A into F in LAPACK's layout (as dgetrf: F, ipiv, *info). sym:
   A is symmetric and, when positive definite, factored by Cholesky (its lower triangle read) and
   written as L = C D^-1, U = D C^T with no pivots (T163); dgetrf when not (or when Cholesky breaks
   down). */
void nscd_factor_closed(int n, const double *A, double *F, int *ipiv, int sym, int *info);
/* Status iterations of one status-set step (each a dense solve) */
#define NSCD_STATUS_ITER 8
/* A contact with no reaction is closed when its scaled velocity is below this fraction of the
   reactions' scale (or 100 tol, what the sweeps' tolerance leaves) */
#define NSCD_WEAK 1e-9


/* The status-set step on W (not the sweep on bodies): from the statuses of r, solve the closed
   contacts' linear problem (minimum-norm when it is rank-deficient); when its solution satisfies
   the law (scaled residual <= tol or at round-off) r, status and *res take it (info->accepted);
   otherwise r is kept and S->U is recomputed exactly. tol < 0: measure the rank only, never
   accept. MO_OK or MO_ENOMEM. */
int nscd_status_step(nscd_state *S, const mo_contact_problem *P, double *r, int *status, double tol,
                     double *res, nscd_accel_info *info, int mode, mo_ctx *ctx);
/* mode: NSCD_STEP_FACTOR, the kinds of r (factored when they are not the kept LU's);
   NSCD_STEP_CACHED, solve only when they are those of the kept LU (no factorization);
   NSCD_STEP_PREDICT, as FACTOR with the open contacts that U = W r + q penetrates closed: the
   first LU of a run without sweeps before it (T163). */
enum { NSCD_STEP_FACTOR = 0, NSCD_STEP_CACHED = 1, NSCD_STEP_PREDICT = 2 };
/* Frictionless (S->nonly): the normal components of U = W r + q from the normal entries of W;
   the tangential ones get q_t (finite, not exact: U_t is made exact before the solve returns). */
void nscd_normal_mult(const nscd_state *S, const mo_contact_problem *P, const double *r, double *U);
void nscd_status_cache_free(nscd_state *S);
/* The round-off level of the scaled residual at r (T85): 0 on the sweep on bodies. */
double nscd_roundoff_floor(const nscd_state *S, const mo_contact_problem *P, const double *r);

#endif
