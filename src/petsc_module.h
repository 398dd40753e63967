/* petsc_module.h: the contract between libmoreau and its PETSc module (moreau_petsc.so, built by
   configure --with-petsc; doc/parallel.md §1). libmoreau never links PETSc or MPI: a serial run
   does not load their hundred shared libraries (0.2 s at every start); parallel.c loads the
   module when a run asks for it (mpirun, linear_solver.type = "petsc"). The module calls
   libmoreau only through the host table it is given, so that it can be loaded by the library
   and by programs linked with moreau's objects alike. */
#ifndef MOREAU_PETSC_MODULE_H
#define MOREAU_PETSC_MODULE_H

#include <stdarg.h>
#include <stddef.h>

#include <moreau/ctx.h>
#include <moreau/sparse.h>

/* Raised whenever a member changes meaning or position. */
#define MO_PETSC_ABI 10
#define MO_PETSC_SYMBOL "mo_petsc_module_v1"
#define MO_PETSC_MODULE_NAME "moreau_petsc.so"

typedef struct mo_petsc_host {
  int (*verror)(mo_ctx *ctx, int code, const char *fmt, va_list ap);
  void *(*malloc_)(mo_ctx *ctx, size_t n);
  void *(*calloc_)(mo_ctx *ctx, size_t count, size_t size);
  void (*free_)(void *p);
  int (*csc_transpose)(const mo_csc *A, mo_csc **AT, mo_ctx *ctx);
  void (*csc_free)(mo_csc *A);
  double (*clock)(void);
  /* the memory check before MUMPS's numeric factorization (doc/theory.md (T181)) */
  double (*memory_rss)(void);
  double (*memory_limit)(void);
  void (*log)(const mo_ctx *ctx, int level, const char *fmt, ...);
  /* CHOLMOD's order with the contact dofs last, given to MUMPS (doc/theory.md (T183)) */
  int (*order_last)(const mo_csc *A, int nlast, const int *last, int *perm, const char **ordering, mo_ctx *ctx);
  /* the copy of the rows to order last that set_last keeps (the same as CHOLMOD's type) */
  int (*order_last_set)(int nlast, const int *last, int *nkeep, int **keep, int *fresh, mo_ctx *ctx);
} mo_petsc_host;

typedef struct mo_petsc_module {
  int abi;                   /* MO_PETSC_ABI */
  const char *petsc_version; /* PETSc's version string */
  /* Start MPI and PETSc once per process; rank and size of the world. */
  int (*start)(const mo_petsc_host *host, int *rank, int *nranks, mo_ctx *ctx);
  int (*started)(void);
  void (*finish)(void);
  /* Collective calls over every rank (doc/parallel.md): op 0 sum, 1 maximum. */
  int (*allreduce)(double *x, long n, int op, mo_ctx *ctx);
  int (*bcast)(void *buf, long bytes, int root, mo_ctx *ctx);
  int (*allgatherv)(const double *mine, const int *n, double *all, mo_ctx *ctx);
  /* (status, -rank) pairs reduced by MAXLOC, then the failing rank's message to every rank. */
  int (*agree)(int st, mo_ctx *ctx);
  /* Point to point with each of npeer ranks peer[k]: send[off[k] .. off[k + 1]) to it, as many
     values from it into recv[off[k] .. off[k + 1]). Every peer must list this rank with the same
     count. */
  int (*exchange)(int npeer, const int *peer, const int *off, const double *send, double *recv, mo_ctx *ctx);
  const mo_linsolver_type *linsolver;
  /* A distributed n x n matrix assembled from element blocks (doc/parallel.md §3): dof k is
     PETSc's row and column perm[k] (NULL: k), this rank owns the rows rstart .. rend-1, their
     entries in and out of its diagonal block dnnz[i] and onnz[i] (row rstart + i); every index
     passed in or out is a dof (perm applied inside). Element blocks are added (ADD_VALUES: the
     rows of other ranks through PETSc's stash), then dmat_assemble. Every call but dmat_add,
     dmat_row and dmat_counts is collective. */
  int (*dmat_create)(int n, int rstart, int rend, const int *perm, const int *dnnz, const int *onnz, void **A,
                     mo_ctx *ctx);
  int (*dmat_add)(void *A, int nd, const int *dofs, const double *Ae, mo_ctx *ctx);
  int (*dmat_assemble)(void *A, mo_ctx *ctx);
  /* y = A x, x and y whole on every rank (x's owned rows in, y gathered to every rank). */
  int (*dmat_mult)(void *A, const double *x, double *y, mo_ctx *ctx);
  /* The row of dof `row` (owned): its nonzeros' columns (dofs) and values (at most cap), their
     count in *nz. */
  int (*dmat_row)(void *A, int row, int cap, int *nz, int *cols, double *vals, mo_ctx *ctx);
  /* Entries stored on this rank (its rows'), entries preallocated, and the element entries it
     sent to other ranks' rows (through the stash). */
  void (*dmat_counts)(void *A, long *nnz, long *allocated, long *sent);
  void (*dmat_free)(void *A);
  /* allgatherv's blocks to rank 0 only (all read on rank 0 alone). */
  int (*gatherv0)(const double *mine, const int *n, double *all, mo_ctx *ctx);
  /* One value to each rank: send[r] to rank r, recv[r] from it (MPI_Alltoall). */
  int (*alltoall)(const double *send, double *recv, mo_ctx *ctx);
  /* Point to point, the counts apart: send[soff[k] .. soff[k + 1]) to speer[k] (nsend of them),
     recv[roff[k] .. roff[k + 1]) from rpeer[k] (nrecv); each sender's count is its receiver's. */
  int (*exchangev)(int nsend, const int *speer, const int *soff, const double *send, int nrecv, const int *rpeer,
                   const int *roff, double *recv, mo_ctx *ctx);
} mo_petsc_module;

#endif
