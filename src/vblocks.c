/* vblocks.c: the broad phase's pair list kept by blocks of bodies moving together.

   (T111)'s list holds while every body stays within half the skin of the bodies' mean motion. A
   column of grains falling onto a bed is two motions, and the front between them moves at every
   step: one mean fails every body, and the list was built at nearly every step. Here the bodies
   are grouped in blocks of neighbours, each block in its own frame (a translation of constant
   acceleration, the block's mean motion when it was last made), and the list holds pair by pair
   (doc/theory.md §12.26):
   - a pair of one block was left out at the block's making by more than reach = alert + skin; the
     frame is common to both bodies, so their own drifts from it bound what they closed (T321);
   - a pair of two blocks near each other was left out, when that pair of blocks was last made, by
     reach plus the pair's slack X_kl; the two frames' relative drift since then, plus what their
     relative velocity can close over two steps, must stay within X_kl (T322);
   - two blocks whose spheres (the bodies' predicted positions and radii) are apart by more than
     reach plus that relative velocity's margin have no pair within reach (T323).
   Every body checks its drift from its block's frame; a block that fails is made again (new frame,
   new snapshots) with its pairs; a pair of blocks that fails or comes near is made again; the
   other pairs are kept. The list stays sorted by (lower, higher): the pairs kept are filtered in
   place and merged with the new ones, sorted. */
#include "config.h"
#include "vblocks.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* a pair of near blocks k < l: its pairs made at time t, the slack X of the pairs left out then */
typedef struct {
  int k, l;
  double t, X;
} vb_entry;

struct mo_vblocks {
  int dim, n, m, nb;    /* bodies, bodies taking part, blocks */
  int ok;               /* a list is held */
  double sumrho0;       /* the blocks' radii summed at the last whole build */
  /* per body: block (-1 outside), snapshot (dim), margin e_b, radius grown by it, a mark of this call */
  int *blk;
  double *xs, *e, *R;
  unsigned char *flag;
  /* the members, block by block in increasing index: mem[mstart[k] .. mstart[k + 1]) */
  int *mem, *mstart;
  /* per block: frame (origin time, velocity, acceleration), its mean velocity now and at tprev,
     the snapshots' centre and the sphere of the snapshots' balls about it; the sphere now */
  double *tau, *fv, *fa, *vm, *vmp, *c, *rho, *cb, *rb;
  unsigned char *ref;
  double tprev;
  int hist;
  /* the table of near pairs of blocks, sorted by (k, l), and the next one */
  vb_entry *tab, *tab2;
  long ntab;
  /* the pairs of blocks changed without either being made again (k << 32 | l, sorted) */
  uint64_t *chg;
  long nchg;
  /* the list, the new pairs of this call (lower << 32 | higher) and the radix sort's scratch for
     them; a pair of blocks' gathered members (make_cross) */
  int *pair;
  long npair;
  uint64_t *add, *add2;
  long nadd;
  double *gath;
  mo_broad *bb; /* the blocks' own broad phase */
  long refreshed;
  size_t cap_body, cap_mem, cap_block, cap_tab, cap_tab2, cap_chg, cap_pair, cap_add, cap_add2, cap_gath;
};

int mo_vblocks_create(mo_vblocks **out, mo_ctx *ctx)
{
  *out = mo_calloc(ctx, 1, sizeof **out);
  if (!*out) return MO_ENOMEM;
  if (mo_broad_create(&(*out)->bb, ctx)) {
    mo_free(*out);
    *out = NULL;
    return MO_ENOMEM;
  }
  return MO_OK;
}

void mo_vblocks_free(mo_vblocks *V)
{
  if (!V) return;
  mo_free(V->blk);
  mo_free(V->xs);
  mo_free(V->e);
  mo_free(V->R);
  mo_free(V->flag);
  mo_free(V->mem);
  mo_free(V->mstart);
  mo_free(V->tau);
  mo_free(V->fv);
  mo_free(V->fa);
  mo_free(V->vm);
  mo_free(V->vmp);
  mo_free(V->c);
  mo_free(V->rho);
  mo_free(V->cb);
  mo_free(V->rb);
  mo_free(V->ref);
  mo_free(V->tab);
  mo_free(V->tab2);
  mo_free(V->chg);
  mo_free(V->pair);
  mo_free(V->add);
  mo_free(V->add2);
  mo_free(V->gath);
  mo_broad_free(V->bb);
  mo_free(V);
}

size_t mo_vblocks_bytes(const mo_vblocks *V)
{
  if (!V) return 0;
  return sizeof *V + V->cap_body * (sizeof(int) + (size_t)(V->dim + 2) * sizeof(double) + 1) +
         V->cap_mem * sizeof(int) + V->cap_block * (sizeof(int) + (size_t)(6 * V->dim + 3) * sizeof(double) + 1) +
         (V->cap_tab + V->cap_tab2) * sizeof(vb_entry) + (V->cap_chg + V->cap_add + V->cap_add2) * sizeof(uint64_t) + V->cap_gath * sizeof(double) +
         V->cap_pair * sizeof(int) + mo_broad_bytes(V->bb);
}

