/* mesh.c: mesh storage, named sets, boundary facets, structured generators. */
#include "config.h"
#include <moreau/fe.h>
#include <moreau/mesh.h>
#include "mesh_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const mo_eltype_info eltypes[MO_EL_NTYPES] = {
  [MO_EL_BAR2] = {.name = "bar2", .dim = 1, .nen = 2, .nfacet = 2, .nfn = 1, .facet = {{0}, {1}},
                  .nvert = 2, .nfv = 1, .order = 1, .fkind = MO_FK_POINT, .centre = {0, 0, 0}},
  [MO_EL_T3] = {.name = "T3", .dim = 2, .nen = 3, .nfacet = 3, .nfn = 2, .facet = {{0, 1}, {1, 2}, {2, 0}},
                .nvert = 3, .nfv = 2, .order = 1, .fkind = MO_FK_LINE2, .centre = {1.0 / 3, 1.0 / 3, 0}},
  [MO_EL_Q4] = {.name = "Q4", .dim = 2, .nen = 4, .nfacet = 4, .nfn = 2, .facet = {{0, 1}, {1, 2}, {2, 3}, {3, 0}},
                .nvert = 4, .nfv = 2, .order = 1, .fkind = MO_FK_LINE2, .centre = {0, 0, 0}},
  [MO_EL_H8] = {.name = "H8", .dim = 3, .nen = 8, .nfacet = 6, .nfn = 4,
                .facet = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}},
                .nvert = 8, .nfv = 4, .order = 1, .fkind = MO_FK_QUAD4, .centre = {0, 0, 0}},
  /* faces (a, b, c) with (b - a) x (c - a) outward; T10's add the middles of ab, bc, ca */
  [MO_EL_T4] = {.name = "T4", .dim = 3, .nen = 4, .nfacet = 4, .nfn = 3,
                .facet = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}},
                .nvert = 4, .nfv = 3, .order = 1, .fkind = MO_FK_TRI3, .centre = {0.25, 0.25, 0.25}},
  [MO_EL_T10] = {.name = "T10", .dim = 3, .nen = 10, .nfacet = 4, .nfn = 6,
                 .facet = {{0, 2, 1, 6, 5, 4}, {0, 1, 3, 4, 8, 7}, {0, 3, 2, 7, 9, 6}, {1, 2, 3, 5, 9, 8}},
                 .nvert = 4, .nfv = 3, .order = 2, .fkind = MO_FK_TRI6, .centre = {0.25, 0.25, 0.25}},
  [MO_EL_T6] = {.name = "T6", .dim = 2, .nen = 6, .nfacet = 3, .nfn = 3, .facet = {{0, 1, 3}, {1, 2, 4}, {2, 0, 5}},
                .nvert = 3, .nfv = 2, .order = 2, .fkind = MO_FK_LINE3, .centre = {1.0 / 3, 1.0 / 3, 0}},
};

const mo_eltype_info *mo_eltype_get(mo_eltype t)
{
  return (unsigned)t < MO_EL_NTYPES ? &eltypes[t] : NULL;
}

void mo_mesh_free(mo_mesh *m)
{
  int i;
  if (!m) return;
  mo_free(m->x);
  mo_free(m->conn);
  for (i = 0; i < m->nnodeset; i++) {
    mo_free(m->nodeset[i].name);
    mo_free(m->nodeset[i].node);
  }
  for (i = 0; i < m->nfacetset; i++) {
    mo_free(m->facetset[i].name);
    mo_free(m->facetset[i].node);
    mo_free(m->facetset[i].elem);
    mo_free(m->facetset[i].lface);
  }
  mo_free(m->nodeset);
  mo_free(m->facetset);
  mo_free(m);
}

static int mesh_alloc(int dim, int nnode, mo_eltype type, int nelem, mo_mesh **out, mo_ctx *ctx)
{
  mo_mesh *m = mo_calloc(ctx, 1, sizeof *m);
  *out = NULL;
  if (!m) return MO_ENOMEM;
  m->dim = dim;
  m->nnode = nnode;
  m->type = type;
  m->nelem = nelem;
  m->nen = eltypes[type].nen;
  m->x = mo_calloc(ctx, (size_t)nnode * (size_t)dim, sizeof(double));
  m->conn = mo_calloc(ctx, (size_t)nelem * (size_t)m->nen, sizeof(int));
  if (!m->x || !m->conn) {
    mo_mesh_free(m);
    return MO_ENOMEM;
  }
  *out = m;
  return MO_OK;
}

const mo_nodeset *mo_mesh_find_nodeset(const mo_mesh *m, const char *name)
{
  int i;
  for (i = 0; i < m->nnodeset; i++)
    if (!strcmp(m->nodeset[i].name, name)) return &m->nodeset[i];
  return NULL;
}

const mo_facetset *mo_mesh_find_facetset(const mo_mesh *m, const char *name)
{
  int i;
  for (i = 0; i < m->nfacetset; i++)
    if (!strcmp(m->facetset[i].name, name)) return &m->facetset[i];
  return NULL;
}

static int cmp_int(const void *a, const void *b)
{
  int x = *(const int *)a, y = *(const int *)b;
  return (x > y) - (x < y);
}

int mo_mesh_add_nodeset(mo_mesh *m, const char *name, const int *ids, int n, mo_ctx *ctx)
{
  mo_nodeset *ns;
  int i, k;
  if (MO_INTERRUPTED(ctx)) return mo_error(ctx, MO_EINTERRUPT, "interrupted while building the mesh (set '%s')", name);
  if (mo_mesh_find_nodeset(m, name))
    return mo_error(ctx, MO_EINPUT, "node set '%s' is defined twice", name);
  for (i = 0; i < n; i++)
    if (ids[i] < 0 || ids[i] >= m->nnode)
      return mo_error(ctx, MO_EINPUT, "node set '%s': node %d does not exist (0..%d)", name,
                      ids[i], m->nnode - 1);
  ns = mo_realloc(ctx, m->nodeset, (size_t)(m->nnodeset + 1) * sizeof *ns);
  if (!ns) return MO_ENOMEM;
  m->nodeset = ns;
  ns = &m->nodeset[m->nnodeset];
  memset(ns, 0, sizeof *ns);
  ns->name = mo_strdup(ctx, name);
  ns->node = mo_malloc(ctx, (size_t)(n > 0 ? n : 1) * sizeof(int));
  if (!ns->name || !ns->node) {
    mo_free(ns->name);
    mo_free(ns->node);
    return MO_ENOMEM;
  }
  if (n > 0) memcpy(ns->node, ids, (size_t)n * sizeof(int)); /* ids may be NULL when n = 0 */
  qsort(ns->node, (size_t)n, sizeof(int), cmp_int);
  for (i = 0, k = 0; i < n; i++)
    if (k == 0 || ns->node[k - 1] != ns->node[i]) ns->node[k++] = ns->node[i];
  ns->n = k;
  m->nnodeset++;
  return MO_OK;
}

