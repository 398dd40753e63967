/* detect.c: contact detection for the pairs with rigid shapes (disks, spheres, polygons), run at
   every geometry with an alert distance: the broad phase, the narrow phases, and the detected
   candidates with their frames, gaps and keys (doc/theory.md §12.3). */
#include "config.h"
#include <moreau/body.h>
#include <moreau/contact.h>
#include "broad.h"
#include "vblocks.h"
#include "parallel_detect.h"
#include <moreau/parallel.h>
#include "contact_internal.h"
#include "narrow.h"

#include <math.h>
#include <string.h>

static int is_shape(const mo_body *B) { return (B->type->flags & (MO_BODY_F_BALL | MO_BODY_F_POLYGON)) != 0; }

/* 1 when pair k joins rigid shapes on both sides (the broad phase serves it). */
static int rigid_rigid(const mo_contact *C, const mo_contact_pair *P)
{
  return P->dynamic && is_shape(&C->sc->body[P->sb[0]]) && is_shape(&C->sc->body[P->mb[0]]);
}

void mo_contact_detect_free(mo_contact *C)
{
  mo_broad_free(C->broad);
  mo_vblocks_free(C->vb);
  C->vb = NULL;
  mo_free(C->rcm);
  mo_free(C->rcs);
  mo_free(C->bR);
  mo_free(C->rr);
  mo_free(C->bc);
  mo_free(C->br);
  mo_free(C->bs);
  mo_free(C->be);
  mo_free(C->bv);
  mo_free(C->bw);
  mo_free(C->bs2);
  mo_free(C->psb);
  mo_free(C->bmask);
  mo_free(C->dmask);
  mo_free(C->bcur);
  mo_free(C->bdof);
  mo_pdetect_free(C);
  mo_free(C->krr);
  mo_setmap_free(&C->smap);
  C->broad = NULL;
}

double mo_contact_smallest_size(const mo_contact *C)
{
  const mo_scene *sc = C->sc;
  double hmin = HUGE_VAL;
  int k, i, side;
  for (k = 0; k < C->npair; k++) {
    const mo_contact_pair *P = &C->pair[k];
    if (P->law == MO_LAW_SIGNORINI) continue; /* pairs with a rigid body */
    for (side = 0; side < 2; side++)
      for (i = 0; i < (side ? (P->dynamic ? P->nm : 1) : (P->dynamic ? P->ns : 1)); i++) {
        const mo_body *B = &sc->body[side ? (P->dynamic ? P->mb[i] : P->mbody) : (P->dynamic ? P->sb[i] : P->sbody)];
        double h = HUGE_VAL;
        if (is_shape(B)) h = B->kind == MO_BODY_POLYGON ? B->bound * cos(M_PI / B->nvert) : B->bound;
        else if (B->mesh) mo_mesh_edge_range(B->mesh, &h, NULL);
        if (h < hmin) hmin = h;
      }
  }
  return isfinite(hmin) ? hmin : 1;
}

/* dmask's bits of body B (MO_DM_*, (T310)): in a dynamic pair, and its kind's flags. */
static unsigned char dyn_bits(const mo_body *B)
{
  const unsigned f = B->type->flags;
  return (unsigned char)(MO_DM_DYN | (f & MO_BODY_F_RIGID ? MO_DM_RIGID : 0) | (f & MO_BODY_F_OBSTACLE ? MO_DM_OBSTACLE : 0) |
                         (f & MO_BODY_F_BALL ? MO_DM_BALL : 0));
}

/* The classes of the rigid-rigid pairs' sides (T310): from each body's masks ms[2 b] (master
   sides) and ms[2 b + 1] (slave sides), the distinct pairs of masks numbered from 1 in the order
   of the bodies, each body's class in bmask (0: on no side), the classes' masks in rcm and rcs. A
   side names a body or a group, so a body's class follows from whether its name and its group's
   are sides: the 64 pairs name at most 128 sides, and there are at most 128 classes besides 0. The
   bodies of one entry are consecutive and share their sides: the previous body's class is tried
   first. */
static int side_classes(mo_contact *C, const unsigned long long *ms, mo_ctx *ctx)
{
  unsigned long long cm[256], cs[256];
  int n = 1, b, c, last = 0;
  cm[0] = cs[0] = 0;
  for (b = 0; b < C->sc->nbody; b++) {
    const unsigned long long m = ms[2 * (size_t)b], sl = ms[2 * (size_t)b + 1];
    C->bmask[b] = 0;
    if (!(m | sl)) continue;
    c = last;
    if (cm[c] != m || cs[c] != sl)
      for (c = 1; c < n && (cm[c] != m || cs[c] != sl); c++) {}
    if (c == n) {
      if (n == 256)
        return mo_error(ctx, MO_EUNSUPPORTED, "%s: the bodies of the contact pairs between rigid shapes are on more "
                        "than 255 different sets of the pairs' sides; join bodies into groups (one entry making "
                        "several bodies) and pair the groups", mo_case_file(C->sc->cs));
      cm[n] = m;
      cs[n++] = sl;
    }
    C->bmask[b] = (unsigned char)c;
    last = c;
  }
  C->nrcls = n;
  C->rcm = mo_malloc(ctx, (size_t)n * sizeof *C->rcm);
  C->rcs = mo_malloc(ctx, (size_t)n * sizeof *C->rcs);
  if (!C->rcm || !C->rcs) return MO_ENOMEM;
  memcpy(C->rcm, cm, (size_t)n * sizeof *cm);
  memcpy(C->rcs, cs, (size_t)n * sizeof *cs);
  return MO_OK;
}

