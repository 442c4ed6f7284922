// view.js — kerf view's page: the flipbook, live progress, frame-record plots
// and the tweak loop. Plain script, no framework; everything it shows comes
// from the kerf process that served it (/api/state, /api/keys, /files/...).
'use strict';

const $ = (id) => document.getElementById(id);
const token = document.querySelector('meta[name="kerf-token"]').content;

// ---- state -----------------------------------------------------------------
const S = {
  state: null,        // the last /api/state
  seqs: new Map(),    // id -> sequence {dir, out, kind, prefix, frames, names}
  a: null, b: null,   // sequence ids shown
  frame: 0,           // the current frame number
  playing: false,
  last: 0,            // time of the last frame step while playing
  wipe: 0.5,          // wipe position, 0..1 of the picture's width
  images: new Map(),  // url -> Image
  records: new Map(), // output dir -> {frame -> record}
  recordsAt: new Map(), // output dir -> when fetched
  keys: [],           // /api/keys
  edits: new Map(),   // path -> value text
  checkSeq: 0,
};

const seqId = (s) => s.dir + '|' + s.prefix;
const fileUrl = (rel) => '/files/' + rel.split('/').map(encodeURIComponent).join('/');

function seqLabel(s) {
  const where = s.out || '(root)';
  if (s.kind === 'turntable') {
    const m = /f(\d+)\.$/.exec(s.prefix);
    return where + ' turntable' + (m ? ' of ' + m[1] : '');
  }
  return where + (s.dir.endsWith('images') ? '' : ' ' + s.dir.split('/').pop());
}

function image(url) {
  let im = S.images.get(url);
  if (!im) {
    im = new Image();
    im.decoding = 'async';
    im.src = url;
    S.images.set(url, im);
  }
  return im;
}

// the file of a sequence's frame (the nearest earlier one when missing)
function frameUrl(s, frame) {
  if (!s || !s.frames.length) return null;
  let i = s.frames.indexOf(frame);
  if (i < 0) {
    i = 0;
    while (i + 1 < s.frames.length && s.frames[i + 1] <= frame) i++;
  }
  return fileUrl((s.dir ? s.dir + '/' : '') + s.names[i]);
}

// ---- drawing ---------------------------------------------------------------
function fit(im, x, y, w, h) {
  const k = Math.min(w / im.naturalWidth, h / im.naturalHeight);
  const dw = im.naturalWidth * k, dh = im.naturalHeight * k;
  return [x + (w - dw) / 2, y + (h - dh) / 2, dw, dh];
}

function draw() {
  const cv = $('view');
  const r = cv.getBoundingClientRect();
  if (cv.width !== Math.round(r.width) || cv.height !== Math.round(r.height)) {
    cv.width = Math.max(1, Math.round(r.width));
    cv.height = Math.max(1, Math.round(r.height));
  }
  const g = cv.getContext('2d');
  const A = S.seqs.get(S.a), B = S.seqs.get(S.b), mode = $('mode').value;
  const ia = A && image(frameUrl(A, S.frame)), ib = B && mode !== 'single' && image(frameUrl(B, S.frame));
  const ready = (im) => im && im.complete && im.naturalWidth > 0;
  if (ia && !ready(ia)) return; // keep the last picture until this one has loaded
  if (ib && !ready(ib)) return;
  g.fillStyle = '#111';
  g.fillRect(0, 0, cv.width, cv.height);
  if (!ia) return;
  if (mode === 'side' && ib) {
    const w = cv.width / 2;
    g.drawImage(ia, ...fit(ia, 0, 0, w - 2, cv.height));
    g.drawImage(ib, ...fit(ib, w + 2, 0, w - 2, cv.height));
  } else if (mode === 'wipe' && ib) {
    const box = fit(ia, 0, 0, cv.width, cv.height);
    g.drawImage(ia, ...box);
    const x = box[0] + box[2] * S.wipe;
    g.save();
    g.beginPath();
    g.rect(x, 0, cv.width - x, cv.height);
    g.clip();
    g.drawImage(ib, ...fit(ib, 0, 0, cv.width, cv.height));
    g.restore();
    g.fillStyle = '#fff';
    g.fillRect(x - 1, box[1], 2, box[3]);
  } else {
    g.drawImage(ia, ...fit(ia, 0, 0, cv.width, cv.height));
  }
  cv.dataset.frame = String(S.frame); // the frame on screen, for whoever checks
}

