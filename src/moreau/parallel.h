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
/* The same blocks to rank 0 only: all is read (and must hold sum n values) on rank 0 alone. */
int mo_par_gather0(const double *mine, const int *n, double *all, mo_ctx *ctx);
/* Point to point with the npeer ranks peer[k] (not collective: only the ranks named take part):
   send[off[k] .. off[k + 1]) goes to peer[k], as many values from it arrive in recv[off[k] ..
   off[k + 1]). Each peer must name this rank with the same count. No-op on one rank. */
int mo_par_exchange(int npeer, const int *peer, const int *off, const double *send, double *recv, mo_ctx *ctx);
/* One value to each rank and one from each (collective): send[r] goes to rank r, recv[r] comes from
   it. On one rank recv[0] = send[0]. */
int mo_par_alltoall(const double *send, double *recv, mo_ctx *ctx);
/* Point to point with the counts apart (only the ranks named take part): send[soff[k] ..
   soff[k + 1]) to speer[k] for k < nsend, recv[roff[k] .. roff[k + 1]) from rpeer[k] for k <
   nrecv; what a rank sends another is what that one expects from it. No-op on one rank. */
int mo_par_exchangev(int nsend, const int *speer, const int *soff, const double *send, int nrecv, const int *rpeer,
                     const int *roff, double *recv, mo_ctx *ctx);
/* The worst status of the ranks: each rank passes its own; every rank gets the largest, and when
   it is another rank's, the message names that rank (so that a rank that failed alone, rank 0 on a
   full disk say, does not leave the others waiting in the next collective call). */
int mo_par_agree(int st, mo_ctx *ctx);

/* A matrix distributed by rows over the ranks (PETSc's MPIAIJ), assembled from element blocks
   (doc/parallel.md §3). Dof k is PETSc's row perm[k] (perm NULL: k); this rank owns PETSc's rows
   rstart .. rend-1, preallocated with dnnz[i] entries in its diagonal block and onnz[i] outside
   it (row rstart + i). Every index in and out of these calls is a dof. Element blocks are added
   with mo_dmat_add (the rows of other ranks are sent to them), then mo_dmat_assemble. Collective
   but for mo_dmat_add, mo_dmat_row and mo_dmat_counts; MO_EUNSUPPORTED without PETSc or before
   mo_parallel_start. */
typedef struct mo_dmat mo_dmat;
int mo_dmat_create(int n, int rstart, int rend, const int *perm, const int *dnnz, const int *onnz, mo_dmat **A,
                   mo_ctx *ctx);
int mo_dmat_add(mo_dmat *A, int nd, const int *dofs, const double *Ae, mo_ctx *ctx);
int mo_dmat_assemble(mo_dmat *A, mo_ctx *ctx);
/* y = A x with x and y whole on every rank. */
int mo_dmat_mult(mo_dmat *A, const double *x, double *y, mo_ctx *ctx);
/* The row of an owned dof: its nonzeros' columns (dofs) and values (at most cap; *nz their count). */
int mo_dmat_row(mo_dmat *A, int row, int cap, int *nz, int *cols, double *vals, mo_ctx *ctx);
/* Entries stored on this rank, entries preallocated, and element entries this rank sent to other
   ranks' rows. */
void mo_dmat_counts(const mo_dmat *A, long *nnz, long *allocated, long *sent);
void mo_dmat_free(mo_dmat *A);

/* K and M of a scene's deformable bodies assembled over the ranks straight into distributed
   matrices (doc/parallel.md §3): each rank computes the elements of its block (element_block's
   split: nelem / nranks contiguous elements in the scene's order) and owns the rows of the dofs
   that only its elements reach, and about half of those it shares with other ranks' elements
   (PETSc's rows are the dofs reordered rank after rank), so that the element entries land
   mostly in its own rows.
   No rank holds K or M whole. */
typedef struct mo_dist_assembly {
  mo_dmat *K, *M;      /* M NULL when not asked for */
  int rstart, rend;    /* this rank's rows, in PETSc's order */
  int *row;            /* dof k is PETSc's row row[k] (whole on every rank: 4 bytes a dof) */
  long elements;       /* elements this rank computed */
  double local;        /* of the element entries of every rank, the share in the computing
                          rank's own rows (the rest went through the stash) */
  double seconds;      /* this rank's seconds: both passes and the assemblies */
} mo_dist_assembly;
struct mo_scene;
int mo_scene_assemble_distributed(const struct mo_scene *sc, int with_mass, mo_dist_assembly *out, mo_ctx *ctx);
void mo_dist_assembly_free(mo_dist_assembly *a);

#ifdef __cplusplus
}
#endif
#endif
