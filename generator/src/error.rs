//! The one error type of the generator. Every message names the problem and
//! the fix, because it ends up in front of a user at a terminal or in a
//! build script's output.

use std::path::PathBuf;

/// Everything the generator can refuse; each message names the fix.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("cannot read {path}: {source} (check the path and its permissions)")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("malformed spec {origin}: {message} (see generator/catalog/*.toml for the format)")]
    Spec { origin: String, message: String },
    /// An emission option that this filter cannot have (the message names the alternative).
    #[error("{origin}: {message}")]
    Unsupported { origin: String, message: String },
    #[error("unknown filter '{name}': it is neither a catalog name ({available}) nor a readable .toml spec file")]
    UnknownFilter { name: String, available: String },
    #[error("unknown lattice '{name}': use one of cc, bcc, fcc, square, quincunx, or give `lattice = {{ generators = [[..], ..] }}`")]
    UnknownLattice { name: String },
    #[error("{what} has the non-integer entry {value}: directions and lattice generators must be integer vectors")]
    NotInteger { what: String, value: String },
    #[error("direction {index} is the zero vector: remove it (a box spline needs non-zero directions)")]
    ZeroDirection { index: usize },
    #[error("mixed dimensions: {what} has {found} entries but the lattice is {expected}-dimensional; give every vector {expected} entries")]
    MixedDimensions { what: String, found: usize, expected: usize },
    #[error("unsupported dimension {dim}: boxforge handles 2D and 3D (and 1D/4D only where noted); use 2 or 3 entries per vector")]
    UnsupportedDimension { dim: usize },
    #[error("the lattice generator matrix is singular (determinant 0): give {dim} linearly independent generators")]
    SingularLattice { dim: usize },
    #[error("the directions have rank {rank} < {dim}: they must span R^{dim}; add a direction outside their span")]
    RankDeficient { rank: usize, dim: usize },
    #[error("direction {index} {vector:?} is not a point of the {lattice} lattice: use lattice vectors (e.g. scale it by 2) or pick a lattice that contains it")]
    NotInLattice { index: usize, vector: Vec<i64>, lattice: String },
    #[error(
        "{count} directions exceed the cap of {cap}: remove directions or raise `caps.max_directions` in the spec"
    )]
    TooManyDirections { count: usize, cap: usize },
    #[error("degree {degree} exceeds the cap of {cap}: use fewer directions or raise `caps.max_degree` in the spec")]
    DegreeCap { degree: usize, cap: usize },
    #[error("the stencil would have up to {size} samples, over the cap of {cap}: use shorter directions or raise `caps.max_stencil` in the spec")]
    StencilCap { size: usize, cap: usize },
    #[error("the knot planes cut the unit cubes into at least {cells} cells (counted before cutting), over the cap of {cap}: use shorter or fewer directions, or raise `caps.max_cells` in the spec (`Caps` in the Builder)")]
    CellCap { cells: usize, cap: usize },
    #[error("{} {polynomials} polynomials ({pieces} reference pieces x {} {stencil} stencil samples), over the cap of {cap}: use shorter or fewer directions (or more symmetric ones), or raise `caps.max_polynomials` in the spec (`Caps` in the Builder)", if *exact { "the derivation needs" } else { "the derivation would need about" }, if *exact { "up to" } else { "about" })]
    PolynomialCap { polynomials: usize, pieces: usize, stencil: usize, exact: bool, cap: usize },
    #[error("the shader would hold {polynomials} polynomials ({pieces} reference pieces), over the emission cap of {cap} (about 3 KB of WGSL and 2 ms of generation each): use shorter or fewer directions (or more symmetric ones), or raise `caps.max_emitted_polynomials` in the spec (`Caps` in the Builder)")]
    EmitCap { polynomials: usize, pieces: usize, cap: usize },
    #[error(
        "no quasi-interpolation prefilter found within {shells} shells: raise the shell limit or check the filter"
    )]
    Prefilter { shells: usize },
    #[error("no output directory: OUT_DIR is not set (Cargo sets it for build scripts); call .out_dir(path) on the boxforge::Builder outside a build script")]
    OutDir,
    #[error(
        "generated WGSL for {file} is invalid: {message} (this is a boxforge bug; please report it with the spec)"
    )]
    InvalidWgsl { file: PathBuf, message: String },
}

/// The generator's result type.
pub type Result<T> = std::result::Result<T, Error>;
