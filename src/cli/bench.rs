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

use super::{Format, Global};

mod cam_program;
mod process;
mod transform;

#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  driftloop bench --size-mb 10 --runs 1")]
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
    #[arg(long, value_name = "FILE")]
    save: Option<PathBuf>,
    /// Also time `transform` of the same program (the transform tests' model, the default profile) in the
    /// same alternation, and report it against parse + print (the transform's target is 1.5x).
    #[arg(long)]
    transform: bool,
    /// `human`: text; `json`: the figures as JSON.
    #[arg(long, value_enum, default_value_t = Format::Human)]
    format: Format,
}

#[derive(Debug, Serialize)]
struct Report {
    file_bytes: usize,
    lines: usize,
    runs: u32,
    /// driftloop parses large programs in parallel on the rayon pool; gcode uses one thread.
    driftloop_threads: usize,
    driftloop: DriftloopNumbers,
    /// Absent when built without the `bench-gcode` feature.
    gcode: Option<GcodeNumbers>,
    /// driftloop parse + print throughput over gcode parse throughput, by wall clock.
    ratio_parse_print_vs_gcode: Option<f64>,
    /// The same per CPU-second: how much less work per byte, whatever the number of cores.
    ratio_parse_print_vs_gcode_per_cpu_s: Option<f64>,
    /// With `--transform`.
    transform: Option<transform::TransformNumbers>,
}

#[derive(Debug, Serialize)]
struct DriftloopNumbers {
    parse_mb_per_s: f64,
    print_mb_per_s: f64,
    parse_print_mb_per_s: f64,
    parse_print_mb_per_cpu_s: Option<f64>,
    /// Peak resident memory of the whole process while parsing and printing (source buffer included).
    peak_rss_bytes: Option<u64>,
    peak_rss_per_file_byte: Option<f64>,
    round_trip_identical: bool,
    diagnostics: usize,
}

