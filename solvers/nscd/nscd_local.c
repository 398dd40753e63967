/* nscd_local.c: the one-contact problems of the nonlinear Gauss-Seidel (doc/theory.md §8.2):
   exact in 1D and 2D (J88 §3.3: open, stick, slide forward, slide backward), Alart-Curnier
   nonsmooth Newton with a projection fallback in 3D. */
#include "config.h"
#include "nscd.h"

#include <math.h>
#include <string.h>


void nscd_local_prepare(int d, const double *W, double mu, double *aux)
{
  memset(aux, 0, NSCD_AUX * sizeof *aux);
  if (d == 1) {
    aux[0] = W[0] > 0 ? 1 / W[0] : 0;
  } else if (d == 2)
    nscd_local_prepare_2d(W, mu, aux);
  else {
    double c00 = W[4] * W[8] - W[5] * W[7], c01 = W[5] * W[6] - W[3] * W[8], c02 = W[3] * W[7] - W[4] * W[6];
    double det = W[0] * c00 + W[1] * c01 + W[2] * c02, pd = W[0] * W[4] * W[8];
    if (pd != 0 && fabs(det) > NSCD_SINGULAR * fabs(pd)) {
      /* adjugate / det */
      aux[0] = c00 / det;
      aux[1] = (W[2] * W[7] - W[1] * W[8]) / det;
      aux[2] = (W[1] * W[5] - W[2] * W[4]) / det;
      aux[3] = c01 / det;
      aux[4] = (W[0] * W[8] - W[2] * W[6]) / det;
      aux[5] = (W[2] * W[3] - W[0] * W[5]) / det;
      aux[6] = c02 / det;
      aux[7] = (W[1] * W[6] - W[0] * W[7]) / det;
      aux[8] = (W[0] * W[4] - W[1] * W[3]) / det;
      aux[9] = 1;
    }
    /* Alart-Curnier parameters: the inverse diagonal stiffnesses of the contact */
    aux[10] = W[0] > 0 ? 1 / W[0] : 0;
    aux[11] = W[4] + W[8] > 0 ? 2 / (W[4] + W[8]) : aux[10];
  }
}

int nscd_local_1d(const double *W, const double *q, double *r)
{
  if (q[0] >= 0) {
    r[0] = 0;
    return MO_CS_OPEN;
  }
  if (!(W[0] > 0)) return -1;
  r[0] = -q[0] / W[0];               /* U_n = W r_n + q_n = 0 */
  return MO_CS_STICK;
}

/* Residual of one 2D candidate solution (tie-breaks at the boundaries between cases). */
static double res2(const double *W, const double *q, double mu, double rn, double rt)
{
  double r[2] = {rn, rt}, U[2];
  U[0] = W[0] * rn + W[1] * rt + q[0];
  U[1] = W[2] * rn + W[3] * rt + q[1];
  return mo_fc_natural_map_unit(2, mu, r, U);
}

int nscd_local_2d(const double *W, const double *aux, const double *q, double mu, double *r)
{
  /* the candidates of the cases that do not hold strictly, in the order stick, forward, backward:
     their residuals are read only when no case holds (the tie-break below), and formed then, in
     that order, the same numbers and comparisons as where each case fails (T293) */
  double qn = q[0], qt = q[1], rn, rt, ut, e, best = HUGE_VAL, br[2] = {0, 0}, cr[3][2];
  int bs = -1, cs[3], nc = 0, k;
  /* open: r = 0 leaves U = q with U_n >= 0 (J88 (2.1)_1) */
  if (qn >= 0) {
    r[0] = r[1] = 0;
    return MO_CS_OPEN;
  }
  if (!(W[0] > 0)) return -1;
  /* stick: U = 0, r = -W^-1 q inside the cone */
  if (aux[6] != 0) {
    rn = -(aux[0] * qn + aux[1] * qt);
    rt = -(aux[2] * qn + aux[3] * qt);
    if (rn > 0 && fabs(rt) <= mu * rn) {
      r[0] = rn;
      r[1] = rt;
      return MO_CS_STICK;
    }
    cr[nc][0] = rn; cr[nc][1] = rt; cs[nc++] = MO_CS_STICK;
  }
  /* slide forward: U_t > 0, r_t = -mu r_n, U_n = 0 */
  if (aux[4] > 0) {
    rn = -qn * aux[4];
    ut = (W[2] - mu * W[3]) * rn + qt;
    if (ut > 0) {
      r[0] = rn;
      r[1] = -mu * rn;
      return MO_CS_SLIDE;
    }
    cr[nc][0] = rn; cr[nc][1] = -mu * rn; cs[nc++] = MO_CS_SLIDE;
  }
  /* slide backward: U_t < 0, r_t = +mu r_n, U_n = 0 */
  if (aux[5] > 0) {
    rn = -qn * aux[5];
    ut = (W[2] + mu * W[3]) * rn + qt;
    if (ut < 0) {
      r[0] = rn;
      r[1] = mu * rn;
      return MO_CS_SLIDE;
    }
    cr[nc][0] = rn; cr[nc][1] = mu * rn; cs[nc++] = MO_CS_SLIDE;
  }
  /* no case holds strictly: round-off at a boundary between two cases (U_t = 0 on the cone's
     edge), or a block for which the one-contact problem has no solution (W_nn <= mu |W_nt|):
     the candidate closest to the law */
  for (k = 0; k < nc; k++)
    if ((e = res2(W, q, mu, cr[k][0], cr[k][1])) < best) { best = e; br[0] = cr[k][0]; br[1] = cr[k][1]; bs = cs[k]; }
  if (bs < 0 || !isfinite(br[0]) || !isfinite(br[1])) return -1;
  r[0] = br[0];
  r[1] = br[1];
  return bs;
}

