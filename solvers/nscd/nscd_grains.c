/* nscd_grains.c: nscd's sweep on body velocities for the granular path (doc/theory.md §12.9):
   the contacts come as compact records (bodies, point, normal; P->grains) instead of columns of
   H, and each contact keeps its two sides' first velocities, W_aa and c_a; the moments of its
   frame about the sides' centres and the local solver's data are formed at each visit (T188).
   The arithmetic is that of the sweep on H (nscd_bodies.c, (T79)) to the bit: the same rows of
   H, the same sums in the same order. */
#include "config.h"
#include "nscd.h"
#include <moreau/parallel.h>
#include "partition.h"

#include <math.h>
#include <string.h>

/* Dofs of a body and its rotations in a problem of contact dimension d (2D: 3 and 1, 3D: 6 and 3). */
#define NK(d) ((d) == 3 ? 6 : 3)
#define NR(d) ((d) == 3 ? 3 : 1)
/* The kernels below take d as a constant of each call site: inlined, their loops unroll. */
#define KERNEL static inline __attribute__((always_inline))

/* One record per contact (d = 2: 48 bytes, d = 3: 96): c_a = q_a - H_a^T v_free and W_aa. The
   rows of H on the sides' rotations and the local solver's data are formed again at each visit
   from the point, the frame (from its normal, (T225)) and the sides' centres (geometry) and from
   W_aa, in the operations that formed them once: the same numbers (T188); so are the contact's
   sides (sides: from its key and the bodies' first velocities, (T226)). A side is + (o + 1) for a
   slave side, - (o + 1) for a master side whose body's velocities start at o in vb, increasing o;
   0 none. */
#define OFF_W(d) (8 * (d))
#define RECSZ(d) ((size_t)(OFF_W(d) + 8 * (d) * (d)))
#define REC(S, a, d) ((char *)(S)->grec + (size_t)(a) * RECSZ(d))
#define R_C(p) ((double *)(p))
#define R_W(p, d) ((double *)((p) + OFF_W(d)))
#define SIDE_O(g) (((g) > 0 ? (g) : -(g)) - 1)

void nscd_grains_free(nscd_state *S)
{
  mo_free(S->grec);
  mo_free(S->giv);
  mo_free(S->own);
  mo_free(S->oorder);
  mo_free(S->ifc);
  mo_free(S->bfirst);
  mo_free(S->bmulti);
  mo_free(S->cifc);
  mo_free(S->ilist);
  mo_free(S->vlist);
  mo_free(S->aside);
  mo_free(S->onil);
  mo_free(S->bm);
  mo_free(S->nbuf);
  mo_free(S->pbuf);
  mo_free(S->ibase);
  mo_free(S->gl);
  mo_free(S->apart);
  mo_free(S->ridx);
  mo_free(S->ipos);
  mo_free(S->pcnt);
  mo_free(S->pkey);
  mo_free(S->peer);
  mo_free(S->poff);
  mo_free(S->pj);
  mo_free(S->mj);
  mo_free(S->msrc0);
  mo_free(S->msrc);
  mo_free(S->pe);
  mo_free(S->sbuf);
  mo_free(S->rbuf);
  mo_free(S->gcnt);
  mo_free(S->hx);
  mo_free(S->hbuf);
  mo_free(S->gbuf);
}

/* Room for nc contacts and nfree velocities. */
static int reserve(nscd_state *S, const mo_contact_problem *P, int nfree, mo_ctx *ctx)
{
  size_t nc = (size_t)S->nc + 1;
  void *p;
#define GROW(ptr, n) if (!(p = mo_realloc(ctx, ptr, (n)))) return MO_ENOMEM; ptr = p
  if (nc > S->gcap) {
    nc = mo_contact_room(P->contact, nc - 1) + 1; /* the contact set's capacity (T252), one record over it */
    GROW(S->grec, nc * RECSZ(S->d));
    S->gcap = nc;
  }
  if ((size_t)nfree + 1 > S->vcap) {
    GROW(S->vb, ((size_t)nfree + 1) * sizeof *S->vb);
    S->vcap = (size_t)nfree + 1;
  }
#undef GROW
  return MO_OK;
}

/* The diagonal of What^-1 over the rigid free dofs (S->gi): the stepper's own when it stores the
   blocks' diagonals and no nodal dof comes first, otherwise a copy (giv) from its blocks when they
   changed. The blocks of disks, spheres and polygons are diagonal (diag(m, m, I) in 2D,
   diag(m Id, (2/5) m R^2 Id) in 3D, inverted exactly by Gauss-Jordan), so inv_k G^T is the diagonal
   times G^T to the bit. */
static int inverse_diagonal(nscd_state *S, const mo_what_inverse *Wi, int nfree, mo_ctx *ctx)
{
  int k, i, j;
  if (Wi->dinv && Wi->off[0] == 0) {
    S->gi = Wi->dinv;
    return MO_OK;
  }
  if ((size_t)nfree + 1 > S->gvcap) {
    void *p = mo_realloc(ctx, S->giv, ((size_t)nfree + 1) * sizeof *S->giv);
    if (!p) return MO_ENOMEM;
    S->giv = p;
    S->gvcap = (size_t)nfree + 1;
    S->givver = -1;
  }
  S->gi = S->giv;
  if (S->givver == Wi->version) return MO_OK;
  for (k = 0; k < Wi->nblk; k++) {
    int o = Wi->off[k], nk = Wi->off[k + 1] - o;
    double inv[36];
    mo_what_block(Wi, k, inv);
    for (i = 0; i < nk; i++)
      for (j = 0; j < nk; j++)
        if (i != j && inv[i * nk + j] != 0)
          return mo_error(ctx, MO_EINTERNAL, "nscd: the mass block of a rigid body of the granular path is not "
                          "diagonal (block %d)", k);
    for (i = 0; i < nk; i++) S->giv[o + i] = inv[i * nk + i];
  }
  S->givver = Wi->version;
  return MO_OK;
}

/* Contact a's sides (see the record), in increasing o: the order of H's rows. */
KERNEL void sides(const mo_grains *G, int a, int *gs)
{
  const int *key = G->key + (size_t)a * MO_KEY;
  int os = G->vel[key[1]], om = key[2] >= 0 ? G->vel[key[2]] : -1;
  gs[0] = gs[1] = 0;
  if (os >= 0 && om >= 0) {
    gs[0] = os < om ? os + 1 : -(om + 1);
    gs[1] = os < om ? -(om + 1) : os + 1;
  } else if (os >= 0)
    gs[0] = os + 1;
  else if (om >= 0)
    gs[0] = -(om + 1);
}

/* The rows of H on a side (d x NK(d), row-major): cf F_i on the translations, cf (x - c) x F_i on
   the rotations (T68); rot gets the moments (x - c) x F_i without the sign cf. */
KERNEL void side_rows(const int d, const double *F, const double *x, const double *c, double cf, double *G,
                      double *rot)
{
  int i, j;
  double r[3] = {0, 0, 0};
  for (j = 0; j < d; j++) r[j] = x[j] - c[j];
  for (i = 0; i < d; i++) {
    const double *Fi = F + i * d;
    for (j = 0; j < d; j++) G[i * NK(d) + j] = cf * Fi[j];
    if (d == 2)
      G[i * NK(d) + 2] = cf * (rot[i] = r[0] * Fi[1] - r[1] * Fi[0]);
    else {
      double w[3] = {r[1] * Fi[2] - r[2] * Fi[1], r[2] * Fi[0] - r[0] * Fi[2], r[0] * Fi[1] - r[1] * Fi[0]};
      for (j = 0; j < 3; j++) G[i * NK(d) + 3 + j] = cf * (rot[i * 3 + j] = w[j]);
    }
  }
}

/* Contact a's moments on its sides' rotations (rot, d x NR(d) per side, without the side's sign)
   and, for the first nw rows and columns (d, or 1: W_nn alone; 0: none), W_aa = sum_s G inv_s G^T
   as nscd_bodies.c's prepare computes it from H (an entry H does not store, a zero, gives a zero
   product here: the sums differ at most by the sign of a zero); with ca, c_a -= sum_s G v_free as
   well. The same operations at every call: what a visit forms is what the preparation formed (T188). */
KERNEL void geometry(const int d, const nscd_state *S, const mo_contact_problem *P, int a, const int *gs,
                     double *F, double *rot, const int nw, double *Waa, double *ca)
{
  const mo_grains *Gr = P->grains;
  const double *x = Gr->x + (size_t)a * d, *iv = S->gs;
  const int *key = Gr->key + (size_t)a * MO_KEY;
  int s, i, j, k;
  mo_frame_of_normal(d, Gr->n + (size_t)a * d, F); /* the frame from its normal (T225) */
  if (d == 2) {
    /* the loops below written out, the same products and sums in the same order; W_aa's products
       without the side's sign cf = -+1: (cf a) (iv (cf b)) = a (iv b) exactly in IEEE arithmetic */
    double w00 = 0, w01 = 0, w10 = 0, w11 = 0;
    for (s = 0; s < 2 && gs[s]; s++) {
      const int o = SIDE_O(gs[s]);
      const double *c = Gr->centre + (size_t)(gs[s] > 0 ? key[1] : key[2]) * 2;
      const double r0 = x[0] - c[0], r1 = x[1] - c[1];
      const double u0 = r0 * F[1] - r1 * F[0], u1 = r0 * F[3] - r1 * F[2]; /* the moments, unsigned */
      rot[2 * s] = u0;
      rot[2 * s + 1] = u1;
      if (nw) { /* MG = inv G^T, column 0 (m*0) and 1 (m*1) */
        const double m00 = iv[o] * F[0], m10 = iv[o + 1] * F[1], m20 = iv[o + 2] * u0;
        w00 = w00 + F[0] * m00 + F[1] * m10 + u0 * m20;
        if (nw > 1) {
          const double m01 = iv[o] * F[2], m11 = iv[o + 1] * F[3], m21 = iv[o + 2] * u1;
          w01 = w01 + F[0] * m01 + F[1] * m11 + u0 * m21;
          w10 = w10 + F[2] * m00 + F[3] * m10 + u1 * m20;
          w11 = w11 + F[2] * m01 + F[3] * m11 + u1 * m21;
        }
      }
      if (ca) {
        const double cf = gs[s] > 0 ? 1 : -1, *xf = P->xfree + o;
        ca[0] = ca[0] - (cf * F[0]) * xf[0] - (cf * F[1]) * xf[1] - (cf * u0) * xf[2];
        ca[1] = ca[1] - (cf * F[2]) * xf[0] - (cf * F[3]) * xf[1] - (cf * u1) * xf[2];
      }
    }
    if (nw) Waa[0] = w00;
    if (nw > 1) {
      Waa[1] = w01;
      Waa[2] = w10;
      Waa[3] = w11;
    }
    return;
  }
  for (i = 0; i < nw * d; i++) Waa[i] = 0;
  for (s = 0; s < 2 && gs[s]; s++) {
    const int o = SIDE_O(gs[s]), b = gs[s] > 0 ? key[1] : key[2];
    double G[3 * 6], MG[6 * 3];
    side_rows(d, F, x, Gr->centre + (size_t)b * d, gs[s] > 0 ? 1 : -1, G, rot + s * d * NR(d));
    if (nw) /* inv_k G^T: the diagonal times G^T */
      for (k = 0; k < NK(d); k++)
        for (j = 0; j < nw; j++) MG[k * d + j] = iv[o + k] * G[j * NK(d) + k];
    for (i = 0; i < d; i++) {
      if (i < nw)
        for (j = 0; j < nw; j++) {
          double acc = Waa[i * d + j];
          for (k = 0; k < NK(d); k++) acc += G[i * NK(d) + k] * MG[k * d + j];
          Waa[i * d + j] = acc;
        }
      if (ca)
        for (k = 0; k < NK(d); k++) ca[i] -= G[i * NK(d) + k] * P->xfree[o + k];
    }
  }
}

