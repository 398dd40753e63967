/* test_mortar.c: the contact patch test (Taylor and Papadopoulos 1991; BDZ07 §6.4) between
   non-matching meshes, levelset back end, Gauss collocation with P0 and P1 multipliers, against
   its closed form: two stacked blocks with rollers on their lateral faces, the lower one held at
   its bottom, the upper one's top moved down by delta in one quasi-static step. Exact: uniform
   sigma_nn = -p in both blocks, p = delta / (H_l / M_l + H_u / M_u) with the constrained modulus
   M = E (1 - nu) / ((1 + nu)(1 - 2 nu)), u_n linear in the normal coordinate in each block, no
   lateral displacement. Segmented integration (the slave facets cut at the master's facets,
   doc/theory.md (T90)-(T92)) reaches it to round-off in 2D (Q4, 12 against 11 elements) and 3D
   (H8, 4 x 4 against 3 x 3 facets); the Gauss points of whole facets (integration = "facet")
   miss it (the master's shape functions integrated inexactly across its nodes). */
#include "config.h"
#include <moreau/moreau.h>
#include "testlib.h"

typedef tl_steps run_t;
#define run_free tl_steps_free

static int run_open(run_t *R, const char *text, const char *const *sets, int nset)
{
  int st = tl_steps_open(R, text, "patch.cfg", sets, nset);
  if (st) diag("setup: %s", R->ctx.errmsg);
  return st;
}

/* The scenes: blocks of width 1 (and depth 1 in 3D) and height 0.5 each, the interface at 0.5. */
static const char *patch2d_fmt =
  "bodies = (\n"
  "  { name = \"lower\";\n"
  "    mesh = { generator = \"rectangle\"; size = [1.0, 0.5]; elements = [%d, 6]; element = \"Q4\"; };\n"
  "    material = { E = 2.0e11; nu = 0.3; rho = 7800.0; };\n"
  "    fix = ( { set = \"bottom\"; dofs = [\"y\"]; }, { set = \"left\"; dofs = [\"x\"]; }, { set = \"right\"; dofs = [\"x\"]; } ); },\n"
  "  { name = \"upper\";\n"
  "    mesh = { generator = \"rectangle\"; origin = [0.0, 0.5]; size = [1.0, 0.5]; elements = [%d, 6]; element = \"Q4\"; };\n"
  "    material = { E = 1.0e11; nu = 0.3; rho = 7800.0; };\n"
  "    fix = ( { set = \"left\"; dofs = [\"x\"]; }, { set = \"right\"; dofs = [\"x\"]; } );\n"
  "    prescribed = ( { set = \"top\"; dof = \"y\"; displacement = \"-1.0e-4 * t\"; } ); }\n"
  ");\n"
  "time = { scheme = \"quasistatic\"; steps = 1; };\n"
  "contact = {\n"
  "  solver = \"levelset\";\n"
  "  pairs = ( { name = \"interface\"; slave = \"lower\"; slave_set = \"top\"; master = \"upper\"; master_set = \"bottom\";\n"
  "              collocation = \"gauss\"; gauss = 2; } );\n"
  "  levelset = { multipliers = \"%s\"; };\n"
  "};\n";

static const char *patch3d_fmt =
  "bodies = (\n"
  "  { name = \"lower\";\n"
  "    mesh = { generator = \"box\"; size = [1.0, 1.0, 0.5]; elements = [%d, %d, 2]; };\n"
  "    material = { E = 2.0e11; nu = 0.3; rho = 7800.0; };\n"
  "    fix = ( { set = \"zmin\"; dofs = [\"z\"]; }, { set = \"xmin\"; dofs = [\"x\"]; }, { set = \"xmax\"; dofs = [\"x\"]; },\n"
  "            { set = \"ymin\"; dofs = [\"y\"]; }, { set = \"ymax\"; dofs = [\"y\"]; } ); },\n"
  "  { name = \"upper\";\n"
  "    mesh = { generator = \"box\"; origin = [0.0, 0.0, 0.5]; size = [1.0, 1.0, 0.5]; elements = [%d, %d, 2]; };\n"
  "    material = { E = 1.0e11; nu = 0.3; rho = 7800.0; };\n"
  "    fix = ( { set = \"xmin\"; dofs = [\"x\"]; }, { set = \"xmax\"; dofs = [\"x\"]; },\n"
  "            { set = \"ymin\"; dofs = [\"y\"]; }, { set = \"ymax\"; dofs = [\"y\"]; } );\n"
  "    prescribed = ( { set = \"zmax\"; dof = \"z\"; displacement = \"-1.0e-4 * t\"; } ); }\n"
  ");\n"
  "time = { scheme = \"quasistatic\"; steps = 1; };\n"
  "contact = {\n"
  "  solver = \"levelset\";\n"
  "  pairs = ( { name = \"interface\"; slave = \"lower\"; slave_set = \"zmax\"; master = \"upper\"; master_set = \"zmin\";\n"
  "              collocation = \"gauss\"; gauss = 2; } );\n"
  "  levelset = { multipliers = \"%s\"; };\n"
  "};\n";

