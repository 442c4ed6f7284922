/* step.c — one substep, CFL-adaptive advancing, and recovery from trouble.
 *
 * A substep: bin (sort) → P2G → grid update → G2P (with F update and
 * advection) → stress (the return mapping and the stress the next P2G
 * scatters). Each stage is timed into kf_step_stats. P2G and G2P check every
 * particle for numerical trouble; kf_advance answers
 * trouble by restarting the interval at half the CFL number.
 *
 * Where the scene allows (kf_fuse_applies), G2P and stress run as one sweep
 * over the owner blocks, and when the next substep's Δt is known in advance
 * (kf_state_fuse_next; kf_advance knows it under a fixed step, a holding
 * dt_max clamp, or the CFL rule's look-ahead) the sweep also makes the next
 * substep's P2G (kf_g2p2g), which that substep then uses instead of its
 * own: the same bits either way, one pass over the particles fewer. With
 * rigid bodies that needs the next substep's colored distance field before
 * the sweep: where every body is static it is this one (cpic/early.c), and
 * the band's early P2G keeps the colours it started from until the next
 * substep has taken it or dropped it.
 *
 * The CFL rule picks Δt from the particles after G2P (the fastest |v|, the
 * most compressed state), too late for a sweep that scatters the next P2G
 * during G2P. Where every particle's new velocity is a weighted mean of
 * the grid's (looks_ahead), kf_step also picks the next length before G2P
 * from the grid's new velocities (guess_next_dt), and kf_advance steps the
 * smaller of that and the rule's own: never longer than the rule allows,
 * and the look-ahead's (so the scatter is used) nearly always. The sweep
 * gathers the rule's figures as it goes (kf_cfl_scan), so kf_advance needs
 * no pass of its own over the particles. */
#include <math.h>
#ifdef __GLIBC__
#include <malloc.h>
#endif
#include <omp.h>
#include <stdio.h>
#include <string.h>

#include "../core/timer.h"
#include "contact.h"
#include "cpic_seam.h"
#include "model.h"
#include "../dist/dist.h"

const char *kf_stage_name(kf_stage s) {
    static const char *names[KF_STAGE_COUNT] = {"sort", "p2g", "grid", "g2p", "stress", "cdf", "rigid"};
    return s < KF_STAGE_COUNT ? names[s] : "?";
}

static void set_trouble(kf_trouble *t, const kf_state *s, size_t i, const char *what, double value) {
    memset(t, 0, sizeof *t);
    t->found = 1;
    snprintf(t->what, sizeof t->what, "%s", what);
    t->particle = s->p.n ? s->p.id[i] : 0;
    t->material = s->p.n ? s->p.mat[i] : -1;
    t->substep = s->substep;
    t->value = value;
}

static double rigid_max_speed(const kf_model *m, const kf_state *s);
static double guess_next_dt(const kf_model *m, const kf_state *s);
static double landed(double dt, double left);

