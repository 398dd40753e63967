/* main.c: the moreau command line (argument handling and messages only; no numerics). */
#include "config.h"
#include <moreau/moreau.h>

#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Set by SIGINT/SIGTERM; the library polls it through ctx.interrupt. */
static volatile sig_atomic_t interrupted = 0;

static void on_signal(int sig)
{
  (void)sig;
  interrupted = 1;
}

/* SIGINT and SIGTERM set the flag that the library polls (ctx.interrupt). */
static void catch_signals(mo_ctx *ctx)
{
  struct sigaction sa;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_signal;
  sigaction(SIGINT, &sa, NULL);
  sigaction(SIGTERM, &sa, NULL);
  ctx->interrupt = &interrupted;
}

static void usage(FILE *f)
{
  fprintf(f,
          "usage: moreau COMMAND [ARGS]\n"
          "\n"
          "  run CASE [--solver S] [--set KEY=VALUE]... [--out DIR] [--log] [--quiet]\n"
          "          [--dump-fclib DIR]\n"
          "            run a case (a folder holding case.cfg, or a file); outputs in DIR\n"
          "            (default out/<case>): history.csv, summary.json, fields.pvd;\n"
          "            --dump-fclib: the contact problem each step solved, as an FCLIB local\n"
          "            problem DIR/step-NNNNNN.hdf5: the candidates of the step's index set, W,\n"
          "            q, mu and the step's solution r, U = W r + q (the file's info says so)\n"
          "  compare CASE [--solvers a,b,...] [--dt h1,h2,...] [--vary KEY=v1,v2,...]...\n"
          "          [--set KEY=VALUE]... [--out DIR] [--metric NAME] [--penetration-tol F]\n"
          "          [--repeat N] [--reference DT]\n"
          "            the same scene by several back ends and time steps (and parameter grids):\n"
          "            compare.csv, orders.csv, stability.csv, report.md, plots/ (default\n"
          "            out/compare-<case>); classes stable, chatter, unstable, failed;\n"
          "            --repeat N: runs per cell, timed by the median step time (default:\n"
          "            until the median is stable, at most 5); --reference DT: one more run\n"
          "            per back end at DT, the reference of the others (else the finest)\n"
          "          [--peer FILE.csv]...: another program's rows (compare.csv's columns) join the\n"
          "            work-precision figure and report.md\n"
          "  check CASE [--solver S] [--set KEY=VALUE]...\n"
          "            validate a case and build its scene without running it\n"
          "  bench-local FILE.hdf5... [--tol T] [--vs-siconos] [--max-sweeps N] [--min-time S]\n"
          "            [--siconos-dense]\n"
          "            the nscd solver on FCLIB local problems: sweeps, residual, time to 1e-4\n"
          "            and 1e-8, cost per contact update (with Siconos' NSGS side by side)\n"
          "  list-solvers   the registered contact back ends and their papers' presets\n"
          "  keys           every case-file key with its type, range and default\n"
          "  --version, --help\n"
          "\n"
          "S is a back end, or a formulation BACKEND[:PRESET][[KEY=VALUE;...]]: levelset:bdz07,\n"
          "nscd:jean88, nscd[theta=0.5] (moreau list-solvers).\n"
          "\n"
          "Exit status: 0 success, 1 the run failed (the outputs say how far it got; also an\n"
          "output that could not be written, a full disk),\n"
          "2 bad command line or case file. See moreau(1) and doc/case-format.md.\n");
}

typedef struct {
  mo_run_options o;
  const char **sets;
  int quiet;
} cli;

