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
  double *rhs, *xf; /* free-size work */
  double *w1, *w2, *w3; /* full-size work */
  double *uprev, *vprev, *fprev; /* previous state for reactions */
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
};

/* step.c: the prescribed components of the scheme's unknown at time t (v, a or u). */
void mo_stepper_presc_unknown(const mo_stepper *S, double t, double *x);

/* newton.c */
int mo_newton_setup(mo_stepper *S, mo_ctx *ctx);
/* A new step h (S->h, S->cm and S->ck already set): the linear part Wlin of the tangent. */
int mo_newton_set_dt(mo_stepper *S, mo_ctx *ctx);
void mo_newton_release(mo_stepper *S);
/* Internal forces at u (full) from the committed states q: f_int into f (full), trial states
   into S->qt, and with tangent != 0, What = cm M + ck K_t into S->W's values; with dxp (full,
   non-zero on prescribed dofs only) the elements' coupling ck K_t dxp is added to cfp. */
int mo_newton_forces(mo_stepper *S, const double *u, const double *q, double *f, int tangent,
                     const double *dxp, double *cfp, mo_ctx *ctx);
/* Stored energy and plastic work of the finite-strain bodies in states q. */
void mo_newton_energies(const mo_stepper *S, const double *q, double *psi, double *wp);

#endif
