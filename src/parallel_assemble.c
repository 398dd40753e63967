/* parallel_assemble.c: K and M assembled over the ranks straight into distributed matrices
   (doc/parallel.md §3). Each rank computes the element matrices of its block of elements and
   owns the rows of the dofs its block reaches first, so that most element entries land in its
   own rows; the others go to their ranks through PETSc's stash. The rows are preallocated
   exactly from a pass over the connectivity of every element that reaches them. */
#include "config.h"
#include <moreau/parallel.h>
#include <moreau/scene.h>
#include <moreau/fe.h>

#include <string.h>

/* The deformable bodies' elements, numbered body after body (scene.c's order), split over the
   ranks in contiguous blocks: nelem / nranks each, the first nelem % nranks ranks one more. */
static long count_elements(const mo_scene *sc)
{
  long n = 0;
  int b;
  for (b = 0; b < sc->nbody; b++)
    if (sc->body[b].kind == MO_BODY_DEFORMABLE) n += sc->body[b].mesh->nelem;
  return n;
}

static int rank_of(long g, long n, int nranks)
{
  long q = n / nranks, m = n % nranks;
  if (g < m * (q + 1)) return (int)(g / (q + 1));
  return (int)(m + (g - m * (q + 1)) / q);
}

/* An element's dofs (scene.c's numbering: dof0 + node D + component). */
static int element_dofs(const mo_scene *sc, const mo_body *B, int e, int *dofs)
{
  const mo_mesh *m = B->mesh;
  int a, c, D = sc->dim;
  for (a = 0; a < m->nen; a++)
    for (c = 0; c < D; c++) dofs[a * D + c] = B->dof0 + m->conn[e * m->nen + a] * D + c;
  return m->nen * D;
}

/* The rows of every rank, and PETSc's order of the dofs. A dof is reached by the elements of one
   rank, or of several (the interfaces between the blocks): ranks f (its first element's, the
   lowest, as the blocks follow the element order) to l (its last element's). A dof reached by
   one rank's elements is that rank's; an interface node goes to f or to l, every other node
   (by its number), so that the interfaces split in halves; a dof no element reaches (the rigid
   bodies', after the nodal ones) goes with the dof before it. PETSc's rows are the dofs rank
   after rank, in the scene's order within a rank: contiguous ranges whatever the mesh's
   numbering. */
static int row_order(const mo_scene *sc, long nel, int *start, int *perm, mo_ctx *ctx)
{
  int *first, *last, b, e, k, r, dofs[MO_ND_MAX], nr = ctx->nranks, D = sc->dim;
  long g = 0;
  first = mo_malloc(ctx, ((size_t)sc->ndof + 1) * sizeof *first);
  last = perm; /* the last ranks first, the owners then, then the rows */
  if (!first) return MO_ENOMEM;
  for (k = 0; k < sc->ndof; k++) first[k] = last[k] = -1;
  for (b = 0; b < sc->nbody; b++) {
    const mo_body *B = &sc->body[b];
    if (B->kind != MO_BODY_DEFORMABLE) continue;
    for (e = 0; e < B->mesh->nelem; e++, g++) {
      int nd = element_dofs(sc, B, e, dofs), rk = rank_of(g, nel, nr);
      for (k = 0; k < nd; k++) {
        if (first[dofs[k]] < 0) first[dofs[k]] = rk;
        last[dofs[k]] = rk;
      }
    }
  }
  for (r = 0; r <= nr; r++) start[r] = 0;
  for (k = 0; k < sc->ndof; k++) {
    int *own = perm;
    if (first[k] < 0) own[k] = k ? own[k - 1] : 0;
    else if (first[k] != last[k] && !((k / D) & 1)) own[k] = first[k];
    start[own[k] + 1]++;
  }
  for (r = 0; r < nr; r++) start[r + 1] += start[r];
  /* first[] now counts each rank's rows placed so far */
  for (r = 0; r < nr; r++) first[r] = start[r];
  for (k = 0; k < sc->ndof; k++) perm[k] = first[perm[k]]++;
  mo_free(first);
  return MO_OK;
}

/* The entries of this rank's rows of K and M (in and out of its diagonal block), from the
   connectivity of every element that reaches them: a node's rows couple every dof of the nodes it
   shares an element with (a lumped mass: its own dof only; finite-strain bodies: no constant
   stiffness). Per body, the elements of each node (a count, then a fill), and a stamp per node. */
