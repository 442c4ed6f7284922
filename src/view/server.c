/* server.c — kerf view's HTTP side (libmicrohttpd): where it listens, which
 * requests it answers, and how (see view.h for the rules).
 *
 * One internal thread answers every request in turn, so the state in
 * kf_view needs no locks; the calling thread only starts and stops it. */
#define _DEFAULT_SOURCE /* realpath, getrandom */
#include <arpa/inet.h>
#include <errno.h>
#include <microhttpd.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/random.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include "../io/atomic_file.h"
#include "assets.h"
#include "files.h"
#include "internal.h"

/* ---- answers ------------------------------------------------------------------ */

static enum MHD_Result send_buf(struct MHD_Connection *c, unsigned status, const char *type, const void *data,
                                size_t n) {
    struct MHD_Response *r = MHD_create_response_from_buffer(n, (void *)data, MHD_RESPMEM_MUST_COPY);
    if (!r) return MHD_NO;
    MHD_add_response_header(r, "Content-Type", type);
    MHD_add_response_header(r, "Cache-Control", "no-store");
    MHD_add_response_header(r, "X-Content-Type-Options", "nosniff");
    MHD_add_response_header(r, "Referrer-Policy", "no-referrer");
    /* the page runs only its own script and shows only this server's images; no one may frame it */
    MHD_add_response_header(r, "Content-Security-Policy",
                            "default-src 'self'; img-src 'self'; style-src 'self'; frame-ancestors 'none'");
    enum MHD_Result ok = MHD_queue_response(c, status, r);
    MHD_destroy_response(r);
    return ok;
}

static enum MHD_Result send_text(struct MHD_Connection *c, unsigned status, const char *text) {
    return send_buf(c, status, "text/plain; charset=utf-8", text, strlen(text));
}

static enum MHD_Result send_json(struct MHD_Connection *c, unsigned status, kf_buf *b) {
    if (b->failed) return send_text(c, 500, "out of memory\n");
    return send_buf(c, status, "application/json", b->s ? b->s : "{}", b->s ? b->len : 2);
}

static const char *type_of(const char *name) {
    const char *dot = strrchr(name, '.');
    if (!dot) return "application/octet-stream";
    if (!strcmp(dot, ".png")) return "image/png";
    if (!strcmp(dot, ".json")) return "application/json";
    if (!strcmp(dot, ".jsonl") || !strcmp(dot, ".log") || !strcmp(dot, ".txt")) return "text/plain; charset=utf-8";
    if (!strcmp(dot, ".html")) return "text/html; charset=utf-8";
    if (!strcmp(dot, ".js")) return "text/javascript; charset=utf-8";
    if (!strcmp(dot, ".css")) return "text/css; charset=utf-8";
    return "application/octet-stream";
}

static enum MHD_Result send_file(kf_view *v, struct MHD_Connection *c, const char *rel) {
    int fd;
    size_t size;
    int st = kf_view_open(v->root, rel, &fd, &size);
    if (st == 400) return send_text(c, 400, "not a plain path under the output root\n");
    if (st == 403) return send_text(c, 403, "outside the output root\n");
    if (st != 200) return send_text(c, 404, "no such file\n");
    struct MHD_Response *r = MHD_create_response_from_fd(size, fd);
    if (!r) {
        close(fd);
        return MHD_NO;
    }
    MHD_add_response_header(r, "Content-Type", type_of(rel));
    /* frames are rewritten in place by a re-run, records grow: always ask again */
    MHD_add_response_header(r, "Cache-Control", "no-cache");
    MHD_add_response_header(r, "X-Content-Type-Options", "nosniff");
    enum MHD_Result ok = MHD_queue_response(c, 200, r);
    MHD_destroy_response(r);
    return ok;
}

