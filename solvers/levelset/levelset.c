/* levelset.c: the levelset contact back end: Ben Dhia and Zammali's Level-Set stabilized
   Lagrangian (BDZ07 §3-5, BDZ04), frictionless and frictional, with the nested loops of BDZ07
   Fig. 2 (doc/theory.md §6). */
#include "config.h"
#include "levelset.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

typedef struct {
  ls_params par;
  int nc, d, m, friction;
  ls_space A;
  ls_system S;
  ls_kkt K;
  /* per candidate: sign fields, threshold, current pressure and semi-multiplier, U' */
  unsigned char *su, *sv, *sf, *nsu, *nsv, *nsf;
  double *pg, *ph, *lam, *U, *Umag, *r;
  /* warm start from the previous step */
  double *ph_prev, *lam_prev;
  int have_prev;
  /* per multiplier: current values (y's p and Lam are gathered from and scattered to these) */
  double *pm, *lm;
  double *gdir;              /* sliding directions at the previous Newton iterate (nc x 2) */
  double *mu;                /* nc: friction coefficients of the step, 0 where no free dof moves
                                the candidate tangentially (W_tt = 0: a candidate on a symmetry
                                axis); its friction impulse would act on nothing, and its
                                sticking equation U'_t = 0 would be an empty row */
  unsigned char *rev;        /* nc: the sliding direction reversed in the last Newton loop */
  double *viol;              /* nc: how far the new solution is beyond a sign's boundary */
  /* work sized by the contact set (grown on demand) */
  double *y, *dy, *D, *WCC, *J, *Uc, *Umc;
  int *ipiv;
  size_t cap_y, cap_u, cap_j, cap_w;
  ls_lu_cache lu;            /* the factors of the last Newton matrix (T86) */
  ls_reduced red;            /* the reduced path's partition and kept factor of W_XX (T130-T133) */
  ls_sparse sp;              /* its sparse algebra on large sets (T137) */
  ls_bodies bd;              /* the smoother's sweep on body velocities (T145) */
  double *wd;                /* nc LS_WD(d): the smoother's diagonal blocks of W + eps D (S_u = 1) and
                                what its local solves keep of them (T147) */
  int bodies;                /* bd applies in this solve */
  int dense_max;             /* ls_dense_max() read once (the environment is the run's) */
  int ro, ro_known;          /* rigid_only() of the contact set ro_cset */
  long ro_cset;
  int rigid;                 /* some candidate joins two rigid bodies (a dynamic pair) */
  int reduced;               /* the reduced path applies (A = I and the path allows it) */
  int want_prox;             /* the automatic proximal term is on (T136) */
  int prox_request;          /* a frozen status met redundant normal impulses without it */
  int coupled;               /* the threshold is coupled in this solve (T134) */
  int glob;                  /* the damped level-set loop on the natural map (T140) in this solve */
  int hybrid;                /* ... with the smoother (T144): asked, or auto on a rigid set (T149) */
  int spre;                  /* the smoother's sweeps before the first Newton step in this solve */
  int lsmax;                 /* the damped loop's most iterations in this solve (levelset_max; T149) */
  double stol;               /* the sign tests' relative tolerance in this solve (status_tol; T149) */
  double *rk, *Uk, *rs, *Us; /* m: the damped loop's iterate and the frozen solution (impulses, U') */
  double *edir;              /* nc x 2: the sliding directions the damped loop freezes */
  int frozen_solve;          /* a frozen-threshold (dense) solve since the last threshold update */
  unsigned char *phi;        /* nc: where friction acts with the coupled threshold (S_v = 1, mu > 0) */
  /* the proximal loop (T136): the local problem (W + eps D, q - eps D r_c) */
  double eps;                /* eps of this solve (0: the problem itself) */
  const double *b;           /* q - eps D r_c (qeff), or P->b */
  double *qeff, *rc, *dW;    /* m: q - eps D r_c, the center r_c, D = the diagonal of W */
  double wcc_eps;            /* the eps WCC holds on its diagonal */
  long wcc_gen;              /* WCC builds */
  long uc_gen;               /* Uc, Umc hold U' at the last Newton iterate with WCC of this build; -1 none */
  int u_partial;             /* L->U holds W r + q only over Cset's components (the rest: full_velocity) */
  const mo_delassus *wcc_W;  /* what WCC holds: W, its version, the contact set (nC, cset) */
  long wcc_version;
  int wcc_nC, wcc_nr, *wcc_cset;
  double *dv, *ddv;          /* KKT path: velocity correction over the free dofs */
  /* status history of the level-set loop (cycling detection) */
  unsigned char *hist;
  int hist_cap;
} ls_state;

/* What one solve carries through its loops: the problem, its path and scales, the sign tests'
   tolerances, and the loop counts. */
typedef struct {
  const mo_contact_problem *P;
  int kkt, end_gap, dt;
  double c, kt, rho_n, rho_t, tol_v, tol_f, scale_v;
  int nls, nnewt, nthr;
  int nsweep;                /* the hybrid's smoother sweeps (T144) */
} ls_pass;

#define LS_PROX_EPS 1e-8      /* the automatic proximal eps (T136) */
/* globalization = "auto" on a pile (friction between rigid bodies, more than LS_DENSE_MAX local
   unknowns): the hybrid, its smoother finishing the steps (smoother_pre when not given) at the sign
   tests' tolerance of nscd's accuracy on the shipped piles (status_tol at least; T149) */
#define LS_PILE_PRE 1000
#define LS_PILE_TOL 1e-3
/* ... and on a smaller rigid frictional set of more than LS_SET_MIN local unknowns (the masonry
   arch: 148), the hybrid with smoother_pre LS_PILE_PRE at status_tol LS_SET_TOL at least, the
   undamped loop of BDZ07 Fig. 2 redoing a step it fails (T149) */
#define LS_SET_MIN 100
#define LS_SET_TRY 20         /* the hybrid's most iterations there before the undamped loop redoes the step */
#define LS_SET_TOL 1e-9       /* status_tol at least there and in a redone step (the collapsing arch) */
/* a candidate's record in the smoother's work L->wd: W_jj + eps D_j (d x d), its inverse (d x d),
   1 / (c w_j), the 2D sliding denominators' inverses 1 / (W_nn -+ mu W_nt) (0: none) and whether
   the inverse exists (T147) */
#define LS_WD(d) (2 * (d) * (d) + 4)

/* --- options ---------------------------------------------------------------------------------- */

#define OFF(f) offsetof(ls_params, f)
static const mo_option_spec ls_options[] = {
  {"multipliers", MO_OPT_ENUM, OFF(multipliers), "auto|p1|p0", NAN, NAN, "\"auto\"",
   "Multiplier space (BDZ07 (65)): auto is P1 at the nodes for node collocation and P0 per slave facet for Gauss collocation (P1 at the Gauss points where P0 would outnumber the slave nodes, doc/theory.md (T195)); p1 at Gauss points interpolates nodal multipliers with the facet's shape functions."},
  {"h_n", MO_OPT_DOUBLE, OFF(h_n), NULL, 0, NAN, "0 (automatic)",
   "h_n of BDZ07 (27), (67), in pressure per unit of U'; 0 takes the contact stiffness 1/(c w W_nn) averaged over the candidates (doc/theory.md (T16))."},
  {"rho_n", MO_OPT_DOUBLE, OFF(rho_n), NULL, 0, NAN, "0 (automatic)",
   "rho_n of the sign field S_v, BDZ07 (29) (or S of (15) for position-level and quasi-static steps); 0 is automatic as for h_n."},
  {"k_n", MO_OPT_DOUBLE, OFF(k_n), NULL, 0, NAN, "0",
   "Stabilization k_n of BDZ07 (37) (0: the Lagrangian formulation; k_n = h_n = rho_n: the augmented one)."},
  {"stabilization", MO_OPT_ENUM, OFF(stabilization), "projected|unprojected", NAN, NAN, "\"projected\"",
   "k_n term projected on the multiplier space over the contact set (BDZ07 Remark 4), or taken pointwise (inconsistent when the spaces differ: kept to show the perturbation, BDZ07 §6.4)."},
  {"rho_t", MO_OPT_DOUBLE, OFF(rho_t), NULL, 0, NAN, "0 (automatic)",
   "rho_tau of the friction sign field S_f, BDZ07 (41); 0 takes 1/(c w W_tt mu p) averaged over the contact set."},
  {"h1_t", MO_OPT_DOUBLE, OFF(h1_t), NULL, 0, NAN, "0 (automatic)",
   "h1_tau of BDZ07 (44) (sticking rows; it cancels from the discrete equations, kept for completeness); 0 is rho_t."},
  {"h2_t", MO_OPT_DOUBLE, OFF(h2_t), NULL, 0, NAN, "0 (automatic)",
   "h2_tau of BDZ07 (42), (44): the sliding direction (Lam + h2 [v_t]) / |...|; 0 is rho_t."},
  {"k_t", MO_OPT_DOUBLE, OFF(k_t), NULL, 0, NAN, "0",
   "Tangential stabilization k_tau of BDZ07 (49) on sticking points."},
  {"su", MO_OPT_ENUM, OFF(su), "index_set|end_gap", NAN, NAN, "\"index_set\"",
   "Theta steps at velocity level: S_u from the gap predicted without contact impulse (the core's index set, frozen in the step), or re-evaluated from the end-of-step gap in the level-set loop (BDZ07 (53) literally: it cycles at landing steps)."},
  {"path", MO_OPT_ENUM, OFF(path), "auto|schur|kkt|reduced", NAN, NAN, "\"auto\"",
   "Linear algebra: reduced solves each Newton step on the constrained components only, with the kept factor of W restricted to them (one multiplier per candidate: node collocation; doc/theory.md (T130)); schur solves the whole frozen-status system on the contact set through W (the shared factorization, linear scenes) with a dense LU; kkt assembles the saddle-point system over the free dofs and solves it with UMFPACK; auto is reduced where it applies, else schur."},
  {"threshold", MO_OPT_ENUM, OFF(threshold), "auto|loop|coupled", NAN, NAN, "\"auto\"",
   "Friction threshold p^g: loop freezes it in each frozen-status solve and updates it to the pressure after (the outer loop of BDZ07 Fig. 2); coupled makes every closed candidate's threshold its own pressure inside the frozen system, r_t = -mu r_n e when sliding (the same discrete problem in one pass; 2D, the reduced path; doc/theory.md (T134)); auto is coupled where it applies, else loop."},
  {"proximal", MO_OPT_DOUBLE, OFF(proximal), NULL, 0, 1, "0 (automatic)",
   "Proximal term on the impulses (doc/theory.md (T136)): each pass solves the problem with W + eps D and q - eps D r_c (D the diagonal of W, r_c the previous pass's impulses) until the term falls below newton_tol, so that a frozen status whose impulses are not unique (redundant contacts: piles, masonry) has one solution, the nearest to r_c, and the law holds at the end. 0: eps = 1e-8 where the reduced path finds redundant normal impulses (or a contact set too large for dense algebra between rigid bodies), none elsewhere."},
  {"globalization", MO_OPT_ENUM, OFF(globalization), "auto|none|line_search|hybrid", NAN, NAN, "\"auto\"",
   "The level-set loop on the reduced path with the coupled threshold: line_search moves from the current impulses toward the frozen-status solution by the step that decreases the natural-map residual of the contact law (Armijo backtracking) and takes the sign fields of the point reached (doc/theory.md (T140)-(T143); in 3D with the sliding directions frozen at the iterate); hybrid is line_search with a smoother where it traps: sweeps of projected block Gauss-Seidel on the same law, each candidate's contact law solved exactly against the current impulses of the others (doc/theory.md (T144)); none takes the whole step (BDZ07 Fig. 2); auto is hybrid on piles (every candidate between rigid bodies and obstacles, more than 400 free dofs: its smoother finishing the steps, smoother_pre 1000 unless given, status_tol at least 1e-3, the core's residual of nscd at its tolerance on the shipped piles; doc/theory.md (T149)), on other sets of friction between rigid bodies and obstacles the hybrid above 100 local unknowns (smoother_pre 1000 unless given, status_tol at least 1e-9, at most 20 level-set iterations: the masonry arch) and the undamped loop below, the other of the two redoing a step the first fails at status_tol at least 1e-9, line_search on other 2D sets of more than 400 local unknowns with a candidate between rigid bodies, none elsewhere."},
  {"smoother_sweeps", MO_OPT_INT, OFF(smooth_sweeps), NULL, 1, 100000, "500",
   "Hybrid globalization: the most Gauss-Seidel sweeps over the contact set where the damped loop traps (doc/theory.md (T144))."},
  {"smoother_drop", MO_OPT_DOUBLE, OFF(smooth_drop), NULL, 0, 1, "0.01",
   "Hybrid globalization: the sweeps at a trap stop once the natural-map merit is below this fraction of its value at the trap (0: always smoother_sweeps)."},
  {"smoother_pre", MO_OPT_INT, OFF(smooth_pre), NULL, 0, 100000, "0",
   "Hybrid globalization: Gauss-Seidel sweeps before the first Newton step of every solve."},
  {"smoother_alpha", MO_OPT_DOUBLE, OFF(smooth_alpha), NULL, 0, 1, "0.001",
   "Hybrid globalization: a line-search step shorter than this (or none decreasing the merit) is a trap, where the smoother sweeps instead."},
  {"smoother_path", MO_OPT_ENUM, OFF(smooth_path), "auto|bodies|delassus", NAN, NAN, "\"auto\"",
   "Hybrid globalization: the smoother's sweep through the bodies' velocities (v = What^-1 H r kept up to date candidate by candidate, one local update O(1), as nscd's sweep on bodies) or through W's block rows; bodies needs every candidate between rigid bodies and obstacles; auto is bodies in 3D where every candidate joins rigid bodies and obstacles (sphere-deposit: 0.75 times the CPU time of the sweep on W's rows), delassus otherwise (2D piles: the same within noise; doc/theory.md (T145), (T148))."},
  {"smoother_local", MO_OPT_ENUM, OFF(smooth_local), "kept|elimination", NAN, NAN, "\"kept\"",
   "Hybrid globalization: each candidate's local solve in a sweep on its factors kept for the solve (the inverse of W's diagonal block with the proximal term, the 2D sliding denominators; in 3D Newton's method on the sliding direction's angle) with the change of its impulse as the sweep's stopping cue, or by Gaussian elimination at every visit (in 3D a fixed point on the direction) with the natural map as the cue; the law is tested on the final iterate either way (doc/theory.md (T147))."},
  {"smoother_order", MO_OPT_ENUM, OFF(smooth_order), "forward|alternate", NAN, NAN, "\"forward\"",
   "Hybrid globalization: the sweeps over the candidates forward only, in the candidates' order (nscd's natural order), or forward and backward in turn (symmetric Gauss-Seidel: on the piles measured 1.3 to 1.6 times the sweeps; doc/theory.md (T148))."},
  {"proximal_max", MO_OPT_INT, OFF(proximal_max), NULL, 1, 10000, "50",
   "Proximal loop: iteration limit."},
  {"threshold_max", MO_OPT_INT, OFF(threshold_max), NULL, 1, 100000, "200",
   "Friction-threshold loop: iteration limit."},
  {"threshold_tol", MO_OPT_DOUBLE, OFF(threshold_tol), NULL, 0, 1, "1e-10",
   "Friction-threshold loop: stop when max |p - p_threshold| <= threshold_tol max |p|."},
  {"levelset_max", MO_OPT_INT, OFF(levelset_max), NULL, 1, 100000, "100",
   "Level-set loop: iteration limit (per friction threshold)."},
  {"newton_max", MO_OPT_INT, OFF(newton_max), NULL, 1, 10000, "50",
   "Newton loop: iteration limit (per frozen status)."},
  {"newton_tol", MO_OPT_DOUBLE, OFF(newton_tol), NULL, 0, 1, "1e-10",
   "Newton loop: stop when every equation's residual is below newton_tol times the size of its terms."},
  {"status_tol", MO_OPT_DOUBLE, OFF(status_tol), NULL, 0, 1, "1e-10",
   "Relative tolerance of the sign tests (S_v, S_f), scaled by the problem's largest pressure, friction threshold and U' (doc/theory.md (T88)); a status changes only beyond it, and a solution satisfying the contact law within it ends the level-set loop (T89), so that round-off at a status boundary does not flip a sign."},
};
#undef OFF