static int parse_run_args(int argc, char **argv, int i, cli *c)
{
  c->sets = calloc((size_t)argc, sizeof *c->sets);
  if (!c->sets) return 2;
  c->o.sets = c->sets;
  c->o.progress = 1;
  for (; i < argc; i++) {
    const char *a = argv[i];
    if (!strcmp(a, "--set") || !strcmp(a, "-s")) {
      if (++i >= argc) { fprintf(stderr, "moreau: --set needs KEY=VALUE\n"); return 2; }
      c->sets[c->o.nset++] = argv[i];
    } else if (!strncmp(a, "--set=", 6)) {
      c->sets[c->o.nset++] = a + 6;
    } else if (!strcmp(a, "--solver")) {
      if (++i >= argc) { fprintf(stderr, "moreau: --solver needs a name (see moreau list-solvers)\n"); return 2; }
      c->o.solver = argv[i];
    } else if (!strcmp(a, "--out") || !strcmp(a, "-o")) {
      if (++i >= argc) { fprintf(stderr, "moreau: --out needs a folder\n"); return 2; }
      c->o.outdir = argv[i];
    } else if (!strcmp(a, "--dump-fclib")) {
      if (++i >= argc) { fprintf(stderr, "moreau: --dump-fclib needs a folder\n"); return 2; }
      c->o.dump_fclib = argv[i];
    } else if (!strcmp(a, "--log")) {
      c->o.log = 1;
    } else if (!strcmp(a, "--quiet") || !strcmp(a, "-q")) {
      c->quiet = 1;
      c->o.progress = 0;
    } else if (a[0] == '-' && a[1]) {
      fprintf(stderr, "moreau: unknown option '%s'\n", a);
      return 2;
    } else if (!c->o.case_path) {
      c->o.case_path = a;
    } else {
      fprintf(stderr, "moreau: one case at a time ('%s' and '%s')\n", c->o.case_path, a);
      return 2;
    }
  }
  if (!c->o.case_path) {
    fprintf(stderr, "moreau: which case? (a folder holding case.cfg, or a file)\n");
    return 2;
  }
  return 0;
}

static int exit_code(int st);

/* Split a comma-separated list in place. Commas inside brackets, parentheses or quotes belong
   to the item (a --vary value may be a vector: velocity=[0.0,-1.0],[0.0,-10.0]). Returns the
   number of items, or -1 when there are more than max or the brackets do not match. */
static int split_list(char *s, char **items, int max)
{
  int n = 0, depth = 0, quote = 0;
  char *start = s, *p;
  for (p = s;; p++) {
    if (*p == '"') quote = !quote;
    else if (!quote && (*p == '[' || *p == '(')) depth++;
    else if (!quote && (*p == ']' || *p == ')')) {
      if (--depth < 0) return -1;
    } else if (*p == '\0' || (*p == ',' && !depth && !quote)) {
      int end = *p == '\0';
      if (end && (depth || quote)) return -1;
      *p = '\0';
      if (*start) {
        if (n == max) return -1;
        items[n++] = start;
      }
      if (end) break;
      start = p + 1;
    }
  }
  return n;
}

