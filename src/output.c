/* output.c: CSV histories, VTK XML field series, atomic file replacement. */
#include "config.h"
#include <moreau/material.h>
#include <moreau/output.h>

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

int mo_mkdir_p(const char *dir, mo_ctx *ctx)
{
  char buf[4096];
  size_t n = strlen(dir), i;
  struct stat sb;
  if (n == 0 || n >= sizeof buf) return mo_error(ctx, MO_EIO, "invalid output folder '%s'", dir);
  memcpy(buf, dir, n + 1);
  for (i = 1; i <= n; i++) {
    if (buf[i] == '/' || buf[i] == '\0') {
      char c = buf[i];
      buf[i] = '\0';
      if (stat(buf, &sb) != 0) {
        if (mkdir(buf, 0777) != 0 && errno != EEXIST)
          return mo_error(ctx, MO_EIO, "cannot create folder '%s': %s", buf, strerror(errno));
      } else if (!S_ISDIR(sb.st_mode))
        return mo_error(ctx, MO_EIO, "'%s' exists and is not a folder", buf);
      buf[i] = c;
    }
  }
  return MO_OK;
}

int mo_write_file_atomic(const char *path, const char *data, size_t len, mo_ctx *ctx)
{
  char tmp[4200];
  FILE *f;
  if (snprintf(tmp, sizeof tmp, "%s.tmp.%ld", path, (long)getpid()) >= (int)sizeof tmp)
    return mo_error(ctx, MO_EIO, "path too long: '%s'", path);
  f = fopen(tmp, "wb");
  if (!f) return mo_error(ctx, MO_EIO, "cannot write '%s': %s", tmp, strerror(errno));
  if (fwrite(data, 1, len, f) != len || fflush(f) != 0 || fsync(fileno(f)) != 0) {
    int e = errno;
    fclose(f);
    remove(tmp);
    return mo_error(ctx, MO_EIO, "cannot write '%s': %s", tmp, strerror(e));
  }
  if (fclose(f) != 0) {
    remove(tmp);
    return mo_error(ctx, MO_EIO, "cannot write '%s': %s", tmp, strerror(errno));
  }
  if (rename(tmp, path) != 0) {
    int e = errno;
    remove(tmp);
    return mo_error(ctx, MO_EIO, "cannot replace '%s': %s", path, strerror(e));
  }
  return MO_OK;
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
    return mo_error(ctx, MO_EIO, "cannot write '%s': %s", path, strerror(errno));
  }
  c->ncol = ncol;
  c->prec = precision;
  for (k = 0; k < ncol; k++) fprintf(c->f, "%s%s", k ? "," : "", names[k]);
  fputc('\n', c->f);
  if (fflush(c->f) != 0) {
    mo_csv_close(c, ctx);
    return mo_error(ctx, MO_EIO, "cannot write '%s': %s", path, strerror(errno));
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
    return mo_error(ctx, MO_EIO, "cannot write '%s': %s", c->path, strerror(errno));
  return MO_OK;
}

int mo_csv_close(mo_csv *c, mo_ctx *ctx)
{
  int st = MO_OK;
  if (!c) return MO_OK;
  if (c->f && fclose(c->f) != 0) st = mo_error(ctx, MO_EIO, "cannot close '%s'", c->path);
  mo_free(c->path);
  mo_free(c);
  return st;
}

/* --- VTK ----------------------------------------------------------------------------------- */

struct mo_vtk {
  char *dir;
  int nframe, cap;
  double *times;
};

int mo_vtk_open(const char *dir, const mo_scene *sc, mo_vtk **out, mo_ctx *ctx)
{
  mo_vtk *v = mo_calloc(ctx, 1, sizeof *v);
  (void)sc;
  *out = NULL;
  if (!v) return MO_ENOMEM;
  v->dir = mo_strdup(ctx, dir);
  if (!v->dir) { mo_free(v); return MO_ENOMEM; }
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

static int vtk_cell_type(mo_eltype t)
{
  switch (t) {
  case MO_EL_BAR2: return 3;
  case MO_EL_T3: return 5;
  case MO_EL_Q4: return 9;
  default: return 12;
  }
}

/* Green-Lagrange strain E = (F^T F - I) / 2 at the centroid of element e of a finite-strain
   body, in the hypothesis' component order (fe.h). */
static void green_lagrange(const mo_mesh *m, int e, const mo_material *mat, const double *ue,
                           double *E)
{
  static const double ctr[MO_EL_NTYPES][3] = {{0, 0, 0}, {1.0 / 3, 1.0 / 3, 0}, {0, 0, 0}, {0, 0, 0}};
  double N[8], dN[24], xq[3], F[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, C[9];
  int D = m->dim, a, i, j, k;
  mo_elem_geometry(m, e, ctr[m->type], N, dN, xq);
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
  char tmp[4200];
  FILE *f;
  if (snprintf(tmp, sizeof tmp, "%s.tmp.%ld", path, (long)getpid()) >= (int)sizeof tmp)
    return mo_error(ctx, MO_EIO, "path too long: '%s'", path);
  f = fopen(tmp, "w");
  if (!f) return mo_error(ctx, MO_EIO, "cannot write '%s': %s", tmp, strerror(errno));
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
      fclose(f);
      remove(tmp);
      return MO_ENOMEM;
    }
    for (e = 0; e < m->nelem; e++) {
      double ue[24], ee[6], se[6];
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
  if (ferror(f) || fclose(f) != 0) {
    remove(tmp);
    return mo_error(ctx, MO_EIO, "cannot write '%s'", tmp);
  }
  if (rename(tmp, path) != 0) {
    remove(tmp);
    return mo_error(ctx, MO_EIO, "cannot replace '%s': %s", path, strerror(errno));
  }
  return MO_OK;
}

int mo_vtk_frame(mo_vtk *v, const mo_scene *sc, const mo_state *s, mo_ctx *ctx)
{
  char path[4200], *pvd = NULL;
  size_t cap = 4096, len = 0;
  int b, k, st;
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
  /* the collection, rewritten whole so that it always lists complete frames only */
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
