/* box_mumps.c: MUMPS's analysis alone of the box of bench/box_scaling.sh through PETSc (no numeric
   factorization: what the run would need before it runs; doc/theory.md (T181)). The pattern is the
   stiffness matrix's of an n^3 H8 grid, 3 dofs per node, every node coupled to its 26 neighbours;
   the 3 dofs of the (n + 1)^2 bottom nodes are MUMPS's Schur variables (the contact dofs of the
   run, (T180)), or none with --no-schur.

     mpicc -O2 bench/box_mumps.c $(pkg-config --cflags --libs PETSc) -o /tmp/box_mumps
     /tmp/box_mumps [--no-schur] 31 [45 68 ...]

   One line per n: dofs, Schur variables, MUMPS's estimated factor entries (INFOG(20)) and flops
   (RINFOG(1)), its estimated memory in core (INFOG(17)) and out of core (INFOG(27)) in GB (MUMPS's
   MB are 1e6 bytes), the dense Schur complement, the ordering MUMPS chose (INFOG(7): 0 AMD,
   2 AMF, 3 SCOTCH, 4 PORD, 5 METIS, 6 QAMD), the analysis' seconds and this process's peak resident size. One rank (the
   Schur complement needs one under PETSc 3.18). */
#include <petscmat.h>
#include <stdio.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

static double now(void)
{
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static double infog(Mat F, PetscInt k)
{
  PetscInt v = 0;
  MatMumpsGetInfog(F, k, &v);
  return v < 0 ? -1e6 * (double)v : (double)v;
}

/* The grid's matrix: the pattern with zeros off the diagonal, 1 on it (the analysis reads the
   pattern only). */
static PetscErrorCode grid(PetscInt n, Mat *A)
{
  PetscInt m = n + 1, N = 3 * m * m * m, x, y, z, *nnz, cols[81];
  PetscScalar vals[81];
  PetscFunctionBeginUser;
  PetscCall(PetscMalloc1(N, &nnz));
  for (z = 0; z < m; z++)
    for (y = 0; y < m; y++)
      for (x = 0; x < m; x++) {
        PetscInt cx = 1 + (x > 0) + (x < n), cy = 1 + (y > 0) + (y < n), cz = 1 + (z > 0) + (z < n), a;
        for (a = 0; a < 3; a++) nnz[3 * ((z * m + y) * m + x) + a] = 3 * cx * cy * cz;
      }
  PetscCall(MatCreateSeqAIJ(PETSC_COMM_SELF, N, N, 0, nnz, A));
  PetscCall(PetscFree(nnz));
  for (z = 0; z < m; z++)
    for (y = 0; y < m; y++)
      for (x = 0; x < m; x++) {
        PetscInt node = (z * m + y) * m + x, k = 0, dz, dy, dx, a, b;
        for (dz = -1; dz <= 1; dz++)
          for (dy = -1; dy <= 1; dy++)
            for (dx = -1; dx <= 1; dx++) {
              PetscInt X = x + dx, Y = y + dy, Z = z + dz;
              if (X < 0 || Y < 0 || Z < 0 || X > n || Y > n || Z > n) continue;
              for (b = 0; b < 3; b++) cols[k++] = 3 * ((Z * m + Y) * m + X) + b;
            }
        for (a = 0; a < 3; a++) {
          PetscInt row = 3 * node + a, j;
          for (j = 0; j < k; j++) vals[j] = cols[j] == row ? 1.0 : 0.0;
          PetscCall(MatSetValues(*A, 1, &row, k, cols, vals, INSERT_VALUES));
        }
      }
  PetscCall(MatAssemblyBegin(*A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(*A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatSetOption(*A, MAT_SPD, PETSC_TRUE));
  PetscFunctionReturn(0);
}

static PetscErrorCode analyse(PetscInt n, int schur)
{
  Mat A, F;
  MatFactorInfo fi;
  PetscInt m = n + 1, nC = schur ? 3 * m * m : 0, k;
  PetscReal fl = 0;
  double t0;
  struct rusage ru;
  PetscFunctionBeginUser;
  PetscCall(grid(n, &A));
  PetscCall(MatGetFactor(A, MATSOLVERMUMPS, MAT_FACTOR_CHOLESKY, &F));
  if (nC) {
    IS is;
    PetscInt *idx;
    PetscCall(PetscMalloc1(nC, &idx));
    for (k = 0; k < nC; k++) idx[k] = k; /* the bottom nodes (z = 0) come first */
    PetscCall(ISCreateGeneral(PETSC_COMM_SELF, nC, idx, PETSC_OWN_POINTER, &is));
    PetscCall(MatFactorSetSchurIS(F, is));
    PetscCall(ISDestroy(&is));
  }
  PetscCall(MatFactorInfoInitialize(&fi));
  t0 = now();
  PetscCall(MatCholeskyFactorSymbolic(F, A, NULL, &fi));
  t0 = now() - t0;
  PetscCall(MatMumpsGetRinfog(F, 1, &fl));
  getrusage(RUSAGE_SELF, &ru);
  printf("n=%d dofs=%d schur=%d factor_entries=%.4g flops=%.4g in_core_GB=%.2f out_of_core_GB=%.2f schur_GB=%.2f "
         "ordering=%g analysis_s=%.1f peak_rss_GB=%.2f\n",
         (int)n, (int)(3 * m * m * m), (int)nC, infog(F, 20), (double)fl, infog(F, 17) / 1e3, infog(F, 27) / 1e3,
         8.0 * nC * nC / 1e9, infog(F, 7), t0, ru.ru_maxrss / 1e6);
  fflush(stdout);
  PetscCall(MatDestroy(&F));
  PetscCall(MatDestroy(&A));
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  int a, schur = 1;
  PetscCall(PetscInitialize(&argc, &argv, NULL, NULL));
  for (a = 1; a < argc; a++) {
    if (!strcmp(argv[a], "--no-schur")) schur = 0;
    else if (argv[a][0] != '-') PetscCall(analyse((PetscInt)atoi(argv[a]), schur));
  }
  PetscCall(PetscFinalize());
  return 0;
}