typedef struct {
  int nc;
  double ep;    /* max |r_n / w - p| / p over the collocation points */
  double eu;    /* max |u_n - u_n,exact| / delta, and the lateral displacements / delta, every node */
  double es;    /* max |sigma_nn + p| / p over the elements of both blocks */
  double eF;    /* |total normal force - p A| / (p A) */
} patch_err;

/* One quasi-static step of the patch test; the errors against the closed form. */
static int patch_run(int dim, int ns, int nm, const char *mult, const char *const *sets, int nset,
                     patch_err *E)
{
  const double delta = 1e-4, nu = 0.3, H = 0.5;
  const double Ml = 2e11 * (1 - nu) / ((1 + nu) * (1 - 2 * nu)), Mu = 1e11 * (1 - nu) / ((1 + nu) * (1 - 2 * nu));
  const double p = delta / (H / Ml + H / Mu);
  char text[4096];
  run_t R;
  int st, a, b, D = dim, nrm = dim - 1;
  double F = 0;
  memset(E, 0, sizeof *E);
  if (dim == 2) snprintf(text, sizeof text, patch2d_fmt, ns, nm, mult);
  else snprintf(text, sizeof text, patch3d_fmt, ns, ns, nm, nm, mult);
  if (run_open(&R, text, sets, nset)) return -1;
  if ((st = mo_contact_step(R.D, &R.s, &R.ctx))) {
    diag("%s", R.ctx.errmsg);
    run_free(&R);
    return st;
  }
  E->nc = mo_contact_ncandidates(R.C);
  for (a = 0; a < E->nc; a++) {
    double r = mo_contact_reactions(R.D)[D * a], w = mo_contact_candidate(R.C, a)->w, e = fabs(r / w - p) / p;
    F += r;
    if (e > E->ep) E->ep = e;
  }
  E->eF = fabs(F - p) / p; /* the interface's area is 1 (and thickness 1 in plane strain) */
  for (b = 0; b < 2; b++) {
    const mo_body *B = &R.sc->body[b];
    const mo_mesh *m = B->mesh;
    int e, k, i;
    for (a = 0; a < m->nnode; a++) {
      double y = m->x[a * D + nrm];
      double uex = b == 0 ? -p / Ml * y : -p / Ml * H - p / Mu * (y - H);
      for (i = 0; i < D; i++) {
        double u = R.s.u[B->dof0 + a * D + i], err = fabs(u - (i == nrm ? uex : 0)) / delta;
        if (err > E->eu) E->eu = err;
      }
    }
    for (e = 0; e < m->nelem; e++) {
      double ue[MO_ND_MAX], eps[6], sig[6];
      int nen = m->nen;
      for (k = 0; k < nen; k++)
        for (i = 0; i < D; i++) ue[D * k + i] = R.s.u[B->dof0 + D * m->conn[nen * e + k] + i];
      mo_elem_stress(m, e, B->mat, ue, eps, sig);
      if (fabs(sig[nrm] + p) / p > E->es) E->es = fabs(sig[nrm] + p) / p;
    }
  }
  run_free(&R);
  return 0;
}

