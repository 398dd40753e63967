/* scene.c: building a scene from a validated case (meshes, dofs, assembly, loads, settings). */
#include "config.h"
#include <moreau/scene.h>
#include <moreau/material.h>
#include <moreau/parallel.h>
#include "case_internal.h"
#include "scene_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>


const char *mo_quantity_name(mo_quantity q)
{
  static const char *n[MO_Q_N] = {"ux", "uy", "uz", "vx", "vy", "vz", "fx", "fy", "fz",
                                  "cx", "cy", "cz", "pn", "gn", "lam"};
  return (unsigned)q < MO_Q_N ? n[q] : "?";
}

/* doc/theory.md (T101): the amplification matrix of (T1)-(T2) on a mode u'' + w^2 u = 0, with
   Omega = h w, has det P = (1 + Omega^2 (1 - theta)(1 - theta_f)) / (1 + Omega^2 theta theta_f)
   and trace T = (2 - Omega^2 (theta + theta_f - 2 theta theta_f)) / (1 + Omega^2 theta theta_f);
   its roots stay in the unit disk iff P <= 1 (theta + theta_f >= 1) and T >= -(1 + P), i.e.
   Omega^2 (1 - 2 theta)(2 theta_f - 1) <= 4. */
int mo_theta_stability(double theta, double theta_f, double *omega_h)
{
  double c = (1 - 2 * theta) * (2 * theta_f - 1);
  if (omega_h) *omega_h = HUGE_VAL;
  if (theta + theta_f < 1 - 1e-12) {
    if (omega_h) *omega_h = 0;
    return MO_STAB_UNSTABLE;
  }
  if (c <= 0) return MO_STAB_UNCONDITIONAL;
  if (omega_h) *omega_h = 2 / sqrt(c);
  return MO_STAB_CONDITIONAL;
}

/* Dilatational (P-) wave speed of a linear elastic material (T102). */
static double wave_speed(const mo_material *m)
{
  double E = m->E, nu = m->nu;
  switch (m->hyp) {
  case MO_HYP_BAR: return sqrt(E / m->rho);
  case MO_HYP_PLANE_STRESS: return sqrt(E / (m->rho * (1 - nu * nu)));
  default: return sqrt(E * (1 - nu) / (m->rho * (1 + nu) * (1 - 2 * nu)));
  }
}

/* Measure of facet f of element e (a length in 2D, an area in 3D; 0 for a point). */
static double facet_measure(const mo_mesh *m, const mo_eltype_info *T, int e, int f)
{
  const int *c = m->conn + (size_t)e * (size_t)m->nen, *fn = T->facet[f];
  const double *x0 = m->x + (size_t)c[fn[0]] * (size_t)m->dim;
  int i;
  if (T->nfv == 2) {
    const double *x1 = m->x + (size_t)c[fn[1]] * (size_t)m->dim;
    double s = 0;
    for (i = 0; i < m->dim; i++) s += (x1[i] - x0[i]) * (x1[i] - x0[i]);
    return sqrt(s);
  }
  if (T->nfv >= 3 && m->dim == 3) {
    /* a triangle: |ab x ac| / 2; a planar quad: |ac x bd| / 2 */
    const double *a = x0, *b = m->x + (size_t)c[fn[1]] * 3, *cc = m->x + (size_t)c[fn[2]] * 3;
    const double *d = T->nfv == 4 ? m->x + (size_t)c[fn[3]] * 3 : NULL;
    double p[3], q[3], r[3];
    for (i = 0; i < 3; i++) {
      p[i] = d ? cc[i] - a[i] : b[i] - a[i];
      q[i] = d ? d[i] - b[i] : cc[i] - a[i];
    }
    r[0] = p[1] * q[2] - p[2] * q[1];
    r[1] = p[2] * q[0] - p[0] * q[2];
    r[2] = p[0] * q[1] - p[1] * q[0];
    return 0.5 * sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
  }
  return 0;
}

/* (T102): l_e = measure / largest facet (bar: its length; T3: twice, T4: three times, the
   smallest altitude; Q4, H8: area over the longest side, volume over the largest face; T6, T10:
   the altitude of their corners' simplex over sqrt 6, (T192)), dt_e = l_e / c_d. */
double mo_scene_dt_crit(const mo_scene *sc, int *body, int *elem)
{
  double best = HUGE_VAL;
  int b, e, f, q, i;
  if (body) *body = -1;
  if (elem) *elem = -1;
  for (b = 0; b < sc->nbody; b++) {
    const mo_body *B = &sc->body[b];
    const mo_mesh *m = B->mesh;
    const mo_eltype_info *T;
    double c;
    if (B->kind != MO_BODY_DEFORMABLE || !m) continue;
    T = mo_eltype_get(m->type);
    c = wave_speed(B->mat);
    if (!(c > 0) || !isfinite(c)) continue;
    for (e = 0; e < m->nelem; e++) {
      double meas = 0, fmax = 0, l;
      if (m->type != MO_EL_Q4 && m->type != MO_EL_H8) {
        /* a bar or a simplex: the measure of its corners */
        const int *cn = m->conn + (size_t)e * (size_t)m->nen;
        const double *x0 = m->x + (size_t)cn[0] * (size_t)m->dim, *x1 = m->x + (size_t)cn[1] * (size_t)m->dim;
        if (m->type == MO_EL_BAR2) meas = fabs(x1[0] - x0[0]);
        else if (m->dim == 2) {
          const double *x2 = m->x + (size_t)cn[2] * 2;
          meas = 0.5 * fabs((x1[0] - x0[0]) * (x2[1] - x0[1]) - (x1[1] - x0[1]) * (x2[0] - x0[0]));
        } else {
          const double *x2 = m->x + (size_t)cn[2] * 3, *x3 = m->x + (size_t)cn[3] * 3;
          double p[3], q2[3], r[3];
          for (i = 0; i < 3; i++) {
            p[i] = x1[i] - x0[i];
            q2[i] = x2[i] - x0[i];
            r[i] = x3[i] - x0[i];
          }
          meas = fabs(p[0] * (q2[1] * r[2] - q2[2] * r[1]) - p[1] * (q2[0] * r[2] - q2[2] * r[0]) +
                      p[2] * (q2[0] * r[1] - q2[1] * r[0])) / 6;
        }
      } else {
        /* Q4, H8: the 2^dim Gauss points of weight 1 integrate det J exactly */
        double xi[3], N[8], dNx[24], xq[3];
        const double g = 1 / sqrt(3.0);
        for (q = 0; q < (1 << m->dim); q++) {
          for (i = 0; i < m->dim; i++) xi[i] = (q >> i) & 1 ? g : -g;
          meas += mo_elem_geometry(m, e, xi, N, dNx, xq);
        }
      }
      if (m->type == MO_EL_BAR2) l = meas;
      else {
        for (f = 0; f < T->nfacet; f++) {
          double fm = facet_measure(m, T, e, f);
          if (fm > fmax) fmax = fm;
        }
        /* the altitude: d measure / largest facet for a simplex of dimension d */
        l = fmax > 0 ? (T->nvert == m->dim + 1 ? m->dim : 1) * meas / fmax : 0;
        if (T->order == 2) l /= sqrt(6.0);
      }
      if (l > 0 && l / c < best) {
        best = l / c;
        if (body) *body = b;
        if (elem) *elem = e;
      }
    }
  }
  return best;
}

/* lmax over the free columns of K and M (held NULL: all; else those that several ranks hold
   when shared, the others when not), any when a column counted, nan when a mass is not
   diagonal. */
static void dt_bound_columns(const mo_scene *sc, const mo_csc *K, const mo_csc *M, const double *held, int shared,
                             double *lmax, int *any, int *nan)
{
  int j, p, n = sc->nfe_dof;
  for (j = 0; j < n; j++) {
    double mjj = 0, rs = 0;
    if (sc->free_of[j] < 0 || (held && (held[j] > 1.5) != shared)) continue;
    for (p = M->p[j]; p < M->p[j + 1]; p++) {
      if (M->i[p] == j) mjj += M->x[p];
      else if (M->x[p] != 0) *nan = 1;
    }
    /* K symmetric: column j holds row j */
    for (p = K->p[j]; p < K->p[j + 1]; p++) rs += fabs(K->x[p]);
    if (!(mjj > 0)) continue;
    if (rs / mjj > *lmax) *lmax = rs / mjj;
    *any = 1;
  }
}

/* (T103a): a guaranteed bound. With a diagonal (lumped) mass, Gershgorin's theorem on the
   free rows of M^-1 K bounds omega_max^2 <= max_i sum_j |K_ij| / M_ii, so central differences
   are stable for dt <= 2 / sqrt of it. HUGE_VAL when there is no nodal free dof; NAN when a
   nodal mass is not diagonal (consistent mass) or K is absent (finite-strain bodies). */
double mo_scene_dt_bound(const mo_scene *sc)
{
  double lmax = 0;
  int any = 0, nan = 0;
  if (!sc->M || !sc->K) return NAN;
  if (sc->kpart) return sc->dt_bound;
  dt_bound_columns(sc, sc->K, sc->M, NULL, 0, &lmax, &any, &nan);
  if (nan) return NAN;
  if (!any || !(lmax > 0)) return HUGE_VAL;
  return 2 / sqrt(lmax);
}

