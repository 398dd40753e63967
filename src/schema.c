/* schema.c: every case-file key, its type, range, default and one line of documentation.
   doc/case-format.md documents the same keys; tests/test_case_doc checks that it names them all. */
#include "config.h"
#include "case_internal.h"
#include <moreau/contact.h>
#include <moreau/backend.h>

#include <math.h>
#include <string.h>

#define U NAN
#define NONE U, U, 0, 0, 0, 0
/* ranges: R(lo, hi, lo_open, hi_open) */
#define R(lo, hi, lo_open, hi_open) lo, hi, lo_open, hi_open, 0, 0
#define POS R(0, U, 1, 0)
#define NONNEG R(0, U, 0, 0)
#define A(lo, hi, lo_open, hi_open, amin, amax) lo, hi, lo_open, hi_open, amin, amax

static const mo_key core_keys[] = {
  {"title", K_STRING, NULL, NONE, 0, "\"\"", "One line naming the scene (printed in summaries and plots).", NULL},
  {"description", K_STRING, NULL, NONE, 0, "\"\"", "Free text.", NULL},
  {"presets", K_LIST, NULL, NONE, 0, NULL, "Formulations of this scene for --solver BACKEND:PRESET: the per-figure parameters of a paper's setting (applied after the program's preset of the same name), or new names.", NULL},
  {"presets.[].name", K_STRING, NULL, NONE, 1, NULL, "BACKEND:PRESET, e.g. \"newmark:bdz07\".", NULL},
  {"presets.[].set", K_SARRAY, NULL, NONE, 0, NULL, "KEY=VALUE assignments, as --set takes them.", NULL},

  /* --- bodies ------------------------------------------------------------------------------ */
  {"bodies", K_LIST, NULL, NONE, 1, NULL, "The bodies of the scene: deformable meshes, rigid planes, disks, spheres, polygons and meshes held rigid.", NULL},
  {"bodies.[].name", K_STRING, NULL, NONE, 1, NULL, "Unique name, used by contact pairs, probes and --set.", NULL},
  {"bodies.[].type", K_ENUM, "deformable|plane|disk|sphere|polygon|rigid_mesh", NONE, 0, "\"deformable\"", "A finite-element body, a rigid plane obstacle, a rigid disk (2D), sphere (3D), convex polygon (2D), or a mesh held rigid (doc/theory.md §12).", NULL},
  {"bodies.[].point", K_FARRAY, NULL, A(U, U, 0, 0, 1, 3), 0, NULL, "Plane: a point of the plane (dim values).", NULL},
  {"bodies.[].normal", K_FARRAY, NULL, A(U, U, 0, 0, 1, 3), 0, NULL, "Plane: outward normal, pointing toward the side bodies stay on (normalised).", NULL},
  {"bodies.[].until", K_FLOAT, NULL, NONNEG, 0, "always there", "Plane: the time (s) after which the plane is gone, its contacts open for good (a gate that opens: the column collapse).", NULL},
  {"bodies.[].velocity", K_FARRAY, NULL, A(U, U, 0, 0, 1, 3), 0, "zero", "Plane: prescribed translation velocity (m/s).", NULL},
  {"bodies.[].center", K_FARRAY, NULL, A(U, U, 0, 0, 2, 3), 0, NULL, "Disk, sphere: centre; polygon given by 'size' or 'sides': centroid (m).", NULL},
  {"bodies.[].radius", K_FLOAT, NULL, POS, 0, NULL, "Disk, sphere: radius; regular polygon: circumradius (m).", "a radius must be positive"},
  {"bodies.[].angle", K_FLOAT, NULL, NONE, 0, "0", "2D rigid bodies given by 'size' or 'sides' (and disks): initial orientation (rad, counter-clockwise).", NULL},
  {"bodies.[].size", K_FARRAY, NULL, A(0, U, 1, 0, 2, 2), 0, NULL, "Polygon: a rectangle [a, b] (m), centred on 'center', turned by 'angle'.", "a rectangle's sides are positive"},
  {"bodies.[].sides", K_INT, NULL, R(3, 64, 0, 0), 0, NULL, "Polygon: a regular polygon with this many sides (with 'radius', 'center', 'angle').", "a regular polygon has 3 to 64 sides"},
  {"bodies.[].vertices", K_FARRAY, NULL, A(U, U, 0, 0, 6, 128), 0, NULL, "Polygon: [x0, y0, x1, y1, ...], convex and counter-clockwise, where they are at t = 0 (m).", NULL},
  {"bodies.[].arch", K_GROUP, NULL, NONE, 0, NULL, "Polygon: the voussoirs of a circular arch, one body NAME.k per block (group NAME).", NULL},
  {"bodies.[].arch.center", K_FARRAY, NULL, A(U, U, 0, 0, 2, 2), 0, "[0, 0]", "Centre of the arch's circles (m).", NULL},
  {"bodies.[].arch.radius", K_FLOAT, NULL, POS, 1, NULL, "Radius of the centre line (m).", NULL},
  {"bodies.[].arch.thickness", K_FLOAT, NULL, POS, 1, NULL, "Radial thickness t of the ring (m).", NULL},
  {"bodies.[].arch.blocks", K_INT, NULL, R(1, 100000, 0, 0), 1, NULL, "Number of voussoirs.", NULL},
  {"bodies.[].arch.from", K_FLOAT, NULL, NONE, 0, "0", "Angle where the ring starts (degrees, counter-clockwise from +x).", NULL},
  {"bodies.[].arch.to", K_FLOAT, NULL, NONE, 0, "180", "Angle where the ring ends (degrees).", NULL},
  {"bodies.[].pack", K_GROUP, NULL, NONE, 0, NULL, "Disk, sphere: a pack of grains on a loose lattice filling a box from its bottom, one body NAME.k per grain (group NAME).", NULL},
  {"bodies.[].pack.count", K_INT, NULL, R(1, 1e7, 0, 0), 1, NULL, "Number of grains.", "a pack holds 1 to 10^7 grains"},
  {"bodies.[].pack.radius", K_FLOAT, NULL, POS, 1, NULL, "Mean radius R (m).", NULL},
  {"bodies.[].pack.dispersion", K_FLOAT, NULL, R(0, 1, 0, 1), 0, "0", "Radii uniform in R (1 - d, 1 + d).", "a dispersion lies in [0, 1)"},
  {"bodies.[].pack.box", K_FARRAY, NULL, A(U, U, 0, 0, 4, 6), 1, NULL, "The region filled: [xmin, xmax, ymin, ymax(, zmin, zmax)] (m); layers along x (and z) first, then up y.", NULL},
  {"bodies.[].pack.spacing", K_FLOAT, NULL, POS, 0, "2.2 R (1 + d)", "Lattice spacing (m), at least the largest diameter.", NULL},
  {"bodies.[].pack.jitter", K_FLOAT, NULL, R(0, 1, 0, 0), 0, "0.5", "Random offset of each grain within its cell, as a fraction of the room it has.", NULL},
  {"bodies.[].pack.seed", K_INT, NULL, R(0, 2147483647, 0, 0), 0, "1", "Seed of the radii and offsets (the same seed, the same pack).", NULL},
  {"bodies.[].density", K_FLOAT, NULL, POS, 0, NULL, "Rigid bodies: mass density (kg/m^3); in 2D the mass is density x area x thickness.", "density must be positive"},
  {"bodies.[].thickness", K_FLOAT, NULL, POS, 0, "1", "2D rigid bodies: out-of-plane thickness (m).", NULL},
  {"bodies.[].inertia", K_NUMS, NULL, A(U, U, 0, 0, 1, 9), 0, "the shape's", "Rigid bodies: moment of inertia about the centroid (2D: I; 3D: principal values or the 9 entries of J in the body frame) (kg m^2).", NULL},
  {"bodies.[].fixed", K_BOOL, NULL, NONE, 0, "false", "Rigid bodies: every dof held fixed (a support).", NULL},

  {"bodies.[].mesh", K_GROUP, NULL, NONE, 0, NULL, "Deformable body: its mesh.", NULL},
  {"bodies.[].mesh.generator", K_ENUM, "bar|rectangle|box|disk", NONE, 0, NULL, "Structured generator: bar (1D, bar2), rectangle (2D, Q4, T3 or T6), box (3D, H8, T4 or T10), disk (2D, Q4 O-grid); or give `file`.", NULL},
  {"bodies.[].mesh.file", K_STRING, NULL, NONE, 0, NULL, "A Gmsh MSH file (4.1 ASCII or binary, or ASCII 2.2), relative to the case file; its physical groups name the sets.", NULL},
  {"bodies.[].mesh.scale", K_FLOAT, NULL, POS, 0, "1", "file: factor on the file's coordinates (1e-3 for millimetres).", "a scale is a positive factor"},
  {"bodies.[].mesh.translate", K_FARRAY, NULL, A(U, U, 0, 0, 1, 3), 0, "zero", "file: translation added after scaling (dim values).", NULL},
  {"bodies.[].mesh.length", K_FLOAT, NULL, POS, 0, NULL, "bar: length (m).", NULL},
  {"bodies.[].mesh.origin", K_NUMS, NULL, A(U, U, 0, 0, 1, 3), 0, "zero", "bar: x of the first node; rectangle, box: lower corner.", NULL},
  {"bodies.[].mesh.size", K_FARRAY, NULL, A(0, U, 1, 0, 2, 3), 0, NULL, "rectangle: [Lx, Ly]; box: [Lx, Ly, Lz] (m).", NULL},
  {"bodies.[].mesh.elements", K_INTS, NULL, A(1, 1e7, 0, 0, 1, 3), 0, NULL, "Number of elements: bar: n; rectangle: [nx, ny]; box: [nx, ny, nz].", "at least one element per direction, at most 10^7"},
  {"bodies.[].mesh.element", K_ENUM, "Q4|T3|T6|H8|T4|T10", NONE, 0, "Q4 (rectangle), H8 (box)", "rectangle: Q4, T3 or T6; box: H8, T4 or T10 (Kuhn's 6 tetrahedra per cell).", NULL},
  {"bodies.[].mesh.diagonal", K_ENUM, "right|left|alternate|union_jack", NONE, 0, "\"right\"", "rectangle with T3 or T6: how each cell is split (right: (a,b,d)+(b,c,d); left: (a,b,c)+(a,c,d); alternate; union_jack).", NULL},
  {"bodies.[].mesh.center", K_FARRAY, NULL, A(U, U, 0, 0, 2, 2), 0, "[0, 0]", "disk: centre.", NULL},
  {"bodies.[].mesh.radius", K_FLOAT, NULL, POS, 0, NULL, "disk: radius (m).", NULL},
  {"bodies.[].mesh.core", K_INT, NULL, R(2, 10000, 0, 0), 0, "8", "disk: cells per side of the square core (even).", NULL},
  {"bodies.[].mesh.rings", K_INT, NULL, R(1, 10000, 0, 0), 0, "4", "disk: rings of cells between the core and the circle.", NULL},
  {"bodies.[].mesh.sets", K_LIST, NULL, NONE, 0, NULL, "Extra named node sets (with their boundary facets).", NULL},
  {"bodies.[].mesh.sets.[].name", K_STRING, NULL, NONE, 1, NULL, "Set name.", NULL},
  {"bodies.[].mesh.sets.[].box", K_FARRAY, NULL, A(U, U, 0, 0, 2, 6), 0, NULL, "Nodes inside [xmin, xmax(, ymin, ymax(, zmin, zmax))].", NULL},
  {"bodies.[].mesh.sets.[].nodes", K_IARRAY, NULL, A(0, U, 0, 0, 1, 0), 0, NULL, "Explicit node numbers (0-based).", NULL},

  {"bodies.[].material", K_GROUP, NULL, NONE, 0, NULL, "Deformable body: its material.", NULL},
  {"bodies.[].material.model", K_ENUM, "elastic|hencky|j2", NONE, 0, "\"elastic\"", "Constitutive model: elastic (linear, small strains), hencky (finite-strain hyperelasticity, Hencky's logarithmic energy), j2 (finite-strain von Mises plasticity with linear isotropic hardening).", NULL},
  {"bodies.[].material.E", K_FLOAT, NULL, POS, 1, NULL, "Young's modulus (Pa).", "Young's modulus must be positive"},
  {"bodies.[].material.nu", K_FLOAT, NULL, R(-1, 0.5, 1, 1), 0, "0", "Poisson's ratio.", "Poisson's ratio of an isotropic solid lies in (-1, 0.5); 0.5 (incompressible) is not supported by displacement elements"},
  {"bodies.[].material.rho", K_FLOAT, NULL, POS, 1, NULL, "Mass density (kg/m^3).", "density must be positive"},
  {"bodies.[].material.sigma_y", K_FLOAT, NULL, POS, 0, NULL, "j2: initial yield stress (Pa).", "a yield stress must be positive"},
  {"bodies.[].material.Et", K_FLOAT, NULL, NONNEG, 0, "0", "j2: tangent modulus of the uniaxial curve past yield (Pa), 0 <= Et < E (0: perfect plasticity).", "a tangent modulus is not negative"},
  {"bodies.[].material.hypothesis", K_ENUM, "plane_strain|plane_stress|axisymmetric", NONE, 0, "\"plane_strain\"", "2D bodies: modelling hypothesis (axisymmetric: x is the radius, y the axis).", NULL},
  {"bodies.[].material.area", K_FLOAT, NULL, POS, 0, "1", "1D bodies: cross-section area (m^2).", NULL},
  {"bodies.[].material.thickness", K_FLOAT, NULL, POS, 0, "1", "Plane strain / plane stress: thickness (m).", NULL},
  {"bodies.[].mass", K_ENUM, "consistent|lumped", NONE, 0, "\"consistent\"", "Mass matrix.", NULL},

  {"bodies.[].fix", K_LIST, NULL, NONE, 0, NULL, "Homogeneous Dirichlet conditions (dofs eliminated).", NULL},
  {"bodies.[].fix.[].set", K_STRING, NULL, NONE, 0, NULL, "Deformable bodies: node set; \"a&b\" is the intersection of sets a and b.", NULL},
  {"bodies.[].fix.[].dofs", K_SARRAY, "x|y|z|theta|rx|ry|rz|all", A(U, U, 0, 0, 1, 6), 0, "\"all\"", "Components fixed (rigid bodies: also theta in 2D, rx, ry, rz in 3D).", NULL},

  {"bodies.[].prescribed", K_LIST, NULL, NONE, 0, NULL, "Prescribed motion of dofs (eliminated).", NULL},
  {"bodies.[].prescribed.[].set", K_STRING, NULL, NONE, 0, NULL, "Deformable bodies: node set (or intersection).", NULL},
  {"bodies.[].prescribed.[].dof", K_ENUM, "x|y|z|theta|rx|ry|rz", NONE, 1, NULL, "Component (rigid bodies: also theta in 2D, rx, ry, rz in 3D; a rotation's displacement is an angle).", NULL},
  {"bodies.[].prescribed.[].velocity", K_FLOAT, NULL, NONE, 0, NULL, "Constant velocity from t = 0 (m/s): u = u0 + v t.", NULL},
  {"bodies.[].prescribed.[].displacement", K_FEXPR, NULL, NONE, 0, NULL, "Displacement as a function of t (m); its velocity is differentiated numerically.", NULL},

  {"bodies.[].loads", K_LIST, NULL, NONE, 0, NULL, "External loads.", NULL},
  {"bodies.[].loads.[].type", K_ENUM, "nodal|pressure|traction", NONE, 1, NULL, "nodal: force on each node of the set; pressure: normal pressure on the facets (positive pushes inward); traction: force per unit area on the facets.", NULL},
  {"bodies.[].loads.[].set", K_STRING, NULL, NONE, 1, NULL, "Node set (nodal) or facet set (pressure, traction).", NULL},
  {"bodies.[].loads.[].value", K_VEXPR, NULL, A(U, U, 0, 0, 1, 3), 0, NULL, "nodal, traction: vector (dim components); pressure: scalar. Numbers or expressions in x, y, z.", NULL},
  {"bodies.[].loads.[].values", K_FARRAY, NULL, A(U, U, 0, 0, 1, 0), 0, NULL, "pressure given per facet (in the set's order), or nodal forces per node: one value per item, along `direction`.", NULL},
  {"bodies.[].loads.[].direction", K_FARRAY, NULL, A(U, U, 0, 0, 1, 3), 0, NULL, "nodal `values`: the direction of the forces.", NULL},
  {"bodies.[].loads.[].amplitude", K_FEXPR, NULL, NONE, 0, "1", "Time factor multiplying the load: a number or an expression in t.", NULL},
  {"bodies.[].body_force", K_VEXPR, NULL, A(U, U, 0, 0, 1, 3), 0, "zero", "Body force per unit mass (m/s^2), e.g. gravity [0.0, -9.81].", NULL},
  {"bodies.[].initial", K_GROUP, NULL, NONE, 0, NULL, "Initial fields.", NULL},
  {"bodies.[].initial.displacement", K_VEXPR, NULL, A(U, U, 0, 0, 1, 3), 0, "zero", "Initial displacement: dim numbers or expressions in x, y, z.", NULL},
  {"bodies.[].initial.velocity", K_VEXPR, NULL, A(U, U, 0, 0, 1, 3), 0, "zero", "Initial velocity: dim numbers or expressions in x, y, z (rigid bodies: of the centroid).", NULL},
  {"bodies.[].initial.omega", K_VEXPR, NULL, A(U, U, 0, 0, 1, 3), 0, "zero", "Rigid bodies: initial angular velocity (2D: one value; 3D: three, world frame) (rad/s).", NULL},

  /* --- time -------------------------------------------------------------------------------- */
  {"time", K_GROUP, NULL, NONE, 1, NULL, "Time integration.", NULL},
  {"time.scheme", K_ENUM, "theta|explicit|newmark|quasistatic", NONE, 0, "\"theta\"", "theta: the velocity theta-scheme shared by nscd and levelset; explicit: central differences with lumped mass (the theta-scheme at theta = 1, theta_f = 0, contact by forward-increment impulses, doc/theory.md §1.7); newmark: Newmark (beta, gamma) on displacements; quasistatic: load steps without inertia.", NULL},
  {"time.dt", K_FLOAT, NULL, POS, 0, NULL, "Time step h (s). Required by the dynamic schemes.", "the time step must be positive"},
  {"time.end", K_FLOAT, NULL, POS, 0, NULL, "End time (s); or give `steps`.", "the end time must be positive"},
  {"time.steps", K_INT, NULL, R(1, 1e9, 0, 0), 0, "1 (quasistatic)", "Number of steps (load steps for quasistatic).", NULL},
  {"time.theta", K_FLOAT, NULL, R(0, 1, 0, 0), 0, "0.5", "theta of u+ = u + h [theta v+ + (1 - theta) v-]; below 1/2 only conditionally stable (a warning gives the limit, doc/theory.md (T101)).", "theta must lie in [0, 1]"},
  {"time.theta_f", K_FLOAT, NULL, R(0, 1, 0, 0), 0, "theta", "Weight of f(t+) in the momentum balance: theta (Moreau-Jean) or 1 (Ben Dhia-Zammali); below 1/2 only conditionally stable (T101).", "theta_f must lie in [0, 1]"},
  {"time.beta", K_FLOAT, NULL, R(0, 0.5, 1, 0), 0, "0.25", "Newmark beta.", "Newmark beta must lie in (0, 0.5]"},
  {"time.gamma", K_FLOAT, NULL, R(0.5, 1, 0, 0), 0, "0.5", "Newmark gamma.", "Newmark gamma must lie in [0.5, 1] (below 1/2 the scheme is unstable)"},
  {"time.max_cuts", K_INT, NULL, R(0, 12, 0, 0), 0, "0", "Step cutting: a step whose contact solve or Newton iterations do not converge, or that meets a NaN, an inverted element or an indefinite matrix, is taken again as two steps of h/2, and so on down to h / 2^max_cuts; 0 stops the run at the first failure (doc/theory.md §1.5).", "time.max_cuts lies in 0 .. 12 (at most 4096 substeps per step)"},
  {"time.newton", K_GROUP, NULL, NONE, 0, NULL, "Newton iterations of the steps of nonlinear scenes (finite-strain materials).", NULL},
  {"time.newton.tol", K_FLOAT, NULL, R(0, 1e-2, 1, 0), 0, "1e-8", "A step ends when the residual of its momentum balance is at most tol times the balance's scale (doc/theory.md (T64)).", "a Newton tolerance lies in (0, 0.01]"},
  {"time.newton.max_iter", K_INT, NULL, R(1, 1000, 0, 0), 0, "25", "Newton iterations per step before the run stops with a diagnosis.", NULL},

  /* --- contact ----------------------------------------------------------------------------- */
  {"contact", K_GROUP, NULL, NONE, 0, NULL, "Contact pairs and the back end that solves them.", NULL},
  {"contact.solver", K_STRING, NULL, NONE, 0, "\"nscd\"", "Contact back end (moreau list-solvers); --solver S overrides it.", NULL},
  {"contact.signorini", K_ENUM, "position|velocity", NONE, 0, "\"velocity\"", "What the unilateral condition controls for back ends on the local problem with the theta-scheme: the normal velocity of candidates predicted closed (Moreau; no chatter) or the end-of-step gap (J88 (3.2)_1; chatters at theta = 1/2, doc/theory.md (T93)).", NULL},
  {"contact.position_correction", K_ENUM, "project|shift|none", NONE, 0, "\"none\"", "Velocity-level Signorini with the theta-scheme: none (Moreau-Jean as usual): the drift of the landing steps is left, bounded and reported (metrics.contact.max_penetration, final_penetration); project: project the end-of-step positions onto the admissible set (g >= 0) in the norm of What with the step's Delassus operator, the energy the shift would add taken from the kinetic energy (energy not increased, momentum changed by the reported amount; doc/theory.md (T94)-(T96)); shift: the projection alone (momentum exact, energy may grow by the reported amount).", NULL},
  {"contact.geometry", K_ENUM, "reference|step", NONE, 0, "\"reference\"", "Pairing: once in the reference configuration (small strains, small sliding) or again at the start of every step.", NULL},
  {"contact.reactions", K_ENUM, "concentrated|weighted", NONE, 0, NULL, "Short form setting the reactions of every pair (it overrides contact.pairs.[].reactions).", NULL},
  {"contact.alert", K_FLOAT, NULL, NONNEG, 0, "a tenth of the smallest rigid body", "Alert distance of the detection between rigid bodies (m): pairs closer than this (plus what they can travel in a step) are candidates of the step.", NULL},
  {"contact.skin", K_FLOAT, NULL, NONNEG, 0, "half the smallest rigid body (at least contact.alert)", "Margin of the broad phase's pair list between rigid shapes (m): the list holds the pairs within the alert distance plus this, and is built again when a body has moved, relative to the bodies' mean motion, by more than half of it (doc/theory.md (T110)); a wider skin builds the list less often and tests more pairs at each step.", NULL},
  {"contact.verlet", K_ENUM, "auto|global|blocks", NONE, 0, "\"auto\"", "How the broad phase's pair list between rigid shapes is kept (doc/theory.md (T110)-(T111), §12.26): global: built again whole when a body has moved by half the skin relative to the bodies' mean motion; blocks: the bodies grouped in blocks of neighbours, each in its own frame, and only the blocks and pairs of blocks whose frames fail made again (a column falling onto a bed keeps the list of the falling part and of the bed); auto: blocks from 4096 shapes, global below. Over MPI ranks the list is the global one whatever the setting (the ranks' slabs are cut at its builds). The candidates, and so the results, do not depend on it.", NULL},
  {"contact.detect_split_min", K_INT, NULL, R(0, 1e9, 0, 0), 0, "64", "Over MPI ranks, granular scenes: the contact detection is split over the ranks (each its part of space, the candidates gathered) only when the pairs between rigid shapes hold at least this many bodies a rank; a smaller scene is detected whole on every rank, as one process detects it, with no message (doc/theory.md (T337)). The candidates, and so the results, do not depend on it. 0: split whatever the size.", NULL},
  {"contact.delassus", K_ENUM, "auto|always", NONE, 0, "\"auto\"", "auto: where every candidate joins rigid bodies and obstacles, a back end that can (nscd) sweeps on body velocities and W = H^T What^-1 H is not built; always: W is built and used at every step (the two give the same solutions to the solver's tolerance: a check, and the Delassus path's cost).", NULL},
  {"contact.distributed_set", K_BOOL, NULL, NONE, 0, "false", "Over MPI ranks, granular scenes whose detection is split (contact.detect_split_min), nscd only: each rank keeps only the contacts it detected (their geometry, reactions, statuses and histories), the sweep's interface joined by messages between the ranks that share a body, and the outputs gathered to rank 0 when written; no rank holds the whole contact set (doc/scaling.md §4); on scenes of rigid bodies and obstacles with every dof free, each rank steps only the bodies of its box and halo (doc/theory.md §13.18). Experimental: a contact whose point moves to another rank's box at a build of the pair list starts from a zero reaction there.", NULL},
  {"contact.compact", K_BOOL, NULL, NONE, 0, "true", "Where every candidate is a detected contact between rigid shapes (disks, spheres, polygons) or a shape and a plane, and the back end reads them (nscd): the narrow phase writes one compact record per contact and H is built only for what needs it (doc/theory.md §12.9); false: points, candidates and H at every step as for any scene (the same results to the bit, slower: a check).", NULL},
  {"contact.factor_order", K_ENUM, "contact_last|solver", NONE, 0, "\"contact_last\"", "contact_last: the free dofs contact acts on are ordered last in the factorization of What, so that W comes from its trailing block (the inverse of the Schur complement on them) and a step takes one forward solve, the contact problem and one backward solve (doc/theory.md §13); solver: CHOLMOD's own order, W by one solve per column and the correction by a further solve (the path before; the same results to round-off).", NULL},
  {"contact.on_failure", K_ENUM, "stop|continue", NONE, 0, "\"stop\"", "A contact solve that does not converge stops the run with a diagnosis, or is counted and the run goes on.", NULL},
  {"contact.pairs", K_LIST, NULL, A(U, U, 0, 0, 1, 0), 1, NULL, "Contact pairs: a slave surface against a master (a plane or a facet set).", NULL},
  {"contact.pairs.[].name", K_STRING, NULL, NONE, 0, "pairK", "Pair name (reports, contact.csv).", NULL},
  {"contact.pairs.[].active", K_BOOL, NULL, NONE, 0, "true", "false leaves the pair out (variants of a scene chosen with --set).", NULL},
  {"contact.pairs.[].slave", K_STRING, NULL, NONE, 1, NULL, "Slave body, or a group of generated bodies (NAME of an arch entry).", NULL},
  {"contact.pairs.[].slave_set", K_STRING, NULL, NONE, 0, NULL, "Slave surface of a mesh body: a facet set (or, for concentrated reactions at nodes, a node set).", NULL},
  {"contact.pairs.[].master", K_STRING, NULL, NONE, 1, NULL, "Master body (or group): a plane, a rigid body, or a mesh body with master_set.", NULL},
  {"contact.pairs.[].master_set", K_STRING, NULL, NONE, 0, NULL, "Master facet set of a mesh body (deformable or rigid).", NULL},
  {"contact.pairs.[].law", K_ENUM, "impact|gap", NONE, 0, "\"impact\"", "Pairs with a rigid body: Moreau's impact law U_n+ + e U_n- >= 0 on the contacts predicted closed (T71), or Signorini on the end-of-step gap g + h (theta U_n+ + (1 - theta) U_n-) >= 0 (T78): no restitution, and no overlap left by a fast approach (granular deposits).", NULL},
  {"contact.pairs.[].e", K_FLOAT, NULL, R(0, 1, 0, 0), 0, "0", "Newton's restitution coefficient of Moreau's impact law U_n+ + e U_n- >= 0 (pairs with a rigid body; doc/theory.md (T71)).", "a restitution coefficient lies in [0, 1]"},
  {"contact.pairs.[].mu", K_FLOAT, NULL, NONNEG, 0, "0", "Coulomb friction coefficient.", "a friction coefficient is not negative"},
  {"contact.pairs.[].reactions", K_ENUM, "concentrated|weighted", NONE, 0, "\"concentrated\"", "Reactions concentrated at the candidates, or P-weighted densities on dual cells (J88 §4.4).", NULL},
  {"contact.pairs.[].collocation", K_ENUM, "nodes|gauss", NONE, 0, "\"nodes\"", "Candidates at the slave nodes, or at Gauss points of the slave facets.", NULL},
  {"contact.pairs.[].gauss", K_INT, NULL, R(1, 4, 0, 0), 0, "2", "Gauss collocation: points per direction of each facet or segment.", NULL},
  {"contact.pairs.[].integration", K_ENUM, "segments|facet", NONE, 0, "\"segments\"", "Gauss collocation against a mesh master: Gauss points on the parts of each slave facet cut by the master facets (mortar segmentation, exact on non-matching meshes), or on the whole slave facet (doc/theory.md §4.7).", NULL},
  {"contact.pairs.[].ends", K_ENUM, "dual|half|extend", NONE, 0, "\"dual\"", "Weighted reactions: how dual cells end where the slave surface ends (doc/theory.md §4.3).", NULL},
  {"contact.pairs.[].off_master", K_ENUM, "nearest|inactive", NONE, 0, "\"nearest\"", "A slave point projecting off the master surface pairs with the nearest facet (clamped), or is inactive.", NULL},
  {"contact.pairs.[].exclude", K_STRING, NULL, NONE, 0, NULL, "Node set of slave nodes that are not candidates.", NULL},

  /* --- output ------------------------------------------------------------------------------ */
  {"linear_solver", K_GROUP, NULL, NONE, 0, NULL, "The solver of the iteration matrix What (M + c K, or K for quasi-static steps; doc/parallel.md).", NULL},
  {"linear_solver.type", K_ENUM, "cholmod|petsc", NONE, 0, "\"cholmod\" (\"petsc\" under mpirun with more than one rank)", "cholmod: CHOLMOD's supernodal Cholesky factorization on one process; petsc: PETSc's KSP distributed over the MPI ranks (builds configured --with-petsc).", NULL},
  {"linear_solver.ksp", K_STRING, NULL, NONE, 0, "\"preonly\"", "petsc: the Krylov method by PETSc's name (preonly: the factorization alone; cg, gmres, ...).", NULL},
  {"linear_solver.pc", K_STRING, NULL, NONE, 0, "\"cholesky\"", "petsc: the preconditioner by PETSc's name (cholesky, lu: a direct factorization by 'package'; gamg, jacobi, ...).", NULL},
  {"linear_solver.package", K_STRING, NULL, NONE, 0, "\"mumps\"", "petsc with pc cholesky or lu: the factorization package (mumps, superlu_dist, petsc).", NULL},
  {"linear_solver.rtol", K_FLOAT, NULL, R(0, 1, 1, 1), 0, "1e-10", "petsc with an iterative ksp: the relative tolerance of each solve.", "a relative tolerance lies in (0, 1)"},
  {"linear_solver.options", K_STRING, NULL, NONE, 0, "\"\"", "petsc: PETSc options passed through, e.g. \"-pc_gamg_threshold 0.05 -ksp_norm_type unpreconditioned\".", NULL},
  {"linear_solver.out_of_core", K_BOOL, NULL, NONE, 0, "false", "petsc with ksp preonly, pc cholesky or lu and package mumps: MUMPS keeps the factor on disk (ICNTL(22)), in a folder of the run's own removed at its end; the memory needed is MUMPS's out-of-core estimate (doc/theory.md (T181)-(T182)).", NULL},
  {"linear_solver.ooc_dir", K_STRING, NULL, NONE, 0, "TMPDIR, else /tmp", "with out_of_core: where the folder of the factor's files is made.", NULL},
  {"output", K_GROUP, NULL, NONE, 0, NULL, "What is written.", NULL},
  {"output.every", K_INT, NULL, R(1, U, 0, 0), 0, "1", "Write a history row every N steps (the first and last steps are always written).", NULL},
  {"output.precision", K_INT, NULL, R(3, 17, 0, 0), 0, "10", "Significant digits in CSV files.", NULL},
  {"output.energy", K_BOOL, NULL, NONE, 0, "true", "History columns energy.kinetic, energy.elastic, energy.total, energy.external_work.", NULL},
  {"output.probes", K_LIST, NULL, NONE, 0, NULL, "Points whose histories are written to history.csv.", NULL},
  {"output.probes.[].name", K_STRING, NULL, NONE, 1, NULL, "Column prefix (columns are name.quantity).", NULL},
  {"output.probes.[].body", K_STRING, NULL, NONE, 0, "the first body", "Body observed.", NULL},
  {"output.probes.[].set", K_STRING, NULL, NONE, 0, NULL, "Node set: values are averaged over its nodes (forces summed).", NULL},
  {"output.probes.[].point", K_FARRAY, NULL, A(U, U, 0, 0, 1, 3), 0, NULL, "The node nearest to this point.", NULL},
  {"output.probes.[].node", K_INT, NULL, R(0, U, 0, 0), 0, NULL, "A node number (0-based).", NULL},
  {"output.probes.[].quantities", K_SARRAY, "ux|uy|uz|vx|vy|vz|fx|fy|fz|cx|cy|cz|pn|gn|lam", A(U, U, 0, 0, 1, 15), 1, NULL, "u: displacement, v: velocity, f: support reaction, c: contact force (summed over the set), pn: contact pressure, gn: gap, lam: friction semi-multiplier |r_t| / (mu r_n) (candidates at the set's nodes, averaged).", NULL},
  {"output.extents", K_LIST, NULL, NONE, 0, NULL, "Node sets whose bounding box in the current configuration summary.json reports at the end (metrics.extents).", NULL},
  {"output.extents.[].name", K_STRING, NULL, NONE, 1, NULL, "Name of the extent (metrics.extents.NAME.xmin ...).", NULL},
  {"output.extents.[].body", K_STRING, NULL, NONE, 0, "the first body", "Body measured.", NULL},
  {"output.extents.[].set", K_STRING, NULL, NONE, 0, "\"all\"", "Node set measured.", NULL},
  {"output.report", K_SARRAY, NULL, A(U, U, 0, 0, 1, 16), 0, NULL, "Headline metrics: compare.csv columns (e.g. extents.bar.ymax, energy.balance_relative) that moreau compare lists in report.md for this case.", NULL},
  {"output.contact_table", K_BOOL, NULL, NONE, 0, "false", "Print the candidates' table in Jean's layout at the end of the run (node, D1, D2, RT, RN and the other representation's columns).", NULL},
  {"output.vtk", K_GROUP, NULL, NONE, 0, NULL, "VTK XML field series (fields.pvd + .vtu), written when present.", NULL},
  {"output.vtk.every", K_INT, NULL, R(1, U, 0, 0), 0, "10", "Write fields every N steps (and at the last step).", NULL},
  {"output.vtk.fields", K_SARRAY, "displacement|velocity|stress|strain|von_mises|eps_p", A(U, U, 0, 0, 1, 6), 0, "all", "Fields written (eps_p: equivalent plastic strain of j2 bodies).", NULL},
  {"output.vtk.contacts", K_ENUM, "all|closed|none", NONE, 0, "\"all\"", "Candidates in contact_points.pvd (a scene with contact): all, the closed ones (a status other than open, or a reaction), or none (no series).", NULL},
  {"output.contact_history", K_GROUP, NULL, NONE, 0, NULL, "contact_history.csv, written when present: contact.csv's rows for every output step, prefixed by step and t.", NULL},
  {"output.contact_history.every", K_INT, NULL, R(1, U, 0, 0), 0, "output.every", "A block of rows every N steps (the first and last steps always).", NULL},
  {"output.contact_history.candidates", K_ENUM, "all|closed", NONE, 0, "\"all\"", "Rows for every candidate, or for the closed ones only.", NULL},
  {"output.draw", K_GROUP, NULL, NONE, 0, NULL, "Drawings without ParaView, written when present: plots/draw.dat and plots/draw.gp, rendered by gnuplot (when on PATH) into plots/snapshots.png and plots/animation.gif (2D; a 3D scene is drawn in x-y projection).", NULL},
  {"output.draw.frames", K_INT, NULL, R(1, 64, 0, 0), 0, "8", "Snapshots in snapshots.png, evenly spaced from t = 0 to the end, each titled with its time.", "output.draw.frames lies in 1 .. 64"},
  {"output.draw.gif", K_BOOL, NULL, NONE, 0, "true when gnuplot has the gif terminal", "Also animation.gif, the whole run in at most 200 frames.", NULL},
  {"output.draw.every", K_INT, NULL, R(1, U, 0, 0), 0, "steps / 100", "Steps between frames of the GIF (and the last step); raised when the GIF would have more than 200 frames.", NULL},
  {"output.draw.box", K_FARRAY, NULL, A(U, U, 0, 0, 4, 4), 0, "everything drawn, with a margin", "The view [xmin, xmax, ymin, ymax] (m).", NULL},
  {"output.draw.forces", K_BOOL, NULL, NONE, 0, "true", "Draw the contact network: a segment per closed contact, wider as its normal force r_n grows.", NULL},

  /* --- reference solution ------------------------------------------------------------------ */
  {"reference", K_GROUP, NULL, NONE, 0, NULL, "A closed-form solution the core compares the probes with (errors in summary.json).", NULL},
  {"reference.type", K_ENUM, "bar_release|bar_step_velocity|rods_impact|bar_obstacle|energy|bounce|incline|struck_bar", NONE, 1, NULL, "energy: only the exact total energy (key energy); bar_release: bar clamped at x = origin, free at origin + L, released at rest from a uniform strain; bar_step_velocity: same bar, the far end given a constant velocity from rest; rods_impact: a rod against a rigid wall (or each of two identical rods); bar_obstacle: Doyen-Ern-Piperno's bar released against an obstacle (doc/theory.md §3); bounce: a rigid ball dropped on a plane (y up); incline: a rigid block, disk or sphere released on a slope descending toward +x; struck_bar: a bar struck at x = origin by a rigid mass (doc/theory.md §12.6).", NULL},
  {"reference.body", K_STRING, NULL, NONE, 0, "the first deformable body", "The body the closed form describes (field errors).", NULL},
  {"reference.length", K_FLOAT, NULL, POS, 0, NULL, "Bar length L (m).", NULL},
  {"reference.wave_speed", K_FLOAT, NULL, POS, 0, NULL, "Wave speed c (sqrt(E / rho) for bars; state which one for 2D and 3D models) (m/s).", NULL},
  {"reference.strain", K_FLOAT, NULL, NONE, 0, NULL, "bar_release: initial uniform strain.", NULL},
  {"reference.velocity", K_FLOAT, NULL, NONE, 0, NULL, "bar_step_velocity: velocity of the far end; rods_impact: speed toward the obstacle (> 0) (m/s).", NULL},
  {"reference.origin", K_FLOAT, NULL, NONE, 0, "0", "bar_release, bar_step_velocity: x of the clamped end; bar_obstacle: x of the contact end.", NULL},
  {"reference.contact_end", K_FLOAT, NULL, NONE, 0, NULL, "rods_impact: x of the rod's contact end in the reference configuration.", NULL},
  {"reference.direction", K_FLOAT, NULL, NONE, 0, "1", "rods_impact: +1 when the rod moves toward +x, -1 toward -x.", NULL},
  {"reference.gap", K_FLOAT, NULL, NONNEG, 0, NULL, "rods_impact: distance the contact end travels before impact (half the gap of two identical rods) (m).", NULL},
  {"reference.amplitude", K_FLOAT, NULL, NONE, 0, NULL, "bar_obstacle: initial displacement of the contact end (u0 = a (1 - x/L)) (m).", NULL},
  {"reference.density", K_FLOAT, NULL, POS, 0, "1", "Density, for contact forces and pressures (kg/m^3).", NULL},
  {"reference.area", K_FLOAT, NULL, POS, 0, "1", "Cross-section, for contact forces (m^2).", NULL},
  {"reference.gravity", K_FLOAT, NULL, POS, 0, "9.81", "bounce, incline: gravity g (m/s^2), acting along -y.", NULL},
  {"reference.height", K_FLOAT, NULL, POS, 0, NULL, "bounce: initial height of the ball's bottom above the plane (m).", NULL},
  {"reference.restitution", K_FLOAT, NULL, R(0, 1, 0, 0), 0, NULL, "bounce: Newton's restitution coefficient e.", NULL},
  {"reference.angle", K_FLOAT, NULL, R(0, 90, 0, 1), 0, NULL, "incline: slope angle (degrees); the slope descends toward +x.", NULL},
  {"reference.mu", K_FLOAT, NULL, NONNEG, 0, NULL, "incline: friction coefficient of the body on the slope.", NULL},
  {"reference.mass", K_FLOAT, NULL, POS, 0, NULL, "struck_bar: the striking mass M (kg, per unit thickness in 2D).", NULL},
  {"reference.energy", K_FLOAT, NULL, NONE, 0, "E(0)", "Exact total mechanical energy, potential of the external loads included (e.g. m g h for a body dropped from h): energy ratios are E(t) / energy with E(t) = kinetic + elastic - external work - support work + (energy - E(0)) (J).", NULL},
};

