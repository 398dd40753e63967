/* case.c: reading case files, --set overrides, and validation against the schema. */
#include "config.h"
#include "case_internal.h"
#include <moreau/contact.h>
#include <moreau/backend.h>

#include <ctype.h>
#include <errno.h>
#include <jansson.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

const char *mo_key_type_name(mo_key_type t);

/* --- locations and errors ------------------------------------------------------------------ */

void mo_case_path(const config_setting_t *s, char *buf, size_t n)
{
  const config_setting_t *chain[64];
  int depth = 0, k;
  size_t len = 0;
  buf[0] = '\0';
  while (s && config_setting_parent(s) && depth < 64) {
    chain[depth++] = s;
    s = config_setting_parent(s);
  }
  for (k = depth - 1; k >= 0 && len < n; k--) {
    const config_setting_t *c = chain[k];
    const char *name = config_setting_name(c);
    int w;
    if (name)
      w = snprintf(buf + len, n - len, "%s%s", len ? "." : "", name);
    else
      w = snprintf(buf + len, n - len, "%s[%d]", len ? "." : "", config_setting_index(c));
    if (w < 0) break;
    len += (size_t)w;
  }
  if (len >= n && n > 0) buf[n - 1] = '\0';
}

/* Schema path: list indices replaced by "[]". */
static void schema_path(const config_setting_t *s, char *buf, size_t n)
{
  char raw[512];
  const char *p;
  size_t k = 0;
  mo_case_path(s, raw, sizeof raw);
  for (p = raw; *p && k + 3 < n; p++) {
    if (*p == '[') {
      buf[k++] = '[';
      buf[k++] = ']';
      while (*p && *p != ']') p++;
      if (!*p) break;
    } else
      buf[k++] = *p;
  }
  buf[k] = '\0';
}

static const char *override_for(const mo_case *cs, const char *path)
{
  int i;
  for (i = cs->nset - 1; i >= 0; i--) {
    const char *eq = strchr(cs->sets[i], '=');
    size_t kl = eq ? (size_t)(eq - cs->sets[i]) : strlen(cs->sets[i]);
    if (strlen(path) >= kl && !strncmp(cs->sets[i], path, kl)) return cs->sets[i];
  }
  return cs->nset ? cs->sets[cs->nset - 1] : NULL;
}

void mo_case_where(const mo_case *cs, const config_setting_t *s, char *buf, size_t n)
{
  int line = s ? (int)config_setting_source_line(s) : 0;
  if (line > 0) {
    snprintf(buf, n, "%s:%d", cs->file, line);
  } else if (s && config_setting_parent(s)) {
    char path[512];
    const char *o;
    mo_case_path(s, path, sizeof path);
    o = override_for(cs, path);
    if (o) snprintf(buf, n, "--set %s", o);
    else snprintf(buf, n, "%s", cs->file);
  } else
    snprintf(buf, n, "%s", cs->file);
}

int mo_case_error(const mo_case *cs, const config_setting_t *s, mo_ctx *ctx, const char *fmt, ...)
{
  char where[600], path[512], msg[1024];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(msg, sizeof msg, fmt, ap);
  va_end(ap);
  mo_case_where(cs, s, where, sizeof where);
  mo_case_path(s, path, sizeof path);
  if (path[0]) return mo_error(ctx, MO_EINPUT, "%s: key '%s': %s", where, path, msg);
  return mo_error(ctx, MO_EINPUT, "%s: %s", where, msg);
}

/* --- loading --------------------------------------------------------------------------------- */

static int syntax_error(const mo_case *cs, const char *fallback, mo_ctx *ctx)
{
  const char *f = config_error_file(&cs->cfg), *t = config_error_text(&cs->cfg);
  int line = config_error_line(&cs->cfg);
  const char *hint = "";
  if (t && strstr(t, "mismatched element type"))
    hint = " (an array holds one type: write 0.0 rather than 0 next to decimals)";
  if (config_error_type(&cs->cfg) == CONFIG_ERR_FILE_IO)
    return mo_error(ctx, MO_EIO, "%s: cannot read the file (%s)", fallback, strerror(errno));
  if (t && !strcmp(t, "syntax error")) t = NULL; /* libconfig's text adds nothing */
  return mo_error(ctx, MO_EINPUT, "%s:%d: syntax error%s%s%s", f ? f : fallback, line, t ? ": " : "",
                  t ? t : "", hint);
}

static mo_case *case_new(const char *file, mo_ctx *ctx)
{
  mo_case *cs = mo_calloc(ctx, 1, sizeof *cs);
  const char *slash;
  if (!cs) return NULL;
  config_init(&cs->cfg);
  config_set_options(&cs->cfg, 0);
  cs->file = mo_strdup(ctx, file);
  slash = strrchr(file, '/');
  if (slash) {
    size_t n = (size_t)(slash - file);
    cs->dir = mo_malloc(ctx, n + 1);
    if (cs->dir) {
      memcpy(cs->dir, file, n);
      cs->dir[n] = '\0';
    }
  } else
    cs->dir = mo_strdup(ctx, ".");
  if (!cs->file || !cs->dir) {
    mo_case_free(cs);
    return NULL;
  }
  return cs;
}

