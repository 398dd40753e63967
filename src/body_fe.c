/* body_fe.c: the deformable body (a finite-element mesh, its material, supports, loads and
   initial fields) and the rigid plane obstacle, as kinds of body (moreau/body.h). */
#include "config.h"
#include <moreau/body.h>
#include <moreau/material.h>
#include "case_internal.h"
#include "scene_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const xyz_vars[] = {"x", "y", "z"};
static const char *const t_var[] = {"t"};

/* --- meshes ---------------------------------------------------------------------------------- */

/* A Gmsh file (path relative to the case file), scaled and translated. */
static int read_mesh_file(const mo_case *cs, const config_setting_t *mg, mo_mesh **out, mo_ctx *ctx)
{
  static const char *gen_keys[] = {"length", "origin", "size", "elements", "element", "diagonal",
                                   "center", "radius", "core", "rings"};
  const config_setting_t *fs = mo_cfg_member(mg, "file");
  const char *file = mo_cfg_string(mg, "file", "");
  char path[4096];
  mo_gmsh_options o;
  size_t k;
  int n, st;
  *out = NULL;
  for (k = 0; k < MO_COUNT(gen_keys); k++)
    if (mo_cfg_member(mg, gen_keys[k]))
      return mo_case_error(cs, mo_cfg_member(mg, gen_keys[k]), ctx,
                           "belongs to the generators: a mesh file brings its own geometry (place it "
                           "with 'scale' and 'translate')");
  if (!file[0]) return mo_case_error(cs, fs, ctx, "the file name is empty");
  n = file[0] == '/' ? snprintf(path, sizeof path, "%s", file)
                     : snprintf(path, sizeof path, "%s/%s", mo_case_dir(cs), file);
  if (n < 0 || (size_t)n >= sizeof path) return mo_case_error(cs, fs, ctx, "the path is too long");
  memset(&o, 0, sizeof o);
  o.scale = mo_cfg_float(mg, "scale", 1);
  n = mo_cfg_count(mg, "translate");
  for (k = 0; k < (size_t)n && k < 3; k++) o.translate[k] = mo_cfg_num_at(mg, "translate", (int)k);
  if ((st = mo_mesh_read_gmsh(path, &o, out, NULL, ctx))) return mo_scene_relocate(cs, fs, ctx);
  if (n && n != (*out)->dim) {
    int dim = (*out)->dim;
    mo_mesh_free(*out);
    *out = NULL;
    return mo_case_error(cs, mo_cfg_member(mg, "translate"), ctx, "needs %d values for this %dD mesh",
                         dim, dim);
  }
  return MO_OK;
}

