/* broad.c: the broad phase: pairs of bounding balls within alert from a dense or hashed cell grid. */
#include "config.h"
#include "broad.h"

#include <limits.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* Cell coordinates are clamped to [0, QMAX]: a body absurdly far away (or a cell size absurdly
   small) shares a boundary cell with others, which costs distance tests, never a pair, and keeps
   q +- 1 far from integer overflow. */
#define QMAX 4503599627370496.0 /* 2^52 */

struct mo_broad {
  /* grid of the current call: origin lo, cell size h, dense extents nc (hashed: unused) */
  int dim, hashed, ncell;
  double lo[3], h;
  int64_t nc[3];
  /* cell of each body (-1: left out), bodies of cell k in body[start[k] .. start[k + 1]) */
  int *cell, *start, *body;
  /* hashed grid: coordinates of each cell (dim per cell), open-addressing table of cell
     indices (-1 empty) of size tmask + 1, a power of 2 */
  int64_t *key;
  int *slot;
  size_t tmask;
  /* candidates of the current body, and the pairs */
  int *cand, *pair;
  long npair;
  size_t cap_cell, cap_start, cap_body, cap_key, cap_slot, cap_cand, cap_pair;
};

int mo_broad_create(mo_broad **out, mo_ctx *ctx)
{
  *out = mo_calloc(ctx, 1, sizeof **out);
  return *out ? MO_OK : MO_ENOMEM;
}

void mo_broad_free(mo_broad *B)
{
  if (!B) return;
  mo_free(B->cell);
  mo_free(B->start);
  mo_free(B->body);
  mo_free(B->key);
  mo_free(B->slot);
  mo_free(B->cand);
  mo_free(B->pair);
  mo_free(B);
}

size_t mo_broad_bytes(const mo_broad *B)
{
  size_t ints;
  if (!B) return 0;
  ints = B->cap_cell + B->cap_start + B->cap_body + B->cap_slot + B->cap_cand + B->cap_pair;
  return sizeof *B + ints * sizeof(int) + B->cap_key * sizeof(int64_t);
}

/* p with room for need elements of size sz (*cap counts them), grown geometrically so that stable
   sizes allocate nothing. NULL with MO_ENOMEM recorded in ctx; the old block then stays with the
   caller. */
static void *reserve(void *p, size_t *cap, size_t need, size_t sz, mo_ctx *ctx)
{
  size_t c = *cap ? *cap : 16;
  if (need <= *cap) return p;
  while (c < need) c *= 2;
  p = mo_realloc(ctx, p, c * sz);
  if (p) *cap = c;
  return p;
}

/* Check the bodies taking part, count them in *m, and when there are 2 or more size the grid:
   origin, cell size, dense or hashed. */
static int broad_grid(mo_broad *B, int n, const double *c, const double *r, const unsigned char *mask,
                      double alert, int *m, mo_ctx *ctx)
{
  double hi[3] = {0, 0, 0}, rmax = 0, ext = 0, ncell = 1;
  int i, k, dim = B->dim;
  *m = 0;
  for (i = 0; i < n; i++) {
    if (mask && !mask[i]) continue;
    for (k = 0; k < dim; k++) {
      double x = c[dim * i + k];
      if (!isfinite(x))
        return mo_error(ctx, MO_EINPUT, "broad phase: body %d has a non-finite coordinate", i);
      if (!*m || x < B->lo[k]) B->lo[k] = x;
      if (!*m || x > hi[k]) hi[k] = x;
    }
    if (!(r[i] >= 0) || isinf(r[i]))
      return mo_error(ctx, MO_EINPUT, "broad phase: body %d has radius %g, not a finite number >= 0", i,
                      r[i]);
    if (r[i] > rmax) rmax = r[i];
    ++*m;
  }
  if (*m < 2) return MO_OK;
  for (k = 0; k < dim; k++) ext = fmax(ext, hi[k] - B->lo[k]);
  /* any h >= 2 r_max + alert puts every pair in neighbouring cells */
  B->h = 2 * rmax + alert;
  if (!(B->h > 0)) B->h = ext / *m; /* points and alert 0: any size will do, take one that spreads them */
  if (!(B->h > 0)) B->h = 1;
  for (k = 0; k < dim; k++) {
    double q = floor((hi[k] - B->lo[k]) / B->h) + 1;
    B->nc[k] = q <= QMAX ? (int64_t)q : 0;
    ncell *= q;
  }
  B->hashed = !(ncell <= 4.0 * *m + 64);
  B->ncell = B->hashed ? 0 : (int)ncell;
  return MO_OK;
}

/* Integer coordinates of the cell holding point x. */
static void cell_coords(const mo_broad *B, const double *x, int64_t *q)
{
  int k;
  for (k = 0; k < B->dim; k++) {
    double s = floor((x[k] - B->lo[k]) / B->h); /* >= 0: x is in the box; +inf past the double range */
    q[k] = s < QMAX ? (int64_t)s : (int64_t)QMAX;
  }
}