/* the page, with this session's token in it */
static enum MHD_Result send_asset(kf_view *v, struct MHD_Connection *c, const char *name) {
    for (int i = 0; i < kf_view_nassets; i++) {
        const kf_view_asset *a = &kf_view_assets[i];
        if (strcmp(a->name, name)) continue;
        const char *mark = "__KERF_TOKEN__", *at = NULL;
        size_t ml = strlen(mark);
        for (size_t k = 0; !strcmp(name, "index.html") && k + ml <= a->size && !at; k++)
            if (!memcmp(a->data + k, mark, ml)) at = (const char *)a->data + k;
        if (!at) return send_buf(c, 200, type_of(name), a->data, a->size);
        kf_buf b = {0};
        kf_buf_put(&b, (const char *)a->data, (size_t)(at - (const char *)a->data));
        kf_buf_put(&b, v->token, strlen(v->token));
        size_t rest = (size_t)(at - (const char *)a->data) + strlen(mark);
        kf_buf_put(&b, (const char *)a->data + rest, a->size - rest);
        enum MHD_Result ok =
            b.failed ? send_text(c, 500, "out of memory\n") : send_buf(c, 200, type_of(name), b.s, b.len);
        kf_buf_free(&b);
        return ok;
    }
    return send_text(c, 404, "no such page\n");
}

static enum MHD_Result send_state(kf_view *v, struct MHD_Connection *c) {
    kf_buf b = {0};
    kf_buf_put(&b, "{", 1);
    kf_buf_kv(&b, "shot", v->shot ? v->shot->name : NULL);
    kf_buf_kv(&b, "shot_file", v->shot ? v->shot_path : NULL);
    const char *slash = strrchr(v->root, '/');
    kf_buf_kv(&b, "root", slash ? slash + 1 : v->root);
    if (v->shot)
        kf_buf_printf(&b, ",\"fps\":%g,\"first\":%d,\"last\":%d,\"tweak\":true", v->shot->fps, v->shot->frame_start,
                      v->shot->frame_end);
    else kf_buf_printf(&b, ",\"tweak\":false"); /* the page takes the rate from the run's record */
    kf_buf_put(&b, ",\"runs\":", 8);
    kf_view_runs_json(v, &b);
    kf_buf_put(&b, ",", 1);
    kf_view_scan(v->root, &b);
    kf_buf_put(&b, "}", 1);
    enum MHD_Result ok = send_json(c, 200, &b);
    kf_buf_free(&b);
    return ok;
}

/* ---- requests ------------------------------------------------------------------ */

typedef struct request {
    kf_buf body;
    int too_big;
} request;

/* the body: one override (path=value) a line */
static int split_sets(char *body, char **sets, int max) {
    int n = 0;
    for (char *line = body; line && *line;) {
        char *next = strchr(line, '\n');
        if (next) *next++ = 0;
        size_t l = strlen(line);
        if (l && line[l - 1] == '\r') line[--l] = 0;
        if (l) {
            if (n == max) return -1;
            sets[n++] = line;
        }
        line = next;
    }
    return n;
}

/* constant time: the answer's timing tells nothing about the token */
static int token_ok(const kf_view *v, const char *got) {
    size_t n = strlen(v->token);
    if (!got || strlen(got) != n) return 0;
    unsigned diff = 0;
    for (size_t i = 0; i < n; i++) diff |= (unsigned)(got[i] ^ v->token[i]);
    return diff == 0;
}

/* a page elsewhere reaching this port through a name of its own (DNS rebinding) sends its own Host */
static int host_ok(const kf_view *v, const char *host) {
    char a[64], b[64];
    snprintf(a, sizeof a, "127.0.0.1:%d", v->port);
    snprintf(b, sizeof b, "localhost:%d", v->port);
    return host && (!strcmp(host, a) || !strcmp(host, b));
}

