/* testlib.h: what several C tests share (header-only, like tap.h): the source tree, a small
   scene built from a case text, a run through mo_run, its summary.json and CSV files read back,
   its folder removed; a few dense helpers. */
#ifndef MOREAU_TESTLIB_H
#define MOREAU_TESTLIB_H

#include <moreau/moreau.h>
#include "tap.h"

#include <dirent.h>
#include <jansson.h>
#include <stdarg.h>
#include <string.h>
#include <unistd.h>

#define TL_UNUSED __attribute__((unused))

/* A scene stepped by the test itself (the stepper and the contact driver driven directly): the
   case, its scene, contact set, stepper, contact driver and state. tl_steps_open loads the case (a
   path, or the text itself when text is set, read as file name), applies the overrides, builds
   everything and sets the initial state; on failure everything is freed and R->ctx.errmsg says
   why. */
typedef struct {
  mo_ctx ctx;
  mo_case *cs;
  mo_scene *sc;
  mo_contact *C;
  mo_stepper *S;
  mo_contact_driver *D;
  mo_state s;
} tl_steps;

static void tl_steps_free(tl_steps *R) TL_UNUSED;
static void tl_steps_free(tl_steps *R)
{
  mo_contact_driver_free(R->D);
  mo_state_release(&R->s);
  mo_stepper_free(R->S);
  mo_contact_free(R->C);
  mo_scene_free(R->sc);
  mo_case_free(R->cs);
  R->D = NULL; R->S = NULL; R->C = NULL; R->sc = NULL; R->cs = NULL;
}

static int tl_steps_open(tl_steps *R, const char *src, const char *text_name, const char *const *sets, int nset) TL_UNUSED;
static int tl_steps_open(tl_steps *R, const char *src, const char *text_name, const char *const *sets, int nset)
{
  int st, k;
  memset(R, 0, sizeof *R);
  mo_ctx_init(&R->ctx);
  R->ctx.verbosity = 0;
  st = text_name ? mo_case_load_string(src, text_name, &R->cs, &R->ctx) : mo_case_load(src, &R->cs, &R->ctx);
  if (!st) st = mo_case_validate(R->cs, &R->ctx);
  for (k = 0; !st && k < nset; k++) st = mo_case_set(R->cs, sets[k], &R->ctx);
  if (!st) st = mo_case_validate(R->cs, &R->ctx);
  if (!st) st = mo_scene_build(R->cs, &R->sc, &R->ctx);
  if (!st) st = mo_contact_build(R->sc, &R->C, &R->ctx);
  if (!st) {
    /* as mo_run does: the contact dofs last unless the case says otherwise */
    const char *order = "contact_last";
    mo_case_lookup_string(R->cs, "contact.factor_order", &order);
    st = mo_stepper_create_contact(R->sc, R->C, !strcmp(order, "contact_last"), &R->S, &R->ctx);
  }
  if (!st) st = mo_contact_driver_create(R->sc, R->C, R->S, &R->D, &R->ctx);
  if (!st) st = mo_state_alloc(R->sc, &R->s, &R->ctx);
  if (!st) st = mo_stepper_init_state(R->S, &R->s, &R->ctx);
  if (st) tl_steps_free(R);
  return st;
}

/* The source tree: $MOREAU_SRCDIR (make check sets it), else the one the program was built
   with when it was told (MOREAU_TOP_SRCDIR), else "..". */
static const char *tl_srcdir(void) TL_UNUSED;
static const char *tl_srcdir(void)
{
  const char *s = getenv("MOREAU_SRCDIR");
#ifdef MOREAU_TOP_SRCDIR
  return s ? s : MOREAU_TOP_SRCDIR;
#else
  return s ? s : "..";
#endif
}

/* The folder of a shipped case: <source tree>/cases/<name>. */
static void tl_case_path(char *buf, size_t n, const char *name) TL_UNUSED;
static void tl_case_path(char *buf, size_t n, const char *name)
{
  snprintf(buf, n, "%s/cases/%s", tl_srcdir(), name);
}

