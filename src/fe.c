/* fe.c: shape functions, quadrature rules, small-strain element matrices and facet loads. */
#include "config.h"
#include <moreau/fe.h>

#include <gsl/gsl_integration.h>
#include <math.h>
#include <string.h>

int mo_hyp_ncomp(mo_hypothesis h)
{
  switch (h) {
  case MO_HYP_BAR: return 1;
  case MO_HYP_3D: return 6;
  default: return 4;
  }
}

const char *mo_hyp_name(mo_hypothesis h)
{
  static const char *n[] = {"bar", "plane_strain", "plane_stress", "axisymmetric", "3d"};
  return (unsigned)h <= MO_HYP_3D ? n[h] : "?";
}

/* Simplices in barycentric coordinates L_0 = 1 - sum xi, L_i = xi_i: linear N_a = L_a; quadratic
   corners L_a (2 L_a - 1), middles 4 L_a L_b over the edges of the node order (mesh.h). */
static void simplex_shape(mo_eltype t, const double *xi, double *N, double *dN)
{
  static const int t6mid[3][2] = {{0, 1}, {1, 2}, {2, 0}};
  static const int t10mid[6][2] = {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}};
  const int D = t == MO_EL_T6 ? 2 : 3, nv = D + 1, quad = t != MO_EL_T4;
  const int(*mid)[2] = t == MO_EL_T6 ? t6mid : t10mid;
  const int nmid = quad ? (t == MO_EL_T6 ? 3 : 6) : 0;
  double L[4], dL[4][3];
  int a, i;
  L[0] = 1;
  for (i = 0; i < D; i++) {
    L[0] -= xi[i];
    L[i + 1] = xi[i];
  }
  for (a = 0; a < nv; a++)
    for (i = 0; i < D; i++) dL[a][i] = a == 0 ? -1 : (a == i + 1);
  for (a = 0; a < nv; a++) {
    N[a] = quad ? L[a] * (2 * L[a] - 1) : L[a];
    if (dN)
      for (i = 0; i < D; i++) dN[a * D + i] = (quad ? 4 * L[a] - 1 : 1) * dL[a][i];
  }
  for (a = 0; a < nmid; a++) {
    int p = mid[a][0], q = mid[a][1];
    N[nv + a] = 4 * L[p] * L[q];
    if (dN)
      for (i = 0; i < D; i++) dN[(nv + a) * D + i] = 4 * (L[p] * dL[q][i] + L[q] * dL[p][i]);
  }
}

void mo_shape(mo_eltype t, const double *xi, double *N, double *dN)
{
  switch (t) {
  case MO_EL_BAR2:
    N[0] = 0.5 * (1 - xi[0]);
    N[1] = 0.5 * (1 + xi[0]);
    if (dN) { dN[0] = -0.5; dN[1] = 0.5; }
    break;
  case MO_EL_T3:
    N[0] = 1 - xi[0] - xi[1];
    N[1] = xi[0];
    N[2] = xi[1];
    if (dN) { dN[0] = -1; dN[1] = -1; dN[2] = 1; dN[3] = 0; dN[4] = 0; dN[5] = 1; }
    break;
  case MO_EL_Q4: {
    static const double s[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    int a;
    for (a = 0; a < 4; a++) {
      N[a] = 0.25 * (1 + s[a][0] * xi[0]) * (1 + s[a][1] * xi[1]);
      if (dN) {
        dN[2 * a] = 0.25 * s[a][0] * (1 + s[a][1] * xi[1]);
        dN[2 * a + 1] = 0.25 * s[a][1] * (1 + s[a][0] * xi[0]);
      }
    }
    break;
  }
  case MO_EL_H8: {
    static const double s[8][3] = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1},
                                   {-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1}};
    int a;
    for (a = 0; a < 8; a++) {
      double p = 1 + s[a][0] * xi[0], q = 1 + s[a][1] * xi[1], r = 1 + s[a][2] * xi[2];
      N[a] = 0.125 * p * q * r;
      if (dN) {
        dN[3 * a] = 0.125 * s[a][0] * q * r;
        dN[3 * a + 1] = 0.125 * s[a][1] * p * r;
        dN[3 * a + 2] = 0.125 * s[a][2] * p * q;
      }
    }
    break;
  }
  case MO_EL_T4:
  case MO_EL_T6:
  case MO_EL_T10: simplex_shape(t, xi, N, dN); break;
  default: break;
  }
}