static void ls_defaults(void *params)
{
  ls_params *p = params;
  memset(p, 0, sizeof *p);
  p->multipliers = LS_MULT_AUTO;
  p->stabilization = LS_STAB_PROJECTED;
  p->su = LS_SU_INDEX_SET;
  p->path = LS_PATH_AUTO;
  p->threshold_max = 200;
  p->proximal_max = 50;
  p->threshold_tol = 1e-10;
  p->levelset_max = 100;
  p->smooth_sweeps = 500;
  p->smooth_drop = 1e-2;
  p->smooth_pre = 0;
  p->smooth_alpha = 1e-3;
  p->newton_max = 50;
  p->newton_tol = 1e-10;
  p->status_tol = 1e-10;
}

/* --- state -------------------------------------------------------------------------------------- */

static void ls_free(void *state)
{
  ls_state *L = state;
  if (!L) return;
  ls_space_free(&L->A);
  ls_system_free(&L->S);
  ls_kkt_free(&L->K);
  ls_lu_cache_free(&L->lu);
  ls_reduced_free(&L->red);
  ls_sparse_free(&L->sp);
  ls_bodies_free(&L->bd);
  mo_free(L->wd);
  mo_free(L->phi);
  mo_free(L->rk); mo_free(L->Uk); mo_free(L->rs); mo_free(L->Us); mo_free(L->edir);
  mo_free(L->qeff); mo_free(L->rc); mo_free(L->dW);
  mo_free(L->wcc_cset);
  mo_free(L->su); mo_free(L->sv); mo_free(L->sf); mo_free(L->nsu); mo_free(L->nsv); mo_free(L->nsf);
  mo_free(L->pg); mo_free(L->ph); mo_free(L->lam); mo_free(L->U); mo_free(L->Umag); mo_free(L->r);
  mo_free(L->ph_prev); mo_free(L->lam_prev); mo_free(L->pm); mo_free(L->lm);
  mo_free(L->y); mo_free(L->dy); mo_free(L->D); mo_free(L->WCC); mo_free(L->J); mo_free(L->Uc); mo_free(L->Umc);
  mo_free(L->ipiv); mo_free(L->dv); mo_free(L->ddv); mo_free(L->hist); mo_free(L->gdir); mo_free(L->mu); mo_free(L->rev); mo_free(L->viol);
  memset(L, 0, sizeof *L);
}

static int ls_init(void *state, const void *params, const mo_contact_problem *P, mo_ctx *ctx)
{
  ls_state *L = state;
  int nc = P->nc, d = P->dim, m = P->m, j, st;
  size_t n1 = (size_t)nc + 1, nm1;
  L->par = *(const ls_params *)params;
  L->stol = L->par.status_tol;
  L->nc = nc;
  L->d = d;
  L->m = m;
  L->friction = 0;
  L->wcc_nC = -1;
  L->uc_gen = -1;
  L->dense_max = ls_dense_max();
  for (j = 0; j < nc; j++) L->friction |= d > 1 && P->mu[j] > 0;
  if (L->par.path == LS_PATH_KKT && (!P->H || !P->What || P->nfree <= 0))
    return mo_error(ctx, MO_EINTERNAL, "levelset: the kkt path needs the global system (H, What)");
  if ((st = ls_space_build(&L->A, P->contact, L->par.multipliers, ctx))) return st;
  L->reduced = (L->par.path == LS_PATH_AUTO || L->par.path == LS_PATH_REDUCED) && ls_reduced_applies(&L->A);
  if (L->par.path == LS_PATH_REDUCED && !L->reduced)
    return mo_error(ctx, MO_EINPUT, "contact.levelset.path = \"reduced\" needs one multiplier per candidate "
                    "(node collocation); this scene's multipliers are shared by several candidates");
  if (L->par.threshold == LS_THR_COUPLED && !(L->reduced && d == 2))
    return mo_error(ctx, MO_EINPUT, "contact.levelset.threshold = \"coupled\" needs the reduced path (one "
                    "multiplier per candidate) in 2D; %s", d != 2 ? "this scene is not 2D" :
                    "this scene's multipliers are shared by several candidates, or path is not \"auto\" or \"reduced\"");
  for (j = 0; j < nc && !L->rigid; j++)
    L->rigid = mo_contact_pair_get(P->contact, mo_contact_candidate(P->contact, j)->pair)->dynamic;
  if (!(L->phi = mo_calloc(ctx, n1, 1)) || !(L->qeff = mo_calloc(ctx, (size_t)m + 1, sizeof(double))) ||
      !(L->rc = mo_calloc(ctx, (size_t)m + 1, sizeof(double))) || !(L->dW = mo_calloc(ctx, (size_t)m + 1, sizeof(double))))
    return MO_ENOMEM;
  if (!(L->rk = mo_calloc(ctx, (size_t)m + 1, sizeof(double))) || !(L->Uk = mo_calloc(ctx, (size_t)m + 1, sizeof(double))) ||
      !(L->rs = mo_calloc(ctx, (size_t)m + 1, sizeof(double))) || !(L->Us = mo_calloc(ctx, (size_t)m + 1, sizeof(double))) ||
      !(L->edir = mo_calloc(ctx, 2 * n1, sizeof(double))))
    return MO_ENOMEM;
  nm1 = (size_t)L->A.nm + 1;
  L->su = mo_calloc(ctx, n1, 1); L->sv = mo_calloc(ctx, n1, 1); L->sf = mo_calloc(ctx, n1, 1);
  L->nsu = mo_calloc(ctx, n1, 1); L->nsv = mo_calloc(ctx, n1, 1); L->nsf = mo_calloc(ctx, n1, 1);
  L->pg = mo_calloc(ctx, n1, sizeof(double));
  L->ph = mo_calloc(ctx, n1, sizeof(double));
  L->lam = mo_calloc(ctx, 2 * n1, sizeof(double));
  L->ph_prev = mo_calloc(ctx, n1, sizeof(double));
  L->lam_prev = mo_calloc(ctx, 2 * n1, sizeof(double));
  L->U = mo_calloc(ctx, (size_t)m + 1, sizeof(double));
  L->Umag = mo_calloc(ctx, (size_t)m + 1, sizeof(double));
  L->r = mo_calloc(ctx, (size_t)m + 1, sizeof(double));
  L->pm = mo_calloc(ctx, nm1, sizeof(double));
  L->lm = mo_calloc(ctx, 2 * nm1, sizeof(double));
  L->gdir = mo_calloc(ctx, 2 * n1, sizeof(double));
  L->mu = mo_calloc(ctx, n1, sizeof(double));
  L->rev = mo_calloc(ctx, n1, 1);
  L->viol = mo_calloc(ctx, n1, sizeof(double));
  L->wd = mo_calloc(ctx, n1 * (size_t)LS_WD(d), sizeof *L->wd);
  L->dv = mo_calloc(ctx, (size_t)P->nfree + 1, sizeof(double));
  L->ddv = mo_calloc(ctx, (size_t)P->nfree + 1, sizeof(double));
  if (!L->su || !L->sv || !L->sf || !L->nsu || !L->nsv || !L->nsf || !L->pg || !L->ph || !L->lam ||
      !L->ph_prev || !L->lam_prev || !L->U || !L->Umag || !L->r || !L->pm || !L->lm || !L->dv || !L->ddv || !L->gdir || !L->mu || !L->rev || !L->viol || !L->wd)
    return MO_ENOMEM;
  return MO_OK;
}

/* A new contact set (contacts between rigid bodies come and go at most steps): a new state for
   it, keeping what the run has learnt, that its impulses need the proximal term (T136). */
static int ls_reinit(void *state, const mo_contact_problem *P, mo_ctx *ctx)
{
  ls_state *L = state;
  ls_params par = L->par;
  int want = L->want_prox, st;
  ls_free(L);
  memset(L, 0, sizeof *L);
  st = ls_init(L, &par, P, ctx);
  L->want_prox = want;
  return st;
}

/* Grow the work arrays for ny unknowns and nu local velocities; the dense ones (the Newton
   matrix J, ny x ny, and W_CC, nu x nu) only when `dense` asks for them. */
static int ls_reserve(ls_state *L, size_t ny, size_t nu, int dense, mo_ctx *ctx)
{
  double *a;
  int *ip;
  if (ny > L->cap_y) {
    if (!(a = mo_realloc(ctx, L->y, (ny + 1) * sizeof(double)))) return MO_ENOMEM;
    L->y = a;
    if (!(a = mo_realloc(ctx, L->dy, (ny + 1) * sizeof(double)))) return MO_ENOMEM;
    L->dy = a;
    if (!(a = mo_realloc(ctx, L->D, (ny + 1) * sizeof(double)))) return MO_ENOMEM;
    L->D = a;
    if (!(ip = mo_realloc(ctx, L->ipiv, (ny + 1) * sizeof(int)))) return MO_ENOMEM;
    L->ipiv = ip;
    L->cap_y = ny;
  }
  if (nu > L->cap_u) {
    if (!(a = mo_realloc(ctx, L->Uc, (nu + 1) * sizeof(double)))) return MO_ENOMEM;
    L->Uc = a;
    if (!(a = mo_realloc(ctx, L->Umc, (nu + 1) * sizeof(double)))) return MO_ENOMEM;
    L->Umc = a;
    L->cap_u = nu;
  }
  if (dense && ny > L->cap_j) {
    if (!(a = mo_realloc(ctx, L->J, (ny * ny + 1) * sizeof(double)))) return MO_ENOMEM;
    L->J = a;
    L->cap_j = ny;
  }
  if (dense && nu > L->cap_w) {
    if (!(a = mo_realloc(ctx, L->WCC, (nu * nu + 1) * sizeof(double)))) return MO_ENOMEM;
    L->WCC = a;
    L->cap_w = nu;
    L->wcc_nC = -1; /* its contents are gone */
  }
  return MO_OK;
}

/* --- one frozen-status solve: the Newton loop ------------------------------------------------------ */

/* 1 when the sliding direction G = Lam_h + h2_t U'_t of a sliding candidate with friction
   points against its direction at the previous Newton iterate (stored in L->gdir, nc x 2). */
static int slide_reversed(ls_state *L, const double *y, const double *Uc, int first)
{
  ls_system *S = &L->S;
  int jc, t, rev = 0;
  for (jc = 0; jc < S->nC; jc++) {
    int j = S->cset[jc];
    double lam[2], G[2], dot = 0;
    if (!S->dt || S->sf[j] || !ls_phi(S, j)) continue;
    ls_lam_at(S, &L->A, y, j, lam);
    for (t = 0; t < S->dt; t++) {
      G[t] = lam[t] + S->h2_t * Uc[jc * S->nr + 1 + t];
      dot += G[t] * L->gdir[2 * j + t];
    }
    if (!first && dot < 0) rev = L->rev[j] = 1;
    for (t = 0; t < S->dt; t++) L->gdir[2 * j + t] = G[t];
  }
  return rev;
}

/* The scales of the unknowns that choose among the solutions of a singular frozen system (T76):
   the columns of J equilibrated, except the friction impulses r_t and semi-multipliers Lam of
   sticking candidates with their own multiplier, scaled by sqrt(tau) and 1 / sqrt(tau) (tau = c w
   mu p^g): the smallest |D^-1 y| then minimises sum r_t^2 / tau + tau Lam^2, the distribution of
   the friction impulses among redundant points proportional to their thresholds, every point at
   the same mobilization |Lam| (the total's), inside its cone when the total is inside its own. */