static void check_with(int dim, int ns, int nm, const char *mult, const char *integ, const char *extra,
                       const char *extra2, double tol)
{
  char set[128];
  const char *sets[3] = {NULL, NULL, NULL};
  patch_err E;
  int n = 0;
  if (integ) {
    snprintf(set, sizeof set, "contact.pairs.interface.integration=\"%s\"", integ);
    sets[n++] = set;
  }
  if (extra) sets[n++] = extra;
  if (extra2) sets[n++] = extra2;
  if (patch_run(dim, ns, nm, mult, sets, n, &E)) {
    ok(0, "%dD patch test %d against %d runs", dim, ns, nm);
    return;
  }
  diag("%dD, %d against %d elements across, %s multipliers, integration %s%s%s%s%s: %d points; errors: pressure %.2e, "
       "u %.2e, sigma_nn %.2e, total force %.2e", dim, ns, nm, mult, integ ? integ : "(default)", extra ? ", " : "",
       extra ? extra : "", extra2 ? ", " : "", extra2 ? extra2 : "", E.nc, E.ep, E.eu, E.es, E.eF);
  if (tol > 0) {
    ok(E.ep <= tol && E.eu <= tol && E.es <= tol && E.eF <= tol,
       "%dD patch test, %d against %d, %s, %s%s%s%s%s: uniform pressure to %.1e (u %.1e of delta, sigma_nn %.1e, force %.1e; <= %.0e)",
       dim, ns, nm, mult, integ ? integ : "default", extra ? ", " : "", extra ? extra : "", extra2 ? ", " : "",
       extra2 ? extra2 : "", E.ep, E.eu, E.es, E.eF, tol);
  } else {
    /* the old collocation misses the closed form: kept to show why the segments are the default */
    ok(E.ep > 1e-6 && E.es > 1e-6,
       "%dD patch test, %d against %d, %s, whole facets: the closed form is missed (pressure %.1e, sigma_nn %.1e)",
       dim, ns, nm, mult, E.ep, E.es);
  }
}

/* --- the cuts themselves: a master grid turned by 30 degrees ----------------------------------- */

/* An H8 block of n x n x 1 cells of side h, turned by theta about the vertical through (0.5, 0.5),
   its bottom face (set "bottom") at z = 0.5: an MSH 2.2 file. */
static int write_turned_block(const char *path, int n, double h, double theta)
{
  FILE *f = fopen(path, "w");
  int i, j, k, e = 0;
  if (!f) return -1;
  fprintf(f, "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n2\n2 1 \"bottom\"\n3 2 \"block\"\n$EndPhysicalNames\n");
  fprintf(f, "$Nodes\n%d\n", 2 * (n + 1) * (n + 1));
  for (k = 0; k < 2; k++)
    for (j = 0; j <= n; j++)
      for (i = 0; i <= n; i++) {
        double a = (i - 0.5 * n) * h, b = (j - 0.5 * n) * h;
        fprintf(f, "%d %.17g %.17g %.17g\n", 1 + i + (n + 1) * (j + (n + 1) * k), 0.5 + cos(theta) * a - sin(theta) * b,
                0.5 + sin(theta) * a + cos(theta) * b, 0.5 + 0.5 * k);
      }
  fprintf(f, "$EndNodes\n$Elements\n%d\n", 2 * n * n);
#define NODE(i, j, k) (1 + (i) + (n + 1) * ((j) + (n + 1) * (k)))
  for (j = 0; j < n; j++)
    for (i = 0; i < n; i++) {
      fprintf(f, "%d 5 2 2 1 %d %d %d %d %d %d %d %d\n", ++e, NODE(i, j, 0), NODE(i + 1, j, 0), NODE(i + 1, j + 1, 0),
              NODE(i, j + 1, 0), NODE(i, j, 1), NODE(i + 1, j, 1), NODE(i + 1, j + 1, 1), NODE(i, j + 1, 1));
      fprintf(f, "%d 3 2 1 1 %d %d %d %d\n", ++e, NODE(i, j, 0), NODE(i, j + 1, 0), NODE(i + 1, j + 1, 0), NODE(i + 1, j, 0));
    }
#undef NODE
  fprintf(f, "$EndElements\n");
  return fclose(f);
}

/* The 4 x 4 top of the unit box against the bottom of a block turned by 30 degrees that covers it:
   the parts are triangles and polygons of up to six sides. Their points must integrate exactly
   what is polynomial on them: the slave facets' measure, the consistent nodal weights of a uniform
   pressure on the slave nodes (int N_a) and on the master nodes whose support lies under the slave
   face (int N_b = h^2), and int x y = 1/4 over the face. */
