/* moreau/parallel.h: runs over MPI ranks (doc/parallel.md). Every rank builds the same scene and
   takes the same steps; what is distributed is the linear algebra (linear_solver.type = "petsc")
   and, for granular scenes, the contact sweep (grains partitioned in space). Without PETSc (the
   default build) these are the serial calls: rank 0 of 1. */
#ifndef MOREAU_PARALLEL_H
#define MOREAU_PARALLEL_H

#include <moreau/ctx.h>

#ifdef __cplusplus
extern "C" {
#endif

/* 1 when this build has PETSc and MPI (configure --with-petsc). */
int mo_parallel_available(void);
/* 1 when the process was started by an MPI launcher (mpirun, mpiexec): the environment of Open
   MPI, MPICH or PMIx says so. */
int mo_parallel_launched(void);
/* Start MPI and PETSc (once per process) and set ctx->rank, ctx->nranks. Called at the start of
   a program launched by mpirun, and on demand by the first PETSc solver of a serial run (a
   singleton MPI start costs about 0.5 s: a serial run that does not ask for PETSc never pays it).
   PETSc and MPI live in a module of their own, loaded here (doc/parallel.md §1). MO_EUNSUPPORTED
   in a build without PETSc, or when the module cannot be loaded. */
int mo_parallel_start(int *argc, char ***argv, mo_ctx *ctx);
/* 1 once mo_parallel_start has succeeded with this context. */
int mo_parallel_started(const mo_ctx *ctx);
/* Finalize PETSc and MPI if they were started (at the program's exit). */
void mo_parallel_finish(mo_ctx *ctx);

/* Collective operations over every rank (no-ops on one rank). Each returns MO_OK, or an error
   recorded in ctx if MPI fails. */
int mo_par_sum(double *x, long n, mo_ctx *ctx);   /* x <- the sum of x over the ranks */
int mo_par_max(double *x, long n, mo_ctx *ctx);   /* x <- the maximum over the ranks */
int mo_par_bcast(void *buf, long bytes, int root, mo_ctx *ctx);
/* Allgather of variable-sized double blocks: rank r contributes n[r] values from mine; all[] gets
   the blocks in rank order (sum n values). */
int mo_par_gatherv(const double *mine, const int *n, double *all, mo_ctx *ctx);
/* The worst status of the ranks: each rank passes its own; every rank gets the largest, and when
   it is another rank's, the message names that rank (so that a rank that failed alone, rank 0 on a
   full disk say, does not leave the others waiting in the next collective call). */
int mo_par_agree(int st, mo_ctx *ctx);

#ifdef __cplusplus
}
#endif
#endif
