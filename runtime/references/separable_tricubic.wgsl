// Hand-written reference: the tricubic B-spline as a practitioner writes it.
//
// Source: the uniform cubic B-spline weights of a separable (tensor-product)
// filter, as in C. Sigg and M. Hadwiger, "Fast Third-Order Texture Filtering",
// GPU Gems 2, ch. 20 (2005), eq. 20.1-20.2 (w0..w3 of the fractional
// position), here applied with 64 exact texel loads instead of 8 filtered
// fetches. A textbook formula ( the catalog's
// `cc_tricubic` cites the same chapter).
//
// Coordinates: s(p) = sum_j c_j B(p - j) with B the centred cubic B-spline
// (support [-2, 2] per axis), p in texel units, lattice point j at texel j,
// like `cc_tricubic_eval`. With i = floor(p) and t = p - i, the samples
// i-1 .. i+2 get B(t+1), B(t), B(t-1), B(t-2) = w0 .. w3 below. No scale
// factor: the weights sum to 1.

fn ref_bspline_weights(t: f32) -> vec4<f32> {
    let t2 = t * t;
    let t3 = t2 * t;
    let s = 1.0 - t;
    return vec4<f32>(s * s * s, 3.0 * t3 - 6.0 * t2 + 4.0, -3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0, t3) * (1.0 / 6.0);
}

/// Four samples along x starting at j, weighted by w.
fn ref_tricubic_row(j: vec3<i32>, w: vec4<f32>) -> f32 {
    let f = vec4<f32>(
        cc_tricubic_fetch(j),
        cc_tricubic_fetch(j + vec3<i32>(1, 0, 0)),
        cc_tricubic_fetch(j + vec3<i32>(2, 0, 0)),
        cc_tricubic_fetch(j + vec3<i32>(3, 0, 0)),
    );
    return dot(f, w);
}

/// Sixteen samples of one z-plane starting at j: four rows, weighted by wy.
fn ref_tricubic_plane(j: vec3<i32>, wx: vec4<f32>, wy: vec4<f32>) -> f32 {
    let r = vec4<f32>(
        ref_tricubic_row(j, wx),
        ref_tricubic_row(j + vec3<i32>(0, 1, 0), wx),
        ref_tricubic_row(j + vec3<i32>(0, 2, 0), wx),
        ref_tricubic_row(j + vec3<i32>(0, 3, 0), wx),
    );
    return dot(r, wy);
}

fn separable_tricubic(p: vec3<f32>) -> f32 {
    let i = floor(p);
    let t = p - i;
    let wx = ref_bspline_weights(t.x);
    let wy = ref_bspline_weights(t.y);
    let wz = ref_bspline_weights(t.z);
    let j = vec3<i32>(i) - vec3<i32>(1);
    let q = vec4<f32>(
        ref_tricubic_plane(j, wx, wy),
        ref_tricubic_plane(j + vec3<i32>(0, 0, 1), wx, wy),
        ref_tricubic_plane(j + vec3<i32>(0, 0, 2), wx, wy),
        ref_tricubic_plane(j + vec3<i32>(0, 0, 3), wx, wy),
    );
    return dot(q, wz);
}