int mo_csc_sum_parts(const mo_csc *A, const double *held, mo_csc **out, mo_ctx *ctx)
{
  int j, p, r, st, *cnt = NULL;
  long m = 0, tot = 0;
  double *mine = NULL, *all = NULL, one;
  mo_triplet T;
  memset(&T, 0, sizeof T);
  *out = NULL;
  for (j = 0; j < A->ncol; j++)
    if (!held || held[j] > 1.5) m += A->p[j + 1] - A->p[j];
  if (!(cnt = mo_malloc(ctx, (size_t)ctx->nranks * sizeof *cnt)) ||
      !(mine = mo_malloc(ctx, (3 * (size_t)m + 1) * sizeof *mine)) ||
      !(all = mo_malloc(ctx, (size_t)ctx->nranks * sizeof *all))) { st = MO_ENOMEM; goto done; }
  m = 0;
  for (j = 0; j < A->ncol; j++)
    if (!held || held[j] > 1.5)
      for (p = A->p[j]; p < A->p[j + 1]; p++, m += 3) mine[m] = j, mine[m + 1] = A->i[p], mine[m + 2] = A->x[p];
  /* every rank's count, then every rank's entries */
  for (r = 0; r < ctx->nranks; r++) cnt[r] = 1;
  one = (double)m;
  if ((st = mo_par_gatherv(&one, cnt, all, ctx))) goto done;
  for (r = 0; r < ctx->nranks; r++) tot += (long)all[r];
  if (tot > 0x7fffffffL) {
    st = mo_error(ctx, MO_ELIMIT, "a matrix summed over the ranks: %ld values", tot);
    goto done;
  }
  for (r = 0; r < ctx->nranks; r++) cnt[r] = (int)all[r];
  mo_free(all);
  if (!(all = mo_malloc(ctx, ((size_t)tot + 1) * sizeof *all))) { st = MO_ENOMEM; goto done; }
  if ((st = mo_par_gatherv(mine, cnt, all, ctx))) goto done;
  mo_free(mine);
  mine = NULL;
  if ((st = mo_triplet_init(&T, A->nrow, A->ncol, (size_t)tot / 3 + 1, ctx))) goto done;
  for (m = 0; m < tot; m += 3)
    if ((st = mo_triplet_add(&T, (int)all[m + 1], (int)all[m], all[m + 2], ctx))) goto done;
  st = mo_triplet_to_csc(&T, A->symmetric, out, ctx);
done:
  mo_triplet_release(&T);
  mo_free(cnt);
  mo_free(mine);
  mo_free(all);
  return st;
}

/* (T103a) over the ranks, K and M in parts (sc->kpart), (T202): a column that one rank's elements
   alone reach is whole on that rank; the columns of several ranks (the interfaces of the
   element blocks) are summed from every rank's entries, then the largest ratio over the ranks:
   the bound one process gives. */
static int dt_bound_parts(mo_scene *sc, mo_ctx *ctx)
{
  const mo_csc *K = sc->K, *M = sc->M;
  int n = sc->nfe_dof, j, st, any = 0, nan = 0;
  double *held = NULL, v[3], lmax = 0;
  mo_csc *Ks = NULL, *Ms = NULL;
  sc->dt_bound = NAN;
  if (!M || !K) return MO_OK;
  if (!(held = mo_calloc(ctx, (size_t)sc->ndof + 1, sizeof *held))) return MO_ENOMEM;
  for (j = 0; j < n; j++) held[j] = (K->p[j + 1] > K->p[j] || M->p[j + 1] > M->p[j]) && sc->free_of[j] >= 0;
  if (!(st = mo_par_sum(held, n, ctx)) && !(st = mo_csc_sum_parts(K, held, &Ks, ctx)) &&
      !(st = mo_csc_sum_parts(M, held, &Ms, ctx))) {
    dt_bound_columns(sc, Ks, Ms, held, 1, &lmax, &any, &nan);
    dt_bound_columns(sc, K, M, held, 0, &lmax, &any, &nan);
    v[0] = lmax;
    v[1] = any;
    v[2] = nan;
    if (!(st = mo_par_max(v, 3, ctx)))
      sc->dt_bound = v[2] > 0 ? NAN : !(v[1] > 0) || !(v[0] > 0) ? HUGE_VAL : 2 / sqrt(v[0]);
  }
  mo_csc_free(Ks);
  mo_csc_free(Ms);
  mo_free(held);
  return st;
}

/* (T201): a part's product, then one sum over the ranks */
void mo_scene_gaxpy(const mo_scene *sc, const mo_csc *A, double alpha, const double *x, double beta, double *y)
{
  int i;
  if (!sc->kpart) {
    mo_csc_gaxpy(A, alpha, x, beta, y);
    return;
  }
  mo_csc_gaxpy(A, 1, x, 0, sc->pwork);
  /* an MPI failure aborts the job (MPI's default handler): nothing to return here */
  mo_par_sum(sc->pwork, A->nrow, sc->pctx);
  if (beta == 0)
    for (i = 0; i < A->nrow; i++) y[i] = alpha * sc->pwork[i];
  else
    for (i = 0; i < A->nrow; i++) y[i] = beta * y[i] + alpha * sc->pwork[i];
}

int mo_scene_body_index(const mo_scene *sc, const char *name)
{
  int b;
  for (b = 0; b < sc->nbody; b++)
    if (!strcmp(sc->body[b].name, name)) return b;
  return -1;
}

void mo_scene_free(mo_scene *sc)
{
  int i;
  if (!sc) return;
  for (i = 0; i < sc->nbody; i++) {
    mo_body *B = &sc->body[i];
    if (B->type && B->type->release) B->type->release(B);
    mo_mesh_free(B->mesh); /* a body whose reading failed before its type was set */
    mo_free(B->vert);
    mo_free(B->name);
    mo_free(B->mat);
    if (!i || sc->body[i - 1].group != B->group) mo_free(B->group); /* one string per group */
  }
  mo_free(sc->rigid);
  mo_free(sc->rigid_md);
  mo_free(sc->asm_elems);
  mo_free(sc->asm_seconds);
  mo_free(sc->asm_entries);
  mo_free(sc->body);
  for (i = 0; i < sc->npresc; i++) mo_expr_free(sc->presc[i].disp);
  mo_free(sc->presc);
  for (i = 0; i < sc->nload; i++) {
    mo_free(sc->load[i].dof);
    mo_free(sc->load[i].val);
    mo_expr_free(sc->load[i].amp);
  }
  mo_free(sc->load);
  for (i = 0; i < sc->nprobe; i++) {
    mo_free(sc->probe[i].name);
    mo_free(sc->probe[i].node);
  }
  mo_free(sc->probe);
  for (i = 0; i < sc->out.nextent; i++) {
    mo_free(sc->out.extent[i].name);
    mo_free(sc->out.extent[i].node);
  }
  mo_free(sc->out.extent);
  if (sc->full_of != sc->free_of) mo_free(sc->full_of);
  mo_free(sc->free_of);
  mo_csc_free(sc->K);
  mo_csc_free(sc->M);
  mo_free(sc->pwork);
  mo_free(sc->u0);
  mo_free(sc->v0);
  mo_free(sc->title);
  mo_free(sc->case_file);
  mo_free(sc);
}

/* Compile member `name` of g (a number or an expression) with the given variables. */
int mo_scene_compile(const mo_case *cs, const config_setting_t *g, const char *name, int i,
                          const char *const *vars, int nvar, mo_expr **e, mo_ctx *ctx)
{
  char buf[64], where[700], loc[600], path[512];
  const config_setting_t *s = mo_cfg_member(g, name);
  const char *src = mo_cfg_expr_at(g, name, i, buf, sizeof buf);
  *e = NULL;
  if (!src) return MO_OK;
  mo_case_where(cs, s, loc, sizeof loc);
  mo_case_path(s, path, sizeof path);
  if (snprintf(where, sizeof where, "%s: key '%s'", loc, path) >= (int)sizeof where)
    where[sizeof where - 1] = '\0';
  return mo_expr_compile(src, vars, nvar, where, e, ctx);
}

/* --- meshes ---------------------------------------------------------------------------------- */

int mo_scene_need(const mo_case *cs, const config_setting_t *g, const char *key, const char *why,
                mo_ctx *ctx)
{
  if (mo_cfg_member(g, key)) return MO_OK;
  return mo_case_error(cs, g, ctx, "%s needs '%s'", why, key);
}

int mo_scene_need_len(const mo_case *cs, const config_setting_t *g, const char *key, int n,
                    const char *why, mo_ctx *ctx)
{
  int st = mo_scene_need(cs, g, key, why, ctx);
  if (st) return st;
  if (mo_cfg_count(g, key) != n)
    return mo_case_error(cs, mo_cfg_member(g, key), ctx, "%s needs %d values here, not %d", why,
                         n, mo_cfg_count(g, key));
  return MO_OK;
}

/* Re-locate the last error at setting s (for errors raised by lower layers). */
int mo_scene_relocate(const mo_case *cs, const config_setting_t *s, mo_ctx *ctx)
{
  char msg[MO_ERRMSG_MAX];
  int code = ctx->status;
  if (code == MO_OK || code == MO_ENOMEM) return code;
  snprintf(msg, sizeof msg, "%s", ctx->errmsg);
  mo_ctx_clear_error(ctx);
  mo_case_error(cs, s, ctx, "%s", msg);
  ctx->status = code;
  return code;
}


