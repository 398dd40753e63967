/* moreau/scene.h: a scene built from a case: bodies, dof numbering, matrices, loads, initial
   fields, time and output settings, probes and the closed-form reference. */
#ifndef MOREAU_SCENE_H
#define MOREAU_SCENE_H

#include <moreau/case.h>
#include <moreau/ctx.h>
#include <moreau/expr.h>
#include <moreau/fe.h>
#include <moreau/mesh.h>
#include <moreau/sparse.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The kinds of body (moreau/body.h: each is a type object; this enum names them). */
typedef enum {
  MO_BODY_DEFORMABLE = 0, MO_BODY_PLANE, MO_BODY_DISK, MO_BODY_SPHERE, MO_BODY_POLYGON,
  MO_BODY_RIGID_MESH
} mo_body_kind;

struct mo_body_type;
struct mo_scene;

typedef struct mo_body {
  char *name;
  char *group;          /* the entry that generated it with others (an arch's voussoirs), or NULL */
  int entry;            /* its entry in the case's bodies list */
  mo_body_kind kind;    /* (the int-sized fields in pairs: no padding, 208 bytes a body) */
  const struct mo_body_type *type;
  mo_mesh *mesh;        /* deformable and rigid-mesh bodies */
  mo_material *mat;     /* bodies with a mesh (deformable, rigid mesh; owned), NULL for shapes and
                           planes: 64 bytes a grain less */
  /* finite-strain bodies (material models hencky and j2, moreau/material.h): their internal
     forces and tangents come from the kernels of fe_nonlinear.c, not from the scene's K */
  int nl;
  int nvert;            /* polygon: its vertices (vert below) */
  int dof0, ndof;       /* global dofs dof0 .. dof0+ndof-1; node a, component i: dof0+a*dim+i */
  double mass;          /* total mass (kg, or kg per unit thickness as the hypothesis says) */
  /* a plane's fields, a rigid body's and a deformable body's share their memory (a body is one of
     the three, and nothing reads another's: 96 bytes less a grain, T263) */
  union {
    /* deformable bodies (kind MO_BODY_DEFORMABLE; read only there) */
    struct {
      size_t q0;        /* offset of its first state block in mo_state.q (doubles) */
      int lumped;       /* lumped mass */
      int npoint;       /* quadrature points per element (state blocks per element) */
    };
    struct {
      double point[3], normal[3], velocity[3]; /* plane obstacles (unit normal) */
      double until;     /* plane: gone after this time (a gate that opens); HUGE_VAL: always there */
    };
    /* rigid bodies: disk, sphere, polygon, rigid mesh (doc/theory.md §12) */
    struct {
      double J[9];      /* inertia about the centroid in the body frame (2D: J[0] = I) */
      double xc0[3];    /* centroid in the reference configuration */
    };
  };
  double theta0;        /* 2D: orientation in the reference configuration (rad) */
  double radius;        /* disk, sphere */
  double *vert;         /* polygon: vertices about the centroid in the body frame, counter-clockwise */
  int orient;           /* 3D rigid bodies: index of the quaternion in mo_state.orient, else -1 */
  int fixed;            /* every dof held fixed (a support: no history columns) */
  double bound;         /* bounding radius about the centroid */
} mo_body;

typedef enum { MO_PRESC_FIX = 0, MO_PRESC_VELOCITY, MO_PRESC_EXPR } mo_presc_kind;

/* A prescribed (eliminated) dof. FIX holds the dof at its initial value; VELOCITY moves it at
   constant velocity; EXPR follows an expression in t. */
typedef struct {
  int dof;
  mo_presc_kind kind;
  double u0, vel;
  mo_expr *disp;
} mo_presc;

/* A load pattern: f(t) += amplitude(t) * F, F stored sparse over full dofs. */
typedef struct {
  int n, cap;    /* entries, room */
  int *dof;
  double *val;
  mo_expr *amp;  /* NULL: constant 1 */
} mo_load;

/* Probe quantities: displacement, velocity, support reaction, contact force (vectors, by
   component), contact pressure, gap and friction semi-multiplier (at the candidates of the
   probe's nodes). */
