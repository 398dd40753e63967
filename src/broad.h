/* broad.h: the broad phase of contact detection: pairs of bounding balls within alert, in O(N). */
#ifndef MOREAU_BROAD_H
#define MOREAU_BROAD_H

#include <stddef.h>

#include <moreau/ctx.h>

/* Reusable state of the broad phase: the grid and the pair list of the last call. Once the sizes
   are stable (bodies, occupied cells, pairs), a call allocates nothing. */
typedef struct mo_broad mo_broad;

/* A new, empty broad phase in *out (NULL on failure, MO_ENOMEM recorded in ctx). */
int mo_broad_create(mo_broad **out, mo_ctx *ctx);

/* Release B and everything it holds; NULL is accepted. */
void mo_broad_free(mo_broad *B);

/* Every pair i < j of the n balls (centres c: dim * n, radii r: n, dim 2 or 3) with
   |c_i - c_j| - r_i - r_j <= alert (alert >= 0), bodies with mask[i] == 0 left out (mask NULL:
   all take part). The pairs come in *pairs, 2 ints each, i increasing and j increasing for each
   i, *npairs of them; the array is owned by B and valid until the next call (it may be NULL
   when *npairs is 0).
   Bodies are binned by centre in cells of size h = 2 r_max + alert, so a pair lies in
   neighbouring cells and each body meets only the 3^dim cells around it: O(n) time and memory
   when the radii are of bounded ratio. The grid is a dense array over the bodies' bounding box
   when that takes at most about 4 cells per body, else (sparse sets, a body far away from the
   others) a hash table of the occupied cells, never more cells than bodies.
   Errors: MO_EINPUT for a dimension other than 2 or 3, n < 0, alert not >= 0, or a body taking
   part with a non-finite coordinate or a radius not finite >= 0 (the message names the body);
   MO_ENOMEM. On error *npairs is 0. */
int mo_broad_pairs(mo_broad *B, int dim, int n, const double *c, const double *r, const unsigned char *mask,
                   double alert, const int **pairs, long *npairs, mo_ctx *ctx);
/* Keeps the pairs (i, j) of the last list for which keep(arg, i, j) is not 0, in their order, and
   returns their count: the list's new length (the list itself stays where mo_broad_pairs put it). */
long mo_broad_keep(mo_broad *B, int (*keep)(void *arg, int i, int j), void *arg);

/* Release what B holds but keep B: its next call allocates again (a broad phase called seldom,
   vblocks.c's whole builds, need not hold its arrays between calls). The pairs of the last call
   are gone. */
void mo_broad_trim(mo_broad *B);

/* Bytes held by B (for memory reports); 0 for NULL. */
size_t mo_broad_bytes(const mo_broad *B);

#endif
