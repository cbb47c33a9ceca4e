// Hand-written reference: fcc6, the cubic six-direction box spline on FCC.
//
// Source: M. Kim, "GPU isosurface ray casting of FCC datasets" (Kim 2013),
// Figure 5 (branch-free GLSL: parity reflection, tetrahedron type from four
// knot-plane tests, reflection into the reference cube, 19 fetches each one
// vector add from the last) followed, as the paper says, by "a BB-form of
// the polynomial piece based on Table 1 in Kim et al. [2008]" evaluated "using
// the de Casteljau algorithm". Figure 5 is ported statement by statement
// (GLSL's implicit conversions explicit; FETCH(i) is `fcc6_fetch(f)`, the
// generated module's clamped texel load, lattice point j at texel j, so both
// sides pay the same loads; `>> 1` on i32 is arithmetic, as in GLSL).
//
// The BB coefficients: Kim et al. 2008's Table 1 is not among this project's
// sources, so the two tables below (the 20 cubic BB coefficients of the
// reference corner tetrahedron tau0 = [0, e1, e2, e3] and of the central
// tetrahedron tau4 = [e1, e2, e3, e1+e2+e3], each as 24x a combination of the
// fetched samples c00..c18 in Figure 5's order) were computed once from the
// box spline's definition: the exact rational weights phi(x - j) of the
// project's oracle (the recursive box-spline definition, independent of the
// generator's pieces) at 20 points inside each tetrahedron, solved against
// the Bernstein basis. As the paper states, each piece uses 16 of the 19
// samples (tau0: all but c04, c09, c14; tau4: all but c07, c12, c17).
// runtime/tests/it/bench_refs.rs checks the result against the generated
// fcc6_eval on the device.
//
// Branch-free as in the paper: both tables are formed and blended by the
// tetrahedron type (0 corner, 1 centre), then one de Casteljau pass in the
// barycentric coordinates of the blended tetrahedron.
// Scale: the tables sum to 24 x the partition of unity; divided at the end.