typedef enum {
  MO_Q_UX = 0, MO_Q_UY, MO_Q_UZ, MO_Q_VX, MO_Q_VY, MO_Q_VZ, MO_Q_FX, MO_Q_FY, MO_Q_FZ,
  MO_Q_CX, MO_Q_CY, MO_Q_CZ, MO_Q_PN, MO_Q_GN,
  MO_Q_LAM,  /* friction semi-multiplier |Lambda| = |r_t| / (mu r_n) (BDZ07 Fig. 10; 0 when open) */
  MO_Q_N
} mo_quantity;
const char *mo_quantity_name(mo_quantity q);

typedef struct {
  char *name;
  int body;
  int nnode;
  int *node;      /* body-local node numbers */
  int nq;
  mo_quantity q[MO_Q_N];
} mo_probe;

typedef enum { MO_SCHEME_THETA = 0, MO_SCHEME_NEWMARK, MO_SCHEME_QUASISTATIC } mo_scheme;

typedef struct {
  mo_scheme scheme;
  double dt, end;
  long steps;
  double theta, theta_f;  /* theta scheme */
  /* time.scheme = "explicit": the theta-scheme at theta = 1, theta_f = 0 with lumped mass,
     i.e. central differences (doc/theory.md §1.7, (T100)); scheme is MO_SCHEME_THETA */
  int explicit_cd;
  double beta, gamma;     /* Newmark */
  /* Newton iterations of nonlinear scenes (doc/theory.md §11): the step ends when the
     residual of the momentum balance is at most newton_tol times its scale (T64) */
  double newton_tol;
  int newton_max;         /* iterations before the run stops with a diagnosis */
  /* bounded step cutting: a step that fails to converge (or meets a NaN, an inverted element,
     an indefinite matrix) is taken again as two steps of h/2, down to h / 2^max_cuts */
  int max_cuts;
} mo_time_settings;

#define MO_MAX_CUTS 12   /* the largest time.max_cuts */

/* Linear stability of the theta-scheme (theta, theta_f) on an undamped mode of frequency w
   (doc/theory.md (T101)): MO_STAB_UNCONDITIONAL (theta, theta_f >= 1/2), MO_STAB_CONDITIONAL
   (stable iff h w <= *omega_h, e.g. 2 / sqrt(1 - 2 theta) at theta_f = 1, 2 for explicit
   central differences), MO_STAB_UNSTABLE (theta + theta_f < 1: every mode grows at every h). */
enum { MO_STAB_UNCONDITIONAL = 0, MO_STAB_CONDITIONAL, MO_STAB_UNSTABLE };
int mo_theta_stability(double theta, double theta_f, double *omega_h);

/* A node set whose extent (bounding box in the current configuration) summary.json reports. */
typedef struct {
  char *name;
  int body;
  int nnode;
  int *node;      /* body-local node numbers */
} mo_extent;

typedef struct {
  int every;
  int precision;
  int energy;
  int vtk;              /* write VTK series */
  int vtk_every;
  unsigned vtk_fields;  /* bit set of MO_VTK_* */
  int vtk_contacts;     /* output.vtk.contacts: MO_VTK_CONTACTS_* */
  int contact_history;  /* output.contact_history present: contact_history.csv */
  int contact_history_every;
  int contact_history_closed; /* output.contact_history.candidates = "closed" */
  int nextent;
  mo_extent *extent;    /* output.extents */
} mo_output_settings;

/* Which candidates the contact outputs of every frame carry: none, the closed ones (a status
   other than open, or a reaction), all. */
enum { MO_VTK_CONTACTS_NONE = 0, MO_VTK_CONTACTS_CLOSED, MO_VTK_CONTACTS_ALL };
enum { MO_VTK_DISPLACEMENT = 1, MO_VTK_VELOCITY = 2, MO_VTK_STRESS = 4, MO_VTK_STRAIN = 8,
       MO_VTK_VON_MISES = 16, MO_VTK_EPS_P = 32 };

typedef enum {
  MO_REF_NONE = 0,
  MO_REF_BAR_RELEASE,        /* clamped-free bar released from a uniform strain (T5) */
  MO_REF_BAR_STEP_VELOCITY,  /* clamped bar, far end given a constant velocity (T6) */
  MO_REF_RODS_IMPACT,        /* a rod against a rigid wall, or half of two identical rods (T43) */
  MO_REF_BAR_OBSTACLE,       /* Doyen-Ern-Piperno's bar released against an obstacle (T44) */
  MO_REF_ENERGY,             /* only the exact total energy (potential of the loads included) */
  MO_REF_BOUNCE,             /* a ball dropped on a plane, Newton's restitution e (T73) */
  MO_REF_INCLINE,            /* a block sliding or sticking, a disk or sphere rolling or slipping
                                on a slope (T74) */
  MO_REF_STRUCK_BAR          /* a bar struck by a rigid mass: Saint-Venant's contact force (T75) */
} mo_reference_type;

