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
mod tests {
    use super::*;

    fn valid(source: &str) -> ValidationReport {
        let report = validate_wgsl(source, "test.wgsl");
        assert!(report.valid, "{}", report.error.as_deref().unwrap_or(""));
        assert!(report.error.is_none());
        report
    }

    fn get<'a>(report: &'a ValidationReport, name: &str) -> &'a FunctionReport {
        report.function(name).unwrap_or_else(|| panic!("no function {name} in {report:#?}"))
    }

    const BRANCH_FREE: &str = r#"
@group(0) @binding(0) var vol: texture_3d<f32>;
struct Coeffs { data: array<f32> }
@group(0) @binding(1) var<storage, read> coeffs: Coeffs;
struct Params { w: array<vec4<f32>, 4> }
@group(0) @binding(2) var<uniform> params: Params;
@group(0) @binding(3) var<storage, read_write> out: array<f32>;

fn fetch(p: vec3<i32>) -> f32 {
    return textureLoad(vol, p, 0).x;
}

fn weights(t: vec3<f32>) -> vec3<f32> {
    let a = t * t;
    return select(a, vec3<f32>(1.0) - a, t > vec3<f32>(0.5));
}

fn eval(p: vec3<f32>) -> f32 {
    let i = vec3<i32>(floor(p));
    let t = fract(p);
    let w = weights(t);
    let inside = ((t.x > 0.0) & (t.y < 1.0)) | (t.z == 0.5);
    let s = fetch(i) * w.x + fetch(i + vec3<i32>(1, 0, 0)) * w.y
        + textureLoad(vol, i + vec3<i32>(0, 1, 0), 0).x * w.z;
    let c = coeffs.data[u32(i.x)];
    let v = t[u32(i.y) % 3u];
    let u = params.w[u32(i.z) & 3u].y;
    return select(0.0, s + c + v + u, inside);
}

@compute @workgroup_size(8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    out[id.x] = eval(vec3<f32>(id));
}
"#;

    #[test]
    fn branch_free_function_passes_and_counts_loads() {
        let report = valid(BRANCH_FREE);
        let fetch = get(&report, "fetch");
        assert_eq!((fetch.loads, fetch.total_loads), (1, 1));
        let weights = get(&report, "weights");
        assert_eq!(weights.total_loads, 0);
        let eval = get(&report, "eval");
        assert!(!eval.entry_point);
        assert_eq!(eval.branches, 0);
        assert_eq!(eval.loops, 0);
        assert_eq!(eval.kills, 0);
        // Storage and uniform buffer indexing and a dynamic vector index are not tables.
        assert_eq!(eval.dynamic_array_indexing, 0);
        // One textureLoad and one storage-buffer read in the own body (the uniform read is
        // not a load), plus two calls to `fetch`.
        assert_eq!(eval.loads, 2);
        assert_eq!((eval.image_loads, fetch.image_loads), (1, 1));
        assert_eq!(eval.calls, vec!["weights", "fetch", "fetch"]);
        assert_eq!(eval.total_loads, 4);
        let main = get(&report, "main");
        assert!(main.entry_point);
        assert_eq!(main.calls, vec!["eval"]);
        assert_eq!(main.loads, 0);
        assert_eq!(main.total_loads, 4);
        assert!(main.is_branch_free());
        check_branch_free(&report, &["fetch", "weights", "eval", "main"]).unwrap();
        // The report is plain serialisable data.
        let json = serde_json::to_string(&report).unwrap();
        assert!(json.contains("\"total_loads\":4"), "{json}");
    }

    const BRANCHY: &str = r#"
fn with_if(x: f32) -> f32 {
    var y = x;
    if x > 0.0 {
        y = 1.0;
    }
    return y;
}

fn with_switch(i: i32) -> f32 {
    var y = 0.0;
    switch i {
        case 0: { y = 1.0; }
        default: { y = 2.0; }
    }
    return y;
}

