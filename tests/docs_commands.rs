//! The documentation runs: every command of every ```sh block in README.md and docs/ is executed with the
//! built binary first on PATH, each page in a fresh folder where `fixtures/` is the repository's and
//! `../shared` the shared data (commands that read it are skipped with a notice when it is absent). A page's
//! commands run in order, so a later one may read what an earlier one wrote.
//!
//! What a line of a ```sh block may say at its end, after two blanks and `#`:
//! - `# exit N`: the command is expected to exit with N (default 0);
//! - `# slow`: run only by the ignored test `slow_docs_commands_run` (`cargo test --test docs_commands --
//!   --ignored`), for the benchmarks and the real-data runs that take minutes in a debug build;
//! - `# test: CMD`: the fast test runs CMD instead (the same command with a smaller argument), the ignored
//!   test the command as written;
//! - several of them separated by `, ` (`# slow, exit 1`).
//!
//! Cargo commands (build, install, test, bench, doc) are not run here: they are the test run itself.
//! Also checked: every flag of every command's `--help` is in its reference page, and every relative link
//! of the documentation points at a file and heading that exist.

mod common;
mod shared_data;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// README.md and every Markdown file under docs/, sorted.
fn pages() -> Vec<PathBuf> {
    let mut out = vec![root().join("README.md")];
    out.extend(common::files_under(&root().join("docs"), &["md"]));
    out
}

#[derive(Debug)]
struct Shown {
    line: usize,
    command: String,
    expect: i32,
    slow: bool,
    fast_variant: Option<String>,
}

/// The end word of a here-document the line starts (`cat > f <<'EOF'`), if any.
fn here_document(line: &str) -> Option<String> {
    let after = line.split("<<").nth(1)?;
    let word = after.trim().trim_matches(['\'', '"']);
    (!word.is_empty() && word.chars().all(|c| c.is_ascii_alphanumeric() || c == '_'))
        .then(|| word.to_string())
}

/// The commands of a page's ```sh blocks, continuation lines joined, here-documents kept with their
/// command.
fn commands(page: &Path) -> Vec<Shown> {
    commands_in(&std::fs::read_to_string(page).unwrap(), page)
}

/// [`commands`] of a page's text.
fn commands_in(text: &str, page: &Path) -> Vec<Shown> {
    let mut out = Vec::new();
    let mut in_sh = false;
    let mut pending: Option<(usize, String)> = None;
    let mut here: Option<(usize, String, String)> = None;
    for (i, line) in text.lines().enumerate() {
        let trimmed = line.trim_start();
        if let Some((start, mut body, end)) = here.take() {
            body.push('\n');
            body.push_str(line);
            if line.trim() == end {
                out.push(annotated(start, &body));
            } else {
                here = Some((start, body, end));
            }
            continue;
        }
        if trimmed.starts_with("```") {
            in_sh = !in_sh && trimmed.trim_end() == "```sh";
            continue;
        }
        if !in_sh {
            continue;
        }
        if pending.is_none()
            && let Some(end) = here_document(trimmed)
        {
            here = Some((i + 1, trimmed.to_string(), end));
            continue;
        }
        let (start, mut joined) = match pending.take() {
            Some((start, before)) => (start, before + " " + trimmed),
            None if trimmed.is_empty() || trimmed.starts_with('#') => continue,
            None => (i + 1, trimmed.to_string()),
        };
        if let Some(head) = joined.strip_suffix('\\') {
            joined = head.trim_end().to_string();
            pending = Some((start, joined));
            continue;
        }
        out.push(annotated(start, &joined));
    }
    assert!(!in_sh, "{}: a ```sh block is not closed", page.display());
    out
}

fn annotated(line: usize, text: &str) -> Shown {
    let mut shown = Shown {
        line,
        command: text.to_string(),
        expect: 0,
        slow: false,
        fast_variant: None,
    };
    if let Some((command, notes)) = text.rsplit_once("  # ") {
        let mut known = true;
        for note in notes.split(", ").map(str::trim) {
            if let Some(code) = note.strip_prefix("exit ") {
                shown.expect = code.parse().expect("`# exit N` takes a number");
            } else if note == "slow" {
                shown.slow = true;
            } else if let Some(variant) = note.strip_prefix("test: ") {
                shown.fast_variant = Some(variant.to_string());
            } else {
                known = false;
            }
        }
        if known {
            shown.command = command.trim_end().to_string();
        } else {
            (shown.expect, shown.slow, shown.fast_variant) = (0, false, None);
        }
    }
    shown
}

