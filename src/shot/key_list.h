/* key_list.h — every key a shot file may hold, once: the X-macro list that
 * keys.c expands into the key table (kf_keys) and internal.h into the key
 * enum (kf_key_id: KK_<ID>), so the loader names a key by a constant and a
 * misspelt one does not compile.
 *
 * To add a key, add one row where it belongs (rows of a section stay
 * together, after the section's own row):
 *     KF_KEY(ID, "path", type, scope(field), bounds, choices, default, unit, only, flags,
 *            "help text")
 *   ID       the path in capitals, "[]" and ".*" dropped, other punctuation '_'
 *            ("colliders[].keys[].frame" → COLLIDERS_KEYS_FRAME); code says KK_ID
 *   path     as written in a shot: "sim.dx", "materials.*.E", "objects[].mesh"
 *   type     KT_NUM, KT_INT, KT_BOOL, KT_STR, KT_ENUM, KT_VEC3, ... (internal.h)
 *   field    TOP(m), MAT(m), OBJ(m), COL(m), KEY(m), RIG(m), JNT(m): the struct
 *            member it writes; KS_<scope>, NOFIELD for sections
 *   bounds   ANY, GT(a), GE(a), CC(a, b), OO(a, b), CO(a, b), OC(a, b)
 *   choices  "a|b|c" for KT_ENUM (and allowed integer values), else NULL
 *   default  as `kerf help shot` shows it (NULL: none), unit (NULL: none)
 *   only     "key=value" it is restricted to (NULL: always), flags KF_REQ, KF_IDENT, ...
 * The loader, overrides, error text and `kerf help shot` pick the row up with
 * no other change. No include guard: each includer defines KF_KEY first. */

KF_KEY(SHOT, "shot", KT_STR, TOP(s.name), ANY, NULL, "(the file name without extension)", NULL, NULL, KF_IDENT,
       "Name of the shot: {shot} in output templates.")
KF_KEY(VERSION, "version", KT_INT, TOP(s.version), CC(0, 9999), NULL, "1", NULL, NULL, 0,
       "Version: {version} in output templates; bump it to keep earlier results.")

KF_KEY(FRAMES, "frames", KT_SECTION, KS_TOP, NOFIELD, ANY, NULL, NULL, NULL, NULL, KF_REQ, "The frame range and rate.")
KF_KEY(FRAMES_START, "frames.start", KT_INT, TOP(s.frame_start), CC(0, 9999999), NULL, "1001", NULL, NULL, 0,
       "First frame (the VFX convention is 1001).")
KF_KEY(FRAMES_END, "frames.end", KT_INT, TOP(s.frame_end), CC(0, 9999999), NULL, NULL, NULL, NULL, KF_REQ,
       "Last frame, inclusive.")
KF_KEY(FRAMES_FPS, "frames.fps", KT_NUM, TOP(s.fps), OC(0, 1000), NULL, "24", "frames/s", NULL, 0, "Frames per second.")

KF_KEY(SIM, "sim", KT_SECTION, KS_TOP, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0, "Solver settings.")
KF_KEY(SIM_DX, "sim.dx", KT_NUM, TOP(s.sim.dx), OC(0, 10), NULL, "0.02", "m", NULL, 0,
       "Grid spacing; particles grow as 1/dx^3. --quality preview doubles it.")
KF_KEY(SIM_PPC, "sim.ppc", KT_INT, TOP(s.ppc), ANY, "1|8|27|64", "8", NULL, NULL, 0,
       "Particles per grid cell when seeding.")
KF_KEY(SIM_CFL, "sim.cfl", KT_NUM, TOP(s.sim.cfl), OC(0, 2), NULL, "0.4", NULL, NULL, 0,
       "CFL number: a substep is at most cfl * dx / (wave speed + fastest particle).")
KF_KEY(SIM_DT_MAX, "sim.dt_max", KT_NUM, TOP(s.sim.dt_max), GE(0), NULL, "0", "s", NULL, 0,
       "Longest substep allowed (0 = only the CFL rule).")
KF_KEY(SIM_DT_FIXED, "sim.dt_fixed", KT_NUM, TOP(s.sim.dt_fixed), GE(0), NULL, "0", "s", NULL, 0,
       "Fixed substep instead of the CFL rule (0 = adaptive); for tests and benchmarks. Fixed means fixed: "
       "numerical trouble at it fails the frame naming the step, unless sim.retry_fixed lets a retry halve it. "
       "Material compressed stiffer than the step resolves (water's pressure, packed snow, crushed jelly: a wave "
       "faster than a cell per step) is evaluated at the stiffness the step does resolve, and each frame's log "
       "counts those particles (stiffness-limited).")
KF_KEY(SIM_RETRY_FIXED, "sim.retry_fixed", KT_BOOL, TOP(s.sim.retry_fixed), ANY, NULL, "false", NULL, NULL, 0,
       "Under sim.dt_fixed, let a frame that runs into numerical trouble be retried at half the fixed step "
       "(up to sim.max_retries times; each retry is logged with the step it used).")
KF_KEY(SIM_GRAVITY, "sim.gravity", KT_VEC3, TOP(s.sim.gravity), ANY, NULL, "[0, -9.81, 0]", "m/s^2", NULL, 0,
       "Gravitational acceleration.")
KF_KEY(SIM_KERNEL, "sim.kernel", KT_ENUM, TOP(s.sim.kernel), ANY, "quadratic|cubic", "quadratic", NULL, NULL, 0,
       "B-spline interpolation kernel.")
KF_KEY(SIM_FORCE, "sim.force", KT_ENUM, TOP(s.sim.force), ANY, "mls|classic", "mls", NULL, NULL, 0,
       "Force discretisation: MLS-MPM, or classic MPM with kernel gradients.")
KF_KEY(SIM_TRANSFER, "sim.transfer", KT_ENUM, TOP(s.sim.transfer), ANY, "apic|pic|flip|polypic", "apic", NULL, NULL, 0,
       "Particle-grid transfer: APIC keeps rotation, PIC damps it. Both lose, at every substep, the part of the motion "
       "finer than the kernel, so a wobbling body comes to rest sooner at a smaller CFL number. flip keeps APIC's "
       "rotation and adds back sim.flip_ratio of what the grid missed of each particle's velocity. Measured on a "
       "jelly bar 4 cells thick ringing for 10 periods: flip keeps 60% of its energy at CFL 0.4 and 54% at 0.1, "
       "APIC 31% and 4% (tools/evidence/flip_results.md); flip costs one more scatter and gather per substep. "
       "polypic keeps every velocity mode the quadratic kernel's 3x3x3 stencil holds (23 beyond APIC's), so a "
       "transfer loses only what particles moving between nodes blur: a stretched jelly cube 16 cells across keeps "
       "65% of its energy over 10 periods at CFL 0.4, where APIC keeps 31% and flip 49% "
       "(tools/evidence/flip_results.md); it costs 4.4x APIC per substep and 292 bytes a particle. flip and "
       "polypic: explicit integration on one rank only; polypic needs the quadratic kernel.")
KF_KEY(SIM_FLIP_RATIO, "sim.flip_ratio", KT_NUM, TOP(s.sim.flip_ratio), CC(0, 1), NULL, "0.95", NULL, "transfer=flip",
       KF_SOFT,
       "Under sim.transfer: flip, the share of each particle's velocity beyond the grid's kept per substep (1 = "
       "pure FLIP, livelier and noisier; 0 = APIC).")
