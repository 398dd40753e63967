/* levelset.h: private header of the levelset back end (Ben Dhia-Zammali's Level-Set stabilized
   Lagrangian, doc/theory.md §6): parameters, state, the frozen-status system and its two
   linear-algebra paths. Nothing here is exported from libmoreau. */
#ifndef MOREAU_LEVELSET_H
#define MOREAU_LEVELSET_H

#include <moreau/contact.h>
#include <math.h>

/* --- parameters (contact.levelset.*) ---------------------------------------------------------- */

enum { LS_MULT_AUTO = 0, LS_MULT_P1, LS_MULT_P0 };
enum { LS_STAB_PROJECTED = 0, LS_STAB_UNPROJECTED };
enum { LS_SU_INDEX_SET = 0, LS_SU_END_GAP };
enum { LS_PATH_AUTO = 0, LS_PATH_SCHUR, LS_PATH_KKT, LS_PATH_REDUCED };
enum { LS_THR_AUTO = 0, LS_THR_LOOP, LS_THR_COUPLED };
enum { LS_GLOB_AUTO = 0, LS_GLOB_NONE, LS_GLOB_LINE_SEARCH, LS_GLOB_HYBRID };
enum { LS_SMOOTH_AUTO = 0, LS_SMOOTH_BODIES, LS_SMOOTH_DELASSUS };
enum { LS_LOCAL_KEPT = 0, LS_LOCAL_ELIMINATION };
enum { LS_ORDER_FORWARD = 0, LS_ORDER_ALTERNATE };

typedef struct {
  int multipliers;        /* LS_MULT_*: the multiplier space H_h of BDZ07 (65) */
  double h_n, rho_n, k_n; /* BDZ07 (27)-(29), (37); 0 = automatic for h_n, rho_n (T16) */
  int stabilization;      /* LS_STAB_*: k_n projected on H_h (Remark 4) or not */
  double rho_t, h1_t, h2_t, k_t; /* BDZ07 (41), (44), (49); 0 = automatic except k_t */
  int su;                 /* LS_SU_*: how S_u is evaluated in a theta step (T14) */
  int path;               /* LS_PATH_* */
  int threshold;          /* LS_THR_*: the friction threshold frozen in an outer loop, or coupled (T134) */
  double proximal;        /* eps of the proximal term (T136); 0 = automatic */
  int globalization;      /* LS_GLOB_*: the damped level-set loop on the natural map (T140) */
  int smooth_sweeps;      /* hybrid: Gauss-Seidel sweeps at a trap of the damped loop (T144) */
  int smooth_pre;         /* hybrid: sweeps before the first Newton step of a solve */
  double smooth_drop;     /* hybrid: the sweeps at a trap stop at this fraction of the merit */
  double smooth_alpha;    /* hybrid: a step shorter than this is a trap */
  int smooth_path;        /* LS_SMOOTH_*: the sweep on body velocities or on W's rows (T145) */
  int smooth_local;       /* LS_LOCAL_*: each visit's local solve on kept factors, or eliminated (T147) */
  int smooth_order;       /* LS_ORDER_*: sweeps forward only, or forward and backward in turn (T148) */
  int threshold_max, levelset_max, newton_max, proximal_max;
  double threshold_tol, newton_tol, status_tol;
} ls_params;

/* --- the multiplier space -----------------------------------------------------------------------
   lambda_h(p_j) = sum_k A_jk lambda_k (BDZ07 (65) at the collocation points): row j of A holds
   the multipliers whose basis function is non-zero at candidate j, column k the candidates in
   the support of multiplier k (both lists built once by ls_space_build). */
typedef struct {
  int nc, nm;
  int *rp, *ri;     /* rows: candidate j -> entries rp[j] .. rp[j+1]-1 (multiplier ri, value rx) */
  double *rx;
  int *cp, *ci;     /* columns: multiplier k -> candidates ci[cp[k] .. cp[k+1]-1], values cx */
  double *cx;
  int *pair;        /* nm: the pair of each multiplier */
  int *kind;        /* npair: LS_MULT_P1 or LS_MULT_P0 as chosen for the pair */
} ls_space;

int ls_space_build(ls_space *A, const mo_contact *C, int mode, mo_ctx *ctx);
void ls_space_free(ls_space *A);

