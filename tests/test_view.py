#!/usr/bin/env python3
"""test_view.py — kerf view end to end, through a real headless Chromium.

  usage: test_view.py <kerf binary> <tests dir>

HTTP: files only under the output root (../, %2e%2e, symlinks out refused),
the Host and token checks, the request size limit, loopback-only binding, a
second view on the same port refused with a clear message. Browser (WebDriver
over chromedriver's HTTP API): frames play at the shot's fps and loop, the
canvas shows the frame's own pixels, keys step, A/B side by side, a plot
click jumps to its frame, a turntable plays; an edit to an invalid value
shows kerf's --set error at the key, a valid one re-runs at preview quality
and the new version appears in the grid. Exit 77 (skipped) without chromium.
"""
import base64, http.client, json, os, re, shutil, signal, socket, struct, subprocess, sys, tempfile, time, zlib

KERF, TESTS = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
fails = 0
procs = []  # every child started here, stopped by its pid at the end


def check(what, ok, detail=''):
    global fails
    print(('ok    ' if ok else 'FAIL  ') + what + ('' if ok else '  ' + str(detail)), flush=True)
    if not ok:
        fails += 1


def wait_for(fn, timeout, step=0.05):
    """fn() until it returns something true, or None after timeout seconds"""
    end = time.time() + timeout
    while time.time() < end:
        try:
            v = fn()
            if v:
                return v
        except Exception:
            pass
        time.sleep(step)
    return None


# ---- files ---------------------------------------------------------------------

def png(path, w, h, rgb):
    """a solid-colour 8-bit RGB PNG"""
    def chunk(kind, data):
        return struct.pack('>I', len(data)) + kind + data + struct.pack('>I', zlib.crc32(kind + data) & 0xffffffff)
    raw = b''.join(b'\0' + bytes(rgb) * w for _ in range(h))
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, 'wb') as f:
        f.write(b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', w, h, 8, 2, 0, 0, 0)) +
                chunk(b'IDAT', zlib.compress(raw)) + chunk(b'IEND', b''))


def colour(version, frame):
    """distinct per frame and version"""
    return ((frame * 37 + version * 101) % 256, (frame * 91 + version * 13) % 200 + 30, (frame * 53) % 256)


# ---- kerf view -------------------------------------------------------------------