KF_KEY(SIM_MAX_RETRIES, "sim.max_retries", KT_INT, TOP(s.sim.max_retries), CC(0, 16), NULL, "4", NULL, NULL, 0,
       "Times a frame is retried at half the CFL number after numerical trouble.")
KF_KEY(SIM_JITTER, "sim.jitter", KT_BOOL, TOP(s.jitter), ANY, NULL, "true", NULL, NULL, 0,
       "Jitter the seeding lattice so no grid pattern shows.")
KF_KEY(SIM_SEED, "sim.seed", KT_INT, TOP(s.seed), CC(1, 2147483647), NULL, "1", NULL, NULL, 0,
       "Random seed of the jitter.")
KF_KEY(SIM_CONTACT, "sim.contact", KT_ENUM, TOP(contact), ANY, "on|off|auto", "auto", NULL, NULL, 0,
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
       "ignores it).")
KF_KEY(SIM_CONTACT_FRICTION, "sim.contact_friction", KT_NUM, TOP(s.sim.contact_friction), GE(0), NULL, "0.3", NULL,
       NULL, 0,
       "Coulomb friction between objects in contact (sim.contact): they stick while the sliding force is below "
       "this times the pressing force.")
KF_KEY(SIM_THREADS, "sim.threads", KT_INT, TOP(s.sim.threads), CC(0, 1024), NULL, "0", NULL, NULL, 0,
       "Worker threads (0 = OMP_NUM_THREADS or every core).")
KF_KEY(SIM_INTEGRATOR, "sim.integrator", KT_ENUM, TOP(s.sim.integrator), ANY, "explicit|implicit", "explicit", NULL,
       NULL, 0,
       "Time integration: explicit (symplectic Euler, substep limited by the elastic wave speed) or implicit "
       "(Newton-Krylov on the grid velocities: substeps limited by advection alone, for stiff solids; see "
       "sim.implicit_scheme). Implicit covers corotated, von_mises, sand and snow; water and rigid bodies need "
       "explicit. Its step: sim.dt_fixed, or sim.cfl on advection alone. Measured on a 40 cm bar thrown tumbling "
       "at E = 1e6 Pa, 20x the explicit step: the midpoint scheme costs 0.42x what explicit needs for the same "
       "error (0.08 mm); backward Euler at that step is 6.5 mm off. Every substep's transfers also damp motion "
       "finer than a few cells (a wobbling body 4 cells across), so fewer, larger substeps keep more wobble. At "
       "hundreds of explicit steps per substep the solves slow down on moving bodies (~100 CG iterations per "
       "Newton iteration).")
KF_KEY(SIM_IMPLICIT_SCHEME, "sim.implicit_scheme", KT_ENUM, TOP(s.sim.implicit_scheme), ANY, "backward_euler|midpoint",
       "backward_euler", NULL, "integrator=implicit", KF_SOFT,
       "The implicit step: backward_euler (first order; damps wobble and swing the substeps do not resolve, its "
       "bodies fall 1/2 g dt t too far; robust at any step) or midpoint (the same solve over half the substep, "
       "the particles then move with that velocity: second order, gravity's arc exact, no numerical damping, same "
       "cost; it keeps the look of explicit: the snow shot at preview took 22 s against explicit's 189 s and "
       "broke the wall as explicit does, where backward Euler's damped impact, 18 s, left it whole). Midpoint "
       "keeps fast oscillations it cannot resolve rather than damping them.")
KF_KEY(SIM_NEWTON_TOL, "sim.newton_tol", KT_NUM, TOP(s.sim.newton_tol), GT(0), NULL, "1e-3", NULL,
       "integrator=implicit", KF_SOFT, "Newton stops when the residual, relative to the momentum scale, is below this.")
KF_KEY(SIM_NEWTON_MAX, "sim.newton_max", KT_INT, TOP(s.sim.newton_max), CC(1, 1000), NULL, "20", NULL,
       "integrator=implicit", KF_SOFT, "Most Newton iterations per substep.")
KF_KEY(SIM_KRYLOV_TOL, "sim.krylov_tol", KT_NUM, TOP(s.sim.krylov_tol), OO(0, 1), NULL, "1e-2", NULL,
       "integrator=implicit", KF_SOFT, "Conjugate gradients stop when the residual has fallen by this factor.")
KF_KEY(SIM_KRYLOV_MAX, "sim.krylov_max", KT_INT, TOP(s.sim.krylov_max), CC(1, 100000), NULL, "200", NULL,
       "integrator=implicit", KF_SOFT, "Most conjugate-gradient iterations per Newton iteration.")
KF_KEY(SIM_PRECOND, "sim.precond", KT_ENUM, TOP(s.sim.precond), ANY, "multigrid|jacobi", "multigrid", NULL,
       "integrator=implicit", KF_SOFT,
       "Conjugate-gradient preconditioner: multigrid (coarse grids of 2, 4, 8... x dx; fewer iterations, growing "
       "more slowly with the step: faster from ~20x the explicit step) or jacobi (the Hessian's diagonal; cheaper "
       "to set up: faster at small steps).")

KF_KEY(DOMAIN, "domain", KT_SECTION, KS_TOP, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0, "The simulation box.")
KF_KEY(DOMAIN_MIN, "domain.min", KT_VEC3, TOP(s.sim.domain_min), ANY, NULL, "[0, 0, 0]", "m", NULL, 0, "Lower corner.")
KF_KEY(DOMAIN_MAX, "domain.max", KT_VEC3, TOP(s.sim.domain_max), ANY, NULL, "[1, 1, 1]", "m", NULL, 0,
       "Upper corner; above min on every axis.")
KF_KEY(DOMAIN_WALLS, "domain.walls", KT_ENUM, TOP(walls), ANY, "none|sticky|slip|separate", "separate", NULL, NULL, 0,
       "The box's walls: none (open), sticky, slip (frictionless), separate (material can lift off).")
KF_KEY(DOMAIN_FRICTION, "domain.friction", KT_NUM, TOP(s.sim.wall_friction), GE(0), NULL, "0.3", NULL, "walls=separate",
       KF_SOFT, "Coulomb friction of separate walls.")

KF_KEY(MATERIALS, "materials", KT_DICT, KS_MATERIAL, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0,
       "Named materials: a preset with any parameter overridden. Names: letters, digits, _ and -.")
KF_KEY(MATERIALS_PRESET, "materials.*.preset", KT_PRESET, MAT(preset), ANY, NULL, NULL, NULL, NULL, 0,
       "Preset to start from (see the list below).")
KF_KEY(MATERIALS_COLOR, "materials.*.color", KT_VEC3, MAT(color), CC(0, 1), NULL,
       "(by kind: water blue, sand tan, ...)", "sRGB", NULL, KF_BROADCAST,
       "Colour of this material's surface in renders.")
KF_KEY(MATERIALS_SPECULAR, "materials.*.specular", KT_NUM, MAT(specular), CC(0, 1), NULL,
       "(by kind: water 0.6, sand 0.05, ...)", NULL, NULL, 0, "Strength of the highlights in renders (0 = matte).")
KF_KEY(MATERIALS_ROUGHNESS, "materials.*.roughness", KT_NUM, MAT(roughness), CC(0.03, 1), NULL,
       "(by kind: water 0.15, sand 0.9, ...)", NULL, NULL, 0,
       "Width of the highlights in renders: small is glossy, 1 a broad sheen.")
KF_KEY(MATERIALS_MODEL, "materials.*.model", KT_ENUM, MAT(mat.model), ANY, "corotated|water|von_mises|sand|snow",
       PRESET_DEF, NULL, NULL, 0, "Constitutive model; required when there is no preset.")
