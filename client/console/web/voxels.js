// The voxel blocks the page holds and their drawing.
//
// Binary messages ("VXL1", see client/console/README.md) are queued and applied in slices of at most
// `budget` voxels per animation frame. Each held block remembers the instance slots of its voxels; a slot
// freed by a replaced or removed block is filled by the last instance (swap-remove), so the instanced
// mesh stays dense and `.count` is the number of occupied voxels held.
import * as THREE from 'three';

export const VOXEL_MAGIC = 0x314c5856; // "VXL1"
export const FLAG_RESET = 1;
const HEADER_BYTES = 32;
const ENTRY_HEADER_BYTES = 16;
const EMPTY = new Int32Array(0);

// Parses the 32-byte header; throws on a malformed message.
export function parseVoxelHeader(buffer) {
  if (!(buffer instanceof ArrayBuffer) || buffer.byteLength < HEADER_BYTES) {
    throw new Error(`voxel message too short (${buffer.byteLength} bytes)`);
  }
  const dv = new DataView(buffer);
  const magic = dv.getUint32(0, true);
  if (magic !== VOXEL_MAGIC) throw new Error(`voxel message with bad magic 0x${magic.toString(16)}`);
  const flags = dv.getUint32(4, true);
  return {
    flags,
    reset: (flags & FLAG_RESET) !== 0,
    resolution: dv.getFloat64(8, true),
    mapVersion: dv.getFloat64(16, true),
    nBlocks: dv.getUint32(24, true),
    totalOccupied: dv.getUint32(28, true),
  };
}

// Height colour ramp (deep blue -> cyan -> green -> yellow -> red).
const RAMP = [
  [0.0, [0.18, 0.25, 0.75]],
  [0.25, [0.10, 0.65, 0.85]],
  [0.5, [0.25, 0.80, 0.35]],
  [0.75, [0.95, 0.85, 0.20]],
  [1.0, [0.90, 0.30, 0.20]],
];
export function rampColor(t, out, o) {
  if (!(t > 0)) t = 0; else if (t > 1) t = 1;
  let i = 1;
  while (i < RAMP.length - 1 && t > RAMP[i][0]) i++;
  const [t0, c0] = RAMP[i - 1];
  const [t1, c1] = RAMP[i];
  const u = (t - t0) / (t1 - t0);
  out[o] = c0[0] + (c1[0] - c0[0]) * u;
  out[o + 1] = c0[1] + (c1[1] - c0[1]) * u;
  out[o + 2] = c0[2] + (c1[2] - c0[2]) * u;
}
export function rampCss() {
  return 'linear-gradient(to right, ' + RAMP.map(([t, c]) =>
    `rgb(${Math.round(c[0] * 255)},${Math.round(c[1] * 255)},${Math.round(c[2] * 255)}) ${t * 100}%`).join(', ') + ')';
}

// A cube of edge `size` drawn with only the three faces that look at the camera: the geometry holds the
// +x, +y and +z faces and the vertex shader mirrors each instance towards the camera. Half the vertices
// and triangles of a full box; the faces are shaded by their axis (no lighting).
export function makeCubeGeometry(size) {
  const h = size / 2;
  const pos = [];
  const col = [];
  const shade = [0.78, 0.64, 1.0]; // x, y, z faces
  for (let axis = 0; axis < 3; axis++) {
    const u = (axis + 1) % 3, v = (axis + 2) % 3;
    for (const [a, b] of [[-1, -1], [1, -1], [1, 1], [-1, 1]]) {
      const p = [0, 0, 0];
      p[axis] = h; p[u] = a * h; p[v] = b * h;
      pos.push(...p);
      col.push(shade[axis], shade[axis], shade[axis]);
    }
  }
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.Float32BufferAttribute(pos, 3));
  g.setAttribute('color', new THREE.Float32BufferAttribute(col, 3));
  g.setIndex([0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7, 8, 9, 10, 8, 10, 11]);
  return g;
}

