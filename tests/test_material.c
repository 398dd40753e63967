/* test_material.c: finite-strain J2 at a material point: uniaxial loading-unloading against the
   closed form in logarithmic strain, exactness of the radial return on proportional paths,
   the consistent tangent against finite differences, objectivity, parameter checks. */
#include "config.h"
#include <moreau/material.h>
#include "testlib.h"

static void transpose(const double *A, double *B)
{
  int i, j;
  for (i = 0; i < 3; i++)
    for (j = 0; j < 3; j++) B[3 * j + i] = A[3 * i + j];
}

/* R diag(d) R^T */
static void rotated_diag(const double *R, const double *d, double *A)
{
  double D[9] = {d[0], 0, 0, 0, d[1], 0, 0, 0, d[2]}, T[9], Rt[9];
  mul3(R, D, T);
  transpose(R, Rt);
  mul3(T, Rt, A);
}

/* ---- closed form of the uniaxial Kirchhoff stress - logarithmic strain response ---------- */

typedef struct {
  double E, sy, Et, H;
  double eps_p, epsb; /* signed axial plastic strain, equivalent plastic strain */
  double tau;
} uniaxial;

/* The bilinear isotropic-hardening curve, segment by segment: elastic until |tau| reaches the
   current yield stress sy + H epsb, then slope Et. Exact for a monotone strain increment. */
static void uniaxial_to(uniaxial *u, double eps)
{
  double tr = u->E * (eps - u->eps_p), y = u->sy + u->H * u->epsb;
  if (fabs(tr) > y) {
    /* on the hardening branch: tau = sign * (y + Et (eps - eps_at_yield)) */
    double sg = tr > 0 ? 1 : -1, eyield = u->eps_p + sg * y / u->E;
    u->tau = sg * y + u->Et * (eps - eyield);
    u->epsb += fabs(eps - eyield) - fabs(u->tau - sg * y) / u->E;
  } else {
    u->tau = tr;
  }
  u->eps_p = eps - u->tau / u->E;
}

