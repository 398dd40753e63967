/* moreau/step.h: time integration shared by every back end: the theta-scheme (ARCHITECTURE.md
   §2), Newmark (beta, gamma) and quasi-static load steps. */
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
  double *reac;       /* support reactions on prescribed dofs (0 elsewhere), over the last step */
  double wext;        /* work of external forces since t = 0 (trapezoidal rule) */
  double wsupport;    /* work of the support reactions (moving supports) */
  double wcontact;    /* work of contact impulses (filled by the contact layer) */
} mo_state;

int mo_state_alloc(const mo_scene *sc, mo_state *s, mo_ctx *ctx);
void mo_state_release(mo_state *s);
int mo_state_copy(const mo_state *src, mo_state *dst, int ndof);

/* Kinetic energy 1/2 v.Mv and elastic energy 1/2 u.Ku (both over full dofs). */
double mo_energy_kinetic(const mo_scene *sc, const double *v, double *work);
double mo_energy_elastic(const mo_scene *sc, const double *u, double *work);

typedef struct mo_stepper mo_stepper;

/* Create the stepper of a scene: builds and factors the iteration matrix
     theta:       What = M + h^2 theta theta_f K         (velocities v+ are the unknowns)
     newmark:     What = M + beta h^2 K                  (accelerations a+)
     quasistatic: What = K                               (displacements u+)
   restricted to free dofs; factored once (the matrix does not change for linear scenes). */
int mo_stepper_create(const mo_scene *sc, mo_stepper **out, mo_ctx *ctx);
void mo_stepper_free(mo_stepper *S);

/* Initial state: t = 0, u0, v0, prescribed values; Newmark also a0 from M a0 = f0 - K u0. */
int mo_stepper_init_state(mo_stepper *S, mo_state *s, mo_ctx *ctx);

/* One step split in three, so that a contact layer can act between them:
   1. predict: x_free = What^-1 rhs (the unconstrained step), written as the full vector of the
      scheme's unknown (v+, a+ or u+) with prescribed values in place. */
int mo_stepper_predict(mo_stepper *S, const mo_state *s, double *x_full, mo_ctx *ctx);
/* 2. correction for an impulse (theta), a force (newmark, quasistatic) given over full dofs:
      dx = What^-1 imp on free dofs (0 on prescribed dofs). */
int mo_stepper_correct(mo_stepper *S, const double *imp_full, double *dx_full, mo_ctx *ctx);
/* 3. finish: from the scheme's unknown at t+ (full), update u, v, a, t, f, the works and the
      reactions. Refuses a non-finite unknown (MO_ENAN naming the dof). */
int mo_stepper_finish(mo_stepper *S, mo_state *s, const double *x_full, mo_ctx *ctx);
/* predict + finish: one step without contact. */
int mo_stepper_step(mo_stepper *S, mo_state *s, mo_ctx *ctx);

/* The factored iteration matrix and its free-dof restriction (for the Delassus operator). */
mo_linsolver *mo_stepper_solver(mo_stepper *S);
const mo_csc *mo_stepper_matrix(const mo_stepper *S);
/* Scale linking the scheme's unknown x to the displacement increment over the step,
   du = du_fixed + c dx: h theta (theta), beta h^2 (newmark), 1 (quasistatic). */
double mo_stepper_du_dx(const mo_stepper *S);
const mo_scene *mo_stepper_scene(const mo_stepper *S);
/* Free-dof restriction (gather) and extension (scatter, prescribed left untouched). */
void mo_stepper_gather(const mo_stepper *S, const double *full, double *freev);
void mo_stepper_scatter(const mo_stepper *S, const double *freev, double *full);

#ifdef __cplusplus
}
#endif
#endif
