/* moreau/run.h: running a case end to end (what `moreau run` and `moreau check` do). */
#ifndef MOREAU_RUN_H
#define MOREAU_RUN_H

#include <moreau/ctx.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct {
  const char *case_path;        /* case folder or file */
  const char *solver;           /* --solver: contact back end (overrides contact.solver) */
  int nset;
  const char *const *sets;      /* --set KEY=VALUE, applied in order */
  const char *outdir;           /* --out (default: out/<case name>) */
  int log;                      /* --log: timing table and skipped work */
  int progress;                 /* draw a progress bar on stderr */
  const char *dump_fclib;       /* --dump-fclib DIR */
  int no_draw;                  /* leave output.draw out (the runs of a comparison) */
  int map_large;                /* the program's: on the granular path, blocks of 16 kB and more
                                   mapped rather than taken from the heap (doc/theory.md (T235), (T280)) */
} mo_run_options;

typedef struct {
  long steps;                   /* steps completed */
  double t;                     /* time reached */
  double wall;                  /* wall time (s) */
  double step_wall;             /* of which the steps alone (no setup, no output) */
  double energy0, energy1;      /* total mechanical energy at start and end */
  int complete;                 /* 1 when the run reached its end time */
  int summary;                  /* 1 when summary.json was written (complete or not) */
  char outdir[4096];
  int nmetric;                  /* errors against the reference */
  char metric_name[32][64];
  double metric_l2[32], metric_linf[32];
  unsigned outputs;             /* the files written in outdir (MO_OUT_* bits) */
  int vtk_frames;               /* frames of the VTK series */
} mo_run_result;

/* The files of a run's folder (mo_run_result.outputs), named at the end of `moreau run`. */
enum {
  MO_OUT_HISTORY = 1u << 0,         /* history.csv */
  MO_OUT_SUMMARY = 1u << 1,         /* summary.json */
  MO_OUT_CONTACT = 1u << 2,         /* contact.csv: the last step's candidates */
  MO_OUT_CONTACT_HISTORY = 1u << 3, /* contact_history.csv: the candidates of every output step */
  MO_OUT_BODIES = 1u << 4,          /* bodies.csv */
  MO_OUT_FIELDS = 1u << 5,          /* fields.pvd and its fields_BODY_NNNNN.vtu */
  MO_OUT_CONTACT_POINTS = 1u << 6,  /* contact_points.pvd */
  MO_OUT_PLANES = 1u << 7,          /* planes.pvd */
  MO_OUT_RIGID = 1u << 8,           /* particles.pvd, polygons.pvd, contacts.pvd, particles.py */
  MO_OUT_DRAW = 1u << 9             /* plots/: the drawings of output.draw */
};

/* Load, override, validate and build the scene without running it. */
int mo_check(const mo_run_options *opt, mo_ctx *ctx);
/* Run a case: outputs in opt->outdir (history.csv, summary.json, fields.pvd when asked).
   On failure the outputs written so far stay readable and summary.json says "incomplete". */
int mo_run(const mo_run_options *opt, mo_run_result *res, mo_ctx *ctx);

#ifdef __cplusplus
}
#endif
#endif