/* --- 3D: Alart-Curnier ------------------------------------------------------------------------

   phi(r) = [ r_n - P_R+(z_n) ; r_t - P_D(mu P_R+(z_n))(z_t) ],  z = r - diag(rho_n, rho_t, rho_t) U,
   U = W r + q (T39). phi(r) = 0 is the law (T12). A generalized Jacobian J and the Newton step
   J dr = -phi, with a backtracking line search on |phi|^2 / 2. */

/* phi at r, with what its Jacobian needs. */
typedef struct {
  double U[3], zn, zt[2], nzt, R;
} ac_point;

static void ac_phi(const double *W, const double *q, double mu, double rho_n, double rho_t,
                   const double *r, double *phi, ac_point *pt)
{
  double *U = pt->U;
  int i;
  for (i = 0; i < 3; i++) U[i] = W[3 * i] * r[0] + W[3 * i + 1] * r[1] + W[3 * i + 2] * r[2] + q[i];
  pt->zn = r[0] - rho_n * U[0];
  pt->zt[0] = r[1] - rho_t * U[1];
  pt->zt[1] = r[2] - rho_t * U[2];
  phi[0] = pt->zn > 0 ? rho_n * U[0] : r[0];
  pt->R = pt->zn > 0 ? mu * pt->zn : 0;
  pt->nzt = sqrt(pt->zt[0] * pt->zt[0] + pt->zt[1] * pt->zt[1]);
  if (pt->nzt <= pt->R) {
    /* inside the disk: phi_t = rho_t U_t */
    phi[1] = rho_t * U[1];
    phi[2] = rho_t * U[2];
  } else {
    double s = pt->R / pt->nzt;
    phi[1] = r[1] - s * pt->zt[0];
    phi[2] = r[2] - s * pt->zt[1];
  }
}

/* A generalized Jacobian of phi at the point pt describes. */
static void ac_jac(const double *W, double mu, double rho_n, double rho_t, const ac_point *pt, double *J)
{
  int i, k;
  if (pt->zn > 0) for (i = 0; i < 3; i++) J[i] = rho_n * W[i];
  else { J[0] = 1; J[1] = J[2] = 0; }
  if (pt->nzt <= pt->R) {
    for (i = 0; i < 3; i++) { J[3 + i] = rho_t * W[3 + i]; J[6 + i] = rho_t * W[6 + i]; }
  } else {
    /* d phi_t = [0 I] - zeta dR - (R / |z_t|) (I - zeta zeta^T) dz_t,
       dR = mu (e_n - rho_n W_n) when z_n > 0, dz_t = [0 I] - rho_t W_t */
    double z0 = pt->zt[0] / pt->nzt, z1 = pt->zt[1] / pt->nzt, s = pt->R / pt->nzt;
    double dR[3] = {0, 0, 0}, dz[2][3], Pm[2][2];
    if (pt->zn > 0) for (i = 0; i < 3; i++) dR[i] = mu * ((i == 0) - rho_n * W[i]);
    for (i = 0; i < 3; i++) {
      dz[0][i] = (i == 1) - rho_t * W[3 + i];
      dz[1][i] = (i == 2) - rho_t * W[6 + i];
    }
    Pm[0][0] = 1 - z0 * z0;
    Pm[0][1] = Pm[1][0] = -z0 * z1;
    Pm[1][1] = 1 - z1 * z1;
    for (k = 0; k < 2; k++)
      for (i = 0; i < 3; i++)
        J[3 * (k + 1) + i] = (i == k + 1) - (k ? z1 : z0) * dR[i] - s * (Pm[k][0] * dz[0][i] + Pm[k][1] * dz[1][i]);
  }
}

