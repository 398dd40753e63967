/* moreau/ctx.h: the context carried by every call (errors, allocation, timers, statistics). */
#ifndef MOREAU_CTX_H
#define MOREAU_CTX_H

#include <stddef.h>
#include <stdarg.h>
#include <signal.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Status codes. Every fallible function returns one; 0 is success. A contact solve that does not
   converge is not an error: it is a reason in the contact report (see contact.h). */
enum {
  MO_OK = 0,
  MO_ENOMEM = 1,     /* allocation failed (or was refused by the injection allocator) */
  MO_EINPUT = 2,     /* bad case file, option or argument: the message names file, line, key */
  MO_EIO = 3,        /* a file could not be read or written */
  MO_ESINGULAR = 4,  /* a matrix that must be definite or invertible is not */
  MO_ENOCONV = 5,    /* an iteration the run depends on did not converge */
  MO_ENAN = 6,       /* a NaN or an infinity appeared */
  MO_ELIMIT = 7,     /* a size limit was exceeded (refused before allocating) */
  MO_EINTERRUPT = 8, /* SIGINT or SIGTERM */
  MO_EUNSUPPORTED = 9, /* the scene asks for something this build or back end cannot do */
  MO_EINTERNAL = 10, /* a broken invariant: a bug */
  MO_EOUTPUT = 11    /* an output could not be written (a full disk): the run failed, exit 1 */
};

/* Phases timed by the core; `moreau run --log` prints them as a table. */
typedef enum {
  MO_PH_SETUP = 0, /* reading the case, meshing, dof numbering */
  MO_PH_ASSEMBLY,  /* element loops, triplet to CSC */
  MO_PH_FACTOR,    /* symbolic and numeric factorizations */
  MO_PH_SOLVE,     /* triangular solves and matrix-vector products of the stepper */
  MO_PH_GEOMETRY,  /* contact pairing, frames, gaps, H */
  MO_PH_DELASSUS,  /* W = H^T What^-1 H */
  MO_PH_CONTACT,   /* the back end's solve */
  MO_PH_OUTPUT,    /* histories, fields, summaries */
  MO_PH_BROAD,     /* the broad phase of the rigid shapes (Verlet list and cell grid), out of geometry */
  MO_PH_CORRECT,   /* the correction What^-1 H r of a contact impulse (with the split step's backward solve) */
  MO_PH_LOCAL,     /* the core's part of a contact step that no other phase takes: the local
                      problem (H^T x_free, offsets, index set), the measure of the solve (U = W r +
                      q, residual), the impulse H r, the contact work, the candidate set's arrays */
  MO_PH_METRICS,   /* the run's per-step records: chatter, penetration and momenta metrics, and the
                      state kept for step cutting */
  MO_PH_N
} mo_phase;

#define MO_ERRMSG_MAX 2048
#define MO_MAX_SKIPS 32

typedef struct mo_ctx {
  /* error state: the first error recorded wins until mo_ctx_clear_error */
  int status;
  char errmsg[MO_ERRMSG_MAX];
  /* verbosity: 0 quiet, 1 normal, 2 log, 3 debug */
  int verbosity;
  /* allocation failure injection (tests): when alloc_fail_at > 0, the alloc_fail_at-th
     allocation through mo_malloc & co. fails; alloc_calls counts them */
  long alloc_calls;
  long alloc_fail_at;
  /* per-phase wall time (s) and call counts */
  double phase_time[MO_PH_N];
  long phase_calls[MO_PH_N];
  /* work the scene did not need, reported by --log (doc/architecture.md §9) */
  int nskip;
  char skipped[MO_MAX_SKIPS][160];
  /* seed of every random choice (contact ordering, random test problems) */
  unsigned long seed;
  /* when non-NULL, a flag set asynchronously (SIGINT/SIGTERM handler of the program); long
     loops poll it and stop cleanly with MO_EINTERRUPT */
  volatile sig_atomic_t *interrupt;
  /* size limits, refused with MO_ELIMIT before allocating (0: the defaults, 2e7 dofs) */
  long max_dofs;
  /* MPI runs (moreau/parallel.h): this process's rank among nranks (0 of 1 when serial), and
     the collective calls made through it: their number, seconds and the bytes each rank sent
     (doc/parallel.md: the measured communication behind the projections) */
  int rank, nranks;
  const void *par_module;  /* the PETSc module once loaded (parallel.c), else NULL */
  long par_calls;
  double par_time, par_bytes;
  /* the granular sweep split over the ranks (nscd, doc/parallel.md §4): the solves and sweeps so
     split, the interface bodies and the largest slab's share of the active contacts over its
     mean, summed over those solves */
  long par_grain_solves, par_grain_sweeps;
  long par_grain_serial; /* split sweeps that stalled and went on as the serial sweep on every rank */
  double par_grain_interface, par_grain_imbalance;
  long par_grain_detparts; /* split solves whose parts were the detection's owners (T341) */
  /* the granular detection split over the ranks (doc/parallel.md §4, (T215)): the candidates the
     largest rank detected itself, and every rank's, over the run */
  long par_detect_largest, par_detect_total;
  int par_dset;              /* the contact set distributed over the ranks (contact.distributed_set) */
  int par_held;                          /* the bodies' state was held per rank (doc/theory.md §13.18) */
  long par_state_moved, par_state_joins; /* the bodies' state per rank: records sent at the builds,
                                            joins of every body's state (the outputs') */
  long par_detect_builds, par_detect_boxpts; /* builds of the split list; those whose boxes were cut
                                                 from the last solve's contact points (T341) */
  /* the Delassus build's columns What^-1 H^T (doc/parallel.md §2, (T210)): the most nodal rows of
     them one rank held (the largest rank's, over the builds), the nodal rows whole, the columns */
  long par_column_rows, par_column_dofs, par_columns;
  /* contact back ends loaded at run time (moreau/backend.h): owned by the context that loaded
     them, shared by its copies (a comparison's runs), unloaded by mo_ctx_release */
  struct mo_plugins *plugins;
  /* the memory a run may take (bytes; 0: the machine's, mo_memory_limit): the factorization's
     check against it (doc/theory.md (T154)) */
  double max_bytes;
  /* the granular sweep over more than 2 ranks: the interface bodies touched by the contacts of
     more than 2 ranks (doc/theory.md (T332)), summed over the split solves */
  double par_grain_multi;
  /* granular solves over the ranks swept whole on every rank, their set too small to split
     (nscd's split_min, doc/theory.md (T333)) */
  long par_grain_whole;
} mo_ctx;

