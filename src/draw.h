/* draw.h: scenes that draw themselves without ParaView (output.draw): gnuplot data and script,
   snapshots.png and animation.gif. Private to the core. */
#ifndef MOREAU_DRAW_H
#define MOREAU_DRAW_H

#include <moreau/case.h>
#include <moreau/output.h>
#include <moreau/scene.h>
#include <moreau/step.h>

typedef struct mo_draw mo_draw;

/* Read the case's output.draw group and prepare OUTDIR/plots: *out stays NULL when the group is
   absent. The frames are sampled from the steps 0 .. sc->time.steps: `frames` snapshots evenly
   spaced, and with the GIF every `every` steps and the last. Errors on keys name file:line:key. */
int mo_draw_open(const char *outdir, const mo_scene *sc, const mo_case *cs, mo_draw **out, mo_ctx *ctx);
/* 1 when step `step` is one of the sampled frames. */
int mo_draw_wants(const mo_draw *d, long step);
/* Append the geometry of state s to plots/draw.dat (bodies in the current configuration, the
   contact network net when output.draw.forces; net may be NULL). Nothing is kept in memory but
   the frame's step and time and the bounding box. */
int mo_draw_frame(mo_draw *d, const mo_scene *sc, const mo_state *s, mo_vtk_contacts *net, mo_ctx *ctx);
/* Close draw.dat (planes clipped to the view appended), write plots/draw.gp, and render it when
   gnuplot is on PATH; logs "draw: N figures, M rendered". A gnuplot that fails is reported,
   not an error of the run. */
int mo_draw_finish(mo_draw *d, const mo_scene *sc, mo_ctx *ctx);
void mo_draw_free(mo_draw *d);

#endif
