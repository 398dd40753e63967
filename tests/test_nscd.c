/* test_nscd.c: the nscd back end: its local solvers against the law itself (the natural map),
   the Gauss-Seidel loop against Siconos' fc2d/fc3d NSGS on random well-posed problems and on the
   shared FCLIB problems, Jean's norms against the core's, options, and failure reporting. */
#include "config.h"
#include <moreau/moreau.h>
#include "../solvers/nscd/nscd.h"
#include "tap.h"

#include <unistd.h>

#ifdef HAVE_SICONOS
#include <suitesparse/cs.h>
#include <siconos/numerics/SparseBlockMatrix.h>
#include <siconos/numerics/FrictionContactProblem.h>
#include <siconos/numerics/Friction_cst.h>
#include <siconos/numerics/NonSmoothDrivers.h>
#include <siconos/numerics/NumericsMatrix.h>
#include <siconos/numerics/SolverOptions.h>
#endif

extern const mo_contact_solver_type mo_contact_solver_nscd;

/* --- a small deterministic generator (xorshift64*) ------------------------------------------- */

static double urand(unsigned long long *s)
{
  *s ^= *s >> 12;
  *s ^= *s << 25;
  *s ^= *s >> 27;
  return (double)((*s * 2685821657736338717ULL) >> 11) / 9007199254740992.0;
}

static double nrand(unsigned long long *s)
{
  double u = urand(s) + 1e-300, v = urand(s);
  return sqrt(-2 * log(u)) * cos(2 * M_PI * v);
}

static double norm(int n, const double *x)
{
  double s = 0;
  int i;
  for (i = 0; i < n; i++) s += x[i] * x[i];
  return sqrt(s);
}

/* A random SPD d x d block W = A A^T + 0.1 I with a random scale. */
static void random_block(int d, double *W, unsigned long long *s)
{
  double A[9], sc = exp(4 * (urand(s) - 0.5));
  int i, j, k;
  for (i = 0; i < d * d; i++) A[i] = nrand(s);
  for (i = 0; i < d; i++)
    for (j = 0; j < d; j++) {
      double acc = i == j ? 0.1 : 0;
      for (k = 0; k < d; k++) acc += A[i * d + k] * A[j * d + k];
      W[i * d + j] = sc * acc;
    }
}

/* --- the local solvers ------------------------------------------------------------------------- */

static void test_local(int d)
{
  unsigned long long s = 12345 + (unsigned long long)d;
  nscd_params p;
  nscd_local_stats st;
  int t, n = 20000, bad = 0, badstat = 0, wellposed = 0, counts[3] = {0, 0, 0};
  double worst = 0;
  nscd_params_default(&p);
  memset(&st, 0, sizeof st);
  for (t = 0; t < n; t++) {
    double W[9], aux[NSCD_AUX], q[3], r[3] = {0, 0, 0}, U[3], mu = 1.2 * urand(&s), e, scale;
    int i, j, status;
    random_block(d, W, &s);
    /* the one-contact problem may have no solution when W_nn <= mu |W_nt| (sliding would need
       r_n < 0 in some directions): keep the well-posed ones */
    if (W[0] <= mu * (d == 2 ? fabs(W[1]) : hypot(W[1], W[2]))) continue;
    wellposed++;
    for (i = 0; i < d; i++) q[i] = nrand(&s) * exp(2 * (urand(&s) - 0.5));
    if (t % 7 == 0) q[0] = fabs(q[0]);     /* some open contacts */
    nscd_local_prepare(d, W, mu, aux);
    status = nscd_local_solve(d, W, aux, q, mu, r, &p, &st);
    for (i = 0; i < d; i++) {
      U[i] = q[i];
      for (j = 0; j < d; j++) U[i] += W[i * d + j] * r[j];
    }
    e = sqrt(mo_fc_natural_map_unit(d, mu, r, U));
    scale = norm(d, r) + norm(d, q) / W[0];
    /* the natural map mixes r and U: measure it on U scaled by 1 / W_nn */
    for (i = 0; i < d; i++) U[i] /= W[0];
    e = sqrt(mo_fc_natural_map_unit(d, mu, r, U)) / scale;
    if (status < 0 || !(e <= 1e-10)) bad++;
    if (e > worst || isnan(e)) worst = e;
    if (status >= 0) counts[status]++;
    /* the status says which case holds */
    {
      double rt = d == 2 ? fabs(r[1]) : hypot(r[1], r[2]), ut = d == 2 ? fabs(U[1]) : hypot(U[1], U[2]);
      if (status == MO_CS_OPEN && (r[0] != 0 || U[0] < 0)) badstat++;
      if (status == MO_CS_STICK && (ut > 1e-9 * (norm(d, q) / W[0]) || rt > mu * r[0] * (1 + 1e-12))) badstat++;
      if (status == MO_CS_SLIDE && fabs(rt - mu * r[0]) > 1e-10 * r[0]) badstat++;
    }
  }
  ok(bad == 0, "%dD local solver: %d random contacts (%d open, %d stick, %d slide) solve the law to 1e-10 "
     "(worst scaled natural map %.2e; %d failures)", d, wellposed, counts[0], counts[1], counts[2], worst, bad);
  ok(badstat == 0, "%dD local solver: the status names the case that holds (%d mismatches)", d, badstat);
  ok(counts[0] > 0 && counts[1] > 0 && counts[2] > 0, "%dD: every case occurs", d);
  if (d == 3)
    ok(st.failures == 0, "3D: every solve met a tolerance (%ld Newton iterations; %ld Newton stalls, of which "
       "%ld finished by the slip-angle search and %ld by the projection; %ld failures)", st.newton, st.fallbacks,
       st.angle, st.projection, st.failures);
}

