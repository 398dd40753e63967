/* moreau/output.h: result files: CSV histories (flushed every row), VTK XML series, files
   replaced atomically (written to a temporary name, then renamed). */
#ifndef MOREAU_OUTPUT_H
#define MOREAU_OUTPUT_H

#include <stdio.h>

#include <moreau/ctx.h>
#include <moreau/scene.h>
#include <moreau/step.h>
#include <moreau/run.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Create folder `dir` (and its parents) if needed. */
int mo_mkdir_p(const char *dir, mo_ctx *ctx);
/* Write `len` bytes to `path` atomically: a reader sees the old file or the new one, never a
   part of the new one. */
int mo_write_file_atomic(const char *path, const char *data, size_t len, mo_ctx *ctx);
/* The same for a file written piece by piece: open a temporary beside `path`, write to A->f,
   then commit: with ok, flushed, synced and renamed onto `path` (an error if any write
   failed); without, removed (the old file stays). */
typedef struct mo_atomic_file {
  FILE *f;
  char path[4200], tmp[4240];
  int anon;   /* the bytes are in an anonymous file (O_TMPFILE) until the commit */
  int nosync; /* set after open: commit without fsync (the frames of a series) */
} mo_atomic_file;
int mo_atomic_open(mo_atomic_file *A, const char *path, mo_ctx *ctx);
int mo_atomic_commit(mo_atomic_file *A, int ok, mo_ctx *ctx);

/* A run's claim on its output folder (doc/case-format.md, "Output folder"): created if
   needed, locked (DIR/.lock, flock: a second run on the same folder is refused with
   MO_EINPUT, and the lock goes with the process, also on SIGKILL), the temporaries a killed
   run left removed, and the old summary.json replaced by one saying "running" before any
   other byte is written, so that no reader takes the folder for complete until the run says
   so. */
typedef struct mo_outdir {
  int fd;
  char dir[4096];
} mo_outdir;
int mo_outdir_claim(mo_outdir *O, const char *dir, const char *case_file, mo_ctx *ctx);
void mo_outdir_release(mo_outdir *O);

typedef struct mo_csv mo_csv;
/* Open a CSV file with a header row; rows are flushed as written, so that a crash leaves every
   complete row readable. */
int mo_csv_open(const char *path, const char *const *names, int ncol, int precision,
                mo_csv **out, mo_ctx *ctx);
int mo_csv_row(mo_csv *c, const double *vals, mo_ctx *ctx);
int mo_csv_close(mo_csv *c, mo_ctx *ctx);

/* The contact network and the contact points of one frame are made by chunks of at most
   MO_VTK_CHUNK entries, each written before the next is filled, so that a frame of 10^5 contacts
   holds a few hundred kilobytes and not 350 bytes a contact (doc/theory.md §12.11). Their source
   (mo_contact_network, mo_contact_points in moreau/contact.h, so that the writers need not know
   the contact layer) sets total, the frame's entries, and next, which fills the chunk after the
   current one: first its first entry, n its entries (0 past the end). A reader goes through the
   frame as: mo_vtk_*_rewind; while (!(st = mo_vtk_*_next(X, ctx)) && X->n) use entries 0..n-1.
   128 entries hold 44 kB (348 bytes an entry, both kinds), a slice of an array 0.5 to 6 kB: the
   buffers stay small beside a run's contact set (at 512, 178 kB were a tenth of the heap at the end
   of a 10^3 pile, its peak), and the writes still large (doc/theory.md (T251)). */
#define MO_VTK_CHUNK 128

/* What a source keeps between chunks (its own, opaque to the writers). */
typedef struct mo_vtk_source {
  const void *sc, *C, *D, *s;
  long cursor;          /* the source's next item (a candidate) */
  int closed_only;
  /* the distributed set (doc/scaling.md §4): on rank 0 every rank's entries gathered, recw
     numbers each, in contact.csv's order; cursor then counts them */
  double *rec;          /* every rank's entries as received (rank by rank) */
  long *ord;            /* rec's entries in that order: the place of each in rec */
  long nrec;
  int recw;
} mo_vtk_source;

/* The gathered entries of a source freed (the distributed set's, once its frame is written). */
void mo_vtk_source_drop(mo_vtk_source *src);

/* The contact network: one line per candidate that is closed or carries a reaction. cap is the
   room of the arrays (entries). The owner releases them with mo_vtk_contacts_release. */
typedef struct mo_vtk_contacts {
  long total, first;
  int n, cap;
  double *end;      /* 6 n: the two ends (x, y, z): the slave side, then the master side: a rigid
                       shape's centre, or the material point (mesh slave) and the contact point
                       (plane or mesh master) */
  double *point;    /* 3 n: the contact point */
  double *rn, *rt;  /* n: normal force, norm of the tangential force (forces, not impulses) */
  double *gap;      /* n: the gap of the step's geometry */
  int *status;      /* n: 0 open, 1 stick, 2 slide (MO_CS_*) */
  int *body;        /* 2 n: slave and master body (index in mo_scene.body; -1: none) */
  int (*fill)(struct mo_vtk_contacts *N, mo_ctx *ctx); /* fills the chunk at first (n entries) */
  mo_vtk_source src;
} mo_vtk_contacts;
/* Room for n lines in the arrays (the contents kept). */
int mo_vtk_contacts_reserve(mo_vtk_contacts *N, int n, mo_ctx *ctx);
void mo_vtk_contacts_rewind(mo_vtk_contacts *N);
int mo_vtk_contacts_next(mo_vtk_contacts *N, mo_ctx *ctx);
void mo_vtk_contacts_release(mo_vtk_contacts *N);