KF_KEY(MATERIALS_DENSITY, "materials.*.density", KT_NUM, MAT(mat.density), GT(0), NULL, PRESET_DEF, "kg/m^3", NULL, 0,
       "Rest density.")
KF_KEY(MATERIALS_E, "materials.*.E", KT_NUM, MAT(mat.E), GT(0), NULL, PRESET_DEF, "Pa", SOLID, KF_SOFT,
       "Young's modulus.")
KF_KEY(MATERIALS_NU, "materials.*.nu", KT_NUM, MAT(mat.nu), CO(0, 0.5), NULL, PRESET_DEF, NULL, SOLID, KF_SOFT,
       "Poisson ratio.")
KF_KEY(MATERIALS_YIELD_STRESS, "materials.*.yield_stress", KT_NUM, MAT(mat.yield_stress), GT(0), NULL, PRESET_DEF, "Pa",
       "model=von_mises", KF_SOFT, "Von Mises uniaxial yield stress.")
KF_KEY(MATERIALS_FRICTION_ANGLE, "materials.*.friction_angle", KT_NUM, MAT(mat.friction_angle), OO(0, 90), NULL,
       PRESET_DEF, "deg", "model=sand", KF_SOFT,
       "Drucker-Prager friction angle; giving it turns hardening off unless hardening is given.")
KF_KEY(MATERIALS_COHESION, "materials.*.cohesion", KT_NUM, MAT(mat.cohesion), GE(0), NULL, PRESET_DEF, NULL,
       "model=sand", KF_SOFT, "Tensile cohesion, as a Hencky strain offset.")
KF_KEY(MATERIALS_HARDENING, "materials.*.hardening", KT_BOOL, MAT(mat.hardening), ANY, NULL, PRESET_DEF, NULL,
       "model=sand", KF_SOFT, "Friction angle grows with plastic strain: h0 + (h1 q - h3) exp(-h2 q).")
KF_KEY(MATERIALS_H0, "materials.*.h0", KT_NUM, MAT(mat.h0), OO(0, 90), NULL, PRESET_DEF, "deg", "model=sand", KF_SOFT,
       "Hardening: limit friction angle.")
KF_KEY(MATERIALS_H1, "materials.*.h1", KT_NUM, MAT(mat.h1), ANY, NULL, PRESET_DEF, "deg", "model=sand", KF_SOFT,
       "Hardening: linear growth.")
KF_KEY(MATERIALS_H2, "materials.*.h2", KT_NUM, MAT(mat.h2), GE(0), NULL, PRESET_DEF, NULL, "model=sand", KF_SOFT,
       "Hardening: decay rate.")
KF_KEY(MATERIALS_H3, "materials.*.h3", KT_NUM, MAT(mat.h3), ANY, NULL, PRESET_DEF, "deg", "model=sand", KF_SOFT,
       "Hardening: h0 - h3 is the initial friction angle.")
KF_KEY(MATERIALS_VOLUME_CORRECTION, "materials.*.volume_correction", KT_BOOL, MAT(mat.volume_correction), ANY, NULL,
       PRESET_DEF, NULL, "model=sand", KF_SOFT, "Klar's volume correction of sand pulled apart.")
KF_KEY(MATERIALS_BULK_MODULUS, "materials.*.bulk_modulus", KT_NUM, MAT(mat.bulk_modulus), GT(0), NULL, PRESET_DEF, "Pa",
       "model=water", KF_SOFT, "Fluid bulk modulus: p = bulk_modulus (J^-gamma - 1).")
KF_KEY(MATERIALS_GAMMA, "materials.*.gamma", KT_NUM, MAT(mat.gamma), GE(1), NULL, PRESET_DEF, NULL, "model=water",
       KF_SOFT, "Fluid stiffness exponent (7 for water).")
KF_KEY(MATERIALS_VISCOSITY, "materials.*.viscosity", KT_NUM, MAT(mat.viscosity), GE(0), NULL, PRESET_DEF, "Pa s",
       "model=water", KF_SOFT, "Dynamic viscosity (0 = inviscid).")
KF_KEY(MATERIALS_THETA_C, "materials.*.theta_c", KT_NUM, MAT(mat.theta_c), OO(0, 1), NULL, PRESET_DEF, NULL,
       "model=snow", KF_SOFT, "Snow: critical compression.")
KF_KEY(MATERIALS_THETA_S, "materials.*.theta_s", KT_NUM, MAT(mat.theta_s), OO(0, 1), NULL, PRESET_DEF, NULL,
       "model=snow", KF_SOFT, "Snow: critical stretch.")
KF_KEY(MATERIALS_XI, "materials.*.xi", KT_NUM, MAT(mat.xi), GE(0), NULL, PRESET_DEF, NULL, "model=snow", KF_SOFT,
       "Snow: hardening coefficient.")

KF_KEY(OBJECTS, "objects", KT_LIST, KS_OBJECT, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0,
       "Particle sources, filled at the first frame: each shape is scaled and rotated about its centre, then "
       "placed at center + translate (a fitted mesh: at fit.center + translate).")
KF_KEY(OBJECTS_NAME, "objects[].name", KT_STR, OBJ(name), ANY, NULL, "(shape and position, e.g. box0)", NULL, NULL,
       KF_IDENT, "Name, for messages and --set objects.NAME.key=value.")
KF_KEY(OBJECTS_SHAPE, "objects[].shape", KT_ENUM, OBJ(shape), ANY, "box|sphere|cylinder|mesh", NULL, NULL, NULL, KF_REQ,
       "What to fill.")
KF_KEY(OBJECTS_MATERIAL, "objects[].material", KT_REF, OBJ(material_name), ANY, NULL, NULL, NULL, NULL, KF_REQ,
       "A material defined under materials.")
KF_KEY(OBJECTS_CENTER, "objects[].center", KT_VEC3, OBJ(center), ANY, NULL, NULL, "m", "shape=box|sphere|cylinder",
       KF_REQ, "Centre.")
KF_KEY(OBJECTS_SIZE, "objects[].size", KT_VEC3, OBJ(size), GT(0), NULL, NULL, "m", "shape=box", KF_REQ | KF_BROADCAST,
       "Edge lengths (one number: a cube).")
KF_KEY(OBJECTS_RADIUS, "objects[].radius", KT_NUM, OBJ(radius), GT(0), NULL, NULL, "m", "shape=sphere|cylinder", KF_REQ,
       "Radius.")
KF_KEY(OBJECTS_HEIGHT, "objects[].height", KT_NUM, OBJ(height), GT(0), NULL, NULL, "m", "shape=cylinder", KF_REQ,
       "Length along the axis.")
KF_KEY(OBJECTS_AXIS, "objects[].axis", KT_ENUM, OBJ(axis), ANY, "x|y|z", "y", NULL, "shape=cylinder", 0,
       "Cylinder axis.")
KF_KEY(OBJECTS_MESH, "objects[].mesh", KT_STR, OBJ(mesh), ANY, NULL, NULL, NULL, "shape=mesh", KF_REQ,
       "Closed triangle mesh, relative to the shot file's directory.")
KF_KEY(OBJECTS_ROTATE, "objects[].rotate", KT_VEC3, OBJ(rotate), ANY, NULL, "[0, 0, 0]", "deg", NULL, 0,
       "Rotation about x, then y, then z (fixed axes), about the centre (an unfitted mesh: its origin).")