// ---- the flipbook ------------------------------------------------------------
function frames() {
  const A = S.seqs.get(S.a);
  return A ? A.frames : [];
}

function setFrame(f) {
  const fr = frames();
  if (!fr.length) return;
  if (fr.indexOf(f) < 0) { // the nearest frame there is
    f = fr.reduce((best, x) => (Math.abs(x - f) < Math.abs(best - f) ? x : best), fr[0]);
  }
  S.frame = f;
  const i = fr.indexOf(f);
  $('scrub').max = String(fr.length - 1);
  $('scrub').value = String(i);
  $('frame').textContent = f + '  (' + (i + 1) + '/' + fr.length + ')';
  $('frame').dataset.frame = String(f);
  draw();
  plotAll();
}

function step(d) {
  const fr = frames();
  if (!fr.length) return false;
  let i = fr.indexOf(S.frame) + d;
  if (i >= fr.length || i < 0) {
    if (!$('loop').checked) return false;
    i = (i + fr.length) % fr.length;
  }
  setFrame(fr[i]);
  return true;
}

function play(on) {
  S.playing = on;
  $('play').textContent = on ? 'pause' : 'play';
  S.last = performance.now();
}

function tick(now) {
  if (S.playing) {
    const dt = 1000 / Math.max(1, Number($('fps').value) || 24);
    // keep time with the shot's rate; wait for a frame that has not loaded yet
    const A = S.seqs.get(S.a);
    const im = A && image(frameUrl(A, S.frame));
    if (now - S.last >= dt && im && im.complete) {
      S.last = now - Math.min(dt, now - S.last - dt);
      if (!step(1)) play(false);
      const fr = frames(), i = fr.indexOf(S.frame); // fetch ahead
      for (let k = 1; k <= 4 && fr.length; k++) image(frameUrl(A, fr[(i + k) % fr.length]));
    }
  }
  requestAnimationFrame(tick);
}

function selectSeqs() {
  S.a = $('seqA').value;
  S.b = $('seqB').value;
  setFrame(S.frame || (frames()[0] ?? 0));
  markVersions();
  loadRecords(true);
}

// ---- live state --------------------------------------------------------------
function fillSelect(sel, current) {
  const ids = [...S.seqs.keys()];
  const old = [...sel.options].map((o) => o.value).join('\n');
  if (old !== ids.join('\n')) {
    sel.innerHTML = '';
    for (const id of ids) sel.add(new Option(seqLabel(S.seqs.get(id)), id));
  }
  if (current && S.seqs.has(current)) sel.value = current;
}

function fmtEta(s) {
  if (!(s >= 0)) return '';
  s = Math.round(s);
  return s >= 3600 ? Math.floor(s / 3600) + 'h' + String(Math.floor(s / 60) % 60).padStart(2, '0') + 'm'
                   : Math.floor(s / 60) + 'm' + String(s % 60).padStart(2, '0') + 's';
}

function outputOf(dir) {
  return (S.state && S.state.outputs.find((o) => o.dir === dir)) || null;
}

function statusText(o) {
  if (!o || !o.run) return '';
  const r = o.run;
  if (r.stage === 'done') return (o.dir || 'root') + ': done, frames ' + r.first + '-' + r.last;
  if (r.stage === 'failed') return (o.dir || 'root') + ': failed (see its view.log or the run\'s output)';
  if (!o.alive) return (o.dir || 'root') + ': stopped at frame ' + r.frame + ' (kerf run --resume continues)';
  const what = r.stage === 'sim' ? 'simulating' : r.stage === 'surface' ? 'surfacing' : 'rendering';
  return (o.dir || 'root') + ': ' + what + ' frame ' + r.frame + ' (' + r.done + '/' + r.todo + ')' +
         (r.eta_s >= 0 ? ', ETA ' + fmtEta(r.eta_s) : '');
}