static void test_uniaxial(mo_hypothesis hyp, const char *name)
{
  mo_material mat = {MO_MAT_J2, 2e11, 0.3, 7800, 2.5e8, 2e10, hyp, 1, 1};
  double sn[MO_J2_NSTATE], s[MO_J2_NSTATE], tau[9], R[9], ax[3] = {0.48, -0.6, 0.64};
  double path[4] = {0, 0.05, -0.08, 0}, err_tau = 0, err_lat = 0, err_ep = 0, err_psi = 0,
         err_wp = 0, err_sig = 0;
  uniaxial u = {2e11, 2.5e8, 2e10, 0, 0, 0, 0};
  int seg, k, nstep = 40, st = 0, ax_i = hyp == MO_HYP_3D ? 0 : 1;
  mo_ctx ctx;
  mo_ctx_init(&ctx);
  u.H = mo_j2_hardening(&mat);
  rotation(ax, hyp == MO_HYP_3D ? 0.7 : 0, R);
  mo_j2_state_init(hyp, sn, 1);
  /* the last segment ends where the stress is zero again (closed form of the elastic reload) */
  for (seg = 1; seg <= 3; seg++) {
    double e0 = path[seg - 1], e1 = path[seg];
    if (seg == 3) e1 = u.eps_p;
    for (k = 1; k <= nstep; k++) {
      double eps = e0 + (e1 - e0) * k / nstep, lam[3], F[9], taur[9], Rt[9], T[9], lat, J;
      uniaxial_to(&u, eps);
      lat = -mat.nu * u.tau / mat.E - 0.5 * u.eps_p; /* lateral log strain, elastic + isochoric */
      lam[0] = lam[1] = lam[2] = exp(lat);
      lam[ax_i] = exp(eps);
      rotated_diag(R, lam, F);
      st |= mo_j2_update(&mat, F, sn, s, tau, NULL, &ctx);
      /* back to the loading axes: R^T tau R should be diag(tau, 0, 0) */
      transpose(R, Rt);
      mul3(Rt, tau, T);
      mul3(T, R, taur);
      J = exp(eps + 2 * lat);
      err_tau = fmax(err_tau, fabs(taur[4 * ax_i] - u.tau));
      taur[4 * ax_i] = 0;
      err_lat = fmax(err_lat, maxabs(taur, 9));
      err_ep = fmax(err_ep, fabs(s[MO_J2_EPSP] - u.epsb));
      err_psi = fmax(err_psi, fabs(s[MO_J2_PSI] - u.tau * u.tau / (2 * mat.E)));
      err_wp = fmax(err_wp, fabs(s[MO_J2_WP] - (mat.sigma_y + 0.5 * u.H * u.epsb) * u.epsb));
      /* stored Cauchy stress: uniaxial, so its von Mises value is |tau| / J */
      err_sig = fmax(err_sig, fabs(mo_von_mises(hyp, s + MO_J2_SIG) - fabs(u.tau) / J));
      memcpy(sn, s, sizeof sn);
    }
  }
  ok(st == 0, "%s uniaxial: 120 steps of tension, reverse yielding, unloading", name);
  ok(err_tau < 1e-9 * mat.sigma_y, "%s uniaxial: axial Kirchhoff stress = closed form (max error %.2e Pa)",
     name, err_tau);
  ok(err_lat < 1e-9 * mat.sigma_y, "%s uniaxial: lateral and shear stresses vanish (max %.2e Pa)",
     name, err_lat);
  ok(err_ep < 1e-12, "%s uniaxial: equivalent plastic strain = closed form (max error %.2e, final %.4f)",
     name, err_ep, u.epsb);
  ok(err_psi < 1e-9 * mat.sigma_y, "%s uniaxial: elastic energy = tau^2 / 2E (max error %.2e J/m^3)",
     name, err_psi);
  ok(err_wp < 1e-9 * mat.sigma_y, "%s uniaxial: plastic work = int sigma_y d epsp (max error %.2e J/m^3)",
     name, err_wp);
  ok(err_sig < 1e-9 * mat.sigma_y, "%s uniaxial: stored Cauchy stress = tau / J (max error %.2e Pa)",
     name, err_sig);
  ok(maxabs(tau, 9) < 1e-9 * mat.sigma_y, "%s uniaxial: back at zero stress at the end (%.2e Pa)",
     name, maxabs(tau, 9));
}

/* ---- proportional path: one step, many steps and the closed form agree ------------------ */

