// Hand-written references: Mattausch et al.'s two plane-stack schemes on BCC.
//
// Source: O. Mattausch, T. Theussl, H. Hauser and E. Groeller, "Comparison of
// Rendering Methods for BCC Grids" (2003), section 3.1 (bilinear
// interpolation in the 2D CC grid planes of the stack most perpendicular to
// the view) and section 3.2 (bilinear plus spatial interpolation: the
// bilinear values S_i, S_i+1 of the two planes around the point, then
// S_alpha = (1 - alpha) S_i + alpha S_i+1, the paper's equation (1) with
// alpha measured in plane spacings so that constants are reproduced). Cited in
// docs/BOX_SPLINES.md §6.
//
// Neither is a box spline of the catalog: bilinear is discontinuous between
// planes, and bilinear plus spatial is the tensor product hat(u/2) hat(v/2)
// hat(w) of the samples, a box spline whose stack direction (0, 0, 1) is not
// a BCC lattice vector (the generator wants lattice directions). So they
// are written once here, on the generated `bcc_linear` module's clamped
// texel load (lattice point j at texel j, embedded layout).
//
// BCC here is the project's `bcc` lattice: integer points whose three
// coordinates share one parity. Along stack axis k the planes x_k = m
// (integer m) hold the points whose other two coordinates have m's parity:
// a square grid of spacing 2, every second plane shifted by (1, 1). `axis`
// picks the stack (0: x, 1: y, 2: z); the renderer would pick the stack most
// perpendicular to the view, as the paper does. No branch: the axis is
// applied with select().

/// Lattice point with in-plane coordinates (a, b) in plane m of stack `axis`.
fn mattausch_point(a: i32, b: i32, m: i32, axis: i32) -> vec3<i32> {
    return select(select(vec3<i32>(a, b, m), vec3<i32>(a, m, b), axis == 1), vec3<i32>(m, a, b), axis == 0);
}

/// Bilinear interpolation at in-plane position (u, v) in plane m of stack `axis`.
fn mattausch_plane(u: f32, v: f32, m: i32, axis: i32) -> f32 {
    let c = f32(m & 1);
    // The lower-left sample of the square of spacing 2 around (u, v).
    let a = 2.0 * floor((u - c) * 0.5) + c;
    let b = 2.0 * floor((v - c) * 0.5) + c;
    let fu = (u - a) * 0.5;
    let fv = (v - b) * 0.5;
    let ia = i32(a);
    let ib = i32(b);
    let s00 = bcc_linear_fetch(mattausch_point(ia, ib, m, axis));
    let s10 = bcc_linear_fetch(mattausch_point(ia + 2, ib, m, axis));
    let s01 = bcc_linear_fetch(mattausch_point(ia, ib + 2, m, axis));
    let s11 = bcc_linear_fetch(mattausch_point(ia + 2, ib + 2, m, axis));
    return mix(mix(s00, s10, fu), mix(s01, s11, fu), fv);
}

/// The in-plane coordinates (u, v) and the stack coordinate w of p.
fn mattausch_uvw(p: vec3<f32>, axis: i32) -> vec3<f32> {
    return select(select(p, p.xzy, axis == 1), p.yzx, axis == 0);
}

/// Section 3.1: bilinear interpolation in the nearest plane of the stack.
fn mattausch_bilinear(p: vec3<f32>, axis: i32) -> f32 {
    let q = mattausch_uvw(p, axis);
    return mattausch_plane(q.x, q.y, i32(floor(q.z + 0.5)), axis);
}

/// Section 3.2: bilinear in the planes below and above, then linear between them.
fn mattausch_bilinear_spatial(p: vec3<f32>, axis: i32) -> f32 {
    let q = mattausch_uvw(p, axis);
    let m = floor(q.z);
    let alpha = q.z - m;
    let below = mattausch_plane(q.x, q.y, i32(m), axis);
    let above = mattausch_plane(q.x, q.y, i32(m) + 1, axis);
    return (1.0 - alpha) * below + alpha * above;
}

// The z-stack variants as plain evaluation functions fn(p) -> f32.
fn mattausch_bilinear_z(p: vec3<f32>) -> f32 {
    return mattausch_bilinear(p, 2);
}

fn mattausch_bilinear_spatial_z(p: vec3<f32>) -> f32 {
    return mattausch_bilinear_spatial(p, 2);
}
