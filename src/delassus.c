/* delassus.c: the Delassus operator W = c H^T What^-1 H by d x d blocks, computed with the
   shared factorization by chunks of right-hand sides (doc/theory.md §4.4). */
#include "config.h"
#include <moreau/contact.h>
#include "contact_internal.h"
#include <moreau/parallel.h>

#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Columns What^-1 H are kept when they hold at most this many doubles (128 MB). */
#define MO_KEEP_COLUMNS_MAX 16000000.0
/* Right-hand sides per solve when building W. */
#define MO_CHUNK 64

struct mo_delassus {
  int m, d, nb, nfree;
  long hversion, fversion;
  double c;
  int built;
  long version;     /* counts the builds: back ends key their caches on (D, version) */
  int *rowp;        /* nb + 1 */
  int *colb;        /* block columns */
  double *val;      /* d*d per block, row-major */
  long nblocks;
  double *C;        /* nfe x (d nbf) column-major: What_fe^-1 H over the candidates touching the
                       nodal block, or NULL */
  int nfe, nbf;     /* nodal free dofs; candidates touching them */
  int *fecol;       /* nb: each candidate's block column in C, or -1 */
  double *work;     /* nfree */
  double *y;        /* nfe: the forward solve of a correction on the trailing block (T153) */
  int schur;        /* the last build came from the factor's trailing block (T151) */
  double *nn;       /* d > 1: W_ab,nn of every block in val's order (T164), or NULL */
  double *nt;       /* d > 1: W_ab,tn (d - 1 a block) in val's order, the rest of the normal
                       column (T176), or NULL */
  int r0, r1;       /* the nodal rows of C this process holds: all (0 .. nfe) but when the solver's
                       rows are split over the ranks (T210); C is then (r1 - r0) x (d nbf) */
  int *rcnt;        /* split rows: every rank's row count (nranks), for the correction's gather */
  double *part;     /* split rows: this rank's rows of a correction */
};

int mo_delassus_create(mo_delassus **out, mo_ctx *ctx)
{
  *out = mo_calloc(ctx, 1, sizeof **out);
  if (!*out) return MO_ENOMEM;
  (*out)->hversion = (*out)->fversion = -1;
  return MO_OK;
}

static void clear(mo_delassus *D)
{
  mo_free(D->rowp);
  mo_free(D->colb);
  mo_free(D->val);
  mo_free(D->C);
  mo_free(D->work);
  mo_free(D->fecol);
  mo_free(D->y);
  mo_free(D->nn);
  mo_free(D->nt);
  mo_free(D->rcnt);
  mo_free(D->part);
  D->rowp = D->colb = D->fecol = D->rcnt = NULL;
  D->val = D->C = D->work = D->y = D->nn = D->nt = D->part = NULL;
  D->r0 = D->r1 = 0;
  D->built = 0;
  D->schur = 0;
}

void mo_delassus_free(mo_delassus *D)
{
  if (!D) return;
  clear(D);
  mo_free(D);
}

int mo_delassus_m(const mo_delassus *D) { return D->m; }
int mo_delassus_dim(const mo_delassus *D) { return D->d; }
long mo_delassus_nblocks(const mo_delassus *D) { return D->nblocks; }
int mo_delassus_has_columns(const mo_delassus *D) { return D->C != NULL; }
int mo_delassus_from_schur(const mo_delassus *D) { return D->schur; }

/* --- rows of blocks under construction ------------------------------------------------------ */

typedef struct {
  int nb, dd;
  int *cnt, *cap;
  int **col;
  double **val;
} rows;

static void rows_free(rows *R)
{
  int a;
  for (a = 0; a < R->nb; a++) {
    if (R->col) mo_free(R->col[a]);
    if (R->val) mo_free(R->val[a]);
  }
  mo_free(R->col);
  mo_free(R->val);
  mo_free(R->cnt);
  mo_free(R->cap);
  memset(R, 0, sizeof *R);
}

static int rows_init(rows *R, int nb, int d, mo_ctx *ctx)
{
  memset(R, 0, sizeof *R);
  R->nb = nb;
  R->dd = d * d;
  R->cnt = mo_calloc(ctx, (size_t)nb + 1, sizeof(int));
  R->cap = mo_calloc(ctx, (size_t)nb + 1, sizeof(int));
  R->col = mo_calloc(ctx, (size_t)nb + 1, sizeof(int *));
  R->val = mo_calloc(ctx, (size_t)nb + 1, sizeof(double *));
  return R->cnt && R->cap && R->col && R->val ? MO_OK : MO_ENOMEM;
}

/* Append block (a, b) (duplicates are summed when the rows are compressed). */
static int rows_add(rows *R, int a, int b, const double *blk, mo_ctx *ctx)
{
  if (R->cnt[a] == R->cap[a]) {
    int cap = R->cap[a] ? 2 * R->cap[a] : 8;
    int *ic = mo_realloc(ctx, R->col[a], (size_t)cap * sizeof(int));
    double *vc;
    if (!ic) return MO_ENOMEM;
    R->col[a] = ic;
    vc = mo_realloc(ctx, R->val[a], (size_t)cap * (size_t)R->dd * sizeof(double));
    if (!vc) return MO_ENOMEM;
    R->val[a] = vc;
    R->cap[a] = cap;
  }
  R->col[a][R->cnt[a]] = b;
  memcpy(R->val[a] + (size_t)R->cnt[a] * (size_t)R->dd, blk, (size_t)R->dd * sizeof(double));
  R->cnt[a]++;
  return MO_OK;
}