async function poll() {
  try {
    const st = await (await fetch('/api/state')).json();
    S.state = st;
    $('shot').textContent = st.shot ? st.shot + '  (' + st.root + ')' : st.root;
    // the shot's rate; a directory's from what its run recorded
    const rec = st.outputs.find((o) => o.run && o.run.fps);
    const fps = st.fps || (rec && rec.run.fps);
    if (!$('fps').dataset.set && fps) {
      $('fps').value = String(fps);
      $('fps').dataset.set = '1';
    }
    S.seqs = new Map(st.sequences.map((s) => [seqId(s), s]));
    if (!S.seqs.has(S.a)) S.a = st.sequences.length ? seqId(st.sequences[0]) : null;
    if (!S.seqs.has(S.b)) S.b = st.sequences.length > 1 ? seqId(st.sequences[1]) : S.a;
    fillSelect($('seqA'), S.a);
    fillSelect($('seqB'), S.b);
    if (!frames().includes(S.frame)) setFrame(S.frame || (frames()[0] ?? 0));
    else setFrame(S.frame);
    // progress: the run writing what A shows, else any run still going
    const A = S.seqs.get(S.a);
    let o = A ? outputOf(A.out) : null;
    const going = st.outputs.find((x) => x.alive && x.run && x.run.stage !== 'done' && x.run.stage !== 'failed');
    if (going && !(o && o.alive)) o = going;
    $('status').textContent = statusText(o);
    $('status').className = o && o.run && !o.alive && o.run.stage !== 'done' ? 'stopped' : '';
    versions();
    loadRecords(false);
  } catch (e) {
    $('status').textContent = 'kerf view is not answering';
  }
  setTimeout(poll, 1000);
}

// ---- versions grid -------------------------------------------------------------
function versions() {
  const box = $('versions');
  const st = S.state;
  const main = st.sequences.filter((s) => s.kind === 'frames');
  const html = [];
  const cards = [];
  for (const s of main) {
    const o = outputOf(s.out);
    const mid = s.frames[Math.floor(s.frames.length / 2)];
    const sets = o && o.view && o.view.sets ? o.view.sets.join(' ') : (o && o.wedge) || '';
    const run = o && o.run && o.run.stage !== 'done' ? ' ' + (o.alive ? o.run.stage + ' ' + o.run.frame : 'stopped') : '';
    cards.push({id: seqId(s), url: frameUrl(s, mid), label: (s.out || 'root') + run, sets});
  }
  // runs that have no frames yet show too, so a new version appears at once;
  // one that ended before writing any says how, with its log
  const mine = new Map((st.runs || []).map((r) => [r.dir, r]));
  for (const o of st.outputs) {
    if (main.some((s) => s.out === o.dir)) continue;
    const sets = o.view && o.view.sets ? o.view.sets.join(' ') : o.wedge || '';
    const r = mine.get(o.dir);
    let what = o.run ? (o.alive ? o.run.stage + ' ' + o.run.frame : o.run.stage) : 'starting';
    if (r && !r.running && r.status !== 0) what = 'failed (exit ' + r.status + ')';
    cards.push({id: '', url: '', label: (o.dir || 'root') + ' ' + what, sets, dir: o.dir,
                log: o.view ? fileUrl((o.dir ? o.dir + '/' : '') + 'view.log') : ''});
  }
  const sig = JSON.stringify([cards, st.sheets]);
  if (box.dataset.sig === sig) return markVersions();
  box.dataset.sig = sig;
  box.innerHTML = '';
  // a wedge set's contact sheet first, the width of the grid; a click opens it whole
  for (const sh of st.sheets || []) {
    const d = document.createElement('div');
    d.className = 'version sheet';
    const im = document.createElement('img');
    im.src = fileUrl(sh);
    im.alt = 'contact sheet ' + sh;
    const t = document.createElement('div');
    t.textContent = 'contact sheet: ' + sh;
    d.append(im, t);
    d.addEventListener('click', () => window.open(fileUrl(sh), '_blank'));
    box.appendChild(d);
  }
  for (const c of cards) {
    const d = document.createElement('div');
    d.className = 'version';
    d.dataset.seq = c.id;
    d.dataset.dir = c.dir ?? S.seqs.get(c.id)?.out ?? '';
    if (c.url) {
      const im = document.createElement('img');
      im.src = c.url;
      im.alt = c.label;
      d.appendChild(im);
    }
    const t = document.createElement('div');
    t.textContent = c.label;
    d.appendChild(t);
    if (c.sets) {
      const u = document.createElement('div');
      u.textContent = c.sets;
      u.title = c.sets;
      d.appendChild(u);
    }
    if (c.log) {
      const a = document.createElement('a');
      a.href = c.log;
      a.target = '_blank';
      a.textContent = 'its log';
      d.appendChild(a);
    }
    d.addEventListener('click', (ev) => {
      if (!c.id) return;
      if (ev.shiftKey) {
        $('seqB').value = c.id;
        if ($('mode').value === 'single') $('mode').value = 'side';
      } else $('seqA').value = c.id;
      selectSeqs();
    });
    box.appendChild(d);
  }
  markVersions();
}