/* x = A^-1 b for a 3 x 3 A by its adjugate; 1 when A is singular to working precision (its
   determinant against the product of its rows' norms). */
static int solve3(const double *A, const double *b, double *x)
{
  double c0 = A[4] * A[8] - A[5] * A[7], c1 = A[5] * A[6] - A[3] * A[8], c2 = A[3] * A[7] - A[4] * A[6];
  double det = A[0] * c0 + A[1] * c1 + A[2] * c2, n0, n1, n2;
  n0 = A[0] * A[0] + A[1] * A[1] + A[2] * A[2];
  n1 = A[3] * A[3] + A[4] * A[4] + A[5] * A[5];
  n2 = A[6] * A[6] + A[7] * A[7] + A[8] * A[8];
  if (!(fabs(det) > 1e-14 * sqrt(n0 * n1 * n2))) return 1;
  det = 1 / det;
  x[0] = det * (c0 * b[0] + (A[2] * A[7] - A[1] * A[8]) * b[1] + (A[1] * A[5] - A[2] * A[4]) * b[2]);
  x[1] = det * (c1 * b[0] + (A[0] * A[8] - A[2] * A[6]) * b[1] + (A[2] * A[3] - A[0] * A[5]) * b[2]);
  x[2] = det * (c2 * b[0] + (A[1] * A[6] - A[0] * A[7]) * b[1] + (A[0] * A[4] - A[1] * A[3]) * b[2]);
  return 0;
}

int nscd_ac_newton(const double *W, const double *q, double mu, double rho_n, double rho_t,
                   double *r, double tol, int maxit, long *iters)
{
  double phi[3], J[9], x[3], ph1[3], dx[3], b[3], f0, f1, scale = fabs(rho_n * q[0]), nr;
  ac_point pt, pt1;
  int it, ls;
  ac_phi(W, q, mu, rho_n, rho_t, r, phi, &pt);
  f0 = phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2];
  for (it = 0;; it++) {
    double alpha = 1;
    nr = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    if (sqrt(f0) <= tol * (nr + scale)) return 0;
    if (it == maxit) return 1;
    ac_jac(W, mu, rho_n, rho_t, &pt, J);
    b[0] = -phi[0];
    b[1] = -phi[1];
    b[2] = -phi[2];
    if (solve3(J, b, dx)) return 1;
    if (iters) (*iters)++;
    /* backtracking (Armijo on |phi|^2 / 2 along the Newton direction) */
    for (ls = 0; ls < 30; ls++) {
      x[0] = r[0] + alpha * dx[0];
      x[1] = r[1] + alpha * dx[1];
      x[2] = r[2] + alpha * dx[2];
      ac_phi(W, q, mu, rho_n, rho_t, x, ph1, &pt1);
      f1 = ph1[0] * ph1[0] + ph1[1] * ph1[1] + ph1[2] * ph1[2];
      if (f1 <= (1 - 1e-4 * alpha) * f0) break;
      alpha *= 0.5;
    }
    /* no decrease: converged to round-off, or a local minimum of |phi|^2 */
    if (ls == 30) return sqrt(f0) <= 1e3 * tol * (nr + scale) ? 0 : 1;
    memcpy(r, x, sizeof x);
    memcpy(phi, ph1, sizeof ph1);
    pt = pt1;
    f0 = f1;
  }
}

/* Relative residual of one 3D contact: the natural map of U / W_nn (T42), over |r| + |q| / W_nn. */
static double res3(const double *W, const double *q, double mu, const double *r)
{
  double U[3], s = 1 / W[0];
  int i;
  for (i = 0; i < 3; i++) U[i] = s * (W[3 * i] * r[0] + W[3 * i + 1] * r[1] + W[3 * i + 2] * r[2] + q[i]);
  return sqrt(mo_fc_natural_map_unit(3, mu, r, U)) /
         (sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]) + s * sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]) + 1e-300);
}

