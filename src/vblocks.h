/* vblocks.h: the broad phase's pair list kept by blocks of bodies, each block in its own moving
   frame, and made again only where the frames fail (doc/theory.md §12.26, (T320)-(T326)). */
#ifndef MOREAU_VBLOCKS_H
#define MOREAU_VBLOCKS_H

#include <stddef.h>

#include <moreau/ctx.h>

#include "broad.h"

typedef struct mo_vblocks mo_vblocks;

/* The bodies at one detection: n of them (indices 0 .. n-1), those with mask[b] != 0 taking part;
   per body its centre x (dim values), translation velocity v (dim), what its rotation adds to the
   speed of its points w (|omega| times its bounding radius) and its bounding radius bound; the
   time t of the state, the step h the alert margin is taken over, the alert distance and the
   skin (contact.alert, contact.skin). The mask and the bounds must not change between calls. */
typedef struct {
  int dim, n;
  const unsigned char *mask;
  const double *x, *v, *w, *bound;
  double t, h, alert, skin;
} mo_vblocks_in;

/* A new, empty list in *out (NULL on failure, MO_ENOMEM recorded in ctx). */
int mo_vblocks_create(mo_vblocks **out, mo_ctx *ctx);

/* Release V and everything it holds; NULL is accepted. */
void mo_vblocks_free(mo_vblocks *V);

/* The list for the bodies of in: every pair (i < j) whose gap |x_i - x_j| - bound_i - bound_j is
   at most alert + 2 h (|v_i - v_j| + w_i + w_j) is in it (doc/theory.md (T320)-(T324): the pairs
   of the blocks whose frames still hold are kept, those of the others made again). *pairs holds
   *npairs pairs, 2 ints each, sorted by (lower, higher); owned by V, valid until the next call.
   *built: 1 when every block was formed again (a whole build), else 0. The first call and
   calls where more than half of the bodies' blocks fail build the whole list with B's cells.
   Errors as mo_broad_pairs; MO_ENOMEM. On error the list is emptied and the next call builds it
   whole. */
int mo_vblocks_update(mo_vblocks *V, const mo_vblocks_in *in, mo_broad *B, const int **pairs, long *npairs,
                      int *built, mo_ctx *ctx);

/* Blocks made again by the last calls' updates, and blocks in all (for reports). */
void mo_vblocks_stats(const mo_vblocks *V, long *refreshed, long *nblock);

/* Bytes held by V (for memory reports); 0 for NULL. */
size_t mo_vblocks_bytes(const mo_vblocks *V);

#endif
