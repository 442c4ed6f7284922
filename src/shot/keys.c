/* keys.c — the one table of shot-file keys, and everything read straight
 * from it: converting a node to a field, range checks and their message,
 * defaults, and `kerf help shot`.
 *
 * Adding a key is adding a row here (and a field it writes); the loader,
 * overrides, error text and help pick it up with no other change. */
#include <ctype.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "internal.h"

/* ---- the table ------------------------------------------------------------------ */

#define F(T, m) offsetof(T, m), sizeof(((T *)0)->m)
#define TOP(m) KS_TOP, F(kf_top, m)
#define MAT(m) KS_MATERIAL, F(kf_shot_material, m)
#define OBJ(m) KS_OBJECT, F(kf_shot_object, m)
#define COL(m) KS_COLLIDER, F(kf_shot_collider, m)
#define KEY(m) KS_KEY, F(kf_rawkey, m)
#define RIG(m) KS_RIGID, F(kf_shot_rigid, m)
#define JNT(m) KS_JOINT, F(kf_shot_joint, m)
#define NOFIELD 0, 0

#define ANY 0, 0.0, 0.0
#define GT(a) KB_LO | KB_LO_OPEN, (double)(a), 0.0
#define GE(a) KB_LO, (double)(a), 0.0
#define CC(a, b) KB_LO | KB_HI, (double)(a), (double)(b)                           /* [a, b] */
#define OO(a, b) KB_LO | KB_LO_OPEN | KB_HI | KB_HI_OPEN, (double)(a), (double)(b) /* (a, b) */
#define CO(a, b) KB_LO | KB_HI | KB_HI_OPEN, (double)(a), (double)(b)              /* [a, b) */
#define OC(a, b) KB_LO | KB_LO_OPEN | KB_HI, (double)(a), (double)(b)              /* (a, b] */

#define PRESET_DEF "(the preset's)"
#define SOLID "model=corotated|von_mises|sand|snow"

