/* compare.c: `moreau compare`: the same scene by several back ends, time steps and parameter
   grids; compare.csv, stability.csv, report.md and gnuplot figures (doc/theory.md §10). */
#include "config.h"
#include <moreau/compare.h>
#include <moreau/output.h>
#include <moreau/run.h>
#include <moreau/backend.h>

#include "metrics.h"

#include <errno.h>
#include <jansson.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define MAX_COLS 256

typedef struct {
  char label[256];
  char solver[64];
  double dt;
  char vary[MO_COMPARE_MAX_VARY][128];  /* value of each varied key */
  int status;                /* MO_OK or the error code */
  char reason[512];
  char cls[32];              /* stable, chatter, unstable, failed (doc/theory.md (T97)) */
  char why[512];
  double wall;
  double tmin, tmed, tmax;   /* step times over the repeats (s): setup and output left out (T99) */
  int nrep;                  /* runs of this cell */
  int dup_of;                /* a cell not run: the row whose run it shares (the back end ignores a
                                varied key), -1 otherwise */
  unsigned ignored;          /* bit k: the back end ignores varied key k */
  long steps;
  double val[MAX_COLS];      /* flattened metrics, NaN when absent */
  double dt_crit;            /* summary.json time.dt_crit (doc/theory.md (T102)), NaN when absent */
  double pen_landing;        /* penetration a landing may leave: (1 - theta) h max |U_n| at
                                velocity level (doc/theory.md §5), 0 otherwise */
  char outdir[1024];
  int ok;
} run_row;

typedef struct {
  int n;
  char name[MAX_COLS][96];
} colset;

static int col_index(colset *C, const char *name)
{
  int k;
  for (k = 0; k < C->n; k++)
    if (!strcmp(C->name[k], name)) return k;
  if (C->n == MAX_COLS) return -1;
  snprintf(C->name[C->n], sizeof C->name[0], "%s", name);
  return C->n++;
}

/* Flatten the numbers of a JSON object into prefix.key columns. */
static void flatten(json_t *j, const char *prefix, colset *C, run_row *r)
{
  const char *key;
  json_t *v;
  json_object_foreach(j, key, v) {
    char name[96];
    snprintf(name, sizeof name, "%s%s%s", prefix, prefix[0] ? "." : "", key);
    if (json_is_object(v)) flatten(v, name, C, r);
    else if (json_is_number(v)) {
      int k = col_index(C, name);
      if (k >= 0) r->val[k] = json_number_value(v);
    } else if (json_is_array(v) && json_array_size(v) > 0 && json_is_number(json_array_get(v, json_array_size(v) - 1))) {
      /* a list (energy after each impact): its last value */
      int k;
      snprintf(name, sizeof name, "%s%s%s_last", prefix, prefix[0] ? "." : "", key);
      k = col_index(C, name);
      if (k >= 0) r->val[k] = json_number_value(json_array_get(v, json_array_size(v) - 1));
    }
  }
}

/* The case's headline metrics (summary.json "report", from output.report), read from the
   first summary that has them. */
static void read_report(json_t *root, colset *H)
{
  json_t *a = json_object_get(root, "report");
  size_t k;
  if (H->n || !json_is_array(a)) return;
  for (k = 0; k < json_array_size(a) && H->n < MAX_COLS; k++)
    if (json_is_string(json_array_get(a, k)))
      snprintf(H->name[H->n++], sizeof H->name[0], "%s", json_string_value(json_array_get(a, k)));
}

static void read_summary(run_row *r, colset *C, colset *H)
{
  char path[1200];
  json_t *root, *m;
  json_error_t err;
  int k;
  for (k = 0; k < MAX_COLS; k++) r->val[k] = NAN;
  r->pen_landing = 0;
  r->dt_crit = NAN;
  snprintf(path, sizeof path, "%s/summary.json", r->outdir);
  root = json_load_file(path, 0, &err);
  if (!root) return;
  if ((m = json_object_get(root, "time")) && json_is_number(json_object_get(m, "dt_crit")))
    r->dt_crit = json_number_value(json_object_get(m, "dt_crit"));
  /* the step the run took, when the grid sets it (--vary time.dt=...) rather than --dt */
  if (isnan(r->dt) && (m = json_object_get(root, "time")) && json_is_number(json_object_get(m, "dt")))
    r->dt = json_number_value(json_object_get(m, "dt"));
  if ((m = json_object_get(root, "metrics"))) flatten(m, "", C, r);
  if ((m = json_object_get(root, "energy"))) flatten(m, "energy", C, r);
  if ((m = json_object_get(root, "contact"))) flatten(m, "contact", C, r);
  /* wall time per phase (the call counts stay in summary.json) */
  if ((m = json_object_get(root, "timings"))) {
    const char *key;
    json_t *v;
    json_object_foreach(m, key, v) {
      char name[96];
      int kk;
      if (!json_is_number(v)) continue;
      snprintf(name, sizeof name, "time.%s_s", key);
      if ((kk = col_index(C, name)) >= 0) r->val[kk] = json_number_value(v);
    }
  }
  if ((m = json_object_get(root, "newton"))) flatten(m, "newton", C, r);
  read_report(root, H);
  if ((m = json_object_get(root, "scene")) && json_object_get(m, "hmin")) {
    int kk = col_index(C, "scene.hmin");
    if (kk >= 0) r->val[kk] = json_number_value(json_object_get(m, "hmin"));
  }
  {
    /* velocity-level Signorini (the default) corrects no position unless contact.
       position_correction does: a theta-scheme landing step ends at
       g_k + h (1 - theta) U-_n with U+_n = 0, a penetration of order h that refinement removes,
       not an instability */
    json_t *tm = json_object_get(root, "time");
    json_t *sig = json_object_get(json_object_get(json_object_get(root, "settings"), "contact"), "signorini");
    json_t *vs = json_object_get(json_object_get(json_object_get(root, "metrics"), "contact"), "velocity_scale");
    const char *scheme = json_string_value(json_object_get(tm, "scheme"));
    if (scheme && !strcmp(scheme, "theta") && (!sig || (json_is_string(sig) && !strcmp(json_string_value(sig), "velocity"))) &&
        json_is_number(vs))
      r->pen_landing = (1 - json_number_value(json_object_get(tm, "theta"))) *
                       json_number_value(json_object_get(tm, "dt")) * json_number_value(vs);
  }
  json_decref(root);
}

static double colval(const run_row *r, const colset *C, const char *name)
{
  int k;
  for (k = 0; k < C->n; k++)
    if (!strcmp(C->name[k], name)) return r->val[k];
  return NAN;
}

static void classify(run_row *r, const colset *C, double pen_rel)
{
  if (r->status != MO_OK) {
    /* the contact driver's message says on what a solve stopped (mo_contact_reason_name) */
    char why[64];
    double growth = colval(r, C, "energy.max_growth");
    if (strstr(r->reason, "(time.max_cuts)")) snprintf(why, sizeof why, "step cut limit");
    else if (strstr(r->reason, "cycling")) snprintf(why, sizeof why, "status cycling");
    else if (strstr(r->reason, "stopped on NaN") || r->status == MO_ENAN) snprintf(why, sizeof why, "NaN");
    else if (strstr(r->reason, "stopped on breakdown")) snprintf(why, sizeof why, "breakdown");
    else if (r->status == MO_ENOCONV) snprintf(why, sizeof why, "non-convergence");
    else if (r->status == MO_ESINGULAR) snprintf(why, sizeof why, "singular matrix");
    else if (r->status == MO_EINPUT) snprintf(why, sizeof why, "input rejected");
    else snprintf(why, sizeof why, "%s", mo_strerror(r->status));
    if (growth > 0.01) {
      /* a run that blew up before it stopped is unstable: the failure is the consequence */
      snprintf(r->cls, sizeof r->cls, "unstable");
      snprintf(r->why, sizeof r->why, "energy growth %.2g %%, then the run stopped: %s", 100 * growth, why);
    } else {
      snprintf(r->cls, sizeof r->cls, "failed");
      snprintf(r->why, sizeof r->why, "%s", why);
    }
    return;
  }
  {
    double growth = colval(r, C, "energy.max_growth"), pen = colval(r, C, "contact.max_penetration");
    double hmin = colval(r, C, "scene.hmin");
    mo_chatter_input ci;
    char cwhy[300] = "";
    int chatter = 0;
    /* the contact measures of metrics.contact (T50), when the scene has contact */
    ci.impact_velocity = colval(r, C, "contact.impact_velocity");
    ci.velocity_scale = colval(r, C, "contact.velocity_scale");
    ci.max_vn_in_contact = colval(r, C, "contact.max_vn_in_contact");
    ci.oscillation_index = colval(r, C, "contact.oscillation_index");
    ci.oscillation_scale = colval(r, C, "contact.oscillation_scale");
    ci.vn_sign_changes = colval(r, C, "contact.vn_sign_changes");
    ci.restitution = colval(r, C, "contact.restitution");
    if (isnan(ci.restitution)) ci.restitution = 0;
    if (!isnan(ci.velocity_scale)) {
      if (isnan(ci.impact_velocity)) ci.impact_velocity = 0;
      chatter = mo_chatter_verdict(&ci, cwhy, sizeof cwhy);
    }
    if (isnan(colval(r, C, "energy.final")) || isnan(growth)) {
      snprintf(r->cls, sizeof r->cls, "unstable");
      snprintf(r->why, sizeof r->why, "non-finite energy");
    } else if (growth > 0.01) {
      snprintf(r->cls, sizeof r->cls, "unstable");
      snprintf(r->why, sizeof r->why, "energy growth %.2g %%", 100 * growth);
    } else if (!isnan(pen) && !isnan(hmin) && pen > pen_rel * hmin + r->pen_landing) {
      snprintf(r->cls, sizeof r->cls, "unstable");
      if (r->pen_landing > 0)
        snprintf(r->why, sizeof r->why, "penetration %.3g (%.2g of the smallest element, beyond the %.3g a landing leaves)",
                 pen, pen / hmin, r->pen_landing);
      else
        snprintf(r->why, sizeof r->why, "penetration %.3g (%.2g of the smallest element)", pen, pen / hmin);
    } else if (chatter) {
      snprintf(r->cls, sizeof r->cls, "chatter");
      snprintf(r->why, sizeof r->why, "%s", cwhy);
    } else {
      /* stable, and why: what was measured against the thresholds */
      snprintf(r->cls, sizeof r->cls, "stable");
      snprintf(r->why, sizeof r->why, "energy growth %.2g %% (<= 1 %%)%s%s", 100 * (growth > 0 ? growth : 0),
               cwhy[0] ? "; " : "", cwhy);
    }
  }
}

/* The error used for the work-precision figure: the option, else the first field error, else
   the first probe displacement error. */
