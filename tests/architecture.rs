//! The layering rule of `src/` (docs/architecture.md): the child modules of a module (each with everything
//! below it) import each other without a cycle. A reference from `a::b::c` to `a::d::e` is an edge `b → d`
//! among the children of `a`; references are resolved to the module that defines the item, through
//! re-exports and imports. What a module defines itself is the vocabulary its children share: a child may
//! use its parent's items while the parent uses the child (`super::Modal` in a child, `child::build` in the
//! parent). Code under `#[cfg(test)]` may reach anywhere and is left out.
//!
//! The timeline is held to more: its steps form a pipeline in which each imports only the ones before it,
//! and its `mod.rs` defines nothing (`the_timeline_is_a_pipeline`).

mod module_graph;

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use module_graph::{Crate, ModPath, Reference};

/// What a module defines itself, as one of its parts.
const OWN: &str = "(own items)";

/// Edges among the children of each module, with the references behind each edge.
type Layers = BTreeMap<ModPath, BTreeMap<(String, String), Vec<Reference>>>;

/// The part of module `m` that lies under `parent`: the child it is in, or [`OWN`].
fn part(parent: &[String], m: &ModPath) -> String {
    m.get(parent.len())
        .cloned()
        .unwrap_or_else(|| OWN.to_string())
}

fn layers(refs: Vec<Reference>) -> Layers {
    let mut out: Layers = BTreeMap::new();
    for r in refs {
        let common = r.from.iter().zip(&r.to).take_while(|(a, b)| a == b).count();
        let parent = &r.from[..common];
        let (a, b) = (part(parent, &r.from), part(parent, &r.to));
        if a == OWN || b == OWN {
            continue;
        }
        out.entry(parent.to_vec())
            .or_default()
            .entry((a, b))
            .or_default()
            .push(r);
    }
    out
}

/// The nodes of a graph that lie on a cycle, grouped by the cycle they lie on (strongly connected).
fn cycles(edges: &BTreeMap<(String, String), Vec<Reference>>) -> Vec<BTreeSet<String>> {
    let nodes: BTreeSet<&String> = edges.keys().flat_map(|(a, b)| [a, b]).collect();
    let reach = |from: &String| {
        let mut seen = BTreeSet::new();
        let mut stack = vec![from];
        while let Some(n) = stack.pop() {
            for (a, b) in edges.keys() {
                if a == n && seen.insert(b) {
                    stack.push(b);
                }
            }
        }
        seen
    };
    let reached: BTreeMap<&String, BTreeSet<&String>> =
        nodes.iter().map(|&n| (n, reach(n))).collect();
    let mut out: Vec<BTreeSet<String>> = Vec::new();
    for &n in &nodes {
        if !reached[n].contains(n) || out.iter().any(|c| c.contains(n)) {
            continue;
        }
        let component = nodes
            .iter()
            .filter(|&&m| reached[n].contains(m) && reached[m].contains(n))
            .map(|m| m.to_string())
            .collect();
        out.push(component);
    }
    out
}

fn shown(r: &Reference) -> String {
    format!("{}:{} {}", r.file.display(), r.line, r.written)
}

/// Every cycle with the references that close it, one line per edge (at most three references each).
fn describe(layers: &Layers) -> Vec<String> {
    let mut out = Vec::new();
    for (module, edges) in layers {
        for cycle in cycles(edges) {
            let name = if module.is_empty() {
                "crate".to_string()
            } else {
                module.join("::")
            };
            let members: Vec<&str> = cycle.iter().map(String::as_str).collect();
            out.push(format!("cycle in {name}: {}", members.join(", ")));
            for ((a, b), refs) in edges {
                if cycle.contains(a) && cycle.contains(b) {
                    let some: Vec<String> = refs.iter().take(3).map(shown).collect();
                    out.push(format!("  {a} -> {b}: {}", some.join("; ")));
                }
            }
        }
    }
    out
}

