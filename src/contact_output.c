/* contact_output.c: per-candidate results: contact.csv and the table in Jean's layout (J88
   Figs. 3-4), with the other reaction representation (P images or P^-1 images); the contact
   network the VTK series and the drawings show. */
#include "config.h"
#include <moreau/contact.h>
#include <moreau/output.h>
#include "contact_internal.h"
#include <moreau/parallel.h>

#include <gsl/gsl_linalg.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

/* Reactions as forces (impulses over the step divided by its h for the theta-scheme). */
static double force_scale(const mo_scene *sc, const mo_contact_driver *Dr)
{
  return sc->time.scheme == MO_SCHEME_THETA ? 1 / mo_contact_driver_dt(Dr) : 1;
}

/* The other representation of the reactions of pair k (d components per candidate), in the
   pair's candidate order: concentrated r -> rho = (P*^T)^-1 r; weighted rho -> F = P*^T rho. */
static int other_representation(const mo_contact *C, int k, const double *r, double *out,
                                 mo_ctx *ctx)
{
  const double *P;
  const int *cands;
  int n, d = C->dim, i, j, c, st = MO_OK;
  if (mo_contact_pair_P(C, k, &P, &n, &cands)) return MO_EUNSUPPORTED;
  if (C->pair[k].reactions == MO_REACT_WEIGHTED) {
    for (i = 0; i < n; i++)
      for (c = 0; c < d; c++) {
        double s = 0;
        for (j = 0; j < n; j++) s += P[j * n + i] * r[cands[j] * d + c];
        out[i * d + c] = s;
      }
    return MO_OK;
  }
  {
    gsl_matrix *A = gsl_matrix_alloc((size_t)n, (size_t)n);
    gsl_permutation *perm = gsl_permutation_alloc((size_t)n);
    gsl_vector *b = gsl_vector_alloc((size_t)n), *x = gsl_vector_alloc((size_t)n);
    int sg;
    if (!A || !perm || !b || !x) st = mo_error(ctx, MO_ENOMEM, "P^-1 images");
    for (i = 0; !st && i < n; i++)
      for (j = 0; j < n; j++) gsl_matrix_set(A, (size_t)i, (size_t)j, P[j * n + i]); /* P*^T */
    if (!st && gsl_linalg_LU_decomp(A, perm, &sg)) st = mo_error(ctx, MO_ESINGULAR, "P* is singular");
    for (c = 0; !st && c < d; c++) {
      for (i = 0; i < n; i++) gsl_vector_set(b, (size_t)i, r[cands[i] * d + c]);
      if (gsl_linalg_LU_solve(A, perm, b, x)) { st = mo_error(ctx, MO_ESINGULAR, "P* is singular"); break; }
      for (i = 0; i < n; i++) out[i * d + c] = gsl_vector_get(x, (size_t)i);
    }
    gsl_matrix_free(A);
    gsl_permutation_free(perm);
    gsl_vector_free(b);
    gsl_vector_free(x);
  }
  return st;
}

double mo_contact_friction_ratio(int d, double mu, const double *r)
{
  double rt = 0;
  int i;
  if (d < 2 || !(mu > 0) || !(r[0] > 0)) return 0;
  for (i = 1; i < d; i++) rt += r[i] * r[i];
  return sqrt(rt) / (mu * r[0]);
}

/* The displacement of candidate a's slave point: its nodes' (a deformable body), the rigid motion
   of its nodes (a rigid mesh), the body's centroid (a rigid shape). */
static void cand_node_disp(const mo_scene *sc, const mo_contact *C, int a, const mo_state *s, double *D)
{
  mo_cpoint pb;
  const mo_cpoint *p = mo_contact_cand_point(C, a, &pb);
  const mo_body *B = &sc->body[p->sb];
  int i, k;
  for (i = 0; i < sc->dim; i++) D[i] = 0;
  if (B->kind == MO_BODY_DEFORMABLE) {
    for (i = 0; i < sc->dim; i++)
      for (k = 0; k < p->nn; k++) D[i] += p->N[k] * s->u[B->dof0 + p->node[k] * sc->dim + i];
  } else if (B->type->flags & MO_BODY_F_RIGID) {
    if (B->mesh && p->nn) {
      for (k = 0; k < p->nn; k++) {
        double x[3];
        mo_contact_node_pos(sc, p->sb, p->node[k], s, x);
        for (i = 0; i < sc->dim; i++) D[i] += p->N[k] * (x[i] - B->mesh->x[p->node[k] * sc->dim + i]);
      }
    } else
      for (i = 0; i < sc->dim; i++) D[i] = s->u[B->dof0 + i];
  }
}

/* The columns of contact.csv: pair, candidate, node, position x.., displacement D1.., gap, the
   local velocity and reactions normal first (UN UT US, RN RT RS), status, measure,
   representation, then (with `other`) the other representation's reactions (RN_other ...),
   lambda, slave, master. */
