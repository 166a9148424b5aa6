// vog-console page: the live mission view. Protocol: client/console/README.md.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { VoxelStore, rampCss } from './voxels.js';
import { MissionScene } from './scene.js';

const RECONNECT_MS = 2000;
const VOXELS_PER_FRAME = 20000;
const MAX_EVENTS_SHOWN = 500;

const $ = (id) => document.getElementById(id);

// ------------------------------------------------------------------------------------------ 3D view

const host = $('canvas-host');
const renderer = new THREE.WebGLRenderer({ antialias: false, powerPreference: 'high-performance' });
renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
renderer.setClearColor(0x070a0e);
host.appendChild(renderer.domElement);

const scene = new THREE.Scene();
const camera = new THREE.PerspectiveCamera(55, 1, 0.05, 5000);
camera.up.set(0, 0, 1);
const controls = new OrbitControls(camera, renderer.domElement);
controls.enableDamping = false;
controls.screenSpacePanning = true;

scene.add(new THREE.HemisphereLight(0xdde8ff, 0x202830, 1.4));
const sun = new THREE.DirectionalLight(0xffffff, 1.6);
sun.position.set(0.4, -0.6, 1);
scene.add(sun);
const grid = new THREE.GridHelper(200, 100, 0x2a3a48, 0x16202a);
grid.rotation.x = Math.PI / 2; // XZ -> XY plane
scene.add(grid);
scene.add(new THREE.AxesHelper(2));

const voxels = new VoxelStore(scene, { budget: VOXELS_PER_FRAME });
voxels.setFov(camera.fov);
const mission = new MissionScene(scene);
let needsRender = true;

function resize() {
  const w = Math.max(host.clientWidth, 1), h = Math.max(host.clientHeight, 1);
  renderer.setSize(w, h, false);
  camera.aspect = w / h;
  camera.updateProjectionMatrix();
  needsRender = true;
}
window.addEventListener('resize', resize);
controls.addEventListener('change', () => { needsRender = true; });

function resetView() {
  let min, max;
  const b = voxels.bounds;
  if (voxels.occupiedCount > 0 && Number.isFinite(b.min[0])) {
    min = b.min; max = b.max;
  } else if (mission.boxValue) {
    min = mission.boxValue.min; max = mission.boxValue.max;
  } else if (mission.pose) {
    const p = mission.pose.p;
    min = [p[0] - 10, p[1] - 10, p[2] - 5]; max = [p[0] + 10, p[1] + 10, p[2] + 5];
  } else {
    min = [-10, -10, -5]; max = [10, 10, 5];
  }
  const c = new THREE.Vector3((min[0] + max[0]) / 2, (min[1] + max[1]) / 2, (min[2] + max[2]) / 2);
  const r = Math.max(2, 0.5 * Math.hypot(max[0] - min[0], max[1] - min[1], max[2] - min[2]));
  const d = r / Math.sin(THREE.MathUtils.degToRad(camera.fov / 2)) * 0.9;
  controls.target.copy(c);
  camera.position.copy(c).add(new THREE.Vector3(-0.55, -0.75, 0.55).normalize().multiplyScalar(d));
  camera.near = Math.max(0.01, d / 1000);
  camera.far = d * 20 + 1000;
  camera.updateProjectionMatrix();
  controls.update();
  needsRender = true;
}
let viewFitted = false;

$('btn-reset-view').addEventListener('click', resetView);
$('legend-bar').style.background = rampCss();

// ------------------------------------------------------------------------------------------ panels

const state = {
  link: 'connecting', // the page's WebSocket
  hello: null,
  controls: false,
  controlsReason: 'not connected',
  status: null,
  lastReply: null,
  poseLatencyMs: null,
  pendingPoseStamp: null,
};

function setText(id, v) {
  const el = $(id);
  const s = v === undefined || v === null ? '–' : String(v);
  if (el.textContent !== s) el.textContent = s;
}

function setBadge(id, value) {
  const el = $(id);
  el.textContent = value;
  el.className = 'badge ' + value;
}

function fmt(n, d = 2) { return Number.isFinite(n) ? n.toFixed(d) : '–'; }

function setLinkState(s) {
  state.link = s;
  setBadge('link-state', s);
  updateControls();
}