/* The records: c_a = q_a - sum_s G v_free; W_aa of the active contacts (0 for the others), for the
   friction coefficients as nscd_prepare_local keeps them (a coefficient where a free dof moves the
   contact tangentially). */
/* The problem's coefficient of contact a: P->mu's, or its pair's (T189); 0 without either. */
static inline double problem_mu(const mo_contact_problem *P, int a)
{
  return P->mu ? P->mu[a] : P->grains->pmu ? P->grains->pmu[P->grains->key[(size_t)a * MO_KEY]] : 0;
}

/* Contact a's record: for an active contact (act) c_a and W_aa, and whether its coefficient
   differs from the problem's (the return); otherwise c_a (its U, r = 0) only and W_aa = 0 (its
   scaling 0). */
KERNEL int record(nscd_state *S, const mo_contact_problem *P, int a, int act, const int d)
{
  char *rec = REC(S, a, d);
  double *Waa = R_W(rec, d), rot[2 * 3 * 3], F[9], *ca = R_C(rec), wtt = 0, mua;
  int gs[2], i;
  sides(P->grains, a, gs);
  for (i = 0; i < d; i++) ca[i] = P->b[a * d + i];
  /* W_aa for the contacts of the step's problem only */
  if (act) geometry(d, S, P, a, gs, F, rot, d, Waa, ca);
  else {
    for (i = 0; i < d * d; i++) Waa[i] = 0;
    geometry(d, S, P, a, gs, F, rot, 0, Waa, ca);
    if (S->muown) S->muown[a] = 0;
    return 0;
  }
  for (i = 1; i < d; i++) wtt += Waa[i * d + i];
  mua = wtt > 1e-12 * Waa[0] ? problem_mu(P, a) : 0;
  if (S->muown) S->muown[a] = mua;
  else return (!P->mu && !P->grains->pmu) || mua != problem_mu(P, a);
  return 0;
}

/* Contact a's W_aa (an active contact's) formed again, its c_a kept; its coefficient as record
   decides it. */
KERNEL void record_w(nscd_state *S, const mo_contact_problem *P, int a, const int d)
{
  char *rec = REC(S, a, d);
  double *Waa = R_W(rec, d), rot[2 * 3 * 3], F[9], wtt = 0;
  int gs[2], i;
  sides(P->grains, a, gs);
  geometry(d, S, P, a, gs, F, rot, d, Waa, NULL);
  for (i = 1; i < d; i++) wtt += Waa[i * d + i];
  if (S->muown) S->muown[a] = wtt > 1e-12 * Waa[0] ? problem_mu(P, a) : 0;
}

/* The records of every contact or, over the ranks (gpart), of the rank's own active contacts
   only (T274): no other record is read by the split sweep, its stopping rule or the U of its end
   (T278). */
KERNEL int prepare_d(nscd_state *S, const mo_contact_problem *P, const int d)
{
  int a, k, differ = 0;
  if (S->gpart) {
    for (k = 0; k < S->noact; k++) differ |= record(S, P, S->oorder[k], 1, d);
    /* on 2 ranks, the other rank's interface contacts too: every rank forms their residual (T340) */
    if (S->nranks == 2)
      for (k = 0; k < S->nilist; k++)
        if (!S->own[S->ilist[k]]) differ |= record(S, P, S->ilist[k], 1, d);
  } else
    for (a = 0; a < S->nc; a++) differ |= record(S, P, a, !P->active || P->active[a], d);
  return differ;
}

/* The split sweep's inverse masses (T332): an interface body touched by the contacts of k > 2
   ranks is, in each of their sweeps, a body of mass 2 m / k (its inverse mass and inertia times
   f = k / 2), and the ranks' increments are summed divided by f (nscd_grains_sync): the velocity
   stays v_free + M^-1 H r, and no body moves by more than the sum of two ranks' full increments,
   the Jacobi step between 2 ranks. Bodies of 2 ranks keep their masses (f = 1). */
static double split_factor(int k)
{
  return k > 2 ? 0.5 * k : 1.0;
}

static int split_masses(nscd_state *S, int nfree, mo_ctx *ctx)
{
  const int nk = NK(S->d);
  int m, i, any = 0;
  if (!S->xchg) return MO_OK; /* 2 ranks: f = 1 for every body */
  for (m = 0; m < S->nmine && !any; m++) any = S->msrc0[m + 1] - S->msrc0[m] > 2;
  if (!any) return MO_OK; /* no copy: the sweep reads gi */
  if ((size_t)nfree + 1 > S->glcap) {
    void *p = mo_realloc(ctx, S->gl, ((size_t)nfree + 1) * sizeof *S->gl);
    if (!p) return MO_ENOMEM;
    S->gl = p;
    S->glcap = (size_t)nfree + 1;
  }
  memcpy(S->gl, S->gi, (size_t)nfree * sizeof *S->gl);
  for (m = 0; m < S->nmine; m++) {
    const int o = S->ifc[S->mj[m]];
    const double f = split_factor(S->msrc0[m + 1] - S->msrc0[m]);
    for (i = 0; i < nk; i++) S->gl[o + i] = S->gi[o + i] * f;
  }
  S->gs = S->gl;
  return MO_OK;
}

int nscd_grains_prepare(nscd_state *S, const mo_contact_problem *P, mo_ctx *ctx)
{
  int st, differ;
  if (S->d != 2 && S->d != 3)
    return mo_error(ctx, MO_EINTERNAL, "nscd: granular contacts in dimension %d", S->d);
  if ((st = reserve(S, P, P->nfree, ctx)) || (st = inverse_diagonal(S, P->Wi, P->nfree, ctx))) return st;
  S->gs = S->gi;
  if (S->par && (st = split_masses(S, P->nfree, ctx))) return st;
  S->gw = REC(S, 0, S->d) + OFF_W(S->d); /* nscd_waa */
  S->gstride = RECSZ(S->d);
  /* over the ranks, the slab's records only: nscd_grains_partition has cut the slabs (T274) */
  S->gpart = S->par;
  /* the friction coefficients are the problem's (no copy: (T186)), P->mu's or the pairs' (T189),
     unless an active contact's differs */
  S->gkey = P->grains->key;
  S->gpmu = P->grains->pmu;
  differ = S->d == 2 ? prepare_d(S, P, 2) : prepare_d(S, P, 3);
  if (S->gpart && !S->muown) {
    /* each rank has seen its own contacts: the copy is made on every rank or on none (T275), so
       that the records made later for the others (T277) and the count (T279) read the same
       coefficients on every rank */
    double x = differ;
    if ((st = mo_par_max(&x, 1, ctx))) return st;
    differ = x > 0;
  }
  if (differ) {
    if (S->cap > S->mucap) {
      void *p = mo_realloc(ctx, S->muown, S->cap * sizeof *S->muown);
      if (!p) return MO_ENOMEM;
      S->muown = p;
      S->mucap = S->cap;
    }
    if (S->d == 2) prepare_d(S, P, 2);
    else prepare_d(S, P, 3);
  }
  S->mu = S->muown ? S->muown : P->mu;
  return MO_OK;
}

void nscd_grains_complete(nscd_state *S, const mo_contact_problem *P)
{
  const int split = S->gs != S->gi;
  int a;
  if (!S->gpart) return;
  /* the others' records as nscd_grains_prepare makes them on one process: the same numbers
     (T277); the rank's own W_aa again where an interface body's mass was divided (T332) */
  S->gs = S->gi;
  for (a = 0; a < S->nc; a++) {
    const int act = !P->active || P->active[a];
    if (!S->own[a]) {
      if (S->d == 2) record(S, P, a, act, 2);
      else record(S, P, a, act, 3);
    } else if (split) {
      /* W_aa alone, from the bodies' own masses: c_a does not depend on them, and q, which it
         is formed from, is U's place now (T240) */
      if (S->d == 2) record_w(S, P, a, 2);
      else record_w(S, P, a, 3);
    }
  }
  S->gpart = 0;
}

/* u += G_s v_s over one side of sign cf: the products (cf F_ik) v_k of the sweep on H are
   cf (F_ik v_k) to the bit, so the master side subtracts (rot: the moments without the sign). */
KERNEL void side_U(const int d, const double *F, const double *rot, const double *restrict v, int slave, double *u)
{
  int i, k;
  for (i = 0; i < d; i++) {
    double t = u[i];
    if (slave)
      for (k = 0; k < d; k++) t += F[i * d + k] * v[k];
    else
      for (k = 0; k < d; k++) t -= F[i * d + k] * v[k];
    if (slave)
      for (k = 0; k < NR(d); k++) t += rot[i * NR(d) + k] * v[d + k];
    else
      for (k = 0; k < NR(d); k++) t -= rot[i * NR(d) + k] * v[d + k];
    u[i] = t;
  }
}

