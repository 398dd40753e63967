/* jacobi.c: an example of a contact back end built outside moreau (doc/backends.md): a projected
   block Jacobi iteration on the Delassus operator, loaded at run time as a plug-in:

     moreau run CASE --plugin ./jacobi.so --solver jacobi
     moreau compare CASE --plugin ./jacobi.so --solvers nscd,jacobi

   The step's local problem is U = W r + q with Signorini's condition U_n >= 0 _|_ r_n >= 0 and
   Coulomb's law on U_t (doc/theory.md §5). Its solutions are the fixed points of the natural
   map, r = P_K(r - rho (U + mu |U_t| e_n)) at every contact (De Saxce's modified velocity),
   which this back end iterates for every contact at once from the same U (Jacobi; nscd updates
   them one after the other, Gauss-Seidel):

     r_a <- P_K(r_a - omega / W_a,nn (U_a + mu_a |U_a,t| e_n)),   U = W r + q      (T170)

   Without friction this is a projected gradient step on 1/2 r.W r + q.r scaled by the diagonal
   D of W, which converges for omega < 2 / lambda_max(D^-1 W); omega = 0 (the default) takes
   1 / lambda_max, estimated by power iterations on D^-1/2 W D^-1/2 (T171). The iteration stops
   on the natural-map residual the core measures for every back end (T10). Equations: moreau's
   doc/theory.md §10.4. */
#include <moreau/backend.h>

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

typedef struct {
  double omega; /* relaxation; 0: 1 / lambda_max(D^-1 W) */
  double tol;   /* natural-map residual to reach */
  int max_iter;
} jacobi_params;

static void jacobi_defaults(void *params)
{
  jacobi_params *p = params;
  p->omega = 0;
  p->tol = 1e-10;
  p->max_iter = 100000;
}

static const mo_option_spec jacobi_options[] = {
  {"omega", MO_OPT_DOUBLE, offsetof(jacobi_params, omega), NULL, 0, 2, "0",
   "Relaxation of the projected Jacobi step (0: 1 / lambda_max of the diagonally scaled W)."},
  {"tol", MO_OPT_DOUBLE, offsetof(jacobi_params, tol), NULL, 1e-16, 1e-2, "1e-10",
   "Natural-map residual (the core's measure) at which the iteration stops."},
  {"max_iter", MO_OPT_INT, offsetof(jacobi_params, max_iter), NULL, 1, 100000000, "100000",
   "Iteration limit."},
};

typedef struct {
  jacobi_params p;
  int nc, d, m, nact;
  double *U, *rho, *y, *z; /* m, nc, m, m */
  int *act;                /* the candidates that may close this step */
} jacobi_state;

static void jacobi_free(void *state)
{
  jacobi_state *S = state;
  mo_free(S->U);
  mo_free(S->rho);
  mo_free(S->y);
  mo_free(S->z);
  mo_free(S->act);
}

static int jacobi_init(void *state, const void *params, const mo_contact_problem *P, mo_ctx *ctx)
{
  jacobi_state *S = state;
  size_t m = (size_t)P->m + 1, nc = (size_t)P->nc + 1;
  S->p = *(const jacobi_params *)params;
  S->nc = P->nc;
  S->d = P->dim;
  S->m = P->m;
  S->U = mo_malloc(ctx, m * sizeof(double));
  S->y = mo_malloc(ctx, m * sizeof(double));
  S->z = mo_malloc(ctx, m * sizeof(double));
  S->rho = mo_malloc(ctx, nc * sizeof(double));
  S->act = mo_malloc(ctx, nc * sizeof(int));
  return S->U && S->y && S->z && S->rho && S->act ? MO_OK : MO_ENOMEM;
}

/* U = W r + q */
static void local_velocity(const mo_contact_problem *P, const double *r, double *U)
{
  int i;
  mo_delassus_mult(P->W, r, 0, U);
  for (i = 0; i < P->m; i++) U[i] += P->b[i];
}

/* lambda_max of D^-1/2 W D^-1/2 over the active contacts (D = W_a,nn on each of a's rows), by
   power iterations from a vector of ones: a lower bound that is close after a few tens (T171). */
static double lambda_max(jacobi_state *S, const mo_contact_problem *P)
{
  int d = S->d, k, i, it;
  double lam = 1;
  /* W multiplies every candidate's entries of z: those of the inactive ones stay zero */
  memset(S->y, 0, (size_t)S->m * sizeof *S->y);
  memset(S->z, 0, (size_t)S->m * sizeof *S->z);
  for (k = 0; k < S->nact; k++)
    for (i = 0; i < d; i++) S->y[S->act[k] * d + i] = 1;
  for (it = 0; it < 50; it++) {
    double n2 = 0, l = 0;
    for (k = 0; k < S->nact; k++)
      for (i = 0; i < d; i++) S->z[S->act[k] * d + i] = S->y[S->act[k] * d + i] * sqrt(S->rho[S->act[k]]);
    mo_delassus_mult(P->W, S->z, 0, S->U);
    for (k = 0; k < S->nact; k++)
      for (i = 0; i < d; i++) {
        int j = S->act[k] * d + i;
        double v = S->U[j] * sqrt(S->rho[S->act[k]]);
        l += v * S->y[j];
        n2 += S->y[j] * S->y[j];
        S->z[j] = v;
      }
    if (!(n2 > 0)) break;
    lam = l / n2;
    n2 = 0;
    for (k = 0; k < S->nact; k++)
      for (i = 0; i < d; i++) n2 += S->z[S->act[k] * d + i] * S->z[S->act[k] * d + i];
    if (!(n2 > 0)) break;
    for (k = 0; k < S->nact; k++)
      for (i = 0; i < d; i++) S->y[S->act[k] * d + i] = S->z[S->act[k] * d + i] / sqrt(n2);
  }
  return lam > 0 && isfinite(lam) ? lam : 1;
}