fn kim_fcc6(p_in: vec3<f32>) -> f32 {
    var f = vec3<i32>(floor(p_in));
    var p_cube = p_in - vec3<f32>(f);
    let parity = (f.x + f.y + f.z) & 1;
    var p_local = p_cube;
    p_cube += f32(parity) * (1.0 - 2.0 * p_cube);
    let vitet = vec4<f32>(vec4<bool>(
        dot(p_cube, vec3<f32>(-1.0, -1.0, -1.0)) > -1.0,
        dot(p_cube, vec3<f32>(1.0, 1.0, -1.0)) > 1.0,
        dot(p_cube, vec3<f32>(1.0, -1.0, 1.0)) > 1.0,
        dot(p_cube, vec3<f32>(-1.0, 1.0, 1.0)) > 1.0,
    ));
    let tet_type = 1.0 - (vitet.x + vitet.y + vitet.z + vitet.w);
    var offset = i32(vitet.y + vitet.z + vitet.w) * (vec3<i32>(1) - vec3<i32>(vitet.wzy));
    offset += parity * (vec3<i32>(1) - 2 * offset);
    var R = vec3<i32>(1) - 2 * offset;
    p_local = vec3<f32>(offset) + vec3<f32>(R) * p_local;
    f += offset;
    R *= 2;

    let c00 = fcc6_fetch(f);
    f.x += R.x; let c01 = fcc6_fetch(f);
    f.x -= R.x; f.y += R.y; let c02 = fcc6_fetch(f);
    f.y -= R.y; f.z += R.z; let c03 = fcc6_fetch(f);
    f.x += R.x; f.y += R.y >> 1u; f.z -= R.z >> 1u; let c04 = fcc6_fetch(f);
    f.x -= R.x; let c05 = fcc6_fetch(f);
    f.z -= R.z; let c06 = fcc6_fetch(f);
    f.y -= R.y; let c07 = fcc6_fetch(f);
    f.z += R.z; let c08 = fcc6_fetch(f);
    f.x += R.x >> 1u; f.y += (3 * R.y) >> 1u; let c09 = fcc6_fetch(f);
    f.y -= R.y; let c10 = fcc6_fetch(f);
    f.x -= R.x; let c11 = fcc6_fetch(f);
    f.z -= R.z; let c12 = fcc6_fetch(f);
    f.x += R.x; let c13 = fcc6_fetch(f);
    f.y += R.y >> 1u; f.z += (3 * R.z) >> 1u; let c14 = fcc6_fetch(f);
    f.z -= R.z; let c15 = fcc6_fetch(f);
    f.x -= R.x; let c16 = fcc6_fetch(f);
    f.y -= R.y; let c17 = fcc6_fetch(f);
    f.x += R.x; let c18 = fcc6_fetch(f);

    // 24 x BB coefficients of tau0 (a) and tau4 (b), index = barycentric exponents.
    let a3000 = 12.0 * c00 + c05 + c06 + c07 + c08 + c10 + c11 + c12 + c13 + c15 + c16 + c17 + c18;
    let a2100 = 12.0 * c00 + c05 + c06 + c07 + c08 + 2.0 * c10 + 2.0 * c13 + 2.0 * c15 + 2.0 * c18;
    let a2010 = 12.0 * c00 + 2.0 * c05 + 2.0 * c06 + c10 + c11 + c12 + c13 + 2.0 * c15 + 2.0 * c16;
    let a2001 = 12.0 * c00 + 2.0 * c05 + 2.0 * c08 + 2.0 * c10 + 2.0 * c11 + c15 + c16 + c17 + c18;
    let a1200 = 8.0 * c00 + 4.0 * c10 + 4.0 * c13 + 4.0 * c15 + 4.0 * c18;
    let a1110 = 12.0 * c00 + 2.0 * c05 + 2.0 * c06 + 2.0 * c10 + 2.0 * c13 + 4.0 * c15;
    let a1101 = 12.0 * c00 + 2.0 * c05 + 2.0 * c08 + 4.0 * c10 + 2.0 * c15 + 2.0 * c18;
    let a1020 = 8.0 * c00 + 4.0 * c05 + 4.0 * c06 + 4.0 * c15 + 4.0 * c16;
    let a1011 = 12.0 * c00 + 4.0 * c05 + 2.0 * c10 + 2.0 * c11 + 2.0 * c15 + 2.0 * c16;
    let a1002 = 8.0 * c00 + 4.0 * c05 + 4.0 * c08 + 4.0 * c10 + 4.0 * c11;
    let a0300 = 4.0 * c00 + 4.0 * c01 + 4.0 * c10 + 4.0 * c13 + 4.0 * c15 + 4.0 * c18;
    let a0210 = 8.0 * c00 + 4.0 * c10 + 4.0 * c13 + 8.0 * c15;
    let a0201 = 8.0 * c00 + 8.0 * c10 + 4.0 * c15 + 4.0 * c18;
    let a0120 = 8.0 * c00 + 4.0 * c05 + 4.0 * c06 + 8.0 * c15;
    let a0111 = 12.0 * c00 + 4.0 * c05 + 4.0 * c10 + 4.0 * c15;
    let a0102 = 8.0 * c00 + 4.0 * c05 + 4.0 * c08 + 8.0 * c10;
    let a0030 = 4.0 * c00 + 4.0 * c02 + 4.0 * c05 + 4.0 * c06 + 4.0 * c15 + 4.0 * c16;
    let a0021 = 8.0 * c00 + 8.0 * c05 + 4.0 * c15 + 4.0 * c16;
    let a0012 = 8.0 * c00 + 8.0 * c05 + 4.0 * c10 + 4.0 * c11;
    let a0003 = 4.0 * c00 + 4.0 * c03 + 4.0 * c05 + 4.0 * c08 + 4.0 * c10 + 4.0 * c11;
    let b3000 = 4.0 * c00 + 4.0 * c01 + 4.0 * c10 + 4.0 * c13 + 4.0 * c15 + 4.0 * c18;
    let b2100 = 8.0 * c00 + 4.0 * c10 + 4.0 * c13 + 8.0 * c15;
    let b2010 = 8.0 * c00 + 8.0 * c10 + 4.0 * c15 + 4.0 * c18;
    let b2001 = 4.0 * c00 + 4.0 * c01 + 8.0 * c10 + 8.0 * c15;
    let b1200 = 8.0 * c00 + 4.0 * c05 + 4.0 * c06 + 8.0 * c15;
    let b1110 = 12.0 * c00 + 4.0 * c05 + 4.0 * c10 + 4.0 * c15;
    let b1101 = 4.0 * c00 + 4.0 * c05 + 4.0 * c10 + 12.0 * c15;
    let b1020 = 8.0 * c00 + 4.0 * c05 + 4.0 * c08 + 8.0 * c10;
    let b1011 = 4.0 * c00 + 4.0 * c05 + 12.0 * c10 + 4.0 * c15;
    let b1002 = 4.0 * c04 + 4.0 * c05 + 8.0 * c10 + 8.0 * c15;
    let b0300 = 4.0 * c00 + 4.0 * c02 + 4.0 * c05 + 4.0 * c06 + 4.0 * c15 + 4.0 * c16;
    let b0210 = 8.0 * c00 + 8.0 * c05 + 4.0 * c15 + 4.0 * c16;
    let b0201 = 4.0 * c00 + 4.0 * c02 + 8.0 * c05 + 8.0 * c15;
    let b0120 = 8.0 * c00 + 8.0 * c05 + 4.0 * c10 + 4.0 * c11;
    let b0111 = 4.0 * c00 + 12.0 * c05 + 4.0 * c10 + 4.0 * c15;
    let b0102 = 8.0 * c05 + 4.0 * c09 + 4.0 * c10 + 8.0 * c15;
    let b0030 = 4.0 * c00 + 4.0 * c03 + 4.0 * c05 + 4.0 * c08 + 4.0 * c10 + 4.0 * c11;
    let b0021 = 4.0 * c00 + 4.0 * c03 + 8.0 * c05 + 8.0 * c10;
    let b0012 = 8.0 * c05 + 8.0 * c10 + 4.0 * c14 + 4.0 * c15;
    let b0003 = 4.0 * c04 + 4.0 * c05 + 4.0 * c09 + 4.0 * c10 + 4.0 * c14 + 4.0 * c15;

    let k3000 = a3000 + tet_type * (b3000 - a3000);
    let k2100 = a2100 + tet_type * (b2100 - a2100);
    let k2010 = a2010 + tet_type * (b2010 - a2010);
    let k2001 = a2001 + tet_type * (b2001 - a2001);
    let k1200 = a1200 + tet_type * (b1200 - a1200);
    let k1110 = a1110 + tet_type * (b1110 - a1110);
    let k1101 = a1101 + tet_type * (b1101 - a1101);
    let k1020 = a1020 + tet_type * (b1020 - a1020);
    let k1011 = a1011 + tet_type * (b1011 - a1011);
    let k1002 = a1002 + tet_type * (b1002 - a1002);
    let k0300 = a0300 + tet_type * (b0300 - a0300);
    let k0210 = a0210 + tet_type * (b0210 - a0210);
    let k0201 = a0201 + tet_type * (b0201 - a0201);
    let k0120 = a0120 + tet_type * (b0120 - a0120);
    let k0111 = a0111 + tet_type * (b0111 - a0111);
    let k0102 = a0102 + tet_type * (b0102 - a0102);
    let k0030 = a0030 + tet_type * (b0030 - a0030);
    let k0021 = a0021 + tet_type * (b0021 - a0021);
    let k0012 = a0012 + tet_type * (b0012 - a0012);
    let k0003 = a0003 + tet_type * (b0003 - a0003);

    // Barycentric coordinates of p_local in tau0 and in tau4, blended by type.
    let x = p_local.x;
    let y = p_local.y;
    let z = p_local.z;
    let d = 0.5 * (x + y + z - 1.0);
    let w = mix(vec4<f32>(1.0 - x - y - z, x, y, z), vec4<f32>(x - d, y - d, z - d, d), tet_type);

    // de Casteljau: cubic -> quadratic -> linear -> value.
    let l2000 = w.x * k3000 + w.y * k2100 + w.z * k2010 + w.w * k2001;
    let l1100 = w.x * k2100 + w.y * k1200 + w.z * k1110 + w.w * k1101;
    let l1010 = w.x * k2010 + w.y * k1110 + w.z * k1020 + w.w * k1011;
    let l1001 = w.x * k2001 + w.y * k1101 + w.z * k1011 + w.w * k1002;
    let l0200 = w.x * k1200 + w.y * k0300 + w.z * k0210 + w.w * k0201;
    let l0110 = w.x * k1110 + w.y * k0210 + w.z * k0120 + w.w * k0111;
    let l0101 = w.x * k1101 + w.y * k0201 + w.z * k0111 + w.w * k0102;
    let l0020 = w.x * k1020 + w.y * k0120 + w.z * k0030 + w.w * k0021;
    let l0011 = w.x * k1011 + w.y * k0111 + w.z * k0021 + w.w * k0012;
    let l0002 = w.x * k1002 + w.y * k0102 + w.z * k0012 + w.w * k0003;
    let m1000 = w.x * l2000 + w.y * l1100 + w.z * l1010 + w.w * l1001;
    let m0100 = w.x * l1100 + w.y * l0200 + w.z * l0110 + w.w * l0101;
    let m0010 = w.x * l1010 + w.y * l0110 + w.z * l0020 + w.w * l0011;
    let m0001 = w.x * l1001 + w.y * l0101 + w.z * l0011 + w.w * l0002;
    let n0000 = w.x * m1000 + w.y * m0100 + w.z * m0010 + w.w * m0001;
    return n0000 * (1.0 / 24.0);
}
