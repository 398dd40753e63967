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
  double rcap, rmax;    /* the radius the cells are sized for, and the largest */
  int nbin;             /* balls binned */
  /* scratch: the balls' positions and radii in body[]'s order while the pairs are collected (dim + 1
     values per ball, the radius -1 for a large ball), then the sort's bucket starts and cursors */
  double *scr;
  size_t cap_scr;
  int64_t nc[3];
  /* cell of each body (-1: left out), bodies of cell k in body[start[k] .. start[k + 1]) */
  int *cell, *start, *body;
  /* hashed grid: coordinates of each cell (dim per cell), open-addressing table of cell
     indices (-1 empty) of size tmask + 1, a power of 2 */
  int64_t *key;
  int *slot;
  size_t tmask;
  /* scratch of the sort by lower index (bucket starts and cursors), and the pairs */
  int *pair;
  long npair;
  size_t cap_cell, cap_start, cap_body, cap_key, cap_slot, cap_pair;
};

int mo_broad_create(mo_broad **out, mo_ctx *ctx)
{
  *out = mo_calloc(ctx, 1, sizeof **out);
  return *out ? MO_OK : MO_ENOMEM;
}

void mo_broad_trim(mo_broad *B)
{
  if (!B) return;
  mo_free(B->cell);
  mo_free(B->start);
  mo_free(B->body);
  mo_free(B->key);
  mo_free(B->slot);
  mo_free(B->pair);
  mo_free(B->scr);
  B->cell = B->start = B->body = B->slot = B->pair = NULL;
  B->key = NULL;
  B->scr = NULL;
  B->cap_cell = B->cap_start = B->cap_body = B->cap_key = B->cap_slot = B->cap_pair = B->cap_scr = 0;
  B->npair = 0;
}

void mo_broad_free(mo_broad *B)
{
  if (!B) return;
  mo_broad_trim(B);
  mo_free(B);
}

size_t mo_broad_bytes(const mo_broad *B)
{
  size_t ints;
  if (!B) return 0;
  ints = B->cap_cell + B->cap_start + B->cap_body + B->cap_slot + B->cap_pair;
  return sizeof *B + ints * sizeof(int) + B->cap_key * sizeof(int64_t) + B->cap_scr * sizeof(double);
}

/* p with room for need elements of size sz (*cap counts them), grown geometrically so that stable
   sizes allocate nothing: doubled, or by a quarter (quarter != 0: the pair list, which grows a
   little at a time while a pile settles, as the contact set's arrays do). The first room is the
   first need itself (at least 16): the arrays over the bodies keep their size from build to build,
   and the positions' scratch of a pack of 10^3 grains held 4 096 doubles for 3 000 (8.8 bytes a
   grain, T268). NULL with MO_ENOMEM recorded in ctx; the old block then stays with the caller. */
static void *reserve_by(void *p, size_t *cap, size_t need, size_t sz, int quarter, mo_ctx *ctx)
{
  size_t c = *cap ? *cap : need > 16 ? need : 16;
  if (need <= *cap) return p;
  while (c < need) c = quarter ? c + c / 4 + 2 : 2 * c;
  p = mo_realloc(ctx, p, c * sz);
  if (p) *cap = c;
  return p;
}

static void *reserve(void *p, size_t *cap, size_t need, size_t sz, mo_ctx *ctx)
{
  return reserve_by(p, cap, need, sz, 0, ctx);
}

/* Check the bodies taking part, count them in *m, and when there are 2 or more size the grid:
   origin, cell size, dense or hashed. */
