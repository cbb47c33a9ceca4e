//! Running the other shading languages' output (issue 25): the translated
//! module's evaluation functions executed as emitted and read back, so
//! `verify --target` can hold them to the exact evaluator.
//!
//! | target | runner | what runs |
//! |---|---|---|
//! | `spirv` | Vulkan | the emitted `<f>_eval_main` binary, through wgpu's passthrough |
//! | `glsl` | Vulkan | the emitted library + boxforge's GLSL entry point ([`mains`]), compiled by glslang, through passthrough |
//! | `hlsl` | Vulkan | the emitted library + boxforge's HLSL entry point, compiled by glslang's HLSL front end, through passthrough |
//! | `glsl` | OpenGL | the emitted library + the entry point as GLSL text, compiled by the GL driver (EGL, no window) |
//! | `wgsl` | Vulkan or GL | the WGSL module through wgpu (naga translates it: this tests the device, not a translation) |
//!
//! GLSL ES and MSL have no runner here (no ES-only driver; no Metal on Linux).

pub mod glslang;
pub mod mains;
pub mod vulkan;

#[cfg(feature = "gl-run")]
pub mod gl;

use crate::gpu::{Gpu, GpuError};
use crate::volume::DeviceVolume;
#[cfg(feature = "gl-run")]
use crate::volume::LatticeVolume;
use boxforge::back::{BackError, Role, Target, Translated};
#[cfg(feature = "gl-run")]
use boxforge::emit::Layout;

/// Where a translation runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "files", derive(serde::Serialize))]
#[cfg_attr(feature = "files", serde(rename_all = "lowercase"))]
pub enum Runner {
    /// The wgpu device (lavapipe here), SPIR-V by passthrough.
    Vulkan,
    /// An OpenGL 4.3+ driver through EGL (llvmpipe here), GLSL as text.
    Gl,
}

impl Runner {
    pub fn name(self) -> &'static str {
        match self {
            Runner::Vulkan => "vulkan",
            Runner::Gl => "gl",
        }
    }
}