#[derive(Debug, Serialize)]
struct GcodeNumbers {
    parse_mb_per_s: f64,
    parse_mb_per_cpu_s: Option<f64>,
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
    let setup = args.transform.then(transform::Setup::new).transpose()?;
    let measured = measure_interleaved(source, args.runs, setup.as_ref())?;
    let (driftloop, gcode, file_bytes) = (measured.driftloop, measured.gcode, measured.file_bytes);
    let report = Report {
        file_bytes,
        lines,
        runs: args.runs,
        driftloop_threads: rayon::current_num_threads(),
        ratio_parse_print_vs_gcode: gcode
            .as_ref()
            .map(|g| driftloop.parse_print_mb_per_s / g.parse_mb_per_s),
        ratio_parse_print_vs_gcode_per_cpu_s: gcode
            .as_ref()
            .and_then(|g| Some(driftloop.parse_print_mb_per_cpu_s? / g.parse_mb_per_cpu_s?)),
        driftloop,
        gcode,
        transform: measured.transform,
    };
    let mut out = super::output::stdout();
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

struct Measured {
    driftloop: DriftloopNumbers,
    gcode: Option<GcodeNumbers>,
    transform: Option<transform::TransformNumbers>,
    file_bytes: usize,
}

/// Runs the two parsers (and the transform, when asked) alternately, so a change in machine load (a shared
/// 2-core box) hits all alike and the ratios stay meaningful. Peak memory is reset before each run, so each
/// peak is that run's own.
fn measure_interleaved(
    mut source: Vec<u8>,
    runs: u32,
    setup: Option<&transform::Setup>,
) -> anyhow::Result<Measured> {
    let len = source.len();
    let expected = Fingerprint::of(&source);
    let mut sink = CopySink::default();
    let mut driftloop_runs = Vec::new();
    let mut gcode_runs = Vec::new();
    let mut transform_runs = Vec::new();
    // Between timed runs only, so the line costs no measured time.
    let progress = super::progress::Progress::new("timed runs", runs as usize);
    for _ in 0..runs {
        let (run, returned) = driftloop_run(source, &expected, &mut sink);
        source = returned;
        driftloop_runs.push(run);
        gcode_runs.extend(gcode_run(&source));
        if let Some(setup) = setup {
            let (run, returned) = transform::transform_run(source, setup, &mut sink)?;
            source = returned;
            transform_runs.push(run);
        }
        progress.tick();
    }
    progress.finish();

    let mut parse: Vec<Duration> = driftloop_runs.iter().map(|r| r.parse).collect();
    let mut print: Vec<Duration> = driftloop_runs.iter().map(|r| r.print).collect();
    let mut both: Vec<Duration> = driftloop_runs.iter().map(|r| r.parse + r.print).collect();
    let mut both_cpu: Option<Vec<Duration>> = driftloop_runs.iter().map(|r| r.cpu).collect();
    let transform = setup
        .map(|_| transform::TransformNumbers::new(&transform_runs, both.clone(), both_cpu.clone()));
    let peak = driftloop_runs.iter().filter_map(|r| r.peak).max();
    let driftloop = DriftloopNumbers {
        parse_mb_per_s: mb_per_s(len, median(&mut parse)),
        print_mb_per_s: mb_per_s(len, median(&mut print)),
        parse_print_mb_per_s: mb_per_s(len, median(&mut both)),
        parse_print_mb_per_cpu_s: both_cpu.as_deref_mut().map(|t| mb_per_s(len, median(t))),
        peak_rss_bytes: peak,
        peak_rss_per_file_byte: peak.map(|p| p as f64 / len as f64),
        round_trip_identical: driftloop_runs.iter().all(|r| r.identical),
        diagnostics: driftloop_runs.last().map_or(0, |r| r.diagnostics),
    };
    let gcode = (!gcode_runs.is_empty()).then(|| {
        let mut times: Vec<Duration> = gcode_runs.iter().map(|r| r.parse).collect();
        let mut cpu: Option<Vec<Duration>> = gcode_runs.iter().map(|r| r.cpu).collect();
        let peak = gcode_runs.iter().filter_map(|r| r.peak).max();
        GcodeNumbers {
            parse_mb_per_s: mb_per_s(len, median(&mut times)),
            parse_mb_per_cpu_s: cpu.as_deref_mut().map(|t| mb_per_s(len, median(t))),
            peak_rss_bytes: peak,
            peak_rss_per_file_byte: peak.map(|p| p as f64 / len as f64),
            blocks: gcode_runs.last().map_or(0, |r| r.blocks),
        }
    });
    Ok(Measured {
        driftloop,
        gcode,
        transform,
        file_bytes: len,
    })
}

struct DriftloopRun {
    parse: Duration,
    print: Duration,
    /// CPU time of parse + print over all threads.
    cpu: Option<Duration>,
    peak: Option<u64>,
    identical: bool,
    diagnostics: usize,
}

/// Parses the one buffer in place (`parse_owned`), so the peak is what a real caller pays: the source plus
/// the tree. The buffer is handed back for the next run, outside the measured window.
fn driftloop_run(
    source: Vec<u8>,
    expected: &Fingerprint,
    sink: &mut CopySink,
) -> (DriftloopRun, Vec<u8>) {
    let peak_reset = process::reset_peak();
    let cpu_before = process::cpu_time();
    let started = Instant::now();
    let program = crate::parse_owned(source);
    let parse = started.elapsed();
    let started = Instant::now();
    let printed = program.write_to(sink);
    let print = started.elapsed();
    let cpu = cpu_used_since(cpu_before);
    let peak = process::peak_rss().filter(|_| peak_reset);
    // Checked against the input's fingerprint, untimed: no second copy of the program in memory.
    let mut written = Fingerprint::default();
    let identical =
        printed.is_ok() && program.write_to(&mut written).is_ok() && written == *expected;
    let run = DriftloopRun {
        parse,
        print,
        cpu,
        peak,
        identical,
        diagnostics: program.diagnostics().len(),
    };
    (run, program.source().to_vec())
}

struct GcodeRun {
    parse: Duration,
    cpu: Option<Duration>,
    peak: Option<u64>,
    blocks: usize,
}

#[cfg(feature = "bench-gcode")]
fn gcode_run(source: &[u8]) -> Option<GcodeRun> {
    // The generated program is ASCII; the UTF-8 check gcode's `&str` API needs is not part of its timing.
    let text = std::str::from_utf8(source).expect("generated program is ASCII");
    let peak_reset = process::reset_peak();
    let cpu_before = process::cpu_time();
    let started = Instant::now();
    let program = gcode::parse(text);
    let parse = started.elapsed();
    let cpu = cpu_used_since(cpu_before);
    let peak = process::peak_rss().filter(|_| peak_reset);
    Some(GcodeRun {
        parse,
        cpu,
        peak,
        blocks: program.map_or(0, |p| p.blocks.len()),
    })
}

#[cfg(not(feature = "bench-gcode"))]
fn gcode_run(_source: &[u8]) -> Option<GcodeRun> {
    None
}

fn write_human(out: &mut impl Write, r: &Report) -> io::Result<()> {
    write_parsers(out, r)?;
    match &r.transform {
        Some(t) => t.write_human(out),
        None => Ok(()),
    }
}

fn write_parsers(out: &mut impl Write, r: &Report) -> io::Result<()> {
    let mb = r.file_bytes as f64 / 1e6;
    let per_file = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:.2}x file size"));
    let bytes =
        |v: Option<u64>| v.map_or("n/a".to_string(), |v| format!("{:.1} MB", v as f64 / 1e6));
    let speed = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:.1} MB/s"));
    let times = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:.1}x"));
    writeln!(
        out,
        "program: {mb:.1} MB, {} lines; median of {} alternating runs; driftloop on {} threads, gcode on 1",
        r.lines, r.runs, r.driftloop_threads
    )?;
    let d = &r.driftloop;
    writeln!(
        out,
        "driftloop  parse {:.1} MB/s, print {:.1} MB/s, parse+print {:.1} MB/s ({} per CPU-second)",
        d.parse_mb_per_s,
        d.print_mb_per_s,
        d.parse_print_mb_per_s,
        speed(d.parse_print_mb_per_cpu_s)
    )?;
    writeln!(
        out,
        "           peak RSS {} ({}), round trip {}, {} diagnostics",
        bytes(d.peak_rss_bytes),
        per_file(d.peak_rss_per_file_byte),
        if d.round_trip_identical {
            "byte-identical"
        } else {
            "DIFFERS"
        },
        d.diagnostics
    )?;
    match &r.gcode {
        Some(g) => {
            writeln!(
                out,
                "gcode      parse {:.1} MB/s ({} per CPU-second), peak RSS {} ({}), {} blocks",
                g.parse_mb_per_s,
                speed(g.parse_mb_per_cpu_s),
                bytes(g.peak_rss_bytes),
                per_file(g.peak_rss_per_file_byte),
                g.blocks
            )?;
            writeln!(
                out,
                "ratio      driftloop parse+print / gcode parse: {} by wall clock, {} per CPU-second",
                times(r.ratio_parse_print_vs_gcode),
                times(r.ratio_parse_print_vs_gcode_per_cpu_s)
            )
        }
        None => writeln!(
            out,
            "gcode      not built in; run `cargo run --release --features bench-gcode -- bench`"
        ),
    }
}

fn cpu_used_since(before: Option<Duration>) -> Option<Duration> {
    Some(process::cpu_time()?.saturating_sub(before?))
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