/* Sort each row by block column (insertion: rows are short), sum duplicates, store as CSR. */
static int rows_compress(rows *R, mo_delassus *D, mo_ctx *ctx)
{
  int nb = R->nb, dd = R->dd, a, k, q;
  size_t total = 0;
  double tmp[9];
  for (a = 0; a < nb; a++) {
    int *c = R->col[a], n = R->cnt[a], w = 0;
    double *v = R->val[a];
    for (k = 1; k < n; k++) {
      int ck = c[k];
      memcpy(tmp, v + (size_t)k * dd, (size_t)dd * sizeof *tmp);
      for (q = k; q > 0 && c[q - 1] > ck; q--) {
        c[q] = c[q - 1];
        memcpy(v + (size_t)q * dd, v + (size_t)(q - 1) * dd, (size_t)dd * sizeof *v);
      }
      c[q] = ck;
      memcpy(v + (size_t)q * dd, tmp, (size_t)dd * sizeof *tmp);
    }
    for (k = 0; k < n; k++) {
      if (w && c[w - 1] == c[k]) {
        for (q = 0; q < dd; q++) v[(size_t)(w - 1) * dd + q] += v[(size_t)k * dd + q];
        continue;
      }
      if (w != k) {
        c[w] = c[k];
        memcpy(v + (size_t)w * dd, v + (size_t)k * dd, (size_t)dd * sizeof *v);
      }
      w++;
    }
    R->cnt[a] = w;
    total += (size_t)w;
  }
  D->rowp = mo_malloc(ctx, ((size_t)nb + 1) * sizeof(int));
  D->colb = mo_malloc(ctx, (total + 1) * sizeof(int));
  D->val = mo_malloc(ctx, (total * (size_t)dd + 1) * sizeof(double));
  if (!D->rowp || !D->colb || !D->val) return MO_ENOMEM;
  D->rowp[0] = 0;
  for (a = 0; a < nb; a++) {
    D->rowp[a + 1] = D->rowp[a] + R->cnt[a];
    memcpy(D->colb + D->rowp[a], R->col[a], (size_t)R->cnt[a] * sizeof(int));
    memcpy(D->val + (size_t)D->rowp[a] * dd, R->val[a], (size_t)R->cnt[a] * (size_t)dd * sizeof(double));
  }
  D->nblocks = (long)total;
  return MO_OK;
}

/* --- the build (doc/theory.md §4.4, (T72)) -------------------------------------------------- */

static int apply_Cinv(mo_delassus *D, const mo_csc *H, const mo_what_inverse *Wi, const double *r, double *dx,
                      mo_ctx *ctx);

/* The largest rank's nodal rows of the columns What^-1 H over the builds, the rows whole and the
   columns (summary.json parallel.delassus_columns). */
static void count_rows(mo_ctx *ctx, double largest, int nfe, int ncols)
{
  if (largest > ctx->par_column_rows) ctx->par_column_rows = (long)largest;
  ctx->par_column_dofs = nfe;
  ctx->par_columns = ncols;
}

/* The candidates whose columns of H touch the nodal rows 0 .. nfe-1: fe[0 .. nbf-1], and each
   candidate's place among them in D->fecol (-1: none). */
static int touching(mo_delassus *D, const mo_csc *H, int nfe, int *fe, mo_ctx *ctx)
{
  int d = D->d, nb = D->nb, nbf = 0, a, k, p;
  D->fecol = mo_malloc(ctx, ((size_t)nb + 1) * sizeof *D->fecol);
  if (!D->fecol) return MO_ENOMEM;
  for (a = 0; a < nb; a++) {
    int touch = 0;
    for (k = a * d; k < a * d + d && !touch; k++)
      for (p = H->p[k]; p < H->p[k + 1]; p++) touch |= H->i[p] < nfe;
    D->fecol[a] = touch ? nbf : -1;
    if (touch) fe[nbf++] = a;
  }
  D->nbf = nbf;
  return MO_OK;
}

/* The nodal part: c H_a^T What_fe^-1 H_b for the candidates whose columns touch the nodal block
   (rows 0 .. nfe-1), by chunks of right-hand sides through the factorization; the columns
   X = What_fe^-1 H are kept when they fit. When the solver's rows are split over the ranks
   (split: doc/theory.md (T210)-(T212)) each rank solves for and keeps its rows r0 .. r1-1 of X (no
   rank holds them whole), takes its rows' share of c H_a^T X, and one sum over the ranks a chunk
   completes the chunk's blocks of W (T211), the same on every rank; otherwise r0 = 0, r1 = nfe. */