int mo_body_build_mesh(const mo_case *cs, const config_setting_t *mg, mo_mesh **out, mo_ctx *ctx)
{
  const char *gen = mo_cfg_string(mg, "generator", "");
  const config_setting_t *sets, *ms;
  mo_mesh *m = NULL;
  int st, i, k;
  *out = NULL;
  if (mo_cfg_member(mg, "generator") && mo_cfg_member(mg, "file"))
    return mo_case_error(cs, mo_cfg_member(mg, "file"), ctx, "a mesh has a 'generator' or a 'file', not both");
  if (mo_cfg_member(mg, "file")) {
    if ((st = read_mesh_file(cs, mg, &m, ctx))) return st;
  } else if (!mo_cfg_member(mg, "generator")) {
    return mo_case_error(cs, mg, ctx, "a mesh needs a 'generator' or a 'file'");
  } else if ((ms = mo_cfg_member(mg, "scale")) || (ms = mo_cfg_member(mg, "translate"))) {
    return mo_case_error(cs, ms, ctx, "applies to mesh files only (move the generator's 'origin')");
  } else if (!strcmp(gen, "bar")) {
    if ((st = mo_scene_need(cs, mg, "length", "a bar mesh", ctx)) ||
        (st = mo_scene_need_len(cs, mg, "elements", 1, "a bar mesh", ctx)))
      return st;
    if (mo_cfg_count(mg, "origin") > 1)
      return mo_case_error(cs, mo_cfg_member(mg, "origin"), ctx, "a bar's origin is one number");
    st = mo_mesh_bar(mo_cfg_count(mg, "origin") ? mo_cfg_num_at(mg, "origin", 0) : 0,
                     mo_cfg_float(mg, "length", 1), (int)mo_cfg_num_at(mg, "elements", 0), &m, ctx);
  } else if (!strcmp(gen, "rectangle")) {
    double o[2] = {0, 0}, s[2];
    int n[2];
    const char *el = mo_cfg_string(mg, "element", "Q4"), *dg = mo_cfg_string(mg, "diagonal", "right");
    mo_diag d = MO_DIAG_RIGHT;
    if ((st = mo_scene_need_len(cs, mg, "size", 2, "a rectangle mesh", ctx)) ||
        (st = mo_scene_need_len(cs, mg, "elements", 2, "a rectangle mesh", ctx)))
      return st;
    if (mo_cfg_count(mg, "origin") && (st = mo_scene_need_len(cs, mg, "origin", 2, "a rectangle mesh", ctx)))
      return st;
    for (k = 0; k < 2; k++) {
      if (mo_cfg_count(mg, "origin")) o[k] = mo_cfg_num_at(mg, "origin", k);
      s[k] = mo_cfg_num_at(mg, "size", k);
      n[k] = (int)mo_cfg_num_at(mg, "elements", k);
    }
    if (!strcmp(dg, "left")) d = MO_DIAG_LEFT;
    else if (!strcmp(dg, "alternate")) d = MO_DIAG_ALTERNATE;
    else if (!strcmp(dg, "union_jack")) d = MO_DIAG_UNION_JACK;
    if (strcmp(el, "Q4") && strcmp(el, "T3") && strcmp(el, "T6"))
      return mo_case_error(cs, mo_cfg_member(mg, "element"), ctx, "a rectangle is meshed with Q4, T3 or T6 (%s is a "
                           "3D element)", el);
    if (mo_cfg_member(mg, "diagonal") && !strcmp(el, "Q4"))
      return mo_case_error(cs, mo_cfg_member(mg, "diagonal"), ctx, "only T3 and T6 meshes have diagonals");
    st = mo_mesh_rectangle(o, s, n, !strcmp(el, "T3") ? MO_EL_T3 : !strcmp(el, "T6") ? MO_EL_T6 : MO_EL_Q4, d, &m, ctx);
  } else if (!strcmp(gen, "box")) {
    double o[3] = {0, 0, 0}, s[3];
    int n[3];
    const char *el = mo_cfg_string(mg, "element", "H8");
    if (strcmp(el, "H8") && strcmp(el, "T4") && strcmp(el, "T10"))
      return mo_case_error(cs, mo_cfg_member(mg, "element"), ctx, "a box is meshed with H8, T4 or T10 (%s is a 2D "
                           "element)", el);
    if (mo_cfg_member(mg, "diagonal"))
      return mo_case_error(cs, mo_cfg_member(mg, "diagonal"), ctx, "a box's tetrahedra follow Kuhn's split; 'diagonal' is "
                           "the rectangle's");
    if ((st = mo_scene_need_len(cs, mg, "size", 3, "a box mesh", ctx)) ||
        (st = mo_scene_need_len(cs, mg, "elements", 3, "a box mesh", ctx)))
      return st;
    if (mo_cfg_count(mg, "origin") && (st = mo_scene_need_len(cs, mg, "origin", 3, "a box mesh", ctx)))
      return st;
    for (k = 0; k < 3; k++) {
      if (mo_cfg_count(mg, "origin")) o[k] = mo_cfg_num_at(mg, "origin", k);
      s[k] = mo_cfg_num_at(mg, "size", k);
      n[k] = (int)mo_cfg_num_at(mg, "elements", k);
    }
    if ((double)n[0] * n[1] * n[2] * (strcmp(el, "H8") ? 6 : 1) > 1e7)
      return mo_case_error(cs, mo_cfg_member(mg, "elements"), ctx, "%d x %d x %d cells%s exceed the limit of 10^7 "
                           "elements", n[0], n[1], n[2], strcmp(el, "H8") ? " of 6 tetrahedra" : "");
    st = mo_mesh_box_elements(o, s, n, !strcmp(el, "T4") ? MO_EL_T4 : !strcmp(el, "T10") ? MO_EL_T10 : MO_EL_H8, &m, ctx);
  } else if (!strcmp(gen, "disk")) {
    double c[2] = {0, 0};
    int core = mo_cfg_int(mg, "core", 8);
    if ((st = mo_scene_need(cs, mg, "radius", "a disk mesh", ctx))) return st;
    if (core % 2)
      return mo_case_error(cs, mo_cfg_member(mg, "core"), ctx, "the core division must be even");
    if (mo_cfg_count(mg, "center")) {
      c[0] = mo_cfg_num_at(mg, "center", 0);
      c[1] = mo_cfg_num_at(mg, "center", 1);
    }
    st = mo_mesh_disk(c, mo_cfg_float(mg, "radius", 1), core, mo_cfg_int(mg, "rings", 4), &m, ctx);
  } else
    return mo_case_error(cs, mg, ctx, "unknown generator '%s'", gen);
  if (st) return mo_scene_relocate(cs, mg, ctx);
  if ((st = mo_mesh_check(m, ctx))) {
    mo_mesh_free(m);
    return st;
  }
  sets = mo_cfg_member(mg, "sets");
  for (i = 0; sets && i < config_setting_length(sets); i++) {
    const config_setting_t *sg = config_setting_get_elem(sets, (unsigned)i);
    const char *name = mo_cfg_string(sg, "name", "");
    int hasbox = mo_cfg_member(sg, "box") != NULL, hasnodes = mo_cfg_member(sg, "nodes") != NULL;
    if (hasbox == hasnodes) {
      mo_mesh_free(m);
      return mo_case_error(cs, sg, ctx, "a set is defined by exactly one of 'box' or 'nodes'");
    }
    if (hasbox) {
      double lo[3], hi[3], ext = 0;
      int d;
      if (mo_cfg_count(sg, "box") != 2 * m->dim) {
        int dim = m->dim;
        mo_mesh_free(m);
        return mo_case_error(cs, mo_cfg_member(sg, "box"), ctx, "needs %d values in %dD", 2 * dim, dim);
      }
      for (d = 0; d < m->dim; d++) {
        lo[d] = mo_cfg_num_at(sg, "box", 2 * d);
        hi[d] = mo_cfg_num_at(sg, "box", 2 * d + 1);
        if (hi[d] - lo[d] > ext) ext = hi[d] - lo[d];
      }
      mo_mesh_edge_range(m, &ext, NULL);
      st = mo_mesh_add_box_set(m, name, lo, hi, 1e-6 * ext, ctx);
    } else {
      int n = mo_cfg_count(sg, "nodes"), *ids = mo_malloc(ctx, (size_t)n * sizeof(int));
      if (!ids) { mo_mesh_free(m); return MO_ENOMEM; }
      for (k = 0; k < n; k++) ids[k] = (int)mo_cfg_num_at(sg, "nodes", k);
      st = mo_mesh_add_nodeset(m, name, ids, n, ctx);
      if (!st) st = mo_mesh_add_facetset_from_nodes(m, name, ids, n, ctx);
      mo_free(ids);
    }
    if (st) {
      char msg[MO_ERRMSG_MAX];
      snprintf(msg, sizeof msg, "%s", ctx->errmsg);
      mo_ctx_clear_error(ctx);
      mo_mesh_free(m);
      return mo_case_error(cs, sg, ctx, "%s", msg);
    }
  }
  *out = m;
  return MO_OK;
}

