/* main.c: the moreau command line (argument handling and messages only; no numerics).

   Every command is a row of `commands` below: its operands, its help and a table of options.
   getopt_long parses the table (`--opt value`, `--opt=value`, `-o value`, unique prefixes of
   long names, `--` before an operand that starts with '-'), and `moreau CMD --help`, the
   synopsis of `moreau --help` and the error messages are made from the same rows. An option
   added to a command is one row of its table and one case of its handler. */
#include "config.h"
#include <moreau/moreau.h>

#include <getopt.h>
#include <math.h>
#include <signal.h>
#include <stdarg.h>
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

static int exit_code(int st)
{
  return st == MO_EINPUT || st == MO_EIO ? 2 : 1;
}

/* --- commands and their options ------------------------------------------------------------ */

/* Keys of the options without a short letter (those with one use the letter). */
enum {
  OPT_SOLVER = 256, OPT_DUMP_FCLIB, OPT_LOG, OPT_SOLVERS, OPT_DT, OPT_VARY, OPT_METRIC, OPT_PEER,
  OPT_REPEAT, OPT_REFERENCE, OPT_PENETRATION_TOL, OPT_TOL, OPT_MAX_SWEEPS, OPT_MIN_TIME,
  OPT_VS_SICONOS, OPT_SICONOS_DENSE
};

/* One option: its long name (without "--"), its key (a short letter or OPT_*), its argument as
   the help shows it (NULL: a flag), whether it may be repeated, and what it does (lines
   separated by '\n', printed beside the name). */
typedef struct {
  const char *name;
  int key;
  const char *arg;
  int repeat;
  const char *help;
} cli_option;

typedef struct cli_command cli_command;
/* A command's handler for one option (o) or one operand (o NULL, arg the operand); returns 0 or
   the exit status of a refusal (its message printed). */
typedef int (*cli_handler)(const cli_command *cmd, void *data, const cli_option *o, const char *arg);

struct cli_command {
  const char *name;
  const char *operands;        /* the operands as the synopsis shows them */
  const char *summary;         /* one line (or two) under its synopsis in `moreau --help` */
  const char *about;           /* the paragraph of `moreau CMD --help` */
  const cli_option *opt;       /* ended by a row with a NULL name */
  int (*main)(const cli_command *cmd, int argc, char **argv, mo_ctx *ctx);
};

static const cli_option run_options[] = {
  {"solver", OPT_SOLVER, "S", 0,
   "contact back end, or a formulation BACKEND[:PRESET][[KEY=VALUE;...]]:\n"
   "levelset:bdz07, nscd:jean88, nscd[theta=0.5] (moreau list-solvers)"},
  {"set", 's', "KEY=VALUE", 1, "override a case key (case-file syntax; a bare word is a string)"},
  {"out", 'o', "DIR", 0, "output folder (default out/<case>)"},
  {"dump-fclib", OPT_DUMP_FCLIB, "DIR", 0,
   "the contact problem each step solved, as an FCLIB local problem\n"
   "DIR/step-NNNNNN.hdf5: the candidates of the step's index set, W, q, mu\n"
   "and the step's solution r, U = W r + q (the file's info says so)"},
  {"log", OPT_LOG, NULL, 0, "print the per-phase timing table and the work the scene did not need"},
  {"quiet", 'q', NULL, 0, "print nothing but errors"},
  {NULL, 0, NULL, 0, NULL}};

static const cli_option check_options[] = {
  {"solver", OPT_SOLVER, "S", 0, "contact back end or formulation, as for run"},
  {"set", 's', "KEY=VALUE", 1, "override a case key, as for run"},
  {"quiet", 'q', NULL, 0, "print nothing but errors"},
  {NULL, 0, NULL, 0, NULL}};

static const cli_option compare_options[] = {
  {"solvers", OPT_SOLVERS, "a,b,...", 0,
   "back ends or formulations, at most 16 (default: the case's);\n"
   "commas inside [ ] belong to a spec: nscd[theta=0.5]"},
  {"dt", OPT_DT, "h1,h2,...", 0, "time steps, 1 to 64 (default: the case's)"},
  {"vary", OPT_VARY, "KEY=v1,v2,...", 1,
   "a grid over a case key (several: a grid over all, the last fastest);\n"
   "a vector value keeps its commas inside [ ]"},
  {"set", 's', "KEY=VALUE", 1, "override a case key in every run"},
  {"out", 'o', "DIR", 0, "output folder (default out/compare-<case>)"},
  {"metric", OPT_METRIC, "NAME", 0, "the error of the work-precision figure (a compare.csv column)"},
  {"penetration-tol", OPT_PENETRATION_TOL, "F", 0,
   "unstable beyond F times the smallest element (default 0.01)"},
  {"peer", OPT_PEER, "FILE.csv", 1,
   "another program's rows (compare.csv's columns) join the\n"
   "work-precision figure and report.md"},
  {"repeat", OPT_REPEAT, "N", 0,
   "runs per cell, 1 to 20, timed by the median step time (default:\n"
   "until the median is stable, at most 5)"},
  {"reference", OPT_REFERENCE, "DT", 0,
   "one more run per back end at DT, the reference of the others\n"
   "(default: the finest run of the sweep)"},
  {"quiet", 'q', NULL, 0, "print nothing but errors"},
  {NULL, 0, NULL, 0, NULL}};

