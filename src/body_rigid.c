/* body_rigid.c: the rigid kinds of body (disk, sphere, convex polygon, a mesh held rigid): their
   shapes, mass properties, supports, initial velocities and body forces (doc/theory.md §12.1). */
#include "config.h"
#include <moreau/body.h>
#include <moreau/fe.h>
#include "narrow.h"
#include "scene_internal.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

static const char *const xyz_vars[] = {"x", "y", "z"};
static const char *const t_var[] = {"t"};

/* --- shapes and mass properties ---------------------------------------------------------------- */

/* Keys of the other kinds, refused so that a misplaced key is not silently ignored. */
static int refuse(const mo_case *cs, const config_setting_t *bg, const char *kind, const char *const *keys, int n,
                  mo_ctx *ctx)
{
  int k;
  for (k = 0; k < n; k++)
    if (mo_cfg_member(bg, keys[k]))
      return mo_case_error(cs, mo_cfg_member(bg, keys[k]), ctx, "a %s body takes no '%s'", kind, keys[k]);
  return MO_OK;
}

/* Density and (2D) thickness: mass = density x area x thickness in 2D, density x volume in 3D. The
   thickness is read here and used by the mass and inertia the body's read forms, and not kept in the
   body (8 bytes a grain, doc/theory.md (T311)). */
static int read_density(mo_body *B, int dim, const mo_case *cs, const config_setting_t *bg, double *rho, double *th,
                        mo_ctx *ctx)
{
  if (!mo_cfg_member(bg, "density"))
    return mo_case_error(cs, bg, ctx, "rigid body '%s' needs its 'density' (kg/m^3)", B->name);
  *rho = mo_cfg_float(bg, "density", 1);
  if (dim == 3 && mo_cfg_member(bg, "thickness"))
    return mo_case_error(cs, mo_cfg_member(bg, "thickness"), ctx, "only 2D rigid bodies take a thickness");
  *th = dim == 2 ? mo_cfg_float(bg, "thickness", 1) : 1;
  return MO_OK;
}

/* The centre (dim values), required. */
static int read_center(mo_body *B, int dim, const mo_case *cs, const config_setting_t *bg, mo_ctx *ctx)
{
  int k, st;
  if ((st = mo_scene_need_len(cs, bg, "center", dim, dim == 3 ? "a sphere" : "this body", ctx))) return st;
  for (k = 0; k < dim; k++) B->xc0[k] = mo_cfg_num_at(bg, "center", k);
  return MO_OK;
}

/* An explicit inertia overrides the shape's (2D: I about the centroid; 3D: the principal values
   or the 9 entries of J in the body frame). */
static int read_inertia(mo_body *B, int dim, const mo_case *cs, const config_setting_t *bg, mo_ctx *ctx)
{
  const config_setting_t *s = mo_cfg_member(bg, "inertia");
  int n = mo_cfg_count(bg, "inertia"), k;
  if (!s) return MO_OK;
  if (dim == 2 && n != 1) return mo_case_error(cs, s, ctx, "a 2D body's inertia is one value (kg m^2)");
  if (dim == 3 && n != 3 && n != 9)
    return mo_case_error(cs, s, ctx, "a 3D body's inertia is 3 principal values or the 9 entries of J");
  for (k = 0; k < n; k++)
    if (!(mo_cfg_num_at(bg, "inertia", k) >= 0) && (n != 9 || k % 4 == 0))
      return mo_case_error(cs, s, ctx, "an inertia is not negative");
  memset(B->J, 0, sizeof B->J);
  if (dim == 2) B->J[0] = mo_cfg_num_at(bg, "inertia", 0);
  else if (n == 3) for (k = 0; k < 3; k++) B->J[4 * k] = mo_cfg_num_at(bg, "inertia", k);
  else for (k = 0; k < 9; k++) B->J[k] = mo_cfg_num_at(bg, "inertia", k);
  return MO_OK;
}

static const char *const mesh_keys[] = {"mesh", "material", "loads", "mass"};

/* --- packs of grains ---------------------------------------------------------------------------
   One entry makes `count` disks (spheres) on a loose lattice filling a box from its bottom, with
   radii uniform in R (1 -+ dispersion) and a jitter inside each lattice cell: deterministic for a
   seed, each grain computed from its rank alone (a counter-based generator, no state). */

