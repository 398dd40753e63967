/* delassus.c: the Delassus operator W = c H^T What^-1 H by d x d blocks, computed with the
   shared factorization by chunks of right-hand sides (doc/theory.md §4.4). */
#include "config.h"
#include <moreau/contact.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Columns What^-1 H are kept when they hold at most this many doubles (128 MB). */
#define MO_KEEP_COLUMNS_MAX 16000000.0
/* Right-hand sides per solve when building W. */
#define MO_CHUNK 64

struct mo_delassus {
  int m, d, nb, nfree;
  long hversion, fversion;
  double c;
  int built;
  long version;     /* counts the builds: back ends key their caches on (D, version) */
  int *rowp;        /* nb + 1 */
  int *colb;        /* block columns */
  double *val;      /* d*d per block, row-major */
  long nblocks;
  double *C;        /* nfree x m column-major: What^-1 H, or NULL */
  double *work;     /* nfree */
};

int mo_delassus_create(mo_delassus **out, mo_ctx *ctx)
{
  *out = mo_calloc(ctx, 1, sizeof **out);
  if (!*out) return MO_ENOMEM;
  (*out)->hversion = (*out)->fversion = -1;
  return MO_OK;
}

static void clear(mo_delassus *D)
{
  mo_free(D->rowp);
  mo_free(D->colb);
  mo_free(D->val);
  mo_free(D->C);
  mo_free(D->work);
  D->rowp = D->colb = NULL;
  D->val = D->C = D->work = NULL;
  D->built = 0;
}

void mo_delassus_free(mo_delassus *D)
{
  if (!D) return;
  clear(D);
  mo_free(D);
}

int mo_delassus_m(const mo_delassus *D) { return D->m; }
int mo_delassus_dim(const mo_delassus *D) { return D->d; }
long mo_delassus_nblocks(const mo_delassus *D) { return D->nblocks; }
int mo_delassus_has_columns(const mo_delassus *D) { return D->C != NULL; }

