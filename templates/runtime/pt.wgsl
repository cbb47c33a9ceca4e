// Projected tetrahedra (Shirley & Tuchman 1990; on BCC: Mattausch, Theussl,
// Hauser & Groeller 2003, section 4), orthographic views, pre-integrated.
// Host: boxforge_runtime::pt. One instance per visible tetrahedron, drawn
// back to front (the instance order is the implicit traversal order);
// 12 vertices per instance = 4 triangles. The vertex shader projects the
// tetrahedron, classifies its projected profile (the paper's two cases,
// figure 6: one vertex inside the triangle of the others -> 3 triangles;
// a convex quadrilateral -> 4 triangles around the crossing of its
// diagonals) and gives the "thick" vertex the front and back values, ray
// parameters and normals of the ray through it; the silhouette vertices get
// zero thickness. The linear interpolant makes both (front and back) planar
// over each triangle, so rasterised linear interpolation is exact. The
// fragment shader clips the segment to the valid box (the ray caster's)
// and composites it front to back from the ray caster's pre-integration
// table (entries for segments of `step` cells) in ceil(length / step)
// sub-segments with opacity correction, then shades it (Gouraud: lighting
// at the vertices, interpolated, modulating the pre-integrated colour with
// the specular term added after; Phong: the normal interpolated, the
// lighting equation per fragment) with the ray caster's light and weight.
// The output is premultiplied and blended "over" onto what lies behind.
struct PtParams {
    eye: vec4<f32>,
    forward: vec4<f32>,
    right: vec4<f32>,
    up: vec4<f32>,
    box_lo: vec4<f32>,
    box_hi: vec4<f32>,
    /// table lo, unused, (n_pi - 1) / (hi - lo), step (cells)
    tf: vec4<f32>,
    /// ambient, diffuse, specular, gradient scale g0 of the shading weight
    light: vec4<f32>,
    /// width, height, shading (0 Gouraud, 1 Phong), normals (0 the cell's gradient, 1 per-vertex)
    image: vec4<i32>,
    /// volume box nx, ny, nz; grid (0 BCC, 1 CC)
    dims: vec4<i32>,
    /// complexes per axis; spacing of their base points
    counts: vec4<i32>,
    /// base point of complex 0; pre-integration entries per axis
    origin: vec4<i32>,
}

@group(0) @binding(0) var<uniform> P: PtParams;
@group(0) @binding(1) var<storage, read> DATA: array<f32>;
/// Vertex offsets of the tetrahedron types, 4 per type.
@group(0) @binding(2) var<storage, read> TYPES: array<vec4<i32>>;
/// Inverse edge matrices of the types, 3 rows per type.
@group(0) @binding(3) var<storage, read> INV: array<vec4<f32>>;
/// Visible tetrahedra back to front: complex index * 16 + type.
@group(0) @binding(4) var<storage, read> IDS: array<u32>;
@group(0) @binding(5) var<storage, read> PI: array<vec4<f32>>;

/// The sample at lattice point j (clamped to the volume). CC: x fastest.
/// BCC: only the lattice points are stored, the all-even ones then the
/// all-odd ones, each a half-resolution grid x fastest (a quarter of the
/// embedded volume's size; boxforge_runtime::pt::render::packed_data).
fn sample(j: vec3<i32>) -> f32 {
    let c = clamp(j, vec3<i32>(0), P.dims.xyz - 1);
    let h = (P.dims.xyz + 1) / 2;
    let bcc = (c.x & 1) * h.x * h.y * h.z + ((c.z >> 1u) * h.y + (c.y >> 1u)) * h.x + (c.x >> 1u);
    let cc = (c.z * P.dims.y + c.y) * P.dims.x + c.x;
    return DATA[select(cc, bcc, P.dims.w == 0)];
}