int mo_contact_detect_setup(mo_contact *C, mo_ctx *ctx)
{
  const mo_scene *sc = C->sc;
  unsigned long long *ms;
  int k, i, st;
  if (C->alert < 0) C->alert = 0.1 * mo_contact_smallest_size(C);
  /* the Verlet list's skin (T110): half the smallest body, never less than the alert distance */
  if (C->skin < 0) C->skin = fmax(C->alert, 0.5 * mo_contact_smallest_size(C));
  C->rr = mo_malloc(ctx, ((size_t)C->npair + 1) * sizeof *C->rr);
  C->bc = mo_calloc(ctx, (size_t)sc->dim * sc->nbody + 1, sizeof *C->bc); /* D per body (T110) */
  C->bcur = mo_calloc(ctx, (size_t)sc->dim * sc->nbody + 1, sizeof *C->bcur);
  C->bdof = mo_malloc(ctx, ((size_t)sc->nbody + 1) * sizeof *C->bdof);
  C->br = mo_calloc(ctx, (size_t)sc->nbody + 1, sizeof *C->br);
  C->bs = mo_calloc(ctx, (size_t)sc->nbody + 1, sizeof *C->bs);
  C->be = mo_calloc(ctx, (size_t)sc->nbody + 1, sizeof *C->be);
  C->bv = mo_calloc(ctx, (size_t)sc->dim * sc->nbody + 1, sizeof *C->bv); /* D per body: 8 bytes a 2D grain less than 3 (T266) */
  C->bw = mo_calloc(ctx, (size_t)sc->nbody + 1, sizeof *C->bw);
  C->bs2 = mo_calloc(ctx, (size_t)sc->nbody + 1, sizeof *C->bs2);
  C->bR = mo_malloc(ctx, ((size_t)sc->nbody + 1) * sizeof *C->bR);
  C->bmask = mo_calloc(ctx, (size_t)sc->nbody + 1, 1);
  C->dmask = mo_calloc(ctx, (size_t)sc->nbody + 1, 1);
  C->psb = mo_calloc(ctx, (size_t)C->npair + 1, sizeof *C->psb);
  if (!C->rr || !C->bc || !C->bcur || !C->bdof || !C->br || !C->bs || !C->be || !C->bv || !C->bw || !C->bs2 || !C->bR ||
      !C->bmask || !C->dmask || !C->psb)
    return MO_ENOMEM;
  for (k = 0; k < C->npair; k++)
    for (i = 0; i < C->pair[k].ns; i++) C->psb[k] = fmax(C->psb[k], sc->body[C->pair[k].sb[i]].bound);
  for (i = 0; i < sc->nbody; i++) {
    C->bdof[i] = (sc->body[i].type->flags & MO_BODY_F_RIGID) ? sc->body[i].dof0 : -1;
    C->bR[i] = sc->body[i].bound;
  }
  for (k = 0; k < C->npair; k++) {
    const mo_contact_pair *P = &C->pair[k];
    if (!P->dynamic) continue;
    for (i = 0; i < P->ns; i++) C->dmask[P->sb[i]] = dyn_bits(&sc->body[P->sb[i]]);
    for (i = 0; i < P->nm; i++) C->dmask[P->mb[i]] = dyn_bits(&sc->body[P->mb[i]]);
  }
  C->nrr = 0;
  if (!(ms = mo_calloc(ctx, 2 * (size_t)sc->nbody + 1, sizeof *ms))) return MO_ENOMEM;
  for (k = 0; k < C->npair; k++) {
    const mo_contact_pair *P = &C->pair[k];
    if (!rigid_rigid(C, P)) continue;
    if (C->nrr == 64) {
      mo_free(ms);
      return mo_error(ctx, MO_EUNSUPPORTED, "%s: more than 64 contact pairs between rigid shapes; join bodies into "
                      "groups (one entry making several bodies) and pair the groups", mo_case_file(sc->cs));
    }
    for (i = 0; i < P->nm; i++) ms[2 * (size_t)P->mb[i]] |= 1ULL << C->nrr;
    for (i = 0; i < P->ns; i++) ms[2 * (size_t)P->sb[i] + 1] |= 1ULL << C->nrr;
    C->rr[C->nrr++] = k;
  }
  st = side_classes(C, ms, ctx);
  mo_free(ms);
  if (st) return st;
  /* the remap written by the detection (T220): the pairs between shapes in the broad phase's
     order, those of shapes against a plane by pair, then by slave, which the pair's list must
     give in increasing order (the granular path has no other pair) */
  if (!(C->krr = mo_calloc(ctx, (size_t)C->npair + 1, 1))) return MO_ENOMEM;
  for (k = 0; k < C->nrr; k++) C->krr[C->rr[k]] = 1;
  C->smap_ok = 1;
  for (k = 0; k < C->npair; k++) {
    const mo_contact_pair *P = &C->pair[k];
    if (!P->dynamic || C->krr[k]) continue;
    if (!(sc->body[P->mb[0]].type->flags & MO_BODY_F_OBSTACLE)) C->smap_ok = 0;
    for (i = 1; i < P->ns; i++) C->smap_ok &= P->sb[i] > P->sb[i - 1];
  }
  C->smap_from = C->smap_to = -1;
  if (C->nrr && (st = mo_broad_create(&C->broad, ctx))) return st;
  mo_log(ctx, 2, "contact detection: %d dynamic pairs (%d between rigid shapes), alert distance %g m\n", C->ndyn,
         C->nrr, C->alert);
  return MO_OK;
}

/* --- one detected contact ------------------------------------------------------------------- */

typedef struct {
  int pair, sb, mb, sfeat, mfeat;
  int snode;                 /* slave mesh node, or -1 */
  int mfacet, mn, mnode[MO_FNODE_MAX];  /* master mesh facet, or -1 */
  double mN[MO_FNODE_MAX];
} dyn_side;

/* Write key (pair, slave, master, features) of detected candidate a, noting whether it differs from
   the key a held in the previous set (C->knold keys; C->ksame: the set is the same so far); on the
   granular path, its place in the old set with it (setmap.c, (T220)-(T222)). */
static inline int set_key(mo_contact *C, int a, int pair, int sb, int mb, int sfeat, int mfeat, mo_ctx *ctx)
{
  int *key = C->key + (size_t)a * MO_KEY;
  if (a >= C->knold || key[0] != pair || key[1] != sb || key[2] != mb || key[3] != sfeat || key[4] != mfeat)
    C->ksame = 0;
  if (C->smap_from == -2) { /* this detection writes the map */
    const int k[MO_KEY] = {pair, sb, mb, sfeat, mfeat};
    return mo_setmap_put(&C->smap, C->key, a, k, ctx);
  }
  key[0] = pair; key[1] = sb; key[2] = mb; key[3] = sfeat; key[4] = mfeat;
  return MO_OK;
}

/* Append the contact N of pair k between slave sb and master mb as a point and a candidate,
   with its frame, gap, obstacle velocity, key and law. */