int mo_delassus_update(mo_delassus *D, const mo_csc *H, long hversion, mo_linsolver *ls,
                       long fversion, double c, int dim, int *rebuilt, mo_ctx *ctx)
{
  int m = H->ncol, n = H->nrow, d = dim, nb = m / dim, st = MO_OK, j0, k, p, a, b;
  double *B = NULL, *X = NULL, t0;
  int *cnt = NULL;
  /* per block row: growable lists of (beta, block) */
  int **rcol = NULL;
  double **rval = NULL;
  int *rcap = NULL;
  if (rebuilt) *rebuilt = 0;
  if (D->built && D->hversion == hversion && D->fversion == fversion && D->c == c) return MO_OK;
  t0 = mo_clock();
  clear(D);
  D->m = m;
  D->d = d;
  D->nb = nb;
  D->nfree = n;
  D->c = c;
  B = mo_calloc(ctx, (size_t)n * MO_CHUNK + 1, sizeof(double));
  X = mo_malloc(ctx, ((size_t)n * MO_CHUNK + 1) * sizeof(double));
  cnt = mo_calloc(ctx, (size_t)nb + 1, sizeof(int));
  rcol = mo_calloc(ctx, (size_t)nb + 1, sizeof(int *));
  rval = mo_calloc(ctx, (size_t)nb + 1, sizeof(double *));
  rcap = mo_calloc(ctx, (size_t)nb + 1, sizeof(int));
  D->work = mo_malloc(ctx, ((size_t)n + 1) * sizeof(double));
  if (!B || !X || !cnt || !rcol || !rval || !rcap || !D->work) { st = MO_ENOMEM; goto done; }
  if ((double)n * (double)m <= MO_KEEP_COLUMNS_MAX) {
    D->C = mo_malloc(ctx, ((size_t)n * (size_t)m + 1) * sizeof(double));
    if (!D->C) { st = MO_ENOMEM; goto done; }
  } else
    mo_note_skip(ctx, "storing What^-1 H (%d x %d would exceed %.0f MB): one solve per correction",
                 n, m, MO_KEEP_COLUMNS_MAX * 8 / 1e6);
  /* chunks of whole candidates so that each block column is computed at once */
  for (j0 = 0; j0 < m; j0 += (MO_CHUNK / d) * d) {
    int ncols = (MO_CHUNK / d) * d, bc0 = j0 / d, nbc;
    if (j0 + ncols > m) ncols = m - j0;
    nbc = ncols / d;
    memset(B, 0, (size_t)n * (size_t)ncols * sizeof(double));
    for (k = 0; k < ncols; k++)
      for (p = H->p[j0 + k]; p < H->p[j0 + k + 1]; p++) B[(size_t)k * n + (size_t)H->i[p]] = H->x[p];
    if ((st = mo_linsolver_solve_multi(ls, ncols, B, X, ctx))) goto done;
    if (D->C) memcpy(D->C + (size_t)j0 * n, X, (size_t)n * (size_t)ncols * sizeof(double));
    /* W(:, chunk) = H^T X: row r of W is column r of H dotted with X's columns */
    for (a = 0; a < nb; a++)
      for (b = 0; b < nbc; b++) {
        double blk[9];
        int nz = 0, ii, jj;
        for (ii = 0; ii < d; ii++)
          for (jj = 0; jj < d; jj++) {
            int r = a * d + ii, col = b * d + jj;
            double s = 0;
            for (p = H->p[r]; p < H->p[r + 1]; p++) s += H->x[p] * X[(size_t)col * n + (size_t)H->i[p]];
            blk[ii * d + jj] = c * s;
            nz |= s != 0;
          }
        if (!nz) continue;
        if (cnt[a] == rcap[a]) {
          int cap = rcap[a] ? 2 * rcap[a] : 8;
          int *ic = mo_realloc(ctx, rcol[a], (size_t)cap * sizeof(int));
          double *vc;
          if (!ic) { st = MO_ENOMEM; goto done; }
          rcol[a] = ic;
          vc = mo_realloc(ctx, rval[a], (size_t)cap * (size_t)(d * d) * sizeof(double));
          if (!vc) { st = MO_ENOMEM; goto done; }
          rval[a] = vc;
          rcap[a] = cap;
        }
        rcol[a][cnt[a]] = bc0 + b;
        memcpy(rval[a] + (size_t)cnt[a] * (size_t)(d * d), blk, (size_t)(d * d) * sizeof(double));
        cnt[a]++;
      }
  }
  /* compress the rows (block columns already increasing: chunks go left to right) */
  D->rowp = mo_malloc(ctx, ((size_t)nb + 1) * sizeof(int));
  if (!D->rowp) { st = MO_ENOMEM; goto done; }
  D->rowp[0] = 0;
  for (a = 0; a < nb; a++) D->rowp[a + 1] = D->rowp[a] + cnt[a];
  D->nblocks = D->rowp[nb];
  D->colb = mo_malloc(ctx, ((size_t)D->nblocks + 1) * sizeof(int));
  D->val = mo_malloc(ctx, ((size_t)D->nblocks * (size_t)(d * d) + 1) * sizeof(double));
  if (!D->colb || !D->val) { st = MO_ENOMEM; goto done; }
  for (a = 0; a < nb; a++) {
    memcpy(D->colb + D->rowp[a], rcol[a], (size_t)cnt[a] * sizeof(int));
    memcpy(D->val + (size_t)D->rowp[a] * (size_t)(d * d), rval[a], (size_t)cnt[a] * (size_t)(d * d) * sizeof(double));
  }
  D->hversion = hversion;
  D->fversion = fversion;
  D->built = 1;
  D->version++;
  if (rebuilt) *rebuilt = 1;
done:
  for (a = 0; a < nb; a++) { /* either list may be the allocation that failed */
    if (rcol) mo_free(rcol[a]);
    if (rval) mo_free(rval[a]);
  }
  mo_free(rcol);
  mo_free(rval);
  mo_free(rcap);
  mo_free(cnt);
  mo_free(B);
  mo_free(X);
  if (st) clear(D);
  mo_phase_add(ctx, MO_PH_DELASSUS, t0);
  return st;
}

const double *mo_delassus_block(const mo_delassus *D, int a, int b)
{
  int p;
  for (p = D->rowp[a]; p < D->rowp[a + 1]; p++)
    if (D->colb[p] == b) return D->val + (size_t)p * (size_t)(D->d * D->d);
  return NULL;
}

int mo_delassus_row(const mo_delassus *D, int a, const int **beta, const double **blocks)
{
  *beta = D->colb + D->rowp[a];
  *blocks = D->val + (size_t)D->rowp[a] * (size_t)(D->d * D->d);
  return D->rowp[a + 1] - D->rowp[a];
}

void mo_delassus_mult(const mo_delassus *D, const double *x, double beta, double *y)
{
  int d = D->d, a, p, i, j;
  for (a = 0; a < D->nb; a++) {
    double acc[3] = {0, 0, 0};
    for (p = D->rowp[a]; p < D->rowp[a + 1]; p++) {
      const double *blk = D->val + (size_t)p * (size_t)(d * d), *xb = x + D->colb[p] * d;
      for (i = 0; i < d; i++)
        for (j = 0; j < d; j++) acc[i] += blk[i * d + j] * xb[j];
    }
    for (i = 0; i < d; i++) y[a * d + i] = acc[i] + (beta == 0 ? 0 : beta * y[a * d + i]);
  }
}

int mo_delassus_dense(const mo_delassus *D, double **out, mo_ctx *ctx)
{
  int d = D->d, m = D->m, a, p, i, j;
  double *W = mo_calloc(ctx, (size_t)m * (size_t)m + 1, sizeof(double));
  *out = NULL;
  if (!W) return MO_ENOMEM;
  for (a = 0; a < D->nb; a++)
    for (p = D->rowp[a]; p < D->rowp[a + 1]; p++)
      for (i = 0; i < d; i++)
        for (j = 0; j < d; j++)
          W[(size_t)(a * d + i) * (size_t)m + (size_t)(D->colb[p] * d + j)] = D->val[(size_t)p * (size_t)(d * d) + (size_t)(i * d + j)];
  *out = W;
  return MO_OK;
}

