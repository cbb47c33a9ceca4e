//! The hand-written references of `boxforge bench` (runtime/references/):
//! they validate with naga, agree with the generated evaluation on the device
//! (within 1e-5 of the data range), and a wrong one is caught.

use boxforge::emit::{emit, EmitOptions};
use boxforge_runtime::{bench, references};

fn generated_module(filter: &str) -> String {
    let f = boxforge::spec::resolve(filter).unwrap();
    let d = boxforge::derive::Derivation::new(&f).unwrap();
    emit(&d, &EmitOptions { kernels: false, ..Default::default() }).unwrap().source
}

#[test]
fn references_validate_with_naga_and_count_their_work() {
    let refs = references::builtin();
    assert_eq!(refs.len(), 4);
    for r in &refs {
        let src = format!("{}\n{}", generated_module(&r.like), r.source);
        let report = boxforge::validate::validate_wgsl(&src, &r.name);
        assert!(report.valid, "{}: {:?}", r.name, report.error);
        assert!(report.function(&r.entry).is_some(), "{} defines {}", r.name, r.entry);
        assert!(r.source.starts_with("// Hand-written reference"), "{} has a header citing its source", r.name);
        let fetches = references::fetches(&src, &r.source, &r.entry).unwrap();
        let want = match r.entry.as_str() {
            "kim_lee_bcc7" => 30,
            "kim_fcc6" => 19,
            "separable_tricubic" => 64,
            "sigg_hadwiger_tricubic" => 8,
            e => panic!("unexpected reference {e}"),
        };
        assert_eq!(fetches, want, "{}", r.name);
        // Helpers count per call site: the separable filter's 16 rows and 4
        // planes are more than its code's static text.
        let ops = references::ops(&src, &r.source, &r.entry);
        assert!(ops > 50, "{}: {ops} ops", r.name);
    }
    let src = format!("{}\n{}", generated_module("cc_tricubic"), references::SEPARABLE_TRICUBIC);
    let dynamic = references::ops(&src, references::SEPARABLE_TRICUBIC, "separable_tricubic");
    let text = boxforge::emit::count_ops(&references::code_only(references::SEPARABLE_TRICUBIC));
    assert!(dynamic > 3 * text, "{dynamic} vs {text}");
}

#[test]
fn references_agree_with_the_generated_eval_on_the_device() {
    let gpu = crate::common::gpu();
    for r in references::builtin() {
        let row = bench::compare_reference(gpu, &r, 3000, 2).unwrap();
        if references::uses_sampler(&r.source) && !bench::can_filter_f32(gpu) {
            assert!(row.note.as_deref().unwrap_or("").contains("FLOAT32_FILTERABLE"), "{row:?}");
            continue;
        }
        assert!(row.agrees, "{}: {row:?}", r.name);
        let rel = row.rel_diff.unwrap();
        assert!(rel < bench::REFERENCE_TOLERANCE, "{}: {rel:e}", r.name);
        let ratio = row.ratio.expect("timed");
        assert_eq!(ratio.rounds, 2);
        assert!(ratio.median > 0.0 && ratio.min <= ratio.median && ratio.median <= ratio.max);
        let ray = row.ray_ratio.expect("the ray-caster shape is timed too");
        assert!(ray.rounds == 2 && ray.min <= ray.median && ray.median <= ray.max, "{}: {ray:?}", r.name);
    }
    // The check can fail: Kim & Lee's formula without its 1/384 scale (the
    // published sum), or with a wrong one, is reported invalid and not timed.
    let kim = references::builtin().into_iter().find(|r| r.entry == "kim_lee_bcc7").unwrap();
    for (from, to) in [("* (1.0 / 384.0)", "* (1.0 / 383.0)"), ("* (1.0 / 384.0)", "* 1.0")] {
        assert!(kim.source.contains(from));
        let wrong = references::Reference { source: kim.source.replace(from, to), ..kim.clone() };
        let row = bench::compare_reference(gpu, &wrong, 3000, 2).unwrap();
        assert!(!row.agrees && row.ratio.is_none(), "{to}: {row:?}");
        assert!(row.note.as_deref().unwrap().contains("INVALID"), "{row:?}");
    }
    // A tricubic shifted by half a texel (an off-by-half coordinate convention) is caught too.
    let sep = references::builtin().into_iter().find(|r| r.entry == "separable_tricubic").unwrap();
    let shifted = references::Reference {
        source: sep.source.replace("let i = floor(p);", "let i = floor(p + 0.5);"),
        ..sep.clone()
    };
    let row = bench::compare_reference(gpu, &shifted, 3000, 2).unwrap();
    assert!(!row.agrees, "{row:?}");
    // Kim's fcc6 with the corner tetrahedron's table everywhere (the type
    // blend dropped) is wrong in the central tetrahedra, and caught.
    let fcc = references::builtin().into_iter().find(|r| r.entry == "kim_fcc6").unwrap();
    let from = "let tet_type = 1.0 - (";
    assert!(fcc.source.contains(from));
    let corner_only =
        references::Reference { source: fcc.source.replace(from, "let tet_type = 0.0 * ("), ..fcc.clone() };
    let row = bench::compare_reference(gpu, &corner_only, 3000, 2).unwrap();
    assert!(!row.agrees, "{row:?}");
}