static enum MHD_Result answer(void *cls, struct MHD_Connection *c, const char *url, const char *method,
                              const char *version, const char *upload, size_t *upload_size, void **con_cls) {
    kf_view *v = cls;
    request *rq = *con_cls;
    int post = !strcmp(method, "POST");
    if (!rq) {
        rq = calloc(1, sizeof *rq);
        if (!rq) return MHD_NO;
        *con_cls = rq;
        const char *len = MHD_lookup_connection_value(c, MHD_HEADER_KIND, "Content-Length");
        if (len && strtoull(len, NULL, 10) > KF_VIEW_MAX_BODY) rq->too_big = 1;
        return MHD_YES;
    }
    if (*upload_size) {
        /* the body, kept up to the limit and drained past it */
        if (!rq->too_big && rq->body.len + *upload_size <= KF_VIEW_MAX_BODY)
            kf_buf_put(&rq->body, upload, *upload_size);
        else rq->too_big = 1;
        *upload_size = 0;
        return MHD_YES;
    }
    if (!host_ok(v, MHD_lookup_connection_value(c, MHD_HEADER_KIND, "Host")))
        return send_text(c, 403, "kerf view answers only http://127.0.0.1:<port>/\n");
    if (rq->too_big) return send_text(c, 413, "request too large\n");
    if (!post && strcmp(method, "GET") && strcmp(method, "HEAD")) return send_text(c, 405, "GET or POST only\n");

    if (!post) {
        if (!strcmp(url, "/") || !strcmp(url, "/index.html")) return send_asset(v, c, "index.html");
        if (!strcmp(url, "/view.js") || !strcmp(url, "/view.css")) return send_asset(v, c, url + 1);
        if (!strcmp(url, "/api/state")) return send_state(v, c);
        if (!strcmp(url, "/api/keys")) return send_json(c, 200, &v->keys);
        if (!strncmp(url, "/files/", 7)) return send_file(v, c, url + 7);
        return send_text(c, 404, "no such page\n");
    }
    /* everything posted acts on this session: its token, in a header a page elsewhere cannot set */
    if (!token_ok(v, MHD_lookup_connection_value(c, MHD_HEADER_KIND, "X-Kerf-Token")))
        return send_text(c, 403, "missing or wrong session token\n");
    int check = !strcmp(url, "/api/check"), run = !strcmp(url, "/api/run");
    if (!check && !run) return send_text(c, 404, "no such action\n");
    char *sets[KF_VIEW_MAX_SETS];
    kf_buf_put(&rq->body, "", 0);
    int n = split_sets(rq->body.s ? rq->body.s : "", sets, KF_VIEW_MAX_SETS);
    if (n < 0) return send_text(c, 413, "too many edits at once\n");
    kf_buf out = {0};
    int status = 200;
    if (check) kf_view_check(v, sets, n, &out);
    else status = kf_view_start_run(v, sets, n, &out);
    enum MHD_Result ok = send_json(c, (unsigned)status, &out);
    kf_buf_free(&out);
    return ok;
}

static void completed(void *cls, struct MHD_Connection *c, void **con_cls, enum MHD_RequestTerminationCode why) {
    request *rq = *con_cls;
    if (!rq) return;
    kf_buf_free(&rq->body);
    free(rq);
    *con_cls = NULL;
}

/* URLs are taken as sent: a percent-encoded path is refused, never decoded into one that climbs out */
static size_t no_unescape(void *cls, struct MHD_Connection *c, char *s) { return strlen(s); }

/* ---- start and stop ----------------------------------------------------------------- */

/* The output root of a shot: output.dir up to its first component that
 * varies by version or frame (out/{shot}/v{version:03d} -> out/bunny), so
 * every version lies under it; without one, the directory itself. */
static int shot_root(const kf_shot *shot, char *out, size_t n) {
    char prefix[512];
    const char *t = shot->output_dir, *cut = NULL;
    for (const char *p = t; *p;) {
        size_t l = strcspn(p, "/");
        char comp[512];
        snprintf(comp, sizeof comp, "%.*s", (int)l, p);
        if (strstr(comp, "{version") || strstr(comp, "{frame")) {
            cut = p;
            break;
        }
        p += l + (p[l] == '/');
    }
    snprintf(prefix, sizeof prefix, "%.*s", (int)(cut ? cut - t : (long)strlen(t)), t);
    size_t l = strlen(prefix);
    while (l > 1 && prefix[l - 1] == '/') prefix[--l] = 0;
    if (!l) return kf_shot_expand(t, shot, shot->frame_start, out, n);
    return kf_shot_expand(prefix, shot, shot->frame_start, out, n);
}

static int listen_loopback(int port, int *actual, char *err, size_t errlen) {
    int s = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (s < 0) {
        snprintf(err, errlen, "kerf view: cannot open a socket: %s", strerror(errno));
        return -1;
    }
    /* a restart soon after the last one binds again; two listeners still cannot share the port */
    int one = 1;
    setsockopt(s, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = htons((uint16_t)port)};
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (bind(s, (struct sockaddr *)&a, sizeof a) != 0 || listen(s, 32) != 0) {
        int e = errno;
        if (e == EADDRINUSE)
            snprintf(err, errlen,
                     "kerf view: 127.0.0.1:%d is in use (another kerf view, or another program); stop "
                     "it or choose another port with --port N",
                     port);
        else snprintf(err, errlen, "kerf view: cannot listen on 127.0.0.1:%d: %s", port, strerror(e));
        close(s);
        return -1;
    }
    socklen_t len = sizeof a;
    getsockname(s, (struct sockaddr *)&a, &len);
    *actual = ntohs(a.sin_port);
    return s;
}

