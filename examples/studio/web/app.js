// ss_studio's page: the live view (frames long-polled from /api/frame as JPEG bytes, the
// tracks drawn over them), the event log and plot, and the calibration workflow. Plain
// JavaScript, no library.
'use strict';

// The token (a non-loopback ss_studio prints it) comes in the page's address and goes with
// every request; requests that change state carry X-Studio: 1 (ss_studio refuses them without).
const token = new URLSearchParams(location.search).get('token') || '';
async function api(method, path) {
  const headers = { 'X-Studio': '1' };
  if (token) headers['X-Studio-Token'] = token;
  const res = await fetch(path, { method, headers, cache: 'no-store' });
  const type = res.headers.get('Content-Type') || '';
  const body = type.startsWith('application/json') ? await res.json() : await res.blob();
  if (!res.ok) throw new Error((body && body.error) || `${method} ${path}: ${res.status}`);
  return body;
}
const $ = (id) => document.getElementById(id);
function setStatus(text, bad) {
  $('status').textContent = text;
  $('status').classList.toggle('bad', !!bad);
}

// ---------------------------------------------------------------- tabs
let tab = 'live';
for (const b of document.querySelectorAll('.tab')) {
  b.addEventListener('click', () => showTab(b.dataset.tab));
}
function showTab(name) {
  tab = name;
  for (const b of document.querySelectorAll('.tab')) b.classList.toggle('active', b.dataset.tab === name);
  for (const p of document.querySelectorAll('.panel')) p.classList.toggle('active', p.id === name);
  if (name === 'calib') refreshCalib();
}

// ---------------------------------------------------------------- live view
// The colour of the track boxes drawn by the page (the browser test looks for it).
const OVERLAY = '#00ff66';
const PALETTE = ['#ff6b6b', '#4dabf7', '#ffd43b', '#b197fc', '#63e6be', '#ffa94d'];
// shown: frames drawn; latencies: ms from the server reading the frame to the page drawing it
// (delivery: from the server publishing it, encoded, to the page drawing it);
// times: when the last frames were drawn (the shown frame rate); skipped: frames the server
// published that the page never drew (it asked or drew too late); stage_sum: the server's stage
// milliseconds summed over the frames received.
const stats = { shown: 0, received: 0, skipped: 0, overlay_frames: 0, latencies: [], delivery: [], times: [], stage_sum: {}, last: null, paused: false };
window.studioStats = stats; // read by the browser test and the measurement
const history = new Map(); // track id -> [{t, area, hover}]

function percentile(sorted, q) { return sorted.length ? sorted[Math.floor(q * (sorted.length - 1))] : 0; }
function latencySummary() {
  const l = stats.latencies.slice().sort((a, b) => a - b);
  return { p50: percentile(l, 0.5), p90: percentile(l, 0.9) };
}
function shownFps() {
  const t = stats.times;
  return t.length > 1 ? (1000 * (t.length - 1)) / (t[t.length - 1] - t[0]) : 0;
}

function drawFrame(f, bitmap) {
  const c = $('live-canvas');
  if (c.width !== f.width || c.height !== f.height) { c.width = f.width; c.height = f.height; }
  const g = c.getContext('2d');
  g.drawImage(bitmap, 0, 0);
  g.lineWidth = 2;
  g.font = '13px sans-serif';
  for (const t of f.tracks) {
    const [x, y, w, h] = t.box;
    g.strokeStyle = OVERLAY;
    g.strokeRect(x + 1, y + 1, Math.max(w - 2, 1), Math.max(h - 2, 1));
    const label = `${t.id} ${t.state}` + (t.hover_cm != null ? ` ${t.hover_cm.toFixed(1)} cm` : '');
    g.fillStyle = '#000';
    g.fillRect(x, Math.max(y - 16, 0), g.measureText(label).width + 6, 16);
    g.fillStyle = OVERLAY;
    g.fillText(label, x + 3, Math.max(y - 4, 12));
    if (t.contact) {
      g.beginPath();
      g.arc(t.contact[0], t.contact[1], 5, 0, 2 * Math.PI);
      g.stroke();
    }
  }
  const now = Date.now();
  stats.shown++;
  if (f.tracks.length) stats.overlay_frames++;
  stats.latencies.push(now - f.read_epoch_ms);
  stats.times.push(now);
  while (stats.latencies.length > 300) stats.latencies.shift();
  while (stats.times.length && now - stats.times[0] > 2000) stats.times.shift();
  stats.last = { frame: f.frame, name: f.name, tracks: f.tracks.length };
}