static int broad_grid(mo_broad *B, int n, const double *c, const double *r, const unsigned char *mask,
                      double alert, int *m, mo_ctx *ctx)
{
  double hi[3] = {0, 0, 0}, rmax = 0, rsum = 0, ext = 0, ncell = 1;
  int i, k, dim = B->dim, nlarge = 0;
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
    rsum += r[i];
    ++*m;
  }
  if (*m < 2) return MO_OK;
  for (k = 0; k < dim; k++) ext = fmax(ext, hi[k] - B->lo[k]);
  /* the cells are sized for the normal balls, of radius up to r_cap = 1.5 times the mean radius (a
     few fast grains grown by their speed, or a few big bodies, do not make every cell large); the
     others, the large ones, search their own reach, unless they are more than a tenth of the balls */
  B->rmax = rmax;
  B->rcap = fmin(rmax, 1.5 * rsum / *m);
  for (i = 0; i < n; i++) nlarge += (!mask || mask[i]) && r[i] > B->rcap;
  if (nlarge > *m / 10) B->rcap = rmax; /* no exception: every ball is normal */
  /* any h >= 2 r_cap + alert puts every pair of normal balls in neighbouring cells (a margin over
     the round-off of the cell coordinates of two bodies exactly that far apart) */
  B->h = (2 * B->rcap + alert) * (1 + 1e-9);
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
static inline void cell_coords(const mo_broad *B, const double *x, int64_t *q)
{
  int k;
  for (k = 0; k < B->dim; k++) {
    /* >= 0 (x is in the box, lo its least coordinate), so the conversion's truncation is floor;
       +inf past the double range */
    double s = (x[k] - B->lo[k]) / B->h;
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
static int broad_bin(mo_broad *B, int n, const double *c, const double *r, const unsigned char *mask, int m,
                     mo_ctx *ctx)
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
    /* a ball is in the box: its dense index directly */
    B->cell[i] = B->hashed ? cell_find(B, q, 1)
                           : (int)(q[0] + B->nc[0] * (q[1] + (B->dim == 3 ? B->nc[1] * q[2] : 0)));
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
  B->nbin = m;
  /* the positions and radii in body[]'s order (the tests of a cell read them in a row); the scratch
     also holds the sort's 2 n + 1 ints afterwards */
  {
    size_t need = (size_t)(B->dim + 1) * m, need_sort = ((2 * (size_t)n + 1) * sizeof(int) + sizeof(double) - 1) / sizeof(double);
    double *px, *pr;
    if (!(p = reserve(B->scr, &B->cap_scr, need > need_sort ? need : need_sort, sizeof(double), ctx))) return MO_ENOMEM;
    B->scr = p;
    px = B->scr;
    pr = B->scr + (size_t)B->dim * m;
    for (i = 0; i < m; i++) {
      int b = B->body[i];
      for (k = 0; k < B->dim; k++) px[(size_t)B->dim * i + k] = c[(size_t)B->dim * b + k];
      pr[i] = r[b] > B->rcap ? -1 : r[b];
    }
  }
  return MO_OK;
}

/* 1 when balls i < j are within alert: |c_i - c_j| - r_i - r_j <= alert, decided on the squares
   away from the boundary (no square root for almost every pair) and exactly near it. */
static inline int near_pair(const mo_broad *B, const double *c, const double *r, int i, int j, double alert)
{
  const int dim = B->dim;
  const double *ci = c + (size_t)dim * i, *cj = c + (size_t)dim * j;
  double d2 = 0, s = r[i] + r[j] + alert, s2 = s * s;
  int k;
  for (k = 0; k < dim; k++) d2 += (cj[k] - ci[k]) * (cj[k] - ci[k]);
  if (d2 < s2 * (1 - 1e-12)) return 1;
  if (d2 > s2 * (1 + 1e-12)) return 0;
  return sqrt(d2) - r[i] - r[j] <= alert;
}

/* Room for one more pair. */
static int pair_room(mo_broad *B, mo_ctx *ctx)
{
  void *p;
  if (2 * ((size_t)B->npair + 1) <= B->cap_pair) return MO_OK;
  if (!(p = reserve_by(B->pair, &B->cap_pair, 2 * ((size_t)B->npair + 1), sizeof(int), 1, ctx))) return MO_ENOMEM;
  B->pair = p;
  return MO_OK;
}

/* The pairs of bodies l0 .. l1-1 of body[] (the bodies of one cell) with the bodies m0 .. m1-1 (those of
   a neighbouring cell, or the same cell with m0 = l + 1 for each l), each as (lower, higher) index;
   from the positions and radii gathered in body[]'s order (px, pr; pr < 0: a large ball). */
static inline __attribute__((always_inline)) int cells_pairs_d(mo_broad *B, int l0, int l1, int m0, int m1, int same,
                                                                const double *c, const double *r, double alert,
                                                                const int dim, mo_ctx *ctx)
{
  const double *px = B->scr, *pr = B->scr + (size_t)dim * B->nbin;
  int l, m, k;
  for (l = l0; l < l1; l++) {
    const double *xl = px + (size_t)dim * l, rl = pr[l] + alert;
    if (pr[l] < 0) continue; /* a large ball's pairs are its own search's */
    for (m = same ? l + 1 : m0; m < m1; m++) {
      const double *xm = px + (size_t)dim * m;
      double d2 = 0, sr = rl + pr[m], s2 = sr * sr;
      int i, j, lo, hi;
      for (k = 0; k < dim; k++) d2 += (xm[k] - xl[k]) * (xm[k] - xl[k]);
      if (pr[m] < 0 || d2 > s2 * (1 + 1e-12)) continue;
      i = B->body[l];
      j = B->body[m];
      lo = i < j ? i : j;
      hi = i < j ? j : i;
      /* near the boundary: the exact test */
      if (!(d2 < s2 * (1 - 1e-12)) && !near_pair(B, c, r, lo, hi, alert)) continue;
      if (pair_room(B, ctx)) return MO_ENOMEM;
      B->pair[2 * B->npair] = lo;
      B->pair[2 * B->npair + 1] = hi;
      B->npair++;
    }
  }
  return MO_OK;
}

static int cells_pairs(mo_broad *B, int l0, int l1, int m0, int m1, int same, const double *c, const double *r,
                       double alert, mo_ctx *ctx)
{
  return B->dim == 2 ? cells_pairs_d(B, l0, l1, m0, m1, same, c, r, alert, 2, ctx)
                     : cells_pairs_d(B, l0, l1, m0, m1, same, c, r, alert, 3, ctx);
}

/* The bodies of the cell with coordinates q: body[*l0 .. *l1); 0 when there is none. */
static int cell_range(mo_broad *B, const int64_t *q, int *l0, int *l1)
{
  int e = cell_find(B, q, 0);
  if (e < 0) return 0;
  *l0 = B->start[e];
  *l1 = B->start[e + 1];
  return *l1 > *l0;
}

/* Every pair once: each occupied cell with itself and with the half of its neighbours ahead of it
   (in 2D (+1, 0) and the row above; in 3D the 13 of the 26 lexicographically after it), then the
   large balls' own searches, then the pairs sorted by (lower, higher): an in-place counting sort by
   the lower index, each bucket's few higher indices by insertion. */
static int broad_collect(mo_broad *B, int n, const double *c, const double *r, double alert, mo_ctx *ctx)
{
  const int dim = B->dim, nh = dim == 3 ? 13 : 4;
  int e, k, st;
  int64_t q[3], nq[3];
  int *cnt, *cur;
  long t;
  B->npair = 0;
  for (e = 0; e < B->ncell; e++) {
    int l0 = B->start[e], l1 = B->start[e + 1];
    if (l1 <= l0) continue;
    /* the cell's coordinates (dense cells by index arithmetic, hashed ones from their first body) */
    if (B->hashed) cell_coords(B, c + (size_t)dim * B->body[l0], q);
    else {
      q[0] = e % B->nc[0];
      q[1] = e / B->nc[0] % B->nc[1];
      q[2] = dim == 3 ? e / (B->nc[0] * B->nc[1]) : 0;
    }
    if ((st = cells_pairs(B, l0, l1, 0, l1, 1, c, r, alert, ctx))) return st;
    for (k = 0; k < nh; k++) {
      int e1, m0, m1;
      /* the offsets (dz, dy, dx) of {-1, 0, 1}^dim lexicographically after 0: codes 14 .. 26 in 3D,
         5 .. 8 of the 2D codes dy * 3 + dx + 4 */
      int code = dim == 3 ? k + 14 : k + 5;
      nq[0] = q[0] + code % 3 - 1;
      nq[1] = q[1] + code / 3 % 3 - 1;
      nq[2] = dim == 3 ? q[2] + code / 9 - 1 : 0;
      if (!B->hashed) {
        if (nq[0] < 0 || nq[0] >= B->nc[0] || nq[1] < 0 || nq[1] >= B->nc[1] ||
            (dim == 3 && (nq[2] < 0 || nq[2] >= B->nc[2])))
          continue;
        e1 = (int)(nq[0] + B->nc[0] * (nq[1] + (dim == 3 ? B->nc[1] * nq[2] : 0)));
      } else if ((e1 = cell_find(B, nq, 0)) < 0)
        continue;
      if ((m1 = B->start[e1 + 1]) > (m0 = B->start[e1]) && (st = cells_pairs(B, l0, l1, m0, m1, 0, c, r, alert, ctx)))
        return st;
    }
  }
  /* the large balls (radius above rcap): each searches the cells within its reach of any ball,
     r + r_max + alert, for all its pairs with normal balls and with the large ones of higher index */
  for (e = 0; e < n; e++) {
    int64_t lo[3], hi[3];
    double reach;
    if (B->cell[e] < 0 || !(r[e] > B->rcap)) continue;
    reach = r[e] + B->rmax + alert;
    for (k = 0; k < dim; k++) {
      double a = floor((c[(size_t)dim * e + k] - reach - B->lo[k]) / B->h), b = floor((c[(size_t)dim * e + k] + reach - B->lo[k]) / B->h);
      lo[k] = a < 0 ? 0 : a < QMAX ? (int64_t)a : (int64_t)QMAX;
      hi[k] = b < 0 ? 0 : b < QMAX ? (int64_t)b : (int64_t)QMAX;
      if (!B->hashed && hi[k] >= B->nc[k]) hi[k] = B->nc[k] - 1;
    }
    {
      double box = 1;
      for (k = 0; k < dim; k++) box *= (double)(hi[k] - lo[k] + 1);
      if (box > n) { /* more cells than balls: the balls themselves */
        int j;
        for (j = 0; j < n; j++) {
          int a = e < j ? e : j, b = e < j ? j : e;
          if (j == e || B->cell[j] < 0 || (r[j] > B->rcap && j < e) || !near_pair(B, c, r, a, b, alert)) continue;
          if (pair_room(B, ctx)) return MO_ENOMEM;
          B->pair[2 * B->npair] = a;
          B->pair[2 * B->npair + 1] = b;
          B->npair++;
        }
        continue;
      }
    }
    for (nq[2] = dim == 3 ? lo[2] : 0; nq[2] <= (dim == 3 ? hi[2] : 0); nq[2]++)
      for (nq[1] = lo[1]; nq[1] <= hi[1]; nq[1]++)
        for (nq[0] = lo[0]; nq[0] <= hi[0]; nq[0]++) {
          int m0, m1, m;
          if (!cell_range(B, nq, &m0, &m1)) continue;
          for (m = m0; m < m1; m++) {
            int j = B->body[m], a = e < j ? e : j, b = e < j ? j : e;
            if (j == e || (r[j] > B->rcap && j < e) || !near_pair(B, c, r, a, b, alert)) continue;
            if (pair_room(B, ctx)) return MO_ENOMEM;
            B->pair[2 * B->npair] = a;
            B->pair[2 * B->npair + 1] = b;
            B->npair++;
          }
        }
  }
  if (!B->npair) return MO_OK;
  /* sorted by (lower, higher): an in-place counting sort by the lower index (its bucket starts
     and write cursors, 2 n + 1 ints), then each bucket's few higher indices by insertion */
  cnt = (int *)B->scr; /* the positions are not needed any more */
  cur = cnt + n + 1;
  memset(cnt, 0, ((size_t)n + 1) * sizeof *cnt);
  for (t = 0; t < B->npair; t++) cnt[B->pair[2 * t] + 1]++;
  for (k = 0; k < n; k++) cnt[k + 1] += cnt[k];
  memcpy(cur, cnt, (size_t)n * sizeof *cur);
  for (k = 0; k < n; k++)
    while (cur[k] < cnt[k + 1]) {
      int *pk = B->pair + 2 * (size_t)cur[k], lo = pk[0];
      if (lo == k) cur[k]++;
      else { /* to its bucket's cursor, what was there comes here */
        int *pd = B->pair + 2 * (size_t)cur[lo]++, a = pd[0], b = pd[1];
        pd[0] = pk[0];
        pd[1] = pk[1];
        pk[0] = a;
        pk[1] = b;
      }
    }
  for (k = 0; k < n; k++) {
    long v;
    for (v = cnt[k] + 1; v < cnt[k + 1]; v++) {
      int j = B->pair[2 * v + 1];
      long w = v;
      for (; w > cnt[k] && B->pair[2 * w - 1] > j; w--) B->pair[2 * w + 1] = B->pair[2 * w - 1];
      B->pair[2 * w + 1] = j;
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
    if ((st = broad_bin(B, n, c, r, mask, m, ctx))) return st;
    if ((st = broad_collect(B, n, c, r, alert, ctx))) {
      B->npair = 0;
      return st;
    }
  }
  *pairs = B->pair;
  *npairs = B->npair;
  return MO_OK;
}

long mo_broad_keep(mo_broad *B, int (*keep)(void *arg, int i, int j), void *arg)
{
  long q, m = 0;
  for (q = 0; q < B->npair; q++)
    if (keep(arg, B->pair[2 * q], B->pair[2 * q + 1])) {
      B->pair[2 * m] = B->pair[2 * q];
      B->pair[2 * m + 1] = B->pair[2 * q + 1];
      m++;
    }
  return B->npair = m;
}