static void test_turned_master(void)
{
  static const char *fmt =
    "bodies = (\n"
    "  { name = \"lower\"; mesh = { generator = \"box\"; size = [1.0, 1.0, 0.5]; elements = [4, 4, 2]; };\n"
    "    material = { E = 2.0e11; nu = 0.3; rho = 7800.0; }; fix = ( { set = \"zmin\"; dofs = [\"x\", \"y\", \"z\"]; } ); },\n"
    "  { name = \"upper\"; mesh = { file = \"%s\"; };\n"
    "    material = { E = 1.0e11; nu = 0.3; rho = 7800.0; }; }\n"
    ");\n"
    "time = { scheme = \"quasistatic\"; steps = 1; };\n"
    "contact = { solver = \"levelset\";\n"
    "  pairs = ( { name = \"interface\"; slave = \"lower\"; slave_set = \"zmax\"; master = \"upper\"; master_set = \"bottom\";\n"
    "              collocation = \"gauss\"; gauss = 2; } ); };\n";
  const int n = 10;
  const double h = 0.2, theta = M_PI / 6;
  char path[] = "/tmp/moreau-mortar-XXXXXX", file[64], text[4096];
  mo_ctx ctx;
  mo_case *cs = NULL;
  mo_scene *sc = NULL;
  mo_contact *C = NULL;
  int fd = mkdtemp(path) ? 0 : -1, a, j, off = 0, nc, nmaster = 0;
  double W = 0, xy = 0, es = 0, em = 0, Ns[25] = {0}, *Nm = NULL;
  if (fd == 0) {
    snprintf(file, sizeof file, "%s/turned.msh", path);
    fd = write_turned_block(file, n, h, theta);
  }
  if (fd) { ok(0, "turned master: the mesh file"); return; }
  snprintf(text, sizeof text, fmt, file);
  mo_ctx_init(&ctx);
  ctx.verbosity = 0;
  if (tl_scene(text, "turned.cfg", &cs, &sc, &ctx) || mo_contact_build(sc, &C, &ctx)) {
    ok(0, "turned master: the scene (%s)", ctx.errmsg);
    goto done;
  }
  nc = mo_contact_ncandidates(C);
  Nm = calloc((size_t)sc->body[1].mesh->nnode, sizeof *Nm);
  for (a = 0; a < nc; a++) {
    const mo_candidate *c = mo_contact_candidate(C, a);
    const mo_cpoint *p = mo_contact_point(C, c->point);
    W += c->w;
    xy += c->w * p->x0[0] * p->x0[1];
    off += p->off;
    for (j = 0; j < p->nn; j++) Ns[p->node[j] % 25] += c->w * p->N[j]; /* the top nodes are 50..74 */
    for (j = 0; j < p->mn; j++) Nm[p->mnode[j]] += c->w * p->mN[j];
  }
  for (a = 0; a < 25; a++) {
    int i = a % 5, k = a / 5, edges = (i == 0 || i == 4) + (k == 0 || k == 4);
    double exact = 1.0 / 16 / (edges == 2 ? 4 : edges == 1 ? 2 : 1);
    if (fabs(Ns[a] - exact) / exact > es) es = fabs(Ns[a] - exact) / exact;
  }
  for (a = 0; a < sc->body[1].mesh->nnode; a++) {
    const double *x = &sc->body[1].mesh->x[3 * a];
    int inside = x[2] < 0.75, q;
    for (q = 0; q < 4 && inside; q++) { /* the corners of its support */
      double u = (q & 1 ? 1 : -1) * h, v = (q & 2 ? 1 : -1) * h;
      double X = x[0] + cos(theta) * u - sin(theta) * v, Y = x[1] + sin(theta) * u + cos(theta) * v;
      inside = X > 0 && X < 1 && Y > 0 && Y < 1;
    }
    if (!inside) continue;
    nmaster++;
    if (fabs(Nm[a] - h * h) / (h * h) > em) em = fabs(Nm[a] - h * h) / (h * h);
  }
  diag("turned master: %d points, measure %.17g, int x y %.17g, slave nodal weights %.1e, %d master nodes "
       "under the face %.1e, %d falling off", nc, W, xy, es, nmaster, em, off);
  ok(fabs(W - 1) <= 1e-13 && fabs(xy - 0.25) <= 1e-13 && es <= 1e-12 && off == 0 &&
     mo_contact_pair_get(C, 0)->nseg_fallback == 0,
     "turned master: the segments cover the slave face once (measure 1 %+.1e, int x y 1/4 %+.1e, int N_a %.1e)",
     W - 1, xy - 0.25, es);
  ok(nmaster >= 1 && em <= 1e-12, "turned master: int N_b = h^2 under the slave face (%d master nodes, %.1e)",
     nmaster, em);
done:
  free(Nm);
  mo_contact_free(C);
  mo_scene_free(sc);
  mo_case_free(cs);
  if (fd == 0) {
    remove(file);
    rmdir(path);
  }
}

/* A master narrower than the slave. In 2D the part of a slave facet past the master's edge is a
   segment of its own, and the facets with no master in front keep their points; in 3D a facet
   that the master covers in part keeps the points of the whole facet. */
