//! `driftloop transform` and `plan` through the built binary: output modes, refusals, exit codes.

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

fn fixtures() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures/omm")
}

fn model() -> String {
    fixtures().join("model.toml").display().to_string()
}

/// Copies fixture `from` to `dir/to`.
fn copy_fixture(dir: &Path, from: &str, to: &str) -> PathBuf {
    let to = dir.join(to);
    std::fs::create_dir_all(to.parent().unwrap()).unwrap();
    std::fs::copy(fixtures().join(from), &to).unwrap();
    to
}

/// `transform TREE --model … -o OUT [extra…]` through the binary.
fn transform_tree(tree: &Path, out: &Path, extra: &[&str]) -> Output {
    let (tree, out, model) = (
        tree.display().to_string(),
        out.display().to_string(),
        model(),
    );
    let mut args = vec!["transform", &tree, "--model", &model, "-o", &out];
    args.extend_from_slice(extra);
    common::run(&args)
}

fn code(o: &Output) -> i32 {
    o.status.code().unwrap()
}

#[test]
fn stdin_to_stdout() {
    let input = std::fs::read(fixtures().join("handwritten.mpf")).unwrap();
    let o = common::driftloop(
        Path::new(env!("CARGO_MANIFEST_DIR")),
        &["transform", "-", "--model", &model()],
        &input,
    );
    assert_eq!(code(&o), 0, "{}", String::from_utf8_lossy(&o.stderr));
    assert!(o.stdout.starts_with(b"; driftloop-omm"));
    assert!(o.stdout.len() > input.len());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("-: 3 passes"), "{stderr}");
}