static int build_material(const mo_case *cs, const config_setting_t *g, const mo_mesh *msh,
                          mo_material *mat, mo_ctx *ctx)
{
  const config_setting_t *h = mo_cfg_member(g, "hypothesis"), *mk = mo_cfg_member(g, "model");
  const char *model = mo_cfg_string(g, "model", "elastic");
  int dim = msh->dim, st;
  memset(mat, 0, sizeof *mat);
  mat->model = !strcmp(model, "j2") ? MO_MAT_J2 : MO_MAT_ELASTIC;
  mat->E = mo_cfg_float(g, "E", 0);
  mat->nu = mo_cfg_float(g, "nu", 0);
  mat->rho = mo_cfg_float(g, "rho", 0);
  mat->sigma_y = mo_cfg_float(g, "sigma_y", 0);
  mat->Et = mo_cfg_float(g, "Et", 0);
  mat->area = mo_cfg_float(g, "area", 1);
  mat->thickness = mo_cfg_float(g, "thickness", 1);
  if (dim == 1) {
    mat->hyp = MO_HYP_BAR;
    if (h) return mo_case_error(cs, h, ctx, "only 2D bodies take a hypothesis");
  } else if (dim == 3) {
    mat->hyp = MO_HYP_3D;
    if (h) return mo_case_error(cs, h, ctx, "only 2D bodies take a hypothesis");
  } else {
    const char *hs = mo_cfg_string(g, "hypothesis", "plane_strain");
    mat->hyp = !strcmp(hs, "plane_stress") ? MO_HYP_PLANE_STRESS
               : !strcmp(hs, "axisymmetric") ? MO_HYP_AXISYMMETRIC : MO_HYP_PLANE_STRAIN;
  }
  if (dim != 1 && mo_cfg_member(g, "area"))
    return mo_case_error(cs, mo_cfg_member(g, "area"), ctx, "only 1D bodies take an area");
  if ((dim != 2 || mat->hyp == MO_HYP_AXISYMMETRIC) && mo_cfg_member(g, "thickness"))
    return mo_case_error(cs, mo_cfg_member(g, "thickness"), ctx,
                         "only plane strain and plane stress bodies take a thickness");
  if (mat->model == MO_MAT_ELASTIC) { /* elastic or hencky */
    const config_setting_t *s = mo_cfg_member(g, "sigma_y") ? mo_cfg_member(g, "sigma_y") : mo_cfg_member(g, "Et");
    if (s) return mo_case_error(cs, s, ctx, "only material model 'j2' takes '%s'", config_setting_name(s));
  }
  if (!strcmp(model, "elastic")) return MO_OK;
  /* finite strains: hencky (hyperelastic) or j2 (doc/theory.md §7) */
  if (mat->hyp == MO_HYP_BAR || mat->hyp == MO_HYP_PLANE_STRESS)
    return mo_case_error(cs, mat->hyp == MO_HYP_BAR || !h ? mk : h, ctx,
                         "material model '%s' (finite strains) needs plane strain, axisymmetry or 3D, "
                         "not %s", model, mat->hyp == MO_HYP_BAR ? "a 1D bar" : "plane stress");
  if (mo_elem_nl_npoint(msh->type, mat->hyp) <= 0)
    return mo_case_error(cs, mk, ctx, "material model '%s' (finite strains) has no %s element in %s",
                         model, mo_eltype_get(msh->type)->name, mo_hyp_name(mat->hyp));
  if (mat->model == MO_MAT_J2 && !mo_cfg_member(g, "sigma_y"))
    return mo_case_error(cs, g, ctx, "material model 'j2' needs the yield stress 'sigma_y'");
  if (mat->model == MO_MAT_J2 && !(mat->Et < mat->E))
    return mo_case_error(cs, mo_cfg_member(g, "Et"), ctx,
                         "the tangent modulus Et = %g must be below E = %g (Et >= E would be a "
                         "softening or infinite hardening modulus H = E Et / (E - Et))", mat->Et, mat->E);
  if ((st = mo_j2_check(mat, ctx))) return mo_scene_relocate(cs, mk ? mk : g, ctx);
  return MO_OK;
}

