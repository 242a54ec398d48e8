//! Any bytes: parsing never panics, printing gives the input back, parsing the printed program again yields
//! the same diagnostics (the tree holds everything that decides them), and every block's tree covers its
//! bytes leaf by leaf and can be read by the views.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let program = driftloop::parse(data);
    let printed = program.to_bytes();
    assert_eq!(printed, data, "print(parse(x)) != x");
    for d in program.diagnostics() {
        assert!(d.span.start <= d.span.end && d.span.end <= data.len(), "span out of source: {d:?}");
    }
    let reparsed = driftloop::parse(&printed);
    assert_eq!(reparsed.diagnostics(), program.diagnostics(), "re-parse changed the diagnostics");
    for block in program.blocks() {
        let mut at = block.span().start;
        for leaf in block.root.leaves() {
            assert_eq!(leaf.span.start, at, "leaves leave a gap in block {}", block.index);
            at = leaf.span.end;
        }
        assert_eq!(at, block.span().end, "leaves end before block {} does", block.index);
        let _ = driftloop::views::facts(&block);
    }
});
