/* parallel.c: MPI ranks and their collective calls (moreau/parallel.h, doc/parallel.md): the
   serial calls, or the PETSc module's once a run has loaded it (petsc_module.h). */
#define _GNU_SOURCE /* dladdr */
#include "config.h"
#include <moreau/parallel.h>
#include "petsc_module.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef HAVE_PETSC
#include <dlfcn.h>
#include <limits.h>
#include <sys/stat.h>
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

#ifdef HAVE_PETSC
static const mo_petsc_host host = {mo_verror, mo_malloc, mo_calloc, mo_free, mo_csc_transpose, mo_csc_free, mo_clock,
                                   mo_memory_rss, mo_memory_limit, mo_log, mo_order_last,
                                   mo_order_last_set};

static int exists(const char *path)
{
  struct stat st;
  return stat(path, &st) == 0 && S_ISREG(st.st_mode);
}

/* Where the module is: MOREAU_PETSC_MODULE, beside the object holding this code (the installed
   library's folder/moreau/, or the build tree's .libs/), the build tree, the install folder. */
static int module_path(char *path, size_t n)
{
  const char *env = getenv("MOREAU_PETSC_MODULE");
  Dl_info info;
  if (env && *env) {
    snprintf(path, n, "%s", env);
    return exists(path);
  }
  if (dladdr((void *)&mo_parallel_available, &info) && info.dli_fname) {
    char dir[PATH_MAX];
    char *slash;
    snprintf(dir, sizeof dir, "%s", info.dli_fname);
    slash = strrchr(dir, '/');
    if (slash) {
      *slash = 0;
      snprintf(path, n, "%s/moreau/%s", dir, MO_PETSC_MODULE_NAME);
      if (exists(path)) return 1;
      snprintf(path, n, "%s/%s", dir, MO_PETSC_MODULE_NAME);
      if (exists(path)) return 1;
      snprintf(path, n, "%s/.libs/%s", dir, MO_PETSC_MODULE_NAME);
      if (exists(path)) return 1;
    }
  }
  snprintf(path, n, "%s/.libs/%s", MO_BUILDDIR, MO_PETSC_MODULE_NAME);
  if (exists(path)) return 1;
  snprintf(path, n, "%s/%s", MO_PKGLIBDIR, MO_PETSC_MODULE_NAME);
  return exists(path);
}

/* Load the module (once: dlopen counts) with its own symbols first: Debian's Siconos numerics
   brings the sequential MUMPS into the process, and PETSc must call the MPI one; MPI's own
   components need its symbols global. */
static int load(mo_ctx *ctx)
{
  char path[PATH_MAX + 64];
  void *h;
  const mo_petsc_module *M;
  if (ctx->par_module) return MO_OK;
  if (!module_path(path, sizeof path))
    return mo_error(ctx, MO_EUNSUPPORTED, "the PETSc module %s is not installed beside libmoreau (looked last at "
                    "%s; MOREAU_PETSC_MODULE names another)", MO_PETSC_MODULE_NAME, path);
  if (!(h = dlopen(path, RTLD_NOW | RTLD_GLOBAL | RTLD_DEEPBIND)))
    return mo_error(ctx, MO_EUNSUPPORTED, "the PETSc module %s cannot be loaded: %s", path, dlerror());
  M = (const mo_petsc_module *)dlsym(h, MO_PETSC_SYMBOL);
  if (!M || M->abi != MO_PETSC_ABI)
    return mo_error(ctx, MO_EUNSUPPORTED, "%s is not this moreau's PETSc module (%s)", path,
                    M ? "another ABI version" : "no " MO_PETSC_SYMBOL);
  ctx->par_module = M;
  return MO_OK;
}
#define MODULE(ctx) ((const mo_petsc_module *)(ctx)->par_module)
#endif

int mo_parallel_start(int *argc, char ***argv, mo_ctx *ctx)
{
  (void)argc;
  (void)argv;
#ifdef HAVE_PETSC
  {
    int st;
    if ((st = load(ctx))) return st;
    return MODULE(ctx)->start(&host, &ctx->rank, &ctx->nranks, ctx);
  }
#else
  return mo_error(ctx, MO_EUNSUPPORTED, "this build of moreau has no MPI: configure it --with-petsc "
                  "(Debian: apt-get install petsc-dev openmpi-bin)");
#endif
}

