/* contact_internal.h: the contact set's storage, private to the core. */
#ifndef MOREAU_CONTACT_INTERNAL_H
#define MOREAU_CONTACT_INTERNAL_H

#include <moreau/body.h>
#include <moreau/contact.h>

struct mo_broad;
struct mo_pdetect;

/* The remap the detection writes while it overwrites the set's keys (setmap.c, doc/theory.md
   §12.15): map[a] = the place of new candidate a in the old set (-1: new), in the detection's
   order (T220); the old keys overwritten before they are read held aside in a ring (T221). */
typedef struct {
  unsigned long long hi, lo;  /* an order of (T220), packed: compared hi first */
} mo_setmap_ord;

/* The detection's order of candidate key k (T220), packed in two words compared in turn: a pair
   between two shapes (rr[pair]) visits the body pairs of the broad phase's list, sorted by
   (lower, higher) index, after every other pair; the others go by pair, slave, master (indices
   >= 0). */
static inline mo_setmap_ord mo_setmap_order(const unsigned char *rr, const int *k)
{
  mo_setmap_ord o;
  if (rr[k[0]]) {
    const unsigned long long a = (unsigned)(k[1] < k[2] ? k[1] : k[2]), b = (unsigned)(k[1] < k[2] ? k[2] : k[1]);
    o.hi = 1ULL << 32 | a;
    o.lo = b << 32;
  } else {
    o.hi = (unsigned)k[0];
    o.lo = (unsigned long long)(unsigned)k[1] << 32 | (unsigned)k[2];
  }
  return o;
}

/* -1, 0, 1 as order a is before, the same as, after order b. */
static inline int mo_setmap_cmp(mo_setmap_ord a, mo_setmap_ord b)
{
  if (a.hi != b.hi) return a.hi < b.hi ? -1 : 1;
  return a.lo < b.lo ? -1 : a.lo > b.lo;
}
typedef struct {
  int *map, mcap;             /* per candidate of the new set (its capacity grows by a quarter) */
  int *hold, hmask;           /* the ring of old keys: place p in slot p & hmask */
  const unsigned char *rr;    /* per pair: 1 between two shapes (the broad phase's list orders it) */
  int nold;                   /* candidates of the old set */
  int j;                      /* the first old candidate not passed yet */
  int g1;                     /* the end of the current group's old candidates [j, g1) */
  mo_setmap_ord g, og1;       /* the current group's order (T220), and that of the old candidate
                                 at g1 (when g1 < nold) */
  int ingroup;
  int written;                /* places of the set written so far */
  int bad;                    /* a key out of the detection's order: the map is not to be used */
} mo_setmap;
int mo_setmap_begin(mo_setmap *M, const unsigned char *rr, int nold, int nstatic, mo_ctx *ctx);
/* Write key at place a of keys (the old set's there until now) and map a. The keys put may be
   any subsequence of the new set in the order of (T220) (a rank's part of it, (T270)): each is
   mapped as in the whole set. */
int mo_setmap_put(mo_setmap *M, int *keys, int a, const int *key, mo_ctx *ctx);
/* Room in the map for places [0, n). */
int mo_setmap_reserve(mo_setmap *M, int n, mo_ctx *ctx);
void mo_setmap_free(mo_setmap *M);