static void csv_header(FILE *f, int D, int d, int other)
{
  static const char *ax[3] = {"x", "y", "z"}, *dn[3] = {"D1", "D2", "D3"}, *ln[3] = {"N", "T", "S"};
  int i;
  fprintf(f, "pair,candidate,node");
  for (i = 0; i < D; i++) fprintf(f, ",%s", ax[i]);
  for (i = 0; i < D; i++) fprintf(f, ",%s", dn[i]);
  fprintf(f, ",gap");
  for (i = 0; i < d; i++) fprintf(f, ",U%s", ln[i]);
  for (i = 0; i < d; i++) fprintf(f, ",R%s", ln[i]);
  fprintf(f, ",status,measure,representation");
  for (i = 0; other && i < d; i++) fprintf(f, ",R%s_other", ln[i]);
  fprintf(f, ",lambda,slave,master\n");
}

/* The values the rows read: the driver's reactions (as forces: times fs), local velocities and
   statuses, the candidates' gaps. */
typedef struct {
  const double *r, *U, *g;
  const int *status;
  double fs;
} cand_values;

static void cand_values_get(const mo_scene *sc, const mo_contact *C, const mo_contact_driver *Dr, cand_values *v)
{
  v->r = mo_contact_reactions(Dr);
  v->U = mo_contact_local_velocity(Dr);
  v->g = mo_contact_gaps(C);
  v->status = mo_contact_statuses(Dr);
  v->fs = force_scale(sc, Dr);
}

/* Candidate a's row of contact.csv (other: its other representation, NULL for none; with_other:
   the file has those columns). */
static void csv_row(FILE *f, const mo_scene *sc, const mo_contact *C, const cand_values *v, const mo_state *s,
                    int a, int with_other, const double *other)
{
  mo_candidate cb;
  mo_cpoint pb;
  const mo_candidate *c = mo_contact_cand_get(C, a, &cb);
  const mo_cpoint *p = mo_contact_cand_point(C, a, &pb);
  int d = C->dim, D = sc->dim, i;
  double Dd[3];
  cand_node_disp(sc, C, a, s, Dd);
  fprintf(f, "%s,%d,%d", C->pair[c->pair].name, a, c->node);
  for (i = 0; i < D; i++) fprintf(f, ",%.10g", p->x0[i]);
  for (i = 0; i < D; i++) fprintf(f, ",%.10g", Dd[i]);
  fprintf(f, ",%.10g", v->g[a]);
  for (i = 0; i < d; i++) fprintf(f, ",%.10g", v->U[a * d + i]);
  for (i = 0; i < d; i++) fprintf(f, ",%.10g", v->r[a * d + i] * v->fs);
  fprintf(f, ",%s,%.10g,%s", mo_contact_status_name(v->status[a]), c->w,
          C->pair[c->pair].reactions == MO_REACT_WEIGHTED ? "weighted" : "concentrated");
  for (i = 0; with_other && i < d; i++) {
    if (other) fprintf(f, ",%.10g", other[i] * v->fs);
    else fprintf(f, ",");
  }
  fprintf(f, ",%.10g,%s,%s\n", mo_contact_friction_ratio(d, c->mu, v->r + a * d), sc->body[p->sb].name,
          p->mb >= 0 ? sc->body[p->mb].name : "");
}

/* A candidate shown among the closed ones: a status other than open, or a reaction. */
static int cand_closed(const cand_values *v, int d, int a)
{
  int i, any = v->status[a] != MO_CS_OPEN;
  for (i = 0; i < d; i++) any |= v->r[a * d + i] != 0;
  return any;
}

static int write_csv_dist(const char *path, const mo_scene *sc, const mo_contact *C, const mo_contact_driver *Dr,
                          const mo_state *s, mo_ctx *ctx);

int mo_contact_write_csv(const char *path, const mo_scene *sc, const mo_contact *C,
                         const mo_contact_driver *Dr, const mo_state *s, mo_ctx *ctx)
{
  int d = C->dim, a, i, k, st = MO_OK;
  cand_values v;
  double *other = NULL;
  int *has_other = NULL;
  mo_atomic_file A;
  A.f = NULL;
  if (mo_contact_distributed(C)) return write_csv_dist(path, sc, C, Dr, s, ctx);
  cand_values_get(sc, C, Dr, &v);
  /* the other representation's columns: only pairs with facets (P*) have one */
  for (k = 0; k < C->npair; k++) {
    const double *P;
    const int *cands;
    int n;
    if (!mo_contact_pair_P(C, k, &P, &n, &cands)) break;
  }
  if (k < C->npair) {
    other = mo_calloc(ctx, (size_t)C->nc * (size_t)d + 1, sizeof(double));
    has_other = mo_calloc(ctx, (size_t)C->nc + 1, sizeof(int));
    if (!other || !has_other) { st = MO_ENOMEM; goto done; }
  }
  for (k = 0; other && k < C->npair; k++) {
    const double *P;
    const int *cands;
    int n;
    double *tmp;
    if (mo_contact_pair_P(C, k, &P, &n, &cands)) continue;
    tmp = mo_malloc(ctx, (size_t)n * (size_t)d * sizeof(double) + 1);
    if (!tmp) { st = MO_ENOMEM; goto done; }
    if (!other_representation(C, k, v.r, tmp, ctx))
      for (i = 0; i < n; i++) {
        memcpy(&other[cands[i] * d], &tmp[i * d], (size_t)d * sizeof(double));
        has_other[cands[i]] = 1;
      }
    mo_ctx_clear_error(ctx);
    mo_free(tmp);
  }
  /* streamed: a pile of 10^5 grains has 2 10^5 candidates */
  if ((st = mo_atomic_open(&A, path, ctx))) goto done;
  csv_header(A.f, sc->dim, d, 1);
  for (a = 0; a < C->nc; a++) csv_row(A.f, sc, C, &v, s, a, 1, has_other && has_other[a] ? &other[a * d] : NULL);
  st = mo_atomic_commit(&A, 1, ctx);
  A.f = NULL;
done:
  if (A.f) mo_atomic_commit(&A, 0, ctx); /* an error above: the old file stays */
  mo_free(other);
  mo_free(has_other);
  return st;
}

