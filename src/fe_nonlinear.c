/* fe_nonlinear.c: finite-strain element kernels (total Lagrangian, F-bar with the element's mean
   dilatation, variational): internal forces, consistent tangents, energies and output fields
   (doc/theory.md §7, (T32)-(T35)). */
#include "config.h"
#include <moreau/material.h>

#include <math.h>
#include <string.h>

#include "tensor3.h"

/* Quadrature rules, kept as constants so that no call allocates (mo_quad_element builds its
   Gauss tables through GSL at every call). g = 1/sqrt(3): the 2-point Gauss-Legendre rule. */
#define G3 0.57735026918962576450914878050196
static const double xi_t3c[1][3] = {{1.0 / 3, 1.0 / 3, 0}};
static const double w_t3c[1] = {0.5};
static const double xi_t3x[3][3] = {{1.0 / 6, 1.0 / 6, 0}, {2.0 / 3, 1.0 / 6, 0}, {1.0 / 6, 2.0 / 3, 0}};
static const double w_t3x[3] = {1.0 / 6, 1.0 / 6, 1.0 / 6};
static const double xi_q4[4][3] = {{-G3, -G3, 0}, {G3, -G3, 0}, {G3, G3, 0}, {-G3, G3, 0}};
static const double w_q4[4] = {1, 1, 1, 1};
static const double xi_h8[8][3] = {{-G3, -G3, -G3}, {G3, -G3, -G3}, {G3, G3, -G3}, {-G3, G3, -G3},
                                   {-G3, -G3, G3},  {G3, -G3, G3},  {G3, G3, G3},  {-G3, G3, G3}};
static const double w_h8[8] = {1, 1, 1, 1, 1, 1, 1, 1};
/* simplices: T4 the centroid; T10 the 4-point degree-2 rule, a = (5 - sqrt 5) / 20; T6 the 3-point
   degree-2 rule, in axisymmetry the 6-point degree-4 rule (as the small-strain stiffness, fe.c) */
#define TA 0.13819660112501051518
#define TB 0.58541019662496845446
static const double xi_t4[1][3] = {{0.25, 0.25, 0.25}};
static const double w_t4[1] = {1.0 / 6};
static const double xi_t10[4][3] = {{TA, TA, TA}, {TB, TA, TA}, {TA, TB, TA}, {TA, TA, TB}};
static const double w_t10[4] = {1.0 / 24, 1.0 / 24, 1.0 / 24, 1.0 / 24};
#define D4A 0.445948490915965
#define D4B 0.091576213509771
static const double xi_t6x[6][3] = {{D4A, D4A, 0}, {1 - 2 * D4A, D4A, 0}, {D4A, 1 - 2 * D4A, 0},
                                    {D4B, D4B, 0}, {1 - 2 * D4B, D4B, 0}, {D4B, 1 - 2 * D4B, 0}};
static const double w_t6x[6] = {0.223381589678011 / 2, 0.223381589678011 / 2, 0.223381589678011 / 2,
                                0.109951743655322 / 2, 0.109951743655322 / 2, 0.109951743655322 / 2};

typedef struct {
  int n;
  const double (*xi)[3];
  const double *w;
} nl_rule;

