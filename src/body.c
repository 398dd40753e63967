/* body.c: the table of kinds of body, and the kinematics and mass of rigid bodies the stepper,
   the contact layer and the outputs share (doc/theory.md §12.1-12.2). */
#include "config.h"
#include <moreau/body.h>
#include <moreau/step.h>

#include <math.h>
#include <string.h>

/* The kinds, defined where their reading lives (body_fe.c, body_rigid.c). */
extern const mo_body_type mo_body_deformable, mo_body_plane, mo_body_disk, mo_body_sphere,
    mo_body_polygon, mo_body_rigid_mesh;

static const mo_body_type *const registry[] = {
  &mo_body_deformable, &mo_body_plane, &mo_body_disk, &mo_body_sphere, &mo_body_polygon,
  &mo_body_rigid_mesh
};

int mo_body_type_count(void) { return (int)MO_COUNT(registry); }
const mo_body_type *mo_body_type_at(int i)
{
  return i >= 0 && i < (int)MO_COUNT(registry) ? registry[i] : NULL;
}

const mo_body_type *mo_body_type_find(const char *name)
{
  size_t k;
  for (k = 0; k < MO_COUNT(registry); k++)
    if (!strcmp(registry[k]->name, name)) return registry[k];
  return NULL;
}

const char *mo_body_type_names(void)
{
  return "deformable|plane|disk|sphere|polygon|rigid_mesh";
}

/* --- quaternions (w, x, y, z), body to world ------------------------------------------------ */

void mo_quat_matrix(const double *q, double *R)
{
  double w = q[0], x = q[1], y = q[2], z = q[3];
  R[0] = 1 - 2 * (y * y + z * z); R[1] = 2 * (x * y - w * z);     R[2] = 2 * (x * z + w * y);
  R[3] = 2 * (x * y + w * z);     R[4] = 1 - 2 * (x * x + z * z); R[5] = 2 * (y * z - w * x);
  R[6] = 2 * (x * z - w * y);     R[7] = 2 * (y * z + w * x);     R[8] = 1 - 2 * (x * x + y * y);
}

/* q <- exp(phi / 2) q (T69): the rotation by the vector phi (world frame) applied after q. The
   half-angle sine is evaluated by its series near zero so that tiny rotations keep full
   precision. */
void mo_quat_rotate(double *q, const double *phi)
{
  double a = sqrt(phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2]), c, s, e[4], r[4], n;
  int i;
  c = cos(0.5 * a);
  s = a > 1e-4 ? sin(0.5 * a) / a : 0.5 - a * a / 48;   /* sin(a/2)/a */
  e[0] = c;
  for (i = 0; i < 3; i++) e[i + 1] = s * phi[i];
  r[0] = e[0] * q[0] - e[1] * q[1] - e[2] * q[2] - e[3] * q[3];
  r[1] = e[0] * q[1] + e[1] * q[0] + e[2] * q[3] - e[3] * q[2];
  r[2] = e[0] * q[2] - e[1] * q[3] + e[2] * q[0] + e[3] * q[1];
  r[3] = e[0] * q[3] + e[1] * q[2] - e[2] * q[1] + e[3] * q[0];
  n = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3]);
  for (i = 0; i < 4; i++) q[i] = r[i] / n;
}

/* --- rigid kinematics ------------------------------------------------------------------------ */

int mo_rigid_ndof(int dim) { return dim == 3 ? 6 : 3; }

void mo_rigid_rotation(const mo_scene *sc, const mo_body *B, const mo_state *s, double *R)
{
  static const double id[4] = {1, 0, 0, 0};
  memset(R, 0, 9 * sizeof *R);
  if (sc->dim == 2) {
    double th = B->theta0 + (s ? s->u[B->dof0 + 2] : 0);
    R[0] = cos(th); R[1] = -sin(th);
    R[3] = sin(th); R[4] = cos(th);
    R[8] = 1;
    return;
  }
  mo_quat_matrix(s && s->orient && B->orient >= 0 ? s->orient + 4 * B->orient : id, R);
}