const eventsEl = $('events');
function addEvent(ev, cls) {
  const li = document.createElement('li');
  const level = ['info', 'warning', 'error'].includes(ev.level) ? ev.level : 'info';
  li.className = level + (cls ? ' ' + cls : '');
  const t = document.createElement('span');
  t.className = 't';
  const d = Number.isFinite(ev.unix_ms) ? new Date(ev.unix_ms) : new Date();
  t.textContent = d.toLocaleTimeString([], { hour12: false });
  li.appendChild(t);
  li.appendChild(document.createTextNode(String(ev.text ?? '')));
  eventsEl.insertBefore(li, eventsEl.firstChild);
  while (eventsEl.childElementCount > MAX_EVENTS_SHOWN) eventsEl.removeChild(eventsEl.lastChild);
}
function localEvent(level, text, cls) { addEvent({ unix_ms: Date.now(), level, text }, cls); }

function renderDevices(devices) {
  const tbody = $('devices').tBodies[0];
  const rows = [];
  for (const d of devices || []) {
    const tr = document.createElement('tr');
    const st = ['ok', 'degraded', 'failed', 'disconnected'].includes(d.state) ? d.state : 'disconnected';
    tr.className = st;
    const cells = [
      ['name', d.name], ['state', d.state], ['detail', d.detail],
      ['num', `${d.messages ?? 0} msg / ${d.errors ?? 0} err`],
    ];
    for (const [cls, v] of cells) {
      const td = document.createElement('td');
      td.className = cls;
      td.textContent = v ?? '';
      tr.appendChild(td);
    }
    tr.dataset.device = d.name ?? '';
    rows.push(tr);
  }
  tbody.replaceChildren(...rows);
}

const BOX_IDS = ['box-min-x', 'box-min-y', 'box-min-z', 'box-max-x', 'box-max-y', 'box-max-z'];
const boxEdited = new Set();
for (const id of BOX_IDS) $(id).addEventListener('input', () => boxEdited.add(id));

function prefillBox(box) {
  if (!box || !Array.isArray(box.min) || !Array.isArray(box.max)) return;
  const v = [...box.min, ...box.max];
  BOX_IDS.forEach((id, i) => {
    const el = $(id);
    if (boxEdited.has(id) || document.activeElement === el) return;
    if (Number.isFinite(v[i])) el.value = String(v[i]);
  });
}

// The box from the inputs: {min, max}, null when all are empty, or a string saying what is wrong.
function readBox() {
  const raw = BOX_IDS.map((id) => $(id).value.trim());
  if (raw.every((s) => s === '')) return null;
  const v = raw.map(Number);
  if (raw.some((s) => s === '') || !v.every(Number.isFinite)) return 'fill all six box fields with numbers';
  const box = { min: v.slice(0, 3), max: v.slice(3) };
  for (let i = 0; i < 3; i++) if (!(box.min[i] < box.max[i])) return `box min ${'xyz'[i]} must be below max ${'xyz'[i]}`;
  return box;
}

function applyStatus(s) {
  state.status = s;
  setText('mission-state', s.mission_state);
  setText('planner-state', s.planner_state);
  setText('n-submaps', s.n_submaps);
  setText('n-closures', s.n_closures);
  setText('map-version', s.map_version);
  setText('graph-version', s.graph_version);
  if (s.pose) {
    if (mission.setPose(s.pose.p, s.pose.q, s.stamp_ns, false)) needsRender = true;
  }
  if (Array.isArray(s.sigma_xyz_m)) {
    mission.setSigma(s.sigma_xyz_m);
    setText('sigma-text', `${s.sigma_xyz_m.map((x) => fmt(x, 2)).join(' ')} m / ${fmt(s.sigma_yaw_rad, 3)} rad`);
    needsRender = true;
  }
  if ('box' in s) {
    mission.setBox(s.box);
    prefillBox(s.box);
    needsRender = true;
  }
  if (Array.isArray(s.devices)) renderDevices(s.devices);
  showPose();
}

function showPose() {
  const p = mission.pose;
  if (!p) return;
  const e = new THREE.Euler().setFromQuaternion(mission.vehicle.quaternion, 'ZYX');
  setText('pose-text', `${p.p.map((x) => fmt(x, 2)).join(', ')}  yaw ${fmt(THREE.MathUtils.radToDeg(e.z), 0)}°`);
}

