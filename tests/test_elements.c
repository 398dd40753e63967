/* test_elements.c: patch tests, rigid-body modes, total mass, constant strain and stress, for
   every element and hypothesis. */
#include "config.h"
#include <moreau/fe.h>
#include <moreau/mesh.h>
#include <moreau/sparse.h>
#include "tap.h"

typedef struct {
  const char *name;
  mo_eltype type;
  mo_hypothesis hyp;
} variant;

static const variant variants[] = {
  {"bar2", MO_EL_BAR2, MO_HYP_BAR},
  {"T3 plane strain", MO_EL_T3, MO_HYP_PLANE_STRAIN},
  {"T3 plane stress", MO_EL_T3, MO_HYP_PLANE_STRESS},
  {"T3 axisymmetric", MO_EL_T3, MO_HYP_AXISYMMETRIC},
  {"Q4 plane strain", MO_EL_Q4, MO_HYP_PLANE_STRAIN},
  {"Q4 plane stress", MO_EL_Q4, MO_HYP_PLANE_STRESS},
  {"Q4 axisymmetric", MO_EL_Q4, MO_HYP_AXISYMMETRIC},
  {"H8", MO_EL_H8, MO_HYP_3D},
  {"T6 plane strain", MO_EL_T6, MO_HYP_PLANE_STRAIN},
  {"T6 plane stress", MO_EL_T6, MO_HYP_PLANE_STRESS},
  {"T6 axisymmetric", MO_EL_T6, MO_HYP_AXISYMMETRIC},
  {"T4", MO_EL_T4, MO_HYP_3D},
  {"T10", MO_EL_T10, MO_HYP_3D},
};

static int variant_dim(const variant *V) { return V->type == MO_EL_BAR2 ? 1 : V->hyp == MO_HYP_3D ? 3 : 2; }

/* The middle nodes of the quadratic elements back at the middles of their edges (a straight-sided
   element after its corners moved). */
static void straighten(mo_mesh *m)
{
  static const int t6e[3][2] = {{0, 1}, {1, 2}, {2, 0}};
  static const int t10e[6][2] = {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}};
  const mo_eltype_info *T = mo_eltype_get(m->type);
  int e, k, d, D = m->dim;
  if (T->order != 2) return;
  for (e = 0; e < m->nelem; e++)
    for (k = 0; k < T->nen - T->nvert; k++) {
      const int *c = &m->conn[e * m->nen];
      int p = c[m->type == MO_EL_T6 ? t6e[k][0] : t10e[k][0]], q = c[m->type == MO_EL_T6 ? t6e[k][1] : t10e[k][1]];
      for (d = 0; d < D; d++) m->x[c[T->nvert + k] * D + d] = 0.5 * (m->x[p * D + d] + m->x[q * D + d]);
    }
}

/* A small mesh of the variant with interior nodes moved off the grid (a distorted patch; the
   quadratic elements' sides stay straight). */
static mo_mesh *patch_mesh(const variant *V, mo_ctx *ctx)
{
  mo_mesh *m = NULL;
  int a, d;
  if (V->type == MO_EL_BAR2) mo_mesh_bar(0.3, 1.2, 5, &m, ctx);
  else if (V->hyp == MO_HYP_3D) {
    double o[3] = {0.1, 0.2, 0.3}, s[3] = {1, 1.5, 2};
    int ne[3] = {3, 3, 3};
    mo_mesh_box_elements(o, s, ne, V->type, &m, ctx);
  } else {
    double o[2] = {0.5, 0.2}, s[2] = {1, 1.5};
    int ne[2] = {3, 4};
    mo_mesh_rectangle(o, s, ne, V->type, MO_DIAG_ALTERNATE, &m, ctx);
  }
  /* pseudo-random interior perturbation, 15% of the cell size */
  for (a = 0; a < m->nnode; a++) {
    int interior = 1;
    double hmin;
    for (d = 0; d < 6 && interior; d++) {
      static const char *nm[6] = {"xmin", "xmax", "ymin", "ymax", "zmin", "zmax"};
      const mo_nodeset *ns = mo_mesh_find_nodeset(m, nm[d]);
      int k;
      if (!ns) continue;
      for (k = 0; k < ns->n; k++)
        if (ns->node[k] == a) interior = 0;
    }
    if (!interior) continue;
    mo_mesh_edge_range(m, &hmin, NULL);
    for (d = 0; d < m->dim; d++) m->x[a * m->dim + d] += 0.15 * hmin * sin(12.9898 * a + 78.233 * d);
  }
  straighten(m);
  return m;
}