/* --- the frozen-status system (doc/theory.md (T17)-(T20)) ----------------------------------------
   With the sign fields S_u, S_v, S_f and the friction threshold frozen, the unknowns of one step
   are the impulses r_j of the candidates with S_u = 1 (Cset: the normal impulse vanishes where
   S_v = 0, the friction impulse acts wherever the threshold does, as in BDZ07 (42)), the
   pressures p_k and the friction semi-multipliers Lam_k of the multipliers these candidates
   touch (Mset); U' = W r + q is eliminated through W (Schur path) or kept with the velocity
   correction (KKT path). */
typedef struct {
  /* sizes and layout of y = (r over Cset [nr per candidate], p over Mset, Lam over Mset) */
  int d, dt, nr;          /* local dimension, tangents (d - 1 with friction, else 0), nr = 1 + dt */
  int nC, nM, ny;
  int *cset, *mset;       /* the candidates of Cset, the multipliers of Mset */
  int *cpos, *mpos;       /* nc -> position in Cset or -1; nm -> position in Mset or -1 */
  /* frozen data, per candidate j (full size nc) */
  const unsigned char *su, *sv, *sf;
  const double *pg;       /* friction threshold p^g (pressure) */
  const unsigned char *phi; /* where a friction threshold acts; NULL: where mu p^g > 0 (the
                             threshold loop); the coupled threshold (T134): the closed candidates */
  const double *edir;     /* nc: the coupled sliders' directions e_j set by the damped loop (T140);
                             NULL: sign(Lam + h2_t U'_t) at the iterate */
  const double *w, *mu;
  double c;               /* r = c x force: h (theta) or 1 (quasistatic) */
  double h_n, k_n, k_t, h1_t, h2_t;
  int projected;
  double eps;             /* the proximal term on the diagonal of W (T136), 0 without */
  /* the projection Z on the multiplier space restricted to Cset (nC x nC), NULL = identity */
  double *Z;
  /* the residual F (ny), the Jacobians dF/dy (ny x ny) and dF/dU' (ny x nC nr), row-major,
     and the per-equation magnitude used by the convergence test */
  double *F, *Jy, *JU, *Fmag;
  int jac;                /* Jy and JU allocated and evaluated (ls_system_jacobians) */
  size_t cap_c, cap_cp, cap_m, cap_mp, cap_f, cap_fm, cap_jy, cap_ju; /* capacities kept between setups */
} ls_system;

/* Whether candidate j carries friction in the frozen system. */
static inline int ls_phi(const ls_system *S, int j)
{
  return S->dt && (S->phi ? S->phi[j] != 0 : S->mu[j] > 0 && S->pg[j] > 0);
}

/* The sliding direction e = G / |G| of BDZ07 (42), G = Lam + h2_t U_t, and its derivative
   D = (I - e e^T) / |G| (the generalized Newton step of §5.3; D = 0 in 2D, where e = sign G):
   the same for the frozen-status system (levelset_system.c) and the reduced step
   (levelset_reduced.c). */
static inline void ls_slide_dir(int dt, const double *lam, const double *Ut, double h2, double *e, double *D)
{
  double G[2], g = 0;
  int t, s;
  for (t = 0; t < dt; t++) { G[t] = lam[t] + h2 * Ut[t]; g += G[t] * G[t]; }
  g = sqrt(g);
  for (t = 0; t < dt; t++) e[t] = g > 0 ? G[t] / g : 0;
  for (t = 0; t < dt; t++)
    for (s = 0; s < dt; s++) D[t * dt + s] = g > 0 ? ((t == s) - e[t] * e[s]) / g : 0;
}

/* Set up Cset, Mset and the projection for the frozen statuses (allocating what the sizes
   need); y's layout follows. */
int ls_system_setup(ls_system *S, const ls_space *A, int nc, mo_ctx *ctx);
void ls_system_free(ls_system *S);
/* Allocate the Jacobians Jy and JU for the current sizes; ls_system_eval then fills them (the
   dense paths; the reduced path evaluates the residual alone). */