/* The three 3D methods alone on random sliding contacts: Newton from a cold start mostly
   converges (the rest stop at local minima of |phi|, which is why it has fallbacks); the search on
   the slip angle always does; the projection, when it does, finds the same reaction. */
static void test_newton_angle_projection(void)
{
  unsigned long long s = 777;
  int t, n = 1000, nbad = 0, abad = 0, pbad = 0, agree_n = 0, both_n = 0, agree_p = 0, both_p = 0;
  long it = 0;
  for (t = 0; t < n; t++) {
    double W[9], q[3], r1[3], r2[3], r3[3] = {0, 0, 0}, mu = 0.1 + 1.1 * urand(&s), rs[3], aux[NSCD_AUX];
    int i, a, b, c;
    random_block(3, W, &s);
    for (i = 0; i < 3; i++) q[i] = nrand(&s);
    q[0] = -fabs(q[0]);
    if (W[0] <= mu * hypot(W[1], W[2])) { t--; continue; }      /* well-posed (see test_local) */
    /* sliding contacts only: the stick trial fails */
    nscd_local_prepare(3, W, mu, aux);
    for (i = 0; i < 3; i++) rs[i] = -(aux[3 * i] * q[0] + aux[3 * i + 1] * q[1] + aux[3 * i + 2] * q[2]);
    if (rs[0] > 0 && hypot(rs[1], rs[2]) <= mu * rs[0]) { t--; continue; }
    r1[0] = r2[0] = -q[0] / W[0];
    r1[1] = r1[2] = r2[1] = r2[2] = 0;
    a = nscd_ac_newton(W, q, mu, 1 / W[0], 2 / (W[4] + W[8]), r1, 1e-13, 50, &it);
    b = nscd_projection(W, q, mu, r2, 1e-13, 20000);
    c = nscd_slide_angle(W, q, mu, r3, 1e-12);
    nbad += a != 0;
    pbad += b != 0;
    abad += c != 0;
    if (!a && !c) {
      double d[3] = {r1[0] - r3[0], r1[1] - r3[1], r1[2] - r3[2]};
      both_n++;
      agree_n += norm(3, d) <= 1e-8 * norm(3, r3);
    }
    if (!b && !c) {
      double d[3] = {r2[0] - r3[0], r2[1] - r3[1], r2[2] - r3[2]};
      both_p++;
      agree_p += norm(3, d) <= 1e-8 * norm(3, r3);
    }
  }
  ok(abad == 0, "the slip-angle search solves all %d random well-posed sliding contacts to 1e-12 (mu in [0.1, 1.2])", n);
  ok(nbad <= n / 20, "Alart-Curnier Newton alone, from r = (-q_n / W_nn, 0, 0), converges on %d of %d "
     "(%.1f iterations on average)", n - nbad, n, (double)it / n);
  ok(agree_n == both_n, "where it converges, Newton finds the slip-angle solution (%d of %d)", agree_n, both_n);
  ok(agree_p == both_p && both_p > 0, "where it converges (%d of %d within 20000 iterations), the projection "
     "finds it too (%d of %d)", n - pbad, n, agree_p, both_p);
}

/* --- global problems ----------------------------------------------------------------------------- */

typedef struct {
  int d, nc, m;
  double *W;          /* m x m, row-major */
  double *q, *mu;
} problem;

static void problem_free(problem *P)
{
  free(P->W);
  free(P->q);
  free(P->mu);
}

/* W = H^T M^-1 H with random H (n = 2m dofs) and masses: SPD, well conditioned; q with normal
   parts of both signs. */
static void random_problem(int d, int nc, double mumax, unsigned long long *s, problem *P)
{
  int m = d * nc, n = 2 * m, i, j, k;
  double *H = malloc((size_t)n * m * sizeof *H), *Mi = malloc((size_t)n * sizeof *Mi);
  P->d = d;
  P->nc = nc;
  P->m = m;
  P->W = calloc((size_t)m * m, sizeof *P->W);
  P->q = malloc((size_t)m * sizeof *P->q);
  P->mu = malloc((size_t)nc * sizeof *P->mu);
  for (i = 0; i < n * m; i++) H[i] = urand(s) < 0.3 ? nrand(s) : 0;
  for (i = 0; i < n; i++) Mi[i] = 0.5 + urand(s);
  for (i = 0; i < m; i++) H[(size_t)(i % n) * m + i] += 2;   /* every contact moves */
  for (i = 0; i < m; i++)
    for (j = 0; j < m; j++) {
      double acc = 0;
      for (k = 0; k < n; k++) acc += H[(size_t)k * m + i] * Mi[k] * H[(size_t)k * m + j];
      P->W[(size_t)i * m + j] = acc;
    }
  for (i = 0; i < nc; i++) {
    P->mu[i] = mumax * (0.2 + 0.8 * urand(s));
    P->q[i * d] = nrand(s) - 0.5;
    for (j = 1; j < d; j++) P->q[i * d + j] = nrand(s);
  }
  free(H);
  free(Mi);
}

static mo_csc *dense_to_csc(int m, const double *A, mo_ctx *ctx)
{
  mo_triplet T;
  mo_csc *C = NULL;
  int i, j;
  mo_triplet_init(&T, m, m, (size_t)m * m, ctx);
  for (j = 0; j < m; j++)
    for (i = 0; i < m; i++)
      if (A[(size_t)i * m + j] != 0) mo_triplet_add(&T, i, j, A[(size_t)i * m + j], ctx);
  mo_triplet_to_csc(&T, 0, &C, ctx);
  mo_triplet_release(&T);
  return C;
}