/* The linear field u_i = c_i + G_ij x_j (axisymmetric: u_r = g r, u_z = c + G x). */
static void linear_field(const variant *V, const double *x, double *u)
{
  static const double c[3] = {1e-3, -2e-3, 0.5e-3};
  static const double G[3][3] = {{2e-3, 1e-3, -1e-3}, {0.5e-3, -1e-3, 2e-3}, {1e-3, 3e-3, 1.5e-3}};
  int D = variant_dim(V), i, j;
  for (i = 0; i < D; i++) {
    u[i] = c[i];
    for (j = 0; j < D; j++) u[i] += G[i][j] * x[j];
  }
  if (V->hyp == MO_HYP_AXISYMMETRIC) {
    u[0] = 2e-3 * x[0];                 /* u_r proportional to r */
    u[1] = -2e-3 + 1e-3 * x[1];         /* sigma_rz = 0: a constant sigma_rz is not in
                                           equilibrium in cylindrical coordinates */
  }
}

static void pressure_cb(const double *x, const double *n, void *data, double *t)
{
  double p = *(const double *)data;
  (void)x;
  t[0] = -p * n[0];
  t[1] = -p * n[1];
}

static void pressure3_cb(const double *x, const double *n, void *data, double *t)
{
  double p = *(const double *)data;
  int i;
  (void)x;
  for (i = 0; i < 3; i++) t[i] = -p * n[i];
}

static double fact(int n) { return n <= 1 ? 1 : n * fact(n - 1); }

/* max over the monomials of degree <= deg of |rule - exact| on the unit simplex of dimension d
   (exact: i! j! k! / (i + j + k + d)!) */
static double rule_error(const mo_quad *Q, int d, int deg)
{
  double worst = 0;
  int i, j, k, q;
  for (i = 0; i <= deg; i++)
    for (j = 0; i + j <= deg; j++)
      for (k = 0; i + j + k <= deg && (d == 3 || k == 0); k++) {
        double exact = fact(i) * fact(j) * fact(k) / fact(i + j + k + d), sum = 0;
        for (q = 0; q < Q->n; q++) sum += Q->w[q] * pow(Q->xi[q][0], i) * pow(Q->xi[q][1], j) * (d == 3 ? pow(Q->xi[q][2], k) : 1);
        worst = fmax(worst, fabs(sum - exact) / exact);
      }
  return worst;
}

/* The simplex rules integrate the monomials of their degree exactly, and not those of the next. */
static void check_rules(mo_ctx *ctx)
{
  static const struct { mo_eltype t; int order, degree, npts; } R[] = {
    {MO_EL_T3, 1, 1, 1}, {MO_EL_T3, 2, 2, 3}, {MO_EL_T6, 4, 4, 6}, {MO_EL_T6, 5, 5, 7},
    {MO_EL_T4, 1, 1, 1}, {MO_EL_T4, 2, 2, 4}, {MO_EL_T10, 5, 5, 14},
  };
  static const int fdeg[5] = {0, 1, 4, 5, 8};
  size_t r;
  int o;
  for (r = 0; r < MO_COUNT(R); r++) {
    mo_quad Q;
    int d = mo_eltype_get(R[r].t)->dim, st = mo_quad_element(R[r].t, R[r].order, &Q, ctx);
    double e = rule_error(&Q, d, R[r].degree), e1 = rule_error(&Q, d, R[r].degree + 1);
    ok(st == MO_OK && Q.n == R[r].npts && e < 1e-13 && e1 > 1e-6,
       "%s rule of degree %d: %d points, monomials exact to %.1e, degree %d off by %.1e", d == 2 ? "triangle" : "tetrahedron",
       R[r].degree, Q.n, e, R[r].degree + 1, e1);
  }
  for (o = 1; o <= 4; o++) {
    mo_quad Q;
    int st = mo_quad_facet_kind(MO_FK_TRI6, o, &Q, ctx);
    double e = rule_error(&Q, 2, fdeg[o]), e1 = rule_error(&Q, 2, fdeg[o] + 1);
    ok(st == MO_OK && e < 1e-13 && e1 > 1e-6 && fdeg[o] >= 2 * o - 1,
       "triangular facet rule of order %d: degree %d (at least 2 order - 1), %d points, exact to %.1e", o, fdeg[o], Q.n, e);
  }
}

