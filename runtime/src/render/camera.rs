//! The camera every renderer shares: an orbit around the volume's valid box
//! (azimuth and elevation in degrees, orthographic or perspective), and the
//! frame a renderer draws into; and the camera part every ray caster's
//! uniform block starts with ([`CameraUniform`]); a host's camera as a
//! view-projection matrix ([`FrameCamera::ViewProj`]) and its depth buffer
//! ([`HostDepth`]), which stops the rays at the host's opaque geometry.

use glam::{Mat4, Vec3, Vec4};

/// Where the eye looks from: an orbit around the centre of the volume's
/// valid box, at a distance that shows the whole box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Degrees around the z axis, from +x toward +y.
    pub azimuth: f32,
    /// Degrees above the xy plane.
    pub elevation: f32,
    /// A 45-degree perspective view instead of a parallel one.
    pub perspective: bool,
}

impl Default for Camera {
    fn default() -> Self {
        Camera { azimuth: 30.0, elevation: 25.0, perspective: false }
    }
}

impl Camera {
    /// The view-projection matrix of this orbit around the valid box [`lo`,
    /// `hi`] for a `width` x `height` target
    /// ([`CameraUniform::view_projection`]): what a host draws its geometry
    /// with to pass its depth to a frame with this camera.
    pub fn view_projection(&self, lo: [f32; 3], hi: [f32; 3], width: u32, height: u32) -> Mat4 {
        CameraUniform::orbit(self, lo, hi, width, height).view_projection(self.perspective)
    }

    /// The camera's forward direction (from the eye toward the volume):
    /// what view-dependent filters follow.
    pub fn view_direction(&self) -> [f64; 3] {
        view_direction(self.azimuth, self.elevation)
    }
}

/// The six vec4 every ray caster's uniform block starts with (`eye`,
/// `forward`, `right`, `up`, `box_lo`, `box_hi` in `templates/raycast.wgsl.j2`,
/// `templates/dvr.wgsl.j2` and `templates/pt.wgsl`): the first field of
/// `iso::RayParams`, `dvr::DvrParams` and `pt::render::PtParams` (the
/// renderers build on this module, not the other way round). Directions
/// and positions have w = 0.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CameraUniform {
    /// Eye position (perspective), or the centre of the image plane (orthographic).
    pub eye: [f32; 4],
    /// View direction, unit length.
    pub forward: [f32; 4],
    /// Half the image's width along the view plane.
    pub right: [f32; 4],
    /// Half the image's height along the view plane.
    pub up: [f32; 4],
    /// Valid box (the filter's support inside the volume): low corner.
    pub box_lo: [f32; 4],
    /// Valid box: high corner.
    pub box_hi: [f32; 4],
}

/// The uniform layout of a direction or position: xyz and a zero w.
fn v4(a: Vec3) -> [f32; 4] {
    a.extend(0.0).to_array()
}

impl CameraUniform {
    /// The camera of a host's view-projection `view_proj` (wgpu's clip
    /// space, depth 0..1, mapping the volume's sample-index coordinates to
    /// clip space), looking at the valid box [`lo`, `hi`], and whether it
    /// is a perspective one: the rays start on the near plane
    /// (orthographic) or at the eye (perspective) and pass through the
    /// pixel centres the host's rasterizer uses, so a ray stops where the
    /// host's depth says. Inverse of [`CameraUniform::view_projection`] up
    /// to rounding.
    pub fn from_view_projection(view_proj: Mat4, lo: [f32; 3], hi: [f32; 3]) -> (CameraUniform, bool) {
        let inv = view_proj.inverse();
        let at = |x: f32, y: f32| inv.project_point3(Vec3::new(x, y, 0.0));
        let (c, px, py) = (at(0.0, 0.0), at(1.0, 0.0), at(0.0, 1.0));
        // The clip w of a perspective projection grows with the distance;
        // an orthographic one's is constant.
        let w = view_proj.row(3);
        let perspective = w.truncate().length() > 1e-6 * view_proj.row(0).truncate().length();
        let (eye, forward, right, up) = if perspective {
            // The eye: the one point with clip x = y = w = 0, the limit of
            // NDC (0, 0, z) for z to infinity.
            let e = inv * Vec4::new(0.0, 0.0, 1.0, 0.0);
            let eye = e.truncate() / e.w;
            let l = (c - eye).length();
            (eye, (c - eye) / l, (px - c) / l, (py - c) / l)
        } else {
            let f = inv.project_point3(Vec3::new(0.0, 0.0, 1.0)) - c;
            (c, f / f.length(), px - c, py - c)
        };
        let uniform = CameraUniform {
            eye: v4(eye),
            forward: v4(forward),
            right: v4(right),
            up: v4(up),
            box_lo: v4(Vec3::from_array(lo)),
            box_hi: v4(Vec3::from_array(hi)),
        };
        (uniform, perspective)
    }

