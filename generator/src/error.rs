//! The one error type of the generator. Every message names the problem and
//! the fix, because it ends up in front of a user at a terminal or in a
//! build script's output.

use std::path::PathBuf;

/// Everything the generator can refuse; each message names the fix.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file or directory could not be read, created or written.
    #[error("cannot read {path}: {source} (check the path and its permissions)")]
    Io {
        /// The file or directory that could not be read, created or written.
        path: PathBuf,
        /// The underlying I/O error.
        source: std::io::Error,
    },
    /// A spec or option that cannot be met: TOML that does not parse or has the
    /// wrong shape, a failed check on the filter or lattice, or an emission
    /// option the filter does not allow.
    #[error("malformed spec {origin}: {message} (see generator/catalog/*.toml for the format)")]
    Spec {
        /// What the message is about: the spec's file or catalog path, the
        /// filter or the lattice.
        origin: String,
        /// What is wrong (for unparsable TOML, the parser's message on one line).
        message: String,
    },
    /// An emission option that this filter cannot have (the message names the alternative).
    #[error("{origin}: {message}")]
    Unsupported {
        /// The filter the option was asked for (`filter <name>`).
        origin: String,
        /// The refused option and why it does not apply.
        message: String,
    },
    /// A filter argument that is neither a catalog name nor a readable spec file.
    #[error("unknown filter '{name}': it is neither a catalog name ({available}) nor a readable .toml spec file")]
    UnknownFilter {
        /// The name or path as given.
        name: String,
        /// The catalog names, comma-separated.
        available: String,
    },
    /// A lattice name outside the built-in lattices.
    #[error("unknown lattice '{name}': use one of cc, bcc, fcc, square, quincunx, or give `lattice = {{ generators = [[..], ..] }}`")]
    UnknownLattice {
        /// The lattice name as given.
        name: String,
    },
    /// A direction or lattice generator entry that is not an integer.
    #[error("{what} has the non-integer entry {value}: directions and lattice generators must be integer vectors")]
    NotInteger {
        /// The vector holding the entry (`direction i` or `lattice generator i`).
        what: String,
        /// The offending TOML value, as written back by the parser.
        value: String,
    },
    /// A direction that is the zero vector.
    #[error("direction {index} is the zero vector: remove it (a box spline needs non-zero directions)")]
    ZeroDirection {
        /// Position of the zero vector in the direction list (from 0).
        index: usize,
    },
    /// A vector whose length differs from the lattice dimension.
    #[error("mixed dimensions: {what} has {found} entries but the lattice is {expected}-dimensional; give every vector {expected} entries")]
    MixedDimensions {
        /// The vector with the wrong length (`direction i` or `lattice generator i`).
        what: String,
        /// Its number of entries.
        found: usize,
        /// The lattice dimension every vector must match.
        expected: usize,
    },
    /// A dimension the generator does not handle.
    #[error("unsupported dimension {dim}: boxforge derives 2D, 3D and 4D filters (and emits WGSL for 2D and 3D); use 2, 3 or 4 entries per vector")]
    UnsupportedDimension {
        /// The dimension asked for (the number of lattice generators).
        dim: usize,
    },
    /// Lattice generators with determinant 0.
    #[error("the lattice generator matrix is singular (determinant 0): give {dim} linearly independent generators")]
    SingularLattice {
        /// The lattice dimension (number of generators needed).
        dim: usize,
    },
    /// Directions that do not span the space.
    #[error("the directions have rank {rank} < {dim}: they must span R^{dim}; add a direction outside their span")]
    RankDeficient {
        /// Rank of the direction matrix.
        rank: usize,
        /// The lattice dimension the directions must span.
        dim: usize,
    },
    /// A direction that is not a point of the lattice.
    #[error("direction {index} {vector:?} is not a point of the {lattice} lattice: use lattice vectors (e.g. scale it by 2) or pick a lattice that contains it")]
    NotInLattice {
        /// Position of the direction in the direction list (from 0).
        index: usize,
        /// The direction itself.
        vector: Vec<i64>,
        /// Name of the lattice it is not a point of.
        lattice: String,
    },
    /// More directions than `caps.max_directions`.
    #[error(
        "{count} directions exceed the cap of {cap}: remove directions or raise `caps.max_directions` in the spec"
    )]
    TooManyDirections {
        /// Number of directions given.
        count: usize,
        /// `caps.max_directions`.
        cap: usize,
    },
    /// A polynomial degree above `caps.max_degree`.
    #[error("degree {degree} exceeds the cap of {cap}: use fewer directions or raise `caps.max_degree` in the spec")]
    DegreeCap {
        /// Polynomial degree of the spline: number of directions minus the dimension.
        degree: usize,
        /// `caps.max_degree`.
        cap: usize,
    },
    /// A stencil larger than `caps.max_stencil`.
    #[error("the stencil would have up to {size} samples, over the cap of {cap}: use shorter directions or raise `caps.max_stencil` in the spec")]
    StencilCap {
        /// Samples per evaluation: the early estimate support volume / det G, or
        /// the largest reference-piece stencil once derived.
        size: usize,
        /// `caps.max_stencil`.
        cap: usize,
    },
    /// More cells per fundamental domain than `caps.max_cells`.
    #[error("the knot planes cut the unit cubes into at least {cells} cells (counted before cutting), over the cap of {cap}: use shorter or fewer directions, or raise `caps.max_cells` in the spec (`Caps` in the Builder)")]
    CellCap {
        /// A lower bound on the cells per fundamental domain, counted without cutting.
        cells: usize,
        /// `caps.max_cells`.
        cap: usize,
    },
    /// More polynomials to derive than `caps.max_polynomials`.
    #[error("{} {polynomials} polynomials ({pieces} reference pieces x {} {stencil} stencil samples), over the cap of {cap}: use shorter or fewer directions (or more symmetric ones), or raise `caps.max_polynomials` in the spec (`Caps` in the Builder)", if *exact { "the derivation needs" } else { "the derivation would need about" }, if *exact { "up to" } else { "about" })]
    PolynomialCap {
        /// Polynomials to derive: reference pieces x stencil samples (estimated or exact).
        polynomials: usize,
        /// Number of reference pieces (at least cells / |symmetry group| when estimated).
        pieces: usize,
        /// Stencil size: the mean estimate, or the largest reference stencil when exact.
        stencil: usize,
        /// Whether the counts come from the derived pieces rather than the estimate.
        exact: bool,
        /// `caps.max_polynomials`.
        cap: usize,
    },
    /// More polynomials in one shader than `caps.max_emitted_polynomials`.
    #[error("the shader would hold {polynomials} polynomials ({pieces} reference pieces), over the emission cap of {cap} (about 3 KB of WGSL and 2 ms of generation each): use shorter or fewer directions (or more symmetric ones), or raise `caps.max_emitted_polynomials` in the spec (`Caps` in the Builder)")]
    EmitCap {
        /// Polynomials the shader would hold: the sum of the reference stencil sizes.
        polynomials: usize,
        /// Number of reference pieces.
        pieces: usize,
        /// `caps.max_emitted_polynomials`.
        cap: usize,
    },
    /// No quasi-interpolation prefilter within the shell limit.
    #[error(
        "no quasi-interpolation prefilter found within {shells} shells: raise the shell limit or check the filter"
    )]
    Prefilter {
        /// The shell limit that was searched.
        shells: usize,
    },
    /// No output directory: neither `OUT_DIR` nor [`Builder::out_dir`](crate::Builder::out_dir) is set.
    #[error("no output directory: OUT_DIR is not set (Cargo sets it for build scripts); call .out_dir(path) on the boxforge::Builder outside a build script")]
    OutDir,
    /// A template that failed to render (the templates are fixed at build
    /// time and every emission test renders them, so this is a generator bug).
    #[error("the WGSL templates failed to render for filter {filter}: {source} (this is a boxforge bug; please report it with the spec)")]
    Template {
        /// The filter whose module was being written.
        filter: String,
        /// minijinja's error.
        source: minijinja::Error,
    },
    /// A generated module that naga rejects or that is not branch-free (a generator bug).
    #[error(
        "generated WGSL for {file} is invalid: {message} (this is a boxforge bug; please report it with the spec)"
    )]
    InvalidWgsl {
        /// The path the module would have been written to.
        file: PathBuf,
        /// naga's validation error, or why the branch-free check failed.
        message: String,
    },
    /// A module that could not be translated into another language (the
    /// message names the target and what works instead).
    #[error(transparent)]
    Translate(#[from] crate::back::BackError),
}

/// The generator's result type.
pub type Result<T> = std::result::Result<T, Error>;
