#!/usr/bin/env node
// Drives the vog-console page in headless Chromium and checks it against the console's /api/state.
//
//   node tests/console/browser_test.mjs --url http://127.0.0.1:PORT/ [--token T] --mode operator|observer \
//        --screenshot out.png [--expect-start] [--json result.json] [--chromium /usr/bin/chromium]
//
// Prints one line per check (PASS/FAIL/SKIP + detail), writes a JSON summary and exits 1 if a check failed.
import fs from 'node:fs';
import path from 'node:path';

import { launchChromium } from './chromium.mjs';


// ------------------------------------------------------------------------------------------ options

function usage(msg) {
  if (msg) console.error(`browser_test: ${msg}`);
  console.error('usage: browser_test.mjs --url http://HOST:PORT/ [--token T] --mode operator|observer ' +
    '--screenshot out.png [--expect-start] [--json result.json] [--chromium PATH]');
  process.exit(2);
}

const opt = { url: null, token: null, mode: null, screenshot: null, expectStart: false, json: null,
  chromium: '/usr/bin/chromium' };
{
  const a = process.argv.slice(2);
  for (let i = 0; i < a.length; i++) {
    const next = () => (i + 1 < a.length ? a[++i] : usage(`${a[i]} needs a value`));
    switch (a[i]) {
      case '--url': opt.url = next(); break;
      case '--token': opt.token = next(); break;
      case '--mode': opt.mode = next(); break;
      case '--screenshot': opt.screenshot = next(); break;
      case '--expect-start': opt.expectStart = true; break;
      case '--json': opt.json = next(); break;
      case '--chromium': opt.chromium = next(); break;
      case '-h': case '--help': usage(); break;
      default: usage(`unknown argument ${a[i]}`);
    }
  }
  if (!opt.url) usage('--url is required');
  if (!['operator', 'observer'].includes(opt.mode)) usage('--mode operator|observer is required');
  if (!opt.screenshot) opt.screenshot = 'console.png';
}

const base = new URL(opt.url);
base.search = '';
base.hash = '';
if (!base.pathname.endsWith('/')) base.pathname += '/';
const withToken = (u) => { const x = new URL(u, base); if (opt.token) x.searchParams.set('token', opt.token); return x.toString(); };
const pageUrl = withToken(base);
const wsBase = `${base.protocol === 'https:' ? 'wss' : 'ws'}://${base.host}/ws`;

// ------------------------------------------------------------------------------------------ helpers

const checks = [];
const summary = { url: base.toString(), mode: opt.mode, expectStart: opt.expectStart, checks, maxFrameMs: null,
  frames: null, occupied: null, screenshot: null, passed: false };

function record(name, status, detail) {
  checks.push({ name, status, ok: status !== 'FAIL', detail });
  console.log(`${status} ${name}: ${detail}`);
}
const pass = (n, d) => record(n, 'PASS', d);
const fail = (n, d) => record(n, 'FAIL', d);
const skip = (n, d) => record(n, 'SKIP', d);

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

async function apiState() {
  const r = await fetch(withToken('api/state'), { cache: 'no-store' });
  if (!r.ok) throw new Error(`GET /api/state: HTTP ${r.status}`);
  return r.json();
}

async function httpStatus(u) {
  try {
    const r = await fetch(u, { redirect: 'manual' });
    await r.arrayBuffer();
    return r.status;
  } catch (e) {
    return `error ${e.message}`;
  }
}

// Polls fn() until it returns a truthy value or the time is up; returns the last value.
async function waitFor(fn, timeoutMs, everyMs = 250) {
  const end = Date.now() + timeoutMs;
  let v;
  for (;;) {
    try { v = await fn(); } catch (e) { v = undefined; }
    if (v || Date.now() >= end) return v;
    await sleep(everyMs);
  }
}

const mapVersionOf = (s) => (s.mirror && s.mirror.map_version !== undefined ? s.mirror.map_version : s.map_version);

// ------------------------------------------------------------------------------------------ the run