/* The largest case file read (bytes). */
#define MO_CASE_FILE_MAX (1 << 20)

int mo_case_load(const char *path, mo_case **out, mo_ctx *ctx)
{
  struct stat sb;
  char file[4096];
  mo_case *cs;
  *out = NULL;
  if (stat(path, &sb) != 0)
    return mo_error(ctx, MO_EIO, "%s: no such case file or folder", path);
  if (S_ISDIR(sb.st_mode)) {
    size_t n = strlen(path);
    while (n > 1 && path[n - 1] == '/') n--;
    snprintf(file, sizeof file, "%.*s/case.cfg", (int)n, path);
    if (stat(file, &sb) != 0)
      return mo_error(ctx, MO_EIO, "%s: this folder holds no case.cfg", path);
  } else
    snprintf(file, sizeof file, "%s", path);
  /* a bounded input: libconfig's scanner takes time quadratic in a string's length (1 MB:
     0.5 s, 4 MB: 29 s), and a case is a page of settings, its data in mesh files */
  if (stat(file, &sb) != 0 || !S_ISREG(sb.st_mode))
    return mo_error(ctx, MO_EINPUT, "%s: not a regular file (a case file is read whole)", file);
  if (sb.st_size > MO_CASE_FILE_MAX)
    return mo_error(ctx, MO_EINPUT, "%s: %lld bytes, more than the %d bytes a case file may hold (large data "
                    "belong in mesh files)", file, (long long)sb.st_size, MO_CASE_FILE_MAX);
  cs = case_new(file, ctx);
  if (!cs) return MO_ENOMEM;
  if (cs->dir) config_set_include_dir(&cs->cfg, cs->dir);
  if (!config_read_file(&cs->cfg, file)) {
    int st = syntax_error(cs, file, ctx);
    mo_case_free(cs);
    return st;
  }
  *out = cs;
  return MO_OK;
}

int mo_case_load_string(const char *text, const char *name, mo_case **out, mo_ctx *ctx)
{
  mo_case *cs = case_new(name, ctx);
  *out = NULL;
  if (!cs) return MO_ENOMEM;
  if (!config_read_string(&cs->cfg, text)) {
    int line = config_error_line(&cs->cfg);
    const char *t = config_error_text(&cs->cfg);
    int st = mo_error(ctx, MO_EINPUT, "%s:%d: syntax error%s%s", name, line,
                      t && strcmp(t, "syntax error") ? ": " : "", t && strcmp(t, "syntax error") ? t : "");
    mo_case_free(cs);
    return st;
  }
  *out = cs;
  return MO_OK;
}

void mo_case_free(mo_case *cs)
{
  int i;
  if (!cs) return;
  config_destroy(&cs->cfg);
  for (i = 0; i < cs->nset; i++) mo_free(cs->sets[i]);
  mo_free(cs->sets);
  mo_free(cs->file);
  mo_free(cs->dir);
  mo_free(cs);
}

const char *mo_case_file(const mo_case *cs) { return cs->file; }
const char *mo_case_dir(const mo_case *cs) { return cs->dir; }

/* --- validation ------------------------------------------------------------------------------ */

static int lev(const char *a, const char *b)
{
  int la = (int)strlen(a), lb = (int)strlen(b), i, j;
  int d[64][64];
  if (la > 63 || lb > 63) return 99;
  for (i = 0; i <= la; i++) d[i][0] = i;
  for (j = 0; j <= lb; j++) d[0][j] = j;
  for (i = 1; i <= la; i++)
    for (j = 1; j <= lb; j++) {
      int c = d[i - 1][j - 1] + (tolower((unsigned char)a[i - 1]) != tolower((unsigned char)b[j - 1]));
      if (d[i - 1][j] + 1 < c) c = d[i - 1][j] + 1;
      if (d[i][j - 1] + 1 < c) c = d[i][j - 1] + 1;
      /* adjacent transposition counts as one edit */
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] && d[i - 2][j - 2] + 1 < c)
        c = d[i - 2][j - 2] + 1;
      d[i][j] = c;
    }
  return d[la][lb];
}

typedef struct {
  const char *parent;
  const char *name;
  const char *best;
  int bestd;
  char buf[128];
} suggest_data;

static void suggest_visit(const char *path, const char *type, const char *range,
                          const char *deflt, const char *doc, void *data)
{
  suggest_data *S = data;
  size_t lp = strlen(S->parent);
  const char *child;
  int d;
  (void)type; (void)range; (void)deflt; (void)doc;
  if (lp) {
    if (strncmp(path, S->parent, lp) || path[lp] != '.') return;
    child = path + lp + 1;
  } else
    child = path;
  if (strchr(child, '.')) return;
  d = lev(S->name, child);
  if (d < S->bestd) {
    S->bestd = d;
    snprintf(S->buf, sizeof S->buf, "%s", child);
    S->best = S->buf;
  }
}

