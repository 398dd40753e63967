/* test_gmsh.c: Gmsh MSH files (tests/meshes/, made by Gmsh 4.8.4 from the .geo files beside
   them): counts, sets, areas and volumes against closed forms, spectra against the same meshes
   from the generators, patch tests, tetrahedra and second-order elements (T4, T10, T6), binary
   MSH 4.1 read as its ASCII twin, hostile inputs in text and binary, and a contact scene on a Gmsh
   mesh. */
#include "config.h"
#include <moreau/moreau.h>
#include "testlib.h"

#include <stdint.h>

/* LAPACK: generalized symmetric-definite eigenproblem and SPD solve */
extern void dsygv_(const int *itype, const char *jobz, const char *uplo, const int *n, double *a,
                   const int *lda, double *b, const int *ldb, double *w, double *work,
                   const int *lwork, int *info);
extern void dposv_(const char *uplo, const int *n, const int *nrhs, double *a, const int *lda,
                   double *b, const int *ldb, int *info);

static void src_path(char *buf, size_t n, const char *rel)
{
  snprintf(buf, n, "%s/%s", tl_srcdir(), rel);
}

static int read_mesh(const char *rel, const mo_gmsh_options *o, mo_mesh **m, mo_gmsh_report *r,
                     mo_ctx *ctx)
{
  char p[4096];
  src_path(p, sizeof p, rel);
  return mo_mesh_read_gmsh(p, o, m, r, ctx);
}

static char *slurp(const char *rel, size_t *len)
{
  char p[4096], *buf;
  FILE *f;
  long n;
  src_path(p, sizeof p, rel);
  if (!(f = fopen(p, "rb"))) return NULL;
  fseek(f, 0, SEEK_END);
  n = ftell(f);
  fseek(f, 0, SEEK_SET);
  buf = malloc((size_t)n + 1);
  if (buf && fread(buf, 1, (size_t)n, f) != (size_t)n) { free(buf); buf = NULL; }
  if (buf) buf[n] = '\0';
  fclose(f);
  *len = (size_t)n;
  return buf;
}

static mo_material material(int dim, double E, double nu, double rho)
{
  mo_material mat;
  memset(&mat, 0, sizeof mat);
  mat.model = MO_MAT_ELASTIC;
  mat.E = E;
  mat.nu = nu;
  mat.rho = rho;
  mat.hyp = dim == 1 ? MO_HYP_BAR : dim == 2 ? MO_HYP_PLANE_STRAIN : MO_HYP_3D;
  mat.area = 1;
  mat.thickness = 1;
  return mat;
}

static double total_measure(const mo_mesh *m)
{
  mo_material mat = material(m->dim, 1, 0, 1);
  double s = 0;
  int e;
  for (e = 0; e < m->nelem; e++) s += mo_elem_measure(m, e, &mat);
  return s;
}

/* Dense K and M over the dofs of the nodes outside node set `held` (NULL: none); returns the
   number of free dofs, map[dof] = free index or -1. */
static int assemble_dense(const mo_mesh *m, const mo_material *mat, const char *held, int **map,
                          double **K, double **M)
{
  mo_ctx ctx;
  int D = m->dim, ndof = m->nnode * D, n = 0, e, a, b, *ids = NULL, nids = 0, i;
  mo_ctx_init(&ctx);
  *map = malloc((size_t)ndof * sizeof(int));
  for (i = 0; i < ndof; i++) (*map)[i] = 0;
  if (held && !mo_mesh_nodeset_resolve(m, held, &ids, &nids, &ctx))
    for (i = 0; i < nids; i++)
      for (a = 0; a < D; a++) (*map)[ids[i] * D + a] = -1;
  free(ids);
  for (i = 0; i < ndof; i++) (*map)[i] = (*map)[i] < 0 ? -1 : n++;
  *K = calloc((size_t)n * (size_t)n, sizeof(double));
  *M = calloc((size_t)n * (size_t)n, sizeof(double));
  for (e = 0; e < m->nelem; e++) {
    double Ke[MO_ND_MAX * MO_ND_MAX], Me[MO_ND_MAX * MO_ND_MAX];
    int nd = m->nen * D, dof[MO_ND_MAX];
    mo_elem_stiffness(m, e, mat, Ke, &ctx);
    mo_elem_mass(m, e, mat, 0, Me, &ctx);
    for (a = 0; a < m->nen; a++)
      for (i = 0; i < D; i++) dof[a * D + i] = (*map)[m->conn[e * m->nen + a] * D + i];
    for (a = 0; a < nd; a++)
      for (b = 0; b < nd; b++)
        if (dof[a] >= 0 && dof[b] >= 0) {
          (*K)[(size_t)dof[b] * (size_t)n + (size_t)dof[a]] += Ke[a * nd + b];
          (*M)[(size_t)dof[b] * (size_t)n + (size_t)dof[a]] += Me[a * nd + b];
        }
  }
  return n;
}

/* Squared natural frequencies (ascending) with the nodes of `held` clamped; n of them. */
static double *spectrum(const mo_mesh *m, const mo_material *mat, const char *held, int *n)
{
  int *map, one = 1, lwork, info;
  double *K, *M, *w, *work;
  *n = assemble_dense(m, mat, held, &map, &K, &M);
  lwork = 64 * (*n > 0 ? *n : 1);
  w = malloc((size_t)(*n > 0 ? *n : 1) * sizeof(double));
  work = malloc((size_t)lwork * sizeof(double));
  dsygv_(&one, "N", "U", n, K, n, M, n, w, work, &lwork, &info);
  if (info) w[0] = NAN;
  free(map); free(K); free(M); free(work);
  return w;
}

/* Largest relative difference of two spectra of n values (relative to the largest). */
static double spectrum_diff(const double *a, const double *b, int n)
{
  double d = 0, s = 0;
  int i;
  for (i = 0; i < n; i++) {
    d = fmax(d, fabs(a[i] - b[i]));
    s = fmax(s, fabs(b[i]));
  }
  return d / s;
}

/* Patch test: the nodes of the sets `boundary` ("a", "a|b|..." for a union) take the linear field
   u_i = c_i0 + sum_j c_ij x_j; solving K u = 0 for the others must give the same field (exact for
   bar2, T3, Q4, H8 on any valid mesh). Returns the largest error relative to the field's size. */
