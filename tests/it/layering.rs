//! The layering rules (docs/src/development/architecture.md §2): pure layers do no IO, printing, threading, Parquet
//! or global randomness; only store/ touches polars, only report/ plotters and minijinja, only run/
//! rayon; and no import circle joins two top-level modules.

use crate::util::repo;
use std::path::Path;

const PURE: &[&str] =
    &["geom", "world", "features", "slam", "scanmatch", "metrics", "algo", "trace.rs"];
const FORBIDDEN_IN_PURE: &[&str] = &[
    "std::fs",
    "std::io",
    "std::net",
    "std::env",
    "std::thread",
    "std::process",
    "println!",
    "eprintln!",
    "print!(",
    "dbg!",
    "rayon",
    "polars",
    "plotters",
    "minijinja",
    "thread_rng",
    "rand::rng(",
    "from_entropy",
    "OsRng",
    "Instant::now",
    "SystemTime",
];

fn sources(dir: &Path) -> Vec<(String, String)> {
    let mut out = Vec::new();
    if dir.is_file() {
        out.push((dir.display().to_string(), std::fs::read_to_string(dir).unwrap()));
        return out;
    }
    if let Ok(entries) = std::fs::read_dir(dir) {
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                out.extend(sources(&p));
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push((p.display().to_string(), std::fs::read_to_string(&p).unwrap()));
            }
        }
    }
    out
}

/// Source without comments (doc comments may mention anything).
fn code(text: &str) -> String {
    text.lines().map(|l| l.split("//").next().unwrap_or("")).collect::<Vec<_>>().join("\n")
}

/// Modules of `std` a pure layer must not import, also when grouped: `use std::{fs, io}`.
const FORBIDDEN_STD_MODULES: &[&str] = &["fs", "io", "net", "env", "thread", "process", "time"];

#[test]
fn pure_layers_stay_pure() {
    let src = repo().join("src");
    for layer in PURE {
        for (path, text) in sources(&src.join(layer)) {
            let code = code(&text);
            for bad in FORBIDDEN_IN_PURE.iter().chain(&["rand::random", "File::", "OpenOptions"]) {
                assert!(
                    !code.contains(bad),
                    "{path} uses `{bad}`: pure layers do no IO, threading or global randomness"
                );
            }
            // grouped imports: `use std::{fs, io::Write}`
            for group in code.split("std::{").skip(1) {
                let items = group.split('}').next().unwrap_or("");
                for item in
                    items.split(',').map(|i| i.trim().split("::").next().unwrap_or("").trim())
                {
                    assert!(
                        !FORBIDDEN_STD_MODULES.contains(&item),
                        "{path} imports std::{item}: pure layers do no IO, threading or timing"
                    );
                }
            }
        }
    }
}

#[test]
fn each_dependency_stays_in_its_layer() {
    let src = repo().join("src");
    let rules = [
        ("polars", "store"),
        ("polars_parquet", "store"),
        ("plotters", "report"),
        ("minijinja", "report"),
        ("rayon", "run"),
        ("indicatif", "run"),
    ];
    for (path, text) in sources(&src) {
        // The one use of rayon outside run/: the store asserts that its Parquet IO is not on a
        // rayon worker (polars inside a worker nests jobs until the stack overflows).
        let code = code(&text).replace("rayon::current_thread_index()", "");
        for (dep, home) in rules {
            let inside = Path::new(&path).starts_with(src.join(home));
            assert!(
                inside || !code.contains(&format!("{dep}::")),
                "{path} uses {dep}, which belongs in src/{home}/ only"
            );
        }
    }
}

#[test]
fn every_source_file_says_what_it_does() {
    for (path, text) in sources(&repo().join("src")) {
        if path.ends_with("main.rs") {
            continue;
        }
        assert!(
            text.trim_start().starts_with("//!"),
            "{path} must start with a //! comment saying its role"
        );
    }
}

/// Verdicts live below the pages that show them: `stats/` and `judge/` import neither `report/`
/// nor `diff/`, `diff/` does not reach into `report/`, and `spec/` (the judge's input) imports none
/// of them.
#[test]
fn verdict_rules_sit_below_report_and_diff() {
    let src = repo().join("src");
    for (layer, banned) in [
        ("stats", &["crate::report", "crate::diff", "crate::judge"][..]),
        ("judge", &["crate::report", "crate::diff"][..]),
        ("diff", &["crate::report"][..]),
        // the specs are the judge's input, never the other way round
        ("spec", &["crate::judge", "crate::report", "crate::diff"][..]),
    ] {
        for (path, text) in sources(&src.join(layer)) {
            let code = code(&text);
            for b in banned {
                assert!(!code.contains(b), "{path} uses `{b}`: {layer}/ must not depend on it");
            }
        }
    }
}

/// The world is simulated without the filters: `world/` and `dataset/` (which build worlds)
/// import nothing from `slam/` (what kind of world a map makes, `WorldKind`, is the world's).
#[test]
fn worlds_do_not_depend_on_the_filters() {
    let src = repo().join("src");
    for layer in ["world", "dataset"] {
        for (path, text) in sources(&src.join(layer)) {
            assert!(
                !code(&text).contains("crate::slam"),
                "{path} uses crate::slam: the world must not depend on the filters"
            );
        }
    }
}

