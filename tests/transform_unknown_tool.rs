//! A program that never changes tools (the operator loaded the tool by hand or in MDA) with a spindle probe:
//! `[probe] unknown_tool = "runtime"` (the builtin spindle-probe profiles) makes its gates read the tool and
//! edge in force, swap only when there is one, select it again after the probe and stop before cutting
//! unless it reads back; `"refuse"` keeps the refusal.

mod common;

use common::{run_on_machine, stderr, transform_in, transformed_in};
use driftloop::vm::End;

const SPINDLE_PROBES: [&str; 2] = ["blum-tc50", "siemens-cycle978"];

fn single_tool() -> String {
    std::fs::read_to_string(common::fixture("shop/24_single_tool_face.mpf")).unwrap()
}

/// A machine that does not drift, with the named tool T3 (`EM_D80`, D1) in force at the start.
const TOOL_LOADED: &str = "[tool]\nnumber = 3\nname = \"EM_D80\"\nd = 1\n";

/// The default profile with `from` replaced by `to` (which must change it).
fn default_with(from: &str, to: &str) -> String {
    let text = driftloop::omm::DEFAULT_PROFILE.replace(from, to);
    assert_ne!(text, driftloop::omm::DEFAULT_PROFILE, "{from}");
    text
}

const TM_TEMPLATE: &str = "tool_by_number = \"$TC_TP2[{t}]\"";

/// The default profile selecting the tool again with `T=template`.
fn with_template(template: &str) -> String {
    default_with(TM_TEMPLATE, &format!("tool_by_number = \"{template}\""))
}

/// The lines of the output from the comment of gate `n` to its skip label.
fn gate_text(out: &str, n: usize) -> String {
    let lines: Vec<&str> = out.lines().collect();
    let start = lines
        .iter()
        .position(|l| l.starts_with(&format!("; driftloop gate {n} ")))
        .unwrap();
    let end = lines
        .iter()
        .position(|l| l.starts_with(&format!("DLSKIP{n}:")))
        .unwrap();
    lines[start..=end].join("\n")
}

#[test]
fn a_single_tool_program_transforms_with_both_spindle_probe_profiles() {
    let program = single_tool();
    for profile in SPINDLE_PROBES {
        let out = transformed_in(&[("p.mpf", &program)], "p.mpf", profile);
        for needed in [
            "=$P_TOOLNO ;DL",
            "=$P_TOOL ;DL",
            "T=$TC_TP2[R",
            "D=R",
            "IF ($P_TOOLNO<>R",
            "SETAL(65002) ;DL",
        ] {
            assert!(out.contains(needed), "{profile}: no {needed}:\n{out}");
        }
        // The read comes after the gate's STOPRE and before the probe goes in; the check before the first
        // move after the tool is back.
        let read = out.find("=$P_TOOLNO ;DL").unwrap();
        let probe = out.find("\nT=\"").unwrap();
        let back = out.find("T=$TC_TP2[").unwrap();
        let check = out.find("IF ($P_TOOLNO<>").unwrap();
        let moved = back + out[back..].find("G0 G90").unwrap();
        assert!(out[..read].contains("STOPRE"), "{profile}");
        assert!(
            read < probe && probe < back && back < check && check < moved,
            "{profile}"
        );
    }
}

