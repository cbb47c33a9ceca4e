// Hand-written reference: bcc7, the quartic seven-direction box spline on BCC,
// in GLSL as published.
//
// Source: M. Kim and Y. Lee, "Real-time BCC volume isosurface ray casting on
// the GPU" (KCGS 2012 / Kim 2013), Figure 7 ("GLSL code snippet for
// Algorithm 1 (excluding evaluation step)": parity, reflection, permutation,
// 30 axis-aligned fetches), and M. Kim's slides "GPU isosurface ray casting
// of BCC and FCC data with box splines" ("GLSL Code": the same statements in
// the layout below; "Simplified Symbolic Formula" for the reference
// tetrahedron 1 >= x >= y >= z >= 0). Both are cited in docs/BOX_SPLINES.md
// section 6; runtime/references/kim_lee_bcc7.wgsl is the WGSL port of the
// same text.
//
// What is the papers' and what is added here:
// - The macros FETCH and IT0..IT7 and every statement from `ivec3 xlow` to
//   the last FETCH are the slides' text, character for character but for
//   FETCH's body (below). (The paper's extracted text misprints one
//   `o -= R[0]` as `o -> R[0]` and IT0 as ITO; the slides have neither.)
//   GLSL's implicit int -> float conversions (`Rc*(p_in-o)`, `IT0*xc.xyz`)
//   are the published ones.
// - The published `float c[30];` is declared as the thirty scalars c01..c30
//   that the FETCH lines name.
// - The statements are wrapped in `float kim_lee_bcc7(vec3 p_in)`: the
//   published snippet is the inside of the ray caster's evaluation.
// - FETCH reads through `kim_lee_fetch(o)`: texelFetch of level 0 with the
//   coordinate clamped to the texture, as the generated library's fetch
//   clamps, so both sides pay the same loads and read the same texels at the
//   volume's edges. `volume_tex` is set 0, binding 0, a sampler3D: the
//   binding of the generated GLSL library (`boxforge generate bcc7 --target
//   glsl --layout embedded` names it `_group_0_binding_0_cs`; an r32float
//   texture, lattice point j at texel j), so one host layout binds either.
// - The formula is the slides' "Simplified Symbolic Formula", grouped as in
//   the WGSL port (each (a)^4 a square of a square, each (a)^3 a*a*a).
//
// Scale: the formula as published has no overall factor; with every c = 1 it
// sums to 384. It is divided by 384 here so that the spline is a partition of
// unity like the generated `bcc7_eval` (see the WGSL port's header). No shift
// is needed: Kim & Lee's lattice (all-even and all-odd integer points) is the
// project's `bcc` lattice in the embedded layout.

layout(binding = 0) uniform sampler3D volume_tex;

float kim_lee_fetch(ivec3 o) {
    ivec3 size = textureSize(volume_tex, 0);
    return texelFetch(volume_tex, clamp(o, ivec3(0), size - ivec3(1)), 0).r;
}

#define FETCH(var)    var = kim_lee_fetch(o);
#define IT0  itv1.x
#define IT1  itv1.y
#define IT3  itv1.z
#define IT4  itv2.x
#define IT6  itv2.y
#define IT7  itv2.z

