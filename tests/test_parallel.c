/* test_parallel.c: the PETSc linear-solver type on one or more MPI ranks against CHOLMOD on the
   same matrices (doc/parallel.md §2), the collective calls, and K and M assembled by the ranks
   each from its block of elements against one process's assembly (§3). Run alone, or under mpirun by
   tests/test_mpi.sh; every rank checks, rank 0 prints. */
#include "config.h"
#include <moreau/parallel.h>
#include <moreau/sparse.h>
#include <moreau/case.h>
#include <moreau/scene.h>
#include "tap.h"
#include "broad.h"
#include "parallel_detect.h"

#include <math.h>
#include <stdlib.h>

/* A 2D Laplacian on an nx x ny grid plus a mass-like diagonal: SPD, with the pattern of a
   stiffness matrix (rows coupled across the ranks' row blocks). */
static mo_csc *laplacian(int nx, int ny, double shift, mo_ctx *ctx)
{
  mo_triplet T;
  mo_csc *A = NULL;
  int i, j, n = nx * ny;
  mo_triplet_init(&T, n, n, (size_t)5 * n, ctx);
  for (j = 0; j < ny; j++)
    for (i = 0; i < nx; i++) {
      int a = j * nx + i;
      mo_triplet_add(&T, a, a, 4 + shift * (1 + 0.1 * (a % 7)), ctx);
      if (i + 1 < nx) {
        mo_triplet_add(&T, a, a + 1, -1, ctx);
        mo_triplet_add(&T, a + 1, a, -1, ctx);
      }
      if (j + 1 < ny) {
        mo_triplet_add(&T, a, a + nx, -1, ctx);
        mo_triplet_add(&T, a + nx, a, -1, ctx);
      }
    }
  mo_triplet_to_csc(&T, 1, &A, ctx);
  mo_triplet_release(&T);
  return A;
}

/* max |x - y| / max |y| */
static double rel(const double *x, const double *y, long n)
{
  double d = 0, m = 0;
  long k;
  for (k = 0; k < n; k++) {
    if (fabs(x[k] - y[k]) > d) d = fabs(x[k] - y[k]);
    if (fabs(y[k]) > m) m = fabs(y[k]);
  }
  return m > 0 ? d / m : d;
}

static int agree_all(int pass, mo_ctx *ctx)
{
  double f = pass ? 0 : 1;
  mo_par_max(&f, 1, ctx);
  return f == 0;
}

/* Rank r's part of A (the parts' sum is A, each part another pattern): the diagonal shared
   evenly, an off-diagonal entry (i, j) on rank (i + j) mod nranks. */
static mo_csc *part_of(const mo_csc *A, mo_ctx *ctx)
{
  mo_triplet T;
  mo_csc *P = NULL;
  int j, p, nr = ctx->nranks;
  mo_triplet_init(&T, A->nrow, A->ncol, (size_t)mo_csc_nnz(A), ctx);
  for (j = 0; j < A->ncol; j++)
    for (p = A->p[j]; p < A->p[j + 1]; p++) {
      int i = A->i[p];
      if (i == j) mo_triplet_add(&T, i, j, A->x[p] / nr, ctx);
      else if ((i + j) % nr == ctx->rank) mo_triplet_add(&T, i, j, A->x[p], ctx);
    }
  mo_triplet_to_csc(&T, 0, &P, ctx);
  mo_triplet_release(&T);
  return P;
}

/* The solutions kept by rows (T210): each rank's rows of B in, its rows of X out, equal to
   those rows of CHOLMOD's solutions; the ranks' rows contiguous and together every row once. */
static void rows_checks(mo_linsolver *ps, mo_linsolver *chol, const double *B, int nrhs, double tol, mo_ctx *ctx)
{
  int n = mo_linsolver_n(chol), r0 = -1, r1 = -1, q0 = -1, q1 = -1, nloc, k, i, st;
  double *Br, *Xr, *Y = malloc(sizeof(double) * n * nrhs), d = 0, m = 0, cnt[2];
  st = mo_linsolver_solve_rows(ps, 0, NULL, NULL, &r0, &r1, ctx);
  nloc = r1 - r0;
  Br = malloc(sizeof(double) * (nloc > 0 ? nloc : 1) * nrhs);
  Xr = malloc(sizeof(double) * (nloc > 0 ? nloc : 1) * nrhs);
  /* every rank's count and the first rows' end: the rows split, each row on one rank */
  cnt[0] = nloc;
  cnt[1] = ctx->rank == 0 ? r0 : 0;
  mo_par_sum(cnt, 2, ctx);
  ok(agree_all(st == MO_OK && nloc > 0 && cnt[0] == n && cnt[1] == 0 && (ctx->nranks == 1 || nloc < n), ctx),
     "petsc rows: %d of the %d rows on this rank, %d over the ranks", nloc, n, (int)cnt[0]);
  for (k = 0; k < nrhs; k++)
    for (i = 0; i < nloc; i++) Br[(size_t)k * nloc + i] = B[(size_t)k * n + r0 + i];
  mo_linsolver_solve_multi(chol, nrhs, B, Y, ctx);
  st = mo_linsolver_solve_rows(ps, nrhs, Br, Xr, &q0, &q1, ctx);
  for (k = 0; k < nrhs; k++)
    for (i = 0; i < nloc; i++) {
      double y = Y[(size_t)k * n + r0 + i], x = Xr[(size_t)k * nloc + i];
      if (fabs(x - y) > d) d = fabs(x - y);
      if (fabs(y) > m) m = fabs(y);
    }
  d = m > 0 ? d / m : 1;
  mo_par_max(&d, 1, ctx);
  ok(agree_all(st == MO_OK && q0 == r0 && q1 == r1, ctx) && d < tol,
     "petsc rows: each rank's rows of %d solutions equal CHOLMOD's to %.1e (tol %.0e)", nrhs, d, tol);
  free(Br);
  free(Xr);
  free(Y);
}