/* One Jacobi step at every active contact from U: y = P_K(r - omega rho (U + mu |U_t| e_n)) (T170). */
static void jacobi_step(jacobi_state *S, const mo_contact_problem *P, const double *r, double omega)
{
  int d = S->d, k, i;
  for (k = 0; k < S->nact; k++) {
    int a = S->act[k];
    const double *Ua = &S->U[a * d];
    double ut = 0, *ya = &S->y[a * d];
    for (i = 1; i < d; i++) ut += Ua[i] * Ua[i];
    for (i = 0; i < d; i++) ya[i] = r[a * d + i] - omega * S->rho[a] * (Ua[i] + (i ? 0 : P->mu[a] * sqrt(ut)));
    mo_fc_project_cone(d, P->mu[a], ya);
  }
}

static int status_of(int d, double mu, const double *r)
{
  double rt = 0;
  int i;
  if (!(r[0] > 0)) return MO_CS_OPEN;
  if (d == 1) return MO_CS_STICK;
  for (i = 1; i < d; i++) rt += r[i] * r[i];
  return mu > 0 && sqrt(rt) < (1 - 1e-9) * mu * r[0] ? MO_CS_STICK : MO_CS_SLIDE;
}

static int jacobi_solve(void *state, const mo_contact_problem *P, mo_contact_vars *x, mo_contact_report *rep,
                        mo_ctx *ctx)
{
  jacobi_state *S = state;
  int d = S->d, a, i, k, it = 0;
  double *r = x->r, omega, qn = 0, res = HUGE_VAL;
  if (!P->W) return mo_error(ctx, MO_EINTERNAL, "jacobi: the core built no Delassus operator");
  if (P->nc != S->nc || P->dim != d) return mo_error(ctx, MO_EINTERNAL, "jacobi: the problem changed size");
  /* the active contacts, warm-started from the last step's reactions inside the cone */
  S->nact = 0;
  for (a = 0; a < S->nc; a++) {
    const double *Wa = mo_delassus_block(P->W, a, a);
    S->rho[a] = Wa && Wa[0] > 0 ? 1 / Wa[0] : 0;
    if ((P->active && !P->active[a]) || !(S->rho[a] > 0)) {
      for (i = 0; i < d; i++) r[a * d + i] = 0;
      continue;
    }
    S->act[S->nact++] = a;
    for (i = 0; i < d; i++) {
      if (!isfinite(r[a * d + i])) r[a * d + i] = 0;
      qn += P->b[a * d + i] * P->b[a * d + i];
    }
    mo_fc_project_cone(d, P->mu[a], &r[a * d]);
  }
  omega = S->p.omega > 0 ? S->p.omega : 1 / lambda_max(S, P);
  for (;;) {
    local_velocity(P, r, S->U);
    res = mo_fc_natural_map_subset(d, S->nact, S->act, P->mu, NULL, r, S->U, sqrt(qn)); /* (T10) */
    if (!(res > S->p.tol) || it == S->p.max_iter || (ctx->interrupt && *ctx->interrupt)) break;
    jacobi_step(S, P, r, omega);
    for (k = 0; k < S->nact; k++)
      for (i = 0; i < d; i++) r[S->act[k] * d + i] = S->y[S->act[k] * d + i];
    it++;
  }
  memcpy(x->U, S->U, (size_t)S->m * sizeof *x->U);
  for (a = 0; a < S->nc; a++) x->status[a] = status_of(d, P->mu[a], &r[a * d]);
  rep->iterations = it;
  rep->constraints = -1;
  rep->rcond = NAN;
  if (!isfinite(res)) {
    rep->reason = MO_CR_NAN;
    snprintf(rep->message, sizeof rep->message, "jacobi: the residual is not finite after %d iterations", it);
  } else if (res <= S->p.tol) {
    rep->reason = S->nact ? MO_CR_CONVERGED : MO_CR_NOCONTACT;
  } else {
    rep->reason = MO_CR_MAXITER;
    snprintf(rep->message, sizeof rep->message, "jacobi: natural-map residual %.3e after %d iterations "
             "(omega %.3g; tol %.1e)", res, it, omega, S->p.tol);
  }
  return MO_OK;
}

static const mo_contact_solver_type jacobi_type = {
  "jacobi",
  "example plug-in: projected block Jacobi on the Delassus operator (examples/backend-jacobi)",
  sizeof(jacobi_state),
  sizeof(jacobi_params),
  MO_NEEDS_DELASSUS,
  (1u << MO_SCHEME_THETA) | (1u << MO_SCHEME_NEWMARK) | (1u << MO_SCHEME_QUASISTATIC),
  jacobi_options,
  (int)(sizeof jacobi_options / sizeof jacobi_options[0]),
  jacobi_defaults,
  jacobi_init,
  jacobi_solve,
  jacobi_free,
  NULL, /* the case's time scheme */
  NULL  /* a new contact set: free, then init */
};

MO_PLUGIN(jacobi_type);