int mo_facet_cmp_key(const void *a, const void *b)
{
  const mo_facet *p = a, *q = b;
  int i;
  for (i = 0; i < 4; i++)
    if (p->key[i] != q->key[i]) return (p->key[i] > q->key[i]) - (p->key[i] < q->key[i]);
  return 0;
}

static int cmp_facet_sorted(const void *a, const void *b)
{
  const mo_facet *p = a, *q = b;
  int c = mo_facet_cmp_key(a, b);
  if (c) return c;
  if (p->elem != q->elem) return (p->elem > q->elem) - (p->elem < q->elem);
  return (p->lface > q->lface) - (p->lface < q->lface);
}

/* Sort the n <= 4 nodes of a facet key (insertion: qsort's call costs more than the sort). */
static void sort_key(int *k, int n)
{
  int i, j;
  for (i = 1; i < n; i++) {
    int v = k[i];
    for (j = i; j > 0 && k[j - 1] > v; j--) k[j] = k[j - 1];
    k[j] = v;
  }
}

/* Sorts the n facets of one bucket (they share key[0]) by cmp_facet_sorted: insertion for the
   few facets a node usually starts, qsort past that (a fan of many elements around one node). */
static void sort_bucket(mo_facet *F, size_t n)
{
  size_t i, j;
  if (n > 32) {
    qsort(F, n, sizeof *F, cmp_facet_sorted);
    return;
  }
  for (i = 1; i < n; i++) {
    mo_facet v = F[i];
    for (j = i; j > 0 && cmp_facet_sorted(&F[j - 1], &v) > 0; j--) F[j] = F[j - 1];
    F[j] = v;
  }
}

/* The facets are distributed by their smallest node (a counting sort: key[0] is a node number,
   the first field of the order), then each node's few facets sorted: the order of one qsort by
   cmp_facet_sorted, in O(facets) (4e6 elements: 3 s of qsort before), and an interrupt is
   honoured between buckets. */
int mo_mesh_all_facets(const mo_mesh *m, mo_facet **out, size_t *nout, mo_ctx *ctx)
{
  const mo_eltype_info *T = &eltypes[m->type];
  size_t nf = (size_t)m->nelem * (size_t)T->nfacet, i, *start = NULL;
  mo_facet *F, *G = NULL;
  int e, f, a, v;
  if (MO_INTERRUPTED(ctx)) return mo_error(ctx, MO_EINTERRUPT, "interrupted while building the mesh (its facets)");
  *out = NULL;
  *nout = 0;
  F = mo_malloc(ctx, (nf ? nf : 1) * sizeof *F);
  if (F) G = mo_malloc(ctx, (nf ? nf : 1) * sizeof *G);
  if (G) start = mo_calloc(ctx, (size_t)m->nnode + 1, sizeof *start);
  if (!start) {
    mo_free(F);
    mo_free(G);
    return MO_ENOMEM;
  }
  for (e = 0, i = 0; e < m->nelem; e++)
    for (f = 0; f < T->nfacet; f++, i++) {
      for (a = 0; a < 4; a++)
        G[i].key[a] = a < T->nfv ? m->conn[(size_t)e * (size_t)m->nen + (size_t)T->facet[f][a]]
                                 : -1;
      sort_key(G[i].key, T->nfv);
      G[i].elem = e;
      G[i].lface = f;
      start[G[i].key[0] + 1]++;
    }
  for (v = 0; v < m->nnode; v++) start[v + 1] += start[v];
  for (i = 0; i < nf; i++) F[start[G[i].key[0]]++] = G[i]; /* start[v] moves to bucket v's end */
  mo_free(G);
  for (v = 0; v < m->nnode; v++) {
    size_t b = v ? start[v - 1] : 0;
    if (!(v & 0xffff) && MO_INTERRUPTED(ctx)) {
      mo_free(start);
      mo_free(F);
      return mo_error(ctx, MO_EINTERRUPT, "interrupted while building the mesh (its facets)");
    }
    sort_bucket(F + b, start[v] - b);
  }
  mo_free(start);
  *out = F;
  *nout = nf;
  return MO_OK;
}

/* Boundary facets: element facets that no other element shares. */
static int boundary_facets(const mo_mesh *m, mo_facet **out, int *nout, mo_ctx *ctx)
{
  mo_facet *F;
  size_t nf, i, j, nb = 0;
  int st = mo_mesh_all_facets(m, &F, &nf, ctx);
  *out = NULL;
  *nout = 0;
  if (st) return st;
  for (i = 0; i < nf; i = j) {
    for (j = i + 1; j < nf && !mo_facet_cmp_key(&F[i], &F[j]); j++) {}
    if (j == i + 1) F[nb++] = F[i];
  }
  *out = F;
  *nout = (int)nb;
  return MO_OK;
}

/* 1 when the nodes fn (nfn of them, the facet's corners first) are those of local facet lf of
   element e, in any order. */
static int same_facet_nodes(const mo_mesh *m, int e, int lf, const int *fn, int nfn)
{
  const mo_eltype_info *T = &eltypes[m->type];
  int a, b;
  for (a = 0; a < nfn; a++) {
    int hit = 0;
    for (b = 0; b < nfn && !hit; b++) hit = m->conn[(size_t)e * (size_t)m->nen + (size_t)T->facet[lf][b]] == fn[a];
    if (!hit) return 0;
  }
  return 1;
}

