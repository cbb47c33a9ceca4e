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