/* --- dofs, conditions, loads ----------------------------------------------------------------- */

/* Component of a nodal dof name (x, y, z), 3 for a rotation name (rigid bodies only). */
static int dof_of_letter(const char *s)
{
  return !strcmp(s, "x") ? 0 : !strcmp(s, "y") ? 1 : !strcmp(s, "z") ? 2 : 3;
}

static int build_conditions(mo_scene *sc, const mo_case *cs, const config_setting_t *bg, int b,
                            int *owner, mo_ctx *ctx)
{
  mo_body *B = &sc->body[b];
  const config_setting_t *fl = mo_cfg_member(bg, "fix"), *pl = mo_cfg_member(bg, "prescribed");
  int i, k, c, st, D = sc->dim;
  for (i = 0; fl && i < config_setting_length(fl); i++) {
    const config_setting_t *fg = config_setting_get_elem(fl, (unsigned)i);
    int *ids, n, comp[3] = {0, 0, 0};
    int nd = mo_cfg_count(fg, "dofs");
    if (nd == 0) comp[0] = comp[1] = comp[2] = 1;
    if (!mo_cfg_member(fg, "set")) return mo_case_error(cs, fg, ctx, "a deformable body's fix needs a node 'set'");
    for (k = 0; k < nd; k++) {
      const char *s = mo_cfg_string_at(fg, "dofs", k);
      if (!strcmp(s, "all")) comp[0] = comp[1] = comp[2] = 1;
      else {
        c = dof_of_letter(s);
        if (c >= D)
          return mo_case_error(cs, mo_cfg_member(fg, "dofs"), ctx, "component '%s' does not exist %s", s,
                               c == 3 ? "for a deformable body (its dofs are nodal translations)" : D == 1 ? "in 1D" : "in 2D");
        comp[c] = 1;
      }
    }
    if (mo_mesh_nodeset_resolve(B->mesh, mo_cfg_string(fg, "set", ""), &ids, &n, ctx))
      return mo_scene_relocate(cs, mo_cfg_member(fg, "set"), ctx);
    if (n == 0) {
      mo_free(ids);
      return mo_case_error(cs, mo_cfg_member(fg, "set"), ctx, "the set selects no node");
    }
    for (k = 0; k < n; k++)
      for (c = 0; c < D; c++)
        if (comp[c]) {
          st = mo_scene_add_presc(sc, B->dof0 + ids[k] * D + c, MO_PRESC_FIX, 0, NULL, owner, ctx);
          if (st < 0) {
            mo_free(ids);
            return mo_case_error(cs, fg, ctx, "node %d, component %c is both fixed and prescribed", ids[k], "xyz"[c]);
          }
          if (st == MO_ENOMEM) { mo_free(ids); return st; }
        }
    mo_free(ids);
  }
  for (i = 0; pl && i < config_setting_length(pl); i++) {
    const config_setting_t *pg = config_setting_get_elem(pl, (unsigned)i);
    int *ids, n, hv = mo_cfg_member(pg, "velocity") != NULL, hd = mo_cfg_member(pg, "displacement") != NULL;
    c = dof_of_letter(mo_cfg_string(pg, "dof", "x"));
    if (c >= D)
      return mo_case_error(cs, mo_cfg_member(pg, "dof"), ctx, "component does not exist %s",
                           c == 3 ? "for a deformable body (its dofs are nodal translations)" : D == 1 ? "in 1D" : "in 2D");
    if (!mo_cfg_member(pg, "set")) return mo_case_error(cs, pg, ctx, "a deformable body's prescribed motion needs a node 'set'");
    if (hv == hd)
      return mo_case_error(cs, pg, ctx, "give exactly one of 'velocity' or 'displacement'");
    if (mo_mesh_nodeset_resolve(B->mesh, mo_cfg_string(pg, "set", ""), &ids, &n, ctx))
      return mo_scene_relocate(cs, mo_cfg_member(pg, "set"), ctx);
    if (n == 0) {
      mo_free(ids);
      return mo_case_error(cs, mo_cfg_member(pg, "set"), ctx, "the set selects no node");
    }
    for (k = 0; k < n; k++) {
      mo_expr *e = NULL;
      if (hd && (st = mo_scene_compile(cs, pg, "displacement", 0, t_var, 1, &e, ctx))) {
        mo_free(ids);
        return st;
      }
      st = mo_scene_add_presc(sc, B->dof0 + ids[k] * D + c, hv ? MO_PRESC_VELOCITY : MO_PRESC_EXPR,
                     mo_cfg_float(pg, "velocity", 0), e, owner, ctx);
      if (st) {
        int node = ids[k];
        mo_expr_free(e);
        mo_free(ids);
        if (st == MO_ENOMEM) return st;
        return mo_case_error(cs, pg, ctx, "node %d, component %c is already fixed or prescribed", node, "xyz"[c]);
      }
      if (hv && mo_cfg_float(pg, "velocity", 0) != 0) sc->has_moving_presc = 1;
      if (hd) sc->has_moving_presc = 1;
    }
    mo_free(ids);
  }
  return MO_OK;
}