export function makeCubeMaterial() {
  const m = new THREE.MeshBasicMaterial({ color: 0xffffff, vertexColors: true, side: THREE.DoubleSide });
  m.onBeforeCompile = (shader) => {
    shader.vertexShader = shader.vertexShader.replace('#include <begin_vertex>', `#include <begin_vertex>
#ifdef USE_INSTANCING
  {
    vec3 towards = cameraPosition - (modelMatrix * instanceMatrix[3]).xyz;
    transformed *= vec3(towards.x < 0.0 ? -1.0 : 1.0, towards.y < 0.0 ? -1.0 : 1.0, towards.z < 0.0 ? -1.0 : 1.0);
  }
#endif`);
  };
  m.customProgramCacheKey = () => 'vog-voxel-cube-3face';
  return m;
}

// A dense pool of slots; each slot is owned by (block, index in block[field]).
class SlotPool {
  constructor(field, stride, capacity) {
    this.field = field; // 'occ' or 'free'
    this.stride = stride; // floats of position data per slot
    this.count = 0;
    this.capacity = 0;
    this.owner = [];
    this.ownerIdx = new Int32Array(0);
    this.pos = new Float32Array(0); // x,y,z per slot (centres)
    this.grow(capacity);
  }

  grow(capacity) {
    const idx = new Int32Array(capacity);
    idx.set(this.ownerIdx.subarray(0, this.count));
    this.ownerIdx = idx;
    const pos = new Float32Array(capacity * 3);
    pos.set(this.pos.subarray(0, this.count * 3));
    this.pos = pos;
    this.capacity = capacity;
  }

  clear() {
    this.count = 0;
    this.owner.length = 0;
  }
}

export class VoxelStore {
  constructor(scene, { budget = 20000 } = {}) {
    this.scene = scene;
    this.budget = budget;
    this.blocks = new Map(); // "bx,by,bz" -> {occ: Int32Array slots, free: Int32Array slots}
    this.queue = []; // {buffer, dv, header, offset, done}
    this.resolution = 0;
    this.mapVersion = null; // of the last fully applied message
    this.totalOccupied = null; // as announced by the last fully applied message
    this.applied = 0; // messages applied
    this.errors = 0;
    this.onError = null;
    this.onApplied = null;
    this.zRange = null; // [lo, hi] of the colour ramp
    this.bounds = { min: [Infinity, Infinity, Infinity], max: [-Infinity, -Infinity, -Infinity] };
    this.recolorAt = -1; // next slot to recolour (slices), -1 when done
    this.showFree = false;

    this.occ = new SlotPool('occ', 3, 4096);
    this.free = new SlotPool('free', 3, 4096);

    this.cubeGeometry = makeCubeGeometry(1);
    this.cubeMaterial = makeCubeMaterial();
    this.mesh = null;
    // The same voxels as square points: far fewer vertices, for machines that draw in software.
    this.occPointsGeometry = new THREE.BufferGeometry();
    this.occPoints = new THREE.Points(this.occPointsGeometry, new THREE.PointsMaterial({
      size: 1, sizeAttenuation: true, vertexColors: true }));
    this.occPoints.frustumCulled = false;
    this.occPoints.name = 'occupied-voxel-points';
    this.occPoints.visible = false;
    scene.add(this.occPoints);
    this.mode = 'cubes'; // or 'points'
    this.pointScale = 2; // size attenuation divides by the half-height of the view: 1 / tan(fov / 2)
    this.makeMesh(this.occ.capacity);

    this.pointsGeometry = new THREE.BufferGeometry();
    this.pointsMaterial = new THREE.PointsMaterial({
      color: 0x9fd3f5, size: 3, sizeAttenuation: false, transparent: true, opacity: 0.4, depthWrite: false,
    });
    this.points = new THREE.Points(this.pointsGeometry, this.pointsMaterial);
    this.points.frustumCulled = false;
    this.points.visible = false;
    this.freePosAttr = null;
    this.makePointsAttr();
    scene.add(this.points);
  }