static const cli_option bench_options[] = {
  {"tol", OPT_TOL, "T", 0, "the accuracy whose sweeps and update cost are reported (default 1e-8)"},
  {"vs-siconos", OPT_VS_SICONOS, NULL, 0, "solve the same problems with Siconos' NSGS, print the ratios"},
  {"siconos-dense", OPT_SICONOS_DENSE, NULL, 0, "the same, Siconos given a dense W"},
  {"max-sweeps", OPT_MAX_SWEEPS, "N", 0, "iteration limit of every solve (default 20000)"},
  {"min-time", OPT_MIN_TIME, "S", 0, "repeat each timing for S seconds, keep the fastest (default 0.2)"},
  {NULL, 0, NULL, 0, NULL}};

static const cli_option no_options[] = {{NULL, 0, NULL, 0, NULL}};

static int cmd_run(const cli_command *cmd, int argc, char **argv, mo_ctx *ctx);
static int cmd_compare(const cli_command *cmd, int argc, char **argv, mo_ctx *ctx);
static int cmd_bench_local(const cli_command *cmd, int argc, char **argv, mo_ctx *ctx);
static int cmd_list_solvers(const cli_command *cmd, int argc, char **argv, mo_ctx *ctx);
static int cmd_keys(const cli_command *cmd, int argc, char **argv, mo_ctx *ctx);

static const cli_command commands[] = {
  {"run", "CASE", "run a case (a folder holding case.cfg, or a file)",
   "Run a case: a folder holding case.cfg, or a case file. Outputs in DIR (default out/<case>):\n"
   "history.csv, summary.json (written last: \"complete\", or \"incomplete\" and why), and as the\n"
   "case asks: contact.csv (the last step's candidates), contact_history.csv (output.contact_history),\n"
   "fields.pvd, contact_points.pvd, planes.pvd and the rigid series for ParaView (output.vtk),\n"
   "bodies.csv, plots/ (output.draw). The end of the run lists the files written.",
   run_options, cmd_run},
  {"check", "CASE", "validate a case and build its scene without running it",
   "Validate a case (every key, the scene, the contact set, the back end and its options) and\n"
   "build its scene without running it. Prints \"CASE: ok\", or the error with file, line and key.",
   check_options, cmd_run},
  {"compare", "CASE", "the same scene by several back ends and time steps (and parameter grids)",
   "Run the same scene by several back ends and time steps (and parameter grids): compare.csv,\n"
   "orders.csv, stability.csv, report.md, plots/ in DIR (default out/compare-<case>), every run\n"
   "in DIR/runs/<label>; each run classed stable, chatter, unstable or failed, with its reason.",
   compare_options, cmd_compare},
  {"bench-local", "FILE.hdf5...", "the nscd solver on FCLIB local problems (with Siconos' NSGS)",
   "Solve FCLIB local problems with the nscd back end: sweeps, residual, time to 1e-4 and 1e-8,\n"
   "cost per contact update (with Siconos' NSGS side by side).",
   bench_options, cmd_bench_local},
  {"list-solvers", "", "the registered contact back ends and their papers' presets",
   "One line per registered contact back end, then the presets (formulations) and what each sets.",
   no_options, cmd_list_solvers},
  {"keys", "", "every case-file key with its type, range and default",
   "Every case-file key with its type, range, default and meaning (doc/case-format.md).",
   no_options, cmd_keys},
  {NULL, NULL, NULL, NULL, NULL, NULL}};

static const cli_option help_option = {"help", 'h', NULL, 0, "this help"};

/* --- help ---------------------------------------------------------------------------------- */

