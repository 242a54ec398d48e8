//! Tests of the timeline: the word scanner against the tree, times, passes, sites, loops and calls.
use std::rc::Rc;

use super::fold::{Builder, Callees};
use super::read::{CHUNK_BLOCKS, Scan, decimal, scan_tree, scan_words_into};
use super::timing::{TICKS_PER_MIN, ticks};
use super::*;
use crate::omm::profile::Profile;
use crate::syntax::{BlockKind, Program};

/// Every line the word scanner accepts gives the same facts as the syntax tree.
#[test]
fn word_scanner_agrees_with_the_tree() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut sources = vec![
        b"N10 G1 X10.5 Y-3 F800 ; PASS finish\nG0 Z50.\nT12 M6\nS3000 M3 D2\nG2 X1 Y2 I-.5 J0\nG54 G90\nG3 X5 Y5 CR=-12.5 F100\n"
            .to_vec(),
    ];
    for name in ["handwritten.mpf", "crlf.mpf", "latin1.mpf"] {
        sources.push(std::fs::read(dir.join("fixtures/omm").join(name)).unwrap());
    }
    // The real CAM program joins the sources when ../shared is there.
    if let Some(cam) =
        crate::shared_data::path("corpus/sinumerik-840d-sl-cas-package/Approach A/CAM TEST.MPF")
    {
        sources.push(std::fs::read(cam).unwrap());
    }
    let mut fast = 0;
    for src in sources {
        let program = crate::parse(&src);
        // One buffer for all lines, as `build` uses it: a field left over from a line shows here.
        let mut quick = Scan::default();
        for i in 0..program.block_count() {
            let span = program.content_span(i);
            if scan_words_into(&program.source()[span.start..span.end], "PASS", &mut quick) {
                let mut tree = scan_tree(&program, i, "PASS");
                let mut copy = quick.clone();
                let len = usize::from(copy.g.len);
                copy.g.v[..len].sort_unstable();
                let len = usize::from(tree.g.len);
                tree.g.v[..len].sort_unstable();
                assert_eq!(copy, tree, "line {}", i + 1);
                fast += 1;
            }
        }
    }
    assert!(fast > 50, "the scanner took only {fast} lines");
}

/// The timeline of a program folded block by block from whole scans, as before chunks existed.
fn block_by_block(program: &Program, profile: &Profile) -> Timeline {
    struct NoCalls;
    impl Callees for NoCalls {
        fn timeline(&mut self, _: &str) -> Option<(Rc<Timeline>, bool)> {
            None
        }
    }
    let mut none = NoCalls;
    let mut b = Builder::new(profile, &mut none);
    for jump in crate::syntax::structure::analyze(program).jumps {
        if let Some(to) = jump.to {
            b.jumps.entry(jump.from).or_default().push(to);
        }
    }
    let mut words = Scan::default();
    for i in 0..program.block_count() {
        let span = program.content_span(i);
        let kind = program.block_kind(i);
        let line = &program.source()[span.start..span.end];
        if kind == BlockKind::Plain && scan_words_into(line, "PASS", &mut words) {
            b.block(i, &words, kind);
        } else {
            b.block(i, &scan_tree(program, i, "PASS"), kind);
        }
    }
    let mut t = b.finish().0;
    t.unit_end = program.block_count();
    t
}

/// Large programs are read in parallel chunks, moves packed into heads and numbers: the timeline is the
/// one the blocks give one by one, site for site and bit for bit.
#[test]
fn chunks_give_the_block_by_block_timeline() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut text = std::fs::read(dir.join("fixtures/omm/handwritten.mpf")).unwrap();
    text.truncate(text.len() - b"M5\nM30\n".len());
    let mut n = 0u64;
    while text.len() < 3_000_000 {
        let x = (n * 37 % 4000) as f64 / 10.0;
        let line = match n % 9 {
            0 => format!("N{n} G1 X{x} Y-{x} Z-1.5 F900\n"),
            1 => format!("N{n} G3 X{x} Y{x} CR=-12.5\n"),
            2 => format!("G2 X0 Y{x} I-{x} J.5 ; arc\n"),
            3 => "G0 Z50\n".to_string(),
            4 => format!("X{x} Y{x}\n"),
            5 if n % 1000 == 5 => {
                format!("T{} M6 ; PASS\nS{} M3\nG4 F2\n", n % 7, 1000 + n % 5000)
            }
            6 => format!("G1 X=AC({x}) Y=IC(2) Z=R1\n"),
            7 if n % 500 == 7 => "WHILE R1<2\nG0 Z10\nG0 X1\nENDWHILE\n".to_string(),
            _ => format!("G91 G1 X1 F{}\nG90\n", 100 + n % 50),
        };
        text.extend_from_slice(line.as_bytes());
        n += 1;
    }
    text.extend_from_slice(b"M5\nM30\n");
    let program = crate::parse(&text);
    assert!(program.block_count() > 3 * CHUNK_BLOCKS);
    let profile = Profile::default_profile();
    let chunked = build(&program, &profile);
    assert!(chunked.sites.len() > 100 && chunked.passes.len() > 10);
    assert_eq!(chunked, block_by_block(&program, &profile));
}