int mo_parallel_started(const mo_ctx *ctx)
{
#ifdef HAVE_PETSC
  return ctx->par_module && MODULE(ctx)->started();
#else
  (void)ctx;
  return 0;
#endif
}

void mo_parallel_finish(mo_ctx *ctx)
{
#ifdef HAVE_PETSC
  if (ctx->par_module) MODULE(ctx)->finish();
#else
  (void)ctx;
#endif
}

const mo_linsolver_type *mo_linsolver_petsc(mo_ctx *ctx)
{
#ifdef HAVE_PETSC
  if (!mo_parallel_started(ctx) && mo_parallel_start(NULL, NULL, ctx)) return NULL;
  return MODULE(ctx)->linsolver;
#else
  mo_error(ctx, MO_EUNSUPPORTED, "this build of moreau has no PETSc: configure it --with-petsc "
           "(Debian: apt-get install petsc-dev openmpi-bin)");
  return NULL;
#endif
}

/* The collective calls go to the module when there is more than one rank. */
#ifdef HAVE_PETSC
#define PARALLEL(ctx) ((ctx)->nranks > 1 && (ctx)->par_module)
#else
#define PARALLEL(ctx) 0
#endif

int mo_par_sum(double *x, long n, mo_ctx *ctx)
{
#ifdef HAVE_PETSC
  if (PARALLEL(ctx)) return MODULE(ctx)->allreduce(x, n, 0, ctx);
#endif
  (void)x;
  (void)n;
  (void)ctx;
  return MO_OK;
}

int mo_par_max(double *x, long n, mo_ctx *ctx)
{
#ifdef HAVE_PETSC
  if (PARALLEL(ctx)) return MODULE(ctx)->allreduce(x, n, 1, ctx);
#endif
  (void)x;
  (void)n;
  (void)ctx;
  return MO_OK;
}

int mo_par_bcast(void *buf, long bytes, int root, mo_ctx *ctx)
{
#ifdef HAVE_PETSC
  if (PARALLEL(ctx)) return MODULE(ctx)->bcast(buf, bytes, root, ctx);
#endif
  (void)buf;
  (void)bytes;
  (void)root;
  (void)ctx;
  return MO_OK;
}

int mo_par_gatherv(const double *mine, const int *n, double *all, mo_ctx *ctx)
{
#ifdef HAVE_PETSC
  if (PARALLEL(ctx)) return MODULE(ctx)->allgatherv(mine, n, all, ctx);
#endif
  memmove(all, mine, (size_t)n[0] * sizeof *all);
  (void)ctx;
  return MO_OK;
}

int mo_par_gather0(const double *mine, const int *n, double *all, mo_ctx *ctx)
{
#ifdef HAVE_PETSC
  if (PARALLEL(ctx)) return MODULE(ctx)->gatherv0(mine, n, all, ctx);
#endif
  memmove(all, mine, (size_t)n[0] * sizeof *all);
  (void)ctx;
  return MO_OK;
}

int mo_par_exchange(int npeer, const int *peer, const int *off, const double *send, double *recv, mo_ctx *ctx)
{
#ifdef HAVE_PETSC
  if (PARALLEL(ctx) && npeer > 0) return MODULE(ctx)->exchange(npeer, peer, off, send, recv, ctx);
#endif
  (void)npeer;
  (void)peer;
  (void)off;
  (void)send;
  (void)recv;
  (void)ctx;
  return MO_OK;
}

int mo_par_alltoall(const double *send, double *recv, mo_ctx *ctx)
{
#ifdef HAVE_PETSC
  if (PARALLEL(ctx)) return MODULE(ctx)->alltoall(send, recv, ctx);
#endif
  recv[0] = send[0];
  (void)ctx;
  return MO_OK;
}

int mo_par_exchangev(int nsend, const int *speer, const int *soff, const double *send, int nrecv, const int *rpeer,
                     const int *roff, double *recv, mo_ctx *ctx)
{
#ifdef HAVE_PETSC
  if (PARALLEL(ctx) && nsend + nrecv > 0)
    return MODULE(ctx)->exchangev(nsend, speer, soff, send, nrecv, rpeer, roff, recv, ctx);
#endif
  (void)nsend; (void)speer; (void)soff; (void)send; (void)nrecv; (void)rpeer; (void)roff; (void)recv; (void)ctx;
  return MO_OK;
}

