/* metrics.h: measures of a run against its reference and of its contact behaviour
   (doc/theory.md §10), computed by the core for every back end. Private to the core. */
#ifndef MOREAU_METRICS_H
#define MOREAU_METRICS_H

#include <jansson.h>

#include <moreau/contact.h>
#include <moreau/scene.h>
#include <moreau/step.h>

typedef struct mo_metrics mo_metrics;

/* The shortest element edge of the deformable bodies (HUGE_VAL without one): the scale of
   the gap tolerance here and of the penetration `moreau compare` judges (summary.json
   scene.hmin). */
double mo_metrics_hmin(const mo_scene *sc);
/* work: a scratch of ndof + 1 doubles the caller lends for the metrics' life (NULL: their own),
   free between the calls. D: the run's contact driver, whose remaps the metrics follow the
   candidate set by (mo_contact_driver_remap; it must then be the D of every mo_metrics_step
   after the first), or NULL: the metrics keep the keys themselves. */
int mo_metrics_create(const mo_scene *sc, const mo_contact *C, const mo_contact_driver *D, double *work,
                      mo_metrics **out, mo_ctx *ctx);
/* Record the state after a step (and at t = 0, with D = NULL before the first step). */
void mo_metrics_step(mo_metrics *M, const mo_state *s, const mo_contact_driver *D);
/* Energy ratio E(t) / E0 (doc/theory.md §10): kinetic + elastic - external and support work,
   shifted by the reference's exact energy when it gives one. */
double mo_metrics_energy_ratio(const mo_metrics *M, const mo_state *s);
/* The kinetic and elastic energies of s and the ratio above, from one product by M and one by
   K (the run measures them at every step); excess (may be NULL): E(t) - E_ref, the numerator of
   the growth, defined also where E_ref = 0 and the ratio is not (doc/theory.md (T49a)). */
/* *ek and *ee on entry: NaN, or the kinetic and stored energies given (the bodies' state per rank:
   the ranks' sum, and 0 on its scenes of rigid bodies only). */
void mo_metrics_energies(const mo_metrics *M, const mo_state *s, double *ek, double *ee, double *ratio, double *excess);
/* Over MPI ranks with the set distributed (mo_contact_distributed): each rank's measures of its own
   candidates joined into the whole set's (maxima, sums), on every rank: a collective, called once
   after the last step and before the reports read them; nothing otherwise. */
int mo_metrics_join(mo_metrics *M, mo_ctx *ctx);
json_t *mo_metrics_json(const mo_metrics *M);
/* Chatter of a persistent contact. The verdict is mo_chatter_verdict (T97), the one criterion of
   a run's warning and of compare's class. Reported beside it (T93), over the candidates of the
   Signorini and gap laws: the most alternations in sign of one candidate's increments of U_n
   between bearing steps (each above 1e-2 of the landing speed and of the round-off speed
   1e-9 h_min / h), and the largest |U_n| in contact over the landing speed. */
typedef struct {
  double vimpact;      /* landing speed of the watched laws (velocity_scale when no landing was seen) */
  long alternations;   /* the most alternations of one candidate */
  double ratio;        /* max |U_n| in contact (watched laws) / vimpact */
  int chatter;         /* the verdict (T97) */
  char why[256];       /* its reason */
} mo_chatter;
void mo_metrics_chatter(const mo_metrics *M, mo_chatter *ch);
void mo_metrics_free(mo_metrics *M);

/* Chatter (doc/theory.md (T97)): the thresholds, relative to the impact velocity V (the
   largest approach |U_n| of a candidate's first landing; no verdict when nothing landed). */
#define MO_CHATTER_VN_FLOOR 1e-3     /* a sign change counts when both sides exceed this x the
                                        largest |U_n| so far */
#define MO_CHATTER_VN_REL 0.05       /* max |U_n| between two bearing steps above this x V */
#define MO_CHATTER_SIGN_CHANGES 2    /* this many sign changes of U_n while bearing */
#define MO_STR_(x) #x
#define MO_STR(x) MO_STR_(x)

/* The measures the verdict reads, as summary.json's metrics.contact names them (the
   oscillation index is reported with them, not judged: it also counts the landing that follows
   a grazing step). */
typedef struct {
  double impact_velocity, velocity_scale, max_vn_in_contact, oscillation_index, vn_sign_changes;
  double restitution;        /* the largest Newton restitution e of the pairs (0: none) */
  double oscillation_scale;  /* the oscillation index's velocity scale (T50); NAN: velocity_scale
                                (summaries written before it was reported) */
} mo_chatter_input;

/* A run's chatter measures (the values metrics.contact of summary.json holds). */
void mo_metrics_chatter_input(const mo_metrics *M, mo_chatter_input *in);
/* A pure function of the measures: 1 when the contact chatters (T97), else 0; why (n bytes,
   may be NULL) says the measures against the thresholds. Pairs with Newton's restitution
   e > 0 bounce by their law: no verdict (0, and why says so). */
int mo_chatter_verdict(const mo_chatter_input *in, char *why, size_t n);

/* finite.c: no NaN or infinity in a run's outputs (doc/theory.md §10.3). The likely cause of a
   non-finite value at time t, naming its case key, into buf; the MO_ENAN error naming the
   quantity, the step and that cause; the checks of a state (u, v) and of a history row. */
void mo_finite_cause(const mo_scene *sc, double t, char *buf, size_t n);
int mo_finite_error(const mo_scene *sc, long step, double t, const char *what, double value, mo_ctx *ctx);
int mo_finite_state(const mo_scene *sc, const mo_state *s, mo_ctx *ctx);
/* The same over the rigid bodies list[0 .. n) (the bodies' state per rank: those this rank holds). */
int mo_finite_bodies(const mo_scene *sc, const mo_state *s, const int *list, int n, mo_ctx *ctx);
/* The first dof whose initial displacement or velocity (sc->u0, sc->v0) is extreme, or -1 (also
   when the scene no longer holds them: they were released only when none was, T248). */
int mo_finite_initial(const mo_scene *sc);
void mo_matrix_cause(const mo_scene *sc, char *buf, size_t n);
int mo_finite_row(const mo_scene *sc, const mo_state *s, const double *row, const char *const *names, int ncol,
                  mo_ctx *ctx);

#endif
