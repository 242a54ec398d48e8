//! How the gates behave when the operator does not simply press cycle start: a block search into the
//! program, a program test or the panel's simulation (`$P_SEARCH`, `$P_ISTEST`, `$P_SIM`) interpret the
//! program without machining it, and a dry run (`$P_DRYRUN`) would drive the probe at the dry-run feed, so
//! no gate may measure there; and after a gate stopped with an alarm the
//! probe is still in the spindle, so a program that cuts with the tool in force must not start again with it.

mod common;

use common::{run_on_machine, transformed_in};
use driftloop::vm::{End, Run};

fn program(name: &str) -> String {
    std::fs::read_to_string(common::fixture(name)).unwrap()
}

/// The handwritten part names its tool; the single-tool face cuts with the one in force (read at run time).
fn outputs() -> Vec<(&'static str, String, String)> {
    let mut v = Vec::new();
    for name in ["omm/handwritten.mpf", "shop/24_single_tool_face.mpf"] {
        let original = program(name);
        for profile in ["blum-tc50", "siemens-cycle978", "tool-setter"] {
            let out = transformed_in(&[("p.mpf", &original)], "p.mpf", profile);
            v.push((profile, original.clone(), out));
        }
    }
    v
}

/// A tool in force at the start, for the program that names none.
const TOOL: &str = "[tool]\nnumber = 3\nname = \"EM_D80\"\nd = 1\n";

/// The nominal depth of every pass (the error differs: a gate that does not measure still corrects by the
/// model's prediction, and this machine does not drift).
fn depths(r: &Run) -> Vec<f64> {
    r.passes.iter().map(|p| p.nominal_z_mm).collect()
}

#[test]
fn every_gate_that_can_measure_leaves_it_out_in_a_block_search_program_test_or_simulation() {
    for (profile, _, out) in outputs() {
        let guards = out
            .lines()
            .filter(|l| {
                l.contains("$P_SEARCH OR $P_ISTEST OR $P_SIM OR $P_DRYRUN") && l.contains("GOTOF")
            })
            .count();
        let skips = out
            .lines()
            .filter(|l| l.starts_with("DLSKIP") && l.ends_with(": ;DL"))
            .count();
        assert!(skips > 1, "{profile}: {skips} skip labels");
        assert_eq!(
            guards, skips,
            "{profile}: a measuring gate without the guard"
        );
    }
}

#[test]
fn interpreted_without_machining_the_output_measures_nothing_and_cuts_as_the_original() {
    // The tool setter's gates call its subprogram, which this machine does not have.
    let probes = outputs()
        .into_iter()
        .filter(|(p, _, _)| *p != "tool-setter");
    for (profile, original, out) in probes {
        let plain = run_on_machine(TOOL, &[], &original);
        assert!(!plain.passes.is_empty(), "{profile}");
        for mode in [
            "$P_SEARCH = 1",
            "$P_SEARCH = 5",
            "$P_ISTEST = 1",
            "$P_SIM = 1",
            "$P_DRYRUN = 1",
        ] {
            let machine = format!("{TOOL}[variables]\n\"{}\n", mode.replacen(' ', "\" ", 1));
            let run = run_on_machine(&machine, &[], &out);
            assert!(
                matches!(run.end, End::ProgramEnd { .. }),
                "{profile}, {mode}: {:?}",
                run.end
            );
            assert!(run.alarms.is_empty(), "{profile}, {mode}: {:?}", run.alarms);
            assert!(
                run.measurements.is_empty(),
                "{profile}, {mode}: the probe measured"
            );
            // No probe swap either: every pass is cut as in the original.
            assert_eq!(depths(&run), depths(&plain), "{profile}, {mode}");
        }
        // Machined, the same output measures.
        let run = run_on_machine(TOOL, &[], &out);
        assert!(!run.measurements.is_empty(), "{profile}");
    }
}

#[test]
fn a_probe_left_in_the_spindle_stops_a_program_that_cuts_with_the_tool_in_force() {
    let original = program("shop/24_single_tool_face.mpf");
    for (profile, probe) in [("blum-tc50", "BLUM_TC50"), ("siemens-cycle978", "3D_PROBE")] {
        let out = transformed_in(&[("p.mpf", &original)], "p.mpf", profile);
        assert!(
            out.contains(&format!("==\"{probe}\" ;DL")),
            "{profile}:\n{out}"
        );
        let left_in = format!("[tool]\nnumber = 9\nname = \"{probe}\"\nd = 1\n");
        let run = run_on_machine(&left_in, &[], &out);
        assert!(
            matches!(run.end, End::Alarm { number: 65002 }),
            "{profile}: {:?}",
            run.end
        );
        assert!(run.passes.is_empty(), "{profile}: cut with the probe");
        assert!(run.measurements.is_empty(), "{profile}");
        assert!(
            run.messages.iter().any(|m| m
                .text
                .contains(&format!("the probe {probe} is in the spindle"))),
            "{profile}: {:?}",
            run.messages
        );
    }
}

#[test]
fn a_control_without_p_sim_gets_the_condition_its_profile_gives() {
    let original = program("omm/handwritten.mpf");
    let without_sim = driftloop::omm::DEFAULT_PROFILE.replace(
        "# not_machining = \"$P_SEARCH OR $P_ISTEST OR $P_SIM OR $P_DRYRUN\"",
        "not_machining = \"$P_SEARCH OR $P_ISTEST\"",
    );
    assert_ne!(without_sim, driftloop::omm::DEFAULT_PROFILE);
    let out = transformed_in(
        &[("p.mpf", &original), ("old.toml", &without_sim)],
        "p.mpf",
        "old.toml",
    );
    assert!(!out.contains("$P_SIM"), "{out}");
    assert!(
        out.contains("IF $P_SEARCH OR $P_ISTEST GOTOF DLSKIP"),
        "{out}"
    );
    let empty = driftloop::omm::DEFAULT_PROFILE.replace(
        "# not_machining = \"$P_SEARCH OR $P_ISTEST OR $P_SIM OR $P_DRYRUN\"",
        "not_machining = \" \"",
    );
    let (o, _dir) = common::transform_in(
        &[("p.mpf", &original), ("e.toml", &empty)],
        "p.mpf",
        "e.toml",
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(
        common::stderr(&o).contains("registers.not_machining"),
        "{}",
        common::stderr(&o)
    );
}
