//! Turns the `PATH…` arguments of a command into the list of programs it works on.
//!
//! A path named explicitly is taken as it is, whatever its extension: the user asked for it. Directories are
//! walked recursively and contribute only files with an NC program extension (`.mpf .spf .arc .nc .def`, any
//! case). The result is sorted per directory so runs are reproducible, and it is a plain list so callers can
//! process it in parallel (`rayon`) and still report in this order.

use std::collections::HashMap;
use std::fmt;
use std::fs;
use std::io::{self, Read};
use std::path::{Path, PathBuf};

/// Extensions (compared case-insensitively) of the files a directory walk picks up.
pub const PROGRAM_EXTENSIONS: [&str; 5] = ["mpf", "spf", "arc", "nc", "def"];

/// One program to read: a file or standard input (`-`), or a path the walk found but cannot read (a missing
/// argument, a dangling link, a directory it could not list, a device), kept in its place so the other
/// programs are still worked on and this one is reported with them.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Input {
    Stdin,
    File(PathBuf),
    Unreadable { path: PathBuf, why: String },
}

impl Input {
    /// Reads the whole program as raw bytes; the error names the path. An empty standard input is an
    /// error: a closed stdin (`<&-`) reads as empty, and no program is no program to work on.
    pub fn read(&self) -> Result<Vec<u8>, WalkError> {
        match self {
            Input::Stdin => {
                let mut bytes = Vec::new();
                io::stdin()
                    .lock()
                    .read_to_end(&mut bytes)
                    .map_err(|source| WalkError::new(Path::new("-"), "cannot read", source))?;
                if bytes.is_empty() {
                    return Err(WalkError::new(
                        Path::new("-"),
                        "cannot read",
                        io::Error::new(
                            io::ErrorKind::UnexpectedEof,
                            "standard input is empty or closed: no program",
                        ),
                    ));
                }
                Ok(bytes)
            }
            Input::File(path) => {
                fs::read(path).map_err(|source| WalkError::new(path, "cannot read", source))
            }
            Input::Unreadable { path, why } => Err(WalkError::new(
                path,
                "cannot read",
                io::Error::other(why.clone()),
            )),
        }
    }
}

impl fmt::Display for Input {
    /// The name used in diagnostics and JSON output: the path as given, `-` for stdin.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Input::Stdin => f.write_str("-"),
            Input::File(path) | Input::Unreadable { path, .. } => write!(f, "{}", path.display()),
        }
    }
}

/// An I/O failure tied to the path it happened on. The message already carries the cause, so it is not
/// chained again as a `source` (that would print it twice).
#[derive(Debug, thiserror::Error)]
#[error("{action} {}: {cause}", path.display())]
pub struct WalkError {
    pub path: PathBuf,
    action: &'static str,
    pub cause: io::Error,
}

impl WalkError {
    fn new(path: &Path, action: &'static str, cause: io::Error) -> Self {
        WalkError {
            path: path.to_path_buf(),
            action,
            cause,
        }
    }
}

/// Whether a directory walk should pick up this file.
pub fn is_program_file(path: &Path) -> bool {
    path.extension()
        .and_then(|ext| ext.to_str())
        .is_some_and(|ext| {
            PROGRAM_EXTENSIONS
                .iter()
                .any(|known| ext.eq_ignore_ascii_case(known))
        })
}

/// Expands command-line paths in the order given; each directory expands to its programs in sorted order.
/// A path that does not exist, a directory that cannot be listed and a program entry that cannot be read
/// (a dangling link, a device) become [`Input::Unreadable`] in their place: reported, never skipped.
pub fn expand<P: AsRef<Path>>(paths: &[P]) -> Vec<Input> {
    let mut inputs = Vec::new();
    for path in paths {
        let path = path.as_ref();
        if path == Path::new("-") {
            inputs.push(Input::Stdin);
            continue;
        }
        match fs::metadata(path) {
            Ok(meta) if meta.is_dir() => walk_dir(path, &mut inputs),
            Ok(_) => inputs.push(Input::File(path.to_path_buf())),
            Err(e) => inputs.push(unreadable(path, &e.to_string())),
        }
    }
    inputs
}