int kf_step(const kf_model *m, kf_state *s, double dt, kf_step_stats *st, kf_trouble *trouble) {
    kf_trouble none;
    /* arrays the model writes are not zero arrays (a material or body added
     * after the state was made); stress planes kept from now on are filled
     * before the next P2G reads them */
    const unsigned zero = s->p.zero & kf_state_zero_arrays(m, s);
    if ((s->p.zero & KF_ZERO_TAU) && !(zero & KF_ZERO_TAU)) s->tau_valid = 0;
    s->p.zero = zero;
    /* the fastest rigid surface over the substep (start and end), cells: the
     * material it drives moves as fast, and its elastic rebound twice as fast */
    double body_cells = m->nrigid ? rigid_max_speed(m, s) * dt / m->sim.dx : 0;
    if (!trouble) trouble = &none;
    memset(trouble, 0, sizeof *trouble);
    const kf_real rdt = (kf_real)dt;
    double t0 = kf_now_ms(), t1;

    /* across ranks: particles first go to the rank that owns their block now */
    if (s->dist && kf_dist_migrate(m, s)) kf_dist_abort(1);
    /* sort: particles into owner blocks (cheap when nobody changed block);
     * nothing to do when the last substep's fused sweep found every
     * particle within its owner's reach and nothing edited them since */
    kf_grid *g = &s->g;
    const int fusable = kf_fuse_applies(m, s);
    /* the last substep's fused end (kf_g2p2g) scattered this one's P2G
     * already: usable when it was made for this substep and this Δt, nothing
     * edited the particles, and (as the sweep reports a scatter only with
     * every particle in reach) binning below keeps every particle where it
     * is. With rigid bodies that early P2G also rewrote its band particles'
     * colours: usable only at its Δt to the bit (gΔt is a double), else the
     * colours go back now, while the particles are where the sweep left them */
    double early_dt = 0;
    const int early = m->nrigid && kf_cpic_early_pending(s, &early_dt);
    int scattered = fusable && g->fused_ready && g->fused_substep == s->substep && g->fused_rebins == g->rebins &&
                    g->valid && s->tau_valid && g->fused_dt == rdt && (!m->nrigid || (early && early_dt == dt));
    g->fused_ready = 0;
    if (early && !scattered) kf_cpic_early_undo(s);
    const int reach_tested =
        fusable && g->valid && s->tau_valid && g->reach_substep == s->substep && g->reach_rebins == g->rebins;
    const int in_reach = reach_tested && g->reach_all;
    /* some owner out of reach: binning skips its own test of every owner */
    g->known_out = reach_tested && !g->reach_all;
    g->reach_substep = -1;
    size_t bad = 0;
    int rc =
        in_reach ? 0 : kf_grid_bin(g, &s->p, kf_model_inv_dx(m), m->sim.kernel == KF_KERNEL_CUBIC, m->nthreads, &bad);
    if (rc == -2) set_trouble(trouble, s, bad, "position NaN or out of range", s->p.x[0][bad]);
    if (rc == -1) set_trouble(trouble, s, 0, "out of memory binning particles", 0);
    if (s->dist ? kf_dist_agree(s, rc != 0, trouble) : rc != 0) return 1;
    t1 = kf_now_ms();
    if (st) st->ms[KF_STAGE_SORT] += t1 - t0;

    /* testing the recovery path: one particle's velocity goes bad, once */
    if (m->fault_substep > 0 && s->substep == m->fault_substep && !s->fault_done && s->p.n &&
        (!s->dist || kf_dist_rank() == 0)) {
        s->fault_done = 1;
        s->p.v[0][0] = (kf_real)NAN;
    }

    /* CPIC: the grid colored distance field of this substep's rigid poses */
    if (m->nrigid) {
        if (kf_cpic_splat(m, s, dt)) {
            set_trouble(trouble, s, 0, "out of memory building the colored distance field", 0);
            return 1;
        }
        t0 = kf_now_ms();
        if (st) st->ms[KF_STAGE_CDF] += t0 - t1;
        t1 = t0;
    }

    /* contact between objects: the owners where fields meet (contact.h) */
    if (m->sim.contact) {
        /* the cut's pieces read the colours the substep starts with: an
         * early P2G's own are set aside meanwhile */
        const int swap = scattered && m->nrigid;
        if (swap) kf_cpic_early_swap(s);
        const int crc = kf_contact_prepare(m, s);
        if (swap) kf_cpic_early_swap(s);
        if (crc) {
            set_trouble(trouble, s, 0, "out of memory preparing contact between objects", 0);
            return 1;
        }
        /* fields meet somewhere: P2G scatters them too, which the early one did not */
        if (scattered && s->contact && s->contact->active) {
            kf_cpic_early_undo(s);
            scattered = 0;
        }
    }
    /* the early P2G's impulses become this substep's (the CDF is the one it
     * read; else its colours go back and P2G runs) */
    if (scattered && m->nrigid && !kf_cpic_early_take(s)) scattered = 0;

    if (m->sim.integrator == KF_INTEGRATOR_IMPLICIT) {
        /* backward Euler (implicit.h): P2G of mass and momentum,
         * Newton-Krylov on the grid velocities, boundaries; leaves the grid
         * where kf_grid_update leaves it, so G2P and stress run unchanged */
        kf_trouble imp_trouble;
        int irc = kf_implicit_grid(m, s, dt, st, &imp_trouble);
        t0 = t1;
        t1 = kf_now_ms();
        if (st) st->ms[KF_STAGE_GRID] += t1 - t0;
        if (irc) {
            *trouble = imp_trouble;
            return 1;
        }
    } else {
        int updated = 0; /* the grid update ran in P2G's parallel region */
        if (scattered) {
            if (st) st->fused++;
            /* the scatter's nodes become the grid's */
            kf_v4 *nodes = g->node;
            size_t cap = g->node_cap;
            g->node = g->node_next, g->node_cap = g->node_next_cap;
            g->node_next = nodes, g->node_next_cap = cap;
            t0 = t1;
        } else {
            kf_trouble p2g_trouble;
            /* across ranks: the boundary owners' caches to the ranks that share their nodes */
            if (s->dist && kf_dist_halo(m, s, rdt)) kf_dist_abort(1);
            /* one rank: the grid update in P2G's parallel region, one
             * hand-off fewer (the P2G stage ends when this thread's owners do) */
            updated = kf_p2g_joins_update(m, s);
            if (updated) kf_p2g_update(m, s, rdt, &p2g_trouble, &t0);
            else kf_p2g(m, s, rdt, &p2g_trouble), t0 = kf_now_ms();
            if (st) st->ms[KF_STAGE_P2G] += t0 - t1;
            if (s->dist ? kf_dist_agree(s, p2g_trouble.found, &p2g_trouble) : p2g_trouble.found) {
                *trouble = p2g_trouble;
                return 1;
            }
        }

        if (!updated) kf_grid_update(m, s, rdt);
        if (m->sim.contact) kf_contact_grid(m, s, rdt);
        /* under the CFL rule's look-ahead (kf_advance): the next substep's
         * length from the grid's new velocities, before G2P, so the sweep
         * below can scatter the next P2G at it */
        if (s->fuse_cfl > 0) {
            s->guess_dt = guess_next_dt(m, s);
            s->fuse_next = s->fuse_left > 0 ? landed(s->guess_dt, s->fuse_left) : 0;
        }
        t1 = kf_now_ms();
        if (st) st->ms[KF_STAGE_GRID] += t1 - t0;
    }

    kf_g2p_result res;
    s->scan_valid = 0;
    if (fusable) {
        /* G2P and the stress pass in one sweep, with the next substep's P2G
         * when its Δt is announced; the whole sweep is timed as G2P */
        const kf_real next = (kf_real)s->fuse_next;
        const int got = kf_g2p2g(m, s, rdt, s->fuse_next, &res);
        /* without trouble the sweep tested every owner's reach */
        if (!res.trouble.found) {
            g->reach_substep = s->substep + 1;
            g->reach_rebins = g->rebins;
            g->reach_all = (got & KF_FUSED_REACH) != 0;
        }
        if (got & KF_FUSED_SCATTER) {
            g->fused_ready = 1;
            g->fused_substep = s->substep + 1;
            g->fused_rebins = g->rebins;
            g->fused_dt = next;
        }
        t0 = kf_now_ms();
        if (st) st->ms[KF_STAGE_G2P] += t0 - t1;
        t1 = t0;
    } else {
        kf_g2p(m, s, rdt, &res);
        if (s->dist) {
            /* every rank sees the same trouble and the same fastest particle speed */
            res.trouble.found = kf_dist_agree(s, res.trouble.found, &res.trouble);
            res.max_cells = kf_dist_max(s, res.max_cells);
        }
        /* implicit midpoint: the particles' velocity ends at v_{n+1} */
        kf_implicit_g2p_finish(m, s);
        t0 = kf_now_ms();
        if (st) st->ms[KF_STAGE_G2P] += t0 - t1;

        /* plasticity, and the stress the next P2G scatters */
        kf_stress(m, s, 1);
        t1 = kf_now_ms();
        if (st) st->ms[KF_STAGE_STRESS] += t1 - t0;
    }
    if (st && s->stiff_limited > st->stiff_limited) st->stiff_limited = s->stiff_limited;

    /* rigid bodies: the material's impulses, contacts, joints, advection */
    if (m->nrigid) {
        kf_cpic_finish(m, s, dt);
        kf_cpic_guard_settle(m, s); /* the guard's predicted poses against the bodies' own (guard.c) */
        if (st) {
            long caught;
            double depth;
            kf_cpic_caught(s, &caught, &depth);
            st->thin_caught += caught;
            double deep = depth / m->sim.dx;
            if (deep > st->thin_deepest) st->thin_deepest = deep;
        }
        t0 = kf_now_ms();
        if (st) st->ms[KF_STAGE_RIGID] += t0 - t1;
    }

    s->time += dt;
    s->substep++;
    if (st) {
        st->substeps++;
        st->particle_steps += (long)s->p.n;
        if (m->nrigid) st->band_particle_steps += kf_cpic_band_particles(s);
        st->active_blocks = (long)s->g.nblocks;
        if (st->dt_min == 0 || dt < st->dt_min) st->dt_min = dt;
        if (dt > st->dt_max) st->dt_max = dt;
    }
    if (st && res.max_cells > st->max_cells_moved) st->max_cells_moved = res.max_cells;
    if (res.trouble.found) {
        *trouble = res.trouble;
        return 1;
    }
    if (m->nrigid) {
        double end_cells = rigid_max_speed(m, s) * dt / m->sim.dx;
        if (end_cells > body_cells) body_cells = end_cells;
    }
    /* material a body drives moves as fast as the body, and rebounds at up to
     * twice its speed, for as long as it coasts after the body stops: under a
     * fixed step that may be more than the CFL bound, and is not trouble */
    if (body_cells > s->drive_cells) s->drive_cells = body_cells;
    double limit = m->sim.max_cells_per_step;
    if (m->sim.dt_fixed > 0 && 2.5 * s->drive_cells > limit) limit = 2.5 * s->drive_cells;
    if (res.max_cells > limit) {
        /* moving more than the kernel tolerates: report the fastest particle */
        size_t fast = 0;
        kf_real best = -1;
        for (size_t i = 0; i < s->p.n; i++) {
            kf_real v2 = s->p.v[0][i] * s->p.v[0][i] + s->p.v[1][i] * s->p.v[1][i] + s->p.v[2][i] * s->p.v[2][i];
            if (v2 > best) best = v2, fast = i;
        }
        set_trouble(trouble, s, fast, "CFL violated (cells moved per substep)", res.max_cells);
        /* across ranks: the report of a rank holding the fastest particle */
        if (s->dist) kf_dist_agree(s, s->p.n && (double)best == kf_dist_max(s, (double)best), trouble);
        return 1;
    }
    return 0;
}