/* Print `text` (lines separated by '\n'), every line after the first indented by `indent`. */
static void print_lines(FILE *f, const char *text, int indent)
{
  const char *p = text;
  while (*p) {
    const char *nl = strchr(p, '\n');
    int n = nl ? (int)(nl - p) : (int)strlen(p);
    if (p != text) fprintf(f, "\n%*s", indent, "");
    fprintf(f, "%.*s", n, p);
    p += n + (nl != NULL);
  }
  fputc('\n', f);
}

/* The synopsis: "run CASE [--solver S] [--set KEY=VALUE]... ...", wrapped at 94 columns. */
static void print_synopsis(FILE *f, const cli_command *cmd, int indent)
{
  const cli_option *o;
  int col = indent + fprintf(f, "%*s%s%s%s", indent, "", cmd->name, cmd->operands[0] ? " " : "", cmd->operands) - indent;
  for (o = cmd->opt; o->name; o++) {
    char item[128];
    int n = snprintf(item, sizeof item, " [--%s%s%s]%s", o->name, o->arg ? " " : "", o->arg ? o->arg : "",
                     o->repeat ? "..." : "");
    if (col + n > 94) {
      fprintf(f, "\n%*s", indent + 8, "");
      col = indent + 8;
      n--;
      fputs(item + 1, f);
    } else
      fputs(item, f);
    col += n;
  }
  fputc('\n', f);
}

/* One option's line: "  -s, --set KEY=VALUE ...   help". */
static void print_option(FILE *f, const cli_option *o)
{
  char left[80], help[1024];
  int n;
  if (o->key < 256) n = snprintf(left, sizeof left, "  -%c, --%s", o->key, o->name);
  else n = snprintf(left, sizeof left, "      --%s", o->name);
  if (o->arg) snprintf(left + n, sizeof left - (size_t)n, " %s", o->arg);
  if (strlen(left) > 30) fprintf(f, "%s\n%32s", left, "");
  else fprintf(f, "%-32s", left);
  snprintf(help, sizeof help, "%s%s", o->help, o->repeat ? " (repeatable)" : "");
  print_lines(f, help, 32);
}

static void command_help(FILE *f, const cli_command *cmd)
{
  const cli_option *o;
  fprintf(f, "usage: moreau %s%s%s%s\n\n", cmd->name, cmd->operands[0] ? " " : "", cmd->operands,
          cmd->opt->name ? " [OPTION]..." : "");
  print_lines(f, cmd->about, 0);
  fprintf(f, "\noptions:\n");
  for (o = cmd->opt; o->name; o++) print_option(f, o);
  print_option(f, &help_option);
  fprintf(f, "\nExit status: 0 success, 1 the run failed or an output could not be written, 2 bad\n"
             "command line or case file. See moreau(1) and doc/case-format.md.\n");
}

static void usage(FILE *f)
{
  const cli_command *c;
  fprintf(f, "usage: moreau COMMAND [ARGS]\n\n");
  for (c = commands; c->name; c++) {
    print_synopsis(f, c, 2);
    fprintf(f, "            %s\n", c->summary);
  }
  fprintf(f, "  help [COMMAND], --help, --version\n"
             "\n"
             "moreau COMMAND --help: the command's options, each explained. Options take their value as\n"
             "--opt VALUE or --opt=VALUE. S is a back end, or a formulation BACKEND[:PRESET][[KEY=VALUE;...]]:\n"
             "levelset:bdz07, nscd:jean88, nscd[theta=0.5] (moreau list-solvers).\n"
             "\n"
             "Every command takes --plugin FILE.so or --plugin NAME (repeatable): a contact back end\n"
             "built outside moreau (doc/backends.md), then named like the others (--solver NAME);\n"
             "NAME is NAME.so in the plug-in folders, which are also loaded whole: MOREAU_PLUGIN_PATH\n"
             "(DIR:DIR...), else the installed folder.\n"
             "\n"
             "Exit status: 0 success, 1 the run failed (the outputs say how far it got; also an\n"
             "output that could not be written, a full disk),\n"
             "2 bad command line or case file. See moreau(1) and doc/case-format.md.\n");
}

/* --- parsing --------------------------------------------------------------------------------- */

static int cli_refuse(const cli_command *cmd, const char *fmt, ...)
{
  va_list ap;
  fprintf(stderr, "moreau %s: ", cmd->name);
  va_start(ap, fmt);
  vfprintf(stderr, fmt, ap);
  va_end(ap);
  fputc('\n', stderr);
  return 2;
}

static const cli_option *find_option(const cli_command *cmd, int key)
{
  const cli_option *o;
  for (o = cmd->opt; o->name; o++)
    if (o->key == key) return o;
  return NULL;
}