/* parts: each rank factors its part of the matrix (K and M in parts over the ranks) */
static void solver_checks(mo_ctx *ctx, const char *ksp, const char *pc, double tol, int parts)
{
  mo_csc *A = laplacian(23, 17, 0.5, ctx), *A2 = laplacian(23, 17, 2.0, ctx), *P = NULL, *P2 = NULL;
  int n = A->nrow, k, nrhs = 3;
  double *B = malloc(sizeof(double) * n * nrhs), *X = malloc(sizeof(double) * n * nrhs),
         *Y = malloc(sizeof(double) * n * nrhs);
  mo_linsolver *chol = NULL, *ps = NULL;
  mo_linsolver_settings set = {ksp, pc, "mumps", "", 1e-13, 1, parts, 0, NULL};
  long nf = 0, ns = 0;
  const char *how = parts ? " (parts)" : "";
  if (parts) {
    P = part_of(A, ctx);
    P2 = part_of(A2, ctx);
  }
  for (k = 0; k < n * nrhs; k++) B[k] = sin(0.37 * k) + (k % 5 == 0);
  mo_linsolver_create(&mo_linsolver_cholmod, &chol, ctx);
  mo_linsolver_factor(chol, A, ctx);
  mo_linsolver_solve_multi(chol, nrhs, B, Y, ctx);
  ok(mo_linsolver_create(mo_linsolver_petsc(ctx), &ps, ctx) == MO_OK && mo_linsolver_configure(ps, &set, ctx) == MO_OK,
     "petsc %s/%s%s: created on %d rank(s)", ksp, pc, how, ctx->nranks);
  ok(agree_all(mo_linsolver_factor(ps, parts ? P : A, ctx) == MO_OK, ctx), "petsc %s/%s%s: factored (%s)", ksp, pc, how,
     ctx->errmsg);
  ok(agree_all(mo_linsolver_solve_multi(ps, nrhs, B, X, ctx) == MO_OK, ctx), "petsc %s/%s%s: solved", ksp, pc, how);
  {
    double e = rel(X, Y, (long)n * nrhs);
    ok(agree_all(e < tol, ctx), "petsc %s/%s%s: 3 solutions equal CHOLMOD's to %.1e (tol %.0e)", ksp, pc, how, e, tol);
  }
  /* new values on the same pattern: the symbolic analysis kept, the answer the new matrix's */
  mo_linsolver_factor(chol, A2, ctx);
  mo_linsolver_solve_multi(chol, 1, B, Y, ctx);
  {
    int done = agree_all(mo_linsolver_factor(ps, parts ? P2 : A2, ctx) == MO_OK && mo_linsolver_solve(ps, B, X, ctx) == MO_OK,
                         ctx);
    double e = rel(X, Y, n);
    ok(done && agree_all(e < tol, ctx), "petsc %s/%s%s: refactored with new values, solution equal to CHOLMOD's to %.1e",
       ksp, pc, how, e);
  }
  mo_linsolver_stats(ps, &nf, NULL, &ns);
  ok(nf == 2 && ns == 4, "petsc %s/%s%s: 2 factorizations, 4 right-hand sides counted (%ld, %ld)", ksp, pc, how, nf, ns);
  rows_checks(ps, chol, B, nrhs, tol, ctx);
  mo_linsolver_free(ps);
  mo_linsolver_free(chol);
  mo_csc_free(A);
  mo_csc_free(A2);
  mo_csc_free(P);
  mo_csc_free(P2);
  free(B);
  free(X);
  free(Y);
}

/* The largest entry of A - B over the largest of B (the sum of the two patterns: an entry
   one lacks counts as a zero of it), or 1 when A - B cannot be formed. */
