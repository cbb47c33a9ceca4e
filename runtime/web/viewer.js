// boxforge web viewer: isosurfaces of the generated box-spline shaders in
// WebGPU. Everything the native renderer does on the device happens here
// with the same WGSL (shaders/*.wgsl, written by `boxforge web` from the
// same templates): the lattice samples are uploaded in the layout the
// emitted `<f>_fetch` reads, the emitted `<f>_minmax_main` builds the
// min/max block grid, and `<f>_raycast_main` casts one ray per pixel into a
// storage buffer that a small render pass draws on the canvas. The camera
// and volume arithmetic mirror runtime/src/render.rs (ray_params,
// fine_edge) and runtime/src/volume (Marschner-Lobb, lattice subset,
// coset packing), so a scene renders the same image as `boxforge render`.

const $ = (id) => document.getElementById(id);

// ---------------------------------------------------------------- lattices

/** The class representative of v in Z^3 / L (Lattice::reduce: lower-triangular Hermite columns). */
export function reduce(hermite, v) {
  const x = v.slice();
  for (let i = 0; i < x.length; i++) {
    const h = hermite[i][i];
    const q = Math.floor(x[i] / h);
    if (q !== 0) for (let r = i; r < x.length; r++) x[r] -= q * hermite[i][r];
  }
  return x;
}

/** A membership test for lattice points of an n^3 box, tabulated over one period (det e_i lies in L). */
function membership(lattice) {
  const p = lattice.det;
  if (p > 16) return (i, j, k) => reduce(lattice.hermite, [i, j, k]).every((c) => c === 0);
  const table = new Uint8Array(p * p * p);
  for (let k = 0; k < p; k++) for (let j = 0; j < p; j++) for (let i = 0; i < p; i++) {
    table[i + p * (j + p * k)] = reduce(lattice.hermite, [i, j, k]).every((c) => c === 0) ? 1 : 0;
  }
  return (i, j, k) => table[(i % p) + p * ((j % p) + p * (k % p))] === 1;
}

// ----------------------------------------------------------------- volumes

const ML_FM = 6.0;
const ML_ALPHA = 0.25;

/** Marschner-Lobb (f_M = 6, alpha = 0.25) on [-1,1]^3 (volume/synthetic.rs). */
export function marschnerLobb(x, y, z) {
  const r = Math.sqrt(x * x + y * y);
  const rho = Math.cos(2 * Math.PI * ML_FM * Math.cos((Math.PI * r) / 2));
  return (1 - Math.sin((Math.PI * z) / 2) + ML_ALPHA * (1 + rho)) / (2 * (1 + ML_ALPHA));
}

/** Box edge for about `samples` lattice points (scene::matched_edge). */
export function matchedEdge(det, samples) {
  const n = Math.cbrt(samples * det);
  return Math.max(Math.round(n / 2) * 2, 4);
}

/** Marschner-Lobb at the lattice points of an e^3 box with about n^3 samples (0 elsewhere). */
export function mlVolume(lattice, n) {
  const e = matchedEdge(lattice.det, n * n * n);
  const dims = [e, e, e];
  const data = new Float32Array(e * e * e);
  const member = membership(lattice);
  const pos = (j) => -1 + (2 * j) / (e - 1);
  let idx = 0;
  let count = 0;
  for (let k = 0; k < e; k++) for (let j = 0; j < e; j++) for (let i = 0; i < e; i++, idx++) {
    if (member(i, j, k)) {
      data[idx] = marschnerLobb(pos(i), pos(j), pos(k));
      count++;
    }
  }
  return { dims, data, samples: count, label: `Marschner-Lobb, about ${n}^3 samples` };
}

/** The lattice points of a Cartesian volume (LatticeVolume::subset): other points become 0. */
export function subsetVolume(lattice, cart, label) {
  const [nx, ny, nz] = cart.dims;
  const data = new Float32Array(cart.data.length);
  const member = membership(lattice);
  let idx = 0;
  let count = 0;
  for (let k = 0; k < nz; k++) for (let j = 0; j < ny; j++) for (let i = 0; i < nx; i++, idx++) {
    if (member(i, j, k)) {
      data[idx] = cart.data[idx];
      count++;
    }
  }
  return { dims: cart.dims.slice(), data, samples: count, label };
}

/**
 * The coset-packed texture (LatticeVolume::packed): words x fastest in a texture of
 * g = ceil(dims / 2) texels per axis, 2 g on the pivot axes (the axes of the coset id's
 * bits: coset c's bit i is the parity of axis pivots[i]); coset c's grid is the tile at
 * (r & p) * g for its parity vector r. Returns the words, texture size and grid [gx, gy, gz, words].
 */
export function packVolume(vol, cosets) {
  const g = vol.dims.map((n) => Math.ceil(n / 2));
  const words = g[0] * g[1] * g[2];
  // Pivot axes: the first axis of each coset bit (cosets 1, 2, 4, ... differ from 0 there).
  const pivot = [0, 0, 0];
  for (let i = 1; i < cosets.length; i *= 2) {
    const r = cosets[i];
    if (r.length === 3) pivot[r.findIndex((x) => x === 1)] = 1;
  }
  const size = g.map((n, a) => n * (1 + pivot[a]));
  const buf = new Float32Array(cosets.length * words);
  const [nx, ny] = vol.dims;
  cosets.forEach((r) => {
    if (r.length !== 3) return;
    const o = r.map((x, a) => x * pivot[a] * g[a]);
    for (let mz = 0; mz < g[2]; mz++) for (let my = 0; my < g[1]; my++) for (let mx = 0; mx < g[0]; mx++) {
      const m = [mx, my, mz];
      const j = [0, 0, 0];
      let inside = true;
      for (let a = 0; a < 3; a++) {
        let v = 2 * m[a] + r[a];
        if (v >= vol.dims[a]) {
          if (v >= 2) v -= 2;
          else inside = false;
        }
        j[a] = v;
      }
      if (inside) buf[((mz + o[2]) * size[1] + my + o[1]) * size[0] + mx + o[0]] = vol.data[j[0] + nx * (j[1] + ny * j[2])];
    }
  });
  return { words: buf, size, grid: new Int32Array([g[0], g[1], g[2], words]) };
}

