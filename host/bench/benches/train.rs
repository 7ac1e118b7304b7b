//! The default training run (both stages, 300 trials each, plus the held-out evaluation and
//! grasps) on the in-process bus, as `trn train` runs it.
//! `cargo bench -p trn-bench --bench train`

use criterion::{criterion_group, criterion_main, Criterion};
use trn_bench::{run, Command, RunSpec};

fn train(c: &mut Criterion) {
    let spec = RunSpec::new(Command::Train, 1);
    let mut g = c.benchmark_group("train");
    g.sample_size(10);
    g.bench_function(
        "default train run (300 trials per network + eval + grasps, inproc bus)",
        |b| b.iter(|| run::run_quietly(&spec).unwrap()),
    );
    g.finish();
}

criterion_group!(benches, train);
criterion_main!(benches);
