// Hand-written reference: tricubic B-spline in 8 trilinear (hardware
// filtered) fetches.
//
// Source: C. Sigg and M. Hadwiger, "Fast Third-Order Texture Filtering",
// GPU Gems 2, ch. 20 (2005), section 20.2-20.3: per axis the four B-spline
// weights w0..w3 collapse into two linear fetches with weights
// g0 = w0 + w1, g1 = w2 + w3 at offsets h0 = w1 / g0 - 1, h1 = w3 / g1 + 1
// from the sample i = floor(p); the tensor product gives 8 trilinear fetches.
// A textbook method ( the catalog's `cc_tricubic`
// cites the same chapter).
//
// Coordinates: s(p) = sum_j c_j B(p - j), B the centred cubic B-spline, p in
// texel units with lattice point j at texel j, like `cc_tricubic_eval`. The
// texel j has its centre at normalized coordinate (j + 0.5) / size, so a
// filtered fetch at texel-unit position h reads (h + 0.5) / size. No scale
// factor. Boundary: the sampler clamps to the edge (the bench keeps points
// where the stencil is inside the volume).
//
// Bindings: `ref_linear` (group 1, binding 0) is a linear-filtering,
// clamp-to-edge sampler; the harness binds `cc_tricubic_volume` as a
// filterable texture (R32Float needs the FLOAT32_FILTERABLE feature).

@group(1) @binding(0) var ref_linear: sampler;

fn sigg_hadwiger_tricubic(p: vec3<f32>) -> f32 {
    let size = vec3<f32>(textureDimensions(cc_tricubic_volume));
    let i = floor(p);
    let t = p - i;
    let s = 1.0 - t;
    let t2 = t * t;
    let t3 = t2 * t;
    // B-spline weights per axis (vectors over x, y, z).
    let w0 = s * s * s * (1.0 / 6.0);
    let w1 = (3.0 * t3 - 6.0 * t2 + 4.0) * (1.0 / 6.0);
    let w2 = (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) * (1.0 / 6.0);
    let w3 = t3 * (1.0 / 6.0);
    let g0 = w0 + w1;
    let g1 = w2 + w3;
    // Linear-fetch positions (texel units), then normalized coordinates.
    let h0 = (i - 1.0 + w1 / g0 + 0.5) / size;
    let h1 = (i + 1.0 + w3 / g1 + 0.5) / size;
    let t000 = textureSampleLevel(cc_tricubic_volume, ref_linear, vec3<f32>(h0.x, h0.y, h0.z), 0.0).x;
    let t100 = textureSampleLevel(cc_tricubic_volume, ref_linear, vec3<f32>(h1.x, h0.y, h0.z), 0.0).x;
    let t010 = textureSampleLevel(cc_tricubic_volume, ref_linear, vec3<f32>(h0.x, h1.y, h0.z), 0.0).x;
    let t110 = textureSampleLevel(cc_tricubic_volume, ref_linear, vec3<f32>(h1.x, h1.y, h0.z), 0.0).x;
    let t001 = textureSampleLevel(cc_tricubic_volume, ref_linear, vec3<f32>(h0.x, h0.y, h1.z), 0.0).x;
    let t101 = textureSampleLevel(cc_tricubic_volume, ref_linear, vec3<f32>(h1.x, h0.y, h1.z), 0.0).x;
    let t011 = textureSampleLevel(cc_tricubic_volume, ref_linear, vec3<f32>(h0.x, h1.y, h1.z), 0.0).x;
    let t111 = textureSampleLevel(cc_tricubic_volume, ref_linear, vec3<f32>(h1.x, h1.y, h1.z), 0.0).x;
    // Mix along x, then y, then z with the g weights.
    let y0z0 = g0.x * t000 + g1.x * t100;
    let y1z0 = g0.x * t010 + g1.x * t110;
    let y0z1 = g0.x * t001 + g1.x * t101;
    let y1z1 = g0.x * t011 + g1.x * t111;
    let z0 = g0.y * y0z0 + g1.y * y1z0;
    let z1 = g0.y * y0z1 + g1.y * y1z1;
    return g0.z * z0 + g1.z * z1;
}
