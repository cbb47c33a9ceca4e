//! The two naga modules every translation starts from, made from one
//! emitted WGSL module:
//!
//! * the **library**: every function of the module and the resources they
//!   use, reachable from a stub entry point `<f>_library_stub` that calls
//!   each function with zero arguments and binds nothing of its own (GLSL
//!   needs an entry point to write anything; [`naga::compact`] then drops
//!   the kernels' resources, which the library does not use);
//! * the **kernels**: the module's entry points plus `<f>_eval_main`, which
//!   writes `<f>_eval` and `<f>_eval_grad` at every point of a buffer into
//!   two more (bindings after the module's last one, in its group).
//!
//! Both are parsed and validated here, once, for every target.

use super::BackError;
use crate::validate::bindings::bindings;
use crate::validate::Binding;
use naga::valid::{Capabilities, ModuleInfo, ValidationFlags, Validator};
use naga::{Module, ScalarKind, TypeInner};
use std::fmt::Write;

/// Invocations per workgroup of `<f>_eval_main` (one point each; x only,
/// so one dispatch covers up to 65535 x 64 points).
pub const EVAL_WORKGROUP_SIZE: u32 = 64;

/// A validated naga module with its analysis.
pub struct Validated {
    /// The module.
    pub module: Module,
    /// naga's analysis of it.
    pub info: ModuleInfo,
}

/// One emitted module, ready for every backend.
pub struct Prepared {
    /// File stem, e.g. `bcc7.embedded` (from `bcc7.embedded.wgsl`).
    pub stem: String,
    /// The filter name, `<f>`.
    pub filter: String,
    /// The WGSL module's leading `//` lines (they name the generating
    /// command, the filter, layout and form), each ending in a newline.
    pub wgsl_header: String,
    /// The dimension, from `<f>_eval`'s argument.
    pub dim: usize,
    /// Which of `<f>_fetch`, `<f>_eval`, `<f>_eval_grad` the WGSL proof
    /// holds for (no branch, loop, kill or table in the call tree).
    pub branch_free: Vec<String>,
    /// The module's functions (not entry points), in module order: the API.
    pub public_functions: Vec<String>,
    /// The entry points of the module as emitted.
    pub original_entry_points: Vec<String>,
    /// The bindings of the module as emitted (what a WGSL user binds).
    pub original_bindings: Vec<Binding>,
    /// The library module (only the stub entry point).
    pub library: Validated,
    /// Bindings the library uses.
    pub library_bindings: Vec<Binding>,
    /// The kernels module: the module's entry points and `<f>_eval_main`.
    pub kernels: Validated,
    /// Bindings of the kernels module (`entry_points` says which uses which).
    pub kernel_bindings: Vec<Binding>,
    /// The stub's name, `<f>_library_stub`.
    pub stub: String,
    /// `(group, first binding)` of `<f>_eval_main`'s three buffers, if added.
    pub eval_kernel_slots: Option<(u32, u32)>,
}

fn validate(module: Module, file: &str) -> Result<Validated, BackError> {
    let info = Validator::new(ValidationFlags::all(), Capabilities::default())
        .validate(&module)
        .map_err(|e| BackError::InvalidWgsl { file: file.to_string(), message: format!("{:?}", e.into_inner()) })?;
    Ok(Validated { module, info })
}

fn with_purposes(filter: &str, mut list: Vec<Binding>) -> Vec<Binding> {
    for b in &mut list {
        b.purpose = crate::validate::bindings::binding_purpose(filter, &b.name)
            .or_else(|| eval_kernel_purpose(filter, &b.name))
            .map(str::to_string);
    }
    list
}

/// What the host puts in `<f>_eval_main`'s buffers.
fn eval_kernel_purpose(filter: &str, name: &str) -> Option<&'static str> {
    Some(match name.strip_prefix(filter)?.strip_prefix('_')? {
        "points" => "The eval kernel's input: one point per invocation, lattice coordinates in xyz (xy in 2D, xyzw in 4D).",
        "values" => "The eval kernel's output: <f>_eval at each point.",
        "gradients" => "The eval kernel's output: <f>_eval_grad at each point (value, then the gradient; w = 0 in 2D; in 4D the gradient alone, the value being in values).",
        _ => return None,
    })
}

