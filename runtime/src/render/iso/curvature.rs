//! Curvature shading of isosurfaces (`render --shade curvature|mean|gaussian|ridges|contours`),
//! after Kindlmann et al. 2003, "Curvature-Based Transfer Functions for
//! Direct Volume Rendering": from the gradient g and Hessian H of the spline
//! (`<f>_eval_hessian`), with n = -g/|g| and P = I - n n^T the tangent-plane
//! projection, G = -P H P / |g|; its two non-zero eigenvalues are the
//! principal curvatures k1 >= k2, from T = trace G and F = |G|_F:
//! k = (T +- sqrt(2 F^2 - T^2)) / 2. Positive curvature is convex as seen
//! from the lower-valued side (a bright blob is a positive sphere).
//!
//! The same arithmetic is written twice: as WGSL for the ray caster
//! ([`Shade::wgsl`]) and in f64 for the CPU reference ([`Shade::color`]), so
//! tests compare the device's image with the exact evaluator's.

use glam::{DMat3, DVec3};

/// How a hit is coloured.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ShadeMode {
    /// Blinn-Phong from the gradient (the default).
    #[default]
    Phong,
    /// A 2D colormap over (k1, k2): convex red, concave blue, saddle green, flat grey.
    Curvature,
    /// Mean curvature (k1 + k2) / 2: red positive, blue negative.
    Mean,
    /// Gaussian curvature k1 k2: orange elliptic, teal hyperbolic.
    Gaussian,
    /// Ridges (k1 large, yellow) and valleys (k2 very negative, dark blue) over Phong.
    Ridges,
    /// Kindlmann's view-dependent contours: dark where |n . v| <=
    /// sqrt(T k_v (2 - T k_v)), k_v the normal curvature along the view.
    Contours,
}

impl ShadeMode {
    /// Every mode, in the order the CLI lists them.
    pub const ALL: [ShadeMode; 6] = [
        ShadeMode::Phong,
        ShadeMode::Curvature,
        ShadeMode::Mean,
        ShadeMode::Gaussian,
        ShadeMode::Ridges,
        ShadeMode::Contours,
    ];

    /// The name used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            ShadeMode::Phong => "phong",
            ShadeMode::Curvature => "curvature",
            ShadeMode::Mean => "mean",
            ShadeMode::Gaussian => "gaussian",
            ShadeMode::Ridges => "ridges",
            ShadeMode::Contours => "contours",
        }
    }

    /// The mode named `s`.
    pub fn parse(s: &str) -> Option<ShadeMode> {
        Self::ALL.into_iter().find(|m| m.name() == s)
    }

    /// Whether the mode needs second derivatives (`<f>_eval_hessian`).
    pub fn needs_hessian(self) -> bool {
        self != ShadeMode::Phong
    }

    fn index(self) -> i32 {
        Self::ALL.iter().position(|m| *m == self).expect("ALL lists every mode") as i32
    }
}

/// The shading of an isosurface renderer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shade {
    pub mode: ShadeMode,
    /// Radius of curvature (cells) at which the colormaps saturate: |k| R = 1.
    pub radius: f32,
    /// Contour thickness T (cells) of [`ShadeMode::Contours`].
    pub thickness: f32,
}

impl Default for Shade {
    fn default() -> Self {
        Shade { mode: ShadeMode::Phong, radius: 4.0, thickness: 1.0 }
    }
}

/// Principal curvatures (k1 >= k2) from a gradient and Hessian, f64.
pub fn principal_curvatures(g: DVec3, h: DMat3) -> (f64, f64) {
    let (k1, k2, _) = curvature_frame(g, h);
    (k1, k2)
}

/// (k1, k2, G) as [`Shade::wgsl`] computes them.
fn curvature_frame(g: DVec3, h: DMat3) -> (f64, f64, DMat3) {
    let glen = g.length().max(1e-20);
    let n = -g / glen;
    let p = DMat3::IDENTITY - DMat3::from_cols(n * n.x, n * n.y, n * n.z);
    let gm = -(p * h * p) * (1.0 / glen);
    let t = gm.x_axis.x + gm.y_axis.y + gm.z_axis.z;
    let f2 = gm.x_axis.length_squared() + gm.y_axis.length_squared() + gm.z_axis.length_squared();
    let disc = (2.0 * f2 - t * t).max(0.0).sqrt();
    (0.5 * (t + disc), 0.5 * (t - disc), gm)
}