/* --- the distributed set (doc/scaling.md §4) --------------------------------------------------------
   Each rank lists its own candidates; rank 0 gathers every rank's entries, each led by its
   candidate's place in the detection's order (T220) as four 32-bit halves, and merges them in that
   order: the order of one process's set, so that the candidates are numbered as its. */
#define ORDW 4
/* a point's entry: the order, then x, x0, disp, normal, R, U, force, vrel (3 each), gap, lambda,
   measure, pair, node, status, slave, master, closed */
#define PTW (ORDW + 24 + 3 + 5 + 1)
/* a line's: the order, then end (6), point (3), rn, rt, gap, status, slave, master */
#define NETW (ORDW + 15)

static int points_dist(const mo_scene *sc, const mo_contact *C, const mo_contact_driver *Dr, const mo_state *s,
                       int closed_only, mo_vtk_points *P, mo_ctx *ctx);

static void order_put(const mo_contact *C, int a, double *o)
{
  const mo_setmap_ord k = mo_setmap_order(C->krr, mo_contact_key(C, a));
  o[0] = (double)(k.hi >> 32);
  o[1] = (double)(k.hi & 0xffffffffu);
  o[2] = (double)(k.lo >> 32);
  o[3] = (double)(k.lo & 0xffffffffu);
}

static int order_before(const double *a, const double *b)
{
  int i;
  for (i = 0; i < ORDW; i++)
    if (a[i] != b[i]) return a[i] < b[i];
  return 0;
}

/* n entries of w numbers from every rank (each in the order) into src->rec on rank 0, merged; *total
   their count there (0 elsewhere). A collective. */
static int gather_merge(mo_vtk_source *src, const double *mine, long n, int w, int failed, long *total, mo_ctx *ctx)
{
  const int np = ctx->nranks;
  /* (the distributed set runs on at most 52 ranks: nscd_grains.c) */
  double c = (double)n * w, cnt_d[64], *all = NULL, bad = failed ? 1 : 0;
  int cnt[64] = {0}, one[64] = {0}, r, st = MO_OK;
  long tot = 0, head[64], lim[64], k, *ord = NULL;
  *total = 0;
  mo_vtk_source_drop(src);
  if (np > 64) return mo_error(ctx, MO_ELIMIT, "contact output over %d ranks (at most 64)", np);
  for (r = 0; r < np; r++) one[r] = 1;
  /* every rank's count; then whether every rank has its room (a rank that has not: no gather) */
  if ((st = mo_par_gatherv(&c, one, cnt_d, ctx))) return st;
  for (r = 0; r < np; r++) {
    if (cnt_d[r] > 0x7fffffff) bad = 2;
    cnt[r] = (int)cnt_d[r];
    head[r] = tot;
    tot += cnt[r];
    lim[r] = tot;
  }
  if (!bad && ctx->rank == 0 &&
      (!(all = mo_malloc(ctx, ((size_t)tot + 1) * sizeof *all)) ||
       !(ord = mo_malloc(ctx, ((size_t)tot / (size_t)w + 1) * sizeof *ord))))
    bad = 1;
  if ((st = mo_par_max(&bad, 1, ctx))) goto done;
  if (bad) {
    st = bad > 1 ? mo_error(ctx, MO_ELIMIT, "contact output: more than 2^31 values from one rank")
                 : mo_error(ctx, MO_ENOMEM, "contact output: no memory to gather the ranks' contacts");
    goto done;
  }
  if ((st = mo_par_gather0(mine, cnt, all, ctx))) goto done;
  if (ctx->rank == 0) {
    /* the ranks' runs merged (the rank whose next entry comes first), as places in rec */
    for (k = 0; k < tot / w; k++) {
      int best = -1;
      for (r = 0; r < np; r++)
        if (head[r] < lim[r] && (best < 0 || order_before(all + head[r], all + head[best]))) best = r;
      ord[k] = head[best];
      head[best] += w;
    }
    src->rec = all;
    src->ord = ord;
    src->recw = w;
    src->nrec = tot / w;
    *total = tot / w;
    all = NULL;
    ord = NULL;
  }
done:
  mo_free(all);
  mo_free(ord);
  return st;
}

