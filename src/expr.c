/* expr.c: recursive-descent compiler of arithmetic expressions to a stack program. */
#include "config.h"
#include <moreau/expr.h>

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum {
  OP_NUM, OP_VAR, OP_NEG, OP_ADD, OP_SUB, OP_MUL, OP_DIV, OP_POW,
  OP_LT, OP_LE, OP_GT, OP_GE, OP_EQ, OP_NE, OP_SEL, OP_F1, OP_F2
};

typedef double (*fn1)(double);
typedef double (*fn2)(double, double);

typedef struct {
  int op;
  double num;
  int var;
  fn1 f1;
  fn2 f2;
} ins;

struct mo_expr {
  ins *code;
  int n, cap;
  int depth;     /* stack depth needed */
  unsigned long long uses; /* bit i: variable i used */
  char *src;
};

static double f_step(double x) { return x >= 0 ? 1.0 : 0.0; }
static double f_sign(double x) { return (x > 0) - (x < 0); }
static double f_min(double a, double b) { return a < b ? a : b; }
static double f_max(double a, double b) { return a > b ? a : b; }

static const struct { const char *name; fn1 f; } funcs1[] = {
  {"sin", sin}, {"cos", cos}, {"tan", tan}, {"asin", asin}, {"acos", acos}, {"atan", atan},
  {"sinh", sinh}, {"cosh", cosh}, {"tanh", tanh}, {"exp", exp}, {"log", log},
  {"log10", log10}, {"sqrt", sqrt}, {"abs", fabs}, {"floor", floor}, {"ceil", ceil},
  {"step", f_step}, {"sign", f_sign}};
static const struct { const char *name; fn2 f; } funcs2[] = {
  {"atan2", atan2}, {"min", f_min}, {"max", f_max}, {"pow", pow}, {"mod", fmod}};

typedef struct {
  const char *s, *p;
  const char *const *vars;
  int nvar;
  mo_expr *e;
  int sp; /* current simulated stack depth */
  mo_ctx *ctx;
  const char *where;
  int err;
} parser;

static int perr(parser *P, const char *what)
{
  if (!P->err)
    P->err = mo_error(P->ctx, MO_EINPUT, "%s%sin expression \"%s\" at column %d: %s",
                      P->where ? P->where : "", P->where ? ": " : "", P->s,
                      (int)(P->p - P->s) + 1, what);
  return P->err;
}

static void skip(parser *P)
{
  while (isspace((unsigned char)*P->p)) P->p++;
}

static int emit(parser *P, ins i)
{
  mo_expr *e = P->e;
  if (e->n == e->cap) {
    int cap = e->cap ? 2 * e->cap : 16;
    ins *c = mo_realloc(P->ctx, e->code, (size_t)cap * sizeof *c);
    if (!c) return P->err = MO_ENOMEM;
    e->code = c;
    e->cap = cap;
  }
  e->code[e->n++] = i;
  /* stack effect */
  switch (i.op) {
  case OP_NUM: case OP_VAR: P->sp++; break;
  case OP_NEG: case OP_F1: break;
  case OP_SEL: P->sp -= 2; break;
  default: P->sp--; break;
  }
  if (P->sp > e->depth) e->depth = P->sp;
  return 0;
}

static int expr_cond(parser *P);

