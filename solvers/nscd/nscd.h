/* nscd.h: private header of the nscd back end (Jean's nonlinear Gauss-Seidel over contacts on
   the Delassus operator, doc/theory.md §8): parameters, the local solvers, the sweep kernel. */
#ifndef MOREAU_NSCD_H
#define MOREAU_NSCD_H

#include <moreau/contact.h>

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

typedef struct {
  long newton;         /* 3D Newton iterations */
  long fallbacks;      /* 3D solves the Newton did not finish (a local minimum of its merit) */
  long angle;          /* ... finished by the search on the slip angle */
  long projection;     /* ... finished by the projection */
  long failures;       /* 3D solves that met no tolerance (the best candidate is kept) */
} nscd_local_stats;

void nscd_local_prepare(int d, const double *W, double mu, double *aux);
int nscd_local_solve(int d, const double *W, const double *aux, const double *q, double mu,
                     double *r, const nscd_params *p, nscd_local_stats *st);

/* The three local solvers (called by nscd_local_solve; exposed for the tests). */
int nscd_local_1d(const double *W, const double *q, double *r);
int nscd_local_2d(const double *W, const double *aux, const double *q, double mu, double *r);
int nscd_local_3d(const double *W, const double *aux, const double *q, double mu, double *r,
                  const nscd_params *p, nscd_local_stats *st);
/* The 3D Alart-Curnier Newton, the search on the slip angle and the projection alone (tests).
   Return 0 when they met their tolerance. */
int nscd_ac_newton(const double *W, const double *q, double mu, double rho_n, double rho_t,
                   double *r, double tol, int maxit, long *iters);
int nscd_slide_angle(const double *W, const double *q, double mu, double *r, double tol);
int nscd_projection(const double *W, const double *q, double mu, double *r, double tol,
                    int maxit);

#endif