typedef struct {
  mo_reference_type type;
  int body;                  /* the body the closed form describes (field errors) */
  double length, c;          /* bar length L, wave speed c */
  double strain, velocity;   /* bar_release: eps; bar_step_velocity and rods: v (speed) */
  double x0;                 /* bar: clamped end; bar_obstacle: contact end; rods: contact end */
  double direction;          /* rods: +1 when the rod moves toward +x, -1 otherwise */
  double gap;                /* rods: distance the contact end travels before impact */
  double amplitude;          /* bar_obstacle: initial displacement of the contact end */
  double density, area;      /* for forces and pressures (E = rho c^2) */
  double energy;             /* exact total energy (NaN: E(0)) */
  /* rigid scenes (doc/theory.md §12.6): the body described (body), gravity g, */
  double gravity;
  double height, restitution, radius; /* bounce: initial height of the bottom, e, radius */
  double angle, mu;          /* incline: slope (rad, descending toward +x), friction */
  double accel, alpha;       /* incline: acceleration along the slope, angular acceleration
                                (negative: clockwise), from the regime */
  int regime;                /* incline: 0 stick, 1 slide (or roll with slip), 2 roll */
  double mass;               /* struck_bar: the striking mass M */
  double x1[3];              /* the centroid at t = 0 */
} mo_reference;

/* Closed form along the bar at material coordinate x, time t: displacement, velocity and axial
   strain along x (global axis). */
void mo_reference_field(const mo_reference *R, double x, double t, double *u, double *v,
                        double *eps);
/* Contact pressure (>= 0) at the contact end at time t; 1 when the contact is closed. */
int mo_reference_contact(const mo_reference *R, double t, double *pressure);
/* Time of the first release after an impact (NaN when the closed form has none), and the
   impulse of the contact force on the body over [0, T] (N s). */
double mo_reference_release_time(const mo_reference *R);
double mo_reference_impulse(const mo_reference *R, double T);
/* Value of probe quantity q at (x, t) from the reference; 0 when it has none. */
int mo_reference_eval(const mo_reference *R, mo_quantity q, double x, double t, double *val);
/* Value of component comp of rigid body b's history columns (2D x, y, theta, vx, vy, omega; 3D
   x, y, z, q0..q3, vx, vy, vz, wx, wy, wz) at time t from a rigid reference; 0 when it has
   none. */
int mo_reference_rigid(const mo_reference *R, const struct mo_scene *sc, int b, int comp, double t, double *val);
const char *mo_reference_name(mo_reference_type t);

/* linear_solver: the solver of What (moreau/sparse.h mo_linsolver_settings). */
typedef struct {
  int petsc;                  /* 1: PETSc's KSP over the MPI ranks; 0: CHOLMOD */
  char ksp[32], pc[32], package[32], options[1024];
  double rtol;
  int out_of_core;            /* MUMPS's factor on disk (doc/theory.md (T182)) */
  char ooc_dir[512];          /* where its folder is made ("": TMPDIR, else /tmp) */
} mo_linear_settings;