fn unreadable(path: &Path, why: &str) -> Input {
    Input::Unreadable {
        path: path.to_path_buf(),
        why: why.to_string(),
    }
}

/// Symlinked directories are not followed (no cycles); symlinked files are read like files.
fn walk_dir(dir: &Path, out: &mut Vec<Input>) {
    let walk = walkdir::WalkDir::new(dir)
        .min_depth(1)
        .follow_links(false)
        .sort_by_file_name();
    for entry in walk {
        let entry = match entry {
            Ok(entry) => entry,
            Err(e) => {
                let path = e.path().unwrap_or(dir);
                let why = e
                    .io_error()
                    .map_or_else(|| e.to_string(), io::Error::to_string);
                out.push(unreadable(
                    path,
                    &format!("cannot list the directory: {why}"),
                ));
                continue;
            }
        };
        let path = entry.path();
        if entry.file_type().is_dir() || !is_program_file(path) {
            continue;
        }
        match fs::metadata(path) {
            Ok(meta) if meta.is_file() => out.push(Input::File(path.to_path_buf())),
            // A link to a directory named like a program is a directory, not followed.
            Ok(meta) if meta.is_dir() => {}
            Ok(_) => out.push(unreadable(path, "not a regular file (a device or a pipe)")),
            Err(e) if entry.path_is_symlink() => out.push(unreadable(
                path,
                &format!(
                    "dangling symbolic link to {} ({e})",
                    fs::read_link(path).map_or_else(|_| "?".into(), |t| t.display().to_string())
                ),
            )),
            Err(e) => out.push(unreadable(path, &e.to_string())),
        }
    }
}

/// The program a path names, as a call names it (`/_N_WKS_DIR/_N_SHAFT_WPD/_N_PART1_SPF` → `PART1`,
/// `PART1.SPF` → `PART1`): `EXTCALL` and `PCALL` name programs by their path.
pub fn program_name(path: &str) -> String {
    let last = path
        .rsplit(['/', '\\'])
        .next()
        .unwrap_or(path)
        .to_ascii_uppercase();
    let last = last.strip_prefix("_N_").unwrap_or(&last);
    [".SPF", ".MPF", "_SPF", "_MPF"]
        .iter()
        .find_map(|ext| last.strip_suffix(ext))
        .unwrap_or(last)
        .to_string()
}

/// The `.SPF` / `.MPF` files of a folder (`_N_NAME_SPF` too) by upper-cased program name, as a call names
/// them (`NAME`, `L123`); of two that differ only in case or form, the
/// first in byte order.
pub fn programs_by_name(dir: &Path) -> HashMap<String, PathBuf> {
    let mut out = HashMap::new();
    for path in sorted_entries(dir) {
        let Some(name) = path.file_name() else {
            continue;
        };
        let file = name.to_string_lossy().to_ascii_uppercase();
        let stem = file
            .strip_suffix(".SPF")
            .or_else(|| file.strip_suffix(".MPF"))
            .or_else(|| {
                file.strip_prefix("_N_")
                    .and_then(|f| f.strip_suffix("_SPF").or_else(|| f.strip_suffix("_MPF")))
            });
        if let Some(stem) = stem {
            out.entry(stem.to_string()).or_insert(path);
        }
    }
    out
}

/// The definition files of a folder (`NAME.DEF` in any case, `_N_NAME_DEF`: the GUD and macro files of
/// the control's `_N_DEF_DIR`), in byte order.
pub fn definition_files(dir: &Path) -> Vec<PathBuf> {
    sorted_entries(dir)
        .into_iter()
        .filter(|path| {
            path.file_name().is_some_and(|name| {
                let file = name.to_string_lossy().to_ascii_uppercase();
                file.ends_with(".DEF") || (file.starts_with("_N_") && file.ends_with("_DEF"))
            })
        })
        .collect()
}

