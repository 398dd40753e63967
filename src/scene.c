/* scene.c: building a scene from a validated case (meshes, dofs, assembly, loads, settings). */
#include "config.h"
#include <moreau/scene.h>
#include <moreau/material.h>
#include "case_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const xyz_vars[] = {"x", "y", "z"};
static const char *const t_var[] = {"t"};

const char *mo_quantity_name(mo_quantity q)
{
  static const char *n[MO_Q_N] = {"ux", "uy", "uz", "vx", "vy", "vz", "fx", "fy", "fz",
                                  "cx", "cy", "cz", "pn", "gn", "lam"};
  return (unsigned)q < MO_Q_N ? n[q] : "?";
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
    mo_free(sc->body[i].name);
    mo_mesh_free(sc->body[i].mesh);
  }
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
  mo_free(sc->free_of);
  mo_free(sc->full_of);
  mo_csc_free(sc->K);
  mo_csc_free(sc->M);
  mo_free(sc->u0);
  mo_free(sc->v0);
  mo_free(sc->title);
  mo_free(sc->case_file);
  mo_free(sc);
}

/* Compile member `name` of g (a number or an expression) with the given variables. */
static int compile_member(const mo_case *cs, const config_setting_t *g, const char *name, int i,
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

static int need(const mo_case *cs, const config_setting_t *g, const char *key, const char *why,
                mo_ctx *ctx)
{
  if (mo_cfg_member(g, key)) return MO_OK;
  return mo_case_error(cs, g, ctx, "%s needs '%s'", why, key);
}

static int need_len(const mo_case *cs, const config_setting_t *g, const char *key, int n,
                    const char *why, mo_ctx *ctx)
{
  int st = need(cs, g, key, why, ctx);
  if (st) return st;
  if (mo_cfg_count(g, key) != n)
    return mo_case_error(cs, mo_cfg_member(g, key), ctx, "%s needs %d values here, not %d", why,
                         n, mo_cfg_count(g, key));
  return MO_OK;
}

/* Re-locate the last error at setting s (for errors raised by lower layers). */
static int relocate(const mo_case *cs, const config_setting_t *s, mo_ctx *ctx)
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
  if ((st = mo_mesh_read_gmsh(path, &o, out, NULL, ctx))) return relocate(cs, fs, ctx);
  if (n && n != (*out)->dim) {
    int dim = (*out)->dim;
    mo_mesh_free(*out);
    *out = NULL;
    return mo_case_error(cs, mo_cfg_member(mg, "translate"), ctx, "needs %d values for this %dD mesh",
                         dim, dim);
  }
  return MO_OK;
}