/// Whether the command runs cargo (with environment words before it, or after `cd dir &&`): the build, the
/// tests and the benchmarks are what runs this test, not something it can run.
fn runs_cargo(command: &str) -> bool {
    command.split_whitespace().any(|w| w == "cargo")
}

/// A fresh folder laid out like the repository for the commands: `work/fixtures` (and `docs`, `grammar`)
/// linked to the repository's, `shared` beside `work` linked to the shared data when it is there.
fn workspace(shared: Option<&Path>) -> (tempfile::TempDir, PathBuf) {
    let tmp = tempfile::tempdir().unwrap();
    let work = tmp.path().join("work");
    std::fs::create_dir(&work).unwrap();
    for dir in ["fixtures", "docs", "grammar"] {
        std::os::unix::fs::symlink(root().join(dir), work.join(dir)).unwrap();
    }
    if let Some(shared) = shared {
        std::os::unix::fs::symlink(shared, tmp.path().join("shared")).unwrap();
    }
    (tmp, work)
}

/// `PATH` with the built binary's folder first, so the pages' `driftloop` is the one under test.
fn path_with_the_binary() -> String {
    let bin_dir = Path::new(env!("CARGO_BIN_EXE_driftloop")).parent().unwrap();
    format!(
        "{}:{}",
        bin_dir.display(),
        std::env::var("PATH").unwrap_or_default()
    )
}

/// The `--help` of a command (`log merge`: of the subcommand).
fn help_of(command: &str) -> String {
    let mut args: Vec<&str> = command.split(' ').collect();
    args.push("--help");
    let out = Command::new(env!("CARGO_BIN_EXE_driftloop"))
        .args(&args)
        .output()
        .unwrap();
    String::from_utf8(out.stdout).unwrap()
}

/// Runs the pages' commands; `slow` runs the slow ones and the commands as written instead of their fast
/// variants. Returns the failures.
fn run_pages(slow: bool) -> Vec<String> {
    let path = path_with_the_binary();
    let shared = shared_data::path("");
    let mut failures = Vec::new();
    let mut ran = 0;
    for page in pages() {
        let shown = commands(&page);
        if shown.is_empty() {
            continue;
        }
        let (_tmp, work) = workspace(shared.as_deref());
        let rel = page.strip_prefix(root()).unwrap().display().to_string();
        for s in shown {
            let at = format!("{rel}:{}", s.line);
            if runs_cargo(&s.command) {
                continue;
            }
            if s.command.contains("../shared") && shared.is_none() {
                eprintln!("note: {at} skipped, ../shared is absent: {}", s.command);
                continue;
            }
            let command = match (&s.fast_variant, slow) {
                (Some(fast), false) => fast.clone(),
                _ if s.slow && !slow => continue,
                _ => s.command.clone(),
            };
            let started = Instant::now();
            let out = Command::new("sh")
                .arg("-c")
                .arg(&command)
                .current_dir(&work)
                .env("PATH", &path)
                .env_remove("NO_COLOR")
                .output()
                .unwrap();
            ran += 1;
            let code = out.status.code().unwrap_or(-1);
            eprintln!(
                "{at}: exit {code} in {:.1} s: {command}",
                started.elapsed().as_secs_f64()
            );
            if code != s.expect {
                failures.push(format!(
                    "{at}: `{command}` exited {code}, the page expects {}\n{}",
                    s.expect,
                    String::from_utf8_lossy(&out.stderr)
                ));
            }
        }
    }
    assert!(ran > 0, "no command found in the documentation");
    failures
}

