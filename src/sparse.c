/* sparse.c: triplet assembly (converted once through CHOLMOD) and CSC kernels. */
#include "config.h"
#include <moreau/sparse.h>
#include "ss.h"

#include <math.h>
#include <string.h>

int mo_ss_cholmod_error(const cholmod_common *c, const char *what, mo_ctx *ctx)
{
  const char *m;
  switch (c->status) {
  case CHOLMOD_OK: return MO_OK;
  case CHOLMOD_OUT_OF_MEMORY: return mo_error(ctx, MO_ENOMEM, "%s: CHOLMOD ran out of memory", what);
  case CHOLMOD_TOO_LARGE: return mo_error(ctx, MO_ELIMIT, "%s: CHOLMOD: problem too large", what);
  case CHOLMOD_NOT_POSDEF: m = "matrix not positive definite"; break;
  case CHOLMOD_DSMALL: m = "diagonal entry tiny"; break;
  case CHOLMOD_INVALID: m = "invalid input"; break;
  case CHOLMOD_NOT_INSTALLED: m = "method not installed"; break;
  default: m = "unknown CHOLMOD status"; break;
  }
  return mo_error(ctx, c->status == CHOLMOD_NOT_POSDEF ? MO_ESINGULAR : MO_EINTERNAL,
                  "%s: CHOLMOD: %s (status %d)", what, m, c->status);
}

int mo_ss_umfpack_error(int status, const char *what, mo_ctx *ctx)
{
  switch (status) {
  case UMFPACK_OK: return MO_OK;
  case UMFPACK_WARNING_singular_matrix:
    return mo_error(ctx, MO_ESINGULAR, "%s: UMFPACK: matrix is singular", what);
  case UMFPACK_ERROR_out_of_memory:
    return mo_error(ctx, MO_ENOMEM, "%s: UMFPACK ran out of memory", what);
  default: return mo_error(ctx, MO_EINTERNAL, "%s: UMFPACK error %d", what, status);
  }
}

int mo_triplet_init(mo_triplet *T, int nrow, int ncol, size_t cap, mo_ctx *ctx)
{
  memset(T, 0, sizeof *T);
  T->nrow = nrow;
  T->ncol = ncol;
  if (cap < 16) cap = 16;
  T->i = mo_malloc(ctx, cap * sizeof(int));
  T->j = mo_malloc(ctx, cap * sizeof(int));
  T->x = mo_malloc(ctx, cap * sizeof(double));
  if (!T->i || !T->j || !T->x) {
    mo_triplet_release(T);
    return MO_ENOMEM;
  }
  T->cap = cap;
  return MO_OK;
}

void mo_triplet_release(mo_triplet *T)
{
  mo_free(T->i);
  mo_free(T->j);
  mo_free(T->x);
  memset(T, 0, sizeof *T);
}

static int grow(mo_triplet *T, size_t need, mo_ctx *ctx)
{
  size_t cap = T->cap;
  int *i, *j;
  double *x;
  if (need <= cap) return MO_OK;
  while (cap < need) cap *= 2;
  i = mo_realloc(ctx, T->i, cap * sizeof(int));
  if (!i) return MO_ENOMEM;
  T->i = i;
  j = mo_realloc(ctx, T->j, cap * sizeof(int));
  if (!j) return MO_ENOMEM;
  T->j = j;
  x = mo_realloc(ctx, T->x, cap * sizeof(double));
  if (!x) return MO_ENOMEM;
  T->x = x;
  T->cap = cap;
  return MO_OK;
}

int mo_triplet_add(mo_triplet *T, int i, int j, double v, mo_ctx *ctx)
{
  if (i < 0 || j < 0) return MO_OK;
  if (grow(T, T->n + 1, ctx)) return MO_ENOMEM;
  T->i[T->n] = i;
  T->j[T->n] = j;
  T->x[T->n] = v;
  T->n++;
  return MO_OK;
}

/* One element block's entries, the rows and columns < 0 left out; zeros left out too unless
   keep_zeros (a pattern: a NULL blk adds zeros). */
