/* mjguard.c — MuJoCo's error and warning hooks (see mjguard.h). The hooks
 * are process-wide; the message and the jump target are per thread. */
#include "mjguard.h"

#include <mujoco/mujoco.h>
#include <stdio.h>

static _Thread_local jmp_buf *guard;
static _Thread_local char message[512];

static void on_error(const char *msg) {
    snprintf(message, sizeof message, "MuJoCo error: %s", msg);
    /* MuJoCo's error hook must not return into the engine */
    if (guard) longjmp(*guard, 1);
}

static void on_warning(const char *msg) { snprintf(message, sizeof message, "MuJoCo warning: %s", msg); }

void kf_mj_hooks(void) {
    mju_user_error = on_error;
    mju_user_warning = on_warning;
}

void kf_mj_guard(jmp_buf *jb) { guard = jb; }
const char *kf_mj_message(void) { return message; }
void kf_mj_clear(void) { message[0] = 0; }