/* An option getopt_long did not take: unknown, or the prefix of several (--s: --solvers, --set). */
static int unknown_option(const cli_command *cmd, const char *word)
{
  char names[512] = "";
  const cli_option *o;
  size_t n = strcspn(word, "="), k = 0;
  int matches = 0;
  if (!strncmp(word, "--", 2) && n > 2)
    for (o = cmd->opt; o->name; o++)
      if (!strncmp(o->name, word + 2, n - 2) && k < sizeof names - 64) {
        k += (size_t)snprintf(names + k, sizeof names - k, "%s--%s", matches ? ", " : "", o->name);
        matches++;
      }
  if (matches > 1) return cli_refuse(cmd, "'%.*s' is ambiguous: %s", (int)n, word, names);
  return cli_refuse(cmd, "unknown option '%s' (moreau %s --help lists the options)", word, cmd->name);
}

#define CLI_MAX_OPTIONS 40
#define CLI_HELP_SHOWN -1

/* Parse argv (argv[1] the command) with getopt_long over the command's table: fn for every
   option and operand in order. Returns 0, CLI_HELP_SHOWN after --help, or 2 after a refusal
   (its message printed). */
static int cli_parse(const cli_command *cmd, int argc, char **argv, cli_handler fn, void *data)
{
  struct option lo[CLI_MAX_OPTIONS + 2];
  char shorts[2 * CLI_MAX_OPTIONS + 4];
  int n = 0, ns = 0, c, rc, i;
  const cli_option *o;
  shorts[ns++] = ':'; /* a missing argument is ':', told apart from an unknown option */
  for (o = cmd->opt; o->name && n < CLI_MAX_OPTIONS; o++, n++) {
    lo[n].name = o->name;
    lo[n].has_arg = o->arg ? required_argument : no_argument;
    lo[n].flag = NULL;
    lo[n].val = o->key;
    if (o->key < 256) {
      shorts[ns++] = (char)o->key;
      if (o->arg) shorts[ns++] = ':';
    }
  }
  lo[n] = (struct option){"help", no_argument, NULL, 'h'};
  lo[n + 1] = (struct option){NULL, 0, NULL, 0};
  shorts[ns++] = 'h';
  shorts[ns] = '\0';
  opterr = 0;
  optind = 0; /* glibc: start afresh */
  /* argv[1], the command, stands for the program's name */
  while ((c = getopt_long(argc - 1, argv + 1, shorts, lo, NULL)) != -1) {
    /* a long option getopt refuses is the word before optind (argv + 1 counts from the command) */
    const char *bad = optind >= 1 && optind < argc ? argv[optind] : "";
    if (c == 'h') {
      command_help(stdout, cmd);
      return CLI_HELP_SHOWN;
    }
    if (c == ':') {
      o = find_option(cmd, optopt);
      if (!o) return cli_refuse(cmd, "'%s' needs a value (moreau %s --help)", bad, cmd->name);
      {
        int len = (int)strcspn(o->help, "\n");
        while (len > 0 && strchr(":;, ", o->help[len - 1])) len--;
        return cli_refuse(cmd, "--%s needs %s: %.*s", o->name, o->arg, len, o->help);
      }
    }
    if (c == '?') {
      o = optopt == 'h' ? &help_option : optopt ? find_option(cmd, optopt) : NULL;
      if (o && !strncmp(bad, "--", 2)) return cli_refuse(cmd, "--%s takes no value ('%s')", o->name, bad);
      if (optopt > 0 && optopt < 256)
        return cli_refuse(cmd, "unknown option '-%c' (moreau %s --help lists the options)", optopt, cmd->name);
      return unknown_option(cmd, bad);
    }
    if ((rc = fn(cmd, data, find_option(cmd, c), optarg))) return rc;
  }
  for (i = optind + 1; i < argc; i++)
    if ((rc = fn(cmd, data, NULL, argv[i]))) return rc;
  return 0;
}

/* --- run, check -------------------------------------------------------------------------------- */

typedef struct {
  mo_run_options o;
  const char **sets;
  int quiet;
} run_args;

static int run_option(const cli_command *cmd, void *data, const cli_option *o, const char *arg)
{
  run_args *c = data;
  if (!o) {
    if (c->o.case_path) return cli_refuse(cmd, "one case at a time ('%s' and '%s')", c->o.case_path, arg);
    c->o.case_path = arg;
    return 0;
  }
  switch (o->key) {
  case 's': c->sets[c->o.nset++] = arg; break;
  case OPT_SOLVER: c->o.solver = arg; break;
  case 'o': c->o.outdir = arg; break;
  case OPT_DUMP_FCLIB: c->o.dump_fclib = arg; break;
  case OPT_LOG: c->o.log = 1; break;
  case 'q':
    c->quiet = 1;
    c->o.progress = 0;
    break;
  default: return cli_refuse(cmd, "--%s: not handled", o->name);
  }
  return 0;
}

