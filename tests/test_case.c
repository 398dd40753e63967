/* test_case.c: case-file validation: each error checked for its exact message and line. */
#include "config.h"
#include <moreau/case.h>
#include <moreau/scene.h>
#include "tap.h"

static const char *good =
  "title = \"t\";\n"                                                   /* 1 */
  "bodies = (\n"                                                       /* 2 */
  "  {\n"                                                              /* 3 */
  "    name = \"bar\";\n"                                              /* 4 */
  "    mesh = { generator = \"bar\"; length = 1.0; elements = 10; };\n"/* 5 */
  "    material = { E = 1.0; rho = 1.0; };\n"                          /* 6 */
  "    fix = ( { set = \"left\"; } );\n"                               /* 7 */
  "  }\n"                                                              /* 8 */
  ");\n"                                                               /* 9 */
  "time = { dt = 0.01; end = 1.0; };\n";                               /* 10 */

/* Load text (with `from` replaced by `to` when given), validate, build; return the message. */
static const char *check(const char *from, const char *to, const char *const *sets, int nset)
{
  static char msg[MO_ERRMSG_MAX];
  char text[4096];
  mo_ctx ctx;
  mo_case *cs = NULL;
  mo_scene *sc = NULL;
  int k;
  mo_ctx_init(&ctx);
  ctx.verbosity = 0;
  snprintf(text, sizeof text, "%s", good);
  if (from) {
    char *p = strstr(text, from);
    if (!p) return "(test bug: pattern not found)";
    memmove(p + strlen(to), p + strlen(from), strlen(p + strlen(from)) + 1);
    memcpy(p, to, strlen(to));
  }
  if (!mo_case_load_string(text, "bad.cfg", &cs, &ctx) && !mo_case_validate(cs, &ctx)) {
    for (k = 0; k < nset && !ctx.status; k++) mo_case_set(cs, sets[k], &ctx);
    if (!ctx.status && !mo_case_validate(cs, &ctx)) mo_scene_build(cs, &sc, &ctx);
  }
  snprintf(msg, sizeof msg, "%s", ctx.status ? ctx.errmsg : "ok");
  mo_scene_free(sc);
  mo_case_free(cs);
  return msg;
}

int main(void)
{
  is_str(check(NULL, NULL, NULL, 0), "ok", "the reference case is valid");
  is_str(check("time = {", "tme = {", NULL, 0),
         "bad.cfg:10: unknown key 'tme' (did you mean 'time'?)", "unknown top-level key");
  is_str(check("material =", "materail =", NULL, 0),
         "bad.cfg:6: unknown key 'materail' in 'bodies.[0]' (did you mean 'material'?)",
         "typo in a nested key");
  is_str(check("length = 1.0", "lenght = 1.0", NULL, 0),
         "bad.cfg:5: unknown key 'lenght' in 'bodies.[0].mesh' (did you mean 'length'?)",
         "typo two levels down");
  is_str(check("E = 1.0", "E = \"steel\"", NULL, 0),
         "bad.cfg:6: key 'bodies.[0].material.E': must be a number, not a string", "wrong type");
  is_str(check("elements = 10", "elements = 10.5", NULL, 0),
         "bad.cfg:5: key 'bodies.[0].mesh.elements': must be an integer or an array of integers, not a number",
         "integer expected");
  is_str(check("E = 1.0;", "E = 1.0; nu = 0.5;", NULL, 0),
         "bad.cfg:6: key 'bodies.[0].material.nu': value 0.5 is out of range (-1, 0.5): Poisson's ratio "
         "of an isotropic solid lies in (-1, 0.5); 0.5 (incompressible) is not supported by displacement elements",
         "nu = 0.5 rejected");
  is_str(check("dt = 0.01", "dt = -0.001", NULL, 0),
         "bad.cfg:10: key 'time.dt': value -0.001 is out of range (0, inf): the time step must be positive",
         "negative time step");
  is_str(check("    mesh = { generator = \"bar\"; length = 1.0; elements = 10; };\n", "", NULL, 0),
         "bad.cfg:3: key 'bodies.[0]': body 'bar' has no mesh (add mesh = { generator = ...; })",
         "missing mesh");
  is_str(check("E = 1.0; rho = 1.0;", "E = 1.0;", NULL, 0),
         "bad.cfg:6: 'bodies.[0].material' lacks the required key 'rho'", "missing required key");
  is_str(check("time = { dt = 0.01; end = 1.0; };\n", "", NULL, 0),
         "bad.cfg: required key 'time' is missing", "missing time group");
  is_str(check("generator = \"bar\"", "generator = \"bra\"", NULL, 0),
         "bad.cfg:5: key 'bodies.[0].mesh.generator': 'bra' is not one of: bar, rectangle, box, disk "
         "(did you mean 'bar'?)", "unknown enumeration value");
  is_str(check("set = \"left\"", "set = \"lefft\"", NULL, 0),
         "bad.cfg:7: key 'bodies.[0].fix.[0].set': no node set 'lefft' in this mesh (sets: xmin, left, "
         "xmax, right, all)", "unknown node set");
  is_str(check("dt = 0.01;", "dt = 0.01; theta = 1.5;", NULL, 0),
         "bad.cfg:10: key 'time.theta': value 1.5 is out of range [0, 1]: theta must lie in [0, 1]",
         "theta outside [0, 1]");
  is_str(check("end = 1.0;", "end = 1.0 ;;", NULL, 0),
         "bad.cfg:10: syntax error", "syntax error with its line");
  is_str(check("initial", "initial", NULL, 0), "(test bug: pattern not found)", "helper detects a missing pattern");
  {
    const char *s1[] = {"time.dt=-1"};
    const char *s2[] = {"time.dtt=1"};
    const char *s3[] = {"bodies.bar.material.E=2e11"};
    const char *s4[] = {"bodies.[0].material.nu=0.5"};
    const char *s5[] = {"output.vtk.every=0"};
    const char *s6[] = {"bodies.rod.material.E=1"};
    const char *s7[] = {"time.scheme=thet"};
    is_str(check(NULL, NULL, s1, 1),
           "--set time.dt=-1: key 'time.dt': value -1 is out of range (0, inf): the time step must be positive",
           "--set validated at once");
    is_str(check(NULL, NULL, s2, 1), "--set time.dtt=1: unknown key 'dtt' in 'time' (did you mean 'dt'?)",
           "--set unknown key");
    is_str(check(NULL, NULL, s3, 1), "ok", "--set addresses list elements by name");
    is_str(check(NULL, NULL, s4, 1),
           "--set bodies.[0].material.nu=0.5: key 'bodies.[0].material.nu': value 0.5 is out of range (-1, 0.5): "
           "Poisson's ratio of an isotropic solid lies in (-1, 0.5); 0.5 (incompressible) is not supported by "
           "displacement elements", "--set by index, range checked");
    is_str(check(NULL, NULL, s5, 1),
           "--set output.vtk.every=0: key 'output.vtk.every': value 0 is out of range [1, inf)",
           "--set creates missing groups and checks them");
    is_str(check(NULL, NULL, s6, 1), "--set bodies.rod.material.E=1: no element named 'rod' in this list",
           "--set unknown list element");
    is_str(check(NULL, NULL, s7, 1),
           "--set time.scheme=thet: key 'time.scheme': 'thet' is not one of: theta, explicit, newmark, quasistatic "
           "(did you mean 'theta'?)", "--set bare word taken as a string and checked");
  }
  return done_testing();
}