void mo_rigid_center(const mo_scene *sc, const mo_body *B, const mo_state *s, double *x)
{
  int i;
  for (i = 0; i < 3; i++) x[i] = i < sc->dim ? B->xc0[i] + (s ? s->u[B->dof0 + i] : 0) : 0;
}

void mo_rigid_point(const mo_scene *sc, const mo_body *B, const mo_state *s, const double *X, double *x)
{
  double R[9], c[3];
  int D = sc->dim, i, j;
  mo_rigid_rotation(sc, B, s, R);
  mo_rigid_center(sc, B, s, c);
  for (i = 0; i < D; i++) {
    x[i] = c[i];
    for (j = 0; j < D; j++) x[i] += R[i * 3 + j] * X[j];
  }
}

void mo_rigid_jacobian(int dim, const double *xc, const double *P, double *G)
{
  double r[3] = {P[0] - xc[0], P[1] - xc[1], dim == 3 ? P[2] - xc[2] : 0};
  if (dim == 2) {
    /* v(P) = v + omega e_z x r */
    G[0] = 1; G[1] = 0; G[2] = -r[1];
    G[3] = 0; G[4] = 1; G[5] = r[0];
    return;
  }
  /* v(P) = v + omega x r = v - [r]x omega */
  memset(G, 0, 18 * sizeof *G);
  G[0] = G[7] = G[14] = 1;
  G[3] = 0;     G[4] = r[2];  G[5] = -r[1];
  G[9] = -r[2]; G[10] = 0;    G[11] = r[0];
  G[15] = r[1]; G[16] = -r[0]; G[17] = 0;
}

/* J_w = R J R^T (3 x 3). */
static void world_inertia(const mo_scene *sc, const mo_body *B, const mo_state *s, double *Jw)
{
  double R[9], T[9];
  int i, j, k;
  mo_rigid_rotation(sc, B, s, R);
  for (i = 0; i < 3; i++)
    for (j = 0; j < 3; j++) {
      T[i * 3 + j] = 0;
      for (k = 0; k < 3; k++) T[i * 3 + j] += R[i * 3 + k] * B->J[k * 3 + j];
    }
  for (i = 0; i < 3; i++)
    for (j = 0; j < 3; j++) {
      Jw[i * 3 + j] = 0;
      for (k = 0; k < 3; k++) Jw[i * 3 + j] += T[i * 3 + k] * R[j * 3 + k];
    }
}

void mo_rigid_mass(const mo_scene *sc, const mo_body *B, const mo_state *s, double *M)
{
  int n = mo_rigid_ndof(sc->dim), i, j;
  memset(M, 0, (size_t)(n * n) * sizeof *M);
  if (sc->dim == 2) {
    M[0] = M[4] = B->mass;
    M[8] = B->J[0];
    return;
  }
  {
    double Jw[9];
    world_inertia(sc, B, s, Jw);
    for (i = 0; i < 3; i++) {
      M[i * 6 + i] = B->mass;
      for (j = 0; j < 3; j++) M[(3 + i) * 6 + 3 + j] = Jw[i * 3 + j];
    }
  }
}

void mo_rigid_gyroscopic(const mo_scene *sc, const mo_body *B, const mo_state *s, const double *v,
                         double *f)
{
  double Jw[9], w[3], Jo[3];
  int n = mo_rigid_ndof(sc->dim), i, j;
  for (i = 0; i < n; i++) f[i] = 0;
  if (sc->dim != 3) return;
  world_inertia(sc, B, s, Jw);
  for (i = 0; i < 3; i++) w[i] = v[3 + i];
  for (i = 0; i < 3; i++) {
    Jo[i] = 0;
    for (j = 0; j < 3; j++) Jo[i] += Jw[i * 3 + j] * w[j];
  }
  f[3] = -(w[1] * Jo[2] - w[2] * Jo[1]);
  f[4] = -(w[2] * Jo[0] - w[0] * Jo[2]);
  f[5] = -(w[0] * Jo[1] - w[1] * Jo[0]);
}

