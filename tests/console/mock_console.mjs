#!/usr/bin/env node
// A stand-in for vog-console with synthetic data, for developing and testing the page
// (client/console/web/) without vogd. It speaks the page protocol of client/console/README.md:
//   node tests/console/mock_console.mjs --port 0 [--host 127.0.0.1] [--operator] [--token T]
//        [--state idle|exploring] [--reset-every 20]
// and prints "listening http://HOST:PORT/" on stdout.
//
// The map: a seabed with a few mounds and a pillar (a cylinder wall) that grows a layer at a time; every
// --reset-every seconds a "loop closure" shifts the whole map by one voxel and sends it again as a reset
// of ~200,000 voxels in several messages. The vehicle orbits the pillar while exploring or returning.
import http from 'node:http';
import fs from 'node:fs';
import path from 'node:path';
import crypto from 'node:crypto';
import { fileURLToPath } from 'node:url';
import { createRequire } from 'node:module';

const here = path.dirname(fileURLToPath(import.meta.url));
const webRoot = path.resolve(here, '../../client/console/web');
const require = createRequire(path.join(webRoot, 'package.json'));
const { WebSocketServer } = require('ws');

// ------------------------------------------------------------------------------------------ options

function parseArgs(argv) {
  const o = { port: 8080, host: '127.0.0.1', operator: false, token: '', state: null, resetEvery: 20, maxVoxels: 40000 };
  for (let i = 0; i < argv.length; i++) {
    const a = argv[i];
    const next = () => { if (i + 1 >= argv.length) throw new Error(`${a} needs a value`); return argv[++i]; };
    if (a === '--port') o.port = Number(next());
    else if (a === '--host') o.host = next();
    else if (a === '--operator') o.operator = true;
    else if (a === '--token') o.token = next();
    else if (a === '--state') o.state = next();
    else if (a === '--reset-every') o.resetEvery = Number(next());
    else if (a === '--max-voxels-per-message') o.maxVoxels = Number(next());
    else if (a === '-h' || a === '--help') {
      console.log('usage: mock_console.mjs --port N [--host H] [--operator] [--token T] [--state idle|exploring] [--reset-every S]');
      process.exit(0);
    } else throw new Error(`unknown argument ${a}`);
  }
  if (!o.state) o.state = o.operator ? 'idle' : 'exploring';
  return o;
}
const opt = parseArgs(process.argv.slice(2));

// ------------------------------------------------------------------------------------------ the map

const RES = 0.2;
const blocks = new Map(); // "bx,by,bz" -> {bx,by,bz, occ:Set<number>, free:Set<number>}
let occupied = 0;
let freeCount = 0;
let mapVersion = 1;
let shift = 0; // voxels; alternates with each loop closure

function keyOf(bx, by, bz) { return `${bx},${by},${bz}`; }
function voxelIndex(x, y, z) { return (x & 7) | ((y & 7) << 3) | ((z & 7) << 6); }

function setVoxel(x, y, z, kind, changed) {
  const bx = x >> 3, by = y >> 3, bz = z >> 3;
  const k = keyOf(bx, by, bz);
  let b = blocks.get(k);
  if (!b) { b = { bx, by, bz, occ: new Set(), free: new Set() }; blocks.set(k, b); }
  const i = voxelIndex(x, y, z);
  if (kind === 'occ') {
    if (b.free.delete(i)) freeCount--;
    if (!b.occ.has(i)) { b.occ.add(i); occupied++; }
  } else {
    if (b.occ.has(i)) return;
    if (!b.free.has(i)) { b.free.add(i); freeCount++; }
  }
  if (changed) changed.add(k);
}

function clearVoxel(x, y, z, changed) {
  const k = keyOf(x >> 3, y >> 3, z >> 3);
  const b = blocks.get(k);
  if (!b) return;
  const i = voxelIndex(x, y, z);
  if (b.occ.delete(i)) occupied--;
  if (b.free.delete(i)) freeCount--;
  if (b.occ.size === 0 && b.free.size === 0) blocks.delete(k); // sent as an entry with no voxels
  changed.add(k);
}

