//! Other shading languages: the validated WGSL module translated by naga's
//! backends into SPIR-V, GLSL (core and ES), HLSL and MSL (issue 25).
//!
//! The WGSL that [`crate::emit`] writes stays the one source: every target
//! is a translation of it, made after naga has validated it, so the
//! mathematics (and the branch-free shape, checked again on the SPIR-V) is
//! the same in every language. What a user of each language gets:
//!
//! | target | library (the evaluation functions) | kernels (complete compute shaders) |
//! |---|---|---|
//! | `spirv` | none: a function-only SPIR-V module needs `Linkage`, which Vulkan does not take | one binary module per entry point, `<stem>.<kernel>.spv`, and `<stem>.spirv.txt` listing their bindings |
//! | `glsl`, `glsl-es` | `<stem>.glsl` / `<stem>.es.glsl`: to paste or `#include` after the user's `#version` line | one shader per entry point, `<stem>.<kernel>.comp` / `.es.comp` |
//! | `hlsl` | `<stem>.hlsl`, to `#include` | `<stem>.kernels.hlsl`, every entry point in one file |
//! | `msl` | `<stem>.metal`, to `#include` | `<stem>.kernels.metal` |
//!
//! The kernels are the module's own (`<f>_prefilter_main`, `<f>_minmax_main`)
//! plus `<f>_eval_main`, added here ([`modules`]): it evaluates `<f>_eval`
//! and `<f>_eval_grad` at every point of a buffer, so the evaluation
//! functions are reachable from an entry point (GLSL and SPIR-V write only
//! what an entry point reaches) and a host can run them as they are.
//!
//! GLSL and HLSL backends write one program per entry point, so the library
//! is translated through a stub entry point that calls every function of
//! the module and uses no resource of its own; the stub is cut from the
//! text afterwards (GLSL also loses its `#version` and `local_size` lines,
//! which belong to the including shader). The public names are kept (naga's
//! namer leaves `<f>_eval` alone: it only changes reserved words and names
//! ending in a digit); [`check::check_translated`] proves it for every unit,
//! and a translation in which a backend changed a public name is refused
//! with [`BackError::Renamed`] rather than shipped with a mapping.
//!
//! Every text unit starts with a header: the WGSL header (which names the
//! generating command), the language version, and every binding the host
//! must provide as the backend emitted it ([`TargetBinding`]).

pub mod check;
pub mod compilers;
pub mod header;
pub mod modules;
pub mod spirv;
#[cfg(feature = "targets")]
pub mod spirv_writer;
#[cfg(feature = "targets")]
pub mod text;

use crate::validate::Binding;
pub use check::check_translated;
use serde::Serialize;

/// A shading language boxforge writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Target {
    /// WGSL, as emitted (no translation).
    Wgsl,
    /// Vulkan SPIR-V binaries, one per compute entry point.
    Spirv,
    /// GLSL 4.50 core (OpenGL 4.5).
    Glsl,
    /// GLSL ES 3.10 (OpenGL ES 3.1, the first ES with compute shaders).
    GlslEs,
    /// HLSL shader model 5.1.
    Hlsl,
    /// Metal Shading Language 2.1.
    Msl,
}

/// Every target, in the order the CLI lists them.
pub const ALL_TARGETS: [Target; 6] =
    [Target::Wgsl, Target::Spirv, Target::Glsl, Target::GlslEs, Target::Hlsl, Target::Msl];

impl Target {
    /// The name on the command line (`--target`).
    pub fn name(self) -> &'static str {
        match self {
            Target::Wgsl => "wgsl",
            Target::Spirv => "spirv",
            Target::Glsl => "glsl",
            Target::GlslEs => "glsl-es",
            Target::Hlsl => "hlsl",
            Target::Msl => "msl",
        }
    }

    /// The target named `s` (see [`name`](Self::name)); None otherwise.
    pub fn parse(s: &str) -> Option<Target> {
        ALL_TARGETS.into_iter().find(|t| t.name() == s)
    }

    /// The language and version the translation is written in (named in
    /// every header).
    pub fn language(self) -> &'static str {
        match self {
            Target::Wgsl => "WGSL",
            Target::Spirv => "SPIR-V 1.3 (Vulkan 1.1)",
            Target::Glsl => "GLSL 4.50 core",
            Target::GlslEs => "GLSL ES 3.10",
            Target::Hlsl => "HLSL shader model 5.1",
            Target::Msl => "Metal Shading Language 2.1",
        }
    }
}

