//! `bench --transform`: what `driftloop transform` does to the same program (parse with the moves timed,
//! plan, gates, the output streamed), timed in the same alternation as parse + print, so the ratio the
//! transform's speed target names is measured under one load.

use std::io::Write;
use std::time::{Duration, Instant};

use serde::Serialize;

use super::{cpu_used_since, median, process};
use crate::model::DriftModel;
use crate::omm::{self, ModelRef, Profile};

/// The transform tests' two-mode model: the transform's work does not depend on the model's numbers.
const MODEL: &str = include_str!("../../../fixtures/omm/model.toml");

pub(super) struct Setup {
    model: DriftModel,
    profile: Profile,
}

impl Setup {
    pub(super) fn new() -> anyhow::Result<Setup> {
        Ok(Setup {
            model: DriftModel::from_toml(MODEL, "fixtures/omm/model.toml")?,
            profile: Profile::default_profile(),
        })
    }
}

pub(super) struct TransformRun {
    time: Duration,
    cpu: Option<Duration>,
    peak: Option<u64>,
    inserted: usize,
}

/// Transforms the buffer as the CLI does and streams the output to `sink`; the buffer is handed back for
/// the next run, outside the measured window.
pub(super) fn transform_run(
    source: Vec<u8>,
    setup: &Setup,
    sink: &mut impl Write,
) -> anyhow::Result<(TransformRun, Vec<u8>)> {
    let model = ModelRef {
        model: &setup.model,
        sha256: "bench",
    };
    let peak_reset = process::reset_peak();
    let cpu_before = process::cpu_time();
    let started = Instant::now();
    let (program, moves) = omm::parse_timed(source);
    let prepared = omm::prepare_timed(&program, &moves, &[model], &setup.profile, false)?;
    prepared.write_to(sink)?;
    let time = started.elapsed();
    let run = TransformRun {
        time,
        cpu: cpu_used_since(cpu_before),
        peak: process::peak_rss().filter(|_| peak_reset),
        inserted: prepared.summary.blocks_inserted,
    };
    drop(prepared);
    Ok((run, program.source().to_vec()))
}

#[derive(Debug, Serialize)]
pub(super) struct TransformNumbers {
    transform_ms: f64,
    transform_cpu_ms: Option<f64>,
    parse_print_ms: f64,
    parse_print_cpu_ms: Option<f64>,
    /// Median transform time over median parse + print time (the target is 1.5).
    ratio_to_parse_print: f64,
    ratio_to_parse_print_cpu: Option<f64>,
    peak_rss_bytes: Option<u64>,
    blocks_inserted: usize,
}

impl TransformNumbers {
    pub(super) fn new(
        runs: &[TransformRun],
        mut parse_print: Vec<Duration>,
        parse_print_cpu: Option<Vec<Duration>>,
    ) -> TransformNumbers {
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        let mut times: Vec<Duration> = runs.iter().map(|r| r.time).collect();
        let cpu: Option<Vec<Duration>> = runs.iter().map(|r| r.cpu).collect();
        let transform_ms = ms(median(&mut times));
        let parse_print_ms = ms(median(&mut parse_print));
        let transform_cpu_ms = cpu.map(|mut c| ms(median(&mut c)));
        let parse_print_cpu_ms = parse_print_cpu.map(|mut c| ms(median(&mut c)));
        TransformNumbers {
            transform_ms,
            transform_cpu_ms,
            parse_print_ms,
            parse_print_cpu_ms,
            ratio_to_parse_print: transform_ms / parse_print_ms,
            ratio_to_parse_print_cpu: transform_cpu_ms.zip(parse_print_cpu_ms).map(|(t, p)| t / p),
            peak_rss_bytes: runs.iter().filter_map(|r| r.peak).max(),
            blocks_inserted: runs.last().map_or(0, |r| r.inserted),
        }
    }

    pub(super) fn write_human(&self, out: &mut impl Write) -> std::io::Result<()> {
        let cpu = |t: Option<f64>, p: Option<f64>, r: Option<f64>| match (t, p, r) {
            (Some(t), Some(p), Some(r)) => format!("; CPU {t:.1} ms against {p:.1} ms: {r:.2}x"),
            _ => String::new(),
        };
        writeln!(
            out,
            "transform  {:.1} ms against parse+print {:.1} ms: {:.2}x (target 1.5x){}",
            self.transform_ms,
            self.parse_print_ms,
            self.ratio_to_parse_print,
            cpu(
                self.transform_cpu_ms,
                self.parse_print_cpu_ms,
                self.ratio_to_parse_print_cpu
            )
        )?;
        writeln!(
            out,
            "           {} blocks inserted, peak RSS {}",
            self.blocks_inserted,
            self.peak_rss_bytes
                .map_or("n/a".to_string(), |b| format!("{:.1} MB", b as f64 / 1e6))
        )
    }
}