/* Solve with nscd through the seam (mo_local_solver), options "key=value" ... */
static int solve_nscd(int d, const mo_csc *Wc, const double *q, const double *mu, double *r, double *U,
                      int *status, mo_contact_report *rep, const char *const *opts, mo_ctx *ctx)
{
  mo_delassus *W = NULL;
  mo_local_solver *L = NULL;
  int st, k;
  if ((st = mo_delassus_create(&W, ctx)) || (st = mo_delassus_set_matrix(W, Wc, d, ctx)) ||
      (st = mo_local_solver_create(&mo_contact_solver_nscd, W, q, mu, &L, ctx)))
    goto done;
  for (k = 0; opts && opts[k]; k++) {
    char key[64];
    const char *eq = strchr(opts[k], '=');
    snprintf(key, sizeof key, "%.*s", (int)(eq - opts[k]), opts[k]);
    if ((st = mo_local_solver_set(L, key, eq + 1, ctx))) goto done;
  }
  st = mo_local_solver_solve(L, r, U, status, rep, ctx);
done:
  mo_local_solver_free(L);
  mo_delassus_free(W);
  return st;
}

#ifdef HAVE_SICONOS
/* Siconos' NSGS (fc2d or fc3d) on W (the problem takes it over, with copies of q and mu);
   returns info, fills r, the iterations. */
static int siconos_nsgs(int d, int nc, NumericsMatrix *W, const double *q, const double *mu, double tol, int maxit,
                        double *r, int *iters)
{
  int m = d * nc, info;
  double *qc = malloc((size_t)m * sizeof *qc), *muc = malloc((size_t)nc * sizeof *muc), *v = calloc((size_t)m, sizeof *v);
  FrictionContactProblem *pb;
  SolverOptions *o;
  memcpy(qc, q, (size_t)m * sizeof *qc);
  memcpy(muc, mu, (size_t)nc * sizeof *muc);
  pb = frictionContactProblem_new_with_data(d, nc, W, qc, muc);
  o = solver_options_create(d == 2 ? SICONOS_FRICTION_2D_NSGS : SICONOS_FRICTION_3D_NSGS);
  o->iparam[SICONOS_IPARAM_MAX_ITER] = maxit;
  o->dparam[SICONOS_DPARAM_TOL] = tol;
  memset(r, 0, (size_t)m * sizeof *r);
  info = d == 2 ? fc2d_driver(pb, r, v, o) : fc3d_driver(pb, r, v, o);
  *iters = o->iparam[SICONOS_IPARAM_ITER_DONE];
  solver_options_delete(o);
  frictionContactProblem_free(pb);
  free(v);
  return info;
}

/* NSGS on a dense copy of the row-major W. */
static int solve_siconos(int d, int nc, const double *Wrow, const double *q, const double *mu, double tol,
                         int maxit, double *r, int *iters)
{
  int m = d * nc, i, j;
  double *A = malloc((size_t)m * m * sizeof *A);
  for (i = 0; i < m; i++)
    for (j = 0; j < m; j++) A[(size_t)j * m + i] = Wrow[(size_t)i * m + j];   /* column-major */
  return siconos_nsgs(d, nc, NM_create_from_data(NM_DENSE, m, m, A), q, mu, tol, maxit, r, iters);
}

/* The same on Siconos' sparse-block storage, from a compressed-column W. */
static int solve_siconos_csc(int d, int nc, const mo_csc *W, const double *q, const double *mu, double tol,
                             int maxit, double *r, int *iters)
{
  int m = d * nc, j, nnz = W->p[m];
  long *Ap = malloc(((size_t)m + 1) * sizeof *Ap), *Ai = malloc(((size_t)nnz + 1) * sizeof *Ai);
  cs_dl A;
  SparseBlockStructuredMatrix *S = SBM_new();
  for (j = 0; j <= m; j++) Ap[j] = W->p[j];
  for (j = 0; j < nnz; j++) Ai[j] = W->i[j];
  A.nzmax = nnz;
  A.m = A.n = m;
  A.p = Ap;
  A.i = Ai;
  A.x = W->x;
  A.nz = -1;
  SBM_from_csparse(d, (const CSparseMatrix *)&A, S);
  free(Ap);
  free(Ai);
  return siconos_nsgs(d, nc, NM_create_from_data(NM_SPARSE_BLOCK, m, m, S), q, mu, tol, maxit, r, iters);
}
#endif