/* Contact a's sides (gs), frame (F) and moments (rot), formed at its visit in the operations of
   nscd_grains_prepare (T188, T226). */
KERNEL void visit(const int d, const nscd_state *S, const mo_contact_problem *P, int a, int *gs, double *F,
                  double *rot)
{
  double w0[1];
  sides(P->grains, a, gs);
  geometry(d, S, P, a, gs, F, rot, 0, w0, NULL);
}

/* U_a = c_a + sum_s G_as v_s, gs, c, F and rot those of visit. */
KERNEL void local_U(const nscd_state *S, const int *gs, const double *c, const double *F, const double *rot,
                    double *restrict U, const int d)
{
  double u[3] = {0, 0, 0};
  int i;
  for (i = 0; i < d; i++) u[i] = c[i];
  if (gs[0]) {
    side_U(d, F, rot, S->vb + SIDE_O(gs[0]), gs[0] > 0, u);
    if (gs[1]) side_U(d, F, rot + d * NR(d), S->vb + SIDE_O(gs[1]), gs[1] > 0, u);
  }
  for (i = 0; i < d; i++) U[i] = u[i];
}

/* U_a with its rows formed here. */
KERNEL void contact_U(const nscd_state *S, const mo_contact_problem *P, int a, double *restrict U, const int d)
{
  double rot[2 * 3 * 3], F[9];
  int gs[2];
  visit(d, S, P, a, gs, F, rot);
  local_U(S, gs, R_C(REC(S, a, d)), F, rot, U, d);
}

/* v_s += inv_s G_s^T dr on one side: (inv_k (cf F_jk)) dr_j summed over j, that is cf times the
   same sum with F (to the bit). */
KERNEL void side_push(const int d, const double *F, const double *rot, const double *iv, double *restrict v,
                      int slave, const double *dr)
{
  int k, j;
  for (k = 0; k < d; k++) {
    double acc = 0;
    for (j = 0; j < d; j++) acc += iv[k] * F[j * d + k] * dr[j];
    if (slave) v[k] += acc;
    else v[k] -= acc;
  }
  for (k = 0; k < NR(d); k++) {
    double acc = 0;
    for (j = 0; j < d; j++) acc += iv[d + k] * (slave ? rot[j * NR(d) + k] : -rot[j * NR(d) + k]) * dr[j];
    v[d + k] += acc;
  }
}

KERNEL void push(nscd_state *S, const int *gs, const double *F, const double *rot, const double *dr, const int d)
{
  int o;
  if (!gs[0]) return;
  o = SIDE_O(gs[0]);
  side_push(d, F, rot, S->gs + o, S->vb + o, gs[0] > 0, dr);
  if (!gs[1]) return;
  o = SIDE_O(gs[1]);
  side_push(d, F, rot + d * NR(d), S->gs + o, S->vb + o, gs[1] > 0, dr);
}

KERNEL void push_r(nscd_state *S, const mo_contact_problem *P, int a, const double *dr, const int d)
{
  double Waa[1], rot[2 * 3 * 3], F[9];
  int gs[2];
  sides(P->grains, a, gs);
  geometry(d, S, P, a, gs, F, rot, 0, Waa, NULL);
  push(S, gs, F, rot, dr, d);
}

void nscd_grains_free_velocities(nscd_state *S, const mo_contact_problem *P)
{
  const mo_grains *G = P->grains;
  const int nk = NK(S->d);
  int k;
  if (!G || !G->hold) {
    memcpy(S->vb, P->xfree, (size_t)P->nfree * sizeof *S->vb);
    return;
  }
  /* the bodies' state per rank: the held bodies' (doc/theory.md §13.18) */
  for (k = 0; k < G->nhlist; k++) {
    const int o = G->vel[G->hlist[k]];
    if (o >= 0) memcpy(S->vb + o, P->xfree + o, (size_t)nk * sizeof *S->vb);
  }
}

void nscd_grains_velocities(nscd_state *S, const mo_contact_problem *P, const double *r)
{
  const double *split = S->gs;
  int a;
  S->gs = S->gi; /* v = v_free + M^-1 H r: the bodies' own masses (T332) */
  memcpy(S->vb, P->xfree, (size_t)P->nfree * sizeof *S->vb);
  /* a contact without reaction moves nothing (its push would add zeros) */
  if (S->d == 2) {
    for (a = 0; a < S->nc; a++)
      if (r[2 * a] != 0 || r[2 * a + 1] != 0) push_r(S, P, a, r + (size_t)a * 2, 2);
  } else
    for (a = 0; a < S->nc; a++)
      if (r[3 * a] != 0 || r[3 * a + 1] != 0 || r[3 * a + 2] != 0) push_r(S, P, a, r + (size_t)a * 3, 3);
  S->gs = split;
}

/* (T336) A body's velocity is v_free plus the pushes of the contacts that touch it, in the
   contacts' order: the pushes of the contacts touching the rank's bodies (its own, and the
   interface contacts touching its interface bodies), in that order, give its bodies' velocities
   to the bit (the other bodies' are not read by its sweep). */
void nscd_grains_velocities_part(nscd_state *S, const mo_contact_problem *P, const double *r)
{
  const double *split = S->gs;
  const int d = S->d;
  int k, i;
  S->gs = S->gi;
  nscd_grains_free_velocities(S, P);
  for (k = 0; k < S->nvlist; k++) {
    const int a = S->vlist[k];
    int nz = 0;
    for (i = 0; i < d; i++) nz |= r[(size_t)a * d + i] != 0;
    if (!nz) continue;
    if (d == 2) push_r(S, P, a, r + (size_t)a * 2, 2);
    else push_r(S, P, a, r + (size_t)a * 3, 3);
  }
  S->gs = split;
}

/* The pushes of contact a on its interface bodies only (its other side's velocity is its owner's,
   final already). */
KERNEL void push_ifc(nscd_state *S, const mo_contact_problem *P, int a, const double *dr, const int d)
{
  double Waa[1], rot[2 * 3 * 3], F[9];
  int gs[2], s;
  sides(P->grains, a, gs);
  geometry(d, S, P, a, gs, F, rot, 0, Waa, NULL);
  for (s = 0; s < 2 && gs[s]; s++) {
    const int o = SIDE_O(gs[s]);
    if (S->bmulti[o]) side_push(d, F, rot + s * d * NR(d), S->gs + o, S->vb + o, gs[s] > 0, dr);
  }
}

/* U_a without its record: c_a formed at the visit, in the operations of the record's (the same
   numbers, (T278)), then U_a = c_a + sum_s G_as v_s. */
KERNEL void fresh_U(const nscd_state *S, const mo_contact_problem *P, int a, double *restrict U, const int d)
{
  double rot[2 * 3 * 3], F[9], c[3], w0[1];
  int gs[2], i;
  sides(P->grains, a, gs);
  for (i = 0; i < d; i++) c[i] = P->b[a * d + i];
  geometry(d, S, P, a, gs, F, rot, 0, w0, c);
  local_U(S, gs, c, F, rot, U, d);
}

KERNEL void exact_U_d(nscd_state *S, const mo_contact_problem *P, const int d)
{
  int a;
  if (S->gpart) /* the others' records not made (T278) */
    for (a = 0; a < S->nc; a++) {
      if (S->own[a]) contact_U(S, P, a, S->U + (size_t)a * d, d);
      else fresh_U(S, P, a, S->U + (size_t)a * d, d);
    }
  else
    for (a = 0; a < S->nc; a++) contact_U(S, P, a, S->U + (size_t)a * d, d);
}

void nscd_grains_exact_U(nscd_state *S, const mo_contact_problem *P)
{
  if (S->d == 2) exact_U_d(S, P, 2);
  else exact_U_d(S, P, 3);
}

/* Contact a's terms of Jean's norms (T11) after its update dr (r_a now holds the new reaction):
   those of jean_parts (nscd.c) with r_a - rold_a = dr, in the same operations. */
KERNEL void jean_add(const int d, const double *Waa, const double *ra, const double *dr, double *jp)
{
  int i, j;
  double dU2 = 0, rr = 0, wrr = 0;
  for (i = 0; i < d; i++) {
    double wi = 0, di = 0;
    for (j = 0; j < d; j++) {
      di += Waa[i * d + j] * dr[j];
      wi += Waa[i * d + j] * ra[j];
    }
    dU2 += di * di;
    rr += ra[i] * ra[i];
    wrr += wi * ra[i];
  }
  if (rr > 0) jp[2]++;
  jp[0] += dU2 * rr;
  jp[1] += wrr;
  if (sqrt(dU2 * rr) > jp[3]) jp[3] = sqrt(dU2 * rr);
}

KERNEL int sweep_d(nscd_state *S, const mo_contact_problem *P, double *r, int *status, const int *order, int n,
                   const int d)
{
  const double omega = S->p.relax, *mu = S->mu, *pmu = S->gpmu;
  const int jw = S->jwant, *key = S->gkey;
  double jp[4] = {0, 0, 0, 0};
  int k, i, j;
  for (k = 0; k < n; k++) {
    const int a = order[k];
    const char *rec = REC(S, a, d);
    const double *Waa = R_W(rec, d);
    double *ra = r + (size_t)a * d, U[3], ql[3], rl[3], dr[3], rot[2 * 3 * 3], F[9], aux[NSCD_AUX];
    int st, nz = 0, gs[2];
    visit(d, S, P, a, gs, F, rot);
    local_U(S, gs, R_C(rec), F, rot, U, d);
    for (i = 0; i < d; i++) {
      double acc = U[i];
      for (j = 0; j < d; j++) acc -= Waa[i * d + j] * ra[j];
      ql[i] = acc;
      rl[i] = ra[i];
    }
    if (d == 2) {
      if (ql[0] >= 0) { /* open: nscd_local_2d_fast's first case, without the local data */
        rl[0] = rl[1] = 0;
        st = MO_CS_OPEN;
      } else { /* nscd_local_2d_fast's other cases, the slide denominators only when they are read */
        const double mua = mu ? mu[a] : pmu[key[(size_t)a * MO_KEY]]; /* (T189) */
        nscd_local_inverse_2d(Waa, aux);
        if (nscd_local_2d_stick(Waa, aux, ql, mua, rl)) st = MO_CS_STICK;
        else {
          nscd_local_slide_2d(Waa, mua, aux);
          st = nscd_local_2d(Waa, aux, ql, mua, rl);
        }
      }
    } else {
      const double mua = mu ? mu[a] : pmu[key[(size_t)a * MO_KEY]];
      nscd_local_prepare(3, Waa, mua, aux);
      st = nscd_local_3d(Waa, aux, ql, mua, rl, &S->lp, &S->lst);
    }
    if (st < 0) {
      if (jw) memcpy(S->jp, jp, sizeof jp); /* the parts of the contacts updated before it */
      return a;
    }
    status[a] = st;
    for (i = 0; i < d; i++) {
      if (omega != 1) rl[i] = omega * rl[i] + (1 - omega) * ra[i]; /* (T37) */
      dr[i] = rl[i] - ra[i];
      nz |= dr[i] != 0;
    }
    if (nz) {
      push(S, gs, F, rot, dr, d);
      for (i = 0; i < d; i++) ra[i] = rl[i];
    }
    /* a contact is updated once a sweep: r_a - rold_a is dr (0 when nz is 0) */
    if (jw) jean_add(d, Waa, ra, dr, jp);
  }
  if (jw) memcpy(S->jp, jp, sizeof jp);
  /* over the ranks, U waits for the interface velocities of the other ranks (nscd_grains_owned_U) */
  if (!S->par && (S->p.stop == NSCD_STOP_SCALED || S->p.stop == NSCD_STOP_NATURAL))
    for (k = 0; k < S->nact; k++) {
      const int a = S->act[k];
      contact_U(S, P, a, S->U + (size_t)a * d, d);
    }
  return -1;
}