static void test_proportional(void)
{
  mo_material mat = {MO_MAT_J2, 1.17e11, 0.35, 8930, 4e8, 1e8, MO_HYP_3D, 1, 1};
  double e[3] = {0.08, -0.03, -0.035}, ax[3] = {0.0, 0.6, 0.8}, R[9], F[9], lam[3];
  double s1[MO_J2_NSTATE], sn[MO_J2_NSTATE], s[MO_J2_NSTATE], tau1[9], tauN[9], tref[9];
  double K = mat.E / (3 * (1 - 2 * mat.nu)), G = mat.E / (2 * (1 + mat.nu)), H, th, dev[3],
         qtr = 0, ep, tp[3];
  int i, k, N = 64, st;
  mo_ctx ctx;
  mo_ctx_init(&ctx);
  H = mo_j2_hardening(&mat);
  rotation(ax, 1.1, R);
  /* one step from the virgin state */
  for (i = 0; i < 3; i++) lam[i] = exp(e[i]);
  rotated_diag(R, lam, F);
  mo_j2_state_init(MO_HYP_3D, sn, 1);
  st = mo_j2_update(&mat, F, sn, s1, tau1, NULL, &ctx);
  /* N steps along F(t) = R exp(t diag(e)) R^T */
  for (k = 1; k <= N; k++) {
    for (i = 0; i < 3; i++) lam[i] = exp(e[i] * k / N);
    rotated_diag(R, lam, F);
    st |= mo_j2_update(&mat, F, sn, s, tauN, NULL, &ctx);
    memcpy(sn, s, sizeof sn);
  }
  /* closed form: radial return of the whole trial is exact for a fixed flow direction */
  th = e[0] + e[1] + e[2];
  for (i = 0; i < 3; i++) { dev[i] = e[i] - th / 3; qtr += dev[i] * dev[i]; }
  qtr = 2 * G * sqrt(1.5 * qtr);
  ep = (qtr - mat.sigma_y) / (3 * G + H);
  for (i = 0; i < 3; i++) tp[i] = K * th + (mat.sigma_y + H * ep) / qtr * 2 * G * dev[i];
  rotated_diag(R, tp, tref);
  for (i = 0; i < 9; i++) { tau1[i] -= tref[i]; tauN[i] -= tref[i]; }
  ok(st == 0 && ep > 0.05, "proportional path: plastic (closed-form epsp %.5f)", ep);
  ok(maxabs(tau1, 9) < 1e-9 * mat.sigma_y && fabs(s1[MO_J2_EPSP] - ep) < 1e-13,
     "proportional path: one step = closed form (stress error %.2e Pa, epsp error %.2e)",
     maxabs(tau1, 9), fabs(s1[MO_J2_EPSP] - ep));
  ok(maxabs(tauN, 9) < 1e-9 * mat.sigma_y && fabs(s[MO_J2_EPSP] - ep) < 1e-13,
     "proportional path: %d steps = closed form (stress error %.2e Pa, epsp error %.2e)", N,
     maxabs(tauN, 9), fabs(s[MO_J2_EPSP] - ep));
  ok(fabs(s[MO_J2_WP] - s1[MO_J2_WP]) < 1e-9 * s1[MO_J2_WP] &&
         fabs(s1[MO_J2_WP] - (mat.sigma_y + 0.5 * H * ep) * ep) < 1e-9 * s1[MO_J2_WP],
     "proportional path: plastic work the same in 1 and %d steps, = (sy + H ep / 2) ep", N);
  for (i = 0; i < 6; i++) s[i] -= s1[i];
  ok(maxabs(s + MO_J2_CPINV, 6) < 1e-13, "proportional path: Cp^-1 the same in 1 and %d steps "
     "(difference %.2e)", N, maxabs(s + MO_J2_CPINV, 6));
}

/* ---- consistent tangent against central differences of tau(F) ---------------------------- */

/* Max over entries of |FD - A : (dF F^-1)| / max |A : (dF F^-1)|, perturbing the components of
   F the hypothesis allows. */
