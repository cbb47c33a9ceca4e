//! The renderers, one folder each over a shared core: [`iso`] (isosurfaces
//! by fixed steps or exact hits), [`dvr`] (direct volume rendering with
//! pre-integrated transfer functions), [`perm`] (Lim and Shin's cache on
//! top of DVR), [`pt`] (projected tetrahedra) and [`schemes`] (the
//! literature's hand-written BCC schemes, ray cast through DVR).

pub mod blocks;
pub mod camera;
pub mod dvr;
mod error;
pub mod four;
mod host;
pub mod iso;
pub mod paged;
pub mod perm;
pub mod present;
pub mod pt;
#[cfg(feature = "references")]
pub mod schemes;
mod templates;

pub use camera::{Camera, FrameCamera, HostDepth, Target, HOST_DEPTH_FORMATS};
pub use dvr::{DvrLook, DvrRenderer};
pub use error::{Mismatch, RenderError};
pub use iso::renderer::{IsoOptions, IsoRenderer};