/* A uniform number in [0, 1) from (seed, grain, draw): SplitMix64's finalizer. */
static double pack_uniform(unsigned long seed, int grain, int draw)
{
  unsigned long long z = (unsigned long long)seed * 0x9E3779B97F4A7C15ULL + (unsigned long long)grain * 0xBF58476D1CE4E5B9ULL +
                         (unsigned long long)draw * 0x94D049BB133111EBULL + 0x632BE59BD9B4E019ULL;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  z ^= z >> 31;
  return (double)(z >> 11) * (1.0 / 9007199254740992.0);
}

static int pack_count(const config_setting_t *bg)
{
  const config_setting_t *p = mo_cfg_member(bg, "pack");
  return p ? mo_cfg_int(p, "count", 1) : 1;
}

/* Grain `member` of the pack: its centre (dim values) and radius. */
static int pack_grain(const mo_body *B, int member, int dim, const mo_case *cs, const config_setting_t *bg, double *c,
                      double *R, mo_ctx *ctx)
{
  const config_setting_t *p = mo_cfg_member(bg, "pack");
  double Rm = mo_cfg_float(p, "radius", 1), disp = mo_cfg_float(p, "dispersion", 0), jit = mo_cfg_float(p, "jitter", 0.5);
  double s = mo_cfg_float(p, "spacing", 2.2 * Rm * (1 + disp)), lo[3], hi[3];
  unsigned long seed = (unsigned long)mo_cfg_int(p, "seed", 1);
  int count = mo_cfg_int(p, "count", 1), n[3] = {1, 1, 1}, idx[3], k, up = dim - 1;
  double cap = 1;
  if (mo_cfg_count(p, "box") != 2 * dim)
    return mo_case_error(cs, mo_cfg_member(p, "box") ? mo_cfg_member(p, "box") : p, ctx,
                         "a pack's box is [xmin, xmax, ymin, ymax%s]", dim == 3 ? ", zmin, zmax" : "");
  if (!(s >= 2 * Rm * (1 + disp)))
    return mo_case_error(cs, mo_cfg_member(p, "spacing"), ctx, "a spacing of %g m lets grains of radius up to %g m "
                         "overlap", s, Rm * (1 + disp));
  for (k = 0; k < dim; k++) {
    double cells;
    lo[k] = mo_cfg_num_at(p, "box", 2 * k);
    hi[k] = mo_cfg_num_at(p, "box", 2 * k + 1);
    cells = floor((hi[k] - lo[k]) / s + 1e-9);
    if (!(cells >= 1)) /* NaN too */
      return mo_case_error(cs, mo_cfg_member(p, "box"), ctx, "the box is narrower than one lattice cell (%g m) along %c",
                           s, "xyz"[k]);
    /* no direction needs more cells than grains (the layout is the same) */
    n[k] = cells < count ? (int)cells : count;
    cap *= n[k];
  }
  if (count > cap)
    return mo_case_error(cs, mo_cfg_member(p, "count"), ctx, "the box holds %.0f grains on a lattice of spacing %g m, "
                         "not %d: make it taller or wider", cap, s, count);
  /* fill the horizontal layers first (x, then z in 3D), then go up (y) */
  idx[0] = member % n[0];
  if (dim == 2) idx[1] = member / n[0];
  else {
    idx[2] = (member / n[0]) % n[2];
    idx[1] = (int)(member / ((long long)n[0] * n[2]));
  }
  *R = Rm * (1 + disp * (2 * pack_uniform(seed, member, 0) - 1));
  for (k = 0; k < dim; k++) {
    double free = 0.5 * s - *R;  /* room inside the cell */
    c[k] = lo[k] + s * (idx[k] + 0.5) + jit * free * (2 * pack_uniform(seed, member, 1 + k) - 1);
  }
  (void)up;
  (void)B;
  return MO_OK;
}
static const char *const plane_keys[] = {"point", "normal", "velocity", "until"};

