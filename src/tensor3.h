/* tensor3.h: 3x3 tensor kernels for the finite-strain code (private; row-major a[3*i+j]). */
#ifndef MOREAU_TENSOR3_H
#define MOREAU_TENSOR3_H

#include <math.h>
#include <string.h>

#include <moreau/fe.h>

/* C = A B */
static inline void t3_mul(const double *A, const double *B, double *C)
{
  int i, j;
  for (i = 0; i < 3; i++)
    for (j = 0; j < 3; j++)
      C[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
}

/* C = A B^T */
static inline void t3_mul_nt(const double *A, const double *B, double *C)
{
  int i, j;
  for (i = 0; i < 3; i++)
    for (j = 0; j < 3; j++)
      C[3 * i + j] =
          A[3 * i] * B[3 * j] + A[3 * i + 1] * B[3 * j + 1] + A[3 * i + 2] * B[3 * j + 2];
}

static inline double t3_det(const double *A)
{
  return A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) +
         A[2] * (A[3] * A[7] - A[4] * A[6]);
}

/* B = A^-1 (cofactors over the determinant); returns det A (B untouched when it is 0). */
static inline double t3_inv(const double *A, double *B)
{
  double d = t3_det(A);
  if (d == 0) return 0;
  B[0] = (A[4] * A[8] - A[5] * A[7]) / d;
  B[1] = (A[2] * A[7] - A[1] * A[8]) / d;
  B[2] = (A[1] * A[5] - A[2] * A[4]) / d;
  B[3] = (A[5] * A[6] - A[3] * A[8]) / d;
  B[4] = (A[0] * A[8] - A[2] * A[6]) / d;
  B[5] = (A[2] * A[3] - A[0] * A[5]) / d;
  B[6] = (A[3] * A[7] - A[4] * A[6]) / d;
  B[7] = (A[1] * A[6] - A[0] * A[7]) / d;
  B[8] = (A[0] * A[4] - A[1] * A[3]) / d;
  return d;
}

/* B = Q diag(x) Q^T (symmetric) */
static inline void t3_spectral(const double *Q, const double *x, double *B)
{
  int i, j;
  for (i = 0; i < 3; i++)
    for (j = i; j < 3; j++)
      B[3 * i + j] = B[3 * j + i] =
          Q[3 * i] * x[0] * Q[3 * j] + Q[3 * i + 1] * x[1] * Q[3 * j + 1] +
          Q[3 * i + 2] * x[2] * Q[3 * j + 2];
}

/* Symmetric tensor <-> components in the hypothesis order of fe.h: plane strain and
   axisymmetric (11, 22, 12, 33), 3D (11, 22, 33, 23, 13, 12). */
static inline void t3_from_sym(mo_hypothesis h, const double *v, double *A)
{
  if (h == MO_HYP_3D) {
    A[0] = v[0]; A[4] = v[1]; A[8] = v[2];
    A[5] = A[7] = v[3];
    A[2] = A[6] = v[4];
    A[1] = A[3] = v[5];
  } else {
    A[0] = v[0]; A[4] = v[1]; A[8] = v[3];
    A[1] = A[3] = v[2];
    A[2] = A[5] = A[6] = A[7] = 0;
  }
}

static inline void t3_to_sym(mo_hypothesis h, const double *A, double *v)
{
  if (h == MO_HYP_3D) {
    v[0] = A[0]; v[1] = A[4]; v[2] = A[8];
    v[3] = A[5]; v[4] = A[2]; v[5] = A[1];
  } else {
    v[0] = A[0]; v[1] = A[4]; v[2] = A[1]; v[3] = A[8];
  }
}

#endif
