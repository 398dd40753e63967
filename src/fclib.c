/* fclib.c: FCLIB local problems (U = W r + q, mu) written and read through Debian's libfclib. */
#include "config.h"
#include <moreau/contact.h>

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#ifdef HAVE_FCLIB
#include <fclib.h>
#include <hdf5.h>

/* 1: an fclib_local group, 2: fclib_global, 0: neither (checked with HDF5 directly, so that
   libfclib does not print errors for the group a file lacks). */
static int mo_fclib_kind(const char *path)
{
  hid_t file;
  int kind = 0;
  H5E_auto2_t fn;
  void *data;
  H5Eget_auto2(H5E_DEFAULT, &fn, &data);
  H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
  file = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
  if (file >= 0) {
    if (H5Lexists(file, "/fclib_local", H5P_DEFAULT) > 0) kind = 1;
    else if (H5Lexists(file, "/fclib_global", H5P_DEFAULT) > 0) kind = 2;
    H5Fclose(file);
  }
  H5Eset_auto2(H5E_DEFAULT, fn, data);
  return kind;
}

int mo_fclib_available(void) { return 1; }

/* Write the local problem with W compressed by columns (p, i, x: m + 1, nnz, nnz) and its
   solution (r, U) when r is not NULL, atomically (a temporary file renamed). */
static int write_local(const char *path, int d, int nc, int *p, int *ii, double *x, const double *q,
                       const double *mu, const double *r, const double *U, const char *title,
                       const char *description, const char *math_info, mo_ctx *ctx)
{
  struct fclib_local pb;
  struct fclib_matrix M;
  struct fclib_info info;
  struct fclib_solution sol;
  char tmp[4200];
  int m = d * nc, st = MO_OK;
  if (d != 2 && d != 3)
    return mo_error(ctx, MO_EUNSUPPORTED, "FCLIB holds 2D and 3D frictional problems (local dimension %d)", d);
  memset(&M, 0, sizeof M);
  M.nzmax = p[m];
  M.m = M.n = m;
  M.p = p;
  M.i = ii;
  M.x = x;
  M.nz = -1;
  memset(&info, 0, sizeof info);
  info.title = (char *)(title ? title : "moreau local problem");
  info.description = (char *)(description ? description : "U = W r + q with Coulomb friction; written by moreau");
  info.math_info = (char *)(math_info ? math_info : "W = H^T What^-1 H symmetric positive semi-definite");
  memset(&pb, 0, sizeof pb);
  pb.W = &M;
  pb.mu = (double *)mu;
  pb.q = (double *)q;
  pb.spacedim = d;
  pb.info = &info;
  if (snprintf(tmp, sizeof tmp, "%s.tmp.%ld", path, (long)getpid()) >= (int)sizeof tmp)
    return mo_error(ctx, MO_EIO, "path too long: %s", path);
  remove(tmp);
  if (!fclib_write_local(&pb, tmp)) {
    st = mo_error(ctx, MO_EOUTPUT, "%s: libfclib could not write the local problem", path);
    goto done;
  }
  if (r && U) {
    memset(&sol, 0, sizeof sol);
    sol.r = (double *)r;
    sol.u = (double *)U;
    if (!fclib_write_solution(&sol, tmp)) {
      st = mo_error(ctx, MO_EOUTPUT, "%s: libfclib could not write the solution", path);
      goto done;
    }
  }
  if (rename(tmp, path) != 0) st = mo_error(ctx, MO_EOUTPUT, "cannot replace '%s'", path);
done:
  if (st) remove(tmp);
  return st;
}

int mo_fclib_write(const char *path, int d, int nc, const double *W, const double *q,
                   const double *mu, const double *r, const double *U, const char *title,
                   mo_ctx *ctx)
{
  int m = d * nc, i, j, nnz = 0, *p = NULL, *ii = NULL, st;
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
  st = write_local(path, d, nc, p, ii, x, q, mu, r, U, title, NULL, NULL, ctx);
done:
  mo_free(p);
  mo_free(ii);
  mo_free(x);
  return st;
}

int mo_fclib_write_csc(const char *path, int d, int nc, const mo_csc *W, const double *q,
                       const double *mu, const double *r, const double *U, const char *title,
                       const char *description, const char *math_info, mo_ctx *ctx)
{
  if (W->nrow != d * nc || W->ncol != d * nc)
    return mo_error(ctx, MO_EINPUT, "%s: W is %d x %d for %d contacts of dimension %d", path, W->nrow, W->ncol, nc, d);
  return write_local(path, d, nc, W->p, W->i, W->x, q, mu, r, U, title, description, math_info, ctx);
}