/* A case text loaded (under the file name `name`), validated and its scene built. */
static int tl_scene(const char *text, const char *name, mo_case **cs, mo_scene **sc, mo_ctx *ctx) TL_UNUSED;
static int tl_scene(const char *text, const char *name, mo_case **cs, mo_scene **sc, mo_ctx *ctx)
{
  int st = mo_case_load_string(text, name, cs, ctx);
  if (!st) st = mo_case_validate(*cs, ctx);
  if (!st) st = mo_scene_build(*cs, sc, ctx);
  return st;
}

/* mo_run with a quiet context: the options as given, the result in *res when given, the error
   message in err (empty on success) when given. Returns mo_run's status. */
static int tl_run_options(const mo_run_options *o, mo_run_result *res, char *err, size_t nerr) TL_UNUSED;
static int tl_run_options(const mo_run_options *o, mo_run_result *res, char *err, size_t nerr)
{
  mo_ctx ctx;
  mo_run_result r;
  int st;
  mo_ctx_init(&ctx);
  ctx.verbosity = 0;
  memset(&r, 0, sizeof r);
  st = mo_run(o, &r, &ctx);
  if (err && nerr) snprintf(err, nerr, "%s", st ? ctx.errmsg : "");
  if (res) *res = r;
  return st;
}

/* Run a case (a folder or a file) with a back end (NULL: the case's own) and overrides into
   outdir, quietly; on failure the message goes to a diagnostic, after "who: " when who is given.
   The result in *res when res is given. Returns mo_run's status. */
static int tl_run(const char *case_path, const char *solver, const char *const *sets, int nset, const char *outdir,
                  const char *who, mo_run_result *res) TL_UNUSED;
static int tl_run(const char *case_path, const char *solver, const char *const *sets, int nset, const char *outdir,
                  const char *who, mo_run_result *res)
{
  mo_run_options o;
  char err[MO_ERRMSG_MAX];
  int st;
  memset(&o, 0, sizeof o);
  o.case_path = case_path;
  o.solver = solver;
  o.sets = sets;
  o.nset = nset;
  o.outdir = outdir;
  st = tl_run_options(&o, res, err, sizeof err);
  if (st && who) diag("%s: %s", who, err);
  else if (st) diag("%s", err);
  return st;
}

/* Run a case text: it is written to <outdir>.cfg (the folder above made when missing), run as
   tl_run does, and the file removed. */
static int tl_run_text(const char *text, const char *outdir, const char *who, mo_run_result *res) TL_UNUSED;
static int tl_run_text(const char *text, const char *outdir, const char *who, mo_run_result *res)
{
  char cfg[4200], *slash;
  FILE *f;
  mo_ctx ctx;
  int st;
  snprintf(cfg, sizeof cfg, "%s", outdir);
  if ((slash = strrchr(cfg, '/'))) {
    *slash = '\0';
    mo_ctx_init(&ctx);
    mo_mkdir_p(cfg, &ctx);
  }
  snprintf(cfg, sizeof cfg, "%s.cfg", outdir);
  if (!(f = fopen(cfg, "w"))) return -1;
  fputs(text, f);
  fclose(f);
  st = tl_run(cfg, NULL, NULL, 0, outdir, who, res);
  unlink(cfg);
  return st;
}

/* A run's summary.json, parsed (NULL, and a diagnostic, when it cannot be read). */
static json_t *tl_summary(const char *outdir) TL_UNUSED;
static json_t *tl_summary(const char *outdir)
{
  char path[4200];
  json_error_t err;
  json_t *root;
  snprintf(path, sizeof path, "%s/summary.json", outdir);
  root = json_load_file(path, 0, &err);
  if (!root) diag("%s: %s", path, err.text);
  return root;
}

/* A number in a JSON object by its keys, one per level, up to a NULL (a key may contain dots:
   "cend.ux"); NaN when absent or not a number. */
static double tl_jnum(json_t *j, ...) __attribute__((sentinel, unused));
static double tl_jnum(json_t *j, ...)
{
  va_list ap;
  const char *k;
  va_start(ap, j);
  while (j && (k = va_arg(ap, const char *))) j = json_object_get(j, k);
  va_end(ap);
  return j && json_is_number(j) ? json_number_value(j) : NAN;
}

