/* fuzz_case.c: libFuzzer target for the case reader: any bytes are read as a case file,
   validated, built into a scene and a contact set; lines "#set KEY=VALUE" are applied as
   overrides first. Nothing may crash, leak or read out of bounds (ASan, UBSan). Built and run
   by `make fuzz` (clang), seeded with cases/ and tests/bad/. */
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