typedef struct {
  int ncomp;
  mo_expr *e[3];
  double scale; /* pressure sign */
  int pressure;
  const double *pervals; /* per-facet pressure values */
  int facet;
} traction_data;

static void traction_cb(const double *x, const double *n, void *data, double *t)
{
  traction_data *T = data;
  double xv[3] = {x[0], 0, 0};
  int i, D = T->ncomp;
  if (D > 1) xv[1] = x[1];
  if (D > 2) xv[2] = x[2];
  if (T->pressure) {
    double p = T->pervals ? T->pervals[T->facet] : mo_expr_eval(T->e[0], xv);
    for (i = 0; i < D; i++) t[i] = -p * n[i];
  } else
    for (i = 0; i < D; i++) t[i] = mo_expr_eval(T->e[i], xv);
}

static int build_loads(mo_scene *sc, const mo_case *cs, const config_setting_t *bg, int b,
                       double *f, mo_ctx *ctx)
{
  mo_body *B = &sc->body[b];
  mo_mesh *m = B->mesh;
  const config_setting_t *ll = mo_cfg_member(bg, "loads");
  int i, k, a, c, st, D = sc->dim;
  for (i = 0; ll && i < config_setting_length(ll); i++) {
    const config_setting_t *lg = config_setting_get_elem(ll, (unsigned)i);
    const char *type = mo_cfg_string(lg, "type", "nodal"), *set = mo_cfg_string(lg, "set", "");
    int hv = mo_cfg_member(lg, "value") != NULL, hvs = mo_cfg_member(lg, "values") != NULL;
    mo_expr *amp = NULL;
    memset(f, 0, (size_t)sc->ndof * sizeof *f);
    if (hv == hvs) return mo_case_error(cs, lg, ctx, "give exactly one of 'value' or 'values'");
    if ((st = mo_scene_compile(cs, lg, "amplitude", 0, t_var, 1, &amp, ctx))) return st;
    if (!strcmp(type, "nodal")) {
      int *ids, n;
      if (mo_mesh_nodeset_resolve(m, set, &ids, &n, ctx)) {
        mo_expr_free(amp);
        return mo_scene_relocate(cs, mo_cfg_member(lg, "set"), ctx);
      }
      if (hv) {
        mo_expr *e[3] = {NULL, NULL, NULL};
        if (mo_cfg_count(lg, "value") != D) {
          mo_free(ids);
          mo_expr_free(amp);
          return mo_case_error(cs, mo_cfg_member(lg, "value"), ctx, "a nodal force has %d components here", D);
        }
        for (c = 0; c < D; c++)
          if ((st = mo_scene_compile(cs, lg, "value", c, xyz_vars, D, &e[c], ctx))) break;
        for (k = 0; !st && k < n; k++)
          for (c = 0; c < D; c++) f[B->dof0 + ids[k] * D + c] += mo_expr_eval(e[c], &m->x[ids[k] * D]);
        for (c = 0; c < 3; c++) mo_expr_free(e[c]);
      } else {
        double dir[3] = {0, 0, 0};
        if (mo_cfg_count(lg, "values") != n) {
          mo_free(ids);
          mo_expr_free(amp);
          return mo_case_error(cs, mo_cfg_member(lg, "values"), ctx, "has %d values for the %d nodes of set '%s'", mo_cfg_count(lg, "values"), n, set);
        }
        if (mo_cfg_count(lg, "direction") != D) {
          mo_free(ids);
          mo_expr_free(amp);
          return mo_case_error(cs, lg, ctx, "nodal 'values' need a 'direction' of %d components", D);
        }
        for (c = 0; c < D; c++) dir[c] = mo_cfg_num_at(lg, "direction", c);
        /* values in the set's node order: sorted by node number */
        for (k = 0; k < n; k++)
          for (c = 0; c < D; c++) f[B->dof0 + ids[k] * D + c] += mo_cfg_num_at(lg, "values", k) * dir[c];
      }
      mo_free(ids);
      if (st) { mo_expr_free(amp); return st; }
    } else { /* pressure, traction on facets */
      const mo_facetset *fs = mo_mesh_find_facetset(m, set);
      traction_data T;
      double fe[3 * MO_FNODE_MAX], *vals = NULL;
      memset(&T, 0, sizeof T);
      if (!fs || fs->n == 0) {
        mo_expr_free(amp);
        return mo_case_error(cs, mo_cfg_member(lg, "set"), ctx, "no boundary facets in set '%s'", set);
      }
      T.ncomp = D;
      T.pressure = !strcmp(type, "pressure");
      if (T.pressure) {
        if (hv && mo_cfg_count(lg, "value") != 1) {
          mo_expr_free(amp);
          return mo_case_error(cs, mo_cfg_member(lg, "value"), ctx, "a pressure is one value");
        }
        if (hv) st = mo_scene_compile(cs, lg, "value", 0, xyz_vars, D, &T.e[0], ctx);
        else {
          if (mo_cfg_count(lg, "values") != fs->n) {
            mo_expr_free(amp);
            return mo_case_error(cs, mo_cfg_member(lg, "values"), ctx, "has %d values for the %d facets of set '%s'", mo_cfg_count(lg, "values"), fs->n, set);
          }
          vals = mo_malloc(ctx, (size_t)fs->n * sizeof *vals);
          if (!vals) st = MO_ENOMEM;
          for (k = 0; !st && k < fs->n; k++) vals[k] = mo_cfg_num_at(lg, "values", k);
          T.pervals = vals;
        }
      } else {
        if (!hv || mo_cfg_count(lg, "value") != D) {
          mo_expr_free(amp);
          return mo_case_error(cs, lg, ctx, "a traction needs a 'value' of %d components", D);
        }
        for (c = 0; !st && c < D; c++) st = mo_scene_compile(cs, lg, "value", c, xyz_vars, D, &T.e[c], ctx);
      }
      for (k = 0; !st && k < fs->n; k++) {
        T.facet = k;
        if ((st = mo_facet_load(m, fs, k, B->mat, traction_cb, &T, fe, ctx))) break;
        for (a = 0; a < fs->nfn; a++)
          for (c = 0; c < D; c++) f[B->dof0 + fs->node[k * fs->nfn + a] * D + c] += fe[a * D + c];
      }
      for (c = 0; c < 3; c++) mo_expr_free(T.e[c]);
      mo_free(vals);
      if (st) { mo_expr_free(amp); return st; }
    }
    if ((st = mo_scene_add_load(sc, f, amp, ctx))) return st;
  }
  return MO_OK;
}

