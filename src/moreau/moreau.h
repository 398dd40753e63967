/* moreau/moreau.h: the whole public interface of libmoreau. */
#ifndef MOREAU_MOREAU_H
#define MOREAU_MOREAU_H

#include <stdio.h>

#include <moreau/ctx.h>
#include <moreau/expr.h>
#include <moreau/mesh.h>
#include <moreau/fe.h>
#include <moreau/material.h>
#include <moreau/sparse.h>
#include <moreau/case.h>
#include <moreau/scene.h>
#include <moreau/body.h>
#include <moreau/parallel.h>
#include <moreau/step.h>
#include <moreau/output.h>
#include <moreau/run.h>
#include <moreau/contact.h>
#include <moreau/compare.h>
#include <moreau/bench.h>
#include <moreau/backend.h>
#include <moreau/api.h>

#ifdef __cplusplus
extern "C" {
#endif

/* `moreau list-solvers`: one line per registered contact back end. Returns an exit code. */
int mo_cli_list_solvers(FILE *out);

#ifdef __cplusplus
}
#endif
#endif
