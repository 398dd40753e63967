/* nscd_bodies.c: nscd's sweep on body velocities, for contact sets that join rigid bodies and
   obstacles only (doc/theory.md §8.6): v = v_free + What^-1 H r is kept up to date contact by
   contact, the local problem of contact a read from the velocities of its (at most two) bodies,
   U_a = c_a + sum_s G_as v_s, W_aa from its own blocks: a contact update costs O(1), a sweep
   O(contacts), and no W is stored beyond the diagonal blocks (the LMGC90 and Siconos way). */
#include "config.h"
#include "nscd.h"

#include <math.h>
#include <string.h>

/* The dofs of a rigid block in a problem of contact dimension d (2D bodies 3, 3D bodies 6): the
   stride of the per-side rows G_as and columns What_s^-1 G_as^T. */
#define NK(d) ((d) == 3 ? 6 : (d) == 2 ? 3 : 1)

/* Room for nc contacts (two sides each) and nfree velocities. */
static int reserve(nscd_state *S, int nfree, mo_ctx *ctx)
{
  size_t nc = (size_t)S->nc + 1, d = (size_t)S->d;
  void *p;
  if (nc > S->bcap) {
#define GROW(ptr, n) if (!(p = mo_realloc(ctx, ptr, (n) * sizeof *(ptr)))) return MO_ENOMEM; ptr = p
    GROW(S->nsd, nc);
    GROW(S->sblk, 2 * nc);
    GROW(S->soff, 2 * nc);
    GROW(S->G, 2 * nc * d * NK(d));
    GROW(S->MG, 2 * nc * d * NK(d));
    GROW(S->Wd, nc * d * d);
    GROW(S->c, nc * d);
    S->bcap = nc;
  }
  if ((size_t)nfree + 1 > S->vcap) {
    GROW(S->vb, (size_t)nfree + 1);
    S->vcap = (size_t)nfree + 1;
#undef GROW
  }
  return MO_OK;
}

void nscd_bodies_free(nscd_state *S)
{
  mo_free(S->bmark);
  mo_free(S->nsd);
  mo_free(S->sblk);
  mo_free(S->soff);
  mo_free(S->G);
  mo_free(S->MG);
  mo_free(S->Wd);
  mo_free(S->c);
  mo_free(S->vb);
}

/* Contact a's sides from its d columns of H: the blocks its entries fall in (at most two) and the
   rows of H on each block's dofs, G_as (d x n_k, row-major, stride NK(d)). */
static inline int contact_sides(nscd_state *S, const mo_contact_problem *P, int a, int d, mo_ctx *ctx)
{
  const mo_csc *H = P->H;
  const mo_what_inverse *Wi = P->Wi;
  int i, p, *blk = S->sblk + 2 * a, *ns = S->nsd + a;
  double *G = S->G + (size_t)2 * a * d * NK(d);
  *ns = 0;
  memset(G, 0, (size_t)2 * d * NK(d) * sizeof *G);
  for (i = 0; i < d; i++)
    for (p = H->p[a * d + i]; p < H->p[a * d + i + 1]; p++) {
      int row = H->i[p], k, s;
      if (row < Wi->nfe)
        return mo_error(ctx, MO_EINTERNAL, "nscd: contact %d touches a deformable body, the core should have built W", a);
      k = mo_what_block_of(Wi, row);
      for (s = 0; s < *ns && blk[s] != k; s++) {}
      if (s == *ns) {
        if (*ns == 2) return mo_error(ctx, MO_EINTERNAL, "nscd: contact %d touches more than two bodies", a);
        blk[(*ns)++] = k;
      }
      if (row - Wi->off[k] >= NK(d))
        return mo_error(ctx, MO_EINTERNAL, "nscd: contact %d: a block of %d dofs in a %dD problem", a,
                        Wi->off[k + 1] - Wi->off[k], d);
      G[(size_t)s * d * NK(d) + (size_t)i * NK(d) + (size_t)(row - Wi->off[k])] = H->x[p];
    }
  return MO_OK;
}

/* W_aa, c_a and inv_k G^T of every contact, with d (the contact's dimension) a constant of each
   instance: the loops unroll. */
