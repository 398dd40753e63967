/* scene_internal.h: the scene reader's helpers shared by the kinds of body (body_fe.c,
   body_rigid.c) and scene.c. Private to the core. */
#ifndef MOREAU_SCENE_INTERNAL_H
#define MOREAU_SCENE_INTERNAL_H

#include <moreau/body.h>
#include "case_internal.h"

/* Compile member `name` of g (its i-th value: a number or an expression) with the given
   variables; *e is NULL when the member is absent. */
int mo_scene_compile(const mo_case *cs, const config_setting_t *g, const char *name, int i,
                     const char *const *vars, int nvar, mo_expr **e, mo_ctx *ctx);
/* Errors located at g when key is missing, or does not hold n values. */
int mo_scene_need(const mo_case *cs, const config_setting_t *g, const char *key, const char *why,
                  mo_ctx *ctx);
int mo_scene_need_len(const mo_case *cs, const config_setting_t *g, const char *key, int n,
                      const char *why, mo_ctx *ctx);
/* Re-locate the last error (raised by a lower layer) at setting s. */
int mo_scene_relocate(const mo_case *cs, const config_setting_t *s, mo_ctx *ctx);
/* A mesh from its case group (generator or Gmsh file, extra sets), checked. */
int mo_body_build_mesh(const mo_case *cs, const config_setting_t *mg, mo_mesh **out, mo_ctx *ctx);

#endif