static int atom(parser *P)
{
  ins i = {0};
  skip(P);
  if (*P->p == '(') {
    P->p++;
    if (expr_cond(P)) return P->err;
    skip(P);
    if (*P->p != ')') return perr(P, "expected ')'");
    P->p++;
    return 0;
  }
  if (isdigit((unsigned char)*P->p) || *P->p == '.') {
    char *end;
    i.op = OP_NUM;
    i.num = strtod(P->p, &end);
    if (end == P->p) return perr(P, "malformed number");
    P->p = end;
    return emit(P, i);
  }
  if (isalpha((unsigned char)*P->p) || *P->p == '_') {
    const char *b = P->p;
    size_t len;
    int k;
    while (isalnum((unsigned char)*P->p) || *P->p == '_') P->p++;
    len = (size_t)(P->p - b);
    skip(P);
    if (*P->p == '(') {
      int nargs = 0;
      P->p++;
      for (;;) {
        if (expr_cond(P)) return P->err;
        nargs++;
        skip(P);
        if (*P->p == ',') { P->p++; continue; }
        if (*P->p == ')') { P->p++; break; }
        return perr(P, "expected ',' or ')' in function call");
      }
      for (k = 0; k < (int)MO_COUNT(funcs1); k++)
        if (strlen(funcs1[k].name) == len && !strncmp(funcs1[k].name, b, len)) {
          if (nargs != 1) return perr(P, "this function takes one argument");
          i.op = OP_F1;
          i.f1 = funcs1[k].f;
          return emit(P, i);
        }
      for (k = 0; k < (int)MO_COUNT(funcs2); k++)
        if (strlen(funcs2[k].name) == len && !strncmp(funcs2[k].name, b, len)) {
          if (nargs != 2) return perr(P, "this function takes two arguments");
          i.op = OP_F2;
          i.f2 = funcs2[k].f;
          return emit(P, i);
        }
      P->p = b;
      return perr(P, "unknown function");
    }
    for (k = 0; k < P->nvar; k++)
      if (strlen(P->vars[k]) == len && !strncmp(P->vars[k], b, len)) {
        i.op = OP_VAR;
        i.var = k;
        if (k < 64) P->e->uses |= 1ULL << k;
        return emit(P, i);
      }
    if (len == 2 && !strncmp(b, "pi", 2)) {
      i.op = OP_NUM;
      i.num = M_PI;
      return emit(P, i);
    }
    P->p = b;
    {
      char msg[256];
      int n = snprintf(msg, sizeof msg, "unknown name (variables:");
      for (k = 0; k < P->nvar && n < (int)sizeof msg - 32; k++)
        n += snprintf(msg + n, sizeof msg - (size_t)n, " %s", P->vars[k]);
      snprintf(msg + n, sizeof msg - (size_t)n, "; constant: pi)");
      return perr(P, msg);
    }
  }
  if (!*P->p) return perr(P, "unexpected end of expression");
  return perr(P, "unexpected character");
}

static int unary(parser *P);

static int power(parser *P)
{
  if (atom(P)) return P->err;
  skip(P);
  if (*P->p == '^') {
    ins i = {OP_POW, 0, 0, 0, 0};
    P->p++;
    if (unary(P)) return P->err; /* right associative */
    return emit(P, i);
  }
  return 0;
}

static int unary(parser *P)
{
  skip(P);
  if (*P->p == '-') {
    ins i = {OP_NEG, 0, 0, 0, 0};
    P->p++;
    if (unary(P)) return P->err;
    return emit(P, i);
  }
  if (*P->p == '+') {
    P->p++;
    return unary(P);
  }
  return power(P);
}

static int product(parser *P)
{
  if (unary(P)) return P->err;
  for (;;) {
    ins i = {0};
    skip(P);
    if (*P->p == '*') i.op = OP_MUL;
    else if (*P->p == '/') i.op = OP_DIV;
    else return 0;
    P->p++;
    if (unary(P) || emit(P, i)) return P->err;
  }
}

static int sum(parser *P)
{
  if (product(P)) return P->err;
  for (;;) {
    ins i = {0};
    skip(P);
    if (*P->p == '+') i.op = OP_ADD;
    else if (*P->p == '-') i.op = OP_SUB;
    else return 0;
    P->p++;
    if (product(P) || emit(P, i)) return P->err;
  }
}

static int compare(parser *P)
{
  if (sum(P)) return P->err;
  for (;;) {
    ins i = {0};
    skip(P);
    if (P->p[0] == '<' && P->p[1] == '=') { i.op = OP_LE; P->p += 2; }
    else if (P->p[0] == '>' && P->p[1] == '=') { i.op = OP_GE; P->p += 2; }
    else if (P->p[0] == '=' && P->p[1] == '=') { i.op = OP_EQ; P->p += 2; }
    else if (P->p[0] == '!' && P->p[1] == '=') { i.op = OP_NE; P->p += 2; }
    else if (P->p[0] == '<') { i.op = OP_LT; P->p++; }
    else if (P->p[0] == '>') { i.op = OP_GT; P->p++; }
    else return 0;
    if (sum(P) || emit(P, i)) return P->err;
  }
}

