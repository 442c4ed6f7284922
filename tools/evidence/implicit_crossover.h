/* implicit_crossover.h — the stiffness crossover of the implicit evidence
 * (implicit_crossover.c), run by kf_evid_implicit_sweep --crossover. */
#ifndef KF_EVID_IMPLICIT_CROSSOVER_H
#define KF_EVID_IMPLICIT_CROSSOVER_H

/* For each Young's modulus Es[0..nE), the cheapest run within each error
 * budget, written under out/; returns 0, or nonzero when a run failed. */
int crossover(const char *out, const double *Es, int nE);

#endif
