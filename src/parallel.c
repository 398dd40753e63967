/* parallel.c: MPI ranks and their collective calls (moreau/parallel.h, doc/parallel.md); the
   serial calls in a build without PETSc. */
#include "config.h"
#include <moreau/parallel.h>

#include <stdlib.h>
#include <string.h>

#ifdef HAVE_PETSC
#include <petscsys.h>
#include <mpi.h>
#endif

int mo_parallel_available(void)
{
#ifdef HAVE_PETSC
  return 1;
#else
  return 0;
#endif
}

int mo_parallel_launched(void)
{
  /* Open MPI, MPICH/Hydra and PMIx launchers export the size of the job */
  static const char *const vars[] = {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "MPI_LOCALNRANKS"};
  size_t k;
  for (k = 0; k < MO_COUNT(vars); k++)
    if (getenv(vars[k])) return 1;
  return 0;
}

int mo_parallel_started(void)
{
#ifdef HAVE_PETSC
  PetscBool up = PETSC_FALSE;
  PetscInitialized(&up);
  return up == PETSC_TRUE;
#else
  return 0;
#endif
}

int mo_parallel_start(int *argc, char ***argv, mo_ctx *ctx)
{
#ifdef HAVE_PETSC
  PetscMPIInt r = 0, n = 1;
  if (!mo_parallel_started()) {
    /* PETSc reads its options from the command line only when given one: moreau's own
       arguments are not PETSc's, so it gets none (linear_solver.options carries them) */
    int zero = 0;
    char **none = NULL;
    (void)argc;
    (void)argv;
    if (PetscInitialize(&zero, &none, NULL, NULL))
      return mo_error(ctx, MO_EUNSUPPORTED, "PETSc could not be started (PetscInitialize failed)");
  }
  MPI_Comm_rank(PETSC_COMM_WORLD, &r);
  MPI_Comm_size(PETSC_COMM_WORLD, &n);
  ctx->rank = r;
  ctx->nranks = n;
  return MO_OK;
#else
  (void)argc;
  (void)argv;
  return mo_error(ctx, MO_EUNSUPPORTED, "this build of moreau has no MPI: configure it --with-petsc "
                  "(Debian: apt-get install petsc-dev openmpi-bin)");
#endif
}

void mo_parallel_finish(void)
{
#ifdef HAVE_PETSC
  if (mo_parallel_started()) PetscFinalize();
#endif
}

#ifdef HAVE_PETSC
/* Account one collective call of `bytes` sent by this rank. */
static void traffic(mo_ctx *ctx, double t0, double bytes)
{
  ctx->par_calls++;
  ctx->par_time += mo_clock() - t0;
  ctx->par_bytes += bytes;
}

static int mpi_fail(mo_ctx *ctx, int rc, const char *what)
{
  char msg[MPI_MAX_ERROR_STRING];
  int len = 0;
  MPI_Error_string(rc, msg, &len);
  return mo_error(ctx, MO_EINTERNAL, "MPI %s failed: %.*s", what, len, msg);
}

static int reduce(double *x, long n, MPI_Op op, const char *what, mo_ctx *ctx)
{
  double t0 = mo_clock();
  long k = 0;
  int rc;
  /* in chunks that an int count holds */
  while (k < n) {
    int m = n - k > (1L << 30) ? 1 << 30 : (int)(n - k);
    if ((rc = MPI_Allreduce(MPI_IN_PLACE, x + k, m, MPI_DOUBLE, op, PETSC_COMM_WORLD)) != MPI_SUCCESS)
      return mpi_fail(ctx, rc, what);
    k += m;
  }
  traffic(ctx, t0, 8.0 * (double)n);
  return MO_OK;
}
#endif

int mo_par_sum(double *x, long n, mo_ctx *ctx)
{
#ifdef HAVE_PETSC
  if (ctx->nranks > 1) return reduce(x, n, MPI_SUM, "sum", ctx);
#else
  (void)x;
  (void)n;
#endif
  (void)ctx;
  return MO_OK;
}