impl std::fmt::Display for Target {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The contents of one output file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Code {
    /// Source text (every language but SPIR-V, and SPIR-V's binding list).
    Text(String),
    /// A SPIR-V binary, as words (written little-endian).
    Words(Vec<u32>),
}

impl Code {
    /// The bytes of the file: the text, or the words little-endian.
    pub fn bytes(&self) -> Vec<u8> {
        match self {
            Code::Text(t) => t.clone().into_bytes(),
            Code::Words(w) => w.iter().flat_map(|w| w.to_le_bytes()).collect(),
        }
    }

    /// The text, or None for a binary.
    pub fn text(&self) -> Option<&str> {
        match self {
            Code::Text(t) => Some(t),
            Code::Words(_) => None,
        }
    }
}

/// What one output file is for.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// The evaluation functions and their resources, to include.
    Library,
    /// Complete compute shaders (the entry points are in [`Unit::entry_points`]).
    Kernels,
    /// SPIR-V's header: the command, version and bindings of its binaries.
    Manifest,
}

/// Where the host binds a resource, in the target's own terms.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum TargetSlot {
    /// Vulkan: descriptor set and binding (SPIR-V `DescriptorSet` / `Binding`).
    DescriptorSet {
        /// The descriptor set (the WGSL group).
        set: u32,
        /// The binding in the set (the WGSL binding).
        binding: u32,
    },
    /// OpenGL: `layout(binding = N)`, a texture unit for samplers and the
    /// buffer binding point for blocks (GL has no groups: the WGSL binding).
    GlBinding {
        /// The binding point.
        binding: u32,
    },
    /// Direct3D: a register (`t0`, `u1`, `b2`, `s4`) in a register space.
    Register {
        /// The register, class letter and number.
        register: String,
        /// The register space (the WGSL group).
        space: u32,
    },
    /// Metal: an argument index of a kernel (`texture(0)`, `buffer(1)`,
    /// `sampler(4)`); library functions take the resource as an argument.
    MetalIndex {
        /// The attribute, e.g. `texture(0)`.
        index: String,
    },
    /// Nothing to bind separately: GLSL has no separate samplers, the
    /// sampler state belongs to the combined sampler named here.
    CombinedWith {
        /// The GLSL name of the combined texture-sampler.
        texture: String,
    },
}

impl std::fmt::Display for TargetSlot {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TargetSlot::DescriptorSet { set, binding } => write!(f, "set {set} binding {binding}"),
            TargetSlot::GlBinding { binding } => write!(f, "binding {binding}"),
            TargetSlot::Register { register, space } => write!(f, "register({register}, space{space})"),
            TargetSlot::MetalIndex { index } => write!(f, "[[{index}]]"),
            TargetSlot::CombinedWith { texture } => write!(f, "sampler state of {texture}"),
        }
    }
}

/// One resource the host must provide, as the backend emitted it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct TargetBinding {
    /// The WGSL binding (group, binding, name, kind, format, purpose).
    pub wgsl: Binding,
    /// The name of the resource in the translated code (naga renames
    /// GLSL resources `_group_G_binding_B_cs`; the others keep the WGSL name).
    pub name_in_target: String,
    /// Where the host binds it.
    pub slot: TargetSlot,
}

/// One output file of a translation.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Unit {
    /// The file name, e.g. `bcc7.embedded.glsl` or `bcc7.embedded.eval.spv`.
    pub file_name: String,
    /// Library, kernels or manifest.
    pub role: Role,
    /// The contents (the header included for text).
    pub code: Code,
    /// The public functions the unit defines, by their names in the target
    /// (the WGSL names: [`check_translated`] refuses a rename).
    pub functions: Vec<String>,
    /// The compute entry points (kernels), by name in the target (GLSL: every
    /// kernel file's entry point is `main`; the WGSL name is given here).
    pub entry_points: Vec<String>,
    /// The resources this unit declares.
    pub bindings: Vec<TargetBinding>,
}

/// A module in one target language.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Translated {
    /// The language.
    pub target: Target,
    /// The filter, `<f>` in `<f>_eval`.
    pub filter: String,
    /// The dimension (2 or 3): `<f>_eval` takes a `vec2` or a `vec3`.
    pub dim: usize,
    /// Functions whose SPIR-V call trees must hold no branch, loop or kill:
    /// `<f>_fetch`, `<f>_eval` and `<f>_eval_grad` where the WGSL proof
    /// holds for them (the fast variant), none for the naive variant.
    pub branch_free: Vec<String>,
    /// The output files, library first.
    pub units: Vec<Unit>,
}

