/* registry.c: the explicit table of contact back ends (ARCHITECTURE.md §3). */
#include "config.h"
#include <moreau/moreau.h>

int mo_cli_list_solvers(FILE *out)
{
  fprintf(out, "no contact back ends are registered in this build\n");
  return 0;
}
