/* output.c: CSV histories, VTK XML series (fields, rigid bodies, contact network, contact points,
   planes) appended raw, atomic file replacement. */
#ifndef _GNU_SOURCE
#define _GNU_SOURCE 1 /* O_TMPFILE, linkat */
#endif
#include "config.h"
#include <moreau/body.h>
#include <moreau/material.h>
#include <moreau/output.h>

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

int mo_mkdir_p(const char *dir, mo_ctx *ctx)
{
  char buf[4096];
  size_t n = strlen(dir), i;
  struct stat sb;
  if (n == 0) return mo_error(ctx, MO_EIO, "the output folder's name is empty");
  if (n >= sizeof buf - 64)
    return mo_error(ctx, MO_EIO, "the output folder's path has %zu characters, more than the %zu this program "
                    "takes (a shorter --out, please): '%.60s...'", n, sizeof buf - 64, dir);
  memcpy(buf, dir, n + 1);
  for (i = 1; i <= n; i++) {
    if (buf[i] == '/' || buf[i] == '\0') {
      char c = buf[i];
      buf[i] = '\0';
      if (stat(buf, &sb) != 0) {
        if (mkdir(buf, 0777) != 0 && errno != EEXIST)
          return mo_error(ctx, errno == ENAMETOOLONG ? MO_EIO : MO_EOUTPUT, "cannot create folder '%s': %s", buf,
                        strerror(errno));
      } else if (!S_ISDIR(sb.st_mode))
        return mo_error(ctx, MO_EIO, "'%s' exists and is not a folder", buf);
      buf[i] = c;
    }
  }
  return MO_OK;
}

/* A file replaced atomically. Its bytes go to an anonymous file of the destination's folder
   (O_TMPFILE) that gets a name only once complete: linked as PATH.tmp.PID and renamed onto
   PATH at once, so that a run killed while it writes (SIGKILL, a full disk) leaves no
   temporary behind (the window is one linkat and one rename; mo_outdir_claim removes what a
   killed run may still have left). Where the file system has no O_TMPFILE, the named
   temporary from the start. */
int mo_atomic_open(mo_atomic_file *A, const char *path, mo_ctx *ctx)
{
  char dir[4200];
  const char *slash;
  int fd = -1;
  A->f = NULL;
  A->anon = 0;
  A->nosync = 0;
  if (snprintf(A->path, sizeof A->path, "%s", path) >= (int)sizeof A->path ||
      snprintf(A->tmp, sizeof A->tmp, "%s.tmp.%ld", path, (long)getpid()) >= (int)sizeof A->tmp)
    return mo_error(ctx, MO_EIO, "path too long (%zu characters): '%.200s...'", strlen(path), path);
  slash = strrchr(path, '/');
  if (slash) snprintf(dir, sizeof dir, "%.*s", (int)((slash - path) ? (slash - path) : 1), path);
  else snprintf(dir, sizeof dir, ".");
#ifdef O_TMPFILE
  fd = open(dir, O_TMPFILE | O_WRONLY | O_CLOEXEC, 0666);
  if (fd >= 0 && !(A->f = fdopen(fd, "wb"))) close(fd);
  if (A->f) A->anon = 1;
#endif
  (void)fd;
  if (!A->f && !(A->f = fopen(A->tmp, "wb")))
    return mo_error(ctx, MO_EOUTPUT, "cannot write '%s': %s", A->tmp, strerror(errno));
  return MO_OK;
}

int mo_atomic_commit(mo_atomic_file *A, int ok, mo_ctx *ctx)
{
  int e = 0, st = MO_OK, named = 0;
  if (!A->f) return MO_OK;
  errno = 0;
  if (ok && (fflush(A->f) != 0 || ferror(A->f) || (!A->nosync && fsync(fileno(A->f)) != 0))) e = errno ? errno : EIO;
  if (ok && !e && A->anon) {
    /* the name and the rename in two consecutive calls, the stream closed after them (a close
       between the two widened the window in which a SIGKILL leaves PATH.tmp.PID behind) */
    char proc[64];
    snprintf(proc, sizeof proc, "/proc/self/fd/%d", fileno(A->f));
    remove(A->tmp); /* a leftover of an earlier process of the same id */
    if (linkat(AT_FDCWD, proc, AT_FDCWD, A->tmp, AT_SYMLINK_FOLLOW) != 0) e = errno ? errno : EIO;
    else if (rename(A->tmp, A->path) != 0) {
      e = errno ? errno : EIO;
      remove(A->tmp);
      fclose(A->f);
      A->f = NULL;
      return mo_error(ctx, MO_EOUTPUT, "cannot replace '%s': %s", A->path, strerror(e));
    } else
      named = 1;
  }
  if (fclose(A->f) != 0 && ok && !e) e = errno ? errno : EIO;
  A->f = NULL;
  if (named) return e ? mo_error(ctx, MO_EOUTPUT, "cannot write '%s': %s", A->path, strerror(e)) : MO_OK;
  if (!ok || e) {
    if (!A->anon || e) remove(A->tmp);
    if (e) st = mo_error(ctx, MO_EOUTPUT, "cannot write '%s': %s", A->path, strerror(e));
    return st;
  }
  if (rename(A->tmp, A->path) != 0) {
    e = errno;
    remove(A->tmp);
    return mo_error(ctx, MO_EOUTPUT, "cannot replace '%s': %s", A->path, strerror(e));
  }
  return MO_OK;
}

int mo_write_file_atomic(const char *path, const char *data, size_t len, mo_ctx *ctx)
{
  mo_atomic_file A;
  int st = mo_atomic_open(&A, path, ctx);
  if (st) return st;
  if (fwrite(data, 1, len, A.f) != len) {
    int e = errno ? errno : EIO;
    mo_atomic_commit(&A, 0, ctx);
    return mo_error(ctx, MO_EOUTPUT, "cannot write '%s': %s", path, strerror(e));
  }
  return mo_atomic_commit(&A, 1, ctx);
}

/* --- the output folder ------------------------------------------------------------------------ */

/* A temporary of mo_atomic_open: NAME.tmp.DIGITS. */
static int is_leftover(const char *name)
{
  const char *p = strstr(name, ".tmp."), *q;
  if (!p) return 0;
  for (q = p + 5; *q; q++)
    if (*q < '0' || *q > '9') return is_leftover(p + 1);
  return q > p + 5;
}

int mo_outdir_claim(mo_outdir *O, const char *dir, const char *case_file, mo_ctx *ctx)
{
  char path[4200], buf[512];
  int st, n;
  DIR *d;
  O->fd = -1;
  if ((st = mo_mkdir_p(dir, ctx))) return st;
  snprintf(O->dir, sizeof O->dir, "%s", dir);
  snprintf(path, sizeof path, "%s/.lock", dir);
  O->fd = open(path, O_RDWR | O_CREAT | O_CLOEXEC, 0666);
  if (O->fd < 0) return mo_error(ctx, MO_EOUTPUT, "cannot write '%s': %s", path, strerror(errno));
  if (flock(O->fd, LOCK_EX | LOCK_NB) != 0) {
    int e = errno;
    long pid = 0;
    n = (int)pread(O->fd, buf, sizeof buf - 1, 0);
    if (n > 0) {
      buf[n] = '\0';
      pid = strtol(buf, NULL, 10);
    }
    close(O->fd);
    O->fd = -1;
    if (e == EWOULDBLOCK)
      return mo_error(ctx, MO_EINPUT, "'%s' is the output folder of another run in progress (pid %ld holds "
                      "'%s'): wait for it to end, or give this run another --out", dir, pid, path);
    return mo_error(ctx, MO_EOUTPUT, "cannot lock '%s': %s", path, strerror(e));
  }
  n = snprintf(buf, sizeof buf, "%ld\n", (long)getpid());
  if (ftruncate(O->fd, 0) != 0 || pwrite(O->fd, buf, (size_t)n, 0) != n) {
    /* a full disk: the lock holds without the pid */
  }
  /* the temporaries of a run killed while it wrote (no other run holds the folder) */
  if ((d = opendir(dir))) {
    struct dirent *de;
    while ((de = readdir(d)))
      if (is_leftover(de->d_name)) {
        snprintf(path, sizeof path, "%s/%s", dir, de->d_name);
        remove(path);
      }
    closedir(d);
  }
  /* the old summary is stale from here on: replaced by "running" (atomically), or removed
     when even that cannot be written (a full disk) */
  snprintf(path, sizeof path, "%s/summary.json", dir);
  {
    char js[4600];
    const char *c = case_file ? case_file : "";
    size_t k, m = 0;
    m += (size_t)snprintf(js, sizeof js, "{\n  \"moreau\": \"%s\",\n  \"case\": \"", PACKAGE_VERSION);
    for (k = 0; c[k] && m < sizeof js - 200; k++) {
      unsigned char ch = (unsigned char)c[k];
      if (ch == '"' || ch == '\\') js[m++] = '\\';
      js[m++] = ch < 0x20 || ch >= 0x80 ? '?' : (char)ch;
    }
    m += (size_t)snprintf(js + m, sizeof js - m,
                          "\",\n  \"status\": \"running\",\n  \"pid\": %ld,\n  \"reason\": \"the run has not ended "
                          "(or was killed): the files beside this one are partial\"\n}\n", (long)getpid());
    st = mo_write_file_atomic(path, js, m, ctx);
  }
  if (st) {
    remove(path);
    mo_outdir_release(O);
    return st;
  }
  return MO_OK;
}

