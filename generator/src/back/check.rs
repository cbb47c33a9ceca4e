//! The check every translation passes before it is returned: the code says
//! what its header says. Every public function is defined under its WGSL
//! name, every entry point exists, every binding in the header is declared
//! in the code with that name and slot (and, in SPIR-V, no other), and the
//! evaluation functions that the WGSL proof holds for have no
//! `OpBranchConditional`, `OpSwitch`, loop or kill in their SPIR-V call trees.

use super::spirv::read;
use super::{BackError, Code, Role, Target, TargetSlot, Translated, Unit};

fn is_ident_byte(b: u8) -> bool {
    b.is_ascii_alphanumeric() || b == b'_'
}

/// Byte offsets where `name` occurs as a whole identifier in `text`.
fn ident_positions<'a>(text: &'a str, name: &'a str) -> impl Iterator<Item = usize> + 'a {
    text.match_indices(name).map(|(i, _)| i).filter(move |&i| {
        let before = text.as_bytes().get(i.wrapping_sub(1)).copied().filter(|_| i > 0);
        let after = text.as_bytes().get(i + name.len()).copied();
        !before.is_some_and(is_ident_byte) && !after.is_some_and(is_ident_byte)
    })
}

/// Whether `name` is defined as a function: the identifier followed by `(`.
fn defines_function(text: &str, name: &str) -> bool {
    ident_positions(text, name).any(|i| text[i + name.len()..].starts_with('('))
}

/// The lines of `text` on which `name` occurs as an identifier.
fn lines_with<'a>(text: &'a str, name: &'a str) -> Vec<&'a str> {
    text.lines().filter(|l| ident_positions(l, name).next().is_some()).collect()
}

fn fail(t: &Translated, u: &Unit, message: String) -> BackError {
    BackError::Check { file: u.file_name.clone(), target: t.target, message }
}

/// Checks a translation (see the module docs).
///
/// # Errors
///
/// [`BackError::Renamed`] for a public function or entry point the
/// backend renamed; [`BackError::Check`] for anything else that differs.
pub fn check_translated(t: &Translated) -> Result<(), BackError> {
    for u in &t.units {
        match &u.code {
            Code::Words(words) => check_spirv(t, u, words)?,
            Code::Text(text) if u.role != Role::Manifest => check_text(t, u, text)?,
            Code::Text(_) => {}
        }
    }
    Ok(())
}

fn check_text(t: &Translated, u: &Unit, text: &str) -> Result<(), BackError> {
    // The header lists every name; look at the code below it.
    let code = text.split_once("\n\n").map_or(text, |(_, c)| c);
    let renamed = |name: &str| BackError::Renamed { file: u.file_name.clone(), target: t.target, name: name.into() };
    for f in &u.functions {
        if !defines_function(code, f) {
            return Err(renamed(f));
        }
    }
    for ep in &u.entry_points {
        let name = if matches!(t.target, Target::Glsl | Target::GlslEs) { "main" } else { ep };
        if !defines_function(code, name) {
            return Err(renamed(ep));
        }
    }
    for b in &u.bindings {
        let lines = lines_with(code, &b.name_in_target);
        let declared = match &b.slot {
            // Every declaration agrees: OpenGL's and, for textures, the
            // `#ifdef VULKAN` twin's (`layout(set = G, binding = N)`).
            TargetSlot::GlBinding { binding } => {
                // A buffer block (4D samples: a header and an array) names
                // its instance on the closing line, `} NAME;`, and its
                // binding on the nearest `layout(..) buffer X {` above it.
                let all: Vec<&str> = code.lines().collect();
                let block_headers: Vec<&str> = all
                    .iter()
                    .enumerate()
                    .filter(|(_, l)| l.starts_with('}') && ident_positions(l, &b.name_in_target).next().is_some())
                    .filter_map(|(i, _)| all[..i].iter().rev().find(|l| l.starts_with("layout(")).copied())
                    .collect();
                let decls: Vec<&&str> =
                    lines.iter().filter(|l| l.starts_with("layout(")).chain(block_headers.iter()).collect();
                !decls.is_empty() && decls.iter().all(|l| l.contains(&format!("binding = {binding})")))
            }
            TargetSlot::CombinedWith { texture } => !texture.is_empty() && !lines_with(code, texture).is_empty(),
            TargetSlot::Register { register, space } => {
                let reg = if *space == 0 {
                    format!("register({register})")
                } else {
                    format!("register({register}, space{space})")
                };
                lines.iter().any(|l| l.contains(&reg))
            }
            TargetSlot::MetalIndex { index } if u.role == Role::Kernels => {
                lines.iter().any(|l| l.contains(&format!("[[{index}]]")))
            }
            TargetSlot::MetalIndex { .. } => !lines.is_empty(),
            TargetSlot::DescriptorSet { set, binding } => {
                lines.iter().any(|l| l.contains(&format!("@group({set}) @binding({binding})")))
            }
        };
        if !declared {
            return Err(fail(
                t,
                u,
                format!("the header's binding `{}` ({}) is not declared so in the code", b.name_in_target, b.slot),
            ));
        }
    }
    Ok(())
}

fn check_spirv(t: &Translated, u: &Unit, words: &[u32]) -> Result<(), BackError> {
    let m = read(words).map_err(|e| fail(t, u, e))?;
    if m.entry_points != u.entry_points {
        return Err(fail(t, u, format!("entry points {:?}, the manifest says {:?}", m.entry_points, u.entry_points)));
    }
    let mut found: Vec<(String, u32, u32)> =
        m.resources.iter().map(|r| (r.name.clone().unwrap_or_default(), r.set, r.binding)).collect();
    let mut listed: Vec<(String, u32, u32)> = u
        .bindings
        .iter()
        .map(|b| match b.slot {
            TargetSlot::DescriptorSet { set, binding } => (b.name_in_target.clone(), set, binding),
            _ => (b.name_in_target.clone(), u32::MAX, u32::MAX),
        })
        .collect();
    found.sort();
    listed.sort();
    if found != listed {
        return Err(fail(t, u, format!("descriptor bindings {found:?}, the manifest says {listed:?}")));
    }
    for f in &u.functions {
        if !m.functions.iter().any(|g| g.name.as_deref() == Some(f)) {
            return Err(BackError::Renamed { file: u.file_name.clone(), target: t.target, name: f.clone() });
        }
    }
    for f in t.branch_free.iter().filter(|f| u.functions.contains(f)) {
        match m.call_tree_branches(f) {
            Some(0) => {}
            Some(n) => {
                return Err(fail(t, u, format!("{f} has {n} branches, loops or kills in its SPIR-V call tree")));
            }
            None => return Err(fail(t, u, format!("{f} is not in the binary"))),
        }
    }
    Ok(())
}
