/* parallel_detect.c: the granular path's detection split over MPI ranks (doc/parallel.md §4,
   doc/theory.md (T215)-(T217)). At every build of the broad phase's pair list the bodies are cut
   into slabs of equal counts along their largest extent (the same cut on every rank: the same
   replicated positions); a rank runs the broad phase on its slab plus a halo and the narrow phase
   on the pairs it owns (those of its slab's bodies), then the ranks' candidates are gathered into
   the serial detection's order, so that everything after the detection sees the set a single
   process finds. */
#include "config.h"
#include "contact_internal.h"
#include "parallel_detect.h"
#include "partition.h"
#include <moreau/parallel.h>

#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define NTAG MO_PDETECT_NTAG

/* The detection writes the remap (T270): each rank its part's, the blocks carry them (T271). */
static inline int with_map(const mo_contact *C)
{
  return C->smap_from == -2;
}


/* mo_pdetect_boxes with the largest radius given (rmax >= 0: the bodies' state per rank, where a rank
   knows only its own bodies' radii: their maximum over the ranks) and the halo returned. */
static int boxes(int dim, int n, const double *c, const double *r, const unsigned char *mask, double reach, long npts,
                 const double *pts, int nranks, int rank, mo_rcb_tree *T, int *owner, unsigned char *rmask, int *idx,
                 int *ppart, double rmax, double *halo_out)
{
  double lo[3], hi[3], halo;
  int b, k;
  /* (T341) the boxes cut from the points, or (T215), (T330) from the bodies' centres; a body's box
     its centre's */
  if (npts > 0) {
    if (mo_rcb_tree_make(dim, (int)npts, pts, NULL, NULL, nranks, ppart, idx, T) < 0) return -1;
    for (b = 0; b < n; b++) owner[b] = !mask || mask[b] ? mo_rcb_locate(T, c + (size_t)dim * b) : -1;
  } else if (mo_rcb_tree_make(dim, n, c, NULL, mask, nranks, owner, idx, T) < 0)
    return -1;
  if (rmax < 0)
    for (rmax = 0, b = 0; b < n; b++)
      if (owner[b] >= 0 && r[b] > rmax) rmax = r[b];
  /* (T216), (T341): a pair within reach whose point (on the segment between the centres) lies in
     the box has both centres within 2 r_max + reach of it */
  halo = (2 * rmax + reach) * (1 + 1e-9);
  mo_rcb_box(T, rank, lo, hi);
  for (b = 0; b < n; b++) {
    int in = owner[b] >= 0;
    for (k = 0; k < dim && in && owner[b] != rank; k++) {
      const double x = c[(size_t)dim * b + k];
      in = x >= lo[k] - halo && x <= hi[k] + halo;
    }
    rmask[b] = (unsigned char)in;
  }
  if (halo_out) *halo_out = halo;
  return 0;
}

int mo_pdetect_boxes(int dim, int n, const double *c, const double *r, const unsigned char *mask, double reach,
                     long npts, const double *pts, int nranks, int rank, mo_rcb_tree *T, int *owner,
                     unsigned char *rmask, int *idx, int *ppart)
{
  return boxes(dim, n, c, r, mask, reach, npts, pts, nranks, rank, T, owner, rmask, idx, ppart, -1, NULL);
}

void mo_pdetect_free(mo_contact *C)
{
  struct mo_pdetect *P = C->pd;
  if (!P) return;
  mo_free(P->owner);
  mo_free(P->rmask);
  mo_free(P->okey);
  mo_free(P->tag);
  mo_free(P->buf);
  mo_free(P->all);
  mo_free(P->cnt);
  mo_free(P->one);
  mo_free(P->rc);
  mo_free(P->tot);
  mo_free(P->own);
  mo_free(P->near);
  mo_free(P->rest);
  mo_free(P->wall);
  mo_free(P->wall0);
  mo_free(P->up);
  mo_free(P->pts);
  mo_free(P->pidx);
  mo_free(P->ppart);
  mo_free(P->cown);
  mo_free(P->hold);
  mo_free(P->hlist);
  mo_free(P->xlist);
  mo_free(P->xdm);
  mo_free(P->xnb);
  mo_free(P->winv);
  mo_free(P->count);
  mo_free(P->mig_old);
  mo_free(P->mig_box);
  mo_free(P->sh_off);
  mo_free(P->sh_b);
  mo_free(P->mig_m);
  mo_free(P->rlist);
  mo_free(P->mig_s);
  mo_free(P->mig_r);
  mo_free(P->mig_cnt);
  mo_free(P);
  C->pd = NULL;
}

int mo_pdetect_active(mo_contact *C, mo_ctx *ctx)
{
  const mo_scene *sc = C->sc;
  struct mo_pdetect *P;
  int k, r;
  if (ctx->nranks < 2 || !C->compact || !C->nrr || !mo_parallel_started(ctx) || C->pd_whole) return 0;
  if (C->pd) return 1;
  for (k = 0; k < C->npair; k++) {
    const mo_contact_pair *Q = &C->pair[k];
    int rr = 0;
    for (r = 0; r < C->nrr; r++) rr |= C->rr[r] == k;
    if (Q->dynamic && !rr && !(sc->body[Q->mb[0]].type->flags & MO_BODY_F_OBSTACLE)) return 0;
  }
  {
    /* (T337) a small scene is detected whole on every rank: the broad phase's bodies (bmask, those
       of the pairs between rigid shapes), fewer than detect_split_min a rank (the same count on
       every rank: the scene's) */
    long nb = 0;
    for (k = 0; k < sc->nbody; k++) nb += C->bmask[k] != 0;
    if ((double)nb < (double)C->pd_min * ctx->nranks) {
      C->pd_whole = 1;
      mo_note_skip(ctx, "the detection's split over the %d ranks (%ld bodies, fewer than contact.detect_split_min = %d "
                   "a rank: detected whole on every rank, doc/theory.md (T337))", ctx->nranks, nb, C->pd_min);
      if (C->pd_dist)
        mo_note_skip(ctx, "contact.distributed_set: the set is kept whole on every rank, its detection being whole "
                     "(contact.detect_split_min)");
      return 0;
    }
  }
  if (!(P = mo_calloc(ctx, 1, sizeof *P))) return -1;
  C->pd = P;
  P->rank = ctx->rank;
  P->nranks = ctx->nranks;
  if (!(P->owner = mo_malloc(ctx, ((size_t)sc->nbody + 1) * sizeof *P->owner)) ||
      !(P->rmask = mo_calloc(ctx, (size_t)sc->nbody + 1, 1)) ||
      !(P->cnt = mo_malloc(ctx, (size_t)P->nranks * sizeof *P->cnt)) ||
      !(P->one = mo_malloc(ctx, (size_t)P->nranks * sizeof *P->one)) ||
      !(P->rc = mo_malloc(ctx, (size_t)P->nranks * sizeof *P->rc)) ||
      !(P->tot = mo_calloc(ctx, (size_t)P->nranks, sizeof *P->tot)) ||
      !(P->own = mo_malloc(ctx, ((size_t)sc->nbody + 1) * sizeof *P->own)) ||
      !(P->near = mo_malloc(ctx, ((size_t)sc->nbody + 1) * sizeof *P->near)) ||
      !(P->rest = mo_malloc(ctx, ((size_t)sc->nbody + 1) * sizeof *P->rest)) ||
      !(P->wall0 = mo_calloc(ctx, (size_t)C->npair + 1, sizeof *P->wall0))) {
    mo_pdetect_free(C);
    return -1;
  }
  for (r = 0; r < P->nranks; r++) P->one[r] = 1;
  for (k = 0; k < sc->nbody; k++) P->owner[k] = -1;
  P->up_nc = -1;
  return 1;
}