function markVersions() {
  for (const d of $('versions').children) {
    d.classList.toggle('a', d.dataset.seq === S.a);
    d.classList.toggle('b', d.dataset.seq === S.b && $('mode').value !== 'single');
  }
}

// ---- frame records and their plots ------------------------------------------------
const PLOTS = [
  {title: 'substeps', get: (r) => [r.substeps]},
  {title: 'max CFL', get: (r) => [r.max_cfl]},
  {title: 'ms per stage', legend: ['p2g', 'grid', 'g2p', 'stress', 'cdf', 'rigid'],
   get: (r) => ['p2g', 'grid', 'g2p', 'stress', 'cdf', 'rigid'].map((k) => (r.ms_stage || {})[k])},
  {title: 'retries, warnings', legend: ['retries', 'warnings'], get: (r) => [r.retries, r.warnings]},
  // thin bodies: crossings the guard caught and put back during the frame, and
  // the audit at its end (particles still on the wrong side of a body)
  {title: 'thin: crossings', legend: ['caught', 'across at end'], get: (r) => [r.thin_caught, r.thin_across]},
  {title: 'thin: deepest, cells', legend: ['caught', 'across at end'],
   get: (r) => [r.thin_deepest, r.thin_across_deepest]},
];
const COLOURS = ['#6fb3ff', '#ffb36f', '#9fd39f', '#e07be0', '#e0e070', '#ff7b72'];

async function loadRecords(force) {
  const A = S.seqs.get(S.a);
  const o = A ? outputOf(A.out) : null;
  if (!o || !o.records) {
    plotAll();
    return;
  }
  const key = o.dir, now = Date.now();
  // a finished run's records do not change; a live one's grow
  if (!force && S.records.has(key) && (!o.alive || now - (S.recordsAt.get(key) || 0) < 2000)) return;
  S.recordsAt.set(key, now);
  try {
    const text = await (await fetch(fileUrl((key ? key + '/' : '') + 'frames.jsonl'))).text();
    const recs = {};
    for (const line of text.split('\n')) {
      try { const r = JSON.parse(line); recs[r.frame] = r; } catch (e) { /* a line cut short by a kill */ }
    }
    S.records.set(key, recs);
  } catch (e) { /* not there yet */ }
  plotAll();
}

function plotAll() {
  const box = $('stats');
  if (!box.children.length) {
    PLOTS.forEach((p, i) => {
      const d = document.createElement('div');
      d.className = 'plot';
      const t = document.createElement('span');
      t.textContent = p.title;
      const cv = document.createElement('canvas');
      cv.id = 'plot' + i;
      cv.addEventListener('click', (ev) => {
        const f = cv._frameAt && cv._frameAt(ev.offsetX);
        if (f !== undefined) {
          play(false);
          setFrame(f);
        }
      });
      d.append(t, cv);
      box.appendChild(d);
    });
  }
  const A = S.seqs.get(S.a);
  const recs = (A && S.records.get(A.out)) || {};
  const fs = Object.keys(recs).map(Number).sort((x, y) => x - y);
  PLOTS.forEach((p, i) => plot($('plot' + i), p, fs, recs));
}

function plot(cv, p, fs, recs) {
  const r = cv.getBoundingClientRect();
  cv.width = Math.max(1, Math.round(r.width));
  cv.height = Math.max(1, Math.round(r.height));
  const g = cv.getContext('2d');
  g.clearRect(0, 0, cv.width, cv.height);
  if (!fs.length) {
    g.fillStyle = '#777';
    g.fillText('no frame records', 6, 14);
    cv._frameAt = undefined;
    return;
  }
  const series = fs.map((f) => p.get(recs[f]).map(Number));
  let top = 0;
  for (const v of series) for (const x of v) if (x > top) top = x;
  const hi = top > 0 ? top * 1.1 : 1;
  const pad = 4, W = cv.width - 2 * pad, H = cv.height - 2 * pad - 10;
  const f0 = fs[0], f1 = fs[fs.length - 1];
  const X = (f) => pad + (f1 > f0 ? (f - f0) / (f1 - f0) : 0.5) * W;
  const Y = (v) => pad + 10 + H - (v / hi) * H;
  // the current frame
  g.fillStyle = '#555';
  g.fillRect(X(S.frame) - 0.5, pad, 1, cv.height - 2 * pad);
  const n = series[0].length;
  for (let k = 0; k < n; k++) {
    g.strokeStyle = g.fillStyle = COLOURS[k % COLOURS.length];
    g.beginPath();
    fs.forEach((f, j) => (j ? g.lineTo(X(f), Y(series[j][k])) : g.moveTo(X(f), Y(series[j][k]))));
    g.stroke();
    if (fs.length <= 200) fs.forEach((f, j) => g.fillRect(X(f) - 1.5, Y(series[j][k]) - 1.5, 3, 3));
  }
  g.fillStyle = '#aaa';
  const cur = recs[S.frame];
  g.fillText('max ' + +top.toPrecision(3) + (cur ? '   ' + S.frame + ': ' + p.get(cur).map((x) => +Number(x).toPrecision(3)).join(' ') : ''), pad, pad + 8);
  // which colour is which
  let lx = pad;
  (p.legend || []).forEach((name, k) => {
    g.fillStyle = COLOURS[k % COLOURS.length];
    g.fillText(name, lx, cv.height - pad);
    lx += g.measureText(name).width + 6;
  });
  cv._frameAt = (x) => fs.reduce((best, f) => (Math.abs(X(f) - x) < Math.abs(X(best) - x) ? f : best), fs[0]);
}