static int ball_read(mo_body *B, int member, int dim, const mo_case *cs, const config_setting_t *bg, mo_ctx *ctx)
{
  static const char *const poly[] = {"size", "sides", "vertices", "arch"};
  const char *kind = B->kind == MO_BODY_SPHERE ? "sphere" : "disk";
  double rho, th, R = 0;
  int st;
  (void)member;
  if ((st = refuse(cs, bg, kind, mesh_keys, 4, ctx)) || (st = refuse(cs, bg, kind, plane_keys, (int)MO_COUNT(plane_keys), ctx)) ||
      (st = refuse(cs, bg, kind, poly, 4, ctx)))
    return st;
  if (dim && dim != (B->kind == MO_BODY_SPHERE ? 3 : 2))
    return mo_case_error(cs, mo_cfg_member(bg, "type"), ctx, "a %s lives in %dD, but an earlier body is %dD", kind,
                         B->kind == MO_BODY_SPHERE ? 3 : 2, dim);
  dim = B->kind == MO_BODY_SPHERE ? 3 : 2;
  if (B->kind == MO_BODY_SPHERE && mo_cfg_member(bg, "angle"))
    return mo_case_error(cs, mo_cfg_member(bg, "angle"), ctx, "only 2D bodies take an angle");
  if (mo_cfg_member(bg, "pack")) {
    const config_setting_t *s2 = mo_cfg_member(bg, "center") ? mo_cfg_member(bg, "center") : mo_cfg_member(bg, "radius");
    if (s2) return mo_case_error(cs, s2, ctx, "a pack places and sizes its grains (pack.box, pack.radius)");
    if ((st = pack_grain(B, member, dim, cs, bg, B->xc0, &R, ctx)) || (st = read_density(B, dim, cs, bg, &rho, &th, ctx)))
      return st;
    B->radius = R;
  } else {
    if ((st = read_center(B, dim, cs, bg, ctx)) || (st = mo_scene_need(cs, bg, "radius", kind, ctx)) ||
        (st = read_density(B, dim, cs, bg, &rho, &th, ctx)))
      return st;
    R = B->radius = mo_cfg_float(bg, "radius", 1);
  }
  B->theta0 = mo_cfg_float(bg, "angle", 0);
  memset(B->J, 0, sizeof B->J);
  if (dim == 2) {
    B->mass = rho * M_PI * R * R * th;
    B->J[0] = 0.5 * B->mass * R * R;                 /* I = m R^2 / 2 */
  } else {
    B->mass = rho * 4.0 / 3.0 * M_PI * R * R * R;
    B->J[0] = B->J[4] = B->J[8] = 0.4 * B->mass * R * R; /* J = (2/5) m R^2 Id */
  }
  B->bound = R;
  B->ndof = mo_rigid_ndof(dim);
  return read_inertia(B, dim, cs, bg, ctx);
}

/* --- polygons ---------------------------------------------------------------------------------- */

/* Voussoirs of an arch: rings of `blocks` quadrilaterals between radii R -+ t/2 over the angles
   from .. to (degrees, counter-clockwise), chords for the intrados and extrados. */
static int arch_count(const config_setting_t *bg)
{
  const config_setting_t *a = mo_cfg_member(bg, "arch");
  return a ? mo_cfg_int(a, "blocks", 1) : 1;
}