/* Room for n values in *p of capacity *cap. */
static int room(void **p, size_t *cap, size_t n, size_t sz, mo_ctx *ctx)
{
  void *q;
  if (n <= *cap) return MO_OK;
  n += n / 4 + 16;
  if (!(q = mo_realloc(ctx, *p, n * sz))) return MO_ENOMEM;
  *p = q;
  *cap = n;
  return MO_OK;
}

int mo_pdetect_begin(mo_contact *C, mo_ctx *ctx)
{
  struct mo_pdetect *P = C->pd;
  size_t n = C->knold > C->nc ? (size_t)(C->knold - C->nc) : 0;
  int st;
  P->nc0 = C->nc;
  P->knold = C->knold;
  P->ksame = C->ksame;
  if (with_map(C)) return MO_OK; /* the keys compared through the map (mo_pdetect_finish) */
  if ((st = room((void **)&P->okey, &P->okcap, n * MO_KEY + 1, sizeof *P->okey, ctx))) return st;
  if (n) memcpy(P->okey, C->key + (size_t)C->nc * MO_KEY, n * MO_KEY * sizeof *P->okey);
  return MO_OK;
}

/* (T347) mo_rcb_tree_make's tree from the points each rank holds of its own (n of them, D each,
   reordered in place), none gathered: cut by cut, level by level of the recursion, each node's
   count and bounding box (one maximum a level), its histogram along the cut's axis in 64 coarse
   bins (one sum), then the 64 fine bins of the coarse bin the cut falls in (one sum): the counts
   cut() reads are sums of integers, exact, so the cuts are the gathered points' to the bit. */
#define RCB_COARSE 64
static int rcb_tree_dist(int D, long n, double *pts, int nparts, mo_rcb_tree *T, mo_ctx *ctx)
{
  struct nd {
    int q, ni;
    long a, b;
    double lo, w, m;
    int ax, c;
  } cur[MO_RCB_MAXPARTS], nxt[MO_RCB_MAXPARTS];
  const int per = 1 + 2 * D;
  double v[MO_RCB_MAXPARTS * (RCB_COARSE + 1)], before[MO_RCB_MAXPARTS];
  int ncur = 0, k, i, st;
  if (nparts > MO_RCB_MAXPARTS) return -1;
  T->nparts = nparts;
  T->dim = D;
  if (nparts > 1) cur[ncur++] = (struct nd){nparts, 0, 0, n, 0, 1, 0, 0, 0};
  while (ncur) {
    int nnext = 0;
    /* each node's count and box: the maximum of (count, -lo, hi) */
    for (k = 0; k < ncur; k++) {
      double *x = v + (size_t)k * per;
      long t;
      x[0] = (double)(cur[k].b - cur[k].a);
      for (i = 0; i < D; i++) x[1 + i] = x[1 + D + i] = -HUGE_VAL;
      for (t = cur[k].a; t < cur[k].b; t++)
        for (i = 0; i < D; i++) {
          const double c = pts[(size_t)D * t + i];
          if (-c > x[1 + i]) x[1 + i] = -c;
          if (c > x[1 + D + i]) x[1 + D + i] = c;
        }
    }
    if ((st = mo_par_max(v, (long)ncur * per, ctx))) return st;
    for (k = 0; k < ncur; k++) {
      const double *x = v + (size_t)k * per;
      double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
      int ax = 0;
      for (i = 0; i < D; i++) {
        lo[i] = -x[1 + i];
        hi[i] = x[1 + D + i];
      }
      cur[k].m = x[0]; /* 0 when no rank has a point; the sum follows */
      for (i = 1; i < D; i++)
        if (hi[i] - lo[i] > hi[ax] - lo[ax]) ax = i;
      cur[k].ax = ax;
      cur[k].lo = lo[ax];
      cur[k].w = hi[ax] > lo[ax] ? (hi[ax] - lo[ax]) / MO_RCB_BINS : 1;
    }
    /* the coarse histogram and the count */
    for (i = 0; i < ncur * (RCB_COARSE + 1); i++) v[i] = 0;
    for (k = 0; k < ncur; k++) {
      double *h = v + (size_t)k * (RCB_COARSE + 1);
      long t;
      h[RCB_COARSE] = (double)(cur[k].b - cur[k].a);
      if (cur[k].m == 0) continue;
      for (t = cur[k].a; t < cur[k].b; t++)
        h[mo_rcb_bin(pts[(size_t)D * t + cur[k].ax], cur[k].lo, cur[k].w) / (MO_RCB_BINS / RCB_COARSE)]++;
    }
    if ((st = mo_par_sum(v, (long)ncur * (RCB_COARSE + 1), ctx))) return st;
    for (k = 0; k < ncur; k++) {
      const double *h = v + (size_t)k * (RCB_COARSE + 1);
      const long m = (long)h[RCB_COARSE], ql = cur[k].q / 2, q = cur[k].q;
      long cum = 0;
      int c;
      cur[k].m = (double)m;
      cur[k].c = 0;
      if (m == 0) continue;
      /* the first coarse bin whose count before it puts the cut at or before it (cut()'s rule) */
      for (c = 0; c < RCB_COARSE; c++) {
        if (cum * q / m >= ql) break;
        cum += (long)h[c];
      }
      cur[k].c = c; /* the cut in (64 (c - 1), 64 c], or 0 with c = 0 */
      before[k] = c > 0 ? (double)cum - h[c - 1] : 0; /* the count before coarse bin c - 1 */
    }
    /* the fine bins of coarse bin c - 1 */
    for (i = 0; i < ncur * RCB_COARSE; i++) v[i] = 0;
    for (k = 0; k < ncur; k++) {
      double *h = v + (size_t)k * RCB_COARSE;
      const int b0 = (cur[k].c - 1) * (MO_RCB_BINS / RCB_COARSE);
      long t;
      if (cur[k].m == 0 || cur[k].c == 0) continue;
      for (t = cur[k].a; t < cur[k].b; t++) {
        const int b = mo_rcb_bin(pts[(size_t)D * t + cur[k].ax], cur[k].lo, cur[k].w);
        if (b >= b0 && b < b0 + RCB_COARSE) h[b - b0]++;
      }
    }
    if ((st = mo_par_sum(v, (long)ncur * RCB_COARSE, ctx))) return st;
    {
      struct nd child[2 * MO_RCB_MAXPARTS];
      int nchild = 0;
      for (k = 0; k < ncur; k++) {
        mo_rcb_node *N = &T->node[cur[k].ni];
        const long m = (long)cur[k].m, ql = cur[k].q / 2, q = cur[k].q;
        long t, nl = cur[k].a;
        int bcut;
        if (m == 0) {
          N->ax = 0;
          N->lo = 0;
          N->w = 1;
          bcut = MO_RCB_BINS + 1;
        } else if (cur[k].c == 0)
          bcut = 0;
        else {
          const double *h = v + (size_t)k * RCB_COARSE;
          const int b0 = (cur[k].c - 1) * (MO_RCB_BINS / RCB_COARSE);
          long cum = (long)before[k];
          for (bcut = b0 + 1; bcut < b0 + RCB_COARSE; bcut++) {
            cum += (long)h[bcut - 1 - b0];
            if (cum * q / m >= ql) break;
          }
        }
        if (m) {
          N->ax = cur[k].ax;
          N->lo = cur[k].lo;
          N->w = cur[k].w;
        }
        N->bcut = bcut;
        /* this rank's points below the cut first */
        for (t = cur[k].a; t < cur[k].b; t++)
          if (m && mo_rcb_bin(pts[(size_t)D * t + N->ax], N->lo, N->w) < bcut) {
            double tmp[3];
            memcpy(tmp, pts + (size_t)D * nl, (size_t)D * sizeof *tmp);
            memcpy(pts + (size_t)D * nl, pts + (size_t)D * t, (size_t)D * sizeof *tmp);
            memcpy(pts + (size_t)D * t, tmp, (size_t)D * sizeof *tmp);
            nl++;
          }
        if (!m) nl = cur[k].b; /* empty everywhere: every point (none) below */
        child[nchild++] = (struct nd){(int)ql, cur[k].ni + 1, cur[k].a, nl, 0, 1, 0, 0, 0};
        child[nchild++] = (struct nd){(int)(q - ql), cur[k].ni + (int)ql, nl, cur[k].b, 0, 1, 0, 0, 0};
      }
      for (k = 0; k < nchild; k++)
        if (child[k].q > 1) nxt[nnext++] = child[k];
    }
    memcpy(cur, nxt, (size_t)nnext * sizeof *cur);
    ncur = nnext;
  }
  return 0;
}

