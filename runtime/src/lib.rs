//! boxforge runtime: the generated shaders driven on a wgpu device, in a
//! host program's device or a headless one (lavapipe without a GPU).
//!
//! * [`gpu`]: the device context ([`gpu::Gpu`], opened here or handed in by
//!   a host), shader compilation with errors caught, binding helpers, timing.
//! * [`volume`]: volumes on the host (files, synthetic signals, lattice
//!   conversion) and on the device ([`volume::DeviceVolume`]).
//! * [`render`]: the renderers over one shared core (camera, block grid):
//!   isosurfaces (fixed steps or exact hits), direct volume rendering, the
//!   PERM cache, projected tetrahedra and the literature's hand-written schemes.
//! * [`verify`], [`prefilter`]: point evaluation against the exact evaluator,
//!   and the quasi-interpolation prefilter on the device.
//! * [`targets`]: the other shading languages' translations run as emitted
//!   (SPIR-V, GLSL, HLSL on the device by passthrough; GLSL on an OpenGL driver).
//! * [`bench`](mod@bench), `pictures`, `web` (features): what the `boxforge` CLI measures,
//!   draws and serves.

#[cfg(feature = "bench")]
pub mod bench;
pub mod gpu;
pub mod limits;
pub mod memory;
pub mod par;
#[cfg(feature = "pictures")]
pub mod pictures;
pub mod prefilter;
pub mod progress;
#[cfg(feature = "references")]
pub mod references;
pub mod render;
pub mod scene;
#[cfg(feature = "targets")]
pub mod targets;
pub mod verify;
pub mod volume;
#[cfg(feature = "web")]
pub mod web;