/* Names people write for keys that have a shorter physical name here. */
static const char *synonym(const char *name)
{
  static const struct { const char *from, *to; } syn[] = {
    {"young", "E"}, {"youngs_modulus", "E"}, {"young_modulus", "E"}, {"modulus", "E"},
    {"poisson", "nu"}, {"poisson_ratio", "nu"}, {"poissons_ratio", "nu"},
    {"density", "rho"}, {"timestep", "dt"}, {"time_step", "dt"}, {"step", "dt"},
    {"tmax", "end"}, {"t_end", "end"}, {"final_time", "end"}, {"friction", "mu"},
    {"nelem", "elements"}, {"n_elements", "elements"}, {"gravity", "body_force"}};
  size_t k;
  for (k = 0; k < sizeof syn / sizeof syn[0]; k++)
    if (!strcmp(syn[k].from, name)) return syn[k].to;
  return NULL;
}

static const char *suggest(const char *parent, const char *name, char *buf, size_t n, const mo_ctx *ctx)
{
  suggest_data S;
  int limit;
  const char *syn = synonym(name);
  if (syn) {
    char path[512];
    mo_key K;
    snprintf(path, sizeof path, "%s%s%s", parent, parent[0] ? "." : "", syn);
    if (mo_schema_lookup(path, &K, ctx)) {
      snprintf(buf, n, "%s", syn);
      return buf;
    }
  }
  memset(&S, 0, sizeof S);
  S.parent = parent;
  S.name = name;
  S.bestd = 1000;
  mo_case_schema_visit_ctx(suggest_visit, &S, ctx);
  limit = (int)strlen(name) <= 4 ? 1 : (int)strlen(name) / 3 + 1;
  if (S.best && S.bestd <= limit) {
    snprintf(buf, n, "%s", S.best);
    return buf;
  }
  return NULL;
}

static const char *enum_suggest(const char *enums, const char *v, char *buf, size_t n)
{
  const char *p = enums;
  int bestd = 1000;
  buf[0] = '\0';
  while (*p) {
    const char *bar = strchr(p, '|');
    size_t len = bar ? (size_t)(bar - p) : strlen(p);
    char item[64];
    int d;
    if (len < sizeof item) {
      memcpy(item, p, len);
      item[len] = '\0';
      d = lev(v, item);
      if (d < bestd) {
        bestd = d;
        snprintf(buf, n, "%s", item);
      }
    }
    if (!bar) break;
    p = bar + 1;
  }
  return bestd <= (int)strlen(v) / 3 + 1 ? buf : NULL;
}

static int enum_has(const char *enums, const char *v)
{
  size_t lv = strlen(v);
  const char *p = enums;
  while (*p) {
    const char *bar = strchr(p, '|');
    size_t len = bar ? (size_t)(bar - p) : strlen(p);
    if (len == lv && !strncmp(p, v, len)) return 1;
    if (!bar) break;
    p = bar + 1;
  }
  return 0;
}

static void enum_list(const char *enums, char *buf, size_t n)
{
  size_t k = 0;
  const char *p;
  for (p = enums; *p && k + 3 < n; p++) {
    if (*p == '|') {
      buf[k++] = ',';
      buf[k++] = ' ';
    } else
      buf[k++] = *p;
  }
  buf[k] = '\0';
}

static int is_number(const config_setting_t *s)
{
  int t = config_setting_type(s);
  return t == CONFIG_TYPE_INT || t == CONFIG_TYPE_INT64 || t == CONFIG_TYPE_FLOAT;
}

static int is_integer(const config_setting_t *s)
{
  int t = config_setting_type(s);
  return t == CONFIG_TYPE_INT || t == CONFIG_TYPE_INT64;
}

static double num_value(const config_setting_t *s)
{
  switch (config_setting_type(s)) {
  case CONFIG_TYPE_INT: return (double)config_setting_get_int(s);
  case CONFIG_TYPE_INT64: return (double)config_setting_get_int64(s);
  case CONFIG_TYPE_FLOAT: return config_setting_get_float(s);
  default: return NAN;
  }
}

static const char *setting_type_name(const config_setting_t *s)
{
  switch (config_setting_type(s)) {
  case CONFIG_TYPE_INT:
  case CONFIG_TYPE_INT64: return "an integer";
  case CONFIG_TYPE_FLOAT: return "a number";
  case CONFIG_TYPE_STRING: return "a string";
  case CONFIG_TYPE_BOOL: return "a boolean";
  case CONFIG_TYPE_ARRAY: return "an array";
  case CONFIG_TYPE_LIST: return "a list";
  case CONFIG_TYPE_GROUP: return "a group";
  default: return "an unknown value";
  }
}

static void fmt_range(const mo_key *K, char *buf, size_t n)
{
  char lo[40] = "-inf", hi[40] = "inf";
  if (!isnan(K->lo)) snprintf(lo, sizeof lo, "%g", K->lo);
  if (!isnan(K->hi)) snprintf(hi, sizeof hi, "%g", K->hi);
  snprintf(buf, n, "%c%s, %s%c", K->lo_open || isnan(K->lo) ? '(' : '[', lo, hi,
           K->hi_open || isnan(K->hi) ? ')' : ']');
}