int mo_pdetect_tree_dist(int D, long n, double *pts, int nparts, mo_rcb_tree *T, mo_ctx *ctx)
{
  return rcb_tree_dist(D, n, pts, nparts, T, ctx);
}

/* (T341) The boxes of a build (mo_pdetect_boxes): cut from the points (mo_pdetect_point's, at
   this build's centres) of the candidates active in the driver's last solve, the points the
   sweep's parts balance, when there are at least MO_PDETECT_PTS a rank, else from the bodies'
   centres. The same data on every rank, so the same boxes. */
#define MO_PDETECT_PTS 16
static int build_boxes(mo_contact *C, int nold, mo_ctx *ctx)
{
  struct mo_pdetect *P = C->pd;
  const mo_scene *sc = C->sc;
  const int D = sc->dim;
  long np = 0;
  int i, centres = 0;
  double rmax = -1;
  const size_t need = (size_t)(C->knold > sc->nbody ? C->knold : sc->nbody) + 1;
  if (room((void **)&P->pts, &P->ptcap, need * (size_t)D, sizeof *P->pts, ctx) ||
      room((void **)&P->pidx, &P->pidxcap, need, sizeof *P->pidx, ctx) ||
      room((void **)&P->ppart, &P->ppartcap, need, sizeof *P->ppart, ctx))
    return MO_ENOMEM;
  /* the last solve's active candidates (still the keys from nc_static to knold: the detection
     writes the new set after the build) */
  if (C->act_of && C->act_set == C->cset_version)
    for (i = C->nc_static; i < C->knold; i++) {
      const int *key = C->key + (size_t)i * MO_KEY, s = key[1], m = key[2];
      const int si = s >= 0 && s < sc->nbody && C->bmask[s], mi = m >= 0 && m < sc->nbody && C->bmask[m];
      if (!C->act_of[i] || (!si && !mi)) continue;
      /* against an obstacle the shape's own centre (i == j) */
      mo_pdetect_point(D, C->bc, C->bR, si ? s : m, mi ? m : s, P->pts + (size_t)D * np++);
    }
  if (P->held) {
    /* the bodies' state per rank: the largest radius over the ranks' own bodies (the others' are
       not current here); with too few points, the own bodies' centres gathered as the points */
    long tot = np;
    rmax = 0;
    for (i = 0; i < nold; i++)
      if (C->br[P->mig_old[i]] > rmax) rmax = C->br[P->mig_old[i]];
    {
      double v[2] = {rmax, 0};
      int st;
      if ((st = mo_par_max(v, 1, ctx))) return st;
      rmax = v[0];
      v[0] = (double)np;
      if ((st = mo_par_sum(v, 1, ctx))) return st;
      tot = (long)v[0];
    }
    if (tot < (long)MO_PDETECT_PTS * P->nranks) {
      for (np = 0; np < nold; np++)
        memcpy(P->pts + (size_t)D * np, C->bc + (size_t)D * P->mig_old[np], (size_t)D * sizeof *P->pts);
      centres = 1;
    }
    /* (T347) the boxes cut from every rank's points without gathering them; each own body's box */
    ctx->par_detect_builds++;
    if (!centres) ctx->par_detect_boxpts++;
    {
      int st = rcb_tree_dist(D, np, P->pts, P->nranks, &P->tree, ctx);
      if (st < 0)
        return mo_error(ctx, MO_ELIMIT, "contact detection over %d ranks (at most %d)", P->nranks, MO_RCB_MAXPARTS);
      if (st) return st;
    }
    for (i = 0; i < nold; i++) P->owner[P->mig_old[i]] = mo_rcb_locate(&P->tree, C->bc + (size_t)D * P->mig_old[i]);
    P->halo = (2 * rmax + C->vl_reach) * (1 + 1e-9);
    return MO_OK;
  }
  if (C->pd_dist) {
    /* the distributed set: each rank holds its own candidates' activities, the points gathered
       (every rank cuts the same boxes from the same points, in the ranks' order) */
    int st, r;
    long tot = 0;
    double mine = (double)(np * D);
    if ((st = mo_par_gatherv(&mine, P->one, P->rc, ctx))) return st;
    for (r = 0; r < P->nranks; r++) {
      P->cnt[r] = (int)P->rc[r];
      tot += (long)P->rc[r];
    }
    if ((st = room((void **)&P->all, &P->allcap, (size_t)tot + 1, sizeof *P->all, ctx)) ||
        (st = room((void **)&P->pidx, &P->pidxcap, (size_t)tot / D + (size_t)sc->nbody + 1, sizeof *P->pidx, ctx)) ||
        (st = room((void **)&P->ppart, &P->ppartcap, (size_t)tot / D + (size_t)sc->nbody + 1, sizeof *P->ppart, ctx)) ||
        (st = mo_par_gatherv(P->pts, P->cnt, P->all, ctx)))
      return st;
    if ((st = room((void **)&P->pts, &P->ptcap, (size_t)tot + 1, sizeof *P->pts, ctx))) return st;
    memcpy(P->pts, P->all, (size_t)tot * sizeof *P->pts);
    np = tot / D;
  }
  ctx->par_detect_builds++;
  if (np < (long)MO_PDETECT_PTS * P->nranks) np = 0; /* too few: the bodies' centres */
  else ctx->par_detect_boxpts++;
  if (boxes(D, sc->nbody, C->bc, C->br, C->bmask, C->vl_reach, np, P->pts, P->nranks, P->rank, &P->tree, P->owner,
            P->rmask, P->pidx, P->ppart, rmax, &P->halo) < 0)
    return mo_error(ctx, MO_ELIMIT, "contact detection over %d ranks (at most %d)", P->nranks, MO_RCB_MAXPARTS);
  return MO_OK;
}

/* --- the bodies' state per rank (doc/theory.md §13.18) --------------------------------------------- */

