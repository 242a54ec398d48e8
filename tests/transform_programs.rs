//! Real kinds of programs through the `transform` command with the profile made for them — a cylindrical
//! grinder with an in-process gauge, a single-tool milling part with a tool setter, a lathe with a setter
//! arm, a program whose labels are defined twice — each passing the safety audit the command runs on its
//! output (exit 0: no hazard the inserted blocks caused; the audit ran to the end), with golden files.

mod common;

use common::fixture;

/// The transformed program, after checking the command succeeded with a complete audit.
fn transformed(program: &str, profile: &str) -> String {
    let o = common::run(&[
        "transform",
        &fixture(&format!("programs/{program}")),
        "--model",
        &fixture("omm/model.toml"),
        "--profile",
        profile,
        "-o",
        "-",
    ]);
    let stderr = common::stderr(&o);
    assert!(o.status.success(), "{stderr}");
    assert!(!stderr.contains("audit incomplete"), "{stderr}");
    assert!(!stderr.contains("warning:"), "{stderr}");
    String::from_utf8(o.stdout).unwrap()
}

#[test]
fn a_grinder_with_a_gauge() {
    let out = transformed("grinder.mpf", "grinder-gauge");
    // The gauge is read after the dressing call: the wheel is off the part there.
    let after_dress = out.split("\nDRESS\n").nth(1).unwrap();
    assert!(after_dress.starts_with("; driftloop gate"), "{after_dress}");
    insta::assert_snapshot!("grinder", out);
}

#[test]
fn a_single_tool_milling_part_with_a_tool_setter() {
    let out = transformed("single_tool.mpf", "tool-setter");
    assert!(!out.lines().any(|l| l.ends_with(";DL") && l.contains("M6")));
    insta::assert_snapshot!("single_tool", out);
}

#[test]
fn a_lathe_with_a_setter_arm() {
    let out = transformed("lathe.mpf", "lathe-setter");
    // Radius while the gate moves, diameters again after it.
    assert!(
        out.contains("DIAMOF ;DL") && out.contains(" DIAMON ;DL"),
        "{out}"
    );
    insta::assert_snapshot!("lathe", out);
}

#[test]
fn a_program_with_labels_defined_twice() {
    let out = transformed("duplicate_labels.mpf", "blum-tc50");
    insta::assert_snapshot!("duplicate_labels", out);
}

#[test]
fn a_cam_program_with_a_title_above_its_header_cycles_and_a_modal_call() {
    // A GBK title comment above `%_N_…_MPF`, CYCLE832 with symbolic arguments, G41, MCALL CYCLE81: the
    // header goes after the `%` lines, the program's own flow is followed, and the audit runs to the end
    // (the cycles it cannot find are skipped alike in both runs).
    let o = common::run(&[
        "transform",
        &fixture("programs/gbk_title.mpf"),
        "--model",
        &fixture("omm/model.toml"),
        "-o",
        "-",
    ]);
    let stderr = common::stderr(&o);
    assert!(o.status.success(), "{stderr}");
    assert!(!stderr.contains("audit incomplete"), "{stderr}");
    let out = o.stdout;
    let lines: Vec<&[u8]> = out.split(|&b| b == b'\n').collect();
    assert!(lines[1].starts_with(b"%_N_PART1_MPF") && lines[3].starts_with(b"; driftloop-omm"));
}

/// What the operator panel writes around a program block (`GROUP_BEGIN`/`GROUP_END`) and a wait for a
/// positioned spindle (`WAITS`) move nothing: they were read as unknown calls, so a program that opens
/// with a block marker had no place for its zero (found on real programs). Now it transforms, with an audit
/// that runs to the end, and its gates are where the plain program's are.
#[test]
fn program_block_markers_and_waits_move_nothing() {
    let plain = "G54\nT1 M6\nS2000 M3\nG0 X30 Y30 Z5\nG1 Z-1 F100\nG1 X80 F500\nG0 Z50\nSPOS=0\nG1 X90 F300\nM30\n";
    let marked = "GROUP_BEGIN(0,\"ROUGH\",0,0)\nG54\nT1 M6\nS2000 M3\nG0 X30 Y30 Z5\nG1 Z-1 F100\nG1 X80 F500\nG0 Z50\nGROUP_END(0,0)\nSPOS=0\nWAITS(1)\nG1 X90 F300\nM30\n";
    for profile in ["blum-tc50", "tool-setter"] {
        let gates = |src: &str| {
            let out = common::transformed_in(&[("p.mpf", src)], "p.mpf", profile);
            out.lines()
                .filter(|l| l.starts_with("; driftloop gate"))
                .count()
        };
        let plain_gates = gates(plain);
        assert!(plain_gates > 0, "{profile}");
        assert_eq!(gates(marked), plain_gates, "{profile}");
    }
}
