/* linsolve.c: the linear-solver interface and its CHOLMOD (SPD) and UMFPACK (general) types. */
#include "config.h"
#include <moreau/sparse.h>
#include "ss.h"

#include <math.h>
#include <string.h>

struct mo_linsolver {
  const mo_linsolver_type *type;
  void *state;
  int n;
  int *pat_p, *pat_i; /* pattern of the last factored matrix, to detect a change */
  int pat_nnz;
  long nfactor, nsymbolic, nsolve;
};

int mo_linsolver_create(const mo_linsolver_type *T, mo_linsolver **out, mo_ctx *ctx)
{
  mo_linsolver *S = mo_calloc(ctx, 1, sizeof *S);
  *out = NULL;
  if (!S) return MO_ENOMEM;
  S->type = T;
  S->state = mo_calloc(ctx, 1, T->state_size);
  if (!S->state) {
    mo_free(S);
    return MO_ENOMEM;
  }
  *out = S;
  return MO_OK;
}

static int same_pattern(const mo_linsolver *S, const mo_csc *A)
{
  int nnz = mo_csc_nnz(A);
  if (!S->pat_p || S->n != A->ncol || S->pat_nnz != nnz) return 0;
  return !memcmp(S->pat_p, A->p, ((size_t)A->ncol + 1) * sizeof(int)) &&
         !memcmp(S->pat_i, A->i, (size_t)nnz * sizeof(int));
}

int mo_linsolver_factor(mo_linsolver *S, const mo_csc *A, mo_ctx *ctx)
{
  int same, st, nnz = mo_csc_nnz(A), k;
  if (A->nrow != A->ncol)
    return mo_error(ctx, MO_EINTERNAL, "factor: matrix is %d x %d, not square", A->nrow, A->ncol);
  for (k = 0; k < nnz; k++)
    if (!isfinite(A->x[k]))
      return mo_error(ctx, MO_ENAN, "factor: the matrix holds a NaN or an infinity (column "
                      "of entry %d)", k);
  same = same_pattern(S, A);
  if ((st = S->type->factor(S->state, A, same, ctx))) return st;
  if (!same) {
    int *p = mo_realloc(ctx, S->pat_p, ((size_t)A->ncol + 1) * sizeof(int));
    int *i;
    if (!p) return MO_ENOMEM;
    S->pat_p = p;
    i = mo_realloc(ctx, S->pat_i, (size_t)(nnz > 0 ? nnz : 1) * sizeof(int));
    if (!i) return MO_ENOMEM;
    S->pat_i = i;
    memcpy(S->pat_p, A->p, ((size_t)A->ncol + 1) * sizeof(int));
    memcpy(S->pat_i, A->i, (size_t)nnz * sizeof(int));
    S->pat_nnz = nnz;
    S->nsymbolic++;
  }
  S->n = A->ncol;
  S->nfactor++;
  return MO_OK;
}

int mo_linsolver_solve_multi(mo_linsolver *S, int nrhs, const double *B, double *X, mo_ctx *ctx)
{
  if (!S->nfactor) return mo_error(ctx, MO_EINTERNAL, "solve before factor");
  S->nsolve += nrhs;
  return S->type->solve(S->state, nrhs, B, X, ctx);
}

int mo_linsolver_solve(mo_linsolver *S, const double *b, double *x, mo_ctx *ctx)
{
  return mo_linsolver_solve_multi(S, 1, b, x, ctx);
}

int mo_linsolver_configure(mo_linsolver *S, const mo_linsolver_settings *set, mo_ctx *ctx)
{
  return S->type->configure ? S->type->configure(S->state, set, ctx) : MO_OK;
}

int mo_linsolver_n(const mo_linsolver *S) { return S->n; }

void mo_linsolver_stats(const mo_linsolver *S, long *nfactor, long *nsymbolic, long *nsolve)
{
  if (nfactor) *nfactor = S->nfactor;
  if (nsymbolic) *nsymbolic = S->nsymbolic;
  if (nsolve) *nsolve = S->nsolve;
}

const char *mo_linsolver_name(const mo_linsolver *S) { return S->type->name; }

void mo_linsolver_free(mo_linsolver *S)
{
  if (!S) return;
  if (S->type->free) S->type->free(S->state);
  mo_free(S->state);
  mo_free(S->pat_p);
  mo_free(S->pat_i);
  mo_free(S);
}

/* --- CHOLMOD: symmetric positive definite --------------------------------------------------- */

typedef struct {
  int started;
  cholmod_common c;
  cholmod_factor *L;
  cholmod_dense *X, *Y, *E; /* workspace reused across solves (cholmod_solve2) */
  int n;
} chol_state;

/* A cholmod_sparse view of the lower triangle stored in A (no copy: stype = -1 reads the lower
   part of a matrix holding both triangles). */
static void chol_view(const mo_csc *A, cholmod_sparse *S)
{
  memset(S, 0, sizeof *S);
  S->nrow = (size_t)A->nrow;
  S->ncol = (size_t)A->ncol;
  S->nzmax = (size_t)mo_csc_nnz(A);
  S->p = A->p;
  S->i = A->i;
  S->x = A->x;
  S->stype = -1;
  S->itype = CHOLMOD_INT;
  S->xtype = CHOLMOD_REAL;
  S->dtype = CHOLMOD_DOUBLE;
  S->sorted = 1;
  S->packed = 1;
}

