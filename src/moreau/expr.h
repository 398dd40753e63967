/* moreau/expr.h: small arithmetic expressions in case files (initial fields, load amplitudes). */
#ifndef MOREAU_EXPR_H
#define MOREAU_EXPR_H

#include <moreau/ctx.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Grammar (C precedence):  e := c ('?' e ':' e)?   c := s (('<'|'<='|'>'|'>='|'=='|'!=') s)*
   s := p (('+'|'-') p)*   p := u (('*'|'/') u)*   u := ('-'|'+') u | w   w := a ('^' u)?
   a := number | name | name '(' e (',' e)* ')' | '(' e ')'
   Names: the variables given at compile time (x, y, z, t, ...) and the constant pi.
   Functions: sin cos tan asin acos atan atan2 sinh cosh tanh exp log log10 sqrt abs
   floor ceil min max pow step (Heaviside, step(0) = 1) sign mod. Comparisons give 0 or 1. */
typedef struct mo_expr mo_expr;

/* Compile `src` with variables vars[0..nvar-1]. On a syntax error the message gives the column
   and what was expected; `where` (e.g. "case.cfg:12: key 'initial.velocity'") prefixes it. */
int mo_expr_compile(const char *src, const char *const *vars, int nvar, const char *where,
                    mo_expr **out, mo_ctx *ctx);
/* Evaluate with variable values vals[0..nvar-1]. Never fails; may return NaN or inf (callers
   that cannot accept them check with isfinite). */
double mo_expr_eval(const mo_expr *e, const double *vals);
/* 1 when the expression does not use variable i (so callers may skip re-evaluation). */
int mo_expr_uses(const mo_expr *e, int i);
/* 1 when the expression is a constant; its value in *value. */
int mo_expr_is_constant(const mo_expr *e, double *value);
const char *mo_expr_source(const mo_expr *e);
void mo_expr_free(mo_expr *e);

#ifdef __cplusplus
}
#endif
#endif
