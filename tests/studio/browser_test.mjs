// The browser test of ss_studio (run by .ci/steps/studio_browser.sh): headless Chromium driven
// by playwright-core opens the page on a VIDEO made from a generated gesture dataset
// (video_frames.py: its images in name order, padded to 640x480, MJPG), sees frames advance,
// records empty-skin and touch frames from the video, draws their boxes with the mouse
// (keyboard for previous / next / no contact), calibrates, saves, and checks
//   * the saved file equals ss_calibrate's on the same frames (decoded from the video
//     independently, by OpenCV in Python) and the same boxes (the dataset's), thresholds within
//     1e-6 and the empty-skin model byte for byte; and equals ss_calibrate's on the frames and
//     labels the studio saved beside it (OUT/NAME.frames, for the user to re-run);
//   * the live view draws the track overlay after the switch to the new calibration (pixels of
//     the overlay colour in a screenshot; none before, without a calibration); the frames shown
//     per second, the frame-to-screen latency and the stage times are printed, not asserted;
//   * a second tab sees the same recorded frames;
//   * on a phone-sized screen (390x844) nothing overflows sideways and the main controls show;
//   * a path traversal attempt is refused and writes nothing;
//   * bound to a non-loopback address, a request without the token is refused.
// Usage: node browser_test.mjs --playwright DIR --chromium BIN --studio BIN --calibrate BIN
//        --data DATASET --video VIDEO --work DIR [--python BIN] [--screenshots DIR]
// --measure VIDEO [--measure-calibration FILE] [--measure-model FILE|none] [--measure-seconds S]:
// instead of the test, play VIDEO (ss_studio on one core via taskset) for S seconds (default 10)
// and print the frames shown per second, the frame-to-screen latency and the stage times.
import { spawn, execFileSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import zlib from 'node:zlib';
import { createRequire } from 'node:module';
import { fileURLToPath } from 'node:url';

const args = {};
for (let i = 2; i < process.argv.length; i += 2) args[process.argv[i].slice(2)] = process.argv[i + 1];
for (const k of ['playwright', 'chromium', 'studio', 'work']) {
  if (!args[k]) { console.error(`browser_test: missing --${k}`); process.exit(2); }
}
const { chromium } = createRequire(path.resolve(args.playwright, 'x.js'))('playwright-core');
const OVERLAY = [0, 255, 102]; // app.js OVERLAY, '#00ff66'

let failures = 0;
function check(ok, what) {
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`);
  if (!ok) failures++;
}
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
async function until(what, f, ms = 20000) {
  const end = Date.now() + ms;
  for (;;) {
    const v = await f();
    if (v) return v;
    if (Date.now() > end) throw new Error(`timed out waiting for ${what}`);
    await sleep(50);
  }
}

// ss_studio in the background; resolves with its base URL and token once it listens.
const children = [];
function startStudio(extra, prefix = []) {
  const cmd = prefix.length ? prefix[0] : args.studio;
  const argv = prefix.length ? [...prefix.slice(1), args.studio, ...extra] : extra;
  const p = spawn(cmd, argv, { stdio: ['ignore', 'pipe', 'pipe'] });
  children.push(p);
  let out = '';
  p.stderr.on('data', (d) => process.stderr.write(d));
  return new Promise((resolve, reject) => {
    p.stdout.on('data', (d) => {
      out += d;
      const m = out.match(/at (http:\/\/\S+?:(\d+)\/)(\?token=([0-9a-f]+))?\n/);
      if (m) resolve({ proc: p, port: Number(m[2]), token: m[4] || '' });
    });
    p.on('exit', (code) => reject(new Error(`ss_studio exited with ${code}: ${out}`)));
  });
}
function stopAll() {
  for (const p of children) if (p.exitCode === null) p.kill('SIGTERM');
}

// RGB(A) pixels of a PNG (8-bit, non-interlaced: what Chromium's screenshots are).
function decodePng(buf) {
  let pos = 8, width = 0, height = 0, colourType = 0;
  const idat = [];
  while (pos < buf.length) {
    const len = buf.readUInt32BE(pos);
    const type = buf.toString('ascii', pos + 4, pos + 8);
    const data = buf.subarray(pos + 8, pos + 8 + len);
    if (type === 'IHDR') {
      width = data.readUInt32BE(0); height = data.readUInt32BE(4);
      if (data[8] !== 8 || data[12] !== 0) throw new Error('decodePng: only 8-bit non-interlaced');
      colourType = data[9];
    } else if (type === 'IDAT') idat.push(data);
    pos += 12 + len;
  }
  const bpp = { 2: 3, 6: 4 }[colourType];
  if (!bpp) throw new Error(`decodePng: colour type ${colourType}`);
  const raw = zlib.inflateSync(Buffer.concat(idat));
  const stride = width * bpp, out = Buffer.alloc(stride * height);
  for (let y = 0; y < height; y++) {
    const f = raw[y * (stride + 1)], row = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
    for (let x = 0; x < stride; x++) {
      const a = x >= bpp ? out[y * stride + x - bpp] : 0, b = y ? out[(y - 1) * stride + x] : 0;
      const c = x >= bpp && y ? out[(y - 1) * stride + x - bpp] : 0;
      const p = a + b - c, pa = Math.abs(p - a), pb = Math.abs(p - b), pc = Math.abs(p - c);
      const pred = [0, a, b, (a + b) >> 1, pa <= pb && pa <= pc ? a : pb <= pc ? b : c][f];
      out[y * stride + x] = (row[x] + pred) & 255;
    }
  }
  return { width, height, bpp, data: out };
}
function overlayPixels(png) {
  const img = decodePng(png);
  let n = 0;
  for (let i = 0; i < img.width * img.height; i++) {
    const o = i * img.bpp;
    if (img.data[o] === OVERLAY[0] && img.data[o + 1] === OVERLAY[1] && img.data[o + 2] === OVERLAY[2]) n++;
  }
  return n;
}

// The header lines and the empty-skin bytes of a calibration file (docs/calibration.md).
function readCalibration(file) {
  const buf = fs.readFileSync(file);
  const text = buf.toString('latin1');
  const at = text.indexOf('\nempty_skin ');
  const head = at < 0 ? text : text.slice(0, at + 1);
  const values = {};
  for (const line of head.split('\n')) {
    const parts = line.trim().split(/\s+/);
    if (!parts[0] || parts[0].startsWith('#')) continue;
    (values[parts[0]] = values[parts[0]] || []).push(parts.slice(1));
  }
  let skin = null;
  if (at >= 0) {
    const nl = text.indexOf('\n', at + 1);
    const [, w, h] = text.slice(at + 1, nl).split(' ');
    const n = Number(w) * Number(h) * 3 * 4;
    skin = { header: text.slice(at + 1, nl), bytes: buf.subarray(nl + 1, nl + 1 + n) };
  }
  return { values, skin };
}
function sameCalibration(a, b) {
  const problems = [];
  const keys = new Set([...Object.keys(a.values), ...Object.keys(b.values)]);
  for (const k of keys) {
    const x = a.values[k] || [], y = b.values[k] || [];
    if (x.length !== y.length) { problems.push(`${k}: ${x.length} vs ${y.length} lines`); continue; }
    x.forEach((row, i) => {
      if (row.length !== y[i].length) return problems.push(`${k}: ${row} vs ${y[i]}`);
      row.forEach((v, j) => {
        const nx = Number(v), ny = Number(y[i][j]);
        const equal = Number.isFinite(nx) && Number.isFinite(ny) ? Math.abs(nx - ny) <= 1e-6 : v === y[i][j];
        if (!equal && k !== 'end') problems.push(`${k}: ${row.join(' ')} vs ${y[i].join(' ')}`);
      });
    });
  }
  if (!a.skin || !b.skin) problems.push('an empty-skin model is missing');
  else if (a.skin.header !== b.skin.header || !a.skin.bytes.equals(b.skin.bytes)) problems.push('the empty-skin models differ');
  return problems;
}

// The dataset's boxes by file name (metadata.csv, docs/dataset_format.md).
function readMetadata(dir) {
  const lines = fs.readFileSync(path.join(dir, 'metadata.csv'), 'utf8').trim().split('\n');
  const head = lines[0].split(',');
  const col = (name) => head.indexOf(name);
  const rows = new Map();
  for (const line of lines.slice(1)) {
    const c = line.split(',');
    const box = (p) => (c[col(p + '_x')] === '' ? null : ['x', 'y', 'w', 'h'].map((k) => Number(c[col(`${p}_${k}`)])));
    rows.set(c[col('file_name')], { cls: c[col('class')], shadow: box('shadow'), contact: box('contact') });
  }
  return rows;
}

async function openPage(browser, url) {
  const page = await browser.newPage({ viewport: { width: 1400, height: 1000 } });
  page.on('pageerror', (e) => { console.log(`FAIL page error: ${e.message}`); failures++; });
  await page.goto(url);
  return page;
}
const frameName = (page) => page.$eval('#calib-frame', (e) => e.textContent.replace(/^#\d+ /, ''));

async function stepTo(page, name, button = '#calib-step') {
  for (let k = 0; k < 200; k++) {
    if ((await frameName(page)) === name) return;
    const before = await page.$eval('#calib-frame', (e) => e.textContent);
    await page.click(button);
    await until('a step', async () => (await page.$eval('#calib-frame', (e) => e.textContent)) !== before, 5000).catch(async (e) => {
      throw new Error(`${e.message} from '${before}' to ${name}; the page shows '${await page.$eval('#status', (s) => s.textContent)}'`);
    });
  }
  throw new Error(`never reached frame ${name}`);
}

