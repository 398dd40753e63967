/* taylor_explicit.h: the axisymmetric Taylor bar by explicit central differences, the
   independent reference the implicit scenes are checked against (tests), and its whole-mesh
   nonlinear assembly, which test_finite_strain's Newton uses too. */
#ifndef MOREAU_TAYLOR_EXPLICIT_H
#define MOREAU_TAYLOR_EXPLICIT_H

#include <moreau/material.h>
#include <moreau/mesh.h>

/* Internal forces f of a whole mesh by mo_elem_nl_force at u, the trial states s from the
   committed sn (and the dense tangent K, n x n row-major, when K is not NULL). */
int nl_assemble(const mo_mesh *m, const mo_material *mat, unsigned opts, const double *u, const double *sn,
                double *s, double *f, double *K, mo_ctx *ctx);

/* The copper bar of doc/architecture.md §11 (radius 3.2 mm, length 32.4 mm, 227 m/s) on a rigid
   frictionless wall to 80 us, nr x nz Q4 (axisymmetric, J2, opts as mo_elem_nl_force), lumped
   mass, central differences with a step from the current smallest element height, the wall as a
   velocity projection. Writes the final length, the footprint radius (the impact face's largest
   radius), the largest element mean of epsp, the relative gap between the work of the internal
   forces and stored + plastic energy, and the fraction of the kinetic energy the wall took (the
   inelastic node impacts). NaN on failure. */
void taylor_explicit(unsigned opts, int nr, int nz, double *len, double *rad, double *epmax,
                     double *gap, double *wall);

#endif
