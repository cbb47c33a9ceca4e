//! The camera every renderer shares: an orbit around the volume's valid box
//! (azimuth and elevation in degrees, orthographic or perspective), and the
//! frame a renderer draws into; and the camera part every ray caster's
//! uniform block starts with ([`CameraUniform`]).

use glam::Vec3;

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

/// The camera's forward direction (from the eye toward the volume) for an
/// azimuth and elevation in degrees: what view-dependent filters follow.
pub fn view_direction(azimuth: f32, elevation: f32) -> [f64; 3] {
    let (az, el) = (azimuth.to_radians(), elevation.to_radians());
    let toward_eye = Vec3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
    (-toward_eye).to_array().map(f64::from)
}