static int check_number(const mo_case *cs, const config_setting_t *s, const mo_key *K,
                        const config_setting_t *item, mo_ctx *ctx)
{
  double v = num_value(item);
  char r[128];
  int bad = 0;
  if (!isfinite(v)) bad = 1;
  /* a subnormal number (|v| < 2.2e-308) is no physical quantity: its reciprocal overflows */
  if (fpclassify(v) == FP_SUBNORMAL)
    return mo_case_error(cs, s, ctx, "value %g is subnormal (below 2.2e-308 in magnitude): its reciprocal "
                         "overflows; check the units", v);
  if (!isnan(K->lo) && (K->lo_open ? !(v > K->lo) : !(v >= K->lo))) bad = 1;
  if (!isnan(K->hi) && (K->hi_open ? !(v < K->hi) : !(v <= K->hi))) bad = 1;
  if (!bad) return MO_OK;
  fmt_range(K, r, sizeof r);
  if (!isfinite(v)) return mo_case_error(cs, s, ctx, "value %g is not finite", v);
  return mo_case_error(cs, s, ctx, "value %g is out of range %s%s%s", v, r, K->why ? ": " : "",
                       K->why ? K->why : "");
}

static int check_enum_item(const mo_case *cs, const config_setting_t *s, const mo_key *K,
                           const char *v, mo_ctx *ctx)
{
  char list[256], sug[64];
  if (!K->enums || enum_has(K->enums, v)) return MO_OK;
  enum_list(K->enums, list, sizeof list);
  if (enum_suggest(K->enums, v, sug, sizeof sug))
    return mo_case_error(cs, s, ctx, "'%s' is not one of: %s (did you mean '%s'?)", v, list, sug);
  return mo_case_error(cs, s, ctx, "'%s' is not one of: %s", v, list);
}

static int check_array_len(const mo_case *cs, const config_setting_t *s, const mo_key *K, int n,
                           mo_ctx *ctx)
{
  if (K->amin && n < K->amin)
    return mo_case_error(cs, s, ctx, "has %d element%s, needs at least %d", n, n == 1 ? "" : "s",
                         K->amin);
  if (K->amax && n > K->amax)
    return mo_case_error(cs, s, ctx, "has %d elements, at most %d allowed", n, K->amax);
  return MO_OK;
}

static int validate_group(const mo_case *cs, const config_setting_t *g, const char *spath,
                          mo_ctx *ctx);

static int validate_value(const mo_case *cs, const config_setting_t *s, const mo_key *K,
                          const char *spath, mo_ctx *ctx)
{
  int t = config_setting_type(s), n, i, st;
  switch (K->type) {
  case K_GROUP:
    if (t != CONFIG_TYPE_GROUP)
      return mo_case_error(cs, s, ctx, "must be a group { ... }, not %s", setting_type_name(s));
    return validate_group(cs, s, spath, ctx);
  case K_LIST:
    if (t != CONFIG_TYPE_LIST)
      return mo_case_error(cs, s, ctx, "must be a list ( { ... }, ... ), not %s", setting_type_name(s));
    n = config_setting_length(s);
    if ((st = check_array_len(cs, s, K, n, ctx))) return st;
    for (i = 0; i < n; i++) {
      const config_setting_t *e = config_setting_get_elem(s, (unsigned)i);
      char sub[512];
      if (config_setting_type(e) != CONFIG_TYPE_GROUP)
        return mo_case_error(cs, e, ctx, "must be a group { ... }, not %s", setting_type_name(e));
      snprintf(sub, sizeof sub, "%s.[]", spath);
      if ((st = validate_group(cs, e, sub, ctx))) return st;
    }
    return MO_OK;
  case K_FLOAT:
    if (!is_number(s)) return mo_case_error(cs, s, ctx, "must be a number, not %s", setting_type_name(s));
    return check_number(cs, s, K, s, ctx);
  case K_INT:
    if (!is_integer(s)) return mo_case_error(cs, s, ctx, "must be an integer, not %s", setting_type_name(s));
    return check_number(cs, s, K, s, ctx);
  case K_BOOL:
    if (t != CONFIG_TYPE_BOOL) return mo_case_error(cs, s, ctx, "must be true or false, not %s", setting_type_name(s));
    return MO_OK;
  case K_STRING:
  case K_ENUM:
    if (t != CONFIG_TYPE_STRING) return mo_case_error(cs, s, ctx, "must be a string, not %s", setting_type_name(s));
    if (K->type == K_STRING && !config_setting_get_string(s)[0] && K->required)
      return mo_case_error(cs, s, ctx, "must not be empty");
    return check_enum_item(cs, s, K, config_setting_get_string(s), ctx);
  case K_FEXPR:
    if (t == CONFIG_TYPE_STRING) return MO_OK; /* compiled (and checked) by its user */
    if (!is_number(s)) return mo_case_error(cs, s, ctx, "must be a number or an expression string, not %s", setting_type_name(s));
    return check_number(cs, s, K, s, ctx);
  case K_NUMS:
  case K_INTS:
  case K_FARRAY:
  case K_IARRAY:
  case K_SARRAY:
  case K_VEXPR: {
    int scalar_ok = K->type == K_NUMS || K->type == K_INTS || K->type == K_SARRAY || K->type == K_VEXPR;
    int want_int = K->type == K_INTS || K->type == K_IARRAY;
    int want_str = K->type == K_SARRAY;
    if (t != CONFIG_TYPE_ARRAY && t != CONFIG_TYPE_LIST) {
      if (!scalar_ok) return mo_case_error(cs, s, ctx, "must be an array [ ... ], not %s", setting_type_name(s));
      if (want_str) {
        if (t != CONFIG_TYPE_STRING) return mo_case_error(cs, s, ctx, "must be a string or an array of strings, not %s", setting_type_name(s));
        return check_enum_item(cs, s, K, config_setting_get_string(s), ctx);
      }
      if (K->type == K_VEXPR && t == CONFIG_TYPE_STRING) return MO_OK;
      if (want_int ? !is_integer(s) : !is_number(s))
        return mo_case_error(cs, s, ctx, "must be %s, not %s", want_int ? "an integer or an array of integers" : (K->type == K_VEXPR ? "a number, an expression string, or an array of them" : "a number or an array of numbers"), setting_type_name(s));
      return check_number(cs, s, K, s, ctx);
    }
    if (t == CONFIG_TYPE_LIST && K->type != K_VEXPR)
      return mo_case_error(cs, s, ctx, "must be an array [ ... ], not a list ( ... )");
    n = config_setting_length(s);
    if ((st = check_array_len(cs, s, K, n, ctx))) return st;
    for (i = 0; i < n; i++) {
      const config_setting_t *e = config_setting_get_elem(s, (unsigned)i);
      int et = config_setting_type(e);
      if (want_str) {
        if (et != CONFIG_TYPE_STRING) return mo_case_error(cs, s, ctx, "element %d must be a string, not %s", i, setting_type_name(e));
        if ((st = check_enum_item(cs, s, K, config_setting_get_string(e), ctx))) return st;
      } else if (K->type == K_VEXPR && et == CONFIG_TYPE_STRING) {
        continue;
      } else {
        if (want_int ? !is_integer(e) : !is_number(e))
          return mo_case_error(cs, s, ctx, "element %d must be %s, not %s", i, want_int ? "an integer" : "a number", setting_type_name(e));
        if ((st = check_number(cs, s, K, e, ctx))) return st;
      }
    }
    return MO_OK;
  }
  }
  return MO_OK;
}

