//! Any bytes: parsing never panics, printing gives the input back, and parsing the printed program again
//! yields the same diagnostics (the tree holds everything that decides them).
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
});