/// The 2D (k1, k2) colormap at a = k1 R, b = k2 R (both in [-1, 1]): grey
/// flat, red convex (both positive), blue concave (both negative), green
/// saddle.
fn k1k2_color(a: f64, b: f64) -> DVec3 {
    let convex = b.max(0.0);
    let concave = (-a).max(0.0);
    let saddle = a.max(0.0).min((-b).max(0.0));
    DVec3::splat(0.85)
        + convex * DVec3::new(0.15, -0.55, -0.55)
        + concave * DVec3::new(-0.55, -0.45, 0.15)
        + saddle * DVec3::new(-0.45, 0.1, -0.45)
}

fn smoothstep(a: f64, b: f64, x: f64) -> f64 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

fn diverging(x: f64, pos: DVec3, neg: DVec3) -> DVec3 {
    let white = DVec3::splat(0.9);
    if x >= 0.0 {
        white + (pos - white) * x
    } else {
        white + (neg - white) * (-x)
    }
}

impl Shade {
    /// The colour of a hit with gradient `g` and Hessian `h`, the ray along
    /// `dir` (unit) and the camera's `up` (the light), in f64.
    pub fn color(&self, g: DVec3, h: DMat3, dir: DVec3, up: DVec3) -> DVec3 {
        let glen = g.length().max(1e-20);
        let mut ns = g / glen;
        if ns.dot(dir) > 0.0 {
            ns = -ns;
        }
        let l = {
            let v = -dir + 0.35 * up / up.length().max(1e-20);
            v / v.length()
        };
        let light = 0.25 + 0.75 * ns.dot(l).max(0.0);
        let (k1, k2, gm) = curvature_frame(g, h);
        let r = self.radius as f64;
        let a = (k1 * r).clamp(-1.0, 1.0);
        let b = (k2 * r).clamp(-1.0, 1.0);
        let phong = DVec3::new(0.85, 0.72, 0.55);
        match self.mode {
            ShadeMode::Phong | ShadeMode::Curvature => k1k2_color(a, b) * light,
            ShadeMode::Mean => {
                let m = (0.5 * (k1 + k2) * r).clamp(-1.0, 1.0);
                diverging(m, DVec3::new(0.85, 0.2, 0.15), DVec3::new(0.15, 0.3, 0.85)) * light
            }
            ShadeMode::Gaussian => {
                let k = (k1 * k2 * r * r).clamp(-1.0, 1.0);
                diverging(k, DVec3::new(0.9, 0.55, 0.1), DVec3::new(0.1, 0.6, 0.6)) * light
            }
            ShadeMode::Ridges => {
                let ridge = smoothstep(0.3, 0.8, a);
                let valley = smoothstep(0.3, 0.8, -b);
                let c = phong * light;
                let c = c + (DVec3::new(1.0, 0.95, 0.3) - c) * ridge;
                c + (DVec3::new(0.1, 0.1, 0.35) - c) * valley
            }
            ShadeMode::Contours => {
                let n = -g / glen;
                let p = DMat3::IDENTITY - DMat3::from_cols(n * n.x, n * n.y, n * n.z);
                let kv = dir.dot(gm * dir) / dir.dot(p * dir).max(1e-20);
                let tk = self.thickness as f64 * kv;
                let lim = (tk * (2.0 - tk)).max(0.0).sqrt().max(1e-6);
                let line = 1.0 - smoothstep(0.7 * lim, lim, n.dot(dir).abs());
                phong * light * (1.0 - line)
            }
        }
    }