typedef struct {
  const char *parent;
  const config_setting_t *g;
  const mo_case *cs;
  mo_ctx *ctx;
  int st;
} required_data;

static void required_visit(const char *path, const char *type, const char *range,
                           const char *deflt, const char *doc, void *data)
{
  required_data *R = data;
  size_t lp = strlen(R->parent);
  const char *child;
  (void)type; (void)range; (void)doc;
  if (R->st || !deflt || strcmp(deflt, "required")) return;
  if (lp) {
    if (strncmp(path, R->parent, lp) || path[lp] != '.') return;
    child = path + lp + 1;
  } else
    child = path;
  if (strchr(child, '.')) return;
  if (!config_setting_get_member(R->g, child)) {
    char where[600], gp[512];
    if (!config_setting_parent(R->g)) {
      R->st = mo_error(R->ctx, MO_EINPUT, "%s: required key '%s' is missing", R->cs->file, child);
      return;
    }
    mo_case_where(R->cs, R->g, where, sizeof where);
    mo_case_path(R->g, gp, sizeof gp);
    R->st = mo_error(R->ctx, MO_EINPUT, "%s: '%s' lacks the required key '%s'", where, gp, child);
  }
}

static int validate_group(const mo_case *cs, const config_setting_t *g, const char *spath,
                          mo_ctx *ctx)
{
  int n = config_setting_length(g), i, st;
  required_data R;
  for (i = 0; i < n; i++) {
    const config_setting_t *s = config_setting_get_elem(g, (unsigned)i);
    const char *name = config_setting_name(s);
    char sub[512], sug[128];
    mo_key K;
    snprintf(sub, sizeof sub, "%s%s%s", spath, spath[0] ? "." : "", name);
    if (!mo_schema_lookup(sub, &K, ctx)) {
      char where[600], gp[512];
      mo_case_where(cs, s, where, sizeof where);
      mo_case_path(g, gp, sizeof gp);
      if (suggest(spath, name, sug, sizeof sug, ctx))
        return mo_error(ctx, MO_EINPUT, "%s: unknown key '%s'%s%s%s (did you mean '%s'?)", where,
                        name, gp[0] ? " in '" : "", gp, gp[0] ? "'" : "", sug);
      return mo_error(ctx, MO_EINPUT, "%s: unknown key '%s'%s%s%s", where, name,
                      gp[0] ? " in '" : "", gp, gp[0] ? "'" : "");
    }
    if ((st = validate_value(cs, s, &K, sub, ctx))) return st;
  }
  R.parent = spath;
  R.g = g;
  R.cs = cs;
  R.ctx = ctx;
  R.st = 0;
  mo_case_schema_visit_ctx(required_visit, &R, ctx);
  return R.st;
}

/* The offset of the first byte of s that is not valid UTF-8 (RFC 3629: no overlong forms,
   no surrogates, at most U+10FFFF), or -1. */