int mo_mesh_locate_facets(const mo_mesh *m, const int *fnodes, int nf, int *elem, int *lface,
                          mo_ctx *ctx)
{
  const int nfn = eltypes[m->type].nfn, nfv = eltypes[m->type].nfv;
  mo_facet *F, q;
  size_t n;
  int f, a, st;
  for (f = 0; f < nf * nfn; f++)
    if (fnodes[f] < 0 || fnodes[f] >= m->nnode)
      return mo_error(ctx, MO_EINPUT, "facet %d refers to node %d, which does not exist (0..%d)",
                      f / nfn, fnodes[f], m->nnode - 1);
  if ((st = mo_mesh_all_facets(m, &F, &n, ctx))) return st;
  for (f = 0; f < nf; f++) {
    const mo_facet *hit;
    /* found by its corners; a quadratic facet's middle nodes must be the element's too */
    for (a = 0; a < 4; a++) q.key[a] = a < nfv ? fnodes[(size_t)f * (size_t)nfn + (size_t)a] : -1;
    sort_key(q.key, nfv);
    hit = bsearch(&q, F, n, sizeof *F, mo_facet_cmp_key);
    elem[f] = -1;
    lface[f] = -1;
    if (!hit) continue;
    if ((hit > F && !mo_facet_cmp_key(hit - 1, &q)) || (hit + 1 < F + n && !mo_facet_cmp_key(hit + 1, &q))) {
      elem[f] = -2; /* two elements share it: inside the mesh */
      continue;
    }
    if (!same_facet_nodes(m, hit->elem, hit->lface, fnodes + (size_t)f * (size_t)nfn, nfn)) continue;
    elem[f] = hit->elem;
    lface[f] = hit->lface;
  }
  mo_free(F);
  return MO_OK;
}

static int cmp_elem_lface(const void *a, const void *b)
{
  const int *p = a, *q = b;
  if (p[0] != q[0]) return (p[0] > q[0]) - (p[0] < q[0]);
  return (p[1] > q[1]) - (p[1] < q[1]);
}

int mo_mesh_add_facetset(mo_mesh *m, const char *name, const int *elem, const int *lface, int n,
                         mo_ctx *ctx)
{
  const mo_eltype_info *T = &eltypes[m->type];
  mo_facetset *fs;
  int *P, i, a, cnt = 0;
  if (MO_INTERRUPTED(ctx)) return mo_error(ctx, MO_EINTERRUPT, "interrupted while building the mesh (set '%s')", name);
  if (mo_mesh_find_facetset(m, name))
    return mo_error(ctx, MO_EINPUT, "facet set '%s' is defined twice", name);
  for (i = 0; i < n; i++)
    if (elem[i] < 0 || elem[i] >= m->nelem || lface[i] < 0 || lface[i] >= T->nfacet)
      return mo_error(ctx, MO_EINPUT, "facet set '%s': facet %d of element %d does not exist",
                      name, lface[i], elem[i]);
  /* a reproducible order: by element, then local facet; each facet once */
  P = mo_malloc(ctx, (size_t)(n ? n : 1) * 2 * sizeof(int));
  if (!P) return MO_ENOMEM;
  for (i = 0; i < n; i++) {
    P[2 * i] = elem[i];
    P[2 * i + 1] = lface[i];
  }
  qsort(P, (size_t)n, 2 * sizeof(int), cmp_elem_lface);
  for (i = 0; i < n; i++)
    if (cnt == 0 || cmp_elem_lface(&P[2 * (cnt - 1)], &P[2 * i])) {
      P[2 * cnt] = P[2 * i];
      P[2 * cnt + 1] = P[2 * i + 1];
      cnt++;
    }
  fs = mo_realloc(ctx, m->facetset, (size_t)(m->nfacetset + 1) * sizeof *fs);
  if (!fs) {
    mo_free(P);
    return MO_ENOMEM;
  }
  m->facetset = fs; /* realloc freed the old block: keep the new one at once */
  fs = &m->facetset[m->nfacetset];
  memset(fs, 0, sizeof *fs);
  fs->name = mo_strdup(ctx, name);
  fs->nfn = T->nfn;
  fs->kind = T->fkind;
  fs->n = cnt;
  fs->node = mo_malloc(ctx, (size_t)(cnt ? cnt : 1) * (size_t)T->nfn * sizeof(int));
  fs->elem = mo_malloc(ctx, (size_t)(cnt ? cnt : 1) * sizeof(int));
  fs->lface = mo_malloc(ctx, (size_t)(cnt ? cnt : 1) * sizeof(int));
  if (!fs->name || !fs->node || !fs->elem || !fs->lface) {
    mo_free(fs->name); mo_free(fs->node); mo_free(fs->elem); mo_free(fs->lface);
    mo_free(P);
    return MO_ENOMEM;
  }
  for (i = 0; i < cnt; i++) {
    fs->elem[i] = P[2 * i];
    fs->lface[i] = P[2 * i + 1];
    for (a = 0; a < T->nfn; a++)
      fs->node[i * T->nfn + a] =
          m->conn[(size_t)P[2 * i] * (size_t)m->nen + (size_t)T->facet[P[2 * i + 1]][a]];
  }
  m->nfacetset++;
  mo_free(P);
  return MO_OK;
}

int mo_mesh_add_facetset_from_nodes(mo_mesh *m, const char *name, const int *nodes, int n,
                                    mo_ctx *ctx)
{
  const mo_eltype_info *T = &eltypes[m->type];
  mo_facet *F = NULL;
  unsigned char *in = NULL;
  int *el = NULL, *lf = NULL;
  int nb, i, a, cnt = 0, st;
  if (mo_mesh_find_facetset(m, name))
    return mo_error(ctx, MO_EINPUT, "facet set '%s' is defined twice", name);
  if ((st = boundary_facets(m, &F, &nb, ctx))) return st;
  in = mo_calloc(ctx, (size_t)m->nnode, 1);
  el = mo_malloc(ctx, (size_t)(nb ? nb : 1) * sizeof(int));
  lf = mo_malloc(ctx, (size_t)(nb ? nb : 1) * sizeof(int));
  if (!in || !el || !lf) {
    st = MO_ENOMEM;
    goto done;
  }
  for (i = 0; i < n; i++) in[nodes[i]] = 1;
  for (i = 0; i < nb; i++) {
    int all = 1;
    for (a = 0; a < T->nfv; a++) all &= in[F[i].key[a]]; /* its corners */
    if (all) {
      el[cnt] = F[i].elem;
      lf[cnt++] = F[i].lface;
    }
  }
  st = mo_mesh_add_facetset(m, name, el, lf, cnt, ctx);
done:
  mo_free(F);
  mo_free(in);
  mo_free(el);
  mo_free(lf);
  return st;
}

