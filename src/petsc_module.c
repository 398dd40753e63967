/* petsc_module.c: moreau's PETSc module (moreau_petsc.so; petsc_module.h): MPI's start and
   collective calls, and the linear-solver type over PETSc's KSP on every rank (doc/parallel.md
   §2): the matrix distributed by rows, replicated right-hand sides in, replicated solutions out. */
#include "config.h"
#include "petsc_module.h"
#include <moreau/mesh.h>

#include <petscksp.h>
#include <dmumps_c.h>
#include <mpi.h>
#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <sys/statvfs.h>
#include <unistd.h>

/* The library that loaded the module: set once by start, read-only after (the module has no
   other state of its own; PETSc's is process-wide by design). */
static const mo_petsc_host *H;

static int module_error(mo_ctx *ctx, int code, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static int module_error(mo_ctx *ctx, int code, const char *fmt, ...)
{
  va_list ap;
  int rc;
  va_start(ap, fmt);
  rc = H->verror(ctx, code, fmt, ap);
  va_end(ap);
  return rc;
}
#define mo_error module_error
#define mo_malloc(ctx, n) H->malloc_(ctx, n)
#define mo_calloc(ctx, c, s) H->calloc_(ctx, c, s)
#define mo_free(p) H->free_(p)
#define mo_csc_transpose(A, T, ctx) H->csc_transpose(A, T, ctx)
#define mo_csc_free(A) H->csc_free(A)
#define mo_clock() H->clock()
#define mo_memory_rss() H->memory_rss()
#define mo_memory_limit() H->memory_limit()
#define mo_log H->log
#define mo_order_last H->order_last
#define mo_order_last_set H->order_last_set

/* --- MPI ---------------------------------------------------------------------------------------- */

static int started(void)
{
  PetscBool up = PETSC_FALSE;
  PetscInitialized(&up);
  return up == PETSC_TRUE;
}

static int start(const mo_petsc_host *host, int *rank, int *nranks, mo_ctx *ctx)
{
  PetscMPIInt r = 0, n = 1;
  H = host;
  if (!started()) {
    /* PETSc reads its options from the command line only when given one: moreau's own
       arguments are not PETSc's (linear_solver.options carries those) */
    int zero = 0;
    char **none = NULL;
    if (PetscInitialize(&zero, &none, NULL, NULL))
      return mo_error(ctx, MO_EUNSUPPORTED, "PETSc could not be started (PetscInitialize failed)");
  }
  MPI_Comm_rank(PETSC_COMM_WORLD, &r);
  MPI_Comm_size(PETSC_COMM_WORLD, &n);
  *rank = r;
  *nranks = n;
  return MO_OK;
}

static void finish(void)
{
  if (started()) PetscFinalize();
}

/* Account one collective call of `bytes` sent by this rank. */
static void traffic(mo_ctx *ctx, double t0, double bytes)
{
  ctx->par_calls++;
  ctx->par_time += mo_clock() - t0;
  ctx->par_bytes += bytes;
}

static int mpi_fail(mo_ctx *ctx, int rc, const char *what)
{
  char msg[MPI_MAX_ERROR_STRING];
  int len = 0;
  MPI_Error_string(rc, msg, &len);
  return mo_error(ctx, MO_EINTERNAL, "MPI %s failed: %.*s", what, len, msg);
}

static int allreduce(double *x, long n, int op, mo_ctx *ctx)
{
  double t0 = mo_clock();
  long k = 0;
  int rc;
  /* in chunks that an int count holds */
  while (k < n) {
    int m = n - k > (1L << 30) ? 1 << 30 : (int)(n - k);
    if ((rc = MPI_Allreduce(MPI_IN_PLACE, x + k, m, MPI_DOUBLE, op ? MPI_MAX : MPI_SUM, PETSC_COMM_WORLD)) !=
        MPI_SUCCESS)
      return mpi_fail(ctx, rc, op ? "maximum" : "sum");
    k += m;
  }
  traffic(ctx, t0, 8.0 * (double)n);
  return MO_OK;
}

static int bcast(void *buf, long bytes, int root, mo_ctx *ctx)
{
  double t0 = mo_clock();
  int rc;
  if (bytes > 0x7fffffffL) return mo_error(ctx, MO_ELIMIT, "MPI broadcast of %ld bytes", bytes);
  if ((rc = MPI_Bcast(buf, (int)bytes, MPI_BYTE, root, PETSC_COMM_WORLD)) != MPI_SUCCESS)
    return mpi_fail(ctx, rc, "broadcast");
  traffic(ctx, t0, ctx->rank == root ? (double)bytes : 0);
  return MO_OK;
}

/* The ranks' blocks of n[r] values to every rank (root < 0) or to root only. */
static int gather_blocks(const double *mine, const int *n, double *all, int root, mo_ctx *ctx)
{
  double t0 = mo_clock();
  int *displ, r, rc;
  long tot = 0;
  if (!(displ = mo_malloc(ctx, (size_t)ctx->nranks * sizeof *displ))) return MO_ENOMEM;
  for (r = 0; r < ctx->nranks; r++) {
    displ[r] = (int)tot;
    tot += n[r];
  }
  if (tot > 0x7fffffffL) {
    mo_free(displ);
    return mo_error(ctx, MO_ELIMIT, "MPI gather of %ld values", tot);
  }
  rc = root < 0 ? MPI_Allgatherv(mine, n[ctx->rank], MPI_DOUBLE, all, n, displ, MPI_DOUBLE, PETSC_COMM_WORLD)
                : MPI_Gatherv(mine, n[ctx->rank], MPI_DOUBLE, all, n, displ, MPI_DOUBLE, root, PETSC_COMM_WORLD);
  mo_free(displ);
  if (rc != MPI_SUCCESS) return mpi_fail(ctx, rc, "gather");
  traffic(ctx, t0, 8.0 * n[ctx->rank]);
  return MO_OK;
}

static int allgatherv(const double *mine, const int *n, double *all, mo_ctx *ctx)
{
  return gather_blocks(mine, n, all, -1, ctx);
}

static int gatherv0(const double *mine, const int *n, double *all, mo_ctx *ctx)
{
  return gather_blocks(mine, n, all, 0, ctx);
}

static int agree(int st, mo_ctx *ctx)
{
  /* (status, -rank) pairs: the largest status, and the lowest rank that has it */
  int in[2], out[2], rc, from;
  char msg[MO_ERRMSG_MAX];
  double t0 = mo_clock();
  in[0] = st;
  in[1] = -ctx->rank;
  if ((rc = MPI_Allreduce(in, out, 1, MPI_2INT, MPI_MAXLOC, PETSC_COMM_WORLD)) != MPI_SUCCESS)
    return mpi_fail(ctx, rc, "status agreement");
  if (out[0] == MO_OK) {
    traffic(ctx, t0, 8);
    return MO_OK;
  }
  /* the failing rank's message, for every rank's diagnosis */
  from = -out[1];
  if (ctx->rank == from) snprintf(msg, sizeof msg, "%s", ctx->errmsg);
  if ((rc = MPI_Bcast(msg, (int)sizeof msg, MPI_CHAR, from, PETSC_COMM_WORLD)) != MPI_SUCCESS)
    return mpi_fail(ctx, rc, "status agreement");
  traffic(ctx, t0, 8.0 + (ctx->rank == from ? (double)sizeof msg : 0));
  msg[sizeof msg - 1] = 0;
  if (st != MO_OK) return st;
  return mo_error(ctx, out[0], "rank %d stopped: %s", from, msg);
}

static int exchange(int npeer, const int *peer, const int *off, const double *send, double *recv, mo_ctx *ctx)
{
  MPI_Request few[32], *req = few;
  double t0 = mo_clock();
  int k, rc = MPI_SUCCESS;
  if (npeer > 16 && !(req = mo_malloc(ctx, 2 * (size_t)npeer * sizeof *req))) return MO_ENOMEM;
  for (k = 0; k < npeer && rc == MPI_SUCCESS; k++)
    rc = MPI_Irecv(recv + off[k], off[k + 1] - off[k], MPI_DOUBLE, peer[k], 0x6d6f, PETSC_COMM_WORLD, req + k);
  for (k = 0; k < npeer && rc == MPI_SUCCESS; k++)
    rc = MPI_Isend((void *)(send + off[k]), off[k + 1] - off[k], MPI_DOUBLE, peer[k], 0x6d6f, PETSC_COMM_WORLD,
                   req + npeer + k);
  if (rc == MPI_SUCCESS) rc = MPI_Waitall(2 * npeer, req, MPI_STATUSES_IGNORE);
  if (req != few) mo_free(req);
  if (rc != MPI_SUCCESS) return mpi_fail(ctx, rc, "exchange");
  traffic(ctx, t0, 8.0 * off[npeer]);
  return MO_OK;
}

static int alltoall(const double *send, double *recv, mo_ctx *ctx)
{
  double t0 = mo_clock();
  int rc = MPI_Alltoall((void *)send, 1, MPI_DOUBLE, recv, 1, MPI_DOUBLE, PETSC_COMM_WORLD);
  if (rc != MPI_SUCCESS) return mpi_fail(ctx, rc, "all-to-all");
  traffic(ctx, t0, 8.0 * ctx->nranks);
  return MO_OK;
}

static int exchangev(int nsend, const int *speer, const int *soff, const double *send, int nrecv, const int *rpeer,
                     const int *roff, double *recv, mo_ctx *ctx)
{
  MPI_Request few[32], *req = few;
  double t0 = mo_clock();
  int k, rc = MPI_SUCCESS;
  if (nsend + nrecv > 32 && !(req = mo_malloc(ctx, (size_t)(nsend + nrecv) * sizeof *req))) return MO_ENOMEM;
  for (k = 0; k < nrecv && rc == MPI_SUCCESS; k++)
    rc = MPI_Irecv(recv + roff[k], roff[k + 1] - roff[k], MPI_DOUBLE, rpeer[k], 0x6d70, PETSC_COMM_WORLD, req + k);
  for (k = 0; k < nsend && rc == MPI_SUCCESS; k++)
    rc = MPI_Isend((void *)(send + soff[k]), soff[k + 1] - soff[k], MPI_DOUBLE, speer[k], 0x6d70, PETSC_COMM_WORLD,
                   req + nrecv + k);
  if (rc == MPI_SUCCESS) rc = MPI_Waitall(nsend + nrecv, req, MPI_STATUSES_IGNORE);
  if (req != few) mo_free(req);
  if (rc != MPI_SUCCESS) return mpi_fail(ctx, rc, "exchange");
  traffic(ctx, t0, 8.0 * soff[nsend]);
  return MO_OK;
}

/* --- the linear-solver type ----------------------------------------------------------------------- */

typedef struct {
  int configured;
  char ksp[32], pc[32], package[32], options[1024];
  double rtol;
  int spd;
  int parts;                /* each rank gives its part of the matrix, which is their sum */
  Mat A;
  KSP ksp_obj;
  Vec b, x, xall;           /* distributed right-hand side and solution, the whole solution */
  VecScatter toall;
  int n, rstart, rend;      /* rows of this rank: rstart .. rend-1 */
  mo_csc *At;               /* the factored matrix by rows (its transpose), for the owned rows */
  long iterations;          /* Krylov iterations over the solves (0 for direct solves) */
  /* MUMPS directly (ksp preonly, pc cholesky or lu, package mumps): its factor F without a KSP,
     analysed apart from the numeric factorization so that the memory is checked in between,
     the contact dofs as its Schur variables (one rank), the factor on disk (T180)-(T182) */
  int direct;
  Mat F;
  int nlast, *last, last_new, schur;
  double reserve;
  int ooc;
  char ooc_base[512], ooc_dir[600];
  double t_solve;
  long n_solve;
  mo_linsolver_info info;
  /* one rank, Cholesky, the contact dofs last: MUMPS's own struct instead of F, given our order
     (PERM_IN: PETSc 3.18's Cholesky passes none, and with Schur variables MUMPS would order by
     AMD), the lower triangle's entries by coordinates, S dense by columns (T183) */
  int dm, dm_live, dm_inverted;
  DMUMPS_STRUC_C id;
  MUMPS_INT *irn, *jcn, *perm_in, *listvar;
  double *a, *S, *red;
  int red_cap;
  char ordname[96];
} petsc_state;

/* A PETSc error as moreau's: the call and PETSc's own message. */
static int petsc_fail(mo_ctx *ctx, PetscErrorCode e, const char *call)
{
  const char *text = NULL;
  PetscErrorMessage(e, &text, NULL);
  return mo_error(ctx, e == PETSC_ERR_MEM ? MO_ENOMEM : MO_EINTERNAL, "PETSc: %s failed: %s", call,
                  text ? text : "(no message)");
}
#define P(call)                                         \
  do {                                                  \
    PetscErrorCode e_ = (call);                         \
    if (e_) return petsc_fail(ctx, e_, #call);          \
  } while (0)

static int petsc_configure(void *state, const mo_linsolver_settings *set, mo_ctx *ctx)
{
  petsc_state *s = state;
  snprintf(s->ksp, sizeof s->ksp, "%s", set->ksp ? set->ksp : "preonly");
  snprintf(s->pc, sizeof s->pc, "%s", set->pc ? set->pc : (set->spd ? "cholesky" : "lu"));
  snprintf(s->package, sizeof s->package, "%s", set->package ? set->package : "mumps");
  snprintf(s->options, sizeof s->options, "%s", set->options ? set->options : "");
  s->rtol = set->rtol > 0 ? set->rtol : 1e-10;
  s->spd = set->spd;
  s->parts = set->parts;
  s->direct = !strcmp(s->ksp, "preonly") && (!strcmp(s->pc, "cholesky") || !strcmp(s->pc, "lu")) &&
              !strcmp(s->package, "mumps");
  s->ooc = set->out_of_core;
  {
    const char *t = getenv("TMPDIR");
    snprintf(s->ooc_base, sizeof s->ooc_base, "%s", set->ooc_dir && *set->ooc_dir ? set->ooc_dir : t && *t ? t : "/tmp");
  }
  s->configured = 1;
  if (s->ooc && !s->direct)
    return mo_error(ctx, MO_EINPUT, "linear_solver.out_of_core needs MUMPS's factorization (ksp \"preonly\", pc "
                    "\"cholesky\" or \"lu\", package \"mumps\"), not %s, %s, %s", s->ksp, s->pc, s->package);
  return MO_OK;
}

/* The KSP and its preconditioner from the settings, then PETSc's own options over them. */
static int make_ksp(petsc_state *s, mo_ctx *ctx)
{
  PC pc;
  P(KSPCreate(PETSC_COMM_WORLD, &s->ksp_obj));
  P(KSPSetType(s->ksp_obj, s->ksp));
  P(KSPGetPC(s->ksp_obj, &pc));
  P(PCSetType(pc, s->pc));
  if (!strcmp(s->pc, "lu") || !strcmp(s->pc, "cholesky")) P(PCFactorSetMatSolverType(pc, s->package));
  P(KSPSetTolerances(s->ksp_obj, s->rtol, PETSC_DEFAULT, PETSC_DEFAULT, PETSC_DEFAULT));
  /* an iterative solve starts from zero: a replicated start would need a scatter, and the
     stepper's unknowns change little enough between steps for the tolerance to decide */
  P(KSPSetInitialGuessNonzero(s->ksp_obj, PETSC_FALSE));
  if (s->options[0]) P(PetscOptionsInsertString(NULL, s->options));
  P(KSPSetFromOptions(s->ksp_obj));
  return MO_OK;
}

/* PETSc's split of n rows (PetscSplitOwnership): the rank that owns row i and its first row. */
static void split_owner(int n, int nranks, int i, int *lo, int *hi)
{
  int q = n / nranks, m = n % nranks, r;
  r = i < m * (q + 1) ? i / (q + 1) : m + (i - m * (q + 1)) / (q > 0 ? q : 1);
  *lo = r * q + (r < m ? r : m);
  *hi = *lo + q + (r < m);
}

/* The matrix of the sum of the ranks' parts (K and M in parts, doc/parallel.md §3): each rank's
   entries of row i counted in or out of the diagonal block of i's owner, the counts summed over
   the ranks (an entry that two ranks hold is counted twice: the interfaces' rows are
   preallocated a little over), then each rank its own rows'. */
/* The preallocation of s->A (dn, on: nonzeros a local row in the diagonal and off-diagonal
   blocks) and what every distributed matrix then takes: SPD where it is, no new nonzero, the
   vectors and the scatter to every rank. */
static int finish_matrix(petsc_state *s, const PetscInt *dn, const PetscInt *on, mo_ctx *ctx)
{
  PetscErrorCode e = MatSeqAIJSetPreallocation(s->A, 0, dn);
  if (!e) e = MatMPIAIJSetPreallocation(s->A, 0, dn, 0, on);
  if (e) return petsc_fail(ctx, e, "MatMPIAIJSetPreallocation");
  if (s->spd) P(MatSetOption(s->A, MAT_SPD, PETSC_TRUE));
  P(MatSetOption(s->A, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE));
  P(MatCreateVecs(s->A, &s->x, &s->b));
  P(VecScatterCreateToAll(s->x, &s->toall, &s->xall));
  return MO_OK;
}

static int make_matrix_parts(petsc_state *s, const mo_csc *A, mo_ctx *ctx)
{
  int n = s->n, j, p, lo, hi, nloc = s->rend - s->rstart, st;
  PetscInt *cnt, *dn, *on, i;
  if (!(cnt = mo_calloc(ctx, 2 * (size_t)n + 1, sizeof *cnt))) return MO_ENOMEM;
  for (j = 0; j < n; j++)
    for (p = A->p[j]; p < A->p[j + 1]; p++) {
      split_owner(n, ctx->nranks, A->i[p], &lo, &hi);
      cnt[2 * A->i[p] + (j < lo || j >= hi)]++;
    }
  if (MPI_Allreduce(MPI_IN_PLACE, cnt, 2 * n, MPIU_INT, MPI_SUM, PETSC_COMM_WORLD) != MPI_SUCCESS) {
    mo_free(cnt);
    return mo_error(ctx, MO_EINTERNAL, "MPI_Allreduce failed while counting the rows");
  }
  dn = cnt + 2 * s->rstart; /* packed below as dn[0 .. nloc-1], on[0 .. nloc-1] */
  if (!(on = mo_malloc(ctx, ((size_t)nloc + 1) * sizeof *on))) {
    mo_free(cnt);
    return MO_ENOMEM;
  }
  for (i = 0; i < nloc; i++) {
    PetscInt d = dn[2 * i], o = dn[2 * i + 1];
    dn[i] = d < nloc ? d : nloc;
    on[i] = o < n - nloc ? o : n - nloc;
  }
  st = finish_matrix(s, dn, on, ctx);
  mo_free(cnt);
  mo_free(on);
  return st;
}

/* This rank's part added column by column (the rows of other ranks through PETSc's stash). */
static int add_parts(petsc_state *s, const mo_csc *A, mo_ctx *ctx)
{
  PetscInt j, *rows = NULL;
  int cap = 0;
  for (j = 0; j < A->ncol; j++) {
    int nz = A->p[j + 1] - A->p[j], k;
    if (!nz) continue;
    if (nz > cap) {
      mo_free(rows);
      cap = nz;
      if (!(rows = mo_malloc(ctx, (size_t)cap * sizeof *rows))) return MO_ENOMEM;
    }
    for (k = 0; k < nz; k++) rows[k] = A->i[A->p[j] + k];
    {
      PetscErrorCode e = MatSetValues(s->A, nz, rows, 1, &j, A->x + A->p[j], ADD_VALUES);
      if (e) {
        mo_free(rows);
        return petsc_fail(ctx, e, "MatSetValues");
      }
    }
  }
  mo_free(rows);
  return MO_OK;
}

/* The distributed matrix with the pattern of A: each rank preallocates and owns a contiguous
   block of rows (PETSc's split), filled from the rows of A (the columns of A^T). */
static int make_matrix(petsc_state *s, const mo_csc *A, mo_ctx *ctx)
{
  PetscInt *dn = NULL, *on = NULL, n = A->nrow, r;
  int st;
  const mo_csc *T;
  mo_csc_free(s->At);
  s->At = NULL;
  if (!s->parts && (st = mo_csc_transpose(A, &s->At, ctx))) return st;
  T = s->At;
  {
    /* PETSc's split of the rows: contiguous blocks, the first ranks one row more */
    PetscInt nloc = PETSC_DECIDE, N = n, end = 0;
    P(PetscSplitOwnership(PETSC_COMM_WORLD, &nloc, &N));
    if (MPI_Scan(&nloc, &end, 1, MPIU_INT, MPI_SUM, PETSC_COMM_WORLD) != MPI_SUCCESS)
      return mo_error(ctx, MO_EINTERNAL, "MPI_Scan failed while splitting the rows");
    s->rstart = (int)(end - nloc);
    s->rend = (int)end;
    P(MatCreate(PETSC_COMM_WORLD, &s->A));
    P(MatSetSizes(s->A, nloc, nloc, n, n));
    P(MatSetType(s->A, MATAIJ));
  }
  s->n = (int)n;
  if (s->parts) return make_matrix_parts(s, A, ctx);
  if (!(dn = mo_calloc(ctx, (size_t)(s->rend - s->rstart) + 1, sizeof *dn)) ||
      !(on = mo_calloc(ctx, (size_t)(s->rend - s->rstart) + 1, sizeof *on))) {
    mo_free(dn);
    return MO_ENOMEM;
  }
  for (r = s->rstart; r < s->rend; r++) {
    int p;
    for (p = T->p[r]; p < T->p[r + 1]; p++)
      if (T->i[p] >= s->rstart && T->i[p] < s->rend) dn[r - s->rstart]++;
      else on[r - s->rstart]++;
  }
  st = finish_matrix(s, dn, on, ctx);
  mo_free(dn);
  mo_free(on);
  return st;
}

static void dm_drop(petsc_state *s);

static void drop(petsc_state *s)
{
  if (s->F) MatDestroy(&s->F);
  dm_drop(s);
  if (s->ksp_obj) KSPDestroy(&s->ksp_obj);
  if (s->A) MatDestroy(&s->A);
  if (s->b) VecDestroy(&s->b);
  if (s->x) VecDestroy(&s->x);
  if (s->xall) VecDestroy(&s->xall);
  if (s->toall) VecScatterDestroy(&s->toall);
}

/* --- MUMPS directly: the contact dofs as its Schur variables, the factor out of core ------------

   With ksp preonly and a direct pc by MUMPS, the module drives the factor F itself (MatGetFactor,
   the symbolic then the numeric factorization apart) instead of a KSP: between the two, MUMPS's
   own estimates of the memory (INFOG(17) in core, INFOG(27) out of core, in MB = 1e6 bytes, over
   the ranks) are checked against what the run may take, and the run is refused with the figures
   before the hour-long numeric factorization when even out of core does not fit (T181). The
   contact dofs ordered last become MUMPS's Schur variables (ICNTL(19)): for a Cholesky factor
   through MUMPS's own struct in CHOLMOD's order (dm_*, (T183)), for LU through PETSc's
   MatFactorSetSchurIS. The numeric factorization leaves S = A_CC - A_CI A_II^-1 A_IC dense,
   inverted in place (LAPACK's Cholesky and its inverse, potrf and potri), and G = S^-1 =
   (A^-1)_CC is W's middle factor as CHOLMOD's L22 gives it (T150)-(T151), with no solve per
   column. PETSc 3.18 refuses
   Schur complements on more than one rank ("MUMPS distributed parallel Schur complements not yet
   supported from PETSc"): there the contact dofs are not ordered and W is built by solves. The
   whole solves stay: MUMPS condenses on S, the product with G, MUMPS expands (ICNTL(26) 1 and
   2); MUMPS keeps the condensed interior right-hand side inside between the two, so the split
   solves of (T153) (a forward solve kept and summed with an impulse's) have no counterpart and
   the type has none (T180). Out of core (ICNTL(22) = 1) MUMPS writes the factor to files under
   MUMPS_OOC_TMPDIR: a folder of this solver's own, made under ooc_dir, emptied and removed when
   the solver is freed (the end of a run, a failure, or an interrupted run's end) (T182). */

/* MUMPS's INFOG(k), with its negative counts in millions. */
static double infog(Mat F, PetscInt k)
{
  PetscInt v = 0;
  if (MatMumpsGetInfog(F, k, &v)) return NAN;
  return v < 0 ? -1e6 * (double)v : (double)v;
}

static int ooc_folder(petsc_state *s, mo_ctx *ctx)
{
  if (s->ooc_dir[0]) return MO_OK;
  snprintf(s->ooc_dir, sizeof s->ooc_dir, "%s/moreau-ooc.XXXXXX", s->ooc_base);
  if (!mkdtemp(s->ooc_dir)) {
    int e = errno;
    s->ooc_dir[0] = 0;
    return mo_error(ctx, MO_EIO, "linear_solver.ooc_dir: no folder for the out-of-core factor could be made in '%s': %s",
                    s->ooc_base, strerror(e));
  }
  if (setenv("MUMPS_OOC_TMPDIR", s->ooc_dir, 1))
    return mo_error(ctx, MO_EINTERNAL, "MUMPS_OOC_TMPDIR could not be set");
  return MO_OK;
}

/* MUMPS removes its files when F is destroyed; what a failed factorization left goes here. */
static void ooc_remove(petsc_state *s)
{
  DIR *d;
  struct dirent *e;
  char path[1200];
  if (!s->ooc_dir[0]) return;
  if ((d = opendir(s->ooc_dir))) {
    while ((e = readdir(d)))
      if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..")) {
        snprintf(path, sizeof path, "%s/%s", s->ooc_dir, e->d_name);
        unlink(path);
      }
    closedir(d);
  }
  rmdir(s->ooc_dir);
  s->ooc_dir[0] = 0;
}

/* --- MUMPS's own struct: the Schur path in our order (T183) ------------------------------------ */

#define ICNTL(I) icntl[(I) - 1]
#define INFOG(I) infog[(I) - 1]
#define RINFOG(I) rinfog[(I) - 1]

extern void dpotrf_(const char *uplo, const int *n, double *a, const int *lda, int *info);
extern void dpotri_(const char *uplo, const int *n, double *a, const int *lda, int *info);
extern void dsymm_(const char *side, const char *uplo, const int *m, const int *n, const double *alpha,
                   const double *a, const int *lda, const double *b, const int *ldb, const double *beta, double *c,
                   const int *ldc);

/* INFOG(k) of the struct, its negative counts in millions. */
static double dm_infog(const petsc_state *s, int k)
{
  MUMPS_INT v = s->id.infog[k - 1];
  return v < 0 ? -1e6 * (double)v : (double)v;
}

static void dm_drop(petsc_state *s)
{
  if (s->dm_live) {
    s->id.job = -2;
    dmumps_c(&s->id);
    s->dm_live = 0;
  }
  mo_free(s->irn);
  mo_free(s->jcn);
  mo_free(s->a);
  mo_free(s->perm_in);
  mo_free(s->listvar);
  mo_free(s->S);
  mo_free(s->red);
  s->irn = s->jcn = s->perm_in = s->listvar = NULL;
  s->a = s->S = s->red = NULL;
  s->red_cap = 0;
  s->dm = s->dm_inverted = 0;
}

/* The lower triangle's values of A (both triangles stored) in the order of irn and jcn. */
static void dm_values(petsc_state *s, const mo_csc *A)
{
  int j, p;
  long q = 0;
  for (j = 0; j < A->ncol; j++)
    for (p = A->p[j]; p < A->p[j + 1]; p++)
      if (A->i[p] >= j) s->a[q++] = A->x[p];
}

/* The analysis with PERM_IN = CHOLMOD's order with the contact dofs last (mo_order_last), the
   contact dofs MUMPS's Schur variables (ICNTL(19) = 3), and MUMPS's estimates (T181), (T183). */
static int dm_analyze(petsc_state *s, const mo_csc *A, mo_ctx *ctx)
{
  int j, p, k, n = A->ncol, *perm = NULL, st = MO_OK;
  long nz = 0, q = 0;
  const char *ord = "?";
  double t0 = mo_clock();
  dm_drop(s);
  s->dm = 1;
  s->last_new = 0;
  if (s->ooc && (st = ooc_folder(s, ctx))) return st;
  for (j = 0; j < n; j++)
    for (p = A->p[j]; p < A->p[j + 1]; p++) nz += A->i[p] >= j;
  if (!(s->irn = mo_malloc(ctx, ((size_t)nz + 1) * sizeof *s->irn)) ||
      !(s->jcn = mo_malloc(ctx, ((size_t)nz + 1) * sizeof *s->jcn)) ||
      !(s->a = mo_malloc(ctx, ((size_t)nz + 1) * sizeof *s->a)) ||
      !(s->perm_in = mo_malloc(ctx, ((size_t)n + 1) * sizeof *s->perm_in)) ||
      !(s->listvar = mo_malloc(ctx, ((size_t)s->nlast + 1) * sizeof *s->listvar)) ||
      !(perm = mo_malloc(ctx, ((size_t)n + 1) * sizeof *perm)))
    { st = MO_ENOMEM; goto done; }
  for (j = 0; j < n; j++)
    for (p = A->p[j]; p < A->p[j + 1]; p++)
      if (A->i[p] >= j) {
        s->irn[q] = A->i[p] + 1;
        s->jcn[q++] = j + 1;
      }
  if ((st = mo_order_last(A, s->nlast, s->last, perm, &ord, ctx))) goto done;
  /* PERM_IN(i): the position of variable i in the pivot order, from 1 */
  for (k = 0; k < n; k++) s->perm_in[perm[k]] = k + 1;
  for (k = 0; k < s->nlast; k++) s->listvar[k] = s->last[k] + 1;
  memset(&s->id, 0, sizeof s->id);
  s->id.job = -1;
  s->id.par = 1;
  s->id.sym = 1;
  s->id.comm_fortran = (MUMPS_INT)MPI_Comm_c2f(PETSC_COMM_SELF);
  dmumps_c(&s->id);
  if (s->id.INFOG(1) < 0) {
    st = mo_error(ctx, MO_EINTERNAL, "MUMPS's initialization failed (INFOG(1) = %g)", dm_infog(s, 1));
    goto done;
  }
  s->dm_live = 1;
  s->id.ICNTL(1) = s->id.ICNTL(2) = s->id.ICNTL(3) = -1;
  s->id.ICNTL(4) = 0;
  s->id.n = n;
  s->id.nnz = nz;
  s->id.irn = s->irn;
  s->id.jcn = s->jcn;
  s->id.a = s->a;
  s->id.ICNTL(7) = 1;
  s->id.perm_in = s->perm_in;
  s->id.ICNTL(19) = 3;
  s->id.size_schur = s->nlast;
  s->id.listvar_schur = s->listvar;
  s->id.ICNTL(22) = s->ooc;
  if (s->ooc) {
    size_t len = strlen(s->ooc_dir);
    if (len >= sizeof s->id.ooc_tmpdir) {
      st = mo_error(ctx, MO_EINPUT, "linear_solver.ooc_dir: the folder '%s' is longer than MUMPS takes (%d characters)",
                    s->ooc_dir, (int)sizeof s->id.ooc_tmpdir - 1);
      goto done;
    }
    memcpy(s->id.ooc_tmpdir, s->ooc_dir, len + 1);
  }
  s->id.job = 1;
  dmumps_c(&s->id);
  if (s->id.INFOG(1) < 0) {
    st = mo_error(ctx, MO_EINTERNAL, "MUMPS's analysis failed (INFOG(1) = %g, INFOG(2) = %g)", dm_infog(s, 1),
                  dm_infog(s, 2));
    goto done;
  }
  s->info.nnz_L = dm_infog(s, 20);
  s->info.flops = s->id.RINFOG(1);
  s->info.bytes_in_core = 1e6 * dm_infog(s, 17);
  s->info.bytes_out_of_core = 1e6 * dm_infog(s, 27);
  s->info.bytes_factor = 8 * s->info.nnz_L;
  s->info.bytes_work = s->ooc ? s->info.bytes_out_of_core : s->info.bytes_in_core;
  s->info.out_of_core = s->ooc;
  /* INFOG(7) = 1: MUMPS took the order given */
  snprintf(s->ordname, sizeof s->ordname, "%s, given to mumps (INFOG(7) = %d)", ord, (int)s->id.INFOG(7));
  s->info.ordering = s->ordname;
  s->schur = 1;
done:
  s->info.t_analyze += mo_clock() - t0;
  mo_free(perm);
  return st;
}

/* The numeric factorization: S = A_CC - A_CI A_II^-1 A_IC dense in s->S (T150). */
static int dm_numeric(petsc_state *s, const mo_csc *A, mo_ctx *ctx)
{
  size_t nC = (size_t)s->nlast;
  double t0 = mo_clock();
  mo_free(s->S);
  if (!(s->S = mo_calloc(ctx, nC * nC + 1, sizeof *s->S))) return MO_ENOMEM;
  dm_values(s, A);
  s->id.schur = s->S;
  s->id.schur_lld = s->nlast;
  s->id.nprow = s->id.npcol = 1;
  s->id.mblock = s->id.nblock = s->nlast;
  s->id.job = 2;
  dmumps_c(&s->id);
  s->info.t_numeric = mo_clock() - t0;
  s->dm_inverted = 0;
  if (s->id.INFOG(1) == -10)
    return mo_error(ctx, MO_ESINGULAR, "factorization by MUMPS: a zero pivot: the matrix is singular (a body free to "
                    "move rigidly with zero mass, or a missing support)");
  if (s->id.INFOG(1) == -9 || s->id.INFOG(1) == -13 || s->id.INFOG(1) == -19)
    return mo_error(ctx, MO_ENOMEM, "factorization by MUMPS: out of memory (INFOG(1) = %g, INFOG(2) = %g)",
                    dm_infog(s, 1), dm_infog(s, 2));
  if (s->id.INFOG(1) < 0)
    return mo_error(ctx, MO_EINTERNAL, "factorization by MUMPS failed (INFOG(1) = %g, INFOG(2) = %g)", dm_infog(s, 1),
                    dm_infog(s, 2));
  s->info.nlast = s->nlast;
  s->info.trailing = 1;
  return MO_OK;
}

/* S^-1 in place, both triangles: MUMPS gives one triangle of S (which one: the one it filled,
   the other left zero), LAPACK's Cholesky and its inverse (T151). */
static int dm_invert(petsc_state *s, mo_ctx *ctx)
{
  size_t nC = (size_t)s->nlast, a, b;
  int n = s->nlast, info = 0, upper = 0, lower = 0;
  double *S = s->S;
  if (s->dm_inverted) return MO_OK;
  for (b = 0; b < nC; b++)
    for (a = b + 1; a < nC; a++) {
      upper |= S[b + a * nC] != 0;
      lower |= S[a + b * nC] != 0;
    }
  if (upper && !lower)
    for (b = 0; b < nC; b++)
      for (a = b + 1; a < nC; a++) S[a + b * nC] = S[b + a * nC];
  if (n > 0) dpotrf_("L", &n, S, &n, &info);
  if (!info && n > 0) dpotri_("L", &n, S, &n, &info);
  if (info)
    return mo_error(ctx, MO_ESINGULAR, "MUMPS's Schur complement on the contact dofs is singular (LAPACK %d)", info);
  for (b = 0; b < nC; b++)
    for (a = b + 1; a < nC; a++) S[b + a * nC] = S[a + b * nC];
  for (a = 0; a < nC * nC; a++)
    if (!isfinite(S[a])) return mo_error(ctx, MO_ENAN, "the inverse of MUMPS's Schur complement holds a NaN");
  s->dm_inverted = 1;
  return MO_OK;
}

/* X = A^-1 B (nrhs columns of n): MUMPS condenses on the Schur variables (ICNTL(26) = 1), the
   condensed right-hand side times S^-1, then MUMPS expands (ICNTL(26) = 2) (T180). */
static int dm_solve(petsc_state *s, int nrhs, const double *B, double *X, mo_ctx *ctx)
{
  int st, n = s->nlast;
  size_t need = (size_t)s->nlast * (size_t)nrhs;
  double one = 1, zero = 0, t0 = mo_clock(), *y;
  if (!nrhs) return MO_OK;
  if ((st = dm_invert(s, ctx))) return st;
  if ((size_t)s->red_cap < need) {
    mo_free(s->red);
    s->red_cap = 0;
    if (!(s->red = mo_malloc(ctx, (2 * need + 1) * sizeof *s->red))) return MO_ENOMEM;
    s->red_cap = (int)need;
  }
  y = s->red + need;
  if (X != B) memcpy(X, B, (size_t)s->n * (size_t)nrhs * sizeof *X);
  s->id.rhs = X;
  s->id.nrhs = nrhs;
  s->id.lrhs = s->n;
  s->id.redrhs = s->red;
  s->id.lredrhs = s->nlast;
  s->id.ICNTL(26) = 1;
  s->id.job = 3;
  dmumps_c(&s->id);
  if (s->id.INFOG(1) < 0)
    return mo_error(ctx, MO_EINTERNAL, "MUMPS's condensed solve failed (INFOG(1) = %g, INFOG(2) = %g)", dm_infog(s, 1),
                    dm_infog(s, 2));
  if (n > 0) {
    dsymm_("L", "L", &n, &nrhs, &one, s->S, &n, s->red, &n, &zero, y, &n);
    memcpy(s->red, y, need * sizeof *y);
  }
  s->id.ICNTL(26) = 2;
  dmumps_c(&s->id);
  s->id.ICNTL(26) = 0;
  if (s->id.INFOG(1) < 0)
    return mo_error(ctx, MO_EINTERNAL, "MUMPS's expansion failed (INFOG(1) = %g, INFOG(2) = %g)", dm_infog(s, 1),
                    dm_infog(s, 2));
  s->t_solve += (mo_clock() - t0) / nrhs;
  s->n_solve++;
  for (need = 0; need < (size_t)s->n * (size_t)nrhs; need++)
    if (!isfinite(X[need])) return mo_error(ctx, MO_ENAN, "a solve by MUMPS gave a NaN");
  return MO_OK;
}

static int petsc_set_last(void *state, int nlast, const int *last, double reserve, mo_ctx *ctx)
{
  petsc_state *s = state;
  s->reserve = reserve;
  if (nlast && (!s->direct || ctx->nranks > 1)) {
    /* W by solves: said once */
    if (!s->nlast && !s->last)
      mo_log(ctx, 2, "moreau: the Delassus operator by solves: MUMPS's Schur complement on the contact dofs %s\n",
             ctx->nranks > 1 ? "runs on one rank only (PETSc 3.18 refuses it on several)"
                             : "needs ksp preonly with a direct pc by MUMPS");
    nlast = 0;
  }
  return mo_order_last_set(nlast, last, &s->nlast, &s->last, &s->last_new, ctx);
}

/* The symbolic factorization, with the Schur variables, and MUMPS's estimates (T181). */
static int direct_analyze(petsc_state *s, mo_ctx *ctx)
{
  MatFactorInfo fi;
  int chol = !strcmp(s->pc, "cholesky"), k;
  double t0 = mo_clock(), ent;
  PetscReal fl = 0;
  if (s->F) MatDestroy(&s->F);
  s->schur = 0;
  s->last_new = 0;
  if (s->ooc) {
    int st = ooc_folder(s, ctx);
    if (st) return st;
  }
  /* MUMPS reads its options at the analysis: ours first, the case's over them */
  P(PetscOptionsSetValue(NULL, "-mat_mumps_icntl_22", s->ooc ? "1" : "0"));
  if (s->options[0]) P(PetscOptionsInsertString(NULL, s->options));
  P(MatGetFactor(s->A, MATSOLVERMUMPS, chol ? MAT_FACTOR_CHOLESKY : MAT_FACTOR_LU, &s->F));
  if (s->nlast) {
    IS is;
    PetscInt *idx;
    PetscErrorCode e;
    if (!(idx = mo_malloc(ctx, (size_t)s->nlast * sizeof *idx))) return MO_ENOMEM;
    for (k = 0; k < s->nlast; k++) idx[k] = s->last[k];
    e = ISCreateGeneral(PETSC_COMM_WORLD, s->nlast, idx, PETSC_COPY_VALUES, &is);
    mo_free(idx);
    if (e) return petsc_fail(ctx, e, "ISCreateGeneral");
    e = MatFactorSetSchurIS(s->F, is);
    ISDestroy(&is);
    if (e) return petsc_fail(ctx, e, "MatFactorSetSchurIS");
    s->schur = 1;
  }
  P(MatFactorInfoInitialize(&fi));
  if (chol) P(MatCholeskyFactorSymbolic(s->F, s->A, NULL, &fi));
  else P(MatLUFactorSymbolic(s->F, s->A, NULL, NULL, &fi));
  if (infog(s->F, 1) < 0)
    return mo_error(ctx, MO_EINTERNAL, "MUMPS's analysis failed (INFOG(1) = %g, INFOG(2) = %g)", infog(s->F, 1),
                    infog(s->F, 2));
  ent = infog(s->F, 20);
  MatMumpsGetRinfog(s->F, 1, &fl);
  s->info.nnz_L = ent;
  s->info.flops = fl;
  s->info.bytes_in_core = 1e6 * infog(s->F, 17);
  s->info.bytes_out_of_core = 1e6 * infog(s->F, 27);
  s->info.bytes_factor = 8 * ent;
  s->info.bytes_work = s->ooc ? s->info.bytes_out_of_core : s->info.bytes_in_core;
  s->info.out_of_core = s->ooc;
  s->info.ordering = "mumps";
  s->info.t_analyze += mo_clock() - t0;
  return MO_OK;
}

/* The memory of the numeric factorization (T181): MUMPS's whole estimate for the chosen mode,
   the Schur complement (PETSc's dense copy, inverted in place) and what the caller will need
   beside (W, and G's copy): refused with the figures when it does not fit; the factor's bytes
   against the free disk out of core. */
static int direct_memory_check(petsc_state *s, mo_ctx *ctx)
{
  double sc = s->schur ? 8.0 * s->nlast * s->nlast : 0, reserve = s->reserve + sc;
  double need_in = s->info.bytes_in_core + sc + reserve, need_ooc = s->info.bytes_out_of_core + sc + reserve;
  double have = mo_memory_rss(), limit = mo_memory_limit(), need = s->ooc ? need_ooc : need_in;
  double sum = need, lim = limit;
  if (ctx->max_bytes > 0 && ctx->max_bytes < limit) limit = ctx->max_bytes;
  /* the ranks' sum against the machine's: every rank of one machine shares it */
  if (ctx->nranks > 1) {
    double hv = have;
    if (MPI_Allreduce(&hv, &have, 1, MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD) != MPI_SUCCESS)
      return mo_error(ctx, MO_EINTERNAL, "MPI_Allreduce failed in the memory check");
  }
  (void)lim;
  s->info.bytes_reserve = reserve;
  s->info.bytes_before = have;
  s->info.bytes_limit = limit;
  if (sum + have > 2e9 || ctx->verbosity >= 3)
    mo_log(ctx, 1, "moreau: MUMPS's factorization of %d dofs%s: %.4g factor entries (%.2f GB), %.3g flops; MUMPS's "
           "estimate %.2f GB in core, %.2f GB out of core; the Schur complement on %d contact dofs and the Delassus "
           "operator %.2f GB; beside %.2f GB in use: %.2f GB of the %.2f GB this run may take (%s)\n",
           s->n, s->ooc ? " out of core" : "", s->info.nnz_L, s->info.bytes_factor / 1e9, s->info.flops,
           s->info.bytes_in_core / 1e9, s->info.bytes_out_of_core / 1e9, s->schur ? s->nlast : 0, (sc + reserve) / 1e9,
           have / 1e9, (need + have) / 1e9, limit / 1e9, s->ooc ? "the factor on disk" : "in core");
  if (s->ooc) {
    struct statvfs v;
    if (!statvfs(s->ooc_dir, &v) && (double)v.f_bavail * (double)v.f_frsize < s->info.bytes_factor)
      return mo_error(ctx, MO_ELIMIT, "linear_solver.ooc_dir: the out-of-core factor (%.4g entries, %.2f GB) does not "
                      "fit on the disk of '%s' (%.2f GB free)", s->info.nnz_L, s->info.bytes_factor / 1e9, s->ooc_base,
                      (double)v.f_bavail * (double)v.f_frsize / 1e9);
  }
  if (need + have > limit)
    return mo_error(ctx, MO_ELIMIT,
                    "MUMPS's factorization of the iteration matrix (%d dofs, %.4g factor entries, %.3g flops) needs "
                    "%.2f GB %s (MUMPS's estimate %.2f GB in core, %.2f GB out of core, INFOG(17) and INFOG(27); the "
                    "Schur complement and the Delassus operator %.2f GB) beside the %.2f GB the run holds already; "
                    "this machine gives a run %.2f GB (doc/theory.md (T181)). Refused before the numeric "
                    "factorization: %s",
                    s->n, s->info.nnz_L, s->info.flops, need / 1e9, s->ooc ? "out of core" : "in core",
                    s->info.bytes_in_core / 1e9, s->info.bytes_out_of_core / 1e9, (sc + reserve) / 1e9, have / 1e9,
                    limit / 1e9,
                    !s->ooc && need_ooc + have <= limit ? "linear_solver.out_of_core = true fits"
                                                        : "a coarser mesh, or a machine with more memory");
  return MO_OK;
}

static int direct_factor(petsc_state *s, const mo_csc *A, mo_ctx *ctx)
{
  MatFactorInfo fi;
  MatFactorError fe = MAT_FACTOR_NOERROR;
  int st, chol = !strcmp(s->pc, "cholesky");
  double t0;
  if (s->nlast && chol && ctx->nranks == 1) {
    /* the Schur path in our order: MUMPS's struct (T183) */
    if (s->F) MatDestroy(&s->F);
    if (!s->dm || s->last_new) {
      if ((st = dm_analyze(s, A, ctx))) return st;
      if ((st = direct_memory_check(s, ctx))) return st;
    }
    return dm_numeric(s, A, ctx);
  }
  if (s->dm) dm_drop(s);
  if (!s->F || s->last_new) {
    if ((st = direct_analyze(s, ctx))) return st;
    if ((st = direct_memory_check(s, ctx))) return st;
  }
  P(MatFactorInfoInitialize(&fi));
  t0 = mo_clock();
  if (chol) P(MatCholeskyFactorNumeric(s->F, s->A, &fi));
  else P(MatLUFactorNumeric(s->F, s->A, &fi));
  s->info.t_numeric = mo_clock() - t0;
  P(MatFactorGetError(s->F, &fe));
  if (fe == MAT_FACTOR_NUMERIC_ZEROPIVOT)
    return mo_error(ctx, MO_ESINGULAR, "factorization by MUMPS: a zero pivot: the matrix is singular (a body free to "
                    "move rigidly with zero mass, or a missing support)");
  if (fe == MAT_FACTOR_OUTMEMORY)
    return mo_error(ctx, MO_ENOMEM, "factorization by MUMPS: out of memory (INFOG(1) = %g, INFOG(2) = %g)",
                    infog(s->F, 1), infog(s->F, 2));
  if (fe != MAT_FACTOR_NOERROR)
    return mo_error(ctx, MO_EINTERNAL, "factorization by MUMPS failed (INFOG(1) = %g, INFOG(2) = %g)", infog(s->F, 1),
                    infog(s->F, 2));
  s->info.nlast = s->schur ? s->nlast : 0;
  s->info.trailing = s->schur;
  return MO_OK;
}

/* G = S^-1 = (A^-1)_CC (nlast x nlast, column-major, both triangles): PETSc inverts MUMPS's Schur
   complement in place (LAPACK), the later solves multiply by it (T180). */
static int petsc_schur_inverse(void *state, double *G, mo_ctx *ctx)
{
  petsc_state *s = state;
  Mat S;
  MatFactorSchurStatus ss;
  const PetscScalar *a;
  PetscInt lda, m, nn;
  int j, n = s->nlast, st;
  if (s->dm) {
    if ((st = dm_invert(s, ctx))) return st;
    memcpy(G, s->S, (size_t)n * (size_t)n * sizeof *G);
    return MO_OK;
  }
  if (!s->schur || !s->F) return mo_error(ctx, MO_EINTERNAL, "no Schur complement in this factor");
  P(MatFactorInvertSchurComplement(s->F));
  P(MatFactorGetSchurComplement(s->F, &S, &ss));
  P(MatGetSize(S, &m, &nn));
  if (m != n || nn != n) {
    MatFactorRestoreSchurComplement(s->F, &S, ss);
    return mo_error(ctx, MO_EINTERNAL, "MUMPS's Schur complement is %d x %d, not %d x %d", (int)m, (int)nn, n, n);
  }
  P(MatDenseGetLDA(S, &lda));
  P(MatDenseGetArrayRead(S, &a));
  for (j = 0; j < n; j++) memcpy(G + (size_t)j * n, a + (size_t)j * lda, (size_t)n * sizeof *G);
  P(MatDenseRestoreArrayRead(S, &a));
  P(MatFactorRestoreSchurComplement(s->F, &S, ss));
  for (j = 0; j < n * n; j++)
    if (!isfinite(G[j])) return mo_error(ctx, MO_ENAN, "the inverse of MUMPS's Schur complement holds a NaN");
  return MO_OK;
}

static void petsc_info(const void *state, mo_linsolver_info *out)
{
  const petsc_state *s = state;
  if (!s->direct || (!s->F && !s->dm)) return;
  *out = s->info;
  out->two_solves = s->n_solve ? s->t_solve / s->n_solve : NAN;
}

static int petsc_factor(void *state, const mo_csc *A, int same, mo_ctx *ctx)
{
  petsc_state *s = state;
  PetscInt r;
  PC pc;
  PCFailedReason pf;
  int st;
  if (!s->configured) {
    mo_linsolver_settings d = {NULL, NULL, NULL, NULL, 0, 0, 0, 0, NULL};
    petsc_configure(s, &d, ctx);
  }
  if (s->parts) {
    /* the pattern of the sum is unchanged only when every rank's part is */
    int all = same && s->A;
    if (MPI_Allreduce(MPI_IN_PLACE, &all, 1, MPI_INT, MPI_MIN, PETSC_COMM_WORLD) != MPI_SUCCESS)
      return mo_error(ctx, MO_EINTERNAL, "MPI_Allreduce failed before a factorization");
    if (!all) {
      drop(s);
      if ((st = make_matrix(s, A, ctx))) return st;
      if (!s->direct && (st = make_ksp(s, ctx))) return st;
    } else
      P(MatZeroEntries(s->A));
    if ((st = add_parts(s, A, ctx))) return st;
  } else if (!same || !s->A) {
    drop(s);
    if ((st = make_matrix(s, A, ctx))) return st;
    if (!s->direct && (st = make_ksp(s, ctx))) return st;
  } else {
    /* the same pattern: new values in the rows this rank owns (PETSc keeps the symbolic
       factorization of a matrix whose nonzero pattern did not change) */
    mo_csc_free(s->At);
    s->At = NULL;
    if ((st = mo_csc_transpose(A, &s->At, ctx))) return st;
  }
  for (r = s->rstart; !s->parts && r < s->rend; r++) {
    const mo_csc *T = s->At;
    PetscInt row = r, nz = T->p[r + 1] - T->p[r], k, cols[64], *cp = cols;
    PetscInt *big = NULL;
    if (nz > 64) {
      if (!(big = mo_malloc(ctx, (size_t)nz * sizeof *big))) return MO_ENOMEM;
      cp = big;
    }
    for (k = 0; k < nz; k++) cp[k] = T->i[T->p[r] + k];
    {
      PetscErrorCode e = MatSetValues(s->A, 1, &row, nz, cp, T->x + T->p[r], INSERT_VALUES);
      mo_free(big);
      if (e) return petsc_fail(ctx, e, "MatSetValues");
    }
  }
  P(MatAssemblyBegin(s->A, MAT_FINAL_ASSEMBLY));
  P(MatAssemblyEnd(s->A, MAT_FINAL_ASSEMBLY));
  if (s->direct) return direct_factor(s, A, ctx);
  P(KSPSetOperators(s->ksp_obj, s->A, s->A));
  /* the factorization (or the preconditioner's set-up) now, where the stepper times it */
  P(KSPSetUp(s->ksp_obj));
  P(KSPGetPC(s->ksp_obj, &pc));
  P(PCGetFailedReason(pc, &pf));
  if (pf != PC_NOERROR)
    return mo_error(ctx, MO_ESINGULAR, "factorization by PETSc (%s, %s): %s", s->pc, s->package,
                    pf == PC_FACTOR_NUMERIC_ZEROPIVOT ? "a zero pivot: the matrix is singular (a body free to "
                    "move rigidly with zero mass, or a missing support)" : PCFailedReasons[pf]);
  return MO_OK;
}

/* One replicated right-hand side in, the replicated solution out. */
static int solve_one(petsc_state *s, const double *b, double *x, mo_ctx *ctx)
{
  PetscScalar *pb;
  const PetscScalar *px;
  KSPConvergedReason why;
  PetscInt its;
  P(VecGetArray(s->b, &pb));
  memcpy(pb, b + s->rstart, (size_t)(s->rend - s->rstart) * sizeof *pb);
  P(VecRestoreArray(s->b, &pb));
  if (s->direct) {
    double t0 = mo_clock();
    P(MatSolve(s->F, s->b, s->x));
    s->t_solve += mo_clock() - t0;
    s->n_solve++;
  } else {
    P(KSPSolve(s->ksp_obj, s->b, s->x));
    P(KSPGetConvergedReason(s->ksp_obj, &why));
    if (why < 0)
      return mo_error(ctx, MO_ENOCONV, "the PETSc solve (%s, %s) did not converge: %s", s->ksp, s->pc,
                      KSPConvergedReasons[why]);
    P(KSPGetIterationNumber(s->ksp_obj, &its));
    s->iterations += its;
  }
  P(VecScatterBegin(s->toall, s->x, s->xall, INSERT_VALUES, SCATTER_FORWARD));
  P(VecScatterEnd(s->toall, s->x, s->xall, INSERT_VALUES, SCATTER_FORWARD));
  P(VecGetArrayRead(s->xall, &px));
  memcpy(x, px, (size_t)s->n * sizeof *x);
  P(VecRestoreArrayRead(s->xall, &px));
  return MO_OK;
}

/* Several right-hand sides in one call of the factorization (MUMPS solves them together): this
   rank's rows of B (column k at B + k ldb + off) in, its rows of X out (leading dimension its
   row count), dense by rows over the ranks. */
static int solve_local(petsc_state *s, int nrhs, const double *B, size_t ldb, size_t off, double *mine, mo_ctx *ctx)
{
  Mat Bm, Xm;
  PetscScalar *pb;
  const PetscScalar *px;
  int nloc = s->rend - s->rstart, k;
  KSPConvergedReason why = KSP_CONVERGED_ITS;
  P(MatCreateDense(PETSC_COMM_WORLD, nloc, PETSC_DECIDE, s->n, nrhs, NULL, &Bm));
  P(MatCreateDense(PETSC_COMM_WORLD, nloc, PETSC_DECIDE, s->n, nrhs, NULL, &Xm));
  P(MatDenseGetArray(Bm, &pb));
  for (k = 0; k < nrhs; k++) memcpy(pb + (size_t)k * nloc, B + (size_t)k * ldb + off, (size_t)nloc * sizeof *pb);
  P(MatDenseRestoreArray(Bm, &pb));
  if (s->direct) P(MatMatSolve(s->F, Bm, Xm));
  else {
    P(KSPMatSolve(s->ksp_obj, Bm, Xm));
    P(KSPGetConvergedReason(s->ksp_obj, &why));
  }
  if (why < 0) {
    MatDestroy(&Bm);
    MatDestroy(&Xm);
    return mo_error(ctx, MO_ENOCONV, "the PETSc solve (%s, %s) of %d right-hand sides did not converge: %s", s->ksp,
                    s->pc, nrhs, KSPConvergedReasons[why]);
  }
  P(MatDenseGetArrayRead(Xm, &px));
  memcpy(mine, px, (size_t)nloc * nrhs * sizeof *mine);
  P(MatDenseRestoreArrayRead(Xm, &px));
  MatDestroy(&Bm);
  MatDestroy(&Xm);
  return MO_OK;
}

/* Several replicated right-hand sides, the whole solutions on every rank: each rank's rows
   solved (solve_local), then gathered. */
static int solve_block(petsc_state *s, int nrhs, const double *B, double *X, mo_ctx *ctx)
{
  int nloc = s->rend - s->rstart, k, r, *cnt = NULL, st = MO_OK;
  double *mine = NULL, *all = NULL;
  /* the rows of every rank, rank after rank, each block column-major */
  if (!(cnt = mo_malloc(ctx, (size_t)ctx->nranks * sizeof *cnt)) ||
      !(mine = mo_malloc(ctx, ((size_t)nloc * nrhs + 1) * sizeof *mine)) ||
      !(all = mo_malloc(ctx, ((size_t)s->n * nrhs + 1) * sizeof *all))) {
    st = MO_ENOMEM;
    goto done;
  }
  if ((st = solve_local(s, nrhs, B, (size_t)s->n, (size_t)s->rstart, mine, ctx))) goto done;
  {
    /* PETSc's split (PetscSplitOwnership): n / size rows each, one more on the first n % size */
    long off = 0, first = 0;
    for (r = 0; r < ctx->nranks; r++) cnt[r] = (s->n / ctx->nranks + (r < s->n % ctx->nranks)) * nrhs;
    if (cnt[ctx->rank] != nloc * nrhs) {
      st = mo_error(ctx, MO_EINTERNAL, "PETSc's row split is not the one expected (%d rows here)", nloc);
      goto done;
    }
    if ((st = allgatherv(mine, cnt, all, ctx))) goto done;
    for (r = 0; r < ctx->nranks; r++) {
      int rows = cnt[r] / nrhs;
      for (k = 0; k < nrhs; k++)
        memcpy(X + (size_t)k * s->n + first, all + off + (size_t)k * rows, (size_t)rows * sizeof *X);
      off += cnt[r];
      first += rows;
    }
  }
done:
  mo_free(cnt);
  mo_free(mine);
  mo_free(all);
  return st;
}

/* The solutions kept by rows (T210): this rank's rows of B in, its rows of X out, nothing
   gathered. */
static int petsc_solve_rows(void *state, int nrhs, const double *B, double *X, int *r0, int *r1, mo_ctx *ctx)
{
  petsc_state *s = state;
  *r0 = s->rstart;
  *r1 = s->rend;
  if (!nrhs) return MO_OK;
  if (s->dm) return dm_solve(s, nrhs, B, X, ctx);
  return solve_local(s, nrhs, B, (size_t)(s->rend - s->rstart), 0, X, ctx);
}

static int petsc_solve(void *state, int nrhs, const double *B, double *X, mo_ctx *ctx)
{
  petsc_state *s = state;
  int k, st;
  if (s->dm) return dm_solve(s, nrhs, B, X, ctx);
  if (nrhs > 1) return solve_block(s, nrhs, B, X, ctx);
  for (k = 0; k < nrhs; k++)
    if ((st = solve_one(s, B + (size_t)k * (size_t)s->n, X + (size_t)k * (size_t)s->n, ctx))) return st;
  return MO_OK;
}

static void petsc_free(void *state)
{
  petsc_state *s = state;
  drop(s);
  ooc_remove(s);
  mo_csc_free(s->At);
  mo_free(s->last);
}

static const mo_linsolver_type petsc_type = {"petsc", 0, sizeof(petsc_state), petsc_factor, petsc_solve,
                                             petsc_free, petsc_configure, petsc_set_last, NULL,
                                             petsc_schur_inverse, petsc_info, petsc_solve_rows};

/* --- a matrix assembled from element blocks (doc/parallel.md §3) -------------------------------- */

typedef struct {
  Mat A;
  int n, rstart, rend;
  int *perm, *iperm;        /* dof -> PETSc's row, and back */
  Vec x, y, yall;           /* for dmat_mult: the owned rows of x and y, y whole */
  VecScatter toall;
  long sent;                /* entries stashed for other ranks in the values' pass */
} dmat;

static void dmat_free(void *h)
{
  dmat *D = h;
  if (!D) return;
  if (D->A) MatDestroy(&D->A);
  if (D->x) VecDestroy(&D->x);
  if (D->y) VecDestroy(&D->y);
  if (D->yall) VecDestroy(&D->yall);
  if (D->toall) VecScatterDestroy(&D->toall);
  mo_free(D->perm);
  mo_free(D->iperm);
  mo_free(D);
}

static int dmat_create(int n, int rstart, int rend, const int *perm, const int *dnnz, const int *onnz, void **h,
                       mo_ctx *ctx)
{
  dmat *D;
  PetscInt nloc = rend - rstart, *dn, *on;
  PetscErrorCode e;
  int k;
  *h = NULL;
  if (!(D = mo_calloc(ctx, 1, sizeof *D))) return MO_ENOMEM;
  *h = D;
  D->n = n;
  D->rstart = rstart;
  D->rend = rend;
  if (!(D->perm = mo_malloc(ctx, ((size_t)n + 1) * sizeof *D->perm)) ||
      !(D->iperm = mo_malloc(ctx, ((size_t)n + 1) * sizeof *D->iperm)))
    return MO_ENOMEM;
  for (k = 0; k < n; k++) D->perm[k] = D->iperm[k] = -1;
  for (k = 0; k < n; k++) {
    int r = perm ? perm[k] : k;
    if (r < 0 || r >= n || D->iperm[r] >= 0) return mo_error(ctx, MO_EINTERNAL, "the rows' order is not a permutation");
    D->perm[k] = r;
    D->iperm[r] = k;
  }
  P(MatCreate(PETSC_COMM_WORLD, &D->A));
  P(MatSetSizes(D->A, nloc, nloc, n, n));
  P(MatSetType(D->A, MATAIJ));
  /* d_nnz and o_nnz of every owned row, counted by the caller from the connectivity */
  dn = mo_malloc(ctx, ((size_t)nloc + 1) * sizeof *dn);
  on = mo_malloc(ctx, ((size_t)nloc + 1) * sizeof *on);
  if (!dn || !on) {
    mo_free(dn);
    mo_free(on);
    return MO_ENOMEM;
  }
  for (k = 0; k < nloc; k++) {
    dn[k] = dnnz[k];
    on[k] = onnz[k];
  }
  e = MatSeqAIJSetPreallocation(D->A, 0, dn);
  if (!e) e = MatMPIAIJSetPreallocation(D->A, 0, dn, 0, on);
  mo_free(dn);
  mo_free(on);
  if (e) return petsc_fail(ctx, e, "MatMPIAIJSetPreallocation");
  P(MatSetOption(D->A, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE));
  return MO_OK;
}

static int dmat_add(void *h, int nd, const int *dofs, const double *Ae, mo_ctx *ctx)
{
  dmat *D = h;
  PetscInt idx[MO_ND_MAX], at[MO_ND_MAX];
  PetscScalar v[MO_ND_MAX * MO_ND_MAX];
  int i, j;
  if (nd > MO_ND_MAX) return mo_error(ctx, MO_EINTERNAL, "an element block of %d dofs (at most %d)", nd, MO_ND_MAX);
  /* the rows in increasing order (PETSc searches each row's columns from the last one found):
     insertion sort of the element's dofs, the block permuted alike */
  for (i = 0; i < nd; i++) {
    PetscInt r = D->perm[dofs[i]];
    for (j = i; j > 0 && idx[j - 1] > r; j--) {
      idx[j] = idx[j - 1];
      at[j] = at[j - 1];
    }
    idx[j] = r;
    at[j] = i;
  }
  /* v row-major (PETSc's default), Ae column-major */
  for (i = 0; i < nd; i++)
    for (j = 0; j < nd; j++) v[i * nd + j] = Ae[at[j] * nd + at[i]];
  /* ADD_VALUES: the rows of other ranks go to PETSc's stash, sent at dmat_assemble */
  P(MatSetValues(D->A, nd, idx, nd, idx, v, ADD_VALUES));
  return MO_OK;
}

static int dmat_assemble(void *h, mo_ctx *ctx)
{
  dmat *D = h;
  PetscInt ns = 0, nr = 0;
  P(MatStashGetInfo(D->A, &ns, &nr, NULL, NULL));
  D->sent = ns;
  P(MatAssemblyBegin(D->A, MAT_FINAL_ASSEMBLY));
  P(MatAssemblyEnd(D->A, MAT_FINAL_ASSEMBLY));
  P(MatCreateVecs(D->A, &D->x, &D->y));
  P(VecScatterCreateToAll(D->y, &D->toall, &D->yall));
  return MO_OK;
}

static int dmat_mult(void *h, const double *x, double *y, mo_ctx *ctx)
{
  dmat *D = h;
  PetscScalar *px;
  const PetscScalar *py;
  int k;
  P(VecGetArray(D->x, &px));
  for (k = D->rstart; k < D->rend; k++) px[k - D->rstart] = x[D->iperm[k]];
  P(VecRestoreArray(D->x, &px));
  P(MatMult(D->A, D->x, D->y));
  P(VecScatterBegin(D->toall, D->y, D->yall, INSERT_VALUES, SCATTER_FORWARD));
  P(VecScatterEnd(D->toall, D->y, D->yall, INSERT_VALUES, SCATTER_FORWARD));
  P(VecGetArrayRead(D->yall, &py));
  for (k = 0; k < D->n; k++) y[k] = py[D->perm[k]];
  P(VecRestoreArrayRead(D->yall, &py));
  return MO_OK;
}

static int dmat_row(void *h, int dof, int cap, int *nz, int *cols, double *vals, mo_ctx *ctx)
{
  dmat *D = h;
  PetscInt m, k, row = dof >= 0 && dof < D->n ? D->perm[dof] : -1;
  const PetscInt *c;
  const PetscScalar *v;
  if (row < D->rstart || row >= D->rend)
    return mo_error(ctx, MO_EINTERNAL, "dof %d is not this rank's", dof);
  P(MatGetRow(D->A, row, &m, &c, &v));
  *nz = (int)m;
  for (k = 0; k < m && k < cap; k++) {
    cols[k] = D->iperm[c[k]];
    vals[k] = v[k];
  }
  P(MatRestoreRow(D->A, row, &m, &c, &v));
  return m > cap ? mo_error(ctx, MO_ELIMIT, "the row of dof %d has %d entries (room for %d)", dof, (int)m, cap)
                 : MO_OK;
}

static void dmat_counts(void *h, long *nnz, long *allocated, long *sent)
{
  dmat *D = h;
  MatInfo info;
  *nnz = *allocated = 0;
  if (D->A && !MatGetInfo(D->A, MAT_LOCAL, &info)) {
    *nnz = (long)info.nz_used;
    *allocated = (long)info.nz_allocated;
  }
  *sent = D->sent;
}

/* The module's one export (petsc_module.h). */
extern const mo_petsc_module mo_petsc_module_v1;
const mo_petsc_module mo_petsc_module_v1 = {MO_PETSC_ABI, PETSC_VERSION_GIT, start, started, finish, allreduce,
                                            bcast, allgatherv, agree, exchange, &petsc_type, dmat_create, dmat_add,
                                            dmat_assemble, dmat_mult, dmat_row, dmat_counts, dmat_free, gatherv0,
                                            alltoall, exchangev};