kf_view *kf_view_start(const kf_view_opts *o, kf_diag *diag, int *status, char *err, size_t errlen) {
    *status = 1;
    kf_view *v = calloc(1, sizeof *v);
    if (!v) {
        snprintf(err, errlen, "kerf view: out of memory");
        return NULL;
    }
    v->sock = -1;
    char root[2048];
    struct stat st;
    if (stat(o->target, &st) == 0 && S_ISDIR(st.st_mode)) {
        snprintf(root, sizeof root, "%s", o->target);
    } else {
        snprintf(v->shot_path, sizeof v->shot_path, "%s", o->target);
        v->shot = kf_shot_load(o->target, NULL, 0, NULL, NULL, diag);
        if (!v->shot) {
            snprintf(err, errlen, "kerf: %s: %d error%s, nothing served", o->target, diag->errors,
                     diag->errors == 1 ? "" : "s");
            *status = 2;
            goto fail;
        }
        /* the root may not exist before the first run: watch it fill */
        if (shot_root(v->shot, root, sizeof root) || kf_mkdirs(root)) {
            snprintf(err, errlen, "kerf view: %s: cannot make the output directory '%s': %s", o->target, root,
                     strerror(errno));
            goto fail;
        }
    }
    if (!realpath(root, v->root)) {
        snprintf(err, errlen, "kerf view: %s: %s", root, strerror(errno));
        goto fail;
    }
    if (o->kerf) snprintf(v->exe, sizeof v->exe, "%s", o->kerf);
    else {
        ssize_t n = readlink("/proc/self/exe", v->exe, sizeof v->exe - 1);
        v->exe[n > 0 ? n : 0] = 0;
    }
    unsigned char rnd[16];
    if (getrandom(rnd, sizeof rnd, 0) != (ssize_t)sizeof rnd) {
        snprintf(err, errlen, "kerf view: no random source for the session token: %s", strerror(errno));
        goto fail;
    }
    for (int i = 0; i < 16; i++) snprintf(v->token + 2 * i, 3, "%02x", rnd[i]);
    kf_view_keys_json(v, &v->keys);

    v->sock = listen_loopback(o->port, &v->port, err, errlen);
    if (v->sock < 0) goto fail;
    v->mhd = MHD_start_daemon(MHD_USE_AUTO_INTERNAL_THREAD, 0, NULL, NULL, answer, v, MHD_OPTION_LISTEN_SOCKET, v->sock,
                              MHD_OPTION_CONNECTION_LIMIT, (unsigned)64, MHD_OPTION_CONNECTION_TIMEOUT, (unsigned)30,
                              /* headers and URL of one request, all together */
                              MHD_OPTION_CONNECTION_MEMORY_LIMIT, (size_t)32768, MHD_OPTION_UNESCAPE_CALLBACK,
                              no_unescape, NULL, MHD_OPTION_NOTIFY_COMPLETED, completed, NULL, MHD_OPTION_END);
    if (!v->mhd) {
        snprintf(err, errlen, "kerf view: the HTTP server did not start on 127.0.0.1:%d", v->port);
        goto fail;
    }
    snprintf(v->url, sizeof v->url, "http://127.0.0.1:%d/", v->port);
    *status = 0;
    return v;
fail:
    if (v->sock >= 0) close(v->sock);
    if (v->shot) kf_shot_free(v->shot);
    kf_buf_free(&v->keys);
    free(v);
    return NULL;
}

const char *kf_view_url(const kf_view *v) { return v->url; }
const char *kf_view_root(const kf_view *v) { return v->root; }

void kf_view_stop(kf_view *v) {
    if (!v) return;
    MHD_stop_daemon(v->mhd);
    close(v->sock);
    kf_view_runs_stop(v);
    if (v->shot) kf_shot_free(v->shot);
    kf_buf_free(&v->keys);
    free(v);
}