int mo_mesh_add_box_set(mo_mesh *m, const char *name, const double *lo, const double *hi,
                        double tol, mo_ctx *ctx)
{
  int *ids = mo_malloc(ctx, (size_t)m->nnode * sizeof(int));
  int i, d, n = 0, st;
  if (!ids) return MO_ENOMEM;
  for (i = 0; i < m->nnode; i++) {
    int inside = 1;
    for (d = 0; d < m->dim; d++) {
      double c = m->x[(size_t)i * (size_t)m->dim + (size_t)d];
      if (c < lo[d] - tol || c > hi[d] + tol) inside = 0;
    }
    if (inside) ids[n++] = i;
  }
  if (n == 0) {
    mo_free(ids);
    return mo_error(ctx, MO_EINPUT, "set '%s': the box selects no node", name);
  }
  st = mo_mesh_add_nodeset(m, name, ids, n, ctx);
  if (!st) st = mo_mesh_add_facetset_from_nodes(m, name, ids, n, ctx);
  mo_free(ids);
  return st;
}

void mo_mesh_set_names(const mo_mesh *m, int facets, char *buf, size_t n)
{
  size_t k = 0;
  int i, count = facets ? m->nfacetset : m->nnodeset;
  if (!n) return;
  buf[0] = '\0';
  for (i = 0; i < count; i++) {
    const char *name = facets ? m->facetset[i].name : m->nodeset[i].name;
    if (k + strlen(name) + 8 > n) {
      snprintf(buf + k, n - k, "%s...", i ? ", " : "");
      return;
    }
    k += (size_t)snprintf(buf + k, n - k, "%s%s", i ? ", " : "", name);
  }
  if (!count) snprintf(buf, n, "none");
}

int mo_mesh_nodeset_resolve(const mo_mesh *m, const char *expr, int **ids, int *n, mo_ctx *ctx)
{
  char part[128];
  const char *p = expr;
  int *cur = NULL, ncur = 0, first = 1;
  *ids = NULL;
  *n = 0;
  while (1) {
    const char *amp = strchr(p, '&');
    size_t len = amp ? (size_t)(amp - p) : strlen(p);
    const mo_nodeset *ns;
    while (len && p[0] == ' ') { p++; len--; }
    while (len && p[len - 1] == ' ') len--;
    if (len == 0 || len >= sizeof part) {
      mo_free(cur);
      return mo_error(ctx, MO_EINPUT, "malformed set expression '%s'", expr);
    }
    memcpy(part, p, len);
    part[len] = '\0';
    ns = mo_mesh_find_nodeset(m, part);
    if (!ns) {
      char avail[512];
      mo_mesh_set_names(m, 0, avail, sizeof avail);
      mo_free(cur);
      return mo_error(ctx, MO_EINPUT, "no node set '%s' in this mesh (sets: %s)", part, avail);
    }
    if (first) {
      cur = mo_malloc(ctx, (size_t)(ns->n ? ns->n : 1) * sizeof(int));
      if (!cur) return MO_ENOMEM;
      memcpy(cur, ns->node, (size_t)ns->n * sizeof(int));
      ncur = ns->n;
      first = 0;
    } else { /* both sorted: intersect in place */
      int i = 0, j = 0, k = 0;
      while (i < ncur && j < ns->n) {
        if (cur[i] < ns->node[j]) i++;
        else if (cur[i] > ns->node[j]) j++;
        else { cur[k++] = cur[i]; i++; j++; }
      }
      ncur = k;
    }
    if (!amp) break;
    p = amp + 1;
  }
  *ids = cur;
  *n = ncur;
  return MO_OK;
}

int mo_mesh_nearest_node(const mo_mesh *m, const double *p, double *dist)
{
  int i, d, best = -1;
  double bd = HUGE_VAL;
  for (i = 0; i < m->nnode; i++) {
    double s = 0;
    for (d = 0; d < m->dim; d++) {
      double c = m->x[(size_t)i * (size_t)m->dim + (size_t)d] - p[d];
      s += c * c;
    }
    if (s < bd) { bd = s; best = i; }
  }
  if (dist) *dist = sqrt(bd);
  return best;
}

void mo_mesh_edge_range(const mo_mesh *m, double *hmin, double *hmax)
{
  const mo_eltype_info *T = &eltypes[m->type];
  double lo = HUGE_VAL, hi = 0;
  int e, f, a, d;
  /* edges: the element itself in 1D, the cyclic edges of every facet's corners otherwise (a
     quadratic element's edges run corner to corner) */
  for (e = 0; e < m->nelem; e++) {
    const int *c = &m->conn[(size_t)e * (size_t)m->nen];
    int nf = T->dim == 1 ? 1 : T->nfacet, nfn = T->dim == 1 ? 2 : T->nfv;
    for (f = 0; f < nf; f++)
      for (a = 0; a < nfn; a++) {
        int na = T->dim == 1 ? a : T->facet[f][a];
        int nb = T->dim == 1 ? 1 - a : T->facet[f][(a + 1) % nfn];
        const double *xa = &m->x[(size_t)c[na] * (size_t)m->dim];
        const double *xb = &m->x[(size_t)c[nb] * (size_t)m->dim];
        double s = 0;
        for (d = 0; d < m->dim; d++) s += (xa[d] - xb[d]) * (xa[d] - xb[d]);
        s = sqrt(s);
        if (s < lo) lo = s;
        if (s > hi) hi = s;
      }
  }
  if (hmin) *hmin = lo;
  if (hmax) *hmax = hi;
}