/* Back-end options appear as contact.<backend>.<option>; their specs come from the registry,
   so a new back end's options are validated and documented the moment it is registered. */
static int backend_key(const char *path, mo_key *out, const mo_ctx *ctx)
{
  char name[64];
  const char *rest, *dot;
  const mo_contact_solver_type *T;
  int k;
  size_t len;
  if (strncmp(path, "contact.", 8)) return 0;
  rest = path + 8;
  dot = strchr(rest, '.');
  len = dot ? (size_t)(dot - rest) : strlen(rest);
  if (len == 0 || len >= sizeof name) return 0;
  memcpy(name, rest, len);
  name[len] = '\0';
  T = mo_contact_solver_lookup(name, ctx);
  if (!T) return 0;
  memset(out, 0, sizeof *out);
  out->lo = out->hi = NAN;
  if (!dot) {
    out->path = path;
    out->type = K_GROUP;
    out->doc = T->summary;
    return 1;
  }
  for (k = 0; k < T->noptions; k++) {
    const mo_option_spec *o = &T->options[k];
    if (strcmp(o->name, dot + 1)) continue;
    out->path = path;
    out->type = o->type == MO_OPT_INT ? K_INT : o->type == MO_OPT_DOUBLE ? K_FLOAT
              : o->type == MO_OPT_BOOL ? K_BOOL : K_ENUM;
    out->enums = o->type == MO_OPT_ENUM ? o->enums : NULL;
    out->lo = o->lo;
    out->hi = o->hi;
    out->deflt = o->deflt;
    out->doc = o->doc;
    return 1;
  }
  return 0;
}

