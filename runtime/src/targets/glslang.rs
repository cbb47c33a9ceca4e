//! GLSL and HLSL compiled to Vulkan SPIR-V by glslang (`glslangValidator
//! -V`, its HLSL front end with `-D`), then checked by `spirv-val`: the
//! binaries that run through wgpu's passthrough, so the driver gets what
//! glslang made of the emitted text and nothing of boxforge's in between.

use super::TargetError;
use boxforge::back::compilers::{glslang_version, spirv_val_version, INSTALL};
use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};

/// The source language of a compile.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source<'a> {
    Glsl,
    Hlsl { entry: &'a str },
}

/// `source` as SPIR-V words, accepted by spirv-val; `label` names the
/// shader in errors. The compiler's name and version in `.1`.
pub fn compile(source: &str, language: Source, label: &str) -> Result<(Vec<u32>, String), TargetError> {
    let version = glslang_version().ok_or(TargetError::MissingTool { tool: "glslangValidator", install: INSTALL })?;
    let val = spirv_val_version().ok_or(TargetError::MissingTool { tool: "spirv-val", install: INSTALL })?;
    static N: AtomicUsize = AtomicUsize::new(0);
    let dir =
        std::env::temp_dir().join(format!("boxforge-run-{}-{}", std::process::id(), N.fetch_add(1, Ordering::Relaxed)));
    std::fs::create_dir_all(&dir)?;
    let result = (|| {
        let (file, by) = match language {
            Source::Glsl => ("shader.comp", format!("glslangValidator {version} (GLSL to SPIR-V)")),
            Source::Hlsl { .. } => ("shader.hlsl", format!("glslangValidator {version} (HLSL front end to SPIR-V)")),
        };
        let path = dir.join(file);
        let out = dir.join("shader.spv");
        std::fs::write(&path, source)?;
        let mut cmd = Command::new("glslangValidator");
        cmd.args(["-V", "--target-env", "vulkan1.1"]);
        if let Source::Hlsl { entry } = language {
            cmd.args(["-D", "-S", "comp", "-e", entry]);
        }
        cmd.arg(&path).arg("-o").arg(&out);
        let o = cmd.output()?;
        if !o.status.success() {
            return Err(TargetError::Compile {
                label: label.to_string(),
                by,
                message: String::from_utf8_lossy(&o.stdout).trim().to_string(),
            });
        }
        let o = Command::new("spirv-val").args(["--target-env", "vulkan1.1"]).arg(&out).output()?;
        if !o.status.success() {
            return Err(TargetError::Compile {
                label: label.to_string(),
                by: format!("spirv-val {val}"),
                message: format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
                    .trim()
                    .to_string(),
            });
        }
        let bytes = std::fs::read(&out)?;
        let words = bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
        Ok((words, by))
    })();
    let _ = std::fs::remove_dir_all(&dir);
    result
}