/* Signed measure indicator of element e: Jacobian determinant at corners (min over them). */
static double min_corner_jacobian(const mo_mesh *m, int e)
{
  const int *c = &m->conn[(size_t)e * (size_t)m->nen];
  const double *X = m->x;
  int D = m->dim;
  switch (m->type) {
  case MO_EL_BAR2: return X[c[1]] - X[c[0]];
  case MO_EL_T3: {
    const double *a = &X[c[0] * D], *b = &X[c[1] * D], *d = &X[c[2] * D];
    return (b[0] - a[0]) * (d[1] - a[1]) - (b[1] - a[1]) * (d[0] - a[0]);
  }
  case MO_EL_Q4: {
    double jmin = HUGE_VAL;
    int k;
    for (k = 0; k < 4; k++) {
      const double *p = &X[c[k] * D], *n = &X[c[(k + 1) % 4] * D], *q = &X[c[(k + 3) % 4] * D];
      double j = (n[0] - p[0]) * (q[1] - p[1]) - (n[1] - p[1]) * (q[0] - p[0]);
      if (j < jmin) jmin = j;
    }
    return jmin;
  }
  case MO_EL_H8: {
    /* corner k: edges to its three neighbours along the reference axes */
    static const int nb[8][3] = {{1, 3, 4}, {2, 0, 5}, {3, 1, 6}, {0, 2, 7},
                                 {7, 5, 0}, {4, 6, 1}, {5, 7, 2}, {6, 4, 3}};
    double jmin = HUGE_VAL;
    int k, d;
    for (k = 0; k < 8; k++) {
      double a[3], b[3], g[3], j;
      const double *p = &X[c[k] * 3];
      for (d = 0; d < 3; d++) {
        a[d] = X[c[nb[k][0]] * 3 + d] - p[d];
        b[d] = X[c[nb[k][1]] * 3 + d] - p[d];
        g[d] = X[c[nb[k][2]] * 3 + d] - p[d];
      }
      j = a[0] * (b[1] * g[2] - b[2] * g[1]) - a[1] * (b[0] * g[2] - b[2] * g[0]) +
          a[2] * (b[0] * g[1] - b[1] * g[0]);
      if (j < jmin) jmin = j;
    }
    return jmin;
  }
  case MO_EL_T4: {
    const double *p = &X[c[0] * 3];
    double a[3], b[3], g[3];
    int d;
    for (d = 0; d < 3; d++) {
      a[d] = X[c[1] * 3 + d] - p[d];
      b[d] = X[c[2] * 3 + d] - p[d];
      g[d] = X[c[3] * 3 + d] - p[d];
    }
    return a[0] * (b[1] * g[2] - b[2] * g[1]) - a[1] * (b[0] * g[2] - b[2] * g[0]) +
           a[2] * (b[0] * g[1] - b[1] * g[0]);
  }
  default: return -1;
  }
}

/* The reference coordinates of the nodes of the quadratic types (corners, then middles). */
static const double t6_nodes[6][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.5, 0, 0}, {0.5, 0.5, 0}, {0, 0.5, 0}};
static const double t10_nodes[10][3] = {{0, 0, 0},     {1, 0, 0},     {0, 1, 0},   {0, 0, 1},     {0.5, 0, 0},
                                        {0.5, 0.5, 0}, {0, 0.5, 0},   {0, 0, 0.5}, {0.5, 0, 0.5}, {0, 0.5, 0.5}};

double mo_mesh_elem_min_jacobian(const mo_mesh *m, int e, int *at)
{
  const double(*ref)[3] = m->type == MO_EL_T6 ? t6_nodes : t10_nodes;
  double N[MO_NEN_MAX], dNx[3 * MO_NEN_MAX], xq[3], jmin = HUGE_VAL;
  int k;
  if (at) *at = -1;
  if (eltypes[m->type].order == 1) return min_corner_jacobian(m, e);
  /* a curved element: det J of its map at its nodes and its centre (a middle node placed too
     far from its edge's middle turns the map over near a corner first) */
  for (k = 0; k <= m->nen; k++) {
    double j = mo_elem_geometry(m, e, k < m->nen ? ref[k] : eltypes[m->type].centre, N, dNx, xq);
    if (!(j >= jmin)) {
      jmin = j;
      if (at) *at = k < m->nen ? k : -1;
    }
  }
  return jmin;
}

int mo_mesh_check(const mo_mesh *m, mo_ctx *ctx)
{
  int e, i;
  for (i = 0; i < m->nnode * m->dim; i++)
    if (!isfinite(m->x[i]))
      return mo_error(ctx, MO_EINPUT, "node %d has a non-finite coordinate", i / m->dim);
  for (i = 0; i < m->nelem * m->nen; i++)
    if (m->conn[i] < 0 || m->conn[i] >= m->nnode)
      return mo_error(ctx, MO_EINPUT, "element %d refers to node %d, which does not exist",
                      i / m->nen, m->conn[i]);
  for (e = 0; e < m->nelem; e++) {
    double j = mo_mesh_elem_min_jacobian(m, e, NULL);
    if (!(e & 0xffff) && MO_INTERRUPTED(ctx))
      return mo_error(ctx, MO_EINTERRUPT, "interrupted while checking the mesh (element %d of %d)", e, m->nelem);
    if (!isfinite(j)) {
      double xmax = 0;
      for (i = 0; i < m->nnode * m->dim; i++) xmax = fmax(xmax, fabs(m->x[i]));
      return mo_error(ctx, MO_EINPUT, "element %d (%s): its Jacobian overflows (%g), the coordinates reach %g: "
                      "check the mesh's scale and size (lengths in metres)", e, eltypes[m->type].name, j, xmax);
    }
    if (!(j > 0))
      return mo_error(ctx, MO_EINPUT,
                      "element %d (%s) is %s (corner Jacobian %g): check node order and "
                      "coordinates", e, eltypes[m->type].name, j < 0 ? "inverted" : "degenerate",
                      j);
  }
  return MO_OK;
}