/* Remove a run's folder and every file in it. */
static void tl_remove_dir(const char *dir) TL_UNUSED;
static void tl_remove_dir(const char *dir)
{
  char file[4400];
  DIR *d = opendir(dir);
  struct dirent *e;
  while (d && (e = readdir(d)))
    if (e->d_name[0] != '.') {
      snprintf(file, sizeof file, "%s/%s", dir, e->d_name);
      unlink(file);
    }
  if (d) closedir(d);
  rmdir(dir);
}

/* --- CSV files whose header names the columns (history.csv, contact.csv, data tables) ------- */

typedef struct {
  int ncol, nrow;
  char **name;  /* ncol */
  char ***cell; /* nrow x ncol; "" for a cell a short row lacks */
} tl_table;

static void tl_table_free(tl_table *T) TL_UNUSED;
static void tl_table_free(tl_table *T)
{
  int i, j;
  for (i = 0; i < T->nrow; i++) {
    for (j = 0; j < T->ncol; j++) free(T->cell[i][j]);
    free(T->cell[i]);
  }
  for (j = 0; j < T->ncol; j++) free(T->name[j]);
  free(T->cell);
  free(T->name);
  memset(T, 0, sizeof *T);
}

/* The cells of one line (its end of line dropped), each a copy; their number in *n. */
static char **tl_split(char *line, int *n) TL_UNUSED;
static char **tl_split(char *line, int *n)
{
  char **out = NULL, *p = line, *c;
  line[strcspn(line, "\r\n")] = '\0';
  for (*n = 0;; p = c + 1) {
    c = strchr(p, ',');
    if (c) *c = '\0';
    out = realloc(out, (size_t)(*n + 1) * sizeof *out);
    out[(*n)++] = strdup(p);
    if (!c) return out;
  }
}

/* Read a CSV file; 0 on success. Cells beyond the header's count are dropped. */
static int tl_table_read(const char *path, tl_table *T) TL_UNUSED;
static int tl_table_read(const char *path, tl_table *T)
{
  FILE *f = fopen(path, "r");
  char *line = NULL;
  size_t cap = 0;
  memset(T, 0, sizeof *T);
  if (!f) return -1;
  if (getline(&line, &cap, f) < 0) {
    free(line);
    fclose(f);
    return -1;
  }
  T->name = tl_split(line, &T->ncol);
  while (getline(&line, &cap, f) > 0) {
    int n, j;
    char **c = tl_split(line, &n);
    T->cell = realloc(T->cell, (size_t)(T->nrow + 1) * sizeof *T->cell);
    T->cell[T->nrow] = calloc((size_t)T->ncol, sizeof(char *));
    for (j = 0; j < n; j++) {
      if (j < T->ncol) T->cell[T->nrow][j] = c[j];
      else free(c[j]);
    }
    for (j = n; j < T->ncol; j++) T->cell[T->nrow][j] = strdup("");
    free(c);
    T->nrow++;
  }
  free(line);
  fclose(f);
  return 0;
}

/* The column named `name`, -1 when absent. */
static int tl_col(const tl_table *T, const char *name) TL_UNUSED;
static int tl_col(const tl_table *T, const char *name)
{
  int j;
  for (j = 0; j < T->ncol; j++)
    if (!strcmp(T->name[j], name)) return j;
  return -1;
}

/* Row i of column j as a number: NaN for an absent column or an empty cell. */
static double tl_num(const tl_table *T, int i, int j) TL_UNUSED;
static double tl_num(const tl_table *T, int i, int j)
{
  return j < 0 || !T->cell[i][j][0] ? NAN : atof(T->cell[i][j]);
}

/* --- dense helpers (row-major 3 x 3) ----------------------------------------------------- */

/* max |a_i| */
static double maxabs(const double *a, int n) TL_UNUSED;
static double maxabs(const double *a, int n)
{
  double m = 0;
  int i;
  for (i = 0; i < n; i++)
    if (fabs(a[i]) > m) m = fabs(a[i]);
  return m;
}

/* max |a_i - b_i| */
static double maxdiff(const double *a, const double *b, int n) TL_UNUSED;
static double maxdiff(const double *a, const double *b, int n)
{
  double m = 0;
  int i;
  for (i = 0; i < n; i++)
    if (fabs(a[i] - b[i]) > m) m = fabs(a[i] - b[i]);
  return m;
}