/* path, type, scope + field, bounds, choices, default, unit, only, flags, doc */
const kf_keydef kf_keys[] = {
    {"shot", KT_STR, TOP(s.name), ANY, NULL, "(the file name without extension)", NULL, NULL, KF_IDENT,
     "Name of the shot: {shot} in output templates."},
    {"version", KT_INT, TOP(s.version), CC(0, 9999), NULL, "1", NULL, NULL, 0,
     "Version: {version} in output templates; bump it to keep earlier results."},

    {"frames", KT_SECTION, KS_TOP, NOFIELD, ANY, NULL, NULL, NULL, NULL, KF_REQ, "The frame range and rate."},
    {"frames.start", KT_INT, TOP(s.frame_start), CC(0, 9999999), NULL, "1001", NULL, NULL, 0,
     "First frame (the VFX convention is 1001)."},
    {"frames.end", KT_INT, TOP(s.frame_end), CC(0, 9999999), NULL, NULL, NULL, NULL, KF_REQ,
     "Last frame, inclusive."},
    {"frames.fps", KT_NUM, TOP(s.fps), OC(0, 1000), NULL, "24", "frames/s", NULL, 0, "Frames per second."},

    {"sim", KT_SECTION, KS_TOP, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0, "Solver settings."},
    {"sim.dx", KT_NUM, TOP(s.sim.dx), OC(0, 10), NULL, "0.02", "m", NULL, 0,
     "Grid spacing; particles grow as 1/dx^3. --quality preview doubles it."},
    {"sim.ppc", KT_INT, TOP(s.ppc), ANY, "1|8|27|64", "8", NULL, NULL, 0, "Particles per grid cell when seeding."},
    {"sim.cfl", KT_NUM, TOP(s.sim.cfl), OC(0, 2), NULL, "0.4", NULL, NULL, 0,
     "CFL number: a substep is cfl * dx / (wave speed + fastest particle)."},
    {"sim.dt_max", KT_NUM, TOP(s.sim.dt_max), GE(0), NULL, "0", "s", NULL, 0,
     "Longest substep allowed (0 = only the CFL rule)."},
    {"sim.dt_fixed", KT_NUM, TOP(s.sim.dt_fixed), GE(0), NULL, "0", "s", NULL, 0,
     "Fixed substep instead of the CFL rule (0 = adaptive); for tests and benchmarks. Fixed means fixed: "
     "numerical trouble at it fails the frame naming the step, unless sim.retry_fixed lets a retry halve it."},
    {"sim.retry_fixed", KT_BOOL, TOP(s.sim.retry_fixed), ANY, NULL, "false", NULL, NULL, 0,
     "Under sim.dt_fixed, let a frame that runs into numerical trouble be retried at half the fixed step "
     "(up to sim.max_retries times; each retry is logged with the step it used)."},
    {"sim.gravity", KT_VEC3, TOP(s.sim.gravity), ANY, NULL, "[0, -9.81, 0]", "m/s^2", NULL, 0,
     "Gravitational acceleration."},
    {"sim.kernel", KT_ENUM, TOP(s.sim.kernel), ANY, "quadratic|cubic", "quadratic", NULL, NULL, 0,
     "B-spline interpolation kernel."},
    {"sim.force", KT_ENUM, TOP(s.sim.force), ANY, "mls|classic", "mls", NULL, NULL, 0,
     "Force discretisation: MLS-MPM, or classic MPM with kernel gradients."},
    {"sim.transfer", KT_ENUM, TOP(s.sim.transfer), ANY, "apic|pic", "apic", NULL, NULL, 0,
     "Particle-grid transfer: APIC keeps rotation, PIC damps it."},
    {"sim.max_retries", KT_INT, TOP(s.sim.max_retries), CC(0, 16), NULL, "4", NULL, NULL, 0,
     "Times a frame is retried at half the CFL number after numerical trouble."},
    {"sim.jitter", KT_BOOL, TOP(s.jitter), ANY, NULL, "true", NULL, NULL, 0,
     "Jitter the seeding lattice so no grid pattern shows."},
    {"sim.seed", KT_INT, TOP(s.seed), CC(1, 2147483647), NULL, "1", NULL, NULL, 0, "Random seed of the jitter."},
    {"sim.contact", KT_ENUM, TOP(contact), ANY, "on|off|auto", "auto", NULL, NULL, 0,
     "Contact between objects: on gives each object its own velocity on the grid nodes it shares with another, "
     "so objects touch where their surfaces meet (within a fraction of a cell), slide on each other with "
     "sim.contact_friction and pull apart freely; off lets objects share one velocity, so they push each other "
     "from about 1.3 cells before their surfaces meet and stay glued where they come close. Pieces a thin body "
     "cuts from a solid (parts no longer connected but through the blade) become objects of their own, 16 per "
     "object, so they part without a bridge; sand and water flow together again. auto is on where the shot has "
     "more than one object, or a thin body and a solid to cut. Measured on two jelly spheres 10 cells in radius "
     "meeting at 0.2 m/s: off, momentum passed between them 28% longer than Hertz's elastic contact lasts and "
     "their surfaces never came closer than 1.27 cells; on, within 1% of Hertz's time and the surfaces closed "
     "to -0.09 cells (tools/evidence/contact_results.md). Explicit integration only (sim.integrator: implicit "
     "ignores it)."},
    {"sim.contact_friction", KT_NUM, TOP(s.sim.contact_friction), GE(0), NULL, "0.3", NULL, NULL, 0,
     "Coulomb friction between objects in contact (sim.contact): they stick while the sliding force is below "
     "this times the pressing force."},
    {"sim.threads", KT_INT, TOP(s.sim.threads), CC(0, 1024), NULL, "0", NULL, NULL, 0,
     "Worker threads (0 = OMP_NUM_THREADS or every core)."},
    {"sim.integrator", KT_ENUM, TOP(s.sim.integrator), ANY, "explicit|implicit", "explicit", NULL, NULL, 0,
     "Time integration: explicit (symplectic Euler, substep limited by the elastic wave speed) or implicit "
     "(Newton-Krylov on the grid velocities: substeps limited by advection alone, for stiff solids; see "
     "sim.implicit_scheme). Implicit covers corotated, von_mises, sand and snow; water and rigid bodies need "
     "explicit. Its step: sim.dt_fixed, or sim.cfl on advection alone. Measured on a 40 cm bar thrown tumbling "
     "at E = 1e6 Pa, 20x the explicit step: the midpoint scheme costs 0.42x what explicit needs for the same "
     "error (0.08 mm); backward Euler at that step is 6.5 mm off. Every substep's transfers also damp motion "
     "finer than a few cells (a wobbling body 4 cells across), so fewer, larger substeps keep more wobble. At "
     "hundreds of explicit steps per substep the solves slow down on moving bodies (~100 CG iterations per "
     "Newton iteration)."},
    {"sim.implicit_scheme", KT_ENUM, TOP(s.sim.implicit_scheme), ANY, "backward_euler|midpoint", "backward_euler",
     NULL, "integrator=implicit", KF_SOFT,
     "The implicit step: backward_euler (first order; damps wobble and swing the substeps do not resolve, its "
     "bodies fall 1/2 g dt t too far; robust at any step) or midpoint (the same solve over half the substep, "
     "the particles then move with that velocity: second order, gravity's arc exact, no numerical damping, same "
     "cost; it keeps the look of explicit: the snow shot at preview took 22 s against explicit's 189 s and "
     "broke the wall as explicit does, where backward Euler's damped impact, 18 s, left it whole). Midpoint "
     "keeps fast oscillations it cannot resolve rather than damping them."},
    {"sim.newton_tol", KT_NUM, TOP(s.sim.newton_tol), GT(0), NULL, "1e-3", NULL, "integrator=implicit", KF_SOFT,
     "Newton stops when the residual, relative to the momentum scale, is below this."},
    {"sim.newton_max", KT_INT, TOP(s.sim.newton_max), CC(1, 1000), NULL, "20", NULL, "integrator=implicit", KF_SOFT,
     "Most Newton iterations per substep."},
    {"sim.krylov_tol", KT_NUM, TOP(s.sim.krylov_tol), OO(0, 1), NULL, "1e-2", NULL, "integrator=implicit", KF_SOFT,
     "Conjugate gradients stop when the residual has fallen by this factor."},
    {"sim.krylov_max", KT_INT, TOP(s.sim.krylov_max), CC(1, 100000), NULL, "200", NULL, "integrator=implicit",
     KF_SOFT, "Most conjugate-gradient iterations per Newton iteration."},
    {"sim.precond", KT_ENUM, TOP(s.sim.precond), ANY, "multigrid|jacobi", "multigrid", NULL, "integrator=implicit",
     KF_SOFT,
     "Conjugate-gradient preconditioner: multigrid (coarse grids of 2, 4, 8... x dx; fewer iterations, growing "
     "more slowly with the step: faster from ~20x the explicit step) or jacobi (the Hessian's diagonal; cheaper "
     "to set up: faster at small steps)."},

    {"domain", KT_SECTION, KS_TOP, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0, "The simulation box."},
    {"domain.min", KT_VEC3, TOP(s.sim.domain_min), ANY, NULL, "[0, 0, 0]", "m", NULL, 0, "Lower corner."},
    {"domain.max", KT_VEC3, TOP(s.sim.domain_max), ANY, NULL, "[1, 1, 1]", "m", NULL, 0,
     "Upper corner; above min on every axis."},
    {"domain.walls", KT_ENUM, TOP(walls), ANY, "none|sticky|slip|separate", "separate", NULL, NULL, 0,
     "The box's walls: none (open), sticky, slip (frictionless), separate (material can lift off)."},
    {"domain.friction", KT_NUM, TOP(s.sim.wall_friction), GE(0), NULL, "0.3", NULL, "walls=separate", KF_SOFT,
     "Coulomb friction of separate walls."},

    {"materials", KT_DICT, KS_MATERIAL, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0,
     "Named materials: a preset with any parameter overridden. Names: letters, digits, _ and -."},
    {"materials.*.preset", KT_PRESET, MAT(preset), ANY, NULL, NULL, NULL, NULL, 0,
     "Preset to start from (see the list below)."},
    {"materials.*.color", KT_VEC3, MAT(color), CC(0, 1), NULL, "(by kind: water blue, sand tan, ...)", "sRGB", NULL,
     KF_BROADCAST, "Colour of this material's surface in renders."},
    {"materials.*.specular", KT_NUM, MAT(specular), CC(0, 1), NULL, "(by kind: water 0.6, sand 0.05, ...)", NULL,
     NULL, 0, "Strength of the highlights in renders (0 = matte)."},
    {"materials.*.roughness", KT_NUM, MAT(roughness), CC(0.03, 1), NULL, "(by kind: water 0.15, sand 0.9, ...)",
     NULL, NULL, 0, "Width of the highlights in renders: small is glossy, 1 a broad sheen."},
    {"materials.*.model", KT_ENUM, MAT(mat.model), ANY, "corotated|water|von_mises|sand|snow", PRESET_DEF, NULL,
     NULL, 0, "Constitutive model; required when there is no preset."},
    {"materials.*.density", KT_NUM, MAT(mat.density), GT(0), NULL, PRESET_DEF, "kg/m^3", NULL, 0, "Rest density."},
    {"materials.*.E", KT_NUM, MAT(mat.E), GT(0), NULL, PRESET_DEF, "Pa", SOLID, KF_SOFT, "Young's modulus."},
    {"materials.*.nu", KT_NUM, MAT(mat.nu), CO(0, 0.5), NULL, PRESET_DEF, NULL, SOLID, KF_SOFT, "Poisson ratio."},
    {"materials.*.yield_stress", KT_NUM, MAT(mat.yield_stress), GT(0), NULL, PRESET_DEF, "Pa", "model=von_mises",
     KF_SOFT, "Von Mises uniaxial yield stress."},
    {"materials.*.friction_angle", KT_NUM, MAT(mat.friction_angle), OO(0, 90), NULL, PRESET_DEF, "deg",
     "model=sand", KF_SOFT, "Drucker-Prager friction angle; giving it turns hardening off unless hardening is given."},
    {"materials.*.cohesion", KT_NUM, MAT(mat.cohesion), GE(0), NULL, PRESET_DEF, NULL, "model=sand", KF_SOFT,
     "Tensile cohesion, as a Hencky strain offset."},
    {"materials.*.hardening", KT_BOOL, MAT(mat.hardening), ANY, NULL, PRESET_DEF, NULL, "model=sand", KF_SOFT,
     "Friction angle grows with plastic strain: h0 + (h1 q - h3) exp(-h2 q)."},
    {"materials.*.h0", KT_NUM, MAT(mat.h0), OO(0, 90), NULL, PRESET_DEF, "deg", "model=sand", KF_SOFT,
     "Hardening: limit friction angle."},
    {"materials.*.h1", KT_NUM, MAT(mat.h1), ANY, NULL, PRESET_DEF, "deg", "model=sand", KF_SOFT,
     "Hardening: linear growth."},
    {"materials.*.h2", KT_NUM, MAT(mat.h2), GE(0), NULL, PRESET_DEF, NULL, "model=sand", KF_SOFT,
     "Hardening: decay rate."},
    {"materials.*.h3", KT_NUM, MAT(mat.h3), ANY, NULL, PRESET_DEF, "deg", "model=sand", KF_SOFT,
     "Hardening: h0 - h3 is the initial friction angle."},
    {"materials.*.volume_correction", KT_BOOL, MAT(mat.volume_correction), ANY, NULL, PRESET_DEF, NULL,
     "model=sand", KF_SOFT, "Klar's volume correction of sand pulled apart."},
    {"materials.*.bulk_modulus", KT_NUM, MAT(mat.bulk_modulus), GT(0), NULL, PRESET_DEF, "Pa", "model=water", KF_SOFT,
     "Fluid bulk modulus: p = bulk_modulus (J^-gamma - 1)."},
    {"materials.*.gamma", KT_NUM, MAT(mat.gamma), GE(1), NULL, PRESET_DEF, NULL, "model=water", KF_SOFT,
     "Fluid stiffness exponent (7 for water)."},
    {"materials.*.viscosity", KT_NUM, MAT(mat.viscosity), GE(0), NULL, PRESET_DEF, "Pa s", "model=water", KF_SOFT,
     "Dynamic viscosity (0 = inviscid)."},
    {"materials.*.theta_c", KT_NUM, MAT(mat.theta_c), OO(0, 1), NULL, PRESET_DEF, NULL, "model=snow", KF_SOFT,
     "Snow: critical compression."},
    {"materials.*.theta_s", KT_NUM, MAT(mat.theta_s), OO(0, 1), NULL, PRESET_DEF, NULL, "model=snow", KF_SOFT,
     "Snow: critical stretch."},
    {"materials.*.xi", KT_NUM, MAT(mat.xi), GE(0), NULL, PRESET_DEF, NULL, "model=snow", KF_SOFT,
     "Snow: hardening coefficient."},

    {"objects", KT_LIST, KS_OBJECT, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0,
     "Particle sources, filled at the first frame: each shape is scaled and rotated about its centre, then "
     "placed at center + translate (a fitted mesh: at fit.center + translate)."},
    {"objects[].name", KT_STR, OBJ(name), ANY, NULL, "(shape and position, e.g. box0)", NULL, NULL, KF_IDENT,
     "Name, for messages and --set objects.NAME.key=value."},
    {"objects[].shape", KT_ENUM, OBJ(shape), ANY, "box|sphere|cylinder|mesh", NULL, NULL, NULL, KF_REQ,
     "What to fill."},
    {"objects[].material", KT_REF, OBJ(material_name), ANY, NULL, NULL, NULL, NULL, KF_REQ,
     "A material defined under materials."},
    {"objects[].center", KT_VEC3, OBJ(center), ANY, NULL, NULL, "m", "shape=box|sphere|cylinder", KF_REQ, "Centre."},
    {"objects[].size", KT_VEC3, OBJ(size), GT(0), NULL, NULL, "m", "shape=box", KF_REQ | KF_BROADCAST,
     "Edge lengths (one number: a cube)."},
    {"objects[].radius", KT_NUM, OBJ(radius), GT(0), NULL, NULL, "m", "shape=sphere|cylinder", KF_REQ, "Radius."},
    {"objects[].height", KT_NUM, OBJ(height), GT(0), NULL, NULL, "m", "shape=cylinder", KF_REQ,
     "Length along the axis."},
    {"objects[].axis", KT_ENUM, OBJ(axis), ANY, "x|y|z", "y", NULL, "shape=cylinder", 0, "Cylinder axis."},
    {"objects[].mesh", KT_STR, OBJ(mesh), ANY, NULL, NULL, NULL, "shape=mesh", KF_REQ,
     "Closed triangle mesh, relative to the shot file's directory."},
    {"objects[].rotate", KT_VEC3, OBJ(rotate), ANY, NULL, "[0, 0, 0]", "deg", NULL, 0,
     "Rotation about x, then y, then z (fixed axes), about the centre (an unfitted mesh: its origin)."},
    {"objects[].scale", KT_VEC3, OBJ(scale), GT(0), NULL, "1", NULL, NULL, KF_BROADCAST,
     "Scale about the centre (one number: uniform)."},
    {"objects[].translate", KT_VEC3, OBJ(translate), ANY, NULL, "[0, 0, 0]", "m", NULL, 0, "Offset added to center (a fitted mesh: to fit.center)."},
    {"objects[].velocity", KT_VEC3, OBJ(velocity), ANY, NULL, "[0, 0, 0]", "m/s", NULL, 0, "Initial velocity."},
    {"objects[].angular_velocity", KT_VEC3, OBJ(angular_velocity), ANY, NULL, "[0, 0, 0]", "rad/s", NULL, 0,
     "Initial spin about the centroid of the object's particles."},

    {"objects[].fit", KT_SECTION, KS_OBJECT, NOFIELD, ANY, NULL, NULL, NULL, "shape=mesh", 0,
     "After rotate and scale, fit the mesh's bounding box (else the mesh keeps its file's coordinates)."},
    {"objects[].fit.center", KT_VEC3, OBJ(fit_center), ANY, NULL, NULL, "m", NULL, KF_REQ,
     "Where the bounding box centre goes."},
    {"objects[].fit.size", KT_NUM, OBJ(fit_size), GT(0), NULL, NULL, "m", NULL, KF_REQ,
     "The bounding box's largest extent becomes this."},

    {"colliders", KT_LIST, KS_COLLIDER, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0,
     "Kinematic colliders: planes, boxes, spheres and closed meshes; static, at constant velocity, or keyframed "
     "(translate, rotate, scale about the pivot). Evaluated at every substep."},
    {"colliders[].name", KT_STR, COL(name), ANY, NULL, "(shape and position, e.g. plane0)", NULL, NULL, KF_IDENT,
     "Name, for messages and --set colliders.NAME.key=value."},
    {"colliders[].shape", KT_ENUM, COL(col.shape), ANY, "plane|box|sphere|mesh", NULL, NULL, NULL, KF_REQ,
     "Collider shape."},
    {"colliders[].point", KT_VEC3, COL(col.center), ANY, NULL, NULL, "m", "shape=plane", KF_REQ,
     "A point on the plane (the pivot of its keys)."},
    {"colliders[].normal", KT_VEC3, COL(col.normal), ANY, NULL, NULL, NULL, "shape=plane", KF_REQ | KF_NONZERO,
     "The side material stays on (normalised)."},
    {"colliders[].center", KT_VEC3, COL(col.center), ANY, NULL, NULL, "m", "shape=box|sphere", KF_REQ,
     "Centre (the pivot of its keys)."},
    {"colliders[].size", KT_VEC3, COL(size), GT(0), NULL, NULL, "m", "shape=box", KF_REQ | KF_BROADCAST,
     "Edge lengths (one number: a cube)."},
    {"colliders[].radius", KT_NUM, COL(col.radius), GT(0), NULL, NULL, "m", "shape=sphere", KF_REQ, "Radius."},
    {"colliders[].mesh", KT_STR, COL(mesh), ANY, NULL, NULL, NULL, "shape=mesh", KF_REQ,
     "Closed triangle mesh, relative to the shot file's directory; sampled into a signed distance grid of "
     "spacing dx/2."},
    {"colliders[].rotate", KT_VEC3, COL(rotate), ANY, NULL, "[0, 0, 0]", "deg", "shape=box|mesh", 0,
     "Rest orientation: rotation about x, then y, then z (fixed axes), about the centre (a mesh: placed like an "
     "object's)."},
    {"colliders[].scale", KT_VEC3, COL(scale), GT(0), NULL, "1", NULL, "shape=mesh", KF_BROADCAST,
     "Scale of the mesh about its origin, before rotate (one number: uniform)."},
    {"colliders[].translate", KT_VEC3, COL(translate), ANY, NULL, "[0, 0, 0]", "m", "shape=mesh", 0,
     "Where the mesh's origin goes (a fitted mesh: offset added to fit.center)."},
    {"colliders[].pivot", KT_VEC3, COL(pivot), ANY, NULL, "(fit.center + translate, else translate)", "m",
     "shape=mesh", 0, "The point of the placed mesh that keys move, rotate and scale about."},
    {"colliders[].inside", KT_BOOL, COL(col.inside), ANY, NULL, "false", NULL, "shape=box|sphere|mesh", 0,
     "Keep material inside (a container) instead of outside."},
    {"colliders[].boundary", KT_ENUM, COL(col.boundary), ANY, "sticky|slip|separate", "separate", NULL, NULL, 0,
     "Contact: sticky, slip (frictionless), separate (can lift off)."},
    {"colliders[].friction", KT_NUM, COL(col.friction), GE(0), NULL, "0.3", NULL, "boundary=separate", KF_SOFT,
     "Coulomb friction."},
    {"colliders[].color", KT_VEC3, COL(color), CC(0, 1), NULL, "0.55", "sRGB", NULL, KF_BROADCAST,
     "Colour of the collider in renders."},
    {"colliders[].specular", KT_NUM, COL(specular), CC(0, 1), NULL, "0.2", NULL, NULL, 0,
     "Strength of the collider's highlights in renders (0 = matte)."},
    {"colliders[].roughness", KT_NUM, COL(roughness), CC(0.03, 1), NULL, "0.6", NULL, NULL, 0,
     "Width of the collider's highlights in renders: small is glossy, 1 a broad sheen."},
    {"colliders[].velocity", KT_VEC3, COL(col.velocity), ANY, NULL, "[0, 0, 0]", "m/s", NULL, 0,
     "Constant velocity (without keys)."},
    {"colliders[].interpolation", KT_ENUM, COL(col.interp), ANY, "linear|smooth", "linear", NULL, NULL, 0,
     "Between keys, per channel: linear, or smooth (cubic Hermite through the keys, Catmull-Rom tangents, "
     "easing in and out at the first and last key: velocity continuous)."},
    {"colliders[].fit", KT_SECTION, KS_COLLIDER, NOFIELD, ANY, NULL, NULL, NULL, "shape=mesh", 0,
     "After rotate and scale, fit the mesh's bounding box (else the mesh keeps its file's coordinates)."},
    {"colliders[].fit.center", KT_VEC3, COL(fit_center), ANY, NULL, NULL, "m", NULL, KF_REQ,
     "Where the bounding box centre goes."},
    {"colliders[].fit.size", KT_NUM, COL(fit_size), GT(0), NULL, NULL, "m", NULL, KF_REQ,
     "The bounding box's largest extent becomes this."},
    {"colliders[].keys", KT_LIST, KS_KEY, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0,
     "Keyframed motion of the rest shape about its pivot (point, center, or a mesh's pivot): scaled, then "
     "rotated, then moved by translate; held before the first key and after the last; frames increase."},
    {"colliders[].keys[].frame", KT_NUM, KEY(frame), CC(-9999999, 9999999), NULL, NULL, NULL, NULL, KF_REQ,
     "Frame of the key (may be fractional)."},
    {"colliders[].keys[].translate", KT_VEC3, KEY(translate), ANY, NULL, "[0, 0, 0]", "m", NULL, 0,
     "Offset of the pivot from its rest position at that frame."},
    {"colliders[].keys[].rotate", KT_VEC3, KEY(rotate), CC(-1e6, 1e6), NULL, "[0, 0, 0]", "deg", NULL, 0,
     "Rotation about x, then y, then z (fixed axes) on top of the rest orientation; angles interpolate per "
     "channel, so 0 to 720 is two turns."},
    {"colliders[].keys[].scale", KT_VEC3, KEY(scale), GT(0), NULL, "1", NULL, NULL, KF_BROADCAST,
     "Scale along x, y, z about the pivot (one number: uniform)."},

    /* rigid bodies and their joints (CPIC, paper section 5) */
    {"rigids", KT_LIST, KS_RIGID, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0,
     "Rigid bodies that material cannot cross, however thin (at most 14): thin cutters and shells, or closed "
     "solids; static, kinematic (keys or a constant velocity) or dynamic (pushed by the material, pushing back, "
     "colliding with each other). The pivot is put at center and the body turned about it by rotate."},
    {"rigids[].name", KT_STR, RIG(def.name), ANY, NULL, "(shape and position, e.g. mesh0)", NULL, NULL, KF_IDENT,
     "Name, for messages, joints and --set rigids.NAME.key=value."},
    {"rigids[].shape", KT_ENUM, RIG(shape), ANY, "box|mesh", NULL, NULL, NULL, KF_REQ,
     "A box (triangulated), or a triangle mesh file."},
    {"rigids[].mesh", KT_STR, RIG(mesh), ANY, NULL, NULL, NULL, "shape=mesh", KF_REQ,
     "Triangle mesh, relative to the shot file's directory: any surface when thin, a closed one when solid."},
    {"rigids[].scale", KT_VEC3, RIG(scale), GT(0), NULL, "1", NULL, "shape=mesh", KF_BROADCAST,
     "Scale of the mesh about its own origin (one number: uniform)."},
    {"rigids[].pivot", KT_VEC3, RIG(pivot), ANY, NULL, "(the scaled mesh's bounding-box centre)", "m", "shape=mesh", 0,
     "The point of the scaled mesh, in its own coordinates, that is put at center; rotate and keys turn about it."},
    {"rigids[].size", KT_VEC3, RIG(size), GT(0), NULL, NULL, "m", "shape=box", KF_REQ | KF_BROADCAST,
     "Edge lengths (one number: a cube)."},
    {"rigids[].center", KT_VEC3, RIG(def.position), ANY, NULL, NULL, "m", NULL, KF_REQ,
     "Where the pivot (a box: its centre) is at the first frame."},
    {"rigids[].rotate", KT_VEC3, RIG(def.rotate), CC(-1e6, 1e6), NULL, "[0, 0, 0]", "deg", NULL, 0,
     "Orientation at the first frame: rotation about x, then y, then z (fixed axes), about the pivot."},
    {"rigids[].thin", KT_BOOL, RIG(def.thin), ANY, NULL, "false", NULL, NULL, 0,
     "true: an infinitely thin shell or cutter (open or not; material on its two sides moves independently); "
     "false: a closed solid."},
    {"rigids[].motion", KT_ENUM, RIG(def.motion), ANY, "static|kinematic|dynamic", "static", NULL, NULL, 0,
     "static: stays put; kinematic: follows its keys (or a constant velocity) whatever pushes it; dynamic: moved "
     "by gravity, the material, other bodies and joints."},
    {"rigids[].keys", KT_LIST, KS_KEY, NOFIELD, ANY, NULL, NULL, NULL, "motion=kinematic", 0,
     "Keyframed motion about the pivot: rotated, then moved by translate; held before the first key and after "
     "the last; frames increase."},
    {"rigids[].keys[].frame", KT_NUM, KEY(frame), CC(-9999999, 9999999), NULL, NULL, NULL, NULL, KF_REQ,
     "Frame of the key (may be fractional)."},
    {"rigids[].keys[].translate", KT_VEC3, KEY(translate), ANY, NULL, "[0, 0, 0]", "m", NULL, 0,
     "Offset of the pivot from center at that frame."},
    {"rigids[].keys[].rotate", KT_VEC3, KEY(rotate), CC(-1e6, 1e6), NULL, "[0, 0, 0]", "deg", NULL, 0,
     "Rotation about x, then y, then z (fixed axes) on top of rotate, about the pivot; angles interpolate per "
     "channel, so 0 to 720 is two turns."},
    {"rigids[].interpolation", KT_ENUM, RIG(def.interp), ANY, "linear|smooth", "linear", NULL, "motion=kinematic", 0,
     "Between keys, per channel: linear, or smooth (cubic Hermite, easing in and out at the first and last key)."},
    {"rigids[].velocity", KT_VEC3, RIG(def.velocity), ANY, NULL, "[0, 0, 0]", "m/s", "motion=kinematic|dynamic", 0,
     "dynamic: initial velocity; kinematic without keys: constant velocity."},
    {"rigids[].angular_velocity", KT_VEC3, RIG(def.angular_velocity), ANY, NULL, "[0, 0, 0]", "rad/s",
     "motion=kinematic|dynamic", 0,
     "dynamic: initial spin; kinematic without keys: constant spin about the pivot (world axes)."},
    {"rigids[].density", KT_NUM, RIG(def.density), GT(0), NULL, NULL, "kg/m^3 (thin: kg/m^2)", "motion=dynamic",
     KF_REQ, "Mass per volume of a solid, or per area of a thin shell; mass and inertia follow from the mesh."},
    {"rigids[].boundary", KT_ENUM, RIG(def.boundary), ANY, "sticky|slip|separate", "separate", NULL, NULL, 0,
     "How material meets the body: sticky, slip (frictionless), separate (can lift off, with friction)."},
    {"rigids[].friction", KT_NUM, RIG(def.friction), GE(0), NULL, "0.3", NULL, "boundary=separate", KF_SOFT,
     "Coulomb friction between the material and the body."},
    {"rigids[].penalty", KT_NUM, RIG(def.penalty), GE(0), NULL, "auto", "1/s", NULL, KF_AUTO,
     "Keeps material touching the body half a particle spacing off its surface (paper Eq. 22, measured at the "
     "particle's extent), so its surface does not poke through the body. auto: on a thin body a contact, a particle "
     "inside that skin is put back on it and loses its approach (nothing bounces or jitters); around a solid off. "
     "A number: the "
     "paper's velocity penalty, the overlap closing at this rate, never faster than within one substep; 0 = off. "
     "Whatever it is, no particle passes through the surface: each one's path relative to the body is checked "
     "against the exact triangles every substep."},
    {"rigids[].push", KT_NUM, RIG(def.push), GE(0), NULL, "auto", "m/s^2", NULL, KF_AUTO,
     "Extra acceleration of colliding material away from the surface (paper section 5.5). auto: none, since no "
     "particle can pass through the surface anyway (a push adds energy, measured as jitter of material at rest); "
     "a number pushes that hard."},
    {"rigids[].color", KT_VEC3, RIG(color), CC(0, 1), NULL, "0.55", "sRGB", NULL, KF_BROADCAST,
     "Colour of the body in renders."},

    {"joints", KT_LIST, KS_JOINT, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0,
     "Joints between dynamic rigid bodies, or a dynamic body and the world (a wheel on its axle)."},
    {"joints[].name", KT_STR, JNT(name), ANY, NULL, "(type and position, e.g. hinge0)", NULL, NULL, KF_IDENT,
     "Name, for messages and --set joints.NAME.key=value."},
    {"joints[].type", KT_ENUM, JNT(type), ANY, "hinge", "hinge", NULL, NULL, 0,
     "hinge: the bodies keep a common axis and turn about it."},
    {"joints[].body", KT_STR, JNT(body), ANY, NULL, NULL, NULL, NULL, KF_REQ | KF_IDENT,
     "A dynamic rigid body, by name."},
    {"joints[].to", KT_STR, JNT(to), ANY, NULL, "world", NULL, NULL, KF_IDENT,
     "The other dynamic body, by name, or world (fixed in space)."},
    {"joints[].anchor", KT_VEC3, JNT(def.anchor), ANY, NULL, NULL, "m", NULL, KF_REQ,
     "A point on the hinge axis at the first frame."},
    {"joints[].axis", KT_VEC3, JNT(def.axis), ANY, NULL, NULL, NULL, NULL, KF_REQ | KF_NONZERO,
     "Direction of the hinge axis at the first frame (normalised)."},
    {"joints[].damping", KT_NUM, JNT(def.damping), GE(0), NULL, "0", "N m s/rad", NULL, 0,
     "Rotational damping of the hinge."},

    {"output", KT_SECTION, KS_TOP, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0, "Where results go."},
    {"output.dir", KT_STR, TOP(s.output_dir), ANY, NULL, "out/{shot}/v{version:03d}", NULL, NULL, KF_TEMPLATE,
     "Output directory (a template), relative to the directory kerf runs in, not to the shot file; --out "
     "replaces it. Must not be empty."},
    {"output.name", KT_STR, TOP(s.output_name), ANY, NULL, "{shot}.{frame:04d}", NULL, NULL, KF_TEMPLATE,
     "File name of a frame's outputs, without extension (a template with {frame}); it stays inside output.dir "
     "(no '..')."},
    {"output.particles", KT_BOOL, TOP(s.output_particles), ANY, NULL, "true", NULL, NULL, 0,
     "Write the particles of every frame."},
    {"output.checkpoints", KT_BOOL, TOP(s.output_checkpoints), ANY, NULL, "true", NULL, NULL, 0,
     "Write a resumable checkpoint of every frame."},
    {"output.surface", KT_BOOL, TOP(s.output_surface), ANY, NULL, "true", NULL, NULL, 0,
     "Surface every frame into an OpenVDB level set (surface/<name>.vdb)."},
    {"output.images", KT_BOOL, TOP(s.output_images), ANY, NULL, "true", NULL, NULL, 0,
     "Render every frame's surface to PNG (images/<name>.png); needs output.surface."},
    {"output.points", KT_BOOL, TOP(s.output_points), ANY, NULL, "false", NULL, NULL, 0,
     "Also write the particles as OpenVDB points (points/<name>.vdb: v, material, Jp) for Houdini or Blender."},

    {"surface", KT_SECTION, KS_TOP, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0,
     "How particles become OpenVDB level sets (changing these never re-simulates)."},
    {"surface.voxel", KT_NUM, TOP(s.surface_voxel), CC(0.1, 4), NULL, "0.75", "particle spacings", NULL, 0,
     "Voxel size of the level set, in particle spacings (dx / cube root of ppc)."},
    {"surface.radius", KT_NUM, TOP(s.surface_radius), CC(0.5, 4), NULL, "1.2", "particle spacings", NULL, 0,
     "Radius of each particle's sphere; at least 1.5 voxels (smaller ones are raised and counted)."},
    {"surface.smooth", KT_ENUM, TOP(s.surface_smooth), ANY, "none|mean_curvature|gaussian|laplacian",
     "mean_curvature", NULL, NULL, 0, "Smoothing filter between dilation and erosion."},
    {"surface.iterations", KT_INT, TOP(s.surface_iterations), CC(0, 100), NULL, "3", NULL, NULL, 0,
     "Smoothing passes."},
    {"surface.dilate", KT_NUM, TOP(s.surface_dilate), GE(0), NULL, "0", "m", NULL, 0,
     "Grow the surface before smoothing (fills small gaps)."},
    {"surface.erode", KT_NUM, TOP(s.surface_erode), GE(-1), NULL, "-1", "m", NULL, 0,
     "Shrink it after smoothing; -1 = back onto the material (radius - half a spacing, plus dilate)."},
    {"surface.quality", KT_ENUM, TOP(s.surface_quality), ANY, "final|preview", "final", NULL, NULL, 0,
     "Preset: preview doubles voxel and radius (1.5 and 2.4 spacings: 1/8 the voxels) and smooths once; "
     "surface keys the shot sets itself win."},
    {"surface.group", KT_ENUM, TOP(s.surface_group), ANY, "material|object", "material", NULL, NULL, 0,
     "One level set (and render colour) per material, or per object (objects of one material stay apart)."},

    {"render", KT_SECTION, KS_TOP, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0,
     "How frames are rendered (changing these never re-simulates)."},
    {"render.width", KT_INT, TOP(s.render_width), CC(16, 16384), NULL, "1280", "pixels", NULL, 0,
     "Image width; --quality preview halves it."},
    {"render.height", KT_INT, TOP(s.render_height), CC(16, 16384), NULL, "720", "pixels", NULL, 0,
     "Image height; --quality preview halves it."},
    {"render.quality", KT_ENUM, TOP(s.render_quality), ANY, "final|preview", "final", NULL, NULL, 0,
     "Preset: preview renders without anti-aliasing and with a shadow map of at most 1024 texels (--quality preview sets it); "
     "render.samples set in the shot wins."},
    {"render.samples", KT_INT, TOP(s.render_samples), CC(1, 16), NULL, "4", NULL, NULL, 0,
     "Anti-aliasing samples per pixel (1 = none; preview uses 1)."},
    {"render.eye", KT_VEC3, TOP(s.render_eye), ANY, NULL, "(framed to the first frame)", "m", NULL, 0,
     "Camera position; without it the camera frames the first frame from the front right."},
    {"render.target", KT_VEC3, TOP(s.render_target), ANY, NULL, "(the framed centre)", "m", NULL, 0,
     "Point the camera looks at."},
    {"render.fov", KT_NUM, TOP(s.render_fov), OO(1, 170), NULL, "35", "degrees", NULL, 0,
     "Vertical field of view."},
    {"render.ground", KT_BOOL, TOP(s.render_ground), ANY, NULL, "true", NULL, NULL, 0,
     "Draw a ground plane that catches shadows (at the floor when there are walls)."},
};
const int kf_nkeys = (int)(sizeof kf_keys / sizeof kf_keys[0]);

