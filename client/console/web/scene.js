// The 3D view besides the voxels: the vehicle, its path, the waypoints, the exploration box, the submap
// bases and the loop closures. World frame: z up.
import * as THREE from 'three';

// Protocol quaternions are [w, x, y, z].
export function quatFromWxyz(q, out = new THREE.Quaternion()) {
  if (!Array.isArray(q) || q.length !== 4) return out.identity();
  out.set(q[1], q[2], q[3], q[0]);
  if (out.lengthSq() < 1e-12) return out.identity();
  return out.normalize();
}

// A growable line strip.
class GrowLine {
  constructor(color, opacity = 1) {
    this.capacity = 1024;
    this.count = 0;
    this.geometry = new THREE.BufferGeometry();
    this.attr = new THREE.BufferAttribute(new Float32Array(this.capacity * 3), 3);
    this.attr.setUsage(THREE.DynamicDrawUsage);
    this.geometry.setAttribute('position', this.attr);
    this.geometry.setDrawRange(0, 0);
    this.object = new THREE.Line(this.geometry,
      new THREE.LineBasicMaterial({ color, transparent: opacity < 1, opacity }));
    this.object.frustumCulled = false;
  }

  clear() { this.count = 0; this.geometry.setDrawRange(0, 0); }

  push(p) {
    if (this.count >= this.capacity) {
      this.capacity *= 2;
      const a = new Float32Array(this.capacity * 3);
      a.set(this.attr.array);
      this.attr = new THREE.BufferAttribute(a, 3);
      this.attr.setUsage(THREE.DynamicDrawUsage);
      this.geometry.setAttribute('position', this.attr);
    }
    const a = this.attr.array, o = this.count * 3;
    a[o] = p[0]; a[o + 1] = p[1]; a[o + 2] = p[2];
    this.count++;
    this.geometry.setDrawRange(0, this.count);
    this.attr.needsUpdate = true;
  }

  last() {
    if (this.count === 0) return null;
    const a = this.attr.array, o = (this.count - 1) * 3;
    return [a[o], a[o + 1], a[o + 2]];
  }
}

export class MissionScene {
  constructor(scene) {
    this.scene = scene;

    // The vehicle: a cone along its +x (heading) with a small mast, and the position sigma ellipsoid.
    const vehicle = new THREE.Group();
    vehicle.name = 'vehicle';
    const body = new THREE.Mesh(new THREE.ConeGeometry(0.35, 1.2, 16),
      new THREE.MeshLambertMaterial({ color: 0xff8c1a, emissive: 0x552200 }));
    body.rotation.z = -Math.PI / 2; // cone axis +y -> +x
    vehicle.add(body);
    const mast = new THREE.Mesh(new THREE.CylinderGeometry(0.04, 0.04, 0.6, 6),
      new THREE.MeshBasicMaterial({ color: 0xffffff }));
    mast.rotation.x = Math.PI / 2; // along z
    mast.position.set(-0.2, 0, 0.3);
    vehicle.add(mast);
    // drawn over the map: the operator always sees where the vehicle is
    vehicle.traverse((o) => { if (o.material) { o.material.depthTest = false; o.renderOrder = 10; } });
    vehicle.visible = false;
    this.vehicle = vehicle;
    scene.add(vehicle);

    this.sigma = new THREE.Mesh(new THREE.SphereGeometry(1, 24, 16),
      new THREE.MeshBasicMaterial({ color: 0xffc266, transparent: true, opacity: 0.18, depthWrite: false }));
    this.sigma.visible = false;
    scene.add(this.sigma);

    this.path = new GrowLine(0xffd27f, 0.9);
    scene.add(this.path.object);

    // Waypoints: dots and the line through them, ordered by seq.
    this.waypoints = new Map();
    this.wpLine = new THREE.Line(new THREE.BufferGeometry(), new THREE.LineDashedMaterial({
      color: 0xd070ff, dashSize: 0.4, gapSize: 0.25 }));
    this.wpLine.frustumCulled = false;
    this.wpPoints = new THREE.Points(new THREE.BufferGeometry(),
      new THREE.PointsMaterial({ color: 0xe59cff, size: 7, sizeAttenuation: false }));
    this.wpPoints.frustumCulled = false;
    scene.add(this.wpLine, this.wpPoints);

    // The exploration box.
    this.box = new THREE.LineSegments(new THREE.EdgesGeometry(new THREE.BoxGeometry(1, 1, 1)),
      new THREE.LineBasicMaterial({ color: 0x55c8ff }));
    this.box.visible = false;
    this.boxValue = null;
    scene.add(this.box);

    // Submap bases (dots + small axes) and loop closures.
    this.bases = new Map(); // id -> {p, q}
    this.closures = []; // [from, to]
    this.closureKeys = new Set();
    this.baseDots = new THREE.Points(new THREE.BufferGeometry(),
      new THREE.PointsMaterial({ color: 0xffffff, size: 5, sizeAttenuation: false }));
    this.baseAxes = new THREE.LineSegments(new THREE.BufferGeometry(),
      new THREE.LineBasicMaterial({ vertexColors: true }));
    this.closureLines = new THREE.LineSegments(new THREE.BufferGeometry(),
      new THREE.LineBasicMaterial({ color: 0x39ff88, transparent: true, opacity: 0.85 }));
    for (const o of [this.baseDots, this.baseAxes, this.closureLines]) { o.frustumCulled = false; scene.add(o); }
    this.axisLength = 0.8;

    this.baseScale = 1;
    this.pose = null; // {p, q, stamp_ns}
    this.sigmaXyz = null;
  }

