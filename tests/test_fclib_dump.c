/* test_fclib_dump.c: `moreau run --dump-fclib` writes the problem each step solved
   (doc/theory.md §4.6, (T80)), a round trip through other programs: every file a short run
   writes is read back by libfclib (problem and stored solution), the stored solution is held to
   the stored problem's own law (natural-map residual (T10) of the stored (r, U) on the stored
   (W, q, mu), and U = W r + q), and Siconos' NSGS (fc2d or fc3d), started from zero on the
   stored problem, finds the stored reactions and velocities again (to 1e-5 of |r| and |U|: the
   stored solutions meet 1e-8 of (T10), the runs' tolerance with a margin).
   Scenes: cylinder-wall (velocity-level Signorini, nscd; the step 25, 3 of 32 candidates
   closed), the same with levelset, with P-weighted reactions and at the position level; Jean's
   GRECO block with weighted reactions (quasi-static); rigid scenes (newton-cradle: Moreau's
   impact law on a chain of disks; incline-block; the first steps of disk-pile, whose detected
   candidate set changes every step).
   With file arguments, it prints each file's figures instead (the table):
   tests/test_fclib_dump DIR/step-000025.hdf5 ... */
#define _XOPEN_SOURCE 700
#include "config.h"
#include <moreau/moreau.h>
#include "testlib.h"

#include <ftw.h>
#include <math.h>
#include <string.h>

#ifdef HAVE_FCLIB
#include <fclib.h>
#endif
#ifdef HAVE_SICONOS
#include <siconos/numerics/FrictionContactProblem.h>
#include <siconos/numerics/Friction_cst.h>
#include <siconos/numerics/NonSmoothDrivers.h>
#include <siconos/numerics/NumericsMatrix.h>
#include <siconos/numerics/SolverOptions.h>
#endif

#if defined(HAVE_FCLIB) && defined(HAVE_SICONOS)

static double nrm(int m, const double *x)
{
  double s = 0;
  int i;
  for (i = 0; i < m; i++) s += x[i] * x[i];
  return sqrt(s);
}

/* Siconos' NSGS on the dense copy of W (CSC): info, r and its U = W r + q. */
static int siconos_solve(int d, int nc, const mo_csc *W, const double *q, const double *mu, double *r, double *U,
                         int *iters)
{
  int m = d * nc, j, p, info;
  double *A = calloc((size_t)m * m + 1, sizeof *A), *qc = malloc((size_t)m * sizeof *qc + 1),
         *muc = malloc((size_t)nc * sizeof *muc + 1);
  FrictionContactProblem *pb;
  SolverOptions *o;
  for (j = 0; j < m; j++)
    for (p = W->p[j]; p < W->p[j + 1]; p++) A[(size_t)j * m + W->i[p]] = W->x[p];   /* column-major */
  memcpy(qc, q, (size_t)m * sizeof *qc);
  memcpy(muc, mu, (size_t)nc * sizeof *muc);
  pb = frictionContactProblem_new_with_data(d, nc, NM_create_from_data(NM_DENSE, m, m, A), qc, muc);
  o = solver_options_create(d == 2 ? SICONOS_FRICTION_2D_NSGS : SICONOS_FRICTION_3D_NSGS);
  o->iparam[SICONOS_IPARAM_MAX_ITER] = 100000;
  o->dparam[SICONOS_DPARAM_TOL] = 1e-13;
  memset(r, 0, (size_t)m * sizeof *r);
  memset(U, 0, (size_t)m * sizeof *U);
  info = d == 2 ? fc2d_driver(pb, r, U, o) : fc3d_driver(pb, r, U, o);
  *iters = o->iparam[SICONOS_IPARAM_ITER_DONE];
  solver_options_delete(o);
  frictionContactProblem_free(pb);
  /* U again from W r + q, by moreau's own product (the check does not trust either solver's U) */
  memcpy(U, q, (size_t)m * sizeof *U);
  mo_csc_gaxpy(W, 1, r, 1, U);
  return info;
}

typedef struct {
  int files, law_ok, reproduced, described, verbose;
  double worst_law, worst_dr, worst_du, worst_wrq;
  char worst_file[64];
  int nc_last, ncand_last;
} tally;

/* One dumped file: the stored solution on the stored problem, and Siconos from zero.
   tol: the largest natural-map residual (T10) of the stored solution (the run's own tolerance
   with a margin); rtol: how close Siconos' r and U must come, relative to |r| and |U|. */