/// Why a translation could not be run.
#[derive(Debug, thiserror::Error)]
pub enum TargetError {
    #[error(transparent)]
    Back(#[from] BackError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[cfg(feature = "gl-run")]
    #[error(transparent)]
    Gl(#[from] gl::GlError),
    #[error("{tool} is not installed; install it with: {install}")]
    MissingTool { tool: &'static str, install: &'static str },
    #[error("{label}: {by} rejected it:\n{message}")]
    Compile { label: String, by: String, message: String },
    #[error("scratch files for the compiler: {0}")]
    Io(#[from] std::io::Error),
    /// A Vulkan program asked to run without its device and volume.
    #[error("a Vulkan program needs its device and volume")]
    NoDevice,
    #[error("{target} cannot run on {runner}: {why}")]
    Unsupported { target: Target, runner: &'static str, why: String },
}

/// A translation ready to evaluate at points.
pub struct TargetEvaluator {
    program: Program,
    /// What runs: the compiler and the device or driver.
    pub how: String,
}

enum Program {
    Vulkan(vulkan::Program),
    #[cfg(feature = "gl-run")]
    Gl(Box<GlProgram>),
}

/// Unsupported, with the runs that do exist.
fn unsupported(target: Target, runner: Runner, why: &str) -> TargetError {
    TargetError::Unsupported {
        target,
        runner: runner.name(),
        why: format!("{why}; runs that exist: spirv, glsl and hlsl on vulkan, glsl on gl"),
    }
}

/// The library unit's text of a translation.
pub fn library(t: &Translated) -> Result<&str, TargetError> {
    t.units
        .iter()
        .find(|u| u.role == Role::Library)
        .and_then(|u| u.code.text())
        .ok_or_else(|| unsupported(t.target, Runner::Vulkan, "the translation has no library text"))
}

impl TargetEvaluator {
    /// Compiles what runs `t` on the wgpu device over `dv` (which must be
    /// the volume layout the module was emitted for).
    pub fn vulkan(gpu: &Gpu, t: &Translated, dv: &DeviceVolume) -> Result<TargetEvaluator, TargetError> {
        let f = &t.filter;
        let (words, entry, io, by) = match t.target {
            Target::Spirv => {
                let entry = format!("{f}_eval_main");
                let unit = t
                    .units
                    .iter()
                    .find(|u| u.entry_points.contains(&entry))
                    .ok_or_else(|| unsupported(t.target, Runner::Vulkan, "the translation has no eval kernel"))?;
                let boxforge::back::Code::Words(words) = &unit.code else {
                    return Err(unsupported(t.target, Runner::Vulkan, "the eval kernel is not a binary"));
                };
                let first = unit
                    .bindings
                    .iter()
                    .find(|b| b.wgsl.name == format!("{f}_points"))
                    .map(|b| b.wgsl.binding)
                    .ok_or_else(|| unsupported(t.target, Runner::Vulkan, "the eval kernel lists no points binding"))?;
                (words.clone(), entry, vulkan::Io::EvalKernel { first }, "the emitted SPIR-V binary".to_string())
            }
            Target::Glsl => {
                let source = mains::glsl(library(t)?, f, mains::GlslApi::Vulkan);
                let (words, by) = glslang::compile(&source, glslang::Source::Glsl, &format!("{f} GLSL"))?;
                (words, "main".to_string(), vulkan::Io::Set1, by)
            }
            Target::Hlsl => {
                let source = mains::hlsl(library(t)?, f);
                let (words, by) = glslang::compile(
                    &source,
                    glslang::Source::Hlsl { entry: mains::HLSL_ENTRY },
                    &format!("{f} HLSL"),
                )?;
                (words, mains::HLSL_ENTRY.to_string(), vulkan::Io::Set1, by)
            }
            Target::GlslEs => {
                return Err(unsupported(t.target, Runner::Vulkan, "GLSL ES is compiled (glslang) but not run"))
            }
            Target::Msl => return Err(unsupported(t.target, Runner::Vulkan, "no Metal driver on this machine")),
            Target::Wgsl => {
                return Err(unsupported(t.target, Runner::Vulkan, "WGSL runs through verify::verify, untranslated"))
            }
        };
        let label = format!("{f} {}", t.target);
        let program = vulkan::Program::new(gpu, &words, &entry, &label, dv, io)?;
        Ok(TargetEvaluator {
            program: Program::Vulkan(program),
            how: format!("{by} on {} (passthrough)", gpu.describe()),
        })
    }

    /// Compiles `t` (GLSL) for the OpenGL driver over `vol` in `layout`
    /// (linear fetches when the library combines a sampler with the texture).
    #[cfg(feature = "gl-run")]
    pub fn gl(t: &Translated, vol: &LatticeVolume, layout: Layout) -> Result<TargetEvaluator, TargetError> {
        if t.target != Target::Glsl {
            return Err(unsupported(t.target, Runner::Gl, "only GLSL runs on the OpenGL driver"));
        }
        let lib = library(t)?;
        // Linear fetches: GL keeps the filter with the texture (naga's
        // combined `sampler3D`), so the texture is set to filter linearly.
        let linear = t
            .units
            .iter()
            .flat_map(|u| &u.bindings)
            .any(|b| matches!(b.slot, boxforge::back::TargetSlot::CombinedWith { .. }));
        let context = gl::GlCompute::new()?;
        let how = format!("the GLSL text compiled by the driver: {}", context.describe());
        let source = mains::glsl(lib, &t.filter, mains::GlslApi::OpenGl);
        let samples = match layout {
            Layout::Bricked | Layout::BrickedPacked => {
                return Err(unsupported(t.target, Runner::Gl, "the OpenGL runner binds the embedded or packed layout"))
            }
            Layout::Embedded => GlSamples::Texture {
                dims: [vol.dims[0] as u32, vol.dims[1] as u32, vol.dims[2] as u32],
                data: vol.data.clone(),
                linear,
            },
            Layout::Packed => {
                let packed = vol.packed().map_err(|e| unsupported(t.target, Runner::Gl, &e.to_string()))?;
                GlSamples::Packed {
                    linear,
                    dims: packed.texture.map(|n| n as u32),
                    words: packed.words,
                    grid: bytemuck::cast_slice(&packed.grid).to_vec(),
                }
            }
        };
        Ok(TargetEvaluator { program: Program::Gl(Box::new(GlProgram { context, source, samples })), how })
    }

    /// (values, value + gradient) at every point.
    pub fn eval(
        &self,
        gpu: Option<&Gpu>,
        dv: Option<&DeviceVolume>,
        points: &[[f32; 4]],
    ) -> Result<(Vec<f32>, Vec<[f32; 4]>), TargetError> {
        match &self.program {
            Program::Vulkan(p) => match (gpu, dv) {
                (Some(gpu), Some(dv)) => p.eval(gpu, dv, points),
                _ => Err(TargetError::NoDevice),
            },
            #[cfg(feature = "gl-run")]
            Program::Gl(p) => p.eval(points),
        }
    }
}

#[cfg(feature = "gl-run")]
enum GlSamples {
    Texture {
        dims: [u32; 3],
        data: Vec<f32>,
        linear: bool,
    },
    /// The coset tiles' texture and the `<f>_grid` uniform.
    Packed {
        dims: [u32; 3],
        words: Vec<f32>,
        grid: Vec<u8>,
        linear: bool,
    },
}

#[cfg(feature = "gl-run")]
struct GlProgram {
    context: gl::GlCompute,
    source: String,
    samples: GlSamples,
}

#[cfg(feature = "gl-run")]
impl GlProgram {
    fn eval(&self, points: &[[f32; 4]]) -> Result<(Vec<f32>, Vec<[f32; 4]>), TargetError> {
        let mut values = Vec::with_capacity(points.len());
        let mut grads = Vec::with_capacity(points.len());
        let first = mains::GL_FIRST_BINDING;
        for chunk in points.chunks(vulkan::POINTS_PER_DISPATCH) {
            let n = chunk.len();
            let mut resources = match &self.samples {
                GlSamples::Texture { dims, data, linear } => {
                    vec![gl::GlResource::Texture3d { binding: 0, dims: *dims, data, linear: *linear }]
                }
                GlSamples::Packed { dims, words, grid, linear } => vec![
                    gl::GlResource::Texture3d { binding: 0, dims: *dims, data: words, linear: *linear },
                    gl::GlResource::Uniform { binding: 1, data: grid },
                ],
            };
            resources.push(gl::GlResource::Storage { binding: first, data: bytemuck::cast_slice(chunk) });
            let groups = [n.div_ceil(mains::WORKGROUP_SIZE as usize) as u32, 1, 1];
            let out = self.context.run(&self.source, &resources, &[(first + 1, n * 16), (first + 2, n * 4)], groups)?;
            grads.extend_from_slice(bytemuck::cast_slice::<u8, [f32; 4]>(&out[0]));
            values.extend_from_slice(bytemuck::cast_slice::<u8, f32>(&out[1]));
        }
        Ok((values, grads))
    }
}
