/* box_ordering.c: the factor of the box of bench/box_scaling.sh under several orderings, by
   CHOLMOD's symbolic analysis alone (no numeric factorization: a few seconds and about 1 GB at
   68^3, where the factor would take 25 GB). The pattern is the stiffness matrix's of an n^3 H8
   grid, 3 dofs per node, every node coupled to its 26 neighbours; the contact dofs C are those
   of the (n + 1)^2 bottom nodes (doc/theory.md (T150)-(T152), (T154)).

     cc -O2 -I/usr/include/suitesparse bench/box_ordering.c -lcholmod -o /tmp/box_ordering
     /tmp/box_ordering [--only NAME,NAME] 45 [68 ...]

   One line per ordering: nnz(L), the supernodal storage xsize and the bytes of (T154)'s factor
   term, 8 (xsize + ssize + 3 nsuper):
     whole      CHOLMOD's default on A, C anywhere (the fallback when the ordered factor is too large)
     I:amd      AMD on A_II, C last in the given order (CHOLMOD's default picks AMD or METIS)
     I:metis    METIS on A_II, C last
     I:nesdis   CHOLMOD's nested dissection on A_II, C last
     I:metis-n  METIS on A_II, only the normal (z) dofs of C last: a frictionless pair's W is
                W_nn alone, 1 of the 3 dofs of each contact node (T160)
     camd       CAMD on A with C constrained last (one ordering, C's order its own)
   --only runs the named ones alone (the 68^3 box takes about 2 min for each). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <suitesparse/cholmod.h>

typedef SuiteSparse_long sl;

/* the lower triangle of the pattern, columns sorted */
static cholmod_sparse *grid(int n, cholmod_common *c)
{
  sl m = n + 1, nodes = m * m * m, N = 3 * nodes, nz = 0, col = 0;
  cholmod_sparse *A = cholmod_l_allocate_sparse(N, N, N * 81 / 2 + 3 * N, 1, 1, -1, CHOLMOD_PATTERN, c);
  sl *Ap = A->p, *Ai = A->i, x, y, z;
  if (!A) return NULL;
  for (z = 0; z < m; z++)
    for (y = 0; y < m; y++)
      for (x = 0; x < m; x++) {
        int a;
        for (a = 0; a < 3; a++, col++) {
          sl dz, dy, dx, b;
          Ap[col] = nz;
          /* neighbours in increasing node order: rows 3 nb + b >= col */
          for (dz = -1; dz <= 1; dz++)
            for (dy = -1; dy <= 1; dy++)
              for (dx = -1; dx <= 1; dx++) {
                sl X = x + dx, Y = y + dy, Z = z + dz, nb;
                if (X < 0 || Y < 0 || Z < 0 || X >= m || Y >= m || Z >= m) continue;
                nb = (Z * m + Y) * m + X;
                for (b = 0; b < 3; b++)
                  if (3 * nb + b >= col) Ai[nz++] = 3 * nb + b;
              }
        }
      }
  Ap[N] = nz;
  return A;
}

static void report(const char *name, cholmod_factor *L, cholmod_common *c)
{
  double lnz = c->lnz, bytes;
  if (!L) {
    printf("  %-9s failed (status %d)\n", name, c->status);
    return;
  }
  bytes = L->is_super ? 8.0 * ((double)L->xsize + (double)L->ssize + 3.0 * (double)L->nsuper) : 8.0 * lnz;
  printf("  %-9s nnz(L) %.4g  xsize %.4g  factor %.2f GB  flops %.3g  largest update %.2f GB\n", name, lnz,
         (double)L->xsize, bytes / 1e9, c->fl, 8.0 * (double)L->maxcsize / 1e9);
}

