//! The marker fill's tests: an anchored estimate after a long move, an outlier refused, an
//! estimate from a near track.

use rand_core::SeedableRng;

use super::*;
use crate::readings::Readings;
use crate::stereo::tolerance_px;
use crate::{kinematics, Plant, SimConfig};

/// A reading of `x` in camera `cam` (noise-free), or hidden.
fn reading(plant: &Plant, x: &Vector3<f64>, cam: usize, seen: bool) -> PixelReading {
    let (u, v) = plant.cameras[cam].project(x).expect("in view");
    if seen {
        PixelReading {
            x: u,
            y: v,
            status: PointStatus::Valid,
        }
    } else {
        PixelReading {
            x: f64::NAN,
            y: f64::NAN,
            status: PointStatus::Occluded,
        }
    }
}

/// A pose whose three markers both cameras have in view, the markers p, q, c (mm).
fn pose(plant: &mut Plant) -> [Vector3<f64>; 3] {
    pose_from(
        plant,
        &mut rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(7),
    )
}

/// [`pose`] from random pressures of `rng`.
fn pose_from(plant: &mut Plant, rng: &mut impl rand_core::RngCore) -> [Vector3<f64>; 3] {
    loop {
        let p = plant.random_pressures(rng);
        plant.command(&p);
        plant.settle();
        let pose = plant.gripper_pose();
        let [p, q] = kinematics::lights(plant.config(), &pose);
        let m = [p, q, pose.centre_mm];
        if m.iter()
            .all(|x| (0..2).all(|cam| plant.cameras[cam].project(x).is_some()))
        {
            return m;
        }
    }
}

/// Lights p, q and centre c with `seen[marker][cam]`.
fn readings(
    plant: &Plant,
    m: &[Vector3<f64>; 3],
    seen: [[bool; 2]; 3],
) -> (Readings<4>, Readings<2>) {
    let lights = Readings {
        points: core::array::from_fn(|k| reading(plant, &m[k / 2], k % 2, seen[k / 2][k % 2])),
    };
    let centre = Readings {
        points: core::array::from_fn(|cam| reading(plant, &m[2], cam, seen[2][cam])),
    };
    (lights, centre)
}

/// A tracker whose last body is the true one moved `by` (mm).
fn tracker(m: &[Vector3<f64>; 3], by: &Vector3<f64>) -> Tracker {
    Tracker {
        last: Some(Track {
            centre: m[2] + by,
            normal: Some(unit(&(m[0] - m[1]))),
        }),
        ..Tracker::default()
    }
}

/// A move of `mm` at right angles to both cameras' rays to `x`.
fn across(plant: &Plant, x: &Vector3<f64>, mm: f64) -> Vector3<f64> {
    let ray = |cam: usize| unit(&(x - plant.cameras[cam].position()));
    unit(&ray(0).cross(&ray(1))) * mm
}