static int cmd_compare(int argc, char **argv, mo_ctx *ctx)
{
  mo_compare_options o;
  mo_compare_result res;
  char *solvers[16], *vals[MO_COMPARE_MAX_VARY][64], outbuf[4200];
  double dts[64];
  const char **sets = calloc((size_t)argc, sizeof *sets), **peers = calloc((size_t)argc, sizeof *peers);
  int i, k, st, rc = 2;
  memset(&o, 0, sizeof o);
  if (!sets || !peers) goto out;
  o.sets = sets;
  o.peers = peers;
  for (i = 2; i < argc; i++) {
    const char *a = argv[i];
    if (!strcmp(a, "--solvers") && i + 1 < argc) {
      o.nsolver = split_list(argv[++i], solvers, 16);
      o.solvers = (const char *const *)solvers;
      if (o.nsolver == 0) {
        fprintf(stderr, "moreau compare: --solvers names no back end, only commas (a,b,...: see moreau list-solvers)\n");
        goto out;
      }
      if (o.nsolver < 0) {
        fprintf(stderr, "moreau compare: --solvers a,b,...: at most 16 back ends, brackets matched\n");
        goto out;
      }
    } else if (!strcmp(a, "--dt") && i + 1 < argc) {
      char *items[64], *end;
      int n = split_list(argv[++i], items, 64);
      if (n <= 0) {
        fprintf(stderr, "moreau compare: --dt h1,h2,...: 1 to 64 time steps\n");
        goto out;
      }
      for (k = 0; k < n; k++) {
        dts[k] = strtod(items[k], &end);
        if (*end || !(dts[k] > 0)) {
          fprintf(stderr, "moreau compare: --dt: '%s' is not a positive time step\n", items[k]);
          goto out;
        }
      }
      o.ndt = n;
      o.dt = dts;
    } else if (!strcmp(a, "--vary") && i + 1 < argc) {
      char *eq = strchr(argv[++i], '=');
      if (!eq || o.nvary == MO_COMPARE_MAX_VARY) {
        fprintf(stderr, "moreau compare: --vary KEY=v1,v2,... (at most %d keys)\n", MO_COMPARE_MAX_VARY);
        goto out;
      }
      *eq = '\0';
      o.vary[o.nvary].key = argv[i];
      o.vary[o.nvary].nval = split_list(eq + 1, vals[o.nvary], 64);
      o.vary[o.nvary].val = (const char *const *)vals[o.nvary];
      if (o.vary[o.nvary].nval <= 0) {
        fprintf(stderr, "moreau compare: --vary %s=...: 1 to 64 values, brackets matched (a vector value "
                "keeps its commas inside [ ])\n", argv[i]);
        goto out;
      }
      o.nvary++;
    } else if ((!strcmp(a, "--set") || !strcmp(a, "-s")) && i + 1 < argc) {
      sets[o.nset++] = argv[++i];
    } else if ((!strcmp(a, "--out") || !strcmp(a, "-o")) && i + 1 < argc) {
      o.outdir = argv[++i];
    } else if (!strcmp(a, "--metric") && i + 1 < argc) {
      o.metric = argv[++i];
    } else if (!strcmp(a, "--peer") && i + 1 < argc) {
      peers[o.npeer++] = argv[++i];
    } else if (!strcmp(a, "--repeat") && i + 1 < argc) {
      char *end;
      long n = strtol(argv[++i], &end, 10);
      if (*end || n < 1 || n > 20) {
        fprintf(stderr, "moreau compare: --repeat N: 1 to 20 runs per cell ('%s')\n", argv[i]);
        goto out;
      }
      o.repeat = (int)n;
    } else if (!strcmp(a, "--reference") && i + 1 < argc) {
      char *end;
      o.reference_dt = strtod(argv[++i], &end);
      if (*end || !(o.reference_dt > 0)) {
        fprintf(stderr, "moreau compare: --reference DT: '%s' is not a positive time step\n", argv[i]);
        goto out;
      }
    } else if (!strcmp(a, "--penetration-tol") && i + 1 < argc) {
      o.penetration_tol = atof(argv[++i]);
    } else if (!strcmp(a, "--quiet") || !strcmp(a, "-q")) {
      ctx->verbosity = 0;
    } else if (a[0] == '-' && a[1]) {
      fprintf(stderr, "moreau compare: unknown or incomplete option '%s'\n", a);
      goto out;
    } else if (!o.case_path) {
      o.case_path = a;
    } else {
      fprintf(stderr, "moreau compare: one case at a time\n");
      goto out;
    }
  }
  if (!o.case_path) {
    fprintf(stderr, "moreau compare: which case?\n");
    goto out;
  }
  if (!o.outdir) {
    char tmp[4096], *base;
    size_t l;
    snprintf(tmp, sizeof tmp, "%s", o.case_path);
    l = strlen(tmp);
    while (l > 1 && tmp[l - 1] == '/') tmp[--l] = '\0';
    base = strrchr(tmp, '/');
    snprintf(outbuf, sizeof outbuf, "out/compare-%s", base ? base + 1 : tmp);
    o.outdir = outbuf;
  }
  if ((st = mo_compare(&o, &res, ctx))) {
    fprintf(stderr, "moreau compare: %s\n", ctx->errmsg);
    rc = exit_code(st);
    goto out;
  }
  if (ctx->verbosity >= 1) {
    printf("%s: %d runs (%d stable, %d chatter, %d unstable, %d failed)\n", o.case_path, res.nrun, res.nstable,
           res.nchatter, res.nunstable, res.nfailed);
    if (res.nmarked)
      printf("  %d grid cells not run: their back end ignores the varied key (marked in report.md)\n", res.nmarked);
    printf("  outputs: %s/compare.csv, %s/report.md, %s/plots/ (%d figures, %d rendered)\n", o.outdir, o.outdir, o.outdir,
           res.nfigures, res.rendered);
    if (res.npeer) printf("  with %d external rows from the --peer files (report.md, work-precision figure)\n", res.npeer);
  }
  rc = 0;
out:
  free(sets);
  free(peers);
  return rc;
}