// A drifting object (a lost buoy) of 3x3x3 voxels: its old voxels cleared, new ones set, so deltas carry
// replaced blocks and removed (empty) blocks.
let buoy = null;
function moveBuoy(t, changed) {
  if (buoy) for (const [x, y, z] of buoy) clearVoxel(x + shift, y, z, changed);
  const cx = Math.round((20 * Math.cos(t * 0.05)) / RES), cy = Math.round((-20 + 8 * Math.sin(t * 0.11)) / RES);
  const cz = Math.round(6 / RES);
  buoy = [];
  for (let dx = 0; dx < 3; dx++) for (let dy = 0; dy < 3; dy++) for (let dz = 0; dz < 3; dz++) buoy.push([cx + dx, cy + dy, cz + dz]);
  for (const [x, y, z] of buoy) setVoxel(x + shift, y, z, 'occ', changed);
}

const PILLAR = { cx: 0, cy: 0, r: 6.0, maxLayers: 150 };
let pillarLayers = 0;

function seabedZ(x, y) { // metres
  const m1 = 2.2 * Math.exp(-((x - 14) ** 2 + (y + 10) ** 2) / 30);
  const m2 = 1.6 * Math.exp(-((x + 16) ** 2 + (y - 12) ** 2) / 45);
  return -4 + 0.6 * Math.sin(x * 0.21) * Math.cos(y * 0.17) + m1 + m2;
}

function buildSeabed(changed) {
  const half = 185; // voxels: 74 m x 74 m
  for (let ix = -half; ix < half; ix++) {
    for (let iy = -half; iy < half; iy++) {
      const x = (ix + 0.5) * RES, y = (iy + 0.5) * RES;
      const kz = Math.floor(seabedZ(x, y) / RES);
      setVoxel(ix + shift, iy, kz, 'occ', changed);
      // a second layer where the slope is steep, so the bed looks closed
      const kz2 = Math.floor(seabedZ(x + RES, y) / RES);
      if (Math.abs(kz2 - kz) > 1) setVoxel(ix + shift, iy, kz + Math.sign(kz2 - kz), 'occ', changed);
      // free voxels: a sparse layer of water above the bed near the pillar
      if ((ix & 3) === 0 && (iy & 3) === 0 && Math.hypot(x, y) < 25) {
        for (let dz = 2; dz < 20; dz += 4) setVoxel(ix + shift, iy, kz + dz, 'free', changed);
      }
    }
  }
}

function addPillarLayer(layer, changed) {
  const z0 = Math.floor(-4 / RES) + layer;
  const rIn = PILLAR.r / RES, rOut = rIn + 2;
  const n = Math.ceil(rOut);
  for (let ix = -n; ix <= n; ix++) {
    for (let iy = -n; iy <= n; iy++) {
      const d = Math.hypot(ix + 0.5, iy + 0.5);
      if (d >= rIn && d < rOut) setVoxel(ix + shift, iy, z0, 'occ', changed);
    }
  }
}

function rebuildMap() {
  blocks.clear();
  occupied = 0;
  freeCount = 0;
  buildSeabed(null);
  for (let l = 0; l < pillarLayers; l++) addPillarLayer(l, null);
  if (buoy) for (const [x, y, z] of buoy) setVoxel(x + shift, y, z, 'occ', null);
}

// ------------------------------------------------------------------------------------------ binary messages

function encodeVoxelMessages(list, reset, withFree) {
  const out = [];
  let at = 0;
  do {
    const parts = [];
    let nBlocks = 0, voxels = 0, size = 32;
    for (; at < list.length; at++) {
      const b = list[at];
      const occ = b ? [...b.occ] : [];
      const free = b && withFree ? [...b.free] : [];
      const n = occ.length + free.length;
      if (nBlocks > 0 && voxels + n > opt.maxVoxels) break;
      const bytes = 16 + 2 * n + (n % 2) * 2;
      const e = Buffer.alloc(bytes);
      e.writeInt32LE(list[at].bx, 0);
      e.writeInt32LE(list[at].by, 4);
      e.writeInt32LE(list[at].bz, 8);
      e.writeUInt16LE(occ.length, 12);
      e.writeUInt16LE(free.length, 14);
      let o = 16;
      for (const i of occ) { e.writeUInt16LE(i, o); o += 2; }
      for (const i of free) { e.writeUInt16LE(i, o); o += 2; }
      parts.push(e);
      size += bytes;
      nBlocks++;
      voxels += n;
    }
    const h = Buffer.alloc(32);
    h.writeUInt32LE(0x314c5856, 0);
    h.writeUInt32LE(out.length === 0 && reset ? 1 : 0, 4);
    h.writeDoubleLE(RES, 8);
    h.writeDoubleLE(mapVersion, 16);
    h.writeUInt32LE(nBlocks, 24);
    h.writeUInt32LE(occupied, 28);
    out.push(Buffer.concat([h, ...parts], size));
  } while (at < list.length);
  return out;
}

