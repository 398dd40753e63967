/* plugin.c: contact back ends loaded at run time from shared libraries (moreau/backend.h,
   doc/backends.md): the entry's checks, the plug-in folders, the context's set of plug-ins. */
#include "config.h"
#include <moreau/backend.h>

#include <dirent.h>
#include <dlfcn.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#ifndef MO_PLUGINDIR
#define MO_PLUGINDIR "" /* builds outside the makefile (the fuzzer): no installed folder */
#endif

typedef struct {
  void *handle;
  const mo_contact_solver_type *type;
  char *file;
} plugin;

struct mo_plugins {
  int n, cap;
  plugin *p;
  char *failures; /* "file: reason\n" for every file a scan refused */
};

static const char *const struct_names[MO_PLUGIN_NSIZES] = {
  "mo_contact_solver_type", "mo_contact_problem", "mo_contact_vars", "mo_contact_report", "mo_option_spec",
  "mo_ctx"};

const char *mo_plugin_default_folder(void)
{
  return MO_PLUGINDIR;
}

const char *mo_plugin_folders(void)
{
  const char *env = getenv("MOREAU_PLUGIN_PATH");
  return env ? env : MO_PLUGINDIR;
}

int mo_plugin_count(const mo_ctx *ctx)
{
  return ctx && ctx->plugins ? ctx->plugins->n : 0;
}

const mo_contact_solver_type *mo_plugin_type(const mo_ctx *ctx, int i)
{
  return i >= 0 && i < mo_plugin_count(ctx) ? ctx->plugins->p[i].type : NULL;
}

const char *mo_plugin_file(const mo_ctx *ctx, int i)
{
  return i >= 0 && i < mo_plugin_count(ctx) ? ctx->plugins->p[i].file : NULL;
}

const char *mo_plugin_failures(const mo_ctx *ctx)
{
  return ctx && ctx->plugins && ctx->plugins->failures ? ctx->plugins->failures : "";
}

void mo_ctx_release(mo_ctx *ctx)
{
  struct mo_plugins *S = ctx->plugins;
  int i;
  if (S) {
    for (i = S->n - 1; i >= 0; i--) {
      dlclose(S->p[i].handle);
      mo_free(S->p[i].file);
    }
    mo_free(S->p);
    mo_free(S->failures);
    mo_free(S);
  }
  mo_ctx_init(ctx);
}

/* --- the checks of a type object ------------------------------------------------------------- */

/* A name made of letters, digits, '_' and '-', starting with a letter, as the solver specs
   (BACKEND:PRESET[KEY=VALUE]) and case keys (contact.BACKEND.KEY) can carry it. */
static int good_name(const char *s, size_t max)
{
  size_t k;
  if (!s || !((s[0] >= 'a' && s[0] <= 'z') || (s[0] >= 'A' && s[0] <= 'Z'))) return 0;
  for (k = 0; s[k]; k++)
    if (k >= max || !((s[k] >= 'a' && s[k] <= 'z') || (s[k] >= 'A' && s[k] <= 'Z') || (s[k] >= '0' && s[k] <= '9') ||
                      s[k] == '_' || s[k] == '-'))
      return 0;
  return 1;
}

/* Option k of T: a good name met once, a known type stored inside the parameter struct. */
static int check_option(const mo_contact_solver_type *T, int k, const char *file, mo_ctx *ctx)
{
  const mo_option_spec *o = &T->options[k];
  size_t sz = o->type == MO_OPT_DOUBLE ? sizeof(double) : sizeof(int);
  int j;
  if (!good_name(o->name, 48))
    return mo_error(ctx, MO_EINPUT, "plug-in %s: back end '%s': option %d has no valid name (letters, digits, "
                    "'_', '-')", file, T->name, k);
  for (j = 0; j < k; j++)
    if (!strcmp(T->options[j].name, o->name))
      return mo_error(ctx, MO_EINPUT, "plug-in %s: back end '%s': option '%s' is declared twice", file, T->name, o->name);
  if ((unsigned)o->type > MO_OPT_ENUM)
    return mo_error(ctx, MO_EINPUT, "plug-in %s: back end '%s': option '%s' has an unknown type %d", file, T->name,
                    o->name, (int)o->type);
  if (o->offset % sz || o->offset + sz > T->params_size)
    return mo_error(ctx, MO_EINPUT, "plug-in %s: back end '%s': option '%s' is stored at offset %zu, outside its "
                    "parameter struct of %zu bytes (or misaligned)", file, T->name, o->name, o->offset, T->params_size);
  if (o->type == MO_OPT_ENUM && (!o->enums || !o->enums[0]))
    return mo_error(ctx, MO_EINPUT, "plug-in %s: back end '%s': option '%s' is an enum without values", file,
                    T->name, o->name);
  if (!o->doc || !o->deflt)
    return mo_error(ctx, MO_EINPUT, "plug-in %s: back end '%s': option '%s' has no %s", file, T->name, o->name,
                    o->doc ? "printed default" : "doc line");
  if (!isnan(o->lo) && !isnan(o->hi) && o->lo > o->hi)
    return mo_error(ctx, MO_EINPUT, "plug-in %s: back end '%s': option '%s' has the empty range [%g, %g]", file,
                    T->name, o->name, o->lo, o->hi);
  return MO_OK;
}