static int add_entries(mo_triplet *T, const int *rows, int nr, const int *cols, int nc,
                       const double *blk, int keep_zeros, mo_ctx *ctx)
{
  int a, b;
  if (grow(T, T->n + (size_t)nr * (size_t)nc, ctx)) return MO_ENOMEM;
  for (a = 0; a < nr; a++) {
    if (rows[a] < 0) continue;
    for (b = 0; b < nc; b++) {
      double v = blk ? blk[a * nc + b] : 0;
      if (cols[b] < 0 || (v == 0 && !keep_zeros)) continue;
      T->i[T->n] = rows[a];
      T->j[T->n] = cols[b];
      T->x[T->n] = v;
      T->n++;
    }
  }
  return MO_OK;
}

int mo_triplet_add_block(mo_triplet *T, const int *rows, int nr, const int *cols, int nc,
                         const double *blk, mo_ctx *ctx)
{
  return add_entries(T, rows, nr, cols, nc, blk, 0, ctx);
}

int mo_triplet_add_pattern(mo_triplet *T, const int *rows, int nr, const int *cols, int nc,
                           const double *blk, mo_ctx *ctx)
{
  return add_entries(T, rows, nr, cols, nc, blk, 1, ctx);
}

void mo_csc_drop_zeros(mo_csc *A)
{
  int j, p, q = 0, start;
  for (j = 0; j < A->ncol; j++) {
    start = A->p[j];
    A->p[j] = q;
    for (p = start; p < A->p[j + 1]; p++)
      if (A->x[p] != 0) {
        A->i[q] = A->i[p];
        A->x[q++] = A->x[p];
      }
  }
  A->p[A->ncol] = q;
}

int mo_csc_alloc(int nrow, int ncol, int nnz, mo_csc **out, mo_ctx *ctx)
{
  mo_csc *A = mo_calloc(ctx, 1, sizeof *A);
  *out = NULL;
  if (!A) return MO_ENOMEM;
  A->nrow = nrow;
  A->ncol = ncol;
  A->p = mo_calloc(ctx, (size_t)ncol + 1, sizeof(int));
  A->i = mo_malloc(ctx, (size_t)(nnz > 0 ? nnz : 1) * sizeof(int));
  A->x = mo_malloc(ctx, (size_t)(nnz > 0 ? nnz : 1) * sizeof(double));
  if (!A->p || !A->i || !A->x) {
    mo_csc_free(A);
    return MO_ENOMEM;
  }
  *out = A;
  return MO_OK;
}

void mo_csc_free(mo_csc *A)
{
  if (!A) return;
  mo_free(A->p);
  mo_free(A->i);
  mo_free(A->x);
  mo_free(A);
}

int mo_csc_nnz(const mo_csc *A)
{
  return A->p[A->ncol];
}

int mo_triplet_to_csc(const mo_triplet *T, int symmetric, mo_csc **out, mo_ctx *ctx)
{
  cholmod_common c;
  cholmod_triplet ct;
  cholmod_sparse *S;
  mo_csc *A;
  int st, nnz, j;
  *out = NULL;
  cholmod_start(&c);
  memset(&ct, 0, sizeof ct);
  ct.nrow = (size_t)T->nrow;
  ct.ncol = (size_t)T->ncol;
  ct.nzmax = T->cap;
  ct.nnz = T->n;
  ct.i = T->i;
  ct.j = T->j;
  ct.x = T->x;
  ct.stype = 0; /* both triangles stored */
  ct.itype = CHOLMOD_INT;
  ct.xtype = CHOLMOD_REAL;
  ct.dtype = CHOLMOD_DOUBLE;
  S = cholmod_triplet_to_sparse(&ct, T->n, &c);
  if (!S) {
    st = mo_ss_cholmod_error(&c, "assembly (triplet to CSC)", ctx);
    cholmod_finish(&c);
    return st ? st : mo_error(ctx, MO_EINTERNAL, "assembly: CHOLMOD returned no matrix");
  }
  nnz = (int)((int *)S->p)[S->ncol];
  if ((st = mo_csc_alloc(T->nrow, T->ncol, nnz, &A, ctx))) {
    cholmod_free_sparse(&S, &c);
    cholmod_finish(&c);
    return st;
  }
  memcpy(A->p, S->p, ((size_t)T->ncol + 1) * sizeof(int));
  memcpy(A->i, S->i, (size_t)nnz * sizeof(int));
  memcpy(A->x, S->x, (size_t)nnz * sizeof(double));
  (void)j;
  A->symmetric = symmetric;
  cholmod_free_sparse(&S, &c);
  cholmod_finish(&c);
  *out = A;
  return MO_OK;
}