static int polygon_vertices(mo_body *B, int member, const mo_case *cs, const config_setting_t *bg, double *v,
                            int *nv, mo_ctx *ctx)
{
  const config_setting_t *a = mo_cfg_member(bg, "arch");
  int forms = (mo_cfg_member(bg, "vertices") != NULL) + (mo_cfg_member(bg, "size") != NULL) +
              (mo_cfg_member(bg, "sides") != NULL) + (a != NULL), k, st;
  double c[2] = {0, 0}, ang = mo_cfg_float(bg, "angle", 0);
  if (forms != 1)
    return mo_case_error(cs, bg, ctx, "polygon '%s' is given by exactly one of 'vertices', 'size' (a rectangle), "
                         "'sides' (a regular polygon) or 'arch' (voussoirs)", B->name);
  if ((mo_cfg_member(bg, "vertices") || a) && mo_cfg_member(bg, "angle"))
    return mo_case_error(cs, mo_cfg_member(bg, "angle"), ctx, "'angle' turns a rectangle or a regular polygon; "
                         "give the vertices where they are instead");
  if (!mo_cfg_member(bg, "vertices") && !a) {
    if ((st = read_center(B, 2, cs, bg, ctx))) return st;
    c[0] = B->xc0[0];
    c[1] = B->xc0[1];
  } else if (mo_cfg_member(bg, "center"))
    return mo_case_error(cs, mo_cfg_member(bg, "center"), ctx, "the centroid of given vertices is computed, not given");
  if (mo_cfg_member(bg, "vertices")) {
    int n = mo_cfg_count(bg, "vertices");
    if (n % 2 || n < 6 || n > 2 * MO_POLYGON_MAX)
      return mo_case_error(cs, mo_cfg_member(bg, "vertices"), ctx, "needs x, y pairs of 3 to %d vertices, not %d values",
                           MO_POLYGON_MAX, n);
    for (k = 0; k < n; k++) v[k] = mo_cfg_num_at(bg, "vertices", k);
    *nv = n / 2;
  } else if (mo_cfg_member(bg, "size")) {
    double hx, hy, ca = cos(ang), sa = sin(ang), X[4] = {-1, 1, 1, -1}, Y[4] = {-1, -1, 1, 1};
    if (mo_cfg_count(bg, "size") != 2)
      return mo_case_error(cs, mo_cfg_member(bg, "size"), ctx, "a rectangle's size is [a, b]");
    hx = 0.5 * mo_cfg_num_at(bg, "size", 0);
    hy = 0.5 * mo_cfg_num_at(bg, "size", 1);
    for (k = 0; k < 4; k++) {
      v[2 * k] = c[0] + ca * X[k] * hx - sa * Y[k] * hy;
      v[2 * k + 1] = c[1] + sa * X[k] * hx + ca * Y[k] * hy;
    }
    *nv = 4;
  } else if (mo_cfg_member(bg, "sides")) {
    int n = mo_cfg_int(bg, "sides", 3);
    double R;
    if ((st = mo_scene_need(cs, bg, "radius", "a regular polygon (its circumradius)", ctx))) return st;
    R = mo_cfg_float(bg, "radius", 1);
    for (k = 0; k < n; k++) {
      double t = ang + 2 * M_PI * k / n;
      v[2 * k] = c[0] + R * cos(t);
      v[2 * k + 1] = c[1] + R * sin(t);
    }
    *nv = n;
  } else {
    double R = mo_cfg_float(a, "radius", 1), t = mo_cfg_float(a, "thickness", 0.1), ri, ro, t0, t1;
    double from = mo_cfg_float(a, "from", 0) * M_PI / 180, to = mo_cfg_float(a, "to", 180) * M_PI / 180;
    int nb = mo_cfg_int(a, "blocks", 1);
    if (!(t < 2 * R)) return mo_case_error(cs, mo_cfg_member(a, "thickness"), ctx, "an arch thinner than its diameter");
    if (!(to > from)) return mo_case_error(cs, a, ctx, "an arch spans from < to (degrees, counter-clockwise)");
    if (mo_cfg_count(a, "center")) {
      c[0] = mo_cfg_num_at(a, "center", 0);
      c[1] = mo_cfg_num_at(a, "center", 1);
    }
    ri = R - 0.5 * t;
    ro = R + 0.5 * t;
    t0 = from + (to - from) * member / nb;
    t1 = from + (to - from) * (member + 1) / nb;
    v[0] = c[0] + ri * cos(t0); v[1] = c[1] + ri * sin(t0);
    v[2] = c[0] + ro * cos(t0); v[3] = c[1] + ro * sin(t0);
    v[4] = c[0] + ro * cos(t1); v[5] = c[1] + ro * sin(t1);
    v[6] = c[0] + ri * cos(t1); v[7] = c[1] + ri * sin(t1);
    *nv = 4;
  }
  return MO_OK;
}