/* ---- table look-ups ------------------------------------------------------------------ */

int kf_key_find(const char *path) {
    for (int i = 0; i < kf_nkeys; i++)
        if (strcmp(kf_keys[i].path, path) == 0) return i;
    return -1;
}

const char *kf_key_leaf(const kf_keydef *k) {
    const char *dot = strrchr(k->path, '.');
    return dot ? dot + 1 : k->path;
}

void kf_key_parent(const kf_keydef *k, char *out, size_t n) {
    const char *dot = strrchr(k->path, '.');
    size_t len = dot ? (size_t)(dot - k->path) : 0;
    if (len >= n) len = n - 1;
    memcpy(out, k->path, len);
    out[len] = '\0';
}

const char *kf_key_choice(const kf_keydef *k, int i, char *buf, size_t n) {
    const char *p = k->choices ? k->choices : "";
    for (int j = 0; j < i && p; j++) {
        p = strchr(p, '|');
        if (p) p++;
    }
    buf[0] = '\0';
    if (!p || !*p) return buf;
    size_t len = strcspn(p, "|");
    if (len >= n) len = n - 1;
    memcpy(buf, p, len);
    buf[len] = '\0';
    return buf;
}

static int choice_index(const kf_keydef *k, const char *s) {
    char buf[64];
    for (int i = 0; *kf_key_choice(k, i, buf, sizeof buf); i++)
        if (strcmp(buf, s) == 0) return i;
    return -1;
}

