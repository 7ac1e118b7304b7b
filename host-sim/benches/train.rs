//! The default training run (both stages, 300 trials each, plus the held-out evaluation and
//! grasps) on the in-process bus, as `trn train` runs it.
//! `cargo bench -p trn-sim --bench train`

use criterion::{criterion_group, criterion_main, Criterion};
use trn_sim::experiment::cli::{Ablation, Common, Preset};
use trn_sim::experiment::run::{run_plan, Plan};

fn train(c: &mut Criterion) {
    let common = Common::inproc(1, Preset::Project, Ablation::None);
    let mut g = c.benchmark_group("train");
    g.sample_size(10);
    g.bench_function(
        "default train run (300 trials per network + eval + grasps, inproc bus)",
        |b| b.iter(|| run_plan(&common, Plan::new(300, 100, 50), None, None, "bench").unwrap()),
    );
    g.finish();
}

criterion_group!(benches, train);
criterion_main!(benches);
