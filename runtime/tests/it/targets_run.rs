//! The other shading languages run as emitted (issue 25): SPIR-V, and GLSL
//! and HLSL compiled by glslang, on lavapipe through wgpu's passthrough;
//! GLSL as text on Mesa's OpenGL driver through EGL. Each is held to the
//! exact evaluator; a broken translation is caught; a GLSL program written
//! here by hand includes the emitted library and calls `bcc7_eval` by name.

use boxforge::back::{translate, Code, Role, Target, TranslateOptions, Translated};
use boxforge::derive::Derivation;
use boxforge::emit::{emit, EmitOptions, FetchMode, Layout, Variant};
use boxforge_runtime::targets::gl::{GlCompute, GlResource};
use boxforge_runtime::targets::{Runner, TargetEvaluator};
use boxforge_runtime::verify::target::verify_target;
use boxforge_runtime::verify::{data_range, random_points, random_volume, Tally};
use boxforge_runtime::volume::DeviceVolume;

const RUNS: [(Target, Runner); 4] = [
    (Target::Spirv, Runner::Vulkan),
    (Target::Glsl, Runner::Vulkan),
    (Target::Hlsl, Runner::Vulkan),
    (Target::Glsl, Runner::Gl),
];

fn three_d_filters() -> Vec<Derivation> {
    boxforge::spec::catalog::names()
        .into_iter()
        .map(|n| Derivation::new(&boxforge::spec::resolve(n).unwrap()).unwrap())
        .filter(|d| d.facts.dim == 3)
        .collect()
}

/// Every 3D catalog filter in every executable target, the layouts
/// alternating so that each target runs both and each filter runs both.
#[test]
fn every_filter_runs_in_every_executable_target_within_tolerance() {
    let gpu = crate::common::gpu();
    let filters = three_d_filters();
    assert!(filters.len() >= 8, "{}", filters.len());
    let mut ran = 0;
    for (k, d) in filters.iter().enumerate() {
        for (r, &(target, runner)) in RUNS.iter().enumerate() {
            let layout = if (k + r) % 2 == 0 { Layout::Embedded } else { Layout::Packed };
            let t = verify_target(
                Some(gpu),
                d,
                layout,
                Variant::Fast,
                FetchMode::Exact,
                target,
                runner,
                1500,
                7 + k as u64,
            )
            .unwrap_or_else(|e| panic!("{} {layout:?} {target} on {runner:?}: {e}", d.filter.name));
            let rep = &t.report;
            assert!(rep.passed, "{} {layout:?} {target} on {runner:?}: {rep:?}", d.filter.name);
            assert!(rep.max_abs_err <= 1e-5 * rep.data_range, "{rep:?}");
            ran += 1;
        }
    }
    eprintln!("targets run: {ran}/{} (filter x target, layouts alternating)", filters.len() * RUNS.len());
}

/// Linear (hardware-filtered) fetches in both layouts where a target can
/// express them: SPIR-V and GLSL on lavapipe (a texture and a separate
/// sampler at binding 4, so the runner's layout must keep the WGSL numbers:
/// see `targets::vulkan`), GLSL on GL (naga's combined sampler, the texture
/// set to filter linearly). HLSL refuses with a line saying why (naga's
/// HLSL has no plain sampler register).
#[test]
fn linear_fetches_run_in_spirv_and_glsl_and_hlsl_refuses_cleanly() {
    let gpu = crate::common::gpu();
    let get = |n: &str| Derivation::new(&boxforge::spec::resolve(n).unwrap()).unwrap();
    let run = |d: &Derivation, layout, target, runner, seed| {
        verify_target(Some(gpu), d, layout, Variant::Fast, FetchMode::Linear, target, runner, 1500, seed)
    };
    for (d, layout) in [(get("cc_tricubic"), Layout::Embedded), (get("bcc7"), Layout::Packed)] {
        for (target, runner) in
            [(Target::Spirv, Runner::Vulkan), (Target::Glsl, Runner::Vulkan), (Target::Glsl, Runner::Gl)]
        {
            // Two seeds: a sampler bound at the wrong descriptor gave values that changed from run to run.
            for seed in [1, 11] {
                let t = run(&d, layout, target, runner, seed)
                    .unwrap_or_else(|e| panic!("{} {layout:?} linear {target} on {runner:?}: {e}", d.filter.name));
                assert_eq!(t.report.fetch, FetchMode::Linear);
                let r = &t.report;
                assert!(r.passed && r.max_abs_err <= 1e-5 * r.data_range, "{target} on {runner:?}: {r:?}");
            }
        }
        let e = run(&d, layout, Target::Hlsl, Runner::Vulkan, 1).expect_err("HLSL has no linear sampler").to_string();
        assert!(e.contains("fetch = exact"), "{e}");
    }
}

