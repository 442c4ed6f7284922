/* checkpoint.h — the full simulation state per frame, lossless and resumable.
 *
 * A checkpoint holds everything the step reads from the state: every particle
 * plane (bit for bit), material ids, stable ids, time, substep count and the
 * next particle id. Grid data is transient (rebuilt by the next bin), so it is
 * not stored; resuming from a checkpoint reproduces the uninterrupted run to
 * the bit (tests/test_checkpoint.c).
 *
 * Layout (little-endian): header {magic "KERFCKPT", format version, size of
 * kf_real, particle count, frame, time, substep, next id, inputs hash, rigid
 * body count, rigid solver bytes}, the particle planes (reals, material, id,
 * object, CPIC colour), the rigid body states and the rigid solver's state,
 * then a 64-bit FNV-1a checksum of everything before it.
 * Written to a temporary name and renamed. */
#ifndef KF_CHECKPOINT_H
#define KF_CHECKPOINT_H

#include <stddef.h>
#include <stdint.h>

#include <kerf/kerf.h>

#define KF_CHECKPOINT_VERSION 2 /* 2: object ids, CPIC colours, rigid bodies */

typedef struct kf_checkpoint_info {
    int frame;
    double time;
    long substep;
    size_t particles;
    uint64_t inputs_hash; /* hash of the sim-relevant inputs that made it */
} kf_checkpoint_info;

/* Returns 0, or -1 with a message naming the path in err. The file holds
 * the particles but not how the grid groups them (kf_grid_bin keeps a
 * grouping while particles drift within reach of their blocks), so the
 * state's next substep re-sorts from scratch, exactly as the run resumed
 * from this file will: both continue bit for bit alike. */
int kf_checkpoint_write(const char *path, kf_state *s, int frame, uint64_t inputs_hash, char *err, size_t errlen);

/* The same file written from pieces (one MPI run's ranks' particles, a
 * window at a time, without the whole state in one place): _begin with the
 * state's clock and rigid bodies and the whole particle count n; _window
 * for particles [at, at + win's count) of the whole array, in any order of
 * windows; _end writes the rest and the checksum (read back from the file)
 * and renames. A failure is kept and reported by _end, which also cleans
 * up; _abort drops the file. Returns 0, or -1 with a message in err. */
typedef struct kf_checkpoint_out {
    void *af; /* the atomic file */
    size_t n;
    long body; /* where the particle arrays begin */
    int failed, err_no;
} kf_checkpoint_out;
int kf_checkpoint_begin(kf_checkpoint_out *o, const char *path, const kf_state *s, size_t n, int frame,
                        uint64_t inputs_hash, char *err, size_t errlen);
void kf_checkpoint_window(kf_checkpoint_out *o, const kf_state *win, size_t at);
int kf_checkpoint_end(kf_checkpoint_out *o, const kf_state *s, char *err, size_t errlen);

/* Replace the state's particles and clock with the checkpoint's. The
 * checksum over the whole file is verified before any header field is
 * believed; then the version, the precision, and every count against the
 * file's length (with overflow checks), so a damaged or forged header is
 * refused before anything is allocated from it; materials must exist in m.
 * Returns 0, or -1 with a message naming the path and what is wrong. */
int kf_checkpoint_read(const char *path, const kf_model *m, kf_state *s, kf_checkpoint_info *info, char *err,
                       size_t errlen);

/* Only some of the particles, without the whole state in memory (one MPI
 * rank's part): the file is verified as kf_checkpoint_read does, then read
 * a window of particles at a time, twice. The first pass shows `see` every
 * particle's position, in file order; then `settle` says how many `keep`
 * will accept; the second pass keeps those `keep` accepts, in file order.
 * Every particle's material is checked, kept or not, so each reader of one
 * file comes to the same answer. The state's clock, rigid bodies and next
 * id are the file's. Returns 0, or -1 with a message in err. */
typedef struct kf_checkpoint_filter {
    int (*see)(void *ctx, kf_real *const x[3], size_t n); /* 0, or -1 (out of memory) */
    long (*settle)(void *ctx);                            /* particles keep will accept, or -1 */
    int (*keep)(void *ctx, const kf_real x[3]);
    void *ctx;
} kf_checkpoint_filter;
int kf_checkpoint_read_part(const char *path, const kf_model *m, kf_state *s, const kf_checkpoint_filter *filter,
                            kf_checkpoint_info *info, char *err, size_t errlen);

/* The file's particles a window at a time into win (particles [at, at +
 * win's count), in file order), for a writer that needs no whole state:
 * visit is called for each, and a visit that returns nonzero ends the read.
 * win's clock is the file's before the first window. Returns 0, or -1 with
 * a message in err (after a failed visit, err is as visit left it). */
int kf_checkpoint_windows(const char *path, const kf_model *m, kf_state *win,
                          int (*visit)(void *ctx, const kf_state *win, size_t at), void *ctx, char *err, size_t errlen);

/* Only the header, checked against the file's length: for finding where to
 * resume. The checksum is verified only when the header looks foreign (another
 * version or precision, counts the length does not match), so that damage is
 * reported as damage and not as another build. */
int kf_checkpoint_peek(const char *path, kf_checkpoint_info *info, char *err, size_t errlen);

#endif
