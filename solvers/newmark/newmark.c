/* newmark.c: the classical baseline of the seeds: Newmark (beta, gamma) on displacements with
   Lagrange multipliers enforcing the end-of-step Signorini condition and Coulomb's law on the
   slip increment, solved by Alart and Curnier's generalized Newton method (doc/theory.md §9). */
#include "config.h"
#include <moreau/contact.h>

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

extern void dgesv_(const int *n, const int *nrhs, double *a, const int *lda, int *ipiv, double *b,
                   const int *ldb, int *info);

typedef struct {
  double beta, gamma;  /* Newmark parameters (the papers': (0.3025, 0.6) rods, (0.4, 0.7)
                          cylinder, (0.49, 0.9) Taylor bar) */
  double tol;          /* natural-map residual to reach */
  int max_iter;        /* Newton iterations */
  double rho;          /* augmentation, relative to 1 / W_aa (Alart-Curnier's r) */
} newmark_params;

static void newmark_defaults(void *p)
{
  newmark_params *P = p;
  P->beta = 0.3025;
  P->gamma = 0.6;
  P->tol = 1e-12;
  P->max_iter = 100;
  P->rho = 1;
}

static const mo_option_spec newmark_options[] = {
  {"beta", MO_OPT_DOUBLE, offsetof(newmark_params, beta), NULL, 1e-6, 0.5, "0.3025",
   "Newmark beta (the time scheme of this back end, whatever time.scheme says)."},
  {"gamma", MO_OPT_DOUBLE, offsetof(newmark_params, gamma), NULL, 0.5, 1, "0.6",
   "Newmark gamma (> 1/2 dissipates)."},
  {"tol", MO_OPT_DOUBLE, offsetof(newmark_params, tol), NULL, 1e-16, 1e-2, "1e-12",
   "Relative Alart-Curnier residual |Phi| / max(|r|, |rho q|) at which the generalized Newton stops."},
  {"max_iter", MO_OPT_INT, offsetof(newmark_params, max_iter), NULL, 1, 10000, "100",
   "Newton iteration limit."},
  {"rho", MO_OPT_DOUBLE, offsetof(newmark_params, rho), NULL, 1e-6, 1e6, "1",
   "Augmentation parameter times 1 / W_aa (Alart-Curnier)."},
};

typedef struct {
  int m;
  double *J, *Phi, *dr, *rtry, *U, *Utry, *rho;
  double *mu;  /* nc: the step's friction coefficients, 0 where no free dof moves the candidate
                  tangentially (W_tt = 0, e.g. on a symmetry axis: its friction impulse acts on
                  nothing, and its sticking row rho U_t would be zero) */
  int *ipiv;
  newmark_params par;
} newmark_state;

static int newmark_time(const void *params, mo_time_settings *T, mo_ctx *ctx)
{
  const newmark_params *P = params;
  (void)ctx;
  T->scheme = MO_SCHEME_NEWMARK;
  T->beta = P->beta;
  T->gamma = P->gamma;
  return MO_OK;
}

static void newmark_free(void *state)
{
  newmark_state *s = state;
  mo_free(s->J);
  mo_free(s->Phi);
  mo_free(s->dr);
  mo_free(s->rtry);
  mo_free(s->U);
  mo_free(s->Utry);
  mo_free(s->rho);
  mo_free(s->mu);
  mo_free(s->ipiv);
}

static int newmark_init(void *state, const void *params, const mo_contact_problem *P, mo_ctx *ctx)
{
  newmark_state *s = state;
  int m = P->m;
  s->par = *(const newmark_params *)params;
  s->m = m;
  s->J = mo_malloc(ctx, (size_t)m * (size_t)m * sizeof(double) + 1);
  s->Phi = mo_malloc(ctx, (size_t)m * sizeof(double) + 1);
  s->dr = mo_malloc(ctx, (size_t)m * sizeof(double) + 1);
  s->rtry = mo_malloc(ctx, (size_t)m * sizeof(double) + 1);
  s->U = mo_malloc(ctx, (size_t)m * sizeof(double) + 1);
  s->Utry = mo_malloc(ctx, (size_t)m * sizeof(double) + 1);
  s->rho = mo_malloc(ctx, (size_t)P->nc * sizeof(double) + 1);
  s->mu = mo_malloc(ctx, (size_t)P->nc * sizeof(double) + 1);
  s->ipiv = mo_malloc(ctx, (size_t)m * sizeof(int) + 1);
  if (!s->J || !s->Phi || !s->dr || !s->rtry || !s->U || !s->Utry || !s->rho || !s->mu || !s->ipiv) return MO_ENOMEM;
  return MO_OK;
}

/* Alart-Curnier's function Phi(r) at one contact (BDZ07 ref. [10]): with xi = r_n - rho U_n and
   z = r_t - rho U_t,
     open (xi <= 0):             Phi = r
     closed, stick (|z| <= mu xi): Phi = rho U
     closed, slip:               Phi_n = rho U_n, Phi_t = r_t - mu xi z / |z|
   and the rows of its generalized Jacobian (with dU/dr = W). Returns the status. */
