//! The GLSL world's generated-vs-hand-written row (issue 25): Kim & Lee's
//! bcc7 evaluation as published in GLSL (runtime/references/kim_lee_bcc7.glsl)
//! beside the generated bcc7 translated into GLSL by
//! [`boxforge::back::translate`], each behind the same hand-written compute
//! entry point ([`kernel`]), both compiled by glslang to SPIR-V and run
//! through wgpu's passthrough on the same volume and points. The check, the
//! interleaved rounds and the statistics are the WGSL table's
//! ([`super::compare_reference`]): a comparison whose values differ by
//! [`REFERENCE_TOLERANCE`](super::REFERENCE_TOLERANCE) of the data range or more is INVALID and not
//! timed. A reported row, not a gate: a missing glslang, or an adapter
//! without passthrough, gives a row that says so.

use super::compare::{bench_volume, check, RAY_STEPS};
use super::job::{timed_rounds, Job};
use super::options::derive_filter;
use super::rows::GlslRivalRow;
use super::stats::{median, Ratio};
use super::BenchError;
use crate::gpu::Gpu;
use crate::references::Reference;
use crate::targets::{glslang, TargetError};
use crate::verify::kernel::{MAX_GROUPS_X, WORKGROUP_SIZE};
use crate::verify::{data_range, random_points};
use crate::volume::DeviceVolume;
use boxforge::back::{translate, Target, TranslateOptions};
use boxforge::emit::{emit, EmitOptions, Layout};

/// Kim & Lee's bcc7 in GLSL as published (Figure 7's code and the slides'
/// simplified symbolic formula, ÷ 384): `float kim_lee_bcc7(vec3 p_in)` and
/// its own clamped fetch on `volume_tex`, set 0 binding 0.
pub const KIM_LEE_BCC7_GLSL: &str = include_str!("../../references/kim_lee_bcc7.glsl");

/// Points per volume side of the comparison's random volume.
const VOLUME_SIDE: usize = 64;

/// The built-in GLSL references (GLSL source in [`Reference::source`]).
pub fn builtin() -> Vec<Reference> {
    vec![Reference {
        name: "Kim & Lee bcc7 (GLSL)".into(),
        like: "bcc7".into(),
        entry: "kim_lee_bcc7".into(),
        citation:
            "M. Kim & Y. Lee 2012 / M. Kim 2013: branch-free GLSL (Fig. 7) + simplified symbolic formula, as published"
                .into(),
        source: KIM_LEE_BCC7_GLSL.into(),
    }]
}

/// A complete GLSL 4.50 compute shader around `library` that writes
/// `vec4(f(p), 0, 0, 0)` at every point (`ray`: the sum of `f` at
/// `RAY_STEPS` (16) points a quarter cell apart, as the WGSL table's ray-caster
/// shape): the points at set 1 binding 0, the outputs at set 1 binding 1,
/// the same kernel as [`super::program`]'s for [`Job::from_spirv`].
pub fn kernel(library: &str, f: &str, ray: bool) -> String {
    let (helper, call) = if ray {
        (
            format!(
                "float bx_ray(vec3 p) {{\n    float acc = 0.0;\n    for (uint k = 0u; k < {RAY_STEPS}u; k++) {{\n        acc += {f}(p + (0.25 * float(k)) * vec3(0.48, 0.36, 0.8));\n    }}\n    return acc;\n}}\n"
            ),
            "bx_ray(p)".to_string(),
        )
    } else {
        (String::new(), format!("{f}(p)"))
    };
    format!(
        "#version 450 core\n{library}\n\
// The timing entry point (boxforge, by hand): one write per invocation.\n\
layout(local_size_x = {WORKGROUP_SIZE}) in;\n\
layout(std430, set = 1, binding = 0) readonly buffer BxPoints {{ vec4 bx_points[]; }};\n\
layout(std430, set = 1, binding = 1) buffer BxOut {{ vec4 bx_out[]; }};\n\
{helper}\
void main() {{\n\
    uint i = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * {MAX_GROUPS_X}u * {WORKGROUP_SIZE}u;\n\
    if (i >= uint(bx_points.length())) {{\n\
        return;\n\
    }}\n\
    vec3 p = bx_points[i].xyz;\n\
    bx_out[i] = vec4({call}, 0.0, 0.0, 0.0);\n\
}}\n"
    )
}

/// Times the generated `<like>_eval` translated into GLSL beside the GLSL
/// reference `r`, on the same random points of a random 64^3 volume.
pub fn compare_glsl(gpu: &Gpu, r: &Reference, points: usize, rounds: usize) -> Result<GlslRivalRow, BenchError> {
    compare_on(gpu, r, VOLUME_SIDE, points, rounds)
}

