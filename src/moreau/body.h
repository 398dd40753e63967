/* moreau/body.h: kinds of body as type objects (deformable, plane, disk, sphere, polygon, rigid
   mesh) and the rigid-body kinematics the stepper and the contact layer share (doc/theory.md §12). */
#ifndef MOREAU_BODY_H
#define MOREAU_BODY_H

#include <moreau/scene.h>

#ifdef __cplusplus
extern "C" {
#endif

struct mo_state;
struct config_setting_t; /* libconfig's, for the readers of case groups */

/* The most vertices a polygon may have. */
#define MO_POLYGON_MAX 64

/* What a kind of body is, for the code that must not ask which kind it holds. */
enum {
  MO_BODY_F_NODAL = 1,     /* dofs at the nodes of a mesh, in the shared FE block of What */
  MO_BODY_F_RIGID = 2,     /* dofs (x, v) and (theta, omega) of a rigid body: its own block */
  MO_BODY_F_OBSTACLE = 4,  /* no dofs: a prescribed motion (planes) */
  MO_BODY_F_MESH = 8,      /* carries a mesh: node and facet sets usable by contact pairs */
  MO_BODY_F_BALL = 16,     /* contact shape: a disk (2D) or a sphere (3D) */
  MO_BODY_F_POLYGON = 32   /* contact shape: a convex polygon (2D) */
};

/* A kind of body (GSL-style type object; the table is src/body.c). The scene calls read, then
   conditions once the dofs are numbered, then loads once the free dofs are numbered; the
   stepper asks rigid types for their mass block; the contact layer asks every type where a
   material point is and how it moves. */
typedef struct mo_body_type {
  const char *name;        /* the value of bodies.[].type */
  mo_body_kind kind;
  unsigned flags;          /* MO_BODY_F_* */
  unsigned dims;           /* bit d set when the kind exists in space dimension d */
  const char *summary;     /* one line for the documentation */
  /* Bodies one case entry makes (NULL: one; an arch generator makes its voussoirs). */
  int (*count)(const struct config_setting_t *bg);
  /* Read the body's own keys (shape, mesh, material, mass, placement) from its validated group;
     member is its rank among the entry's bodies; dim is the space dimension (0 when no body has
     fixed it yet: obstacles are read again once it is known). Sets B->ndof. Errors name file,
     line and key. */
  int (*read)(mo_body *B, int member, int dim, const mo_case *cs, const struct config_setting_t *bg,
              mo_ctx *ctx);
  /* Fixed and prescribed dofs and initial velocities, once B->dof0 is known; owner[dof] is the
     prescription holding a dof (-1: free), updated by mo_scene_add_presc. */
  int (*conditions)(mo_scene *sc, int b, const struct config_setting_t *bg, int *owner, mo_ctx *ctx);
  /* Loads, once the free dofs are numbered; f is ndof scratch. */
  int (*loads)(mo_scene *sc, int b, const struct config_setting_t *bg, double *f, mo_ctx *ctx);
  void (*release)(mo_body *B);
} mo_body_type;

/* The table of kinds, and lookup by name (NULL when unknown). */
int mo_body_type_count(void);
const mo_body_type *mo_body_type_at(int i);
const mo_body_type *mo_body_type_find(const char *name);
/* "deformable|plane|..." for messages and the schema. */
const char *mo_body_type_names(void);

/* --- rigid bodies -----------------------------------------------------------------------------
   2D: dofs (x, y, theta), u holds (x - x0, y - y0, theta - theta0); 3D: dofs (x, y, z) and the
   rotation (rx, ry, rz), u holding the displacement of the centroid and the integral of omega
   (world frame), the orientation itself in mo_state.orient (unit quaternion, body to world). */

/* Number of dofs of a rigid body in dimension dim (3 or 6). */
int mo_rigid_ndof(int dim);
/* Rotation matrix R (3 x 3 row-major; 2D in the upper 2 x 2 block) of a rigid body at state s
   (s NULL: the reference orientation). */
void mo_rigid_rotation(const mo_scene *sc, const mo_body *B, const struct mo_state *s, double *R);
/* World position of the centroid at state s (NULL: reference). */
void mo_rigid_center(const mo_scene *sc, const mo_body *B, const struct mo_state *s, double *x);
/* World position of a point given in the body frame (relative to the centroid). */
void mo_rigid_point(const mo_scene *sc, const mo_body *B, const struct mo_state *s, const double *X,
                    double *x);
/* Velocity Jacobian at the world point P: v(P) = G v_body, G dim x ndof row-major
   (2D: [1 0 -(Py - yc); 0 1 (Px - xc)], 3D: [I, -[P - xc]x]). */
void mo_rigid_jacobian(int dim, const double *xc, const double *P, double *G);
/* Mass matrix of the body at state s (ndof x ndof row-major): diag(m, m, I) in 2D,
   blockdiag(m I, R J R^T) in 3D. */
void mo_rigid_mass(const mo_scene *sc, const mo_body *B, const struct mo_state *s, double *M);
/* Gyroscopic force -omega x (J_w omega) of a 3D body (world frame) on its rotation rows, into
   f (ndof values; translation rows 0). Zero in 2D and for isotropic inertia. */
void mo_rigid_gyroscopic(const mo_scene *sc, const mo_body *B, const struct mo_state *s,
                         const double *v, double *f);
/* Update the orientation of a 3D body by the rotation vector phi (world frame):
   q <- exp(phi / 2) * q, renormalized (doc/theory.md (T69)). */
void mo_quat_rotate(double *q, const double *phi);
/* Rotation matrix of a unit quaternion (w, x, y, z). */
void mo_quat_matrix(const double *q, double *R);
/* Kinetic energy of every rigid body at state s. */
double mo_rigid_kinetic(const mo_scene *sc, const struct mo_state *s);
/* The kinetic energy of the rigid bodies list[0 .. n) with mask[b] != 0 (mask NULL: all of them). */
double mo_rigid_kinetic_list(const mo_scene *sc, const struct mo_state *s, const int *list, int n,
                             const unsigned char *mask);
/* Bounding radius of a rigid body about its centroid (disk, sphere: R; polygon, mesh: the
   farthest vertex). */
double mo_rigid_bound(const mo_body *B);
/* A polygon's vertices in the world at state s (2 * nvert values). */
void mo_polygon_world(const mo_scene *sc, const mo_body *B, const struct mo_state *s, double *v);

/* --- shared by the kinds' read functions (scene.c) ------------------------------------------ */

/* Add a prescription of `dof` (returns 0, 1 when the dof was already fixed the same way, -1 on
   a conflict, MO_ENOMEM). */
int mo_scene_add_presc(mo_scene *sc, int dof, mo_presc_kind kind, double vel, mo_expr *disp,
                       int *owner, mo_ctx *ctx);
/* A load pattern from a dense vector over all dofs (amp: NULL or an expression in t, owned). */
int mo_scene_add_load(mo_scene *sc, const double *f, mo_expr *amp, mo_ctx *ctx);
/* The same from n entries (dof, value); a constant load (amp NULL) joins the last constant
   pattern. amp is owned by the scene afterwards (freed on failure). */
int mo_scene_add_load_sparse(mo_scene *sc, int n, const int *dof, const double *val, mo_expr *amp, mo_ctx *ctx);

#ifdef __cplusplus
}
#endif
#endif
