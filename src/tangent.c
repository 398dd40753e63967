/* tangent.c: the finite-strain bodies' part of the stepper: the pattern of the tangent iteration
   matrix, the element loops that give internal forces and tangents (scattered into What without
   search), and their stored energy (doc/theory.md §11.1). The stepper (step.c) and Newton
   (newton.c) call it; it calls neither. */
#include "config.h"
#include <moreau/material.h>
#include "step_internal.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* The largest element: nen dim dofs (H8: 24). */
#define ND_MAX MO_ND_MAX

void mo_tangent_release(mo_stepper *S)
{
  mo_free(S->Wlin);
  mo_free(S->emap);
  mo_free(S->emap0);
  mo_free(S->qt);
  mo_free(S->fint);
  mo_free(S->fint0);
  mo_free(S->R);
  mo_free(S->g);
  mo_free(S->xfr);
  mo_free(S->xs);
  mo_free(S->xk);
  mo_free(S->gk);
  mo_free(S->dxp);
  mo_free(S->cfp);
  mo_free(S->work);
}

/* Position of entry (row, col) in the column-compressed W (sorted rows), or -1. */
static int csc_find(const mo_csc *W, int row, int col)
{
  int lo = W->p[col], hi = W->p[col + 1] - 1;
  while (lo <= hi) {
    int mid = (lo + hi) / 2;
    if (W->i[mid] == row) return mid;
    if (W->i[mid] < row) lo = mid + 1;
    else hi = mid - 1;
  }
  return -1;
}

int mo_tangent_set_dt(mo_stepper *S, mo_ctx *ctx)
{
  const mo_scene *sc = S->sc;
  mo_csc *L = NULL;
  int j, p, st;
  if (S->scheme == MO_SCHEME_QUASISTATIC) return MO_OK;
  /* Wlin = cm M + ck K (the linear bodies) scattered onto W's pattern, which holds it */
  if ((st = mo_csc_add(sc->M, sc->K, S->cm, S->ck, &L, ctx))) return st;
  memset(S->Wlin, 0, (size_t)mo_csc_nnz(S->W) * sizeof *S->Wlin);
  for (j = 0; j < L->ncol; j++) {
    int fj = sc->free_of[j];
    if (fj < 0) continue;
    for (p = L->p[j]; p < L->p[j + 1]; p++) {
      int fi = sc->free_of[L->i[p]], q;
      if (fi < 0) continue;
      if ((q = csc_find(S->W, fi, fj)) < 0) {
        mo_csc_free(L);
        return mo_error(ctx, MO_EINTERNAL, "step change: entry (%d, %d) of M + c K is not in the tangent's pattern", fi, fj);
      }
      S->Wlin[q] += L->x[p];
    }
  }
  mo_csc_free(L);
  return MO_OK;
}

/* The pattern of What = cm M + ck K_t over free dofs: the linear part's pattern and every
   element block of the finite-strain bodies, analysed once; the element maps that scatter an
   element tangent into its values (no triplets, no search at run time). */
