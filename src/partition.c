/* partition.c: recursive coordinate bisection (doc/theory.md (T330)). */
#include "config.h"
#include "partition.h"

#include <math.h>
#include <string.h>

static inline const double *point(int dim, const double *x, const int *sel, int k)
{
  return x + (size_t)dim * (size_t)(sel ? sel[k] : k);
}

static inline int bin_of(double v, double lo, double w)
{
  long b = (long)((v - lo) / w);
  return (int)(b < 0 ? 0 : b >= MO_RCB_BINS ? MO_RCB_BINS - 1 : b);
}

/* The m items idx[0 .. m-1] into parts q0 .. q0 + q - 1. Returns the axis of the cut. */
static int cut(int dim, const double *x, const int *sel, int *idx, long m, int q0, int q, int *part)
{
  double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL}, w;
  long cnt[MO_RCB_BINS], cum = 0, i, nl = 0;
  int ax = 0, k, b, bcut, ql = q / 2;
  if (q == 1 || m == 0) {
    for (i = 0; i < m; i++) part[idx[i]] = q0;
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
  cut(dim, x, sel, idx, nl, q0, ql, part);
  cut(dim, x, sel, idx + nl, m - nl, q0 + ql, q - ql, part);
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
  return cut(dim, x, sel, idx, m, 0, nparts < 1 ? 1 : nparts, part);
}