/* moreau bench-local FILE... [options] */
static int bench_local(int argc, char **argv, mo_ctx *ctx)
{
  mo_bench_options o;
  const char **files = calloc((size_t)argc, sizeof *files);
  int i, n = 0, st;
  if (!files) return 2;
  mo_bench_options_default(&o);
  for (i = 2; i < argc; i++) {
    const char *a = argv[i];
    char *end;
    if (!strcmp(a, "--tol") || !strcmp(a, "--max-sweeps") || !strcmp(a, "--min-time")) {
      if (++i >= argc) { fprintf(stderr, "moreau: %s needs a value\n", a); free(files); return 2; }
      if (!strcmp(a, "--max-sweeps")) {
        long v = strtol(argv[i], &end, 10);
        if (*end || v < 1 || v > 1000000000L) { fprintf(stderr, "moreau: --max-sweeps takes a positive integer, not '%s'\n", argv[i]); free(files); return 2; }
        o.max_sweeps = (int)v;
      } else {
        double v = strtod(argv[i], &end);
        if (*end || !(v > 0) || !(v < 1e6)) { fprintf(stderr, "moreau: %s takes a positive number, not '%s'\n", a, argv[i]); free(files); return 2; }
        if (!strcmp(a, "--tol")) o.tol = v;
        else o.min_time = v;
      }
    } else if (!strcmp(a, "--vs-siconos")) {
      o.vs_siconos = 1;
    } else if (!strcmp(a, "--siconos-dense")) {
      o.vs_siconos = 1;
      o.siconos_dense = 1;
    } else if (a[0] == '-' && a[1]) {
      fprintf(stderr, "moreau: unknown option '%s'\n", a);
      free(files);
      return 2;
    } else
      files[n++] = a;
  }
  if (!n) {
    fprintf(stderr, "moreau: bench-local needs FCLIB files (.hdf5)\n");
    free(files);
    return 2;
  }
  if (o.vs_siconos && !mo_bench_have_siconos()) {
    fprintf(stderr, "moreau: --vs-siconos: this build has no Siconos numerics (install libsiconos-numerics-dev and configure again)\n");
    free(files);
    return 2;
  }
  if (!mo_fclib_available()) {
    fprintf(stderr, "moreau: this build reads no FCLIB files (install libfclib-dev libhdf5-dev and configure again)\n");
    free(files);
    return 2;
  }
  st = mo_bench_local(files, n, &o, stdout, ctx);
  free(files);
  if (st) {
    fprintf(stderr, "moreau: %s\n", ctx->errmsg);
    return exit_code(st);
  }
  return 0;
}

static int exit_code(int st)
{
  return st == MO_EINPUT || st == MO_EIO ? 2 : 1;
}


static void print_key(const char *path, const char *type, const char *range, const char *deflt,
                      const char *doc, void *data)
{
  (void)data;
  printf("%-36s %-28s %-24s %-14s %s\n", path, type, range, deflt, doc);
}

/* OpenBLAS's thread count, when OpenBLAS is the BLAS loaded (weak: absent otherwise). */
extern void openblas_set_num_threads(int n) __attribute__((weak));