// An entry for a removed block: its key with no voxels.
function entriesFor(keys) {
  return [...keys].map((k) => {
    const b = blocks.get(k);
    if (b && (b.occ.size || b.free.size)) return b;
    const [bx, by, bz] = k.split(',').map(Number);
    return { bx, by, bz, occ: new Set(), free: new Set() };
  });
}

// ------------------------------------------------------------------------------------------ mission

let missionState = opt.state;
let plannerState = missionState === 'exploring' ? 'exploring' : 'idle';
let box = { min: [-20, -20, -6], max: [20, 20, 24] };
const path_ = [];
const waypoints = [];
const events = [];
const bases = new Map(); // id -> {id, p, q}
const closures = [];
let graphVersion = 0;
let nextBase = 0;
let poseSeq = 0;
let wpSeq = 0;
let theta = 0; // orbit angle
let pose = { p: [12, 0, 2], q: [1, 0, 0, 0] };
const stampStart = Date.now();
let bytesReceived = 0;

const controls = opt.operator;
const controlsReason = controls ? '' : 'no --secret-file';

const devices = [
  { name: 'dvl', state: 'ok', detail: 'bottom lock', messages: 0, errors: 0 },
  { name: 'imu', state: 'ok', detail: '200 Hz', messages: 0, errors: 0 },
  { name: 'sonar', state: 'ok', detail: 'multibeam 256 beams', messages: 0, errors: 0 },
  { name: 'depth', state: 'ok', detail: '', messages: 0, errors: 0 },
  { name: 'gps', state: 'disconnected', detail: 'submerged', messages: 0, errors: 0 },
];

function stampNs() { return String((Date.now() - stampStart) * 1e6); }

function event(level, text) {
  const e = { type: 'event', unix_ms: Date.now(), level, text };
  events.push(e);
  while (events.length > 200) events.shift();
  broadcastText(e);
}

function statusJson() {
  return {
    type: 'status',
    mission_state: missionState,
    planner_state: plannerState,
    n_submaps: bases.size,
    n_closures: closures.length,
    map_version: mapVersion,
    graph_version: graphVersion,
    stamp_ns: Number(stampNs()),
    pose: { p: pose.p, q: pose.q },
    sigma_xyz_m: [0.15 + 0.05 * Math.sin(theta), 0.2, 0.05],
    sigma_yaw_rad: 0.02,
    devices,
    box,
    mirror: {
      submaps: bases.size, occupied, free: freeCount, map_version: mapVersion, graph_version: graphVersion,
      complete: true, bytes_received: bytesReceived,
    },
    link: 'connected',
    controls,
  };
}

function setMission(s, why) {
  if (s === missionState) return;
  missionState = s;
  plannerState = s === 'exploring' ? 'exploring' : s === 'returning' ? 'returning' : 'idle';
  event('info', `mission ${s}${why ? ': ' + why : ''}`);
  broadcastText(statusJson());
}

function validBox(b) {
  return b && Array.isArray(b.min) && Array.isArray(b.max) && b.min.length === 3 && b.max.length === 3 &&
    [...b.min, ...b.max].every(Number.isFinite) && b.min.every((v, i) => v < b.max[i]);
}