void mo_outdir_release(mo_outdir *O)
{
  if (O->fd >= 0) close(O->fd);
  O->fd = -1;
}

/* --- CSV --------------------------------------------------------------------------------------- */

struct mo_csv {
  FILE *f;
  int ncol, prec;
  char *path;
};

int mo_csv_open(const char *path, const char *const *names, int ncol, int precision,
                mo_csv **out, mo_ctx *ctx)
{
  mo_csv *c = mo_calloc(ctx, 1, sizeof *c);
  int k;
  *out = NULL;
  if (!c) return MO_ENOMEM;
  c->path = mo_strdup(ctx, path);
  if (!c->path) { mo_free(c); return MO_ENOMEM; }
  c->f = fopen(path, "w");
  if (!c->f) {
    mo_free(c->path);
    mo_free(c);
    return mo_error(ctx, MO_EOUTPUT, "cannot write '%s': %s", path, strerror(errno));
  }
  c->ncol = ncol;
  c->prec = precision;
  for (k = 0; k < ncol; k++) fprintf(c->f, "%s%s", k ? "," : "", names[k]);
  fputc('\n', c->f);
  if (fflush(c->f) != 0) {
    mo_csv_close(c, ctx);
    return mo_error(ctx, MO_EOUTPUT, "cannot write '%s': %s", path, strerror(errno));
  }
  *out = c;
  return MO_OK;
}

int mo_csv_row(mo_csv *c, const double *vals, mo_ctx *ctx)
{
  int k;
  for (k = 0; k < c->ncol; k++) fprintf(c->f, "%s%.*g", k ? "," : "", c->prec, vals[k]);
  fputc('\n', c->f);
  if (fflush(c->f) != 0)
    return mo_error(ctx, MO_EOUTPUT, "cannot write '%s': %s", c->path, strerror(errno));
  return MO_OK;
}

int mo_csv_close(mo_csv *c, mo_ctx *ctx)
{
  int st = MO_OK;
  if (!c) return MO_OK;
  if (c->f && fclose(c->f) != 0) st = mo_error(ctx, MO_EOUTPUT, "cannot write '%s': %s", c->path, strerror(errno));
  mo_free(c->path);
  mo_free(c);
  return st;
}

/* --- VTK ----------------------------------------------------------------------------------- */

/* Every .vtu of the series is an UnstructuredGrid whose arrays are appended raw (VTK's
   format="appended", encoding="raw": after the XML, '_' then per array a UInt64 byte count and
   the values in the machine's byte order, which the file names), exact to the last bit and read
   by VTK, ParaView and meshio. A file is written in two passes of the same code: the first
   writes the XML, each array declared with its offset; the second its values. An array whose
   values do not fill what was declared is an internal error, never a file. The contact network
   and points come by chunks (MO_VTK_CHUNK entries, moreau/output.h): their second pass runs once
   per chunk, each array's slice of values put at its place in the file (vtu_slice). */

#define VTU_MAXARR 32

typedef enum { VT_F64 = 8, VT_I32 = 4, VT_U8 = 1 } vtu_type;

typedef struct {
  mo_atomic_file A;
  FILE *f;
  int pass;             /* 0: XML, 1: the appended values */
  uint64_t offset;      /* pass 0: the offset of the next array */
  uint64_t left;        /* pass 1: the bytes the current array still owes */
  int short_array;      /* an array got fewer or more values than it declared */
  unsigned char buf[1 << 16];
  size_t nbuf;
  /* values by slices (sliced): every array's offset and bytes (pass 0), the file position of
     the first byte count, the entries of the file, those written, the current slice */
  int sliced, narr, karr;
  uint64_t aoff[VTU_MAXARR], abytes[VTU_MAXARR];
  off_t base;
  long stotal, sdone, sfirst, sn;
} vtu;

static void vtu_flush(vtu *w)
{
  if (w->nbuf) fwrite(w->buf, 1, w->nbuf, w->f);
  w->nbuf = 0;
}

static void vtu_bytes(vtu *w, const void *p, size_t n)
{
  if (n > w->left) {
    w->short_array = 1;
    return;
  }
  w->left -= n;
  if (w->nbuf + n > sizeof w->buf) vtu_flush(w);
  memcpy(w->buf + w->nbuf, p, n);
  w->nbuf += n;
}

static void put_f64(vtu *w, double x) { vtu_bytes(w, &x, sizeof x); }
static void put_i32(vtu *w, long x)
{
  int32_t y = (int32_t)x;
  vtu_bytes(w, &y, sizeof y);
}
static void put_u8(vtu *w, int x)
{
  unsigned char y = (unsigned char)x;
  vtu_bytes(w, &y, 1);
}
/* The first D of three components, padded with zeros (2D and 1D vectors as VTK's 3). */
static void put_vec3(vtu *w, const double *x, int D)
{
  int i;
  for (i = 0; i < 3; i++) put_f64(w, i < D ? x[i] : 0.0);
}

/* An array of n values (ncomp per tuple) named `name`. Pass 0 declares it and returns 0; pass
   1 starts its values and returns 1: the caller then puts exactly n values. */
static int vtu_array(vtu *w, const char *name, vtu_type type, int ncomp, long n)
{
  uint64_t bytes = (uint64_t)n * (uint64_t)type;
  if (w->pass == 0) {
    fprintf(w->f, "<DataArray type=\"%s\" Name=\"%s\" NumberOfComponents=\"%d\" format=\"appended\" "
                  "offset=\"%llu\"/>\n",
            type == VT_F64 ? "Float64" : type == VT_I32 ? "Int32" : "UInt8", name, ncomp,
            (unsigned long long)w->offset);
    if (w->narr < VTU_MAXARR) {
      w->aoff[w->narr] = w->offset;
      w->abytes[w->narr] = bytes;
    }
    w->narr++;
    w->offset += sizeof bytes + bytes;
    return 0;
  }
  if (w->left) w->short_array = 1;
  if (w->sliced) {
    /* this slice's values of array k: bytes per entry times the slice's entries, at the entry's place */
    int k = w->karr++;
    uint64_t per = k < w->narr && k < VTU_MAXARR && w->stotal > 0 ? w->abytes[k] / (uint64_t)w->stotal : 0;
    vtu_flush(w);
    w->left = 0;
    if (k >= w->narr || k >= VTU_MAXARR || per * (uint64_t)w->stotal != w->abytes[k] || bytes != per * (uint64_t)w->sn ||
        fseeko(w->f, w->base + (off_t)(w->aoff[k] + sizeof bytes + per * (uint64_t)w->sfirst), SEEK_SET)) {
      w->short_array = 1;
      return 1;
    }
    w->left = bytes;
    return 1;
  }
  w->left = sizeof bytes;
  vtu_bytes(w, &bytes, sizeof bytes);
  w->left = bytes;
  return 1;
}

/* XML of the first pass only (section tags). */
static void vtu_xml(vtu *w, const char *text)
{
  if (w->pass == 0) fputs(text, w->f);
}

static const char *byte_order(void)
{
  const uint16_t one = 1;
  return *(const unsigned char *)&one ? "LittleEndian" : "BigEndian";
}

/* Open `path` (a temporary until vtu_close) for a piece of npoint points and ncell cells at
   time t (its FieldData TimeValue), and write the header. */
static int vtu_open(vtu *w, const char *path, long npoint, long ncell, double t, mo_ctx *ctx)
{
  int st;
  w->f = NULL;
  w->pass = 0;
  w->offset = w->left = 0;
  w->short_array = 0;
  w->nbuf = 0;
  w->sliced = w->narr = w->karr = 0;
  if (npoint > INT_MAX || ncell > INT_MAX)
    return mo_error(ctx, MO_ELIMIT, "'%s': more than %d points or cells", path, INT_MAX);
  if ((st = mo_atomic_open(&w->A, path, ctx))) return st;
  w->A.nosync = 1;
  w->f = w->A.f;
  fprintf(w->f, "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" "
                "byte_order=\"%s\" header_type=\"UInt64\">\n<UnstructuredGrid>\n"
                "<FieldData>\n<DataArray type=\"Float64\" Name=\"TimeValue\" NumberOfTuples=\"1\" format=\"ascii\">"
                "%.17g</DataArray>\n</FieldData>\n"
                "<Piece NumberOfPoints=\"%ld\" NumberOfCells=\"%ld\">\n",
          byte_order(), t, npoint, ncell);
  return MO_OK;
}

/* Between the passes: the end of the XML, the start of the appended values. */
static void vtu_values(vtu *w)
{
  fputs("</Piece>\n</UnstructuredGrid>\n<AppendedData encoding=\"raw\">\n_", w->f);
  w->pass = 1;
}

/* The same, for values that come by slices of a file of `total` entries (every array's values
   a fixed number per entry): every byte count is written now, the values by vtu_slice. */
static void vtu_values_sliced(vtu *w, long total)
{
  int k;
  vtu_values(w);
  w->sliced = 1;
  w->stotal = total;
  w->sdone = 0;
  w->base = ftello(w->f);
  if (w->base < 0 || w->narr > VTU_MAXARR) w->short_array = 1;
  for (k = 0; !w->short_array && k < w->narr; k++)
    if (fseeko(w->f, w->base + (off_t)w->aoff[k], SEEK_SET) || fwrite(&w->abytes[k], sizeof w->abytes[k], 1, w->f) != 1)
      w->short_array = 1;
}

