/* material.c: finite-strain J2 plasticity at a quadrature point: Hencky elasticity in the
   logarithmic elastic strain, exponential-map radial return, consistent spatial tangent
   (doc/theory.md §7, (T23)-(T31)). */
#include "config.h"
#include <moreau/material.h>

#include <math.h>
#include <string.h>

#include "tensor3.h"

double mo_j2_hardening(const mo_material *mat)
{
  return mat->E * mat->Et / (mat->E - mat->Et); /* (T27) */
}

int mo_j2_check(const mo_material *m, mo_ctx *ctx)
{
  if (m->hyp != MO_HYP_PLANE_STRAIN && m->hyp != MO_HYP_AXISYMMETRIC && m->hyp != MO_HYP_3D)
    return mo_error(ctx, MO_EUNSUPPORTED, "finite strains: hypothesis '%s' is not supported "
                    "(plane strain, axisymmetric or 3D)", mo_hyp_name(m->hyp));
  if (!(m->E > 0) || !isfinite(m->E))
    return mo_error(ctx, MO_EINPUT, "finite strains: E = %g must be positive", m->E);
  if (!(m->nu > -1 && m->nu < 0.5))
    return mo_error(ctx, MO_EINPUT, "finite strains: nu = %g is outside (-1, 0.5)", m->nu);
  if (m->model == MO_MAT_J2) {
    if (!(m->sigma_y > 0) || !isfinite(m->sigma_y))
      return mo_error(ctx, MO_EINPUT, "J2: sigma_y = %g must be positive", m->sigma_y);
    if (!(m->Et >= 0 && m->Et < m->E))
      return mo_error(ctx, MO_EINPUT, "J2: Et = %g must satisfy 0 <= Et < E = %g", m->Et, m->E);
  } else if (m->model != MO_MAT_ELASTIC) {
    return mo_error(ctx, MO_EINPUT, "finite strains: unknown material model %d", (int)m->model);
  }
  return MO_OK;
}

void mo_j2_state_init(mo_hypothesis h, double *state, int npoint)
{
  static const double I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  int q;
  for (q = 0; q < npoint; q++) {
    double *s = state + (size_t)q * MO_J2_NSTATE;
    memset(s, 0, MO_J2_NSTATE * sizeof *s);
    t3_to_sym(h, I, s + MO_J2_CPINV);
    s[MO_J2_DETF] = 1;
  }
}

/* Eigen-decomposition be = Q diag(x) Q^T of a symmetric tensor whose 3rd axis is principal
   (plane strain, axisymmetry): closed form in the (1, 2) plane. Columns of Q are the
   eigenvectors; the first, of x0 = m + r, is (d + r, b12) or (b12, r - d), whichever has no
   cancellation. Exactly repeated eigenvalues give Q = I. */
static void eig_block2(const double *b, double *x, double *Q)
{
  double m = 0.5 * (b[0] + b[4]), d = 0.5 * (b[0] - b[4]), r = hypot(d, b[1]), c = 1, s = 0;
  x[0] = m + r;
  x[1] = m - r;
  x[2] = b[8];
  if (r > 0) {
    double v0 = d >= 0 ? d + r : b[1], v1 = d >= 0 ? b[1] : r - d, n = hypot(v0, v1);
    c = v0 / n;
    s = v1 / n;
  }
  Q[0] = c; Q[1] = -s; Q[2] = 0;
  Q[3] = s; Q[4] = c;  Q[5] = 0;
  Q[6] = 0; Q[7] = 0;  Q[8] = 1;
}

/* Cyclic Jacobi for a symmetric 3x3 tensor (Golub and Van Loan, Algorithm 8.4.3): eigenvectors
   orthonormal to round-off whatever the gaps between eigenvalues, which the tangent's divided
   differences (T31) need; it converges quadratically (3 to 5 sweeps). */