static int build_nodal(mo_delassus *D, const mo_csc *H, const mo_what_inverse *Wi, double c, rows *R, int split,
                       int r0, int r1, mo_ctx *ctx)
{
  int nfe = Wi->nfe, d = D->d, nb = D->nb, nloc = r1 - r0, nbf, mb, a, b, k, p, j0, q0, q1, i, st = MO_OK;
  int *fe = NULL;
  double *B = NULL, *X = NULL, *Wp = NULL, *cnt = NULL, largest = nloc, total = 0;
  fe = mo_malloc(ctx, ((size_t)nb + 1) * sizeof *fe);
  if (!fe) { st = MO_ENOMEM; goto done; }
  if (split) {
    cnt = mo_calloc(ctx, (size_t)ctx->nranks, sizeof *cnt);
    D->rcnt = mo_malloc(ctx, (size_t)ctx->nranks * sizeof *D->rcnt);
    D->part = mo_malloc(ctx, ((size_t)nloc + 1) * sizeof *D->part);
    if (!cnt || !D->rcnt || !D->part) { st = MO_ENOMEM; goto done; }
    /* every rank's rows: the correction's gather (T212) and the count of summary.json */
    cnt[ctx->rank] = nloc;
    if ((st = mo_par_sum(cnt, ctx->nranks, ctx))) goto done;
    for (i = 0, largest = 0; i < ctx->nranks; i++) {
      D->rcnt[i] = (int)cnt[i];
      total += cnt[i];
      if (cnt[i] > largest) largest = cnt[i];
    }
    if (total != nfe) { st = mo_error(ctx, MO_EINTERNAL, "Delassus: the ranks' rows sum to %.0f of %d", total, nfe); goto done; }
  }
  D->r0 = r0;
  D->r1 = r1;
  if ((st = touching(D, H, nfe, fe, ctx))) goto done;
  nbf = D->nbf;
  mb = nbf * d;
  count_rows(ctx, largest, nfe, mb);
  if (!nbf || !nfe) goto done;
  B = mo_calloc(ctx, (size_t)nloc * MO_CHUNK + 1, sizeof *B);
  X = mo_malloc(ctx, ((size_t)nloc * MO_CHUNK + 1) * sizeof *X);
  Wp = mo_malloc(ctx, ((size_t)mb * MO_CHUNK + 1) * sizeof *Wp);
  if (!B || !X || !Wp) { st = MO_ENOMEM; goto done; }
  /* the same choice on every rank: the largest rank's rows */
  if (largest * (double)mb <= MO_KEEP_COLUMNS_MAX) {
    D->C = mo_malloc(ctx, ((size_t)nloc * (size_t)mb + 1) * sizeof *D->C);
    if (!D->C) { st = MO_ENOMEM; goto done; }
  } else
    mo_note_skip(ctx, "storing What^-1 H%s (%.0f x %d would exceed %.0f MB): one solve per correction",
                 split ? " by rows" : "", largest, mb, MO_KEEP_COLUMNS_MAX * 8 / 1e6);
  /* chunks of whole candidates so that each block column is computed at once */
  for (j0 = 0; j0 < nbf; j0 += MO_CHUNK / d) {
    int nbc = MO_CHUNK / d, ncols;
    if (j0 + nbc > nbf) nbc = nbf - j0;
    ncols = nbc * d;
    memset(B, 0, (size_t)nloc * (size_t)ncols * sizeof *B);
    for (b = 0; b < nbc; b++)
      for (k = 0; k < d; k++) {
        int col = fe[j0 + b] * d + k;
        for (p = H->p[col]; p < H->p[col + 1]; p++)
          if (H->i[p] >= r0 && H->i[p] < r1) B[(size_t)(b * d + k) * nloc + (size_t)(H->i[p] - r0)] = H->x[p];
      }
    if (!split) st = mo_linsolver_solve_multi(Wi->ls, ncols, B, X, ctx);
    else if (!(st = mo_linsolver_solve_rows(Wi->ls, ncols, B, X, &q0, &q1, ctx)) && (q0 != r0 || q1 != r1))
      st = mo_error(ctx, MO_EINTERNAL, "Delassus: the solver's rows moved (%d .. %d, then %d .. %d)", r0, r1, q0, q1);
    if (st) goto done;
    if (D->C) memcpy(D->C + (size_t)j0 * d * nloc, X, (size_t)nloc * (size_t)ncols * sizeof *X);
    /* these rows' share of c H^T X (all of it on one rank), mb x ncols column-major (T211) */
    for (b = 0; b < ncols; b++)
      for (k = 0; k < mb; k++) {
        int r = fe[k / d] * d + k % d;
        double sum = 0;
        for (p = H->p[r]; p < H->p[r + 1]; p++)
          if (H->i[p] >= r0 && H->i[p] < r1) sum += H->x[p] * X[(size_t)b * nloc + (size_t)(H->i[p] - r0)];
        Wp[(size_t)b * mb + (size_t)k] = c * sum;
      }
    if (split && (st = mo_par_sum(Wp, (long)mb * ncols, ctx))) goto done;
    for (k = 0; k < nbf; k++)
      for (b = 0; b < nbc; b++) {
        double blk[9];
        int nz = 0, ii, jj;
        a = fe[k];
        for (ii = 0; ii < d; ii++)
          for (jj = 0; jj < d; jj++) {
            blk[ii * d + jj] = Wp[(size_t)(b * d + jj) * mb + (size_t)(k * d + ii)];
            nz |= blk[ii * d + jj] != 0;
          }
        if (nz && (st = rows_add(R, a, fe[j0 + b], blk, ctx))) goto done;
      }
  }
done:
  mo_free(fe);
  mo_free(cnt);
  mo_free(B);
  mo_free(X);
  mo_free(Wp);
  return st;
}

/* --- the nodal part from the factor's trailing block (doc/theory.md (T151)) ----------------- */

/* Each candidate's entries of H on the contact dofs: ep (nb + 1) into ec (the row's place among
   the contact dofs), el (the local direction 0 .. d-1), ev (the value). NULL when some nodal row
   of H is not a contact dof of the factor (the old path then). */
typedef struct {
  int *ep, *ec, *el;
  double *ev;
} cand_entries;

static void cand_entries_free(cand_entries *E)
{
  mo_free(E->ep);
  mo_free(E->ec);
  mo_free(E->el);
  mo_free(E->ev);
  memset(E, 0, sizeof *E);
}

static int cand_entries_build(const mo_csc *H, const mo_what_inverse *Wi, int d, cand_entries *E, int *covered,
                              mo_ctx *ctx)
{
  int nfe = Wi->nfe, nb = H->ncol / d, *pos = NULL, j, p, k, q = 0, st = MO_OK;
  memset(E, 0, sizeof *E);
  *covered = 0;
  if (!Wi->ls || !Wi->nlast || !nfe) return MO_OK;
  if (!(pos = mo_malloc(ctx, (size_t)nfe * sizeof *pos))) return MO_ENOMEM;
  for (k = 0; k < nfe; k++) pos[k] = -1;
  for (k = 0; k < Wi->nlast; k++) pos[Wi->last[k]] = k;
  for (j = 0; j < H->ncol; j++)
    for (p = H->p[j]; p < H->p[j + 1]; p++)
      if (H->i[p] < nfe) {
        if (pos[H->i[p]] < 0) goto done; /* a row the factor did not order last */
        q++;
      }
  E->ep = mo_malloc(ctx, ((size_t)nb + 1) * sizeof *E->ep);
  E->ec = mo_malloc(ctx, ((size_t)q + 1) * sizeof *E->ec);
  E->el = mo_malloc(ctx, ((size_t)q + 1) * sizeof *E->el);
  E->ev = mo_malloc(ctx, ((size_t)q + 1) * sizeof *E->ev);
  if (!E->ep || !E->ec || !E->el || !E->ev) { st = MO_ENOMEM; goto done; }
  q = 0;
  E->ep[0] = 0;
  for (k = 0; k < nb; k++) {
    for (j = k * d; j < k * d + d; j++)
      for (p = H->p[j]; p < H->p[j + 1]; p++)
        if (H->i[p] < nfe) {
          E->ec[q] = pos[H->i[p]];
          E->el[q] = j - k * d;
          E->ev[q++] = H->x[p];
        }
    E->ep[k + 1] = q;
  }
  *covered = 1;
done:
  mo_free(pos);
  if (st || !*covered) cand_entries_free(E);
  return st;
}