/* The next slice: entries first .. first + n - 1, following the previous one. */
static void vtu_slice(vtu *w, long first, long n)
{
  if (first != w->sdone || n < 0 || first + n > w->stotal) w->short_array = 1;
  w->sdone = first + n;
  w->sfirst = first;
  w->sn = n;
  w->karr = 0;
}

/* Close the file and put it in place; `ok` 0 (an error of the caller): removed. */
static int vtu_close(vtu *w, int ok, mo_ctx *ctx)
{
  if (!w->f) return MO_OK;
  if (ok) {
    if (w->left) w->short_array = 1;
    vtu_flush(w);
    /* by slices: every entry written, then the end of the values */
    if (w->sliced && (w->sdone != w->stotal || fseeko(w->f, w->base + (off_t)w->offset, SEEK_SET)))
      w->short_array = 1;
    fputs("\n</AppendedData>\n</VTKFile>\n", w->f);
  }
  w->f = NULL;
  if (ok && w->short_array) {
    mo_atomic_commit(&w->A, 0, ctx);
    return mo_error(ctx, MO_EINTERNAL, "'%s': an array's values do not match its declaration", w->A.path);
  }
  return mo_atomic_commit(&w->A, ok, ctx);
}

/* Cells of one type with nv vertices each, numbered in order (vertices, lines): connectivity,
   offsets, types; ncell cells from cell c0 (a slice: c0 its first entry). */
static void vtu_cells_from(vtu *w, long c0, long ncell, int nv, int type)
{
  long c;
  vtu_xml(w, "<Cells>\n");
  if (vtu_array(w, "connectivity", VT_I32, 1, ncell * nv))
    for (c = 0; c < ncell * nv; c++) put_i32(w, c0 * nv + c);
  if (vtu_array(w, "offsets", VT_I32, 1, ncell))
    for (c = 0; c < ncell; c++) put_i32(w, (c0 + c + 1) * nv);
  if (vtu_array(w, "types", VT_U8, 1, ncell))
    for (c = 0; c < ncell; c++) put_u8(w, type);
  vtu_xml(w, "</Cells>\n");
}

static void vtu_uniform_cells(vtu *w, long ncell, int nv, int type) { vtu_cells_from(w, 0, ncell, nv, type); }

struct mo_vtk {
  char *dir;
  int nframe, cap;
  double *times;
  int fields;                /* deformable bodies: fields_BODY_NNNNN.vtu, fields.pvd */
  int balls, shapes, rigid;  /* the rigid series of the scene: particles, polygons, contacts */
  int points;                /* contact_points_NNNNN.vtu (the scene has contact, output.vtk.contacts) */
  int planes;                /* planes_NNNNN.vtu */
  double box[6];             /* the bodies' bounding box over the frames so far (planes' size) */
  int has_box;
  /* MPI runs (doc/parallel.md §3): each rank writes its piece of every deformable body, rank r
     the elements [ne r / N, ne (r + 1) / N) as fields_BODY_NNNNN_r.vtu, and rank 0 the
     fields_BODY_NNNNN.pvtu that joins them and every other series */
  int rank, nranks;
  int indexed;               /* frames whose collections (.pvtu, .pvd) are written */
};

static int write_paraview_script(const mo_vtk *v, const mo_scene *sc, mo_ctx *ctx);

int mo_vtk_open(const char *dir, const mo_scene *sc, int contact, mo_vtk **out, mo_ctx *ctx)
{
  mo_vtk *v = mo_calloc(ctx, 1, sizeof *v);
  int k, st;
  *out = NULL;
  if (!v) return MO_ENOMEM;
  v->dir = mo_strdup(ctx, dir);
  if (!v->dir) { mo_free(v); return MO_ENOMEM; }
  for (k = 0; k < sc->nbody; k++) {
    v->fields |= sc->body[k].kind == MO_BODY_DEFORMABLE;
    v->planes |= sc->body[k].kind == MO_BODY_PLANE;
  }
  for (k = 0; k < sc->nrigid; k++) {
    mo_body_kind kd = sc->body[sc->rigid[k]].kind;
    v->balls |= kd == MO_BODY_DISK || kd == MO_BODY_SPHERE;
    v->shapes |= kd == MO_BODY_POLYGON || kd == MO_BODY_RIGID_MESH;
  }
  v->rigid = sc->nrigid > 0;
  v->points = contact && sc->out.vtk_contacts != MO_VTK_CONTACTS_NONE;
  v->rank = ctx->rank;
  v->nranks = ctx->nranks;
  if (v->rank != 0) v->balls = v->shapes = v->rigid = v->points = v->planes = 0;
  if (v->rigid && (st = write_paraview_script(v, sc, ctx))) {
    mo_vtk_close(v);
    return st;
  }
  *out = v;
  return MO_OK;
}

int mo_vtk_frames(const mo_vtk *v) { return v->nframe; }

int mo_vtk_wants_points(const mo_vtk *v) { return v->points; }

unsigned mo_vtk_outputs(const mo_vtk *v)
{
  return (v->fields ? MO_OUT_FIELDS : 0u) | (v->points ? MO_OUT_CONTACT_POINTS : 0u) |
         (v->planes ? MO_OUT_PLANES : 0u) | (v->rigid ? MO_OUT_RIGID : 0u);
}

void mo_vtk_close(mo_vtk *v)
{
  if (!v) return;
  mo_free(v->dir);
  mo_free(v->times);
  mo_free(v);
}

int mo_vtk_contacts_reserve(mo_vtk_contacts *N, int n, mo_ctx *ctx)
{
  int cap = N->cap ? N->cap : 16;
  void *p;
  if (n <= N->cap) return MO_OK;
  while (cap < n) cap *= 2;
#define GROW(ptr, k)                                                                            \
  if (!(p = mo_realloc(ctx, ptr, (size_t)cap * (k) * sizeof *(ptr)))) return MO_ENOMEM;           \
  ptr = p
  GROW(N->end, 6); GROW(N->point, 3); GROW(N->rn, 1); GROW(N->rt, 1); GROW(N->gap, 1);
  GROW(N->status, 1); GROW(N->body, 2);
#undef GROW
  N->cap = cap;
  return MO_OK;
}

void mo_vtk_source_drop(mo_vtk_source *src)
{
  mo_free(src->rec);
  mo_free(src->ord);
  src->rec = NULL;
  src->ord = NULL;
  src->nrec = 0;
}

void mo_vtk_contacts_release(mo_vtk_contacts *N)
{
  if (!N) return;
  mo_free(N->end);
  mo_free(N->point);
  mo_free(N->rn);
  mo_free(N->rt);
  mo_free(N->gap);
  mo_free(N->status);
  mo_free(N->body);
  mo_vtk_source_drop(&N->src);
  memset(N, 0, sizeof *N);
}

void mo_vtk_contacts_rewind(mo_vtk_contacts *N)
{
  N->first = 0;
  N->n = 0;
  N->src.cursor = 0;
}

int mo_vtk_contacts_next(mo_vtk_contacts *N, mo_ctx *ctx)
{
  N->first += N->n;
  N->n = 0;
  return N->first < N->total && N->fill ? N->fill(N, ctx) : MO_OK;
}

int mo_vtk_points_reserve(mo_vtk_points *P, int n, int d, mo_ctx *ctx)
{
  int cap = P->cap ? P->cap : 16;
  void *p;
  P->d = d;
  if (n <= P->cap) return MO_OK;
  while (cap < n) cap *= 2;
#define GROW(ptr, k)                                                                            \
  if (!(p = mo_realloc(ctx, ptr, (size_t)cap * (k) * sizeof *(ptr)))) return MO_ENOMEM;           \
  ptr = p
  GROW(P->x, 3); GROW(P->x0, 3); GROW(P->disp, 3); GROW(P->normal, 3); GROW(P->R, 3); GROW(P->U, 3);
  GROW(P->force, 3); GROW(P->vrel, 3); GROW(P->gap, 1); GROW(P->lambda, 1); GROW(P->measure, 1);
  GROW(P->cand, 1); GROW(P->pair, 1); GROW(P->node, 1); GROW(P->status, 1); GROW(P->body, 2);
#undef GROW
  P->cap = cap;
  return MO_OK;
}

void mo_vtk_points_release(mo_vtk_points *P)
{
  if (!P) return;
  mo_free(P->x); mo_free(P->x0); mo_free(P->disp); mo_free(P->normal); mo_free(P->R); mo_free(P->U);
  mo_free(P->force); mo_free(P->vrel); mo_free(P->gap); mo_free(P->lambda); mo_free(P->measure);
  mo_free(P->cand); mo_free(P->pair); mo_free(P->node); mo_free(P->status); mo_free(P->body);
  mo_vtk_source_drop(&P->src);
  memset(P, 0, sizeof *P);
}

void mo_vtk_points_rewind(mo_vtk_points *P)
{
  P->first = 0;
  P->n = 0;
  P->src.cursor = 0;
}

int mo_vtk_points_next(mo_vtk_points *P, mo_ctx *ctx)
{
  P->first += P->n;
  P->n = 0;
  return P->first < P->total && P->fill ? P->fill(P, ctx) : MO_OK;
}