/// wgpu numbers a group's Vulkan descriptors by rank; the runner fills the
/// holes below the highest binding so that passthrough SPIR-V, which keeps
/// the WGSL numbers, meets the right descriptors.
#[test]
fn the_passthrough_layout_has_no_holes() {
    use boxforge_runtime::gpu::binding::{storage_entry, uniform_entry};
    use boxforge_runtime::targets::vulkan::hole_entries;
    let entries = [uniform_entry(0), storage_entry(4, true), storage_entry(5, false)];
    let holes: Vec<u32> = hole_entries(&entries).iter().map(|e| e.binding).collect();
    assert_eq!(holes, vec![1, 2, 3]);
    assert!(hole_entries(&[uniform_entry(0), uniform_entry(1)]).is_empty());
}

fn translated(d: &Derivation, layout: Layout, target: Target) -> Translated {
    let m = emit(d, &EmitOptions { layout, kernels: false, ..Default::default() }).unwrap();
    translate(&m.source, m.file_name.trim_end_matches(".wgsl"), target, &TranslateOptions::default()).unwrap()
}

fn library_mut(t: &mut Translated) -> &mut String {
    match &mut t.units.iter_mut().find(|u| u.role == Role::Library).unwrap().code {
        Code::Text(s) => s,
        Code::Words(_) => panic!("a text library"),
    }
}

/// Runs `t` and reports whether it agrees with the exact evaluator.
fn agrees(d: &Derivation, t: &Translated, layout: Layout, runner: Runner) -> bool {
    let gpu = crate::common::gpu();
    let vol = random_volume(d, 3);
    let pts = random_points(d, &vol, 800, 5);
    let dv = DeviceVolume::new(gpu, &vol, layout).unwrap();
    let e = match runner {
        Runner::Vulkan => TargetEvaluator::vulkan(gpu, t, &dv).unwrap(),
        Runner::Gl => TargetEvaluator::gl(t, &vol, layout).unwrap(),
    };
    let (v, g) = e.eval(Some(gpu), Some(&dv), &pts).unwrap();
    let mut tally = Tally::new(data_range(&vol));
    tally.check(d, &vol, &pts, &v, &g);
    tally.passed()
}

/// The runs can fail: a sign flipped in the translated eval (GLSL on both
/// runners, HLSL), and another filter's SPIR-V binary, are caught.
#[test]
fn a_broken_translation_fails_the_check() {
    let d = Derivation::new(&boxforge::spec::resolve("bcc7").unwrap()).unwrap();
    for (target, runner) in [(Target::Glsl, Runner::Vulkan), (Target::Glsl, Runner::Gl), (Target::Hlsl, Runner::Vulkan)]
    {
        let good = translated(&d, Layout::Embedded, target);
        assert!(agrees(&d, &good, Layout::Embedded, runner), "{target} on {runner:?}");
        let mut bad = good.clone();
        let lib = library_mut(&mut bad);
        // The value's last line: `return <expr>;` in bcc7_eval, negated.
        let at = lib.find("bcc7_eval(").unwrap();
        let ret = at + lib[at..].find("return ").unwrap() + "return ".len();
        lib.insert(ret, '-');
        assert!(!agrees(&d, &bad, Layout::Embedded, runner), "{target} on {runner:?}: a negated eval passed");
    }
    // SPIR-V: bcc8's eval kernel handed bcc7's samples.
    let bcc8 = Derivation::new(&boxforge::spec::resolve("bcc8").unwrap()).unwrap();
    let good = translated(&d, Layout::Packed, Target::Spirv);
    assert!(agrees(&d, &good, Layout::Packed, Runner::Vulkan));
    let mut other = translated(&bcc8, Layout::Packed, Target::Spirv);
    other.filter = "bcc7".into();
    for u in &mut other.units {
        u.entry_points = u.entry_points.iter().map(|e| e.replace("bcc8", "bcc7")).collect();
        for b in &mut u.bindings {
            b.wgsl.name = b.wgsl.name.replace("bcc8", "bcc7");
        }
    }
    let renamed = other
        .units
        .iter()
        .any(|u| matches!(u.code, Code::Words(_)) && u.entry_points.contains(&"bcc7_eval_main".to_string()));
    assert!(renamed);
    // The binary still names its entry point bcc8_eval_main: give the driver that name.
    let gpu = crate::common::gpu();
    let vol = random_volume(&d, 3);
    let dv = DeviceVolume::new(gpu, &vol, Layout::Packed).unwrap();
    let words = match &other.units.iter().find(|u| u.entry_points.contains(&"bcc7_eval_main".to_string())).unwrap().code
    {
        Code::Words(w) => w.clone(),
        Code::Text(_) => unreachable!(),
    };
    let first =
        other.units.iter().flat_map(|u| &u.bindings).find(|b| b.wgsl.name == "bcc7_points").unwrap().wgsl.binding;
    let program = boxforge_runtime::targets::vulkan::Program::new(
        gpu,
        &words,
        "bcc8_eval_main",
        "bcc8 as bcc7",
        &dv,
        boxforge_runtime::targets::vulkan::Io::EvalKernel { first },
    )
    .unwrap();
    let pts = random_points(&d, &vol, 800, 5);
    let (v, g) = program.eval(gpu, &dv, &pts).unwrap();
    let mut tally = Tally::new(data_range(&vol));
    tally.check(&d, &vol, &pts, &v, &g);
    assert!(!tally.passed(), "bcc8's binary passed as bcc7: {tally:?}");
}