int main(int argc, char **argv)
{
  mo_ctx ctx;
  cli c;
  int st, rc;
  const char *cmd;
  mo_ctx_init(&ctx);
  /* moreau computes on one thread: the comparisons time one core against one core, and the
     dense kernels it calls are small (levelset's least squares, CHOLMOD's supernodes), where
     OpenBLAS's threads spin in sched_yield more than they help. OPENBLAS_NUM_THREADS overrides. */
  if (openblas_set_num_threads && !getenv("OPENBLAS_NUM_THREADS")) openblas_set_num_threads(1);
  memset(&c, 0, sizeof c);
  if (argc < 2) {
    usage(stderr);
    return 2;
  }
  cmd = argv[1];
  if (!strcmp(cmd, "--help") || !strcmp(cmd, "-h") || !strcmp(cmd, "help")) {
    usage(stdout);
    return 0;
  }
  {
    int i;
    for (i = 2; i < argc; i++)
      if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) { /* moreau COMMAND --help */
        usage(stdout);
        return 0;
      }
  }
  if (!strcmp(cmd, "--version")) {
    printf("moreau %s\n", PACKAGE_VERSION);
    return 0;
  }
  if (!strcmp(cmd, "keys")) {
    mo_case_schema_visit(print_key, NULL);
    return 0;
  }
  if (!strcmp(cmd, "compare")) {
    if (mo_parallel_launched()) {
      fprintf(stderr, "moreau: compare runs its cells one after the other in one process: run a case over MPI "
                      "ranks with 'mpirun -np N moreau run CASE'\n");
      return 2;
    }
    catch_signals(&ctx);
    return cmd_compare(argc, argv, &ctx);
  }
  if (!strcmp(cmd, "bench-local")) return bench_local(argc, argv, &ctx);
  if (!strcmp(cmd, "list-solvers")) {
    return mo_cli_list_solvers(stdout);
  }
  if (!strcmp(cmd, "run") || !strcmp(cmd, "check")) {
    mo_run_result res;
    if ((rc = parse_run_args(argc, argv, 2, &c))) {
      free(c.sets);
      return rc;
    }
    if (c.quiet) ctx.verbosity = 0;
    if (!strcmp(cmd, "check")) {
      catch_signals(&ctx);
      st = mo_check(&c.o, &ctx);
      free(c.sets);
      if (st) {
        fprintf(stderr, "%s\n", ctx.errmsg);
        return exit_code(st);
      }
      if (!c.quiet) printf("%s: ok\n", c.o.case_path);
      return 0;
    }
    catch_signals(&ctx);
    /* under mpirun every rank runs the case; rank 0 writes and speaks (doc/parallel.md) */
    if (mo_parallel_launched() && (st = mo_parallel_start(&argc, &argv, &ctx))) {
      fprintf(stderr, "moreau: %s\n", ctx.errmsg);
      free(c.sets);
      return exit_code(st);
    }
    st = mo_run(&c.o, &res, &ctx);
    mo_parallel_finish(&ctx);
    free(c.sets);
    if (ctx.rank != 0) return st ? exit_code(st) : 0;
    if (st) {
      fprintf(stderr, "moreau: %s\n", ctx.errmsg);
      if (res.outdir[0] && res.steps > 0 && res.summary)
        fprintf(stderr, "moreau: outputs up to step %ld (t = %.6g) are in %s (summary.json says "
                        "\"incomplete\")\n", res.steps, res.t, res.outdir);
      else if (res.outdir[0] && res.steps > 0)
        fprintf(stderr, "moreau: the partial outputs in %s have no summary.json (it could not be "
                        "written): no reader takes them for complete\n", res.outdir);
      return exit_code(st);
    }
    if (!c.quiet) {
      int k;
      printf("%s: %ld steps to t = %.6g in %.3f s\n", c.o.case_path, res.steps, res.t, res.wall);
      if (res.energy0 > 0)
        printf("  energy: initial %.6g, final %.6g (ratio %.6f)\n", res.energy0, res.energy1,
               res.energy1 / res.energy0);
      for (k = 0; k < res.nmetric; k++)
        printf("  error of %s against the reference: L2 %.3e, Linf %.3e (relative)\n",
               res.metric_name[k], res.metric_l2[k], res.metric_linf[k]);
      printf("  outputs: %s/history.csv, %s/summary.json\n", res.outdir, res.outdir);
    }
    return 0;
  }
  fprintf(stderr, "moreau: unknown command '%s'\n\n", cmd);
  usage(stderr);
  return 2;
}