/// Options of a translation. The language versions are fixed (the ones
/// [`Target::language`] names and the compilers here check).
#[derive(Clone, Debug, Default)]
pub struct TranslateOptions {
    /// Leave out the eval kernel `<f>_eval_main` (SPIR-V then proves
    /// nothing about the evaluation functions; off by default).
    pub no_eval_kernel: bool,
}

/// Why a module could not be translated. Each message names the fix or
/// the targets that work.
#[derive(Debug, thiserror::Error)]
pub enum BackError {
    /// The WGSL does not parse or validate (naga's message).
    #[error("{file}: the WGSL module does not validate, so it cannot be translated: {message}")]
    InvalidWgsl {
        /// The module's file name.
        file: String,
        /// naga's message.
        message: String,
    },
    /// The module has no `<f>_eval_grad`, so it is not a boxforge module.
    #[error("{file}: no function named <filter>_eval_grad: only modules emitted by boxforge can be translated")]
    NotABoxforgeModule {
        /// The module's file name.
        file: String,
    },
    /// A naga backend refused the module.
    #[error("{file}: naga's {target} backend refused it: {message}; the other targets (wgsl, spirv, glsl, glsl-es, hlsl, msl) may still work")]
    Backend {
        /// The file that would have been written.
        file: String,
        /// The target.
        target: Target,
        /// The backend's message.
        message: String,
    },
    /// A backend renamed a public function or resource.
    #[error("{file}: the {target} backend renamed `{name}` (a reserved word or prefix in {target}): rename the filter so that `{name}` is a plain identifier there")]
    Renamed {
        /// The file.
        file: String,
        /// The target.
        target: Target,
        /// The WGSL name that was not kept.
        name: String,
    },
    /// A translation that does not say what it contains: a binding in the
    /// header missing from the code, a branch in an evaluation function's
    /// SPIR-V, a malformed binary (a boxforge bug).
    #[error("{file}: the {target} translation fails its check: {message} (this is a boxforge bug; please report it)")]
    Check {
        /// The file.
        file: String,
        /// The target.
        target: Target,
        /// What is wrong.
        message: String,
    },
    /// A target whose naga back end this build of boxforge leaves out: the
    /// other languages are behind the `targets` feature, so that a build
    /// script writing WGSL does not compile four back ends.
    #[error("{file}: translating into {target} needs boxforge's `targets` feature (naga's non-WGSL back ends): add `features = [\"targets\"]` to the boxforge dependency")]
    TargetNotBuilt {
        /// The file that would have been written.
        file: String,
        /// The target.
        target: Target,
    },
    /// A target that this filter or option cannot have.
    #[error("{file}: {message}")]
    Unsupported {
        /// The file.
        file: String,
        /// Why, and which targets work.
        message: String,
    },
}

/// Translates one emitted WGSL module (`stem` names its files, e.g.
/// `bcc7.embedded`, from `bcc7.embedded.wgsl`) into `target`, then checks
/// the result ([`check_translated`]). WGSL gives the source back unchanged
/// as one library unit.
///
/// # Errors
///
/// [`BackError`]: a module that does not validate or is not boxforge's, a
/// backend's refusal, a renamed public name, a failed check.
pub fn translate(wgsl: &str, stem: &str, target: Target, opts: &TranslateOptions) -> Result<Translated, BackError> {
    let prepared = modules::Prepared::remembered(wgsl, stem, !opts.no_eval_kernel)?;
    let prepared = &*prepared;
    let units = match target {
        Target::Wgsl => vec![Unit {
            file_name: format!("{stem}.wgsl"),
            role: Role::Library,
            code: Code::Text(wgsl.to_string()),
            functions: prepared.public_functions.clone(),
            entry_points: prepared.original_entry_points.clone(),
            bindings: prepared
                .original_bindings
                .iter()
                .map(|b| TargetBinding {
                    wgsl: b.clone(),
                    name_in_target: b.name.clone(),
                    slot: TargetSlot::DescriptorSet { set: b.group, binding: b.binding },
                })
                .collect(),
        }],
        #[cfg(feature = "targets")]
        Target::Spirv => spirv_writer::translate(prepared)?,
        #[cfg(feature = "targets")]
        Target::Glsl | Target::GlslEs | Target::Hlsl | Target::Msl => text::translate(prepared, target)?,
        #[cfg(not(feature = "targets"))]
        _ => return Err(BackError::TargetNotBuilt { file: format!("{stem}.wgsl"), target }),
    };
    let t = Translated {
        target,
        filter: prepared.filter.clone(),
        dim: prepared.dim,
        branch_free: prepared.branch_free.clone(),
        units,
    };
    check_translated(&t)?;
    Ok(t)
}
