/* moreau/mesh.h: meshes, named node and facet sets, structured generators. */
#ifndef MOREAU_MESH_H
#define MOREAU_MESH_H

#include <moreau/ctx.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum {
  MO_EL_BAR2 = 0, /* 2-node bar (1D) */
  MO_EL_T3,       /* 3-node triangle */
  MO_EL_Q4,       /* 4-node quadrilateral */
  MO_EL_H8,       /* 8-node hexahedron */
  MO_EL_NTYPES
} mo_eltype;

/* Reference-element facts: dimension, nodes per element, facets per element and nodes per
   facet, and the local node numbers of each facet, ordered so that the facet's outward normal
   follows from the ordering (2D: edge a->b has outward normal (tb_y, -tb_x); 3D: quad face
   a,b,c,d has outward normal (b-a) x (d-a)). */
typedef struct {
  const char *name;
  int dim, nen, nfacet, nfn;
  int facet[6][4];
} mo_eltype_info;
const mo_eltype_info *mo_eltype_get(mo_eltype t);

/* A named set of nodes (sorted, unique ids). */
typedef struct {
  char *name;
  int n;
  int *node;
} mo_nodeset;

/* A named set of boundary facets: end points in 1D, edges in 2D, quadrilateral faces in 3D.
   Facet f has nodes node[f*nfn .. f*nfn+nfn-1] (outward orientation), and lies on local facet
   lface[f] of element elem[f]. */
typedef struct {
  char *name;
  int n, nfn;
  int *node;
  int *elem;
  int *lface;
} mo_facetset;

typedef struct mo_mesh {
  int dim;           /* space dimension: 1, 2 or 3 */
  int nnode;
  double *x;         /* nnode*dim coordinates */
  mo_eltype type;    /* one element type per mesh */
  int nelem, nen;
  int *conn;         /* nelem*nen node numbers, counter-clockwise (2D), right-handed (3D) */
  int nnodeset, nfacetset;
  mo_nodeset *nodeset;
  mo_facetset *facetset;
} mo_mesh;

/* Pattern of the diagonal splitting each rectangle of a structured T3 mesh, with corners
   a=(i,j), b=(i+1,j), c=(i+1,j+1), d=(i,j+1):
   RIGHT: (a,b,d)+(b,c,d) (diagonal b-d); LEFT: (a,b,c)+(a,c,d) (diagonal a-c);
   ALTERNATE: RIGHT and LEFT in a checkerboard; UNION_JACK: ALTERNATE mirrored so that four
   triangles meet at every other node. */
typedef enum { MO_DIAG_RIGHT = 0, MO_DIAG_LEFT, MO_DIAG_ALTERNATE, MO_DIAG_UNION_JACK } mo_diag;

/* Generators. Node sets and facet sets are created for the bounding faces: "xmin", "xmax" (1D,
   2D, 3D), "ymin", "ymax" (2D, 3D), "zmin", "zmax" (3D), with aliases "left" = xmin,
   "right" = xmax and, in 2D, "bottom" = ymin, "top" = ymax; and "all" (every node). Nodes are
   numbered x fastest, then y, then z. */
int mo_mesh_bar(double x0, double length, int nel, mo_mesh **out, mo_ctx *ctx);
int mo_mesh_rectangle(const double origin[2], const double size[2], const int nel[2],
                      mo_eltype type, mo_diag diag, mo_mesh **out, mo_ctx *ctx);
int mo_mesh_box(const double origin[3], const double size[3], const int nel[3], mo_mesh **out,
                mo_ctx *ctx);
/* Q4 disk of given centre and radius: a square core of n x n cells and nr rings of n cells per
   quarter (an "O-grid"); sets "boundary" (the circle), "all", and "bottom_point", "top_point",
   "left_point", "right_point" (single nodes on the axes). */
int mo_mesh_disk(const double centre[2], double radius, int n, int nr, mo_mesh **out,
                 mo_ctx *ctx);

void mo_mesh_free(mo_mesh *m);

/* Look up a set by name; NULL when absent. "a&b" in a node-set name means the intersection
   (resolved by mo_mesh_nodeset_resolve). */
const mo_nodeset *mo_mesh_find_nodeset(const mo_mesh *m, const char *name);
const mo_facetset *mo_mesh_find_facetset(const mo_mesh *m, const char *name);
/* The names of the mesh's sets, ", "-separated into buf (n bytes, cut with "..." when full): the
   node sets (facets = 0) or the facet sets (facets = 1), for the errors that name a missing one. */
