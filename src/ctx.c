/* ctx.c: error recording, counted allocation with failure injection, phase timers. */
#include "config.h"
#include <moreau/ctx.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

void mo_ctx_init(mo_ctx *ctx)
{
  memset(ctx, 0, sizeof *ctx);
  ctx->verbosity = 1;
  ctx->seed = 1;
  ctx->nranks = 1;
}

mo_ctx *mo_ctx_create(void)
{
  mo_ctx *ctx = malloc(sizeof *ctx);
  if (ctx) mo_ctx_init(ctx);
  return ctx;
}

void mo_ctx_destroy(mo_ctx *ctx)
{
  if (!ctx) return;
  mo_ctx_release(ctx); /* plugin.c: what a context owns */
  free(ctx);
}

int mo_verror(mo_ctx *ctx, int code, const char *fmt, va_list ap)
{
  if (ctx->status != MO_OK) return code; /* keep the root cause */
  ctx->status = code;
  vsnprintf(ctx->errmsg, sizeof ctx->errmsg, fmt, ap);
  return code;
}

int mo_error(mo_ctx *ctx, int code, const char *fmt, ...)
{
  va_list ap;
  va_start(ap, fmt);
  mo_verror(ctx, code, fmt, ap);
  va_end(ap);
  return code;
}

int mo_error_prefix(mo_ctx *ctx, const char *fmt, ...)
{
  char pre[512];
  size_t lp, lm;
  va_list ap;
  if (ctx->status == MO_OK) return MO_OK;
  va_start(ap, fmt);
  vsnprintf(pre, sizeof pre, fmt, ap);
  va_end(ap);
  lp = strlen(pre);
  lm = strlen(ctx->errmsg);
  if (lp + 2 + lm >= sizeof ctx->errmsg) lm = sizeof ctx->errmsg - lp - 3;
  memmove(ctx->errmsg + lp + 2, ctx->errmsg, lm);
  memcpy(ctx->errmsg, pre, lp);
  ctx->errmsg[lp] = ':';
  ctx->errmsg[lp + 1] = ' ';
  ctx->errmsg[lp + 2 + lm] = '\0';
  return ctx->status;
}

void mo_ctx_clear_error(mo_ctx *ctx)
{
  ctx->status = MO_OK;
  ctx->errmsg[0] = '\0';
}

const char *mo_strerror(int code)
{
  switch (code) {
  case MO_OK: return "success";
  case MO_ENOMEM: return "out of memory";
  case MO_EINPUT: return "invalid input";
  case MO_EIO: return "input/output error";
  case MO_EOUTPUT: return "output not written";
  case MO_ESINGULAR: return "singular matrix";
  case MO_ENOCONV: return "no convergence";
  case MO_ENAN: return "NaN or infinity";
  case MO_ELIMIT: return "size limit exceeded";
  case MO_EINTERRUPT: return "interrupted";
  case MO_EUNSUPPORTED: return "unsupported";
  case MO_EINTERNAL: return "internal error";
  default: return "unknown error";
  }
}

static int alloc_refused(mo_ctx *ctx)
{
  if (!ctx) return 0;
  ctx->alloc_calls++;
  return ctx->alloc_fail_at > 0 && ctx->alloc_calls == ctx->alloc_fail_at;
}

void *mo_malloc(mo_ctx *ctx, size_t n)
{
  void *p = alloc_refused(ctx) ? NULL : malloc(n ? n : 1);
  if (!p && ctx) mo_error(ctx, MO_ENOMEM, "out of memory (request of %zu bytes)", n);
  return p;
}

void *mo_calloc(mo_ctx *ctx, size_t count, size_t size)
{
  void *p = alloc_refused(ctx) ? NULL : calloc(count ? count : 1, size ? size : 1);
  if (!p && ctx) mo_error(ctx, MO_ENOMEM, "out of memory (request of %zu x %zu bytes)", count, size);
  return p;
}

