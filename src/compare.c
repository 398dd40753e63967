/* compare.c: `moreau compare`: the same scene by several back ends, time steps and parameter
   grids; compare.csv, stability.csv, report.md and gnuplot figures (doc/theory.md §10). */
#include "config.h"
#include <moreau/compare.h>
#include <moreau/output.h>
#include <moreau/run.h>

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
  char cls[32];              /* stable, unstable, failure */
  char why[256];
  double wall;
  long steps;
  double val[MAX_COLS];      /* flattened metrics, NaN when absent */
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
  snprintf(path, sizeof path, "%s/summary.json", r->outdir);
  root = json_load_file(path, 0, &err);
  if (!root) return;
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
    /* velocity-level Signorini never corrects a position: a theta-scheme landing step ends at
       g_k + h (1 - theta) U-_n with U+_n = 0, a penetration of order h that refinement removes,
       not an instability */
    json_t *tm = json_object_get(root, "time");
    json_t *sig = json_object_get(json_object_get(json_object_get(root, "settings"), "contact"), "signorini");
    json_t *vs = json_object_get(json_object_get(json_object_get(root, "metrics"), "contact"), "velocity_scale");
    const char *scheme = json_string_value(json_object_get(tm, "scheme"));
    if (scheme && !strcmp(scheme, "theta") && json_is_string(sig) && !strcmp(json_string_value(sig), "velocity") &&
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
      snprintf(r->cls, sizeof r->cls, "failure");
      snprintf(r->why, sizeof r->why, "%s", why);
    }
    return;
  }
  {
    double growth = colval(r, C, "energy.max_growth"), pen = colval(r, C, "contact.max_penetration");
    double hmin = colval(r, C, "scene.hmin");
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
    } else {
      snprintf(r->cls, sizeof r->cls, "stable");
      r->why[0] = '\0';
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
    if (l > 9 && (!strcmp(C->name[k] + l - 9, ".x.l2_rel") || !strcmp(C->name[k] + l - 9, ".y.l2_rel") ||
                  !strcmp(C->name[k] + l - 9, ".z.l2_rel")))
      return k;
  }
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