int ls_system_jacobians(ls_system *S, mo_ctx *ctx);
/* F(y, U') and, after ls_system_jacobians, its Jacobians at y with local velocities U' (nC * nr, Cset order) of magnitudes
   Umag (the size of the terms U' was summed from, for the convergence test). */
void ls_system_eval(ls_system *S, const ls_space *A, const double *y, const double *U,
                    const double *Umag);
/* 1 when every |F_e| <= tol * Fmag_e. */
int ls_system_converged(const ls_system *S, double tol);
/* The pressure lambda_h and friction semi-multiplier Lam_h at candidate j from y (lam: two
   entries, dt of them used); inline: called per candidate in the loops of every solve, where one or
   two candidates made the calls a good part of the work. */
static inline double ls_p_at(const ls_system *S, const ls_space *A, const double *y, int j)
{
  double p = 0;
  int q, off = S->nC * S->nr;
  for (q = A->rp[j]; q < A->rp[j + 1]; q++) {
    int mi = S->mpos[A->ri[q]];
    if (mi >= 0) p += A->rx[q] * y[off + mi];
  }
  return p;
}

static inline void ls_lam_at(const ls_system *S, const ls_space *A, const double *y, int j, double *lam)
{
  int q, t, off = S->nC * S->nr + S->nM;
  lam[0] = lam[1] = 0; /* (two entries: a call of memset for dt of them costs more) */
  for (q = A->rp[j]; q < A->rp[j + 1]; q++) {
    int mi = S->mpos[A->ri[q]];
    if (mi >= 0)
      for (t = 0; t < S->dt; t++) lam[t] += A->rx[q] * y[off + mi * S->dt + t];
  }
}

/* --- linear algebra paths (levelset_linalg.c) ------------------------------------------------- */

struct ls_lu_cache;

/* Dense LU solve of the n x n row-major Newton system J dx = b at iterate y (J overwritten, dx
   into b). A singular J (redundant constraints: two points of an edge resting on an edge leave
   their tangential impulses non-unique) takes the iterate y + dx of smallest norm |D^-1 (y +
   dx)| (LAPACK's least squares, dgelsy), D > 0 the scales of the unknowns. */
int ls_dense_solve(int n, double *J, double *b, const double *y, const double *D, int *ipiv,
                   struct ls_lu_cache *C, mo_ctx *ctx);

/* The LU factors of the last Newton matrix that LU solved (doc/theory.md (T86)): while the
   frozen status, the thresholds and W leave J bit for bit the same (every Newton iterate of a
   frozen status in 2D and without sliding points in 3D; the steps whose statuses repeat), the
   next solve is two triangular solves on these factors, giving what a new factorization would. */
typedef struct ls_lu_cache {
  int n, valid;
  double *key;             /* the matrix factored, row-major as built (n x n) */
  double *lu;              /* the LU factors (LAPACK dgetrf, column-major) of its transpose
                              scaled to unit rows and columns, R^-1 J^T C^-1 */
  double *rs, *cs;         /* the scales R and C */
  int *piv;
  size_t cap;
  long factorizations, reuses; /* over the run: LU or least-squares solves of a new matrix, reuses */
} ls_lu_cache;

/* Solve J dx = b (dx into b) with the cached factors when J is the matrix they factor (*hit =
   1), else leave b untouched (*hit = 0). */
int ls_lu_lookup(ls_lu_cache *C, int n, const double *J, double *b, int *hit, mo_ctx *ctx);
void ls_lu_cache_free(ls_lu_cache *C);

/* Schur path: the local velocities U' = W_CC r + q over Cset and their magnitudes. */
void ls_schur_velocity(const ls_system *S, const double *WCC, const double *q, const double *y,
                       double *U, double *Umag);
/* W restricted to Cset (nC nr x nC nr, row-major; normal and tangent components as in y). */
int ls_schur_wcc(const ls_system *S, const mo_delassus *W, double *WCC);

/* KKT path: the saddle-point system [What, -H_C; dF/dU' H_C^T, dF/dy] assembled over the free
   dofs and y, solved by UMFPACK. */
typedef struct {
  mo_linsolver *ls;
  double *rhs, *sol;
  int cap;
} ls_kkt;

int ls_kkt_step(ls_kkt *K, const ls_system *S, const mo_contact_problem *P, const double *dv,
                const double *y, double *ddv, double *dy, mo_ctx *ctx);