#[test]
fn the_output_runs_as_the_original_with_the_tool_in_force_and_strips_back() {
    let program = single_tool();
    let (o, dir) = transform_in(&[("p.mpf", &program)], "p.mpf", "blum-tc50");
    assert!(o.status.success(), "{}", stderr(&o));
    let out = std::fs::read_to_string(dir.path().join("out.mpf")).unwrap();
    let original = run_on_machine(TOOL_LOADED, &[], &program);
    let transformed = run_on_machine(TOOL_LOADED, &[], &out);
    assert!(
        matches!(transformed.end, End::ProgramEnd { .. }),
        "{:?}",
        transformed.end
    );
    assert!(transformed.alarms.is_empty(), "{:?}", transformed.alarms);
    // The probe went in and measured, and the same passes were cut at the same depths.
    assert!(!transformed.measurements.is_empty());
    let cuts = |r: &driftloop::vm::Run| {
        r.passes
            .iter()
            .map(|p| (p.nominal_z_mm, p.error_um))
            .collect::<Vec<_>>()
    };
    assert_eq!(cuts(&original), cuts(&transformed));
    assert_eq!(original.passes.len(), 3);
    // `strip` gives the original back byte for byte.
    let back = common::driftloop(dir.path(), &["strip", "out.mpf"], b"");
    assert!(back.status.success(), "{}", stderr(&back));
    assert_eq!(back.stdout, program.as_bytes());
}

#[test]
fn with_no_tool_active_the_gates_do_not_swap_and_the_program_cuts_as_before() {
    let program = single_tool();
    let out = transformed_in(&[("p.mpf", &program)], "p.mpf", "blum-tc50");
    // The dry run starts with no tool and D0, as a machine where nothing was loaded.
    let original = run_on_machine("", &[], &program);
    let transformed = run_on_machine("", &[], &out);
    assert!(
        matches!(transformed.end, End::ProgramEnd { .. }),
        "{:?}",
        transformed.end
    );
    assert!(transformed.alarms.is_empty(), "{:?}", transformed.alarms);
    assert!(
        transformed.measurements.is_empty(),
        "the probe was swapped in"
    );
    assert_eq!(original.passes.len(), transformed.passes.len());
    // The rows are logged without a reading; the correction of the model stays.
    let log = &transformed.files["DRIFTLOG"];
    assert!(log.lines().count() > 1, "{log}");
}

#[test]
fn a_tool_loaded_again_that_is_another_stops_before_the_next_cut() {
    let program = single_tool();
    // A template that selects the tool after the one read: the dry run's tool table has no such tool.
    let wrong = with_template("{t}+1");
    let (o, dir) = transform_in(
        &[("p.mpf", &program), ("wrong.toml", &wrong)],
        "p.mpf",
        "wrong.toml",
    );
    let err = stderr(&o);
    // The audit, which runs with a tool in force, finds it.
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("tool-state") && err.contains("another than the one before it"),
        "{err}"
    );
    assert!(!dir.path().join("out.mpf").exists());
    // Written without the audit, the run-time check stops the program at the first gate that swaps.
    let model = common::fixture("omm/model.toml");
    let args = [
        "transform",
        "p.mpf",
        "--model",
        &model,
        "--profile",
        "wrong.toml",
        "--no-audit",
        "-o",
        "out.mpf",
    ];
    let o = common::driftloop(dir.path(), &args, b"");
    assert!(o.status.success(), "{}", stderr(&o));
    let out = std::fs::read_to_string(dir.path().join("out.mpf")).unwrap();
    let run = run_on_machine(TOOL_LOADED, &[], &out);
    assert!(
        matches!(run.end, End::Alarm { number: 65002 }),
        "{:?}",
        run.end
    );
    assert!(
        run.passes.is_empty(),
        "a pass was cut after the wrong tool came in"
    );
    assert!(
        run.messages.iter().any(|m| m.text.contains("is not T3 D1")),
        "{:?}",
        run.messages
    );
}

#[test]
fn tool_numbers_without_tool_management_are_selected_by_number() {
    let program = single_tool();
    let plain = with_template("{t}");
    let out = transformed_in(
        &[("p.mpf", &program), ("plain.toml", &plain)],
        "p.mpf",
        "plain.toml",
    );
    assert!(
        out.lines()
            .any(|l| l.starts_with("T=R") && l.contains(" M6 ;DL")),
        "{out}"
    );
    let unnamed = "[tool]\nnumber = 3\nd = 1\n";
    let run = run_on_machine(unnamed, &[], &out);
    assert!(
        run.alarms.is_empty() && !run.measurements.is_empty(),
        "{:?}",
        run.alarms
    );
    // The tool-management template on that machine: the tool has no name, so the gate's check that it
    // is not the probe cannot compare it (a control without tool management has no `$TC_TP2` at all) and
    // the run stops before it moves or cuts.
    let named = transformed_in(&[("p.mpf", &program)], "p.mpf", "blum-tc50");
    let err = common::try_run_on_machine(unnamed, &[], &named).expect_err("a tool with no name");
    assert!(err.message.contains("BLUM_TC50"), "{err:?}");
}