fn with_for(n: i32) -> f32 {
    var s = 0.0;
    for (var k = 0; k < n; k++) {
        s += 1.0;
    }
    return s;
}

fn with_loop(n: i32) -> f32 {
    var s = 0.0;
    var k = 0;
    loop {
        s += 1.0;
        k++;
        continuing {
            break if k >= n;
        }
    }
    return s;
}

fn with_and(a: f32, b: f32) -> bool {
    return (a > 0.0) && (b > 0.0);
}

fn with_or(a: f32, b: f32) -> bool {
    return (a > 0.0) || (b > 0.0);
}

fn with_bitand(a: f32, b: f32) -> bool {
    return (a > 0.0) & (b > 0.0);
}

fn nested(n: i32) -> f32 {
    var s = 0.0;
    loop {
        {
            switch n {
                case 1: {
                    if s > 2.0 { s = 0.0; }
                }
                default: {}
            }
        }
        continuing {
            break if s > 3.0;
        }
    }
    return s;
}

@fragment
fn fs(@location(0) v: f32) -> @location(0) vec4<f32> {
    if v < 0.5 {
        discard;
    }
    return vec4<f32>(v);
}
"#;

    #[test]
    fn branches_loops_and_kills_are_detected() {
        let report = valid(BRANCHY);
        let counts = |name: &str| {
            let f = get(&report, name);
            (f.branches, f.loops, f.kills, f.dynamic_array_indexing)
        };
        assert_eq!(counts("with_if"), (1, 0, 0, 0));
        assert_eq!(counts("with_switch"), (1, 0, 0, 0));
        assert_eq!(counts("with_loop"), (0, 1, 0, 0));
        // `for` becomes a `Loop` whose exit test is an `If` inside the body.
        let with_for = get(&report, "with_for");
        assert_eq!(with_for.loops, 1);
        assert!(with_for.branches >= 1);
        // Runtime `&&` / `||` are lowered to an `If` (naga >= 28); `&` is not.
        assert_eq!(counts("with_and"), (1, 0, 0, 0));
        assert_eq!(counts("with_or"), (1, 0, 0, 0));
        assert_eq!(counts("with_bitand"), (0, 0, 0, 0));
        // Nested blocks: Loop body -> Block -> Switch case -> If.
        assert_eq!(counts("nested"), (2, 1, 0, 0));
        let fs = get(&report, "fs");
        assert!(fs.entry_point);
        assert_eq!((fs.branches, fs.kills), (1, 1));

        for name in ["with_if", "with_switch", "with_for", "with_loop", "with_and", "with_or", "nested", "fs"] {
            let err = check_branch_free(&report, &[name]).unwrap_err();
            assert!(err.contains(name), "{err}");
        }
        check_branch_free(&report, &["with_bitand"]).unwrap();
        let err = check_branch_free(&report, &["with_bitand", "with_if", "fs"]).unwrap_err();
        assert!(err.contains("with_if") && err.contains("fs") && !err.contains("with_bitand"), "{err}");
    }

    const TABLES: &str = r#"
var<private> table: array<f32, 4> = array<f32, 4>(1.0, 2.0, 3.0, 4.0);
var<workgroup> shared_table: array<f32, 64>;
const CONST_TABLE = array<f32, 4>(1.0, 2.0, 3.0, 4.0);

fn private_table(i: u32) -> f32 {
    return table[i];
}

fn let_table(i: u32) -> f32 {
    let t = array<f32, 4>(1.0, 2.0, 3.0, 4.0);
    return t[i];
}

fn var_table(i: u32) -> f32 {
    var t = array<f32, 4>(1.0, 2.0, 3.0, 4.0);
    return t[i];
}

fn const_table(i: u32) -> f32 {
    return CONST_TABLE[i];
}

fn arg_table(t: array<f32, 4>, i: u32) -> f32 {
    return t[i];
}

