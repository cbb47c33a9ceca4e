//! The libraries' error enums say what went wrong in their own terms: no
//! catch-all variant whose whole message is one string handed in from
//! elsewhere (`#[error("{0}")]`, `#[error("{message}")]`: the caller's text,
//! typed as nothing), and no message that names a command-line flag
//! (`--format`): the library does not know which flags, if any, its caller
//! has. The CLI words its own messages (`runtime/src/bin/`, not checked).
//! `#[error(transparent)]` wraps a typed error and is fine.

use std::path::{Path, PathBuf};

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries {
        let p = e.unwrap().path();
        if p.is_dir() {
            // The CLI is not a library: its messages name its flags.
            if p.file_name().is_some_and(|n| n != "bin") {
                rust_files(&p, out);
            }
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The format strings of every `#[error("...")]` attribute in `text`.
fn error_messages(text: &str) -> Vec<String> {
    let mut found = Vec::new();
    let mut rest = text;
    while let Some(i) = rest.find("#[error(") {
        rest = &rest[i + "#[error(".len()..];
        let body = rest.trim_start();
        let Some(literal) = body.strip_prefix('"') else { continue };
        let mut message = String::new();
        let mut chars = literal.chars();
        while let Some(c) = chars.next() {
            match c {
                '\\' => {
                    if let Some(n) = chars.next() {
                        message.push('\\');
                        message.push(n);
                    }
                }
                '"' => break,
                c => message.push(c),
            }
        }
        found.push(message);
    }
    found
}

/// Why `message` is refused, if it is.
fn refusal(message: &str) -> Option<&'static str> {
    // One placeholder, with at most two words around it ("{0}", "GPU
    // error: {0}"): the message is whatever string the variant was built
    // with, so the variant says nothing of the case.
    let placeholders = message.matches('{').count();
    let words_around = message
        .split(['{', '}'])
        .enumerate()
        .filter(|(i, _)| i % 2 == 0)
        .map(|(_, t)| t.split_whitespace().count())
        .sum::<usize>();
    if placeholders == 1 && words_around <= 2 {
        return Some(
            "a catch-all: the whole message is one string from elsewhere (give the case a variant of its own)",
        );
    }
    let names_flag = message.match_indices("--").any(|(i, _)| {
        let before = message[..i].chars().next_back();
        let after = message[i + 2..].chars().next();
        before.is_none_or(|c| c == ' ' || c == '`' || c == '(') && after.is_some_and(|c| c.is_ascii_lowercase())
    });
    if names_flag {
        return Some("names a command-line flag (name the option or type instead; the CLI words its own messages)");
    }
    None
}

/// `path: message (why)` for every refused message under `roots`.
fn refused(roots: &[PathBuf]) -> Vec<String> {
    let mut files = Vec::new();
    for r in roots {
        rust_files(r, &mut files);
    }
    files.sort();
    let mut out = Vec::new();
    for f in files {
        let text = std::fs::read_to_string(&f).unwrap();
        for m in error_messages(&text) {
            if let Some(why) = refusal(&m) {
                out.push(format!("{}: \"{m}\" ({why})", f.display()));
            }
        }
    }
    out
}

#[test]
fn the_check_finds_a_catch_all_and_a_flag() {
    let dir = std::env::temp_dir().join(format!("boxforge-error-texts-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("bin")).unwrap();
    std::fs::write(
        dir.join("lib.rs"),
        "enum E {\n    #[error(\"{0}\")]\n    Runtime(String),\n    #[error(\"GPU error: {0}\")]\n    Gpu(String),\n    #[error(\n        \"{message}\"\n    )]\n    Other { message: String },\n    #[error(\"use --format f32\")]\n    Flag,\n    #[error(transparent)]\n    Typed(#[from] std::io::Error),\n    #[error(\"{a} of {b}: fine\")]\n    Fine { a: u32, b: u32 },\n    #[error(\"i32 range is -- wide, x--y\")]\n    NotAFlag,\n}\n",
    )
    .unwrap();
    std::fs::write(dir.join("bin/main.rs"), "#[error(\"use --format f32\")]\n").unwrap();
    let found = refused(std::slice::from_ref(&dir));
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(found.len(), 4, "{found:#?}");
    assert!(found[0].contains("\"{0}\"") && found[1].contains("GPU error: {0}"), "{found:#?}");
    assert!(found[2].contains("\"{message}\"") && found[3].contains("--format"), "{found:#?}");
}

#[test]
fn library_errors_are_typed_and_name_no_flag() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let roots = [root.join("generator/src"), root.join("runtime/src")];
    let found = refused(&roots);
    assert!(found.is_empty(), "{}", found.join("\n"));
}
