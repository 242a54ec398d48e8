//! A wider sweep than the per-effect tests (20 seeds per kind, effect size 3× the noise, sampling 1, 3 or
//! 5 min); release-speed, so ignored by default: `cargo test --release --test diagnose_sweep -- --ignored
//! --nocapture`. It prints the hit rates the README quotes and asserts only that no control blames a column.

use driftloop::diagnose::scenario::{CHANNEL, Scenario, simulate};
use driftloop::diagnose::{Options, diagnose};
use driftloop::model::effects::Kind;
use driftloop::model::{FitOptions, fit};

#[test]
#[ignore = "release-speed sweep; run explicitly"]
fn sweep() {
    let kinds: Vec<Option<Kind>> = std::iter::once(None)
        .chain(Kind::DIAGNOSED.into_iter().map(Some))
        .collect();
    for kind in kinds {
        let (mut ok_kind, mut ok_rms, mut n) = (0, 0, 0);
        let mut fails = Vec::new();
        for seed in 100..120u64 {
            let mut sc = Scenario::new(seed, kind);
            sc.effect_size = 3.0;
            sc.step_min = [1.0, 3.0, 5.0][(seed % 3) as usize];
            let sim = simulate(&sc).unwrap();
            let declared = fit(&sim.characterisation, &FitOptions::new(CHANNEL)).unwrap();
            let d = diagnose(
                &declared,
                &sim.production,
                &Options::new(CHANNEL).holdout_from(1080.0),
            )
            .unwrap();
            n += 1;
            let good = match kind {
                None => d.effects_added.iter().all(|a| a.effect.signal.is_none()),
                Some(k) => d.effects_added.first().is_some_and(|a| {
                    a.effect.kind == k
                        && a.effect.signal
                            == Kind::reads_signal(k)
                                .then(|| sim.truth.effects[0].signal.clone())
                                .flatten()
                }),
            };
            if good {
                ok_kind += 1
            } else {
                fails.push((
                    seed,
                    d.effects_added
                        .iter()
                        .map(|a| a.effect.kind.name())
                        .collect::<Vec<_>>(),
                ))
            }
            if d.after.holdout.unwrap().rms_um <= 0.6 {
                ok_rms += 1
            }
        }
        eprintln!("{kind:?}: kind ok {ok_kind}/{n}, holdout ≤ 2σ {ok_rms}/{n}; fails {fails:?}");
        if kind.is_none() {
            assert_eq!(ok_kind, n, "a control blamed a column");
        }
    }
}