static int pick_metric(const colset *C, const char *want)
{
  static const char *pref[] = {"field.u_l2l2_rel", "field.v_l2l2_rel"};
  int k;
  size_t p;
  if (want) {
    for (k = 0; k < C->n; k++)
      if (!strcmp(C->name[k], want)) return k;
    return -1;
  }
  for (p = 0; p < sizeof pref / sizeof pref[0]; p++)
    for (k = 0; k < C->n; k++)
      if (!strcmp(C->name[k], pref[p])) return k;
  for (k = 0; k < C->n; k++)
    if (strstr(C->name[k], "ux.l2_rel") || strstr(C->name[k], "uy.l2_rel") || strstr(C->name[k], "uz.l2_rel")) return k;
  /* rigid bodies: the error of a position of the centre (BODY.x, .y, .z) */
  for (k = 0; k < C->n; k++) {
    size_t l = strlen(C->name[k]);
    if (strncmp(C->name[k], "ref.", 4) && l > 9 &&
        (!strcmp(C->name[k] + l - 9, ".x.l2_rel") || !strcmp(C->name[k] + l - 9, ".y.l2_rel") ||
         !strcmp(C->name[k] + l - 9, ".z.l2_rel")))
      return k;
  }
  /* no closed form: the distance to the finest run (T98), a displacement or position first */
  for (k = 0; k < C->n; k++) {
    size_t l = strlen(C->name[k]);
    if (!strncmp(C->name[k], "ref.", 4) && l > 10 &&
        (strstr(C->name[k], ".ux.l2_rel") || strstr(C->name[k], ".uy.l2_rel") || strstr(C->name[k], ".uz.l2_rel") ||
         !strcmp(C->name[k] + l - 9, ".x.l2_rel") || !strcmp(C->name[k] + l - 9, ".y.l2_rel")))
      return k;
  }
  for (k = 0; k < C->n; k++)
    if (!strncmp(C->name[k], "ref.", 4) && strstr(C->name[k], ".l2_rel")) return k;
  return -1;
}

static int write_text(const char *path, const char *text, mo_ctx *ctx)
{
  return mo_write_file_atomic(path, text, strlen(text), ctx);
}

/* A growable string. */
typedef struct {
  char *s;
  size_t n, cap;
  int err;
} sbuf;