/* the order of A_II by one method, C appended in order, then the supernodal analysis */
static void ordered(const char *name, cholmod_sparse *A, const sl *Cset, sl nC, int method, cholmod_common *c)
{
  sl N = A->ncol, nI = N - nC, k, j, p, q = 0;
  sl *map = malloc(N * sizeof *map), *perm = malloc(N * sizeof *perm), *Ap = A->p, *Ai = A->i;
  cholmod_sparse *B = cholmod_l_allocate_sparse(nI, nI, Ap[N], 1, 1, -1, CHOLMOD_PATTERN, c);
  cholmod_factor *LI, *L;
  sl *Bp = B->p, *Bi = B->i;
  for (j = 0; j < N; j++) map[j] = 0;
  for (k = 0; k < nC; k++) map[Cset[k]] = -1;
  for (j = 0, k = 0; j < N; j++)
    if (map[j] == 0) map[j] = k++;
  for (j = 0, k = 0; j < N; j++) {
    if (map[j] < 0) continue;
    Bp[k++] = q;
    for (p = Ap[j]; p < Ap[j + 1]; p++)
      if (map[Ai[p]] >= 0) Bi[q++] = map[Ai[p]];
  }
  Bp[nI] = q;
  c->nmethods = 1;
  c->method[0].ordering = method;
  c->supernodal = CHOLMOD_SIMPLICIAL;
  LI = cholmod_l_analyze(B, c);
  c->supernodal = CHOLMOD_SUPERNODAL;
  if (!LI) {
    printf("  %-9s failed on A_II (status %d)\n", name, c->status);
    goto done;
  }
  {
    sl *rest = malloc(nI * sizeof *rest);
    for (j = 0, k = 0; j < N; j++)
      if (map[j] >= 0) rest[k++] = j;
    for (k = 0; k < nI; k++) perm[k] = rest[((sl *)LI->Perm)[k]];
    for (k = 0; k < nC; k++) perm[nI + k] = Cset[k];
    free(rest);
  }
  cholmod_l_free_factor(&LI, c);
  c->nmethods = 1;
  c->method[0].ordering = CHOLMOD_GIVEN;
  c->postorder = 0;
  L = cholmod_l_analyze_p(A, perm, NULL, 0, c);
  c->postorder = 1;
  report(name, L, c);
  cholmod_l_free_factor(&L, c);
done:
  cholmod_l_free_sparse(&B, c);
  free(map);
  free(perm);
}

static const char *only = NULL;

/* whether the ordering NAME is asked for (--only: a comma-separated list) */
static int wanted(const char *name)
{
  size_t l = strlen(name);
  const char *p = only;
  if (!only) return 1;
  while ((p = strstr(p, name))) {
    if ((p == only || p[-1] == ',') && (p[l] == ',' || p[l] == 0)) return 1;
    p += l;
  }
  return 0;
}

int main(int argc, char **argv)
{
  int a;
  for (a = 1; a < argc; a++) {
    int n;
    sl m, nC, k, N;
    sl *Cset, *Cz;
    if (!strcmp(argv[a], "--only") && a + 1 < argc) {
      only = argv[++a];
      continue;
    }
    n = atoi(argv[a]);
    m = n + 1;
    nC = 3 * m * m;
    cholmod_common c;
    cholmod_sparse *A;
    cholmod_factor *L;
    if (n < 1) return 2;
    cholmod_l_start(&c);
    c.print = 0;
    if (!(A = grid(n, &c))) return 1;
    N = A->ncol;
    Cset = malloc(nC * sizeof *Cset);
    Cz = malloc(m * m * sizeof *Cz);
    for (k = 0; k < nC; k++) Cset[k] = k; /* the bottom layer's nodes come first in the grid */
    for (k = 0; k < m * m; k++) Cz[k] = 3 * k + 2; /* their z dofs */
    printf("n = %d: %ld dofs, nnz(A) %ld (lower), %ld contact dofs\n", n, (long)N, (long)((sl *)A->p)[N], (long)nC);
    fflush(stdout);
    if (wanted("whole")) {
      c.nmethods = 0; /* CHOLMOD's default choice */
      L = cholmod_l_analyze(A, &c);
      report("whole", L, &c);
      cholmod_l_free_factor(&L, &c);
      fflush(stdout);
    }
    if (wanted("I:amd")) ordered("I:amd", A, Cset, nC, CHOLMOD_AMD, &c);
    fflush(stdout);
    if (wanted("I:metis")) ordered("I:metis", A, Cset, nC, CHOLMOD_METIS, &c);
    fflush(stdout);
    if (wanted("I:metis-n")) ordered("I:metis-n", A, Cz, m * m, CHOLMOD_METIS, &c);
    fflush(stdout);
    if (wanted("I:nesdis")) ordered("I:nesdis", A, Cset, nC, CHOLMOD_NESDIS, &c);
    fflush(stdout);
    if (wanted("camd")) {
      sl *Cm = malloc(N * sizeof *Cm), *perm = malloc(N * sizeof *perm);
      for (k = 0; k < N; k++) Cm[k] = k < nC;
      if (!cholmod_l_camd(A, NULL, 0, Cm, perm, &c)) printf("  camd      failed (status %d)\n", c.status);
      else {
        c.nmethods = 1;
        c.method[0].ordering = CHOLMOD_GIVEN;
        c.postorder = 0;
        L = cholmod_l_analyze_p(A, perm, NULL, 0, &c);
        c.postorder = 1;
        report("camd", L, &c);
        cholmod_l_free_factor(&L, &c);
      }
      free(Cm);
      free(perm);
    }
    cholmod_l_free_sparse(&A, &c);
    free(Cset);
    free(Cz);
    cholmod_l_finish(&c);
  }
  return 0;
}
