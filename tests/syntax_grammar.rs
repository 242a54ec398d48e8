//! Keeps grammar/sinumerik.ebnf honest: its node rules are exactly the parser's node kinds, and every node
//! kind is produced by at least one fixture.

mod syntax_support;

use std::collections::BTreeSet;

use driftloop::{NodeKind, parse};
use syntax_support::all_fixtures;

fn grammar_rules() -> BTreeSet<String> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("grammar/sinumerik.ebnf");
    let text = std::fs::read_to_string(path).expect("grammar/sinumerik.ebnf");
    text.lines()
        .filter_map(|line| {
            let (name, _) = line.split_once('=')?;
            let name = name.trim();
            let is_rule = !line.starts_with(' ')
                && name.chars().next().is_some_and(|c| c.is_ascii_uppercase())
                && name.chars().all(|c| c.is_ascii_alphanumeric());
            is_rule.then(|| name.to_string())
        })
        .collect()
}

#[test]
fn grammar_node_rules_are_the_parser_node_kinds() {
    let rules = grammar_rules();
    let kinds: BTreeSet<String> = NodeKind::ALL.iter().map(|k| k.name().to_string()).collect();
    let missing: Vec<_> = kinds.difference(&rules).collect();
    let extra: Vec<_> = rules.difference(&kinds).collect();
    assert!(
        missing.is_empty() && extra.is_empty(),
        "not in grammar: {missing:?}; not in parser: {extra:?}"
    );
}

#[test]
fn every_node_kind_is_exercised_by_a_fixture() {
    let mut seen = BTreeSet::new();
    for (_, src) in all_fixtures() {
        for block in parse(&src).blocks() {
            block.root.walk(&mut |n| {
                seen.insert(n.kind);
            });
        }
    }
    let unused: Vec<&str> = NodeKind::ALL
        .iter()
        .filter(|k| !seen.contains(k))
        .map(|k| k.name())
        .collect();
    assert!(
        unused.is_empty(),
        "node kinds no fixture produces: {unused:?}"
    );
}