typedef struct mo_scene {
  char *title;
  char *case_file;
  int dim;
  int nbody;
  mo_body *body;
  int ndof, nfree;
  /* the nodal dofs of deformable bodies come first (0 .. nfe_dof-1, free indices 0 ..
     nfe_free-1: the block of What factored by CHOLMOD), the rigid bodies' after */
  int nfe_dof, nfe_free;
  int nrigid;
  int *rigid;     /* nrigid body indices; rigid body r's dofs are nfe_dof + r nd .. + nd - 1 (number_dofs) */
  double *rigid_md; /* 2D: per rigid body (rigid's order), its mass and inertia (m, I), the diagonal of
                       diag(m, m, I) the per-step passes read instead of the body records (T311); NULL in 3D */
  int norient;    /* 3D rigid bodies (quaternions in mo_state.orient) */
  int *free_of;   /* ndof: free index of each dof, or -1 when prescribed */
  int *full_of;   /* nfree: dof of each free index (free_of itself when every dof is free) */
  int npresc;
  mo_presc *presc;
  int nload, loadcap;
  mo_load *load;
  mo_csc *K, *M;  /* full ndof x ndof (M is NULL for quasi-static scenes); K holds the linear
                     bodies only (finite-strain bodies have no constant stiffness) */
  double *u0, *v0;  /* the initial fields; released by mo_run once its state holds them on a scene
                      without a mesh and without an extreme one (doc/theory.md (T248)) */
  double mass_total;
  /* the elements whose K and M each rank computed, and its seconds in that loop (nranks values
     each; one process: its count and time; doc/parallel.md §3) */
  double *asm_elems, *asm_seconds;
  double *asm_entries;  /* the entries of K and M each rank holds (nnz(K) + nnz(M)) */
  /* Over MPI ranks, a linear scene (doc/parallel.md §3): K and M hold the elements this rank
     computed, the scene's matrices being their sums over the ranks; every product with them
     is the sum of the parts' products (mo_scene_gaxpy, collective). 0: K and M whole. */
  int kpart;
  mo_ctx *pctx;         /* kpart: the context of those sums (the run's) */
  double *pwork;        /* kpart: ndof, a part's product before the sum */
  double dt_bound;      /* kpart: (T103a), computed over the ranks once assembled */
  int has_moving_presc; /* some prescribed dof moves: coupling terms needed */
  int nonlinear;        /* some body has a finite-strain material: Newton steps (§11) */
  size_t nq;            /* doubles of material state over the finite-strain bodies */
  mo_time_settings time;
  mo_linear_settings lin;
  mo_output_settings out;
  int nprobe;
  mo_probe *probe;
  mo_reference ref;
  const mo_case *cs; /* the case it was built from (not owned) */
  double bytes_estimate; /* the run's memory as estimated from the case before building (T105,
                            T165), bytes (summary.json bytes_estimate) */
} mo_scene;

/* Build a scene from a validated case: meshes, sets, dofs, assembly of K and (for dynamic
   schemes) M, loads, initial fields, probes. Semantic errors name file, line and key. */
int mo_scene_build(const mo_case *cs, mo_scene **out, mo_ctx *ctx);
void mo_scene_free(mo_scene *sc);

/* Every dof free and no nodal dof (rigid bodies and obstacles only): the free numbering is the
   full one, so the driver's and the stepper's free-dof vectors are their full ones
   (doc/theory.md (T236), (T246)). */
static inline int mo_scene_all_free_rigid(const mo_scene *sc) { return sc->nfree == sc->ndof && sc->nfe_dof == 0; }

/* External force f(t) over full dofs (overwrites f). */
void mo_scene_fext(const mo_scene *sc, double t, double *f);
/* Prescribed displacement and velocity of presc[k] at time t. */
void mo_scene_presc_eval(const mo_scene *sc, int k, double t, double *u, double *v);
/* Reference block of the case (called by mo_scene_build). */
int mo_reference_build(mo_reference *R, const mo_scene *sc, mo_ctx *ctx);
/* Index of a body by name, or -1. */
int mo_scene_body_index(const mo_scene *sc, const char *name);
/* Critical time step of explicit central differences (doc/theory.md (T102)): the smallest over
   the elements of the deformable bodies of l_e / c_d (characteristic length over dilatational
   wave speed); with body and elem (may be NULL) where it is reached. HUGE_VAL without elements. */
double mo_scene_dt_crit(const mo_scene *sc, int *body, int *elem);
/* A guaranteed stable step of central differences (doc/theory.md (T103)): 2 / sqrt of
   Gershgorin's bound on omega_max^2 over the free rows of M^-1 K; NAN unless every nodal mass is
   diagonal (lumped) and the bodies linear, HUGE_VAL without nodal free dofs. */
double mo_scene_dt_bound(const mo_scene *sc);
/* y = alpha A x + beta y, A the scene's K or M or a matrix made of them (What over full dofs):
   with sc->kpart A is this rank's part and the product the sum over the ranks of the parts'
   (one sum of A's nrow values; every rank must call it). */
void mo_scene_gaxpy(const mo_scene *sc, const mo_csc *A, double alpha, const double *x, double beta, double *y);
/* The sum over the ranks of every rank's part A (columns j with held[j] > 1.5 only; held NULL:
   all), gathered whole on every rank (collective). */
int mo_csc_sum_parts(const mo_csc *A, const double *held, mo_csc **out, mo_ctx *ctx);

#ifdef __cplusplus
}
#endif
#endif