fn timeline_of(text: &str) -> Timeline {
    build(&crate::parse(text.as_bytes()), &Profile::default_profile())
}

/// One minute of cutting at F100 over 100 mm, then the way back as a rapid.
const BODY: &str = "G1 X100 F100\nG0 Z50\nG0 X0\nG1 Z0 F6000\n";

fn loop_time(t: &Timeline) -> f64 {
    t.loops[0].body_min
}

/// The times of the first retract site's runs.
fn retract_times(t: &Timeline) -> Vec<f64> {
    let retract = t
        .sites
        .iter()
        .position(|s| matches!(s.kind, SiteKind::Retract { .. }))
        .unwrap();
    let runs = crate::omm::loops::site_runs(t);
    assert!(runs.complete);
    runs.sites
        .iter()
        .filter(|(k, _)| *k == retract)
        .map(|(_, time)| *time)
        .collect()
}

/// The time of the tool change every test program starts with.
fn base() -> f64 {
    timeline_of("T1 M6\nS1000 M3\nM30\n").total_min
}

#[test]
fn a_for_loop_with_literal_bounds_runs_its_body_that_often() {
    let once = timeline_of(&format!("T1 M6\nS1000 M3\n{BODY}M30\n"));
    let t = timeline_of(&format!(
        "T1 M6\nS1000 M3\nFOR R1 = 3 TO 7\n{BODY}ENDFOR\nM30\n"
    ));
    let l = &t.loops[0];
    assert_eq!((l.kind, l.runs, l.unknown), (LoopKind::For, Some(5), None));
    assert_eq!((l.block, l.body, l.repeat_block), (2, (3, 7), 7));
    assert!((loop_time(&t) - (once.total_min - base())).abs() < 1e-9);
    assert!((t.total_min - base() - 5.0 * loop_time(&t)).abs() < 1e-9);
    // The retract site in the body is listed once per run, a body apart.
    let times = retract_times(&t);
    assert_eq!(times.len(), 5);
    for pair in times.windows(2) {
        assert!((pair[1] - pair[0] - loop_time(&t)).abs() < 1e-9);
    }
}

#[test]
fn r_parameter_bounds_count_when_last_assigned_a_literal() {
    let t = timeline_of(&format!(
        "R5=4\nT1 M6\nS1000 M3\nFOR R1 = 1 TO R5\n{BODY}ENDFOR\nR5=R5+1\nFOR R2 = 1 TO R5\n{BODY}ENDFOR\nM30\n"
    ));
    assert_eq!(t.loops[0].runs, Some(4));
    assert_eq!(t.loops[1].runs, None);
    assert_eq!(t.loops[1].unknown, Some("bounds computed at run time"));
    assert!((t.total_min - base() - 5.0 * loop_time(&t)).abs() < 1e-9);
}

#[test]
fn loops_ending_on_a_condition_are_counted_once() {
    let t = timeline_of(&format!(
        "T1 M6\nS1000 M3\nWHILE R1<3\n{BODY}R1=R1+1\nENDWHILE\nREPEAT\n{BODY}UNTIL R1>5\nFOR R2 = 5 TO 1\n{BODY}ENDFOR\nM30\n"
    ));
    let kinds: Vec<_> = t.loops.iter().map(|l| (l.kind, l.runs)).collect();
    assert_eq!(
        kinds,
        [
            (LoopKind::While, None),
            (LoopKind::RepeatUntil, None),
            (LoopKind::For, None)
        ]
    );
    assert_eq!(t.loops[2].unknown, Some("the bounds give no run"));
    assert!((t.total_min - base() - 3.0 * loop_time(&t)).abs() < 1e-9);
}

#[test]
fn section_repeats_add_their_runs_at_the_statement() {
    let t = timeline_of(&format!(
        "T1 M6\nS1000 M3\nSTART: G0 X0\n{BODY}REPEAT START P=2\nONE: G1 X100 F100\nG0 X0\nREPEATB ONE P=3\nREPEAT LATER P=2\nLATER: G0 X0\nM30\n"
    ));
    let counted: Vec<_> = t
        .loops
        .iter()
        .map(|l| (l.kind, l.block, l.body, l.runs))
        .collect();
    assert_eq!(
        counted,
        [
            (LoopKind::Repeat, 7, (2, 6), Some(3)),
            (LoopKind::RepeatBlock, 10, (8, 8), Some(4)),
            (LoopKind::Repeat, 11, (11, 11), None),
        ]
    );
    assert_eq!(
        t.loops[2].unknown,
        Some("the section is not before the REPEAT statement")
    );
    // The section: one minute of cutting plus rapids, three times; the repeated block one minute, four
    // times; the rapid back in between.
    let section = t.loops[0].body_min;
    assert!((t.loops[1].body_min - 1.0).abs() < 1e-9);
    let rapid_back = 100.0 / Profile::default_profile().timeline.rapid_mm_per_min;
    assert!((t.total_min - base() - (3.0 * section + 4.0 + rapid_back)).abs() < 1e-9);
}

