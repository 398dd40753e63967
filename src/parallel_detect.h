/* parallel_detect.h: the granular path's detection split over MPI ranks (doc/parallel.md §4,
   doc/theory.md (T215)-(T217)). Private to the core (detect.c and the tests). */
#ifndef MOREAU_PARALLEL_DETECT_H
#define MOREAU_PARALLEL_DETECT_H

#include <stddef.h>

#include <moreau/ctx.h>
#include <moreau/step.h>

#include "partition.h"

struct mo_contact;

/* The detection is split over the ranks only when the broad phase holds at least this many
   bodies a rank (contact.detect_split_min; doc/theory.md (T337)); fewer are detected whole on
   every rank, as one process detects them, with no message. */
#define MO_PDETECT_MIN 64

/* The split's state, per contact set (parallel_detect.c). */
#define MO_PDETECT_NTAG 3
struct mo_pdetect {
  int rank, nranks;
  int *owner;              /* per body: its box at the last build of the pair list (-1: none) */
  mo_rcb_tree tree;        /* the boxes of the last build (T341): a point's owner, the same on every rank */
  double *pts;             /* the points the boxes were cut from (D each), and the cut's scratch */
  int *pidx, *ppart;
  size_t ptcap, pidxcap, ppartcap;
  int *cown;               /* per candidate of the merged set: the rank that detected it (-1: before the
                              split part), of set cown_set (T341) */
  size_t cowncap;
  long cown_set;
  unsigned char *rmask;    /* per body: in this rank's broad phase (its slab and halo) */
  int nc0;                 /* the first candidate of the split part of the detection */
  int *okey;               /* the previous set's keys from nc0 on (knold - nc0 of them); not kept when
                              the detection writes the remap: the keys compared through it (T271) */
  size_t okcap;
  int knold, ksame;        /* as C's, before the split part */
  int *tag;                /* MO_PDETECT_NTAG per candidate this rank appended: the serial order's key
                              (none when the detection writes the remap: the keys give the order, T271) */
  size_t tagcap;
  double *buf, *all;       /* this rank's records, every rank's */
  size_t bufcap, allcap;
  int *cnt, *one;          /* per rank: its values in the gather; 1 each */
  double *rc;              /* per rank: its candidates (or -1: it failed) */
  long *tot;               /* per rank: its candidates over the run */
  /* lists made at each build (T230)-(T231): this rank's own bodies of the broad phase; the bodies
     whose speeds it needs between builds (its slab and halo, and the dynamic bodies outside the
     broad phase); the other dynamic bodies; per pair k, the slave indices of this rank's shapes
     (wall[wall0[k] .. wall0[k + 1]]) */
  int *own, *near, *rest, *wall, *wall0;
  size_t wallcap;
  int nown, nnear, nrest;
  /* U- = H^T v + U0 of the split part's candidates (d each, from nc0 on, at the set's places), each
     rank forming its own part's at the detection's state before the gather, which carries them
     (T300); of state (up_u, up_v, up_step) and of the set up_set of up_nc candidates, up_nc < 0
     when the last detection made none (T301) */
  double *up;
  size_t upcap;
  const double *up_u, *up_v;
  long up_step, up_set;
  int up_nc;
  /* The bodies' state per rank (doc/theory.md §13.18): with the distributed set on a scene of rigid
     bodies and obstacles only, from the second build of the list each rank keeps current only the
     bodies of its box and halo (rmask) and those outside the broad phase (every rank's); at each
     build the owner of each body sends its state to every rank that newly or still holds it. */
  int held;                /* on from the first build (then every rank holds every body) */
  unsigned long long *hold;/* per body this rank holds: the ranks that hold it (bit r: rank r) */
  int *hlist, nhlist;      /* the bodies this rank holds (broad phase's and others, ascending) */
  int *xlist, nxlist;      /* the rigid bodies outside the broad phase (every rank's) */
  int *xdm, nxdm;          /* the dynamic bodies outside the broad phase (their speeds every rank's) */
  int *xnb, nxnb;          /* every body outside the broad phase (rank 0 detects their contacts) */
  int *winv;               /* per pair k and body b, b's index among k's slaves (-1: none; NULL: not
                              made, a pair listing a body twice) */
  int winv_up;             /* every pair's slaves in increasing body order */
  unsigned char *count;    /* per body: 1 when this rank counts it in the sums over bodies (its own,
                              and rank 0 the dynamic bodies outside the broad phase) */
  double halo;             /* the halo of the last build's boxes */
  int *mig_old, *mig_box;  /* scratch: the own list of the last build (the senders' bodies), their boxes */
  unsigned long long *mig_m; /* scratch: their hold masks now */
  int *rlist, nrecv;       /* the bodies received at the last build */
  int *sh_off, *sh_at, *sh_b; /* per rank q, the held bodies it holds too: sh_b[sh_off[q] ..
                              sh_off[q + 1]), ascending (sh_at: scratch) */
  size_t sh_bcap;
  size_t rlistcap;
  double *mig_s, *mig_r;   /* the records sent and received at a build */
  size_t mig_scap, mig_rcap;
  int *mig_cnt;            /* 7 nranks + 2: counts sent, received; offsets, peers, cursors */
};

/* Whether this rank detects body b's candidates against obstacles (it owns its box); a body in no
   pair between shapes (a shape against obstacles only) is rank 0's. */
static inline int mo_pdetect_owns(const struct mo_pdetect *P, int b)
{
  return P->owner[b] == P->rank || (P->owner[b] == -1 && P->rank == 0);
}

/* A pair's point (T341): between shapes i and j, the point of the segment between their centres
   (cen, D each) at the ratio of their bounding radii R, from the lower index (the contact point of
   two balls that touch); with i == j (a shape against an obstacle) its centre. The same on every
   rank. */