static void sb_printf(sbuf *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void sb_printf(sbuf *b, const char *fmt, ...)
{
  va_list ap;
  int w;
  if (b->err) return;
  for (;;) {
    size_t room = b->cap - b->n;
    va_start(ap, fmt);
    w = vsnprintf(b->s ? b->s + b->n : NULL, b->s ? room : 0, fmt, ap);
    va_end(ap);
    if (w < 0) { b->err = 1; return; }
    if (b->s && (size_t)w < room) { b->n += (size_t)w; return; }
    {
      size_t cap = b->cap ? 2 * b->cap : 4096;
      char *p;
      while (cap < b->n + (size_t)w + 1) cap *= 2;
      p = realloc(b->s, cap);
      if (!p) { b->err = 1; return; }
      b->s = p;
      b->cap = cap;
    }
  }
}

/* ",value", quoted as RFC 4180 asks when the value holds a comma or a quote (a vector such as
   [0.0,-1.0], a string). */
static void csv_field(sbuf *b, const char *v)
{
  const char *p;
  if (!strpbrk(v, ",\"\n")) {
    sb_printf(b, ",%s", v);
    return;
  }
  sb_printf(b, ",\"");
  for (p = v; *p; p++) sb_printf(b, *p == '"' ? "\"\"" : "%c", *p);
  sb_printf(b, "\"");
}

/* Axes of a stability map. A time step, or a numeric parameter spanning a decade (positive),
   gets a log axis; a parameter with a non-numeric value (a scheme name, say) is plotted at the index
   of its value, labelled. */
static int vary_numeric(const mo_compare_vary *V, double *lo, double *hi)
{
  int k;
  *lo = HUGE_VAL;
  *hi = -HUGE_VAL;
  for (k = 0; k < V->nval; k++) {
    char *end;
    double x = strtod(V->val[k], &end);
    if (end == V->val[k] || *end || !isfinite(x)) return 0;
    if (x < *lo) *lo = x;
    if (x > *hi) *hi = x;
  }
  return V->nval > 0;
}

static void axis_coord(const mo_compare_vary *V, const char *val, char *out, size_t n)
{
  double lo, hi;
  int k;
  if (vary_numeric(V, &lo, &hi)) {
    snprintf(out, n, "%s", val);
    return;
  }
  for (k = 0; k < V->nval; k++)
    if (!strcmp(V->val[k], val)) break;
  snprintf(out, n, "%d", k);
}

static void axis_setup(sbuf *gp, const mo_compare_vary *V, char axis)
{
  double lo, hi;
  int k;
  if (vary_numeric(V, &lo, &hi)) {
    /* a time step, or a positive parameter spanning a decade: a log axis */
    if (lo > 0 && (hi >= 8 * lo || !strcmp(V->key, "time.dt"))) sb_printf(gp, "set logscale %c\nset format %c '%%.0e'\n", axis, axis);
    return;
  }
  sb_printf(gp, "set %ctics (", axis);
  for (k = 0; k < V->nval; k++) sb_printf(gp, "%s'%s' %d", k ? ", " : "", V->val[k], k);
  sb_printf(gp, ")\n");
}

#define HEADER_MAX 16384

/* Column number (1-based, gnuplot) of `name` in a CSV header line, 0 when absent. */
static int csv_column(const char *header, const char *name)
{
  char line[HEADER_MAX], *tok, *save = NULL;
  int k = 0;
  snprintf(line, sizeof line, "%s", header);
  for (tok = strtok_r(line, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
    k++;
    if (!strcmp(tok, name)) return k;
  }
  return 0;
}

static int run_gnuplot(const char *dir, const char *script, mo_ctx *ctx)
{
#ifdef GNUPLOT_PATH
  char cmd[2400];
  int rc;
  snprintf(cmd, sizeof cmd, "cd '%s' && '%s' '%s' > /dev/null 2>&1", dir, GNUPLOT_PATH, script);
  rc = system(cmd);
  if (rc != 0) mo_log(ctx, 1, "moreau compare: gnuplot failed on %s/%s (exit %d)\n", dir, script, rc);
  return rc == 0;
#else
  (void)dir; (void)script; (void)ctx;
  return 0;
#endif
}

/* The terminal of one rendering of figure `name`: PNG (svg = 0), then SVG. */
static void set_terminal(sbuf *gp, const char *name, int svg)
{
  sb_printf(gp, svg ? "set terminal svg noenhanced size 900,600\nset output '%s.svg'\n"
                    : "set terminal pngcairo noenhanced size 900,600\nset output '%s.png'\n", name);
}

/* The colour of the i-th back end in every figure (with its own marker and dash pattern). */
static const char *colour(int i)
{
  static const char *c[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#17becf", "#7f7f7f"};
  return c[i % 8];
}

/* Keep the script of figure `name` as plots/NAME.gp and render it: 1 when gnuplot drew it. */
static int render(const char *dir, const char *name, const sbuf *gp, mo_ctx *ctx)
{
  char pdir[1200], sname[300], path[1600];
  snprintf(pdir, sizeof pdir, "%s/plots", dir);
  snprintf(sname, sizeof sname, "%s.gp", name);
  snprintf(path, sizeof path, "%s/%s", pdir, sname);
  if (gp->s) write_text(path, gp->s, ctx);
  return run_gnuplot(pdir, sname, ctx);
}

/* The header line of a run's history.csv, "" when it has none. */
static void history_header(const char *outdir, char *line, size_t n)
{
  char path[1200];
  FILE *f;
  line[0] = '\0';
  snprintf(path, sizeof path, "%s/history.csv", outdir);
  if (!(f = fopen(path, "r"))) return;
  if (!fgets(line, (int)n, f)) line[0] = '\0';
  fclose(f);
  line[strcspn(line, "\r\n")] = '\0';
}

/* The run of `solver` with the smallest time step at the first grid point, -1 when none. */
static int finest_run(const run_row *rows, int nrun, int ngrid, const char *solver)
{
  int r, rb = -1;
  for (r = 0; r < nrun; r += ngrid)
    if (!strcmp(rows[r].solver, solver) && (rb < 0 || rows[r].dt < rows[rb].dt)) rb = r;
  return rb;
}

/* Sanitise a label for file names. */
static void slug(const char *in, char *out, size_t n)
{
  size_t k = 0;
  for (; *in && k + 1 < n; in++) {
    if (*in == ']' || *in == '"') continue; /* nscd:jean88[theta=0.5] -> nscd-jean88_theta_0.5 */
    out[k++] = (char)(*in == ':' ? '-' : strchr("/ =,;[(*?", *in) ? '_' : *in);
  }
  out[k] = '\0';
}

/* --- peers: rows another program measured (--peer FILE.csv) ---------------------------------- */

/* The peer files' rows: read before the runs (a bad file stops the comparison before any work),
   merged after compare.csv is written (they never enter it). */
typedef struct {
  int nfile;
  colset *head;   /* one header per file */
  int n, cap;
  run_row *row;   /* val[k] holds the k-th column of its file until peers_merge */
  int *file;      /* the file of each row */
} peer_set;

#define MAX_PEER_ROWS 100000

static void peers_free(peer_set *P)
{
  mo_free(P->head);
  mo_free(P->row);
  mo_free(P->file);
  memset(P, 0, sizeof *P);
}

/* Split a CSV line in place into its cells (RFC 4180: a quoted cell may hold commas, and ""
   stands for a quote in it); -1 beyond max cells, -2 for a quote out of place. */
static int csv_split(char *line, char **cell, int max)
{
  int n = 0;
  char *r = line, *w;
  line[strcspn(line, "\r\n")] = '\0';
  for (;;) {
    if (n == max) return -1;
    cell[n++] = w = r;
    if (*r == '"') {
      for (r++;; r++) {
        if (!*r) return -2;                  /* no closing quote */
        if (*r == '"' && r[1] != '"') break; /* the closing quote */
        if (*r == '"') r++;                  /* "" stands for " */
        *w++ = *r;
      }
      r++;
      if (*r && *r != ',') return -2;
    } else {
      for (; *r && *r != ','; r++) {
        if (*r == '"') return -2;
        *w++ = *r;
      }
    }
    if (!*r) {
      *w = '\0';
      return n;
    }
    *w = '\0';
    r++;
  }
}

/* The columns a row holds as text or as its own fields, not as metrics. */
static int peer_field_column(const char *name)
{
  static const char *field[] = {"solver", "dt", "wall_s", "steps", "status", "class", "reason"};
  size_t k;
  for (k = 0; k < sizeof field / sizeof field[0]; k++)
    if (!strcmp(name, field[k])) return 1;
  return 0;
}

static int peers_read(const mo_compare_options *opt, peer_set *P, mo_ctx *ctx)
{
  int f, st = MO_OK;
  char *line = NULL, **cell = NULL;
  size_t cap = 0;
  FILE *in = NULL;
  memset(P, 0, sizeof *P);
  if (opt->npeer <= 0) return MO_OK;
  P->nfile = opt->npeer;
  P->head = mo_calloc(ctx, (size_t)opt->npeer, sizeof *P->head);
  cell = mo_calloc(ctx, MAX_COLS, sizeof *cell);
  if (!P->head || !cell) {
    st = MO_ENOMEM;
    goto done;
  }
  for (f = 0; f < opt->npeer; f++) {
    const char *path = opt->peers[f];
    colset *H = &P->head[f];
    int c_solver = -1, c_dt = -1, c_wall = -1, c_steps = -1, c_status = -1, c_reason = -1, k, nc, lineno = 1;
    if (!(in = fopen(path, "r"))) {
      st = mo_error(ctx, MO_EIO, "peer %s: %s", path, strerror(errno));
      goto done;
    }
    if (getline(&line, &cap, in) < 0) {
      st = mo_error(ctx, MO_EINPUT, "peer %s: empty (a header row is expected)", path);
      goto done;
    }
    if ((nc = csv_split(line, cell, MAX_COLS)) < 0) {
      if (nc == -1) st = mo_error(ctx, MO_ELIMIT, "peer %s: more than %d columns", path, MAX_COLS);
      else st = mo_error(ctx, MO_EINPUT, "peer %s: a quote out of place in the header", path);
      goto done;
    }
    for (k = 0; k < nc; k++) {
      snprintf(H->name[k], sizeof H->name[k], "%s", cell[k]);
      if (!strcmp(cell[k], "solver")) c_solver = k;
      else if (!strcmp(cell[k], "dt")) c_dt = k;
      else if (!strcmp(cell[k], "wall_s")) c_wall = k;
      else if (!strcmp(cell[k], "steps")) c_steps = k;
      else if (!strcmp(cell[k], "status")) c_status = k;
      else if (!strcmp(cell[k], "reason")) c_reason = k;
    }
    H->n = nc;
    if (c_solver < 0 || c_dt < 0 || c_wall < 0) {
      st = mo_error(ctx, MO_EINPUT, "peer %s: no column '%s' in the header (a peer file has compare.csv's "
                    "columns: solver, dt, wall_s, then steps, status, reason and metrics by name)",
                    path, c_solver < 0 ? "solver" : c_dt < 0 ? "dt" : "wall_s");
      goto done;
    }
    while (getline(&line, &cap, in) >= 0) {
      run_row *R;
      char *end;
      int s;
      lineno++;
      if (line[strspn(line, " \t\r\n")] == '\0') continue;
      if ((nc = csv_split(line, cell, MAX_COLS)) == -2) {
        st = mo_error(ctx, MO_EINPUT, "peer %s:%d: a quote out of place (RFC 4180 quoting, one row per line)", path, lineno);
        goto done;
      }
      if (nc != H->n) {
        st = mo_error(ctx, MO_EINPUT, "peer %s:%d: %d fields, the header has %d", path, lineno, nc < 0 ? MAX_COLS : nc, H->n);
        goto done;
      }
      if (P->n == P->cap) {
        int ncap = P->cap ? 2 * P->cap : 16;
        run_row *nr;
        int *nf;
        if (P->n >= MAX_PEER_ROWS) {
          st = mo_error(ctx, MO_ELIMIT, "peer %s: more than %d rows in the peer files", path, MAX_PEER_ROWS);
          goto done;
        }
        if (!(nr = mo_realloc(ctx, P->row, (size_t)ncap * sizeof *nr))) {
          st = MO_ENOMEM;
          goto done;
        }
        P->row = nr;
        if (!(nf = mo_realloc(ctx, P->file, (size_t)ncap * sizeof *nf))) {
          st = MO_ENOMEM;
          goto done;
        }
        P->file = nf;
        P->cap = ncap;
      }
      R = &P->row[P->n];
      memset(R, 0, sizeof *R);
      if (!cell[c_solver][0]) {
        st = mo_error(ctx, MO_EINPUT, "peer %s:%d: no solver name", path, lineno);
        goto done;
      }
      snprintf(R->solver, sizeof R->solver, "%s", cell[c_solver]);
      for (s = 0; s < opt->nsolver; s++)
        if (!strcmp(R->solver, opt->solvers[s])) {
          st = mo_error(ctx, MO_EINPUT, "peer %s:%d: solver '%s' is a back end of this comparison: a peer "
                        "row names its own solver", path, lineno, R->solver);
          goto done;
        }
      R->dt = strtod(cell[c_dt], &end);
      if (end == cell[c_dt] || *end || !(R->dt > 0)) {
        st = mo_error(ctx, MO_EINPUT, "peer %s:%d: dt '%s' is not a positive number", path, lineno, cell[c_dt]);
        goto done;
      }
      R->wall = strtod(cell[c_wall], &end);
      if (end == cell[c_wall] || *end) R->wall = NAN;
      R->steps = c_steps >= 0 ? strtol(cell[c_steps], NULL, 10) : 0;
      /* a failed peer run: status other than "complete" (the reason column says why) */
      R->status = c_status >= 0 && cell[c_status][0] && strcmp(cell[c_status], "complete") ? -1 : MO_OK;
      if (c_reason >= 0) snprintf(R->reason, sizeof R->reason, "%s", cell[c_reason]);
      for (k = 0; k < H->n; k++) {
        double v = strtod(cell[k], &end);
        R->val[k] = peer_field_column(H->name[k]) || end == cell[k] || *end ? NAN : v;
      }
      P->file[P->n++] = f;
    }
    if (ferror(in)) {
      st = mo_error(ctx, MO_EIO, "peer %s: read error", path);
      goto done;
    }
    fclose(in);
    in = NULL;
  }
done:
  if (in) fclose(in);
  free(line);
  mo_free(cell);
  if (st) peers_free(P);
  return st;
}

/* The peer rows into dst, their metrics in the comparison's columns; classified as moreau's
   runs are when they carry the energy columns. Returns the number of rows. */
static int peers_merge(const peer_set *P, colset *C, run_row *dst, double pen_rel)
{
  int r, k;
  for (r = 0; r < P->n; r++) {
    run_row *R = &dst[r];
    const colset *H = &P->head[P->file[r]];
    *R = P->row[r];
    for (k = 0; k < MAX_COLS; k++) R->val[k] = NAN;
    for (k = 0; k < H->n; k++) {
      int c;
      if (isnan(P->row[r].val[k]) || (c = col_index(C, H->name[k])) < 0) continue;
      R->val[c] = P->row[r].val[k];
    }
    snprintf(R->label, sizeof R->label, "%s-dt%g (external)", R->solver, R->dt);
    R->dup_of = -1;
    R->nrep = 0;
    R->tmin = R->tmed = R->tmax = NAN;
    R->outdir[0] = '\0';
    if (R->status) {
      snprintf(R->cls, sizeof R->cls, "failed");
      snprintf(R->why, sizeof R->why, "%s", R->reason[0] ? R->reason : "failed (the peer gives no reason)");
    } else if (isnan(colval(R, C, "energy.final")) && isnan(colval(R, C, "energy.max_growth"))) {
      snprintf(R->cls, sizeof R->cls, "unclassified");
      R->why[0] = '\0';
    } else
      classify(R, C, pen_rel);
  }
  return P->n;
}

/* The peers' lines of the work-precision figure: a data file and a dashed line per solver. */
static void peers_plot(sbuf *gp, const run_row *rows, int n, int metric_col, const char *dir, mo_ctx *ctx)
{
  int i, r;
  for (i = 0; i < n; i++) {
    char nm[128], f[1400];
    sbuf dat = {NULL, 0, 0, 0};
    for (r = 0; r < i && strcmp(rows[r].solver, rows[i].solver); r++) continue;
    if (r < i) continue; /* a solver already drawn */
    for (r = i; r < n; r++)
      if (!strcmp(rows[r].solver, rows[i].solver) && !rows[r].status && rows[r].val[metric_col] > 0 && rows[r].wall > 0)
        sb_printf(&dat, "%.6g,%.6g,%.6g\n", rows[r].wall, rows[r].val[metric_col], rows[r].dt);
    if (!dat.s) continue;
    slug(rows[i].solver, nm, sizeof nm);
    snprintf(f, sizeof f, "%s/plots/work-precision-peer-%s.csv", dir, nm);
    write_text(f, dat.s, ctx);
    free(dat.s);
    sb_printf(gp, ", 'work-precision-peer-%s.csv' using 1:2 with linespoints lw 2 dt 2 pt 6 title '%s (peer)'", nm,
              rows[i].solver);
  }
}

/* Whether back end `solver` ignores case key `key`, so that the cells of a grid that differ in
   that key alone are one run: the options of another back end (contact.OTHER.*), and the
   theta-scheme's keys for a back end that runs its own scheme (newmark's time_scheme). The
   back end's name is the part of `solver` before a ':' or '[' (a preset, a labelled entry). */
static int solver_ignores(const char *solver, const char *key, const mo_ctx *ctx)
{
  char base[64], other[64];
  const mo_contact_solver_type *T;
  size_t n = strcspn(solver, ":[");
  if (n >= sizeof base) return 0;
  memcpy(base, solver, n);
  base[n] = '\0';
  if (!(T = mo_contact_solver_lookup(base, ctx))) return 0;  /* "case", or a name the run will reject */
  if (!strncmp(key, "contact.", 8)) {
    size_t m = strcspn(key + 8, ".");
    if (key[8 + m] != '.' || m >= sizeof other) return 0;
    memcpy(other, key + 8, m);
    other[m] = '\0';
    return strcmp(other, base) && mo_contact_solver_lookup(other, ctx) != NULL;
  }
  if (!strcmp(key, "time.theta") || !strcmp(key, "time.theta_f")) {
    mo_time_settings ts;
    void *params;
    int own = 0;
    if (!T->time_scheme) return 0;
    if (!(params = calloc(1, T->params_size ? T->params_size : 1))) return 0;
    if (T->defaults) T->defaults(params);
    memset(&ts, 0, sizeof ts);
    ts.scheme = MO_SCHEME_THETA;
    if (!T->time_scheme(params, &ts, NULL)) own = ts.scheme != MO_SCHEME_THETA;
    free(params);
    return own;
  }
  return 0;
}

/* Step times of the runs of a cell so far: another run when --repeat N asks for more, or (N = 0)
   until the median is stable, (T99): at least 3 runs, at most MAX_REPEAT, stopping when the
   last run moved the median by less than REPEAT_TOL of it, or when the cell's runs took
   REPEAT_BUDGET seconds (a run that long has a small spread of its own). */
#define MAX_REPEAT 5      /* adaptive */
#define REPEAT_CAP 20     /* --repeat N */
#define REPEAT_TOL 0.05
#define REPEAT_BUDGET 5.0

static double median(const double *x, int n)
{
  double y[REPEAT_CAP];
  int i, j;
  for (i = 0; i < n; i++) {
    double v = x[i];
    for (j = i; j > 0 && y[j - 1] > v; j--) y[j] = y[j - 1];
    y[j] = v;
  }
  return n % 2 ? y[n / 2] : 0.5 * (y[n / 2 - 1] + y[n / 2]);
}

static int repeat_more(const double *t, int n, double spent, int want)
{
  double m, mprev;
  if (want > 0) return n < (want < REPEAT_CAP ? want : REPEAT_CAP);
  if (n >= MAX_REPEAT || spent >= REPEAT_BUDGET) return 0;
  if (n < 3) return 1;
  m = median(t, n);
  mprev = median(t, n - 1);
  return fabs(m - mprev) > REPEAT_TOL * m;
}

/* --- references without a closed form, and observed orders (doc/theory.md (T98)) ------------ */

/* A run's history.csv as numbers: ncol names and nrow rows of ncol values. */
typedef struct {
  int ncol, nrow;
  char (*name)[96];
  double *v;
} history;

static void history_free(history *h)
{
  free(h->name);
  free(h->v);
  memset(h, 0, sizeof *h);
}

static int history_read(const char *outdir, history *h)
{
  char path[1200], *line = NULL, *cell[MAX_COLS];
  size_t cap = 0, vcap = 0;
  FILE *f;
  int n, k;
  memset(h, 0, sizeof *h);
  snprintf(path, sizeof path, "%s/history.csv", outdir);
  if (!(f = fopen(path, "r"))) return 0;
  if (getline(&line, &cap, f) < 0 || (n = csv_split(line, cell, MAX_COLS)) < 2 || !(h->name = calloc((size_t)n, sizeof *h->name)))
    goto fail;
  h->ncol = n;
  for (k = 0; k < n; k++) snprintf(h->name[k], sizeof h->name[k], "%s", cell[k]);
  while (getline(&line, &cap, f) >= 0) {
    if (csv_split(line, cell, MAX_COLS) != h->ncol) continue;
    if ((size_t)(h->nrow + 1) * (size_t)h->ncol > vcap) {
      size_t nc = vcap ? 2 * vcap : 1024 * (size_t)h->ncol;
      double *p = realloc(h->v, nc * sizeof *p);
      if (!p) goto fail;
      h->v = p;
      vcap = nc;
    }
    for (k = 0; k < h->ncol; k++) h->v[(size_t)h->nrow * (size_t)h->ncol + (size_t)k] = strtod(cell[k], NULL);
    h->nrow++;
  }
  fclose(f);
  free(line);
  return h->nrow > 0;
fail:
  fclose(f);
  free(line);
  history_free(h);
  return 0;
}

static int history_col(const history *h, const char *name)
{
  int k;
  for (k = 1; k < h->ncol; k++)
    if (!strcmp(h->name[k], name)) return k;
  return -1;
}

/* Column c of h at time t, linear between rows (t within the rows' span), NaN outside. */
static double history_at(const history *h, int c, double t)
{
  int lo = 0, hi = h->nrow - 1, m;
  const double *v = h->v;
  size_t nc = (size_t)h->ncol;
  double t0 = v[0], t1 = v[(size_t)hi * nc], tol = 1e-9 * (fabs(t1) + fabs(t0) + 1e-300);
  if (t < t0 - tol || t > t1 + tol) return NAN;
  while (hi - lo > 1) {
    m = (lo + hi) / 2;
    if (v[(size_t)m * nc] <= t) lo = m;
    else hi = m;
  }
  {
    double ta = v[(size_t)lo * nc], tb = v[(size_t)hi * nc], w;
    if (fabs(t - ta) <= tol || hi == lo) return v[(size_t)lo * nc + (size_t)c];
    if (fabs(t - tb) <= tol) return v[(size_t)hi * nc + (size_t)c];
    w = (t - ta) / (tb - ta);
    return (1 - w) * v[(size_t)lo * nc + (size_t)c] + w * v[(size_t)hi * nc + (size_t)c];
  }
}

/* The quantities a reference run is compared on: the probes' and rigid bodies' columns (not
   their closed forms, energies, or the contact diagnostics of the step). */
static int compared_column(const char *name)
{
  static const char *skip[] = {"energy.", "contact.", "newton.", "time.", "rigid."};
  size_t k, l = strlen(name);
  if (!strchr(name, '.') || (l > 6 && !strcmp(name + l - 6, ".exact"))) return 0;
  for (k = 0; k < sizeof skip / sizeof skip[0]; k++)
    if (!strncmp(name, skip[k], strlen(skip[k]))) return 0;
  return 1;
}

#define MAX_REF_COLS 12

/* The relative L2 distance of column ca of A and column cb of B over A's rows (B interpolated),
   scaled by |B|; NaN when B vanishes there or they share no times. */
static double history_distance(const history *A, int ca, const history *B, int cb)
{
  double e = 0, n = 0;
  int i, m = 0;
  for (i = 0; i < A->nrow; i++) {
    double t = A->v[(size_t)i * (size_t)A->ncol], y = A->v[(size_t)i * (size_t)A->ncol + (size_t)ca];
    double yr = history_at(B, cb, t);
    if (!isfinite(yr) || !isfinite(y)) continue;
    e += (y - yr) * (y - yr);
    n += yr * yr;
    m++;
  }
  return m && n > 0 ? sqrt(e / n) : NAN;
}

/* Richardson (T98): the order p with (h1^p - h2^p) / (h2^p - h3^p) = d12 / d23 (for h1/h2 =
   h2/h3 = r, p = log(d12/d23) / log r); NaN when the differences do not shrink. */
static double richardson(double h1, double h2, double h3, double d12, double d23)
{
  double q, lo = 1e-3, hi = 20, r1 = h1 / h2, r2 = h2 / h3;
  int it;
  if (!(d12 > 0) || !(d23 > 0) || !isfinite(d12) || !isfinite(d23) || !(r1 > 1) || !(r2 > 1)) return NAN;
  q = d12 / d23;
  if (fabs(r1 - r2) < 1e-9 * r1) return q > 1 ? log(q) / log(r1) : NAN;
  /* f(p) = r2^p (r1^p - 1) / (r2^p - 1) increases with p */
#define RF(p) (pow(r2, p) * (pow(r1, p) - 1) / (pow(r2, p) - 1))
  if (q <= RF(lo) || q >= RF(hi)) return NAN;
  for (it = 0; it < 200; it++) {
    double m = 0.5 * (lo + hi);
    if (RF(m) < q) lo = m;
    else hi = m;
  }
#undef RF
  return 0.5 * (lo + hi);
}

typedef struct {
  int row;                 /* the run with the finest step of the triple */
  char metric[96];         /* the history column */
  double h[3], d12, d23, p;
} order_rec;

typedef struct {
  int n, cap;
  order_rec *o;
} order_set;

/* For every back end and grid point: the run with the smallest step is the reference of the
   others (columns ref.COL.l2_rel and ref.dt), and every three successive steps give an observed
   order per compared column. */
static int references(run_row *rows, int nrun, int nsol, int ndt, int ngrid, colset *C, order_set *O, mo_ctx *ctx)
{
  int si, gi, st = MO_OK;
  int *idx = mo_malloc(ctx, (size_t)ndt * sizeof *idx);
  history *hs = mo_calloc(ctx, (size_t)ndt, sizeof *hs);
  if (!idx || !hs) { mo_free(idx); mo_free(hs); return MO_ENOMEM; }
  for (si = 0; si < nsol; si++)
    for (gi = 0; gi < ngrid; gi++) {
      int n = 0, di, a, bb, c, ncmp = 0, cols[MAX_REF_COLS];
      const history *ref;
      for (di = 0; di < ndt; di++) {
        int r = si * ndt * ngrid + di * ngrid + gi;
        if (r >= nrun || rows[r].dup_of >= 0 || rows[r].status || !(rows[r].dt > 0)) continue;
        idx[n++] = r;
      }
      /* coarsest first */
      for (a = 1; a < n; a++)
        for (bb = a; bb > 0 && rows[idx[bb - 1]].dt < rows[idx[bb]].dt; bb--) {
          int t = idx[bb];
          idx[bb] = idx[bb - 1];
          idx[bb - 1] = t;
        }
      if (n < 2) continue;
      for (a = 0; a < n; a++)
        if (!history_read(rows[idx[a]].outdir, &hs[a])) break;
      if (a < n) {
        for (bb = 0; bb < n; bb++) history_free(&hs[bb]);
        continue;
      }
      ref = &hs[n - 1];
      for (c = 1; c < ref->ncol && ncmp < MAX_REF_COLS; c++)
        if (compared_column(ref->name[c])) cols[ncmp++] = c;
      for (a = 0; a < n; a++) {
        int kd = col_index(C, "ref.dt");
        if (kd >= 0) rows[idx[a]].val[kd] = rows[idx[n - 1]].dt;
        if (a == n - 1) continue;
        for (c = 0; c < ncmp; c++) {
          char name[96];
          int ca = history_col(&hs[a], ref->name[cols[c]]), k;
          if (ca < 0) continue;
          snprintf(name, sizeof name, "ref.%s.l2_rel", ref->name[cols[c]]);
          if ((k = col_index(C, name)) >= 0) rows[idx[a]].val[k] = history_distance(&hs[a], ca, ref, cols[c]);
        }
      }
      for (a = 0; a + 2 < n; a++)
        for (c = 0; c < ncmp; c++) {
          const char *nm = ref->name[cols[c]];
          int c1 = history_col(&hs[a], nm), c2 = history_col(&hs[a + 1], nm), c3 = history_col(&hs[a + 2], nm);
          order_rec *o;
          double n3 = 0, e12 = 0, e23 = 0;
          int i;
          if (c1 < 0 || c2 < 0 || c3 < 0) continue;
          /* both differences on the coarsest run's times */
          for (i = 0; i < hs[a].nrow; i++) {
            double t = hs[a].v[(size_t)i * (size_t)hs[a].ncol], y1 = hs[a].v[(size_t)i * (size_t)hs[a].ncol + (size_t)c1];
            double y2 = history_at(&hs[a + 1], c2, t), y3 = history_at(&hs[a + 2], c3, t);
            if (!isfinite(y1) || !isfinite(y2) || !isfinite(y3)) continue;
            e12 += (y1 - y2) * (y1 - y2);
            e23 += (y2 - y3) * (y2 - y3);
            n3 += y3 * y3;
          }
          if (!(n3 > 0)) continue;
          if (O->n == O->cap) {
            int nc = O->cap ? 2 * O->cap : 64;
            order_rec *p = mo_realloc(ctx, O->o, (size_t)nc * sizeof *p);
            if (!p) { st = MO_ENOMEM; goto out; }
            O->o = p;
            O->cap = nc;
          }
          o = &O->o[O->n++];
          o->row = idx[a + 2];
          snprintf(o->metric, sizeof o->metric, "%s", nm);
          o->h[0] = rows[idx[a]].dt;
          o->h[1] = rows[idx[a + 1]].dt;
          o->h[2] = rows[idx[a + 2]].dt;
          o->d12 = sqrt(e12 / n3);
          o->d23 = sqrt(e23 / n3);
          /* distances at round-off: no time error to measure (a quantity the scheme gets exactly) */
          o->p = o->d12 < 1e-11 || o->d23 < 1e-11 ? NAN : richardson(o->h[0], o->h[1], o->h[2], o->d12, o->d23);
        }
    out:
      for (a = 0; a < n; a++) history_free(&hs[a]);
      if (st) goto done;
    }
done:
  mo_free(idx);
  mo_free(hs);
  return st;
}

int mo_compare(const mo_compare_options *opt, mo_compare_result *res, mo_ctx *ctx)
{
  int nsol = opt->nsolver ? opt->nsolver : 1, ndt = opt->ndt ? opt->ndt : 1, ngrid = 1, i, j, k, st = MO_OK;
  int nrun, r, metric_col, nown, stop;
  run_row *rows = NULL;
  colset *C = NULL, *H = NULL;
  const char **sets = NULL;
  peer_set P;
  order_set O = {0, 0, NULL};
  char dir[1024], path[1400], stopmsg[MO_ERRMSG_MAX];
  double dtl[65];
  const double *dts = opt->dt;
  sbuf b = {NULL, 0, 0, 0};
  memset(res, 0, sizeof *res);
  /* --reference DT: one more step, the finest (T98) */
  if (opt->reference_dt > 0) {
    if (!opt->ndt || opt->ndt >= 64)
      return mo_error(ctx, MO_EINPUT, "compare: --reference needs the sweep's time steps (--dt h1,h2,..., at most 63)");
    for (k = 0; k < opt->ndt; k++) {
      if (!(opt->reference_dt < opt->dt[k]))
        return mo_error(ctx, MO_EINPUT, "compare: --reference %g is not smaller than the step %g of --dt", opt->reference_dt,
                        opt->dt[k]);
      dtl[k] = opt->dt[k];
    }
    dtl[k] = opt->reference_dt;
    ndt = opt->ndt + 1;
    dts = dtl;
  }
  if (opt->repeat < 0 || opt->repeat > REPEAT_CAP)
    return mo_error(ctx, MO_EINPUT, "compare: --repeat %d: 1 to %d runs per cell (0: adaptive)", opt->repeat, REPEAT_CAP);
  for (k = 0; k < opt->nvary; k++) ngrid *= opt->vary[k].nval;
  nrun = nsol * ndt * ngrid;
  if (nrun > 10000) return mo_error(ctx, MO_ELIMIT, "compare: %d runs (more than 10000): a smaller grid, please", nrun);
  if ((st = peers_read(opt, &P, ctx))) return st;
  snprintf(dir, sizeof dir, "%s", opt->outdir);
  if ((st = mo_mkdir_p(dir, ctx))) goto done;
  snprintf(path, sizeof path, "%s/plots", dir);
  if ((st = mo_mkdir_p(path, ctx))) goto done;
  rows = mo_calloc(ctx, (size_t)nrun + (size_t)P.n, sizeof *rows);
  C = mo_calloc(ctx, 1, sizeof *C);
  H = mo_calloc(ctx, 1, sizeof *H);
  /* each run's --set list: the common ones, its time step, its grid point */
  sets = mo_calloc(ctx, (size_t)opt->nset + (size_t)opt->nvary + 2, sizeof *sets);
  if (!rows || !C || !H || !sets) { st = MO_ENOMEM; goto done; }

  /* run every (solver, dt, grid point); a cell that differs from another only in keys its back
     end ignores shares that cell's run (dup_of), marked, not run twice */
  for (r = 0; r < nrun; r++) {
    run_row *R = &rows[r];
    int si = r / (ndt * ngrid), di = (r / ngrid) % ndt, gi = r % ngrid, g = gi, nset = 0, stride = 1, g0 = 0;
    char dtset[64], varyset[MO_COMPARE_MAX_VARY][512], lab[512];
    double times[REPEAT_CAP], spent = 0;
    mo_run_options ro;
    mo_run_result rr;
    mo_ctx rc;
    for (k = 0; k < opt->nset; k++) sets[nset++] = opt->sets[k];
    snprintf(R->solver, sizeof R->solver, "%s", opt->nsolver ? opt->solvers[si] : "case");
    R->dt = opt->ndt ? dts[di] : NAN;
    R->dup_of = -1;
    if (opt->ndt) {
      snprintf(dtset, sizeof dtset, "time.dt=%.17g", dts[di]);
      sets[nset++] = dtset;
    }
    snprintf(lab, sizeof lab, "%s", R->solver);
    if (opt->ndt) snprintf(lab + strlen(lab), sizeof lab - strlen(lab), "-dt%g", R->dt);
    for (k = opt->nvary - 1; k >= 0; k--) { /* the last key varies fastest */
      int vi = g % opt->vary[k].nval;
      g /= opt->vary[k].nval;
      snprintf(R->vary[k], sizeof R->vary[k], "%s", opt->vary[k].val[vi]);
      snprintf(varyset[k], sizeof varyset[k], "%s=%s", opt->vary[k].key, opt->vary[k].val[vi]);
      if (solver_ignores(R->solver, opt->vary[k].key, ctx)) R->ignored |= 1u << k;
      else g0 += vi * stride; /* the cell with every ignored key at its first value */
      stride *= opt->vary[k].nval;
    }
    if (g0 != gi) {
      /* the run of cell g0 stands for this one: nothing to run */
      run_row *D = &rows[r - gi + g0];
      R->dup_of = r - gi + g0;
      R->status = D->status;
      snprintf(R->cls, sizeof R->cls, "%s", D->cls);
      snprintf(R->why, sizeof R->why, "%s", D->why);
      snprintf(R->label, sizeof R->label, "%s", D->label);
      snprintf(R->outdir, sizeof R->outdir, "%s", D->outdir);
      R->dt = D->dt;
      continue;
    }
    for (k = 0; k < opt->nvary; k++) {
      const char *dot = strrchr(opt->vary[k].key, '.');
      sets[nset++] = varyset[k];
      if (!(R->ignored & 1u << k))
        snprintf(lab + strlen(lab), sizeof lab - strlen(lab), "-%s%s", dot ? dot + 1 : opt->vary[k].key, R->vary[k]);
    }
    slug(lab, R->label, sizeof R->label);
    if (snprintf(R->outdir, sizeof R->outdir, "%s/runs/%s", dir, R->label) >= (int)sizeof R->outdir) {
      st = mo_error(ctx, MO_EIO, "compare: output path too long under %s", dir);
      goto done;
    }
    memset(&ro, 0, sizeof ro);
    ro.case_path = opt->case_path;
    ro.solver = opt->nsolver ? opt->solvers[si] : NULL;
    ro.sets = sets;
    ro.nset = nset;
    ro.outdir = R->outdir;
    ro.no_draw = 1;
    /* the run, again until its step time's median is known (T99): the runs are deterministic,
       each one rewrites the same outputs */
    R->nrep = 0;
    do {
      mo_ctx_init(&rc);
      rc.verbosity = 0;
      rc.interrupt = ctx->interrupt;
      rc.plugins = ctx->plugins; /* the back ends loaded at run time, shared */
      R->status = mo_run(&ro, &rr, &rc);
      R->wall = rr.wall;
      R->steps = rr.steps;
      spent += rr.wall;
      if (R->status) break;
      times[R->nrep++] = rr.step_wall;
    } while (repeat_more(times, R->nrep, spent, opt->repeat) && !(ctx->interrupt && *ctx->interrupt));
    if (R->nrep) {
      R->tmin = R->tmax = times[0];
      for (k = 1; k < R->nrep; k++) {
        if (times[k] < R->tmin) R->tmin = times[k];
        if (times[k] > R->tmax) R->tmax = times[k];
      }
      R->tmed = median(times, R->nrep);
    } else
      R->tmin = R->tmed = R->tmax = NAN; /* a failed run has no step time of a whole run */
    if (R->status && snprintf(R->reason, sizeof R->reason, "%s", rc.errmsg) >= (int)sizeof R->reason)
      R->reason[sizeof R->reason - 1] = '\0';
    read_summary(R, C, H);
    classify(R, C, opt->penetration_tol > 0 ? opt->penetration_tol : 0.01);
    if (ctx->verbosity >= 1)
      fprintf(stderr, "[%d/%d] %-40s %8.3f s  %s%s%s\n", r + 1, nrun, R->label, R->nrep ? R->tmed : R->wall, R->cls,
              R->why[0] ? ": " : "", R->why);
    if (R->status == MO_EINPUT || R->status == MO_EIO) {
      /* a case that does not load fails every run the same way: stop here */
      st = mo_error(ctx, R->status, "%s", R->reason);
      nrun = r + 1;
      break;
    }
    if (ctx->interrupt && *ctx->interrupt) {
      st = mo_error(ctx, MO_EINTERRUPT, "compare interrupted after %d of %d runs", r + 1, nrun);
      nrun = r + 1;
      break;
    }
  }
  /* a case that does not load, or an interrupt, ends the comparison with that error once the
     runs done so far are written */
  stop = st;
  if (stop) snprintf(stopmsg, sizeof stopmsg, "%s", ctx->errmsg);
  /* the cells run: a marked cell shares another's run (and its class) */
  for (r = 0; r < nrun; r++) {
    if (rows[r].dup_of >= 0) {
      res->nmarked++;
      continue;
    }
    res->nrun++;
    if (!strcmp(rows[r].cls, "stable")) res->nstable++;
    else if (!strcmp(rows[r].cls, "chatter")) res->nchatter++;
    else if (!strcmp(rows[r].cls, "unstable")) res->nunstable++;
    else res->nfailed++;
  }
  /* the errors of every run against the finest of its sweep, and the observed orders (T98) */
  if ((st = references(rows, nrun, nsol, ndt, ngrid, C, &O, ctx))) goto done;

  /* compare.csv: one row per run (a marked cell has none: its back end ignores a varied key,
     whose cell reads "ignored") */
  sb_printf(&b, "solver,dt");
  for (k = 0; k < opt->nvary; k++) sb_printf(&b, ",%s", opt->vary[k].key);
  sb_printf(&b, ",wall_s,steps,status,class,reason,time_min_s,time_median_s,time_max_s,repeats");
  for (k = 0; k < C->n; k++) sb_printf(&b, ",%s", C->name[k]);
  sb_printf(&b, "\n");
  for (r = 0; r < nrun; r++) {
    run_row *R = &rows[r];
    char why[1100];
    size_t q;
    if (R->dup_of >= 0) continue;
    snprintf(why, sizeof why, "%s%s%s", R->why, R->status && R->why[0] ? ": " : "", R->status ? R->reason : "");
    for (q = 0; why[q]; q++) if (why[q] == ',' || why[q] == '\n' || why[q] == '"') why[q] = ';';
    sb_printf(&b, "%s,%.10g", R->solver, R->dt);
    for (k = 0; k < opt->nvary; k++) csv_field(&b, R->ignored & 1u << k ? "ignored" : R->vary[k]);
    sb_printf(&b, ",%.6g,%ld,%s,%s,%s", R->wall, R->steps, R->status ? "failed" : "complete", R->cls, why);
    if (R->nrep) sb_printf(&b, ",%.6g,%.6g,%.6g,%d", R->tmin, R->tmed, R->tmax, R->nrep);
    else sb_printf(&b, ",,,,0");
    for (k = 0; k < C->n; k++) {
      if (isnan(R->val[k])) sb_printf(&b, ",");
      else sb_printf(&b, ",%.10g", R->val[k]);
    }
    sb_printf(&b, "\n");
  }
  if (b.err) { st = mo_error(ctx, MO_ENOMEM, "compare.csv"); goto done; }
  snprintf(path, sizeof path, "%s/compare.csv", dir);
  if ((st = write_text(path, b.s, ctx))) goto done;
  if (opt->nvary) {
    snprintf(path, sizeof path, "%s/stability.csv", dir);
    b.n = 0;
    sb_printf(&b, "solver,dt");
    for (k = 0; k < opt->nvary; k++) sb_printf(&b, ",%s", opt->vary[k].key);
    sb_printf(&b, ",class,reason,energy_max_growth,max_penetration,wall_s\n");
    for (r = 0; r < nrun; r++) {
      run_row *R = &rows[r];
      char why[600];
      size_t q;
      if (R->dup_of >= 0) continue;
      snprintf(why, sizeof why, "%s", R->why);
      for (q = 0; why[q]; q++) if (why[q] == ',' || why[q] == '\n') why[q] = ';';
      sb_printf(&b, "%s,%.10g", R->solver, R->dt);
      for (k = 0; k < opt->nvary; k++) csv_field(&b, R->ignored & 1u << k ? "ignored" : R->vary[k]);
      sb_printf(&b, ",%s,%s,%.6g,%.6g,%.6g\n", R->cls, why, colval(R, C, "energy.max_growth"),
                colval(R, C, "contact.max_penetration"), R->wall);
    }
    if ((st = write_text(path, b.s, ctx))) goto done;
  }
  /* orders.csv: the observed order of every three successive steps (T98) */
  {
    snprintf(path, sizeof path, "%s/orders.csv", dir);
    b.n = 0;
    sb_printf(&b, "solver");
    for (k = 0; k < opt->nvary; k++) sb_printf(&b, ",%s", opt->vary[k].key);
    sb_printf(&b, ",metric,dt1,dt2,dt3,diff12,diff23,order\n");
    for (k = 0; k < O.n; k++) {
      const order_rec *o = &O.o[k];
      const run_row *R = &rows[o->row];
      sb_printf(&b, "%s", R->solver);
      for (j = 0; j < opt->nvary; j++) csv_field(&b, R->ignored & 1u << j ? "ignored" : R->vary[j]);
      sb_printf(&b, ",%s,%.10g,%.10g,%.10g,%.6g,%.6g,", o->metric, o->h[0], o->h[1], o->h[2], o->d12, o->d23);
      if (isnan(o->p)) sb_printf(&b, "\n");
      else sb_printf(&b, "%.4f\n", o->p);
    }
    if (b.err) { st = mo_error(ctx, MO_ENOMEM, "orders.csv"); goto done; }
    if ((st = write_text(path, b.s ? b.s : "", ctx))) goto done;
  }

  /* the peers' rows follow the runs' (every loop below takes them; the figures' per-solver
     loops draw the runs' back ends, peers_plot the peers) */
  nown = nrun;
  res->npeer = peers_merge(&P, C, rows + nrun, opt->penetration_tol > 0 ? opt->penetration_tol : 0.01);
  nrun += res->npeer;

  /* figures: data files and gnuplot scripts (kept so that users restyle them); each back end
     with its own colour, marker and dash pattern, so that coinciding curves stay visible */
  metric_col = pick_metric(C, opt->metric);
  if (opt->metric && metric_col < 0) {
    /* a metric asked for by name that no run reported: say so, with the ones there are */
    char have[600] = "";
    size_t l = 0;
    for (k = 0; k < C->n && l < sizeof have - 80; k++)
      if (strstr(C->name[k], "_rel"))
        l += (size_t)snprintf(have + l, sizeof have - l, "%s%s", l ? ", " : "", C->name[k]);
    st = mo_error(ctx, MO_EINPUT, "compare --metric '%s': no run reported such a metric (%s%s)", opt->metric,
                  l ? "the relative errors are: " : "the case has no reference to measure errors against", have);
    goto done;
  }
  {
    int rendered = 0, nfig = 0;
    int closed = metric_col >= 0 && strncmp(C->name[metric_col], "ref.", 4);
    char ylab[300];
    if (metric_col >= 0) {
      if (closed) snprintf(ylab, sizeof ylab, "%s (relative, against the closed form)", C->name[metric_col]);
      else snprintf(ylab, sizeof ylab, "%s (relative, against the finest run)", C->name[metric_col]);
    }
    /* 1. error against the median step time, one line per back end, and 2. against the step */
    if (metric_col >= 0) {
      double t0 = NAN, e0 = NAN, h0 = NAN;
      for (i = 0; i < nsol; i++) {
        char f[1400], nm[128];
        sbuf dat = {NULL, 0, 0, 0};
        slug(rows[i * ndt * ngrid].solver, nm, sizeof nm);
        /* one line per grid point (a blank line between them) */
        for (j = 0; j < ngrid; j++) {
          int any = 0;
          for (k = 0; k < ndt; k++) {
            r = i * ndt * ngrid + k * ngrid + j;
            if (r < nown && rows[r].dup_of < 0 && !rows[r].status && !isnan(rows[r].val[metric_col]) &&
                rows[r].val[metric_col] > 0 && rows[r].tmed > 0) {
              sb_printf(&dat, "%s%.6g,%.6g,%.6g\n", any || !dat.s ? "" : "\n", rows[r].tmed, rows[r].val[metric_col],
                        rows[r].dt);
              any = 1;
              if (isnan(t0)) { t0 = rows[r].tmed; e0 = rows[r].val[metric_col]; h0 = rows[r].dt; }
            }
          }
        }
        snprintf(f, sizeof f, "%s/plots/work-precision-%s.csv", dir, nm);
        if (dat.s) write_text(f, dat.s, ctx);
        free(dat.s);
      }
      for (j = 0; j < 2; j++) {
        sbuf gp = {NULL, 0, 0, 0};
        const char *fig = j ? "convergence" : "work-precision";
        int first = 1;
        if (j)
          sb_printf(&gp, "# convergence: %s against the time step, one line per back end, with slopes 1 and 2\n"
                    "set datafile separator ','\nset logscale xy\nset grid\nset key below\n"
                    "set xlabel 'h [s]'\nset ylabel '%s'\nset title 'error against the time step'\n",
                    C->name[metric_col], ylab);
        else
          sb_printf(&gp, "# work-precision: %s against the median step time (setup and output left out),\n"
                    "# one line per back end, each point labelled with its h; the reference slopes are\n"
                    "# orders 1 and 2 (the step time goes as 1/h)\n"
                    "set datafile separator ','\nset logscale xy\nset grid\nset key below\n"
                    "set xlabel 't_steps [s] (median of the repeats)'\nset ylabel '%s'\n"
                    "set title 'error against run time'\n",
                    C->name[metric_col], ylab);
        for (k = 0; k < 2; k++) {
          set_terminal(&gp, fig, k);
          sb_printf(&gp, "plot ");
          first = 1;
          for (i = 0; i < nsol; i++) {
            char nm[128], f[1400];
            slug(rows[i * ndt * ngrid].solver, nm, sizeof nm);
            snprintf(f, sizeof f, "%s/plots/work-precision-%s.csv", dir, nm);
            if (access(f, R_OK)) continue;
            sb_printf(&gp, "%s'work-precision-%s.csv' using %s:2 with linespoints lw 2 dt %d pt %d ps 1.5 lc rgb '%s' "
                      "title '%s'", first ? "" : ", ", nm, j ? "3" : "1", i + 1, 4 + 2 * (i % 6), colour(i),
                      rows[i * ndt * ngrid].solver);
            if (!j)
              sb_printf(&gp, ", 'work-precision-%s.csv' using 1:2:(sprintf('h=%%g', $3)) with labels offset char 1,%d "
                        "font ',8' notitle", nm, 1 - i);
            first = 0;
          }
          if (!first && !isnan(e0)) {
            if (j)
              sb_printf(&gp, ", %.6g * (x / %.6g) with lines lc rgb 'gray40' dt 3 title 'order 1', "
                        "%.6g * (x / %.6g)**2 with lines lc rgb 'gray20' dt 4 title 'order 2'", e0, h0, e0, h0);
            else
              sb_printf(&gp, ", %.6g * (x / %.6g)**-1 with lines lc rgb 'gray40' dt 3 title 'order 1', "
                        "%.6g * (x / %.6g)**-2 with lines lc rgb 'gray20' dt 4 title 'order 2'", e0, t0, e0, t0);
          }
          if (!j) peers_plot(&gp, rows + nown, nrun - nown, metric_col, dir, ctx);
          if (first) sb_printf(&gp, "NaN notitle");
          sb_printf(&gp, "\n");
        }
        rendered += render(dir, fig, &gp, ctx);
        free(gp.s);
        nfig++;
      }
    }
    /* 3. histories of each back end (its run with the smallest dt at the first grid point),
          with the closed form where the case has one, and 4. the energy; the probes are those
          of the first run's history. Each history's header is read once. */
    {
      /* probe quantities (the first probe of each), then rigid bodies' columns (BODY.x ... BODY.vx
         ..., the first body of each that has an exact value) */
      static const char *quant[] = {"ux", "vx", "uy", "vy", "uz", "vz", "cx", "cy", "cz", "pn",
                                    "x", "y", "z", "vx", "vy", "vz", "omega"};
      static const char *qlabel[] = {"u_x [m]", "v_x [m/s]", "u_y [m]", "v_y [m/s]", "u_z [m]", "v_z [m/s]",
                                     "contact force F_x [N]", "contact force F_y [N]", "contact force F_z [N]",
                                     "contact pressure sigma_n [Pa]", "x [m]", "y [m]", "z [m]", "v_x [m/s]",
                                     "v_y [m/s]", "v_z [m/s]", "omega [rad/s]"};
      const size_t nprobeq = 10;
      size_t qk;
      int *best = mo_malloc(ctx, (size_t)nsol * sizeof *best);
      long *nlines = mo_malloc(ctx, (size_t)nsol * sizeof *nlines);
      char *head = mo_malloc(ctx, ((size_t)nsol + 1) * HEADER_MAX), *first_head;
      if (!best || !head || !nlines) {
        mo_free(best);
        mo_free(head);
        mo_free(nlines);
        st = MO_ENOMEM;
        goto done;
      }
      for (i = 0; i < nsol; i++) {
        best[i] = finest_run(rows, nown, ngrid, rows[i * ndt * ngrid].solver);
        nlines[i] = 0;
        if (best[i] >= 0) {
          FILE *f;
          history_header(rows[best[i]].outdir, head + (size_t)i * HEADER_MAX, HEADER_MAX);
          snprintf(path, sizeof path, "%s/history.csv", rows[best[i]].outdir);
          if ((f = fopen(path, "r"))) {
            int ch;
            while ((ch = getc(f)) != EOF) nlines[i] += ch == '\n';
            fclose(f);
          }
        } else
          head[(size_t)i * HEADER_MAX] = '\0';
      }
      first_head = head + (size_t)nsol * HEADER_MAX;
      history_header(rows[0].outdir, first_head, HEADER_MAX);
      for (qk = 0; first_head[0] && qk < sizeof quant / sizeof quant[0]; qk++) {
        /* the first probe with this quantity in the first run's history */
        char line[HEADER_MAX], *tok, *save = NULL, probe[128] = "";
        snprintf(line, sizeof line, "%s", first_head);
        for (tok = strtok_r(line, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
          size_t l = strlen(tok), lq = strlen(quant[qk]);
          if (l > lq + 1 && !strcmp(tok + l - lq, quant[qk]) && tok[l - lq - 1] == '.' && !strstr(tok, ".exact") &&
              strncmp(tok, "energy.", 7) && strncmp(tok, "contact.", 8) && strncmp(tok, "rigid.", 6)) {
            char ex[160], om[160], wz[160];
            int rigid;
            /* a rigid body's columns: BODY.x .. BODY.omega (or .wz) */
            snprintf(ex, sizeof ex, "%s.exact", tok);
            snprintf(om, sizeof om, "%.*s.omega", (int)(l - lq - 1), tok);
            snprintf(wz, sizeof wz, "%.*s.wz", (int)(l - lq - 1), tok);
            rigid = csv_column(first_head, om) || csv_column(first_head, wz);
            if (qk < nprobeq ? rigid : !rigid || !csv_column(first_head, ex)) continue;
            snprintf(probe, sizeof probe, "%s", tok);
            break;
          }
        }
        if (!probe[0]) continue;
        {
          sbuf gp = {NULL, 0, 0, 0};
          char nm[200], ex[160], fig[220];
          int first = 1, any_exact = 0;
          slug(probe, nm, sizeof nm);
          snprintf(fig, sizeof fig, "history-%s", nm);
          snprintf(ex, sizeof ex, "%s.exact", probe);
          for (i = 0; i < nsol; i++) any_exact |= best[i] >= 0 && csv_column(head + (size_t)i * HEADER_MAX, ex);
          sb_printf(&gp, "# history of %s: each back end at its smallest time step%s\n"
                    "set datafile separator ','\nset key outside right\nset grid\n"
                    "set xlabel 't [s]'\nset ylabel '%s'\nset title '%s'\n", probe,
                    any_exact ? ", and the closed form" : " (the case has no closed form)", qlabel[qk], probe);
          for (k = 0; k < 2; k++) {
            int drawn_exact = 0, exact_run = 0, exact_col = 0;
            set_terminal(&gp, fig, k);
            sb_printf(&gp, "plot ");
            first = 1;
            for (i = 0; i < nsol; i++) {
              int rb = best[i], cu, ce;
              const char *h = head + (size_t)i * HEADER_MAX;
              long pi = nlines[i] / 12 > 1 ? nlines[i] / 12 : 1;
              if (rb < 0 || !(cu = csv_column(h, probe))) continue;
              sb_printf(&gp, "%s'../runs/%s/history.csv' using 1:%d with linespoints lw 2 dt %d pt %d pi %ld "
                        "lc rgb '%s' title '%s (h = %g)'", first ? "" : ", ", rows[rb].label, cu, i + 1, 4 + 2 * (i % 6),
                        pi + i, colour(i), rows[rb].solver, rows[rb].dt);
              first = 0;
              ce = csv_column(h, ex);
              if (ce && !drawn_exact) {
                exact_run = rb;
                exact_col = ce;
                drawn_exact = 1;
              }
            }
            /* the closed form last, in black, under the back ends' curves in the key */
            if (drawn_exact)
              sb_printf(&gp, ", '../runs/%s/history.csv' using 1:%d with lines lw 1 lc rgb 'black' title 'closed form'",
                        rows[exact_run].label, exact_col);
            sb_printf(&gp, "\n");
          }
          if (!first) {
            rendered += render(dir, fig, &gp, ctx);
            nfig++;
          }
          free(gp.s);
        }
      }
      /* energy */
      {
        sbuf gp = {NULL, 0, 0, 0};
        int first = 1;
        sb_printf(&gp, "# energy ratio E(t)/E0 of each back end at its smallest time step\n"
                  "set datafile separator ','\nset key outside right\nset grid\nset xlabel 't [s]'\n"
                  "set ylabel 'E(t) / E_0 [-]'\nset title 'energy'\n");
        for (k = 0; k < 2; k++) {
          set_terminal(&gp, "energy", k);
          sb_printf(&gp, "plot ");
          first = 1;
          for (i = 0; i < nsol; i++) {
            int rb = best[i], ce;
            long pi = nlines[i] / 12 > 1 ? nlines[i] / 12 : 1;
            if (rb < 0 || !(ce = csv_column(head + (size_t)i * HEADER_MAX, "energy.ratio"))) continue;
            sb_printf(&gp, "%s'../runs/%s/history.csv' using 1:%d with linespoints lw 2 dt %d pt %d pi %ld lc rgb '%s' "
                      "title '%s (h = %g)'", first ? "" : ", ", rows[rb].label, ce, i + 1, 4 + 2 * (i % 6), pi + i, colour(i),
                      rows[rb].solver, rows[rb].dt);
            first = 0;
          }
          sb_printf(&gp, "\n");
        }
        if (!first) {
          rendered += render(dir, "energy", &gp, ctx);
          nfig++;
        }
        free(gp.s);
      }
      mo_free(best);
      mo_free(head);
      mo_free(nlines);
    }
    /* 5. stability map per back end: a grid picture, one colour per class (T97); axes the first
          two varied keys, or the varied key and the time step */
    if (opt->nvary >= 1) {
      static const char *cname[] = {"stable", "unstable", "failed", "chatter"};
      static const char *ccol[] = {"#2a9d2a", "#e69500", "#d62728", "#1f5fbf"};
      int ydt = opt->nvary == 1 && ndt > 1;
      for (i = 0; i < nsol; i++) {
        sbuf gp = {NULL, 0, 0, 0}, dat = {NULL, 0, 0, 0};
        char nm[128], fig[200];
        int two = opt->nvary >= 2, cls, c, ndup = 0;
        slug(rows[i * ndt * ngrid].solver, nm, sizeof nm);
        snprintf(fig, sizeof fig, "stability-%s", nm);
        for (r = 0; r < nown; r++) {
          char xs[32], ys[32];
          if (strcmp(rows[r].solver, rows[i * ndt * ngrid].solver)) continue;
          cls = !strcmp(rows[r].cls, "stable") ? 0 : !strcmp(rows[r].cls, "unstable") ? 1 : !strcmp(rows[r].cls, "chatter") ? 3 : 2;
          axis_coord(&opt->vary[0], rows[r].vary[0], xs, sizeof xs);
          if (two) axis_coord(&opt->vary[1], rows[r].vary[1], ys, sizeof ys);
          else if (ydt) snprintf(ys, sizeof ys, "%.6g", rows[r].dt);
          else snprintf(ys, sizeof ys, "0");
          /* the fifth column marks a cell that shares another's run (a key its back end ignores) */
          sb_printf(&dat, "%s,%s,%d,%.6g,%d\n", xs, ys, cls, rows[r].dt, rows[r].dup_of >= 0);
          ndup += rows[r].dup_of >= 0;
        }
        snprintf(path, sizeof path, "%s/plots/stability-%s.csv", dir, nm);
        if (dat.s) write_text(path, dat.s, ctx);
        free(dat.s);
        sb_printf(&gp, "# stability map of %s: one square per cell, green stable, blue chatter, orange unstable,\n"
                  "# red failed; an open square shares the run of its row's first value (a key %s ignores)\n"
                  "set datafile separator ','\nset grid front\nset xlabel '%s'\nset ylabel '%s'\n"
                  "set title 'stability: %s'\nset key outside right\n",
                  rows[i * ndt * ngrid].solver, rows[i * ndt * ngrid].solver, opt->vary[0].key,
                  two ? opt->vary[1].key : ydt ? "h [s]" : "", rows[i * ndt * ngrid].solver);
        axis_setup(&gp, &opt->vary[0], 'x');
        if (two) axis_setup(&gp, &opt->vary[1], 'y');
        else if (ydt) {
          double lo = HUGE_VAL, hi = 0;
          for (k = 0; k < ndt; k++) {
            if (dts[k] < lo) lo = dts[k];
            if (dts[k] > hi) hi = dts[k];
          }
          sb_printf(&gp, "set logscale y\nset yrange [%.6g:%.6g]\nset ytics (", lo / 1.6, hi * 1.6);
          for (k = 0; k < ndt; k++) sb_printf(&gp, "%s'%g' %.6g", k ? ", " : "", dts[k], dts[k]);
          sb_printf(&gp, ")\n");
        }
        else sb_printf(&gp, "unset ytics\n");
        sb_printf(&gp, ydt ? "set offsets graph 0.08, graph 0.08, 0, 0\n" : "set offsets graph 0.08, graph 0.08, graph 0.1, graph 0.1\n");
        {
          /* the critical step of central differences (T102) as a line across a dt axis */
          double dtc = NAN, lo, hi;
          int ax;
          for (r = 0; r < nrun; r++)
            if (!strcmp(rows[r].solver, rows[i * ndt * ngrid].solver) && isfinite(rows[r].dt_crit) &&
                !(rows[r].dt_crit >= dtc)) dtc = rows[r].dt_crit;
          for (ax = 0; ax < (two ? 2 : 1) && isfinite(dtc); ax++)
            if (!strcmp(opt->vary[ax].key, "time.dt") && vary_numeric(&opt->vary[ax], &lo, &hi)) {
              if (ax == 0)
                sb_printf(&gp, "set arrow from %.6g, graph 0 to %.6g, graph 1 nohead dt 2 lw 2 lc rgb 'black'\n"
                          "set label 'dt_crit' at %.6g, graph 1 offset 0.5, -1 left\n", dtc, dtc, dtc);
              else
                sb_printf(&gp, "set arrow from graph 0, first %.6g to graph 1, first %.6g nohead dt 2 lw 2 lc rgb 'black'\n"
                          "set label 'dt_crit' at graph 0, first %.6g offset 1, 0.6 left\n", dtc, dtc, dtc);
            }
        }
        for (j = 0; j < 2; j++) {
          set_terminal(&gp, fig, j);
          sb_printf(&gp, "plot ");
          for (c = 0; c < 4; c++)
            sb_printf(&gp, "%s'stability-%s.csv' using 1:($3==%d && $5==0?$2:1/0) with points pt 5 ps 4 lc rgb '%s' title '%s'",
                      c ? ", " : "", nm, c, ccol[c], cname[c]);
          if (ndup) {
            for (c = 0; c < 4; c++)
              sb_printf(&gp, ", 'stability-%s.csv' using 1:($3==%d && $5==1?$2:1/0) with points pt 4 ps 4 lw 2 lc rgb '%s' "
                        "notitle", nm, c, ccol[c]);
            sb_printf(&gp, ", NaN with points pt 4 ps 2 lw 2 lc rgb 'black' title 'same run (key ignored)'");
          }
          sb_printf(&gp, "\n");
        }
        rendered += render(dir, fig, &gp, ctx);
        free(gp.s);
        nfig++;
      }
    }
    res->nfigures = nfig;
    res->rendered = rendered;
  }

  /* report.md: only what the runs measured */
  b.n = 0;
  sb_printf(&b, "# moreau compare: %s\n\n", opt->case_path);
  sb_printf(&b, "%d runs: %d stable, %d chatter, %d unstable, %d failed. Every run's outputs are under `runs/`; "
            "all metrics are in `compare.csv`%s; observed orders in `orders.csv`; figures in `plots/` (gnuplot "
            "scripts kept).\n\n",
            res->nrun, res->nstable, res->nchatter, res->nunstable, res->nfailed,
            opt->nvary ? ", the classification in `stability.csv`" : "");
  sb_printf(&b, "Classes (doc/theory.md (T51), (T97)): *failed*, the run stopped on an error; *unstable*, the "
            "energy grew by more than 1 %% or the penetration exceeded %g of the smallest element (beyond what a "
            "velocity-level landing leaves); *chatter*, between two bearing steps the normal velocity reached "
            "%g of the impact velocity, or it changed sign %d times (not judged for pairs with Newton's restitution "
            "e > 0); *stable*, none of these. Each run's reason gives the measures.\n\n",
            opt->penetration_tol > 0 ? opt->penetration_tol : 0.01, MO_CHATTER_VN_REL, MO_CHATTER_SIGN_CHANGES);
  if (res->nmarked) {
    sb_printf(&b, "%d grid cells were not run: their back end ignores the varied key", res->nmarked);
    for (k = 0; k < opt->nvary; k++) {
      int any = 0;
      for (r = 0; r < nown; r++) any |= (rows[r].ignored >> k) & 1;
      if (any) {
        sb_printf(&b, " `%s` (", opt->vary[k].key);
        for (i = 0, j = 0; i < nsol; i++)
          if (solver_ignores(rows[i * ndt * ngrid].solver, opt->vary[k].key, ctx))
            sb_printf(&b, "%s%s", j++ ? ", " : "", rows[i * ndt * ngrid].solver);
        sb_printf(&b, ")");
      }
    }
    sb_printf(&b, "; each shares the run of the key's first value, its column reads `ignored` in `compare.csv`, "
              "and the stability maps draw it as an open square.\n\n");
  }
  {
    /* varying theta alone leaves theta_f where the case puts it: a mixed scheme unless both vary */
    int vt = -1, vtf = -1;
    for (k = 0; k < opt->nvary; k++) {
      if (!strcmp(opt->vary[k].key, "time.theta")) vt = k;
      if (!strcmp(opt->vary[k].key, "time.theta_f")) vtf = k;
    }
    for (k = 0; k < opt->nset; k++)
      if (!strncmp(opt->sets[k], "time.theta_f=", 13)) vtf = 99;
    if (vt >= 0 && vtf < 0) {
      double thf = NAN;
      for (r = 0; r < nown && isnan(thf); r++) {
        json_t *root;
        json_error_t err;
        if (rows[r].dup_of >= 0 || !rows[r].outdir[0]) continue;
        snprintf(path, sizeof path, "%s/summary.json", rows[r].outdir);
        if ((root = json_load_file(path, 0, &err))) {
          json_t *v = json_object_get(json_object_get(root, "time"), "theta_f");
          if (json_is_number(v)) thf = json_number_value(v);
          json_decref(root);
        }
      }
      sb_printf(&b, "`time.theta` varies alone: `time.theta_f` stays at the case's value (%g) in every run, so a "
                "run with theta != %g is a mixed scheme (doc/theory.md (T1)), not the theta-method with theta_f = theta; "
                "vary `time.theta_f` too (or `--set time.theta_f=...`) for that.\n\n", thf, thf);
    }
  }
  {
    double tmn = HUGE_VAL, tmx = 0;
    int nr = 0;
    for (r = 0; r < nown; r++)
      if (rows[r].dup_of < 0 && rows[r].nrep) {
        if (rows[r].nrep < tmn) tmn = rows[r].nrep;
        if (rows[r].nrep > tmx) tmx = rows[r].nrep;
        nr++;
      }
    if (nr)
      sb_printf(&b, "Times (doc/theory.md (T99)): `t_steps` is the time of the steps alone (setup, the initial state and "
                "every output left out: `time.setup_s` and `time.output_s` in `compare.csv`), the median of %g to %g "
                "runs of each cell (%s), with its min and max in `compare.csv`.\n\n", tmn, tmx,
                opt->repeat > 0 ? "--repeat" : "repeated until the median moved by less than 5 %, at most 5 runs "
                "or 5 s of runs");
  }
  if (metric_col >= 0) {
    if (strncmp(C->name[metric_col], "ref.", 4))
      sb_printf(&b, "Error: `%s`, against the case's closed form.\n\n", C->name[metric_col]);
    else
      sb_printf(&b, "Error: `%s`, the relative L2 distance over the run's history rows to the run with the smallest "
                "time step of the same back end and grid point (`ref.dt`; the case has no closed form for it, "
                "doc/theory.md (T98)).\n\n", C->name[metric_col]);
  }
  {
    /* the chosen error, then the measures the seeds' comparisons turn on (doc/theory.md §10),
       those the runs have */
    static const char *key[] = {"contact.oscillation_index", "contact.max_vn_in_contact",
                                "contact.impulse_error", "contact.release_time_error",
                                "energy.ratio_mechanical", "contact.iterations_mean"};
    static const char *head[] = {"osc. index", "max vn in contact", "impulse err.", "release err.",
                                 "E(T)/E_ref", "iter./step"};
    int show[8 + MAX_COLS], ns = 0, kk, jj;
    if (metric_col >= 0) show[ns++] = metric_col;
    for (kk = 0; kk < (int)(sizeof key / sizeof key[0]); kk++) {
      int c = -1, any = 0;
      for (jj = 0; jj < C->n; jj++)
        if (!strcmp(C->name[jj], key[kk])) c = jj;
      if (c < 0 || c == metric_col) continue;
      for (r = 0; r < nrun; r++) any |= rows[r].dup_of < 0 && !isnan(rows[r].val[c]);
      if (any) show[ns++] = c;
    }
    /* then the columns the case asks for (output.report), those not shown already */
    for (kk = 0; kk < H->n; kk++) {
      int c = -1, seen = 0;
      for (jj = 0; jj < C->n; jj++)
        if (!strcmp(C->name[jj], H->name[kk])) c = jj;
      for (jj = 0; jj < ns; jj++) seen |= show[jj] == c;
      if (c >= 0 && !seen) show[ns++] = c;
    }
    sb_printf(&b, "| run | solver | dt | t_steps (s) | steps | class |");
    for (jj = 0; jj < ns; jj++) {
      const char *h = C->name[show[jj]];
      for (kk = 0; kk < (int)(sizeof key / sizeof key[0]); kk++)
        if (!strcmp(h, key[kk])) h = head[kk];
      sb_printf(&b, " %s |", h);
    }
    sb_printf(&b, "\n| --- | --- | --- | --- | --- | --- |");
    for (jj = 0; jj < ns; jj++) sb_printf(&b, " --- |");
    sb_printf(&b, "\n");
    for (r = 0; r < nrun; r++) {
      run_row *R = &rows[r];
      if (R->dup_of >= 0) continue;
      sb_printf(&b, "| %s | %s | %g |", R->label, R->solver, R->dt);
      if (R->nrep) sb_printf(&b, " %.3g (%.3g-%.3g, %d runs) |", R->tmed, R->tmin, R->tmax, R->nrep);
      else if (r >= nown && R->wall > 0) sb_printf(&b, " %.3f (peer's wall) |", R->wall);
      else sb_printf(&b, " - |");
      {
        /* a bar inside a table cell is escaped */
        char why[1100];
        size_t q, w = 0;
        for (q = 0; R->why[q] && w + 2 < sizeof why; q++) {
          if (R->why[q] == '|') why[w++] = '\\';
          why[w++] = R->why[q];
        }
        why[w] = '\0';
        sb_printf(&b, " %ld | %s%s%s |", R->steps, R->cls, why[0] ? ": " : "", why);
      }
      for (jj = 0; jj < ns; jj++) {
        if (isnan(R->val[show[jj]])) sb_printf(&b, " |");
        else sb_printf(&b, " %.4g |", R->val[show[jj]]);
      }
      sb_printf(&b, "\n");
    }
  }
  sb_printf(&b, "\n");
  for (r = 0; r < nrun; r++)
    if (rows[r].dup_of < 0 && rows[r].status) sb_printf(&b, "- `%s` failed: %s\n", rows[r].label, rows[r].reason);
  if (nrun > nown) {
    sb_printf(&b, "\nRows marked (external) are %d rows of", nrun - nown);
    for (k = 0; k < opt->npeer; k++) sb_printf(&b, "%s `%s`", k ? (k == opt->npeer - 1 ? " and" : ",") : "", opt->peers[k]);
    sb_printf(&b, " (--peer): measured by another program with its own clock, not run here and not in "
              "`compare.csv`; dashed lines in the work-precision figure.\n");
  }
  /* observed orders: the finest triple of each back end, grid point and quantity */
  if (O.n) {
    sb_printf(&b, "\n## Observed order of convergence in h (Richardson, doc/theory.md (T98))\n\n"
              "From three successive steps h1 > h2 > h3 of one back end: the distances d12 = |y(h1) - y(h2)| and "
              "d23 = |y(h2) - y(h3)| (relative L2 over the coarsest run's history rows) give p with "
              "(h1^p - h2^p) / (h2^p - h3^p) = d12 / d23; no closed form is used. The finest triple of each "
              "quantity (every triple in `orders.csv`); an order holds only where the solution is smooth in time "
              "over the run (no impact, release or chatter inside it).\n\n"
              "| solver | grid point | quantity | h1, h2, h3 | d12 | d23 | order |\n| --- | --- | --- | --- | --- | --- | --- |\n");
    for (k = 0; k < O.n; k++) {
      const order_rec *o = &O.o[k];
      const run_row *R = &rows[o->row];
      int later = 0;
      for (j = k + 1; j < O.n; j++)
        later |= !strcmp(O.o[j].metric, o->metric) && !strcmp(rows[O.o[j].row].solver, R->solver) &&
                 (O.o[j].row % ngrid) == (o->row % ngrid);
      if (later) continue;
      sb_printf(&b, "| %s | ", R->solver);
      for (j = 0; j < opt->nvary; j++)
        sb_printf(&b, "%s%s=%s", j ? ", " : "", opt->vary[j].key, R->ignored & 1u << j ? "ignored" : R->vary[j]);
      if (!opt->nvary) sb_printf(&b, "-");
      sb_printf(&b, " | %s | %g, %g, %g | %.3g | %.3g | ", o->metric, o->h[0], o->h[1], o->h[2], o->d12, o->d23);
      if (o->d23 < 1e-11 || o->d12 < 1e-11) sb_printf(&b, "none (equal to round-off: no time error to measure) |\n");
      else if (isnan(o->p)) sb_printf(&b, "none (the distances do not shrink) |\n");
      else sb_printf(&b, "%.2f |\n", o->p);
    }
  }
  sb_printf(&b, "\n## Figures\n\n");
  if (metric_col >= 0)
    sb_printf(&b, "![work-precision](plots/work-precision.png)\n\n![convergence](plots/convergence.png)\n\n");
  sb_printf(&b, "Histories of each back end at its smallest step (with the closed form where the case has one): "
            "`plots/history-*.png`; energy: `plots/energy.png`%s.\n",
            opt->nvary ? "; stability maps: `plots/stability-*.png`" : "");
  snprintf(path, sizeof path, "%s/report.md", dir);
  if (!b.err) st = write_text(path, b.s, ctx);
  if (!st && stop) st = mo_error(ctx, stop, "%s", stopmsg);
done:
  free(b.s);
  mo_free(rows);
  mo_free(C);
  peers_free(&P);
  mo_free(O.o);
  mo_free(H);
  mo_free(sets);
  return st;
}