#[test]
fn nested_counted_loops_multiply() {
    let t = timeline_of(&format!(
        "T1 M6\nS1000 M3\nFOR R1 = 1 TO 3\nFOR R2 = 1 TO 4\n{BODY}ENDFOR\nENDFOR\nM30\n"
    ));
    let inner = t.loops[0].body_min;
    assert!((t.loops[1].body_min - 4.0 * inner).abs() < 1e-9);
    assert!((t.total_min - base() - 12.0 * inner).abs() < 1e-9);
    let times = retract_times(&t);
    assert_eq!(times.len(), 12);
    assert!(times.windows(2).all(|w| (w[1] - w[0] - inner).abs() < 1e-9));
}

#[test]
fn a_loop_of_millions_of_runs_is_timed_but_not_listed_run_by_run() {
    let t = timeline_of(&format!(
        "T1 M6\nS1000 M3\nFOR R1 = 1 TO 5000000\n{BODY}ENDFOR\nM30\n"
    ));
    assert!((t.total_min - base() - 5e6 * loop_time(&t)).abs() < 1e-3);
    let runs = crate::omm::loops::site_runs(&t);
    assert!(!runs.complete);
    assert_eq!(runs.sites.len(), crate::omm::loops::MAX_SITE_RUNS);
    // Counts past u64 and a section that is its own statement neither overflow nor hang.
    let t = timeline_of(&format!(
        "START: REPEAT START P=2\nT1 M6\nFOR R1 = 0 TO 99999999999999999999\n{BODY}ENDFOR\nM30\n"
    ));
    assert_eq!(t.loops[1].runs, Some(u64::MAX));
    assert_eq!(t.loops[0].runs, Some(3));
    assert!(t.total_min.is_finite());
}

/// A gate in a loop body restores the state of the body's first run: where a later run reaches the
/// block in another state (the spindle speed set after it in the body), the site says so.
#[test]
fn sites_reached_in_another_state_by_later_runs_are_marked() {
    let text = "G54\nT1 M6\nS1000 M3\nG0 X0 Y0 Z10\nFOR R1 = 1 TO 3\nG0 Z50\nG0 X10\nG1 Z-1 F100\nS2000 M3\nG1 X100\nG0 Z40\nG0 X0\nENDFOR\nM30\n";
    let t = timeline_of(text);
    let retracts: Vec<(usize, bool)> = t
        .sites
        .iter()
        .filter(|s| matches!(s.kind, SiteKind::Retract { .. }))
        .map(|s| (s.block, s.state_varies))
        .collect();
    // Before `G0 X10` the speed is 1000 rpm in the first run and 2000 in later ones; before `G0 X0` it
    // was set in the same run.
    assert_eq!(retracts, [(6, true), (11, false)]);
    let (_, plan) = crate::omm::plan_program(
        &crate::parse(text.as_bytes()),
        &crate::model::DriftModel::read(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("fixtures/omm/model.toml")
                .as_ref(),
        )
        .unwrap(),
        &Profile::default_profile(),
    )
    .unwrap();
    let gate = plan.gates.iter().find(|g| g.block == 6).unwrap();
    assert!(!gate.can_measure);
    // Without the speed change, and with the feed set before the loop: every run alike.
    let same = timeline_of(
        &text
            .replace("S2000 M3\n", "")
            .replace("G0 X0 Y0 Z10", "G0 X0 Y0 Z10 F100"),
    );
    assert!(same.sites.iter().all(|s| !s.state_varies));
}

#[test]
fn subprogram_and_cycle_calls_are_listed_as_not_timed() {
    let t = timeline_of(
        "G0 X0 Y0\nMSG(\"roughing\")\nCYCLE81(10,0,2,-5)\nN40 L100 P3\nCALL \"CONTOUR\"\nMCALL CYCLE82(10,0,2,-5,,1)\nX10\nY10\nF200\nMCALL\nSETAL(65000)\nG1 X20 F100\nPOCKET\nSTOPRE\nTRANS Z1\nSOFT\nSUB2 P3\nM30\n",
    );
    let calls: Vec<(usize, &str)> = t
        .untimed_calls
        .iter()
        .map(|(line, name)| (*line, name.as_str()))
        .collect();
    assert_eq!(
        calls,
        [
            (3, "CYCLE81"),
            (4, "L100"),
            (5, "CONTOUR"),
            // A modal call runs after each block that moves, until `MCALL` alone.
            (7, "MCALL CYCLE82"),
            (8, "MCALL CYCLE82"),
            // A bare name calls a subprogram unless the control predefines it.
            (13, "POCKET"),
            (17, "SUB2"),
        ]
    );
}