/* "a, b or c" */
static void choices_text(const kf_keydef *k, char *out, size_t n) {
    char buf[64];
    int count = 0;
    while (*kf_key_choice(k, count, buf, sizeof buf)) count++;
    out[0] = '\0';
    for (int i = 0; i < count; i++) {
        size_t l = strlen(out);
        snprintf(out + l, n - l, "%s%s", i == 0 ? "" : i == count - 1 ? " or " : ", ", kf_key_choice(k, i, buf, sizeof buf));
    }
}

/* whole numbers in full (9999999, not 1e+07), others as %g */
static const char *num_text(double v, char *buf, size_t n) {
    if (v == floor(v) && fabs(v) < 1e15) snprintf(buf, n, "%.0f", v);
    else snprintf(buf, n, "%g", v);
    return buf;
}

void kf_key_bounds_text(const kf_keydef *k, char *out, size_t n) {
    unsigned b = k->bounds;
    char lo[32], hi[32];
    num_text(k->lo, lo, sizeof lo);
    num_text(k->hi, hi, sizeof hi);
    if ((b & KB_LO) && (b & KB_HI))
        snprintf(out, n, "in %c%s, %s%c", b & KB_LO_OPEN ? '(' : '[', lo, hi, b & KB_HI_OPEN ? ')' : ']');
    else if (b & KB_LO) snprintf(out, n, "%s %s", b & KB_LO_OPEN ? ">" : ">=", lo);
    else if (b & KB_HI) snprintf(out, n, "%s %s", b & KB_HI_OPEN ? "<" : "<=", hi);
    else snprintf(out, n, "%s", "");
}