static void check_file(const char *path, const char *name, double tol, double rtol, tally *T)
{
  mo_ctx ctx;
  mo_csc *W = NULL;
  double *q = NULL, *mu = NULL, *rs = NULL, *Us = NULL, *Uw = NULL;
  struct fclib_solution *sol = NULL;
  struct fclib_local *pb = NULL;
  int d, nc, m, i, it, info;
  double e, dr = 0, du = 0, wrq = 0, qn;
  mo_ctx_init(&ctx);
  if (mo_fclib_read(path, &d, &nc, &W, &q, &mu, &ctx)) {
    ok(0, "%s: read back: %s", name, ctx.errmsg);
    return;
  }
  m = d * nc;
  sol = fclib_read_solution(path);
  pb = fclib_read_local(path);
  T->files++;
  if (!sol || !sol->r || !sol->u) {
    ok(0, "%s: the file holds the step's solution", name);
    goto done;
  }
  if (pb && pb->info && pb->info->description && strstr(pb->info->description, "index set")) T->described++;
  /* the stored solution on the stored problem */
  Uw = malloc((size_t)m * sizeof *Uw + 1);
  memcpy(Uw, q, (size_t)m * sizeof *Uw);
  mo_csc_gaxpy(W, 1, sol->r, 1, Uw);
  qn = nrm(m, q);
  for (i = 0; i < m; i++) wrq = fmax(wrq, fabs(Uw[i] - sol->u[i]));
  wrq /= fmax(fmax(qn, nrm(m, sol->u)), 1e-300);
  e = mo_fc_natural_map(d, nc, mu, sol->r, Uw, qn);
  if (e <= tol && wrq <= 1e-12) T->law_ok++;
  if (!(e <= T->worst_law)) {
    T->worst_law = e;
    snprintf(T->worst_file, sizeof T->worst_file, "%s", name);
    T->nc_last = nc;
  }
  if (wrq > T->worst_wrq) T->worst_wrq = wrq;
  /* Siconos from zero */
  rs = malloc((size_t)m * sizeof *rs + 1);
  Us = malloc((size_t)m * sizeof *Us + 1);
  info = siconos_solve(d, nc, W, q, mu, rs, Us, &it);
  for (i = 0; i < m; i++) {
    dr = fmax(dr, fabs(rs[i] - sol->r[i]));
    du = fmax(du, fabs(Us[i] - Uw[i]));
  }
  dr /= fmax(nrm(m, sol->r), 1e-300);
  du /= fmax(fmax(nrm(m, Uw), qn), 1e-300);
  if (T->verbose) {
    double sn = 0, ss = 0, un = 0;
    int a, closed = 0, sclosed = 0;
    for (a = 0; a < nc; a++) {
      sn += sol->r[a * d];
      ss += rs[a * d];
      closed += sol->r[a * d] > 0;
      sclosed += rs[a * d] > 0;
      if (Uw[a * d] < un) un = Uw[a * d];
    }
    printf("# %s: %d contacts; stored: %d closed, sum r_n %.6g, min U_n %.4g, residual (T10) %.2e; Siconos (info %d, "
           "%d it.): %d closed, sum r_n %.6g (%.3gx), |dr|/|r| %.2e, |dU|/|U| %.2e\n",
           name, nc, closed, sn, un, e, info, it, sclosed, ss, sn != 0 ? ss / sn : NAN, dr, du);
  }
  if (info == 0 && dr <= rtol && du <= rtol) T->reproduced++;
  else diag("%s (%d contacts): Siconos info %d after %d iterations, |dr|/|r| = %.2e, |dU|/|U| = %.2e; stored "
            "solution's residual %.2e", name, nc, info, it, dr, du, e);
  if (dr > T->worst_dr || isnan(dr)) T->worst_dr = dr;
  if (du > T->worst_du || isnan(du)) T->worst_du = du;
done:
  if (sol) fclib_delete_solutions(sol, 1);
  if (pb) fclib_delete_local(pb);
  free(rs);
  free(Us);
  free(Uw);
  mo_csc_free(W);
  mo_free(q);
  mo_free(mu);
}

static int rm_entry(const char *p, const struct stat *sb, int flag, struct FTW *f)
{
  (void)sb; (void)flag; (void)f;
  return remove(p);
}

