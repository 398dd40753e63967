/* moreau/material.h: finite-strain J2 plasticity (material point) and finite-strain element
   kernels (internal forces, consistent tangents, energies, output fields). doc/theory.md §7. */
#ifndef MOREAU_MATERIAL_H
#define MOREAU_MATERIAL_H

#include <moreau/ctx.h>
#include <moreau/fe.h>
#include <moreau/mesh.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ---- The material ------------------------------------------------------------------------

   Multiplicative elastoplasticity F = Fe Fp with a Hencky (logarithmic) elastic energy and a
   von Mises yield surface with linear isotropic hardening, integrated by the exponential-map
   return (Simo 1992; Eterovic and Bathe 1990): the radial return of small strains applied to
   the logarithmic elastic trial strain, doc/theory.md (T23)-(T29). With MO_MAT_ELASTIC the
   same code is Hencky hyperelasticity (no yield). Parameters come from mo_material: E, nu
   (elasticity), sigma_y (initial yield stress, Pa), Et (tangent modulus of the uniaxial
   Kirchhoff stress - logarithmic strain curve, 0 <= Et < E; Et = 0 is perfect plasticity). */

/* Hardening modulus H = E Et / (E - Et): sigma_y(epsp) = sigma_y + H epsp, with epsp the
   equivalent plastic strain, so that the uniaxial curve has slope Et past yield (T27). */
double mo_j2_hardening(const mo_material *mat);

/* Check a material for the finite-strain kernels: E > 0, -1 < nu < 0.5, and for MO_MAT_J2
   sigma_y > 0 and 0 <= Et < E; hypothesis plane strain, axisymmetric or 3D (MO_EUNSUPPORTED
   for bar and plane stress). MO_EINPUT names the bad parameter. */
int mo_j2_check(const mo_material *mat, mo_ctx *ctx);

/* The state of one quadrature point: MO_J2_NSTATE doubles. Symmetric tensors are stored in the
   hypothesis' component order (fe.h): plane strain and axisymmetric 4 values (11, 22, 12, 33),
   3D 6 values (11, 22, 33, 23, 13, 12); the slots past those are zero.
   - MO_J2_CPINV: Cp^-1, the inverse plastic right Cauchy-Green tensor (the internal variable:
     the elastic trial is be = F Cp^-1 F^T, (T24));
   - MO_J2_EPSP: equivalent plastic strain;
   - MO_J2_WP: plastic work per unit reference volume, accumulated (J/m^3) (T29);
   - MO_J2_PSI: elastic stored energy per unit reference volume (J/m^3) (T25);
   - MO_J2_SIG: Cauchy stress (Pa), tau / det F;
   - MO_J2_DETF: det F, the volume ratio (in the elements: of the F-bar the material sees, the
     element's mean dilatation theta, (T32)).
   The first three are the history (what the step starts from); the others are results kept for
   energies and output. The caller stores one block per point, points of an element
   consecutive, elements consecutive: a committed array and a trial array of the same shape. */
enum {
  MO_J2_CPINV = 0,
  MO_J2_EPSP = 6,
  MO_J2_WP = 7,
  MO_J2_PSI = 8,
  MO_J2_SIG = 9,
  MO_J2_DETF = 15,
  MO_J2_NSTATE = 16
};

/* Initial (virgin, stress-free) state of npoint points: Cp^-1 = I, all else 0, det F = 1. */
void mo_j2_state_init(mo_hypothesis h, double *state, int npoint);

/* The constitutive update at one point. Reads F (deformation gradient, 3x3 row-major; in 2D
   F13 = F23 = F31 = F32 = 0 and F33 is 1 in plane strain, r/R in axisymmetry) and the
   committed state sn; writes the trial state s (sn and s may be the same array), the Kirchhoff
   stress tau = J sigma (3x3 row-major, symmetric) and, when A is not NULL, the consistent
   tangent A (9x9 row-major): the linearization of tau in the spatial velocity gradient,
   d tau = A : (dF F^-1), A[(3i+j)*9 + 3k+l] = d tau_ij / d l_kl (T30)-(T31). No allocation.
   Returns MO_ENAN (message in ctx) when det F <= 0 or a value is not finite. */
int mo_j2_update(const mo_material *mat, const double *F, const double *sn, double *s,
                 double *tau, double *A, mo_ctx *ctx);

/* ---- Finite-strain elements --------------------------------------------------------------

   Total Lagrangian: displacements and integrals refer to the reference (mesh) configuration;
   the mass matrix is the small-strain one (mo_elem_mass). Isochoric plastic flow does not lock
   Q4 and H8: F-bar with the element's mean dilatation, F-bar = (theta / det F)^(1/d) F with
   theta = v_e / V_e the element's volume ratio (Nagtegaal, Parks and Rice 1974; Simo, Taylor
   and Pister 1985), in variational form: the forces are the gradient of the stored energy, the
   tangent is symmetric, and a homogeneous stress passes the patch test on distorted elements
   (T32)-(T35). Quadrature: Q4 2x2, H8 2x2x2 Gauss; T3 one point in plane strain (constant
   strain: it locks under isochoric flow unless the diagonals alternate, use Q4), three points
   in axisymmetry with the mean dilatation. */

/* Option bits of mo_elem_nl_force. */
enum {
  MO_NL_STANDARD = 1 /* without the mean dilatation: the standard displacement element, which
                        locks under isochoric flow (for comparisons) */
};

/* Quadrature points of the finite-strain kernels for this element type and hypothesis
   (0 when unsupported): the number of state blocks per element. */
int mo_elem_nl_npoint(mo_eltype t, mo_hypothesis h);

/* Internal forces and consistent tangent of element e at total displacements ue (nen*dim,
   node-major as in fe.h), for a material the caller has checked once with mo_j2_check. Reads
   the committed states sn of the element's points (npoint blocks of MO_J2_NSTATE); writes the
   trial states s (same shape, not aliasing sn), the internal force vector fe (nen*dim;
   equilibrium is f_int = f_ext) and, when Ke is not NULL, the tangent Ke = d fe / d ue
   (row-major, (nen*dim)^2, symmetric). opts: 0 or MO_NL_STANDARD. Returns MO_ENAN when the
   deformation is not admissible (det F <= 0 at a point: the caller may cut its step),
   MO_EINPUT for a reference element with a non-positive Jacobian, MO_EUNSUPPORTED for bar
   elements and 1D or plane-stress hypotheses. No allocation. */
int mo_elem_nl_force(const mo_mesh *msh, int e, const mo_material *mat, unsigned opts,
                     const double *ue, const double *sn, double *s, double *fe, double *Ke,
                     mo_ctx *ctx);

/* Energies of element e in state s (its npoint blocks): elastic stored energy *psi and plastic
   work *wp accumulated since the virgin state (J; integrals over the reference volume, the
   full ring in axisymmetry, times the thickness in plane strain). The plastic dissipation of
   a step is the difference of *wp between the trial and the committed states. */
int mo_elem_nl_energy(const mo_mesh *msh, int e, const mo_material *mat, const double *s,
                      double *psi, double *wp);

/* Output fields of element e in state s, averaged over its points with reference-volume
   weights: Cauchy stress sig (mo_hyp_ncomp values, fe.h order; may be NULL), von Mises stress
   *vm (the mean of the points' values) and equivalent plastic strain *epsp. */
int mo_elem_nl_fields(const mo_mesh *msh, int e, const mo_material *mat, const double *s,
                      double *sig, double *vm, double *epsp);

#ifdef __cplusplus
}
#endif
#endif
