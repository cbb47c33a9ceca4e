//! WGSL validation and the static branch-free / table-free proof (docs/BOX_SPLINES.md §4).
//!
//! [`validate_wgsl`] parses a module with naga's WGSL front end, runs naga's validator
//! (all checks, default capabilities) and walks the IR of every function and entry point,
//! counting what the evaluation functions must not contain and the loads they perform.
//! [`check_branch_free`] then proves that named functions are branch-free over their whole
//! call tree.
//!
//! What is counted (see [`FunctionReport`]):
//! * branches: `Statement::If` and `Statement::Switch`. Since naga 28 a runtime `&&` / `||`
//!   lowers to an `If` (short-circuit), so it counts as a branch: emit `select()` and the
//!   non-short-circuit `&` / `|` on bools instead;
//! * loops: `Statement::Loop` (`for`, `while` and `loop` all become one);
//! * kills: `Statement::Kill` (`discard`);
//! * dynamic array indexing (lookup tables): `Expression::Access` whose base is an array
//!   value (a `let` or `const` array) or a pointer to an array in the function, private or
//!   workgroup address space. Dynamic indexing of vectors and matrices, and of storage or
//!   uniform buffers (a buffer read), is not counted; a constant index (`AccessIndex`) is not
//!   counted;
//! * loads: `Expression::ImageLoad` (`textureLoad`) plus `Expression::Load` whose pointer is an
//!   `Access` / `AccessIndex` chain rooted at a global in the storage address space.
//!   Loads through pointer-typed function arguments are not traced back to a global.

pub mod bindings;

pub use bindings::{bindings_of_wgsl, Binding};
use naga::valid::{Capabilities, FunctionInfo, ModuleInfo, ValidationFlags, Validator};
use naga::{AddressSpace, Block, Expression, Function, Handle, Module, Statement, TypeInner};

/// Counts for one function (or entry point).
///
/// The unprefixed counts cover the function's own body only; the `total_*` counts cover its
/// whole call tree: own counts plus, for every call site (in `calls`), the callee's totals.
/// A function called twice is therefore counted twice (its loads really happen twice).
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct FunctionReport {
    /// Function name, or the entry point name for entry points.
    pub name: String,
    /// Whether this is an entry point (`@compute`, `@vertex`, `@fragment`, ...).
    pub entry_point: bool,
    /// `If` + `Switch` statements in the own body (nested blocks included).
    pub branches: usize,
    /// `Loop` statements in the own body.
    pub loops: usize,
    /// `Kill` (`discard`) statements in the own body.
    pub kills: usize,
    /// Dynamic indexing of a value array or of a function/private/workgroup array (a table).
    pub dynamic_array_indexing: usize,
    /// `textureLoad`s plus loads from storage globals in the own body.
    pub loads: usize,
    /// `textureLoad`s alone in the own body (`loads` less the storage-buffer reads).
    pub image_loads: usize,
    /// Functions called from the own body, one entry per call site, in statement order.
    pub calls: Vec<String>,
    /// `branches` over the call tree.
    pub total_branches: usize,
    /// `loops` over the call tree.
    pub total_loops: usize,
    /// `kills` over the call tree.
    pub total_kills: usize,
    /// `dynamic_array_indexing` over the call tree.
    pub total_dynamic_array_indexing: usize,
    /// `loads` over the call tree (per call site).
    pub total_loads: usize,
}

impl FunctionReport {
    /// True when the call tree has no branch, loop, kill or lookup table.
    pub fn is_branch_free(&self) -> bool {
        self.total_branches == 0
            && self.total_loops == 0
            && self.total_kills == 0
            && self.total_dynamic_array_indexing == 0
    }
}

/// Result of [`validate_wgsl`].
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct ValidationReport {
    /// Whether naga parsed and validated the module.
    pub valid: bool,
    /// naga's message rendered with spans (`path:line:column`) when `valid` is false.
    pub error: Option<String>,
    /// Module functions in declaration order, then entry points. Empty when `valid` is false.
    pub functions: Vec<FunctionReport>,
}