int nscd_grains_sweep(nscd_state *S, const mo_contact_problem *P, double *r, int *status)
{
  return S->d == 2 ? sweep_d(S, P, r, status, S->order, S->nact, 2) : sweep_d(S, P, r, status, S->order, S->nact, 3);
}

/* --- over MPI ranks (doc/parallel.md §4) ------------------------------------------------------ */

static int count_list(nscd_state *S, const mo_contact_problem *P, const double *r, const int *list, int n, int *nu_,
                      int *nd_, mo_ctx *ctx);

/* Room for the per-contact and per-dof arrays of the split sweep. */
static int par_reserve(nscd_state *S, int nfree, mo_ctx *ctx)
{
  size_t nc = (size_t)S->nc + 1, nf = (size_t)nfree + 1, nr = (size_t)S->nranks + 1;
  void *p;
#define GROW(ptr, n) if (!(p = mo_realloc(ctx, ptr, (n)))) return MO_ENOMEM; ptr = p
  if (nc > S->pcap) {
    GROW(S->own, nc);
    GROW(S->oorder, nc * sizeof *S->oorder);
    GROW(S->apart, nc * sizeof *S->apart);
    GROW(S->ridx, nc * sizeof *S->ridx);
    GROW(S->cifc, nc);
    GROW(S->ilist, nc * sizeof *S->ilist);
    GROW(S->vlist, nc * sizeof *S->vlist);
    GROW(S->aside, 2 * nc * sizeof *S->aside);
    GROW(S->onil, nc * sizeof *S->onil);
    S->pcap = nc;
  }
  {
    /* the pattern's entries: 2 a contact (its sides), or those the distributed set's masks give */
    const size_t nkw = 2 * nc > S->kwant ? 2 * nc : S->kwant;
    if (nkw > S->kcap) {
      GROW(S->pkey, nkw * sizeof *S->pkey);
      GROW(S->pj, nkw * sizeof *S->pj);
      GROW(S->msrc, nkw * sizeof *S->msrc);
      GROW(S->pe, nkw * sizeof *S->pe);
      S->kcap = nkw;
    }
  }
  if (nf > S->pncap) {
    GROW(S->ifc, nf * sizeof *S->ifc);
    GROW(S->bfirst, nf * sizeof *S->bfirst);
    GROW(S->bmulti, nf);
    GROW(S->ibase, nf * sizeof *S->ibase);
    GROW(S->ipos, nf * sizeof *S->ipos);
    GROW(S->mj, nf * sizeof *S->mj);
    GROW(S->msrc0, nf * sizeof *S->msrc0);
    S->pncap = nf;
  }
  if (nf + 16 > S->pbcap) {
    GROW(S->pbuf, (nf + 16) * sizeof *S->pbuf);
    S->pbcap = nf + 16;
  }
  if (!S->peer) {
    GROW(S->peer, nr * sizeof *S->peer);
    GROW(S->poff, nr * sizeof *S->poff);
    GROW(S->pcnt, nr * sizeof *S->pcnt);
    GROW(S->gcnt, nr * sizeof *S->gcnt);
  }
#undef GROW
  return MO_OK;
}

static int cmp_int(const void *a, const void *b)
{
  int x = *(const int *)a, y = *(const int *)b;
  return x < y ? -1 : x > y;
}

static int cmp_long(const void *a, const void *b)
{
  long x = *(const long *)a, y = *(const long *)b;
  return x < y ? -1 : x > y;
}

/* The point-to-point pattern of the interface sums on more than 2 ranks (T331), from the parts
   every rank holds: each interface body's ranks (the parts of the active contacts touching it),
   the peers this rank shares bodies with, and the order of their values. */
static int pattern_of_keys(nscd_state *S, long nkey, mo_ctx *ctx);

static int exchange_pattern(nscd_state *S, const mo_contact_problem *P, mo_ctx *ctx)
{
  const int nr = S->nranks;
  long nkey = 0, k;
  int j, s;
  (void)P;
  for (j = 0; j < S->nifc; j++) S->ipos[S->ifc[j]] = j;
  /* (interface body, rank) for every side of an active contact on an interface body */
  for (k = 0; k < S->nact; k++)
    for (s = 0; s < 2; s++) {
      const int o = S->aside[2 * k + s];
      if (o >= 0 && S->bmulti[o]) S->pkey[nkey++] = (long)S->ipos[o] * nr + S->apart[k];
    }
  return pattern_of_keys(S, nkey, ctx);
}

/* The pattern from its keys pkey[0 .. nkey) (ifc index x nranks + rank, repeats allowed). */
static int pattern_of_keys(nscd_state *S, long nkey, mo_ctx *ctx)
{
  const int nk = NK(S->d), me = S->rank, nr = S->nranks;
  long k, e = 0, t;
  int i, j, ns = 0;
  qsort(S->pkey, (size_t)nkey, sizeof *S->pkey, cmp_long);
  /* per body of this rank: its ranks in increasing order; per entry to another rank, its peer */
  S->nmine = 0;
  for (i = 0; i <= nr; i++) S->pcnt[i] = 0;
  for (k = 0; k < nkey;) {
    long k1 = k;
    int mine = 0, nq = 0;
    j = (int)(S->pkey[k] / nr);
    while (k1 < nkey && S->pkey[k1] / nr == j) {
      mine |= S->pkey[k1] % nr == me;
      nq += k1 == k || S->pkey[k1] != S->pkey[k1 - 1];
      k1++;
    }
    if (nq > 2) ctx->par_grain_multi++;
    if (mine) {
      S->mj[S->nmine] = j;
      S->msrc0[S->nmine++] = ns;
      for (t = k; t < k1; t++) {
        int q = (int)(S->pkey[t] % nr);
        if (t > k && S->pkey[t] == S->pkey[t - 1]) continue;
        if (q == me) S->msrc[ns++] = -1;
        else {
          S->pj[e] = j;
          S->pe[e] = q; /* the peer, until the entries are ordered by peer */
          S->pcnt[q]++;
          S->msrc[ns++] = (int)e++;
        }
      }
    }
    k = k1;
  }
  S->msrc0[S->nmine] = ns;
  /* the entries ordered by peer (stable: by body within a peer, as the peer orders them) */
  S->npeer = 0;
  {
    int q, at = 0;
    for (q = 0; q < nr; q++) {
      int c = S->pcnt[q];
      S->pcnt[q] = at;
      if (c) {
        S->peer[S->npeer] = q;
        S->poff[S->npeer++] = at * nk;
      }
      at += c;
    }
    S->poff[S->npeer] = at * nk;
  }
  {
    /* place of entry e in peer order; the bodies' list in that order */
    size_t need = (size_t)e * nk + 1;
    if (need > S->xcap) {
      void *p;
      if (!(p = mo_realloc(ctx, S->sbuf, need * sizeof *S->sbuf))) return MO_ENOMEM;
      S->sbuf = p;
      if (!(p = mo_realloc(ctx, S->rbuf, need * sizeof *S->rbuf))) return MO_ENOMEM;
      S->rbuf = p;
      S->xcap = need;
    }
    for (t = 0; t < e; t++) {
      int place = S->pcnt[S->pe[t]]++;
      S->pe[t] = place;
    }
    /* pj in peer order (the keys' array is free now) */
    for (t = 0; t < e; t++) S->pkey[S->pe[t]] = S->pj[t];
    for (t = 0; t < e; t++) S->pj[t] = (int)S->pkey[t];
    for (t = 0; t < ns; t++)
      if (S->msrc[t] >= 0) S->msrc[t] = S->pe[S->msrc[t]] * nk;
  }
  return MO_OK;
}

/* The parts: the active contacts' points cut into `nranks` boxes of equal counts by recursive
   bisection (mo_rcb, (T330); with 2 ranks one cut across the largest extent, the slabs of
   (T215)), every rank computing the same cut from the same replicated data; a contact is swept by
   its point's part. A body touched by contacts of more than one part is an interface body. */