static void newton_scales(const ls_state *L, const double *J, double *D)
{
  const ls_system *S = &L->S;
  const ls_space *A = &L->A;
  int ny = S->ny, nr = S->nr, nu = S->nC * nr, k, e, jc, t;
  for (k = 0; k < ny; k++) {
    double c2 = 0;
    for (e = 0; e < ny; e++) c2 += J[(size_t)e * ny + k] * J[(size_t)e * ny + k];
    D[k] = c2 > 0 ? 1 / sqrt(c2) : 1;
  }
  for (jc = 0; S->dt && jc < S->nC; jc++) {
    int j = S->cset[jc], q = A->rp[j], mi;
    double tau = S->c * S->w[j] * S->mu[j] * S->pg[j];
    if (!S->sf[j] || !(tau > 0) || A->rp[j + 1] - q != 1 || A->cp[A->ri[q] + 1] - A->cp[A->ri[q]] != 1) continue;
    if ((mi = S->mpos[A->ri[q]]) < 0) continue;
    for (t = 0; t < S->dt; t++) {
      D[jc * nr + 1 + t] = sqrt(tau);
      D[nu + S->nM + mi * S->dt + t] = 1 / sqrt(tau);
    }
  }
}

static int nonzero(const double *y, int n)
{
  int e;
  for (e = 0; e < n; e++)
    if (y[e] != 0) return 1;
  return 0;
}

/* 1 when y = 0 and F(y) = 0 exactly: the Newton step from there is 0 (whatever J). y first: the
   reduced step evaluates F at its first iterate only where y = 0 (ls_newton). */
static int zero_start(const ls_system *S, const double *y)
{
  int e;
  if (nonzero(y, S->ny)) return 0;
  for (e = 0; e < S->ny; e++)
    if (S->F[e] != 0) return 0;
  return 1;
}

/* 1 when no candidate of Cset is closed (S_v = 0) and y = 0: then F(0) = 0 exactly ((T17)-(T20):
   an open candidate's rows are r = 0 and p / h_n = 0, and without a threshold, p^g = 0 off the
   closed set, Lam = 0). */
static int all_open_at_zero(const ls_system *S, const double *y)
{
  int e;
  for (e = 0; e < S->nC; e++)
    if (S->sv[S->cset[e]]) return 0;
  for (e = 0; e < S->ny; e++)
    if (y[e] != 0) return 0;
  return 1;
}

/* W_CC is rebuilt only when the contact set or W changed since it was built (T86). */
static int wcc_current(const ls_state *L, const mo_delassus *W)
{
  const ls_system *S = &L->S;
  return L->wcc_nC >= 0 && L->wcc_W == W && L->wcc_version == mo_delassus_version(W) && L->wcc_eps == L->eps &&
         L->wcc_nC == S->nC && L->wcc_nr == S->nr &&
         !memcmp(L->wcc_cset, S->cset, (size_t)S->nC * sizeof *S->cset);
}

static int wcc_remember(ls_state *L, const mo_delassus *W, mo_ctx *ctx)
{
  const ls_system *S = &L->S;
  if (!L->wcc_cset && !(L->wcc_cset = mo_malloc(ctx, ((size_t)L->nc + 1) * sizeof *L->wcc_cset)))
    return MO_ENOMEM;
  memcpy(L->wcc_cset, S->cset, (size_t)S->nC * sizeof *L->wcc_cset);
  L->wcc_W = W;
  L->wcc_version = mo_delassus_version(W);
  L->wcc_nC = S->nC;
  L->wcc_nr = S->nr;
  return MO_OK;
}

/* The dense paths freeze the threshold (T17): with the coupled threshold, this solve takes p^g as
   it stands (the pressures of the last iterate, 0 where none is positive), and the threshold loop
   updates it after. */
static void frozen_threshold(ls_state *L)
{
  int j;
  if (!L->coupled || L->S.phi == NULL) return;
  L->S.phi = NULL;
  L->frozen_solve = 1;
  for (j = 0; j < L->nc; j++)
    if (!(L->pg[j] > 0)) L->pg[j] = 0;
}

/* Solve F(y, U') = 0 for the frozen sign fields and threshold (T17)-(T20), by (generalized)
   Newton: U' = W_CC r + q on the Schur path, U' = q + H_C^T dv with What dv = H_C r on the KKT
   path. The system is linear except for the sliding directions: one step, plus the check, unless
   a sliding direction turns. A sliding direction that reverses means that the candidate passes
   through zero slip: the frozen status is wrong, and Newton hands back to the level-set loop
   (in 2D, where G / |G| = sign G has no derivative, it would flip forever). Returns MO_OK with
   *conv = 0 when newton_max is reached or a direction reverses. */
static int ls_newton(ls_state *L, const mo_contact_problem *P, int kkt, int *its, int *conv,
                     mo_ctx *ctx)
{
  ls_system *S = &L->S;
  const ls_space *A = &L->A;
  int ny = S->ny, nu = S->nC * S->nr, it, e, k, col, st, mi, t, hit, reduced;
  /* the sparse path (T137) for sets too large for dense algebra on the reduced path */
  const int sparse = !kkt && L->reduced && nu > L->dense_max;
  *its = 0;
  *conv = 0;
  memset(L->rev, 0, (size_t)L->nc);
  if ((st = ls_reserve(L, (size_t)ny, (size_t)nu, !sparse, ctx))) return st;
  /* start from the previous solution (r, and dv on the KKT path: U' consistent with them), p and
     Lam from the current multipliers: the sliding directions G / |G| start where the last solve
     left them, not at the free slip of r = 0 */
  memset(L->y, 0, (size_t)ny * sizeof(double));
  for (k = 0; k < S->nC; k++)
    for (t = 0; t < S->nr; t++) L->y[k * S->nr + t] = L->r[S->cset[k] * S->d + t];
  for (mi = 0; mi < S->nM; mi++) {
    L->y[nu + mi] = L->pm[S->mset[mi]];
    for (t = 0; t < S->dt; t++) L->y[nu + S->nM + mi * S->dt + t] = L->lm[S->mset[mi] * 2 + t];
  }
  if (!kkt && all_open_at_zero(S, L->y)) {
    /* no closed candidate and y = 0: every equation reads 0 = 0 (r = 0, p / h_n = 0, Lam = 0
       without a threshold); Newton would take the zero step once and stop */
    *its = 1;
    *conv = 1;
    L->uc_gen = -1;
    return MO_OK;
  }
  if (sparse && !(L->eps > 0) && L->rigid) {
    /* contacts between rigid bodies: redundancy the sparse factor cannot tell from round-off
       (no pivot test); the proximal term from the start (T136) */
    L->prox_request = 1;
    return MO_OK;
  }
  if (!kkt && !sparse && !wcc_current(L, P->W)) {
    if ((st = ls_schur_wcc(S, P->W, L->WCC))) return st;
    if (L->eps > 0) /* the proximal term (T136) on the diagonal */
      for (e = 0; e < nu; e++) L->WCC[(size_t)e * nu + e] += L->eps * L->dW[S->cset[e / S->nr] * S->d + e % S->nr];
    if ((st = wcc_remember(L, P->W, ctx))) return st;
    L->wcc_eps = L->eps;
    L->wcc_gen++;
  }
  /* the reduced path (T130) where the multipliers are the candidates' own; the dense Newton
     matrix otherwise, and for a step the reduced path hands back */
  reduced = 0;
  if (!kkt && L->reduced && (st = ls_reduced_classify(&L->red, S, A, L->coupled, &reduced, ctx))) return st;
  if (!reduced) {
    if (nu > LS_DENSE_MAX && !kkt)
      mo_log(ctx, 2, "levelset: dense Newton matrix of %d unknowns (the multipliers are shared: no reduced path)\n", ny);
    if ((st = ls_reserve(L, (size_t)ny, (size_t)nu, 1, ctx)) || (st = ls_system_jacobians(S, ctx))) return st;
    frozen_threshold(L);
  }
  for (it = 0;; it++) {
    /* U' at the iterate: the previous Newton loop ended at this y with this W_CC (Uc kept) */
    if (kkt) ls_kkt_velocity(S, P, L->dv, L->Uc, L->Umc);
    else if (sparse) ls_sparse_velocity(S, P->W, L->b, L->eps, L->dW, L->y, L->Uc, L->Umc);
    else if (it > 0 || L->uc_gen != L->wcc_gen) ls_schur_velocity(S, L->WCC, L->b, L->y, L->Uc, L->Umc);
    if (L->glob && reduced && it > 0) {
      /* the damped loop (T140): the frozen system is linear with the directions frozen, one
         step solves it; the natural map, not (T17)'s direction test, judges the point */
      *conv = 1;
      break;
    }
    /* the reduced step needs F only to test convergence, and to find y = 0 a solution */
    if (!reduced || it > 0 || !nonzero(L->y, ny)) ls_system_eval(S, A, L->y, L->Uc, L->Umc);
    if (it > 0 && ls_system_converged(S, L->par.newton_tol)) { *conv = 1; break; }
    if (it == L->par.newton_max) break;
    if (slide_reversed(L, L->y, L->Uc, it < 2) && it >= 2) break;
    if (it == 0 && !kkt && zero_start(S, L->y)) {
      /* y = 0 solves the frozen system (an all-open step from an open one: r = 0, p = 0,
         Lam = 0): the Newton step J^-1 0 is 0, and the next evaluation would repeat this one */
      (*its)++;
      *conv = 1;
      break;
    }
    if (reduced) {
      int fallback;
      if (sparse)
        st = ls_sparse_step(&L->sp, &L->red, S, P->W, L->eps, L->dW, L->b, L->Uc, L->y, L->pg,
                            &L->lu.factorizations, &L->lu.reuses, &fallback, ctx);
      else
        st = ls_reduced_step(&L->red, S, P->W, L->WCC, L->Uc, L->y, L->pg, &L->lu.factorizations,
                             &L->lu.reuses, &fallback, ctx);
      if (st) return st;
      if (!fallback) {
        (*its)++;
        continue;
      }
      if (fallback == 2 && !(L->eps > 0)) {
        /* redundant normal impulses: the solve starts again with the proximal term (T136) */
        L->prox_request = 1;
        return MO_OK;
      }
      if (sparse)
        return mo_error(ctx, MO_ESINGULAR, "levelset: the frozen status of %d contact unknowns %s; the dense "
                        "Newton matrix it would need is too large (reduced path on sparse algebra, "
                        "doc/theory.md (T137))", nu, fallback == 2 ? "is singular" :
                        "has sliding directions that the sparse path does not solve (3D, or the threshold loop)");
      /* the reduced matrix singular with sliding directions coupled to it: this status on the
         dense path, with the threshold frozen */
      reduced = 0;
      if ((st = ls_reserve(L, (size_t)ny, (size_t)nu, 1, ctx)) || (st = ls_system_jacobians(S, ctx))) return st;
      frozen_threshold(L);
      ls_system_eval(S, A, L->y, L->Uc, L->Umc);
    }
    if (kkt) {
      L->lu.factorizations++; /* UMFPACK factors the saddle-point matrix at every step */
      if ((st = ls_kkt_step(&L->K, S, P, L->dv, L->y, L->ddv, L->dy, ctx))) return st;
      for (k = 0; k < P->nfree; k++) L->dv[k] += L->ddv[k];
    } else {
      /* J = dF/dy + dF/dU' W_CC (U' depends on the impulses, the first nu unknowns) */
      memcpy(L->J, S->Jy, (size_t)ny * (size_t)ny * sizeof(double));
      for (e = 0; e < ny; e++) {
        const double *ju = S->JU + (size_t)e * nu;
        double *jr = L->J + (size_t)e * ny;
        for (k = 0; k < nu; k++) {
          const double *wr;
          if (ju[k] == 0) continue;
          wr = L->WCC + (size_t)k * nu;
          for (col = 0; col < nu; col++) jr[col] += ju[k] * wr[col];
        }
      }
      for (e = 0; e < ny; e++) L->dy[e] = -S->F[e];
      if ((st = ls_lu_lookup(&L->lu, ny, L->J, L->dy, &hit, ctx))) return st;
      if (!hit) {
        newton_scales(L, L->J, L->D);
        if ((st = ls_dense_solve(ny, L->J, L->dy, L->y, L->D, L->ipiv, &L->lu, ctx))) return st;
      }
    }
    for (e = 0; e < ny; e++) L->y[e] += L->dy[e];
    (*its)++;
  }
  L->uc_gen = kkt || sparse ? -1 : L->wcc_gen;
  /* keep the multipliers for the next solve */
  for (mi = 0; mi < S->nM; mi++) {
    L->pm[S->mset[mi]] = L->y[nu + mi];
    for (t = 0; t < S->dt; t++) L->lm[S->mset[mi] * 2 + t] = L->y[nu + S->nM + mi * S->dt + t];
  }
  return MO_OK;
}

/* --- reports ------------------------------------------------------------------------------------------ */

static void describe_candidate(const mo_contact_problem *P, int j, char *buf, size_t n)
{
  const mo_candidate *c = mo_contact_candidate(P->contact, j);
  const mo_contact_pair *pr = mo_contact_pair_get(P->contact, c->pair);
  if (pr->dynamic) snprintf(buf, n, "%d (contact %d of '%s')", j, j - mo_contact_nstatic(P->contact), pr->name);
  else if (c->node >= 0) snprintf(buf, n, "%d (node %d of '%s')", j, c->node, pr->name);
  else snprintf(buf, n, "%d (Gauss point of facet %d of '%s')", j,
                mo_contact_point(P->contact, c->point)->facet, pr->name);
}