async function drag(page, box) {
  const r = await page.$eval('#label-canvas', (c) => { const b = c.getBoundingClientRect(); return [b.left, b.top, b.width, c.width]; });
  if (Math.abs(r[2] - r[3]) > 0.01) throw new Error(`the label canvas is shown at ${r[2]} px for ${r[3]} px; the test needs 1:1`);
  const [x, y, w, h] = box;
  // Whole client pixels (the browser may round the mouse's position): the first one whose
  // offset from the canvas's edge is at least the image pixel's.
  const at = (edge, v) => Math.ceil(edge + v - 1e-6);
  await page.mouse.move(at(r[0], x), at(r[1], y));
  await page.mouse.down();
  await page.mouse.move(at(r[0], x + w / 2), at(r[1], y + h / 2), { steps: 4 });
  await page.mouse.move(at(r[0], x + w), at(r[1], y + h), { steps: 2 });
  await page.mouse.up();
}

async function labelState(page) {
  return page.$eval('#label-state', (e) => e.textContent);
}

// Frames shown per second, frame-to-screen latency and the server's frame rate over `ms`.
async function measureLive(page, ms) {
  const start = await page.evaluate(() => { const s = window.studioStats; s.latencies.length = 0; s.delivery.length = 0; return { shown: s.shown, received: s.received, skipped: s.skipped, stage_sum: { ...s.stage_sum }, t: Date.now() }; });
  await sleep(ms);
  return page.evaluate((start) => {
    const s = window.studioStats, l = s.latencies.slice().sort((a, b) => a - b), d = s.delivery.slice().sort((a, b) => a - b);
    const q = (f) => (l.length ? l[Math.floor(f * (l.length - 1))] : NaN);
    const seconds = (Date.now() - start.t) / 1000;
    const rows = Object.fromEntries([...document.querySelectorAll('#speed tr')].map((tr) => [tr.cells[0].textContent, tr.cells[1].textContent]));
    return { shown_fps: (s.shown - start.shown) / seconds, received_fps: (s.received - start.received) / seconds, skipped: s.skipped - start.skipped, p50: q(0.5), p90: q(0.9), n: l.length, delivery_p50: d.length ? d[d.length >> 1] : NaN, rows,
      stages: Object.fromEntries(Object.keys(s.stage_sum).map((k) => [k, (s.stage_sum[k] - (start.stage_sum[k] || 0)) / Math.max(1, s.received - start.received)])) };
  }, start);
}
function printLive(what, m) {
  const stages = [['read', 'read'], ['segment', 'segment'], ['track', 'blobs+track+touch'], ['classify', 'classify'], ['draw', 'draw'], ['encode', 'encode']].map(([k, name]) => `${name} ${(m.stages[k] || 0).toFixed(1)}`).join(', ');
  console.log(`${what}: ${m.shown_fps.toFixed(1)} frames shown per second (${m.received_fps.toFixed(1)} received, ${m.skipped} skipped); frame to screen ${m.p50.toFixed(0)} ms median, ${m.p90.toFixed(0)} ms p90 over ${m.n} frames (publish to screen ${m.delivery_p50.toFixed(0)} ms median); server ${m.rows.processed}; mean ms per frame on the server: ${stages}`);
}