int mo_par_max(double *x, long n, mo_ctx *ctx)
{
#ifdef HAVE_PETSC
  if (ctx->nranks > 1) return reduce(x, n, MPI_MAX, "maximum", ctx);
#else
  (void)x;
  (void)n;
#endif
  (void)ctx;
  return MO_OK;
}

int mo_par_bcast(void *buf, long bytes, int root, mo_ctx *ctx)
{
#ifdef HAVE_PETSC
  if (ctx->nranks > 1) {
    double t0 = mo_clock();
    int rc;
    if (bytes > 0x7fffffffL) return mo_error(ctx, MO_ELIMIT, "MPI broadcast of %ld bytes", bytes);
    if ((rc = MPI_Bcast(buf, (int)bytes, MPI_BYTE, root, PETSC_COMM_WORLD)) != MPI_SUCCESS)
      return mpi_fail(ctx, rc, "broadcast");
    traffic(ctx, t0, ctx->rank == root ? (double)bytes : 0);
  }
#else
  (void)buf;
  (void)bytes;
  (void)root;
#endif
  (void)ctx;
  return MO_OK;
}

int mo_par_gatherv(const double *mine, const int *n, double *all, mo_ctx *ctx)
{
#ifdef HAVE_PETSC
  if (ctx->nranks > 1) {
    double t0 = mo_clock();
    int *displ, r, rc;
    long tot = 0;
    if (!(displ = mo_malloc(ctx, (size_t)ctx->nranks * sizeof *displ))) return MO_ENOMEM;
    for (r = 0; r < ctx->nranks; r++) {
      displ[r] = (int)tot;
      tot += n[r];
    }
    if (tot > 0x7fffffffL) {
      mo_free(displ);
      return mo_error(ctx, MO_ELIMIT, "MPI gather of %ld values", tot);
    }
    rc = MPI_Allgatherv(mine, n[ctx->rank], MPI_DOUBLE, all, n, displ, MPI_DOUBLE, PETSC_COMM_WORLD);
    mo_free(displ);
    if (rc != MPI_SUCCESS) return mpi_fail(ctx, rc, "gather");
    traffic(ctx, t0, 8.0 * n[ctx->rank]);
    return MO_OK;
  }
#endif
  memmove(all, mine, (size_t)n[0] * sizeof *all);
  (void)ctx;
  return MO_OK;
}

int mo_par_agree(int st, mo_ctx *ctx)
{
#ifdef HAVE_PETSC
  if (ctx->nranks > 1) {
    /* (status, -rank) pairs: the largest status, and the lowest rank that has it */
    int in[2], out[2], rc, from;
    char msg[MO_ERRMSG_MAX];
    double t0 = mo_clock();
    in[0] = st;
    in[1] = -ctx->rank;
    if ((rc = MPI_Allreduce(in, out, 1, MPI_2INT, MPI_MAXLOC, PETSC_COMM_WORLD)) != MPI_SUCCESS)
      return mpi_fail(ctx, rc, "status agreement");
    if (out[0] == MO_OK) {
      traffic(ctx, t0, 8);
      return MO_OK;
    }
    /* the failing rank's message, for every rank's diagnosis */
    from = -out[1];
    if (ctx->rank == from) snprintf(msg, sizeof msg, "%s", ctx->errmsg);
    if ((rc = MPI_Bcast(msg, (int)sizeof msg, MPI_CHAR, from, PETSC_COMM_WORLD)) != MPI_SUCCESS)
      return mpi_fail(ctx, rc, "status agreement");
    traffic(ctx, t0, 8 + (ctx->rank == from ? sizeof msg : 0));
    msg[sizeof msg - 1] = 0;
    if (st != MO_OK) return st;
    return mo_error(ctx, out[0], "rank %d stopped: %s", from, msg);
  }
#endif
  (void)ctx;
  return st;
}