/** A `.bfv` file: "BFVOL\0\x01\0", nx, ny, nz (u32 LE), then f32 LE samples, x fastest. */
export function parseBfv(buffer) {
  const dv = new DataView(buffer);
  const magic = new Uint8Array(buffer, 0, Math.min(8, buffer.byteLength));
  const want = [66, 70, 86, 79, 76, 0, 1, 0];
  if (buffer.byteLength < 20 || want.some((b, i) => magic[i] !== b)) throw new Error('not a .bfv volume (it must start with BFVOL, version 1)');
  const dims = [dv.getUint32(8, true), dv.getUint32(12, true), dv.getUint32(16, true)];
  const count = dims[0] * dims[1] * dims[2];
  if (buffer.byteLength !== 20 + 4 * count) throw new Error(`a ${dims.join('x')} .bfv needs ${20 + 4 * count} bytes, the file has ${buffer.byteLength}`);
  return { dims, data: new Float32Array(buffer.slice(20)) };
}

/** A raw volume of `spec` = "nx,ny,nz,type" (type u8, u16 or f32, little-endian), as `--raw`. */
export function parseRaw(buffer, spec) {
  const parts = (spec || '').split(',').map((s) => s.trim());
  if (parts.length !== 4) throw new Error('a .raw file needs its size and type, e.g. 256,256,128,u8');
  const dims = parts.slice(0, 3).map(Number);
  if (dims.some((n) => !Number.isInteger(n) || n < 2)) throw new Error(`raw size ${parts.slice(0, 3).join(',')}: each edge must be a whole number >= 2`);
  const size = { u8: 1, u16: 2, f32: 4 }[parts[3]];
  if (!size) throw new Error(`raw type ${parts[3]}: use u8, u16 or f32`);
  const count = dims[0] * dims[1] * dims[2];
  if (buffer.byteLength !== count * size) throw new Error(`a ${dims.join('x')} ${parts[3]} volume is ${count * size} bytes, the file has ${buffer.byteLength}`);
  const dv = new DataView(buffer);
  const data = new Float32Array(count);
  for (let i = 0; i < count; i++) {
    data[i] = size === 1 ? dv.getUint8(i) : size === 2 ? dv.getUint16(2 * i, true) : dv.getFloat32(4 * i, true);
  }
  return { dims, data };
}

/** A NIfTI-1 volume (.nii, or .nii.gz through the browser's gzip stream), scl_slope/scl_inter applied. */
export async function parseNifti(buffer) {
  let bytes = new Uint8Array(buffer);
  if (bytes[0] === 0x1f && bytes[1] === 0x8b) {
    const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream('gzip'));
    bytes = new Uint8Array(await new Response(stream).arrayBuffer());
  }
  const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  if (bytes.byteLength < 352) throw new Error('not a NIfTI-1 file (shorter than its 348-byte header)');
  const le = dv.getInt32(0, true) === 348;
  if (!le && dv.getInt32(0, false) !== 348) throw new Error('not a NIfTI-1 file (sizeof_hdr is not 348)');
  const dim = [...Array(8)].map((_, i) => dv.getInt16(40 + 2 * i, le));
  if (dim[0] < 3 || dim.slice(4, dim[0] + 1).some((d) => d !== 1)) throw new Error(`the NIfTI volume has dims ${dim.slice(1, dim[0] + 1).join('x')}: the viewer needs a 3D scalar volume`);
  const dims = [dim[1], dim[2], dim[3]];
  const type = dv.getInt16(70, le);
  const offset = Math.max(352, Math.round(dv.getFloat32(108, le)));
  let slope = dv.getFloat32(112, le);
  let inter = dv.getFloat32(116, le);
  if (!slope || !Number.isFinite(slope)) { slope = 1; inter = 0; }
  const readers = {
    2: [1, (o) => dv.getUint8(o)], 256: [1, (o) => dv.getInt8(o)],
    4: [2, (o) => dv.getInt16(o, le)], 512: [2, (o) => dv.getUint16(o, le)],
    8: [4, (o) => dv.getInt32(o, le)], 768: [4, (o) => dv.getUint32(o, le)],
    16: [4, (o) => dv.getFloat32(o, le)], 64: [8, (o) => dv.getFloat64(o, le)],
  };
  const reader = readers[type];
  if (!reader) throw new Error(`NIfTI datatype ${type} is not a scalar type the viewer reads (u8, i8, i16, u16, i32, u32, f32, f64)`);
  const count = dims[0] * dims[1] * dims[2];
  if (offset + count * reader[0] > bytes.byteLength) throw new Error(`the NIfTI file is truncated: ${dims.join('x')} samples need ${offset + count * reader[0]} bytes`);
  const data = new Float32Array(count);
  for (let i = 0; i < count; i++) data[i] = reader[1](offset + i * reader[0]) * slope + inter;
  return { dims, data };
}

function range(data) {
  let lo = Infinity;
  let hi = -Infinity;
  for (const v of data) { if (v < lo) lo = v; if (v > hi) hi = v; }
  return lo > hi ? [0, 0] : [lo, hi];
}

// ------------------------------------------------------------------ camera

/** From the eye toward the volume, for azimuth and elevation in degrees (render::view_direction). */
export function viewDirection(az, el) {
  const a = (az * Math.PI) / 180;
  const e = (el * Math.PI) / 180;
  return [-(Math.cos(e) * Math.cos(a)), -(Math.cos(e) * Math.sin(a)), -Math.sin(e)];
}

const sub = (a, b) => a.map((x, i) => x - b[i]);
const add = (a, b) => a.map((x, i) => x + b[i]);
const scale = (a, s) => a.map((x) => x * s);
const len = (a) => Math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];

