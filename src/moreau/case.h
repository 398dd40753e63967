/* moreau/case.h: case files (libconfig syntax): loading, overrides, validation. */
#ifndef MOREAU_CASE_H
#define MOREAU_CASE_H

#include <moreau/ctx.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mo_case mo_case;

/* Load a case: `path` is a case folder (holding case.cfg) or a file. Syntax errors come back as
   MO_EINPUT with "FILE:LINE: <libconfig's message>". Nothing is validated yet. */
int mo_case_load(const char *path, mo_case **out, mo_ctx *ctx);
/* Load from a string (tests, fuzzing); `name` stands for the file name in messages. */
int mo_case_load_string(const char *text, const char *name, mo_case **out, mo_ctx *ctx);
/* Apply one override "key=value" (the argument of --set). Keys use libconfig paths
   ("time.dt", "bodies.[0].material.E") and may name list elements by their `name` member
   ("bodies.bar.material.E"). Values use case-file syntax; a bare word is taken as a string.
   The new value is validated at once against the schema ("--set KEY=VALUE: ..."). */
int mo_case_set(mo_case *cs, const char *assignment, mo_ctx *ctx);
/* Validate every key against the schema: unknown keys (with a suggestion), types, ranges,
   required keys. Messages: "FILE:LINE: ...". */
int mo_case_validate(mo_case *cs, mo_ctx *ctx);
/* File the case was read from and the folder holding it (for relative paths). */
const char *mo_case_file(const mo_case *cs);
const char *mo_case_dir(const mo_case *cs);
/* Convenience lookups by libconfig path (after validation). Return 1 when present. */
int mo_case_lookup_float(const mo_case *cs, const char *path, double *v);
int mo_case_lookup_int(const mo_case *cs, const char *path, int *v);
int mo_case_lookup_string(const mo_case *cs, const char *path, const char **v);
/* 1 when the boolean at path is present and true. */
int mo_case_lookup_bool(const mo_case *cs, const char *path);
void mo_case_free(mo_case *cs);

/* A back-end spec BACKEND[:PRESET][[KEY=VALUE;...]] (--solver, compare's --solvers): sets
   contact.solver, applies the preset (the program's, then the case's `presets` entry of the same
   name), then sets[0..nset), then the bracketed overrides (keys without a dot are looked up as
   time.KEY, contact.KEY, contact.BACKEND.KEY). Errors name the spec. */
int mo_solver_spec_apply(mo_case *cs, const char *spec, const char *const *sets, int nset, mo_ctx *ctx);
/* The program's presets, for list-solvers: name of the i-th (NULL past the end), its summary. */
int mo_preset_count(void);
const char *mo_preset_name(int i, const char **summary);

/* The schema, for `moreau keys` and the documentation check: calls fn for every key. */
typedef void (*mo_key_visit)(const char *path, const char *type, const char *range,
                             const char *deflt, const char *doc, void *data);
void mo_case_schema_visit(mo_key_visit fn, void *data);
/* The same, with the options of the plug-ins loaded into ctx after the registry's back ends'. */
void mo_case_schema_visit_ctx(mo_key_visit fn, void *data, const mo_ctx *ctx);

#ifdef __cplusplus
}
#endif
#endif
