//! What a caller chooses for an emitted module: the sample layout, the
//! variant, bounds and fetch modes, the sample map and texel format, and
//! [`EmitOptions`] that gathers them. Kept apart from the emitter itself
//! because the builder, the reports and the runtime name these types
//! without needing any of the code that writes WGSL.

use crate::spec::EvalForm;
use serde::Serialize;

/// Storage layout of the samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Layout {
    /// Cartesian texture with the lattice embedded (|det G| texels per sample).
    Embedded,
    /// One dense grid per coset of 2Z^s, each a tile of one texture read with
    /// `textureLoad` (one texel per sample).
    Packed,
    /// The embedded texels cut into bricks of B^s, each in a slot of a pool
    /// texture with a halo as wide as the stencils reach, found through a
    /// page table once per evaluation ([`bricks`](super::bricks)): volumes larger than one
    /// texture, and bricks kept resident only where a frame needs them.
    Bricked,
    /// The same bricks, each slot holding its region coset-packed (one
    /// texel per sample, a tile per coset of 2Z^s, as [`Layout::Packed`]).
    BrickedPacked,
}

/// Code shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Variant {
    /// Branch-free, table-free straight-line code.
    Fast,
    /// The same mathematics with branches, loops and lookup tables.
    Naive,
}

impl Layout {
    /// The name used on the command line (and in reports).
    pub fn name(self) -> &'static str {
        match self {
            Layout::Embedded => "embedded",
            Layout::Packed => "packed",
            Layout::Bricked => "bricked",
            Layout::BrickedPacked => "bricked-packed",
        }
    }
    /// Whether the samples are bricks in a pool with a page table.
    pub fn is_bricked(self) -> bool {
        matches!(self, Layout::Bricked | Layout::BrickedPacked)
    }

    /// Bindings the samples take from the first one (the kernels' outputs
    /// follow them): the texture; the coset grid uniform (packed); the
    /// bricks uniform and the page table (bricked).
    pub fn sample_bindings(self) -> u32 {
        match self {
            Layout::Embedded => 1,
            Layout::Packed => 2,
            Layout::Bricked | Layout::BrickedPacked => 3,
        }
    }
    /// The value named `s` (see [`name`](Self::name)); None for any other string.
    pub fn parse(s: &str) -> Option<Layout> {
        match s {
            "embedded" => Some(Layout::Embedded),
            "packed" => Some(Layout::Packed),
            "bricked" => Some(Layout::Bricked),
            "bricked-packed" => Some(Layout::BrickedPacked),
            _ => None,
        }
    }
}

impl Variant {
    /// The name used on the command line (and in reports).
    pub fn name(self) -> &'static str {
        match self {
            Variant::Fast => "fast",
            Variant::Naive => "naive",
        }
    }
    /// The value named `s` (see [`name`](Self::name)); None for any other string.
    pub fn parse(s: &str) -> Option<Variant> {
        match s {
            "fast" => Some(Variant::Fast),
            "naive" => Some(Variant::Naive),
            _ => None,
        }
    }
}

/// What to emit: layout, code shape, bindings, form and fetch choices.
#[derive(Clone, Debug)]
pub struct EmitOptions {
    /// Storage layout of the samples.
    pub layout: Layout,
    /// Fast (branch-free) or naive code.
    pub variant: Variant,
    /// Bind group and first binding of the samples.
    pub group: u32,
    /// First binding of the samples; the others follow it.
    pub binding: u32,
    /// Include the prefilter and min/max compute kernels.
    pub kernels: bool,
    /// The command named in the header.
    pub command: String,
    /// Evaluation form; None: the filter's own (`form` in its spec, default auto).
    pub form: Option<EvalForm>,
    /// Out-of-range fetches: clamp to the volume (default) or trust the caller.
    pub bounds: Bounds,
    /// Exact texel loads (default) or hardware-filtered (linear) fetches in `eval`.
    pub fetch: FetchMode,
    /// What a stored sample means: value = offset + scale * stored (compact
    /// formats store normalized samples); identity by default.
    pub samples: SampleMap,
    /// What one texel of the sample texture holds: one f32-readable sample
    /// (default) or four 8-bit samples in an r32uint word.
    pub texels: Texels,
}