static void test_random_vs_siconos(int d)
{
  unsigned long long s = 99 + (unsigned long long)d;
  int t, ntest = 20, conv = 0, sic = 0, agree = 0;
  double worst_res = 0, worst_diff = 0;
  long sweeps = 0;
  for (t = 0; t < ntest; t++) {
    mo_ctx ctx;
    problem P;
    mo_csc *Wc;
    mo_contact_report rep;
    double *r, *U;
    int nc = 5 + t * 4, st;
    const char *opts[] = {"stop=natural", "tol=1e-12", "max_sweeps=100000", NULL};
    mo_ctx_init(&ctx);
    random_problem(d, nc, d == 2 ? 0.5 : 0.4, &s, &P);
    Wc = dense_to_csc(P.m, P.W, &ctx);
    r = calloc((size_t)P.m, sizeof *r);
    U = calloc((size_t)P.m, sizeof *U);
    st = solve_nscd(d, Wc, P.q, P.mu, r, U, NULL, &rep, opts, &ctx);
    if (!st && rep.reason == MO_CR_CONVERGED && rep.residual <= 1e-10) conv++;
    if (rep.residual > worst_res || st) worst_res = st ? INFINITY : rep.residual;
    sweeps += rep.iterations;
#ifdef HAVE_SICONOS
    {
      double *rs = calloc((size_t)P.m, sizeof *rs), *Us = calloc((size_t)P.m, sizeof *Us), qn = norm(P.m, P.q), diff[1] = {0};
      int it, info = solve_siconos(d, nc, P.W, P.q, P.mu, 1e-12, 100000, rs, &it), i, j;
      for (i = 0; i < P.m; i++) {
        Us[i] = P.q[i];
        for (j = 0; j < P.m; j++) Us[i] += P.W[(size_t)i * P.m + j] * rs[j];
      }
      if (info == 0 && mo_fc_natural_map(d, nc, P.mu, rs, Us, qn) <= 1e-10) sic++;
      for (i = 0; i < P.m; i++) diff[0] = fmax(diff[0], fabs(r[i] - rs[i]));
      diff[0] /= fmax(norm(P.m, r), 1e-300);
      if (diff[0] > worst_diff) worst_diff = diff[0];
      if (diff[0] <= 1e-7) agree++;
      free(rs);
      free(Us);
    }
#endif
    free(r);
    free(U);
    mo_csc_free(Wc);
    problem_free(&P);
  }
  ok(conv == ntest, "%dD: nscd reaches a natural-map residual of 1e-10 on %d random well-posed problems "
     "(5 to %d contacts, %ld sweeps in all; worst %.2e)", d, ntest, 5 + (ntest - 1) * 4, sweeps, worst_res);
#ifdef HAVE_SICONOS
  ok(sic == ntest, "%dD: Siconos' fc%dd NSGS reaches 1e-10 on the same problems (%d of %d)", d, d, sic, ntest);
  ok(agree == ntest, "%dD: the reactions agree with Siconos' (largest difference %.2e of |r|)", d, worst_diff);
#else
  ok(1, "# SKIP no Siconos in this build");
  ok(1, "# SKIP no Siconos in this build");
#endif
}

/* The shared FCLIB problems (granular media: W singular, reactions not unique): both solvers reach
   1e-10; the local velocities they find are compared. */
static void test_fclib_vs_siconos(void)
{
  static const char *files[] = {"Box_Stacks-i0122-82-5", "Capsules-i125-1213",
                                "LMGC_100_PR_PerioBox-i00361-60-03000", "Spheres-i099-356-679"};
  const char *shared = getenv("MOREAU_SHARED");
  size_t k;
  char probe[1024];
  snprintf(probe, sizeof probe, "%s/data/fclib", shared ? shared : ".");
  if (!mo_fclib_available() || !shared || access(probe, R_OK)) {
    ok(1, "# SKIP no FCLIB or no shared data (%s)", probe);
    return;
  }
  for (k = 0; k < MO_COUNT(files); k++) {
    char path[1024];
    mo_ctx ctx;
    int d, nc, m, st;
    mo_csc *W = NULL;
    double *q = NULL, *mu = NULL, *r, *U;
    mo_contact_report rep;
    const char *opts[] = {"stop=natural", "tol=1e-10", "max_sweeps=100000", "warm_start=false", NULL};
    mo_ctx_init(&ctx);
    snprintf(path, sizeof path, "%s/data/fclib/%s.hdf5", shared, files[k]);
    if (mo_fclib_read(path, &d, &nc, &W, &q, &mu, &ctx)) { ok(0, "%s: %s", files[k], ctx.errmsg); continue; }
    m = d * nc;
    r = calloc((size_t)m, sizeof *r);
    U = calloc((size_t)m, sizeof *U);
    st = solve_nscd(d, W, q, mu, r, U, NULL, &rep, opts, &ctx);
    ok(!st && rep.reason == MO_CR_CONVERGED && rep.residual <= 1e-10, "%s (%d contacts): nscd reaches %.2e in %d sweeps",
       files[k], nc, rep.residual, rep.iterations);
#ifdef HAVE_SICONOS
    {
      double *rs = calloc((size_t)m, sizeof *rs), *Us = calloc((size_t)m, sizeof *Us);
      double qn = norm(m, q), es, du = 0, dr = 0;
      int it, info, i;
      info = solve_siconos_csc(d, nc, W, q, mu, 1e-10, 100000, rs, &it);
      memcpy(Us, q, (size_t)m * sizeof *Us);
      mo_csc_gaxpy(W, 1, rs, 1, Us);
      es = mo_fc_natural_map(d, nc, mu, rs, Us, qn);
      for (i = 0; i < m; i++) {
        du = fmax(du, fabs(U[i] - Us[i]));
        dr = fmax(dr, fabs(r[i] - rs[i]));
      }
      ok(info == 0 && es <= 1e-10, "%s: Siconos' fc3d NSGS reaches %.2e in %d iterations", files[k], es, it);
      /* (the reactions of a granular packing need not be unique; the velocities are, to the
         accuracy the residual allows: 1e-10 of max(|q|, |r|, |U|) per contact) */
      ok(du <= 1e-6 * fmax(fmax(qn, norm(m, r)), norm(m, U)), "%s: the local velocities agree (largest difference "
         "%.2e; |U| = %.2e, |r| = %.2e; reactions differ by %.2e)", files[k], du, norm(m, U), norm(m, r), dr);
      free(rs);
      free(Us);
    }
#else
    ok(1, "# SKIP no Siconos in this build");
#endif
    free(r);
    free(U);
    mo_csc_free(W);
    mo_free(q);
    mo_free(mu);
  }
}

/* 1D (normal only): the problem is an LCP with a symmetric positive definite W, whose unique
   solution is found here by trying every active set. */