// ---- tweak -------------------------------------------------------------------------
function section(path) {
  const p = path.split('.');
  if (p.length === 1) return 'shot';
  return ['materials', 'objects', 'colliders', 'rigids', 'joints'].includes(p[0]) ? p[0] + '.' + p[1] : p[0];
}

async function loadKeys() {
  const j = await (await fetch('/api/keys')).json();
  S.keys = j.keys.filter((k) => k.applies);
  const box = $('keys');
  box.innerHTML = '';
  if (!S.state || !S.state.tweak) {
    box.textContent = 'a directory is shown, not a shot: nothing to tweak';
    return;
  }
  const groups = new Map();
  for (const k of S.keys) {
    const s = section(k.path);
    if (!groups.has(s)) groups.set(s, []);
    groups.get(s).push(k);
  }
  for (const [name, keys] of groups) {
    const det = document.createElement('details');
    if (name === 'sim' || name.startsWith('materials')) det.open = true;
    const sum = document.createElement('summary');
    sum.textContent = name;
    det.appendChild(sum);
    for (const k of keys) det.appendChild(keyRow(k));
    box.appendChild(det);
  }
}

function keyRow(k) {
  const row = document.createElement('div');
  row.className = 'key' + (k.editable ? '' : ' fixed');
  row.dataset.path = k.path;
  const label = document.createElement('label');
  label.textContent = k.path.includes('.') ? k.path.slice(section(k.path).length + 1) : k.path;
  label.title = k.path;
  row.appendChild(label);
  let input;
  if (!k.editable) {
    input = document.createElement('span');
    input.className = 'value';
    input.textContent = k.value;
  } else if (k.type === 'enum' || k.type === 'bool') {
    input = document.createElement('select');
    for (const c of k.type === 'bool' ? ['true', 'false'] : k.choices.split('|')) input.add(new Option(c, c));
    input.value = k.value;
  } else {
    input = document.createElement('input');
    input.value = k.value;
    input.placeholder = k.default || '';  // empty: the default (often computed) applies
    input.spellcheck = false;
  }
  input.id = 'key-' + k.path;
  input.title = k.doc || '';
  row.appendChild(input);
  const meta = document.createElement('div');
  meta.className = 'meta';
  meta.textContent = [k.unit, k.bounds, k.type === 'integer' && k.choices ? 'one of ' + k.choices.split('|').join(', ') : '',
                      k.default ? 'default ' + k.default : ''].filter(Boolean).join(' · ');
  row.appendChild(meta);
  const doc = document.createElement('div');
  doc.className = 'doc';
  doc.textContent = k.doc || '';
  row.appendChild(doc);
  const err = document.createElement('div');
  err.className = 'err';
  err.id = 'err-' + k.path;
  row.appendChild(err);
  if (k.editable) {
    const changed = () => {
      const v = input.value.trim();
      if (v === k.value) S.edits.delete(k.path);
      else S.edits.set(k.path, v);
      row.classList.toggle('edited', S.edits.has(k.path));
      check();
    };
    input.addEventListener('change', changed);
    input.addEventListener('keydown', (ev) => { if (ev.key === 'Enter') changed(); });
  }
  return row;
}

function editLines() {
  return [...S.edits].map(([p, v]) => p + '=' + v);
}

