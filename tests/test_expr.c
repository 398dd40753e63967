/* test_expr.c: the expression compiler against values computed by hand. */
#include "config.h"
#include <moreau/expr.h>
#include "tap.h"

static double ev(const char *src, double x, double t)
{
  static const char *const vars[] = {"x", "t"};
  double v[2] = {x, t}, r;
  mo_ctx ctx;
  mo_expr *e;
  mo_ctx_init(&ctx);
  if (mo_expr_compile(src, vars, 2, NULL, &e, &ctx)) return NAN;
  r = mo_expr_eval(e, v);
  mo_expr_free(e);
  return r;
}

int main(void)
{
  mo_ctx ctx;
  mo_expr *e;
  static const char *const vars[] = {"x", "y", "z"};
  double c;
  is_close(ev("1 + 2 * 3", 0, 0), 7, 0, "precedence of * over +");
  is_close(ev("2 ^ 3 ^ 2", 0, 0), 512, 0, "^ is right associative");
  is_close(ev("-2 ^ 2", 0, 0), -4, 0, "unary minus binds looser than ^");
  is_close(ev("(1 + 2) * 3", 0, 0), 9, 0, "parentheses");
  is_close(ev("0.5 - x / 2", 0.25, 0), 0.375, 1e-15, "variables: u0 of the bar-obstacle benchmark");
  is_close(ev("sin(pi / 2) + cos(0)", 0, 0), 2, 1e-15, "functions and pi");
  is_close(ev("min(x, t) + max(x, t)", 3, 5), 8, 0, "two-argument functions");
  is_close(ev("t < 1 ? 10 : 20", 0, 0.5), 10, 0, "conditional, true branch");
  is_close(ev("t < 1 ? 10 : 20", 0, 1.5), 20, 0, "conditional, false branch");
  is_close(ev("step(t - 1)", 0, 1), 1, 0, "step(0) = 1");
  is_close(ev("1e-3 * 2", 0, 0), 2e-3, 1e-18, "exponent notation");
  mo_ctx_init(&ctx);
  ok(mo_expr_compile("2 * (x + 1", vars, 3, "f.cfg:3: key 'a'", &e, &ctx) == MO_EINPUT, "unclosed parenthesis rejected");
  is_str(ctx.errmsg, "f.cfg:3: key 'a': in expression \"2 * (x + 1\" at column 11: expected ')'", "message names where and what");
  mo_ctx_init(&ctx);
  ok(mo_expr_compile("w + 1", vars, 3, NULL, &e, &ctx) == MO_EINPUT, "unknown variable rejected");
  ok(strstr(ctx.errmsg, "unknown name (variables: x y z; constant: pi)") != NULL, "lists the variables: %s", ctx.errmsg);
  mo_ctx_init(&ctx);
  ok(mo_expr_compile("sqr(2)", vars, 3, NULL, &e, &ctx) == MO_EINPUT, "unknown function rejected");
  mo_ctx_init(&ctx);
  ok(mo_expr_compile("1 2", vars, 3, NULL, &e, &ctx) == MO_EINPUT, "trailing text rejected");
  mo_ctx_init(&ctx);
  ok(mo_expr_compile("3 * 4", vars, 3, NULL, &e, &ctx) == MO_OK && mo_expr_is_constant(e, &c) && c == 12,
     "constant folding detected");
  mo_expr_free(e);
  ok(mo_expr_compile("y * 2", vars, 3, NULL, &e, &ctx) == MO_OK && !mo_expr_uses(e, 0) && mo_expr_uses(e, 1),
     "variable use recorded");
  mo_expr_free(e);
  return done_testing();
}
