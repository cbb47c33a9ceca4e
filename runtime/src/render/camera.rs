//! The camera every renderer shares: an orbit around the volume's valid box
//! (azimuth and elevation in degrees, orthographic or perspective), and the
//! frame a renderer draws into.

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
        crate::render::iso::view_direction(self.azimuth, self.elevation)
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
