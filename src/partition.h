/* partition.h: recursive coordinate bisection of points into parts of equal counts, the
   partition of the granular path over MPI ranks (doc/parallel.md §4, doc/theory.md (T330)). */
#ifndef MOREAU_PARTITION_H
#define MOREAU_PARTITION_H

/* The points of items 0 .. n-1 cut into `nparts` boxes of about equal counts (T330): item k's
   point is x + dim * (sel ? sel[k] : k); items with mask[k] == 0 (mask NULL: none) take part -1.
   A box of q > 1 parts is cut across the axis of its points' largest extent, its first q / 2 parts
   below the cut and about count * (q / 2) / q of its points: through a histogram of its points
   along that axis in MO_RCB_BINS bins, each bin whole on one side (points of one abscissa are
   never split). The cut depends on the data only, so that every rank computes the same one from
   the same replicated positions; with nparts = 2 it is one cut, the slabs of (T215). idx: n ints
   of scratch. Returns the axis of the first cut (0 when nparts < 2). */
#define MO_RCB_BINS 4096
int mo_rcb(int dim, int n, const double *x, const int *sel, const unsigned char *mask, int nparts, int *part,
           int *idx);

/* The cuts of a partition kept (doc/theory.md (T341)): one node a cut, in the order the recursion
   makes them (a box's node, then its first half's nodes, then its second half's: nparts - 1 in
   all), so that any point, not only those cut, finds its part by the same tests. */
#define MO_RCB_MAXPARTS 64
typedef struct {
  int ax, bcut;   /* the axis, and the first bin above the cut (MO_RCB_BINS + 1: every point below) */
  double lo, w;   /* the bins' origin and width along ax */
} mo_rcb_node;
typedef struct {
  int nparts, dim;
  mo_rcb_node node[MO_RCB_MAXPARTS - 1];
} mo_rcb_tree;
/* mo_rcb's partition (the same parts), its cuts kept in T; -1 past MO_RCB_MAXPARTS parts. */
int mo_rcb_tree_make(int dim, int n, const double *x, const int *sel, const unsigned char *mask, int nparts,
                     int *part, int *idx, mo_rcb_tree *T);
/* The bin of abscissa v in the histogram of origin lo and width w (cut()'s own, for a cut made
   elsewhere from the same counts). */
static inline int mo_rcb_bin(double v, double lo, double w)
{
  long b = (long)((v - lo) / w);
  return (int)(b < 0 ? 0 : b >= MO_RCB_BINS ? MO_RCB_BINS - 1 : b);
}
/* The part of point p (dim coordinates): for the points T was made from, their part. */
int mo_rcb_locate(const mo_rcb_tree *T, const double *p);
/* The box of a part: lo[k] <= p[k] <= hi[k] for k < 3 of every point mo_rcb_locate gives it,
   the points beyond the bins included (infinite where no cut bounds it; lo = +infinity for a part
   no point reaches), to the rounding of a cut's abscissa. */
void mo_rcb_box(const mo_rcb_tree *T, int part, double *lo, double *hi);

#endif