static int add_contact(mo_contact *C, const dyn_side *S, const mo_narrow *N, double t, mo_ctx *ctx)
{
  const mo_scene *sc = C->sc;
  const mo_contact_pair *P = &C->pair[S->pair];
  const mo_body *M = &sc->body[S->mb];
  int D = sc->dim, d = C->dim, a = C->nc, i, j, st;
  double *F, Fb[9];
  if (C->compact) {
    /* the granular path: the per-candidate arrays and the point, nothing else (§12.9); of the
       frame its normal alone, the frame formed from it (T225) */
    if ((st = mo_contact_reserve(C, C->nc + 1, ctx))) return st;
    C->nc++;
    for (i = 0; i < d; i++) C->frame[(size_t)a * d + i] = N->n[i];
    mo_contact_frame_from_normal(D, N->n, Fb);
    F = Fb;
  } else {
    int pi = C->npt;
    double one = 1;
    mo_cpoint *p;
    mo_candidate c;
    /* the point is written in its slot of the set (no copy of the large struct) */
    if ((st = mo_contact_point_room(C, ctx))) return st;
    p = &C->pt[C->npt++];
    memset(p, 0, sizeof *p);
    memset(&c, 0, sizeof c);
    p->pair = S->pair;
    p->facet = -1;
    p->sb = S->sb;
    p->mb = S->mb;
    p->sfeat = S->sfeat;
    p->mfeat = S->mfeat;
    if (S->snode >= 0) {
      p->nn = 1;
      p->node[0] = S->snode;
      p->N[0] = 1;
    }
    p->mfacet = S->mfacet;
    p->mn = S->mn;
    for (i = 0; i < S->mn; i++) {
      p->mnode[i] = S->mnode[i];
      p->mN[i] = S->mN[i];
    }
    for (i = 0; i < D; i++) p->xs[i] = p->xm[i] = p->x0[i] = N->x[i];
    mo_contact_frame_from_normal(D, N->n, p->frame);
    p->g = N->g;
    c.pair = S->pair;
    c.np = 1;
    c.node = S->snode;
    c.point = pi;
    c.w = 1;
    c.mu = P->mu;
    if ((st = mo_contact_add_candidate(C, &c, &pi, &one, ctx)) || (st = mo_contact_reserve(C, C->nc, ctx))) return st;
    F = C->frame + (size_t)a * (size_t)(d * d);
    memcpy(F, C->pt[pi].frame, (size_t)(d * d) * sizeof *F);
  }
  for (i = 0; i < D; i++) C->x[(size_t)a * D + i] = N->x[i];
  C->g[a] = N->g;
  C->active[a] = 1;
  for (i = 0; i < d; i++) {
    double u0 = 0;
    if (M->type->flags & MO_BODY_F_OBSTACLE)
      for (j = 0; j < D; j++) u0 -= F[i * d + j] * M->velocity[j];
    if (C->U0) C->U0[(size_t)a * d + i] = u0;
  }
  (void)t;
  return set_key(C, a, S->pair, S->sb, S->mb, S->sfeat, S->mfeat, ctx);
}

/* The granular path's append of a contact between two shapes (no mesh side): add_contact's
   compact branch, without what meshes and planes need. */
static inline int compact_add(mo_contact *C, int pair, int sb, int mb, const mo_narrow *N, mo_ctx *ctx)
{
  const int D = C->dim, a = C->nc;
  int i, st;
  if (a + 1 > C->nalloc && (st = mo_contact_reserve(C, a + 1, ctx))) return st;
  C->nc++;
  for (i = 0; i < D; i++) {
    C->frame[(size_t)a * D + i] = N->n[i]; /* the frame's normal alone (T225) */
    C->x[(size_t)a * D + i] = N->x[i];
    if (C->U0) C->U0[(size_t)a * D + i] = 0;
  }
  C->g[a] = N->g;
  C->active[a] = 1;
  return set_key(C, a, pair, sb, mb, N->fb, N->fa, ctx);
}

/* --- narrow phases by the kinds of the two sides ------------------------------------------------ */

/* A rigid shape's world description: centre and radius (ball), or world vertices (polygon). */
static inline void shape_world(const mo_scene *sc, const mo_body *B, const mo_state *s, double *c, double *v)
{
  int k;
  for (k = 0; k < 3; k++) c[k] = k < sc->dim ? B->xc0[k] + s->u[B->dof0 + k] : 0; /* mo_rigid_center */
  if (B->kind == MO_BODY_POLYGON) mo_polygon_world(sc, B, s, v);
}

/* The alert distance of a pair of bodies: contact.alert plus what the two can close in two steps:
   their relative velocity plus what their rotations (or a mesh's deformation) add (T77). Grains
   falling together are not candidates of each other; a fast grain widens its own pairs only. */
static double pair_alert(const mo_contact *C, int a, int b)
{
  const int D = C->dim;
  const double *va = C->bv + (size_t)D * a, *vb = C->bv + (size_t)D * b;
  double dv2 = (va[0] - vb[0]) * (va[0] - vb[0]) + (va[1] - vb[1]) * (va[1] - vb[1]), dv;
  if (D == 3) dv2 += (va[2] - vb[2]) * (va[2] - vb[2]); /* in 2D it was +0: the same sum (T266) */
  dv = sqrt(dv2);
  return C->alert + 2 * C->h * (dv + C->bw[a] + C->bw[b]);
}

/* Shape `sb` (slave) against shape `mb` (master): the narrow phase of their two kinds. */
static int shape_shape(mo_contact *C, int k, int sb, int mb, const mo_state *s, double t, mo_ctx *ctx)
{
  const double alert = pair_alert(C, sb, mb);
  const mo_scene *sc = C->sc;
  const mo_body *S, *M;
  double cs[3], cm[3], vs[2 * MO_POLYGON_MAX], vm[2 * MO_POLYGON_MAX];
  mo_narrow out[2];
  dyn_side ds;
  int n = 0, i, st, flip = 0;
  if (C->compact && (C->dmask[sb] & C->dmask[mb] & MO_DM_BALL)) {
    /* two balls on the granular path (the shapes of a rigid-rigid pair are balls or polygons): at
       most one contact, appended as a compact record. Their centres are body_speed's of this
       detection (bcur: x_c0 + u, the sums of shape_world), read where they are instead of formed
       again for every pair (T290); their radii are bR's, their kinds dmask's: no body record read
       (T310) */
    const double *bs = C->bcur + (size_t)sc->dim * sb, *bm = C->bcur + (size_t)sc->dim * mb;
    if (!mo_narrow_ball_ball(sc->dim, bm, C->bR[mb], bs, C->bR[sb], alert, out)) return MO_OK;
    return compact_add(C, k, sb, mb, out, ctx);
  }
  S = &sc->body[sb];
  M = &sc->body[mb];
  shape_world(sc, S, s, cs, vs);
  shape_world(sc, M, s, cm, vm);
  if (S->kind != MO_BODY_POLYGON && M->kind != MO_BODY_POLYGON)
    n = mo_narrow_ball_ball(sc->dim, cm, M->radius, cs, S->radius, alert, out);
  else if (M->kind == MO_BODY_POLYGON && S->kind != MO_BODY_POLYGON)
    n = mo_narrow_polygon_ball(M->nvert, vm, cs, S->radius, alert, out);
  else if (M->kind != MO_BODY_POLYGON) {
    /* a ball master and a polygon slave: the polygon's narrow phase, turned round */
    n = mo_narrow_polygon_ball(S->nvert, vs, cm, M->radius, alert, out);
    flip = 1;
  } else
    n = mo_narrow_polygon_polygon(M->nvert, vm, S->nvert, vs, alert, out);
  memset(&ds, 0, sizeof ds);
  ds.pair = k;
  ds.sb = sb;
  ds.mb = mb;
  ds.snode = ds.mfacet = -1;
  for (i = 0; i < n; i++) {
    if (flip) {
      int f = out[i].fa;
      out[i].n[0] = -out[i].n[0]; out[i].n[1] = -out[i].n[1]; out[i].n[2] = -out[i].n[2];
      out[i].fa = out[i].fb;
      out[i].fb = f;
    }
    ds.mfeat = out[i].fa;
    ds.sfeat = out[i].fb;
    if ((st = add_contact(C, &ds, &out[i], t, ctx))) return st;
  }
  return MO_OK;
}

