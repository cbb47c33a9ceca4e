use boxforge::derive::arrangement::Arrangement;
use boxforge::derive::spline::SplineFacts;
use boxforge::spec::lattice::Lattice;
use boxforge::spec::{Caps, Filter};
fn main() {
    let l = Lattice::builtin("cc").unwrap();
    let dirs = vec![
        vec![2, 1, 0],
        vec![-1, 2, 1],
        vec![1, -2, 2],
        vec![2, 2, -1],
        vec![0, 1, 2],
        vec![1, 1, 1],
        vec![-2, 1, 1],
    ];
    let f = Filter::new("r", "", l, dirs, Caps::default()).unwrap();
    let facts = SplineFacts::new(&f);
    println!("support {} normals {}", facts.support_volume, facts.normals.len());
    let t = std::time::Instant::now();
    let a = Arrangement::new(&facts, &f.lattice);
    println!("cells {} pieces {} in {:?}", a.cells.len(), a.pieces_per_fundamental_domain, t.elapsed());
    if std::env::args().count() > 1 {
        full(&f);
    }
}
#[allow(dead_code)]
fn full(f: &Filter) {
    let t = std::time::Instant::now();
    let d = boxforge::derive::Derivation::new(f).unwrap();
    println!("derivation: refs {} stencil {} in {:?}", d.references.len(), d.max_stencil(), t.elapsed());
}