/* Sets of the bounding box faces, with their aliases. */
static int add_bbox_sets(mo_mesh *m, double tol, mo_ctx *ctx)
{
  static const char *names[3][2] = {{"xmin", "xmax"}, {"ymin", "ymax"}, {"zmin", "zmax"}};
  static const char *alias2[2][2] = {{"left", "right"}, {"bottom", "top"}};
  double lo[3], hi[3], blo[3], bhi[3];
  int i, d, s, st;
  for (d = 0; d < m->dim; d++) { lo[d] = HUGE_VAL; hi[d] = -HUGE_VAL; }
  for (i = 0; i < m->nnode; i++)
    for (d = 0; d < m->dim; d++) {
      double c = m->x[(size_t)i * (size_t)m->dim + (size_t)d];
      if (c < lo[d]) lo[d] = c;
      if (c > hi[d]) hi[d] = c;
    }
  for (d = 0; d < m->dim; d++)
    for (s = 0; s < 2; s++) {
      int k;
      for (k = 0; k < m->dim; k++) { blo[k] = lo[k]; bhi[k] = hi[k]; }
      if (s == 0) bhi[d] = lo[d];
      else blo[d] = hi[d];
      if ((st = mo_mesh_add_box_set(m, names[d][s], blo, bhi, tol, ctx))) return st;
      if (d < 2 && (m->dim <= 2 || d == 0)) {
        if (m->dim == 1 && d == 1) continue;
        if ((st = mo_mesh_add_box_set(m, alias2[d][s], blo, bhi, tol, ctx))) return st;
      }
    }
  {
    int *all = mo_malloc(ctx, (size_t)m->nnode * sizeof(int));
    if (!all) return MO_ENOMEM;
    for (i = 0; i < m->nnode; i++) all[i] = i;
    st = mo_mesh_add_nodeset(m, "all", all, m->nnode, ctx);
    mo_free(all);
  }
  return st;
}

/* An edge of an element between corners a < b, for numbering the middle nodes. */
typedef struct {
  int a, b, elem, k;
} mesh_edge;

static int cmp_edge(const void *p, const void *q)
{
  const mesh_edge *x = p, *y = q;
  if (x->a != y->a) return (x->a > y->a) - (x->a < y->a);
  if (x->b != y->b) return (x->b > y->b) - (x->b < y->b);
  if (x->elem != y->elem) return (x->elem > y->elem) - (x->elem < y->elem);
  return (x->k > y->k) - (x->k < y->k);
}

/* The quadratic mesh of a linear one (T3 -> T6, T4 -> T10): a node at the middle of every edge,
   numbered after the corners in the order of the edges' sorted corner pairs. The sets are built
   afterwards (from coordinates). */
static int elevate(mo_mesh *m, mo_ctx *ctx)
{
  static const int t3e[3][2] = {{0, 1}, {1, 2}, {2, 0}};
  static const int t4e[6][2] = {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}};
  const int(*E)[2] = m->type == MO_EL_T3 ? t3e : t4e;
  mo_eltype q = m->type == MO_EL_T3 ? MO_EL_T6 : MO_EL_T10;
  int ne = m->type == MO_EL_T3 ? 3 : 6, nq = eltypes[q].nen, D = m->dim, e, k, d, nnew = 0;
  size_t n = (size_t)m->nelem * (size_t)ne, i;
  mesh_edge *L = mo_malloc(ctx, (n ? n : 1) * sizeof *L);
  int *conn = mo_malloc(ctx, ((size_t)m->nelem * (size_t)nq + 1) * sizeof *conn);
  double *x = NULL;
  if (!L || !conn) { mo_free(L); mo_free(conn); return MO_ENOMEM; }
  for (e = 0, i = 0; e < m->nelem; e++)
    for (k = 0; k < ne; k++, i++) {
      int p = m->conn[(size_t)e * (size_t)m->nen + (size_t)E[k][0]], r = m->conn[(size_t)e * (size_t)m->nen + (size_t)E[k][1]];
      L[i].a = p < r ? p : r;
      L[i].b = p < r ? r : p;
      L[i].elem = e;
      L[i].k = k;
    }
  qsort(L, n, sizeof *L, cmp_edge);
  for (i = 0; i < n; i++) nnew += i == 0 || L[i].a != L[i - 1].a || L[i].b != L[i - 1].b;
  if (!(x = mo_malloc(ctx, ((size_t)(m->nnode + nnew) * (size_t)D + 1) * sizeof *x))) {
    mo_free(L);
    mo_free(conn);
    return MO_ENOMEM;
  }
  memcpy(x, m->x, (size_t)m->nnode * (size_t)D * sizeof *x);
  for (e = 0; e < m->nelem; e++)
    for (k = 0; k < m->nen; k++) conn[(size_t)e * (size_t)nq + (size_t)k] = m->conn[(size_t)e * (size_t)m->nen + (size_t)k];
  for (i = 0, k = m->nnode - 1; i < n; i++) {
    if (i == 0 || L[i].a != L[i - 1].a || L[i].b != L[i - 1].b) {
      k++;
      for (d = 0; d < D; d++) x[(size_t)k * (size_t)D + (size_t)d] = 0.5 * (m->x[(size_t)L[i].a * (size_t)D + (size_t)d] + m->x[(size_t)L[i].b * (size_t)D + (size_t)d]);
    }
    conn[(size_t)L[i].elem * (size_t)nq + (size_t)(m->nen + L[i].k)] = k;
  }
  mo_free(L);
  mo_free(m->x);
  mo_free(m->conn);
  m->x = x;
  m->conn = conn;
  m->nnode += nnew;
  m->type = q;
  m->nen = nq;
  return MO_OK;
}

int mo_mesh_bar(double x0, double length, int nel, mo_mesh **out, mo_ctx *ctx)
{
  mo_mesh *m;
  int i, st;
  if (nel < 1) return mo_error(ctx, MO_EINPUT, "a bar needs at least one element");
  if (!(length > 0)) return mo_error(ctx, MO_EINPUT, "a bar needs a positive length");
  if ((st = mesh_alloc(1, nel + 1, MO_EL_BAR2, nel, &m, ctx))) return st;
  for (i = 0; i <= nel; i++) m->x[i] = x0 + length * (double)i / (double)nel;
  m->x[nel] = x0 + length;
  for (i = 0; i < nel; i++) {
    m->conn[2 * i] = i;
    m->conn[2 * i + 1] = i + 1;
  }
  if ((st = add_bbox_sets(m, 1e-9 * length, ctx))) {
    mo_mesh_free(m);
    return st;
  }
  *out = m;
  return MO_OK;
}