int mo_scene_add_presc(mo_scene *sc, int dof, mo_presc_kind kind, double vel, mo_expr *disp,
                     int *owner, mo_ctx *ctx)
{
  mo_presc *p;
  if (owner[dof] >= 0) {
    /* a dof held twice the same way is harmless; two different motions are a conflict */
    mo_presc *q = &sc->presc[owner[dof]];
    if (kind == MO_PRESC_FIX && q->kind == MO_PRESC_FIX) return 1;
    return -1;
  }
  p = mo_realloc(ctx, sc->presc, (size_t)(sc->npresc + 1) * sizeof *p);
  if (!p) return MO_ENOMEM;
  sc->presc = p;
  p = &sc->presc[sc->npresc];
  memset(p, 0, sizeof *p);
  p->dof = dof;
  p->kind = kind;
  p->vel = vel;
  p->disp = disp;
  owner[dof] = sc->npresc++;
  return 0;
}

static int load_push(mo_scene *sc, mo_load *L, mo_ctx *ctx)
{
  if (sc->nload == sc->loadcap) {
    int cap = sc->loadcap ? 2 * sc->loadcap : 8;
    mo_load *p = mo_realloc(ctx, sc->load, (size_t)cap * sizeof *p);
    if (!p) return MO_ENOMEM;
    sc->load = p;
    sc->loadcap = cap;
  }
  sc->load[sc->nload++] = *L;
  return MO_OK;
}

int mo_scene_add_load_sparse(mo_scene *sc, int n, const int *dof, const double *val, mo_expr *amp, mo_ctx *ctx)
{
  mo_load *L = sc->nload ? &sc->load[sc->nload - 1] : NULL, N;
  if (!amp && L && !L->amp) {
    /* constant loads join the last constant pattern: one pattern for the body forces of a pack
       of 10^5 grains, not one each */
    if (L->n + n > L->cap) {
      int cap = 2 * (L->n + n);
      int *d = mo_realloc(ctx, L->dof, (size_t)cap * sizeof *d);
      double *v;
      if (!d) return MO_ENOMEM;
      L->dof = d;
      if (!(v = mo_realloc(ctx, L->val, (size_t)cap * sizeof *v))) return MO_ENOMEM;
      L->val = v;
      L->cap = cap;
    }
    memcpy(L->dof + L->n, dof, (size_t)n * sizeof *dof);
    memcpy(L->val + L->n, val, (size_t)n * sizeof *val);
    L->n += n;
    return MO_OK;
  }
  memset(&N, 0, sizeof N);
  N.dof = mo_malloc(ctx, (size_t)(n ? n : 1) * sizeof *N.dof);
  N.val = mo_malloc(ctx, (size_t)(n ? n : 1) * sizeof *N.val);
  if (!N.dof || !N.val) {
    mo_free(N.dof);
    mo_free(N.val);
    mo_expr_free(amp);
    return MO_ENOMEM;
  }
  if (n) {
    memcpy(N.dof, dof, (size_t)n * sizeof *dof);
    memcpy(N.val, val, (size_t)n * sizeof *val);
  }
  N.n = N.cap = n;
  N.amp = amp;
  if (load_push(sc, &N, ctx)) {
    mo_free(N.dof);
    mo_free(N.val);
    mo_expr_free(amp);
    return MO_ENOMEM;
  }
  return MO_OK;
}

/* Compress a dense load vector into a sparse pattern. */
int mo_scene_add_load(mo_scene *sc, const double *f, mo_expr *amp, mo_ctx *ctx)
{
  mo_load L;
  int i, n = 0;
  memset(&L, 0, sizeof L);
  for (i = 0; i < sc->ndof; i++) n += f[i] != 0;
  L.dof = mo_malloc(ctx, (size_t)(n ? n : 1) * sizeof(int));
  L.val = mo_malloc(ctx, (size_t)(n ? n : 1) * sizeof(double));
  if (!L.dof || !L.val) {
    mo_free(L.dof);
    mo_free(L.val);
    mo_expr_free(amp);
    return MO_ENOMEM;
  }
  for (i = 0; i < sc->ndof; i++)
    if (f[i] != 0) {
      L.dof[L.n] = i;
      L.val[L.n++] = f[i];
    }
  L.amp = amp;
  L.cap = L.n;
  if (load_push(sc, &L, ctx)) {
    mo_free(L.dof);
    mo_free(L.val);
    mo_expr_free(amp);
    return MO_ENOMEM;
  }
  return MO_OK;
}

/* --- assembly -------------------------------------------------------------------------------- */

/* Over MPI ranks (doc/parallel.md §3): the deformable bodies' elements, numbered body after
   body, in contiguous blocks of nelem / nranks (the first ranks one more); rank r computes the
   matrices of [*lo, *hi). */
static void element_block(const mo_scene *sc, const mo_ctx *ctx, long *lo, long *hi)
{
  long n = 0, q, m;
  int b;
  for (b = 0; b < sc->nbody; b++)
    if (sc->body[b].kind == MO_BODY_DEFORMABLE) n += sc->body[b].mesh->nelem;
  q = n / ctx->nranks;
  m = n % ctx->nranks;
  *lo = ctx->rank * q + (ctx->rank < m ? ctx->rank : m);
  *hi = *lo + q + (ctx->rank < m);
}

/* The ranks' sums of K and M (each holds the pattern of every element and the values of its
   own), the zeros of that pattern dropped: the matrices one process assembles, to rounding (the
   sums are taken in another order). */
static int assemble_reduce(mo_scene *sc, mo_ctx *ctx)
{
  int st;
  if ((st = mo_par_sum(sc->K->x, mo_csc_nnz(sc->K), ctx))) return st;
  if (sc->M && (st = mo_par_sum(sc->M->x, mo_csc_nnz(sc->M), ctx))) return st;
  mo_csc_drop_zeros(sc->K);
  if (sc->M) mo_csc_drop_zeros(sc->M);
  return MO_OK;
}

/* Every rank's count of elements and seconds in the element loop (one gather; one process: its
   own). */
static int assemble_counts(mo_scene *sc, long mine, double secs, mo_ctx *ctx)
{
  int st, r, *two;
  double me[3], *all;
  size_t n = (size_t)ctx->nranks;
  me[0] = (double)mine;
  me[1] = secs;
  me[2] = (double)(sc->K ? mo_csc_nnz(sc->K) : 0) + (double)(sc->M ? mo_csc_nnz(sc->M) : 0);
  if (!(sc->asm_elems = mo_calloc(ctx, n, sizeof *sc->asm_elems)) ||
      !(sc->asm_seconds = mo_calloc(ctx, n, sizeof *sc->asm_seconds)) ||
      !(sc->asm_entries = mo_calloc(ctx, n, sizeof *sc->asm_entries)))
    return MO_ENOMEM;
  if (!(two = mo_malloc(ctx, n * sizeof *two))) return MO_ENOMEM;
  if (!(all = mo_malloc(ctx, 3 * n * sizeof *all))) {
    mo_free(two);
    return MO_ENOMEM;
  }
  for (r = 0; r < ctx->nranks; r++) two[r] = 3;
  st = mo_par_gatherv(me, two, all, ctx);
  for (r = 0; !st && r < ctx->nranks; r++) {
    sc->asm_elems[r] = all[3 * r];
    sc->asm_seconds[r] = all[3 * r + 1];
    sc->asm_entries[r] = all[3 * r + 2];
  }
  mo_free(two);
  mo_free(all);
  return st;
}