static long utf8_bad(const char *str)
{
  const unsigned char *s = (const unsigned char *)str;
  long i = 0;
  while (s[i]) {
    unsigned c = s[i];
    int n = c < 0x80 ? 0 : (c & 0xe0) == 0xc0 ? 1 : (c & 0xf0) == 0xe0 ? 2 : (c & 0xf8) == 0xf0 ? 3 : -1, k;
    unsigned long cp;
    if (n < 0 || (n == 1 && c < 0xc2)) return i;
    cp = n == 0 ? c : c & (0x3fu >> n);
    for (k = 1; k <= n; k++) {
      if ((s[i + k] & 0xc0) != 0x80) return i;
      cp = cp << 6 | (s[i + k] & 0x3f);
    }
    if ((n == 2 && (cp < 0x800 || (cp >= 0xd800 && cp <= 0xdfff))) || (n == 3 && (cp < 0x10000 || cp > 0x10ffff)))
      return i;
    i += n + 1;
  }
  return -1;
}

/* Every string of the case is UTF-8 (summary.json and the VTK files are; a title in another
   encoding was dropped from summary.json). */
static int check_utf8(const mo_case *cs, const config_setting_t *g, mo_ctx *ctx)
{
  int t = config_setting_type(g), i, n, st;
  if (t == CONFIG_TYPE_STRING) {
    long at = utf8_bad(config_setting_get_string(g));
    if (at >= 0)
      return mo_case_error(cs, g, ctx, "is not valid UTF-8 (byte 0x%02x at offset %ld): save the case file as UTF-8",
                           (unsigned char)config_setting_get_string(g)[at], at);
    return MO_OK;
  }
  if (t != CONFIG_TYPE_GROUP && t != CONFIG_TYPE_LIST && t != CONFIG_TYPE_ARRAY) return MO_OK;
  n = config_setting_length(g);
  for (i = 0; i < n; i++)
    if ((st = check_utf8(cs, config_setting_get_elem(g, (unsigned)i), ctx))) return st;
  return MO_OK;
}

int mo_case_validate(mo_case *cs, mo_ctx *ctx)
{
  int st = check_utf8(cs, config_root_setting(&cs->cfg), ctx);
  return st ? st : validate_group(cs, config_root_setting(&cs->cfg), "", ctx);
}

/* --- overrides ------------------------------------------------------------------------------- */

/* Copy value of `src` (a parsed setting) into a new member `name` of `parent` (or a new element
   when name is NULL). */
static config_setting_t *copy_setting(config_setting_t *parent, const char *name,
                                      const config_setting_t *src)
{
  int t = config_setting_type(src), i, n;
  config_setting_t *d = config_setting_add(parent, name, t);
  if (!d) return NULL;
  switch (t) {
  case CONFIG_TYPE_INT: config_setting_set_int(d, config_setting_get_int(src)); break;
  case CONFIG_TYPE_INT64: config_setting_set_int64(d, config_setting_get_int64(src)); break;
  case CONFIG_TYPE_FLOAT: config_setting_set_float(d, config_setting_get_float(src)); break;
  case CONFIG_TYPE_BOOL: config_setting_set_bool(d, config_setting_get_bool(src)); break;
  case CONFIG_TYPE_STRING: config_setting_set_string(d, config_setting_get_string(src)); break;
  default:
    n = config_setting_length(src);
    for (i = 0; i < n; i++) {
      const config_setting_t *e = config_setting_get_elem(src, (unsigned)i);
      if (!copy_setting(d, t == CONFIG_TYPE_GROUP ? config_setting_name(e) : NULL, e)) return NULL;
    }
  }
  return d;
}

/* Find the element of list `l` whose member `name` equals `want`. */
static config_setting_t *list_by_name(config_setting_t *l, const char *want)
{
  int i, n = config_setting_length(l);
  for (i = 0; i < n; i++) {
    config_setting_t *e = config_setting_get_elem(l, (unsigned)i);
    const char *nm;
    if (config_setting_type(e) == CONFIG_TYPE_GROUP &&
        config_setting_lookup_string(e, "name", &nm) && !strcmp(nm, want))
      return e;
  }
  return NULL;
}