const STAGES = [['read', 'read'], ['segment', 'segment'], ['track', 'blobs · track · touch'],
  ['classify', 'classify'], ['draw', 'draw'], ['encode', 'encode']];
// The speed table and the plot (a few times a second: they are read, not watched).
function showInfo(f) {
  const lat = latencySummary();
  const rows = [
    ['shown', stats.paused ? 'paused' : `${shownFps().toFixed(1)} fps`],
    ['processed', stats.paused ? `paused (input ${f.input_fps.toFixed(1)} fps)` : `${f.processed_fps.toFixed(1)} fps (input ${f.input_fps.toFixed(1)})`],
    ['frame to screen', `${lat.p50.toFixed(0)} ms median, ${lat.p90.toFixed(0)} ms p90`],
    ...STAGES.map(([k, name]) => [name, `${f.stage_ms[k].toFixed(1)} ms`]),
    ['calibration', f.calibrated ? (lastCalibration || 'from the command line') : 'none yet (Calibrate tab)'],
  ];
  $('speed').innerHTML = '';
  for (const [k, v] of rows) {
    const tr = $('speed').insertRow();
    tr.insertCell().textContent = k;
    tr.insertCell().textContent = v;
  }
  drawPlot(f.t_ms);
}
// The tracks and the gesture of the frame drawn (every frame: they name what the canvas shows).
function showTracks(f) {
  const tb = $('tracks').tBodies[0];
  tb.innerHTML = '';
  for (const t of f.tracks) {
    const tr = tb.insertRow();
    tr.insertCell().textContent = t.id;
    tr.insertCell().textContent = t.state;
    tr.insertCell().textContent = Math.round(t.contact_area);
    tr.insertCell().textContent = t.hover_cm != null ? `${t.hover_cm.toFixed(1)} cm` : t.opacity != null ? `opacity ${t.opacity.toFixed(2)}` : '–';
  }
  const gs = f.gesture;
  $('gesture').textContent = gs.label ? `${gs.label} ${(100 * gs.confidence).toFixed(0)}%` + (f.touch_gestures.length ? ' · ' + f.touch_gestures.join(', ') : '') : (f.classifier ? 'no shadow' : 'no model (touch events only)');
  const pb = $('probabilities');
  pb.innerHTML = '';
  if (gs.classes) {
    gs.classes.forEach((name, i) => {
      const d = document.createElement('div');
      d.className = 'bar';
      d.style.width = `${Math.max(2, 100 * gs.probabilities[i])}%`;
      d.textContent = `${name} ${(100 * gs.probabilities[i]).toFixed(0)}%`;
      pb.appendChild(d);
    });
  }
}
function addHistory(f) {
  for (const t of f.tracks) {
    if (!history.has(t.id)) history.set(t.id, []);
    const hover = t.hover_cm != null ? t.hover_cm : t.opacity != null ? 10 * t.opacity : null;
    history.get(t.id).push({ t: f.t_ms, area: t.contact_area, hover });
  }
}

function drawPlot(now) {
  const c = $('plot');
  const g = c.getContext('2d');
  g.clearRect(0, 0, c.width, c.height);
  const span = 10000;
  let maxArea = 100, maxHover = 10;
  for (const [id, h] of history) {
    while (h.length && (h[0].t < now - span || h[0].t > now)) h.shift();
    if (!h.length) { history.delete(id); continue; }
    for (const p of h) { maxArea = Math.max(maxArea, p.area); if (p.hover != null) maxHover = Math.max(maxHover, p.hover); }
  }
  const X = (t) => c.width * (1 - (now - t) / span);
  let row = 0; // the legend: one line per track in the plot
  for (const [id, h] of history) {
    const colour = PALETTE[id % PALETTE.length];
    g.strokeStyle = colour;
    g.setLineDash([]);
    g.beginPath();
    h.forEach((p, i) => { const y = c.height - 4 - (c.height - 8) * p.area / maxArea; i ? g.lineTo(X(p.t), y) : g.moveTo(X(p.t), y); });
    g.stroke();
    g.setLineDash([4, 3]);
    g.beginPath();
    let open = false;
    for (const p of h) {
      if (p.hover == null) { open = false; continue; }
      const y = c.height - 4 - (c.height - 8) * p.hover / maxHover;
      open ? g.lineTo(X(p.t), y) : g.moveTo(X(p.t), y);
      open = true;
    }
    g.stroke();
    g.setLineDash([]);
    g.fillStyle = colour;
    g.fillText(`track ${id}`, 4, 12 + 12 * row++);
  }
  g.fillStyle = '#9aa5b1';
  g.fillText(`${Math.round(maxArea)} px`, c.width - 60, 12);
}