int mo_mesh_rectangle(const double origin[2], const double size[2], const int nel[2],
                      mo_eltype type, mo_diag diag, mo_mesh **out, mo_ctx *ctx)
{
  mo_mesh *m;
  int nx = nel[0], ny = nel[1], i, j, st, e = 0;
  int ne;
  if (nx < 1 || ny < 1) return mo_error(ctx, MO_EINPUT, "a rectangle needs at least 1 x 1 cells");
  if (!(size[0] > 0 && size[1] > 0))
    return mo_error(ctx, MO_EINPUT, "a rectangle needs positive sizes");
  if (type != MO_EL_Q4 && type != MO_EL_T3 && type != MO_EL_T6)
    return mo_error(ctx, MO_EINPUT, "a rectangle is meshed with Q4, T3 or T6 elements");
  ne = nx * ny * (type == MO_EL_Q4 ? 1 : 2);
  if ((st = mesh_alloc(2, (nx + 1) * (ny + 1), type == MO_EL_Q4 ? MO_EL_Q4 : MO_EL_T3, ne, &m, ctx))) return st;
  for (j = 0; j <= ny; j++)
    for (i = 0; i <= nx; i++) {
      int n = j * (nx + 1) + i;
      m->x[2 * n] = i == nx ? origin[0] + size[0] : origin[0] + size[0] * (double)i / (double)nx;
      m->x[2 * n + 1] = j == ny ? origin[1] + size[1] : origin[1] + size[1] * (double)j / (double)ny;
    }
  for (j = 0; j < ny; j++)
    for (i = 0; i < nx; i++) {
      int a = j * (nx + 1) + i, b = a + 1, c = b + nx + 1, d = a + nx + 1;
      if (m->type == MO_EL_Q4) {
        int *q = &m->conn[4 * e++];
        q[0] = a; q[1] = b; q[2] = c; q[3] = d;
      } else {
        int right;
        int *t1 = &m->conn[3 * e++], *t2 = &m->conn[3 * e++];
        switch (diag) {
        case MO_DIAG_LEFT: right = 0; break;
        case MO_DIAG_ALTERNATE: right = (i + j) % 2 == 0; break;
        case MO_DIAG_UNION_JACK: right = (i + j) % 2 == 1; break;
        default: right = 1; break;
        }
        if (right) { /* (a,b,d) + (b,c,d) */
          t1[0] = a; t1[1] = b; t1[2] = d;
          t2[0] = b; t2[1] = c; t2[2] = d;
        } else {     /* (a,b,c) + (a,c,d) */
          t1[0] = a; t1[1] = b; t1[2] = c;
          t2[0] = a; t2[1] = c; t2[2] = d;
        }
      }
    }
  if ((type == MO_EL_T6 && (st = elevate(m, ctx))) ||
      (st = add_bbox_sets(m, 1e-9 * (size[0] < size[1] ? size[0] : size[1]), ctx))) {
    mo_mesh_free(m);
    return st;
  }
  *out = m;
  return MO_OK;
}

int mo_mesh_box(const double origin[3], const double size[3], const int nel[3], mo_mesh **out,
                mo_ctx *ctx)
{
  return mo_mesh_box_elements(origin, size, nel, MO_EL_H8, out, ctx);
}

/* The 6 tetrahedra of Kuhn's subdivision of cell h (its 8 corners in H8 order) into t: one per
   order in which the path from corner 0 to corner 6 steps along x, y and z, each turned
   right-handed. */
static void kuhn(const mo_mesh *m, const int *h, int *t)
{
  static const int perm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  /* H8 corners as bit sets of the unit steps: 0 = 000, 1 = x, 2 = xy, 3 = y, 4 = z, 5 = xz, 6 = xyz, 7 = yz */
  static const int bits2h8[8] = {0, 1, 3, 2, 4, 5, 7, 6};
  int k;
  for (k = 0; k < 6; k++) {
    int b = 0, j, *v = t + 4 * k, d;
    double a[3][3], det;
    v[0] = h[0];
    for (j = 0; j < 3; j++) {
      b |= 1 << perm[k][j];
      v[j + 1] = h[bits2h8[b]];
    }
    for (j = 0; j < 3; j++)
      for (d = 0; d < 3; d++) a[j][d] = m->x[(size_t)v[j + 1] * 3 + (size_t)d] - m->x[(size_t)v[0] * 3 + (size_t)d];
    det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
          a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
    if (det < 0) {
      int s = v[1];
      v[1] = v[2];
      v[2] = s;
    }
  }
}