/** The ray caster's uniform block (render::ray_params, RayParams: 9 vec4, 144 bytes). */
export function rayParams(supportRadius, dims, o) {
  const r = supportRadius;
  const lo = [r, r, r];
  const hi = dims.map((n) => n - 1 - r);
  const center = scale(add(lo, hi), 0.5);
  const radius = 0.5 * len(sub(hi, lo));
  const forward = viewDirection(o.azimuth, o.elevation);
  const worldUp = Math.abs(Math.cos((o.elevation * Math.PI) / 180)) < 1e-3 ? [0, 1, 0] : [0, 0, 1];
  const c = cross(forward, worldUp);
  const right = scale(c, 1 / Math.max(len(c), 1e-20));
  const up = cross(right, forward);
  const aspect = o.width / o.height;
  const zoom = o.zoom || 1;
  let eye;
  let half;
  if (o.perspective) {
    eye = sub(center, scale(forward, (radius * 2.6) / zoom));
    half = Math.tan((22.5 * Math.PI) / 180);
  } else {
    eye = sub(center, scale(forward, radius * 2));
    half = (radius * 1.05) / zoom;
  }
  const buf = new ArrayBuffer(144);
  const f = new Float32Array(buf);
  const i = new Int32Array(buf);
  f.set([...eye, 0, ...forward, 0, ...scale(right, half * aspect), 0, ...scale(up, half), 0, ...lo, 0, ...hi, 0], 0);
  f.set([o.iso, o.step, o.perspective ? 1 : 0, o.skip ? 1 : 0], 24);
  i.set([o.width, o.height, o.block, 0], 28);
  i.set([...dims.map((n) => Math.ceil(n / o.block)), 0], 32);
  return buf;
}

/** The exact walk's fine bounds grid: edge 1 unless more than 65535 workgroups of 64 (render::fine_edge). */
export function fineEdge(dims, coarse) {
  let e = 1;
  while (e < Math.max(coarse, 1)) {
    const blocks = dims.reduce((a, n) => a * Math.ceil(n / e), 1);
    if (Math.ceil(blocks / 64) <= 65535) break;
    e *= 2;
  }
  return e;
}

// ------------------------------------------------------------------ DVR

/**
 * The DVR caster's uniform block (dvr::dvr_params, DvrParams: 12 vec4, 192 bytes): the ray
 * caster's camera and valid box, then the tables' scales, mode, light and sizes.
 */
export function dvrParams(supportRadius, dims, o, tf, dvr) {
  const ray = rayParams(supportRadius, dims, { ...o, block: dvr.block });
  const rf = new Float32Array(ray);
  const ri = new Int32Array(ray);
  const buf = new ArrayBuffer(192);
  const f = new Float32Array(buf);
  const i = new Int32Array(buf);
  const [lo, hi] = tf.range;
  const span = Math.fround(Math.fround(hi) - Math.fround(lo));
  f.set(rf.subarray(0, 24), 0);
  f.set([lo, (tf.table_size - 1) / span, (tf.preint_size - 1) / span, o.step], 24);
  f.set([o.perspective ? 1 : 0, o.skip ? 1 : 0, 1, dvr.termination], 28);
  f.set([...dvr.light, dvr.g0_of_range * span], 32);
  i.set([o.width, o.height, dvr.block, 0], 36);
  i.set([ri[32], ri[33], ri[34], tf.table_size], 40);
  i.set([tf.preint_size, 0, 0, 0], 44);
  return buf;
}

/** Per block, 1 when the transfer function is transparent over its [min, max] (Tf1d::transparent). */
export function emptyFlags(bounds, tf) {
  const n = tf.table_size;
  const [lo, hi] = tf.range;
  const coord = (v) => Math.min(Math.max((v - lo) * ((n - 1) / (hi - lo)), 0), n - 1);
  const out = new Uint32Array(bounds.length / 2);
  for (let k = 0; k < out.length; k++) {
    const [vmin, vmax] = [bounds[2 * k], bounds[2 * k + 1]];
    if (Number.isNaN(vmin) || Number.isNaN(vmax) || vmin > vmax) continue;
    const a = Math.max(Math.floor(coord(vmin)) - 1, 0);
    const b = Math.min(Math.ceil(coord(vmax)) + 1, n - 1);
    let clear = 1;
    for (let e = a; e <= b; e++) if (tf.table[4 * e + 3] !== 0) { clear = 0; break; }
    out[k] = clear;
  }
  return out;
}

/** Skipped blocks: empty with every block within `radius` (dvr::skip_flags, a separable min filter). */
export function skipFlags(empty, blocks, radius) {
  const [nx, ny, nz] = blocks;
  let f = Uint32Array.from(empty);
  for (const [n, stride] of [[nx, 1], [ny, nx], [nz, nx * ny]]) {
    const prev = f.slice();
    for (let i = 0; i < f.length; i++) {
      const c = Math.floor(i / stride) % n;
      const base = i - c * stride;
      let all = 1;
      for (let q = Math.max(0, c - radius); q <= Math.min(n - 1, c + radius); q++) if (!prev[base + q * stride]) { all = 0; break; }
      f[i] = all;
    }
  }
  return f;
}

// ------------------------------------------------------------------ WebGPU

/** A WGSL module that failed to compile, with its messages as file:line:column. */
export class CompileError extends Error {
  constructor(path, messages) {
    super(`${path} failed to compile:\n${messages.join('\n')}`);
    this.path = path;
    this.messages = messages;
  }
}

const BLIT = `
struct Sizes { image: vec2<u32>, canvas: vec2<u32> }
@group(0) @binding(0) var<storage, read> image: array<u32>;
@group(0) @binding(1) var<uniform> sizes: Sizes;
@vertex fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let p = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(p * 2.0 - 1.0, 0.0, 1.0);
}
@fragment fn fs(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let x = min(u32(p.x * f32(sizes.image.x) / f32(sizes.canvas.x)), sizes.image.x - 1u);
    let y = min(u32(p.y * f32(sizes.image.y) / f32(sizes.canvas.y)), sizes.image.y - 1u);
    return unpack4x8unorm(image[y * sizes.image.x + x]);
}`;