fn constant_index(i: u32) -> f32 {
    let t = array<f32, 4>(f32(i), 2.0, 3.0, 4.0);
    var v = array<f32, 4>(1.0, f32(i), 3.0, 4.0);
    return t[2] + table[1] + v[3] + CONST_TABLE[0];
}

@compute @workgroup_size(64)
fn cs(@builtin(local_invocation_index) i: u32) {
    shared_table[i] = f32(i);
    workgroupBarrier();
    table[i & 3u] = shared_table[63u - i];
}
"#;

    #[test]
    fn lookup_tables_are_detected_and_constant_indices_are_not() {
        let report = valid(TABLES);
        for name in ["private_table", "let_table", "var_table", "const_table", "arg_table"] {
            let f = get(&report, name);
            assert_eq!(f.dynamic_array_indexing, 1, "{name}: {f:?}");
            assert_eq!((f.branches, f.loops, f.kills), (0, 0, 0), "{name}");
            let err = check_branch_free(&report, &[name]).unwrap_err();
            assert!(err.contains(name) && err.contains("1 table lookups"), "{err}");
        }
        let constant = get(&report, "constant_index");
        assert_eq!(constant.dynamic_array_indexing, 0, "{constant:?}");
        check_branch_free(&report, &["constant_index"]).unwrap();
        // Workgroup arrays (store and load) and a private array store.
        assert_eq!(get(&report, "cs").dynamic_array_indexing, 3);
    }

    #[test]
    fn branchy_callee_makes_caller_branchy() {
        let report = valid(
            r#"
fn g(x: f32) -> f32 {
    if x > 0.0 {
        return 1.0;
    }
    return x;
}
fn h(x: f32) -> f32 {
    return x * 2.0;
}
fn f(x: f32) -> f32 {
    return h(g(x)) + h(x);
}
fn top(x: f32) -> f32 {
    return f(x) + f(-x);
}
"#,
        );
        let f = get(&report, "f");
        assert_eq!((f.branches, f.total_branches), (0, 1));
        assert_eq!(f.calls, vec!["g", "h", "h"]);
        assert_eq!(get(&report, "top").total_branches, 2);
        check_branch_free(&report, &["h"]).unwrap();
        let err = check_branch_free(&report, &["f"]).unwrap_err();
        assert!(err.contains("f (call tree: 1 branches"), "{err}");
        let err = check_branch_free(&report, &["h", "top"]).unwrap_err();
        assert!(err.contains("top (call tree: 2 branches") && !err.contains("h (call"), "{err}");
    }

    #[test]
    fn parse_error_is_reported_with_its_line() {
        let report = validate_wgsl("fn f() -> f32 {\n    let a = 1.0;\n    let x = ;\n    return a;\n}\n", "bad.wgsl");
        assert!(!report.valid);
        assert!(report.functions.is_empty());
        let error = report.error.clone().unwrap();
        assert!(error.contains("bad.wgsl:3:"), "{error}");
        assert!(check_branch_free(&report, &["f"]).unwrap_err().contains("failed validation"));
    }

    #[test]
    fn validation_error_is_reported_with_its_line() {
        // Parses, but the validator rejects two globals on one binding in one entry point.
        let source = "@group(0) @binding(0) var<storage, read> a: array<f32>;\n@group(0) @binding(0) var<storage, read_write> b: array<f32>;\n\n@compute @workgroup_size(1)\nfn cs() {\n    b[0] = a[0];\n}\n";
        assert!(naga::front::wgsl::parse_str(source).is_ok());
        let report = validate_wgsl(source, "collision.wgsl");
        assert!(!report.valid);
        let error = report.error.unwrap();
        assert!(error.contains("collision.wgsl:2:") && error.contains("conflict with other resource"), "{error}");
    }

    #[test]
    fn missing_function_is_an_error() {
        let report = valid("fn present() -> f32 { return 1.0; }\n");
        check_branch_free(&report, &["present"]).unwrap();
        let err = check_branch_free(&report, &["present", "absent"]).unwrap_err();
        assert!(err.contains("no such function: absent"), "{err}");
    }
}
