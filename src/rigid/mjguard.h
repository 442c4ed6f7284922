/* mjguard.h — MuJoCo prints and exits on errors unless told otherwise.
 * kf_mj_hooks() routes its errors and warnings into a per-thread message;
 * an error inside a guarded call jumps back to the guard:
 *
 *     jmp_buf jb;
 *     if (setjmp(jb)) { ... kf_mj_message() ... }   // MuJoCo failed
 *     kf_mj_guard(&jb);  mj_step(m, d);  kf_mj_guard(NULL);
 */
#ifndef KF_RIGID_MJGUARD_H
#define KF_RIGID_MJGUARD_H

#include <setjmp.h>

void kf_mj_hooks(void);
void kf_mj_guard(jmp_buf *jb);
/* the last error or warning MuJoCo reported on this thread ("" if none) */
const char *kf_mj_message(void);
void kf_mj_clear(void);

#endif