static int count_rows(const mo_scene *sc, const mo_dist_assembly *A, int with_mass, int *dk, int *ok, int *dm,
                      int *om, mo_ctx *ctx)
{
  int b, D = sc->dim, nloc = A->rend - A->rstart;
  memset(dk, 0, (size_t)nloc * sizeof *dk);
  memset(ok, 0, (size_t)nloc * sizeof *ok);
  if (with_mass) {
    memset(dm, 0, (size_t)nloc * sizeof *dm);
    memset(om, 0, (size_t)nloc * sizeof *om);
  }
  for (b = 0; b < sc->nbody; b++) {
    const mo_body *B = &sc->body[b];
    const mo_mesh *m = B->mesh;
    int *ptr, *elem, *stamp, a, e, k, p, c;
    if (B->kind != MO_BODY_DEFORMABLE) continue;
    ptr = mo_calloc(ctx, (size_t)m->nnode + 1, sizeof *ptr);
    elem = mo_malloc(ctx, ((size_t)m->nelem * m->nen + 1) * sizeof *elem);
    stamp = mo_malloc(ctx, ((size_t)m->nnode + 1) * sizeof *stamp);
    if (!ptr || !elem || !stamp) {
      mo_free(ptr);
      mo_free(elem);
      mo_free(stamp);
      return MO_ENOMEM;
    }
    for (k = 0; k < m->nelem * m->nen; k++) ptr[m->conn[k] + 1]++;
    for (a = 0; a < m->nnode; a++) {
      ptr[a + 1] += ptr[a];
      stamp[a] = -1;
    }
    for (e = 0; e < m->nelem; e++)
      for (k = 0; k < m->nen; k++) elem[ptr[m->conn[e * m->nen + k]]++] = e;
    for (a = m->nnode; a > 0; a--) ptr[a] = ptr[a - 1];
    ptr[0] = 0;
    for (a = 0; a < m->nnode; a++) {
      int row = A->row[B->dof0 + a * D] - A->rstart, in = 0, out = 0;
      if (row < 0 || row >= nloc) continue;
      for (p = ptr[a]; p < ptr[a + 1]; p++)
        for (k = 0; k < m->nen; k++) {
          int q = m->conn[elem[p] * m->nen + k], r = A->row[B->dof0 + q * D];
          if (stamp[q] == a) continue;
          stamp[q] = a;
          if (r >= A->rstart && r < A->rend) in += D;
          else out += D;
        }
      for (c = 0; c < D; c++) {
        int i = A->row[B->dof0 + a * D + c] - A->rstart;
        if (!B->nl) {
          dk[i] = in;
          ok[i] = out;
        }
        /* a consistent mass couples a dof with the same component of its neighbours only */
        if (with_mass) {
          dm[i] = B->lumped ? 1 : in / D;
          om[i] = B->lumped ? 0 : out / D;
        }
      }
    }
    mo_free(ptr);
    mo_free(elem);
    mo_free(stamp);
  }
  return MO_OK;
}

/* An element's mass into M: a lumped mass its diagonal, a consistent one a block per component
   (m_ab I: the entries between components are zeros), as the rows were counted. */
static int add_mass(mo_dmat *M, int D, int nd, const int *dofs, const double *Me, int lumped, mo_ctx *ctx)
{
  int nen = nd / D, a, b, c, k, st, sub[MO_NEN_MAX];
  double Mc[MO_NEN_MAX * MO_NEN_MAX];
  if (lumped) {
    for (k = 0; k < nd; k++)
      if ((st = mo_dmat_add(M, 1, dofs + k, Me + k * nd + k, ctx))) return st;
    return MO_OK;
  }
  for (c = 0; c < D; c++) {
    for (a = 0; a < nen; a++) {
      sub[a] = dofs[a * D + c];
      for (b = 0; b < nen; b++) Mc[b * nen + a] = Me[(b * D + c) * nd + a * D + c];
    }
    if ((st = mo_dmat_add(M, nen, sub, Mc, ctx))) return st;
  }
  return MO_OK;
}

/* This rank's elements into K and M (K's blocks whole, their zeros included: the entries of
   the pattern counted above). */
