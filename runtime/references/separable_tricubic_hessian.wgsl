// Hand-written reference: the tricubic B-spline's value, gradient and
// Hessian as a practitioner writes them, separably.
//
// Source: the uniform cubic B-spline weights w0..w3 of the fractional
// position (C. Sigg and M. Hadwiger, "Fast Third-Order Texture Filtering",
// GPU Gems 2, ch. 20, 2005, eq. 20.1-20.2, whose derivative filters are the
// derivatives of these weights), and their first and second derivatives in
// t; the 64 samples contracted along x, then y, then z, carrying the value,
// the 3 first and the 6 second derivatives. Coordinates as
// separable_tricubic.wgsl: lattice point j at texel j, i = floor(p),
// t = p - i, samples i-1 .. i+2. Read through the generated module's
// `cc_tricubic_fetch`. `bx_separable(p)` folds every entry into one vec4
// with the same weights as `boxforge bench --hessian` folds the generated
// `cc_tricubic_eval_hessian`.

fn sep_w(t: f32) -> vec4<f32> {
    let s = 1.0 - t;
    let t2 = t * t;
    let t3 = t2 * t;
    return vec4<f32>(s * s * s, 3.0 * t3 - 6.0 * t2 + 4.0, -3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0, t3) * (1.0 / 6.0);
}
fn sep_dw(t: f32) -> vec4<f32> {
    let s = 1.0 - t;
    return vec4<f32>(-0.5 * s * s, 1.5 * t * t - 2.0 * t, -1.5 * t * t + t + 0.5, 0.5 * t * t);
}
fn sep_hw(t: f32) -> vec4<f32> {
    return vec4<f32>(1.0 - t, 3.0 * t - 2.0, 1.0 - 3.0 * t, t);
}
fn bx_separable(p: vec3<f32>) -> vec4<f32> {
    let fl = floor(p);
    let t = p - fl;
    let base = vec3<i32>(fl) - vec3<i32>(1);
    let wx = sep_w(t.x);
    let dx = sep_dw(t.x);
    let hx = sep_hw(t.x);
    let wy = sep_w(t.y);
    let dy = sep_dw(t.y);
    let hy = sep_hw(t.y);
    let wz = sep_w(t.z);
    let dz = sep_dw(t.z);
    let hz = sep_hw(t.z);
    var v = 0.0;
    var g = vec3<f32>(0.0);
    var hd = vec3<f32>(0.0);
    var ho = vec3<f32>(0.0);
    for (var k = 0; k < 4; k++) {
        // Along y for this z: value, d/dx, d2/dx2, d/dy, d2/dxdy, d2/dy2.
        var sy = vec3<f32>(0.0);
        var sdy = vec2<f32>(0.0);
        var shy = 0.0;
        for (var j = 0; j < 4; j++) {
            let r = base + vec3<i32>(0, j, k);
            let f = vec4<f32>(
                cc_tricubic_fetch(r),
                cc_tricubic_fetch(r + vec3<i32>(1, 0, 0)),
                cc_tricubic_fetch(r + vec3<i32>(2, 0, 0)),
                cc_tricubic_fetch(r + vec3<i32>(3, 0, 0)),
            );
            let sx = vec3<f32>(dot(f, wx), dot(f, dx), dot(f, hx));
            sy += wy[j] * sx;
            sdy += dy[j] * sx.xy;
            shy += hy[j] * sx.x;
        }
        // Along z.
        v += wz[k] * sy.x;
        g += vec3<f32>(wz[k] * sy.y, wz[k] * sdy.x, dz[k] * sy.x);
        hd += vec3<f32>(wz[k] * sy.z, wz[k] * shy, hz[k] * sy.x);
        ho += vec3<f32>(wz[k] * sdy.y, dz[k] * sy.y, dz[k] * sdy.x);
    }
    // ho: (xy, xz, yz).
    let hm = mat3x3<f32>(vec3<f32>(hd.x, ho.x, ho.y), vec3<f32>(ho.x, hd.y, ho.z), vec3<f32>(ho.y, ho.z, hd.z));
    return vec4<f32>(hm[0] + 0.5 * hm[1] + 0.25 * hm[2], v + dot(g, vec3<f32>(1.0, 0.5, 0.25)));
}
