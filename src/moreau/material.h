/* moreau/material.h: finite-strain J2 plasticity at a material point. doc/theory.md §6. */
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
   the logarithmic elastic trial strain, doc/theory.md (T13)-(T19). With MO_MAT_ELASTIC the
   same code is Hencky hyperelasticity (no yield). Parameters come from mo_material: E, nu
   (elasticity), sigma_y (initial yield stress, Pa), Et (tangent modulus of the uniaxial
   Kirchhoff stress - logarithmic strain curve, 0 <= Et < E; Et = 0 is perfect plasticity). */

/* Hardening modulus H = E Et / (E - Et): sigma_y(epsp) = sigma_y + H epsp, with epsp the
   equivalent plastic strain, so that the uniaxial curve has slope Et past yield (T17). */
double mo_j2_hardening(const mo_material *mat);

/* Check a material for the finite-strain kernels: E > 0, -1 < nu < 0.5, and for MO_MAT_J2
   sigma_y > 0 and 0 <= Et < E; hypothesis plane strain, axisymmetric or 3D (MO_EUNSUPPORTED
   for bar and plane stress). MO_EINPUT names the bad parameter. */
int mo_j2_check(const mo_material *mat, mo_ctx *ctx);

/* The state of one quadrature point: MO_J2_NSTATE doubles. Symmetric tensors are stored in the
   hypothesis' component order (fe.h): plane strain and axisymmetric 4 values (11, 22, 12, 33),
   3D 6 values (11, 22, 33, 23, 13, 12); the slots past those are zero.
   - MO_J2_CPINV: Cp^-1, the inverse plastic right Cauchy-Green tensor (the internal variable:
     the elastic trial is be = F Cp^-1 F^T, (T14));
   - MO_J2_EPSP: equivalent plastic strain;
   - MO_J2_WP: plastic work per unit reference volume, accumulated (J/m^3) (T19);
   - MO_J2_PSI: elastic stored energy per unit reference volume (J/m^3) (T15);
   - MO_J2_SIG: Cauchy stress (Pa);
   - MO_J2_DETF: det F (current over reference volume).
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
   d tau = A : (dF F^-1), A[(3i+j)*9 + 3k+l] = d tau_ij / d l_kl (T20)-(T21). No allocation.
   Returns MO_ENAN (message in ctx) when det F <= 0 or a value is not finite. */
int mo_j2_update(const mo_material *mat, const double *F, const double *sn, double *s,
                 double *tau, double *A, mo_ctx *ctx);

#ifdef __cplusplus
}
#endif
#endif