/* The sliding solution by its slip angle (T40): with r_t = mu r_n e, e = (cos a, sin a),
   U_n = 0 gives r_n(a) = -q_n / (W_nn + mu W_nt.e), and Coulomb asks U_t(a) = -lambda e,
   lambda > 0: a root of g(a) = e x U_t(a) with e.U_t(a) < 0. The roots are bracketed on a grid
   of the circle and refined by bisection to round-off; the one closest to the law is kept. */
typedef struct { int valid; double g, dot, rn, e0, e1; } slide_eval;

static slide_eval slide_at(const double *W, const double *q, double mu, double a)
{
  slide_eval v;
  double D, u1, u2;
  v.e0 = cos(a);
  v.e1 = sin(a);
  D = W[0] + mu * (W[1] * v.e0 + W[2] * v.e1);
  v.valid = D > 0;
  v.rn = v.valid ? -q[0] / D : 0;
  u1 = v.rn * (W[3] + mu * (W[4] * v.e0 + W[5] * v.e1)) + q[1];
  u2 = v.rn * (W[6] + mu * (W[7] * v.e0 + W[8] * v.e1)) + q[2];
  v.g = v.e0 * u2 - v.e1 * u1;
  v.dot = v.e0 * u1 + v.e1 * u2;
  return v;
}

int nscd_slide_angle(const double *W, const double *q, double mu, double *r, double tol)
{
  enum { N = 128 };
  double best = HUGE_VAL, br[3] = {0, 0, 0}, h = 2 * M_PI / N;
  slide_eval v0 = slide_at(W, q, mu, 0), v1;
  int k, it;
  if (!(W[0] > 0) || !(q[0] < 0) || !(mu > 0)) return 1;
  for (k = 1; k <= N; k++, v0 = v1) {
    double lo = (k - 1) * h, hi = k * h, glo = v0.g, x[3], e;
    v1 = slide_at(W, q, mu, hi);
    if (!v0.valid || !v1.valid || (v0.g > 0) == (v1.g > 0)) continue;
    for (it = 0; it < 100; it++) {
      double mid = 0.5 * (lo + hi);
      slide_eval vm;
      if (mid <= lo || mid >= hi) break;
      vm = slide_at(W, q, mu, mid);
      if ((vm.g > 0) == (glo > 0)) { lo = mid; glo = vm.g; }
      else hi = mid;
    }
    v0 = slide_at(W, q, mu, 0.5 * (lo + hi));
    if (!v0.valid || !(v0.dot < 0)) { v0 = slide_at(W, q, mu, (k - 1) * h); continue; }
    x[0] = v0.rn;
    x[1] = mu * v0.rn * v0.e0;
    x[2] = mu * v0.rn * v0.e1;
    if ((e = res3(W, q, mu, x)) < best) { best = e; memcpy(br, x, sizeof br); }
    v0 = slide_at(W, q, mu, (k - 1) * h);
  }
  if (!(best <= tol)) return 1;
  memcpy(r, br, sizeof br);
  return 0;
}

/* De Saxce's fixed point r <- P_K(r - rho (U + mu |U_t| e_n)) (T41), with rho halved whenever
   the natural-map residual grows: slow but it needs no derivative. */
int nscd_projection(const double *W, const double *q, double mu, double *r, double tol, int maxit)
{
  double rho, lam = 0, z[3], U[3], e0, e1, scale = 0;
  int i, it;
  for (i = 0; i < 3; i++) {
    double s = fabs(W[3 * i]) + fabs(W[3 * i + 1]) + fabs(W[3 * i + 2]);
    if (s > lam) lam = s;                         /* >= the spectral radius */
    scale += q[i] * q[i];
  }
  if (!(lam > 0)) return 1;
  rho = 1 / lam;
  scale = sqrt(scale) * rho;
  for (i = 0; i < 3; i++) U[i] = W[3 * i] * r[0] + W[3 * i + 1] * r[1] + W[3 * i + 2] * r[2] + q[i];
  e0 = mo_fc_natural_map_unit(3, mu, r, U);
  for (it = 0; it < maxit; it++) {
    double ut = sqrt(U[1] * U[1] + U[2] * U[2]), dr = 0, nr;
    z[0] = r[0] - rho * (U[0] + mu * ut);
    z[1] = r[1] - rho * U[1];
    z[2] = r[2] - rho * U[2];
    mo_fc_project_cone(3, mu, z);
    for (i = 0; i < 3; i++) U[i] = W[3 * i] * z[0] + W[3 * i + 1] * z[1] + W[3 * i + 2] * z[2] + q[i];
    e1 = mo_fc_natural_map_unit(3, mu, z, U);
    if (e1 > e0 && rho > 1e-12 / lam) {
      rho *= 0.5;
      for (i = 0; i < 3; i++) U[i] = W[3 * i] * r[0] + W[3 * i + 1] * r[1] + W[3 * i + 2] * r[2] + q[i];
      continue;
    }
    for (i = 0; i < 3; i++) dr += (z[i] - r[i]) * (z[i] - r[i]);
    memcpy(r, z, sizeof z);
    e0 = e1;
    nr = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    if (sqrt(e1) <= tol * (nr + scale) || sqrt(dr) <= 1e-16 * nr) return sqrt(e1) <= 1e3 * tol * (nr + scale) ? 0 : 1;
  }
  return 1;
}