struct mo_contact {
  const mo_scene *sc;
  int dim;                    /* local dimension = space dimension */
  int npair;
  mo_contact_pair *pair;
  struct {
    int n;                    /* candidates of the pair */
    int *cand;                /* their global candidate numbers */
    double *P;                /* P* (n x n, row-major), NULL without facets */
  } *pp;
  /* points, candidates and coefficient lists: the mesh points fixed at build first (the static
     part: npt_static, nc_static, ncoef_static), then the detected ones of the last geometry */
  int npt, ptcap, npt_static;
  mo_cpoint *pt;
  int nc, ccap, nc_static;
  mo_candidate *cand;
  int ncoef, coefcap, ncoef_static;
  int *cpt;                   /* candidate point lists */
  double *ccoef;              /* and coefficients */
  int nalloc;                 /* capacity of the per-candidate arrays below */
  double *g;                  /* nc gaps */
  double *frame;              /* nc * dim * dim; on the granular path (compact) nc * dim: the normals
                                 alone, the rest of each frame formed from it (T225) */
  int u0_any;                 /* some obstacle of the scene moves: U0 is stored */
  double *U0;                 /* dim * nc obstacle local velocities; NULL when no obstacle of the
                                 scene moves (every one would be 0) */
  unsigned char *active;      /* nc: 0 when its projection fell off the master (inactive) */
  int *key;                   /* nc * MO_KEY (a candidate's law and restitution are its pair's:
                                 mo_contact_pair_of) */
  mo_csc *Hfull, *H;
  int hcapf, hcap, hpcapf, hpcap; /* capacities of their arrays (entries, columns + 1), kept */
  struct {
    int n[3], cap;
    int *row[3];
    double *val[3];
  } hb;                       /* one candidate's entries of H, gathered before they are sorted */
  long hversion, cset_version;
  int moving_h;               /* some point sits on a rigid body: H follows it at every step */
  const mo_state *hstate;     /* the state of the geometry under way (NULL outside it) */
  mo_signorini signorini;
  int repair;                 /* pair again at every step */
  int on_failure_continue;
  int poscorr;               /* contact.position_correction: 0 none, 1 project (T95-T96), 2 shift (T95) */
  int delassus_always;       /* contact.delassus = "always": W at every step, no body sweep */
  int h_alias;               /* H is Hfull (every dof free, in order): one matrix built */
  /* the granular path (doc/theory.md §12.9): every candidate is a detected contact between rigid
     shapes, or a shape and an obstacle, whose bodies are free or held fixed, and the back end
     reads the compact records (MO_NEEDS_GRAINS). The detection then writes only the per-candidate
     arrays above and the contact points x: no mo_cpoint, no mo_candidate, and H only on demand
     (mo_contact_H_ensure: levelset, FCLIB dumps, contact.delassus = "always" turn compact off) */
  int compact;
  int compact_ok;             /* the scene qualifies (the back end and the options aside) */
  double *x;                  /* D per candidate: the contact point of a detected candidate */
  long hbuilt;                /* cset_version H was last built for (compact: built on demand) */
  char *solver;
  /* detection between rigid shapes (detect.c) */
  int ndyn;                   /* dynamic pairs */
  double alert;               /* contact.alert; the automatic value when the case gives none */
  double skin;                /* contact.skin: the Verlet list's margin (T110) */
  double gtol;                /* gaps below this are closed: round-off of resting contacts (1e-9
                                 of the smallest body of the dynamic pairs) */
  double h;                   /* the step the margin of the alert distance is taken over */
  struct mo_broad *broad;
  /* the pair list kept by blocks in their own frames (vblocks.c, doc/theory.md §12.26): contact.verlet
     (0 auto: from MO_VBLOCKS_MIN bodies of the broad phase on one process, 1 global: (T111)'s one
     mean, 2 blocks), and the list */
  int verlet;
  struct mo_vblocks *vb;
  /* the rigid-rigid pairs' sides by class (T310): the bodies on the same sides of the same pairs
     (an entry's grains) share a class, one byte a body in bmask, and the class's masks give bit k
     when it is on the master (rcm) / slave (rcs) side of rigid-rigid pair k; class 0 is on none */
  unsigned long long *rcm, *rcs;
  int nrcls;                  /* classes, 0 included (at most 256) */
  int nrr;                    /* rigid-rigid pairs (at most 64) */
  int *rr;                    /* their pair numbers */
  double *bc, *br;            /* broad phase: centres and radii of the rigid bodies when the list was built */
  double *bcur;               /* D per body of the dynamic pairs: its centre at this geometry (rigid ones) */
  const double *bcur_u;       /* the state bcur is of: its displacements and its step */
  long bcur_step;
  int *bdof;                  /* per body: its first dof when it is rigid, else -1 */
  double *bs, *be;            /* per body: its speed bound, and its alert margin when the pair list was built */
  double *bv, *bw;            /* per body: its translation velocity (D), and what its rotation adds (omega r_bound) */
  double *bs2;                /* per body of the broad phase: its speed relative to their mean velocity, plus bw */
  double *psb;                /* per pair: the largest bounding radius of its slave shapes (the walls' first test, T297) */
  double *bR;                 /* per body: its bounding radius (a ball's radius), read where the
                                 body record was (T310) */
  unsigned char *dmask;       /* per body: nonzero when in a dynamic pair (its speed is needed): MO_DM_* */
  unsigned char *bmask;       /* per body: nonzero when in a rigid-rigid pair (the broad phase's bodies):
                                 its class (rcm, rcs) */
  /* the broad phase's pair list kept between steps (a Verlet list), its reach (alert plus skin)
     and how many times it was built */
  const int *vl;              /* the broad phase's pair array (owned by C->broad) */
  int knold, ksame;           /* detection: candidates of the previous set; its keys unchanged so far */
  /* the remap written by the detection on the granular path (smap.map, from set smap_from to
     smap_to; -1: none), in place of a copy of the old keys in the driver (T220)-(T222) */
  int smap_ok;                /* the detection's order is that of (T220): the granular path (on one rank
                                 or several, each rank's part in that order, (T270)) */
  unsigned char *krr;         /* per pair: 1 between two shapes */
  mo_setmap smap;
  long smap_from, smap_to;
  long vl_n, vl_builds;
  double vl_reach;
  int vl_built;
  struct mo_pdetect *pd;      /* the detection split over MPI ranks (parallel_detect.c), or NULL */
  int pd_min;                 /* contact.detect_split_min: the split's least bodies a rank (T337) */
  int pd_whole;               /* the scene's detection runs whole on every rank (decided once, T337) */
  int pd_dist;                /* contact.distributed_set: with the split detection, each rank keeps
                                 the candidates it detected only (doc/scaling.md §4) */
  const unsigned char *act_of; /* the driver's index set of its last solve, per candidate of set act_set
                                  (NULL: none yet): the points the split detection's parts balance (T341) */
  long act_set;
};

