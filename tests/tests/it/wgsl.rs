//! Every catalog filter x layout x variant emits WGSL that naga validates;
//! the fast variant is proven branch-free and table-free and fetches exactly
//! its planned samples; the naive variant fails the proof (so it can fail).

use boxforge::build::output::{default_layouts, ALL_VARIANTS};
use boxforge::emit::{emit, EmitOptions};
use boxforge::validate::{check_branch_free, validate_wgsl};
use boxforge_tests::all_catalog;

#[test]
fn catalog_modules_validate_and_fast_ones_are_branch_free() {
    for d in all_catalog() {
        let name = &d.filter.name;
        let eval = format!("{name}_eval");
        let grad = format!("{name}_eval_grad");
        let hessian = format!("{name}_eval_hessian");
        for layout in default_layouts(d.facts.dim) {
            for variant in ALL_VARIANTS {
                let e = emit(&d, &EmitOptions { layout, variant, ..EmitOptions::default() }).unwrap();
                let r = validate_wgsl(&e.source, &e.file_name);
                assert!(r.valid, "{}: {}", e.file_name, r.error.unwrap_or_default());
                // Second order for every filter of degree >= 2, none below.
                assert_eq!(r.function(&hessian).is_some(), d.facts.degree >= 2, "{}: {hessian}", e.file_name);
                let mut required = vec![eval.as_str(), grad.as_str()];
                if d.facts.degree >= 2 {
                    required.push(&hessian);
                }
                let proof = check_branch_free(&r, &required);
                match variant {
                    boxforge::emit::Variant::Fast => {
                        proof.unwrap_or_else(|err| panic!("{}: {err}", e.file_name));
                        // Bricked: one page-table load per evaluation, not per fetch.
                        let pages = usize::from(layout.is_bricked());
                        // 4D: each fetch reads its sample and the buffer's header
                        // (the same words every time; the driver hoists them).
                        let per_fetch = if d.facts.dim == 4 { 2 } else { 1 };
                        for f in &required {
                            let loads = r.function(f).unwrap().total_loads;
                            assert_eq!(
                                loads,
                                per_fetch * e.stats.fetches_per_eval + pages,
                                "{}: {f} loads",
                                e.file_name
                            );
                        }
                        // Fetches: the reference stencil (fcc6: 16 by selecting
                        // among the two reference stencils, not their union).
                        assert_eq!(e.stats.fetches_per_eval, d.max_stencil(), "{}", e.file_name);
                    }
                    boxforge::emit::Variant::Naive => {
                        assert!(proof.is_err(), "{}: the naive variant must fail the proof", e.file_name);
                    }
                }
                // 4D modules have no min/max kernel (see emit: their cube bounds run to megabytes).
                let kernels: &[&str] = if d.facts.dim <= 3 {
                    &["_fetch", "_prefilter_main", "_minmax_main", "_cube_bounds"]
                } else {
                    &["_fetch", "_prefilter_main"]
                };
                for f in kernels {
                    assert!(r.function(&format!("{name}{f}")).is_some(), "{} lacks {name}{f}", e.file_name);
                }
            }
        }
    }
}

#[test]
fn several_filters_live_in_one_shader() {
    // Distinct prefixes and bindings let modules be concatenated.
    let a = boxforge_tests::derive("bcc7");
    let b = boxforge_tests::derive("fcc6");
    let ea = emit(&a, &EmitOptions { binding: 0, kernels: false, ..EmitOptions::default() }).unwrap();
    let eb = emit(&b, &EmitOptions { binding: 1, kernels: false, ..EmitOptions::default() }).unwrap();
    let both = format!("{}\n{}", ea.source, eb.source);
    let r = validate_wgsl(&both, "both.wgsl");
    assert!(r.valid, "{}", r.error.unwrap_or_default());
    check_branch_free(&r, &["bcc7_eval", "fcc6_eval_grad"]).unwrap();
}

#[test]
fn emission_is_deterministic() {
    let d = boxforge_tests::derive("fcc6");
    let a = emit(&d, &EmitOptions::default()).unwrap().source;
    let b = emit(&boxforge_tests::derive("fcc6"), &EmitOptions::default()).unwrap().source;
    assert_eq!(a, b);
}