/* the fastest point of any rigid body's surface now: |v| + |ω| reach */
static double rigid_max_speed(const kf_model *m, const kf_state *s) {
    double best = 0;
    for (int r = 0; r < m->nrigid; r++) {
        const kf_rigid_state *st = &s->rigid[r];
        double v = sqrt(st->v[0] * st->v[0] + st->v[1] * st->v[1] + st->v[2] * st->v[2]) +
                   sqrt(st->w[0] * st->w[0] + st->w[1] * st->w[1] + st->w[2] * st->w[2]) * m->rigid[r].reach;
        if (v > best) best = v;
    }
    return best;
}

/* The CFL rule's figures over particles lo..hi: |v|² in double (exact
 * products of floats, so contraction cannot change it) and the smallest
 * plastic state ps[0] per material (water's J, snow's Jp; the fixed
 * corotated model's det F, whose volume barrier stiffens below J_b; sand's
 * wave speed does not depend on a state). Values above 1 never lower the
 * starting 1. With states_only, only the plastic states ps[0] (the fused
 * sweep's G2P made |v|² and det F as it went: kf_g2p2g). */
__attribute__((noinline)) void kf_cfl_scan(const kf_model *m, const kf_particles *p, size_t lo, size_t hi,
                                           double *v2max, kf_real *state_min, int states_only) {
    /* per lane of 16, in runs of one material: loops the compiler turns into
     * SIMD (max and min are exact, so the lanes' split changes nothing) */
    enum { L = 16 };
    double vb[L];
    for (int j = 0; j < L; j++) vb[j] = *v2max;
    const kf_real *const *F = (const kf_real *const *)p->F;
    const kf_real *const *v = (const kf_real *const *)p->v;
    while (lo < hi) {
        const uint16_t k = p->mat[lo];
        size_t e = lo + 1;
        while (e < hi && p->mat[e] == k) e++;
        const int model = m->mat[k].model;
        kf_real sb[L];
        for (int j = 0; j < L; j++) sb[j] = state_min[k];
        /* nothing left to scan in this run */
        if (states_only && (model == KF_MAT_COROTATED || model == KF_MAT_SAND)) {
            lo = e;
            continue;
        }
        for (size_t i0 = lo; i0 < e; i0 += L) {
            const int n = e - i0 < L ? (int)(e - i0) : L;
            for (int j = 0; j < (states_only ? 0 : n); j++) {
                const size_t i = i0 + (size_t)j;
                double v2 = (double)v[0][i] * v[0][i] + (double)v[1][i] * v[1][i] + (double)v[2][i] * v[2][i];
                vb[j] = v2 > vb[j] ? v2 : vb[j];
            }
            if (model == KF_MAT_COROTATED)
                for (int j = 0; j < n; j++) {
                    const size_t i = i0 + (size_t)j;
                    kf_real st = F[0][i] * (F[4][i] * F[8][i] - F[5][i] * F[7][i]) -
                                 F[1][i] * (F[3][i] * F[8][i] - F[5][i] * F[6][i]) +
                                 F[2][i] * (F[3][i] * F[7][i] - F[4][i] * F[6][i]);
                    sb[j] = st < sb[j] ? st : sb[j];
                }
            else if (model != KF_MAT_SAND)
                for (int j = 0; j < n; j++) sb[j] = p->ps[0][i0 + (size_t)j] < sb[j] ? p->ps[0][i0 + (size_t)j] : sb[j];
        }
        for (int j = 0; j < L; j++)
            if (sb[j] < state_min[k]) state_min[k] = sb[j];
        lo = e;
    }
    for (int j = 0; j < L; j++)
        if (vb[j] > *v2max) *v2max = vb[j];
}