static double tangent_error(const mo_material *mat, const double *F, const double *sn,
                            int *plastic)
{
  static const int comp2[5] = {0, 1, 3, 4, 8};
  double s[MO_J2_NSTATE], tau[9], A[81], Fi[9], Fp[9], tp[9], tm[9], err = 0, big = 0;
  double hstep = 1e-6;
  int n = mat->hyp == MO_HYP_3D ? 9 : 5, c, i;
  mo_ctx ctx;
  mo_ctx_init(&ctx);
  if (mo_j2_update(mat, F, sn, s, tau, A, &ctx)) return INFINITY;
  *plastic = s[MO_J2_EPSP] > sn[MO_J2_EPSP];
  {
    double d = F[0] * (F[4] * F[8] - F[5] * F[7]) - F[1] * (F[3] * F[8] - F[5] * F[6]) +
               F[2] * (F[3] * F[7] - F[4] * F[6]);
    Fi[0] = (F[4] * F[8] - F[5] * F[7]) / d; Fi[1] = (F[2] * F[7] - F[1] * F[8]) / d;
    Fi[2] = (F[1] * F[5] - F[2] * F[4]) / d; Fi[3] = (F[5] * F[6] - F[3] * F[8]) / d;
    Fi[4] = (F[0] * F[8] - F[2] * F[6]) / d; Fi[5] = (F[2] * F[3] - F[0] * F[5]) / d;
    Fi[6] = (F[3] * F[7] - F[4] * F[6]) / d; Fi[7] = (F[1] * F[6] - F[0] * F[7]) / d;
    Fi[8] = (F[0] * F[4] - F[1] * F[3]) / d;
  }
  for (c = 0; c < n; c++) {
    int kM = n == 9 ? c : comp2[c], k = kM / 3, M = kM % 3;
    double an[9];
    memcpy(Fp, F, sizeof Fp);
    Fp[kM] += hstep;
    mo_j2_update(mat, Fp, sn, s, tp, NULL, &ctx);
    Fp[kM] -= 2 * hstep;
    mo_j2_update(mat, Fp, sn, s, tm, NULL, &ctx);
    /* dl = e_k (x) (row M of F^-1) */
    for (i = 0; i < 9; i++) {
      int q;
      an[i] = 0;
      for (q = 0; q < 3; q++) an[i] += A[i * 9 + 3 * k + q] * Fi[3 * M + q];
      big = fmax(big, fabs(an[i]));
      err = fmax(err, fabs((tp[i] - tm[i]) / (2 * hstep) - an[i]));
    }
  }
  return err / big;
}

