/* registry.c: the explicit table of contact back ends (doc/architecture.md §5). A new back end is
   one folder under solvers/ and one line here; back ends built outside moreau are loaded at run
   time into the context (plugin.c) and found after these. */
#include "config.h"
#include <moreau/moreau.h>
#include <moreau/contact.h>
#include <moreau/case.h>
#include <moreau/backend.h>

#include <string.h>

extern const mo_contact_solver_type mo_contact_solver_nscd;
extern const mo_contact_solver_type mo_contact_solver_levelset;
extern const mo_contact_solver_type mo_contact_solver_newmark;

static const mo_contact_solver_type *const registry[] = {
  &mo_contact_solver_nscd,
  &mo_contact_solver_levelset,
  &mo_contact_solver_newmark,
  NULL /* end */
};

int mo_contact_solver_count(void)
{
  return (int)(sizeof registry / sizeof registry[0]) - 1;
}

const mo_contact_solver_type *mo_contact_solver_at(int i)
{
  return i >= 0 && i < mo_contact_solver_count() ? registry[i] : NULL;
}

const mo_contact_solver_type *mo_contact_solver_find(const char *name)
{
  int i;
  for (i = 0; i < mo_contact_solver_count(); i++)
    if (!strcmp(registry[i]->name, name)) return registry[i];
  return NULL;
}

const mo_contact_solver_type *mo_contact_solver_lookup(const char *name, const mo_ctx *ctx)
{
  const mo_contact_solver_type *T = mo_contact_solver_find(name);
  int i;
  for (i = 0; !T && i < mo_plugin_count(ctx); i++)
    if (!strcmp(mo_plugin_type(ctx, i)->name, name)) T = mo_plugin_type(ctx, i);
  return T;
}

int mo_contact_solver_total(const mo_ctx *ctx)
{
  return mo_contact_solver_count() + mo_plugin_count(ctx);
}

const mo_contact_solver_type *mo_contact_solver_nth(int i, const mo_ctx *ctx)
{
  return i < mo_contact_solver_count() ? mo_contact_solver_at(i) : mo_plugin_type(ctx, i - mo_contact_solver_count());
}

int mo_cli_list_solvers(FILE *out)
{
  int i;
  if (!mo_contact_solver_count()) fprintf(out, "no contact back ends are registered in this build\n");
  for (i = 0; i < mo_contact_solver_count(); i++)
    fprintf(out, "%-10s %s\n", registry[i]->name, registry[i]->summary);
  fprintf(out, "\npresets (--solver BACKEND:PRESET; any back end or preset takes [KEY=VALUE;...]):\n");
  for (i = 0; i < mo_preset_count(); i++) {
    const char *sum, *nm = mo_preset_name(i, &sum);
    fprintf(out, "%-22s %s\n", nm, sum);
  }
  return 0;
}