/// A smooth normal at lattice point j: the least-squares gradient of the
/// nearest neighbours (BCC: the 8 at (+-1, +-1, +-1); CC: central differences).
fn vertex_gradient(j: vec3<i32>) -> vec3<f32> {
    if (P.dims.w == 0) {
        var g = vec3<f32>(0.0);
        for (var k = 0; k < 8; k++) {
            let n = vec3<i32>(select(-1, 1, (k & 1) != 0), select(-1, 1, (k & 2) != 0), select(-1, 1, (k & 4) != 0));
            g = g + vec3<f32>(n) * sample(j + n);
        }
        return g / 8.0;
    }
    return 0.5 * vec3<f32>(
        sample(j + vec3<i32>(1, 0, 0)) - sample(j - vec3<i32>(1, 0, 0)),
        sample(j + vec3<i32>(0, 1, 0)) - sample(j - vec3<i32>(0, 1, 0)),
        sample(j + vec3<i32>(0, 0, 1)) - sample(j - vec3<i32>(0, 0, 1)));
}

fn light_dirs() -> array<vec3<f32>, 2> {
    let dir = P.forward.xyz;
    let l = normalize(-dir + 0.35 * P.up.xyz / max(length(P.up.xyz), 1e-20));
    let hv = normalize(l - dir);
    return array<vec3<f32>, 2>(l, hv);
}

/// (ambient + diffuse, specular, weight) of the ray caster's shading for gradient g.
fn lighting(g: vec3<f32>) -> vec3<f32> {
    let lh = light_dirs();
    let g2 = dot(g, g);
    let wgt = g2 / (g2 + P.light.w * P.light.w);
    let n = g / max(sqrt(g2), 1e-20);
    let h1 = abs(dot(n, lh[1]));
    let h4 = (h1 * h1) * (h1 * h1);
    let h16 = (h4 * h4) * (h4 * h4);
    return vec3<f32>(P.light.x + P.light.y * abs(dot(n, lh[0])), P.light.z * h16 * h4, wgt);
}

struct VOut {
    @builtin(position) pos: vec4<f32>,
    /// front value, back value
    @location(0) s: vec2<f32>,
    /// front and back ray parameter
    @location(1) t: vec2<f32>,
    /// mean of the front and back gradients (Phong)
    @location(2) g: vec3<f32>,
    /// Gouraud lighting: ambient + diffuse, specular, weight
    @location(3) lit: vec3<f32>,
}

/// Barycentric coordinates of p in triangle (a, b, c); w = 0 marks a degenerate triangle.
fn bary(a: vec2<f32>, b: vec2<f32>, c: vec2<f32>, p: vec2<f32>) -> vec4<f32> {
    let d = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if (abs(d) < 1e-12) {
        return vec4<f32>(0.0);
    }
    let l1 = ((p.x - a.x) * (c.y - a.y) - (p.y - a.y) * (c.x - a.x)) / d;
    let l2 = ((b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x)) / d;
    return vec4<f32>(1.0 - l1 - l2, l1, l2, 1.0);
}

fn cross2(a: vec2<f32>, b: vec2<f32>) -> f32 {
    return a.x * b.y - a.y * b.x;
}