/* Axes of a stability map. A numeric parameter spanning two decades or more (positive) gets a
   log axis; a parameter with a non-numeric value (a scheme name, say) is plotted at the index
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
    if (lo > 0 && hi >= 100 * lo) sb_printf(gp, "set logscale %c\nset format %c '%%.0e'\n", axis, axis);
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
    R->outdir[0] = '\0';
    if (R->status) {
      snprintf(R->cls, sizeof R->cls, "failure");
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

int mo_compare(const mo_compare_options *opt, mo_compare_result *res, mo_ctx *ctx)
{
  int nsol = opt->nsolver ? opt->nsolver : 1, ndt = opt->ndt ? opt->ndt : 1, ngrid = 1, i, j, k, st = MO_OK;
  int nrun, r, metric_col, nown, stop;
  run_row *rows = NULL;
  colset *C = NULL, *H = NULL;
  const char **sets = NULL;
  peer_set P;
  char dir[1024], path[1400], stopmsg[MO_ERRMSG_MAX];
  sbuf b = {NULL, 0, 0, 0};
  for (k = 0; k < opt->nvary; k++) ngrid *= opt->vary[k].nval;
  nrun = nsol * ndt * ngrid;
  memset(res, 0, sizeof *res);
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

  /* run every (solver, dt, grid point) */
  for (r = 0; r < nrun; r++) {
    run_row *R = &rows[r];
    int si = r / (ndt * ngrid), di = (r / ngrid) % ndt, gi = r % ngrid, g = gi, nset = 0;
    char dtset[64], varyset[MO_COMPARE_MAX_VARY][512], lab[512];
    mo_run_options ro;
    mo_run_result rr;
    mo_ctx rc;
    for (k = 0; k < opt->nset; k++) sets[nset++] = opt->sets[k];
    snprintf(R->solver, sizeof R->solver, "%s", opt->nsolver ? opt->solvers[si] : "case");
    R->dt = opt->ndt ? opt->dt[di] : NAN;
    if (opt->ndt) {
      snprintf(dtset, sizeof dtset, "time.dt=%.17g", opt->dt[di]);
      sets[nset++] = dtset;
    }
    snprintf(lab, sizeof lab, "%s", R->solver);
    if (opt->ndt) snprintf(lab + strlen(lab), sizeof lab - strlen(lab), "-dt%g", R->dt);
    for (k = opt->nvary - 1; k >= 0; k--) { /* the last key varies fastest */
      int vi = g % opt->vary[k].nval;
      g /= opt->vary[k].nval;
      snprintf(R->vary[k], sizeof R->vary[k], "%s", opt->vary[k].val[vi]);
      snprintf(varyset[k], sizeof varyset[k], "%s=%s", opt->vary[k].key, opt->vary[k].val[vi]);
    }
    for (k = 0; k < opt->nvary; k++) {
      const char *dot = strrchr(opt->vary[k].key, '.');
      sets[nset++] = varyset[k];
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
    mo_ctx_init(&rc);
    rc.verbosity = 0;
    rc.interrupt = ctx->interrupt;
    R->status = mo_run(&ro, &rr, &rc);
    R->wall = rr.wall;
    R->steps = rr.steps;
    if (R->status && snprintf(R->reason, sizeof R->reason, "%s", rc.errmsg) >= (int)sizeof R->reason)
      R->reason[sizeof R->reason - 1] = '\0';
    read_summary(R, C, H);
    classify(R, C, opt->penetration_tol > 0 ? opt->penetration_tol : 0.01);
    if (ctx->verbosity >= 1)
      fprintf(stderr, "[%d/%d] %-40s %8.3f s  %s%s%s\n", r + 1, nrun, R->label, R->wall, R->cls,
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
  res->nrun = nrun;
  for (r = 0; r < nrun; r++) {
    if (!strcmp(rows[r].cls, "stable")) res->nstable++;
    else if (!strcmp(rows[r].cls, "unstable")) res->nunstable++;
    else res->nfailed++;
  }

  /* compare.csv */
  sb_printf(&b, "solver,dt");
  for (k = 0; k < opt->nvary; k++) sb_printf(&b, ",%s", opt->vary[k].key);
  sb_printf(&b, ",wall_s,steps,status,class,reason");
  for (k = 0; k < C->n; k++) sb_printf(&b, ",%s", C->name[k]);
  sb_printf(&b, "\n");
  for (r = 0; r < nrun; r++) {
    run_row *R = &rows[r];
    char why[600];
    size_t q;
    snprintf(why, sizeof why, "%s%s%s", R->why, R->status && R->why[0] ? ": " : "", R->status ? R->reason : "");
    for (q = 0; why[q]; q++) if (why[q] == ',' || why[q] == '\n' || why[q] == '"') why[q] = ';';
    sb_printf(&b, "%s,%.10g", R->solver, R->dt);
    for (k = 0; k < opt->nvary; k++) csv_field(&b, R->vary[k]);
    sb_printf(&b, ",%.6g,%ld,%s,%s,%s", R->wall, R->steps, R->status ? "failed" : "complete", R->cls, why);
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
      snprintf(why, sizeof why, "%s", R->why);
      for (q = 0; why[q]; q++) if (why[q] == ',' || why[q] == '\n') why[q] = ';';
      sb_printf(&b, "%s,%.10g", R->solver, R->dt);
      for (k = 0; k < opt->nvary; k++) csv_field(&b, R->vary[k]);
      sb_printf(&b, ",%s,%s,%.6g,%.6g,%.6g\n", R->cls, why, colval(R, C, "energy.max_growth"),
                colval(R, C, "contact.max_penetration"), R->wall);
    }
    if ((st = write_text(path, b.s, ctx))) goto done;
  }

  /* the peers' rows follow the runs' (every loop below takes them; the figures' per-solver
     loops draw the runs' back ends, peers_plot the peers) */
  nown = nrun;
  res->npeer = peers_merge(&P, C, rows + nrun, opt->penetration_tol > 0 ? opt->penetration_tol : 0.01);
  nrun += res->npeer;

  /* figures: data files and gnuplot scripts (kept so that users restyle them) */
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
    /* 1. error against run time, one line per back end */
    if (metric_col >= 0) {
      sbuf gp = {NULL, 0, 0, 0};
      sb_printf(&gp, "# work-precision: %s against wall time, one line per back end\n"
                "set datafile separator ','\nset logscale xy\nset grid\nset key below\n"
                "set xlabel 'wall time (s)'\nset ylabel '%s'\nset title 'error against run time'\n",
                C->name[metric_col], C->name[metric_col]);
      for (i = 0; i < nsol; i++) {
        char f[1400], nm[128];
        sbuf dat = {NULL, 0, 0, 0};
        slug(rows[i * ndt * ngrid].solver, nm, sizeof nm);
        for (r = 0; r < nrun; r++)
          if (!strcmp(rows[r].solver, rows[i * ndt * ngrid].solver) && !rows[r].status && !isnan(rows[r].val[metric_col]) &&
              rows[r].val[metric_col] > 0)
            sb_printf(&dat, "%.6g,%.6g,%.6g\n", rows[r].wall, rows[r].val[metric_col], rows[r].dt);
        snprintf(f, sizeof f, "%s/plots/work-precision-%s.csv", dir, nm);
        if (dat.s) write_text(f, dat.s, ctx);
        free(dat.s);
      }
      set_terminal(&gp, "work-precision", 0);
      sb_printf(&gp, "plot ");
      for (i = 0; i < nsol; i++) {
        char nm[128];
        slug(rows[i * ndt * ngrid].solver, nm, sizeof nm);
        sb_printf(&gp, "%s'work-precision-%s.csv' using 1:2 with linespoints lw 2 title '%s'", i ? ", " : "", nm,
                  rows[i * ndt * ngrid].solver);
      }
      peers_plot(&gp, rows + nown, nrun - nown, metric_col, dir, ctx);
      sb_printf(&gp, "\n");
      set_terminal(&gp, "work-precision", 1);
      sb_printf(&gp, "replot\n");
      rendered += render(dir, "work-precision", &gp, ctx);
      free(gp.s);
      nfig++;
    }
    /* 2. histories of each back end (its run with the smallest dt at the first grid point)
          against the exact solution, and 3. the energy; the probes are those of the first
          run's history. Each history's header is read once. */
    {
      /* probe quantities (the first probe of each), then rigid bodies' columns (BODY.x ... BODY.vx
         ..., the first body of each that has an exact value) */
      static const char *quant[] = {"ux", "vx", "uy", "vy", "uz", "vz", "cx", "cy", "cz", "pn",
                                    "x", "y", "z", "vx", "vy", "vz", "omega"};
      const size_t nprobeq = 10;
      size_t qk;
      int *best = mo_malloc(ctx, (size_t)nsol * sizeof *best);
      char *head = mo_malloc(ctx, ((size_t)nsol + 1) * HEADER_MAX), *first_head;
      if (!best || !head) {
        mo_free(best);
        mo_free(head);
        st = MO_ENOMEM;
        goto done;
      }
      for (i = 0; i < nsol; i++) {
        best[i] = finest_run(rows, nown, ngrid, rows[i * ndt * ngrid].solver);
        if (best[i] >= 0) history_header(rows[best[i]].outdir, head + (size_t)i * HEADER_MAX, HEADER_MAX);
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
          int first = 1;
          slug(probe, nm, sizeof nm);
          snprintf(fig, sizeof fig, "history-%s", nm);
          snprintf(ex, sizeof ex, "%s.exact", probe);
          sb_printf(&gp, "# history of %s: each back end at its smallest time step, and the exact solution\n"
                    "set datafile separator ','\nset key autotitle columnhead outside right\nset grid\n"
                    "set xlabel 't (s)'\nset ylabel '%s'\nset title '%s'\n", probe, probe, probe);
          set_terminal(&gp, fig, 0);
          sb_printf(&gp, "plot ");
          for (i = 0; i < nsol; i++) {
            int rb = best[i], cu, ce;
            const char *h = head + (size_t)i * HEADER_MAX;
            if (rb < 0 || !(cu = csv_column(h, probe))) continue;
            sb_printf(&gp, "%s'../runs/%s/history.csv' using 1:%d with lines lw 2 title '%s (h = %g)'", first ? "" : ", ",
                      rows[rb].label, cu, rows[rb].solver, rows[rb].dt);
            first = 0;
            ce = csv_column(h, ex);
            if (ce && i == nsol - 1)
              sb_printf(&gp, ", '../runs/%s/history.csv' using 1:%d with lines lw 1 dt 2 lc rgb 'black' title 'exact'",
                        rows[rb].label, ce);
          }
          sb_printf(&gp, "\n");
          set_terminal(&gp, fig, 1);
          sb_printf(&gp, "replot\n");
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
                  "set datafile separator ','\nset key outside right\nset grid\nset xlabel 't (s)'\n"
                  "set ylabel 'E(t) / E0'\nset title 'energy'\n");
        set_terminal(&gp, "energy", 0);
        sb_printf(&gp, "plot ");
        for (i = 0; i < nsol; i++) {
          int rb = best[i], ce;
          if (rb < 0 || !(ce = csv_column(head + (size_t)i * HEADER_MAX, "energy.ratio"))) continue;
          sb_printf(&gp, "%s'../runs/%s/history.csv' using 1:%d with lines lw 2 title '%s (h = %g)'", first ? "" : ", ",
                    rows[rb].label, ce, rows[rb].solver, rows[rb].dt);
          first = 0;
        }
        sb_printf(&gp, "\n");
        set_terminal(&gp, "energy", 1);
        sb_printf(&gp, "replot\n");
        if (!first) {
          rendered += render(dir, "energy", &gp, ctx);
          nfig++;
        }
        free(gp.s);
      }
      mo_free(best);
      mo_free(head);
    }
    /* 4. stability map per back end */
    if (opt->nvary >= 1) {
      for (i = 0; i < nsol; i++) {
        sbuf gp = {NULL, 0, 0, 0}, dat = {NULL, 0, 0, 0};
        char nm[128], fig[200];
        int two = opt->nvary >= 2, cls;
        slug(rows[i * ndt * ngrid].solver, nm, sizeof nm);
        snprintf(fig, sizeof fig, "stability-%s", nm);
        for (r = 0; r < nrun; r++) {
          char xs[32], ys[32];
          if (strcmp(rows[r].solver, rows[i * ndt * ngrid].solver)) continue;
          cls = !strcmp(rows[r].cls, "stable") ? 0 : !strcmp(rows[r].cls, "unstable") ? 1 : 2;
          axis_coord(&opt->vary[0], rows[r].vary[0], xs, sizeof xs);
          if (two) axis_coord(&opt->vary[1], rows[r].vary[1], ys, sizeof ys);
          else snprintf(ys, sizeof ys, "0");
          sb_printf(&dat, "%s,%s,%d,%.6g\n", xs, ys, cls, rows[r].dt);
        }
        snprintf(path, sizeof path, "%s/plots/stability-%s.csv", dir, nm);
        if (dat.s) write_text(path, dat.s, ctx);
        free(dat.s);
        sb_printf(&gp, "# stability map of %s: green stable, orange unstable, red solver failure\n"
                  "set datafile separator ','\nset grid\nset xlabel '%s'\nset ylabel '%s'\n"
                  "set title 'stability: %s'\nset key outside right\n",
                  rows[i * ndt * ngrid].solver, opt->vary[0].key, two ? opt->vary[1].key : "", rows[i * ndt * ngrid].solver);
        axis_setup(&gp, &opt->vary[0], 'x');
        if (two) axis_setup(&gp, &opt->vary[1], 'y');
        else sb_printf(&gp, "unset ytics\n");
        sb_printf(&gp, "set offsets graph 0.05, graph 0.05, graph 0.08, graph 0.08\n");
        for (j = 0; j < 2; j++) {
          set_terminal(&gp, fig, j);
          sb_printf(&gp, "plot 'stability-%s.csv' using 1:($3==0?$2:1/0) with points pt 7 ps 2 lc rgb '#2a9d2a' title 'stable', "
                    "'' using 1:($3==1?$2:1/0) with points pt 7 ps 2 lc rgb '#e69500' title 'unstable', "
                    "'' using 1:($3==2?$2:1/0) with points pt 7 ps 2 lc rgb '#d62728' title 'failure'\n", nm);
        }
        rendered += render(dir, fig, &gp, ctx);
        free(gp.s);
        nfig++;
      }
    }
    res->nfigures = nfig;
    res->rendered = rendered;
  }

  /* report.md */
  b.n = 0;
  sb_printf(&b, "# moreau compare: %s\n\n", opt->case_path);
  sb_printf(&b, "%d runs: %d stable, %d unstable, %d failed. Every run's outputs are under `runs/`; "
            "all metrics are in `compare.csv`%s; figures in `plots/` (gnuplot scripts kept).\n\n",
            res->nrun, res->nstable, res->nunstable, res->nfailed, opt->nvary ? ", the classification in `stability.csv`" : "");
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
      int c = col_index(C, key[kk]), any = 0;
      if (c < 0 || c == metric_col) continue;
      for (r = 0; r < nrun; r++) any |= !isnan(rows[r].val[c]);
      if (any) show[ns++] = c;
    }
    /* then the columns the case asks for (output.report), those not shown already */
    for (kk = 0; kk < H->n; kk++) {
      int c = col_index(C, H->name[kk]), seen = 0;
      for (jj = 0; jj < ns; jj++) seen |= show[jj] == c;
      if (c >= 0 && !seen) show[ns++] = c;
    }
    sb_printf(&b, "| run | solver | dt | wall (s) | steps | class |");
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
      sb_printf(&b, "| %s | %s | %g | %.3f | %ld | %s%s%s |", R->label, R->solver, R->dt, R->wall, R->steps, R->cls,
                R->why[0] ? ": " : "", R->why);
      for (jj = 0; jj < ns; jj++) {
        if (isnan(R->val[show[jj]])) sb_printf(&b, " |");
        else sb_printf(&b, " %.4g |", R->val[show[jj]]);
      }
      sb_printf(&b, "\n");
    }
  }
  sb_printf(&b, "\n");
  for (r = 0; r < nrun; r++)
    if (rows[r].status) sb_printf(&b, "- `%s` failed: %s\n", rows[r].label, rows[r].reason);
  if (nrun > nown) {
    sb_printf(&b, "\nRows marked (external) are %d rows of", nrun - nown);
    for (k = 0; k < opt->npeer; k++) sb_printf(&b, "%s `%s`", k ? (k == opt->npeer - 1 ? " and" : ",") : "", opt->peers[k]);
    sb_printf(&b, " (--peer): measured by another program with its own clock, not run here and not in "
              "`compare.csv`; dashed lines in the work-precision figure.\n");
  }
  sb_printf(&b, "\n## Figures\n\n");
  if (metric_col >= 0) sb_printf(&b, "![work-precision](plots/work-precision.png)\n\n");
  sb_printf(&b, "Histories against the exact solution: `plots/history-*.png`; energy: `plots/energy.png`%s.\n",
            opt->nvary ? "; stability maps: `plots/stability-*.png`" : "");
  snprintf(path, sizeof path, "%s/report.md", dir);
  if (!b.err) st = write_text(path, b.s, ctx);
  if (!st && stop) st = mo_error(ctx, stop, "%s", stopmsg);
done:
  free(b.s);
  mo_free(rows);
  mo_free(C);
  peers_free(&P);
  mo_free(H);
  mo_free(sets);
  return st;
}