int nscd_grains_partition(nscd_state *S, const mo_contact_problem *P, mo_ctx *ctx)
{
  const mo_grains *G = P->grains;
  int k, i, st;
  S->nranks = ctx->nranks;
  S->rank = ctx->rank;
  S->par = ctx->nranks > 1;
  if (!S->par) return MO_OK;
  if ((st = par_reserve(S, P->nfree, ctx))) return st;
  /* (T341) each contact swept by the rank that detected it (its point's box, cut at the list's
     build from the points of the last solve's active contacts); without the detection's owners,
     the active contacts' points cut here */
  for (k = 0; G->cown && k < S->nact && G->cown[S->act[k]] >= 0 && G->cown[S->act[k]] < S->nranks; k++)
    S->apart[k] = G->cown[S->act[k]];
  if (G->cown && k == S->nact) ctx->par_grain_detparts++;
  else mo_rcb(G->D, S->nact, G->x, S->act, NULL, S->nranks, S->apart, S->ridx);
  memset(S->own, 0, (size_t)S->nc);
  for (i = 0; i < P->nfree; i++) {
    S->bfirst[i] = -1;
    S->bmulti[i] = 0;
  }
  for (i = 0; i < S->nranks; i++) S->pcnt[i] = 0;
  for (k = 0; k < S->nact; k++) {
    const int a = S->act[k], q = S->apart[k];
    int gs[2], s;
    sides(G, a, gs);
    S->own[a] = q == S->rank;
    S->pcnt[q]++;
    S->aside[2 * k] = S->aside[2 * k + 1] = -1;
    for (s = 0; s < 2 && gs[s]; s++) {
      int o = SIDE_O(gs[s]);
      S->aside[2 * k + s] = o;
      if (S->bfirst[o] < 0) S->bfirst[o] = q;
      else if (S->bfirst[o] != q) {
        S->bmulti[o] = 1;
        if (q < S->bfirst[o]) S->bfirst[o] = q;
      }
    }
  }
  for (S->nifc = 0, i = 0; i < P->nfree; i++)
    if (S->bmulti[i]) S->ifc[S->nifc++] = i;
  for (S->noact = 0, k = 0; k < S->nact; k++)
    if (S->own[S->order[k]]) S->oorder[S->noact++] = S->order[k];
  /* (T336) the interface contacts, and those whose reactions reach the rank's bodies */
  for (S->nilist = S->nvlist = 0, k = 0; k < S->nact; k++) {
    const int a = S->act[k], o0 = S->aside[2 * k], o1 = S->aside[2 * k + 1];
    const int f = (o0 >= 0 && S->bmulti[o0]) || (o1 >= 0 && S->bmulti[o1]);
    S->cifc[a] = (unsigned char)f;
    if (f) S->ilist[S->nilist++] = a;
    if (f || S->own[a]) S->vlist[S->nvlist++] = a;
  }
  /* (T340) the rank's own contacts off the interface, in the sweep's order */
  for (S->nonil = 0, k = 0; k < S->noact; k++)
    if (!S->cifc[S->oorder[k]]) S->onil[S->nonil++] = S->oorder[k];
  {
    /* the sum of a sweep: the interface increments, the rule's parts, and on 2 ranks (T340) the
       residual's parts off the interface and the interface contacts' reactions */
    size_t need = (size_t)S->nifc * NK(S->d) + 16 + (size_t)(S->d + NK(S->d)) * S->nilist;
    void *p;
    if (need > S->pbcap) {
      if (!(p = mo_realloc(ctx, S->pbuf, need * sizeof *S->pbuf))) return MO_ENOMEM;
      S->pbuf = p;
      S->pbcap = need;
    }
    need = 3 + (size_t)(2 * S->d + NK(S->d)) * S->nilist + 1;
    if (need > S->nbcap) {
      if (!(p = mo_realloc(ctx, S->nbuf, need * sizeof *S->nbuf))) return MO_ENOMEM;
      S->nbuf = p;
      S->nbcap = need;
    }
  }
  {
    /* the parts' balance */
    long most = 0;
    for (i = 0; i < S->nranks; i++)
      if (S->pcnt[i] > most) most = S->pcnt[i];
    ctx->par_grain_solves++;
    ctx->par_grain_interface += S->nifc;
    ctx->par_grain_imbalance += S->nact ? (double)most * S->nranks / S->nact : 1.0;
  }
  S->xchg = S->nranks > 2;
  return S->xchg ? exchange_pattern(S, P, ctx) : MO_OK;
}

/* The gather's layout from the blocks' sizes S->gcnt: each rank's block's start in cur, the room in
   S->gbuf for every block and the rank's own after them; *all and *mine in it. */
static int gather_room(nscd_state *S, int *cur, double **all, double **mine, mo_ctx *ctx)
{
  size_t tot = 0;
  int q;
  for (q = 0; q < S->nranks; q++) {
    cur[q] = (int)tot;
    tot += (size_t)S->gcnt[q];
  }
  if (tot + (size_t)S->gcnt[S->rank] + 1 > S->gbcap) {
    void *p = mo_realloc(ctx, S->gbuf, (tot + (size_t)S->gcnt[S->rank] + 1) * sizeof *S->gbuf);
    if (!p) return MO_ENOMEM;
    S->gbuf = p;
    S->gbcap = tot + (size_t)S->gcnt[S->rank] + 1;
  }
  *all = S->gbuf;
  *mine = S->gbuf + tot;
  return MO_OK;
}

/* The count's numbers at the end of a block (T279): the rank's closed unknowns and dofs, then the
   interface bodies its closed contacts move (a body that no other rank's contact touches is counted
   by one rank at most; an interface body by every rank whose closed contacts move it: joined by
   their marks). */
static void count_pack(const nscd_state *S, double *at, int nu, int nd)
{
  const int nk = NK(S->d);
  int i;
  for (i = 0; i < S->nifc; i++) {
    at[2 + i] = S->bmark[S->ifc[i]];
    if (S->bmark[S->ifc[i]]) nd -= nk;
  }
  at[0] = nu;
  at[1] = nd;
}

/* The count over the ranks from the gathered blocks, cur[q] at rank q's numbers. */
static void count_join(const nscd_state *S, const double *all, const int *cur, int *unknowns, int *dofs)
{
  const int nk = NK(S->d);
  double su = 0, sd = 0;
  int q, i;
  *dofs = 0;
  for (q = 0; q < S->nranks; q++) {
    su += all[cur[q]];
    sd += all[cur[q] + 1];
  }
  for (i = 0; i < S->nifc; i++) {
    double m = 0;
    for (q = 0; q < S->nranks; q++) m += all[cur[q] + 2 + i];
    if (m > 0) *dofs += nk;
  }
  *unknowns = (int)su;
  *dofs += (int)sd;
}

/* --- the distributed set (doc/scaling.md §4) ------------------------------------------------------
   Every active contact of the problem is the rank's own: no rank holds another's. The bodies its
   contacts touch are told the other ranks by one sum over the bodies (2^rank from each rank that
   touches a body: the set of its ranks, exact in a double up to 52 ranks), the interface then
   goes point to point between the ranks that share each body as on more than 2 ranks (T331), and
   the end of the solve gathers the bodies' velocities, each from the lowest rank that touches it:
   no contact's values leave its rank. */
#define DIST_MAX_RANKS 52

/* The bodies' state per rank: the ranks whose contacts touch each held body (bm, 2^rank each),
   from this rank's own touches (set by the caller) and a flag from each rank that holds the body
   too (sh_b's lists, the same on both sides: one value each way a shared body); the active
   contacts' counts of the ranks (bm[nslot ..], the balance's figure) by one sum of a value a rank. */
static int touch_held(nscd_state *S, const mo_contact_problem *P, mo_ctx *ctx)
{
  const mo_grains *G = P->grains;
  const int nk = NK(S->d), np = S->nranks, *off = G->sh_off;
  const size_t tot = (size_t)off[np];
  int q, t, st, npeer = 0;
  if ((size_t)(3 * np + 2) > S->hxcap) {
    void *p = mo_realloc(ctx, S->hx, (size_t)(6 * np + 2) * sizeof *S->hx);
    if (!p) return MO_ENOMEM;
    S->hx = p;
    S->hxcap = (size_t)(6 * np + 2);
  }
  if (2 * tot + (size_t)np + 1 > S->hbcap) {
    void *p = mo_realloc(ctx, S->hbuf, (2 * tot + (size_t)np + 1) * sizeof *S->hbuf);
    if (!p) return MO_ENOMEM;
    S->hbuf = p;
    S->hbcap = 2 * tot + (size_t)np + 1;
  }
  {
    int *peer = S->hx, *poff = S->hx + np;
    double *snd = S->hbuf, *rcv = S->hbuf + tot;
    for (q = 0; q < np; q++)
      if (off[q + 1] > off[q]) {
        peer[npeer] = q;
        poff[npeer++] = off[q];
      }
    poff[npeer] = (int)tot;
    for (t = 0; t < (int)tot; t++) {
      const int o = G->vel[G->sh_b[t]];
      snd[t] = o >= 0 && S->bm[o / nk] > 0;
    }
    if ((st = mo_par_exchange(npeer, peer, poff, snd, rcv, ctx))) return st;
    for (q = 0; q < np; q++)
      for (t = off[q]; t < off[q + 1]; t++) {
        const int o = G->vel[G->sh_b[t]];
        if (o >= 0 && rcv[t] != 0) S->bm[o / nk] += ldexp(1.0, q);
      }
  }
  return MO_OK;
}

/* The figures of the balance with the bodies' state per rank: each rank's active contacts
   (bm[nslot + q]) and the interface bodies each counted by its lowest rank, in one sum. */
static int touch_counts(nscd_state *S, const mo_contact_problem *P, int nfirst, mo_ctx *ctx)
{
  const int nk = NK(S->d), np = S->nranks, nslot = P->nfree / nk;
  double *cnt = S->hbuf;
  int q, st;
  for (q = 0; q <= np; q++) cnt[q] = 0;
  cnt[S->rank] = S->nact;
  cnt[np] = nfirst;
  if ((st = mo_par_sum(cnt, np + 1, ctx))) return st;
  for (q = 0; q < np; q++) S->bm[nslot + q] = cnt[q];
  S->nifc_all = (int)cnt[np];
  return MO_OK;
}