void mo_vblocks_stats(const mo_vblocks *V, long *refreshed, long *nblock)
{
  *refreshed = V ? V->refreshed : 0;
  *nblock = V ? V->nb : 0;
}

/* *p with room for need elements of size sz (*cap counts them), grown by half; NULL with MO_ENOMEM
   recorded when it cannot be (the old block then stays with the caller). */
static int grow(void *pp, size_t *cap, size_t need, size_t sz, mo_ctx *ctx)
{
  void **p = pp, *q;
  size_t c = *cap;
  if (need <= c) return MO_OK;
  c = c ? c : 16;
  while (c < need) c += c / 2 + 16;
  if (!(q = mo_realloc(ctx, *p, c * sz))) return MO_ENOMEM;
  *p = q;
  *cap = c;
  return MO_OK;
}

/* Room for the arrays over the bodies and over nb blocks. */
static int room(mo_vblocks *V, int n, int m, int nb, mo_ctx *ctx)
{
  const size_t D = (size_t)V->dim;
  size_t cb = V->cap_body, cm = V->cap_mem, ck = V->cap_block;
  int st = 0;
  if (n > 0 && (size_t)n > cb) {
    size_t c0 = cb;
    st |= grow(&V->blk, &c0, n, sizeof(int), ctx);
    c0 = cb;
    st |= grow(&V->xs, &c0, n, D * sizeof(double), ctx);
    c0 = cb;
    st |= grow(&V->e, &c0, n, sizeof(double), ctx);
    c0 = cb;
    st |= grow(&V->R, &c0, n, sizeof(double), ctx);
    c0 = cb;
    st |= grow(&V->flag, &c0, n, 1, ctx);
    if (st) return MO_ENOMEM;
    V->cap_body = c0;
  }
  if (m > 0 && (size_t)m > cm) {
    if (grow(&V->mem, &cm, m, sizeof(int), ctx)) return MO_ENOMEM;
    V->cap_mem = cm;
  }
  if ((size_t)nb + 1 > ck) {
    size_t c0 = ck;
    double **dv[] = {&V->fv, &V->fa, &V->vm, &V->vmp, &V->c, &V->cb};
    int i;
    for (i = 0; i < 6; i++) {
      c0 = ck;
      st |= grow(dv[i], &c0, (size_t)nb + 1, D * sizeof(double), ctx);
    }
    c0 = ck;
    st |= grow(&V->tau, &c0, (size_t)nb + 1, sizeof(double), ctx);
    c0 = ck;
    st |= grow(&V->rho, &c0, (size_t)nb + 1, sizeof(double), ctx);
    c0 = ck;
    st |= grow(&V->rb, &c0, (size_t)nb + 1, sizeof(double), ctx);
    c0 = ck;
    st |= grow(&V->ref, &c0, (size_t)nb + 1, 1, ctx);
    c0 = ck;
    st |= grow(&V->mstart, &c0, (size_t)nb + 1, sizeof(int), ctx);
    if (st) return MO_ENOMEM;
    V->cap_block = c0;
  }
  return MO_OK;
}

/* Block k's frame at time t: translation T since its origin, velocity W (T320). */
static inline void frame_at(const mo_vblocks *V, int k, double t, double *T, double *W)
{
  const int D = V->dim;
  const double s = t - V->tau[k];
  int a;
  for (a = 0; a < D; a++) {
    if (T) T[a] = V->fv[D * k + a] * s + 0.5 * V->fa[D * k + a] * s * s;
    if (W) W[a] = V->fv[D * k + a] + V->fa[D * k + a] * s;
  }
}

static inline double dist(const double *a, const double *b, int D)
{
  double d2 = (a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]);
  if (D == 3) d2 += (a[2] - b[2]) * (a[2] - b[2]);
  return sqrt(d2);
}

/* Block k made at time t from its members now: frame velocity fv (the members' mean velocity) and
   acceleration fa (given), snapshots, margins e_b = 2 h (|v_b - fv| + w_b), grown radii, the
   centre of the snapshots and the radius of the sphere holding their balls (T320). */