/// WGSL text of a scalar or vector type, for the stub's zero arguments.
fn wgsl_type(module: &Module, ty: naga::Handle<naga::Type>) -> Option<String> {
    let scalar = |s: naga::Scalar| -> Option<&'static str> {
        Some(match (s.kind, s.width) {
            (ScalarKind::Float, 4) => "f32",
            (ScalarKind::Sint, 4) => "i32",
            (ScalarKind::Uint, 4) => "u32",
            (ScalarKind::Bool, _) => "bool",
            _ => return None,
        })
    };
    match module.types[ty].inner {
        TypeInner::Scalar(s) => scalar(s).map(str::to_string),
        TypeInner::Vector { size, scalar: s } => Some(format!("vec{}<{}>", size as u8, scalar(s)?)),
        _ => None,
    }
}

/// How many prepared modules [`Prepared::remembered`] keeps: a caller that
/// translates one module into every target asks for it a few times in a row.
const REMEMBERED: usize = 4;

/// The most recently prepared modules, newest last, by (WGSL, stem, eval kernel).
type Remembered = std::collections::VecDeque<(String, String, bool, std::sync::Arc<Prepared>)>;

impl Prepared {
    /// [`Prepared::new`], remembered for the last few modules: translating
    /// one module into the five targets parses and validates it (three
    /// times, for the library and the kernels) once instead of five times,
    /// and naga's front end is most of a translation's cost.
    ///
    /// # Errors
    ///
    /// As [`Prepared::new`] (errors are not remembered).
    pub fn remembered(wgsl: &str, stem: &str, eval_kernel: bool) -> Result<std::sync::Arc<Prepared>, BackError> {
        static MEMO: std::sync::Mutex<Remembered> = std::sync::Mutex::new(std::collections::VecDeque::new());
        let same = |(w, s, e, _): &(String, String, bool, std::sync::Arc<Prepared>)| {
            w == wgsl && s == stem && *e == eval_kernel
        };
        if let Some((.., p)) = MEMO.lock().unwrap_or_else(|e| e.into_inner()).iter().find(|x| same(x)) {
            return Ok(p.clone());
        }
        let prepared = std::sync::Arc::new(Prepared::new(wgsl, stem, eval_kernel)?);
        let mut memo = MEMO.lock().unwrap_or_else(|e| e.into_inner());
        if !memo.iter().any(same) {
            if memo.len() == REMEMBERED {
                memo.pop_front();
            }
            memo.push_back((wgsl.to_string(), stem.to_string(), eval_kernel, prepared.clone()));
        }
        Ok(prepared)
    }