static void test_1d_lcp(void)
{
  unsigned long long s = 1111;
  int t, good = 0, ntest = 30;
  for (t = 0; t < ntest; t++) {
    enum { N = 8 };
    problem P;
    mo_ctx ctx;
    mo_csc *Wc;
    mo_contact_report rep;
    double r[N] = {0}, U[N], ref[N], *mu = calloc(N, sizeof *mu);
    int set, found = 0, st;
    const char *opts[] = {"stop=natural", "tol=1e-14", "max_sweeps=100000", NULL};
    mo_ctx_init(&ctx);
    random_problem(1, N, 0, &s, &P);
    for (set = 0; set < (1 << N) && !found; set++) {
      /* r_A = -W_AA^-1 q_A by Gaussian elimination on the active rows */
      double A[N][N + 1], x[N] = {0};
      int idx[N], n = 0, i, j, k, okset = 1;
      for (i = 0; i < N; i++) if (set >> i & 1) idx[n++] = i;
      for (i = 0; i < n; i++) {
        for (j = 0; j < n; j++) A[i][j] = P.W[idx[i] * N + idx[j]];
        A[i][n] = -P.q[idx[i]];
      }
      for (k = 0; k < n; k++)
        for (i = k + 1; i < n; i++) {
          double f = A[i][k] / A[k][k];
          for (j = k; j <= n; j++) A[i][j] -= f * A[k][j];
        }
      for (k = n - 1; k >= 0; k--) {
        double acc = A[k][n];
        for (j = k + 1; j < n; j++) acc -= A[k][j] * x[idx[j]];
        x[idx[k]] = acc / A[k][k];
        if (x[idx[k]] < 0) okset = 0;
      }
      for (i = 0; i < N && okset; i++) {
        double u = P.q[i];
        for (j = 0; j < N; j++) u += P.W[i * N + j] * x[j];
        if (!(set >> i & 1) && u < -1e-12) okset = 0;
      }
      if (okset) { memcpy(ref, x, sizeof ref); found = 1; }
    }
    Wc = dense_to_csc(N, P.W, &ctx);
    st = solve_nscd(1, Wc, P.q, mu, r, U, NULL, &rep, opts, &ctx);
    if (!st && found && rep.reason == MO_CR_CONVERGED) {
      double e = 0;
      int i;
      for (i = 0; i < N; i++) e = fmax(e, fabs(r[i] - ref[i]));
      if (e <= 1e-10 * fmax(norm(N, ref), 1e-300) || (norm(N, ref) == 0 && e == 0)) good++;
    }
    mo_csc_free(Wc);
    free(mu);
    problem_free(&P);
  }
  ok(good == ntest, "1D: the reactions of %d random LCPs (8 contacts) are those of the active set that solves them (%d)",
     ntest, good);
}

/* Jean's norms of the last sweep (T11), accumulated during the sweep, equal the core's
   mo_fc_jean_norms on the iterates before and after it. */
static void test_jean_norms(void)
{
  unsigned long long s = 4242;
  mo_ctx ctx;
  problem P;
  mo_csc *Wc;
  mo_delassus *W = NULL;
  mo_contact_report rep4, rep5;
  double *r4, *r5, *U, quad, maxm;
  const char *o4[] = {"stop=sweeps", "max_sweeps=4", "warm_start=false", NULL};
  const char *o5[] = {"stop=sweeps", "max_sweeps=5", "warm_start=false", NULL};
  mo_ctx_init(&ctx);
  random_problem(2, 20, 0.5, &s, &P);
  Wc = dense_to_csc(P.m, P.W, &ctx);
  r4 = calloc((size_t)P.m, sizeof *r4);
  r5 = calloc((size_t)P.m, sizeof *r5);
  U = calloc((size_t)P.m, sizeof *U);
  solve_nscd(2, Wc, P.q, P.mu, r4, U, NULL, &rep4, o4, &ctx);
  solve_nscd(2, Wc, P.q, P.mu, r5, U, NULL, &rep5, o5, &ctx);
  mo_delassus_create(&W, &ctx);
  mo_delassus_set_matrix(W, Wc, 2, &ctx);
  mo_fc_jean_norms(W, P.nc, r4, r5, &quad, &maxm);
  ok(rep4.iterations == 4 && rep5.iterations == 5 && rep5.reason == MO_CR_CONVERGED,
     "stop = \"sweeps\" runs exactly max_sweeps sweeps (%d, %d)", rep4.iterations, rep5.iterations);
  ok(quad > 0 && fabs(rep5.quad - quad) <= 1e-12 * quad, "Quad of the 5th sweep: %.6e, the core's %.6e", rep5.quad, quad);
  ok(maxm > 0 && fabs(rep5.maxm - maxm) <= 1e-12 * maxm, "Maxm of the 5th sweep: %.6e, the core's %.6e", rep5.maxm, maxm);
  mo_delassus_free(W);
  free(r4);
  free(r5);
  free(U);
  mo_csc_free(Wc);
  problem_free(&P);
}

