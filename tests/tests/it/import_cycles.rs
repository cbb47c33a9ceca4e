//! No import cycles between the generator's modules (file level): a cycle
//! means two files can only be understood (and changed) together, which the
//! one-stage-per-folder layout of `generator/src` is meant to prevent.
//!
//! The graph has one node per source file (`foo/mod.rs` is the module `foo`)
//! and an edge for every `use crate::..` / `use super::..` path, resolved to
//! the longest prefix that is a module file. `#[cfg(test)]` code is left out:
//! unit tests may reach back into the module tree. `generator/src` is
//! checked, and `runtime/src` with the CLI (`runtime/src/bin/boxforge`) as a crate of its own.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

type Module = Vec<String>;

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
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

/// `a::{b, c::{d, e}}` -> `a::b`, `a::c::d`, `a::c::e` (whitespace removed first).
fn expand(path: &str) -> Vec<String> {
    let Some(open) = path.find('{') else { return vec![path.to_string()] };
    let mut depth = 0;
    let close = open
        + path[open..]
            .char_indices()
            .find(|&(_, c)| {
                depth += match c {
                    '{' => 1,
                    '}' => -1,
                    _ => 0,
                };
                depth == 0
            })
            .expect("balanced braces")
            .0;
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

/// The paths of the `use` items of `code` (those starting a line), whitespace
/// removed and renames written `x@y`.
fn use_statements(code: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut current: Option<String> = None;
    for line in code.lines() {
        let t = line.trim_start();
        if current.is_none() {
            let vis = ["use ", "pub use ", "pub(crate) use ", "pub(super) use "];
            current = vis.iter().find_map(|v| t.strip_prefix(v)).map(str::to_string);
        } else if let Some(c) = current.as_mut() {
            c.push_str(t);
        }
        if let Some(c) = current.take_if(|c| c.contains(';')) {
            let path = c.split(';').next().unwrap_or_default();
            // `x as y` -> `x@y` before the spaces go, so that renames stay separable.
            let path = path.split_whitespace().collect::<Vec<_>>().join(" ").replace(" as ", "@");
            out.push(path.chars().filter(|c| !c.is_whitespace()).collect());
        }
    }
    out
}

/// Module -> the modules its non-test `use crate::` / `use super::` lines name.
fn import_graph(root: &Path) -> BTreeMap<Module, BTreeSet<Module>> {
    let mut files = Vec::new();
    rust_files(root, &mut files);
    let modules: BTreeSet<Module> = files.iter().map(|f| module_of(root, f)).collect();
    let resolve = |path: &[String]| (0..=path.len()).rev().map(|n| path[..n].to_vec()).find(|m| modules.contains(m));
    let mut graph = BTreeMap::new();
    for f in &files {
        let me = module_of(root, f);
        let text = std::fs::read_to_string(f).unwrap();
        let code = text.split("#[cfg(test)]").next().unwrap_or_default();
        let mut edges = BTreeSet::new();
        for rest in use_statements(code) {
            for path in expand(&rest) {
                let mut parts: Vec<String> =
                    path.split("::").map(|p| p.split('@').next().unwrap().to_string()).collect();
                let mut base = match parts.first().map(String::as_str) {
                    Some("crate") => Vec::new(),
                    Some("super") => me.clone(),
                    _ => continue,
                };
                if parts[0] == "crate" {
                    parts.remove(0);
                }
                while parts.first().map(String::as_str) == Some("super") {
                    base.pop();
                    parts.remove(0);
                }
                base.extend(parts.into_iter().filter(|p| p != "self" && p != "*"));
                if let Some(target) = resolve(&base).filter(|t| *t != me) {
                    edges.insert(target);
                }
            }
        }
        graph.insert(me, edges);
    }
    graph
}

/// One cycle of the graph, if any (depth-first search for a back edge).
fn find_cycle(graph: &BTreeMap<Module, BTreeSet<Module>>) -> Option<Vec<Module>> {
    fn visit(
        m: &Module,
        graph: &BTreeMap<Module, BTreeSet<Module>>,
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

#[test]
fn the_checker_finds_a_planted_cycle() {
    let dir = std::env::temp_dir().join(format!("boxforge-cycles-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("a")).unwrap();
    std::fs::write(dir.join("lib.rs"), "pub mod a;\n").unwrap();
    std::fs::write(dir.join("a/mod.rs"), "pub mod b;\npub mod c;\n").unwrap();
    std::fs::write(dir.join("a/b.rs"), "use super::{c::{X, Y as Z}};\npub struct W;\n").unwrap();
    std::fs::write(dir.join("a/c.rs"), "use crate::a::b::W;\n#[cfg(test)]\nmod t { use crate::a::b; }\n").unwrap();
    let graph = import_graph(&dir);
    let cycle = find_cycle(&graph).map(|c| show(&c));
    std::fs::write(dir.join("a/c.rs"), "pub struct X;\n#[cfg(test)]\nmod t { use crate::a::b::W; }\n").unwrap();
    let acyclic = find_cycle(&import_graph(&dir));
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(cycle.as_deref(), Some("a/b -> a/c"));
    assert_eq!(acyclic, None, "test-only imports are not edges");
}

#[test]
fn generator_modules_have_no_import_cycle() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../generator/src");
    let graph = import_graph(&root);
    assert!(graph.len() > 40, "read the generator's modules ({} found)", graph.len());
    if let Some(cycle) = find_cycle(&graph) {
        panic!("import cycle in generator/src: {} (move the shared items into a module both use)", show(&cycle));
    }
}

#[test]
fn runtime_modules_have_no_import_cycle() {
    for (dir, least) in [("../runtime/src", 40), ("../runtime/src/bin/boxforge", 8)] {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join(dir);
        let graph = import_graph(&root);
        assert!(graph.len() > least, "read the modules of {dir} ({} found)", graph.len());
        if let Some(cycle) = find_cycle(&graph) {
            panic!("import cycle in {dir}: {} (move the shared items into a module both use)", show(&cycle));
        }
    }
}
