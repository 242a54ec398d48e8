//! The crate's modules and the references between them, read from the source files: every `use` and every
//! path written in code that starts at `crate`, `super`, `self`, a child module or a name a `use` brought
//! in. A reference is resolved to the module that defines the item, following imports (`pub use`
//! re-exports and private `use` alike, since a child sees its parent's imports), so a re-export is no
//! dependency on the module that re-exports.
//!
//! Items under `#[cfg(test)]` (unit tests, test-only re-exports) are left out: tests may reach anywhere.
//!
//! Not a compiler: macros are not expanded, and a name that only a glob import (`use x::*`) brings in
//! counts as defined where it is used.

pub mod lex;

use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};

use lex::Tok;

/// A module as its path from the crate root (`["omm", "timeline"]`); the root is empty.
pub type ModPath = Vec<String>;

/// A source file, its module and its tokens.
type Lexed = (PathBuf, ModPath, Vec<(Tok, usize)>);

/// A reference from one module to another, where it is written.
#[derive(Debug, Clone)]
pub struct Reference {
    pub from: ModPath,
    pub to: ModPath,
    pub file: PathBuf,
    pub line: usize,
    /// The path as written (`super::fold::ticks`).
    pub written: String,
}

/// A path as written in module `module`, before it is resolved.
#[derive(Debug, Clone)]
struct Written {
    module: ModPath,
    segments: Vec<String>,
    file: PathBuf,
    line: usize,
}

#[derive(Debug, Default)]
pub struct Crate {
    modules: BTreeSet<ModPath>,
    /// The names each module's `use` declarations bind, with the path they name.
    imports: HashMap<ModPath, HashMap<String, Written>>,
    written: Vec<Written>,
}

impl Crate {
    /// Reads the crate whose root is `src/lib.rs`. The binary's own modules (`src/cli/`, which name the
    /// library's items as `crate::…` through `main.rs`'s glob import) are read as children of that root;
    /// `main.rs` itself is left out.
    pub fn read(src: &Path) -> Crate {
        let mut files = Vec::new();
        rust_files(src, &mut files);
        files.sort();
        let tokens: Vec<Lexed> = files
            .into_iter()
            .filter_map(|file| {
                let module = file_module(src, &file)?;
                let text = std::fs::read_to_string(&file).expect("source files are UTF-8");
                Some((file, module, lex::tokens(&text)))
            })
            .collect();
        let mut c = Crate::default();
        let mut tests = Vec::new();
        for (_, module, toks) in &tokens {
            c.modules.insert(module.clone());
            let mut declared = |m: &ModPath, test: bool| {
                if test {
                    tests.push(m.clone());
                } else {
                    c.modules.insert(m.clone());
                }
            };
            walk(module, toks, &mut |_, _, _| {}, &mut declared);
        }
        let tokens: Vec<_> = tokens
            .into_iter()
            .filter(|(_, module, _)| !tests.iter().any(|t| module.starts_with(t)))
            .collect();
        c.modules
            .retain(|m| !tests.iter().any(|t| m.starts_with(t)));
        for (file, module, toks) in &tokens {
            let mut found = Vec::new();
            walk(
                module,
                toks,
                &mut |m, segments, line| found.push((m.clone(), segments, line)),
                &mut |_, _| {},
            );
            for (module, segments, line) in found {
                c.note(module, segments, file, line);
            }
        }
        c
    }

    pub fn modules(&self) -> &BTreeSet<ModPath> {
        &self.modules
    }

    /// Every reference from one module to another, resolved.
    pub fn references(&self) -> Vec<Reference> {
        self.written
            .iter()
            .filter_map(|w| {
                let to = self.resolve(&self.absolute(w, 0)?, 0);
                (to != w.module).then(|| Reference {
                    from: w.module.clone(),
                    to,
                    file: w.file.clone(),
                    line: w.line,
                    written: w.segments.join("::"),
                })
            })
            .collect()
    }

    /// Records a path; a `use` path (its segments end in the name it binds, after `#as`) also binds a name.
    fn note(&mut self, module: ModPath, mut segments: Vec<String>, file: &Path, line: usize) {
        let alias = match segments.iter().position(|s| s == "#as") {
            Some(k) => {
                let alias = segments.get(k + 1).cloned();
                segments.truncate(k);
                alias
            }
            None => None,
        };
        let is_use = segments.first().is_some_and(|s| s == "#use");
        if is_use {
            segments.remove(0);
        }
        if segments.last().is_some_and(|s| s == "self") {
            segments.pop();
        }
        if segments.is_empty() {
            return;
        }
        let w = Written {
            module: module.clone(),
            segments,
            file: file.to_path_buf(),
            line,
        };
        let name = alias.or_else(|| w.segments.last().cloned());
        if let Some(name) = name.filter(|n| is_use && n != "*" && n != "_") {
            self.imports
                .entry(module)
                .or_default()
                .insert(name, w.clone());
        }
        self.written.push(w);
    }