double mo_rigid_kinetic(const mo_scene *sc, const mo_state *s)
{
  double e = 0, M[36];
  int k, i, j, n = mo_rigid_ndof(sc->dim);
  if (sc->dim == 2) {
    /* M = diag(m, m, J) (mo_rigid_mass): the sum below without its six zero entries (T292). A
       zero entry's term 0.5 v_i 0 v_j is +-0 for finite v, and e, which starts at +0, is never
       -0, so adding it changes no bit; a non-finite v_i made a term NaN, and makes e NaN here. */
    if (sc->rigid_md) {
      /* m and I from the scene's compact (m, I), the dofs as number_dofs gives them: the same sums
         without a body record read (T311) */
      const double *v = s->v + sc->nfe_dof, *md = sc->rigid_md;
      for (k = 0; k < sc->nrigid; k++, v += 3, md += 2) {
        e += 0.5 * v[0] * md[0] * v[0];
        e += 0.5 * v[1] * md[0] * v[1];
        e += 0.5 * v[2] * md[1] * v[2];
        if (!isfinite(v[0]) || !isfinite(v[1]) || !isfinite(v[2])) e += NAN;
      }
      return e;
    }
    for (k = 0; k < sc->nrigid; k++) {
      const mo_body *B = &sc->body[sc->rigid[k]];
      const double *v = s->v + B->dof0;
      e += 0.5 * v[0] * B->mass * v[0];
      e += 0.5 * v[1] * B->mass * v[1];
      e += 0.5 * v[2] * B->J[0] * v[2];
      if (!isfinite(v[0]) || !isfinite(v[1]) || !isfinite(v[2])) e += NAN;
    }
    return e;
  }
  for (k = 0; k < sc->nrigid; k++) {
    const mo_body *B = &sc->body[sc->rigid[k]];
    const double *v = s->v + B->dof0;
    mo_rigid_mass(sc, B, s, M);
    for (i = 0; i < n; i++)
      for (j = 0; j < n; j++) e += 0.5 * v[i] * M[i * n + j] * v[j];
  }
  return e;
}

double mo_rigid_kinetic_list(const mo_scene *sc, const mo_state *s, const int *list, int n, const unsigned char *mask)
{
  double e = 0, M[36];
  int k, i, j, nd = mo_rigid_ndof(sc->dim);
  for (k = 0; k < n; k++) {
    const mo_body *B = &sc->body[list[k]];
    const double *v = s->v + B->dof0;
    if ((mask && !mask[list[k]]) || !(B->type->flags & MO_BODY_F_RIGID)) continue;
    if (sc->dim == 2) {
      e += 0.5 * v[0] * B->mass * v[0];
      e += 0.5 * v[1] * B->mass * v[1];
      e += 0.5 * v[2] * B->J[0] * v[2];
      if (!isfinite(v[0]) || !isfinite(v[1]) || !isfinite(v[2])) e += NAN;
      continue;
    }
    mo_rigid_mass(sc, B, s, M);
    for (i = 0; i < nd; i++)
      for (j = 0; j < nd; j++) e += 0.5 * v[i] * M[i * nd + j] * v[j];
  }
  return e;
}

double mo_rigid_bound(const mo_body *B) { return B->bound; }

void mo_polygon_world(const mo_scene *sc, const mo_body *B, const mo_state *s, double *v)
{
  double R[9], c[3];
  int k;
  mo_rigid_rotation(sc, B, s, R);
  mo_rigid_center(sc, B, s, c);
  for (k = 0; k < B->nvert; k++) {
    const double *X = B->vert + 2 * k;
    v[2 * k] = c[0] + R[0] * X[0] + R[1] * X[1];
    v[2 * k + 1] = c[1] + R[3] * X[0] + R[4] * X[1];
  }
}
