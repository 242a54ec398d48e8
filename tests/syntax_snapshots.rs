//! One snapshot per fixture: the input (escaped, so line endings and odd bytes show), the tree dump and the
//! diagnostics. Round-trip exactness is checked by bytes elsewhere; these pin the tree shape.

mod syntax_support;

use driftloop::{LineIndex, escape, parse};
use syntax_support::fixture;

fn report(name: &str) -> String {
    let src = fixture(name);
    let program = parse(&src);
    let index = LineIndex::new(&src);
    let mut out = format!("# {name}\n\n## Input\n\n```\n");
    for i in 0..program.block_count() {
        out.push_str(&escape(program.block_span(i).slice(&src)));
        out.push('\n');
    }
    out.push_str("```\n\n## Tree\n\n```\n");
    out.push_str(&program.dump_tree());
    out.push_str("```\n\n## Diagnostics\n\n");
    if program.diagnostics().is_empty() {
        out.push_str("none\n");
    }
    for d in program.diagnostics() {
        let (line, col) = index.line_col(d.span.start);
        out.push_str(&format!("- {line}:{col} {:?}: {}\n", d.severity, d.message));
        if let Some(help) = &d.help {
            out.push_str(&format!("  help: {help}\n"));
        }
        for (span, note) in &d.related {
            let (line, col) = index.line_col(span.start);
            out.push_str(&format!("  related {line}:{col}: {note}\n"));
        }
    }
    out
}

macro_rules! snapshot {
    ($test:ident, $file:literal) => {
        #[test]
        fn $test() {
            insta::with_settings!({ snapshot_path => "snapshots", prepend_module_to_snapshot => false }, {
                insta::assert_snapshot!(stringify!($test), report($file));
            });
        }
    };
}

snapshot!(syntax_cam, "cam.mpf");
snapshot!(syntax_control, "control.mpf");
snapshot!(syntax_crlf, "crlf.mpf");
snapshot!(syntax_latin1, "latin1.mpf");
snapshot!(syntax_errors, "errors.mpf");
snapshot!(syntax_jumps, "jumps.mpf");
snapshot!(syntax_archive, "archive.arc");
snapshot!(syntax_declarations, "declarations.spf");
snapshot!(syntax_dialect, "dialect.mpf");
