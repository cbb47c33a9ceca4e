// Hand-written reference: bcc7, the quartic seven-direction box spline on BCC.
//
// Source: M. Kim and Y. Lee, "Real-time BCC volume isosurface ray casting on
// the GPU" (KCGS 2012 / Kim 2013), Figure 7 (branch-free GLSL: parity,
// reflection, permutation, 30 axis-aligned fetches) and M. Kim's slides "GPU
// isosurface ray casting of BCC and FCC data with box splines" (the same GLSL
// and the "Simplified Symbolic Formula" for the reference tetrahedron
// 1 >= x >= y >= z >= 0). Both are cited in
// docs/BOX_SPLINES.md §6 (paper, Figure 7; slides, "GLSL Code" and
// "Simplified Symbolic Formula").
//
// Port: the GLSL statements in their published order (same locate, same fetch
// order with one vector add per fetch, same formula grouping), written in WGSL:
// GLSL's implicit int -> float conversions are explicit, `R[3]` is three
// lets, and FETCH(var) is `bcc7_fetch(o)`, the generated module's clamped
// texel load (lattice point j at texel j), so both sides pay the same loads.
//
// Scale: the formula as published has no overall factor; with every c = 1 it
// sums to 384 (checked symbolically: constants give 384, c_j = j_x gives
// 384 x, so the formula is already centred and in texel units). It is divided
// by 384 here so the spline is a partition of unity like `bcc7_eval`
// (s(p) = sum_j c_j phi(p - j), phi the centred box spline). No shift was
// needed: Kim & Lee's lattice (all-even and all-odd integer points) is the
// project's `bcc` lattice in the embedded layout.