/* contact.csv over the distributed set: every rank's candidates gathered to rank 0 as the VTK
   points' entries (points_dist), written there with their numbers in one process's set; path is
   read on rank 0 only. A collective. */
static int write_csv_dist(const char *path, const mo_scene *sc, const mo_contact *C, const mo_contact_driver *Dr,
                          const mo_state *s, mo_ctx *ctx)
{
  mo_vtk_points P;
  mo_atomic_file A;
  const int d = C->dim, D = sc->dim;
  long a;
  int st, i;
  memset(&P, 0, sizeof P);
  A.f = NULL;
  if ((st = points_dist(sc, C, Dr, s, 0, &P, ctx)) || ctx->rank != 0) goto done;
  if ((st = mo_atomic_open(&A, path, ctx))) goto done;
  csv_header(A.f, D, d, 1);
  for (a = 0; a < P.src.nrec; a++) {
    const double *e = P.src.rec + P.src.ord[a] + ORDW;
    const mo_contact_pair *Q = &C->pair[(int)e[27]];
    const int sb = (int)e[30], mb = (int)e[31];
    fprintf(A.f, "%s,%ld,%d", Q->name, a, (int)e[28]);
    for (i = 0; i < D; i++) fprintf(A.f, ",%.10g", e[3 + i]);
    for (i = 0; i < D; i++) fprintf(A.f, ",%.10g", e[6 + i]);
    fprintf(A.f, ",%.10g", e[24]);
    for (i = 0; i < d; i++) fprintf(A.f, ",%.10g", e[15 + i]);
    for (i = 0; i < d; i++) fprintf(A.f, ",%.10g", e[12 + i]);
    fprintf(A.f, ",%s,%.10g,%s", mo_contact_status_name((int)e[29]), e[26],
            Q->reactions == MO_REACT_WEIGHTED ? "weighted" : "concentrated");
    for (i = 0; i < d; i++) fprintf(A.f, ",");
    fprintf(A.f, ",%.10g,%s,%s\n", e[25], sc->body[sb].name, mb >= 0 ? sc->body[mb].name : "");
  }
  st = mo_atomic_commit(&A, 1, ctx);
  A.f = NULL;
done:
  if (A.f) mo_atomic_commit(&A, 0, ctx);
  mo_vtk_points_release(&P);
  return st;
}

/* --- contact_history.csv: the candidates of every output step ---------------------------------- */

struct mo_contact_history {
  FILE *f;
  char *path;
  int closed;
};

int mo_contact_history_open(const char *path, const mo_scene *sc, const mo_contact *C, int closed_only,
                            mo_contact_history **out, mo_ctx *ctx)
{
  mo_contact_history *H = mo_calloc(ctx, 1, sizeof *H);
  *out = NULL;
  if (!H) return MO_ENOMEM;
  if (!(H->path = mo_strdup(ctx, path))) {
    mo_free(H);
    return MO_ENOMEM;
  }
  H->closed = closed_only;
  if (!(H->f = fopen(path, "w"))) {
    int e = errno;
    mo_contact_history_close(H, ctx);
    return mo_error(ctx, MO_EOUTPUT, "cannot write '%s': %s", path, strerror(e));
  }
  fprintf(H->f, "step,t,");
  csv_header(H->f, sc->dim, C->dim, 0);
  *out = H;
  return MO_OK;
}

int mo_contact_history_write(mo_contact_history *H, const mo_scene *sc, const mo_contact *C,
                             const mo_contact_driver *Dr, const mo_state *s, mo_ctx *ctx)
{
  cand_values v;
  int a;
  cand_values_get(sc, C, Dr, &v);
  for (a = 0; a < C->nc; a++) {
    if (H->closed && !cand_closed(&v, C->dim, a)) continue;
    fprintf(H->f, "%ld,%.17g,", s->step, s->t);
    csv_row(H->f, sc, C, &v, s, a, 0, NULL);
  }
  /* a block is flushed whole: a reader of a run killed meanwhile sees whole steps but the last */
  if (fflush(H->f) != 0 || ferror(H->f))
    return mo_error(ctx, MO_EOUTPUT, "cannot write '%s': %s", H->path, strerror(errno ? errno : EIO));
  return MO_OK;
}

int mo_contact_history_close(mo_contact_history *H, mo_ctx *ctx)
{
  int st = MO_OK;
  if (!H) return MO_OK;
  if (H->f && fclose(H->f) != 0) st = mo_error(ctx, MO_EOUTPUT, "cannot write '%s': %s", H->path, strerror(errno));
  mo_free(H->path);
  mo_free(H);
  return st;
}