#[test]
fn a_turret_selects_the_tool_again_with_t_alone() {
    let program = single_tool();
    let turret = with_template("{t}").replace("tool_change = \"m6\"", "tool_change = \"t\"");
    let out = transformed_in(
        &[("p.mpf", &program), ("turret.toml", &turret)],
        "p.mpf",
        "turret.toml",
    );
    let gate = gate_text(&out, 3);
    let back = gate.lines().position(|l| l.starts_with("T=R")).unwrap();
    let lines: Vec<&str> = gate.lines().collect();
    assert!(
        !lines[back].contains("M6") && lines[back + 1].starts_with("D=R"),
        "{gate}"
    );
}

#[test]
fn refuse_keeps_the_refusal() {
    let program = single_tool();
    let refusing = default_with("unknown_tool = \"runtime\"", "unknown_tool = \"refuse\"");
    let (o, _dir) = transform_in(
        &[("p.mpf", &program), ("r.toml", &refusing)],
        "p.mpf",
        "r.toml",
    );
    let err = stderr(&o);
    assert!(!o.status.success());
    assert!(
        err.contains("the tool in the spindle is not known there (no tool change before it), so the probe could not be swapped for it again"),
        "{err}"
    );
}

#[test]
fn a_profile_without_the_key_refuses_and_a_template_needs_the_number() {
    let without = default_with("unknown_tool = \"runtime\"\n", "");
    let p = driftloop::omm::Profile::from_toml(&without, "p.toml").unwrap();
    assert_eq!(
        p.probe.unknown_tool,
        driftloop::omm::profile::UnknownTool::Refuse
    );
    let bad = with_template("$TC_TP2[1]");
    let err = driftloop::omm::Profile::from_toml(&bad, "p.toml")
        .unwrap_err()
        .to_string();
    assert!(err.contains("probe.tool_by_number"), "{err}");
}

#[test]
fn the_gate_that_reads_the_tool() {
    let out = transformed_in(&[("p.mpf", &single_tool())], "p.mpf", "blum-tc50");
    insta::assert_snapshot!("unknown_tool_gate", gate_text(&out, 3));
}

/// A program that faces with the tool in the spindle and then loads, with a bare `M6`, the tool the
/// operator preselected in MDA.
const BARE_M6: &str = "G17 G90 G94 G71 G40\nG54\nD1\nS3000 M3 M8\nG0 X-30 Y10 Z30\nG0 Z2\nG1 Z0 F500\n\
G1 X130 F1800\nG0 Z30\nG1 Z0 F500\nG1 X-30 F1800\nG0 Z100\nM5 M9\nM6\nD1\nS2000 M3\nG0 X0 Y40 Z30\n\
G1 Z-1 F300\nG1 X100 F1000\nG0 Z100\nM30\n";

#[test]
fn no_probe_swap_before_an_m6_that_loads_the_operators_preselection() {
    for profile in SPINDLE_PROBES {
        let out = transformed_in(&[("p.mpf", BARE_M6)], "p.mpf", profile);
        let m6 = out.find("\nM6\n").expect("the program's M6");
        // Before the program's M6 no gate loads the probe (its T would replace the preselection the M6
        // loads); the zero goes after it, with the tool read at run time.
        assert!(!out[..m6].contains("M6 ;DL"), "{profile}:\n{out}");
        assert!(out[m6..].contains("=$P_TOOLNO ;DL"), "{profile}:\n{out}");
    }
}
