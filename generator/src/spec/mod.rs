//! Filter spec files (TOML): parsing and validation into a [`Filter`].
//!
//! ```toml
//! name = "bcc7"
//! description = "Kim 2013 quartic"
//! lattice = "bcc"                      # or { generators = [[-1,1,1],[1,-1,1],[1,1,-1]] }
//! directions = [[1,1,1],[-1,1,1],[1,-1,1],[1,1,-1],[2,0,0],[0,2,0],[0,0,2]]
//! [caps]                               # optional
//! max_degree = 12
//! ```

pub mod lattice;
pub mod random;

use crate::error::{Error, Result};
use crate::math::linalg::{rank_of_vectors, IVec};
use crate::spec::lattice::Lattice;
use serde::Deserialize;
use std::path::Path;

/// Limits that keep a derivation from running for hours.
#[derive(Clone, Debug, Deserialize, PartialEq, Eq)]
#[serde(deny_unknown_fields, default)]
pub struct Caps {
    /// Most directions a filter may have.
    pub max_directions: usize,
    /// Highest polynomial degree (number of directions minus the dimension).
    pub max_degree: usize,
    /// Most samples per evaluation: checked early against support volume /
    /// |det G|, then against the largest stencil of any reference piece.
    pub max_stencil: usize,
    /// Evaluation cells per fundamental domain (counted exactly before any
    /// cell is cut).
    pub max_cells: usize,
    /// Polynomials to derive and emit: reference pieces x stencil samples
    /// (estimated before the cells are cut, checked exactly after).
    pub max_polynomials: usize,
    /// Polynomials in one emitted shader (each costs about 3 KB of WGSL).
    pub max_emitted_polynomials: usize,
}

impl Default for Caps {
    fn default() -> Caps {
        Caps {
            max_directions: 16,
            max_degree: 12,
            max_stencil: 512,
            max_cells: 20_000,
            max_polynomials: 50_000,
            max_emitted_polynomials: 2_048,
        }
    }
}

/// The exact evaluation form of the emitted `eval` / `eval_grad`
/// (`form = "..."` in a spec; `auto` lets the generator pick the cheapest).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum EvalForm {
    /// The cheapest available form by the cost model (static op count).
    #[default]
    Auto,
    /// Tensor-product filters: 1D weights per axis, contraction axis by axis.
    Factored,
    /// Monomial coefficients with shared subexpressions, nested Horner.
    Power,
    /// Linear-form (ridge) form: each piece as a sum of products of powers
    /// of knot-plane linear forms, the shape of Kim & Lee's published bcc7 formula.
    Ridge,
    /// BB coefficients with shared subexpressions, de Casteljau.
    Bb,
    /// BB coefficients as dense sums of every sample (the first milestone's form).
    Dense,
}

impl EvalForm {
    /// Every form, `auto` first.
    pub const ALL: [EvalForm; 6] =
        [EvalForm::Auto, EvalForm::Factored, EvalForm::Power, EvalForm::Ridge, EvalForm::Bb, EvalForm::Dense];

    /// The name used in specs and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            EvalForm::Auto => "auto",
            EvalForm::Factored => "factored",
            EvalForm::Power => "power",
            EvalForm::Ridge => "ridge",
            EvalForm::Bb => "bb",
            EvalForm::Dense => "dense",
        }
    }

    /// Parses a form name (`auto`, `factored`, `power`, `ridge`, `bb`, `dense`).
    pub fn parse(s: &str) -> Option<EvalForm> {
        EvalForm::ALL.into_iter().find(|f| f.name() == s)
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSpec {
    name: String,
    #[serde(default)]
    description: String,
    lattice: RawLattice,
    directions: Vec<Vec<toml::Value>>,
    #[serde(default)]
    caps: Caps,
    #[serde(default)]
    form: EvalForm,
    #[serde(default)]
    view_dependent: bool,
}

#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum RawLattice {
    Name(String),
    Generators { generators: Vec<Vec<toml::Value>> },
}