class Gpu {
  static async open() {
    if (!navigator.gpu) throw new Error('this browser has no WebGPU (navigator.gpu is missing): use a current Chrome or Edge, or enable WebGPU in Firefox or Safari');
    const adapter = await navigator.gpu.requestAdapter();
    if (!adapter) throw new Error('WebGPU found no adapter (no GPU and no software fallback enabled)');
    const l = adapter.limits;
    const device = await adapter.requestDevice({
      requiredLimits: { maxStorageBufferBindingSize: l.maxStorageBufferBindingSize, maxBufferSize: l.maxBufferSize },
    });
    const g = new Gpu();
    g.adapter = adapter;
    g.device = device;
    g.info = adapter.info ? `${adapter.info.vendor} ${adapter.info.architecture} ${adapter.info.description || ''}`.trim() : 'WebGPU';
    g.modules = new Map();
    return g;
  }

  /** The module at `path` of the site, compiled; throws CompileError with Tint's messages. */
  async module(path) {
    if (this.modules.has(path)) return this.modules.get(path);
    const response = await fetch(path);
    if (!response.ok) throw new Error(`cannot load ${path}: HTTP ${response.status}`);
    const code = await response.text();
    const module = this.device.createShaderModule({ label: path, code });
    const info = await module.getCompilationInfo();
    const errors = info.messages.filter((m) => m.type === 'error');
    if (errors.length) {
      const lines = code.split('\n');
      throw new CompileError(path, errors.map((m) => `${path}:${m.lineNum}:${m.linePos}: ${m.message}\n    ${(lines[m.lineNum - 1] || '').trim()}`));
    }
    this.modules.set(path, module);
    return module;
  }

  buffer(data, usage) {
    const size = Math.max(16, Math.ceil(data.byteLength / 4) * 4);
    const b = this.device.createBuffer({ size, usage: usage | GPUBufferUsage.COPY_DST });
    this.device.queue.writeBuffer(b, 0, data);
    return b;
  }

  empty(size, usage) {
    return this.device.createBuffer({ size: Math.max(16, size), usage });
  }
}

/** One filter, layout, hit mode and volume on the device: pipelines, samples, bounds grids. */
class Scene {
  static async create(gpu, filter, layout, hit, vol, block) {
    const s = new Scene();
    const dev = gpu.device;
    const name = filter.name;
    s.gpu = gpu;
    s.filter = filter;
    s.layout = layout;
    s.hit = hit;
    s.vol = vol;
    s.block = block;
    const dvr = hit === 'dvr';
    const module = await gpu.module(filter.shaders[layout][hit]);
    const STORAGE = GPUBufferUsage.STORAGE;
    const UNIFORM = GPUBufferUsage.UNIFORM;
    // Samples in the layout of the emitted fetch.
    let volumeEntries;
    if (layout === 'embedded') {
      const [nx, ny, nz] = vol.dims;
      const limit = dev.limits.maxTextureDimension3D;
      if (Math.max(nx, ny, nz) > limit) throw new Error(`the volume is ${vol.dims.join('x')}, over this device's 3D texture limit of ${limit}: use the packed layout or fewer samples`);
      const tex = dev.createTexture({ size: [nx, ny, nz], format: 'r32float', dimension: '3d', usage: GPUTextureUsage.TEXTURE_BINDING | GPUTextureUsage.COPY_DST });
      dev.queue.writeTexture({ texture: tex }, vol.data, { bytesPerRow: nx * 4, rowsPerImage: ny }, [nx, ny, nz]);
      volumeEntries = [{ binding: 0, resource: tex.createView() }];
      s.bytes = vol.data.byteLength;
    } else {
      if (!filter.lattice.cosets) throw new Error(`the ${filter.lattice.name} lattice has no packed layout (2Z^3 is not in it)`);
      const packed = packVolume(vol, filter.lattice.cosets);
      const [tx, ty, tz] = packed.size;
      const limit = dev.limits.maxTextureDimension3D;
      if (Math.max(tx, ty, tz) > limit) throw new Error(`the packed volume is a ${packed.size.join('x')} texture (one tile per coset), over this device's 3D texture limit of ${limit}: use fewer samples`);
      const tex = dev.createTexture({ size: [tx, ty, tz], format: 'r32float', dimension: '3d', usage: GPUTextureUsage.TEXTURE_BINDING | GPUTextureUsage.COPY_DST });
      dev.queue.writeTexture({ texture: tex }, packed.words, { bytesPerRow: tx * 4, rowsPerImage: ty }, [tx, ty, tz]);
      volumeEntries = [
        { binding: 0, resource: tex.createView() },
        { binding: 1, resource: { buffer: gpu.buffer(packed.grid, UNIFORM) } },
      ];
      s.bytes = packed.words.byteLength;
    }
    s.volumeEntries = volumeEntries;
    // Min/max block grids with the emitted kernel (bindings after the samples').
    const outBinding = layout === 'packed' ? 2 : 1;
    const minmax = await dev.createComputePipelineAsync({ layout: 'auto', compute: { module, entryPoint: `${name}_minmax_main` } });
    const grid = (edge) => {
      const blocks = vol.dims.map((n) => Math.ceil(n / edge));
      const count = blocks[0] * blocks[1] * blocks[2];
      const out = gpu.empty(count * 8, STORAGE | GPUBufferUsage.COPY_SRC);
      const job = gpu.buffer(new Int32Array([0, 0, 0, 0, ...blocks, edge]), UNIFORM);
      const bind = dev.createBindGroup({
        layout: minmax.getBindGroupLayout(0),
        entries: [...volumeEntries, { binding: outBinding, resource: { buffer: out } }, { binding: outBinding + 1, resource: { buffer: job } }],
      });
      const enc = dev.createCommandEncoder();
      const pass = enc.beginComputePass();
      pass.setPipeline(minmax);
      pass.setBindGroup(0, bind);
      pass.dispatchWorkgroups(Math.ceil(count / 64));
      pass.end();
      dev.queue.submit([enc.finish()]);
      return { out, blocks, count };
    };
    s.coarse = grid(block);
    const constants = {};
    if (hit === 'exact') {
      const e = fineEdge(vol.dims, block);
      s.fine = grid(e);
      Object.assign(constants, { [`${name}_FINE_EDGE`]: e, [`${name}_FINE_BX`]: s.fine.blocks[0], [`${name}_FINE_BY`]: s.fine.blocks[1], [`${name}_FINE_BZ`]: s.fine.blocks[2] });
    }
    // The coarse bounds on the CPU too, for the share of empty blocks.
    const read = gpu.empty(s.coarse.count * 8, GPUBufferUsage.MAP_READ | GPUBufferUsage.COPY_DST);
    const enc = dev.createCommandEncoder();
    enc.copyBufferToBuffer(s.coarse.out, 0, read, 0, s.coarse.count * 8);
    dev.queue.submit([enc.finish()]);
    await read.mapAsync(GPUMapMode.READ);
    s.bounds = new Float32Array(read.getMappedRange().slice(0));
    read.unmap();
    const entryPoint = dvr ? `${name}_dvr_main` : `${name}_raycast_main`;
    s.raycast = await dev.createComputePipelineAsync({ layout: 'auto', compute: { module, entryPoint, constants } });
    s.volumeGroup = dev.createBindGroup({ layout: s.raycast.getBindGroupLayout(0), entries: volumeEntries });
    s.params = gpu.empty(dvr ? 192 : 144, UNIFORM | GPUBufferUsage.COPY_DST);
    s.tf = null;
    s.pixels = 0;
    return s;
  }