static int build_mesh(const mo_case *cs, const config_setting_t *mg, mo_mesh **out, mo_ctx *ctx)
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
    if ((st = need(cs, mg, "length", "a bar mesh", ctx)) ||
        (st = need_len(cs, mg, "elements", 1, "a bar mesh", ctx)))
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
    if ((st = need_len(cs, mg, "size", 2, "a rectangle mesh", ctx)) ||
        (st = need_len(cs, mg, "elements", 2, "a rectangle mesh", ctx)))
      return st;
    if (mo_cfg_count(mg, "origin") && (st = need_len(cs, mg, "origin", 2, "a rectangle mesh", ctx)))
      return st;
    for (k = 0; k < 2; k++) {
      if (mo_cfg_count(mg, "origin")) o[k] = mo_cfg_num_at(mg, "origin", k);
      s[k] = mo_cfg_num_at(mg, "size", k);
      n[k] = (int)mo_cfg_num_at(mg, "elements", k);
    }
    if (!strcmp(dg, "left")) d = MO_DIAG_LEFT;
    else if (!strcmp(dg, "alternate")) d = MO_DIAG_ALTERNATE;
    else if (!strcmp(dg, "union_jack")) d = MO_DIAG_UNION_JACK;
    if (mo_cfg_member(mg, "diagonal") && strcmp(el, "T3"))
      return mo_case_error(cs, mo_cfg_member(mg, "diagonal"), ctx, "only T3 meshes have diagonals");
    st = mo_mesh_rectangle(o, s, n, !strcmp(el, "T3") ? MO_EL_T3 : MO_EL_Q4, d, &m, ctx);
  } else if (!strcmp(gen, "box")) {
    double o[3] = {0, 0, 0}, s[3];
    int n[3];
    if ((st = need_len(cs, mg, "size", 3, "a box mesh", ctx)) ||
        (st = need_len(cs, mg, "elements", 3, "a box mesh", ctx)))
      return st;
    if (mo_cfg_count(mg, "origin") && (st = need_len(cs, mg, "origin", 3, "a box mesh", ctx)))
      return st;
    for (k = 0; k < 3; k++) {
      if (mo_cfg_count(mg, "origin")) o[k] = mo_cfg_num_at(mg, "origin", k);
      s[k] = mo_cfg_num_at(mg, "size", k);
      n[k] = (int)mo_cfg_num_at(mg, "elements", k);
    }
    if ((double)n[0] * n[1] * n[2] > 1e7)
      return mo_case_error(cs, mo_cfg_member(mg, "elements"), ctx,
                           "%d x %d x %d elements exceed the limit of 10^7", n[0], n[1], n[2]);
    st = mo_mesh_box(o, s, n, &m, ctx);
  } else if (!strcmp(gen, "disk")) {
    double c[2] = {0, 0};
    int core = mo_cfg_int(mg, "core", 8);
    if ((st = need(cs, mg, "radius", "a disk mesh", ctx))) return st;
    if (core % 2)
      return mo_case_error(cs, mo_cfg_member(mg, "core"), ctx, "the core division must be even");
    if (mo_cfg_count(mg, "center")) {
      c[0] = mo_cfg_num_at(mg, "center", 0);
      c[1] = mo_cfg_num_at(mg, "center", 1);
    }
    st = mo_mesh_disk(c, mo_cfg_float(mg, "radius", 1), core, mo_cfg_int(mg, "rings", 4), &m, ctx);
  } else
    return mo_case_error(cs, mg, ctx, "unknown generator '%s'", gen);
  if (st) return relocate(cs, mg, ctx);
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
  if ((st = mo_j2_check(mat, ctx))) return relocate(cs, mk ? mk : g, ctx);
  return MO_OK;
}

/* --- dofs, conditions, loads ----------------------------------------------------------------- */

static int dof_of_letter(const char *s)
{
  return s[0] == 'x' ? 0 : s[0] == 'y' ? 1 : s[0] == 'z' ? 2 : -1;
}

typedef struct {
  int *kind;   /* per dof: -1 free, else index in presc */
} presc_map;