/* The files a run wrote, named at its end (res->outputs, moreau/run.h). */
static void print_outputs(const mo_run_result *res)
{
  static const struct { unsigned bit; const char *file, *what; } out[] = {
    {MO_OUT_HISTORY, "history.csv", ""},
    {MO_OUT_SUMMARY, "summary.json", ""},
    {MO_OUT_CONTACT, "contact.csv", " (the last step's candidates)"},
    {MO_OUT_CONTACT_HISTORY, "contact_history.csv", " (the candidates of every output step)"},
    {MO_OUT_BODIES, "bodies.csv", ""},
    {MO_OUT_FIELDS, "fields.pvd", ""},
    {MO_OUT_CONTACT_POINTS, "contact_points.pvd", ""},
    {MO_OUT_PLANES, "planes.pvd", ""},
    {MO_OUT_RIGID, "particles.py", " (the rigid series: particles.pvd, polygons.pvd, contacts.pvd)"},
    {MO_OUT_DRAW, "plots/", " (drawings)"}};
  size_t k;
  int n = 0;
  printf("  outputs:");
  for (k = 0; k < sizeof out / sizeof out[0]; k++)
    if (res->outputs & out[k].bit) printf("%s %s/%s%s", n++ ? "," : "", res->outdir, out[k].file, out[k].what);
  printf("\n");
  if (res->outputs & MO_OUT_RIGID)
    printf("  ParaView: %d frames (pvpython %s/particles.py)\n", res->vtk_frames, res->outdir);
  else if (res->outputs & (MO_OUT_FIELDS | MO_OUT_CONTACT_POINTS | MO_OUT_PLANES))
    printf("  ParaView: %d frames (paraview %s/%s)\n", res->vtk_frames, res->outdir,
           res->outputs & MO_OUT_FIELDS ? "fields.pvd" : res->outputs & MO_OUT_CONTACT_POINTS ? "contact_points.pvd"
                                                                                            : "planes.pvd");
}

static int cmd_run(const cli_command *cmd, int argc, char **argv, mo_ctx *ctx)
{
  run_args c;
  mo_run_result res;
  int st, rc;
  memset(&c, 0, sizeof c);
  if (!(c.sets = calloc((size_t)argc, sizeof *c.sets))) return 2;
  c.o.sets = c.sets;
  c.o.progress = 1;
  c.o.map_large = 1;
  rc = cli_parse(cmd, argc, argv, run_option, &c);
  if (!rc && !c.o.case_path) rc = cli_refuse(cmd, "which case? (a folder holding case.cfg, or a file)");
  if (rc) {
    free(c.sets);
    return rc == CLI_HELP_SHOWN ? 0 : rc;
  }
  if (c.quiet) ctx->verbosity = 0;
  catch_signals(ctx);
  if (!strcmp(cmd->name, "check")) {
    st = mo_check(&c.o, ctx);
    free(c.sets);
    if (st) {
      fprintf(stderr, "%s\n", ctx->errmsg);
      return exit_code(st);
    }
    if (!c.quiet) printf("%s: ok\n", c.o.case_path);
    return 0;
  }
  /* under mpirun every rank runs the case; rank 0 writes and speaks (doc/parallel.md) */
  if (mo_parallel_launched() && (st = mo_parallel_start(&argc, &argv, ctx))) {
    fprintf(stderr, "moreau: %s\n", ctx->errmsg);
    free(c.sets);
    return exit_code(st);
  }
  st = mo_run(&c.o, &res, ctx);
  mo_parallel_finish(ctx);
  free(c.sets);
  if (ctx->rank != 0) {
    /* rank 0 speaks for the run, but mpirun may end it before it has printed when another rank
       exits first with an error: that rank prints its message too */
    if (st) fprintf(stderr, "moreau (rank %d): %s\n", ctx->rank, ctx->errmsg);
    return st ? exit_code(st) : 0;
  }
  if (st) {
    fprintf(stderr, "moreau: %s\n", ctx->errmsg);
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
    print_outputs(&res);
  }
  return 0;
}

/* --- compare ------------------------------------------------------------------------------------ */

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

typedef struct {
  mo_compare_options o;
  char *solvers[16], *vals[MO_COMPARE_MAX_VARY][64];
  double dts[64];
  const char **sets, **peers;
  int quiet;
} compare_args;

