//! The generated evaluation timed beside a hand-written one.

use super::job::{can_filter_f32, program, timed_rounds, Job};
use super::options::derive_filter;
use super::stats::{median, Ratio};
use super::{BenchError, ReferenceRow};
use crate::gpu::Gpu;
use crate::references::{self, Reference};
use crate::verify::{random_volume, Rng};
use crate::volume::{DeviceVolume, LatticeVolume};
use boxforge::derive::Derivation;
use boxforge::emit::{emit, EmitOptions, FetchMode, Layout};

/// Agreement required between a reference and the generated evaluation:
/// max |generated - reference| below this fraction of the data range.
pub const REFERENCE_TOLERANCE: f64 = 1e-5;

/// Evaluations per invocation in the ray-caster kernel shape.
pub const RAY_STEPS: u32 = 16;

/// Where the two kernel shapes' ratios may differ before the report says so.
pub const SHAPE_DISAGREEMENT: f64 = 0.10;

/// A function `bx_ray_<f>(p)` that evaluates `f` at [`RAY_STEPS`] points a
/// quarter cell apart along a fixed unit direction from `p` and returns their
/// sum: the shape of a ray caster's inner loop (several evaluations per
/// invocation, consecutive points close together so their loads share cache
/// lines, one write), where one evaluation per invocation measures mostly
/// launch and write costs on some adapters.
pub fn ray_shape(f: &str) -> String {
    format!(
        "fn bx_ray_{f}(p: vec3<f32>) -> f32 {{\n    var acc = 0.0;\n    for (var k = 0u; k < {RAY_STEPS}u; k++) {{\n        acc += {f}(p + (0.25 * f32(k)) * vec3<f32>(0.48, 0.36, 0.8));\n    }}\n    return acc;\n}}\n"
    )
}

/// The generated `<name>_eval` cut after its last fetch, returning the mean
/// of the fetched samples as `<name>_loads_only`: the same point location,
/// addressing and loads with none of the arithmetic after them. None when
/// the body has no fetch lines of the form `let f = <name>_fetch...`.
pub fn loads_only(module: &str, name: &str) -> Option<String> {
    let start = module.find(&format!("fn {name}_eval(p: "))?;
    let open = start + module[start..].find('{')? + 1;
    let end = open + module[open..].find("\n}\n")?;
    let lines: Vec<&str> = module[open..end].lines().collect();
    let call = format!("{name}_fetch");
    let last = lines.iter().rposition(|l| l.contains(&call))?;
    let fetched: Vec<&str> = lines[..=last]
        .iter()
        .filter(|l| l.contains(&call))
        .filter_map(|l| l.trim().strip_prefix("let ")?.split(' ').next())
        .collect();
    if fetched.is_empty() {
        return None;
    }
    Some(format!(
        "fn {name}_loads_only(p: vec3<f32>) -> f32 {{\n{}\n    return ({}) * {:?};\n}}\n",
        lines[..=last].join("\n"),
        fetched.join(" + "),
        1.0f32 / fetched.len() as f32
    ))
}

/// An n^3-ish volume of random data (at least the support-sized one of
/// `verify`): what the generated-vs-hand-written comparisons run on.
pub(super) fn bench_volume(d: &Derivation, n: usize) -> LatticeVolume {
    let vol = random_volume(d, 11);
    if vol.dims[0] >= n {
        return vol;
    }
    let mut rng = Rng(17);
    let mut data = vec![0f32; n * n * n];
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                if d.filter.lattice.contains(&[i as i64, j as i64, k as i64]) {
                    data[i + n * (j + n * k)] = rng.next_f64() as f32;
                }
            }
        }
    }
    LatticeVolume { lattice: d.filter.lattice.clone(), dims: [n, n, n], data }
}

