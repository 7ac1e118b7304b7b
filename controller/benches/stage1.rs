//! Criterion benchmarks of the stage-1 network's hot paths.
//! `cargo bench -p trn-controller --bench stage1`

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use trn_controller::rank::{RankMode, RankScratch, Ranking};
use trn_controller::{Command, Config, Controller, Observation, Stage1, Task};

const V: [f32; 8] = [300.0, 200.0, 310.0, 210.0, 320.0, 220.0, 330.0, 230.0];

fn stage1() -> Box<Stage1> {
    let mut s = Box::new(Stage1::new(Config::project_default().stage1));
    use rand_core::SeedableRng;
    s.init_random(&mut rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(1));
    s
}

fn benches(c: &mut Criterion) {
    let mut scratch = Box::new(RankScratch::new());
    let mut s = stage1();
    c.bench_function("stage1 rank + coarse output (partial selection)", |b| {
        b.iter(|| {
            let p = s.begin(black_box(&V), None, false, &mut scratch).unwrap();
            s.abort();
            p
        })
    });
    s.set_rank_mode(RankMode::FullSort);
    c.bench_function("stage1 rank + coarse output (full sort)", |b| {
        b.iter(|| {
            let p = s.begin(black_box(&V), None, false, &mut scratch).unwrap();
            s.abort();
            p
        })
    });

    let net = stage1();
    let mut r = Ranking::<128>::new();
    c.bench_function("rank 1000 neurons: partial selection of 128", |b| {
        b.iter(|| {
            r.compute(
                net.net().weights(),
                black_box(&V),
                &mut scratch,
                RankMode::PartialSelect,
            )
        })
    });
    let mut rf = Box::new(Ranking::<1000>::new());
    c.bench_function("rank 1000 neurons: full sort", |b| {
        b.iter(|| {
            rf.compute(
                net.net().weights(),
                black_box(&V),
                &mut scratch,
                RankMode::FullSort,
            )
        })
    });

    let mut s = stage1();
    c.bench_function(
        "stage1 rank + coarse + one fine move (mean Jacobian + output)",
        |b| {
            b.iter(|| {
                s.begin(&V, None, false, &mut scratch).unwrap();
                let mut seen = V;
                seen[0] += 20.0;
                let step = s.observe(black_box(&seen), &mut scratch).unwrap();
                s.abort();
                step
            })
        },
    );

    let mut ctrl = Box::new(Controller::new(Config::project_default()));
    ctrl.init_random(2);
    c.bench_function(
        "stage1 full learning step (coarse + 2 fine moves, all updates)",
        |b| {
            b.iter(|| {
                let mut cmd = ctrl
                    .begin(Task::Stage1 {
                        v: V,
                        supervised: None,
                        learn: true,
                    })
                    .unwrap();
                // coarse move, then fine moves that each cut the error; the trial is aborted
                // after the second fine move's updates, so every iteration costs the same
                for n in 0..3 {
                    if let Command::Done(_) = cmd {
                        break;
                    }
                    let mut seen = V;
                    seen[0] += 20.0 / (1.0 + n as f32 * 4.0);
                    cmd = ctrl.observe(Observation::Lights(seen)).unwrap();
                }
                ctrl.abort();
            })
        },
    );
}

criterion_group!(stage1_benches, benches);
criterion_main!(stage1_benches);