static void test_tangent(void)
{
  static const mo_hypothesis hyps[3] = {MO_HYP_PLANE_STRAIN, MO_HYP_AXISYMMETRIC, MO_HYP_3D};
  static const char *hn[3] = {"plane strain", "axisymmetric", "3D"};
  int h;
  for (h = 0; h < 3; h++) {
    mo_material mat = {MO_MAT_J2, 1.17e11, 0.35, 8930, 4e8, 1e8, hyps[h], 1, 1};
    int three = hyps[h] == MO_HYP_3D, pl, k;
    double sn[MO_J2_NSTATE], s[MO_J2_NSTATE], tau[9], err, worst = 0;
    double I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    double Fg[9] = {1.03, 0.21, 0, -0.12, 0.94, 0, 0, 0, 1.02}; /* stretch, shear, rotation */
    double Fp[9] = {1.12, 0.05, 0, 0.02, 0.9, 0, 0, 0, 1.0};    /* a plastic pre-strain */
    double Fu[9], lam[3] = {0.85, 1.0 / sqrt(0.85), 1.0 / sqrt(0.85)}, R[9], axr[3] = {0.6, 0, 0.8};
    mo_ctx ctx;
    mo_ctx_init(&ctx);
    if (three) { Fg[2] = 0.07; Fg[5] = -0.05; Fg[6] = 0.03; Fg[7] = 0.11;
                 Fp[2] = 0.04; Fp[6] = -0.03; }
    if (hyps[h] == MO_HYP_PLANE_STRAIN) Fg[8] = Fp[8] = 1;

    /* virgin state at F = I: three equal eigenvalues, elastic */
    mo_j2_state_init(hyps[h], sn, 1);
    err = tangent_error(&mat, I, sn, &pl);
    ok(err < 1e-6 && !pl, "%s tangent: F = I (repeated eigenvalues), elastic: FD error %.2e", hn[h], err);
    worst = fmax(worst, err);
    /* elastic, general F: Hencky with MO_MAT_ELASTIC */
    mat.model = MO_MAT_ELASTIC;
    err = tangent_error(&mat, Fg, sn, &pl);
    ok(err < 1e-6, "%s tangent: Hencky elasticity, F with stretch, shear and rotation: FD error %.2e",
       hn[h], err);
    worst = fmax(worst, err);
    mat.model = MO_MAT_J2;
    /* plastic loading from the virgin state */
    err = tangent_error(&mat, Fg, sn, &pl);
    ok(err < 1e-6 && pl, "%s tangent: plastic loading from the virgin state: FD error %.2e", hn[h], err);
    worst = fmax(worst, err);
    /* plastic loading from a committed plastic state, with a different F */
    mo_j2_update(&mat, Fp, sn, s, tau, NULL, &ctx);
    memcpy(sn, s, sizeof sn);
    err = tangent_error(&mat, Fg, sn, &pl);
    ok(err < 1e-6 && pl, "%s tangent: plastic loading from a plastic state (epsp %.3f): FD error %.2e",
       hn[h], sn[MO_J2_EPSP], err);
    worst = fmax(worst, err);
    /* elastic unloading from that state */
    for (k = 0; k < 9; k++) Fu[k] = Fp[k] - 0.001 * (Fp[k] - I[k]);
    err = tangent_error(&mat, Fu, sn, &pl);
    ok(err < 1e-6 && !pl, "%s tangent: elastic unloading from a plastic state: FD error %.2e", hn[h], err);
    worst = fmax(worst, err);
    /* uniaxial compression, plastic: two exactly equal eigenvalues (lateral stretches) */
    mo_j2_state_init(hyps[h], sn, 1);
    if (three) {
      rotation(axr, 0.4, R);
      rotated_diag(R, lam, Fu);
    } else {
      memset(Fu, 0, sizeof Fu);
      Fu[0] = lam[1]; Fu[4] = lam[0]; Fu[8] = hyps[h] == MO_HYP_AXISYMMETRIC ? lam[1] : 1;
    }
    err = tangent_error(&mat, Fu, sn, &pl);
    ok(err < 1e-6 && pl, "%s tangent: plastic uniaxial compression (equal lateral eigenvalues): FD "
       "error %.2e", hn[h], err);
    worst = fmax(worst, err);
    /* nearly equal eigenvalues: divided differences near their limit */
    if (three) {
      double lam2[3] = {0.9, 1.08, 1.08 * (1 + 3e-9)};
      rotated_diag(R, lam2, Fu);
    } else {
      Fu[0] = 1.08; Fu[4] = 0.9; Fu[8] = hyps[h] == MO_HYP_AXISYMMETRIC ? 1.08 * (1 + 3e-9) : 1;
      if (hyps[h] == MO_HYP_PLANE_STRAIN) { Fu[0] = 1.0 * (1 + 3e-9); Fu[4] = 0.9; }
    }
    err = tangent_error(&mat, Fu, sn, &pl);
    ok(err < 1e-6 && pl, "%s tangent: plastic, eigenvalues equal to 3e-9: FD error %.2e", hn[h], err);
    worst = fmax(worst, err);
    diag("%s: worst relative FD error of the consistent tangent %.2e", hn[h], worst);
  }
}

/* ---- objectivity -------------------------------------------------------------------------- */

