//! How far the camera processor's analytic fit ([`Fit::Analytic`], which the Python
//! environment's `dt_s` option selects) puts the lights it fills in from where the lab's
//! forward differences put them, on the Python environment's own captures: the realistic
//! plant at an exact physics step, episodes of random moves from a fresh track, each capture
//! taken twice from the same state (the plant, its noise generators and the track copied),
//! once with each fit.
//!
//! `cargo run --release -p trn-bench --example fit_agreement > docs/python/fit-agreement.md`
//! (`fit_agreement [EPISODES] [MOVES]`, default 1,000 episodes of 10 moves; a few seconds)
//! writes the page: for `dt_s` 0.01 and 0.05, the captures, those that filled a light in (as
//! valid or estimated), the readings the fill placed in both, how many differ by more than 1e-4 px, their
//! median and the largest difference, and the captures whose statuses differ.
use rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use trn_plant::markers::{Fit, Tracker};
use trn_plant::{Plant, PointStatus, SimConfig};

/// What one `dt_s` measured.
struct Row {
    captures: usize,
    filling: usize,
    compared: usize,
    apart_px: Vec<f64>,
    largest: f64,
    other: usize,
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |k: usize, default: usize| -> usize {
        args.get(k).map_or(default, |a| {
            a.parse().unwrap_or_else(|_| {
                eprintln!("fit_agreement: `{a}` is not a count (fit_agreement [EPISODES] [MOVES])");
                std::process::exit(2)
            })
        })
    };
    let (episodes, moves) = (arg(0, 1_000), arg(1, 10));
    println!(
        "# The analytic fit against the lab's\n\n\
         Written by `cargo run --release -p trn-bench --example fit_agreement > \
         docs/python/fit-agreement.md` (host/bench/examples/fit_agreement.rs).\n\n\
         With `dt_s` the Python environment's camera processor fits the marker body with its \
         analytic Jacobian, stopped at convergence, where the lab differences the body's five \
         coordinates and iterates until no step lowers the cost. The realistic plant, {episodes} \
         episodes of {moves} random moves from a fresh track (as the environment's episodes \
         begin), each capture taken twice from the same state (the plant, its noise \
         generators and the track copied), once with each fit; a reading compared is one \
         the fill placed (valid or estimated) in both, the captures' statuses the same. A \
         capture whose statuses differ is one where a hidden light's fill is on the edge of \
         being determined by the readings: one fit reports it valid, the other estimated.\n"
    );
    println!(
        "| `dt_s` | captures | captures filling a light in | readings filled in by both | \
         differing by more than 1e-4 px | their median px | largest px | captures whose \
         statuses differ |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|");
    for dt_s in [0.01, 0.05] {
        let mut r = measure(episodes, moves, dt_s);
        r.apart_px.sort_by(f64::total_cmp);
        let median = r.apart_px.get(r.apart_px.len() / 2).copied().unwrap_or(0.0);
        println!(
            "| {dt_s} | {} | {} | {} | {} | {median:.1e} | {:.1e} | {} |",
            r.captures,
            r.filling,
            r.compared,
            r.apart_px.len(),
            r.largest,
            r.other
        );
    }
}

/// Episodes of random moves at `dt_s`, each capture taken with both fits.
fn measure(episodes: usize, moves: usize, dt_s: f64) -> Row {
    let cfg = SimConfig::realistic();
    let mut row = Row {
        captures: 0,
        filling: 0,
        compared: 0,
        apart_px: vec![],
        largest: 0.0,
        other: 0,
    };
    for episode in 0..episodes {
        let seed = 1_000 + episode as u64;
        let mut lab = Plant::new(&cfg, seed).expect("the realistic plant");
        lab.set_exact_step(Some(dt_s))
            .expect("a step the plant takes");
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let mut track = Tracker::default();
        for _ in 0..moves {
            let p = lab.random_pressures(&mut rng);
            lab.command(&p);
            lab.settle();
            let mut fast = lab.clone();
            fast.set_fit(Fit::Analytic);
            let mut fast_track = track;
            let (a, fill) = lab.gripper_lights_filled(&mut track);
            let (b, _) = fast.gripper_lights_filled(&mut fast_track);
            row.captures += 1;
            row.filling += usize::from(fill.filled + fill.estimated > 0);
            let statuses = |r: &trn_plant::Readings<4>| r.points.map(|p| p.status);
            if statuses(&a) != statuses(&b) {
                row.other += 1;
                continue;
            }
            // the readings the fill placed (a light the capture saw is the same in both)
            for (k, (x, y)) in a.points.iter().zip(&b.points).enumerate() {
                if x.status == PointStatus::Occluded || fill.seen[k] == Some(PointStatus::Valid) {
                    continue;
                }
                row.compared += 1;
                let d = (x.x - y.x).hypot(x.y - y.y);
                row.largest = row.largest.max(d);
                if d > 1e-4 {
                    row.apart_px.push(d);
                }
            }
        }
    }
    row
}
