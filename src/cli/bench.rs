//! `driftloop bench`: parse + print throughput and peak memory on a generated CAM program, side by side with
//! the `gcode` crate on the same bytes. A subcommand rather than a criterion bench because peak memory has to
//! be read from the process itself, phase by phase; `cargo test` never runs it.
//!
//! The `gcode` comparison is compiled in with `--features bench-gcode` so the default build carries no
//! benchmark-only dependency.

use std::io::{self, Write};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::Context;
use serde::Serialize;

use super::Global;
use super::check::Format;

mod cam_program;
mod memory;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Size of the generated program in megabytes (10^6 bytes).
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u64).range(1..))]
    size_mb: u64,
    /// Seed of the program generator; the same seed gives the same bytes.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Timed runs per parser; the median run is reported.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..))]
    runs: u32,
    /// Also write the generated program to this file, to feed other tools the same bytes.
    #[arg(long)]
    save: Option<PathBuf>,
    #[arg(long, value_enum, default_value_t = Format::Human)]
    format: Format,
}

#[derive(Debug, Serialize)]
struct Report {
    file_bytes: usize,
    lines: usize,
    runs: u32,
    driftloop: DriftloopNumbers,
    /// Absent when built without the `bench-gcode` feature.
    gcode: Option<GcodeNumbers>,
    /// driftloop parse + print throughput over gcode parse throughput.
    ratio_parse_print_vs_gcode: Option<f64>,
}

#[derive(Debug, Serialize)]
struct DriftloopNumbers {
    parse_mb_per_s: f64,
    print_mb_per_s: f64,
    parse_print_mb_per_s: f64,
    /// Peak resident memory of the whole process while parsing and printing (source buffer included).
    peak_rss_bytes: Option<u64>,
    peak_rss_per_file_byte: Option<f64>,
    round_trip_identical: bool,
    diagnostics: usize,
}

#[derive(Debug, Serialize)]
struct GcodeNumbers {
    parse_mb_per_s: f64,
    peak_rss_bytes: Option<u64>,
    peak_rss_per_file_byte: Option<f64>,
    blocks: usize,
}

