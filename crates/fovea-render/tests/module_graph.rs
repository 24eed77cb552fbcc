//! No module cycle in any crate of the workspace: each crate's top-level modules, with an edge
//! `a → b` wherever a file of module `a` names `crate::b`, form a directed acyclic graph, so
//! the frame's data flows down the pipeline (eye → plan → trace → shade → sample-space post →
//! reconstruct → screen post → output) without climbing back.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Every `.rs` file under `dir`.
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

/// The top-level module a file of `src` belongs to (`None` for the crate root and `main.rs`).
fn module_of(src: &Path, file: &Path) -> Option<String> {
    let rel = file.strip_prefix(src).unwrap();
    let first = rel.components().next()?.as_os_str().to_str()?.to_string();
    match first.as_str() {
        "lib.rs" | "main.rs" => None,
        f => Some(f.trim_end_matches(".rs").to_string()),
    }
}

/// `crate::name` references in `text`, outside `//` comments.
fn crate_refs(text: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for line in text.lines() {
        let code = line.split("//").next().unwrap_or("");
        let mut rest = code;
        while let Some(i) = rest.find("crate::") {
            let after = &rest[i + "crate::".len()..];
            let name: String = after
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            if !name.is_empty() {
                out.insert(name);
            }
            rest = after;
        }
    }
    out
}

/// A cycle in `graph`, if there is one.
fn find_cycle(graph: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        n: &str,
        graph: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        stack: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(n.to_string(), 1);
        stack.push(n.to_string());
        for m in graph.get(n).into_iter().flatten() {
            match state.get(m).copied().unwrap_or(0) {
                1 => {
                    let start = stack.iter().position(|s| s == m).unwrap();
                    let mut c = stack[start..].to_vec();
                    c.push(m.clone());
                    return Some(c);
                }
                0 => {
                    if let Some(c) = visit(m, graph, state, stack) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        stack.pop();
        state.insert(n.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for n in graph.keys() {
        if state.get(n).copied().unwrap_or(0) == 0 {
            let mut stack = Vec::new();
            if let Some(c) = visit(n, graph, &mut state, &mut stack) {
                return Some(c);
            }
        }
    }
    None
}

fn module_graph(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in files {
        let Some(m) = module_of(src, &f) else {
            continue;
        };
        let text = std::fs::read_to_string(&f).unwrap();
        let entry = graph.entry(m.clone()).or_default();
        for r in crate_refs(&text) {
            let is_module = src.join(format!("{r}.rs")).exists() || src.join(&r).is_dir();
            if r != m && is_module {
                entry.insert(r);
            }
        }
    }
    graph
}

#[test]
fn no_crate_has_a_module_cycle() {
    let crates = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut checked = 0;
    for name in [
        "fovea-core",
        "fovea-post",
        "fovea-render",
        "fovea-eval",
        "fovea-cli",
        "fovea-gpu",
    ] {
        let src = crates.join(name).join("src");
        let graph = module_graph(&src);
        assert!(!graph.is_empty(), "{name}: no modules found");
        if let Some(c) = find_cycle(&graph) {
            panic!("{name}: module cycle {}", c.join(" → "));
        }
        checked += 1;
    }
    assert_eq!(checked, 6);
}

#[test]
fn the_checker_finds_a_cycle() {
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    g.entry("pipeline".into())
        .or_default()
        .insert("temporal".into());
    g.entry("temporal".into())
        .or_default()
        .insert("plan".into());
    g.entry("plan".into())
        .or_default()
        .insert("settings".into());
    assert!(find_cycle(&g).is_none());
    g.entry("plan".into())
        .or_default()
        .insert("pipeline".into());
    let c = find_cycle(&g).unwrap();
    assert_eq!(c.first(), c.last());
    assert!(c.len() == 4, "{c:?}");
    assert_eq!(
        crate_refs("use crate::a::B; // crate::c\nlet x = crate::d(1);"),
        ["a", "d"].iter().map(|s| s.to_string()).collect()
    );
}