async function measure(browser) {
  const extra = args['measure-calibration'] ? ['--calibration', args['measure-calibration']] : [];
  const s = await startStudio(['--input', args.measure, '--model', args['measure-model'] || 'none', '--port', '0', ...extra], ['taskset', '-c', '0']);
  const page = await openPage(browser, `http://127.0.0.1:${s.port}/`);
  await until('frames', () => page.evaluate(() => window.studioStats.shown > 30));
  printLive(`measure (${args.measure}, ss_studio on one core)`, await measureLive(page, Number(args['measure-seconds'] || 10) * 1000));
}

const frameOfVideo = (k) => `frame_${String(k).padStart(6, '0')}`; // ss_studio's names

// The page at 390x844: no sideways overflow, the main controls on screen, on both tabs.
async function phoneChecks(browser, url) {
  const page = await browser.newPage({ viewport: { width: 390, height: 844 }, deviceScaleFactor: 2, isMobile: true, hasTouch: true });
  page.on('pageerror', (e) => { console.log(`FAIL page error: ${e.message}`); failures++; });
  await page.goto(url);
  await until('frames on the phone', () => page.evaluate(() => window.studioStats.shown > 3));
  await sleep(300); // the tables, drawn a few times a second
  // A mobile browser widens its layout viewport (innerWidth) to content that overflows, so both
  // are held to the phone's width.
  const PHONE = 390;
  const fits = async (ids) => page.evaluate(([ids, PHONE]) => {
    const out = { scroll: document.documentElement.scrollWidth, inner: window.innerWidth, hidden: [] };
    for (const id of ids) {
      const e = document.getElementById(id), r = e.getBoundingClientRect();
      if (!(r.width > 0 && r.height > 0 && r.left >= 0 && r.right <= PHONE + 0.5)) out.hidden.push(`${id} at ${r.left.toFixed(0)}..${r.right.toFixed(0)}`);
    }
    return out;
  }, [ids, PHONE]);
  const ok = (m) => m.scroll <= PHONE && m.inner === PHONE && !m.hidden.length;
  const say = (m) => `scrollWidth ${m.scroll}, innerWidth ${m.inner} (expected <= ${PHONE}, ${PHONE}), main controls on screen${m.hidden.length ? ': not ' + m.hidden.join(', ') : ''}`;
  const live = await fits(['tab-live', 'tab-calib', 'live-canvas', 'pause', 'step', 'speed', 'events']);
  check(ok(live), `phone, live view: ${say(live)}`);
  if (args.screenshots) await page.screenshot({ path: path.join(args.screenshots, 'studio_phone.png') });
  await page.click('#tab-calib');
  const calib = await fits(['calib-pause', 'rec-empty', 'rec-touch', 'prev', 'next', 'no-contact', 'label-canvas', 'run-calib', 'save-name', 'save']);
  check(ok(calib), `phone, calibration screen: ${say(calib)}`);
  await page.close();
}

