//! Runs a GLSL compute shader text as is on an OpenGL 4.3+ driver: a
//! headless EGL context (Mesa's surfaceless platform, llvmpipe here) and glow.
//! wgpu's GL backend translates WGSL itself, so it cannot run *our* GLSL
//! text; this runner hands the emitted text to the driver's own compiler.
//! Needs `libEGL.so.1` and Mesa's GL driver at run time (Debian: libegl1
//! libegl-mesa0 libgl1-mesa-dri); it is loaded when a context is opened.

use glow::HasContext;
use khronos_egl as egl;

/// `EGL_PLATFORM_SURFACELESS_MESA`: a display without a window system.
const PLATFORM_SURFACELESS_MESA: egl::Enum = 0x31DD;

/// Why the GL runner could not run a shader.
#[derive(Debug, thiserror::Error)]
pub enum GlError {
    #[error("no EGL library (libEGL.so.1): {0}; on Debian install libegl1 libegl-mesa0 libgl1-mesa-dri")]
    NoEgl(String),
    #[error("EGL could not open a headless OpenGL 4.3 context: {0}")]
    Context(String),
    #[error("the OpenGL driver rejected the compute shader:\n{0}")]
    Compile(String),
    #[error("the OpenGL driver could not link the compute shader:\n{0}")]
    Link(String),
    #[error("OpenGL call failed: {0}")]
    Call(String),
}

