//! boxforge runtime: a headless wgpu device, volumes in, GPU evaluation of
//! the generated shaders checked against the exact evaluator, isosurface
//! images out.

pub mod bench;
pub mod dvr;
pub mod gpu;
pub mod perm;
pub mod pictures;
pub mod prefilter;
pub mod progress;
pub mod pt;
pub mod render;
pub mod request;
pub mod scene;
pub mod schemes;
pub mod transfer;
pub mod upload;
pub mod verify;
pub mod volume;
pub mod web;
