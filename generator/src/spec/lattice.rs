//! Integer lattices L = G Z^s embedded in Z^s: membership, the classes of
//! Z^s modulo L (cube classes), and the built-in lattices.

use crate::error::{Error, Result};
use crate::math::linalg::{det_columns, IVec};

/// A full-rank integer lattice given by generator columns.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Lattice {
    /// Built-in name, or "custom".
    pub name: String,
    /// Generator columns as given.
    pub generators: Vec<IVec>,
    /// Lower-triangular Hermite basis (columns): column i is zero above row i
    /// and has a positive diagonal entry. Gives canonical class representatives.
    hermite: Vec<IVec>,
    det: i64,
}

/// Names of the built-in lattices.
pub const BUILTIN_LATTICES: &[&str] = &["cc", "bcc", "fcc", "square", "quincunx", "z4", "d4", "d4star"];

/// Largest |entry| of a lattice generator (directions have the same bound).
pub const MAX_GENERATOR_ENTRY: i64 = 64;

impl Lattice {
    /// A built-in lattice by name (see docs/BOX_SPLINES.md §1).
    ///
    /// # Errors
    ///
    /// [`Error::UnknownLattice`] for a name outside [`BUILTIN_LATTICES`].
    pub fn builtin(name: &str) -> Result<Lattice> {
        let gens: Vec<IVec> = match name {
            "cc" => vec![vec![1, 0, 0], vec![0, 1, 0], vec![0, 0, 1]],
            "bcc" => vec![vec![-1, 1, 1], vec![1, -1, 1], vec![1, 1, -1]],
            "fcc" => vec![vec![0, 1, 1], vec![1, 0, 1], vec![1, 1, 0]],
            "square" => vec![vec![1, 0], vec![0, 1]],
            "quincunx" => vec![vec![1, 1], vec![1, -1]],
            // 4D: the Cartesian lattice, the checkerboard lattice D4 (even
            // coordinate sum) and its dual D4* scaled by 2 (2Z^4 and 2Z^4 +
            // (1,1,1,1), like BCC in 3D).
            "z4" => vec![vec![1, 0, 0, 0], vec![0, 1, 0, 0], vec![0, 0, 1, 0], vec![0, 0, 0, 1]],
            "d4" => vec![vec![1, 1, 0, 0], vec![1, -1, 0, 0], vec![0, 1, -1, 0], vec![0, 0, 1, -1]],
            "d4star" => vec![vec![2, 0, 0, 0], vec![0, 2, 0, 0], vec![0, 0, 2, 0], vec![1, 1, 1, 1]],
            _ => return Err(Error::UnknownLattice { name: name.to_string() }),
        };
        Lattice::from_generators(name, gens)
    }

    /// A lattice from generator columns; errors on a singular or ragged matrix.
    ///
    /// # Errors
    ///
    /// [`Error::UnsupportedDimension`] unless there are 1 to 4 generators,
    /// [`Error::MixedDimensions`] for a generator of the wrong length, [`Error::Spec`]
    /// when the determinant does not fit an i64, and [`Error::SingularLattice`] when it is 0.
    pub fn from_generators(name: &str, generators: Vec<IVec>) -> Result<Lattice> {
        let dim = generators.len();
        if !(1..=4).contains(&dim) {
            return Err(Error::UnsupportedDimension { dim });
        }
        for (i, g) in generators.iter().enumerate() {
            if g.len() != dim {
                return Err(Error::MixedDimensions {
                    what: format!("lattice generator {i}"),
                    found: g.len(),
                    expected: dim,
                });
            }
        }
        // Generators are user input: bounded like directions, so the Hermite
        // form and every reduction stay far inside i64.
        if let Some((i, g)) =
            generators.iter().enumerate().find(|(_, g)| g.iter().any(|x| x.abs() > MAX_GENERATOR_ENTRY))
        {
            return Err(Error::Spec {
                origin: format!("lattice '{name}'"),
                message: format!(
                    "generator {i} {g:?} has an entry beyond ±{MAX_GENERATOR_ENTRY}; use a smaller basis of the same lattice"
                ),
            });
        }
        let cols: Vec<&[i64]> = generators.iter().map(|g| g.as_slice()).collect();
        // A determinant beyond i64 is refused, not a panic.
        let Some(det) = det_columns(&cols).and_then(i64::checked_abs) else {
            return Err(Error::Spec {
                origin: format!("lattice '{name}'"),
                message: "the generator determinant does not fit a 64-bit integer; use smaller generators".into(),
            });
        };
        if det == 0 {
            return Err(Error::SingularLattice { dim });
        }
        let hermite = hermite_lower(&generators);
        Ok(Lattice { name: name.to_string(), generators, hermite, det })
    }

    /// The dimension s.
    pub fn dim(&self) -> usize {
        self.generators.len()
    }

    /// |det G|: integer points per lattice point.
    pub fn det(&self) -> i64 {
        self.det
    }

    /// The canonical representative of v's class in Z^s / L: the unique
    /// point of the class with 0 <= r_i < H_ii.
    pub fn reduce(&self, v: &[i64]) -> IVec {
        let mut x = v.to_vec();
        for i in 0..x.len() {
            let h = self.hermite[i][i];
            let q = x[i].div_euclid(h);
            if q != 0 {
                for (r, xr) in x.iter_mut().enumerate().skip(i) {
                    *xr -= q * self.hermite[i][r];
                }
            }
        }
        x
    }