/* Orders, relaxation, warm start and Jean's stopping rules reach the same (unique) solution. */
static void test_options(void)
{
  unsigned long long s = 31337;
  mo_ctx ctx;
  problem P;
  mo_csc *Wc;
  mo_contact_report rep;
  double *r0, *r, *U, worst = 0;
  size_t k;
  int conv = 1, st;
  static const char *variants[][6] = {
    {"order=reverse", NULL},
    {"order=shuffled", NULL},
    {"order=shuffled", "reshuffle=true", NULL},
    {"relax=0.7", NULL},
    {"relax=1.3", NULL},
    {"stop=natural", NULL},
  };
  const char *base[] = {"tol=1e-12", "max_sweeps=100000", "warm_start=false", NULL};
  mo_ctx_init(&ctx);
  random_problem(3, 40, 0.3, &s, &P);
  Wc = dense_to_csc(P.m, P.W, &ctx);
  r0 = calloc((size_t)P.m, sizeof *r0);
  r = calloc((size_t)P.m, sizeof *r);
  U = calloc((size_t)P.m, sizeof *U);
  st = solve_nscd(3, Wc, P.q, P.mu, r0, U, NULL, &rep, base, &ctx);
  ok(!st && rep.reason == MO_CR_CONVERGED, "default options: converged in %d sweeps (residual %.2e)", rep.iterations, rep.residual);
  for (k = 0; k < MO_COUNT(variants); k++) {
    const char *o[10];
    int n = 0, j, i;
    double e = 0;
    for (j = 0; base[j]; j++) o[n++] = base[j];
    for (j = 0; variants[k][j]; j++) o[n++] = variants[k][j];
    o[n] = NULL;
    memset(r, 0, (size_t)P.m * sizeof *r);
    st = solve_nscd(3, Wc, P.q, P.mu, r, U, NULL, &rep, o, &ctx);
    if (st || rep.reason != MO_CR_CONVERGED) conv = 0;
    for (i = 0; i < P.m; i++) e = fmax(e, fabs(r[i] - r0[i]));
    e /= norm(P.m, r0);
    if (e > worst) worst = e;
    diag("%s%s%s: %d sweeps", variants[k][0], variants[k][1] ? " " : "", variants[k][1] ? variants[k][1] : "", rep.iterations);
  }
  ok(conv && worst <= 1e-8, "orders, relaxations and the unscaled natural map find the same reactions (largest "
     "difference %.2e of |r|)", worst);
  /* warm start from the solution: one sweep confirms it */
  {
    const char *o[] = {"tol=1e-10", NULL};
    memcpy(r, r0, (size_t)P.m * sizeof *r);
    st = solve_nscd(3, Wc, P.q, P.mu, r, U, NULL, &rep, o, &ctx);
    ok(!st && rep.reason == MO_CR_CONVERGED && rep.iterations == 1, "warm start from the solution: %d sweep", rep.iterations);
  }
  {
    const char *o[] = {"stop=quad", "tol=1e-10", "warm_start=false", NULL};
    const char *o2[] = {"stop=maxm", "tol=1e-10", "warm_start=false", NULL};
    memset(r, 0, (size_t)P.m * sizeof *r);
    st = solve_nscd(3, Wc, P.q, P.mu, r, U, NULL, &rep, o, &ctx);
    ok(!st && rep.reason == MO_CR_CONVERGED && rep.quad <= 1e-10, "stop = \"quad\": Quad %.2e after %d sweeps (natural map %.2e)",
       rep.quad, rep.iterations, rep.residual);
    memset(r, 0, (size_t)P.m * sizeof *r);
    st = solve_nscd(3, Wc, P.q, P.mu, r, U, NULL, &rep, o2, &ctx);
    ok(!st && rep.reason == MO_CR_CONVERGED && rep.maxm <= 1e-10, "stop = \"maxm\": Maxm %.2e after %d sweeps (natural map %.2e)",
       rep.maxm, rep.iterations, rep.residual);
  }
  {
    const char *o[] = {"tol=1e-14", "max_sweeps=2", "warm_start=false", NULL};
    memset(r, 0, (size_t)P.m * sizeof *r);
    st = solve_nscd(3, Wc, P.q, P.mu, r, U, NULL, &rep, o, &ctx);
    ok(!st && rep.reason == MO_CR_MAXITER && strstr(rep.message, "largest local residuals at candidate"),
       "the sweep limit is a reported non-convergence, not an error: %s", rep.message);
  }
  {
    ok(mo_option_set(mo_contact_solver_nscd.options, mo_contact_solver_nscd.noptions, r, "relax", "2.5", &ctx) == MO_EINPUT,
       "relax = 2.5 is refused: %s", ctx.errmsg);
    mo_ctx_clear_error(&ctx);
    ok(mo_option_set(mo_contact_solver_nscd.options, mo_contact_solver_nscd.noptions, r, "order", "random", &ctx) == MO_EINPUT,
       "order = random is refused: %s", ctx.errmsg);
  }
  free(r0);
  free(r);
  free(U);
  mo_csc_free(Wc);
  problem_free(&P);
}

/* A candidate that nothing can push back (W_nn = 0) with a closing gap: a breakdown, reported. */
static void test_breakdown(void)
{
  mo_ctx ctx;
  double Wd[16] = {1, 0, 0.2, 0, 0, 1, 0, 0, 0.2, 0, 0, 0, 0, 0, 0, 1}; /* contact 1: W_nn = 0 */
  double q[4] = {-1, 0.1, -1, 0}, mu[2] = {0.3, 0.3}, r[4] = {0, 0, 0, 0}, U[4];
  mo_csc *Wc;
  mo_contact_report rep;
  int st, i, fin = 1;
  mo_ctx_init(&ctx);
  Wd[8] = 0;
  Wd[2] = 0;
  Wc = dense_to_csc(4, Wd, &ctx);
  st = solve_nscd(2, Wc, q, mu, r, U, NULL, &rep, NULL, &ctx);
  for (i = 0; i < 4; i++) fin &= isfinite(r[i]);
  ok(!st && rep.reason == MO_CR_BREAKDOWN && strstr(rep.message, "candidate 1") && fin,
     "W_nn = 0 with a closing gap: breakdown reported, reactions finite (%s)", rep.message);
  mo_csc_free(Wc);
}

