/* moreau/api.h: runs and comparisons through opaque objects, for callers that cannot know the
   layout of moreau's structs (Python's ctypes, other languages' foreign-function interfaces):
   a context from mo_ctx_create (moreau/ctx.h), a job built by calls, its results read by
   accessors. The options mirror the command line's (doc/moreau.1). */
#ifndef MOREAU_API_H
#define MOREAU_API_H

#include <moreau/ctx.h>

#ifdef __cplusplus
extern "C" {
#endif

/* --- the context's state ----------------------------------------------------------------------- */

/* The status and the message of the first error recorded (0 and "" when none). */
int mo_ctx_status(const mo_ctx *ctx);
const char *mo_ctx_message(const mo_ctx *ctx);
/* 0 quiet, 1 normal (warnings on stderr), 2 the run's log, 3 debug. */
void mo_ctx_set_verbosity(mo_ctx *ctx, int verbosity);
/* The library's version ("0.1.0"). */
const char *mo_version(void);

/* --- a run (moreau run) ------------------------------------------------------------------------ */

typedef struct mo_run_job mo_run_job;

/* A run of the case at case_path (a folder holding case.cfg, or a file). Strings are copied. */
int mo_run_job_create(const char *case_path, mo_run_job **out, mo_ctx *ctx);
void mo_run_job_free(mo_run_job *J);
/* --solver SPEC (a back end or BACKEND[:PRESET][[KEY=VALUE;...]]); NULL: the case's. */
int mo_run_job_solver(mo_run_job *J, const char *spec, mo_ctx *ctx);
/* --set KEY=VALUE, applied in the order given. */
int mo_run_job_add_set(mo_run_job *J, const char *assign, mo_ctx *ctx);
/* --out DIR (NULL: out/<case name> under the working folder). */
int mo_run_job_outdir(mo_run_job *J, const char *dir, mo_ctx *ctx);
/* --dump-fclib DIR (NULL: none). */
int mo_run_job_dump_fclib(mo_run_job *J, const char *dir, mo_ctx *ctx);
/* --log: the timing table and the skipped work on stderr. */
void mo_run_job_log(mo_run_job *J, int on);
/* Run it (mo_run), or only check it (mo_check: load, override, validate, build). A run that
   fails returns its status with the message in ctx; the accessors then tell how far it got. */
int mo_run_job_exec(mo_run_job *J, mo_ctx *ctx);
int mo_run_job_check(mo_run_job *J, mo_ctx *ctx);
/* After mo_run_job_exec: steps done, time reached, wall time of the run and of its steps
   alone, total mechanical energy at the start and at the end, whether it reached its end time,
   whether summary.json was written, the output folder. */
long mo_run_job_steps(const mo_run_job *J);
double mo_run_job_time(const mo_run_job *J);
double mo_run_job_wall(const mo_run_job *J);
double mo_run_job_step_wall(const mo_run_job *J);
double mo_run_job_energy(const mo_run_job *J, int end);
int mo_run_job_complete(const mo_run_job *J);
int mo_run_job_summary_written(const mo_run_job *J);
const char *mo_run_job_out(const mo_run_job *J);
/* The errors against the case's reference: their number, and the k-th's name, relative L2 and
   Linf errors (NULL for k out of range). */
int mo_run_job_nmetrics(const mo_run_job *J);
const char *mo_run_job_metric(const mo_run_job *J, int k, double *l2, double *linf);

/* --- a comparison (moreau compare) ------------------------------------------------------------- */

typedef struct mo_compare_job mo_compare_job;

int mo_compare_job_create(const char *case_path, mo_compare_job **out, mo_ctx *ctx);
void mo_compare_job_free(mo_compare_job *J);
/* --solvers: one back end or formulation per call (at most 16). */
int mo_compare_job_add_solver(mo_compare_job *J, const char *spec, mo_ctx *ctx);
/* --dt: one time step per call (at most 64). */
int mo_compare_job_add_dt(mo_compare_job *J, double dt, mo_ctx *ctx);
/* --vary KEY=v1,v2,...: one value per call; the keys in the order they first come (at most 4
   keys of 64 values). */
int mo_compare_job_add_vary(mo_compare_job *J, const char *key, const char *value, mo_ctx *ctx);
int mo_compare_job_add_set(mo_compare_job *J, const char *assign, mo_ctx *ctx);
int mo_compare_job_add_peer(mo_compare_job *J, const char *csv_file, mo_ctx *ctx);
/* --out DIR (NULL: out/compare-<case name>), --metric NAME, --repeat N (0: adaptive),
   --reference DT (0: none), --penetration-tol F (0: the default, 0.01). */
int mo_compare_job_outdir(mo_compare_job *J, const char *dir, mo_ctx *ctx);
int mo_compare_job_metric(mo_compare_job *J, const char *name, mo_ctx *ctx);
int mo_compare_job_repeat(mo_compare_job *J, int n, mo_ctx *ctx);
int mo_compare_job_reference(mo_compare_job *J, double dt, mo_ctx *ctx);
int mo_compare_job_penetration_tol(mo_compare_job *J, double f, mo_ctx *ctx);
int mo_compare_job_exec(mo_compare_job *J, mo_ctx *ctx);
/* After mo_compare_job_exec: the output folder, and the counts of runs by class: what is one
   of "run", "stable", "chatter", "unstable", "failed", "marked" (cells not run), "figures",
   "rendered", "peer" (rows of the peer files); -1 for another word. */
const char *mo_compare_job_out(const mo_compare_job *J);
int mo_compare_job_count(const mo_compare_job *J, const char *what);

/* --- plug-ins (moreau/backend.h) and the back ends a context sees ------------------------------ */

/* The back ends of the registry, then the plug-ins loaded into ctx: their number, and the i-th's
   name and one-line summary (NULL out of range). */
int mo_backend_count(const mo_ctx *ctx);
const char *mo_backend_name(const mo_ctx *ctx, int i, const char **summary);

#ifdef __cplusplus
}
#endif
#endif
