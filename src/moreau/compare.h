/* moreau/compare.h: the same scene by several back ends, time steps and parameter grids. */
#ifndef MOREAU_COMPARE_H
#define MOREAU_COMPARE_H

#include <moreau/ctx.h>

#ifdef __cplusplus
extern "C" {
#endif

#define MO_COMPARE_MAX_VARY 4

/* One --vary KEY=v1,v2,... */
typedef struct {
  const char *key;
  int nval;
  const char *const *val;
} mo_compare_vary;

typedef struct {
  const char *case_path;
  int nsolver;
  const char *const *solvers;  /* back ends (none: the case's) */
  int ndt;
  const double *dt;            /* time steps (none: the case's) */
  int nvary;                   /* --vary KEY=v1,v2,...: a grid over every key */
  mo_compare_vary vary[MO_COMPARE_MAX_VARY];
  int nset;
  const char *const *sets;     /* --set KEY=VALUE for every run */
  const char *outdir;
  const char *metric;          /* the error of the work-precision figure (a compare.csv column) */
  double penetration_tol;      /* unstable above this fraction of the smallest element (0.01) */
  int npeer;
  const char *const *peers;    /* --peer FILE.csv: rows measured by another program, in
                                  compare.csv's columns (at least solver, dt, wall_s) */
  int repeat;                  /* --repeat N: runs of each cell, timed by the median of their
                                  step times; 0: adaptive, until the median is stable, up to 5 */
  double reference_dt;         /* --reference DT: one more run per back end and grid point at
                                  DT, the reference of the others (0: none; the finest run of
                                  the sweep is the reference) */
} mo_compare_options;

typedef struct {
  int nrun, nstable, nunstable, nfailed;
  int nchatter;                /* runs classed chatter (doc/theory.md (T97)) */
  int nmarked;                 /* grid cells not run: the back end ignores a varied key */
  int nfigures, rendered;      /* figures scripted, and rendered by gnuplot */
  int npeer;                   /* rows read from the peer files */
} mo_compare_result;

/* Run every (back end, time step, grid point); write compare.csv (solver, dt, the varied keys,
   wall_s, steps, status, class, reason, the step times (min, median, max over the repeats) and
   the number of repeats, then every metric of summary.json flattened as name.sub, and the
   errors against the finest run, ref.*), orders.csv (Richardson's observed orders, (T98)),
   stability.csv when keys vary, report.md, and plots/ (gnuplot scripts and their
   PNG and SVG renderings when gnuplot is present). A failing run is recorded, not fatal; a
   case that does not load (or an interrupt) stops the comparison: what was run is written, and
   the error is returned. Rows of the peer files join the
   work-precision figure (one dashed line per peer solver) and report.md's table, marked
   external; they are not written to compare.csv. */
int mo_compare(const mo_compare_options *opt, mo_compare_result *res, mo_ctx *ctx);

#ifdef __cplusplus
}
#endif
#endif