static int add_elements(const mo_scene *sc, long lo, long hi, int with_mass, mo_dist_assembly *A, double *inrows,
                        mo_ctx *ctx)
{
  double Ke[MO_ND_MAX * MO_ND_MAX], Me[MO_ND_MAX * MO_ND_MAX];
  int b, e, k, st, dofs[MO_ND_MAX];
  long g = 0;
  for (b = 0; b < sc->nbody; b++) {
    const mo_body *B = &sc->body[b];
    int ne;
    if (B->kind != MO_BODY_DEFORMABLE) continue;
    ne = B->mesh->nelem;
    for (e = 0; e < ne; e++, g++) {
      int nd;
      if (g < lo || g >= hi) continue;
      if (!(e & 0xffff) && MO_INTERRUPTED(ctx))
        return mo_error(ctx, MO_EINTERRUPT, "interrupted while assembling body '%s' (element %d of %d)", B->name, e, ne);
      nd = element_dofs(sc, B, e, dofs);
      for (k = 0; k < nd; k++) inrows[A->row[dofs[k]] >= A->rstart && A->row[dofs[k]] < A->rend]++;
      /* finite-strain bodies have no constant stiffness (scene.c's assemble) */
      if (!B->nl && ((st = mo_elem_stiffness(B->mesh, e, B->mat, Ke, ctx)) ||
                     (st = mo_dmat_add(A->K, nd, dofs, Ke, ctx))))
        return st;
      if (with_mass && ((st = mo_elem_mass(B->mesh, e, B->mat, B->lumped, Me, ctx)) ||
                        (st = add_mass(A->M, sc->dim, nd, dofs, Me, B->lumped, ctx))))
        return st;
    }
  }
  return MO_OK;
}

int mo_scene_assemble_distributed(const mo_scene *sc, int with_mass, mo_dist_assembly *out, mo_ctx *ctx)
{
  long nel = count_elements(sc), q, m, lo, hi;
  int *start = NULL, *nz = NULL, st, nloc = 0;
  double t0 = mo_clock(), inrows[2] = {0, 0};
  memset(out, 0, sizeof *out);
  q = nel / ctx->nranks;
  m = nel % ctx->nranks;
  lo = ctx->rank * q + (ctx->rank < m ? ctx->rank : m);
  hi = lo + q + (ctx->rank < m);
  if (!(start = mo_malloc(ctx, ((size_t)ctx->nranks + 1) * sizeof *start)) ||
      !(out->row = mo_malloc(ctx, ((size_t)sc->ndof + 1) * sizeof *out->row)))
    st = MO_ENOMEM;
  else
    st = row_order(sc, nel, start, out->row, ctx);
  if (!st) {
    out->rstart = start[ctx->rank];
    out->rend = start[ctx->rank + 1];
    out->elements = hi - lo;
    nloc = out->rend - out->rstart;
    if (!(nz = mo_malloc(ctx, (4 * (size_t)nloc + 1) * sizeof *nz))) st = MO_ENOMEM;
  }
  if (!st) st = count_rows(sc, out, with_mass, nz, nz + nloc, nz + 2 * nloc, nz + 3 * nloc, ctx);
  /* a rank that failed alone must not leave the others in the collective calls below */
  if ((st = mo_par_agree(st, ctx))) goto done;
  st = mo_dmat_create(sc->ndof, out->rstart, out->rend, out->row, nz, nz + nloc, &out->K, ctx);
  if (!st && with_mass) st = mo_dmat_create(sc->ndof, out->rstart, out->rend, out->row, nz + 2 * nloc, nz + 3 * nloc,
                                            &out->M, ctx);
  if ((st = mo_par_agree(st, ctx))) goto done;
  st = add_elements(sc, lo, hi, with_mass, out, inrows, ctx);
  if ((st = mo_par_agree(st, ctx))) goto done;
  if ((st = mo_dmat_assemble(out->K, ctx)) || (with_mass && (st = mo_dmat_assemble(out->M, ctx)))) goto done;
  out->seconds = mo_clock() - t0;
  if ((st = mo_par_sum(inrows, 2, ctx))) goto done;
  out->local = inrows[0] + inrows[1] > 0 ? inrows[1] / (inrows[0] + inrows[1]) : 1;
done:
  mo_free(start);
  mo_free(nz);
  if (st) mo_dist_assembly_free(out);
  return st;
}

void mo_dist_assembly_free(mo_dist_assembly *a)
{
  mo_dmat_free(a->K);
  mo_dmat_free(a->M);
  mo_free(a->row);
  a->K = a->M = NULL;
  a->row = NULL;
}
