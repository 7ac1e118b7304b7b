//! Where stage 1's error comes from, measured on a static copy of the plant the networks
//! were trained on (a plant without hysteresis, no process noise, every reading taken at
//! rest): the coarse move's error against the distance from the target to the nearest
//! neuron (the interpolation of the map between its neurons' centres), and the first fine
//! move of the learned averaged Jacobian against the plant's true local Jacobian (its gain
//! along the error, its residual across it, and the error a step with the true Jacobian
//! leaves: what the map's curvature alone leaves).
//!
//! Two more columns say whether the learned Jacobians or the representation limit the first
//! fine move: the step of the neighbours' *true* Jacobians (each neuron's plant Jacobian at its
//! own pressures, averaged with the weights the network gives its ranks, then inverted), and
//! how far the nearest neurons' pressures lie from the target's own pressures against the
//! coarse command.
//!
//! The last two ask how far the learning is from what this network's pieces could do: where
//! the nearest neurons' own pressures land, against their centres (a piece's own error), and
//! the coarse move the same ranks would make if every piece were exact (each neuron's
//! pressure, where it lands, and the plant's Jacobian there, extrapolated to the target and
//! averaged with the weights the network gives its ranks): the interpolation's own bias.
//!
//! `scripts/diagnosis_map.sh` trains the networks (seeds 100-102) and runs it:
//! `map_error PLANT.toml SEED=NET.ckpt ...` prints one row per checkpoint and their mean.
use nalgebra::{SMatrix, SVector};
use rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use std::path::Path;
use trn_bench::targets::dist;
use trn_controller::rank::RankScratch;
use trn_controller::{checkpoint, Config, Controller, StageStep};
use trn_plant::{Plant, SimConfig};

/// Simulated time after a command before the reading: long enough for the ringing and the
/// pressure lag to die out (the map a static learner could learn).
const REST_S: f64 = 20.0;
/// Held-out targets per checkpoint, from random pressures (this tool's own seed).
const TARGETS: usize = 300;
/// Pressure step of the central differences of the true Jacobian.
const H: f32 = 0.02;
/// Ranks whose true Jacobians are averaged (weights `exp(-r / 10)`, the network's averaging
/// range: the ranks beyond carry 5 % of the weight).
const AVERAGED: usize = 30;
/// The nearest neurons whose pressures are compared with the target's.
const NEAREST: usize = 5;

/// The weight the network gives rank `r` in its averages, `exp(-r / 10)`.
fn rank_weight(r: usize) -> f32 {
    (-(r as f32) / 10.0).exp()
}

fn at_rest(plant: &mut Plant, p: &[f32; 5]) -> Option<[f32; 8]> {
    let p: [f32; 5] = core::array::from_fn(|i| p[i].clamp(-1.0, 1.0));
    plant.command(&p);
    plant.advance(REST_S);
    plant.observe_gripper_lights_true().reported_vector()
}

fn mean(v: &[f32]) -> f32 {
    v.iter().sum::<f32>() / v.len() as f32
}

fn p95(v: &[f32]) -> f32 {
    let mut v = v.to_vec();
    v.sort_by(|a, b| a.total_cmp(b));
    v[((v.len() - 1) as f32 * 0.95).round() as usize]
}

/// One target's measurements.
struct Row {
    nearest_px: f32,
    coarse_px: f32,
    learned_ratio: f32,
    true_ratio: f32,
    gain: f32,
    across: f32,
    neighbours_true_ratio: f32,
    nearest_p: f32,
    coarse_p: f32,
    own_px: f32,
    exact_pieces_px: f32,
}

fn pressure_distance(a: &[f32; 5], b: &[f32; 5]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f32>()
        .sqrt()
}

/// The true Jacobian dv/dp at `p` (central differences), or `None` if a light left a view.
fn jacobian(plant: &mut Plant, p: &[f32; 5]) -> Option<SMatrix<f32, 8, 5>> {
    let mut j = SMatrix::<f32, 8, 5>::zeros();
    for c in 0..5 {
        let (mut a, mut b) = (*p, *p);
        a[c] += H;
        b[c] -= H;
        let (va, vb) = (at_rest(plant, &a)?, at_rest(plant, &b)?);
        for r in 0..8 {
            j[(r, c)] = (va[r] - vb[r]) / (2.0 * H);
        }
    }
    Some(j)
}