/// A validated filter: a lattice and integer directions in it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Filter {
    /// Name: ASCII letters, digits and `_` (it prefixes WGSL identifiers).
    pub name: String,
    /// Free-text description (may be empty).
    pub description: String,
    /// The lattice the samples lie on.
    pub lattice: Lattice,
    /// The integer directions, each a point of the lattice.
    pub directions: Vec<IVec>,
    /// Limits on the derivation.
    pub caps: Caps,
    /// The evaluation form asked for (default `auto`).
    pub form: EvalForm,
    /// A view-dependent scheme (spec key `view_dependent = true`): the
    /// directions are the variant for views whose largest component is +z
    /// and whose others are non-negative, and a renderer uses, per frame,
    /// [`Filter::view_variant`] for its view direction (Mattausch et al.'s
    /// sheared trilinear interpolation picks its shear planes and shear
    /// directions this way).
    pub view_dependent: bool,
}

fn integer(v: &toml::Value, what: &str) -> Result<i64> {
    match v {
        toml::Value::Integer(i) => Ok(*i),
        toml::Value::Float(f) if f.fract() == 0.0 && f.abs() < 1e15 => Ok(*f as i64),
        other => Err(Error::NotInteger { what: what.to_string(), value: other.to_string() }),
    }
}

fn integer_vector(v: &[toml::Value], what: &str) -> Result<IVec> {
    v.iter().map(|x| integer(x, what)).collect()
}

impl Filter {
    /// Parses and validates spec text; `origin` names it in errors.
    ///
    /// # Errors
    ///
    /// [`Error::Spec`] when the TOML does not parse or has the wrong shape,
    /// [`Error::NotInteger`] for a non-integer entry, the errors of
    /// [`Lattice::builtin`] and [`Lattice::from_generators`], and every error of
    /// [`Filter::new`].
    pub fn from_toml(text: &str, origin: &str) -> Result<Filter> {
        let raw: RawSpec = toml::from_str(text).map_err(|e| Error::Spec {
            origin: origin.to_string(),
            message: e.to_string().trim().replace('\n', " "),
        })?;
        let lattice = match raw.lattice {
            RawLattice::Name(n) => Lattice::builtin(&n)?,
            RawLattice::Generators { generators } => {
                let gens = generators
                    .iter()
                    .enumerate()
                    .map(|(i, g)| integer_vector(g, &format!("lattice generator {i}")))
                    .collect::<Result<Vec<_>>>()?;
                Lattice::from_generators("custom", gens)?
            }
        };
        let directions = raw
            .directions
            .iter()
            .enumerate()
            .map(|(i, d)| integer_vector(d, &format!("direction {i}")))
            .collect::<Result<Vec<_>>>()?;
        let mut filter = Filter::new(&raw.name, &raw.description, lattice, directions, raw.caps)?;
        filter.form = raw.form;
        if raw.view_dependent && filter.dim() != 3 {
            return Err(Error::Spec {
                origin: origin.to_string(),
                message: "view_dependent = true needs a 3D lattice (the variant follows a 3D view direction)".into(),
            });
        }
        filter.view_dependent = raw.view_dependent;
        Ok(filter)
    }

    /// Reads and validates a spec file.
    ///
    /// # Errors
    ///
    /// [`Error::Io`] when the file cannot be read, and every error of [`Filter::from_toml`].
    pub fn from_file(path: &Path) -> Result<Filter> {
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
        Filter::from_toml(&text, &path.display().to_string())
    }