static double patch_test(const mo_mesh *m, const char *boundary)
{
  static const double C[3][4] = {{1e-3, 2e-3, 3e-3, -1e-3}, {-1e-3, 5e-4, -1.5e-3, 2e-3},
                                 {2e-3, -1e-3, 1e-3, 5e-4}};
  mo_ctx ctx;
  mo_material mat = material(m->dim, 2e11, m->dim == 1 ? 0 : 0.3, 7800);
  int D = m->dim, ndof = m->nnode * D, *held = calloc((size_t)ndof, sizeof(int)), *map, n, i, j, e,
      one = 1, info;
  double *u = malloc((size_t)ndof * sizeof(double)), *K, *Mm, *rhs, err = 0, size = 0;
  char names[256], *tok, *save = NULL;
  mo_ctx_init(&ctx);
  snprintf(names, sizeof names, "%s", boundary);
  for (tok = strtok_r(names, "|", &save); tok; tok = strtok_r(NULL, "|", &save)) {
    int *ids, nid;
    if (mo_mesh_nodeset_resolve(m, tok, &ids, &nid, &ctx)) { err = NAN; nid = 0; ids = NULL; }
    for (j = 0; j < nid; j++)
      for (i = 0; i < D; i++) held[ids[j] * D + i] = 1;
    free(ids);
  }
  for (j = 0; j < m->nnode; j++)
    for (i = 0; i < D; i++) {
      double v = C[i][0];
      for (e = 0; e < D; e++) v += C[i][e + 1] * m->x[j * D + e];
      u[j * D + i] = v;
      size = fmax(size, fabs(v));
    }
  /* K over all dofs, then K_ii u_i = -K_ib u_b */
  n = assemble_dense(m, &mat, NULL, &map, &K, &Mm);
  {
    int ni = 0, *fi = malloc((size_t)ndof * sizeof(int));
    double *Kii;
    for (i = 0; i < ndof; i++) fi[i] = held[i] ? -1 : ni++;
    Kii = calloc((size_t)(ni ? ni : 1) * (size_t)(ni ? ni : 1), sizeof(double));
    rhs = calloc((size_t)(ni ? ni : 1), sizeof(double));
    for (j = 0; j < n; j++)
      for (i = 0; i < n; i++) {
        double k = K[(size_t)j * (size_t)n + (size_t)i];
        if (fi[i] < 0) continue;
        if (fi[j] >= 0) Kii[(size_t)fi[j] * (size_t)ni + (size_t)fi[i]] = k;
        else rhs[fi[i]] -= k * u[j];
      }
    dposv_("L", &ni, &one, Kii, &ni, rhs, &ni, &info);
    if (info) err = NAN;
    for (i = 0; i < ndof && !isnan(err); i++)
      if (fi[i] >= 0) err = fmax(err, fabs(rhs[fi[i]] - u[i]));
    if (ni == 0) err = NAN; /* no interior node: the test would prove nothing */
    free(fi); free(Kii); free(rhs);
  }
  free(held); free(u); free(map); free(K); free(Mm);
  return err / size;
}

static int outward(const mo_mesh *m, const char *set, const double *want)
{
  const mo_facetset *fs = mo_mesh_find_facetset(m, set);
  int f, d, good = fs && fs->n > 0;
  for (f = 0; good && f < fs->n; f++) {
    double n[3];
    mo_facet_normal(m, fs, f, n, NULL);
    for (d = 0; d < m->dim; d++)
      if (fabs(n[d] - want[d]) > 1e-12) good = 0;
  }
  return good;
}

static int set_size(const mo_mesh *m, const char *name, int facets)
{
  if (facets) {
    const mo_facetset *fs = mo_mesh_find_facetset(m, name);
    return fs ? fs->n : -1;
  } else {
    const mo_nodeset *ns = mo_mesh_find_nodeset(m, name);
    return ns ? ns->n : -1;
  }
}

/* --- the 2D plates --------------------------------------------------------------------------- */

static void test_plates(void)
{
  mo_ctx ctx;
  mo_mesh *m = NULL, *m22 = NULL, *g = NULL, *cw = NULL;
  mo_gmsh_report r;
  mo_material mat = material(2, 2e11, 0.3, 7800);
  static const double down[2] = {0, -1}, up[2] = {0, 1}, left[2] = {-1, 0}, right[2] = {1, 0};
  int st, nb, n1, n2;
  mo_ctx_init(&ctx);
  ctx.verbosity = 0;

  /* unstructured triangles */
  st = read_mesh("tests/meshes/plate-t3.msh", NULL, &m, &r, &ctx);
  ok(st == MO_OK && m && m->type == MO_EL_T3 && m->dim == 2 && r.version == 41 && r.nunused == 0,
     "plate-t3.msh (MSH 4.1): a 2D T3 body %s", st ? ctx.errmsg : "");
  if (st) return;
  nb = set_size(m, "bottom", 1) + set_size(m, "right", 1) + set_size(m, "top", 1) + set_size(m, "left", 1);
  ok(set_size(m, "bottom", 1) == 8 && set_size(m, "top", 1) == 8 && set_size(m, "left", 1) == 4 &&
     set_size(m, "right", 1) == 4, "plate-t3: the sides' facet sets hold the 8, 4, 8, 4 segments of the .geo's lc = 0.25");
  ok(m->nelem == 2 * m->nnode - nb - 2, "plate-t3: Euler's relation of a triangulated disk: %d triangles = 2 x %d "
     "nodes - %d boundary nodes - 2", m->nelem, m->nnode, nb);
  ok(set_size(m, "bottom", 0) == 9 && set_size(m, "plate", 0) == m->nnode && set_size(m, "all", 0) == m->nnode &&
     set_size(m, "origin", 0) == 1 && m->x[2 * mo_mesh_find_nodeset(m, "origin")->node[0]] == 0,
     "plate-t3: node sets: bottom 9 nodes, the surface's group and 'all' every node, 'origin' the node at (0, 0)");
  ok(outward(m, "bottom", down) && outward(m, "top", up) && outward(m, "left", left) && outward(m, "right", right),
     "plate-t3: facet normals point out of the plate on all four sides");
  is_close(total_measure(m), 2, 1e-13, "plate-t3: the triangles' areas sum to the plate's, 2 m^2");
  {
    int *ids = NULL, n = 0;
    st = mo_mesh_nodeset_resolve(m, "bottom&left", &ids, &n, &ctx);
    ok(st == MO_OK && n == 1 && m->x[2 * ids[0]] == 0 && m->x[2 * ids[0] + 1] == 0,
       "plate-t3: 'bottom&left' is the corner (0, 0)");
    free(ids);
  }
  is_close(patch_test(m, "bottom|right|top|left"), 0, 1e-10,
           "plate-t3: patch test: a linear field on the boundary is reproduced inside");
  mo_mesh_free(m);
  m = NULL;

  /* structured quadrangles, in both formats, against the rectangle generator */
  st = read_mesh("tests/meshes/plate-q4.msh", NULL, &m, &r, &ctx);
  ok(!st && m->type == MO_EL_Q4 && m->nnode == 9 * 5 && m->nelem == 8 * 4,
     "plate-q4.msh: 9 x 5 nodes, 8 x 4 Q4 (transfinite)");
  st |= read_mesh("tests/meshes/plate-q4-v22.msh", NULL, &m22, &r, &ctx);
  ok(!st && r.version == 22 && m22->nnode == m->nnode && m22->nelem == m->nelem &&
     !memcmp(m22->conn, m->conn, (size_t)m->nelem * 4 * sizeof(int)) &&
     !memcmp(m22->x, m->x, (size_t)m->nnode * 2 * sizeof(double)),
     "plate-q4-v22.msh (MSH 2.2) gives the same nodes and elements as the MSH 4.1 file");
  ok(m22 && m22->nnodeset == m->nnodeset && m22->nfacetset == m->nfacetset &&
     set_size(m22, "left", 1) == 4 && set_size(m22, "origin", 0) == 1, "... and the same sets");
  if (st) return;
  {
    double o[2] = {0, 0}, s[2] = {2, 1};
    int ne[2] = {8, 4};
    double *wg, *wm;
    mo_mesh_rectangle(o, s, ne, MO_EL_Q4, MO_DIAG_RIGHT, &g, &ctx);
    wm = spectrum(m, &mat, "left", &n1);
    wg = spectrum(g, &mat, "left", &n2);
    ok(n1 == n2 && n1 == 80 && spectrum_diff(wm, wg, n1) < 1e-10,
       "plate-q4 clamped on 'left': its 80 frequencies are the rectangle generator's (largest difference %.1e)",
       n1 == n2 ? spectrum_diff(wm, wg, n1) : NAN);
    free(wm);
    /* the clockwise file: reoriented, the same plate */
    st = read_mesh("tests/meshes/plate-cw.msh", NULL, &cw, &r, &ctx);
    ok(!st && r.nreoriented == 32 && mo_mesh_check(cw, &ctx) == MO_OK,
       "plate-cw.msh: its 32 clockwise quadrangles are reoriented (reported %d) and pass the check", st ? -1 : r.nreoriented);
    if (!st) {
      is_close(total_measure(cw), 2, 1e-13, "plate-cw: area 2 m^2");
      ok(outward(cw, "bottom", down) && outward(cw, "top", up), "plate-cw: its facet sets point outward");
      wm = spectrum(cw, &mat, "bottom", &n1);
      free(wg);
      wg = spectrum(g, &mat, "bottom", &n2);
      ok(n1 == n2 && spectrum_diff(wm, wg, n1) < 1e-10,
         "plate-cw clamped on 'bottom': the generator's frequencies (largest difference %.1e)",
         n1 == n2 ? spectrum_diff(wm, wg, n1) : NAN);
      free(wm);
    }
    free(wg);
  }
  mo_mesh_free(m);
  mo_mesh_free(m22);
  mo_mesh_free(g);
  mo_mesh_free(cw);
}

