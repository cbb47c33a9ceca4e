//! `boxforge web`: write the browser viewer (a static site), and serve it
//! with --serve.

use crate::common::Failure;
use crate::request;
use boxforge::spec;
use boxforge_runtime::web;

#[derive(clap::Args)]
pub struct WebArgs {
    /// Spec files (or catalog names) to add; the whole catalog is always in.
    specs: Vec<String>,
    /// Only these filters (comma-separated catalog names or spec files) instead of the catalog.
    #[arg(long, value_delimiter = ',')]
    only: Vec<String>,
    /// Site folder (default: site). --serve builds it only when it holds no site yet.
    #[arg(short, long)]
    out: Option<std::path::PathBuf>,
    /// Serve the site on 127.0.0.1 and print its URL (until interrupted).
    #[arg(long)]
    serve: bool,
    /// Port for --serve (0: any free port).
    #[arg(long, default_value_t = 8000, requires = "serve")]
    port: u16,
    /// Leave the MNI head out of the site (it is 3.6 MB).
    #[arg(long)]
    no_mni: bool,
}

pub fn run(a: WebArgs) -> Result<(), Failure> {
    let WebArgs { specs, only, out, serve, port, no_mni } = a;
    let dir = out.unwrap_or_else(|| std::path::PathBuf::from("site"));
    // --serve serves an existing site as it is (build it again without --serve).
    let build = !serve || !dir.join("index.html").is_file();
    if build {
        request::check_output_dir(&dir, "--out")?;
        let mut names: Vec<String> =
            if only.is_empty() { spec::catalog::names().into_iter().map(String::from).collect() } else { only };
        for s in &specs {
            if !names.contains(s) {
                names.push(s.clone());
            }
        }
        let filters = names.iter().map(|n| spec::resolve(n)).collect::<Result<Vec<_>, _>>()?;
        let volumes = if no_mni { vec![] } else { vec![web::mni_volume(2).map_err(failure)?] };
        let started = std::time::Instant::now();
        let site = web::write_site(&dir, &filters, &web::SiteOptions { volumes }, |i, n, name| {
            eprintln!("web: [{}/{n}] {name}", i + 1)
        })
        .map_err(failure)?;
        outln!(
            "{}: viewer for {} filters ({}), {} catalog modules, {} files, {:.1} MB in {:.1} s",
            dir.display(),
            site.filters.len(),
            site.filters.join(", "),
            site.modules,
            site.files.len(),
            site.bytes as f64 / 1e6,
            started.elapsed().as_secs_f64()
        );
    }
    if serve {
        let server = web::serve(&dir, port).map_err(failure)?;
        outln!("serving {} at {} (Ctrl-C to stop)", dir.display(), server.url());
        server.run();
    } else {
        outln!(
            "serve it with: boxforge web --serve -o {} (or any static file server; WebGPU needs https or localhost)",
            dir.display()
        );
    }
    Ok(())
}

/// A refusal of the site's writer or server, worded with this command's flags.
fn failure(e: web::WebError) -> Failure {
    use web::WebError;
    Failure(match e {
        WebError::MissingMni => {
            "the MNI head data/mni152_t1_1mm.nii.gz is missing: run from the repository root, or pass --no-mni".into()
        }
        WebError::NoSite { root } => format!(
            "{} holds no index.html: build the site first with boxforge web -o {}",
            root.display(),
            root.display()
        ),
        WebError::Listen { port, error } => {
            format!("cannot listen on 127.0.0.1:{port}: {error} (pick another --port, or --port 0 for any free one)")
        }
        WebError::TransferFunction(e) => format!("--tf {e}"),
        e => e.to_string(),
    })
}