// Returns [ok, text].
function runCommand(m) {
  const refuse = (why) => { event('warning', `${m.command} refused: ${why}`); return [false, why]; };
  switch (m.command) {
    case 'start':
      if (missionState !== 'idle') return refuse(`start only from idle (the mission is ${missionState})`);
      if (m.box !== undefined) {
        if (!validBox(m.box)) return refuse('the box is not valid');
        box = { min: m.box.min, max: m.box.max };
      }
      if (!box) return refuse('no box');
      setMission('exploring', 'started by the operator');
      return [true, missionState];
    case 'pause':
      if (missionState !== 'exploring') return refuse(`pause only while exploring (the mission is ${missionState})`);
      setMission('paused');
      return [true, missionState];
    case 'resume':
      if (missionState !== 'paused') return refuse(`resume only while paused (the mission is ${missionState})`);
      setMission('exploring', 'resumed');
      return [true, missionState];
    case 'return_home':
      if (!['exploring', 'paused'].includes(missionState)) return refuse(`nothing to return from (the mission is ${missionState})`);
      setMission('returning');
      return [true, missionState];
    case 'abort':
      if (['idle', 'aborted'].includes(missionState)) return refuse(`nothing to abort (the mission is ${missionState})`);
      setMission('aborted', 'aborted by the operator');
      return [true, missionState];
    case 'set_box':
      if (!validBox(m.box)) return refuse('the box is not valid');
      box = { min: m.box.min, max: m.box.max };
      broadcastText(statusJson());
      return [true, missionState];
    default:
      return [false, `unknown command "${m.command}"`];
  }
}

// ------------------------------------------------------------------------------------------ HTTP

const TYPES = {
  '.html': 'text/html; charset=utf-8', '.js': 'text/javascript; charset=utf-8', '.mjs': 'text/javascript; charset=utf-8',
  '.css': 'text/css; charset=utf-8', '.json': 'application/json', '.png': 'image/png', '.svg': 'image/svg+xml',
};

function cookieValue(header, name) {
  for (const part of String(header || '').split(';')) {
    const [k, ...v] = part.trim().split('=');
    if (k === name) return v.join('=');
  }
  return null;
}

function sameSecret(a, b) {
  const x = Buffer.from(String(a)), y = Buffer.from(String(b));
  return x.length === y.length && crypto.timingSafeEqual(x, y);
}

// [ok, fromQuery]
function tokenOk(req, url) {
  if (!opt.token) return [true, false];
  const q = url.searchParams.get('token');
  if (q !== null && sameSecret(q, opt.token)) return [true, true];
  const c = cookieValue(req.headers.cookie, 'vog_token');
  return [c !== null && sameSecret(c, opt.token), false];
}

const server = http.createServer((req, res) => {
  const url = new URL(req.url, 'http://x');
  const [ok, fromQuery] = tokenOk(req, url);
  const headers = { 'Cache-Control': 'no-store', 'X-Content-Type-Options': 'nosniff', Server: 'vog-console-mock' };
  if (!ok) {
    res.writeHead(401, { ...headers, 'Content-Type': 'text/plain' });
    res.end('vog-console: the token is missing or wrong (open the URL vog-console printed, with ?token=...)\n');
    return;
  }
  if (req.method !== 'GET' && req.method !== 'HEAD') {
    res.writeHead(405, { ...headers, 'Content-Type': 'text/plain' });
    res.end('only GET and HEAD\n');
    return;
  }
  if (url.pathname === '/api/state') {
    res.writeHead(200, { ...headers, 'Content-Type': 'application/json' });
    res.end(JSON.stringify(statusJson()));
    return;
  }
  let rel;
  try { rel = decodeURIComponent(url.pathname).slice(1) || 'index.html'; } catch { rel = null; }
  const full = rel === null || rel.includes('\0') ? null : path.resolve(webRoot, rel);
  if (!full || !full.startsWith(webRoot + path.sep) || !fs.existsSync(full) || !fs.statSync(full).isFile()) {
    res.writeHead(404, { ...headers, 'Content-Type': 'text/plain' });
    res.end('not found\n');
    return;
  }
  if (fromQuery && (rel === 'index.html')) {
    headers['Set-Cookie'] = `vog_token=${opt.token}; HttpOnly; SameSite=Strict; Path=/`;
  }
  res.writeHead(200, { ...headers, 'Content-Type': TYPES[path.extname(full)] || 'application/octet-stream' });
  if (req.method === 'HEAD') res.end(); else fs.createReadStream(full).pipe(res);
});

// ------------------------------------------------------------------------------------------ WebSocket

const wss = new WebSocketServer({ noServer: true, maxPayload: 64 * 1024 });
const pages = new Map(); // ws -> {free}