/* Consistent nodal forces of a uniform pressure p on the top of a quadratic or tetrahedral
   patch: T6 edges p L / 6 at the ends and 2 p L / 3 in the middle; T4 faces p A / 3 at each
   corner; T10 faces 0 at the corners and p A / 3 in the middles. */
static void check_facet_loads(mo_ctx *ctx)
{
  static const mo_eltype types[3] = {MO_EL_T6, MO_EL_T4, MO_EL_T10};
  int t;
  for (t = 0; t < 3; t++) {
    mo_mesh *m = NULL;
    mo_material mat = {MO_MAT_ELASTIC, 1, 0, 1, 0, 0, MO_HYP_PLANE_STRAIN, 1, 0.5};
    const mo_facetset *fs;
    const mo_eltype_info *T = mo_eltype_get(types[t]);
    double p = 3e6, worst = 0, total = 0, area = 0, fe[3 * MO_FNODE_MAX];
    int k, a, D;
    if (types[t] == MO_EL_T6) {
      double o[2] = {0, 0}, sz[2] = {2, 1};
      int ne[2] = {3, 2};
      mo_mesh_rectangle(o, sz, ne, MO_EL_T6, MO_DIAG_ALTERNATE, &m, ctx);
    } else {
      double o[3] = {0, 0, 0}, sz[3] = {2, 1, 1.5};
      int ne[3] = {2, 3, 1};
      mo_mesh_box_elements(o, sz, ne, types[t], &m, ctx);
      mat.hyp = MO_HYP_3D;
    }
    D = m->dim;
    fs = mo_mesh_find_facetset(m, D == 2 ? "top" : "zmax");
    for (k = 0; k < fs->n; k++) {
      double meas, n[3], want;
      mo_facet_normal(m, fs, k, n, &meas);
      area += meas;
      mo_facet_load(m, fs, k, &mat, D == 2 ? pressure_cb : pressure3_cb, &p, fe, ctx);
      for (a = 0; a < fs->nfn; a++) {
        double w = D == 2 ? mat.thickness * meas : meas;
        if (types[t] == MO_EL_T6) want = a < 2 ? w / 6 : 2 * w / 3;
        else if (types[t] == MO_EL_T4) want = w / 3;
        else want = a < 3 ? 0 : w / 3;
        worst = fmax(worst, fabs(-fe[a * D + D - 1] - p * want) / (p * w));
        total -= fe[a * D + D - 1];
      }
    }
    ok(fs->kind == T->fkind && worst < 1e-13, "%s: uniform pressure on the top facets gives the consistent nodal forces "
       "(max error %.1e of p times the facet's measure)", T->name, worst);
    is_close(total, p * area * (D == 2 ? mat.thickness : 1), 1e-12 * p * area, "%s: the forces add up to p times the "
             "top's measure (%g)", T->name, area);
    is_close(area, 2, 1e-13, "%s: the top's measure is its size", T->name);
    mo_mesh_free(m);
  }
}

