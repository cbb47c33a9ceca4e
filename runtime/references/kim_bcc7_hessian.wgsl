// Hand-written reference: value, gradient and Hessian of bcc7 (the quartic
// seven-direction box spline on BCC) by Kim's method.
//
// Method: M. Kim, "Quartic box-spline reconstruction on the BCC lattice",
// IEEE TVCG 19(2), 2013; M. Kim, "Analysis of symmetry groups of box-splines
// for evaluation on GPUs", Graphical Models 93, 2017; as published by the
// authors in the GitHub repository cg-uos/bcc7, file
// bcc7_raycast_curvature.frag (no licence attached: this file is our own
// WGSL, written after reading it). The method: reduce p by the lattice's
// symmetry (4 reflections of the unit cube about a BCC corner, times the 6
// axis permutations) to the reference tetrahedron 1 >= x >= y >= z >= 0,
// fetch the 30 samples of its stencil, and evaluate ONE quartic formula for
// the value, THREE cubic formulas (Bernstein monomials of the barycentric
// coordinates u) for the gradient and SIX quadratic formulas (likewise) for
// the second derivatives, then map gradient and Hessian back. The
// polynomial coefficients of those ten formulas are the published ones
// (transcribed as mathematics, with the repository's sample numbering
// c0..c29); locate, stencil and back-mapping are written here.
//
// Two published coefficients are corrected here. Checked term by term
// against central differences of the published quartic (in f64, every
// sample and every Bernstein monomial), the cubic for d/dy of the
// reference frame has, in its u012 term, 3*(c3 - c4) where the quartic's
// derivative has 4*(c3 - c4); the cubic for d/dx has, in its u112 term,
// 3*(-c13 - c14 + c17 + c18) where the derivative has 2*(...). With these
// two fixes all three cubics are the quartic's derivatives and the six
// quadratics its second derivatives (they needed no fix). The fixes change
// constants only, not the operation count.
//
// Our formulation of the locate and back-mapping: the reference frame's axes
// in lattice coordinates are a_k = S e_pi(k) (S the reflection, pi sorting
// the local coordinates in decreasing order); the stencil is a fixed table of
// lattice vectors in that frame (taken from the published fetch walk); the
// gradient is F g_ref and the Hessian F H_ref F^T with F = [a_0 a_1 a_2].
// Because S has determinant +1 here (an even number of sign flips), the
// diagonal of F H_ref F^T is the permuted diagonal of H_ref and its
// off-diagonal (yz, zx, xy) is F applied to H_ref's: no matrix products.
// This equals the repository's 24 x 6 lookup table of second-derivative
// indices (checked case by case, all 24).
//
// Coordinates: lattice point j at integer coordinates j (all even or all
// odd), as kim_lee_bcc7.wgsl, read through the generated module's
// `bcc7_fetch`. Scale: value 1/192 (the published SCALE_M; a partition of
// unity). Per lattice unit the gradient is 1/96 of the cubics and the
// Hessian 1/32 of the quadratics' combinations: half the published
// factors (SCALE_Tj x 0.5 = 1/48, SCALE_Tij x 0.25 = 1/16), which give
// twice the derivatives of the published quartic per lattice unit (both by
// the same factor, so curvature -PHP/|g| is unchanged; the published
// shader then multiplies by its own texture-space scale). Checked against
// `bcc7_eval_hessian` by `boxforge bench --hessian`.
// `bx_kim_bcc7(p)` folds every entry into one vec4 with the bench's weights.