static void make_block(mo_vblocks *V, const mo_vblocks_in *in, int k, const double *fa)
{
  const int D = V->dim;
  int i, a;
  double *c = V->c + (size_t)D * k, r = 0;
  const int i0 = V->mstart[k], i1 = V->mstart[k + 1];
  V->tau[k] = in->t;
  for (a = 0; a < D; a++) {
    V->fv[D * k + a] = V->vm[D * k + a];
    V->fa[D * k + a] = fa ? fa[a] : 0;
    c[a] = 0;
  }
  for (i = i0; i < i1; i++) {
    const int b = V->mem[i];
    const double *x = in->x + (size_t)D * b, *v = in->v + (size_t)D * b;
    double dv = 0;
    for (a = 0; a < D; a++) {
      V->xs[(size_t)D * b + a] = x[a];
      c[a] += x[a];
      dv += (v[a] - V->fv[D * k + a]) * (v[a] - V->fv[D * k + a]);
    }
    V->e[b] = 2 * in->h * (sqrt(dv) + in->w[b]);
    V->R[b] = in->bound[b] + V->e[b];
  }
  for (a = 0; a < D; a++) c[a] /= i1 - i0;
  for (i = i0; i < i1; i++) {
    const int b = V->mem[i];
    r = fmax(r, dist(V->xs + (size_t)D * b, c, D) + V->R[b]);
  }
  V->rho[k] = r;
}

/* The block cell of centre x: its coordinates from lo in cells of side `side`, 21 bits each
   (clamped), packed into one key (< 2^63), the first coordinate lowest. */
static uint64_t cell_key(const double *x, int D, const double *lo, double side)
{
  uint64_t cell = 0;
  int a;
  for (a = D - 1; a >= 0; a--) {
    const double s = floor((x[a] - lo[a]) / side);
    cell = cell << 21 | (uint64_t)(s < 2097151.0 ? s : 2097151.0);
  }
  return cell;
}

static int cmp_u64(const void *a, const void *b)
{
  const uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
  return x < y ? -1 : x > y;
}

/* The blocks' spheres at time t (centre c_k + T_k(t), radius rho_k grown by 2 h |W_k - Z|, Z the
   blocks' mean frame velocity: 2 h |W_k - W_l| <= the two growths, (T323)) and the pairs of blocks
   within reach of each other, sorted. */
static int near_blocks(mo_vblocks *V, const mo_vblocks_in *in, double reach, const int **bp, long *nbp, mo_ctx *ctx)
{
  const int D = V->dim;
  double Z[3] = {0, 0, 0}, T[3], W[3];
  int k, a;
  for (k = 0; k < V->nb; k++) {
    frame_at(V, k, in->t, T, W);
    for (a = 0; a < D; a++) {
      V->cb[D * k + a] = V->c[D * k + a] + T[a];
      Z[a] += W[a] / V->nb;
    }
  }
  for (k = 0; k < V->nb; k++) {
    double dw = 0;
    frame_at(V, k, in->t, NULL, W);
    for (a = 0; a < D; a++) dw += (W[a] - Z[a]) * (W[a] - Z[a]);
    V->rb[k] = V->rho[k] + 2 * in->h * sqrt(dw);
  }
  return mo_broad_pairs(V->bb, D, V->nb, V->cb, V->rb, NULL, reach, bp, nbp, ctx);
}

/* Room for one more new pair. */
static inline int add_pair(mo_vblocks *V, int i, int j, mo_ctx *ctx)
{
  if ((size_t)V->nadd >= V->cap_add && grow(&V->add, &V->cap_add, (size_t)V->nadd + 1, sizeof(uint64_t), ctx))
    return MO_ENOMEM;
  V->add[V->nadd++] = i < j ? (uint64_t)i << 32 | (uint64_t)j : (uint64_t)j << 32 | (uint64_t)i;
  return MO_OK;
}

/* The pairs of blocks k != l at time t from the bodies' predicted positions (snapshot plus frame):
   those within cut = reach + skin + 2 h |W_k - W_l|, and in *X the least slack over reach of those
   left out (T322; +inf when none is). A body whose ball is farther than cut from the other block's
   sphere has every pair of it left out by at least that distance: l's members within cut of k's
   sphere are gathered first (positions, radius, index: D + 2 values each), then each member of k
   within cut of l's sphere is tested against them. */
