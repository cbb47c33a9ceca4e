//! The render choices that the request checks read as well as the
//! `render` subcommand: typed (clap `ValueEnum`), in a module of their own
//! so that `request` does not import `render`, which uses `request`.

/// `--mode`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ModeArg {
    Iso,
    Dvr,
}

/// `--cache`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum CacheArg {
    None,
    Perm,
}

/// `--renderer`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum RendererArg {
    Raycast,
    Pt,
}
