//! The crate's one minijinja environment: the generator's templates
//! (`templates/generator/`, reached through the `generator/templates`
//! symlink so that `cargo package` ships them as files of this crate),
//! embedded at build time and parsed once per process.

use std::sync::OnceLock;

/// Every template of the generator, by the name the others include it under.
/// Embedded so the generator works as a build-dependency without the
/// repository around it.
const TEMPLATES: &[(&str, &str)] = &[
    ("module.wgsl.j2", include_str!("../../templates/module.wgsl.j2")),
    ("fetch_embedded.wgsl.j2", include_str!("../../templates/fetch_embedded.wgsl.j2")),
    ("fetch_packed.wgsl.j2", include_str!("../../templates/fetch_packed.wgsl.j2")),
    ("fetch_macros.wgsl.j2", include_str!("../../templates/fetch_macros.wgsl.j2")),
    ("fetch_bricked.wgsl.j2", include_str!("../../templates/fetch_bricked.wgsl.j2")),
    ("fetch_bricked-packed.wgsl.j2", include_str!("../../templates/fetch_bricked-packed.wgsl.j2")),
    ("fetch_storage.wgsl.j2", include_str!("../../templates/fetch_storage.wgsl.j2")),
    ("kernels.wgsl.j2", include_str!("../../templates/kernels.wgsl.j2")),
];

/// The environment every emission renders in (built on first use; the
/// templates are fixed, so one parse serves every module of a run).
pub(crate) fn env() -> &'static minijinja::Environment<'static> {
    static ENV: OnceLock<minijinja::Environment<'static>> = OnceLock::new();
    ENV.get_or_init(|| {
        let mut env = minijinja::Environment::new();
        env.set_syntax(
            minijinja::syntax::SyntaxConfig::builder()
                .keep_trailing_newline(true)
                .trim_blocks(true)
                .build()
                .expect("the default delimiters are a valid syntax"),
        );
        for &(name, source) in TEMPLATES {
            env.add_template(name, source)
                .expect("the embedded templates are fixed at build time and parse (every emission test renders them)");
        }
        env
    })
}