/* --- disks ------------------------------------------------------------------------------------ */

static void test_disks(void)
{
  mo_ctx ctx;
  mo_mesh *m = NULL;
  mo_gmsh_report r;
  mo_gmsh_options o;
  const double polygon = 16 * sin(M_PI / 16); /* the inscribed 32-gon of the unit circle */
  int st, f, good;
  mo_ctx_init(&ctx);
  ctx.verbosity = 0;
  st = read_mesh("tests/meshes/disk-t3.msh", NULL, &m, &r, &ctx);
  ok(!st && m->type == MO_EL_T3 && set_size(m, "boundary", 1) == 32 && set_size(m, "boundary", 0) == 32,
     "disk-t3.msh: T3, 32 boundary segments");
  if (st) return;
  ok(m->nelem == 2 * m->nnode - 32 - 2, "disk-t3: Euler's relation (%d triangles, %d nodes)", m->nelem, m->nnode);
  is_close(total_measure(m), polygon, 1e-13, "disk-t3: area of the inscribed 32-gon, 16 sin(pi/16)");
  {
    const mo_facetset *fs = mo_mesh_find_facetset(m, "boundary");
    for (f = 0, good = 1; f < fs->n; f++) {
      double n[2], c[2];
      const double *a = &m->x[2 * fs->node[2 * f]], *b = &m->x[2 * fs->node[2 * f + 1]];
      mo_facet_normal(m, fs, f, n, NULL);
      c[0] = 0.5 * (a[0] + b[0]);
      c[1] = 0.5 * (a[1] + b[1]);
      if (fabs(n[0] * c[0] + n[1] * c[1] - cos(M_PI / 32)) > 1e-9) good = 0;
    }
    ok(good, "disk-t3: every boundary normal is radial and outward (n.x = cos(pi/32) at the midpoints, to "
        "the 1e-8 rad of Gmsh's nodes on its arcs)");
  }
  is_close(patch_test(m, "boundary"), 0, 1e-10, "disk-t3: patch test");
  mo_mesh_free(m);
  m = NULL;

  /* the cylinder of cylinder-wall in millimetres: scale and translate */
  memset(&o, 0, sizeof o);
  o.scale = 1e-3;
  o.translate[1] = 0.04;
  st = read_mesh("tests/meshes/cylinder-q4.msh", &o, &m, &r, &ctx);
  ok(!st && m->type == MO_EL_Q4 && mo_mesh_check(m, &ctx) == MO_OK && set_size(m, "boundary", 1) == 32,
     "cylinder-q4.msh: unstructured Q4 (recombined, subdivided), 32 boundary segments");
  if (st) return;
  is_close(total_measure(m), polygon * 0.03 * 0.03, 1e-15, "cylinder-q4 at scale 1e-3: area 16 sin(pi/16) (30 mm)^2");
  {
    const mo_nodeset *ns = mo_mesh_find_nodeset(m, "bottom_point");
    ok(ns && ns->n == 1 && fabs(m->x[2 * ns->node[0]]) < 1e-15 && fabs(m->x[2 * ns->node[0] + 1] - 0.01) < 1e-15,
       "cylinder-q4 translated by [0, 0.04]: 'bottom_point' at (0, 0.01)");
  }
  is_close(patch_test(m, "boundary"), 0, 1e-9, "cylinder-q4: patch test on distorted quadrangles");
  mo_mesh_free(m);
}

/* --- the H8 box and the bar ---------------------------------------------------------------------- */

static void test_box_bar(void)
{
  mo_ctx ctx;
  mo_mesh *m = NULL, *g = NULL;
  mo_gmsh_report r;
  int st, d, n1, n2;
  mo_ctx_init(&ctx);
  ctx.verbosity = 0;
  st = read_mesh("tests/meshes/box-h8.msh", NULL, &m, &r, &ctx);
  ok(!st && m->type == MO_EL_H8 && m->dim == 3 && m->nnode == 3 * 4 * 5 && m->nelem == 2 * 3 * 4,
     "box-h8.msh: 3 x 4 x 5 nodes, 2 x 3 x 4 H8 %s", st ? ctx.errmsg : "");
  if (st) return;
  is_close(total_measure(m), 6, 1e-13, "box-h8: volume 1 x 2 x 3");
  for (d = 0; d < 6; d++) {
    static const char *nm[6] = {"xmin", "xmax", "ymin", "ymax", "zmin", "zmax"};
    static const int cnt[6] = {12, 12, 8, 8, 6, 6};
    double n[3] = {0, 0, 0};
    n[d / 2] = d % 2 ? 1 : -1;
    ok(set_size(m, nm[d], 1) == cnt[d] && outward(m, nm[d], n), "box-h8: face group %s: %d quadrangles, outward normals",
       nm[d], cnt[d]);
  }
  ok(set_size(m, "edge", 0) == 3 && set_size(m, "corner", 0) == 1 && !mo_mesh_find_facetset(m, "edge"),
     "box-h8: a physical curve and a physical point give node sets only");
  is_close(patch_test(m, "xmin|xmax|ymin|ymax|zmin|zmax"), 0, 1e-10, "box-h8: patch test");
  {
    double o[3] = {0, 0, 0}, s[3] = {1, 2, 3}, *wm, *wg;
    int ne[3] = {2, 3, 4};
    mo_material mat = material(3, 2e11, 0.3, 7800);
    mo_mesh_box(o, s, ne, &g, &ctx);
    wm = spectrum(m, &mat, "zmin", &n1);
    wg = spectrum(g, &mat, "zmin", &n2);
    ok(n1 == n2 && n1 == 144 && spectrum_diff(wm, wg, n1) < 1e-10,
       "box-h8 clamped on 'zmin': its 144 frequencies are the box generator's (largest difference %.1e)",
       n1 == n2 ? spectrum_diff(wm, wg, n1) : NAN);
    free(wm); free(wg);
  }
  mo_mesh_free(m);
  mo_mesh_free(g);
  m = g = NULL;

  st = read_mesh("tests/meshes/bar.msh", NULL, &m, &r, &ctx);
  ok(!st && m->type == MO_EL_BAR2 && m->dim == 1 && m->nnode == 21 && m->nelem == 20 &&
     set_size(m, "left", 1) == 1 && set_size(m, "right", 1) == 1,
     "bar.msh: a 1D body of 20 bar2, end points 'left' and 'right' as facet sets");
  if (st) return;
  {
    mo_material mat = material(1, 2e11, 0, 7800);
    double c = sqrt(2e11 / 7800), w1 = M_PI * c / (2 * 2), *wm, *wg;
    mo_mesh_bar(0, 2, 20, &g, &ctx);
    wm = spectrum(m, &mat, "left", &n1);
    wg = spectrum(g, &mat, "left", &n2);
    ok(n1 == 20 && n2 == 20 && spectrum_diff(wm, wg, n1) < 1e-10,
       "bar clamped on 'left': the bar generator's 20 frequencies (largest difference %.1e)", spectrum_diff(wm, wg, 20));
    ok(fabs(sqrt(wm[0]) - w1) < 1e-3 * w1, "bar: first frequency %.6g rad/s, pi c / 2L = %.6g (%.1e relative)",
       sqrt(wm[0]), w1, fabs(sqrt(wm[0]) - w1) / w1);
    free(wm); free(wg);
  }
  is_close(patch_test(m, "left|right"), 0, 1e-12, "bar: patch test");
  mo_mesh_free(m);
  mo_mesh_free(g);
}