float kim_lee_bcc7(vec3 p_in) {
float c01, c02, c03, c04, c05, c06, c07, c08, c09, c10, c11, c12, c13, c14, c15,
      c16, c17, c18, c19, c20, c21, c22, c23, c24, c25, c26, c27, c28, c29, c30;
ivec3 o;
vec3 xtet;
ivec3 xlow = ivec3(p_in);
ivec3 parity = ivec3(xlow.x&0x01, xlow.y&0x01, xlow.z&0x01);
o = ivec3(xlow) + parity;
ivec3 Rc = ivec3(1,1,1)-2*parity;
vec3 xc = Rc*(p_in-o);
int itet = (int(xc.y >= xc.x)<<2) + (int(xc.z >= xc.x)<<1) + int(xc.z >= xc.y);
ivec3 itv1 = ivec3(itet==0, itet==1, itet==3);
ivec3 itv2 = ivec3(itet==4, itet==6, itet==7);
xtet = IT0*xc.xyz + IT1*xc.xzy + IT3*xc.zxy + IT4*xc.yxz + IT6*xc.yzx + IT7*xc.zyx;
ivec3 R[3] = ivec3[](
    2*ivec3(Rc.x*(IT0+IT1), Rc.y*(IT4+IT6), Rc.z*(IT3+IT7)),
    2*ivec3(Rc.x*(IT3+IT4), Rc.y*(IT0+IT7), Rc.z*(IT1+IT6)),
    2*ivec3(Rc.x*(IT6+IT7), Rc.y*(IT1+IT3), Rc.z*(IT0+IT4)));
    FETCH(c01); o -= R[0];    FETCH(c11); o += (R[0]<<1); FETCH(c10);
o -= R[1];    FETCH(c21); o -= R[0];    FETCH(c13); o += (R[1]<<1); FETCH(c12);
o += R[0];    FETCH(c20); o -= R[2];    FETCH(c30); o -= R[1];    FETCH(c19);
o -= R[0];    FETCH(c15); o += R[1];    FETCH(c17); o += (R[2]<<1); FETCH(c16);
o += R[0];    FETCH(c29); o -= R[1];    FETCH(c18); o -= R[0];    FETCH(c14);
o += ((-R[0]+R[1]-3*R[2])>>1);    FETCH(c07);
o -= R[1];    FETCH(c09); o += R[0];    FETCH(c05); o += (R[1]<<1); FETCH(c27);
o -= R[1];    FETCH(c03); o += (R[2]<<1);    FETCH(c28); o -= R[2];    FETCH(c02);
o += R[1];    FETCH(c26); o -= (R[1]<<1);    FETCH(c04); o -= R[0];    FETCH(c08);
o += R[1];    FETCH(c06); o += (R[0]<<1);    FETCH(c22); o -= R[2];    FETCH(c23);
o -= R[1];    FETCH(c25); o += R[2];    FETCH(c24);

    // The "Simplified Symbolic Formula" at xtet, term by term.
    float x = xtet.x;
    float y = xtet.y;
    float z = xtet.z;
    float x2 = x * x;
    float xm1 = x - 1.0;
    float xm1_2 = xm1 * xm1;
    float tmx = 3.0 - x;
    float tmx_2 = tmx * tmx;
    float xm2 = x - 2.0;
    float xm2_2 = xm2 * xm2;
    float xp1 = x + 1.0;
    float xp1_2 = xp1 * xp1;
    float z2 = z * z;
    float zm1 = z - 1.0;
    float zm1_2 = zm1 * zm1;
    float zp1 = z + 1.0;
    float zp1_2 = zp1 * zp1;
    float zm2 = z - 2.0;
    float zm2_2 = zm2 * zm2;
    float zp2 = z + 2.0;
    float zp2_2 = zp2 * zp2;
    float s8 = -x2 * x2 * (c10 + c20)
        + xm1_2 * xm1_2 * (c01 - c06 - c07 - c08 - c09 + c11 + c12 + c13 + c15)
        + tmx_2 * tmx_2 * c01
        - xm2_2 * xm2_2 * (c01 - c06 + c12)
        + xp1_2 * xp1_2 * c10
        + z2 * z2 * (c02 + c04 - c14 - c16 - c18 + c22 + c26 + c28 - c29)
        - zm1_2 * zm1_2 * (c03 + c05)
        - zp1_2 * zp1_2 * (c02 + c04 - c14)
        + zm2_2 * zm2_2 * c03
        + zp2_2 * zp2_2 * c02;

    float xpy = x + y;
    float xmy = x - y;
    float ypz = y + z;
    float ymz = y - z;
    float xpz = x + z;
    float xmz = x - z;
    float a1 = xmy - 2.0;
    float a2 = ypz - 2.0;
    float a3 = ymz - 2.0;
    float s4 = -xpy * xpy * xpy * (2.0 + xmy) * (c10 - c20)
        - a1 * a1 * a1 * (xpy - 4.0) * (c01 - c12)
        + a2 * a2 * a2 * (2.0 + ymz) * (c03 - c05)
        + a3 * a3 * a3 * (2.0 + ypz) * (c02 - c04);

    float b1 = xpy - 2.0;
    float b2 = xpz - 2.0;
    float b3 = xmz - 2.0;
    float s2 = -xmy * xmy * xmy * (4.0 * (c10 - c21) - 2.0 * z * (c24 - c25) - xpy * (2.0 * (c20 - c21) + c24 + c25))
        - xpz * xpz * xpz * (4.0 * (c02 + c04 + c10 + c14 - c18) + 2.0 * y * (c02 - c04 - c10 + c20 - c22) - xmz * (2.0 * (c14 - c18) + c02 + c04 - c10 - c20 + c22))
        + xmz * xmz * xmz * (-4.0 * (c03 + c05 + c10 - c19) - 2.0 * y * (c03 - c05 - c10 + c20 - c23) + xpz * (c03 + c05 - c10 - 2.0 * c19 - c20 + c23))
        - ypz * ypz * ypz * (4.0 * (c02 - c04 + c14 - c16) - 2.0 * x * (c14 - c16 - c18 - c22 + c29) + ymz * (2.0 * (c04 - c26) - c14 + c16 - c18 - c22 + c29))
        - ymz * ymz * ymz * (4.0 * (c03 - c05 - c17) + 2.0 * x * (c17 + c19 + c23 - c30) - ypz * (-2.0 * (c05 - c27) + c23 - c17 + c19 - c30))
        + b1 * b1 * b1 * (4.0 * (c01 - c12) + 2.0 * (c06 + c07 - c08 - c09 + c15) + 2.0 * z * (c06 - c07 - c08 + c09 - c15) - xmy * (c06 + c07 - c08 - c09 + c15 - 2.0 * (c12 - c13)))
        + b2 * b2 * b2 * (6.0 * c01 + 2.0 * (c03 + c05 + c12 - c15) + 4.0 * (c06 - c07) - 2.0 * y * (c01 - c03 + c05 - c12 - c15) - xmz * (c01 - c03 - c05 + c12 + c15 + 2.0 * (c06 - c07)))
        + b3 * b3 * b3 * (6.0 * c01 + 2.0 * (c02 + c04 + c12) - 2.0 * y * (c01 - c02 + c04 - c12) - xpz * (c01 - c02 - c04 + c12));

    return (8.0 * s8 + 4.0 * s4 + 2.0 * s2) * (1.0 / 384.0);
}