    /// The view-projection matrix (wgpu's clip space: x, y in -1..1 with y
    /// up, depth 0..1) whose pixel centres are this camera's rays: what a
    /// host rasterizes its geometry with so that its depth buffer lines up
    /// with the rays ([`HostDepth`]). Near and far enclose the valid box:
    /// near at the eye plane (orthographic) or half the distance to the
    /// box's nearest corner (perspective), far at twice the farthest corner.
    pub fn view_projection(&self, perspective: bool) -> Mat4 {
        let v = |a: [f32; 4]| Vec3::from_slice(&a[..3]);
        let (eye, forward, right, up) = (v(self.eye), v(self.forward), v(self.right), v(self.up));
        let (lo, hi) = (v(self.box_lo), v(self.box_hi));
        let depths = (0..8).map(|i| {
            let corner = Vec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            );
            (corner - eye).dot(forward)
        });
        let (nearest, farthest) = depths.fold((f32::MAX, f32::MIN), |(a, b), d| (a.min(d), b.max(d)));
        let far = 2.0 * farthest.max(1e-3);
        let near = if perspective { (0.5 * nearest).max(far * 1e-4) } else { 0.0 };
        // Rows of the matrix: x and y along right and up (in units of the
        // half extents), the depth along forward, w = 1 or the depth.
        let row = |a: Vec3, s: f32| (a * s).extend(-(a * s).dot(eye));
        let (rx, ry) = (row(right, 1.0 / right.length_squared()), row(up, 1.0 / up.length_squared()));
        let rows = if perspective {
            let rw = row(forward, 1.0);
            let k = far / (far - near);
            [rx, ry, rw * k - Vec4::W * (k * near), rw]
        } else {
            let rz = row(forward, 1.0 / (far - near)) - Vec4::W * (near / (far - near));
            [rx, ry, rz, Vec4::W]
        };
        Mat4::from_cols(rows[0], rows[1], rows[2], rows[3]).transpose()
    }

    /// `camera`'s orbit around the valid box [`lo`, `hi`] for an image of
    /// `width` x `height` pixels: the eye at 2 (orthographic, half-height
    /// 1.05) or 2.6 (45-degree perspective) times the box's half-diagonal
    /// from its centre.
    pub fn orbit(camera: &Camera, lo: [f32; 3], hi: [f32; 3], width: u32, height: u32) -> CameraUniform {
        let (lo, hi) = (Vec3::from_array(lo), Vec3::from_array(hi));
        let center = (lo + hi) * 0.5;
        let radius = 0.5 * (hi - lo).length();
        let forward = Vec3::from_array(camera.view_direction().map(|x| x as f32));
        let world_up = if camera.elevation.to_radians().cos().abs() < 1e-3 { Vec3::Y } else { Vec3::Z };
        // Divide by the (guarded) length rather than glam's normalize, which
        // multiplies by its reciprocal and rounds differently.
        let right = {
            let c = forward.cross(world_up);
            c / c.length().max(1e-20)
        };
        let up = right.cross(forward);
        let aspect = width as f32 / height as f32;
        let (eye, half) = if camera.perspective {
            let dist = radius * 2.6;
            (center - forward * dist, (22.5f32).to_radians().tan())
        } else {
            (center - forward * (radius * 2.0), radius * 1.05)
        };
        CameraUniform {
            eye: v4(eye),
            forward: v4(forward),
            right: v4(right * (half * aspect)),
            up: v4(up * half),
            box_lo: v4(lo),
            box_hi: v4(hi),
        }
    }
}

/// The texture view a renderer draws a frame into, as a host hands it over
/// (a window surface's view, or any texture with `RENDER_ATTACHMENT` usage):
/// the renderer uses it as a colour attachment and nothing else.
#[derive(Clone, Copy, Debug)]
pub struct Target<'a> {
    pub view: &'a wgpu::TextureView,
    /// The view's format; sRGB formats get the image's sRGB bytes unchanged.
    pub format: wgpu::TextureFormat,
    pub width: u32,
    pub height: u32,
}

/// Where a frame's rays come from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FrameCamera {
    /// An orbit around the volume ([`Camera`]); a host depth is converted
    /// with [`Camera::view_projection`].
    Orbit(Camera),
    /// A host's camera: its projection x view (x the volume's model matrix,
    /// if it places the volume in its world), mapping the volume's
    /// sample-index coordinates (sample (i, j, k) at (i, j, k)) to wgpu's
    /// clip space (depth 0..1). The rays are this camera's
    /// ([`CameraUniform::from_view_projection`]) and a host depth is
    /// unprojected with the same matrix: one matrix for both, so the rays
    /// and the depth cannot disagree.
    ViewProj(Mat4),
}

impl From<Camera> for FrameCamera {
    fn from(camera: Camera) -> FrameCamera {
        FrameCamera::Orbit(camera)
    }
}

impl FrameCamera {
    /// The camera uniform around the valid box [`lo`, `hi`] for a `width` x
    /// `height` target, whether it is a perspective camera, and the
    /// view-projection a host depth is unprojected with.
    pub fn resolve(&self, lo: [f32; 3], hi: [f32; 3], width: u32, height: u32) -> (CameraUniform, bool, Mat4) {
        match *self {
            FrameCamera::Orbit(c) => {
                let u = CameraUniform::orbit(&c, lo, hi, width, height);
                (u, c.perspective, u.view_projection(c.perspective))
            }
            FrameCamera::ViewProj(m) => {
                let (u, perspective) = CameraUniform::from_view_projection(m, lo, hi);
                (u, perspective, m)
            }
        }
    }
}