/* The rule of a supported (type, hypothesis); 0 when unsupported. */
static int nl_rule_get(mo_eltype t, mo_hypothesis h, nl_rule *R)
{
  int two = h == MO_HYP_PLANE_STRAIN || h == MO_HYP_AXISYMMETRIC;
  memset(R, 0, sizeof *R);
  if (t == MO_EL_T3 && two) {
    int ax = h == MO_HYP_AXISYMMETRIC; /* the hoop strain u_r / r varies: three points */
    R->n = ax ? 3 : 1;
    R->xi = ax ? xi_t3x : xi_t3c;
    R->w = ax ? w_t3x : w_t3c;
  } else if (t == MO_EL_Q4 && two) {
    R->n = 4;
    R->xi = xi_q4;
    R->w = w_q4;
  } else if (t == MO_EL_H8 && h == MO_HYP_3D) {
    R->n = 8;
    R->xi = xi_h8;
    R->w = w_h8;
  } else if (t == MO_EL_T4 && h == MO_HYP_3D) {
    R->n = 1;
    R->xi = xi_t4;
    R->w = w_t4;
  } else if (t == MO_EL_T10 && h == MO_HYP_3D) {
    R->n = 4;
    R->xi = xi_t10;
    R->w = w_t10;
  } else if (t == MO_EL_T6 && two) {
    int ax = h == MO_HYP_AXISYMMETRIC;
    R->n = ax ? 6 : 3;
    R->xi = ax ? xi_t6x : xi_t3x;
    R->w = ax ? w_t6x : w_t3x;
  }
  return R->n;
}

int mo_elem_nl_npoint(mo_eltype t, mo_hypothesis h)
{
  nl_rule R;
  return nl_rule_get(t, h, &R);
}

/* Deformation gradient F = I + sum_a u_a (x) grad_X N_a (3x3); axisymmetric F33 = r / R. */
static void kinematics(int D, int ax, int nen, const double *N, const double *dNX,
                       const double *X, const double *ue, double *F)
{
  int a, i, j;
  memset(F, 0, 9 * sizeof *F);
  F[0] = F[4] = F[8] = 1;
  for (a = 0; a < nen; a++)
    for (i = 0; i < D; i++) {
      double u = ue[a * D + i];
      for (j = 0; j < D; j++) F[3 * i + j] += u * dNX[a * D + j];
    }
  if (ax) {
    double ur = 0;
    for (a = 0; a < nen; a++) ur += N[a] * ue[a * D];
    F[8] = 1 + ur / X[0];
  }
}

/* Spatial gradients g_a = F^-T grad_X N_a, hoop terms h_a = N_a / r (axisymmetric), and the
   derivative of div u with respect to u_a,i: dv[a*D+i] = g_a,i (+ h_a for i = r). */
static void spatial(int D, int ax, int nen, const double *N, const double *dNX,
                    const double *X, const double *F, const double *Fi, double *g, double *h,
                    double *dv)
{
  int a, j, K;
  for (a = 0; a < nen; a++) {
    for (j = 0; j < D; j++) {
      double v = 0;
      for (K = 0; K < D; K++) v += dNX[a * D + K] * Fi[3 * K + j];
      g[a * D + j] = v;
      dv[a * D + j] = v;
    }
    h[a] = ax ? N[a] / (X[0] * F[8]) : 0;
    if (ax) dv[a * D] += h[a];
  }
}

static int unsupported(const mo_mesh *msh, const mo_material *mat, mo_ctx *ctx)
{
  return mo_error(ctx, MO_EUNSUPPORTED, "finite strains: element %s with hypothesis '%s' is "
                  "not supported (T3, T6 or Q4 in plane strain or axisymmetry, H8, T4 or T10 in 3D)",
                  mo_eltype_get(msh->type)->name, mo_hyp_name(mat->hyp));
}