/// A marker seen by both cameras passed the stereo check: it anchors the body however
/// far the arm moved since the last capture (an untrained network's move), and the
/// hidden lights are placed from it. Markers seen by one camera only, as far from the
/// track, are refused as an outlier; from a near track they are estimated.
#[test]
fn a_marker_seen_by_both_cameras_anchors_an_estimate_after_a_long_move() {
    let cfg = SimConfig::realistic();
    let mut plant = Plant::new(&cfg, 5).unwrap();
    let m = pose(&mut plant);
    let tol = tolerance_px(cfg.pixel_noise_px);
    // 300 mm: beyond what an estimate may move from its track without an anchor
    let far = across(&plant, &m[2], 1.5 * FAR_MOVES * PRIOR_MOVE_MM);

    // c in both cameras, p in camera 0 only, q hidden: the track far away
    let (mut l, mut c) = readings(&plant, &m, [[true, false], [false, false], [true, true]]);
    let mut t = tracker(&m, &far);
    let fill = plant.fill_markers(&mut l, &mut c, &[0, 1], &mut t);
    assert_eq!(fill.no_fit, None, "{fill:?}");
    assert_eq!(fill.filled + fill.estimated, 3, "{fill:?}");
    let truth = readings(&plant, &m, [[true; 2]; 3]).0;
    for (a, b) in l.points.iter().zip(&truth.points) {
        assert_ne!(a.status, PointStatus::Occluded);
        let off = (a.x - b.x).hypot(a.y - b.y);
        assert!(off <= tol, "{off} px off: {l:?}");
    }
    assert!((t.last.unwrap().centre - m[2]).norm() < 1.0, "{t:?}");

    // every marker in camera 0 only: nothing anchors them
    let only0 = [[true, false]; 3];
    let (mut l, mut c) = readings(&plant, &m, only0);
    let fill = plant.fill_markers(&mut l, &mut c, &[0, 1], &mut tracker(&m, &far));
    assert!(matches!(fill.no_fit, Some(NoFit::Far(_))), "{fill:?}");
    assert!(l.points[1].status == PointStatus::Occluded);
    assert!(l.points[3].status == PointStatus::Occluded);
    let (mut l, mut c) = readings(&plant, &m, only0);
    let near = tracker(&m, &Vector3::zeros());
    let fill = plant.fill_markers(&mut l, &mut c, &[0, 1], &mut near.clone());
    assert_eq!(fill.no_fit, None, "{fill:?}");
    assert_eq!(fill.estimated, 2, "{fill:?}");
}

/// Exact readings (a camera configured without noise) fill a hidden light as the noisy
/// camera does: the fit weighs its residuals by a floor on the noise, never by zero.
#[test]
fn a_noise_free_camera_fills_a_hidden_light() {
    let mut cfg = SimConfig::realistic();
    cfg.pixel_noise_px = 0.0;
    let mut plant = Plant::new(&cfg, 5).unwrap();
    let m = pose(&mut plant);
    // q hidden from camera 1 only: p and c seen by both, the track where the arm is
    let (mut l, mut c) = readings(&plant, &m, [[true, true], [true, false], [true, true]]);
    let fill = plant.fill_markers(&mut l, &mut c, &[0, 1], &mut tracker(&m, &Vector3::zeros()));
    assert_eq!(fill.no_fit, None, "{fill:?}");
    assert_eq!(fill.filled, 1, "{fill:?}");
    let truth = readings(&plant, &m, [[true; 2]; 3]).0;
    let (a, b) = (&l.points[3], &truth.points[3]);
    assert_eq!(a.status, PointStatus::Valid, "{l:?}");
    let off = (a.x - b.x).hypot(a.y - b.y);
    assert!(off <= tolerance_px(0.0), "{off} px off: {l:?}");
}

/// The fit's starts are solved in parallel on a thread of rayon's pool and in turn
/// elsewhere (`fit::Problem::all`): the same fills, tracks and bodies bit for bit, for
/// every pattern of hidden markers, with and without a track. Fails if the parallel path
/// reorders the starts' bodies (the best of equal costs would differ) or drops one.
#[test]
fn the_fill_is_the_same_on_the_pool_and_off_it() {
    let cfg = SimConfig::realistic();
    let mut plant = Plant::new(&cfg, 5).unwrap();
    let m = pose(&mut plant);
    let fills = |plant: &Plant| {
        let mut out = vec![];
        for pattern in 0u32..64 {
            let seen: [[bool; 2]; 3] = core::array::from_fn(|k| {
                core::array::from_fn(|cam| pattern >> (2 * k + cam) & 1 == 1)
            });
            for by in [None, Some(Vector3::new(20.0, -10.0, 5.0))] {
                let (mut l, mut c) = readings(plant, &m, seen);
                let mut t = by.map_or_else(Tracker::default, |by| tracker(&m, &by));
                let fill = plant.fill_markers(&mut l, &mut c, &[0, 1], &mut t);
                out.push(format!("{fill:?} {l:?} {c:?} {t:?}"));
            }
        }
        out
    };
    let off_pool = fills(&plant);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let on_pool = pool.install(|| {
        assert!(rayon::current_thread_index().is_some());
        fills(&plant)
    });
    assert_eq!(off_pool.len(), 128);
    assert!(
        off_pool.iter().any(|f| f.contains("Estimated")),
        "{off_pool:?}"
    );
    assert_eq!(off_pool, on_pool);
}