static int assemble(mo_scene *sc, int with_mass, mo_ctx *ctx)
{
  mo_triplet TK, TM;
  int b, e, a, c, st = MO_OK, D = sc->dim, fe = 0;
  /* over MPI ranks each computes its block of elements (element_block) */
  int split = ctx->nranks > 1 && mo_parallel_started(ctx);
  long g = 0, lo = 0, hi = 0, mine = 0;
  size_t hint = 0;
  double t0 = mo_clock(), t1;
  if (split) element_block(sc, ctx, &lo, &hi);
  /* (T200): a linear scene keeps each rank's part (its elements' entries only): no rank holds K or M
     whole, and every product with them is summed over the ranks (mo_scene_gaxpy). Finite-strain
     bodies' tangents (tangent.c) still take K and M whole: their scenes take the sums. */
  for (b = 0; b < sc->nbody; b++)
    if (sc->body[b].kind == MO_BODY_DEFORMABLE) {
      int nd = sc->body[b].mesh->nen * D;
      hint += (size_t)sc->body[b].mesh->nelem * (size_t)nd * (size_t)nd;
      fe = 1;
    }
  /* a scene of rigid bodies has no element: nothing to keep in parts, and K and M in parts would
     make every product and energy with them a pass over the dofs of empty parts on every rank */
  sc->kpart = split && !sc->nonlinear && fe;
  if (sc->kpart) hint = hint / (size_t)ctx->nranks + 1;
  memset(&TM, 0, sizeof TM);
  if ((st = mo_triplet_init(&TK, sc->ndof, sc->ndof, hint, ctx))) return st;
  if (with_mass && (st = mo_triplet_init(&TM, sc->ndof, sc->ndof, hint, ctx))) {
    mo_triplet_release(&TK);
    return st;
  }
  for (b = 0; b < sc->nbody && !st; b++) {
    mo_body *B = &sc->body[b];
    mo_mesh *m = B->mesh;
    int dofs[MO_ND_MAX], nd;
    double Ke[MO_ND_MAX * MO_ND_MAX], Me[MO_ND_MAX * MO_ND_MAX];
    if (B->kind != MO_BODY_DEFORMABLE) continue;
    nd = m->nen * D;
    B->mass = 0;
    for (e = 0; e < m->nelem && !st; e++) {
      if (!(e & 0xffff) && MO_INTERRUPTED(ctx)) {
        st = mo_error(ctx, MO_EINTERRUPT, "interrupted while assembling body '%s' (element %d of %d)", B->name, e,
                      m->nelem);
        break;
      }
      for (a = 0; a < m->nen; a++)
        for (c = 0; c < D; c++) dofs[a * D + c] = B->dof0 + m->conn[e * m->nen + a] * D + c;
      /* finite-strain bodies have no constant stiffness: their forces and tangents are
         computed by the stepper at every Newton iterate (doc/theory.md §11) */
      if (sc->kpart) {
        /* this rank's elements only */
        int own = g >= lo && g < hi;
        g++;
        mine += own;
        if (own && (st = mo_elem_stiffness(m, e, B->mat, Ke, ctx))) break;
        if (own && (st = mo_triplet_add_block(&TK, dofs, nd, dofs, nd, Ke, ctx))) break;
        if (with_mass && own && (st = mo_elem_mass(m, e, B->mat, B->lumped, Me, ctx))) break;
        if (with_mass && own && (st = mo_triplet_add_block(&TM, dofs, nd, dofs, nd, Me, ctx))) break;
      } else if (split) {
        /* another rank's element: its pattern only, its values come with the sums */
        int own = g >= lo && g < hi;
        g++;
        mine += own;
        if (!B->nl && own && (st = mo_elem_stiffness(m, e, B->mat, Ke, ctx))) break;
        if (!B->nl && (st = mo_triplet_add_pattern(&TK, dofs, nd, dofs, nd, own ? Ke : NULL, ctx))) break;
        if (with_mass && own && (st = mo_elem_mass(m, e, B->mat, B->lumped, Me, ctx))) break;
        if (with_mass && (st = mo_triplet_add_pattern(&TM, dofs, nd, dofs, nd, own ? Me : NULL, ctx))) break;
      } else {
        g++;
        if (!B->nl) {
          if ((st = mo_elem_stiffness(m, e, B->mat, Ke, ctx))) break;
          if ((st = mo_triplet_add_block(&TK, dofs, nd, dofs, nd, Ke, ctx))) break;
        }
        if (with_mass) {
          if ((st = mo_elem_mass(m, e, B->mat, B->lumped, Me, ctx))) break;
          if ((st = mo_triplet_add_block(&TM, dofs, nd, dofs, nd, Me, ctx))) break;
        }
      }
      B->mass += B->mat->rho * mo_elem_measure(m, e, B->mat);
    }
    sc->mass_total += B->mass;
  }
  if (!st) st = mo_triplet_to_csc(&TK, 1, &sc->K, ctx);
  if (!st && with_mass) st = mo_triplet_to_csc(&TM, 1, &sc->M, ctx);
  mo_triplet_release(&TK);
  mo_triplet_release(&TM);
  /* every rank reaches the sums: a failure above is the same on every rank (the same case), but
     a rank that failed alone (memory) must not leave the others waiting in them */
  if (!split) mine = g;
  t1 = mo_clock() - t0;
  if (split && !(st = mo_par_agree(st, ctx))) {
    if (!sc->kpart) st = assemble_reduce(sc, ctx);
    else if (!(sc->pwork = mo_calloc(ctx, (size_t)sc->ndof + 1, sizeof *sc->pwork))) st = MO_ENOMEM;
    else {
      sc->pctx = ctx;
      st = dt_bound_parts(sc, ctx);
    }
  }
  if (!st) st = assemble_counts(sc, mine, t1, ctx);
  mo_phase_add(ctx, MO_PH_ASSEMBLY, t0);
  return st;
}

/* --- settings -------------------------------------------------------------------------------- */

static int build_time(mo_scene *sc, const mo_case *cs, mo_ctx *ctx)
{
  const config_setting_t *tg = config_lookup(&cs->cfg, "time");
  const char *scheme = mo_cfg_string(tg, "scheme", "theta");
  mo_time_settings *T = &sc->time;
  const config_setting_t *s;
  double wh;
  int stab;
  T->scheme = !strcmp(scheme, "newmark") ? MO_SCHEME_NEWMARK
              : !strcmp(scheme, "quasistatic") ? MO_SCHEME_QUASISTATIC : MO_SCHEME_THETA;
  T->explicit_cd = !strcmp(scheme, "explicit");
  T->theta = mo_cfg_float(tg, "theta", 0.5);
  T->theta_f = mo_cfg_float(tg, "theta_f", T->theta);
  if (T->explicit_cd) {
    /* central differences = the theta-scheme at theta = 1, theta_f = 0 (T100) */
    if (mo_cfg_member(tg, "theta") || mo_cfg_member(tg, "theta_f"))
      mo_note_skip(ctx, "time.theta = %g, time.theta_f = %g of the case: scheme 'explicit' is central differences, "
                   "theta = 1, theta_f = 0", T->theta, T->theta_f);
    T->theta = 1;
    T->theta_f = 0;
  } else if (T->scheme == MO_SCHEME_THETA &&
             (stab = mo_theta_stability(T->theta, T->theta_f, &wh)) != MO_STAB_UNCONDITIONAL) {
    /* below 1/2 the theta-method is only conditionally stable, or not at all (T101) */
    if (stab == MO_STAB_UNSTABLE)
      mo_log(ctx, 1, "%s: warning: theta = %g, theta_f = %g: theta + theta_f < 1, the theta-scheme is unstable at "
             "every time step (every mode grows, doc/theory.md (T101))\n", cs->file, T->theta, T->theta_f);
    else
      mo_log(ctx, 1, "%s: warning: theta = %g, theta_f = %g: the theta-scheme is only conditionally stable, "
             "h omega_max <= %.4g (doc/theory.md (T101))\n", cs->file, T->theta, T->theta_f, wh);
  }
  T->beta = mo_cfg_float(tg, "beta", 0.25);
  T->gamma = mo_cfg_float(tg, "gamma", 0.5);
  T->newton_tol = mo_cfg_float(mo_cfg_member(tg, "newton"), "tol", 1e-8);
  T->newton_max = mo_cfg_int(mo_cfg_member(tg, "newton"), "max_iter", 25);
  T->max_cuts = mo_cfg_int(tg, "max_cuts", 0);
  /* keys that the chosen scheme ignores are almost always a mistake */
  if (T->scheme != MO_SCHEME_THETA && ((s = mo_cfg_member(tg, "theta")) || (s = mo_cfg_member(tg, "theta_f"))))
    return mo_case_error(cs, s, ctx, "is not used by scheme '%s' (only by 'theta')", scheme);
  if (T->scheme != MO_SCHEME_NEWMARK && ((s = mo_cfg_member(tg, "beta")) || (s = mo_cfg_member(tg, "gamma"))))
    return mo_case_error(cs, s, ctx, "is not used by scheme '%s' (only by 'newmark')", scheme);
  if (T->scheme == MO_SCHEME_NEWMARK && T->beta < 0.25 * (0.5 + T->gamma) * (0.5 + T->gamma) * 0.999999 &&
      (s = mo_cfg_member(tg, "beta")))
    mo_log(ctx, 1, "%s: warning: Newmark beta = %g < (gamma + 1/2)^2 / 4 = %g: only conditionally stable\n",
           cs->file, T->beta, 0.25 * (0.5 + T->gamma) * (0.5 + T->gamma));
  if (T->scheme == MO_SCHEME_QUASISTATIC) {
    T->steps = mo_cfg_int(tg, "steps", 1);
    T->end = mo_cfg_float(tg, "end", 1);
    if (mo_cfg_member(tg, "dt"))
      T->steps = (long)ceil(T->end / mo_cfg_float(tg, "dt", 1) - 1e-9);
    T->dt = T->end / (double)T->steps;
    return MO_OK;
  }
  if (!mo_cfg_member(tg, "dt"))
    return mo_case_error(cs, tg, ctx, "a dynamic scheme needs the time step 'dt'");
  T->dt = mo_cfg_float(tg, "dt", 0);
  if (mo_cfg_member(tg, "end") && mo_cfg_member(tg, "steps"))
    return mo_case_error(cs, tg, ctx, "give 'end' or 'steps', not both");
  if (mo_cfg_member(tg, "end")) {
    double n = mo_cfg_float(tg, "end", 0) / T->dt;
    /* one step rounds the run up to dt: refused when that more than doubles it (dt = 1e300
       would run to t = 1e300 and overflow M + c K) */
    if (n < 0.5)
      return mo_case_error(cs, mo_cfg_member(tg, "dt"), ctx, "the time step %g is longer than the run (time.end = %g): "
                           "the one step would end at t = %g", T->dt, mo_cfg_float(tg, "end", 0), T->dt);
    if (n > 1e9) return mo_case_error(cs, mo_cfg_member(tg, "end"), ctx, "end / dt = %.3g steps exceed the limit of 10^9", n);
    T->steps = (long)ceil(n - 1e-9);
    if (T->steps < 1) T->steps = 1;
  } else if (mo_cfg_member(tg, "steps"))
    T->steps = mo_cfg_int(tg, "steps", 1);
  else
    return mo_case_error(cs, tg, ctx, "needs 'end' or 'steps'");
  T->end = (double)T->steps * T->dt;
  if (!isfinite(T->end) || T->end > 1e100)
    return mo_case_error(cs, mo_cfg_member(tg, "dt"), ctx, "%ld steps of %g make the run end at t = %g: check the units",
                         T->steps, T->dt, T->end);
  return MO_OK;
}

