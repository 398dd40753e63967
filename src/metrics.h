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
int mo_metrics_create(const mo_scene *sc, const mo_contact *C, mo_metrics **out, mo_ctx *ctx);
/* Record the state after a step (and at t = 0, with D = NULL before the first step). */
void mo_metrics_step(mo_metrics *M, const mo_state *s, const mo_contact_driver *D);
/* Energy ratio E(t) / E0 (doc/theory.md §10): kinetic + elastic - external and support work,
   shifted by the reference's exact energy when it gives one. */
double mo_metrics_energy_ratio(const mo_metrics *M, const mo_state *s);
/* The kinetic and elastic energies of s and the ratio above, from one product by M and one by
   K (the run measures them at every step). */
void mo_metrics_energies(const mo_metrics *M, const mo_state *s, double *ek, double *ee, double *ratio);
json_t *mo_metrics_json(const mo_metrics *M);
/* Chatter of a persistent contact (doc/theory.md (T93)), over the candidates of the Signorini
   and gap laws: one whose increments of U_n between bearing steps, each above 1e-2 of the
   impact speed (and of the round-off speed 1e-9 h_min / h), alternate in sign at least
   MO_CHATTER_ALTERNATIONS times, while their largest |U_n| in contact reaches MO_CHATTER_RATIO
   of the impact speed (the largest approach speed before a landing). */
#define MO_CHATTER_ALTERNATIONS 10
#define MO_CHATTER_RATIO 0.1
typedef struct {
  double vimpact;      /* impact speed (velocity_scale when no landing was seen) */
  long alternations;   /* the most alternations of one candidate */
  double ratio;        /* max_vn_in_contact / vimpact */
  int chatter;         /* both thresholds reached */
} mo_chatter;
void mo_metrics_chatter(const mo_metrics *M, mo_chatter *ch);
void mo_metrics_free(mo_metrics *M);

#endif