impl ValidationReport {
    /// The report for the function or entry point called `name`.
    pub fn function(&self, name: &str) -> Option<&FunctionReport> {
        self.functions.iter().find(|f| f.name == name)
    }
}

/// Parses and validates WGSL with naga; on failure `valid = false` and `error` holds naga's
/// message rendered with spans (`emit_to_string_with_path`), naming `path`.
pub fn validate_wgsl(source: &str, path: &str) -> ValidationReport {
    let failed = |error: String| ValidationReport { valid: false, error: Some(error), functions: Vec::new() };
    let module = match naga::front::wgsl::parse_str(source) {
        Ok(module) => module,
        Err(e) => return failed(e.emit_to_string_with_path(source, path)),
    };
    let info = match Validator::new(ValidationFlags::all(), Capabilities::default()).validate(&module) {
        Ok(info) => info,
        Err(e) => return failed(e.emit_to_string_with_path(source, path)),
    };
    ValidationReport { valid: true, error: None, functions: analyze_module(&module, &info) }
}

/// Branch-free proof: every function in `required` must exist, and its call tree must have no
/// branch (`If`, `Switch`, including lowered `&&` / `||`), loop, kill or lookup table.
///
/// The error names every offending function with its call-tree totals, or the missing names,
/// or says the module did not validate.
///
/// # Errors
///
/// A message (not a crate error) when the module did not validate, a required
/// function is missing, or one is not branch-free.
pub fn check_branch_free(report: &ValidationReport, required: &[&str]) -> Result<(), String> {
    if !report.valid {
        return Err(format!("module failed validation: {}", report.error.as_deref().unwrap_or("(no message)")));
    }
    let mut missing = Vec::new();
    let mut branchy = Vec::new();
    for &name in required {
        match report.function(name) {
            None => missing.push(name.to_string()),
            Some(f) if !f.is_branch_free() => branchy.push(format!(
                "{} (call tree: {} branches, {} loops, {} kills, {} table lookups)",
                f.name, f.total_branches, f.total_loops, f.total_kills, f.total_dynamic_array_indexing
            )),
            Some(_) => {}
        }
    }
    let mut problems = Vec::new();
    if !missing.is_empty() {
        problems.push(format!("no such function: {}", missing.join(", ")));
    }
    if !branchy.is_empty() {
        problems.push(format!("not branch-free: {}", branchy.join("; ")));
    }
    if problems.is_empty() {
        Ok(())
    } else {
        Err(problems.join("; "))
    }
}

/// Counts for every function and entry point of an already validated module (`info` must be
/// the [`ModuleInfo`] naga's validator returned for `module`).
pub fn analyze_module(module: &Module, info: &ModuleInfo) -> Vec<FunctionReport> {
    let names: Vec<String> = module
        .functions
        .iter()
        .map(|(h, f)| f.name.clone().unwrap_or_else(|| format!("function#{}", h.index())))
        .collect();
    let own: Vec<Own> = module.functions.iter().map(|(h, f)| Own::of(module, f, &info[h])).collect();

    // Call-tree totals of module functions; WGSL forbids recursion and naga rejects it.
    let mut memo: Vec<Option<Totals>> = vec![None; own.len()];
    let mut reports: Vec<FunctionReport> = Vec::new();
    for (i, o) in own.iter().enumerate() {
        let totals = totals_of(i, &own, &mut memo, 0);
        reports.push(o.report(names[i].clone(), false, totals, &names));
    }
    for (i, ep) in module.entry_points.iter().enumerate() {
        let o = Own::of(module, &ep.function, info.get_entry_point(i));
        let mut totals = o.counts;
        for callee in &o.calls {
            totals.add(&totals_of(callee.index(), &own, &mut memo, 0));
        }
        reports.push(o.report(ep.name.clone(), true, totals, &names));
    }
    reports
}

#[derive(Debug, Clone, Copy, Default)]
struct Totals {
    branches: usize,
    loops: usize,
    kills: usize,
    tables: usize,
    loads: usize,
}