static double mat_diff(const mo_csc *A, const mo_csc *B, mo_ctx *ctx)
{
  mo_csc *D = NULL;
  double d = 0, m = 0;
  int p;
  if (A->nrow != B->nrow || A->ncol != B->ncol || mo_csc_add(A, B, 1, -1, &D, ctx)) return 1;
  for (p = 0; p < mo_csc_nnz(D); p++)
    if (fabs(D->x[p]) > d) d = fabs(D->x[p]);
  for (p = 0; p < mo_csc_nnz(B); p++)
    if (fabs(B->x[p]) > m) m = fabs(B->x[p]);
  mo_csc_free(D);
  return m > 0 ? d / m : d;
}

/* The owned rows of a distributed matrix against the whole matrix A (symmetric: its column j
   is row j): the largest difference over the largest entry of A, the same on every rank. */
static double dmat_diff(mo_dmat *D, const mo_dist_assembly *a, const mo_csc *A, mo_ctx *ctx)
{
  int n = A->nrow, r, p, k, nz, rows = 0, cap = 4096, *cols = malloc(sizeof(int) * cap);
  double *row = calloc((size_t)n, sizeof *row), *vals = malloc(sizeof(double) * cap), d[2] = {0, 0};
  for (p = 0; p < mo_csc_nnz(A); p++)
    if (fabs(A->x[p]) > d[1]) d[1] = fabs(A->x[p]);
  for (r = 0; r < n; r++) {
    if (a->row[r] < a->rstart || a->row[r] >= a->rend) continue;
    rows++;
    if (mo_dmat_row(D, r, cap, &nz, cols, vals, ctx)) {
      d[0] = HUGE_VAL;
      break;
    }
    for (p = A->p[r]; p < A->p[r + 1]; p++) row[A->i[p]] = A->x[p];
    for (k = 0; k < nz; k++) row[cols[k]] -= vals[k];
    for (p = A->p[r]; p < A->p[r + 1]; p++) row[A->i[p]] = fabs(row[A->i[p]]) > d[0] ? (d[0] = fabs(row[A->i[p]]), 0) : 0;
    /* an entry outside A's pattern: its whole value is the difference */
    for (k = 0; k < nz; k++)
      if (row[cols[k]] != 0) {
        if (fabs(row[cols[k]]) > d[0]) d[0] = fabs(row[cols[k]]);
        row[cols[k]] = 0;
      }
  }
  if (rows != a->rend - a->rstart) d[0] = HUGE_VAL;
  mo_par_max(d, 1, ctx);
  free(cols);
  free(vals);
  free(row);
  return d[1] > 0 ? d[0] / d[1] : d[0];
}

/* K and M assembled straight into distributed matrices (each rank its elements, its rows:
   doc/parallel.md §3) against one process's K and M: the entries, the products, the rows' split. */
static void distributed_checks(mo_ctx *ctx, const char *name, const mo_scene *par, const mo_scene *one)
{
  mo_dist_assembly a;
  int n = one->ndof, k, r, nr = ctx->nranks, st;
  double dk = 1, dm = 0, dp = 1, rows[64], lo = 1e300, hi = 0, mean = (double)n / nr, ne[64], tot = 0;
  double *x = malloc(sizeof(double) * (n + 1)), *y = malloc(sizeof(double) * (n + 1)), *z = malloc(sizeof(double) * (n + 1));
  st = mo_scene_assemble_distributed(par, one->M != NULL, &a, ctx);
  ok(agree_all(!st, ctx), "%s: K and M assembled into distributed matrices on %d rank(s) (%s)", name, nr,
     st ? ctx->errmsg : "ok");
  if (st) goto done;
  dk = dmat_diff(a.K, &a, one->K, ctx);
  if (one->M) dm = dmat_diff(a.M, &a, one->M, ctx);
  ok(agree_all(dk <= 1e-12 && dm <= 1e-12, ctx),
     "%s: the distributed K and M equal one process's row by row to %.1e and %.1e of their largest entry", name, dk, dm);
  for (k = 0; k < n; k++) x[k] = sin(0.37 * k + 1) + (k % 3 == 0);
  mo_csc_gaxpy(one->K, 1, x, 0, z);
  if (!mo_dmat_mult(a.K, x, y, ctx)) dp = rel(y, z, n);
  if (one->M) {
    double e = 1;
    mo_csc_gaxpy(one->M, 1, x, 0, z);
    if (!mo_dmat_mult(a.M, x, y, ctx)) e = rel(y, z, n);
    if (e > dp) dp = e;
  }
  ok(agree_all(dp <= 1e-12, ctx), "%s: K x and M x on the distributed matrices equal one process's to %.1e", name, dp);
  {
    /* the preallocation counted from the connectivity: every entry preallocated is used */
    long nk, ak, sk, nm, am, sm;
    mo_dmat_counts(a.K, &nk, &ak, &sk);
    mo_dmat_counts(a.M, &nm, &am, &sm);
    ok(agree_all(nk == ak && nm == am && nk > 0, ctx),
       "%s: rank %d's rows preallocated exactly: K %ld of %ld entries, M %ld of %ld (sent %ld and %ld)", name,
       ctx->rank, nk, ak, nm, am, sk, sm);
  }
  /* the rows: every dof once, about n / nranks each; the elements nelem / nranks each */
  for (r = 0; r < nr && r < 64; r++) rows[r] = ne[r] = 0;
  rows[ctx->rank] = a.rend - a.rstart;
  ne[ctx->rank] = (double)a.elements;
  mo_par_sum(rows, nr, ctx);
  mo_par_sum(ne, nr, ctx);
  for (r = 0; r < nr; r++) {
    tot += rows[r];
    if (rows[r] < lo) lo = rows[r];
    if (rows[r] > hi) hi = rows[r];
  }
  ok(agree_all(tot == n && hi <= 1.25 * mean && lo >= 0.75 * mean, ctx),
     "%s: the rows split %.0f to %.0f of %d (limit 25 %% from %.0f each)", name, lo, hi, n, mean);
  ok(agree_all(nr == 1 ? a.local == 1 : a.local >= 0.75, ctx),
     "%s: %.1f %% of the element entries in the computing rank's own rows (%.0f and %.0f elements)", name,
     100 * a.local, ne[0], nr > 1 ? ne[1] : 0);
done:
  mo_dist_assembly_free(&a);
  free(x);
  free(y);
  free(z);
}