static int in_bounds(const kf_keydef *k, double v) {
    unsigned b = k->bounds;
    if (!isfinite(v)) return 0;
    if (b & KB_LO) {
        if (b & KB_LO_OPEN ? !(v > k->lo) : !(v >= k->lo)) return 0;
    }
    if (b & KB_HI) {
        if (b & KB_HI_OPEN ? !(v < k->hi) : !(v <= k->hi)) return 0;
    }
    return 1;
}

/* ---- node → value ------------------------------------------------------------------ */

/* how a node looks, for "expected X, got Y" */
static void describe(const ky_node *n, char *out, size_t len) {
    if (n->kind == KY_MAP) snprintf(out, len, "a mapping {...}");
    else if (n->kind == KY_SEQ) snprintf(out, len, "a list [...]");
    else if (ky_is_null(n)) snprintf(out, len, "nothing");
    else if (n->quoted) snprintf(out, len, "the string \"%.60s\"", n->text);
    else snprintf(out, len, "'%.60s'", n->text);
}

static int parse_number(const char *s, double *v) {
    if (!*s || strpbrk(s, "xXpP") || !(isdigit((unsigned char)*s) || strchr("+-.", *s))) return -1;
    char *end;
    *v = strtod(s, &end);
    return *end == '\0' && isfinite(*v) ? 0 : -1;
}