#[test]
fn docs_commands_run() {
    let failures = run_pages(false);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
#[ignore = "benchmarks and real-data runs: minutes in a debug build"]
fn slow_docs_commands_run() {
    let failures = run_pages(true);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn the_annotations_are_read() {
    let s = annotated(3, "driftloop check x.mpf  # exit 1");
    assert_eq!((s.command.as_str(), s.expect), ("driftloop check x.mpf", 1));
    let s = annotated(3, "driftloop bench  # test: driftloop bench --size-mb 1");
    assert_eq!(
        s.fast_variant.as_deref(),
        Some("driftloop bench --size-mb 1")
    );
    let s = annotated(3, "driftloop run --audit big.mpf  # slow, exit 1");
    assert!(s.slow && s.expect == 1 && s.command == "driftloop run --audit big.mpf");
    let s = annotated(3, "echo a  # just a comment");
    assert_eq!(s.command, "echo a  # just a comment");
    assert_eq!(
        here_document("cat > m.toml <<'EOF'").as_deref(),
        Some("EOF")
    );
    assert_eq!(here_document("driftloop check a.mpf"), None);
    assert!(runs_cargo(
        "RUSTDOCFLAGS=\"-D warnings\" cargo doc --no-deps"
    ));
    assert!(runs_cargo("cargo test") && !runs_cargo("driftloop demo"));
}

/// The subcommands and their reference pages.
const COMMANDS: [&str; 17] = [
    "demo",
    "check",
    "parse",
    "fit",
    "predict",
    "forward",
    "log merge",
    "transform",
    "strip",
    "plan",
    "run",
    "diagnose",
    "simulate-data",
    "sensors",
    "positioning",
    "bench",
    "profiles",
];

#[test]
fn every_flag_is_in_its_reference_page() {
    let mut missing = Vec::new();
    for command in COMMANDS {
        let page = root()
            .join("docs/commands")
            .join(format!("{}.md", command.split(' ').next().unwrap()));
        let text =
            std::fs::read_to_string(&page).unwrap_or_else(|e| panic!("{}: {e}", page.display()));
        let help = help_of(command);
        for line in help.lines() {
            let option = line.trim_start();
            if !option.starts_with('-') {
                continue;
            }
            for word in option.split([' ', ',']) {
                let flag = word.split(['=', '<']).next().unwrap();
                if flag.starts_with("--")
                    && !["--help", "--color"].contains(&flag)
                    && !text.contains(&format!("`{flag}"))
                {
                    missing.push(format!("{}: {flag}", page.display()));
                }
            }
        }
    }
    assert!(
        missing.is_empty(),
        "flags without documentation:\n{}",
        missing.join("\n")
    );
}

/// GitHub's anchor of a heading: lower case, blanks to `-`, punctuation other than `-` and `_` dropped.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            '-' | '_' => Some(c),
            c if c.is_alphanumeric() => Some(c),
            _ => None,
        })
        .flat_map(char::to_lowercase)
        .collect()
}

/// The anchors of a Markdown page's headings (outside code blocks).
fn anchors(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut fenced = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
        } else if !fenced && line.starts_with('#') {
            out.push(slug(line.trim_start_matches('#')));
        }
    }
    out
}

#[test]
fn relative_links_point_at_files_and_headings_that_exist() {
    assert_eq!(
        slug(" 5. `diagnose`: judged on later time"),
        "5-diagnose-judged-on-later-time"
    );
    let mut broken = Vec::new();
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        for piece in text.split("](").skip(1) {
            let target = piece.split(')').next().unwrap();
            let (file, anchor) = target.split_once('#').unwrap_or((target, ""));
            if file.contains("://") || file.starts_with("mailto:") {
                continue;
            }
            let path = if file.is_empty() {
                page.clone()
            } else {
                page.parent().unwrap().join(file)
            };
            if !path.exists() {
                broken.push(format!("{}: {target}", page.display()));
            } else if !anchor.is_empty()
                && path.extension().is_some_and(|e| e == "md")
                && !anchors(&std::fs::read_to_string(&path).unwrap()).contains(&anchor.to_string())
            {
                broken.push(format!("{}: {target} (no such heading)", page.display()));
            }
        }
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn the_readme_picture_is_what_the_demo_draws() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("demo.svg");
    let out = Command::new(env!("CARGO_BIN_EXE_driftloop"))
        .args(["demo", "--plot"])
        .arg(&svg)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let drawn = std::fs::read_to_string(&svg).unwrap();
    let committed = std::fs::read_to_string(root().join("docs/demo.svg")).unwrap();
    assert!(
        drawn == committed,
        "docs/demo.svg is not what the demo draws now: run `driftloop demo --plot docs/demo.svg` and commit it"
    );
    assert!(drawn.starts_with("<svg") && drawn.contains("machined error"));
}