/* A case's scene built over the ranks (each its block of elements, then the sums) and by this
   process alone (ctx.nranks 1: no collective call), K and M compared. */
static void assembly_checks(mo_ctx *ctx, const char *name, const char *const *set)
{
  const char *src = getenv("MOREAU_SRCDIR");
  char path[4096];
  mo_case *cs = NULL;
  mo_scene *par = NULL, *one = NULL;
  int nr = ctx->nranks, st, r, b, k;
  double dk = 1, dm = 0, tot = 0, lo = 1e300, hi = 0, n = 0;
  snprintf(path, sizeof path, "%s/cases/%s", src ? src : ".", name);
  st = mo_case_load(path, &cs, ctx);
  for (k = 0; !st && set && set[k]; k++) st = mo_case_set(cs, set[k], ctx);
  if (!st) st = mo_case_validate(cs, ctx);
  if (!st) st = mo_scene_build(cs, &par, ctx);
  ctx->nranks = 1;
  if (!st) st = mo_scene_build(cs, &one, ctx);
  ctx->nranks = nr;
  ok(agree_all(!st, ctx), "%s: scenes built over %d rank(s) and by one process (%s)", name, nr, st ? ctx->errmsg : "ok");
  if (st) goto done;
  /* over ranks a linear scene keeps each rank's part of K and M (its elements' entries): their
     sums, gathered here, are the scene's matrices. The patterns may differ by the entries whose
     contributions cancel exactly (one process keeps them as zeros): compared by value */
  ok(agree_all(par->kpart == (nr > 1), ctx), "%s: K and M %s on %d rank(s)", name, par->kpart ? "in parts" : "whole", nr);
  {
    mo_csc *Ks = NULL, *Ms = NULL;
    long mine = mo_csc_nnz(par->K) + (par->M ? mo_csc_nnz(par->M) : 0), whole = mo_csc_nnz(one->K) + (one->M ? mo_csc_nnz(one->M) : 0);
    double big = (double)mine, sum = (double)mine;
    if (par->kpart) {
      st = mo_csc_sum_parts(par->K, NULL, &Ks, ctx);
      if (!st && par->M) st = mo_csc_sum_parts(par->M, NULL, &Ms, ctx);
    }
    if (!st) {
      dk = mat_diff(Ks ? Ks : par->K, one->K, ctx);
      if (one->M) dm = par->M ? mat_diff(Ms ? Ms : par->M, one->M, ctx) : 1;
    }
    ok(agree_all(!st && dk <= 1e-12 && dm <= 1e-12, ctx),
       "%s: K and M assembled by the ranks (summed) equal one process's to %.1e and %.1e of their largest entry "
       "(%d and %d entries, %d and %d)", name, dk, dm, Ks ? mo_csc_nnz(Ks) : mo_csc_nnz(par->K),
       Ms ? mo_csc_nnz(Ms) : par->M ? mo_csc_nnz(par->M) : 0, mo_csc_nnz(one->K), one->M ? mo_csc_nnz(one->M) : 0);
    /* no rank holds K and M whole: the largest part holds 60 % of the entries at most, and the
       parts all of them (the interfaces' entries twice) */
    mo_par_max(&big, 1, ctx);
    mo_par_sum(&sum, 1, ctx);
    if (nr > 1)
      ok(big <= 0.6 * (double)whole && sum >= (double)whole,
         "%s: the largest rank's part of K and M holds %.0f of their %ld entries (%.1f %%), the parts %.0f", name, big, whole,
         100 * big / (double)whole, sum);
    /* a product summed over the ranks (mo_scene_gaxpy) and (T103a)'s bound, against one process */
    {
      int nd = one->ndof, i;
      double *x = calloc((size_t)nd + 1, sizeof *x), *y1 = calloc((size_t)nd + 1, sizeof *y1),
             *y2 = calloc((size_t)nd + 1, sizeof *y2), e = 0, ymax = 0, b1 = mo_scene_dt_bound(one), b2 = mo_scene_dt_bound(par);
      for (i = 0; i < nd; i++) x[i] = y1[i] = y2[i] = sin(0.37 * i + 0.1);
      mo_csc_gaxpy(one->K, 2, x, 0.5, y1);
      mo_scene_gaxpy(par, par->K, 2, x, 0.5, y2);
      for (i = 0; i < nd; i++) {
        if (fabs(y1[i] - y2[i]) > e) e = fabs(y1[i] - y2[i]);
        if (fabs(y1[i]) > ymax) ymax = fabs(y1[i]);
      }
      ok(agree_all(e <= 1e-13 * ymax, ctx), "%s: 2 K x + y / 2 summed over the ranks equals one process's to %.1e of its largest value", name,
         ymax > 0 ? e / ymax : e);
      ok(agree_all((isnan(b1) && isnan(b2)) || fabs(b1 - b2) <= 1e-13 * fabs(b1), ctx),
         "%s: the stable step's bound (T103a) over the ranks %.10g, one process %.10g", name, b2, b1);
      free(x);
      free(y1);
      free(y2);
    }
    mo_csc_free(Ks);
    mo_csc_free(Ms);
  }
  for (b = 0; b < one->nbody; b++)
    if (one->body[b].kind == MO_BODY_DEFORMABLE) n += one->body[b].mesh->nelem;
  distributed_checks(ctx, name, par, one);
  if (nr == 1) {
    ok(par->asm_elems && par->asm_elems[0] == n, "%s: one process: all %.0f elements assembled by it", name, n);
    goto done;
  }
  for (r = 0; par->asm_elems && r < nr; r++) {
    tot += par->asm_elems[r];
    if (par->asm_elems[r] < lo) lo = par->asm_elems[r];
    if (par->asm_elems[r] > hi) hi = par->asm_elems[r];
  }
  ok(par->asm_elems && tot == n && hi - lo <= 1 && lo >= 1,
     "%s: the ranks computed %.0f to %.0f of the %.0f elements, %.0f in all", name, lo, hi, n, tot);
done:
  mo_scene_free(par);
  mo_scene_free(one);
  mo_case_free(cs);
  mo_ctx_clear_error(ctx);
}