static int polygon_read(mo_body *B, int member, int dim, const mo_case *cs, const config_setting_t *bg, mo_ctx *ctx)
{
  double v[2 * MO_POLYGON_MAX], c[2], rho, th, area, r2max = 0;
  char why[160];
  int nv = 0, k, st;
  const config_setting_t *where;
  static const char *const pack_key[] = {"pack"}; /* packs are of disks and spheres */
  if ((st = refuse(cs, bg, "polygon", mesh_keys, 4, ctx)) || (st = refuse(cs, bg, "polygon", plane_keys, (int)MO_COUNT(plane_keys), ctx)) ||
      (st = refuse(cs, bg, "polygon", pack_key, 1, ctx)))
    return st;
  if (dim && dim != 2)
    return mo_case_error(cs, mo_cfg_member(bg, "type"), ctx, "a polygon lives in 2D, but an earlier body is %dD", dim);
  if (mo_cfg_member(bg, "radius") && !mo_cfg_member(bg, "sides"))
    return mo_case_error(cs, mo_cfg_member(bg, "radius"), ctx, "a polygon takes a 'radius' only as a regular polygon (with 'sides')");
  if ((st = read_density(B, 2, cs, bg, &rho, &th, ctx))) return st;
  if ((st = polygon_vertices(B, member, cs, bg, v, &nv, ctx))) return st;
  where = mo_cfg_member(bg, "vertices") ? mo_cfg_member(bg, "vertices") : mo_cfg_member(bg, "arch") ? mo_cfg_member(bg, "arch") : bg;
  if (mo_polygon_check(nv, v, 1e-12, why, sizeof why))
    return mo_case_error(cs, where, ctx, "polygon '%s' is not a convex counter-clockwise polygon: %s", B->name, why);
  area = mo_polygon_area(nv, v);
  mo_polygon_centroid(nv, v, c);
  B->nvert = nv;
  B->vert = mo_malloc(ctx, (size_t)(2 * nv) * sizeof *B->vert);
  if (!B->vert) return MO_ENOMEM;
  /* the body frame: a rectangle's or a regular polygon's own axes (theta = the angle given), the
     world's axes for given vertices and voussoirs (theta = 0 at t = 0) */
  B->theta0 = mo_cfg_member(bg, "size") || mo_cfg_member(bg, "sides") ? mo_cfg_float(bg, "angle", 0) : 0;
  for (k = 0; k < nv; k++) {
    double dx = v[2 * k] - c[0], dy = v[2 * k + 1] - c[1], ca = cos(B->theta0), sa = sin(B->theta0);
    B->vert[2 * k] = ca * dx + sa * dy;
    B->vert[2 * k + 1] = -sa * dx + ca * dy;
    r2max = fmax(r2max, dx * dx + dy * dy);
  }
  B->xc0[0] = c[0];
  B->xc0[1] = c[1];
  B->mass = rho * area * th;
  memset(B->J, 0, sizeof B->J);
  B->J[0] = rho * th * mo_polygon_inertia(nv, v, c);
  B->bound = sqrt(r2max);
  B->ndof = 3;
  return read_inertia(B, 2, cs, bg, ctx);
}

static void polygon_release(mo_body *B)
{
  mo_free(B->vert);
  B->vert = NULL;
}

/* --- a mesh held rigid ---------------------------------------------------------------------------- */

/* Mass, centroid and inertia of the mesh by its consistent mass matrix: with M_ab = int rho N_a N_b
   and sum_b N_b x_b = x, sum_ab x_a M_ab = int rho x and sum_ab x_a x_b M_ab = int rho x x^T exactly. */
static int mesh_mass(mo_body *B, double rho, double th, mo_ctx *ctx)
{
  const mo_mesh *m = B->mesh;
  mo_material mat;
  int D = m->dim, e, a, b, i, j, st, nen = m->nen, nd = nen * D;
  double S0 = 0, S1[3] = {0, 0, 0}, S2[9] = {0}, Me[MO_ND_MAX * MO_ND_MAX], r2max = 0;
  memset(&mat, 0, sizeof mat);
  mat.model = MO_MAT_ELASTIC;
  mat.E = 1;
  mat.rho = rho;
  mat.area = 1;
  mat.thickness = th;
  mat.hyp = D == 3 ? MO_HYP_3D : MO_HYP_PLANE_STRAIN;
  for (e = 0; e < m->nelem; e++) {
    const int *cn = m->conn + (size_t)e * nen;
    if ((st = mo_elem_mass(m, e, &mat, 0, Me, ctx))) return st;
    for (a = 0; a < nen; a++)
      for (b = 0; b < nen; b++) {
        double Mab = Me[(a * D) * nd + b * D];
        const double *xa = m->x + cn[a] * D, *xb = m->x + cn[b] * D;
        S0 += Mab;
        for (i = 0; i < D; i++) {
          S1[i] += Mab * xb[i];
          for (j = 0; j < D; j++) S2[i * 3 + j] += Mab * xa[i] * xb[j];
        }
      }
  }
  if (!(S0 > 0)) return mo_error(ctx, MO_EINPUT, "rigid body '%s': its mesh has no mass", B->name);
  B->mass = S0;
  for (i = 0; i < D; i++) B->xc0[i] = S1[i] / S0;
  /* second moments about the centroid: C_ij = int rho r_i r_j */
  for (i = 0; i < D; i++)
    for (j = 0; j < D; j++) S2[i * 3 + j] -= S0 * B->xc0[i] * B->xc0[j];
  memset(B->J, 0, sizeof B->J);
  if (D == 2) B->J[0] = S2[0] + S2[4];
  else
    for (i = 0; i < 3; i++)
      for (j = 0; j < 3; j++) B->J[i * 3 + j] = (i == j ? S2[0] + S2[4] + S2[8] : 0) - S2[i * 3 + j];
  for (a = 0; a < m->nnode; a++) {
    double r2 = 0;
    for (i = 0; i < D; i++) r2 += (m->x[a * D + i] - B->xc0[i]) * (m->x[a * D + i] - B->xc0[i]);
    r2max = fmax(r2max, r2);
  }
  B->bound = sqrt(r2max);
  return MO_OK;
}