/// The analytic fit (`Fit::Analytic`, the Python environment's fast physics) fills in what
/// the lab's forward differences fill in: for 12 poses, every pattern of hidden markers,
/// with a track and without, each reading off by up to 0.45 px (the fit's residuals are
/// then not zero, as with the cameras' noise), the same fill (filled, estimated, why not),
/// and the readings it fills in as valid the same to a ten-thousandth of a pixel (the
/// differences' Jacobian, off by its step, stops them a little short of the minimum), but
/// where the readings leave two mirror bodies of the same cost to the rounding (the fill
/// takes either: both put the hidden light within the stereo tolerance). Fails if a row of the analytic
/// Jacobian is wrong (the fits then end elsewhere or fail) or if its convergence stop ends
/// a fit early (they differ in the bulk).
#[test]
fn the_analytic_fit_fills_what_the_differences_fill() {
    let cfg = SimConfig::realistic();
    let tol = tolerance_px(cfg.pixel_noise_px);
    let mut plant = Plant::new(&cfg, 5).unwrap();
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(21);
    let (mut cases, mut valid, mut same) = (0, 0, 0);
    let mut worst: f64 = 0.0;
    for pose_k in 0..12 {
        let m = pose_from(&mut plant, &mut rng);
        for pattern in 0u32..64 {
            let seen: [[bool; 2]; 3] = core::array::from_fn(|k| {
                core::array::from_fn(|cam| pattern >> (2 * k + cam) & 1 == 1)
            });
            for by in [None, Some(Vector3::new(20.0, -10.0, 5.0))] {
                let (mut l0, mut c0) = readings(&plant, &m, seen);
                // a deterministic offset of each coordinate, up to 0.45 px
                for (k, p) in l0.points.iter_mut().chain(c0.points.iter_mut()).enumerate() {
                    let k = (k + pose_k) as f64;
                    p.x += 0.45 * (1.7 * k).sin();
                    p.y += 0.45 * (2.3 * k + 0.5).cos();
                }
                let mut out = vec![];
                for fit in [Fit::Differences, Fit::Analytic] {
                    plant.set_fit(fit);
                    let (mut l, mut c) = (l0, c0);
                    let mut t = by.map_or_else(Tracker::default, |by| tracker(&m, &by));
                    let f = plant.fill_markers(&mut l, &mut c, &[0, 1], &mut t);
                    let mut points = l.points.to_vec();
                    points.extend(c.points);
                    out.push((f, points));
                }
                plant.set_fit(Fit::Differences);
                let ((fa, a), (fb, b)) = (&out[0], &out[1]);
                let what = |f: &Fill| {
                    (
                        f.filled,
                        f.estimated,
                        f.no_fit.as_ref().map(core::mem::discriminant),
                    )
                };
                let case = format!("pose {pose_k}, pattern {pattern}, track {by:?}");
                assert_eq!(what(fa), what(fb), "{case}: {fa:?} / {fb:?}");
                for (x, y) in a.iter().zip(b) {
                    assert_eq!(x.status, y.status, "{case}");
                    let d = (x.x - y.x).hypot(x.y - y.y);
                    match x.status {
                        PointStatus::Valid if !d.is_nan() && d > 0.0 => {
                            valid += 1;
                            worst = worst.max(d);
                            // the same body, or the other of two mirror bodies
                            assert!(
                                d < 1e-4 || (0.1..=tol).contains(&d),
                                "{case}: {x:?} / {y:?}"
                            );
                            same += usize::from(d < 1e-4);
                        }
                        _ => {}
                    }
                }
                cases += 1;
            }
        }
    }
    assert_eq!(cases, 12 * 128);
    eprintln!("{valid} valid fills, {same} within 1e-4 px, the largest difference {worst:e} px");
    assert!(valid > 200, "{valid}");
    assert!(same * 100 >= 80 * valid, "{same} of {valid}");
}