/* Whether the scene's bodies can be held per rank: the distributed set, rigid bodies and obstacles
   only, every dof free (no prescribed motion to follow, whose reactions every rank would sum), no
   step cutting (a cut step's state is restored from a copy the builds of the cut step did not
   write), at most 52 ranks (the hold masks travel in doubles). The same answer on every rank. */
static int held_eligible(const mo_contact *C, const mo_ctx *ctx)
{
  const mo_scene *sc = C->sc;
  return C->pd_dist && sc->nfe_dof == 0 && sc->nfree == sc->ndof && ctx->nranks <= 52 && sc->nrigid > 0 &&
         sc->time.max_cuts <= 0;
}

/* The ranks whose boxes grown by the halo hold the centre c of a body whose box is `owner` (the
   test of boxes(), so that a rank holds a body exactly when its own mask says so). */
static unsigned long long holders(const struct mo_pdetect *P, int D, const double *c, int owner)
{
  unsigned long long m = 0;
  double lo[3], hi[3];
  int k, i;
  for (k = 0; k < P->nranks; k++) {
    int in = 1;
    if (k != owner) {
      mo_rcb_box(&P->tree, k, lo, hi);
      for (i = 0; i < D && in; i++) in = c[i] >= lo[i] - P->halo && c[i] <= hi[i] + P->halo;
    }
    if (in) m |= 1ULL << k;
  }
  return m;
}

/* A body's record: its index, box, hold mask, then u, v and f_ext of its dofs (and a: Newmark), and
   its orientation (3D). */
static int record_size(const mo_scene *sc, const mo_state *s)
{
  const int nd = sc->dim == 3 ? 6 : 3;
  return 3 + nd * (s->a ? 4 : 3) + (sc->dim == 3 ? 4 : 0);
}

static void record_pack(const mo_scene *sc, const mo_state *s, int b, int owner, unsigned long long m, double *x)
{
  const mo_body *B = &sc->body[b];
  const int nd = sc->dim == 3 ? 6 : 3;
  int i, k = 3;
  x[0] = b;
  x[1] = owner;
  x[2] = (double)m;
  for (i = 0; i < nd; i++) x[k++] = s->u[B->dof0 + i];
  for (i = 0; i < nd; i++) x[k++] = s->v[B->dof0 + i];
  for (i = 0; i < nd; i++) x[k++] = s->f[B->dof0 + i];
  for (i = 0; i < nd && s->a; i++) x[k++] = s->a[B->dof0 + i];
  for (i = 0; i < 4 && sc->dim == 3; i++) x[k++] = s->orient[4 * (size_t)B->orient + i];
}

static int record_unpack(const mo_scene *sc, mo_state *s, const double *x, int *owner, unsigned long long *m)
{
  const int b = (int)x[0], nd = sc->dim == 3 ? 6 : 3;
  const mo_body *B = &sc->body[b];
  int i, k = 3;
  *owner = (int)x[1];
  *m = (unsigned long long)x[2];
  for (i = 0; i < nd; i++) s->u[B->dof0 + i] = x[k++];
  for (i = 0; i < nd; i++) s->v[B->dof0 + i] = x[k++];
  for (i = 0; i < nd; i++) s->f[B->dof0 + i] = x[k++];
  for (i = 0; i < nd && s->a; i++) s->a[B->dof0 + i] = x[k++];
  for (i = 0; i < 4 && sc->dim == 3; i++) s->orient[4 * (size_t)B->orient + i] = x[k++];
  return b;
}

/* The tests' check that no rank reads a body it does not hold (MOREAU_TEST_POISON_UNHELD set): the
   state of every such body made NaN, so that a read of it shows (a NaN stops the run where a check
   sees it, or parts the results from the serial run's). Not at step 0, where
   every rank's state is still whole and current (the run's initial energies and momenta read it). */
static void poison_unheld(mo_contact *C, mo_state *s)
{
  const mo_scene *sc = C->sc;
  const int nd = sc->dim == 3 ? 6 : 3;
  const char *e = getenv("MOREAU_TEST_POISON_UNHELD");
  int b, i;
  if (!e || !*e || !s || s->step == 0) return;
  for (b = 0; b < sc->nbody; b++) {
    const mo_body *B = &sc->body[b];
    if (!C->bmask[b] || C->pd->rmask[b]) continue;
    for (i = 0; i < nd; i++) s->u[B->dof0 + i] = s->v[B->dof0 + i] = s->f[B->dof0 + i] = NAN;
    for (i = 0; i < nd && s->a; i++) s->a[B->dof0 + i] = NAN;
    for (i = 0; i < 4 && sc->dim == 3; i++) s->orient[4 * (size_t)B->orient + i] = NAN;
  }
}

/* The lists that follow the hold: the bodies this rank holds, ascending, and those it counts. */
static int cmp_int(const void *a, const void *b)
{
  int x = *(const int *)a, y = *(const int *)b;
  return x < y ? -1 : x > y;
}

/* first: every body looked at (the first build; the outside bodies' list made); else the held list
   from the old own bodies still held (mig_old with their boxes in mig_box), those received (rlist)
   and the bodies outside the broad phase, sorted: no pass over every body. */
static int hold_lists(mo_contact *C, int first, int nold, mo_ctx *ctx)
{
  struct mo_pdetect *P = C->pd;
  const mo_scene *sc = C->sc;
  const unsigned long long all = P->nranks >= 64 ? ~0ULL : (1ULL << P->nranks) - 1;
  int b;
  int k, q, *off = P->sh_off;
  if (first) {
    P->nhlist = P->nxlist = P->nxdm = P->nxnb = 0;
    for (b = 0; b < sc->nbody; b++) {
      if (!C->bmask[b]) {
        P->xnb[P->nxnb++] = b;
        /* outside the broad phase: every rank's, counted by rank 0 */
        P->hold[b] = all;
        P->count[b] = P->rank == 0;
        if (C->dmask[b]) P->xdm[P->nxdm++] = b;
        if ((sc->body[b].type->flags & MO_BODY_F_RIGID) && !sc->body[b].fixed) {
          P->hlist[P->nhlist++] = b;
          P->xlist[P->nxlist++] = b;
        }
        continue;
      }
      P->count[b] = P->owner[b] == P->rank;
      if (P->rmask[b]) P->hlist[P->nhlist++] = b;
    }
  } else {
    for (k = 0; k < P->nhlist; k++)
      if (C->bmask[P->hlist[k]]) P->count[P->hlist[k]] = 0;
    /* three ascending lists merged: the old own bodies kept (the own list's order), those received
       (each sender's block ascending: sorted), those outside */
    int a = 0, r = 0, x = 0;
    qsort(P->rlist, (size_t)P->nrecv, sizeof *P->rlist, cmp_int);
    P->nhlist = 0;
    for (;;) {
      int ba, br, bx, m;
      while (a < nold && P->mig_box[a] == -3) a++;
      ba = a < nold ? P->mig_old[a] : INT_MAX;
      br = r < P->nrecv ? P->rlist[r] : INT_MAX;
      bx = x < P->nxlist ? P->xlist[x] : INT_MAX;
      m = ba < br ? (ba < bx ? ba : bx) : (br < bx ? br : bx);
      if (m == INT_MAX) break;
      P->hlist[P->nhlist++] = m;
      if (m == ba) a++;
      else if (m == br) r++;
      else x++;
    }
    for (k = 0; k < P->nhlist; k++)
      if (C->bmask[P->hlist[k]]) P->count[P->hlist[k]] = P->owner[P->hlist[k]] == P->rank;
  }
  /* per other rank, the held bodies it holds too, ascending (the same list on both sides) */
  for (q = 0; q <= P->nranks; q++) off[q] = 0;
  for (k = 0; k < P->nhlist; k++) {
    const unsigned long long m = P->hold[P->hlist[k]] & ~(1ULL << P->rank);
    for (q = 0; q < P->nranks; q++) off[q + 1] += (int)(m >> q & 1);
  }
  for (q = 0; q < P->nranks; q++) off[q + 1] += off[q];
  if (room((void **)&P->sh_b, &P->sh_bcap, (size_t)off[P->nranks] + 1, sizeof *P->sh_b, ctx)) return MO_ENOMEM;
  for (q = 0; q < P->nranks; q++) P->sh_at[q] = off[q];
  for (k = 0; k < P->nhlist; k++) {
    const unsigned long long m = P->hold[P->hlist[k]] & ~(1ULL << P->rank);
    for (q = 0; q < P->nranks; q++)
      if (m >> q & 1) P->sh_b[P->sh_at[q]++] = P->hlist[k];
  }
  return MO_OK;
}