int nscd_grains_partition_dist(nscd_state *S, const mo_contact_problem *P, mo_ctx *ctx)
{
  const mo_grains *G = P->grains;
  const int nk = NK(S->d), me = ctx->rank, nr = ctx->nranks, nslot = P->nfree / nk;
  const double bit = ldexp(1.0, me);
  long nkey = 0, most = 0, total = 0;
  int k, i, j, st;
  S->nranks = nr;
  S->rank = me;
  S->par = 1;
  S->dist = 1;
  if (nr > DIST_MAX_RANKS)
    return mo_error(ctx, MO_ELIMIT, "contact.distributed_set over %d ranks (at most %d)", nr, DIST_MAX_RANKS);
  if ((st = par_reserve(S, P->nfree, ctx))) return st;
  if ((size_t)(nslot + nr) + 1 > S->bmscap) {
    void *p = mo_realloc(ctx, S->bm, ((size_t)(nslot + nr) + 1) * sizeof *S->bm);
    if (!p) return MO_ENOMEM;
    S->bm = p;
    S->bmscap = (size_t)(nslot + nr) + 1;
  }
  if (G->hold)
    /* the bodies' state per rank: only the held bodies' masks are read (§13.18) */
    for (k = 0; k < G->nhlist; k++) {
      const int o = G->vel[G->hlist[k]];
      if (o < 0) continue;
      S->bm[o / nk] = 0;
      S->bfirst[o] = -1;
      S->bmulti[o] = 0;
    }
  else
    memset(S->bm, 0, (size_t)(nslot + nr) * sizeof *S->bm);
  memset(S->own, 0, (size_t)S->nc);
  for (k = 0; k < S->nact; k++) {
    const int a = S->act[k];
    int gs[2], s;
    sides(G, a, gs);
    S->own[a] = 1;
    S->apart[k] = me;
    S->aside[2 * k] = S->aside[2 * k + 1] = -1;
    for (s = 0; s < 2 && gs[s]; s++) {
      const int o = SIDE_O(gs[s]);
      if (o % nk) return mo_error(ctx, MO_EINTERNAL, "nscd: a body's velocities at %d, not a multiple of %d", o, nk);
      S->aside[2 * k + s] = o;
      S->bm[o / nk] = bit;
    }
  }
  S->nifc = 0;
  if (G->hold) {
    /* the bodies' state per rank: each held body's ranks from the ranks that hold it too, a flag
       each way for every body two ranks both hold (point to point), not a sum over every body */
    int nfirst = 0;
    if ((st = touch_held(S, P, ctx))) return st;
    for (k = 0; k < G->nhlist; k++) {
      const int o = G->vel[G->hlist[k]];
      unsigned long long msk;
      if (o < 0 || !(S->bm[o / nk] > 0)) continue;
      msk = (unsigned long long)S->bm[o / nk];
      S->bfirst[o] = __builtin_ctzll(msk);
      if (msk & (msk - 1)) {
        S->bmulti[o] = 1;
        S->ifc[S->nifc++] = o;
        nfirst += S->bfirst[o] == me;
      }
    }
    /* in the bodies' order on every rank (the pattern pairs two ranks' entries by it) */
    qsort(S->ifc, (size_t)S->nifc, sizeof *S->ifc, cmp_int);
    if ((st = touch_counts(S, P, nfirst, ctx))) return st;
  } else {
    S->bm[nslot + me] = S->nact;
    if ((st = mo_par_sum(S->bm, nslot + nr, ctx))) return st;
    for (i = 0; i < P->nfree; i++) {
      S->bfirst[i] = -1;
      S->bmulti[i] = 0;
    }
    for (j = 0; j < nslot; j++)
      if (S->bm[j] > 0) {
        const unsigned long long msk = (unsigned long long)S->bm[j];
        const int o = j * nk;
        S->bfirst[o] = __builtin_ctzll(msk);
        if (msk & (msk - 1)) {
          S->bmulti[o] = 1;
          S->ifc[S->nifc++] = o;
        }
      }
  }
  for (S->noact = 0, k = 0; k < S->nact; k++) S->oorder[S->noact++] = S->order[k];
  for (S->nilist = S->nvlist = 0, k = 0; k < S->nact; k++) {
    const int a = S->act[k], o0 = S->aside[2 * k], o1 = S->aside[2 * k + 1];
    const int f = (o0 >= 0 && S->bmulti[o0]) || (o1 >= 0 && S->bmulti[o1]);
    S->cifc[a] = (unsigned char)f;
    if (f) S->ilist[S->nilist++] = a;
    S->vlist[S->nvlist++] = a;
  }
  for (S->nonil = 0, k = 0; k < S->noact; k++)
    if (!S->cifc[S->oorder[k]]) S->onil[S->nonil++] = S->oorder[k];
  {
    size_t need = (size_t)S->nifc * nk + 16;
    void *p;
    if (need > S->pbcap) {
      if (!(p = mo_realloc(ctx, S->pbuf, need * sizeof *S->pbuf))) return MO_ENOMEM;
      S->pbuf = p;
      S->pbcap = need;
    }
  }
  for (i = 0; i < nr; i++) {
    const long c = (long)S->bm[nslot + i];
    total += c;
    if (c > most) most = c;
  }
  ctx->par_grain_solves++;
  ctx->par_grain_detparts++;
  ctx->par_grain_interface += G->hold ? S->nifc_all : S->nifc;
  ctx->par_grain_imbalance += total ? (double)most * nr / (double)total : 1.0;
  /* the pattern: (interface body, rank) for each rank touching each interface body this rank
     touches, from the masks */
  for (j = 0; j < S->nifc; j++) {
    const unsigned long long msk = (unsigned long long)S->bm[S->ifc[j] / nk];
    if (msk >> me & 1) nkey += __builtin_popcountll(msk);
  }
  if ((size_t)nkey > S->kcap) {
    S->kwant = (size_t)nkey;
    if ((st = par_reserve(S, P->nfree, ctx))) return st;
  }
  nkey = 0;
  for (j = 0; j < S->nifc; j++) {
    const unsigned long long msk = (unsigned long long)S->bm[S->ifc[j] / nk];
    int q;
    if (!(msk >> me & 1)) continue;
    for (q = 0; q < nr; q++)
      if (msk >> q & 1) S->pkey[nkey++] = (long)j * nr + q;
  }
  S->xchg = 1;
  return pattern_of_keys(S, nkey, ctx);
}

/* The velocities of the rank's interface bodies summed over the ranks that touch them, from their
   increments over the free velocities, each rank's made with the bodies' own masses: v = v_free +
   the sum of every rank's pushes, the same on each (the ranks' increments in increasing order). */
static int exchange_plain(nscd_state *S, const mo_contact_problem *P, mo_ctx *ctx)
{
  const int nk = NK(S->d);
  int m, i, t, st, nv = S->poff[S->npeer] / nk;
  for (t = 0; t < nv; t++) {
    const int o = S->ifc[S->pj[t]];
    for (i = 0; i < nk; i++) S->sbuf[(size_t)t * nk + i] = S->vb[o + i] - P->xfree[o + i];
  }
  if ((st = mo_par_exchange(S->npeer, S->peer, S->poff, S->sbuf, S->rbuf, ctx))) return st;
  for (m = 0; m < S->nmine; m++) {
    const int o = S->ifc[S->mj[m]], s0 = S->msrc0[m], s1 = S->msrc0[m + 1];
    for (i = 0; i < nk; i++) {
      const double own = S->vb[o + i] - P->xfree[o + i];
      double sum = S->msrc[s0] < 0 ? own : S->rbuf[S->msrc[s0] + i];
      for (t = s0 + 1; t < s1; t++) sum += S->msrc[t] < 0 ? own : S->rbuf[S->msrc[t] + i];
      S->vb[o + i] = P->xfree[o + i] + sum;
    }
  }
  return MO_OK;
}

int nscd_grains_velocities_dist(nscd_state *S, const mo_contact_problem *P, const double *r, mo_ctx *ctx)
{
  nscd_grains_velocities_part(S, P, r);
  return exchange_plain(S, P, ctx);
}

static int end_held(nscd_state *S, const mo_contact_problem *P, mo_ctx *ctx);

/* The redundancy count's join with the bodies' state per rank (T279; each rank's interface list its
   own): the marks of the interface bodies each rank's closed contacts move, to the ranks touching
   them (the sweep's pattern), each such body's dofs counted once, by the lowest rank touching it,
   when any rank marks it; then one sum of the ranks' unknowns and dofs. */
static int count_held(nscd_state *S, int nu, int nd, int *unknowns, int *dofs, mo_ctx *ctx)
{
  const int nk = NK(S->d), nv = S->poff[S->npeer] / nk;
  double v[2];
  int t, m, st;
  for (t = 0; t < nv; t++) {
    S->sbuf[(size_t)t * nk] = S->bmark[S->ifc[S->pj[t]]];
    for (m = 1; m < nk; m++) S->sbuf[(size_t)t * nk + m] = 0;
  }
  if ((st = mo_par_exchange(S->npeer, S->peer, S->poff, S->sbuf, S->rbuf, ctx))) return st;
  for (t = 0; t < S->nifc; t++)
    if (S->bmark[S->ifc[t]]) nd -= nk;
  for (m = 0; m < S->nmine; m++) {
    const int o = S->ifc[S->mj[m]];
    int any = S->bmark[o] != 0;
    for (t = S->msrc0[m]; t < S->msrc0[m + 1] && !any; t++) any = S->msrc[t] >= 0 && S->rbuf[S->msrc[t]] != 0;
    if (any && S->bfirst[o] == S->rank) nd += nk;
  }
  v[0] = nu;
  v[1] = nd;
  if ((st = mo_par_sum(v, 2, ctx))) return st;
  *unknowns = (int)v[0];
  *dofs = (int)v[1];
  return MO_OK;
}

/* The end of a solve over the distributed set: the exact velocities of the bodies the rank's
   contacts touch (its pushes from v_free with the bodies' masses, the interface's summed), every
   body's velocity gathered from the lowest rank touching it, then U of the rank's candidates
   (records for the active ones, c_a formed for the others); with unknowns, the redundancy count
   joined as in nscd_grains_gather. */
int nscd_grains_gather_dist(nscd_state *S, const mo_contact_problem *P, double *r, int *unknowns, int *dofs,
                            mo_ctx *ctx)
{
  const int nk = NK(S->d), np = S->nranks, nx = unknowns ? 2 + S->nifc : 0;
  size_t at = 0;
  double *all, *mine;
  int i, l, q, st, nu = 0, nd = 0, *cur = S->pcnt;
  if (unknowns && (st = count_list(S, P, r, S->oorder, S->noact, &nu, &nd, ctx))) return st;
  if ((st = nscd_grains_velocities_dist(S, P, r, ctx))) return st;
  if (P->grains->hold) {
    /* the bodies' state per rank: the held bodies' velocities point to point; the count's numbers
       alone gathered */
    if ((st = end_held(S, P, ctx))) return st;
    if (unknowns && (st = count_held(S, nu, nd, unknowns, dofs, ctx))) return st;
    nscd_grains_exact_U(S, P);
    return MO_OK;
  }
  for (q = 0; q < np; q++) S->gcnt[q] = nx;
  for (i = 0; i < P->nfree; i++)
    if (S->bfirst[i] >= 0) S->gcnt[S->bfirst[i]] += i + nk <= P->nfree ? nk : P->nfree - i;
  if ((st = gather_room(S, cur, &all, &mine, ctx))) return st;
  for (i = 0; i < P->nfree; i++)
    if (S->bfirst[i] == S->rank)
      for (l = 0; l < nk && i + l < P->nfree; l++) mine[at++] = S->vb[i + l];
  if (unknowns) count_pack(S, mine + at, nu, nd);
  if ((st = mo_par_gatherv(mine, S->gcnt, all, ctx))) return st;
  for (i = 0; i < P->nfree; i++) {
    if (S->bfirst[i] < 0) {
      S->vb[i] = P->xfree[i] + 0.0;
      continue;
    }
    {
      const double *b = all + cur[S->bfirst[i]];
      for (l = 0; l < nk && i + l < P->nfree; l++) S->vb[i + l] = b[l];
      cur[S->bfirst[i]] += l;
      i += l - 1;
    }
  }
  if (unknowns) count_join(S, all, cur, unknowns, dofs);
  /* U of the rank's candidates from every body's velocity: an open candidate may touch a body only
     another rank's contacts move */
  nscd_grains_exact_U(S, P);
  return MO_OK;
}