static int make_cross(mo_vblocks *V, const mo_vblocks_in *in, int k, int l, double reach, double *X, mo_ctx *ctx)
{
  const int D = V->dim, S = D + 2;
  double Tk[3], Tl[3], Wk[3] = {0, 0, 0}, Wl[3] = {0, 0, 0}, pa[3], cut, x = INFINITY;
  const double *ck = V->cb + (size_t)D * k, *cl = V->cb + (size_t)D * l;
  double *g;
  int i, j, a, ng = 0;
  frame_at(V, k, in->t, Tk, Wk);
  frame_at(V, l, in->t, Tl, Wl);
  /* the pairs left out must be apart by what the frames' relative velocity closes over two steps
     at once (T322), and the skin beyond it for the frames' drift to come */
  cut = reach + in->skin + 2 * in->h * dist(Wk, Wl, D);
  if (grow(&V->gath, &V->cap_gath, (size_t)S * (V->mstart[l + 1] - V->mstart[l]), sizeof(double), ctx))
    return MO_ENOMEM;
  g = V->gath;
  for (j = V->mstart[l]; j < V->mstart[l + 1]; j++) {
    const int bb = V->mem[j];
    double *gb = g + (size_t)S * ng, far;
    for (a = 0; a < D; a++) gb[a] = V->xs[(size_t)D * bb + a] + Tl[a];
    gb[D] = V->R[bb];
    far = dist(gb, ck, D) - gb[D] - V->rho[k];
    if (far > cut) {
      if (far - reach < x) x = far - reach;
      continue;
    }
    gb[D + 1] = bb;
    ng++;
  }
  for (i = V->mstart[k]; i < V->mstart[k + 1] && ng; i++) {
    const int ba = V->mem[i];
    const double ra = V->R[ba];
    double far;
    for (a = 0; a < D; a++) pa[a] = V->xs[(size_t)D * ba + a] + Tk[a];
    far = dist(pa, cl, D) - ra - V->rho[l];
    if (far > cut) {
      if (far - reach < x) x = far - reach;
      continue;
    }
    for (j = 0; j < ng; j++) {
      const double *gb = g + (size_t)S * j, P = dist(pa, gb, D) - ra - gb[D];
      if (P <= cut) {
        if (add_pair(V, ba, (int)gb[D + 1], ctx)) return MO_ENOMEM;
      } else if (P - reach < x)
        x = P - reach;
    }
  }
  *X = x;
  return MO_OK;
}

/* The pairs within block k, just made (snapshots = positions now): those within reach (T321). */
static int make_inner(mo_vblocks *V, int k, double reach, mo_ctx *ctx)
{
  const int D = V->dim;
  int i, j;
  for (i = V->mstart[k]; i < V->mstart[k + 1]; i++) {
    const int ba = V->mem[i];
    const double *xa = V->xs + (size_t)D * ba;
    for (j = i + 1; j < V->mstart[k + 1]; j++) {
      const int bb = V->mem[j];
      if (dist(xa, V->xs + (size_t)D * bb, D) - V->R[ba] - V->R[bb] <= reach && add_pair(V, ba, bb, ctx))
        return MO_ENOMEM;
    }
  }
  return MO_OK;
}

/* The frames' relative drift of entry E since it was made, at time t (T322): with each frame's
   translation T(s) = fv (s - tau) + fa (s - tau)^2 / 2 unchanged since E.t. */
static double drift(const mo_vblocks *V, const vb_entry *E, double t)
{
  const int D = V->dim;
  double d2 = 0;
  int a;
  for (a = 0; a < D; a++) {
    const double sk1 = t - V->tau[E->k], sk0 = E->t - V->tau[E->k], sl1 = t - V->tau[E->l], sl0 = E->t - V->tau[E->l];
    const double dk = V->fv[D * E->k + a] * (t - E->t) + 0.5 * V->fa[D * E->k + a] * (sk1 * sk1 - sk0 * sk0);
    const double dl = V->fv[D * E->l + a] * (t - E->t) + 0.5 * V->fa[D * E->l + a] * (sl1 * sl1 - sl0 * sl0);
    d2 += (dk - dl) * (dk - dl);
  }
  return sqrt(d2);
}

/* The whole list: the blocks formed again (cells of side about four bodies' reach in 2D, three in
   3D, the members of each in increasing index), each made now, and every pair within reach plus
   the skin found with B's cells (those of one block only within reach); every pair of blocks
   within reach plus two skins of each other in the table with the slack X = skin (T324). */
