//! `transform` against parse + print on the same generated CAM program (default 100 MB; set
//! DRIFTLOOP_BENCH_MB to change it). The target: transform within 1.5x of parse + print. Also a folder of
//! programs transformed with rayon, to see both cores at work.
//!
//! `cargo bench --bench transform`

use std::hint::black_box;
use std::io::{self, Write};

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use rayon::prelude::*;

use driftloop::model::DriftModel;
use driftloop::omm::{ModelRef, Profile, parse_timed, prepare, prepare_timed, transform};

/// A CAM-like program: passes with tool changes, spindle speeds, feed moves, arcs and retracts.
fn cam_program(target: usize, seed: u64) -> Vec<u8> {
    let mut rng = driftloop::model::synth::Rng::new(seed);
    let mut out = Vec::with_capacity(target + 4096);
    out.extend_from_slice(b"%_N_BENCH_MPF\n;$PATH=/_N_MPF_DIR\nG17 G90 G94 G710\nG54\n");
    let (mut n, mut tool) = (10u64, 1);
    // About five passes in a small program, 20 000 moves per pass in a big one.
    let moves = (target / 200).clamp(50, 20_000);
    while out.len() < target {
        let rpm = 1000 + 1000 * (rng.next_u64() % 5);
        writeln!(out, "T{tool} M6\nD1\nS{rpm} M3\nG0 X0 Y0 Z50").unwrap();
        for k in 0..moves {
            let (x, y, z) = (
                rng.uniform() * 400.0,
                rng.uniform() * 300.0,
                -rng.uniform() * 5.0,
            );
            if k % 50 == 49 {
                writeln!(out, "N{n} G3 X{x:.3} Y{y:.3} CR=80 F900").unwrap();
            } else {
                writeln!(out, "N{n} G1 X{x:.3} Y{y:.3} Z{z:.3} F1200").unwrap();
            }
            n += 10;
            if k % 500 == 499 {
                writeln!(out, "N{n} G0 Z50\nN{} X{x:.3} Y{y:.3}", n + 5).unwrap();
                n += 10;
            }
        }
        tool += 1;
    }
    out.extend_from_slice(b"M5\nM30\n");
    out
}

fn setup() -> (DriftModel, Profile) {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/omm/model.toml");
    (
        DriftModel::read(path.as_ref()).unwrap(),
        Profile::default_profile(),
    )
}

fn big_file(c: &mut Criterion) {
    let mb: usize = std::env::var("DRIFTLOOP_BENCH_MB")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(100);
    let source = cam_program(mb * 1_000_000, 1);
    let (model, profile) = setup();
    let mut group = c.benchmark_group(format!("cam_{mb}mb"));
    group.sample_size(10);
    let model = ModelRef {
        model: &model,
        sha256: "bench",
    };
    // Each measures parse_owned of a fresh copy of the source plus `after` on the parsed program.
    let mut parsed_then = |name: &str, after: &dyn Fn(&driftloop::Program) -> usize| {
        group.bench_function(name, |b| {
            b.iter_batched(
                || source.clone(),
                |src| black_box(after(&driftloop::parse_owned(src))),
                BatchSize::PerIteration,
            )
        });
    };
    parsed_then("parse_print", &|program| {
        program.write_to(&mut io::sink()).unwrap();
        program.block_count()
    });
    parsed_then("transform", &|program| {
        let t = transform(program, model, &profile, false).unwrap();
        io::sink().write_all(&t.bytes).unwrap();
        t.summary.blocks_inserted
    });
    // Like parse_print: the output streamed to its writer, no copy of the whole program.
    parsed_then("transform_stream", &|program| {
        let t = prepare(program, model, &profile, false).unwrap();
        t.write_to(&mut io::sink()).unwrap();
        t.summary.blocks_inserted
    });
    // What `driftloop transform` does: the parser times the plain moves in its pass, the output streamed.
    group.bench_function("transform_timed", |b| {
        b.iter_batched(
            || source.clone(),
            |src| {
                let (program, moves) = parse_timed(src);
                let t = prepare_timed(&program, &moves, &[model], &profile, false).unwrap();
                t.write_to(&mut io::sink()).unwrap();
                black_box(t.summary.blocks_inserted)
            },
            BatchSize::PerIteration,
        )
    });
    group.finish();
}

fn folder(c: &mut Criterion) {
    let programs: Vec<Vec<u8>> = (0..1000).map(|i| cam_program(20_000, i)).collect();
    let (model, profile) = setup();
    let one = |src: &Vec<u8>| {
        let program = driftloop::parse(src);
        let model = ModelRef {
            model: &model,
            sha256: "bench",
        };
        transform(&program, model, &profile, false)
            .unwrap()
            .bytes
            .len()
    };
    let mut group = c.benchmark_group("folder_1000_programs");
    group.sample_size(10);
    group.bench_function("sequential", |b| {
        b.iter(|| programs.iter().map(one).sum::<usize>())
    });
    group.bench_function("rayon", |b| {
        b.iter(|| programs.par_iter().map(one).sum::<usize>())
    });
    group.finish();
}

criterion_group!(benches, big_file, folder);
criterion_main!(benches);