void mo_contact_print_table(FILE *f, const mo_scene *sc, const mo_contact *C,
                            const mo_contact_driver *Dr, const mo_state *s, mo_ctx *ctx)
{
  int d = C->dim, k, i;
  const double *r = mo_contact_reactions(Dr);
  const int *status = mo_contact_statuses(Dr);
  const mo_contact_report *rep = mo_contact_last_report(Dr);
  double fs = force_scale(sc, Dr);
  for (k = 0; k < C->npair; k++) {
    const mo_contact_pair *P = &C->pair[k];
    const double *Pm;
    const int *cands;
    int n, weighted = P->reactions == MO_REACT_WEIGHTED, have_other;
    double Rx[3] = {0, 0, 0}, *oth;
    if (mo_contact_pair_P(C, k, &Pm, &n, &cands)) continue;
    oth = mo_calloc(ctx, (size_t)n * (size_t)d + 1, sizeof(double));
    if (!oth) return;
    have_other = other_representation(C, k, r, oth, ctx) == MO_OK;
    mo_ctx_clear_error(ctx);
    fprintf(f, "\npair %s (%s reactions)   t = %.6g   iterations = %d   residual = %.3e\n", P->name,
            weighted ? "weighted" : "concentrated", s->t, rep->iterations, rep->residual);
    fprintf(f, "%5s %13s %13s %13s %13s  %-6s| %13s %13s\n", "node", "D1", "D2", "RT", "RN", "status",
            "RT", "RN");
    fprintf(f, "%5s %13s %13s %13s %13s  %-6s| %27s\n", "", "", "", weighted ? "weighted" : "concentrated",
            "reactions", "", weighted ? "equiv. concentrated (P rho)" : "equiv. weighted (P^-1 r)");
    for (i = 0; i < n; i++) {
      int a = cands[i];
      double Dd[3], rt = d > 1 ? r[a * d + 1] * fs : 0, rn = r[a * d] * fs, Fb[9];
      const double *F = mo_contact_frame_of(C, a, Fb);
      int j;
      cand_node_disp(sc, C, a, s, Dd);
      fprintf(f, "%5d %13.5e %13.5e %13.5e %13.5e  %-6s| ", i + 1, Dd[0], sc->dim > 1 ? Dd[1] : 0.0, rt, rn,
              mo_contact_status_name(status[a]));
      if (have_other)
        fprintf(f, "%13.5e %13.5e\n", d > 1 ? oth[i * d + 1] * fs : 0.0, oth[i * d] * fs);
      else
        fprintf(f, "%13s %13s\n", "-", "-");
      /* resultant in global axes: sum of the (weighted or concentrated) reactions */
      for (j = 0; j < sc->dim; j++) {
        int l;
        for (l = 0; l < d; l++) Rx[j] += r[a * d + l] * fs * F[l * d + j];
      }
    }
    fprintf(f, "%5s %13.5e %13.5e   (Rx, Ry: sum of the %s reactions)\n", "R", Rx[0],
            sc->dim > 1 ? Rx[1] : 0.0, weighted ? "weighted" : "concentrated");
    mo_free(oth);
  }
}

/* --- the contact network for the VTK series and the drawings --------------------------------- */

/* A rigid shape (disk, sphere, polygon): its line ends at its centre. */
static int network_shape(const mo_scene *sc, int b)
{
  return b >= 0 && (sc->body[b].type->flags & MO_BODY_F_RIGID) && sc->body[b].kind != MO_BODY_RIGID_MESH;
}

/* World position at state s of the point of mesh body b interpolating nodes node[0..n-1] by N
   (x = X + u on a deformable body, through the rigid map on a rigid mesh); `dflt` when the point
   has no nodes. */
static void network_material(const mo_scene *sc, const mo_state *s, int b, int n, const int *node,
                             const double *N, const double *dflt, double *x)
{
  const mo_body *B = b >= 0 ? &sc->body[b] : NULL;
  int D = sc->dim, k, i;
  double X[3], y[3];
  memset(x, 0, 3 * sizeof *x);
  if (!B || !B->mesh || n <= 0) {
    for (i = 0; i < D; i++) x[i] = dflt[i];
    return;
  }
  for (k = 0; k < n; k++) {
    const double *Xk = B->mesh->x + (size_t)node[k] * D;
    if (B->kind == MO_BODY_RIGID_MESH) {
      for (i = 0; i < D; i++) X[i] = Xk[i] - B->xc0[i];
      mo_rigid_point(sc, B, s, X, y);
    } else
      for (i = 0; i < D; i++) y[i] = Xk[i] + s->u[B->dof0 + node[k] * D + i];
    for (i = 0; i < D; i++) x[i] += N[k] * y[i];
  }
}