/// Production code only: each `#[cfg(test)]` item (a `mod tests { … }` block, closed by a `}` at
/// column 0, or one line) is left out.
fn production(text: &str) -> String {
    let mut out = Vec::new();
    let mut lines = text.lines().peekable();
    while let Some(line) = lines.next() {
        if line.trim() != "#[cfg(test)]" {
            out.push(line);
            continue;
        }
        let Some(item) = lines.next() else { break };
        if item.trim_end().ends_with(';') {
            continue;
        }
        for l in lines.by_ref() {
            if l == "}" {
                break;
            }
        }
    }
    code(&out.join("\n"))
}

/// The top-level modules a file's code names through `crate::…`, grouped imports included.
fn imports(code: &str) -> std::collections::BTreeSet<String> {
    let ident = |s: &str| {
        s.chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect::<String>()
    };
    let mut out = std::collections::BTreeSet::new();
    for part in code.split("crate::").skip(1) {
        if let Some(group) = part.strip_prefix('{') {
            // `crate::{a::X, b}`: the first name of each item at depth 0
            let mut depth = 0;
            let mut item_start = true;
            for (i, c) in group.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => item_start = true,
                    c if item_start && !c.is_whitespace() => {
                        out.insert(ident(&group[i..]));
                        item_start = false;
                    }
                    _ => {}
                }
            }
        } else {
            out.insert(ident(part));
        }
    }
    out.retain(|m| !m.is_empty());
    out
}

/// The modules on an import circle, if any: a strongly connected component of more than one
/// module in the graph of top-level modules (Tarjan).
fn circles(
    graph: &std::collections::BTreeMap<String, std::collections::BTreeSet<String>>,
) -> Vec<Vec<String>> {
    use std::collections::BTreeMap;
    struct T<'g> {
        g: &'g BTreeMap<String, std::collections::BTreeSet<String>>,
        index: BTreeMap<&'g str, usize>,
        low: BTreeMap<&'g str, usize>,
        stack: Vec<&'g str>,
        on: std::collections::BTreeSet<&'g str>,
        out: Vec<Vec<String>>,
    }
    fn visit<'g>(t: &mut T<'g>, v: &'g str) {
        let n = t.index.len();
        t.index.insert(v, n);
        t.low.insert(v, n);
        t.stack.push(v);
        t.on.insert(v);
        for w in t.g.get(v).into_iter().flatten() {
            let w = w.as_str();
            if !t.g.contains_key(w) {
                continue;
            }
            if !t.index.contains_key(w) {
                visit(t, w);
                let lw = t.low[w];
                let lv = t.low.get_mut(v).unwrap();
                *lv = (*lv).min(lw);
            } else if t.on.contains(w) {
                let iw = t.index[w];
                let lv = t.low.get_mut(v).unwrap();
                *lv = (*lv).min(iw);
            }
        }
        if t.low[v] == t.index[v] {
            let mut scc = Vec::new();
            while let Some(w) = t.stack.pop() {
                t.on.remove(w);
                scc.push(w.to_string());
                if w == v {
                    break;
                }
            }
            if scc.len() > 1 {
                scc.sort();
                t.out.push(scc);
            }
        }
    }
    let mut t = T {
        g: graph,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: Default::default(),
        out: Vec::new(),
    };
    for v in graph.keys() {
        if !t.index.contains_key(v.as_str()) {
            visit(&mut t, v);
        }
    }
    t.out
}

/// The top-level modules form floors (docs/src/development/architecture.md §2): no module reaches one that
/// reaches back, however far round.
#[test]
fn no_import_circle_joins_top_level_modules() {
    let src = repo().join("src");
    let mut graph: std::collections::BTreeMap<String, std::collections::BTreeSet<String>> =
        Default::default();
    for entry in std::fs::read_dir(&src).unwrap().flatten() {
        let p = entry.path();
        let name = p.file_stem().unwrap().to_string_lossy().to_string();
        if name == "lib" || name == "main" {
            continue;
        }
        let mut used = std::collections::BTreeSet::new();
        for (_, text) in sources(&p) {
            used.extend(imports(&production(&text)));
        }
        used.remove(&name);
        graph.insert(name, used);
    }
    assert!(graph.len() > 10 && graph["run"].contains("algo"), "the graph was read: {graph:?}");
    let found = circles(&graph);
    assert!(found.is_empty(), "import circles between top-level modules: {found:?}");
}

#[test]
fn the_circle_finder_finds_circles() {
    let g = |edges: &[(&str, &str)]| {
        let mut g: std::collections::BTreeMap<String, std::collections::BTreeSet<String>> =
            Default::default();
        for (a, b) in edges {
            g.entry(a.to_string()).or_default().insert(b.to_string());
            g.entry(b.to_string()).or_default();
        }
        g
    };
    assert_eq!(circles(&g(&[("a", "b"), ("b", "c"), ("c", "a"), ("c", "d")])), [["a", "b", "c"]]);
    assert!(circles(&g(&[("a", "b"), ("b", "c"), ("a", "c")])).is_empty());
    assert_eq!(
        imports("use crate::{algo::X, world::{Y, Z}};\nlet a = crate::plan::cost::work();"),
        ["algo", "plan", "world"].map(String::from).into()
    );
}
