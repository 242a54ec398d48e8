//! Any text as a machine profile: loading never panics; a profile it accepts writes only NC a control can
//! take: every text that reaches a block is printable ASCII, and its probe cycle and result parse as blocks.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|text: &str| {
    let Ok(profile) = driftloop::omm::Profile::from_toml(text, "fuzz.toml") else {
        return;
    };
    for text in [
        &profile.name,
        &profile.probe.tool,
        &profile.probe.result,
        &profile.offset.select,
        &profile.registers.timer,
        &profile.registers.log_file,
    ] {
        assert!(text.chars().all(|c| (' '..='~').contains(&c)), "{text:?} reaches NC");
    }
    let call = profile.cycle_call();
    assert!(driftloop::omm::nc::find_unwritable(&call).is_none(), "{call}");
    assert!(driftloop::syntax::line_syntax_errors(call.as_bytes()).is_empty(), "{call}");
});
