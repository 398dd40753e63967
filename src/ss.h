/* ss.h: the one place SuiteSparse headers are included (Debian 12 installs them under
   suitesparse/ and ships no pkg-config files). Private to the core. */
#ifndef MOREAU_SS_H
#define MOREAU_SS_H

#include <suitesparse/cholmod.h>
#include <suitesparse/umfpack.h>

#include <moreau/ctx.h>

/* Translate a CHOLMOD status into a moreau error, with CHOLMOD's own meaning. */
int mo_ss_cholmod_error(const cholmod_common *c, const char *what, mo_ctx *ctx);
/* Translate an UMFPACK status into a moreau error. */
int mo_ss_umfpack_error(int status, const char *what, mo_ctx *ctx);

#endif
