/* dist_assembly.c: K and M of a case over MPI ranks, the two ways of doc/parallel.md §3, side by
   side in one process per rank: the scene's assembly (each rank its block of elements, then the
   sums that make K and M whole on every rank) and the distributed one (each rank its block of
   elements added straight into PETSc's matrices, its own rows only). Prints the slowest rank's
   seconds of each and the largest rank's bytes of K and M: the whole CSC matrices for the first,
   the heap the distributed matrices take for the second (glibc's in-use bytes, mallinfo2, before
   and after: PETSc's rows, their preallocation and the rows' order).

     cc -O2 -I src -I build bench/dist_assembly.c -L build/.libs -lmoreau -o /tmp/dist_assembly
     mpirun -np 2 env LD_LIBRARY_PATH=build/.libs /tmp/dist_assembly CASE [--set KEY=VALUE ...]

   bench/mpi_scaling.sh --assembly runs it on the boxes. */
#include <malloc.h>
#include <stdio.h>
#include <string.h>
#include <moreau/moreau.h>
#include <moreau/case.h>
#include <moreau/scene.h>
#include <moreau/sparse.h>
#include <moreau/parallel.h>

static double heap(void)
{
  struct mallinfo2 m = mallinfo2();
  return (double)m.uordblks + (double)m.hblkhd;
}

static double csc_bytes(const mo_csc *A)
{
  return A ? 12.0 * mo_csc_nnz(A) + 4.0 * (A->ncol + 1) : 0;
}

int main(int argc, char **argv)
{
  mo_ctx ctx;
  mo_case *cs = NULL;
  mo_scene *sc = NULL;
  mo_dist_assembly a;
  int k, st;
  /* slowest seconds and largest bytes over the ranks: build, its K+M, distributed, its heap,
     entries stored, entries sent, rows */
  double t0, f[7];
  long nnz = 0, sent = 0, alloc = 0;
  mo_ctx_init(&ctx);
  if (argc < 2) {
    fprintf(stderr, "usage: dist_assembly CASE [--set KEY=VALUE ...]\n");
    return 2;
  }
  if ((st = mo_parallel_start(&argc, &argv, &ctx))) goto fail;
  if ((st = mo_case_load(argv[1], &cs, &ctx))) goto fail;
  for (k = 2; k + 1 < argc; k += 2)
    if (!strcmp(argv[k], "--set") && (st = mo_case_set(cs, argv[k + 1], &ctx))) goto fail;
  if ((st = mo_case_validate(cs, &ctx))) goto fail;
  t0 = mo_clock();
  if ((st = mo_scene_build(cs, &sc, &ctx))) goto fail;
  f[0] = mo_clock() - t0;
  f[1] = csc_bytes(sc->K) + csc_bytes(sc->M);
  f[3] = heap();
  if ((st = mo_scene_assemble_distributed(sc, sc->M != NULL, &a, &ctx))) goto fail;
  f[2] = a.seconds;
  f[3] = heap() - f[3];
  mo_dmat_counts(a.K, &nnz, &alloc, &sent);
  f[4] = (double)nnz;
  f[5] = (double)sent;
  mo_dmat_counts(a.M, &nnz, &alloc, &sent);
  f[4] += (double)nnz;
  f[5] += (double)sent;
  f[6] = a.rend - a.rstart;
  if ((st = mo_par_max(f, 7, &ctx))) goto fail;
  if (ctx.rank == 0)
    printf("ranks %d dofs %d scene_build_s %.3f replicated_KM_MB %.1f distributed_s %.3f distributed_KM_MB %.1f "
           "entries_max %.0f sent_max %.0f local %.3f rows_max %.0f\n", ctx.nranks, sc->ndof, f[0], f[1] / 1e6, f[2], f[3] / 1e6,
           f[4], f[5], a.local, f[6]);
  mo_dist_assembly_free(&a);
  mo_scene_free(sc);
  mo_case_free(cs);
  mo_parallel_finish(&ctx);
  return 0;
fail:
  fprintf(stderr, "dist_assembly (rank %d): %s\n", ctx.rank, ctx.errmsg);
  mo_parallel_finish(&ctx);
  return 1;
}
