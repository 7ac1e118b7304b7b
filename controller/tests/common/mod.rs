//! A synthetic "plant" shared by the learning test and `examples/explore.rs`: a known smooth
//! nonlinear map from 5 pressures to 8 pixel coordinates, no simulator.
#![allow(dead_code)]

use rand_core::RngCore;
use trn_controller::FineMoves;
use trn_controller::{Command, Controller, Observation, Outcome, Task};

/// The "plant": a smooth nonlinear map from 5 pressures in [-1, 1] to 8 pixel coordinates
/// (the controller learns its inverse on the 5-D manifold it spans).
pub fn plant(p: &[f32; 5]) -> [f32; 8] {
    const B: [[f32; 5]; 8] = [
        [1.0, 0.3, -0.2, 0.1, 0.0],
        [0.2, 1.0, 0.4, 0.0, 0.1],
        [0.9, -0.2, 0.3, 0.0, 0.2],
        [0.1, 0.8, 0.5, 0.2, -0.1],
        [0.7, 0.3, -0.1, 0.6, 0.3],
        [0.0, 0.6, 0.6, -0.3, 0.5],
        [0.8, -0.1, 0.2, 0.5, -0.4],
        [0.2, 0.7, 0.3, -0.5, 0.6],
    ];
    let mut v = [0.0; 8];
    for i in 0..8 {
        let mut s = 0.0;
        for j in 0..5 {
            s += B[i][j] * (0.9 * p[j]).tanh();
        }
        s += 0.15 * (p[0] * p[1] + 0.5 * p[2]).sin();
        v[i] = if i % 2 == 0 { 320.0 } else { 240.0 } + 120.0 * s;
    }
    v
}

pub fn random_pressures(rng: &mut impl RngCore) -> [f32; 5] {
    core::array::from_fn(|_| ((rng.next_u32() >> 8) as f32 / 16_777_216.0) * 1.6 - 0.8)
}

pub fn dist(a: &[f32; 8], b: &[f32; 8]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f32>()
        .sqrt()
}

/// Runs one task against the plant to its end.
pub fn run(ctrl: &mut Controller, task: Task) -> Outcome {
    run_with(ctrl, task, FineMoves::Policy)
}

/// [`run`] with a choice of fine moves.
pub fn run_with(ctrl: &mut Controller, task: Task, fine: FineMoves) -> Outcome {
    let mut cmd = ctrl.begin_with(task, fine).expect("begin");
    loop {
        match cmd {
            Command::Move { pressures, .. } => {
                cmd = ctrl
                    .observe(Observation::Lights(plant(&pressures)))
                    .expect("observe");
            }
            Command::Done(o) => return o,
        }
    }
}