int nscd_local_3d(const double *W, const double *aux, const double *q, double mu, double *r,
                  const nscd_params *p, nscd_local_stats *st)
{
  double x[3], rs[3] = {0, 0, 0};
  int have_rs = 0, i;
  if (q[0] >= 0) {
    r[0] = r[1] = r[2] = 0;
    return MO_CS_OPEN;
  }
  if (!(W[0] > 0)) return -1;
  if (aux[9] != 0) {
    /* stick: U = 0 */
    for (i = 0; i < 3; i++) rs[i] = -(aux[3 * i] * q[0] + aux[3 * i + 1] * q[1] + aux[3 * i + 2] * q[2]);
    if (rs[0] > 0 && rs[1] * rs[1] + rs[2] * rs[2] <= mu * mu * rs[0] * rs[0]) {
      memcpy(r, rs, sizeof rs);
      return MO_CS_STICK;
    }
    have_rs = 1;
  }
  if (mu == 0) {
    /* frictionless: r_t = 0, U_n = 0 */
    r[0] = -q[0] * aux[10];
    r[1] = r[2] = 0;
    return MO_CS_SLIDE;
  }
  /* sliding: Newton from the previous iterate when it was closed, else from the stick trial
     projected on the cone */
  memcpy(x, r, sizeof x);
  if (!(x[0] > 0)) {
    if (have_rs) {
      memcpy(x, rs, sizeof x);
      mo_fc_project_cone(3, mu, x);
    }
    if (!(x[0] > 0)) { x[0] = -q[0] * aux[10]; x[1] = x[2] = 0; }
  }
  if (nscd_ac_newton(W, q, mu, aux[10], aux[11], x, p->local_tol, p->local_iter, st ? &st->newton : NULL)) {
    /* a local minimum of |phi|: the slip-angle search, then the projection from the best point */
    double y[3], ey, ex = isfinite(x[0] + x[1] + x[2]) ? res3(W, q, mu, x) : HUGE_VAL;
    if (st) st->fallbacks++;
    if (!nscd_slide_angle(W, q, mu, y, 1e3 * p->local_tol)) {
      memcpy(x, y, sizeof y);
      if (st) st->angle++;
    } else {
      if (!(ex < HUGE_VAL) || !(x[0] >= 0)) { x[0] = -q[0] * aux[10]; x[1] = x[2] = 0; }
      memcpy(y, x, sizeof y);
      mo_fc_project_cone(3, mu, y);
      if (!nscd_projection(W, q, mu, y, p->local_tol, 2000)) {
        memcpy(x, y, sizeof y);
        if (st) st->projection++;
      } else {
        if ((ey = res3(W, q, mu, y)) < ex) memcpy(x, y, sizeof y);
        if (st) st->failures++;
      }
    }
  }
  if (!isfinite(x[0] + x[1] + x[2])) return -1;
  memcpy(r, x, sizeof x);
  if (!(r[0] > 0)) return MO_CS_OPEN;
  return sqrt(r[1] * r[1] + r[2] * r[2]) < mu * r[0] * (1 - 1e-12) ? MO_CS_STICK : MO_CS_SLIDE;
}

int nscd_local_solve(int d, const double *W, const double *aux, const double *q, double mu,
                     double *r, const nscd_params *p, nscd_local_stats *st)
{
  if (d == 2) return nscd_local_2d(W, aux, q, mu, r);
  if (d == 3) return nscd_local_3d(W, aux, q, mu, r, p, st);
  return nscd_local_1d(W, q, r);
}