fn bx_kim_bcc7(p: vec3<f32>) -> vec4<f32> {
    // The unit cube around p and its corner of the lattice's parity.
    let lower = vec3<i32>(floor(p));
    let odd = lower & vec3<i32>(1);
    let flip = (odd.x + odd.y + odd.z) & 1;
    let tr = select(odd, vec3<i32>(1) - odd, flip == 1);
    let org = lower + tr;
    let si = vec3<i32>(1) - 2 * tr;
    let s = vec3<f32>(si);
    let xc = (p - vec3<f32>(org)) * s;
    // Sort the local coordinates: one-hot of the largest, middle, smallest.
    let yx = xc.y >= xc.x;
    let zx = xc.z >= xc.x;
    let zy = xc.z >= xc.y;
    let imax = vec3<i32>(vec3<bool>(!yx && !zx, yx && !zy, zx && zy));
    let imin = vec3<i32>(vec3<bool>(yx && zx, !yx && zy, !zx && !zy));
    let imid = vec3<i32>(1) - imax - imin;
    let a0 = si * imax;
    let a1 = si * imid;
    let a2 = si * imin;
    let x = dot(xc, vec3<f32>(imax));
    let y = dot(xc, vec3<f32>(imid));
    let z = dot(xc, vec3<f32>(imin));

    // The 30 samples, at org + k0 a0 + k1 a1 + k2 a2.
    let c0 = bcc7_fetch(org);
    let c1 = bcc7_fetch(org + a0 + a1 + a2);
    let c2 = bcc7_fetch(org + a0 + a1 - a2);
    let c3 = bcc7_fetch(org + a0 - a1 + a2);
    let c4 = bcc7_fetch(org + a0 - a1 - a2);
    let c5 = bcc7_fetch(org - a0 + a1 + a2);
    let c6 = bcc7_fetch(org - a0 + a1 - a2);
    let c7 = bcc7_fetch(org - a0 - a1 + a2);
    let c8 = bcc7_fetch(org - a0 - a1 - a2);
    let c9 = bcc7_fetch(org + 2 * a0);
    let c10 = bcc7_fetch(org - 2 * a0);
    let c11 = bcc7_fetch(org + 2 * a1);
    let c12 = bcc7_fetch(org - 2 * a1);
    let c13 = bcc7_fetch(org + 2 * a2);
    let c14 = bcc7_fetch(org - 2 * a2);
    let c15 = bcc7_fetch(org + 2 * (a1 + a2));
    let c16 = bcc7_fetch(org + 2 * (a1 - a2));
    let c17 = bcc7_fetch(org + 2 * (a0 + a2));
    let c18 = bcc7_fetch(org + 2 * (a0 - a2));
    let c19 = bcc7_fetch(org + 2 * (a0 + a1));
    let c20 = bcc7_fetch(org + 2 * (a0 - a1));
    let c21 = bcc7_fetch(org + 3 * a0 + a1 + a2);
    let c22 = bcc7_fetch(org + 3 * a0 + a1 - a2);
    let c23 = bcc7_fetch(org + 3 * a0 - a1 + a2);
    let c24 = bcc7_fetch(org + 3 * a0 - a1 - a2);
    let c25 = bcc7_fetch(org + a0 + 3 * a1 + a2);
    let c26 = bcc7_fetch(org + a0 + 3 * a1 - a2);
    let c27 = bcc7_fetch(org + a0 + a1 + 3 * a2);
    let c28 = bcc7_fetch(org + 2 * (a0 + a1 + a2));
    let c29 = bcc7_fetch(org + 2 * (a0 + a1 - a2));

    // The quartic: value.
    let xpy = x + y;
    let xmy = x - y;
    let xpz = x + z;
    let xmz = x - z;
    let ypz = y + z;
    let ymz = y - z;
    let q0 = x * x;
    let q1 = (x - 1.0) * (x - 1.0);
    let q2 = (x - 2.0) * (x - 2.0);
    let q3 = (x - 3.0) * (x - 3.0);
    let q4 = (x + 1.0) * (x + 1.0);
    let r0 = z * z;
    let r1 = (z - 1.0) * (z - 1.0);
    let r2 = (z - 2.0) * (z - 2.0);
    let r3 = (z + 1.0) * (z + 1.0);
    let r4 = (z + 2.0) * (z + 2.0);
    let v8 = -q0 * q0 * (c9 + c19)
        + q1 * q1 * (c0 - c5 - c6 - c7 - c8 + c10 + c11 + c12 + c14)
        + q3 * q3 * c0
        - q2 * q2 * (c0 - c5 + c11)
        + q4 * q4 * c9
        + r0 * r0 * (c1 + c3 - c13 - c15 - c17 + c21 + c25 + c27 - c28)
        - r1 * r1 * (c2 + c4)
        - r3 * r3 * (c1 + c3 - c13)
        + r2 * r2 * c2
        + r4 * r4 * c1;
    let w0 = xmy - 2.0;
    let w1 = ypz - 2.0;
    let w2 = ymz - 2.0;
    let v4 = -xpy * xpy * xpy * (2.0 + xmy) * (c9 - c19)
        - w0 * w0 * w0 * (xpy - 4.0) * (c0 - c11)
        + w1 * w1 * w1 * (ymz + 2.0) * (c2 - c4)
        + w2 * w2 * w2 * (ypz + 2.0) * (c1 - c3);
    let w3 = xpy - 2.0;
    let w4 = xpz - 2.0;
    let w5 = xmz - 2.0;
    let v2 = -xmy * xmy * xmy * (2.0 * (2.0 * (c9 - c20) - z * (c23 - c24)) - xpy * (2.0 * (c19 - c20) + c23 + c24))
        - xpz * xpz * xpz * (2.0 * (2.0 * (c1 + c3 + c9 + c13 - c17) + y * (c1 - c3 - c9 + c19 - c21)) - xmz * (2.0 * (c13 - c17) + c1 + c3 - c9 - c19 + c21))
        + xmz * xmz * xmz * (2.0 * (-2.0 * (c2 + c4 + c9 - c18) - y * (c2 - c4 - c9 + c19 - c22)) + xpz * (c2 + c4 - c9 - 2.0 * c18 - c19 + c22))
        - ypz * ypz * ypz * (2.0 * (2.0 * (c1 - c3 + c13 - c15) - x * (c13 - c15 - c17 - c21 + c28)) + ymz * (2.0 * (c3 - c25) - c13 + c15 - c17 - c21 + c28))
        - ymz * ymz * ymz * (2.0 * (2.0 * (c2 - c4 - c16) + x * (c16 + c18 + c22 - c29)) - ypz * (-2.0 * (c4 - c26) + c22 - c16 + c18 - c29))
        + w3 * w3 * w3 * (2.0 * (2.0 * (c0 - c11) + (c5 + c6 - c7 - c8 + c14) + z * (c5 - c6 - c7 + c8 - c14)) - xmy * (c5 + c6 - c7 - c8 + c14 - 2.0 * (c11 - c12)))
        + w4 * w4 * w4 * (2.0 * (3.0 * c0 + (c2 + c4 + c11 - c14) + 2.0 * (c5 - c6) - y * (c0 - c2 + c4 - c11 - c14)) - xmz * (c0 - c2 - c4 + c11 + c14 + 2.0 * (c5 - c6)))
        + w5 * w5 * w5 * (2.0 * (3.0 * c0 + (c1 + c3 + c11) - y * (c0 - c1 + c3 - c11)) - xpz * (c0 - c1 - c3 + c11));
    let value = (4.0 * v8 + 2.0 * v4 + v2) * (1.0 / 192.0);

    // Barycentric coordinates of the reference tetrahedron
    // (0,0,0), (1,0,0), (1,1,0), (1,1,1).
    let u0 = 1.0 - x;
    let u1 = x - y;
    let u2 = y - z;
    let u3 = z;

    // The three cubics (gradient), in the cubic Bernstein monomials.
    let u00 = u0 * u0;
    let u11 = u1 * u1;
    let u22 = u2 * u2;
    let u33 = u3 * u3;
    let u000 = u00 * u0;
    let u001 = u00 * u1;
    let u002 = u00 * u2;
    let u003 = u00 * u3;
    let u011 = u0 * u11;
    let u012 = u0 * u1 * u2;
    let u013 = u0 * u1 * u3;
    let u022 = u0 * u22;
    let u023 = u0 * u2 * u3;
    let u033 = u0 * u33;
    let u111 = u11 * u1;
    let u112 = u11 * u2;
    let u113 = u11 * u3;
    let u122 = u1 * u22;
    let u123 = u1 * u2 * u3;
    let u133 = u1 * u33;
    let u222 = u22 * u2;
    let u223 = u22 * u3;
    let u233 = u2 * u33;
    let u333 = u33 * u3;
    let t0 = u012*12.0*(6.0*(c11 - c0) + 7.0*(c1 + c2 - c3 - c4) + 2.0*(c19 - c9) + c5 + c6 - c7 - c8)
        + u013*24.0*(3.0*(c11 - c0) + 5.0*(c1 - c3) + c19 + 2.0*(c2 - c4) + c5 - c7 - c9)
        + u011*6.0*(7.0*(c1 + c2 - c3 - c4) + 3.0*(c11 - c12) + c19 - c20 + c5 + c6 - c7 - c8)
        + u023*24.0*(5.0*(c11 - c0) + 3.0*(c1 - c3) - c13 + c15 + 2.0*(c19 - c9) + c2 - c4)
        + u022*6.0*(10.0*(c11 - c0) + 4.0*(c1 + c19 + c2 - c3 - c4 - c9) - c13 - c14 + c15 + c16)
        + u033*24.0*(2.0*(c11 - c0 + c1 - c3) - c13 + c15 + c19 - c9)
        + u000*8.0*(c1 + c11 - c12 + c2 - c3 - c4 + c5 + c6 - c7 - c8)
        + u001*12.0*(3.0*(c1 + c2 - c3 - c4) + 2.0*(c11 - c12) + c5 + c6 - c7 - c8)
        + u002*12.0*(4.0*(-c0 + c11) + 3.0*(c1 + c2 - c3 - c4) + c5 + c6 - c7 - c8)
        + u003*24.0*(2.0*(-c0 + c1 + c11 - c3) + c2 - c4 + c5 - c7)
        + u123*12.0*(7.0*(-c0 + c11 + c19 - c9) + 6.0*(c1 - c3) - c13 + c15 - c17 + 2.0*(c2 - c4) + c28)
        + u122*3.0*(14.0*(-c0 + c11 + c19 - c9) + 8.0*(c1 + c2 - c3 - c4) - c13 - c14 + c15 + c16 - c17 - c18 + c28 + c29)
        + u133*12.0*(3.0*(-c0 + c11 + c19 - c9) + 4.0*(c1 - c3) - c13 + c15 - c17 + c28)
        + u112*3.0*(8.0*(-c0 + c11 + c19 - c9) + 14.0*(c1 + c2 - c3 - c4) + c21 + c22 - c23 - c24 + c5 + c6 - c7 - c8)
        + u113*6.0*(4.0*(-c0 + c11 + c19 + c2 - c4 - c9) + 10.0*(c1 - c3) + c21 - c23 + c5 - c7)
        + u111*(14.0*(c1 + c2 - c3 - c4) + 4.0*(c11 - c12 + c19 - c20) + c21 + c22 - c23 - c24 + c5 + c6 - c7 - c8)
        + u233*12.0*(3.0*(-c0 + c11 + c19 - c9) - c13 + c15 - c17 + 2.0*(c25 - c3) + c28)
        + u223*6.0*(7.0*(-c0 + c11 + c19 - c9) - c13 + c15 - c17 + 3.0*(c25 - c3) + c26 + c28 - c4)
        + u222*(14.0*(-c0 + c11 + c19 - c9) - c13 - c14 + c15 + c16 - c17 - c18 + 4.0*(c25 + c26 - c3 - c4) + c28 + c29)
        + u333*8.0*(-c0 + c11 - c13 + c15 - c17 + c19 + c25 + c28 - c3 - c9);
    let t1 = u012*12.0*(10.0*(c1 - c2) + 3.0*(c13 - c14) + 4.0*(c3 - c4) + c17 - c18 + 2.0*(c5 - c6))
        + u013*24.0*(3.0*(-c0 + c13) + 5.0*(c1 - c2) + c17 + 2.0*(c3 - c4) + c5 - c6 - c9)
        + u011*6.0*(7.0*(c1 - c2 + c3 - c4) + 3.0*(c13 - c14) + c17 - c18 + c5 - c6 + c7 - c8)
        + u023*24.0*(2.0*(-c0 + c13) + 6.0*(c1 - c2) - c11 + c15 + c17 + c3 - c4 + c5 - c6 - c9)
        + u022*6.0*(12.0*(c1 - c2) + 2.0*(c13 - c14 + c3 - c4 + c5 - c6) + c15 - c16 + c17 - c18)
        + u033*24.0*(2.0*(-c0 + c1 + c13 - c2) - c11 + c15 + c17 - c9)
        + u000*8.0*(c1 + c13 - c14 - c2 + c3 - c4 + c5 - c6 + c7 - c8)
        + u001*12.0*(3.0*(c1 - c2 + c3 - c4) + 2.0*(c13 - c14) + c5 - c6 + c7 - c8)
        + u002*24.0*(2.0*(c1 - c2) + c13 - c14 + c3 - c4 + c5 - c6)
        + u003*24.0*(2.0*(-c0 + c1 + c13 - c2) + c3 - c4 + c5 - c6)
        + u123*12.0*(3.0*(-c0 + c13 + c17 - c9) + 12.0*(c1 - c2) - c11 + c15 - c19 + c21 - c22 + c28 + 2.0*(c3 - c4) + c5 - c6)
        + u122*3.0*(24.0*(c1 - c2) + 4.0*(c3 - c4) + 3.0*(c13 - c14 + c17 - c18) + 2.0*(c21 - c22 + c5 - c6) + c15 - c16 + c28 - c29)
        + u133*12.0*(3.0*(-c0 + c13 + c17 - c9) + 4.0*(c1 - c2) - c11 + c15 - c19 + c28)
        + u112*6.0*(10.0*(c1 - c2) + 2.0*(c13 - c14 + c17 - c18) + c21 - c22 + 4.0*(c3 - c4) + c5 - c6)
        + u113*6.0*(10.0*(c1 - c2) + 4.0*(-c0 + c13 + c17 + c3 - c4 - c9) + c21 - c22 + c5 - c6)
        + u111*(14.0*(c1 - c2 + c3 - c4) + 4.0*(c13 - c14 + c17 - c18) + c21 - c22 + c23 - c24 + c5 - c6 + c7 - c8)
        + u233*24.0*(-c0 + 2.0*(c1 - c2) - c11 + c13 + c15 + c17 - c19 + c28 - c9)
        + u223*6.0*(12.0*(c1 - c2) + 2.0*(-c0 - c11 + c13 + c15 + c17 - c19 + c28 - c9) + c21 - c22 + c25 - c26 + c3 - c4 + c5 - c6)
        + u222*2.0*(12.0*(c1 - c2) + c13 - c14 + c15 - c16 + c17 - c18 + c21 - c22 + c25 - c26 + c28 - c29 + c3 - c4 + c5 - c6)
        + u333*8.0*(-c0 - c11 + c13 + c15 + c17 - c19 - c2 + c27 + c28 - c9);
    let t2 = u012*12.0*(12.0*(c9 - c0) + 3.0*(c1 + c2 - c5 - c6) + 2.0*(c19 - c11) - c13 - c14 + c17 + c18 + c3 + c4 - c7 - c8)
        + u013*24.0*(6.0*(c9 - c0) + 2.0*(c1 - c5) - c11 - c13 + c17 + c19 + c2 + c3 - c6 - c7)
        + u011*6.0*(12.0*(c9 - c0) + 2.0*(c1 + c2 + c3 + c4 - c5 - c6 - c7 - c8) - c11 - c12 - c13 - c14 + c17 + c18 + c19 + c20)
        + u023*24.0*(5.0*(c9 - c0) + 3.0*(c1 - c5) + 2.0*(c19 - c11) - c13 + c17 + c2 - c6)
        + u022*6.0*(10.0*(c9 - c0) + 4.0*(c1 - c11 + c19 + c2 - c5 - c6) - c13 - c14 + c17 + c18)
        + u033*24.0*(2.0*(-c0 + c1 - c5 + c9) - c11 - c13 + c17 + c19)
        + u000*8.0*(c1 - c10 + c2 + c3 + c4 - c5 - c6 - c7 - c8 + c9)
        + u001*24.0*(2.0*(c9 - c0) + c1 + c2 + c3 + c4 - c5 - c6 - c7 - c8)
        + u002*12.0*(4.0*(c9 - c0) + 3.0*(c1 + c2 - c5 - c6) + c3 + c4 - c7 - c8)
        + u003*24.0*(2.0*(-c0 + c1 - c5 + c9) + c2 + c3 - c6 - c7)
        + u123*12.0*(10.0*(c9 - c0) + 4.0*(-c11 + c19) + 2.0*(-c13 + c17) + 3.0*(c21 - c5) + c22 - c6)
        + u122*6.0*(10.0*(c9 - c0) + 4.0*(-c11 + c19) - c13 - c14 + c17 + c18 + 2.0*(c21 + c22 - c5 - c6))
        + u133*24.0*(2.0*(c9 - c0) - c11 - c13 + c17 + c19 + c21 - c5)
        + u112*3.0*(24.0*(c9 - c0) + 4.0*(c19 - c11) + 2.0*(-c13 - c14 + c17 + c18) + 3.0*(c21 + c22 - c5 - c6) + c23 + c24 - c7 - c8)
        + u113*6.0*(12.0*(c9 - c0) + 2.0*(-c11 - c13 + c17 + c19 + c21 - c5) + c22 + c23 - c6 - c7)
        + u111*2.0*(12.0*(c9 - c0) - c11 - c12 - c13 - c14 + c17 + c18 + c19 + c20 + c21 + c22 + c23 + c24 - c5 - c6 - c7 - c8)
        + u233*12.0*(3.0*(c9 - c0 - c11 + c19) - c13 - c15 + c17 + 2.0*(c21 - c5) + c28)
        + u223*6.0*(7.0*(c9 - c0 - c11 + c19) - c13 - c15 + c17 + 3.0*(c21 - c5) + c22 + c28 - c6)
        + u222*(14.0*(c9 - c0 - c11 + c19) - c13 - c14 - c15 - c16 + c17 + c18 + 4.0*(c21 + c22 - c5 - c6) + c28 + c29)
        + u333*8.0*(-c0 - c11 - c13 - c15 + c17 + c19 + c21 + c28 - c5 + c9);
    // In the reference frame: d/dx = t2, d/dy = t0, d/dz = t1 (scaled).
    let g_ref = vec3<f32>(t2, t0, t1) * (1.0 / 96.0);

    // The six quadratics (second derivatives), in the quadratic monomials.
    let xx = u0 * u0;
    let yy = u1 * u1;
    let zz = u2 * u2;
    let ww = u3 * u3;
    let xy = u0 * u1;
    let xz = u0 * u2;
    let xw = u0 * u3;
    let yz = u1 * u2;
    let yw = u1 * u3;
    let zw = u2 * u3;
    let e0 = yy*(c1 + c11 + c12 - 2.0*c14 - 2.0*c17 + c19 + c2 + c20 - c21 - c23 + c3 + c4 - c6 - c8)
        + zz*(c0 + c11 - c14 - c16 - c17 + c19 - 2.0*(c6 + c21) + c25 + c26 - c28 + c3 + c4 + c9)
        + xw*8.0*(c11 - c17 + c3 - c6)
        + 2.0*(xx*(2.0*c0 - c1 - c10 + c11 + c12 - c13 - c14 + c2 - c3 + c4 + c5 - c6 + c7 - c8 - c9) + ww*(-c0 + 2.0*c1 - c11 + c13 + c15 - c17 + c19 - c2 - c21 + c25 - c27 - c28 + c3 - c5 + c9))
        + 4.0*(xy*(c0 + c11 + c12 - c14 - c17 + c2 + c4 - c6 - c8 - c9) + xz*(c0 - c1 + 2.0*(c11 - c6) - c14 - c17 + c2 + c3 + c4 - c9) + yz*(c11 - c14 - c17 + c19 - c21 + c3 + c4 - c6) + yw*(-c0 + c1 + c11 + c19 - c2 - c21 + 2.0*(c3 - c17) - c6 + c9) + zw*(c1 - c17 + c19 - c2 - c21 + c25 - c28 + c3 - c6 + c9));
    let e1 = yy*(c1 - 2.0*(c12 + c19) + c13 + c14 + c17 + c18 + c2 - c21 - c22 + c3 + c4 - c7 - c8)
        + zz*(-4.0*(c0 + c19 - c2) + 4.0*c1 + 2.0*c11 + c15 + c16 + c17 + c18 - c21 - c22 - c25 - c26 - c3 - c4 - c5 - c6 + 2.0*c9)
        + xw*8.0*(c13 - c19 + c2 - c7)
        + 2.0*(ww*(-c0 + 2.0*c1 + c11 - c13 + c15 + c17 - c19 + c2 - c21 - c25 + c27 - c28 - c3 - c5 + c9) + xx*(2.0*c0 - c1 - c10 - c11 - c12 + c13 + c14 - c2 + c3 + c4 + c5 + c6 - c7 - c8 - c9) + yz*(-2.0*(c0 - c9 + 2.0*c19) + 3.0*(c1 + c2) + c13 + c14 + c17 + c18 - c21 - c22 - c3 - c4 - c7 - c8))
        + 4.0*(xy*(c0 - c12 + c13 + c14 - c19 + c3 + c4 - c7 - c8 - c9) + xz*(c1 + c13 + c14 - 2.0*c19 + c2 - c7 - c8) + yw*(-c0 + c1 + c13 + c17 - 2.0*(c19 - c2) - c21 - c3 - c7 + c9) + zw*(-2.0*(c0 - c1 + c19) + c11 + c15 + c17 + 2.0*c2 - c21 - c25 - c3 - c5 + c9));
    let e2 = yy*(4.0*(c0 - c1 - c4 + c9) - c11 - c12 - c13 - c14 - c17 - c18 - c19 + 2.0*(c2 + c3) - c20 + c22 + c23 + c6 + c7)
        + zz*(c0 + c11 - c14 - c15 - c18 + c19 + c21 + c22 - 2.0*(c25 + c4) - c28 + c5 + c6 + c9)
        + xw*8.0*(-c15 - c4 + c5 + c9)
        + 2.0*(xx*(2.0*c0 - c1 + c10 - c11 - c12 - c13 - c14 + c2 + c3 - c4 - c5 + c6 + c7 - c8 + c9) + ww*(-c0 + 2.0*c1 + c11 + c13 - c15 + c17 + c19 - c2 + c21 - c25 - c27 - c28 - c3 + c5 - c9) + yz*(3.0*(c0 + c9) - 2.0*(c1 - c2 + 2.0*c4) - c11 - c14 - c15 - c18 - c19 + c21 + c22 - c28 + c5 + c6))
        + 4.0*(xy*(2.0*(c0 - c1 - c4 + c9) - c11 - c12 - c13 - c14 + c2 + c3 + c6 + c7) + xz*(c0 - c1 - c11 - c14 - c15 + c2 - 2.0*(c4 - c9) + c5 + c6) + yw*(c0 - c15 + c21 - c28 - 2.0*c4 + c5 + c9) + zw*(c1 + c11 - c15 + c19 - c2 + c21 - c25 - c28 - c4 + c5));
    let e3 = yy*(c1 + c11 + c12 - 2.0*(c13 + c18) + c19 + c2 + c20 - c22 - c24 + c3 + c4 - c5 - c7)
        + zz*(c0 + c11 - c13 - c15 - c18 + c19 - 2.0*(c22 + c5) + c25 + c26 - c29 + c3 + c4 + c9)
        + xw*8.0*(c0 + c1 + c11 - c13 - c2 + c3 - c5 - c9)
        + 2.0*(xx*(2.0*c0 + c1 - c10 + c11 + c12 - c13 - c14 - c2 + c3 - c4 - c5 + c6 - c7 + c8 - c9) + ww*(c0 + 2.0*c1 + c11 - c13 - c15 + c17 - c19 - c2 - c21 + c25 - c27 + c28 + c3 - c5 - c9))
        + 4.0*(xy*(c0 + c1 + c11 + c12 - c13 - c18 + c3 - c5 - c7 - c9) + xz*(c0 + c1 + 2.0*(c11 - c5) - c13 - c18 - c2 + c3 + c4 - c9) + yz*(c11 - c13 - c18 + c19 - c22 + c3 + c4 - c5) + yw*(c0 + c1 + c11 - 2.0*(c13 - c3) + c19 - c2 - c22 - c5 - c9) + zw*(c0 + c1 + c11 - c13 - c15 - c2 - c22 + c25 + c3 - c5));
    let e4 = yy*(c1 - 2.0*(c11 + c20) + c13 + c14 + c17 + c18 + c2 - c23 - c24 + c3 + c4 - c5 - c6)
        + zz*(2.0*(c0 + c19) + 4.0*(c1 - c11 + c2 - c9) + c13 + c14 - c21 - c22 - c25 - c26 + c28 + c29 - c3 - c4 - c5 - c6)
        + xw*8.0*(c0 + c1 - c11 + c13 + c2 - c3 - c5 - c9)
        + 2.0*(xx*(2.0*c0 + c1 - c10 - c11 - c12 + c13 + c14 + c2 - c3 - c4 - c5 - c6 + c7 + c8 - c9) + ww*(c0 + 2.0*c1 - c11 + c13 - c15 - c17 + c19 + c2 - c21 - c25 + c27 + c28 - c3 - c5 - c9) + yz*(2.0*(c0 - 2.0*c11 - c9) + 3.0*(c1 + c2) + c13 + c14 + c17 + c18 - c23 - c24 - c3 - c4 - c5 - c6))
        + 4.0*(xy*(c0 + c1 - c11 + c13 + c14 + c2 - c20 - c5 - c6 - c9) + xz*(2.0*(c0 + c1 - c11 + c2 - c9) + c13 + c14 - c3 - c4 - c5 - c6) + yw*(c0 + c1 - 2.0*(c11 - c2) + c13 + c17 - c23 - c3 - c5 - c9) + zw*(c0 + 2.0*(c1 - c11 - c9) + c13 + c19 + 2.0*c2 - c21 - c25 + c28 - c3 - c5));
    let e5 = yy*(4.0*(c0 - c2 - c3 + c9) + 2.0*(c1 + c4) - c11 - c12 - c13 - c14 - c17 - c18 - c19 - c20 + c21 + c24 + c5 + c8)
        + zz*(c0 + c11 - c13 - c16 - c17 + c19 + c21 + c22 - 2.0*c26 - c29 - 2.0*c3 + c5 + c6 + c9)
        + xw*8.0*(c0 + c1 - c11 - c13 - c2 - c3 + c5 + c9)
        + 2.0*(xx*(2.0*c0 + c1 + c10 - c11 - c12 - c13 - c14 - c2 - c3 + c4 + c5 - c6 - c7 + c8 + c9) + ww*(c0 + 2.0*c1 - c11 - c13 + c15 - c17 - c19 - c2 + c21 - c25 - c27 + c28 - c3 + c5 + c9) + yz*(3.0*(c0 + c9) + 2.0*(c1 - c2) - c11 - c13 - c16 - c17 - c19 + c21 + c22 - c29 - 4.0*c3 + c5 + c6))
        + 4.0*(xy*(2.0*(c0 - c2 - c3 + c9) + c1 - c11 - c12 - c13 - c14 + c4 + c5 + c8) + xz*(c0 + c1 - c11 - c13 - c16 - c2 - 2.0*(c3 - c9) + c5 + c6) + yw*(2.0*(c0 + c1 - c2 - c3 + c9) - c11 - c13 - c17 - c19 + c21 + c5) + zw*(c0 + c1 - c13 - c17 - c2 + c21 - c26 - c3 + c5 + c9));
    // The reference frame's Hessian: diagonal and (yz, zx, xy).
    let d_ref = vec3<f32>(-e0 - e1 - e3 - e4, -e1 - e2 - e4 - e5, -e0 - e2 - e3 - e5) * (1.0 / 32.0);
    let o_ref = vec3<f32>(e5 - e2, e3 - e0, e4 - e1) * (1.0 / 32.0);

    // Back to lattice coordinates.
    let f = mat3x3<f32>(vec3<f32>(a0), vec3<f32>(a1), vec3<f32>(a2));
    let perm = mat3x3<f32>(vec3<f32>(imax), vec3<f32>(imid), vec3<f32>(imin));
    let g = f * g_ref;
    let d = perm * d_ref;
    let o = f * o_ref;
    let hm = mat3x3<f32>(vec3<f32>(d.x, o.z, o.y), vec3<f32>(o.z, d.y, o.x), vec3<f32>(o.y, o.x, d.z));
    return vec4<f32>(hm[0] + 0.5 * hm[1] + 0.25 * hm[2], value + dot(g, vec3<f32>(1.0, 0.5, 0.25)));
}