static int parse_int(const char *s, double *v) {
    if (!*s) return -1;
    char *end;
    long long x = strtoll(s, &end, 10);
    if (*end || x > 2147483647LL || x < -2147483647LL) return -1;
    *v = (double)x;
    return 0;
}

static int parse_bool(const char *s, int *v) {
    static const char *yes[] = {"true", "True", "TRUE", "yes", "Yes", "on", "On"};
    static const char *no[] = {"false", "False", "FALSE", "no", "No", "off", "Off"};
    for (int i = 0; i < 7; i++) {
        if (strcmp(s, yes[i]) == 0) return *v = 1, 0;
        if (strcmp(s, no[i]) == 0) return *v = 0, 0;
    }
    return -1;
}

/* a number in the key's bounds (and choices), or a reported error */
static int number_at(const kf_keydef *k, const ky_node *n, const char *what, int axis, double *out, kf_diag *d,
                     const kf_srcs *srcs) {
    char got[96], ax[4] = "";
    int whole = k->type == KT_INT;
    if (axis >= 0) snprintf(ax, sizeof ax, ".%c", "xyz"[axis]);
    if (n->kind != KY_SCALAR || n->quoted || (whole ? parse_int(n->text, out) : parse_number(n->text, out))) {
        int quoted_number = n->kind == KY_SCALAR && n->quoted && !parse_number(n->text, out);
        describe(n, got, sizeof got);
        kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s%s: expected %s, got %s%s", what, ax,
                     whole ? "a whole number" : (k->flags & KF_AUTO) ? "auto or a number" : "a number", got,
                     quoted_number ? " (drop the quotes)" : "");
        return -1;
    }
    if (k->choices) {
        char buf[64], list[128];
        for (int i = 0; *kf_key_choice(k, i, buf, sizeof buf); i++)
            if (atof(buf) == *out) return 0;
        choices_text(k, list, sizeof list);
        kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s must be %s, got %s", what, list, n->text);
        return -1;
    }
    if (!in_bounds(k, *out)) {
        char bt[96];
        kf_key_bounds_text(k, bt, sizeof bt);
        kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s%s must be %s%s%s, got %s", what, ax, bt, k->unit ? " " : "",
                     k->unit ? k->unit : "", n->text);
        return -1;
    }
    return 0;
}