static int build_all(mo_vblocks *V, const mo_vblocks_in *in, mo_broad *B, double reach, mo_ctx *ctx)
{
  const int D = in->dim, n = in->n;
  double lo[3] = {0, 0, 0}, rsum = 0, side;
  uint64_t *key = NULL;
  double *acc = NULL, *acc_r = NULL, *grown;
  size_t cap_r = 0;
  const int *bp;
  long nbp, q;
  int i, k, a, m = 0, nb = 0, st;
  const int n_old = V->n, dim_old = V->dim, nb_old = V->nb;
  V->ok = 0;
  V->npair = 0;
  V->ntab = 0;
  V->dim = D;
  V->n = n;
  for (i = 0; i < n; i++)
    if (!in->mask || in->mask[i]) {
      for (a = 0; a < D; a++) {
        double x = in->x[(size_t)D * i + a];
        if (!isfinite(x)) /* mo_broad_pairs's message */
          return mo_broad_pairs(B, D, n, in->x, in->bound, in->mask, reach, &bp, &nbp, ctx);
        if (!m || x < lo[a]) lo[a] = x;
      }
      rsum += in->bound[i];
      m++;
    }
  if ((st = room(V, n, m, 0, ctx))) return st;
  V->m = m;
  if (m < 2) { /* no pair; every body its own block is not needed */
    for (i = 0; i < n; i++) V->blk[i] = -1;
    V->nb = 0;
    V->hist = 0;
    V->ok = 1;
    return MO_OK;
  }
  /* each body's acceleration as its old block's mean velocity changed over the last step, for the
     new blocks' frames (a falling column formed again keeps falling in its frames) */
  if (V->hist && nb_old > 0 && in->t > V->tprev && n_old == n && dim_old == D) {
    if (!(acc = mo_malloc(ctx, (size_t)D * n * sizeof *acc))) return MO_ENOMEM;
    for (i = 0; i < n; i++)
      for (a = 0; a < D; a++)
        acc[(size_t)D * i + a] = V->blk[i] >= 0 ? (V->vm[D * V->blk[i] + a] - V->vmp[D * V->blk[i] + a]) / (in->t - V->tprev) : 0;
  }
  V->nb = 0;
  V->hist = 0;
  side = (D == 2 ? 4.0 : 3.0) * (2 * rsum / m + reach);
  if (!(side > 0)) side = 1;
  if (!(key = mo_malloc(ctx, (size_t)m * sizeof *key))) {
    st = MO_ENOMEM;
    goto out;
  }
  /* the block of each body: its cell's coordinates (21 bits each, clamped) and its index */
  for (i = 0, k = 0; i < n; i++) {
    V->blk[i] = -1;
    V->flag[i] = 0;
    if (in->mask && !in->mask[i]) continue;
    key[k++] = cell_key(in->x + (size_t)D * i, D, lo, side);
  }
  /* counting the blocks: sort the cells, then each body's block by binary search */
  qsort(key, m, sizeof *key, cmp_u64);
  for (i = 0; i < m; i++)
    if (!i || key[i] != key[i - 1]) key[nb++] = key[i];
  if ((st = room(V, n, m, nb, ctx))) goto out;
  memset(V->mstart, 0, ((size_t)nb + 1) * sizeof *V->mstart);
  for (i = 0; i < n; i++) {
    uint64_t cell;
    long lo_i = 0, hi_i = nb - 1;
    if (in->mask && !in->mask[i]) continue;
    cell = cell_key(in->x + (size_t)D * i, D, lo, side);
    while (lo_i < hi_i) {
      long mid = (lo_i + hi_i) / 2;
      if (key[mid] < cell) lo_i = mid + 1;
      else hi_i = mid;
    }
    V->blk[i] = (int)lo_i;
    V->mstart[lo_i + 1]++;
  }
  for (k = 0; k < nb; k++) V->mstart[k + 1] += V->mstart[k];
  for (i = 0; i < n; i++) /* placed in increasing index; mstart[k] moves to the next block's start */
    if (V->blk[i] >= 0) V->mem[V->mstart[V->blk[i]]++] = i;
  for (k = nb; k > 0; k--) V->mstart[k] = V->mstart[k - 1];
  V->mstart[0] = 0;
  V->nb = nb;
  /* each block made now, from its mean velocity and its members' mean acceleration (none known at
     the first build) */
  for (k = 0; k < nb; k++) {
    double fa[3] = {0, 0, 0};
    const int nk = V->mstart[k + 1] - V->mstart[k];
    for (a = 0; a < D; a++) V->vm[D * k + a] = 0;
    for (i = V->mstart[k]; i < V->mstart[k + 1]; i++)
      for (a = 0; a < D; a++) {
        V->vm[D * k + a] += in->v[(size_t)D * V->mem[i] + a];
        if (acc) fa[a] += acc[(size_t)D * V->mem[i] + a];
      }
    for (a = 0; a < D; a++) {
      V->vm[D * k + a] /= nk;
      fa[a] /= nk;
    }
    make_block(V, in, k, fa);
    for (a = 0; a < D; a++) V->vmp[D * k + a] = V->vm[D * k + a];
  }
  V->sumrho0 = 0;
  for (k = 0; k < nb; k++) V->sumrho0 += V->rho[k];
  V->tprev = in->t;
  V->hist = 1;
  /* every pair within reach + skin + 2 h (|W_k - Z| + |W_l - Z|), Z the frames' mean velocity, so
     that the slack of those left out holds what the frames' relative velocity closes (T322): the
     cells on the radii grown by 2 h |W_k - Z| (in rb for the moment); those of one block within
     reach only */
  {
    double Z[3] = {0, 0, 0};
    for (k = 0; k < nb; k++)
      for (a = 0; a < D; a++) Z[a] += V->fv[D * k + a] / nb;
    if ((st = grow(&acc_r, &cap_r, (size_t)n, sizeof(double), ctx))) goto out;
    for (k = 0; k < nb; k++) {
      double dz = 0;
      for (a = 0; a < D; a++) dz += (V->fv[D * k + a] - Z[a]) * (V->fv[D * k + a] - Z[a]);
      V->rb[k] = 2 * in->h * sqrt(dz);
      for (i = V->mstart[k]; i < V->mstart[k + 1]; i++) acc_r[V->mem[i]] = V->R[V->mem[i]] + V->rb[k];
    }
  }
  if ((st = mo_broad_pairs(B, D, n, V->xs, acc_r, in->mask, reach + in->skin, &bp, &nbp, ctx))) goto out;
  if ((st = grow(&V->pair, &V->cap_pair, 2 * (size_t)nbp + 2, sizeof(int), ctx))) goto out;
  for (q = 0; q < nbp; q++) {
    const int ba = bp[2 * q], bb = bp[2 * q + 1];
    if (V->blk[ba] == V->blk[bb] &&
        dist(V->xs + (size_t)D * ba, V->xs + (size_t)D * bb, D) - V->R[ba] - V->R[bb] > reach)
      continue;
    V->pair[2 * V->npair] = ba;
    V->pair[2 * V->npair + 1] = bb;
    V->npair++;
  }
  /* the table: the pairs of blocks near each other, made now with the slack of the skin and the
     growths (kept in acc_r's first nb places, the bodies' grown radii read no more) */
  grown = acc_r;
  for (k = 0; k < nb; k++) grown[k] = V->rb[k];
  if ((st = near_blocks(V, in, reach + 2 * in->skin, &bp, &nbp, ctx))) goto out;
  if ((st = grow(&V->tab, &V->cap_tab, (size_t)nbp + 1, sizeof(vb_entry), ctx))) goto out;
  for (q = 0; q < nbp; q++) {
    V->tab[q].k = bp[2 * q];
    V->tab[q].l = bp[2 * q + 1];
    V->tab[q].t = in->t;
    V->tab[q].X = in->skin + grown[bp[2 * q]] + grown[bp[2 * q + 1]];
  }
  V->ntab = nbp;
  V->ok = 1;
out:
  mo_broad_trim(B); /* the cells' arrays until the next whole build: none (the list is V's) */
  mo_free(key);
  mo_free(acc);
  mo_free(acc_r);
  if (st) {
    V->ok = 0;
    V->npair = 0;
  }
  return st;
}