  makeMesh(capacity) {
    const old = this.mesh;
    const mesh = new THREE.InstancedMesh(this.cubeGeometry, this.cubeMaterial, capacity);
    mesh.instanceMatrix.setUsage(THREE.DynamicDrawUsage);
    mesh.instanceColor = new THREE.InstancedBufferAttribute(new Float32Array(capacity * 3), 3);
    mesh.instanceColor.setUsage(THREE.DynamicDrawUsage);
    mesh.frustumCulled = false;
    mesh.name = 'occupied-voxels';
    if (old) {
      const n = this.occ.count;
      mesh.instanceMatrix.array.set(old.instanceMatrix.array.subarray(0, n * 16));
      mesh.instanceColor.array.set(old.instanceColor.array.subarray(0, n * 3));
      this.scene.remove(old);
      old.dispose();
    }
    mesh.count = this.occ.count;
    mesh.visible = this.mode === 'cubes';
    this.mesh = mesh;
    this.matrices = mesh.instanceMatrix.array;
    this.colors = mesh.instanceColor.array;
    this.dirtyLo = 0;
    this.dirtyHi = this.occ.count; // whole buffer uploads once after a growth
    this.scene.add(mesh);
    // the points share the slot positions and the instance colours
    this.occPointsPos = new THREE.BufferAttribute(this.occ.pos, 3);
    this.occPointsCol = new THREE.BufferAttribute(this.colors, 3);
    this.occPointsPos.setUsage(THREE.DynamicDrawUsage);
    this.occPointsCol.setUsage(THREE.DynamicDrawUsage);
    this.occPointsGeometry.setAttribute('position', this.occPointsPos);
    this.occPointsGeometry.setAttribute('color', this.occPointsCol);
    this.occPointsGeometry.setDrawRange(0, this.occ.count);
  }

  // Points as wide as a voxel for a camera of this vertical field of view (degrees).
  setFov(fovDeg) {
    this.pointScale = 1.05 / Math.tan((fovDeg * Math.PI) / 360);
    if (this.resolution > 0) this.occPoints.material.size = this.resolution * this.pointScale;
  }

  // 'cubes' (an instanced mesh) or 'points'.
  setMode(mode) {
    if (mode !== 'cubes' && mode !== 'points') return;
    if (mode === this.mode) return;
    this.mode = mode;
    this.mesh.visible = mode === 'cubes';
    this.occPoints.visible = mode === 'points';
    // the newly shown representation uploads in full
    for (const a of mode === 'cubes' ? [this.mesh.instanceMatrix, this.mesh.instanceColor]
      : [this.occPointsPos, this.occPointsCol]) {
      a.clearUpdateRanges();
      a.needsUpdate = true;
    }
  }

  makePointsAttr() {
    this.freePosAttr = new THREE.BufferAttribute(this.free.pos, 3);
    this.freePosAttr.setUsage(THREE.DynamicDrawUsage);
    this.pointsGeometry.setAttribute('position', this.freePosAttr);
    this.pointsGeometry.setDrawRange(0, this.free.count);
    this.freeDirty = true;
  }

  get occupiedCount() { return this.occ.count; }
  get freeCount() { return this.free.count; }
  get pendingMessages() { return this.queue.length; }

  setShowFree(on) {
    this.showFree = on;
    this.points.visible = on;
  }

  // Queues one binary message; returns its header. Throws if the header is malformed.
  enqueue(buffer) {
    const header = parseVoxelHeader(buffer);
    // a reset drops everything before it: the messages still pending would be cleared anyway
    if (header.reset) this.queue.length = 0;
    this.queue.push({ buffer, dv: new DataView(buffer), header, offset: HEADER_BYTES, done: 0, started: false });
    return header;
  }