/// [`compare_glsl`] on a random volume of `side`^3 points (at least the
/// support-sized one).
fn compare_on(gpu: &Gpu, r: &Reference, side: usize, points: usize, rounds: usize) -> Result<GlslRivalRow, BenchError> {
    let d = derive_filter(&r.like)?;
    let name = d.filter.name.clone();
    let vol = bench_volume(&d, side);
    let pts = random_points(&d, &vol, points, 23);
    let mut row = GlslRivalRow {
        filter: name.clone(),
        generated: format!("{name}_eval (boxforge::back::translate → GLSL 4.50)"),
        reference: r.name.clone(),
        entry: r.entry.clone(),
        citation: r.citation.clone(),
        compiled_by: None,
        points: pts.len(),
        generated_evals_per_s: None,
        reference_evals_per_s: None,
        ratio: None,
        ray_ratio: None,
        max_abs_diff: None,
        data_range: data_range(&vol),
        rel_diff: None,
        agrees: false,
        note: None,
    };
    if !gpu.device.features().contains(wgpu::Features::PASSTHROUGH_SHADERS) {
        row.note = Some("skipped: this adapter does not take SPIR-V as it is (no PASSTHROUGH_SHADERS)".into());
        return Ok(row);
    }
    let m = emit(&d, &EmitOptions { kernels: false, command: "boxforge bench".into(), ..Default::default() })?;
    let stem = m.file_name.trim_end_matches(".wgsl").to_string();
    let t = translate(&m.source, &stem, Target::Glsl, &TranslateOptions::default())?;
    let library = crate::targets::library(&t)?;
    let f_gen = format!("{name}_eval");
    // Four programs: (source, label); a compile failure is the row's note.
    let sources = [
        (kernel(library, &f_gen, false), format!("{f_gen} GLSL")),
        (kernel(&r.source, &r.entry, false), r.name.clone()),
        (kernel(library, &f_gen, true), format!("{f_gen} GLSL ray")),
        (kernel(&r.source, &r.entry, true), format!("{} ray", r.name)),
    ];
    let mut words = Vec::with_capacity(sources.len());
    for (source, label) in &sources {
        match glslang::compile(source, glslang::Source::Glsl, label) {
            Ok((w, by)) => {
                row.compiled_by = Some(by);
                words.push(w);
            }
            Err(e @ TargetError::MissingTool { .. }) => {
                row.note = Some(format!("skipped: {e}"));
                return Ok(row);
            }
            Err(TargetError::Compile { label, by, message }) => {
                let first =
                    message.lines().find(|l| l.contains("ERROR")).unwrap_or(message.lines().next().unwrap_or(""));
                row.note = Some(format!("INVALID: {label} does not compile ({by}): {}; not timed", first.trim()));
                return Ok(row);
            }
            Err(e) => return Err(e.into()),
        }
    }
    let dv = DeviceVolume::new(gpu, &vol, Layout::Embedded)?;
    let job = |k: usize| Job::from_spirv(gpu, &words[k], "main", &sources[k].1, &dv, &pts);
    let (a, b) = (job(0)?, job(1)?);
    // The check first: a reference that disagrees is not timed.
    a.time(gpu)?;
    b.time(gpu)?;
    let (max_diff, rel, invalid) = check(&a.outputs(gpu)?, &b.outputs(gpu)?, row.data_range);
    row.max_abs_diff = Some(max_diff);
    row.rel_diff = Some(rel);
    row.agrees = invalid.is_none();
    if invalid.is_some() {
        row.note = invalid;
        return Ok(row);
    }
    let (a_ray, b_ray) = (job(2)?, job(3)?);
    let rates = timed_rounds(gpu, &[&a, &b, &a_ray, &b_ray], rounds)?;
    row.generated_evals_per_s = Some(median(&rates[0]));
    row.reference_evals_per_s = Some(median(&rates[1]));
    row.ratio = Some(Ratio::of_rates(&rates[0], &rates[1]));
    row.ray_ratio = Some(Ratio::of_rates(&rates[2], &rates[3]));
    row.note = super::compare::shape_note(row.ratio.as_ref(), row.ray_ratio.as_ref());
    Ok(row)
}

#[cfg(test)]
mod tests {
    use super::super::markdown::{glsl_rivals_markdown as markdown, GLSL_HEADING as HEADING};
    use super::super::REFERENCE_TOLERANCE;
    use super::*;
    use std::sync::OnceLock;