/* The deformable body an output item (extent, probe) observes: its 'body', or the first
   deformable body; `what` is the error for a body of another kind. */
static int observed_body(const mo_scene *sc, const mo_case *cs, const config_setting_t *g,
                         const char *what, int *out, mo_ctx *ctx)
{
  const char *bname = mo_cfg_string(g, "body", NULL);
  int b;
  if (bname) {
    b = mo_scene_body_index(sc, bname);
    if (b < 0) return mo_case_error(cs, mo_cfg_member(g, "body"), ctx, "no body named '%s'", bname);
  } else
    for (b = 0; b < sc->nbody && sc->body[b].kind != MO_BODY_DEFORMABLE; b++) {}
  if (b >= sc->nbody || sc->body[b].kind != MO_BODY_DEFORMABLE) return mo_case_error(cs, g, ctx, "%s", what);
  *out = b;
  return MO_OK;
}

/* output.extents: node sets whose bounding box in the current configuration the summary
   reports (e.g. the length and footprint of a Taylor bar). */
static int build_extents(mo_scene *sc, const mo_case *cs, const config_setting_t *el, mo_ctx *ctx)
{
  int i, k, st, n = el ? config_setting_length(el) : 0;
  if (!n) return MO_OK;
  sc->out.extent = mo_calloc(ctx, (size_t)n, sizeof *sc->out.extent);
  if (!sc->out.extent) return MO_ENOMEM;
  for (i = 0; i < n; i++) {
    const config_setting_t *g = config_setting_get_elem(el, (unsigned)i);
    mo_extent *X = &sc->out.extent[sc->out.nextent];
    const char *set = mo_cfg_string(g, "set", "all");
    int b = 0;
    X->name = mo_strdup(ctx, mo_cfg_string(g, "name", "extent"));
    if (!X->name) return MO_ENOMEM;
    sc->out.nextent++;
    for (k = 0; k < i; k++)
      if (!strcmp(sc->out.extent[k].name, X->name))
        return mo_case_error(cs, mo_cfg_member(g, "name"), ctx, "extent name '%s' is used twice", X->name);
    if (strchr(X->name, '.') || strchr(X->name, ',') || strchr(X->name, '"'))
      return mo_case_error(cs, mo_cfg_member(g, "name"), ctx, "an extent name must not contain '.', ',' or '\"'");
    if ((st = observed_body(sc, cs, g, "an extent measures a deformable body", &b, ctx))) return st;
    X->body = b;
    if (mo_mesh_nodeset_resolve(sc->body[b].mesh, set, &X->node, &X->nnode, ctx))
      return mo_scene_relocate(cs, mo_cfg_member(g, "set") ? mo_cfg_member(g, "set") : g, ctx);
    if (X->nnode == 0) return mo_case_error(cs, mo_cfg_member(g, "set"), ctx, "the set selects no node");
  }
  return MO_OK;
}

/* A PETSc name (a type or a package): letters, digits and underscores. */
static int petsc_name(const char *v)
{
  if (!*v) return 0;
  for (; *v; v++)
    if (!((*v >= 'a' && *v <= 'z') || (*v >= 'A' && *v <= 'Z') || (*v >= '0' && *v <= '9') || *v == '_')) return 0;
  return 1;
}

/* linear_solver.out_of_core and ooc_dir: MUMPS's factor on disk (doc/theory.md (T182)), with
   PETSc's direct factorization by MUMPS only. */
static int build_out_of_core(mo_linear_settings *L, const mo_case *cs, const config_setting_t *lg, mo_ctx *ctx)
{
  const config_setting_t *o = mo_cfg_member(lg, "out_of_core"), *d = mo_cfg_member(lg, "ooc_dir");
  L->out_of_core = mo_cfg_bool(lg, "out_of_core", 0);
  snprintf(L->ooc_dir, sizeof L->ooc_dir, "%s", mo_cfg_string(lg, "ooc_dir", ""));
  if (d && !L->ooc_dir[0]) return mo_case_error(cs, d, ctx, "is empty (a folder, or leave the key out: TMPDIR)");
  if (d && !L->out_of_core) return mo_case_error(cs, d, ctx, "is used with linear_solver.out_of_core = true only");
  if (L->out_of_core && (!L->petsc || strcmp(L->ksp, "preonly") || strcmp(L->package, "mumps") ||
                         (strcmp(L->pc, "cholesky") && strcmp(L->pc, "lu"))))
    return mo_case_error(cs, o, ctx, "needs MUMPS's factorization: linear_solver.type = \"petsc\" with ksp \"preonly\", "
                         "pc \"cholesky\" or \"lu\" and package \"mumps\"");
  return MO_OK;
}

/* linear_solver: CHOLMOD, or PETSc over the MPI ranks; under mpirun with more than one rank the
   default is PETSc (a CHOLMOD factorization on every rank would repeat the same work). */
static int build_linear(mo_scene *sc, const mo_case *cs, mo_ctx *ctx)
{
  const config_setting_t *lg = config_lookup(&cs->cfg, "linear_solver"), *t = mo_cfg_member(lg, "type");
  mo_linear_settings *L = &sc->lin;
  static const char *const names[] = {"ksp", "pc", "package"};
  char *dest[3];
  size_t k;
  int st;
  L->petsc = t ? !strcmp(mo_cfg_string(lg, "type", "cholmod"), "petsc") : ctx->nranks > 1;
  dest[0] = L->ksp;
  dest[1] = L->pc;
  dest[2] = L->package;
  for (k = 0; k < 3; k++) {
    const config_setting_t *m = mo_cfg_member(lg, names[k]);
    const char *v = mo_cfg_string(lg, names[k], k == 0 ? "preonly" : k == 1 ? "cholesky" : "mumps");
    if (m && !petsc_name(v))
      return mo_case_error(cs, m, ctx, "'%s' is not a PETSc name (letters, digits and '_')", v);
    if (m && !L->petsc)
      return mo_case_error(cs, m, ctx, "is used by linear_solver.type = \"petsc\" only");
    snprintf(dest[k], 32, "%s", v);
  }
  L->rtol = mo_cfg_float(lg, "rtol", 1e-10);
  snprintf(L->options, sizeof L->options, "%s", mo_cfg_string(lg, "options", ""));
  if ((st = build_out_of_core(L, cs, lg, ctx))) return st;
  if (L->petsc && !mo_parallel_available())
    return mo_case_error(cs, t ? t : lg, ctx, "asks for PETSc, and this build of moreau has none: configure it "
                         "--with-petsc (Debian: apt-get install petsc-dev openmpi-bin)");
  if (ctx->nranks > 1 && !L->petsc)
    mo_note_skip(ctx, "distributed linear algebra (linear_solver.type = \"cholmod\" under %d ranks: every rank "
                 "factors What alone)", ctx->nranks);
  return MO_OK;
}

