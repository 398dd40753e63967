/* draw.c: teaching scenes that draw themselves: the sampled frames as gnuplot data, the script that
   renders snapshots.png and animation.gif, and gnuplot run when it is on PATH. */
#include "config.h"
#include "draw.h"
#include <moreau/body.h>
#include "case_internal.h"
#include "mesh_internal.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#define DRAW_GIF_MAX 200   /* frames of the GIF at most */
#define DRAW_CLASSES 5     /* line widths of the contact network, by r_n */

/* A mesh body's outline: its boundary facets (2D: edges, 3D: faces), or its elements (1D). */
typedef struct {
  int n, nfn;
  int *node;
  int open;   /* 1: a polyline (a 3-node edge), else a closed polygon from nfn > 2 nodes */
} outline;

typedef struct {
  long step;
  double t;
  unsigned char snap, gif;
} frame_info;

struct mo_draw {
  char dir[4200];          /* OUTDIR/plots */
  char gnuplot[4096];      /* gnuplot found on PATH, "" when none */
  FILE *f;                 /* draw.dat, NULL once finished */
  long steps, every;       /* the run's steps; the GIF's period in steps */
  int gif, forces, has_box, nsnap, nbody;
  long *snap;              /* the snapshots' steps, increasing */
  double box[4];           /* output.draw.box */
  double bb[4];            /* bounding box of what was drawn: xmin, xmax, ymin, ymax */
  double rnmax;            /* the largest normal force drawn */
  int many;                /* more than 32 balls (a granular scene): coloured by speed, no radius lines */
  double vmax;             /* the largest ball speed drawn */
  int nframe, cap;
  frame_info *frame;
  outline *out;            /* per body (n = 0 for bodies without a mesh) */
};

/* --- gnuplot --------------------------------------------------------------------------------- */

/* The program `name` in a folder of PATH into buf: 1 when found. */
static int find_on_path(const char *name, char *buf, size_t n)
{
  const char *p = getenv("PATH"), *q;
  struct stat sb;
  while (p && *p) {
    size_t len;
    q = strchr(p, ':');
    len = q ? (size_t)(q - p) : strlen(p);
    if (snprintf(buf, n, "%.*s/%s", (int)(len ? len : 1), len ? p : ".", name) < (int)n &&
        stat(buf, &sb) == 0 && S_ISREG(sb.st_mode) && access(buf, X_OK) == 0)
      return 1;
    p = q ? q + 1 : NULL;
  }
  buf[0] = '\0';
  return 0;
}

/* Run gnuplot `prog` (argv[0] its name) in folder dir, its output into the file `log` there, or
   when cap > 0 into out (NUL-terminated, cut at cap). Returns its exit status, -1 when it could
   not run. No shell: folder names need no quoting. */