@vertex
fn pt_vs(@builtin(vertex_index) vi: u32, @builtin(instance_index) ii: u32) -> VOut {
    let id = IDS[ii];
    let ty = i32(id & 15u);
    let cell = i32(id >> 4u);
    let cc = vec3<i32>(cell % P.counts.x, (cell / P.counts.x) % P.counts.y, cell / (P.counts.x * P.counts.y));
    let base = P.origin.xyz + P.counts.w * cc;
    var pr: array<vec2<f32>, 4>;
    var dep: array<f32, 4>;
    var val: array<f32, 4>;
    var nrm: array<vec3<f32>, 4>;
    let rr = dot(P.right.xyz, P.right.xyz);
    let uu = dot(P.up.xyz, P.up.xyz);
    for (var k = 0; k < 4; k++) {
        let j = base + TYPES[4 * ty + k].xyz;
        let q = vec3<f32>(j) - P.eye.xyz;
        pr[k] = vec2<f32>(dot(q, P.right.xyz) / rr, dot(q, P.up.xyz) / uu);
        dep[k] = dot(q, P.forward.xyz);
        val[k] = sample(j);
    }
    // The interpolant's gradient (constant on the cell), or smooth vertex normals.
    let ds = vec3<f32>(val[1] - val[0], val[2] - val[0], val[3] - val[0]);
    let gc = vec3<f32>(dot(INV[3 * ty].xyz, ds), dot(INV[3 * ty + 1].xyz, ds), dot(INV[3 * ty + 2].xyz, ds));
    for (var k = 0; k < 4; k++) {
        nrm[k] = gc;
        if (P.image.w == 1) {
            nrm[k] = vertex_gradient(base + TYPES[4 * ty + k].xyz);
        }
    }
    // Thick vertex: (screen point, values, ray parameters, normals of both ends).
    var thick = pr[0];
    var sa = val[0];
    var sb = val[0];
    var ta = dep[0];
    var tb = dep[0];
    var na = nrm[0];
    var nb = nrm[0];
    var ring = array<i32, 4>(0, 0, 0, 0);
    var tris = 0;
    // Case 2: two projected edges cross (a convex quadrilateral).
    let pairs = array<vec4<i32>, 3>(vec4<i32>(0, 1, 2, 3), vec4<i32>(0, 2, 1, 3), vec4<i32>(0, 3, 1, 2));
    for (var q = 0; q < 3; q++) {
        let e = pairs[q];
        let a = pr[e.x];
        let b = pr[e.y];
        let c = pr[e.z];
        let d = pr[e.w];
        let den = cross2(b - a, d - c);
        if (abs(den) < 1e-12 || tris != 0) {
            continue;
        }
        let u = cross2(c - a, d - c) / den;
        let w = cross2(c - a, b - a) / den;
        if (u > 0.0 && u < 1.0 && w > 0.0 && w < 1.0) {
            thick = mix(a, b, u);
            sa = mix(val[e.x], val[e.y], u);
            ta = mix(dep[e.x], dep[e.y], u);
            na = mix(nrm[e.x], nrm[e.y], u);
            sb = mix(val[e.z], val[e.w], w);
            tb = mix(dep[e.z], dep[e.w], w);
            nb = mix(nrm[e.z], nrm[e.w], w);
            ring = array<i32, 4>(e.x, e.z, e.y, e.w);
            tris = 4;
        }
    }
    // Case 1: one vertex projects into the triangle of the other three.
    if (tris == 0) {
        var best = -1e30;
        for (var i = 0; i < 4; i++) {
            let j = (i + 1) % 4;
            let k = (i + 2) % 4;
            let l = (i + 3) % 4;
            let bc = bary(pr[j], pr[k], pr[l], pr[i]);
            let m = min(min(bc.x, bc.y), bc.z);
            if (bc.w > 0.5 && m > best) {
                best = m;
                thick = pr[i];
                sa = val[i];
                ta = dep[i];
                na = nrm[i];
                sb = bc.x * val[j] + bc.y * val[k] + bc.z * val[l];
                tb = bc.x * dep[j] + bc.y * dep[k] + bc.z * dep[l];
                nb = bc.x * nrm[j] + bc.y * nrm[k] + bc.z * nrm[l];
                ring = array<i32, 4>(j, k, l, j);
                tris = 3;
            }
        }
    }
    let tri = i32(vi / 3u);
    let corner = i32(vi % 3u);
    var out: VOut;
    // Silhouette corners: zero thickness.
    var p2 = thick;
    var s = vec2<f32>(min(sa, sb), 0.0);
    if (ta <= tb) {
        s = vec2<f32>(sa, sb);
    } else {
        s = vec2<f32>(sb, sa);
    }
    var t = vec2<f32>(min(ta, tb), max(ta, tb));
    var g = 0.5 * (na + nb);
    var lit = 0.5 * (lighting(na) + lighting(nb));
    if (corner != 0) {
        let v = ring[(tri + corner - 1) % 4];
        p2 = pr[v];
        s = vec2<f32>(val[v], val[v]);
        t = vec2<f32>(dep[v], dep[v]);
        g = nrm[v];
        lit = lighting(nrm[v]);
    }
    if (tri >= tris) {
        p2 = thick; // a degenerate triangle: nothing rasterised
    }
    out.pos = vec4<f32>(p2, 0.5, 1.0);
    out.s = s;
    out.t = t;
    out.g = g;
    out.lit = lit;
    return out;
}