pub fn run(args: Args, _global: &Global) -> anyhow::Result<ExitCode> {
    let target = usize::try_from(args.size_mb * 1_000_000).context("--size-mb is too large")?;
    let source = cam_program::generate(target, args.seed);
    if let Some(path) = &args.save {
        std::fs::write(path, &source)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    let lines = source.iter().filter(|&&b| b == b'\n').count();
    let (driftloop, source) = measure_driftloop(source, args.runs);
    let gcode = measure_gcode(&source, args.runs);
    let report = Report {
        file_bytes: source.len(),
        lines,
        runs: args.runs,
        ratio_parse_print_vs_gcode: gcode
            .as_ref()
            .map(|g| driftloop.parse_print_mb_per_s / g.parse_mb_per_s),
        driftloop,
        gcode,
    };
    let mut out = io::stdout().lock();
    match args.format {
        Format::Human => write_human(&mut out, &report)?,
        Format::Json => {
            serde_json::to_writer_pretty(&mut out, &report)?;
            writeln!(out)?;
        }
    }
    Ok(if report.driftloop.round_trip_identical {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// Each run parses the one buffer in place (`parse_owned`), so the measured peak is what a real caller pays:
/// the source plus the tree. The buffer is taken back out between runs, outside the measured window.
fn measure_driftloop(mut source: Vec<u8>, runs: u32) -> (DriftloopNumbers, Vec<u8>) {
    let len = source.len();
    let mut parse_times = Vec::new();
    let mut print_times = Vec::new();
    let mut peak: Option<u64> = None;
    let mut round_trip_identical = true;
    let mut diagnostics = 0;
    let expected = Fingerprint::of(&source);
    let mut sink = CopySink::default();
    for _ in 0..runs {
        let peak_reset = memory::reset_peak();
        let started = Instant::now();
        let program = crate::parse_owned(source);
        parse_times.push(started.elapsed());
        let started = Instant::now();
        let printed = program.write_to(&mut sink);
        print_times.push(started.elapsed());
        // Checked against the input's fingerprint, untimed: no second copy of the program in memory.
        let mut written = Fingerprint::default();
        round_trip_identical &=
            printed.is_ok() && program.write_to(&mut written).is_ok() && written == expected;
        if peak_reset {
            peak = peak.max(memory::peak_rss());
        }
        diagnostics = program.diagnostics().len();
        source = program.source().to_vec();
    }
    let (parse, print) = (median(&mut parse_times), median(&mut print_times));
    let numbers = DriftloopNumbers {
        parse_mb_per_s: mb_per_s(len, parse),
        print_mb_per_s: mb_per_s(len, print),
        parse_print_mb_per_s: mb_per_s(len, parse + print),
        peak_rss_bytes: peak,
        peak_rss_per_file_byte: peak.map(|p| p as f64 / len as f64),
        round_trip_identical,
        diagnostics,
    };
    (numbers, source)
}

#[cfg(feature = "bench-gcode")]
fn measure_gcode(source: &[u8], runs: u32) -> Option<GcodeNumbers> {
    // The generated program is ASCII; the UTF-8 check gcode's `&str` API needs is not part of its timing.
    let text = std::str::from_utf8(source).expect("generated program is ASCII");
    let mut times = Vec::new();
    let mut blocks = 0;
    let mut peak: Option<u64> = None;
    for _ in 0..runs {
        // Without a reset the peak would still hold driftloop's phase.
        let peak_reset = memory::reset_peak();
        let started = Instant::now();
        let program = gcode::parse(text);
        times.push(started.elapsed());
        if peak_reset {
            peak = peak.max(memory::peak_rss());
        }
        blocks = program.map_or(0, |p| p.blocks.len());
    }
    Some(GcodeNumbers {
        parse_mb_per_s: mb_per_s(source.len(), median(&mut times)),
        peak_rss_bytes: peak,
        peak_rss_per_file_byte: peak.map(|p| p as f64 / source.len() as f64),
        blocks,
    })
}

#[cfg(not(feature = "bench-gcode"))]
fn measure_gcode(_source: &[u8], _runs: u32) -> Option<GcodeNumbers> {
    None
}

fn write_human(out: &mut impl Write, r: &Report) -> io::Result<()> {
    let mb = r.file_bytes as f64 / 1e6;
    let ratio = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:.2}x file size"));
    let bytes =
        |v: Option<u64>| v.map_or("n/a".to_string(), |v| format!("{:.1} MB", v as f64 / 1e6));
    writeln!(
        out,
        "program: {mb:.1} MB, {} lines, median of {} runs",
        r.lines, r.runs
    )?;
    let d = &r.driftloop;
    writeln!(
        out,
        "driftloop  parse {:8.1} MB/s  print {:8.1} MB/s  parse+print {:8.1} MB/s  peak RSS {} ({})",
        d.parse_mb_per_s,
        d.print_mb_per_s,
        d.parse_print_mb_per_s,
        bytes(d.peak_rss_bytes),
        ratio(d.peak_rss_per_file_byte)
    )?;
    writeln!(
        out,
        "           round trip {}, {} diagnostics",
        if d.round_trip_identical {
            "byte-identical"
        } else {
            "DIFFERS"
        },
        d.diagnostics
    )?;
    match (&r.gcode, r.ratio_parse_print_vs_gcode) {
        (Some(g), Some(ratio_vs)) => {
            writeln!(
                out,
                "gcode      parse {:8.1} MB/s  peak RSS {} ({}), {} blocks",
                g.parse_mb_per_s,
                bytes(g.peak_rss_bytes),
                ratio(g.peak_rss_per_file_byte),
                g.blocks
            )?;
            writeln!(
                out,
                "ratio      driftloop parse+print / gcode parse = {ratio_vs:.1}x"
            )
        }
        _ => writeln!(
            out,
            "gcode      not built in; run `cargo run --release --features bench-gcode -- bench`"
        ),
    }
}

fn median(times: &mut [Duration]) -> Duration {
    times.sort();
    times[times.len() / 2]
}

fn mb_per_s(bytes: usize, time: Duration) -> f64 {
    bytes as f64 / 1e6 / time.as_secs_f64().max(1e-9)
}

/// Stands in for a buffered output file: every printed byte is copied once, into a reused 1 MiB buffer.
struct CopySink {
    buffer: Vec<u8>,
}

impl Default for CopySink {
    fn default() -> Self {
        CopySink {
            buffer: vec![0; 1 << 20],
        }
    }
}

impl Write for CopySink {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        for chunk in buf.chunks(self.buffer.len()) {
            self.buffer[..chunk.len()].copy_from_slice(chunk);
            std::hint::black_box(&self.buffer);
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

/// An order-sensitive checksum of a byte stream that does not depend on how the stream is split into
/// writes; enough to catch a printer that drops, adds, changes or reorders bytes.
#[derive(Debug, Default, PartialEq, Eq)]
struct Fingerprint {
    len: u64,
    sum: u64,
    weighted: u64,
}

impl Fingerprint {
    fn of(bytes: &[u8]) -> Self {
        let mut f = Fingerprint::default();
        f.add(bytes);
        f
    }

    fn add(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.len += 1;
            self.sum = self.sum.wrapping_add(u64::from(b));
            self.weighted = self
                .weighted
                .wrapping_add(u64::from(b).wrapping_mul(self.len));
        }
    }
}

impl Write for Fingerprint {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.add(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fingerprint_ignores_write_boundaries_but_not_content() {
        let whole = Fingerprint::of(b"N10 G1 X1\n");
        let mut split = Fingerprint::default();
        split.write_all(b"N10 G").unwrap();
        split.write_all(b"1 X1\n").unwrap();
        assert_eq!(split, whole);
        assert_ne!(Fingerprint::of(b"N10 G1 X1"), whole, "missing byte");
        assert_ne!(Fingerprint::of(b"N10 G1 X2\n"), whole, "changed byte");
        assert_ne!(Fingerprint::of(b"N01 G1 X1\n"), whole, "swapped bytes");
    }

    #[test]
    fn copy_sink_takes_writes_larger_than_its_buffer() {
        let mut sink = CopySink::default();
        let big = vec![7u8; (1 << 20) * 2 + 5];
        sink.write_all(&big).unwrap();
        assert_eq!(sink.buffer[..5], [7; 5]);
    }

    #[test]
    fn median_picks_the_middle_run() {
        let mut t = [3, 1, 2].map(Duration::from_millis);
        assert_eq!(median(&mut t), Duration::from_millis(2));
    }
}