#[test]
fn archive_subprograms_are_timed_in_the_order_they_call_each_other() {
    // SUBA calls SUBB, which comes before it; SUBC and SUBD call each other.
    let archive = "%_N_MAIN_MPF\n;$PATH=/_N_MPF_DIR\nG90 G0 X0 Y0 Z0\nT1 M6\nSUBA P2\nMCALL SUBB\nG0 X10\nG0 X0\nMCALL\nSUBC\nM30\n\
                   %_N_SUBB_SPF\nG91 G1 X10 F100\nG90\nM17\n\
                   %_N_SUBA_SPF\nG91 G1 X100 F100\nG90\nSUBB\nM17\n\
                   %_N_SUBC_SPF\nG91 G1 Z100 F100\nG90\nSUBD\nM17\n\
                   %_N_SUBD_SPF\nG91 G1 Z50 F100\nG90\nSUBC\nM17\n";
    let t = timeline_of(archive);
    let tool_change = Profile::default_profile().timeline.tool_change_s / 60.0;
    let rapid = |mm: f64| mm / Profile::default_profile().timeline.rapid_mm_per_min;
    // SUBA twice (1 + 0.1 min each), SUBB after both moves of the modal call (0.1 min each), SUBC
    // (1 min) with SUBD (0.5 min) once: the call back from SUBD to SUBC is not followed.
    let expected = tool_change + 2.0 * 1.1 + 2.0 * (rapid(10.0) + 0.1) + 1.5;
    assert!(
        (t.total_min - expected).abs() < 1e-9,
        "{} vs {expected}",
        t.total_min
    );
    assert_eq!(t.untimed_calls, [(29, "SUBC".to_string())]);
}

#[test]
fn an_archive_times_its_main_program_and_the_subprograms_it_calls() {
    let main = |call: &str| {
        format!(
            "%_N_MAIN_MPF\n;$PATH=/_N_MPF_DIR\nG90 G0 X0 Y0 Z0\nT1 M6\nG1 X100 F100\n{call}G0 Z50\nM30\n"
        )
    };
    let subprograms = "%_N_L100_SPF\n;$PATH=/_N_SPF_DIR\nG91 G1 X10 F100\nG90\nT2 M6\nR55=1\nM17\n\
                       %_N_OTHER_SPF\nG0 Z10\nG55\nM17\n";
    let alone = timeline_of(&main(""));
    let t = timeline_of(&(main("L100 P3\n") + subprograms));
    // Three runs of 10 mm at F100 and a tool change, nothing of the other units.
    let tool_change = Profile::default_profile().timeline.tool_change_s / 60.0;
    let added = t.total_min - alone.total_min;
    assert!((added - 3.0 * (0.1 + tool_change)).abs() < 1e-9, "{added}");
    assert_eq!(t.unit_end, 8);
    assert!(t.sites.iter().all(|s| s.block < 8) && t.passes.len() == 1);
    assert_eq!(t.ends.len(), 1);
    // What the other units use is taken all the same: R-parameters are global on the control.
    assert!(t.used_r.contains(&55));
    assert!(t.offsets.iter().any(|(g, _)| *g == 55));
    assert!(t.untimed_calls.is_empty());
    // A subprogram not in the archive stays untimed.
    let t = timeline_of(&(main("L200\n") + subprograms));
    assert_eq!(t.untimed_calls, [(6, "L200".to_string())]);
}

#[test]
fn an_archive_that_opens_with_other_files_times_its_main_program_and_the_main_programs_it_calls() {
    let main = "%_N_MAIN_MPF\nG90 G0 X0 Y0 Z0\nT1 M6\nG1 X100 F100\nSIDE\nG0 Z50\nM30\n";
    let before = "%_N_UGUD_DEF\nDEF NCK REAL XW\nM30\n%_N_SUB_SPF\nG1 X500 F100\nM17\n";
    let side = "%_N_SIDE_MPF\nG91 G1 X10 F100\nG90\nM17\n";
    let t = timeline_of(&format!("{before}{main}{side}"));
    // The main program and SIDE's 0.1 min, as when the archive opens with the main program; nothing of
    // SUB's 5 min.
    let plain = timeline_of(&format!("{main}{side}"));
    assert!(t.untimed_calls.is_empty(), "{:?}", t.untimed_calls);
    assert!(
        (t.total_min - plain.total_min).abs() < 1e-9,
        "{} vs {}",
        t.total_min,
        plain.total_min
    );
    let without_side = timeline_of(&main.replace("SIDE\n", ""));
    assert!((plain.total_min - without_side.total_min - 0.1).abs() < 1e-9);
    let main_start = before.lines().count();
    assert_eq!(t.unit_end, main_start + main.lines().count());
    assert!(
        t.sites
            .iter()
            .all(|s| s.block > main_start && s.block < t.unit_end)
    );
}

