/* preset.c: formulations, not only solvers. A back-end spec names a back end, optionally one of
   its papers' settings, and optionally overrides that make it a distinct labelled entry:

     nscd                      the back end, the case's own settings
     levelset:bdz07            the back end in a paper's setting (a preset: a list of --set)
     nscd[theta=0.5]           any --set, written inside brackets (';' or ',' between them)
     nscd:jean88[nscd.tol=1e-10]

   A preset is the list below, then the case's own `presets` entry of the same name (the
   per-scene parameters of a paper, e.g. the Newmark (beta, gamma) of each BDZ07 figure), which
   may also define new names. The order of application is: contact.solver, the preset, the run's
   --set (compare's time step and grid point among them), the bracketed overrides last: the
   bracket is the entry's identity. doc/theory.md §10.2 says what each preset means. */
#include "config.h"
#include "case_internal.h"
#include <moreau/contact.h>
#include <moreau/backend.h>

#include <stdio.h>
#include <string.h>

typedef struct {
  const char *name;    /* "backend:preset" */
  const char *summary; /* one line for list-solvers */
  const char *sets[12]; /* time.* keys apply to theta-scheme runs only */
  int per_case;         /* the values are the case's: its `presets` entry is required */
} preset;

/* Every preset pins every key of its formulation, so that a change of the program's defaults
   does not change what a preset compares. */
static const preset presets[] = {
  {"levelset:bdz07",
   "Ben Dhia-Zammali 2007 §5-6: theta = 1 (implicit Euler, (50)-(52)), Signorini-Moreau at the "
   "velocity level ((23)-(29)), the Lagrangian formulation k_n = 0, h_n and rho_n automatic",
   {"time.theta=1.0", "time.theta_f=1.0", "contact.signorini=velocity", "contact.levelset.k_n=0.0", "contact.levelset.h_n=0.0", "contact.levelset.rho_n=0.0",
    "contact.levelset.su=index_set", NULL}, 0},
  {"nscd:jean88",
   "Jean 1988 §3.2-3.3: X(i+1) = X(i) + h V(i+1) (theta = 1), the unilateral condition on "
   "U_N + q_N(i)/h ((3.2)_1, position level), reactions concentrated at the nodes",
   {"time.theta=1.0", "time.theta_f=1.0", "contact.signorini=position", "contact.reactions=concentrated", NULL}, 0},
  {"nscd:jean88-weighted",
   "Jean 1988 §4.4: as nscd:jean88 with the P-weighted reactions H_n, H_t",
   {"time.theta=1.0", "time.theta_f=1.0", "contact.signorini=position", "contact.reactions=weighted", NULL}, 0},
  {"newmark:bdz07",
   "the seeds' displacement-based Lagrangian with a dissipative Newmark scheme, (beta, gamma) of the "
   "paper's figure from the case's `presets` entry: (0.3025, 0.6) rods, (0.4, 0.7) cylinder, (0.49, 0.9) Taylor",
   {NULL}, 1},
};
#define NPRESET ((int)(sizeof presets / sizeof presets[0]))

int mo_preset_count(void) { return NPRESET; }

const char *mo_preset_name(int i, const char **summary)
{
  if (i < 0 || i >= NPRESET) return NULL;
  if (summary) *summary = presets[i].summary;
  return presets[i].name;
}

/* The case's `presets` entry named name, or NULL. */
static config_setting_t *case_preset(const mo_case *cs, const char *name)
{
  config_setting_t *L = config_lookup(&cs->cfg, "presets");
  int i, n = L ? config_setting_length(L) : 0;
  for (i = 0; i < n; i++) {
    config_setting_t *e = config_setting_get_elem(L, (unsigned)i);
    const char *nm = NULL;
    if (config_setting_lookup_string(e, "name", &nm) && !strcmp(nm, name)) return e;
  }
  return NULL;
}

/* One assignment of a spec, with the spec named in the error. */
static int spec_set(mo_case *cs, const char *spec, const char *assign, mo_ctx *ctx)
{
  int st = mo_case_set(cs, assign, ctx);
  if (st) {
    char msg[MO_ERRMSG_MAX];
    snprintf(msg, sizeof msg, "%s", ctx->errmsg);
    mo_ctx_clear_error(ctx);
    st = mo_error(ctx, MO_EINPUT, "--solver %s: %s", spec, msg);
  }
  return st;
}

/* A bracketed key without a dot: time.KEY, contact.KEY or contact.BACKEND.KEY, the one the
   schema knows (theta, theta_f, dt; signorini, reactions; tol, max_sweeps, k_n, ...). */
static int resolve_key(const char *base, const char *key, char *out, size_t nout, const mo_ctx *ctx)
{
  const char *pre[3] = {"time.", "contact.", NULL};
  char b[96];
  mo_key K;
  int i;
  if (strchr(key, '.')) return snprintf(out, nout, "%s", key) < (int)nout ? 0 : -1;
  snprintf(b, sizeof b, "contact.%s.", base);
  pre[2] = b;
  for (i = 0; i < 3; i++) {
    if (snprintf(out, nout, "%s%s", pre[i], key) >= (int)nout) return -1;
    if (mo_schema_lookup(out, &K, ctx)) return 0;
  }
  return -1;
}

