/* parallel_assemble.c: K and M assembled over the ranks straight into distributed matrices
   (doc/parallel.md §3). Each rank computes the element matrices of its block of elements and
   owns the rows of the dofs its block reaches first, so that most element entries land in its
   own rows; the others go to their ranks through PETSc's stash. The rows are preallocated
   exactly from a first pass over the same blocks' connectivity. */
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

/* One pass over this rank's elements: the pattern (values NULL: zeros) or the values. */
static int add_elements(const mo_scene *sc, long lo, long hi, int with_mass, mo_dist_assembly *A, int values,
                        double *inrows, mo_ctx *ctx)
{
  static const double zero[MO_ND_MAX * MO_ND_MAX];
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
      nd = element_dofs(sc, B, e, dofs);
      if (!values) {
        /* finite-strain bodies have no constant stiffness (scene.c's assemble) */
        if (!B->nl && (st = mo_dmat_add(A->K, nd, dofs, zero, ctx))) return st;
        if (with_mass && (st = mo_dmat_add(A->M, nd, dofs, zero, ctx))) return st;
        for (k = 0; k < nd; k++) inrows[A->row[dofs[k]] >= A->rstart && A->row[dofs[k]] < A->rend]++;
        continue;
      }
      if (!(e & 0xffff) && MO_INTERRUPTED(ctx))
        return mo_error(ctx, MO_EINTERRUPT, "interrupted while assembling body '%s' (element %d of %d)", B->name, e, ne);
      if (!B->nl && ((st = mo_elem_stiffness(B->mesh, e, &B->mat, Ke, ctx)) ||
                     (st = mo_dmat_add(A->K, nd, dofs, Ke, ctx))))
        return st;
      if (with_mass && ((st = mo_elem_mass(B->mesh, e, &B->mat, B->lumped, Me, ctx)) ||
                        (st = mo_dmat_add(A->M, nd, dofs, Me, ctx))))
        return st;
    }
  }
  return MO_OK;
}

int mo_scene_assemble_distributed(const mo_scene *sc, int with_mass, mo_dist_assembly *out, mo_ctx *ctx)
{
  long nel = count_elements(sc), q, m, lo, hi;
  int *start = NULL, st, agreed;
  double t0 = mo_clock(), inrows[2] = {0, 0};
  memset(out, 0, sizeof *out);
  if (!(start = mo_malloc(ctx, ((size_t)ctx->nranks + 1) * sizeof *start))) return mo_par_agree(MO_ENOMEM, ctx);
  q = nel / ctx->nranks;
  m = nel % ctx->nranks;
  lo = ctx->rank * q + (ctx->rank < m ? ctx->rank : m);
  hi = lo + q + (ctx->rank < m);
  if (!(out->row = mo_malloc(ctx, ((size_t)sc->ndof + 1) * sizeof *out->row))) st = MO_ENOMEM;
  else st = row_order(sc, nel, start, out->row, ctx);
  /* a rank that failed alone must not leave the others in the collective calls below */
  if ((st = mo_par_agree(st, ctx))) goto done;
  out->rstart = start[ctx->rank];
  out->rend = start[ctx->rank + 1];
  out->elements = hi - lo;
  st = mo_dmat_create(sc->ndof, out->rstart, out->rend, out->row, &out->K, ctx);
  if (!st && with_mass) st = mo_dmat_create(sc->ndof, out->rstart, out->rend, out->row, &out->M, ctx);
  if (!st) st = add_elements(sc, lo, hi, with_mass, out, 0, inrows, ctx);
  if ((st = mo_par_agree(st, ctx))) goto done;
  if ((st = mo_dmat_assemble(out->K, ctx)) || (with_mass && (st = mo_dmat_assemble(out->M, ctx)))) goto done;
  st = add_elements(sc, lo, hi, with_mass, out, 1, inrows, ctx);
  if ((st = mo_par_agree(st, ctx))) goto done;
  if ((st = mo_dmat_assemble(out->K, ctx)) || (with_mass && (st = mo_dmat_assemble(out->M, ctx)))) goto done;
  out->seconds = mo_clock() - t0;
  if ((st = mo_par_sum(inrows, 2, ctx))) goto done;
  out->local = inrows[0] + inrows[1] > 0 ? inrows[1] / (inrows[0] + inrows[1]) : 1;
done:
  agreed = st;
  mo_free(start);
  if (agreed) mo_dist_assembly_free(out);
  return agreed;
}

void mo_dist_assembly_free(mo_dist_assembly *a)
{
  mo_dmat_free(a->K);
  mo_dmat_free(a->M);
  mo_free(a->row);
  a->K = a->M = NULL;
  a->row = NULL;
}