void *mo_realloc(mo_ctx *ctx, void *p, size_t n)
{
  void *q = alloc_refused(ctx) ? NULL : realloc(p, n ? n : 1);
  if (!q && ctx) mo_error(ctx, MO_ENOMEM, "out of memory (request of %zu bytes)", n);
  return q;
}

char *mo_strdup(mo_ctx *ctx, const char *s)
{
  size_t n = strlen(s) + 1;
  char *d = mo_malloc(ctx, n);
  if (d) memcpy(d, s, n);
  return d;
}

void mo_free(void *p)
{
  free(p);
}

/* The phase timers' clock: the monotonic wall clock, or with MOREAU_CLOCK=cpu the thread's CPU
   time, which a loaded machine does not inflate (the time the thread waits for a processor is
   not counted: benchmarks that compare phases of runs on a shared machine, bench/levelset_cost.sh). */
double mo_clock(void)
{
  static int cpu = -1;
  struct timespec ts;
  if (cpu < 0) {
    const char *e = getenv("MOREAU_CLOCK");
    cpu = e && !strcmp(e, "cpu");
  }
  clock_gettime(cpu ? CLOCK_THREAD_CPUTIME_ID : CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

void mo_phase_add(mo_ctx *ctx, mo_phase ph, double t0)
{
  ctx->phase_time[ph] += mo_clock() - t0;
  ctx->phase_calls[ph]++;
}

double mo_phase_total(const mo_ctx *ctx)
{
  double t = 0;
  int p;
  for (p = 0; p < MO_PH_N; p++) t += ctx->phase_time[p];
  return t;
}

void mo_phase_rest(mo_ctx *ctx, mo_phase ph, double t0, double inner0)
{
  double rest = (mo_clock() - t0) - (mo_phase_total(ctx) - inner0);
  if (rest > 0) ctx->phase_time[ph] += rest;
  ctx->phase_calls[ph]++;
}

const char *mo_phase_name(mo_phase ph)
{
  static const char *names[MO_PH_N] = {"setup",    "assembly", "factor", "solve",
                                       "geometry", "delassus", "contact", "output", "broad",
                                       "correct",  "local",    "metrics"};
  return (unsigned)ph < MO_PH_N ? names[ph] : "?";
}

double mo_memory_limit(void)
{
  double mem = (double)sysconf(_SC_PHYS_PAGES) * (double)sysconf(_SC_PAGE_SIZE);
  struct rlimit rl;
  if (!(mem > 0)) mem = 8e9;
  if (getrlimit(RLIMIT_AS, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY && (double)rl.rlim_cur < mem)
    mem = (double)rl.rlim_cur;
  return mem;
}

double mo_memory_rss(void)
{
  long pages = 0, rss = 0;
  FILE *f = fopen("/proc/self/statm", "r");
  if (f) {
    if (fscanf(f, "%ld %ld", &pages, &rss) != 2) rss = 0;
    fclose(f);
  }
  return (double)rss * (double)sysconf(_SC_PAGE_SIZE);
}

void mo_note_skip(mo_ctx *ctx, const char *fmt, ...)
{
  char buf[160];
  va_list ap;
  int i;
  va_start(ap, fmt);
  vsnprintf(buf, sizeof buf, fmt, ap);
  va_end(ap);
  for (i = 0; i < ctx->nskip; i++)
    if (!strcmp(ctx->skipped[i], buf)) return;
  if (ctx->nskip < MO_MAX_SKIPS) memcpy(ctx->skipped[ctx->nskip++], buf, sizeof buf);
}

void mo_log(const mo_ctx *ctx, int level, const char *fmt, ...)
{
  va_list ap;
  if (level <= 0 || !ctx || ctx->verbosity < level) return;
  /* every rank of an MPI run takes the same steps: one of them speaks */
  if (ctx->rank != 0) return;
  va_start(ap, fmt);
  vfprintf(stderr, fmt, ap);
  va_end(ap);
}