int mo_csc_copy(const mo_csc *A, mo_csc **out, mo_ctx *ctx)
{
  int nnz = mo_csc_nnz(A), st;
  mo_csc *B;
  if ((st = mo_csc_alloc(A->nrow, A->ncol, nnz, &B, ctx))) return st;
  memcpy(B->p, A->p, ((size_t)A->ncol + 1) * sizeof(int));
  memcpy(B->i, A->i, (size_t)nnz * sizeof(int));
  memcpy(B->x, A->x, (size_t)nnz * sizeof(double));
  B->symmetric = A->symmetric;
  *out = B;
  return MO_OK;
}

void mo_csc_gaxpy(const mo_csc *A, double alpha, const double *x, double beta, double *y)
{
  const int *Ap = A->p, *Ai = A->i;
  const double *Ax = A->x;
  int j, p, n = A->ncol;
  if (beta == 0) memset(y, 0, (size_t)A->nrow * sizeof *y);
  else if (beta != 1)
    for (j = 0; j < A->nrow; j++) y[j] *= beta;
  for (j = 0; j < n; j++) {
    double xj = alpha * x[j];
    if (xj == 0) continue;
    for (p = Ap[j]; p < Ap[j + 1]; p++) y[Ai[p]] += Ax[p] * xj;
  }
}

void mo_csc_gatxpy(const mo_csc *A, double alpha, const double *x, double beta, double *y)
{
  const int *Ap = A->p, *Ai = A->i;
  const double *Ax = A->x;
  int j, p;
  for (j = 0; j < A->ncol; j++) {
    double s = 0;
    for (p = Ap[j]; p < Ap[j + 1]; p++) s += Ax[p] * x[Ai[p]];
    y[j] = alpha * s + (beta == 0 ? 0 : beta * y[j]);
  }
}

int mo_csc_add(const mo_csc *A, const mo_csc *B, double alpha, double beta, mo_csc **out,
               mo_ctx *ctx)
{
  int n = A->ncol, m = A->nrow, j, pa, pb, k = 0, st;
  mo_csc *C;
  if (A->nrow != B->nrow || A->ncol != B->ncol)
    return mo_error(ctx, MO_EINTERNAL, "mo_csc_add: shapes differ");
  if ((st = mo_csc_alloc(m, n, mo_csc_nnz(A) + mo_csc_nnz(B), &C, ctx))) return st;
  for (j = 0; j < n; j++) { /* merge two sorted columns */
    C->p[j] = k;
    pa = A->p[j];
    pb = B->p[j];
    while (pa < A->p[j + 1] || pb < B->p[j + 1]) {
      int ia = pa < A->p[j + 1] ? A->i[pa] : m, ib = pb < B->p[j + 1] ? B->i[pb] : m;
      if (ia < ib) { C->i[k] = ia; C->x[k++] = alpha * A->x[pa++]; }
      else if (ib < ia) { C->i[k] = ib; C->x[k++] = beta * B->x[pb++]; }
      else { C->i[k] = ia; C->x[k++] = alpha * A->x[pa++] + beta * B->x[pb++]; }
    }
  }
  C->p[n] = k;
  C->symmetric = A->symmetric && B->symmetric;
  *out = C;
  return MO_OK;
}

