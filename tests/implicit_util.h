/* implicit_util.h — what the implicit-solver tests share: a model and
 * state held together, a uniform random number in [-1, 1), and the
 * workspace of one substep (binned with the model's own 1/Δx, so the
 * stencils match the transfers). Include after kt.h and scene_util.h. */
#ifndef KF_TEST_IMPLICIT_UTIL_H
#define KF_TEST_IMPLICIT_UTIL_H

#include "implicit/implicit.h"
#include "mpm/model.h"

static inline double urand(unsigned *s) { return 2 * tu_uniform(s) - 1; }

typedef struct scene {
    kf_model *m;
    kf_state *s;
    int mat;
} scene;

static inline void scene_free(scene *sc) {
    kf_state_destroy(sc->s);
    kf_model_destroy(sc->m);
}

/* the workspace of a substep of dt from the scene's state */
static inline void workspace_create(scene *sc, double dt, kf_implicit *w) {
    size_t bad;
    int rc = kf_grid_bin(&sc->s->g, &sc->s->p, kf_model_inv_dx(sc->m), sc->m->sim.kernel == KF_KERNEL_CUBIC, 2, &bad);
    KT_CHECK(rc == 0, "bin %d", rc);
    KT_CHECK(kf_imp_create(w, sc->m, sc->s, dt) == 0, "workspace");
}

#endif