/// Pre-integration table lookup, bilinear, clamped: premultiplied (r, g, b, alpha).
fn pi_at(sf: f32, sb: f32) -> vec4<f32> {
    let n = P.origin.w;
    let u = clamp((sf - P.tf.x) * P.tf.z, 0.0, f32(n - 1));
    let w = clamp((sb - P.tf.x) * P.tf.z, 0.0, f32(n - 1));
    let i = min(i32(floor(u)), n - 2);
    let j = min(i32(floor(w)), n - 2);
    let fu = u - f32(i);
    let fw = w - f32(j);
    let top = mix(PI[i * n + j], PI[i * n + j + 1], fw);
    let bottom = mix(PI[(i + 1) * n + j], PI[(i + 1) * n + j + 1], fw);
    return mix(top, bottom, fu);
}

@fragment
fn pt_fs(v: VOut) -> @location(0) vec4<f32> {
    let sx = v.pos.x / f32(P.image.x) * 2.0 - 1.0;
    let sy = 1.0 - v.pos.y / f32(P.image.y) * 2.0;
    let origin = P.eye.xyz + sx * P.right.xyz + sy * P.up.xyz;
    let dir = P.forward.xyz;
    let t_lo = (P.box_lo.xyz - origin) / dir;
    let t_hi = (P.box_hi.xyz - origin) / dir;
    let tmin = min(t_lo, t_hi);
    let tmax = max(t_lo, t_hi);
    let t0 = max(max(max(tmin.x, tmin.y), tmin.z), 0.0);
    let t1 = min(min(tmax.x, tmax.y), tmax.z);
    let ta = max(v.t.x, t0);
    let tb = min(v.t.y, t1);
    if (tb <= ta) {
        return vec4<f32>(0.0);
    }
    let len = v.t.y - v.t.x;
    var sa = v.s.x;
    var sb = v.s.y;
    if (len > 1e-6) {
        sa = mix(v.s.x, v.s.y, (ta - v.t.x) / len);
        sb = mix(v.s.x, v.s.y, (tb - v.t.x) / len);
    }
    let step = P.tf.w;
    let l = tb - ta;
    let n = clamp(i32(ceil(l / step - 1e-4)), 1, 256);
    let r = l / (f32(n) * step);
    var acc = vec3<f32>(0.0);
    var alpha = 0.0;
    for (var k = 0; k < n; k++) {
        let e = pi_at(mix(sa, sb, f32(k) / f32(n)), mix(sa, sb, f32(k + 1) / f32(n)));
        // The table is for `step`: opacity 1 - (1 - a)^r, colour scaled alike.
        let a = 1.0 - exp(r * log(max(1.0 - e.w, 1e-30)));
        var c = e.xyz * r;
        if (e.w > 1e-6) {
            c = e.xyz * (a / e.w);
        }
        acc = acc + (1.0 - alpha) * c;
        alpha = alpha + (1.0 - alpha) * a;
    }
    var sh = v.lit;
    if (P.image.z == 1) {
        sh = lighting(v.g);
    }
    let shaded = acc * sh.x + vec3<f32>(alpha * sh.y);
    return vec4<f32>(mix(acc, shaded, sh.z), alpha);
}