static size_t cell_hash(const int64_t *q, int dim)
{
  /* odd multipliers spread neighbouring coordinates over the table; the shift folds the high
     bits, where the products mix best, into the low ones the mask keeps */
  uint64_t h = (uint64_t)q[0] * UINT64_C(0x9E3779B97F4A7C15) + (uint64_t)q[1] * UINT64_C(0xC2B2AE3D27D4EB4F);
  if (dim == 3) h += (uint64_t)q[2] * UINT64_C(0x165667B19E3779F9);
  return (size_t)(h ^ (h >> 29) ^ (h >> 47));
}

/* Index of the cell with coordinates q in the dense grid, -1 outside it. */
static int dense_index(const mo_broad *B, const int64_t *q)
{
  int k;
  for (k = 0; k < B->dim; k++)
    if (q[k] < 0 || q[k] >= B->nc[k]) return -1;
  return (int)(q[0] + B->nc[0] * (q[1] + (B->dim == 3 ? B->nc[1] * q[2] : 0)));
}

/* Index of the cell with coordinates q, -1 when no body is in it. With insert (hashed grid),
   a missing cell is added. */
static int cell_find(mo_broad *B, const int64_t *q, int insert)
{
  size_t s;
  int dim = B->dim;
  if (!B->hashed) return dense_index(B, q);
  for (s = cell_hash(q, dim) & B->tmask;; s = (s + 1) & B->tmask) { /* linear probing, load <= 1/2 */
    int e = B->slot[s];
    if (e < 0) break;
    if (q[0] == B->key[dim * e] && q[1] == B->key[dim * e + 1] && (dim == 2 || q[2] == B->key[dim * e + 2]))
      return e;
  }
  if (!insert) return -1;
  memcpy(B->key + (size_t)dim * B->ncell, q, dim * sizeof *q);
  B->slot[s] = B->ncell;
  return B->ncell++;
}

/* Bin the m bodies taking part: cell[i], then the bodies of each cell in increasing order. */
static int broad_bin(mo_broad *B, int n, const double *c, const unsigned char *mask, int m, mo_ctx *ctx)
{
  int64_t q[3];
  size_t tsize = 16;
  void *p;
  int i, k;
  if (!(p = reserve(B->cell, &B->cap_cell, n, sizeof(int), ctx))) return MO_ENOMEM;
  B->cell = p;
  if (!(p = reserve(B->body, &B->cap_body, m, sizeof(int), ctx))) return MO_ENOMEM;
  B->body = p;
  if (B->hashed) {
    while (tsize < 2 * (size_t)m) tsize *= 2;
    if (!(p = reserve(B->slot, &B->cap_slot, tsize, sizeof(int), ctx))) return MO_ENOMEM;
    B->slot = p;
    if (!(p = reserve(B->key, &B->cap_key, (size_t)m * B->dim, sizeof(int64_t), ctx))) return MO_ENOMEM;
    B->key = p;
    B->tmask = tsize - 1;
    memset(B->slot, 0xff, tsize * sizeof(int)); /* all -1 */
  }
  for (i = 0; i < n; i++) {
    B->cell[i] = -1;
    if (mask && !mask[i]) continue;
    cell_coords(B, c + (size_t)B->dim * i, q);
    B->cell[i] = cell_find(B, q, 1);
  }
  /* counting sort of the bodies by cell: counts, offsets, then placement in increasing i */
  if (!(p = reserve(B->start, &B->cap_start, (size_t)B->ncell + 1, sizeof(int), ctx))) return MO_ENOMEM;
  B->start = p;
  memset(B->start, 0, ((size_t)B->ncell + 1) * sizeof(int));
  for (i = 0; i < n; i++)
    if (B->cell[i] >= 0) B->start[B->cell[i] + 1]++;
  for (k = 0; k < B->ncell; k++) B->start[k + 1] += B->start[k];
  for (i = 0; i < n; i++)
    if (B->cell[i] >= 0) B->body[B->start[B->cell[i]]++] = i;
  for (k = B->ncell; k > 0; k--) B->start[k] = B->start[k - 1]; /* placement moved each start to the next */
  B->start[0] = 0;
  return MO_OK;
}

static int cmp_int(const void *a, const void *b)
{
  int x = *(const int *)a, y = *(const int *)b;
  return (x > y) - (x < y);
}

/* Sort the k candidates: a handful usually (insertion), many when alert is large (qsort). */
static void sort_ints(int *a, int k)
{
  int i, j, x;
  if (k > 32) {
    qsort(a, (size_t)k, sizeof *a, cmp_int);
    return;
  }
  for (i = 1; i < k; i++) {
    x = a[i];
    for (j = i; j > 0 && a[j - 1] > x; j--) a[j] = a[j - 1];
    a[j] = x;
  }
}