KF_KEY(OBJECTS_SCALE, "objects[].scale", KT_VEC3, OBJ(scale), GT(0), NULL, "1", NULL, NULL, KF_BROADCAST,
       "Scale about the centre (one number: uniform).")
KF_KEY(OBJECTS_TRANSLATE, "objects[].translate", KT_VEC3, OBJ(translate), ANY, NULL, "[0, 0, 0]", "m", NULL, 0,
       "Offset added to center (a fitted mesh: to fit.center).")
KF_KEY(OBJECTS_VELOCITY, "objects[].velocity", KT_VEC3, OBJ(velocity), ANY, NULL, "[0, 0, 0]", "m/s", NULL, 0,
       "Initial velocity.")
KF_KEY(OBJECTS_ANGULAR_VELOCITY, "objects[].angular_velocity", KT_VEC3, OBJ(angular_velocity), ANY, NULL, "[0, 0, 0]",
       "rad/s", NULL, 0, "Initial spin about the centroid of the object's particles.")

KF_KEY(OBJECTS_BOND, "objects[].bond", KT_STR, OBJ(bond), ANY, NULL, "(none)", NULL, NULL, KF_IDENT,
       "Another object, by name, this one is part of: the two are filled separately, each with its own material, "
       "and then are one object, so sim.contact gives them one velocity and they stay stuck together where they "
       "touch (a peel round its flesh) instead of sliding on each other; a blade cuts them into shared pieces, and "
       "surface.group: object surfaces them as one. The named object must not itself name a bond.")
KF_KEY(OBJECTS_FIT, "objects[].fit", KT_SECTION, KS_OBJECT, NOFIELD, ANY, NULL, NULL, NULL, "shape=mesh", 0,
       "After rotate and scale, fit the mesh's bounding box (else the mesh keeps its file's coordinates).")
KF_KEY(OBJECTS_FIT_CENTER, "objects[].fit.center", KT_VEC3, OBJ(fit_center), ANY, NULL, NULL, "m", NULL, KF_REQ,
       "Where the bounding box centre goes.")
KF_KEY(OBJECTS_FIT_SIZE, "objects[].fit.size", KT_NUM, OBJ(fit_size), GT(0), NULL, NULL, "m", NULL, KF_REQ,
       "The bounding box's largest extent becomes this.")

KF_KEY(COLLIDERS, "colliders", KT_LIST, KS_COLLIDER, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0,
       "Kinematic colliders: planes, boxes, spheres and closed meshes; static, at constant velocity, or keyframed "
       "(translate, rotate, scale about the pivot). Evaluated at every substep.")
KF_KEY(COLLIDERS_NAME, "colliders[].name", KT_STR, COL(name), ANY, NULL, "(shape and position, e.g. plane0)", NULL,
       NULL, KF_IDENT, "Name, for messages and --set colliders.NAME.key=value.")
KF_KEY(COLLIDERS_SHAPE, "colliders[].shape", KT_ENUM, COL(col.shape), ANY, "plane|box|sphere|mesh", NULL, NULL, NULL,
       KF_REQ, "Collider shape.")
KF_KEY(COLLIDERS_POINT, "colliders[].point", KT_VEC3, COL(col.center), ANY, NULL, NULL, "m", "shape=plane", KF_REQ,
       "A point on the plane (the pivot of its keys).")
KF_KEY(COLLIDERS_NORMAL, "colliders[].normal", KT_VEC3, COL(col.normal), ANY, NULL, NULL, NULL, "shape=plane",
       KF_REQ | KF_NONZERO, "The side material stays on (normalised).")
KF_KEY(COLLIDERS_CENTER, "colliders[].center", KT_VEC3, COL(col.center), ANY, NULL, NULL, "m", "shape=box|sphere",
       KF_REQ, "Centre (the pivot of its keys).")
KF_KEY(COLLIDERS_SIZE, "colliders[].size", KT_VEC3, COL(size), GT(0), NULL, NULL, "m", "shape=box",
       KF_REQ | KF_BROADCAST, "Edge lengths (one number: a cube).")
KF_KEY(COLLIDERS_RADIUS, "colliders[].radius", KT_NUM, COL(col.radius), GT(0), NULL, NULL, "m", "shape=sphere", KF_REQ,
       "Radius.")
KF_KEY(COLLIDERS_MESH, "colliders[].mesh", KT_STR, COL(mesh), ANY, NULL, NULL, NULL, "shape=mesh", KF_REQ,
       "Closed triangle mesh, relative to the shot file's directory; sampled into a signed distance grid of "
       "spacing dx/2.")
KF_KEY(COLLIDERS_ROTATE, "colliders[].rotate", KT_VEC3, COL(rotate), ANY, NULL, "[0, 0, 0]", "deg", "shape=box|mesh", 0,
       "Rest orientation: rotation about x, then y, then z (fixed axes), about the centre (a mesh: placed like an "
       "object's).")
KF_KEY(COLLIDERS_SCALE, "colliders[].scale", KT_VEC3, COL(scale), GT(0), NULL, "1", NULL, "shape=mesh", KF_BROADCAST,
       "Scale of the mesh about its origin, before rotate (one number: uniform).")
KF_KEY(COLLIDERS_TRANSLATE, "colliders[].translate", KT_VEC3, COL(translate), ANY, NULL, "[0, 0, 0]", "m", "shape=mesh",
       0, "Where the mesh's origin goes (a fitted mesh: offset added to fit.center).")
KF_KEY(COLLIDERS_PIVOT, "colliders[].pivot", KT_VEC3, COL(pivot), ANY, NULL, "(fit.center + translate, else translate)",
       "m", "shape=mesh", 0, "The point of the placed mesh that keys move, rotate and scale about.")
KF_KEY(COLLIDERS_INSIDE, "colliders[].inside", KT_BOOL, COL(col.inside), ANY, NULL, "false", NULL,
       "shape=box|sphere|mesh", 0, "Keep material inside (a container) instead of outside.")
KF_KEY(COLLIDERS_BOUNDARY, "colliders[].boundary", KT_ENUM, COL(col.boundary), ANY, "sticky|slip|separate", "separate",
       NULL, NULL, 0, "Contact: sticky, slip (frictionless), separate (can lift off).")
KF_KEY(COLLIDERS_FRICTION, "colliders[].friction", KT_NUM, COL(col.friction), GE(0), NULL, "0.3", NULL,
       "boundary=separate", KF_SOFT, "Coulomb friction.")
KF_KEY(COLLIDERS_COLOR, "colliders[].color", KT_VEC3, COL(color), CC(0, 1), NULL, "0.55", "sRGB", NULL, KF_BROADCAST,
       "Colour of the collider in renders.")
KF_KEY(COLLIDERS_SPECULAR, "colliders[].specular", KT_NUM, COL(specular), CC(0, 1), NULL, "0.2", NULL, NULL, 0,
       "Strength of the collider's highlights in renders (0 = matte).")
KF_KEY(COLLIDERS_ROUGHNESS, "colliders[].roughness", KT_NUM, COL(roughness), CC(0.03, 1), NULL, "0.6", NULL, NULL, 0,
       "Width of the collider's highlights in renders: small is glossy, 1 a broad sheen.")
KF_KEY(COLLIDERS_VELOCITY, "colliders[].velocity", KT_VEC3, COL(col.velocity), ANY, NULL, "[0, 0, 0]", "m/s", NULL, 0,
       "Constant velocity (without keys).")