  /** DVR: the transfer function's tables on the device and the skipping flags for it. */
  useTransferFunction(tf, step) {
    if (this.tf === tf && this.tfStep === step) return;
    const STORAGE = GPUBufferUsage.STORAGE;
    const empty = emptyFlags(this.bounds, tf);
    this.emptyBlocks = empty.reduce((a, b) => a + b, 0) / Math.max(1, empty.length);
    const flags = skipFlags(empty, this.coarse.blocks, Math.ceil(step / this.block));
    this.tf = tf;
    this.tfStep = step;
    this.tfBuffers = [this.gpu.buffer(flags, STORAGE), this.gpu.buffer(tf.table, STORAGE), this.gpu.buffer(tf.preint, STORAGE)];
    this.pixels = 0; // a new bind group
  }

  /** Share of coarse blocks whose bounds exclude `iso` (DVR: that the transfer function leaves transparent). */
  emptyShare(iso) {
    if (this.hit === 'dvr') return this.emptyBlocks || 0;
    let n = 0;
    for (let i = 0; i < this.bounds.length; i += 2) if (iso < this.bounds[i] || iso > this.bounds[i + 1]) n++;
    return n / Math.max(1, this.bounds.length / 2);
  }

  /** Image and depth buffers for w x h pixels (grown when needed) and the ray-cast bind group. */
  ensureImage(w, h) {
    if (w * h <= this.pixels) return;
    const dev = this.gpu.device;
    this.pixels = w * h;
    this.image = this.gpu.empty(w * h * 4, GPUBufferUsage.STORAGE | GPUBufferUsage.COPY_SRC);
    this.depth = this.gpu.empty(w * h * 4, GPUBufferUsage.STORAGE | GPUBufferUsage.COPY_SRC);
    const entries = [
      { binding: 0, resource: { buffer: this.params } },
      { binding: 1, resource: { buffer: this.image } },
      { binding: 2, resource: { buffer: this.coarse.out } },
      { binding: 3, resource: { buffer: this.depth } },
    ];
    if (this.hit === 'dvr') {
      entries.splice(2, 2, ...this.tfBuffers.map((buffer, k) => ({ binding: 2 + k, resource: { buffer } })));
    }
    if (this.fine) entries.push({ binding: 4, resource: { buffer: this.fine.out } });
    this.rayGroup = dev.createBindGroup({ layout: this.raycast.getBindGroupLayout(1), entries });
  }

  /** Records the ray cast of a w x h image with `view` (iso, angles, ...) into `enc`. */
  encode(enc, view, w, h) {
    const dvr = state.catalog.dvr;
    if (this.hit === 'dvr') this.useTransferFunction(view.tf, dvr.step);
    this.ensureImage(w, h);
    const o = { ...view, width: w, height: h, block: this.block };
    if (this.hit === 'dvr') {
      this.gpu.device.queue.writeBuffer(this.params, 0, dvrParams(this.filter.support_radius, this.vol.dims, { ...o, step: dvr.step }, view.tf, dvr));
    } else {
      this.gpu.device.queue.writeBuffer(this.params, 0, rayParams(this.filter.support_radius, this.vol.dims, o));
    }
    const pass = enc.beginComputePass();
    pass.setPipeline(this.raycast);
    pass.setBindGroup(0, this.volumeGroup);
    pass.setBindGroup(1, this.rayGroup);
    pass.dispatchWorkgroups(Math.ceil(w / 8), Math.ceil(h / 8));
    pass.end();
  }
}

/** Draws a scene's image buffer on the canvas (scaled to the canvas: progressive frames). */
class Presenter {
  constructor(gpu, canvas) {
    this.gpu = gpu;
    this.canvas = canvas;
    this.context = canvas.getContext('webgpu');
    this.context.configure({
      device: gpu.device,
      format: 'rgba8unorm',
      usage: GPUTextureUsage.RENDER_ATTACHMENT | GPUTextureUsage.COPY_SRC,
      alphaMode: 'opaque',
    });
    const module = gpu.device.createShaderModule({ label: 'blit', code: BLIT });
    this.pipeline = gpu.device.createRenderPipeline({
      layout: 'auto',
      vertex: { module, entryPoint: 'vs' },
      fragment: { module, entryPoint: 'fs', targets: [{ format: 'rgba8unorm' }] },
      primitive: { topology: 'triangle-list' },
    });
    this.sizes = gpu.empty(16, GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST);
    this.groups = new WeakMap();
  }

