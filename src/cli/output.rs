//! Standard output of the commands. `print!` panics when stdout cannot be written (a full disk,
//! `/dev/full`); here a failed write is the command's error, named ("cannot write to standard output"), so
//! the command exits 2 like on any other I/O error.

use std::io::{self, Write};

/// Standard output whose write errors name it.
pub struct Stdout(io::StdoutLock<'static>);

/// The locked standard output.
pub fn stdout() -> Stdout {
    Stdout(io::stdout().lock())
}

/// Writes `text` to standard output.
pub fn print(text: &str) -> io::Result<()> {
    let mut out = stdout();
    out.write_all(text.as_bytes())?;
    out.flush()
}

/// A report a reader cuts short (`| head`) is no failure, and the main program forgives a broken pipe; a
/// program written to stdout is different: one that stops early is an error even on a closed pipe.
pub fn program_not_written(e: io::Error) -> io::Error {
    if e.kind() == io::ErrorKind::BrokenPipe {
        io::Error::other(format!(
            "the program was not written completely: standard output was closed ({e})"
        ))
    } else {
        e
    }
}

impl Write for Stdout {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.0.write(buf).map_err(named)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.0.flush().map_err(named)
    }
}

/// The error with "standard output" in its message; a broken pipe keeps its kind, which the main program
/// recognises.
pub fn named(e: io::Error) -> io::Error {
    if e.to_string().contains("standard output") {
        return e;
    }
    io::Error::new(e.kind(), format!("cannot write to standard output: {e}"))
}

/// Refuses to start when an output (`flag`, path) is one of the inputs, by any name (a link, `./x`): the
/// input would be destroyed before or while it is read. `-` (stdout) and outputs that do not exist yet
/// are no input.
pub fn refuse_overwriting(
    outputs: &[(&str, Option<&std::path::Path>)],
    inputs: &[&std::path::Path],
) -> anyhow::Result<()> {
    let known: std::collections::HashMap<FileId, &std::path::Path> = inputs
        .iter()
        .filter_map(|p| Some((file_id(p)?, *p)))
        .collect();
    for (flag, output) in outputs {
        let Some(output) = output.filter(|o| o.as_os_str() != "-") else {
            continue;
        };
        if let Some(input) = file_id(output).and_then(|id| known.get(&id)) {
            anyhow::bail!(
                "{flag} {} is the input {}: writing it would destroy what is read; choose another file",
                output.display(),
                input.display(),
            );
        }
    }
    Ok(())
}

/// What makes two paths one file: device and inode where there are such, else the canonical path.
#[cfg(unix)]
type FileId = (u64, u64);
#[cfg(not(unix))]
type FileId = std::path::PathBuf;

#[cfg(unix)]
fn file_id(path: &std::path::Path) -> Option<FileId> {
    use std::os::unix::fs::MetadataExt;
    let meta = std::fs::metadata(path).ok()?;
    Some((meta.dev(), meta.ino()))
}

#[cfg(not(unix))]
fn file_id(path: &std::path::Path) -> Option<FileId> {
    std::fs::canonicalize(path).ok()
}