int mo_tangent_setup(mo_stepper *S, mo_ctx *ctx)
{
  const mo_scene *sc = S->sc;
  mo_triplet T;
  mo_csc *P = NULL, *L = NULL, *Wf = NULL;
  size_t nmap = 0, hint = 0, k;
  int b, e, a, c, i, j, st, D = sc->dim;
  double one[ND_MAX * ND_MAX];
  memset(&T, 0, sizeof T);
  S->nl = 1;
  for (b = 0; b < sc->nbody; b++)
    if (sc->body[b].nl) {
      size_t nd = (size_t)sc->body[b].mesh->nen * (size_t)D;
      nmap += (size_t)sc->body[b].mesh->nelem * nd * nd;
    }
  hint = nmap;
  for (k = 0; k < ND_MAX * ND_MAX; k++) one[k] = 1;
  S->emap = mo_malloc(ctx, (nmap + 1) * sizeof *S->emap);
  S->emap0 = mo_calloc(ctx, (size_t)sc->nbody + 1, sizeof *S->emap0);
  S->qt = mo_calloc(ctx, sc->nq + 1, sizeof *S->qt);
  S->fint = mo_calloc(ctx, (size_t)sc->ndof + 1, sizeof *S->fint);
  S->fint0 = mo_calloc(ctx, (size_t)sc->ndof + 1, sizeof *S->fint0);
  S->R = mo_calloc(ctx, (size_t)sc->ndof + 1, sizeof *S->R);
  S->g = mo_calloc(ctx, (size_t)sc->ndof + 1, sizeof *S->g);
  S->xfr = mo_calloc(ctx, (size_t)sc->ndof + 1, sizeof *S->xfr);
  S->xs = mo_calloc(ctx, (size_t)sc->ndof + 1, sizeof *S->xs);
  S->xk = mo_calloc(ctx, (size_t)sc->ndof + 1, sizeof *S->xk);
  S->gk = mo_calloc(ctx, (size_t)sc->ndof + 1, sizeof *S->gk);
  S->dxp = mo_calloc(ctx, (size_t)sc->ndof + 1, sizeof *S->dxp);
  S->cfp = mo_calloc(ctx, (size_t)sc->ndof + 1, sizeof *S->cfp);
  S->work = mo_malloc(ctx, (3 * ND_MAX + ND_MAX * ND_MAX) * sizeof *S->work);
  if (!S->emap || !S->emap0 || !S->qt || !S->fint || !S->fint0 || !S->R || !S->g || !S->xfr || !S->xs || !S->xk || !S->gk || !S->dxp || !S->cfp || !S->work)
    return MO_ENOMEM;
  /* the finite-strain bodies' structure, with ones (the values are not used) */
  if ((st = mo_triplet_init(&T, sc->ndof, sc->ndof, hint + 1, ctx))) return st;
  for (b = 0; b < sc->nbody; b++) {
    const mo_body *B = &sc->body[b];
    int dofs[ND_MAX], nd;
    if (!B->nl) continue;
    nd = B->mesh->nen * D;
    for (e = 0; e < B->mesh->nelem; e++) {
      for (a = 0; a < B->mesh->nen; a++)
        for (c = 0; c < D; c++) dofs[a * D + c] = B->dof0 + B->mesh->conn[e * B->mesh->nen + a] * D + c;
      if ((st = mo_triplet_add_block(&T, dofs, nd, dofs, nd, one, ctx))) goto done;
    }
  }
  if ((st = mo_triplet_to_csc(&T, 1, &P, ctx))) goto done;
  /* the linear part cm M + ck K (K holds the linear bodies only) */
  if (S->scheme == MO_SCHEME_QUASISTATIC) st = mo_csc_copy(sc->K, &L, ctx);
  else st = mo_csc_add(sc->M, sc->K, S->cm, S->ck, &L, ctx);
  if (!st) st = mo_csc_add(L, P, 1, 0, &Wf, ctx); /* the union of the patterns, P's values x 0 */
  if (!st) st = mo_csc_extract(Wf, sc->free_of, sc->nfe_free, sc->free_of, sc->nfe_free, &S->W, ctx);
  if (st) goto done;
  S->Wlin = mo_malloc(ctx, ((size_t)mo_csc_nnz(S->W) + 1) * sizeof *S->Wlin);
  if (!S->Wlin) { st = MO_ENOMEM; goto done; }
  memcpy(S->Wlin, S->W->x, (size_t)mo_csc_nnz(S->W) * sizeof *S->Wlin);
  /* element maps */
  k = 0;
  for (b = 0; b < sc->nbody; b++) {
    const mo_body *B = &sc->body[b];
    int nd;
    S->emap0[b] = k;
    if (!B->nl) continue;
    nd = B->mesh->nen * D;
    for (e = 0; e < B->mesh->nelem; e++) {
      int fr[ND_MAX];
      for (a = 0; a < B->mesh->nen; a++)
        for (c = 0; c < D; c++) fr[a * D + c] = sc->free_of[B->dof0 + B->mesh->conn[e * B->mesh->nen + a] * D + c];
      for (i = 0; i < nd; i++)
        for (j = 0; j < nd; j++) {
          int p = fr[i] >= 0 && fr[j] >= 0 ? csc_find(S->W, fr[i], fr[j]) : -1;
          if (fr[i] >= 0 && fr[j] >= 0 && p < 0) {
            st = mo_error(ctx, MO_EINTERNAL, "tangent pattern: entry (%d, %d) of body '%s' element %d missing",
                          fr[i], fr[j], B->name, e);
            goto done;
          }
          S->emap[k++] = p;
        }
    }
  }
  S->emap0[sc->nbody] = k;
done:
  mo_triplet_release(&T);
  mo_csc_free(P);
  mo_csc_free(L);
  mo_csc_free(Wf);
  return st;
}