  /** Records the blit of `scene`'s w x h image; returns the canvas texture drawn into. */
  encode(enc, scene, w, h) {
    const dev = this.gpu.device;
    dev.queue.writeBuffer(this.sizes, 0, new Uint32Array([w, h, this.canvas.width, this.canvas.height]));
    let group = this.groups.get(scene.image);
    if (!group) {
      group = dev.createBindGroup({ layout: this.pipeline.getBindGroupLayout(0), entries: [{ binding: 0, resource: { buffer: scene.image } }, { binding: 1, resource: { buffer: this.sizes } }] });
      this.groups.set(scene.image, group);
    }
    const texture = this.context.getCurrentTexture();
    const pass = enc.beginRenderPass({ colorAttachments: [{ view: texture.createView(), loadOp: 'clear', storeOp: 'store', clearValue: [0, 0, 0, 1] }] });
    pass.setPipeline(this.pipeline);
    pass.setBindGroup(0, group);
    pass.draw(3);
    pass.end();
    return texture;
  }
}

// ------------------------------------------------------------------ viewer

const state = {
  catalog: null,
  gpu: null,
  presenter: null,
  scene: null,
  sceneKey: '',
  cartesian: new Map(), // volume name -> Cartesian volume (MNI, user files)
  tfs: new Map(), // transfer-function name -> tables
  view: { azimuth: 30, elevation: 25, zoom: 1 },
  lastFullMs: 0,
  busy: false,
  pending: null,
  idleTimer: 0,
};

function showError(text) {
  const e = $('errors');
  e.textContent = text;
  e.hidden = !text;
}

function settings() {
  return {
    filter: $('filter').value,
    layout: $('layout').value,
    hit: $('mode').value === 'dvr' ? 'dvr' : $('hit').value,
    tf: $('tf').value,
    volume: $('volume').value,
    mlN: Number($('ml-n').value),
    iso: Number($('iso').value),
    size: Number($('size').value),
    perspective: $('perspective').checked,
    skip: $('skip').checked,
  };
}

function filterByName(name) {
  const f = state.catalog.filters.find((x) => x.name === name);
  if (!f) throw new Error(`no filter ${name} in this site (catalog.json lists ${state.catalog.filters.map((x) => x.name).join(', ')})`);
  return f;
}

/** The lattice samples of the chosen volume for this filter's lattice (cached per lattice). */
async function latticeVolume(filter, s) {
  if (s.volume === 'ml') {
    if (!Number.isInteger(s.mlN) || s.mlN < 2 || s.mlN > 160) throw new Error(`Marschner-Lobb N = ${s.mlN}: pick a whole number from 2 to 160`);
    return mlVolume(filter.lattice, s.mlN);
  }
  let cart = state.cartesian.get(s.volume);
  if (!cart) {
    const entry = state.catalog.volumes.find((v) => v.name === s.volume);
    if (!entry) throw new Error(`no volume ${s.volume}`);
    const response = await fetch(entry.file);
    if (!response.ok) throw new Error(`cannot load ${entry.file}: HTTP ${response.status}`);
    cart = { ...parseBfv(await response.arrayBuffer()), label: entry.description };
    state.cartesian.set(s.volume, cart);
  }
  return subsetVolume(filter.lattice, cart, cart.label);
}

/** The scene for the current settings, rebuilt only when filter, layout, hit or volume change. */
async function currentScene(s) {
  const key = JSON.stringify([s.filter, s.layout, s.hit, s.volume, s.volume === 'ml' ? s.mlN : 0]);
  if (state.scene && state.sceneKey === key) return state.scene;
  const filter = filterByName(s.filter);
  const vol = await latticeVolume(filter, s);
  $('stats').textContent = `building ${s.filter} (${s.layout}, ${s.hit}) for ${vol.dims.join('x')} ...`;
  const block = s.hit === 'dvr' ? state.catalog.dvr.block : state.catalog.defaults.block;
  state.scene = await Scene.create(state.gpu, filter, s.layout, s.hit, vol, block);
  state.sceneKey = key;
  return state.scene;
}

function viewOf(s, tf) {
  return { iso: s.iso, step: state.catalog.defaults.step, perspective: s.perspective, skip: s.skip, tf, ...state.view };
}

/** The transfer function `name` of the site: range, sizes and its two tables (tf/<name>.bin), cached. */
async function transferFunction(name) {
  if (state.tfs.has(name)) return state.tfs.get(name);
  const entry = state.catalog.transfer_functions.find((t) => t.name === name);
  if (!entry) throw new Error(`no transfer function ${name} in this site`);
  const response = await fetch(entry.file);
  if (!response.ok) throw new Error(`cannot load ${entry.file}: HTTP ${response.status}`);
  const all = new Float32Array(await response.arrayBuffer());
  const n = 4 * entry.table_size;
  if (all.length !== n + 4 * entry.preint_size * entry.preint_size) throw new Error(`${entry.file} has ${all.length} floats, the catalog says ${n} + ${4 * entry.preint_size ** 2}`);
  const tf = { ...entry, table: all.slice(0, n), preint: all.slice(n) };
  state.tfs.set(name, tf);
  return tf;
}