KF_KEY(COLLIDERS_INTERPOLATION, "colliders[].interpolation", KT_ENUM, COL(col.interp), ANY, "linear|smooth", "linear",
       NULL, NULL, 0,
       "Between keys, per channel: linear, or smooth (cubic Hermite through the keys, Catmull-Rom tangents, "
       "easing in and out at the first and last key: velocity continuous).")
KF_KEY(COLLIDERS_FIT, "colliders[].fit", KT_SECTION, KS_COLLIDER, NOFIELD, ANY, NULL, NULL, NULL, "shape=mesh", 0,
       "After rotate and scale, fit the mesh's bounding box (else the mesh keeps its file's coordinates).")
KF_KEY(COLLIDERS_FIT_CENTER, "colliders[].fit.center", KT_VEC3, COL(fit_center), ANY, NULL, NULL, "m", NULL, KF_REQ,
       "Where the bounding box centre goes.")
KF_KEY(COLLIDERS_FIT_SIZE, "colliders[].fit.size", KT_NUM, COL(fit_size), GT(0), NULL, NULL, "m", NULL, KF_REQ,
       "The bounding box's largest extent becomes this.")
KF_KEY(COLLIDERS_KEYS, "colliders[].keys", KT_LIST, KS_KEY, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0,
       "Keyframed motion of the rest shape about its pivot (point, center, or a mesh's pivot): scaled, then "
       "rotated, then moved by translate; held before the first key and after the last; frames increase.")
KF_KEY(COLLIDERS_KEYS_FRAME, "colliders[].keys[].frame", KT_NUM, KEY(frame), CC(-9999999, 9999999), NULL, NULL, NULL,
       NULL, KF_REQ, "Frame of the key (may be fractional).")
KF_KEY(COLLIDERS_KEYS_TRANSLATE, "colliders[].keys[].translate", KT_VEC3, KEY(translate), ANY, NULL, "[0, 0, 0]", "m",
       NULL, 0, "Offset of the pivot from its rest position at that frame.")
KF_KEY(COLLIDERS_KEYS_ROTATE, "colliders[].keys[].rotate", KT_VEC3, KEY(rotate), CC(-1e6, 1e6), NULL, "[0, 0, 0]",
       "deg", NULL, 0,
       "Rotation about x, then y, then z (fixed axes) on top of the rest orientation; angles interpolate per "
       "channel, so 0 to 720 is two turns.")
KF_KEY(COLLIDERS_KEYS_SCALE, "colliders[].keys[].scale", KT_VEC3, KEY(scale), GT(0), NULL, "1", NULL, NULL,
       KF_BROADCAST, "Scale along x, y, z about the pivot (one number: uniform).")

/* rigid bodies and their joints (CPIC, paper section 5) */
KF_KEY(RIGIDS, "rigids", KT_LIST, KS_RIGID, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0,
       "Rigid bodies that material cannot cross, however thin (at most 14): thin cutters and shells, or closed "
       "solids; static, kinematic (keys or a constant velocity) or dynamic (pushed by the material, pushing back, "
       "colliding with each other). The pivot is put at center and the body turned about it by rotate.")
KF_KEY(RIGIDS_NAME, "rigids[].name", KT_STR, RIG(def.name), ANY, NULL, "(shape and position, e.g. mesh0)", NULL, NULL,
       KF_IDENT, "Name, for messages, joints and --set rigids.NAME.key=value.")
KF_KEY(RIGIDS_SHAPE, "rigids[].shape", KT_ENUM, RIG(shape), ANY, "box|mesh", NULL, NULL, NULL, KF_REQ,
       "A box (triangulated), or a triangle mesh file.")
KF_KEY(RIGIDS_MESH, "rigids[].mesh", KT_STR, RIG(mesh), ANY, NULL, NULL, NULL, "shape=mesh", KF_REQ,
       "Triangle mesh, relative to the shot file's directory: any surface when thin, a closed one when solid.")
KF_KEY(RIGIDS_SCALE, "rigids[].scale", KT_VEC3, RIG(scale), GT(0), NULL, "1", NULL, "shape=mesh", KF_BROADCAST,
       "Scale of the mesh about its own origin (one number: uniform).")
KF_KEY(RIGIDS_PIVOT, "rigids[].pivot", KT_VEC3, RIG(pivot), ANY, NULL, "(the scaled mesh's bounding-box centre)", "m",
       "shape=mesh", 0,
       "The point of the scaled mesh, in its own coordinates, that is put at center; rotate and keys turn about it.")
KF_KEY(RIGIDS_SIZE, "rigids[].size", KT_VEC3, RIG(size), GT(0), NULL, NULL, "m", "shape=box", KF_REQ | KF_BROADCAST,
       "Edge lengths (one number: a cube).")
KF_KEY(RIGIDS_CENTER, "rigids[].center", KT_VEC3, RIG(def.position), ANY, NULL, NULL, "m", NULL, KF_REQ,
       "Where the pivot (a box: its centre) is at the first frame.")
KF_KEY(RIGIDS_ROTATE, "rigids[].rotate", KT_VEC3, RIG(def.rotate), CC(-1e6, 1e6), NULL, "[0, 0, 0]", "deg", NULL, 0,
       "Orientation at the first frame: rotation about x, then y, then z (fixed axes), about the pivot.")
KF_KEY(RIGIDS_THIN, "rigids[].thin", KT_BOOL, RIG(def.thin), ANY, NULL, "false", NULL, NULL, 0,
       "true: an infinitely thin shell or cutter (open or not; material on its two sides moves independently); "
       "false: a closed solid.")
KF_KEY(RIGIDS_MOTION, "rigids[].motion", KT_ENUM, RIG(def.motion), ANY, "static|kinematic|dynamic", "static", NULL,
       NULL, 0,
       "static: stays put; kinematic: follows its keys (or a constant velocity) whatever pushes it; dynamic: moved "
       "by gravity, the material, other bodies and joints.")
KF_KEY(RIGIDS_KEYS, "rigids[].keys", KT_LIST, KS_KEY, NOFIELD, ANY, NULL, NULL, NULL, "motion=kinematic", 0,
       "Keyframed motion about the pivot: rotated, then moved by translate; held before the first key and after "
       "the last; frames increase.")
KF_KEY(RIGIDS_KEYS_FRAME, "rigids[].keys[].frame", KT_NUM, KEY(frame), CC(-9999999, 9999999), NULL, NULL, NULL, NULL,
       KF_REQ, "Frame of the key (may be fractional).")
KF_KEY(RIGIDS_KEYS_TRANSLATE, "rigids[].keys[].translate", KT_VEC3, KEY(translate), ANY, NULL, "[0, 0, 0]", "m", NULL,
       0, "Offset of the pivot from center at that frame.")
KF_KEY(RIGIDS_KEYS_ROTATE, "rigids[].keys[].rotate", KT_VEC3, KEY(rotate), CC(-1e6, 1e6), NULL, "[0, 0, 0]", "deg",
       NULL, 0,
       "Rotation about x, then y, then z (fixed axes) on top of rotate, about the pivot; angles interpolate per "
       "channel, so 0 to 720 is two turns.")
KF_KEY(RIGIDS_INTERPOLATION, "rigids[].interpolation", KT_ENUM, RIG(def.interp), ANY, "linear|smooth", "linear", NULL,
       "motion=kinematic", 0,
       "Between keys, per channel: linear, or smooth (cubic Hermite, easing in and out at the first and last key).")
KF_KEY(RIGIDS_VELOCITY, "rigids[].velocity", KT_VEC3, RIG(def.velocity), ANY, NULL, "[0, 0, 0]", "m/s",
       "motion=kinematic|dynamic", 0, "dynamic: initial velocity; kinematic without keys: constant velocity.")
