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

#endif