/* The end of a solve with the bodies' state per rank (doc/theory.md §13.18): each body a rank holds
   takes its velocity from the lowest rank whose contacts touch it, sent point to point to the
   holders that do not touch it (the rank touching it has it exact already; a body no contact
   touches keeps its free velocity, which every holder computed). No body's velocity goes to a rank
   that does not hold it. */
static int end_held(nscd_state *S, const mo_contact_problem *P, mo_ctx *ctx)
{
  const mo_grains *G = P->grains;
  const int nk = NK(S->d), np = S->nranks, me = S->rank;
  int *sc, *rc, *so, *ro, *sp, *rp, ns = 0, nr = 0, k, q, i, st;
  size_t ts = 0, tr = 0;
  if ((size_t)(6 * np + 2) > S->hxcap) {
    void *p = mo_realloc(ctx, S->hx, (size_t)(6 * np + 2) * sizeof *S->hx);
    if (!p) return MO_ENOMEM;
    S->hx = p;
    S->hxcap = (size_t)(6 * np + 2);
  }
  sc = S->hx;
  rc = sc + np;
  so = rc + np;
  ro = so + np + 1;
  sp = ro + np + 1;
  rp = sp + np;
  for (q = 0; q < np; q++) sc[q] = rc[q] = 0;
  for (k = 0; k < G->nhlist; k++) {
    const int b = G->hlist[k], o = G->vel[b];
    unsigned long long t, send;
    if (o < 0) continue;
    t = (unsigned long long)S->bm[o / nk];
    if (!t) continue;
    if (S->bfirst[o] == me) {
      send = G->hold[b] & ~t;
      for (q = 0; q < np; q++) sc[q] += (int)(send >> q & 1);
    } else if (!(t >> me & 1))
      rc[S->bfirst[o]]++;
  }
  for (q = 0; q < np; q++) {
    if (sc[q]) {
      sp[ns] = q;
      so[ns++] = (int)ts;
      ts += (size_t)sc[q] * nk;
    }
    if (rc[q]) {
      rp[nr] = q;
      ro[nr++] = (int)tr;
      tr += (size_t)rc[q] * nk;
    }
  }
  so[ns] = (int)ts;
  ro[nr] = (int)tr;
  if (ts + tr + 1 > S->hbcap) {
    void *p = mo_realloc(ctx, S->hbuf, (ts + tr + 1) * sizeof *S->hbuf);
    if (!p) return MO_ENOMEM;
    S->hbuf = p;
    S->hbcap = ts + tr + 1;
  }
  /* each peer's cursor (values): sends from their block's start, receives likewise */
  for (q = 0, k = 0; q < np; q++) sc[q] = sc[q] ? so[k++] : 0;
  for (q = 0, k = 0; q < np; q++) rc[q] = rc[q] ? ro[k++] : 0;
  for (k = 0; k < G->nhlist; k++) {
    const int b = G->hlist[k], o = G->vel[b];
    unsigned long long t, send;
    if (o < 0 || S->bfirst[o] != me) continue;
    t = (unsigned long long)S->bm[o / nk];
    send = G->hold[b] & ~t;
    for (q = 0; q < np; q++)
      if (send >> q & 1) {
        for (i = 0; i < nk; i++) S->hbuf[sc[q] + i] = S->vb[o + i];
        sc[q] += nk;
      }
  }
  if ((st = mo_par_exchangev(ns, sp, so, S->hbuf, nr, rp, ro, S->hbuf + ts, ctx))) return st;
  for (k = 0; k < G->nhlist; k++) {
    const int b = G->hlist[k], o = G->vel[b];
    unsigned long long t;
    if (o < 0) continue;
    t = (unsigned long long)S->bm[o / nk];
    if (!t || (t >> me & 1)) continue;
    q = S->bfirst[o];
    for (i = 0; i < nk; i++) S->vb[o + i] = S->hbuf[ts + rc[q] + i];
    rc[q] += nk;
  }
  return MO_OK;
}

int nscd_grains_sweep_owned(nscd_state *S, const mo_contact_problem *P, double *r, int *status)
{
  const int nk = NK(S->d);
  int j, i, m;
  /* the interface velocities before the sweep: the ranks' increments are summed after it (on
     more than 2 ranks those of the rank's own interface bodies only, T331) */
  if (S->xchg)
    for (m = 0; m < S->nmine; m++) {
      j = S->mj[m];
      for (i = 0; i < nk; i++) S->ibase[(size_t)j * nk + i] = S->vb[S->ifc[j] + i];
    }
  else
    for (j = 0; j < S->nifc; j++)
      for (i = 0; i < nk; i++) S->ibase[(size_t)j * nk + i] = S->vb[S->ifc[j] + i];
  return S->d == 2 ? sweep_d(S, P, r, status, S->oorder, S->noact, 2)
                   : sweep_d(S, P, r, status, S->oorder, S->noact, 3);
}

/* (T340) The interface contacts' values joined to a 2-rank sum, d + NK(d) a contact: the reactions
   (d each, first), then the velocity of the side off the interface (an interface contact touches
   at most one such body, whose velocity only its rank's contacts change); the rank's own contacts'
   values, zeros for the other's. After the sum, the other rank's velocities written in vb (a body
   this rank's sweep does not read): every rank then forms the same U of every interface contact. */
int nscd_grains_ifc_count(const nscd_state *S) { return (S->d + NK(S->d)) * S->nilist; }

void nscd_grains_ifc_pack(const nscd_state *S, const mo_contact_problem *P, const double *r, double *x)
{
  const int d = S->d, nk = NK(d);
  double *xv = x + (size_t)d * S->nilist;
  int k, i, s, gs[2];
  for (k = 0; k < S->nilist; k++) {
    const int a = S->ilist[k];
    for (i = 0; i < d; i++) x[(size_t)k * d + i] = S->own[a] ? r[(size_t)a * d + i] : 0;
    for (i = 0; i < nk; i++) xv[(size_t)k * nk + i] = 0;
    if (!S->own[a]) continue;
    sides(P->grains, a, gs);
    for (s = 0; s < 2 && gs[s]; s++)
      if (!S->bmulti[SIDE_O(gs[s])])
        for (i = 0; i < nk; i++) xv[(size_t)k * nk + i] = S->vb[SIDE_O(gs[s]) + i];
  }
}

void nscd_grains_ifc_unpack(nscd_state *S, const mo_contact_problem *P, const double *x)
{
  const int d = S->d, nk = NK(d);
  const double *xv = x + (size_t)d * S->nilist;
  int k, i, s, gs[2];
  for (k = 0; k < S->nilist; k++) {
    const int a = S->ilist[k];
    if (S->own[a]) continue;
    sides(P->grains, a, gs);
    /* (the owner keeps its own: the same value, but for the sign of a zero, which no product
       below changes) */
    for (s = 0; s < 2 && gs[s]; s++)
      if (!S->bmulti[SIDE_O(gs[s])])
        for (i = 0; i < nk; i++) S->vb[SIDE_O(gs[s]) + i] = xv[(size_t)k * nk + i];
  }
}

void nscd_grains_ifc_U(nscd_state *S, const mo_contact_problem *P, double *Uk)
{
  int k;
  for (k = 0; k < S->nilist; k++) { /* not in S->U: the other's would write over its q (T240) */
    if (S->d == 2) contact_U(S, P, S->ilist[k], Uk + (size_t)k * 2, 2);
    else contact_U(S, P, S->ilist[k], Uk + (size_t)k * 3, 3);
  }
}

void nscd_grains_list_U(nscd_state *S, const mo_contact_problem *P, const int *list, int n)
{
  int k;
  for (k = 0; k < n; k++) {
    const int a = list[k];
    if (S->d == 2) contact_U(S, P, a, S->U + (size_t)a * 2, 2);
    else contact_U(S, P, a, S->U + (size_t)a * 3, 3);
  }
}

void nscd_grains_owned_U(nscd_state *S, const mo_contact_problem *P)
{
  nscd_grains_list_U(S, P, S->oorder, S->noact);
}

int nscd_grains_exchange(nscd_state *S, mo_ctx *ctx)
{
  const int nk = NK(S->d);
  int i, st;
  if (S->xchg) {
    /* (T331): each shared body's increment to the ranks that share it; then, on every rank that
       touches it, the ranks' increments summed in increasing rank order (the same sum on each),
       divided by f_k (T332) */
    const int *pj = S->pj;
    int t, m, nv = S->poff[S->npeer] / nk;
    for (t = 0; t < nv; t++) {
      const int o = S->ifc[pj[t]];
      for (i = 0; i < nk; i++) S->sbuf[(size_t)t * nk + i] = S->vb[o + i] - S->ibase[(size_t)pj[t] * nk + i];
    }
    if ((st = mo_par_exchange(S->npeer, S->peer, S->poff, S->sbuf, S->rbuf, ctx))) return st;
    for (m = 0; m < S->nmine; m++) {
      const int jm = S->mj[m], o = S->ifc[jm], s0 = S->msrc0[m], s1 = S->msrc0[m + 1];
      const double f = split_factor(s1 - s0);
      double *base = S->ibase + (size_t)jm * nk;
      for (i = 0; i < nk; i++) {
        const double own = S->vb[o + i] - base[i];
        double sum = S->msrc[s0] < 0 ? own : S->rbuf[S->msrc[s0] + i];
        for (t = s0 + 1; t < s1; t++) sum += S->msrc[t] < 0 ? own : S->rbuf[S->msrc[t] + i];
        S->vb[o + i] = base[i] + sum / f;
      }
    }
  }
  return MO_OK;
}

