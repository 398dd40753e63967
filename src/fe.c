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
  default: break;
  }
}

void mo_facet_shape(int nfn, const double *s, double *N, double *dN)
{
  if (nfn == 1) {
    N[0] = 1;
  } else if (nfn == 2) {
    mo_shape(MO_EL_BAR2, s, N, dN);
  } else {
    mo_shape(MO_EL_Q4, s, N, dN);
  }
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

int mo_quad_element(mo_eltype t, int order, mo_quad *q, mo_ctx *ctx)
{
  memset(q, 0, sizeof *q);
  if (t == MO_EL_T3) {
    q->dim = 2;
    if (order <= 1) {
      q->n = 1;
      q->xi[0][0] = q->xi[0][1] = 1.0 / 3;
      q->w[0] = 0.5;
    } else { /* degree-2 rule: exact for the consistent mass */
      static const double p[3][2] = {{1.0 / 6, 1.0 / 6}, {2.0 / 3, 1.0 / 6}, {1.0 / 6, 2.0 / 3}};
      int i;
      q->n = 3;
      for (i = 0; i < 3; i++) {
        q->xi[i][0] = p[i][0];
        q->xi[i][1] = p[i][1];
        q->w[i] = 1.0 / 6;
      }
    }
    return MO_OK;
  }
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
  double dN[24], J[9] = {0}, Ji[9], det;
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

static int stiff_order(mo_eltype t) { return t == MO_EL_T3 ? 1 : 2; }

int mo_elem_stiffness(const mo_mesh *msh, int e, const mo_material *mat, double *Ke,
                      mo_ctx *ctx)
{
  const mo_eltype_info *T = mo_eltype_get(msh->type);
  int D = msh->dim, nen = T->nen, nd = nen * D, nc = mo_hyp_ncomp(mat->hyp), q, i, j, k, st;
  double N[8], dNx[24], xq[3], B[6 * 24], DB[6 * 24], Dm[36];
  mo_quad Q;
  /* axisymmetric T3: the hoop strain u_r/r needs more than the centroid */
  if ((st = mo_quad_element(msh->type, (msh->type == MO_EL_T3 && mat->hyp == MO_HYP_AXISYMMETRIC)
                                           ? 2 : stiff_order(msh->type), &Q, ctx)))
    return st;
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
  double N[8], dNx[24], xq[3], Ms[64];
  mo_quad Q;
  /* exact for the consistent mass of every type (bilinear products) */
  if ((st = mo_quad_element(msh->type, 2, &Q, ctx))) return st;
  memset(Ms, 0, sizeof Ms);
  for (q = 0; q < Q.n; q++) {
    double det = mo_elem_geometry(msh, e, Q.xi[q], N, dNx, xq);
    double wq = det * Q.w[q] * mo_measure_factor(mat, xq) * mat->rho;
    if (!(det > 0))
      return mo_error(ctx, MO_EINPUT, "element %d has a non-positive Jacobian (%g)", e, det);
    for (a = 0; a < nen; a++)
      for (b = 0; b < nen; b++) Ms[a * nen + b] += wq * N[a] * N[b];
  }
  if (lumped)
    for (a = 0; a < nen; a++) {
      double s = 0;
      for (b = 0; b < nen; b++) { s += Ms[a * nen + b]; Ms[a * nen + b] = 0; }
      Ms[a * nen + a] = s;
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
  double N[8], dNx[24], xq[3], B[6 * 24], Dm[36], c[3] = {0, 0, 0};
  if (msh->type == MO_EL_T3) c[0] = c[1] = 1.0 / 3;
  mo_elem_geometry(msh, e, c, N, dNx, xq);
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
  double N[8], dNx[24], xq[3], s = 0;
  mo_quad Q;
  mo_ctx c;
  int q;
  mo_ctx_init(&c);
  if (mo_quad_element(msh->type, 2, &Q, &c)) return NAN;
  for (q = 0; q < Q.n; q++) {
    double det = mo_elem_geometry(msh, e, Q.xi[q], N, dNx, xq);
    s += det * Q.w[q] * mo_measure_factor(mat, xq);
  }
  return s;
}

/* Facet geometry at facet coordinates s: point, tangent(s), unit normal, measure density. */
static double facet_geom(const mo_mesh *msh, const int *fn, int nfn, int lface, const double *s,
                         double *N, double *xq, double *n)
{
  int D = msh->dim, a, i;
  double dN[8], t1[3] = {0, 0, 0}, t2[3] = {0, 0, 0}, len;
  mo_facet_shape(nfn, s, N, dN);
  for (i = 0; i < D; i++) xq[i] = 0;
  for (a = 0; a < nfn; a++) {
    const double *x = &msh->x[(size_t)fn[a] * (size_t)D];
    for (i = 0; i < D; i++) {
      xq[i] += N[a] * x[i];
      if (nfn >= 2) t1[i] += dN[a * (nfn == 2 ? 1 : 2)] * x[i];
      if (nfn == 4) t2[i] += dN[a * 2 + 1] * x[i];
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

int mo_facet_load(const mo_mesh *msh, const mo_facetset *fs, int f, const mo_material *mat,
                  mo_traction_fn traction, void *data, double *fe, mo_ctx *ctx)
{
  int D = msh->dim, nfn = fs->nfn, q, a, i, st;
  const int *fn = &fs->node[f * nfn];
  double N[4], xq[3], n[3], t[3];
  mo_quad Q;
  if ((st = mo_quad_facet(D - 1, 2, &Q, ctx))) return st;
  memset(fe, 0, (size_t)nfn * (size_t)D * sizeof *fe);
  for (q = 0; q < Q.n; q++) {
    double jac = facet_geom(msh, fn, nfn, fs->lface[f], Q.xi[q], N, xq, n);
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
  double s[2] = {0, 0}, N[4], xq[3], jac;
  jac = facet_geom(msh, &fs->node[f * fs->nfn], fs->nfn, fs->lface[f], s, N, xq, n);
  if (measure) *measure = fs->nfn == 1 ? 1 : jac * (fs->nfn == 2 ? 2 : 4);
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