/* The closest facet of a facet set to x (projections inside a facet preferred, as the pairing of
   mesh points): facet, shape values, point q and normal n; the signed distance along n. */
static double closest_facet(const mo_scene *sc, int b, const mo_facetset *fs, const double *x, const mo_state *s,
                            int *fbest, double *N, double *q, double *n)
{
  double best = HUGE_VAL, bestin = HUGE_VAL, xi[2], Nf[MO_FNODE_MAX], qf[3], nf[3], g = 0;
  int f, fin = -1, fout = -1, inside, i, fsel;
  for (f = 0; f < fs->n; f++) {
    double dist = mo_contact_project_facet(sc, b, fs, f, x, s, xi, Nf, qf, nf, &inside);
    if (dist < best) { best = dist; fout = f; }
    if (inside && dist < bestin) { bestin = dist; fin = f; }
  }
  fsel = fin >= 0 ? fin : fout;
  *fbest = fsel;
  mo_contact_project_facet(sc, b, fs, fsel, x, s, xi, N, q, n, &inside);
  for (i = 0; i < sc->dim; i++) g += (x[i] - q[i]) * n[i];
  return g;
}

/* A ball (centre c, radius r) or a polygon vertex (r = 0) of slave sb against the facets of mesh
   master mb. */
static int point_facets(mo_contact *C, int k, int sb, int sfeat, const double *c, double r, const mo_state *s,
                        double alert, double t, mo_ctx *ctx)
{
  const mo_scene *sc = C->sc;
  const mo_contact_pair *P = &C->pair[k];
  const mo_facetset *fs = mo_mesh_find_facetset(sc->body[P->mb[0]].mesh, P->mset);
  double N[MO_FNODE_MAX], q[3], n[3], g;
  int f, i;
  dyn_side ds;
  mo_narrow nc;
  g = closest_facet(sc, P->mb[0], fs, c, s, &f, N, q, n) - r;
  if (g > alert) return MO_OK;
  memset(&ds, 0, sizeof ds);
  memset(&nc, 0, sizeof nc);
  ds.pair = k;
  ds.sb = sb;
  ds.mb = P->mb[0];
  ds.sfeat = sfeat;
  ds.mfeat = -1;
  ds.snode = -1;
  ds.mfacet = f;
  ds.mn = fs->nfn;
  for (i = 0; i < fs->nfn; i++) {
    ds.mnode[i] = fs->node[f * fs->nfn + i];
    ds.mN[i] = N[i];
  }
  for (i = 0; i < sc->dim; i++) {
    nc.n[i] = n[i];
    nc.x[i] = q[i] + 0.5 * g * n[i];
  }
  nc.g = g;
  return add_contact(C, &ds, &nc, t, ctx);
}

/* The nodes of a mesh slave (its set) against a rigid shape master mb. */
static int nodes_shape(mo_contact *C, int k, int mb, const mo_state *s, double t, mo_ctx *ctx)
{
  const double alert = pair_alert(C, C->pair[k].sb[0], mb);
  const mo_scene *sc = C->sc;
  const mo_contact_pair *P = &C->pair[k];
  const mo_body *M = &sc->body[mb];
  int sb = P->sb[0], *ids = NULL, nn = 0, a, i, st = MO_OK, D = sc->dim;
  double cm[3], vm[2 * MO_POLYGON_MAX];
  const mo_facetset *fs = mo_mesh_find_facetset(sc->body[sb].mesh, P->sset);
  shape_world(sc, M, s, cm, vm);
  if (fs) { /* the nodes of the facets */
    ids = mo_malloc(ctx, ((size_t)fs->n * fs->nfn + 1) * sizeof *ids);
    if (!ids) return MO_ENOMEM;
    for (i = 0; i < fs->n * fs->nfn; i++) {
      int v = fs->node[i], j, dup = 0;
      for (j = 0; j < nn && !dup; j++) dup = ids[j] == v;
      if (!dup) ids[nn++] = v;
    }
  } else if (mo_mesh_nodeset_resolve(sc->body[sb].mesh, P->sset, &ids, &nn, ctx))
    return ctx->status;
  for (a = 0; a < nn && !st; a++) {
    double x[3], d2 = 0, rr = M->bound + alert;
    mo_narrow out[1];
    dyn_side ds;
    int n;
    mo_contact_node_pos(sc, sb, ids[a], s, x);
    for (i = 0; i < D; i++) d2 += (x[i] - cm[i]) * (x[i] - cm[i]);
    if (d2 > rr * rr) continue;
    n = M->kind == MO_BODY_POLYGON ? mo_narrow_polygon_ball(M->nvert, vm, x, 0, alert, out)
                                   : mo_narrow_ball_ball(D, cm, M->radius, x, 0, alert, out);
    if (!n) continue;
    memset(&ds, 0, sizeof ds);
    ds.pair = k;
    ds.sb = sb;
    ds.mb = mb;
    ds.sfeat = ids[a];
    ds.mfeat = out[0].fa;
    ds.snode = ids[a];
    ds.mfacet = -1;
    st = add_contact(C, &ds, &out[0], t, ctx);
  }
  mo_free(ids);
  return st;
}

/* The walls' first test (T297) from the pair's shape q on (own[q], or q, in its list sbl): the first
   shape whose bounding ball may be within an alert distance of the plane (point p, unit normal nrm),
   or nq when none is. The loop of shapes_obstacle with the pair's constants read once (the alert
   distance, 2 h, the plane's speed bound s_m, the largest bounding radius psb) and the dimension a
   constant of the call (T312): the same sums in the same order, h from +0 over the components and
   the margin (alert + 2 h (s_b + s_m)) (1 + 1e-9), so the same shapes are passed over. */
