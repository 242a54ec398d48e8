use std::path::Path;
fn walk(p: &Path, out: &mut Vec<std::path::PathBuf>) {
    for e in std::fs::read_dir(p).unwrap() {
        let e = e.unwrap().path();
        if e.is_dir() {
            walk(&e, out)
        } else {
            out.push(e)
        }
    }
}
#[test]
fn scratch() {
    let mut files = Vec::new();
    walk(Path::new("../shared/corpus"), &mut files);
    files.sort();
    let mut clean = 0;
    let mut nc = 0;
    for f in &files {
        let ext = f
            .extension()
            .map(|e| e.to_string_lossy().to_lowercase())
            .unwrap_or_default();
        let src = std::fs::read(f).unwrap();
        let p = driftloop::parse(&src);
        assert_eq!(p.to_bytes(), src);
        for b in p.blocks() {
            let l: Vec<u8> = b
                .root
                .leaves()
                .iter()
                .flat_map(|n| n.span.slice(&src).to_vec())
                .collect();
            assert_eq!(l, b.root.span.slice(&src), "{}", f.display());
        }
        if !["mpf", "spf", "arc", "nc", "def"].contains(&ext.as_str()) {
            continue;
        }
        nc += 1;
        let idx = driftloop::LineIndex::new(&src);
        let errs: Vec<_> = p
            .diagnostics()
            .iter()
            .filter(|d| d.severity == driftloop::Severity::Error)
            .collect();
        if errs.is_empty() {
            clean += 1;
        }
        if !errs.is_empty() {
            println!("DIRTY {} {}", f.display(), errs.len());
        }
        for d in errs
            .iter()
            .take(if std::env::var("V").is_ok() { 40 } else { 0 })
        {
            let (l, c) = idx.line_col(d.span.start);
            let ls = idx.line_span(l);
            println!(
                "{}:{}:{}: {} | {}",
                f.display(),
                l,
                c,
                d.message,
                String::from_utf8_lossy(ls.slice(&src))
            );
        }
    }
    println!("clean {clean}/{nc} of {}", files.len());
}