int mo_elem_nl_force(const mo_mesh *msh, int e, const mo_material *mat, unsigned opts,
                     const double *ue, const double *sn, double *s, double *fe, double *Ke,
                     mo_ctx *ctx)
{
  /* the symmetric stress components a problem needs, as indices 3i+j into 3x3 tensors */
  static const int rows2[4] = {0, 4, 1, 8};
  static const int rows3[6] = {0, 4, 8, 5, 2, 1};
  /* symrow[3D][i][j]: the row of component (i j) in rows2 / rows3 */
  static const int symrow[2][3][3] = {{{0, 2, 0}, {2, 1, 0}, {0, 0, 3}},
                                      {{0, 5, 4}, {5, 1, 3}, {4, 3, 2}}};
  const mo_hypothesis hyp = mat->hyp;
  const int D = msh->dim, nen = msh->nen, nd = nen * D;
  const int ax = hyp == MO_HYP_AXISYMMETRIC, ps = hyp == MO_HYP_PLANE_STRAIN;
  const int nsym = D == 3 ? 6 : 4;
  const int *rows = D == 3 ? rows3 : rows2;
  const double dd = ps ? 2 : 3; /* directions the mean dilatation scales (T32) */
  /* per point: weight, F, J, spatial gradients, hoop terms, divergence operator */
  double w[8], F[8][9], J[8], g[8][MO_ND_MAX], h[8][MO_NEN_MAX], dv[8][MO_ND_MAX];
  double N[MO_NEN_MAX], dNX[MO_ND_MAX], X[3], Fi[9], Fb[9], tau[9], A[81], tg[MO_ND_MAX];
  double m[MO_ND_MAX] = {0}, dT[6 * MO_ND_MAX], cq[8];
  double v = 0, V0 = 0, theta = 1, P = 0;
  nl_rule R;
  int md, q, a, b, i, k, r, c, st;

  if (!nl_rule_get(msh->type, hyp, &R) || (D == 3) != (hyp == MO_HYP_3D))
    return unsupported(msh, mat, ctx);
  /* one point (T3 in plane strain): the mean dilatation is the point's own */
  md = !(opts & MO_NL_STANDARD) && R.n > 1;

  /* kinematics at every point, the element's volume ratio theta = v / V0 and the mean
     divergence operator m = int J dv dV0 / int J dV0 (T32) */
  for (q = 0; q < R.n; q++) {
    double det = mo_elem_geometry(msh, e, R.xi[q], N, dNX, X);
    if (!(det > 0))
      return mo_error(ctx, MO_EINPUT, "element %d has a non-positive Jacobian (%g)", e, det);
    w[q] = det * R.w[q] * mo_measure_factor(mat, X);
    kinematics(D, ax, nen, N, dNX, X, ue, F[q]);
    J[q] = t3_inv(F[q], Fi);
    if (!(J[q] > 0) || !isfinite(J[q]))
      return mo_error(ctx, MO_ENAN, "element %d, point %d: det F = %g", e, q, J[q]);
    spatial(D, ax, nen, N, dNX, X, F[q], Fi, g[q], h[q], dv[q]);
    V0 += w[q];
    v += w[q] * J[q];
    for (c = 0; c < nd; c++) m[c] += w[q] * J[q] * dv[q][c];
  }
  if (md) {
    theta = v / V0;
    for (c = 0; c < nd; c++) m[c] /= v;
  }
  memset(fe, 0, (size_t)nd * sizeof *fe);
  if (Ke) memset(Ke, 0, (size_t)nd * (size_t)nd * sizeof *Ke);

  for (q = 0; q < R.n; q++) {
    const double *gq = g[q], *hq = h[q], *dq = dv[q];
    double pb, cp;
    memcpy(Fb, F[q], sizeof Fb);
    if (md) { /* F-bar = (theta / J)^(1/d) F on the scaled directions (T32) */
      double phi = ps ? sqrt(theta / J[q]) : cbrt(theta / J[q]);
      if (ps) { Fb[0] *= phi; Fb[1] *= phi; Fb[3] *= phi; Fb[4] *= phi; }
      else for (i = 0; i < 9; i++) Fb[i] *= phi;
    }
    st = mo_j2_update(mat, Fb, sn + (size_t)q * MO_J2_NSTATE, s + (size_t)q * MO_J2_NSTATE, tau,
                      Ke ? A : NULL, ctx);
    if (st) return mo_error_prefix(ctx, "element %d, point %d", e, q);
    pb = ps ? tau[0] + tau[4] : tau[0] + tau[4] + tau[8]; /* tr_d tau-bar */
    cp = md ? pb / dd : 0;
    P += w[q] * cp;

    /* f_a = int tau-bar : d l-bar / d u_a dV0 (T33) */
    for (a = 0; a < nen; a++)
      for (i = 0; i < D; i++) {
        double t = 0;
        int j;
        for (j = 0; j < D; j++) t += tau[3 * i + j] * gq[a * D + j];
        tg[a * D + i] = t; /* (tau g_a)_i, reused by the geometric stiffness */
        if (ax && i == 0) t += tau[8] * hq[a];
        if (md) t += cp * (m[a * D + i] - dq[a * D + i]);
        fe[a * D + i] += w[q] * t;
      }
    if (!Ke) continue;

    /* K is symmetric (T34)-(T35): every part below fills the upper triangle only, and the
       lower one is mirrored at the end. The virtual velocity gradient of dof (a, i) has the
       structure dl-bar = e_i (x) g_a + delta_ir h_a e_3 (x) e_3 + cb I_d, cb = (m - dv)/d:
       products with it cost D + 2 terms, not 9. */
    cq[q] = cp;
    /* material part dl-bar : A : Dl-bar (T34): first dT[c] = w A : Dl-bar for every column
       dof c (the symmetric components of d tau-bar), then the row dofs' contractions */
    {
      double sd[6];
      for (r = 0; r < nsym; r++) {
        const double *Ar = A + rows[r] * 9;
        sd[r] = Ar[0] + Ar[4] + (ps ? 0 : Ar[8]); /* A : I_d */
      }
      for (b = 0; b < nen; b++)
        for (k = 0; k < D; k++) {
          int cc = b * D + k;
          double cb = md ? (m[cc] - dq[cc]) / dd : 0;
          for (r = 0; r < nsym; r++) {
            const double *Ar = A + rows[r] * 9 + 3 * k;
            double t = cb * sd[r];
            int j;
            for (j = 0; j < D; j++) t += Ar[j] * gq[b * D + j];
            if (ax && k == 0) t += Ar[8 - 3 * k] * hq[b];
            dT[r * nd + cc] = w[q] * t;
          }
        }
    }
    for (a = 0; a < nen; a++)
      for (i = 0; i < D; i++) {
        int ra = a * D + i;
        double *Kr = Ke + (size_t)ra * nd;
        double cb = md ? (m[ra] - dq[ra]) / dd : 0, ga[3] = {0, 0, 0}, hoop = 0;
        const double *d0 = dT, *d1 = dT + nd, *d2 = dT + 2 * nd, *dd33 = dT + 3 * nd;
        const double *di[3];
        int j;
        for (j = 0; j < D; j++) {
          ga[j] = gq[a * D + j];
          di[j] = dT + symrow[D == 3][i][j] * nd; /* d tau-bar_(i j) */
        }
        if (ax && i == 0) hoop = hq[a];
        if (D == 3) {
          for (c = ra; c < nd; c++)
            Kr[c] += ga[0] * di[0][c] + ga[1] * di[1][c] + ga[2] * di[2][c] +
                     cb * (d0[c] + d1[c] + d2[c]);
        } else {
          for (c = ra; c < nd; c++)
            Kr[c] += ga[0] * di[0][c] + ga[1] * di[1][c] + hoop * dd33[c] +
                     cb * (d0[c] + d1[c] + (ps ? 0 : dd33[c]));
        }
      }
    /* geometric part at the point: - tau : (dl Dl) (T34); its (p/d) tr(dl Dl) joins (T35) */
    for (a = 0; a < nen; a++)
      for (i = 0; i < D; i++) {
        double *Kr = Ke + (size_t)(a * D + i) * nd;
        for (b = a; b < nen; b++) {
          double tgi = w[q] * tg[b * D + i];
          for (k = b == a ? i : 0; k < D; k++) Kr[b * D + k] -= tgi * gq[a * D + k];
          if (ax && i == 0) Kr[b * D] -= w[q] * tau[8] * hq[a] * hq[b];
        }
      }
  }

  if (Ke) {
    /* with the mean dilatation: sum_q w_q (p_q/d) tr(dl Dl) from (T34), and the second
       variation of ln theta, P [<J (div du div Du - tr(dl Dl))> / <J> - (m.du)(m.Du)], with
       P = int p/d dV0 and <.> = int . dV0 (T35), in one pass over the points */
    if (md) {
      double ctr[8], cdv[8];
      for (q = 0; q < R.n; q++) {
        cdv[q] = P * w[q] * J[q] / v;
        ctr[q] = w[q] * cq[q] - cdv[q];
      }
      for (a = 0; a < nen; a++)
        for (i = 0; i < D; i++) {
          int ra = a * D + i;
          double *Kr = Ke + (size_t)ra * nd;
          for (b = a; b < nen; b++)
            for (k = b == a ? i : 0; k < D; k++) {
              int cc = b * D + k;
              double t = -P * m[ra] * m[cc];
              for (q = 0; q < R.n; q++) {
                double tr = g[q][a * D + k] * g[q][b * D + i];
                if (ax && i == 0 && k == 0) tr += h[q][a] * h[q][b];
                t += ctr[q] * tr + cdv[q] * dv[q][ra] * dv[q][cc];
              }
              Kr[cc] += t;
            }
        }
    }
    for (a = 0; a < nd; a++)
      for (c = a + 1; c < nd; c++) Ke[(size_t)c * nd + a] = Ke[(size_t)a * nd + c];
  }
  return MO_OK;
}