/// A host's depth buffer for one frame: the rays stop at its opaque
/// geometry (the isosurface caster reports no hit behind it, DVR
/// composites up to it, the last segment weighted by the fraction in
/// front), and the frame is composited over the target's contents (the
/// host's colour, drawn with that depth) with premultiplied alpha instead of
/// being drawn opaque over the background. The depth is unprojected with the
/// frame's view-projection ([`FrameCamera`]), so the host must have drawn
/// it with that same matrix.
///
/// Accepted: `Depth32Float` (the common case), `Depth24Plus` or
/// `Depth16Unorm` textures with `TEXTURE_BINDING` usage, one sample, the
/// target's size; the view must be of the whole depth aspect at mip level 0.
/// Depth 1.0 (the cleared far plane) means nothing is there. Formats with a
/// stencil aspect and anything else give [`crate::render::RenderError::HostDepthFormat`]
/// (usage and size: `HostDepthUsage`, `HostDepthSize`).
#[derive(Clone, Copy, Debug)]
pub struct HostDepth<'a> {
    pub view: &'a wgpu::TextureView,
}

impl HostDepth<'_> {
    /// Checks the texture against the rules above for a `width` x `height` target.
    pub fn check(&self, width: u32, height: u32) -> Result<(), crate::render::RenderError> {
        use crate::render::RenderError;
        let t = self.view.texture();
        if !HOST_DEPTH_FORMATS.contains(&t.format()) {
            return Err(RenderError::HostDepthFormat { format: t.format() });
        }
        if !t.usage().contains(wgpu::TextureUsages::TEXTURE_BINDING) {
            return Err(RenderError::HostDepthUsage { usage: t.usage() });
        }
        if (t.width(), t.height(), t.sample_count()) != (width, height, 1) {
            return Err(RenderError::HostDepthSize {
                depth: [t.width(), t.height()],
                samples: t.sample_count(),
                target: [width, height],
            });
        }
        Ok(())
    }
}

/// The depth formats [`HostDepth`] accepts.
pub const HOST_DEPTH_FORMATS: [wgpu::TextureFormat; 3] =
    [wgpu::TextureFormat::Depth32Float, wgpu::TextureFormat::Depth24Plus, wgpu::TextureFormat::Depth16Unorm];

/// The camera's forward direction (from the eye toward the volume) for an
/// azimuth and elevation in degrees: what view-dependent filters follow.
pub fn view_direction(azimuth: f32, elevation: f32) -> [f64; 3] {
    let (az, el) = (azimuth.to_radians(), elevation.to_radians());
    let toward_eye = Vec3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
    (-toward_eye).to_array().map(f64::from)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_view_projection_maps_the_rays_to_pixels_and_gives_back_its_camera() {
        let (lo, hi) = ([2.0, 2.0, 2.0], [20.0, 23.0, 21.0]);
        for perspective in [false, true] {
            let camera = Camera { azimuth: 40.0, elevation: -20.0, perspective };
            let u = CameraUniform::orbit(&camera, lo, hi, 96, 64);
            let vp = u.view_projection(perspective);
            let v = |a: [f32; 4]| Vec3::from_slice(&a[..3]);
            // Points along the ray of NDC (sx, sy) project to (sx, sy), at
            // depths in 0..1 inside the box.
            for (sx, sy) in [(0.0, 0.0), (1.0, 1.0), (-0.5, 0.25)] {
                for t in [5.0, 20.0, 40.0] {
                    let p = if perspective {
                        v(u.eye) + t * (v(u.forward) + sx * v(u.right) + sy * v(u.up)).normalize()
                    } else {
                        v(u.eye) + sx * v(u.right) + sy * v(u.up) + t * v(u.forward)
                    };
                    let ndc = vp.project_point3(p);
                    assert!((ndc.x - sx).abs() < 1e-5 && (ndc.y - sy).abs() < 1e-5, "{perspective}: {ndc}");
                }
            }
            for i in 0..8 {
                let corner = Vec3::new(
                    if i & 1 == 0 { lo[0] } else { hi[0] },
                    if i & 2 == 0 { lo[1] } else { hi[1] },
                    if i & 4 == 0 { lo[2] } else { hi[2] },
                );
                let z = vp.project_point3(corner).z;
                assert!(z > 0.0 && z < 1.0, "{perspective}: corner {i} at depth {z}");
            }
            let (back, p) = CameraUniform::from_view_projection(vp, lo, hi);
            assert_eq!(p, perspective);
            for (a, b) in [(u.eye, back.eye), (u.forward, back.forward), (u.right, back.right), (u.up, back.up)] {
                assert!((v(a) - v(b)).length() <= 1e-4 * v(a).length().max(1.0), "{perspective}: {a:?} vs {b:?}");
            }
        }
    }
}
