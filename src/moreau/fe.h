/* moreau/fe.h: materials, shape functions, quadrature and element matrices (small strain). */
#ifndef MOREAU_FE_H
#define MOREAU_FE_H

#include <moreau/ctx.h>
#include <moreau/mesh.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum {
  MO_HYP_BAR = 0,       /* 1D bar: axial stress, cross-section area */
  MO_HYP_PLANE_STRAIN,  /* 2D, per unit thickness unless thickness is set */
  MO_HYP_PLANE_STRESS,
  MO_HYP_AXISYMMETRIC,  /* 2D (r, z): integrals over the full ring (factor 2 pi r) */
  MO_HYP_3D
} mo_hypothesis;

typedef enum { MO_MAT_ELASTIC = 0, MO_MAT_J2 } mo_material_model;

typedef struct {
  mo_material_model model;
  double E, nu, rho;
  double sigma_y, Et;   /* J2: initial yield stress, tangent (hardening) modulus */
  mo_hypothesis hyp;
  double area;          /* bar cross-section (m^2) */
  double thickness;     /* plane strain / plane stress thickness (m) */
} mo_material;

/* Number of stress/strain components stored per point: bar 1; plane 4 (xx, yy, xy, zz);
   axisymmetric 4 (rr, zz, rz, tt); 3D 6 (xx, yy, zz, yz, xz, xy). */
int mo_hyp_ncomp(mo_hypothesis h);
const char *mo_hyp_name(mo_hypothesis h);

/* Shape functions and derivatives with respect to reference coordinates xi at one point.
   Reference elements: bar [-1,1]; T3 and T6 area coordinates (xi, eta) in the unit triangle; T4
   and T10 (xi, eta, zeta) in the unit tetrahedron; Q4 [-1,1]^2; H8 [-1,1]^3. N[nen],
   dN[nen*dim] (dN[a*dim+i] = dN_a/dxi_i). The nodes' order: mesh.h. */
void mo_shape(mo_eltype t, const double *xi, double *N, double *dN);
/* Shape functions of a facet of kind k (mesh.h: its reference domain and node order); dN holds
   one derivative per node on lines, two (d/ds0, d/ds1) on surfaces. */
void mo_facet_shape_kind(mo_facet_kind k, const double *s, double *N, double *dN);
/* The same by node count (1 point, 2 line, 3 triangle, 4 quadrilateral, 6 quadratic triangle;
   the 3-node line has the kind only). */
void mo_facet_shape(int nfn, const double *s, double *N, double *dN);
/* Dimension of a facet kind's reference domain (0, 1 or 2). */
int mo_facet_kind_dim(mo_facet_kind k);

/* A quadrature rule on the reference element or facet. */
#define MO_QMAX 27
typedef struct {
  int n, dim;
  double xi[MO_QMAX][3];
  double w[MO_QMAX];
} mo_quad;
/* Gauss-Legendre rules (GSL) of `order` points per direction for bar/Q4/H8 and for facets; for
   the simplices (T3, T6, T4, T10) `order` is the polynomial degree the rule integrates exactly:
   1 (the centroid), 2 (3 points on triangles, 4 on tetrahedra), 3 or 4 (6 points on triangles),
   5 (7 points on triangles; 14 points, degree 5, on tetrahedra, also for 3 and 4). */
int mo_quad_element(mo_eltype t, int order, mo_quad *q, mo_ctx *ctx);
int mo_quad_facet(int fdim, int order, mo_quad *q, mo_ctx *ctx);
/* A rule on a facet of kind k: `order` Gauss points per direction on lines and quadrilaterals;
   on triangles a rule at least as exact (degree 2 order - 1: 1, 6, 7 or 25 points). */
int mo_quad_facet_kind(mo_facet_kind k, int order, mo_quad *q, mo_ctx *ctx);

/* Geometry of element e at reference point xi: shape functions N[nen], Cartesian derivatives
   dNx[a*dim+i] = dN_a/dx_i (mesh coordinates), point coordinates xq[dim]. Returns the Jacobian
   determinant (<= 0 for an inverted element). */
double mo_elem_geometry(const mo_mesh *msh, int e, const double *xi, double *N, double *dNx,
                        double *xq);
/* Integration factor at point xq: bar cross-section, plane thickness, 2 pi r (axisymmetric:
   integrals over the full ring), 1 in 3D. */
double mo_measure_factor(const mo_material *mat, const double *xq);

/* Elasticity matrix D (ncomp x ncomp, row-major) in the stored component order. For plane
   strain the zz row is used only to recover sigma_zz; for plane stress sigma_zz = 0. */
void mo_elastic_D(const mo_material *m, double *D);

/* Element matrices for linear elasticity of element e of mesh msh (row-major, size
   (nen*dim)^2, dofs ordered node-major: node a, component i at a*dim+i). Stiffness with full
   integration (2x2 / 2x2x2 Gauss, the centroid for T3 and T4, degree 2 for T6 and T10); mass
   consistent or lumped (row sums for the linear types, HRZ diagonal scaling for T6 and T10,
   doc/theory.md (T191)). */
int mo_elem_stiffness(const mo_mesh *msh, int e, const mo_material *mat, double *Ke,
                      mo_ctx *ctx);
int mo_elem_mass(const mo_mesh *msh, int e, const mo_material *mat, int lumped, double *Me,
                 mo_ctx *ctx);
/* Strain and stress at the element centroid (mo_eltype_info.centre) from element displacements
   ue (ordering as above).
   eps, sig: mo_hyp_ncomp(...) values (shear as tensor components, not engineering strains). */
int mo_elem_stress(const mo_mesh *msh, int e, const mo_material *mat, const double *ue,
                   double *eps, double *sig);
/* Measure of element e: length*area (bar), area*thickness or ring volume (2D), volume (3D). */
double mo_elem_measure(const mo_mesh *msh, int e, const mo_material *mat);

/* Consistent nodal forces of a traction t(x) (force per unit facet measure; in 1D force per
   unit area of the end section) applied on facet `f` of facet set fs. `traction` is called at
   each quadrature point with the point coordinates and the outward unit normal, and writes the
   dim traction components. fe receives nfn*dim values (node-major). */
typedef void (*mo_traction_fn)(const double *x, const double *n, void *data, double *t);
int mo_facet_load(const mo_mesh *msh, const mo_facetset *fs, int f, const mo_material *mat,
                  mo_traction_fn traction, void *data, double *fe, mo_ctx *ctx);
/* Outward unit normal and measure (length, area; 1 for a point) of facet f, at its centre. */
void mo_facet_normal(const mo_mesh *msh, const mo_facetset *fs, int f, double *n,
                     double *measure);

/* Von Mises equivalent of a stress stored in the hypothesis' component order. */
double mo_von_mises(mo_hypothesis h, const double *sig);

#ifdef __cplusplus
}
#endif
#endif
