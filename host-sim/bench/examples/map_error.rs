//! Where stage 1's error comes from, measured on a static copy of the plant the networks
//! were trained on (a plant without hysteresis, no process noise, every reading taken at
//! rest): the coarse move's error against the distance from the target to the nearest
//! neuron (the interpolation of the map between its neurons' centres), and the first fine
//! move of the learned averaged Jacobian against the plant's true local Jacobian (its gain
//! along the error, its residual across it, and the error a step with the true Jacobian
//! leaves: what the map's curvature alone leaves).
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
    /// Scratch: the step of the neighbours' true inverse Jacobians (at their own pressures),
    /// averaged with the network's weights, and of the learned ones over the first ranks.
    avg_true_ratio: f32,
    avg_j_ratio: f32,
    near_learned_ratio: f32,
    own_learned_ratio: f32,
    target_j_ratio: f32,
    p_nbr: f32,
    p_coarse: f32,
    cond: f32,
    pr_learned: f32,
    pr_true: f32,
    reg_p: f32,
    reg_w: f32,
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
    let mut cache: std::collections::HashMap<usize, Option<SMatrix<f32, 8, 5>>> =
        std::collections::HashMap::new();
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
        let ranks: usize = std::env::var("RANKS").ok().and_then(|s| s.parse().ok()).unwrap_or(30);
        let near: usize = std::env::var("NEAR").ok().and_then(|s| s.parse().ok()).unwrap_or(4);
        let mut a_true = SMatrix::<f32, 5, 8>::zeros();
        let mut j_avg = SMatrix::<f32, 8, 5>::zeros();
        let mut a_near = SMatrix::<f32, 5, 8>::zeros();
        let (mut wsum, mut nsum) = (0.0f32, 0.0f32);
        for (r, &k) in order[..ranks].iter().enumerate() {
            let al = (-(r as f32) / 10.0).exp();
            let jk = *cache.entry(k).or_insert_with(|| jacobian(plant, &net.pressure(k)));
            if let Some(jk) = jk {
                if let Ok(pk) = jk.pseudo_inverse(1e-6) {
                    a_true += pk * al;
                    j_avg += jk * al;
                    wsum += al;
                }
            }
            if r < near {
                let ak = net.jacobian(k);
                a_near += SMatrix::<f32, 5, 8>::from_fn(|m, d| ak[m][d]) * al;
                nsum += al;
            }
        }
        let ak0 = net.jacobian(order[0]);
        let a_own = SMatrix::<f32, 5, 8>::from_fn(|m, d| ak0[m][d]);
        let jt_pre = jacobian(plant, &pt);
        let pdist = |a: &[f32; 5]| a.iter().zip(&p0).map(|(x, y)| (x - y) * (x - y)).sum::<f32>();
        let mut porder: Vec<usize> = (0..1000).collect();
        porder.sort_by(|&a, &b| pdist(&net.pressure(a)).total_cmp(&pdist(&net.pressure(b))));
        let pranks: usize = std::env::var("PRANKS").ok().and_then(|s| s.parse().ok()).unwrap_or(10);
        let palpha: f32 = std::env::var("PALPHA").ok().and_then(|s| s.parse().ok()).unwrap_or(3.0);
        let (mut a_pl, mut j_pt, mut pw, mut pwt) =
            (SMatrix::<f32, 5, 8>::zeros(), SMatrix::<f32, 8, 5>::zeros(), 0.0f32, 0.0f32);
        for (r, &k) in porder[..pranks].iter().enumerate() {
            let al = (-(r as f32) / palpha).exp();
            let ak = net.jacobian(k);
            a_pl += SMatrix::<f32, 5, 8>::from_fn(|m, d| ak[m][d]) * al;
            pw += al;
            if let Some(jk) = *cache.entry(k).or_insert_with(|| jacobian(plant, &net.pressure(k))) {
                j_pt += jk * al;
                pwt += al;
            }
        }
        let mut ratio_of = |a: SMatrix<f32, 5, 8>| -> f32 {
            let dx = a * e;
            let p: [f32; 5] = core::array::from_fn(|i| p0[i] + dx[i]);
            at_rest(plant, &p).map_or(f32::NAN, |v| dist(&u, &v) / coarse_px)
        };
        let avg_true_ratio = ratio_of(a_true / wsum.max(1e-9));
        let avg_j_ratio = (j_avg / wsum.max(1e-9))
            .pseudo_inverse(1e-6)
            .map_or(f32::NAN, &mut ratio_of);
        let near_learned_ratio = ratio_of(a_near / nsum);
        let own_learned_ratio = ratio_of(a_own);
        let regn: usize = std::env::var("REGN").ok().and_then(|s| s.parse().ok()).unwrap_or(20);
        let fit = |idx: &[usize], ralpha: f32| -> (SVector<f32, 5>, SVector<f32, 8>, SMatrix<f32, 5, 5>, SMatrix<f32, 8, 8>, SMatrix<f32, 8, 5>) {
            let (mut pb, mut wb, mut ws) = (SVector::<f32, 5>::zeros(), SVector::<f32, 8>::zeros(), 0.0f32);
            for (r, &k) in idx.iter().enumerate() {
                let al = (-(r as f32) / ralpha).exp();
                pb += SVector::<f32, 5>::from(net.pressure(k)) * al;
                wb += SVector::<f32, 8>::from(net.weight(k)) * al;
                ws += al;
            }
            pb /= ws;
            wb /= ws;
            let (mut cpp, mut cww, mut cwp) = (SMatrix::<f32, 5, 5>::zeros(), SMatrix::<f32, 8, 8>::zeros(), SMatrix::<f32, 8, 5>::zeros());
            for (r, &k) in idx.iter().enumerate() {
                let al = (-(r as f32) / ralpha).exp();
                let dp = SVector::<f32, 5>::from(net.pressure(k)) - pb;
                let dw = SVector::<f32, 8>::from(net.weight(k)) - wb;
                cpp += dp * dp.transpose() * al;
                cww += dw * dw.transpose() * al;
                cwp += dw * dp.transpose() * al;
            }
            (pb, wb, cpp, cww, cwp)
        };
        let (_, _, cpp, _, cwp) = fit(&porder[..regn], palpha);
        let reg_p = cpp
            .try_inverse()
            .map(|ci| cwp * ci)
            .and_then(|j| j.pseudo_inverse(1e-6).ok())
            .map_or(f32::NAN, &mut ratio_of);
        let (_, _, _, cww, cwp) = fit(&order[..regn], 10.0);
        let reg_w = cww
            .pseudo_inverse(1e-3 * cww.trace())
            .map(|ci| cwp.transpose() * ci)
            .map_or(f32::NAN, &mut ratio_of);
        let pr_learned = ratio_of(a_pl / pw);
        let pr_true = (j_pt / pwt.max(1e-9)).pseudo_inverse(1e-6).map_or(f32::NAN, &mut ratio_of);
        let target_j_ratio = jt_pre
            .and_then(|jt| jt.pseudo_inverse(1e-6).ok())
            .map_or(f32::NAN, &mut ratio_of);
        let pv = |a: &[f32; 5]| SVector::<f32, 5>::from_iterator(a.iter().zip(&pt).map(|(x, y)| x - y)).norm();
        let p_nbr = order[..5].iter().map(|&k| pv(&net.pressure(k))).sum::<f32>() / 5.0;
        let p_coarse = pv(&p0);
        let sv = j.singular_values();
        let cond = sv.max() / sv.min().max(1e-9);
        rows.push(Row {
            avg_true_ratio,
            avg_j_ratio,
            near_learned_ratio,
            own_learned_ratio,
            target_j_ratio,
            p_nbr,
            p_coarse,
            cond,
            pr_learned,
            pr_true,
            reg_p,
            reg_w,
            nearest_px,
            coarse_px,
            learned_ratio: dist(&u, &v1) / coarse_px,
            true_ratio: dist(&u, &vx) / coarse_px,
            gain,
            across: (moved - e * gain).norm() / coarse_px,
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
        "| seed | targets | nearest neuron px | coarse px: mean (p95) | coarse, nearest third px | coarse, farthest third px | first fine move: error left, learned Jacobian (p95) | error left, true Jacobian (p95) | learned step: gain along the error | learned step: residual across the error |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let mut all: Vec<[f32; 9]> = Vec::new();
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
        ];
        let gain = mean(&col(|r| r.gain, &rows));
        let across = mean(&col(|r| r.across, &rows));
        let nanmean = |v: Vec<f32>| {
            let mut v: Vec<f32> = v.into_iter().filter(|x| x.is_finite()).collect();
            v.sort_by(|a, b| a.total_cmp(b));
            format!("{:.3}/med {:.3}", mean(&v), v[v.len() / 2])
        };
        eprintln!(
            "{seed}: avg true inverse {} | inverse of avg true J {} | learned first ranks {} | learned nearest only {} | J at target {} | |p_k-pt| ranks<5 {} | |p0-pt| {} | cond J(p0) {} | pressure-ranked learned {} true {} | regression on pressure nbrs {} on image nbrs {}",
            nanmean(col(|r| r.avg_true_ratio, &rows)),
            nanmean(col(|r| r.avg_j_ratio, &rows)),
            nanmean(col(|r| r.near_learned_ratio, &rows)),
            nanmean(col(|r| r.own_learned_ratio, &rows)),
            nanmean(col(|r| r.target_j_ratio, &rows)),
            nanmean(col(|r| r.p_nbr, &rows)),
            nanmean(col(|r| r.p_coarse, &rows)),
            nanmean(col(|r| r.cond, &rows)),
            nanmean(col(|r| r.pr_learned, &rows)),
            nanmean(col(|r| r.pr_true, &rows)),
            nanmean(col(|r| r.reg_p, &rows)),
            nanmean(col(|r| r.reg_w, &rows)),
        );
        println!(
            "| {seed} | {} | {:.1} | {:.1} ({:.1}) | {:.1} | {:.1} | {:.3} ({:.3}) | {:.3} ({:.3}) | {gain:.3} | {across:.3} |",
            rows.len(),
            v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8]
        );
        all.push(v);
    }
    let m = |i: usize| all.iter().map(|v| v[i]).sum::<f32>() / all.len() as f32;
    println!(
        "| mean | | {:.1} | {:.1} ({:.1}) | {:.1} | {:.1} | {:.3} ({:.3}) | {:.3} ({:.3}) | | |",
        m(0),
        m(1),
        m(2),
        m(3),
        m(4),
        m(5),
        m(6),
        m(7),
        m(8)
    );
}
