//! The generated evaluation timed beside a hand-written one.

use super::job::{can_filter_f32, program, timed_rounds, Job};
use super::options::derive_filter;
use super::stats::{median, Ratio};
use super::{BenchError, ReferenceRow};
use crate::gpu::Gpu;
use crate::references::{self, Reference};
use crate::verify::{random_volume, Rng};
use crate::volume::{DeviceVolume, LatticeVolume};
use boxforge::emit::{emit, EmitOptions, FetchMode, Layout};

/// Agreement required between a reference and the generated evaluation:
/// max |generated - reference| below this fraction of the data range.
pub const REFERENCE_TOLERANCE: f64 = 1e-5;

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

/// Times a hand-written evaluation beside the generated `<like>_eval` on the
/// same random points of a random volume, after checking that they agree.
pub fn compare_reference(gpu: &Gpu, r: &Reference, points: usize, rounds: usize) -> Result<ReferenceRow, BenchError> {
    let d = derive_filter(&r.like)?;
    let name = d.filter.name.clone();
    // A 64^3-ish volume of random data (at least the support-sized one).
    let mut vol = random_volume(&d, 11);
    if vol.dims[0] < 64 {
        let n = 64usize;
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
        vol = LatticeVolume { lattice: d.filter.lattice.clone(), dims: [n, n, n], data };
    }
    let pts = crate::verify::random_points(&d, &vol, points, 23);
    let (lo, hi) = vol.data.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
    let data_range = (hi - lo).max(f32::MIN_POSITIVE) as f64;
    // A reference that uses hardware filtering meets the generated module
    // with linear fetches where the filter allows them (same fetch budget).
    let linear = references::uses_sampler(&r.source)
        && can_filter_f32(gpu)
        && d.factorisation().is_some_and(|f| f.supports_linear_fetch());
    let fetch = if linear { FetchMode::Linear } else { FetchMode::Exact };
    let m = emit(&d, &EmitOptions { kernels: false, fetch, ..Default::default() }).map_err(BenchError::emit)?;
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
    let a = Job::new(gpu, &ours, &m.file_name, &dv, &pts)?;
    let b = Job::new(gpu, &theirs, &r.name, &dv, &pts)?;
    // The check first: a reference that disagrees is not timed.
    a.time(gpu)?;
    b.time(gpu)?;
    let (va, vb) = (a.outputs(gpu)?, b.outputs(gpu)?);
    let max_diff = va.iter().zip(&vb).map(|(x, y)| (x[0] as f64 - y[0] as f64).abs()).fold(0f64, |m, x| {
        if x.is_nan() || m.is_nan() {
            f64::NAN
        } else {
            m.max(x)
        }
    });
    let rel = max_diff / data_range;
    row.max_abs_diff = Some(max_diff);
    row.rel_diff = Some(rel);
    row.agrees = rel < REFERENCE_TOLERANCE;
    if !row.agrees {
        row.note = Some(format!(
            "INVALID: max |generated - reference| = {max_diff:.3e} = {rel:.2e} of the data range (tolerance {REFERENCE_TOLERANCE:.0e}); not timed"
        ));
        return Ok(row);
    }
    // The ceiling of exact loads: the generated eval cut after its fetches.
    let ceiling = match loads_only(&m.source, &name) {
        Some(f) if !linear => {
            let src = program(&m.source, &f, &format!("vec4<f32>({name}_loads_only(p), 0.0, 0.0, 0.0)"));
            Some(Job::new(gpu, &src, &format!("{name} loads only"), &dv, &pts)?)
        }
        _ => None,
    };
    let mut jobs = vec![&a, &b];
    jobs.extend(ceiling.as_ref());
    let rates = timed_rounds(gpu, &jobs, rounds)?;
    row.generated_evals_per_s = Some(median(&rates[0]));
    row.reference_evals_per_s = Some(median(&rates[1]));
    row.ratio = Some(Ratio::of_rates(&rates[0], &rates[1]));
    row.loads_only_ratio = rates.get(2).map(|c| Ratio::of_rates(c, &rates[1]));
    Ok(row)
}

#[cfg(test)]
mod tests {
    use super::*;

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