void mo_facet_shape_kind(mo_facet_kind k, const double *s, double *N, double *dN)
{
  switch (k) {
  case MO_FK_POINT: N[0] = 1; break;
  case MO_FK_LINE2: mo_shape(MO_EL_BAR2, s, N, dN); break;
  case MO_FK_LINE3: /* the ends at s = -1, 1, the middle at 0 */
    N[0] = 0.5 * s[0] * (s[0] - 1);
    N[1] = 0.5 * s[0] * (s[0] + 1);
    N[2] = 1 - s[0] * s[0];
    if (dN) { dN[0] = s[0] - 0.5; dN[1] = s[0] + 0.5; dN[2] = -2 * s[0]; }
    break;
  case MO_FK_TRI3: mo_shape(MO_EL_T3, s, N, dN); break;
  case MO_FK_TRI6: mo_shape(MO_EL_T6, s, N, dN); break;
  case MO_FK_QUAD4: mo_shape(MO_EL_Q4, s, N, dN); break;
  }
}

void mo_facet_shape(int nfn, const double *s, double *N, double *dN)
{
  mo_facet_shape_kind(nfn == 1 ? MO_FK_POINT : nfn == 2 ? MO_FK_LINE2 : nfn == 3 ? MO_FK_TRI3
                      : nfn == 6 ? MO_FK_TRI6 : MO_FK_QUAD4, s, N, dN);
}

int mo_facet_kind_dim(mo_facet_kind k)
{
  return k == MO_FK_POINT ? 0 : k == MO_FK_LINE2 || k == MO_FK_LINE3 ? 1 : 2;
}

static int gauss_legendre(int order, double *x, double *w, mo_ctx *ctx)
{
  gsl_integration_glfixed_table *t = gsl_integration_glfixed_table_alloc((size_t)order);
  int i;
  if (!t) return mo_error(ctx, MO_ENOMEM, "GSL could not build a %d-point Gauss rule", order);
  for (i = 0; i < order; i++) gsl_integration_glfixed_point(-1, 1, (size_t)i, &x[i], &w[i], t);
  gsl_integration_glfixed_table_free(t);
  return MO_OK;
}

static int tensor_rule(int dim, int order, mo_quad *q, mo_ctx *ctx)
{
  double x[4], w[4];
  int i, j, k, n = 0, st, npts = order * (dim > 1 ? order : 1) * (dim > 2 ? order : 1);
  /* up to 4 points per direction while the rule fits (facets: contact.pairs.[].gauss <= 4) */
  if (order < 1 || order > 4 || npts > MO_QMAX)
    return mo_error(ctx, MO_EINTERNAL, "quadrature order %d in dimension %d", order, dim);
  if ((st = gauss_legendre(order, x, w, ctx))) return st;
  q->dim = dim;
  for (k = 0; k < (dim > 2 ? order : 1); k++)
    for (j = 0; j < (dim > 1 ? order : 1); j++)
      for (i = 0; i < order; i++) {
        q->xi[n][0] = x[i];
        q->xi[n][1] = dim > 1 ? x[j] : 0;
        q->xi[n][2] = dim > 2 ? x[k] : 0;
        q->w[n] = w[i] * (dim > 1 ? w[j] : 1) * (dim > 2 ? w[k] : 1);
        n++;
      }
  q->n = n;
  return MO_OK;
}