static int expr_cond(parser *P)
{
  if (compare(P)) return P->err;
  skip(P);
  if (*P->p == '?') {
    ins i = {OP_SEL, 0, 0, 0, 0};
    P->p++;
    if (expr_cond(P)) return P->err;
    skip(P);
    if (*P->p != ':') return perr(P, "expected ':' of a conditional");
    P->p++;
    if (expr_cond(P)) return P->err;
    return emit(P, i);
  }
  return 0;
}

int mo_expr_compile(const char *src, const char *const *vars, int nvar, const char *where,
                    mo_expr **out, mo_ctx *ctx)
{
  parser P;
  mo_expr *e;
  *out = NULL;
  e = mo_calloc(ctx, 1, sizeof *e);
  if (!e) return MO_ENOMEM;
  e->src = mo_strdup(ctx, src);
  if (!e->src) {
    mo_free(e);
    return MO_ENOMEM;
  }
  memset(&P, 0, sizeof P);
  P.s = P.p = src;
  P.vars = vars;
  P.nvar = nvar;
  P.e = e;
  P.ctx = ctx;
  P.where = where;
  if (!expr_cond(&P)) {
    skip(&P);
    if (*P.p) perr(&P, "unexpected text after the expression");
  }
  if (P.err) {
    mo_expr_free(e);
    return P.err;
  }
  *out = e;
  return MO_OK;
}

double mo_expr_eval(const mo_expr *e, const double *vals)
{
  double stackbuf[64], *st = stackbuf;
  stackbuf[0] = NAN;
  double r;
  int sp = 0, k;
  if (e->depth > (int)MO_COUNT(stackbuf)) {
    st = malloc((size_t)e->depth * sizeof *st);
    if (!st) return NAN;
  }
  for (k = 0; k < e->n; k++) {
    const ins *i = &e->code[k];
    switch (i->op) {
    case OP_NUM: st[sp++] = i->num; break;
    case OP_VAR: st[sp++] = vals[i->var]; break;
    case OP_NEG: st[sp - 1] = -st[sp - 1]; break;
    case OP_ADD: sp--; st[sp - 1] += st[sp]; break;
    case OP_SUB: sp--; st[sp - 1] -= st[sp]; break;
    case OP_MUL: sp--; st[sp - 1] *= st[sp]; break;
    case OP_DIV: sp--; st[sp - 1] /= st[sp]; break;
    case OP_POW: sp--; st[sp - 1] = pow(st[sp - 1], st[sp]); break;
    case OP_LT: sp--; st[sp - 1] = st[sp - 1] < st[sp]; break;
    case OP_LE: sp--; st[sp - 1] = st[sp - 1] <= st[sp]; break;
    case OP_GT: sp--; st[sp - 1] = st[sp - 1] > st[sp]; break;
    case OP_GE: sp--; st[sp - 1] = st[sp - 1] >= st[sp]; break;
    case OP_EQ: sp--; st[sp - 1] = st[sp - 1] == st[sp]; break;
    case OP_NE: sp--; st[sp - 1] = st[sp - 1] != st[sp]; break;
    case OP_SEL: sp -= 2; st[sp - 1] = st[sp - 1] != 0 ? st[sp] : st[sp + 1]; break;
    case OP_F1: st[sp - 1] = i->f1(st[sp - 1]); break;
    case OP_F2: sp--; st[sp - 1] = i->f2(st[sp - 1], st[sp]); break;
    }
  }
  r = sp > 0 ? st[sp - 1] : NAN;
  if (st != stackbuf) free(st);
  return r;
}

int mo_expr_uses(const mo_expr *e, int i)
{
  return i < 64 ? (int)((e->uses >> i) & 1) : 1;
}

int mo_expr_is_constant(const mo_expr *e, double *value)
{
  if (e->uses) return 0;
  if (value) *value = mo_expr_eval(e, NULL);
  return 1;
}

const char *mo_expr_source(const mo_expr *e)
{
  return e->src;
}

void mo_expr_free(mo_expr *e)
{
  if (!e) return;
  mo_free(e->code);
  mo_free(e->src);
  mo_free(e);
}