// ------------------------------------------------------------------------------------------ controls

const CONTROL_IDS = ['btn-start', 'btn-pause', 'btn-resume', 'btn-home', 'btn-abort', 'btn-set-box', ...BOX_IDS];

function controlsEnabled() { return state.link === 'connected' && state.controls === true; }

function updateControls() {
  const on = controlsEnabled();
  for (const id of CONTROL_IDS) $(id).disabled = !on;
  let reason = '';
  if (state.link !== 'connected') reason = 'Controls off: the page is not connected to the console';
  else if (!state.controls) reason = 'Controls off: ' + (state.controlsReason || 'no operator rights');
  setText('controls-reason', reason);
  if (!reason) $('controls-reason').textContent = '';
  if (!on) hideModal();
}

let nextCommandId = 1;
const pendingCommands = new Map(); // id -> command name

function sendCommand(command, extra = {}) {
  if (!controlsEnabled()) return;
  const id = nextCommandId++;
  const msg = { type: 'command', id, command, ...extra };
  pendingCommands.set(id, command);
  if (!sendJson(msg)) {
    pendingCommands.delete(id);
    localEvent('error', `${command}: not sent, the page is not connected`, 'reply-refused');
    return;
  }
  localEvent('info', `→ ${command}` + (extra.box ? ` box [${extra.box.min}] .. [${extra.box.max}]` : '') + ` (#${id})`);
}

$('btn-start').addEventListener('click', () => {
  const box = readBox();
  if (typeof box === 'string') { localEvent('error', 'start: ' + box, 'reply-refused'); return; }
  sendCommand('start', box ? { box } : {});
  boxEdited.clear();
});
$('btn-pause').addEventListener('click', () => sendCommand('pause'));
$('btn-resume').addEventListener('click', () => sendCommand('resume'));
$('btn-home').addEventListener('click', () => sendCommand('return_home'));
$('btn-set-box').addEventListener('click', () => {
  const box = readBox();
  if (box === null || typeof box === 'string') {
    localEvent('error', 'set box: ' + (box ?? 'fill all six box fields'), 'reply-refused');
    return;
  }
  sendCommand('set_box', { box });
  boxEdited.clear();
});

const modal = $('modal');
function hideModal() { modal.classList.add('hidden'); }
$('btn-abort').addEventListener('click', () => {
  if (!controlsEnabled()) return;
  modal.classList.remove('hidden');
  $('btn-abort-cancel').focus();
});
$('btn-abort-cancel').addEventListener('click', hideModal);
$('btn-abort-confirm').addEventListener('click', () => { hideModal(); sendCommand('abort'); });
window.addEventListener('keydown', (e) => { if (e.key === 'Escape') hideModal(); });

// Voxel drawing: 'auto' draws cubes and falls back to points when frames that draw take too long
// (software rendering); the choice is the operator's otherwise.
let voxelMode = 'auto';
let slowDraws = 0;
$('voxel-mode').addEventListener('change', (e) => {
  voxelMode = e.target.value;
  voxels.setMode(voxelMode === 'points' ? 'points' : 'cubes');
  slowDraws = 0;
  needsRender = true;
});
// How long this machine takes to draw a cube, measured once at start (also compiles the voxel shaders):
// 0 when it is fast (a GPU), else milliseconds per cube (software rendering).
let cubeCostMs = 0;
function probeDrawCost() {
  const n = 2000;
  const probe = new THREE.InstancedMesh(voxels.cubeGeometry, voxels.cubeMaterial, n);
  probe.frustumCulled = false;
  const m = new THREE.Matrix4();
  const dir = new THREE.Vector3();
  camera.getWorldDirection(dir);
  const c = camera.position.clone().addScaledVector(dir, 10);
  // small cubes: the cost of their vertices, not of filling the view
  for (let i = 0; i < n; i++) {
    m.makeScale(0.01, 0.01, 0.01).setPosition(c.x + ((i % 50) - 25) * 0.02, c.y + (Math.floor(i / 50) - 20) * 0.02, c.z);
    probe.setMatrixAt(i, m);
  }
  const g = renderer.getContext();
  const px = new Uint8Array(4);
  const time = () => {
    const t = performance.now();
    renderer.render(scene, camera);
    g.readPixels(0, 0, 1, 1, g.RGBA, g.UNSIGNED_BYTE, px);
    return performance.now() - t;
  };
  // compile every program now (software GL takes long; hidden objects would compile on first show)
  const hidden = [];
  scene.traverse((o) => { if (!o.visible) { hidden.push(o); o.visible = true; } });
  renderer.compile(scene, camera);
  time();
  for (const o of hidden) o.visible = false;
  const base = Math.min(time(), time());
  scene.add(probe);
  time(); // compiles
  const t = Math.min(time(), time());
  scene.remove(probe);
  probe.dispose();
  const extra = t - base;
  cubeCostMs = extra > 5 ? extra / n : 0;
  return { baseMs: base, cubesMs: t, cubeCostMs };
}

