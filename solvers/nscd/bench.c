/* bench.c: `moreau bench-local`: the nscd back end on FCLIB local problems, timed cold to fixed
   accuracies of the natural map (T10), side by side with Siconos' NSGS (fc2d/fc3d) when the build
   has Siconos numerics. */
#include "config.h"
#include <moreau/bench.h>
#include "nscd.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#ifdef HAVE_SICONOS
#include <suitesparse/cs.h>
#include <siconos/numerics/FrictionContactProblem.h>
#include <siconos/numerics/Friction_cst.h>
#include <siconos/numerics/NonSmoothDrivers.h>
#include <siconos/numerics/NumericsMatrix.h>
#include <siconos/numerics/SolverOptions.h>
#include <siconos/numerics/SparseBlockMatrix.h>
#endif

extern const mo_contact_solver_type mo_contact_solver_nscd;

/* CPU time of the process (s): on a shared machine it does not count the time other processes
   hold the core, and it counts every thread a library might start. */
static double cpu_clock(void)
{
  struct timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

void mo_bench_options_default(mo_bench_options *o)
{
  o->tol = 1e-8;
  o->max_sweeps = 20000;
  o->min_time = 0.2;
  o->vs_siconos = 0;
  o->siconos_dense = 0;
}

int mo_bench_have_siconos(void)
{
#ifdef HAVE_SICONOS
  return 1;
#else
  return 0;
#endif
}

/* One measured solve: the fastest of repeated cold solves. */
typedef struct {
  int reached;          /* the natural-map residual (T10) met the tolerance */
  int sweeps;
  double residual, time;
} bench_run;

typedef struct {
  int d, nc, m;
  const mo_csc *Wc;     /* m x m */
  const mo_delassus *W;
  const double *q, *mu;
  double qnorm;
  double *r, *U;
} bench_problem;

static int run_nscd(const bench_problem *B, mo_local_solver *L, double tol, double min_time,
                    bench_run *out, mo_ctx *ctx)
{
  char buf[32];
  double t0, tsum = 0, best = HUGE_VAL;
  int st, reps = 0;
  mo_contact_report rep;
  snprintf(buf, sizeof buf, "%.17g", tol);
  if ((st = mo_local_solver_set(L, "tol", buf, ctx))) return st;
  /* the timed solves are the back end's alone (as Siconos' are its driver's); one more solve,
     untimed, gets the core's residual (T10) on U = W r + q */
  mo_local_solver_verify(L, 0);
  do {
    double t;
    memset(B->r, 0, (size_t)B->m * sizeof *B->r);
    t0 = cpu_clock();
    if ((st = mo_local_solver_solve(L, B->r, B->U, NULL, &rep, ctx))) break;
    t = cpu_clock() - t0;
    tsum += t;
    if (t < best) best = t;
    reps++;
  } while (tsum < min_time && reps < 1000);
  mo_local_solver_verify(L, 1);
  if (st) return st;
  memset(B->r, 0, (size_t)B->m * sizeof *B->r);
  if ((st = mo_local_solver_solve(L, B->r, B->U, NULL, &rep, ctx))) return st;
  out->sweeps = rep.iterations;
  out->residual = rep.residual;
  out->reached = rep.reason > 0 && rep.residual <= tol;
  out->time = best;
  return MO_OK;
}

#ifdef HAVE_SICONOS
/* Siconos' problem on copies of the data (it owns and frees them). */
static FrictionContactProblem *siconos_problem(const bench_problem *B, int dense, mo_ctx *ctx)
{
  int m = B->m, j, p, nnz = B->Wc->p[m];
  double *q = malloc((size_t)m * sizeof *q), *mu = malloc((size_t)B->nc * sizeof *mu);
  NumericsMatrix *M = NULL;
  if (!q || !mu) goto fail;
  memcpy(q, B->q, (size_t)m * sizeof *q);
  memcpy(mu, B->mu, (size_t)B->nc * sizeof *mu);
  if (dense) {
    double *A = calloc((size_t)m * (size_t)m, sizeof *A);   /* column-major */
    if (!A) goto fail;
    for (j = 0; j < m; j++)
      for (p = B->Wc->p[j]; p < B->Wc->p[j + 1]; p++) A[(size_t)j * (size_t)m + (size_t)B->Wc->i[p]] = B->Wc->x[p];
    M = NM_create_from_data(NM_DENSE, m, m, A);
  } else {
    /* its sparse-block storage, the one its NSGS is written for */
    cs_dl A;
    SparseBlockStructuredMatrix *S = SBM_new();
    long *Ap = malloc(((size_t)m + 1) * sizeof *Ap), *Ai = malloc(((size_t)nnz + 1) * sizeof *Ai);
    if (!S || !Ap || !Ai) { free(Ap); free(Ai); free(S); goto fail; }
    for (j = 0; j <= m; j++) Ap[j] = B->Wc->p[j];
    for (p = 0; p < nnz; p++) Ai[p] = B->Wc->i[p];
    A.nzmax = nnz;
    A.m = A.n = m;
    A.p = Ap;
    A.i = Ai;
    A.x = B->Wc->x;
    A.nz = -1;
    if (SBM_from_csparse(B->d, (const CSparseMatrix *)&A, S)) {
      free(Ap); free(Ai);
      SBM_clear(S);
      free(S);
      goto fail;
    }
    free(Ap);
    free(Ai);
    M = NM_create_from_data(NM_SPARSE_BLOCK, m, m, S);
  }
  if (!M) goto fail;
  return frictionContactProblem_new_with_data(B->d, B->nc, M, q, mu);
fail:
  free(q);
  free(mu);
  mo_error(ctx, MO_ENOMEM, "cannot build Siconos' problem");
  return NULL;
}

static int run_siconos(const bench_problem *B, FrictionContactProblem *pb, double tol, int maxit,
                       double min_time, bench_run *out, mo_ctx *ctx)
{
  double t0, tsum = 0, best = HUGE_VAL;
  int reps = 0, info = 0, it = 0, i;
  do {
    SolverOptions *o = solver_options_create(B->d == 2 ? SICONOS_FRICTION_2D_NSGS : SICONOS_FRICTION_3D_NSGS);
    double t;
    if (!o) return mo_error(ctx, MO_ENOMEM, "Siconos' solver options");
    o->iparam[SICONOS_IPARAM_MAX_ITER] = maxit;
    o->dparam[SICONOS_DPARAM_TOL] = tol;
    memset(B->r, 0, (size_t)B->m * sizeof *B->r);
    memset(B->U, 0, (size_t)B->m * sizeof *B->U);
    t0 = cpu_clock();
    info = B->d == 2 ? fc2d_driver(pb, B->r, B->U, o) : fc3d_driver(pb, B->r, B->U, o);
    t = cpu_clock() - t0;
    it = o->iparam[SICONOS_IPARAM_ITER_DONE];
    solver_options_delete(o);
    tsum += t;
    if (t < best) best = t;
    reps++;
  } while (tsum < min_time && reps < 1000);
  /* the same measure as ours, on U = W r + q */
  mo_delassus_mult(B->W, B->r, 0, B->U);
  for (i = 0; i < B->m; i++) B->U[i] += B->q[i];
  out->residual = mo_fc_natural_map(B->d, B->nc, B->mu, B->r, B->U, B->qnorm);
  out->sweeps = it;
  out->reached = info == 0 && out->residual <= tol;
  out->time = best;
  return MO_OK;
}
#endif

static void fmt_time(char *buf, size_t n, const bench_run *R)
{
  if (!R->reached) snprintf(buf, n, "-");
  else if (R->time < 1e-3) snprintf(buf, n, "%.1f us", R->time * 1e6);
  else if (R->time < 1) snprintf(buf, n, "%.2f ms", R->time * 1e3);
  else snprintf(buf, n, "%.3f s", R->time);
}

static void print_row(FILE *out, const char *name, const char *who, int nc, const bench_run *main,
                      const bench_run *t4, const bench_run *t8)
{
  char a[32], b[32];
  fmt_time(a, sizeof a, t4);
  fmt_time(b, sizeof b, t8);
  fprintf(out, "%-38.38s %5d  %-8s %7d  %9.2e  %10s  %10s  %8.3f\n", name, nc, who, main->sweeps, main->residual,
          a, b, main->sweeps > 0 ? main->time * 1e6 / ((double)main->sweeps * nc) : NAN);
}

static void print_ratio(FILE *out, double x, int ok)
{
  if (ok && x > 0 && isfinite(x)) fprintf(out, "  %10.2f", x);
  else fprintf(out, "  %10s", "-");
}

int mo_bench_local(const char *const *files, int nfiles, const mo_bench_options *o, FILE *out,
                   mo_ctx *ctx)
{
  int k, st = MO_OK;
#ifndef HAVE_SICONOS
  if (o->vs_siconos)
    return mo_error(ctx, MO_EUNSUPPORTED, "--vs-siconos: this build has no Siconos numerics "
                    "(configure found no libsiconos-numerics-dev)");
#endif
  fprintf(out, "bench-local: cold solves to the natural-map residual (T10); times are process CPU times, "
               "the fastest of\nsolves repeated over %.2g s; sweeps, residual and us/update at tol = %.0e; "
               "limit %d sweeps\n\n", o->min_time, o->tol, o->max_sweeps);
  fprintf(out, "%-38s %5s  %-8s %7s  %9s  %10s  %10s  %8s\n", "problem", "nc", "solver", "sweeps", "residual",
          "t(1e-4)", "t(1e-8)", "us/update");
  for (k = 0; k < nfiles && !st; k++) {
    bench_problem B;
    mo_csc *Wc = NULL;
    mo_delassus *W = NULL;
    mo_local_solver *L = NULL;
    double *q = NULL, *mu = NULL;
    bench_run ours, o4, o8;
    const char *name = strrchr(files[k], '/') ? strrchr(files[k], '/') + 1 : files[k];
    char buf[32];
    int i;
    memset(&B, 0, sizeof B);
    if ((st = mo_fclib_read(files[k], &B.d, &B.nc, &Wc, &q, &mu, ctx))) goto next;
    B.m = B.d * B.nc;
    B.Wc = Wc;
    B.q = q;
    B.mu = mu;
    for (i = 0; i < B.m; i++) B.qnorm += q[i] * q[i];
    B.qnorm = sqrt(B.qnorm);
    B.r = mo_calloc(ctx, (size_t)B.m + 1, sizeof *B.r);
    B.U = mo_calloc(ctx, (size_t)B.m + 1, sizeof *B.U);
    if (!B.r || !B.U) { st = MO_ENOMEM; goto next; }
    if ((st = mo_delassus_create(&W, ctx)) || (st = mo_delassus_set_matrix(W, Wc, B.d, ctx))) goto next;
    B.W = W;
    if ((st = mo_local_solver_create(&mo_contact_solver_nscd, W, q, mu, &L, ctx))) goto next;
    snprintf(buf, sizeof buf, "%d", o->max_sweeps);
    if ((st = mo_local_solver_set(L, "max_sweeps", buf, ctx)) || (st = mo_local_solver_set(L, "stop", "natural", ctx)) ||
        (st = mo_local_solver_set(L, "warm_start", "false", ctx)))
      goto next;
    if ((st = run_nscd(&B, L, o->tol, o->min_time, &ours, ctx)) || (st = run_nscd(&B, L, 1e-4, o->min_time, &o4, ctx)) ||
        (st = run_nscd(&B, L, 1e-8, o->min_time, &o8, ctx)))
      goto next;
    print_row(out, name, "nscd", B.nc, &ours, &o4, &o8);
#ifdef HAVE_SICONOS
    if (o->vs_siconos) {
      bench_run s, s4, s8;
      /* Debian's fc2d NSGS on sparse-block storage stops after one iteration, far from the
         solution: 2D problems go to its dense path */
      int dense = o->siconos_dense || B.d == 2;
      FrictionContactProblem *pb = siconos_problem(&B, dense, ctx);
      if (!pb) { st = MO_ENOMEM; goto next; }
      st = run_siconos(&B, pb, o->tol, o->max_sweeps, o->min_time, &s, ctx);
      if (!st) st = run_siconos(&B, pb, 1e-4, o->max_sweeps, o->min_time, &s4, ctx);
      if (!st) st = run_siconos(&B, pb, 1e-8, o->max_sweeps, o->min_time, &s8, ctx);
      frictionContactProblem_free(pb);
      if (st) goto next;
      print_row(out, "", dense ? "sic-dens" : "siconos", B.nc, &s, &s4, &s8);
      fprintf(out, "%-38s %5s  %-8s %7s  %9s", "", "", "ratio", "", "");
      print_ratio(out, s4.time / o4.time, s4.reached && o4.reached);
      print_ratio(out, s8.time / o8.time, s8.reached && o8.reached);
      fprintf(out, "  %8.2f   (Siconos / nscd)\n",
              (s.time / ((double)s.sweeps * B.nc)) / (ours.time / ((double)ours.sweeps * B.nc)));
    }
#endif
  next:
    /* the file's name, once (the reader's messages begin with it) */
    if (st && strncmp(ctx->errmsg, files[k], strlen(files[k]))) mo_error_prefix(ctx, "%s", files[k]);
    mo_local_solver_free(L);
    mo_delassus_free(W);
    mo_csc_free(Wc);
    mo_free(q);
    mo_free(mu);
    mo_free(B.r);
    mo_free(B.U);
  }
  return st;
}
