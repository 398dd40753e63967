/* taylor_explicit.c: the axisymmetric Taylor bar by explicit central differences (lumped mass,
   the wall as a velocity projection): an integrator independent of the core's stepper and
   contact layer, for cross-checks of the implicit scenes. The centre of the impact face reaches
   epsp ~ 3 and its element is crushed ~20 times, so the stable step falls to ~5e-9 s: 10^4
   steps, about 2 s for 5 x 50 Q4. */
#include "config.h"
#include <moreau/material.h>
#include <moreau/mesh.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "taylor_explicit.h"

int nl_assemble(const mo_mesh *m, const mo_material *mat, unsigned opts, const double *u,
                const double *sn, double *s, double *f, double *K, mo_ctx *ctx)
{
  int D = m->dim, nen = m->nen, nd = nen * D, n = m->nnode * D;
  int nq = mo_elem_nl_npoint(m->type, mat->hyp), e, a, b, st;
  double ue[MO_ND_MAX], fe[MO_ND_MAX], Ke[MO_ND_MAX * MO_ND_MAX];
  memset(f, 0, (size_t)n * sizeof *f);
  if (K) memset(K, 0, (size_t)n * n * sizeof *K);
  for (e = 0; e < m->nelem; e++) {
    const int *c = &m->conn[e * nen];
    size_t off = (size_t)e * nq * MO_J2_NSTATE;
    for (a = 0; a < nd; a++) ue[a] = u[c[a / D] * D + a % D];
    if ((st = mo_elem_nl_force(m, e, mat, opts, ue, sn + off, s + off, fe, K ? Ke : NULL, ctx)))
      return st;
    for (a = 0; a < nd; a++) {
      int ga = c[a / D] * D + a % D;
      f[ga] += fe[a];
      if (K)
        for (b = 0; b < nd; b++) K[(size_t)ga * n + c[b / D] * D + b % D] += Ke[a * nd + b];
    }
  }
  return MO_OK;
}

void taylor_explicit(unsigned opts, int nr, int nz, double *len, double *rad,
                            double *epmax, double *gap, double *wall)
{
  const double R0 = 3.2e-3, L0 = 32.4e-3, V0 = 227, T = 80e-6, cfl = 1.0;
  mo_material mat = {MO_MAT_J2, 1.17e11, 0.35, 8930, 4e8, 1e8, MO_HYP_AXISYMMETRIC, 1, 1};
  double o[2] = {0, 0}, sz[2] = {R0, L0}, c;
  int ne[2] = {nr, nz}, n, nq = 4, ns, e, a, i;
  double *u, *v, *f, *fo, *M, *sn, *s, t = 0, hprev = 0, K0 = 0, Kin = 0, W = 0, psi = 0, wp = 0;
  mo_mesh *m = NULL;
  mo_ctx ctx;
  mo_ctx_init(&ctx);
  mo_mesh_rectangle(o, sz, ne, MO_EL_Q4, MO_DIAG_RIGHT, &m, &ctx);
  n = 2 * m->nnode;
  ns = m->nelem * nq * MO_J2_NSTATE;
  u = calloc((size_t)n, sizeof *u); v = calloc((size_t)n, sizeof *v);
  f = calloc((size_t)n, sizeof *f); fo = calloc((size_t)n, sizeof *fo);
  M = calloc((size_t)n, sizeof *M);
  sn = malloc((size_t)ns * sizeof *sn); s = malloc((size_t)ns * sizeof *s);
  mo_j2_state_init(mat.hyp, sn, m->nelem * nq);
  c = sqrt(mat.E * (1 - mat.nu) / ((1 + mat.nu) * (1 - 2 * mat.nu)) / mat.rho); /* P wave */
  for (e = 0; e < m->nelem; e++) {
    double Me[64];
    mo_elem_mass(m, e, &mat, 1, Me, &ctx);
    for (a = 0; a < 8; a++) M[2 * m->conn[e * 4 + a / 2] + a % 2] += Me[a * 8 + a];
  }
  for (a = 0; a < m->nnode; a++) v[2 * a + 1] = -V0;
  for (i = 0; i < n; i++) K0 += 0.5 * M[i] * v[i] * v[i];
  *len = *rad = *epmax = NAN;
  while (t < T) {
    double lmin = INFINITY, h;
    for (e = 0; e < m->nelem; e++) { /* current height: area / longest diagonal */
      const int *cn = &m->conn[e * 4];
      double X[4][2], A2, d1, d2;
      int k;
      for (k = 0; k < 4; k++) {
        X[k][0] = m->x[2 * cn[k]] + u[2 * cn[k]];
        X[k][1] = m->x[2 * cn[k] + 1] + u[2 * cn[k] + 1];
      }
      A2 = (X[2][0] - X[0][0]) * (X[3][1] - X[1][1]) - (X[2][1] - X[0][1]) * (X[3][0] - X[1][0]);
      d1 = hypot(X[2][0] - X[0][0], X[2][1] - X[0][1]);
      d2 = hypot(X[3][0] - X[1][0], X[3][1] - X[1][1]);
      lmin = fmin(lmin, 0.5 * A2 / fmax(d1, d2));
    }
    h = fmin(cfl * lmin / c, T - t);
    for (i = 0; i < n; i++) v[i] -= 0.5 * (hprev + h) * f[i] / M[i];
    for (a = 0; a < m->nnode; a++) {
      double z = m->x[2 * a + 1] + u[2 * a + 1];
      if (m->x[2 * a] == 0) v[2 * a] = 0;                      /* the axis */
      if (z + h * v[2 * a + 1] < 0) v[2 * a + 1] = -z / h;     /* the wall z = 0 */
    }
    for (i = 0; i < n; i++) u[i] += h * v[i];
    memcpy(fo, f, (size_t)n * sizeof *f);
    if (nl_assemble(m, &mat, opts, u, sn, s, f, NULL, &ctx)) goto done;
    for (i = 0; i < n; i++) W += 0.5 * (fo[i] + f[i]) * h * v[i];
    memcpy(sn, s, (size_t)ns * sizeof *sn);
    hprev = h;
    t += h;
  }
  *len = *rad = *epmax = 0;
  for (a = 0; a < m->nnode; a++) {
    *len = fmax(*len, m->x[2 * a + 1] + u[2 * a + 1]);
    if (m->x[2 * a + 1] == 0) *rad = fmax(*rad, m->x[2 * a] + u[2 * a]);
  }
  for (i = 0; i < n; i++) Kin += 0.5 * M[i] * v[i] * v[i];
  for (e = 0; e < m->nelem; e++) {
    double p, w, vm, ep;
    mo_elem_nl_energy(m, e, &mat, sn + (size_t)e * nq * MO_J2_NSTATE, &p, &w);
    mo_elem_nl_fields(m, e, &mat, sn + (size_t)e * nq * MO_J2_NSTATE, NULL, &vm, &ep);
    psi += p;
    wp += w;
    *epmax = fmax(*epmax, ep);
  }
  *gap = fabs(W - psi - wp) / W; /* the kernels' energies against the work of their forces */
  *wall = (K0 - Kin - W) / K0;   /* what the wall took (inelastic node impacts) */
done:
  mo_mesh_free(m);
  free(u); free(v); free(f); free(fo); free(M); free(sn); free(s);
}

