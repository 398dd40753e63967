/* case_internal.h: the case reader's private view (libconfig settings, locations, schema). */
#ifndef MOREAU_CASE_INTERNAL_H
#define MOREAU_CASE_INTERNAL_H

#include <libconfig.h>

#include <moreau/case.h>

struct mo_case {
  config_t cfg;
  char *file; /* as given (for messages) */
  char *dir;  /* folder of the file */
  int nset;   /* overrides applied */
  char **sets;
};

typedef enum {
  K_GROUP,  /* group */
  K_LIST,   /* list of groups */
  K_FLOAT,  /* number (integers accepted) */
  K_INT,    /* integer */
  K_BOOL,
  K_STRING,
  K_ENUM,   /* string out of enums */
  K_FARRAY, /* array of numbers */
  K_IARRAY, /* array of integers */
  K_SARRAY, /* array of strings (from enums when enums is set); a single string accepted */
  K_NUMS,   /* a number or an array of numbers */
  K_INTS,   /* an integer or an array of integers */
  K_FEXPR,  /* a number or an expression string */
  K_VEXPR   /* a number, an expression string, or an array of them */
} mo_key_type;

typedef struct {
  const char *path;   /* "bodies.[].material.E"; "[]" stands for any list element */
  mo_key_type type;
  const char *enums;  /* "a|b|c" */
  double lo, hi;      /* numeric range (NaN: unbounded) */
  unsigned char lo_open, hi_open;
  int amin, amax;     /* array length range (0: unbounded) */
  unsigned char required;
  const char *deflt;
  const char *doc;
  const char *why;    /* sentence appended to range errors ("Poisson's ratio ...") */
} mo_key;

/* Schema lookup: the core's keys and each contact back end's option keys (from the registry, so
   a new back end's options are validated and documented at once, and from the plug-ins loaded
   into ctx, which may be NULL). 1 when found. */
int mo_schema_lookup(const char *path, mo_key *out, const mo_ctx *ctx);

/* Location of a setting: "FILE:LINE" for a setting read from the file, "--set" for one created
   by an override. */
void mo_case_where(const mo_case *cs, const config_setting_t *s, char *buf, size_t n);
/* Path of a setting in libconfig syntax ("bodies.[0].material.E"). */
void mo_case_path(const config_setting_t *s, char *buf, size_t n);
/* Record an error located at setting s: "FILE:LINE: key 'PATH': <message>". */
int mo_case_error(const mo_case *cs, const config_setting_t *s, mo_ctx *ctx, const char *fmt,
                  ...) __attribute__((format(printf, 4, 5)));

/* Typed reads of an already validated group member (defaults when absent). */
const config_setting_t *mo_cfg_member(const config_setting_t *g, const char *name);
double mo_cfg_float(const config_setting_t *g, const char *name, double dflt);
int mo_cfg_int(const config_setting_t *g, const char *name, int dflt);
int mo_cfg_bool(const config_setting_t *g, const char *name, int dflt);
const char *mo_cfg_string(const config_setting_t *g, const char *name, const char *dflt);
/* Number of values of a K_NUMS / K_INTS / K_VEXPR / K_SARRAY member (1 for a scalar, 0 absent),
   and the i-th one. */
int mo_cfg_count(const config_setting_t *g, const char *name);
double mo_cfg_num_at(const config_setting_t *g, const char *name, int i);
/* The i-th element as an expression source (a number is printed with full precision). */
const char *mo_cfg_expr_at(const config_setting_t *g, const char *name, int i, char *buf,
                           size_t n);
const char *mo_cfg_string_at(const config_setting_t *g, const char *name, int i);

/* Settings after overrides as a JSON object (for summary.json). */
struct json_t;
struct json_t *mo_case_to_json(const mo_case *cs);

#endif