static void eig_jacobi3(const double *b, double *x, double *Q)
{
  static const int P[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  double a[9];
  int sweep, k, r;
  memcpy(a, b, sizeof a);
  memset(Q, 0, 9 * sizeof *Q);
  Q[0] = Q[4] = Q[8] = 1;
  for (sweep = 0; sweep < 16; sweep++) {
    double off = a[1] * a[1] + a[2] * a[2] + a[5] * a[5];
    double dia = a[0] * a[0] + a[4] * a[4] + a[8] * a[8];
    if (off <= 1e-36 * dia) break;
    for (k = 0; k < 3; k++) {
      int p = P[k][0], q = P[k][1];
      double apq = a[3 * p + q], th, t, c, s;
      if (apq == 0) continue;
      th = (a[3 * q + q] - a[3 * p + p]) / (2 * apq);
      t = (th >= 0 ? 1 : -1) / (fabs(th) + sqrt(th * th + 1));
      c = 1 / sqrt(t * t + 1);
      s = t * c;
      /* a <- J^T a J, J the rotation by (c, s) in the (p, q) plane */
      a[3 * p + p] -= t * apq;
      a[3 * q + q] += t * apq;
      a[3 * p + q] = a[3 * q + p] = 0;
      r = 3 - p - q; /* the third index */
      {
        double arp = a[3 * r + p], arq = a[3 * r + q];
        a[3 * r + p] = a[3 * p + r] = c * arp - s * arq;
        a[3 * r + q] = a[3 * q + r] = s * arp + c * arq;
      }
      for (r = 0; r < 3; r++) {
        double vp = Q[3 * r + p], vq = Q[3 * r + q];
        Q[3 * r + p] = c * vp - s * vq;
        Q[3 * r + q] = s * vp + c * vq;
      }
    }
  }
  x[0] = a[0];
  x[1] = a[4];
  x[2] = a[8];
}

/* First divided difference of ln: (ln x - ln y) / (x - y), and its limit 1/x when y = x.
   With u = (x - y)/(x + y), ln(x/y) = 2 atanh(u): no cancellation near y = x. */
static double dlog(double x, double y)
{
  double u = (x - y) / (x + y), g;
  if (fabs(u) < 1e-4) g = 1 + u * u * (1.0 / 3 + u * u / 5); /* atanh(u)/u, error < u^6/7 */
  else g = atanh(u) / u;
  return 2 * g / (x + y);
}

int mo_j2_update(const mo_material *mat, const double *F, const double *sn, double *s,
                 double *tau, double *A, mo_ctx *ctx)
{
  const mo_hypothesis hyp = mat->hyp;
  const int three = hyp == MO_HYP_3D, plastic = mat->model == MO_MAT_J2;
  const double E = mat->E, nu = mat->nu;
  const double K = E / (3 * (1 - 2 * nu)), G = E / (2 * (1 + nu));
  const double H = plastic ? mo_j2_hardening(mat) : 0, sy0 = mat->sigma_y;
  double Cpi[9], T[9], be[9], x[3], Q[9], e[3], dev[3], str[3], tp[3];
  double th, qtr, nstr, epsp_n, wp_n, syn, dep = 0, alpha = 1, c = 0, J, psi;
  int i;

  /* read the history first: s may alias sn */
  t3_from_sym(hyp, sn + MO_J2_CPINV, Cpi);
  epsp_n = sn[MO_J2_EPSP];
  wp_n = sn[MO_J2_WP];
  J = t3_det(F);
  if (!(J > 0) || !isfinite(J))
    return mo_error(ctx, MO_ENAN, "finite strains: det F = %g is not positive", J);

  /* elastic trial be = F Cp^-1 F^T (T24), its spectral decomposition and log strains */
  t3_mul(F, Cpi, T);
  t3_mul_nt(T, F, be);
  if (three) eig_jacobi3(be, x, Q);
  else eig_block2(be, x, Q);
  for (i = 0; i < 3; i++) {
    if (!(x[i] > 0) || !isfinite(x[i]))
      return mo_error(ctx, MO_ENAN, "finite strains: elastic trial stretch^2 %g is not "
                      "positive", x[i]);
    e[i] = 0.5 * log(x[i]);
  }
  th = e[0] + e[1] + e[2];
  for (i = 0; i < 3; i++) {
    dev[i] = e[i] - th / 3;
    str[i] = 2 * G * dev[i]; /* trial deviatoric Kirchhoff stress (T25) */
  }
  nstr = sqrt(str[0] * str[0] + str[1] * str[1] + str[2] * str[2]);
  qtr = sqrt(1.5) * nstr;
  syn = sy0 + H * epsp_n;

  /* radial return in principal space (T26)-(T28) */
  if (plastic && qtr > syn) {
    dep = (qtr - syn) / (3 * G + H);
    alpha = 1 - 3 * G * dep / qtr;
    c = 1 / (3 * G + H) - dep / qtr;
  }
  for (i = 0; i < 3; i++) tp[i] = K * th + alpha * str[i];
  t3_spectral(Q, tp, tau);

  /* trial state */
  if (dep > 0) {
    double xe[3], ben[9], Fi[9];
    for (i = 0; i < 3; i++) xe[i] = exp(2 * (alpha * dev[i] + th / 3)); /* be = exp(2 eps_e) */
    t3_spectral(Q, xe, ben);
    t3_inv(F, Fi);
    t3_mul(Fi, ben, T);
    t3_mul_nt(T, Fi, Cpi); /* Cp^-1 = F^-1 be F^-T */
  }
  memset(s, 0, MO_J2_NSTATE * sizeof *s);
  t3_to_sym(hyp, Cpi, s + MO_J2_CPINV);
  s[MO_J2_EPSP] = epsp_n + dep;
  s[MO_J2_WP] = wp_n + 0.5 * (syn + sy0 + H * (epsp_n + dep)) * dep; /* (T29) */
  psi = 0.5 * K * th * th;
  for (i = 0; i < 3; i++) psi += G * alpha * alpha * dev[i] * dev[i];
  s[MO_J2_PSI] = psi;
  for (i = 0; i < 9; i++) T[i] = tau[i] / J;
  t3_to_sym(hyp, T, s + MO_J2_SIG);
  s[MO_J2_DETF] = J;

  /* consistent tangent d tau = A : dl (T30)-(T31), built column by column (dl = e_k (x) e_l)
     in the principal frame: d eps' = dlog-weighted symmetric part of (dl' be' + be' dl'^T) / 2,
     d tau' = D_ep : d eps', d tau = Q d tau' Q^T */
  if (A) {
    static const int cols2[5][2] = {{0, 0}, {0, 1}, {1, 0}, {1, 1}, {2, 2}};
    double Dd[3][3], nh[3], f1[3][3];
    int j, r, t, col, ncol = three ? 9 : 5;
    for (i = 0; i < 3; i++) nh[i] = nstr > 0 ? str[i] / nstr : 0;
    for (i = 0; i < 3; i++)
      for (j = 0; j < 3; j++) {
        Dd[i][j] = K + 2 * G * alpha * ((i == j) - 1.0 / 3) - 6 * G * G * c * nh[i] * nh[j];
        f1[i][j] = i == j ? 1 / x[i] : dlog(x[i], x[j]);
      }
    memset(A, 0, 81 * sizeof *A);
    for (col = 0; col < ncol; col++) {
      int k = three ? col / 3 : cols2[col][0], l = three ? col % 3 : cols2[col][1];
      double de[3][3], dt[3][3], W[3][3];
      const double *qk = Q + 3 * k, *ql = Q + 3 * l; /* rows k and l of Q */
      for (r = 0; r < 3; r++) {
        de[r][r] = qk[r] * ql[r];
        for (t = r + 1; t < 3; t++)
          de[r][t] = de[t][r] = 0.5 * f1[r][t] * (x[t] * qk[r] * ql[t] + x[r] * qk[t] * ql[r]);
      }
      for (r = 0; r < 3; r++) {
        dt[r][r] = Dd[r][0] * de[0][0] + Dd[r][1] * de[1][1] + Dd[r][2] * de[2][2];
        for (t = r + 1; t < 3; t++) dt[r][t] = dt[t][r] = 2 * G * alpha * de[r][t];
      }
      /* W = Q dt, d tau = W Q^T */
      for (i = 0; i < 3; i++)
        for (t = 0; t < 3; t++)
          W[i][t] = Q[3 * i] * dt[0][t] + Q[3 * i + 1] * dt[1][t] + Q[3 * i + 2] * dt[2][t];
      for (i = 0; i < 3; i++)
        for (j = i; j < 3; j++) {
          double v = W[i][0] * Q[3 * j] + W[i][1] * Q[3 * j + 1] + W[i][2] * Q[3 * j + 2];
          A[(3 * i + j) * 9 + 3 * k + l] = A[(3 * j + i) * 9 + 3 * k + l] = v;
        }
    }
  }
  return MO_OK;
}