static int build_output(mo_scene *sc, const mo_case *cs, mo_ctx *ctx)
{
  const config_setting_t *og = config_lookup(&cs->cfg, "output"), *pl, *vg;
  int i, k, st;
  sc->out.every = mo_cfg_int(og, "every", 1);
  sc->out.precision = mo_cfg_int(og, "precision", 10);
  sc->out.energy = mo_cfg_bool(og, "energy", 1);
  vg = mo_cfg_member(og, "vtk");
  if (vg) {
    int nf = mo_cfg_count(vg, "fields");
    sc->out.vtk = 1;
    sc->out.vtk_every = mo_cfg_int(vg, "every", 10);
    sc->out.vtk_fields = nf ? 0 : 0x3f;
    {
      const char *c = mo_cfg_string(vg, "contacts", "all");
      sc->out.vtk_contacts = !strcmp(c, "none") ? MO_VTK_CONTACTS_NONE
                             : !strcmp(c, "closed") ? MO_VTK_CONTACTS_CLOSED : MO_VTK_CONTACTS_ALL;
    }
    for (k = 0; k < nf; k++) {
      const char *f = mo_cfg_string_at(vg, "fields", k);
      sc->out.vtk_fields |= !strcmp(f, "displacement") ? MO_VTK_DISPLACEMENT
                            : !strcmp(f, "velocity") ? MO_VTK_VELOCITY
                            : !strcmp(f, "stress") ? MO_VTK_STRESS
                            : !strcmp(f, "strain") ? MO_VTK_STRAIN
                            : !strcmp(f, "eps_p") ? MO_VTK_EPS_P : MO_VTK_VON_MISES;
    }
  }
  if ((vg = mo_cfg_member(og, "contact_history"))) {
    sc->out.contact_history = 1;
    sc->out.contact_history_every = mo_cfg_int(vg, "every", sc->out.every);
    sc->out.contact_history_closed = !strcmp(mo_cfg_string(vg, "candidates", "all"), "closed");
  }
  if ((st = build_extents(sc, cs, mo_cfg_member(og, "extents"), ctx))) return st;
  pl = mo_cfg_member(og, "probes");
  if (!pl) return MO_OK;
  sc->probe = mo_calloc(ctx, (size_t)config_setting_length(pl) + 1, sizeof *sc->probe);
  if (!sc->probe) return MO_ENOMEM;
  for (i = 0; i < config_setting_length(pl); i++) {
    const config_setting_t *pg = config_setting_get_elem(pl, (unsigned)i);
    mo_probe *P = &sc->probe[sc->nprobe];
    int b = 0, nsel = (mo_cfg_member(pg, "set") != NULL) + (mo_cfg_member(pg, "point") != NULL) +
                      (mo_cfg_member(pg, "node") != NULL);
    mo_mesh *m;
    P->name = mo_strdup(ctx, mo_cfg_string(pg, "name", "probe"));
    if (!P->name) return MO_ENOMEM;
    sc->nprobe++;
    for (k = 0; k < i; k++)
      if (!strcmp(sc->probe[k].name, P->name))
        return mo_case_error(cs, mo_cfg_member(pg, "name"), ctx, "probe name '%s' is used twice", P->name);
    if (strchr(P->name, '.') || strchr(P->name, ',') || strchr(P->name, '"'))
      return mo_case_error(cs, mo_cfg_member(pg, "name"), ctx, "a probe name must not contain '.', ',' or '\"'");
    if ((st = observed_body(sc, cs, pg, "a probe observes a deformable body", &b, ctx))) return st;
    P->body = b;
    m = sc->body[b].mesh;
    if (nsel != 1) return mo_case_error(cs, pg, ctx, "give exactly one of 'set', 'point' or 'node'");
    if (mo_cfg_member(pg, "set")) {
      if (mo_mesh_nodeset_resolve(m, mo_cfg_string(pg, "set", ""), &P->node, &P->nnode, ctx))
        return mo_scene_relocate(cs, mo_cfg_member(pg, "set"), ctx);
      if (P->nnode == 0) return mo_case_error(cs, mo_cfg_member(pg, "set"), ctx, "the set selects no node");
    } else {
      int id;
      if (mo_cfg_member(pg, "point")) {
        double p[3];
        if (mo_cfg_count(pg, "point") != sc->dim)
          return mo_case_error(cs, mo_cfg_member(pg, "point"), ctx, "needs %d coordinates", sc->dim);
        for (k = 0; k < sc->dim; k++) p[k] = mo_cfg_num_at(pg, "point", k);
        id = mo_mesh_nearest_node(m, p, NULL);
      } else {
        id = mo_cfg_int(pg, "node", 0);
        if (id >= m->nnode)
          return mo_case_error(cs, mo_cfg_member(pg, "node"), ctx, "body '%s' has nodes 0..%d", sc->body[b].name, m->nnode - 1);
      }
      P->node = mo_malloc(ctx, sizeof(int));
      if (!P->node) return MO_ENOMEM;
      P->node[0] = id;
      P->nnode = 1;
    }
    for (k = 0; k < mo_cfg_count(pg, "quantities"); k++) {
      const char *q = mo_cfg_string_at(pg, "quantities", k);
      int qi;
      for (qi = 0; qi < MO_Q_N && strcmp(q, mo_quantity_name((mo_quantity)qi)); qi++) {}
      if (qi < MO_Q_PN && (qi % 3) >= sc->dim)
        return mo_case_error(cs, mo_cfg_member(pg, "quantities"), ctx, "'%s' does not exist in %dD", q, sc->dim);
      P->q[P->nq++] = (mo_quantity)qi;
    }
  }
  (void)st;
  return MO_OK;
}

/* --- driver ---------------------------------------------------------------------------------- */

/* The kind of each entry and the number of bodies the entries make. */
static int count_bodies(const config_setting_t *bl, int *total)
{
  int e, n = bl ? config_setting_length(bl) : 0;
  *total = 0;
  for (e = 0; e < n; e++) {
    const config_setting_t *bg = config_setting_get_elem(bl, (unsigned)e);
    const mo_body_type *T = mo_body_type_find(mo_cfg_string(bg, "type", "deformable"));
    int c = T && T->count ? T->count(bg) : 1;
    *total += c > 0 ? c : 1;
  }
  return n;
}

/* The space dimension a body fixes (0: an obstacle, which takes the scene's). */
static int body_dim(const mo_body *B)
{
  if (B->mesh) return B->mesh->dim;
  return B->kind == MO_BODY_SPHERE ? 3 : B->kind == MO_BODY_DISK || B->kind == MO_BODY_POLYGON ? 2 : 0;
}

/* 1 when name is "group.k" with 0 <= k < count. */
static int generated_name(const char *name, const char *group, int count)
{
  size_t n = strlen(group);
  char *end;
  long k;
  if (strncmp(name, group, n) || name[n] != '.' || !name[n + 1]) return 0;
  k = strtol(name + n + 1, &end, 10);
  return !*end && k >= 0 && k < count && (name[n + 1] != '0' || !name[n + 2]);
}

/* Body names are unique: the entries' names against each other and against the names the
   groups generate (NAME.k), in O(entries^2) rather than O(bodies^2). */
static int check_names(const mo_case *cs, const config_setting_t *bl, int nentry, mo_ctx *ctx)
{
  int e, f;
  for (e = 0; e < nentry; e++) {
    const config_setting_t *ge = config_setting_get_elem(bl, (unsigned)e);
    const mo_body_type *Te = mo_body_type_find(mo_cfg_string(ge, "type", "deformable"));
    const char *ne = mo_cfg_string(ge, "name", "");
    int ce = Te->count ? Te->count(ge) : 1;
    for (f = 0; f < e; f++) {
      const config_setting_t *gf = config_setting_get_elem(bl, (unsigned)f);
      const mo_body_type *Tf = mo_body_type_find(mo_cfg_string(gf, "type", "deformable"));
      const char *nf = mo_cfg_string(gf, "name", "");
      int cf = Tf->count ? Tf->count(gf) : 1;
      if (ce > 1 ? !strcmp(ne, nf) || (cf <= 1 && generated_name(nf, ne, ce))
                 : cf > 1 ? generated_name(ne, nf, cf) : !strcmp(ne, nf))
        return mo_case_error(cs, mo_cfg_member(ge, "name"), ctx, "body name '%s' is used twice%s", ne,
                             ce > 1 || cf > 1 ? " (a group of N bodies names them NAME.0 .. NAME.N-1)" : "");
    }
  }
  return MO_OK;
}

/* Pass 1: every body's own keys; the dimension from the first body that fixes it; obstacles
   (planes) once it is known. Generated bodies are named NAME.k, their group NAME. */
static int read_bodies(mo_scene *sc, const config_setting_t *bl, int nentry, mo_ctx *ctx)
{
  const mo_case *cs = sc->cs;
  int e, b, st, dim = 0, pass;
  if ((st = check_names(cs, bl, nentry, ctx))) return st;
  for (pass = 0; pass < 2; pass++)
    for (e = 0, b = 0; e < nentry; e++) {
      const config_setting_t *bg = config_setting_get_elem(bl, (unsigned)e);
      const mo_body_type *T = mo_body_type_find(mo_cfg_string(bg, "type", "deformable"));
      int c = T->count ? T->count(bg) : 1, m;
      if (c < 1) c = 1;
      for (m = 0; m < c; m++, b++) {
        mo_body *B = &sc->body[b];
        const char *name = mo_cfg_string(bg, "name", "");
        if ((T->flags & MO_BODY_F_OBSTACLE) != (pass ? MO_BODY_F_OBSTACLE : 0u)) continue;
        B->type = T;
        B->kind = T->kind;
        B->orient = -1;
        B->entry = e;
        if (c == 1) B->name = mo_strdup(ctx, name);
        else {
          char buf[300];
          snprintf(buf, sizeof buf, "%s.%d", name, m);
          B->name = mo_strdup(ctx, buf);
          /* the group's name, shared by its bodies */
          B->group = m ? sc->body[b - 1].group : mo_strdup(ctx, name);
          if (!B->group) return MO_ENOMEM;
        }
        if (!B->name) return MO_ENOMEM;
        if ((st = T->read(B, m, dim, cs, bg, ctx))) return st;
        if (!dim) dim = body_dim(B);
      }
    }
  if (!dim)
    return mo_case_error(cs, bl, ctx, "the scene needs at least one body that moves (deformable or rigid); "
                         "planes are obstacles");
  sc->dim = dim;
  return MO_OK;
}

/* Dofs: the nodal dofs of deformable bodies first (the FE block of What), then the rigid
   bodies'; finite-strain state blocks; 3D orientations. */
static int number_dofs(mo_scene *sc, mo_ctx *ctx)
{
  long limit = ctx->max_dofs > 0 ? ctx->max_dofs : 20000000L, n = 0;
  int pass, b;
  for (b = 0; b < sc->nbody; b++) sc->nrigid += (sc->body[b].type->flags & MO_BODY_F_RIGID) != 0;
  sc->rigid = mo_malloc(ctx, ((size_t)sc->nrigid + 1) * sizeof *sc->rigid);
  if (!sc->rigid) return MO_ENOMEM;
  sc->nrigid = 0;
  for (pass = 0; pass < 2; pass++)
    for (b = 0; b < sc->nbody; b++) {
      mo_body *B = &sc->body[b];
      unsigned want = pass ? MO_BODY_F_RIGID : MO_BODY_F_NODAL;
      if (!(B->type->flags & want)) continue;
      B->dof0 = (int)n;
      n += B->ndof;
      if (n > limit) {
        const config_setting_t *bl = config_lookup(&sc->cs->cfg, "bodies");
        mo_case_error(sc->cs, bl, ctx, "the scene reaches %ld dofs with body '%s', more than the limit of %ld (a "
                      "direct factorization would not fit in memory)", n, B->name, limit);
        ctx->status = MO_ELIMIT;
        return MO_ELIMIT;
      }
      if (B->nl) {
        B->q0 = sc->nq;
        sc->nq += (size_t)B->mesh->nelem * (size_t)B->npoint * MO_J2_NSTATE;
        sc->nonlinear = 1;
      }
      if (pass) {
        sc->rigid[sc->nrigid++] = b;
        if (sc->dim == 3) B->orient = sc->norient++;
      } else
        sc->nfe_dof = (int)n;
      sc->mass_total += pass ? B->mass : 0;
    }
  sc->ndof = (int)n;
  return MO_OK;
}