void ls_kkt_free(ls_kkt *K);
/* U' = q + H_C^T dv over Cset (and magnitudes). */
void ls_kkt_velocity(const ls_system *S, const mo_contact_problem *P, const double *dv,
                     double *U, double *Umag);

/* --- the reduced path (levelset_reduced.c, doc/theory.md §6.4.2) ----------------------------------
   With one multiplier per candidate (A = I: P1 at the nodes, node collocation), the frozen system
   (T17)-(T20) splits its local components in three: the constrained ones X (the normal of a closed
   candidate, U'_n = 0; the tangents of a sticking one, U'_t = 0), whose impulses are unknown; the
   sliding candidates S, whose friction impulse is -tau Lam with Lam = G / |G|; and the fixed ones
   (an open normal, a tangent without threshold), whose impulse is 0. A Newton step of the whole
   system is then one solve with W_XX, the principal submatrix of W on X (symmetric, positive
   semi-definite), plus, in 3D, a 2 n_S system for the sliding directions; the pressures and
   semi-multipliers follow from the linear rows (T130). W_XX depends on the set X only: its factor
   is kept across Newton, level-set and threshold iterations and steps while X and W stay (T131).
   With the coupled threshold (2D, T134) a sliding candidate's threshold is its own pressure,
   r_t = -mu e r_n, and the matrix is W_XX + W_XS C_e, factored by LU and kept while X, the sliders
   and their directions e stay. */
enum { LS_RED_NONE = 0, LS_RED_CHOL, LS_RED_PINV, LS_RED_LU, LS_RED_SINGULAR };
enum { LS_CLS_FIXED = 0, LS_CLS_X, LS_CLS_SLIDE };

typedef struct {
  /* the partition of the frozen status (Cset layout: component e = jc nr + i) */
  int nu, nX, nS, coupled;
  unsigned char *cls;      /* nu: LS_CLS_* of each component */
  int *xc, *xg;            /* nX: the constrained components, local (Cset layout) and global (j d + i) */
  int *sc;                 /* nS: the Cset positions of the sliding candidates */
  int *scode;              /* nS: coupled 2D sliders: 3 j + 1 + e, their directions in the key */
  double *es;              /* nS: coupled 2D sliders' directions e */
  /* the kept factor: of Ds W_XX Ds (Ds = diag(W_XX)^-1/2) by Cholesky, or when W_XX is singular
     its eigenvectors and eigenvalues (the weighted minimum-norm solution, T132); coupled: the LU
     of W_XX + W_XS C_e scaled to unit rows (ds) and columns (cs) */
  int kind, nkey, nkeys, rank;
  const mo_delassus *W;
  long version;
  double eps;              /* the proximal term on the factored matrix's diagonal (T136) */
  int *key, *keys;         /* the global components X and the coupled sliders' codes of the factor */
  double *f, *kval, *ds, *cs, *ev; /* kval: the matrix factored, unscaled (the values' key) */
  int *piv;
  /* 3D sliding (threshold loop): Z = W_XX^-1 W_XS and Wred = W_SS - W_SX Z over the sliders'
     tangents, for the slider set zkey of the kept factor */
  int zvalid, nzkey;
  int *zkey;
  double *Z, *Wred;
  /* work (each buffer kept with its capacity) */
  double *up, *bx, *t1, *m2, *wk;
  int *ipiv, *iwk;
  size_t cap_c, cap_f, cap_kv, cap_d, cap_cs, cap_e, cap_w, cap_i, cap_k, cap_ks, cap_pv, cap_z, cap_r, cap_zk,
      cap_m2, cap_p, cap_up, cap_bx, cap_t1;
  long singular;           /* factorizations that found the matrix singular */
  int normal_null;         /* the singular W_XX's null space moves normal impulses */
} ls_reduced;

/* 1 when the multiplier space is one multiplier per candidate with A = I. */
int ls_reduced_applies(const ls_space *A);
/* Split Cset's components for the frozen statuses of S (*ok = 0 when the layout is not A = I);
   coupled: the threshold of a closed candidate is its own pressure (2D only). */