/* The ends and the contact point of point p: slave side, contact point, master side (3 each). */
static void network_line(const mo_scene *sc, const mo_state *s, const mo_cpoint *p, double *ends, double *cp)
{
  int D = sc->dim, i;
  double xs[3];
  network_material(sc, s, p->sb, p->nn, p->node, p->N, p->xs, xs);
  if (p->mb >= 0 && sc->body[p->mb].kind == MO_BODY_PLANE) {
    /* the slave point projected on the plane where it is at time t */
    const mo_body *P = &sc->body[p->mb];
    double g = 0;
    for (i = 0; i < D; i++) g += (xs[i] - (P->point[i] + P->velocity[i] * s->t)) * P->normal[i];
    memset(cp, 0, 3 * sizeof *cp);
    for (i = 0; i < D; i++) cp[i] = xs[i] - g * P->normal[i];
  } else
    network_material(sc, s, p->mb, p->mn, p->mnode, p->mN, p->xm, cp);
  if (network_shape(sc, p->sb)) mo_rigid_center(sc, &sc->body[p->sb], s, ends);
  else memcpy(ends, xs, 3 * sizeof *ends);
  if (network_shape(sc, p->mb)) mo_rigid_center(sc, &sc->body[p->mb], s, ends + 3);
  else memcpy(ends + 3, cp, 3 * sizeof *ends);
}

/* The next chunk of the network: the lines from candidate src.cursor on. */
static int network_fill(mo_vtk_contacts *N, mo_ctx *ctx)
{
  const mo_scene *sc = N->src.sc;
  const mo_contact *C = N->src.C;
  const mo_contact_driver *Dr = N->src.D;
  const mo_state *s = N->src.s;
  const double *r = mo_contact_reactions(Dr), *g = mo_contact_gaps(C), fs = force_scale(sc, Dr);
  const int *status = mo_contact_statuses(Dr);
  long want = N->total - N->first;
  int a, i, d = C->dim, nc = mo_contact_ncandidates(C);
  (void)ctx;
  if (want > N->cap) want = N->cap;
  for (a = (int)N->src.cursor; a < nc && N->n < want; a++) {
    mo_cpoint pb;
    const mo_cpoint *p;
    double rt = 0;
    int n = N->n, any = status[a] != MO_CS_OPEN;
    for (i = 0; i < d; i++) any |= r[a * d + i] != 0;
    if (!any) continue;
    p = mo_contact_cand_point(C, a, &pb);
    for (i = 1; i < d; i++) rt += r[a * d + i] * r[a * d + i];
    network_line(sc, s, p, N->end + 6 * n, N->point + 3 * n);
    N->rn[n] = r[a * d] * fs;
    N->rt[n] = sqrt(rt) * fs;
    N->gap[n] = g[a];
    N->status[n] = status[a];
    N->body[2 * n] = p->sb;
    N->body[2 * n + 1] = p->mb;
    N->n++;
  }
  N->src.cursor = a;
  return MO_OK;
}

/* A frame's source for mo_contact_network and mo_contact_points: what its fill reads, kept in
   src, and the count of the entries it lists (every candidate, or the closed ones). */
static long frame_source(mo_vtk_source *src, const mo_scene *sc, const mo_contact *C, const mo_contact_driver *Dr,
                         const mo_state *s, int closed_only)
{
  cand_values v;
  long total = 0;
  int a;
  cand_values_get(sc, C, Dr, &v);
  for (a = 0; a < C->nc; a++) total += !closed_only || cand_closed(&v, C->dim, a);
  src->sc = sc;
  src->C = C;
  src->D = Dr;
  src->s = s;
  src->closed_only = closed_only;
  return total;
}

/* The next chunk of the network from the gathered lines (rank 0). */
static int network_fill_rec(mo_vtk_contacts *N, mo_ctx *ctx)
{
  long want = N->total - N->first, a;
  int i;
  (void)ctx;
  if (want > N->cap) want = N->cap;
  for (a = N->src.cursor; a < N->src.nrec && N->n < want; a++) {
    const double *e = N->src.rec + N->src.ord[a] + ORDW;
    const int n = N->n;
    for (i = 0; i < 6; i++) N->end[6 * n + i] = e[i];
    for (i = 0; i < 3; i++) N->point[3 * n + i] = e[6 + i];
    N->rn[n] = e[9];
    N->rt[n] = e[10];
    N->gap[n] = e[11];
    N->status[n] = (int)e[12];
    N->body[2 * n] = (int)e[13];
    N->body[2 * n + 1] = (int)e[14];
    N->n++;
  }
  N->src.cursor = a;
  return MO_OK;
}

