/* step_internal.h: the stepper's storage, shared by step.c (linear steps, the scheme's
   kinematics) and newton.c (nonlinear steps). Private to the core. */
#ifndef MOREAU_STEP_INTERNAL_H
#define MOREAU_STEP_INTERNAL_H

#include <moreau/step.h>

struct mo_stepper {
  const mo_scene *sc;
  mo_scheme scheme;
  double h, theta, theta_f, beta, gamma;
  double cm, ck;        /* What = cm M + ck K (K_t for nonlinear scenes) for the current h */
  mo_csc *Wfull;    /* M + c K over full dofs (for prescribed couplings); NULL when not needed */
  mo_csc *W;        /* free-free restriction */
  mo_linsolver *ls; /* its factorization */
  double *rhs, *xf; /* free-size work; on a scene of rigid bodies and obstacles whose dofs are
                       all free (alias), rhs is w1 and xf is not made: What^-1 is solved into
                       the caller's full vector (doc/theory.md (T246)) */
  int alias;
  double *w1, *w2, *w3; /* full-size work (w2 not made with alias under the theta-scheme when K
                           is empty: its one use is K's product) */
  double *uprev, *vprev, *fprev; /* previous state for reactions (vprev, fprev: prescribed dofs only) */
  /* the bodies' state per rank (mo_stepper_hold): the bodies this rank steps (NULL: every one), and
     per body whether it counts it (the external work summed over the ranks' counted bodies) */
  const int *hlist;
  int nhl;
  const unsigned char *bcount;
  int *ld_lo, *ld_l;             /* the loads by dof (loads_by_dof): entries lo[d] .. lo[d + 1] */
  int *hd0;                      /* per body: its first dof (a rigid body with dofs), else -1 */
  double *fconst;                /* f_ext when every load is constant (NULL otherwise) */
  double *ld_v, *ld_a, *ld_a0;   /* their values; the loads' amplitudes at t_k+1; scratch (at t_k, then
                                    the trapezoid's factors) */
  /* nonlinear scenes (newton.c); all NULL for linear ones */
  int nl;
  double *Wlin;         /* values of cm M + ck K on the pattern of W (the linear bodies' part) */
  int *emap;            /* per element of the finite-strain bodies, (nen dim)^2 positions in W->x
                           (row-major element matrix; -1 where a row or column is prescribed) */
  size_t *emap0;        /* per body, its first entry in emap */
  double *qt;           /* trial material states (mo_scene.nq) */
  double *fint, *fint0; /* internal forces f_int (full, K u of the linear bodies included) at the
                           iterate and at the start of the step */
  double *R, *g, *xfr;  /* full-size Newton work: residual, constraint term, x_free */
  double *xs;           /* the solution of mo_stepper_step */
  double *xk, *gk;      /* the last linearization point and its constraint term (damping) */
  double *dxp, *cfp;    /* a step's prescribed increment of the unknown, and ck K_t dxp */
  double *work;         /* element work: ue, fe, Ke */
  mo_newton_report rep;
  /* Newton's state between the calls of mo_newton_iterate */
  int nit, nhalf, ninv, ndamp, any_dxp;
  double prev;
  char inverted[MO_ERRMSG_MAX];
  /* What by blocks (doc/theory.md (T70)): W above is the nodal block (free indices 0 .. nfe-1,
     factored by ls, NULL when there is none); each rigid body with free dofs has a dense block,
     the free-free part of its mass matrix, inverted */
  int nfe;
  int nblk;
  int *blk_body;        /* nblk: the body of each block (NULL: rigid[k], every rigid body has one) */
  int *blk_rig;         /* nblk: its rank in sc->rigid (its mass block in rig_M; NULL: k) */
  int *blk_of;          /* per free rigid dof (index - nfe): its block; NULL when every block is
                           full (nd dofs, the block of a dof its index over nd: Wi.bsize, T260) */
  int *blk_off;         /* nblk + 1: free index of each block's first dof (blk_off[0] = nfe) */
  int *blk_loc;         /* per free rigid dof (index - nfe): its local dof in the body; NULL when
                           every block is full (the identity, blk_local) */
  int *blk_ioff;        /* nblk: offset of the block's inverse in blk_inv (NULL when blk_diag) */
  double *blk_inv;      /* the blocks' inverses, or with blk_diag their diagonals (one per rigid free dof) */
  double *rig_M;        /* per rigid body (scene order), its full mass block (ndof^2, 36 max), or
                           with blk_diag its diagonal (ndof); NULL with blk_diag in 2D: the
                           bodies' own diag(m, m, I) (rig_diag, T267) */
  int blk_diag;         /* every rigid body's mass block is diagonal and fixed: diagonals stored */
  int blk_varies;       /* some block turns with its body (3D, anisotropic inertia) */
  long blk_version;     /* changes with the blocks */
  double *gyro;         /* full: the gyroscopic forces at the start of the step (rigid rows) */
  mo_what_inverse Wi;
  mo_csc *Wall;         /* What over every free dof (the nodal block and the rigid blocks), on demand */
  long Wall_version;    /* blk_version + factorizations it was assembled at */
  /* the split step (doc/theory.md (T153)): the nodal free dofs contact acts on, ordered last in
     the factorization (nlast of them, last[k] their free indices), the forward solve y of the
     step's right-hand side kept between the prediction and the correction (nfe), and its
     rigid rows (x_free there, nfree - nfe) */
  int nlast, *last;
  unsigned char *islast;  /* nfe: 1 on the contact dofs */
  double reserve;
  double *ysplit, *cw;  /* nfe; nlast */
  int split_state;      /* 0 none, 1 predicted (y holds the forward solve), 2 corrected */
};

/* step.c: What^-1 by blocks over free vectors (nrhs columns, leading dimension nfree), and the
   mass matrix of every body applied to a full vector (y = M x, rigid blocks at the state the
   blocks were last updated at). */
int mo_stepper_what_solve(mo_stepper *S, int nrhs, const double *B, double *X, mo_ctx *ctx);
void mo_stepper_mass_apply(const mo_stepper *S, const double *x, double *y);
/* The rigid blocks at state s (orientations), and the gyroscopic forces at s into S->gyro. */
int mo_stepper_rigid_update(mo_stepper *S, const mo_state *s, mo_ctx *ctx);

/* step.c: the prescribed components of the scheme's unknown at time t (v, a or u). */
void mo_stepper_presc_unknown(const mo_stepper *S, double t, double *x);

/* tangent.c: the finite-strain bodies' element kernels */
int mo_tangent_setup(mo_stepper *S, mo_ctx *ctx);
/* A new step h (S->h, S->cm and S->ck already set): the linear part Wlin of the tangent. */
int mo_tangent_set_dt(mo_stepper *S, mo_ctx *ctx);
void mo_tangent_release(mo_stepper *S);
/* Internal forces at u (full) from the committed states q: f_int into f (full), trial states
   into S->qt, and with tangent != 0, What = cm M + ck K_t into S->W's values; with dxp (full,
   non-zero on prescribed dofs only) the elements' coupling ck K_t dxp is added to cfp. */
int mo_tangent_forces(mo_stepper *S, const double *u, const double *q, double *f, int tangent,
                     const double *dxp, double *cfp, mo_ctx *ctx);
/* Stored energy and plastic work of the finite-strain bodies in states q. */
void mo_tangent_energies(const mo_stepper *S, const double *q, double *psi, double *wp);

#endif