/* The 2D rigid bodies' mass diagonals diag(m, m, I) as (m, I) in the order of sc->rigid: the
   stepper's right-hand side and the kinetic energy, the two passes a step makes over every rigid
   body's mass, read them there and not in the body records, 208 bytes apart (doc/theory.md
   (T311)). Rigid body r's first dof is nfe_dof + 3 r (number_dofs: the rigid bodies' dofs after the
   nodal ones, nd each in that order), which those passes use in place of the record's dof0: checked
   here in every dimension. */
static int rigid_diagonals(mo_scene *sc, mo_ctx *ctx)
{
  const int nd = mo_rigid_ndof(sc->dim);
  int r;
  for (r = 0; r < sc->nrigid; r++) {
    const mo_body *B = &sc->body[sc->rigid[r]];
    if (B->dof0 != sc->nfe_dof + nd * r || B->ndof != nd)
      return mo_error(ctx, MO_EINTERNAL, "rigid body '%s': dofs %d.. where number_dofs gives %d..", B->name, B->dof0,
                      sc->nfe_dof + nd * r);
  }
  if (sc->dim != 2 || !sc->nrigid) return MO_OK;
  if (!(sc->rigid_md = mo_malloc(ctx, 2 * (size_t)sc->nrigid * sizeof *sc->rigid_md))) return MO_ENOMEM;
  for (r = 0; r < sc->nrigid; r++) {
    sc->rigid_md[2 * (size_t)r] = sc->body[sc->rigid[r]].mass;
    sc->rigid_md[2 * (size_t)r + 1] = sc->body[sc->rigid[r]].J[0];
  }
  return MO_OK;
}

/* Pass 2: supports, prescribed motions and initial fields, then the free numbering. */
static int conditions(mo_scene *sc, const config_setting_t *bl, int nentry, int *owner, mo_ctx *ctx)
{
  int e, b, k, st, m;
  for (k = 0; k < sc->ndof; k++) owner[k] = -1;
  for (e = 0, b = 0; e < nentry; e++) {
    const config_setting_t *bg = config_setting_get_elem(bl, (unsigned)e);
    const mo_body_type *T = sc->body[b].type;
    int c = T->count ? T->count(bg) : 1;
    for (m = 0; m < (c < 1 ? 1 : c); m++, b++)
      if (T->conditions && (st = T->conditions(sc, b, bg, owner, ctx))) return st;
  }
  sc->nfree = sc->nfe_free = 0;
  for (k = 0; k < sc->ndof; k++) {
    sc->free_of[k] = owner[k] >= 0 ? -1 : sc->nfree++;
    if (k < sc->nfe_dof && owner[k] < 0) sc->nfe_free++;
  }
  /* every dof free: both maps are the identity over ndof = nfree entries, one array serves as
     both (12 bytes a 2D grain, T262) */
  sc->full_of = sc->nfree == sc->ndof ? sc->free_of
                                      : mo_malloc(ctx, (size_t)(sc->nfree ? sc->nfree : 1) * sizeof(int));
  if (!sc->full_of) return MO_ENOMEM;
  for (k = 0; k < sc->ndof; k++)
    if (sc->free_of[k] >= 0) sc->full_of[sc->free_of[k]] = k;
  for (k = 0; k < sc->npresc; k++) {
    mo_presc *p = &sc->presc[k];
    p->u0 = sc->u0[p->dof];
    if (p->kind == MO_PRESC_FIX) sc->v0[p->dof] = 0;
    else {
      double u, v;
      mo_scene_presc_eval(sc, k, 0, &u, &v);
      sc->u0[p->dof] = u;
      sc->v0[p->dof] = v;
    }
  }
  return MO_OK;
}

static int loads(mo_scene *sc, const config_setting_t *bl, int nentry, double *f, mo_ctx *ctx)
{
  int e, b, st, m;
  for (e = 0, b = 0; e < nentry; e++) {
    const config_setting_t *bg = config_setting_get_elem(bl, (unsigned)e);
    const mo_body_type *T = sc->body[b].type;
    int c = T->count ? T->count(bg) : 1;
    for (m = 0; m < (c < 1 ? 1 : c); m++, b++)
      if (T->loads && (st = T->loads(sc, b, bg, f, ctx))) return st;
  }
  /* the patterns at their size: a pack's body forces grew by doubling (up to twice the entries, T264) */
  for (e = 0; e < sc->nload; e++) {
    mo_load *L = &sc->load[e];
    if (L->cap > L->n && L->n > 0) {
      int *d = mo_realloc(ctx, L->dof, (size_t)L->n * sizeof *d);
      double *v;
      if (!d) return MO_ENOMEM;
      L->dof = d;
      if (!(v = mo_realloc(ctx, L->val, (size_t)L->n * sizeof *v))) return MO_ENOMEM;
      L->val = v;
      L->cap = L->n;
    }
  }
  return MO_OK;
}

/* Bytes per dof of a run, measured (peak RSS over dofs, FE assembly, CHOLMOD factor, state,
   outputs: doc/theory.md (T105)): 1D bars 315 B (wave-bar, 10^6 elements), 2D Q4 2.0 kB
   (plate-vibration 200 x 200); 3D boxes by box_bytes (T159), other 3D meshes 4 times 2D. */
static const double bytes_per_dof[4] = {300, 320, 2000, 8000};

/* The memory a run may take: the physical memory, or the address-space limit when lower, or
   the context's limit (mo_ctx.max_bytes). */
static double memory_limit(const mo_ctx *ctx)
{
  double mem = mo_memory_limit();
  return ctx->max_bytes > 0 && ctx->max_bytes < mem ? ctx->max_bytes : mem;
}

/* A 3D box of n[0] x n[1] x n[2] H8 (doc/theory.md (T159), (T165)): its factor grows faster than
   its dofs N. Nested dissection of a grid gives nnz(L) = kappa N sqrt(s), s the dofs of the
   smallest cross-section (the top separator); kappa grows with log N on CHOLMOD's factors of the
   cubes 14^3 .. 68^3 (bench/box_ordering.c, within 3.2 %): 3.55 + 1.41 ln N with the contact dofs
   last (last: the box is in an active pair and factor_order is contact_last), 1.97 + 1.20 ln N in
   CHOLMOD's own order. The run's peak then holds 10 bytes per entry of L (the supernodal values
   and indices), the larger of the factorization's largest update (s^2) and W and G on the contact
   face (2 s^2, with the contact dofs last), 4.5 kB per dof (K, M, What, the vectors) and 17.5 MB of
   the process: peak RSS of the box scaling runs 14^3 .. 45^3 within 4.3 % (bench/README.md). */
static double box_bytes(const double *n, int last, int ooc)
{
  double a = n[0] + 1, b = n[1] + 1, c = n[2] + 1, N = 3 * a * b * c, s, nnz;
  s = 3 * fmin(a * b, fmin(b * c, a * c));
  nnz = (last ? 3.55 + 1.41 * log(N) : 1.97 + 1.20 * log(N)) * N * sqrt(s);
  /* MUMPS's factor out of core is on disk: its workspace in the given order, INFOG(27) over
     INFOG(20), is 4.5 bytes per entry at 31^3 and 3.8 at 68^3 (T183); MUMPS's analysis then
     states its own figure (T181) */
  return 17.5e6 + 4490 * N + (ooc ? 4.5 : 10) * nnz + (last ? 16 : 8) * s * s;
}

/* linear_solver.out_of_core: MUMPS's factor on disk (T182) */
static int out_of_core(const mo_case *cs)
{
  const config_setting_t *lg = config_lookup(&cs->cfg, "linear_solver");
  return lg && mo_cfg_bool(lg, "out_of_core", 0);
}

/* Whether body `name` is in an active contact pair whose dofs the factorization orders last
   (contact.factor_order "contact_last", the default): what box_bytes counts. */
static int contact_last(const mo_case *cs, const char *name)
{
  const config_setting_t *pairs = config_lookup(&cs->cfg, "contact.pairs");
  int k, n = pairs ? config_setting_length(pairs) : 0;
  if (!strcmp(mo_cfg_string(config_lookup(&cs->cfg, "contact"), "factor_order", "contact_last"), "solver")) return 0;
  for (k = 0; k < n; k++) {
    const config_setting_t *pg = config_setting_get_elem(pairs, (unsigned)k);
    if (mo_cfg_bool(pg, "active", 1) && (!strcmp(mo_cfg_string(pg, "slave", ""), name) || !strcmp(mo_cfg_string(pg, "master", ""), name)))
      return 1;
  }
  return 0;
}

/* The scene's size from the case alone, before anything is built (T105): nodes, elements and
   dofs of each mesh generator and of the rigid bodies, and the bytes they will take; past the
   limits (10^7 elements, ctx->max_dofs dofs, the memory) refused with MO_ELIMIT naming the key
   and printing the estimate. Mesh files are bounded by their size and the reader's limits. */