/* The tubes' radius in particles.py: a tenth of the smallest rigid body. */
static double tube_radius(const mo_scene *sc)
{
  double r = HUGE_VAL;
  int k;
  for (k = 0; k < sc->nrigid; k++) {
    const mo_body *B = &sc->body[sc->rigid[k]];
    double b = B->kind == MO_BODY_DISK || B->kind == MO_BODY_SPHERE ? B->radius : B->bound;
    if (b > 0 && b < r) r = b;
  }
  return r < HUGE_VAL ? 0.1 * r : 0.01;
}

/* particles.py, once: the ParaView script that shows the rigid series (pvpython, or the GUI's
   Python Shell > Run Script). The folder is found from the script's own path, or else is the
   absolute path of v->dir when the run wrote it. */
static int write_paraview_script(const mo_vtk *v, const mo_scene *sc, mo_ctx *ctx)
{
  char path[4200], absdir[PATH_MAX], here[PATH_MAX + 8], text[8192];
  int n;
  /* the folder as a Python literal; a name with quotes or backslashes: the current folder */
  if (realpath(v->dir, absdir) && !strpbrk(absdir, "'\\\n")) snprintf(here, sizeof here, "'%s'", absdir);
  else snprintf(here, sizeof here, "os.getcwd()");
  n = snprintf(text, sizeof text,
    "# particles.py: a ParaView view of the rigid-body series moreau wrote in this folder.\n"
    "# Run: `pvpython particles.py`, `paraview --script=particles.py`, or in ParaView View > Python Shell >\n"
    "# Run Script. It loads particles.pvd (disks and spheres as points) and draws them as spheres of\n"
    "# their radius (Glyph scaled by the point array radius) coloured by the velocity magnitude,\n"
    "# polygons.pvd (polygons and rigid meshes) coloured likewise, and contacts.pvd (the contact network,\n"
    "# one line per closed contact) as tubes coloured by the normal force rn. Arrays: particles (points):\n"
    "# radius, velocity, omega, orientation (2D: angle; 3D: quaternion w x y z), body; polygons (cells):\n"
    "# velocity, omega, body; contacts (cells): rn, rt (forces), gap, point, status (0 open, 1 stick,\n"
    "# 2 slide), slave, master (body numbers); planes.pvd (the planes, sized to the scene) and\n"
    "# contact_points.pvd (a point per candidate: force, R, U, gap, status...) when written. Play the\n"
    "# animation for the time series.\n"
    "import os\n"
    "from paraview.simple import *\n\n"
    "try:\n    HERE = os.path.dirname(os.path.abspath(__file__))\n"
    "except NameError:  # Run Script may not set __file__\n    HERE = %s\n\n"
    "def series(name):\n"
    "    path = os.path.join(HERE, name + '.pvd')\n"
    "    return PVDReader(FileName=path) if os.path.exists(path) else None\n\n"
    "def colour(shown, where, array, component=None):\n"
    "    ColorBy(shown, (where, array, component) if component else (where, array))\n"
    "    shown.RescaleTransferFunctionToDataRange(True, False)\n"
    "    shown.SetScalarBarVisibility(view, True)\n\n"
    "view = GetActiveViewOrCreate('RenderView')\n"
    "particles = series('particles')\n"
    "if particles is not None:\n"
    "    glyph = Glyph(Input=particles, GlyphType='Sphere')\n"
    "    glyph.ScaleArray = ['POINTS', 'radius']\n"
    "    glyph.ScaleFactor = 2.0  # the glyph sphere has radius 1/2: a sphere of radius r\n"
    "    glyph.GlyphMode = 'All Points'\n"
    "    colour(Show(glyph, view), 'POINTS', 'velocity', 'Magnitude')\n"
    "polygons = series('polygons')\n"
    "if polygons is not None:\n"
    "    colour(Show(polygons, view), 'CELLS', 'velocity', 'Magnitude')\n"
    "contacts = series('contacts')\n"
    "if contacts is not None:\n"
    "    tube = Tube(Input=contacts)\n"
    "    tube.Radius = %.6g  # a tenth of the smallest body\n"
    "    colour(Show(tube, view), 'CELLS', 'rn')\n"
    "planes = series('planes')\n"
    "if planes is not None:\n"
    "    shown = Show(planes, view)\n"
    "    shown.Opacity = 0.3\n"
    "points = series('contact_points')\n"
    "if points is not None:\n"
    "    arrows = Glyph(Input=points, GlyphType='Arrow')\n"
    "    arrows.OrientationArray = ['POINTS', 'force']\n"
    "    arrows.ScaleArray = ['POINTS', 'No scale array']\n"
    "    arrows.ScaleFactor = %.6g  # the contact forces' directions, coloured by their size\n"
    "    arrows.GlyphMode = 'All Points'\n"
    "    colour(Show(arrows, view), 'POINTS', 'force', 'Magnitude')\n"
    "GetAnimationScene().UpdateAnimationUsingDataTimeSteps()\n"
    "%s"
    "view.ResetCamera()\n"
    "Render()\n",
    here, tube_radius(sc), 20 * tube_radius(sc), sc->dim == 2 ? "view.InteractionMode = '2D'\n" : "");
  if (n < 0 || n >= (int)sizeof text) return mo_error(ctx, MO_EINTERNAL, "particles.py: text too long");
  snprintf(path, sizeof path, "%s/particles.py", v->dir);
  return mo_write_file_atomic(path, text, (size_t)n, ctx);
}

static int vtk_cell_type(mo_eltype t)
{
  switch (t) {
  case MO_EL_BAR2: return 3;   /* VTK_LINE */
  case MO_EL_T3: return 5;     /* VTK_TRIANGLE */
  case MO_EL_Q4: return 9;     /* VTK_QUAD */
  case MO_EL_T4: return 10;    /* VTK_TETRA */
  case MO_EL_T6: return 22;    /* VTK_QUADRATIC_TRIANGLE: the node order of mesh.h */
  case MO_EL_T10: return 24;   /* VTK_QUADRATIC_TETRA: the node order of mesh.h */
  default: return 12;          /* VTK_HEXAHEDRON */
  }
}

/* Green-Lagrange strain E = (F^T F - I) / 2 at the centroid of element e of a finite-strain
   body, in the hypothesis' component order (fe.h). */