/* The detection's boxes (T215)-(T216), (T330), (T341) against a brute-force enumeration: random
   balls (radii of ratio 3, a pile's density, some stacked at one abscissa) in a box 4 long (`cube`
   0) or a cube, for 1-8 ranks, the boxes cut from the bodies' centres (`onpts` 0) or from the
   points of the pairs within reach (1, as the last solve's contacts): every pair within reach
   (all n (n - 1) / 2 tested) found by the broad phase of the rank whose box holds its point, on
   that rank's box and halo, and the ranks' owned pairs together every pair exactly once; every
   rank's boxes the same; the parts of equal counts of what they were cut from; in the cube, boxes
   and not slabs. */
static void box_checks(int dim, int n, int nranks, int cube, int onpts, unsigned seed, mo_ctx *ctx)
{
  double *c = malloc((size_t)dim * n * sizeof *c), *r = malloc((size_t)n * sizeof *r), reach = 0.05;
  double *pts = malloc((size_t)dim * n * n / 2 * sizeof *pts + 1);
  int *owner = malloc((size_t)n * sizeof *owner), *own0 = malloc((size_t)n * sizeof *own0);
  int *idx = malloc(((size_t)n * n / 2 + n) * sizeof *idx), *ppart = malloc(((size_t)n * n / 2 + n) * sizeof *ppart);
  int *seen = calloc((size_t)n * n, sizeof *seen);
  unsigned char *rmask = malloc((size_t)n), *mask = malloc((size_t)n);
  long near = 0, twice = 0, missed = 0, far = 0, found = 0, maxmine = 0, q, np, npts = 0;
  int i, j, k, rank, same = 1, bad_owner = 0;
  mo_rcb_tree T, T0;
  mo_broad *B = NULL;
  const int *pairs;
  const char *from = onpts ? "pair points" : "centres";
  srand(seed);
  for (i = 0; i < n; i++) {
    for (k = 0; k < dim; k++) c[(size_t)dim * i + k] = (double)rand() / RAND_MAX * (k == 0 && !cube ? 4.0 : 1.0);
    if (i % 17 == 0) c[(size_t)dim * i] = cube ? 0.5 : 2.0; /* ties on the first cut's axis */
    r[i] = 0.02 + 0.04 * (double)rand() / RAND_MAX;
    mask[i] = i % 23 != 5; /* some bodies out of the broad phase */
  }
  for (i = 0; i < n && onpts; i++)
    for (j = i + 1; j < n; j++) {
      double d2 = 0;
      for (k = 0; k < dim; k++) d2 += (c[(size_t)dim * j + k] - c[(size_t)dim * i + k]) * (c[(size_t)dim * j + k] - c[(size_t)dim * i + k]);
      if (mask[i] && mask[j] && sqrt(d2) - r[i] - r[j] <= reach) mo_pdetect_point(dim, c, r, i, j, pts + (size_t)dim * npts++);
    }
  mo_broad_create(&B, ctx);
  memset(&T0, 0, sizeof T0);
  for (rank = 0; rank < nranks; rank++) {
    long mine = 0;
    memset(&T, 0, sizeof T);
    mo_pdetect_boxes(dim, n, c, r, mask, reach, npts, pts, nranks, rank, &T, owner, rmask, idx, ppart);
    if (rank == 0) T0 = T;
    else same &= !memcmp(&T, &T0, sizeof T);
    for (i = 0; i < n; i++) {
      if (rank == 0) own0[i] = owner[i];
      else same &= own0[i] == owner[i];
      bad_owner += mask[i] ? owner[i] < 0 || owner[i] >= nranks : owner[i] != -1 || rmask[i];
    }
    if (mo_broad_pairs(B, dim, n, c, r, rmask, reach, &pairs, &np, ctx)) break;
    for (q = 0; q < np; q++) {
      double p[3];
      mo_pdetect_point(dim, c, r, pairs[2 * q], pairs[2 * q + 1], p);
      if (mo_rcb_locate(&T, p) == rank) {
        seen[(size_t)pairs[2 * q] * n + pairs[2 * q + 1]]++;
        mine++;
      }
    }
    if (mine > maxmine) maxmine = mine;
  }
  for (i = 0; i < n; i++)
    for (j = i + 1; j < n; j++) {
      double d2 = 0;
      int in;
      for (k = 0; k < dim; k++) d2 += (c[(size_t)dim * j + k] - c[(size_t)dim * i + k]) * (c[(size_t)dim * j + k] - c[(size_t)dim * i + k]);
      in = mask[i] && mask[j] && sqrt(d2) - r[i] - r[j] <= reach;
      near += in;
      found += seen[(size_t)i * n + j];
      if (in && seen[(size_t)i * n + j] == 0) missed++;
      if (seen[(size_t)i * n + j] > 1) twice++;
      if (!in && seen[(size_t)i * n + j]) far++;
    }
  ok(rank == nranks && same && !bad_owner && near > 0 && found == near && !missed && !twice && !far,
     "detection boxes from %s, %dD %s, %d balls, %d rank(s): each of the %ld pairs within reach found by exactly "
     "one rank, its point's (missed %ld, twice %ld, out of reach %ld), the same boxes on every rank, the largest "
     "rank %ld pairs", from, dim, cube ? "cube" : "bar", n, nranks, near, missed, twice, far, maxmine);
  {
    /* the parts' balance: equal counts of what was cut (bodies, or the pairs' points), but for the
       bins' granularity (a bin of 1/4096 of the extent whole on one side, at most 3 cuts deep) and
       the bin holding the tied abscissa (one body in 17) */
    long cnt[8] = {0}, m = 0, most = 0;
    double lo[8][3], hi[8][3], wide = 0;
    for (k = 0; k < nranks; k++)
      for (j = 0; j < 3; j++) {
        lo[k][j] = HUGE_VAL;
        hi[k][j] = -HUGE_VAL;
      }
    for (i = 0; i < n; i++)
      if (mask[i]) {
        if (!onpts) {
          cnt[own0[i]]++;
          m++;
        }
        for (j = 0; j < dim; j++) {
          lo[own0[i]][j] = fmin(lo[own0[i]][j], c[(size_t)dim * i + j]);
          hi[own0[i]][j] = fmax(hi[own0[i]][j], c[(size_t)dim * i + j]);
        }
      }
    for (q = 0; q < npts; q++) {
      cnt[mo_rcb_locate(&T0, pts + (size_t)dim * q)]++;
      m++;
    }
    for (k = 0; k < nranks; k++) {
      most = cnt[k] > most ? cnt[k] : most;
      for (j = 0; j < dim; j++) wide = fmax(wide, hi[k][j] - lo[k][j]);
    }
    ok(most <= m / nranks + m / 17 + 6, "detection boxes from %s, %dD %s, %d rank(s): the largest part %ld of %ld %s",
       from, dim, cube ? "cube" : "bar", nranks, most, m, onpts ? "points" : "bodies");
    /* in the unit cube, 2^dim ranks take boxes of side 1/2 (slabs would be 1 wide) */
    if (cube && nranks == (dim == 2 ? 4 : 8))
      ok(wide < 0.6, "detection boxes from %s, %dD cube, %d ranks: boxes, the widest side of a part's centres %.3f",
         from, dim, nranks, wide);
  }
  mo_broad_free(B);
  free(c);
  free(r);
  free(pts);
  free(owner);
  free(own0);
  free(idx);
  free(ppart);
  free(seen);
  free(rmask);
  free(mask);
}