    /// The lower-triangular Hermite basis (columns), for shaders that reduce
    /// cube corners to class representatives with integer arithmetic.
    pub fn hermite_basis(&self) -> &[IVec] {
        &self.hermite
    }

    /// Is v a lattice point?
    pub fn contains(&self, v: &[i64]) -> bool {
        self.reduce(v).iter().all(|&x| x == 0)
    }

    /// All class representatives of Z^s / L, sorted (the first is the origin).
    pub fn classes(&self) -> Vec<IVec> {
        let dim = self.dim();
        let mut out = vec![vec![]];
        for i in 0..dim {
            let h = self.hermite[i][i];
            out = out
                .into_iter()
                .flat_map(|p: IVec| {
                    (0..h).map(move |k| {
                        let mut q = p.clone();
                        q.push(k);
                        q
                    })
                })
                .collect();
        }
        let mut reps: Vec<IVec> = out.iter().map(|p| self.reduce(p)).collect();
        reps.sort();
        reps.dedup();
        // Prefer small-norm representatives (nicer reports): for each class,
        // the lexicographically least among the points of {-1,0,1}^s ∪ reps
        // with least L1 norm.
        let mut nice: Vec<IVec> = Vec::new();
        for r in &reps {
            let mut best = r.clone();
            for cand in small_points(dim) {
                if self.reduce(&cand) == *r {
                    let key = |p: &IVec| (p.iter().map(|x| x.abs()).sum::<i64>(), p.iter().any(|&x| x < 0), p.clone());
                    if key(&cand) < key(&best) {
                        best = cand;
                    }
                }
            }
            nice.push(best);
        }
        nice.sort_by_key(|p| (p.iter().map(|x| x.abs()).sum::<i64>(), std::cmp::Reverse(p.clone())));
        nice
    }
}

fn small_points(dim: usize) -> Vec<IVec> {
    let mut out = vec![vec![]];
    for _ in 0..dim {
        out = out
            .into_iter()
            .flat_map(|p: IVec| {
                (-1..=1).map(move |k| {
                    let mut q = p.clone();
                    q.push(k);
                    q
                })
            })
            .collect();
    }
    out
}

/// Lower-triangular column Hermite form: returns basis columns h_0..h_{s-1}
/// with h_i[r] = 0 for r < i and h_i[i] > 0.
fn hermite_lower(generators: &[IVec]) -> Vec<IVec> {
    let dim = generators.len();
    let mut cols: Vec<IVec> = generators.to_vec();
    for i in 0..dim {
        // Euclid on row i among columns i..dim.
        loop {
            let nonzero: Vec<usize> = (i..dim).filter(|&c| cols[c][i] != 0).collect();
            if nonzero.len() <= 1 {
                if let Some(&c) = nonzero.first() {
                    cols.swap(i, c);
                }
                break;
            }
            let &p =
                nonzero.iter().min_by_key(|&&c| cols[c][i].abs()).expect("`nonzero` has at least two columns here");
            for &c in &nonzero {
                if c != p {
                    let q = cols[c][i].div_euclid(cols[p][i]);
                    let pc = cols[p].clone();
                    for (x, y) in cols[c].iter_mut().zip(&pc) {
                        *x -= q * y;
                    }
                }
            }
        }
        if cols[i][i] < 0 {
            cols[i].iter_mut().for_each(|x| *x = -*x);
        }
    }
    cols
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_membership() {
        let bcc = Lattice::builtin("bcc").unwrap();
        assert_eq!(bcc.det(), 4);
        assert!(bcc.contains(&[1, 1, 1]) && bcc.contains(&[2, 0, 0]) && bcc.contains(&[-1, 3, 1]));
        assert!(!bcc.contains(&[1, 0, 0]) && !bcc.contains(&[1, 1, 0]));
        let fcc = Lattice::builtin("fcc").unwrap();
        assert_eq!(fcc.det(), 2);
        assert!(fcc.contains(&[1, 1, 0]) && !fcc.contains(&[1, 0, 0]) && !fcc.contains(&[1, 1, 1]));
        let q = Lattice::builtin("quincunx").unwrap();
        assert!(q.contains(&[1, 1]) && q.contains(&[2, 0]) && !q.contains(&[0, 1]));
    }

    #[test]
    fn classes_are_complete_and_distinct() {
        for name in BUILTIN_LATTICES {
            let l = Lattice::builtin(name).unwrap();
            let c = l.classes();
            assert_eq!(c.len() as i64, l.det(), "{name}");
            assert!(c[0].iter().all(|&x| x == 0));
            for (i, a) in c.iter().enumerate() {
                for b in &c[i + 1..] {
                    assert!(!l.contains(&crate::math::linalg::sub_i(a, b)));
                }
            }
        }
    }

    #[test]
    fn singular_is_rejected() {
        let e = Lattice::from_generators("custom", vec![vec![1, 1], vec![2, 2]]).unwrap_err();
        assert!(matches!(e, Error::SingularLattice { .. }));
    }

    #[test]
    fn huge_generators_are_an_error_not_an_overflow() {
        let big = 1 << 40;
        let e =
            Lattice::from_generators("custom", vec![vec![big, 0, 0], vec![0, big, 0], vec![0, 0, big]]).unwrap_err();
        assert!(matches!(e, Error::Spec { .. }) && e.to_string().contains("beyond"), "{e}");
        let edge = MAX_GENERATOR_ENTRY;
        assert!(Lattice::from_generators("custom", vec![vec![edge, 0, 0], vec![0, 1, 0], vec![0, 0, 1]]).is_ok());
    }
}