/* A number from the whole of `s` (strtod), or NAN. */
static double parse_number(const char *s)
{
  char *end;
  double v = strtod(s, &end);
  return *s && !*end ? v : NAN;
}

static int compare_option(const cli_command *cmd, void *data, const cli_option *o, const char *arg)
{
  compare_args *c = data;
  char *a = (char *)arg; /* an argv word: split_list cuts it in place */
  int k, n;
  if (!o) {
    if (c->o.case_path) return cli_refuse(cmd, "one case at a time ('%s' and '%s')", c->o.case_path, arg);
    c->o.case_path = arg;
    return 0;
  }
  switch (o->key) {
  case OPT_SOLVERS:
    c->o.nsolver = split_list(a, c->solvers, 16);
    c->o.solvers = (const char *const *)c->solvers;
    if (c->o.nsolver == 0)
      return cli_refuse(cmd, "--solvers names no back end, only commas (a,b,...: see moreau list-solvers)");
    if (c->o.nsolver < 0) return cli_refuse(cmd, "--solvers a,b,...: at most 16 back ends, brackets matched");
    break;
  case OPT_DT: {
    char *items[64];
    n = split_list(a, items, 64);
    if (n <= 0) return cli_refuse(cmd, "--dt h1,h2,...: 1 to 64 time steps");
    for (k = 0; k < n; k++) {
      c->dts[k] = parse_number(items[k]);
      if (!(c->dts[k] > 0)) return cli_refuse(cmd, "--dt: '%s' is not a positive time step", items[k]);
    }
    c->o.ndt = n;
    c->o.dt = c->dts;
    break;
  }
  case OPT_VARY: {
    char *eq = strchr(a, '=');
    mo_compare_vary *V = &c->o.vary[c->o.nvary];
    if (!eq || c->o.nvary == MO_COMPARE_MAX_VARY)
      return cli_refuse(cmd, "--vary KEY=v1,v2,... (at most %d keys)", MO_COMPARE_MAX_VARY);
    *eq = '\0';
    V->key = a;
    V->nval = split_list(eq + 1, c->vals[c->o.nvary], 64);
    V->val = (const char *const *)c->vals[c->o.nvary];
    if (V->nval <= 0)
      return cli_refuse(cmd, "--vary %s=...: 1 to 64 values, brackets matched (a vector value keeps its commas "
                        "inside [ ])", a);
    c->o.nvary++;
    break;
  }
  case 's': c->sets[c->o.nset++] = arg; break;
  case 'o': c->o.outdir = arg; break;
  case OPT_METRIC: c->o.metric = arg; break;
  case OPT_PEER: c->peers[c->o.npeer++] = arg; break;
  case OPT_REPEAT: {
    double v = parse_number(arg);
    if (!(v >= 1 && v <= 20 && v == (int)v)) return cli_refuse(cmd, "--repeat N: 1 to 20 runs per cell ('%s')", arg);
    c->o.repeat = (int)v;
    break;
  }
  case OPT_REFERENCE:
    c->o.reference_dt = parse_number(arg);
    if (!(c->o.reference_dt > 0)) return cli_refuse(cmd, "--reference DT: '%s' is not a positive time step", arg);
    break;
  case OPT_PENETRATION_TOL:
    c->o.penetration_tol = parse_number(arg);
    if (!(c->o.penetration_tol > 0) || !(c->o.penetration_tol < 1e300))
      return cli_refuse(cmd, "--penetration-tol F: '%s' is not a positive fraction of the smallest element", arg);
    break;
  case 'q': c->quiet = 1; break;
  default: return cli_refuse(cmd, "--%s: not handled", o->name);
  }
  return 0;
}

