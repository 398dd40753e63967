/* output.c: CSV histories, VTK XML series (fields, rigid bodies, contact network), atomic file
   replacement. */
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
  if (slash) snprintf(dir, sizeof dir, "%.*s", (int)(slash - path ? slash - path : 1), path);
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
  int e = 0, st = MO_OK;
  if (!A->f) return MO_OK;
  errno = 0;
  if (ok && (fflush(A->f) != 0 || ferror(A->f) || (!A->nosync && fsync(fileno(A->f)) != 0))) e = errno ? errno : EIO;
  if (ok && !e && A->anon) {
    char proc[64];
    snprintf(proc, sizeof proc, "/proc/self/fd/%d", fileno(A->f));
    remove(A->tmp); /* a leftover of an earlier process of the same id */
    if (linkat(AT_FDCWD, proc, AT_FDCWD, A->tmp, AT_SYMLINK_FOLLOW) != 0) e = errno ? errno : EIO;
  }
  if (fclose(A->f) != 0 && ok && !e) e = errno;
  A->f = NULL;
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

struct mo_vtk {
  char *dir;
  int nframe, cap;
  double *times;
  int balls, shapes, rigid;  /* the rigid series of the scene: particles, polygons, contacts */
};

static int write_paraview_script(const mo_vtk *v, const mo_scene *sc, mo_ctx *ctx);

int mo_vtk_open(const char *dir, const mo_scene *sc, mo_vtk **out, mo_ctx *ctx)
{
  mo_vtk *v = mo_calloc(ctx, 1, sizeof *v);
  int k, st;
  *out = NULL;
  if (!v) return MO_ENOMEM;
  v->dir = mo_strdup(ctx, dir);
  if (!v->dir) { mo_free(v); return MO_ENOMEM; }
  for (k = 0; k < sc->nrigid; k++) {
    mo_body_kind kd = sc->body[sc->rigid[k]].kind;
    v->balls |= kd == MO_BODY_DISK || kd == MO_BODY_SPHERE;
    v->shapes |= kd == MO_BODY_POLYGON || kd == MO_BODY_RIGID_MESH;
  }
  v->rigid = sc->nrigid > 0;
  if (v->rigid && (st = write_paraview_script(v, sc, ctx))) {
    mo_vtk_close(v);
    return st;
  }
  *out = v;
  return MO_OK;
}

int mo_vtk_frames(const mo_vtk *v) { return v->nframe; }

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
  memset(N, 0, sizeof *N);
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
  char path[4200], absdir[PATH_MAX], here[PATH_MAX + 8], text[6144];
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
    "# 2 slide), slave, master (body numbers). Play the animation for the time series.\n"
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
    "GetAnimationScene().UpdateAnimationUsingDataTimeSteps()\n"
    "%s"
    "view.ResetCamera()\n"
    "Render()\n",
    here, tube_radius(sc), sc->dim == 2 ? "view.InteractionMode = '2D'\n" : "");
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

