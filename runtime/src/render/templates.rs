//! The runtime's WGSL templates, in one minijinja environment for the whole
//! crate, built on first use. The files live in `templates/runtime/` at the
//! top of the repository (beside the generator's `templates/generator/`);
//! `runtime/templates` links there, so `cargo package` ships them inside the
//! crate and these `include_str!` paths stay within it.
//!
//! Every template is registered under its short name (`raycast`, `dvr`,
//! `paged`, `perm`, `perm_build`, `four_hit`, `hit_roots`): that is the name
//! the templates `{% include %}` each other by. The environment keeps
//! minijinja's defaults, as each renderer's own environment did, so the WGSL
//! is the same text byte for byte.

use std::sync::OnceLock;

/// The fixed-step and exact-hit ray caster (isosurfaces).
pub(crate) const RAYCAST: &str = include_str!("../../templates/raycast.wgsl.j2");
/// The direct volume rendering ray caster.
pub(crate) const DVR: &str = include_str!("../../templates/dvr.wgsl.j2");
/// The out-of-core sampling included by `raycast` and `dvr` (`paged`).
pub(crate) const PAGED: &str = include_str!("../../templates/paged.wgsl.j2");
/// The PERM cache lookup and formats.
pub(crate) const PERM: &str = include_str!("../../templates/perm.wgsl.j2");
/// The PERM cache preprocessing.
pub(crate) const PERM_BUILD: &str = include_str!("../../templates/perm_build.wgsl.j2");
/// The 4D exact-hit walk.
pub(crate) const FOUR_HIT: &str = include_str!("../../templates/four_hit.wgsl.j2");
/// The first-root search shared by the exact walks.
pub(crate) const HIT_ROOTS: &str = include_str!("../../templates/hit_roots.wgsl.j2");
/// The projected-tetrahedra render pipeline: plain WGSL, no template.
pub(crate) const PT: &str = include_str!("../../templates/pt.wgsl");

/// (name, text) of every template, the names the templates include by.
const ALL: [(&str, &str); 7] = [
    ("raycast", RAYCAST),
    ("dvr", DVR),
    ("paged", PAGED),
    ("perm", PERM),
    ("perm_build", PERM_BUILD),
    ("four_hit", FOUR_HIT),
    ("hit_roots", HIT_ROOTS),
];

fn environment() -> &'static minijinja::Environment<'static> {
    static ENV: OnceLock<minijinja::Environment<'static>> = OnceLock::new();
    ENV.get_or_init(|| {
        let mut env = minijinja::Environment::new();
        for (name, text) in ALL {
            env.add_template(name, text).expect("the runtime's templates parse (a test renders each)");
        }
        env
    })
}

/// The template `name` (one of `ALL`'s) rendered with `ctx`. The
/// templates are the crate's own and every renderer's context is fixed in
/// code, so a failure is a bug here, not bad input: it panics.
pub(crate) fn render(name: &str, ctx: minijinja::Value) -> String {
    let template = environment().get_template(name).unwrap_or_else(|e| panic!("template {name}: {e}"));
    template.render(ctx).unwrap_or_else(|e| panic!("template {name}: {e}"))
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_runtime_template_parses_under_its_include_name() {
        let env = super::environment();
        for (name, text) in super::ALL {
            let t = env.get_template(name).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(t.source(), text, "{name}");
        }
        // `paged` alone renders (the others need their renderer's context).
        assert!(super::render("paged", minijinja::context! { name => "bcc7" }).contains("bcc7"));
    }
}