/// A GLSL program written by hand (not generated): it includes the emitted
/// library, binds the volume where the library's header says, and calls
/// `bcc7_eval` and `bcc7_eval_grad` by name, on the OpenGL driver.
#[test]
fn a_hand_written_glsl_program_uses_the_library_by_its_header() {
    let d = Derivation::new(&boxforge::spec::resolve("bcc7").unwrap()).unwrap();
    let t = translated(&d, Layout::Embedded, Target::Glsl);
    let library = t.units.iter().find(|u| u.role == Role::Library).unwrap().code.text().unwrap().to_string();
    // The header's binding line for the samples, as a user reads it:
    // `//   binding N: NAME (WGSL @group(0) @binding(0) bcc7_volume: ...`.
    let line =
        library.lines().find(|l| l.contains("bcc7_volume") && l.trim_start().starts_with("//   binding")).unwrap();
    let (binding, name) = {
        let rest = line.trim_start().trim_start_matches("//   binding ");
        let (n, rest) = rest.split_once(": ").unwrap();
        (n.parse::<u32>().unwrap(), rest.split_whitespace().next().unwrap().to_string())
    };
    assert!(
        library.contains(&format!("layout(binding = {binding}) uniform sampler3D {name};")),
        "the header names binding {binding} {name}, which the code must declare"
    );
    let source = format!(
        "#version 450 core\n{library}\n\
         layout(local_size_x = 1) in;\n\
         layout(std430, binding = 5) buffer Results {{ float results[]; }};\n\
         void main() {{\n\
             vec3 p = vec3(10.3, 11.7, 9.2);\n\
             results[0] = bcc7_eval(p);\n\
             vec4 g = bcc7_eval_grad(p);\n\
             results[1] = g.x; results[2] = g.y; results[3] = g.z; results[4] = g.w;\n\
         }}\n"
    );
    let vol = random_volume(&d, 9);
    let gl = GlCompute::new().unwrap();
    let dims = [vol.dims[0] as u32, vol.dims[1] as u32, vol.dims[2] as u32];
    let out = gl
        .run(&source, &[GlResource::Texture3d { binding, dims, data: &vol.data, linear: false }], &[(5, 20)], [1, 1, 1])
        .unwrap();
    let r: &[f32] = bytemuck::cast_slice(&out[0]);
    let data = |j: &[i64]| vol.get(j) as f64;
    let (value, grad) = d.eval_f64(&[10.3f32 as f64, 11.7f32 as f64, 9.2f32 as f64], &data);
    let range = data_range(&vol);
    assert!((r[0] as f64 - value).abs() <= 1e-5 * range, "{} vs {value}", r[0]);
    assert!((r[1] as f64 - value).abs() <= 1e-5 * range);
    for i in 0..3 {
        assert!((r[2 + i] as f64 - grad[i]).abs() <= 1e-4 * range.max(grad[i].abs()), "{r:?} vs {grad:?}");
    }
}