static int run_gnuplot(const char *prog, const char *dir, char *const argv[], const char *log, char *out,
                       size_t cap)
{
  int fd[2] = {-1, -1}, status;
  pid_t pid;
  if (cap && pipe(fd) != 0) return -1;
  pid = fork();
  if (pid == 0) { /* the child: only async-signal-safe calls until exec */
    int o = cap ? fd[1] : -1, in = open("/dev/null", O_RDONLY);
    if (cap) close(fd[0]);
    if (dir && chdir(dir) != 0) _exit(127);
    if (!cap) o = open(log ? log : "/dev/null", O_WRONLY | O_CREAT | O_TRUNC, 0666);
    if (o < 0 || in < 0 || dup2(in, 0) < 0 || dup2(o, 1) < 0 || dup2(o, 2) < 0) _exit(127);
    execv(prog, argv);
    _exit(127);
  }
  if (cap) {
    size_t len = 0;
    char buf[4096];
    ssize_t r;
    close(fd[1]);
    while (pid > 0 && ((r = read(fd[0], buf, sizeof buf)) > 0 || (r < 0 && errno == EINTR)))
      for (ssize_t i = 0; i < r && len + 1 < cap; i++) out[len++] = buf[i];
    out[len] = '\0';
    close(fd[0]);
  }
  if (pid < 0) return -1;
  while (waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/* Whether gnuplot `prog` has the gif terminal (GPVAL_TERMINALS). */
static int gif_supported(const char *prog)
{
  char out[8192], *p;
  char *const argv[] = {"gnuplot", "-e", "print GPVAL_TERMINALS", NULL};
  if (run_gnuplot(prog, NULL, argv, NULL, out + 1, sizeof out - 2) != 0) return 0;
  out[0] = ' ';
  for (p = out; *p; p++)
    if (*p == '\n' || *p == '\t') *p = ' ';
  strcat(out, " ");
  return strstr(out, " gif ") != NULL;
}

/* --- settings and sampling ------------------------------------------------------------------- */

static int is_snap(const mo_draw *d, long step)
{
  int k;
  for (k = 0; k < d->nsnap; k++)
    if (d->snap[k] == step) return 1;
  return 0;
}

static int is_gif(const mo_draw *d, long step)
{
  return d->gif && (step % d->every == 0 || step == d->steps);
}

int mo_draw_wants(const mo_draw *d, long step) { return is_gif(d, step) || is_snap(d, step); }

/* output.draw's keys: frames, gif, every, box, forces; the snapshots' steps. */
static int read_settings(mo_draw *d, const mo_scene *sc, const mo_case *cs, const config_setting_t *g,
                         mo_ctx *ctx)
{
  int frames = mo_cfg_int(g, "frames", 8), k;
  long N = sc->time.steps;
  d->steps = N;
  d->forces = mo_cfg_bool(g, "forces", 1);
  d->gif = mo_cfg_member(g, "gif") ? mo_cfg_bool(g, "gif", 1) : !d->gnuplot[0] || gif_supported(d->gnuplot);
  if (!d->gif && !mo_cfg_member(g, "gif"))
    mo_note_skip(ctx, "animation.gif (this gnuplot has no gif terminal)");
  d->every = mo_cfg_member(g, "every") ? mo_cfg_int(g, "every", 1) : (long)fmax(1, floor(N / 100.0 + 0.5));
  if (d->gif && N / d->every + 1 > DRAW_GIF_MAX) {
    long e = (N + DRAW_GIF_MAX - 2) / (DRAW_GIF_MAX - 1);
    mo_log(ctx, 2, "output.draw.every = %ld would give %ld GIF frames: every %ld steps instead\n", d->every,
           N / d->every + 1, e);
    d->every = e;
  }
  if (mo_cfg_count(g, "box") == 4) {
    for (k = 0; k < 4; k++) d->box[k] = mo_cfg_num_at(g, "box", k);
    if (!(d->box[0] < d->box[1] && d->box[2] < d->box[3]))
      return mo_case_error(cs, mo_cfg_member(g, "box"), ctx,
                           "the view is [xmin, xmax, ymin, ymax] with xmin < xmax and ymin < ymax");
    d->has_box = 1;
  }
  if (!(d->snap = mo_calloc(ctx, (size_t)frames, sizeof *d->snap))) return MO_ENOMEM;
  for (k = 0; k < frames; k++) {
    long s = frames == 1 ? N : (long)floor((double)k * (double)N / (frames - 1) + 0.5);
    if (!d->nsnap || s != d->snap[d->nsnap - 1]) d->snap[d->nsnap++] = s;
  }
  return MO_OK;
}

/* The outline of a mesh: boundary facets in the elements' node order (1D: the elements). */
static int outline_build(const mo_mesh *m, outline *o, mo_ctx *ctx)
{
  const mo_eltype_info *T = mo_eltype_get(m->type);
  mo_facet *F = NULL;
  size_t nf, i, j;
  int c, st;
  if (m->dim == 1) {
    if (!(o->node = mo_malloc(ctx, (size_t)m->nelem * 2 * sizeof *o->node + 1))) return MO_ENOMEM;
    memcpy(o->node, m->conn, (size_t)m->nelem * 2 * sizeof *o->node);
    o->n = m->nelem;
    o->nfn = 2;
    return MO_OK;
  }
  if ((st = mo_mesh_all_facets(m, &F, &nf, ctx))) return st;
  o->nfn = T->nfn;
  o->open = T->fkind == MO_FK_LINE3;
  if (!(o->node = mo_malloc(ctx, (nf + 1) * (size_t)T->nfn * sizeof *o->node))) {
    mo_free(F);
    return MO_ENOMEM;
  }
  for (i = 0; i < nf; i = j) {
    for (j = i + 1; j < nf && !mo_facet_cmp_key(&F[i], &F[j]); j++) continue;
    if (j - i != 1) continue; /* shared by two elements: inside */
    for (c = 0; c < T->nfn; c++) {
      /* along the facet's outline: a 3-node edge end, middle, end; a 6-node face corner, middle, ... */
      static const int line3[3] = {0, 2, 1}, tri6[6] = {0, 3, 1, 4, 2, 5};
      int lc = T->fkind == MO_FK_LINE3 ? line3[c] : T->fkind == MO_FK_TRI6 ? tri6[c] : c;
      o->node[o->n * T->nfn + c] = m->conn[(size_t)F[i].elem * m->nen + T->facet[F[i].lface][lc]];
    }
    o->n++;
  }
  mo_free(F);
  return MO_OK;
}

int mo_draw_open(const char *outdir, const mo_scene *sc, const mo_case *cs, mo_draw **out, mo_ctx *ctx)
{
  const config_setting_t *g = config_lookup(&cs->cfg, "output.draw");
  char path[4300];
  mo_draw *d;
  int b, st;
  *out = NULL;
  if (!g) return MO_OK;
  if (!(d = mo_calloc(ctx, 1, sizeof *d))) return MO_ENOMEM;
  d->bb[0] = d->bb[2] = HUGE_VAL;
  d->bb[1] = d->bb[3] = -HUGE_VAL;
  if (snprintf(d->dir, sizeof d->dir, "%s/plots", outdir) >= (int)sizeof d->dir) {
    mo_free(d);
    return mo_error(ctx, MO_EIO, "path too long: '%s/plots'", outdir);
  }
  find_on_path("gnuplot", d->gnuplot, sizeof d->gnuplot);
  d->nbody = sc->nbody;
  {
    int k, nb = 0;
    for (k = 0; k < sc->nrigid; k++)
      nb += sc->body[sc->rigid[k]].kind == MO_BODY_DISK || sc->body[sc->rigid[k]].kind == MO_BODY_SPHERE;
    d->many = nb > 32;
  }
  if ((st = read_settings(d, sc, cs, g, ctx))) goto fail;
  /* the meshes' outlines, per body when some body has a mesh (a pile has none: no array) */
  for (b = 0; b < sc->nbody && !sc->body[b].mesh; b++) {}
  if (b < sc->nbody && !(d->out = mo_calloc(ctx, (size_t)sc->nbody + 1, sizeof *d->out))) goto fail;
  for (b = 0; d->out && b < sc->nbody; b++)
    if (sc->body[b].mesh && (st = outline_build(sc->body[b].mesh, &d->out[b], ctx))) goto fail;
  if ((st = mo_mkdir_p(d->dir, ctx))) goto fail;
  snprintf(path, sizeof path, "%s/draw.dat", d->dir);
  if (!(d->f = fopen(path, "w"))) {
    st = mo_error(ctx, MO_EOUTPUT, "cannot write '%s': %s", path, strerror(errno));
    goto fail;
  }
  fprintf(d->f, "# draw.dat: the frames moreau drew of '%s' (plots/draw.gp renders them).\n"
                "# Frame k: index 3k circles (x y r speed: disks, spheres), 3k+1 outlines (x y polylines:\n"
                "# polygons, radius lines, mesh boundaries), 3k+2 contact network (x y dx dy rn, forces\n"
                "# in N); after the NF frames, index 3 NF + k: the planes of frame k, clipped to the\n"
                "# view.\n\n",
          sc->title ? sc->title : "");
  *out = d;
  return MO_OK;
fail:
  if (!st) st = MO_ENOMEM;
  mo_draw_free(d);
  return st;
}

void mo_draw_free(mo_draw *d)
{
  int b;
  if (!d) return;
  if (d->f) fclose(d->f);
  for (b = 0; d->out && b < d->nbody; b++) mo_free(d->out[b].node);
  mo_free(d->out);
  mo_free(d->snap);
  mo_free(d->frame);
  mo_free(d);
}

/* --- one frame ------------------------------------------------------------------------------- */

static void bb_add(mo_draw *d, double x, double y, double r)
{
  if (!isfinite(x) || !isfinite(y)) return;
  d->bb[0] = fmin(d->bb[0], x - r);
  d->bb[1] = fmax(d->bb[1], x + r);
  d->bb[2] = fmin(d->bb[2], y - r);
  d->bb[3] = fmax(d->bb[3], y + r);
}

/* A point of a polyline, projected on x-y (1D: on the x axis). */
static void put_xy(mo_draw *d, const mo_scene *sc, const double *x)
{
  double y = sc->dim > 1 ? x[1] : 0;
  fprintf(d->f, "%.9g %.9g\n", x[0], y);
  bb_add(d, x[0], y, 0);
}

/* Current position of node a of a mesh body (x = X + u, or through the rigid map). */
static void node_pos(const mo_scene *sc, const mo_state *s, const mo_body *B, int a, double *x)
{
  double X[3] = {0, 0, 0};
  int D = sc->dim, i;
  memset(x, 0, 3 * sizeof *x);
  if (B->kind == MO_BODY_RIGID_MESH) {
    for (i = 0; i < D; i++) X[i] = B->mesh->x[(size_t)a * D + i] - B->xc0[i];
    mo_rigid_point(sc, B, s, X, x);
    return;
  }
  for (i = 0; i < D; i++) x[i] = B->mesh->x[(size_t)a * D + i] + s->u[B->dof0 + a * D + i];
}

/* Disks and spheres as circles x y r speed. */
static void frame_balls(mo_draw *d, const mo_scene *sc, const mo_state *s)
{
  int k, i;
  for (k = 0; k < sc->nrigid; k++) {
    const mo_body *B = &sc->body[sc->rigid[k]];
    double c[3], v2 = 0;
    if (B->kind != MO_BODY_DISK && B->kind != MO_BODY_SPHERE) continue;
    mo_rigid_center(sc, B, s, c);
    for (i = 0; s && i < sc->dim; i++) v2 += s->v[B->dof0 + i] * s->v[B->dof0 + i];
    fprintf(d->f, "%.9g %.9g %.9g %.6g\n", c[0], c[1], B->radius, sqrt(v2));
    if (!B->fixed && sqrt(v2) > d->vmax) d->vmax = sqrt(v2);
    bb_add(d, c[0], c[1], B->radius);
  }
}

/* One body's polylines: a ball's radius line along its body x axis, a polygon, a mesh's outline. */
static void body_outline(mo_draw *d, const mo_scene *sc, const mo_state *s, int b)
{
  const mo_body *B = &sc->body[b];
  const outline *o = d->out ? &d->out[b] : NULL;
  double x[3], R[9], v[2 * MO_POLYGON_MAX + 2];
  int k, a;
  if (B->kind == MO_BODY_DISK || B->kind == MO_BODY_SPHERE) {
    if (d->many) return; /* a pile's radius lines would hide it */
    mo_rigid_center(sc, B, s, x);
    mo_rigid_rotation(sc, B, s, R);
    fputc('\n', d->f);
    put_xy(d, sc, x);
    x[0] += B->radius * R[0];
    x[1] += B->radius * R[3];
    put_xy(d, sc, x);
  } else if (B->kind == MO_BODY_POLYGON) {
    mo_polygon_world(sc, B, s, v);
    v[2 * B->nvert] = v[0];
    v[2 * B->nvert + 1] = v[1];
    fputc('\n', d->f);
    for (a = 0; a <= B->nvert; a++) put_xy(d, sc, v + 2 * a);
  }
  for (k = 0; o && k < o->n; k++) {
    fputc('\n', d->f);
    for (a = 0; a < o->nfn + (o->nfn > 2 && !o->open); a++) {
      node_pos(sc, s, B, o->node[k * o->nfn + a % o->nfn], x);
      put_xy(d, sc, x);
    }
  }
}

/* The contact network: x y dx dy rn, from the slave side to the master side (chunk by chunk). */
static int frame_network(mo_draw *d, const mo_scene *sc, mo_vtk_contacts *net, mo_ctx *ctx)
{
  int k, st;
  mo_vtk_contacts_rewind(net);
  while (!(st = mo_vtk_contacts_next(net, ctx)) && net->n)
    for (k = 0; k < net->n; k++) {
      const double *e = net->end + 6 * k;
      double y0 = sc->dim > 1 ? e[1] : 0, y1 = sc->dim > 1 ? e[4] : 0;
      fprintf(d->f, "%.9g %.9g %.9g %.9g %.9g\n", e[0], y0, e[3] - e[0], y1 - y0, net->rn[k]);
      bb_add(d, e[0], y0, 0);
      bb_add(d, e[3], y1, 0);
      if (net->rn[k] > d->rnmax) d->rnmax = net->rn[k];
    }
  return st;
}

int mo_draw_frame(mo_draw *d, const mo_scene *sc, const mo_state *s, mo_vtk_contacts *net, mo_ctx *ctx)
{
  frame_info *fi;
  int b, st;
  if (!d->f) return MO_OK;
  if (d->nframe == d->cap) {
    int cap = d->cap ? 2 * d->cap : 64;
    frame_info *p = mo_realloc(ctx, d->frame, (size_t)cap * sizeof *p);
    if (!p) return MO_ENOMEM;
    d->frame = p;
    d->cap = cap;
  }
  fi = &d->frame[d->nframe];
  fi->step = s->step;
  fi->t = s->t;
  fi->snap = (unsigned char)is_snap(d, s->step);
  fi->gif = (unsigned char)is_gif(d, s->step);
  fprintf(d->f, "# frame %d: step %ld, t = %.9g\n# circles\nNaN NaN NaN\n", d->nframe, s->step, s->t);
  frame_balls(d, sc, s);
  fputs("\n\n# outlines\nNaN NaN\n", d->f);
  for (b = 0; b < sc->nbody; b++) body_outline(d, sc, s, b);
  fputs("\n\n# contact network\nNaN NaN NaN NaN NaN\n", d->f);
  if (d->forces && net && (st = frame_network(d, sc, net, ctx))) return st;
  fputs("\n\n", d->f);
  if (ferror(d->f)) return mo_error(ctx, MO_EOUTPUT, "cannot write '%s/draw.dat'", d->dir);
  d->nframe++;
  return MO_OK;
}

/* --- the view, the planes -------------------------------------------------------------------- */

/* The trace of plane B at time t in the x-y view: a point p and a unit normal n; 0 when it has
   none (a 3D plane that is not vertical covers the whole view). */
static int plane_trace(const mo_scene *sc, const mo_body *B, double t, double *p, double *n)
{
  int i;
  double len;
  for (i = 0; i < 2; i++) {
    p[i] = i < sc->dim ? B->point[i] + B->velocity[i] * t : 0;
    n[i] = i < sc->dim ? B->normal[i] : 0;
  }
  len = hypot(n[0], n[1]);
  if (sc->dim == 3 && !(len > 1e-6)) return 0;
  n[0] /= len;
  n[1] /= len;
  return 1;
}

/* The view: output.draw.box, or the bounding box of everything drawn with the planes' points
   nearest to it, widened where flat, with a margin of 5%. */
static void view_box(const mo_draw *d, const mo_scene *sc, double *v)
{
  double c[2], p[2], n[2], w, h, m;
  int b, k;
  if (d->has_box) {
    memcpy(v, d->box, 4 * sizeof *v);
    return;
  }
  memcpy(v, d->bb, 4 * sizeof *v);
  if (!(v[0] <= v[1])) v[0] = v[2] = -1, v[1] = v[3] = 1;
  c[0] = 0.5 * (v[0] + v[1]);
  c[1] = 0.5 * (v[2] + v[3]);
  for (b = 0; b < sc->nbody; b++)
    for (k = 0; k < d->nframe && sc->body[b].kind == MO_BODY_PLANE; k += d->nframe > 1 ? d->nframe - 1 : 1)
      if (plane_trace(sc, &sc->body[b], d->frame[k].t, p, n)) {
        double g = (c[0] - p[0]) * n[0] + (c[1] - p[1]) * n[1];
        v[0] = fmin(v[0], c[0] - g * n[0]);
        v[1] = fmax(v[1], c[0] - g * n[0]);
        v[2] = fmin(v[2], c[1] - g * n[1]);
        v[3] = fmax(v[3], c[1] - g * n[1]);
      }
  w = v[1] - v[0];
  h = v[3] - v[2];
  if (!(w > 0) && !(h > 0)) w = h = 1;
  if (h < 0.2 * w) { v[2] -= 0.1 * w - 0.5 * h; v[3] += 0.1 * w - 0.5 * h; h = 0.2 * w; }
  if (w < 0.2 * h) { v[0] -= 0.1 * h - 0.5 * w; v[1] += 0.1 * h - 0.5 * w; w = 0.2 * h; }
  m = 0.05 * fmax(w, h);
  v[0] -= m; v[1] += m; v[2] -= m; v[3] += m;
}

/* The part of the line through p with normal n inside the view v: 1 with its ends in e. */
static int clip_line(const double *p, const double *n, const double *v, double *e)
{
  double tau[2] = {-n[1], n[0]}, lo = -HUGE_VAL, hi = HUGE_VAL;
  int i;
  for (i = 0; i < 2; i++) {
    double a, b;
    if (fabs(tau[i]) < 1e-300) {
      if (p[i] < v[2 * i] || p[i] > v[2 * i + 1]) return 0;
      continue;
    }
    a = (v[2 * i] - p[i]) / tau[i];
    b = (v[2 * i + 1] - p[i]) / tau[i];
    lo = fmax(lo, fmin(a, b));
    hi = fmin(hi, fmax(a, b));
  }
  if (!(lo < hi)) return 0;
  for (i = 0; i < 2; i++) {
    e[i] = p[i] + lo * tau[i];
    e[2 + i] = p[i] + hi * tau[i];
  }
  return 1;
}

/* After the frames, index 3 NF + k: the planes of frame k clipped to the view. */
static void write_planes(mo_draw *d, const mo_scene *sc, const double *v)
{
  int k, b;
  for (k = 0; k < d->nframe; k++) {
    fprintf(d->f, "# planes of frame %d\nNaN NaN\n", k);
    for (b = 0; b < sc->nbody; b++) {
      double p[2], n[2], e[4];
      if (sc->body[b].kind != MO_BODY_PLANE || !plane_trace(sc, &sc->body[b], d->frame[k].t, p, n) ||
          !clip_line(p, n, v, e))
        continue;
      fprintf(d->f, "\n%.9g %.9g\n%.9g %.9g\n", e[0], e[1], e[2], e[3]);
    }
    fputs("\n\n", d->f);
  }
}

/* --- the script ------------------------------------------------------------------------------ */

typedef struct {
  char *s;
  size_t len, cap;
  int failed;
} text;

static void tx(text *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void tx(text *b, const char *fmt, ...)
{
  va_list ap;
  int n;
  if (b->failed) return;
  for (;;) {
    va_start(ap, fmt);
    n = vsnprintf(b->s ? b->s + b->len : NULL, b->s ? b->cap - b->len : 0, fmt, ap);
    va_end(ap);
    if (n < 0) { b->failed = 1; return; }
    if (b->s && (size_t)n < b->cap - b->len) break;
    {
      size_t cap = b->cap ? 2 * b->cap : 8192;
      char *p;
      while (cap < b->len + (size_t)n + 1) cap *= 2;
      if (!(p = realloc(b->s, cap))) { b->failed = 1; return; }
      b->s = p;
      b->cap = cap;
    }
  }
  b->len += (size_t)n;
}

/* A gnuplot single-quoted string of s ('' for a quote, no line breaks). */
static void gp_quote(const char *s, char *out, size_t n)
{
  size_t k = 0;
  out[k++] = '\'';
  for (; s && *s && k + 4 < n; s++) {
    if (*s == '\'') out[k++] = '\'';
    out[k++] = *s == '\n' || *s == '\r' ? ' ' : *s;
  }
  out[k++] = '\'';
  out[k] = '\0';
}

/* The definitions every figure uses: the view, the frame count, the plot command FRAME. */
static void script_head(text *g, const mo_draw *d, const double *v)
{
  int ngif = 0, nsnap = 0, k;
  for (k = 0; k < d->nframe; k++) {
    ngif += d->frame[k].gif;
    nsnap += d->frame[k].snap;
  }
  tx(g, "# draw.gp: moreau's drawing of this run (gnuplot draw.gp, in this folder): snapshots.png, %d\n"
        "# snapshots, and animation.gif, %d frames%s. The data are draw.dat: frame K is index 3*K (disks,\n"
        "# spheres: x y r speed), 3*K+1 (outlines: polygons, radius lines, mesh boundaries), 3*K+2 (contact\n"
        "# network: x y dx dy rn, drawn with widths by rn); index 3*NF+K are the planes of frame K.\n",
     nsnap, ngif, d->gif ? "" : " (no GIF asked)");
  tx(g, "NF = %d\nRN = %.9g   # the largest normal force drawn (N)\n", d->nframe,
     d->rnmax > 0 ? d->rnmax : 1.0);
  tx(g, "set xrange [%.9g:%.9g]\nset yrange [%.9g:%.9g]\nset size ratio -1\nunset key\n", v[0], v[1], v[2],
     v[3]);
  tx(g, "set style fill solid 0.35 border\n");
  if (d->many) /* a granular scene: the grains coloured by speed */
    tx(g, "set palette defined (0 '#2c7bb6', 0.5 '#ffffbf', 1 '#d7191c')\nset cbrange [0:%.9g]\n"
          "set cblabel 'speed (m/s)'\n", d->vmax > 0 ? d->vmax : 1.0);
  else
    tx(g, "unset colorbox\n");
  tx(g, "FRAME = \"plot 'draw.dat' index 3*K using 1:2:3%s with circles %s, "
        "'' index 3*K+1 using 1:2 with lines lw 1.5 lc rgb '#202020', "
        "'' index 3*NF+K using 1:2 with lines lw 3 lc rgb '#8c6d31'",
     d->many ? ":4" : "", d->many ? "lc palette fill solid 0.9 noborder" : "lc rgb '#1f77b4'");
  if (d->forces)
    tx(g, ", for [c=1:%d] '' index 3*K+2 using 1:2:((c == 1 || $5 > (c-1)*RN/%d) && "
          "(c == %d || $5 <= c*RN/%d) ? $3 : 1/0):4 with vectors nohead lw c lc rgb '#d62728'",
       DRAW_CLASSES, DRAW_CLASSES, DRAW_CLASSES, DRAW_CLASSES);
  tx(g, "\"\n");
}

/* The size in pixels of one picture of the view v whose plot has about `area` pixels in the view's
   proportions (each side in 160 .. 960), with room for the axes and the title. */
static void panel_size(const double *v, double area, int *w, int *h)
{
  double ar = (v[3] - v[2]) / (v[1] - v[0]);
  *w = (int)fmin(fmax(sqrt(area / ar), 160), 960) + 100;
  *h = (int)fmin(fmax(sqrt(area * ar), 160), 960) + 80;
}

/* snapshots.png: the snapshots in a grid of at most 4 columns (the one whose picture is nearest
   to 16:10), each titled with its time. */
static void script_snapshots(text *g, const mo_draw *d, const mo_scene *sc, const double *v)
{
  char title[600], t[300];
  int n = 0, k, i = 0, cols = 1, rows, w, h;
  double best = HUGE_VAL;
  for (k = 0; k < d->nframe; k++) n += d->frame[k].snap;
  panel_size(v, d->many ? 960.0 * 720 : 480.0 * 360, &w, &h); /* a pile needs the pixels */
  for (k = 1; k <= (n < 4 ? n : 4); k++) {
    int r = (n + k - 1) / k;
    double dev = fabs(log((double)(k * w) / (r * h) / 1.6));
    if (dev < best) {
      best = dev;
      cols = k;
    }
  }
  rows = (n + cols - 1) / cols;
  snprintf(t, sizeof t, "%s%s", sc->title ? sc->title : "",
           sc->dim == 3 ? " (x-y projection of a 3D scene)" : "");
  gp_quote(t, title, sizeof title);
  tx(g, "\n# snapshots.png\nif (strstrt(GPVAL_TERMINALS, 'pngcairo') > 0) {\n"
        "  set terminal pngcairo noenhanced size %d,%d\n} else {\n"
        "  set terminal png noenhanced size %d,%d\n}\n",
     cols * w, rows * h + 40, cols * w, rows * h + 40);
  tx(g, "set output 'snapshots.png'\nset multiplot layout %d,%d title %s\n", rows ? rows : 1, cols, title);
  for (k = 0; k < d->nframe; k++)
    if (d->frame[k].snap)
      tx(g, "K = %d; set title 't = %.6g s'; eval FRAME  # snapshot %d/%d\n", k, d->frame[k].t, ++i, n);
  tx(g, "unset multiplot\nset output\n");
}

/* animation.gif: the GIF frames (about 8 s in all), when this gnuplot has the gif terminal. */
static void script_gif(text *g, const mo_draw *d, const mo_scene *sc, const double *v)
{
  int n = 0, k, i = 0, w, h, delay;
  for (k = 0; k < d->nframe; k++) n += d->frame[k].gif;
  if (!n) return;
  panel_size(v, 640 * 480, &w, &h);
  delay = (int)fmin(fmax(800.0 / n, 4), 50);
  tx(g, "\n# animation.gif\nif (strstrt(' '.GPVAL_TERMINALS.' ', ' gif ') > 0) {\n"
        "  set terminal gif animate delay %d loop 0 noenhanced size %d,%d\n  set output 'animation.gif'\n",
     delay, w, h);
  for (k = 0; k < d->nframe; k++)
    if (d->frame[k].gif)
      tx(g, "  K = %d; set title 't = %.6g s%s'; eval FRAME  # gif %d/%d\n", k, d->frame[k].t,
         sc->dim == 3 ? " (x-y projection)" : "", ++i, n);
  tx(g, "  set output\n} else {\n  print 'draw.gp: this gnuplot has no gif terminal: no animation.gif'\n}\n");
}

static int write_script(const mo_draw *d, const mo_scene *sc, const double *v, mo_ctx *ctx)
{
  text g = {NULL, 0, 0, 0};
  char path[4300];
  int st;
  script_head(&g, d, v);
  script_snapshots(&g, d, sc, v);
  if (d->gif) script_gif(&g, d, sc, v);
  if (g.failed) {
    free(g.s);
    return mo_error(ctx, MO_ENOMEM, "draw.gp: out of memory");
  }
  snprintf(path, sizeof path, "%s/draw.gp", d->dir);
  st = mo_write_file_atomic(path, g.s, g.len, ctx);
  free(g.s);
  return st;
}

/* --- the end of the run ---------------------------------------------------------------------- */

/* 1 when file `name` of the plots folder exists and is not empty. */
static int produced(const mo_draw *d, const char *name)
{
  char path[4300];
  struct stat sb;
  snprintf(path, sizeof path, "%s/%s", d->dir, name);
  return stat(path, &sb) == 0 && sb.st_size > 0;
}

/* Render draw.gp: the figures gnuplot produced (0 when it failed). */
static int render(const mo_draw *d, mo_ctx *ctx)
{
  char path[4300];
  char *const argv[] = {"gnuplot", "draw.gp", NULL};
  int rc;
  snprintf(path, sizeof path, "%s/snapshots.png", d->dir);
  remove(path);
  snprintf(path, sizeof path, "%s/animation.gif", d->dir);
  remove(path);
  rc = run_gnuplot(d->gnuplot, d->dir, argv, "gnuplot.log", NULL, 0);
  if (rc != 0) {
    mo_log(ctx, 1, "draw: gnuplot failed on %s/draw.gp (exit %d; its messages in gnuplot.log)\n", d->dir, rc);
    return 0;
  }
  return produced(d, "snapshots.png") + (d->gif && produced(d, "animation.gif"));
}

int mo_draw_finish(mo_draw *d, const mo_scene *sc, mo_ctx *ctx)
{
  double v[4];
  int st, nfig, nrend = 0, bad;
  if (!d->f) return MO_OK;
  view_box(d, sc, v);
  write_planes(d, sc, v);
  bad = ferror(d->f);
  bad |= fclose(d->f);
  d->f = NULL;
  if (bad) return mo_error(ctx, MO_EOUTPUT, "cannot write '%s/draw.dat'", d->dir);
  if ((st = write_script(d, sc, v, ctx))) return st;
  nfig = d->nframe ? 1 + d->gif : 0;
  if (nfig && d->gnuplot[0] && ctx->interrupt && *ctx->interrupt)
    mo_note_skip(ctx, "rendering the drawings (interrupted: gnuplot draw.gp in %s renders them)", d->dir);
  else if (nfig && d->gnuplot[0]) nrend = render(d, ctx);
  else if (nfig)
    mo_note_skip(ctx, "rendering the drawings (no gnuplot on PATH: gnuplot draw.gp in %s renders them)",
                 d->dir);
  mo_log(ctx, 1, "  drawings: %d figure%s, %d rendered (%s/draw.gp%s)\n", nfig, nfig == 1 ? "" : "s", nrend,
         d->dir, d->gnuplot[0] ? "" : "; no gnuplot on PATH");
  return MO_OK;
}