def start_view(target, cwd, port=0):
    p = subprocess.Popen([KERF, 'view', target, '--port', str(port)], cwd=cwd, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    procs.append(p)
    line = p.stdout.readline()
    m = re.search(r'http://127\.0\.0\.1:(\d+)/', line)
    if not m:
        raise RuntimeError('kerf view did not start: ' + line + p.stderr.read())
    return p, int(m.group(1))


def request(port, method, path, body=None, headers=None, host=None):
    c = http.client.HTTPConnection('127.0.0.1', port, timeout=20)
    c.putrequest(method, path, skip_host=True, skip_accept_encoding=True)
    c.putheader('Host', host or '127.0.0.1:%d' % port)
    for k, v in (headers or {}).items():
        c.putheader(k, v)
    if body is not None:
        c.putheader('Content-Length', str(len(body)))
    c.endheaders(body)
    r = c.getresponse()
    data = r.read()
    c.close()
    return r.status, data


def token_of(port):
    st, page = request(port, 'GET', '/')
    return re.search(rb'name="kerf-token" content="([0-9a-f]{32})"', page).group(1).decode()


# ---- WebDriver (chromedriver's HTTP API) -----------------------------------------------

class Browser:
    def __init__(self, tmp):
        s = socket.socket()
        s.bind(('127.0.0.1', 0))
        self.port = s.getsockname()[1]
        s.close()
        self.proc = subprocess.Popen([shutil.which('chromedriver'), '--port=%d' % self.port], stdout=subprocess.DEVNULL,
                                     stderr=subprocess.DEVNULL, start_new_session=True)
        procs.append(self.proc)
        wait_for(lambda: self.call('GET', '/status')['value']['ready'], 30, 0.2)
        opts = {'args': ['--headless=new', '--no-sandbox', '--disable-gpu', '--disable-dev-shm-usage',
                         '--window-size=1280,720', '--user-data-dir=' + os.path.join(tmp, 'chromium')]}
        for b in ('chromium', 'chromium-browser'):
            if shutil.which(b):
                opts['binary'] = shutil.which(b)
                break
        caps = {'capabilities': {'alwaysMatch': {'browserName': 'chrome', 'goog:chromeOptions': opts}}}
        self.sid = self.call('POST', '/session', caps)['value']['sessionId']
        # the page at exactly 1280x720 CSS pixels, whatever the window's frame takes
        self.s('POST', '/goog/cdp/execute', {'cmd': 'Emulation.setDeviceMetricsOverride',
                                             'params': {'width': 1280, 'height': 720, 'deviceScaleFactor': 1,
                                                        'mobile': False}})

    def call(self, method, path, body=None):
        c = http.client.HTTPConnection('127.0.0.1', self.port, timeout=120)
        data = json.dumps(body).encode() if body is not None else None
        c.request(method, path, data, {'Content-Type': 'application/json'} if data else {})
        r = json.loads(c.getresponse().read() or b'{}')
        c.close()
        if isinstance(r.get('value'), dict) and 'error' in r['value']:
            raise RuntimeError('webdriver: %s: %s' % (r['value']['error'], r['value'].get('message', '')[:300]))
        return r

    def s(self, method, path, body=None):
        return self.call(method, '/session/%s%s' % (self.sid, path), body)['value']

    def go(self, url):
        self.s('POST', '/url', {'url': url})

    def js(self, script, *args):
        return self.s('POST', '/execute/sync', {'script': script, 'args': list(args)})

    def element(self, css):
        v = self.s('POST', '/element', {'using': 'css selector', 'value': css})
        return list(v.values())[0]

    def click(self, css):
        self.s('POST', '/element/%s/click' % self.element(css), {})

    def type(self, css, text):
        e = self.element(css)
        self.s('POST', '/element/%s/clear' % e, {})
        self.s('POST', '/element/%s/value' % e, {'text': text})

    def keys(self, *keys):
        acts = []
        for k in keys:
            acts += [{'type': 'keyDown', 'value': k}, {'type': 'keyUp', 'value': k}]
        self.s('POST', '/actions', {'actions': [{'type': 'key', 'id': 'kb', 'actions': acts}]})

    def click_at(self, css, dx, dy):
        """a click at (dx, dy) from the element's centre"""
        e = self.element(css)
        self.s('POST', '/actions', {'actions': [{'type': 'pointer', 'id': 'mouse', 'parameters': {'pointerType': 'mouse'},
                                                 'actions': [{'type': 'pointerMove', 'origin': {'element-6066-11e4-a52e-4f735466cecf': e},
                                                              'x': int(dx), 'y': int(dy)},
                                                             {'type': 'pointerDown', 'button': 0},
                                                             {'type': 'pointerUp', 'button': 0}]}]})

    def close(self):
        try:
            self.call('DELETE', '/session/' + self.sid)
        except Exception:
            pass


# what the canvas shows: the frame it says it drew, and its pixel at (fx, fy) of its size
PIXEL = """const cv = document.getElementById('view'), g = cv.getContext('2d');
const p = g.getImageData(Math.floor(cv.width * arguments[0]), Math.floor(cv.height * arguments[1]), 1, 1).data;
return [Number(cv.dataset.frame || -1), p[0], p[1], p[2]];"""


def close_to(rgb, want, tol=3):
    return all(abs(a - b) <= tol for a, b in zip(rgb, want))


def shown(b, fx=0.5, fy=0.5):
    f, r, g, bl = b.js(PIXEL, fx, fy)
    return f, (r, g, bl)


# ---- the tests ------------------------------------------------------------------------

def http_tests(work):
    root = os.path.join(work, 'synthetic')
    p, port = start_view(root, work)
    st, data = request(port, 'GET', '/files/v001/images/shot.1001.png')
    check('a frame under the root is served (200, PNG)', st == 200 and data[:8] == b'\x89PNG\r\n\x1a\n', st)
    for path in ['/files/../outside.txt', '/files/v001/../../outside.txt', '/files/%2e%2e/outside.txt',
                 '/files/%2E%2E/outside.txt', '/files/v001/%2e%2e/%2e%2e/outside.txt', '/files/..%2foutside.txt',
                 '/files//etc/passwd', '/files/v001/./images/shot.1001.png', '/files/v001\\..\\..\\outside.txt']:
        st, data = request(port, 'GET', path)
        check('traversal %s refused (400, got %d)' % (path, st), st == 400 and b'secret' not in data, data[:80])
    st, data = request(port, 'GET', '/files/v001/leak.png')
    check('a symlink out of the root is refused (403, got %d)' % st, st == 403 and b'secret' not in data)
    st, data = request(port, 'GET', '/files/v001/etc/passwd')
    check('a symlinked directory out of the root is refused (403, got %d)' % st, st == 403)
    st, data = request(port, 'GET', '/files/v001/inside.png')
    check('a symlink inside the root is followed (200, got %d)' % st, st == 200 and data[:4] == b'\x89PNG')
    st, _ = request(port, 'GET', '/files/v001/fifo.png')
    check('a FIFO under the root is not served, and does not hang the server (404, got %d)' % st, st == 404)
    st, _ = request(port, 'GET', '/files/v001/none.png')
    check('a missing file is 404 (got %d)' % st, st == 404)
    st, _ = request(port, 'GET', '/', host='evil.example:%d' % port)
    check('another Host (DNS rebinding) is refused (403, got %d)' % st, st == 403)
    try:
        st = request(port, 'GET', '/files/' + 'a/' * 20000 + 'x.png')[0]
    except (http.client.HTTPException, OSError):
        st = 0  # closed without an answer: refused too
    check('an oversized request line is refused (4xx or closed, got %d)' % st, st == 0 or 400 <= st < 500)
    check('... and the server still answers', request(port, 'GET', '/api/state')[0] == 200)

    # loopback only: the listening socket's address, and no answer on another address of this machine
    listen = []
    for fn in ('/proc/net/tcp', '/proc/net/tcp6'):
        for line in open(fn).read().splitlines()[1:]:
            f = line.split()
            if f[3] == '0A' and int(f[1].split(':')[1], 16) == port:
                listen.append(f[1].split(':')[0])
    check('it listens on 127.0.0.1 only (%s)' % listen, listen == ['0100007F'], listen)
    others = [a for a in subprocess.run(['hostname', '-I'], capture_output=True, text=True).stdout.split()
              if ':' not in a and not a.startswith('127.')]
    for a in others[:1]:
        s = socket.socket()
        s.settimeout(3)
        try:
            s.connect((a, port))
            check('no connection on %s:%d' % (a, port), False, 'connected')
        except OSError:
            check('no connection on %s:%d' % (a, port), True)
        s.close()

    # a second view on the same port: a clear error, exit 1, and the first still answers
    q = subprocess.run([KERF, 'view', root, '--port', str(port)], capture_output=True, text=True, timeout=30)
    check('a second kerf view on port %d exits 1 (got %d)' % (port, q.returncode), q.returncode == 1)
    check('... saying the port is in use', '127.0.0.1:%d is in use' % port in q.stderr, q.stderr)
    check('... and the first still answers', request(port, 'GET', '/api/state')[0] == 200)
    p.send_signal(signal.SIGTERM)
    check('SIGTERM stops kerf view (exit 0)', p.wait(timeout=20) == 0)


def token_tests(work, port):
    """posts to a view of a shot: without the token nothing runs"""
    before = sorted(os.listdir(os.path.join(work, 'tiny')))
    for hdr, what in [({}, 'missing'), ({'X-Kerf-Token': '0' * 32}, 'wrong'), ({'X-Kerf-Token': ''}, 'empty')]:
        st, data = request(port, 'POST', '/api/run', b'sim.cfl=0.3', hdr)
        check('a run with a %s token is refused (403, got %d)' % (what, st), st == 403, data[:80])
    st, _ = request(port, 'POST', '/api/run', b'sim.cfl=0.3', {'X-Kerf-Token': token_of(port)},
                    host='localhost.evil:%d' % port)
    check('a run with the token but another Host is refused (403, got %d)' % st, st == 403)
    time.sleep(0.5)
    check('... and no run started', sorted(os.listdir(os.path.join(work, 'tiny'))) == before)
    st, data = request(port, 'POST', '/api/check', b'x' * 20000, {'X-Kerf-Token': token_of(port)})
    check('a body over 16 KB is refused (413, got %d)' % st, st == 413)
    st, data = request(port, 'POST', '/api/check', b'sim.cfl=5', {'X-Kerf-Token': token_of(port)})
    j = json.loads(data)
    want = 'sim.cfl must be in (0, 2], got 5'
    check('a check gives --set\'s own message at --set:1:9', st == 200 and not j['ok'] and
          j['errors'][0]['message'] == want and j['errors'][0]['where'] == '--set:1:9', data[:200])
    st, data = request(port, 'POST', '/api/run', b'sim.dx=0.0004', {'X-Kerf-Token': token_of(port)})
    j = json.loads(data)
    check('a run kerf run would refuse (memory budget) is refused at its key, nothing started (400, got %d)' % st,
          st == 400 and j['errors'][0]['set'] == 0 and 'more than this machine' in j['errors'][0]['message'] and
          sorted(os.listdir(os.path.join(work, 'tiny'))) == before, data[:300])
    st, data = request(port, 'GET', '/api/keys')
    keys = {k['path']: k for k in json.loads(data)['keys']}
    cfl, e = keys.get('sim.cfl', {}), keys.get('materials.jelly.E', {})
    check('keys come from the key table: sim.cfl (help, bounds, value)', cfl.get('bounds') == 'in (0, 2]' and
          cfl.get('value') == '0.4' and cfl.get('doc', '').startswith('CFL number'), cfl)
    check('... materials.jelly.E with its unit', e.get('unit') == 'Pa' and e.get('editable'), e)
    # the lists, as written (loaded, a key is in seconds and absolute position)
    for path, value in [('colliders.post.keys.1.frame', '1003'), ('colliders.post.keys.1.translate', '[0, 0.1, 0]'),
                        ('colliders.post.center', '[0.9, 0.4, 0.9]'), ('colliders.post.friction', '0.3'),
                        ('render.camera_keys.1.eye', '[1.8, 1.4, 2.3]')]:
        k = keys.get(path, {})
        check('the list key %s is editable with its value as written (%s)' % (path, value),
              k.get('value') == value and k.get('editable') and k.get('applies'), k)
    st, data = request(port, 'POST', '/api/check', b'sim.cfl=0.3\ncolliders.post.keys.1.translate=[0, 0.1]',
                       {'X-Kerf-Token': token_of(port)})
    j = json.loads(data)
    check('a keyframe edit is checked as --set checks it, at its line (set 1)', st == 200 and not j['ok'] and
          [e['set'] for e in j['errors']] == [1] and 'colliders[0].keys[1].translate' in j['errors'][0]['message'], data[:300])

    # joints and rigid bodies: a robot's hinges, a leg's rotation as written (loaded, it is baked into the mesh)
    q, qport = start_view(os.path.join(os.path.dirname(TESTS), 'shots/robot_sand.yaml'), work)
    keys = {k['path']: k for k in json.loads(request(qport, 'GET', '/api/keys')[1])['keys']}
    for path, value in [('joints.hip_fl.kp', '0.5'), ('joints.hip_fl.axis', '[0, 0, -1]'), ('joints.hip_fl.motor', 'position'),
                        ('rigids.leg_fr.rotate', '[0, 0, 180]'), ('rigids.leg_fr.pivot', '[0, 0, 0]')]:
        k = keys.get(path, {})
        check('%s is editable with its value as written (%s)' % (path, value), k.get('value') == value and k.get('editable'), k)
    st, data = request(qport, 'POST', '/api/check', b'joints.hip_fl.kp=-1', {'X-Kerf-Token': token_of(qport)})
    j = json.loads(data)
    check('a joint edit out of bounds: --set\'s message at its key', st == 200 and not j['ok'] and
          j['errors'][0]['set'] == 0 and j['errors'][0]['message'] == 'joints[0].kp must be > 0 N m/rad, got -1', data[:300])
    q.send_signal(signal.SIGTERM)
    q.wait(timeout=20)


def browser_flipbook(b, port, root):
    b.go('http://127.0.0.1:%d/' % port)
    first = wait_for(lambda: shown(b)[0] == 1001 and shown(b), 30)
    check('the page shows frame 1001 first', bool(first), shown(b))
    f, rgb = shown(b)
    check('... with frame 1001\'s pixels %s' % (colour(1, 1001),), close_to(rgb, colour(1, 1001)), rgb)
    lay = b.js("const r = (id) => document.getElementById(id).getBoundingClientRect();"
               "return [innerWidth, innerHeight, document.documentElement.scrollWidth, document.documentElement.scrollHeight,"
               "r('view').width, r('view').height, r('plot0').bottom, r('keys').bottom, r('transport').bottom];")
    check('usable at 1280x720: nothing spills out, the picture at least 800x300, plots and keys on screen (%s)' % lay,
          lay[:2] == [1280, 720] and lay[2] <= 1280 and lay[3] <= 720 and lay[4] >= 800 and lay[5] >= 300 and
          max(lay[6:]) <= 720)
    check('fps of a directory: the rate its run recorded (run.json: 30)', b.js("return document.getElementById('fps').value") == '30')

    # play: frames advance at the fps and loop back to the first
    b.js("document.getElementById('fps').value = '12'")
    b.click('#play')
    seen, t0, wrapped, last = [], time.time(), False, 1001
    while time.time() - t0 < 6 and not (wrapped and len(set(seen)) >= 8):
        f = shown(b)[0]
        if f != last:
            wrapped |= f < last
            seen.append(f)
            last = f
        time.sleep(0.02)
    elapsed = time.time() - t0
    check('playing shows every frame 1002-1008 (saw %s)' % sorted(set(seen)), set(range(1002, 1009)) <= set(seen) | {1001})
    check('... and loops back to 1001', wrapped)
    b.click('#play')
    time.sleep(0.3)
    f, rgb = shown(b)
    check('paused at %d: its own pixels %s (got %s)' % (f, colour(1, f), rgb), close_to(rgb, colour(1, f)))
    label = b.js("return document.getElementById('frame').textContent")
    check('the frame number is shown (%r)' % label, label.startswith(str(f)))

    # at 12 fps, 8 frames and a wrap take about 0.6 s or more; faster would ignore the rate
    check('... at the set rate (%.2f s for %d steps at 12 fps)' % (elapsed, len(seen)), elapsed >= (len(seen) - 1) / 12 * 0.8)

    # keyboard stepping
    b.js("document.activeElement.blur()")
    b.keys('\uE011')  # Home
    time.sleep(0.2)
    b.keys('\uE014', '\uE014')  # ArrowRight twice
    got = wait_for(lambda: shown(b)[0] == 1003, 5)
    f, rgb = shown(b)
    check('Home then Right Right: frame 1003 (got %d)' % f, bool(got))
    check('... with 1003\'s pixels', close_to(rgb, colour(1, 1003)), rgb)
    b.keys('\uE012')  # ArrowLeft
    check('Left: frame 1002', bool(wait_for(lambda: shown(b)[0] == 1002, 5)), shown(b))

    # A/B side by side: v002 on the right half
    b.js("const m = document.getElementById('mode'); m.value = 'side'; m.dispatchEvent(new Event('change'));"
         "const s = document.getElementById('seqB'); s.value = [...s.options].find(o => o.value.startsWith('v002/images')).value;"
         "s.dispatchEvent(new Event('change'));")
    ok = wait_for(lambda: close_to(shown(b, 0.75)[1], colour(2, 1002)) and close_to(shown(b, 0.25)[1], colour(1, 1002)), 10)
    check('side by side: A (v001) left, B (v002) right, both at 1002', bool(ok), (shown(b, 0.25), shown(b, 0.75)))
    b.js("const m = document.getElementById('mode'); m.value = 'wipe'; m.dispatchEvent(new Event('change'));")
    ok = wait_for(lambda: close_to(shown(b, 0.3)[1], colour(1, 1002)) and close_to(shown(b, 0.7)[1], colour(2, 1002)), 10)
    check('wipe at the middle: A left of it, B right of it', bool(ok), (shown(b, 0.3), shown(b, 0.7)))
    b.js("const m = document.getElementById('mode'); m.value = 'single'; m.dispatchEvent(new Event('change'));")

    # a wedge set: its contact sheet heads the grid, each wedge labelled with its value
    sheet = wait_for(lambda: b.js("const d = document.querySelector('#versions .sheet img');"
                                  "return d && d.complete && d.naturalWidth === 128 && d.getAttribute('src')"), 10)
    check('the contact sheet heads the versions grid (%s)' % sheet, sheet == '/files/v003/contact_sheet.png')
    labels = b.js("return [...document.querySelectorAll('#versions .version')].map(d => d.textContent)")
    check('wedges are labelled with their values', any(l.startswith('v003/w01') and 'sim.cfl=0.2' in l for l in labels) and
          any(l.startswith('v003/w02') and 'sim.cfl=0.4' in l for l in labels), labels)

    # stats: the plots have the records; a click on the right end jumps to the last frame
    ok = wait_for(lambda: b.js("return document.getElementById('plot0')._frameAt !== undefined"), 10)
    check('the substeps plot has the frame records', bool(ok))
    w = b.js("return document.getElementById('plot0').getBoundingClientRect().width")
    b.click_at('#plot0', w / 2 - 5, 0)
    check('a click at the plot\'s right end jumps to frame 1008', bool(wait_for(lambda: shown(b)[0] == 1008, 5)), shown(b))
    titles = b.js("return [...document.querySelectorAll('#stats .plot span')].map(s => s.textContent)")
    i = titles.index('thin: crossings') if 'thin: crossings' in titles else -1
    check('the thin-body audit is plotted (%s)' % titles, i >= 0 and 'thin: deepest, cells' in titles)
    if i >= 0:
        lay = b.js("const r = document.getElementById('plot%d').getBoundingClientRect(); return [r.left, r.right];" % i)
        check('... on screen at 1280x720 (%s)' % lay, lay[0] >= 0 and lay[1] <= 1280 - 380)
        w = b.js("return document.getElementById('plot%d').getBoundingClientRect().width" % i)
        b.click_at('#plot%d' % i, -w / 2 + 4 + (w - 8) * 3 / 6, 0)  # 1005: the third of six steps from 1002
        check('... and a click on its peak jumps to frame 1005', bool(wait_for(lambda: shown(b)[0] == 1005, 5)), shown(b))

    # turntables play the same way
    b.js("const s = document.getElementById('seqA'); s.value = [...s.options].find(o => o.value.includes('turntable')).value;"
         "s.dispatchEvent(new Event('change'));")
    ok = wait_for(lambda: shown(b)[0] == 3 and close_to(shown(b)[1], colour(3, 3)), 10)
    check('a turntable shows the view nearest the frame before (its last, 3)', bool(ok), shown(b))
    b.keys('\uE011')
    ok = wait_for(lambda: shown(b)[0] == 0 and close_to(shown(b)[1], colour(3, 0)), 5)
    check('... Home: its first view', bool(ok), shown(b))
    b.keys('\uE014')
    ok = wait_for(lambda: shown(b)[0] == 1 and close_to(shown(b)[1], colour(3, 1)), 5)
    check('... and steps to its second', bool(ok), shown(b))

    # live: a run (this process stands in for it) writes a new frame and its progress
    b.js("const s = document.getElementById('seqA'); s.value = [...s.options].find(o => o.value.startsWith('v001/images')).value;"
         "s.dispatchEvent(new Event('change'));")
    png(os.path.join(root, 'v001/images/shot.1009.png'), 64, 36, colour(1, 1009))
    with open(os.path.join(root, 'v001/run.json'), 'w') as f:
        json.dump({'pid': os.getpid(), 'stage': 'sim', 'frame': 1009, 'first': 1001, 'last': 1010, 'done': 8, 'todo': 9,
                   'eta_s': 65.0}, f)
    want = 'v001: simulating frame 1009 (8/9), ETA 1m05s'
    got = wait_for(lambda: b.js("return document.getElementById('status').textContent") == want, 10)
    check('live: the run\'s progress and ETA are shown (%r)' % want, bool(got),
          b.js("return document.getElementById('status').textContent"))
    b.keys('\uE010')  # End
    ok = wait_for(lambda: shown(b)[0] == 1009 and close_to(shown(b)[1], colour(1, 1009)), 10)
    check('live: the frame written meanwhile (1009) plays', bool(ok), shown(b))


def browser_tweak(b, port, work):
    b.go('http://127.0.0.1:%d/' % port)
    ok = wait_for(lambda: b.js("return !!document.getElementById('key-sim.cfl')"), 30)
    check('the tweak panel lists sim.cfl', bool(ok))
    b.type('#key-sim\\.cfl', '5\n')
    want = 'error: sim.cfl must be in (0, 2], got 5'
    err = wait_for(lambda: b.js("return document.getElementById('err-sim.cfl').textContent") == want and want, 20)
    err = err or b.js("return document.getElementById('err-sim.cfl').textContent")
    check('an invalid value shows kerf\'s error at the key (%r)' % err, err == 'error: sim.cfl must be in (0, 2], got 5')
    check('... and re-run stays disabled', b.js("return document.getElementById('rerun').disabled") is True)
    b.type('#key-sim\\.cfl', '0.3\n')
    ok = wait_for(lambda: b.js("return !document.getElementById('rerun').disabled && "
                               "document.getElementById('err-sim.cfl').textContent === ''"), 20)
    check('a valid value clears the error and allows a re-run', bool(ok))
    kid = 'colliders\\.post\\.keys\\.1\\.translate'
    b.js("document.getElementById('key-colliders.post.keys.1.translate').closest('details').querySelector('summary').click()")
    b.type('#key-' + kid, '[0, 0.1]\n')
    err = wait_for(lambda: b.js("return document.getElementById('err-colliders.post.keys.1.translate').textContent"), 20)
    check('a keyframe edited to two numbers: the error at that key (%r)' % err,
          bool(err) and err.startswith('error: colliders[0].keys[1].translate') and
          b.js("return document.getElementById('rerun').disabled") is True)
    b.type('#key-' + kid, '[0, 0.05, 0]\n')
    ok = wait_for(lambda: b.js("return !document.getElementById('rerun').disabled && "
                               "document.getElementById('err-colliders.post.keys.1.translate').textContent === ''"), 20)
    check('... and a valid keyframe clears it', bool(ok))
    before = b.js("return document.querySelectorAll('#versions .version').length")
    b.click('#rerun')
    # the new version appears in the grid, then its frames
    card = wait_for(lambda: b.js("return [...document.querySelectorAll('#versions .version')]"
                                 ".some(d => d.textContent.includes('v002'))"), 30)
    check('the new version v002 appears in the grid (had %d)' % before, bool(card))
    done = wait_for(lambda: b.js("return [...document.querySelectorAll('#versions .version')]"
                                 ".some(d => d.textContent.startsWith('v002') && d.querySelector('img') && "
                                 "d.textContent.includes('sim.cfl=0.3') && !d.textContent.includes('stopped'))")
                    and os.path.exists(os.path.join(work, 'tiny/v002/run.json'))
                    and json.load(open(os.path.join(work, 'tiny/v002/run.json')))['stage'] == 'done', 240, 0.5)
    check('... with its frames and its edit as a label, the run done', bool(done))
    imgs = sorted(f for f in os.listdir(os.path.join(work, 'tiny/v002/images')) if f.endswith('.png')) if done else []
    check('v002 has the preview frames 1001-1003 (%s)' % imgs, imgs == ['tiny.%d.png' % f for f in (1001, 1002, 1003)])
    log = open(os.path.join(work, 'tiny/v002/view.log')).read() if done else ''
    check('the run was the edit at preview quality (its log: v002, dx 0.1 m: twice the shot\'s 0.05)',
          'tiny v002' in log and 'dx 0.1 m' in log,
          log[:300])


def main():
    if not shutil.which('chromedriver'):
        print('SKIP: chromedriver is not installed (tools/setup.sh installs chromium and chromium-driver)')
        return 77
    work = tempfile.mkdtemp(prefix='kerf_view.')
    b = None
    try:
        # an output root with two versions, records and a turntable; a secret beside it
        root = os.path.join(work, 'synthetic')
        for f in range(1001, 1009):
            png(os.path.join(root, 'v001/images/shot.%d.png' % f), 64, 36, colour(1, f))
            png(os.path.join(root, 'v002/images/shot.%d.png' % f), 64, 36, colour(2, f))
        for k in range(4):
            png(os.path.join(root, 'v001/turntable/shot.f1004.%04d.png' % k), 64, 36, colour(3, k))
        with open(os.path.join(root, 'v001/frames.jsonl'), 'w') as fr:
            for f in range(1002, 1009):
                fr.write(json.dumps({'frame': f, 'substeps': f - 1000, 'max_cfl': 0.4, 'ms': 1.0, 'retries': 0,
                                     'warnings': 0, 'thin_caught': 0, 'thin_deepest': 0,
                                     'thin_across': 7 if f == 1005 else 0, 'thin_across_deepest': 0.5 if f == 1005 else 0,
                                     'ms_stage': {k: 0.1 for k in
                                     ('sort', 'p2g', 'grid', 'g2p', 'stress', 'cdf', 'rigid')}}) + '\n')
            fr.write('{"frame": 1009, "subst')  # a line cut short by a kill
        # a wedge set as kerf run --wedge leaves it: w01, w02, their labels, the contact sheet
        for k in (1, 2):
            png(os.path.join(root, 'v003/w%02d/images/shot.1001.png' % k), 64, 36, colour(3 + k, 1001))
        with open(os.path.join(root, 'v003/wedges.txt'), 'w') as f:
            f.write('w01\tsim.cfl=0.2\t--set sim.cfl=0.2\nw02\tsim.cfl=0.4\t--set sim.cfl=0.4\n')
        png(os.path.join(root, 'v003/contact_sheet.png'), 128, 72, (200, 200, 200))
        with open(os.path.join(root, 'v002/run.json'), 'w') as f:
            json.dump({'pid': 0, 'shot': 'shot', 'stage': 'done', 'frame': 1008, 'first': 1001, 'last': 1008,
                       'fps': 30, 'done': 7, 'todo': 7, 'eta_s': 0}, f)
        with open(os.path.join(work, 'outside.txt'), 'w') as f:
            f.write('secret\n')
        os.symlink(os.path.join(work, 'outside.txt'), os.path.join(root, 'v001/leak.png'))
        os.symlink('/etc', os.path.join(root, 'v001/etc'))
        os.symlink('images/shot.1001.png', os.path.join(root, 'v001/inside.png'))
        os.mkfifo(os.path.join(root, 'v001/fifo.png'))
        http_tests(work)

        # a small real shot, run once at preview quality (v001), viewed as a shot
        shot = open(os.path.join(TESTS, 'cli/tiny.yaml')).read().replace('end: 1012', 'end: 1003')
        shot += ('colliders:\n  - {name: post, shape: box, center: [0.9, 0.4, 0.9], size: [0.06, 0.2, 0.06],\n'
                 '     keys: [{frame: 1001}, {frame: 1003, translate: [0, 0.1, 0]}]}\n'
                 'render: {width: 160, height: 90, camera_keys: [{frame: 1001, eye: [2, 1.5, 2.5], target: [0.5, 0.3, 0.5]},\n'
                 '                                               {frame: 1003, eye: [1.8, 1.4, 2.3], target: [0.5, 0.3, 0.5]}]}\n')
        open(os.path.join(work, 'tiny.yaml'), 'w').write(shot)
        env = dict(os.environ, OMP_NUM_THREADS='1', OMP_WAIT_POLICY='PASSIVE')
        r = subprocess.run([KERF, 'run', 'tiny.yaml', '--quality', 'preview'], cwd=work, env=env,
                           capture_output=True, text=True, timeout=300)
        check('kerf run tiny.yaml (preview) works', r.returncode == 0, r.stderr[-500:])
        recs = [json.loads(l) for l in open(os.path.join(work, 'tiny/v001/frames.jsonl'))]
        check('kerf run writes a record per simulated frame (1002, 1003)', [x['frame'] for x in recs] == [1002, 1003] and
              all(x['substeps'] > 0 and 0 < x['max_cfl'] <= 0.4 + 1e-6 for x in recs), recs)
        check('... with the thin-body audit at each frame\'s end (no bodies: 0 across, 0 deep)',
              all(x.get('thin_across') == 0 and x.get('thin_across_deepest') == 0 for x in recs), recs)
        run = json.load(open(os.path.join(work, 'tiny/v001/run.json')))
        check('... and run.json says done, frames 1001-1003 of tiny at 24 fps', run['stage'] == 'done' and
              run['first'] == 1001 and run['last'] == 1003 and run['shot'] == 'tiny' and run['fps'] == 24, run)

        p, port = start_view('tiny.yaml', work)
        token_tests(work, port)

        b = Browser(work)
        p2, port2 = start_view(root, work)
        browser_flipbook(b, port2, root)
        browser_tweak(b, port, work)

        # stopping the view stops the run it started (the run can be resumed)
        st, data = request(port, 'POST', '/api/run', b'frames.end=1012', {'X-Kerf-Token': token_of(port)})
        child = json.loads(data).get('pid', 0)
        ok = wait_for(lambda: os.path.exists(os.path.join(work, 'tiny/v003/run.json')), 60, 0.2)
        p.send_signal(signal.SIGTERM)
        check('SIGTERM during a run: kerf view exits 0', p.wait(timeout=30) == 0)
        def gone():
            try:
                os.kill(child, 0)
                return False
            except ProcessLookupError:
                return True
        check('... and the run it started (pid %d) is stopped' % child, st == 200 and bool(ok) and child > 0 and
              bool(wait_for(gone, 10)))
    except Exception as e:  # a broken harness is a failure too, said plainly
        check('the test ran to its end', False, repr(e))
    finally:
        if b:
            b.close()
        for p in procs:
            if p.poll() is None:
                try:
                    if p.args[0] != KERF:
                        os.killpg(p.pid, signal.SIGKILL)  # chromedriver and the browser it started
                    else:
                        p.send_signal(signal.SIGTERM)
                    p.wait(timeout=20)
                except Exception:
                    p.kill()
        shutil.rmtree(work, ignore_errors=True)
    print('%d failed' % fails)
    return 1 if fails else 0


if __name__ == '__main__':
    sys.exit(main())
