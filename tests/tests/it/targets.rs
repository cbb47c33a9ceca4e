//! Issue 25: every catalog filter x layout x fetch mode x target (the fast
//! variant; naive variants aside) translated by naga's backends, checked
//! (public names kept, bindings as the header says, no branch in the
//! evaluation functions' SPIR-V) and compiled by the compilers at hand:
//! glslang for GLSL and GLSL ES, glslang's HLSL front end for HLSL
//! ("accepted by glslang"), spirv-val for SPIR-V. MSL is emitted and not
//! compiled (no Metal compiler on Linux). And translations broken on
//! purpose fail the check or the compiler.

use boxforge::back::compilers::{self, Outcome};
use boxforge::back::{self, check_translated, spirv, BackError, Code, Target, Translated};
use boxforge::derive::Derivation;
use boxforge::emit::{coset_pivots, emit, EmitOptions, FetchMode, Layout, Variant};
use boxforge::spec::catalog;
use std::collections::BTreeMap;

const TARGETS: [Target; 5] = [Target::Spirv, Target::Glsl, Target::GlslEs, Target::Hlsl, Target::Msl];

/// Every (stem, WGSL) of the catalog's fast modules: both layouts with
/// exact fetches, and linear fetches where they apply.
fn catalog_modules() -> Vec<(String, String)> {
    let names = catalog::names();
    let per_filter: Vec<Vec<(String, String)>> = std::thread::scope(|s| {
        let handles: Vec<_> = names
            .iter()
            .map(|name| {
                s.spawn(move || {
                    let d = Derivation::new(&catalog::get(name).unwrap()).unwrap();
                    d.derive_all_forms(&|_, _| {});
                    // 4D: the packed layout of d4star8 and z4_linear (the layouts
                    // differ only in `<f>_fetch`, which wgsl.rs checks in both;
                    // every 4D module in every language would add about a
                    // minute of glslang on 5000-line shaders to the suite).
                    let layouts = match d.facts.dim {
                        4 if ["d4star8", "z4_linear"].contains(name) => vec![Layout::Packed],
                        4 => vec![],
                        dim => boxforge::build::output::default_layouts(dim),
                    };
                    let mut jobs: Vec<(Layout, FetchMode)> =
                        layouts.into_iter().map(|l| (l, FetchMode::Exact)).collect();
                    // 4D samples are a storage buffer: exact fetches only.
                    let textures = d.facts.dim <= 3;
                    if textures && d.factorisation().is_some_and(|f| f.supports_linear_fetch()) {
                        jobs.push((Layout::Embedded, FetchMode::Linear));
                    }
                    if textures && coset_pivots(&d.filter.lattice).is_ok() {
                        jobs.push((Layout::Packed, FetchMode::Linear));
                    }
                    jobs.into_iter()
                        .map(|(layout, fetch)| {
                            let opts = EmitOptions {
                                layout,
                                variant: Variant::Fast,
                                fetch,
                                command: "boxforge-tests targets".into(),
                                ..EmitOptions::default()
                            };
                            let e = emit(&d, &opts).unwrap();
                            (e.file_name.trim_end_matches(".wgsl").to_string(), e.source)
                        })
                        .collect()
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    per_filter.into_iter().flatten().collect()
}

#[test]
fn every_catalog_module_translates_checks_and_compiles_in_every_target() {
    assert!(
        compilers::glslang_version().is_some() && compilers::spirv_val_version().is_some(),
        "glslangValidator and spirv-val are needed: {} (scripts/test.sh installs them as root)",
        compilers::INSTALL
    );
    let started = std::time::Instant::now();
    let modules = catalog_modules();
    let jobs: Vec<(&(String, String), Target)> = modules.iter().flat_map(|m| TARGETS.map(|t| (m, t))).collect();
    let threads = std::thread::available_parallelism().map_or(2, |n| n.get()).max(2);
    let chunks: Vec<Vec<(&(String, String), Target)>> =
        (0..threads).map(|k| jobs.iter().skip(k).step_by(threads).copied().collect()).collect();
    // Per target: (compiled, total, compiler) and the failures.
    let results: Vec<(Target, String, Outcome)> = std::thread::scope(|s| {
        let handles: Vec<_> = chunks
            .iter()
            .map(|chunk| {
                s.spawn(move || {
                    let mut out = Vec::new();
                    for ((stem, wgsl), target) in chunk {
                        let translated = back::translate(wgsl, stem, *target, &Default::default());
                        if *target == Target::Hlsl && stem.ends_with(".linear") {
                            // naga's HLSL samplers need wgpu's DX12 sampler heap: refused, with the way out.
                            let e = translated.expect_err("hlsl with a sampler is refused");
                            assert!(
                                matches!(e, BackError::Unsupported { .. }) && e.to_string().contains("fetch = exact")
                            );
                            out.push((*target, format!("{stem}.hlsl"), Outcome::NotCompilable { why: "refused" }));
                            continue;
                        }
                        let t = translated.unwrap_or_else(|e| panic!("{stem} -> {target}: {e}"));
                        // Fast modules: the evaluation functions' SPIR-V must be proven branch-free.
                        assert_eq!(t.branch_free.len(), 3, "{stem}: {:?}", t.branch_free);
                        if *target == Target::Spirv {
                            let eval = t.units.iter().find(|u| u.file_name.ends_with(".eval.spv")).unwrap();
                            for f in &t.branch_free {
                                assert!(eval.functions.contains(f), "{stem}: {f} not in {}", eval.file_name);
                            }
                        }
                        for u in &t.units {
                            out.push((*target, u.file_name.clone(), compilers::compile(&t, u)));
                        }
                    }
                    out
                })
            })
            .collect();
        handles.into_iter().flat_map(|h| h.join().unwrap()).collect()
    });
    let mut per_target: BTreeMap<Target, (usize, usize, String)> = BTreeMap::new();
    let mut failures = Vec::new();
    let mut metal = 0;
    let mut refused = 0;
    for (target, file, outcome) in &results {
        match outcome {
            Outcome::Compiled { by } => {
                let e = per_target.entry(*target).or_insert((0, 0, by.clone()));
                e.0 += 1;
                e.1 += 1;
            }
            Outcome::NotCompilable { .. } if *target == Target::Msl => metal += 1,
            Outcome::NotCompilable { why: "refused" } => refused += 1,
            Outcome::NotCompilable { .. } => {} // SPIR-V's manifest
            other => {
                per_target.entry(*target).or_insert((0, 0, String::new())).1 += 1;
                failures.push(format!("{file}: {other:?}"));
            }
        }
    }
    let compiled: usize = per_target.values().map(|v| v.0).sum();
    let total: usize = per_target.values().map(|v| v.1).sum();
    println!(
        "{compiled}/{total} files compiled from {} catalog modules (filter x layout x fetch mode, fast variant) in {:.1} s",
        modules.len(),
        started.elapsed().as_secs_f64()
    );
    for (t, (c, n, by)) in &per_target {
        // glslang's HLSL front end is no D3D compiler: it accepted the HLSL, no more.
        let verb = if *t == Target::Hlsl { "accepted by" } else { "compiled by" };
        println!("  {:<8} {c}/{n} {verb} {by}", t.name());
    }
    println!("  msl      {metal} files emitted, not compiled (no Metal compiler on Linux)");
    println!("  hlsl     {refused} linear-fetch modules refused (samplers need wgpu's DX12 sampler heap)");
    assert!(failures.is_empty(), "{} of {total} failed:\n{}", failures.len(), failures.join("\n"));
    assert_eq!(compiled, total);
    assert!(metal >= 2 * modules.len(), "a library and a kernels file per module");
}

fn bcc7_embedded() -> String {
    let d = Derivation::new(&catalog::get("bcc7").unwrap()).unwrap();
    emit(&d, &EmitOptions::default()).unwrap().source
}

fn replace_in_library(t: &mut Translated, from: &str, to: &str) {
    let lib = &mut t.units[0];
    let Code::Text(text) = &mut lib.code else { panic!("a text library") };
    assert!(text.contains(from), "{from}");
    *text = text.replace(from, to);
}

#[test]
fn a_renamed_binding_or_function_fails_the_check() {
    let wgsl = bcc7_embedded();
    let good = back::translate(&wgsl, "bcc7.embedded", Target::Glsl, &Default::default()).unwrap();
    check_translated(&good).unwrap();
    assert_eq!(good.units[0].bindings[0].name_in_target, "_group_0_binding_0_cs");
    // Every use renamed: the text still compiles, but it no longer has the binding its header names.
    let mut renamed = good.clone();
    replace_in_library(&mut renamed, "_group_0_binding_0_cs", "bcc7_volume_texture");
    assert!(matches!(compilers::compile(&renamed, &renamed.units[0]), Outcome::Compiled { .. }));
    let e = check_translated(&renamed).unwrap_err();
    assert!(matches!(e, BackError::Check { .. }) && e.to_string().contains("_group_0_binding_0_cs"), "{e}");
    // The binding number changed in the declaration only.
    let mut moved = good.clone();
    replace_in_library(&mut moved, "layout(binding = 0) uniform", "layout(binding = 3) uniform");
    assert!(check_translated(&moved).is_err());
    // A public function under another name.
    let mut mangled = good.clone();
    replace_in_library(&mut mangled, "bcc7_eval(", "bcc7_eval_(");
    let e = check_translated(&mangled).unwrap_err();
    assert!(matches!(e, BackError::Renamed { ref name, .. } if name == "bcc7_eval"), "{e}");
    // A declaration dropped: the compiler refuses what the check cannot see.
    let mut dropped = good;
    replace_in_library(&mut dropped, "layout(binding = 0) uniform sampler3D _group_0_binding_0_cs;", "");
    assert!(matches!(compilers::compile(&dropped, &dropped.units[0]), Outcome::Failed { .. }));
}

#[test]
fn a_branch_injected_into_eval_fails_the_spirv_proof() {
    let wgsl = bcc7_embedded();
    let good = back::translate(&wgsl, "bcc7.embedded", Target::Spirv, &Default::default()).unwrap();
    let eval_unit = good.units.iter().position(|u| u.file_name == "bcc7.embedded.eval.spv").unwrap();
    let Code::Words(words) = &good.units[eval_unit].code else { panic!("a binary") };
    let m = spirv::read(words).unwrap();
    for f in ["bcc7_fetch", "bcc7_eval", "bcc7_eval_grad"] {
        assert_eq!(m.call_tree_branches(f), Some(0), "{f}");
    }
    // The kernel itself has its bounds check: the walker sees branches.
    assert!(m.call_tree_branches("bcc7_eval_main").unwrap_or(0) > 0 || m.functions.iter().any(|f| f.branches > 0));

    let head = "fn bcc7_eval(p: vec3<f32>) -> f32 {\n";
    assert!(wgsl.contains(head));
    let branchy = wgsl.replace(head, &format!("{head}    if (p.x > 1e30) {{\n        return 0.0;\n    }}\n"));
    let bad = back::translate(&branchy, "bcc7.embedded", Target::Spirv, &Default::default()).unwrap();
    assert!(!bad.branch_free.contains(&"bcc7_eval".to_string()), "the WGSL proof does not hold for it either");
    let Code::Words(bad_words) = &bad.units[eval_unit].code else { panic!("a binary") };
    assert_eq!(spirv::read(bad_words).unwrap().call_tree_branches("bcc7_eval"), Some(1));
    // The good translation with the branchy binary in place of its eval kernel fails.
    let mut broken = good.clone();
    broken.units[eval_unit].code = Code::Words(bad_words.clone());
    let e = check_translated(&broken).unwrap_err();
    assert!(e.to_string().contains("bcc7_eval has 1 branches"), "{e}");
    // spirv-val still accepts it: the proof is ours, not the validator's.
    assert!(matches!(compilers::compile(&broken, &broken.units[eval_unit]), Outcome::Compiled { .. }));
    // A truncated binary is not read.
    assert!(spirv::read(&bad_words[..bad_words.len() - 1]).is_err());
}

#[test]
fn translation_is_deterministic_and_names_the_command_and_bindings() {
    let wgsl = bcc7_embedded();
    for target in TARGETS {
        let a = back::translate(&wgsl, "bcc7.embedded", target, &Default::default()).unwrap();
        let b = back::translate(&wgsl, "bcc7.embedded", target, &Default::default()).unwrap();
        assert_eq!(a, b, "{target}");
        let head = a.units[0].code.text().unwrap();
        assert!(head.contains("// generated by `boxforge generate`"), "{target}: {head}");
        assert!(head.contains(target.language()), "{target}");
    }
    let glsl = back::translate(&wgsl, "bcc7.embedded", Target::Glsl, &Default::default()).unwrap();
    let lib = glsl.units[0].code.text().unwrap();
    assert!(
        lib.contains("//   binding 0: _group_0_binding_0_cs (WGSL @group(0) @binding(0) bcc7_volume: texture_3d<f32>)"),
        "{lib}"
    );
    let hlsl = back::translate(&wgsl, "bcc7.embedded", Target::Hlsl, &Default::default()).unwrap();
    assert!(hlsl.units[0].code.text().unwrap().contains("//   register(t0, space0): bcc7_volume"));
}

/// GLSL compiled for Vulkan (`VULKAN` defined) declares the descriptor kinds
/// a host of the WGSL layout binds: a sampled image, and a separate sampler
/// where the fetches filter; naga's OpenGL-only combined `sampler3D` would
/// not match a wgpu (or any WGSL-layout) descriptor set.
#[test]
fn glsl_for_vulkan_declares_the_descriptors_a_wgsl_host_binds() {
    use compilers::DescriptorKind::{CombinedImageSampler, SampledImage, Sampler};
    let vulkan_descriptors = |t: &Translated| -> Vec<(u32, u32, compilers::DescriptorKind)> {
        let dir = std::env::temp_dir().join(format!("boxforge-vk-descriptors-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (src, spv) = (dir.join(format!("{}.comp", t.filter)), dir.join(format!("{}.spv", t.filter)));
        let lib = t.units[0].code.text().unwrap();
        let f = &t.filter;
        let main = format!("layout(local_size_x = 1) in;\nvoid main() {{ float v = {f}_eval(vec3(0.5)); }}\n");
        std::fs::write(&src, format!("#version 450 core\n{lib}{main}")).unwrap();
        let ok =
            std::process::Command::new("glslangValidator").arg("-V").arg(&src).arg("-o").arg(&spv).output().unwrap();
        assert!(ok.status.success(), "{}", String::from_utf8_lossy(&ok.stdout));
        let dis = std::process::Command::new("spirv-dis").arg("--raw-id").arg(&spv).output().unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        compilers::opaque_descriptors(&String::from_utf8_lossy(&dis.stdout))
    };
    let exact = back::translate(&bcc7_embedded(), "bcc7.embedded", Target::Glsl, &Default::default()).unwrap();
    assert!(matches!(compilers::compile(&exact, &exact.units[0]), Outcome::Compiled { .. }));
    assert_eq!(vulkan_descriptors(&exact), vec![(0, 0, SampledImage)]);

    let d = Derivation::new(&catalog::get("cc_tricubic").unwrap()).unwrap();
    let options = EmitOptions { layout: Layout::Packed, fetch: FetchMode::Linear, ..Default::default() };
    let wgsl = emit(&d, &options).unwrap().source;
    let linear = back::translate(&wgsl, "cc_tricubic.packed.linear", Target::Glsl, &Default::default()).unwrap();
    assert!(matches!(compilers::compile(&linear, &linear.units[0]), Outcome::Compiled { .. }));
    let sampler_binding = linear.units[0].bindings.iter().find(|b| b.wgsl.kind == "sampler").unwrap().wgsl.binding;
    assert_eq!(vulkan_descriptors(&linear), vec![(0, 0, SampledImage), (0, sampler_binding, Sampler)]);

    // Without the Vulkan twin, the OpenGL declaration reaches Vulkan: a
    // combined image sampler, which the compile check refuses.
    let mut combined = exact.clone();
    replace_in_library(
        &mut combined,
        "#ifdef VULKAN\nlayout(set = 0, binding = 0) uniform texture3D _group_0_binding_0_cs;\n#else\n",
        "#if 1\n",
    );
    assert_eq!(vulkan_descriptors(&combined), vec![(0, 0, CombinedImageSampler)]);
    let Outcome::Failed { message, .. } = compilers::compile(&combined, &combined.units[0]) else {
        panic!("a combined image sampler passed the Vulkan descriptor check")
    };
    assert!(message.contains("CombinedImageSampler") && message.contains("SampledImage"), "{message}");
}
