/* api.c: runs and comparisons through opaque objects (moreau/api.h), for foreign-function
   interfaces that cannot copy struct layouts (the Python module, python/moreau). */
#include "config.h"
#include <moreau/api.h>
#include <moreau/backend.h>
#include <moreau/compare.h>
#include <moreau/run.h>

#include <math.h>
#include <string.h>

int mo_ctx_status(const mo_ctx *ctx)
{
  return ctx->status;
}

const char *mo_ctx_message(const mo_ctx *ctx)
{
  return ctx->errmsg;
}

void mo_ctx_set_verbosity(mo_ctx *ctx, int verbosity)
{
  ctx->verbosity = verbosity < 0 ? 0 : verbosity > 3 ? 3 : verbosity;
}

const char *mo_version(void)
{
  return PACKAGE_VERSION;
}

/* A growing list of copied strings. */
typedef struct {
  int n, cap;
  char **s;
} strlist;

static int strlist_add(strlist *L, const char *s, mo_ctx *ctx)
{
  char *c;
  if (L->n == L->cap) {
    int cap = L->cap ? 2 * L->cap : 8;
    char **p = mo_realloc(ctx, L->s, (size_t)cap * sizeof *p);
    if (!p) return MO_ENOMEM;
    L->s = p;
    L->cap = cap;
  }
  if (!(c = mo_strdup(ctx, s))) return MO_ENOMEM;
  L->s[L->n++] = c;
  return MO_OK;
}

static void strlist_free(strlist *L)
{
  int k;
  for (k = 0; k < L->n; k++) mo_free(L->s[k]);
  mo_free(L->s);
}

/* Replace *dst by a copy of src (NULL: none). */
static int set_string(char **dst, const char *src, mo_ctx *ctx)
{
  char *c = NULL;
  if (src && !(c = mo_strdup(ctx, src))) return MO_ENOMEM;
  mo_free(*dst);
  *dst = c;
  return MO_OK;
}

/* --- runs ------------------------------------------------------------------------------------ */

struct mo_run_job {
  char *case_path, *solver, *outdir, *dump_fclib;
  strlist sets;
  int log;
  mo_run_result res;
};

int mo_run_job_create(const char *case_path, mo_run_job **out, mo_ctx *ctx)
{
  mo_run_job *J;
  *out = NULL;
  if (!case_path || !case_path[0]) return mo_error(ctx, MO_EINPUT, "run: which case? (a folder holding case.cfg, or a file)");
  if (!(J = mo_calloc(ctx, 1, sizeof *J))) return MO_ENOMEM;
  if (!(J->case_path = mo_strdup(ctx, case_path))) {
    mo_free(J);
    return MO_ENOMEM;
  }
  *out = J;
  return MO_OK;
}

void mo_run_job_free(mo_run_job *J)
{
  if (!J) return;
  mo_free(J->case_path);
  mo_free(J->solver);
  mo_free(J->outdir);
  mo_free(J->dump_fclib);
  strlist_free(&J->sets);
  mo_free(J);
}

int mo_run_job_solver(mo_run_job *J, const char *spec, mo_ctx *ctx) { return set_string(&J->solver, spec, ctx); }
int mo_run_job_add_set(mo_run_job *J, const char *assign, mo_ctx *ctx) { return strlist_add(&J->sets, assign, ctx); }
int mo_run_job_outdir(mo_run_job *J, const char *dir, mo_ctx *ctx) { return set_string(&J->outdir, dir, ctx); }
int mo_run_job_dump_fclib(mo_run_job *J, const char *dir, mo_ctx *ctx) { return set_string(&J->dump_fclib, dir, ctx); }
void mo_run_job_log(mo_run_job *J, int on) { J->log = on != 0; }

static void run_options(const mo_run_job *J, mo_run_options *o)
{
  memset(o, 0, sizeof *o);
  o->case_path = J->case_path;
  o->solver = J->solver;
  o->nset = J->sets.n;
  o->sets = (const char *const *)J->sets.s;
  o->outdir = J->outdir;
  o->dump_fclib = J->dump_fclib;
  o->log = J->log;
}

int mo_run_job_exec(mo_run_job *J, mo_ctx *ctx)
{
  mo_run_options o;
  run_options(J, &o);
  return mo_run(&o, &J->res, ctx);
}

