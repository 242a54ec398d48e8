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

/// One program to read: a file or standard input (`-`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Input {
    Stdin,
    File(PathBuf),
}

impl Input {
    /// Reads the whole program as raw bytes; the error names the path.
    pub fn read(&self) -> Result<Vec<u8>, WalkError> {
        match self {
            Input::Stdin => {
                let mut bytes = Vec::new();
                io::stdin()
                    .lock()
                    .read_to_end(&mut bytes)
                    .map_err(|source| WalkError::new(Path::new("-"), "cannot read", source))?;
                Ok(bytes)
            }
            Input::File(path) => {
                fs::read(path).map_err(|source| WalkError::new(path, "cannot read", source))
            }
        }
    }
}

impl fmt::Display for Input {
    /// The name used in diagnostics and JSON output: the path as given, `-` for stdin.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Input::Stdin => f.write_str("-"),
            Input::File(path) => write!(f, "{}", path.display()),
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
/// Fails on the first path that does not exist or cannot be listed.
pub fn expand<P: AsRef<Path>>(paths: &[P]) -> Result<Vec<Input>, WalkError> {
    let mut inputs = Vec::new();
    for path in paths {
        let path = path.as_ref();
        if path == Path::new("-") {
            inputs.push(Input::Stdin);
            continue;
        }
        let meta =
            fs::metadata(path).map_err(|source| WalkError::new(path, "cannot open", source))?;
        if meta.is_dir() {
            walk_dir(path, &mut inputs)?;
        } else {
            inputs.push(Input::File(path.to_path_buf()));
        }
    }
    Ok(inputs)
}

fn walk_dir(dir: &Path, out: &mut Vec<Input>) -> Result<(), WalkError> {
    let listing_error = |source| WalkError::new(dir, "cannot list directory", source);
    let mut entries = fs::read_dir(dir)
        .map_err(listing_error)?
        .map(|entry| entry.map(|e| e.path()))
        .collect::<Result<Vec<_>, _>>()
        .map_err(listing_error)?;
    entries.sort();
    for path in entries {
        // Symlinked directories are not followed (no cycles); symlinked files are read like files.
        let link_meta = fs::symlink_metadata(&path)
            .map_err(|source| WalkError::new(&path, "cannot open", source))?;
        if link_meta.is_dir() {
            walk_dir(&path, out)?;
        } else if is_program_file(&path) && fs::metadata(&path).is_ok_and(|m| m.is_file()) {
            out.push(Input::File(path));
        }
    }
    Ok(())
}

/// The `.SPF` / `.MPF` files of a folder (`_N_NAME_SPF` too) by upper-cased program name, as a call names
/// them (`NAME`, `L123`); of two that differ only in case or form, the
/// first in byte order.
pub fn programs_by_name(dir: &Path) -> HashMap<String, PathBuf> {
    let mut out = HashMap::new();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return out;
    };
    let mut paths: Vec<PathBuf> = entries.flatten().map(|e| e.path()).collect();
    paths.sort();
    for path in paths {
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
        let got = expand(&[root]).unwrap();
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
        let got = expand(&[root.join("real")]).unwrap();
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
        let got = expand(&[txt.as_path(), Path::new("-")]).unwrap();
        assert_eq!(got, vec![Input::File(txt), Input::Stdin]);
        assert_eq!(Input::Stdin.to_string(), "-");
    }

    #[test]
    fn missing_path_is_an_error_naming_it() {
        let tmp = tempfile::tempdir().unwrap();
        let missing = tmp.path().join("nope.mpf");
        let err = expand(&[&missing]).unwrap_err();
        assert_eq!(err.path, missing);
        assert!(err.to_string().contains("nope.mpf"), "{err}");
    }
}
