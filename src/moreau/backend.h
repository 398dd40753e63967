/* moreau/backend.h: what a contact back end built outside moreau includes, and what a program
   that loads such back ends calls (doc/backends.md). A plug-in is a shared library exporting one
   object, MO_PLUGIN_SYMBOL, that names its mo_contact_solver_type (moreau/contact.h); moreau
   loads it by file or by name (--plugin, MOREAU_PLUGIN_PATH) and selects it by its type's name,
   like the back ends it ships. */
#ifndef MOREAU_BACKEND_H
#define MOREAU_BACKEND_H

#include <stddef.h>
#include <stdio.h>

#include <moreau/ctx.h>
#include <moreau/contact.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The version of the back-end contract: raised whenever the meaning of a member of
   mo_contact_solver_type, mo_contact_problem, mo_contact_vars, mo_contact_report or
   mo_option_spec changes, or a service a back end calls changes its signature. A plug-in built
   against another version is refused. Layout changes are caught apart (the sizes below). */
#define MO_PLUGIN_ABI 1

/* The name of the one object a plug-in exports. */
#define MO_PLUGIN_SYMBOL "mo_plugin_backend"

/* The sizes of the contract's structs as the plug-in saw them when it was built. */
#define MO_PLUGIN_NSIZES 6
#define MO_PLUGIN_SIZES                                                                        \
  { sizeof(mo_contact_solver_type), sizeof(mo_contact_problem), sizeof(mo_contact_vars),       \
    sizeof(mo_contact_report), sizeof(mo_option_spec), sizeof(mo_ctx) }

typedef struct mo_plugin_entry {
  unsigned abi;                       /* MO_PLUGIN_ABI of the headers the plug-in was built with */
  size_t sizes[MO_PLUGIN_NSIZES];     /* MO_PLUGIN_SIZES of those headers */
  const mo_contact_solver_type *type; /* the back end */
} mo_plugin_entry;

/* In the plug-in's one source file that defines the type object T:
     MO_PLUGIN(my_backend_type);
   defines and exports the entry moreau looks for. */
#define MO_PLUGIN(T)                                                                           \
  __attribute__((visibility("default"))) const mo_plugin_entry mo_plugin_backend = {           \
    MO_PLUGIN_ABI, MO_PLUGIN_SIZES, &(T) }

/* --- loading (the host's side) ------------------------------------------------------------------
   Loaded back ends belong to the context that loaded them (ctx->plugins): copies of the context
   share them (the runs of a comparison), mo_ctx_release unloads them. */

/* Load one plug-in: SPEC is a file (it holds a '/' or ends in ".so") or a name NAME, looked for
   as NAME.so in the plug-in folders (mo_plugin_folders). Refused with MO_EINPUT and a sentence
   naming the file: one that does not load, lacks MO_PLUGIN_SYMBOL, was built for another ABI
   or other struct sizes, or whose type is incomplete (no name, init, solve or free; options
   outside the parameter struct; unknown capability or scheme bits) or names a back end that
   exists already. Loading the same file twice is a no-op. */
int mo_plugin_load(mo_ctx *ctx, const char *spec);
/* Load every *.so of the folders of a colon-separated list (NULL: mo_plugin_folders), in name
   order. A file that is refused does not stop the others: its reason is kept and repeated when
   a run asks for a back end that is not there (mo_plugin_failures); *nloaded (may be NULL)
   counts the back ends loaded. Missing folders are skipped. Returns MO_ENOMEM only. */
int mo_plugin_scan(mo_ctx *ctx, const char *folders, int *nloaded);
/* The plug-in folders: $MOREAU_PLUGIN_PATH when it is set (colon-separated, may be empty),
   else the folder the library was installed with (pkg-config --variable=plugindir moreau). */
const char *mo_plugin_folders(void);
const char *mo_plugin_default_folder(void);
/* The plug-ins loaded into ctx: their number, the i-th's type and file. */
int mo_plugin_count(const mo_ctx *ctx);
const mo_contact_solver_type *mo_plugin_type(const mo_ctx *ctx, int i);
const char *mo_plugin_file(const mo_ctx *ctx, int i);
/* What mo_plugin_scan refused, one "file: reason" per line ("" when nothing was). */
const char *mo_plugin_failures(const mo_ctx *ctx);
/* Check a type object as mo_plugin_load does (tests; `file` names it in the message). */
int mo_plugin_check_type(const mo_contact_solver_type *T, const char *file, const mo_ctx *loaded,
                         mo_ctx *ctx);
/* `moreau list-solvers`: the loaded plug-ins, each with its file and options. */
void mo_plugin_print(FILE *out, const mo_ctx *ctx);

/* --- lookup: the registry's back ends, then the context's plug-ins ------------------------------ */

/* The back end named `name` (ctx NULL: the registry alone). */
const mo_contact_solver_type *mo_contact_solver_lookup(const char *name, const mo_ctx *ctx);
/* Every back end the context sees: the registry's first, then the plug-ins. */
int mo_contact_solver_total(const mo_ctx *ctx);
const mo_contact_solver_type *mo_contact_solver_nth(int i, const mo_ctx *ctx);

#ifdef __cplusplus
}
#endif
#endif