const BUTTONS = ['btn-start', 'btn-pause', 'btn-resume', 'btn-home', 'btn-abort', 'btn-set-box'];
const BOX_IDS = ['box-min-x', 'box-min-y', 'box-min-z', 'box-max-x', 'box-max-y', 'box-max-z'];

let browser;
const pageErrors = [];
const consoleErrors = [];

async function main() {
  browser = await launchChromium(opt.chromium);
  const context = await browser.newContext({ viewport: { width: 1440, height: 860 } });
  const page = await context.newPage();
  page.on('pageerror', (e) => pageErrors.push(String(e && e.message ? e.message : e)));
  page.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(m.text()); });
  page.on('dialog', (d) => { consoleErrors.push(`unexpected dialog: ${d.message()}`); d.dismiss().catch(() => {}); });

  // 1. the page loads and connects
  {
    const name = '1 page loads and connects';
    let resp;
    try { resp = await page.goto(pageUrl, { waitUntil: 'load', timeout: 30000 }); } catch (e) { fail(name, `goto: ${e.message}`); return; }
    const status = resp ? resp.status() : 0;
    const hooked = await waitFor(() => page.evaluate(() => !!window.vogConsole), 15000);
    const link = hooked ? await waitFor(async () => (await page.evaluate(() => vogConsole.linkState())) === 'connected', 15000) : false;
    const gl = hooked ? await page.evaluate(() => {
      const r = vogConsole.renderer;
      const g = r && r.getContext();
      const ext = g && g.getExtension('WEBGL_debug_renderer_info');
      return g ? `WebGL${r.capabilities.isWebGL2 ? '2' : '1'} ${ext ? g.getParameter(ext.UNMASKED_RENDERER_WEBGL) : ''}` : null;
    }) : null;
    await sleep(500);
    const problems = [];
    if (status !== 200) problems.push(`HTTP ${status}`);
    if (!hooked) problems.push('window.vogConsole missing');
    if (!link) problems.push('link state never became "connected"');
    if (!gl) problems.push('no WebGL context');
    if (pageErrors.length) problems.push(`page errors: ${pageErrors.join(' | ')}`);
    if (consoleErrors.length) problems.push(`console errors: ${consoleErrors.join(' | ')}`);
    if (problems.length) { fail(name, problems.join('; ')); if (!hooked || !link) return; }
    else pass(name, `HTTP 200, link connected, ${gl}`);
  }

  // 2. the voxel count shown equals the mirror's
  async function checkCount() {
    const name = '2 occupied count matches /api/state';
    let last = null;
    const ok = await waitFor(async () => {
      const a = await apiState();
      const p = await page.evaluate(() => ({
        shown: document.getElementById('occupied-count').textContent.trim(),
        count: vogConsole.occupiedCount(), pending: vogConsole.pendingMessages(), mapVersion: vogConsole.mapVersion(),
        total: vogConsole.totalOccupied(),
      }));
      const b = await apiState();
      last = { api: a.mirror ? a.mirror.occupied : undefined, apiMapVersion: mapVersionOf(a), page: p };
      return a.mirror && b.mirror && a.mirror.occupied === b.mirror.occupied && mapVersionOf(a) === mapVersionOf(b) &&
        a.mirror.occupied > 0 && p.pending === 0 && /^\d+$/.test(p.shown) && Number(p.shown) === a.mirror.occupied &&
        p.count === a.mirror.occupied && p.mapVersion === mapVersionOf(a);
    }, 60000, 300);
    summary.occupied = last;
    const bookkeeping = await page.evaluate(() => (vogConsole.verifyVoxels ? vogConsole.verifyVoxels() : []));
    if (bookkeeping.length) { fail(name, `the page's voxel bookkeeping is inconsistent: ${bookkeeping.join('; ')}`); }
    const d = last ? `shown ${JSON.stringify(last.page.shown)} (held ${last.page.count}, pending ${last.page.pending}, ` +
      `map_version ${last.page.mapVersion}) vs mirror.occupied ${last.api} (map_version ${last.apiMapVersion})` : 'no data';
    if (ok && !bookkeeping.length) pass(name, d); else if (!ok) fail(name, d);
  }

  const vehiclePos = () => page.evaluate(() => { const p = vogConsole.vehicle.position; return [p.x, p.y, p.z, vogConsole.vehicle.visible]; });
  async function checkMoves(afterStart) {
    const name = '3 vehicle marker moves';
    const p0 = await vehiclePos();
    let p1 = p0;
    const moved = await waitFor(async () => {
      p1 = await vehiclePos();
      return Math.hypot(p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]) > 1e-3;
    }, 20000, 200);
    const d = `from (${p0.slice(0, 3).map((v) => v.toFixed(2))}) to (${p1.slice(0, 3).map((v) => v.toFixed(2))}), visible ${p1[3]}`;
    if (moved && p1[3]) return pass(name, d);
    const st = await apiState().catch(() => ({}));
    if (!afterStart && !opt.expectStart && st.mission_state && st.mission_state !== 'exploring' && st.mission_state !== 'returning') {
      return skip(name, `the mission is ${st.mission_state} and the vehicle did not move (${d})`);
    }
    fail(name, `${moved ? 'marker not visible' : 'no movement in 20 s'} (${d}, mission ${st.mission_state})`);
  }

  const waitReply = (id, timeoutMs = 10000) =>
    waitFor(() => page.evaluate((i) => { const r = vogConsole.lastReply(); return r && r.id === i ? r : null; }, id), timeoutMs, 100);

  // 4. controls
  async function checkControls() {
  if (opt.mode === 'observer') {
    const name = '4 observer: controls off, commands refused';
    const st = await page.evaluate((ids) => ({
      disabled: ids.map((id) => [id, document.getElementById(id).disabled]),
      reason: document.getElementById('controls-reason').textContent.trim(),
      enabled: vogConsole.controlsEnabled(),
    }), BUTTONS);
    await page.evaluate(() => vogConsole.send({ type: 'command', id: 9001, command: 'start' }));
    const r = await waitReply(9001);
    const problems = [];
    const on = st.disabled.filter(([, d]) => !d).map(([id]) => id);
    if (on.length) problems.push(`enabled: ${on.join(', ')}`);
    if (!st.reason) problems.push('#controls-reason is empty');
    if (st.enabled) problems.push('controlsEnabled() is true');
    if (!r) problems.push('no reply to command 9001');
    else if (r.ok !== false) problems.push(`reply 9001 ok=${r.ok}`);
    const d = `reason "${st.reason}", reply 9001 ${r ? `ok=${r.ok} "${r.text}"` : 'missing'}`;
    if (problems.length) fail(name, `${problems.join('; ')} (${d})`); else pass(name, `all ${BUTTONS.length} buttons disabled, ${d}`);
  } else {
    const name = '4 operator: controls';
    const problems = [];
    const details = [];
    const enabled = await waitFor(() => page.evaluate(() => vogConsole.controlsEnabled()), 10000);
    const st = await page.evaluate((ids) => ({
      disabled: ids.filter((id) => document.getElementById(id).disabled),
      reason: document.getElementById('controls-reason').textContent.trim(),
    }), BUTTONS);
    if (!enabled) problems.push(`controls off ("${st.reason}")`);
    if (st.disabled.length) problems.push(`disabled: ${st.disabled.join(', ')}`);
    // the abort dialog opens in the page and Cancel sends nothing
    if (enabled) {
      const before = await page.evaluate(() => vogConsole.lastReply());
      await page.click('#btn-abort');
      const shown = await page.isVisible('#btn-abort-confirm');
      await page.click('#btn-abort-cancel');
      await sleep(300);
      const hidden = !(await page.isVisible('#btn-abort-confirm'));
      const after = await page.evaluate(() => vogConsole.lastReply());
      if (!shown) problems.push('abort did not ask for confirmation');
      if (!hidden) problems.push('the abort dialog stayed open after Cancel');
      if (JSON.stringify(before) !== JSON.stringify(after)) problems.push('cancelling abort sent a command');
      else details.push('abort asks to confirm');
    }
    let state = (await apiState()).mission_state;
    if (opt.expectStart && enabled) {
      const s = await apiState();
      const values = await page.evaluate((ids) => ids.map((id) => document.getElementById(id).value), BOX_IDS);
      let box = s.box;
      if (!box && values.some((v) => v === '')) {
        const p = (s.pose && s.pose.p) || [0, 0, 0];
        box = { min: [p[0] - 10, p[1] - 10, p[2] - 5], max: [p[0] + 10, p[1] + 10, p[2] + 5] };
      }
      if (box) {
        const v = [...box.min, ...box.max];
        for (let i = 0; i < 6; i++) await page.fill(`#${BOX_IDS[i]}`, String(v[i]));
      }
      await page.click('#btn-start');
      const startReply = await waitFor(() => page.evaluate(() => vogConsole.lastReply()), 10000, 100);
      const exploring = await waitFor(async () => (state = (await apiState()).mission_state) === 'exploring', 60000, 500);
      details.push(`start reply ${startReply ? `ok=${startReply.ok} "${startReply.text}"` : 'missing'}, mission ${state}`);
      if (!exploring) problems.push(`mission is "${state}", not exploring, 60 s after Start`);
    }
    if (enabled && state !== 'paused') {
      await page.evaluate(() => vogConsole.send({ type: 'command', id: 9002, command: 'resume' }));
      const r = await waitReply(9002);
      if (!r) problems.push('no reply to resume (9002)');
      else if (r.ok !== false || !String(r.text || '').trim()) problems.push(`resume while ${state}: ok=${r.ok} "${r.text}"`);
      else details.push(`resume while ${state} refused: "${r.text}"`);
      const shown = await page.evaluate(() => !!document.querySelector('#events li.reply-refused'));
      if (!shown) problems.push('the refusal is not shown as an error in #events');
    }
    if (problems.length) fail(name, `${problems.join('; ')} (${details.join('; ')})`); else pass(name, details.join('; '));
  }
  }

  // An operator run that starts the mission starts it first: the map grows and the vehicle moves after.
  const startFirst = opt.expectStart && opt.mode === 'operator';
  if (startFirst) await checkControls();
  await checkCount();
  if (!startFirst) await checkControls();

  // 3. the vehicle moves (after the start when it is expected)
  await checkMoves(startFirst);

  // 7. screenshot once the map is shown
  {
    const name = '7 screenshot';
    await waitFor(() => page.evaluate(() => vogConsole.pendingMessages() === 0 && vogConsole.occupiedCount() > 0), 20000);
    await sleep(500);
    const dir = path.dirname(path.resolve(opt.screenshot));
    fs.mkdirSync(dir, { recursive: true });
    const png = await page.screenshot({ path: opt.screenshot });
    summary.screenshot = path.resolve(opt.screenshot);
    // how much of the 3D view is not the background colour
    const cover = await page.evaluate(async (b64) => {
      const img = new Image();
      img.src = `data:image/png;base64,${b64}`;
      await img.decode();
      const r = document.getElementById('canvas-host').getBoundingClientRect();
      const c = document.createElement('canvas');
      c.width = Math.max(1, Math.floor(r.width)); c.height = Math.max(1, Math.floor(r.height));
      const g = c.getContext('2d');
      g.drawImage(img, r.left, r.top, r.width, r.height, 0, 0, c.width, c.height);
      const d = g.getImageData(0, 0, c.width, c.height).data;
      let n = 0, bright = 0;
      for (let i = 0; i < d.length; i += 4) {
        if (Math.abs(d[i] - 7) + Math.abs(d[i + 1] - 10) + Math.abs(d[i + 2] - 14) > 40) n++;
        if (d[i] + d[i + 1] + d[i + 2] > 150) bright++;
      }
      return { drawn: n / (d.length / 4), bright: bright / (d.length / 4) };
    }, png.toString('base64'));
    const mf = await page.evaluate(() => vogConsole.maxFrameMs());
    const d = `${opt.screenshot}: ${(cover.drawn * 100).toFixed(1)}% of the 3D view drawn, maxFrameMs ${mf.toFixed(1)}`;
    if (cover.drawn > 0.02) pass(name, d); else fail(name, `the 3D view looks empty (${d})`);
  }

  // 5. bad input
  {
    const name = '5 bad input';
    const problems = [];
    const details = [];
    const c0 = await page.evaluate(() => ({ opened: vogConsole.connections(), closed: vogConsole.disconnects(), err: vogConsole.lastError() }));
    await page.evaluate(() => vogConsole.sendRaw('not json'));
    const err = await waitFor(() => page.evaluate((prev) => {
      const e = vogConsole.lastError();
      return e && JSON.stringify(e) !== prev ? e : null;
    }, JSON.stringify(c0.err)), 5000, 100);
    await sleep(500);
    const c1 = await page.evaluate(() => ({ opened: vogConsole.connections(), closed: vogConsole.disconnects(), link: vogConsole.linkState() }));
    if (!err) problems.push('no error message for "not json"');
    else details.push(`"not json" -> error "${err.text}"`);
    if (c1.closed !== c0.closed || c1.link !== 'connected') problems.push('the socket closed after "not json"');

    const e1 = await page.evaluate(() => JSON.stringify(vogConsole.lastError()));
    await page.evaluate(() => vogConsole.send({ type: 'command', id: 9003, command: 'fly_to_the_moon' }));
    const r = await waitFor(() => page.evaluate((prev) => {
      const rp = vogConsole.lastReply();
      if (rp && rp.id === 9003) return { reply: rp };
      const e = vogConsole.lastError();
      return e && JSON.stringify(e) !== prev ? { error: e } : null;
    }, e1), 5000, 100);
    if (!r) problems.push('no reply or error for command "fly_to_the_moon"');
    else if (r.reply && r.reply.ok !== false) problems.push('"fly_to_the_moon" was accepted');
    else details.push(`fly_to_the_moon -> ${r.reply ? `reply ok=false "${r.reply.text}"` : `error "${r.error.text}"`}`);

    const c2 = await page.evaluate(() => ({ opened: vogConsole.connections(), closed: vogConsole.disconnects() }));
    const t0 = Date.now();
    await page.evaluate(() => vogConsole.sendRaw('x'.repeat(100000)));
    const closed = await waitFor(() => page.evaluate((n) => vogConsole.disconnects() > n, c2.closed), 5000, 50);
    const tClosed = Date.now();
    const back = closed ? await waitFor(() => page.evaluate((n) => vogConsole.connections() > n && vogConsole.linkState() === 'connected', c2.opened), 5000, 100) : false;
    if (!closed) problems.push('a 100000-byte message did not close the socket');
    else if (!back) problems.push('the page did not reconnect within 5 s');
    else details.push(`100000 bytes -> closed after ${tClosed - t0} ms, connected again after ${Date.now() - tClosed} ms`);
    if (problems.length) fail(name, `${problems.join('; ')} (${details.join('; ')})`); else pass(name, details.join('; '));
  }

  // 6. token
  if (opt.token) {
    const name = '6 token';
    const problems = [];
    const details = [];
    const noToken = await httpStatus(new URL('/', base).toString());
    const apiNoToken = await httpStatus(new URL('/api/state', base).toString());
    const good = await httpStatus(withToken('/'));
    const wrong = await httpStatus(`${new URL('/', base)}?token=${encodeURIComponent(opt.token + 'x')}`);
    if (noToken !== 401) problems.push(`GET / without token: ${noToken}`);
    if (apiNoToken !== 401) problems.push(`GET /api/state without token: ${apiNoToken}`);
    if (wrong !== 401) problems.push(`GET / with a wrong token: ${wrong}`);
    if (good !== 200) problems.push(`GET /?token=: ${good}`);
    details.push(`GET / ${noToken}, /api/state ${apiNoToken}, wrong token ${wrong}, with token ${good}`);
    // a fresh context has no cookie: its WebSocket without ?token must fail, with it must open
    const fresh = await browser.newContext();
    const p2 = await fresh.newPage();
    const resp = await p2.goto(new URL('/', base).toString()).catch(() => null);
    const st = resp ? resp.status() : 0;
    if (st !== 401) problems.push(`fresh browser GET / without token: ${st}`);
    const tryWs = (u) => p2.evaluate((url) => new Promise((res) => {
      let w;
      try { w = new WebSocket(url); } catch (e) { res(`throw ${e.message}`); return; }
      const t = setTimeout(() => { res('timeout'); w.close(); }, 5000);
      w.onopen = () => { clearTimeout(t); res('open'); w.close(); };
      w.onerror = () => { clearTimeout(t); res('error'); };
      w.onclose = () => { clearTimeout(t); res('closed'); };
    }), u);
    const wsNo = await tryWs(wsBase);
    const wsYes = await tryWs(`${wsBase}?token=${encodeURIComponent(opt.token)}`);
    await fresh.close();
    if (wsNo === 'open') problems.push('a WebSocket without the token opened');
    if (wsYes !== 'open') problems.push(`a WebSocket with ?token= did not open (${wsYes})`);
    details.push(`fresh browser: GET / ${st}, ws without token ${wsNo}, ws with ?token= ${wsYes}`);
    if (problems.length) fail(name, `${problems.join('; ')} (${details.join('; ')})`); else pass(name, details.join('; '));
  } else {
    skip('6 token', 'no --token given');
  }

  // the whole run: no page errors, no console errors; frame timing
  {
    const name = '1b no page or console errors during the run';
    const link = await waitFor(async () => (await page.evaluate(() => vogConsole.linkState())) === 'connected', 5000);
    const frames = await page.evaluate(() => {
      const t = vogConsole.frameTimes().slice().sort((a, b) => a - b);
      const q = (f) => (t.length ? t[Math.min(t.length - 1, Math.floor(f * t.length))] : null);
      return { count: t.length, p50: q(0.5), p95: q(0.95), p99: q(0.99), max: vogConsole.maxFrameMs(),
        slow: vogConsole.slowFrames ? vogConsole.slowFrames() : [], voxelMode: vogConsole.voxelMode ? vogConsole.voxelMode() : null };
    });
    summary.maxFrameMs = frames.max;
    summary.frames = frames;
    const problems = [];
    if (pageErrors.length) problems.push(`page errors: ${pageErrors.join(' | ')}`);
    if (consoleErrors.length) problems.push(`console errors: ${consoleErrors.join(' | ')}`);
    if (!link) problems.push('not connected at the end');
    const d = `maxFrameMs ${frames.max.toFixed(1)} (p50 ${frames.p50?.toFixed(1)}, p95 ${frames.p95?.toFixed(1)}, ` +
      `p99 ${frames.p99?.toFixed(1)} over ${frames.count} frames)`;
    if (problems.length) fail(name, `${problems.join('; ')}; ${d}`); else pass(name, d);
  }
}

let exitCode = 0;
try {
  await main();
} catch (e) {
  fail('run', e && e.stack ? e.stack.split('\n').slice(0, 3).join(' ') : String(e));
} finally {
  if (browser) await browser.close().catch(() => {});
}
summary.passed = checks.length > 0 && checks.every((c) => c.ok);
if (!summary.passed) exitCode = 1;
console.log(`${summary.passed ? 'PASS' : 'FAIL'} browser_test ${opt.mode}: ${checks.filter((c) => c.status === 'PASS').length} passed, ` +
  `${checks.filter((c) => c.status === 'FAIL').length} failed, ${checks.filter((c) => c.status === 'SKIP').length} skipped; ` +
  `maxFrameMs ${summary.maxFrameMs === null ? '-' : summary.maxFrameMs.toFixed(1)}`);
if (opt.json) fs.writeFileSync(opt.json, JSON.stringify(summary, null, 2) + '\n');
process.exit(exitCode);