static inline __attribute__((always_inline)) int plane_scan(const mo_contact *C, const int *sbl, const int *own, int q,
                                                            int nq, const double *p, const double *nrm, double bsm,
                                                            double psb, const int D)
{
  const double *bcur = C->bcur, *bs = C->bs, alert = C->alert, h2 = 2 * C->h;
  for (; q < nq; q++) {
    const int sb = sbl[own ? own[q] : q];
    const double *cb = bcur + (size_t)D * sb; /* body_speed's centre (T290) */
    const double margin = (alert + h2 * (bs[sb] + bsm)) * (1 + 1e-9);
    double h = 0;
    int j;
    for (j = 0; j < D; j++) h += (cb[j] - p[j]) * nrm[j];
    if (!(h > psb + margin)) return q;
  }
  return nq;
}

static int plane_next(const mo_contact *C, const int *sbl, const int *own, int q, int nq, const double *p,
                      const double *nrm, double bsm, double psb)
{
  const int D = C->sc->dim;
  if (D == 2) return plane_scan(C, sbl, own, q, nq, p, nrm, bsm, psb, 2);
  if (D == 3) return plane_scan(C, sbl, own, q, nq, p, nrm, bsm, psb, 3);
  return plane_scan(C, sbl, own, q, nq, p, nrm, bsm, psb, D);
}

/* Every slave shape of pair k against its plane or mesh master (O(bodies of the pair)). */
static int shapes_obstacle(mo_contact *C, int k, const mo_state *s, double t, mo_ctx *ctx)
{
  const mo_scene *sc = C->sc;
  const mo_contact_pair *P = &C->pair[k];
  const mo_body *M = &sc->body[P->mb[0]];
  const int *own = NULL, plane = (M->type->flags & MO_BODY_F_OBSTACLE) != 0;
  int i, j, n, q, nq = P->ns, st;
  /* split over the ranks: the shapes of this rank's slab only (T215, T231) */
  double p[3] = {0, 0, 0};
  if (C->pd && plane) nq = mo_pdetect_walls(C->pd, k, &own);
  if (plane) {
    if (t > M->until) return MO_OK; /* the gate has opened */
    /* the plane's point at t: one for every shape of the pair (T290) */
    for (j = 0; j < sc->dim; j++) p[j] = M->point[j] + M->velocity[j] * t;
  }
  for (q = 0; q < nq; q++) {
    int sb;
    const mo_body *S;
    double c[3], v[2 * MO_POLYGON_MAX], alert;
    mo_narrow out[MO_POLYGON_MAX];
    dyn_side ds;
    /* a plane: on to the next shape its first test keeps (T312) */
    if (plane && (q = plane_next(C, P->sb, own, q, nq, p, M->normal, C->bs[P->mb[0]], C->psb[k])) == nq) break;
    sb = P->sb[i = own ? own[q] : q];
    S = &sc->body[sb];
    if (plane) {
      const double *cb = C->bcur + (size_t)sc->dim * sb; /* body_speed's centre (T290) */
      double h = 0, reach;
      int from = C->nc;
      /* a shape whose bounding ball is farther from the plane than any alert distance of theirs
         (pair_alert <= alert + 2 h (s_b + s_plane)) is passed over before its narrow phase; first
         against the largest bounding radius of the pair's shapes (T297), which reads no body
         record: almost every shape of a pile is passed over there (plane_scan, T312; the test is
         formed again here for the shape it kept), and the body records, 208 bytes apart, are read
         only for the few near the plane (the same shapes pass both tests: psb >= bound, and the
         sums round alike) */
      const double margin = (C->alert + 2 * C->h * (C->bs[sb] + C->bs[P->mb[0]])) * (1 + 1e-9);
      for (j = 0; j < sc->dim; j++) h += (cb[j] - p[j]) * M->normal[j];
      if (h > C->psb[k] + margin) continue;
      reach = S->bound + margin;
      if (h > reach) continue;
      alert = pair_alert(C, sb, P->mb[0]);
      if (S->kind == MO_BODY_POLYGON) {
        shape_world(sc, S, s, c, v);
        n = mo_narrow_plane_polygon(p, M->normal, S->nvert, v, alert, out);
      } else
        n = mo_narrow_plane_ball(sc->dim, p, M->normal, cb, S->radius, alert, out);
      memset(&ds, 0, sizeof ds);
      ds.pair = k;
      ds.sb = sb;
      ds.mb = P->mb[0];
      ds.snode = ds.mfacet = -1;
      for (j = 0; j < n; j++) {
        ds.sfeat = out[j].fb;
        ds.mfeat = -1;
        if ((st = add_contact(C, &ds, &out[j], t, ctx))) return st;
      }
      if (C->pd && C->smap_from != -2 && C->nc > from && (st = mo_pdetect_tag(C, from, k, i, 0, ctx))) return st;
    } else if (S->kind == MO_BODY_POLYGON) {
      alert = pair_alert(C, sb, P->mb[0]);
      shape_world(sc, S, s, c, v);
      for (j = 0; j < S->nvert; j++)
        if ((st = point_facets(C, k, sb, j, v + 2 * j, 0, s, alert, t, ctx))) return st;
    } else {
      alert = pair_alert(C, sb, P->mb[0]);
      shape_world(sc, S, s, c, v);
      if ((st = point_facets(C, k, sb, -1, c, S->radius, s, alert, t, ctx))) return st;
    }
  }
  return MO_OK;
}

/* Body b of the dynamic pairs: its centre, velocity, and the largest speed a point of it can have
   (|v| + |omega| times its bounding radius; a plane's velocity; a mesh's fastest node), the margin
   of its pairs' alert distances over a step. */
static inline void body_speed(mo_contact *C, const mo_state *s, int b)
{
  const mo_scene *sc = C->sc;
  const mo_body *B = &sc->body[b];
  const unsigned char fl = C->dmask[b];
  int a, i, D = sc->dim;
  double v2 = 0, w2 = 0, vmax = 0, *v = C->bv + (size_t)D * b;
  if (fl & MO_DM_RIGID) {
    /* the kind from dmask, the first dof from bdof, the bounding radius from bR, the dofs
       mo_rigid_ndof's: of the body record its centroid alone is read (T310) */
    const int d0 = C->bdof[b], nd = D == 3 ? 6 : 3; /* mo_rigid_ndof */
    const double *x0 = B->xc0;
    for (a = 0; a < D; a++) C->bcur[(size_t)D * b + a] = x0[a] + s->u[d0 + a]; /* mo_rigid_center */
    for (a = 0; a < D; a++) v2 += (v[a] = s->v[d0 + a]) * s->v[d0 + a];
    for (a = D; a < nd; a++) w2 += s->v[d0 + a] * s->v[d0 + a];
    C->bw[b] = sqrt(w2) * C->bR[b];
    vmax = sqrt(v2) + C->bw[b];
  } else if (fl & MO_DM_OBSTACLE) {
    C->bw[b] = 0;
    for (a = 0; a < D; a++) v2 += (v[a] = B->velocity[a]) * B->velocity[a];
    vmax = sqrt(v2);
  } else {
    for (a = 0; a < D; a++) v[a] = 0;
    /* a mesh: its fastest node, as a spread about no common velocity */
    for (a = 0; a < B->mesh->nnode; a++) {
      v2 = 0;
      for (i = 0; i < D; i++) v2 += s->v[B->dof0 + a * D + i] * s->v[B->dof0 + a * D + i];
      vmax = fmax(vmax, sqrt(v2));
    }
    C->bw[b] = vmax;
  }
  C->bs[b] = vmax;
}

