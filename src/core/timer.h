/* timer.h — monotonic wall clock, process and thread CPU time in milliseconds. */
#ifndef KF_TIMER_H
#define KF_TIMER_H

#include <time.h>

static inline double kf_now_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

/* CPU time of every thread of the process (the honest figure on a busy
 * machine when idle OpenMP threads sleep) */
static inline double kf_process_cpu_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

/* CPU time of the calling thread only (a kernel timed on one thread
 * while others run) */
static inline double kf_thread_cpu_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

#endif