/// Times a hand-written evaluation beside the generated `<like>_eval` on the
/// same random points of a random volume, after checking that they agree.
pub fn compare_reference(gpu: &Gpu, r: &Reference, points: usize, rounds: usize) -> Result<ReferenceRow, BenchError> {
    let d = derive_filter(&r.like)?;
    let name = d.filter.name.clone();
    let vol = bench_volume(&d, 64);
    let pts = crate::verify::random_points(&d, &vol, points, 23);
    let (lo, hi) = vol.data.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
    let data_range = (hi - lo).max(f32::MIN_POSITIVE) as f64;
    // A reference that uses hardware filtering meets the generated module
    // with linear fetches where the filter allows them (same fetch budget).
    let linear = references::uses_sampler(&r.source)
        && can_filter_f32(gpu)
        && d.factorisation().is_some_and(|f| f.supports_linear_fetch());
    let fetch = if linear { FetchMode::Linear } else { FetchMode::Exact };
    let m = emit(&d, &EmitOptions { kernels: false, fetch, ..Default::default() })?;
    let module_with_ref = format!("{}\n{}", m.source, r.source);
    let reference_ops = references::ops(&module_with_ref, &r.source, &r.entry);
    let mut row = ReferenceRow {
        filter: name.clone(),
        generated: if linear { format!("{name}_eval (linear fetches)") } else { format!("{name}_eval") },
        reference: r.name.clone(),
        entry: r.entry.clone(),
        citation: r.citation.clone(),
        generated_fetches: m.stats.fetches_per_eval,
        reference_fetches: references::fetches(&module_with_ref, &r.source, &r.entry),
        generated_ops: m.stats.ops_eval,
        reference_ops,
        generated_evals_per_s: None,
        reference_evals_per_s: None,
        ratio: None,
        points: pts.len(),
        max_abs_diff: None,
        data_range,
        rel_diff: None,
        agrees: false,
        note: None,
        loads_only_ratio: None,
        ray_ratio: None,
        ray_loads_only_ratio: None,
    };
    if references::uses_sampler(&r.source) && !can_filter_f32(gpu) {
        row.note = Some(format!(
            "skipped: {} needs hardware filtering of R32Float, and this adapter lacks FLOAT32_FILTERABLE",
            r.name
        ));
        return Ok(row);
    }
    let dv = if linear {
        DeviceVolume::new_filtered(gpu, &vol, Layout::Embedded)
    } else {
        DeviceVolume::new(gpu, &vol, Layout::Embedded)
    }?;
    let ours = program(&m.source, "", &format!("vec4<f32>({name}_eval(p), 0.0, 0.0, 0.0)"));
    let theirs = program(&m.source, &r.source, &format!("vec4<f32>({}(p), 0.0, 0.0, 0.0)", r.entry));
    let ray = |extra: &str, f: &str| {
        program(&m.source, &format!("{extra}\n{}", ray_shape(f)), &format!("vec4<f32>(bx_ray_{f}(p), 0.0, 0.0, 0.0)"))
    };
    let a = Job::new(gpu, &ours, &m.file_name, &dv, &pts)?;
    let b = Job::new(gpu, &theirs, &r.name, &dv, &pts)?;
    // The check first: a reference that disagrees is not timed.
    a.time(gpu)?;
    b.time(gpu)?;
    let (va, vb) = (a.outputs(gpu)?, b.outputs(gpu)?);
    let (max_diff, rel, invalid) = check(&va, &vb, data_range);
    row.max_abs_diff = Some(max_diff);
    row.rel_diff = Some(rel);
    row.agrees = invalid.is_none();
    if invalid.is_some() {
        row.note = invalid;
        return Ok(row);
    }
    // The ceiling of exact loads: the generated eval cut after its fetches.
    let cut = loads_only(&m.source, &name).filter(|_| !linear);
    let ceiling = match &cut {
        Some(f) => {
            let src = program(&m.source, f, &format!("vec4<f32>({name}_loads_only(p), 0.0, 0.0, 0.0)"));
            Some(Job::new(gpu, &src, &format!("{name} loads only"), &dv, &pts)?)
        }
        None => None,
    };
    // The ray-caster shape of the same three, timed in the same rounds.
    let a_ray = Job::new(gpu, &ray("", &format!("{name}_eval")), &format!("{} ray", m.file_name), &dv, &pts)?;
    let b_ray = Job::new(gpu, &ray(&r.source, &r.entry), &format!("{} ray", r.name), &dv, &pts)?;
    let ceiling_ray = match &cut {
        Some(f) => {
            Some(Job::new(gpu, &ray(f, &format!("{name}_loads_only")), &format!("{name} loads only ray"), &dv, &pts)?)
        }
        None => None,
    };
    let mut jobs = vec![&a, &b, &a_ray, &b_ray];
    jobs.extend(ceiling.as_ref());
    jobs.extend(ceiling_ray.as_ref());
    let rates = timed_rounds(gpu, &jobs, rounds)?;
    row.generated_evals_per_s = Some(median(&rates[0]));
    row.reference_evals_per_s = Some(median(&rates[1]));
    row.ratio = Some(Ratio::of_rates(&rates[0], &rates[1]));
    row.ray_ratio = Some(Ratio::of_rates(&rates[2], &rates[3]));
    row.loads_only_ratio = rates.get(4).map(|c| Ratio::of_rates(c, &rates[1]));
    row.ray_loads_only_ratio = rates.get(5).map(|c| Ratio::of_rates(c, &rates[3]));
    row.note = shape_note(row.ratio.as_ref(), row.ray_ratio.as_ref());
    Ok(row)
}