/* the scan over every particle, across ranks too (max and min are exact,
 * so the figures do not depend on the thread count or the ranks' split) */
static void cfl_scan_all(const kf_model *m, const kf_state *s, double *vmax2, kf_real *state_min) {
    const kf_particles *p = &s->p;
    const int nmat = m->nmat, nthreads = m->nthreads;
    const size_t n = p->n;
    *vmax2 = 0;
    for (int k = 0; k < nmat; k++) state_min[k] = 1;
#pragma omp parallel num_threads(nthreads)
    {
        kf_real local[KF_MAX_MATERIALS];
        double v2max = 0;
        for (int k = 0; k < nmat; k++) local[k] = 1;
        int t = omp_get_thread_num(), nt = omp_get_num_threads();
        kf_cfl_scan(m, p, n * (size_t)t / (size_t)nt, n * (size_t)(t + 1) / (size_t)nt, &v2max, local, 0);
#pragma omp critical
        {
            if (v2max > *vmax2) *vmax2 = v2max;
            for (int k = 0; k < nmat; k++)
                if (local[k] < state_min[k]) state_min[k] = local[k];
        }
    }
    /* across ranks: the global max and min (exact, so the substep agrees) */
    if (s->dist) {
        *vmax2 = kf_dist_max(s, *vmax2);
        kf_dist_min_reals(s, state_min, nmat);
    }
}