/* Symmetric rules on the reference triangle (area 1/2) and tetrahedron (volume 1/6): points
   given by one barycentric coordinate a per orbit. Triangle: degree 1 (centroid), 2 (3 points
   (1/6, 1/6)), 4 (6 points, Strang and Fix / Dunavant), 5 (7 points, Radon); tetrahedron: degree
   1 (centroid), 2 (4 points a = (5 - sqrt 5) / 20), 5 (14 points: two orbits (a, a, a, 1 - 3a)
   and one (a, a, 1/2 - a, 1/2 - a), Walkington's rule). Exactness is checked on the monomials in
   tests/test_elements. */
static void put_point(mo_quad *q, const double *xi, double w)
{
  int i;
  for (i = 0; i < 3; i++) q->xi[q->n][i] = i < q->dim ? xi[i] : 0;
  q->w[q->n++] = w;
}

/* The 3 (triangle) or 4 (tetrahedron) points of the orbit (a, ..., a, 1 - d a). */
static void orbit_corner(mo_quad *q, double a, double w)
{
  int d = q->dim, k, i;
  for (k = 0; k <= d; k++) {
    double L[4], xi[3];
    for (i = 0; i <= d; i++) L[i] = i == k ? 1 - d * a : a;
    for (i = 0; i < d; i++) xi[i] = L[i + 1];
    put_point(q, xi, w);
  }
}

