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
/* The same, keeping the zeros (blk NULL: a block of zeros): the pattern of the block whatever
   its values, so that ranks that computed different elements hold one pattern (scene.c). */
int mo_triplet_add_pattern(mo_triplet *T, const int *rows, int nr, const int *cols, int nc,
                           const double *blk, mo_ctx *ctx);
void mo_triplet_release(mo_triplet *T);
/* Convert once to CSC through CHOLMOD (cholmod_triplet_to_sparse: duplicates summed, sorted). */
int mo_triplet_to_csc(const mo_triplet *T, int symmetric, mo_csc **A, mo_ctx *ctx);

int mo_csc_alloc(int nrow, int ncol, int nnz, mo_csc **A, mo_ctx *ctx);
void mo_csc_free(mo_csc *A);
int mo_csc_nnz(const mo_csc *A);
int mo_csc_copy(const mo_csc *A, mo_csc **B, mo_ctx *ctx);
/* Remove the entries equal to zero, in place (the pattern shrinks; the arrays keep their size). */
void mo_csc_drop_zeros(mo_csc *A);
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
  /* over MPI ranks: the matrix each rank factors is its part, the matrix solved the sum of the
     ranks' parts (K and M in parts: mo_scene's kpart); the types of one process ignore it */
  int parts;
  /* MUMPS (ksp preonly, pc cholesky or lu): its factor on disk (ICNTL(22)) in a private folder
     made under ooc_dir (NULL: TMPDIR, else /tmp) and removed with the solver (doc/theory.md (T182)) */
  int out_of_core;
  const char *ooc_dir;
} mo_linsolver_settings;
/* The split solves of a factor P A P^T = L L^T whose trailing rows are the ones ordered last
   (mo_linsolver_set_last), with L = [L11 0; L21 L22] (doc/theory.md (T150)-(T153)):
   FORWARD         out = L^-1 P in            (n values in, n out: the factor's order)
   BACKWARD        out = P^T L^-T in          (n in the factor's order, n out)
   TRAIL_FORWARD   out = L22^-1 in            (the nlast trailing values; out may alias in)
   TRAIL_BACKWARD  out = L22^-T in            (likewise)
   so that A^-1 b = BACKWARD(FORWARD(b)), the last rows of x = A^-1 b are TRAIL_BACKWARD of the
   last nlast values of FORWARD(b), and the forward solve of a right-hand side that vanishes
   outside the last rows is TRAIL_FORWARD of its last rows (zero above them). */
typedef enum {
  MO_SPLIT_FORWARD = 0, MO_SPLIT_BACKWARD, MO_SPLIT_TRAIL_FORWARD, MO_SPLIT_TRAIL_BACKWARD
} mo_split_op;

/* What a factorization measured of itself (NaN or 0 where the type does not say). */
typedef struct mo_linsolver_info {
  double nnz_L;          /* entries of the factor (without the zeros of supernodal amalgamation) */
  double flops;          /* of the numeric factorization */
  double bytes_factor;   /* the factor's values and indices */
  double bytes_work;     /* the largest workspace of the numeric factorization */
  double bytes_reserve;  /* what the caller said it needs beside (mo_linsolver_set_last) */
  double bytes_before;   /* resident size when the numeric factorization started */
  double bytes_limit;    /* the memory this run may take (mo_memory_limit) */
  double bytes_trailing; /* when the contact dofs last did not fit: what they would have needed (else 0) */
  double t_analyze, t_numeric; /* seconds: symbolic analyses (all), the last numeric factorization */
  double two_solves;     /* mean seconds of a forward and a backward solve on one right-hand side
                            (the split ones, or whole solves; NaN before any) */
  const char *ordering;  /* "amd", "metis", ...: of the rows not ordered last */
  int nlast, trailing;   /* rows ordered last, and whether the factor holds them as its trailing block */
  int supernodal, long_indices;
  /* MUMPS: its own estimates of the memory of the whole factorization in core (INFOG(17)) and
     out of core (INFOG(27)), and whether the factor is on disk (doc/theory.md (T181)) */
  double bytes_in_core, bytes_out_of_core;
  int out_of_core;
} mo_linsolver_info;

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
  /* Optional (NULL where the type has none). Order the nlast rows and columns last[] last, in
     that order, from the next factorization on; reserve: bytes the caller will need beside the
     factor (the Delassus operator; the type adds the Schur inverse when it orders them last),
     counted in the memory check before the numeric factorization. When the ordered factor does
     not fit in memory the type may fall back to its own order (mo_linsolver_nlast then 0). */
  int (*set_last)(void *state, int nlast, const int *last, double reserve, mo_ctx *ctx);
  int (*split)(void *state, mo_split_op op, const double *in, double *out, mo_ctx *ctx);
  /* G = (A^-1)_CC over the rows ordered last (nlast x nlast, column-major, both triangles). */
  int (*schur_inverse)(void *state, double *G, mo_ctx *ctx);
  void (*info)(const void *state, mo_linsolver_info *I);
  /* Optional (NULL: every process holds every row, as solve). A solver whose rows are split over
     MPI ranks: solve A X = B keeping this rank's rows *r0 .. *r1 - 1 alone, B and X those rows of
     the right-hand sides and solutions (column-major, leading dimension *r1 - *r0). nrhs = 0
     only reports the rows (doc/parallel.md §2, (T210)). */
  int (*solve_rows)(void *state, int nrhs, const double *B, double *X, int *r0, int *r1, mo_ctx *ctx);
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
/* This process's rows of the solutions, rows *r0 .. *r1 - 1 of B and X (leading dimension
   *r1 - *r0): every row (0 .. n - 1, as solve_multi) but for a solver split over MPI ranks
   (PETSc's on more than one), whose solutions stay by rows (T210). nrhs = 0: the rows alone. */