  setScale(resolution) {
    const s = Math.max(0.6, resolution * 6);
    this.baseScale = s;
    this.vehicle.scale.setScalar(s);
    this.axisLength = s;
    this.rebuildGraph();
  }

  // A pose: [x,y,z], [w,x,y,z]. Extends the path when `extend`.
  setPose(p, q, stampNs, extend) {
    if (!Array.isArray(p) || p.length !== 3 || !p.every(Number.isFinite)) return false;
    if (this.pose && stampNs != null && this.pose.stamp_ns != null && stampNs < this.pose.stamp_ns) return false;
    this.pose = { p, q, stamp_ns: stampNs };
    this.vehicle.position.set(p[0], p[1], p[2]);
    quatFromWxyz(q, this.vehicle.quaternion);
    this.vehicle.visible = true;
    this.sigma.position.copy(this.vehicle.position);
    if (extend) {
      const l = this.path.last();
      if (!l || Math.hypot(l[0] - p[0], l[1] - p[1], l[2] - p[2]) > 0.02) this.path.push(p);
    }
    this.updateSigma();
    return true;
  }

  setSigma(s) {
    if (Array.isArray(s) && s.length === 3 && s.every(Number.isFinite)) this.sigmaXyz = s;
    this.updateSigma();
  }

  updateSigma() {
    const s = this.sigmaXyz;
    if (!s || !this.pose) { this.sigma.visible = false; return; }
    const m = 0.02;
    this.sigma.scale.set(Math.max(s[0], m), Math.max(s[1], m), Math.max(s[2], m));
    this.sigma.visible = true;
  }

  setPath(points) {
    this.path.clear();
    if (!Array.isArray(points)) return;
    for (const p of points) if (Array.isArray(p) && p.length === 3) this.path.push(p);
    if (this.pose) this.path.push(this.pose.p);
  }

  setWaypoints(items, replace) {
    if (replace) this.waypoints.clear();
    for (const w of items || []) {
      if (w && Array.isArray(w.p) && w.p.length === 3) this.waypoints.set(w.seq ?? this.waypoints.size, w);
    }
    const list = [...this.waypoints.values()].sort((a, b) => (a.seq ?? 0) - (b.seq ?? 0));
    const pos = new Float32Array(list.length * 3);
    list.forEach((w, i) => pos.set(w.p, i * 3));
    for (const o of [this.wpLine, this.wpPoints]) {
      o.geometry.dispose();
      o.geometry = new THREE.BufferGeometry();
      o.geometry.setAttribute('position', new THREE.BufferAttribute(pos.slice(), 3));
    }
    this.wpLine.computeLineDistances();
  }

  setBox(box) {
    const ok = box && Array.isArray(box.min) && Array.isArray(box.max);
    this.boxValue = ok ? box : null;
    if (!ok) { this.box.visible = false; return; }
    const [a, b] = [box.min, box.max];
    this.box.position.set((a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2);
    this.box.scale.set(Math.max(b[0] - a[0], 1e-3), Math.max(b[1] - a[1], 1e-3), Math.max(b[2] - a[2], 1e-3));
    this.box.visible = true;
  }

  applyGraph(g) {
    if (g.full) { this.bases.clear(); this.closures = []; this.closureKeys.clear(); }
    for (const s of g.submaps || []) {
      if (s && Array.isArray(s.p)) this.bases.set(s.id, { p: s.p, q: s.q });
    }
    for (const c of g.closures || []) {
      if (!Array.isArray(c) || c.length !== 2) continue;
      const k = c[0] + '-' + c[1];
      if (this.closureKeys.has(k)) continue;
      this.closureKeys.add(k);
      this.closures.push(c);
    }
    this.rebuildGraph();
  }

  rebuildGraph() {
    const n = this.bases.size;
    const dots = new Float32Array(n * 3);
    const axes = new Float32Array(n * 18);
    const colors = new Float32Array(n * 18);
    const q = new THREE.Quaternion();
    const v = new THREE.Vector3();
    const L = this.axisLength;
    const rgb = [[1, 0.3, 0.3], [0.3, 1, 0.3], [0.4, 0.6, 1]];
    let i = 0;
    for (const { p, q: qq } of this.bases.values()) {
      dots.set(p, i * 3);
      quatFromWxyz(qq, q);
      for (let a = 0; a < 3; a++) {
        v.set(a === 0 ? L : 0, a === 1 ? L : 0, a === 2 ? L : 0).applyQuaternion(q);
        const o = i * 18 + a * 6;
        axes[o] = p[0]; axes[o + 1] = p[1]; axes[o + 2] = p[2];
        axes[o + 3] = p[0] + v.x; axes[o + 4] = p[1] + v.y; axes[o + 5] = p[2] + v.z;
        colors.set(rgb[a], o); colors.set(rgb[a], o + 3);
      }
      i++;
    }
    const lines = [];
    for (const [a, b] of this.closures) {
      const pa = this.bases.get(a), pb = this.bases.get(b);
      if (pa && pb) lines.push(...pa.p, ...pb.p);
    }
    const set = (obj, attrs) => {
      obj.geometry.dispose();
      obj.geometry = new THREE.BufferGeometry();
      for (const [name, arr] of attrs) obj.geometry.setAttribute(name, new THREE.BufferAttribute(arr, 3));
    };
    set(this.baseDots, [['position', dots]]);
    set(this.baseAxes, [['position', axes], ['color', colors]]);
    set(this.closureLines, [['position', new Float32Array(lines)]]);
  }
}