server.on('upgrade', (req, socket, head) => {
  const url = new URL(req.url, 'http://x');
  const refuse = (code, text) => {
    socket.end(`HTTP/1.1 ${code}\r\nContent-Type: text/plain\r\nConnection: close\r\n\r\n${text}\n`);
  };
  if (url.pathname !== '/ws') return refuse('404 Not Found', 'no WebSocket here; use /ws');
  if (!tokenOk(req, url)[0]) return refuse('401 Unauthorized', 'vog-console: the token is missing or wrong');
  const origin = req.headers.origin;
  if (origin && origin.replace(/^[a-z]+:\/\//, '') !== req.headers.host) {
    return refuse('403 Forbidden', `vog-console: a page from ${origin} may not open this console's WebSocket`);
  }
  wss.handleUpgrade(req, socket, head, (ws) => onPage(ws));
});

function sendText(ws, obj) { if (ws.readyState === 1) ws.send(JSON.stringify(obj)); }
function broadcastText(obj) { const s = JSON.stringify(obj); for (const ws of pages.keys()) if (ws.readyState === 1) ws.send(s); }
function sendAll(ws, reset) {
  const page = pages.get(ws);
  for (const m of encodeVoxelMessages([...blocks.values()], reset, page.free)) if (ws.readyState === 1) ws.send(m);
}

function graphFull() {
  return { type: 'graph', version: graphVersion, full: true, submaps: [...bases.values()], closures };
}

function onPage(ws) {
  pages.set(ws, { free: false });
  sendText(ws, { type: 'hello', protocol: 1, controls, controls_reason: controlsReason, server: 'vog-console-mock' });
  sendText(ws, { type: 'link', state: 'connected', detail: 'synthetic vehicle', host: 'mock:29600' });
  sendText(ws, statusJson());
  sendText(ws, { type: 'path', points: path_ });
  sendText(ws, { type: 'waypoints', items: waypoints });
  sendText(ws, graphFull());
  sendText(ws, { type: 'events', items: events });
  sendAll(ws, true);
  ws.on('message', (data, isBinary) => {
    if (isBinary) return sendText(ws, { type: 'error', text: 'binary messages are not accepted' });
    let m;
    try { m = JSON.parse(data.toString('utf8')); } catch (e) {
      return sendText(ws, { type: 'error', text: 'not JSON: ' + e.message });
    }
    if (!m || typeof m !== 'object' || Array.isArray(m)) return sendText(ws, { type: 'error', text: 'not a JSON object' });
    if (m.type === 'view') {
      if (typeof m.free !== 'boolean') return sendText(ws, { type: 'error', text: 'view: "free" must be a boolean' });
      const page = pages.get(ws);
      if (page.free === m.free) return;
      page.free = m.free;
      return sendAll(ws, true);
    }
    if (m.type !== 'command') return sendText(ws, { type: 'error', text: `unknown message type "${m.type}"` });
    if (!Number.isInteger(m.id)) return sendText(ws, { type: 'error', text: 'command without an integer "id"' });
    const known = ['start', 'pause', 'resume', 'return_home', 'abort', 'set_box'];
    if (!known.includes(m.command)) {
      return sendText(ws, { type: 'reply', id: m.id, ok: false, text: `unknown command "${m.command}"` });
    }
    if (!controls) return sendText(ws, { type: 'reply', id: m.id, ok: false, text: 'the controls are off: ' + controlsReason });
    const [ok, text] = runCommand(m);
    sendText(ws, { type: 'reply', id: m.id, ok, text });
  });
  ws.on('close', () => pages.delete(ws));
  ws.on('error', () => pages.delete(ws));
}

// ------------------------------------------------------------------------------------------ the simulation

function broadcastDelta(changed) {
  if (changed.size === 0) return;
  mapVersion++;
  const list = entriesFor(changed);
  for (const [ws, page] of pages) {
    for (const m of encodeVoxelMessages(list, false, page.free)) if (ws.readyState === 1) ws.send(m);
  }
}

// The pillar grows a layer every 0.5 s; the buoy drifts.
let buoyT = 0;
setInterval(() => {
  const changed = new Set();
  if (pillarLayers < PILLAR.maxLayers) addPillarLayer(pillarLayers++, changed);
  moveBuoy(buoyT++, changed);
  broadcastDelta(changed);
}, 500);

// Loop closure: everything shifts by a voxel, the whole map again as a reset.
if (opt.resetEvery > 0) {
  setInterval(() => {
    shift = shift === 0 ? 1 : 0;
    rebuildMap();
    mapVersion++;
    for (const ws of pages.keys()) sendAll(ws, true);
    if (bases.size >= 2) {
      const ids = [...bases.keys()];
      const c = [ids[ids.length - 1], ids[0]];
      closures.push(c);
      graphVersion++;
      for (const b of bases.values()) b.p = [b.p[0] + (shift ? RES : -RES), b.p[1], b.p[2]];
      broadcastText({ type: 'graph', version: graphVersion, full: false, submaps: [...bases.values()], closures: [c] });
    }
    event('info', `loop closure: the map moved ${shift ? '+' : '-'}${RES} m in x (${occupied} occupied voxels sent again)`);
  }, opt.resetEvery * 1000);
}

// The vehicle: 5 poses per second, orbiting while exploring or returning.
let lastWaypoint = 0;
let lastBase = 0;
setInterval(() => {
  const moving = missionState === 'exploring' || missionState === 'returning';
  if (moving) theta += 0.04;
  const R = 12;
  const z = 1.5 + 1.0 * Math.sin(theta * 0.5);
  const yaw = theta + Math.PI / 2;
  pose = { p: [R * Math.cos(theta), R * Math.sin(theta), z], q: [Math.cos(yaw / 2), 0, 0, Math.sin(yaw / 2)] };
  for (const d of devices) if (d.state !== 'disconnected') d.messages += 40;
  bytesReceived += 2000;
  if (moving) {
    path_.push(pose.p);
    if (path_.length > 20000) path_.shift();
  }
  broadcastText({
    type: 'pose', seq: ++poseSeq, stamp_ns: Number(stampNs()), published_unix_ms: Date.now(), p: pose.p, q: pose.q,
  });
  const now = Date.now();
  if (moving && now - lastWaypoint > 3000) {
    lastWaypoint = now;
    const a = theta + 0.6;
    const wy = a + Math.PI / 2;
    const w = { seq: ++wpSeq, p: [R * Math.cos(a), R * Math.sin(a), z], q: [Math.cos(wy / 2), 0, 0, Math.sin(wy / 2)], speed_mps: 0.5 };
    waypoints.push(w);
    if (waypoints.length > 500) waypoints.shift();
    broadcastText({ type: 'waypoint', ...w });
  }
  if (moving && now - lastBase > 8000) {
    lastBase = now;
    const b = { id: nextBase++, p: pose.p.slice(), q: pose.q.slice() };
    bases.set(b.id, b);
    graphVersion++;
    broadcastText({ type: 'graph', version: graphVersion, full: false, submaps: [b], closures: [] });
  }
}, 200);

// Status every second; now and then a device hiccup.
let tick = 0;
setInterval(() => {
  tick++;
  if (tick % 15 === 0) {
    const sonar = devices[2];
    if (sonar.state === 'ok') {
      sonar.state = 'degraded'; sonar.detail = 'ping timeouts'; sonar.errors++;
      event('warning', 'device sonar degraded: ping timeouts');
    } else {
      sonar.state = 'ok'; sonar.detail = 'multibeam 256 beams';
      event('info', 'device sonar ok');
    }
  }
  if (missionState === 'returning' && tick % 10 === 0) setMission('idle', 'home reached');
  broadcastText(statusJson());
}, 1000);

// ------------------------------------------------------------------------------------------ start

pillarLayers = 60; // the pillar is part built; it grows to PILLAR.maxLayers
rebuildMap();
event('info', 'link connected: synthetic vehicle');
server.listen(opt.port, opt.host, () => {
  const a = server.address();
  const host = a.family === 'IPv6' ? `[${a.address}]` : a.address;
  console.log(`listening http://${host}:${a.port}/`);
  if (opt.token) console.log(`open http://${host}:${a.port}/?token=${opt.token}`);
});
for (const sig of ['SIGINT', 'SIGTERM']) process.on(sig, () => process.exit(0));
