/* test_mesh.c: structured generators, sets, boundary facets, geometric checks. */
#include "config.h"
#include <moreau/mesh.h>
#include <moreau/fe.h>
#include "tap.h"

static double total_measure(const mo_mesh *m, mo_hypothesis h)
{
  mo_material mat = {MO_MAT_ELASTIC, 1, 0, 1, 0, 0, h, 1, 1};
  double s = 0;
  int e;
  for (e = 0; e < m->nelem; e++) s += mo_elem_measure(m, e, &mat);
  return s;
}

int main(void)
{
  mo_ctx ctx;
  mo_mesh *m;
  const mo_facetset *fs;
  const mo_nodeset *ns;
  int *ids, n, f, d;
  double hmin, hmax;
  mo_ctx_init(&ctx);

  ok(mo_mesh_bar(0.5, 2.0, 10, &m, &ctx) == MO_OK, "bar generated");
  ok(m->nnode == 11 && m->nelem == 10 && m->dim == 1, "bar: 11 nodes, 10 elements");
  is_close(m->x[10], 2.5, 0, "bar: last node exactly at origin + length");
  ns = mo_mesh_find_nodeset(m, "right");
  ok(ns && ns->n == 1 && ns->node[0] == 10, "bar: 'right' is the last node");
  fs = mo_mesh_find_facetset(m, "left");
  ok(fs && fs->n == 1 && fs->node[0] == 0 && fs->lface[0] == 0, "bar: 'left' facet is the first end");
  mo_mesh_edge_range(m, &hmin, &hmax);
  is_close(hmin, 0.2, 1e-15, "bar: element length");
  mo_mesh_free(m);

  {
    double o[2] = {0, 0}, s[2] = {0.04, 0.04};
    int ne[2] = {16, 8};
    ok(mo_mesh_rectangle(o, s, ne, MO_EL_T3, MO_DIAG_RIGHT, &m, &ctx) == MO_OK, "GRECO T3 mesh generated");
    ok(m->nnode == 153 && m->nelem == 256, "16 x 8 rectangles: 153 nodes, 256 T3 (Jean's mesh)");
    ok(m->conn[0] == 0 && m->conn[1] == 1 && m->conn[2] == 17 && m->conn[3] == 1 && m->conn[4] == 18 && m->conn[5] == 17,
       "first cell split into (a,b,d) + (b,c,d)");
    fs = mo_mesh_find_facetset(m, "bottom");
    ok(fs && fs->n == 16, "bottom facet set has 16 edges");
    {
      int outward = 1;
      for (f = 0; f < fs->n; f++) {
        double nrm[2], len;
        mo_facet_normal(m, fs, f, nrm, &len);
        if (!(fabs(nrm[0]) < 1e-14 && fabs(nrm[1] + 1) < 1e-14 && fabs(len - 0.0025) < 1e-15)) outward = 0;
      }
      ok(outward, "bottom edges: outward normal (0, -1), length 2.5 mm");
    }
    ok(mo_mesh_nodeset_resolve(m, "right&bottom", &ids, &n, &ctx) == MO_OK && n == 1 && ids[0] == 16,
       "intersection 'right&bottom' is the corner (0.04, 0)");
    mo_free(ids);
    ok(mo_mesh_nodeset_resolve(m, "rigth", &ids, &n, &ctx) == MO_EINPUT && strstr(ctx.errmsg, "no node set 'rigth'"),
       "unknown set named in the error");
    mo_ctx_clear_error(&ctx);
    is_close(total_measure(m, MO_HYP_PLANE_STRAIN), 0.04 * 0.04, 1e-14 * 0.04 * 0.04, "T3 areas sum to the square's");
    mo_mesh_free(m);
  }
  {
    double o[2] = {0, 0}, s[2] = {2, 1};
    int ne[2] = {4, 3};
    mo_diag dg;
    for (dg = MO_DIAG_RIGHT; dg <= MO_DIAG_UNION_JACK; dg++) {
      ok(mo_mesh_rectangle(o, s, ne, MO_EL_T3, dg, &m, &ctx) == MO_OK && mo_mesh_check(m, &ctx) == MO_OK,
         "T3 pattern %d: all triangles positive", (int)dg);
      is_close(total_measure(m, MO_HYP_PLANE_STRESS), 2, 1e-14, "T3 pattern %d: area", (int)dg);
      mo_mesh_free(m);
    }
    ok(mo_mesh_rectangle(o, s, ne, MO_EL_Q4, MO_DIAG_RIGHT, &m, &ctx) == MO_OK, "Q4 rectangle generated");
    fs = mo_mesh_find_facetset(m, "top");
    ok(fs && fs->n == 4, "top: 4 edges");
    {
      int outward = 1;
      for (f = 0; f < fs->n; f++) {
        double nrm[2];
        mo_facet_normal(m, fs, f, nrm, NULL);
        if (fabs(nrm[1] - 1) > 1e-14) outward = 0;
      }
      ok(outward, "top edges point up");
    }
    is_close(total_measure(m, MO_HYP_AXISYMMETRIC), M_PI * 4 * 1, 1e-12, "axisymmetric ring volume pi (r2^2 - r1^2) h");
    /* an inverted element is caught */
    { int t = m->conn[1]; m->conn[1] = m->conn[3]; m->conn[3] = t; }
    ok(mo_mesh_check(m, &ctx) == MO_EINPUT && strstr(ctx.errmsg, "element 0 (Q4) is inverted"),
       "inverted element reported: %s", ctx.errmsg);
    mo_ctx_clear_error(&ctx);
    mo_mesh_free(m);
  }
  {
    double o[3] = {0, 0, 0}, s[3] = {1, 2, 3};
    int ne[3] = {2, 3, 4};
    ok(mo_mesh_box(o, s, ne, &m, &ctx) == MO_OK && mo_mesh_check(m, &ctx) == MO_OK, "H8 box generated, positive");
    ok(m->nnode == 3 * 4 * 5 && m->nelem == 24, "box: node and element counts");
    is_close(total_measure(m, MO_HYP_3D), 6, 1e-13, "box volume");
    for (d = 0; d < 6; d++) {
      static const char *nm[6] = {"xmin", "xmax", "ymin", "ymax", "zmin", "zmax"};
      static const int cnt[6] = {12, 12, 8, 8, 6, 6};
      int good = 1;
      fs = mo_mesh_find_facetset(m, nm[d]);
      if (!fs || fs->n != cnt[d]) good = 0;
      for (f = 0; good && f < fs->n; f++) {
        double nrm[3], area;
        mo_facet_normal(m, fs, f, nrm, &area);
        if (fabs(nrm[d / 2] - (d % 2 ? 1 : -1)) > 1e-14) good = 0;
      }
      ok(good, "box face set %s: %d faces, outward normals", nm[d], cnt[d]);
    }
    mo_mesh_free(m);
  }
  {
    double c[2] = {0, 0.03};
    ok(mo_mesh_disk(c, 0.03, 8, 4, &m, &ctx) == MO_OK && mo_mesh_check(m, &ctx) == MO_OK, "disk generated, positive");
    is_close(total_measure(m, MO_HYP_PLANE_STRAIN), M_PI * 0.03 * 0.03, 0.01 * M_PI * 0.03 * 0.03, "disk area within 1%% of pi r^2");
    ns = mo_mesh_find_nodeset(m, "bottom_point");
    ok(ns && ns->n == 1 && fabs(m->x[2 * ns->node[0]]) < 1e-15 && fabs(m->x[2 * ns->node[0] + 1]) < 1e-15,
       "disk bottom point at (0, 0)");
    fs = mo_mesh_find_facetset(m, "boundary");
    ok(fs && fs->n == 32, "disk boundary: 32 edges");
    mo_mesh_free(m);
  }
  return done_testing();
}