/* --- tetrahedra and second-order elements; binary files ------------------------------------------- */

/* 1 when meshes a and b have the same nodes (coordinates to tol), elements and sets. */
static int same_mesh(const mo_mesh *a, const mo_mesh *b, double tol, double *dx)
{
  int i, k, same = a->type == b->type && a->dim == b->dim && a->nnode == b->nnode && a->nelem == b->nelem &&
                   a->nnodeset == b->nnodeset && a->nfacetset == b->nfacetset;
  *dx = 0;
  if (!same) return 0;
  for (i = 0; i < a->nnode * a->dim; i++) *dx = fmax(*dx, fabs(a->x[i] - b->x[i]));
  same &= *dx <= tol && !memcmp(a->conn, b->conn, (size_t)a->nelem * (size_t)a->nen * sizeof(int));
  for (k = 0; same && k < a->nnodeset; k++) {
    const mo_nodeset *p = &a->nodeset[k], *q = mo_mesh_find_nodeset(b, p->name);
    same &= q && q->n == p->n && !memcmp(p->node, q->node, (size_t)p->n * sizeof(int));
  }
  for (k = 0; same && k < a->nfacetset; k++) {
    const mo_facetset *p = &a->facetset[k], *q = mo_mesh_find_facetset(b, p->name);
    same &= q && q->n == p->n && q->kind == p->kind && !memcmp(p->node, q->node, (size_t)p->n * (size_t)p->nfn * sizeof(int));
  }
  return same;
}

/* The largest distance of a middle node from the middle of its edge (the box's T10 are straight):
   the 9th and 10th nodes must sit on edges 13 and 23 once read (Gmsh writes them the other way). */
static double middle_error(const mo_mesh *m)
{
  static const int edge[6][2] = {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}};
  double worst = 0;
  int e, k, d;
  for (e = 0; e < m->nelem; e++)
    for (k = 0; k < 6; k++) {
      const int *c = &m->conn[e * 10];
      double s = 0;
      for (d = 0; d < 3; d++) {
        double t = m->x[c[4 + k] * 3 + d] - 0.5 * (m->x[c[edge[k][0]] * 3 + d] + m->x[c[edge[k][1]] * 3 + d]);
        s += t * t;
      }
      worst = fmax(worst, sqrt(s));
    }
  return worst;
}

static void test_tets(void)
{
  static const char *files[2][2] = {{"tests/meshes/box-t4.msh", "tests/meshes/box-t4-bin.msh"},
                                    {"tests/meshes/box-t10.msh", "tests/meshes/box-t10-bin.msh"}};
  mo_ctx ctx;
  mo_mesh *m = NULL, *mb = NULL;
  mo_gmsh_report r, rb;
  int k, st, d;
  mo_ctx_init(&ctx);
  ctx.verbosity = 0;
  for (k = 0; k < 2; k++) {
    double dx = 0;
    st = read_mesh(files[k][0], NULL, &m, &r, &ctx);
    st |= read_mesh(files[k][1], NULL, &mb, &rb, &ctx);
    ok(!st && m->type == (k ? MO_EL_T10 : MO_EL_T4) && !r.binary && rb.binary && rb.version == 41 &&
       mo_mesh_check(m, &ctx) == MO_OK,
       "%s and its binary twin: %s bodies (%s)", files[k][0] + 13, k ? "T10" : "T4", st ? ctx.errmsg : "read");
    if (st) break;
    ok(same_mesh(m, mb, 1e-15, &dx), "%s: the binary file gives the ASCII file's mesh: %d nodes, %d elements, %d node "
       "and %d facet sets, coordinates within %.1e", files[k][1] + 13, m->nnode, m->nelem, m->nnodeset, m->nfacetset, dx);
    is_close(total_measure(m), 6, 1e-13, "%s: volume 1 x 2 x 3", files[k][0] + 13);
    for (d = 0; d < 6; d++) {
      static const char *nm[6] = {"xmin", "xmax", "ymin", "ymax", "zmin", "zmax"};
      static const double area[6] = {6, 6, 3, 3, 2, 2};
      const mo_facetset *fs = mo_mesh_find_facetset(m, nm[d]);
      double n[3] = {0, 0, 0}, a = 0;
      int f;
      n[d / 2] = d % 2 ? 1 : -1;
      for (f = 0; fs && f < fs->n; f++) {
        double meas, nn[3];
        mo_facet_normal(m, fs, f, nn, &meas);
        a += meas;
      }
      ok(fs && fs->kind == (k ? MO_FK_TRI6 : MO_FK_TRI3) && outward(m, nm[d], n) && fabs(a - area[d]) < 1e-13,
         "%s: face group %s: %d %s faces, outward normals, area %g", files[k][0] + 13, nm[d], fs ? fs->n : 0,
         k ? "6-node" : "3-node", a);
    }
    ok(set_size(m, "origin", 0) == 1 && m->x[3 * mo_mesh_find_nodeset(m, "origin")->node[0] + 2] == 0,
       "%s: the physical point 'origin' is the node at (0, 0, 0)", files[k][0] + 13);
    is_close(patch_test(m, "xmin|xmax|ymin|ymax|zmin|zmax"), 0, 1e-10, "%s: patch test on Gmsh's tetrahedra",
             files[k][0] + 13);
    if (k) {
      double w = middle_error(m);
      ok(w < 1e-12, "box-t10.msh: every middle node at the middle of its edge in moreau's order (largest distance "
         "%.1e): Gmsh's 9th and 10th nodes swapped", w);
    }
    mo_mesh_free(m);
    mo_mesh_free(mb);
    m = mb = NULL;
  }
  /* curved 6-node triangles: the quarter disk, its arc's middle nodes on the circle */
  st = read_mesh("tests/meshes/quarter-t6.msh", NULL, &m, &r, &ctx);
  ok(!st && m->type == MO_EL_T6 && set_size(m, "arc", 1) > 0 && mo_mesh_find_facetset(m, "arc")->kind == MO_FK_LINE3,
     "quarter-t6.msh: a T6 body, its arc a facet set of 3-node edges %s", st ? ctx.errmsg : "");
  if (!st) {
    const mo_facetset *fs = mo_mesh_find_facetset(m, "arc");
    double area = total_measure(m), poly = 0, len = 0, off = 0;
    int f;
    for (f = 0; f < fs->n; f++) { /* the corners' polygon: what T3 with these corners would enclose */
      const double *a = &m->x[2 * fs->node[3 * f]], *b = &m->x[2 * fs->node[3 * f + 1]], *c = &m->x[2 * fs->node[3 * f + 2]];
      double meas, nn[2];
      poly += 0.5 * fabs(a[0] * b[1] - a[1] * b[0]);
      mo_facet_normal(m, fs, f, nn, &meas);
      len += meas;
      off = fmax(off, fabs(hypot(c[0], c[1]) - 1));
    }
    ok(off < 1e-12, "quarter-t6: the middle nodes of its %d arc edges lie on the unit circle (%.1e)", fs->n, off);
    ok(fabs(area - M_PI / 4) < 1e-5 && fabs(poly - M_PI / 4) > 100 * fabs(area - M_PI / 4),
       "quarter-t6: area %.9f against pi/4 = %.9f (%.1e; the corners' polygon %.1e)", area, M_PI / 4,
       fabs(area - M_PI / 4), fabs(poly - M_PI / 4));
    ok(fabs(len - M_PI / 2) < 1e-5, "quarter-t6: the arc's length %.9f against pi/2 (%.1e)", len, fabs(len - M_PI / 2));
    is_close(patch_test(m, "xaxis|arc|yaxis"), 0, 1e-10, "quarter-t6: patch test on curved 6-node triangles");
  }
  mo_mesh_free(m);
}