/* An fclib_matrix (triplets, compressed columns or rows) as CSC. */
/* A matrix of a file, checked before it is read: sizes, pointers and indices in range, values
   finite (a corrupt file names itself and what is wrong, never an out-of-range read). */
static int fclib_check_matrix(const char *path, const char *what, const struct fclib_matrix *M, mo_ctx *ctx)
{
  long k, j, np;
  if (!M) return mo_error(ctx, MO_EINPUT, "%s: the matrix %s is missing", path, what);
  if (M->m < 0 || M->n < 0 || M->nzmax < 0 || M->nz < -2)
    return mo_error(ctx, MO_EINPUT, "%s: the matrix %s has sizes %d x %d, nzmax %d, nz %d", path, what, M->m, M->n,
                    M->nzmax, M->nz);
  if (M->nz >= 0) {
    if (M->nz > M->nzmax) return mo_error(ctx, MO_EINPUT, "%s: the matrix %s holds nz = %d > nzmax = %d", path, what, M->nz, M->nzmax);
    for (k = 0; k < M->nz; k++) {
      if (M->i[k] < 0 || M->i[k] >= M->m || M->p[k] < 0 || M->p[k] >= M->n)
        return mo_error(ctx, MO_EINPUT, "%s: the matrix %s: entry %ld at (%d, %d), outside %d x %d", path, what, k,
                        M->i[k], M->p[k], M->m, M->n);
      if (!isfinite(M->x[k]))
        return mo_error(ctx, MO_EINPUT, "%s: the matrix %s: entry %ld is not finite (%g)", path, what, k, M->x[k]);
    }
    return MO_OK;
  }
  np = M->nz == -1 ? M->n : M->m;
  if (M->p[0] != 0) return mo_error(ctx, MO_EINPUT, "%s: the matrix %s: its first pointer is %d, not 0", path, what, M->p[0]);
  for (j = 0; j < np; j++)
    if (M->p[j + 1] < M->p[j] || M->p[j + 1] > M->nzmax)
      return mo_error(ctx, MO_EINPUT, "%s: the matrix %s: corrupt %s pointers (p[%ld] = %d after p[%ld] = %d, nzmax %d)",
                      path, what, M->nz == -1 ? "column" : "row", j + 1, M->p[j + 1], j, M->p[j], M->nzmax);
  for (k = 0; k < M->p[np]; k++) {
    if (M->i[k] < 0 || M->i[k] >= (M->nz == -1 ? M->m : M->n))
      return mo_error(ctx, MO_EINPUT, "%s: the matrix %s: index %d of entry %ld is out of range", path, what, M->i[k], k);
    if (!isfinite(M->x[k]))
      return mo_error(ctx, MO_EINPUT, "%s: the matrix %s: entry %ld is not finite (%g)", path, what, k, M->x[k]);
  }
  return MO_OK;
}

/* A vector of a file: finite values, and for friction coefficients non-negative ones. */
static int fclib_check_vector(const char *path, const char *what, const double *v, long n, int nonneg, mo_ctx *ctx)
{
  long k;
  if (!v && n > 0) return mo_error(ctx, MO_EINPUT, "%s: the vector %s is missing", path, what);
  for (k = 0; k < n; k++) {
    if (!isfinite(v[k])) return mo_error(ctx, MO_EINPUT, "%s: %s[%ld] is not finite (%g)", path, what, k, v[k]);
    if (nonneg && v[k] < 0)
      return mo_error(ctx, MO_EINPUT, "%s: %s[%ld] = %g: a friction coefficient is not negative", path, what, k, v[k]);
  }
  return MO_OK;
}

/* libfclib and HDF5 print their complaints on stderr: they are kept aside during a call and
   printed after it with the file's name. */
typedef struct {
  int saved;
  FILE *tmp;
} err_capture;

static void capture_begin(err_capture *c)
{
  fflush(stderr);
  c->saved = -1;
  c->tmp = tmpfile();
  if (!c->tmp) return;
  c->saved = dup(2);
  if (c->saved < 0 || dup2(fileno(c->tmp), 2) < 0) {
    if (c->saved >= 0) close(c->saved);
    c->saved = -1;
    fclose(c->tmp);
    c->tmp = NULL;
  }
}