/* Body force: f_a = sum_e int rho b N_a (consistent), from b(x) at quadrature points. */
static int build_body_force(mo_scene *sc, const mo_case *cs, const config_setting_t *bg, int b,
                            double *f, mo_ctx *ctx)
{
  mo_body *B = &sc->body[b];
  mo_mesh *m = B->mesh;
  mo_expr *e[3] = {NULL, NULL, NULL};
  int D = sc->dim, c, st = MO_OK, el, a;
  if (!mo_cfg_member(bg, "body_force")) return MO_OK;
  if (mo_cfg_count(bg, "body_force") != D)
    return mo_case_error(cs, mo_cfg_member(bg, "body_force"), ctx, "needs %d components", D);
  for (c = 0; c < D && !st; c++) st = mo_scene_compile(cs, bg, "body_force", c, xyz_vars, D, &e[c], ctx);
  memset(f, 0, (size_t)sc->ndof * sizeof *f);
  /* f_a = b(x_e) * sum_b int rho N_a N_b (the row sums of the consistent mass, whatever mass the
     body steps with: HRZ's lumped diagonal is not the load of T6 and T10): exact for a constant b
     (gravity), b taken at the element's mean node position otherwise */
  for (el = 0; !st && el < m->nelem; el++) {
    double Me[MO_ND_MAX * MO_ND_MAX], ctr[3] = {0, 0, 0}, bv[3];
    int nen = m->nen, nd = nen * D, b2;
    const int *cn = &m->conn[el * nen];
    if ((st = mo_elem_mass(m, el, B->mat, 0, Me, ctx))) break;
    for (a = 0; a < nen; a++)
      for (c = 0; c < D; c++) ctr[c] += m->x[cn[a] * D + c] / nen;
    for (c = 0; c < D; c++) bv[c] = mo_expr_eval(e[c], ctr);
    for (a = 0; a < nen; a++)
      for (c = 0; c < D; c++)
        for (b2 = 0; b2 < nen; b2++) f[B->dof0 + cn[a] * D + c] += Me[(a * D + c) * nd + b2 * D + c] * bv[c];
  }
  for (c = 0; c < 3; c++) mo_expr_free(e[c]);
  if (st) return st;
  return mo_scene_add_load(sc, f, NULL, ctx);
}