fn src() -> Crate {
    Crate::read(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"))
}

#[test]
fn no_module_imports_its_siblings_in_a_cycle() {
    let found = describe(&layers(src().references()));
    assert!(found.is_empty(), "{}", found.join("\n"));
}

/// The timeline's steps, each allowed to import only the ones before it; its `mod.rs` comes last (it
/// declares and re-exports).
const TIMELINE: [&str; 9] = [
    "modal", "record", "timing", "read", "moves", "fold", "unit", "build", OWN,
];

#[test]
fn the_timeline_is_a_pipeline() {
    let timeline: ModPath = vec!["omm".into(), "timeline".into()];
    let krate = src();
    let steps: BTreeSet<&str> = krate
        .modules()
        .iter()
        .filter(|m| m.len() == 3 && m.starts_with(&timeline))
        .map(|m| m[2].as_str())
        .collect();
    let listed: BTreeSet<&str> = TIMELINE[..TIMELINE.len() - 1].iter().copied().collect();
    assert_eq!(
        steps, listed,
        "each step of the timeline has its place in TIMELINE"
    );
    let rank = |p: &str| TIMELINE.iter().position(|s| *s == p).expect("listed");
    let backwards: Vec<String> = krate
        .references()
        .into_iter()
        .filter(|r| r.from.starts_with(&timeline) && r.to.starts_with(&timeline))
        .filter_map(|r| {
            let (a, b) = (part(&timeline, &r.from), part(&timeline, &r.to));
            (a != b && rank(&a) <= rank(&b)).then(|| format!("{a} -> {b}: {}", shown(&r)))
        })
        .collect();
    assert!(backwards.is_empty(), "{}", backwards.join("\n"));
}

/// The reader sees what the rule is about: the modules, the references across them, resolved through
/// re-exports and private imports, and a cycle where there is one.
#[test]
fn the_reader_resolves_references_and_finds_cycles() {
    let dir = tempfile::tempdir().unwrap();
    let write = |path: &str, text: &str| {
        let path = dir.path().join(path);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, text).unwrap();
    };
    let found = || describe(&layers(Crate::read(dir.path()).references()));
    write("lib.rs", "pub mod a;\npub mod d;\npub use a::Thing;\n");
    write(
        "a/mod.rs",
        "mod b;\nmod c;\nuse crate::d::Helper as H;\npub use b::Thing;\npub struct Own;\n\
         pub mod inline { pub const X: u8 = 1; }\n",
    );
    write(
        "a/b.rs",
        "use super::c::{self, Other};\npub struct Thing;\nfn f() -> u8 { c::g() + super::inline::X }\n",
    );
    write(
        "a/c.rs",
        "pub struct Other;\npub fn g() -> u8 { let _ = super::H::new(); 0 }\n// super::b::Thing\n",
    );
    write(
        "d.rs",
        "pub struct Helper;\nfn f() { let _ = crate::Thing; let _ = \"crate::a::Own\"; }\n",
    );
    let krate = Crate::read(dir.path());
    let inline: ModPath = vec!["a".into(), "inline".into()];
    assert!(krate.modules().contains(&inline));
    let mut edges: Vec<(String, String)> = krate
        .references()
        .iter()
        .map(|r| (r.from.join("::"), r.to.join("::")))
        .collect();
    edges.sort();
    edges.dedup();
    let expected = [
        ("", "a::b"),
        ("a", "a::b"),
        ("a", "d"),
        ("a::b", "a::c"),
        ("a::b", "a::inline"),
        ("a::c", "d"),
        ("d", "a::b"),
    ];
    let expected: Vec<(String, String)> = expected
        .iter()
        .map(|(a, b)| (a.to_string(), b.to_string()))
        .collect();
    assert_eq!(edges, expected);
    let cycle = found();
    assert_eq!(cycle.len(), 3, "{cycle:#?}");
    assert_eq!(cycle[0], "cycle in crate: a, d");
    // A child may use what its parent defines while the parent uses the child, and a test module may use
    // anything.
    write(
        "a/c.rs",
        "pub struct Other;\npub fn g() -> u8 { let _ = super::Own; 0 }\n",
    );
    write(
        "a/mod.rs",
        "mod b;\nmod c;\npub use b::Thing;\npub struct Own;\nfn f() { c::g(); }\npub mod inline {}\n\
         #[cfg(test)]\nmod tests { fn t() { super::b::Thing; } }\n",
    );
    write("d.rs", "pub struct Helper;\n#[cfg(test)]\nmod tests;\n");
    write("d/tests.rs", "fn t() { crate::a::Own; }\n");
    assert_eq!(found(), Vec::<String>::new());
    // Two children may not use each other.
    write("a/c.rs", "pub fn g() -> u8 { super::b::Thing; 0 }\n");
    let cycle = found();
    assert_eq!(
        cycle.first().map(String::as_str),
        Some("cycle in a: b, c"),
        "{cycle:#?}"
    );
}