static int cmd_compare(const cli_command *cmd, int argc, char **argv, mo_ctx *ctx)
{
  compare_args *c = calloc(1, sizeof *c);
  mo_compare_result res;
  char outbuf[4200];
  int st, rc = 2;
  if (!c) return 2;
  c->sets = calloc((size_t)argc, sizeof *c->sets);
  c->peers = calloc((size_t)argc, sizeof *c->peers);
  if (!c->sets || !c->peers) goto out;
  c->o.sets = c->sets;
  c->o.peers = c->peers;
  if ((rc = cli_parse(cmd, argc, argv, compare_option, c))) {
    if (rc == CLI_HELP_SHOWN) rc = 0;
    goto out;
  }
  rc = 2;
  if (!c->o.case_path) {
    cli_refuse(cmd, "which case? (a folder holding case.cfg, or a file)");
    goto out;
  }
  if (c->quiet) ctx->verbosity = 0;
  if (mo_parallel_launched()) {
    fprintf(stderr, "moreau: compare runs its cells one after the other in one process: run a case over MPI "
                    "ranks with 'mpirun -np N moreau run CASE'\n");
    goto out;
  }
  if (!c->o.outdir) {
    char tmp[4096], *base;
    size_t l;
    snprintf(tmp, sizeof tmp, "%s", c->o.case_path);
    l = strlen(tmp);
    while (l > 1 && tmp[l - 1] == '/') tmp[--l] = '\0';
    base = strrchr(tmp, '/');
    snprintf(outbuf, sizeof outbuf, "out/compare-%s", base ? base + 1 : tmp);
    c->o.outdir = outbuf;
  }
  catch_signals(ctx);
  if ((st = mo_compare(&c->o, &res, ctx))) {
    fprintf(stderr, "moreau compare: %s\n", ctx->errmsg);
    rc = exit_code(st);
    goto out;
  }
  if (ctx->verbosity >= 1) {
    const char *d = c->o.outdir;
    printf("%s: %d runs (%d stable, %d chatter, %d unstable, %d failed)\n", c->o.case_path, res.nrun, res.nstable,
           res.nchatter, res.nunstable, res.nfailed);
    if (res.nmarked)
      printf("  %d grid cells not run: their back end ignores the varied key (marked in report.md)\n", res.nmarked);
    printf("  outputs: %s/compare.csv, %s/report.md, %s/plots/ (%d figures, %d rendered)\n", d, d, d, res.nfigures,
           res.rendered);
    if (res.npeer) printf("  with %d external rows from the --peer files (report.md, work-precision figure)\n", res.npeer);
  }
  rc = 0;
out:
  free(c->sets);
  free(c->peers);
  free(c);
  return rc;
}

/* --- bench-local, list-solvers, keys ----------------------------------------------------------- */

typedef struct {
  mo_bench_options o;
  const char **files;
  int n;
} bench_args;

static int bench_option(const cli_command *cmd, void *data, const cli_option *o, const char *arg)
{
  bench_args *b = data;
  double v;
  if (!o) {
    b->files[b->n++] = arg;
    return 0;
  }
  switch (o->key) {
  case OPT_MAX_SWEEPS:
    v = parse_number(arg);
    if (!(v >= 1 && v <= 1e9 && v == (long)v))
      return cli_refuse(cmd, "--max-sweeps takes a positive integer, not '%s'", arg);
    b->o.max_sweeps = (int)v;
    break;
  case OPT_TOL:
  case OPT_MIN_TIME:
    v = parse_number(arg);
    if (!(v > 0) || !(v < 1e6)) return cli_refuse(cmd, "--%s takes a positive number, not '%s'", o->name, arg);
    if (o->key == OPT_TOL) b->o.tol = v;
    else b->o.min_time = v;
    break;
  case OPT_SICONOS_DENSE: /* a comparison with Siconos, given a dense W */
    b->o.siconos_dense = 1;
    b->o.vs_siconos = 1;
    break;
  case OPT_VS_SICONOS: b->o.vs_siconos = 1; break;
  default: return cli_refuse(cmd, "--%s: not handled", o->name);
  }
  return 0;
}

static int cmd_bench_local(const cli_command *cmd, int argc, char **argv, mo_ctx *ctx)
{
  bench_args b;
  int st, rc;
  memset(&b, 0, sizeof b);
  if (!(b.files = calloc((size_t)argc, sizeof *b.files))) return 2;
  mo_bench_options_default(&b.o);
  rc = cli_parse(cmd, argc, argv, bench_option, &b);
  if (!rc && !b.n) rc = cli_refuse(cmd, "which FCLIB files? (FILE.hdf5...)");
  if (!rc && b.o.vs_siconos && !mo_bench_have_siconos())
    rc = cli_refuse(cmd, "--vs-siconos: this build has no Siconos numerics (install libsiconos-numerics-dev and "
                    "configure again)");
  if (!rc && !mo_fclib_available())
    rc = cli_refuse(cmd, "this build reads no FCLIB files (install libfclib-dev libhdf5-dev and configure again)");
  if (rc) {
    free(b.files);
    return rc == CLI_HELP_SHOWN ? 0 : rc;
  }
  st = mo_bench_local(b.files, b.n, &b.o, stdout, ctx);
  free(b.files);
  if (st) {
    fprintf(stderr, "moreau: %s\n", ctx->errmsg);
    return exit_code(st);
  }
  return 0;
}

/* A command without options or operands. */
static int no_operand(const cli_command *cmd, void *data, const cli_option *o, const char *arg)
{
  (void)data;
  (void)o;
  return cli_refuse(cmd, "takes no operand ('%s')", arg);
}