    /// Validates a filter given in code.
    ///
    /// # Errors
    ///
    /// [`Error::UnsupportedDimension`] unless the lattice is 2D, 3D or 4D (4D is
    /// derived but not emitted as WGSL); [`Error::Spec`] for a
    /// name that is not a WGSL-safe identifier or a direction entry beyond ±64;
    /// [`Error::TooManyDirections`], [`Error::MixedDimensions`], [`Error::ZeroDirection`],
    /// [`Error::RankDeficient`], [`Error::NotInLattice`] and [`Error::DegreeCap`].
    pub fn new(name: &str, description: &str, lattice: Lattice, directions: Vec<IVec>, caps: Caps) -> Result<Filter> {
        let dim = lattice.dim();
        if !(2..=4).contains(&dim) {
            return Err(Error::UnsupportedDimension { dim });
        }
        if name.trim().is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return Err(Error::Spec {
                origin: format!("'{name}'"),
                message: "the name must be non-empty ASCII letters, digits and '_' (it prefixes WGSL identifiers)"
                    .into(),
            });
        }
        if directions.len() > caps.max_directions {
            return Err(Error::TooManyDirections { count: directions.len(), cap: caps.max_directions });
        }
        for (i, d) in directions.iter().enumerate() {
            if d.len() != dim {
                return Err(Error::MixedDimensions { what: format!("direction {i}"), found: d.len(), expected: dim });
            }
            if d.iter().any(|&x| x.abs() > 64) {
                return Err(Error::Spec {
                    origin: format!("'{name}'"),
                    message: format!("direction {i} {d:?} has an entry beyond ±64; use shorter directions"),
                });
            }
        }
        for (i, d) in directions.iter().enumerate() {
            if d.iter().all(|&x| x == 0) {
                return Err(Error::ZeroDirection { index: i });
            }
        }
        let rank = rank_of_vectors(&directions);
        if rank < dim {
            return Err(Error::RankDeficient { rank, dim });
        }
        for (i, d) in directions.iter().enumerate() {
            if !lattice.contains(d) {
                return Err(Error::NotInLattice { index: i, vector: d.clone(), lattice: lattice.name.clone() });
            }
        }
        let degree = directions.len() - dim;
        if degree > caps.max_degree {
            return Err(Error::DegreeCap { degree, cap: caps.max_degree });
        }
        Ok(Filter {
            name: name.to_string(),
            description: description.to_string(),
            lattice,
            directions,
            caps,
            form: EvalForm::Auto,
            view_dependent: false,
        })
    }

    /// The variant of a view-dependent filter for the view direction `view`
    /// (3D): the reference axis z goes to the axis k of the largest |view_k|
    /// (the first on a tie), the reference x and y to the other two in
    /// order, and each axis a is then multiplied by the sign of view_a (+
    /// for 0). For Mattausch et al.'s sheared trilinear interpolation this
    /// puts the shear planes perpendicular to axis k, the plane stack most
    /// perpendicular to the view, and the short cell edge along the signs
    /// of the view (the sheared cell borders as parallel to the ray as the
    /// lattice allows). Also returns a one-line description of the choice.
    /// A filter that is not view-dependent comes back unchanged.
    ///
    /// # Errors
    ///
    /// [`Error::Spec`] for a view that is not 3D or not finite and non-zero,
    /// and [`Error::NotInLattice`] when the lattice is not invariant under
    /// that signed permutation (a custom lattice).
    pub fn view_variant(&self, view: [f64; 3]) -> Result<(Filter, String)> {
        if !self.view_dependent {
            return Ok((self.clone(), format!("{} is not view-dependent", self.name)));
        }
        if self.dim() != 3 || view.iter().any(|x| !x.is_finite()) || view.iter().all(|&x| x == 0.0) {
            return Err(Error::Spec {
                origin: format!("filter {}", self.name),
                message: format!("the view direction {view:?} must be 3D, finite and non-zero"),
            });
        }
        let k = (0..3).fold(0, |best, a| if view[a].abs() > view[best].abs() { a } else { best });
        let others: Vec<usize> = (0..3).filter(|&a| a != k).collect();
        let target = [others[0], others[1], k];
        let sign: Vec<i64> = view.iter().map(|&x| if x < 0.0 { -1 } else { 1 }).collect();
        let directions: Vec<IVec> = self
            .directions
            .iter()
            .map(|v| {
                let mut w = vec![0; 3];
                for (j, &a) in target.iter().enumerate() {
                    w[a] = sign[a] * v[j];
                }
                w
            })
            .collect();
        let mut f = Filter::new(&self.name, &self.description, self.lattice.clone(), directions, self.caps.clone())?;
        f.form = self.form;
        f.view_dependent = true;
        let s = |x: i64| if x < 0 { '-' } else { '+' };
        let label = format!(
            "{}: view ({:.2}, {:.2}, {:.2}): reference z along {}, signs ({}, {}, {}), directions {:?}",
            self.name,
            view[0],
            view[1],
            view[2],
            ["x", "y", "z"][k],
            s(sign[0]),
            s(sign[1]),
            s(sign[2]),
            f.directions
        );
        Ok((f, label))
    }

    /// The dimension of the lattice (and of every direction).
    pub fn dim(&self) -> usize {
        self.lattice.dim()
    }
}

/// The built-in catalog: every spec file in `generator/catalog/`, embedded at
/// build time (see build.rs), in exactly the format users write.
pub mod catalog {
    use super::*;

    include!(concat!(env!("OUT_DIR"), "/catalog_files.rs"));