/// A new user reads `--help` first: every flag says what it does (`--format` of nine commands showed only
/// its possible values), and every command ends with examples that use its own flags.
#[test]
fn every_help_describes_each_flag_and_ends_with_examples() {
    let mut problems = Vec::new();
    for command in COMMANDS {
        let help = help_of(command);
        let lines: Vec<&str> = help.lines().collect();
        for (i, line) in lines.iter().enumerate() {
            let option = line.trim_start();
            // Options only: not the `- value: …` lines of a list of possible values.
            if !option.starts_with('-') || option.starts_with("- ") {
                continue;
            }
            let next = lines.get(i + 1).map_or("", |l| l.trim());
            if next.is_empty()
                || next.starts_with("Possible values")
                || next.starts_with("[default")
            {
                problems.push(format!("{command}: `{option}` has no description"));
            }
        }
        let Some(examples) = help.split("\nExamples:\n").nth(1) else {
            problems.push(format!("{command}: no Examples section"));
            continue;
        };
        for example in examples.lines().filter(|l| !l.trim().is_empty()) {
            if !example.trim().starts_with(&format!("driftloop {command}")) {
                problems.push(format!(
                    "{command}: example `{example}` runs another command"
                ));
            }
            for flag in example.split_whitespace().filter(|w| w.starts_with('-')) {
                let long = flag.split('=').next().unwrap();
                let declared = lines.iter().any(|l| {
                    let option = l.trim_start();
                    option.starts_with('-')
                        && option
                            .split([' ', ','])
                            .any(|w| w.split(['=', '<']).next() == Some(long))
                });
                if long != "-" && !declared {
                    problems.push(format!("{command}: example flag {long} is not in --help"));
                }
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// The tutorial shows what its commands print: every line of a ```text block after a ```sh block (but `…`)
/// is a line its commands write, on stdout or stderr. Its numbers had gone stale (609 inserted blocks where
/// the transform inserts 601, a warning about a law the fit no longer chooses) while the commands still ran.
#[test]
fn the_tutorial_shows_what_its_commands_print() {
    let page = root().join("docs/tutorial.md");
    let text = std::fs::read_to_string(&page).unwrap();
    // Each ```sh block with the ```text block that follows it, if one does.
    let mut blocks: Vec<(String, Option<String>)> = Vec::new();
    let mut fence: Option<(&str, String)> = None;
    for line in text.lines() {
        match (&mut fence, line.trim_end()) {
            (None, "```sh") => fence = Some(("sh", String::new())),
            (None, "```text") => fence = Some(("text", String::new())),
            (Some((kind, body)), "```") => {
                let body = std::mem::take(body);
                match (*kind, blocks.last_mut()) {
                    ("sh", _) => blocks.push((body, None)),
                    ("text", Some((_, shown @ None))) => *shown = Some(body),
                    _ => {}
                }
                fence = None;
            }
            (Some((_, body)), _) => {
                body.push_str(line);
                body.push('\n');
            }
            (None, _) => {
                if !line.trim().is_empty() && !line.starts_with("```") {
                    // Prose between an sh block and a text block: the text shows something else.
                    if let Some((_, shown @ None)) = blocks.last_mut() {
                        *shown = Some(String::new());
                    }
                }
            }
        }
    }
    let path = path_with_the_binary();
    let (_tmp, work) = workspace(None);
    let mut stale = Vec::new();
    let mut compared = 0;
    for (sh, shown) in &blocks {
        let mut printed = String::new();
        for s in commands_in(&format!("```sh\n{sh}```\n"), &page) {
            let out = Command::new("sh")
                .arg("-c")
                .arg(&s.command)
                .current_dir(&work)
                .env("PATH", &path)
                .env("NO_COLOR", "1")
                .output()
                .unwrap();
            printed.push_str(&String::from_utf8_lossy(&out.stdout));
            printed.push_str(&String::from_utf8_lossy(&out.stderr));
        }
        let Some(shown) = shown.as_deref().filter(|t| !t.is_empty()) else {
            continue;
        };
        compared += 1;
        let lines: Vec<&str> = printed.lines().map(str::trim_end).collect();
        for expected in shown.lines().map(str::trim_end) {
            if !expected.is_empty() && expected != "…" && !lines.contains(&expected) {
                stale.push(format!("{}\n  shows: {expected}", sh.trim()));
            }
        }
    }
    assert!(compared >= 10, "only {compared} output blocks found");
    assert!(
        stale.is_empty(),
        "docs/tutorial.md shows lines its commands no longer print:\n{}",
        stale.join("\n")
    );
}