void mo_mesh_set_names(const mo_mesh *m, int facets, char *buf, size_t n);
/* Resolve a node-set expression "a", "a&b&..." into a freshly allocated id array (*ids, *n);
   MO_EINPUT naming the missing set when a part is unknown. */
int mo_mesh_nodeset_resolve(const mo_mesh *m, const char *expr, int **ids, int *n, mo_ctx *ctx);

/* Add a node set (and the facet set of the boundary facets all of whose nodes it holds) made of
   the nodes inside the box [lo, hi] (per axis, tolerance tol). An empty selection is an error. */
int mo_mesh_add_box_set(mo_mesh *m, const char *name, const double *lo, const double *hi,
                        double tol, mo_ctx *ctx);
/* Add a node set from explicit node ids (validated). */
int mo_mesh_add_nodeset(mo_mesh *m, const char *name, const int *ids, int n, mo_ctx *ctx);
/* Add a facet set from all boundary facets whose nodes all belong to node set `nodes`. */
int mo_mesh_add_facetset_from_nodes(mo_mesh *m, const char *name, const int *nodes, int n,
                                    mo_ctx *ctx);

/* Locate facets given by their nodes (nfn nodes per facet, in any order): elem[f] and lface[f]
   are the element and local facet that have facet f on the boundary; elem[f] = -1 when no
   element has such a facet, -2 when two or more elements share it (it lies inside the mesh). */
int mo_mesh_locate_facets(const mo_mesh *m, const int *fnodes, int nf, int *elem, int *lface,
                          mo_ctx *ctx);
/* Add a facet set from (element, local facet) pairs, e.g. from mo_mesh_locate_facets: each facet
   once, ordered by element and local facet, nodes in the element's outward order. */
int mo_mesh_add_facetset(mo_mesh *m, const char *name, const int *elem, const int *lface, int n,
                         mo_ctx *ctx);

/* Gmsh MSH files, ASCII 4.1 (Gmsh's default) and 2.2 (doc/case-format.md, "Gmsh files").
   The body is made of the elements of the highest dimension in the file, all of one type (2-node
   lines, 3-node triangles, 4-node quadrangles or 8-node hexahedra); nodes no such element uses
   are dropped and the others numbered 0, 1, ... in increasing tag order. Every physical group
   gives a node set under its name (unnamed groups: "point7", "curve3", "surface1", "volume2";
   groups that share a name are merged); a group of facets (points in 1D, lines in 2D,
   quadrangles in 3D) on the boundary also gives a facet set; "all" holds every node unless the
   file names a group so. Elements written clockwise (negative Jacobian at the centre) are
   reoriented with a note; degenerate and inverted elements, repeated or missing nodes,
   unsupported element types and malformed sections are errors "FILE:LINE: ..." (MO_EINPUT),
   counts past ctx->max_dofs are refused before allocating (MO_ELIMIT), an unreadable file is
   MO_EIO. Coordinates become scale * x + translate. */
typedef struct {
  double scale;         /* > 0 */
  double translate[3];
} mo_gmsh_options;

typedef struct {
  int version;          /* 41 or 22 */
  int nreoriented;      /* elements written clockwise, reoriented */
  int nunused;          /* nodes of the file that no body element uses (dropped) */
  int nduplicate;       /* MSH 2.2: body elements repeated once per physical group (dropped) */
} mo_gmsh_report;

/* Read the file at `path`; opt and rep may be NULL (scale 1, no translation). */
int mo_mesh_read_gmsh(const char *path, const mo_gmsh_options *opt, mo_mesh **out,
                      mo_gmsh_report *rep, mo_ctx *ctx);
/* The same from len bytes in memory (tests, fuzzing); `name` stands for the file in messages. */
int mo_mesh_read_gmsh_buffer(const char *buf, size_t len, const char *name,
                             const mo_gmsh_options *opt, mo_mesh **out, mo_gmsh_report *rep,
                             mo_ctx *ctx);

/* Node nearest to point p (dim coordinates); distance in *dist when non-NULL. */
int mo_mesh_nearest_node(const mo_mesh *m, const double *p, double *dist);

/* Geometric checks: every element has positive measure (Jacobian > 0 at its corners/centre).
   Returns MO_EINPUT naming the first bad element. */
int mo_mesh_check(const mo_mesh *m, mo_ctx *ctx);

/* Characteristic sizes: smallest and largest element edge length. */
void mo_mesh_edge_range(const mo_mesh *m, double *hmin, double *hmax);

#ifdef __cplusplus
}
#endif
#endif