/** Renders one frame at `fraction` of the full resolution; returns its GPU time in ms. */
async function frame(fraction) {
  const s = settings();
  const scene = await currentScene(s);
  const w = Math.max(8, Math.round(s.size * fraction));
  const h = w;
  const canvas = $('view');
  if (canvas.width !== s.size) { canvas.width = s.size; canvas.height = s.size; }
  const dev = state.gpu.device;
  const t0 = performance.now();
  const enc = dev.createCommandEncoder();
  scene.encode(enc, viewOf(s, s.hit === 'dvr' ? await transferFunction(s.tf) : null), w, h);
  state.presenter.encode(enc, scene, w, h);
  dev.queue.submit([enc.finish()]);
  await dev.queue.onSubmittedWorkDone();
  const ms = performance.now() - t0;
  const v = scene.vol;
  const note = scene.filter.view_dependent ? ' (reference variant: the native renderer picks one per view)' : '';
  $('stats').textContent = `${scene.filter.name}${note} · ${scene.layout} · ${scene.hit} · ${v.label}: ${v.dims.join('x')}, ${v.samples} samples · `
    + `${w}x${h} in ${ms.toFixed(1)} ms${fraction < 1 ? ' (preview, refining)' : ''} · ${(100 * scene.emptyShare(s.iso)).toFixed(0)}% of blocks empty · ${state.gpu.info}`;
  return ms;
}

/** Schedules a frame: at once at a preview resolution when full frames are slow, full resolution when idle. */
function requestFrame() {
  clearTimeout(state.idleTimer);
  const full = async () => run(1);
  const run = async (fraction) => {
    if (state.busy) { state.pending = fraction; return; }
    state.busy = true;
    try {
      const ms = await frame(fraction);
      if (fraction === 1) state.lastFullMs = ms;
      showError('');
    } catch (e) {
      showError(e.messages ? e.message : String(e.stack || e));
    } finally {
      state.busy = false;
    }
    if (state.pending !== null) {
      const f = state.pending;
      state.pending = null;
      run(f);
    }
  };
  if (state.lastFullMs > 60) {
    run(state.lastFullMs > 400 ? 0.25 : 0.5);
    state.idleTimer = setTimeout(full, 250);
  } else {
    run(1);
  }
}

function fillFilters() {
  const sel = $('filter');
  sel.innerHTML = '';
  for (const f of state.catalog.filters) {
    const o = document.createElement('option');
    o.value = f.name;
    o.textContent = `${f.name} (${f.lattice.name})`;
    sel.appendChild(o);
  }
  sel.value = state.catalog.filters.some((f) => f.name === 'bcc7') ? 'bcc7' : state.catalog.filters[0].name;
  fillLayouts();
}

function fillLayouts() {
  const f = filterByName($('filter').value);
  $('filter-description').textContent = f.description;
  const sel = $('layout');
  const keep = sel.value;
  sel.innerHTML = '';
  for (const l of Object.keys(f.shaders)) {
    const o = document.createElement('option');
    o.value = l;
    o.textContent = l;
    sel.appendChild(o);
  }
  if (Object.keys(f.shaders).includes(keep)) sel.value = keep;
}

function setIsoRange(lo, hi, value) {
  const iso = $('iso');
  iso.min = lo;
  iso.max = hi;
  iso.step = (hi - lo) / 1000 || 0.001;
  iso.value = value;
  $('iso-value').textContent = Number(iso.value).toPrecision(4);
}

async function loadFile(file) {
  const buffer = await file.arrayBuffer();
  const lower = file.name.toLowerCase();
  let cart;
  if (lower.endsWith('.bfv')) cart = parseBfv(buffer);
  else if (lower.endsWith('.nii') || lower.endsWith('.nii.gz')) cart = await parseNifti(buffer);
  else if (lower.endsWith('.raw')) cart = parseRaw(buffer, $('raw-spec').value);
  else throw new Error(`${file.name}: the viewer reads .nii, .nii.gz, .bfv and .raw (with its size and type)`);
  const name = `file:${file.name}`;
  state.cartesian.set(name, { ...cart, label: file.name });
  let o = [...$('volume').options].find((x) => x.value === name);
  if (!o) {
    o = document.createElement('option');
    o.value = name;
    o.textContent = file.name;
    $('volume').appendChild(o);
  }
  $('volume').value = name;
  const [lo, hi] = range(cart.data);
  setIsoRange(lo, hi, (lo + hi) / 2);
}

function volumeChanged() {
  const v = $('volume').value;
  $('ml-budget-row').hidden = v !== 'ml';
  if (v === 'ml') setIsoRange(0, 1, 0.5);
  const entry = state.catalog.volumes.find((x) => x.name === v);
  if (entry) setIsoRange(0, 200, entry.iso);
  const tf = v === 'ml' ? 'marschner-lobb' : entry && entry.transfer_function;
  if (tf && state.catalog.transfer_functions.some((t) => t.name === tf)) $('tf').value = tf;
}

function modeChanged() {
  const dvr = $('mode').value === 'dvr';
  $('tf-row').hidden = !dvr;
  $('hit-row').hidden = dvr;
  $('iso-row').hidden = dvr;
}

function fillTransferFunctions() {
  for (const t of state.catalog.transfer_functions) $('tf').add(new Option(`${t.name} (${t.range[0]} to ${t.range[1]})`, t.name));
}

function wireControls() {
  const canvas = $('view');
  for (const id of ['layout', 'hit', 'tf', 'size', 'perspective', 'skip', 'ml-n']) $(id).addEventListener('change', requestFrame);
  $('mode').addEventListener('change', () => { modeChanged(); requestFrame(); });
  $('filter').addEventListener('change', () => { fillLayouts(); requestFrame(); });
  $('volume').addEventListener('change', () => { volumeChanged(); requestFrame(); });
  $('iso').addEventListener('input', () => { $('iso-value').textContent = Number($('iso').value).toPrecision(4); requestFrame(); });
  $('file').addEventListener('change', async (e) => {
    const file = e.target.files[0];
    if (!file) return;
    try { await loadFile(file); requestFrame(); } catch (err) { showError(String(err.message || err)); }
  });
  let drag = null;
  canvas.addEventListener('pointerdown', (e) => { drag = [e.clientX, e.clientY]; canvas.setPointerCapture(e.pointerId); canvas.classList.add('dragging'); });
  canvas.addEventListener('pointerup', () => { drag = null; canvas.classList.remove('dragging'); });
  canvas.addEventListener('pointermove', (e) => {
    if (!drag) return;
    state.view.azimuth -= (e.clientX - drag[0]) * 0.4;
    state.view.elevation = Math.max(-89, Math.min(89, state.view.elevation + (e.clientY - drag[1]) * 0.4));
    drag = [e.clientX, e.clientY];
    requestFrame();
  });
  canvas.addEventListener('wheel', (e) => {
    e.preventDefault();
    state.view.zoom = Math.max(0.25, Math.min(16, state.view.zoom * Math.exp(-e.deltaY * 0.001)));
    requestFrame();
  }, { passive: false });
}