int mo_plugin_check_type(const mo_contact_solver_type *T, const char *file, const mo_ctx *loaded, mo_ctx *ctx)
{
  const unsigned needs = MO_NEEDS_DELASSUS | MO_NEEDS_GLOBAL | MO_NEEDS_BODIES;
  const unsigned schemes = (1u << MO_SCHEME_THETA) | (1u << MO_SCHEME_NEWMARK) | (1u << MO_SCHEME_QUASISTATIC);
  const mo_contact_solver_type *other;
  const size_t big = (size_t)1 << 30;
  int k, st;
  if (!good_name(T->name, 31) || !strcmp(T->name, "case"))
    return mo_error(ctx, MO_EINPUT, "plug-in %s: its back end's name is %s%s%s: a name is 1 to 31 letters, digits, "
                    "'_' or '-', starting with a letter (and not 'case')", file, T->name ? "'" : "",
                    T->name ? T->name : "missing", T->name ? "'" : "");
  if ((other = mo_contact_solver_lookup(T->name, loaded))) {
    int i;
    const char *from = "this build";
    for (i = 0; i < mo_plugin_count(loaded); i++)
      if (mo_plugin_type(loaded, i) == other) from = mo_plugin_file(loaded, i);
    return mo_error(ctx, MO_EINPUT, "plug-in %s: back end '%s' exists already (from %s)", file, T->name, from);
  }
  if (!T->summary || !T->init || !T->solve || !T->free)
    return mo_error(ctx, MO_EINPUT, "plug-in %s: back end '%s' has no %s (moreau/contact.h: summary, init, solve "
                    "and free are required)", file, T->name,
                    !T->summary ? "summary" : !T->init ? "init" : !T->solve ? "solve" : "free");
  if (T->state_size > big || T->params_size > big)
    return mo_error(ctx, MO_EINPUT, "plug-in %s: back end '%s' asks for %zu bytes of state and %zu of parameters "
                    "(at most 1 GiB each)", file, T->name, T->state_size, T->params_size);
  if (T->needs & ~needs || (T->needs & MO_NEEDS_BODIES && !(T->needs & MO_NEEDS_DELASSUS)))
    return mo_error(ctx, MO_EINPUT, "plug-in %s: back end '%s' needs 0x%x: the known bits are MO_NEEDS_DELASSUS, "
                    "MO_NEEDS_GLOBAL and MO_NEEDS_BODIES (with MO_NEEDS_DELASSUS)", file, T->name, T->needs);
  if (!T->schemes || T->schemes & ~schemes)
    return mo_error(ctx, MO_EINPUT, "plug-in %s: back end '%s' declares the schemes 0x%x: one or more of "
                    "1 << MO_SCHEME_THETA, MO_SCHEME_NEWMARK, MO_SCHEME_QUASISTATIC", file, T->name, T->schemes);
  if (T->noptions < 0 || T->noptions > 1000 || (T->noptions && !T->options))
    return mo_error(ctx, MO_EINPUT, "plug-in %s: back end '%s' declares %d options%s", file, T->name, T->noptions,
                    T->noptions > 0 && !T->options ? " but no table of them" : "");
  for (k = 0; k < T->noptions; k++)
    if ((st = check_option(T, k, file, ctx))) return st;
  return MO_OK;
}