/* The candidates whose sign fields differ among the states hist[k0 .. n-1] of a cycle. */
static void report_cycle(const ls_state *L, const mo_contact_problem *P, int k0, int n,
                         mo_contact_report *rep)
{
  int j, k, len, shown = 0, total = 0;
  len = snprintf(rep->message, sizeof rep->message, "the sign fields cycle with period %d at candidate", n - k0);
  for (j = 0; j < L->nc; j++) {
    unsigned diff = 0;
    for (k = k0 + 1; k < n; k++) diff |= L->hist[(size_t)k * L->nc + j] ^ L->hist[(size_t)k0 * L->nc + j];
    if (!diff) continue;
    total++;
    if (len < (int)sizeof rep->message - 96) {
      char who[96];
      describe_candidate(P, j, who, sizeof who);
      len += snprintf(rep->message + len, sizeof rep->message - (size_t)len, "%s %s%s%s%s", shown ? "," : "",
                      who, diff & 1 ? " S_u" : "", diff & 2 ? " S_v" : "", diff & 4 ? " S_f" : "");
      shown++;
    }
  }
  if (total > shown && len < (int)sizeof rep->message - 24)
    snprintf(rep->message + len, sizeof rep->message - (size_t)len, " and %d more", total - shown);
}

/* Keep only the most violated sign change of the proposed update (ns* against s*; the violation
   of each candidate's change is in L->viol): the safeguard against cycling of (T22). */
static void one_sign(ls_state *L)
{
  int j, best = -1;
  for (j = 0; j < L->nc; j++) {
    int changed = L->nsu[j] != L->su[j] || L->nsv[j] != L->sv[j] || L->nsf[j] != L->sf[j];
    if (changed && (best < 0 || L->viol[j] > L->viol[best])) best = j;
  }
  for (j = 0; j < L->nc; j++)
    if (j != best) {
      L->nsu[j] = L->su[j];
      L->nsv[j] = L->sv[j];
      L->nsf[j] = L->sf[j];
    }
}

/* --- the step: geometry -> friction threshold -> level sets -> Newton (BDZ07 Fig. 2) -------------- */

static double safe_inv(double x) { return x > 0 && isfinite(1 / x) ? 1 / x : 0; }

/* The tolerances of the sign tests, from the problem's scales (T88): pressures and rho_n U'_n for
   S_v, in pressure; friction thresholds mu p^g and mu p^g rho_t U'_t for S_f, in pressure too (the
   S_f test of candidate j divides it by its own mu_j p^g_j). U'_n and U'_t enter through their
   magnitudes Umag (the size of the terms they are summed from, the free motion q included), so
   that a velocity that is round-off of the problem's velocities counts as zero. The thresholds
   themselves are known to threshold_tol of the largest pressure (the loop's stopping rule), and
   Lam = r_t / (c w mu p^g) carries that error: it is part of tol_f. */
static void sign_tolerances(const ls_state *L, int d, int dt, double rho_n, double rho_t, double *tol_v,
                            double *tol_f, double *scale_v)
{
  double psc = 0, usc = 0, fsc = 0, vsc = 0;
  int j, t;
  /* (b > a ? b : a is fmax(a, b) for the a here, never NaN: a NaN b is skipped as fmax does, and
     without the call into libm) */
#define LS_MAX(a, b) ((b) > (a) ? (b) : (a))
  for (j = 0; j < L->nc; j++) {
    if (!L->su[j]) continue;
    psc = LS_MAX(psc, fabs(L->ph[j]));
    usc = LS_MAX(usc, L->Umag[j * d]);
    if (dt && L->mu[j] > 0 && L->pg[j] > 0) {
      double f = L->mu[j] * L->pg[j], ut = 0, v;
      for (t = 0; t < dt; t++) ut += L->Umag[j * d + 1 + t] * L->Umag[j * d + 1 + t];
      v = f * sqrt(ut);
      fsc = LS_MAX(fsc, f);
      vsc = LS_MAX(vsc, v);
    }
  }
#undef LS_MAX
  *scale_v = psc + rho_n * usc;
  *tol_v = L->stol * *scale_v;
  *tol_f = L->stol * (fsc + rho_t * vsc) + L->par.threshold_tol * fsc;
}

/* U'_n = W_nn r_n + q_n alone over every candidate, 1 when it applies (T175): without friction (mu
   = 0 on every candidate) and without tangential impulses the sign tests read U'_n and its
   magnitude only (S_v, tol_v; S_f and the tangential scales are not formed, the damped loop and
   the smoother need friction), so that W's normal entries, contiguous (T164), replace a pass over
   every d x d block (9 times the bytes in 3D). The sums are those of mo_delassus_mult in the same
   order (the same bits); the tangential components hold q_t, finite but not W r + q: tangential
   says whether they are needed exact (the outputs when the core does not measure U itself). */
static int normal_velocity(ls_state *L, const mo_contact_problem *P, int tangential)
{
  const int d = L->d, nc = L->nc;
  int j, t, p;
  if (d == 1 || L->friction || tangential || L->eps > 0) return 0;
  for (j = 0; j < L->m; j++)
    if (j % d && L->r[j] != 0) return 0;
  for (j = 0; j < nc; j++) {
    const int *beta;
    const double *wn;
    int n = mo_delassus_row_normal(P->W, j, &beta, &wn);
    double acc = 0;
    if (!wn) return 0; /* (only the first row can find none: W keeps them for every row or none) */
    for (p = 0; p < n; p++) acc += wn[p] * L->r[beta[p] * d];
    L->U[j * d] = acc + L->b[j * d];
    L->Umag[j * d] = fabs(L->b[j * d]) + fabs(L->U[j * d] - L->b[j * d]);
    for (t = 1; t < d; t++) {
      L->U[j * d + t] = L->b[j * d + t];
      L->Umag[j * d + t] = fabs(L->b[j * d + t]);
    }
  }
  L->u_partial = 0;
  return 1;
}

/* U' = W r + q (Schur) or q + H^T dv (KKT) over every candidate, and its magnitudes (without
   friction the normal components alone, normal_velocity, unless tangential). */
static void full_velocity_t(ls_state *L, const mo_contact_problem *P, int kkt, int tangential)
{
  int j, m = L->m;
  if (!kkt && normal_velocity(L, P, tangential)) return;
  memcpy(L->U, L->b, (size_t)m * sizeof(double));
  if (kkt) mo_csc_gatxpy(P->H, 1, L->dv, 1, L->U);
  else {
    for (j = 0; j < m && L->r[j] == 0; j++) continue;
    if (j < m) mo_delassus_mult(P->W, L->r, 1, L->U); /* (r = 0: U' = q) */
    if (L->eps > 0)
      for (j = 0; j < m; j++) L->U[j] += L->eps * L->dW[j] * L->r[j];
  }
  for (j = 0; j < m; j++) L->Umag[j] = fabs(L->b[j]) + fabs(L->U[j] - L->b[j]);
  L->u_partial = 0;
}

static void full_velocity(ls_state *L, const mo_contact_problem *P, int kkt) { full_velocity_t(L, P, kkt, 0); }

/* The proximal term of this solve (T136): eps, D = the diagonal of W, the center r_c = the
   previous impulses, q_eff. With proximal = 0 the term is off unless redundancy asks for it
   (L->want_prox, set by a solve that met redundant normal impulses, and large rigid sets). */
static void proximal_setup(ls_state *L, ls_pass *Q, const mo_contact_vars *x)
{
  const mo_contact_problem *P = Q->P;
  const int nc = L->nc, d = L->d;
  int j, i;
  L->eps = Q->kkt ? 0 : L->par.proximal > 0 ? L->par.proximal : L->want_prox ? LS_PROX_EPS : 0;
  L->S.eps = L->eps;
  L->b = P->b;
  if (!(L->eps > 0)) return;
  for (j = 0; j < nc; j++) {
    const double *Wjj = mo_delassus_block(P->W, j, j);
    for (i = 0; i < d; i++) L->dW[j * d + i] = Wjj ? Wjj[i * d + i] : 0;
  }
  memcpy(L->rc, x->r, (size_t)L->m * sizeof(double));
  L->b = L->qeff;
}

/* rho_t (T16): 1 / (c w W_tt mu p) with the mean threshold over the contact set, and h1_t, h2_t
   (rho_t unless set); kept as it was when no threshold is positive yet. */
static void friction_scales(ls_state *L, double kt, double *rho_t)
{
  double ps = 0, ms = 0;
  int np = 0, j;
  for (j = 0; j < L->nc; j++)
    if (L->pg[j] > 0 && L->mu[j] > 0) { ps += L->pg[j]; ms += L->mu[j]; np++; }
  if (L->par.rho_t > 0) *rho_t = L->par.rho_t;
  else if (np) *rho_t = kt * np / (ms / np * ps);
  else if (!L->coupled) *rho_t = 0;
  L->S.h2_t = L->par.h2_t > 0 ? L->par.h2_t : *rho_t;
  L->S.h1_t = L->par.h1_t > 0 ? L->par.h1_t : *rho_t;
}

/* S_f of candidate j from g = |Lam + rho_t U'_t| with hysteresis (T88): a sticking candidate
   starts to slide only beyond 1 + b, a sliding one sticks only below 1 - b, b the tolerance tol_f
   of the problem's friction scale in units of the candidate's threshold mu p^g (status_tol at
   least, and alone where no threshold acts). */
static int stick_sign(const ls_state *L, int j, double g, int stick, double tol_f)
{
  double f = L->mu[j] * L->pg[j], b = L->stol;
  if (f > 0 && tol_f / f > b) b = tol_f / f;
  return stick ? g <= 1 + b : g < 1 - b;
}

/* The residual of the contact law at the frozen-status solution (T89): for every candidate of
   S_u = 1, the natural map of Signorini min(p_h, rho_n U'_n) in pressure, and where a friction
   threshold acts, mu p^g |Lam - P_B(Lam + rho_t U'_t)| (P_B the projection on the unit ball).
   1 when every one is within the tolerances of the sign tests: the solution satisfies the law
   whatever the signs of round-off say. */
static int law_satisfied(const ls_state *L, const ls_system *S, const ls_space *A, int d, int dt,
                         double rho_n, double rho_t, double tol_v, double tol_f)
{
  int j, t;
  for (j = 0; j < L->nc; j++) {
    double ph = L->ph[j], en;
    if (!L->su[j]) continue;
    en = fabs(fmin(ph, rho_n * L->U[j * d]));
    if (!(en <= tol_v)) return 0;
    if (dt && L->mu[j] > 0 && L->pg[j] > 0) {
      double lam[2], z[2], g = 0, e = 0;
      ls_lam_at(S, A, L->y, j, lam);
      for (t = 0; t < dt; t++) {
        z[t] = lam[t] + rho_t * L->U[j * d + 1 + t];
        g += z[t] * z[t];
      }
      g = sqrt(g);
      for (t = 0; t < dt; t++) {
        double pz = g > 1 ? z[t] / g : z[t];
        e += (lam[t] - pz) * (lam[t] - pz);
      }
      if (!(L->mu[j] * L->pg[j] * sqrt(e) <= tol_f)) return 0;
    }
  }
  return 1;
}

/* The scales of the step (T16): the friction coefficients (0 for a candidate that no free dof
   moves tangentially), the mean contact stiffnesses kn (normal) and kt (tangential), h_n and
   rho_n; and the frozen system's constants. */
static void solve_scales(ls_state *L, ls_pass *Q)
{
  const mo_contact_problem *P = Q->P;
  ls_system *S = &L->S;
  const int nc = L->nc, d = L->d, dt = Q->dt;
  double kn = 0, kt = 0;
  int nkn = 0, nkt = 0, j, t;
  for (j = 0; j < nc; j++) {
    const double *Wjj = mo_delassus_block(P->W, j, j);
    L->mu[j] = P->mu[j];
    if (dt && Wjj) {
      double wtt = 0;
      for (t = 1; t < d; t++) wtt += Wjj[t * d + t];
      if (!(wtt > 1e-12 * Wjj[0])) L->mu[j] = 0;
    }
    if (!P->active[j] || !Wjj) continue;
    kn += safe_inv(Q->c * P->w[j] * Wjj[0]);
    nkn++;
    if (dt) {
      double wt = 0;
      for (t = 1; t < d; t++) wt += Wjj[t * d + t] / (d - 1);
      kt += safe_inv(Q->c * P->w[j] * wt);
      nkt++;
    }
  }
  kn = nkn ? kn / nkn : 1;
  Q->kt = nkt ? kt / nkt : 1;
  Q->rho_n = L->par.rho_n > 0 ? L->par.rho_n : kn;
  memset(S, 0, offsetof(ls_system, cset));
  S->d = d;
  S->dt = dt;
  S->nr = 1 + dt;
  S->su = L->su;
  S->sv = L->sv;
  S->sf = L->sf;
  S->pg = L->pg;
  S->w = P->w;
  S->mu = L->mu;
  S->c = Q->c;
  S->h_n = L->par.h_n > 0 ? L->par.h_n : kn;
  S->k_n = L->par.k_n;
  S->k_t = L->par.k_t;
  S->projected = L->par.stabilization == LS_STAB_PROJECTED;
}

/* The starting state from the previous solve: U'0 = W r_prev + q, the sign fields and thresholds
   of the previous pressures, the multipliers' values (the first Newton loop starts from r_prev on
   the Schur paths, from r = 0, dv = 0 on the KKT path, where dv would have to match it). */