/* Row a of the nodal part, W_ab = c H_a^T G H_b for every candidate b with entries: g_i =
   sum over a's entries in direction i of v G(:, row) (G symmetric: its columns), then
   W_ab(i, j) = c sum over b's entries in direction j of v g_i(row). blk: nb d x d blocks. */
static void schur_row(const cand_entries *E, const double *G, int nC, int d, int nb, int a, double c, double *g,
                      double *blk)
{
  int p, q, i, b, r;
  memset(g, 0, (size_t)d * (size_t)nC * sizeof *g);
  for (p = E->ep[a]; p < E->ep[a + 1]; p++) {
    const double *Gc = G + (size_t)E->ec[p] * (size_t)nC, v = E->ev[p];
    double *gi = g + (size_t)E->el[p] * (size_t)nC;
    for (r = 0; r < nC; r++) gi[r] += v * Gc[r];
  }
  for (b = 0; b < nb; b++) {
    double *B = blk + (size_t)b * (size_t)(d * d);
    memset(B, 0, (size_t)(d * d) * sizeof *B);
    for (q = E->ep[b]; q < E->ep[b + 1]; q++)
      for (i = 0; i < d; i++) B[i * d + E->el[q]] += c * E->ev[q] * g[(size_t)i * (size_t)nC + (size_t)E->ec[q]];
  }
}

static int block_nonzero(const double *B, int dd)
{
  int k;
  for (k = 0; k < dd; k++)
    if (B[k] != 0) return 1;
  return 0;
}

/* The nodal part from G = (What^-1)_CC, the inverse of the Schur complement on the contact dofs
   (T151): into the rows R (when rigid blocks add theirs), or straight into D's block rows in two
   passes (count, then fill), so that W is never held twice. */
static int build_schur(mo_delassus *D, const mo_csc *H, const mo_what_inverse *Wi, const cand_entries *E, double c,
                       rows *R, mo_ctx *ctx)
{
  int d = D->d, dd = d * d, nb = D->nb, nC = Wi->nlast, a, b, pass, st = MO_OK;
  double *G = NULL, *g = NULL, *blk = NULL;
  long nz;
  G = mo_malloc(ctx, (size_t)nC * (size_t)nC * sizeof *G + 1);
  g = mo_malloc(ctx, (size_t)d * (size_t)nC * sizeof *g + 1);
  blk = mo_malloc(ctx, (size_t)nb * (size_t)dd * sizeof *blk + 1);
  if (!G || !g || !blk) { st = MO_ENOMEM; goto done; }
  if ((st = mo_linsolver_schur_inverse(Wi->ls, G, ctx))) goto done;
  if (R) {
    for (a = 0; a < nb; a++) {
      if (E->ep[a] == E->ep[a + 1]) continue;
      schur_row(E, G, nC, d, nb, a, c, g, blk);
      for (b = 0; b < nb; b++)
        if (E->ep[b] < E->ep[b + 1] && block_nonzero(blk + (size_t)b * dd, dd) &&
            (st = rows_add(R, a, b, blk + (size_t)b * dd, ctx)))
          goto done;
    }
    goto done;
  }
  if (!(D->rowp = mo_calloc(ctx, (size_t)nb + 1, sizeof *D->rowp))) { st = MO_ENOMEM; goto done; }
  for (pass = 0; pass < 2; pass++) {
    for (a = 0, nz = 0; a < nb; a++) {
      if (E->ep[a] < E->ep[a + 1]) {
        schur_row(E, G, nC, d, nb, a, c, g, blk);
        for (b = 0; b < nb; b++) {
          const double *B = blk + (size_t)b * dd;
          if (E->ep[b] == E->ep[b + 1] || !block_nonzero(B, dd)) continue;
          if (pass) {
            D->colb[nz] = b;
            memcpy(D->val + (size_t)nz * dd, B, (size_t)dd * sizeof *B);
          }
          nz++;
        }
      }
      if (!pass) D->rowp[a + 1] = (int)nz;
    }
    if (!pass) {
      if (nz > INT_MAX) { st = mo_error(ctx, MO_ELIMIT, "the Delassus operator has %ld blocks (more than %d)", nz, INT_MAX); goto done; }
      D->colb = mo_malloc(ctx, ((size_t)nz + 1) * sizeof *D->colb);
      D->val = mo_malloc(ctx, ((size_t)nz * (size_t)dd + 1) * sizeof *D->val);
      if (!D->colb || !D->val) { st = MO_ENOMEM; goto done; }
      D->nblocks = nz;
    }
  }
done:
  mo_free(G);
  mo_free(g);
  mo_free(blk);
  return st;
}

/* The free nodal dofs the contact acts on, for the factorization to order last (T150): the
   rows of H over the candidates fixed at build, every dof of their slave nodes, and every node
   of the master facet sets of deformable masters (a point may pair again with any facet of its
   master); none when a detected pair touches a deformable body (its rows change every step).
   In the order of the candidates. *reserve: the bytes of W (T154). */