static int rigid_mesh_read(mo_body *B, int member, int dim, const mo_case *cs, const config_setting_t *bg, mo_ctx *ctx)
{
  static const char *const other[] = {"material", "loads", "mass", "center", "radius", "angle", "size", "sides",
                                      "vertices", "arch", "pack"};
  double rho, th;
  int st;
  (void)member;
  if ((st = refuse(cs, bg, "rigid_mesh", other, (int)MO_COUNT(other), ctx)) ||
      (st = refuse(cs, bg, "rigid_mesh", plane_keys, (int)MO_COUNT(plane_keys), ctx)))
    return st;
  if (!mo_cfg_member(bg, "mesh"))
    return mo_case_error(cs, bg, ctx, "body '%s' has no mesh (add mesh = { generator = ...; })", B->name);
  if ((st = mo_body_build_mesh(cs, mo_cfg_member(bg, "mesh"), &B->mesh, ctx))) return st;
  if (B->mesh->dim == 1)
    return mo_case_error(cs, mo_cfg_member(bg, "mesh"), ctx, "a rigid mesh is 2D or 3D (a 1D rigid body has no rotation)");
  if (dim && B->mesh->dim != dim)
    return mo_case_error(cs, mo_cfg_member(bg, "mesh"), ctx, "body '%s' is %dD but an earlier body is %dD", B->name,
                         B->mesh->dim, dim);
  if ((st = read_density(B, B->mesh->dim, cs, bg, &rho, &th, ctx))) return st;
  if ((st = mesh_mass(B, rho, th, ctx))) return mo_scene_relocate(cs, mo_cfg_member(bg, "mesh"), ctx);
  /* the facets' measures of its contact sets (dual cells, Gauss weights) read the material's
     hypothesis and thickness */
  if (!(B->mat = mo_calloc(ctx, 1, sizeof *B->mat))) return MO_ENOMEM;
  B->mat->model = MO_MAT_ELASTIC;
  B->mat->rho = rho;
  B->mat->hyp = B->mesh->dim == 3 ? MO_HYP_3D : MO_HYP_PLANE_STRAIN;
  B->mat->thickness = th;
  B->mat->area = 1;
  B->theta0 = 0;
  B->ndof = mo_rigid_ndof(B->mesh->dim);
  return read_inertia(B, B->mesh->dim, cs, bg, ctx);
}

static void rigid_mesh_release(mo_body *B)
{
  mo_mesh_free(B->mesh);
  B->mesh = NULL;
}

/* --- supports, initial velocities, body forces (every rigid kind) ---------------------------------- */

/* Local dof of a name: x, y, z, then theta (2D) or rx, ry, rz (3D); -1 when it does not exist. */
static int rigid_dof(int dim, const char *s)
{
  static const char *const n2[] = {"x", "y", "theta"}, *const n3[] = {"x", "y", "z", "rx", "ry", "rz"};
  int k;
  for (k = 0; k < (dim == 2 ? 3 : 6); k++)
    if (!strcmp(s, dim == 2 ? n2[k] : n3[k])) return k;
  return -1;
}