static inline int prepare_d(nscd_state *S, const mo_contact_problem *P, const int d, mo_ctx *ctx)
{
  const mo_what_inverse *Wi = P->Wi;
  int a, s, i, j, k, q, st;
  for (a = 0; a < S->nc; a++) {
    double *Waa = S->Wd + (size_t)a * d * d, *ca = S->c + (size_t)a * d;
    if ((st = contact_sides(S, P, a, d, ctx))) return st;
    for (i = 0; i < d * d; i++) Waa[i] = 0;
    for (i = 0; i < d; i++) ca[i] = P->b[a * d + i];
    for (s = 0; s < S->nsd[a]; s++) {
      int kb = S->sblk[2 * a + s], o = Wi->off[kb], nk = Wi->off[kb + 1] - o;
      const double *G = S->G + (size_t)(2 * a + s) * d * NK(d);
      double inv[36];
      mo_what_block(Wi, kb, inv);
      S->soff[2 * a + s] = nk == NK(d) ? o : -1;
      double *MG = S->MG + (size_t)(2 * a + s) * d * NK(d); /* inv G^T: nk x d (stride d) */
      if (nk == NK(d)) { /* a free body: the sizes are constants, the loops unroll */
        for (k = 0; k < NK(d); k++)
          for (j = 0; j < d; j++) {
            double acc = 0;
            for (q = 0; q < NK(d); q++) acc += inv[k * NK(d) + q] * G[j * NK(d) + q];
            MG[k * d + j] = acc;
          }
        for (i = 0; i < d; i++) {
          for (j = 0; j < d; j++) {
            double acc = Waa[i * d + j];
            for (k = 0; k < NK(d); k++) acc += G[i * NK(d) + k] * MG[k * d + j];
            Waa[i * d + j] = acc;
          }
          for (k = 0; k < NK(d); k++) ca[i] -= G[i * NK(d) + k] * P->xfree[o + k];
        }
        continue;
      }
      for (k = 0; k < nk; k++)
        for (j = 0; j < d; j++) {
          double acc = 0;
          for (q = 0; q < nk; q++) acc += inv[k * nk + q] * G[j * NK(d) + q];
          MG[k * d + j] = acc;
        }
      /* W_aa += G inv G^T; c = q - G v_free */
      for (i = 0; i < d; i++) {
        for (j = 0; j < d; j++)
          for (k = 0; k < nk; k++) Waa[i * d + j] += G[i * NK(d) + k] * MG[k * d + j];
        for (k = 0; k < nk; k++) ca[i] -= G[i * NK(d) + k] * P->xfree[o + k];
      }
    }
    S->diag[a] = Waa;
  }
  return MO_OK;
}

int nscd_bodies_prepare(nscd_state *S, const mo_contact_problem *P, mo_ctx *ctx)
{
  int st;
  if ((st = reserve(S, P->nfree, ctx))) return st;
  st = S->d == 2 ? prepare_d(S, P, 2, ctx) : S->d == 3 ? prepare_d(S, P, 3, ctx) : prepare_d(S, P, 1, ctx);
  if (st) return st;
  nscd_prepare_local(S, P);
  return MO_OK;
}

/* v += (inv_k G_as^T) dr over the sides of contact a. A side on a free body (soff >= 0) has
   NK(d) dofs, a constant of the instance: the loops unroll and the operands stay in registers
   (a disk's update is 12 multiply-adds each way); a side on a body with fixed components takes
   the generic loop. */
static inline void push(nscd_state *S, const mo_what_inverse *Wi, int a, const double *dr, const int d)
{
  int s, k, j;
  for (s = 0; s < S->nsd[a]; s++) {
    const double *MG = S->MG + (size_t)(2 * a + s) * d * NK(d);
    const int o = S->soff[2 * a + s];
    if (o >= 0) {
      double *restrict v = S->vb + o;
      for (k = 0; k < NK(d); k++) {
        double acc = 0;
        for (j = 0; j < d; j++) acc += MG[k * d + j] * dr[j];
        v[k] += acc;
      }
    } else {
      int kb = S->sblk[2 * a + s], og = Wi->off[kb], nk = Wi->off[kb + 1] - og;
      double *v = S->vb + og;
      for (k = 0; k < nk; k++, MG += d) {
        double acc = 0;
        for (j = 0; j < d; j++) acc += MG[j] * dr[j];
        v[k] += acc;
      }
    }
  }
}

/* U_a = c_a + sum_s G_as v_s (the same two paths as push). */
static inline void local_U(const nscd_state *S, const mo_what_inverse *Wi, int a, double *restrict U, const int d)
{
  int s, i, k;
  double u[3] = {0, 0, 0};
  for (i = 0; i < d; i++) u[i] = S->c[(size_t)a * d + i];
  for (s = 0; s < S->nsd[a]; s++) {
    const double *G = S->G + (size_t)(2 * a + s) * d * NK(d);
    const int o = S->soff[2 * a + s];
    if (o >= 0) {
      const double *restrict v = S->vb + o;
      for (i = 0; i < d; i++)
        for (k = 0; k < NK(d); k++) u[i] += G[i * NK(d) + k] * v[k];
    } else {
      int kb = S->sblk[2 * a + s], og = Wi->off[kb], nk = Wi->off[kb + 1] - og;
      for (i = 0; i < d; i++)
        for (k = 0; k < nk; k++) u[i] += G[i * NK(d) + k] * S->vb[og + k];
    }
  }
  for (i = 0; i < d; i++) U[i] = u[i];
}