/// One resource the shader reads, at its `layout(binding = N)`.
pub enum GlResource<'a> {
    /// A single-channel f32 3D texture (`sampler3D`), nearest or linear
    /// filtering, clamped to the edge, on texture unit `binding`.
    Texture3d { binding: u32, dims: [u32; 3], data: &'a [f32], linear: bool },
    /// A shader storage buffer (`buffer`), read-only use.
    Storage { binding: u32, data: &'a [u8] },
    /// A uniform block (`uniform`).
    Uniform { binding: u32, data: &'a [u8] },
}

/// A current headless GL context on this thread (EGL contexts are
/// per-thread: make one where it is used).
pub struct GlCompute {
    egl: egl::DynamicInstance<egl::EGL1_5>,
    display: egl::Display,
    context: egl::Context,
    gl: glow::Context,
}

impl GlCompute {
    /// Opens the context: OpenGL 4.5 core, else 4.3 core (compute shaders).
    pub fn new() -> Result<GlCompute, GlError> {
        let egl = unsafe { egl::DynamicInstance::<egl::EGL1_5>::load_required() }
            .map_err(|e| GlError::NoEgl(e.to_string()))?;
        let display =
            unsafe { egl.get_platform_display(PLATFORM_SURFACELESS_MESA, egl::DEFAULT_DISPLAY, &[egl::ATTRIB_NONE]) }
                .map_err(|e| GlError::Context(format!("surfaceless display: {e}")))?;
        egl.initialize(display).map_err(|e| GlError::Context(format!("eglInitialize: {e}")))?;
        egl.bind_api(egl::OPENGL_API).map_err(|e| GlError::Context(format!("eglBindAPI(OpenGL): {e}")))?;
        let config = egl
            .choose_first_config(
                display,
                &[egl::SURFACE_TYPE, egl::PBUFFER_BIT, egl::RENDERABLE_TYPE, egl::OPENGL_BIT, egl::NONE],
            )
            .map_err(|e| GlError::Context(format!("eglChooseConfig: {e}")))?
            .ok_or_else(|| GlError::Context("no EGL config renders OpenGL".into()))?;
        let mut context = Err(GlError::Context("no context".into()));
        for minor in [5, 3] {
            let attributes = [
                egl::CONTEXT_MAJOR_VERSION,
                4,
                egl::CONTEXT_MINOR_VERSION,
                minor,
                egl::CONTEXT_OPENGL_PROFILE_MASK,
                egl::CONTEXT_OPENGL_CORE_PROFILE_BIT,
                egl::NONE,
            ];
            context = egl
                .create_context(display, config, None, &attributes)
                .map_err(|e| GlError::Context(format!("OpenGL 4.{minor} core: {e}")));
            if context.is_ok() {
                break;
            }
        }
        let context = context?;
        egl.make_current(display, None, None, Some(context))
            .map_err(|e| GlError::Context(format!("eglMakeCurrent: {e}")))?;
        let gl = unsafe {
            glow::Context::from_loader_function(|name| {
                egl.get_proc_address(name).map_or(std::ptr::null(), |p| p as *const _)
            })
        };
        Ok(GlCompute { egl, display, context, gl })
    }

    /// `OpenGL <version> on <renderer>`, for reports.
    pub fn describe(&self) -> String {
        unsafe {
            format!(
                "OpenGL {} on {}",
                self.gl.get_parameter_string(glow::VERSION),
                self.gl.get_parameter_string(glow::RENDERER)
            )
        }
    }

    /// Compiles `source` (a complete `#version` compute shader), binds
    /// `resources`, dispatches `groups` and returns the bytes of each output
    /// storage buffer `(binding, length in bytes)`, zero-filled first.
    pub fn run(
        &self,
        source: &str,
        resources: &[GlResource],
        outputs: &[(u32, usize)],
        groups: [u32; 3],
    ) -> Result<Vec<Vec<u8>>, GlError> {
        let gl = &self.gl;
        unsafe {
            let program = self.program(source)?;
            let mut textures = Vec::new();
            let mut buffers = Vec::new();
            for r in resources {
                match *r {
                    GlResource::Texture3d { binding, dims, data, linear } => {
                        let t = gl.create_texture().map_err(GlError::Call)?;
                        gl.active_texture(glow::TEXTURE0 + binding);
                        gl.bind_texture(glow::TEXTURE_3D, Some(t));
                        gl.pixel_store_i32(glow::UNPACK_ALIGNMENT, 4);
                        gl.tex_image_3d(
                            glow::TEXTURE_3D,
                            0,
                            glow::R32F as i32,
                            dims[0] as i32,
                            dims[1] as i32,
                            dims[2] as i32,
                            0,
                            glow::RED,
                            glow::FLOAT,
                            glow::PixelUnpackData::Slice(Some(bytemuck::cast_slice(data))),
                        );
                        let filter = if linear { glow::LINEAR } else { glow::NEAREST } as i32;
                        gl.tex_parameter_i32(glow::TEXTURE_3D, glow::TEXTURE_MIN_FILTER, filter);
                        gl.tex_parameter_i32(glow::TEXTURE_3D, glow::TEXTURE_MAG_FILTER, filter);
                        for wrap in [glow::TEXTURE_WRAP_S, glow::TEXTURE_WRAP_T, glow::TEXTURE_WRAP_R] {
                            gl.tex_parameter_i32(glow::TEXTURE_3D, wrap, glow::CLAMP_TO_EDGE as i32);
                        }
                        textures.push(t);
                    }
                    GlResource::Storage { binding, data } => {
                        buffers.push(self.buffer(glow::SHADER_STORAGE_BUFFER, binding, data)?)
                    }
                    GlResource::Uniform { binding, data } => {
                        buffers.push(self.buffer(glow::UNIFORM_BUFFER, binding, data)?)
                    }
                }
            }
            let mut outs = Vec::new();
            for &(binding, bytes) in outputs {
                outs.push(self.buffer(glow::SHADER_STORAGE_BUFFER, binding, &vec![0u8; bytes.max(4)])?);
            }
            gl.use_program(Some(program));
            gl.dispatch_compute(groups[0], groups[1], groups[2]);
            gl.memory_barrier(glow::BUFFER_UPDATE_BARRIER_BIT | glow::SHADER_STORAGE_BARRIER_BIT);
            let mut results = Vec::new();
            for (&(_, bytes), &b) in outputs.iter().zip(&outs) {
                let mut out = vec![0u8; bytes];
                gl.bind_buffer(glow::SHADER_STORAGE_BUFFER, Some(b));
                gl.get_buffer_sub_data(glow::SHADER_STORAGE_BUFFER, 0, &mut out);
                results.push(out);
            }
            let error = gl.get_error();
            for b in outs.into_iter().chain(buffers) {
                gl.delete_buffer(b);
            }
            for t in textures {
                gl.delete_texture(t);
            }
            gl.delete_program(program);
            if error != glow::NO_ERROR {
                return Err(GlError::Call(format!("glGetError 0x{error:x} after the dispatch")));
            }
            Ok(results)
        }
    }

    unsafe fn program(&self, source: &str) -> Result<glow::Program, GlError> {
        let gl = &self.gl;
        unsafe {
            let shader = gl.create_shader(glow::COMPUTE_SHADER).map_err(GlError::Call)?;
            gl.shader_source(shader, source);
            gl.compile_shader(shader);
            if !gl.get_shader_compile_status(shader) {
                let log = gl.get_shader_info_log(shader);
                gl.delete_shader(shader);
                return Err(GlError::Compile(log));
            }
            let program = gl.create_program().map_err(GlError::Call)?;
            gl.attach_shader(program, shader);
            gl.link_program(program);
            gl.delete_shader(shader);
            if !gl.get_program_link_status(program) {
                let log = gl.get_program_info_log(program);
                gl.delete_program(program);
                return Err(GlError::Link(log));
            }
            Ok(program)
        }
    }

    unsafe fn buffer(&self, target: u32, binding: u32, data: &[u8]) -> Result<glow::Buffer, GlError> {
        let gl = &self.gl;
        unsafe {
            let b = gl.create_buffer().map_err(GlError::Call)?;
            gl.bind_buffer(target, Some(b));
            gl.buffer_data_u8_slice(target, data, glow::DYNAMIC_COPY);
            gl.bind_buffer_base(target, binding, Some(b));
            Ok(b)
        }
    }
}

impl Drop for GlCompute {
    fn drop(&mut self) {
        let _ = self.egl.make_current(self.display, None, None, None);
        let _ = self.egl.destroy_context(self.display, self.context);
        let _ = self.egl.terminate(self.display);
    }
}