int ls_reduced_classify(ls_reduced *R, const ls_system *S, const ls_space *A, int coupled, int *ok,
                        mo_ctx *ctx);
/* One Newton step of (T17)-(T20) on the partition of ls_reduced_classify, from the iterate y with
   local velocities U = W_CC r + q (Cset layout) and W_CC dense (nu x nu, row-major): y is replaced
   by the next iterate, and with the coupled threshold pg (the state's thresholds) takes the new
   pressures of the candidates with friction. *fallback (y untouched): 1 when the reduced matrix
   is singular and sliders couple to it (the dense path then takes the step), 2 when the
   impulses are not unique and the proximal term (T136) is off. Counts a factorization or a reuse
   of the kept factor. */
int ls_reduced_step(ls_reduced *R, const ls_system *S, const mo_delassus *W, const double *WCC,
                    const double *U, double *y, double *pg, long *nfact, long *nreuse, int *fallback,
                    mo_ctx *ctx);
void ls_reduced_free(ls_reduced *R);
/* The kept factor for a matrix its caller assembles (the sparse path's dense sets, T137a): *A is
   room for the n x n matrix of the current partition (column-major, unscaled: W_XX, plus W_XS C_e
   in the coupled sliders' normal columns, their codes in scode); ls_reduced_factor keeps the factor
   when the key (X, the sliders' codes) and the values are those factored (*fresh = 0), else factors
   it as ls_reduced_step does (Cholesky of the equilibrated matrix or its eigen-decomposition when
   singular, LU when coupled: kind); ls_reduced_solve replaces b = -U'_X by the step dr_X (the
   impulses of smallest weighted norm for a singular W_XX, from the iterate y). */
int ls_reduced_matrix(ls_reduced *R, int nks, double **A, mo_ctx *ctx);
/* 1 when the kept factor is that of the current partition's matrix without looking at it: the
   same key, W of the same version and the same proximal term (T162). */
int ls_reduced_kept(const ls_reduced *R, const ls_system *S, const mo_delassus *W, int nks);
int ls_reduced_factor(ls_reduced *R, const ls_system *S, const mo_delassus *W, int nks, int *fresh, mo_ctx *ctx);
int ls_reduced_solve(ls_reduced *R, const ls_system *S, const double *y, double *b, mo_ctx *ctx);
/* The pressures, thresholds (coupled: p^g = p where friction acts) and semi-multipliers of the new
   iterate y from its impulses, by the linear rows of (T17)-(T20); U over Cset at the new iterate
   (read only with k_n or k_t). */
void ls_reduced_multipliers(const ls_reduced *R, const ls_system *S, const double *U, double *y, double *pg);

/* The reduced path on contact sets of more than LS_DENSE_MAX components (levelset_sparse.c, T137):
   no dense W_CC; products from W's block rows, the frozen status's matrix sparse, factored by
   CHOLMOD or UMFPACK and kept while it repeats (pattern and values). */
#define LS_DENSE_MAX 400
/* The frozen status's matrix on the sparse path is assembled dense and factored as the reduced
   path's (ls_reduced_factor: LAPACK's Cholesky, LU with coupled sliders) when its fill nnz / n^2 is
   at least this (T137a): W_XX of a box pressed on a plane is dense, where CHOLMOD's supernodes run
   at a fraction of LAPACK's rate. */
#define LS_DENSE_FILL 0.3
/* LS_DENSE_MAX, or MOREAU_LEVELSET_DENSE_MAX from the environment (tests force the sparse path
   on small sets with it) */
int ls_dense_max(void);
/* LS_DENSE_FILL, or MOREAU_LEVELSET_DENSE_FILL (0: LAPACK always, above 1: never) */
double ls_dense_fill(void);
typedef struct {
  mo_linsolver *chol, *umf;
  mo_csc *M;               /* the matrix factored (kept: UMFPACK reads it, and it is the key) */
  int kind;                /* 1: UMFPACK (coupled sliders), 0: CHOLMOD */
  int dense;               /* 1: this step solves with the reduced path's kept factor (dense by fill) */
  int *pos;                /* Cset component -> position in X, or -1 */
  double *x;               /* work: U' and the right-hand side */
  size_t cap;
} ls_sparse;

