/* linsolve.c: the linear-solver interface and its CHOLMOD (SPD, long indices, contact dofs
   ordered last: doc/theory.md §13) and UMFPACK (general) types. */
#include "config.h"
#include <moreau/sparse.h>
#include "ss.h"

#include <dlfcn.h>
#include <limits.h>
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

int mo_linsolver_solve_rows(mo_linsolver *S, int nrhs, const double *B, double *X, int *r0, int *r1,
                            mo_ctx *ctx)
{
  if (!S->nfactor) return mo_error(ctx, MO_EINTERNAL, "solve before factor");
  S->nsolve += nrhs;
  if (S->type->solve_rows) return S->type->solve_rows(S->state, nrhs, B, X, r0, r1, ctx);
  *r0 = 0;
  *r1 = S->n;
  return nrhs ? S->type->solve(S->state, nrhs, B, X, ctx) : MO_OK;
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

int mo_linsolver_set_last(mo_linsolver *S, int nlast, const int *last, double reserve, mo_ctx *ctx)
{
  /* a type without the ordering keeps its own: mo_linsolver_nlast says 0, and the stepper takes
     the path of one solve per column */
  if (!S->type->set_last) return MO_OK;
  return S->type->set_last(S->state, nlast, last, reserve, ctx);
}

int mo_linsolver_nlast(const mo_linsolver *S)
{
  mo_linsolver_info I;
  mo_linsolver_info_get(S, &I);
  return I.trailing ? I.nlast : 0;
}

void mo_linsolver_info_get(const mo_linsolver *S, mo_linsolver_info *I)
{
  memset(I, 0, sizeof *I);
  I->nnz_L = I->two_solves = NAN;
  if (S->type->info) S->type->info(S->state, I);
}

/* The split and trailing solves exist only once a factor holds the trailing block. */
static int split_ready(const mo_linsolver *S, mo_ctx *ctx)
{
  if (!S->nfactor || !S->type->split) return mo_error(ctx, MO_EINTERNAL, "split solve without a factor that has one");
  return MO_OK;
}

int mo_linsolver_split(mo_linsolver *S, mo_split_op op, const double *in, double *out, mo_ctx *ctx)
{
  int st = split_ready(S, ctx);
  if (st) return st;
  if (op == MO_SPLIT_FORWARD) S->nsolve++; /* a forward and a backward make one solve */
  return S->type->split(S->state, op, in, out, ctx);
}

int mo_linsolver_has_split(const mo_linsolver *S) { return S->type->split != NULL; }

int mo_linsolver_schur_inverse(mo_linsolver *S, double *G, mo_ctx *ctx)
{
  if (!S->nfactor || !S->type->schur_inverse) return mo_error(ctx, MO_EINTERNAL, "no Schur inverse in this solver");
  return S->type->schur_inverse(S->state, G, ctx);
}

/* --- BLAS threads ------------------------------------------------------------------------------
   OpenBLAS (Debian's default BLAS) lets its idle threads spin in sched_yield between calls: on
   the small products of the steps and the contact solves a second thread only waits, and on a
   machine shared with other jobs the spinning threads of a large factorization fight them for
   the cores (the 14^3 box's numeric factorization took 5.2-10.9 s on two threads against
   0.54-1.15 s on one, on the loaded 2-core machine of doc/theory.md (T155)). The program runs one
   thread (main.c sets it); MOREAU_BLAS_THREADS=N gives N threads to the large dense work alone
   (numeric factorizations and the Schur inverse above 1e9 flops), the rest staying on one (or
   on OPENBLAS_NUM_THREADS when it is set). Another BLAS has no such setter and is left alone. */

typedef void (*blas_setter)(int);

static blas_setter blas_threads_setter(void)
{
  return (blas_setter)dlsym(RTLD_DEFAULT, "openblas_set_num_threads");
}

static int env_threads(const char *name, int deflt)
{
  const char *e = getenv(name);
  long n = e && *e ? strtol(e, NULL, 10) : deflt;
  return n < 1 ? 1 : n > 64 ? 64 : (int)n;
}

int mo_blas_threads_max(void)
{
  return env_threads("MOREAU_BLAS_THREADS", env_threads("OPENBLAS_NUM_THREADS", 1));
}

int mo_blas_threads_base(void)
{
  return env_threads("OPENBLAS_NUM_THREADS", 1);
}

void mo_blas_threads(int n)
{
  blas_setter set = blas_threads_setter();
  if (set) set(n < 1 ? 1 : n);
}

/* Work (flops) above which the dense kernels take every core. */
#define MO_BLAS_PARALLEL_FLOPS 1e9

/* --- CHOLMOD: symmetric positive definite, long indices ---------------------------------------

   Every CHOLMOD call goes through the SuiteSparse_long interface (cholmod_l_*): the factor of a
   3D mesh passes 2^31 entries near 10^6 dofs (nnz(L) = 2.15e9 for the 68^3 box), which the int
   interface refuses ("problem too large"). The matrix keeps int indices (its entries stay far
   below 2^31); a long copy of its pattern lives for the factorization only.

   Rows and columns may be ordered last (mo_linsolver_set_last: the contact dofs): the remaining
   ones I are ordered by CHOLMOD's own choice on A_II (AMD, METIS when AMD fills too much), then
   the last ones C follow in the order given, without postordering, so that P A P^T = L L^T has
   L = [L11 0; L21 L22] with L22 L22^T = A_CC - A_CI A_II^-1 A_IC, the Schur complement on C
   (doc/theory.md (T150)-(T152)). Its factor L22, at the end of the supernodal (or simplicial LL')
   storage, gives (A^-1)_CC and the trailing solves without touching the rest of L. */

typedef SuiteSparse_long sslong;

typedef struct {
  int started;
  cholmod_common c;
  cholmod_factor *L;
  cholmod_dense *X, *Y, *E; /* workspace reused across solves (cholmod_solve2) */
  int n;
  int nlast, *last;         /* rows and columns to order last (requested) */
  int last_new;             /* the request changed: a new analysis */
  int trailing;             /* the factor has them as its trailing rows, in order */
  double reserve;           /* bytes the caller will need beside the factor (the Delassus) */
  long s0;                  /* supernodal: the first supernode holding a trailing column */
  double *w, *tmp;          /* n: permuted vectors; the largest supernode's rows */
  double *invd;             /* n: a simplicial LL' factor's inverse diagonal (a product, not a division, per column) */
  cholmod_dense *Bd;        /* a view for split solves */
  double t_full, t_fw, t_bw; /* seconds in whole, forward and backward solves of one right-hand side */
  long n_full, n_fw, n_bw;
  mo_linsolver_info info;
} chol_state;

static void chol_start(chol_state *s)
{
  if (s->started) return;
  cholmod_l_start(&s->c);
  s->c.print = 0;
  s->started = 1;
}

int mo_order_last_set(int nlast, const int *last, int *nkeep, int **keep, int *fresh, mo_ctx *ctx)
{
  if (nlast == *nkeep && (!nlast || !memcmp(last, *keep, (size_t)nlast * sizeof *last))) return MO_OK;
  mo_free(*keep);
  *keep = NULL;
  *nkeep = 0;
  if (nlast) {
    if (!(*keep = mo_malloc(ctx, (size_t)nlast * sizeof **keep))) return MO_ENOMEM;
    memcpy(*keep, last, (size_t)nlast * sizeof *last);
  }
  *nkeep = nlast;
  *fresh = 1;
  return MO_OK;
}

static int chol_set_last(void *state, int nlast, const int *last, double reserve, mo_ctx *ctx)
{
  chol_state *s = state;
  s->reserve = reserve;
  return mo_order_last_set(nlast, last, &s->nlast, &s->last, &s->last_new, ctx);
}

/* A long-index cholmod_sparse of the pattern of A (both triangles stored, stype = -1 reads the
   lower one); *p and *i are the copies, freed by the caller. */
static int chol_long_view(const mo_csc *A, cholmod_sparse *S, sslong **p, sslong **i, mo_ctx *ctx)
{
  size_t nnz = (size_t)mo_csc_nnz(A), k;
  *p = mo_malloc(ctx, ((size_t)A->ncol + 1) * sizeof **p);
  *i = mo_malloc(ctx, (nnz + 1) * sizeof **i);
  if (!*p || !*i) return MO_ENOMEM;
  for (k = 0; k <= (size_t)A->ncol; k++) (*p)[k] = A->p[k];
  for (k = 0; k < nnz; k++) (*i)[k] = A->i[k];
  memset(S, 0, sizeof *S);
  S->nrow = (size_t)A->nrow;
  S->ncol = (size_t)A->ncol;
  S->nzmax = nnz;
  S->p = *p;
  S->i = *i;
  S->x = A->x;
  S->stype = -1;
  S->itype = CHOLMOD_LONG;
  S->xtype = CHOLMOD_REAL;
  S->dtype = CHOLMOD_DOUBLE;
  S->sorted = 1;
  S->packed = 1;
  return MO_OK;
}

static const char *ordering_name(int o)
{
  switch (o) {
  case CHOLMOD_NATURAL: return "natural";
  case CHOLMOD_GIVEN: return "given";
  case CHOLMOD_AMD: return "amd";
  case CHOLMOD_METIS: return "metis";
  case CHOLMOD_NESDIS: return "nesdis";
  case CHOLMOD_COLAMD: return "colamd";
  default: return "other";
  }
}

/* The fill-reducing order of the rows not ordered last: CHOLMOD's default choice on the pattern
   of A_II (its postordered permutation), written into perm[0 .. n - nlast - 1] as rows of A. */
static int order_rest_c(cholmod_common *c, const cholmod_sparse *A, int nlast, const int *last, sslong *perm,
                        const char **ordering, mo_ctx *ctx)
{
  const sslong *Ap = A->p, *Ai = A->i;
  sslong n = (sslong)A->ncol, nI = n - nlast, j, p, k, nz = 0;
  sslong *map = NULL, *Ip = NULL, *Ii = NULL, *rest = NULL;
  cholmod_sparse B;
  cholmod_factor *LI = NULL;
  int st = MO_OK, super = c->supernodal;
  map = mo_malloc(ctx, ((size_t)n + 1) * sizeof *map);
  rest = mo_malloc(ctx, ((size_t)nI + 1) * sizeof *rest);
  if (!map || !rest) { st = MO_ENOMEM; goto done; }
  for (j = 0; j < n; j++) map[j] = 0;
  for (k = 0; k < nlast; k++) map[last[k]] = -1;
  for (j = 0, k = 0; j < n; j++)
    if (map[j] == 0) { rest[k] = j; map[j] = k++; }
  if (nI == 0) goto done;
  for (j = 0; j < n; j++)
    if (map[j] >= 0)
      for (p = Ap[j]; p < Ap[j + 1]; p++) nz += map[Ai[p]] >= 0;
  Ip = mo_malloc(ctx, ((size_t)nI + 1) * sizeof *Ip);
  Ii = mo_malloc(ctx, ((size_t)nz + 1) * sizeof *Ii);
  if (!Ip || !Ii) { st = MO_ENOMEM; goto done; }
  Ip[0] = 0;
  for (k = 0; k < nI; k++) {
    sslong q = Ip[k];
    j = rest[k];
    for (p = Ap[j]; p < Ap[j + 1]; p++)
      if (map[Ai[p]] >= 0) Ii[q++] = map[Ai[p]];
    Ip[k + 1] = q;
  }
  memset(&B, 0, sizeof B);
  B.nrow = B.ncol = (size_t)nI;
  B.nzmax = (size_t)nz;
  B.p = Ip;
  B.i = Ii;
  B.stype = -1;
  B.itype = CHOLMOD_LONG;
  B.xtype = CHOLMOD_PATTERN;
  B.dtype = CHOLMOD_DOUBLE;
  B.sorted = 1;
  B.packed = 1;
  /* only the permutation is kept: the simplicial analysis is enough to choose it */
  c->supernodal = CHOLMOD_SIMPLICIAL;
  LI = cholmod_l_analyze(&B, c);
  c->supernodal = super;
  if (!LI) { st = mo_ss_cholmod_error(c, "ordering of the dofs without contact", ctx); goto done; }
  *ordering = ordering_name(c->method[c->selected].ordering);
  for (k = 0; k < nI; k++) perm[k] = rest[((sslong *)LI->Perm)[k]];
done:
  if (!st && nI == 0) *ordering = "given";
  if (LI) cholmod_l_free_factor(&LI, c);
  mo_free(map);
  mo_free(rest);
  mo_free(Ip);
  mo_free(Ii);
  return st;
}

static int order_rest(chol_state *s, const cholmod_sparse *A, sslong *perm, mo_ctx *ctx)
{
  return order_rest_c(&s->c, A, s->nlast, s->last, perm, &s->info.ordering, ctx);
}

/* The order of the rows ordered last (sparse.h): CHOLMOD's own, as chol_analyze takes it, for a
   factorization by another package (MUMPS's PERM_IN, doc/theory.md (T183)). */
int mo_order_last(const mo_csc *A, int nlast, const int *last, int *perm, const char **ordering, mo_ctx *ctx)
{
  cholmod_common c;
  cholmod_sparse S;
  sslong *p = NULL, *i = NULL, *pl = NULL, n = A->ncol, nI = n - nlast, k;
  int st;
  *ordering = "given";
  if (nlast < 0 || nlast > A->ncol || A->nrow != A->ncol)
    return mo_error(ctx, MO_EINTERNAL, "mo_order_last: %d rows last of a %d x %d matrix", nlast, A->nrow, A->ncol);
  cholmod_l_start(&c);
  c.print = 0;
  st = chol_long_view(A, &S, &p, &i, ctx);
  if (!st && !(pl = mo_malloc(ctx, ((size_t)n + 1) * sizeof *pl))) st = MO_ENOMEM;
  if (!st) st = order_rest_c(&c, &S, nlast, last, pl, ordering, ctx);
  if (!st) {
    for (k = 0; k < nI; k++) perm[k] = (int)pl[k];
    for (k = 0; k < nlast; k++) perm[nI + k] = last[k];
  }
  mo_free(p);
  mo_free(i);
  mo_free(pl);
  cholmod_l_finish(&c);
  return st;
}

/* The symbolic analysis: CHOLMOD's default, or with the last rows ordered last (trailing). */
static int chol_analyze(chol_state *s, cholmod_sparse *A, int use_last, mo_ctx *ctx)
{
  sslong n = (sslong)A->ncol, nI = n - s->nlast, k, *perm = NULL;
  int st = MO_OK, nm = s->c.nmethods, ord = s->c.method[0].ordering, post = s->c.postorder;
  double t0 = mo_clock();
  if (s->L) cholmod_l_free_factor(&s->L, &s->c);
  s->trailing = 0;
  s->last_new = 0;
  if (!s->nlast || !use_last) {
    s->c.final_ll = 0;
    s->L = cholmod_l_analyze(A, &s->c);
    if (!s->L) return mo_ss_cholmod_error(&s->c, "symbolic factorization", ctx);
    s->info.ordering = ordering_name(s->c.method[s->c.selected].ordering);
  } else {
    if (!(perm = mo_malloc(ctx, ((size_t)n + 1) * sizeof *perm))) return MO_ENOMEM;
    if ((st = order_rest(s, A, perm, ctx))) goto done;
    for (k = 0; k < s->nlast; k++) perm[nI + k] = s->last[k];
    s->c.nmethods = 1;
    s->c.method[0].ordering = CHOLMOD_GIVEN;
    s->c.postorder = 0;
    s->c.final_ll = 1; /* a simplicial factor in LL' form, as the supernodal one */
    s->L = cholmod_l_analyze_p(A, perm, NULL, 0, &s->c);
    s->c.nmethods = nm;
    s->c.method[0].ordering = ord;
    s->c.postorder = post;
    if (!s->L) { st = mo_ss_cholmod_error(&s->c, "symbolic factorization", ctx); goto done; }
    for (k = 0; k < s->nlast; k++)
      if (((sslong *)s->L->Perm)[nI + k] != s->last[k]) {
        st = mo_error(ctx, MO_EINTERNAL, "CHOLMOD did not keep the given order of the contact dofs");
        goto done;
      }
    s->trailing = 1;
  }
  s->info.nnz_L = s->c.lnz;
  s->info.flops = s->c.fl;
  s->info.t_analyze += mo_clock() - t0;
done:
  mo_free(perm);
  return st;
}

/* Memory of the factor (values and indices) and of the numeric factorization's workspace, from
   the symbolic analysis (T154). */
static void chol_memory(chol_state *s)
{
  const cholmod_factor *L = s->L;
  double n = (double)L->n;
  if (L->is_super) {
    s->info.bytes_factor = 8.0 * ((double)L->xsize + (double)L->ssize + 3.0 * ((double)L->nsuper + 1) + 2 * n);
    s->info.bytes_work = 8.0 * ((double)L->maxcsize + 6 * n);
  } else {
    s->info.bytes_factor = 16.0 * s->c.lnz + 8.0 * 6 * n;
    s->info.bytes_work = 8.0 * 6 * n;
  }
  s->info.supernodal = L->is_super;
}

/* Bytes the caller will need beside the factor: W, and with the trailing block (What^-1)_CC. */
static double chol_reserve(const chol_state *s)
{
  return s->reserve + (s->trailing ? 8.0 * s->nlast * s->nlast : 0);
}

/* The memory this run may take: the machine's, or the context's limit when lower. */
static double chol_limit(const mo_ctx *ctx)
{
  double m = mo_memory_limit();
  return ctx->max_bytes > 0 && ctx->max_bytes < m ? ctx->max_bytes : m;
}

/* The bytes beyond what the run holds: the factor, and the larger of the numeric factorization's
   workspace (freed when it ends) and what the caller will allocate after it (T154). */
static double chol_need(const chol_state *s)
{
  return s->info.bytes_factor + fmax(s->info.bytes_work, chol_reserve(s));
}

/* Whether they fit beside what the run holds. */
static int chol_fits(const chol_state *s, const mo_ctx *ctx)
{
  return chol_need(s) + mo_memory_rss() <= chol_limit(ctx);
}

/* The memory the factorization will take against what the machine has (T154): refused with
   the figures when it does not fit; stated in the log when it is large. */
static int chol_memory_check(chol_state *s, mo_ctx *ctx)
{
  double reserve = chol_reserve(s), need = chol_need(s),
         have = mo_memory_rss(), limit = chol_limit(ctx);
  s->info.bytes_reserve = reserve;
  s->info.bytes_before = have;
  s->info.bytes_limit = limit;
  if (need + have > 2e9 || ctx->verbosity >= 3)
    mo_log(ctx, 1, "moreau: factorization of %d dofs: nnz(L) = %.4g (%.2f GB with its indices), then its workspace "
           "(%.2f GB) or the Delassus operator and its Schur inverse (%.2f GB), beside %.2f GB in use: %.2f GB of the "
           "%.2f GB this run may take\n",
           s->n, s->info.nnz_L, s->info.bytes_factor / 1e9, s->info.bytes_work / 1e9, reserve / 1e9, have / 1e9,
           (need + have) / 1e9, limit / 1e9);
  if (need + have > limit)
    return mo_error(ctx, MO_ELIMIT,
                    "the factorization of the iteration matrix (%d dofs) needs %.2f GB: the factor L (nnz(L) = %.4g, "
                    "%.2f GB with its indices), then the larger of the workspace of its numeric factorization (%.2f GB) "
                    "and the Delassus operator with its Schur inverse (%.2f GB), beside the %.2f GB the run holds "
                    "already; this machine "
                    "gives a run %.2f GB (physical memory, or RLIMIT_AS when lower; doc/theory.md (T154)). Refused "
                    "before the numeric factorization: a coarser mesh, or a machine with more memory",
                    s->n, (need + have) / 1e9, s->info.nnz_L, s->info.bytes_factor / 1e9, s->info.bytes_work / 1e9,
                    reserve / 1e9, have / 1e9, limit / 1e9);
  return MO_OK;
}

/* Not positive definite: the column CHOLMOD stopped at, or a pivot that is not positive. */
static int chol_not_posdef(const chol_state *s, int n, mo_ctx *ctx)
{
  const sslong *Lp = s->L->p;
  const double *Lx = s->L->x;
  sslong j;
  if (s->c.status == CHOLMOD_NOT_POSDEF)
    return mo_error(ctx, MO_ESINGULAR,
                    "factorization: the matrix is not positive definite (CHOLMOD stopped at "
                    "column %ld of %d): a body free to move rigidly with zero mass, or a "
                    "missing support in a quasi-static scene", (long)s->L->minor, n);
  if (s->c.status != CHOLMOD_OK) return mo_ss_cholmod_error(&s->c, "numeric factorization", ctx);
  if (s->L->is_super) return MO_OK;
  /* simplicial LDL' factors indefinite matrices too: D > 0 (LL': a positive diagonal) */
  for (j = 0; j < n; j++)
    if (!(Lx[Lp[j]] > 0))
      return mo_error(ctx, MO_ESINGULAR,
                      "factorization: the matrix is not positive definite (pivot %ld of %d is "
                      "%g): a body free to move rigidly with zero mass, or a missing support in "
                      "a quasi-static scene", (long)j, n, Lx[Lp[j]]);
  return MO_OK;
}

static int chol_factor(void *state, const mo_csc *A, int same, mo_ctx *ctx)
{
  chol_state *s = state;
  cholmod_sparse S;
  sslong *p = NULL, *i = NULL;
  int st;
  double t0;
  chol_start(s);
  if ((st = chol_long_view(A, &S, &p, &i, ctx))) goto done;
  s->n = A->ncol;
  if (!same || !s->L || s->last_new) {
    mo_free(s->w);
    mo_free(s->tmp);
    mo_free(s->invd);
    s->tmp = NULL;
    s->invd = NULL;
    if (!(s->w = mo_malloc(ctx, ((size_t)A->ncol + 1) * sizeof *s->w))) { st = MO_ENOMEM; goto done; }
    if ((st = chol_analyze(s, &S, 1, ctx))) goto done;
    chol_memory(s);
    if (s->trailing && !chol_fits(s, ctx)) {
      /* the contact dofs last fill more (T154): when that does not fit, CHOLMOD's own order, W by
         solves */
      s->info.bytes_trailing = chol_need(s);
      mo_log(ctx, 1, "moreau: the factorization with the contact dofs last would need %.2f GB (nnz(L) = %.4g) beside "
             "the %.2f GB in use, more than the %.2f GB this run may take: CHOLMOD's own order instead, the "
             "Delassus operator by solves (doc/theory.md (T154))\n", s->info.bytes_trailing / 1e9, s->info.nnz_L,
             mo_memory_rss() / 1e9, chol_limit(ctx) / 1e9);
      if ((st = chol_analyze(s, &S, 0, ctx))) goto done;
      chol_memory(s);
    }
    if ((st = chol_memory_check(s, ctx))) goto done;
  }
  t0 = mo_clock();
  /* MOREAU_BLAS_THREADS for the dense updates of a large factorization, one thread after it */
  if (s->info.flops > MO_BLAS_PARALLEL_FLOPS) mo_blas_threads(mo_blas_threads_max());
  cholmod_l_factorize(&S, s->L, &s->c);
  mo_blas_threads(mo_blas_threads_base());
  s->info.t_numeric = mo_clock() - t0;
  if ((st = chol_not_posdef(s, A->ncol, ctx))) goto done;
  if (s->trailing && !s->L->is_super && !s->L->is_ll) {
    st = mo_error(ctx, MO_EINTERNAL, "CHOLMOD left a simplicial LDL' factor where LL' was asked");
    goto done;
  }
  if (s->trailing && !s->L->is_super) {
    const sslong *Lp = s->L->p;
    const double *Lx = s->L->x;
    sslong j;
    if (!s->invd && !(s->invd = mo_malloc(ctx, ((size_t)A->ncol + 1) * sizeof *s->invd))) { st = MO_ENOMEM; goto done; }
    for (j = 0; j < A->ncol; j++) s->invd[j] = 1 / Lx[Lp[j]];
  }
  if (s->trailing && !s->tmp) {
    /* the first supernode holding a trailing column, and room for a supernode's rows */
    size_t room = (size_t)s->nlast + 1;
    s->s0 = 0;
    if (s->L->is_super) {
      const sslong *super = s->L->super;
      sslong nI = (sslong)s->n - s->nlast;
      while (s->s0 < (long)s->L->nsuper && super[s->s0 + 1] <= nI) s->s0++;
    }
    if (!(s->tmp = mo_malloc(ctx, room * sizeof *s->tmp))) { st = MO_ENOMEM; goto done; }
  }
  s->info.nlast = s->nlast;
  s->info.trailing = s->trailing;
  s->info.long_indices = 1;
done:
  mo_free(p);
  mo_free(i);
  return st;
}

/* A cholmod_dense view of n x nrhs values (column-major). */
static void dense_view(cholmod_dense *b, size_t n, size_t nrhs, const double *x)
{
  memset(b, 0, sizeof *b);
  b->nrow = n;
  b->ncol = nrhs;
  b->nzmax = n * nrhs;
  b->d = n;
  b->x = (void *)x;
  b->xtype = CHOLMOD_REAL;
  b->dtype = CHOLMOD_DOUBLE;
}

static int chol_sys(chol_state *s, int sys, size_t nrhs, const double *B, double *X, mo_ctx *ctx)
{
  cholmod_dense b;
  dense_view(&b, (size_t)s->n, nrhs, B);
  if (!cholmod_l_solve2(sys, s->L, &b, NULL, &s->X, NULL, &s->Y, &s->E, &s->c))
    return mo_ss_cholmod_error(&s->c, "triangular solve", ctx);
  memcpy(X, s->X->x, (size_t)s->n * nrhs * sizeof(double));
  return MO_OK;
}

static int chol_solve(void *state, int nrhs, const double *B, double *X, mo_ctx *ctx)
{
  chol_state *s = state;
  double t0 = mo_clock();
  int st = chol_sys(s, CHOLMOD_A, (size_t)nrhs, B, X, ctx);
  if (nrhs == 1) {
    s->t_full += mo_clock() - t0;
    s->n_full++;
  }
  return st;
}

/* --- the trailing block L22 (T151): its solves and the Schur inverse --------------------------- */

extern void dtrsv_(const char *uplo, const char *trans, const char *diag, const int *n, const double *a,
                   const int *lda, double *x, const int *incx);
extern void dgemv_(const char *trans, const int *m, const int *n, const double *alpha, const double *a,
                   const int *lda, const double *x, const int *incx, const double *beta, double *y,
                   const int *incy);
extern void dpotri_(const char *uplo, const int *n, double *a, const int *lda, int *info);

/* A simplicial LL' factor's columns j0 .. n-1 (their rows are all >= j0): z = L(j0:, j0:)^-1 z and
   z = L(j0:, j0:)^-T z, z indexed from j0. Column by column; also the whole solves of a simplicial
   factor (j0 = 0), where a call of cholmod_solve2 costs more than the solve itself (a 1D bar). */
static void simplicial_lsolve(const cholmod_factor *L, const double *invd, sslong j0, double *z)
{
  const double *Lx = L->x;
  const sslong *Lp = L->p, *Li = L->i, *Lnz = L->nz;
  sslong j, p, n = (sslong)L->n;
  for (j = j0; j < n; j++) {
    double zj = z[j - j0] *= invd[j];
    for (p = Lp[j] + 1; p < Lp[j] + Lnz[j]; p++) z[Li[p] - j0] -= Lx[p] * zj;
  }
}

static void simplicial_ltsolve(const cholmod_factor *L, const double *invd, sslong j0, double *z)
{
  const double *Lx = L->x;
  const sslong *Lp = L->p, *Li = L->i, *Lnz = L->nz;
  sslong j, p;
  for (j = (sslong)L->n - 1; j >= j0; j--) {
    double acc = z[j - j0];
    for (p = Lp[j] + 1; p < Lp[j] + Lnz[j]; p++) acc -= Lx[p] * z[Li[p] - j0];
    z[j - j0] = acc * invd[j];
  }
}

/* z = L22^-1 z (z: the nlast trailing values). Supernode by supernode from the first one that
   holds a trailing column: the part of its diagonal block on trailing columns, then the rows
   below (all trailing). Simplicial LL': column by column. */
static void trail_lsolve(chol_state *s, double *z)
{
  const cholmod_factor *L = s->L;
  const double *Lx = L->x;
  sslong nI = (sslong)s->n - s->nlast;
  static const int one = 1;
  if (!L->is_super) {
    simplicial_lsolve(L, s->invd, nI, z);
    return;
  }
  {
    const sslong *super = L->super, *Lpi = L->pi, *Lpx = L->px, *Ls = L->s;
    long k;
    for (k = s->s0; k < (long)L->nsuper; k++) {
      sslong k1 = super[k], k2 = super[k + 1], j0 = k1 > nI ? k1 : nI, r;
      int nsrow = (int)(Lpi[k + 1] - Lpi[k]), nscol = (int)(k2 - k1), off = (int)(j0 - k1), nc = (int)(k2 - j0);
      int nb = nsrow - nscol;
      const double *X = Lx + Lpx[k];
      double *zs = z + (j0 - nI);
      static const double m1 = -1, zero = 0, pone = 1;
      dtrsv_("L", "N", "N", &nc, X + off + (size_t)off * nsrow, &nsrow, zs, &one);
      if (nb > 0) {
        dgemv_("N", &nb, &nc, &pone, X + nscol + (size_t)off * nsrow, &nsrow, zs, &one, &zero, s->tmp, &one);
        for (r = 0; r < nb; r++) z[Ls[Lpi[k] + nscol + r] - nI] += m1 * s->tmp[r];
      }
    }
  }
}

/* z = L22^-T z, in the reverse order of trail_lsolve. */
static void trail_ltsolve(chol_state *s, double *z)
{
  const cholmod_factor *L = s->L;
  const double *Lx = L->x;
  sslong nI = (sslong)s->n - s->nlast;
  static const int one = 1;
  if (!L->is_super) {
    simplicial_ltsolve(L, s->invd, nI, z);
    return;
  }
  {
    const sslong *super = L->super, *Lpi = L->pi, *Lpx = L->px, *Ls = L->s;
    long k;
    for (k = (long)L->nsuper - 1; k >= s->s0; k--) {
      sslong k1 = super[k], k2 = super[k + 1], j0 = k1 > nI ? k1 : nI, r;
      int nsrow = (int)(Lpi[k + 1] - Lpi[k]), nscol = (int)(k2 - k1), off = (int)(j0 - k1), nc = (int)(k2 - j0);
      int nb = nsrow - nscol;
      const double *X = Lx + Lpx[k];
      double *zs = z + (j0 - nI);
      static const double m1 = -1, pone = 1;
      if (nb > 0) {
        for (r = 0; r < nb; r++) s->tmp[r] = z[Ls[Lpi[k] + nscol + r] - nI];
        dgemv_("T", &nb, &nc, &m1, X + nscol + (size_t)off * nsrow, &nsrow, s->tmp, &one, &pone, zs, &one);
      }
      dtrsv_("L", "T", "N", &nc, X + off + (size_t)off * nsrow, &nsrow, zs, &one);
    }
  }
}

/* The split solves of mo_linsolver_split. */
static int chol_split(void *state, mo_split_op op, const double *in, double *out, mo_ctx *ctx)
{
  chol_state *s = state;
  const sslong *Perm = s->L->Perm;
  sslong k, n = s->n, nI = n - s->nlast;
  int st;
  if (!s->trailing) return mo_error(ctx, MO_EINTERNAL, "split solve on a factor without a trailing block");
  double t0 = mo_clock();
  switch (op) {
  case MO_SPLIT_FORWARD:           /* out = L^-1 P in */
    if (!s->L->is_super) {
      for (k = 0; k < n; k++) out[k] = in[Perm[k]];
      simplicial_lsolve(s->L, s->invd, 0, out);
      st = MO_OK;
    } else {
      for (k = 0; k < n; k++) s->w[k] = in[Perm[k]];
      st = chol_sys(s, CHOLMOD_L, 1, s->w, out, ctx);
    }
    s->t_fw += mo_clock() - t0;
    s->n_fw++;
    return st;
  case MO_SPLIT_BACKWARD:          /* out = P^T L^-T in */
    if (!s->L->is_super) {
      memcpy(s->w, in, (size_t)n * sizeof *s->w);
      simplicial_ltsolve(s->L, s->invd, 0, s->w);
    } else if ((st = chol_sys(s, CHOLMOD_Lt, 1, in, s->w, ctx)))
      return st;
    for (k = 0; k < n; k++) out[Perm[k]] = s->w[k];
    s->t_bw += mo_clock() - t0;
    s->n_bw++;
    return MO_OK;
  case MO_SPLIT_TRAIL_FORWARD:     /* out = L22^-1 in (nlast values) */
    if (out != in) memcpy(out, in, (size_t)s->nlast * sizeof *out);
    trail_lsolve(s, out);
    return MO_OK;
  case MO_SPLIT_TRAIL_BACKWARD:    /* out = L22^-T in */
    if (out != in) memcpy(out, in, (size_t)s->nlast * sizeof *out);
    trail_ltsolve(s, out);
    return MO_OK;
  }
  (void)nI;
  return mo_error(ctx, MO_EINTERNAL, "split solve %d", (int)op);
}

/* G = (L22 L22^T)^-1 = (A^-1)_CC (nlast x nlast, column-major, both triangles): L22 copied out of
   the factor, then LAPACK's inverse from a Cholesky factor (T151). */
static int chol_schur_inverse(void *state, double *G, mo_ctx *ctx)
{
  chol_state *s = state;
  const cholmod_factor *L = s->L;
  const double *Lx = L->x;
  sslong nI = (sslong)s->n - s->nlast, j, p;
  size_t nC = (size_t)s->nlast, a, b;
  int n = s->nlast, info = 0;
  double flops = (double)n * n * n / 1.5;
  memset(G, 0, nC * nC * sizeof *G);
  if (!L->is_super) {
    const sslong *Lp = L->p, *Li = L->i, *Lnz = L->nz;
    for (j = nI; j < (sslong)s->n; j++)
      for (p = Lp[j]; p < Lp[j] + Lnz[j]; p++) G[(size_t)(Li[p] - nI) + (size_t)(j - nI) * nC] = Lx[p];
  } else {
    const sslong *super = L->super, *Lpi = L->pi, *Lpx = L->px, *Ls = L->s;
    long k;
    for (k = s->s0; k < (long)L->nsuper; k++) {
      sslong k1 = super[k], k2 = super[k + 1], nsrow = Lpi[k + 1] - Lpi[k], r;
      const double *X = Lx + Lpx[k];
      for (j = k1 > nI ? k1 : nI; j < k2; j++)
        for (r = j - k1; r < nsrow; r++) G[(size_t)(Ls[Lpi[k] + r] - nI) + (size_t)(j - nI) * nC] = X[r + (j - k1) * nsrow];
    }
  }
  if (flops > MO_BLAS_PARALLEL_FLOPS) mo_blas_threads(mo_blas_threads_max());
  if (n > 0) dpotri_("L", &n, G, &n, &info);
  mo_blas_threads(mo_blas_threads_base());
  if (info) return mo_error(ctx, MO_ESINGULAR, "the Schur complement on the contact dofs is singular (LAPACK dpotri %d)", info);
  for (b = 0; b < nC; b++)
    for (a = b + 1; a < nC; a++) G[b + a * nC] = G[a + b * nC];
  return MO_OK;
}

static void chol_info(const void *state, mo_linsolver_info *I)
{
  const chol_state *s = state;
  *I = s->info;
  if (!s->L) I->nnz_L = NAN;
  I->two_solves = s->n_fw && s->n_bw ? s->t_fw / s->n_fw + s->t_bw / s->n_bw : s->n_full ? s->t_full / s->n_full : NAN;
}

static void chol_free(void *state)
{
  chol_state *s = state;
  mo_free(s->last);
  mo_free(s->w);
  mo_free(s->tmp);
  mo_free(s->invd);
  if (!s->started) return;
  if (s->L) cholmod_l_free_factor(&s->L, &s->c);
  if (s->X) cholmod_l_free_dense(&s->X, &s->c);
  if (s->Y) cholmod_l_free_dense(&s->Y, &s->c);
  if (s->E) cholmod_l_free_dense(&s->E, &s->c);
  cholmod_l_finish(&s->c);
}

const mo_linsolver_type mo_linsolver_cholmod = {"cholmod", 1, sizeof(chol_state), chol_factor,
                                                chol_solve, chol_free, NULL, chol_set_last, chol_split,
                                                chol_schur_inverse, chol_info, NULL};

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
                                                umf_solve, umf_free, NULL, NULL, NULL, NULL, NULL, NULL};
