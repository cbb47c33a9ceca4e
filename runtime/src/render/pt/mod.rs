//! Projected tetrahedra (Mattausch et al. 2003, §4; Shirley & Tuchman 1990):
//! the tetrahedral meshes and their back-to-front orders ([`tets`]) and the
//! render-pipeline shader (`templates/pt.wgsl`: vertex-shader classification
//! of the projected profile, fragment-shader pre-integrated compositing).
//! The host side ([`render`]: per-cell visibility masks, the back-to-front
//! order, one instanced draw) backs `render --renderer pt`.

pub mod data;
pub mod render;
pub mod renderer;
pub mod tets;

pub use renderer::{PtOptions, PtRenderer};

/// The WGSL of the projected-tetrahedra render pipeline.
pub const SHADER: &str = crate::render::templates::PT;

#[cfg(test)]
mod tests {
    use super::tets::{circumcentre, Grid};

    #[test]
    fn the_shader_validates() {
        let r = boxforge::validate::validate_wgsl(super::SHADER, "pt.wgsl");
        assert!(r.error.is_none(), "{:?}", r.error);
        assert!(r.functions.iter().any(|f| f.name == "pt_vs") && r.functions.iter().any(|f| f.name == "pt_fs"));
    }

    #[test]
    fn each_mesh_names_a_linear_spline_on_its_lattice() {
        for grid in [Grid::Bcc, Grid::Cc] {
            let f = grid.linear_filter();
            assert_eq!(Grid::of(&f.lattice), Some(grid));
            let d = boxforge::derive::Derivation::new(&f).unwrap();
            assert_eq!(d.facts.degree, 1, "{grid:?}: piecewise linear, as barycentric interpolation is");
        }
    }

    #[test]
    fn circumcentres_are_equidistant_from_the_four_vertices() {
        for grid in [Grid::Bcc, Grid::Cc] {
            for t in grid.types() {
                let c = circumcentre(&t);
                let d: Vec<f64> = t.iter().map(|v| (0..3).map(|i| (v[i] as f64 - c[i]).powi(2)).sum::<f64>()).collect();
                assert!(d.iter().all(|x| (x - d[0]).abs() < 1e-12), "{grid:?} {t:?} {d:?}");
            }
        }
    }
}