static int add_presc(mo_scene *sc, int dof, mo_presc_kind kind, double vel, mo_expr *disp,
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
    for (k = 0; k < nd; k++) {
      const char *s = mo_cfg_string_at(fg, "dofs", k);
      if (!strcmp(s, "all")) comp[0] = comp[1] = comp[2] = 1;
      else {
        c = dof_of_letter(s);
        if (c >= D)
          return mo_case_error(cs, mo_cfg_member(fg, "dofs"), ctx, "component '%s' does not exist in %dD", s, D);
        comp[c] = 1;
      }
    }
    if (mo_mesh_nodeset_resolve(B->mesh, mo_cfg_string(fg, "set", ""), &ids, &n, ctx))
      return relocate(cs, mo_cfg_member(fg, "set"), ctx);
    if (n == 0) {
      mo_free(ids);
      return mo_case_error(cs, mo_cfg_member(fg, "set"), ctx, "the set selects no node");
    }
    for (k = 0; k < n; k++)
      for (c = 0; c < D; c++)
        if (comp[c]) {
          st = add_presc(sc, B->dof0 + ids[k] * D + c, MO_PRESC_FIX, 0, NULL, owner, ctx);
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
    if (c >= D) return mo_case_error(cs, mo_cfg_member(pg, "dof"), ctx, "component does not exist in %dD", D);
    if (hv == hd)
      return mo_case_error(cs, pg, ctx, "give exactly one of 'velocity' or 'displacement'");
    if (mo_mesh_nodeset_resolve(B->mesh, mo_cfg_string(pg, "set", ""), &ids, &n, ctx))
      return relocate(cs, mo_cfg_member(pg, "set"), ctx);
    if (n == 0) {
      mo_free(ids);
      return mo_case_error(cs, mo_cfg_member(pg, "set"), ctx, "the set selects no node");
    }
    for (k = 0; k < n; k++) {
      mo_expr *e = NULL;
      if (hd && (st = compile_member(cs, pg, "displacement", 0, t_var, 1, &e, ctx))) {
        mo_free(ids);
        return st;
      }
      st = add_presc(sc, B->dof0 + ids[k] * D + c, hv ? MO_PRESC_VELOCITY : MO_PRESC_EXPR,
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

static int load_push(mo_scene *sc, mo_load *L, mo_ctx *ctx)
{
  mo_load *p = mo_realloc(ctx, sc->load, (size_t)(sc->nload + 1) * sizeof *p);
  if (!p) return MO_ENOMEM;
  sc->load = p;
  sc->load[sc->nload++] = *L;
  return MO_OK;
}

/* Compress a dense load vector into a sparse pattern. */
static int load_from_dense(mo_scene *sc, const double *f, mo_expr *amp, mo_ctx *ctx)
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
  if (load_push(sc, &L, ctx)) {
    mo_free(L.dof);
    mo_free(L.val);
    mo_expr_free(amp);
    return MO_ENOMEM;
  }
  return MO_OK;
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
    if ((st = compile_member(cs, lg, "amplitude", 0, t_var, 1, &amp, ctx))) return st;
    if (!strcmp(type, "nodal")) {
      int *ids, n;
      if (mo_mesh_nodeset_resolve(m, set, &ids, &n, ctx)) {
        mo_expr_free(amp);
        return relocate(cs, mo_cfg_member(lg, "set"), ctx);
      }
      if (hv) {
        mo_expr *e[3] = {NULL, NULL, NULL};
        if (mo_cfg_count(lg, "value") != D) {
          mo_free(ids);
          mo_expr_free(amp);
          return mo_case_error(cs, mo_cfg_member(lg, "value"), ctx, "a nodal force has %d components here", D);
        }
        for (c = 0; c < D; c++)
          if ((st = compile_member(cs, lg, "value", c, xyz_vars, D, &e[c], ctx))) break;
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
      double fe[12], *vals = NULL;
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
        if (hv) st = compile_member(cs, lg, "value", 0, xyz_vars, D, &T.e[0], ctx);
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
        for (c = 0; !st && c < D; c++) st = compile_member(cs, lg, "value", c, xyz_vars, D, &T.e[c], ctx);
      }
      for (k = 0; !st && k < fs->n; k++) {
        T.facet = k;
        if ((st = mo_facet_load(m, fs, k, &B->mat, traction_cb, &T, fe, ctx))) break;
        for (a = 0; a < fs->nfn; a++)
          for (c = 0; c < D; c++) f[B->dof0 + fs->node[k * fs->nfn + a] * D + c] += fe[a * D + c];
      }
      for (c = 0; c < 3; c++) mo_expr_free(T.e[c]);
      mo_free(vals);
      if (st) { mo_expr_free(amp); return st; }
    }
    if ((st = load_from_dense(sc, f, amp, ctx))) return st;
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
  for (c = 0; c < D && !st; c++) st = compile_member(cs, bg, "body_force", c, xyz_vars, D, &e[c], ctx);
  memset(f, 0, (size_t)sc->ndof * sizeof *f);
  /* f_a = b(x_e) * sum_b int rho N_a N_b: exact for a constant b (gravity), b taken at the
     element centroid otherwise */
  for (el = 0; !st && el < m->nelem; el++) {
    double Me[24 * 24], ctr[3] = {0, 0, 0}, bv[3];
    int nen = m->nen, nd = nen * D;
    const int *cn = &m->conn[el * nen];
    if ((st = mo_elem_mass(m, el, &B->mat, 1, Me, ctx))) break;
    for (a = 0; a < nen; a++)
      for (c = 0; c < D; c++) ctr[c] += m->x[cn[a] * D + c] / nen;
    for (c = 0; c < D; c++) bv[c] = mo_expr_eval(e[c], ctr);
    for (a = 0; a < nen; a++)
      for (c = 0; c < D; c++) f[B->dof0 + cn[a] * D + c] += Me[(a * D + c) * nd + a * D + c] * bv[c];
  }
  for (c = 0; c < 3; c++) mo_expr_free(e[c]);
  if (st) return st;
  return load_from_dense(sc, f, NULL, ctx);
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
      if ((st = compile_member(cs, ig, which[w], c, xyz_vars, D, &e, ctx))) return st;
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

/* --- assembly -------------------------------------------------------------------------------- */

static int assemble(mo_scene *sc, int with_mass, mo_ctx *ctx)
{
  mo_triplet TK, TM;
  int b, e, a, c, st = MO_OK, D = sc->dim;
  size_t hint = 0;
  double t0 = mo_clock();
  for (b = 0; b < sc->nbody; b++)
    if (sc->body[b].kind == MO_BODY_DEFORMABLE) {
      int nd = sc->body[b].mesh->nen * D;
      hint += (size_t)sc->body[b].mesh->nelem * (size_t)nd * (size_t)nd;
    }
  memset(&TM, 0, sizeof TM);
  if ((st = mo_triplet_init(&TK, sc->ndof, sc->ndof, hint, ctx))) return st;
  if (with_mass && (st = mo_triplet_init(&TM, sc->ndof, sc->ndof, hint, ctx))) {
    mo_triplet_release(&TK);
    return st;
  }
  for (b = 0; b < sc->nbody && !st; b++) {
    mo_body *B = &sc->body[b];
    mo_mesh *m = B->mesh;
    int dofs[24], nd;
    double Ke[24 * 24], Me[24 * 24];
    if (B->kind != MO_BODY_DEFORMABLE) continue;
    nd = m->nen * D;
    B->mass = 0;
    for (e = 0; e < m->nelem && !st; e++) {
      for (a = 0; a < m->nen; a++)
        for (c = 0; c < D; c++) dofs[a * D + c] = B->dof0 + m->conn[e * m->nen + a] * D + c;
      /* finite-strain bodies have no constant stiffness: their forces and tangents are
         computed by the stepper at every Newton iterate (doc/theory.md §11) */
      if (!B->nl) {
        if ((st = mo_elem_stiffness(m, e, &B->mat, Ke, ctx))) break;
        if ((st = mo_triplet_add_block(&TK, dofs, nd, dofs, nd, Ke, ctx))) break;
      }
      if (with_mass) {
        if ((st = mo_elem_mass(m, e, &B->mat, B->lumped, Me, ctx))) break;
        if ((st = mo_triplet_add_block(&TM, dofs, nd, dofs, nd, Me, ctx))) break;
      }
      B->mass += B->mat.rho * mo_elem_measure(m, e, &B->mat);
    }
    sc->mass_total += B->mass;
  }
  if (!st) st = mo_triplet_to_csc(&TK, 1, &sc->K, ctx);
  if (!st && with_mass) st = mo_triplet_to_csc(&TM, 1, &sc->M, ctx);
  mo_triplet_release(&TK);
  mo_triplet_release(&TM);
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
  T->scheme = !strcmp(scheme, "newmark") ? MO_SCHEME_NEWMARK
              : !strcmp(scheme, "quasistatic") ? MO_SCHEME_QUASISTATIC : MO_SCHEME_THETA;
  T->theta = mo_cfg_float(tg, "theta", 0.5);
  T->theta_f = mo_cfg_float(tg, "theta_f", T->theta);
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
    if (n > 1e9) return mo_case_error(cs, mo_cfg_member(tg, "end"), ctx, "end / dt = %.3g steps exceed the limit of 10^9", n);
    T->steps = (long)ceil(n - 1e-9);
    if (T->steps < 1) T->steps = 1;
  } else if (mo_cfg_member(tg, "steps"))
    T->steps = mo_cfg_int(tg, "steps", 1);
  else
    return mo_case_error(cs, tg, ctx, "needs 'end' or 'steps'");
  T->end = (double)T->steps * T->dt;
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
      return relocate(cs, mo_cfg_member(g, "set") ? mo_cfg_member(g, "set") : g, ctx);
    if (X->nnode == 0) return mo_case_error(cs, mo_cfg_member(g, "set"), ctx, "the set selects no node");
  }
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
    for (k = 0; k < nf; k++) {
      const char *f = mo_cfg_string_at(vg, "fields", k);
      sc->out.vtk_fields |= !strcmp(f, "displacement") ? MO_VTK_DISPLACEMENT
                            : !strcmp(f, "velocity") ? MO_VTK_VELOCITY
                            : !strcmp(f, "stress") ? MO_VTK_STRESS
                            : !strcmp(f, "strain") ? MO_VTK_STRAIN
                            : !strcmp(f, "eps_p") ? MO_VTK_EPS_P : MO_VTK_VON_MISES;
    }
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
        return relocate(cs, mo_cfg_member(pg, "set"), ctx);
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

int mo_scene_build(const mo_case *cs, mo_scene **out, mo_ctx *ctx)
{
  const config_setting_t *bl = config_lookup(&cs->cfg, "bodies");
  mo_scene *sc;
  int nb, b, k, st = MO_OK, dim = 0, *owner = NULL;
  double *f = NULL, t0 = mo_clock();
  *out = NULL;
  sc = mo_calloc(ctx, 1, sizeof *sc);
  if (!sc) return MO_ENOMEM;
  sc->cs = cs;
  sc->title = mo_strdup(ctx, mo_cfg_string(config_root_setting(&cs->cfg), "title", ""));
  sc->case_file = mo_strdup(ctx, cs->file);
  nb = bl ? config_setting_length(bl) : 0;
  sc->body = mo_calloc(ctx, (size_t)(nb ? nb : 1), sizeof *sc->body);
  if (!sc->title || !sc->case_file || !sc->body) { st = MO_ENOMEM; goto fail; }
  if ((st = build_time(sc, cs, ctx))) goto fail;

  /* bodies: meshes and materials; the space dimension comes from the meshes */
  for (b = 0; b < nb; b++) {
    const config_setting_t *bg = config_setting_get_elem(bl, (unsigned)b);
    mo_body *B = &sc->body[b];
    const char *type = mo_cfg_string(bg, "type", "deformable");
    sc->nbody++;
    B->name = mo_strdup(ctx, mo_cfg_string(bg, "name", ""));
    if (!B->name) { st = MO_ENOMEM; goto fail; }
    for (k = 0; k < b; k++)
      if (!strcmp(sc->body[k].name, B->name)) {
        st = mo_case_error(cs, mo_cfg_member(bg, "name"), ctx, "body name '%s' is used twice", B->name);
        goto fail;
      }
    if (!strcmp(type, "plane")) {
      B->kind = MO_BODY_PLANE;
      if (mo_cfg_member(bg, "mesh") || mo_cfg_member(bg, "material")) {
        st = mo_case_error(cs, bg, ctx, "body '%s' is a rigid plane: it has no mesh or material", B->name);
        goto fail;
      }
      continue;
    }
    {
      static const char *only_plane[] = {"point", "normal", "velocity"};
      for (k = 0; k < 3; k++)
        if (mo_cfg_member(bg, only_plane[k])) {
          st = mo_case_error(cs, mo_cfg_member(bg, only_plane[k]), ctx, "only plane bodies take '%s'", only_plane[k]);
          goto fail;
        }
    }
    if (!mo_cfg_member(bg, "mesh")) {
      st = mo_case_error(cs, bg, ctx, "body '%s' has no mesh (add mesh = { generator = ...; })", B->name);
      goto fail;
    }
    if (!mo_cfg_member(bg, "material")) {
      st = mo_case_error(cs, bg, ctx, "body '%s' has no material", B->name);
      goto fail;
    }
    if ((st = build_mesh(cs, mo_cfg_member(bg, "mesh"), &B->mesh, ctx))) goto fail;
    if (dim && B->mesh->dim != dim) {
      st = mo_case_error(cs, mo_cfg_member(bg, "mesh"), ctx, "body '%s' is %dD but an earlier body is %dD", B->name, B->mesh->dim, dim);
      goto fail;
    }
    dim = B->mesh->dim;
    if ((st = build_material(cs, mo_cfg_member(bg, "material"), B->mesh, &B->mat, ctx))) goto fail;
    if (strcmp(mo_cfg_string(mo_cfg_member(bg, "material"), "model", "elastic"), "elastic")) {
      B->nl = 1;
      B->npoint = mo_elem_nl_npoint(B->mesh->type, B->mat.hyp);
      B->q0 = sc->nq;
      sc->nq += (size_t)B->mesh->nelem * (size_t)B->npoint * MO_J2_NSTATE;
      sc->nonlinear = 1;
    }
    B->lumped = !strcmp(mo_cfg_string(bg, "mass", "consistent"), "lumped");
    B->dof0 = sc->ndof;
    B->ndof = B->mesh->nnode * dim;
    sc->ndof += B->ndof;
    if (sc->ndof > (ctx->max_dofs > 0 ? ctx->max_dofs : 20000000L)) {
      st = mo_case_error(cs, mo_cfg_member(bg, "mesh"), ctx, "the scene reaches %d dofs with body '%s', more than "
                         "the limit of %ld (a direct factorization would not fit in memory)", sc->ndof, B->name,
                         ctx->max_dofs > 0 ? ctx->max_dofs : 20000000L);
      ctx->status = MO_ELIMIT;
      goto fail;
    }
  }
  if (!dim) {
    st = mo_case_error(cs, bl, ctx, "the scene needs at least one deformable body");
    goto fail;
  }
  sc->dim = dim;
  /* planes, now that the dimension is known */
  for (b = 0; b < nb; b++) {
    const config_setting_t *bg = config_setting_get_elem(bl, (unsigned)b);
    mo_body *B = &sc->body[b];
    double nn = 0;
    if (B->kind != MO_BODY_PLANE) continue;
    if (mo_cfg_count(bg, "point") != dim || mo_cfg_count(bg, "normal") != dim) {
      st = mo_case_error(cs, bg, ctx, "plane '%s' needs a 'point' and a 'normal' of %d components", B->name, dim);
      goto fail;
    }
    if (mo_cfg_member(bg, "velocity") && mo_cfg_count(bg, "velocity") != dim) {
      st = mo_case_error(cs, mo_cfg_member(bg, "velocity"), ctx, "needs %d components", dim);
      goto fail;
    }
    for (k = 0; k < dim; k++) {
      B->point[k] = mo_cfg_num_at(bg, "point", k);
      B->normal[k] = mo_cfg_num_at(bg, "normal", k);
      B->velocity[k] = mo_cfg_count(bg, "velocity") ? mo_cfg_num_at(bg, "velocity", k) : 0;
      nn += B->normal[k] * B->normal[k];
    }
    if (!(nn > 0)) {
      st = mo_case_error(cs, mo_cfg_member(bg, "normal"), ctx, "the normal must not be zero");
      goto fail;
    }
    for (k = 0; k < dim; k++) B->normal[k] /= sqrt(nn);
  }

  /* prescribed dofs, then the free numbering */
  sc->u0 = mo_calloc(ctx, (size_t)sc->ndof, sizeof(double));
  sc->v0 = mo_calloc(ctx, (size_t)sc->ndof, sizeof(double));
  owner = mo_malloc(ctx, (size_t)sc->ndof * sizeof(int));
  f = mo_malloc(ctx, (size_t)sc->ndof * sizeof(double));
  sc->free_of = mo_malloc(ctx, (size_t)sc->ndof * sizeof(int));
  if (!sc->u0 || !sc->v0 || !owner || !f || !sc->free_of) { st = MO_ENOMEM; goto fail; }
  for (k = 0; k < sc->ndof; k++) owner[k] = -1;
  for (b = 0; b < nb; b++) {
    const config_setting_t *bg = config_setting_get_elem(bl, (unsigned)b);
    if (sc->body[b].kind != MO_BODY_DEFORMABLE) continue;
    if ((st = build_conditions(sc, cs, bg, b, owner, ctx))) goto fail;
    if ((st = build_initial(sc, cs, bg, b, ctx))) goto fail;
  }
  sc->nfree = 0;
  for (k = 0; k < sc->ndof; k++) sc->free_of[k] = owner[k] >= 0 ? -1 : sc->nfree++;
  sc->full_of = mo_malloc(ctx, (size_t)(sc->nfree ? sc->nfree : 1) * sizeof(int));
  if (!sc->full_of) { st = MO_ENOMEM; goto fail; }
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

  /* loads */
  for (b = 0; b < nb; b++) {
    const config_setting_t *bg = config_setting_get_elem(bl, (unsigned)b);
    if (sc->body[b].kind != MO_BODY_DEFORMABLE) continue;
    if ((st = build_loads(sc, cs, bg, b, f, ctx))) goto fail;
    if ((st = build_body_force(sc, cs, bg, b, f, ctx))) goto fail;
  }
  if ((st = build_output(sc, cs, ctx))) goto fail;
  if ((st = mo_reference_build(&sc->ref, sc, ctx))) goto fail;
  mo_phase_add(ctx, MO_PH_SETUP, t0);

  if (sc->time.scheme == MO_SCHEME_QUASISTATIC) mo_note_skip(ctx, "mass matrix (quasi-static scene)");
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