/* Every body of the dynamic pairs (body_speed). Split over the ranks with the list built, the
   bodies of this rank's slab and halo and those outside the broad phase only (T230): the others'
   are taken at the next build, and their centres are not kept for contact_geom.c (bcur_u NULL). */
static void body_speeds(mo_contact *C, const mo_state *s)
{
  int b;
  C->bcur_u = s->u;
  C->bcur_step = s->step;
  if (C->pd && C->vl_built) {
    const int *near;
    const int n = mo_pdetect_near(C->pd, &near);
    C->bcur_u = NULL;
    for (b = 0; b < n; b++) body_speed(C, s, near[b]);
    return;
  }
  if (C->pd) C->bcur_u = NULL;
  for (b = 0; b < C->sc->nbody; b++) {
    /* of its body record body_speed reads the centroid alone (T310), 208 bytes from the last one:
       at 10^5 grains past the caches, and the loop waits on it; asked for 16 bodies ahead (T313) */
    if (b + 16 < C->sc->nbody) __builtin_prefetch(C->sc->body[b + 16].xc0);
    if (C->dmask[b]) body_speed(C, s, b);
  }
}

/* Body b's speed relative to the mean translation velocity vm plus what its rotation adds,
   s'_b = |v_b - vm| + w_b, into bs2 (doc/theory.md (T110)). */
static inline void relative_speed(mo_contact *C, int D, const double *vm, int b)
{
  double e2 = 0;
  int k;
  for (k = 0; k < D; k++) e2 += (C->bv[(size_t)D * b + k] - vm[k]) * (C->bv[(size_t)D * b + k] - vm[k]);
  C->bs2[b] = sqrt(e2) + C->bw[b];
}

/* The mean translation velocity of the broad phase's bodies (bv), and each body's speed relative to
   it plus what its rotation adds, s'_b = |v_b - vm| + w_b, into bs2 (doc/theory.md (T110)). */
static void relative_speeds(mo_contact *C, int D, double *vm)
{
  const mo_scene *sc = C->sc;
  int b, k, n = 0;
  vm[0] = vm[1] = vm[2] = 0;
  for (b = 0; b < sc->nbody; b++)
    if (C->bmask[b]) {
      for (k = 0; k < D; k++) vm[k] += C->bv[(size_t)D * b + k];
      n++;
    }
  for (k = 0; k < D && n; k++) vm[k] /= n;
  for (b = 0; b < sc->nbody; b++)
    if (C->bmask[b]) relative_speed(C, D, vm, b);
}

/* Whether body b keeps the list valid: its displacement since the build relative to the mean one
   (dm), plus what it can close at its relative speed now, within half the skin plus its e_b. */
static inline int body_valid(const mo_contact *C, int D, const double *dm, int b)
{
  double dd = 0;
  int k;
  for (k = 0; k < D; k++) {
    double e = C->bcur[(size_t)D * b + k] - C->bc[(size_t)D * b + k] - dm[k];
    dd += e * e;
  }
  return sqrt(dd) + 2 * C->h * C->bs2[b] <= 0.5 * C->skin + C->be[b];
}

/* The list's validity split over the ranks (doc/theory.md (T230)): the sums of the velocities and
   displacements of each rank's own bodies (its slab at the last build) summed over the ranks into
   the means vm and dm, each rank's own bodies tested, and one maximum over the ranks: every rank
   takes the decision one process takes over every body (to the rounding of the means' sums). */
static int valid_split(mo_contact *C, int D, double *vm, int *valid, mo_ctx *ctx)
{
  const int *own;
  const int n = mo_pdetect_own(C->pd, &own);
  double sum[7] = {0, 0, 0, 0, 0, 0, 0}, dm[3], bad = 0;
  int i, k, st;
  for (i = 0; i < n; i++) {
    const int b = own[i];
    for (k = 0; k < D; k++) {
      sum[k] += C->bv[(size_t)D * b + k];
      sum[D + k] += C->bcur[(size_t)D * b + k] - C->bc[(size_t)D * b + k];
    }
  }
  sum[2 * D] = n;
  if ((st = mo_par_sum(sum, 2 * D + 1, ctx))) return st;
  for (k = 0; k < 3; k++) vm[k] = dm[k] = 0;
  for (k = 0; k < D && sum[2 * D] > 0; k++) {
    vm[k] = sum[k] / sum[2 * D];
    dm[k] = sum[D + k] / sum[2 * D];
  }
  for (i = 0; i < n; i++) {
    relative_speed(C, D, vm, own[i]);
    if (!bad && !body_valid(C, D, dm, own[i])) bad = 1;
  }
  if ((st = mo_par_max(&bad, 1, ctx))) return st;
  *valid = bad == 0;
  return MO_OK;
}

/* The list kept by blocks (vblocks.c, doc/theory.md §12.26): on one process, with contact.verlet =
   blocks, or auto and at least MO_VBLOCKS_MIN shapes in the broad phase (below, the two lists cost
   about the same, (T326)). */
#define MO_VBLOCKS_MIN 4096

static int pair_list_blocks(mo_contact *C, const mo_state *s, mo_ctx *ctx)
{
  const mo_scene *sc = C->sc;
  mo_vblocks_in in;
  const int *pairs;
  long np;
  int st, built;
  const double t0 = mo_clock();
  if (!C->vb && (st = mo_vblocks_create(&C->vb, ctx))) return st;
  in.dim = sc->dim;
  in.n = sc->nbody;
  in.mask = C->bmask;
  in.x = C->bcur;
  in.v = C->bv;
  in.w = C->bw;
  in.bound = C->bR;
  in.t = s->t;
  in.h = C->h;
  in.alert = C->alert;
  in.skin = C->skin;
  if ((st = mo_vblocks_update(C->vb, &in, C->broad, &pairs, &np, &built, ctx))) {
    C->vl_built = 0;
    C->vl_n = 0;
    return st;
  }
  C->vl = pairs;
  C->vl_n = np;
  C->vl_built = 1;
  C->vl_builds += built;
  C->vl_reach = C->alert + C->skin;
  mo_phase_add(ctx, MO_PH_BROAD, t0);
  return MO_OK;
}