    /// `fn <name>_curvature_shade(ph, dir) -> vec3<f32>`: [`Shade::color`]
    /// in WGSL at the hit ph, from `<name>_eval_hessian` (the light from
    /// the ray caster's uniform `<name>_rc.up`).
    pub fn wgsl(&self, name: &str) -> String {
        format!(
            r#"
// Curvature shading (Kindlmann et al. 2003), mode {mode_name}: k1, k2 from G = -P H P / |g|.
const {name}_SHADE_MODE: i32 = {mode};
const {name}_SHADE_RADIUS: f32 = {radius:?};
const {name}_SHADE_THICKNESS: f32 = {thickness:?};

{core}
fn {name}_shade_smooth(a: f32, b: f32, x: f32) -> f32 {{
    let t = clamp((x - a) / (b - a), 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}}

fn {name}_shade_diverging(x: f32, pos: vec3<f32>, neg: vec3<f32>) -> vec3<f32> {{
    let white = vec3<f32>(0.9);
    return select(white + (neg - white) * (-x), white + (pos - white) * x, x >= 0.0);
}}

fn {name}_curvature_shade(ph: vec3<f32>, dir: vec3<f32>) -> vec3<f32> {{
    let r = {name}_eval_hessian(ph);
    let g = r.gradient;
    let glen = max(length(g), 1e-20);
    var ns = g / glen;
    if (dot(ns, dir) > 0.0) {{
        ns = -ns;
    }}
    let up = {name}_rc.up.xyz;
    let l = normalize(-dir + 0.35 * up / max(length(up), 1e-20));
    let light = 0.25 + 0.75 * max(dot(ns, l), 0.0);
    let n = -g / glen;
    let p = {name}_tangent_projection(n);
    let gm = {name}_curvature_matrix(g, r.hessian);
    let k = {name}_principal_curvatures(gm);
    let k1 = k.x;
    let k2 = k.y;
    let rad = {name}_SHADE_RADIUS;
    let a = clamp(k1 * rad, -1.0, 1.0);
    let b = clamp(k2 * rad, -1.0, 1.0);
    let phong = vec3<f32>(0.85, 0.72, 0.55);
    switch {name}_SHADE_MODE {{
        case 2: {{
            let m = clamp(0.5 * (k1 + k2) * rad, -1.0, 1.0);
            return {name}_shade_diverging(m, vec3<f32>(0.85, 0.2, 0.15), vec3<f32>(0.15, 0.3, 0.85)) * light;
        }}
        case 3: {{
            let k = clamp(k1 * k2 * rad * rad, -1.0, 1.0);
            return {name}_shade_diverging(k, vec3<f32>(0.9, 0.55, 0.1), vec3<f32>(0.1, 0.6, 0.6)) * light;
        }}
        case 4: {{
            let ridge = {name}_shade_smooth(0.3, 0.8, a);
            let valley = {name}_shade_smooth(0.3, 0.8, -b);
            var c = phong * light;
            c = c + (vec3<f32>(1.0, 0.95, 0.3) - c) * ridge;
            return c + (vec3<f32>(0.1, 0.1, 0.35) - c) * valley;
        }}
        case 5: {{
            let kv = dot(dir, gm * dir) / max(dot(dir, p * dir), 1e-20);
            let tk = {name}_SHADE_THICKNESS * kv;
            let lim = max(sqrt(max(tk * (2.0 - tk), 0.0)), 1e-6);
            let line = 1.0 - {name}_shade_smooth(0.7 * lim, lim, abs(dot(n, dir)));
            return phong * light * (1.0 - line);
        }}
        default: {{
            return {name}_k1k2_color(a, b) * light;
        }}
    }}
}}
"#,
            core = core_wgsl(name),
            mode_name = self.mode.name(),
            mode = self.mode.index(),
            radius = self.radius,
            thickness = self.thickness,
        )
    }
}

/// The curvature transfer function of DVR (`render --mode dvr
/// --tf-curvature`): a 2D transfer function over (k1, k2) of the isosurface
/// through each sample, Kindlmann et al.'s curvature axis. The colour is the
/// (k1, k2) colormap of [`ShadeMode::Curvature`] (convex red, concave blue,
/// saddle green, flat grey), the value transfer function's opacity is
/// scaled by 0.25 + 0.75 min(max(|k1|, |k2|) R, 1): curved features stay,
/// flat sheets fade. Returns (colour, opacity factor).
pub fn curvature_tf(g: DVec3, h: DMat3, radius: f64) -> (DVec3, f64) {
    let (k1, k2, _) = curvature_frame(g, h);
    let a = (k1 * radius).clamp(-1.0, 1.0);
    let b = (k2 * radius).clamp(-1.0, 1.0);
    (k1k2_color(a, b), 0.25 + 0.75 * a.abs().max(b.abs()))
}

/// `fn <name>_curvature_tf(g, h) -> vec4<f32>`: [`curvature_tf`] in WGSL
/// (xyz the colour, w the opacity factor).
pub fn curvature_tf_wgsl(name: &str, radius: f32) -> String {
    format!(
        r#"
// The curvature transfer function over (k1, k2) (Kindlmann et al. 2003), R = {radius:?} cells.
{core}
fn {name}_curvature_tf(g: vec3<f32>, h: mat3x3<f32>) -> vec4<f32> {{
    let k = clamp({name}_principal_curvatures({name}_curvature_matrix(g, h)) * {radius:?}, vec2<f32>(-1.0), vec2<f32>(1.0));
    return vec4<f32>({name}_k1k2_color(k.x, k.y), 0.25 + 0.75 * max(abs(k.x), abs(k.y)));
}}
"#,
        core = core_wgsl(name)
    )
}

/// The WGSL both curvature shaders share ([`curvature_frame`] and
/// [`k1k2_color`] in f32): the tangent-plane projection, G = -P H P / |g|,
/// its principal curvatures and the (k1, k2) colormap.
fn core_wgsl(name: &str) -> String {
    format!(
        r#"
fn {name}_tangent_projection(n: vec3<f32>) -> mat3x3<f32> {{
    return mat3x3<f32>(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0))
        - mat3x3<f32>(n * n.x, n * n.y, n * n.z);
}}

fn {name}_curvature_matrix(g: vec3<f32>, h: mat3x3<f32>) -> mat3x3<f32> {{
    let glen = max(length(g), 1e-20);
    let p = {name}_tangent_projection(-g / glen);
    return (p * h * p) * (-1.0 / glen);
}}

fn {name}_principal_curvatures(gm: mat3x3<f32>) -> vec2<f32> {{
    let t = gm[0][0] + gm[1][1] + gm[2][2];
    let f2 = dot(gm[0], gm[0]) + dot(gm[1], gm[1]) + dot(gm[2], gm[2]);
    let disc = sqrt(max(2.0 * f2 - t * t, 0.0));
    return vec2<f32>(0.5 * (t + disc), 0.5 * (t - disc));
}}

fn {name}_k1k2_color(a: f32, b: f32) -> vec3<f32> {{
    let convex = max(b, 0.0);
    let concave = max(-a, 0.0);
    let saddle = min(max(a, 0.0), max(-b, 0.0));
    return vec3<f32>(0.85) + convex * vec3<f32>(0.15, -0.55, -0.55)
        + concave * vec3<f32>(-0.55, -0.45, 0.15) + saddle * vec3<f32>(-0.45, 0.1, -0.45);
}}
"#
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ball of radius rho in f = -|x| (bright inside): k1 = k2 = 1/rho;
    /// a cylinder of radius rho along z, f = -sqrt(x^2 + y^2): k1 = 1/rho, k2 = 0;
    /// the saddle f = z - x^2 + y^2 at 0: k = +-2.
    #[test]
    fn principal_curvatures_of_known_surfaces() {
        let x = DVec3::new(1.0, 2.0, 2.0);
        let rho = x.length();
        let g = -x / rho;
        let h = -(DMat3::IDENTITY - DMat3::from_cols(x * x.x, x * x.y, x * x.z) / (rho * rho)) / rho;
        let (k1, k2) = principal_curvatures(g, h);
        assert!((k1 - 1.0 / rho).abs() < 1e-12 && (k2 - 1.0 / rho).abs() < 1e-12, "{k1} {k2}");
        let (x, y) = (3.0f64, 4.0f64);
        let r = (x * x + y * y).sqrt();
        let g = DVec3::new(-x / r, -y / r, 0.0);
        let u = DVec3::new(-y / r, x / r, 0.0);
        let h = -DMat3::from_cols(u * u.x, u * u.y, u * u.z) / r;
        let (k1, k2) = principal_curvatures(g, h);
        assert!((k1 - 1.0 / r).abs() < 1e-12 && k2.abs() < 1e-12, "{k1} {k2}");
        // f = z - x^2 + y^2: g = e_z, H = diag(-2, 2, 0); n = -e_z.
        let (k1, k2) = principal_curvatures(DVec3::Z, DMat3::from_diagonal(DVec3::new(-2.0, 2.0, 0.0)));
        assert!((k1 - 2.0).abs() < 1e-12 && (k2 + 2.0).abs() < 1e-12, "{k1} {k2}");
    }

    #[test]
    fn the_wgsl_of_every_mode_validates() {
        for mode in ShadeMode::ALL {
            let s = Shade { mode, ..Shade::default() };
            let src = format!(
                "struct f_Hessian {{ value: f32, gradient: vec3<f32>, hessian: mat3x3<f32> }}\n\
                 struct f_Rc {{ up: vec4<f32> }}\n\
                 var<private> f_rc: f_Rc;\n\
                 fn f_eval_hessian(p: vec3<f32>) -> f_Hessian {{ return f_Hessian(p.x, p, mat3x3<f32>(p, p, p)); }}\n{}",
                s.wgsl("f")
            );
            let r = boxforge::validate::validate_wgsl(&src, "curvature");
            assert!(r.valid, "{mode:?}: {:?}", r.error);
        }
        let tf = format!(
            "fn f_shade(g: vec3<f32>, h: mat3x3<f32>) -> vec4<f32> {{ return f_curvature_tf(g, h); }}\n{}",
            curvature_tf_wgsl("f", 3.0)
        );
        let r = boxforge::validate::validate_wgsl(&tf, "curvature tf");
        assert!(r.valid, "tf: {:?}", r.error);
        assert_eq!(ShadeMode::parse("ridges"), Some(ShadeMode::Ridges));
        assert_eq!(ShadeMode::parse("nope"), None);
    }
}
