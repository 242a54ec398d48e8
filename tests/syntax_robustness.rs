//! Hostile input must not exhaust the stack: long operator chains, deep parentheses and prefix operators,
//! deep IF nesting — in a small file and in one above 16 MiB (parsed in pieces on the thread pool). Each
//! check runs in a thread with a 2 MiB stack (the default of a spawned thread), so a recursion that grows
//! with the input fails the test instead of passing on the main thread's larger stack.

use driftloop::vm::{Config, SimpleMachine, run_source};
use driftloop::{Program, Severity, parse_owned};

const STACK: usize = 2 << 20;

/// Runs `f` on a thread with a [`STACK`]-byte stack and returns its result (a stack overflow aborts the
/// test process, a panic fails the test).
fn on_small_stack<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
    std::thread::Builder::new()
        .stack_size(STACK)
        .spawn(f)
        .expect("thread")
        .join()
        .expect("no panic")
}

fn chain(terms: usize) -> String {
    format!("R1=1{}\n", "+1".repeat(terms - 1))
}

fn parens(depth: usize) -> String {
    format!("R1={}1{}\n", "(".repeat(depth), ")".repeat(depth))
}

fn minus(depth: usize) -> String {
    format!("R1={}1\n", "-".repeat(depth))
}

/// The messages of the program's error diagnostics.
fn error_messages(p: &Program) -> Vec<String> {
    p.diagnostics()
        .iter()
        .filter(|d| d.severity == Severity::Error)
        .map(|d| d.message.clone())
        .collect()
}

/// Parses `src`, checks the round trip, builds every block's tree and its dump, and returns the errors.
fn parse_everything(src: Vec<u8>) -> Vec<String> {
    let program = parse_owned(src.clone());
    assert!(program.to_bytes() == src, "round trip");
    for block in program.blocks() {
        let json = serde_json::to_string(&block).expect("tree as JSON");
        assert!(!json.is_empty());
        let facts = driftloop::views::facts(&block);
        assert_eq!(facts.index, block.index);
    }
    let dump = program.dump_tree();
    assert!(dump.len() > src.len().min(1 << 16));
    error_messages(&program)
}

const TOO_DEEP: &str = "expression nested deeper than 256 levels";

#[test]
fn hostile_expressions_are_errors_and_print_back() {
    let errors = on_small_stack(|| {
        let src = [chain(200_000), parens(100_000), minus(100_000)].concat();
        parse_everything(src.into_bytes())
    });
    assert_eq!(errors, vec![TOO_DEEP; 3]);
}

#[test]
fn expressions_a_block_of_the_control_can_hold_parse() {
    // 512 characters per block on the control: about 250 operators or parentheses.
    let errors = on_small_stack(|| {
        let mixed = format!("R2={}1{}\n", "-(".repeat(120), ")".repeat(120));
        let src = [chain(250), parens(250), minus(250), mixed].concat();
        parse_everything(src.into_bytes())
    });
    assert!(errors.iter().all(|e| e != TOO_DEEP), "{errors:?}");
}

#[test]
fn hostile_lines_in_a_file_above_16_mib() {
    let errors = on_small_stack(|| {
        let filler = "N10 G1 X12.345 Y-3.2 Z0.5 F800\n".repeat((17 << 20) / 32);
        let src = [
            filler.as_str(),
            &chain(200_000),
            filler.as_str(),
            &parens(100_000),
            &minus(100_000),
        ]
        .concat();
        assert!(src.len() > 16 << 20);
        let program = parse_owned(src.clone().into_bytes());
        assert!(program.to_bytes() == src.as_bytes(), "round trip");
        error_messages(&program)
    });
    assert_eq!(errors, vec![TOO_DEEP; 3]);
}

#[test]
fn deep_if_nesting_is_paired_without_recursion() {
    const LEVELS: usize = 100_000;
    let (errors, ran) = on_small_stack(|| {
        let src = [
            "IF R1==0\n".repeat(LEVELS),
            "ENDIF\n".repeat(LEVELS),
            "M30\n".into(),
        ]
        .concat();
        let program = parse_owned(src.into_bytes());
        let structure = driftloop::analyze(&program);
        assert_eq!(structure.pairs.len(), LEVELS);
        assert_eq!(structure.pairs[0], (LEVELS - 1, LEVELS), "innermost first");
        let run = run_source(
            "deep.mpf",
            program.source(),
            None,
            &Config::default(),
            &mut SimpleMachine::cold(),
        );
        (error_messages(&program), run.map(|r| r.trace.len()))
    });
    assert_eq!(errors, Vec::<String>::new());
    let ran = ran.unwrap_or_else(|e| panic!("{e}"));
    assert!(ran >= 2 * LEVELS, "every IF and ENDIF ran: {ran}");
}

#[test]
fn the_dry_run_evaluates_the_deepest_accepted_expressions() {
    let r1 = on_small_stack(|| {
        let src = [
            chain(256),
            format!("R2={}R1{}\n", "(".repeat(250), ")".repeat(250)),
            format!("R3={}R2\n", "-".repeat(250)),
            "X=R1+R2+R3\nM30\n".into(),
        ]
        .concat();
        let run = run_source(
            "deep.mpf",
            src.as_bytes(),
            None,
            &Config::default(),
            &mut SimpleMachine::cold(),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        run.trace.last().unwrap().machine[0]
    });
    assert_eq!(r1, 256.0 * 3.0);
}
