/* The remap written by the detection (doc/theory.md §12.15, (T220)-(T222)): as the detection
   overwrites the contact set's keys with the new set's, each new candidate's place in the old
   set, found by merging the two sets in the order the detection writes them. */
#include <stdint.h>
#include <string.h>
#include "contact_internal.h"

typedef mo_setmap_ord ord_t;
#define order_of mo_setmap_order
#define order_cmp mo_setmap_cmp

/* Old candidate p's key: aside when its place has been written, else still in the set. */
static inline const int *old_key(const mo_setmap *M, const int *keys, int p)
{
  return p < M->written ? M->hold + (size_t)(p & M->hmask) * MO_KEY : keys + (size_t)p * MO_KEY;
}

static inline int same_key(const int *a, const int *b)
{
  return a[0] == b[0] && a[1] == b[1] && a[2] == b[2] && a[3] == b[3] && a[4] == b[4];
}

static inline void copy_key(int *to, const int *from)
{
  memcpy(to, from, MO_KEY * sizeof *to);
}

int mo_setmap_begin(mo_setmap *M, const unsigned char *rr, int nold, int nstatic, mo_ctx *ctx)
{
  int a;
  if (nstatic > M->mcap) {
    int *p = mo_realloc(ctx, M->map, ((size_t)nstatic + 1) * sizeof *p);
    if (!p) return MO_ENOMEM;
    M->map = p;
    M->mcap = nstatic;
  }
  for (a = 0; a < nstatic; a++) M->map[a] = a; /* the fixed candidates stay where they are */
  M->rr = rr;
  M->nold = nold;
  M->j = M->g1 = M->written = nstatic;
  M->ingroup = 0;
  M->bad = 0;
  return MO_OK;
}

/* Room for the old keys of places [j, a] aside (a power of 2 of slots, place p in slot p & hmask). */
static int hold_room(mo_setmap *M, int a, mo_ctx *ctx)
{
  int n = M->hold ? M->hmask + 1 : 0, p;
  int *h;
  if (a - M->j + 1 <= n) return MO_OK;
  while (n < a - M->j + 1) n = n ? 2 * n : 16;
  if (!(h = mo_malloc(ctx, (size_t)n * MO_KEY * sizeof *h))) return MO_ENOMEM;
  for (p = M->j; p < a && p < M->nold && M->hold; p++)
    copy_key(h + (size_t)(p & (n - 1)) * MO_KEY, M->hold + (size_t)(p & M->hmask) * MO_KEY);
  mo_free(M->hold);
  M->hold = h;
  M->hmask = n - 1;
  return MO_OK;
}

int mo_setmap_reserve(mo_setmap *M, int n, mo_ctx *ctx)
{
  int cap = M->mcap, *q;
  if (n <= cap) return MO_OK;
  while (cap < n) cap = cap ? cap + cap / 8 + 1 : 16; /* an eighth more, as the set's arrays (T253) */
  if (!(q = mo_realloc(ctx, M->map, (size_t)cap * sizeof *q))) return MO_ENOMEM;
  M->map = q;
  M->mcap = cap;
  return MO_OK;
}

int mo_setmap_put(mo_setmap *M, int *keys, int a, const int *key, mo_ctx *ctx)
{
  ord_t g;
  int p, st;
  if (a >= M->mcap && (st = mo_setmap_reserve(M, a + 1, ctx))) return st;
  /* old candidate a not read yet: aside before its place is written (T221) */
  if (a >= M->j && a < M->nold) {
    if ((st = hold_room(M, a, ctx))) return st;
    copy_key(M->hold + (size_t)(a & M->hmask) * MO_KEY, keys + (size_t)a * MO_KEY);
  }
  copy_key(keys + (size_t)a * MO_KEY, key);
  M->written = a + 1;
  g = order_of(M->rr, key);
  if (!M->ingroup || order_cmp(g, M->g) != 0) {
    /* a new group: the old ones before it have no new candidate (T222); the order of the old
       candidate at g1 is known from the last group's end */
    int c = 1;
    if (M->ingroup && order_cmp(g, M->g) < 0) M->bad = 1; /* not the detection's order: a bug */
    M->j = M->g1;
    if (M->j < M->nold) {
      if (!M->ingroup) M->og1 = order_of(M->rr, old_key(M, keys, M->j)); /* the first group */
      c = order_cmp(M->og1, g);
    }
    if (c < 0) {
      /* the old set is in the order too: its first candidate not before g found by galloping
         from j, then bisection (over a rank's part of the new set (T270) the other parts' old
         groups are passed at a few orders each, not one a candidate; on one rank the first probe
         ends it as a step would) */
      int lo = M->j + 1, hi = lo;
      long step = 1;
      ord_t oh = M->og1; /* the order at hi when hi < nold has been probed */
      while (hi < M->nold) {
        oh = order_of(M->rr, old_key(M, keys, hi));
        if (order_cmp(oh, g) >= 0) break;
        lo = hi + 1;
        hi = M->nold - hi > step ? hi + (int)step : M->nold;
        step *= 2;
      }
      while (lo < hi) { /* [j, lo) before g; hi the end, or not before g with order oh */
        const int mid = lo + (hi - lo) / 2;
        const ord_t om = order_of(M->rr, old_key(M, keys, mid));
        if (order_cmp(om, g) < 0) lo = mid + 1;
        else {
          hi = mid;
          oh = om;
        }
      }
      M->j = lo;
      if (M->j < M->nold) { /* hi = lo = j, probed: oh is its order */
        M->og1 = oh;
        c = order_cmp(M->og1, g);
      }
    }
    /* [j, g1): the old candidates of this group */
    for (M->g1 = M->j; c == 0;) {
      if (++M->g1 >= M->nold) break;
      M->og1 = order_of(M->rr, old_key(M, keys, M->g1));
      c = order_cmp(M->og1, g);
    }
    M->g = g;
    M->ingroup = 1;
  }
  /* within the group (a body pair's few contacts), the first old key equal to it */
  M->map[a] = -1;
  for (p = M->j; p < M->g1; p++)
    if (same_key(old_key(M, keys, p), key)) {
      M->map[a] = p;
      break;
    }
  return MO_OK;
}

void mo_setmap_free(mo_setmap *M)
{
  mo_free(M->map);
  mo_free(M->hold);
  memset(M, 0, sizeof *M);
}