#[test]
fn subprograms_in_the_profiles_folders_add_their_time_and_take_their_r_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, text: &str| std::fs::write(dir.path().join(name), text).unwrap();
    // ROUGH cuts 100 mm and calls DRILLIT (10 mm) and a cycle; LOOPA and LOOPB call each other.
    write(
        "rough.spf",
        "G91 G1 X100 F100\nR905=1\nDRILLIT\nCYCLE81(1,0,1,-1)\nG90\nM17\n",
    );
    write("_N_DRILLIT_SPF", "G91 G1 Z-10 F100\nG90\nM17\n");
    write("LOOPA.SPF", "G91 G1 X50 F100\nG90\nLOOPB\nM17\n");
    write("LOOPB.SPF", "G91 G1 X50 F100\nG90\nLOOPA\nM17\n");
    let mut profile = Profile::default_profile();
    profile.timeline.subprograms = vec![dir.path().to_path_buf()];
    let program = "G90 G0 X0 Y0 Z0\nT1 M6\nROUGH P2\nLOOPA\nOTHER\nM30\n";
    let t = build(&crate::parse(program.as_bytes()), &profile);
    let alone = timeline_of(program);
    // ROUGH twice (1 + 0.1 min), LOOPA with LOOPB once (1 min): the call back to LOOPA is not followed.
    let added = t.total_min - alone.total_min;
    assert!((added - (2.0 * 1.1 + 1.0)).abs() < 1e-9, "{added}");
    // What the subprograms leave untimed is listed at the call in this program.
    let calls: Vec<(usize, &str)> = t
        .untimed_calls
        .iter()
        .map(|(line, name)| (*line, name.as_str()))
        .collect();
    assert_eq!(calls, [(3, "CYCLE81"), (4, "LOOPA"), (5, "OTHER")]);
    assert!(t.used_r.contains(&905) && !alone.used_r.contains(&905));
}

#[test]
fn the_spindle_a_subprogram_programs_is_followed_through_the_call() {
    // ROUGH starts the spindle itself; FINISH sets only S (the spindle already turns) and stops it.
    let t = timeline_of(
        "%_N_MAIN_MPF\n;$PATH=/_N_MPF_DIR\nG90 G0 X0 Y0 Z0\nT1 M6\nROUGH\nG0 Z50\nFINISH\nG0 Z60\nM30\n\
         %_N_ROUGH_SPF\nS6000 M3\nG91 G1 X100 F100\nG90\nM17\n\
         %_N_FINISH_SPF\nS2000\nG91 G1 X100 F100\nG90\nM5\nM17\n",
    );
    let tc = Profile::default_profile().timeline.tool_change_s / 60.0;
    let finish = tc + 1.0 + 50.0 / Profile::default_profile().timeline.rapid_mm_per_min;
    let expected = [
        (0.0, 0.0),
        (tc, 6000.0),
        (finish, 2000.0),
        (finish + 1.0, 0.0),
    ];
    assert_eq!(t.speeds.len(), expected.len(), "{:?}", t.speeds);
    for (got, want) in t.speeds.iter().zip(expected) {
        assert!(
            (got.0 - want.0).abs() < 1e-9 && got.1 == want.1,
            "{got:?} vs {want:?}"
        );
    }
    let changes: Vec<(usize, f64)> = t
        .sites
        .iter()
        .filter(|s| s.kind == SiteKind::SpeedChange)
        .map(|s| (s.block + 1, s.rpm_after))
        .collect();
    // A gate before each call takes the call's mean speed (the subprogram has no gates of its own), the
    // block after it the speed the subprogram left, where that differs.
    assert_eq!(changes, [(5, 6000.0), (7, 2000.0), (8, 0.0)]);
}

#[test]
fn after_a_call_no_gate_restores_a_state_until_the_next_tool_change() {
    let t = timeline_of(
        "T1 M6\nS2000 M3\nG0 X0 Y0 Z2\nG1 Z-1 F100\nG0 Z50\nG0 X10\nCYCLE952(\"PIN\",,\"\",2101311,0.25)\nG1 Z-1\nG0 Z50\nG0 X20\nT2 M6\nG0 Z2\nG1 Z-1 F100\nG0 Z50\nG0 X30\nM30\n",
    );
    let retracts: Vec<(usize, bool)> = t
        .sites
        .iter()
        .filter(|s| matches!(s.kind, SiteKind::Retract { .. }))
        .map(|s| (s.block + 1, s.state_varies))
        .collect();
    // The cycle (contour turning, which runs a program it generates) may have left another speed, feed
    // or frame: the retract after it cannot measure. Its speed and direction stay unsure past the tool
    // change until the program writes them (red team 5, F2): T2 cuts with no `S`/`M3`, so its retract
    // (15) is unsure too.
    assert_eq!(retracts, [(6, false), (10, true), (15, true)]);
}

