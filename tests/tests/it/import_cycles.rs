//! No import cycles, at two levels: between files, and between the top-level
//! modules of a crate (its stages: `spec`, `derive`, `emit`, ... in the
//! generator; `gpu`, `volume`, `render`, ... in the runtime). A cycle means
//! two parts can only be understood (and changed) together, which the
//! one-stage-per-folder layout is meant to prevent.
//!
//! The graph has one node per source file (`foo/mod.rs` is the module `foo`)
//! and an edge for every path that starts with `crate::`, `super::` or
//! `self::` anywhere in a file's code, not only in `use` lines: in bodies,
//! signatures and attributes too (`#[from] crate::back::BackError` is an edge),
//! `use` trees expanded (`use super::{a, b::c}`). Each path is resolved to the
//! longest prefix that is a module file. Comments and string literals are not
//! code; `#[cfg(test)]` items (inline test modules and the files of
//! `#[cfg(test)] mod x;`) are left out: unit tests may reach back into the
//! module tree. The stage graph maps every file to its first path component.
//! Checked: `generator/src`, `runtime/src` (the library) and the CLI
//! (`runtime/src/bin/boxforge`) as a crate of its own.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

type Module = Vec<String>;
type Graph = BTreeMap<Module, BTreeSet<Module>>;

fn rust_files(dir: &Path, skip: &[&str], out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            if !skip.iter().any(|s| p.file_name().is_some_and(|n| n == *s)) {
                rust_files(&p, skip, out);
            }
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

fn module_of(root: &Path, file: &Path) -> Module {
    let rel = file.strip_prefix(root).unwrap().with_extension("");
    let mut m: Module = rel.iter().map(|c| c.to_string_lossy().into_owned()).collect();
    if matches!(m.last().map(String::as_str), Some("mod" | "lib" | "main")) {
        m.pop();
    }
    m
}

/// `code` with comments, string, byte-string, raw-string and char literals
/// blanked (lifetimes kept), so that only code is scanned.
fn strip_comments_and_literals(code: &str) -> String {
    let b: Vec<char> = code.chars().collect();
    let mut out = String::with_capacity(code.len());
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        let next = b.get(i + 1).copied();
        if c == '/' && next == Some('/') {
            while i < b.len() && b[i] != '\n' {
                i += 1;
            }
        } else if c == '/' && next == Some('*') {
            let mut depth = 0;
            while i < b.len() {
                if b[i] == '/' && b.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if b[i] == '*' && b.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
            out.push(' ');
        } else if c == 'r'
            && (next == Some('"') || (next == Some('#') && !prev_is_ident(&b, i)))
            && !prev_is_ident(&b, i)
        {
            // r"..." or r#"..."#
            let mut j = i + 1;
            let mut hashes = 0;
            while b.get(j) == Some(&'#') {
                hashes += 1;
                j += 1;
            }
            if b.get(j) != Some(&'"') {
                out.push(c);
                i += 1;
                continue;
            }
            j += 1;
            while j < b.len() {
                if b[j] == '"' && (0..hashes).all(|k| b.get(j + 1 + k) == Some(&'#')) {
                    j += 1 + hashes;
                    break;
                }
                j += 1;
            }
            out.push_str("\"\"");
            i = j;
        } else if c == '"' {
            let mut j = i + 1;
            while j < b.len() && b[j] != '"' {
                j += if b[j] == '\\' { 2 } else { 1 };
            }
            out.push_str("\"\"");
            i = j + 1;
        } else if c == '\'' {
            // A char literal ('a', '\n', '\u{..}') or a lifetime ('a).
            let close = if next == Some('\\') {
                (i + 2..b.len().min(i + 12)).find(|&j| b[j] == '\'')
            } else if b.get(i + 2) == Some(&'\'') {
                Some(i + 2)
            } else {
                None
            };
            match close {
                Some(j) => {
                    out.push_str("' '");
                    i = j + 1;
                }
                None => {
                    out.push(c);
                    i += 1;
                }
            }
        } else {
            out.push(c);
            i += 1;
        }
    }
    out
}

fn prev_is_ident(b: &[char], i: usize) -> bool {
    i > 0 && (b[i - 1].is_alphanumeric() || b[i - 1] == '_')
}

/// `code` without its `#[cfg(test)]` items, and the names of the modules it
/// declares `#[cfg(test)] mod name;` (their files are test code).
fn without_test_items(code: &str) -> (String, Vec<String>) {
    let mut out = String::new();
    let mut test_mods = Vec::new();
    let mut rest = code;
    while let Some(at) = rest.find("#[cfg(test)]") {
        out.push_str(&rest[..at]);
        let item = &rest[at + "#[cfg(test)]".len()..];
        // The item ends at its first `;` outside braces when no `{` comes
        // first (`mod x;`, `use ...;`), else at the brace that closes it.
        let mut depth = 0usize;
        let mut end = item.len();
        for (k, ch) in item.char_indices() {
            match ch {
                '{' => depth += 1,
                '}' => {
                    depth -= 1;
                    if depth == 0 {
                        end = k + 1;
                        break;
                    }
                }
                ';' if depth == 0 => {
                    end = k + 1;
                    break;
                }
                _ => {}
            }
        }
        let head = item[..end].split_whitespace().collect::<Vec<_>>().join(" ");
        if let Some(name) =
            head.strip_suffix(';').and_then(|h| h.rsplit("mod ").next()).filter(|_| head.contains("mod "))
        {
            test_mods.push(name.trim().to_string());
        }
        rest = &item[end..];
    }
    out.push_str(rest);
    (out, test_mods)
}

/// `a::{b, c::{d, e}}` -> `a::b`, `a::c::d`, `a::c::e` (whitespace removed first).
fn expand(path: &str) -> Vec<String> {
    let Some(open) = path.find('{') else { return vec![path.to_string()] };
    let mut depth = 0;
    let Some(close) = path[open..].char_indices().find(|&(_, c)| {
        depth += match c {
            '{' => 1,
            '}' => -1,
            _ => 0,
        };
        depth == 0
    }) else {
        return vec![path[..open].to_string()];
    };
    let close = open + close.0;
    let (pre, inner, post) = (&path[..open], &path[open + 1..close], &path[close + 1..]);
    let mut parts = Vec::new();
    let (mut depth, mut start) = (0, 0);
    for (i, c) in inner.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(&inner[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    parts.push(&inner[start..]);
    parts.into_iter().filter(|p| !p.is_empty()).flat_map(|p| expand(&format!("{pre}{p}{post}"))).collect()
}

/// Every path of `code` (already stripped) that starts with `crate`, `super`
/// or `self` and goes on with `::`, brace groups expanded, renames dropped.
fn rooted_paths(code: &str) -> Vec<Vec<String>> {
    let chars: Vec<char> = code.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        if !(chars[i].is_alphabetic() || chars[i] == '_') || prev_is_ident(&chars, i) || (i > 0 && chars[i - 1] == ':')
        {
            i += 1;
            continue;
        }
        let start = i;
        while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
            i += 1;
        }
        let word: String = chars[start..i].iter().collect();
        if !matches!(word.as_str(), "crate" | "super" | "self") {
            continue;
        }
        // Take the path text: identifiers, `::`, whitespace and balanced
        // `{...}` groups (use trees), up to anything else.
        let mut j = i;
        let mut text = word.clone();
        loop {
            let mut k = j;
            while k < chars.len() && chars[k].is_whitespace() {
                k += 1;
            }
            if chars.get(k) == Some(&':') && chars.get(k + 1) == Some(&':') {
                k += 2;
                while k < chars.len() && chars[k].is_whitespace() {
                    k += 1;
                }
                if chars.get(k) == Some(&'{') {
                    let mut depth = 0;
                    let from = k;
                    while k < chars.len() {
                        depth += match chars[k] {
                            '{' => 1,
                            '}' => -1,
                            _ => 0,
                        };
                        k += 1;
                        if depth == 0 {
                            break;
                        }
                    }
                    text.push_str("::");
                    text.extend(chars[from..k].iter());
                    j = k;
                    break;
                }
                let from = k;
                while k < chars.len() && (chars[k].is_alphanumeric() || chars[k] == '_' || chars[k] == '*') {
                    k += 1;
                }
                if k == from {
                    break;
                }
                text.push_str("::");
                text.extend(chars[from..k].iter());
                j = k;
            } else {
                break;
            }
        }
        i = j;
        if !text.contains("::") {
            continue;
        }
        let compact: String = text.split_whitespace().collect::<Vec<_>>().join(" ").replace(" as ", "@");
        let compact: String = compact.chars().filter(|c| !c.is_whitespace()).collect();
        for p in expand(&compact) {
            out.push(p.split("::").map(|s| s.split('@').next().unwrap().to_string()).collect());
        }
    }
    out
}

/// Module -> the modules its non-test code names by a rooted path.
fn import_graph(root: &Path, skip: &[&str]) -> Graph {
    let mut files = Vec::new();
    rust_files(root, skip, &mut files);
    let mut parsed = BTreeMap::new();
    let mut test_files = BTreeSet::new();
    for f in &files {
        let me = module_of(root, f);
        let code = strip_comments_and_literals(&std::fs::read_to_string(f).unwrap());
        let (code, test_mods) = without_test_items(&code);
        for t in test_mods {
            test_files.insert([me.clone(), vec![t]].concat());
        }
        parsed.insert(me, code);
    }
    parsed.retain(|m, _| !test_files.iter().any(|t| m.starts_with(t)));
    let modules: BTreeSet<Module> = parsed.keys().cloned().collect();
    let resolve = |path: &[String]| (0..=path.len()).rev().map(|n| path[..n].to_vec()).find(|m| modules.contains(m));
    let mut graph = Graph::new();
    for (me, code) in &parsed {
        let mut edges = BTreeSet::new();
        for mut parts in rooted_paths(code) {
            let mut base = match parts[0].as_str() {
                "crate" => Vec::new(),
                _ => me.clone(),
            };
            if parts[0] == "crate" || parts[0] == "self" {
                parts.remove(0);
            }
            while parts.first().map(String::as_str) == Some("super") {
                base.pop();
                parts.remove(0);
            }
            base.extend(parts.into_iter().filter(|p| p != "self" && p != "*"));
            if let Some(target) = resolve(&base).filter(|t| t != me) {
                edges.insert(target);
            }
        }
        graph.insert(me.clone(), edges);
    }
    graph
}

/// The graph of top-level modules (stages): each file counts as the first
/// component of its module path (`lib` for the crate root).
fn stage_graph(files: &Graph) -> Graph {
    let stage = |m: &Module| vec![m.first().cloned().unwrap_or_else(|| "lib".into())];
    let mut graph = Graph::new();
    for (m, edges) in files {
        let from = stage(m);
        let to: BTreeSet<Module> = edges.iter().map(stage).filter(|s| *s != from && s[0] != "lib").collect();
        graph.entry(from).or_default().extend(to);
    }
    graph
}

/// One cycle of the graph, if any (depth-first search for a back edge).
fn find_cycle(graph: &Graph) -> Option<Vec<Module>> {
    fn visit(
        m: &Module,
        graph: &Graph,
        state: &mut BTreeMap<Module, bool>,
        stack: &mut Vec<Module>,
    ) -> Option<Vec<Module>> {
        state.insert(m.clone(), true);
        stack.push(m.clone());
        for n in graph.get(m).into_iter().flatten() {
            match state.get(n) {
                Some(true) => {
                    let from = stack.iter().position(|x| x == n).unwrap();
                    return Some(stack[from..].to_vec());
                }
                Some(false) => {}
                None => {
                    if let Some(c) = visit(n, graph, state, stack) {
                        return Some(c);
                    }
                }
            }
        }
        stack.pop();
        state.insert(m.clone(), false);
        None
    }
    let mut state = BTreeMap::new();
    for m in graph.keys() {
        if !state.contains_key(m) {
            if let Some(c) = visit(m, graph, &mut state, &mut Vec::new()) {
                return Some(c);
            }
        }
    }
    None
}

fn show(cycle: &[Module]) -> String {
    cycle.iter().map(|m| if m.is_empty() { "lib".to_string() } else { m.join("/") }).collect::<Vec<_>>().join(" -> ")
}

/// Fails with the cycle (file level first, then stage level) found under `root`.
fn assert_acyclic(root: &Path, skip: &[&str], least: usize) {
    let files = import_graph(root, skip);
    let name = root.display();
    assert!(files.len() > least, "read the modules of {name} ({} found)", files.len());
    if let Some(cycle) = find_cycle(&files) {
        panic!("import cycle between files in {name}: {} (move the shared items into a module both use)", show(&cycle));
    }
    if let Some(cycle) = find_cycle(&stage_graph(&files)) {
        panic!(
            "import cycle between top-level modules in {name}: {} (a stage may only use the stages below it)",
            show(&cycle)
        );
    }
}

/// A planted tree under the temp dir, removed when dropped.
struct Planted(PathBuf);

impl Planted {
    fn new(tag: &str, files: &[(&str, &str)]) -> Planted {
        let dir = std::env::temp_dir().join(format!("boxforge-cycles-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        for (path, text) in files {
            let p = dir.join(path);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, text).unwrap();
        }
        Planted(dir)
    }
}

impl Drop for Planted {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

#[test]
fn the_checker_finds_a_planted_file_cycle() {
    let tree = Planted::new(
        "files",
        &[
            ("lib.rs", "pub mod a;\n"),
            ("a/mod.rs", "pub mod b;\npub mod c;\n"),
            ("a/b.rs", "use super::{c::{X, Y as Z}};\npub struct W;\n"),
            ("a/c.rs", "pub fn f() -> crate::a::b::W { todo!() }\n#[cfg(test)]\nmod t { use crate::a::b; }\n"),
        ],
    );
    let cycle = find_cycle(&import_graph(&tree.0, &[])).map(|c| show(&c));
    assert_eq!(cycle.as_deref(), Some("a/b -> a/c"), "a path in a signature is an edge");
    std::fs::write(tree.0.join("a/c.rs"), "// crate::a::b::W\npub struct X; const S: &str = \"crate::a::b\";\n#[cfg(test)]\nmod t { fn g() -> crate::a::b::W { todo!() } }\n").unwrap();
    assert_eq!(find_cycle(&import_graph(&tree.0, &[])), None, "comments, strings and test code are not edges");
}

/// The generator's loop of 2026-12 (derive -> error -> back -> emit ->
/// derive), made only of paths outside `use` lines (an attribute's `#[from]`
/// and a call), is a stage cycle though no two files import each other.
#[test]
fn the_checker_finds_the_generators_stage_loop() {
    let tree = Planted::new(
        "stages",
        &[
            ("lib.rs", "pub mod back;\npub mod derive;\npub mod emit;\npub mod error;\n"),
            ("error.rs", "pub enum Error {\n    Back(#[from] crate::back::BackError),\n}\n"),
            ("back/mod.rs", "pub mod modules;\npub struct BackError;\n"),
            ("back/modules.rs", "pub fn m() { let _ = crate::emit::binding_purpose(0); }\n"),
            ("emit/mod.rs", "pub fn binding_purpose(_: u32) {}\npub fn e() { crate::derive::facts(); }\n"),
            (
                "derive/mod.rs",
                "#[cfg(test)]\nmod tests;\npub fn facts() -> Result<(), crate::error::Error> { Ok(()) }\n",
            ),
            ("derive/tests.rs", "use crate::back::modules::m;\n"),
        ],
    );
    let files = import_graph(&tree.0, &[]);
    assert_eq!(find_cycle(&files), None, "no two files import each other");
    assert!(!files.contains_key(&vec!["derive".to_string(), "tests".to_string()]), "a #[cfg(test)] file is not read");
    let cycle = find_cycle(&stage_graph(&files)).map(|c| show(&c));
    assert_eq!(cycle.as_deref(), Some("back -> emit -> derive -> error"));
}

#[test]
fn generator_modules_have_no_import_cycle() {
    assert_acyclic(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../generator/src"), &[], 40);
}

#[test]
fn runtime_modules_have_no_import_cycle() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../runtime/src");
    assert_acyclic(&src, &["bin"], 40);
    assert_acyclic(&src.join("bin/boxforge"), &[], 8);
}