#[test]
fn check_then_write_then_check_again() {
    let dir = tempfile::tempdir().unwrap();
    let src = copy_fixture(dir.path(), "handwritten.mpf", "handwritten.mpf");
    let out = dir.path().join("out.mpf");
    let (src, out_s, model) = (
        src.display().to_string(),
        out.display().to_string(),
        model(),
    );
    let args = |extra: &[&'static str]| {
        let mut v = vec!["transform", &src, "--model", &model, "-o", &out_s];
        v.extend_from_slice(extra);
        v.into_iter().map(String::from).collect::<Vec<_>>()
    };
    let run = |a: Vec<String>| common::run(&a.iter().map(String::as_str).collect::<Vec<_>>());
    let o = run(args(&["--check"]));
    assert_eq!(code(&o), 1, "missing output differs");
    assert!(!out.exists(), "--check writes nothing");
    assert_eq!(code(&run(args(&[]))), 0);
    let written = std::fs::read(&out).unwrap();
    let o = run(args(&["--check"]));
    assert_eq!(code(&o), 0, "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::write(&out, b"stale\n").unwrap();
    assert_eq!(code(&run(args(&["--check"]))), 1);
    std::fs::write(&out, &written).unwrap();
    let o = run(args(&["--check", "--format", "json"]));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(json[0]["changed"], false);
    assert_eq!(json[0]["summary"]["passes"], 3);
    assert!(json[0]["summary"]["measurements_planned"].as_u64().unwrap() >= 2);
    assert!(json[0]["summary"]["r_parameters"].as_array().unwrap().len() >= 20);
    // The zero's label first (it jumps over the zero in a block search), then the gates'.
    assert_eq!(json[0]["summary"]["labels"][0], "DLSKIP1");
    assert_eq!(json[0]["summary"]["labels"][1], "DLSKIP3");
}

#[test]
fn diff_shows_insertions_only() {
    let path = fixtures().join("handwritten.mpf").display().to_string();
    let o = common::run(&["transform", &path, "--model", &model(), "--diff"]);
    assert_eq!(code(&o), 1, "a diff means the program would change");
    let diff = String::from_utf8(o.stdout).unwrap();
    assert!(diff.contains("+; driftloop-omm"), "{diff}");
    assert!(
        diff.lines()
            .any(|l| l.starts_with("+IF (ABS(R") && l.ends_with(" GOTOF DLSKIP3 ;DL")),
        "{diff}"
    );
    for line in diff.lines() {
        assert!(
            !line.starts_with('-') || line.starts_with("---"),
            "removal: {line}"
        );
    }
}

#[test]
fn in_place_is_atomic_and_not_repeated() {
    let dir = tempfile::tempdir().unwrap();
    let src = copy_fixture(dir.path(), "crlf.mpf", "crlf.mpf");
    let p = src.display().to_string();
    let o = common::run(&["transform", &p, "--model", &model(), "--in-place"]);
    assert_eq!(code(&o), 0, "{}", String::from_utf8_lossy(&o.stderr));
    let once = std::fs::read(&src).unwrap();
    assert!(once.windows(13).any(|w| w == b"driftloop-omm"));
    let leftovers: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(leftovers.len(), 1, "no temporary file left");
    let o = common::run(&["transform", &p, "--model", &model(), "--in-place"]);
    assert_eq!(code(&o), 2);
    assert!(String::from_utf8_lossy(&o.stderr).contains("already carries driftloop's blocks"));
    assert_eq!(std::fs::read(&src).unwrap(), once, "refused file untouched");
}

#[test]
fn directories_mirror_into_the_output_directory() {
    let dir = tempfile::tempdir().unwrap();
    let tree = dir.path().join("in");
    copy_fixture(&tree, "handwritten.mpf", "a/handwritten.mpf");
    copy_fixture(&tree, "latin1.mpf", "b/c/latin1.MPF");
    std::fs::write(tree.join("notes.txt"), b"not a program").unwrap();
    let out = dir.path().join("out");
    let o = transform_tree(&tree, &out, &[]);
    assert_eq!(code(&o), 0, "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.join("a/handwritten.mpf").exists());
    assert!(out.join("b/c/latin1.MPF").exists());
    assert!(!out.join("notes.txt").exists());
}

#[test]
fn a_refused_program_stops_the_whole_batch() {
    let dir = tempfile::tempdir().unwrap();
    let tree = dir.path().join("in");
    copy_fixture(&tree, "handwritten.mpf", "handwritten.mpf");
    std::fs::write(tree.join("broken.mpf"), b"T1 M6\nIF R1>\nM30\n").unwrap();
    let out = dir.path().join("out");
    let o = transform_tree(&tree, &out, &[]);
    assert_eq!(code(&o), 2);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("broken.mpf: the program has 1 syntax error"),
        "{stderr}"
    );
    assert!(stderr.contains("nothing written"), "{stderr}");
    assert!(!out.exists());

    // --keep-going writes the good one and still fails the batch.
    let o = transform_tree(&tree, &out, &["--keep-going"]);
    assert_eq!(code(&o), 2);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("1 of 2 program(s) refused; the other 1 written"),
        "{stderr}"
    );
    assert!(
        std::fs::read(out.join("handwritten.mpf"))
            .unwrap()
            .starts_with(b"; driftloop-omm")
    );
    assert!(!out.join("broken.mpf").exists());
}

#[test]
fn several_inputs_need_a_destination() {
    let p = fixtures().join("handwritten.mpf").display().to_string();
    let o = common::run(&["transform", &p, &p, "--model", &model()]);
    assert_eq!(code(&o), 2);
    assert!(String::from_utf8_lossy(&o.stderr).contains("several programs need -o DIRECTORY"));
}

#[test]
fn plan_prints_the_table() {
    let p = fixtures().join("handwritten.mpf").display().to_string();
    let o = common::run(&["plan", &p, "--model", &model()]);
    assert_eq!(code(&o), 0);
    let table = String::from_utf8(o.stdout).unwrap();
    assert!(table.starts_with("pass    line  tool"), "{table}");
    assert!(table.contains("\ngate  pass    line  kind"), "{table}");
    assert!(table.contains("\"ROUGH_D12\""), "{table}");
    assert!(table.contains("extra"));
    let o = common::run(&["plan", &p, "--model", &model(), "--format", "json"]);
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(json["gates"][0]["kind"], "reference");
    assert_eq!(json["passes"][1]["tool"], "\"ROUGH_D12\"");
    assert_eq!(json["passes"][1]["line"], 38);
    let bad = fixtures().join("blum-tc50.toml").display().to_string();
    let o = common::run(&["plan", &p, "--model", &bad]);
    assert_eq!(code(&o), 2, "a profile is not a model");
}