static int held_start(mo_contact *C, mo_state *s, mo_ctx *ctx)
{
  struct mo_pdetect *P = C->pd;
  const mo_scene *sc = C->sc;
  int b, st;
  if (!(P->hold = mo_calloc(ctx, (size_t)sc->nbody + 1, sizeof *P->hold)) ||
      !(P->hlist = mo_malloc(ctx, ((size_t)sc->nbody + 1) * sizeof *P->hlist)) ||
      !(P->xlist = mo_malloc(ctx, ((size_t)sc->nbody + 1) * sizeof *P->xlist)) ||
      !(P->xdm = mo_malloc(ctx, ((size_t)sc->nbody + 1) * sizeof *P->xdm)) ||
      !(P->xnb = mo_malloc(ctx, ((size_t)sc->nbody + 1) * sizeof *P->xnb)) ||
      !(P->count = mo_calloc(ctx, (size_t)sc->nbody + 1, 1)) ||
      !(P->mig_old = mo_malloc(ctx, ((size_t)sc->nbody + 1) * sizeof *P->mig_old)) ||
      !(P->mig_box = mo_malloc(ctx, ((size_t)sc->nbody + 1) * sizeof *P->mig_box)) ||
      !(P->mig_m = mo_malloc(ctx, ((size_t)sc->nbody + 1) * sizeof *P->mig_m)) ||
      !(P->mig_cnt = mo_calloc(ctx, 7 * (size_t)P->nranks + 2, sizeof *P->mig_cnt)) ||
      !(P->sh_off = mo_calloc(ctx, 2 * (size_t)P->nranks + 2, sizeof *P->sh_off)))
    return MO_ENOMEM;
  P->sh_at = P->sh_off + P->nranks + 1;
  {
    /* per pair, each body's index among its slaves (the wall lists from the own bodies); left out
       when a pair lists a body twice (the lists then looked for over every slave) */
    size_t tot = (size_t)C->npair * sc->nbody;
    int k, i, twice = 0;
    if (!(P->winv = mo_malloc(ctx, (tot + 1) * sizeof *P->winv))) return MO_ENOMEM;
    for (i = 0; i < (int)tot; i++) P->winv[i] = -1;
    for (k = 0; k < C->npair && !twice; k++)
      for (i = 0; i < C->pair[k].ns; i++) {
        int *w = P->winv + (size_t)k * sc->nbody + C->pair[k].sb[i];
        if (C->pair[k].sb[i] < 0 || C->pair[k].sb[i] >= sc->nbody) continue;
        if (*w >= 0) twice = 1;
        *w = i;
      }
    if (twice) {
      mo_free(P->winv);
      P->winv = NULL;
    }
    /* each pair's slaves in the bodies' order (a group's): the own bodies' indices come ascending */
    P->winv_up = 1;
    for (k = 0; k < C->npair && P->winv_up; k++)
      for (i = 1; i < C->pair[k].ns && P->winv_up; i++) P->winv_up = C->pair[k].sb[i] > C->pair[k].sb[i - 1];
  }
  /* every rank holds every body now: each its box's and halo's from here on */
  for (b = 0; b < sc->nbody; b++)
    if (C->bmask[b] && P->rmask[b]) P->hold[b] = holders(P, sc->dim, C->bc + (size_t)sc->dim * b, P->owner[b]);
  P->held = 1;
  ctx->par_held = 1;
  P->nrecv = 0;
  if ((st = hold_lists(C, 1, 0, ctx))) return st;
  poison_unheld(C, s);
  return MO_OK;
}

/* At a build: each body this rank owned at the last build (its centre in its box then; mig_old) goes
   to the ranks that hold it now, its state with it; the others' bodies arrive. Then this rank's mask
   and boxes of the bodies are those the records say (a body it does not hold: owner -2). */
static int migrate(mo_contact *C, mo_state *s, int nold, mo_ctx *ctx)
{
  struct mo_pdetect *P = C->pd;
  const mo_scene *sc = C->sc;
  const int D = sc->dim, np = P->nranks, me = P->rank, R = record_size(sc, s);
  int *scnt = P->mig_cnt, *rcnt = scnt + np, *soff = rcnt + np, *roff = soff + np + 1;
  int i, k, b, st, nsend = 0, nrecv = 0;
  double *cs, *cr;
  long ts = 0, tr = 0;
  /* the counts */
  for (k = 0; k < np; k++) scnt[k] = 0;
  for (i = 0; i < nold; i++) {
    const unsigned long long m = holders(P, D, C->bc + (size_t)D * P->mig_old[i], P->owner[P->mig_old[i]]);
    P->mig_m[i] = m;
    for (k = 0; k < np; k++)
      if (k != me && (m >> k & 1)) scnt[k]++;
  }
  if (!(cs = mo_malloc(ctx, 2 * (size_t)np * sizeof *cs))) return MO_ENOMEM;
  cr = cs + np;
  for (k = 0; k < np; k++) cs[k] = scnt[k];
  if ((st = mo_par_alltoall(cs, cr, ctx))) {
    mo_free(cs);
    return st;
  }
  for (k = 0; k < np; k++) {
    rcnt[k] = (int)cr[k];
    ts += scnt[k];
    tr += rcnt[k];
  }
  mo_free(cs);
  if (room((void **)&P->mig_s, &P->mig_scap, (size_t)(ts * R) + 1, sizeof *P->mig_s, ctx) ||
      room((void **)&P->mig_r, &P->mig_rcap, (size_t)(tr * R) + 1, sizeof *P->mig_r, ctx) ||
      room((void **)&P->rlist, &P->rlistcap, (size_t)tr + 1, sizeof *P->rlist, ctx))
    return MO_ENOMEM;
  /* the peers and their offsets (values), then the records in the ranks' blocks */
  {
    int *speer = roff + np + 1, *rpeer = speer + np, *sat = rpeer + np;
    int so = 0, ro = 0;
    for (k = 0; k < np; k++) {
      sat[k] = so;
      if (scnt[k]) {
        speer[nsend] = k;
        soff[nsend++] = so;
        so += scnt[k] * R;
      }
      if (rcnt[k]) {
        rpeer[nrecv] = k;
        roff[nrecv++] = ro;
        ro += rcnt[k] * R;
      }
    }
    soff[nsend] = so;
    roff[nrecv] = ro;
    for (i = 0; i < nold; i++) {
      const int bb = P->mig_old[i], o = P->owner[bb];
      const unsigned long long m = P->mig_m[i];
      for (k = 0; k < np; k++)
        if (k != me && (m >> k & 1)) {
          record_pack(sc, s, bb, o, m, P->mig_s + sat[k]);
          sat[k] += R;
        }
    }
    if ((st = mo_par_exchangev(nsend, speer, soff, P->mig_s, nrecv, rpeer, roff, P->mig_r, ctx))) return st;
  }
  ctx->par_state_moved += ts;
  /* this rank's mask and boxes from the records: its own old bodies it still holds, and those it
     received (written into the state) */
  for (i = 0; i < nold; i++) P->mig_box[i] = P->mig_m[i] >> me & 1 ? P->owner[P->mig_old[i]] : -3;
  for (i = 0; i < P->nhlist; i++) /* the bodies held until now (no other's mask is set) */
    if (C->bmask[b = P->hlist[i]]) {
      P->rmask[b] = 0;
      P->owner[b] = -2;
    }
  for (i = 0; i < nold; i++) {
    const int bb = P->mig_old[i];
    if (P->mig_box[i] == -3) continue; /* no longer held here */
    P->owner[bb] = P->mig_box[i];
    P->hold[bb] = P->mig_m[i];
    P->rmask[bb] = 1;
  }
  for (i = 0; i < (int)tr; i++) {
    int o;
    unsigned long long m;
    b = record_unpack(sc, s, P->mig_r + (size_t)i * R, &o, &m);
    P->owner[b] = o;
    P->hold[b] = m;
    P->rmask[b] = 1;
    P->rlist[i] = b;
  }
  P->nrecv = (int)tr;
  if ((st = hold_lists(C, 0, nold, ctx))) return st;
  poison_unheld(C, s);
  return MO_OK;
}