  // Drops the messages not yet applied (a new connection starts over with a reset).
  dropPending() { this.queue.length = 0; }

  clearAll() {
    this.blocks.clear();
    this.occ.clear();
    this.free.clear();
    this.mesh.count = 0;
    this.pointsGeometry.setDrawRange(0, 0);
    this.bounds = { min: [Infinity, Infinity, Infinity], max: [-Infinity, -Infinity, -Infinity] };
  }

  // Applies queued messages until about `budget` voxels were touched. Returns whether anything changed.
  step(budget = this.budget) {
    if (this.queue.length === 0 && this.recolorAt < 0) return false;
    let work = 0;
    let changed = false;
    while (this.queue.length > 0 && work < budget) {
      const m = this.queue[0];
      if (!m.started) {
        m.started = true;
        if (m.header.reset) { this.clearAll(); changed = true; }
        if (m.header.resolution > 0 && m.header.resolution !== this.resolution) {
          if (this.resolution > 0 && this.blocks.size > 0) {
            // A resolution change needs every block again; the server sends a reset with it.
            this.clearAll();
          }
          this.resolution = m.header.resolution;
          this.cubeGeometry.dispose();
          this.cubeGeometry = makeCubeGeometry(this.resolution * 0.94);
          this.mesh.geometry = this.cubeGeometry;
          this.occPoints.material.size = this.resolution * this.pointScale;
        }
      }
      try {
        while (m.done < m.header.nBlocks && work < budget) {
          work += this.applyEntry(m);
          m.done++;
          changed = true;
        }
      } catch (e) {
        this.errors++;
        if (this.onError) this.onError(e);
        m.done = m.header.nBlocks;
      }
      if (m.done >= m.header.nBlocks) {
        this.queue.shift();
        this.mapVersion = m.header.mapVersion;
        this.totalOccupied = m.header.totalOccupied;
        this.applied++;
        if (this.onApplied) this.onApplied(m.header);
        work += 1;
      }
    }
    if (this.recolorAt >= 0 && work < budget) {
      this.recolorSlice(Math.max(20000, budget * 4));
      changed = true;
    }
    if (changed) this.flush();
    return changed;
  }

  applyEntry(m) {
    const dv = m.dv;
    let o = m.offset;
    if (o + ENTRY_HEADER_BYTES > dv.byteLength) throw new Error('voxel message truncated (entry header)');
    const bx = dv.getInt32(o, true);
    const by = dv.getInt32(o + 4, true);
    const bz = dv.getInt32(o + 8, true);
    const nOcc = dv.getUint16(o + 12, true);
    const nFree = dv.getUint16(o + 14, true);
    o += ENTRY_HEADER_BYTES;
    const n = nOcc + nFree;
    const end = o + 2 * n + (n % 2 === 1 ? 2 : 0);
    if (end > dv.byteLength) throw new Error('voxel message truncated (voxel indices)');
    const key = bx + ',' + by + ',' + bz;
    let work = 1;
    const old = this.blocks.get(key);
    if (old) {
      work += old.occ.length + old.free.length;
      this.release(this.occ, old, old.occ);
      this.release(this.free, old, old.free);
      this.blocks.delete(key);
    }
    if (n > 0) {
      const block = { key, occ: nOcc ? new Int32Array(nOcc) : EMPTY, free: nFree ? new Int32Array(nFree) : EMPTY };
      const r = this.resolution > 0 ? this.resolution : 1;
      const ox = bx * 8, oy = by * 8, oz = bz * 8;
      for (let k = 0; k < nOcc; k++) {
        const i = dv.getUint16(o + 2 * k, true);
        const x = (ox + (i & 7) + 0.5) * r, y = (oy + ((i >> 3) & 7) + 0.5) * r, z = (oz + (i >> 6) + 0.5) * r;
        block.occ[k] = this.addOccupied(block, k, x, y, z);
      }
      const f0 = o + 2 * nOcc;
      for (let k = 0; k < nFree; k++) {
        const i = dv.getUint16(f0 + 2 * k, true);
        const x = (ox + (i & 7) + 0.5) * r, y = (oy + ((i >> 3) & 7) + 0.5) * r, z = (oz + (i >> 6) + 0.5) * r;
        block.free[k] = this.addFree(block, k, x, y, z);
      }
      this.blocks.set(key, block);
      work += n;
    }
    m.offset = end;
    return work;
  }