int nscd_grains_sync(nscd_state *S, double *parts, int nparts, double *extra, int nextra, mo_ctx *ctx)
{
  const int nk = NK(S->d);
  const size_t ni = (size_t)S->nifc * nk;
  int j, i, st;
  double *b = S->pbuf;
  if (S->xchg) { /* the interface went point to point (nscd_grains_exchange): the parts alone */
    if (nextra) return mo_error(ctx, MO_EINTERNAL, "nscd: values joined to a point-to-point sync");
    if ((st = mo_par_sum(parts, nparts, ctx))) return st;
  } else {
    /* one sum: the interface increments, the stopping rule's parts, the caller's extra values */
    for (j = 0; j < S->nifc; j++)
      for (i = 0; i < nk; i++) b[(size_t)j * nk + i] = S->vb[S->ifc[j] + i] - S->ibase[(size_t)j * nk + i];
    memcpy(b + ni, parts, (size_t)nparts * sizeof *b);
    if (nextra) memcpy(b + ni + nparts, extra, (size_t)nextra * sizeof *b);
    if ((st = mo_par_sum(b, (long)(ni + nparts + nextra), ctx))) return st;
    for (j = 0; j < S->nifc; j++)
      for (i = 0; i < nk; i++) S->vb[S->ifc[j] + i] = S->ibase[(size_t)j * nk + i] + b[(size_t)j * nk + i];
    memcpy(parts, b + ni, (size_t)nparts * sizeof *b);
    if (nextra) memcpy(extra, b + ni + nparts, (size_t)nextra * sizeof *b);
  }
  S->par_sweeps++;
  ctx->par_grain_sweeps++;
  return MO_OK;
}

/* (T336) The end of a split solve, before the gather: the velocities of the bodies only the
   rank's contacts touch, as nscd_grains_velocities makes them (the same pushes in the same order:
   every contact touching such a body is the rank's), and U of the rank's contacts that touch no
   interface body, as nscd_grains_exact_U makes it (contact_U: the numbers of the others' fresh_U,
   (T278)); the gather carries both. The interface bodies' pushes land here too and are made
   again after it. */
static void finish_own(nscd_state *S, const mo_contact_problem *P, const double *r)
{
  nscd_grains_velocities_part(S, P, r); /* the interface contacts of the others: overwritten */
  nscd_grains_list_U(S, P, S->onil, S->nonil);
}

/* (T336) After the gather: the interface bodies' velocities from every interface contact's
   reaction (their pushes in the contacts' order, as nscd_grains_velocities), U of the interface
   contacts and of the candidates not active (U = c_a + G v: open, but their bodies moved); on
   every rank, from the gathered reactions. */
static void finish_interface(nscd_state *S, const mo_contact_problem *P, const double *r)
{
  const double *split = S->gs;
  const int d = S->d, nk = NK(d);
  int a, i, j, k;
  S->gs = S->gi;
  for (j = 0; j < S->nifc; j++)
    for (i = 0; i < nk; i++) S->vb[S->ifc[j] + i] = P->xfree[S->ifc[j] + i];
  for (k = 0; k < S->nilist; k++) {
    int nz = 0;
    a = S->ilist[k];
    for (i = 0; i < d; i++) nz |= r[(size_t)a * d + i] != 0;
    if (!nz) continue;
    if (d == 2) push_ifc(S, P, a, r + (size_t)a * 2, 2);
    else push_ifc(S, P, a, r + (size_t)a * 3, 3);
  }
  S->gs = split;
  for (k = 0; k < S->nilist; k++) {
    a = S->ilist[k];
    if (d == 2) {
      if (S->own[a]) contact_U(S, P, a, S->U + (size_t)a * 2, 2);
      else fresh_U(S, P, a, S->U + (size_t)a * 2, 2);
    } else if (S->own[a]) contact_U(S, P, a, S->U + (size_t)a * 3, 3);
    else fresh_U(S, P, a, S->U + (size_t)a * 3, 3);
  }
  for (a = 0, k = 0; a < S->nc; a++) {
    if (k < S->nact && S->act[k] == a) {
      k++;
      continue;
    }
    if (d == 2) fresh_U(S, P, a, S->U + (size_t)a * 2, 2);
    else fresh_U(S, P, a, S->U + (size_t)a * 3, 3);
  }
}

int nscd_grains_gather(nscd_state *S, const mo_contact_problem *P, double *r, int *status, int fin, int *unknowns,
                       int *dofs, mo_ctx *ctx)
{
  const int d = S->d, nk = NK(d), np = S->nranks, nx = unknowns ? 2 + S->nifc : 0;
  size_t at = 0;
  double *all, *mine;
  int a, i, k, l, q, st, nu = 0, nd = 0, *cur = S->pcnt; /* pcnt: the pattern's scratch, free here */
  /* the rank's own closed contacts, before the gather (their r and coefficients are the rank's) */
  if (unknowns && (st = count_list(S, P, r, S->oorder, S->noact, &nu, &nd, ctx))) return st;
  if (fin) finish_own(S, P, r);
  /* (T335) every value has one owner: a contact's reaction and status the rank of its part, a
     body's velocity change the lowest rank that touches it (an interface body's is the same on
     every rank after the last sync); each rank's block size follows from the parts every rank
     holds. Contacts not active (r = 0, open) and bodies no contact touches (v = v_free) are the
     same on every rank already and are not sent */
  /* with fin, U of the contacts that touch no interface body with their reactions, and no
     interface body's velocity (made again on every rank after the gather) */
  for (q = 0; q < np; q++) S->gcnt[q] = nx;
  for (k = 0; k < S->nact; k++) S->gcnt[S->apart[k]] += d + 1 + (fin && !S->cifc[S->act[k]] ? d : 0);
  for (i = 0; i < P->nfree; i++)
    if (S->bfirst[i] >= 0 && !(fin && S->bmulti[i])) S->gcnt[S->bfirst[i]] += i + nk <= P->nfree ? nk : P->nfree - i;
  if ((st = gather_room(S, cur, &all, &mine, ctx))) return st;
  /* the block: the rank's contacts in the order of act, its bodies in dof order, then the count */
  for (k = 0; k < S->nact; k++)
    if (S->apart[k] == S->rank) {
      a = S->act[k];
      for (i = 0; i < d; i++) mine[at++] = r[(size_t)a * d + i];
      mine[at++] = status[a];
      if (fin && !S->cifc[a])
        for (i = 0; i < d; i++) mine[at++] = S->U[(size_t)a * d + i];
    }
  for (i = 0; i < P->nfree; i++)
    if (S->bfirst[i] == S->rank && !(fin && S->bmulti[i]))
      for (l = 0; l < nk && i + l < P->nfree; l++) mine[at++] = fin ? S->vb[i + l] : S->vb[i + l] - P->xfree[i + l];
  if (unknowns) count_pack(S, mine + at, nu, nd);
  if ((st = mo_par_gatherv(mine, S->gcnt, all, ctx))) return st;
  /* read in the order written, a cursor a rank; "+ 0.0" makes -0 the +0 the sum with the other
     ranks' zeros made before (T335: the same numbers to the bit) */
  for (k = 0; k < S->nact; k++) {
    const double *b = all + cur[S->apart[k]];
    const int wu = fin && !S->cifc[S->act[k]];
    a = S->act[k];
    if (!S->own[a]) {
      for (i = 0; i < d; i++) r[(size_t)a * d + i] = b[i] + 0.0;
      status[a] = (int)b[d];
      if (wu)
        for (i = 0; i < d; i++) S->U[(size_t)a * d + i] = b[d + 1 + i];
    }
    cur[S->apart[k]] += d + 1 + (wu ? d : 0);
  }
  for (i = 0; i < P->nfree; i++) {
    if (S->bfirst[i] < 0) {
      S->vb[i] = P->xfree[i] + 0.0;
      continue;
    }
    if (fin && S->bmulti[i]) { /* finish_interface's */
      i += (i + nk <= P->nfree ? nk : P->nfree - i) - 1;
      continue;
    }
    {
      const double *b = all + cur[S->bfirst[i]];
      if (fin) /* the exact velocities themselves (v_free + (v - v_free) is not v to the bit) */
        for (l = 0; l < nk && i + l < P->nfree; l++) S->vb[i + l] = b[l];
      else
        for (l = 0; l < nk && i + l < P->nfree; l++) S->vb[i + l] = P->xfree[i + l] + (b[l] + 0.0);
      cur[S->bfirst[i]] += l;
      i += l - 1; /* a body's dofs follow its first: none of them has a bfirst of its own */
    }
  }
  if (unknowns) count_join(S, all, cur, unknowns, dofs);
  if (fin) finish_interface(S, P, r);
  return MO_OK;
}

/* The closed unknowns of the contacts list[0 .. n-1] and the bodies they move, marked in bmark
   (T84); *nd counts nk dofs a marked body. */
static int count_list(nscd_state *S, const mo_contact_problem *P, const double *r, const int *list, int n, int *nu_,
                      int *nd_, mo_ctx *ctx)
{
  const int d = S->d;
  int k, s, st, nu = 0, nd = 0;
  if ((st = nscd_marks_clear(S, (size_t)P->nfree + 1, ctx))) return st;
  for (k = 0; k < n; k++) {
    const int a = list[k], u = nscd_closed_unknowns(S, a, r + (size_t)a * d, d);
    int gs[2];
    if (!u) continue;
    sides(P->grains, a, gs);
    nu += u;
    for (s = 0; s < 2 && gs[s]; s++) {
      int o = (gs[s] > 0 ? gs[s] : -gs[s]) - 1;
      if (!S->bmark[o]) {
        S->bmark[o] = 1;
        nd += NK(d);
      }
    }
  }
  *nu_ = nu;
  *nd_ = nd;
  return MO_OK;
}

int nscd_grains_count(nscd_state *S, const mo_contact_problem *P, const double *r, int *unknowns, int *dofs,
                      mo_ctx *ctx)
{
  return count_list(S, P, r, S->act, S->nact, unknowns, dofs, ctx);
}
