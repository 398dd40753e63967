/* moreau/contact.h: the core's half of contact: candidates, frames, gaps, the H operators
   (concentrated and P-weighted reactions), the Delassus operator, the contact problem handed to
   a back end, and the back-end type (the seam of doc/architecture.md §5). */
#ifndef MOREAU_CONTACT_H
#define MOREAU_CONTACT_H

#include <math.h>
#include <stdio.h>

#include <moreau/ctx.h>
#include <moreau/scene.h>
#include <moreau/sparse.h>
#include <moreau/step.h>

#ifdef __cplusplus
extern "C" {
#endif

/* --- candidates ---------------------------------------------------------------------------- */

typedef enum { MO_REACT_CONCENTRATED = 0, MO_REACT_WEIGHTED } mo_reactions;
typedef enum { MO_COLLOC_NODES = 0, MO_COLLOC_GAUSS } mo_collocation;
/* Gauss collocation against a mesh master: the Gauss points on the parts of each slave facet cut
   by the master facets (SEGMENTS, mortar segmentation, doc/theory.md §4.7), or on the whole
   slave facet (FACET). */
typedef enum { MO_INTEG_SEGMENTS = 0, MO_INTEG_FACET } mo_integration;
/* How dual cells end where the slave surface ends (weighted reactions, doc/theory.md §4.3):
   DUAL: every facet is split among its nodes; the parts of non-candidate nodes carry no
   reaction (Jean's GRECO runs: last row [.., 1/8, 3/4] at a held end);
   HALF: only facets whose nodes are all candidates count (Jean's printed P*: end rows
   [3/4, 1/4] and [1/4, 3/4]);
   EXTEND: the part of a non-candidate node goes to the nearest candidate of the facet. */
typedef enum { MO_ENDS_DUAL = 0, MO_ENDS_HALF, MO_ENDS_EXTEND } mo_weighted_ends;
typedef enum { MO_MASTER_PLANE = 0, MO_MASTER_FACETS } mo_master_kind;
/* What happens to a slave point whose projection falls off the master surface. */
typedef enum { MO_OFF_NEAREST = 0, MO_OFF_INACTIVE } mo_off_master;
/* The unilateral law of a candidate: Signorini as contact.signorini says (position or velocity
   level), or Moreau's form of Newton's impact law at velocity level with restitution e (pairs
   with a rigid body, doc/theory.md §12.4, (T71)). */
/* SIGNORINI: deformable pairs (contact.signorini); NEWTON: pairs with a rigid body, Moreau's
   impact law (T71); GAP: pairs with a rigid body, Signorini on the end-of-step gap (no
   restitution, no penetration left: contact.pairs.[].law = "gap", (T78)). */
typedef enum { MO_LAW_SIGNORINI = 0, MO_LAW_NEWTON, MO_LAW_GAP } mo_contact_law;

typedef enum { MO_CS_OPEN = 0, MO_CS_STICK, MO_CS_SLIDE } mo_contact_status;
const char *mo_contact_status_name(int s);

/* A contact pair of the case (contact.pairs.[k]). */
typedef struct {
  char *name;
  int sbody;                 /* slave body (the first body of a group) */
  char *sset;                /* slave node or facet set */
  int mbody;                 /* master body: a plane or a deformable body */
  char *mset;                /* master facet set (deformable master) */
  mo_master_kind master;
  double mu;
  mo_reactions reactions;
  mo_collocation colloc;
  int gauss;                 /* points per facet direction (Gauss collocation) */
  mo_integration integ;      /* Gauss collocation: on segments or whole facets */
  int nseg_fallback;         /* slave facets that kept the whole facet's points (not covered once) */
  mo_weighted_ends ends;
  mo_off_master off;
  char *exclude;             /* node set whose nodes are not candidates (or NULL) */
  double e;                  /* restitution coefficient (MO_LAW_NEWTON) */
  mo_contact_law law;
  int dynamic;               /* candidates found by the detection at every step (rigid shapes,
                                doc/theory.md §12.3); 0: the fixed slave points of a mesh */
  int ns, nm;                /* dynamic pairs: the bodies of each side (a body or a group) */
  int *sb, *mb;
} mo_contact_pair;

/* A point of a slave surface (a node, or a Gauss point of a facet) with its pairing. */
typedef struct {
  int pair;
  int facet;                 /* slave facet (index in the slave facet set) of a Gauss point,
                                -1 for a node point */
  int nn, node[MO_FNODE_MAX]; /* slave nodes (body-local) interpolating the point */
  double N[MO_FNODE_MAX];    /* their shape values */
  double x0[3];              /* reference position */
  /* pairing, frozen inside a geometric loop */
  int mfacet;                /* master facet (index in the master set), -1 for a plane */
  int mn, mnode[MO_FNODE_MAX];
  double mN[MO_FNODE_MAX];
  double xi[2];              /* master facet coordinates of the projection */
  int off;                   /* 1: the projection fell off the master (inactive) */
  int mseg;                  /* segmented integration: 1 + the master facet of the point's segment,
                                taken at the first pairing (0: none, search the nearest) */
  double frame[9];           /* rows: n (master to slave), t, s */
  double g;                  /* gap in the current configuration (>= 0 open) */
  /* the bodies and material points on each side (pairs may join groups of bodies): the slave
     point and its master point (the projection) for mesh points, the point midway between the
     surfaces on both sides for detected ones; rigid bodies' columns of H are taken there */
  int sb, mb;
  double xs[3], xm[3];
  int sfeat, mfeat;          /* detected points: features (vertex, edge), to match them over steps */
} mo_cpoint;

/* A candidate alpha: a combination sum_k c_k of points (one point with c = 1 for concentrated
   reactions and Gauss collocation; the P* row of its dual cell for weighted reactions). */
typedef struct {
  int pair;
  int first, np;             /* entries first .. first+np-1 of the point/coefficient lists */
  int node;                  /* representative slave node (body-local), -1 for a Gauss point */
  int point;                 /* its representative point (frame, position) */
  double w;                  /* measure: dual-cell length/area, Gauss weight, or 1 */
  double mu;
} mo_candidate;

typedef struct mo_contact mo_contact;

/* Build the contact set of a scene from its case's `contact` group (NULL when the case has
   none): pairs, slave points, candidates, pairing and H in the reference configuration.
   Fully prescribed slave nodes are not candidates (they cannot move). */
int mo_contact_build(const mo_scene *sc, mo_contact **out, mo_ctx *ctx);
void mo_contact_free(mo_contact *C);

int mo_contact_dim(const mo_contact *C);          /* local dimension (1 in 1D, 2, 3) */
int mo_contact_ncandidates(const mo_contact *C);
/* The room the contact set keeps for its candidates (at least mo_contact_ncandidates), grown by
   steps as the set outgrows it. The modules that keep arrays over the candidates (the driver, the
   back end, the metrics) size theirs to it: one capacity for the set, not one spare room of each
   module's own steps (doc/theory.md (T252)). mo_contact_room: the candidates to make room for when
   n must fit: that capacity when it holds n, else n and a quarter more (C NULL: the latter). */
int mo_contact_capacity(const mo_contact *C);
size_t mo_contact_room(const mo_contact *C, size_t n);
int mo_contact_npairs(const mo_contact *C);
const mo_contact_pair *mo_contact_pair_get(const mo_contact *C, int k);
const mo_candidate *mo_contact_candidate(const mo_contact *C, int alpha);
const mo_cpoint *mo_contact_point(const mo_contact *C, int k);
/* Candidate a and its representative point for any candidate: pointers into the set, or, for a
   compact record of the granular path (doc/theory.md §12.9), the candidate and the point the
   detection would have written, filled into buf (then valid until buf is reused). Consumers that
   read detected candidates use these; mo_contact_candidate and mo_contact_point hold only the
   points the set stores (not the compact records). */
const mo_candidate *mo_contact_cand_get(const mo_contact *C, int a, mo_candidate *buf);
const mo_cpoint *mo_contact_cand_point(const mo_contact *C, int a, mo_cpoint *buf);
/* Bytes the contact set holds (capacities): its per-candidate arrays, points, candidates, H
   (*per_candidate, when not NULL: those that grow with the candidates), and the detection's
   per-body arrays with the broad phase. */
size_t mo_contact_bytes(const mo_contact *C, size_t *per_candidate);
/* The slave and master bodies of candidate a's representative point (master -1: none). */
void mo_contact_cand_bodies(const mo_contact *C, int a, int *sb, int *mb);
/* 1 when the detected candidates are compact records (no points, H on demand). */
int mo_contact_is_compact(const mo_contact *C);
/* 1 when the set is distributed over the MPI ranks (contact.distributed_set, doc/scaling.md §4):
   each rank's candidates 0 .. nc-1 are those it detected, no other rank holds them, and their
   union over the ranks is the set one process finds; the bodies' state is whole on every rank
   until the second build of the detection's list, then each rank's own (mo_contact_held).
   What reads the set (metrics, outputs) joins the ranks' parts by collectives every rank calls at
   the same points. The same on every rank; fixed from the set's first detection on. */
int mo_contact_distributed(const mo_contact *C);
/* With the distributed set on a scene of rigid bodies and obstacles, from the second build of the
   detection's list each rank keeps current only the bodies it holds (doc/theory.md §13.18): 1 then,
   with per body its holders' mask (bit r: rank r; valid for the bodies this rank holds), the held
   bodies ascending, and per body whether this rank counts it in sums over the bodies (each body on
   exactly one rank). 0 while every rank holds every body (the pointers left alone). */
int mo_contact_held(const mo_contact *C, const unsigned long long **hold, const int **hlist, int *nhlist,
                    const unsigned char **count);
/* With mo_contact_held: per rank q, the bodies this rank holds that q holds too, b[off[q] ..
   off[q + 1]) ascending (none for this rank), the same list on q. 0 otherwise. */
int mo_contact_held_shared(const mo_contact *C, const int **off, const int **b);
/* Every body's state made current on every rank (one gather of each body from the rank that counts
   it; a no-op unless mo_contact_held): before the outputs that read every body. Collective. */
int mo_contact_state_join(mo_contact *C, struct mo_state *s, mo_ctx *ctx);
/* H of the last geometry at its state s, built now when the granular path left it out: for
   back ends and outputs that need H (a no-op otherwise). */
int mo_contact_H_ensure(mo_contact *C, const mo_state *s, mo_ctx *ctx);
/* y = H^T x over full dofs for the columns of candidates a0 .. a1-1 (d each), with H the operator
   of the last geometry at its state s, whether H is stored or not: y_j = sum_i H_ij x_i (start
   NULL), or start_j + sum_i H_ij x_i accumulated from start_j. The same sums, in the same order,
   as mo_csc_gatxpy on mo_contact_H_full. */
void mo_contact_Htx(const mo_contact *C, const mo_state *s, const double *x, int a0, int a1, const double *start,
                    double *y);
/* The same for candidate a alone, into y[0 .. d-1] (start: its d values, or NULL). */
void mo_contact_Htx1(const mo_contact *C, const mo_state *s, const double *x, int a, const double *start, double *y);
/* Coefficients and points of candidate alpha: cand->np entries from cand->first. */
const int *mo_contact_cand_points(const mo_contact *C);
const double *mo_contact_cand_coefs(const mo_contact *C);

/* Geometry at the displacement u (full dofs) and time t: pairing (closest point onto the
   master; frozen when `repair` is 0), frames and gaps of every point, then the candidates'
   gaps. H changes only when the pairing or the frames change (planes in small strain: never);
   mo_contact_h_version tells. */
int mo_contact_geometry(mo_contact *C, const struct mo_state *s, double t, int repair, mo_ctx *ctx);
long mo_contact_h_version(const mo_contact *C);
/* Changes whenever the set of candidates changes (the detection between rigid bodies at every
   step): the arrays sized by the candidates must follow (mo_contact_ncandidates). */
long mo_contact_set_version(const mo_contact *C);
/* The candidates of the last geometry that are detected ones (rigid shapes): nc_static .. nc-1;
   0 .. nc_static-1 are the mesh points fixed at build. */
int mo_contact_nstatic(const mo_contact *C);
/* Identity of candidate a (5 ints: pair, slave body, master body, slave feature, master
   feature; static candidates (-1, a, 0, 0, 0)), to match candidates from one set to the next. */
const int *mo_contact_key(const mo_contact *C, int a);
#define MO_KEY 5
/* Candidates found by key from one set to the next: a hash of n keys (MO_KEY ints each, kept by
   the caller while the map is used); find gives a key's position among them, or -1. build
   reuses the map's table. O(1) per key on average. */
typedef struct mo_keymap {
  const int *keys;
  int *tab, mask;
} mo_keymap;
int mo_keymap_build(mo_keymap *M, const int *keys, int n, mo_ctx *ctx);
int mo_keymap_find(const mo_keymap *M, const int *k);
void mo_keymap_free(mo_keymap *M);
/* The alert distance of the detection (0 without pairs of rigid shapes). */
double mo_contact_alert(const mo_contact *C);
/* The broad phase of the detection between rigid shapes: how many times its pair list was built
   and how many pairs it holds (doc/theory.md (T110)); 0 when the scene has no such pair. */
int mo_contact_broad_stats(const mo_contact *C, long *builds, long *pairs);
/* When the list is kept by blocks (contact.verlet, doc/theory.md §12.26): 1, with the blocks made
   again between the whole builds over the run and the blocks now; else 0. */
int mo_contact_broad_blocks(const mo_contact *C, long *made, long *nblock);
/* Candidate a's law and restitution coefficient (those of its pair). */
mo_contact_law mo_contact_law_of(const mo_contact *C, int a);
double mo_contact_restitution_of(const mo_contact *C, int a);
/* Candidate gaps (nc) and frames (nc * dim * dim, rows n, t, s) after mo_contact_geometry. The
   granular path (compact records, doc/theory.md §12.9) stores each candidate's normal alone
   (T225): mo_contact_frames is then NULL and mo_contact_normals the nc * dim normals (NULL off
   that path); mo_contact_frame_of gives candidate a's frame on either path (formed in buf, or
   the stored one). */
const double *mo_contact_gaps(const mo_contact *C);
const double *mo_contact_frames(const mo_contact *C);
const double *mo_contact_normals(const mo_contact *C);
const double *mo_contact_frame_of(const mo_contact *C, int a, double *buf);
/* Frame rows n, t(, s) from the unit normal n (doc/theory.md §4.1, (T225)): 2D t = (n_y, -n_x),
   so that (t, n) is right-handed like (x, y); 3D t from the axis least aligned with n, s = n x t.
   The one rule of the frames: a frame formed again from its normal is the same doubles. */
static inline void mo_frame_of_normal(int dim, const double *n, double *F)
{
  if (dim == 1) {
    F[0] = n[0];
  } else if (dim == 2) {
    F[0] = n[0]; F[1] = n[1];
    F[2] = n[1]; F[3] = -n[0];
  } else {
    double e[3] = {0, 0, 0}, t[3], len, d;
    int k = 0, i;
    if (fabs(n[1]) < fabs(n[k]) - 1e-12) k = 1;
    if (fabs(n[2]) < fabs(n[k]) - 1e-12) k = 2;
    e[k] = 1;
    d = e[0] * n[0] + e[1] * n[1] + e[2] * n[2];
    for (i = 0; i < 3; i++) t[i] = e[i] - d * n[i];
    len = sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
    for (i = 0; i < 3; i++) t[i] /= len;
    for (i = 0; i < 3; i++) F[i] = n[i];
    for (i = 0; i < 3; i++) F[3 + i] = t[i];
    F[6] = n[1] * t[2] - n[2] * t[1];
    F[7] = n[2] * t[0] - n[0] * t[2];
    F[8] = n[0] * t[1] - n[1] * t[0];
  }
}
/* H over free dofs (nfree x dim*nc): U = H^T v + U0, R = H r. */
const mo_csc *mo_contact_H(const mo_contact *C);
/* H over full dofs (ndof x dim*nc), including prescribed rows (for tests and reactions). */
const mo_csc *mo_contact_H_full(const mo_contact *C);
/* Local velocity of the obstacles: U0 (dim*nc), from moving planes; NULL when no obstacle of the
   scene moves (U0 = 0 for every candidate). */
const double *mo_contact_U0(const mo_contact *C);
/* The P* matrix of a pair (ncand_pair x ncand_pair over its candidates, row-major), built for
   every pair so that concentrated and weighted reactions can be compared (J88 §4.4). */
int mo_contact_pair_P(const mo_contact *C, int pair, const double **P, int *n, const int **cands);
/* Build P* for a row of candidate nodes on uniform linear edges (tests: Jean's P*). */

/* --- the Delassus operator ------------------------------------------------------------------
   W = c H^T What^-1 H (c = 1 for the theta-scheme and quasi-static steps, beta h^2 for
   Newmark), stored by d x d blocks (dense when every block is present), with the columns
   C = What^-1 H kept when they fit in memory (then v+ = v_free + C r costs a dense product). */
typedef struct mo_delassus mo_delassus;

int mo_delassus_create(mo_delassus **out, mo_ctx *ctx);
void mo_delassus_free(mo_delassus *D);
/* (Re)build from H (nfree x m) and the factored What when H's version or the factorization
   changed; a no-op otherwise. Returns 1 in *rebuilt when it did work. */
int mo_delassus_update(mo_delassus *D, const mo_csc *H, long hversion, const mo_what_inverse *Wi,
                       double c, int dim, int *rebuilt, mo_ctx *ctx);
int mo_delassus_m(const mo_delassus *D);
int mo_delassus_dim(const mo_delassus *D);
/* Block (alpha, beta), d x d row-major, or NULL when structurally zero. */
const double *mo_delassus_block(const mo_delassus *D, int alpha, int beta);
/* Row alpha: its nonzero blocks (columns beta[k] in increasing order, values blocks + k*d*d). */
int mo_delassus_row(const mo_delassus *D, int alpha, const int **beta, const double **blocks);
/* Row alpha's normal entries W_alpha beta,nn alone, contiguous (wn[k] for beta[k]; one double a
   block, doc/theory.md (T164)), for the passes of frictionless solves; *wn NULL when W keeps none. */
int mo_delassus_row_normal(const mo_delassus *D, int alpha, const int **beta, const double **wn);
/* y = W x (+ beta y); the normal columns of the blocks alone when x has no tangential component. */
void mo_delassus_mult(const mo_delassus *D, const double *x, double beta, double *y);
/* Dense copy (m x m row-major) for tests, FCLIB and small problems. */
int mo_delassus_dense(const mo_delassus *D, double **W, mo_ctx *ctx);
/* dx = What^-1 H r over free dofs: from the stored columns, or by one solve. */
int mo_delassus_apply_Cinv(mo_delassus *D, const mo_csc *H, const mo_what_inverse *Wi, const double *r,
                           double *dx, mo_ctx *ctx);
/* Set W to a given matrix (m x m column-compressed, m = dim nc): FCLIB local problems, tests,
   benchmarks. Blocks that are entirely zero are not stored; no columns What^-1 H are kept (the
   operator has no H), so mo_delassus_apply_Cinv does not apply to it. */
int mo_delassus_set_matrix(mo_delassus *D, const mo_csc *W, int dim, mo_ctx *ctx);
/* Number of stored blocks, and whether the columns What^-1 H are kept. */
long mo_delassus_nblocks(const mo_delassus *D);
/* The number of times W was built (mo_delassus_update that rebuilt, mo_delassus_set_matrix):
   unchanged means the blocks are the same, so a back end may keep what it derived from them. */
long mo_delassus_version(const mo_delassus *D);
int mo_delassus_has_columns(const mo_delassus *D);
/* 1 when the last build took the nodal part from the factor's trailing block (the contact dofs
   ordered last, doc/theory.md (T151)) instead of one solve per column. */
int mo_delassus_from_schur(const mo_delassus *D);
/* The free nodal dofs of a contact set for the factorization to order last (doc/theory.md
   (T150)): rows of H and every dof of the slave nodes of the candidates fixed at build, the nodes
   of deformable masters' facet sets; none (n = 0) when a detected pair touches a deformable
   body. *dofs is allocated (free with mo_free); *reserve: the bytes W will take (dense),
   for the memory check of the factorization (mo_stepper_create_ordered). */
int mo_delassus_contact_dofs(const mo_contact *C, int **dofs, int *n, double *reserve, mo_ctx *ctx);
/* The stepper of a scene with contact C (NULL: none): with order_last, the contact dofs ordered
   last in its factorization (mo_delassus_contact_dofs, mo_stepper_create_ordered); else
   mo_stepper_create. */
int mo_stepper_create_contact(const mo_scene *sc, const mo_contact *C, int order_last, mo_stepper **S, mo_ctx *ctx);

/* --- accuracy measures common to every back end ---------------------------------------------- */

/* Natural-map residual of the discrete Signorini-Coulomb problem U = W r + q, as Siconos
   (Debian's 4.4) defines it: sqrt(sum_alpha |r - P_K(r - (U + mu |U_t| e_n))|^2) divided by
   max(|q|, |r|, |U|) (not divided when all three vanish). Local dimension d = 1 (frictionless,
   normal only), 2 or 3. */
double mo_fc_natural_map(int d, int nc, const double *mu, const double *r, const double *U,
                         double qnorm);
/* The same over the n candidates idx[0..n-1] (idx NULL: 0..n-1), with the local velocity of
   candidate a scaled by scale[a] when scale is not NULL (nscd's (T42)); qnorm is |q| over them
   (scaled likewise). Back ends that stop on the core's measure call this one. */
double mo_fc_natural_map_subset(int d, int n, const int *idx, const double *mu, const double *scale,
                                const double *r, const double *U, double qnorm);
/* The sums of mo_fc_natural_map_subset_pairs without its quotient: out[0] the squared natural map,
   out[1] |r|^2, out[2] |U|^2 over the listed candidates, to be added over MPI ranks (each its own
   candidates) and joined by mo_fc_natural_map_join. */
void mo_fc_natural_map_parts(int d, int n, const int *idx, const double *mu, const int *key, const double *pmu,
                             const double *scale, const double *r, const double *U, double *out);
double mo_fc_natural_map_join(const double *parts, double qnorm);
/* The same with contact a's coefficient pmu[key[a MO_KEY]] (its pair's) where mu is NULL (the
   granular path, doc/theory.md (T189)); both NULL: 0. */
double mo_fc_natural_map_subset_pairs(int d, int n, const int *idx, const double *mu, const int *key, const double *pmu,
                                      const double *scale, const double *r, const double *U, double qnorm);
/* The unit (one contact) term of the residual: |r - P_K(r - (U + mu |U_t| e_n))|^2. */
double mo_fc_natural_map_unit(int d, double mu, const double *r, const double *U);
/* Projection onto the Coulomb cone |r_t| <= mu r_n (in place, dimension d). */
void mo_fc_project_cone(int d, double mu, double *r);
/* Jean's norms of the change between two iterates (doc/theory.md §5.3):
   Quad = sqrt(sum |dU_a|^2 |r_a|^2) / sum (W_aa r_a).r_a,
   Maxm = max |dU_a| |r_a| / (sum (W_aa r_a).r_a / nactive). dU = W_aa dr. */
void mo_fc_jean_norms(const mo_delassus *W, int nc, const double *r_old, const double *r_new,
                      double *quad, double *maxm);

/* --- the seam: contact back ends -------------------------------------------------------------- */

/* What the Signorini condition controls, for back ends on the local problem (doc/theory.md §5):
   POSITION: g_k+1 = g_k + h (theta U+_n + (1 - theta) U-_n) >= 0 _|_ r_n >= 0 (J88 (3.2)_1);
   VELOCITY: U+_n >= 0 _|_ r_n >= 0 on the index set of candidates predicted closed. */
typedef enum { MO_SIGNORINI_POSITION = 0, MO_SIGNORINI_VELOCITY } mo_signorini;

/* The granular contacts of a step (doc/theory.md §12.9), for a back end with MO_NEEDS_GRAINS:
   contact a joins slave body key[a MO_KEY + 1] and master body key[a MO_KEY + 2] at the point
   x[a D .. a D + D - 1], in the frame of normal n[a D .. a D + D - 1] (rows n, t, s, formed by
   mo_frame_of_normal, (T225); P->frame is NULL on this path). The rows of H of a side on a rigid
   body b are the side's sign (+1 slave, -1 master) times the frame's rows on b's translations and
   the moments (x - centre_b) x F_i on its rotations (T68), with b's free velocities from vel[b] in
   x_free (-1: a plane, or a body held fixed, whose motion is in P->b already). */
typedef struct mo_grains {
  int D;                     /* space dimension (2 or 3); 1 + D (2D) or 2 D (3D) dofs per body */
  const int *key;            /* MO_KEY per contact (pair, slave, master, features) */
  const double *x;           /* D per contact: the contact point */
  const double *n;           /* D per contact: the unit normal (master to slave), its frame's first row */
  const int *vel;            /* per body of the scene: its first free dof, or -1 */
  const double *centre;      /* D per body: its centre at the step's start (moving bodies) */
  const double *pmu;         /* per pair its friction coefficient: contact a's is pmu[key[a MO_KEY]]
                                (the problem's mu is NULL on this path, doc/theory.md (T189)) */
  const int *cown;           /* over MPI ranks, when the detection is split: per candidate the rank that
                                detected it, its point's box (doc/theory.md (T341)), the same on every
                                rank; the sweep's parts then. NULL: none */
  int dist;                  /* the set is distributed (mo_contact_distributed): every contact is this
                                rank's, no rank holds another's */
  /* with the bodies' state per rank (mo_contact_held; NULL and 0 otherwise): per body the ranks that
     hold it, and the bodies this rank holds, ascending; the others' velocities are not current here */
  const unsigned long long *hold;
  const int *hlist;
  int nhlist;
  const int *sh_off, *sh_b;  /* per rank q the held bodies q holds too (mo_contact_held_shared) */
} mo_grains;

/* The contact problem of one step, built by the core and handed to a back end. Everything is
   owned by the core and read-only for the back end. */
typedef struct mo_contact_problem {
  int dim;                   /* local dimension d: 1 (1D), 2 or 3; normal first */
  int nc, m;                 /* candidates; m = d nc */
  const double *mu;          /* nc friction coefficients; NULL on the granular path (grains->pmu) */
  const double *g;           /* nc gaps at the start of the step */
  const double *Uprev;       /* m local velocities at the start of the step */
  const double *w;           /* nc candidate measures (NULL on the granular path: every one is 1) */
  const double *frame;       /* nc d x d frames; NULL on the granular path (grains->n, (T225)) */
  const mo_contact *contact; /* candidates, points, pairs */
  /* local relation U' = W r + b: U' is the local velocity (theta) or displacement increment
     (newmark, quasistatic), plus in its normal component the Signorini offset of the chosen
     formulation (g_k / (h theta) + ... for position-level theta, g_k for the others), so that
     the law is U'_n >= 0 _|_ r_n >= 0 with Coulomb on U'_t; W is NULL when the back end did not
     ask for it */
  const mo_delassus *W;
  const double *b;           /* m: the affine term q of U' = W r + q, Signorini offsets included; on
                                the granular path (grains) the array of the solution's U itself: a
                                back end reads b before it writes U (doc/theory.md (T240)) */
  const unsigned char *active; /* nc: candidates that may close this step (0: keep r = 0) */
  const int *act;            /* on the granular path (grains): the nact candidates of active, in
                                increasing order, which the back end reads instead of listing them
                                again (doc/theory.md (T250)); NULL otherwise */
  int nact;
  mo_scheme scheme;
  double h, theta, theta_f, beta, gamma;
  mo_signorini signorini;
  /* the global system, for back ends that work on it (KKT, Schur) */
  int nfree;
  const mo_csc *H;           /* nfree x m */
  const mo_csc *What;        /* nfree x nfree iteration matrix */
  const mo_what_inverse *Wi; /* What^-1 by blocks (the nodal factorization, the rigid blocks) */
  const double *xfree;       /* nfree: the unconstrained step (v_free, a_free or u_free) */
  const mo_grains *grains;   /* the granular path (MO_NEEDS_GRAINS; H NULL), else NULL */
  long cset;                 /* mo_contact_set_version: a back end re-reads what it derived from
                                the candidates when it changes (init is called again) */
  double du_dx;              /* du = c dx over the step */
  long step;                 /* step being computed (1-based) */
  double t;                  /* time at the start of the step */
  int u_measured;            /* 1: the core computes U = W r + q after the solve (its measure), so
                                that a back end on W may return U exact only where the law reads
                                it (the normal components of frictionless contacts): a pass over W
                                saved (doc/theory.md (T156)) */
} mo_contact_problem;

/* What a back end returns. r holds the previous step's reactions on entry (warm start). */
typedef struct mo_contact_vars {
  double *r;                 /* m: impulses (theta) or forces (newmark, quasistatic) */
  double *U;                 /* m: local velocities (increments) after the step */
  int *status;               /* nc: MO_CS_* */
  double *dx;                /* nfree: correction of the step's unknown, when dx_set */
  int dx_set;                /* 1 when the back end wrote dx itself (KKT path) */
} mo_contact_vars;

/* Converged (> 0) and diverged (< 0) reasons, apart from error codes. */
enum {
  MO_CR_CONVERGED = 1,
  MO_CR_NOCONTACT = 2,       /* no candidate closed: nothing to solve */
  MO_CR_MAXITER = -1,
  MO_CR_CYCLING = -2,
  MO_CR_BREAKDOWN = -3,      /* a local solver or a factorization broke down */
  MO_CR_NAN = -4
};
const char *mo_contact_reason_name(int reason);

typedef struct mo_contact_report {
  int iterations;            /* sweeps (nscd), Newton iterations (levelset), ... */
  int loops[4];              /* geometric, friction threshold, level-set, Newton (levelset) */
  double residual;           /* natural-map residual (computed by the core after the solve) */
  double quad, maxm;         /* Jean's norms of the last change (iterative back ends); -1 when the
                                back end did not measure them (nscd's granular path under the
                                residual rules, doc/theory.md §12.11) */
  int nopen, nstick, nslide; /* status counts (counted by the core) */
  int reason;                /* MO_CR_* */
  char message[256];         /* what went wrong, with the candidates involved */
  /* redundancy (doc/theory.md (T84)), when the back end measured it (else constraints = -1):
     the unknowns of the closed set's problem, how many of them the others determine (its
     rank deficiency: the reactions are then not unique), its reciprocal condition */
  int constraints, redundant;
  double rcond;
  int min_norm;              /* the reactions reported are the minimum-norm ones */
  int factorizations;        /* matrices the back end factored in the solve (levelset: Newton */
  int factor_reuses;         /*   matrices), and solves on factors kept from an earlier one */
  int sweeps;                /* local-solver sweeps of a smoother inside a Newton method (levelset's
                                hybrid globalization, doc/theory.md (T144)) */
} mo_contact_report;

/* Typed options of a back end: the case keys contact.<name>.<option> and --set. */
typedef enum { MO_OPT_INT = 0, MO_OPT_DOUBLE, MO_OPT_BOOL, MO_OPT_ENUM } mo_option_type;
typedef struct {
  const char *name;
  mo_option_type type;
  size_t offset;             /* offset in the back end's parameter struct */
  const char *enums;         /* "a|b|c": stored as the index (int) */
  double lo, hi;             /* closed range (NaN: unbounded) */
  const char *deflt;         /* printed default */
  const char *doc;
} mo_option_spec;

/* Capability flags: what the core must build for the back end. */
enum {
  MO_NEEDS_DELASSUS = 1,     /* W = H^T What^-1 H */
  MO_NEEDS_GLOBAL = 2,       /* H, What, its factor and x_free (KKT or Schur paths) */
  MO_NEEDS_BODIES = 4,       /* with MO_NEEDS_DELASSUS: when every candidate joins rigid bodies and
                                obstacles only, the back end works from H, the blocks of What^-1
                                and x_free instead of W, which the core then does not build (P->W
                                NULL): the sweep on body velocities (doc/theory.md §8.6) */
  MO_NEEDS_GRAINS = 8        /* with MO_NEEDS_BODIES: when every candidate is a detected contact of
                                rigid shapes and obstacles, the back end reads their compact
                                records (P->grains) instead of H, which the core then does not
                                build (P->H NULL; doc/theory.md §12.9) */
};

typedef struct mo_contact_solver_type {
  const char *name;          /* the value of contact.solver */
  const char *summary;       /* one line for `moreau list-solvers` */
  size_t state_size;         /* private state, allocated (zeroed) and freed by the core */
  size_t params_size;        /* typed parameter struct, filled by defaults then options */
  unsigned needs;            /* MO_NEEDS_* */
  unsigned schemes;          /* bit (1 << mo_scheme) of every time scheme it supports */
  const mo_option_spec *options;
  int noptions;
  void (*defaults)(void *params);
  /* Prepare the state for a scene (called once, after the first geometry). May read P's
     sizes and the contact set; must not keep pointers to P's arrays across calls. */
  int (*init)(void *state, const void *params, const mo_contact_problem *P, mo_ctx *ctx);
  /* Solve the step's contact problem. Must write r, U and status (and dx when it sets dx_set);
     a non-converged solve is not an error: it sets rep->reason < 0 with a message, and the
     core decides. Returns an error code only for real errors (memory, NaN it cannot explain). */
  int (*solve)(void *state, const mo_contact_problem *P, mo_contact_vars *x,
               mo_contact_report *rep, mo_ctx *ctx);
  void (*free)(void *state);
  /* Optional: the time scheme this back end runs, set from its parameters before the stepper is
     built (the newmark baseline runs Newmark with its own beta, gamma whatever time.scheme says).
     NULL: the case's time settings. */
  int (*time_scheme)(const void *params, mo_time_settings *T, mo_ctx *ctx);
  /* Optional: the contact set changed since init (detected contacts between rigid bodies change
     it at most steps): bring the state to P's set, keeping what memory it can. NULL: the core
     calls free, then init. */
  int (*reinit)(void *state, const mo_contact_problem *P, mo_ctx *ctx);
} mo_contact_solver_type;

/* The registry: an explicit table in the core (src/registry.c). */
const mo_contact_solver_type *mo_contact_solver_find(const char *name);
int mo_contact_solver_count(void);
const mo_contact_solver_type *mo_contact_solver_at(int i);
/* Set one option of a parameter struct from its string value ("--set contact.nscd.tol=1e-8"). */
int mo_option_set(const mo_option_spec *opts, int nopt, void *params, const char *key,
                  const char *val, mo_ctx *ctx);

/* --- a back end on a given local problem (FCLIB files, benchmarks, tests) --------------------- */

typedef struct mo_local_solver mo_local_solver;

/* A back end that needs only the Delassus operator (MO_NEEDS_DELASSUS, not MO_NEEDS_GLOBAL), set
   up on U = W r + q, mu (d, nc; W from mo_delassus_set_matrix). W, q and mu are borrowed: they
   must outlive the solver. Every candidate is active. */
int mo_local_solver_create(const mo_contact_solver_type *T, const mo_delassus *W, const double *q,
                           const double *mu, mo_local_solver **out, mo_ctx *ctx);
/* Set one of the back end's options (as contact.<name>.<key> would). */
int mo_local_solver_set(mo_local_solver *L, const char *key, const char *val, mo_ctx *ctx);
/* Solve from the reactions in r (m values; the back end's warm start), writing r, U = W r + q and
   the statuses (nc, may be NULL). rep receives the back end's report with the natural-map
   residual (T10) computed here as the core computes it. */
int mo_local_solver_solve(mo_local_solver *L, double *r, double *U, int *status,
                          mo_contact_report *rep, mo_ctx *ctx);
/* Whether mo_local_solver_solve recomputes U = W r + q and the residual (T10) after the back end
   (default 1). Benchmarks timing the back end alone turn it off, then verify one solve; with it
   off, U and rep->residual are what the back end reported (residual NaN if it reports none). */
void mo_local_solver_verify(mo_local_solver *L, int on);
void mo_local_solver_free(mo_local_solver *L);

/* --- the contact step ---------------------------------------------------------------------- */

typedef struct mo_contact_driver mo_contact_driver;
/* The distributed set: every rank's candidates bearing (r_n > 0) at the end of the last step. */
long mo_contact_driver_bearing_all(const mo_contact_driver *D);

/* Let the case's back end choose its time scheme (before mo_stepper_create). Notes the change
   in the run's log when it changes the scheme. */
int mo_contact_time_scheme(mo_scene *sc, const mo_contact *C, mo_ctx *ctx);
/* Set up the contact step of a run: the back end named by contact.solver (validated against
   the registry and the scheme), its options from the case, the Delassus operator if needed. */
int mo_contact_driver_create(const mo_scene *sc, mo_contact *C, mo_stepper *S,
                             mo_contact_driver **out, mo_ctx *ctx);
void mo_contact_driver_free(mo_contact_driver *D);
/* One step with contact: predict, geometry, local problem, back-end solve, correction, finish.
   A back end that does not converge makes this return MO_ENOCONV with a diagnosis in ctx,
   unless contact.on_failure = "continue". */
int mo_contact_step(mo_contact_driver *D, mo_state *s, mo_ctx *ctx);
const mo_contact_report *mo_contact_last_report(const mo_contact_driver *D);
/* Redundancy of the closed contacts (doc/theory.md (T84)) as the back end measured it: the last
   solve's unknowns, redundant ones and reciprocal condition, the largest redundancy and the
   number of steps that had some, the smallest rcond, whether the last solve reported the
   minimum-norm reactions. Returns 0 when no solve measured it. */
int mo_contact_driver_redundancy(const mo_contact_driver *D, int *constraints, int *redundant, int *redundant_max,
                                 int *redundant_steps, double *rcond, double *rcond_min, int *min_norm);
/* The largest relative global equilibrium residual |f + H r - K u| of the run's quasi-static
   linear steps (doc/theory.md (T82)); NaN for other scenes. */
double mo_contact_driver_equilibrium(const mo_contact_driver *D);
/* The step of the last solve (impulses are over it): the case's h, or a cut step's. */
double mo_contact_driver_dt(const mo_contact_driver *D);
/* Snapshots of the driver's state between steps, for step cutting: save before a step, restore
   (with the state the step started from: the geometry is recomputed at its displacements) to
   take it again. */
typedef struct mo_contact_snapshot mo_contact_snapshot;
int mo_contact_snapshot_create(const mo_contact_driver *D, mo_contact_snapshot **out, mo_ctx *ctx);
void mo_contact_snapshot_free(mo_contact_snapshot *X);
int mo_contact_snapshot_save(const mo_contact_driver *D, mo_contact_snapshot *X, mo_ctx *ctx);
int mo_contact_snapshot_restore(mo_contact_driver *D, const mo_contact_snapshot *X, const mo_state *s,
                                mo_ctx *ctx);
const double *mo_contact_reactions(const mo_contact_driver *D);  /* m, last step */
/* The last step's resultants, taken before the end-of-step geometry (whose candidates the
   reactions above follow): per pair, the force (world frame, 3 values; impulse / h under the
   theta-scheme) its master exerts on its slaves; the sum of the normal forces. */
const double *mo_contact_pair_forces(const mo_contact_driver *D);
double mo_contact_normal_force(const mo_contact_driver *D);
const double *mo_contact_local_velocity(const mo_contact_driver *D);
/* U- = H^T v + U0 of the detected candidates (from mo_contact_nstatic) at the last geometry, for the
   step that starts at state s: the driver's, when they are of s (its set and velocities), else
   NULL (the values of mesh candidates are not of this form: the caller computes those). */
const double *mo_contact_driver_uprev(const mo_contact_driver *D, const mo_state *s);
const int *mo_contact_statuses(const mo_contact_driver *D);
const mo_contact_solver_type *mo_contact_driver_type(const mo_contact_driver *D);
const mo_delassus *mo_contact_driver_delassus(const mo_contact_driver *D);
/* The position correction of velocity-level theta steps (contact.position_correction, doc/
   theory.md (T95)): whether it is on, the steps it corrected, the largest penetration it removed,
   the largest left after it, the most projected Gauss-Seidel sweeps of a step, the steps whose
   sweeps ran out, the energy the shifts took from the kinetic energy (T96), the energy they
   added that it could not pay (or all of it with "shift"), and the linear momentum the
   compensation took from each body (momentum: 3 per body of the scene). *on: 0 none, 1 project,
   2 shift. */
void mo_contact_driver_correction(const mo_contact_driver *D, int *on, long *steps, double *max_removed,
                                  double *max_left, long *sweeps_max, long *unconverged, double *energy_paid,
                                  double *energy_added, double *momentum);
/* Totals over the run: steps with contact, back-end iterations, rebuilds of W. */
void mo_contact_driver_totals(const mo_contact_driver *D, long *steps, long *iterations,
                              long *max_iterations, long *w_builds, double *max_residual);
/* Build the Delassus operator at every step even where the back end works without it (every
   contact between rigid bodies, MO_NEEDS_BODIES): FCLIB dumps of the steps' problems. */
void mo_contact_driver_keep_delassus(mo_contact_driver *D);
/* Totals over the run of the back end's factorizations and of its solves on kept factors. */
void mo_contact_driver_factor_totals(const mo_contact_driver *D, long *factorizations, long *reuses);
/* Smoother sweeps the back end ran inside its Newton method over the run (levelset's hybrid
   globalization, doc/theory.md (T144)). */
long mo_contact_driver_sweeps(const mo_contact_driver *D);
/* Bytes the driver holds for the candidates (its per-candidate arrays and key map, at their
   capacity) and for the dofs (*per_dof, when not NULL). */
size_t mo_contact_driver_bytes(const mo_contact_driver *D, size_t *per_dof);
/* Solves that did not converge over the run (non-zero only with contact.on_failure = "continue"). */
long mo_contact_driver_failures(const mo_contact_driver *D);
/* Candidates added to velocity-level index sets after a solve found them ending inside (§5). */
long mo_contact_driver_index_added(const mo_contact_driver *D);
/* The driver's last remap of its arrays, when it went from set version `from` to `to`
   (mo_contact_set_version): each candidate's place in the old set, -1 for a new one; NULL
   otherwise. Within a step taken again (a snapshot restored, then the step), the remaps are
   composed from the set of the last step completed, so that whoever follows the candidate set
   after each completed step (the metrics) may read it instead of keeping keys (doc/theory.md
   (T185)). */
const int *mo_contact_driver_remap(const mo_contact_driver *D, long from, long to);
/* The most candidates a step of the run had (the peak the memory figures per candidate divide by). */
int mo_contact_driver_candidates_max(const mo_contact_driver *D);
/* The last step's local problem over every candidate (W dense, q, mu), the inactive ones
   included: what the step solved only when every candidate was in its index set (quasi-static
   and position-level steps with every candidate active). Tests. */
int mo_contact_driver_local_problem(const mo_contact_driver *D, double **W, double **q,
                                    double **mu, int *nc, int *d, mo_ctx *ctx);

/* The problem the last contact solve of a step solved (doc/theory.md §4.6, (T80)): the
   candidates of its index set idx[0..n-1] (increasing, of ncand candidates), W restricted to
   them (n d x n d, compressed columns), q and mu restricted to them, and that solve's solution
   r and U = W r + q (the core's measure); the other candidates were out of the problem (r = 0)
   and are not in it. desc: what it is, in words (the law of the normal part, units, the
   candidates kept, the solve's outcome). Kept at every solve after
   mo_contact_driver_keep_delassus; MO_EUNSUPPORTED when the last solve had no W or no
   candidate in its index set. */
typedef struct {
  int d, n, ncand;
  int *idx;
  mo_csc *W;
  double *q, *mu, *r, *U;
  double residual;           /* the core's natural-map residual (T10) of that solve */
  int reason;                /* MO_CR_* of that solve */
  char desc[1400];
} mo_solved_problem;
int mo_contact_driver_solved_problem(const mo_contact_driver *D, mo_solved_problem *P, mo_ctx *ctx);
void mo_solved_problem_release(mo_solved_problem *P);

/* Per-candidate results of the last step: contact.csv (pair, candidate, node, position,
   displacement D1.., gap, local U and reactions as forces, both normal first (UN UT US, RN RT
   RS), status, measure, representation, the other representation's reactions (RN_other ...:
   P^-1 images of concentrated reactions, P images of weighted ones), lambda, slave, master). */
int mo_contact_write_csv(const char *path, const mo_scene *sc, const mo_contact *C,
                         const mo_contact_driver *D, const mo_state *s, mo_ctx *ctx);
/* contact_history.csv: contact.csv's rows (without the other representation, whose P^-1
   images cost a factorization per pair) for every step written, each prefixed by step and t;
   every candidate, or (closed_only) those with a status other than open or a reaction. Streamed
   and flushed step by step like history.csv: O(candidates) per step. */
typedef struct mo_contact_history mo_contact_history;
int mo_contact_history_open(const char *path, const mo_scene *sc, const mo_contact *C, int closed_only,
                            mo_contact_history **out, mo_ctx *ctx);
int mo_contact_history_write(mo_contact_history *H, const mo_scene *sc, const mo_contact *C,
                             const mo_contact_driver *D, const mo_state *s, mo_ctx *ctx);
int mo_contact_history_close(mo_contact_history *H, mo_ctx *ctx);
/* The same in Jean's layout (J88 Figs. 3-4), with the resultants and the sweeps: RT before RN,
   as his tables print them. */
void mo_contact_print_table(FILE *f, const mo_scene *sc, const mo_contact *C,
                            const mo_contact_driver *D, const mo_state *s, mo_ctx *ctx);
/* The friction semi-multiplier |Lambda| = |r_t| / (mu r_n) of a reaction r (d components,
   normal first; BDZ07 Fig. 10, doc/theory.md (T66)): below 1 sticking, 1 sliding; 0 when
   open or frictionless. contact.csv's lambda and the probes' lam. */
double mo_contact_friction_ratio(int d, double mu, const double *r);

/* --- FCLIB local problems (doc/theory.md §4.6) ----------------------------------------------- */

/* 1 when this build reads and writes FCLIB files. */
int mo_fclib_available(void);
/* Write U = W r + q, mu (W dense, m x m with m = d nc, d = 2 or 3) as an FCLIB local problem;
   a solution (r, U) is written with it when r is not NULL. */
int mo_fclib_write(const char *path, int d, int nc, const double *W, const double *q,
                   const double *mu, const double *r, const double *U, const char *title,
                   mo_ctx *ctx);
/* The same with W compressed by columns (m x m) and the file's info: title, description
   (what the problem is) and math_info (NULL: moreau's defaults). */
int mo_fclib_write_csc(const char *path, int d, int nc, const mo_csc *W, const double *q,
                       const double *mu, const double *r, const double *U, const char *title,
                       const char *description, const char *math_info, mo_ctx *ctx);
/* Read an FCLIB local problem: W as CSC (m x m), q, mu; d the local dimension. */
int mo_fclib_read(const char *path, int *d, int *nc, mo_csc **W, double **q, double **mu,
                  mo_ctx *ctx);

/* --- the contact network for the outputs (moreau/output.h) ------------------------------------ */

struct mo_vtk_contacts;
/* The network of the last step as the source of N (N->total lines, made by chunks as the writers
   read them: mo_vtk_contacts_next, moreau/output.h; the state, the set and the driver must stay
   as they are until then): every candidate closed or with a non-zero reaction, as a line from the slave side (a rigid shape's centre, or
   the material point of a mesh at state s) to the master side (a rigid shape's centre, or the
   contact point on a plane or a mesh), with its forces (reactions over mo_contact_driver_dt for
   the theta-scheme), status and gap. C or D NULL: an empty network. */
int mo_contact_network(const mo_scene *sc, const mo_contact *C, const mo_contact_driver *D,
                       const mo_state *s, struct mo_vtk_contacts *N, mo_ctx *ctx);
struct mo_vtk_points;
/* The contact points of the last step as the source of P (contact_points_NNNNN.vtu; P->total
   points made by chunks, as the network's): every candidate, or
   (closed_only) those with a status other than open or a reaction, with the values of their
   contact.csv rows and, in world axes, the normal, the force on the slave and the relative
   velocity. C or D NULL: none. O(candidates), and O(MO_VTK_CHUNK) memory. */
int mo_contact_points(const mo_scene *sc, const mo_contact *C, const mo_contact_driver *D, const mo_state *s,
                      int closed_only, struct mo_vtk_points *P, mo_ctx *ctx);

#ifdef __cplusplus
}
#endif
#endif
