/* plugin_bad.c: plug-ins that moreau must refuse with a clear message (tests/test_plugin.sh),
   one per macro: BAD_ABI (another contract version), BAD_SIZES (other struct sizes), NO_ENTRY
   (no mo_plugin_backend), NO_SOLVE (a type without solve), BAD_OPTION (an option stored past
   the parameter struct), CLASH (the name of a shipped back end), NULL_TYPE (an entry without a
   type), BAD_SCHEMES (no time scheme). Without a macro it is a valid back end that never
   closes a contact ("bad-open"). */
#include <moreau/backend.h>

#include <stddef.h>
#include <string.h>

typedef struct {
  double x;
} bad_params;

static void bad_defaults(void *p) { ((bad_params *)p)->x = 1; }

static const mo_option_spec bad_options[] = {
#ifdef BAD_OPTION
  {"x", MO_OPT_DOUBLE, sizeof(bad_params), NULL, 0, 1, "1", "A value stored past the struct."},
#else
  {"x", MO_OPT_DOUBLE, offsetof(bad_params, x), NULL, 0, 1, "1", "A value."},
#endif
};

static int bad_init(void *state, const void *params, const mo_contact_problem *P, mo_ctx *ctx)
{
  (void)state, (void)params, (void)P, (void)ctx;
  return MO_OK;
}

static int bad_solve(void *state, const mo_contact_problem *P, mo_contact_vars *x, mo_contact_report *rep,
                     mo_ctx *ctx)
{
  (void)state, (void)ctx;
  memset(x->r, 0, (size_t)P->m * sizeof *x->r);
  memcpy(x->U, P->b, (size_t)P->m * sizeof *x->U);
  memset(x->status, 0, (size_t)P->nc * sizeof *x->status);
  rep->reason = MO_CR_CONVERGED;
  return MO_OK;
}

static void bad_free(void *state) { (void)state; }

static const mo_contact_solver_type bad_type = {
#ifdef CLASH
  "nscd",
#else
  "bad-open",
#endif
  "a back end that never closes a contact (tests)",
  1,
  sizeof(bad_params),
  MO_NEEDS_DELASSUS,
#ifdef BAD_SCHEMES
  0,
#else
  1u << MO_SCHEME_THETA,
#endif
  bad_options,
  1,
  bad_defaults,
  bad_init,
#ifdef NO_SOLVE
  NULL,
#else
  bad_solve,
#endif
  bad_free,
  NULL,
  NULL};

#if defined BAD_ABI
__attribute__((visibility("default"))) const mo_plugin_entry mo_plugin_backend = {MO_PLUGIN_ABI + 1, MO_PLUGIN_SIZES,
                                                                                  &bad_type};
#elif defined BAD_SIZES
__attribute__((visibility("default"))) const mo_plugin_entry mo_plugin_backend = {
  MO_PLUGIN_ABI, {sizeof(mo_contact_solver_type), sizeof(mo_contact_problem) - 8, sizeof(mo_contact_vars),
                  sizeof(mo_contact_report), sizeof(mo_option_spec), sizeof(mo_ctx)}, &bad_type};
#elif defined NULL_TYPE
__attribute__((visibility("default"))) const mo_plugin_entry mo_plugin_backend = {MO_PLUGIN_ABI, MO_PLUGIN_SIZES, NULL};
const void *bad_unused = &bad_type;
#elif defined NO_ENTRY
__attribute__((visibility("default"))) const mo_contact_solver_type *mo_plugin_backend_typo = &bad_type;
#else
MO_PLUGIN(bad_type);
#endif