/* Δx / (c + |v|max): the substep at CFL number 1, from the fastest
 * particle's |v|² and each material's smallest state. c is the fastest wave
 * speed among the materials (water's at the most compressed particle). */
static double unit_from(const kf_model *m, const kf_state *s, double vmax2, const kf_real *state_min) {
    double cmax = 0;
    /* under a fixed step, the wave speed of the stiffness the step resolves */
    const double c_limit = kf_model_c_limit(m);
    for (int k = 0; k < m->nmat; k++) {
        int stateful =
            m->mat[k].model == KF_MAT_WATER || m->mat[k].model == KF_MAT_SNOW || m->mat[k].model == KF_MAT_COROTATED;
        kf_mat mk = m->mat[k];
        if (c_limit > 0) kf_mat_limit(&mk, c_limit);
        double c = kf_mat_wave_speed(&mk, stateful ? (double)state_min[k] : 1.0);
        if (c > cmax) cmax = c;
    }
    if (m->sim.integrator == KF_INTEGRATOR_IMPLICIT) {
        /* implicit: no elastic wave limit, advection alone; the speed gained
         * falling one cell stands in for c, so a body at rest still steps */
        const double *gr = m->sim.gravity;
        cmax = sqrt(sqrt(gr[0] * gr[0] + gr[1] * gr[1] + gr[2] * gr[2]) * m->sim.dx);
    }
    /* a rigid surface must not cross more than the kernel tolerates either */
    double vr = rigid_max_speed(m, s);
    if (vr * vr > vmax2) vmax2 = vr * vr;
    return m->sim.dx / (cmax + sqrt(vmax2) + 1e-30);
}