// ------------------------------------------------- hooks for automated tests

function toBase64(bytes) {
  let s = '';
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
  return btoa(s);
}

/**
 * Sets the controls to `scene` ({filter, layout, hit, mlN, iso, size, view: [az, el], perspective}),
 * renders one full frame and reads the canvas back (copyTextureToBuffer in the same submit as the
 * draw, which is how a presented WebGPU canvas can be read): {width, height, rgba (base64), ms}.
 */
async function renderForTest(scene) {
  const set = (id, v) => { if (v !== undefined) { if ($(id).type === 'checkbox') $(id).checked = v; else $(id).value = v; } };
  set('filter', scene.filter);
  fillLayouts();
  set('layout', scene.layout || 'embedded');
  set('hit', scene.hit || 'step');
  set('volume', scene.volume || 'ml');
  volumeChanged();
  set('ml-n', scene.mlN);
  // Any size, also one the menu does not list.
  const size = String(scene.size || 256);
  if (![...$('size').options].some((o) => o.value === size)) $('size').add(new Option(size, size));
  set('size', size);
  set('perspective', !!scene.perspective);
  set('skip', scene.skip !== false);
  if (scene.iso !== undefined) { $('iso').value = scene.iso; }
  if (scene.view) { state.view.azimuth = scene.view[0]; state.view.elevation = scene.view[1]; state.view.zoom = 1; }
  set('mode', scene.mode || 'iso');
  if (scene.tf) set('tf', scene.tf);
  modeChanged();
  const s = settings();
  s.iso = scene.iso ?? s.iso; // the slider's own step would round it
  const tf = s.hit === 'dvr' ? await transferFunction(s.tf) : null;
  const sc = await currentScene(s);
  const dev = state.gpu.device;
  const canvas = $('view');
  canvas.width = s.size;
  canvas.height = s.size;
  const w = s.size;
  const h = s.size;
  const times = [];
  for (let i = 0; i < (scene.frames || 1); i++) {
    const t0 = performance.now();
    const enc = dev.createCommandEncoder();
    sc.encode(enc, viewOf(s, tf), w, h);
    dev.queue.submit([enc.finish()]);
    await dev.queue.onSubmittedWorkDone();
    times.push(performance.now() - t0);
  }
  const enc = dev.createCommandEncoder();
  sc.encode(enc, viewOf(s, tf), w, h);
  const texture = state.presenter.encode(enc, sc, w, h);
  const rowBytes = Math.ceil((w * 4) / 256) * 256;
  const read = state.gpu.empty(rowBytes * h, GPUBufferUsage.MAP_READ | GPUBufferUsage.COPY_DST);
  enc.copyTextureToBuffer({ texture }, { buffer: read, bytesPerRow: rowBytes }, [w, h]);
  dev.queue.submit([enc.finish()]);
  await read.mapAsync(GPUMapMode.READ);
  const padded = new Uint8Array(read.getMappedRange());
  const rgba = new Uint8Array(w * h * 4);
  for (let y = 0; y < h; y++) rgba.set(padded.subarray(y * rowBytes, y * rowBytes + w * 4), y * w * 4);
  read.unmap();
  times.sort((a, b) => a - b);
  $('stats').textContent = `${sc.filter.name} · ${sc.layout} · ${sc.hit} · ${sc.vol.label}: ${sc.vol.dims.join('x')}, ${sc.vol.samples} samples · `
    + `${w}x${h} in ${times[Math.floor(times.length / 2)].toFixed(1)} ms · ${(100 * sc.emptyShare(s.iso)).toFixed(0)}% of blocks empty · ${state.gpu.info}`;
  return { width: w, height: h, rgba: toBase64(rgba), ms: times[Math.floor(times.length / 2)], samples: sc.vol.samples, dims: sc.vol.dims, adapter: state.gpu.info };
}

/** Compiles every WGSL file of the site in this browser's compiler: [{file, errors: [..]}] for each. */
async function compileAll() {
  const files = [...state.catalog.modules];
  for (const f of state.catalog.filters) for (const l of Object.values(f.shaders)) files.push(...Object.values(l));
  const out = [];
  for (const file of files) {
    try {
      await state.gpu.module(file);
      out.push({ file, errors: [] });
    } catch (e) {
      out.push({ file, errors: e.messages || [String(e)] });
    }
  }
  return out;
}

async function main() {
  const response = await fetch('catalog.json');
  if (!response.ok) throw new Error(`cannot load catalog.json: HTTP ${response.status} (serve the folder that boxforge web wrote)`);
  state.catalog = await response.json();
  $('generator').textContent = state.catalog.generator;
  for (const v of state.catalog.volumes) {
    const o = document.createElement('option');
    o.value = v.name;
    o.textContent = v.description;
    $('volume').appendChild(o);
  }
  fillFilters();
  fillTransferFunctions();
  volumeChanged();
  modeChanged();
  state.gpu = await Gpu.open();
  state.gpu.device.lost.then((info) => showError(`the WebGPU device was lost: ${info.message}`));
  state.gpu.device.addEventListener('uncapturederror', (e) => showError(`WebGPU error: ${e.error.message}`));
  state.presenter = new Presenter(state.gpu, $('view'));
  wireControls();
  requestFrame();
}

const ready = main().catch((e) => { showError(String(e.message || e)); throw e; });
window.boxforge = { ready, renderForTest, compileAll, state };