int mo_solver_spec_apply(mo_case *cs, const char *spec, const char *const *sets, int nset, mo_ctx *ctx)
{
  char base[64], name[160], over[1024], assign[1200];
  const char *colon, *brk, *end;
  size_t lb;
  int st, k;
  brk = strchr(spec, '[');
  end = brk ? brk : spec + strlen(spec);
  colon = memchr(spec, ':', (size_t)(end - spec));
  lb = (size_t)((colon ? colon : end) - spec);
  if (!lb || lb >= sizeof base || (size_t)(end - spec) >= sizeof name)
    return mo_error(ctx, MO_EINPUT, "--solver %s: expected BACKEND[:PRESET][[KEY=VALUE;...]] (see moreau list-solvers)", spec);
  memcpy(base, spec, lb);
  base[lb] = '\0';
  memcpy(name, spec, (size_t)(end - spec));
  name[end - spec] = '\0';
  over[0] = '\0';
  if (brk) {
    size_t lo = strlen(brk);
    if (lo < 2 || brk[lo - 1] != ']' || lo - 2 >= sizeof over)
      return mo_error(ctx, MO_EINPUT, "--solver %s: the overrides go inside one pair of brackets at the end, "
                      "e.g. nscd[theta=0.5;nscd.tol=1e-10]", spec);
    memcpy(over, brk + 1, lo - 2);
    over[lo - 2] = '\0';
  }
  if (!mo_contact_solver_lookup(base, ctx))
    return mo_error(ctx, MO_EINPUT, "--solver %s: no back end '%s' (moreau list-solvers names them; a plug-in's "
                    "is loaded by --plugin)%s%s", spec, base, mo_plugin_failures(ctx)[0] ? "; plug-ins refused: " : "",
                    mo_plugin_failures(ctx));
  snprintf(assign, sizeof assign, "contact.solver=%s", base);
  if ((st = spec_set(cs, spec, assign, ctx))) return st;

  /* the preset: the program's list, then the case's entry of the same name */
  if (colon) {
    const preset *P = NULL;
    config_setting_t *E = case_preset(cs, name);
    for (k = 0; k < NPRESET; k++)
      if (!strcmp(presets[k].name, name)) P = &presets[k];
    if (!P && !E) {
      char known[512] = "";
      for (k = 0; k < NPRESET; k++)
        if (!strncmp(presets[k].name, base, lb) && presets[k].name[lb] == ':')
          snprintf(known + strlen(known), sizeof known - strlen(known), "%s%s", known[0] ? ", " : "", presets[k].name);
      return mo_error(ctx, MO_EINPUT, "--solver %s: no preset '%s' in the program or in the case's `presets`%s%s%s",
                      spec, name, known[0] ? " (the program has " : "", known, known[0] ? ")" : "");
    }
    if (P && P->per_case && !E)
      return mo_error(ctx, MO_EINPUT, "--solver %s: the case gives no parameters for '%s' (a `presets` entry of that "
                      "name: the values of the paper's figure for this scene)", spec, name);
    for (k = 0; P && P->sets[k]; k++) {
      const char *scheme = "theta";
      mo_case_lookup_string(cs, "time.scheme", &scheme);
      if (!strncmp(P->sets[k], "time.", 5) && strcmp(scheme, "theta")) continue; /* a quasi-static case stays one */
      if ((st = spec_set(cs, spec, P->sets[k], ctx))) return st;
    }
    if (E) {
      config_setting_t *S = config_setting_lookup(E, "set");
      int i, n = S ? (config_setting_is_array(S) ? config_setting_length(S) : 1) : 0;
      for (i = 0; i < n; i++) {
        const char *a = config_setting_is_array(S) ? config_setting_get_string_elem(S, (unsigned)i) : config_setting_get_string(S);
        if (a && (st = spec_set(cs, spec, a, ctx))) return st;
      }
    }
  }
  /* the run's own --set */
  for (k = 0; k < nset; k++)
    if ((st = mo_case_set(cs, sets[k], ctx))) return st;
  /* the bracket: KEY=VALUE separated by ';' or ',' outside brackets and quotes */
  if (over[0]) {
    char *p = over, *start = over;
    int depth = 0, quote = 0;
    for (;; p++) {
      if (*p == '"') quote = !quote;
      else if (!quote && (*p == '[' || *p == '(')) depth++;
      else if (!quote && (*p == ']' || *p == ')')) depth--;
      else if (*p == '\0' || ((*p == ';' || *p == ',') && !depth && !quote)) {
        int last = *p == '\0';
        char key[256], full[300];
        const char *eq;
        *p = '\0';
        eq = strchr(start, '=');
        if (!eq || eq == start || (size_t)(eq - start) >= sizeof key)
          return mo_error(ctx, MO_EINPUT, "--solver %s: '%s' inside the brackets is not KEY=VALUE", spec, start);
        memcpy(key, start, (size_t)(eq - start));
        key[eq - start] = '\0';
        if (resolve_key(base, key, full, sizeof full, ctx))
          return mo_error(ctx, MO_EINPUT, "--solver %s: unknown key '%s' (a full key, or one of time.%s, contact.%s, "
                          "contact.%s.%s)", spec, key, key, key, base, key);
        snprintf(assign, sizeof assign, "%s=%s", full, eq + 1);
        if ((st = spec_set(cs, spec, assign, ctx))) return st;
        if (last) break;
        start = p + 1;
      }
    }
  }
  return MO_OK;
}