static int rigid_fix(mo_scene *sc, int b, const config_setting_t *bg, int *owner, mo_ctx *ctx)
{
  const mo_case *cs = sc->cs;
  mo_body *B = &sc->body[b];
  const config_setting_t *fl = mo_cfg_member(bg, "fix");
  int n = B->ndof, i, k, c, fix[6] = {0, 0, 0, 0, 0, 0};
  if (mo_cfg_bool(bg, "fixed", 0)) for (c = 0; c < n; c++) fix[c] = 1;
  for (i = 0; fl && i < config_setting_length(fl); i++) {
    const config_setting_t *fg = config_setting_get_elem(fl, (unsigned)i);
    int nd = mo_cfg_count(fg, "dofs");
    if (mo_cfg_member(fg, "set")) return mo_case_error(cs, mo_cfg_member(fg, "set"), ctx, "a rigid body has no node sets: give its 'dofs'");
    if (nd == 0) for (c = 0; c < n; c++) fix[c] = 1;
    for (k = 0; k < nd; k++) {
      const char *s = mo_cfg_string_at(fg, "dofs", k);
      if (!strcmp(s, "all")) for (c = 0; c < n; c++) fix[c] = 1;
      else if ((c = rigid_dof(sc->dim, s)) < 0)
        return mo_case_error(cs, mo_cfg_member(fg, "dofs"), ctx, "a %dD rigid body has dofs %s, not '%s'", sc->dim,
                             sc->dim == 2 ? "x, y, theta" : "x, y, z, rx, ry, rz", s);
      else fix[c] = 1;
    }
  }
  B->fixed = 1;
  for (c = 0; c < n; c++) {
    int st;
    B->fixed &= fix[c];
    if (!fix[c]) continue;
    st = mo_scene_add_presc(sc, B->dof0 + c, MO_PRESC_FIX, 0, NULL, owner, ctx);
    if (st == MO_ENOMEM) return st;
  }
  return MO_OK;
}

static int rigid_prescribed(mo_scene *sc, int b, const config_setting_t *bg, int *owner, mo_ctx *ctx)
{
  const mo_case *cs = sc->cs;
  mo_body *B = &sc->body[b];
  const config_setting_t *pl = mo_cfg_member(bg, "prescribed");
  int i, st;
  for (i = 0; pl && i < config_setting_length(pl); i++) {
    const config_setting_t *pg = config_setting_get_elem(pl, (unsigned)i);
    int hv = mo_cfg_member(pg, "velocity") != NULL, hd = mo_cfg_member(pg, "displacement") != NULL;
    int c = rigid_dof(sc->dim, mo_cfg_string(pg, "dof", "x"));
    mo_expr *e = NULL;
    if (mo_cfg_member(pg, "set")) return mo_case_error(cs, mo_cfg_member(pg, "set"), ctx, "a rigid body has no node sets");
    if (c < 0)
      return mo_case_error(cs, mo_cfg_member(pg, "dof"), ctx, "a %dD rigid body has dofs %s", sc->dim,
                           sc->dim == 2 ? "x, y, theta" : "x, y, z, rx, ry, rz");
    if (hv == hd) return mo_case_error(cs, pg, ctx, "give exactly one of 'velocity' or 'displacement'");
    if (hd && (st = mo_scene_compile(cs, pg, "displacement", 0, t_var, 1, &e, ctx))) return st;
    st = mo_scene_add_presc(sc, B->dof0 + c, hv ? MO_PRESC_VELOCITY : MO_PRESC_EXPR, mo_cfg_float(pg, "velocity", 0), e,
                            owner, ctx);
    if (st) {
      mo_expr_free(e);
      if (st == MO_ENOMEM) return st;
      return mo_case_error(cs, pg, ctx, "dof '%s' of '%s' is already fixed or prescribed", mo_cfg_string(pg, "dof", "x"),
                           B->name);
    }
    if (hd || mo_cfg_float(pg, "velocity", 0) != 0) sc->has_moving_presc = 1;
    B->fixed = 0;
  }
  return MO_OK;
}

/* A vector member as numbers or expressions of x, y, z evaluated at the centroid. */
static int eval_at_center(const mo_scene *sc, const mo_body *B, const config_setting_t *g, const char *key, int n,
                          double *out, mo_ctx *ctx)
{
  const mo_case *cs = sc->cs;
  int k, st;
  if (mo_cfg_count(g, key) != n)
    return mo_case_error(cs, mo_cfg_member(g, key), ctx, "needs %d component%s here", n, n > 1 ? "s" : "");
  for (k = 0; k < n; k++) {
    mo_expr *e = NULL;
    if ((st = mo_scene_compile(cs, g, key, k, xyz_vars, sc->dim, &e, ctx))) return st;
    out[k] = mo_expr_eval(e, B->xc0);
    mo_expr_free(e);
    if (!isfinite(out[k]))
      return mo_case_error(cs, mo_cfg_member(g, key), ctx, "component %d is not finite at the centroid of '%s'", k, B->name);
  }
  return MO_OK;
}