int mo_case_set(mo_case *cs, const char *assign, mo_ctx *ctx)
{
  const char *eq = strchr(assign, '=');
  char key[512], *comp, *save = NULL, *next;
  const char *val;
  config_t tmp;
  config_setting_t *cur, *src, *dst;
  char **sets;
  int st = MO_OK;
  if (!eq || eq == assign)
    return mo_error(ctx, MO_EINPUT, "--set %s: expected KEY=VALUE", assign);
  if ((size_t)(eq - assign) >= sizeof key)
    return mo_error(ctx, MO_EINPUT, "--set %s: key too long", assign);
  memcpy(key, assign, (size_t)(eq - assign));
  key[eq - assign] = '\0';
  val = eq + 1;
  {
    /* "nscd.tol=..." is short for "contact.nscd.tol=..." (a back end's options) */
    char first[64];
    const char *dot = strchr(key, '.');
    size_t l = dot ? (size_t)(dot - key) : 0;
    if (l && l < sizeof first) {
      memcpy(first, key, l);
      first[l] = '\0';
      if (mo_contact_solver_lookup(first, ctx) && strlen(key) + 9 < sizeof key) {
        memmove(key + 8, key, strlen(key) + 1);
        memcpy(key, "contact.", 8);
      }
    }
  }
  sets = mo_realloc(ctx, cs->sets, (size_t)(cs->nset + 1) * sizeof *sets);
  if (!sets) return MO_ENOMEM;
  cs->sets = sets;
  if (!(cs->sets[cs->nset] = mo_strdup(ctx, assign))) return MO_ENOMEM;
  cs->nset++;

  /* parse the value in case-file syntax; a bare word is a string */
  config_init(&tmp);
  {
    size_t n = strlen(val) + 16;
    char *text = mo_malloc(ctx, n + strlen(val) + 8);
    if (!text) { config_destroy(&tmp); return MO_ENOMEM; }
    snprintf(text, n, "v = %s;", val);
    if (!config_read_string(&tmp, text)) {
      int looks_structured = val[0] == '"' || val[0] == '[' || val[0] == '(' || val[0] == '{';
      if (looks_structured || !val[0]) {
        st = mo_error(ctx, MO_EINPUT, "--set %s: cannot read the value: %s", assign,
                      config_error_text(&tmp));
        mo_free(text);
        config_destroy(&tmp);
        return st;
      }
      config_destroy(&tmp);
      config_init(&tmp);
      config_setting_set_string(config_setting_add(config_root_setting(&tmp), "v", CONFIG_TYPE_STRING), val);
    }
    mo_free(text);
  }
  src = config_lookup(&tmp, "v");

  /* walk the path, creating groups where the schema has them */
  cur = config_root_setting(&cs->cfg);
  comp = strtok_r(key, ".", &save);
  while (comp) {
    config_setting_t *child = NULL;
    next = strtok_r(NULL, ".", &save);
    if (config_setting_type(cur) == CONFIG_TYPE_LIST) {
      if (comp[0] == '[') {
        char *end;
        long idx = strtol(comp + 1, &end, 10);
        if (*end != ']' || idx < 0 || idx >= config_setting_length(cur)) {
          st = mo_error(ctx, MO_EINPUT, "--set %s: no element %s in this list (it has %d)", assign,
                        comp, config_setting_length(cur));
          goto done;
        }
        child = config_setting_get_elem(cur, (unsigned)idx);
      } else {
        child = list_by_name(cur, comp);
        if (!child) {
          st = mo_error(ctx, MO_EINPUT, "--set %s: no element named '%s' in this list", assign, comp);
          goto done;
        }
      }
      if (!next) {
        st = mo_error(ctx, MO_EINPUT, "--set %s: cannot replace a whole list element", assign);
        goto done;
      }
      cur = child;
    } else if (config_setting_type(cur) == CONFIG_TYPE_GROUP) {
      child = config_setting_get_member(cur, comp);
      if (!next) {
        if (child) config_setting_remove(cur, comp);
        dst = copy_setting(cur, comp, src);
        if (!dst) {
          st = mo_error(ctx, MO_EINPUT, "--set %s: '%s' is not a valid key name", assign, comp);
          goto done;
        }
        cur = dst;
        break;
      }
      if (!child) {
        child = config_setting_add(cur, comp, CONFIG_TYPE_GROUP);
        if (!child) {
          st = mo_error(ctx, MO_EINPUT, "--set %s: '%s' is not a valid key name", assign, comp);
          goto done;
        }
      }
      cur = child;
    } else {
      st = mo_error(ctx, MO_EINPUT, "--set %s: '%s' is not inside a group or list", assign, comp);
      goto done;
    }
    comp = next;
  }

  /* validate the new value (and whatever was created on the way) against the schema */
  {
    char sp[512];
    mo_key K;
    config_setting_t *top = cur;
    /* climb to the outermost setting created by this override (no source line) */
    while (config_setting_parent(top) && config_setting_parent(config_setting_parent(top)) &&
           config_setting_source_line(config_setting_parent(top)) == 0)
      top = config_setting_parent(top);
    schema_path(top, sp, sizeof sp);
    if (!mo_schema_lookup(sp, &K, ctx)) {
      char parent[512], sug[128], *dot;
      const char *name = config_setting_name(top);
      snprintf(parent, sizeof parent, "%s", sp);
      dot = strrchr(parent, '.');
      if (dot) *dot = '\0'; else parent[0] = '\0';
      if (suggest(parent, name, sug, sizeof sug, ctx))
        st = mo_error(ctx, MO_EINPUT, "--set %s: unknown key '%s'%s%s%s (did you mean '%s'?)",
                      assign, name, parent[0] ? " in '" : "", parent, parent[0] ? "'" : "", sug);
      else
        st = mo_error(ctx, MO_EINPUT, "--set %s: unknown key '%s'%s%s%s", assign, name,
                      parent[0] ? " in '" : "", parent, parent[0] ? "'" : "");
      goto done;
    }
    st = validate_value(cs, top, &K, sp, ctx);
  }
done:
  config_destroy(&tmp);
  return st;
}

/* --- typed reads ------------------------------------------------------------------------------ */

