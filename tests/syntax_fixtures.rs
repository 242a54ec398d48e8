//! Losslessness over every hand-written fixture: bytes out == bytes in, and the leaves of each block tree
//! add up to exactly that block's bytes.

mod syntax_support;

use driftloop::{Editor, parse};
use syntax_support::all_fixtures;

#[test]
fn every_fixture_round_trips_byte_exact() {
    let fixtures = all_fixtures();
    assert!(
        fixtures.len() >= 20,
        "fixtures/nc holds the language fixtures"
    );
    for (name, src) in fixtures {
        let program = parse(&src);
        assert_eq!(program.to_bytes(), src, "{name}: to_bytes");
        let mut written = Vec::new();
        program.write_to(&mut written).unwrap();
        assert_eq!(written, src, "{name}: write_to");
        assert_eq!(
            Editor::new(&program).to_bytes(),
            src,
            "{name}: editor without edits"
        );
    }
}

#[test]
fn block_leaves_add_up_to_the_source() {
    for (name, src) in all_fixtures() {
        let program = parse(&src);
        let mut rebuilt = Vec::new();
        for block in program.blocks() {
            assert_eq!(
                block.span(),
                program.block_span(block.index),
                "{name}: block {} span",
                block.index
            );
            let mut end = block.span().start;
            for leaf in block.root.leaves() {
                assert_eq!(
                    leaf.span.start, end,
                    "{name}: block {} leaves are contiguous",
                    block.index
                );
                end = leaf.span.end;
                rebuilt.extend_from_slice(leaf.span.slice(&src));
            }
            assert_eq!(
                end,
                block.span().end,
                "{name}: block {} leaves reach its end",
                block.index
            );
        }
        assert_eq!(rebuilt, src, "{name}: leaves of all blocks");
    }
}

#[test]
fn parse_never_panics_on_odd_bytes() {
    let odd: [&[u8]; 9] = [
        b"",
        b"\r",
        b"\n\n\r\r\n",
        b"\xef\xbb\xbf",
        b"\xef\xbb",
        b"IF ((((((",
        b"X=\"unterminated",
        b"\x00\x01\x02 G1 \xff",
        b"N N: :: /// $ $[ R[ R[1 'H 'Bx' GOTOF \"",
    ];
    let deep = [
        [&b"X="[..], &b"(".repeat(100_000)].concat(),
        [&b"R1="[..], &b"-".repeat(100_000), b"1"].concat(),
        [&b"IF "[..], &b"NOT ".repeat(50_000), b"A"].concat(),
        [&b"R1=SIN("[..], &b"COS(".repeat(50_000)].concat(),
        b"R[".repeat(50_000),
    ];
    for src in odd.iter().copied().chain(deep.iter().map(|d| d.as_slice())) {
        let program = parse(src);
        assert_eq!(program.to_bytes(), src);
        for block in program.blocks() {
            let len: usize = block.root.leaves().iter().map(|l| l.span.len()).sum();
            assert_eq!(len, block.span().len());
        }
    }
}

#[test]
fn json_dump_holds_every_block_tree_and_the_diagnostics() {
    let src = syntax_support::fixture("errors.mpf");
    let program = parse(&src);
    let json: serde_json::Value = serde_json::to_value(&program).unwrap();
    let blocks = json["blocks"].as_array().unwrap();
    assert_eq!(blocks.len(), program.block_count());
    assert_eq!(blocks[0]["kind"], "if");
    assert_eq!(blocks[0]["tree"]["kind"], "Block");
    fn leaf_text(node: &serde_json::Value, out: &mut String) {
        match node["children"].as_array() {
            Some(children) => children.iter().for_each(|c| leaf_text(c, out)),
            None => out.push_str(node["text"].as_str().unwrap()),
        }
    }
    let mut text = String::new();
    blocks.iter().for_each(|b| leaf_text(&b["tree"], &mut text));
    assert_eq!(
        text.as_bytes(),
        src,
        "an ASCII file's leaf texts add up to the file"
    );
    let diagnostics = json["diagnostics"].as_array().unwrap();
    assert_eq!(diagnostics.len(), program.diagnostics().len());
    assert_eq!(diagnostics[0]["severity"], "error");
    assert_eq!(
        diagnostics[0]["span"]["start"],
        program.diagnostics()[0].span.start
    );
}