static void capture_end(err_capture *c, const char *path)
{
  char line[1024];
  if (!c->tmp) return;
  fflush(stderr);
  dup2(c->saved, 2);
  close(c->saved);
  rewind(c->tmp);
  while (fgets(line, sizeof line, c->tmp)) fprintf(stderr, "%s: libfclib: %s", path, line);
  fclose(c->tmp);
  c->tmp = NULL;
}

static int fclib_to_csc(const struct fclib_matrix *M, mo_csc **out, mo_ctx *ctx)
{
  mo_triplet T;
  int st, k, j;
  if ((st = mo_triplet_init(&T, M->m, M->n, (size_t)(M->nz >= 0 ? M->nz : M->nzmax) + 1, ctx))) return st;
  if (M->nz >= 0) /* triplets, CSparse's convention: i rows, p columns */
    for (k = 0; k < M->nz && !st; k++) st = mo_triplet_add(&T, M->i[k], M->p[k], M->x[k], ctx);
  else if (M->nz == -1) /* compressed columns */
    for (j = 0; j < M->n && !st; j++)
      for (k = M->p[j]; k < M->p[j + 1] && !st; k++) st = mo_triplet_add(&T, M->i[k], j, M->x[k], ctx);
  else /* compressed rows */
    for (j = 0; j < M->m && !st; j++)
      for (k = M->p[j]; k < M->p[j + 1] && !st; k++) st = mo_triplet_add(&T, j, M->i[k], M->x[k], ctx);
  if (!st) st = mo_triplet_to_csc(&T, 0, out, ctx);
  mo_triplet_release(&T);
  return st;
}

/* A global problem M v = H r + f, U = H^T v + w reduced to its local problem:
   W = H^T M^-1 H, q = H^T M^-1 f + w (M factored by CHOLMOD). */
static int reduce_global(const char *path, struct fclib_global *G, int *d, int *nc, mo_csc **Wout,
                         double **q, double **mu, mo_ctx *ctx)
{
  mo_csc *M = NULL, *H = NULL;
  mo_linsolver *ls = NULL;
  mo_triplet T;
  double *B = NULL, *X = NULL, *v = NULL;
  int st, n, m, j0, i, k, p, chunk = 64;
  memset(&T, 0, sizeof T);
  if (G->G || G->b)
    return mo_error(ctx, MO_EUNSUPPORTED, "%s: global problem with equality constraints (G, b): not supported", path);
  if ((st = fclib_check_matrix(path, "M", G->M, ctx)) || (st = fclib_check_matrix(path, "H", G->H, ctx)))
    return st;
  if ((st = fclib_to_csc(G->M, &M, ctx)) || (st = fclib_to_csc(G->H, &H, ctx))) goto done;
  n = M->nrow;
  m = H->ncol;
  *d = G->spacedim;
  if (*d == 2 || *d == 3) {
    if ((st = fclib_check_vector(path, "f", G->f, n, 0, ctx)) || (st = fclib_check_vector(path, "mu", G->mu, m / *d, 1, ctx)) ||
        (G->w && (st = fclib_check_vector(path, "w", G->w, m, 0, ctx))))
      goto done;
  }
  if ((*d != 2 && *d != 3) || H->nrow != n || m % *d) {
    st = mo_error(ctx, MO_EINPUT, "%s: M is %d x %d, H is %d x %d, local dimension %d", path, M->nrow, M->ncol, H->nrow, H->ncol, *d);
    goto done;
  }
  *nc = m / *d;
  if ((st = mo_linsolver_create(&mo_linsolver_cholmod, &ls, ctx))) goto done;
  if ((st = mo_linsolver_factor(ls, M, ctx))) { mo_error_prefix(ctx, "%s: M", path); goto done; }
  B = mo_calloc(ctx, (size_t)n * (size_t)chunk + 1, sizeof(double));
  X = mo_malloc(ctx, ((size_t)n * (size_t)chunk + 1) * sizeof(double));
  v = mo_malloc(ctx, ((size_t)n + 1) * sizeof(double));
  *q = mo_malloc(ctx, (size_t)m * sizeof(double));
  *mu = mo_malloc(ctx, (size_t)*nc * sizeof(double));
  if (!B || !X || !v || !*q || !*mu || (st = mo_triplet_init(&T, m, m, (size_t)m * 16, ctx))) { st = MO_ENOMEM; goto done; }
  memcpy(*mu, G->mu, (size_t)*nc * sizeof(double));
  /* q = H^T M^-1 f + w */
  if ((st = mo_linsolver_solve(ls, G->f, v, ctx))) goto done;
  mo_csc_gatxpy(H, 1, v, 0, *q);
  for (i = 0; i < m; i++) (*q)[i] += G->w ? G->w[i] : 0;
  /* W by chunks of columns */
  for (j0 = 0; j0 < m; j0 += chunk) {
    int nb = j0 + chunk > m ? m - j0 : chunk;
    memset(B, 0, (size_t)n * (size_t)nb * sizeof(double));
    for (k = 0; k < nb; k++)
      for (p = H->p[j0 + k]; p < H->p[j0 + k + 1]; p++) B[(size_t)k * n + (size_t)H->i[p]] = H->x[p];
    if ((st = mo_linsolver_solve_multi(ls, nb, B, X, ctx))) goto done;
    for (i = 0; i < m; i++)
      for (k = 0; k < nb; k++) {
        double s = 0;
        for (p = H->p[i]; p < H->p[i + 1]; p++) s += H->x[p] * X[(size_t)k * n + (size_t)H->i[p]];
        if (s != 0 && (st = mo_triplet_add(&T, i, j0 + k, s, ctx))) goto done;
      }
  }
  st = mo_triplet_to_csc(&T, 0, Wout, ctx);
done:
  mo_triplet_release(&T);
  mo_csc_free(M);
  mo_csc_free(H);
  mo_linsolver_free(ls);
  mo_free(B);
  mo_free(X);
  mo_free(v);
  return st;
}