/* A W that is not symmetric (Capsules has 1e-3): nscd copies its columns; Siconos agrees. */
static void test_asymmetric(void)
{
  unsigned long long s = 2718;
  mo_ctx ctx;
  problem P;
  mo_csc *Wc;
  mo_contact_report rep;
  double *r, *U;
  int i, j, st;
  const char *o[] = {"stop=natural", "tol=1e-12", "max_sweeps=100000", NULL};
  mo_ctx_init(&ctx);
  random_problem(3, 30, 0.3, &s, &P);
  for (i = 0; i < P.m; i++)
    for (j = 0; j < i; j++) {
      double a = 0.05 * P.W[(size_t)i * P.m + j] * nrand(&s);
      P.W[(size_t)i * P.m + j] += a;
      P.W[(size_t)j * P.m + i] -= a;
    }
  Wc = dense_to_csc(P.m, P.W, &ctx);
  r = calloc((size_t)P.m, sizeof *r);
  U = calloc((size_t)P.m, sizeof *U);
  st = solve_nscd(3, Wc, P.q, P.mu, r, U, NULL, &rep, o, &ctx);
  ok(!st && rep.reason == MO_CR_CONVERGED && rep.residual <= 1e-10, "non-symmetric W (asymmetry %.1e): residual %.2e in %d sweeps",
     mo_csc_asymmetry(Wc), rep.residual, rep.iterations);
#ifdef HAVE_SICONOS
  {
    double *rs = calloc((size_t)P.m, sizeof *rs), e = 0;
    int it, info = solve_siconos(3, P.nc, P.W, P.q, P.mu, 1e-12, 100000, rs, &it);
    for (i = 0; i < P.m; i++) e = fmax(e, fabs(r[i] - rs[i]));
    ok(info == 0 && e <= 1e-7 * norm(P.m, r), "non-symmetric W: the reactions agree with Siconos' (%.2e of |r|)", e / norm(P.m, r));
    free(rs);
  }
#else
  ok(1, "# SKIP no Siconos in this build");
#endif
  free(r);
  free(U);
  mo_csc_free(Wc);
  problem_free(&P);
}

/* Every allocation of the back end and of the local-problem layer may fail: an error, no leak,
   no crash (valgrind and ASan watch). */
extern void dgetrf_(const int *m, const int *n, double *a, const int *lda, int *ipiv, int *info);
extern void dgetrs_(const char *tr, const int *n, const int *nrhs, const double *a, const int *lda,
                    const int *ipiv, double *b, const int *ldb, int *info);

/* The bordered LU of the status iteration (T160): A x = b solved with it, against the residual
   |A x - b| / (|A| |x|) and the solution of A's own LU, on random nonsymmetric matrices (pivoting
   in both blocks), with no border, and with no leading block. */
/* x from the factor LU (piv) of A, y from dgetrf's own LU of A (in F, piv2), and the measures of
   both tests below: the largest row sum |A|, |x|, the residual |A x - b| and |x - y| (max norms) */
static void solve_against_dgetrf(int n, const double *A, double *LU, int *piv, const double *b, double *x, double *y,
                                 double *F, int *piv2, int *info, double *anorm, double *xn, double *res, double *diff)
{
  int i, j, one = 1;
  memcpy(x, b, (size_t)n * sizeof *x);
  if (*info == 0) dgetrs_("N", &n, &one, LU, &n, piv, x, &n, info);
  memcpy(F, A, (size_t)n * n * sizeof *F);
  memcpy(y, b, (size_t)n * sizeof *y);
  dgetrf_(&n, &n, F, &n, piv2, info);
  dgetrs_("N", &n, &one, F, &n, piv2, y, &n, info);
  for (i = 0; i < n; i++) {
    double r = -b[i], a = 0;
    for (j = 0; j < n; j++) {
      r += A[(size_t)j * n + i] * x[j];
      a += fabs(A[(size_t)j * n + i]);
    }
    *anorm = fmax(*anorm, a);
    *xn = fmax(*xn, fabs(x[i]));
    *res = fmax(*res, fabs(r));
    *diff = fmax(*diff, fabs(x[i] - y[i]));
  }
}

static void test_lu_border(void)
{
  static const int sizes[][2] = {{12, 8}, {40, 33}, {7, 7}, {5, 0}, {1, 0}, {30, 1}};
  unsigned long long seed = 0x9e3779b97f4a7c15ULL;
  size_t t;
  for (t = 0; t < sizeof sizes / sizeof *sizes; t++) {
    int n = sizes[t][0], n0 = sizes[t][1], i, j, info = 0;
    double *A = malloc((size_t)n * n * sizeof *A), *F0 = malloc(((size_t)n0 * n0 + 1) * sizeof *F0);
    double *LU = malloc((size_t)n * n * sizeof *LU), *F = malloc((size_t)n * n * sizeof *F);
    double *b = malloc((size_t)n * sizeof *b), *x = malloc((size_t)n * sizeof *x), *y = malloc((size_t)n * sizeof *y);
    int *piv = malloc((size_t)n * sizeof *piv), *piv2 = malloc((size_t)n * sizeof *piv2);
    double anorm = 0, xn = 0, res = 0, diff = 0;
    for (j = 0; j < n; j++)
      for (i = 0; i < n; i++) A[(size_t)j * n + i] = nrand(&seed) + (i == j ? 0.5 : 0);
    for (i = 0; i < n; i++) b[i] = nrand(&seed);
    for (j = 0; j < n0; j++) memcpy(F0 + (size_t)j * n0, A + (size_t)j * n, (size_t)n0 * sizeof *F0);
    if (n0) dgetrf_(&n0, &n0, F0, &n0, piv, &info);
    nscd_lu_border(n, n0, A, F0, LU, piv, &info);
    solve_against_dgetrf(n, A, LU, piv, b, x, y, F, piv2, &info, &anorm, &xn, &res, &diff);
    ok(info == 0 && res <= 1e-13 * anorm * xn && diff <= 1e-10 * xn,
       "bordered LU %d + %d: residual %.2e of |A| |x| (< 1e-13), %.2e from A's own LU (< 1e-10)", n0, n - n0,
       res / (anorm * xn), diff / xn);
    free(A); free(F0); free(LU); free(F); free(b); free(x); free(y); free(piv); free(piv2);
  }
}

