/* levelset_bodies.c: the hybrid smoother's sweep on body velocities (doc/theory.md (T145)), for
   contact sets that join rigid bodies and obstacles only: v = What^-1 H r is kept up to date
   candidate by candidate, U'_j = H_j^T v + q_j read from the (at most two) bodies of candidate j,
   so that one local update costs O(1) instead of a pass over W's block row j. The layout is that
   of nscd's sweep on bodies (solvers/nscd/nscd_bodies.c: per side the rows of H on the body's
   dofs, G, and What_k^-1 G^T): the same operator, kept here for levelset's own state. */
#include "config.h"
#include "levelset.h"

#include <moreau/step.h>
#include <string.h>


void ls_bodies_free(ls_bodies *B)
{
  mo_free(B->nsd);
  mo_free(B->blk);
  mo_free(B->so);
  mo_free(B->snk);
  mo_free(B->G);
  mo_free(B->MG);
  mo_free(B->v);
  memset(B, 0, sizeof *B);
}

static int reserve(ls_bodies *B, int nc, int d, int nfree, mo_ctx *ctx)
{
  void *p;
  if ((size_t)nc + 1 > B->cap) {
    size_t n = (size_t)nc + 1;
#define GROW(ptr, k) if (!(p = mo_realloc(ctx, ptr, (k) * sizeof *(ptr)))) return MO_ENOMEM; ptr = p
    GROW(B->nsd, n);
    GROW(B->blk, 2 * n);
    GROW(B->so, 2 * n);
    GROW(B->snk, 2 * n);
    GROW(B->G, 2 * n * 3 * LS_BODY_NK);
    GROW(B->MG, 2 * n * 3 * LS_BODY_NK);
    B->cap = n;
  }
  if ((size_t)nfree + 1 > B->vcap) {
    GROW(B->v, (size_t)nfree + 1);
    B->vcap = (size_t)nfree + 1;
#undef GROW
  }
  (void)d;
  return MO_OK;
}

/* Candidate j's sides from its d columns of H: the rigid blocks its entries fall in (at most two),
   G_js (d x nk, stride LS_BODY_NK) and What_k^-1 G_js^T (nk x d). Returns 0 when a column reaches a
   nodal dof or a third body (the sweep on W's rows then applies). */
static int sides(ls_bodies *B, const mo_contact_problem *P, int j)
{
  const mo_csc *H = P->H;
  const mo_what_inverse *Wi = P->Wi;
  const int d = P->dim;
  int i, p, s, k, t, q, *blk = B->blk + 2 * j, *ns = B->nsd + j;
  double *G = B->G + (size_t)2 * j * 3 * LS_BODY_NK, inv[36];
  *ns = 0;
  memset(G, 0, (size_t)2 * 3 * LS_BODY_NK * sizeof *G);
  for (i = 0; i < d; i++)
    for (p = H->p[j * d + i]; p < H->p[j * d + i + 1]; p++) {
      int row = H->i[p];
      if (row < Wi->nfe) return 0;
      k = mo_what_block_of(Wi, row);
      for (s = 0; s < *ns && blk[s] != k; s++) {}
      if (s == *ns) {
        if (*ns == 2 || Wi->off[k + 1] - Wi->off[k] > LS_BODY_NK) return 0;
        blk[(*ns)++] = k;
      }
      G[(size_t)s * 3 * LS_BODY_NK + (size_t)i * LS_BODY_NK + (size_t)(row - Wi->off[k])] = H->x[p];
    }
  for (s = 0; s < *ns; s++) {
    const int nk = Wi->off[blk[s] + 1] - Wi->off[blk[s]];
    const double *Gs = G + (size_t)s * 3 * LS_BODY_NK;
    double *MG = B->MG + (size_t)(2 * j + s) * 3 * LS_BODY_NK;
    B->so[2 * j + s] = Wi->off[blk[s]];
    B->snk[2 * j + s] = nk;
    mo_what_block(Wi, blk[s], inv);
    for (k = 0; k < nk; k++)
      for (t = 0; t < d; t++) {
        double acc = 0;
        for (q = 0; q < nk; q++) acc += inv[k * nk + q] * Gs[t * LS_BODY_NK + q];
        MG[k * d + t] = acc;
      }
  }
  return 1;
}

int ls_bodies_build(ls_bodies *B, const mo_contact_problem *P, mo_ctx *ctx)
{
  int j, st;
  B->ok = 0;
  if (!P->H || !P->Wi || P->nfree <= 0 || P->dim < 1 || P->dim > 3) return MO_OK;
  if ((st = reserve(B, P->nc, P->dim, P->nfree, ctx))) return st;
  for (j = 0; j < P->nc; j++)
    if (!sides(B, P, j)) return MO_OK;
  B->ok = 1;
  return MO_OK;
}

void ls_bodies_velocity(ls_bodies *B, const mo_contact_problem *P, const double *r)
{
  int j, t;
  memset(B->v, 0, (size_t)P->nfree * sizeof *B->v);
  for (j = 0; j < P->nc; j++) {
    const double *rj = r + (size_t)j * P->dim;
    int nz = 0;
    for (t = 0; t < P->dim; t++) nz |= rj[t] != 0;
    if (nz) ls_bodies_push(B, j, rj, P->dim);
  }
}
