/* fuzz_case.c: libFuzzer target for the input readers. Bytes that begin with "$MeshFormat" are
   read as a Gmsh MSH file (and the mesh, when accepted, checked and measured); any other bytes
   are read as a case file, validated, built into a scene and a contact set, lines
   "#set KEY=VALUE" applied as overrides first. Nothing may crash, leak or read out of bounds
   (ASan, UBSan). Built and run by `make fuzz` (clang), seeded with cases/, tests/bad/ and
   tests/meshes/. */
#include "config.h"
#include <moreau/moreau.h>

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
  mo_ctx ctx;
  mo_case *cs = NULL;
  mo_scene *sc = NULL;
  mo_contact *C = NULL;
  char *text = malloc(size + 1), *p;
  if (!text) return 0;
  memcpy(text, data, size);
  text[size] = '\0';
  mo_ctx_init(&ctx);
  ctx.verbosity = 0;
  ctx.max_dofs = 20000; /* keep every input fast */
  if (size >= 11 && !memcmp(data, "$MeshFormat", 11)) {
    mo_mesh *m = NULL;
    mo_gmsh_report rep;
    if (!mo_mesh_read_gmsh_buffer((const char *)data, size, "fuzz.msh", NULL, &m, &rep, &ctx)) {
      mo_material mat;
      double s = 0;
      int e;
      memset(&mat, 0, sizeof mat);
      mat.E = mat.rho = mat.area = mat.thickness = 1;
      mat.hyp = m->dim == 1 ? MO_HYP_BAR : m->dim == 2 ? MO_HYP_PLANE_STRAIN : MO_HYP_3D;
      if (mo_mesh_check(m, &ctx)) abort(); /* the reader let a bad element through */
      for (e = 0; e < m->nelem; e++) s += mo_elem_measure(m, e, &mat);
      if (!(s > 0)) abort();
    }
    mo_mesh_free(m);
    free(text);
    return 0;
  }
  if (!mo_case_load_string(text, "fuzz.cfg", &cs, &ctx) && !mo_case_validate(cs, &ctx)) {
    int st = 0;
    for (p = strstr(text, "#set "); p && !st; p = strstr(p + 1, "#set ")) {
      char line[512];
      size_t n = strcspn(p + 5, "\n");
      if (n >= sizeof line) n = sizeof line - 1;
      memcpy(line, p + 5, n);
      line[n] = '\0';
      st = mo_case_set(cs, line, &ctx);
    }
    if (!st && !mo_case_validate(cs, &ctx) && !mo_scene_build(cs, &sc, &ctx))
      mo_contact_build(sc, &C, &ctx);
  }
  mo_contact_free(C);
  mo_scene_free(sc);
  mo_case_free(cs);
  free(text);
  return 0;
}