/* mo_contact_network over the distributed set: every rank's lines to rank 0 (a collective). */
static int network_dist(const mo_scene *sc, const mo_contact *C, const mo_contact_driver *Dr, const mo_state *s,
                        mo_vtk_contacts *N, mo_ctx *ctx)
{
  long own = frame_source(&N->src, sc, C, Dr, s, 1), total = 0, k;
  double *mine = NULL;
  int st, failed, a, i;
  cand_values v;
  cand_values_get(sc, C, Dr, &v);
  failed = mo_vtk_contacts_reserve(N, MO_VTK_CHUNK, ctx) != MO_OK ||
           !(mine = mo_malloc(ctx, ((size_t)own * NETW + 1) * sizeof *mine));
  if (!failed) {
    /* chunk by chunk; the candidates of the lines, in order: those network_fill takes */
    long at = 0;
    a = 0;
    N->total = own;
    do {
      N->first += N->n;
      N->n = 0;
      network_fill(N, ctx);
      for (k = 0; k < N->n; k++, at++) {
        double *e = mine + (size_t)at * NETW;
        while (!cand_closed(&v, C->dim, a)) a++;
        order_put(C, a++, e);
        e += ORDW;
        for (i = 0; i < 6; i++) e[i] = N->end[6 * k + i];
        for (i = 0; i < 3; i++) e[6 + i] = N->point[3 * k + i];
        e[9] = N->rn[k];
        e[10] = N->rt[k];
        e[11] = N->gap[k];
        e[12] = N->status[k];
        e[13] = N->body[2 * k];
        e[14] = N->body[2 * k + 1];
      }
    } while (N->n > 0 && N->first + N->n < own);
  }
  N->total = 0;
  mo_vtk_contacts_rewind(N);
  st = gather_merge(&N->src, mine, failed ? 0 : own, NETW, failed, &total, ctx);
  mo_free(mine);
  if (st) return st;
  N->total = total;
  N->fill = network_fill_rec;
  return MO_OK;
}


int mo_contact_network(const mo_scene *sc, const mo_contact *C, const mo_contact_driver *Dr,
                       const mo_state *s, mo_vtk_contacts *N, mo_ctx *ctx)
{
  long total;
  int st;
  N->total = 0;
  N->fill = NULL;
  mo_vtk_contacts_rewind(N);
  if (!C || !Dr) return MO_OK;
  if (mo_contact_distributed(C)) return network_dist(sc, C, Dr, s, N, ctx);
  total = frame_source(&N->src, sc, C, Dr, s, 1);
  if ((st = mo_vtk_contacts_reserve(N, total < MO_VTK_CHUNK ? (int)total : MO_VTK_CHUNK, ctx))) return st;
  N->total = total;
  N->fill = network_fill;
  return MO_OK;
}

/* The next chunk of the contact points: from candidate src.cursor on. */
static int points_fill(mo_vtk_points *P, mo_ctx *ctx)
{
  const mo_scene *sc = P->src.sc;
  const mo_contact *C = P->src.C;
  const mo_state *s = P->src.s;
  cand_values v;
  long want = P->total - P->first;
  int a, i, l, d = C->dim;
  (void)ctx;
  cand_values_get(sc, C, P->src.D, &v);
  if (want > P->cap) want = P->cap;
  for (a = (int)P->src.cursor; a < C->nc && P->n < want; a++) {
    mo_candidate cb;
    mo_cpoint pb;
    const mo_candidate *c;
    const mo_cpoint *p;
    double Fb[9];
    const double *F = mo_contact_frame_of(C, a, Fb); /* formed from the normal on the granular path (T225) */
    int n = P->n;
    double *x = P->x + 3 * n, *f = P->force + 3 * n, *w = P->vrel + 3 * n;
    if (P->src.closed_only && !cand_closed(&v, d, a)) continue;
    c = mo_contact_cand_get(C, a, &cb);
    p = mo_contact_cand_point(C, a, &pb);
    network_material(sc, s, p->sb, p->nn, p->node, p->N, p->xs, x);
    memset(P->x0 + 3 * n, 0, 3 * sizeof(double));
    memcpy(P->x0 + 3 * n, p->x0, (size_t)sc->dim * sizeof(double));
    memset(P->disp + 3 * n, 0, 3 * sizeof(double));
    cand_node_disp(sc, C, a, s, P->disp + 3 * n);
    memset(P->normal + 3 * n, 0, 3 * sizeof(double));
    memset(P->R + 3 * n, 0, 3 * sizeof(double));
    memset(P->U + 3 * n, 0, 3 * sizeof(double));
    memset(f, 0, 3 * sizeof(double));
    memset(w, 0, 3 * sizeof(double));
    for (l = 0; l < d; l++) {
      P->R[3 * n + l] = v.r[a * d + l] * v.fs;
      P->U[3 * n + l] = v.U[a * d + l];
      for (i = 0; i < d; i++) {
        if (l == 0) P->normal[3 * n + i] = F[i];
        f[i] += P->R[3 * n + l] * F[l * d + i]; /* the frame's rows: n, t, s */
        w[i] += P->U[3 * n + l] * F[l * d + i];
      }
    }
    P->gap[n] = v.g[a];
    P->lambda[n] = mo_contact_friction_ratio(d, c->mu, v.r + a * d);
    P->measure[n] = c->w;
    P->cand[n] = a;
    P->pair[n] = c->pair;
    P->node[n] = c->node;
    P->status[n] = v.status[a];
    P->body[2 * n] = p->sb;
    P->body[2 * n + 1] = p->mb;
    P->n++;
  }
  P->src.cursor = a;
  return MO_OK;
}

