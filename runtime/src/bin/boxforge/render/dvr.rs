//! `boxforge render --mode dvr`: one frame by the renderer the flags chose.

use boxforge::derive::Derivation;
use boxforge::emit::Layout;
use boxforge_runtime::gpu::Gpu;
use boxforge_runtime::render::dvr::transfer::TransferFunction;
use boxforge_runtime::render::dvr::DvrOptions;
use boxforge_runtime::render::iso::Frame;
use boxforge_runtime::render::perm::Quant;
use boxforge_runtime::render::pt::render::{Normals, Shading};
use boxforge_runtime::render::schemes::Scheme;
use boxforge_runtime::volume::LatticeVolume;

/// `--shading`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ShadingArg {
    Gouraud,
    Phong,
}

impl From<ShadingArg> for Shading {
    fn from(s: ShadingArg) -> Shading {
        match s {
            ShadingArg::Gouraud => Shading::Gouraud,
            ShadingArg::Phong => Shading::Phong,
        }
    }
}

/// Which renderer draws the frame.
#[derive(Clone, Copy, Debug)]
pub enum How {
    /// A hand-written plane-stack scheme (`--filter mattausch_bilinear...`).
    Scheme(Scheme),
    /// Projected tetrahedra (`--renderer pt`).
    Pt(Shading),
    /// The ray caster with the PERM cache (`--cache perm`), peeled or not (`--peel`).
    Perm(Quant, bool),
    /// The ray caster evaluating the filter directly.
    RayCast,
}

/// Renders one frame, with what each renderer reports on stderr.
pub fn frame(
    gpu: &Gpu,
    d: &Derivation,
    vol: &LatticeVolume,
    layout: Layout,
    tf: &TransferFunction,
    o: &DvrOptions,
    how: How,
) -> Result<Frame, String> {
    let text = |e: boxforge_runtime::render::RenderError| e.to_string();
    match how {
        How::Scheme(s) => boxforge_runtime::render::schemes::render(gpu, vol, s, tf, o)
            .map(|(f, choice)| {
                eprintln!("{choice}");
                f
            })
            .map_err(text),
        How::Pt(shading) => {
            if d.facts.degree != 1 {
                eprintln!("note: projected tetrahedra interpolate linearly on the tetrahedra; --filter {} sets only the lattice and the clipped box", d.filter.name);
            }
            boxforge_runtime::render::pt::render::render(gpu, d, vol, tf, o, shading, Normals::Vertex)
                .map(|(f, st)| {
                    eprintln!(
                        "projected tetrahedra: {} of {} tetrahedra visible, ordered in {:.0} ms",
                        st.drawn, st.total, st.order_ms
                    );
                    f
                })
                .map_err(text)
        }
        How::Perm(q, peel) => boxforge_runtime::render::perm::render(gpu, d, vol, layout, tf, o, q, peel)
            .map(|(f, c)| {
                if peel {
                    eprintln!("opaque-boundary peeling: {} candidate cells no ray reaches dropped", c.peeled);
                }
                let n = c.counts;
                eprintln!(
                    "PERM N={} M={}: {} of {} cells cached ({} visible), {:.0} ms preprocessing, {}",
                    q.density,
                    q.gradient,
                    n.candidates,
                    n.cells,
                    c.visible.iter().filter(|&&v| v).count(),
                    c.preprocess_ms,
                    c.memory.describe()
                );
                f
            })
            .map_err(|e| crate::request::perm_failure(&e)),
        How::RayCast => boxforge_runtime::render::dvr::render(gpu, d, vol, layout, tf, o).map_err(text),
    }
}