static double unit_cfl_dt(const kf_model *m, const kf_state *s) {
    double v2;
    kf_real state_min[KF_MAX_MATERIALS];
    cfl_scan_all(m, s, &v2, state_min);
    return unit_from(m, s, v2, state_min);
}

static double clamp_dt(const kf_model *m, double dt) {
    return m->sim.dt_max > 0 && dt > m->sim.dt_max ? m->sim.dt_max : dt;
}

/* whether kf_advance picks each substep's length under the CFL rule before
 * the substep before it ends its G2P (kf_step's guess_next_dt): the
 * explicit integrator with APIC, PIC or polypic, whose particle velocities
 * are weighted means of the grid's (no FLIP), in scenes whose bodies all
 * stand still (the only ones whose next P2G the sweep makes early). Near a
 * static body, or where contact fields meet, a particle's velocity need not
 * be such a mean; the guess may then be the longer, and kf_advance takes
 * the rule's (dropping the early P2G): the look-ahead never lengthens a
 * substep, it only shortens one to the length the sweep scattered at. */
static int looks_ahead(const kf_model *m) {
    int moving = 0;
    for (int r = 0; r < m->nrigid; r++) moving |= m->rigid[r].def.motion != KF_RIGID_STATIC;
    return m->sim.integrator == KF_INTEGRATOR_EXPLICIT && m->sim.transfer != KF_TRANSFER_FLIP && !moving &&
           !(m->sim.dt_fixed > 0);
}

static inline double node_v2(const kf_v4 v) {
    /* a node without mass gives every particle a zero weight */
    return v[3] > 0 ? (double)v[0] * v[0] + (double)v[1] * v[1] + (double)v[2] * v[2] : 0;
}

/* The fastest node's |v|² in double: every particle's new velocity is a
 * weighted mean of its stencil's nodes with mass (weights >= 0 summing to
 * 1), so none is faster, up to the mean's rounding. On one rank every node
 * with mass lies in some owner's neighbourhood; across ranks only the nodes
 * of a rank's own owners' neighbourhoods hold the one-rank sums (a halo
 * node may hold part of one), so each rank looks at those, and the max
 * over ranks is the one-rank figure. */
static double grid_vmax2(const kf_model *m, const kf_state *s) {
    const kf_grid *g = &s->g;
    double best = 0;
    if (!s->dist) {
        const size_t nn = g->nblocks * KF_BLOCK_NODES;
#pragma omp parallel for schedule(static) num_threads(m->nthreads) reduction(max : best)
        for (size_t i = 0; i < nn; i++) {
            double v2 = node_v2(g->node[i]);
            if (v2 > best) best = v2;
        }
        return best;
    }
    const size_t nowner = g->nowner;
#pragma omp parallel for schedule(static) num_threads(m->nthreads) reduction(max : best)
    for (size_t r = 0; r < nowner; r++)
        for (int q = 0; q < 8; q++) {
            const kf_v4 *node = &g->node[(size_t)g->nb[r][q] * KF_BLOCK_NODES];
            for (int l = 0; l < KF_BLOCK_NODES; l++) {
                double v2 = node_v2(node[l]);
                if (v2 > best) best = v2;
            }
        }
    return kf_dist_max(s, best);
}