int mo_delassus_contact_dofs(const mo_contact *C, int **dofs, int *n, double *reserve, mo_ctx *ctx)
{
  const mo_scene *sc = C->sc;
  const mo_csc *H = C->H;
  int nfe = sc->nfe_free, dim = sc->dim, k, j, p, i, a, cnt = 0, st = MO_OK;
  unsigned char *mark = NULL;
  int *list = NULL;
  *dofs = NULL;
  *n = 0;
  *reserve = 0;
  if (!nfe || !H) return MO_OK;
  for (k = 0; k < C->npair; k++) {
    const mo_contact_pair *P = &C->pair[k];
    for (i = 0; P->dynamic && i < P->ns + P->nm; i++) {
      int b = i < P->ns ? P->sb[i] : P->mb[i - P->ns];
      if (sc->body[b].kind == MO_BODY_DEFORMABLE) return MO_OK;
    }
  }
  mark = mo_calloc(ctx, (size_t)nfe, 1);
  list = mo_malloc(ctx, (size_t)nfe * sizeof *list);
  if (!mark || !list) { st = MO_ENOMEM; goto done; }
#define ADD(fi) do { int f_ = (fi); if (f_ >= 0 && f_ < nfe && !mark[f_]) { mark[f_] = 1; list[cnt++] = f_; } } while (0)
  for (a = 0; a < C->nc_static; a++) {
    const mo_candidate *cd = &C->cand[a];
    for (j = a * dim; j < (a + 1) * dim && j < H->ncol; j++)
      for (p = H->p[j]; p < H->p[j + 1]; p++) ADD(H->i[p]);
    for (p = cd->first; p < cd->first + cd->np; p++) {
      const mo_cpoint *pt = &C->pt[C->cpt[p]];
      const mo_body *B = &sc->body[pt->sb];
      if (B->kind != MO_BODY_DEFORMABLE) continue;
      for (k = 0; k < pt->nn; k++)
        for (i = 0; i < dim; i++) ADD(sc->free_of[B->dof0 + pt->node[k] * dim + i]);
    }
  }
  for (k = 0; k < C->npair; k++) {
    const mo_contact_pair *P = &C->pair[k];
    const mo_body *B;
    const mo_facetset *fs;
    if (P->dynamic || P->master != MO_MASTER_FACETS || !P->mset) continue;
    B = &sc->body[P->mbody];
    if (B->kind != MO_BODY_DEFORMABLE || !(fs = mo_mesh_find_facetset(B->mesh, P->mset))) continue;
    for (j = 0; j < fs->n * fs->nfn; j++)
      for (i = 0; i < dim; i++) ADD(sc->free_of[B->dof0 + fs->node[j] * dim + i]);
  }
#undef ADD
  if (cnt) {
    double m = (double)C->nc_static * dim;
    *dofs = list;
    list = NULL;
    *n = cnt;
    *reserve = 8.0 * m * m;
  }
done:
  mo_free(mark);
  mo_free(list);
  return st;
}

int mo_stepper_create_contact(const mo_scene *sc, const mo_contact *C, int order_last, mo_stepper **S, mo_ctx *ctx)
{
  int *dofs = NULL, n = 0, st = MO_OK;
  double reserve = 0;
  if (C && order_last && (st = mo_delassus_contact_dofs(C, &dofs, &n, &reserve, ctx))) return st;
  st = mo_stepper_create_ordered(sc, n, dofs, reserve, S, ctx);
  mo_free(dofs);
  return st;
}

/* The rigid part: for every rigid block k, c H_ak^T inv_k H_bk over the pairs of candidates
   touching it, O(sum_k n_k^2) for n_k candidates on body k (T72). */
static int build_rigid(mo_delassus *D, const mo_csc *H, const mo_what_inverse *Wi, double c, rows *R, mo_ctx *ctx)
{
  int nfe = Wi->nfe, n = Wi->n, nr = n - nfe, d = D->d, m = H->ncol, nblk = Wi->nblk, st = MO_OK;
  int *blk_of = NULL, *cnt = NULL, *ecol = NULL, *erow = NULL, j, p, k, e;
  double *eval = NULL, *Hk = NULL, *Gk = NULL;
  int *cand = NULL;
  size_t ne = 0;
  if (!nblk) return MO_OK;
  blk_of = mo_malloc(ctx, ((size_t)nr + 1) * sizeof *blk_of);
  cnt = mo_calloc(ctx, (size_t)nblk + 2, sizeof *cnt);
  if (!blk_of || !cnt) { st = MO_ENOMEM; goto done; }
  for (k = 0; k < nblk; k++)
    for (j = Wi->off[k]; j < Wi->off[k + 1]; j++) blk_of[j - nfe] = k;
  for (j = 0; j < m; j++)
    for (p = H->p[j]; p < H->p[j + 1]; p++)
      if (H->i[p] >= nfe) { cnt[blk_of[H->i[p] - nfe] + 1]++; ne++; }
  if (!ne) goto done;
  for (k = 0; k < nblk; k++) cnt[k + 1] += cnt[k];
  ecol = mo_malloc(ctx, ne * sizeof *ecol);
  erow = mo_malloc(ctx, ne * sizeof *erow);
  eval = mo_malloc(ctx, ne * sizeof *eval);
  if (!ecol || !erow || !eval) { st = MO_ENOMEM; goto done; }
  /* entries grouped by block, in column order within a block (counting sort) */
  for (j = 0; j < m; j++)
    for (p = H->p[j]; p < H->p[j + 1]; p++)
      if (H->i[p] >= nfe) {
        int kb = blk_of[H->i[p] - nfe], q = cnt[kb]++;
        ecol[q] = j;
        erow[q] = H->i[p] - Wi->off[kb];
        eval[q] = H->x[p];
      }
  for (k = nblk; k > 0; k--) cnt[k] = cnt[k - 1];
  cnt[0] = 0;
  for (k = 0; k < nblk; k++) {
    int e0 = cnt[k], e1 = cnt[k + 1], nk = Wi->off[k + 1] - Wi->off[k], nc = 0, a, b, i, jj, q;
    double inv[36];
    if (e0 == e1) continue;
    mo_what_block(Wi, k, inv);
    /* the candidates on the block and their H_ak (nk x d, row-major), then G_ak = inv_k H_ak */
    mo_free(cand); mo_free(Hk); mo_free(Gk);
    cand = mo_malloc(ctx, (size_t)(e1 - e0) * sizeof *cand);
    Hk = mo_calloc(ctx, (size_t)(e1 - e0) * (size_t)(nk * d), sizeof *Hk);
    Gk = mo_calloc(ctx, (size_t)(e1 - e0) * (size_t)(nk * d), sizeof *Gk);
    if (!cand || !Hk || !Gk) { st = MO_ENOMEM; goto done; }
    for (e = e0; e < e1; e++) {
      int ca = ecol[e] / d;
      if (!nc || cand[nc - 1] != ca) cand[nc++] = ca;
      Hk[(size_t)(nc - 1) * (nk * d) + (size_t)(erow[e] * d + ecol[e] % d)] = eval[e];
    }
    for (a = 0; a < nc; a++)
      for (i = 0; i < nk; i++)
        for (jj = 0; jj < d; jj++) {
          double acc = 0;
          for (q = 0; q < nk; q++) acc += inv[i * nk + q] * Hk[(size_t)a * (nk * d) + (size_t)(q * d + jj)];
          Gk[(size_t)a * (nk * d) + (size_t)(i * d + jj)] = acc;
        }
    for (a = 0; a < nc; a++)
      for (b = 0; b < nc; b++) {
        double blk[9];
        const double *Ha = Hk + (size_t)a * (nk * d), *Gb = Gk + (size_t)b * (nk * d);
        for (i = 0; i < d; i++)
          for (jj = 0; jj < d; jj++) {
            double acc = 0;
            for (q = 0; q < nk; q++) acc += Ha[q * d + i] * Gb[q * d + jj];
            blk[i * d + jj] = c * acc;
          }
        if ((st = rows_add(R, cand[a], cand[b], blk, ctx))) goto done;
      }
  }
done:
  mo_free(blk_of); mo_free(cnt); mo_free(ecol); mo_free(erow); mo_free(eval);
  mo_free(cand); mo_free(Hk); mo_free(Gk);
  return st;
}