/* --- loading ----------------------------------------------------------------------------------- */

/* The entry: exported, of this ABI, with this build's struct sizes. */
static int check_entry(const mo_plugin_entry *E, const char *file, mo_ctx *ctx)
{
  static const size_t here[MO_PLUGIN_NSIZES] = MO_PLUGIN_SIZES;
  int k;
  if (E->abi != MO_PLUGIN_ABI)
    return mo_error(ctx, MO_EINPUT, "plug-in %s was built for version %u of the back-end contract; this moreau "
                    "has version %u: build it again against this moreau's headers (pkg-config --cflags moreau)",
                    file, E->abi, (unsigned)MO_PLUGIN_ABI);
  for (k = 0; k < MO_PLUGIN_NSIZES; k++)
    if (E->sizes[k] != here[k])
      return mo_error(ctx, MO_EINPUT, "plug-in %s was built against other moreau headers: its %s has %zu bytes, "
                      "this moreau's %zu: build it again against this moreau's headers (pkg-config --cflags moreau)",
                      file, struct_names[k], E->sizes[k], here[k]);
  if (!E->type)
    return mo_error(ctx, MO_EINPUT, "plug-in %s: its %s names no back end (type NULL)", file, MO_PLUGIN_SYMBOL);
  return MO_OK;
}

static int add(mo_ctx *ctx, void *handle, const mo_contact_solver_type *T, const char *file)
{
  struct mo_plugins *S = ctx->plugins;
  if (!S && !(S = ctx->plugins = mo_calloc(ctx, 1, sizeof *S))) return MO_ENOMEM;
  if (S->n == S->cap) {
    int cap = S->cap ? 2 * S->cap : 4;
    plugin *p = mo_realloc(ctx, S->p, (size_t)cap * sizeof *p);
    if (!p) return MO_ENOMEM;
    S->p = p;
    S->cap = cap;
  }
  if (!(S->p[S->n].file = mo_strdup(ctx, file))) return MO_ENOMEM;
  S->p[S->n].handle = handle;
  S->p[S->n].type = T;
  S->n++;
  return MO_OK;
}

/* Load the file; *added is 1 when it brought a new back end. */
static int load_file(mo_ctx *ctx, const char *file, int *added)
{
  void *h;
  const mo_plugin_entry *E;
  int k, st;
  *added = 0;
  dlerror();
  if (!(h = dlopen(file, RTLD_NOW | RTLD_LOCAL))) {
    const char *why = dlerror();
    return mo_error(ctx, MO_EINPUT, "plug-in %s does not load: %s", file, why ? why : "unknown reason");
  }
  E = (const mo_plugin_entry *)dlsym(h, MO_PLUGIN_SYMBOL);
  if (!E) {
    st = mo_error(ctx, MO_EINPUT, "plug-in %s exports no %s: a back end defines it with MO_PLUGIN(its type) "
                  "(moreau/backend.h, doc/backends.md)", file, MO_PLUGIN_SYMBOL);
    dlclose(h);
    return st;
  }
  if ((st = check_entry(E, file, ctx))) {
    dlclose(h);
    return st;
  }
  for (k = 0; k < mo_plugin_count(ctx); k++)
    if (ctx->plugins->p[k].type == E->type) { /* the same file again */
      dlclose(h);
      return MO_OK;
    }
  if ((st = mo_plugin_check_type(E->type, file, ctx, ctx)) || (st = add(ctx, h, E->type, file))) {
    dlclose(h);
    return st;
  }
  *added = 1;
  mo_log(ctx, 2, "plug-in %s: back end '%s'\n", file, E->type->name);
  return MO_OK;
}

static int is_file(const char *path)
{
  struct stat sb;
  return !stat(path, &sb) && S_ISREG(sb.st_mode);
}

/* NAME.so in the first plug-in folder holding it, into buf; 0 when none does. */
static int find_by_name(const char *name, char *buf, size_t n)
{
  const char *p = mo_plugin_folders();
  while (*p) {
    size_t len = strcspn(p, ":");
    if (len && snprintf(buf, n, "%.*s/%s.so", (int)len, p, name) < (int)n && is_file(buf)) return 1;
    p += len + (p[len] == ':');
  }
  return 0;
}