/* dmask's bits: MO_DM_DYN on every body of the dynamic pairs, and the kind's flags the per-step
   passes over those bodies test (body_speed, the pairs' loop, the narrow phase of two balls), kept
   here so that they read no body record (doc/theory.md (T310)) */
enum { MO_DM_DYN = 1, MO_DM_RIGID = 2, MO_DM_OBSTACLE = 4, MO_DM_BALL = 8 };

/* Candidate a's pair: a detected candidate carries it in its key, a mesh point fixed at build in
   its candidate record. */
static inline int mo_contact_pair_of(const mo_contact *C, int a)
{
  const int p = C->key[(size_t)a * MO_KEY];
  return p >= 0 ? p : C->cand[a].pair;
}

void mo_contact_frame_from_normal(int dim, const double *n, double *F);
/* Doubles a candidate's frame takes in C->frame: its normal on the granular path (T225), the whole
   frame otherwise. */
static inline int mo_contact_fstride(const mo_contact *C) { return C->compact ? C->dim : C->dim * C->dim; }
/* contact_geom.c: node a of mesh body b at state s (NULL: reference), and the closest point of x
   on facet f of a facet set of body b (facet coordinates, shape values, point, normal). */
void mo_contact_node_pos(const mo_scene *sc, int b, int a, const mo_state *s, double *x);
double mo_contact_project_facet(const mo_scene *sc, int b, const mo_facetset *fs, int f, const double *x,
                                const mo_state *s, double *xi, double *N, double *q, double *n, int *inside);
/* The position x, shape values N and (when n is not NULL) the outward unit normal of facet f of
   a facet set of body b at reference coordinates s and state u (NULL: reference); returns the
   measure density |dx/ds| (1 for a point facet). The facet factor of the measure at x:
   thickness, 2 pi r, cross-section or 1. */