/* 1 when the program was asked to stop (SIGINT, SIGTERM): the long loops of loading and
   building poll it every few thousand items and return MO_EINTERRUPT. */
#define MO_INTERRUPTED(ctx) ((ctx)->interrupt && *(ctx)->interrupt)

/* Initialise a context with defaults (verbosity 1, seed 1, no injection). */
void mo_ctx_init(mo_ctx *ctx);
/* Release what a context owns (its plug-ins) and initialise it again. Copies of it must not be
   used afterwards. */
void mo_ctx_release(mo_ctx *ctx);
/* A context on the heap, for callers that cannot know its layout (moreau/api.h): created with
   mo_ctx_init's defaults, destroyed with what it owns. NULL when memory is short. */
mo_ctx *mo_ctx_create(void);
void mo_ctx_destroy(mo_ctx *ctx);

/* Record an error (printf-style message) and return `code`. The first error is kept; later ones
   are ignored until mo_ctx_clear_error, so the root cause is what the user reads. */
int mo_error(mo_ctx *ctx, int code, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
int mo_verror(mo_ctx *ctx, int code, const char *fmt, va_list ap);
/* Prepend context to the recorded message ("while X: <message>"). Returns ctx->status. */
int mo_error_prefix(mo_ctx *ctx, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
void mo_ctx_clear_error(mo_ctx *ctx);
const char *mo_strerror(int code);

/* Allocation through the context: counted, and failing on purpose under injection. Returned
   memory is released with mo_free (plain free is equivalent). mo_malloc(ctx, 0) returns a
   valid pointer. Leaks are the business of valgrind and LeakSanitizer, run on the tests. On failure these record MO_ENOMEM in ctx and return NULL. */
void *mo_malloc(mo_ctx *ctx, size_t n);
void *mo_calloc(mo_ctx *ctx, size_t count, size_t size);
void *mo_realloc(mo_ctx *ctx, void *p, size_t n);
char *mo_strdup(mo_ctx *ctx, const char *s);
void mo_free(void *p);

/* Wall clock in seconds (CLOCK_MONOTONIC). */
double mo_clock(void);
/* Add the time since t0 to phase ph. */
void mo_phase_add(mo_ctx *ctx, mo_phase ph, double t0);
/* The time of every phase so far; and the time since t0 that no phase took since then (the
   phases' total was `inner0` at t0) added to phase ph: the work of a section around calls that
   time themselves. */
double mo_phase_total(const mo_ctx *ctx);
void mo_phase_rest(mo_ctx *ctx, mo_phase ph, double t0, double inner0);
const char *mo_phase_name(mo_phase ph);

/* Memory (bytes): what a run may take (the physical memory, or RLIMIT_AS when lower) and its
   resident size now. */
double mo_memory_limit(void);
double mo_memory_rss(void);

/* Record (once) a piece of work the scene did not need. */
void mo_note_skip(mo_ctx *ctx, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* Messages on stderr by verbosity level (0 never printed by the library). */
void mo_log(const mo_ctx *ctx, int level, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* Number of elements of a static array. */
#define MO_COUNT(a) (sizeof(a) / sizeof((a)[0]))

#ifdef __cplusplus
}
#endif
#endif
