// Hand-written reference: value, gradient and Hessian of cc6 (the cubic
// six-direction box spline on the Cartesian lattice, directions the face
// diagonals) by Kim & Kim's method.
//
// Method: H. Kim and M. Kim, "Volume reconstruction with the six-direction
// cubic box-spline", Graphical Models 125, 101168, 2023
// (doi:10.1016/j.gmod.2022.101168), as published by the authors in the
// GitHub repository cg-uos/cc6, file cc6_raycast_curvature.frag (no
// licence attached: this file is our own WGSL, written after reading it).
// The method: take the nearest lattice point, reflect p into the positive
// octant of its Voronoi cube (8 sign changes), classify it into one of five
// tetrahedra of [0, 1/2]^3 cut by the planes x = y + z (cyclically) and
// x + y + z = 1 -- three "edge" (red) tetrahedra related by the cyclic axis
// permutations, one "vertex" (green) and one "octahedron" (blue) -- fetch
// the 38 samples of the union stencil, and evaluate per tetrahedron type a
// cubic for the value, three quadratics for the gradient and six linear
// forms for the Hessian, in barycentric coordinates u of the type's
// reference tetrahedron; map gradient and Hessian back. As published, the
// value and the gradient evaluate the formulas of all three types and weight
// them by the type (branch-free); the Hessian selects its type by a switch.
// The polynomial coefficients are the published ones (transcribed as
// mathematics, with the repository's sample numbering c0..c37); locate,
// stencil and back-mapping are written here: with the frame axes
// a_k = R e_((P + k) mod 3) (R the reflection, P the cyclic permutation) the
// stencil is a fixed table of lattice vectors in that frame, the gradient is
// F g_ref with F = [a_0 a_1 a_2], the Hessian's diagonal the permuted
// diagonal and its off-diagonal (yz, zx, xy) det(R) F applied to the
// reference one (= F H_ref F^T, the published permute-and-sign rule).
//
// Coordinates: lattice point j at texel j, read through the generated
// module's `cc6_fetch`. Scale, per lattice unit: value 1/384, gradient 1/64,
// Hessian 1/16 (the published DENOM_M, DENOM_G, DENOM_H; the published
// normalisation to texture space, scale_norm, dropped). Checked against
// `cc6_eval_hessian` by `boxforge bench --hessian`.
//
// One published term is corrected here. Checked term by term against
// central differences of the published value cubics (in f64, every sample,
// each tetrahedron type), all gradient quadratics and all Hessian forms but
// one are the derivatives; the red type's d2/dydz reads
// 2*u0*((A) + u3*(A)), A = c6 - c8 - c13 + c15 + c19 - c21 - c26 + c28,
// where the cubic's derivative is 2*(u0*A + u3*A): a misplaced parenthesis,
// moved here (same operation count). `bx_kim_cc6(p)` folds
// every entry into one vec4 with the bench's weights.