int mo_tangent_forces(mo_stepper *S, const double *u, const double *q, double *f, int tangent,
                     const double *dxp, double *cfp, mo_ctx *ctx)
{
  const mo_scene *sc = S->sc;
  const int D = sc->dim;
  double *ue = S->work, *fe = ue + ND_MAX, *Ke = fe + ND_MAX, *Wx = S->W->x, t0 = mo_clock();
  int b, e, a, c, i, nbad = 0, st = MO_OK, list = 0;
  char first[MO_ERRMSG_MAX] = "", where[400] = "";
  size_t len = 0;
  mo_csc_gaxpy(sc->K, 1, u, 0, f);
  if (tangent) memcpy(Wx, S->Wlin, (size_t)mo_csc_nnz(S->W) * sizeof *Wx);
  for (b = 0; b < sc->nbody; b++) {
    const mo_body *B = &sc->body[b];
    const mo_mesh *m = B->mesh;
    int nen, nd, ns;
    if (!B->nl) continue;
    nen = m->nen;
    nd = nen * D;
    ns = B->npoint * MO_J2_NSTATE;
    for (e = 0; e < m->nelem; e++) {
      const int *cn = &m->conn[e * nen];
      size_t off = B->q0 + (size_t)e * (size_t)ns;
      for (a = 0; a < nen; a++)
        for (c = 0; c < D; c++) ue[a * D + c] = u[B->dof0 + cn[a] * D + c];
      st = mo_elem_nl_force(m, e, B->mat, 0, ue, q + off, S->qt + off, fe, tangent ? Ke : NULL, ctx);
      if (st == MO_ENAN) {
        /* an inverted element: collect them all for the diagnosis, then stop */
        if (!nbad++) snprintf(first, sizeof first, "%s", ctx->errmsg);
        if (list < 12) {
          int w = snprintf(where + len, sizeof where - len, "%s'%s' element %d", list ? ", " : "",
                           B->name, e);
          if (w > 0 && (size_t)w < sizeof where - len) len += (size_t)w;
          list++;
        }
        mo_ctx_clear_error(ctx);
        st = MO_OK;
        continue;
      }
      if (st) return st;
      for (a = 0; a < nen; a++)
        for (c = 0; c < D; c++) f[B->dof0 + cn[a] * D + c] += fe[a * D + c];
      if (tangent) {
        const int *map = S->emap + S->emap0[b] + (size_t)e * (size_t)nd * (size_t)nd;
        double ck = S->ck;
        for (i = 0; i < nd * nd; i++)
          if (map[i] >= 0) Wx[map[i]] += ck * Ke[i];
        if (dxp) {
          /* ck K_t,e dx_p: the coupling of a prescribed increment into the free rows */
          double de[ND_MAX];
          int any = 0, j;
          for (a = 0; a < nen; a++)
            for (c = 0; c < D; c++) any |= (de[a * D + c] = dxp[B->dof0 + cn[a] * D + c]) != 0;
          if (any)
            for (i = 0; i < nd; i++) {
              double acc = 0;
              for (j = 0; j < nd; j++) acc += Ke[i * nd + j] * de[j];
              cfp[B->dof0 + cn[i / D] * D + i % D] += ck * acc;
            }
        }
      }
    }
  }
  mo_phase_add(ctx, MO_PH_ASSEMBLY, t0);
  if (nbad)
    return mo_error(ctx, MO_ENAN, "%d element%s inverted (det F <= 0): %s%s; the first: %s", nbad,
                    nbad > 1 ? "s" : "", where, nbad > list ? ", ..." : "", first);
  return MO_OK;
}

void mo_tangent_energies(const mo_stepper *S, const double *q, double *psi, double *wp)
{
  const mo_scene *sc = S->sc;
  int b, e;
  *psi = *wp = 0;
  for (b = 0; b < sc->nbody; b++) {
    const mo_body *B = &sc->body[b];
    size_t ns;
    if (!B->nl) continue;
    ns = (size_t)B->npoint * MO_J2_NSTATE;
    for (e = 0; e < B->mesh->nelem; e++) {
      double p, w;
      if (mo_elem_nl_energy(B->mesh, e, B->mat, q + B->q0 + (size_t)e * ns, &p, &w) == MO_OK) {
        *psi += p;
        *wp += w;
      }
    }
  }
}