double mo_contact_facet_eval(const mo_scene *sc, int b, const mo_facetset *fs, int f, const double *s,
                             const mo_state *u, double *N, double *x, double *n);
double mo_contact_facet_factor(const mo_material *mat, const double *x);
/* contact_mortar.c: segmented integration (doc/theory.md §4.7). The Gauss points of slave facet f
   (set sfs of body sb) cut by the facets of the master set mfs (body mb, their centres, normals and
   radii mg from mo_contact_segment_masters) that face it, at state u: appended to *pts (n,
   capacity cap, grown), each with its facet coordinates, its weight (the measure, facet factor
   included) and its master facet (-1: a 2D segment past the master's edge, paired as any point).
   Appends nothing when no master facet faces it, or when they do not cover it exactly once (a 3D
   facet past the master's edge, masters of several layers, a non-convex projected facet: then
   *whole = 1): that facet keeps the rule of the whole facet. */
typedef struct {
  double xi[2];
  double w;
  int mfacet;
} mo_segpt;
int mo_contact_segment_facet(const mo_scene *sc, int sb, const mo_facetset *sfs, int f, int mb,
                             const mo_facetset *mfs, const double *mg, const mo_state *u, int gauss, mo_segpt **pts,
                             int *n, int *cap, int *whole, mo_ctx *ctx);
/* What mo_contact_segment_facet needs of the master facets, once per pair: per facet its centre,
   its unit normal at the centre and its radius about the centre (7 values; *mg freed by the
   caller). */
int mo_contact_segment_masters(const mo_scene *sc, int mb, const mo_facetset *mfs, const mo_state *u, double **mg,
                               mo_ctx *ctx);
/* Append a point / a candidate (its point and coefficient lists); grow the per-candidate arrays
   to hold nc candidates. */
int mo_contact_add_point(mo_contact *C, const mo_cpoint *p, mo_ctx *ctx);
/* Room for one more point in C->pt (which it may move). */
int mo_contact_point_room(mo_contact *C, mo_ctx *ctx);
int mo_contact_add_candidate(mo_contact *C, const mo_candidate *c, const int *pts, const double *coef,
                             mo_ctx *ctx);
int mo_contact_reserve(mo_contact *C, int nc, mo_ctx *ctx);

/* detect.c: set up the detection of the dynamic pairs, and run it at state s (the detected
   points and candidates replace the previous ones: C->nc_static .. C->nc - 1, their gaps,
   frames, obstacle velocities, keys, laws). */
int mo_contact_detect_setup(mo_contact *C, mo_ctx *ctx);
/* The smallest size of the bodies of the pairs under Newton's law (a rigid shape's bounding
   radius, a mesh's shortest edge): the scale of the alert distance and of eps_g (T71). */
double mo_contact_smallest_size(const mo_contact *C);
int mo_contact_detect(mo_contact *C, const mo_state *s, double t, mo_ctx *ctx);
/* The centres of the rigid bodies of the dynamic pairs at state s (D per body, detect.c's bcur, made
   current for s when it is of another state), or NULL over several ranks (T261). */
const double *mo_contact_centres(mo_contact *C, const mo_state *s);
/* 1 when the detection writes the remap of its sets (T220; over MPI ranks each its part, T270): the
   driver then keeps no keys */
int mo_contact_writes_map(const mo_contact *C, const mo_ctx *ctx);
/* The detection's remap from set `from` to set `to` (each new candidate's place in the old set,
   -1: new), or NULL when its last detection did not go from one to the other. */
const int *mo_contact_detect_map(const mo_contact *C, long from, long to);
/* U- = H^T v + U0 at state s of the candidates from *a0 to the set's end (d each, at their places
   in the set), formed over MPI ranks by the rank that detected each and gathered with the set
   (T300); NULL when the last detection was not split, failed, or was of another state or set
   (T301). */
const double *mo_contact_detect_uprev(const mo_contact *C, const mo_state *s, int *a0);
/* Bytes held by the broad phase. */
size_t mo_contact_broad_bytes(const mo_contact *C);
void mo_contact_detect_free(mo_contact *C);

#endif