    fn gpu() -> &'static Gpu {
        static GPU: OnceLock<Gpu> = OnceLock::new();
        GPU.get_or_init(|| Gpu::new(None).unwrap_or_else(|e| panic!("{e}")))
    }

    fn kim_lee() -> Reference {
        builtin().into_iter().find(|r| r.entry == "kim_lee_bcc7").unwrap()
    }

    /// The published GLSL compiles with glslang, agrees with the generated
    /// bcc7 translated into GLSL within the tolerance, and both are timed.
    #[test]
    fn kim_lee_glsl_compiles_and_matches_the_generated_glsl() {
        let row = compare_on(gpu(), &kim_lee(), 16, 3000, 1).unwrap();
        assert!(row.agrees, "{row:?}");
        assert!(row.rel_diff.unwrap() < REFERENCE_TOLERANCE, "{row:?}");
        assert!(row.compiled_by.as_deref().unwrap().starts_with("glslangValidator"), "{row:?}");
        let ratio = row.ratio.expect("timed");
        assert!(ratio.rounds == 1 && ratio.median > 0.0, "{ratio:?}");
        assert!(row.ray_ratio.is_some() && row.generated_evals_per_s.unwrap() > 0.0, "{row:?}");
        let md = markdown(&[row]);
        assert!(md.starts_with(HEADING) && md.contains("| `bcc7_eval (boxforge::back::translate"), "{md}");
    }

    /// The check can fail: the formula without its ÷384, or with one fetch
    /// offset changed, is reported INVALID and not timed.
    #[test]
    fn a_broken_glsl_reference_is_invalid_and_not_timed() {
        let kim = kim_lee();
        for (from, to) in [("* (1.0 / 384.0)", "* 1.0"), ("o += R[2];    FETCH(c24);", "o += R[1];    FETCH(c24);")] {
            assert!(kim.source.contains(from), "{from}");
            let wrong = Reference { source: kim.source.replace(from, to), ..kim.clone() };
            let row = compare_on(gpu(), &wrong, 16, 3000, 1).unwrap();
            assert!(!row.agrees && row.ratio.is_none() && row.generated_evals_per_s.is_none(), "{to}: {row:?}");
            assert!(row.note.as_deref().unwrap().starts_with("INVALID"), "{row:?}");
            assert!(markdown(&[row]).contains("**INVALID"));
        }
        // GLSL that glslang refuses is INVALID too, not an error of the bench.
        let broken = Reference { source: kim.source.replace("float x = xtet.x;", "float x = xtet.w;"), ..kim };
        let row = compare_on(gpu(), &broken, 16, 300, 1).unwrap();
        assert!(!row.agrees && row.note.as_deref().unwrap().contains("does not compile"), "{row:?}");
    }

    /// The subsection travels with "## Generated vs hand-written": splicing
    /// the section into a file replaces the old subsection too.
    #[test]
    fn the_glsl_subsection_splices_with_its_section() {
        let row = |note: Option<&str>| GlslRivalRow {
            filter: "bcc7".into(),
            generated: "bcc7_eval".into(),
            reference: "Kim & Lee bcc7 (GLSL)".into(),
            entry: "kim_lee_bcc7".into(),
            citation: "paper".into(),
            compiled_by: None,
            points: 1,
            generated_evals_per_s: None,
            reference_evals_per_s: None,
            ratio: None,
            ray_ratio: None,
            max_abs_diff: None,
            data_range: 1.0,
            rel_diff: None,
            agrees: false,
            note: note.map(str::to_string),
        };
        let old = super::super::references_section(&[], &[row(Some("old note"))], None);
        let file = format!("# B\n\n{old}## Evaluation throughput\n\nrows\n");
        let new =
            super::super::references_section(&[], &[row(Some("skipped: glslangValidator is not installed"))], None);
        let out = super::super::splice_references(&file, &new);
        assert_eq!(out.matches(HEADING).count(), 1, "{out}");
        assert!(!out.contains("old note") && out.contains("**skipped: glslangValidator is not installed**"), "{out}");
        assert!(out.contains("(not compiled)") && out.ends_with("## Evaluation throughput\n\nrows\n"), "{out}");
    }

    #[test]
    fn both_kernel_shapes_write_one_vec4_per_point() {
        let k = kernel("float f(vec3 p) { return p.x; }\n", "f", false);
        assert!(k.starts_with("#version 450 core\nfloat f(") && k.contains("bx_out[i] = vec4(f(p), 0.0"), "{k}");
        let r = kernel("float f(vec3 p) { return p.x; }\n", "f", true);
        assert!(r.contains(&format!("k < {RAY_STEPS}u")) && r.contains("vec4(bx_ray(p), 0.0"), "{r}");
        assert!(markdown(&[]).is_empty());
    }
}