int mo_plugin_load(mo_ctx *ctx, const char *spec)
{
  char file[4096];
  size_t l = strlen(spec);
  int added;
  if (!l) return mo_error(ctx, MO_EINPUT, "plug-in: an empty name");
  if (strchr(spec, '/') || (l > 3 && !strcmp(spec + l - 3, ".so"))) {
    if (!is_file(spec)) return mo_error(ctx, MO_EINPUT, "plug-in %s: no such file", spec);
    return load_file(ctx, spec, &added);
  }
  if (!find_by_name(spec, file, sizeof file)) {
    const char *env = getenv("MOREAU_PLUGIN_PATH");
    return mo_error(ctx, MO_EINPUT, "plug-in '%s': no %s.so in the plug-in folders (%s%s%s)", spec, spec,
                    env ? "MOREAU_PLUGIN_PATH=" : "", env ? env : "MOREAU_PLUGIN_PATH unset, the installed folder ",
                    env ? "" : MO_PLUGINDIR);
  }
  return load_file(ctx, file, &added);
}

static int so_file(const struct dirent *e)
{
  size_t l = strlen(e->d_name);
  return e->d_name[0] != '.' && l > 3 && !strcmp(e->d_name + l - 3, ".so");
}

/* Note a refused file among the failures. */
static int note_failure(mo_ctx *ctx, const char *file, const char *why)
{
  struct mo_plugins *S = ctx->plugins;
  size_t have, need = strlen(file) + strlen(why) + 4;
  char *f;
  if (!S && !(S = ctx->plugins = mo_calloc(ctx, 1, sizeof *S))) return MO_ENOMEM;
  have = S->failures ? strlen(S->failures) : 0;
  if (!(f = mo_realloc(ctx, S->failures, have + need))) return MO_ENOMEM;
  snprintf(f + have, need, "%s%s", have ? "\n" : "", why);
  S->failures = f;
  return MO_OK;
}

/* Every *.so of one folder. */
static int scan_folder(mo_ctx *ctx, const char *dir, int *nloaded)
{
  struct dirent **list = NULL;
  int n = scandir(dir, &list, so_file, alphasort), k, st = MO_OK;
  char file[4096];
  for (k = 0; k < n; k++) {
    int added = 0;
    if (st == MO_OK && snprintf(file, sizeof file, "%s/%s", dir, list[k]->d_name) < (int)sizeof file &&
        is_file(file)) {
      if (load_file(ctx, file, &added) == MO_OK) *nloaded += added;
      else {
        char why[MO_ERRMSG_MAX];
        snprintf(why, sizeof why, "%s", ctx->errmsg);
        mo_ctx_clear_error(ctx);
        mo_log(ctx, 1, "moreau: %s (skipped)\n", why);
        st = note_failure(ctx, file, why);
      }
    }
    free(list[k]);
  }
  free(list);
  return st;
}

int mo_plugin_scan(mo_ctx *ctx, const char *folders, int *nloaded)
{
  char dir[4096];
  const char *p = folders ? folders : mo_plugin_folders();
  int n = 0, st = MO_OK;
  if (ctx->status) return mo_error(ctx, MO_EINTERNAL, "mo_plugin_scan on a context holding an error");
  while (*p && st == MO_OK) {
    size_t len = strcspn(p, ":");
    if (len && len < sizeof dir) {
      memcpy(dir, p, len);
      dir[len] = '\0';
      st = scan_folder(ctx, dir, &n);
    }
    p += len + (p[len] == ':');
  }
  if (nloaded) *nloaded = n;
  return st;
}

void mo_plugin_print(FILE *out, const mo_ctx *ctx)
{
  int i, k;
  for (i = 0; i < mo_plugin_count(ctx); i++) {
    const mo_contact_solver_type *T = mo_plugin_type(ctx, i);
    fprintf(out, "%-10s %s\n           (plug-in %s)\n", T->name, T->summary, mo_plugin_file(ctx, i));
    for (k = 0; k < T->noptions; k++)
      fprintf(out, "           contact.%s.%s = %s: %s\n", T->name, T->options[k].name, T->options[k].deflt,
              T->options[k].doc);
  }
  if (mo_plugin_failures(ctx)[0]) fprintf(out, "plug-ins refused:\n%s\n", mo_plugin_failures(ctx));
}