/// What one texel of the sample texture (or brick pool) holds.
///
/// Why [`Texels::U8x4`] exists: on software rasterizers (Mesa's llvmpipe, so
/// lavapipe) a texel fetch is a gather, and its vector path serves only
/// 32-bit texels that need no expansion; an R8Unorm fetch loads lane by
/// lane and loses to R32Float. Four 8-bit samples per r32uint word keep the
/// fetch on the 32-bit path at a quarter of f32's memory, for one shift and
/// mask per sample.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Texels {
    /// One sample per texel, read as `texture_Nd<f32>` (r32float, r16float,
    /// r16unorm or r8unorm: the same module reads each).
    #[default]
    Float,
    /// Four u8 samples per `texture_Nd<u32>` texel along x: sample x in byte
    /// x & 3 (least significant first) of texel x >> 2. A sample reads as its
    /// integer 0..255, so the [`SampleMap`] spans the range over 255 levels.
    /// The texture is ceil(width / 4) texels wide; the embedded layout's
    /// clamp reaches 4 * that width - 1, so its host repeats the last sample
    /// of a row into the padding bytes.
    U8x4,
}

/// The affine map from stored samples to values: value = offset + scale *
/// stored. A box spline is linear in its samples and its weights sum to 1,
/// so the module applies the map once per evaluation (value: offset +
/// scale times the spline of the stored samples; gradient: scale times its
/// gradient), once per prefiltered point (the prefilter's taps sum to 1) and once per bound.
/// Compact sample formats (u8, u16 normalized, f16) store (v - offset) / scale.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SampleMap {
    /// The factor (must be finite and > 0, so bounds keep their order).
    pub scale: f32,
    /// The offset (finite).
    pub offset: f32,
}

impl SampleMap {
    /// Stored samples are the values.
    pub const IDENTITY: SampleMap = SampleMap { scale: 1.0, offset: 0.0 };
    /// Whether the map changes nothing (then the module has no trace of it).
    pub fn is_identity(&self) -> bool {
        *self == Self::IDENTITY
    }
}

impl Default for SampleMap {
    fn default() -> Self {
        Self::IDENTITY
    }
}

/// How `eval` reads the samples.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FetchMode {
    /// One exact `textureLoad` per stencil sample.
    #[default]
    Exact,
    /// Hardware linear filtering: pairs of adjacent samples (box-spline
    /// weights are non-negative) become one `textureSampleLevel` at the
    /// weighted position. Packed layout: any filter, pairs within each coset
    /// grid (a linear sampler at binding + 4 on the packed texture, bound as
    /// filterable; see [`linear`](super::linear)). Embedded layout: one-coset tensor
    /// products in the factored form, groups of 2^s as trilinear fetches
    /// (a filterable texture and a linear sampler at binding + 4). Real GPUs
    /// interpolate with about 8-bit weights; `eval_grad` keeps exact loads
    /// (derivative weights change sign).
    Linear,
}

impl FetchMode {
    /// The name used on the command line (and in reports).
    pub fn name(self) -> &'static str {
        match self {
            FetchMode::Exact => "exact",
            FetchMode::Linear => "linear",
        }
    }
    /// The value named `s` (see [`name`](Self::name)); None for any other string.
    pub fn parse(s: &str) -> Option<FetchMode> {
        match s {
            "exact" => Some(FetchMode::Exact),
            "linear" => Some(FetchMode::Linear),
            _ => None,
        }
    }
}

/// What a fetch does with positions outside the volume.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Bounds {
    /// Clamp every fetch to the volume (`textureDimensions`): safe for any input.
    #[default]
    Clamp,
    /// No clamp: for callers that pad their volumes by the filter's support
    /// (WebGPU's robust access still keeps stray reads in bounds).
    Unchecked,
}

impl Bounds {
    /// The name used on the command line (and in reports).
    pub fn name(self) -> &'static str {
        match self {
            Bounds::Clamp => "clamp",
            Bounds::Unchecked => "unchecked",
        }
    }
    /// The value named `s` (see [`name`](Self::name)); None for any other string.
    pub fn parse(s: &str) -> Option<Bounds> {
        match s {
            "clamp" => Some(Bounds::Clamp),
            "unchecked" => Some(Bounds::Unchecked),
            _ => None,
        }
    }
}

impl Default for EmitOptions {
    fn default() -> Self {
        EmitOptions {
            layout: Layout::Embedded,
            variant: Variant::Fast,
            group: 0,
            binding: 0,
            kernels: true,
            command: "boxforge generate".into(),
            form: None,
            bounds: Bounds::Clamp,
            fetch: FetchMode::Exact,
            samples: SampleMap::IDENTITY,
            texels: Texels::Float,
        }
    }
}
