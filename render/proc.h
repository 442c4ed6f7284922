/* proc.h — symbols found at run time, as function pointers.
 *
 * dlsym hands back a void *, and ISO C has no conversion from an object
 * pointer to a function pointer (POSIX promises only that the bits are the
 * function's address). kf_dlsym copies those bits into a generic function
 * pointer, here and nowhere else; callers convert kf_proc to the typed
 * pointer they keep, a function-to-function conversion C allows. The GL's
 * own lookups (eglGetProcAddress, OSMesaGetProcAddress) already return
 * function pointers and go through kf_proc the same way. */
#ifndef KF_RENDER_PROC_H
#define KF_RENDER_PROC_H

#include <dlfcn.h>
#include <string.h>

typedef void (*kf_proc)(void);

/* the function `name` of the library lib (dlopen's handle), or NULL */
static inline kf_proc kf_dlsym(void *lib, const char *name) {
    void *sym = dlsym(lib, name);
    kf_proc f;
    _Static_assert(sizeof f == sizeof sym, "a function pointer has the size of dlsym's result");
    memcpy(&f, &sym, sizeof f);
    return f;
}

#endif