void nscd_bodies_velocities(nscd_state *S, const mo_contact_problem *P, const double *r)
{
  int a;
  memcpy(S->vb, P->xfree, (size_t)P->nfree * sizeof *S->vb);
  for (a = 0; a < S->nc; a++) push(S, P->Wi, a, r + (size_t)a * S->d, S->d);
}

void nscd_bodies_exact_U(nscd_state *S, const mo_contact_problem *P)
{
  int a;
  for (a = 0; a < S->nc; a++) local_U(S, P->Wi, a, S->U + (size_t)a * S->d, S->d);
}

static inline int sweep_d(nscd_state *S, const mo_contact_problem *P, double *r, int *status, const int d)
{
  const double omega = S->p.relax, *mu = S->mu;
  const mo_what_inverse *Wi = P->Wi;
  int k, i, j;
  for (k = 0; k < S->nact; k++) {
    const int a = S->order[k];
    const double *Waa = S->diag[a];
    double *ra = r + (size_t)a * d, U[3], ql[3], rl[3], dr[3];
    int st, nz = 0;
    /* the local free term: U_a - W_aa r_a, U_a from the bodies' current velocities */
    local_U(S, Wi, a, U, d);
    for (i = 0; i < d; i++) {
      double acc = U[i];
      for (j = 0; j < d; j++) acc -= Waa[i * d + j] * ra[j];
      ql[i] = acc;
      rl[i] = ra[i];
    }
    st = nscd_local_solve(d, Waa, S->aux + (size_t)a * NSCD_AUX, ql, mu ? mu[a] : 0, rl, &S->lp, &S->lst);
    if (st < 0) return a;
    status[a] = st;
    for (i = 0; i < d; i++) {
      if (omega != 1) rl[i] = omega * rl[i] + (1 - omega) * ra[i]; /* (T37) */
      dr[i] = rl[i] - ra[i];
      nz |= dr[i] != 0;
    }
    if (nz) {
      push(S, Wi, a, dr, d);
      for (i = 0; i < d; i++) ra[i] = rl[i];
    }
  }
  /* the natural-map rules read U: from the velocities at the end of the sweep (Jean's norms read
     r and W_aa only) */
  if (S->p.stop == NSCD_STOP_SCALED || S->p.stop == NSCD_STOP_NATURAL)
    for (k = 0; k < S->nact; k++) local_U(S, Wi, S->act[k], S->U + (size_t)S->act[k] * d, d);
  return -1;
}

int nscd_bodies_sweep(nscd_state *S, const mo_contact_problem *P, double *r, int *status)
{
  return S->d == 2 ? sweep_d(S, P, r, status, 2) : S->d == 3 ? sweep_d(S, P, r, status, 3) : sweep_d(S, P, r, status, 1);
}

void nscd_bodies_dx(const nscd_state *S, const mo_contact_problem *P, double *dx)
{
  const mo_grains *G = P->grains;
  const int nk = NK(S->d);
  int i, k;
  if (!G || !G->hold) {
    for (i = 0; i < P->nfree; i++) dx[i] = S->vb[i] - P->xfree[i];
    return;
  }
  /* the bodies' state per rank: the held bodies' (doc/theory.md §13.18) */
  for (k = 0; k < G->nhlist; k++) {
    const int o = G->vel[G->hlist[k]];
    if (o >= 0)
      for (i = o; i < o + nk; i++) dx[i] = S->vb[i] - P->xfree[i];
  }
}

int nscd_marks_clear(nscd_state *S, size_t n, mo_ctx *ctx)
{
  if (n > S->bmcap) {
    int *q = mo_realloc(ctx, S->bmark, n * sizeof *q);
    if (!q) return MO_ENOMEM;
    S->bmark = q;
    S->bmcap = n;
  }
  memset(S->bmark, 0, n * sizeof *S->bmark);
  return MO_OK;
}

int nscd_bodies_count(nscd_state *S, const mo_contact_problem *P, const double *r, int *unknowns, int *dofs,
                      mo_ctx *ctx)
{
  const mo_what_inverse *Wi = P->Wi;
  const int d = S->d;
  int k, s, st, nu = 0, nd = 0;
  if ((st = nscd_marks_clear(S, (size_t)Wi->nblk + 1, ctx))) return st;
  for (k = 0; k < S->nact; k++) {
    const int a = S->act[k], u = nscd_closed_unknowns(S, a, r + (size_t)a * d, d);
    if (!u) continue;
    nu += u;
    for (s = 0; s < S->nsd[a]; s++) {
      int b = S->sblk[2 * a + s];
      if (!S->bmark[b]) {
        S->bmark[b] = 1;
        nd += Wi->off[b + 1] - Wi->off[b];
      }
    }
  }
  *unknowns = nu;
  *dofs = nd;
  return MO_OK;
}
