/* watch.c — rank 0's watchdog: the word that a run over several ranks
 * stopped, when rank 0 gets no chance to say it.
 *
 * When one rank dies, the launcher ends the others. Open MPI sends SIGTERM
 * first, which rank 0 catches (dist.c) to say why; MPICH's Hydra sends
 * SIGKILL at once, and a killed process says nothing. So rank 0 forks,
 * before MPI starts, a small process that holds no MPI state and waits on a
 * pipe from it. Rank 0 writes one byte before it goes: DONE when it exits
 * (a finished or failed run, which says its own piece), SAID when a signal
 * handler has printed why. Seeing the pipe close after neither, the
 * watchdog prints the stop line with the hint to resume, on the stderr
 * the launcher collects (the launcher reads that stream until its last
 * writer closes it, so the line reaches the log), and exits. It lives in its
 * own session, so a group kill or the terminal's Ctrl-C passes it by, and it
 * outlives rank 0 only by that one write: nothing is left behind. */
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdlib.h>
#include <unistd.h>

#include "internal.h"

static int g_watch_fd = -1; /* rank 0's end of the pipe, or -1 */

/* Neither rank 0 nor its watchdog can tell a rank's death from Ctrl-C
 * (Open MPI ends the ranks by SIGTERM for both; Hydra's SIGKILL may come
 * before rank 0 runs its SIGINT handler): the line names both. */
void kf_dist_say_stopped(void) {
    static const char msg[] = "kerf: stopped: an MPI rank of this run ended, or the run was interrupted; `kerf run "
                              "--resume` continues after the last checkpoint written\n";
    ssize_t w = write(2, msg, sizeof msg - 1);
    (void)w;
}

static void watch(int in) {
    char last = 0, c;
    for (;;) {
        ssize_t n = read(in, &c, 1);
        if (n == 1) {
            if (c == KF_DIST_WATCH_DONE) _exit(0);
            last = c;
        } else if (n == 0) break;
        else if (errno != EINTR) _exit(0);
    }
    if (last != KF_DIST_WATCH_SAID) kf_dist_say_stopped();
    _exit(0);
}

void kf_dist_watch_start(void) {
    int fd[2];
    if (pipe(fd)) return; /* without a watchdog the run goes on as before */
    pid_t pid = fork();
    if (pid == 0) {
        /* the watchdog: its own session, and no descriptor but the pipe and
         * stderr (the launcher's PMI socket among those it drops) */
        setsid();
        signal(SIGPIPE, SIG_DFL);
        int in = fd[0];
        long top = sysconf(_SC_OPEN_MAX);
        if (top < 0 || top > 4096) top = 4096;
        for (int f = 0; f < (int)top; f++)
            if (f != in && f != 2) close(f);
        watch(in);
    }
    close(fd[0]);
    if (pid < 0) {
        close(fd[1]);
        return;
    }
    /* programs rank 0 starts do not inherit it: only rank 0's end closes the pipe */
    fcntl(fd[1], F_SETFD, FD_CLOEXEC);
    g_watch_fd = fd[1];
}

void kf_dist_watch_say(char c) {
    if (g_watch_fd < 0) return;
    ssize_t w = write(g_watch_fd, &c, 1);
    (void)w;
    if (c == KF_DIST_WATCH_DONE) {
        close(g_watch_fd);
        g_watch_fd = -1;
    }
}