int mo_delassus_apply_Cinv(mo_delassus *D, const mo_csc *H, mo_linsolver *ls, const double *r,
                           double *dx, mo_ctx *ctx)
{
  int n = H->nrow, m = H->ncol, j, i, p;
  if (D->C) {
    memset(dx, 0, (size_t)n * sizeof(double));
    for (j = 0; j < m; j++) {
      const double *col = D->C + (size_t)j * (size_t)n;
      double rj = r[j];
      if (rj == 0) continue;
      for (i = 0; i < n; i++) dx[i] += rj * col[i];
    }
    return MO_OK;
  }
  memset(D->work, 0, (size_t)n * sizeof(double));
  for (j = 0; j < m; j++)
    if (r[j] != 0)
      for (p = H->p[j]; p < H->p[j + 1]; p++) D->work[H->i[p]] += H->x[p] * r[j];
  return mo_linsolver_solve(ls, D->work, dx, ctx);
}

static int cmp_int(const void *a, const void *b)
{
  int x = *(const int *)a, y = *(const int *)b;
  return (x > y) - (x < y);
}

int mo_delassus_set_matrix(mo_delassus *D, const mo_csc *W, int dim, mo_ctx *ctx)
{
  int m = W->nrow, d = dim, nb, a, i, p, k, st = MO_OK, *mark = NULL, *list = NULL;
  mo_csc *T = NULL;
  if (W->ncol != m || d < 1 || d > 3 || m % d)
    return mo_error(ctx, MO_EINPUT, "a Delassus operator is square with a size that is a multiple of its "
                    "local dimension (got %d x %d, dimension %d)", W->nrow, W->ncol, dim);
  clear(D);
  nb = m / d;
  /* rows of W are the columns of W^T */
  if ((st = mo_csc_transpose(W, &T, ctx))) return st;
  mark = mo_malloc(ctx, ((size_t)nb + 1) * sizeof *mark);
  list = mo_malloc(ctx, ((size_t)nb + 1) * sizeof *list);
  D->rowp = mo_malloc(ctx, ((size_t)nb + 1) * sizeof *D->rowp);
  if (!mark || !list || !D->rowp) { st = MO_ENOMEM; goto done; }
  for (a = 0; a < nb; a++) mark[a] = -1;
  /* count the block columns of each block row */
  D->rowp[0] = 0;
  for (a = 0; a < nb; a++) {
    int n = 0;
    for (i = a * d; i < a * d + d; i++)
      for (p = T->p[i]; p < T->p[i + 1]; p++) {
        int b = T->i[p] / d;
        if (T->x[p] != 0 && mark[b] != a) { mark[b] = a; n++; }
      }
    D->rowp[a + 1] = D->rowp[a] + n;
  }
  D->nblocks = D->rowp[nb];
  D->colb = mo_malloc(ctx, ((size_t)D->nblocks + 1) * sizeof *D->colb);
  D->val = mo_calloc(ctx, (size_t)D->nblocks * (size_t)(d * d) + 1, sizeof *D->val);
  if (!D->colb || !D->val) { st = MO_ENOMEM; goto done; }
  for (a = 0; a < nb; a++) mark[a] = -1;
  for (a = 0; a < nb; a++) {
    int n = 0, r0 = D->rowp[a];
    for (i = a * d; i < a * d + d; i++)
      for (p = T->p[i]; p < T->p[i + 1]; p++) {
        int b = T->i[p] / d;
        if (T->x[p] != 0 && mark[b] != a) { mark[b] = a; list[n++] = b; }
      }
    qsort(list, (size_t)n, sizeof *list, cmp_int);
    for (k = 0; k < n; k++) {
      D->colb[r0 + k] = list[k];
      mark[list[k]] = -2 - (r0 + k);           /* position of block column list[k] in row a */
    }
    for (i = a * d; i < a * d + d; i++)
      for (p = T->p[i]; p < T->p[i + 1]; p++) {
        int j = T->i[p], b = j / d;
        if (T->x[p] != 0) D->val[(size_t)(-2 - mark[b]) * (size_t)(d * d) + (size_t)((i - a * d) * d + j % d)] = T->x[p];
      }
    for (k = 0; k < n; k++) mark[list[k]] = a;
  }
  D->m = m;
  D->d = d;
  D->nb = nb;
  D->nfree = 0;
  D->c = 1;
  D->hversion = D->fversion = -1;
  D->built = 1;
  D->version++;
done:
  if (st) clear(D);
  mo_csc_free(T);
  mo_free(mark);
  mo_free(list);
  return st;
}

long mo_delassus_version(const mo_delassus *D)
{
  return D->version;
}