int mo_run_job_check(mo_run_job *J, mo_ctx *ctx)
{
  mo_run_options o;
  run_options(J, &o);
  return mo_check(&o, ctx);
}

long mo_run_job_steps(const mo_run_job *J) { return J->res.steps; }
double mo_run_job_time(const mo_run_job *J) { return J->res.t; }
double mo_run_job_wall(const mo_run_job *J) { return J->res.wall; }
double mo_run_job_step_wall(const mo_run_job *J) { return J->res.step_wall; }
double mo_run_job_energy(const mo_run_job *J, int end) { return end ? J->res.energy1 : J->res.energy0; }
int mo_run_job_complete(const mo_run_job *J) { return J->res.complete; }
int mo_run_job_summary_written(const mo_run_job *J) { return J->res.summary; }
const char *mo_run_job_out(const mo_run_job *J) { return J->res.outdir; }
int mo_run_job_nmetrics(const mo_run_job *J) { return J->res.nmetric; }

const char *mo_run_job_metric(const mo_run_job *J, int k, double *l2, double *linf)
{
  if (k < 0 || k >= J->res.nmetric) return NULL;
  if (l2) *l2 = J->res.metric_l2[k];
  if (linf) *linf = J->res.metric_linf[k];
  return J->res.metric_name[k];
}

/* --- comparisons ----------------------------------------------------------------------------- */

#define MAX_SOLVERS 16
#define MAX_DT 64
#define MAX_VALUES 64

struct mo_compare_job {
  char *case_path, *outdir, *metric;
  strlist solvers, sets, peers, vary_keys, vary_vals[MO_COMPARE_MAX_VARY];
  int ndt, repeat;
  double dt[MAX_DT], reference, penetration_tol;
  char default_out[4200];
  mo_compare_result res;
};

int mo_compare_job_create(const char *case_path, mo_compare_job **out, mo_ctx *ctx)
{
  mo_compare_job *J;
  char tmp[4096], *base;
  size_t l;
  *out = NULL;
  if (!case_path || !case_path[0]) return mo_error(ctx, MO_EINPUT, "compare: which case?");
  if (!(J = mo_calloc(ctx, 1, sizeof *J))) return MO_ENOMEM;
  if (!(J->case_path = mo_strdup(ctx, case_path))) {
    mo_free(J);
    return MO_ENOMEM;
  }
  /* out/compare-<case name>, as the command line's default */
  snprintf(tmp, sizeof tmp, "%s", case_path);
  l = strlen(tmp);
  while (l > 1 && tmp[l - 1] == '/') tmp[--l] = '\0';
  base = strrchr(tmp, '/');
  snprintf(J->default_out, sizeof J->default_out, "out/compare-%s", base ? base + 1 : tmp);
  *out = J;
  return MO_OK;
}

void mo_compare_job_free(mo_compare_job *J)
{
  int k;
  if (!J) return;
  mo_free(J->case_path);
  mo_free(J->outdir);
  mo_free(J->metric);
  strlist_free(&J->solvers);
  strlist_free(&J->sets);
  strlist_free(&J->peers);
  strlist_free(&J->vary_keys);
  for (k = 0; k < MO_COMPARE_MAX_VARY; k++) strlist_free(&J->vary_vals[k]);
  mo_free(J);
}

int mo_compare_job_add_solver(mo_compare_job *J, const char *spec, mo_ctx *ctx)
{
  if (J->solvers.n == MAX_SOLVERS) return mo_error(ctx, MO_EINPUT, "compare: at most %d back ends", MAX_SOLVERS);
  return strlist_add(&J->solvers, spec, ctx);
}

int mo_compare_job_add_dt(mo_compare_job *J, double dt, mo_ctx *ctx)
{
  if (J->ndt == MAX_DT) return mo_error(ctx, MO_EINPUT, "compare: at most %d time steps", MAX_DT);
  if (!(dt > 0) || !isfinite(dt)) return mo_error(ctx, MO_EINPUT, "compare: %g is not a positive time step", dt);
  J->dt[J->ndt++] = dt;
  return MO_OK;
}