static int rigid_conditions(mo_scene *sc, int b, const config_setting_t *bg, int *owner, mo_ctx *ctx)
{
  mo_body *B = &sc->body[b];
  const config_setting_t *ig = mo_cfg_member(bg, "initial");
  int st, D = sc->dim, nr = D == 2 ? 1 : 3;
  double w[3];
  if ((st = rigid_fix(sc, b, bg, owner, ctx)) || (st = rigid_prescribed(sc, b, bg, owner, ctx))) return st;
  if (!ig) return MO_OK;
  if (mo_cfg_member(ig, "displacement"))
    return mo_case_error(sc->cs, mo_cfg_member(ig, "displacement"), ctx,
                         "a rigid body starts where its shape is given (center, vertices): no initial displacement");
  if (mo_cfg_member(ig, "velocity") && (st = eval_at_center(sc, B, ig, "velocity", D, sc->v0 + B->dof0, ctx))) return st;
  if (mo_cfg_member(ig, "omega")) {
    if ((st = eval_at_center(sc, B, ig, "omega", nr, w, ctx))) return st;
    memcpy(sc->v0 + B->dof0 + D, w, (size_t)nr * sizeof *w);
  }
  return MO_OK;
}

/* Body force b per unit mass: the force m b on the translation dofs (the centroid). */
static int rigid_loads(mo_scene *sc, int b, const config_setting_t *bg, double *f, mo_ctx *ctx)
{
  mo_body *B = &sc->body[b];
  double bf[3], val[3];
  int k, n, st, dof[3];
  if (mo_cfg_member(bg, "loads"))
    return mo_case_error(sc->cs, mo_cfg_member(bg, "loads"), ctx, "a rigid body takes a 'body_force', not 'loads'");
  if (!mo_cfg_member(bg, "body_force")) return MO_OK;
  if ((st = eval_at_center(sc, B, bg, "body_force", sc->dim, bf, ctx))) return st;
  (void)f;
  /* a component that is exactly zero is no entry (gravity along y: one entry a 2D grain, not two,
     12 bytes): f's sum (from +0), the load work and the cause of a non-finite value add +-0 for
     it, which leaves every sum as it was (x + -0 = x, +0 + -0 = +0); a NaN product is kept (T264) */
  for (k = 0, n = 0; k < sc->dim; k++)
    if (B->mass * bf[k] != 0) {
      dof[n] = B->dof0 + k;
      val[n++] = B->mass * bf[k];
    }
  return mo_scene_add_load_sparse(sc, n, dof, val, NULL, ctx);
}

/* --- the kinds ------------------------------------------------------------------------------------ */

const mo_body_type mo_body_disk = {
  "disk", MO_BODY_DISK, MO_BODY_F_RIGID | MO_BODY_F_BALL, 1u << 2,
  "a rigid disk (2D): center, radius, density; or a pack of them",
  pack_count, ball_read, rigid_conditions, rigid_loads, NULL
};

const mo_body_type mo_body_sphere = {
  "sphere", MO_BODY_SPHERE, MO_BODY_F_RIGID | MO_BODY_F_BALL, 1u << 3,
  "a rigid sphere (3D): center, radius, density; or a pack of them",
  pack_count, ball_read, rigid_conditions, rigid_loads, NULL
};

const mo_body_type mo_body_polygon = {
  "polygon", MO_BODY_POLYGON, MO_BODY_F_RIGID | MO_BODY_F_POLYGON, 1u << 2,
  "a rigid convex polygon (2D): vertices, a rectangle, a regular polygon, or the voussoirs of an arch",
  arch_count, polygon_read, rigid_conditions, rigid_loads, polygon_release
};

const mo_body_type mo_body_rigid_mesh = {
  "rigid_mesh", MO_BODY_RIGID_MESH, MO_BODY_F_RIGID | MO_BODY_F_MESH, (1u << 2) | (1u << 3),
  "a mesh held rigid (2D or 3D): mass and inertia from the mesh and a density; its node and facet sets for contact",
  NULL, rigid_mesh_read, rigid_conditions, rigid_loads, rigid_mesh_release
};