// Auto mode: points when the whole map as cubes would take too long to draw here.
function chooseVoxelMode(expected) {
  if (voxelMode !== 'auto' || voxels.mode !== 'cubes' || cubeCostMs === 0) return;
  const ms = cubeCostMs * expected;
  if (ms > 60) {
    voxels.setMode('points');
    localEvent('info', `drawing voxels as points: ${expected} cubes would take about ${ms.toFixed(0)} ms a frame here`);
    needsRender = true;
  }
}

function noteDrawCost(ms) {
  if (voxelMode !== 'auto' || voxels.mode !== 'cubes') return;
  if (ms > 90 && voxels.occupiedCount > 20000) slowDraws++; else slowDraws = Math.max(0, slowDraws - 1);
  if (slowDraws >= 3 || (ms > 250 && voxels.occupiedCount > 5000)) {
    voxels.setMode('points');
    localEvent('info', `drawing voxels as points: cubes took ${ms.toFixed(0)} ms a frame here`);
    $('voxel-mode').title = 'auto: drawing points (cubes were too slow on this machine)';
    needsRender = true;
  }
}

$('toggle-free').addEventListener('change', (e) => {
  const on = e.target.checked;
  voxels.setShowFree(on);
  sendJson({ type: 'view', free: on });
  needsRender = true;
});

// ------------------------------------------------------------------------------------------ the socket

let ws = null;
let reconnectTimer = null;
let nOpened = 0;
let nClosed = 0;

function wsUrl() {
  const proto = location.protocol === 'https:' ? 'wss:' : 'ws:';
  const token = new URLSearchParams(location.search).get('token');
  return `${proto}//${location.host}/ws` + (token ? `?token=${encodeURIComponent(token)}` : '');
}

function sendJson(obj) { return sendRaw(JSON.stringify(obj)); }
function sendRaw(text) {
  if (!ws || ws.readyState !== WebSocket.OPEN) return false;
  ws.send(text);
  return true;
}

function connect() {
  reconnectTimer = null;
  setLinkState('connecting');
  let sock;
  try {
    sock = new WebSocket(wsUrl());
  } catch (e) {
    localEvent('error', 'WebSocket: ' + e.message);
    scheduleReconnect();
    return;
  }
  sock.binaryType = 'arraybuffer';
  ws = sock;
  sock.onopen = () => {
    if (ws !== sock) return;
    nOpened++;
    voxels.dropPending(); // the console starts this page over with a full map (a reset)
    setLinkState('connected');
    if (voxels.showFree) sendJson({ type: 'view', free: true });
  };
  sock.onmessage = (e) => {
    if (ws !== sock) return;
    if (typeof e.data === 'string') onText(e.data);
    else onBinary(e.data);
  };
  sock.onclose = (e) => {
    if (ws !== sock) return;
    ws = null;
    nClosed++;
    state.hello = null;
    state.controls = false;
    setLinkState('disconnected');
    localEvent('warning', `page link closed (${e.code}${e.reason ? ': ' + e.reason : ''}); reconnecting in ${RECONNECT_MS / 1000} s`);
    scheduleReconnect();
  };
  sock.onerror = () => { /* onclose follows */ };
}

function scheduleReconnect() {
  if (reconnectTimer === null) reconnectTimer = setTimeout(connect, RECONNECT_MS);
}

