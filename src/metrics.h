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
void mo_metrics_free(mo_metrics *M);

/* finite.c: no NaN or infinity in a run's outputs (doc/theory.md §10.8). The likely cause of a
   non-finite value at time t, naming its case key, into buf; the MO_ENAN error naming the
   quantity, the step and that cause; the checks of a state (u, v) and of a history row. */
void mo_finite_cause(const mo_scene *sc, double t, char *buf, size_t n);
int mo_finite_error(const mo_scene *sc, long step, double t, const char *what, double value, mo_ctx *ctx);
int mo_finite_state(const mo_scene *sc, const mo_state *s, mo_ctx *ctx);
void mo_matrix_cause(const mo_scene *sc, char *buf, size_t n);
int mo_finite_row(const mo_scene *sc, const mo_state *s, const double *row, const char *const *names, int ncol,
                  mo_ctx *ctx);

#endif