fn kim_lee_bcc7(p_in: vec3<f32>) -> f32 {
    let xlow = vec3<i32>(p_in);
    let parity = vec3<i32>(xlow.x & 1, xlow.y & 1, xlow.z & 1);
    var o = xlow + parity;
    let Rc = vec3<i32>(1, 1, 1) - 2 * parity;
    let xc = vec3<f32>(Rc) * (p_in - vec3<f32>(o));
    let itet = (i32(xc.y >= xc.x) << 2u) + (i32(xc.z >= xc.x) << 1u) + i32(xc.z >= xc.y);
    let itv1 = vec3<i32>(vec3<bool>(itet == 0, itet == 1, itet == 3));
    let itv2 = vec3<i32>(vec3<bool>(itet == 4, itet == 6, itet == 7));
    let IT0 = itv1.x;
    let IT1 = itv1.y;
    let IT3 = itv1.z;
    let IT4 = itv2.x;
    let IT6 = itv2.y;
    let IT7 = itv2.z;
    let xtet = f32(IT0) * xc.xyz + f32(IT1) * xc.xzy + f32(IT3) * xc.zxy + f32(IT4) * xc.yxz + f32(IT6) * xc.yzx + f32(IT7) * xc.zyx;
    let R0 = 2 * vec3<i32>(Rc.x * (IT0 + IT1), Rc.y * (IT4 + IT6), Rc.z * (IT3 + IT7));
    let R1 = 2 * vec3<i32>(Rc.x * (IT3 + IT4), Rc.y * (IT0 + IT7), Rc.z * (IT1 + IT6));
    let R2 = 2 * vec3<i32>(Rc.x * (IT6 + IT7), Rc.y * (IT1 + IT3), Rc.z * (IT0 + IT4));
    let one = vec3<u32>(1u);

    let c01 = bcc7_fetch(o); o -= R0;   let c11 = bcc7_fetch(o); o += (R0 << one); let c10 = bcc7_fetch(o);
    o -= R1;   let c21 = bcc7_fetch(o); o -= R0;   let c13 = bcc7_fetch(o); o += (R1 << one); let c12 = bcc7_fetch(o);
    o += R0;   let c20 = bcc7_fetch(o); o -= R2;   let c30 = bcc7_fetch(o); o -= R1;   let c19 = bcc7_fetch(o);
    o -= R0;   let c15 = bcc7_fetch(o); o += R1;   let c17 = bcc7_fetch(o); o += (R2 << one); let c16 = bcc7_fetch(o);
    o += R0;   let c29 = bcc7_fetch(o); o -= R1;   let c18 = bcc7_fetch(o); o -= R0;   let c14 = bcc7_fetch(o);
    o += ((-R0 + R1 - 3 * R2) >> one); let c07 = bcc7_fetch(o);
    o -= R1;   let c09 = bcc7_fetch(o); o += R0;   let c05 = bcc7_fetch(o); o += (R1 << one); let c27 = bcc7_fetch(o);
    o -= R1;   let c03 = bcc7_fetch(o); o += (R2 << one); let c28 = bcc7_fetch(o); o -= R2;   let c02 = bcc7_fetch(o);
    o += R1;   let c26 = bcc7_fetch(o); o -= (R1 << one); let c04 = bcc7_fetch(o); o -= R0;   let c08 = bcc7_fetch(o);
    o += R1;   let c06 = bcc7_fetch(o); o += (R0 << one); let c22 = bcc7_fetch(o); o -= R2;   let c23 = bcc7_fetch(o);
    o -= R1;   let c25 = bcc7_fetch(o); o += R2;   let c24 = bcc7_fetch(o);

    // The "Simplified Symbolic Formula" at xtet, term by term.
    let x = xtet.x;
    let y = xtet.y;
    let z = xtet.z;
    let x2 = x * x;
    let xm1 = x - 1.0;
    let xm1_2 = xm1 * xm1;
    let tmx = 3.0 - x;
    let tmx_2 = tmx * tmx;
    let xm2 = x - 2.0;
    let xm2_2 = xm2 * xm2;
    let xp1 = x + 1.0;
    let xp1_2 = xp1 * xp1;
    let z2 = z * z;
    let zm1 = z - 1.0;
    let zm1_2 = zm1 * zm1;
    let zp1 = z + 1.0;
    let zp1_2 = zp1 * zp1;
    let zm2 = z - 2.0;
    let zm2_2 = zm2 * zm2;
    let zp2 = z + 2.0;
    let zp2_2 = zp2 * zp2;
    let s8 = -x2 * x2 * (c10 + c20)
        + xm1_2 * xm1_2 * (c01 - c06 - c07 - c08 - c09 + c11 + c12 + c13 + c15)
        + tmx_2 * tmx_2 * c01
        - xm2_2 * xm2_2 * (c01 - c06 + c12)
        + xp1_2 * xp1_2 * c10
        + z2 * z2 * (c02 + c04 - c14 - c16 - c18 + c22 + c26 + c28 - c29)
        - zm1_2 * zm1_2 * (c03 + c05)
        - zp1_2 * zp1_2 * (c02 + c04 - c14)
        + zm2_2 * zm2_2 * c03
        + zp2_2 * zp2_2 * c02;

    let xpy = x + y;
    let xmy = x - y;
    let ypz = y + z;
    let ymz = y - z;
    let xpz = x + z;
    let xmz = x - z;
    let a1 = xmy - 2.0;
    let a2 = ypz - 2.0;
    let a3 = ymz - 2.0;
    let s4 = -xpy * xpy * xpy * (2.0 + xmy) * (c10 - c20)
        - a1 * a1 * a1 * (xpy - 4.0) * (c01 - c12)
        + a2 * a2 * a2 * (2.0 + ymz) * (c03 - c05)
        + a3 * a3 * a3 * (2.0 + ypz) * (c02 - c04);

    let b1 = xpy - 2.0;
    let b2 = xpz - 2.0;
    let b3 = xmz - 2.0;
    let s2 = -xmy * xmy * xmy * (4.0 * (c10 - c21) - 2.0 * z * (c24 - c25) - xpy * (2.0 * (c20 - c21) + c24 + c25))
        - xpz * xpz * xpz * (4.0 * (c02 + c04 + c10 + c14 - c18) + 2.0 * y * (c02 - c04 - c10 + c20 - c22) - xmz * (2.0 * (c14 - c18) + c02 + c04 - c10 - c20 + c22))
        + xmz * xmz * xmz * (-4.0 * (c03 + c05 + c10 - c19) - 2.0 * y * (c03 - c05 - c10 + c20 - c23) + xpz * (c03 + c05 - c10 - 2.0 * c19 - c20 + c23))
        - ypz * ypz * ypz * (4.0 * (c02 - c04 + c14 - c16) - 2.0 * x * (c14 - c16 - c18 - c22 + c29) + ymz * (2.0 * (c04 - c26) - c14 + c16 - c18 - c22 + c29))
        - ymz * ymz * ymz * (4.0 * (c03 - c05 - c17) + 2.0 * x * (c17 + c19 + c23 - c30) - ypz * (-2.0 * (c05 - c27) + c23 - c17 + c19 - c30))
        + b1 * b1 * b1 * (4.0 * (c01 - c12) + 2.0 * (c06 + c07 - c08 - c09 + c15) + 2.0 * z * (c06 - c07 - c08 + c09 - c15) - xmy * (c06 + c07 - c08 - c09 + c15 - 2.0 * (c12 - c13)))
        + b2 * b2 * b2 * (6.0 * c01 + 2.0 * (c03 + c05 + c12 - c15) + 4.0 * (c06 - c07) - 2.0 * y * (c01 - c03 + c05 - c12 - c15) - xmz * (c01 - c03 - c05 + c12 + c15 + 2.0 * (c06 - c07)))
        + b3 * b3 * b3 * (6.0 * c01 + 2.0 * (c02 + c04 + c12) - 2.0 * y * (c01 - c02 + c04 - c12) - xpz * (c01 - c02 - c04 + c12));

    return (8.0 * s8 + 4.0 * s4 + 2.0 * s2) * (1.0 / 384.0);
}