int mo_fclib_read(const char *path, int *d, int *nc, mo_csc **Wout, double **q, double **mu,
                  mo_ctx *ctx)
{
  struct fclib_local *pb;
  struct fclib_global *G;
  int m, st = MO_OK;
  FILE *f = fopen(path, "rb");
  char head[8];
  *Wout = NULL;
  *q = *mu = NULL;
  if (!f) return mo_error(ctx, MO_EIO, "%s: cannot open", path);
  if (fread(head, 1, 8, f) != 8 || memcmp(head, "\x89HDF\r\n\x1a\n", 8)) {
    fclose(f);
    return mo_error(ctx, MO_EINPUT, "%s: not an HDF5 file", path);
  }
  fclose(f);
  /* libfclib prints to stderr when a group is missing: ask for the kind the file holds */
  if (mo_fclib_kind(path) == 2) {
    err_capture ec;
    capture_begin(&ec);
    G = fclib_read_global(path);
    capture_end(&ec, path);
    if (!G) return mo_error(ctx, MO_EINPUT, "%s: libfclib could not read the global problem", path);
    st = reduce_global(path, G, d, nc, Wout, q, mu, ctx);
    fclib_delete_global(G);
    if (st) {
      mo_csc_free(*Wout); mo_free(*q); mo_free(*mu);
      *Wout = NULL; *q = *mu = NULL;
    }
    return st;
  }
  {
    err_capture ec;
    capture_begin(&ec);
    pb = fclib_read_local(path);
    capture_end(&ec, path);
  }
  if (!pb || !pb->W) {
    if (pb) fclib_delete_local(pb);
    return mo_error(ctx, MO_EINPUT, "%s: not an FCLIB local problem (libfclib could not read it)", path);
  }
  m = pb->W->m;
  *d = pb->spacedim;
  if ((*d != 2 && *d != 3) || pb->W->n != m || m % *d) {
    fclib_delete_local(pb);
    return mo_error(ctx, MO_EINPUT, "%s: W is %d x %d with local dimension %d", path, pb->W->m, pb->W->n, *d);
  }
  if (pb->V || pb->R)
    mo_log(ctx, 1, "%s: the equality constraints (V, R) of this mixed problem are ignored\n", path);
  *nc = m / *d;
  if ((st = fclib_check_matrix(path, "W", pb->W, ctx)) || (st = fclib_check_vector(path, "q", pb->q, m, 0, ctx)) ||
      (st = fclib_check_vector(path, "mu", pb->mu, *nc, 1, ctx)))
    goto done;
  if ((st = fclib_to_csc(pb->W, Wout, ctx))) goto done;
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

int mo_fclib_write_csc(const char *path, int d, int nc, const mo_csc *W, const double *q,
                       const double *mu, const double *r, const double *U, const char *title,
                       const char *description, const char *math_info, mo_ctx *ctx)
{
  (void)d; (void)nc; (void)W; (void)q; (void)mu; (void)r; (void)U; (void)title; (void)description; (void)math_info;
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