/* Whether this rank detects the pair of bodies i and j: its point at the build (C->bc) is in the
   rank's box (T341). */
static int pair_owned(void *arg, int i, int j)
{
  const mo_contact *C = arg;
  const int oi = C->pd->owner[i];
  /* two bodies of one box: their point lies between their centres, in that box (a box is where
     every cut's bin test passes, and a bin is monotone in the abscissa): no point formed */
  if (oi >= 0 && oi == C->pd->owner[j]) return oi == C->pd->rank;
  return mo_pdetect_owns_pair(C->pd, C->sc->dim, C->bc, C->bR, i, j);
}

/* Body b's snapshot at a build: its centre, margin e_b and grown radius. */
static inline void snapshot(mo_contact *C, int D, int b)
{
  memcpy(C->bc + (size_t)D * b, C->bcur + (size_t)D * b, (size_t)D * sizeof *C->bc);
  C->be[b] = 2 * C->h * C->bs2[b];
  C->br[b] = C->sc->body[b].bound + C->be[b];
}

/* The broad phase's pair list, kept while it holds every pair closer than its alert distance
   (pair_alert; doc/theory.md (T110)): built with each body's bounding ball grown by what it could
   close relative to the others' mean motion at its speed then (e_b = 2 h s'_b, s'_b its speed
   relative to the bodies' mean velocity plus what its rotation adds) and a skin (contact.skin),
   it stays valid while every body's displacement relative to the bodies' mean
   displacement since the build, plus what it can close at its relative speed now, stays within
   half the skin plus its e_b. Grains falling together move with the mean: their list stays. */
static int pair_list(mo_contact *C, const mo_state *s, mo_ctx *ctx)
{
  const mo_scene *sc = C->sc;
  const int D = sc->dim;
  const int *pairs;
  long np;
  int b, k, st, valid = C->vl_built, n = 0;
  double t0 = mo_clock(), vm[3], dm[3] = {0, 0, 0};
  if (!C->pd && C->verlet == 0) { /* auto: decided once, on the shapes of the broad phase */
    for (b = 0; b < sc->nbody; b++) n += C->bmask[b] != 0;
    C->verlet = n >= MO_VBLOCKS_MIN ? 2 : 1;
    n = 0;
  }
  if (!C->pd && C->verlet == 2 && C->bc) {
    /* the global list's snapshots, radii, margins and relative speeds are not read on this path */
    mo_free(C->bc);
    mo_free(C->br);
    mo_free(C->be);
    mo_free(C->bs2);
    C->bc = C->br = C->be = C->bs2 = NULL;
  }
  if (!C->pd && C->verlet == 2) return pair_list_blocks(C, s, ctx);
  if (C->pd && (valid || C->pd->held)) {
    /* split over the ranks: each rank its own bodies (T230); at a build, the speeds of the bodies
       outside its slab and halo, then every body's relative speed. With the bodies' state per rank
       (§13.18) the means from the own bodies even when the list is to be made again, and only the
       bodies this rank holds: the others' state is not current here */
    const int held = C->pd->held;
    int ok;
    if ((st = valid_split(C, D, vm, &ok, ctx))) return st;
    valid = valid && ok;
    if (!valid && held) {
      const int *hl = C->pd->hlist;
      for (b = 0; b < C->pd->nhlist; b++)
        if (C->bmask[hl[b]]) relative_speed(C, D, vm, hl[b]);
    } else if (!valid) {
      const int *rest;
      const int nr = mo_pdetect_rest(C->pd, &rest);
      for (b = 0; b < nr; b++) body_speed(C, s, rest[b]);
      for (b = 0; b < sc->nbody; b++)
        if (C->bmask[b]) relative_speed(C, D, vm, b);
    }
  } else {
    relative_speeds(C, D, vm);
    if (valid) {
      /* the mean displacement since the build, then each body's displacement relative to it */
      for (b = 0; b < sc->nbody; b++)
        if (C->bmask[b]) {
          for (k = 0; k < D; k++) dm[k] += C->bcur[(size_t)D * b + k] - C->bc[(size_t)D * b + k];
          n++;
        }
      for (k = 0; k < D && n; k++) dm[k] /= n;
      for (b = 0; b < sc->nbody && valid; b++)
        if (C->bmask[b]) valid = body_valid(C, D, dm, b);
    }
  }
  if (valid) {
    mo_phase_add(ctx, MO_PH_BROAD, t0);
    return MO_OK;
  }
  if (C->pd && C->pd->held)
    for (k = 0; k < C->pd->nhlist; k++) {
      if (C->bmask[b = C->pd->hlist[k]]) snapshot(C, D, b);
    }
  else
    for (b = 0; b < sc->nbody; b++)
      if (C->bmask[b]) snapshot(C, D, b);
  C->vl_reach = C->alert + C->skin;
  /* split over the ranks: the slabs of this build, and the broad phase on this rank's slab and
     its halo (T215)-(T216) */
  if (C->pd && (st = mo_pdetect_build(C, s, ctx))) return st;
  if (C->pd && C->pd->held) {
    /* the bodies this rank received at the build: their speeds and snapshot from the state they
       came with (the sender's, to the bit) */
    const int *rl;
    const int nr = mo_pdetect_received(C->pd, &rl);
    for (k = 0; k < nr; k++) {
      body_speed(C, s, rl[k]);
      relative_speed(C, D, vm, rl[k]);
      snapshot(C, D, rl[k]);
    }
  }
  if ((st = mo_broad_pairs(C->broad, D, sc->nbody, C->bc, C->br, C->pd ? mo_pdetect_mask(C) : C->bmask, C->vl_reach,
                           &pairs, &np, ctx))) {
    C->vl_built = 0;
    C->vl_n = 0;
    return st;
  }
  /* split over the ranks, the rank's own pairs only: those whose point at this build lies in its
     box (T341) */
  if (C->pd) np = mo_broad_keep(C->broad, pair_owned, C);
  C->vl = pairs; /* the broad phase's own list, valid until its next call */
  C->vl_n = np;
  C->vl_built = 1;
  C->vl_builds++;
  mo_phase_add(ctx, MO_PH_BROAD, t0);
  return MO_OK;
}

/* Two balls (disks, spheres) of a rigid-rigid pair: a pair of the list farther apart than any
   alert distance of theirs can be (pair_alert <= alert + 2 h (s_a + s_b)) is passed over before
   the narrow phase, which would find it out of reach too. */
static inline int balls_apart(const mo_contact *C, const mo_state *s, int i, int j, int D)
{
  const double *ci = C->bcur + (size_t)D * i, *cj = C->bcur + (size_t)D * j;
  double d2 = 0, reach = C->bR[i] + C->bR[j] + C->alert + 2 * C->h * (C->bs[i] + C->bs[j]);
  int k;
  (void)s;
  for (k = 0; k < D; k++) d2 += (cj[k] - ci[k]) * (cj[k] - ci[k]);
  return d2 > reach * reach * (1 + 1e-9);
}