/* The Cholesky factor of a symmetric closed set written in LU's layout (T163): A x = b solved by
   dgetrs on it, against the residual and dgetrf's solution, on random positive definite matrices
   (no pivot taken: the Cholesky path), bordered by the LU of (T160), and on a symmetric
   indefinite matrix (dgetrf's pivots: the fallback). */
static void test_factor_closed(void)
{
  static const int sizes[][3] = {{1, 0, 0}, {7, 0, 0}, {40, 0, 0}, {120, 0, 0}, {50, 36, 0}, {30, 0, 1}};
  unsigned long long seed = 0x2545f4914f6cdd1dULL;
  size_t t;
  for (t = 0; t < sizeof sizes / sizeof *sizes; t++) {
    int n = sizes[t][0], n0 = sizes[t][1], indef = sizes[t][2], i, j, l, info = 0, nopiv = 1;
    double *B = malloc((size_t)n * n * sizeof *B), *A = malloc((size_t)n * n * sizeof *A);
    double *F0 = malloc(((size_t)n0 * n0 + 1) * sizeof *F0), *LU = malloc((size_t)n * n * sizeof *LU);
    double *F = malloc((size_t)n * n * sizeof *F), *b = malloc((size_t)n * sizeof *b);
    double *x = malloc((size_t)n * sizeof *x), *y = malloc((size_t)n * sizeof *y);
    int *piv = malloc((size_t)n * sizeof *piv), *piv2 = malloc((size_t)n * sizeof *piv2);
    double anorm = 0, xn = 0, res = 0, diff = 0;
    for (i = 0; i < n * n; i++) B[i] = nrand(&seed);
    /* A = B B^T + I (positive definite), or B + B^T (indefinite) */
    for (j = 0; j < n; j++)
      for (i = 0; i < n; i++) {
        double v = 0;
        if (indef) v = B[(size_t)j * n + i] + B[(size_t)i * n + j];
        else {
          for (l = 0; l < n; l++) v += B[(size_t)l * n + i] * B[(size_t)l * n + j];
          v += i == j;
        }
        A[(size_t)j * n + i] = v;
      }
    for (i = 0; i < n; i++) b[i] = nrand(&seed);
    if (n0) {
      /* the leading block, copied out of A (leading dimension n0) */
      for (j = 0; j < n0; j++) memcpy(F + (size_t)j * n0, A + (size_t)j * n, (size_t)n0 * sizeof *F);
      nscd_factor_closed(n0, F, F0, piv, 1, &info);
      for (i = 0; i < n0; i++) nopiv &= piv[i] == i + 1;
      nscd_lu_border(n, n0, A, F0, LU, piv, &info);
    } else {
      nscd_factor_closed(n, A, LU, piv, 1, &info);
      for (i = 0; i < n; i++) nopiv &= piv[i] == i + 1;
    }
    solve_against_dgetrf(n, A, LU, piv, b, x, y, F, piv2, &info, &anorm, &xn, &res, &diff);
    /* the fallback is dgetrf itself: its solution to the bit */
    ok(info == 0 && res <= 1e-13 * anorm * xn && (indef ? diff == 0 && !nopiv : diff <= 1e-10 * xn && nopiv),
       "%s n = %d (bordered from %d): residual %.2e of |A| |x| (< 1e-13), %.2e from dgetrf's (%s), %s",
       indef ? "indefinite" : "Cholesky as LU", n, n0, res / (anorm * xn), diff / xn, indef ? "0" : "< 1e-10",
       nopiv ? "no pivots (Cholesky)" : "pivoted (dgetrf)");
    free(B); free(A); free(F0); free(LU); free(F); free(b); free(x); free(y); free(piv); free(piv2);
  }
}

static void test_alloc_failures(void)
{
  unsigned long long s = 5;
  problem P;
  mo_csc *Wc;
  mo_ctx ctx;
  long k;
  int fails = 0, wrong = 0, st = 1;
  const char *o[] = {"order=shuffled", NULL};
  mo_ctx_init(&ctx);
  random_problem(3, 10, 0.3, &s, &P);
  Wc = dense_to_csc(P.m, P.W, &ctx);
  for (k = 1; st && k < 200; k++) {
    double r[30] = {0}, U[30];
    mo_contact_report rep;
    mo_ctx_init(&ctx);
    ctx.alloc_fail_at = k;
    st = solve_nscd(3, Wc, P.q, P.mu, r, U, NULL, &rep, o, &ctx);
    if (st) {
      fails++;
      if (st != MO_ENOMEM) wrong++;
    }
  }
  ok(!st && fails > 5 && !wrong, "each of the %d allocations failing in turn gives MO_ENOMEM; then the solve succeeds", fails);
  mo_csc_free(Wc);
  problem_free(&P);
}

int main(void)
{
  test_local(2);
  test_local(3);
  test_newton_angle_projection();
  test_random_vs_siconos(2);
  test_random_vs_siconos(3);
  test_fclib_vs_siconos();
  test_1d_lcp();
  test_jean_norms();
  test_options();
  test_breakdown();
  test_asymmetric();
  test_lu_border();
  test_factor_closed();
  test_alloc_failures();
  return done_testing();
}