static int warm_start(ls_state *L, ls_pass *Q, const mo_contact_vars *x, mo_ctx *ctx)
{
  const mo_contact_problem *P = Q->P;
  const ls_space *A = &L->A;
  const int nc = L->nc, d = L->d, m = L->m, dt = Q->dt;
  int j, t;
  L->uc_gen = -1;
  L->u_partial = 0;
  memcpy(L->r, x->r, (size_t)m * sizeof(double));
  full_velocity(L, P, 0);
  if (Q->kkt) {
    memset(L->r, 0, (size_t)m * sizeof(double));
    memset(L->dv, 0, (size_t)P->nfree * sizeof(double));
  }
  for (j = 0; j < nc; j++) {
    double p0 = L->have_prev ? L->ph_prev[j] : (P->w[j] > 0 ? x->r[j * d] / (Q->c * P->w[j]) : 0);
    L->ph[j] = p0;
    L->su[j] = P->active[j] != 0;
    L->sv[j] = L->su[j] && p0 - Q->rho_n * L->U[j * d] >= 0;
    L->pg[j] = L->sv[j] && p0 > 0 ? p0 : 0;
    for (t = 0; t < dt; t++) L->lam[j * 2 + t] = L->have_prev ? L->lam_prev[j * 2 + t] : 0;
    L->sf[j] = 1;
  }
  for (j = 0; j < A->nm; j++) {
    int q = A->cp[j];
    L->pm[j] = L->have_prev && q < A->cp[j + 1] ? L->ph_prev[A->ci[q]] : 0;
    L->lm[2 * j] = L->lm[2 * j + 1] = 0;
    if (L->have_prev && q < A->cp[j + 1])
      for (t = 0; t < dt; t++) L->lm[2 * j + t] = L->lam_prev[A->ci[q] * 2 + t];
  }
  if (!L->hist || L->hist_cap < L->par.levelset_max + 1) {
    unsigned char *h = mo_realloc(ctx, L->hist, ((size_t)L->par.levelset_max + 1) * (size_t)nc + 1);
    if (!h) return MO_ENOMEM;
    L->hist = h;
    L->hist_cap = L->par.levelset_max + 1;
  }
  return MO_OK;
}

/* The new sign fields ns* from the frozen solution: (T14), (T15), BDZ07 (69), (70), (48), tested
   against the problem's scales with hysteresis (T88); the violation of each change in viol. */
static void new_signs(ls_state *L, ls_pass *Q)
{
  const mo_contact_problem *P = Q->P;
  const ls_system *S = &L->S;
  const ls_space *A = &L->A;
  const int nc = L->nc, d = L->d, dt = Q->dt;
  int j, t;
  for (j = 0; j < nc; j++) L->ph[j] = L->su[j] ? ls_p_at(S, A, L->y, j) : 0;
  sign_tolerances(L, d, dt, Q->rho_n, Q->rho_t, &Q->tol_v, &Q->tol_f, &Q->scale_v);
  for (j = 0; j < nc; j++) {
    double ph = L->ph[j], s;
    L->nsu[j] = L->su[j];
    L->nsv[j] = L->sv[j];
    L->nsf[j] = L->sf[j];
    L->viol[j] = 0;
    if (Q->end_gap && P->active[j]) {
      double gend = P->g[j] + P->h * (P->theta * L->U[j * d] + (1 - P->theta) * P->Uprev[j * d]);
      L->nsu[j] = gend <= 0;
      if (L->nsu[j] != L->su[j]) L->viol[j] = HUGE_VAL;
    }
    if (!L->su[j]) { L->nsv[j] = 0; continue; }
    /* closed stays closed down to -tol_v, open stays open up to +tol_v */
    s = ph - Q->rho_n * L->U[j * d];
    L->nsv[j] = L->sv[j] ? s >= -Q->tol_v : s > Q->tol_v;
    if (L->nsv[j] != L->sv[j]) L->viol[j] = fmax(L->viol[j], fabs(s) / (Q->scale_v + 1e-300));
    if (dt) {
      double lam[2], g = 0;
      ls_lam_at(S, A, L->y, j, lam);
      for (t = 0; t < dt; t++) {
        double v = lam[t] + Q->rho_t * L->U[j * d + 1 + t];
        L->lam[j * 2 + t] = lam[t];
        g += v * v;
      }
      /* a slip that reversed in the frozen solve went through zero: try sticking */
      if (L->mu[j] > 0) L->nsf[j] = L->rev[j] || stick_sign(L, j, sqrt(g), L->sf[j], Q->tol_f);
      if (L->nsf[j] != L->sf[j]) L->viol[j] = fmax(L->viol[j], L->rev[j] ? 1 : fabs(sqrt(g) - 1));
    }
  }
}

/* The impulses of the frozen solution over every candidate, and U' over Cset (from the Newton
   loop's last U' when it holds them: the sign fields need no more) or over every candidate. */
static void take_solution(ls_state *L, ls_pass *Q)
{
  const mo_contact_problem *P = Q->P;
  const ls_system *S = &L->S;
  const int d = L->d;
  int k, t;
  memset(L->r, 0, (size_t)L->m * sizeof(double));
  for (k = 0; k < S->nC; k++)
    for (t = 0; t < S->nr; t++) L->r[S->cset[k] * d + t] = L->y[k * S->nr + t];
  if (!Q->kkt && !Q->end_gap && L->uc_gen == L->wcc_gen) {
    for (k = 0; k < S->nC; k++)
      for (t = 0; t < S->nr; t++) {
        int i = S->cset[k] * d + t;
        L->U[i] = L->Uc[k * S->nr + t];
        L->Umag[i] = fabs(L->b[i]) + fabs(L->U[i] - L->b[i]);
      }
    L->u_partial = 1;
  } else
    full_velocity(L, P, Q->kkt);
}

/* Report a breakdown of the frozen system (singular, non-finite) as the solve's reason. */
static void report_breakdown(int st, mo_contact_report *rep, mo_ctx *ctx)
{
  size_t len = strlen(ctx->errmsg);
  if (len >= sizeof rep->message) len = sizeof rep->message - 1;
  memcpy(rep->message, ctx->errmsg, len);
  rep->message[len] = '\0';
  mo_ctx_clear_error(ctx);
  rep->reason = st == MO_ENAN ? MO_CR_NAN : MO_CR_BREAKDOWN;
}

/* The level-set loop (BDZ07 Fig. 2): solve the frozen system by Newton, update the sign fields,
   until they repeat (T22: cycling detected and reported; T89: a solution that satisfies the law
   ends it). rep->reason < 0 on failure; MO_ESINGULAR / MO_ENAN become reasons too. */
/* One frozen-status solve: the system of the current statuses, its Newton iterations (the frozen
   sliding directions of the damped loop released after them) and the solution taken. *done = 1
   when the pass ends here: a proximal term requested, or a breakdown of the frozen system
   (singular, non-finite), reported as the solve's reason rather than an error of the run. */
static int frozen_solve(ls_state *L, ls_pass *Q, int *its, int *conv, int *done, mo_contact_report *rep,
                        mo_ctx *ctx)
{
  int st;
  *done = 1;
  if ((st = ls_system_setup(&L->S, &L->A, L->nc, ctx))) return st;
  st = ls_newton(L, Q->P, Q->kkt, its, conv, ctx);
  L->S.edir = NULL;
  Q->nnewt += *its;
  Q->nls++;
  if (L->prox_request) return MO_OK;
  if (st == MO_ESINGULAR || st == MO_ENAN) {
    report_breakdown(st, rep, ctx);
    return MO_OK;
  }
  if (st) return st;
  take_solution(L, Q);
  *done = 0;
  return MO_OK;
}

static int level_set_loop(ls_state *L, ls_pass *Q, mo_contact_report *rep, mo_ctx *ctx)
{
  const mo_contact_problem *P = Q->P;
  ls_system *S = &L->S;
  const ls_space *A = &L->A;
  const int nc = L->nc, d = L->d, dt = Q->dt;
  int lsit, nhist, safe = 0, j, conv, st;
  for (j = 0; j < nc; j++) L->hist[j] = (unsigned char)(L->su[j] | L->sv[j] << 1 | L->sf[j] << 2);
  nhist = 1;
  for (lsit = 0;; lsit++) {
    int its, done, same = 1, k0 = -1, k;
    S->phi = NULL;
    if (L->coupled) {
      /* friction acts on the closed candidates, with their own pressure as threshold */
      for (j = 0; j < nc; j++) L->phi[j] = L->sv[j] && L->mu[j] > 0;
      S->phi = L->phi;
      if (lsit > 0) friction_scales(L, Q->kt, &Q->rho_t);
    }
    if ((st = frozen_solve(L, Q, &its, &conv, &done, rep, ctx)) || done) return st;
    new_signs(L, Q);
    for (j = 0; j < nc; j++)
      same &= L->nsu[j] == L->su[j] && L->nsv[j] == L->sv[j] && L->nsf[j] == L->sf[j];
    if (!same && conv && !memcmp(L->nsu, L->su, (size_t)nc) &&
        law_satisfied(L, S, A, d, dt, Q->rho_n, Q->rho_t, Q->tol_v, Q->tol_f)) {
      /* (T89): the frozen solution satisfies the contact law to the tolerances of the sign
         tests; the signs that would change sit on their boundaries at round-off */
      mo_log(ctx, 3, "levelset step %ld: the contact law holds to its tolerances; sign changes at "
             "round-off ignored\n", P->step);
      memcpy(L->nsv, L->sv, (size_t)nc);
      memcpy(L->nsf, L->sf, (size_t)nc);
      same = 1;
    }
    if (same && !conv) {
      /* Newton failed on a status that the signs confirm: nothing left to change */
      rep->reason = MO_CR_MAXITER;
      snprintf(rep->message, sizeof rep->message, "the Newton loop did not converge in %d iterations "
               "on a frozen status that the sign fields confirm (newton_max = %d)", its, L->par.newton_max);
      return MO_OK;
    }
    if (same) return MO_OK;
    if (safe) one_sign(L);
    /* cycling: the new state was visited before (T22) */
    for (j = 0; j < nc; j++) L->hist[(size_t)nhist * nc + j] = (unsigned char)(L->nsu[j] | L->nsv[j] << 1 | L->nsf[j] << 2);
    for (k = 0; k < nhist - 1 && k0 < 0; k++)
      if (!memcmp(L->hist + (size_t)k * nc, L->hist + (size_t)nhist * nc, (size_t)nc)) k0 = k;
    if (k0 >= 0 && !safe) {
      /* changing every sign at once can cycle where the solution changes some of them only
         (two coupled candidates at a stick/slip boundary): from the current state, change
         one sign per iteration, the most violated, and call it cycling only if that cycles */
      safe = 1;
      memmove(L->hist, L->hist + (size_t)(nhist - 1) * nc, (size_t)nc);
      nhist = 1;
      one_sign(L);
      for (j = 0; j < nc; j++) L->hist[(size_t)nc + j] = (unsigned char)(L->nsu[j] | L->nsv[j] << 1 | L->nsf[j] << 2);
      k0 = -1;
    }
    if (k0 >= 0) {
      rep->reason = MO_CR_CYCLING;
      report_cycle(L, P, k0, nhist, rep);
      return MO_OK;
    }
    if (lsit + 1 >= L->par.levelset_max) {
      rep->reason = MO_CR_MAXITER;
      snprintf(rep->message, sizeof rep->message, "the level-set loop reached levelset_max = %d",
               L->par.levelset_max);
      return MO_OK;
    }
    nhist++;
    memcpy(L->su, L->nsu, (size_t)nc);
    memcpy(L->sv, L->nsv, (size_t)nc);
    memcpy(L->sf, L->nsf, (size_t)nc);
  }
}

/* --- the damped level-set loop (T140)-(T143) ------------------------------------------------------- */

/* The natural map of the contact law at candidate j (pressure units, T140), from its impulse rj
   and U'_j: with p = r_n / (c w), s = -r_t / (c w) (= mu p Lam), a = p - rho_n U'_n and
   z = s + k_t U'_t,
     F_n = p - max(0, a),   F_t = s - P_B(mu a+)(z)   (B(t): the disk of radius t);
   *ft is |F_t|, *a and z (dt components, *zn = |z|) are what the sign fields test (T141). */
static inline __attribute__((always_inline)) void natural_map(const ls_state *L, const ls_pass *Q, int j,
                                                               const double *rj, const double *Uj, double *fn,
                                                               double *ft, double *a, double *z, double *zn)
{
  const double cw = Q->c * Q->P->w[j], p = rj[0] / cw;
  double ap;
  int t;
  *a = p - Q->rho_n * Uj[0];
  ap = *a > 0 ? *a : 0; /* max(0, a), 0 for a NaN as fmax gives */
  *fn = p - ap;
  *ft = *zn = 0;
  z[0] = z[1] = 0;
  if (Q->dt && L->mu[j] > 0) {
    double thr = L->mu[j] * ap, f = 0, sc;
    for (t = 0; t < Q->dt; t++) {
      z[t] = -rj[1 + t] / cw + Q->kt * Uj[1 + t];
      *zn += z[t] * z[t];
    }
    *zn = sqrt(*zn);
    sc = *zn > thr ? thr / *zn : 1;
    for (t = 0; t < Q->dt; t++) {
      double ft_t = -rj[1 + t] / cw - sc * z[t];
      f += ft_t * ft_t;
    }
    *ft = sqrt(f);
  }
}

/* The merit sum_j F_n,j^2 + F_t,j^2 over S_u = 1 at r = rk + alpha (rs - rk), U' = Uk + alpha (Us -
   Uk) (U' is affine in r); with `take`, that point becomes the iterate L->r, L->U. */
static double merit_at(ls_state *L, const ls_pass *Q, double alpha, int take)
{
  const int nc = L->nc, d = L->d;
  double m = 0, fn, ft, a, z[2], zn, r[3], U[3];
  int j, t;
  for (j = 0; j < nc; j++) {
    if (!L->su[j]) continue;
    for (t = 0; t < d; t++) {
      int i = j * d + t;
      r[t] = L->rk[i] + alpha * (L->rs[i] - L->rk[i]);
      U[t] = L->Uk[i] + alpha * (L->Us[i] - L->Uk[i]);
      if (take) {
        L->r[i] = r[t];
        L->U[i] = U[t];
        L->Umag[i] = fabs(L->b[i]) + fabs(U[t] - L->b[i]);
      }
    }
    natural_map(L, Q, j, r, U, &fn, &ft, &a, z, &zn);
    m += fn * fn + ft * ft;
  }
  return m;
}

