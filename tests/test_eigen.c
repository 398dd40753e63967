/* test_eigen.c: natural frequencies of a clamped-free bar against (2n - 1) pi c / (2 L). */
#include "config.h"
#include <moreau/fe.h>
#include <moreau/mesh.h>
#include "tap.h"

/* LAPACK: generalized symmetric-definite eigenproblem A x = lambda B x */
extern void dsygv_(const int *itype, const char *jobz, const char *uplo, const int *n, double *a,
                   const int *lda, double *b, const int *ldb, double *w, double *work,
                   const int *lwork, int *info);

static void bar_frequencies(int nel, int lumped, double L, double E, double rho, double *omega)
{
  mo_ctx ctx;
  mo_mesh *m;
  mo_material mat = {MO_MAT_ELASTIC, E, 0, rho, 0, 0, MO_HYP_BAR, 1e-4, 1};
  int n = nel, e, a, b, one = 1, lwork = 64 * nel, info;
  double *K = calloc((size_t)n * n, sizeof(double)), *M = calloc((size_t)n * n, sizeof(double));
  double *w = malloc((size_t)n * sizeof(double)), *work = malloc((size_t)lwork * sizeof(double));
  mo_ctx_init(&ctx);
  mo_mesh_bar(0, L, nel, &m, &ctx);
  for (e = 0; e < nel; e++) {
    double Ke[4], Me[4];
    mo_elem_stiffness(m, e, &mat, Ke, &ctx);
    mo_elem_mass(m, e, &mat, lumped, Me, &ctx);
    for (a = 0; a < 2; a++)
      for (b = 0; b < 2; b++) {
        int i = e + a - 1, j = e + b - 1; /* node 0 clamped: free dof of node k is k - 1 */
        if (i < 0 || j < 0) continue;
        K[j * n + i] += Ke[a * 2 + b];
        M[j * n + i] += Me[a * 2 + b];
      }
  }
  dsygv_(&one, "N", "U", &n, K, &n, M, &n, w, work, &lwork, &info);
  for (a = 0; a < n; a++) omega[a] = info == 0 ? sqrt(w[a]) : NAN;
  mo_mesh_free(m);
  free(K); free(M); free(w); free(work);
}

int main(void)
{
  double L = 2.0, E = 2e11, rho = 7800, c = sqrt(E / rho), omega[400];
  int lumped, k;
  for (lumped = 0; lumped < 2; lumped++) {
    double worst = 0;
    bar_frequencies(100, lumped, L, E, rho, omega);
    for (k = 1; k <= 5; k++) {
      double exact = (2 * k - 1) * M_PI * c / (2 * L), rel = fabs(omega[k - 1] - exact) / exact;
      ok(rel < 0.01, "%s mass, 100 elements: mode %d within 1%% (%.3e relative)",
         lumped ? "lumped" : "consistent", k, rel);
      if (rel > worst) worst = rel;
    }
    /* second-order convergence: error at 200 elements about a quarter of that at 100 */
    bar_frequencies(200, lumped, L, E, rho, omega);
    {
      double exact = 9 * M_PI * c / (2 * L), rel = fabs(omega[4] - exact) / exact;
      ok(rel < 0.3 * worst && rel > 0.2 * worst, "%s mass: mode 5 error drops by 4 when h halves (%.3e -> %.3e)",
         lumped ? "lumped" : "consistent", worst, rel);
    }
    /* consistent mass bounds the frequencies from above, lumped from below */
    bar_frequencies(100, lumped, L, E, rho, omega);
    ok(lumped ? omega[0] < M_PI * c / (2 * L) : omega[0] > M_PI * c / (2 * L),
       "%s mass: first frequency is a %s bound", lumped ? "lumped" : "consistent", lumped ? "lower" : "upper");
  }
  return done_testing();
}