#[test]
fn output_through_a_symlink_or_device_is_not_replaced() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("real.mpf");
    std::fs::write(&target, b"old\n").unwrap();
    let link = dir.path().join("link.mpf");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let p = fixtures().join("handwritten.mpf").display().to_string();
    let o = common::run(&[
        "transform",
        &p,
        "--model",
        &model(),
        "-o",
        &link.display().to_string(),
    ]);
    assert_eq!(code(&o), 0, "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert!(
        std::fs::read(&target)
            .unwrap()
            .starts_with(b"; driftloop-omm")
    );
    // A device is written into, not renamed over.
    let o = common::run(&["transform", &p, "--model", &model(), "-o", "/dev/null"]);
    assert_eq!(code(&o), 0);
    use std::os::unix::fs::FileTypeExt;
    assert!(
        std::fs::metadata("/dev/null")
            .unwrap()
            .file_type()
            .is_char_device()
    );
}

#[test]
fn plan_says_which_signals_it_cannot_foresee() {
    let dir = tempfile::tempdir().unwrap();
    let mut model_text = std::fs::read_to_string(fixtures().join("model.toml")).unwrap();
    model_text
        .push_str("\n[[inputs]]\nsignal = \"ambient_c\"\ntau_min = 30.0\ngain_um_per_unit = 2.0\n");
    let ambient = dir.path().join("ambient.toml");
    std::fs::write(&ambient, model_text).unwrap();
    let profile_text = std::fs::read_to_string(fixtures().join("blum-tc50.toml")).unwrap()
        + "[log]\ninputs = { ambient_c = 1 }\n";
    let profile = dir.path().join("p.toml");
    std::fs::write(&profile, profile_text).unwrap();
    let p = fixtures().join("handwritten.mpf").display().to_string();
    let (m, pr) = (ambient.display().to_string(), profile.display().to_string());
    let o = common::run(&["plan", &p, "--model", &m, "--profile", &pr]);
    assert_eq!(code(&o), 0, "{}", String::from_utf8_lossy(&o.stderr));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("note: the model also reads ambient_c; the plan cannot foresee"),
        "{stderr}"
    );
    // A spindle-only model plans without the note.
    let o = common::run(&["plan", &p, "--model", &model()]);
    assert!(!String::from_utf8_lossy(&o.stderr).contains("note:"));
}

#[test]
fn a_model_with_an_extra_mode_and_a_time_trend_is_predicted_in_nc() {
    // `diagnose` adds a slower spindle mode and a creep; the program predicts both.
    let dir = tempfile::tempdir().unwrap();
    let mut text = std::fs::read_to_string(fixtures().join("model.toml")).unwrap();
    text.push_str("\n[[effects]]\nkind = \"extra_mode\"\n\n[effects.params]\ntau_min = 180.0\ngain_um_per_krpm = 3.0\n");
    text.push_str("\n[[effects]]\nkind = \"time_trend\"\n\n[effects.params]\num_per_h = 0.25\n");
    let model = dir.path().join("extra.toml");
    std::fs::write(&model, text).unwrap();
    let p = fixtures().join("handwritten.mpf").display().to_string();
    let o = common::run(&["transform", &p, "--model", &model.display().to_string()]);
    assert_eq!(code(&o), 0, "{}", String::from_utf8_lossy(&o.stderr));
    let out = String::from_utf8(o.stdout).unwrap();
    assert!(
        out.contains("/180) ;DL"),
        "the 180 min mode is updated: {out}"
    );
    assert!(
        out.contains("+0.00025*(R"),
        "the creep since the zero: {out}"
    );
    assert!(driftloop::parse(out.as_bytes()).diagnostics().is_empty());
}