    /// The path from the crate root: `None` for a path into another crate.
    fn absolute(&self, w: &Written, depth: usize) -> Option<Vec<String>> {
        let s = &w.segments;
        let mut base = w.module.clone();
        let rest = match s[0].as_str() {
            "crate" => {
                base.clear();
                &s[1..]
            }
            "self" => &s[1..],
            "super" => {
                let ups = s.iter().take_while(|x| *x == "super").count();
                base.truncate(base.len().checked_sub(ups)?);
                &s[ups..]
            }
            first if self.modules.contains(&child(&base, first)) => &s[..],
            first => {
                let import = self.imports.get(&w.module)?.get(first)?;
                if depth > 8 || import.segments.len() == 1 {
                    return None;
                }
                let mut path = self.absolute(import, depth + 1)?;
                path.extend_from_slice(&s[1..]);
                return Some(path);
            }
        };
        base.extend_from_slice(rest);
        Some(base)
    }

    /// The module that defines the item a path from the crate root names.
    fn resolve(&self, path: &[String], depth: usize) -> ModPath {
        let mut module = ModPath::new();
        for (k, segment) in path.iter().enumerate() {
            let next = child(&module, segment);
            if self.modules.contains(&next) {
                module = next;
                continue;
            }
            let import = self
                .imports
                .get(&module)
                .and_then(|names| names.get(segment));
            if let Some(import) = import.filter(|_| depth < 8)
                && let Some(mut target) = self.absolute(import, 0)
            {
                target.extend_from_slice(&path[k + 1..]);
                return self.resolve(&target, depth + 1);
            }
            break;
        }
        module
    }
}

