/* contact_internal.h: the contact set's storage, private to the core. */
#ifndef MOREAU_CONTACT_INTERNAL_H
#define MOREAU_CONTACT_INTERNAL_H

#include <moreau/contact.h>

struct mo_contact {
  const mo_scene *sc;
  int dim;                    /* local dimension = space dimension */
  int npair;
  mo_contact_pair *pair;
  struct {
    int n;                    /* candidates of the pair */
    int *cand;                /* their global candidate numbers */
    double *P;                /* P* (n x n, row-major), NULL without facets */
  } *pp;
  int npt, ptcap;
  mo_cpoint *pt;
  int nc, ccap;
  mo_candidate *cand;
  int ncoef, coefcap;
  int *cpt;                   /* candidate point lists */
  double *ccoef;              /* and coefficients */
  double *g;                  /* nc gaps */
  double *frame;              /* nc * dim * dim */
  double *U0;                 /* dim * nc obstacle local velocities */
  unsigned char *active;      /* nc: 0 when its projection fell off the master (inactive) */
  mo_csc *Hfull, *H;
  long hversion;
  mo_signorini signorini;
  int repair;                 /* pair again at every step */
  int on_failure_continue;
  char *solver;
};

void mo_contact_frame_from_normal(int dim, const double *n, double *F);

#endif
