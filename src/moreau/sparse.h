/* moreau/sparse.h: compressed-column matrices, triplet assembly, and the linear-solver layer. */
#ifndef MOREAU_SPARSE_H
#define MOREAU_SPARSE_H

#include <moreau/ctx.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Compressed sparse column matrix: sorted row indices, no duplicates, no explicit zeros kept
   beyond what assembly produced. Column j holds i[p[j] .. p[j+1]-1], x[same]. */
typedef struct mo_csc {
  int nrow, ncol;
  int *p, *i;
  double *x;
  int symmetric; /* 1 when known symmetric (both triangles stored) */
} mo_csc;

/* Triplet accumulator (duplicates summed on conversion). */
typedef struct mo_triplet {
  int nrow, ncol;
  size_t n, cap;
  int *i, *j;
  double *x;
} mo_triplet;

int mo_triplet_init(mo_triplet *T, int nrow, int ncol, size_t cap_hint, mo_ctx *ctx);
int mo_triplet_add(mo_triplet *T, int i, int j, double v, mo_ctx *ctx);
/* Add a dense block (row-major nr x nc); entries whose row or column index is negative are
   skipped (eliminated dofs). */
int mo_triplet_add_block(mo_triplet *T, const int *rows, int nr, const int *cols, int nc,
                         const double *blk, mo_ctx *ctx);
void mo_triplet_release(mo_triplet *T);
/* Convert once to CSC through CHOLMOD (cholmod_triplet_to_sparse: duplicates summed, sorted). */
int mo_triplet_to_csc(const mo_triplet *T, int symmetric, mo_csc **A, mo_ctx *ctx);

int mo_csc_alloc(int nrow, int ncol, int nnz, mo_csc **A, mo_ctx *ctx);
void mo_csc_free(mo_csc *A);
int mo_csc_nnz(const mo_csc *A);
int mo_csc_copy(const mo_csc *A, mo_csc **B, mo_ctx *ctx);
/* y = alpha A x + beta y (beta = 0 ignores y's contents). */
void mo_csc_gaxpy(const mo_csc *A, double alpha, const double *x, double beta, double *y);
/* y = alpha A^T x + beta y. */
void mo_csc_gatxpy(const mo_csc *A, double alpha, const double *x, double beta, double *y);
/* C = alpha A + beta B (same shape). */
int mo_csc_add(const mo_csc *A, const mo_csc *B, double alpha, double beta, mo_csc **C,
               mo_ctx *ctx);
/* B = A(rows, cols): rowmap[i] is the new row of old row i or -1, likewise colmap. */
int mo_csc_extract(const mo_csc *A, const int *rowmap, int nrow, const int *colmap, int ncol,
                   mo_csc **B, mo_ctx *ctx);
int mo_csc_transpose(const mo_csc *A, mo_csc **AT, mo_ctx *ctx);
/* Largest |a_ij - a_ji| relative to max |a_ij|. */
double mo_csc_asymmetry(const mo_csc *A);
/* Entry (i, j) or 0. */
double mo_csc_get(const mo_csc *A, int i, int j);
/* Dense copy (column-major nrow x ncol) for small matrices and tests. */
int mo_csc_to_dense(const mo_csc *A, double **D, mo_ctx *ctx);

/* --- Linear solvers -----------------------------------------------------------------------
   A linear solver is a type object (GSL style) behind one interface, so that a distributed
   implementation (PETSc) is a new type, not a rewrite. The factorization is computed by
   mo_linsolver_factor; a second call with a matrix of the same pattern reuses the symbolic
   analysis. */
typedef struct mo_linsolver mo_linsolver;

/* What a configurable solver (PETSc's) is told: the Krylov method and preconditioner by PETSc's
   names ("preonly" and "cholesky" or "lu" for a direct factorization, "cg" and "gamg" ...), the
   factorization package ("mumps"), the relative tolerance of iterative methods, and PETSc
   options passed through ("-pc_gamg_threshold 0.05 ..."). spd: the matrices are symmetric
   positive definite (the stepper's What), so a Cholesky factorization applies. */
typedef struct mo_linsolver_settings {
  const char *ksp, *pc, *package, *options;
  double rtol;
  int spd;
} mo_linsolver_settings;

typedef struct mo_linsolver_type {
  const char *name;   /* "cholmod", "umfpack" */
  int spd_only;       /* 1: the matrix must be symmetric positive definite */
  size_t state_size;
  int (*factor)(void *state, const mo_csc *A, int same_pattern, mo_ctx *ctx);
  /* Solve A X = B for nrhs right-hand sides stored column-major (leading dimension n). X may
     alias B. */
  int (*solve)(void *state, int nrhs, const double *B, double *X, mo_ctx *ctx);
  void (*free)(void *state);
  /* Optional: take settings before the first factorization (NULL: the type has none). */
  int (*configure)(void *state, const mo_linsolver_settings *set, mo_ctx *ctx);
} mo_linsolver_type;

extern const mo_linsolver_type mo_linsolver_cholmod;
extern const mo_linsolver_type mo_linsolver_umfpack;
/* PETSc's KSP over every MPI rank (MUMPS by default): the matrix is distributed by rows, every
   rank passes the same replicated right-hand sides and receives the whole solution
   (doc/parallel.md). Loads and starts the PETSc module on first use; NULL with the reason in ctx
   in builds without PETSc. */
const mo_linsolver_type *mo_linsolver_petsc(mo_ctx *ctx);
/* Pass settings to a solver of a configurable type (a no-op for the others). */
int mo_linsolver_configure(mo_linsolver *S, const mo_linsolver_settings *set, mo_ctx *ctx);

int mo_linsolver_create(const mo_linsolver_type *T, mo_linsolver **out, mo_ctx *ctx);
/* Factor A (symbolic analysis on the first call or when the pattern changed). */
int mo_linsolver_factor(mo_linsolver *S, const mo_csc *A, mo_ctx *ctx);
int mo_linsolver_solve(mo_linsolver *S, const double *b, double *x, mo_ctx *ctx);
int mo_linsolver_solve_multi(mo_linsolver *S, int nrhs, const double *B, double *X,
                             mo_ctx *ctx);
int mo_linsolver_n(const mo_linsolver *S);
/* Statistics: numeric factorizations, symbolic analyses, solves (right-hand sides). */
void mo_linsolver_stats(const mo_linsolver *S, long *nfactor, long *nsymbolic, long *nsolve);
const char *mo_linsolver_name(const mo_linsolver *S);
void mo_linsolver_free(mo_linsolver *S);

#ifdef __cplusplus
}
#endif
#endif
