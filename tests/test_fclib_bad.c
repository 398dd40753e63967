/* test_fclib_bad.c: hostile FCLIB files (issue 19, item 6). Each file is written with libfclib
   itself, a valid 2-contact 3D local problem with one thing broken (NaN or inf in q, W or mu, a
   negative friction coefficient, corrupt column pointers, an index out of range, a zero local
   dimension): mo_fclib_read, and so `moreau bench-local`, refuse it with MO_EINPUT and a
   message naming the file and what is wrong (before: NaN residuals and exit 0).
   tests/test_fclib_bad DIR writes the files into DIR (the campaign, bench/hostile.sh). */
#include "config.h"
#include <moreau/moreau.h>
#include "testlib.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#ifdef HAVE_FCLIB
#include <fclib.h>

typedef struct {
  const char *name, *want; /* file name, a phrase of the message */
} hostile;

static const hostile cases[] = {
    {"q-nan", "q[4] is not finite"},
    {"q-inf", "q[0] is not finite"},
    {"mu-negative", "mu[1] = -0.3: a friction coefficient is not negative"},
    {"mu-nan", "mu[0] is not finite"},
    {"w-nan", "the matrix W: entry 3 is not finite"},
    {"w-colptr", "the matrix W: corrupt column pointers"},
    {"w-colptr-first", "its first pointer is 5, not 0"},
    {"w-rowindex", "index 99 of entry 2 is out of range"},
    {"w-triplet-outside", "the matrix W: entry 5 at (5, 7), outside 6 x 6"},
};

/* W = diag(1..6) (compressed columns), q = -1 (normal) / 0, mu = 0.3; broken by `which`. */
static int write_one(const char *path, int which)
{
  struct fclib_local pb;
  struct fclib_matrix W;
  struct fclib_info info;
  int p[7], i[6], k;
  double x[6], q[6], mu[2];
  memset(&pb, 0, sizeof pb);
  memset(&W, 0, sizeof W);
  memset(&info, 0, sizeof info);
  for (k = 0; k < 6; k++) {
    p[k] = k;
    i[k] = k;
    x[k] = 1 + k;
    q[k] = k % 3 == 0 ? -1 : 0;
  }
  p[6] = 6;
  mu[0] = mu[1] = 0.3;
  W.m = W.n = 6;
  W.nzmax = 6;
  W.nz = -1;
  W.p = p;
  W.i = i;
  W.x = x;
  switch (which) {
  case 0: q[4] = NAN; break;
  case 1: q[0] = INFINITY; break;
  case 2: mu[1] = -0.3; break;
  case 3: mu[0] = NAN; break;
  case 4: x[3] = NAN; break;
  case 5: p[3] = 1000; break;
  case 6: p[0] = 5; break;
  case 7: i[2] = 99; break;
  case 8: /* triplets: i rows, p columns */
    W.nz = 6;
    p[5] = 7;
    break;
  }
  info.title = (char *)"hostile";
  info.description = (char *)cases[which].name;
  info.math_info = (char *)"";
  pb.W = &W;
  pb.q = q;
  pb.mu = mu;
  pb.spacedim = 3;
  pb.info = &info;
  unlink(path);
  return fclib_write_local(&pb, path);
}

int main(int argc, char **argv)
{
  char dir[1024], path[1200];
  size_t k;
  if (argc > 1) { /* the campaign's files */
    for (k = 0; k < MO_COUNT(cases); k++) {
      snprintf(path, sizeof path, "%s/%s.hdf5", argv[1], cases[k].name);
      if (!write_one(path, (int)k)) fprintf(stderr, "%s: libfclib could not write it\n", path);
    }
    return 0;
  }
  snprintf(dir, sizeof dir, "%s/moreau-fclib-bad.%ld", getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp", (long)getpid());
  ok(mkdir(dir, 0777) == 0, "a scratch folder %s", dir);
  for (k = 0; k < MO_COUNT(cases); k++) {
    mo_ctx ctx;
    mo_csc *W = NULL;
    double *q = NULL, *mu = NULL;
    int d = 0, nc = 0, st;
    const char *files[1];
    mo_bench_options o;
    FILE *devnull = fopen("/dev/null", "w");
    mo_ctx_init(&ctx);
    snprintf(path, sizeof path, "%s/%s.hdf5", dir, cases[k].name);
    if (!ok(write_one(path, (int)k), "%s: written by libfclib", cases[k].name)) continue;
    st = mo_fclib_read(path, &d, &nc, &W, &q, &mu, &ctx);
    ok(st == MO_EINPUT, "%s: refused as bad input (status %d)", cases[k].name, st);
    ok(strstr(ctx.errmsg, path) != NULL, "%s: the message names the file", cases[k].name);
    if (!ok(strstr(ctx.errmsg, cases[k].want) != NULL, "%s: and says '%s'", cases[k].name, cases[k].want))
      printf("#   %s\n", ctx.errmsg);
    mo_csc_free(W);
    mo_free(q);
    mo_free(mu);
    /* bench-local on it: an error, no residual printed */
    mo_ctx_init(&ctx);
    mo_bench_options_default(&o);
    o.min_time = 0.001;
    files[0] = path;
    st = mo_bench_local(files, 1, &o, devnull ? devnull : stdout, &ctx);
    ok(st != MO_OK, "%s: bench-local fails (status %d)", cases[k].name, st);
    if (devnull) fclose(devnull);
    unlink(path);
  }
  rmdir(dir);
  return done_testing();
}
#else
int main(void)
{
  printf("1..0 # SKIP this build reads no FCLIB files\n");
  return 0;
}
#endif