static int ac_contact(int d, double mu, double rho, const double *r, const double *U,
                      const double *Wrows /* d rows of W, leading dimension m */, int m, int a,
                      double *Phi, double *J /* d rows, leading dimension m */)
{
  double xi = r[0] - rho * U[0], z[2] = {0, 0}, nz = 0;
  int i, j, k;
  for (i = 1; i < d; i++) {
    z[i - 1] = r[i] - rho * U[i];
    nz += z[i - 1] * z[i - 1];
  }
  nz = sqrt(nz);
  if (J)
    for (i = 0; i < d; i++)
      for (j = 0; j < m; j++) J[i * m + j] = 0;
  if (xi <= 0) {
    for (i = 0; i < d; i++) {
      Phi[i] = r[i];
      if (J) J[i * m + a * d + i] = 1;
    }
    return MO_CS_OPEN;
  }
  Phi[0] = rho * U[0];
  if (J)
    for (j = 0; j < m; j++) J[j] = rho * Wrows[j];
  if (d == 1) return MO_CS_STICK;
  if (mu == 0) { /* frictionless: the cone is the normal half-line, r_t = 0 */
    for (i = 1; i < d; i++) {
      Phi[i] = r[i];
      if (J) J[i * m + a * d + i] = 1;
    }
    return MO_CS_SLIDE;
  }
  if (nz <= mu * xi) {
    for (i = 1; i < d; i++) {
      Phi[i] = rho * U[i];
      if (J)
        for (j = 0; j < m; j++) J[i * m + j] = rho * Wrows[i * m + j];
    }
    return MO_CS_STICK;
  }
  /* slip: Phi_t = r_t - mu xi zhat; dPhi_t = E_t - mu [zhat dxi^T + xi (I - zhat zhat^T) / |z| dz]
     with dxi = e_n - rho W_n., dz = E_t - rho W_t. */
  {
    double zh[2] = {z[0] / nz, z[1] / nz};
    for (i = 1; i < d; i++) Phi[i] = r[i] - mu * xi * zh[i - 1];
    for (i = 1; J && i < d; i++)
      for (j = 0; j < m; j++) {
        double dxi = (j == a * d ? 1 : 0) - rho * Wrows[j], v = (j == a * d + i ? 1 : 0);
        v -= mu * zh[i - 1] * dxi;
        for (k = 1; k < d; k++) {
          double Pik = ((i == k) ? 1 : 0) - zh[i - 1] * zh[k - 1];
          double dz = (j == a * d + k ? 1 : 0) - rho * Wrows[k * m + j];
          v -= mu * xi / nz * Pik * dz;
        }
        J[i * m + j] = v;
      }
  }
  return MO_CS_SLIDE;
}

/* Phi and J for all contacts; returns |Phi|^2. */
static double ac_system(const mo_contact_problem *P, const double *Wd, const double *r,
                        const double *U, const double *rho, const double *mu, double *Phi, double *J,
                        int *status)
{
  int d = P->dim, m = P->m, a, i;
  double s = 0;
  for (a = 0; a < P->nc; a++) {
    int st;
    if (!P->active[a]) {
      for (i = 0; i < d; i++) {
        Phi[a * d + i] = r[a * d + i];
        if (J) {
          memset(&J[(size_t)(a * d + i) * m], 0, (size_t)m * sizeof(double));
          J[(size_t)(a * d + i) * m + a * d + i] = 1;
        }
      }
      if (status) status[a] = MO_CS_OPEN;
    } else {
      st = ac_contact(d, mu[a], rho[a], &r[a * d], &U[a * d], &Wd[(size_t)(a * d) * m], m, a,
                      &Phi[a * d], J ? &J[(size_t)(a * d) * m] : NULL);
      if (status) status[a] = st;
    }
    for (i = 0; i < d; i++) s += Phi[a * d + i] * Phi[a * d + i];
  }
  return s;
}