static void test_partial_cover(void)
{
  char text[4096], *s;
  run_t R;
  snprintf(text, sizeof text, patch2d_fmt, 12, 7, "p0");
  /* the upper block 0.7 wide: slave facets 0..7 lie under it, 8 straddles its edge, 9..11 are past it */
  if ((s = strstr(text, "size = [1.0, 0.5]; elements = [7"))) memcpy(s, "size = [0.7, 0.5]", 17);
  if (run_open(&R, text, NULL, 0)) { ok(0, "partial cover: 2D scene"); return; }
  /* under it, the master nodes 0.1, 0.2, 0.3, 0.4 and 0.6 cut five of the eight facets (0.5 is a
     slave node): 13 segments; facet 8 is cut at 0.7; 3 whole facets: 18 segments of two points */
  ok(mo_contact_pair_get(R.C, 0)->nseg_fallback == 0 && mo_contact_ncandidates(R.C) == 18 * 2,
     "partial cover, 2D: the edge of the master cuts a slave facet like a node (%d points, %d whole facets)",
     mo_contact_ncandidates(R.C), mo_contact_pair_get(R.C, 0)->nseg_fallback);
  run_free(&R);
  snprintf(text, sizeof text, patch3d_fmt, 4, 4, 3, 3, "p0");
  /* the upper block 0.7 deep in x: the column of slave facets over x in [0.5, 0.75] straddles its edge */
  if ((s = strstr(text, "size = [1.0, 1.0, 0.5]; elements = [3"))) memcpy(s, "size = [0.7, 1.0, 0.5]", 22);
  if (run_open(&R, text, NULL, 0)) { ok(0, "partial cover: 3D scene"); return; }
  ok(mo_contact_pair_get(R.C, 0)->nseg_fallback == 4,
     "partial cover, 3D: the 4 slave facets the master's edge crosses keep whole-facet points (%d)",
     mo_contact_pair_get(R.C, 0)->nseg_fallback);
  run_free(&R);
}

static void check(int dim, int ns, int nm, const char *mult, const char *integ, double tol)
{
  check_with(dim, ns, nm, mult, integ, NULL, NULL, tol);
}

int main(void)
{
  /* segmented integration, the default */
  check(2, 12, 11, "p0", NULL, 1e-10);
  check(2, 12, 11, "p1", NULL, 1e-10);
  check(2, 11, 12, "p0", NULL, 1e-10);
  check(3, 4, 3, "p0", NULL, 1e-10);
  check(3, 3, 4, "p0", NULL, 1e-10);
  check(3, 4, 3, "p1", NULL, 1e-10);
  /* the KKT path on the same points */
  check_with(2, 12, 11, "p0", NULL, "contact.levelset.path=\"kkt\"", NULL, 1e-10);
  /* the pointwise stabilization perturbs nothing where the gaps vanish pointwise (BDZ07 §6.4) */
  check_with(2, 12, 11, "p0", NULL, "contact.levelset.k_n=1.0e12", "contact.levelset.stabilization=\"unprojected\"", 1e-10);
  /* matching meshes: the segments are the facets */
  check(2, 12, 12, "p0", NULL, 1e-10);
  check(3, 4, 4, "p0", NULL, 1e-10);
  /* the Gauss points of whole facets */
  check(2, 12, 11, "p0", "facet", 0);
  check(3, 4, 3, "p0", "facet", 0);
  /* tetrahedra: triangular facets cut by triangles (T4 against T4, against H8), and whole T10 faces */
  check_with(3, 4, 3, "auto", NULL, "bodies.lower.mesh.element=\"T4\"", "bodies.upper.mesh.element=\"T4\"", 1e-10);
  check_with(3, 3, 4, "p1", NULL, "bodies.lower.mesh.element=\"T4\"", "bodies.upper.mesh.element=\"T4\"", 1e-10);
  check_with(3, 4, 3, "auto", NULL, "bodies.lower.mesh.element=\"T4\"", NULL, 1e-10);
  check_with(3, 4, 3, "p0", NULL, NULL, "bodies.upper.mesh.element=\"T4\"", 1e-10);
  check_with(3, 4, 4, "p0", NULL, "bodies.lower.mesh.element=\"T10\"", "bodies.upper.mesh.element=\"T10\"", 1e-10);
  check_with(3, 4, 3, "p0", NULL, "bodies.lower.mesh.element=\"T10\"", "bodies.upper.mesh.element=\"T10\"", 0);
  test_turned_master();
  test_partial_cover();
  return done_testing();
}