/* The normal column of every block, contiguous: its normal entry (T164) and its tangential ones
   (T176). The passes of frictionless solves over W_nn read one double a block instead of one in
   d^2 (72 bytes apart in 3D), and W r with r_t = 0 (mo_delassus_mult) d doubles a block in two
   streams instead of touching every byte of W. */
static int keep_normal(mo_delassus *D, mo_ctx *ctx)
{
  const int d = D->d;
  const size_t dd = (size_t)d * (size_t)d;
  long p;
  int i;
  mo_free(D->nn);
  mo_free(D->nt);
  D->nn = D->nt = NULL;
  if (d == 1) return MO_OK;
  if (!(D->nn = mo_malloc(ctx, ((size_t)D->nblocks + 1) * sizeof *D->nn)) ||
      !(D->nt = mo_malloc(ctx, ((size_t)D->nblocks * (size_t)(d - 1) + 1) * sizeof *D->nt)))
    return MO_ENOMEM;
  for (p = 0; p < D->nblocks; p++) {
    const double *blk = D->val + (size_t)p * dd;
    D->nn[p] = blk[0];
    for (i = 1; i < d; i++) D->nt[(size_t)p * (size_t)(d - 1) + (size_t)(i - 1)] = blk[i * d];
  }
  return MO_OK;
}

int mo_delassus_update(mo_delassus *D, const mo_csc *H, long hversion, const mo_what_inverse *Wi, double c, int dim,
                       int *rebuilt, mo_ctx *ctx)
{
  int m = H->ncol, n = H->nrow, st, covered = 0, rigid = 0, k, r0 = 0, r1, split;
  long fv = Wi->version * 1000003L;
  double t0;
  rows R;
  cand_entries E;
  if (rebuilt) *rebuilt = 0;
  if (Wi->ls) {
    long nf;
    mo_linsolver_stats(Wi->ls, &nf, NULL, NULL);
    fv += nf;
  }
  if (D->built && D->hversion == hversion && D->fversion == fv && D->c == c) return MO_OK;
  if (n != Wi->n) return mo_error(ctx, MO_EINTERNAL, "Delassus: H has %d rows, What %d", n, Wi->n);
  t0 = mo_clock();
  clear(D);
  memset(&R, 0, sizeof R);
  D->m = m;
  D->d = dim;
  D->nb = m / dim;
  D->nfree = n;
  D->nfe = Wi->nfe;
  D->c = c;
  D->work = mo_malloc(ctx, ((size_t)n + 1) * sizeof(double));
  D->y = mo_malloc(ctx, ((size_t)Wi->nfe + 1) * sizeof(double));
  if (!D->work || !D->y) { mo_phase_add(ctx, MO_PH_DELASSUS, t0); return MO_ENOMEM; }
  if ((st = cand_entries_build(H, Wi, dim, &E, &covered, ctx))) goto done;
  for (k = 0; k < H->p[m] && !rigid; k++) rigid = H->i[k] >= Wi->nfe;
  /* the solver's rows of the nodal block on this rank: all of them but over split ranks (T210) */
  r1 = Wi->nfe;
  if (Wi->ls && Wi->nfe && (st = mo_linsolver_solve_rows(Wi->ls, 0, NULL, NULL, &r0, &r1, ctx))) goto done;
  split = !covered && (r0 > 0 || r1 < Wi->nfe);
  if (covered && !rigid) {
    /* the factor's trailing block alone: W written once, in place */
    if ((st = build_schur(D, H, Wi, &E, c, NULL, ctx))) goto done;
  } else if ((st = rows_init(&R, D->nb, dim, ctx)) ||
             (st = covered ? build_schur(D, H, Wi, &E, c, &R, ctx)
                   : build_nodal(D, H, Wi, c, &R, split, split ? r0 : 0, split ? r1 : Wi->nfe, ctx)) ||
             (st = build_rigid(D, H, Wi, c, &R, ctx)) || (st = rows_compress(&R, D, ctx)))
    goto done;
  if ((st = keep_normal(D, ctx))) goto done;
  D->schur = covered;
  D->hversion = hversion;
  D->fversion = fv;
  D->built = 1;
  D->version++;
  if (rebuilt) *rebuilt = 1;
done:
  rows_free(&R);
  cand_entries_free(&E);
  if (st) clear(D);
  mo_phase_add(ctx, MO_PH_DELASSUS, t0);
  return st;
}