int mo_contact_held_shared(const mo_contact *C, const int **off, const int **b)
{
  const struct mo_pdetect *P = C->pd;
  if (!P || !P->held) return 0;
  *off = P->sh_off;
  *b = P->sh_b;
  return 1;
}

int mo_contact_held(const mo_contact *C, const unsigned long long **hold, const int **hlist, int *nhlist,
                    const unsigned char **count)
{
  const struct mo_pdetect *P = C->pd;
  if (!P || !P->held) return 0;
  if (hold) *hold = P->hold;
  if (hlist) *hlist = P->hlist;
  if (nhlist) *nhlist = P->nhlist;
  if (count) *count = P->count;
  return 1;
}

int mo_contact_state_join(mo_contact *C, mo_state *s, mo_ctx *ctx)
{
  struct mo_pdetect *P = C->pd;
  const mo_scene *sc = C->sc;
  int i, k, st, R, n;
  long tot = 0;
  double mine;
  if (!P || !P->held) return MO_OK;
  R = record_size(sc, s);
  n = P->nown;
  if (room((void **)&P->mig_s, &P->mig_scap, (size_t)n * R + 1, sizeof *P->mig_s, ctx)) return MO_ENOMEM;
  for (i = 0; i < P->nown; i++)
    record_pack(sc, s, P->own[i], P->rank, P->hold[P->own[i]], P->mig_s + (size_t)i * R);
  mine = (double)n * R;
  if ((st = mo_par_gatherv(&mine, P->one, P->rc, ctx))) return st;
  for (k = 0; k < P->nranks; k++) {
    P->cnt[k] = (int)P->rc[k];
    tot += P->cnt[k];
  }
  if (room((void **)&P->mig_r, &P->mig_rcap, (size_t)tot + 1, sizeof *P->mig_r, ctx)) return MO_ENOMEM;
  if ((st = mo_par_gatherv(P->mig_s, P->cnt, P->mig_r, ctx))) return st;
  for (i = 0; i < (int)(tot / R); i++) {
    /* every body's state as its owner has it; what this rank holds stays as its masks say */
    int o;
    unsigned long long m;
    record_unpack(sc, s, P->mig_r + (size_t)i * R, &o, &m);
  }
  ctx->par_state_joins++;
  return MO_OK;
}

int mo_pdetect_received(const struct mo_pdetect *P, const int **b)
{
  *b = P->rlist;
  return P->nrecv;
}

int mo_pdetect_build(mo_contact *C, const mo_state *s, mo_ctx *ctx)
{
  struct mo_pdetect *P = C->pd;
  const mo_scene *sc = C->sc;
  size_t nw = 0;
  int b, k, i, st, nold = 0;
  /* the bodies' state per rank: the senders of this build are the bodies this rank owned at the last */
  if (P->held) {
    memcpy(P->mig_old, P->own, (size_t)P->nown * sizeof *P->mig_old);
    nold = P->nown;
  }
  if ((st = build_boxes(C, nold, ctx))) return st;
  P->nrecv = 0;
  if (P->held) {
    /* the state the detection reads is the caller's own (contact_finish's): the bodies received
       are written into it */
    if ((st = migrate(C, (mo_state *)s, nold, ctx))) return st;
  } else if (held_eligible(C, ctx) && (st = held_start(C, (mo_state *)s, ctx)))
    return st;
  /* (T230): the bodies whose validity this rank decides, whose speeds it needs, and the others */
  P->nown = P->nnear = P->nrest = 0;
  if (P->held) {
    /* the bodies' state per rank: from the held bodies (and the dynamic ones outside the broad
       phase); no other body's speed is needed here */
    for (k = 0; k < P->nhlist; k++) {
      b = P->hlist[k];
      if (!C->bmask[b]) continue;
      if (P->owner[b] == P->rank) P->own[P->nown++] = b;
      if (C->dmask[b]) P->near[P->nnear++] = b;
    }
    for (k = 0; k < P->nxdm; k++) P->near[P->nnear++] = P->xdm[k];
  } else
    for (b = 0; b < sc->nbody; b++) {
      if (C->bmask[b] && P->owner[b] == P->rank) P->own[P->nown++] = b;
      if (!C->dmask[b]) continue;
      if (!C->bmask[b] || P->rmask[b]) P->near[P->nnear++] = b;
      else P->rest[P->nrest++] = b;
    }
  /* (T231): per pair, the shapes of this rank's slab */
  for (k = 0; k < C->npair; k++) nw += (size_t)C->pair[k].ns;
  if (room((void **)&P->wall, &P->wallcap, nw + 1, sizeof *P->wall, ctx)) return MO_ENOMEM;
  if (P->held && P->winv) {
    /* the bodies' state per rank: from the own bodies (and rank 0's outside the broad phase) by
       each pair's index of its slaves, no pass over every slave */
    for (k = 0, nw = 0; k < C->npair; k++) {
      const int *inv = P->winv + (size_t)k * sc->nbody;
      P->wall0[k] = (int)nw;
      for (i = 0; i < P->nown; i++)
        if (inv[P->own[i]] >= 0) P->wall[nw++] = inv[P->own[i]];
      for (i = 0; i < P->nxnb && P->rank == 0; i++)
        if (inv[P->xnb[i]] >= 0 && P->owner[P->xnb[i]] == -1) P->wall[nw++] = inv[P->xnb[i]];
      if (!P->winv_up) qsort(P->wall + P->wall0[k], nw - (size_t)P->wall0[k], sizeof *P->wall, cmp_int);
    }
  } else
    for (k = 0, nw = 0; k < C->npair; k++) {
      P->wall0[k] = (int)nw;
      for (i = 0; i < C->pair[k].ns; i++)
        if (mo_pdetect_owns(P, C->pair[k].sb[i])) P->wall[nw++] = i;
    }
  P->wall0[C->npair] = (int)nw;
  return MO_OK;
}