#[test]
fn a_user_tensor_cubic_over_bcc_is_factored_and_small() {
    // Issue #8: a user spec of 2e1, 2e2, 2e3 four times each on bcc emitted
    // 410 KB of WGSL with the dense form; the factorisation must shrink it.
    let spec = r#"
        name = "tensor_cubic_bcc"
        lattice = "bcc"
        directions = [[2,0,0],[2,0,0],[2,0,0],[2,0,0],[0,2,0],[0,2,0],[0,2,0],[0,2,0],[0,0,2],[0,0,2],[0,0,2],[0,0,2]]
    "#;
    let f = boxforge::Filter::from_toml(spec, "test").unwrap();
    let d = boxforge::derive::Derivation::new(&f).unwrap();
    let e = emit(&d, &EmitOptions::default()).unwrap();
    assert_eq!(e.stats.form, boxforge::emit::EvalForm::Factored);
    // (The limit was 40 KB before eval_hessian, whose second-derivative
    // contractions over both cosets add 27 KB.)
    assert!(e.source.len() < 80_000, "{} bytes", e.source.len());
    let r = validate_wgsl(&e.source, &e.file_name);
    assert!(r.valid, "{}", r.error.unwrap_or_default());
    check_branch_free(&r, &["tensor_cubic_bcc_eval", "tensor_cubic_bcc_eval_grad"]).unwrap();
    assert_eq!(r.function("tensor_cubic_bcc_eval").unwrap().total_loads, 128);
}

#[test]
fn forms_can_be_forced_and_factored_is_refused_where_it_does_not_apply() {
    use boxforge::emit::EvalForm;
    let d = boxforge_tests::derive("bcc7");
    for form in [EvalForm::Power, EvalForm::Ridge, EvalForm::Bb, EvalForm::Dense] {
        let e = emit(&d, &EmitOptions { form: Some(form), ..EmitOptions::default() }).unwrap();
        assert_eq!(e.stats.form, form);
        let r = validate_wgsl(&e.source, &e.file_name);
        assert!(r.valid, "{form:?}: {}", r.error.clone().unwrap_or_default());
        check_branch_free(&r, &["bcc7_eval", "bcc7_eval_grad"]).unwrap();
    }
    // Above RIDGE_MAX_DEGREE (f32 cancellation) forcing ridge is refused with the alternatives.
    let tricubic = boxforge_tests::derive("cc_tricubic");
    let err = emit(&tricubic, &EmitOptions { form: Some(EvalForm::Ridge), ..EmitOptions::default() }).unwrap_err();
    assert!(err.to_string().contains("ridge") && err.to_string().contains("power"), "{err}");
    let auto = emit(&tricubic, &EmitOptions::default()).unwrap();
    assert!(auto.stats.forms.iter().all(|f| f.form != EvalForm::Ridge), "not offered above the degree");
    // The ridge form on other lattices and dimensions: valid and branch-free.
    for name in ["fcc6", "bcc8", "courant", "zp", "bcc_linear"] {
        let d = boxforge_tests::derive(name);
        let e = emit(&d, &EmitOptions { form: Some(EvalForm::Ridge), ..EmitOptions::default() }).unwrap();
        assert_eq!(e.stats.form, EvalForm::Ridge);
        let r = validate_wgsl(&e.source, &e.file_name);
        assert!(r.valid, "{name} ridge: {}", r.error.clone().unwrap_or_default());
        check_branch_free(&r, &[&format!("{name}_eval"), &format!("{name}_eval_grad")]).unwrap();
    }
    let auto = emit(&d, &EmitOptions::default()).unwrap().stats;
    assert!(auto.forms.iter().any(|f| f.form == EvalForm::Ridge), "auto compares the ridge form");
    // Auto is the cheapest of the forms it reports.
    assert!(auto.forms.iter().all(|f| f.cost() >= auto.ops_eval + auto.ops_eval_grad));
    let err = emit(&d, &EmitOptions { form: Some(EvalForm::Factored), ..EmitOptions::default() }).unwrap_err();
    assert!(err.to_string().contains("factored"), "{err}");
}

#[test]
fn linear_fetch_modules_are_branch_free_with_eight_filtered_fetches() {
    use boxforge::emit::FetchMode;
    let d = boxforge_tests::derive("cc_tricubic");
    let e = emit(&d, &EmitOptions { fetch: FetchMode::Linear, ..EmitOptions::default() }).unwrap();
    assert_eq!(e.stats.fetches_per_eval, 8);
    assert!(e.file_name.ends_with(".linear.wgsl"));
    let r = validate_wgsl(&e.source, &e.file_name);
    assert!(r.valid, "{}", r.error.unwrap_or_default());
    check_branch_free(&r, &["cc_tricubic_eval", "cc_tricubic_eval_grad"]).unwrap();
    let eval_src = e.source.split("fn cc_tricubic_eval(").nth(1).unwrap().split("\n}\n").next().unwrap();
    assert_eq!(eval_src.matches("cc_tricubic_fetch_linear(").count(), 8);
    assert_eq!(eval_src.matches("cc_tricubic_fetch(").count(), 0);
    // bcc7 has no tensor structure, and bcc12 needs per-coset textures: the
    // embedded layout refuses both and names the packed layout.
    for name in ["bcc7", "bcc12"] {
        let d = boxforge_tests::derive(name);
        let err = emit(&d, &EmitOptions { fetch: FetchMode::Linear, ..EmitOptions::default() }).unwrap_err();
        assert!(err.to_string().contains("layout = packed"), "{name}: {err}");
    }
}