int main(void)
{
  mo_ctx ctx;
  size_t v;
  mo_ctx_init(&ctx);
  check_rules(&ctx);
  check_facet_loads(&ctx);
  for (v = 0; v < MO_COUNT(variants); v++) {
    const variant *V = &variants[v];
    mo_material mat = {MO_MAT_ELASTIC, 2.1e11, 0.3, 7800, 0, 0, V->hyp, 3e-4, 0.02};
    mo_mesh *m = patch_mesh(V, &ctx);
    int D = m->dim, n = m->nnode * D, e, a, b, c, st = 0, nen = m->nen, nd = nen * D;
    mo_triplet TK, TM;
    mo_csc *K = NULL, *M = NULL, *Kff = NULL;
    mo_linsolver *ls = NULL;
    int *bnd = calloc((size_t)m->nnode, sizeof(int)), *map = malloc((size_t)n * sizeof(int)), nf = 0;
    double *u = calloc((size_t)n, sizeof(double)), *ue = calloc((size_t)n, sizeof(double)),
           *r = calloc((size_t)n, sizeof(double)), *rf = calloc((size_t)n, sizeof(double));
    double vol = 0, err = 0, serr = 0, smax = 0, msum = 0, mlsum = 0, Dm[36], epsx[6] = {0};
    ok(m && mo_mesh_check(m, &ctx) == MO_OK, "%s: distorted patch is valid", V->name);
    mo_triplet_init(&TK, n, n, 0, &ctx);
    mo_triplet_init(&TM, n, n, 0, &ctx);
    for (e = 0; e < m->nelem; e++) {
      double Ke[MO_ND_MAX * MO_ND_MAX], Me[MO_ND_MAX * MO_ND_MAX], Ml[MO_ND_MAX * MO_ND_MAX];
      int dofs[MO_ND_MAX];
      for (a = 0; a < nen; a++)
        for (c = 0; c < D; c++) dofs[a * D + c] = m->conn[e * nen + a] * D + c;
      st |= mo_elem_stiffness(m, e, &mat, Ke, &ctx);
      st |= mo_elem_mass(m, e, &mat, 0, Me, &ctx);
      st |= mo_elem_mass(m, e, &mat, 1, Ml, &ctx);
      mo_triplet_add_block(&TK, dofs, nd, dofs, nd, Ke, &ctx);
      mo_triplet_add_block(&TM, dofs, nd, dofs, nd, Me, &ctx);
      for (a = 0; a < nd; a++)
        for (b = 0; b < nd; b++) {
          if (a % D == 0 && b % D == 0) { msum += Me[a * nd + b]; mlsum += Ml[a * nd + b]; }
          if (a != b && Ml[a * nd + b] != 0) st |= 1;
          if (a == b && !(Ml[a * nd + b] > 0)) st |= 2;
        }
      vol += mo_elem_measure(m, e, &mat);
    }
    ok(st == 0, "%s: element matrices computed, lumped mass diagonal and positive", V->name);
    if (mo_eltype_get(m->type)->order == 2 && V->hyp != MO_HYP_AXISYMMETRIC) {
      /* HRZ on straight elements: T6 corners 1/19 and middles 16/57 of the element's mass, T10
         corners 1/36 and middles 4/27 (T191) */
      double worst = 0, fc = m->type == MO_EL_T6 ? 1.0 / 19 : 1.0 / 36, fm = m->type == MO_EL_T6 ? 16.0 / 57 : 4.0 / 27;
      int nv = mo_eltype_get(m->type)->nvert;
      for (e = 0; e < m->nelem; e++) {
        double Ml[MO_ND_MAX * MO_ND_MAX], me = mat.rho * mo_elem_measure(m, e, &mat);
        mo_elem_mass(m, e, &mat, 1, Ml, &ctx);
        for (a = 0; a < nen; a++) worst = fmax(worst, fabs(Ml[(a * D) * nd + a * D] / me - (a < nv ? fc : fm)));
      }
      ok(worst < 1e-13, "%s: HRZ lumped mass: corners %.5g, middles %.5g of the element's mass (max error %.1e)", V->name,
         fc, fm, worst);
    }
    mo_triplet_to_csc(&TK, 1, &K, &ctx);
    mo_triplet_to_csc(&TM, 1, &M, &ctx);
    is_close(msum, mat.rho * vol, 1e-12 * mat.rho * vol, "%s: consistent mass sums to rho * volume", V->name);
    is_close(mlsum, mat.rho * vol, 1e-12 * mat.rho * vol, "%s: lumped mass sums to rho * volume", V->name);
    ok(mo_csc_asymmetry(K) < 1e-14 && mo_csc_asymmetry(M) < 1e-14, "%s: K and M symmetric", V->name);

    /* rigid-body modes: translations (and rotations where they are modes) give zero force */
    {
      int mode, nmodes = V->hyp == MO_HYP_AXISYMMETRIC ? 1 : D == 1 ? 1 : D == 2 ? 3 : 6;
      double kmax = 0, fmax = 0;
      for (a = 0; a < mo_csc_nnz(K); a++) if (fabs(K->x[a]) > kmax) kmax = fabs(K->x[a]);
      for (mode = 0; mode < nmodes; mode++) {
        for (a = 0; a < m->nnode; a++) {
          const double *x = &m->x[a * D];
          double *w = &u[a * D];
          for (c = 0; c < D; c++) w[c] = 0;
          if (V->hyp == MO_HYP_AXISYMMETRIC) w[1] = 1;            /* axial translation */
          else if (mode < D) w[mode] = 1;                         /* translations */
          else if (D == 2) { w[0] = -x[1]; w[1] = x[0]; }        /* rotation about z */
          else {
            int ax = mode - 3, i1 = (ax + 1) % 3, i2 = (ax + 2) % 3;
            w[i1] = -x[i2]; w[i2] = x[i1];
          }
        }
        mo_csc_gaxpy(K, 1, u, 0, r);
        for (a = 0; a < n; a++) if (fabs(r[a]) > fmax) fmax = fabs(r[a]);
      }
      ok(fmax <= 1e-12 * kmax, "%s: %d rigid-body mode%s give zero force (|K w| = %.2e, max |K| = %.2e)",
         V->name, nmodes, nmodes > 1 ? "s" : "", fmax, kmax);
    }

    /* patch test: boundary nodes follow a linear field; interior solved from K u = 0 */
    for (c = 0; c < 6; c++) {
      static const char *nm[6] = {"xmin", "xmax", "ymin", "ymax", "zmin", "zmax"};
      const mo_nodeset *ns = mo_mesh_find_nodeset(m, nm[c]);
      int k;
      for (k = 0; ns && k < ns->n; k++) bnd[ns->node[k]] = 1;
    }
    for (a = 0; a < m->nnode; a++) {
      linear_field(V, &m->x[a * D], &ue[a * D]);
      for (c = 0; c < D; c++) {
        map[a * D + c] = bnd[a] ? -1 : nf++;
        u[a * D + c] = bnd[a] ? ue[a * D + c] : 0;
      }
    }
    mo_csc_gaxpy(K, -1, u, 0, r); /* r = -K u_b */
    for (a = 0; a < n; a++) if (map[a] >= 0) rf[map[a]] = r[a];
    mo_csc_extract(K, map, nf, map, nf, &Kff, &ctx);
    mo_linsolver_create(&mo_linsolver_cholmod, &ls, &ctx);
    ok(mo_linsolver_factor(ls, Kff, &ctx) == MO_OK && mo_linsolver_solve(ls, rf, rf, &ctx) == MO_OK,
       "%s: interior problem solved (%d dofs)", V->name, nf);
    for (a = 0; a < n; a++) if (map[a] >= 0) u[a] = rf[map[a]];
    for (a = 0; a < n; a++) {
      double d = fabs(u[a] - ue[a]);
      if (d > err) err = d;
    }
    ok(err < 1e-13, "%s: patch test reproduces the linear field (max error %.2e)", V->name, err);
    /* constant strain and stress in every element, equal to D eps of the field */
    {
      int nc = mo_hyp_ncomp(mat.hyp);
      double x0[3] = {0, 0, 0}, u0[3], dx[3];
      mo_elastic_D(&mat, Dm);
      /* strain of the field by finite differences of the exact linear map */
      linear_field(V, x0, u0);
      for (c = 0; c < D; c++) {
        double x1[3] = {0, 0, 0}, u1[3];
        int i;
        x1[c] = 1;
        linear_field(V, x1, u1);
        for (i = 0; i < D; i++) dx[i] = u1[i] - u0[i]; /* column c of the gradient */
        if (D == 1) epsx[0] = dx[0];
        else if (D == 2) {
          if (c == 0) { epsx[0] = dx[0]; epsx[2] += dx[1]; }
          else { epsx[1] = dx[1]; epsx[2] += dx[0]; }
        } else {
          epsx[c] = dx[c];
          if (c == 0) { epsx[5] += dx[1]; epsx[4] += dx[2]; }
          if (c == 1) { epsx[5] += dx[0]; epsx[3] += dx[2]; }
          if (c == 2) { epsx[4] += dx[0]; epsx[3] += dx[1]; }
        }
      }
      if (mat.hyp == MO_HYP_AXISYMMETRIC) epsx[3] = 2e-3; /* hoop strain u_r / r */
      for (e = 0; e < m->nelem; e++) {
        double uel[MO_ND_MAX], eps[6], sig[6], sref[6];
        int i, j;
        for (a = 0; a < nen; a++)
          for (c = 0; c < D; c++) uel[a * D + c] = u[m->conn[e * nen + a] * D + c];
        mo_elem_stress(m, e, &mat, uel, eps, sig);
        for (i = 0; i < nc; i++) {
          sref[i] = 0;
          for (j = 0; j < nc; j++) sref[i] += Dm[i * nc + j] * epsx[j];
          if (fabs(sref[i]) > smax) smax = fabs(sref[i]);
          if (fabs(sig[i] - sref[i]) > serr) serr = fabs(sig[i] - sref[i]);
        }
      }
      ok(serr <= 1e-10 * smax, "%s: constant stress D eps in every element (max error %.2e of %.2e)",
         V->name, serr, smax);
    }
    if (mo_eltype_get(m->type)->order == 2 && V->hyp != MO_HYP_AXISYMMETRIC) {
      /* quadratic patch test: u = (x^2 - y^2, -2 x y, 0) is harmonic and divergence-free, an
         elastic field without body force (any nu): reproduced to round-off by T6 and T10 */
      double qerr = 0, qmax = 0;
      for (a = 0; a < m->nnode; a++) {
        const double *x = &m->x[a * D];
        ue[a * D] = x[0] * x[0] - x[1] * x[1];
        ue[a * D + 1] = -2 * x[0] * x[1];
        if (D == 3) ue[a * D + 2] = 0;
        for (c = 0; c < D; c++) u[a * D + c] = bnd[a] ? ue[a * D + c] : 0;
      }
      mo_csc_gaxpy(K, -1, u, 0, r);
      for (a = 0; a < n; a++) if (map[a] >= 0) rf[map[a]] = r[a];
      mo_linsolver_solve(ls, rf, rf, &ctx);
      for (a = 0; a < n; a++) if (map[a] >= 0) u[a] = rf[map[a]];
      for (a = 0; a < n; a++) {
        qerr = fmax(qerr, fabs(u[a] - ue[a]));
        qmax = fmax(qmax, fabs(ue[a]));
      }
      ok(qerr < 1e-13 * qmax, "%s: quadratic patch test (x^2 - y^2, -2xy) reproduced (max error %.2e of %.2e)", V->name,
         qerr, qmax);
    }
    mo_linsolver_free(ls);
    mo_csc_free(Kff);
    mo_csc_free(K);
    mo_csc_free(M);
    mo_triplet_release(&TK);
    mo_triplet_release(&TM);
    mo_mesh_free(m);
    free(bnd); free(map); free(u); free(ue); free(r); free(rf);
  }
  /* consistent load of a uniform pressure on edges: half of p t L to each end node */
  {
    mo_mesh *m;
    double o[2] = {0, 0}, s[2] = {2, 1}, fe[4], f[3] = {0, 0, 0}, p = 5e7;
    int ne[2] = {2, 1}, k, a;
    mo_material mat = {MO_MAT_ELASTIC, 1, 0, 1, 0, 0, MO_HYP_PLANE_STRAIN, 1, 0.5};
    const mo_facetset *fs;
    mo_mesh_rectangle(o, s, ne, MO_EL_Q4, MO_DIAG_RIGHT, &m, &ctx);
    fs = mo_mesh_find_facetset(m, "top");
    for (k = 0; k < fs->n; k++) {
      mo_facet_load(m, fs, k, &mat, pressure_cb, &p, fe, &ctx);
      for (a = 0; a < 2; a++) f[fs->node[2 * k + a] - 3] += fe[2 * a + 1];
    }
    is_close(f[0], -p * 0.5 * 0.5, 1e-6, "pressure: corner node gets -p t L / 2");
    is_close(f[1], -p * 0.5, 1e-6, "pressure: middle node gets -p t L");
    is_close(f[2], -p * 0.5 * 0.5, 1e-6, "pressure: other corner");
    mo_mesh_free(m);
  }
  return done_testing();
}
