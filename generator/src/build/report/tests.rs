use super::*;
use crate::spec::catalog;

/// Smoothness classes derived from the direction matrices, against what
/// the literature states: bcc7, bcc8 (Entezari et al.), bcc12 and
/// cc_tricubic are C^2 (continuous Hessian); fcc6 (Kim et al. 2008), cc6
/// (Kim & Kim 2023), the Zwart-Powell element and the triquadratic are C^1
/// (the Hessian jumps); the linear and trilinear splines C^0. The
/// markdown report says so in words.
#[test]
fn smoothness_classes_of_known_filters() {
    for (name, k) in [
        ("bcc7", 2),
        ("bcc8", 2),
        ("bcc12", 2),
        ("cc_tricubic", 2),
        ("fcc6", 1),
        ("cc6", 1),
        ("zp", 1),
        ("cc_triquadratic", 1),
        ("bcc_linear", 0),
        ("cc_trilinear", 0),
        ("courant", 0),
    ] {
        let d = Derivation::new(&catalog::get(name).unwrap()).unwrap();
        assert_eq!(d.facts.continuity, k, "{name}");
        let md = Report::new(&d).to_markdown();
        let line = smoothness(d.facts.continuity, d.facts.degree);
        assert!(md.contains(&line), "{name}: the report states its smoothness");
        assert_eq!(line.contains("Hessian are continuous"), k >= 2, "{name}: {line}");
        assert_eq!(line.contains("Hessian jumps"), k == 1, "{name}: {line}");
    }
}

#[test]
fn all_coefficients_lists_them_past_the_limit() {
    let d = Derivation::new(&catalog::get("bcc_sheared_trilinear").unwrap()).unwrap();
    let counts = |r: &Report| -> (bool, usize, usize) {
        (
            r.work.coefficients_listed,
            r.reference_pieces.iter().map(|p| p.bb.len()).sum(),
            r.reference_pieces.iter().flat_map(|p| &p.power).map(|p| p.terms.len()).sum(),
        )
    };
    let limited = ReportOptions { detail_limit: d.polynomials() - 1, ..ReportOptions::default() };
    let (listed, bb, power) = counts(&Report::with_options(&d, &limited));
    assert_eq!((listed, bb, power), (false, 0, 0), "over the limit nothing is listed");
    let all = ReportOptions { all_coefficients: true, ..limited };
    let full = Report::with_options(&d, &all);
    let (listed, _, power) = counts(&full);
    assert!(listed && power > 0, "all_coefficients lists them past the limit");
    // Under the default limit this small filter lists the same coefficients.
    assert_eq!(full.to_json(), Report::new(&d).to_json());
    assert_eq!(ReportOptions::all_coefficients(), ReportOptions { all_coefficients: true, ..Default::default() });
    assert!(ReportOptions::default().lists_coefficients(DETAIL_LIMIT_POLYNOMIALS));
    assert!(!ReportOptions::default().lists_coefficients(DETAIL_LIMIT_POLYNOMIALS + 1));
}

#[test]
fn unknown_names_have_no_purpose() {
    let b = module_bindings("zp", "x.wgsl", "@group(0) @binding(0) var<uniform> zp_other: vec4<f32>;").unwrap();
    assert_eq!(b.len(), 1);
    assert_eq!(b[0].purpose, None);
    assert!(module_bindings("zp", "x.wgsl", "not wgsl").is_err());
}