int mo_par_agree(int st, mo_ctx *ctx)
{
#ifdef HAVE_PETSC
  if (PARALLEL(ctx)) return MODULE(ctx)->agree(st, ctx);
#endif
  (void)ctx;
  return st;
}

/* --- distributed matrices (the module's, doc/parallel.md §3) ---------------------------------- */

struct mo_dmat {
  const void *module; /* the PETSc module that made it */
  void *h;
};

int mo_dmat_create(int n, int rstart, int rend, const int *perm, const int *dnnz, const int *onnz, mo_dmat **A,
                   mo_ctx *ctx)
{
#ifdef HAVE_PETSC
  mo_dmat *D;
  int st;
  *A = NULL;
  if (!mo_parallel_started(ctx))
    return mo_error(ctx, MO_EUNSUPPORTED, "a distributed matrix needs MPI started (mo_parallel_start)");
  if (!(D = mo_calloc(ctx, 1, sizeof *D))) return MO_ENOMEM;
  D->module = ctx->par_module;
  if ((st = MODULE(ctx)->dmat_create(n, rstart, rend, perm, dnnz, onnz, &D->h, ctx))) {
    MODULE(ctx)->dmat_free(D->h);
    mo_free(D);
    return st;
  }
  *A = D;
  return MO_OK;
#else
  (void)n;
  (void)rstart;
  (void)rend;
  (void)perm;
  (void)dnnz;
  (void)onnz;
  *A = NULL;
  return mo_error(ctx, MO_EUNSUPPORTED, "this build of moreau has no PETSc: configure it --with-petsc "
                  "(Debian: apt-get install petsc-dev openmpi-bin)");
#endif
}

#ifdef HAVE_PETSC
#define DMOD(A) ((const mo_petsc_module *)(A)->module)
#endif

int mo_dmat_add(mo_dmat *A, int nd, const int *dofs, const double *Ae, mo_ctx *ctx)
{
#ifdef HAVE_PETSC
  return DMOD(A)->dmat_add(A->h, nd, dofs, Ae, ctx);
#else
  (void)A, (void)nd, (void)dofs, (void)Ae;
  return mo_error(ctx, MO_EUNSUPPORTED, "no PETSc");
#endif
}

int mo_dmat_assemble(mo_dmat *A, mo_ctx *ctx)
{
#ifdef HAVE_PETSC
  return DMOD(A)->dmat_assemble(A->h, ctx);
#else
  (void)A;
  return mo_error(ctx, MO_EUNSUPPORTED, "no PETSc");
#endif
}

int mo_dmat_mult(mo_dmat *A, const double *x, double *y, mo_ctx *ctx)
{
#ifdef HAVE_PETSC
  return DMOD(A)->dmat_mult(A->h, x, y, ctx);
#else
  (void)A, (void)x, (void)y;
  return mo_error(ctx, MO_EUNSUPPORTED, "no PETSc");
#endif
}

int mo_dmat_row(mo_dmat *A, int row, int cap, int *nz, int *cols, double *vals, mo_ctx *ctx)
{
#ifdef HAVE_PETSC
  return DMOD(A)->dmat_row(A->h, row, cap, nz, cols, vals, ctx);
#else
  (void)A, (void)row, (void)cap, (void)nz, (void)cols, (void)vals;
  return mo_error(ctx, MO_EUNSUPPORTED, "no PETSc");
#endif
}

void mo_dmat_counts(const mo_dmat *A, long *nnz, long *allocated, long *sent)
{
  *nnz = *allocated = *sent = 0;
#ifdef HAVE_PETSC
  if (A) DMOD(A)->dmat_counts(A->h, nnz, allocated, sent);
#else
  (void)A;
#endif
}

void mo_dmat_free(mo_dmat *A)
{
  if (!A) return;
#ifdef HAVE_PETSC
  DMOD(A)->dmat_free(A->h);
#endif
  mo_free(A);
}