/* The next substep's length under the CFL rule, chosen before G2P: the
 * fastest node stands in for the fastest particle, and each material's
 * smallest state for the end of the substep is the newest one the rule
 * saw, lowered by twice its last fall. A relative margin of 1e-5 covers
 * the rounding of the mean. kf_advance takes the smaller of this and the
 * rule's own Δt from the particles after the substep, so this only ever
 * shortens a substep; where it is the smaller (nearly always), the fused
 * sweep's early P2G was made at the right length. */
static double guess_next_dt(const kf_model *m, const kf_state *s) {
    kf_real pred[KF_MAX_MATERIALS];
    for (int k = 0; k < m->nmat; k++) {
        kf_real now = s->cfl_hist > 0 ? s->cfl_state[0][k] : 1, prev = s->cfl_hist > 1 ? s->cfl_state[1][k] : now;
        pred[k] = prev > now ? now - 2 * (prev - now) : now;
    }
    return clamp_dt(m, s->fuse_cfl * (1 - 1e-5) * unit_from(m, s, grid_vmax2(m, s), pred));
}

double kf_stable_dt(const kf_model *m, const kf_state *s, double cfl) { return clamp_dt(m, cfl * unit_cfl_dt(m, s)); }

/* the allocator's free memory handed back to the system (glibc keeps
 * freed blocks below its mmap threshold, which rises to 32 MB as large
 * blocks are freed) */
static void release_heap(void) {
#ifdef __GLIBC__
    malloc_trim(0);
#endif
}

/* land exactly on the interval end without a sliver of a step: dt with
 * `left` of the interval to go */
static double landed(double dt, double left) { return dt >= left ? left : dt > 0.5 * left ? 0.5 * left : dt; }