static int build_initial(mo_scene *sc, const mo_case *cs, const config_setting_t *bg, int b,
                         mo_ctx *ctx)
{
  mo_body *B = &sc->body[b];
  const config_setting_t *ig = mo_cfg_member(bg, "initial");
  static const char *which[2] = {"displacement", "velocity"};
  int w, c, a, st, D = sc->dim;
  if (!ig) return MO_OK;
  for (w = 0; w < 2; w++) {
    double *dst = w ? sc->v0 : sc->u0;
    mo_expr *e;
    if (!mo_cfg_member(ig, which[w])) continue;
    if (mo_cfg_count(ig, which[w]) != D)
      return mo_case_error(cs, mo_cfg_member(ig, which[w]), ctx, "needs %d components", D);
    for (c = 0; c < D; c++) {
      if ((st = mo_scene_compile(cs, ig, which[w], c, xyz_vars, D, &e, ctx))) return st;
      for (a = 0; a < B->mesh->nnode; a++) {
        double v = mo_expr_eval(e, &B->mesh->x[a * D]);
        if (!isfinite(v)) {
          mo_expr_free(e);
          return mo_case_error(cs, mo_cfg_member(ig, which[w]), ctx,
                               "component %c is not finite at node %d", "xyz"[c], a);
        }
        dst[B->dof0 + a * D + c] = v;
      }
      mo_expr_free(e);
    }
  }
  return MO_OK;
}


/* --- the kinds ------------------------------------------------------------------------------- */

/* Keys that belong to other kinds of body (a deformable body given a radius is a mistake). */
static int refuse_keys(const mo_case *cs, const config_setting_t *bg, const char *const *keys, int n,
                       const char *kind, mo_ctx *ctx)
{
  int k;
  for (k = 0; k < n; k++)
    if (mo_cfg_member(bg, keys[k]))
      return mo_case_error(cs, mo_cfg_member(bg, keys[k]), ctx, "a %s body takes no '%s'", kind, keys[k]);
  return MO_OK;
}

static const char *const rigid_keys[] = {"point", "normal", "velocity", "until", "center", "radius", "angle", "size", "sides",
                                         "vertices", "arch", "pack", "density", "thickness", "inertia", "fixed"};