KF_KEY(RIGIDS_ANGULAR_VELOCITY, "rigids[].angular_velocity", KT_VEC3, RIG(def.angular_velocity), ANY, NULL, "[0, 0, 0]",
       "rad/s", "motion=kinematic|dynamic", 0,
       "dynamic: initial spin; kinematic without keys: constant spin about the pivot (world axes).")
KF_KEY(RIGIDS_DENSITY, "rigids[].density", KT_NUM, RIG(def.density), GT(0), NULL, NULL, "kg/m^3 (thin: kg/m^2)",
       "motion=dynamic", KF_REQ,
       "Mass per volume of a solid, or per area of a thin shell; mass and inertia follow from the mesh.")
KF_KEY(RIGIDS_BOUNDARY, "rigids[].boundary", KT_ENUM, RIG(def.boundary), ANY, "sticky|slip|separate", "separate", NULL,
       NULL, 0, "How material meets the body: sticky, slip (frictionless), separate (can lift off, with friction).")
KF_KEY(RIGIDS_FRICTION, "rigids[].friction", KT_NUM, RIG(def.friction), GE(0), NULL, "0.3", NULL, "boundary=separate",
       KF_SOFT, "Coulomb friction between the material and the body.")
KF_KEY(RIGIDS_PENALTY, "rigids[].penalty", KT_NUM, RIG(def.penalty), GE(0), NULL, "auto", "1/s", NULL, KF_AUTO,
       "Keeps material touching the body half a particle spacing off its surface (paper Eq. 22, measured at the "
       "particle's extent), so its surface does not poke through the body. auto: on a thin body a contact, a particle "
       "inside that skin is put back on it and loses its approach (nothing bounces or jitters); around a solid off. "
       "A number: the "
       "paper's velocity penalty, the overlap closing at this rate, never faster than within one substep; 0 = off. "
       "Whatever it is, no particle passes through the surface: each one's path relative to the body is checked "
       "against the exact triangles every substep.")
KF_KEY(RIGIDS_PUSH, "rigids[].push", KT_NUM, RIG(def.push), GE(0), NULL, "auto", "m/s^2", NULL, KF_AUTO,
       "Extra acceleration of colliding material away from the surface (paper section 5.5). auto: none, since no "
       "particle can pass through the surface anyway (a push adds energy, measured as jitter of material at rest); "
       "a number pushes that hard.")
KF_KEY(RIGIDS_COLOR, "rigids[].color", KT_VEC3, RIG(color), CC(0, 1), NULL, "0.55", "sRGB", NULL, KF_BROADCAST,
       "Colour of the body in renders.")

KF_KEY(JOINTS, "joints", KT_LIST, KS_JOINT, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0,
       "Joints between dynamic rigid bodies, or a dynamic body and the world (a wheel on its axle).")
KF_KEY(JOINTS_NAME, "joints[].name", KT_STR, JNT(name), ANY, NULL, "(type and position, e.g. hinge0)", NULL, NULL,
       KF_IDENT, "Name, for messages and --set joints.NAME.key=value.")
KF_KEY(JOINTS_TYPE, "joints[].type", KT_ENUM, JNT(type), ANY, "hinge", "hinge", NULL, NULL, 0,
       "hinge: the bodies keep a common axis and turn about it.")
KF_KEY(JOINTS_BODY, "joints[].body", KT_STR, JNT(body), ANY, NULL, NULL, NULL, NULL, KF_REQ | KF_IDENT,
       "A dynamic rigid body, by name.")
KF_KEY(JOINTS_TO, "joints[].to", KT_STR, JNT(to), ANY, NULL, "world", NULL, NULL, KF_IDENT,
       "The other dynamic body, by name, or world (fixed in space).")
KF_KEY(JOINTS_ANCHOR, "joints[].anchor", KT_VEC3, JNT(def.anchor), ANY, NULL, NULL, "m", NULL, KF_REQ,
       "A point on the hinge axis at the first frame.")
KF_KEY(JOINTS_AXIS, "joints[].axis", KT_VEC3, JNT(def.axis), ANY, NULL, NULL, NULL, NULL, KF_REQ | KF_NONZERO,
       "Direction of the hinge axis at the first frame (normalised).")
KF_KEY(JOINTS_DAMPING, "joints[].damping", KT_NUM, JNT(def.damping), GE(0), NULL, "0", "N m s/rad", NULL, 0,
       "Rotational damping of the hinge.")
KF_KEY(JOINTS_MOTOR, "joints[].motor", KT_ENUM, JNT(def.motor), ANY, "none|velocity|position", "none", NULL, NULL, 0,
       "A motor on the hinge (a MuJoCo actuator) turning body relative to to about +axis (right hand): none (free), "
       "velocity (torque kv (2 pi frequency - rate): turns at the commanded rate, the phase may drift) or position "
       "(a servo, torque kp (target - angle) + kv (2 pi frequency - rate), target = angle + 360 frequency t: "
       "legs keep their phase, as in a gait). The torque never exceeds torque_limit; the frame log gives each "
       "motor's torque and its peak over the frame.")
KF_KEY(JOINTS_FREQUENCY, "joints[].frequency", KT_NUM, JNT(def.frequency), CC(-100, 100), NULL, "0", "Hz",
       "motor=velocity|position", 0,
       "Commanded turns per second (a gait frequency); the sign gives the direction, so negating it reverses the "
       "gait. A position motor at 0 holds angle.")
KF_KEY(JOINTS_ANGLE, "joints[].angle", KT_NUM, JNT(def.angle), CC(-36000, 36000), NULL, "0", "deg", "motor=position", 0,
       "The position motor's target at the first frame, from the pose the bodies start in (0: hold that pose).")
KF_KEY(JOINTS_KP, "joints[].kp", KT_NUM, JNT(def.kp), GT(0), NULL, NULL, "N m/rad", "motor=position", KF_REQ,
       "Position gain: torque per radian the hinge lags its target.")
KF_KEY(JOINTS_KV, "joints[].kv", KT_NUM, JNT(def.kv), GE(0), NULL, "0", "N m s/rad", "motor=velocity|position", 0,
       "Rate gain: torque per rad/s the hinge turns slower than commanded; a velocity motor needs it above 0, a "
       "position motor uses it to damp its servo.")
KF_KEY(JOINTS_TORQUE_LIMIT, "joints[].torque_limit", KT_NUM, JNT(def.torque_limit), OC(0, 1e6), NULL, NULL, "N m",
       "motor=velocity|position", KF_REQ,
       "Largest torque the motor gives either way (a stall torque); its commands are clipped to it.")

KF_KEY(OUTPUT, "output", KT_SECTION, KS_TOP, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0, "Where results go.")
KF_KEY(OUTPUT_DIR, "output.dir", KT_STR, TOP(s.output_dir), ANY, NULL, "out/{shot}/v{version:03d}", NULL, NULL,
       KF_TEMPLATE,
       "Output directory (a template), relative to the directory kerf runs in, not to the shot file; --out "
       "replaces it. Must not be empty.")
KF_KEY(OUTPUT_NAME, "output.name", KT_STR, TOP(s.output_name), ANY, NULL, "{shot}.{frame:04d}", NULL, NULL, KF_TEMPLATE,
       "File name of a frame's outputs, without extension (a template with {frame}); it stays inside output.dir "
       "(no '..').")