/* The new pairs' keys sorted: least significant digit first, 11 bits a pass, over the bits the
   bodies' indices take (both halves of the key), through a scratch as long (a few passes over
   the new pairs, where a comparison sort took 80 % of the update at 10^4 grains). */
static int sort_keys(mo_vblocks *V, mo_ctx *ctx)
{
  enum { BITS = 11, R = 1 << BITS };
  long cnt[R], i;
  int bits = 1, shift, half;
  uint64_t *a = V->add, *b;
  while (bits < 32 && (1L << bits) < V->n) bits++;
  if (V->nadd < 64) { /* a few: by insertion */
    for (i = 1; i < V->nadd; i++) {
      const uint64_t key = a[i];
      long j = i;
      for (; j > 0 && a[j - 1] > key; j--) a[j] = a[j - 1];
      a[j] = key;
    }
    return MO_OK;
  }
  if (grow(&V->add2, &V->cap_add2, (size_t)V->nadd, sizeof(uint64_t), ctx)) return MO_ENOMEM;
  b = V->add2;
  for (half = 0; half < 2; half++)
    for (shift = 0; shift < bits; shift += BITS) {
      const int sh = 32 * half + shift;
      long sum = 0;
      uint64_t *t;
      memset(cnt, 0, sizeof cnt);
      for (i = 0; i < V->nadd; i++) cnt[(a[i] >> sh) & (R - 1)]++;
      for (i = 0; i < R; i++) {
        const long c = cnt[i];
        cnt[i] = sum;
        sum += c;
      }
      for (i = 0; i < V->nadd; i++) b[cnt[(a[i] >> sh) & (R - 1)]++] = a[i];
      t = a;
      a = b;
      b = t;
    }
  /* as many passes over each half: an even count, the sorted keys are back in V->add */
  return MO_OK;
}

/* Mark block pair (k, l), neither made again, as changed: its pairs leave the list. */
static int mark_changed(mo_vblocks *V, int k, int l, mo_ctx *ctx)
{
  int i;
  if (grow(&V->chg, &V->cap_chg, (size_t)V->nchg + 1, sizeof(uint64_t), ctx)) return MO_ENOMEM;
  V->chg[V->nchg++] = (uint64_t)k << 32 | (uint64_t)l;
  for (i = V->mstart[k]; i < V->mstart[k + 1]; i++) V->flag[V->mem[i]] |= 1;
  for (i = V->mstart[l]; i < V->mstart[l + 1]; i++) V->flag[V->mem[i]] |= 1;
  return MO_OK;
}