fn child(module: &ModPath, name: &str) -> ModPath {
    let mut c = module.clone();
    c.push(name.to_string());
    c
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("src is readable") {
        let path = entry.expect("src is readable").path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// `src/lib.rs` → the root, `src/a/mod.rs` → `a`, `src/a/b.rs` → `a::b`; `None` for `src/main.rs`.
fn file_module(src: &Path, file: &Path) -> Option<ModPath> {
    let relative = file.strip_prefix(src).ok()?;
    let mut parts: Vec<String> = relative
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    let last = parts.pop()?;
    match last.as_str() {
        "lib.rs" | "mod.rs" => {}
        "main.rs" if parts.is_empty() => return None,
        _ => parts.push(last.trim_end_matches(".rs").to_string()),
    }
    Some(parts)
}

/// Walks a file's tokens: `module` hears each inline module (`mod name { … }`) and each module declared
/// under `#[cfg(test)]` (with `true`, its items not walked), `path` each path with the module it is
/// written in — a `use` tree expanded into one path per name, led by `#use` and ended by `#as alias` when
/// renamed; any other path of two or more segments as it stands.
fn walk(
    file_module: &ModPath,
    toks: &[(Tok, usize)],
    path: &mut dyn FnMut(&ModPath, Vec<String>, usize),
    module_found: &mut dyn FnMut(&ModPath, bool),
) {
    let ident = |k: usize| match toks.get(k) {
        Some((Tok::Ident(s), _)) => Some(s.as_str()),
        _ => None,
    };
    let is = |k: usize, t: &Tok| toks.get(k).is_some_and(|(x, _)| x == t);
    // The braces open, each with the inline module it opens.
    let mut braces: Vec<Option<String>> = Vec::new();
    let module = |braces: &[Option<String>]| {
        let mut m = file_module.clone();
        m.extend(braces.iter().flatten().cloned());
        m
    };
    let mut k = 0;
    while k < toks.len() {
        let (tok, line) = &toks[k];
        match tok {
            Tok::Punct('#') if is_cfg_test(toks, k) => {
                let item = k + CFG_TEST.len() + 1;
                if let Some(name) = declared_module(toks, item) {
                    module_found(&child(&module(&braces), name), true);
                }
                k = item_end(toks, item);
                continue;
            }
            Tok::Punct('{') => braces.push(None),
            Tok::Punct('}') => {
                braces.pop();
            }
            Tok::Ident(kw)
                if kw == "mod" && ident(k + 1).is_some() && is(k + 2, &Tok::Punct('{')) =>
            {
                braces.push(Some(ident(k + 1).expect("checked").to_string()));
                module_found(&module(&braces), false);
                k += 3;
                continue;
            }
            // `pub(in crate::vm)` names where an item is seen, not what it uses.
            Tok::Ident(kw) if kw == "pub" && is(k + 1, &Tok::Punct('(')) => {
                while k < toks.len() && !is(k, &Tok::Punct(')')) {
                    k += 1;
                }
            }
            Tok::Ident(kw) if kw == "use" => {
                let m = module(&braces);
                let (trees, end) = use_tree(toks, k + 1, vec!["#use".to_string()]);
                for segments in trees {
                    path(&m, segments, *line);
                }
                k = end;
                continue;
            }
            Tok::Ident(first)
                if first != "Self"
                    && is(k + 1, &Tok::PathSep)
                    && ident(k + 2).is_some()
                    && (k == 0 || !is(k - 1, &Tok::PathSep)) =>
            {
                let mut segments = vec![first.clone()];
                let mut j = k + 1;
                while is(j, &Tok::PathSep)
                    && let Some(next) = ident(j + 1)
                {
                    segments.push(next.to_string());
                    j += 2;
                }
                path(&module(&braces), segments, *line);
                k = j;
                continue;
            }
            _ => {}
        }
        k += 1;
    }
}

/// The paths of the use tree at `k` with `prefix` before them, and where the tree ends (past its `;` or
/// before the `,` or `}` that ends a nested tree).
fn use_tree(toks: &[(Tok, usize)], mut k: usize, prefix: Vec<String>) -> (Vec<Vec<String>>, usize) {
    let mut segments = prefix;
    let mut out = Vec::new();
    loop {
        match toks.get(k).map(|(t, _)| t) {
            Some(Tok::Ident(s)) if s == "as" => {
                if let Some((Tok::Ident(alias), _)) = toks.get(k + 1) {
                    segments.extend(["#as".to_string(), alias.clone()]);
                }
                k += 2;
            }
            Some(Tok::Ident(s)) => {
                segments.push(s.clone());
                k += 1;
            }
            Some(Tok::Punct('*')) => {
                segments.push("*".to_string());
                k += 1;
            }
            Some(Tok::PathSep) => k += 1,
            Some(Tok::Punct('{')) => {
                k += 1;
                loop {
                    let (trees, end) = use_tree(toks, k, segments.clone());
                    out.extend(trees);
                    k = end;
                    match toks.get(k).map(|(t, _)| t) {
                        Some(Tok::Punct(',')) => k += 1,
                        Some(Tok::Punct('}')) => {
                            k += 1;
                            break;
                        }
                        _ => break,
                    }
                    if toks.get(k).is_some_and(|(t, _)| *t == Tok::Punct('}')) {
                        k += 1;
                        break;
                    }
                }
                return (out, skip_semicolon(toks, k));
            }
            _ => {
                out.push(segments);
                return (out, skip_semicolon(toks, k));
            }
        }
    }
}

/// The tokens of `#[cfg(test)]` after the `#`.
const CFG_TEST: [&str; 6] = ["[", "cfg", "(", "test", ")", "]"];

fn is_cfg_test(toks: &[(Tok, usize)], k: usize) -> bool {
    CFG_TEST.iter().enumerate().all(|(j, want)| {
        toks.get(k + 1 + j).is_some_and(|(t, _)| match t {
            Tok::Ident(s) => s == want,
            Tok::Punct(c) => want.len() == 1 && want.starts_with(*c),
            Tok::PathSep => false,
        })
    })
}

/// The name of the module the item at `k` declares, with or without a body (`pub mod name;`).
fn declared_module(toks: &[(Tok, usize)], mut k: usize) -> Option<&str> {
    while let Some((Tok::Ident(word), _)) = toks.get(k) {
        match word.as_str() {
            "mod" => match toks.get(k + 1) {
                Some((Tok::Ident(name), _)) => return Some(name),
                _ => return None,
            },
            "pub" => k += 1,
            _ => return None,
        }
        // `pub(crate)`.
        if toks.get(k).is_some_and(|(t, _)| *t == Tok::Punct('(')) {
            k += 3;
        }
    }
    None
}

/// Past the item at `k`: its `;`, or the brace that closes its first `{`, whichever comes first.
fn item_end(toks: &[(Tok, usize)], mut k: usize) -> usize {
    let mut depth = 0;
    while let Some((t, _)) = toks.get(k) {
        k += 1;
        match t {
            Tok::Punct(';') if depth == 0 => return k,
            Tok::Punct('{') => depth += 1,
            Tok::Punct('}') => {
                depth -= 1;
                if depth == 0 {
                    return k;
                }
            }
            _ => {}
        }
    }
    k
}

fn skip_semicolon(toks: &[(Tok, usize)], k: usize) -> usize {
    k + usize::from(toks.get(k).is_some_and(|(t, _)| *t == Tok::Punct(';')))
}