static void test_objectivity(void)
{
  mo_material mat = {MO_MAT_J2, 1.17e11, 0.35, 8930, 4e8, 1e8, MO_HYP_3D, 1, 1};
  double sn[MO_J2_NSTATE], s[MO_J2_NSTATE], s2[MO_J2_NSTATE], tau[9], tau2[9], R[9], RF[9],
         T[9], Rt[9], ref[9];
  double F[9] = {1.1, 0.2, 0.05, -0.1, 0.92, 0.07, 0.02, -0.04, 0.97}, ax[3] = {0, 0, 1};
  double ax2[3] = {0.36, 0.48, 0.8};
  int i;
  mo_ctx ctx;
  mo_ctx_init(&ctx);
  /* a rigid rotation of 90 degrees from the virgin state: no stress */
  rotation(ax, M_PI / 2, R);
  mo_j2_state_init(MO_HYP_3D, sn, 1);
  mo_j2_update(&mat, R, sn, s, tau, NULL, &ctx);
  ok(maxabs(tau, 9) < 1e-4 && s[MO_J2_EPSP] == 0 && fabs(s[MO_J2_PSI]) < 1e-20,
     "rigid rotation of 90 degrees: no stress (max |tau| %.2e Pa), no plastic strain", maxabs(tau, 9));
  /* superposed rotation on a plastic step: tau(R F) = R tau(F) R^T, same internal variables */
  mo_j2_update(&mat, F, sn, s, tau, NULL, &ctx);
  rotation(ax2, 2.3, R);
  mul3(R, F, RF);
  mo_j2_update(&mat, RF, sn, s2, tau2, NULL, &ctx);
  transpose(R, Rt);
  mul3(R, tau, T);
  mul3(T, Rt, ref);
  for (i = 0; i < 9; i++) ref[i] -= tau2[i];
  ok(s[MO_J2_EPSP] > 0.01 && maxabs(ref, 9) < 1e-12 * maxabs(tau, 9) * 10,
     "superposed rotation on a plastic step: tau(RF) = R tau(F) R^T (error %.2e of %.2e Pa)",
     maxabs(ref, 9), maxabs(tau, 9));
  for (i = 0; i < 7; i++) s2[i] -= s[i];
  ok(maxabs(s2, 7) < 1e-12 && fabs(s2[MO_J2_WP] - s[MO_J2_WP]) < 1e-12 * s[MO_J2_WP] &&
         fabs(s2[MO_J2_PSI] - s[MO_J2_PSI]) < 1e-12 * s[MO_J2_PSI],
     "superposed rotation: the same Cp^-1 and epsp (%.2e), plastic work and elastic energy",
     maxabs(s2, 7));
}

static void test_checks(void)
{
  mo_material m = {MO_MAT_J2, 1.17e11, 0.35, 8930, 4e8, 1e8, MO_HYP_3D, 1, 1};
  mo_ctx ctx;
  mo_ctx_init(&ctx);
  ok(mo_j2_check(&m, &ctx) == MO_OK, "check: the Taylor bar's copper is accepted");
  is_close(mo_j2_hardening(&m), 1.17e11 * 1e8 / (1.17e11 - 1e8), 1e-6,
           "hardening modulus H = E Et / (E - Et) (%.6g Pa for Et = 100 MPa)", mo_j2_hardening(&m));
  m.Et = m.E;
  ok(mo_j2_check(&m, &ctx) == MO_EINPUT && strstr(ctx.errmsg, "Et"), "check: Et = E refused (%s)",
     ctx.errmsg);
  mo_ctx_clear_error(&ctx);
  m.Et = 1e8;
  m.nu = 0.5;
  ok(mo_j2_check(&m, &ctx) == MO_EINPUT && strstr(ctx.errmsg, "nu"), "check: nu = 0.5 refused");
  mo_ctx_clear_error(&ctx);
  m.nu = 0.35;
  m.hyp = MO_HYP_PLANE_STRESS;
  ok(mo_j2_check(&m, &ctx) == MO_EUNSUPPORTED, "check: plane stress reported unsupported");
  mo_ctx_clear_error(&ctx);
  m.hyp = MO_HYP_3D;
  {
    double F[9] = {-1, 0, 0, 0, 1, 0, 0, 0, 1}, sn[MO_J2_NSTATE], s[MO_J2_NSTATE], tau[9];
    mo_j2_state_init(MO_HYP_3D, sn, 1);
    ok(mo_j2_update(&m, F, sn, s, tau, NULL, &ctx) == MO_ENAN, "det F < 0 reported (%s)",
       ctx.errmsg);
  }
}

int main(void)
{
  test_uniaxial(MO_HYP_3D, "3D (rotated axes)");
  test_uniaxial(MO_HYP_AXISYMMETRIC, "axisymmetric");
  test_proportional();
  test_tangent();
  test_objectivity();
  test_checks();
  return done_testing();
}