static int changed(const mo_vblocks *V, uint64_t key)
{
  long lo = 0, hi = V->nchg;
  while (lo < hi) {
    long mid = (lo + hi) / 2;
    if (V->chg[mid] < key) lo = mid + 1;
    else hi = mid;
  }
  return lo < V->nchg && V->chg[lo] == key;
}

int mo_vblocks_update(mo_vblocks *V, const mo_vblocks_in *in, mo_broad *B, const int **pairs, long *npairs,
                      int *built, mo_ctx *ctx)
{
  const int D = in->dim;
  const double reach = in->alert + in->skin;
  double T[3], W[3], sumrho = 0;
  const int *bp;
  long nbp, q, i, w, nref = 0;
  int k, a, st, nonfinite = 0, whole = !V->ok || V->dim != D || V->n != in->n;
  *pairs = NULL;
  *npairs = 0;
  *built = 0;
  if (!whole && V->m >= 2) {
    /* each body's drift from its block's frame, plus what it can close at its speed relative to
       the frame, against half the skin plus its margin (T321); each block's mean velocity */
    for (k = 0; k < V->nb; k++) {
      int j, bad = 0;
      frame_at(V, k, in->t, T, W);
      for (a = 0; a < D; a++) V->vm[D * k + a] = 0;
      for (j = V->mstart[k]; j < V->mstart[k + 1]; j++) {
        const int b = V->mem[j];
        const double *x = in->x + (size_t)D * b, *v = in->v + (size_t)D * b, *xs = V->xs + (size_t)D * b;
        double e2 = 0, s2 = 0;
        for (a = 0; a < D; a++) {
          const double ex = x[a] - xs[a] - T[a], ev = v[a] - W[a];
          e2 += ex * ex;
          s2 += ev * ev;
          V->vm[D * k + a] += v[a];
        }
        if (!(e2 + s2 < INFINITY)) nonfinite = 1; /* the whole build, whose cells name the body */
        {
          /* (T321) on the squares first: sqrt(e2) + 2 h sqrt(s2) <= sqrt(2 (e2 + 4 h^2 s2)), so a body
             well within its frame is passed without a square root */
          const double lim = 0.5 * in->skin + V->e[b] - 2 * in->h * in->w[b], c2 = 4 * in->h * in->h;
          if (!(lim >= 0 && 2 * (e2 + c2 * s2) <= lim * lim) && !(sqrt(e2) + 2 * in->h * sqrt(s2) <= lim)) bad = 1;
        }
      }
      for (a = 0; a < D; a++) V->vm[D * k + a] /= V->mstart[k + 1] - V->mstart[k];
      V->ref[k] = (unsigned char)bad;
      if (bad) nref += V->mstart[k + 1] - V->mstart[k];
    }
    whole = 2 * nref > V->m || nonfinite;
  }
  if (whole) {
    if ((st = build_all(V, in, B, reach, ctx))) return st;
    *built = 1;
    *pairs = V->pair;
    *npairs = V->npair;
    return MO_OK;
  }
  if (V->m < 2) return MO_OK;
  /* the blocks that failed made again: their frame's acceleration from their mean velocity's
     change over the last step (a block in free fall: g; at rest: 0) */
  for (k = 0; k < V->nb; k++) {
    if (V->ref[k]) {
      double fa[3] = {0, 0, 0};
      if (V->hist && in->t > V->tprev)
        for (a = 0; a < D; a++) fa[a] = (V->vm[D * k + a] - V->vmp[D * k + a]) / (in->t - V->tprev);
      make_block(V, in, k, fa);
      V->refreshed++;
    }
    sumrho += V->rho[k];
  }
  if (sumrho > 2 * V->sumrho0) { /* the blocks spread out: form them again (their accelerations kept) */
    if ((st = build_all(V, in, B, reach, ctx))) return st;
    *built = 1;
    *pairs = V->pair;
    *npairs = V->npair;
    return MO_OK;
  }
  for (k = 0; k < V->nb; k++)
    for (a = 0; a < D; a++) V->vmp[D * k + a] = V->vm[D * k + a];
  V->tprev = in->t;
  /* the pairs of blocks near each other now against the table: kept while the frames hold, made
     again when one block was or the frames' drift passes the slack, made when new; the entries no
     longer near leave with their pairs (T322)-(T323) */
  if ((st = near_blocks(V, in, reach + 2 * in->skin, &bp, &nbp, ctx))) goto fail;
  if ((st = grow(&V->tab2, &V->cap_tab2, (size_t)nbp + 1, sizeof(vb_entry), ctx))) goto fail;
  V->nchg = 0;
  V->nadd = 0;
  for (q = 0, i = 0, w = 0; q <= nbp; q++) {
    const int kk = q < nbp ? bp[2 * q] : V->nb, ll = q < nbp ? bp[2 * q + 1] : 0;
    vb_entry *E = NULL;
    double X;
    /* the old entries before (kk, ll) are no longer near */
    for (; i < V->ntab && (V->tab[i].k < kk || (V->tab[i].k == kk && V->tab[i].l < ll)); i++)
      if (!V->ref[V->tab[i].k] && !V->ref[V->tab[i].l] && (st = mark_changed(V, V->tab[i].k, V->tab[i].l, ctx)))
        goto fail;
    if (q == nbp) break;
    if (i < V->ntab && V->tab[i].k == kk && V->tab[i].l == ll) E = &V->tab[i++];
    if (E && !V->ref[kk] && !V->ref[ll]) {
      double dw = 0, Wl[3];
      frame_at(V, kk, in->t, NULL, W);
      frame_at(V, ll, in->t, NULL, Wl);
      for (a = 0; a < D; a++) dw += (W[a] - Wl[a]) * (W[a] - Wl[a]);
      if (drift(V, E, in->t) + 2 * in->h * sqrt(dw) <= E->X) {
        V->tab2[w++] = *E;
        continue;
      }
      if ((st = mark_changed(V, kk, ll, ctx))) goto fail;
    }
    if ((st = make_cross(V, in, kk, ll, reach, &X, ctx))) goto fail;
    V->tab2[w].k = kk;
    V->tab2[w].l = ll;
    V->tab2[w].t = in->t;
    V->tab2[w].X = X;
    w++;
  }
  {
    vb_entry *t = V->tab;
    size_t c = V->cap_tab;
    V->tab = V->tab2;
    V->cap_tab = V->cap_tab2;
    V->tab2 = t;
    V->cap_tab2 = c;
    V->ntab = w;
  }
  /* the blocks made again: their own pairs, and every pair of theirs leaves the list */
  for (k = 0; k < V->nb; k++)
    if (V->ref[k]) {
      int j;
      if ((st = make_inner(V, k, reach, ctx))) goto fail;
      for (j = V->mstart[k]; j < V->mstart[k + 1]; j++) V->flag[V->mem[j]] |= 2;
    }
  /* the pairs kept, in place, in their order */
  for (q = 0, w = 0; q < V->npair; q++) {
    const int ba = V->pair[2 * q], bb = V->pair[2 * q + 1];
    const int f = V->flag[ba] | V->flag[bb];
    if (f) {
      const int ka = V->blk[ba], kb = V->blk[bb];
      if (f & 2) continue;
      if (ka != kb && changed(V, ka < kb ? (uint64_t)ka << 32 | (uint64_t)kb : (uint64_t)kb << 32 | (uint64_t)ka)) continue;
    }
    V->pair[2 * w] = ba;
    V->pair[2 * w + 1] = bb;
    w++;
  }
  /* the marks cleared */
  for (k = 0; k < V->nb; k++)
    if (V->ref[k]) {
      int j;
      for (j = V->mstart[k]; j < V->mstart[k + 1]; j++) V->flag[V->mem[j]] = 0;
    }
  for (q = 0; q < V->nchg; q++) {
    const int kk = (int)(V->chg[q] >> 32), ll = (int)(V->chg[q] & 0xffffffffu);
    int j;
    for (j = V->mstart[kk]; j < V->mstart[kk + 1]; j++) V->flag[V->mem[j]] = 0;
    for (j = V->mstart[ll]; j < V->mstart[ll + 1]; j++) V->flag[V->mem[j]] = 0;
  }
  /* the new pairs sorted and merged from the end */
  if (V->nadd) {
    long o, x = w - 1, y = V->nadd - 1;
    if ((st = sort_keys(V, ctx))) goto fail;
    if ((st = grow(&V->pair, &V->cap_pair, 2 * (size_t)(w + V->nadd), sizeof(int), ctx))) goto fail;
    for (o = w + V->nadd - 1; y >= 0; o--) {
      const uint64_t ky = V->add[y];
      const uint64_t kx = x >= 0 ? (uint64_t)V->pair[2 * x] << 32 | (uint64_t)V->pair[2 * x + 1] : 0;
      if (x >= 0 && kx > ky) {
        V->pair[2 * o] = V->pair[2 * x];
        V->pair[2 * o + 1] = V->pair[2 * x + 1];
        x--;
      } else {
        V->pair[2 * o] = (int)(ky >> 32);
        V->pair[2 * o + 1] = (int)(ky & 0xffffffffu);
        y--;
      }
    }
    w += V->nadd;
  }
  V->npair = w;
  *pairs = V->pair;
  *npairs = V->npair;
  return MO_OK;
fail:
  V->ok = 0;
  V->npair = 0;
  V->ntab = 0;
  for (i = 0; i < V->n; i++) V->flag[i] = 0;
  return st;
}