static int write_vtu(const char *path, const mo_scene *sc, const mo_body *B, const mo_state *s,
                     unsigned fields, mo_ctx *ctx)
{
  const mo_mesh *m = B->mesh;
  int D = sc->dim, a, c, e, nc = mo_hyp_ncomp(B->mat.hyp);
  mo_atomic_file A;
  FILE *f;
  int st = mo_atomic_open(&A, path, ctx);
  if (st) return st;
  A.nosync = 1;
  f = A.f;
  fprintf(f, "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" "
             "byte_order=\"LittleEndian\">\n<UnstructuredGrid>\n"
             "<Piece NumberOfPoints=\"%d\" NumberOfCells=\"%d\">\n<Points>\n"
             "<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n",
          m->nnode, m->nelem);
  for (a = 0; a < m->nnode; a++) {
    for (c = 0; c < 3; c++) fprintf(f, "%.10g ", c < D ? m->x[a * D + c] : 0.0);
    fputc('\n', f);
  }
  fprintf(f, "</DataArray>\n</Points>\n<Cells>\n<DataArray type=\"Int32\" Name=\"connectivity\" format=\"ascii\">\n");
  for (e = 0; e < m->nelem; e++) {
    for (a = 0; a < m->nen; a++) fprintf(f, "%d ", m->conn[e * m->nen + a]);
    fputc('\n', f);
  }
  fprintf(f, "</DataArray>\n<DataArray type=\"Int32\" Name=\"offsets\" format=\"ascii\">\n");
  for (e = 0; e < m->nelem; e++) fprintf(f, "%d\n", (e + 1) * m->nen);
  fprintf(f, "</DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n");
  for (e = 0; e < m->nelem; e++) fprintf(f, "%d\n", vtk_cell_type(m->type));
  fprintf(f, "</DataArray>\n</Cells>\n<PointData Vectors=\"displacement\">\n");
  {
    static const char *names[2] = {"displacement", "velocity"};
    const double *src[2] = {s->u, s->v};
    int w;
    for (w = 0; w < 2; w++) {
      if (!(fields & (w ? MO_VTK_VELOCITY : MO_VTK_DISPLACEMENT))) continue;
      fprintf(f, "<DataArray type=\"Float64\" Name=\"%s\" NumberOfComponents=\"3\" format=\"ascii\">\n", names[w]);
      for (a = 0; a < m->nnode; a++) {
        for (c = 0; c < 3; c++) fprintf(f, "%.10g ", c < D ? src[w][B->dof0 + a * D + c] : 0.0);
        fputc('\n', f);
      }
      fprintf(f, "</DataArray>\n");
    }
  }
  fprintf(f, "</PointData>\n<CellData>\n");
  if (fields & (MO_VTK_STRESS | MO_VTK_STRAIN | MO_VTK_VON_MISES | MO_VTK_EPS_P)) {
    /* ParaView reads 6-component arrays as symmetric tensors XX YY ZZ XY YZ XZ */
    int w;
    double *eps = mo_malloc(ctx, (size_t)m->nelem * 6 * sizeof(double));
    double *sig = mo_malloc(ctx, (size_t)m->nelem * 6 * sizeof(double));
    double *vm = mo_malloc(ctx, (size_t)(m->nelem ? m->nelem : 1) * sizeof(double));
    double *ep = mo_calloc(ctx, (size_t)(m->nelem ? m->nelem : 1), sizeof(double));
    if (!eps || !sig || !vm || !ep) {
      mo_free(eps); mo_free(sig); mo_free(vm); mo_free(ep);
      mo_atomic_commit(&A, 0, ctx);
      return MO_ENOMEM;
    }
    for (e = 0; e < m->nelem; e++) {
      double ue[MO_ND_MAX], ee[6], se[6];
      for (a = 0; a < m->nen; a++)
        for (c = 0; c < D; c++) ue[a * D + c] = s->u[B->dof0 + m->conn[e * m->nen + a] * D + c];
      if (B->nl) {
        /* finite strains: the material state's Cauchy stress, von Mises and epsp (element
           means over the points), the Green-Lagrange strain at the centroid */
        const double *q = s->q + B->q0 + (size_t)e * (size_t)B->npoint * MO_J2_NSTATE;
        mo_elem_nl_fields(m, e, &B->mat, q, se, &vm[e], &ep[e]);
        green_lagrange(m, e, &B->mat, ue, ee);
      } else {
        mo_elem_stress(m, e, &B->mat, ue, ee, se);
        vm[e] = mo_von_mises(B->mat.hyp, se);
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
    for (w = 0; w < 2; w++) {
      const double *arr = w ? sig : eps;
      if (!(fields & (w ? MO_VTK_STRESS : MO_VTK_STRAIN))) continue;
      fprintf(f, "<DataArray type=\"Float64\" Name=\"%s\" NumberOfComponents=\"6\" format=\"ascii\">\n", w ? "stress" : "strain");
      for (e = 0; e < m->nelem; e++) {
        for (c = 0; c < 6; c++) fprintf(f, "%.8g ", arr[6 * e + c]);
        fputc('\n', f);
      }
      fprintf(f, "</DataArray>\n");
    }
    if (fields & MO_VTK_VON_MISES) {
      fprintf(f, "<DataArray type=\"Float64\" Name=\"von_mises\" format=\"ascii\">\n");
      for (e = 0; e < m->nelem; e++) fprintf(f, "%.8g\n", vm[e]);
      fprintf(f, "</DataArray>\n");
    }
    if ((fields & MO_VTK_EPS_P) && B->nl) {
      fprintf(f, "<DataArray type=\"Float64\" Name=\"eps_p\" format=\"ascii\">\n");
      for (e = 0; e < m->nelem; e++) fprintf(f, "%.8g\n", ep[e]);
      fprintf(f, "</DataArray>\n");
    }
    mo_free(eps); mo_free(sig); mo_free(vm); mo_free(ep);
  }
  fprintf(f, "</CellData>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n");
  return mo_atomic_commit(&A, 1, ctx);
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
        APPEND("<DataSet timestep=\"%.12g\" part=\"%d\" file=\"fields_%s_%05d.vtu\"/>\n", v->times[k], b,
               sc->body[b].name, k);
  APPEND("</Collection>\n</VTKFile>\n");
#undef APPEND
  snprintf(path, sizeof path, "%s/fields.pvd", v->dir);
  st = mo_write_file_atomic(path, pvd, len, ctx);
  mo_free(pvd);
  return st;
}

/* --- rigid bodies and the contact network: binary .vtu ------------------------------------------ */

/* A .vtu being written under a temporary name, and the base64 stream of its current DataArray
   (VTK's inline binary format: base64 of a UInt64 byte count followed by the values, as one
   stream). */
typedef struct {
  FILE *f;
  mo_atomic_file A;
  unsigned char in[3];
  int nin, nout;
  char out[4096];
} vtu;

static void b64_flush(vtu *w)
{
  if (w->nout) fwrite(w->out, 1, (size_t)w->nout, w->f);
  w->nout = 0;
}

/* The 1 to 3 bytes held as 4 digits ('=' padding when fewer than 3). */
static void b64_group(vtu *w)
{
  static const char dig[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  unsigned long x = (unsigned long)w->in[0] << 16 | (unsigned long)(w->nin > 1 ? w->in[1] : 0) << 8 |
                    (unsigned long)(w->nin > 2 ? w->in[2] : 0);
  char *o;
  if (w->nout + 4 > (int)sizeof w->out) b64_flush(w);
  o = w->out + w->nout;
  o[0] = dig[x >> 18 & 63];
  o[1] = dig[x >> 12 & 63];
  o[2] = w->nin > 1 ? dig[x >> 6 & 63] : '=';
  o[3] = w->nin > 2 ? dig[x & 63] : '=';
  w->nout += 4;
  w->nin = 0;
}

static void vtu_put(vtu *w, const void *p, size_t n)
{
  const unsigned char *b = p;
  size_t i;
  for (i = 0; i < n; i++) {
    w->in[w->nin++] = b[i];
    if (w->nin == 3) b64_group(w);
  }
}

static void put_f64(vtu *w, double x) { vtu_put(w, &x, sizeof x); }
static void put_i32(vtu *w, long x)
{
  int32_t y = (int32_t)x;
  vtu_put(w, &y, sizeof y);
}
static void put_u8(vtu *w, int x)
{
  unsigned char y = (unsigned char)x;
  vtu_put(w, &y, 1);
}

/* Start a DataArray of n values (Float64, Int32 or UInt8, by the size) of ncomp components. */
static void vtu_begin(vtu *w, const char *name, int ncomp, long n, int size)
{
  uint64_t bytes = (uint64_t)n * (uint64_t)size;
  fprintf(w->f, "<DataArray type=\"%s\" Name=\"%s\" NumberOfComponents=\"%d\" format=\"binary\">\n",
          size == 8 ? "Float64" : size == 4 ? "Int32" : "UInt8", name, ncomp);
  vtu_put(w, &bytes, sizeof bytes);
}

static void vtu_end(vtu *w)
{
  if (w->nin) b64_group(w);
  b64_flush(w);
  fputs("\n</DataArray>\n", w->f);
}

static const char *byte_order(void)
{
  const uint16_t one = 1;
  return *(const unsigned char *)&one ? "LittleEndian" : "BigEndian";
}

/* Open DIR/NAME_NNNNN.vtu of frame k under a temporary name and write its header. */
static int vtu_open(vtu *w, const mo_vtk *v, const char *name, int k, long npoint, long ncell, mo_ctx *ctx)
{
  char path[4200];
  int st;
  memset(w, 0, sizeof *w);
  if (snprintf(path, sizeof path, "%s/%s_%05d.vtu", v->dir, name, k) >= (int)sizeof path)
    return mo_error(ctx, MO_EIO, "path too long: '%s/%s'", v->dir, name);
  if (npoint > INT_MAX || ncell > INT_MAX)
    return mo_error(ctx, MO_ELIMIT, "'%s': more than %d points or cells", path, INT_MAX);
  if ((st = mo_atomic_open(&w->A, path, ctx))) return st;
  w->A.nosync = 1;
  w->f = w->A.f;
  fprintf(w->f, "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" "
                "byte_order=\"%s\" header_type=\"UInt64\">\n<UnstructuredGrid>\n"
                "<Piece NumberOfPoints=\"%ld\" NumberOfCells=\"%ld\">\n",
          byte_order(), npoint, ncell);
  return MO_OK;
}

/* Close the file and put it in place (or remove it when writing failed). */
static int vtu_close(vtu *w, mo_ctx *ctx)
{
  fputs("</Piece>\n</UnstructuredGrid>\n</VTKFile>\n", w->f);
  w->f = NULL;
  return mo_atomic_commit(&w->A, 1, ctx);
}

/* The offsets and types of ncell cells of one type with nv vertices each (vertices, lines). */
static void vtu_uniform_cells(vtu *w, long ncell, int nv, int type)
{
  long c;
  vtu_begin(w, "offsets", 1, ncell, 4);
  for (c = 0; c < ncell; c++) put_i32(w, (c + 1) * nv);
  vtu_end(w);
  vtu_begin(w, "types", 1, ncell, 1);
  for (c = 0; c < ncell; c++) put_u8(w, type);
  vtu_end(w);
}

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
  vtu_begin(w, names[what], ncomp, n * ncomp, what == RV_BODY ? 4 : 8);
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
  vtu_end(w);
}

/* particles_NNNNN.vtu: every disk and sphere as a vertex at its centre. */
static int write_particles(const mo_vtk *v, int frame, const mo_scene *sc, const mo_state *s, mo_ctx *ctx)
{
  vtu w;
  long n = 0, a;
  int k, st, what;
  for (k = 0; k < sc->nrigid; k++) n += is_ball(&sc->body[sc->rigid[k]]);
  if ((st = vtu_open(&w, v, "particles", frame, n, n, ctx))) return st;
  fputs("<Points>\n", w.f);
  vtu_begin(&w, "points", 3, 3 * n, 8);
  for (k = 0; k < sc->nrigid; k++) {
    double x[3];
    if (!is_ball(&sc->body[sc->rigid[k]])) continue;
    mo_rigid_center(sc, &sc->body[sc->rigid[k]], s, x);
    for (a = 0; a < 3; a++) put_f64(&w, x[a]);
  }
  vtu_end(&w);
  fputs("</Points>\n<Cells>\n", w.f);
  vtu_begin(&w, "connectivity", 1, n, 4);
  for (a = 0; a < n; a++) put_i32(&w, a);
  vtu_end(&w);
  vtu_uniform_cells(&w, n, 1, 1); /* VTK_VERTEX */
  fputs("</Cells>\n<PointData Scalars=\"radius\" Vectors=\"velocity\">\n", w.f);
  for (what = RV_RADIUS; what <= RV_BODY; what++) rigid_array(&w, sc, s, 1, what, n);
  fputs("</PointData>\n", w.f);
  return vtu_close(&w, ctx);
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
  int k, a, i;
  vtu_begin(w, "points", 3, 3 * npoint, 8);
  for (k = 0; k < sc->nrigid; k++) {
    const mo_body *B = &sc->body[sc->rigid[k]];
    double vw[2 * MO_POLYGON_MAX], x[3];
    if (B->kind == MO_BODY_POLYGON) {
      mo_polygon_world(sc, B, s, vw);
      for (a = 0; a < B->nvert; a++) {
        put_f64(w, vw[2 * a]);
        put_f64(w, vw[2 * a + 1]);
        put_f64(w, 0);
      }
    } else if (B->kind == MO_BODY_RIGID_MESH)
      for (a = 0; a < B->mesh->nnode; a++) {
        rigid_node(sc, s, B, a, x);
        for (i = 0; i < 3; i++) put_f64(w, x[i]);
      }
  }
  vtu_end(w);
}

/* The cells of polygons_: connectivity, offsets, types (VTK_POLYGON, the mesh's cell type). */
static void shape_cells_write(vtu *w, const mo_scene *sc, long nconn, long ncell)
{
  long p0 = 0, off = 0;
  int k, a, e, pass;
  for (pass = 0; pass < 3; pass++) {
    static const char *names[] = {"connectivity", "offsets", "types"};
    vtu_begin(w, names[pass], 1, pass == 0 ? nconn : ncell, pass == 2 ? 1 : 4);
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
    vtu_end(w);
  }
}

/* polygons_NNNNN.vtu: every polygon and rigid mesh in its current configuration. */
static int write_polygons(const mo_vtk *v, int frame, const mo_scene *sc, const mo_state *s, mo_ctx *ctx)
{
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
  if ((st = vtu_open(&w, v, "polygons", frame, npoint, ncell, ctx))) return st;
  fputs("<Points>\n", w.f);
  shape_points(&w, sc, s, npoint);
  fputs("</Points>\n<Cells>\n", w.f);
  shape_cells_write(&w, sc, nconn, ncell);
  fputs("</Cells>\n<CellData Vectors=\"velocity\">\n", w.f);
  for (what = RV_VELOCITY; what <= RV_BODY; what++)
    if (what != RV_ORIENTATION) rigid_array(&w, sc, s, 0, what, ncell);
  fputs("</CellData>\n", w.f);
  return vtu_close(&w, ctx);
}

/* contacts_NNNNN.vtu: the network as lines, two points of their own each. */
static int write_contacts(const mo_vtk *v, int frame, const mo_vtk_contacts *net, mo_ctx *ctx)
{
  static const char *names[] = {"rn", "rt", "gap", "point", "status", "slave", "master"};
  vtu w;
  long n = net ? net->n : 0, a;
  int st, f, i;
  if ((st = vtu_open(&w, v, "contacts", frame, 2 * n, n, ctx))) return st;
  fputs("<Points>\n", w.f);
  vtu_begin(&w, "points", 3, 6 * n, 8);
  for (a = 0; a < 6 * n; a++) put_f64(&w, net->end[a]);
  vtu_end(&w);
  fputs("</Points>\n<Cells>\n", w.f);
  vtu_begin(&w, "connectivity", 1, 2 * n, 4);
  for (a = 0; a < 2 * n; a++) put_i32(&w, a);
  vtu_end(&w);
  vtu_uniform_cells(&w, n, 2, 3); /* VTK_LINE */
  fputs("</Cells>\n<CellData Scalars=\"rn\">\n", w.f);
  for (f = 0; f < 7; f++) {
    int nc = f == 3 ? 3 : 1;
    vtu_begin(&w, names[f], nc, nc * n, f >= 4 ? 4 : 8);
    for (a = 0; a < n; a++)
      switch (f) {
      case 0: put_f64(&w, net->rn[a]); break;
      case 1: put_f64(&w, net->rt[a]); break;
      case 2: put_f64(&w, net->gap[a]); break;
      case 3: for (i = 0; i < 3; i++) put_f64(&w, net->point[3 * a + i]); break;
      case 4: put_i32(&w, net->status[a]); break;
      default: put_i32(&w, net->body[2 * a + f - 5]); break;
      }
    vtu_end(&w);
  }
  fputs("</CellData>\n", w.f);
  return vtu_close(&w, ctx);
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

/* The rigid series of the last frame recorded (v->nframe - 1) and their collections. */
static int write_rigid_frame(const mo_vtk *v, const mo_scene *sc, const mo_state *s,
                             const mo_vtk_contacts *net, mo_ctx *ctx)
{
  int st, k = v->nframe - 1;
  st = v->balls ? write_particles(v, k, sc, s, ctx) : MO_OK;
  if (!st && v->shapes) st = write_polygons(v, k, sc, s, ctx);
  if (!st) st = write_contacts(v, k, net, ctx);
  if (!st && v->balls) st = write_series_pvd(v, "particles", ctx);
  if (!st && v->shapes) st = write_series_pvd(v, "polygons", ctx);
  if (!st) st = write_series_pvd(v, "contacts", ctx);
  return st;
}

int mo_vtk_frame(mo_vtk *v, const mo_scene *sc, const mo_state *s, const mo_vtk_contacts *net,
                 mo_ctx *ctx)
{
  char path[4200];
  int b, st;
  if (v->nframe == v->cap) {
    int cap2 = v->cap ? 2 * v->cap : 64;
    double *t = mo_realloc(ctx, v->times, (size_t)cap2 * sizeof *t);
    if (!t) return MO_ENOMEM;
    v->times = t;
    v->cap = cap2;
  }
  for (b = 0; b < sc->nbody; b++) {
    if (sc->body[b].kind != MO_BODY_DEFORMABLE) continue;
    snprintf(path, sizeof path, "%s/fields_%s_%05d.vtu", v->dir, sc->body[b].name, v->nframe);
    if ((st = write_vtu(path, sc, &sc->body[b], s, sc->out.vtk_fields, ctx))) return st;
  }
  v->times[v->nframe++] = s->t;
  if (v->rigid && (st = write_rigid_frame(v, sc, s, net, ctx))) return st;
  /* fields.pvd lists the deformable bodies' fields: none, no file (the rigid series have theirs) */
  for (b = 0; b < sc->nbody && sc->body[b].kind != MO_BODY_DEFORMABLE; b++) {}
  return b < sc->nbody ? write_fields_pvd(v, sc, ctx) : MO_OK;
}