/* C = A B */
static void mul3(const double *A, const double *B, double *C) TL_UNUSED;
static void mul3(const double *A, const double *B, double *C)
{
  int i, j, k;
  for (i = 0; i < 3; i++)
    for (j = 0; j < 3; j++) {
      C[3 * i + j] = 0;
      for (k = 0; k < 3; k++) C[3 * i + j] += A[3 * i + k] * B[3 * k + j];
    }
}

/* Rotation by angle t about the unit axis n (Rodrigues). */
static void rotation(const double *n, double t, double *R) TL_UNUSED;
static void rotation(const double *n, double t, double *R)
{
  double c = cos(t), s = sin(t), C = 1 - c;
  R[0] = c + n[0] * n[0] * C;        R[1] = n[0] * n[1] * C - n[2] * s; R[2] = n[0] * n[2] * C + n[1] * s;
  R[3] = n[1] * n[0] * C + n[2] * s; R[4] = c + n[1] * n[1] * C;        R[5] = n[1] * n[2] * C - n[0] * s;
  R[6] = n[2] * n[0] * C - n[1] * s; R[7] = n[2] * n[1] * C + n[0] * s; R[8] = c + n[2] * n[2] * C;
}

/* Small FE scenes on contact (tests/test_scale, tests/test_mumps), each a format for snprintf. */
/* a 2D block on a plane: %s element, %s hypothesis, %s time keys, %s extra pair keys */
static const char *const tl_block_2d TL_UNUSED =
  "bodies = (\n"
  "  { name = \"block\"; mesh = { generator = \"rectangle\"; origin = [0.0, 0.0]; size = [0.2, 0.1]; elements = [6, 4]; element = \"%s\"; };\n"
  "    material = { E = 7.0e10; nu = 0.3; rho = 2700.0; hypothesis = \"%s\"; }; body_force = [0.0, -9.81]; },\n"
  "  { name = \"floor\"; type = \"plane\"; point = [0.0, 0.0]; normal = [0.0, 1.0]; }\n"
  ");\n"
  "time = { %s };\n"
  "contact = { pairs = ( { slave = \"block\"; slave_set = \"bottom\"; master = \"floor\"; %s } ); };\n";
/* a 3D box pressed on a plane: %s extra pair keys */
static const char *const tl_box_3d TL_UNUSED =
  "bodies = (\n"
  "  { name = \"box\"; mesh = { generator = \"box\"; size = [0.1, 0.1, 0.05]; elements = [4, 4, 2]; };\n"
  "    material = { E = 2.1e11; nu = 0.3; rho = 7800.0; };\n"
  "    loads = ( { type = \"pressure\"; set = \"zmax\"; value = 1.0e6; } ); },\n"
  "  { name = \"ground\"; type = \"plane\"; point = [0.0, 0.0, 0.0]; normal = [0.0, 0.0, 1.0]; }\n"
  ");\n"
  "time = { scheme = \"theta\"; dt = 1.0e-5; steps = 1; };\n"
  "contact = { pairs = ( { slave = \"box\"; slave_set = \"zmin\"; master = \"ground\"; %s } ); };\n";
/* a 3D box on a fixed box (a mesh master, mu = 0.3): no format */
static const char *const tl_boxes_3d TL_UNUSED =
  "bodies = (\n"
  "  { name = \"lower\"; mesh = { generator = \"box\"; size = [0.1, 0.1, 0.05]; elements = [3, 3, 2]; };\n"
  "    material = { E = 2.1e11; nu = 0.3; rho = 7800.0; }; fix = ( { set = \"zmin\"; } ); },\n"
  "  { name = \"upper\"; mesh = { generator = \"box\"; origin = [0.0, 0.0, 0.05]; size = [0.1, 0.1, 0.05]; elements = [4, 4, 2]; };\n"
  "    material = { E = 2.1e11; nu = 0.3; rho = 7800.0; }; body_force = [0.0, 0.0, -9.81]; }\n"
  ");\n"
  "time = { scheme = \"theta\"; dt = 1.0e-5; steps = 1; };\n"
  "contact = { pairs = ( { slave = \"upper\"; slave_set = \"zmin\"; master = \"lower\"; master_set = \"zmax\"; mu = 0.3; } ); };\n";

#endif