/// Packed layout with linear fetches: every catalog filter pairs its coset
/// samples into filtered fetches; the module validates, stays branch-free,
/// and eval fetches only through `<f>_fetch_pair` (eval_grad keeps loads).
#[test]
fn packed_linear_fetch_modules_pair_coset_samples() {
    use boxforge::emit::{FetchMode, Layout};
    for name in boxforge::spec::catalog::names() {
        let d = boxforge_tests::derive(name);
        let opts = EmitOptions { layout: Layout::Packed, fetch: FetchMode::Linear, ..EmitOptions::default() };
        let e = match emit(&d, &opts) {
            Ok(e) => e,
            // 4D samples are a storage buffer, which no sampler filters.
            Err(err) if d.facts.dim == 4 => {
                assert!(err.to_string().contains("storage buffer"), "{name}: {err}");
                continue;
            }
            // Lattices without 2Z^s have no packed layout at all.
            Err(err) => {
                assert!(err.to_string().contains("2Z^s"), "{name}: {err}");
                continue;
            }
        };
        assert!(e.file_name.ends_with(".packed.linear.wgsl"), "{}", e.file_name);
        let r = validate_wgsl(&e.source, &e.file_name);
        assert!(r.valid, "{name}: {}", r.error.unwrap_or_default());
        check_branch_free(&r, &[&format!("{name}_eval"), &format!("{name}_eval_grad")]).unwrap();
        let eval_src = e.source.split(&format!("fn {name}_eval(")).nth(1).unwrap().split("\n}\n").next().unwrap();
        assert_eq!(eval_src.matches(&format!("{name}_fetch_pair(")).count(), e.stats.fetches_per_eval, "{name}");
        assert_eq!(eval_src.matches(&format!("{name}_fetch(")).count(), 0, "{name}");
        let exact = emit(&d, &EmitOptions { layout: Layout::Packed, ..EmitOptions::default() }).unwrap();
        // Stencils with one sample per coset (cc_trilinear: 8 cosets of 2Z^3) have no pair.
        assert!(e.stats.fetches_per_eval <= exact.stats.fetches_per_eval, "{name}");
    }
    // Issue #8's fetch budgets, checked on what the pairing found.
    for (name, most) in [("bcc7", 16), ("bcc8", 16), ("fcc6", 12)] {
        let d = boxforge_tests::derive(name);
        let opts = EmitOptions { layout: Layout::Packed, fetch: FetchMode::Linear, ..EmitOptions::default() };
        let n = emit(&d, &opts).unwrap().stats.fetches_per_eval;
        assert!(n <= most, "{name}: {n} filtered fetches, budget {most}");
        assert!(n < d.references.iter().map(|r| r.stencil.len()).max().unwrap(), "{name}: no pair");
    }
}

/// Issue 26 point 3: the packed layout's exact fetch reads its samples with
/// one `textureLoad` (naga IR: one `ImageLoad` in `<f>_fetch`, no storage
/// read) and the module declares no storage buffer but the kernels' output,
/// in both bounds modes, for every catalog filter with a packed layout.
#[test]
fn packed_exact_fetch_is_one_texture_load() {
    use boxforge::emit::{Bounds, Layout};
    let mut checked = 0;
    for name in boxforge::spec::catalog::names() {
        let d = boxforge_tests::derive(name);
        if d.facts.dim == 4 {
            continue; // a storage buffer: four_d_fetch_reads_one_storage_buffer
        }
        for bounds in [Bounds::Clamp, Bounds::Unchecked] {
            let opts = EmitOptions { layout: Layout::Packed, bounds, ..EmitOptions::default() };
            let Ok(e) = emit(&d, &opts) else { continue };
            let r = validate_wgsl(&e.source, &e.file_name);
            assert!(r.valid, "{name}: {}", r.error.unwrap_or_default());
            let fetch = r.function(&format!("{name}_fetch")).unwrap();
            assert_eq!((fetch.image_loads, fetch.loads, fetch.total_loads), (1, 1, 1), "{name} {bounds:?}");
            let storage: Vec<&str> = e.source.lines().filter(|l| l.contains("var<storage")).collect();
            assert!(storage.iter().all(|l| l.contains(&format!("{name}_out:"))), "{name}: {storage:?}");
            check_branch_free(&r, &[&format!("{name}_eval"), &format!("{name}_eval_grad")]).unwrap();
            checked += 1;
        }
    }
    assert!(checked >= 8, "{checked}");
}