  addOccupied(block, k, x, y, z) {
    const pool = this.occ;
    if (pool.count >= pool.capacity) {
      pool.grow(pool.capacity * 2);
      this.makeMesh(pool.capacity);
    }
    const s = pool.count++;
    pool.owner[s] = block;
    pool.ownerIdx[s] = k;
    pool.pos[s * 3] = x; pool.pos[s * 3 + 1] = y; pool.pos[s * 3 + 2] = z;
    const a = this.matrices, b = s * 16;
    a[b] = 1; a[b + 1] = 0; a[b + 2] = 0; a[b + 3] = 0;
    a[b + 4] = 0; a[b + 5] = 1; a[b + 6] = 0; a[b + 7] = 0;
    a[b + 8] = 0; a[b + 9] = 0; a[b + 10] = 1; a[b + 11] = 0;
    a[b + 12] = x; a[b + 13] = y; a[b + 14] = z; a[b + 15] = 1;
    this.colorSlot(s, z);
    this.markDirty(s);
    const bd = this.bounds;
    if (x < bd.min[0]) bd.min[0] = x; if (x > bd.max[0]) bd.max[0] = x;
    if (y < bd.min[1]) bd.min[1] = y; if (y > bd.max[1]) bd.max[1] = y;
    if (z < bd.min[2]) bd.min[2] = z; if (z > bd.max[2]) bd.max[2] = z;
    return s;
  }

  addFree(block, k, x, y, z) {
    const pool = this.free;
    if (pool.count >= pool.capacity) {
      pool.grow(pool.capacity * 2);
      this.makePointsAttr();
    }
    const s = pool.count++;
    pool.owner[s] = block;
    pool.ownerIdx[s] = k;
    pool.pos[s * 3] = x; pool.pos[s * 3 + 1] = y; pool.pos[s * 3 + 2] = z;
    this.freeDirty = true;
    return s;
  }

  colorSlot(s, z) {
    let range = this.zRange;
    if (!range) {
      range = this.zRange = [z - 1, z + 1];
      this.rangeChanged = true;
    } else if (z < range[0] || z > range[1]) {
      // Widen with some margin so a growing map does not recolour every frame.
      const span = Math.max(range[1] - range[0], 1);
      if (z < range[0]) range[0] = z - 0.25 * span;
      if (z > range[1]) range[1] = z + 0.25 * span;
      this.recolorAt = 0; // recolour everything in slices
      this.rangeChanged = true;
    }
    rampColor((z - range[0]) / (range[1] - range[0]), this.colors, s * 3);
  }

  recolorSlice(n) {
    const pool = this.occ;
    const end = Math.min(pool.count, this.recolorAt + n);
    const [lo, hi] = this.zRange;
    const inv = 1 / (hi - lo);
    for (let s = this.recolorAt; s < end; s++) rampColor((pool.pos[s * 3 + 2] - lo) * inv, this.colors, s * 3);
    this.markDirty(this.recolorAt);
    this.markDirty(end - 1);
    this.recolorAt = end >= pool.count ? -1 : end;
  }

  markDirty(s) {
    if (s < this.dirtyLo) this.dirtyLo = s;
    if (s + 1 > this.dirtyHi) this.dirtyHi = s + 1;
  }