/* The sign fields of the iterate (L->r, L->U) from its natural map (T141), with the bands of (T88)
   (a status changes only beyond tol_v, tol_f), the frozen sliding directions e = z / |z|, the
   pressures, semi-multipliers and coupled thresholds that the frozen system and the outputs read;
   returns the largest residual in units of its tolerance (<= 1: the law holds, T142). */
static double damped_signs(ls_state *L, ls_pass *Q)
{
  const ls_space *A = &L->A;
  const int nc = L->nc, d = L->d, dt = Q->dt;
  double emax = 0;
  int j, t;
  for (j = 0; j < nc; j++) L->ph[j] = L->su[j] ? L->r[j * d] / (Q->c * Q->P->w[j]) : 0;
  sign_tolerances(L, d, dt, Q->rho_n, Q->rho_t, &Q->tol_v, &Q->tol_f, &Q->scale_v);
  for (j = 0; j < nc; j++) {
    double fn, ft, a, z[2], zn, p = L->ph[j];
    int q = A->rp[j], mi = A->ri[q];
    L->pm[mi] = p;
    L->lm[2 * mi] = L->lm[2 * mi + 1] = 0;
    if (!L->su[j]) { L->sv[j] = 0; continue; }
    natural_map(L, Q, j, L->r + j * d, L->U + j * d, &fn, &ft, &a, z, &zn);
    emax = fmax(emax, fabs(fn) / (Q->tol_v + 1e-300));
    L->sv[j] = L->sv[j] ? a >= -Q->tol_v : a > Q->tol_v;
    if (!dt) continue;
    emax = fmax(emax, fabs(ft) / (Q->tol_f + 1e-300));
    L->pg[j] = L->sv[j] && p > 0 ? p : 0;
    if (L->mu[j] > 0) {
      double thr = L->mu[j] * fmax(0, a);
      L->sf[j] = L->sf[j] ? zn <= thr + Q->tol_f : zn < thr - Q->tol_f;
      for (t = 0; t < dt; t++) {
        double s = -L->r[j * d + 1 + t] / (Q->c * Q->P->w[j]);
        L->edir[2 * j + t] = zn > 0 ? z[t] / zn : 0;
        L->lam[j * 2 + t] = p > 0 ? s / (L->mu[j] * p) : 0;
        L->lm[2 * mi + t] = L->lam[j * 2 + t];
      }
    }
  }
  return emax;
}

/* --- the hybrid's smoother: projected block Gauss-Seidel on the same law (T144) -------------------- */

/* Solve the n x n system A x = b (n <= 3) by Gaussian elimination with partial pivoting; A and b
   are overwritten. Returns 0 when a pivot vanishes. */
static inline __attribute__((always_inline)) int small_solve(int n, double *A, double *b)
{
  int i, k, c;
  for (k = 0; k < n; k++) {
    int piv = k;
    for (i = k + 1; i < n; i++)
      if (fabs(A[i * n + k]) > fabs(A[piv * n + k])) piv = i;
    if (!(fabs(A[piv * n + k]) > 0)) return 0;
    if (piv != k) {
      double t;
      for (c = 0; c < n; c++) t = A[k * n + c], A[k * n + c] = A[piv * n + c], A[piv * n + c] = t;
      t = b[k], b[k] = b[piv], b[piv] = t;
    }
    for (i = k + 1; i < n; i++) {
      double f = A[i * n + k] / A[k * n + k];
      for (c = k; c < n; c++) A[i * n + c] -= f * A[k * n + c];
      b[i] -= f * b[k];
    }
  }
  for (k = n - 1; k >= 0; k--) {
    for (c = k + 1; c < n; c++) b[k] -= A[k * n + c] * b[c];
    b[k] /= A[k * n + k];
  }
  return 1;
}

/* A sliding solution of one candidate's law: r_t = -mu r_n e, U'_n = f_n + (W_nn - mu W_nt e) r_n
   = 0 with r_n > 0 and U'_t = f_t + W_tn r_n + W_tt r_t along e (2D: e = +-1 as given; 3D: e found
   by a damped fixed point from the given one). Returns 1 with r set when one is found. */
static int local_slide(int d, const double *Wl, const double *f, double mu, double *e, double *r)
{
  const int dt = d - 1;
  int it, t, k;
  for (it = 0; it < (dt == 1 ? 1 : 60); it++) {
    double den = Wl[0], ut[2], un = 0, en[2], diff = 0;
    for (t = 0; t < dt; t++) den -= mu * Wl[1 + t] * e[t];
    if (!(den > 0)) return 0;
    r[0] = -f[0] / den;
    for (t = 0; t < dt; t++) r[1 + t] = -mu * r[0] * e[t];
    for (t = 0; t < dt; t++) {
      ut[t] = f[1 + t];
      for (k = 0; k < d; k++) ut[t] += Wl[(1 + t) * d + k] * r[k];
      un += ut[t] * ut[t];
    }
    un = sqrt(un);
    if (dt == 1) return ut[0] * e[0] >= 0;
    if (!(un > 0)) return 1;
    for (t = 0; t < dt; t++) {
      en[t] = ut[t] / un;
      diff = fmax(diff, fabs(en[t] - e[t]));
    }
    if (diff < 1e-12) return 1;
    /* e <- the normalized mean of e and the direction of the slip it gives */
    un = 0;
    for (t = 0; t < dt; t++) {
      e[t] = 0.5 * (e[t] + en[t]);
      un += e[t] * e[t];
    }
    if (!(un > 0)) return 0;
    for (t = 0; t < dt; t++) e[t] /= sqrt(un);
  }
  return r[0] > 0;
}

/* One candidate's contact law (closed: r_n >= 0, U'_n >= 0, r_n U'_n = 0; Coulomb's with the
   threshold mu r_n: sticking U'_t = 0 inside the cone, sliding r_t = -mu r_n U'_t / |U'_t|) solved
   exactly for its impulse r (d components) with U'_j = f + Wl r, the others' impulses fixed: the
   zero of the natural map (T140) of this candidate alone. Open where f_n >= 0, else sticking when
   Wl r = -f lies in the cone, else sliding. Returns 0 (r untouched) when none is found. */
static inline __attribute__((always_inline)) int local_law(int d, const double *Wl, const double *f, double mu,
                                                            double *r)
{
  double A[9], b[3] = {0, 0, 0}, e[2] = {0, 0}, x[3] = {0, 0, 0}, tn = 0;
  int i, t;
  if (f[0] >= 0) {
    for (i = 0; i < d; i++) r[i] = 0;
    return 1;
  }
  if (!(mu > 0) || d == 1) {
    if (!(Wl[0] > 0)) return 0;
    r[0] = -f[0] / Wl[0];
    for (i = 1; i < d; i++) r[i] = 0;
    return 1;
  }
  memcpy(A, Wl, (size_t)(d * d) * sizeof(double));
  for (i = 0; i < d; i++) b[i] = -f[i];
  if (small_solve(d, A, b)) {
    for (t = 1; t < d; t++) tn += b[t] * b[t];
    tn = sqrt(tn);
    if (b[0] >= 0 && tn <= mu * b[0]) {
      memcpy(r, b, (size_t)d * sizeof(double));
      return 1;
    }
  }
  /* sliding: against the sticking impulse's tangent where it exists, the free slip's otherwise */
  for (t = 1; t < d; t++) e[t - 1] = tn > 0 ? -b[t] / tn : f[t];
  if (!(tn > 0)) {
    double n = d == 2 ? fabs(e[0]) : hypot(e[0], e[1]);
    if (!(n > 0)) return 0;
    for (t = 0; t < d - 1; t++) e[t] /= n;
  }
  if (local_slide(d, Wl, f, mu, e, x)) {
    memcpy(r, x, (size_t)d * sizeof(double));
    return 1;
  }
  if (d == 2) {
    e[0] = -e[0];
    if (local_slide(d, Wl, f, mu, e, x)) {
      memcpy(r, x, (size_t)d * sizeof(double));
      return 1;
    }
  }
  return 0;
}

/* --- the kept local solve (T147): each candidate's factors once per smoother call ----------------- */

/* A 3D sliding solution by Newton's method on the direction's angle th, e = (cos th, sin th):
   r_n(th) = -f_n / (W_nn - mu W_nt e), r_t = -mu r_n e, U'_t(th) = f_t + W_tn r_n + W_tt r_t; the
   root of g(th) = e_perp . U'_t with e . U'_t > 0 (the slip along e), from the given e. Returns 1
   with r set on convergence (|g| <= 1e-12 |U'_t|), 0 otherwise (the caller falls back to the
   fixed point of local_slide). */
static int slide_newton(const double *W, const double *f, double mu, const double *e0, double *e, double *r)
{
  double th = atan2(e0[1], e0[0]);
  int it;
  for (it = 0; it < 20; it++) {
    const double c = cos(th), s = sin(th);
    const double den = W[0] - mu * (W[1] * c + W[2] * s), dden = -mu * (-W[1] * s + W[2] * c);
    double rn, drn, rt[2], drt[2], ut[2], dut[2], g, h, dg, step;
    int t;
    if (!(den > 0)) return 0;
    rn = -f[0] / den;
    drn = -rn * dden / den;
    rt[0] = -mu * rn * c, rt[1] = -mu * rn * s;
    drt[0] = -mu * (drn * c - rn * s), drt[1] = -mu * (drn * s + rn * c);
    for (t = 0; t < 2; t++) {
      const double *Wt = W + (1 + t) * 3;
      ut[t] = f[1 + t] + Wt[0] * rn + Wt[1] * rt[0] + Wt[2] * rt[1];
      dut[t] = Wt[0] * drn + Wt[1] * drt[0] + Wt[2] * drt[1];
    }
    g = -s * ut[0] + c * ut[1];
    h = c * ut[0] + s * ut[1];
    if (fabs(g) <= 1e-12 * hypot(ut[0], ut[1])) {
      if (!(h > 0) || !(rn > 0)) return 0;
      r[0] = rn, r[1] = rt[0], r[2] = rt[1];
      e[0] = c, e[1] = s;
      return 1;
    }
    dg = -h + (-s * dut[0] + c * dut[1]);
    if (!(fabs(dg) > 0)) return 0;
    step = g / dg;
    if (!isfinite(step)) return 0;
    th -= fmax(-0.5, fmin(0.5, step)); /* at most half a radian a step */
  }
  return 0;
}

/* One candidate's contact law, as local_law, on the factors kept in its record K (LS_WD(d): W_jj,
   its inverse, 1 / (c w), the 2D sliding denominators' inverses, whether the inverse exists): the
   sticking trial r = -W_jj^-1 f, the 2D slide in closed form for e = +-1, the 3D slide by Newton's
   method on the direction (slide_newton; the fixed point of local_slide where it does not end).
   The same zero as local_law (to round-off where both find one). */
static inline __attribute__((always_inline)) int local_law_kept(const int d, const double *K, const double *f,
                                                                 double mu, double *r)
{
  const double *Wl = K, *Wi = K + d * d, *aux = K + 2 * d * d;
  double b[3], tn2 = 0, e[2], e0[2], x[3];
  int i, k, t;
  if (f[0] >= 0) {
    for (i = 0; i < d; i++) r[i] = 0;
    return 1;
  }
  if (!(mu > 0) || d == 1 || aux[3] == 0) return local_law(d, Wl, f, mu, r);
  for (i = 0; i < d; i++) {
    double acc = 0;
    for (k = 0; k < d; k++) acc -= Wi[i * d + k] * f[k];
    b[i] = acc;
  }
  for (t = 1; t < d; t++) tn2 += b[t] * b[t];
  if (b[0] >= 0 && tn2 <= mu * mu * b[0] * b[0]) {
    for (i = 0; i < d; i++) r[i] = b[i];
    return 1;
  }
  if (d == 2) {
    /* r_n = -f_n / (W_nn - mu W_nt e), r_t = -mu e r_n, accepted where U'_t e >= 0: first e
       against the sticking trial's tangent (the free slip's where it has none), then -e */
    double s = tn2 > 0 ? (b[1] > 0 ? -1 : 1) : (f[1] > 0 ? 1 : f[1] < 0 ? -1 : 0);
    int pass;
    if (s == 0) return 0;
    for (pass = 0; pass < 2; pass++, s = -s) {
      const double iden = aux[s > 0 ? 1 : 2];
      double rn, rt, ut;
      if (!(iden > 0)) continue;
      rn = -f[0] * iden;
      rt = -mu * s * rn;
      ut = f[1] + Wl[2] * rn + Wl[3] * rt;
      if (ut * s >= 0) {
        r[0] = rn, r[1] = rt;
        return 1;
      }
    }
    return 0;
  }
  /* 3D: from the sticking trial's tangent (the free slip's where it has none) */
  if (tn2 > 0) {
    double tn = sqrt(tn2);
    e0[0] = -b[1] / tn, e0[1] = -b[2] / tn;
  } else {
    double n = hypot(f[1], f[2]);
    if (!(n > 0)) return 0;
    e0[0] = f[1] / n, e0[1] = f[2] / n;
  }
  if (slide_newton(Wl, f, mu, e0, e, x)) {
    for (i = 0; i < 3; i++) r[i] = x[i];
    return 1;
  }
  e[0] = e0[0], e[1] = e0[1];
  if (local_slide(3, Wl, f, mu, e, x)) {
    for (i = 0; i < 3; i++) r[i] = x[i];
    return 1;
  }
  return 0;
}

/* Candidate j's record of the smoother's work (LS_WD(d), T147) from W_jj + eps D_j in K[0 .. d^2):
   the inverse (Gauss-Jordan, kept only where every pivot is non-zero and the result finite),
   1 / (c w_j), the 2D sliding denominators' inverses (0 where a denominator is not positive). */