/* The cuts kept (T341): point sets with most points tied at one end of an axis (the cut then falls
   after the last bin, every point below it), and probes within and beyond the points' range on
   every axis: each probe's part (mo_rcb_locate) is the part of the points it coincides with, and
   lies in that part's box (mo_rcb_box); a part no point reaches has an empty box. */
static void rcb_edge_checks(void)
{
  double x[3 * 200], p[3];
  int part[200], idx[200], d, q, np, k, i, bad = 0, probes = 0, same = 0, fell = 0;
  mo_rcb_tree T;
  for (d = 2; d <= 3; d++)
    for (np = 2; np <= 8; np++)
      for (k = 0; k < 3; k++) { /* ties at the high end, the low end, none */
        srand(7u * (unsigned)(d * 100 + np * 10 + k));
        for (i = 0; i < 200; i++)
          for (q = 0; q < d; q++) {
            double v = (double)rand() / RAND_MAX;
            if (q == 0 && k == 0 && i >= 20) v = 1.0;
            if (q == 0 && k == 1 && i >= 20) v = 0.0;
            x[d * i + q] = q == 1 ? 0.2 * v : v; /* the first axis the longest */
          }
        mo_rcb_tree_make(d, 200, x, NULL, NULL, np, part, idx, &T);
        for (i = 0; i < T.nparts - 1; i++) fell += T.node[i].bcut >= MO_RCB_BINS;
        for (i = 0; i < 200; i++) same += mo_rcb_locate(&T, x + d * i) == part[i];
        for (i = 0; i < 2000; i++) {
          double lo[3], hi[3];
          int r, in = 1;
          for (q = 0; q < d; q++) p[q] = -2.0 + 5.0 * (double)rand() / RAND_MAX;
          r = mo_rcb_locate(&T, p);
          mo_rcb_box(&T, r, lo, hi);
          for (q = 0; q < d; q++) in &= p[q] >= lo[q] - 1e-12 && p[q] <= hi[q] + 1e-12;
          bad += !in || r < 0 || r >= np;
          probes++;
        }
      }
  ok(same == 2 * 7 * 3 * 200 && !bad && fell > 0,
     "kept cuts: every point cut located in its part (%d of %d), %d probes within and beyond the points each in its "
     "part's box (%d outside), %d cuts after the last bin among them", same, 2 * 7 * 3 * 200, probes, bad, fell);
}

