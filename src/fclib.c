/* fclib.c: FCLIB local problems (U = W r + q, mu) written and read through Debian's libfclib. */
#include "config.h"
#include <moreau/contact.h>

#include <stdio.h>
#include <string.h>
#include <unistd.h>

#ifdef HAVE_FCLIB
#include <fclib.h>

int mo_fclib_available(void) { return 1; }

int mo_fclib_write(const char *path, int d, int nc, const double *W, const double *q,
                   const double *mu, const double *r, const double *U, const char *title,
                   mo_ctx *ctx)
{
  struct fclib_local pb;
  struct fclib_matrix M;
  struct fclib_info info;
  struct fclib_solution sol;
  char tmp[4200];
  int m = d * nc, i, j, nnz = 0, *p = NULL, *ii = NULL, st = MO_OK;
  double *x = NULL;
  if (d != 2 && d != 3)
    return mo_error(ctx, MO_EUNSUPPORTED, "FCLIB holds 2D and 3D frictional problems (local dimension %d)", d);
  for (j = 0; j < m * m; j++) nnz += W[j] != 0;
  p = mo_malloc(ctx, ((size_t)m + 1) * sizeof(int));
  ii = mo_malloc(ctx, ((size_t)nnz + 1) * sizeof(int));
  x = mo_malloc(ctx, ((size_t)nnz + 1) * sizeof(double));
  if (!p || !ii || !x) { st = MO_ENOMEM; goto done; }
  nnz = 0;
  for (j = 0; j < m; j++) { /* compressed columns of the row-major dense W */
    p[j] = nnz;
    for (i = 0; i < m; i++)
      if (W[(size_t)i * m + j] != 0) { ii[nnz] = i; x[nnz++] = W[(size_t)i * m + j]; }
  }
  p[m] = nnz;
  memset(&M, 0, sizeof M);
  M.nzmax = nnz;
  M.m = M.n = m;
  M.p = p;
  M.i = ii;
  M.x = x;
  M.nz = -1;
  memset(&info, 0, sizeof info);
  info.title = (char *)(title ? title : "moreau local problem");
  info.description = (char *)"U = W r + q with Coulomb friction; written by moreau";
  info.math_info = (char *)"W = H^T What^-1 H symmetric positive semi-definite";
  memset(&pb, 0, sizeof pb);
  pb.W = &M;
  pb.mu = (double *)mu;
  pb.q = (double *)q;
  pb.spacedim = d;
  pb.info = &info;
  if (snprintf(tmp, sizeof tmp, "%s.tmp.%ld", path, (long)getpid()) >= (int)sizeof tmp) {
    st = mo_error(ctx, MO_EIO, "path too long: %s", path);
    goto done;
  }
  remove(tmp);
  if (!fclib_write_local(&pb, tmp)) {
    st = mo_error(ctx, MO_EIO, "%s: libfclib could not write the local problem", path);
    goto done;
  }
  if (r && U) {
    memset(&sol, 0, sizeof sol);
    sol.r = (double *)r;
    sol.u = (double *)U;
    if (!fclib_write_solution(&sol, tmp)) {
      st = mo_error(ctx, MO_EIO, "%s: libfclib could not write the solution", path);
      goto done;
    }
  }
  if (rename(tmp, path) != 0) st = mo_error(ctx, MO_EIO, "cannot replace '%s'", path);
done:
  if (st) remove(tmp);
  mo_free(p);
  mo_free(ii);
  mo_free(x);
  return st;
}

int mo_fclib_read(const char *path, int *d, int *nc, mo_csc **Wout, double **q, double **mu,
                  mo_ctx *ctx)
{
  struct fclib_local *pb;
  struct fclib_matrix *M;
  mo_triplet T;
  int m, st = MO_OK, k, j;
  FILE *f = fopen(path, "rb");
  *Wout = NULL;
  *q = *mu = NULL;
  if (!f) return mo_error(ctx, MO_EIO, "%s: cannot open", path);
  fclose(f);
  pb = fclib_read_local(path);
  if (!pb || !pb->W) {
    if (pb) fclib_delete_local(pb);
    return mo_error(ctx, MO_EINPUT, "%s: not an FCLIB local problem (libfclib could not read it)", path);
  }
  M = pb->W;
  m = M->m;
  *d = pb->spacedim;
  if ((*d != 2 && *d != 3) || M->n != m || m % *d) {
    fclib_delete_local(pb);
    return mo_error(ctx, MO_EINPUT, "%s: W is %d x %d with local dimension %d", path, M->m, M->n, *d);
  }
  if (pb->V || pb->R)
    mo_log(ctx, 1, "%s: the equality constraints (V, R) of this mixed problem are ignored\n", path);
  *nc = m / *d;
  if ((st = mo_triplet_init(&T, m, m, (size_t)(M->nz >= 0 ? M->nz : M->nzmax) + 1, ctx))) goto done;
  if (M->nz >= 0) /* triplets: p rows, i columns */
    for (k = 0; k < M->nz && !st; k++) st = mo_triplet_add(&T, M->p[k], M->i[k], M->x[k], ctx);
  else if (M->nz == -1) /* compressed columns */
    for (j = 0; j < M->n && !st; j++)
      for (k = M->p[j]; k < M->p[j + 1] && !st; k++) st = mo_triplet_add(&T, M->i[k], j, M->x[k], ctx);
  else /* compressed rows */
    for (j = 0; j < M->m && !st; j++)
      for (k = M->p[j]; k < M->p[j + 1] && !st; k++) st = mo_triplet_add(&T, j, M->i[k], M->x[k], ctx);
  if (!st) st = mo_triplet_to_csc(&T, 0, Wout, ctx);
  mo_triplet_release(&T);
  if (st) goto done;
  *q = mo_malloc(ctx, (size_t)m * sizeof(double));
  *mu = mo_malloc(ctx, (size_t)*nc * sizeof(double));
  if (!*q || !*mu) { st = MO_ENOMEM; goto done; }
  memcpy(*q, pb->q, (size_t)m * sizeof(double));
  memcpy(*mu, pb->mu, (size_t)*nc * sizeof(double));
done:
  fclib_delete_local(pb);
  if (st) {
    mo_csc_free(*Wout);
    mo_free(*q);
    mo_free(*mu);
    *Wout = NULL;
    *q = *mu = NULL;
  }
  return st;
}

#else

int mo_fclib_available(void) { return 0; }

int mo_fclib_write(const char *path, int d, int nc, const double *W, const double *q,
                   const double *mu, const double *r, const double *U, const char *title,
                   mo_ctx *ctx)
{
  (void)d; (void)nc; (void)W; (void)q; (void)mu; (void)r; (void)U; (void)title;
  return mo_error(ctx, MO_EUNSUPPORTED, "%s: this build has no FCLIB support (configure found no "
                  "libfclib; on Debian: apt-get install libfclib-dev libhdf5-dev)", path);
}

int mo_fclib_read(const char *path, int *d, int *nc, mo_csc **W, double **q, double **mu,
                  mo_ctx *ctx)
{
  (void)d; (void)nc; (void)W; (void)q; (void)mu;
  return mo_error(ctx, MO_EUNSUPPORTED, "%s: this build has no FCLIB support (configure found no "
                  "libfclib; on Debian: apt-get install libfclib-dev libhdf5-dev)", path);
}

#endif