/* Reference-volume weight of every point: detJ * w * (thickness or 2 pi R). */
static int nl_weights(const mo_mesh *msh, int e, const mo_material *mat, double *wq)
{
  double N[MO_NEN_MAX], dNX[MO_ND_MAX], X[3];
  nl_rule R;
  int q;
  if (!nl_rule_get(msh->type, mat->hyp, &R) || (msh->dim == 3) != (mat->hyp == MO_HYP_3D))
    return 0;
  for (q = 0; q < R.n; q++)
    wq[q] = mo_elem_geometry(msh, e, R.xi[q], N, dNX, X) * R.w[q] * mo_measure_factor(mat, X);
  return R.n;
}

int mo_elem_nl_energy(const mo_mesh *msh, int e, const mo_material *mat, const double *s,
                      double *psi, double *wp)
{
  double wq[8];
  int q, n = nl_weights(msh, e, mat, wq);
  *psi = *wp = 0;
  if (!n) return MO_EUNSUPPORTED;
  for (q = 0; q < n; q++) {
    *psi += wq[q] * s[(size_t)q * MO_J2_NSTATE + MO_J2_PSI];
    *wp += wq[q] * s[(size_t)q * MO_J2_NSTATE + MO_J2_WP];
  }
  return MO_OK;
}

int mo_elem_nl_fields(const mo_mesh *msh, int e, const mo_material *mat, const double *s,
                      double *sig, double *vm, double *epsp)
{
  double wq[8], W = 0;
  int q, i, n = nl_weights(msh, e, mat, wq), nc = mo_hyp_ncomp(mat->hyp);
  *vm = *epsp = 0;
  if (sig) memset(sig, 0, (size_t)nc * sizeof *sig);
  if (!n) return MO_EUNSUPPORTED;
  for (q = 0; q < n; q++) {
    const double *sq = s + (size_t)q * MO_J2_NSTATE;
    W += wq[q];
    *vm += wq[q] * mo_von_mises(mat->hyp, sq + MO_J2_SIG);
    *epsp += wq[q] * sq[MO_J2_EPSP];
    if (sig)
      for (i = 0; i < nc; i++) sig[i] += wq[q] * sq[MO_J2_SIG + i];
  }
  *vm /= W;
  *epsp /= W;
  if (sig)
    for (i = 0; i < nc; i++) sig[i] /= W;
  return MO_OK;
}