int kf_advance(const kf_model *m, kf_state *s, double duration, kf_step_stats *st, char *msg, size_t msglen) {
    if (msg && msglen) msg[0] = 0;
    /* the interval starts from a full sort, as its retry after trouble does
     * (the grid keeps a grouping of particles while they drift within
     * reach, grid.h): a retried interval and one made directly at the
     * smaller step then sum in the same order, bit for bit */
    /* an early P2G a caller of kf_step left pending: its colours back first */
    kf_cpic_early_undo(s);
    kf_grid_invalidate(&s->g);
    /* arrays the model never writes that hold only zeros (after a
     * checkpoint load or a caller's view) go back to untouched pages; out of
     * memory here only leaves them as they are */
    kf_particles_zero(&s->p, kf_state_zero_arrays(m, s) & ~s->p.zero);
    if (kf_snapshot_save(s)) {
        if (msg) snprintf(msg, msglen, "out of memory saving the interval start");
        return 1;
    }
    const double time0 = s->time;
    const long substep0 = s->substep;
    double cfl = m->sim.cfl, fixed = m->sim.dt_fixed;
    kf_trouble tr = {0};
    /* a fixed step is the shot's choice: only an opted-in retry may change it */
    const int retries = fixed > 0 && !m->sim.retry_fixed ? 0 : m->sim.max_retries;
    int attempt = 0;
    /* the CFL number a fixed step reached before the trouble, for the
     * message: a body faster than the material's waves shocks it, and the
     * shocked state's wave speed (compressed water's Tait speed grows as
     * J^((1-γ)/2)) would outgrow what the fixed step resolves; such states
     * are evaluated at the stiffness the step resolves (kf_mat_limit, counted
     * in stiff_limited), and what trouble remains is reported with how far
     * the step was outgrown rather than by changing the shot's step */
    double reached = 0;
    const int ahead = looks_ahead(m);
    for (; attempt <= retries; attempt++) {
        double t = 0;
        int ok = 1;
        /* the look-ahead starts afresh with each try of the interval, so a
         * retried or resumed interval picks the same substeps */
        s->guess_dt = 0, s->cfl_hist = 0, s->scan_valid = 0, s->scan_want = 1;
        while (duration - t > 1e-9 * duration) {
            /* the CFL rule's figures: from the fused sweep where it made
             * them, else one pass over the particles */
            double v2;
            kf_real state_min[KF_MAX_MATERIALS];
            if (s->scan_valid) {
                v2 = s->scan_v2;
                memcpy(state_min, s->scan_state, sizeof(kf_real) * (size_t)m->nmat);
            } else {
                cfl_scan_all(m, s, &v2, state_min);
            }
            s->scan_valid = 0;
            memcpy(s->cfl_state[1], s->cfl_state[0], sizeof s->cfl_state[0]);
            memcpy(s->cfl_state[0], state_min, sizeof(kf_real) * (size_t)m->nmat);
            s->cfl_hist++;
            double unit = unit_from(m, s, v2, state_min), left = duration - t;
            double dt = fixed > 0 ? fixed : clamp_dt(m, cfl * unit);
            /* the look-ahead's pick where it is the shorter */
            if (ahead && s->guess_dt > 0 && s->guess_dt < dt) dt = s->guess_dt;
            if (fixed > 0 && dt / unit > reached) reached = dt / unit;
            /* the next substep's length where it is known now (a fixed step)
             * or likely (the dt_max clamp held): kf_step may scatter its P2G
             * early (kf_g2p2g); a wrong guess only costs that scatter. Under
             * the look-ahead kf_step picks it itself, from the grid. */
            double next = fixed > 0 ? fixed : !ahead && dt < cfl * unit ? dt : 0;
            double left_next = duration - (t + landed(dt, left)); /* as the next turn computes it */
            s->fuse_next = next > 0 && left_next > 1e-9 * duration ? landed(next, left_next) : 0;
            s->fuse_cfl = ahead ? cfl : 0;
            s->fuse_left = left_next > 1e-9 * duration ? left_next : 0;
            s->guess_dt = 0;
            dt = landed(dt, left);
            if (kf_step(m, s, dt, st, &tr)) {
                ok = 0;
                break;
            }
            /* scratch freed by the interval's first substep (a static body's
             * distance store is built once, at its first splat) goes back to
             * the system, not kept by the allocator beside the grid */
            if (t == 0) release_heap();
            t += dt;
            if (st && dt / unit > st->max_cfl) st->max_cfl = dt / unit; /* CFL number used */
        }
        s->fuse_next = 0, s->fuse_cfl = 0, s->guess_dt = 0, s->scan_valid = 0, s->scan_want = 0;
        if (ok) return 0;
        /* trouble: back to the interval start, half the step, try again
         * (the restored colours are the start's: an early P2G's kept ones
         * are forgotten) */
        kf_cpic_early_drop(s);
        if (kf_snapshot_restore(s, time0, substep0)) {
            if (msg) snprintf(msg, msglen, "cannot read the interval start back to retry it");
            return 1;
        }
        if (st) st->retries++, st->warnings++;
        if (attempt == retries) break;
        cfl *= 0.5;
        fixed *= 0.5;
        if (st && fixed > 0) st->fixed_halved = fixed;
    }
    if (msg) {
        const char *name = tr.material >= 0 && tr.material < m->nmat ? m->mat_def[tr.material].name : "?";
        if (m->sim.dt_fixed > 0 && !m->sim.retry_fixed)
            snprintf(msg, msglen,
                     "numerical trouble: %s (value %g) at substep %ld, particle %u, material %d '%s', at the fixed "
                     "step sim.dt_fixed = %g s, which had reached CFL number %.2g (the fastest wave in the "
                     "material's current state plus the fastest particle, times the step over dx; the CFL rule "
                     "keeps it at sim.cfl = %g) (not retried: a fixed step is never changed; "
                     "sim.retry_fixed: true lets a retry halve it)",
                     tr.what, tr.value, tr.substep, tr.particle, tr.material, name, m->sim.dt_fixed, reached,
                     m->sim.cfl);
        else if (m->sim.dt_fixed > 0)
            snprintf(msg, msglen,
                     "numerical trouble: %s (value %g) at substep %ld, particle %u, material %d '%s'; still failing "
                     "after %d retries halving the fixed step (sim.retry_fixed; last step %g s, sim.dt_fixed %g s)",
                     tr.what, tr.value, tr.substep, tr.particle, tr.material, name, retries, fixed, m->sim.dt_fixed);
        else
            snprintf(msg, msglen,
                     "numerical trouble: %s (value %g) at substep %ld, particle %u, material %d '%s'; "
                     "still failing after %d retries at half the CFL number (last cfl %g)",
                     tr.what, tr.value, tr.substep, tr.particle, tr.material, name, retries, cfl);
    }
    return 1;
}