  // Frees the slots of `slots` (held by `block`) in `pool`, filling each hole with the last slot.
  release(pool, block, slots) {
    const isOcc = pool === this.occ;
    for (let k = slots.length - 1; k >= 0; k--) {
      const s = slots[k];
      const last = pool.count - 1;
      if (s !== last) {
        const ob = pool.owner[last];
        const oi = pool.ownerIdx[last];
        pool.owner[s] = ob;
        pool.ownerIdx[s] = oi;
        ob[pool.field][oi] = s;
        pool.pos[s * 3] = pool.pos[last * 3];
        pool.pos[s * 3 + 1] = pool.pos[last * 3 + 1];
        pool.pos[s * 3 + 2] = pool.pos[last * 3 + 2];
        if (isOcc) {
          this.matrices.copyWithin(s * 16, last * 16, last * 16 + 16);
          this.colors.copyWithin(s * 3, last * 3, last * 3 + 3);
          this.markDirty(s);
        }
      }
      pool.owner[last] = undefined;
      pool.count = last;
    }
    if (!isOcc && slots.length) this.freeDirty = true;
  }

  // Checks the slot bookkeeping (for tests): every held voxel's slot points back at it, the instance
  // matrices sit at the slot centres, the counts add up. Returns a list of problems (empty when sound).
  verify(limit = 10) {
    const problems = [];
    let nOcc = 0, nFree = 0;
    for (const block of this.blocks.values()) {
      for (const [pool, slots] of [[this.occ, block.occ], [this.free, block.free]]) {
        for (let k = 0; k < slots.length; k++) {
          const s = slots[k];
          if (s < 0 || s >= pool.count || pool.owner[s] !== block || pool.ownerIdx[s] !== k) {
            if (problems.length < limit) problems.push(`block ${block.key} ${pool.field}[${k}] -> slot ${s} not owned`);
          } else if (pool === this.occ) {
            const a = this.matrices;
            if (a[s * 16 + 12] !== pool.pos[s * 3] || a[s * 16 + 13] !== pool.pos[s * 3 + 1] || a[s * 16 + 14] !== pool.pos[s * 3 + 2]) {
              if (problems.length < limit) problems.push(`slot ${s}: matrix and centre differ`);
            }
          }
        }
        if (pool === this.occ) nOcc += slots.length; else nFree += slots.length;
      }
    }
    if (nOcc !== this.occ.count) problems.push(`blocks hold ${nOcc} occupied voxels, the pool ${this.occ.count}`);
    if (nFree !== this.free.count) problems.push(`blocks hold ${nFree} free voxels, the pool ${this.free.count}`);
    if (this.mesh.count !== this.occ.count) problems.push(`mesh.count ${this.mesh.count} != ${this.occ.count}`);
    return problems;
  }

  // Marks what changed for upload (ranges accumulate until the next draw uploads them), on the shown
  // representation only: the other one uploads in full when shown (setMode).
  flush() {
    const mesh = this.mesh;
    mesh.count = this.occ.count;
    this.occPointsGeometry.setDrawRange(0, this.occ.count);
    if (this.dirtyHi > this.dirtyLo) {
      const lo = this.dirtyLo, hi = Math.min(this.dirtyHi, this.occ.count);
      if (hi > lo) {
        const [m, c] = this.mode === 'cubes' ? [mesh.instanceMatrix, mesh.instanceColor] : [this.occPointsPos, this.occPointsCol];
        const stride = this.mode === 'cubes' ? 16 : 3;
        m.addUpdateRange(lo * stride, (hi - lo) * stride);
        m.needsUpdate = true;
        c.addUpdateRange(lo * 3, (hi - lo) * 3);
        c.needsUpdate = true;
      }
      this.dirtyLo = Infinity;
      this.dirtyHi = 0;
    }
    if (this.freeDirty) {
      this.pointsGeometry.setDrawRange(0, this.free.count);
      this.freePosAttr.addUpdateRange(0, this.free.count * 3);
      this.freePosAttr.needsUpdate = true;
      this.freeDirty = false;
    }
  }
}