// The event log: lines are kept as they come and shown with the speed table (re-laying out
// 200 lines of JSON on every frame lowered the frames the page could show).
const eventLines = [];
let eventsShown = true;
function addEvents(lines) {
  for (const e of lines) eventLines.push(JSON.stringify(e));
  while (eventLines.length > 200) eventLines.shift();
  if (lines.length) eventsShown = false;
}
function showEvents() {
  if (eventsShown) return;
  eventsShown = true;
  const pre = $('events');
  pre.textContent = eventLines.join('\n');
  pre.scrollTop = pre.scrollHeight;
}

let lastCalibration = '';
let shownSeq = 0; // the frame the page shows: the one a recording takes

// One long-polled frame: /api/frame is a 4-byte big-endian length, the JSON of /api/live, then
// the frame's JPEG (r.jpeg, a Blob).
async function fetchFrame(after, eventsAfter) {
  const headers = token ? { 'X-Studio-Token': token } : {};
  const res = await fetch(`/api/frame?after=${after}&events_after=${eventsAfter}`, { headers, cache: 'no-store' });
  if (!res.ok) {
    const body = await res.json().catch(() => null);
    throw new Error((body && body.error) || `GET /api/frame: ${res.status}`);
  }
  const buf = await res.arrayBuffer();
  const n = new DataView(buf).getUint32(0);
  const r = JSON.parse(new TextDecoder().decode(new Uint8Array(buf, 4, n)));
  if (r.frame) r.jpeg = new Blob([new Uint8Array(buf, 4 + n)], { type: 'image/jpeg' });
  return r;
}

// The fetch loop asks for the next frame as soon as the bytes of one are in: decoding
// (createImageBitmap, off the main thread) and drawing overlap the wait for the next frame.
// Decoded frames are taken in order; the newest waits in `pending` for the next animation
// frame, so a page that draws slower than the input shows the newest frame, never a queue.
let pending = null, drawQueued = false, lastInfo = 0;
function present() {
  drawQueued = false;
  const r = pending;
  pending = null;
  if (!r) return;
  shownSeq = r.seq;
  const f = r.frame;
  $('pause').disabled = $('step').disabled = !f.file;
  $('calib-pause').disabled = $('calib-step').disabled = !f.file;
  $('calib-frame').textContent = $('frame-name').textContent = `#${f.frame} ${f.name}`;
  if (tab === 'live') {
    drawFrame(f, r.bitmap);
    showTracks(f);
    stats.delivery.push(Date.now() - r.published_epoch_ms);
    while (stats.delivery.length > 300) stats.delivery.shift();
    const now = performance.now();
    if (now - lastInfo > 200 || r.paused) { showInfo(f); showEvents(); lastInfo = now; }
  }
  r.bitmap.close();
  if (!r.error) setStatus(r.paused ? 'paused' : 'live');
}
function decoded(r) {
  if (pending) { pending.bitmap.close(); stats.skipped++; }
  pending = r;
  if (!drawQueued) { drawQueued = true; requestAnimationFrame(present); }
}
async function liveLoop() {
  let after = 0, eventsAfter = 0, decoding = Promise.resolve();
  for (;;) {
    try {
      const r = await fetchFrame(after, eventsAfter);
      addEvents(r.events);
      eventsAfter = r.events_total;
      lastCalibration = r.calibration;
      stats.paused = r.paused;
      $('pause').textContent = $('calib-pause').textContent = r.paused ? 'Play' : 'Pause';
      if (r.error) setStatus('live view stopped: ' + r.error, true);
      if (r.seq < after) after = 0; // ss_studio was restarted: its frames count from 1 again
      if (r.frame) {
        if (after && r.seq > after + 1) stats.skipped += r.seq - after - 1;
        after = r.seq;
        stats.received++;
        for (const [k, v] of Object.entries(r.frame.stage_ms)) stats.stage_sum[k] = (stats.stage_sum[k] || 0) + v;
        addHistory(r.frame);
        const bitmap = createImageBitmap(r.jpeg);
        decoding = decoding.then(async () => { r.bitmap = await bitmap; decoded(r); }).catch((e) => setStatus(String(e.message || e), true));
      }
    } catch (e) {
      setStatus(String(e.message || e), true);
      await new Promise((res) => setTimeout(res, 500));
    }
  }
}
for (const id of ['pause', 'calib-pause'])
  $(id).addEventListener('click', () => control(stats.paused ? 'play' : 'pause'));