const double *mo_delassus_block(const mo_delassus *D, int a, int b)
{
  int p;
  for (p = D->rowp[a]; p < D->rowp[a + 1]; p++)
    if (D->colb[p] == b) return D->val + (size_t)p * (size_t)(D->d * D->d);
  return NULL;
}

int mo_delassus_row_normal(const mo_delassus *D, int a, const int **beta, const double **wn)
{
  *beta = D->colb + D->rowp[a];
  *wn = D->d == 1 ? D->val + D->rowp[a] : D->nn ? D->nn + D->rowp[a] : NULL;
  return D->rowp[a + 1] - D->rowp[a];
}

int mo_delassus_row(const mo_delassus *D, int a, const int **beta, const double **blocks)
{
  *beta = D->colb + D->rowp[a];
  *blocks = D->val + (size_t)D->rowp[a] * (size_t)(D->d * D->d);
  return D->rowp[a + 1] - D->rowp[a];
}

/* y = W x + beta y for x with no tangential component, from the normal column's copies (T176). */
static void mult_normal_column(const mo_delassus *D, const double *x, double beta, double *y)
{
  const int d = D->d;
  int a, p, i;
  for (a = 0; a < D->nb; a++) {
    double acc[3] = {0, 0, 0};
    for (p = D->rowp[a]; p < D->rowp[a + 1]; p++) {
      const double xb = x[D->colb[p] * d], *t = D->nt + (size_t)p * (size_t)(d - 1);
      acc[0] += D->nn[p] * xb;
      for (i = 1; i < d; i++) acc[i] += t[i - 1] * xb;
    }
    for (i = 0; i < d; i++) y[a * d + i] = acc[i] + (beta == 0 ? 0 : beta * y[a * d + i]);
  }
}

/* y = W x + beta y for block size d (a constant where the caller below passes one: the loops over
   a block unrolled, the same sums in the same order) */
static inline __attribute__((always_inline)) void mult_blocks(const mo_delassus *D, const double *x, double beta,
                                                              double *y, const int d)
{
  int a, p, i, j, nonly = d > 1;
  /* x without tangential components (frictionless contacts' impulses): the normal column of each
     block alone, a third of the reads in 3D and the same sums (the skipped terms are zeros) (T160),
     read from its contiguous copy (T176): the same sums in the same order */
  for (a = 0; a < D->nb && nonly; a++)
    for (i = 1; i < d; i++) nonly &= x[a * d + i] == 0;
  if (nonly && D->nn && D->nt) {
    mult_normal_column(D, x, beta, y);
    return;
  }
  for (a = 0; a < D->nb; a++) {
    double acc[3] = {0, 0, 0};
    for (p = D->rowp[a]; p < D->rowp[a + 1]; p++) {
      const double *blk = D->val + (size_t)p * (size_t)(d * d), *xb = x + D->colb[p] * d;
      if (nonly)
        for (i = 0; i < d; i++) acc[i] += blk[i * d] * xb[0];
      else
        for (i = 0; i < d; i++)
          for (j = 0; j < d; j++) acc[i] += blk[i * d + j] * xb[j];
    }
    for (i = 0; i < d; i++) y[a * d + i] = acc[i] + (beta == 0 ? 0 : beta * y[a * d + i]);
  }
}

void mo_delassus_mult(const mo_delassus *D, const double *x, double beta, double *y)
{
  /* a few candidates (the small rigid scenes: 1-2): the loops' set-up was most of the product */
  if (D->d == 2) mult_blocks(D, x, beta, y, 2);
  else if (D->d == 3) mult_blocks(D, x, beta, y, 3);
  else mult_blocks(D, x, beta, y, D->d);
}

int mo_delassus_dense(const mo_delassus *D, double **out, mo_ctx *ctx)
{
  int d = D->d, m = D->m, a, p, i, j;
  double *W = mo_calloc(ctx, (size_t)m * (size_t)m + 1, sizeof(double));
  *out = NULL;
  if (!W) return MO_ENOMEM;
  for (a = 0; a < D->nb; a++)
    for (p = D->rowp[a]; p < D->rowp[a + 1]; p++)
      for (i = 0; i < d; i++)
        for (j = 0; j < d; j++)
          W[(size_t)(a * d + i) * (size_t)m + (size_t)(D->colb[p] * d + j)] = D->val[(size_t)p * (size_t)(d * d) + (size_t)(i * d + j)];
  *out = W;
  return MO_OK;
}

/* dx = What^-1 (H r) when H's nodal rows are the factor's trailing ones (T153): the forward
   solve of H r is L22's alone (zero above), then one backward solve; the rigid rows by their
   blocks. work holds H r. */
static int apply_trailing(mo_delassus *D, const mo_what_inverse *Wi, double *dx, mo_ctx *ctx)
{
  int n = D->nfree, nfe = Wi->nfe, nC = Wi->nlast, nI = nfe - nC, k, st;
  mo_what_inverse Wr = *Wi;
  memset(D->y, 0, (size_t)nI * sizeof *D->y);
  for (k = 0; k < nC; k++) D->y[nI + k] = D->work[Wi->last[k]];
  if ((st = mo_linsolver_split(Wi->ls, MO_SPLIT_TRAIL_FORWARD, D->y + nI, D->y + nI, ctx)) ||
      (st = mo_linsolver_split(Wi->ls, MO_SPLIT_BACKWARD, D->y, dx, ctx)))
    return st;
  if (n == nfe) return MO_OK;
  Wr.nfe = 0; /* the rigid blocks alone, on their rows of work */
  if ((st = mo_what_solve(&Wr, 1, D->work, D->work, ctx))) return st;
  memcpy(dx + nfe, D->work + nfe, (size_t)(n - nfe) * sizeof(double));
  return MO_OK;
}

int mo_delassus_apply_Cinv(mo_delassus *D, const mo_csc *H, const mo_what_inverse *Wi, const double *r,
                           double *dx, mo_ctx *ctx)
{
  double t0 = mo_clock();
  int st = apply_Cinv(D, H, Wi, r, dx, ctx);
  mo_phase_add(ctx, MO_PH_CORRECT, t0);
  return st;
}