#[test]
fn a_drilling_cycle_leaves_unsure_only_what_it_programs_itself() {
    let retracts_after = |cycle: &str| -> Vec<(usize, bool)> {
        let t = timeline_of(&format!(
            "T1 M6\nS2000 M3\nG0 X0 Y0 Z2\nG1 Z-1 F100\nG0 Z50\nG0 X10\n{cycle}\nG1 Z-1\nG0 Z50\nG0 X20\nS2000 M3\nG1 Z-1 F100\nG0 Z50\nG0 X30\nM30\n"
        ));
        t.sites
            .iter()
            .filter(|s| matches!(s.kind, SiteKind::Retract { .. }))
            .map(|s| (s.block + 1, s.state_varies))
            .collect()
    };
    // CYCLE81 programs nothing that stays: every place after it is sure.
    assert_eq!(
        retracts_after("CYCLE81(10,0,2,-5)"),
        [(6, false), (10, false), (14, false)]
    );
    // CYCLE84 ends with the spindle as its SDAC says: unsure until the program writes S, M3 and F again.
    assert_eq!(
        retracts_after("CYCLE84(10,0,2,-5,,0,4,,1.5,0,500,500)"),
        [(6, false), (10, true), (14, false)]
    );
}

/// The milling and turning cycles whose end state the manuals establish leave unsure only the feed,
/// speed or direction they program themselves (see `machining_cycle_leaves`); the others keep every
/// place up to the next tool change from measuring. Before this rule every one of them did.
#[test]
fn a_machining_cycle_leaves_unsure_only_what_it_programs_itself() {
    let program = |cycle: &str| {
        format!(
            "T1 M6\nS2000 M3\nG0 X0 Y0 Z2\nG1 Z-1 F100\nG0 Z50\nG0 X10 Y10\nG0 Z5\n{cycle}\nG0 Z50\nG0 X20\nG1 Z-1\nG0 Z50\nG0 X30\nS2000 M3\nG1 Z-1 F100\nG0 Z50\nG0 X40\nM30\n"
        )
    };
    let retracts_after = |cycle: &str| -> Vec<(usize, bool)> {
        timeline_of(&program(cycle))
            .sites
            .iter()
            .filter(|s| matches!(s.kind, SiteKind::Retract { .. }))
            .map(|s| (s.block + 1, s.state_varies))
            .collect()
    };
    // POCKET3 mills at its own feeds: the rapid before `G1 Z-1` without F (line 10) does not measure,
    // the one before `G1 Z-1 F100` (line 13) does, the feed is not used there.
    let pocket3 = "POCKET3(50,0,1,-8,50,30,6,30,15,0,4,0.2,0.2,600,600,0,11,12,8,3,15,5,2)";
    assert_eq!(
        retracts_after(pocket3),
        [(6, false), (10, true), (13, false), (17, false)]
    );
    // SLOT1 finishes at its own speed SSF, and CYCLE61 is taken to leave the spindle as a tap does: the
    // place at line 13 waits for the program's `S2000 M3`.
    let slot1 = "SLOT1(50,0,1,-5,,3,20,8,60,40,28,45,90,600,600,2.5,2,0.2,1,,,)";
    let face = "CYCLE61(50,1,2,0,-10,-10,130,90,3,40,0.2,1000,31,0,1,10100)";
    for cycle in [slot1, face] {
        assert_eq!(
            retracts_after(cycle),
            [(6, false), (10, true), (13, true), (17, false)],
            "{cycle}"
        );
    }
    // The contour pocket runs a program it generates: nothing measures until the next tool change.
    assert_eq!(
        retracts_after("CYCLE63(\"POCKET_C\",1,50,0,2,-8)"),
        [(6, false), (10, true), (13, true), (17, true)]
    );
    // Where the cycle leaves the tool no rule says: a stop right after it, with no rapid up, is a place
    // in the part; after a drilling cycle it is not (unchanged).
    let in_part_after = |cycle: &str| {
        let t = timeline_of(&format!(
            "T1 M6\nS2000 M3\nG0 X0 Y0 Z2\nG1 Z-1 F100\nG0 Z50\nG0 X10 Y10\nG0 Z5\n{cycle}\nM0\nG0 X20\nM30\n"
        ));
        let stop = t.sites.iter().find(|s| s.kind == SiteKind::Stop).unwrap();
        assert_eq!(stop.block + 1, 10);
        stop.in_part
    };
    assert!(in_part_after(pocket3));
    assert!(!in_part_after("CYCLE81(50,0,2,-5)"));
    // So after a subprogram whose last cut is such a cycle.
    let t = timeline_of(&format!(
        "%_N_MAIN_MPF\n;$PATH=/_N_MPF_DIR\nT1 M6\nS2000 M3\nG0 X0 Y0 Z50\nG0 Z5\nPOCK\nM0\nG0 X20\nM30\n\
         %_N_POCK_SPF\n{pocket3}\nM17\n"
    ));
    let stop = t.sites.iter().find(|s| s.kind == SiteKind::Stop).unwrap();
    assert_eq!(stop.block + 1, 9);
    assert!(stop.in_part, "{stop:?}");
    // The program's own tool change right after CYCLE61: its macro takes the tool out along its axis as
    // the gate does, and the spindle probe's gate before the M6 gives back neither the spindle (the change
    // stops it) nor the feed (the next tool writes F300 before its first cut), so it measures.
    let t = timeline_of(&format!(
        "T1 M6\nS2000 M3 F500\nG0 X0 Y0 Z50\nG0 Z5\n{face}\nT2 M6\nS3000 M3\nG0 X10 Y10\nG1 Z-1 F300\nM30\n"
    ));
    let change = t
        .sites
        .iter()
        .find(|s| s.block + 1 == 6 && matches!(s.kind, SiteKind::PassStart { .. }))
        .unwrap();
    assert!(!change.state_varies && !change.in_part, "{change:?}");
    assert!(change.before.feed.is_none(), "{change:?}");
}