static inline void mo_pdetect_point(int D, const double *cen, const double *R, int i, int j, double *p)
{
  const int lo = i < j ? i : j, hi = i < j ? j : i;
  const double t = R[lo] + R[hi] > 0 ? R[lo] / (R[lo] + R[hi]) : 0.5;
  int k;
  for (k = 0; k < D; k++) p[k] = cen[(size_t)D * lo + k] + t * (cen[(size_t)D * hi + k] - cen[(size_t)D * lo + k]);
}

/* The boxes of a build (T215)-(T216), (T330), (T341), the same on every rank from the same data:
   the npts points pts (dim each) cut into `nranks` boxes of about equal counts by recursive
   bisection (mo_rcb_tree_make), or with npts = 0 the centres c of the n bodies with mask[b] != 0;
   owner[b] the box of body b's centre (-1 when mask[b] is 0). A pair of bodies within `reach`
   (|c_i - c_j| - r_i - r_j <= reach) is detected by the box of its point (mo_pdetect_point):
   rmask[b] = 1 for the bodies rank `rank` needs to find every such pair, its own and those whose
   centres lie in its box grown by 2 max r + reach (its halo). T: the cuts, for the pairs' owners
   (mo_rcb_locate). idx, ppart: max(n, npts) ints of scratch. -1 past MO_RCB_MAXPARTS ranks. */
int mo_pdetect_boxes(int dim, int n, const double *c, const double *r, const unsigned char *mask, double reach,
                     long npts, const double *pts, int nranks, int rank, mo_rcb_tree *T, int *owner,
                     unsigned char *rmask, int *idx, int *ppart);

/* (T347) mo_rcb_tree_make's tree of the points of every rank, each rank passing its own n (D each,
   reordered in place), none gathered: the same tree to the bit (collective; -1 past
   MO_RCB_MAXPARTS parts, else MO_OK or an MPI error). */
int mo_pdetect_tree_dist(int D, long n, double *pts, int nparts, mo_rcb_tree *T, mo_ctx *ctx);

/* Whether the detection of C is split over the ranks of ctx: more than one rank, the granular
   path's compact records, pairs between rigid shapes, and every other dynamic pair a shape
   against an obstacle. The state is made on the first call. */
int mo_pdetect_active(struct mo_contact *C, mo_ctx *ctx);
/* Before the split part of a detection: its first candidate, and the previous keys kept. */
int mo_pdetect_begin(struct mo_contact *C, mo_ctx *ctx);
/* After a broad-phase build: the slabs and this rank's mask of the bodies (from C->bc, C->br),
   and its lists of bodies and shapes (T230)-(T231). */
int mo_pdetect_build(struct mo_contact *C, const mo_state *s, mo_ctx *ctx);
/* The bodies received at the last build, whose detection data (speeds, snapshot) the caller forms
   from the state (their count; *b the list). */
int mo_pdetect_received(const struct mo_pdetect *P, const int **b);
/* This rank's own bodies of the broad phase at the last build (their count; *b the list). */
static inline int mo_pdetect_own(const struct mo_pdetect *P, const int **b)
{
  *b = P->own;
  return P->nown;
}
/* The dynamic bodies whose speeds this rank needs between builds: its slab and halo, and those
   outside the broad phase. */
static inline int mo_pdetect_near(const struct mo_pdetect *P, const int **b)
{
  *b = P->near;
  return P->nnear;
}
/* The other dynamic bodies (their speeds are needed at a build only). */
static inline int mo_pdetect_rest(const struct mo_pdetect *P, const int **b)
{
  *b = P->rest;
  return P->nrest;
}
/* The slave indices (in the pair's list) of the shapes of pair k this rank detects (T231). */
static inline int mo_pdetect_walls(const struct mo_pdetect *P, int k, const int **i)
{
  *i = P->wall + P->wall0[k];
  return P->wall0[k + 1] - P->wall0[k];
}
/* This rank's broad-phase mask. */
const unsigned char *mo_pdetect_mask(const struct mo_contact *C);
/* Whether this rank detects the pair of shapes i and j at centres cen: its point's box is the rank's
   (T341). */
static inline int mo_pdetect_owns_pair(const struct mo_pdetect *P, int D, const double *cen, const double *R, int i,
                                       int j)
{
  double p[3];
  mo_pdetect_point(D, cen, R, i, j, p);
  return mo_rcb_locate(&P->tree, p) == P->rank;
}
/* Per candidate of C's current set, the rank that detected it (-1: none), or NULL when the
   detection is not split or its owners are not of this set (T341). */
const int *mo_contact_detect_owners(const struct mo_contact *C);
/* The candidates this rank just appended (from `from` to C->nc) carry the order key (s0, s1, s2)
   of the serial detection: (pair, slave index, 0) against an obstacle, (npair, i, j) between two
   shapes. */
int mo_pdetect_tag(struct mo_contact *C, int from, int s0, int s1, int s2, mo_ctx *ctx);
/* Every rank's candidates gathered, in the serial detection's order, into C on every rank (st:
   this rank's status so far, passed to every rank: a failure on one rank fails them all), with
   U- of each at state s, formed by the rank that found it (T300; s->v NULL: none). */
int mo_pdetect_finish(struct mo_contact *C, const mo_state *s, int st, mo_ctx *ctx);
/* After the detection, its set's version known: U- of the gathered candidates is of set `set`. */
static inline void mo_pdetect_seal(struct mo_pdetect *P, long set)
{
  P->up_set = set;
  P->cown_set = set;
}
void mo_pdetect_free(struct mo_contact *C);

#endif
