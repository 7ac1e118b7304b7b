//! Simulated moves per second: servo commands, physics to the settle time, both cameras.
//! `cargo bench -p trn-plant --bench plant`

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use rand_core::SeedableRng;
use trn_plant::{Plant, SimConfig};

fn moves(c: &mut Criterion) {
    let mut plant = Plant::new(&SimConfig::default(), 1).unwrap();
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(1);
    let mut g = c.benchmark_group("plant");
    g.throughput(Throughput::Elements(1));
    g.bench_function(
        "move: command 5 joints + settle 1.2 s + observe lights and centre",
        |b| {
            b.iter(|| {
                let p = plant.random_pressures(&mut rng);
                plant.command(&p);
                plant.settle();
                (
                    plant.observe_gripper_lights(),
                    plant.observe_gripper_centre(),
                )
            })
        },
    );
    g.finish();
}

criterion_group!(benches, moves);
criterion_main!(benches);