impl Totals {
    fn add(&mut self, o: &Totals) {
        self.branches += o.branches;
        self.loops += o.loops;
        self.kills += o.kills;
        self.tables += o.tables;
        self.loads += o.loads;
    }
}

/// Own-body counts and call sites of one function.
struct Own {
    counts: Totals,
    image_loads: usize,
    calls: Vec<Handle<Function>>,
}

impl Own {
    fn of(module: &Module, fun: &Function, info: &FunctionInfo) -> Own {
        let mut own = Own { counts: Totals::default(), image_loads: 0, calls: Vec::new() };
        own.walk_block(&fun.body);
        for (_, expr) in fun.expressions.iter() {
            match *expr {
                Expression::Access { base, .. } if is_table(module, info, base) => own.counts.tables += 1,
                Expression::ImageLoad { .. } => {
                    own.counts.loads += 1;
                    own.image_loads += 1;
                }
                Expression::Load { pointer } if loads_from_storage(module, fun, pointer) => own.counts.loads += 1,
                _ => {}
            }
        }
        own
    }

    fn walk_block(&mut self, block: &Block) {
        for statement in block.iter() {
            match *statement {
                Statement::Block(ref inner) => self.walk_block(inner),
                Statement::If { ref accept, ref reject, .. } => {
                    self.counts.branches += 1;
                    self.walk_block(accept);
                    self.walk_block(reject);
                }
                Statement::Switch { ref cases, .. } => {
                    self.counts.branches += 1;
                    for case in cases {
                        self.walk_block(&case.body);
                    }
                }
                Statement::Loop { ref body, ref continuing, .. } => {
                    self.counts.loops += 1;
                    self.walk_block(body);
                    self.walk_block(continuing);
                }
                Statement::Kill => self.counts.kills += 1,
                Statement::Call { function, .. } => self.calls.push(function),
                _ => {}
            }
        }
    }

    fn report(&self, name: String, entry_point: bool, totals: Totals, names: &[String]) -> FunctionReport {
        FunctionReport {
            name,
            entry_point,
            branches: self.counts.branches,
            loops: self.counts.loops,
            kills: self.counts.kills,
            dynamic_array_indexing: self.counts.tables,
            loads: self.counts.loads,
            image_loads: self.image_loads,
            calls: self.calls.iter().map(|h| names[h.index()].clone()).collect(),
            total_branches: totals.branches,
            total_loops: totals.loops,
            total_kills: totals.kills,
            total_dynamic_array_indexing: totals.tables,
            total_loads: totals.loads,
        }
    }
}

fn totals_of(i: usize, own: &[Own], memo: &mut [Option<Totals>], depth: usize) -> Totals {
    if let Some(t) = memo[i] {
        return t;
    }
    // Validated modules have no recursion; the depth guard only protects against misuse.
    assert!(depth <= own.len(), "recursive call graph in a validated module");
    let mut totals = own[i].counts;
    for callee in &own[i].calls {
        totals.add(&totals_of(callee.index(), own, memo, depth + 1));
    }
    memo[i] = Some(totals);
    totals
}

/// Whether `pointer` is an `Access` / `AccessIndex` chain rooted at a storage global.
fn loads_from_storage(module: &Module, fun: &Function, pointer: Handle<Expression>) -> bool {
    fun.originating_global(pointer)
        .is_some_and(|global| matches!(module.global_variables[global].space, AddressSpace::Storage { .. }))
}

/// Whether a dynamic `Access` on `base` indexes a lookup table: an array value, or a pointer to
/// an array in the function, private or workgroup address space.
fn is_table(module: &Module, info: &FunctionInfo, base: Handle<Expression>) -> bool {
    match *info[base].ty.inner_with(&module.types) {
        TypeInner::Array { .. } => true,
        TypeInner::Pointer { base: pointee, space } => {
            matches!(module.types[pointee].inner, TypeInner::Array { .. })
                && matches!(space, AddressSpace::Function | AddressSpace::Private | AddressSpace::WorkGroup)
        }
        _ => false,
    }
}

#[cfg(test)]
mod tests;