/* The boxes for 1-8 ranks: bars and cubes in 2D and 3D, cut from the centres and from pairs' points. */
static void all_box_checks(mo_ctx *ctx)
{
  int p;
  rcb_edge_checks();
  for (p = 1; p <= 8; p++) {
    box_checks(2, 700, p, 0, 0, 11u + p, ctx);
    box_checks(3, 500, p, 0, 0, 29u + p, ctx);
    box_checks(2, 700, p, 1, 0, 41u + p, ctx);
    box_checks(3, 500, p, 1, 0, 53u + p, ctx);
    box_checks(2, 700, p, 0, 1, 67u + p, ctx);
    box_checks(3, 500, p, 1, 1, 71u + p, ctx);
  }
}

/* (T347) The boxes' tree cut from each rank's own points equals the tree of all the points
   gathered (mo_rcb_tree_make), node by node: random points, ties on an abscissa, a rank without
   points, and no point anywhere. */
static void tree_dist_checks(mo_ctx *ctx)
{
  static const int parts[] = {2, 3, 4, 5, 7, 8, 13};
  const int n = 3000;
  double *all = malloc(3 * (size_t)n * sizeof *all), *mine = malloc(3 * (size_t)n * sizeof *mine);
  int *idx = malloc((size_t)n * sizeof *idx), *part = malloc((size_t)n * sizeof *part);
  int dim, p, c, i, k, bad = 0, runs = 0;
  for (c = 0; c < 3; c++)
    for (dim = 2; dim <= 3; dim++)
      for (p = 0; p < (int)(sizeof parts / sizeof *parts); p++) {
        mo_rcb_tree T0, T1;
        long m = 0, na = c == 2 ? 0 : n;
        srand(1000u + 7u * (unsigned)c + 3u * (unsigned)dim);
        for (i = 0; i < na; i++)
          for (k = 0; k < dim; k++) {
            all[(size_t)dim * i + k] = (double)rand() / RAND_MAX * (k == 0 ? 3.0 : 1.0);
            if (i % 11 == 0 && k == 0) all[(size_t)dim * i] = 1.5; /* ties */
          }
        /* c = 0: the points dealt round the ranks; c = 1: all on the last rank; c = 2: none */
        for (i = 0; i < na; i++)
          if (c == 0 ? i % ctx->nranks == ctx->rank : ctx->rank == ctx->nranks - 1)
            memcpy(mine + (size_t)dim * m++, all + (size_t)dim * i, (size_t)dim * sizeof *all);
        memset(&T0, 0, sizeof T0);
        memset(&T1, 0, sizeof T1);
        mo_rcb_tree_make(dim, (int)na, all, NULL, NULL, parts[p], part, idx, &T0);
        if (mo_pdetect_tree_dist(dim, m, mine, parts[p], &T1, ctx) != MO_OK) bad++;
        bad += T0.nparts != T1.nparts || memcmp(T0.node, T1.node, (size_t)(parts[p] - 1) * sizeof *T0.node) != 0;
        runs++;
      }
  ok(agree_all(!bad, ctx), "detection boxes cut from each rank's own points (T347): %d trees equal the gathered points' "
     "node by node on %d rank(s) (%d differ)", runs, ctx->nranks, bad);
  free(all);
  free(mine);
  free(idx);
  free(part);
}