/* y = the columns' rows r0 .. r1-1 times r (C's rows on this process). */
static void rows_product(const mo_delassus *D, const double *r, double *y)
{
  int nloc = D->r1 - D->r0, d = D->d, j, i;
  memset(y, 0, (size_t)nloc * sizeof *y);
  for (j = 0; j < D->m; j++) {
    const double *col;
    double rj = r[j];
    if (rj == 0 || D->fecol[j / d] < 0) continue;
    col = D->C + ((size_t)D->fecol[j / d] * d + (size_t)(j % d)) * (size_t)nloc;
    for (i = 0; i < nloc; i++) y[i] += rj * col[i];
  }
}

static int apply_Cinv(mo_delassus *D, const mo_csc *H, const mo_what_inverse *Wi, const double *r, double *dx,
                      mo_ctx *ctx)
{
  int n = H->nrow, m = H->ncol, nfe = Wi->nfe, j, p, st;
  /* What^-1 (H r): the rigid rows by their blocks; the nodal rows from the trailing block, from
     the kept columns, or by one solve */
  memset(D->work, 0, (size_t)n * sizeof(double));
  for (j = 0; j < m; j++)
    if (r[j] != 0)
      for (p = H->p[j]; p < H->p[j + 1]; p++) D->work[H->i[p]] += H->x[p] * r[j];
  if (D->schur && nfe && mo_linsolver_has_split(Wi->ls)) return apply_trailing(D, Wi, dx, ctx);
  if (!D->C || !nfe) return mo_what_solve(Wi, 1, D->work, dx, ctx);
  if (D->rcnt) {
    /* this rank's rows from its rows of the columns, then one gather (T212) */
    rows_product(D, r, D->part);
    if ((st = mo_par_gatherv(D->part, D->rcnt, dx, ctx))) return st;
  } else
    rows_product(D, r, dx);
  if (n > nfe) {
    mo_what_inverse Wr = *Wi;
    Wr.nfe = 0; /* the rigid blocks alone; their rows of work are what they act on */
    memcpy(D->work, dx, (size_t)nfe * sizeof(double));
    st = mo_what_solve(&Wr, 1, D->work, D->work, ctx);
    if (st) return st;
    memcpy(dx + nfe, D->work + nfe, (size_t)(n - nfe) * sizeof(double));
  }
  return MO_OK;
}

static int cmp_int(const void *a, const void *b)
{
  int x = *(const int *)a, y = *(const int *)b;
  return (x > y) - (x < y);
}

int mo_delassus_set_matrix(mo_delassus *D, const mo_csc *W, int dim, mo_ctx *ctx)
{
  int m = W->nrow, d = dim, nb, a, i, p, k, st = MO_OK, *mark = NULL, *list = NULL;
  mo_csc *T = NULL;
  if (W->ncol != m || d < 1 || d > 3 || m % d)
    return mo_error(ctx, MO_EINPUT, "a Delassus operator is square with a size that is a multiple of its "
                    "local dimension (got %d x %d, dimension %d)", W->nrow, W->ncol, dim);
  clear(D);
  nb = m / d;
  /* rows of W are the columns of W^T */
  if ((st = mo_csc_transpose(W, &T, ctx))) return st;
  mark = mo_malloc(ctx, ((size_t)nb + 1) * sizeof *mark);
  list = mo_malloc(ctx, ((size_t)nb + 1) * sizeof *list);
  D->rowp = mo_malloc(ctx, ((size_t)nb + 1) * sizeof *D->rowp);
  if (!mark || !list || !D->rowp) { st = MO_ENOMEM; goto done; }
  for (a = 0; a < nb; a++) mark[a] = -1;
  /* count the block columns of each block row */
  D->rowp[0] = 0;
  for (a = 0; a < nb; a++) {
    int n = 0;
    for (i = a * d; i < a * d + d; i++)
      for (p = T->p[i]; p < T->p[i + 1]; p++) {
        int b = T->i[p] / d;
        if (T->x[p] != 0 && mark[b] != a) { mark[b] = a; n++; }
      }
    D->rowp[a + 1] = D->rowp[a] + n;
  }
  D->nblocks = D->rowp[nb];
  D->colb = mo_malloc(ctx, ((size_t)D->nblocks + 1) * sizeof *D->colb);
  D->val = mo_calloc(ctx, (size_t)D->nblocks * (size_t)(d * d) + 1, sizeof *D->val);
  if (!D->colb || !D->val) { st = MO_ENOMEM; goto done; }
  for (a = 0; a < nb; a++) mark[a] = -1;
  for (a = 0; a < nb; a++) {
    int n = 0, r0 = D->rowp[a];
    for (i = a * d; i < a * d + d; i++)
      for (p = T->p[i]; p < T->p[i + 1]; p++) {
        int b = T->i[p] / d;
        if (T->x[p] != 0 && mark[b] != a) { mark[b] = a; list[n++] = b; }
      }
    qsort(list, (size_t)n, sizeof *list, cmp_int);
    for (k = 0; k < n; k++) {
      D->colb[r0 + k] = list[k];
      mark[list[k]] = -2 - (r0 + k);           /* position of block column list[k] in row a */
    }
    for (i = a * d; i < a * d + d; i++)
      for (p = T->p[i]; p < T->p[i + 1]; p++) {
        int j = T->i[p], b = j / d;
        if (T->x[p] != 0) D->val[(size_t)(-2 - mark[b]) * (size_t)(d * d) + (size_t)((i - a * d) * d + j % d)] = T->x[p];
      }
    for (k = 0; k < n; k++) mark[list[k]] = a;
  }
  D->m = m;
  D->d = d;
  D->nb = nb;
  D->nfree = 0;
  D->c = 1;
  D->hversion = D->fversion = -1;
  if ((st = keep_normal(D, ctx))) goto done;
  D->built = 1;
  D->version++;
done:
  if (st) clear(D);
  mo_csc_free(T);
  mo_free(mark);
  mo_free(list);
  return st;
}

long mo_delassus_version(const mo_delassus *D)
{
  return D->version;
}