const unsigned char *mo_pdetect_mask(const mo_contact *C) { return C->pd->rmask; }

int mo_contact_distributed(const mo_contact *C) { return C->pd != NULL && C->pd_dist; }

const int *mo_contact_detect_owners(const mo_contact *C)
{
  const struct mo_pdetect *P = C->pd;
  return P && P->cown && P->cown_set == C->cset_version ? P->cown : NULL;
}



int mo_pdetect_tag(mo_contact *C, int from, int s0, int s1, int s2, mo_ctx *ctx)
{
  struct mo_pdetect *P = C->pd;
  size_t a;
  int st;
  if (with_map(C)) return MO_OK; /* the keys give the order (T271) */
  if ((st = room((void **)&P->tag, &P->tagcap, (size_t)(C->nc - P->nc0) * NTAG + 1, sizeof *P->tag, ctx))) return st;
  for (a = (size_t)(from - P->nc0); a < (size_t)(C->nc - P->nc0); a++) {
    P->tag[NTAG * a] = s0;
    P->tag[NTAG * a + 1] = s1;
    P->tag[NTAG * a + 2] = s2;
  }
  return MO_OK;
}

/* A rank's block in the gather (T232): its n candidates field by field, each field a copy of
   the rank's contiguous part of the set's arrays: points, frames, gaps, obstacle velocities (when
   stored), U- at the detection's state (T300), then the order keys, keys (ints) and the
   activities (bytes), padded to doubles. When the detection writes the remap (T271) the order is
   the keys' own (T220), and in place of the order keys each candidate's place in the previous
   set. */
struct block {
  double *x, *frame, *g, *U0, *up;
  int *tag, *key, *map;
  unsigned char *active;
};


/* The doubles of a block of n candidates. */
static size_t block_size(const mo_contact *C, size_t n)
{
  const size_t D = (size_t)C->sc->dim, d = (size_t)C->dim;
  /* of the frame, its normal alone on the granular path (T225) */
  const size_t f = (size_t)mo_contact_fstride(C);
  size_t bytes = n * (8 * (D + f + 1 + (C->U0 ? d : 0) + d) + 4 * ((with_map(C) ? 1 : NTAG) + MO_KEY) + 1);
  return (bytes + 7) / 8;
}

/* The fields of the block of n candidates at v. */
static struct block block_at(const mo_contact *C, double *v, size_t n)
{
  const size_t D = (size_t)C->sc->dim, d = (size_t)C->dim, f = (size_t)mo_contact_fstride(C);
  struct block B;
  B.x = v;
  B.frame = B.x + n * D;
  B.g = B.frame + n * f;
  B.U0 = B.g + n;
  B.up = B.U0 + (C->U0 ? n * d : 0);
  B.tag = (int *)(B.up + n * d);
  B.key = B.tag + (with_map(C) ? 0 : n * NTAG);
  B.map = B.key + n * MO_KEY;
  B.active = (unsigned char *)(B.map + (with_map(C) ? n : 0));
  return B;
}

/* m candidates from i of block B into the set's candidates from a (to == 0: the other way, the
   set's candidates from a into B's from i). */
static void copy_fields(mo_contact *C, const struct block *B, size_t i, size_t a, size_t m, int to)
{
  const size_t D = (size_t)C->sc->dim, d = (size_t)C->dim;
#define FIELD(dst, src, w) \
  do { \
    if (to) memcpy((dst) + a * (w), (src) + i * (w), m * (w) * sizeof *(dst)); \
    else memcpy((src) + i * (w), (dst) + a * (w), m * (w) * sizeof *(dst)); \
  } while (0)
  FIELD(C->x, B->x, D);
  FIELD(C->frame, B->frame, (size_t)mo_contact_fstride(C));
  FIELD(C->g, B->g, 1);
  if (C->U0) FIELD(C->U0, B->U0, d);
  FIELD(C->pd->up, B->up, d);
  FIELD(C->key, B->key, (size_t)MO_KEY);
  /* each candidate's place in the previous set, found by its rank against the whole previous set
     (replicated): it moves with the candidate (T271) */
  if (with_map(C)) FIELD(C->smap.map, B->map, 1);
  FIELD(C->active, B->active, 1);
#undef FIELD
}

/* Candidate h of block B's place in the serial detection's order: its order key (T217), or with
   the remap its key's order (T220), the same order then (a pair's slaves in increasing index,
   smap_ok); packed as (T220)'s, the order keys' ints being >= 0 */
static inline mo_setmap_ord order_at(const mo_contact *C, const struct block *B, size_t h)
{
  mo_setmap_ord o;
  const int *t = B->tag + h * NTAG;
  if (with_map(C)) return mo_setmap_order(C->krr, B->key + h * MO_KEY);
  o.hi = (unsigned long long)(unsigned)t[0] << 32 | (unsigned)t[1];
  o.lo = (unsigned long long)(unsigned)t[2] << 32;
  return o;
}

/* Every rank's count of candidates (n here, or -1 when st: then every rank fails) in P->rc, and the
   run's counts; *total their sum. */
static int gather_counts(mo_contact *C, size_t n, int st, size_t *total, mo_ctx *ctx)
{
  struct mo_pdetect *P = C->pd;
  double mine = st ? -1 : (double)n, largest = 0;
  int r, st2;
  *total = 0;
  if ((st2 = mo_par_gatherv(&mine, P->one, P->rc, ctx))) return st ? st : st2;
  for (r = 0; r < P->nranks; r++)
    if (P->rc[r] < 0) return st ? st : mo_error(ctx, MO_EINPUT, "contact detection failed on rank %d", r);
  if (P->nranks > 64) return mo_error(ctx, MO_ELIMIT, "contact detection over %d ranks (at most 64)", P->nranks);
  for (r = 0; r < P->nranks; r++) {
    *total += (size_t)P->rc[r];
    P->tot[r] += (long)P->rc[r];
    if ((double)P->tot[r] > largest) largest = (double)P->tot[r];
  }
  ctx->par_detect_largest = (long)largest;
  ctx->par_detect_total += (long)*total;
  return MO_OK;
}

/* The detection's U- are of state s (T301). */
static void up_of_state(struct mo_pdetect *P, const mo_contact *C, const mo_state *s)
{
  if (!s->v) return;
  P->up_u = s->u;
  P->up_v = s->v;
  P->up_step = s->step;
  P->up_nc = C->nc;
}

/* The distributed set (contact.distributed_set, doc/scaling.md §4): the rank keeps the candidates it
   detected, nothing is gathered but the counts (a rank's failure fails every rank). Its part is in
   the serial order already and mapped against its own previous part (the map's keys, (T270)); its
   U- made here as for the gather (T300). */