static int string_at(const kf_keydef *k, const ky_node *n, const char *what, char *dst, kf_diag *d,
                     const kf_srcs *srcs) {
    char got[96];
    if (n->kind != KY_SCALAR || ky_is_null(n)) {
        describe(n, got, sizeof got);
        kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s: expected %s, got %s", what,
                     k->type == KT_STR && !(k->flags & KF_IDENT) ? "text" : "a name", got);
        return -1;
    }
    if (strlen(n->text) >= k->size) {
        kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s is too long (at most %zu characters)", what, k->size - 1);
        return -1;
    }
    if (k->flags & KF_IDENT) {
        for (const char *p = n->text; *p; p++)
            if (!isalnum((unsigned char)*p) && *p != '_' && *p != '-') {
                kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s '%s': a name holds only letters, digits, '_' and '-'",
                             what, n->text);
                return -1;
            }
    }
    if (k->flags & KF_TEMPLATE) {
        int at = 0;
        char why[128];
        if (kf_template_check(n->text, &at, why, sizeof why)) {
            kf_report(d, srcs, n->src, n->line, n->col + at + (n->quoted ? 1 : 0), KF_DIAG_ERROR, "%s: %s", what, why);
            return -1;
        }
    }
    memcpy(dst, n->text, strlen(n->text) + 1);
    return 0;
}

int kf_key_set(const kf_keydef *k, const ky_node *n, void *base, const char *what, kf_diag *d,
               const kf_srcs *srcs) {
    char *dst = (char *)base + k->off;
    char got[96], list[256];
    double v;
    switch (k->type) {
    case KT_NUM:
        if ((k->flags & KF_AUTO) && n->kind == KY_SCALAR && !n->quoted && strcmp(n->text, "auto") == 0) {
            *(double *)dst = KF_RIGID_AUTO;
            return 0;
        }
        if (number_at(k, n, what, -1, &v, d, srcs)) return -1;
        *(double *)dst = v;
        return 0;
    case KT_INT:
        if (number_at(k, n, what, -1, &v, d, srcs)) return -1;
        *(int *)dst = (int)v; /* int, or the uint32_t seed (bounded to int's range) */
        return 0;
    case KT_BOOL: {
        int b;
        if (n->kind != KY_SCALAR || n->quoted || parse_bool(n->text, &b)) {
            describe(n, got, sizeof got);
            kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s: expected true or false, got %s", what, got);
            return -1;
        }
        *(int *)dst = b;
        return 0;
    }
    case KT_ENUM: {
        int i = n->kind == KY_SCALAR ? choice_index(k, n->text) : -1;
        if (i < 0) {
            char opts[16][64];
            const char *cand[16];
            int nc = 0;
            while (nc < 16 && *kf_key_choice(k, nc, opts[nc], sizeof opts[nc])) cand[nc] = opts[nc], nc++;
            const char *near = n->kind == KY_SCALAR ? kf_suggest(n->text, cand, nc) : NULL;
            describe(n, got, sizeof got);
            choices_text(k, list, sizeof list);
            if (near)
                kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s: unknown value %s (did you mean '%s'?); choose %s", what,
                             got, near, list);
            else kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s: expected %s, got %s", what, list, got);
            return -1;
        }
        *(int *)dst = i;
        return 0;
    }
    case KT_VEC3: {
        double x[3];
        if (n->kind == KY_SCALAR && (k->flags & KF_BROADCAST) && !ky_is_null(n) && !parse_number(n->text, &v)) {
            if (number_at(k, n, what, -1, &v, d, srcs)) return -1;
            x[0] = x[1] = x[2] = v;
        } else if (n->kind != KY_SEQ || n->n != 3) {
            if (n->kind == KY_SEQ) snprintf(got, sizeof got, "%d number%s", n->n, n->n == 1 ? "" : "s");
            else describe(n, got, sizeof got);
            kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s: expected [x, y, z]%s, got %s", what,
                         k->flags & KF_BROADCAST ? " or one number" : "", got);
            return -1;
        } else {
            int bad = 0;
            for (int a = 0; a < 3; a++) bad |= number_at(k, n->item[a], what, a, &x[a], d, srcs);
            if (bad) return -1;
        }
        if ((k->flags & KF_NONZERO) && x[0] == 0 && x[1] == 0 && x[2] == 0) {
            kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s must not be [0, 0, 0]", what);
            return -1;
        }
        memcpy(dst, x, sizeof x);
        return 0;
    }
    case KT_PRESET: {
        const char *const *names = kf_material_preset_names();
        for (int i = 0; n->kind == KY_SCALAR && names[i]; i++)
            if (strcmp(names[i], n->text) == 0) return string_at(k, n, what, dst, d, srcs);
        list[0] = '\0';
        for (int i = 0; names[i]; i++) {
            size_t l = strlen(list);
            snprintf(list + l, sizeof list - l, "%s%s", i ? ", " : "", names[i]);
        }
        const char *near = n->kind == KY_SCALAR ? kf_suggest(n->text, names, -1) : NULL;
        describe(n, got, sizeof got);
        if (near)
            kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s: unknown preset %s (did you mean '%s'?); presets: %s", what,
                         got, near, list);
        else kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s: unknown preset %s; presets: %s", what, got, list);
        return -1;
    }
    case KT_STR:
    case KT_REF: return string_at(k, n, what, dst, d, srcs);
    default: return 0;
    }
}

