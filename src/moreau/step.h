/* moreau/step.h: time integration shared by every back end: the theta-scheme (doc/theory.md
   §1, doc/architecture.md §4), Newmark (beta, gamma) and quasi-static load steps. */
#ifndef MOREAU_STEP_H
#define MOREAU_STEP_H

#include <moreau/ctx.h>
#include <moreau/scene.h>
#include <moreau/sparse.h>

#ifdef __cplusplus
extern "C" {
#endif

/* State at time t over full dofs (prescribed dofs included). */
typedef struct mo_state {
  double t;
  long step;
  double *u, *v, *a;  /* a: Newmark only (NULL otherwise) */
  double *f;          /* external force f_ext(t) */
  double *reac;       /* support reactions on prescribed dofs (0 elsewhere), over the last step;
                         NULL on a scene without a prescribed dof or a mesh (doc/theory.md (T245)) */
  double wext;        /* work of external forces since t = 0 (trapezoidal rule) */
  double wsupport;    /* work of the support reactions (moving supports) */
  double wcontact;    /* work of contact impulses (filled by the contact layer) */
  /* finite-strain bodies (moreau/material.h): the committed state of their quadrature points
     (mo_scene.nq doubles, NULL for linear scenes), their stored elastic energy and the plastic
     work accumulated since t = 0 (J), both from q */
  double *q;
  double psi, wplastic;
  /* 3D rigid bodies: their orientations, unit quaternions (w, x, y, z) body to world
     (4 mo_scene.norient doubles, NULL without them) */
  double *orient;
} mo_state;

int mo_state_alloc(const mo_scene *sc, mo_state *s, mo_ctx *ctx);
void mo_state_release(mo_state *s);
/* Copy a state of the scene sc (both allocated by mo_state_alloc for it). */
int mo_state_copy(const mo_scene *sc, const mo_state *src, mo_state *dst);

/* Kinetic energy 1/2 v.Mv of every body at state s (rigid bodies' blocks included) and elastic
   energy 1/2 u.Ku of the linear bodies (both over full dofs; finite-strain bodies have no K:
   their stored energy is mo_state.psi). */
double mo_energy_kinetic(const mo_scene *sc, const mo_state *s, double *work);
double mo_energy_elastic(const mo_scene *sc, const double *u, double *work);
/* 1 when the energies need their work vector (ndof): a mesh, or K with an entry or in parts; a
   scene of rigid bodies and obstacles passes NULL (doc/theory.md (T249)). */
int mo_energy_needs_work(const mo_scene *sc);
/* Stored elastic energy of every body: 1/2 u.Ku + psi. */
double mo_energy_stored(const mo_scene *sc, const mo_state *s, double *work);

typedef struct mo_stepper mo_stepper;

/* Create the stepper of a scene: builds and factors the iteration matrix
     theta:       What = M + h^2 theta theta_f K         (velocities v+ are the unknowns)
     newmark:     What = M + beta h^2 K                  (accelerations a+)
     quasistatic: What = K                               (displacements u+)
   restricted to free dofs; factored once (the matrix does not change for linear scenes). For
   nonlinear scenes K is the tangent stiffness K_t(u) of every Newton iterate (doc/theory.md
   §11): the pattern is analysed once, and What is factored here at the initial state (u0, a
   virgin material), then at every iterate. */
int mo_stepper_create(const mo_scene *sc, mo_stepper **out, mo_ctx *ctx);
/* The same, with the free nodal dofs contact acts on (free indices below the scene's
   nfe_free, nlast of them: mo_delassus_contact_dofs) ordered last in the factorization, so that
   the Delassus operator comes from its trailing block and the step splits into a forward solve,
   the contact problem on the trailing block and one backward solve (doc/theory.md §13), and the
   bytes the Delassus operator will take counted in the memory check before the numeric
   factorization (reserve). nlast = 0: mo_stepper_create. */
int mo_stepper_create_ordered(const mo_scene *sc, int nlast, const int *last, double reserve, mo_stepper **out,
                              mo_ctx *ctx);
void mo_stepper_free(mo_stepper *S);

/* Initial state: t = 0, u0, v0, prescribed values; Newmark also a0 from M a0 = f0 - K u0. */
int mo_stepper_init_state(mo_stepper *S, mo_state *s, mo_ctx *ctx);

/* One step split in three, so that a contact layer can act between them (linear scenes; a
   nonlinear scene's step is mo_stepper_solve, which returns MO_EUNSUPPORTED from predict):
   1. predict: x_free = What^-1 rhs (the unconstrained step), written as the full vector of the
      scheme's unknown (v+, a+ or u+) with prescribed values in place. */
int mo_stepper_predict(mo_stepper *S, const mo_state *s, double *x_full, mo_ctx *ctx);
/* 2. correction for an impulse (theta), a force (newmark, quasistatic) given over full dofs:
      dx = What^-1 imp on free dofs (0 on prescribed dofs). */
int mo_stepper_correct(mo_stepper *S, const double *imp_full, double *dx_full, mo_ctx *ctx);
/* 3. finish: from the scheme's unknown at t+ (full), update u, v, a, t, f, the works and the
      reactions. Refuses a non-finite unknown (MO_ENAN naming the dof). For a nonlinear scene x
      must be the solution mo_stepper_solve returned: its material states are committed. */
int mo_stepper_finish(mo_stepper *S, mo_state *s, const double *x_full, mo_ctx *ctx);
/* With the bodies' state per rank (a scene of rigid bodies only, mo_contact_held): the bodies this
   rank steps (hlist[0 .. n), ascending; NULL: every body), and per body whether it counts it, so
   that mo_stepper_finish sums the external work over each body once, on the rank that counts it (a
   sum over the ranks: collective). mo_stepper_predict and mo_stepper_finish then compute the listed
   bodies only, where the scene allows (rigid bodies only, theta, no prescribed dof), the others'
   state left as it is. */
void mo_stepper_hold(mo_stepper *S, const int *hlist, int n, const unsigned char *count);
/* 4. (optional) a position correction after finish: u += du on the free dofs, v unchanged, the
      external work and the support reactions updated (linear scenes; doc/theory.md (T95)). */
int mo_stepper_shift(mo_stepper *S, mo_state *s, const double *du_free, mo_ctx *ctx);
/* The split step (doc/theory.md (T153)), for linear scenes whose factorization holds the contact
   dofs as its trailing block (mo_stepper_split_ready):
   predict_split: as mo_stepper_predict, but the nodal free dofs are left NaN except the contact
      dofs (their values from the trailing block of the forward solve, which is kept);
   correct_split: x = What^-1 (rhs + imp) over every free dof, imp the impulse (force) over full
      dofs: the trailing forward solve of imp added to the kept one (a full forward solve when imp
      reaches beyond the contact dofs), then one backward solve; prescribed dofs untouched;
   complete_split: the same without impulse (x_free in full).
   After predict_split exactly one of the two must follow before the next prediction. */
int mo_stepper_split_ready(const mo_stepper *S);
/* 1 when the split step applies to a contact operator H (free rows): every nodal row of H is a
   contact dof of the factorization. */
int mo_stepper_split_covers(const mo_stepper *S, const mo_csc *H);
int mo_stepper_predict_split(mo_stepper *S, const mo_state *s, double *x_full, mo_ctx *ctx);
int mo_stepper_correct_split(mo_stepper *S, const double *imp_full, double *x_full, mo_ctx *ctx);
int mo_stepper_complete_split(mo_stepper *S, double *x_full, mo_ctx *ctx);
/* The contact dofs of the factorization (free indices; NULL when none) and how many. */
const int *mo_stepper_contact_dofs(const mo_stepper *S, int *nlast);
/* One step without contact: predict + finish (linear scenes), solve + finish (nonlinear). */
int mo_stepper_step(mo_stepper *S, mo_state *s, mo_ctx *ctx);

/* --- nonlinear steps: Newton on the smooth part (doc/theory.md §11) ---------------------- */

/* 1 when a body has a finite-strain material (mo_body.nl): steps solve (T60)-(T62) by Newton. */
int mo_stepper_nonlinear(const mo_stepper *S);

#define MO_NEWTON_HISTORY 64
/* Newton's record of the last step, and totals over the run. */
typedef struct {
  int iterations;                       /* linearizations (factorizations) of the last step */
  int nres;                             /* residuals recorded (iterations + 1 when converged) */
  double res[MO_NEWTON_HISTORY];        /* relative residuals |R - g| / scale of each iterate */
  double scale;                         /* the last iterate's scale (T64) */
  long steps, total, max;               /* steps solved, iterations over the run, most in a step */
  long damped;                          /* halved updates over the run (T63) */
} mo_newton_report;

/* Newton on a nonlinear step (doc/theory.md §11.2), driven by the caller so that the constraint
   solve of the contact layer sits inside the loop and the stepper never calls back up:

     mo_newton_begin(S, s, x, g)                  x: the initial iterate (mo_stepper_guess)
     while ((st = mo_newton_iterate(S, s, x, g, &xfree)) == MO_NEWTON_LINEARIZED)
       the constraint solve on What_k: writes the next iterate x and its term g = What_k (x -
       xfree) = H r over full dofs (0 on prescribed dofs); without constraint x = xfree, g = 0
     st == MO_OK: x is the solution, with the trial material states that go with it.

   At each call, mo_newton_iterate evaluates the residual of x (T64): converged, it returns
   MO_OK; otherwise (after halving updates that invert elements or do not decrease it, (T63)) it
   factors What_k = M + c K_t(u_k) and returns MO_NEWTON_LINEARIZED with xfree = x_k - What_k^-1
   R(x_k), the unconstrained Newton update (full, prescribed values in place). Non-convergence
   within time.newton.max_iter iterations, or an iterate that inverts elements (det F <= 0),
   returns MO_ENOCONV with the step, the time, the residual history and the inverted elements. */
#define MO_NEWTON_LINEARIZED 100
int mo_newton_begin(mo_stepper *S, const mo_state *s, double *x, double *g, mo_ctx *ctx);
int mo_newton_iterate(mo_stepper *S, const mo_state *s, double *x, double *g, const double **xfree,
                      mo_ctx *ctx);
/* A step without constraint: the loop above with x = xfree, g = 0. */
int mo_stepper_solve(mo_stepper *S, const mo_state *s, double *x, mo_ctx *ctx);
/* The initial iterate of a step: the constant-velocity prediction u+ = u + h v (theta: v;
   Newmark: -(1/2 - beta) a / beta; quasi-static: u), prescribed dofs included (mo_stepper_solve
   moves them to t+ with the first linearization). */
void mo_stepper_guess(mo_stepper *S, const mo_state *s, double *x);
const mo_newton_report *mo_stepper_newton_report(const mo_stepper *S);

/* What^-1 by blocks (doc/theory.md (T70)): the nodal block (free indices 0 .. nfe-1, the
   deformable bodies) through its factorization, then one dense block per rigid body with free
   dofs (the free-free part of its mass matrix, inverted). When every block is diagonal (disks,
   polygons, spheres: the grains' diag(m, m, I) and diag(m Id, I Id)), only the diagonals are
   stored: dinv, and ioff and inv are NULL; mo_what_block gives a block either way. */
typedef struct mo_what_inverse {
  int n, nfe;             /* free dofs; nodal free dofs */
  mo_linsolver *ls;       /* factorization of the nodal block (NULL when nfe = 0) */
  int nblk;
  const int *off;         /* nblk + 1: free index of each block's first dof (off[0] = nfe) */
  const int *ioff;        /* nblk: offset of each block's inverse (row-major) in inv; NULL with dinv */
  const double *inv;
  const double *dinv;     /* the diagonal blocks' inverses, one per rigid free dof i (at i - off[0];
                             off[0], not nfe, which a caller may zero to act on the blocks alone), or NULL */
  const int *blkof;       /* n - nfe: the block of each rigid free dof (index i - nfe), or NULL when
                             every block has bsize dofs (mo_what_block_of) */
  int bsize;              /* with blkof NULL: the dofs of every block (a pack's grains, all free) */
  long version;           /* changes whenever the factorization or a block changes */
  /* the nodal free dofs the factorization holds last, as its trailing block (doc/theory.md §13),
     in its order: (What^-1)_CC is ls's Schur inverse; 0 and NULL when it holds none */
  int nlast;
  const int *last;
} mo_what_inverse;
const mo_what_inverse *mo_stepper_inverse(const mo_stepper *S);
/* Block k of What^-1 (nk x nk, row-major, nk = off[k + 1] - off[k] <= 6) into A. */
static inline void mo_what_block(const mo_what_inverse *Wi, int k, double *A)
{
  int o = Wi->off[k], nk = Wi->off[k + 1] - o, i, j;
  for (i = 0; i < nk; i++)
    for (j = 0; j < nk; j++)
      A[i * nk + j] = Wi->dinv ? (i == j ? Wi->dinv[o - Wi->off[0] + i] : 0) : Wi->inv[Wi->ioff[k] + i * nk + j];
}
/* The block of rigid free dof i (i >= nfe): (i - nfe) / bsize when the blocks are all of one size
   (blkof NULL: 4 bytes a dof less, T260). */
static inline int mo_what_block_of(const mo_what_inverse *Wi, int i)
{
  return Wi->blkof ? Wi->blkof[i - Wi->nfe] : (i - Wi->nfe) / Wi->bsize;
}
/* X = What^-1 B over free dofs (nrhs columns, leading dimension n; X may alias B). */
int mo_what_solve(const mo_what_inverse *Wi, int nrhs, const double *B, double *X, mo_ctx *ctx);

/* The factorization of the nodal block of What and the block itself (nfe x nfe; NULL when
   the scene has no deformable body). */
mo_linsolver *mo_stepper_solver(mo_stepper *S);
const mo_csc *mo_stepper_matrix(const mo_stepper *S);
/* What over every free dof, the rigid blocks included (assembled on demand when they changed;
   the nodal block alone without rigid bodies): the KKT path of levelset. */
int mo_stepper_matrix_full(mo_stepper *S, const mo_csc **W, mo_ctx *ctx);
/* Scale linking the scheme's unknown x to the displacement increment over the step,
   du = du_fixed + c dx: h theta (theta), beta h^2 (newmark), 1 (quasistatic). */
double mo_stepper_du_dx(const mo_stepper *S);
/* The step the stepper takes now, and a change of it (step cutting, doc/theory.md §1.5): the
   iteration matrix is rebuilt for the new h and refactored (the symbolic analysis is kept);
   quasi-static steps only change their load increment. Nonlinear scenes rescale the linear part
   of their tangent; the elements' part is rebuilt at every iteration anyway. */
double mo_stepper_dt(const mo_stepper *S);
int mo_stepper_set_dt(mo_stepper *S, double h, mo_ctx *ctx);
/* Take a step again from s (a state saved before it): what the stepper keeps between steps
   (a nonlinear scene's internal forces at the start of the step) is rebuilt from s. */
int mo_stepper_restart(mo_stepper *S, const mo_state *s, mo_ctx *ctx);
const mo_scene *mo_stepper_scene(const mo_stepper *S);
/* Free-dof restriction (gather) and extension (scatter, prescribed left untouched). */
void mo_stepper_gather(const mo_stepper *S, const double *full, double *freev);
void mo_stepper_scatter(const mo_stepper *S, const double *freev, double *full);

#ifdef __cplusplus
}
#endif
#endif