function onBinary(buf) {
  try {
    const h = voxels.enqueue(buf);
    chooseVoxelMode(Math.max(h.totalOccupied, voxels.occupiedCount));
  } catch (e) {
    localEvent('error', 'voxel message dropped: ' + e.message);
  }
}

function onText(text) {
  let m;
  try {
    m = JSON.parse(text);
  } catch (e) {
    localEvent('error', 'unreadable message from the console: ' + e.message);
    return;
  }
  if (!m || typeof m !== 'object') return;
  switch (m.type) {
    case 'hello':
      state.hello = m;
      state.controls = m.controls === true;
      state.controlsReason = m.controls_reason || '';
      if (m.protocol !== 1) localEvent('warning', `console speaks protocol ${m.protocol}; this page speaks 1`);
      updateControls();
      break;
    case 'link':
      setBadge('vogd-link', m.state || '–');
      setText('vogd-host', [m.host, m.detail !== m.host ? m.detail : ''].filter(Boolean).join(' — '));
      break;
    case 'status':
      applyStatus(m);
      break;
    case 'pose':
      if (mission.setPose(m.p, m.q, m.stamp_ns, true)) {
        needsRender = true;
        state.pendingPoseStamp = m.published_unix_ms;
        showPose();
      }
      break;
    case 'path':
      mission.setPath(m.points);
      needsRender = true;
      break;
    case 'waypoint':
      mission.setWaypoints([m], false);
      needsRender = true;
      break;
    case 'waypoints':
      mission.setWaypoints(m.items, true);
      needsRender = true;
      break;
    case 'graph':
      mission.applyGraph(m);
      if (Number.isFinite(m.version)) setText('graph-version', m.version);
      needsRender = true;
      break;
    case 'event':
      addEvent(m);
      break;
    case 'events':
      eventsEl.replaceChildren();
      for (const ev of m.items || []) addEvent(ev);
      break;
    case 'reply': {
      state.lastReply = m;
      const name = pendingCommands.get(m.id) ?? 'command';
      pendingCommands.delete(m.id);
      if (m.ok) localEvent('info', `✓ ${name} (#${m.id}): ${m.text ?? ''}`, 'reply-ok');
      else localEvent('error', `✗ ${name} refused (#${m.id}): ${m.text ?? ''}`, 'reply-refused');
      break;
    }
    case 'error':
      state.lastError = m;
      localEvent('error', 'console refused a page message: ' + (m.text ?? ''), 'reply-refused');
      break;
    default:
      break;
  }
}

// ------------------------------------------------------------------------------------------ the frame loop

const frameIntervals = [];
const MAX_FRAME_SAMPLES = 5000;
const startedAt = performance.now();
let lastFrame = null;
let maxFrameMs = 0;
const poseLatencies = []; // ms from vogd publishing a pose to the frame that drew it
let fpsCount = 0, fpsAt = performance.now();
let lastResolution = 0;
let lastInterval = null;
const slowFrames = []; // the frames that took long, and what the frame before them did
let lastApplied = 0;
let renderedLast = false;
let lastDrawAt = -Infinity;
let drawCost = 0; // the interval of the last frame that drew