/* U' = W_CC y + b over Cset and the magnitudes of its terms (eps D on the diagonal, T136). */
void ls_sparse_velocity(const ls_system *S, const mo_delassus *W, const double *b, double eps,
                        const double *dW, const double *y, double *U, double *Umag);
/* ls_reduced_step on the sparse path; *fallback: 1 when the status needs dense algebra (3D
   sliding directions, the 2D threshold loop's sliders), 2 when the matrix is singular. */
int ls_sparse_step(ls_sparse *Z, ls_reduced *R, const ls_system *S, const mo_delassus *W, double eps,
                   const double *dW, const double *b, const double *U, double *y, double *pg, long *nfact,
                   long *nreuse, int *fallback, mo_ctx *ctx);
void ls_sparse_free(ls_sparse *Z);

/* --- the smoother's sweep on body velocities (levelset_bodies.c, doc/theory.md (T145)) ------------
   Where every candidate joins rigid bodies and obstacles (H's columns on rigid blocks only, at most
   two a candidate): per candidate its sides (block, G = H's rows on the block's dofs, What_k^-1 G^T)
   and v = What^-1 H r, so that U'_j = H_j^T v + q_j costs O(1). */
#define LS_BODY_NK 6        /* the stride of a side's rows: a rigid block has at most 6 dofs */
typedef struct {
  int ok;                  /* the last build applies: every candidate rigid */
  int *nsd, *blk;          /* per candidate: its sides (0..2) and their blocks (2 per candidate) */
  int *so;                 /* per side: the block's first free dof (its place in v) */
  unsigned char *snk;      /* per side: the block's free dofs */
  double *G, *MG;          /* per side: G (d x 6, stride 6) and What_k^-1 G^T (nk x d) */
  double *v;               /* nfree: What^-1 H r */
  size_t cap, vcap;
} ls_bodies;

int ls_bodies_build(ls_bodies *B, const mo_contact_problem *P, mo_ctx *ctx);
/* v = What^-1 H r */
void ls_bodies_velocity(ls_bodies *B, const mo_contact_problem *P, const double *r);
void ls_bodies_free(ls_bodies *B);

/* A free rigid block's dofs in a problem of local dimension d (2D 3, 3D 6): the constant sizes of
   the loops below, which then unroll (a block with fixed components takes the generic loop). */
#define LS_BODY_FULL(d) ((d) == 3 ? 6 : (d) == 2 ? 3 : 1)

/* v += What^-1 H_j dr over candidate j's sides (d: a constant at the call) */
static inline void ls_bodies_push(ls_bodies *B, int j, const double *dr, const int d)
{
  int s, k, t;
  for (s = 0; s < B->nsd[j]; s++) {
    const double *MG = B->MG + (size_t)(2 * j + s) * 3 * LS_BODY_NK;
    double *restrict v = B->v + B->so[2 * j + s];
    const int nk = B->snk[2 * j + s];
    if (nk == LS_BODY_FULL(d))
      for (k = 0; k < LS_BODY_FULL(d); k++) {
        double acc = 0;
        for (t = 0; t < d; t++) acc += MG[k * d + t] * dr[t];
        v[k] += acc;
      }
    else
      for (k = 0; k < nk; k++) {
        double acc = 0;
        for (t = 0; t < d; t++) acc += MG[k * d + t] * dr[t];
        v[k] += acc;
      }
  }
}

/* u = H_j^T v (d components) */
static inline void ls_bodies_U(const ls_bodies *B, int j, double *restrict u, const int d)
{
  int s, i, k;
  for (i = 0; i < d; i++) u[i] = 0;
  for (s = 0; s < B->nsd[j]; s++) {
    const double *G = B->G + (size_t)(2 * j + s) * 3 * LS_BODY_NK, *v = B->v + B->so[2 * j + s];
    const int nk = B->snk[2 * j + s];
    if (nk == LS_BODY_FULL(d))
      for (i = 0; i < d; i++)
        for (k = 0; k < LS_BODY_FULL(d); k++) u[i] += G[i * LS_BODY_NK + k] * v[k];
    else
      for (i = 0; i < d; i++)
        for (k = 0; k < nk; k++) u[i] += G[i * LS_BODY_NK + k] * v[k];
  }
}

#endif