/* The 6 points of the tetrahedron's orbit (a, a, b, b), b = 1/2 - a. */
static void orbit_edge(mo_quad *q, double a, double w)
{
  static const int pairs[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  int k, i;
  for (k = 0; k < 6; k++) {
    double L[4], xi[3];
    for (i = 0; i < 4; i++) L[i] = i == pairs[k][0] || i == pairs[k][1] ? a : 0.5 - a;
    for (i = 0; i < 3; i++) xi[i] = L[i + 1];
    put_point(q, xi, w);
  }
}

static int simplex_rule(int dim, int degree, mo_quad *q, mo_ctx *ctx)
{
  static const double ctr[3] = {1.0 / 3, 1.0 / 3, 0}, ctr3[3] = {0.25, 0.25, 0.25};
  memset(q, 0, sizeof *q);
  q->dim = dim;
  if (dim == 2) {
    if (degree <= 1) put_point(q, ctr, 0.5);
    else if (degree == 2) orbit_corner(q, 1.0 / 6, 1.0 / 6);
    else if (degree <= 4) {
      orbit_corner(q, 0.445948490915965, 0.223381589678011 / 2);
      orbit_corner(q, 0.091576213509771, 0.109951743655322 / 2);
    } else if (degree == 5) {
      double r = sqrt(15.0);
      put_point(q, ctr, 9.0 / 80);
      orbit_corner(q, (6 - r) / 21, (155 - r) / 2400);
      orbit_corner(q, (6 + r) / 21, (155 + r) / 2400);
    } else
      return mo_error(ctx, MO_EINTERNAL, "no triangle rule of degree %d", degree);
    return MO_OK;
  }
  if (degree <= 1) put_point(q, ctr3, 1.0 / 6);
  else if (degree == 2) orbit_corner(q, (5 - sqrt(5.0)) / 20, 1.0 / 24);
  else if (degree <= 5) {
    orbit_corner(q, 0.3108859192633006, 0.01878132095300264);
    orbit_corner(q, 0.0927352503108912, 0.01224884051939366);
    orbit_edge(q, 0.0455037041256496, 0.007091003462846911);
  } else
    return mo_error(ctx, MO_EINTERNAL, "no tetrahedron rule of degree %d", degree);
  return MO_OK;
}

int mo_quad_element(mo_eltype t, int order, mo_quad *q, mo_ctx *ctx)
{
  memset(q, 0, sizeof *q);
  if (t == MO_EL_T3 || t == MO_EL_T6) return simplex_rule(2, order, q, ctx);
  if (t == MO_EL_T4 || t == MO_EL_T10) return simplex_rule(3, order, q, ctx);
  return tensor_rule(mo_eltype_get(t)->dim, order, q, ctx);
}

int mo_quad_facet(int fdim, int order, mo_quad *q, mo_ctx *ctx)
{
  memset(q, 0, sizeof *q);
  if (fdim == 0) {
    q->n = 1;
    q->w[0] = 1;
    return MO_OK;
  }
  return tensor_rule(fdim, order, q, ctx);
}

int mo_quad_facet_kind(mo_facet_kind k, int order, mo_quad *q, mo_ctx *ctx)
{
  static const int tri_degree[5] = {1, 1, 4, 5, 5}; /* at least 2 order - 1, Gauss-like */
  if (k == MO_FK_TRI3 || k == MO_FK_TRI6) {
    if (order < 1 || order > 4) return mo_error(ctx, MO_EINTERNAL, "triangle facet rule of order %d", order);
    if (order < 4) return simplex_rule(2, tri_degree[order], q, ctx);
    /* order 4 (degree 7): the collapsed product of 5 Gauss points per direction (degree 8) */
    {
      double x[5], w[5];
      int i, j, st;
      memset(q, 0, sizeof *q);
      q->dim = 2;
      if ((st = gauss_legendre(5, x, w, ctx))) return st;
      for (i = 0; i < 5; i++)
        for (j = 0; j < 5; j++) {
          double u = 0.5 * (1 + x[i]), v = 0.5 * (1 + x[j]), xi[2];
          xi[0] = u * (1 - v);
          xi[1] = u * v;
          put_point(q, xi, 0.25 * w[i] * w[j] * u);
        }
      return MO_OK;
    }
  }
  return mo_quad_facet(mo_facet_kind_dim(k), order, q, ctx);
}

void mo_elastic_D(const mo_material *m, double *D)
{
  double E = m->E, nu = m->nu;
  double lam = E * nu / ((1 + nu) * (1 - 2 * nu)), mu = E / (2 * (1 + nu));
  int i, j;
  switch (m->hyp) {
  case MO_HYP_BAR: D[0] = E; break;
  case MO_HYP_PLANE_STRESS: {
    double c = E / (1 - nu * nu);
    memset(D, 0, 16 * sizeof *D);
    D[0] = c; D[1] = c * nu;
    D[4] = c * nu; D[5] = c;
    D[10] = mu;
    break;
  }
  case MO_HYP_PLANE_STRAIN:
  case MO_HYP_AXISYMMETRIC: {
    /* order (xx|rr, yy|zz, xy|rz, zz|tt): normal components 0, 1, 3; shear 2 */
    static const int nrm[3] = {0, 1, 3};
    memset(D, 0, 16 * sizeof *D);
    for (i = 0; i < 3; i++)
      for (j = 0; j < 3; j++) D[nrm[i] * 4 + nrm[j]] = lam + (i == j ? 2 * mu : 0);
    D[2 * 4 + 2] = mu;
    break;
  }
  case MO_HYP_3D:
    memset(D, 0, 36 * sizeof *D);
    for (i = 0; i < 3; i++)
      for (j = 0; j < 3; j++) D[i * 6 + j] = lam + (i == j ? 2 * mu : 0);
    for (i = 3; i < 6; i++) D[i * 6 + i] = mu;
    break;
  }
}

double mo_elem_geometry(const mo_mesh *msh, int e, const double *xi, double *N, double *dNx,
                        double *xq)
{
  const mo_eltype_info *T = mo_eltype_get(msh->type);
  const int *c = &msh->conn[(size_t)e * (size_t)msh->nen];
  int D = msh->dim, nen = T->nen, a, i, j;
  double dN[3 * MO_NEN_MAX], J[9] = {0}, Ji[9], det;
  mo_shape(msh->type, xi, N, dN);
  for (i = 0; i < D; i++) xq[i] = 0;
  for (a = 0; a < nen; a++) {
    const double *x = &msh->x[(size_t)c[a] * (size_t)D];
    for (i = 0; i < D; i++) {
      xq[i] += N[a] * x[i];
      for (j = 0; j < D; j++) J[i * D + j] += x[i] * dN[a * D + j]; /* dx_i/dxi_j */
    }
  }
  if (D == 1) {
    det = J[0];
    Ji[0] = 1 / det;
  } else if (D == 2) {
    det = J[0] * J[3] - J[1] * J[2];
    Ji[0] = J[3] / det; Ji[1] = -J[1] / det;
    Ji[2] = -J[2] / det; Ji[3] = J[0] / det;
  } else {
    det = J[0] * (J[4] * J[8] - J[5] * J[7]) - J[1] * (J[3] * J[8] - J[5] * J[6]) +
          J[2] * (J[3] * J[7] - J[4] * J[6]);
    Ji[0] = (J[4] * J[8] - J[5] * J[7]) / det;
    Ji[1] = (J[2] * J[7] - J[1] * J[8]) / det;
    Ji[2] = (J[1] * J[5] - J[2] * J[4]) / det;
    Ji[3] = (J[5] * J[6] - J[3] * J[8]) / det;
    Ji[4] = (J[0] * J[8] - J[2] * J[6]) / det;
    Ji[5] = (J[2] * J[3] - J[0] * J[5]) / det;
    Ji[6] = (J[3] * J[7] - J[4] * J[6]) / det;
    Ji[7] = (J[1] * J[6] - J[0] * J[7]) / det;
    Ji[8] = (J[0] * J[4] - J[1] * J[3]) / det;
  }
  /* dN/dx_i = sum_j dN/dxi_j (J^-1)_{j i} */
  for (a = 0; a < nen; a++)
    for (i = 0; i < D; i++) {
      double s = 0;
      for (j = 0; j < D; j++) s += dN[a * D + j] * Ji[j * D + i];
      dNx[a * D + i] = s;
    }
  return det;
}

double mo_measure_factor(const mo_material *mat, const double *xq)
{
  switch (mat->hyp) {
  case MO_HYP_BAR: return mat->area;
  case MO_HYP_PLANE_STRAIN:
  case MO_HYP_PLANE_STRESS: return mat->thickness;
  case MO_HYP_AXISYMMETRIC: return 2 * M_PI * xq[0];
  default: return 1;
  }
}

/* Strain-displacement matrix B (ncomp x nen*dim, engineering shear). */
static void bmatrix(const mo_material *mat, int nen, int D, const double *N, const double *dNx,
                    const double *xq, double *B)
{
  int nc = mo_hyp_ncomp(mat->hyp), nd = nen * D, a;
  memset(B, 0, (size_t)nc * (size_t)nd * sizeof *B);
  for (a = 0; a < nen; a++) {
    const double *g = &dNx[a * D];
    switch (mat->hyp) {
    case MO_HYP_BAR: B[a] = g[0]; break;
    case MO_HYP_3D:
      B[0 * nd + 3 * a] = g[0];
      B[1 * nd + 3 * a + 1] = g[1];
      B[2 * nd + 3 * a + 2] = g[2];
      B[3 * nd + 3 * a + 1] = g[2]; B[3 * nd + 3 * a + 2] = g[1];
      B[4 * nd + 3 * a] = g[2];     B[4 * nd + 3 * a + 2] = g[0];
      B[5 * nd + 3 * a] = g[1];     B[5 * nd + 3 * a + 1] = g[0];
      break;
    default:
      B[0 * nd + 2 * a] = g[0];
      B[1 * nd + 2 * a + 1] = g[1];
      B[2 * nd + 2 * a] = g[1]; B[2 * nd + 2 * a + 1] = g[0];
      if (mat->hyp == MO_HYP_AXISYMMETRIC) B[3 * nd + 2 * a] = N[a] / xq[0];
      break;
    }
  }
}

/* The stiffness rule: full integration of straight elements (2 Gauss points per direction;
   simplices: the degree 2 (p - 1) of B^T D B, i.e. the centroid for T3 and T4, degree 2 for T6 and
   T10); axisymmetric triangles take the hoop term u_r / r, not a polynomial, with degree 2 (T3)
   and 4 (T6) (doc/theory.md §2, (T190)). */
static int stiff_order(mo_eltype t, mo_hypothesis h)
{
  int ax = h == MO_HYP_AXISYMMETRIC;
  switch (t) {
  case MO_EL_T3: return ax ? 2 : 1;
  case MO_EL_T6: return ax ? 4 : 2;
  case MO_EL_T4: return 1;
  case MO_EL_T10: return 2;
  default: return 2;
  }
}

/* The mass rule, exact for the consistent mass of straight elements (N_a N_b: degree 2 p on
   simplices; 2 Gauss points per direction otherwise), and for measures. */
static int mass_order(mo_eltype t)
{
  return t == MO_EL_T6 || t == MO_EL_T10 ? 4 : 2;
}

int mo_elem_stiffness(const mo_mesh *msh, int e, const mo_material *mat, double *Ke,
                      mo_ctx *ctx)
{
  const mo_eltype_info *T = mo_eltype_get(msh->type);
  int D = msh->dim, nen = T->nen, nd = nen * D, nc = mo_hyp_ncomp(mat->hyp), q, i, j, k, st;
  double N[MO_NEN_MAX], dNx[3 * MO_NEN_MAX], xq[3], B[6 * MO_ND_MAX], DB[6 * MO_ND_MAX], Dm[36];
  mo_quad Q;
  if ((st = mo_quad_element(msh->type, stiff_order(msh->type, mat->hyp), &Q, ctx))) return st;
  mo_elastic_D(mat, Dm);
  memset(Ke, 0, (size_t)nd * (size_t)nd * sizeof *Ke);
  for (q = 0; q < Q.n; q++) {
    double det = mo_elem_geometry(msh, e, Q.xi[q], N, dNx, xq), wq;
    if (!(det > 0))
      return mo_error(ctx, MO_EINPUT, "element %d has a non-positive Jacobian (%g)", e, det);
    wq = det * Q.w[q] * mo_measure_factor(mat, xq);
    bmatrix(mat, nen, D, N, dNx, xq, B);
    for (i = 0; i < nc; i++)
      for (j = 0; j < nd; j++) {
        double s = 0;
        for (k = 0; k < nc; k++) s += Dm[i * nc + k] * B[k * nd + j];
        DB[i * nd + j] = s;
      }
    for (i = 0; i < nd; i++)
      for (j = 0; j < nd; j++) {
        double s = 0;
        for (k = 0; k < nc; k++) s += B[k * nd + i] * DB[k * nd + j];
        Ke[i * nd + j] += wq * s;
      }
  }
  return MO_OK;
}

int mo_elem_mass(const mo_mesh *msh, int e, const mo_material *mat, int lumped, double *Me,
                 mo_ctx *ctx)
{
  const mo_eltype_info *T = mo_eltype_get(msh->type);
  int D = msh->dim, nen = T->nen, nd = nen * D, q, a, b, i, st;
  double N[MO_NEN_MAX], dNx[3 * MO_NEN_MAX], xq[3], Ms[MO_NEN_MAX * MO_NEN_MAX];
  mo_quad Q;
  if ((st = mo_quad_element(msh->type, mass_order(msh->type), &Q, ctx))) return st;
  memset(Ms, 0, sizeof Ms);
  for (q = 0; q < Q.n; q++) {
    double det = mo_elem_geometry(msh, e, Q.xi[q], N, dNx, xq);
    double wq = det * Q.w[q] * mo_measure_factor(mat, xq) * mat->rho;
    if (!(det > 0))
      return mo_error(ctx, MO_EINPUT, "element %d has a non-positive Jacobian (%g)", e, det);
    for (a = 0; a < nen; a++)
      for (b = 0; b < nen; b++) Ms[a * nen + b] += wq * N[a] * N[b];
  }
  if (lumped && T->order == 1) /* row sums: all positive for the linear types */
    for (a = 0; a < nen; a++) {
      double s = 0;
      for (b = 0; b < nen; b++) { s += Ms[a * nen + b]; Ms[a * nen + b] = 0; }
      Ms[a * nen + a] = s;
    } else if (lumped) {
    /* HRZ (Hinton, Rock and Zienkiewicz 1976): the diagonal scaled to the element's mass; row
       sums would give T6 corners 0 and T10 corners -1/20 of it (T191) */
    double m = 0, dsum = 0;
    for (a = 0; a < nen; a++) {
      dsum += Ms[a * nen + a];
      for (b = 0; b < nen; b++) m += Ms[a * nen + b];
    }
    for (a = 0; a < nen; a++)
      for (b = 0; b < nen; b++) Ms[a * nen + b] = a == b ? Ms[a * nen + a] * m / dsum : 0;
  }
  memset(Me, 0, (size_t)nd * (size_t)nd * sizeof *Me);
  for (a = 0; a < nen; a++)
    for (b = 0; b < nen; b++)
      for (i = 0; i < D; i++) Me[(a * D + i) * nd + b * D + i] = Ms[a * nen + b];
  return MO_OK;
}

int mo_elem_stress(const mo_mesh *msh, int e, const mo_material *mat, const double *ue,
                   double *eps, double *sig)
{
  const mo_eltype_info *T = mo_eltype_get(msh->type);
  int D = msh->dim, nen = T->nen, nd = nen * D, nc = mo_hyp_ncomp(mat->hyp), i, j;
  double N[MO_NEN_MAX], dNx[3 * MO_NEN_MAX], xq[3], B[6 * MO_ND_MAX], Dm[36];
  mo_elem_geometry(msh, e, T->centre, N, dNx, xq);
  bmatrix(mat, nen, D, N, dNx, xq, B);
  mo_elastic_D(mat, Dm);
  for (i = 0; i < nc; i++) {
    double s = 0;
    for (j = 0; j < nd; j++) s += B[i * nd + j] * ue[j];
    eps[i] = s;
  }
  for (i = 0; i < nc; i++) {
    double s = 0;
    for (j = 0; j < nc; j++) s += Dm[i * nc + j] * eps[j];
    sig[i] = s;
  }
  if (mat->hyp == MO_HYP_PLANE_STRESS) /* out-of-plane strain from sigma_zz = 0 */
    eps[3] = -mat->nu / (1 - mat->nu) * (eps[0] + eps[1]);
  /* report tensor shear strains */
  if (mat->hyp == MO_HYP_3D) { eps[3] *= 0.5; eps[4] *= 0.5; eps[5] *= 0.5; }
  else if (mat->hyp != MO_HYP_BAR) eps[2] *= 0.5;
  return MO_OK;
}

double mo_elem_measure(const mo_mesh *msh, int e, const mo_material *mat)
{
  double N[MO_NEN_MAX], dNx[3 * MO_NEN_MAX], xq[3], s = 0;
  mo_quad Q;
  mo_ctx c;
  int q;
  mo_ctx_init(&c);
  if (mo_quad_element(msh->type, mass_order(msh->type), &Q, &c)) return NAN;
  for (q = 0; q < Q.n; q++) {
    double det = mo_elem_geometry(msh, e, Q.xi[q], N, dNx, xq);
    s += det * Q.w[q] * mo_measure_factor(mat, xq);
  }
  return s;
}

/* Facet geometry at facet coordinates s: point, tangent(s), unit normal, measure density. */
static double facet_geom(const mo_mesh *msh, const int *fn, mo_facet_kind kind, int nfn, int lface,
                         const double *s, double *N, double *xq, double *n)
{
  int D = msh->dim, fd = mo_facet_kind_dim(kind), a, i;
  double dN[2 * MO_FNODE_MAX], t1[3] = {0, 0, 0}, t2[3] = {0, 0, 0}, len;
  mo_facet_shape_kind(kind, s, N, dN);
  for (i = 0; i < D; i++) xq[i] = 0;
  for (a = 0; a < nfn; a++) {
    const double *x = &msh->x[(size_t)fn[a] * (size_t)D];
    for (i = 0; i < D; i++) {
      xq[i] += N[a] * x[i];
      if (fd >= 1) t1[i] += dN[a * fd] * x[i];
      if (fd == 2) t2[i] += dN[a * 2 + 1] * x[i];
    }
  }
  if (D == 1) {
    n[0] = lface == 0 ? -1 : 1;
    return 1;
  }
  if (D == 2) {
    len = sqrt(t1[0] * t1[0] + t1[1] * t1[1]);
    n[0] = t1[1] / len;
    n[1] = -t1[0] / len;
    return len;
  }
  n[0] = t1[1] * t2[2] - t1[2] * t2[1];
  n[1] = t1[2] * t2[0] - t1[0] * t2[2];
  n[2] = t1[0] * t2[1] - t1[1] * t2[0];
  len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  for (i = 0; i < 3; i++) n[i] /= len;
  return len;
}

/* The facet rule of the loads: exact for a uniform traction on straight facets and for the
   linear variation of 2 pi r (2 Gauss points per direction, degree 4 on triangles). */
static int load_rule(mo_facet_kind k, mo_quad *Q, mo_ctx *ctx)
{
  return mo_quad_facet_kind(k, k == MO_FK_TRI3 || k == MO_FK_TRI6 ? 3 : 2, Q, ctx);
}

int mo_facet_load(const mo_mesh *msh, const mo_facetset *fs, int f, const mo_material *mat,
                  mo_traction_fn traction, void *data, double *fe, mo_ctx *ctx)
{
  int D = msh->dim, nfn = fs->nfn, q, a, i, st;
  const int *fn = &fs->node[f * nfn];
  double N[MO_FNODE_MAX], xq[3], n[3], t[3];
  mo_quad Q;
  if ((st = load_rule(fs->kind, &Q, ctx))) return st;
  memset(fe, 0, (size_t)nfn * (size_t)D * sizeof *fe);
  for (q = 0; q < Q.n; q++) {
    double jac = facet_geom(msh, fn, fs->kind, nfn, fs->lface[f], Q.xi[q], N, xq, n);
    double w = jac * Q.w[q] * mo_measure_factor(mat, xq);
    if (D == 3) w = jac * Q.w[q];
    traction(xq, n, data, t);
    for (a = 0; a < nfn; a++)
      for (i = 0; i < D; i++) fe[a * D + i] += w * N[a] * t[i];
  }
  return MO_OK;
}

void mo_facet_normal(const mo_mesh *msh, const mo_facetset *fs, int f, double *n,
                     double *measure)
{
  static const double ctr[3][2] = {{0, 0}, {0, 0}, {1.0 / 3, 1.0 / 3}};
  const int *fn = &fs->node[f * fs->nfn];
  double N[MO_FNODE_MAX], xq[3], nq[3];
  int tri = fs->kind == MO_FK_TRI3 || fs->kind == MO_FK_TRI6, q;
  mo_quad Q;
  mo_ctx c;
  facet_geom(msh, fn, fs->kind, fs->nfn, fs->lface[f], ctr[tri ? 2 : 0], N, xq, n);
  if (!measure) return;
  *measure = 0;
  mo_ctx_init(&c);
  if (fs->kind == MO_FK_POINT || load_rule(fs->kind, &Q, &c)) {
    *measure = 1;
    return;
  }
  for (q = 0; q < Q.n; q++) *measure += Q.w[q] * facet_geom(msh, fn, fs->kind, fs->nfn, fs->lface[f], Q.xi[q], N, xq, nq);
}

double mo_von_mises(mo_hypothesis h, const double *s)
{
  switch (h) {
  case MO_HYP_BAR: return fabs(s[0]);
  case MO_HYP_3D:
    return sqrt(0.5 * ((s[0] - s[1]) * (s[0] - s[1]) + (s[1] - s[2]) * (s[1] - s[2]) +
                       (s[2] - s[0]) * (s[2] - s[0])) +
                3 * (s[3] * s[3] + s[4] * s[4] + s[5] * s[5]));
  default: /* xx yy xy zz */
    return sqrt(0.5 * ((s[0] - s[1]) * (s[0] - s[1]) + (s[1] - s[3]) * (s[1] - s[3]) +
                       (s[3] - s[0]) * (s[3] - s[0])) +
                3 * s[2] * s[2]);
  }
}