/* defaults are text in the same syntax as the file, so the help shows
 * exactly what a user would write */
int kf_key_default(const kf_keydef *k, void *base) {
    if (!k->def || k->def[0] == '(') return 0;
    char *dst = (char *)base + k->off;
    double v, x[3];
    int b;
    switch (k->type) {
    case KT_NUM:
        if ((k->flags & KF_AUTO) && strcmp(k->def, "auto") == 0) {
            *(double *)dst = KF_RIGID_AUTO;
            return 0;
        }
        if (parse_number(k->def, &v) || !in_bounds(k, v)) return -1;
        *(double *)dst = v;
        return 0;
    case KT_INT:
        if (parse_int(k->def, &v) || (!k->choices && !in_bounds(k, v))) return -1;
        *(int *)dst = (int)v;
        return 0;
    case KT_BOOL:
        if (parse_bool(k->def, &b)) return -1;
        *(int *)dst = b;
        return 0;
    case KT_ENUM:
        if ((b = choice_index(k, k->def)) < 0) return -1;
        *(int *)dst = b;
        return 0;
    case KT_VEC3:
        if (sscanf(k->def, "[%lf, %lf, %lf]", &x[0], &x[1], &x[2]) != 3) {
            if (!(k->flags & KF_BROADCAST) || parse_number(k->def, &x[0])) return -1;
            x[1] = x[2] = x[0];
        }
        for (int a = 0; a < 3; a++)
            if (!in_bounds(k, x[a])) return -1;
        memcpy(dst, x, sizeof x);
        return 0;
    case KT_STR:
        if (strlen(k->def) >= k->size) return -1;
        memcpy(dst, k->def, strlen(k->def) + 1);
        return 0;
    default: return 0;
    }
}

/* ---- kerf help shot ------------------------------------------------------------------ */

static void type_text(const kf_keydef *k, char *out, size_t n) {
    char bt[96], ch[256];
    kf_key_bounds_text(k, bt, sizeof bt);
    const char *unit = k->unit ? k->unit : "";
    switch (k->type) {
    case KT_NUM:
        snprintf(out, n, "%s%s%s%s%s", k->flags & KF_AUTO ? "auto or number" : "number", *bt ? " " : "", bt,
                 *unit ? ", " : "", unit);
        break;
    case KT_INT:
        if (k->choices) choices_text(k, ch, sizeof ch), snprintf(out, n, "%s", ch);
        else snprintf(out, n, "integer%s%s", *bt ? " " : "", bt);
        break;
    case KT_BOOL: snprintf(out, n, "true or false"); break;
    case KT_ENUM: choices_text(k, ch, sizeof ch), snprintf(out, n, "%s", ch); break;
    case KT_VEC3:
        snprintf(out, n, "[x, y, z]%s%s%s%s%s", k->flags & KF_BROADCAST ? " or one number" : "", *bt ? ", each " : "",
                 bt, *unit ? ", " : "", unit);
        break;
    case KT_PRESET: snprintf(out, n, "a preset name"); break;
    case KT_REF: snprintf(out, n, "a material name"); break;
    case KT_STR: snprintf(out, n, k->flags & KF_TEMPLATE ? "template" : k->flags & KF_IDENT ? "name" : "text"); break;
    case KT_SECTION: snprintf(out, n, "mapping"); break;
    case KT_DICT: snprintf(out, n, "mapping of NAME: {...}"); break;
    case KT_LIST: snprintf(out, n, "list of {...}"); break;
    }
}

/* "only for shape sphere or cylinder" */
static void only_text(const char *only, char *out, size_t n) {
    const char *eq = strchr(only, '=');
    snprintf(out, n, "only for %.*s ", (int)(eq - only), only);
    for (const char *p = eq + 1; *p; p++) {
        size_t l = strlen(out);
        if (*p == '|') snprintf(out + l, n - l, "%s", strchr(p + 1, '|') ? ", " : " or ");
        else if (l + 1 < n) out[l] = *p, out[l + 1] = '\0';
    }
}

void kf_shot_help(FILE *f) {
    fprintf(f, "kerf shot files: YAML (comments allowed) or JSON. Every key, with its type and default.\n"
               "Units are SI unless given. Keys a shot omits take the default; --set path=value overrides any\n"
               "key (list items by name or index: objects.cube.center=[0.5,0.6,0.5]).\n");
    for (int i = 0; i < kf_nkeys; i++) {
        const kf_keydef *k = &kf_keys[i];
        char path[96], ty[256], only[128] = "", def[160];
        int p = 0;
        for (const char *s = k->path; *s && p < (int)sizeof path - 8; s++) /* materials.*.E → materials.NAME.E */
            if (*s == '*') p += snprintf(path + p, sizeof path - p, "NAME");
            else path[p++] = *s;
        path[p] = '\0';
        type_text(k, ty, sizeof ty);
        if (k->only) only_text(k->only, only, sizeof only);
        if (k->type == KT_SECTION || k->type == KT_DICT || k->type == KT_LIST) {
            fprintf(f, "\n%s  (%s%s%s%s)\n    %s\n", path, ty, k->flags & KF_REQ ? ", required" : "", *only ? ", " : "",
                    only, k->doc);
            continue;
        }
        if (k->flags & KF_REQ) snprintf(def, sizeof def, "required");
        else if (k->def) snprintf(def, sizeof def, "default %s", k->def);
        else def[0] = '\0';
        fprintf(f, "  %-32s %s%s%s%s%s\n      %s\n", path, ty, *def ? "; " : "", def, *only ? "; " : "", only, k->doc);
    }
    fprintf(f, "\nmaterial presets (materials.NAME.preset):\n");
    const char *const *names = kf_material_preset_names();
    for (int i = 0; names[i]; i++) {
        kf_material m;
        kf_material_preset(names[i], &m);
        char ch[64];
        const kf_keydef *model = &kf_keys[kf_key_find("materials.*.model")];
        fprintf(f, "  %-10s model %-10s density %g kg/m^3", names[i], kf_key_choice(model, (int)m.model, ch, sizeof ch),
                m.density);
        if (m.model == KF_MAT_WATER) fprintf(f, ", bulk_modulus %g Pa, gamma %g\n", m.bulk_modulus, m.gamma);
        else fprintf(f, ", E %g Pa, nu %g\n", m.E, m.nu);
    }
    fprintf(f, "\ntemplates (output.dir, output.name): {shot}, {version}, {frame}, each with an optional\n"
               "zero-padded width, e.g. {version:03d} -> 001, {frame:04d} -> 1001; {{ and }} are braces.\n"
               "\npaths: mesh files (objects, colliders, rigids) are relative to the shot file's directory;\n"
               "output.dir and --out are relative to the directory kerf runs in.\n"
               "\ncommand line: --set path=value (repeatable), --quality preview|final (preview doubles sim.dx\n"
               "and halves image resolution), --frames A-B (a sub-range of frames.start..frames.end).\n");
}