/* Append to B->cand the bodies j > i of body[l0 .. l1) within alert of body i. Returns the new
   count, -1 on allocation failure. */
static int near_range(mo_broad *B, int i, int l0, int l1, const double *c, const double *r, double alert,
                      int nk, mo_ctx *ctx)
{
  const double *ci = c + (size_t)B->dim * i;
  int j, k, l;
  for (l = l0; l < l1; l++) {
    const double *cj;
    double d2 = 0;
    if ((j = B->body[l]) <= i) continue;
    cj = c + (size_t)B->dim * j;
    for (k = 0; k < B->dim; k++) d2 += (cj[k] - ci[k]) * (cj[k] - ci[k]);
    if (!(sqrt(d2) - r[i] - r[j] <= alert)) continue;
    if (nk == (int)B->cap_cand) {
      void *p = reserve(B->cand, &B->cap_cand, (size_t)nk + 1, sizeof(int), ctx);
      if (!p) return -1;
      B->cand = p;
    }
    B->cand[nk++] = j;
  }
  return nk;
}

/* The candidates j > i of body i within alert, from the 3^dim cells around its own, sorted, in
   B->cand; returns how many (-1 on allocation failure). The cells come by rows along x: in the
   dense grid the 3 cells of a row hold one contiguous range of body[]. */
static int broad_near(mo_broad *B, int i, const double *c, const double *r, double alert, mo_ctx *ctx)
{
  int64_t q[3], nq[3] = {0, 0, 0};
  int dim = B->dim, a, e0, e1, nk = 0;
  cell_coords(B, c + (size_t)dim * i, q);
  for (a = 0; a < (dim == 3 ? 9 : 3) && nk >= 0; a++) {
    nq[1] = q[1] + a % 3 - 1;
    if (dim == 3) nq[2] = q[2] + a / 3 - 1;
    if (!B->hashed) {
      nq[0] = q[0] > 0 ? q[0] - 1 : 0;
      if ((e0 = dense_index(B, nq)) < 0) continue; /* the row is outside the grid */
      nq[0] = q[0] + 1 < B->nc[0] ? q[0] + 1 : q[0];
      e1 = dense_index(B, nq);
      nk = near_range(B, i, B->start[e0], B->start[e1 + 1], c, r, alert, nk, ctx);
      continue;
    }
    for (nq[0] = q[0] - 1; nq[0] <= q[0] + 1 && nk >= 0; nq[0]++)
      if ((e0 = cell_find(B, nq, 0)) >= 0)
        nk = near_range(B, i, B->start[e0], B->start[e0 + 1], c, r, alert, nk, ctx);
  }
  if (nk > 0) sort_ints(B->cand, nk);
  return nk;
}

/* All pairs, i increasing, from the binned bodies. */
static int broad_collect(mo_broad *B, int n, const double *c, const double *r, double alert, mo_ctx *ctx)
{
  int i, k, nk;
  void *p;
  for (i = 0; i < n; i++) {
    if (B->cell[i] < 0) continue;
    if ((nk = broad_near(B, i, c, r, alert, ctx)) < 0) return MO_ENOMEM;
    if (!nk) continue;
    p = reserve(B->pair, &B->cap_pair, 2 * ((size_t)B->npair + nk), sizeof(int), ctx);
    if (!p) return MO_ENOMEM;
    B->pair = p;
    for (k = 0; k < nk; k++) {
      B->pair[2 * B->npair] = i;
      B->pair[2 * B->npair + 1] = B->cand[k];
      B->npair++;
    }
  }
  return MO_OK;
}

int mo_broad_pairs(mo_broad *B, int dim, int n, const double *c, const double *r, const unsigned char *mask,
                   double alert, const int **pairs, long *npairs, mo_ctx *ctx)
{
  int st, m;
  *pairs = NULL;
  *npairs = 0;
  if (dim != 2 && dim != 3) return mo_error(ctx, MO_EINPUT, "broad phase: dimension %d is not 2 or 3", dim);
  if (n < 0 || n > INT_MAX / 8) return mo_error(ctx, MO_EINPUT, "broad phase: %d bodies", n);
  if (!(alert >= 0)) return mo_error(ctx, MO_EINPUT, "broad phase: alert %g is not >= 0", alert);
  B->dim = dim;
  B->npair = 0;
  if ((st = broad_grid(B, n, c, r, mask, alert, &m, ctx))) return st;
  if (m >= 2) {
    if ((st = broad_bin(B, n, c, mask, m, ctx))) return st;
    if ((st = broad_collect(B, n, c, r, alert, ctx))) {
      B->npair = 0;
      return st;
    }
  }
  *pairs = B->pair;
  *npairs = B->npair;
  return MO_OK;
}