#[test]
fn plan_and_transform_name_the_calls_they_cannot_time() {
    let dir = tempfile::tempdir().unwrap();
    let program = dir.path().join("calls.mpf");
    std::fs::write(
        &program,
        "G17 G90 G54\nT1 M6\nS3000 M3\nG0 X0 Y0 Z50\nMSG(\"drilling\")\nCYCLE81(10,0,2,-5)\nL100 P3\nCYCLE81(10,0,2,-8)\nCONTOUR\nMCALL CYCLE82(10,0,2,-5,,1)\nX10\nX20\nMCALL\nG1 X40 F500\nM30\n",
    )
    .unwrap();
    let p = program.display().to_string();
    let o = common::run(&["plan", &p, "--model", &model()]);
    assert_eq!(code(&o), 0, "{}", String::from_utf8_lossy(&o.stderr));
    let table = String::from_utf8(o.stdout).unwrap();
    let untimed = &table[table.find("not timed").expect("a not-timed section")..];
    insta::assert_snapshot!("plan_untimed_calls", untimed);
    let o = common::run(&["plan", &p, "--model", &model(), "--format", "json"]);
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(
        json["untimed_calls"],
        serde_json::json!([
            { "name": "CYCLE81", "calls": 2, "first_line": 6 },
            { "name": "L100", "calls": 1, "first_line": 7 },
            { "name": "CONTOUR", "calls": 1, "first_line": 9 },
            { "name": "MCALL CYCLE82", "calls": 2, "first_line": 11 },
        ])
    );
    let o = common::run(&["transform", &p, "--model", &model(), "-o", "/dev/null"]);
    assert_eq!(code(&o), 0);
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("6 subprogram/cycle call(s) not timed"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn subprogram_folders_from_the_profile_or_the_command_line_are_timed() {
    let dir = tempfile::tempdir().unwrap();
    // Not a folder name the lookup finds by itself (`spf`, `subroutines`, …).
    let spf = dir.path().join("lib");
    std::fs::create_dir(&spf).unwrap();
    // R900 lies in the default free range: the transform must take others.
    std::fs::write(
        spf.join("ROUGH.SPF"),
        "G91 G1 X100 F100\nR900=1\nG90\nM17\n",
    )
    .unwrap();
    let program = dir.path().join("main.mpf");
    std::fs::write(
        &program,
        "G17 G90 G54\nT1 M6\nS3000 M3\nG0 X0 Y0 Z50\nROUGH P3\nG0 Z50\nM30\n",
    )
    .unwrap();
    let (p, model) = (program.display().to_string(), model());
    let plan = |extra: &[&str]| {
        let mut args = vec!["plan", &p, "--model", &model, "--format", "json"];
        args.extend_from_slice(extra);
        let o = common::run(&args);
        assert_eq!(code(&o), 0, "{}", String::from_utf8_lossy(&o.stderr));
        serde_json::from_slice::<serde_json::Value>(&o.stdout).unwrap()
    };
    let without = plan(&[]);
    assert_eq!(without["untimed_calls"][0]["name"], "ROUGH");
    let spf_arg = spf.display().to_string();
    let with = plan(&["--subprograms", &spf_arg]);
    assert_eq!(with["untimed_calls"], serde_json::json!([]));
    assert_eq!(
        with["timed_calls"],
        serde_json::json!([{ "name": "ROUGH", "calls": 1, "first_line": 5, "min_per_run": 1.0 }])
    );
    let added = with["total_min"].as_f64().unwrap() - without["total_min"].as_f64().unwrap();
    assert!(
        (added - 3.0).abs() < 1e-6,
        "three runs of one minute: {added}"
    );
    // The same folder named in the profile, relative to the profile file.
    let profile = dir.path().join("machine.toml");
    let text = driftloop::omm::profile::DEFAULT_PROFILE.replace(
        "tool_change_s = 10.0\n",
        "tool_change_s = 10.0\nsubprograms = [\"lib\"]\n",
    );
    assert_ne!(text, driftloop::omm::profile::DEFAULT_PROFILE);
    std::fs::write(&profile, text).unwrap();
    let profile_arg = profile.display().to_string();
    assert_eq!(
        plan(&["--profile", &profile_arg])["total_min"],
        with["total_min"]
    );
    let o = common::run(&[
        "transform",
        &p,
        "--model",
        &model,
        "--profile",
        &profile_arg,
        "--format",
        "json",
        "-o",
        "/dev/null",
    ]);
    assert_eq!(code(&o), 0, "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let taken = json[0]["summary"]["r_parameters"].as_array().unwrap();
    assert!(!taken.is_empty() && !taken.contains(&serde_json::json!(900)));
    // What the transform refuses in the program it refuses in a subprogram it calls, at the call (another
    // work offset than the one a stored-offset profile corrects).
    let frame = common::frame_profile_file(dir.path()).display().to_string();
    for (text, refusal) in [
        (
            "G55\nM17\n",
            "selects G55 (line 5, in subprogram ROUGH called there)",
        ),
        (
            "R[R1]=1\nM17\n",
            "line 5, in subprogram ROUGH called there, indexes R-parameters by an expression",
        ),
    ] {
        std::fs::write(spf.join("ROUGH.SPF"), text).unwrap();
        let o = common::run(&[
            "transform",
            &p,
            "--model",
            &model,
            "--profile",
            &frame,
            "--subprograms",
            &spf_arg,
            "-o",
            "/dev/null",
        ]);
        assert_eq!(code(&o), 2);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(refusal), "{err}");
    }
    // A folder that is not there is refused, not ignored.
    let o = common::run(&[
        "plan",
        &p,
        "--model",
        &model,
        "--subprograms",
        "/no/such/folder",
    ]);
    assert_eq!(code(&o), 2);
    assert!(String::from_utf8_lossy(&o.stderr).contains("/no/such/folder is not a folder"));
}

/// `plan` finds a called subprogram beside the program, as `transform` does (and the control): its time
/// counts without `--subprograms`, from whatever folder the command runs in.
#[test]
fn subprograms_in_an_spf_folder_beside_or_inside_the_programs_are_found() {
    // A control finds a called subprogram in its SPF directory; an archive or a shop keeps the main
    // programs and the subprograms in sibling folders. Unread, the call that is the first cut leaves no
    // place for the zero (no tool known); read, it is timed and the program transforms.
    let main = "N10 G17 G90 G94 G71 G40 G54\nN20 G0 SUPA Z0\nN30 G0 SUPA X0 Y0\nN40 WARM_UP\nN50 G0 Z100\nN60 M30\n";
    let sub = "PROC WARM_UP\nS3000 M3\nG0 X0 Y0 Z50\nG1 Z10 F300\nG1 X100 F1000\nG0 Z50\nM5\nRET\n";
    // Beside only as a pair: `job` and `subs` side by side are two folders, not the control's.
    for (programs, subprograms, found) in [
        ("_N_MPF_DIR", "_N_SPF_DIR", true),
        ("routines", "subroutines", true),
        ("job", "job/spf", true),
        ("job", "subs", false),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let (p, s) = (dir.path().join(programs), dir.path().join(subprograms));
        std::fs::create_dir_all(&p).unwrap();
        std::fs::create_dir_all(&s).unwrap();
        std::fs::write(p.join("W.MPF"), main).unwrap();
        let program = p.join("W.MPF").display().to_string();
        let m = model();
        let args = ["transform", program.as_str(), "--model", &m, "--check"];
        let o = common::driftloop(dir.path(), &args, b"");
        assert_eq!(code(&o), 2, "{subprograms}: without the subprogram");
        assert!(String::from_utf8_lossy(&o.stderr).contains("WARM_UP"));
        std::fs::write(s.join("WARM_UP.SPF"), sub).unwrap();
        let o = common::driftloop(dir.path(), &args, b"");
        assert_eq!(
            code(&o),
            if found { 1 } else { 2 },
            "{subprograms}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
}

#[test]
fn plan_finds_subprograms_beside_the_program_as_transform_does() {
    let dir = tempfile::tempdir().unwrap();
    let job = dir.path().join("job");
    std::fs::create_dir(&job).unwrap();
    let main = "\
N10 G17 G90 G94 G71 G40 G54
N20 T=\"ROUGH_D12\" M6
N30 D1
N40 S3000 M3
N50 G0 X0 Y0 Z50
N60 G1 Z-1 F300
N70 G0 Z50
N80 POCKET_ROUGH
N90 G0 Z100
N100 M30
";
    std::fs::write(job.join("p.mpf"), main).unwrap();
    std::fs::write(
        job.join("POCKET_ROUGH.SPF"),
        "G1 X100 F100\nG1 Y100\nG0 Z50\nM17\n",
    )
    .unwrap();
    let p = job.join("p.mpf").display().to_string();
    let plan = |extra: &[&str]| {
        let mut args = vec!["plan", p.as_str(), "--model", "", "--format", "json"];
        let m = model();
        args[3] = &m;
        args.extend_from_slice(extra);
        let o = common::driftloop(dir.path(), &args, b"");
        assert_eq!(code(&o), 0, "{}", String::from_utf8_lossy(&o.stderr));
        serde_json::from_slice::<serde_json::Value>(&o.stdout).unwrap()
    };
    let json = plan(&[]);
    assert_eq!(json["untimed_calls"], serde_json::json!([]), "{json}");
    assert_eq!(json["timed_calls"][0]["name"], "POCKET_ROUGH", "{json}");
    // Two minutes of the subprogram's cutting at F100 count.
    assert!(json["program_min"].as_f64().unwrap() > 2.0, "{json}");
    // The same as with the folder given.
    let given = plan(&["--subprograms", &job.display().to_string()]);
    assert_eq!(json["program_min"], given["program_min"]);
    assert_eq!(json["timed_calls"], given["timed_calls"]);
}

#[test]
fn an_audit_warning_in_a_subprogram_names_its_file() {
    // The subprogram's first block cuts across the probe point: the warning named "line 1", which in
    // the main program is a comment.
    let main = "; job\nG17 G90 G40 G94 G71\nG54\nT=\"MILL12\" M6\nD1\nS3000 M3\nG0 X10 Y10 Z50\n\
                EXTCALL \"ROUGH\"\nG0 Z100\nM30\n";
    let rough = "G1 Z-2 F800\nG1 X-10 Y-10\nG0 Z50\nM17\n";
    let (o, _dir) = common::transform_in(
        &[("p.mpf", main), ("ROUGH.SPF", rough)],
        "p.mpf",
        "blum-tc50",
    );
    let err = common::stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("ROUGH.SPF line 2: probe-in-machined-volume"),
        "{err}"
    );
}

#[test]
fn a_program_called_by_extcall_beside_the_main_program_is_read() {
    // `EXTCALL "path/ROUGH.SPF"` runs ROUGH from the external drive; beside the main program (or in a
    // subprogram folder) it is read like any subprogram: timed, its end state followed, and the
    // R-parameter it counts with (R60) left alone. It was listed as not timed and its R60 was taken for a
    // gate's register, which the program's count would then overwrite.
    let main = "G17 G90 G40 G94 G71\nG54\nT=\"MILL12\" M6\nD1\nS3000 M3\nG0 X60 Y60 Z50\n\
                EXTCALL \"CF_CARD/JOBS/ROUGH.SPF\"\nG0 Z100\nM30\n";
    let rough = "G1 Z-2 F800\nR60=R60+1\nG1 X90\nG1 Y90\nG0 Z50\nM17\n";
    let files = [("p.mpf", main), ("ROUGH.SPF", rough)];
    let m = model();
    let (o, _dir) = common::run_in(
        &files,
        &["plan", "p.mpf", "--model", &m, "--profile", "blum-tc50"],
    );
    let plan = common::stdout(&o);
    let timed = plan
        .split("timed subprograms")
        .nth(1)
        .unwrap_or_else(|| panic!("nothing timed:\n{plan}"));
    assert!(timed.contains("EXTCALL ROUGH"), "{plan}");
    let out = common::transformed_in(&files, "p.mpf", "blum-tc50");
    assert!(!out.contains("R60"), "{out}");
}