function frame(now) {
  requestAnimationFrame(frame);
  lastInterval = lastFrame === null ? null : now - lastFrame;
  if (lastFrame !== null && now - startedAt > 1000) {
    const dt = now - lastFrame;
    frameIntervals.push(dt);
    if (frameIntervals.length > MAX_FRAME_SAMPLES) frameIntervals.shift();
    if (dt > maxFrameMs) maxFrameMs = dt;
    if (dt > 150) slowFrames.push({ at: Math.round(now - startedAt), ms: Math.round(dt), drew: renderedLast, applied: lastApplied, n: voxels.occupiedCount, mode: voxels.mode });
    if (slowFrames.length > 50) slowFrames.shift();
  }
  lastFrame = now;

  const appliedBefore = voxels.occupiedCount;
  const stepped = voxels.step();
  lastApplied = voxels.occupiedCount - appliedBefore;
  if (stepped) {
    needsRender = true;
    setText('occupied-count', voxels.occupiedCount);
    setText('free-count', voxels.freeCount);
    if (voxels.rangeChanged && voxels.zRange) {
      setText('legend-min', fmt(voxels.zRange[0], 1) + ' m');
      setText('legend-max', fmt(voxels.zRange[1], 1) + ' m');
      voxels.rangeChanged = false;
    }
    if (voxels.resolution !== lastResolution) {
      lastResolution = voxels.resolution;
      mission.setScale(lastResolution);
    }
    if (!viewFitted && voxels.pendingMessages === 0 && voxels.occupiedCount > 0) { viewFitted = true; resetView(); }
  }
  // the vehicle stays visible from afar: at least ~3% of the view's depth
  if (mission.pose) {
    const want = Math.max(mission.baseScale, camera.position.distanceTo(mission.vehicle.position) * 0.04);
    if (Math.abs(want - mission.vehicle.scale.x) > 0.05 * want) { mission.vehicle.scale.setScalar(want); needsRender = true; }
  }
  if (Number.isFinite(voxels.bounds.min[2]) && Math.abs(grid.position.z - (voxels.bounds.min[2] - 0.5)) > 0.5) {
    grid.position.z = voxels.bounds.min[2] - 0.5; // under the map
    needsRender = true;
  }
  if ($('toggle-follow').checked && mission.pose) {
    const p = mission.vehicle.position;
    const d = p.clone().sub(controls.target);
    if (d.lengthSq() > 1e-6) { controls.target.add(d); camera.position.add(d); controls.update(); needsRender = true; }
  }
  if (renderedLast && lastInterval !== null) {
    drawCost = lastInterval;
    noteDrawCost(lastInterval);
  }
  renderedLast = false;
  // A slow machine draws at most a third of the time, so the page stays responsive.
  if (needsRender && now - lastDrawAt >= 2 * Math.max(0, drawCost - 20)) {
    needsRender = false;
    renderedLast = true;
    lastDrawAt = now;
    renderer.render(scene, camera);
    if (state.pendingPoseStamp) {
      state.poseLatencyMs = Math.round(Date.now() - state.pendingPoseStamp);
      poseLatencies.push(Date.now() - state.pendingPoseStamp);
      if (poseLatencies.length > 100000) poseLatencies.shift();
      state.pendingPoseStamp = null;
      setText('pose-latency', `${state.poseLatencyMs} ms`);
    }
  }
  fpsCount++;
  if (now - fpsAt > 1000) {
    setText('fps', `${Math.round(fpsCount * 1000 / (now - fpsAt))} fps · max frame ${maxFrameMs.toFixed(0)} ms`);
    fpsCount = 0; fpsAt = now;
  }
}

// ------------------------------------------------------------------------------------------ test hook

window.vogConsole = {
  occupiedCount: () => voxels.occupiedCount,
  voxelMode: () => voxels.mode,
  drawProbe: () => probeResult,
  freeCount: () => voxels.freeCount,
  pendingMessages: () => voxels.pendingMessages,
  mapVersion: () => voxels.mapVersion,
  totalOccupied: () => voxels.totalOccupied,
  vehicle: mission.vehicle,
  linkState: () => state.link,
  controlsEnabled,
  lastReply: () => state.lastReply,
  lastError: () => state.lastError ?? null,
  send: (obj) => sendJson(obj),
  sendRaw: (s) => sendRaw(s),
  connections: () => nOpened,
  disconnects: () => nClosed,
  maxFrameMs: () => maxFrameMs,
  frameTimes: () => frameIntervals.slice(),
  slowFrames: () => slowFrames.slice(),
  poseLatencyMs: () => state.poseLatencyMs,
  poseLatencies: () => poseLatencies.slice(),
  verifyVoxels: () => voxels.verify(),
  renderer,
  camera,
  scene,
  resetView,
  // Draws one frame now and waits for the GPU: milliseconds (a diagnostic for slow machines).
  renderMs: () => {
    const t = performance.now();
    renderer.render(scene, camera);
    const g = renderer.getContext();
    g.readPixels(0, 0, 1, 1, g.RGBA, g.UNSIGNED_BYTE, new Uint8Array(4));
    return performance.now() - t;
  },
};

voxels.onError = (e) => localEvent('error', 'voxel message: ' + e.message);
resize();
resetView();
let probeResult = null;
try { probeResult = probeDrawCost(); } catch (e) { probeResult = { error: String(e) }; }
updateControls();
connect();
requestAnimationFrame(frame);