static int name_cmp(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

/* Run a case for a few steps with --dump-fclib and check every file it writes (at most maxf, the
   first ones in step order, plus `must` when given: a step file that has to be there). */
static void round_trip(const char *casename, const char *tag, const char *const *sets, int nset, int maxf,
                       const char *must, double tol, double rtol)
{
  char casepath[1024], out[1200], dump[1300], path[1600], err[MO_ERRMSG_MAX];
  mo_run_options o;
  tally T;
  DIR *dir;
  struct dirent *ent;
  char *names[4096];
  int n = 0, k, st, found = 0;
  memset(&T, 0, sizeof T);
  T.worst_law = -1;
  tl_case_path(casepath, sizeof casepath, casename);
  snprintf(out, sizeof out, "tests/out/fclib-dump-%s-%ld", tag, (long)getpid());
  snprintf(dump, sizeof dump, "%s/fclib", out);
  memset(&o, 0, sizeof o);
  o.case_path = casepath;
  o.sets = sets;
  o.nset = nset;
  o.outdir = out;
  o.dump_fclib = dump;
  o.no_draw = 1;
  st = tl_run_options(&o, NULL, err, sizeof err);
  if (!ok(st == MO_OK, "%s: the run with --dump-fclib %s", tag, err)) return;
  if (!(dir = opendir(dump))) {
    ok(0, "%s: %s written", tag, dump);
    return;
  }
  while ((ent = readdir(dir)) && n < 4096)
    if (strstr(ent->d_name, ".hdf5")) names[n++] = strdup(ent->d_name);
  closedir(dir);
  qsort(names, (size_t)n, sizeof *names, name_cmp);
  for (k = 0; k < n; k++) {
    int take = k < maxf || (must && !strcmp(names[k], must));
    if (must && !strcmp(names[k], must)) found = 1;
    if (!take) continue;
    snprintf(path, sizeof path, "%s/%s", dump, names[k]);
    check_file(path, names[k], tol, rtol, &T);
  }
  ok(T.files > 0 && (!must || found), "%s: %d files written, %d checked%s%s", tag, n, T.files, must ? ", among them " : "",
     must ? must : "");
  ok(T.files > 0 && T.described == T.files, "%s: every file's info says it holds the step's index set (%d of %d)", tag,
     T.described, T.files);
  ok(T.files > 0 && T.law_ok == T.files,
     "%s: the stored solution solves the stored problem in %d of %d files: U = W r + q to %.1e, natural-map residual "
     "(T10) <= %.0e (worst %.2e, %s, %d contacts)", tag, T.law_ok, T.files, T.worst_wrq, tol, T.worst_law,
     T.worst_file, T.nc_last);
  ok(T.files > 0 && T.reproduced == T.files,
     "%s: Siconos' NSGS from zero finds the stored solution in %d of %d files (r and U to %.0e of |r|, |U|; worst "
     "%.2e, %.2e)", tag, T.reproduced, T.files, rtol, T.worst_dr, T.worst_du);
  for (k = 0; k < n; k++) free(names[k]);
  nftw(out, rm_entry, 16, FTW_DEPTH | FTW_PHYS);
}

#endif

int main(int argc, char **argv)
{
#if defined(HAVE_FCLIB) && defined(HAVE_SICONOS)
  if (argc > 1) { /* test_fclib_dump FILE.hdf5...: the figures of each file (the table) */
    tally T;
    int k;
    memset(&T, 0, sizeof T);
    T.verbose = 1;
    T.worst_law = -1;
    for (k = 1; k < argc; k++) check_file(argv[k], argv[k], 1e-8, 1e-5, &T);
    return done_testing();
  }
  {
    /* the scene: 35 steps with contact from step 21; step 25 closes 3 of 32 candidates */
    const char *cw[] = {"time.end=3.0e-5"};
    const char *cwl[] = {"time.end=3.0e-5", "contact.solver=levelset"};
    const char *cwp[] = {"time.end=3.0e-5", "contact.signorini=position"};
    const char *cww[] = {"time.end=3.0e-5", "contact.reactions=weighted"};
    const char *gw[] = {"contact.reactions=weighted"};
    const char *nc[] = {"time.end=0.003"};
    const char *ib[] = {"time.end=0.02"};
    const char *dp[] = {"time.end=0.04", "nscd.stop=natural", "nscd.tol=1e-10", "nscd.max_sweeps=100000"};
    round_trip("cylinder-wall", "cylinder-wall", cw, 1, 100, "step-000025.hdf5", 1e-8, 1e-5);
    round_trip("cylinder-wall", "cylinder-wall-levelset", cwl, 2, 100, "step-000025.hdf5", 1e-8, 1e-5);
    round_trip("cylinder-wall", "cylinder-wall-position", cwp, 2, 100, NULL, 1e-8, 1e-5);
    round_trip("cylinder-wall", "cylinder-wall-weighted", cww, 2, 100, "step-000025.hdf5", 1e-8, 1e-5);
    round_trip("greco-jean-mu1", "greco-mu1-weighted", gw, 1, 1, "step-000001.hdf5", 1e-8, 1e-5);
    round_trip("newton-cradle", "newton-cradle", nc, 1, 30, NULL, 1e-8, 1e-5);
    round_trip("incline-block", "incline-block", ib, 1, 20, NULL, 1e-8, 1e-5);
    /* detected candidates whose set changes from step to step (the driver's arrays follow the
       new set at the end of the step: the dump used to mix the two sets and overran W) */
    round_trip("disk-pile", "disk-pile", dp, 4, 100, NULL, 1e-8, 1e-5);
  }
#else
  (void)argc;
  (void)argv;
  ok(1, "# SKIP this build has no FCLIB or no Siconos");
#endif
  return done_testing();
}