async function main() {
  const browser = await chromium.launch({ executablePath: args.chromium, headless: true, args: ['--no-sandbox', '--no-proxy-server', '--disable-gpu'] });
  try {
    if (args.measure) return await measure(browser);
    for (const k of ['calibrate', 'data', 'video']) if (!args[k]) throw new Error(`missing --${k}`);
    const python = args.python || 'python3';
    const videoTool = fileURLToPath(new URL('./video_frames.py', import.meta.url));
    const work = args.work, out = path.join(work, 'out');
    fs.rmSync(work, { recursive: true, force: true });
    fs.mkdirSync(work, { recursive: true });
    const meta = readMetadata(args.data);
    const files = [...meta.keys()].sort(); // the video's frames, in order
    const s = await startStudio(['--input', args.video, '--model', 'none', '--out', out, '--port', '0']);
    const base = `http://127.0.0.1:${s.port}`;
    const page = await openPage(browser, base + '/');

    // Frames advance; without a calibration no overlay is drawn.
    const f1 = await until('a frame', () => page.evaluate(() => window.studioStats.last));
    await until('frames advancing', async () => (await page.evaluate(() => window.studioStats.shown)) > 15);
    const f2 = await page.evaluate(() => window.studioStats.last);
    check(f2.frame !== f1.frame, `frames advance (frame ${f1.frame} then ${f2.frame})`);
    const bare = overlayPixels(await page.locator('#live-canvas').screenshot());
    check(bare === 0, `no overlay without a calibration (${bare} overlay pixels)`);
    printLive('live view, no calibration', await measureLive(page, 2000));

    // Record from the video: 4 empty frames, 4 touch frames (the last one "no contact" by X).
    await page.click('#tab-calib');
    await page.click('#calib-pause');
    await until('the pause', () => page.evaluate(() => window.studioStats.paused));
    await sleep(300); // a frame in the making when the pause came is still published
    const empty = files.filter((f) => meta.get(f).cls === 'nothing').slice(0, 4);
    const touch = files.filter((f) => meta.get(f).shadow && meta.get(f).contact).filter((_, i) => i % 3 === 0).slice(0, 4);
    // [kind, dataset file, video frame index], in the video's order (recorded stepping forward)
    const chosen = [...empty.map((f) => ['empty', f]), ...touch.map((f) => ['touch', f])]
      .map(([kind, f]) => [kind, f, files.indexOf(f)]).sort((a, b) => a[2] - b[2]);
    for (const [kind, , k] of chosen) {
      await stepTo(page, frameOfVideo(k));
      const n = (await page.evaluate(() => document.getElementById('rec-counts').textContent)) || '';
      await page.click(kind === 'empty' ? '#rec-empty' : '#rec-touch');
      await until(`recording ${frameOfVideo(k)}`, async () => (await page.$eval('#rec-counts', (e) => e.textContent)) !== n);
    }
    const emptyChosen = chosen.filter((c) => c[0] === 'empty'), touchChosen = chosen.filter((c) => c[0] === 'touch');
    const state = await (await fetch(base + '/api/calib')).json();
    check(state.empty.map((r) => r.source).join() === emptyChosen.map((c) => frameOfVideo(c[2])).join(), 'the empty frames recorded are the ones stepped to');
    check(state.touch.map((r) => r.source).join() === touchChosen.map((c) => frameOfVideo(c[2])).join(), 'the touch frames recorded are the ones stepped to');

    // A second tab sees the same recorded frames.
    const page2 = await openPage(browser, base + '/');
    await page2.click('#tab-calib');
    await until('the second tab', async () => (await page2.$eval('#rec-counts', (e) => e.textContent)).startsWith(`${emptyChosen.length} empty · ${touchChosen.length} touch`));
    check(true, 'a second tab sees the same recorded frames');
    await page2.close();

    // Label with the mouse: go to the first frame with P (wrapping from the last), then N.
    const touchFiles = touchChosen.map((c) => c[1]);
    await page.click('#label-canvas', { position: { x: 1, y: 1 } }); // focus; a 0-size drag draws nothing
    await page.keyboard.press('n'); // from the last touch frame to the first (wraps)
    await until('the first touch frame', async () => (await page.$eval('#label-pos', (e) => e.textContent)).startsWith('1 /'));
    await page.keyboard.press('p');
    await until('previous wraps to the last', async () => (await page.$eval('#label-pos', (e) => e.textContent)).startsWith(`${touchFiles.length} /`));
    await page.keyboard.press('n');
    await until('next wraps to the first', async () => (await page.$eval('#label-pos', (e) => e.textContent)).startsWith('1 /'));
    for (let i = 0; i < touchFiles.length; i++) {
      const m = meta.get(touchFiles[i]), source = frameOfVideo(touchChosen[i][2]);
      await until(`touch frame ${i + 1}`, async () => (await labelState(page)).startsWith(source + ':')).catch(async (e) => {
        throw new Error(`${e.message} (${source}): the page shows '${await labelState(page)}' at ${await page.$eval('#label-pos', (x) => x.textContent)}`);
      });
      await drag(page, m.shadow);
      await until(`the shadow box ${m.shadow} of ${source}`, async () => (await labelState(page)).includes(`shadow ${m.shadow.join(',')}`)).catch(async (e) => { throw new Error(e.message + ': the page shows ' + (await labelState(page))); });
      if (m.contact) {
        await drag(page, m.contact);
        await until(`the contact box of ${source}`, async () => (await labelState(page)).includes(`contact ${m.contact.join(',')}`));
      }
      if (i === touchFiles.length - 1) { // the last one: its contact box taken back with X
        m.contact = null;
        await page.keyboard.press('x');
        await until(`no contact on ${source}`, async () => (await labelState(page)).includes('contact none'));
      }
      if (i + 1 < touchFiles.length) await page.keyboard.press('n');
    }
    const labelled = await (await fetch(base + '/api/calib')).json();
    const boxesOk = labelled.touch.every((r, i) => JSON.stringify(r.shadow) === JSON.stringify(meta.get(touchFiles[i]).shadow) && JSON.stringify(r.contact) === JSON.stringify(meta.get(touchFiles[i]).contact));
    check(boxesOk, 'the boxes drawn with the mouse are the dataset\'s boxes in image pixels');

    // Calibrate and save.
    await page.click('#run-calib');
    await until('the calibration', async () => /warning\(s\)|error|expected/.test(await page.$eval('#calib-summary', (e) => e.textContent)), 60000);
    const summary = await page.$eval('#calib-summary', (e) => e.textContent);
    check(/warning\(s\)/.test(summary), `calibration ran: ${summary}`);
    await until('the preview', () => page.$eval('#preview', (e) => e.complete && e.naturalWidth > 0));
    if (args.screenshots) await page.screenshot({ path: path.join(args.screenshots, 'studio_calibration.png') });
    await page.fill('#save-name', 'skin.calib');
    await page.click('#save');
    await until('the save', async () => /saved|refused|error/.test(await page.$eval('#save-result', (e) => e.textContent)));
    const saved = path.join(out, 'skin.calib');
    check(fs.existsSync(saved), `the calibration was saved as ${saved}`);

    // ss_calibrate on the same frames (decoded from the video here, independently of the
    // studio) and the same boxes (the dataset's).
    const ref = path.join(work, 'ref');
    const name = (k) => String(k).padStart(4, '0') + '.png';
    for (const [kind, list] of [['empty', emptyChosen], ['touch', touchChosen]])
      execFileSync(python, [videoTool, 'read', args.video, path.join(ref, kind), ...list.map((c) => String(c[2]))], { stdio: ['ignore', 'ignore', 'inherit'] });
    let csv = 'file,shadow_x,shadow_y,shadow_w,shadow_h,contact_x,contact_y,contact_w,contact_h\n';
    touchFiles.forEach((f, k) => {
      const m = meta.get(f);
      csv += `${name(k)},${m.shadow.join(',')},${m.contact ? m.contact.join(',') : ',,,'}\n`;
    });
    fs.writeFileSync(path.join(ref, 'labels.csv'), csv);
    const calibrate = (dir, file) => execFileSync(args.calibrate, ['--empty', path.join(dir, 'empty'), '--touch', path.join(dir, 'touch'), '--labels', path.join(dir, 'labels.csv'), '--out', file], { stdio: ['ignore', 'ignore', 'inherit'] });
    calibrate(ref, path.join(work, 'ref.calib'));
    // and on what the studio saved beside the file (what a user re-runs ss_calibrate on)
    const framesDir = path.join(out, 'skin.calib.frames');
    check(fs.readFileSync(path.join(framesDir, 'labels.csv'), 'utf8') === csv, 'the studio saved the labels CSV ss_calibrate reads (the boxes drawn)');
    calibrate(framesDir, path.join(work, 'resaved.calib'));
    if (fs.existsSync(saved)) {
      for (const [what, file] of [['on the frames decoded from the video', 'ref.calib'], ['on the frames and labels the studio saved', 'resaved.calib']]) {
        const problems = sameCalibration(readCalibration(saved), readCalibration(path.join(work, file)));
        check(problems.length === 0, `the saved calibration equals ss_calibrate's ${what} (thresholds within 1e-6, same empty-skin model)${problems.length ? ': ' + problems.join('; ') : ''}`);
      }
    }

    // The live view switched to it: the overlay is drawn on a frame with a hand.
    await page.click('#tab-live');
    await stepTo(page, frameOfVideo(touchChosen[0][2]), '#step');
    await until('a frame with a track', () => page.evaluate(() => window.studioStats.last && window.studioStats.last.tracks > 0), 5000).catch(() => false);
    const drawn = overlayPixels(await page.locator('#live-canvas').screenshot());
    check(drawn > 200, `the overlay is drawn after the switch (${drawn} overlay pixels)`);
    const stages = await page.$eval('#speed', (e) => e.innerText);
    check(/segment\s+\d+\.\d ms/.test(stages) && /blobs · track · touch\s+\d+\.\d ms/.test(stages) && /encode\s+\d+\.\d ms/.test(stages), 'the live view shows per-stage milliseconds (segment, blobs · track · touch, classify, draw, encode)');
    await page.click('#pause'); // play again
    const shownBefore = await page.evaluate(() => window.studioStats.shown);
    printLive('live view, calibrated', await measureLive(page, 3000));
    if (args.screenshots) { // on a frame with a hand, as the README shows it
      await until('a frame with a track to show', () => page.evaluate(() => window.studioStats.last.tracks > 0), 5000).catch(() => false);
      await page.screenshot({ path: path.join(args.screenshots, 'studio_live.png') });
    }
    check((await page.evaluate(() => window.studioStats.shown)) > shownBefore, 'frames advance after the switch');

    await phoneChecks(browser, base + '/');

    // Path traversal: refused, nothing written.
    const before = fs.readdirSync(out).sort().join();
    for (const bad of ['../evil.calib', '..%2Fevil.calib', '%2Ftmp%2Fevil.calib', 'sub%2Fevil.calib', '.hidden', '..']) {
      const r = await fetch(`${base}/api/calib/save?name=${bad}`, { method: 'POST', headers: { 'X-Studio': '1' } });
      check(r.status === 400, `save as '${decodeURIComponent(bad)}' is refused (${r.status})`);
    }
    check(fs.readdirSync(out).sort().join() === before && !fs.existsSync(path.join(work, 'evil.calib')) && !fs.existsSync('/tmp/evil.calib'), 'the refused saves wrote nothing');
    const noHeader = await fetch(`${base}/api/control?action=pause`, { method: 'POST' });
    check(noHeader.status === 403, `a POST without X-Studio is refused (${noHeader.status})`);

    // Bound to a non-loopback address: every request needs the token.
    const t = await startStudio(['--input', args.video, '--model', 'none', '--bind', '0.0.0.0', '--port', '0']);
    const tb = `http://127.0.0.1:${t.port}`;
    check(t.token.length === 32, 'a token is printed for a non-loopback bind');
    for (const [what, url, init] of [
      ['the page', '/', {}], ['the live frames', '/api/live', {}], ['the frame pictures', '/api/frame', {}],
      ['a recording', '/api/record?kind=empty', { method: 'POST', headers: { 'X-Studio': '1' } }],
      ['a wrong token', '/api/info?token=' + '0'.repeat(32), {}],
    ]) {
      const r = await fetch(tb + url, init);
      check(r.status === 401, `${what} without the token is refused (${r.status})`);
    }
    const ok = await fetch(`${tb}/api/info`, { headers: { 'X-Studio-Token': t.token } });
    check(ok.status === 200, `with the token it is served (${ok.status})`);
    const tokenPage = await openPage(browser, `${tb}/?token=${t.token}`);
    await until('frames with the token', () => tokenPage.evaluate(() => window.studioStats.shown > 3));
    check(true, 'the page works with the token');
  } finally {
    await browser.close();
    stopAll();
  }
}

main().then(() => {
  if (!args.measure) console.log(failures ? `browser_test: ${failures} check(s) failed` : 'browser_test: all checks passed');
  process.exit(failures ? 1 : 0);
}).catch((e) => {
  console.error(`browser_test: ${e.stack || e}`);
  stopAll();
  process.exit(1);
});