int mo_linsolver_solve_rows(mo_linsolver *S, int nrhs, const double *B, double *X, int *r0, int *r1,
                            mo_ctx *ctx);
/* Statistics: numeric factorizations, symbolic analyses, solves (right-hand sides). */
void mo_linsolver_stats(const mo_linsolver *S, long *nfactor, long *nsymbolic, long *nsolve);
const char *mo_linsolver_name(const mo_linsolver *S);
void mo_linsolver_free(mo_linsolver *S);
/* Rows and columns ordered last from the next factorization on (a new symbolic analysis when
   they change; nlast = 0 clears), and bytes the caller will need beside the factor (counted in
   the memory check). MO_EUNSUPPORTED from a type that cannot order (nlast > 0). */
int mo_linsolver_set_last(mo_linsolver *S, int nlast, const int *last, double reserve, mo_ctx *ctx);
/* The order CHOLMOD's factor takes with nlast rows last: its own choice (AMD or METIS) on the
   other rows, then last[] as given; perm[k] is the row of A at position k (n values), *ordering
   the name of the choice. For a package given the order (MUMPS's PERM_IN). */
int mo_order_last(const mo_csc *A, int nlast, const int *last, int *perm, const char **ordering, mo_ctx *ctx);
/* A type's copy of the rows to order last, for its set_last: *keep (*nkeep entries) becomes a
   copy of last[] when the two differ, and *fresh is set (a new analysis is due); left as it is
   when they are the same. */
int mo_order_last_set(int nlast, const int *last, int *nkeep, int **keep, int *fresh, mo_ctx *ctx);
/* The rows the factor holds as its trailing block (0: none, the split solves do not apply). */
int mo_linsolver_nlast(const mo_linsolver *S);
int mo_linsolver_split(mo_linsolver *S, mo_split_op op, const double *in, double *out, mo_ctx *ctx);
/* Whether the type has the split solves: MUMPS's Schur path has the trailing block's inverse
   (mo_linsolver_schur_inverse) but not them, its steps take whole solves (doc/theory.md (T180)). */
int mo_linsolver_has_split(const mo_linsolver *S);
int mo_linsolver_schur_inverse(mo_linsolver *S, double *G, mo_ctx *ctx);
void mo_linsolver_info_get(const mo_linsolver *S, mo_linsolver_info *I);

/* BLAS threads (OpenBLAS; a no-op with a BLAS that cannot set them, doc/theory.md (T155)): the
   program runs mo_blas_threads_base() (1, or OPENBLAS_NUM_THREADS) and takes
   mo_blas_threads_max() (MOREAU_BLAS_THREADS, else the base) around large dense work only. */
void mo_blas_threads(int n);
int mo_blas_threads_max(void);
int mo_blas_threads_base(void);

#ifdef __cplusplus
}
#endif
#endif