/* The contact points: one entry per candidate of the step (output.vtk.contacts = "all") or per
   closed one ("closed": a status other than open, or a reaction), in contact.csv's order, with
   contact.csv's values. d is the local dimension (1, 2 or 3); R and U hold 3 values per entry,
   the first d used. The owner releases the arrays with mo_vtk_points_release. */
typedef struct mo_vtk_points {
  long total, first;
  int n, cap, d;
  double *x;        /* 3 n: the slave point in the current configuration (x0 + displacement for
                       a mesh point; the contact point of a detected one) */
  double *x0;       /* 3 n: its reference position (contact.csv's x, y, z) */
  double *disp;     /* 3 n: the displacement of the slave point (contact.csv's D1, D2, D3) */
  double *normal;   /* 3 n: the normal of the frame (master to slave) */
  double *R, *U;    /* 3 n: reactions as forces and local relative velocity, normal first */
  double *force;    /* 3 n: the reaction on the slave in world axes, sum_l R_l F_l */
  double *vrel;     /* 3 n: the relative velocity in world axes, sum_l U_l F_l */
  double *gap, *lambda, *measure; /* n: gap, friction semi-multiplier (T66), the candidate's measure */
  int *cand, *pair, *node, *status; /* n: candidate (contact.csv's), pair index, slave node (-1: none),
                                       MO_CS_* */
  int *body;        /* 2 n: slave and master body (index in mo_scene.body; -1: none) */
  int (*fill)(struct mo_vtk_points *P, mo_ctx *ctx); /* fills the chunk at first (n entries) */
  mo_vtk_source src;
} mo_vtk_points;
/* Room for n points of local dimension d in the arrays (the contents kept). */
int mo_vtk_points_reserve(mo_vtk_points *P, int n, int d, mo_ctx *ctx);
void mo_vtk_points_rewind(mo_vtk_points *P);
int mo_vtk_points_next(mo_vtk_points *P, mo_ctx *ctx);
void mo_vtk_points_release(mo_vtk_points *P);

typedef struct mo_vtk mo_vtk;
/* VTK XML series in `dir`, every file an UnstructuredGrid with its arrays appended raw
   (format="appended", encoding="raw", UInt64 byte counts, the machine's byte order, which the
   file names: exact to the last bit; read by VTK, ParaView, meshio) and its time as FieldData
   TimeValue, every collection (.pvd) listing its frames with their times and rewritten
   atomically after each frame, so that it names complete files only. Per frame:
     fields_BODY_NNNNN.vtu  each deformable body in its reference configuration, point data
                          displacement, velocity, cell data strain, stress, von_mises, eps_p
                          (output.vtk.fields), in fields.pvd (one part per body);
     contact_points_NNNNN.vtu (a scene with contact, output.vtk.contacts "all" or "closed") a
                          vertex per candidate (mo_vtk_points), in contact_points.pvd;
     planes_NNNNN.vtu     every plane at time t as a square (3D), a segment (2D) or a point
                          (1D), sized to the bodies' bounding box over the frames so far, cell
                          data body, normal, velocity, in planes.pvd;
   and for a scene with rigid bodies:
     particles_NNNNN.vtu  every disk and sphere as a vertex at its centre, point data radius,
                          velocity, omega (2D: along z), orientation (2D: the angle; 3D: the
                          quaternion w, x, y, z), body;
     polygons_NNNNN.vtu   every polygon as a VTK_POLYGON of its world vertices, and every rigid
                          mesh (2D and 3D) as the cells of its mesh in the current configuration,
                          cell data velocity, omega, body;
     contacts_NNNNN.vtu   the contact network (mo_vtk_contacts) as VTK_LINE cells, cell data rn,
                          rt, status, gap, point, slave, master (a valid empty file when there is
                          no contact);
   with particles.pvd, polygons.pvd, contacts.pvd (the series a scene has; contacts.pvd always)
   and once, particles.py: a ParaView script that shows them (glyphs, tubes, planes, forces).
   `contact`: the scene has contact pairs. */
int mo_vtk_open(const char *dir, const mo_scene *sc, int contact, mo_vtk **out, mo_ctx *ctx);
/* Write frame mo_vtk_frames(v) of state s: the fields, the contact points `pts`, the planes,
   and for a scene with rigid bodies the rigid series with the network `net` (NULL: no
   contact). */
int mo_vtk_frame(mo_vtk *v, const mo_scene *sc, const mo_state *s, mo_vtk_contacts *net, mo_vtk_points *pts,
                 mo_ctx *ctx);
/* The collections that list the frames written (the .pvd of each series, and in MPI runs the
   .pvtu joining the ranks' pieces of each body): after mo_vtk_frame, once every rank's pieces are
   written (rank 0 writes them; a no-op on the others). */
int mo_vtk_index(mo_vtk *v, const mo_scene *sc, mo_ctx *ctx);
int mo_vtk_frames(const mo_vtk *v);
/* The series this writer writes (MO_OUT_* bits of moreau/run.h). */
unsigned mo_vtk_outputs(const mo_vtk *v);
/* 1 when frames carry contact points (mo_vtk_frame reads pts). */
int mo_vtk_wants_points(const mo_vtk *v);
void mo_vtk_close(mo_vtk *v);

#ifdef __cplusplus
}
#endif
#endif