static void keep_factors(const ls_state *L, const ls_pass *Q, int j, double *K)
{
  const int d = L->d;
  double A[9], *Wi = K + d * d, *aux = K + 2 * d * d;
  int i, k, ok = 1;
  const double mu = Q->dt ? L->mu[j] : 0;
  memcpy(A, K, (size_t)(d * d) * sizeof *A);
  for (k = 0; k < d; k++) {
    double b[3] = {0, 0, 0}, M[9];
    b[k] = 1;
    memcpy(M, A, (size_t)(d * d) * sizeof *M);
    if (!small_solve(d, M, b)) ok = 0;
    for (i = 0; i < d; i++) {
      Wi[i * d + k] = b[i];
      ok &= isfinite(b[i]);
    }
  }
  aux[0] = 1 / (Q->c * Q->P->w[j]);
  aux[1] = aux[2] = 0;
  if (d == 2) {
    double dp = K[0] - mu * K[1], dm = K[0] + mu * K[1];
    aux[1] = dp > 0 ? 1 / dp : 0;
    aux[2] = dm > 0 ? 1 / dm : 0;
  }
  aux[3] = ok;
}

/* The merit Psi (T140) at the iterate L->r, L->U; *emax: its largest residual in units of the sign
   tests' tolerances of the last sign fields (<= 1: the law holds, as (T142) tests it). */
static double merit_here(const ls_state *L, const ls_pass *Q, double *emax)
{
  double m = 0, fn, ft, a, z[2], zn;
  int j;
  *emax = 0;
  for (j = 0; j < L->nc; j++) {
    if (!L->su[j]) continue;
    natural_map(L, Q, j, L->r + j * L->d, L->U + j * L->d, &fn, &ft, &a, z, &zn);
    m += fn * fn + ft * ft;
    *emax = fmax(*emax, fmax(fabs(fn) / (Q->tol_v + 1e-300), fabs(ft) / (Q->tol_f + 1e-300)));
  }
  return m;
}

/* U'_j = H_j^T v + q_eff,j (+ eps D_j r_j with the proximal term) from the bodies' velocities
   (T145): what W's block row j accumulates in the sweep on W. */
static inline __attribute__((always_inline)) void body_U(ls_state *L, int j, const int d)
{
  double *Uj = L->U + j * d;
  int i;
  ls_bodies_U(&L->bd, j, Uj, d);
  for (i = 0; i < d; i++) Uj[i] += L->b[j * d + i];
  if (L->eps > 0)
    for (i = 0; i < d; i++) Uj[i] += L->eps * L->dW[j * d + i] * L->r[j * d + i];
}

/* One sweep (forward, or backward with back) over the candidates of S_u = 1 with their records Wd
   + j LS_WD(d) (W's diagonal block with the proximal term first; d: a constant at the call). With
   kept, each local solve reads the factors kept in the record (local_law_kept) and the sweep
   returns the sum over the candidates of |r_j new - r_j old|^2 / (c w_j)^2 (pressure units, the
   change the visit made; its largest in units of the tolerances in *emax, T147); else each
   candidate's natural map (T140) as the sweep met it, before its update, and local_law. Either is
   the smoother's cue to test the law on the iterate itself. */
static inline __attribute__((always_inline)) double sweep(ls_state *L, const ls_pass *Q, const double *Wd, int back,
                                                          double *emax, const int d, const int kept)
{
  double vm = 0, ve = 0;
  const double itv = 1 / (Q->tol_v + 1e-300), itf = 1 / (Q->tol_f + 1e-300);
  const mo_delassus *W = Q->P->W;
  const int nc = L->nc, bodies = L->bodies;
  int jj, i, k, p;
  for (jj = 0; jj < nc; jj++) {
    const int j = back ? nc - 1 - jj : jj;
    const int *beta;
    const double *blk, *K = Wd + (size_t)j * LS_WD(d), *Wl = K;
    double f[3], rn[3], dr[3], *rj = L->r + j * d, *Uj = L->U + j * d;
    int n, moved = 0;
    if (!L->su[j] || isnan(K[0])) continue;
    if (bodies) body_U(L, j, d);
    if (!kept) {
      double fn, ft, a, z[2], zn;
      natural_map(L, Q, j, rj, Uj, &fn, &ft, &a, z, &zn);
      vm += fn * fn + ft * ft;
      fn = fabs(fn) * itv;
      ft *= itf;
      ve = fn > ve ? fn : ve;
      ve = ft > ve ? ft : ve;
    }
    for (i = 0; i < d; i++) {
      f[i] = Uj[i];
      for (k = 0; k < d; k++) f[i] -= Wl[i * d + k] * rj[k];
      rn[i] = rj[i];
    }
    if (kept ? !local_law_kept(d, K, f, Q->dt ? L->mu[j] : 0, rn) : !local_law(d, Wl, f, Q->dt ? L->mu[j] : 0, rn))
      continue;
    for (i = 0; i < d; i++) {
      dr[i] = rn[i] - rj[i];
      moved |= dr[i] != 0;
    }
    if (!moved) continue;
    if (kept) {
      /* the change in pressure units: normal, and tangential (squared) */
      const double icw = K[2 * d * d];
      double cn = dr[0] * icw, ct = 0;
      cn *= cn;
      for (i = 1; i < d; i++) ct += dr[i] * dr[i];
      ct *= icw * icw;
      vm += cn + ct;
      cn *= itv * itv;
      ct *= itf * itf;
      ve = cn > ve ? cn : ve;
      ve = ct > ve ? ct : ve;
    }
    for (i = 0; i < d; i++) rj[i] = rn[i];
    if (bodies) {
      ls_bodies_push(&L->bd, j, dr, d);
      continue;
    }
    /* U'_b += W_bj dr = W_jb^T dr (W symmetric: row j's blocks) */
    n = mo_delassus_row(W, j, &beta, &blk);
    for (p = 0; p < n; p++) {
      const double *bl = blk + (size_t)p * (size_t)(d * d);
      double *Ub = L->U + beta[p] * d;
      for (k = 0; k < d; k++)
        for (i = 0; i < d; i++) Ub[k] += bl[i * d + k] * dr[i];
    }
    if (L->eps > 0)
      for (i = 0; i < d; i++) Uj[i] += L->eps * L->dW[j * d + i] * dr[i];
  }
  *emax = kept ? sqrt(ve) : ve;
  return vm;
}

/* nsweep sweeps of projected block Gauss-Seidel over the candidates of S_u = 1 (in the order of
   smoother_order): each candidate's law solved exactly (local_law) with W's diagonal block (plus the
   proximal term) against the current impulses of the others. U' = W r + q_eff follows the impulse
   changes along W's block row, or (L->bodies, T145) through the bodies' velocities v = What^-1 H r,
   U'_j read from them before each local solve. The sweeps stop on the merit and the law of the
   iterate itself (U' over S_u = 1 from v), tested after a sweep whose candidates met the merit's
   drop or the law as they were visited. L->U must hold U' over the candidates of S_u = 1 on entry;
   on return it does over all of them that W's rows reach (full_velocity refreshes the rest). L->wd
   (nc records of LS_WD(d)) holds the diagonal blocks and, with smoother_local = "kept", what the
   local solves keep of them (keep_factors, T147). */
static void smoother(ls_state *L, ls_pass *Q, int nsweep, double drop)
{
  const int nc = L->nc, d = L->d, kept = L->par.smooth_local == LS_LOCAL_KEPT;
  double e, m0 = merit_here(L, Q, &e), vm;
  int s, j;
  /* the diagonal blocks (with the proximal term), side by side: read at every visit */
  for (j = 0; j < nc; j++) {
    const double *Wjj = L->su[j] ? mo_delassus_block(Q->P->W, j, j) : NULL;
    double *Wl = L->wd + (size_t)j * LS_WD(d);
    int i;
    if (!Wjj) {
      Wl[0] = NAN; /* no block: the sweeps pass it by */
      continue;
    }
    memcpy(Wl, Wjj, (size_t)(d * d) * sizeof *Wl);
    if (L->eps > 0)
      for (i = 0; i < d; i++) Wl[i * d + i] += L->eps * L->dW[j * d + i];
    if (kept) keep_factors(L, Q, j, Wl);
  }
  if (L->bodies) ls_bodies_velocity(&L->bd, Q->P, L->r);
  for (s = 0; s < nsweep; s++) {
    const int back = L->par.smooth_order == LS_ORDER_ALTERNATE && (s & 1);
    if (kept) {
      if (d == 2) vm = sweep(L, Q, L->wd, back, &e, 2, 1);
      else if (d == 3) vm = sweep(L, Q, L->wd, back, &e, 3, 1);
      else vm = sweep(L, Q, L->wd, back, &e, 1, 1);
    } else if (d == 2) vm = sweep(L, Q, L->wd, back, &e, 2, 0);
    else if (d == 3) vm = sweep(L, Q, L->wd, back, &e, 3, 0);
    else vm = sweep(L, Q, L->wd, back, &e, 1, 0);
    Q->nsweep++;
    if (vm > drop * m0 && e > 1 && s + 1 < nsweep) continue;
    if (L->bodies)
      for (j = 0; j < nc; j++) {
        if (!L->su[j]) continue;
        if (d == 2) body_U(L, j, 2);
        else if (d == 3) body_U(L, j, 3);
        else body_U(L, j, 1);
      }
    /* enough: the merit down by the factor drop, or the law holding (the sign fields' test) */
    if (merit_here(L, Q, &e) <= drop * m0 || e <= 1) return;
  }
}

/* The damped level-set loop (T140)-(T142): from the iterate r_k (the warm start), the sign fields
   of its natural map freeze a status, the frozen system gives r*, and the step r_k + alpha (r* -
   r_k) is the longest of 1, 1/2, 1/4, ... that decreases the merit |F|^2 by the Armijo factor (the
   whole step when none does); until the natural map vanishes to the sign tests' tolerances. The
   reduced path with the coupled threshold (in 3D with the directions frozen, T143). */
static int damped_loop(ls_state *L, ls_pass *Q, mo_contact_report *rep, mo_ctx *ctx)
{
  const mo_contact_problem *P = Q->P;
  ls_system *S = &L->S;
  const int nc = L->nc, m = L->m;
  const int hybrid = L->hybrid;
  int it, j, st, its, conv, done, k;
  double m0, emax;
  full_velocity(L, P, 0);
  if (hybrid && L->spre > 0) {
    damped_signs(L, Q); /* the sign tests' tolerances, which the smoother's stop reads */
    smoother(L, Q, L->spre, 0);
    full_velocity(L, P, 0);
  }
  emax = damped_signs(L, Q);
  m0 = merit_at(L, Q, 0, 0);
  for (it = 0;; it++) {
    double alpha = 1, ma = 0;
    int trap;
    if (emax <= 1) return MO_OK;
    if (it >= L->lsmax) {
      rep->reason = MO_CR_MAXITER;
      snprintf(rep->message, sizeof rep->message, "the damped level-set loop reached %s = %d "
               "(natural-map residual %.3e of its tolerance)",
               L->lsmax < L->par.levelset_max ? "its first try's limit" : "levelset_max", L->lsmax, emax);
      return MO_OK;
    }
    for (j = 0; j < nc; j++) L->phi[j] = L->sv[j] && L->mu[j] > 0;
    S->phi = L->phi;
    S->edir = L->edir;
    friction_scales(L, Q->kt, &Q->rho_t);
    memcpy(L->rk, L->r, (size_t)m * sizeof(double));
    memcpy(L->Uk, L->U, (size_t)m * sizeof(double));
    L->uc_gen = -1; /* the iterate moved: Uc does not hold its U' */
    if ((st = frozen_solve(L, Q, &its, &conv, &done, rep, ctx)) || done) return st;
    if (L->u_partial) {
      /* U' of the frozen solution over Cset; the rest of the candidates (S_u = 0) carry no law */
      for (k = 0; k < S->nC; k++) {
        int i = S->cset[k] * L->d;
        memcpy(L->Us + i, L->U + i, (size_t)L->d * sizeof(double));
      }
    } else
      memcpy(L->Us, L->U, (size_t)m * sizeof(double));
    memcpy(L->rs, L->r, (size_t)m * sizeof(double));
    for (k = 0; k < 30; k++, alpha *= 0.5) {
      ma = merit_at(L, Q, alpha, 0);
      if (ma <= (1 - 1e-4 * alpha) * m0) break;
    }
    /* a trap (no decrease, or a step below smoother_alpha): the hybrid sweeps from the iterate
       (or the short step's point) instead of the whole step (T144) */
    trap = hybrid && (k == 30 || alpha < L->par.smooth_alpha);
    if (k == 30) alpha = trap ? 0 : 1, ma = merit_at(L, Q, alpha, 0);
    L->u_partial = 1;
    m0 = ma;
    merit_at(L, Q, alpha, 1);
    if (trap) {
      smoother(L, Q, L->par.smooth_sweeps, L->par.smooth_drop);
      full_velocity(L, P, 0);
      memcpy(L->rk, L->r, (size_t)m * sizeof(double));
      memcpy(L->Uk, L->U, (size_t)m * sizeof(double));
      m0 = merit_at(L, Q, 0, 0);
    }
    emax = damped_signs(L, Q);
  }
}

/* The friction-threshold loop (BDZ04 Fig. 1, loop 3): the level-set loop with the threshold
   frozen, then lambda^g <- max(lambda, 0), until it repeats to threshold_tol (one pass with the
   coupled threshold, T134, unless a dense solve froze it). */