int mo_schema_lookup(const char *path, mo_key *out, const mo_ctx *ctx)
{
  size_t k;
  for (k = 0; k < MO_COUNT(core_keys); k++)
    if (!strcmp(core_keys[k].path, path)) {
      *out = core_keys[k];
      return 1;
    }
  return backend_key(path, out, ctx);
}

static const char *type_name(mo_key_type t)
{
  switch (t) {
  case K_GROUP: return "group";
  case K_LIST: return "list of groups";
  case K_FLOAT: return "number";
  case K_INT: return "integer";
  case K_BOOL: return "boolean";
  case K_STRING: return "string";
  case K_ENUM: return "string";
  case K_FARRAY: return "array of numbers";
  case K_IARRAY: return "array of integers";
  case K_SARRAY: return "string or array of strings";
  case K_NUMS: return "number or array of numbers";
  case K_INTS: return "integer or array of integers";
  case K_FEXPR: return "number or expression";
  case K_VEXPR: return "numbers or expressions";
  }
  return "?";
}

const char *mo_key_type_name(mo_key_type t);
const char *mo_key_type_name(mo_key_type t) { return type_name(t); }

static void visit_one(const mo_key *K, mo_key_visit fn, void *data)
{
  char range[160] = "";
  if (K->enums) snprintf(range, sizeof range, "%s", K->enums);
  else if (!isnan(K->lo) || !isnan(K->hi)) {
    char lo[40] = "-inf", hi[40] = "inf";
    if (!isnan(K->lo)) snprintf(lo, sizeof lo, "%g", K->lo);
    if (!isnan(K->hi)) snprintf(hi, sizeof hi, "%g", K->hi);
    snprintf(range, sizeof range, "%c%s, %s%c", K->lo_open || isnan(K->lo) ? '(' : '[', lo, hi,
             K->hi_open || isnan(K->hi) ? ')' : ']');
  }
  fn(K->path, type_name(K->type), range, K->required ? "required" : (K->deflt ? K->deflt : ""),
     K->doc, data);
}

void mo_case_schema_visit_ctx(mo_key_visit fn, void *data, const mo_ctx *ctx)
{
  size_t k;
  int b, o;
  for (k = 0; k < MO_COUNT(core_keys); k++) visit_one(&core_keys[k], fn, data);
  for (b = 0; b < mo_contact_solver_total(ctx); b++) {
    const mo_contact_solver_type *T = mo_contact_solver_nth(b, ctx);
    char path[160];
    mo_key K;
    snprintf(path, sizeof path, "contact.%s", T->name);
    if (backend_key(path, &K, ctx)) visit_one(&K, fn, data);
    for (o = 0; o < T->noptions; o++) {
      snprintf(path, sizeof path, "contact.%s.%s", T->name, T->options[o].name);
      if (backend_key(path, &K, ctx)) visit_one(&K, fn, data);
    }
  }
}

void mo_case_schema_visit(mo_key_visit fn, void *data)
{
  mo_case_schema_visit_ctx(fn, data, NULL);
}
