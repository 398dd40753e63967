/* moreau/output.h: result files: CSV histories (flushed every row), VTK XML series, files
   replaced atomically (written to a temporary name, then renamed). */
#ifndef MOREAU_OUTPUT_H
#define MOREAU_OUTPUT_H

#include <moreau/ctx.h>
#include <moreau/scene.h>
#include <moreau/step.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Create folder `dir` (and its parents) if needed. */
int mo_mkdir_p(const char *dir, mo_ctx *ctx);
/* Write `len` bytes to `path` atomically: a reader sees the old file or the new one, never a
   part of the new one. */
int mo_write_file_atomic(const char *path, const char *data, size_t len, mo_ctx *ctx);

typedef struct mo_csv mo_csv;
/* Open a CSV file with a header row; rows are flushed as written, so that a crash leaves every
   complete row readable. */
int mo_csv_open(const char *path, const char *const *names, int ncol, int precision,
                mo_csv **out, mo_ctx *ctx);
int mo_csv_row(mo_csv *c, const double *vals, mo_ctx *ctx);
int mo_csv_close(mo_csv *c, mo_ctx *ctx);

typedef struct mo_vtk mo_vtk;
/* VTK XML series in `dir`: one .vtu per deformable body and frame, indexed by fields.pvd
   (rewritten atomically after each frame). */
int mo_vtk_open(const char *dir, const mo_scene *sc, mo_vtk **out, mo_ctx *ctx);
int mo_vtk_frame(mo_vtk *v, const mo_scene *sc, const mo_state *s, mo_ctx *ctx);
int mo_vtk_frames(const mo_vtk *v);
void mo_vtk_close(mo_vtk *v);

#ifdef __cplusplus
}
#endif
#endif