function showErrors(res, lines) {
  for (const e of document.querySelectorAll('.key .err')) e.textContent = '';
  const general = [];
  for (const e of res.errors || []) {
    const text = e.severity + ': ' + e.message;
    const path = e.set >= 0 && e.set < lines.length ? lines[e.set].split('=')[0] : null;
    const box = path && document.getElementById('err-' + path);
    if (box) box.textContent += (box.textContent ? '\n' : '') + text;
    else general.push(e.where + ': ' + text);
  }
  $('tweakmsg').textContent = general.join('; ');
}

async function post(url, lines) {
  const r = await fetch(url, {method: 'POST', headers: {'X-Kerf-Token': token, 'Content-Type': 'text/plain'},
                              body: lines.join('\n')});
  let j = {};
  try { j = await r.json(); } catch (e) { j = {ok: false, errors: [{set: -1, severity: 'error', where: '', message: 'HTTP ' + r.status}]}; }
  return [r.status, j];
}

async function check() {
  const lines = editLines(), seq = ++S.checkSeq;
  $('revert').disabled = !lines.length;
  if (!lines.length) {
    showErrors({errors: []}, lines);
    $('rerun').disabled = true;
    return;
  }
  const [, res] = await post('/api/check', lines);
  if (seq !== S.checkSeq) return; // a later edit's answer matters, not this one
  showErrors(res, lines);
  $('rerun').disabled = !res.ok;
  if (res.ok) $('tweakmsg').textContent = lines.length + ' edit' + (lines.length > 1 ? 's' : '') + ' valid';
}

async function rerun() {
  const lines = editLines();
  $('rerun').disabled = true;
  const [status, res] = await post('/api/run', lines);
  if (status !== 200) {
    showErrors(res, lines);
    return;
  }
  $('tweakmsg').textContent = 'started ' + res.dir + ' (preview)';
}

function revert() {
  S.edits.clear();
  loadKeys().then(check);
}

// ---- input -------------------------------------------------------------------------
function keyboard(ev) {
  const t = ev.target.tagName;
  if (t === 'INPUT' || t === 'SELECT' || t === 'TEXTAREA') return;
  const fr = frames();
  if (ev.key === ' ') play(!S.playing);
  else if (ev.key === 'ArrowRight') { play(false); step(1); }
  else if (ev.key === 'ArrowLeft') { play(false); step(-1); }
  else if (ev.key === 'Home' && fr.length) { play(false); setFrame(fr[0]); }
  else if (ev.key === 'End' && fr.length) { play(false); setFrame(fr[fr.length - 1]); }
  else return;
  ev.preventDefault();
}

function wire() {
  $('play').addEventListener('click', () => play(!S.playing));
  $('next').addEventListener('click', () => { play(false); step(1); });
  $('prev').addEventListener('click', () => { play(false); step(-1); });
  $('first').addEventListener('click', () => { play(false); setFrame(frames()[0]); });
  $('last').addEventListener('click', () => { play(false); setFrame(frames()[frames().length - 1]); });
  $('scrub').addEventListener('input', () => { play(false); setFrame(frames()[Number($('scrub').value)]); });
  $('seqA').addEventListener('change', selectSeqs);
  $('seqB').addEventListener('change', selectSeqs);
  $('mode').addEventListener('change', () => { draw(); markVersions(); });
  $('rerun').addEventListener('click', rerun);
  $('revert').addEventListener('click', revert);
  const wipeAt = (ev) => {
    const cv = $('view');
    const A = S.seqs.get(S.a), ia = A && image(frameUrl(A, S.frame));
    if (!ia || !ia.naturalWidth) return;
    const box = fit(ia, 0, 0, cv.width, cv.height);
    S.wipe = Math.min(1, Math.max(0, (ev.offsetX * cv.width / cv.clientWidth - box[0]) / box[2]));
    draw();
  };
  $('view').addEventListener('mousemove', (ev) => { if (ev.buttons & 1 && $('mode').value === 'wipe') wipeAt(ev); });
  $('view').addEventListener('mousedown', (ev) => { if ($('mode').value === 'wipe') wipeAt(ev); });
  document.addEventListener('keydown', keyboard);
  // a clicked button lets go of the focus, so Space plays instead of pressing it again
  for (const bt of document.querySelectorAll('#transport button')) bt.addEventListener('click', () => bt.blur());
  window.addEventListener('resize', () => { draw(); plotAll(); });
}

wire();
poll().then(loadKeys);
requestAnimationFrame(tick);