/// The check before timing: (max |a - b| over the first components, that
/// ÷ `data_range`, the INVALID note when it is not below
/// [`REFERENCE_TOLERANCE`]). A NaN anywhere makes the maximum NaN (invalid).
pub(super) fn check(a: &[[f32; 4]], b: &[[f32; 4]], data_range: f64) -> (f64, f64, Option<String>) {
    let max_diff = a.iter().zip(b).map(|(x, y)| (x[0] as f64 - y[0] as f64).abs()).fold(0f64, |m, x| {
        if x.is_nan() || m.is_nan() {
            f64::NAN
        } else {
            m.max(x)
        }
    });
    let max_diff = if a.len() == b.len() { max_diff } else { f64::NAN };
    let rel = max_diff / data_range;
    let agrees = rel < REFERENCE_TOLERANCE;
    let invalid = (!agrees).then(|| {
        format!(
            "INVALID: max |generated - reference| = {max_diff:.3e} = {rel:.2e} of the data range (tolerance {REFERENCE_TOLERANCE:.0e}); not timed"
        )
    });
    (max_diff, rel, invalid)
}

/// "kernel shapes disagree: ..." when the one-evaluation and the ray-caster
/// ratios differ by more than [`SHAPE_DISAGREEMENT`].
pub fn shape_note(single: Option<&Ratio>, ray: Option<&Ratio>) -> Option<String> {
    let (s, r) = (single?.median, ray?.median);
    let apart = (s / r - 1.0).abs();
    (apart > SHAPE_DISAGREEMENT).then(|| {
        format!(
            "kernel shapes disagree by {:.0}%: {s:.2}x with one evaluation per invocation, {r:.2}x in the ray-caster shape ({RAY_STEPS} evaluations per invocation); the ray-caster shape is the one a renderer sees",
            apart * 100.0
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ray_shape_validates_and_shapes_are_compared() {
        let d = derive_filter("bcc7").unwrap();
        let m = emit(&d, &EmitOptions { kernels: false, ..Default::default() }).unwrap();
        let src = program(&m.source, &ray_shape("bcc7_eval"), "vec4<f32>(bx_ray_bcc7_eval(p), 0.0, 0.0, 0.0)");
        let r = boxforge::validate::validate_wgsl(&src, "ray");
        assert!(r.valid, "{:?}", r.error);
        let ratio = |m: f64| Ratio { median: m, min: m, max: m, rounds: 1, tie: false };
        assert!(shape_note(Some(&ratio(1.0)), Some(&ratio(1.05))).is_none());
        let note = shape_note(Some(&ratio(1.39)), Some(&ratio(1.07))).unwrap();
        assert!(note.contains("disagree by 30%"), "{note}");
        assert!(shape_note(None, Some(&ratio(1.0))).is_none());
    }

    /// The loads-only cut keeps the eval's point location and every fetch,
    /// drops the arithmetic after them, and is valid WGSL beside the module.
    #[test]
    fn loads_only_keeps_every_fetch_and_nothing_after() {
        for name in ["bcc7", "fcc6", "cc_tricubic"] {
            let d = derive_filter(name).unwrap();
            let m = emit(&d, &EmitOptions { kernels: false, ..Default::default() }).unwrap();
            let cut = loads_only(&m.source, name).unwrap();
            let call = format!("{name}_fetch(");
            assert_eq!(cut.matches(&call).count(), m.stats.fetches_per_eval, "{name}");
            let eval = m.source.split(&format!("fn {name}_eval(")).nth(1).unwrap().split("\n}\n").next().unwrap();
            assert!(boxforge::emit::count_ops(&cut) < boxforge::emit::count_ops(eval), "{name}: nothing was cut");
            let r = boxforge::validate::validate_wgsl(&format!("{}\n{cut}", m.source), name);
            assert!(r.valid, "{name}: {:?}", r.error);
        }
        assert!(loads_only("fn x_eval(p: vec3<f32>) -> f32 {\n    return 1.0;\n}\n", "x").is_none());
    }
}