static int threshold_loop(ls_state *L, ls_pass *Q, mo_contact_report *rep, mo_ctx *ctx)
{
  const int nc = L->nc, d = L->d, dt = Q->dt;
  int thr, j, t, st;
  for (thr = 0;; thr++) {
    double change = 0, pmax = 0;
    Q->nthr++;
    L->frozen_solve = 0;
    if (L->u_partial) full_velocity(L, Q->P, Q->kkt);
    if (dt) {
      friction_scales(L, Q->kt, &Q->rho_t);
      /* S_f from the current semi-multipliers and U', with the hysteresis of (T88) */
      sign_tolerances(L, d, dt, Q->rho_n, Q->rho_t, &Q->tol_v, &Q->tol_f, &Q->scale_v);
      for (j = 0; j < nc; j++) {
        double g = 0;
        for (t = 0; t < dt; t++) {
          double v = L->lam[j * 2 + t] + Q->rho_t * L->U[j * d + 1 + t];
          g += v * v;
        }
        L->sf[j] = (unsigned char)stick_sign(L, j, sqrt(g), L->sf[j], Q->tol_f);
      }
    }
    if ((st = (L->glob ? damped_loop : level_set_loop)(L, Q, rep, ctx))) return st;
    if (rep->reason < 0 || !dt || L->prox_request) return MO_OK;
    /* coupled: every solve took p^g = p, the threshold holds already */
    if (L->coupled && !L->frozen_solve) return MO_OK;
    for (j = 0; j < nc; j++) {
      double pn = L->sv[j] && L->ph[j] > 0 ? L->ph[j] : 0;
      if (fabs(pn - L->pg[j]) > change) change = fabs(pn - L->pg[j]);
      if (pn > pmax) pmax = pn;
      L->pg[j] = pn;
    }
    if (change <= L->par.threshold_tol * pmax) return MO_OK;
    if (thr + 1 >= L->par.threshold_max) {
      rep->reason = MO_CR_MAXITER;
      snprintf(rep->message, sizeof rep->message, "the friction-threshold loop reached "
               "threshold_max = %d (last change %.3e of %.3e)", L->par.threshold_max, change, pmax);
      return MO_OK;
    }
  }
}

/* The proximal loop (T136): the local problem (W + eps D, q - eps D r_c) around the center r_c,
   the previous pass's impulses (the previous step's at the first), until the proximal term
   eps D (r - r_c) is below Newton's tolerance on U'. Without it (eps = 0), one pass on (W, q). */
static int proximal_loop(ls_state *L, ls_pass *Q, mo_contact_report *rep, mo_ctx *ctx)
{
  const mo_contact_problem *P = Q->P;
  const int m = L->m;
  int pass, i, st;
  for (pass = 0;; pass++) {
    double dmax = 0, umax = 0;
    if (L->eps > 0)
      for (i = 0; i < m; i++) L->qeff[i] = P->b[i] - L->eps * L->dW[i] * L->rc[i];
    if ((st = threshold_loop(L, Q, rep, ctx)) || rep->reason < 0 || !(L->eps > 0) || L->prox_request) return st;
    if (L->u_partial) full_velocity(L, P, Q->kkt);
    for (i = 0; i < m; i++) {
      dmax = fmax(dmax, L->eps * L->dW[i] * fabs(L->r[i] - L->rc[i]));
      umax = fmax(umax, L->Umag[i]);
    }
    memcpy(L->rc, L->r, (size_t)m * sizeof(double));
    if (dmax <= L->par.newton_tol * umax) return MO_OK;
    if (pass + 1 >= L->par.proximal_max) {
      rep->reason = MO_CR_MAXITER;
      snprintf(rep->message, sizeof rep->message, "the proximal loop reached proximal_max = %d (its term "
               "%.3e against U' %.3e)", L->par.proximal_max, dmax, umax);
      return MO_OK;
    }
  }
}

/* The outputs in the core's conventions (T13): impulses (forces for quasi-static steps) r_n >= 0
   compressive and r_t = -mu r_n Lam, U' = W r + q, statuses; the warm start of the next solve. */
static void write_solution(ls_state *L, ls_pass *Q, mo_contact_vars *x)
{
  const mo_contact_problem *P = Q->P;
  const int nc = L->nc, d = L->d, m = L->m, dt = Q->dt;
  int j, t;
  /* U' = W r + q over every candidate: the last frozen solve's when it covered them all; none
     where the core measures U' = W r + q itself after the solve (P->u_measured, T156: the pass
     over W saved, as nscd saves it; x->U is then the core's) */
  if (!P->u_measured && !(L->u_partial && L->S.nC == nc && L->S.nr == d && !(L->eps > 0))) {
    L->b = P->b;
    L->eps = 0;
    full_velocity_t(L, P, Q->kkt, 1); /* every component: no measure of the core follows */
  }
  L->b = P->b;
  L->eps = 0;
  memcpy(x->r, L->r, (size_t)m * sizeof(double));
  memcpy(x->U, L->U, (size_t)m * sizeof(double));
  for (j = 0; j < nc; j++) {
    int closed = L->su[j] && L->sv[j];
    /* an open candidate's impulse is zero (its equation is r = 0; Newton through the Schur
       complement leaves round-off, 1e-35, which would count as a bearing contact) */
    if (!closed) for (t = 0; t < d; t++) x->r[j * d + t] = 0;
    if (!closed) x->status[j] = MO_CS_OPEN;
    else if (dt && L->mu[j] > 0) x->status[j] = L->sf[j] ? MO_CS_STICK : MO_CS_SLIDE;
    else x->status[j] = d == 1 ? MO_CS_STICK : MO_CS_SLIDE;
    L->ph_prev[j] = closed ? L->ph[j] : 0;
    for (t = 0; t < dt; t++) L->lam_prev[j * 2 + t] = closed ? L->lam[j * 2 + t] : 0;
  }
  L->have_prev = 1;
  if (Q->kkt) {
    memcpy(x->dx, L->dv, (size_t)P->nfree * sizeof(double));
    x->dx_set = 1;
  }
}

/* Every candidate between rigid bodies and obstacles: H's entries on the rigid blocks' dofs only
   (none on a deformable body's). What the candidates join is the contact set's (P->cset): read
   once per set, not at every step. */
static int rigid_only(ls_state *L, const mo_contact_problem *P)
{
  int p;
  if (L->ro_cset == P->cset && L->ro_known) return L->ro;
  L->ro_cset = P->cset;
  L->ro_known = 1;
  L->ro = 0;
  if (!P->H || !P->Wi) return L->ro;
  for (p = 0; p < P->H->p[P->m]; p++)
    if (P->H->i[p] < P->Wi->nfe) return L->ro;
  return L->ro = 1;
}

static int ls_solve(void *state, const mo_contact_problem *P, mo_contact_vars *x,
                    mo_contact_report *rep, mo_ctx *ctx)
{
  ls_state *L = state;
  const long nfact0 = L->lu.factorizations, nreuse0 = L->lu.reuses;
  ls_pass Q;
  int j, st, pile, alt, set, fallback;
  if (!P->W) return mo_error(ctx, MO_EINTERNAL, "levelset: the core did not build W");
  memset(&Q, 0, sizeof Q);
  Q.P = P;
  Q.kkt = L->par.path == LS_PATH_KKT;
  Q.end_gap = P->scheme == MO_SCHEME_THETA && P->signorini == MO_SIGNORINI_VELOCITY && L->par.su == LS_SU_END_GAP;
  Q.dt = L->friction ? L->d - 1 : 0;
  Q.c = P->scheme == MO_SCHEME_THETA ? P->h : 1;
  /* the damped loop (T140): where asked, or on large rigid sets (piles); in 3D it brings the
     coupled threshold with frozen sliding directions (T143). auto on a pile: the hybrid with the
     smoother finishing the steps at nscd's accuracy on the shipped piles (T149) */
  pile = L->par.globalization == LS_GLOB_AUTO && L->rigid && P->nfree > LS_DENSE_MAX && rigid_only(L, P);
  /* auto on a smaller rigid frictional set: the hybrid too above LS_SET_MIN local unknowns (the
     masonry arch), the sign tests at LS_SET_TOL at least (at 1e-10 both paths stall on a step of
     the collapsing arch, at 1e-3 the standing arch fails a step); a step the first path fails, the
     other one redoes (the undamped loop of BDZ07 Fig. 2 or the hybrid; T149) */
  alt = L->par.globalization == LS_GLOB_AUTO && !pile && Q.dt > 0 && L->rigid && rigid_only(L, P);
  set = alt && P->nc * P->dim > LS_SET_MIN;
  for (fallback = 0;; fallback = 1) {
    L->glob = L->reduced && !Q.kkt && Q.dt > 0 && L->par.threshold != LS_THR_LOOP && L->par.k_n == 0 &&
              L->par.k_t == 0 && (L->par.globalization == LS_GLOB_LINE_SEARCH || L->par.globalization == LS_GLOB_HYBRID || pile ||
              (set != fallback) || (L->par.globalization == LS_GLOB_AUTO && Q.dt == 1 && L->rigid && P->nc * P->dim > LS_DENSE_MAX));
    L->hybrid = L->glob && (L->par.globalization == LS_GLOB_HYBRID || pile || (alt && set != fallback));
    /* the hybrid first on the smaller set: LS_SET_TRY iterations before the other path (the 0.13
       arch: at most 12 a step; the failing steps of the collapsing 0.09 arch: 100 x 500 sweeps) */
    L->lsmax = set && !fallback && L->par.levelset_max > LS_SET_TRY ? LS_SET_TRY : L->par.levelset_max;
    L->spre = (pile || alt) && L->par.smooth_pre == 0 ? LS_PILE_PRE : L->par.smooth_pre;
    L->stol = L->glob && pile ? fmax(L->par.status_tol, LS_PILE_TOL) :
              (set || fallback) ? fmax(L->par.status_tol, LS_SET_TOL) : L->par.status_tol;
    solve_scales(L, &Q);
    L->coupled = L->reduced && !Q.kkt && (Q.dt == 1 || (Q.dt == 2 && L->glob)) && L->par.threshold != LS_THR_LOOP;
    /* the hybrid's sweep on body velocities, where asked and every candidate joins rigid bodies
       (T145); auto takes it in 3D, where W's rows hold many 3 x 3 blocks and the sweep on them costs
       more memory traffic than instructions (sphere-deposit: 0.75 times the CPU time), and W's rows
       in 2D (the two cost the same within noise; T148) */
    L->bodies = 0;
    if (L->hybrid && (L->par.smooth_path == LS_SMOOTH_BODIES || (L->par.smooth_path == LS_SMOOTH_AUTO && L->d == 3))) {
      if ((st = ls_bodies_build(&L->bd, P, ctx))) return st;
      L->bodies = L->bd.ok;
      if (!L->bodies && L->par.smooth_path == LS_SMOOTH_BODIES)
        return mo_error(ctx, MO_EINPUT, "contact.levelset.smoother_path = \"bodies\" needs every candidate "
                        "between rigid bodies and obstacles (step %ld has one on a deformable body)", P->step);
    }
    for (;;) {
      L->prox_request = 0;
      proximal_setup(L, &Q, x);
      if ((st = warm_start(L, &Q, x, ctx))) return st;
      rep->reason = MO_CR_CONVERGED;
      rep->loops[0] = 1; /* the geometric loop: the core freezes the pairing within the step (§6.5) */
      if ((st = proximal_loop(L, &Q, rep, ctx))) return st;
      if (!L->prox_request) break;
      /* redundant normal impulses met without the proximal term: on from now (T136) */
      mo_log(ctx, 2, "levelset step %ld: redundant normal impulses; the proximal term eps = %g from now on\n",
             P->step, LS_PROX_EPS);
      L->want_prox = 1;
    }
    if (!(alt && !fallback && rep->reason < 0 && rep->reason != MO_CR_NAN)) break;
    /* the first path failed on a smaller rigid set: the other one from the same warm start (T149);
       the report counts the work of both */
    mo_log(ctx, 2, "levelset step %ld: the %s loop failed (%s); the %s loop redoes the step\n", P->step,
           L->hybrid ? "hybrid" : "undamped", rep->message, L->hybrid ? "undamped" : "hybrid");
    rep->message[0] = '\0';
  }
  if (rep->reason == MO_CR_BREAKDOWN || rep->reason == MO_CR_NAN) {
    memset(L->r, 0, (size_t)L->m * sizeof(double));
    memset(x->r, 0, (size_t)L->m * sizeof(double));
    memcpy(x->U, P->b, (size_t)L->m * sizeof(double));
    for (j = 0; j < L->nc; j++) x->status[j] = MO_CS_OPEN;
    L->have_prev = 0;
    L->b = P->b;
    L->eps = 0;
  } else
    write_solution(L, &Q, x);
  rep->loops[1] = Q.nthr > 0 ? Q.nthr : 1;
  rep->loops[2] = Q.nls;
  rep->loops[3] = Q.nnewt;
  rep->factorizations = (int)(L->lu.factorizations - nfact0);
  rep->factor_reuses = (int)(L->lu.reuses - nreuse0);
  rep->iterations = Q.nnewt;
  rep->sweeps = Q.nsweep;
  if (ctx->verbosity >= 3) /* (the call's set-up and the reason's name: a few % of a small scene's solve) */
    mo_log(ctx, 3, "levelset step %ld: loops geometry %d, threshold %d, level-set %d, Newton %d (%s)\n",
           P->step, rep->loops[0], rep->loops[1], rep->loops[2], rep->loops[3],
           mo_contact_reason_name(rep->reason));
  return MO_OK;
}

const mo_contact_solver_type mo_contact_solver_levelset = {
  "levelset",
  "Ben Dhia-Zammali Level-Set stabilized Lagrangian (BDZ07): sign fields, Newton, Schur or KKT",
  sizeof(ls_state),
  sizeof(ls_params),
  MO_NEEDS_DELASSUS | MO_NEEDS_GLOBAL,
  (1u << MO_SCHEME_THETA) | (1u << MO_SCHEME_QUASISTATIC),
  ls_options,
  (int)MO_COUNT(ls_options),
  ls_defaults,
  ls_init,
  ls_solve,
  ls_free,
  NULL, /* the case's time scheme */
  ls_reinit
};