    /// Parses and validates `wgsl`, adds the stub and (with `eval_kernel`)
    /// `<f>_eval_main`, and splits it into the library and kernel modules.
    ///
    /// # Errors
    ///
    /// [`BackError::InvalidWgsl`] for WGSL naga rejects;
    /// [`BackError::NotABoxforgeModule`] without `<f>_eval_grad`.
    pub fn new(wgsl: &str, stem: &str, eval_kernel: bool) -> Result<Prepared, BackError> {
        let file = format!("{stem}.wgsl");
        let invalid = |message: String| BackError::InvalidWgsl { file: file.clone(), message };
        let original = naga::front::wgsl::parse_str(wgsl).map_err(|e| invalid(e.emit_to_string(wgsl)))?;
        let original = validate(original, &file)?;
        let filter = original
            .module
            .functions
            .iter()
            .find_map(|(_, f)| f.name.as_deref()?.strip_suffix("_eval_grad").map(str::to_string))
            .ok_or_else(|| BackError::NotABoxforgeModule { file: file.clone() })?;
        let report = crate::validate::analyze_module(&original.module, &original.info);
        let branch_free: Vec<String> = ["fetch", "eval", "eval_grad"]
            .iter()
            .map(|s| format!("{filter}_{s}"))
            .filter(|n| report.iter().any(|f| &f.name == n && f.is_branch_free()))
            .collect();
        let eval = original.module.functions.iter().find(|(_, f)| f.name.as_deref() == Some(&format!("{filter}_eval")));
        let dim = match eval.and_then(|(_, f)| f.arguments.first()).map(|a| &original.module.types[a.ty].inner) {
            Some(TypeInner::Vector { size, .. }) => *size as usize,
            _ => return Err(BackError::NotABoxforgeModule { file }),
        };
        let original_bindings = with_purposes(&filter, bindings(&original.module, &original.info));
        let original_entry_points = original.module.entry_points.iter().map(|ep| ep.name.clone()).collect();
        let public_functions: Vec<String> =
            original.module.functions.iter().filter_map(|(_, f)| f.name.clone()).collect();

        // The stub: every function, called with zero arguments.
        let stub = format!("{filter}_library_stub");
        let mut extra = format!("\n@compute @workgroup_size(1)\nfn {stub}() {{\n");
        for (_, f) in original.module.functions.iter() {
            let args: Option<Vec<String>> =
                f.arguments.iter().map(|a| wgsl_type(&original.module, a.ty).map(|t| format!("{t}()"))).collect();
            if let (Some(name), Some(args)) = (&f.name, args) {
                let _ = writeln!(extra, "    _ = {name}({});", args.join(", "));
            }
        }
        extra.push_str("}\n");

        let eval_kernel_slots = if eval_kernel {
            let group = original_bindings.first().map_or(0, |b| b.group);
            let next = original_bindings.iter().filter(|b| b.group == group).map(|b| b.binding + 1).max().unwrap_or(0);
            let (point, grad) = match dim {
                2 => ("xy", format!("vec4<f32>({filter}_eval_grad(p), 0.0)")),
                // 4D: eval_grad is a struct (WGSL has no vec5); the value is in `values`.
                4 => ("xyzw", format!("{filter}_eval_grad(p).gradient")),
                _ => ("xyz", format!("{filter}_eval_grad(p)")),
            };
            let _ = write!(
                extra,
                "
// boxforge's eval kernel: {filter}_eval and {filter}_eval_grad at every point.
@group({group}) @binding({b0}) var<storage, read> {filter}_points: array<vec4<f32>>;
@group({group}) @binding({b1}) var<storage, read_write> {filter}_values: array<f32>;
@group({group}) @binding({b2}) var<storage, read_write> {filter}_gradients: array<vec4<f32>>;

@compute @workgroup_size({EVAL_WORKGROUP_SIZE})
fn {filter}_eval_main(@builtin(global_invocation_id) gid: vec3<u32>) {{
    let i = gid.x;
    if (i >= arrayLength(&{filter}_points)) {{
        return;
    }}
    let p = {filter}_points[i].{point};
    {filter}_values[i] = {filter}_eval(p);
    {filter}_gradients[i] = {grad};
}}
",
                b0 = next,
                b1 = next + 1,
                b2 = next + 2,
            );
            Some((group, next))
        } else {
            None
        };
        let full_src = format!("{wgsl}{extra}");
        let full = naga::front::wgsl::parse_str(&full_src).map_err(|e| invalid(e.emit_to_string(&full_src)))?;

        let mut library = full.clone();
        library.entry_points.retain(|ep| ep.name == stub);
        naga::compact::compact(&mut library, naga::compact::KeepUnused::No);
        let library = validate(library, &file)?;
        let library_bindings = with_purposes(&filter, bindings(&library.module, &library.info));

        let mut kernels = full;
        kernels.entry_points.retain(|ep| ep.name != stub);
        let kernels = validate(kernels, &file)?;
        let kernel_bindings = with_purposes(&filter, bindings(&kernels.module, &kernels.info));

        let wgsl_header: String = wgsl.lines().take_while(|l| l.starts_with("//")).map(|l| format!("{l}\n")).collect();
        Ok(Prepared {
            stem: stem.to_string(),
            filter,
            dim,
            branch_free,
            wgsl_header,
            public_functions,
            original_entry_points,
            original_bindings,
            library,
            library_bindings,
            kernels,
            kernel_bindings,
            stub,
            eval_kernel_slots,
        })
    }

    /// The kernels' entry point names, module order (`<f>_eval_main` last).
    pub fn kernel_entry_points(&self) -> Vec<String> {
        self.kernels.module.entry_points.iter().map(|ep| ep.name.clone()).collect()
    }

    /// The short name of a kernel in file names: `eval`, `prefilter`, `minmax`.
    pub fn kernel_short_name<'a>(&self, entry_point: &'a str) -> &'a str {
        let s = entry_point.strip_prefix(&self.filter).and_then(|s| s.strip_prefix('_')).unwrap_or(entry_point);
        s.strip_suffix("_main").unwrap_or(s)
    }

    /// The kernels module's bindings that `entry_point` uses.
    pub fn bindings_of(&self, entry_point: &str) -> Vec<Binding> {
        self.kernel_bindings.iter().filter(|b| b.entry_points.iter().any(|e| e == entry_point)).cloned().collect()
    }
}

/// Validates a module again after a change (entry points removed).
///
/// # Errors
///
/// [`BackError::InvalidWgsl`] if naga rejects it (a boxforge bug).
pub fn revalidate(v: Validated, file: &str) -> Result<Validated, BackError> {
    validate(v.module, file)
}