int mo_compare_job_add_vary(mo_compare_job *J, const char *key, const char *value, mo_ctx *ctx)
{
  int k, st;
  for (k = 0; k < J->vary_keys.n && strcmp(J->vary_keys.s[k], key); k++) continue;
  if (k == J->vary_keys.n) {
    if (k == MO_COMPARE_MAX_VARY) return mo_error(ctx, MO_EINPUT, "compare: at most %d varied keys", MO_COMPARE_MAX_VARY);
    if ((st = strlist_add(&J->vary_keys, key, ctx))) return st;
  }
  if (J->vary_vals[k].n == MAX_VALUES) return mo_error(ctx, MO_EINPUT, "compare: at most %d values of %s", MAX_VALUES, key);
  return strlist_add(&J->vary_vals[k], value, ctx);
}

int mo_compare_job_add_set(mo_compare_job *J, const char *assign, mo_ctx *ctx) { return strlist_add(&J->sets, assign, ctx); }
int mo_compare_job_add_peer(mo_compare_job *J, const char *csv_file, mo_ctx *ctx) { return strlist_add(&J->peers, csv_file, ctx); }
int mo_compare_job_outdir(mo_compare_job *J, const char *dir, mo_ctx *ctx) { return set_string(&J->outdir, dir, ctx); }
int mo_compare_job_metric(mo_compare_job *J, const char *name, mo_ctx *ctx) { return set_string(&J->metric, name, ctx); }

int mo_compare_job_repeat(mo_compare_job *J, int n, mo_ctx *ctx)
{
  if (n < 0 || n > 20) return mo_error(ctx, MO_EINPUT, "compare: repeat %d: 1 to 20 runs per cell (0: adaptive)", n);
  J->repeat = n;
  return MO_OK;
}

int mo_compare_job_reference(mo_compare_job *J, double dt, mo_ctx *ctx)
{
  if (!(dt >= 0)) return mo_error(ctx, MO_EINPUT, "compare: reference %g is not a time step", dt);
  J->reference = dt;
  return MO_OK;
}

int mo_compare_job_penetration_tol(mo_compare_job *J, double f, mo_ctx *ctx)
{
  if (!(f >= 0)) return mo_error(ctx, MO_EINPUT, "compare: penetration tolerance %g is not a fraction", f);
  J->penetration_tol = f;
  return MO_OK;
}

int mo_compare_job_exec(mo_compare_job *J, mo_ctx *ctx)
{
  mo_compare_options o;
  int k;
  memset(&o, 0, sizeof o);
  o.case_path = J->case_path;
  o.nsolver = J->solvers.n;
  o.solvers = (const char *const *)J->solvers.s;
  o.ndt = J->ndt;
  o.dt = J->dt;
  o.nvary = J->vary_keys.n;
  for (k = 0; k < o.nvary; k++) {
    o.vary[k].key = J->vary_keys.s[k];
    o.vary[k].nval = J->vary_vals[k].n;
    o.vary[k].val = (const char *const *)J->vary_vals[k].s;
  }
  o.nset = J->sets.n;
  o.sets = (const char *const *)J->sets.s;
  o.npeer = J->peers.n;
  o.peers = (const char *const *)J->peers.s;
  o.outdir = J->outdir ? J->outdir : J->default_out;
  o.metric = J->metric;
  o.repeat = J->repeat;
  o.reference_dt = J->reference;
  o.penetration_tol = J->penetration_tol;
  return mo_compare(&o, &J->res, ctx);
}

const char *mo_compare_job_out(const mo_compare_job *J)
{
  return J->outdir ? J->outdir : J->default_out;
}

int mo_compare_job_count(const mo_compare_job *J, const char *what)
{
  static const char *const names[] = {"run", "stable", "chatter", "unstable", "failed", "marked", "figures",
                                      "rendered", "peer"};
  const int v[] = {J->res.nrun, J->res.nstable, J->res.nchatter, J->res.nunstable, J->res.nfailed, J->res.nmarked,
                   J->res.nfigures, J->res.rendered, J->res.npeer};
  size_t k;
  for (k = 0; k < MO_COUNT(names); k++)
    if (!strcmp(names[k], what)) return v[k];
  return -1;
}

/* --- the back ends a context sees -------------------------------------------------------------- */

int mo_backend_count(const mo_ctx *ctx)
{
  return mo_contact_solver_total(ctx);
}

const char *mo_backend_name(const mo_ctx *ctx, int i, const char **summary)
{
  const mo_contact_solver_type *T = i >= 0 && i < mo_contact_solver_total(ctx) ? mo_contact_solver_nth(i, ctx) : NULL;
  if (summary) *summary = T ? T->summary : NULL;
  return T ? T->name : NULL;
}
