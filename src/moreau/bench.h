/* moreau/bench.h: `moreau bench-local`: the nscd back end measured on FCLIB local problems,
   side by side with Siconos' NSGS when the build has Siconos (solvers/nscd/bench.c). */
#ifndef MOREAU_BENCH_H
#define MOREAU_BENCH_H

#include <stdio.h>

#include <moreau/contact.h>

#ifdef __cplusplus
extern "C" {
#endif

/* --- moreau bench-local ----------------------------------------------------------------------- */

typedef struct {
  double tol;            /* accuracy of the solve whose sweeps, residual and update cost are
                            reported (natural-map residual (T10); default 1e-8) */
  int max_sweeps;        /* iteration limit of every solve, ours and Siconos' (default 20000) */
  double min_time;       /* each timing repeats cold solves for at least this long and keeps the
                            fastest (s; default 0.2) */
  int vs_siconos;        /* also solve with Siconos' NSGS (fc2d/fc3d) and print the ratios */
  int siconos_dense;     /* give Siconos a dense W (default: its sparse-block storage) */
} mo_bench_options;

void mo_bench_options_default(mo_bench_options *o);
/* 1 when this build can compare with Siconos. */
int mo_bench_have_siconos(void);
/* Read each FCLIB file (local, or global reduced to W = H^T M^-1 H), solve it cold with nscd
   to o->tol, 1e-4 and 1e-8 (natural map, T10), and print per problem: contacts, sweeps,
   final residual, time to 1e-4 and 1e-8, microseconds per contact update; with vs_siconos the
   same for Siconos' NSGS and the ratios Siconos / ours. */
int mo_bench_local(const char *const *files, int nfiles, const mo_bench_options *o, FILE *out,
                   mo_ctx *ctx);

#ifdef __cplusplus
}
#endif
#endif