static int chol_factor(void *state, const mo_csc *A, int same, mo_ctx *ctx)
{
  chol_state *s = state;
  cholmod_sparse S;
  if (!s->started) {
    cholmod_start(&s->c);
    s->c.print = 0;
    s->started = 1;
  }
  chol_view(A, &S);
  if (!same || !s->L) {
    if (s->L) cholmod_free_factor(&s->L, &s->c);
    s->L = cholmod_analyze(&S, &s->c);
    if (!s->L) return mo_ss_cholmod_error(&s->c, "symbolic factorization", ctx);
  }
  if (!cholmod_factorize(&S, s->L, &s->c) || s->c.status != CHOLMOD_OK) {
    if (s->c.status == CHOLMOD_NOT_POSDEF)
      return mo_error(ctx, MO_ESINGULAR,
                      "factorization: the matrix is not positive definite (CHOLMOD stopped at "
                      "column %d of %d): a body free to move rigidly with zero mass, or a "
                      "missing support in a quasi-static scene", (int)s->L->minor, A->ncol);
    return mo_ss_cholmod_error(&s->c, "numeric factorization", ctx);
  }
  /* CHOLMOD's simplicial LDL' factors indefinite matrices too: check that D > 0 */
  if (!s->L->is_ll && !s->L->is_super) {
    const int *Lp = s->L->p;
    const double *Lx = s->L->x;
    int j;
    for (j = 0; j < A->ncol; j++)
      if (!(Lx[Lp[j]] > 0))
        return mo_error(ctx, MO_ESINGULAR,
                        "factorization: the matrix is not positive definite (pivot %d of %d is "
                        "%g): a body free to move rigidly with zero mass, or a missing support in "
                        "a quasi-static scene", j, A->ncol, Lx[Lp[j]]);
  }
  s->n = A->ncol;
  return MO_OK;
}

static int chol_solve(void *state, int nrhs, const double *B, double *X, mo_ctx *ctx)
{
  chol_state *s = state;
  cholmod_dense b;
  memset(&b, 0, sizeof b);
  b.nrow = (size_t)s->n;
  b.ncol = (size_t)nrhs;
  b.nzmax = (size_t)s->n * (size_t)nrhs;
  b.d = (size_t)s->n;
  b.x = (void *)B;
  b.xtype = CHOLMOD_REAL;
  b.dtype = CHOLMOD_DOUBLE;
  if (!cholmod_solve2(CHOLMOD_A, s->L, &b, NULL, &s->X, NULL, &s->Y, &s->E, &s->c))
    return mo_ss_cholmod_error(&s->c, "triangular solve", ctx);
  memcpy(X, s->X->x, (size_t)s->n * (size_t)nrhs * sizeof(double));
  return MO_OK;
}

static void chol_free(void *state)
{
  chol_state *s = state;
  if (!s->started) return;
  if (s->L) cholmod_free_factor(&s->L, &s->c);
  if (s->X) cholmod_free_dense(&s->X, &s->c);
  if (s->Y) cholmod_free_dense(&s->Y, &s->c);
  if (s->E) cholmod_free_dense(&s->E, &s->c);
  cholmod_finish(&s->c);
}

const mo_linsolver_type mo_linsolver_cholmod = {"cholmod", 1, sizeof(chol_state), chol_factor,
                                                chol_solve, chol_free, NULL};

/* --- UMFPACK: general square matrices --------------------------------------------------------- */

typedef struct {
  void *sym, *num;
  int n;
  const int *Ap, *Ai;   /* the factored matrix (needed by umfpack_di_solve) */
  const double *Ax;
  double *work;
  double control[UMFPACK_CONTROL], info[UMFPACK_INFO];
} umf_state;

static int umf_factor(void *state, const mo_csc *A, int same, mo_ctx *ctx)
{
  umf_state *s = state;
  int st;
  if (!s->sym) umfpack_di_defaults(s->control);
  if (!same || !s->sym) {
    if (s->sym) umfpack_di_free_symbolic(&s->sym);
    st = umfpack_di_symbolic(A->nrow, A->ncol, A->p, A->i, A->x, &s->sym, s->control, s->info);
    if (st != UMFPACK_OK) return mo_ss_umfpack_error(st, "symbolic factorization", ctx);
  }
  if (s->num) umfpack_di_free_numeric(&s->num);
  st = umfpack_di_numeric(A->p, A->i, A->x, s->sym, &s->num, s->control, s->info);
  if (st != UMFPACK_OK) return mo_ss_umfpack_error(st, "numeric factorization", ctx);
  if (s->n != A->ncol || !s->work) {
    mo_free(s->work);
    s->work = mo_malloc(ctx, (size_t)(A->ncol > 0 ? A->ncol : 1) * sizeof(double));
    if (!s->work) return MO_ENOMEM;
  }
  s->n = A->ncol;
  s->Ap = A->p;
  s->Ai = A->i;
  s->Ax = A->x;
  return MO_OK;
}

static int umf_solve(void *state, int nrhs, const double *B, double *X, mo_ctx *ctx)
{
  umf_state *s = state;
  int k, st;
  for (k = 0; k < nrhs; k++) {
    const double *b = B + (size_t)k * (size_t)s->n;
    double *x = X + (size_t)k * (size_t)s->n;
    if (b == x) { /* UMFPACK does not solve in place */
      memcpy(s->work, b, (size_t)s->n * sizeof(double));
      b = s->work;
    }
    st = umfpack_di_solve(UMFPACK_A, s->Ap, s->Ai, s->Ax, x, b, s->num, s->control, s->info);
    if (st != UMFPACK_OK) return mo_ss_umfpack_error(st, "solve", ctx);
  }
  return MO_OK;
}

static void umf_free(void *state)
{
  umf_state *s = state;
  if (s->sym) umfpack_di_free_symbolic(&s->sym);
  if (s->num) umfpack_di_free_numeric(&s->num);
  mo_free(s->work);
}

const mo_linsolver_type mo_linsolver_umfpack = {"umfpack", 0, sizeof(umf_state), umf_factor,
                                                umf_solve, umf_free, NULL};
