//! Dry-run speed: a 100 000-block straight CAM-style program and a loop of 100 000 iterations (5 blocks each)
//! on a model-free machine; and the safety audit of the CAM program as `transform` writes it (the original
//! and the transformed program run side by side). Run with `cargo bench --bench vm`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use driftloop::model::DriftModel;
use driftloop::omm::{ModelRef, Profile, transform};
use driftloop::vm::audit::{AuditSettings, audit};
use driftloop::vm::{Config, SimpleMachine, run_source};

fn cam_program(blocks: usize) -> Vec<u8> {
    let mut s = String::from("G90 G94 G54 T1 M6\nS8000 M3\nG0 X0 Y0 Z5\nG1 Z-1 F2000\n");
    for i in 0..blocks {
        let x = (i * 7919 % 3000) as f64 / 10.0;
        let y = (i * 104_729 % 2000) as f64 / 10.0;
        s.push_str(&format!("N{} G1 X{x:.3} Y{y:.3}\n", i * 10 + 50));
    }
    s.push_str("M30\n");
    s.into_bytes()
}

const LOOP: &str = "DEF INT I\nG90 G94 F1000 S3000 M3\nI = 0\nWHILE I < 100000\n  I = I + 1\n  \
                    R1 = SIN(I) * 2 + R1 / 3\n  X = R1\nENDWHILE\nM30\n";

fn bench(c: &mut Criterion) {
    let cfg = Config {
        trace: false,
        ..Config::default()
    };
    let cam = cam_program(100_000);
    c.bench_function("dry run 100k CAM blocks", |b| {
        b.iter(|| {
            let run = run_source(
                "cam",
                black_box(&cam),
                None,
                &cfg,
                &mut SimpleMachine::cold(),
            );
            black_box(run.unwrap().time_min)
        })
    });
    let model =
        DriftModel::read(concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/omm/model.toml").as_ref())
            .expect("the transform tests' model");
    let profile = Profile::default_profile();
    let reference = ModelRef {
        model: &model,
        sha256: "bench",
    };
    let transformed = transform(&driftloop::parse(&cam), reference, &profile, false)
        .expect("the CAM program transforms")
        .bytes;
    let settings = AuditSettings::from_profile(&profile);
    c.bench_function("audit 100k CAM blocks, transformed", |b| {
        b.iter(|| {
            let found = audit(black_box(&cam), black_box(&transformed), &settings, &cfg);
            black_box(found.unwrap().transformed_blocks)
        })
    });
    c.bench_function("dry run 100k loop iterations", |b| {
        b.iter(|| {
            let run = run_source(
                "loop",
                black_box(LOOP.as_bytes()),
                None,
                &cfg,
                &mut SimpleMachine::cold(),
            );
            black_box(run.unwrap().blocks_executed)
        })
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = bench
}
criterion_main!(benches);