static int estimate_size(const mo_case *cs, const config_setting_t *bl, int nentry, double *bytes_out, mo_ctx *ctx)
{
  double limit = ctx->max_dofs > 0 ? (double)ctx->max_dofs : 2e7, mem = memory_limit(ctx);
  double nodes = 0, elems = 0, dofs = 0, bytes = 0;
  int e;
  for (e = 0; e < nentry; e++) {
    const config_setting_t *bg = config_setting_get_elem(bl, (unsigned)e), *mg, *key;
    const mo_body_type *T = mo_body_type_find(mo_cfg_string(bg, "type", "deformable"));
    double c, nn = 0, ne = 0, n[3], eb;
    const char *gen;
    int d = 0, k;
    if (!T) continue;
    c = T->count ? T->count(bg) : 1;
    if (c < 1) c = 1;
    if (T->kind != MO_BODY_DEFORMABLE) {
      dofs += c * (T->kind == MO_BODY_SPHERE ? 6 : T->flags & MO_BODY_F_RIGID ? 3 : 0);
      bytes += c * (2000 + sizeof(mo_body)); /* a rigid body: its shape, contact lists, history */
      continue;
    }
    if (!(mg = mo_cfg_member(bg, "mesh")) || mo_cfg_member(mg, "file")) continue;
    gen = mo_cfg_string(mg, "generator", "");
    key = mo_cfg_member(mg, "elements");
    for (k = 0; k < 3; k++) {
      n[k] = mo_cfg_num_at(mg, "elements", k);
      if (!(n[k] >= 1)) n[k] = 1;
    }
    if (!strcmp(gen, "bar")) {
      d = 1;
      ne = n[0];
      nn = n[0] + 1;
    } else if (!strcmp(gen, "rectangle")) {
      const char *el = mo_cfg_string(mg, "element", "Q4");
      int t3 = !strcmp(el, "T3"), t6 = !strcmp(el, "T6"), uj = !strcmp(mo_cfg_string(mg, "diagonal", ""), "union_jack");
      d = 2;
      ne = n[0] * n[1] * (uj ? 4 : t3 || t6 ? 2 : 1);
      nn = t6 ? (2 * n[0] + 1) * (2 * n[1] + 1) : (n[0] + 1) * (n[1] + 1) + (uj ? n[0] * n[1] : 0);
    } else if (!strcmp(gen, "box")) {
      const char *el = mo_cfg_string(mg, "element", "H8");
      int t10 = !strcmp(el, "T10");
      d = 3;
      ne = n[0] * n[1] * n[2] * (strcmp(el, "H8") ? 6 : 1);
      nn = t10 ? (2 * n[0] + 1) * (2 * n[1] + 1) * (2 * n[2] + 1) : (n[0] + 1) * (n[1] + 1) * (n[2] + 1);
    } else if (!strcmp(gen, "disk")) {
      double core = mo_cfg_float(mg, "core", 8), rings = mo_cfg_float(mg, "rings", 4);
      d = 2;
      ne = core * core + 4 * core * rings;
      nn = (core + 1) * (core + 1) + 4 * core * rings;
      key = mo_cfg_member(mg, rings > core ? "rings" : "core");
      if (!key) key = mo_cfg_member(mg, "core");
    } else
      continue;
    if (!key) key = mg;
    nodes += c * nn;
    elems += c * ne;
    dofs += c * nn * d;
    eb = d == 3 && !strcmp(gen, "box") ? box_bytes(n, contact_last(cs, mo_cfg_string(bg, "name", "")), out_of_core(cs)) : nn * d * bytes_per_dof[d];
    bytes += c * eb;
    if (c * ne > 1e7 || dofs > limit || bytes > mem) {
      char why[160];
      if (c * ne > 1e7) snprintf(why, sizeof why, "more than the limit of 10^7 elements");
      else if (dofs > limit) snprintf(why, sizeof why, "the scene's %.3g dofs pass the limit of %.3g", dofs, limit);
      else snprintf(why, sizeof why, "the scene's %.3g GB pass the %.3g GB of memory there are", bytes / 1e9, mem / 1e9);
      return mo_case_error(cs, key, ctx, "body '%s' makes an estimated %.3g nodes, %.3g elements, %.3g dofs (about "
                           "%.3g GB): %s; refused before anything is built (a coarser mesh, please)",
                           mo_cfg_string(bg, "name", "?"), c * nn, c * ne, c * nn * d, c * eb / 1e9, why);
    }
  }
  /* a large scene says what it expects to take before it builds anything (T105, T165); the
     factorization states its exact figure after its symbolic analysis (T154) */
  *bytes_out = bytes;
  if (bytes > 2e9)
    mo_log(ctx, 1, "moreau: %.3g nodes, %.3g elements, %.3g dofs: about %.3g GB estimated before building (of the "
           "%.3g GB this run may take; doc/theory.md (T165))\n", nodes, elems, dofs, bytes / 1e9, mem / 1e9);
  return MO_OK;
}

int mo_scene_build(const mo_case *cs, mo_scene **out, mo_ctx *ctx)
{
  const config_setting_t *bl = config_lookup(&cs->cfg, "bodies");
  mo_scene *sc;
  int nentry, total, st = MO_OK, *owner = NULL;
  double *f = NULL, t0 = mo_clock();
  *out = NULL;
  sc = mo_calloc(ctx, 1, sizeof *sc);
  if (!sc) return MO_ENOMEM;
  sc->cs = cs;
  sc->title = mo_strdup(ctx, mo_cfg_string(config_root_setting(&cs->cfg), "title", ""));
  sc->case_file = mo_strdup(ctx, cs->file);
  nentry = count_bodies(bl, &total);
  if (total > 10000000) {
    st = mo_case_error(cs, bl, ctx, "the entries make %d bodies, more than the limit of 10^7", total);
    ctx->status = MO_ELIMIT;
    goto fail;
  }
  if ((st = estimate_size(cs, bl, nentry, &sc->bytes_estimate, ctx))) goto fail;
  sc->body = mo_calloc(ctx, (size_t)(total ? total : 1), sizeof *sc->body);
  if (!sc->title || !sc->case_file || !sc->body) { st = MO_ENOMEM; goto fail; }
  sc->nbody = total;
  if ((st = build_time(sc, cs, ctx))) goto fail;
  if ((st = read_bodies(sc, bl, nentry, ctx))) goto fail;
  if ((st = number_dofs(sc, ctx)) || (st = rigid_diagonals(sc, ctx))) goto fail;
  if (sc->nrigid && sc->time.scheme == MO_SCHEME_QUASISTATIC) {
    st = mo_case_error(cs, config_lookup(&cs->cfg, "time.scheme"), ctx, "rigid bodies need a dynamic scheme "
                       "(theta or newmark): without inertia nothing holds a rigid body but its contacts");
    goto fail;
  }
  sc->u0 = mo_calloc(ctx, (size_t)sc->ndof + 1, sizeof(double));
  sc->v0 = mo_calloc(ctx, (size_t)sc->ndof + 1, sizeof(double));
  owner = mo_malloc(ctx, ((size_t)sc->ndof + 1) * sizeof(int));
  f = mo_malloc(ctx, ((size_t)sc->ndof + 1) * sizeof(double));
  sc->free_of = mo_malloc(ctx, ((size_t)sc->ndof + 1) * sizeof(int));
  if (!sc->u0 || !sc->v0 || !owner || !f || !sc->free_of) { st = MO_ENOMEM; goto fail; }
  if ((st = conditions(sc, bl, nentry, owner, ctx))) goto fail;
  if ((st = loads(sc, bl, nentry, f, ctx))) goto fail;
  if ((st = build_linear(sc, cs, ctx))) goto fail;
  if ((st = build_output(sc, cs, ctx))) goto fail;
  if ((st = mo_reference_build(&sc->ref, sc, ctx))) goto fail;
  mo_phase_add(ctx, MO_PH_SETUP, t0);

  if (sc->time.scheme == MO_SCHEME_QUASISTATIC) mo_note_skip(ctx, "mass matrix (quasi-static scene)");
  if (!sc->nfe_dof) mo_note_skip(ctx, "finite-element assembly (no deformable body)");
  if ((st = assemble(sc, sc->time.scheme != MO_SCHEME_QUASISTATIC, ctx))) goto fail;
  mo_free(owner);
  mo_free(f);
  *out = sc;
  return MO_OK;
fail:
  mo_free(owner);
  mo_free(f);
  mo_scene_free(sc);
  return st ? st : ctx->status;
}

void mo_scene_fext(const mo_scene *sc, double t, double *f)
{
  int l, k;
  memset(f, 0, (size_t)sc->ndof * sizeof *f);
  for (l = 0; l < sc->nload; l++) {
    const mo_load *L = &sc->load[l];
    double a = L->amp ? mo_expr_eval(L->amp, &t) : 1;
    if (a == 0) continue;
    for (k = 0; k < L->n; k++) f[L->dof[k]] += a * L->val[k];
  }
}

void mo_scene_presc_eval(const mo_scene *sc, int k, double t, double *u, double *v)
{
  const mo_presc *p = &sc->presc[k];
  switch (p->kind) {
  case MO_PRESC_FIX: *u = p->u0; *v = 0; break;
  case MO_PRESC_VELOCITY: *u = p->u0 + p->vel * t; *v = p->vel; break;
  default: {
    double h = 1e-7 * (fabs(sc->time.end) > 0 ? sc->time.end : 1), tp = t + h, tm = t - h;
    *u = mo_expr_eval(p->disp, &t);
    *v = (mo_expr_eval(p->disp, &tp) - mo_expr_eval(p->disp, &tm)) / (2 * h);
  }
  }
}