/* The pair list of the bodies of the rigid-rigid pairs, then their narrow phases. */
static int rigid_pairs(mo_contact *C, const mo_state *s, double t, mo_ctx *ctx)
{
  const mo_scene *sc = C->sc;
  long q;
  int st;
  /* split over the ranks, the list is made before the obstacles' narrow phases (mo_contact_detect) */
  if (!C->pd && (st = pair_list(C, s, ctx))) return st;
  for (q = 0; q < C->vl_n; q++) {
    int i = C->vl[2 * q], j = C->vl[2 * q + 1], r, from = C->nc;
    const unsigned char ci = C->bmask[i], cj = C->bmask[j]; /* the bodies' side classes (T310) */
    unsigned long long ij = C->rcm[ci] & C->rcs[cj], ji = C->rcm[cj] & C->rcs[ci];
    unsigned long long any = ij | ji;
    if (!any) continue;
    /* (split over the ranks, the list holds this rank's pairs only: pair_list, (T341)) */
    /* two balls: their flags and radii from the compact arrays, no body record read (T310) */
    if ((C->dmask[i] & C->dmask[j] & MO_DM_BALL) && balls_apart(C, s, i, j, sc->dim)) continue;
    for (r = 0; !(any >> r & 1ULL); r++) {}
    /* master i, slave j when pair r reads so (for a pair within a group: the lower index) */
    if (ij >> r & 1ULL) st = shape_shape(C, C->rr[r], j, i, s, t, ctx);
    else st = shape_shape(C, C->rr[r], i, j, s, t, ctx);
    if (st) return st;
    if (C->pd && C->smap_from != -2 && C->nc > from && (st = mo_pdetect_tag(C, from, C->npair, i, j, ctx)))
      return st;
  }
  return MO_OK;
}

size_t mo_contact_broad_bytes(const mo_contact *C)
{
  return mo_broad_bytes(C->broad) + mo_vblocks_bytes(C->vb);
}

int mo_contact_broad_blocks(const mo_contact *C, long *made, long *nblock)
{
  mo_vblocks_stats(C->vb, made, nblock);
  return C->vb != NULL;
}

int mo_contact_broad_stats(const mo_contact *C, long *builds, long *pairs)
{
  *builds = C->vl_builds;
  *pairs = C->vl_n;
  return C->nrr > 0;
}

const double *mo_contact_centres(mo_contact *C, const mo_state *s)
{
  const mo_scene *sc = C->sc;
  int b, a, D = sc->dim;
  if (C->pd || !C->bcur) return NULL; /* over ranks only the slab's and halo's are kept */
  if (s->u == C->bcur_u && s->step == C->bcur_step) return C->bcur;
  /* another state (the scene's initial one, which the first geometry is of): body_speed's sums at s,
     which the next detection forms again before it reads them */
  for (b = 0; b < sc->nbody; b++)
    if (C->dmask[b] & MO_DM_RIGID)
      for (a = 0; a < D; a++) C->bcur[(size_t)D * b + a] = sc->body[b].xc0[a] + s->u[C->bdof[b] + a];
  C->bcur_u = s->u;
  C->bcur_step = s->step;
  return C->bcur;
}

int mo_contact_detect(mo_contact *C, const mo_state *s, double t, mo_ctx *ctx)
{
  int k, split, st = MO_OK;
  long from;
  /* the granular path over MPI ranks: each rank its slab's pairs, then every rank's gathered
     (doc/parallel.md §4, (T215)-(T217)) */
  if ((split = mo_pdetect_active(C, ctx)) < 0) return MO_ENOMEM;
  body_speeds(C, s);
  /* the new keys are compared with the old ones as they overwrite them (set_key) */
  C->knold = C->nc;
  C->ksame = 1;
  C->npt = C->npt_static;
  C->nc = C->nc_static;
  C->ncoef = C->ncoef_static;
  /* the granular path writes the remap as it overwrites the keys (-2: under way); over several
     ranks each its part's, merged with the set (T270)-(T271) */
  from = C->cset_version;
  C->smap_from = C->smap_to = -1;
  if (mo_contact_writes_map(C, ctx)) {
    if ((st = mo_setmap_begin(&C->smap, C->krr, C->knold, C->nc_static, ctx))) return st;
    C->smap_from = -2;
  }
  if (split && !(st = pair_list(C, s, ctx))) st = mo_pdetect_begin(C, ctx);
  for (k = 0; k < C->npair && !st; k++) {
    const mo_contact_pair *P = &C->pair[k];
    const mo_body *S, *M;
    if (!P->dynamic || rigid_rigid(C, P)) continue;
    S = &C->sc->body[P->sb[0]];
    M = &C->sc->body[P->mb[0]];
    if ((S->type->flags & MO_BODY_F_MESH) && !(M->type->flags & MO_BODY_F_OBSTACLE)) {
      int i;
      for (i = 0; i < P->nm && !st; i++) st = nodes_shape(C, k, P->mb[i], s, t, ctx);
    } else
      st = shapes_obstacle(C, k, s, t, ctx);
  }
  if (!st && C->nrr) st = rigid_pairs(C, s, t, ctx);
  /* a rank's part out of the order (T220) fails every rank in the gather, not this one alone */
  if (split && !st && C->smap_from == -2 && C->smap.bad)
    st = mo_error(ctx, MO_EINTERNAL, "contact detection: a candidate out of the detection's order (T220)");
  if (split) st = mo_pdetect_finish(C, s, st, ctx);
  if (!st && !(C->ksame && C->nc == C->knold)) C->cset_version++;
  if (split && !st) mo_pdetect_seal(C->pd, C->cset_version); /* the gathered U- are of this set (T301) */
  if (C->smap_from == -2) {
    C->smap_from = C->smap_to = -1;
    if (!st && C->smap.bad)
      st = mo_error(ctx, MO_EINTERNAL, "contact detection: a candidate out of the detection's order (T220)");
    else if (!st) {
      C->smap_from = from;
      C->smap_to = C->cset_version;
    }
  }
  return st;
}

int mo_contact_writes_map(const mo_contact *C, const mo_ctx *ctx)
{
  /* over several ranks too: the whole detection on each (the same as one process), or each its
     part, the parts' maps merged with the set (T270)-(T271) */
  (void)ctx;
  return C->compact && C->smap_ok && C->krr;
}

const int *mo_contact_detect_map(const mo_contact *C, long from, long to)
{
  return C->krr && C->smap_from >= 0 && C->smap_from == from && C->smap_to == to ? C->smap.map : NULL;
}
