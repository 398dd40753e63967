/* tap.h: a few TAP helpers for the C tests (one header, no library). */
#ifndef MOREAU_TAP_H
#define MOREAU_TAP_H

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int tap_n = 0, tap_failed = 0;

static void tap_vreport(int pass, const char *fmt, va_list ap)
{
  tap_n++;
  if (!pass) tap_failed++;
  printf("%s %d - ", pass ? "ok" : "not ok", tap_n);
  vprintf(fmt, ap);
  printf("\n");
  fflush(stdout);
}

/* ok(condition, description...) */
static int ok(int pass, const char *fmt, ...) __attribute__((format(printf, 2, 3), unused));
static int ok(int pass, const char *fmt, ...)
{
  va_list ap;
  va_start(ap, fmt);
  tap_vreport(pass, fmt, ap);
  va_end(ap);
  return pass;
}

/* |got - want| <= tol: prints both on failure */
static int is_close(double got, double want, double tol, const char *fmt, ...)
    __attribute__((format(printf, 4, 5), unused));
static int is_close(double got, double want, double tol, const char *fmt, ...)
{
  va_list ap;
  int pass = fabs(got - want) <= tol && !isnan(got);
  va_start(ap, fmt);
  tap_vreport(pass, fmt, ap);
  va_end(ap);
  if (!pass) printf("#   got %.17g, want %.17g (tol %.3g, diff %.3g)\n", got, want, tol, fabs(got - want));
  return pass;
}

static int is_str(const char *got, const char *want, const char *fmt, ...)
    __attribute__((format(printf, 3, 4), unused));
static int is_str(const char *got, const char *want, const char *fmt, ...)
{
  va_list ap;
  int pass = got && want && !strcmp(got, want);
  va_start(ap, fmt);
  tap_vreport(pass, fmt, ap);
  va_end(ap);
  if (!pass) printf("#   got:  %s\n#   want: %s\n", got ? got : "(null)", want ? want : "(null)");
  return pass;
}

static void diag(const char *fmt, ...) __attribute__((format(printf, 1, 2), unused));
static void diag(const char *fmt, ...)
{
  va_list ap;
  printf("# ");
  va_start(ap, fmt);
  vprintf(fmt, ap);
  va_end(ap);
  printf("\n");
}

static int done_testing(void) __attribute__((unused));
static int done_testing(void)
{
  printf("1..%d\n", tap_n);
  return tap_failed ? 1 : 0;
}

#endif