static int finish_own(mo_contact *C, const mo_state *s, int st, mo_ctx *ctx)
{
  struct mo_pdetect *P = C->pd;
  const size_t n = (size_t)(C->nc - P->nc0);
  size_t a, total;
  P->up_nc = -1;
  if ((st = gather_counts(C, n, st, &total, ctx))) return st;
  ctx->par_dset = 1;
  if ((st = room((void **)&P->up, &P->upcap, (size_t)C->dim * (size_t)C->nc + 1, sizeof *P->up, ctx)) ||
      (st = room((void **)&P->cown, &P->cowncap, (size_t)C->nc + 1, sizeof *P->cown, ctx)))
    return st;
  P->cown_set = -1;
  for (a = 0; a < (size_t)C->nc; a++) P->cown[a] = a < (size_t)P->nc0 ? -1 : P->rank;
  if (n && s->v) mo_contact_Htx(C, s, s->v, P->nc0, C->nc, C->U0, P->up);
  else if (n) memset(P->up + (size_t)P->nc0 * C->dim, 0, n * (size_t)C->dim * sizeof *P->up);
  C->ksame = P->ksame && C->nc <= P->knold;
  if (with_map(C))
    for (a = (size_t)P->nc0; a < (size_t)C->nc && C->ksame; a++) C->ksame = C->smap.map[a] == (int)a;
  else
    C->ksame = C->ksame && !memcmp(C->key + (size_t)P->nc0 * MO_KEY, P->okey, n * MO_KEY * sizeof *C->key);
  up_of_state(P, C, s);
  return MO_OK;
}

static int finish_merge(mo_contact *C, const mo_state *s, int st, mo_ctx *ctx)
{
  struct mo_pdetect *P = C->pd;
  size_t n = (size_t)(C->nc - P->nc0), total = 0, off = 0, head[64], end[64], a;
  struct block B[64], own;
  int r;
  P->up_nc = -1; /* until this detection's U- are gathered (T300) */
  /* every rank's count, or -1 for a rank that failed: then every rank fails */
  if ((st = gather_counts(C, n, st, &total, ctx))) return st;
  for (r = 0; r < P->nranks; r++) P->cnt[r] = (int)block_size(C, (size_t)P->rc[r]);
  if ((st = room((void **)&P->buf, &P->bufcap, block_size(C, n) + 1, sizeof *P->buf, ctx)) ||
      (st = room((void **)&P->all, &P->allcap, block_size(C, total) + (size_t)P->nranks + 1, sizeof *P->all, ctx)))
    return st;
  /* the set's arrays and the map for the merged set (their contents kept) */
  if ((st = mo_contact_reserve(C, P->nc0 + (int)total, ctx)) ||
      (with_map(C) && (st = mo_setmap_reserve(&C->smap, P->nc0 + (int)total + 1, ctx))) ||
      (st = room((void **)&P->up, &P->upcap, (size_t)C->dim * ((size_t)P->nc0 + total) + 1, sizeof *P->up, ctx)) ||
      (st = room((void **)&P->cown, &P->cowncap, (size_t)P->nc0 + total + 1, sizeof *P->cown, ctx)))
    return st;
  P->cown_set = -1; /* until sealed with the new set's version */
  for (a = 0; a < (size_t)P->nc0; a++) P->cown[a] = -1;
  /* U- = H^T v + U0 of this rank's candidates at the state of the detection (T300): the driver's
     sum (fresh_uprev's, mo_contact_Htx over the same records, points, normals and obstacle
     velocities at the same state), made for this rank's part only and carried by the gather */
  if (n && s->v) mo_contact_Htx(C, s, s->v, P->nc0, C->nc, C->U0, P->up);
  else if (n) memset(P->up + (size_t)P->nc0 * C->dim, 0, n * (size_t)C->dim * sizeof *P->up);
  /* this rank's block: its part of the arrays as it is, and its order keys */
  own = block_at(C, P->buf, n);
  if (n) P->buf[block_size(C, n) - 1] = 0; /* the padding sent defined */
  copy_fields(C, &own, 0, (size_t)P->nc0, n, 0);
  if (n && !with_map(C)) memcpy(own.tag, P->tag, n * NTAG * sizeof *own.tag);
  if ((st = mo_par_gatherv(P->buf, P->cnt, P->all, ctx))) return st;
  for (r = 0; r < P->nranks; r++) {
    B[r] = block_at(C, P->all + off, (size_t)P->rc[r]);
    off += (size_t)P->cnt[r];
    head[r] = 0;
    end[r] = (size_t)P->rc[r];
  }
  /* the ranks' lists, each in the serial order, merged by runs (T217, T232): the rank whose next
     order key comes first, and as many of its candidates as come before every other rank's next */
  for (a = 0; a < total;) {
    int best = -1, next = -1;
    mo_setmap_ord ob = {0, 0}, on = {0, 0}, o;
    size_t h, c;
    for (r = 0; r < P->nranks; r++)
      if (head[r] < end[r] && (o = order_at(C, &B[r], head[r]), best < 0 || mo_setmap_cmp(o, ob) < 0)) {
        best = r;
        ob = o;
      }
    for (r = 0; r < P->nranks; r++)
      if (r != best && head[r] < end[r] && (o = order_at(C, &B[r], head[r]), next < 0 || mo_setmap_cmp(o, on) < 0)) {
        next = r;
        on = o;
      }
    /* the run ends at best's first candidate not before next's head: the block is sorted, so
       found by galloping from the head, then bisection (a few orders a run, not one a candidate,
       (T272)) */
    if (next < 0)
      h = end[best];
    else {
      size_t lo = head[best] + 1, hi = lo, step = 1;
      while (hi < end[best] && mo_setmap_cmp(order_at(C, &B[best], hi), on) < 0) {
        lo = hi + 1;
        hi += step;
        step *= 2;
      }
      if (hi > end[best]) hi = end[best];
      while (lo < hi) { /* [head, lo) before next's head; hi the end, or not before it */
        const size_t mid = lo + (hi - lo) / 2;
        if (mo_setmap_cmp(order_at(C, &B[best], mid), on) < 0) lo = mid + 1;
        else hi = mid;
      }
      h = lo;
    }
    copy_fields(C, &B[best], head[best], (size_t)P->nc0 + a, h - head[best], 1);
    for (c = 0; c < h - head[best]; c++) P->cown[(size_t)P->nc0 + a + c] = best;
    a += h - head[best];
    head[best] = h;
  }
  /* the keys compared with the previous set's as one process compares them (set_key): with the
     map, a key is the old one at its place when it maps there (a key is unique in a set) */
  C->ksame = P->ksame && (size_t)P->nc0 + total <= (size_t)P->knold;
  if (with_map(C))
    for (a = (size_t)P->nc0; a < (size_t)P->nc0 + total && C->ksame; a++) C->ksame = C->smap.map[a] == (int)a;
  else
    C->ksame = C->ksame && !memcmp(C->key + (size_t)P->nc0 * MO_KEY, P->okey, total * MO_KEY * sizeof *C->key);
  C->nc = P->nc0 + (int)total;
  up_of_state(P, C, s);
  return MO_OK;
}

int mo_pdetect_finish(mo_contact *C, const mo_state *s, int st, mo_ctx *ctx)
{
  return C->pd_dist ? finish_own(C, s, st, ctx) : finish_merge(C, s, st, ctx);
}

const double *mo_contact_detect_uprev(const mo_contact *C, const mo_state *s, int *a0)
{
  const struct mo_pdetect *P = C->pd;
  if (!P || P->up_nc != C->nc || P->up_set != C->cset_version || P->up_u != s->u || P->up_v != s->v ||
      P->up_step != s->step)
    return NULL;
  *a0 = P->nc0;
  return P->up;
}