int mo_mesh_box_elements(const double origin[3], const double size[3], const int nel[3], mo_eltype type,
                         mo_mesh **out, mo_ctx *ctx)
{
  mo_mesh *m;
  int nx = nel[0], ny = nel[1], nz = nel[2], i, j, k, st, e = 0, tet = type == MO_EL_T4 || type == MO_EL_T10;
  double smin;
  if (nx < 1 || ny < 1 || nz < 1) return mo_error(ctx, MO_EINPUT, "a box needs at least 1 x 1 x 1 cells");
  if (!(size[0] > 0 && size[1] > 0 && size[2] > 0))
    return mo_error(ctx, MO_EINPUT, "a box needs positive sizes");
  if (type != MO_EL_H8 && !tet) return mo_error(ctx, MO_EINPUT, "a box is meshed with H8, T4 or T10 elements");
  if ((st = mesh_alloc(3, (nx + 1) * (ny + 1) * (nz + 1), tet ? MO_EL_T4 : MO_EL_H8, nx * ny * nz * (tet ? 6 : 1), &m,
                       ctx)))
    return st;
  for (k = 0; k <= nz; k++)
    for (j = 0; j <= ny; j++)
      for (i = 0; i <= nx; i++) {
        int n = (k * (ny + 1) + j) * (nx + 1) + i;
        m->x[3 * n] = i == nx ? origin[0] + size[0] : origin[0] + size[0] * (double)i / (double)nx;
        m->x[3 * n + 1] = j == ny ? origin[1] + size[1] : origin[1] + size[1] * (double)j / (double)ny;
        m->x[3 * n + 2] = k == nz ? origin[2] + size[2] : origin[2] + size[2] * (double)k / (double)nz;
      }
  for (k = 0; k < nz; k++)
    for (j = 0; j < ny; j++)
      for (i = 0; i < nx; i++) {
        int a = (k * (ny + 1) + j) * (nx + 1) + i;
        int up = (ny + 1) * (nx + 1);
        int h[8];
        h[0] = a; h[1] = a + 1; h[2] = a + 1 + nx + 1; h[3] = a + nx + 1;
        h[4] = a + up; h[5] = a + 1 + up; h[6] = a + 1 + nx + 1 + up; h[7] = a + nx + 1 + up;
        if (tet) {
          kuhn(m, h, &m->conn[(size_t)4 * (size_t)e]);
          e += 6;
        } else
          memcpy(&m->conn[(size_t)8 * (size_t)e++], h, sizeof h);
      }
  smin = size[0];
  if (size[1] < smin) smin = size[1];
  if (size[2] < smin) smin = size[2];
  if ((type == MO_EL_T10 && (st = elevate(m, ctx))) || (st = add_bbox_sets(m, 1e-9 * smin, ctx))) {
    mo_mesh_free(m);
    return st;
  }
  *out = m;
  return MO_OK;
}

int mo_mesh_disk(const double centre[2], double radius, int n, int nr, mo_mesh **out,
                 mo_ctx *ctx)
{
  mo_mesh *m;
  int ncore = (n + 1) * (n + 1), nper = 4 * n, i, j, k, p, st, e = 0;
  int *ring0 = NULL;
  double s = 0.5 * radius;
  if (n < 2 || n % 2 || nr < 1)
    return mo_error(ctx, MO_EINPUT, "a disk needs an even core division n >= 2 and nr >= 1 rings");
  if (!(radius > 0)) return mo_error(ctx, MO_EINPUT, "a disk needs a positive radius");
  if ((st = mesh_alloc(2, ncore + nr * nper, MO_EL_Q4, n * n + nr * nper, &m, ctx))) return st;
  ring0 = mo_malloc(ctx, (size_t)nper * sizeof(int));
  if (!ring0) { mo_mesh_free(m); return MO_ENOMEM; }
  for (j = 0; j <= n; j++)
    for (i = 0; i <= n; i++) {
      int q = j * (n + 1) + i;
      m->x[2 * q] = centre[0] - s + 2 * s * (double)i / (double)n;
      m->x[2 * q + 1] = centre[1] - s + 2 * s * (double)j / (double)n;
    }
  for (j = 0; j < n; j++)
    for (i = 0; i < n; i++) {
      int a = j * (n + 1) + i;
      int *q = &m->conn[4 * e++];
      q[0] = a; q[1] = a + 1; q[2] = a + n + 2; q[3] = a + n + 1;
    }
  /* perimeter of the core, counter-clockwise from corner (+s,-s) */
  for (p = 0; p < nper; p++) {
    int side = p / n, r = p % n;
    switch (side) {
    case 0: ring0[p] = r * (n + 1) + n; break;             /* x = +s, going up */
    case 1: ring0[p] = n * (n + 1) + (n - r); break;       /* y = +s, going left */
    case 2: ring0[p] = (n - r) * (n + 1); break;           /* x = -s, going down */
    default: ring0[p] = r; break;                          /* y = -s, going right */
    }
  }
  for (k = 1; k <= nr; k++) {
    double f = (double)k / (double)nr;
    for (p = 0; p < nper; p++) {
      int q = ncore + (k - 1) * nper + p;
      double th = -M_PI / 4 + (M_PI / 2) * (double)p / (double)n;
      const double *sq = &m->x[2 * ring0[p]];
      m->x[2 * q] = (1 - f) * sq[0] + f * (centre[0] + radius * cos(th));
      m->x[2 * q + 1] = (1 - f) * sq[1] + f * (centre[1] + radius * sin(th));
    }
    for (p = 0; p < nper; p++) {
      int in0 = k == 1 ? ring0[p] : ncore + (k - 2) * nper + p;
      int in1 = k == 1 ? ring0[(p + 1) % nper] : ncore + (k - 2) * nper + (p + 1) % nper;
      int out0 = ncore + (k - 1) * nper + p, out1 = ncore + (k - 1) * nper + (p + 1) % nper;
      int *q = &m->conn[4 * e++];
      q[0] = in0; q[1] = out0; q[2] = out1; q[3] = in1;
    }
  }
  {
    int *bd = mo_malloc(ctx, (size_t)nper * sizeof(int));
    int *all = mo_malloc(ctx, (size_t)m->nnode * sizeof(int));
    static const char *pts[4] = {"right_point", "top_point", "left_point", "bottom_point"};
    if (!bd || !all) st = MO_ENOMEM;
    for (p = 0; !st && p < nper; p++) bd[p] = ncore + (nr - 1) * nper + p;
    if (!st) st = mo_mesh_add_nodeset(m, "boundary", bd, nper, ctx);
    if (!st) st = mo_mesh_add_facetset_from_nodes(m, "boundary", bd, nper, ctx);
    for (k = 0; !st && k < 4; k++) {
      int id = ncore + (nr - 1) * nper + (n / 2 + k * n) % nper;
      st = mo_mesh_add_nodeset(m, pts[k], &id, 1, ctx);
    }
    for (i = 0; !st && i < m->nnode; i++) all[i] = i;
    if (!st) st = mo_mesh_add_nodeset(m, "all", all, m->nnode, ctx);
    mo_free(bd);
    mo_free(all);
  }
  mo_free(ring0);
  if (st) {
    mo_mesh_free(m);
    return st;
  }
  *out = m;
  return MO_OK;
}