const config_setting_t *mo_cfg_member(const config_setting_t *g, const char *name)
{
  return g ? config_setting_get_member(g, name) : NULL;
}

double mo_cfg_float(const config_setting_t *g, const char *name, double dflt)
{
  const config_setting_t *s = mo_cfg_member(g, name);
  return s && is_number(s) ? num_value(s) : dflt;
}

int mo_cfg_int(const config_setting_t *g, const char *name, int dflt)
{
  const config_setting_t *s = mo_cfg_member(g, name);
  return s && is_integer(s) ? (int)num_value(s) : dflt;
}

int mo_cfg_bool(const config_setting_t *g, const char *name, int dflt)
{
  const config_setting_t *s = mo_cfg_member(g, name);
  return s && config_setting_type(s) == CONFIG_TYPE_BOOL ? config_setting_get_bool(s) : dflt;
}

const char *mo_cfg_string(const config_setting_t *g, const char *name, const char *dflt)
{
  const config_setting_t *s = mo_cfg_member(g, name);
  return s && config_setting_type(s) == CONFIG_TYPE_STRING ? config_setting_get_string(s) : dflt;
}

int mo_cfg_count(const config_setting_t *g, const char *name)
{
  const config_setting_t *s = mo_cfg_member(g, name);
  int t;
  if (!s) return 0;
  t = config_setting_type(s);
  return t == CONFIG_TYPE_ARRAY || t == CONFIG_TYPE_LIST ? config_setting_length(s) : 1;
}

static const config_setting_t *item_at(const config_setting_t *g, const char *name, int i)
{
  const config_setting_t *s = mo_cfg_member(g, name);
  int t;
  if (!s) return NULL;
  t = config_setting_type(s);
  if (t == CONFIG_TYPE_ARRAY || t == CONFIG_TYPE_LIST) return config_setting_get_elem(s, (unsigned)i);
  return i == 0 ? s : NULL;
}

double mo_cfg_num_at(const config_setting_t *g, const char *name, int i)
{
  const config_setting_t *e = item_at(g, name, i);
  return e && is_number(e) ? num_value(e) : NAN;
}

const char *mo_cfg_expr_at(const config_setting_t *g, const char *name, int i, char *buf, size_t n)
{
  const config_setting_t *e = item_at(g, name, i);
  if (!e) return NULL;
  if (config_setting_type(e) == CONFIG_TYPE_STRING) return config_setting_get_string(e);
  snprintf(buf, n, "%.17g", num_value(e));
  return buf;
}

const char *mo_cfg_string_at(const config_setting_t *g, const char *name, int i)
{
  const config_setting_t *e = item_at(g, name, i);
  return e && config_setting_type(e) == CONFIG_TYPE_STRING ? config_setting_get_string(e) : NULL;
}

int mo_case_lookup_float(const mo_case *cs, const char *path, double *v)
{
  const config_setting_t *s = config_lookup(&cs->cfg, path);
  if (!s || !is_number(s)) return 0;
  *v = num_value(s);
  return 1;
}

int mo_case_lookup_int(const mo_case *cs, const char *path, int *v)
{
  const config_setting_t *s = config_lookup(&cs->cfg, path);
  if (!s || !is_integer(s)) return 0;
  *v = (int)num_value(s);
  return 1;
}

int mo_case_lookup_bool(const mo_case *cs, const char *path)
{
  const config_setting_t *s = config_lookup(&cs->cfg, path);
  return s && config_setting_type(s) == CONFIG_TYPE_BOOL && config_setting_get_bool(s);
}

int mo_case_lookup_string(const mo_case *cs, const char *path, const char **v)
{
  const config_setting_t *s = config_lookup(&cs->cfg, path);
  if (!s || config_setting_type(s) != CONFIG_TYPE_STRING) return 0;
  *v = config_setting_get_string(s);
  return 1;
}

/* --- JSON ------------------------------------------------------------------------------------- */

static json_t *to_json(const config_setting_t *s)
{
  int t = config_setting_type(s), i, n;
  json_t *j;
  switch (t) {
  case CONFIG_TYPE_INT: return json_integer(config_setting_get_int(s));
  case CONFIG_TYPE_INT64: return json_integer(config_setting_get_int64(s));
  case CONFIG_TYPE_FLOAT: return json_real(config_setting_get_float(s));
  case CONFIG_TYPE_BOOL: return json_boolean(config_setting_get_bool(s));
  case CONFIG_TYPE_STRING: return json_string(config_setting_get_string(s));
  case CONFIG_TYPE_GROUP:
    j = json_object();
    n = config_setting_length(s);
    for (i = 0; i < n; i++) {
      const config_setting_t *e = config_setting_get_elem(s, (unsigned)i);
      json_object_set_new(j, config_setting_name(e), to_json(e));
    }
    return j;
  default:
    j = json_array();
    n = config_setting_length(s);
    for (i = 0; i < n; i++) json_array_append_new(j, to_json(config_setting_get_elem(s, (unsigned)i)));
    return j;
  }
}

json_t *mo_case_to_json(const mo_case *cs)
{
  return to_json(config_root_setting(&cs->cfg));
}