/// The paths in a folder, in byte order (none when it cannot be read).
fn sorted_entries(dir: &Path) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut paths: Vec<PathBuf> = entries.flatten().map(|e| e.path()).collect();
    paths.sort();
    paths
}

#[cfg(test)]
mod tests {
    use super::*;

    fn touch(path: &Path) {
        fs::create_dir_all(path.parent().unwrap()).unwrap();
        fs::write(path, b"G0 X0\n").unwrap();
    }

    #[test]
    fn extensions_match_any_case_and_nothing_else() {
        for name in ["a.mpf", "b.SPF", "c.Arc", "d.nc", "e.DEF"] {
            assert!(is_program_file(Path::new(name)), "{name}");
        }
        for name in ["a.csv", "mpf", "a.mpf.bak", "a.ncx", "README"] {
            assert!(!is_program_file(Path::new(name)), "{name}");
        }
    }

    #[test]
    fn directories_expand_recursively_sorted_and_filtered() {
        let tmp = tempfile::tempdir().unwrap();
        let root = tmp.path();
        for rel in [
            "b.MPF",
            "a.spf",
            "sub/z.nc",
            "sub/deeper/y.def",
            "notes.txt",
            "sub/x.csv",
        ] {
            touch(&root.join(rel));
        }
        let got = expand(&[root]);
        let want: Vec<Input> = ["a.spf", "b.MPF", "sub/deeper/y.def", "sub/z.nc"]
            .iter()
            .map(|rel| Input::File(root.join(rel)))
            .collect();
        assert_eq!(got, want);
    }

    #[cfg(unix)]
    #[test]
    fn symlinked_files_are_read_but_symlinked_directories_not_followed() {
        let tmp = tempfile::tempdir().unwrap();
        let root = tmp.path();
        touch(&root.join("real/a.mpf"));
        std::os::unix::fs::symlink(root.join("real/a.mpf"), root.join("real/link.mpf")).unwrap();
        // A link back to its own parent would make a naive walk run forever.
        std::os::unix::fs::symlink(root.join("real"), root.join("real/loop")).unwrap();
        let got = expand(&[root.join("real")]);
        assert_eq!(
            got,
            vec![
                Input::File(root.join("real/a.mpf")),
                Input::File(root.join("real/link.mpf"))
            ]
        );
    }

    #[test]
    fn explicit_files_and_stdin_are_kept_in_argument_order() {
        let tmp = tempfile::tempdir().unwrap();
        let txt = tmp.path().join("program.txt");
        touch(&txt);
        let got = expand(&[txt.as_path(), Path::new("-")]);
        assert_eq!(got, vec![Input::File(txt), Input::Stdin]);
        assert_eq!(Input::Stdin.to_string(), "-");
    }

    #[test]
    fn missing_paths_and_dangling_links_are_kept_as_unreadable_in_their_place() {
        let tmp = tempfile::tempdir().unwrap();
        let root = tmp.path();
        let missing = root.join("nope.mpf");
        touch(&root.join("dir/a.mpf"));
        #[cfg(unix)]
        std::os::unix::fs::symlink(root.join("gone.mpf"), root.join("dir/b.mpf")).unwrap();
        let got = expand(&[missing.as_path(), &root.join("dir")]);
        assert!(matches!(&got[0], Input::Unreadable { path, .. } if *path == missing));
        let err = got[0].read().unwrap_err();
        assert!(err.to_string().contains("nope.mpf"), "{err}");
        assert_eq!(got[1], Input::File(root.join("dir/a.mpf")));
        #[cfg(unix)]
        {
            let err = got[2].read().unwrap_err().to_string();
            assert!(err.contains("b.mpf") && err.contains("dangling"), "{err}");
        }
    }
}