int main(int argc, char **argv)
{
  mo_ctx ctx;
  mo_ctx_init(&ctx);
  if (!mo_parallel_available()) {
    /* the detection's boxes are plain arithmetic: checked in every build */
    all_box_checks(&ctx);
    tree_dist_checks(&ctx);
    printf("# the rest skipped: this build has no PETSc (configure --with-petsc)\n");
    return done_testing();
  }
  if (mo_parallel_start(&argc, &argv, &ctx)) {
    printf("1..1\nnot ok 1 - MPI starts: %s\n", ctx.errmsg);
    return 1;
  }
  /* rank 0 speaks for all: each check above is agreed over the ranks */
  if (ctx.rank != 0 && !freopen("/dev/null", "w", stdout)) return 1;
  {
    double x[2] = {1.0 + ctx.rank, -(double)ctx.rank};
    int n[64], r;
    double all[64];
    mo_par_sum(x, 2, &ctx);
    ok(x[0] == ctx.nranks + ctx.nranks * (ctx.nranks - 1) / 2.0 && x[1] == -ctx.nranks * (ctx.nranks - 1) / 2.0,
       "sum over %d rank(s)", ctx.nranks);
    for (r = 0; r < ctx.nranks && r < 64; r++) n[r] = 1;
    x[0] = 10.0 * ctx.rank;
    mo_par_gatherv(x, n, all, &ctx);
    for (r = 0; r < ctx.nranks && r < 64; r++)
      if (all[r] != 10.0 * r) break;
    ok(r == ctx.nranks, "gather of one value per rank in rank order");
    ok(mo_par_agree(ctx.rank == ctx.nranks - 1 ? MO_EIO : MO_OK, &ctx) == MO_EIO &&
           (ctx.nranks == 1 || ctx.rank == ctx.nranks - 1 || strstr(ctx.errmsg, "rank")),
       "a status of one rank reaches every rank (%s)", ctx.errmsg);
    mo_ctx_clear_error(&ctx);
  }
  all_box_checks(&ctx);
  tree_dist_checks(&ctx);
  solver_checks(&ctx, "preonly", "cholesky", 1e-12, 0);
  solver_checks(&ctx, "preonly", "lu", 1e-12, 0);
  solver_checks(&ctx, "cg", "jacobi", 1e-9, 0);
  solver_checks(&ctx, "preonly", "cholesky", 1e-12, 1);
  solver_checks(&ctx, "cg", "jacobi", 1e-9, 1);
  {
    static const char *const box[] = {"bodies.box.mesh.elements=[7,6,5]", NULL};
    /* the box with a lumped mass (its diagonal only) */
    static const char *const lumped[] = {"bodies.box.mesh.elements=[7,6,5]", "bodies.box.mass=\"lumped\"",
                                         "time={scheme=\"theta\";dt=1e-4;steps=1;}", NULL};
    assembly_checks(&ctx, "rods-3d", NULL);
    assembly_checks(&ctx, "box-on-plane", box);
    assembly_checks(&ctx, "box-on-plane", lumped);
  }
  printf("1..%d\n", tap_n);
  mo_parallel_finish(&ctx);
  return tap_failed != 0;
}