    /// Names of the catalog filters, in file-name order.
    pub fn names() -> Vec<&'static str> {
        CATALOG.iter().map(|(n, _)| *n).collect()
    }

    /// The spec text of a catalog filter.
    pub fn source(name: &str) -> Option<&'static str> {
        CATALOG.iter().find(|(n, _)| *n == name).map(|(_, s)| *s)
    }

    /// A catalog filter by name.
    ///
    /// # Errors
    ///
    /// [`Error::UnknownFilter`] when no catalog file has this name (listing the
    /// names); a catalog spec that fails [`Filter::from_toml`] would return its error.
    pub fn get(name: &str) -> Result<Filter> {
        match source(name) {
            Some(text) => Filter::from_toml(text, &format!("catalog/{name}.toml")),
            None => Err(Error::UnknownFilter { name: name.to_string(), available: names().join(", ") }),
        }
    }

    /// Every catalog filter.
    ///
    /// # Errors
    ///
    /// The first error of [`get`] (a catalog spec that does not validate).
    pub fn all() -> Result<Vec<Filter>> {
        names().into_iter().map(get).collect()
    }
}

/// Resolves a command-line argument: a catalog name or a path to a spec file.
///
/// # Errors
///
/// [`Error::UnknownFilter`] when the argument is neither a catalog name nor an
/// existing path or `.toml` name; otherwise the errors of [`catalog::get`] or
/// [`Filter::from_file`].
pub fn resolve(name_or_path: &str) -> Result<Filter> {
    if catalog::source(name_or_path).is_some() {
        return catalog::get(name_or_path);
    }
    let p = Path::new(name_or_path);
    if p.exists() || name_or_path.ends_with(".toml") {
        return Filter::from_file(p);
    }
    Err(Error::UnknownFilter { name: name_or_path.to_string(), available: catalog::names().join(", ") })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(dirs: &str) -> Result<Filter> {
        Filter::from_toml(&format!("name = \"t\"\nlattice = \"bcc\"\ndirections = {dirs}\n"), "test")
    }

    #[test]
    fn catalog_parses() {
        let all = catalog::all().unwrap();
        assert!(all.len() >= 10);
        for f in &all {
            assert_eq!(catalog::get(&f.name).unwrap().name, f.name);
        }
    }

    #[test]
    fn each_bad_input_has_its_error() {
        assert!(matches!(parse("[[1.5,1,1],[1,1,1],[-1,1,1]]"), Err(Error::NotInteger { .. })));
        assert!(matches!(parse("[[0,0,0],[1,1,1],[-1,1,1],[1,-1,1]]"), Err(Error::ZeroDirection { index: 0 })));
        assert!(matches!(parse("[[1,1],[1,1,1]]"), Err(Error::MixedDimensions { .. })));
        assert!(matches!(parse("[[1,1,1],[2,2,2],[-1,1,1]]"), Err(Error::RankDeficient { rank: 2, dim: 3 })));
        assert!(matches!(parse("[[1,0,0],[0,2,0],[0,0,2]]"), Err(Error::NotInLattice { index: 0, .. })));
        assert!(matches!(parse("[[1,1,1]"), Err(Error::Spec { .. })));
        let many = format!("[{}]", vec!["[2,0,0]"; 17].join(","));
        assert!(matches!(parse(&many), Err(Error::TooManyDirections { count: 17, cap: 16 })));
        let deg =
            "name=\"t\"\nlattice=\"cc\"\ndirections=[[1,0,0],[0,1,0],[0,0,1],[1,0,0],[0,1,0]]\n[caps]\nmax_degree=1\n";
        assert!(matches!(Filter::from_toml(deg, "t"), Err(Error::DegreeCap { degree: 2, cap: 1 })));
        let lat = "name=\"t\"\nlattice=\"hex\"\ndirections=[[1,0]]\n";
        assert!(matches!(Filter::from_toml(lat, "t"), Err(Error::UnknownLattice { .. })));
        let sing = "name=\"t\"\nlattice={generators=[[1,1],[2,2]]}\ndirections=[[1,0],[0,1]]\n";
        assert!(matches!(Filter::from_toml(sing, "t"), Err(Error::SingularLattice { .. })));
        assert!(matches!(resolve("no_such_filter"), Err(Error::UnknownFilter { .. })));
    }

    #[test]
    fn explicit_generators_work() {
        let t = "name=\"hexish\"\nlattice={generators=[[2,0],[1,1]]}\ndirections=[[2,0],[1,1],[-1,1]]\n";
        let f = Filter::from_toml(t, "t").unwrap();
        assert_eq!(f.lattice.det(), 2);
    }
}