int mo_csc_extract(const mo_csc *A, const int *rowmap, int nrow, const int *colmap, int ncol,
                   mo_csc **out, mo_ctx *ctx)
{
  int j, p, k = 0, st, nnz = 0;
  mo_csc *B;
  for (j = 0; j < A->ncol; j++) {
    if (colmap[j] < 0) continue;
    for (p = A->p[j]; p < A->p[j + 1]; p++)
      if (rowmap[A->i[p]] >= 0) nnz++;
  }
  if ((st = mo_csc_alloc(nrow, ncol, nnz, &B, ctx))) return st;
  /* count per new column, then fill (new column order may differ from old) */
  for (j = 0; j < A->ncol; j++) {
    int c = colmap[j];
    if (c < 0) continue;
    for (p = A->p[j]; p < A->p[j + 1]; p++)
      if (rowmap[A->i[p]] >= 0) B->p[c + 1]++;
  }
  for (j = 0; j < ncol; j++) B->p[j + 1] += B->p[j];
  {
    int *next = mo_malloc(ctx, (size_t)(ncol > 0 ? ncol : 1) * sizeof(int));
    if (!next) { mo_csc_free(B); return MO_ENOMEM; }
    memcpy(next, B->p, (size_t)ncol * sizeof(int));
    for (j = 0; j < A->ncol; j++) {
      int c = colmap[j];
      if (c < 0) continue;
      for (p = A->p[j]; p < A->p[j + 1]; p++) {
        int r = rowmap[A->i[p]];
        if (r < 0) continue;
        B->i[next[c]] = r;
        B->x[next[c]++] = A->x[p];
        k++;
      }
    }
    mo_free(next);
  }
  /* rows of a column may be out of order if rowmap is not monotone: sort each column */
  for (j = 0; j < ncol; j++) {
    int a, b;
    for (a = B->p[j] + 1; a < B->p[j + 1]; a++)
      for (b = a; b > B->p[j] && B->i[b - 1] > B->i[b]; b--) {
        int ti = B->i[b]; double tx = B->x[b];
        B->i[b] = B->i[b - 1]; B->x[b] = B->x[b - 1];
        B->i[b - 1] = ti; B->x[b - 1] = tx;
      }
  }
  B->symmetric = A->symmetric && rowmap == colmap;
  *out = B;
  return MO_OK;
}

int mo_csc_transpose(const mo_csc *A, mo_csc **out, mo_ctx *ctx)
{
  int nnz = mo_csc_nnz(A), j, p, st;
  int *next;
  mo_csc *T;
  if ((st = mo_csc_alloc(A->ncol, A->nrow, nnz, &T, ctx))) return st;
  for (p = 0; p < nnz; p++) T->p[A->i[p] + 1]++;
  for (j = 0; j < A->nrow; j++) T->p[j + 1] += T->p[j];
  next = mo_malloc(ctx, (size_t)(A->nrow > 0 ? A->nrow : 1) * sizeof(int));
  if (!next) { mo_csc_free(T); return MO_ENOMEM; }
  memcpy(next, T->p, (size_t)A->nrow * sizeof(int));
  for (j = 0; j < A->ncol; j++)
    for (p = A->p[j]; p < A->p[j + 1]; p++) {
      int q = next[A->i[p]]++;
      T->i[q] = j;
      T->x[q] = A->x[p];
    }
  mo_free(next);
  T->symmetric = A->symmetric;
  *out = T;
  return MO_OK;
}

double mo_csc_get(const mo_csc *A, int i, int j)
{
  int p;
  for (p = A->p[j]; p < A->p[j + 1]; p++)
    if (A->i[p] == i) return A->x[p];
  return 0;
}

double mo_csc_asymmetry(const mo_csc *A)
{
  double amax = 0, dmax = 0;
  int j, p;
  for (j = 0; j < A->ncol; j++)
    for (p = A->p[j]; p < A->p[j + 1]; p++) {
      double d = fabs(A->x[p] - mo_csc_get(A, j, A->i[p]));
      if (fabs(A->x[p]) > amax) amax = fabs(A->x[p]);
      if (d > dmax) dmax = d;
    }
  return amax > 0 ? dmax / amax : 0;
}

int mo_csc_to_dense(const mo_csc *A, double **out, mo_ctx *ctx)
{
  double *D = mo_calloc(ctx, (size_t)A->nrow * (size_t)A->ncol, sizeof(double));
  int j, p;
  *out = NULL;
  if (!D) return MO_ENOMEM;
  for (j = 0; j < A->ncol; j++)
    for (p = A->p[j]; p < A->p[j + 1]; p++) D[(size_t)j * (size_t)A->nrow + (size_t)A->i[p]] += A->x[p];
  *out = D;
  return MO_OK;
}