for (const id of ['step', 'calib-step'])
  $(id).addEventListener('click', () => control('step'));
async function control(action) {
  try {
    stats.paused = (await api('POST', `/api/control?action=${action}`)).paused;
    $('pause').textContent = $('calib-pause').textContent = stats.paused ? 'Play' : 'Pause';
  } catch (e) { setStatus(e.message, true); }
}

// ---------------------------------------------------------------- calibration
let calib = { empty: [], touch: [] };
let current = 0;          // index into calib.touch
let currentImage = null;  // the loaded image of calib.touch[current]
let drag = null;          // {x0, y0, x1, y1} while the mouse draws

function mode() { return document.querySelector('input[name=mode]:checked').value; }
function setMode(m) { document.querySelector(`input[name=mode][value=${m}]`).checked = true; }

async function refreshCalib(state) {
  calib = state || await api('GET', '/api/calib');
  $('rec-counts').textContent = `${calib.empty.length} empty · ${calib.touch.length} touch (at most ${calib.max_recorded} each)`;
  current = Math.min(current, Math.max(calib.touch.length - 1, 0));
  const th = $('thumbs');
  th.innerHTML = '';
  calib.touch.forEach((f, i) => {
    const b = document.createElement('button');
    b.textContent = String(i);
    b.title = f.source;
    b.classList.toggle('done', f.labelled);
    b.classList.toggle('current', i === current);
    b.addEventListener('click', () => select(i));
    th.appendChild(b);
  });
  await loadCurrent();
}

async function loadCurrent() {
  const f = calib.touch[current];
  $('label-pos').textContent = f ? `${current + 1} / ${calib.touch.length}` : 'no touch frame';
  if (!f) { currentImage = null; drawLabels(); return; }
  if (!currentImage || currentImage.id !== f.id) {
    const blob = await api('GET', `/api/calib/image?id=${f.id}`);
    const img = await createImageBitmap(blob);
    currentImage = { id: f.id, img };
  }
  drawLabels();
}

function drawLabels() {
  const c = $('label-canvas');
  const g = c.getContext('2d');
  const f = calib.touch[current];
  if (!f || !currentImage) { g.clearRect(0, 0, c.width, c.height); $('label-state').textContent = ''; return; }
  if (c.width !== f.width || c.height !== f.height) { c.width = f.width; c.height = f.height; }
  g.drawImage(currentImage.img, 0, 0);
  g.lineWidth = 2;
  const box = (b, colour) => { if (!b) return; g.strokeStyle = colour; g.strokeRect(b[0] + 1, b[1] + 1, b[2] - 2, b[3] - 2); };
  box(f.shadow, '#4dabf7');
  box(f.contact, '#ff4d4d');
  if (drag) {
    const b = dragBox();
    if (b) box(b, mode() === 'shadow' ? '#a5d8ff' : '#ffa8a8');
  }
  $('label-state').textContent = `${f.source}: ` + (!f.labelled ? 'unlabelled (fitted by clustering)' :
    `shadow ${f.shadow ? f.shadow.join(',') : 'none'} · contact ${f.contact ? f.contact.join(',') : 'none'}`);
}

// Image pixel under the mouse: the canvas may be shown scaled (a phone).
function imagePoint(e) {
  const c = $('label-canvas');
  const r = c.getBoundingClientRect();
  const x = Math.floor(((e.clientX - r.left) * c.width) / r.width);
  const y = Math.floor(((e.clientY - r.top) * c.height) / r.height);
  return [Math.min(Math.max(x, 0), c.width), Math.min(Math.max(y, 0), c.height)];
}
function dragBox() {
  const x = Math.min(drag.x0, drag.x1), y = Math.min(drag.y0, drag.y1);
  const w = Math.abs(drag.x1 - drag.x0), h = Math.abs(drag.y1 - drag.y0);
  return w > 0 && h > 0 ? [x, y, w, h] : null;
}
const labelCanvas = $('label-canvas');
labelCanvas.addEventListener('mousedown', (e) => {
  if (!calib.touch[current]) return;
  const [x, y] = imagePoint(e);
  drag = { x0: x, y0: y, x1: x, y1: y };
  e.preventDefault();
});
window.addEventListener('mousemove', (e) => {
  if (!drag) return;
  [drag.x1, drag.y1] = imagePoint(e);
  drawLabels();
});
window.addEventListener('mouseup', async (e) => {
  if (!drag) return;
  [drag.x1, drag.y1] = imagePoint(e);
  const b = dragBox();
  drag = null;
  const f = calib.touch[current];
  if (!b || !f) { drawLabels(); return; }
  const shadow = mode() === 'shadow' ? b : f.shadow;
  const contact = mode() === 'contact' ? b : (f.labelled ? f.contact : null);
  await label(f, shadow, contact, true);
  if (mode() === 'shadow') setMode('contact');
});