static int deformable_read(mo_body *B, int member, int dim, const mo_case *cs, const config_setting_t *bg, mo_ctx *ctx)
{
  int st;
  (void)member;
  if ((st = refuse_keys(cs, bg, rigid_keys, (int)MO_COUNT(rigid_keys), "deformable", ctx))) return st;
  if (!mo_cfg_member(bg, "mesh"))
    return mo_case_error(cs, bg, ctx, "body '%s' has no mesh (add mesh = { generator = ...; })", B->name);
  if (!mo_cfg_member(bg, "material")) return mo_case_error(cs, bg, ctx, "body '%s' has no material", B->name);
  if ((st = mo_body_build_mesh(cs, mo_cfg_member(bg, "mesh"), &B->mesh, ctx))) return st;
  if (dim && B->mesh->dim != dim)
    return mo_case_error(cs, mo_cfg_member(bg, "mesh"), ctx, "body '%s' is %dD but an earlier body is %dD", B->name,
                         B->mesh->dim, dim);
  if (!(B->mat = mo_calloc(ctx, 1, sizeof *B->mat))) return MO_ENOMEM;
  if ((st = build_material(cs, mo_cfg_member(bg, "material"), B->mesh, B->mat, ctx))) return st;
  if (strcmp(mo_cfg_string(mo_cfg_member(bg, "material"), "model", "elastic"), "elastic")) {
    B->nl = 1;
    B->npoint = mo_elem_nl_npoint(B->mesh->type, B->mat->hyp);
  }
  {
    /* the explicit scheme is central differences with a lumped (row-sum) mass (T100) */
    const char *scheme = NULL;
    int cd = config_lookup_string(&cs->cfg, "time.scheme", &scheme) == CONFIG_TRUE && !strcmp(scheme, "explicit");
    B->lumped = !strcmp(mo_cfg_string(bg, "mass", cd ? "lumped" : "consistent"), "lumped");
    if (cd && B->nl)
      return mo_case_error(cs, mo_cfg_member(mo_cfg_member(bg, "material"), "model"), ctx, "body '%s': scheme 'explicit' "
                           "is implemented for linear elastic bodies only (model 'elastic')", B->name);
    if (cd && !B->lumped)
      return mo_case_error(cs, mo_cfg_member(bg, "mass"), ctx, "body '%s': scheme 'explicit' needs a lumped mass "
                           "(central differences with a consistent mass solve a matrix at every step)", B->name);
  }
  B->ndof = B->mesh->nnode * B->mesh->dim;
  B->orient = -1;
  return MO_OK;
}

static int deformable_conditions(mo_scene *sc, int b, const config_setting_t *bg, int *owner, mo_ctx *ctx)
{
  int st;
  if ((st = build_conditions(sc, sc->cs, bg, b, owner, ctx))) return st;
  return build_initial(sc, sc->cs, bg, b, ctx);
}

static int deformable_loads(mo_scene *sc, int b, const config_setting_t *bg, double *f, mo_ctx *ctx)
{
  int st;
  if ((st = build_loads(sc, sc->cs, bg, b, f, ctx))) return st;
  return build_body_force(sc, sc->cs, bg, b, f, ctx);
}

static void mesh_release(mo_body *B)
{
  mo_mesh_free(B->mesh);
  B->mesh = NULL;
}

const mo_body_type mo_body_deformable = {
  "deformable", MO_BODY_DEFORMABLE, MO_BODY_F_NODAL | MO_BODY_F_MESH, (1u << 1) | (1u << 2) | (1u << 3),
  "a finite-element mesh with its material, supports, loads and initial fields",
  NULL, deformable_read, deformable_conditions, deformable_loads, mesh_release
};

static int plane_read(mo_body *B, int member, int dim, const mo_case *cs, const config_setting_t *bg, mo_ctx *ctx)
{
  static const char *const other[] = {"mesh", "material", "center", "radius", "angle", "size", "sides", "vertices",
                                      "arch", "density", "thickness", "inertia", "initial", "body_force", "fix",
                                      "prescribed", "loads", "fixed", "pack"};
  double nn = 0;
  int k, st;
  (void)member;
  if ((st = refuse_keys(cs, bg, other, (int)MO_COUNT(other), "plane", ctx))) return st;
  B->orient = -1;
  B->ndof = 0;
  B->until = mo_cfg_float(bg, "until", HUGE_VAL);
  if (!dim) return MO_OK; /* read again once another body has fixed the dimension */
  if (mo_cfg_count(bg, "point") != dim || mo_cfg_count(bg, "normal") != dim)
    return mo_case_error(cs, bg, ctx, "plane '%s' needs a 'point' and a 'normal' of %d components", B->name, dim);
  if (mo_cfg_member(bg, "velocity") && mo_cfg_count(bg, "velocity") != dim)
    return mo_case_error(cs, mo_cfg_member(bg, "velocity"), ctx, "needs %d components", dim);
  for (k = 0; k < dim; k++) {
    B->point[k] = mo_cfg_num_at(bg, "point", k);
    B->normal[k] = mo_cfg_num_at(bg, "normal", k);
    B->velocity[k] = mo_cfg_count(bg, "velocity") ? mo_cfg_num_at(bg, "velocity", k) : 0;
    nn += B->normal[k] * B->normal[k];
  }
  if (!(nn > 0)) return mo_case_error(cs, mo_cfg_member(bg, "normal"), ctx, "the normal must not be zero");
  for (k = 0; k < dim; k++) B->normal[k] /= sqrt(nn);
  return MO_OK;
}

const mo_body_type mo_body_plane = {
  "plane", MO_BODY_PLANE, MO_BODY_F_OBSTACLE, (1u << 1) | (1u << 2) | (1u << 3),
  "a rigid plane obstacle (a point, an outward normal, a prescribed velocity)",
  NULL, plane_read, NULL, NULL, NULL
};
