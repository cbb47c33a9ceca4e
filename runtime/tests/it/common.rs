//! What the tests share: one device for the whole binary.

use boxforge_runtime::gpu::Gpu;
use std::sync::OnceLock;

/// The device every GPU test runs on (lavapipe without a GPU), opened once:
/// opening a Vulkan device costs about a second, and tests run in parallel
/// threads on the one device as a host program's renderers would.
pub fn gpu() -> &'static Gpu {
    static GPU: OnceLock<Gpu> = OnceLock::new();
    GPU.get_or_init(|| Gpu::new(None).unwrap_or_else(|e| panic!("{e}")))
}
