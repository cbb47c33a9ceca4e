//! The numbers the literature states (docs/BOX_SPLINES.md §2) come out of the
//! derivation from the direction matrix alone. These are checks, never inputs.

use boxforge_tests::derive;

#[test]
fn bcc7_kim_2013() {
    let d = derive("bcc7");
    assert_eq!(d.arrangement.families.len(), 9, "knot-plane directions");
    assert_eq!(d.facts.support_volume, 120);
    assert_eq!(d.max_stencil(), 30);
    assert_eq!(d.references.len(), 1, "all pieces congruent under the symmetries");
    assert_eq!(d.arrangement.pieces_per_fundamental_domain, 24);
    assert_eq!(d.facts.degree, 4);
}

#[test]
fn bcc8_entezari() {
    let d = derive("bcc8");
    assert_eq!(d.facts.support_volume, 128);
    assert_eq!(d.max_stencil(), 32);
    assert_eq!(d.arrangement.pieces_per_fundamental_domain, 6);
    assert_eq!(d.facts.degree, 5);
}

#[test]
fn bcc12_csebfalvi_hadwiger() {
    let d = derive("bcc12");
    assert_eq!(d.facts.support_volume, 512);
    assert_eq!(d.max_stencil(), 128);
}

#[test]
fn fcc6_kim_entezari_peters() {
    let d = derive("fcc6");
    assert_eq!(d.arrangement.families.len(), 7, "knot-plane directions");
    // Each unit cube splits into 5 tetrahedra: 4 corner ones and 1 central one.
    for ci in 0..d.arrangement.classes.len() {
        let cells: Vec<_> = d.arrangement.cells.iter().filter(|c| c.class == ci).collect();
        assert_eq!(cells.len(), 5);
        assert!(cells.iter().all(|c| c.polytope.is_simplex()));
        let cube_corners = cells.iter().filter(|c| {
            // A corner tetrahedron has 3 of its 4 vertices at cube corners plus
            // one more cube corner: all 4 are cube corners, and one of them
            // has 3 cube edges in the cell. The central one has no such vertex.
            c.polytope.vertices.iter().all(|v| v.iter().all(|x| x.is_integer()))
        });
        assert_eq!(cube_corners.count(), 5, "all vertices are cube corners");
        let volumes: Vec<_> = cells.iter().map(|c| c.polytope.volume()).collect();
        let small = volumes.iter().filter(|v| **v == boxforge::math::exact::Q::frac(1, 6)).count();
        let big = volumes.iter().filter(|v| **v == boxforge::math::exact::Q::frac(1, 3)).count();
        assert_eq!((small, big), (4, 1), "4 corner tetrahedra of volume 1/6, 1 central of 1/3");
    }
    assert_eq!(d.references.len(), 2, "two symmetry classes");
    assert!(d.references.iter().all(|r| r.stencil.len() == 16), "a piece needs 16 samples");
}

#[test]
fn tensor_product_and_2d_facts() {
    let t = derive("cc_tricubic");
    assert_eq!((t.facts.degree, t.facts.approximation_order, t.max_stencil()), (9, 4, 64));
    let q = derive("cc_triquadratic");
    assert_eq!((q.facts.approximation_order, q.max_stencil()), (3, 27));
    let zp = derive("zp");
    assert_eq!((zp.facts.degree, zp.facts.approximation_order, zp.facts.continuity), (2, 3, 1));
    // ZP's axis knot lines sit at 1/2 + Z, so the grid offset is (1/2, 1/2).
    assert!(zp.arrangement.grid_offset.iter().all(|o| *o == boxforge::math::exact::Q::frac(1, 2)));
    let c = derive("courant");
    assert_eq!((c.facts.degree, c.max_stencil(), c.arrangement.cells.len()), (1, 3, 2));
}

#[test]
fn cells_tile_each_cube() {
    use boxforge::math::exact::Q;
    for d in boxforge_tests::all_catalog() {
        for ci in 0..d.arrangement.classes.len() {
            let v: Q = d.arrangement.cells.iter().filter(|c| c.class == ci).map(|c| c.polytope.volume()).sum();
            assert_eq!(v, Q::one(), "{} class {ci}", d.filter.name);
        }
    }
}