/// Issue 29: a 4D module reads its samples from one read-only storage buffer
/// (no texture), the sample and the header's extent per fetch, in both
/// layouts and both bounds modes; the bricked layouts and linear fetches
/// are refused (see d4.rs).
#[test]
fn four_d_fetch_reads_one_storage_buffer() {
    use boxforge::emit::{Bounds, Layout};
    let mut checked = 0;
    for name in boxforge::spec::catalog::names() {
        let d = boxforge_tests::derive(name);
        if d.facts.dim != 4 {
            continue;
        }
        for layout in [Layout::Embedded, Layout::Packed] {
            for bounds in [Bounds::Clamp, Bounds::Unchecked] {
                let opts = EmitOptions { layout, bounds, kernels: false, ..EmitOptions::default() };
                let e = emit(&d, &opts).unwrap();
                let r = validate_wgsl(&e.source, &e.file_name);
                assert!(r.valid, "{name}: {}", r.error.unwrap_or_default());
                let fetch = r.function(&format!("{name}_fetch")).unwrap();
                assert_eq!((fetch.image_loads, fetch.total_loads), (0, 2), "{name} {layout:?} {bounds:?}");
                let storage: Vec<&str> = e.source.lines().filter(|l| l.contains("var<storage")).collect();
                assert_eq!(storage.len(), 1, "{name}: {storage:?}");
                assert!(storage[0].contains(&format!("var<storage, read> {name}_samples:")), "{storage:?}");
                assert!(!e.source.contains("texture_"), "{name}: a 4D module binds no texture");
                checked += 1;
            }
        }
    }
    assert!(checked >= 12, "{checked}");
}

/// u8x4 modules (four u8 samples per r32uint texel) in every 2D/3D layout:
/// valid, branch-free, one texel load per fetch (plus the page in bricks),
/// named apart from the float modules; refused with linear fetches and in 4D.
#[test]
fn u8x4_modules_are_branch_free_with_one_word_load_per_fetch() {
    use boxforge::emit::{FetchMode, Layout, Texels};
    for name in ["bcc7", "cc_tricubic", "fcc6", "courant"] {
        let d = boxforge_tests::derive(name);
        for layout in default_layouts(d.facts.dim) {
            let e = emit(&d, &EmitOptions { layout, texels: Texels::U8x4, ..EmitOptions::default() }).unwrap();
            assert!(e.file_name.ends_with(".u8x4.wgsl"), "{}", e.file_name);
            assert!(e.source.contains("<u32>;") && e.source.contains(&format!("fn {name}_unpack(")), "{}", e.file_name);
            let r = validate_wgsl(&e.source, &e.file_name);
            assert!(r.valid, "{}: {}", e.file_name, r.error.unwrap_or_default());
            let required = [format!("{name}_eval"), format!("{name}_eval_grad")];
            check_branch_free(&r, &required.iter().map(String::as_str).collect::<Vec<_>>())
                .unwrap_or_else(|err| panic!("{}: {err}", e.file_name));
            let pages = usize::from(layout.is_bricked());
            for f in &required {
                assert_eq!(
                    r.function(f).unwrap().total_loads,
                    e.stats.fetches_per_eval + pages,
                    "{}: {f}",
                    e.file_name
                );
            }
            // The float module of the same layout reads f32 texels, as before.
            let float = emit(&d, &EmitOptions { layout, ..EmitOptions::default() }).unwrap();
            assert!(!float.source.contains("_unpack(") && !float.file_name.contains("u8x4"));
        }
    }
    let d = boxforge_tests::derive("cc_tricubic");
    let err = emit(&d, &EmitOptions { texels: Texels::U8x4, fetch: FetchMode::Linear, ..EmitOptions::default() })
        .unwrap_err();
    assert!(err.to_string().contains("u8x4"), "{err}");
    let d4 = boxforge_tests::derive("z4_linear");
    let err = emit(&d4, &EmitOptions { layout: Layout::Embedded, texels: Texels::U8x4, ..EmitOptions::default() })
        .unwrap_err();
    assert!(err.to_string().contains("4D"), "{err}");
}