static void green_lagrange(const mo_mesh *m, int e, const mo_material *mat, const double *ue,
                           double *E)
{
  double N[MO_NEN_MAX], dN[MO_ND_MAX], xq[3], F[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, C[9];
  int D = m->dim, a, i, j, k;
  mo_elem_geometry(m, e, mo_eltype_get(m->type)->centre, N, dN, xq);
  for (a = 0; a < m->nen; a++)
    for (i = 0; i < D; i++)
      for (j = 0; j < D; j++) F[3 * i + j] += ue[a * D + i] * dN[a * D + j];
  if (mat->hyp == MO_HYP_AXISYMMETRIC && xq[0] > 0) {
    double ur = 0;
    for (a = 0; a < m->nen; a++) ur += N[a] * ue[a * D];
    F[8] = 1 + ur / xq[0];
  }
  for (i = 0; i < 3; i++)
    for (j = 0; j < 3; j++) {
      C[3 * i + j] = -(i == j);
      for (k = 0; k < 3; k++) C[3 * i + j] += F[3 * k + i] * F[3 * k + j];
      C[3 * i + j] *= 0.5;
    }
  if (D == 3) {
    E[0] = C[0]; E[1] = C[4]; E[2] = C[8]; E[3] = C[5]; E[4] = C[2]; E[5] = C[1];
  } else {
    E[0] = C[0]; E[1] = C[4]; E[2] = C[1]; E[3] = C[8];
  }
}


/* The element fields of a deformable body at state s: strain and stress as VTK's symmetric
   tensors (XX YY ZZ XY YZ XZ; finite-strain bodies: Green-Lagrange at the centroid and the
   material state's Cauchy stress), von Mises, eps_p (finite-strain bodies). Arrays of nelem. */
static void element_fields(const mo_scene *sc, const mo_body *B, const mo_state *s, double *eps, double *sig,
                           double *vm, double *ep)
{
  const mo_mesh *m = B->mesh;
  int D = sc->dim, a, c, e, w, nc = mo_hyp_ncomp(B->mat->hyp);
  for (e = 0; e < m->nelem; e++) {
    double ue[MO_ND_MAX], ee[6], se[6];
    ep[e] = 0;
    for (a = 0; a < m->nen; a++)
      for (c = 0; c < D; c++) ue[a * D + c] = s->u[B->dof0 + m->conn[e * m->nen + a] * D + c];
    if (B->nl) {
      const double *q = s->q + B->q0 + (size_t)e * (size_t)B->npoint * MO_J2_NSTATE;
      mo_elem_nl_fields(m, e, B->mat, q, se, &vm[e], &ep[e]);
      green_lagrange(m, e, B->mat, ue, ee);
    } else {
      mo_elem_stress(m, e, B->mat, ue, ee, se);
      vm[e] = mo_von_mises(B->mat->hyp, se);
    }
    for (w = 0; w < 2; w++) {
      const double *in = w ? se : ee;
      double *o = (w ? sig : eps) + 6 * e;
      memset(o, 0, 6 * sizeof *o);
      if (nc == 1) o[0] = in[0];
      else if (nc == 6) { o[0] = in[0]; o[1] = in[1]; o[2] = in[2]; o[3] = in[5]; o[4] = in[3]; o[5] = in[4]; }
      else { o[0] = in[0]; o[1] = in[1]; o[2] = in[3]; o[3] = in[2]; }
    }
  }
}

/* fields_BODY_NNNNN.vtu: the mesh in its reference configuration, point data displacement and
   velocity, cell data strain, stress, von_mises, eps_p (as output.vtk.fields asks). */
static int write_fields(const char *path, const mo_scene *sc, const mo_body *B, const mo_state *s,
                        unsigned fields, long e0, long e1, mo_ctx *ctx)
{
  static const char *vname[2] = {"displacement", "velocity"};
  const mo_mesh *m = B->mesh;
  const double *vsrc[2] = {s->u, s->v};
  int D = sc->dim, a, e, w, st, cells = fields & (MO_VTK_STRESS | MO_VTK_STRAIN | MO_VTK_VON_MISES | MO_VTK_EPS_P);
  long ne = e1 - e0, np = m->nnode;
  int *nodes = NULL, *local = NULL; /* a piece: its nodes, and each mesh node's number in it */
  double *eps = NULL, *sig = NULL, *vm = NULL, *ep = NULL;
  vtu wr;
  if (ne < m->nelem) {
    long k;
    nodes = mo_malloc(ctx, (size_t)m->nnode * sizeof *nodes);
    local = mo_malloc(ctx, (size_t)m->nnode * sizeof *local);
    if (!nodes || !local) {
      st = MO_ENOMEM;
      goto done;
    }
    for (a = 0; a < m->nnode; a++) local[a] = -1;
    for (np = 0, k = e0 * m->nen; k < e1 * m->nen; k++)
      if (local[m->conn[k]] < 0) {
        local[m->conn[k]] = (int)np;
        nodes[np++] = m->conn[k];
      }
  }
#define NODE(i) (nodes ? nodes[i] : (i))
  if (cells) {
    /* every element's (a piece reads its own) */
    eps = mo_malloc(ctx, (size_t)(m->nelem + 1) * 6 * sizeof(double));
    sig = mo_malloc(ctx, (size_t)(m->nelem + 1) * 6 * sizeof(double));
    vm = mo_malloc(ctx, (size_t)(m->nelem + 1) * sizeof(double));
    ep = mo_malloc(ctx, (size_t)(m->nelem + 1) * sizeof(double));
    if (!eps || !sig || !vm || !ep) {
      st = MO_ENOMEM;
      goto done;
    }
    element_fields(sc, B, s, eps, sig, vm, ep);
  }
  if ((st = vtu_open(&wr, path, np, ne, s->t, ctx))) goto done;
  for (; wr.pass < 2; wr.pass++) {
    if (wr.pass) vtu_values(&wr);
    vtu_xml(&wr, "<Points>\n");
    if (vtu_array(&wr, "points", VT_F64, 3, 3L * np))
      for (a = 0; a < np; a++) put_vec3(&wr, m->x + (size_t)NODE(a) * D, D);
    vtu_xml(&wr, "</Points>\n<Cells>\n");
    if (vtu_array(&wr, "connectivity", VT_I32, 1, ne * m->nen))
      for (e = 0; e < ne * m->nen; e++) {
        int n = m->conn[e0 * m->nen + e];
        put_i32(&wr, local ? local[n] : n);
      }
    if (vtu_array(&wr, "offsets", VT_I32, 1, ne))
      for (e = 0; e < ne; e++) put_i32(&wr, (long)(e + 1) * m->nen);
    if (vtu_array(&wr, "types", VT_U8, 1, ne))
      for (e = 0; e < ne; e++) put_u8(&wr, vtk_cell_type(m->type));
    vtu_xml(&wr, "</Cells>\n<PointData Vectors=\"displacement\">\n");
    for (w = 0; w < 2; w++)
      if ((fields & (w ? MO_VTK_VELOCITY : MO_VTK_DISPLACEMENT)) && vtu_array(&wr, vname[w], VT_F64, 3, 3L * np))
        for (a = 0; a < np; a++) put_vec3(&wr, vsrc[w] + B->dof0 + (size_t)NODE(a) * D, D);
    vtu_xml(&wr, "</PointData>\n<CellData>\n");
    for (w = 0; w < 2; w++)
      if ((fields & (w ? MO_VTK_STRESS : MO_VTK_STRAIN)) && vtu_array(&wr, w ? "stress" : "strain", VT_F64, 6, 6 * ne))
        for (e = 0; e < 6 * ne; e++) put_f64(&wr, (w ? sig : eps)[6 * e0 + e]);
    if ((fields & MO_VTK_VON_MISES) && vtu_array(&wr, "von_mises", VT_F64, 1, ne))
      for (e = 0; e < ne; e++) put_f64(&wr, vm[e0 + e]);
    if ((fields & MO_VTK_EPS_P) && B->nl && vtu_array(&wr, "eps_p", VT_F64, 1, ne))
      for (e = 0; e < ne; e++) put_f64(&wr, ep[e0 + e]);
    vtu_xml(&wr, "</CellData>\n");
  }
  st = vtu_close(&wr, 1, ctx);
#undef NODE
done:
  mo_free(nodes);
  mo_free(local);
  mo_free(eps);
  mo_free(sig);
  mo_free(vm);
  mo_free(ep);
  return st;
}

/* The parallel file of frame k of body B: the arrays its pieces hold (as write_fields writes
   them) and the pieces fields_BODY_k_r.vtu of the ranks. */
static int write_fields_pvtu(const mo_vtk *v, const mo_scene *sc, const mo_body *B, int k, mo_ctx *ctx)
{
  char path[4200], buf[8192];
  unsigned f = sc->out.vtk_fields;
  size_t len = 0;
  int r;
#define P(...) (len += (size_t)snprintf(buf + len, len < sizeof buf ? sizeof buf - len : 0, __VA_ARGS__))
  P("<?xml version=\"1.0\"?>\n<VTKFile type=\"PUnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
    "header_type=\"UInt64\">\n<PUnstructuredGrid GhostLevel=\"0\">\n");
  P("<PPoints><PDataArray type=\"Float64\" NumberOfComponents=\"3\" Name=\"points\"/></PPoints>\n");
  P("<PPointData Vectors=\"displacement\">\n");
  if (f & MO_VTK_DISPLACEMENT) P("<PDataArray type=\"Float64\" NumberOfComponents=\"3\" Name=\"displacement\"/>\n");
  if (f & MO_VTK_VELOCITY) P("<PDataArray type=\"Float64\" NumberOfComponents=\"3\" Name=\"velocity\"/>\n");
  P("</PPointData>\n<PCellData>\n");
  if (f & MO_VTK_STRAIN) P("<PDataArray type=\"Float64\" NumberOfComponents=\"6\" Name=\"strain\"/>\n");
  if (f & MO_VTK_STRESS) P("<PDataArray type=\"Float64\" NumberOfComponents=\"6\" Name=\"stress\"/>\n");
  if (f & MO_VTK_VON_MISES) P("<PDataArray type=\"Float64\" NumberOfComponents=\"1\" Name=\"von_mises\"/>\n");
  if ((f & MO_VTK_EPS_P) && B->nl) P("<PDataArray type=\"Float64\" NumberOfComponents=\"1\" Name=\"eps_p\"/>\n");
  P("</PCellData>\n");
  for (r = 0; r < v->nranks; r++) P("<Piece Source=\"fields_%s_%05d_%d.vtu\"/>\n", B->name, k, r);
  P("</PUnstructuredGrid>\n</VTKFile>\n");
#undef P
  if (len >= sizeof buf) return mo_error(ctx, MO_ELIMIT, "the parallel file of body '%s' lists too many pieces", B->name);
  snprintf(path, sizeof path, "%s/fields_%s_%05d.pvtu", v->dir, B->name, k);
  return mo_write_file_atomic(path, buf, len, ctx);
}

/* fields.pvd, rewritten whole so that it always lists complete frames only. */
static int write_fields_pvd(const mo_vtk *v, const mo_scene *sc, mo_ctx *ctx)
{
  char path[4200], *pvd = NULL;
  size_t cap = 4096, len = 0;
  int b, k, st;
  pvd = mo_malloc(ctx, cap);
  if (!pvd) return MO_ENOMEM;
#define APPEND(...)                                                                             \
  do {                                                                                          \
    int w_ = snprintf(pvd + len, cap - len, __VA_ARGS__);                                       \
    while (w_ >= 0 && (size_t)w_ >= cap - len) {                                                \
      char *p_ = mo_realloc(ctx, pvd, cap * 2);                                                 \
      if (!p_) { mo_free(pvd); return MO_ENOMEM; }                                              \
      pvd = p_; cap *= 2;                                                                       \
      w_ = snprintf(pvd + len, cap - len, __VA_ARGS__);                                         \
    }                                                                                           \
    len += (size_t)w_;                                                                          \
  } while (0)
  APPEND("<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n<Collection>\n");
  for (k = 0; k < v->nframe; k++)
    for (b = 0; b < sc->nbody; b++)
      if (sc->body[b].kind == MO_BODY_DEFORMABLE)
        APPEND("<DataSet timestep=\"%.17g\" part=\"%d\" file=\"fields_%s_%05d.%s\"/>\n", v->times[k], b,
               sc->body[b].name, k, v->nranks > 1 ? "pvtu" : "vtu");
  APPEND("</Collection>\n</VTKFile>\n");
#undef APPEND
  snprintf(path, sizeof path, "%s/fields.pvd", v->dir);
  st = mo_write_file_atomic(path, pvd, len, ctx);
  mo_free(pvd);
  return st;
}

/* --- rigid bodies and the contact network ----------------------------------------------------- */

/* A rigid body's state as the series show it: centre, velocity, angular velocity (2D: along z),
   orientation (2D: the angle; 3D: the quaternion w, x, y, z). */
typedef struct {
  double x[3], v[3], w[3], q[4];
} rigid_view;

static void rigid_view_get(const mo_scene *sc, const mo_state *s, const mo_body *B, rigid_view *r)
{
  const double *v = s->v + B->dof0;
  int i;
  memset(r, 0, sizeof *r);
  mo_rigid_center(sc, B, s, r->x);
  if (sc->dim == 2) {
    r->v[0] = v[0];
    r->v[1] = v[1];
    r->w[2] = v[2];
    r->q[0] = B->theta0 + s->u[B->dof0 + 2];
    return;
  }
  for (i = 0; i < 3; i++) {
    r->v[i] = v[i];
    r->w[i] = v[3 + i];
  }
  for (i = 0; i < 4; i++) r->q[i] = s->orient && B->orient >= 0 ? s->orient[4 * B->orient + i] : i == 0;
}

static int is_ball(const mo_body *B) { return B->kind == MO_BODY_DISK || B->kind == MO_BODY_SPHERE; }
static int is_shape(const mo_body *B) { return B->kind == MO_BODY_POLYGON || B->kind == MO_BODY_RIGID_MESH; }

/* Cells of a body in polygons_: a polygon is one, a rigid mesh its elements. */
static long shape_cells(const mo_body *B) { return B->kind == MO_BODY_RIGID_MESH ? B->mesh->nelem : 1; }

enum { RV_RADIUS, RV_VELOCITY, RV_OMEGA, RV_ORIENTATION, RV_BODY };

/* The array `what` over the rigid bodies of a series (balls: one value each; shapes: one per
   cell), n entries. */
static void rigid_array(vtu *w, const mo_scene *sc, const mo_state *s, int balls, int what, long n)
{
  static const char *names[] = {"radius", "velocity", "omega", "orientation", "body"};
  int nq = sc->dim == 2 ? 1 : 4, k, i;
  int ncomp = what == RV_VELOCITY || what == RV_OMEGA ? 3 : what == RV_ORIENTATION ? nq : 1;
  long c;
  if (!vtu_array(w, names[what], what == RV_BODY ? VT_I32 : VT_F64, ncomp, n * ncomp)) return;
  for (k = 0; k < sc->nrigid; k++) {
    const mo_body *B = &sc->body[sc->rigid[k]];
    rigid_view r;
    if (balls ? !is_ball(B) : !is_shape(B)) continue;
    rigid_view_get(sc, s, B, &r);
    for (c = 0; c < (balls ? 1 : shape_cells(B)); c++) {
      if (what == RV_BODY) put_i32(w, sc->rigid[k]);
      else if (what == RV_RADIUS) put_f64(w, B->radius);
      for (i = 0; i < ncomp && what != RV_BODY && what != RV_RADIUS; i++)
        put_f64(w, what == RV_VELOCITY ? r.v[i] : what == RV_OMEGA ? r.w[i] : r.q[i]);
    }
  }
}

/* DIR/NAME_NNNNN.vtu of frame k. */
static int frame_path(char *path, size_t n, const mo_vtk *v, const char *name, int k, mo_ctx *ctx)
{
  if (snprintf(path, n, "%s/%s_%05d.vtu", v->dir, name, k) >= (int)n)
    return mo_error(ctx, MO_EIO, "path too long: '%s/%s'", v->dir, name);
  return MO_OK;
}

/* particles_NNNNN.vtu: every disk and sphere as a vertex at its centre. */
static int write_particles(const mo_vtk *v, int frame, const mo_scene *sc, const mo_state *s, mo_ctx *ctx)
{
  char path[4200];
  vtu w;
  long n = 0;
  int k, st, what;
  for (k = 0; k < sc->nrigid; k++) n += is_ball(&sc->body[sc->rigid[k]]);
  if ((st = frame_path(path, sizeof path, v, "particles", frame, ctx)) || (st = vtu_open(&w, path, n, n, s->t, ctx)))
    return st;
  for (; w.pass < 2; w.pass++) {
    if (w.pass) vtu_values(&w);
    vtu_xml(&w, "<Points>\n");
    if (vtu_array(&w, "points", VT_F64, 3, 3 * n))
      for (k = 0; k < sc->nrigid; k++) {
        double x[3];
        if (!is_ball(&sc->body[sc->rigid[k]])) continue;
        mo_rigid_center(sc, &sc->body[sc->rigid[k]], s, x);
        put_vec3(&w, x, 3);
      }
    vtu_xml(&w, "</Points>\n");
    vtu_uniform_cells(&w, n, 1, 1); /* VTK_VERTEX */
    vtu_xml(&w, "<PointData Scalars=\"radius\" Vectors=\"velocity\">\n");
    for (what = RV_RADIUS; what <= RV_BODY; what++) rigid_array(&w, sc, s, 1, what, n);
    vtu_xml(&w, "</PointData>\n");
  }
  return vtu_close(&w, 1, ctx);
}

/* World position of node a of a rigid mesh: x = c + R (X - xc0). */
static void rigid_node(const mo_scene *sc, const mo_state *s, const mo_body *B, int a, double *x)
{
  double X[3] = {0, 0, 0};
  int i, D = sc->dim;
  for (i = 0; i < D; i++) X[i] = B->mesh->x[a * D + i] - B->xc0[i];
  x[2] = 0;
  mo_rigid_point(sc, B, s, X, x);
}

/* The points of polygons_: each polygon's world vertices, each rigid mesh's nodes. */
static void shape_points(vtu *w, const mo_scene *sc, const mo_state *s, long npoint)
{
  int k, a;
  if (!vtu_array(w, "points", VT_F64, 3, 3 * npoint)) return;
  for (k = 0; k < sc->nrigid; k++) {
    const mo_body *B = &sc->body[sc->rigid[k]];
    double vw[2 * MO_POLYGON_MAX], x[3];
    if (B->kind == MO_BODY_POLYGON) {
      mo_polygon_world(sc, B, s, vw);
      for (a = 0; a < B->nvert; a++) put_vec3(w, vw + 2 * a, 2);
    } else if (B->kind == MO_BODY_RIGID_MESH)
      for (a = 0; a < B->mesh->nnode; a++) {
        rigid_node(sc, s, B, a, x);
        put_vec3(w, x, 3);
      }
  }
}

/* The cells of polygons_: connectivity, offsets, types (VTK_POLYGON, the mesh's cell type). */
static void shape_cells_write(vtu *w, const mo_scene *sc, long nconn, long ncell)
{
  long p0 = 0, off = 0;
  int k, a, e, pass;
  for (pass = 0; pass < 3; pass++) {
    static const char *names[] = {"connectivity", "offsets", "types"};
    if (!vtu_array(w, names[pass], pass == 2 ? VT_U8 : VT_I32, 1, pass == 0 ? nconn : ncell)) continue;
    for (k = 0, p0 = 0, off = 0; k < sc->nrigid; k++) {
      const mo_body *B = &sc->body[sc->rigid[k]];
      if (B->kind == MO_BODY_POLYGON) {
        if (pass == 0) for (a = 0; a < B->nvert; a++) put_i32(w, p0 + a);
        else if (pass == 1) put_i32(w, off += B->nvert);
        else put_u8(w, 7); /* VTK_POLYGON */
        p0 += B->nvert;
      } else if (B->kind == MO_BODY_RIGID_MESH) {
        const mo_mesh *m = B->mesh;
        for (e = 0; e < m->nelem; e++)
          if (pass == 0) for (a = 0; a < m->nen; a++) put_i32(w, p0 + m->conn[(size_t)e * m->nen + a]);
          else if (pass == 1) put_i32(w, off += m->nen);
          else put_u8(w, vtk_cell_type(m->type));
        p0 += m->nnode;
      }
    }
  }
}

/* polygons_NNNNN.vtu: every polygon and rigid mesh in its current configuration. */
static int write_polygons(const mo_vtk *v, int frame, const mo_scene *sc, const mo_state *s, mo_ctx *ctx)
{
  char path[4200];
  vtu w;
  long npoint = 0, ncell = 0, nconn = 0;
  int k, st, what;
  for (k = 0; k < sc->nrigid; k++) {
    const mo_body *B = &sc->body[sc->rigid[k]];
    if (B->kind == MO_BODY_POLYGON) {
      npoint += B->nvert;
      nconn += B->nvert;
      ncell++;
    } else if (B->kind == MO_BODY_RIGID_MESH) {
      npoint += B->mesh->nnode;
      nconn += (long)B->mesh->nelem * B->mesh->nen;
      ncell += B->mesh->nelem;
    }
  }
  if ((st = frame_path(path, sizeof path, v, "polygons", frame, ctx)) ||
      (st = vtu_open(&w, path, npoint, ncell, s->t, ctx)))
    return st;
  for (; w.pass < 2; w.pass++) {
    if (w.pass) vtu_values(&w);
    vtu_xml(&w, "<Points>\n");
    shape_points(&w, sc, s, npoint);
    vtu_xml(&w, "</Points>\n<Cells>\n");
    shape_cells_write(&w, sc, nconn, ncell);
    vtu_xml(&w, "</Cells>\n<CellData Vectors=\"velocity\">\n");
    for (what = RV_VELOCITY; what <= RV_BODY; what++)
      if (what != RV_ORIENTATION) rigid_array(&w, sc, s, 0, what, ncell);
    vtu_xml(&w, "</CellData>\n");
  }
  return vtu_close(&w, 1, ctx);
}

/* contacts_NNNNN.vtu: the network as lines, two points of their own each. */
/* The arrays of contacts_NNNNN.vtu for lines 0 .. n - 1 of net (pass 0: n the frame's lines; by
   slices: the chunk's, c0 its first line). */
static void contacts_arrays(vtu *w, const mo_vtk_contacts *net, long c0, long n)
{
  static const char *names[] = {"rn", "rt", "gap", "point", "status", "slave", "master"};
  long a;
  int f, i;
  vtu_xml(w, "<Points>\n");
  if (vtu_array(w, "points", VT_F64, 3, 6 * n))
    for (a = 0; a < 6 * n; a++) put_f64(w, net->end[a]);
  vtu_xml(w, "</Points>\n");
  vtu_cells_from(w, c0, n, 2, 3); /* VTK_LINE */
  vtu_xml(w, "<CellData Scalars=\"rn\">\n");
  for (f = 0; f < 7; f++) {
    int nc = f == 3 ? 3 : 1;
    if (!vtu_array(w, names[f], f >= 4 ? VT_I32 : VT_F64, nc, nc * n)) continue;
    for (a = 0; a < n; a++)
      switch (f) {
      case 0: put_f64(w, net->rn[a]); break;
      case 1: put_f64(w, net->rt[a]); break;
      case 2: put_f64(w, net->gap[a]); break;
      case 3: for (i = 0; i < 3; i++) put_f64(w, net->point[3 * a + i]); break;
      case 4: put_i32(w, net->status[a]); break;
      default: put_i32(w, net->body[2 * a + f - 5]); break;
      }
  }
  vtu_xml(w, "</CellData>\n");
}

static int write_contacts(const mo_vtk *v, int frame, double t, mo_vtk_contacts *net, mo_ctx *ctx)
{
  char path[4200];
  vtu w;
  long n = net ? net->total : 0;
  int st;
  if ((st = frame_path(path, sizeof path, v, "contacts", frame, ctx)) || (st = vtu_open(&w, path, 2 * n, n, t, ctx)))
    return st;
  contacts_arrays(&w, net, 0, n);
  vtu_values_sliced(&w, n);
  if (net) {
    mo_vtk_contacts_rewind(net);
    while (!(st = mo_vtk_contacts_next(net, ctx)) && net->n) {
      vtu_slice(&w, net->first, net->n);
      contacts_arrays(&w, net, net->first, net->n);
    }
  }
  if (st) {
    vtu_close(&w, 0, ctx);
    return st;
  }
  return vtu_close(&w, 1, ctx);
}

/* --- contact points and planes ---------------------------------------------------------------- */

/* The arrays of contact_points_NNNNN.vtu for points 0 .. n - 1 of P (pass 0: n the frame's points;
   by slices: the chunk's, c0 its first point). */
static void points_arrays(vtu *w, const mo_vtk_points *P, long c0, long n)
{
  /* the integer arrays, then the vectors of 3, then the local ones of d, then the scalars */
  static const char *iname[] = {"candidate", "pair", "node", "status", "slave", "master"};
  static const char *vname[] = {"displacement", "normal", "force", "relative_velocity", "reference"};
  static const char *lname[] = {"R", "U"};
  static const char *sname[] = {"gap", "lambda", "measure"};
  int d = P && P->d ? P->d : 1, k;
  long a;
  vtu_xml(w, "<Points>\n");
  if (vtu_array(w, "points", VT_F64, 3, 3 * n))
    for (a = 0; a < 3 * n; a++) put_f64(w, P->x[a]);
  vtu_xml(w, "</Points>\n");
  vtu_cells_from(w, c0, n, 1, 1); /* VTK_VERTEX */
  vtu_xml(w, "<PointData Scalars=\"gap\" Vectors=\"force\">\n");
  for (k = 0; k < 6; k++)
    if (vtu_array(w, iname[k], VT_I32, 1, n))
      for (a = 0; a < n; a++)
        put_i32(w, k == 0 ? P->cand[a] : k == 1 ? P->pair[a] : k == 2 ? P->node[a] : k == 3 ? P->status[a]
                                                                                 : P->body[2 * a + k - 4]);
  for (k = 0; k < 5; k++) {
    const double *src = P ? (k == 0 ? P->disp : k == 1 ? P->normal : k == 2 ? P->force : k == 3 ? P->vrel : P->x0) : NULL;
    if (vtu_array(w, vname[k], VT_F64, 3, 3 * n))
      for (a = 0; a < 3 * n; a++) put_f64(w, src[a]);
  }
  for (k = 0; k < 2; k++)
    if (vtu_array(w, lname[k], VT_F64, d, d * n))
      for (a = 0; a < n; a++) {
        int i;
        for (i = 0; i < d; i++) put_f64(w, (k ? P->U : P->R)[3 * a + i]);
      }
  for (k = 0; k < 3; k++)
    if (vtu_array(w, sname[k], VT_F64, 1, n))
      for (a = 0; a < n; a++) put_f64(w, (k == 0 ? P->gap : k == 1 ? P->lambda : P->measure)[a]);
  vtu_xml(w, "</PointData>\n");
}

/* contact_points_NNNNN.vtu: a vertex per candidate (mo_vtk_points: every one, or the closed
   ones) at its slave point in the current configuration, with its contact.csv row as point
   data: candidate, pair, node, displacement (D1..), gap, U and R (local, normal first: UN UT
   US, RN RT RS; R as forces), status, measure, lambda, slave, master; and in world axes its
   normal, the force on the slave (sum_l R_l F_l) and the relative velocity (sum_l U_l F_l). */
static int write_points(const mo_vtk *v, int frame, double t, mo_vtk_points *P, mo_ctx *ctx)
{
  char path[4200];
  vtu w;
  long n = P ? P->total : 0;
  int st;
  if ((st = frame_path(path, sizeof path, v, "contact_points", frame, ctx)) || (st = vtu_open(&w, path, n, n, t, ctx)))
    return st;
  points_arrays(&w, P, 0, n);
  vtu_values_sliced(&w, n);
  if (P) {
    mo_vtk_points_rewind(P);
    while (!(st = mo_vtk_points_next(P, ctx)) && P->n) {
      vtu_slice(&w, P->first, P->n);
      points_arrays(&w, P, P->first, P->n);
    }
  }
  if (st) {
    vtu_close(&w, 0, ctx);
    return st;
  }
  return vtu_close(&w, 1, ctx);
}

/* Grow the box b (xmin, xmax, ymin, ymax, zmin, zmax) by the ball of radius r about x. */
static void box_add(double *b, const double *x, int D, double r)
{
  int i;
  for (i = 0; i < D; i++) {
    if (x[i] - r < b[2 * i]) b[2 * i] = x[i] - r;
    if (x[i] + r > b[2 * i + 1]) b[2 * i + 1] = x[i] + r;
  }
}

/* The box of every body but the planes at state s, joined with the box of the earlier frames:
   the planes are drawn to its size. O(nodes + bodies). */
static void scene_box(mo_vtk *v, const mo_scene *sc, const mo_state *s)
{
  double b[6] = {HUGE_VAL, -HUGE_VAL, HUGE_VAL, -HUGE_VAL, HUGE_VAL, -HUGE_VAL}, x[3];
  int D = sc->dim, k, a, i, any = 0;
  for (k = 0; k < sc->nbody; k++) {
    const mo_body *B = &sc->body[k];
    if (B->kind == MO_BODY_PLANE) continue;
    any = 1;
    if (B->kind == MO_BODY_DEFORMABLE)
      for (a = 0; a < B->mesh->nnode; a++) {
        for (i = 0; i < D; i++) x[i] = B->mesh->x[(size_t)a * D + i] + s->u[B->dof0 + (size_t)a * D + i];
        box_add(b, x, D, 0);
      }
    else if (B->kind == MO_BODY_RIGID_MESH)
      for (a = 0; a < B->mesh->nnode; a++) {
        rigid_node(sc, s, B, a, x);
        box_add(b, x, D, 0);
      }
    else {
      mo_rigid_center(sc, B, s, x);
      box_add(b, x, D, is_ball(B) ? B->radius : B->bound);
    }
  }
  if (!any) return;
  if (!v->has_box) memcpy(v->box, b, sizeof b);
  for (i = 0; i < D; i++) {
    if (b[2 * i] < v->box[2 * i]) v->box[2 * i] = b[2 * i];
    if (b[2 * i + 1] > v->box[2 * i + 1]) v->box[2 * i + 1] = b[2 * i + 1];
  }
  v->has_box = 1;
}

/* The corners of plane B at time t (4 in 3D, 2 in 2D, 1 in 1D): a square (a segment) centred
   at the projection of the box's centre, of half-side 0.6 times the box's diagonal, so that it
   spans the scene seen from any side. Returns the number of corners. */
static int plane_corners(const mo_vtk *v, const mo_scene *sc, const mo_body *B, double t, double *c)
{
  const double *n = B->normal;
  double p[3] = {0, 0, 0}, m[3] = {0, 0, 0}, t1[3] = {0, 0, 0}, t2[3] = {0, 0, 0}, L = 0, g = 0;
  int D = sc->dim, i, k;
  for (i = 0; i < D; i++) {
    p[i] = B->point[i] + B->velocity[i] * t;
    m[i] = v->has_box ? 0.5 * (v->box[2 * i] + v->box[2 * i + 1]) : p[i];
    if (v->has_box) L += (v->box[2 * i + 1] - v->box[2 * i]) * (v->box[2 * i + 1] - v->box[2 * i]);
  }
  L = 0.6 * sqrt(L);
  if (!(L > 0)) L = 0.5;
  for (i = 0; i < D; i++) g += (m[i] - p[i]) * n[i];
  for (i = 0; i < D; i++) m[i] -= g * n[i];
  memset(c, 0, 12 * sizeof *c);
  if (D == 1) {
    c[0] = p[0];
    return 1;
  }
  if (D == 2) {
    t1[0] = -n[1];
    t1[1] = n[0];
    for (i = 0; i < 2; i++) {
      c[i] = m[i] - L * t1[i];
      c[3 + i] = m[i] + L * t1[i];
    }
    return 2;
  }
  {
    /* t1 normal to n and to the axis least aligned with it, t2 = n x t1 */
    int ax = fabs(n[0]) <= fabs(n[1]) && fabs(n[0]) <= fabs(n[2]) ? 0 : fabs(n[1]) <= fabs(n[2]) ? 1 : 2;
    double e[3] = {0, 0, 0}, r;
    e[ax] = 1;
    t1[0] = n[1] * e[2] - n[2] * e[1];
    t1[1] = n[2] * e[0] - n[0] * e[2];
    t1[2] = n[0] * e[1] - n[1] * e[0];
    r = sqrt(t1[0] * t1[0] + t1[1] * t1[1] + t1[2] * t1[2]);
    for (i = 0; i < 3; i++) t1[i] /= r;
    t2[0] = n[1] * t1[2] - n[2] * t1[1];
    t2[1] = n[2] * t1[0] - n[0] * t1[2];
    t2[2] = n[0] * t1[1] - n[1] * t1[0];
    for (k = 0; k < 4; k++) {
      double s1 = k == 0 || k == 3 ? -L : L, s2 = k < 2 ? -L : L;
      for (i = 0; i < 3; i++) c[3 * k + i] = m[i] + s1 * t1[i] + s2 * t2[i];
    }
    return 4;
  }
}

/* planes_NNNNN.vtu: every plane at time t as a quadrilateral (3D), a segment (2D) or a vertex
   (1D) sized to the scene, cell data body, normal, velocity. */
static int write_planes(const mo_vtk *v, int frame, const mo_scene *sc, double t, mo_ctx *ctx)
{
  char path[4200];
  vtu w;
  int k, st, nv = sc->dim == 3 ? 4 : sc->dim == 2 ? 2 : 1, np = 0, a, f;
  for (k = 0; k < sc->nbody; k++) np += sc->body[k].kind == MO_BODY_PLANE;
  if ((st = frame_path(path, sizeof path, v, "planes", frame, ctx)) ||
      (st = vtu_open(&w, path, (long)np * nv, np, t, ctx)))
    return st;
  for (; w.pass < 2; w.pass++) {
    if (w.pass) vtu_values(&w);
    vtu_xml(&w, "<Points>\n");
    if (vtu_array(&w, "points", VT_F64, 3, 3L * np * nv))
      for (k = 0; k < sc->nbody; k++) {
        double c[12];
        if (sc->body[k].kind != MO_BODY_PLANE) continue;
        plane_corners(v, sc, &sc->body[k], t, c);
        for (a = 0; a < 3 * nv; a++) put_f64(&w, c[a]);
      }
    vtu_xml(&w, "</Points>\n");
    vtu_uniform_cells(&w, np, nv, nv == 4 ? 9 : nv == 2 ? 3 : 1); /* VTK_QUAD, VTK_LINE, VTK_VERTEX */
    vtu_xml(&w, "<CellData Vectors=\"normal\">\n");
    if (vtu_array(&w, "body", VT_I32, 1, np))
      for (k = 0; k < sc->nbody; k++)
        if (sc->body[k].kind == MO_BODY_PLANE) put_i32(&w, k);
    for (f = 0; f < 2; f++)
      if (vtu_array(&w, f ? "velocity" : "normal", VT_F64, 3, 3L * np))
        for (k = 0; k < sc->nbody; k++)
          if (sc->body[k].kind == MO_BODY_PLANE) put_vec3(&w, f ? sc->body[k].velocity : sc->body[k].normal, sc->dim);
    vtu_xml(&w, "</CellData>\n");
  }
  return vtu_close(&w, 1, ctx);
}

/* PREFIX.pvd listing the frames PREFIX_NNNNN.vtu with their times (one part). */
static int write_series_pvd(const mo_vtk *v, const char *prefix, mo_ctx *ctx)
{
  size_t line = 100 + strlen(prefix), cap = 200 + (size_t)v->nframe * line, len = 0;
  char path[4200], *buf = mo_malloc(ctx, cap);
  int k, st;
  if (!buf) return MO_ENOMEM;
  len += (size_t)snprintf(buf, cap, "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n"
                                    "<Collection>\n");
  for (k = 0; k < v->nframe; k++)
    len += (size_t)snprintf(buf + len, cap - len,
                            "<DataSet timestep=\"%.17g\" part=\"0\" file=\"%s_%05d.vtu\"/>\n", v->times[k],
                            prefix, k);
  len += (size_t)snprintf(buf + len, cap - len, "</Collection>\n</VTKFile>\n");
  snprintf(path, sizeof path, "%s/%s.pvd", v->dir, prefix);
  st = mo_write_file_atomic(path, buf, len, ctx);
  mo_free(buf);
  return st;
}

int mo_vtk_frame(mo_vtk *v, const mo_scene *sc, const mo_state *s, mo_vtk_contacts *net, mo_vtk_points *pts,
                 mo_ctx *ctx)
{
  char path[4200];
  int b, st = MO_OK, k;
  if (v->nframe == v->cap) {
    int cap2 = v->cap ? 2 * v->cap : 64;
    double *t = mo_realloc(ctx, v->times, (size_t)cap2 * sizeof *t);
    if (!t) return MO_ENOMEM;
    v->times = t;
    v->cap = cap2;
  }
  k = v->nframe;
  /* every file of the frame first (mo_vtk_index then writes the collections that list it) */
  for (b = 0; !st && b < sc->nbody; b++) {
    const mo_body *B = &sc->body[b];
    long ne = B->kind == MO_BODY_DEFORMABLE ? B->mesh->nelem : 0;
    if (!ne) continue;
    if (v->nranks > 1)
      snprintf(path, sizeof path, "%s/fields_%s_%05d_%d.vtu", v->dir, B->name, k, v->rank);
    else
      snprintf(path, sizeof path, "%s/fields_%s_%05d.vtu", v->dir, B->name, k);
    st = write_fields(path, sc, B, s, sc->out.vtk_fields, ne * v->rank / v->nranks, ne * (v->rank + 1) / v->nranks,
                      ctx);
  }
  if (!st && v->balls) st = write_particles(v, k, sc, s, ctx);
  if (!st && v->shapes) st = write_polygons(v, k, sc, s, ctx);
  if (!st && v->rigid) st = write_contacts(v, k, s->t, net, ctx);
  if (!st && v->points) st = write_points(v, k, s->t, pts, ctx);
  if (!st && v->planes) {
    scene_box(v, sc, s);
    st = write_planes(v, k, sc, s->t, ctx);
  }
  if (st) return st;
  v->times[v->nframe++] = s->t;
  return MO_OK;
}

int mo_vtk_index(mo_vtk *v, const mo_scene *sc, mo_ctx *ctx)
{
  int st = MO_OK, b;
  if (v->rank != 0 || v->indexed == v->nframe) return MO_OK;
  for (; v->nranks > 1 && v->indexed < v->nframe; v->indexed++)
    for (b = 0; !st && b < sc->nbody; b++)
      if (sc->body[b].kind == MO_BODY_DEFORMABLE && (st = write_fields_pvtu(v, sc, &sc->body[b], v->indexed, ctx)))
        return st;
  v->indexed = v->nframe;
  if (v->fields) st = write_fields_pvd(v, sc, ctx);
  if (!st && v->balls) st = write_series_pvd(v, "particles", ctx);
  if (!st && v->shapes) st = write_series_pvd(v, "polygons", ctx);
  if (!st && v->rigid) st = write_series_pvd(v, "contacts", ctx);
  if (!st && v->points) st = write_series_pvd(v, "contact_points", ctx);
  if (!st && v->planes) st = write_series_pvd(v, "planes", ctx);
  return st;
}