/* A binary MSH 4.1 file built byte by byte: one tetrahedron (nodes 1-4) on volume 1 of physical group
   1 "v"; in the writer's byte order (swap: the other one) and size_t of ds bytes. Hooks put
   damage where a test wants it; at[] records where items begin. */
typedef struct {
  char *b;
  size_t n, cap;
  int swap, ds;
} bbuf;

static void b_raw(bbuf *B, const void *p, size_t n)
{
  if (B->n + n > B->cap) {
    B->cap = 2 * (B->n + n) + 64;
    B->b = realloc(B->b, B->cap);
  }
  memcpy(B->b + B->n, p, n);
  B->n += n;
}
static void b_str(bbuf *B, const char *s) { b_raw(B, s, strlen(s)); }
static void b_num(bbuf *B, const void *p, size_t n)
{
  unsigned char t[8];
  size_t i;
  for (i = 0; i < n; i++) t[i] = ((const unsigned char *)p)[B->swap ? n - 1 - i : i];
  b_raw(B, t, n);
}
static void b_int(bbuf *B, int v) { int32_t w = v; b_num(B, &w, 4); }
static void b_size(bbuf *B, unsigned long long v)
{
  if (B->ds == 4) { uint32_t w = (uint32_t)v; b_num(B, &w, 4); }
  else { uint64_t w = v; b_num(B, &w, 8); }
}
static void b_dbl(bbuf *B, double v) { b_num(B, &v, 8); }

enum { BAD_NONE = 0, BAD_CHECK, BAD_NNODES, BAD_TYPE, BAD_NODEREF, BAD_NAN, BAD_MORE, BAD_DIM, BAD_TRUNC };