static int cmd_list_solvers(const cli_command *cmd, int argc, char **argv, mo_ctx *ctx)
{
  int rc = cli_parse(cmd, argc, argv, no_operand, NULL);
  if (rc) return rc == CLI_HELP_SHOWN ? 0 : rc;
  rc = mo_cli_list_solvers(stdout);
  if (mo_plugin_count(ctx) || mo_plugin_failures(ctx)[0]) {
    printf("\nplug-ins (--plugin, MOREAU_PLUGIN_PATH):\n");
    mo_plugin_print(stdout, ctx);
  }
  return rc;
}
/* --plugin FILE|NAME, anywhere after the command and repeatable: the back ends of plug-ins
   (moreau/backend.h), loaded before those of the plug-in folders and before the command reads
   its options, and taken out of argv so that no command's parser sees them. */
static int load_plugins(int *argc, char **argv, mo_ctx *ctx)
{
  int i, j;
  for (i = j = 2; i < *argc; i++) {
    const char *spec;
    if (!strcmp(argv[i], "--plugin")) {
      if (i + 1 >= *argc) {
        fprintf(stderr, "moreau: --plugin needs a plug-in file (.so) or name\n");
        return 2;
      }
      spec = argv[++i];
    } else if (!strncmp(argv[i], "--plugin=", 9)) {
      spec = argv[i] + 9;
    } else {
      argv[j++] = argv[i];
      continue;
    }
    if (mo_plugin_load(ctx, spec)) {
      fprintf(stderr, "moreau: %s\n", ctx->errmsg);
      return 2;
    }
  }
  *argc = j;
  argv[j] = NULL;
  if (mo_plugin_scan(ctx, NULL, NULL)) {
    fprintf(stderr, "moreau: %s\n", ctx->errmsg);
    return 1;
  }
  return 0;
}


static void print_key(const char *path, const char *type, const char *range, const char *deflt,
                      const char *doc, void *data)
{
  (void)data;
  printf("%-36s %-28s %-24s %-14s %s\n", path, type, range, deflt, doc);
}

static int cmd_keys(const cli_command *cmd, int argc, char **argv, mo_ctx *ctx)
{
  int rc = cli_parse(cmd, argc, argv, no_operand, NULL);
  if (rc) return rc == CLI_HELP_SHOWN ? 0 : rc;
  mo_case_schema_visit_ctx(print_key, NULL, ctx); /* with the plug-ins' options */
  return 0;
}

/* --- main ----------------------------------------------------------------------------------- */

static const cli_command *find_command(const char *name)
{
  const cli_command *c;
  for (c = commands; c->name; c++)
    if (!strcmp(c->name, name)) return c;
  return NULL;
}

/* OpenBLAS's thread count, when OpenBLAS is the BLAS loaded (weak: absent otherwise). */
extern void openblas_set_num_threads(int n) __attribute__((weak));

int main(int argc, char **argv)
{
  mo_ctx ctx __attribute__((cleanup(mo_ctx_release))); /* unloads the plug-ins at every return */
  const cli_command *cmd;
  int rc;
  mo_ctx_init(&ctx);
  /* moreau computes on one thread: the comparisons time one core against one core, and the
     dense kernels it calls are small (levelset's least squares, CHOLMOD's supernodes), where
     OpenBLAS's threads spin in sched_yield more than they help. OPENBLAS_NUM_THREADS overrides. */
  if (openblas_set_num_threads && !getenv("OPENBLAS_NUM_THREADS")) openblas_set_num_threads(1);
  if (argc < 2) {
    usage(stderr);
    return 2;
  }
  if (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h") || !strcmp(argv[1], "help")) {
    /* moreau help COMMAND: that command's help */
    if (argc > 2 && strcmp(argv[1], "help") == 0) {
      if (!(cmd = find_command(argv[2]))) {
        fprintf(stderr, "moreau help: no command '%s'\n\n", argv[2]);
        usage(stderr);
        return 2;
      }
      command_help(stdout, cmd);
      return 0;
    }
    usage(stdout);
    return 0;
  }
  if (!strcmp(argv[1], "--version")) {
    printf("moreau %s\n", PACKAGE_VERSION);
    return 0;
  }
  if (!(cmd = find_command(argv[1]))) {
    fprintf(stderr, "moreau: unknown command '%s'\n\n", argv[1]);
    usage(stderr);
    return 2;
  }
  if ((rc = load_plugins(&argc, argv, &ctx))) return rc;
  return cmd->main(cmd, argc, argv, &ctx);
}