async function label(f, shadow, contact, labelled) {
  const fmt = (b) => (b ? b.join(',') : 'none');
  try {
    await refreshCalib(await api('POST', `/api/calib/label?id=${f.id}&labelled=${labelled ? 1 : 0}&shadow=${fmt(shadow)}&contact=${fmt(contact)}`));
  } catch (e) { setStatus(e.message, true); }
}
async function select(i) {
  if (!calib.touch.length) return;
  current = (i + calib.touch.length) % calib.touch.length;
  setMode('shadow');
  await refreshCalib(calib);
}
async function record(kind) {
  try {
    await refreshCalib(await api('POST', `/api/record?kind=${kind}&seq=${shownSeq}`));
    if (kind === 'touch') await select(calib.touch.length - 1);
    setStatus(`recorded a${kind === 'empty' ? 'n empty-skin' : ' touch'} frame`);
  } catch (e) { setStatus(e.message, true); }
}
$('rec-empty').addEventListener('click', () => record('empty'));
$('rec-touch').addEventListener('click', () => record('touch'));
$('next').addEventListener('click', () => select(current + 1));
$('prev').addEventListener('click', () => select(current - 1));
const noContact = () => { const f = calib.touch[current]; if (f) label(f, f.shadow, null, true); };
const unlabel = () => { const f = calib.touch[current]; if (f) label(f, null, null, false); };
async function remove() {
  const f = calib.touch[current];
  if (f) await refreshCalib(await api('POST', `/api/calib/delete?id=${f.id}`));
}
$('no-contact').addEventListener('click', noContact);
$('unlabel').addEventListener('click', unlabel);
$('delete').addEventListener('click', remove);
document.addEventListener('keydown', (e) => {
  if (tab !== 'calib' || e.target.tagName === 'INPUT' || e.ctrlKey || e.metaKey || e.altKey) return;
  const k = e.key.toLowerCase();
  const actions = {
    n: () => select(current + 1), arrowright: () => select(current + 1),
    p: () => select(current - 1), arrowleft: () => select(current - 1),
    x: noContact, u: unlabel, delete: remove,
    s: () => setMode('shadow'), c: () => setMode('contact'),
    e: () => record('empty'), t: () => record('touch'),
  };
  if (actions[k]) { e.preventDefault(); actions[k](); }
});

$('run-calib').addEventListener('click', async () => {
  $('calib-summary').textContent = 'calibrating…';
  try {
    const r = await api('POST', '/api/calib/run');
    $('calib-summary').textContent = `${r.empty_frames} empty + ${r.touch_frames} touch frames, ` +
      r.groups.map((g) => `luminance ${g.luminance.toFixed(0)}: shadow ${g.shadow_darkness.toFixed(3)}, contact ${g.contact_darkness.toFixed(3)} / warmth ${g.contact_warmth.toFixed(3)}`).join('; ') +
      `; ${r.warnings.length} warning(s)`;
    const tb = $('warnings').tBodies[0];
    tb.innerHTML = '';
    for (const w of r.warnings) {
      const tr = tb.insertRow();
      tr.insertCell().textContent = w.frame;
      tr.insertCell().textContent = w.issue;
      tr.insertCell().textContent = w.message;
    }
    $('preview').src = r.preview;
    setStatus('calibrated; save it to use it');
  } catch (e) {
    $('calib-summary').textContent = e.message;
    setStatus(e.message, true);
  }
});
$('save').addEventListener('click', async () => {
  try {
    const r = await api('POST', `/api/calib/save?name=${encodeURIComponent($('save-name').value)}`);
    $('save-result').textContent = `saved ${r.saved} (frames and labels in ${r.frames}); the live view uses it now`;
    setStatus('saved');
  } catch (e) {
    $('save-result').textContent = e.message;
    setStatus(e.message, true);
  }
});

liveLoop();
