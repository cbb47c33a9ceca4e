//! The runtime's parameter blocks as uniform blocks (GPUs) and as
//! read-only storage buffers (CPU adapters, where lavapipe would inline
//! uniform values into a new shader variant per dispatch) draw the same
//! images: isosurface, DVR and out of core.

use boxforge::derive::Derivation;
use boxforge::emit::Layout;
use boxforge_runtime::render::dvr::transfer::TransferFunction;
use boxforge_runtime::render::dvr::DvrOptions;
use boxforge_runtime::render::iso::RenderOptions;
use boxforge_runtime::render::paged::{PagedIsoRenderer, PagedOptions};
use boxforge_runtime::volume::LatticeVolume;

#[test]
fn parameter_blocks_in_storage_or_uniform_buffers_draw_the_same_images() {
    let d = Derivation::new(&boxforge::spec::catalog::get("bcc7").unwrap()).unwrap();
    let vol = LatticeVolume::marschner_lobb(&d.filter.lattice, [20, 20, 20]).unwrap();
    let tf = TransferFunction::preset("marschner-lobb");
    let o = RenderOptions { width: 32, height: 32, frames: 0, ..RenderOptions::default() };
    let dvr = DvrOptions { width: 32, height: 32, frames: 0, ..DvrOptions::default() };
    let images = |storage: bool| {
        let gpu = crate::common::gpu().clone().with_params_in_storage(storage);
        let iso = boxforge_runtime::render::iso::render(&gpu, &d, &vol, Layout::Embedded, &o).unwrap().rgba;
        let volume = boxforge_runtime::render::dvr::render(&gpu, &d, &vol, Layout::Packed, &tf, &dvr).unwrap().rgba;
        let options = PagedOptions { brick: 8, max_pixels: 1024, ..PagedOptions::default() };
        let mut r = PagedIsoRenderer::new(&gpu, &d, &vol, options, &|_, _| {}).unwrap();
        let paged = r.render(&vol, &o).unwrap().0.rgba;
        (iso, volume, paged)
    };
    let (a, b) = (images(true), images(false));
    assert!(a.0 == b.0 && a.1 == b.1 && a.2 == b.2, "the same images whichever address space");
    assert!(a.0.chunks(4).any(|p| p != &a.0[..4]), "something was drawn");
}