fn measure(ctrl: &mut Controller, plant: &mut Plant) -> Vec<Row> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(0x3A9_E44);
    let net = ctrl.stage1().net().clone();
    let mut scratch = RankScratch::new();
    let mut rows = Vec::new();
    // each neuron's true Jacobian at its own pressures, computed once
    let mut at_neuron: Vec<Option<Option<SMatrix<f32, 8, 5>>>> = vec![None; 1000];
    // and where its pressures land
    let mut landing: Vec<Option<Option<[f32; 8]>>> = vec![None; 1000];
    let mut tries = 0;
    while rows.len() < TARGETS && tries < 20 * TARGETS {
        tries += 1;
        let pt = plant.random_pressures(&mut rng);
        let Some(u) = at_rest(plant, &pt) else {
            continue;
        };
        let nearest_px = (0..1000)
            .map(|k| dist(&net.weight(k), &u))
            .fold(f32::INFINITY, f32::min);
        let s = ctrl.stage1_mut();
        let Ok(p0) = s.begin(&u, None, false, &mut scratch) else {
            continue;
        };
        let Some(v0) = at_rest(plant, &p0) else {
            s.abort();
            continue;
        };
        let step = s.observe(&v0, &mut scratch);
        s.abort();
        let Ok(StageStep::Move(p1)) = step else {
            continue;
        };
        let (Some(v1), Some(j)) = (at_rest(plant, &p1), jacobian(plant, &p0)) else {
            continue;
        };
        let Ok(jp) = j.pseudo_inverse(1e-6) else {
            continue;
        };
        let e = SVector::<f32, 8>::from_iterator(u.iter().zip(&v0).map(|(a, b)| a - b));
        let dp = SVector::<f32, 5>::from_iterator(p1.iter().zip(&p0).map(|(a, b)| a - b));
        let moved = j * dp;
        let gain = moved.dot(&e) / e.dot(&e);
        let dx = jp * e;
        let p_true: [f32; 5] = core::array::from_fn(|i| p0[i] + dx[i]);
        let Some(vx) = at_rest(plant, &p_true) else {
            continue;
        };
        let coarse_px = e.norm();
        let mut order: Vec<usize> = (0..1000).collect();
        order.sort_by(|&a, &b| dist(&net.weight(a), &u).total_cmp(&dist(&net.weight(b), &u)));
        let (mut j_avg, mut weight) = (SMatrix::<f32, 8, 5>::zeros(), 0.0f32);
        for (r, &k) in order[..AVERAGED].iter().enumerate() {
            let jk = *at_neuron[k].get_or_insert_with(|| jacobian(plant, &net.pressure(k)));
            if let Some(jk) = jk {
                let al = rank_weight(r);
                j_avg += jk * al;
                weight += al;
            }
        }
        let Ok(jn) = (j_avg / weight.max(f32::MIN_POSITIVE)).pseudo_inverse(1e-6) else {
            continue;
        };
        let dn = jn * e;
        let p_n: [f32; 5] = core::array::from_fn(|i| p0[i] + dn[i]);
        let Some(vn) = at_rest(plant, &p_n) else {
            continue;
        };
        // the same ranks' pieces made exact
        let (mut p_sum, mut w_sum) = ([0.0f32; 5], 0.0f32);
        for (r, &k) in order[..AVERAGED].iter().enumerate() {
            let pk = net.pressure(k);
            let xk = *landing[k].get_or_insert_with(|| at_rest(plant, &pk));
            let jk = *at_neuron[k].get_or_insert_with(|| jacobian(plant, &pk));
            let (Some(xk), Some(jk)) = (xk, jk) else {
                continue;
            };
            let Ok(jkp) = jk.pseudo_inverse(1e-6) else {
                continue;
            };
            let d = SVector::<f32, 8>::from_iterator(u.iter().zip(&xk).map(|(a, b)| a - b));
            let dpk = jkp * d;
            let al = rank_weight(r);
            for i in 0..5 {
                p_sum[i] += al * (pk[i] + dpk[i]);
            }
            w_sum += al;
        }
        if w_sum <= 0.0 {
            continue;
        }
        let p_exact: [f32; 5] = core::array::from_fn(|i| p_sum[i] / w_sum);
        let Some(v_exact) = at_rest(plant, &p_exact) else {
            continue;
        };
        let own: Vec<f32> = order[..NEAREST]
            .iter()
            .filter_map(|&k| {
                let pk = net.pressure(k);
                landing[k]
                    .get_or_insert_with(|| at_rest(plant, &pk))
                    .map(|x| dist(&x, &net.weight(k)))
            })
            .collect();
        if own.is_empty() {
            continue;
        }
        let nearest_p = order[..NEAREST]
            .iter()
            .map(|&k| pressure_distance(&net.pressure(k), &pt))
            .sum::<f32>()
            / NEAREST as f32;
        rows.push(Row {
            neighbours_true_ratio: dist(&u, &vn) / coarse_px,
            nearest_p,
            coarse_p: pressure_distance(&p0, &pt),
            nearest_px,
            coarse_px,
            learned_ratio: dist(&u, &v1) / coarse_px,
            true_ratio: dist(&u, &vx) / coarse_px,
            gain,
            across: (moved - e * gain).norm() / coarse_px,
            own_px: mean(&own),
            exact_pieces_px: dist(&u, &v_exact),
        });
    }
    rows
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: map_error PLANT.toml SEED=NET.ckpt [SEED=NET.ckpt ...]";
    let (Some(plant_path), true) = (args.first(), args.len() > 1) else {
        eprintln!("{usage}");
        std::process::exit(2);
    };
    let cfg = SimConfig::load(Path::new(plant_path)).unwrap_or_else(|e| {
        eprintln!("map_error: {e}");
        std::process::exit(1);
    });
    let mut cfg = cfg;
    cfg.realism.process_noise_deg = 0.0;
    println!(
        "| seed | targets | nearest neuron px | coarse px: mean (p95) | coarse, nearest third px | coarse, farthest third px | first fine move: error left, learned Jacobian (p95) | error left, true Jacobian (p95) | learned step: gain along the error | learned step: residual across the error | error left, the neighbours' true Jacobians averaged (p95) | pressure distance to the target's pressures: nearest neurons / coarse command | nearest neurons: where their pressures land, from their centres px | coarse px, the same ranks' pieces exact (p95) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut all: Vec<[f32; 16]> = Vec::new();
    for arg in &args[1..] {
        let Some((seed, path)) = arg.split_once('=') else {
            eprintln!("{usage}");
            std::process::exit(2);
        };
        let bytes = std::fs::read(path).unwrap_or_else(|e| {
            eprintln!("map_error: {path}: {e}");
            std::process::exit(1);
        });
        let mut ctrl = Box::new(Controller::new(Config::project_default()));
        if let Err(e) = checkpoint::restore(&mut ctrl, &bytes) {
            eprintln!("map_error: {path}: {e:?}");
            std::process::exit(1);
        }
        let mut plant = Plant::new(&cfg, 1).expect("a validated configuration");
        let mut rows = measure(&mut ctrl, &mut plant);
        if rows.len() < 30 {
            eprintln!("map_error: {path}: only {} targets measured", rows.len());
            std::process::exit(1);
        }
        rows.sort_by(|a, b| a.nearest_px.total_cmp(&b.nearest_px));
        let third = rows.len() / 3;
        let col = |f: fn(&Row) -> f32, r: &[Row]| r.iter().map(f).collect::<Vec<f32>>();
        let coarse = col(|r| r.coarse_px, &rows);
        let learned = col(|r| r.learned_ratio, &rows);
        let exact = col(|r| r.true_ratio, &rows);
        let neighbours = col(|r| r.neighbours_true_ratio, &rows);
        let exact_pieces = col(|r| r.exact_pieces_px, &rows);
        let v = [
            mean(&col(|r| r.nearest_px, &rows)),
            mean(&coarse),
            p95(&coarse),
            mean(&coarse[..third]),
            mean(&coarse[rows.len() - third..]),
            mean(&learned),
            p95(&learned),
            mean(&exact),
            p95(&exact),
            mean(&col(|r| r.gain, &rows)),
            mean(&col(|r| r.across, &rows)),
            mean(&neighbours),
            p95(&neighbours),
            mean(&col(|r| r.own_px, &rows)),
            mean(&exact_pieces),
            p95(&exact_pieces),
        ];
        let (near_p, coarse_p) = (
            mean(&col(|r| r.nearest_p, &rows)),
            mean(&col(|r| r.coarse_p, &rows)),
        );
        println!(
            "| {seed} | {} | {:.1} | {:.1} ({:.1}) | {:.1} | {:.1} | {:.3} ({:.3}) | {:.3} ({:.3}) | {:.3} | {:.3} | {:.3} ({:.3}) | {near_p:.2} / {coarse_p:.2} | {:.1} | {:.1} ({:.1}) |",
            rows.len(),
            v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8], v[9], v[10], v[11], v[12],
            v[13], v[14], v[15]
        );
        all.push(v);
    }
    let m = |i: usize| all.iter().map(|v| v[i]).sum::<f32>() / all.len() as f32;
    println!(
        "| mean | | {:.1} | {:.1} ({:.1}) | {:.1} | {:.1} | {:.3} ({:.3}) | {:.3} ({:.3}) | | | {:.3} ({:.3}) | | {:.1} | {:.1} ({:.1}) |",
        m(0),
        m(1),
        m(2),
        m(3),
        m(4),
        m(5),
        m(6),
        m(7),
        m(8),
        m(11),
        m(12),
        m(13),
        m(14),
        m(15)
    );
}