static int newmark_solve(void *state, const mo_contact_problem *P, mo_contact_vars *x,
                         mo_contact_report *rep, mo_ctx *ctx)
{
  newmark_state *s = state;
  const newmark_params *par = &s->par;
  int d = P->dim, m = P->m, nc = P->nc, it, i, a, st = MO_OK, one = 1, info;
  double *Wd = NULL, f, res = HUGE_VAL, qn = 0;
  if (m > 8192) return mo_error(ctx, MO_ELIMIT, "newmark back end: %d local unknowns exceed its dense "
                                "limit of 8192 (its Newton matrix is dense)", m);
  if ((st = mo_delassus_dense(P->W, &Wd, ctx))) return st;
  for (a = 0; a < nc; a++) {
    double waa = Wd[(size_t)(a * d) * m + a * d], wtt = 0;
    s->rho[a] = par->rho / (waa > 0 ? waa : 1);
    for (i = 1; i < d; i++) wtt += Wd[(size_t)(a * d + i) * m + a * d + i];
    s->mu[a] = d > 1 && !(wtt > 1e-12 * waa) ? 0 : P->mu[a];
  }
  /* warm start from the previous step, projected onto the cone */
  for (a = 0; a < nc; a++) {
    if (!P->active[a]) for (i = 0; i < d; i++) x->r[a * d + i] = 0;
    mo_fc_project_cone(d, s->mu[a], &x->r[a * d]);
  }
  /* scale of Phi (force units): |r| or |rho q| */
  {
    double rq = 0;
    for (a = 0; a < nc; a++)
      for (i = 0; i < d; i++) rq += s->rho[a] * s->rho[a] * P->b[a * d + i] * P->b[a * d + i];
    qn = sqrt(rq);
  }
  for (it = 0; it <= par->max_iter; it++) {
    double step = 1, f0, rn = 0;
    mo_delassus_mult(P->W, x->r, 0, s->U);
    for (i = 0; i < m; i++) { s->U[i] += P->b[i]; rn += x->r[i] * x->r[i]; }
    /* Alart-Curnier's Phi is zero exactly at a solution and has force units: stop on
       |Phi| / max(|r|, |rho q|) (the natural map (T10) mixes units when r and U differ by
       orders of magnitude) */
    f0 = ac_system(P, Wd, x->r, s->U, s->rho, s->mu, s->Phi, s->J, NULL);
    res = sqrt(f0) / (sqrt(rn) > qn ? sqrt(rn) : (qn > 0 ? qn : 1));
    if (!isfinite(res)) {
      rep->reason = MO_CR_NAN;
      snprintf(rep->message, sizeof rep->message, "the Newton iterate is not finite");
      break;
    }
    if (res <= par->tol) {
      rep->reason = MO_CR_CONVERGED;
      break;
    }
    if (it == par->max_iter) {
      rep->reason = MO_CR_MAXITER;
      snprintf(rep->message, sizeof rep->message, "Alart-Curnier residual %.3e after %d Newton iterations", res, it);
      break;
    }
    /* J dr = -Phi (J row-major: solve with the transpose convention of LAPACK) */
    for (i = 0; i < m; i++) s->dr[i] = -s->Phi[i];
    {
      /* LAPACK is column-major: transpose J in place */
      int r0, c0;
      for (r0 = 0; r0 < m; r0++)
        for (c0 = r0 + 1; c0 < m; c0++) {
          double t = s->J[(size_t)r0 * m + c0];
          s->J[(size_t)r0 * m + c0] = s->J[(size_t)c0 * m + r0];
          s->J[(size_t)c0 * m + r0] = t;
        }
    }
    dgesv_(&m, &one, s->J, &m, s->ipiv, s->dr, &m, &info);
    if (info != 0) {
      rep->reason = MO_CR_BREAKDOWN;
      snprintf(rep->message, sizeof rep->message, "singular generalized Jacobian at Newton iteration %d "
               "(LAPACK dgesv info %d)", it, info);
      break;
    }
    /* Armijo backtracking on |Phi|^2 */
    for (;;) {
      for (i = 0; i < m; i++) s->rtry[i] = x->r[i] + step * s->dr[i];
      mo_delassus_mult(P->W, s->rtry, 0, s->Utry);
      for (i = 0; i < m; i++) s->Utry[i] += P->b[i];
      f = ac_system(P, Wd, s->rtry, s->Utry, s->rho, s->mu, s->Phi, NULL, NULL);
      if (f <= (1 - 1e-4 * step) * f0 || step < 1e-8) break;
      step *= 0.5;
    }
    memcpy(x->r, s->rtry, (size_t)m * sizeof(double));
  }
  rep->iterations = it;
  /* final statuses and local kinematics */
  mo_delassus_mult(P->W, x->r, 0, x->U);
  for (i = 0; i < m; i++) x->U[i] += P->b[i];
  ac_system(P, Wd, x->r, x->U, s->rho, s->mu, s->Phi, NULL, x->status);
  for (a = 0; a < nc; a++)
    if (x->r[a * d] <= 0 && x->status[a] != MO_CS_OPEN) x->status[a] = MO_CS_OPEN;
  mo_free(Wd);
  return st;
}

const mo_contact_solver_type mo_contact_solver_newmark = {
  "newmark",
  "classical baseline: Newmark (beta, gamma) on displacements, Lagrange multipliers, "
  "Alart-Curnier generalized Newton",
  sizeof(newmark_state),
  sizeof(newmark_params),
  MO_NEEDS_DELASSUS,
  1u << MO_SCHEME_NEWMARK,
  newmark_options,
  (int)(sizeof newmark_options / sizeof newmark_options[0]),
  newmark_defaults,
  newmark_init,
  newmark_solve,
  newmark_free,
  newmark_time,
  NULL /* a new contact set: free, then init */
};