#[test]
fn predefined_procedures_that_leave_what_a_gate_gives_back_are_no_calls() {
    let after = |procedure: &str| -> (Vec<(usize, bool)>, Vec<String>) {
        let t = timeline_of(&format!(
            "T1 M6\nS2000 M3\nG0 X0 Y0 Z2\nG1 Z-1 F100\nG0 Z50\nG0 X10\n{procedure}\nG1 Z-1\nG0 Z50\nG0 X20\nM30\n"
        ));
        let retracts = t
            .sites
            .iter()
            .filter(|s| matches!(s.kind, SiteKind::Retract { .. }))
            .map(|s| (s.block + 1, s.state_varies))
            .collect();
        (
            retracts,
            t.untimed_calls.into_iter().map(|(_, n)| n).collect(),
        )
    };
    // The feed group of the geometry axes, a workpiece counted, the rapid's interpolation, an orientation
    // interpolation: the retract after them measures.
    for procedure in [
        "FGROUP(X,Y,Z)",
        "FGROUP()",
        "FGROUP(X,Y,Z,A)",
        "SETPIECE(1)",
        "RTLIOF",
        "ORIPATH",
    ] {
        assert_eq!(
            after(procedure),
            (vec![(6, false), (10, false)], vec![]),
            "{procedure}"
        );
    }
    // A group without Z moves Z as a synchronous axis: a gate's feed along Z would mean another speed.
    let (retracts, calls) = after("FGROUP(X,Y)");
    assert_eq!(calls, ["FGROUP"]);
    assert_eq!(retracts, [(6, false), (10, true)]);
    // A transformation selected by its data set is the transformation, not a subprogram.
    for procedure in ["TRAORI(1)", "TRACYL(40)"] {
        assert_eq!(after(procedure).1, Vec::<String>::new(), "{procedure}");
    }
}

#[test]
fn decimals_match_the_standard_parser() {
    for t in [
        "0",
        "-0.5",
        "+12.",
        ".25",
        "165.356",
        "-224.452",
        "19083.899",
        "123456789012345",
        "12345678",
        "-123456789.1234",
        "0.000001",
        "98765432.0",
        "1.2345678912",
        "00000000000042",
    ] {
        assert_eq!(
            decimal(t.as_bytes()),
            Some(t.parse::<f64>().unwrap()),
            "{t}"
        );
    }
    for t in ["", "-", "1.2.3", "1e5", "1234567890123456", "12a"] {
        assert_eq!(decimal(t.as_bytes()), None, "{t}");
    }
}

#[test]
fn a_dwell_after_a_retract_is_a_site() {
    let text = "T1 M6\nS4000 M3\nG0 X0 Y0 Z2\nG1 Z-1 F300\nG1 X50 F1200\nG0 Z5\nG4 F600\nG1 X0\nG4 F60\nM30\n";
    let program = crate::parse(text.as_bytes());
    let t = build(&program, &Profile::default_profile());
    let retracts: Vec<usize> = t
        .sites
        .iter()
        .filter(|s| matches!(s.kind, SiteKind::Retract { .. }))
        .map(|s| s.block)
        .collect();
    // The dwell after `G0 Z5` (block 6), not the one after a feed move (block 8).
    assert_eq!(retracts, [6]);
}

/// Time is counted in ticks of 10^-9 min: a block's minutes round to the nearest tick, nothing below zero counts, and a
/// program whose times overflow them stays at the most there are instead of failing.
#[test]
fn times_are_whole_ticks_that_saturate() {
    assert_eq!(ticks(1.0), 1_000_000_000);
    assert_eq!(
        ticks(0.65) as f64 / TICKS_PER_MIN,
        0.65,
        "decimal times stay decimal"
    );
    // A gate's time: the timeline's (in ticks) plus a measurement of 20 s, reported in ticks again.
    assert_eq!(super::on_tick(0.316666667 + 20.0 / 60.0), 0.65);
    assert_eq!(ticks(0.4 / TICKS_PER_MIN), 0);
    assert_eq!(ticks(0.6 / TICKS_PER_MIN), 1);
    assert_eq!((ticks(-1.0), ticks(f64::NAN)), (0, 0));
    assert_eq!(ticks(1e30), u64::MAX);
    let t = timeline_of("T1 M6\nS1000 M3\nG0 X0 Y0 Z0\nG1 X1EX15 F1EX-15\nX0\nX1EX15\nM30\n");
    assert_eq!(t.total_min, u64::MAX as f64 / TICKS_PER_MIN);
    let one = timeline_of("T1 M6\nS1000 M3\nG0 X0 Y0 Z0\nG1 X100 F1000\nM30\n").total_min;
    assert!((one - base() - 0.1).abs() < 1.0 / TICKS_PER_MIN);
}