KF_KEY(OUTPUT_PARTICLES, "output.particles", KT_BOOL, TOP(s.output_particles), ANY, NULL, "true", NULL, NULL, 0,
       "Write the particles of every frame (particles/<name>.ply: x y z, velocity v_x v_y v_z, material, id, "
       "von_mises stress in Pa, volume ratio J, plastic_strain).")
KF_KEY(OUTPUT_CHECKPOINTS, "output.checkpoints", KT_BOOL, TOP(s.output_checkpoints), ANY, NULL, "true", NULL, NULL, 0,
       "Write a resumable checkpoint of every frame.")
KF_KEY(OUTPUT_SURFACE, "output.surface", KT_BOOL, TOP(s.output_surface), ANY, NULL, "true", NULL, NULL, 0,
       "Surface every frame into an OpenVDB level set (surface/<name>.vdb).")
KF_KEY(OUTPUT_IMAGES, "output.images", KT_BOOL, TOP(s.output_images), ANY, NULL, "true", NULL, NULL, 0,
       "Render every frame's surface to PNG (images/<name>.png); needs output.surface.")
KF_KEY(OUTPUT_POINTS, "output.points", KT_BOOL, TOP(s.output_points), ANY, NULL, "false", NULL, NULL, 0,
       "Also write the particles as OpenVDB points (points/<name>.vdb: v, material, Jp, von_mises, J, "
       "plastic_strain) for Houdini or Blender.")

KF_KEY(SURFACE, "surface", KT_SECTION, KS_TOP, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0,
       "How particles become OpenVDB level sets (changing these never re-simulates).")
KF_KEY(SURFACE_KERNEL, "surface.kernel", KT_ENUM, TOP(s.surface_kernel), ANY, "anisotropic|spheres", "anisotropic",
       NULL, NULL, 0,
       "anisotropic: each particle near a face is a thin disc along it, oriented by its neighbours (Yu & Turk "
       "2013), so faces come out flat and edges sharp; spheres: a union of spheres of surface.radius, centres "
       "averaged by surface.average (kerf's earlier look, rounder edges).")
KF_KEY(SURFACE_REACH, "surface.reach", KT_NUM, TOP(s.surface_reach), CC(1.5, 6), NULL, "3", "particle spacings", NULL,
       0,
       "anisotropic: the neighbourhood that orients each particle's disc, and the disc's radius along a face: "
       "larger is flatter, but costs more and reaches further round small features.")
KF_KEY(SURFACE_VOXEL, "surface.voxel", KT_NUM, TOP(s.surface_voxel), CC(0.1, 4), NULL, "0.75", "particle spacings",
       NULL, 0, "Voxel size of the level set, in particle spacings (dx / cube root of ppc).")
KF_KEY(SURFACE_RADIUS, "surface.radius", KT_NUM, TOP(s.surface_radius), CC(0.5, 4), NULL, "2", "particle spacings",
       NULL, 0, "spheres: radius of each particle's sphere; at least 1.5 voxels (smaller ones are raised and counted).")
KF_KEY(SURFACE_SMOOTH, "surface.smooth", KT_ENUM, TOP(s.surface_smooth), ANY, "none|mean_curvature|gaussian|laplacian",
       "mean_curvature", NULL, NULL, 0, "Smoothing filter between dilation and erosion.")
KF_KEY(SURFACE_ITERATIONS, "surface.iterations", KT_INT, TOP(s.surface_iterations), CC(0, 100), NULL, "2", NULL, NULL,
       0, "Smoothing passes (unset: 1 with surface.kernel: spheres).")
KF_KEY(SURFACE_FLATTEN, "surface.flatten", KT_INT, TOP(s.surface_flatten), CC(0, 8), NULL, "3", NULL, NULL, 0,
       "Passes of a filter that flattens faces without rounding edges, after the smoothing: each point of the surface "
       "moves to the mean of its neighbours' tangent planes within 3.75 particle spacings, counting only those whose "
       "normals are within 14 degrees of its own (0 = off; unset: 0 with surface.kernel: spheres, "
       "surface.quality: preview or --quality preview; needs surface.smooth none or mean_curvature).")
KF_KEY(SURFACE_AVERAGE, "surface.average", KT_NUM, TOP(s.surface_average), CC(0, 1), NULL, "1", NULL, NULL, 0,
       "spheres: before surfacing, move each particle's centre this far toward the weighted mean of its neighbours "
       "(Yu & Turk 2013): flattens the jitter of the seeding lattice on faces (0 = off); the surface stays on the "
       "material.")
KF_KEY(SURFACE_AVERAGE_RADIUS, "surface.average_radius", KT_NUM, TOP(s.surface_average_radius), CC(1, 6), NULL, "3",
       "particle spacings", NULL, 0,
       "spheres: neighbourhood of surface.average: larger is flatter, but rounds edges more.")
KF_KEY(SURFACE_DILATE, "surface.dilate", KT_NUM, TOP(s.surface_dilate), GE(0), NULL, "0", "m", NULL, 0,
       "Grow the surface before smoothing (fills small gaps).")
KF_KEY(SURFACE_ERODE, "surface.erode", KT_NUM, TOP(s.surface_erode), GE(-1), NULL, "-1", "m", NULL, 0,
       "Shrink it after smoothing; -1 = back onto the material (spheres: radius - half a spacing; anisotropic: the "
       "discs' half thickness, less the depth of the highest centre under a disc; plus dilate).")
KF_KEY(SURFACE_QUALITY, "surface.quality", KT_ENUM, TOP(s.surface_quality), ANY, "final|preview", "final", NULL, NULL,
       0,
       "Preset: preview doubles the voxel (1.5 spacings: 1/8 the voxels), spheres of 2.4 spacings, one smoothing "
       "pass; "
       "surface keys the shot sets itself win.")
KF_KEY(SURFACE_GROUP, "surface.group", KT_ENUM, TOP(s.surface_group), ANY, "material|object", "material", NULL, NULL, 0,
       "One level set (and render colour) per material, or per object (objects of one material stay apart).")

KF_KEY(RENDER, "render", KT_SECTION, KS_TOP, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0,
       "How frames are rendered (changing these never re-simulates).")
KF_KEY(RENDER_WIDTH, "render.width", KT_INT, TOP(s.render_width), CC(16, 16384), NULL, "1280", "pixels", NULL, 0,
       "Image width; --quality preview halves it.")
KF_KEY(RENDER_HEIGHT, "render.height", KT_INT, TOP(s.render_height), CC(16, 16384), NULL, "720", "pixels", NULL, 0,
       "Image height; --quality preview halves it.")
KF_KEY(RENDER_QUALITY, "render.quality", KT_ENUM, TOP(s.render_quality), ANY, "final|preview", "final", NULL, NULL, 0,
       "Preset: preview renders without anti-aliasing and with a shadow map of at most 1024 texels (--quality preview "
       "sets it); "
       "render.samples set in the shot wins.")
KF_KEY(RENDER_SAMPLES, "render.samples", KT_INT, TOP(s.render_samples), CC(1, 16), NULL, "4", NULL, NULL, 0,
       "Anti-aliasing samples per pixel (1 = none; preview uses 1).")
KF_KEY(RENDER_ANTIALIAS, "render.antialias", KT_ENUM, TOP(s.render_antialias), ANY, "edges|msaa", "edges", NULL, NULL,
       0,
       "How the PNG is anti-aliased when render.samples > 1. edges: one sample a pixel, then each silhouette, open "
       "boundary, crease of a flat-shaded mesh and crossing of the ground blended with the pixel across it by the "
       "area it covers (about half the render time of msaa on finely meshed surfaces; where two meshes pass "
       "through each other the crossing stays aliased); msaa: render.samples samples a pixel. The EXR layers use "
       "render.samples either way.")
