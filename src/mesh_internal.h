/* mesh_internal.h: what the mesh module shares with the Gmsh reader (not installed). */
#ifndef MOREAU_MESH_INTERNAL_H
#define MOREAU_MESH_INTERNAL_H
#include <stddef.h>
#include <moreau/mesh.h>

/* One facet of one element: its nodes sorted (unused entries -1) as the key, the element and
   the facet's local number in it. */
typedef struct {
  int key[4];
  int elem, lface;
} mo_facet;

/* Every facet of every element, sorted by key, then element, then local facet: facets shared by
   several elements are adjacent, in element order. The caller frees *out with mo_free. */
int mo_mesh_all_facets(const mo_mesh *m, mo_facet **out, size_t *nout, mo_ctx *ctx);

/* Compares the keys only (for bsearch and for grouping shared facets). */
int mo_facet_cmp_key(const void *a, const void *b);

/* The smallest Jacobian determinant of element e: at its corners (linear types: of the corner
   edges), or of its isoparametric map at its nodes and centre (quadratic types); *at (when not
   NULL) the local node where it is found, -1 for the centre or a linear type. */
double mo_mesh_elem_min_jacobian(const mo_mesh *m, int e, int *at);

#endif