/* The file, with one defect; *at: the byte offset of the defect's item. */
static bbuf binary_tet(int swap, int ds, int bad, size_t *at)
{
  static const double X[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  bbuf B = {NULL, 0, 0, swap, ds};
  char head[64];
  int i, j;
  *at = 0;
  snprintf(head, sizeof head, "$MeshFormat\n4.1 1 %d\n", ds);
  b_str(&B, head);
  *at = B.n;
  if (bad == BAD_CHECK) b_int(&B, 2);
  else b_int(&B, 1);
  b_str(&B, "\n$EndMeshFormat\n$PhysicalNames\n1\n3 1 \"v\"\n$EndPhysicalNames\n$Entities\n");
  b_size(&B, 0); b_size(&B, 0); b_size(&B, 0); b_size(&B, 1);
  b_int(&B, 1);
  for (i = 0; i < 6; i++) b_dbl(&B, i < 3 ? 0 : 1);
  b_size(&B, 1); b_int(&B, 1); b_size(&B, 0);
  b_str(&B, "\n$EndEntities\n$Nodes\n");
  b_size(&B, 1);
  if (bad == BAD_NNODES) *at = B.n;
  b_size(&B, bad == BAD_NNODES ? 1000000000000ULL : 4);
  b_size(&B, 1); b_size(&B, 4);
  b_int(&B, 3); b_int(&B, 1); b_int(&B, 0); b_size(&B, 4);
  for (i = 0; i < 4; i++) b_size(&B, (unsigned long long)i + 1);
  for (i = 0; i < 4; i++)
    for (j = 0; j < 3; j++) {
      if (bad == BAD_NAN && i == 2 && j == 0) *at = B.n;
      b_dbl(&B, bad == BAD_NAN && i == 2 && j == 0 ? NAN : X[i][j]);
      if (bad == BAD_TRUNC && i == 3 && j == 1) {
        *at = B.n;
        b_raw(&B, "\0\0\0", 3);
        return B;
      }
    }
  b_str(&B, "\n$EndNodes\n$Elements\n");
  b_size(&B, 1); b_size(&B, 1); b_size(&B, 1); b_size(&B, 1);
  if (bad == BAD_DIM) *at = B.n;
  b_int(&B, bad == BAD_DIM ? -1 : 3);
  b_int(&B, 1);
  if (bad == BAD_TYPE) *at = B.n;
  b_int(&B, bad == BAD_TYPE ? 6 : 4);
  b_size(&B, 1);
  b_size(&B, 1);
  for (i = 0; i < 4; i++) {
    if (bad == BAD_NODEREF && i == 3) *at = B.n;
    b_size(&B, bad == BAD_NODEREF && i == 3 ? 9 : (unsigned long long)i + 1);
  }
  if (bad == BAD_MORE) {
    *at = B.n;
    b_size(&B, 5); /* a fifth node where $EndElements belongs */
  }
  b_str(&B, "\n$EndElements\n");
  return B;
}

static void test_binary(void)
{
  mo_ctx ctx;
  mo_mesh *m = NULL, *ref = NULL;
  mo_gmsh_report r;
  static const char ascii[] =
    "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$PhysicalNames\n1\n3 1 \"v\"\n$EndPhysicalNames\n"
    "$Entities\n0 0 0 1\n1 0 0 0 1 1 1 1 1 0\n$EndEntities\n"
    "$Nodes\n1 4 1 4\n3 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n$EndNodes\n"
    "$Elements\n1 1 1 1\n3 1 4 1\n1 1 2 3 4\n$EndElements\n";
  int swap, ds, st, k;
  size_t at;
  mo_ctx_init(&ctx);
  ctx.verbosity = 0;
  st = mo_mesh_read_gmsh_buffer(ascii, strlen(ascii), "a.msh", NULL, &ref, &r, &ctx);
  ok(!st && ref->nelem == 1 && ref->type == MO_EL_T4, "the ASCII tetrahedron reads (%s)", st ? ctx.errmsg : "1 T4");
  if (st) return;
  for (swap = 0; swap < 2; swap++)
    for (ds = 4; ds <= 8; ds += 4) {
      bbuf B = binary_tet(swap, ds, BAD_NONE, &at);
      double dx;
      st = mo_mesh_read_gmsh_buffer(B.b, B.n, "b.msh", NULL, &m, &r, &ctx);
      int same = !st && same_mesh(m, ref, 0, &dx);
      ok(!st && r.binary && same, "binary, %s byte order, %d-byte size_t: the ASCII file's "
         "tetrahedron, bit for bit (%s)", swap ? "the other" : "this machine's", ds, st ? ctx.errmsg : "same");
      mo_mesh_free(m);
      m = NULL;
      free(B.b);
    }
  {
    static const struct { int bad; const char *want; } bad[] = {
      {BAD_CHECK, "the binary check integer reads 02 00 00 00, not 1 in either byte order: a damaged file, or "
                  "one transferred as text"},
      {BAD_NNODES, "the number of nodes: 1000000000000, more than the limit of 20000000 (at least one dof per node, "
                   "and the context's max_dofs bounds the dofs: a direct factorization would not fit in memory)"},
      {BAD_TYPE, "element type 6 (6-node prism) is not supported"},
      {BAD_NAN, "the x coordinate of a node is nan, not a finite number"},
      {BAD_DIM, "the dimension of an element block's entity is -1: it must lie in [0, 3]"},
      {BAD_TRUNC, "the file ends inside a binary section (3 of the 8 bytes of the z coordinate of a node)"},
      {BAD_MORE, "expected $EndElements after the binary data: the section holds more, or other, bytes than its "
                 "counts announce"},
    };
    for (k = 0; k < (int)MO_COUNT(bad); k++) {
      bbuf B = binary_tet(0, 8, bad[k].bad, &at);
      char want[512];
      mo_ctx_clear_error(&ctx);
      snprintf(want, sizeof want, "b.msh: byte %zu: %s", at, bad[k].want);
      st = mo_mesh_read_gmsh_buffer(B.b, B.n, "b.msh", NULL, &m, &r, &ctx);
      ok(st != MO_OK && !strncmp(ctx.errmsg, want, strlen(want)), "binary, refused: %s (%s)", want + 6,
         st ? ctx.errmsg : "accepted");
      mo_mesh_free(m);
      m = NULL;
      free(B.b);
    }
  }
  {
    bbuf B = binary_tet(0, 8, BAD_NODEREF, &at);
    mo_ctx_clear_error(&ctx);
    st = mo_mesh_read_gmsh_buffer(B.b, B.n, "b.msh", NULL, &m, &r, &ctx);
    ok(st == MO_EINPUT && strstr(ctx.errmsg, "b.msh: byte ") &&
           strstr(ctx.errmsg, ": tetrahedron 1 refers to node 9, which $Nodes (byte "),
       "binary, refused: an element's node the file does not define (%s)", ctx.errmsg);
    mo_mesh_free(m);
    m = NULL;
    free(B.b);
  }
  {
    /* every proper prefix of the binary tetrahedron, and damaged copies of box-t4-bin.msh: never a
       crash, an error naming the file and the byte (or the line, in its text parts) */
    bbuf B = binary_tet(0, 8, BAD_NONE, &at);
    size_t len = 0, j;
    char *text = slurp("tests/meshes/box-t4-bin.msh", &len), *copy = malloc(len + 1);
    int accepted_bad = 0, crashes = 0, unlocated = 0, accepted = 0;
    for (j = 0; j + 1 < B.n; j++) {
      mo_ctx_init(&ctx);
      ctx.verbosity = 0;
      st = mo_mesh_read_gmsh_buffer(B.b, j, "cut.msh", NULL, &m, &r, &ctx);
      if (st == MO_OK) accepted_bad++;
      else if (st != MO_EINPUT) crashes++;
      else if (strncmp(ctx.errmsg, "cut.msh: byte ", 14) && strncmp(ctx.errmsg, "cut.msh:", 8)) unlocated++;
      mo_mesh_free(m);
      m = NULL;
    }
    ok(accepted_bad == 0 && crashes == 0 && unlocated == 0, "each of the %zu proper prefixes of the binary "
       "tetrahedron is refused with 'cut.msh: byte N: ...' (%d accepted, %d other codes, %d unlocated)", B.n - 1,
       accepted_bad, crashes, unlocated);
    if (text && copy) {
      unsigned long long sd = 88172645463325252ULL;
      int n = 2000, i;
      for (i = 0; i < n; i++) {
        size_t pos;
        sd ^= sd << 13; sd ^= sd >> 7; sd ^= sd << 17;
        pos = (size_t)(sd % len);
        memcpy(copy, text, len);
        copy[pos] = (char)(sd >> 40);
        mo_ctx_init(&ctx);
        ctx.verbosity = 0;
        st = mo_mesh_read_gmsh_buffer(copy, len, "hit.msh", NULL, &m, &r, &ctx);
        if (st == MO_OK) {
          accepted++;
          if (mo_mesh_check(m, &ctx)) crashes++;
        } else if (st != MO_EINPUT && st != MO_ELIMIT) crashes++;
        else if (strncmp(ctx.errmsg, "hit.msh:", 8)) unlocated++;
        mo_mesh_free(m);
        m = NULL;
      }
      ok(crashes == 0 && unlocated == 0, "%d copies of box-t4-bin.msh with a byte changed: %d read (all pass "
         "mo_mesh_check), the others refused naming the file and the place (%d other codes or failed checks, %d "
         "unlocated)", n, accepted, crashes, unlocated);
    }
    {
      /* every allocation of a binary read, failing, gives MO_ENOMEM */
      long calls, i;
      size_t bad = 0;
      mo_ctx_init(&ctx);
      ctx.verbosity = 0;
      st = mo_mesh_read_gmsh_buffer(text, len, "b.msh", NULL, &m, &r, &ctx);
      mo_mesh_free(m);
      m = NULL;
      calls = ctx.alloc_calls;
      for (i = 1; i <= calls; i++) {
        mo_ctx_init(&ctx);
        ctx.verbosity = 0;
        ctx.alloc_fail_at = i;
        st = mo_mesh_read_gmsh_buffer(text, len, "b.msh", NULL, &m, &r, &ctx);
        if (st != MO_ENOMEM || m) bad++;
        mo_mesh_free(m);
        m = NULL;
      }
      ok(calls > 10 && bad == 0, "each of the %ld allocations of a binary read, failing, gives MO_ENOMEM (%zu did not)",
         calls, bad);
    }
    mo_ctx_init(&ctx);
    ctx.verbosity = 0;
    free(B.b);
    free(text);
    free(copy);
  }
  {
    static const char v22[] = "$MeshFormat\n2.2 1 8\n";
    mo_ctx_clear_error(&ctx);
    st = mo_mesh_read_gmsh_buffer(v22, strlen(v22), "b.msh", NULL, &m, &r, &ctx);
    ok(st == MO_EINPUT && !strcmp(ctx.errmsg, "b.msh:2: a binary MSH 2.2 file is not read: save it as MSH 4.1 (binary or "
       "ASCII) or as ASCII 2.2"), "binary MSH 2.2: refused (%s)", ctx.errmsg);
  }
  mo_mesh_free(ref);
}

/* --- what a file may hold beyond the test meshes -------------------------------------------- */

static const char v22_two_groups[] =
    "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n"
    "$Nodes\n6\n1 0 0 0\n2 1 0 0\n3 2 0 0\n4 0 1 0\n5 1 1 0\n6 2 1 0\n$EndNodes\n"
    "$Elements\n7\n"
    "1 3 2 3 1 1 2 5 4\n"   /* quad 1 in physical surface 3 ... */
    "2 3 2 3 1 2 3 6 5\n"
    "3 3 2 4 1 1 2 5 4\n"   /* ... and again in physical surface 4, as MSH 2.2 writes it */
    "4 1 2 7 1 1 2\n"       /* unnamed physical curve 7 */
    "5 1 2 7 1 2 3\n"
    "6 1 2 8 1 2 5\n"       /* physical curve 8: the edge inside */
    "7 15 2 9 1 3\n"        /* physical point 9 */
    "$EndElements\n"
    "$Comments\nthis section is skipped $Nodes\n$EndComments\n";

static void test_features(void)
{
  mo_ctx ctx;
  mo_mesh *m = NULL;
  mo_gmsh_report r;
  int st;
  mo_ctx_init(&ctx);
  ctx.verbosity = 0;
  st = mo_mesh_read_gmsh_buffer(v22_two_groups, strlen(v22_two_groups), "two.msh", NULL, &m, &r, &ctx);
  ok(!st && m->nelem == 2 && r.nduplicate == 1, "MSH 2.2: an element repeated for a second physical group "
     "is read once (%s)", st ? ctx.errmsg : "2 quadrangles");
  if (st) return;
  ok(set_size(m, "surface3", 0) == 6 && set_size(m, "surface4", 0) == 4,
     "unnamed groups are named after their dimension and tag: surface3 (6 nodes), surface4 (4 nodes)");
  ok(set_size(m, "curve7", 1) == 2 && set_size(m, "curve7", 0) == 3, "curve7: a facet set of 2 edges, 3 nodes");
  ok(set_size(m, "curve8", 0) == 2 && set_size(m, "curve8", 1) == -1,
     "curve8 lies inside the body: a node set, no facet set");
  ok(set_size(m, "point9", 0) == 1 && m->x[2 * mo_mesh_find_nodeset(m, "point9")->node[0]] == 2,
     "point9: the node at x = 2; the $Comments section (holding '$Nodes') is skipped");
  mo_mesh_free(m);
  m = NULL;

  /* errors name the file and the line */
  {
    static const struct { const char *text, *want; } bad[] = {
      {"", "e.msh: the file is empty: expected $MeshFormat"},
      {"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n1\n1 0 0 0\n$EndNodes\n",
       "e.msh: no $Elements section"},
      {"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n2\n1 0 0 0\n2 1 0 0\n$EndNodes\n$Elements\n1\n1 15 2 1 1 1\n$EndElements\n",
       "e.msh:9: only points: no line, surface or volume element to make a body of"},
      {"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n2\n1 0 0 0\n1 1 0 0\n$EndNodes\n$Elements\n1\n1 1 2 1 1 1 1\n$EndElements\n",
       "e.msh:7: node 1 is defined twice (first at line 6)"},
      {"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n2\n1 0 0 0\n2 inf 0 0\n$EndNodes\n",
       "e.msh:7: the x coordinate of a node is 'inf', not a finite number"},
      {"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n1\n1 1 \"a&b\"\n$EndPhysicalNames\n",
       "e.msh:6: physical name 'a&b' contains '&', which set names use for intersections"},
      {"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n0\n$EndNodes\n$Foo\n1 2 3\n",
       "e.msh:8: the file ends inside section $Foo (line 7): no $EndFoo"},
      {"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n1 0 0 0\n2 1 0 0\n3 0.5 0 0\n$EndNodes\n$Elements\n1\n1 8 2 1 1 1 2 3\n$EndElements\n",
       "e.msh:12: the body would be made of 3-node lines: moreau's 1D element is the 2-node bar (save a 1D mesh "
       "with Mesh.ElementOrder = 1); 3-node lines are the sides of 6-node triangles"},
      {"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n2\n1 0 0 0\n2 1 0 0\n$EndNodes\n$Elements\n1\n1 6 2 1 1 1 2 3 4 5 6\n$EndElements\n",
       "e.msh:11: element type 6 (6-node prism) is not supported: moreau reads 2-node lines, 3- and 6-node "
       "triangles, 4-node quadrangles, 4- and 10-node tetrahedra, 8-node hexahedra, and 3-node lines as the sides "
       "of 6-node triangles (Mesh.ElementOrder = 1 or 2 with Mesh.SecondOrderIncomplete = 0; no prisms or pyramids)"},
      /* a 6-node triangle whose middle node of edge 12 sits beyond corner 1: its map turns over there */
      {"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n6\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0.5 0 0\n5 1.6 -0.1 0\n"
       "6 0 0.5 0\n$EndNodes\n$Elements\n1\n1 9 2 1 1 1 2 3 4 5 6\n$EndElements\n",
       "e.msh:15: 6-node triangle 1 is inverted at its node 2 (the Jacobian of its curved map there is -1.4 times "
       "that of its corners' triangle): a middle node lies too far from the middle of its edge"},
      /* a tetrahedron and a 10-node tetrahedron in one body */
      {"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n5\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 1 1 1\n$EndNodes\n"
       "$Elements\n2\n1 4 2 1 1 1 2 3 4\n2 11 2 1 1 2 3 4 5 1 1 1 1 1 1\n$EndElements\n",
       "e.msh:15: element 2 is a 10-node tetrahedron, but the element at line 14 is a tetrahedron: a body has one "
       "element type (recombine every surface into quadrangles, or none; one Mesh.ElementOrder)"},
      /* a group of 3-node triangles on a 10-node tetrahedron */
      {"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n10\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 0.5 0 0\n"
       "6 0.5 0.5 0\n7 0 0.5 0\n8 0 0 0.5\n9 0 0.5 0.5\n10 0.5 0 0.5\n$EndNodes\n"
       "$Elements\n2\n1 11 2 1 1 1 2 3 4 5 6 7 8 9 10\n2 2 2 2 1 1 2 3\n$EndElements\n",
       "e.msh:20: triangle 2 (physical group 'surface2') cannot be a side of a 10-node tetrahedron"},
      {"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n1 0 0 0\n2 1 0 0\n3 0 1 1\n$EndNodes\n"
       "$Elements\n1\n1 2 2 1 1 1 2 3\n$EndElements\n",
       "e.msh:8: node 3 has z = 1, but a 2D body lies in the plane z = 0: the file's highest-dimensional "
       "elements are triangles (Gmsh saves only the elements of physical groups once there are some: add a "
       "physical group for the body, or set Mesh.SaveAll = 1)"},
      {"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0.5 0.5 0\n$EndNodes\n"
       "$Elements\n2\n1 2 2 1 1 1 2 3\n2 2 2 1 1 1 2 4\n$EndElements\n",
       "e.msh:14: triangle 2 and triangle 1 (line 13) lie on the same side of their common edge (nodes 1, 2): "
       "the mesh folds over itself there"},
      {"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 1 1 0\n4 0 1 0\n$EndNodes\n"
       "$Elements\n1\n1 3 2 1 1 1 3 2 4\n$EndElements\n",
       "e.msh:13: quadrangle 1 is degenerate (flat): its area is 0 times the square of its longest edge, a "
       "valid element needs more than 1e-06"},
    };
    size_t k;
    for (k = 0; k < MO_COUNT(bad); k++) {
      mo_ctx_clear_error(&ctx);
      st = mo_mesh_read_gmsh_buffer(bad[k].text, strlen(bad[k].text), "e.msh", NULL, &m, &r, &ctx);
      is_str(st == MO_EINPUT ? ctx.errmsg : "(accepted)", bad[k].want, "rejected: %s", bad[k].want + 6);
      mo_mesh_free(m);
      m = NULL;
    }
  }
}

/* --- limits, allocation failures, hostile bytes -------------------------------------------------- */

static void test_hostile(void)
{
  mo_ctx ctx;
  mo_mesh *m = NULL;
  mo_gmsh_report r;
  size_t len, k;
  char *text = slurp("tests/meshes/plate-q4.msh", &len), *copy;
  long calls, i;
  int st, crashes = 0, unlocated = 0, accepted_bad = 0, accepted = 0;
  static const char huge[] = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 1000000000000 1 1000000000000\n";
  mo_ctx_init(&ctx);
  ctx.verbosity = 0;
  if (!text) {
    ok(0, "tests/meshes/plate-q4.msh is readable");
    return;
  }
  /* limits are refused before allocating */
  st = mo_mesh_read_gmsh_buffer(huge, strlen(huge), "huge.msh", NULL, &m, &r, &ctx);
  ok(st == MO_ELIMIT && ctx.alloc_calls < 4 &&
     !strcmp(ctx.errmsg, "huge.msh:5: the number of nodes: 1000000000000, more than the limit of 20000000 "
             "(at least one dof per node, and the context's max_dofs bounds the dofs: a direct "
             "factorization would not fit in memory)"),
     "10^12 nodes announced: refused before allocating (%ld allocations): %s", ctx.alloc_calls, ctx.errmsg);
  mo_ctx_init(&ctx);
  ctx.verbosity = 0;
  ctx.max_dofs = 40;
  st = mo_mesh_read_gmsh_buffer(text, len, "plate.msh", NULL, &m, &r, &ctx);
  ok(st == MO_ELIMIT && strstr(ctx.errmsg, "plate.msh:26: the number of nodes: 45, more than the limit of 40"),
     "max_dofs = 40: the 45 nodes of plate-q4 are refused: %s", ctx.errmsg);

  /* every allocation of a read, failing, gives MO_ENOMEM and leaks nothing (valgrind, ASan) */
  mo_ctx_init(&ctx);
  ctx.verbosity = 0;
  st = mo_mesh_read_gmsh_buffer(text, len, "plate.msh", NULL, &m, &r, &ctx);
  mo_mesh_free(m);
  m = NULL;
  calls = ctx.alloc_calls;
  for (i = 1, k = 0; i <= calls; i++) {
    mo_ctx_init(&ctx);
    ctx.verbosity = 0;
    ctx.alloc_fail_at = i;
    st = mo_mesh_read_gmsh_buffer(text, len, "plate.msh", NULL, &m, &r, &ctx);
    if (st != MO_ENOMEM || m) k++;
    mo_mesh_free(m);
    m = NULL;
  }
  ok(calls > 10 && k == 0, "each of the %ld allocations of a read, failing, gives MO_ENOMEM (%zu did not)", calls, k);

  /* every prefix of the file, and single-byte damage: never a crash, an error names file:line */
  copy = malloc(len + 1);
  for (k = 0; k + 1 < len; k++) { /* the last newline is optional */
    mo_ctx_init(&ctx);
    ctx.verbosity = 0;
    st = mo_mesh_read_gmsh_buffer(text, k, "cut.msh", NULL, &m, &r, &ctx);
    if (st == MO_OK) accepted_bad++;
    else if (st != MO_EINPUT) crashes++;
    else if (strncmp(ctx.errmsg, "cut.msh:", 8)) unlocated++;
    mo_mesh_free(m);
    m = NULL;
  }
  ok(accepted_bad == 0 && crashes == 0 && unlocated == 0,
     "each of the %zu proper prefixes of plate-q4.msh is refused with 'cut.msh:LINE: ...' (%d accepted, %d other codes, "
     "%d unlocated)", len - 1, accepted_bad, crashes, unlocated);
  {
    static const char bytes[] = "$-+.e9 \n\"x0";
    unsigned long long s = 88172645463325252ULL;
    int n = 3000, j;
    crashes = unlocated = 0;
    for (j = 0; j < n; j++) {
      size_t pos;
      s ^= s << 13; s ^= s >> 7; s ^= s << 17; /* xorshift64 */
      pos = (size_t)(s % len);
      memcpy(copy, text, len);
      copy[pos] = bytes[(s >> 32) % (sizeof bytes - 1)];
      mo_ctx_init(&ctx);
      ctx.verbosity = 0;
      st = mo_mesh_read_gmsh_buffer(copy, len, "hit.msh", NULL, &m, &r, &ctx);
      if (st == MO_OK) {
        accepted++;
        if (mo_mesh_check(m, &ctx)) crashes++;
      } else if (st != MO_EINPUT) crashes++;
      else if (strncmp(ctx.errmsg, "hit.msh:", 8)) unlocated++;
      mo_mesh_free(m);
      m = NULL;
    }
    ok(crashes == 0 && unlocated == 0, "%d damaged copies: %d read (all pass mo_mesh_check), the others refused "
       "with file:line (%d other codes or failed checks, %d unlocated)", n, accepted, crashes, unlocated);
  }
  free(copy);
  free(text);
}

/* --- a case on a Gmsh mesh: the cylinder of cylinder-wall dropped on a rigid plane ----------------- */

/* The plane lies half a step's travel below y = 0, so that the gap does not close at the end of a
   step, where the round-off of the free flight would decide the step of the impact. */

static const char drop_case[] =
    "bodies = (\n"
    "  { name = \"cylinder\"; mesh = { %s };\n"
    "    material = { E = 2.0e11; nu = 0.0; rho = 7800.0; }; initial = { velocity = [0.0, -500.0]; }; },\n"
    "  { name = \"rigid\"; type = \"plane\"; point = [0.0, -2.5e-4]; normal = [0.0, 1.0]; }\n"
    ");\n"
    "time = { theta = 1.0; theta_f = 1.0; dt = 1.0e-6; steps = 40; };\n"
    "contact = { solver = \"nscd\"; signorini = \"velocity\";\n"
    "  pairs = ( { slave = \"cylinder\"; slave_set = \"boundary\"; master = \"rigid\"; } ); };\n"
    "output = { probes = ( { name = \"bottom\"; set = \"bottom_point\"; quantities = [\"vy\", \"gn\"]; } ); };\n";

typedef struct {
  double mass, p0, p1, impulse;
  int first_contact_step;
} drop_result;

static int run_drop(const char *mesh, const char *tag, drop_result *D)
{
  char text[4096], out[256], p[512];
  json_t *j;
  tl_table H;
  int st, i, col;
  snprintf(text, sizeof text, drop_case, mesh);
  snprintf(out, sizeof out, "tests/out/gmsh-drop-%s-%ld", tag, (long)getpid());
  if ((st = tl_run_text(text, out, tag, NULL))) return st;
  j = tl_summary(out);
  if (!j) return -1;
  {
    json_t *b = json_array_get(json_object_get(json_object_get(j, "scene"), "bodies"), 0);
    D->mass = json_real_value(json_object_get(b, "mass"));
    D->p0 = json_number_value(json_array_get(json_object_get(b, "momentum_initial"), 1));
    D->p1 = json_number_value(json_array_get(json_object_get(b, "momentum_final"), 1));
    D->impulse = json_number_value(json_object_get(json_object_get(json_object_get(j, "metrics"), "contact"), "impulse"));
  }
  json_decref(j);
  /* the first step with a contact force */
  D->first_contact_step = -1;
  snprintf(p, sizeof p, "%s/history.csv", out);
  if (!tl_table_read(p, &H) && (col = tl_col(&H, "contact.force_n")) >= 0)
    for (i = 0; i < H.nrow && D->first_contact_step < 0; i++)
      if (tl_num(&H, i, col) != 0) D->first_contact_step = i;
  tl_table_free(&H);
  tl_remove_dir(out);
  return 0;
}

static void test_drop(void)
{
  char mesh[4200];
  drop_result G, R;
  const double m_exact = 7800 * 16 * sin(M_PI / 16) * 0.03 * 0.03;
  int st;
  snprintf(mesh, sizeof mesh, "file = \"%s/tests/meshes/cylinder-q4.msh\"; scale = 1.0e-3; translate = [0.0, 0.04];",
           tl_srcdir());
  st = run_drop(mesh, "gmsh", &G);
  ok(st == 0, "a contact scene runs on a Gmsh mesh (the cylinder of cylinder-wall on a rigid plane, nscd)");
  st |= run_drop("generator = \"disk\"; center = [0.0, 0.04]; radius = 0.03; core = 8; rings = 6;", "generator", &R);
  if (st) return;
  is_close(G.mass, m_exact, 1e-10 * m_exact, "Gmsh cylinder: mass rho 16 sin(pi/16) R^2 = %.10g kg/m", m_exact);
  is_close(R.mass, G.mass, 1e-10 * m_exact, "the generator's disk has the same inscribed polygon and mass");
  is_close(G.p0, -500 * m_exact, 1e-9 * 500 * m_exact, "initial momentum -500 m");
  ok(G.first_contact_step == 21 && R.first_contact_step == 21,
     "the contact force appears in the step ending at 21 us on both meshes (the 10.25 mm gap closes at "
     "20.5 us)");
  is_close(G.p1 - G.p0, G.impulse, 1e-8 * G.impulse,
           "Gmsh mesh: momentum change %.8g N s/m = contact impulse %.8g N s/m", G.p1 - G.p0, G.impulse);
  ok(fabs(G.impulse - R.impulse) < 0.05 * R.impulse,
     "impulse to 40 us: Gmsh mesh %.6g, generator %.6g N s/m (%.1f %% apart; the meshes differ)", G.impulse,
     R.impulse, 100 * fabs(G.impulse - R.impulse) / R.impulse);
}

int main(void)
{
  test_plates();
  test_disks();
  test_box_bar();
  test_tets();
  test_binary();
  test_features();
  test_hostile();
  test_drop();
  done_testing();
  return 0;
}