fn bx_kim_cc6(p: vec3<f32>) -> vec4<f32> {
    // Nearest lattice point, reflection into the positive octant.
    let org = vec3<i32>(round(p));
    let pl = p - vec3<f32>(org);
    let ri = select(vec3<i32>(-1), vec3<i32>(1), pl > vec3<f32>(0.0));
    let r = vec3<f32>(ri);
    let pc = pl * r;
    // Tetrahedron type (0 blue, 1 green, 2 red) and cyclic permutation.
    let b0 = pc.x - pc.y - pc.z > 0.0;
    let b1 = pc.y - pc.x - pc.z > 0.0;
    let b2 = pc.z - pc.x - pc.y > 0.0;
    let b3 = pc.x + pc.y + pc.z > 1.0;
    let edge = b0 || b1 || b2;
    let tt = select(select(1u, 0u, b3), 2u, edge);
    // One-hot of the axis that becomes the reference x (P = 0, 1, 2), and of
    // the axes that become y and z.
    let ex = vec3<i32>(vec3<bool>(!b1 && !b2, b1, b2));
    let ey = ex.zxy;
    let ez = ex.yzx;
    let ax = ri * ex;
    let ay = ri * ey;
    let az = ri * ez;
    let x = dot(pc, vec3<f32>(ex));
    let y = dot(pc, vec3<f32>(ey));
    let z = dot(pc, vec3<f32>(ez));

    // The 38 samples, at org + k0 a_0 + k1 a_1 + k2 a_2.
    let c0 = cc6_fetch(org - ax - ay);
    let c1 = cc6_fetch(org - ax - az);
    let c2 = cc6_fetch(org - ax);
    let c3 = cc6_fetch(org - ax + az);
    let c4 = cc6_fetch(org - ax + ay);
    let c5 = cc6_fetch(org - ax + ay + az);
    let c6 = cc6_fetch(org - ay - az);
    let c7 = cc6_fetch(org - ay);
    let c8 = cc6_fetch(org - ay + az);
    let c9 = cc6_fetch(org - az);
    let c10 = cc6_fetch(org);
    let c11 = cc6_fetch(org + az);
    let c12 = cc6_fetch(org + 2 * az);
    let c13 = cc6_fetch(org + ay - az);
    let c14 = cc6_fetch(org + ay);
    let c15 = cc6_fetch(org + ay + az);
    let c16 = cc6_fetch(org + ay + 2 * az);
    let c17 = cc6_fetch(org + 2 * ay);
    let c18 = cc6_fetch(org + 2 * ay + az);
    let c19 = cc6_fetch(org + ax - ay - az);
    let c20 = cc6_fetch(org + ax - ay);
    let c21 = cc6_fetch(org + ax - ay + az);
    let c22 = cc6_fetch(org + ax - az);
    let c23 = cc6_fetch(org + ax);
    let c24 = cc6_fetch(org + ax + az);
    let c25 = cc6_fetch(org + ax + 2 * az);
    let c26 = cc6_fetch(org + ax + ay - az);
    let c27 = cc6_fetch(org + ax + ay);
    let c28 = cc6_fetch(org + ax + ay + az);
    let c29 = cc6_fetch(org + ax + ay + 2 * az);
    let c30 = cc6_fetch(org + ax + 2 * ay);
    let c31 = cc6_fetch(org + ax + 2 * ay + az);
    let c32 = cc6_fetch(org + 2 * ax - ay);
    let c33 = cc6_fetch(org + 2 * ax - az);
    let c34 = cc6_fetch(org + 2 * ax);
    let c35 = cc6_fetch(org + 2 * ax + az);
    let c36 = cc6_fetch(org + 2 * ax + ay);
    let c37 = cc6_fetch(org + 2 * ax + ay + az);
    // Barycentric coordinates of the type's reference tetrahedron.
    let w_blue = f32(tt == 0u);
    let w_green = f32(tt == 1u);
    let w_red = f32(tt == 2u);
    let u = w_blue * 2.0 * vec4<f32>(x + y + z - 1.0, 0.5 - y, 0.5 - z, 0.5 - x)
        + w_green * vec4<f32>(1.0 - x - y - z, x - y + z, x + y - z, y + z - x)
        + w_red * 2.0 * vec4<f32>(0.5 - x, z, y, x - y - z);
    let u0 = u.x;
    let u1 = u.y;
    let u2 = u.z;
    let u3 = u.w;
    let u2000 = u0 * u0;
    let u3000 = u0 * u2000;
    let u0200 = u1 * u1;
    let u0300 = u1 * u0200;
    let u0020 = u2 * u2;
    let u0030 = u2 * u0020;
    let u0002 = u3 * u3;
    let u0003 = u3 * u0002;

    // Value: the three types' cubics, weighted by the type.
    let m_red = 8.0*u3000*((c0 + c1 + c3 + c4 + c6 + c8 + c13 + c15 + c20 + c22 + c24 + c27) + 4.0*(c2 + c7 + c9 + c11 + c14 + c23) + 12.0*c10)
        + 4.0*(u0300*((c2 + c3 + c9 + c12 + c22 + c25 + c34 + c35) + 4.0*(c7 + c8 + c14 + c15 + c20 + c21 + c27 + c28) + 14.0*(c10 + c11 + c23 + c24)) + u0030*((c2 + c4 + c7 + c17 + c20 + c30 + c34 + c36) + 4.0*(c9 + c11 + c13 + c15 + c22 + c24 + c26 + c28) + 14.0*(c10 + c14 + c23 + c27)))
        + u0003*((c0 + c1 + c3 + c4 + c32 + c33 + c35 + c36) + 4.0*(c2 + c6 + c8 + c13 + c15 + c19 + c21 + c26 + c28 + c34) + 23.0*(c7 + c9 + c11 + c14 + c20 + c22 + c24 + c27) + 76.0*(c10 + c23))
        + 3.0*u0002*(2.0*u0*((c0 + c1 + c3 + c4 + c19 + c21 + c26 + c28) + 3.0*(c6 + c8 + c13 + c15) + 4.0*c2 + 9.0*(c20 + c22 + c24 + c27) + 14.0*(c7 + c9 + c11 + c14) + 32.0*c23 + 44.0*c10) + u1*((c0 + c4 + c6 + c13 + c19 + c26 + c32 + c36) + 2.0*(c3 + c35) + 4.0*(c2 + c34) + 7.0*(c8 + c15 + c21 + c28) + 14.0*(c9 + c22) + 23.0*(c7 + c14 + c20 + c27) + 32.0*(c11 + c24) + 76.0*(c10 + c23)) + u2*((c1 + c3 + c6 + c8 + c19 + c21 + c33 + c35) + 2.0*(c4 + c36) + 4.0*(c2 + c34) + 7.0*(c13 + c15 + c26 + c28) + 14.0*(c7 + c20) + 23.0*(c9 + c11 + c22 + c24) + 32.0*(c14 + c27) + 76.0*(c10 + c23)))
        + 12.0*(u2000*(u1*((c0 + c4 + c6 + c13) + 2.0*(c3 + c22) + 3.0*(c8 + c15 + c20 + c27) + 4.0*(c2 + c9 + c24) + 8.0*(c7 + c14) + 12.0*(c11 + c23) + 24.0*c10) + u2*((c1 + c3 + c6 + c8) + 2.0*(c4 + c20) + 3.0*(c13 + c15 + c22 + c24) + 4.0*(c2 + c7 + c27) + 8.0*(c9 + c11) + 12.0*(c14 + c23) + 24.0*c10) + u3*((c0 + c1 + c3 + c4) + 2.0*(c6 + c8 + c13 + c15) + 3.0*(c20 + c22 + c24 + c27) + 4.0*c2 + 8.0*(c7 + c9 + c11 + c14) + 12.0*c23 + 24.0*c10)) + u0200*(2.0*u0*((c2 + c3 + c9 + c21 + c22 + c28) + 2.0*(c8 + c15 + c20 + c27) + 3.0*(c7 + c14) + 4.0*c24 + 7.0*(c11 + c23) + 10.0*c10) + u2*((c2 + c3 + c8 + c21 + c34 + c35) + 2.0*(c9 + c22) + 3.0*(c7 + c20) + 5.0*(c15 + c28) + 7.0*(c14 + c27) + 11.0*(c11 + c24) + 17.0*(c10 + c23)) + u3*((c2 + c3 + c34 + c35) + 2.0*(c9 + c22) + 3.0*(c8 + c15 + c21 + c28) + 5.0*(c7 + c14 + c20 + c27) + 11.0*(c11 + c24) + 17.0*(c10 + c23))) + u0020*(2.0*u0*((c2 + c4 + c7 + c20 + c26 + c28) + 2.0*(c13 + c15 + c22 + c24) + 3.0*(c9 + c11) + 4.0*c27 + 7.0*(c14 + c23) + 10.0*c10) + u1*((c2 + c4 + c13 + c26 + c34 + c36) + 2.0*(c7 + c20) + 3.0*(c9 + c22) + 5.0*(c15 + c28) + 7.0*(c11 + c24) + 11.0*(c14 + c27) + 17.0*(c10 + c23)) + u3*((c2 + c4 + c34 + c36) + 2.0*(c7 + c20) + 3.0*(c13 + c15 + c26 + c28) + 5.0*(c9 + c11 + c22 + c24) + 11.0*(c14 + c27) + 17.0*(c10 + c23))) + u3*(u0*u1*((c0 + c4 + c6 + c13) + 2.0*(c3 + c21 + c28) + 4.0*c2 + 5.0*(c8 + c15) + 6.0*c22 + 8.0*c9 + 9.0*(c20 + c27) + 12.0*c24 + 14.0*(c7 + c14) + 20.0*c11 + 32.0*c23 + 44.0*c10) + u0*u2*((c1 + c3 + c6 + c8) + 2.0*(c4 + c26 + c28) + 4.0*c2 + 5.0*(c13 + c15) + 6.0*c20 + 8.0*c7 + 9.0*(c22 + c24) + 12.0*c27 + 14.0*(c9 + c11) + 20.0*c14 + 32.0*c23 + 44.0*c10) + u1*u2*((c3 + c4 + c8 + c13 + c21 + c26 + c35 + c36) + 2.0*(c2 + c34) + 6.0*(c15 + c28) + 7.0*(c7 + c9 + c20 + c22) + 16.0*(c11 + c14 + c24 + c27) + 38.0*(c10 + c23))))
        + 24.0*u0*u1*u2*((c3 + c4 + c8 + c13) + 2.0*(c2 + c28) + 3.0*(c20 + c22) + 4.0*(c7 + c9 + c15) + 6.0*(c24 + c27) + 10.0*(c11 + c14) + 16.0*c23 + 22.0*c10);
    let m_green = 8.0*u3000*((c0 + c1 + c3 + c4 + c6 + c8 + c13 + c15 + c20 + c22 + c24 + c27) + 4.0*(c2 + c7 + c9 + c11 + c14 + c23) + 12.0*c10)
        + 4.0*(u0300*((c2 + c3 + c9 + c12 + c22 + c25 + c34 + c35) + 4.0*(c7 + c8 + c14 + c15 + c20 + c21 + c27 + c28) + 14.0*(c10 + c11 + c23 + c24)) + u0030*((c2 + c4 + c7 + c17 + c20 + c30 + c34 + c36) + 4.0*(c9 + c11 + c13 + c15 + c22 + c24 + c26 + c28) + 14.0*(c10 + c14 + c23 + c27)) + u0003*((c7 + c8 + c9 + c12 + c13 + c16 + c17 + c18) + 4.0*(c2 + c3 + c4 + c5 + c23 + c24 + c27 + c28) + 14.0*(c10 + c11 + c14 + c15)))
        + 12.0*(u2000*(u1*((c0 + c4 + c6 + c13) + 2.0*(c3 + c22) + 3.0*(c8 + c15 + c20 + c27) + 4.0*(c2 + c9 + c24) + 8.0*(c7 + c14) + 12.0*(c11 + c23) + 24.0*c10) + u2*((c1 + c3 + c6 + c8) + 2.0*(c4 + c20) + 3.0*(c13 + c15 + c22 + c24) + 4.0*(c2 + c7 + c27) + 8.0*(c9 + c11) + 12.0*(c14 + c23) + 24.0*c10) + u3*((c0 + c1 + c20 + c22) + 2.0*(c8 + c13) + 3.0*(c3 + c4 + c24 + c27) + 4.0*(c7 + c9 + c15) + 8.0*(c2 + c23) + 12.0*(c11 + c14) + 24.0*c10)) + u0200*(2.0*u0*((c2 + c3 + c9 + c21 + c22 + c28) + 2.0*(c8 + c15 + c20 + c27) + 3.0*(c7 + c14) + 4.0*c24 + 7.0*(c11 + c23) + 10.0*c10) + u2*((c2 + c3 + c8 + c21 + c34 + c35) + 2.0*(c9 + c22) + 3.0*(c7 + c20) + 5.0*(c15 + c28) + 7.0*(c14 + c27) + 11.0*(c11 + c24) + 17.0*(c10 + c23)) + u3*((c9 + c12 + c20 + c21 + c22 + c25) + 2.0*(c2 + c3) + 3.0*(c7 + c8) + 5.0*(c27 + c28) + 7.0*(c14 + c15) + 11.0*(c23 + c24) + 17.0*(c10 + c11))) + u0020*(2.0*u0*((c2 + c4 + c7 + c20 + c26 + c28) + 2.0*(c13 + c15 + c22 + c24) + 3.0*(c9 + c11) + 4.0*c27 + 7.0*(c14 + c23) + 10.0*c10) + u1*((c2 + c4 + c13 + c26 + c34 + c36) + 2.0*(c7 + c20) + 3.0*(c9 + c22) + 5.0*(c15 + c28) + 7.0*(c11 + c24) + 11.0*(c14 + c27) + 17.0*(c10 + c23)) + u3*((c7 + c17 + c20 + c22 + c26 + c30) + 2.0*(c2 + c4) + 3.0*(c9 + c13) + 5.0*(c24 + c28) + 7.0*(c11 + c15) + 11.0*(c23 + c27) + 17.0*(c10 + c14))) + u0002*(2.0*u0*((c5 + c7 + c8 + c9 + c13 + c28) + 2.0*(c3 + c4 + c24 + c27) + 3.0*(c2 + c23) + 4.0*c15 + 7.0*(c11 + c14) + 10.0*c10) + u1*((c4 + c5 + c9 + c12 + c13 + c16) + 2.0*(c7 + c8) + 3.0*(c2 + c3) + 5.0*(c27 + c28) + 7.0*(c23 + c24) + 11.0*(c14 + c15) + 17.0*(c10 + c11)) + u2*((c3 + c5 + c7 + c8 + c17 + c18) + 2.0*(c9 + c13) + 3.0*(c2 + c4) + 5.0*(c24 + c28) + 7.0*(c23 + c27) + 11.0*(c11 + c15) + 17.0*(c10 + c14))))
        + 24.0*(u0*(u1*u3*((c4 + c13 + c20 + c22) + 2.0*(c9 + c28) + 3.0*(c3 + c8) + 4.0*(c2 + c7 + c27) + 6.0*(c15 + c24) + 10.0*(c14 + c23) + 16.0*c11 + 22.0*c10) + u1*u2*((c3 + c4 + c8 + c13) + 2.0*(c2 + c28) + 3.0*(c20 + c22) + 4.0*(c7 + c9 + c15) + 6.0*(c24 + c27) + 10.0*(c11 + c14) + 16.0*c23 + 22.0*c10) + u2*u3*((c3 + c8 + c20 + c22) + 2.0*(c7 + c28) + 3.0*(c4 + c13) + 4.0*(c2 + c9 + c24) + 6.0*(c15 + c27) + 10.0*(c11 + c23) + 16.0*c14 + 22.0*c10)) + u1*u2*u3*((c3 + c4 + c8 + c13 + c20 + c22) + 2.0*(c2 + c7 + c9) + 6.0*c28 + 8.0*(c15 + c24 + c27) + 12.0*(c11 + c14 + c23) + 18.0*c10));
    let m_blue = 2.0*u3000*((c2 + c3 + c4 + c5 + c7 + c8 + c9 + c12 + c13 + c16 + c17 + c18 + c20 + c21 + c22 + c25 + c26 + c29 + c30 + c31 + c34 + c35 + c36 + c37) + 21.0*(c10 + c11 + c14 + c15 + c23 + c24 + c27 + c28))
        + 4.0*(u0300*((c2 + c3 + c9 + c12 + c22 + c25 + c34 + c35) + 4.0*(c7 + c8 + c14 + c15 + c20 + c21 + c27 + c28) + 14.0*(c10 + c11 + c23 + c24)) + u0030*((c2 + c4 + c7 + c17 + c20 + c30 + c34 + c36) + 4.0*(c9 + c11 + c13 + c15 + c22 + c24 + c26 + c28) + 14.0*(c10 + c14 + c23 + c27)) + u0003*((c7 + c8 + c9 + c12 + c13 + c16 + c17 + c18) + 4.0*(c2 + c3 + c4 + c5 + c23 + c24 + c27 + c28) + 14.0*(c10 + c11 + c14 + c15)))
        + 3.0*u2000*(u1*((c4 + c5 + c13 + c16 + c26 + c29 + c36 + c37) + 3.0*(c2 + c3 + c9 + c12 + c22 + c25 + c34 + c35) + 4.0*(c7 + c8 + c20 + c21) + 34.0*(c14 + c15 + c27 + c28) + 50.0*(c10 + c11 + c23 + c24)) + u2*((c3 + c5 + c8 + c18 + c21 + c31 + c35 + c37) + 3.0*(c2 + c4 + c7 + c17 + c20 + c30 + c34 + c36) + 4.0*(c9 + c13 + c22 + c26) + 34.0*(c11 + c15 + c24 + c28) + 50.0*(c10 + c14 + c23 + c27)) + u3*((c20 + c21 + c22 + c25 + c26 + c29 + c30 + c31) + 3.0*(c7 + c8 + c9 + c12 + c13 + c16 + c17 + c18) + 4.0*(c2 + c3 + c4 + c5) + 34.0*(c23 + c24 + c27 + c28) + 50.0*(c10 + c11 + c14 + c15)))
        + 12.0*(u0200*(u0*((c2 + c3 + c9 + c12 + c22 + c25 + c34 + c35) + 2.0*(c7 + c8 + c20 + c21) + 6.0*(c14 + c15 + c27 + c28) + 14.0*(c10 + c11 + c23 + c24)) + u2*((c2 + c3 + c8 + c21 + c34 + c35) + 2.0*(c9 + c22) + 3.0*(c7 + c20) + 5.0*(c15 + c28) + 7.0*(c14 + c27) + 11.0*(c11 + c24) + 17.0*(c10 + c23)) + u3*((c9 + c12 + c20 + c21 + c22 + c25) + 2.0*(c2 + c3) + 3.0*(c7 + c8) + 5.0*(c27 + c28) + 7.0*(c14 + c15) + 11.0*(c23 + c24) + 17.0*(c10 + c11))) + u0020*(u0*((c2 + c4 + c7 + c17 + c20 + c30 + c34 + c36) + 2.0*(c9 + c13 + c22 + c26) + 6.0*(c11 + c15 + c24 + c28) + 14.0*(c10 + c14 + c23 + c27)) + u1*((c2 + c4 + c13 + c26 + c34 + c36) + 2.0*(c7 + c20) + 3.0*(c9 + c22) + 5.0*(c15 + c28) + 7.0*(c11 + c24) + 11.0*(c14 + c27) + 17.0*(c10 + c23)) + u3*((c7 + c17 + c20 + c22 + c26 + c30) + 2.0*(c2 + c4) + 3.0*(c9 + c13) + 5.0*(c24 + c28) + 7.0*(c11 + c15) + 11.0*(c23 + c27) + 17.0*(c10 + c14))) + u0002*(u0*((c7 + c8 + c9 + c12 + c13 + c16 + c17 + c18) + 2.0*(c2 + c3 + c4 + c5) + 6.0*(c23 + c24 + c27 + c28) + 14.0*(c10 + c11 + c14 + c15)) + u1*((c4 + c5 + c9 + c12 + c13 + c16) + 2.0*(c7 + c8) + 3.0*(c2 + c3) + 5.0*(c27 + c28) + 7.0*(c23 + c24) + 11.0*(c14 + c15) + 17.0*(c10 + c11)) + u2*((c3 + c5 + c7 + c8 + c17 + c18) + 2.0*(c9 + c13) + 3.0*(c2 + c4) + 5.0*(c24 + c28) + 7.0*(c23 + c27) + 11.0*(c11 + c15) + 17.0*(c10 + c14))) + u0*(u1*u2*((c3 + c4 + c8 + c13 + c21 + c26 + c35 + c36) + 2.0*(c2 + c34) + 3.0*(c7 + c9 + c20 + c22) + 14.0*(c15 + c28) + 20.0*(c11 + c14 + c24 + c27) + 30.0*(c10 + c23)) + u1*u3*((c4 + c5 + c13 + c16 + c20 + c21 + c22 + c25) + 2.0*(c9 + c12) + 3.0*(c2 + c3 + c7 + c8) + 14.0*(c27 + c28) + 20.0*(c14 + c15 + c23 + c24) + 30.0*(c10 + c11)) + u2*u3*((c3 + c5 + c8 + c18 + c20 + c22 + c26 + c30) + 2.0*(c7 + c17) + 3.0*(c2 + c4 + c9 + c13) + 14.0*(c24 + c28) + 20.0*(c11 + c15 + c23 + c27) + 30.0*(c10 + c14))))
        + 24.0*u1*u2*u3*((c3 + c4 + c8 + c13 + c20 + c22) + 2.0*(c2 + c7 + c9) + 6.0*c28 + 8.0*(c15 + c24 + c27) + 12.0*(c11 + c14 + c23) + 18.0*c10);
    let value = (w_red * m_red + w_green * m_green + w_blue * m_blue) * (1.0 / 384.0);

    // Gradient: the three types' quadratics, weighted by the type.
    let gx_red = u0002*((-c1 - c3 - c4 - c0 + c32 + c33 + c35 + c36) + 2.0*(c19 - c6 - c8 - c13 - c15 + c21 + c26 + c28) + 4.0*(-c2 + c34) + 5.0*(-c7 - c9 - c11 - c14 + c20 + c22 + c24 + c27) + 12.0*(-c10 + c23))
        + 4.0*(u2000*((c20 - c1 - c3 - c4 - c0 + c22 + c24 + c27) + 4.0*(-c2 + c23)) + u0200*((c20 - c3 - c7 - c8 - c14 - c15 - c2 + c21 + c27 + c28 + c34 + c35) + 3.0*(-c10 - c11 + c23 + c24)) + u0020*((c22 - c4 - c9 - c11 - c13 - c15 - c2 + c24 + c26 + c28 + c34 + c36) + 3.0*(-c10 - c14 + c23 + c27)) + u0*(u1*((-c4 - c6 - c8 - c13 - c15 - c0) + 2.0*(-c3 - c7 - c14 + c21 + c22 + c28) + 3.0*(c20 + c27) + 4.0*(-c2 - c10 - c11 + c24) + 8.0*c23) + u2*((-c3 - c6 - c8 - c13 - c15 - c1) + 2.0*(c20 - c4 - c9 - c11 + c26 + c28) + 3.0*(c22 + c24) + 4.0*(-c2 - c10 - c14 + c27) + 8.0*c23) + u3*((c19 - c1 - c3 - c4 - c6 - c8 - c13 - c15 - c0 + c21 + c26 + c28) + 2.0*(-c7 - c9 - c11 - c14) + 3.0*(c20 + c22 + c24 + c27) + 4.0*(-c2 - c10) + 8.0*c23)) + u1*u2*((c20 - c3 - c4 - c7 - c8 - c9 - c13 + c21 + c22 + c26 + c35 + c36) + 2.0*(-c15 - c2 + c28 + c34) + 4.0*(-c11 - c14 + c24 + c27) + 6.0*(-c10 + c23)))
        + 2.0*u3*(u1*((c19 - c4 - c6 - c13 - c0 + c26 + c32 + c36) + 2.0*(-c3 - c9 + c22 + c35) + 3.0*(-c8 - c15 + c21 + c28) + 4.0*(-c2 + c34) + 5.0*(-c7 - c14 + c20 + c27) + 8.0*(-c11 + c24) + 12.0*(-c10 + c23)) + u2*((c19 - c3 - c6 - c8 - c1 + c21 + c33 + c35) + 2.0*(-c4 - c7 + c20 + c36) + 3.0*(-c13 - c15 + c26 + c28) + 4.0*(-c2 + c34) + 5.0*(-c9 - c11 + c22 + c24) + 8.0*(-c14 + c27) + 12.0*(-c10 + c23)));
    let gy_red = u0002*((c4 - c0 - c32 + c36) + 3.0*(-c6 - c8 + c13 + c15 - c19 - c21 + c26 + c28) + 9.0*(-c7 + c14 - c20 + c27))
        + 4.0*(u2000*((c4 - c0 - c6 - c8 + c13 + c15 - c20 + c27) + 4.0*(-c7 + c14)) + 2.0*u0200*(c14 - c8 - c7 + c15 - c20 - c21 + c27 + c28) + u0020*((c13 - c9 - c11 - c7 + c15 + c17 - c20 - c22 - c24 + c26 + c28 + c30) + 3.0*(-c10 + c14 - c23 + c27)) + u0*(u1*((c4 - c0 - c6 + c13) + 2.0*(-c21 + c28) + 3.0*(-c8 + c15 - c20 + c27) + 6.0*(-c7 + c14)) + u2*((-c3 - c1 - c6 - c8 - c22 - c24) + 2.0*(c4 - c9 - c11 - c20 + c26 + c28) + 3.0*(c13 + c15) + 4.0*(-c7 - c10 - c23 + c27) + 8.0*c14) + u3*((c4 - c0 - c19 - c21 + c26 + c28) + 2.0*(-c6 - c8 + c13 + c15) + 3.0*(-c20 + c27) + 6.0*(-c7 + c14))) + u1*u2*((c4 - c3 - c8 - c9 + c13 - c21 - c22 + c26 - c35 + c36) + 2.0*(-c11 - c24) + 3.0*(-c7 - c20) + 4.0*(-c10 + c15 - c23 + c28) + 6.0*(c14 + c27)))
        + 2.0*u3*(u1*((c4 - c0 - c6 + c13 - c19 + c26 - c32 + c36) + 5.0*(-c8 + c15 - c21 + c28) + 9.0*(-c7 + c14 - c20 + c27)) + u2*((-c3 - c1 - c6 - c8 - c19 - c21 - c33 - c35) + 2.0*(c4 + c36) + 3.0*(-c9 - c11 - c22 - c24) + 5.0*(c13 + c15 + c26 + c28) + 6.0*(-c7 - c20) + 8.0*(-c10 - c23) + 12.0*(c14 + c27)));
    let gz_red = u0002*((c3 - c1 - c33 + c35) + 3.0*(-c6 + c8 - c13 + c15 - c19 + c21 - c26 + c28) + 9.0*(-c9 + c11 - c22 + c24))
        + 4.0*(u2000*((c3 - c1 - c6 + c8 - c13 + c15 - c22 + c24) + 4.0*(-c9 + c11)) + u0200*((c8 - c7 - c9 + c12 - c14 + c15 - c20 + c21 - c22 + c25 - c27 + c28) + 3.0*(-c10 + c11 - c23 + c24)) + 2.0*u0020*((c11 - c9 - c13 + c15 - c22 + c24 - c26 + c28)) + u0*(u1*((-c0 - c4 - c6 - c13 - c20 - c27) + 2.0*(c3 - c7 - c14 + c21 - c22 + c28) + 3.0*(c8 + c15) + 4.0*(-c9 - c10 - c23 + c24) + 8.0*c11) + u2*((c3 - c1 - c6 + c8) + 2.0*(-c26 + c28) + 3.0*(-c13 + c15 - c22 + c24) + 6.0*(-c9 + c11)) + u3*((c3 - c1 - c19 + c21 - c26 + c28) + 2.0*(-c6 + c8 - c13 + c15) + 3.0*(-c22 + c24) + 6.0*(-c9 + c11))) + u1*u2*((c3 - c4 - c7 + c8 - c13 - c20 + c21 - c26 + c35 - c36) + 2.0*(-c14 - c27) + 3.0*(-c9 - c22) + 4.0*(-c10 + c15 - c23 + c28) + 6.0*(c11 + c24)))
        + 2.0*u3*(u1*((-c0 - c4 - c6 - c13 - c19 - c26 - c32 - c36) + 2.0*(c3 + c35) + 3.0*(-c7 - c14 - c20 - c27) + 5.0*(c8 + c15 + c21 + c28) + 6.0*(-c9 - c22) + 8.0*(-c10 - c23) + 12.0*(c11 + c24)) + u2*((c3 - c1 - c6 + c8 - c19 + c21 - c33 + c35) + 5.0*(-c13 + c15 - c26 + c28) + 9.0*(-c9 + c11 - c22 + c24)));
    let gx_green = 4.0*(u2000*((c20 - c1 - c3 - c4 - c0 + c22 + c24 + c27) + 4.0*(-c2 + c23)) + u0200*((c20 - c3 - c7 - c8 - c14 - c15 - c2 + c21 + c27 + c28 + c34 + c35) + 3.0*(-c10 - c11 + c23 + c24)) + u0020*((c22 - c4 - c9 - c11 - c13 - c15 - c2 + c24 + c26 + c28 + c34 + c36) + 3.0*(-c10 - c14 + c23 + c27)) + 2.0*u0002*((c23 - c3 - c4 - c5 - c2 + c24 + c27 + c28)) + u0*(u1*((-c4 - c6 - c8 - c13 - c15 - c0) + 2.0*(-c3 - c7 - c14 + c21 + c22 + c28) + 3.0*(c20 + c27) + 4.0*(-c2 - c10 - c11 + c24) + 8.0*c23) + u2*((-c3 - c6 - c8 - c13 - c15 - c1) + 2.0*(c20 - c4 - c9 - c11 + c26 + c28) + 3.0*(c22 + c24) + 4.0*(-c2 - c10 - c14 + c27) + 8.0*c23) + u3*((c20 - c1 - c0 + c22) + 2.0*(-c5 + c28) + 3.0*(-c3 - c4 + c24 + c27) + 6.0*(-c2 + c23))) + u1*(u2*((c20 - c3 - c4 - c7 - c8 - c9 - c13 + c21 + c22 + c26 + c35 + c36) + 2.0*(-c15 - c2 + c28 + c34) + 4.0*(-c11 - c14 + c24 + c27) + 6.0*(-c10 + c23)) + u3*((c20 - c4 - c5 - c7 - c8 - c13 - c16 + c21 + c22 + c25) + 2.0*(-c14 - c15) + 3.0*(-c3 - c2) + 4.0*(-c10 - c11 + c27 + c28) + 6.0*(c23 + c24))) + u2*u3*((c20 - c3 - c5 - c8 - c9 - c13 - c18 + c22 + c26 + c30) + 2.0*(-c11 - c15) + 3.0*(-c4 - c2) + 4.0*(-c10 - c14 + c24 + c28) + 6.0*(c23 + c27)));
    let gy_green = 4.0*(u2000*((c4 - c0 - c6 - c8 + c13 + c15 - c20 + c27) + 4.0*(-c7 + c14)) + 2.0*u0200*((c14 - c8 - c7 + c15 - c20 - c21 + c27 + c28)) + u0020*((c13 - c9 - c11 - c7 + c15 + c17 - c20 - c22 - c24 + c26 + c28 + c30) + 3.0*(-c10 + c14 - c23 + c27)) + u0002*((c4 - c3 - c2 + c5 - c7 - c8 + c17 + c18 - c23 - c24 + c27 + c28) + 3.0*(-c10 - c11 + c14 + c15)) + u0*(u1*((c4 - c0 - c6 + c13) + 2.0*(-c21 + c28) + 3.0*(-c8 + c15 - c20 + c27) + 6.0*(-c7 + c14)) + u2*((-c3 - c1 - c6 - c8 - c22 - c24) + 2.0*(c4 - c9 - c11 - c20 + c26 + c28) + 3.0*(c13 + c15) + 4.0*(-c7 - c10 - c23 + c27) + 8.0*c14) + u3*((-c1 - c3 - c0 - c20 - c22 - c24) + 2.0*(-c2 + c5 - c8 + c13 - c23 + c28) + 3.0*(c4 + c27) + 4.0*(-c7 - c10 - c11 + c15) + 8.0*c14)) + u1*(u2*((c4 - c3 - c8 - c9 + c13 - c21 - c22 + c26 - c35 + c36) + 2.0*(-c11 - c24) + 3.0*(-c7 - c20) + 4.0*(-c10 + c15 - c23 + c28) + 6.0*(c14 + c27)) + u3*((c4 - c3 - c2 + c5 + c13 + c16 - c20 - c21 - c22 - c25) + 2.0*(-c23 - c24) + 3.0*(-c7 - c8) + 4.0*(-c10 - c11 + c27 + c28) + 6.0*(c14 + c15))) + u2*u3*((c4 - c3 - c2 + c5 - c8 - c9 + c13 + c18 - c20 - c22 + c26 + c30) + 2.0*(-c7 + c17 - c24 + c28) + 4.0*(-c11 + c15 - c23 + c27) + 6.0*(-c10 + c14)));
    let gz_green = 4.0*(u2000*((c3 - c1 - c6 + c8 - c13 + c15 - c22 + c24) + 4.0*(-c9 + c11)) + u0200*((c8 - c7 - c9 + c12 - c14 + c15 - c20 + c21 - c22 + c25 - c27 + c28) + 3.0*(-c10 + c11 - c23 + c24)) + u0002*((c3 - c2 - c4 + c5 - c9 + c12 - c13 + c16 - c23 + c24 - c27 + c28) + 3.0*(-c10 + c11 - c14 + c15)) + 2.0*u0020*((c11 - c9 - c13 + c15 - c22 + c24 - c26 + c28)) + u0*(u1*((-c0 - c4 - c6 - c13 - c20 - c27) + 2.0*(c3 - c7 - c14 + c21 - c22 + c28) + 3.0*(c8 + c15) + 4.0*(-c9 - c10 - c23 + c24) + 8.0*c11) + u2*((c3 - c1 - c6 + c8) + 2.0*(-c26 + c28) + 3.0*(-c13 + c15 - c22 + c24) + 6.0*(-c9 + c11)) + u3*((-c1 - c0 - c4 - c20 - c22 - c27) + 2.0*(-c2 + c5 + c8 - c13 - c23 + c28) + 3.0*(c3 + c24) + 4.0*(-c9 - c10 - c14 + c15) + 8.0*c11)) + u1*(u2*((c3 - c4 - c7 + c8 - c13 - c20 + c21 - c26 + c35 - c36) + 2.0*(-c14 - c27) + 3.0*(-c9 - c22) + 4.0*(-c10 + c15 - c23 + c28) + 6.0*(c11 + c24)) + u3*((c3 - c2 - c4 + c5 - c7 + c8 - c13 + c16 - c20 + c21 - c22 + c25) + 2.0*(-c9 + c12 - c27 + c28) + 4.0*(-c14 + c15 - c23 + c24) + 6.0*(-c10 + c11))) + u2*u3*((c3 - c2 - c4 + c5 + c8 + c18 - c20 - c22 - c26 - c30) + 2.0*(-c23 - c27) + 3.0*(-c9 - c13) + 4.0*(-c10 - c14 + c24 + c28) + 6.0*(c11 + c15)));
    let gx_blue = u2000*((c20 - c7 - c8 - c9 - c12 - c13 - c16 - c17 - c18 + c21 + c22 + c25 + c26 + c29 + c30 + c31) + 2.0*(-c3 - c4 - c5 - c2 + c34 + c35 + c36 + c37) + 8.0*(-c10 - c11 - c14 - c15 + c23 + c24 + c27 + c28))
        + 8.0*u0002*((c23 - c3 - c4 - c5 - c2 + c24 + c27 + c28))
        + 4.0*(u0200*((c20 - c3 - c7 - c8 - c14 - c15 - c2 + c21 + c27 + c28 + c34 + c35) + 3.0*(-c10 - c11 + c23 + c24)) + u0020*((c22 - c4 - c9 - c11 - c13 - c15 - c2 + c24 + c26 + c28 + c34 + c36) + 3.0*(-c10 - c14 + c23 + c27)) + u1*(u2*((c20 - c3 - c4 - c7 - c8 - c9 - c13 + c21 + c22 + c26 + c35 + c36) + 2.0*(-c15 - c2 + c28 + c34) + 4.0*(-c11 - c14 + c24 + c27) + 6.0*(-c10 + c23)) + u3*((c20 - c4 - c5 - c7 - c8 - c13 - c16 + c21 + c22 + c25) + 2.0*(-c14 - c15) + 3.0*(-c3 - c2) + 4.0*(-c10 - c11 + c27 + c28) + 6.0*(c23 + c24))) + u2*u3*((c20 - c3 - c5 - c8 - c9 - c13 - c18 + c22 + c26 + c30) + 2.0*(-c11 - c15) + 3.0*(-c4 - c2) + 4.0*(-c10 - c14 + c24 + c28) + 6.0*(c23 + c27)))
        + 2.0*u0*(u1*((-c4 - c5 - c9 - c12 - c13 - c16 + c22 + c25 + c26 + c29 + c36 + c37) + 2.0*(c20 - c7 - c8 + c21) + 3.0*(-c3 - c2 + c34 + c35) + 6.0*(-c14 - c15 + c27 + c28) + 10.0*(-c10 - c11 + c23 + c24)) + u2*((c20 - c3 - c5 - c7 - c8 - c17 - c18 + c21 + c30 + c31 + c35 + c37) + 2.0*(-c9 - c13 + c22 + c26) + 3.0*(-c4 - c2 + c34 + c36) + 6.0*(-c11 - c15 + c24 + c28) + 10.0*(-c10 - c14 + c23 + c27)) + u3*((c20 - c7 - c8 - c9 - c12 - c13 - c16 - c17 - c18 + c21 + c22 + c25 + c26 + c29 + c30 + c31) + 4.0*(-c3 - c4 - c5 - c2) + 6.0*(-c10 - c11 - c14 - c15) + 10.0*(c23 + c24 + c27 + c28)));
    let gy_blue = u2000*((c4 - c3 - c2 + c5 - c9 - c12 + c13 + c16 - c22 - c25 + c26 + c29 - c34 - c35 + c36 + c37) + 2.0*(-c7 - c8 + c17 + c18 - c20 - c21 + c30 + c31) + 8.0*(-c10 - c11 + c14 + c15 - c23 - c24 + c27 + c28))
        + 8.0*u0200*((c14 - c8 - c7 + c15 - c20 - c21 + c27 + c28))
        + 4.0*(u0020*((c13 - c9 - c11 - c7 + c15 + c17 - c20 - c22 - c24 + c26 + c28 + c30) + 3.0*(-c10 + c14 - c23 + c27)) + u0002*((c4 - c3 - c2 + c5 - c7 - c8 + c17 + c18 - c23 - c24 + c27 + c28) + 3.0*(-c10 - c11 + c14 + c15)) + u1*(u2*((c4 - c3 - c8 - c9 + c13 - c21 - c22 + c26 - c35 + c36) + 2.0*(-c11 - c24) + 3.0*(-c7 - c20) + 4.0*(-c10 + c15 - c23 + c28) + 6.0*(c14 + c27)) + u3*((c4 - c3 - c2 + c5 + c13 + c16 - c20 - c21 - c22 - c25) + 2.0*(-c23 - c24) + 3.0*(-c7 - c8) + 4.0*(-c10 - c11 + c27 + c28) + 6.0*(c14 + c15))) + u2*u3*((c4 - c3 - c2 + c5 - c8 - c9 + c13 + c18 - c20 - c22 + c26 + c30) + 2.0*(-c7 + c17 - c24 + c28) + 4.0*(-c11 + c15 - c23 + c27) + 6.0*(-c10 + c14)))
        + 2.0*u0*(u1*((c4 - c3 - c2 + c5 - c9 - c12 + c13 + c16 - c22 - c25 + c26 + c29 - c34 - c35 + c36 + c37) + 4.0*(-c7 - c8 - c20 - c21) + 6.0*(-c10 - c11 - c23 - c24) + 10.0*(c14 + c15 + c27 + c28)) + u2*((c4 - c3 - c2 + c5 - c8 + c18 - c21 + c31 - c34 - c35 + c36 + c37) + 2.0*(-c9 + c13 - c22 + c26) + 3.0*(-c7 + c17 - c20 + c30) + 6.0*(-c11 + c15 - c24 + c28) + 10.0*(-c10 + c14 - c23 + c27)) + u3*((-c9 - c12 + c13 + c16 - c20 - c21 - c22 - c25 + c26 + c29 + c30 + c31) + 2.0*(c4 - c3 - c2 + c5) + 3.0*(-c7 - c8 + c17 + c18) + 6.0*(-c23 - c24 + c27 + c28) + 10.0*(-c10 - c11 + c14 + c15)));
    let gz_blue = u2000*((c3 - c2 - c4 + c5 - c7 + c8 - c17 + c18 - c20 + c21 - c30 + c31 - c34 + c35 - c36 + c37) + 2.0*(-c9 + c12 - c13 + c16 - c22 + c25 - c26 + c29) + 8.0*(-c10 + c11 - c14 + c15 - c23 + c24 - c27 + c28))
        + 8.0*u0020*((c11 - c9 - c13 + c15 - c22 + c24 - c26 + c28))
        + 4.0*(u0200*((c8 - c7 - c9 + c12 - c14 + c15 - c20 + c21 - c22 + c25 - c27 + c28) + 3.0*(-c10 + c11 - c23 + c24)) + u0002*((c3 - c2 - c4 + c5 - c9 + c12 - c13 + c16 - c23 + c24 - c27 + c28) + 3.0*(-c10 + c11 - c14 + c15)) + u1*(u2*((c3 - c4 - c7 + c8 - c13 - c20 + c21 - c26 + c35 - c36) + 2.0*(-c14 - c27) + 3.0*(-c9 - c22) + 4.0*(-c10 + c15 - c23 + c28) + 6.0*(c11 + c24)) + u3*((c3 - c2 - c4 + c5 - c7 + c8 - c13 + c16 - c20 + c21 - c22 + c25) + 2.0*(-c9 + c12 - c27 + c28) + 4.0*(-c14 + c15 - c23 + c24) + 6.0*(-c10 + c11))) + u3*(((c3 - c2 - c4 + c5 + c8 + c18 - c20 - c22 - c26 - c30) + 2.0*(-c23 - c27) + 3.0*(-c9 - c13) + 4.0*(-c10 - c14 + c24 + c28) + 6.0*(c11 + c15))*u2))
        + 2.0*(u0*(u1*((c3 - c2 - c4 + c5 - c13 + c16 - c26 + c29 - c34 + c35 - c36 + c37) + 2.0*(-c7 + c8 - c20 + c21) + 3.0*(-c9 + c12 - c22 + c25) + 6.0*(-c14 + c15 - c27 + c28) + 10.0*(-c10 + c11 - c23 + c24)) + u2*((c3 - c2 - c4 + c5 - c7 + c8 - c17 + c18 - c20 + c21 - c30 + c31 - c34 + c35 - c36 + c37) + 4.0*(-c9 - c13 - c22 - c26) + 6.0*(-c10 - c14 - c23 - c27) + 10.0*(c11 + c15 + c24 + c28)) + u3*((-c7 + c8 - c17 + c18 - c20 + c21 - c22 + c25 - c26 + c29 - c30 + c31) + 2.0*(c3 - c2 - c4 + c5) + 3.0*(-c9 + c12 - c13 + c16) + 6.0*(-c23 + c24 - c27 + c28) + 10.0*(-c10 + c11 - c14 + c15))));
    let g_ref = (w_red * vec3<f32>(gx_red, gy_red, gz_red)
        + w_green * vec3<f32>(gx_green, gy_green, gz_green)
        + w_blue * vec3<f32>(gx_blue, gy_blue, gz_blue)) * (1.0 / 64.0);

    // Hessian: the type's linear forms, diagonal and (yz, zx, xy).
    var hd = vec3<f32>(0.0);
    var ho = vec3<f32>(0.0);
    switch tt {
        case 2u: {
            let h0x = 2.0*u0*((c0 + c1 + c3 + c4 - c6 - c8 - c13 - c15 + c19 + c20 + c21 + c22 + c24 + c26 + c27 + c28) + 2.0*(-c7 - c9 - c11 - c14) + 4.0*(c2 - c10))
                + u1*((c0 + c4 + c6 - c7 - c8 + c13 - c14 - c15 + c19 - c20 - c21 + c26 - c27 - c28 + c32 + c36) + 2.0*(c3 - c9 - c22 + c35) + 4.0*(c2 - c10 - c23 + c34))
                + u2*((c1 + c3 + c6 + c8 - c9 - c11 - c13 - c15 + c19 + c21 - c22 - c24 - c26 - c28 + c33 + c35) + 2.0*(c4 - c7 - c20 + c36) + 4.0*(c2 - c10 - c23 + c34))
                + u3*((c0 + c1 + c3 + c4 - c7 - c9 - c11 - c14 - c20 - c22 - c24 - c27 + c32 + c33 + c35 + c36) + 4.0*(c2 - c10 - c23 + c34));
            let h0y = 2.0*u0*((c0 - c1 - c3 + c4 + c6 + c8 + c13 + c15 + c19 + c20 + c21 - c22 - c24 + c26 + c27 + c28) + 2.0*(c7 - c9 - c11 + c14) + 4.0*(-c10 - c23))
                + u1*((c0 + c4 + c6 + c13 + c19 + c26 + c32 + c36) + 2.0*(-c3 - c9 - c22 - c35) + 3.0*(c7 + c8 + c14 + c15 + c20 + c21 + c27 + c28) + 4.0*(-c11 - c24) + 8.0*(-c10 - c23))
                + u2*((c1 + c3 + c6 + c8 - c9 - c11 - c13 - c15 + c19 + c21 - c22 - c24 - c26 - c28 + c33 + c35) + 2.0*(-c4 + c7 + c20 - c36) + 4.0*(-c10 + c17 - c23 + c30))
                + u3*((c0 - c1 - c3 + c4 + c32 - c33 - c35 + c36) + 2.0*(c6 + c8 + c13 + c15 + c19 + c21 + c26 + c28) + 3.0*(c7 - c9 - c11 + c14 + c20 - c22 - c24 + c27) + 8.0*(-c10 - c23));
            let h0z = 2.0*u0*((c1 - c0 + c3 - c4 + c6 + c8 + c13 + c15 + c19 - c20 + c21 + c22 + c24 + c26 - c27 + c28) + 2.0*(-c7 + c9 + c11 - c14) + 4.0*(-c10 - c23))
                + u1*((c0 + c4 + c6 - c7 - c8 + c13 - c14 - c15 + c19 - c20 - c21 + c26 - c27 - c28 + c32 + c36) + 2.0*(-c3 + c9 + c22 - c35) + 4.0*(-c10 + c12 - c23 + c25))
                + u2*((c1 + c3 + c6 + c8 + c19 + c21 + c33 + c35) + 2.0*(-c4 - c7 - c20 - c36) + 3.0*(c9 + c11 + c13 + c15 + c22 + c24 + c26 + c28) + 4.0*(-c14 - c27) + 8.0*(-c10 - c23))
                + u3*((c1 - c0 + c3 - c4 - c32 + c33 + c35 - c36) + 2.0*(c6 + c8 + c13 + c15 + c19 + c21 + c26 + c28) + 3.0*(-c7 + c9 + c11 - c14 - c20 + c22 + c24 - c27) + 8.0*(-c10 - c23));
            let h1x = 2.0*(u0*(c6 - c8 - c13 + c15 + c19 - c21 - c26 + c28) + u3*(c6 - c8 - c13 + c15 + c19 - c21 - c26 + c28))
                + u1*((c0 - c4 + c6 + c7 - c13 - c14 + c19 + c20 - c26 - c27 + c32 - c36) + 3.0*(-c8 + c15 - c21 + c28))
                + u2*((c1 - c3 + c6 - c8 + c9 - c11 + c19 - c21 + c22 - c24 + c33 - c35) + 3.0*(-c13 + c15 - c26 + c28));
            let h1y = 2.0*u0*((c1 - c3 - c19 + c21 - c22 + c24 - c26 + c28) + 2.0*(c9 - c11))
                + u1*((c0 + c4 + c6 + c7 - c8 + c13 + c14 - c15 - c19 - c20 + c21 - c26 - c27 + c28 - c32 - c36) + 2.0*(-c3 + c9 - c22 + c35) + 4.0*(-c11 + c24))
                + u2*((c1 - c3 + c6 - c8 + c13 - c15 - c19 + c21 - c26 + c28 - c33 + c35) + 3.0*(c9 - c11 - c22 + c24))
                + u3*((c1 - c3 + c6 - c8 + c13 - c15 - c19 + c21 - c26 + c28 - c33 + c35) + 3.0*(c9 - c11 - c22 + c24));
            let h1z = 2.0*u0*((c0 - c4 - c19 - c20 - c21 + c26 + c27 + c28) + 2.0*(c7 - c14))
                + u1*((c0 - c4 + c6 + c8 - c13 - c15 - c19 - c21 + c26 + c28 - c32 + c36) + 3.0*(c7 - c14 - c20 + c27))
                + u2*((c1 + c3 + c6 + c8 + c9 + c11 - c13 - c15 - c19 - c21 - c22 - c24 + c26 + c28 - c33 - c35) + 2.0*(-c4 + c7 - c20 + c36) + 4.0*(-c14 + c27))
                + u3*((c0 - c4 + c6 + c8 - c13 - c15 - c19 - c21 + c26 + c28 - c32 + c36) + 3.0*(c7 - c14 - c20 + c27));
            hd = vec3<f32>(h0x, h0y, h0z);
            ho = vec3<f32>(h1x, h1y, h1z);
        }
        case 1u: {
            let h0x = 2.0*u0*((c0 + c1 + c3 + c4 + c5 - c6 - c7 - c8 - c9 - c13 - c15 + c20 + c21 + c22 + c23 + c24 + c26 + c27 + c28) + 3.0*(c2 - c11 - c14) + 4.0*(-c10))
                + u1*((c0 + c4 + c5 + c6 - c8 - c9 + c13 - c15 + c16 - c20 - c25 + c26 - c27 + c36) + 2.0*(c3 - c11 - c14 - c22 - c23 - c28) + 3.0*(c2 + c35) + 4.0*(-c10 + c34))
                + u2*((c1 + c3 + c5 + c6 - c7 + c8 - c13 - c15 + c18 + c21 - c22 - c24 - c30 + c35) + 2.0*(c4 - c11 - c14 - c20 - c23 - c28) + 3.0*(c2 + c36) + 4.0*(-c10 + c34))
                + u3*((c0 + c1 - c7 - c9 - c16 - c18 + c20 + c21 + c22 + c25 + c26 + c30) + 2.0*(-c8 - c13 + c23 + c28) + 3.0*(c3 + c4 + c24 + c27) + 4.0*(c2 + c5 - c15) + 6.0*(-c11 - c14) + 8.0*(-c10));
            let h0y = 2.0*u0*((c0 - c1 - c2 - c3 + c4 + c5 + c6 + c8 - c9 + c13 + c14 + c15 + c20 + c21 - c22 - c24 + c26 + c27 + c28) + 3.0*(c7 - c11 - c23) + 4.0*(-c10))
                + u1*((c0 - c2 + c4 + c5 + c6 - c9 + c13 + c16 - c25 + c26 - c35 + c36) + 2.0*(-c3 + c14 - c22 + c28) + 3.0*(c8 + c15 + c20 + c27) + 4.0*(c7 + c21 - c24) + 6.0*(-c11 - c23) + 8.0*(-c10))
                + u2*((c1 - c2 + c3 + c5 + c6 + c8 - c13 - c15 + c18 + c21 - c22 - c24 + c35 - c36) + 2.0*(-c4 - c11 - c14 + c20 - c23 - c28) + 3.0*(c7 + c30) + 4.0*(-c10 + c17))
                + u3*((c0 + c1 - c3 - c4 - c9 - c16 + c20 + c21 + c22 - c24 + c25 + c26 - c27 + c30) + 2.0*(c8 - c11 - c13 - c14 - c23 - c28) + 3.0*(c7 + c18) + 4.0*(-c10 + c17));
            let h0z = 2.0*u0*((c1 - c0 - c2 + c3 - c4 + c5 + c6 - c7 + c8 + c11 + c13 + c15 - c20 + c21 + c22 + c24 + c26 - c27 + c28) + 3.0*(c9 - c14 - c23) + 4.0*(-c10))
                + u1*((c0 - c2 + c4 + c5 + c6 - c8 + c13 - c15 + c16 - c20 + c26 - c27 - c35 + c36) + 2.0*(-c3 - c11 - c14 + c22 - c23 - c28) + 3.0*(c9 + c25) + 4.0*(-c10 + c12))
                + u2*((c1 - c2 + c3 + c5 + c6 - c7 + c8 + c18 + c21 - c30 + c35 - c36) + 2.0*(-c4 + c11 - c20 + c28) + 3.0*(c13 + c15 + c22 + c24) + 4.0*(c9 + c26 - c27) + 6.0*(-c14 - c23) + 8.0*(-c10))
                + u3*((c0 + c1 - c3 - c4 - c7 - c18 + c20 + c21 + c22 - c24 + c25 + c26 - c27 + c30) + 2.0*(-c8 - c11 + c13 - c14 - c23 - c28) + 3.0*(c9 + c16) + 4.0*(-c10 + c12));
            let h1x = 2.0*u0*((c5 - c2 + c6 + c7 - c8 + c9 - c11 - c13 - c14 + c15 - c21 + c23 - c26 + c28))
                + u1*((c0 - c2 - c4 + c5 + c6 + c9 - c13 + c16 + c20 - c25 - c26 - c27 + c35 - c36) + 2.0*(c7 - c11 - c14 - c21 + c23 + c28) + 3.0*(-c8 + c15))
                + u2*((c1 - c2 - c3 + c5 + c6 + c7 - c8 + c18 - c21 + c22 - c24 - c30 - c35 + c36) + 2.0*(c9 - c11 - c14 + c23 - c26 + c28) + 3.0*(-c13 + c15))
                + u3*((c0 + c1 - c3 - c4 + c7 + c9 + c16 + c18 + c20 - c21 + c22 - c24 - c25 - c26 - c27 - c30) + 2.0*(-c8 - c11 - c13 - c14 + c23 + c28) + 4.0*c15);
            let h1y = 2.0*u0*((c1 + c2 - c3 - c5 - c7 + c9 - c11 + c14 + c21 - c22 - c23 + c24 - c26 + c28))
                + u1*((c0 + c2 + c4 - c5 + c6 - c8 + c9 + c13 - c15 - c16 - c20 + c25 - c26 - c27 + c35 - c36) + 2.0*(-c3 - c11 + c14 - c22 - c23 + c28) + 4.0*c24)
                + u2*((c1 + c2 - c3 - c5 + c6 - c7 - c8 + c13 - c15 - c18 + c21 + c30 + c35 - c36) + 2.0*(c9 - c11 + c14 - c23 - c26 + c28) + 3.0*(-c22 + c24))
                + u3*((c0 + c1 + c4 - c7 + c9 - c16 + c18 - c20 + c21 - c22 + c25 - c26 - c27 - c30) + 2.0*(c2 - c5 - c11 + c14 - c23 + c28) + 3.0*(-c3 + c24));
            let h1z = 2.0*u0*((c0 + c2 - c4 - c5 + c7 - c9 + c11 - c14 - c20 - c21 - c23 + c26 + c27 + c28))
                + u1*((c0 + c2 - c4 - c5 + c6 + c8 - c9 - c13 - c15 - c16 + c25 + c26 - c35 + c36) + 2.0*(c7 + c11 - c14 - c21 - c23 + c28) + 3.0*(-c20 + c27))
                + u2*((c1 + c2 + c3 - c5 + c6 + c7 + c8 - c13 - c15 - c18 - c21 - c22 - c24 + c30 - c35 + c36) + 2.0*(-c4 + c11 - c14 - c20 - c23 + c28) + 4.0*c27)
                + u3*((c0 + c1 + c3 + c7 - c9 + c16 - c18 - c20 - c21 - c22 - c24 - c25 + c26 + c30) + 2.0*(c2 - c5 + c11 - c14 - c23 + c28) + 3.0*(-c4 + c27));
            hd = vec3<f32>(h0x, h0y, h0z);
            ho = vec3<f32>(h1x, h1y, h1z);
        }
        default: {
            let h0x = 2.0*u0*((c2 + c3 + c4 + c5 - c10 - c11 - c14 - c15 - c23 - c24 - c27 - c28 + c34 + c35 + c36 + c37))
                + u1*((c4 + c5 - c9 - c12 + c13 + c16 - c22 - c25 + c26 + c29 + c36 + c37) + 2.0*(-c10 - c11 - c14 - c15 - c23 - c24 - c27 - c28) + 3.0*(c2 + c3 + c34 + c35))
                + u2*((c3 + c5 - c7 + c8 - c17 + c18 - c20 + c21 - c30 + c31 + c35 + c37) + 2.0*(-c10 - c11 - c14 - c15 - c23 - c24 - c27 - c28) + 3.0*(c2 + c4 + c34 + c36))
                + u3*((-c7 - c8 - c9 - c12 - c13 - c16 - c17 - c18 + c20 + c21 + c22 + c25 + c26 + c29 + c30 + c31) + 2.0*(c23 + c24 + c27 + c28) + 4.0*(c2 + c3 + c4 + c5) + 6.0*(-c10 - c11 - c14 - c15));
            let h0y = 2.0*u0*((c7 + c8 - c10 - c11 - c14 - c15 + c17 + c18 + c20 + c21 - c23 - c24 - c27 - c28 + c30 + c31))
                + u1*((c4 - c3 - c2 + c5 - c9 - c12 + c13 + c16 - c22 - c25 + c26 + c29 - c34 - c35 + c36 + c37) + 2.0*(c14 + c15 + c27 + c28) + 4.0*(c7 + c8 + c20 + c21) + 6.0*(-c10 - c11 - c23 - c24))
                + u2*((c3 - c2 - c4 + c5 + c8 + c18 + c21 + c31 - c34 + c35 - c36 + c37) + 2.0*(-c10 - c11 - c14 - c15 - c23 - c24 - c27 - c28) + 3.0*(c7 + c17 + c20 + c30))
                + u3*((-c9 - c12 - c13 - c16 + c20 + c21 + c22 + c25 + c26 + c29 + c30 + c31) + 2.0*(-c10 - c11 - c14 - c15 - c23 - c24 - c27 - c28) + 3.0*(c7 + c8 + c17 + c18));
            let h0z = 2.0*u0*((c9 - c10 - c11 + c12 + c13 - c14 - c15 + c16 + c22 - c23 - c24 + c25 + c26 - c27 - c28 + c29))
                + u1*((c4 - c3 - c2 + c5 + c13 + c16 + c26 + c29 - c34 - c35 + c36 + c37) + 2.0*(-c10 - c11 - c14 - c15 - c23 - c24 - c27 - c28) + 3.0*(c9 + c12 + c22 + c25))
                + u2*((c3 - c2 - c4 + c5 - c7 + c8 - c17 + c18 - c20 + c21 - c30 + c31 - c34 + c35 - c36 + c37) + 2.0*(c11 + c15 + c24 + c28) + 4.0*(c9 + c13 + c22 + c26) + 6.0*(-c10 - c14 - c23 - c27))
                + u3*((-c8 - c7 - c17 - c18 + c20 + c21 + c22 + c25 + c26 + c29 + c30 + c31) + 2.0*(-c10 - c11 - c14 - c15 - c23 - c24 - c27 - c28) + 3.0*(c9 + c12 + c13 + c16));
            let h1x = u0*((c7 - c8 + c9 - c12 - c13 + c16 - c17 + c18 + c20 - c21 + c22 - c25 - c26 + c29 - c30 + c31) + 2.0*(c10 - c11 - c14 + c15 + c23 - c24 - c27 + c28))
                + u1*((c3 - c2 - c4 + c5 + c9 - c12 - c13 + c16 + c22 - c25 - c26 + c29 - c34 + c35 - c36 + c37) + 2.0*(c7 - c8 + c10 - c11 - c14 + c15 + c20 - c21 + c23 - c24 - c27 + c28))
                + u2*((c4 - c3 - c2 + c5 + c7 - c8 - c17 + c18 + c20 - c21 - c30 + c31 - c34 - c35 + c36 + c37) + 2.0*(c9 + c10 - c11 - c13 - c14 + c15 + c22 + c23 - c24 - c26 - c27 + c28))
                + u3*((c7 - c8 + c9 - c12 - c13 + c16 - c17 + c18 + c20 - c21 + c22 - c25 - c26 + c29 - c30 + c31) + 2.0*(c10 - c11 - c14 + c15 + c23 - c24 - c27 + c28));
            let h1y = u0*((c2 - c3 + c4 - c5 + c9 - c12 + c13 - c16 - c22 + c25 - c26 + c29 - c34 + c35 - c36 + c37) + 2.0*(c10 - c11 + c14 - c15 - c23 + c24 - c27 + c28))
                + u1*((c2 - c3 + c4 - c5 + c9 - c12 + c13 - c16 - c22 + c25 - c26 + c29 - c34 + c35 - c36 + c37) + 2.0*(c10 - c11 + c14 - c15 - c23 + c24 - c27 + c28))
                + u2*((c2 - c3 + c4 - c5 - c7 - c8 - c17 - c18 + c20 + c21 + c30 + c31 - c34 + c35 - c36 + c37) + 2.0*(c9 + c10 - c11 + c13 + c14 - c15 - c22 - c23 + c24 - c26 - c27 + c28))
                + u3*((-c7 + c8 + c9 - c12 + c13 - c16 - c17 + c18 - c20 + c21 - c22 + c25 - c26 + c29 - c30 + c31) + 2.0*(c2 - c3 + c4 - c5 + c10 - c11 + c14 - c15 - c23 + c24 - c27 + c28));
            let h1z = u0*((c2 + c3 - c4 - c5 + c7 + c8 - c17 - c18 - c20 - c21 + c30 + c31 - c34 - c35 + c36 + c37) + 2.0*(c10 + c11 - c14 - c15 - c23 - c24 + c27 + c28))
                + u1*((c2 + c3 - c4 - c5 - c9 - c12 - c13 - c16 + c22 + c25 + c26 + c29 - c34 - c35 + c36 + c37) + 2.0*(c7 + c8 + c10 + c11 - c14 - c15 - c20 - c21 - c23 - c24 + c27 + c28))
                + u2*((c2 + c3 - c4 - c5 + c7 + c8 - c17 - c18 - c20 - c21 + c30 + c31 - c34 - c35 + c36 + c37) + 2.0*(c10 + c11 - c14 - c15 - c23 - c24 + c27 + c28))
                + u3*((c7 + c8 - c9 - c12 + c13 + c16 - c17 - c18 - c20 - c21 - c22 - c25 + c26 + c29 + c30 + c31) + 2.0*(c2 + c3 - c4 - c5 + c10 + c11 - c14 - c15 - c23 - c24 + c27 + c28));
            hd = vec3<f32>(h0x, h0y, h0z);
            ho = vec3<f32>(h1x, h1y, h1z);
        }
    }

    // Back to lattice coordinates.
    let f = mat3x3<f32>(vec3<f32>(ax), vec3<f32>(ay), vec3<f32>(az));
    let perm = mat3x3<f32>(vec3<f32>(ex), vec3<f32>(ey), vec3<f32>(ez));
    let g = f * g_ref;
    let d = perm * hd * (1.0 / 16.0);
    let o = f * ho * (r.x * r.y * r.z / 16.0);
    let hm = mat3x3<f32>(vec3<f32>(d.x, o.z, o.y), vec3<f32>(o.z, d.y, o.x), vec3<f32>(o.y, o.x, d.z));
    return vec4<f32>(hm[0] + 0.5 * hm[1] + 0.25 * hm[2], value + dot(g, vec3<f32>(1.0, 0.5, 0.25)));
}