KF_KEY(RENDER_EYE, "render.eye", KT_VEC3, TOP(s.render_eye), ANY, NULL, "(framed to the whole shot)", "m", NULL, 0,
       "Camera position; without it (and without camera keys) the camera frames where the material goes over the "
       "whole shot, from the front right.")
KF_KEY(RENDER_TARGET, "render.target", KT_VEC3, TOP(s.render_target), ANY, NULL, "(the framed centre)", "m", NULL, 0,
       "Point the camera looks at.")
KF_KEY(RENDER_FOV, "render.fov", KT_NUM, TOP(s.render_fov), OO(1, 170), NULL, "35", "degrees", NULL, 0,
       "Vertical field of view.")
KF_KEY(RENDER_GROUND, "render.ground", KT_BOOL, TOP(s.render_ground), ANY, NULL, "true", NULL, NULL, 0,
       "Draw a ground plane that catches shadows (at the floor when there are walls).")
KF_KEY(RENDER_FORMAT, "render.format", KT_ENUM, TOP(s.render_format), ANY, "png|exr|both", "png", NULL, NULL, 0,
       "Image files in images/: png (8-bit, for viewing), exr (half-float OpenEXR for compositing) or both. The "
       "EXR holds: R G B A, linear light (the PNG is these encoded with a 2.2 power), A = 1; Z, camera depth in m "
       "along the view axis (positive, not 1/z: what Nuke's and Houdini's depth tools take), 65504 where nothing "
       "is; N.x N.y N.z, world-space unit normals facing the camera; id, an integer per surfaced group (1 + its "
       "place in materials, or in objects under surface.group: object), per collider (101 + its place) and per "
       "rigid body (201 + its place), 0 on the ground and background, never blended; matte.<name>, each id's "
       "anti-aliased coverage (0..1); forward.u forward.v, screen motion over the next frame in pixels, x right "
       "and y up (Nuke's layer), from the particles' velocity grid in the .vdb, the colliders' and bodies' "
       "motion and the camera's. Also the camera as worldToCamera and worldToNDC.")
KF_KEY(RENDER_MOTION_BLUR, "render.motion_blur", KT_NUM, TOP(s.render_motion_blur), CC(0, 1), NULL, "0", "frames", NULL,
       0,
       "Shutter open for this fraction of a frame, centred on it (0.5 = a 180-degree shutter; 0 = no blur). The "
       "picture is the average of renders spread over the shutter, surfaces moved by their velocity and the "
       "camera along its keys, as many as keep the fastest point within a pixel between renders (at most 32, "
       "each a full render); the EXR's other channels stay those of the frame itself.")
KF_KEY(RENDER_CAMERA_KEYS, "render.camera_keys", KT_LIST, KS_KEY, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0,
       "Keyframed camera: eye, target and fov per key; held before the first key and after the last; frames "
       "increase. Replaces render.eye and render.target.")
KF_KEY(RENDER_CAMERA_KEYS_FRAME, "render.camera_keys[].frame", KT_NUM, KEY(frame), CC(-9999999, 9999999), NULL, NULL,
       NULL, NULL, KF_REQ, "Frame of the key (may be fractional).")
KF_KEY(RENDER_CAMERA_KEYS_EYE, "render.camera_keys[].eye", KT_VEC3, KEY(eye), ANY, NULL, NULL, "m", NULL, KF_REQ,
       "Camera position at that frame.")
KF_KEY(RENDER_CAMERA_KEYS_TARGET, "render.camera_keys[].target", KT_VEC3, KEY(target), ANY, NULL, NULL, "m", NULL,
       KF_REQ, "Point looked at.")
KF_KEY(RENDER_CAMERA_KEYS_FOV, "render.camera_keys[].fov", KT_NUM, KEY(fov), OO(1, 170), NULL, "(render.fov)",
       "degrees", NULL, 0, "Vertical field of view at that frame.")
KF_KEY(
    RENDER_INTERPOLATION, "render.interpolation", KT_ENUM, TOP(s.render_interp), ANY, "linear|smooth", "smooth", NULL,
    NULL, 0,
    "Between camera keys, per channel: linear, or smooth (cubic Hermite, easing in and out at the first and last key).")
/* the three lights; directions point towards the light in camera space, so
 * a moving camera keeps its lighting */
KF_KEY(RENDER_KEY_LIGHT, "render.key_light", KT_SECTION, KS_TOP, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0,
       "The key light: the main light, casting shadows.")
KF_KEY(RENDER_KEY_LIGHT_DIRECTION, "render.key_light.direction", KT_VEC3, TOP(s.lights[0].dir), ANY, NULL,
       "[-0.55, 0.75, 0.6]", NULL, NULL, 0, "Towards the light, in camera space (x right, y up, z towards the viewer).")
KF_KEY(RENDER_KEY_LIGHT_COLOR, "render.key_light.color", KT_VEC3, TOP(s.lights[0].color), CC(0, 1), NULL,
       "[1, 0.96, 0.89]", NULL, NULL, 0, "Colour (linear RGB, scaled by intensity).")
KF_KEY(RENDER_KEY_LIGHT_INTENSITY, "render.key_light.intensity", KT_NUM, TOP(s.lights[0].intensity), CC(0, 100), NULL,
       "1.35", NULL, NULL, 0, "Strength (1: a white surface facing it is lit to white).")
KF_KEY(RENDER_FILL_LIGHT, "render.fill_light", KT_SECTION, KS_TOP, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0,
       "The fill light: softens the key's shadow side.")
KF_KEY(RENDER_FILL_LIGHT_DIRECTION, "render.fill_light.direction", KT_VEC3, TOP(s.lights[1].dir), ANY, NULL,
       "[0.8, 0.2, 0.45]", NULL, NULL, 0, "Towards the light, in camera space.")
KF_KEY(RENDER_FILL_LIGHT_COLOR, "render.fill_light.color", KT_VEC3, TOP(s.lights[1].color), CC(0, 1), NULL,
       "[0.73, 0.83, 1]", NULL, NULL, 0, "Colour (linear RGB).")
KF_KEY(RENDER_FILL_LIGHT_INTENSITY, "render.fill_light.intensity", KT_NUM, TOP(s.lights[1].intensity), CC(0, 100), NULL,
       "0.3", NULL, NULL, 0, "Strength.")
KF_KEY(RENDER_RIM_LIGHT, "render.rim_light", KT_SECTION, KS_TOP, NOFIELD, ANY, NULL, NULL, NULL, NULL, 0,
       "The rim light: from behind, outlining the silhouette against the background.")
KF_KEY(RENDER_RIM_LIGHT_DIRECTION, "render.rim_light.direction", KT_VEC3, TOP(s.lights[2].dir), ANY, NULL,
       "[0.2, 0.5, -1]", NULL, NULL, 0, "Towards the light, in camera space (z < 0: behind the subject).")
KF_KEY(RENDER_RIM_LIGHT_COLOR, "render.rim_light.color", KT_VEC3, TOP(s.lights[2].color), CC(0, 1), NULL, "[1, 1, 1]",
       NULL, NULL, 0, "Colour (linear RGB).")
KF_KEY(RENDER_RIM_LIGHT_INTENSITY, "render.rim_light.intensity", KT_NUM, TOP(s.lights[2].intensity), CC(0, 100), NULL,
       "0.45", NULL, NULL, 0, "Strength (0: no rim light).")
