/* partition.c: recursive coordinate bisection (doc/theory.md (T330)). */
#include "config.h"
#include "partition.h"

#include <math.h>
#include <string.h>

static inline const double *point(int dim, const double *x, const int *sel, int k)
{
  return x + (size_t)dim * (size_t)(sel ? sel[k] : k);
}

static inline int bin_of(double v, double lo, double w) { return mo_rcb_bin(v, lo, w); }

/* The m items idx[0 .. m-1] into parts q0 .. q0 + q - 1, the cuts recorded in T from node *nn on
   (T: NULL, none). Returns the axis of the cut. */
static int cut(int dim, const double *x, const int *sel, int *idx, long m, int q0, int q, int *part, mo_rcb_tree *T,
               int *nn)
{
  double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL}, w;
  long cnt[MO_RCB_BINS], cum = 0, i, nl = 0;
  int ax = 0, k, b, bcut, ql = q / 2;
  if (q == 1) {
    for (i = 0; i < m; i++) part[idx[i]] = q0;
    return 0;
  }
  if (m == 0) {
    /* no point: a node that sends everything to its first half, and its halves' nodes below */
    if (T) {
      mo_rcb_node *N = &T->node[(*nn)++];
      N->ax = 0;
      N->lo = 0;
      N->w = 1;
      N->bcut = MO_RCB_BINS + 1;
      cut(dim, x, sel, idx, 0, q0, ql, part, T, nn);
      cut(dim, x, sel, idx, 0, q0 + ql, q - ql, part, T, nn);
    }
    return 0;
  }
  for (i = 0; i < m; i++) {
    const double *p = point(dim, x, sel, idx[i]);
    for (k = 0; k < dim; k++) {
      if (p[k] < lo[k]) lo[k] = p[k];
      if (p[k] > hi[k]) hi[k] = p[k];
    }
  }
  for (k = 1; k < dim; k++)
    if (hi[k] - lo[k] > hi[ax] - lo[ax]) ax = k;
  w = hi[ax] > lo[ax] ? (hi[ax] - lo[ax]) / MO_RCB_BINS : 1;
  memset(cnt, 0, sizeof cnt);
  for (i = 0; i < m; i++) cnt[bin_of(point(dim, x, sel, idx[i])[ax], lo[ax], w)]++;
  /* a bin goes below the cut while the count before it is under m ql / q (the slab rule of
     (T215): the bin in the part of its first point) */
  for (bcut = 0; bcut < MO_RCB_BINS; bcut++) {
    if (cum * q / m >= ql) break;
    cum += cnt[bcut];
  }
  /* the items below the cut first (their order within a side does not matter: parts only) */
  for (i = 0; i < m; i++)
    if (bin_of(point(dim, x, sel, idx[i])[ax], lo[ax], w) < bcut) {
      b = idx[nl];
      idx[nl++] = idx[i];
      idx[i] = b;
    }
  if (T) {
    mo_rcb_node *N = &T->node[(*nn)++];
    N->ax = ax;
    N->lo = lo[ax];
    N->w = w;
    N->bcut = bcut;
  }
  cut(dim, x, sel, idx, nl, q0, ql, part, T, nn);
  cut(dim, x, sel, idx + nl, m - nl, q0 + ql, q - ql, part, T, nn);
  return ax;
}

int mo_rcb(int dim, int n, const double *x, const int *sel, const unsigned char *mask, int nparts, int *part,
           int *idx)
{
  long m = 0;
  int k;
  for (k = 0; k < n; k++) {
    part[k] = -1;
    if (!mask || mask[k]) idx[m++] = k;
  }
  return cut(dim, x, sel, idx, m, 0, nparts < 1 ? 1 : nparts, part, NULL, NULL);
}

int mo_rcb_tree_make(int dim, int n, const double *x, const int *sel, const unsigned char *mask, int nparts,
                     int *part, int *idx, mo_rcb_tree *T)
{
  long m = 0;
  int k, nn = 0;
  if (nparts < 1) nparts = 1;
  if (nparts > MO_RCB_MAXPARTS) return -1;
  for (k = 0; k < n; k++) {
    part[k] = -1;
    if (!mask || mask[k]) idx[m++] = k;
  }
  T->nparts = nparts;
  T->dim = dim;
  return cut(dim, x, sel, idx, m, 0, nparts, part, T, &nn);
}

/* A point goes below node N's cut when its bin is: the test of cut()'s partition. */
static inline int below(const mo_rcb_node *N, const double *p)
{
  return N->bcut > MO_RCB_BINS || bin_of(p[N->ax], N->lo, N->w) < N->bcut;
}

int mo_rcb_locate(const mo_rcb_tree *T, const double *p)
{
  int q0 = 0, q = T->nparts, ni = 0;
  while (q > 1) {
    const int ql = q / 2;
    if (below(&T->node[ni], p)) {
      ni += 1; /* the first half's nodes follow its node (preorder) */
      q = ql;
    } else {
      ni += ql; /* after the first half's ql - 1 nodes */
      q0 += ql;
      q -= ql;
    }
  }
  return q0;
}

void mo_rcb_box(const mo_rcb_tree *T, int part, double *lo, double *hi)
{
  int q0 = 0, q = T->nparts, ni = 0, k;
  for (k = 0; k < 3; k++) {
    lo[k] = -HUGE_VAL;
    hi[k] = HUGE_VAL;
  }
  while (q > 1) {
    const int ql = q / 2;
    const mo_rcb_node *N = &T->node[ni];
    /* the plane between the bins: a point of bin < bcut is below it (rounding aside: callers
       grow the box by a margin). A point beyond the bins takes the first or last bin: with the cut
       after the last bin (or before the first) the half below (above) reaches to infinity */
    const double at = N->lo + N->w * N->bcut;
    if (part < q0 + ql) {
      if (N->bcut <= 0) hi[N->ax] = -HUGE_VAL; /* no bin below the cut: the half below is empty */
      else if (N->bcut < MO_RCB_BINS && at < hi[N->ax]) hi[N->ax] = at;
      ni += 1;
      q = ql;
    } else {
      if (N->bcut > MO_RCB_BINS) lo[N->ax] = HUGE_VAL; /* every point below: the half above is empty */
      else if (N->bcut > 0 && at > lo[N->ax]) lo[N->ax] = at;
      ni += ql;
      q0 += ql;
      q -= ql;
    }
  }
}