/* A point's entry from the filled arrays (entry k of P, candidate a). */
static void point_pack(const mo_contact *C, const mo_vtk_points *P, int k, int a, int closed, double *e)
{
  int i;
  order_put(C, a, e);
  e += ORDW;
  for (i = 0; i < 3; i++) {
    e[i] = P->x[3 * k + i];
    e[3 + i] = P->x0[3 * k + i];
    e[6 + i] = P->disp[3 * k + i];
    e[9 + i] = P->normal[3 * k + i];
    e[12 + i] = P->R[3 * k + i];
    e[15 + i] = P->U[3 * k + i];
    e[18 + i] = P->force[3 * k + i];
    e[21 + i] = P->vrel[3 * k + i];
  }
  e[24] = P->gap[k];
  e[25] = P->lambda[k];
  e[26] = P->measure[k];
  e[27] = P->pair[k];
  e[28] = P->node[k];
  e[29] = P->status[k];
  e[30] = P->body[2 * k];
  e[31] = P->body[2 * k + 1];
  e[32] = closed;
}

/* The next chunk from the gathered entries (rank 0): their place in the merge is the candidate's
   number; with closed_only the others skipped. */
static int points_fill_rec(mo_vtk_points *P, mo_ctx *ctx)
{
  const long nrec = P->src.nrec;
  long want = P->total - P->first, a;
  int i;
  (void)ctx;
  if (want > P->cap) want = P->cap;
  for (a = P->src.cursor; a < nrec && P->n < want; a++) {
    const double *e = P->src.rec + P->src.ord[a] + ORDW;
    const int n = P->n;
    if (P->src.closed_only && !e[32]) continue;
    for (i = 0; i < 3; i++) {
      P->x[3 * n + i] = e[i];
      P->x0[3 * n + i] = e[3 + i];
      P->disp[3 * n + i] = e[6 + i];
      P->normal[3 * n + i] = e[9 + i];
      P->R[3 * n + i] = e[12 + i];
      P->U[3 * n + i] = e[15 + i];
      P->force[3 * n + i] = e[18 + i];
      P->vrel[3 * n + i] = e[21 + i];
    }
    P->gap[n] = e[24];
    P->lambda[n] = e[25];
    P->measure[n] = e[26];
    P->cand[n] = (int)a;
    P->pair[n] = (int)e[27];
    P->node[n] = (int)e[28];
    P->status[n] = (int)e[29];
    P->body[2 * n] = (int)e[30];
    P->body[2 * n + 1] = (int)e[31];
    P->n++;
  }
  P->src.cursor = a;
  return MO_OK;
}

/* mo_contact_points over the distributed set: every rank's candidates to rank 0, in the order of
   one process's set (a collective; P empty on the other ranks). */
static int points_dist(const mo_scene *sc, const mo_contact *C, const mo_contact_driver *Dr, const mo_state *s,
                       int closed_only, mo_vtk_points *P, mo_ctx *ctx)
{
  const int n = C->nc, d = C->dim;
  double *mine = NULL;
  long total = 0, k, sel = 0;
  int st, failed, a;
  cand_values v;
  P->total = 0;
  P->fill = NULL;
  mo_vtk_points_rewind(P);
  frame_source(&P->src, sc, C, Dr, s, 0);
  failed = mo_vtk_points_reserve(P, MO_VTK_CHUNK, d, ctx) != MO_OK ||
           !(mine = mo_malloc(ctx, ((size_t)n * PTW + 1) * sizeof *mine));
  if (!failed) {
    /* chunk by chunk, each entry packed at its candidate's place */
    cand_values_get(sc, C, Dr, &v);
    P->total = n;
    do {
      P->first += P->n;
      P->n = 0;
      points_fill(P, ctx);
      for (k = 0; k < P->n; k++) {
        a = P->cand[k];
        point_pack(C, P, (int)k, a, cand_closed(&v, d, a), mine + (size_t)a * PTW);
      }
    } while (P->n > 0 && P->first + P->n < n);
  }
  P->total = 0;
  mo_vtk_points_rewind(P);
  st = gather_merge(&P->src, mine, failed ? 0 : n, PTW, failed, &total, ctx);
  mo_free(mine);
  if (st) return st;
  P->src.closed_only = closed_only;
  for (k = 0; k < total; k++) sel += !closed_only || P->src.rec[P->src.ord[k] + ORDW + 32] != 0;
  P->total = sel;
  P->fill = points_fill_rec;
  return MO_OK;
}

int mo_contact_points(const mo_scene *sc, const mo_contact *C, const mo_contact_driver *Dr, const mo_state *s,
                      int closed_only, mo_vtk_points *P, mo_ctx *ctx)
{
  long total;
  int st;
  P->total = 0;
  P->fill = NULL;
  mo_vtk_points_rewind(P);
  if (!C || !Dr) return MO_OK;
  if (mo_contact_distributed(C)) return points_dist(sc, C, Dr, s, closed_only, P, ctx);
  total = frame_source(&P->src, sc, C, Dr, s, closed_only);
  if ((st = mo_vtk_points_reserve(P, total < MO_VTK_CHUNK ? (int)total : MO_VTK_CHUNK, C->dim, ctx))) return st;
  P->total = total;
  P->fill = points_fill;
  return MO_OK;
}