/// Thread cutting and tapping are cuts timed by their lead: the axis follows the spindle (K mm per
/// revolution at S), and no place while one is the modal motion is fit for a gate.
#[test]
fn threads_and_taps_are_cuts_timed_by_their_lead_and_unfit_for_gates() {
    // 20 mm down at K1.5 × S400 = 600 mm/min: 2 s; out again the same.
    let tap = timeline_of("T1 M6\nG0 X0 Y0 Z2\nG331 Z-18 K1.5 S400\nG332 Z2 K1.5\nG0 Z50\nM30\n");
    assert_eq!(tap.first_cut, Some(2));
    // Besides the tap, rapids of a few mm (well under 0.01 min).
    let cut = tap.total_min - base() - 2.0 * 20.0 / 600.0;
    assert!((0.0..0.01).contains(&cut), "{}", tap.total_min);
    // Between G331 and G332 the motion is a tap and the spindle is in position control.
    let mut between = Modal {
        motion: 331,
        ..Modal::default()
    };
    assert!(between.unfit().is_some());
    for g in [33, 34, 35, 63, 332] {
        between.motion = g;
        assert!(between.unfit().is_some(), "G{g}");
    }
    let thread = timeline_of("T1 M6\nS900 M3\nG0 X24 Z5\nG33 Z-30 K1.5\nG0 X30\nM30\n");
    assert_eq!(thread.first_cut, Some(3));
}

/// QA round 15 (F9 of round 14): feed moves with the spindle positioned are a probe's strokes, no cut, when
/// the tool calls a workpiece measuring cycle before it is changed or the spindle turns; otherwise
/// (broaching, shaping, a spindle started before the cycle, a tap) the first of them is the first cut.
#[test]
fn strokes_under_spos_are_cuts_unless_the_tool_calls_a_measuring_cycle() {
    let probe = timeline_of(
        "T31 M6\nSPOS=0\nG54\nG0 X0 Y0 Z20\nG1 Z5 F1000\nCYCLE978\nG1 Z20\nT32 M6\nS6000 M3\nG0 X10\nG1 Z-2 F300\nM30\n",
    );
    assert_eq!(probe.first_cut, Some(10));
    let broach = timeline_of(
        "T7 M6\nSPOS=90\nG0 X0 Y20 Z5\nG1 Z-12 F800\nG0 Z50\nT8 M6\nS3000 M3\nG1 Z-2 F300\nM30\n",
    );
    assert_eq!(broach.first_cut, Some(3));
    let turned = timeline_of("T1 M6\nSPOS=0\nG0 Z5\nG1 Z-1 F100\nS1000 M3\nCYCLE978\nM30\n");
    assert_eq!(turned.first_cut, Some(3));
    let tap = timeline_of("T1 M6\nSPOS=0\nG0 X0 Y0 Z2\nG331 Z-18 K1.5 S400\nCYCLE978\nM30\n");
    assert_eq!(tap.first_cut, Some(3));
    // A driven tool on a mill-turn machine cuts with the main spindle positioned.
    let driven = timeline_of("T1 M6\nS2=2000 M2=3\nSPOS=0\nG0 Z5\nG1 Z-1 F100\nCYCLE978\nM30\n");
    assert_eq!(driven.first_cut, Some(4));
}

#[test]
fn no_site_lies_inside_a_table_definition() {
    // A contour for CYCLE95 between CONTPRON and EXECUTE, and a curve table, each with a stop and speed
    // word the fold would take for places: their blocks are stored by the control, and a gate's blocks
    // among them would go into the table. The places before the opening call and after the closing one
    // stay.
    let t = timeline_of(
        "T1 M6\nS1000 M3\nG0 X0 Y0 Z50\nCONTPRON(TAB,3,NUM)\nG1 X10 F100\nM5\nS2000 M3\nG0 Z60\nG0 X20\nEXECUTE(ERR)\nS1500 M3\nCTABDEF(Y,X,1,0)\nX0 Y0\nS900\nM1\nX20 Y20\nCTABEND\nM5\nM30\n",
    );
    let blocks: Vec<usize> = t.sites.iter().map(|s| s.block + 1).collect();
    for inside in [5, 6, 7, 8, 9, 10, 13, 14, 15, 16, 17] {
        assert!(!blocks.contains(&inside), "{inside}: {blocks:?}");
    }
    assert!(blocks.contains(&11) && blocks.contains(&18), "{blocks:?}");
}
