use super::*;
use crate::render::{Emitter, Renderer, Scene, Sensor};

/// A flat frame of `level` with the pixels `lit` at `value`.
fn flat(w: u32, h: u32, level: u8, lit: &[(u32, u32)], value: u8) -> Frame<u8> {
    let mut f = Frame::from_pixel(w, h, image::Luma([level]));
    for &(x, y) in lit {
        f.put_pixel(x, y, image::Luma([value]));
    }
    f
}

fn known(level: f64) -> DetectorParams {
    DetectorParams {
        background: BackgroundLevel::Known {
            level_dn: level,
            noise_dn: 0.5,
        },
        ..DetectorParams::default()
    }
}

/// Five lights on the plant's 1024 x 768 camera.
fn five() -> (Sensor, Vec<[f64; 2]>, Frame<u8>) {
    let s = Sensor::machine_vision(1024, 768);
    let truth = vec![
        [100.3, 80.7],
        [512.5, 384.5],
        [900.9, 700.1],
        [300.25, 600.75],
        [700.6, 150.4],
    ];
    let scene = Scene {
        emitters: truth
            .iter()
            .map(|&c| Emitter::new(c, 1.3, 30_000.0))
            .collect(),
        occluders: vec![],
    };
    let f = Renderer::<u8>::new(&s).unwrap().render(&scene, 9).unwrap();
    (s, truth, f)
}

#[test]
fn finds_every_light_at_its_centre_and_nothing_else() {
    let (s, truth, f) = five();
    let d = Detector::new(s.width, s.height, DetectorParams::default())
        .unwrap()
        .detect(&f)
        .unwrap();
    assert_eq!(d.blobs.len(), 5, "{:?}", d.rejected);
    for t in &truth {
        let b = d
            .blobs
            .iter()
            .find(|b| (b.centre[0] - t[0]).hypot(b.centre[1] - t[1]) < 0.1)
            .unwrap_or_else(|| panic!("{t:?} not found in {:?}", d.blobs));
        assert!(!b.saturated && b.elongation < 1.3, "{b:?}");
    }
    // the background estimate: 12.5 DN, 0.55 DN (read, shot and rounding noise)
    assert!((d.background_dn - 12.5).abs() < 0.05, "{}", d.background_dn);
    assert!((d.noise_dn - 0.55).abs() < 0.05, "{}", d.noise_dn);
    assert!(d
        .rejected
        .iter()
        .all(|(b, r)| *r == Rejection::TooSmall && b.area_px < 3));
}

#[test]
fn components_are_eight_connected_and_joined_through_later_rows() {
    // a diagonal line, and a U whose arms meet only at its bottom row
    let diagonal = [(2, 2), (3, 3), (4, 4)];
    let u = [
        (10, 2),
        (14, 2),
        (10, 3),
        (14, 3),
        (10, 4),
        (11, 4),
        (12, 4),
        (13, 4),
        (14, 4),
    ];
    let lit: Vec<(u32, u32)> = diagonal.iter().chain(&u).copied().collect();
    let f = flat(20, 8, 10, &lit, 100);
    let d = Detector::new(
        20,
        8,
        DetectorParams {
            max_elongation: 100.0,
            window_margin_px: 0,
            ..known(10.0)
        },
    )
    .unwrap()
    .detect(&f)
    .unwrap();
    let mut areas: Vec<usize> = d.blobs.iter().map(|b| b.area_px).collect();
    areas.sort();
    assert_eq!(areas, vec![3, 9], "{d:?}");
    let diag = d.blobs.iter().find(|b| b.area_px == 3).unwrap();
    assert_eq!(diag.centre, [3.5, 3.5]);
    assert_eq!(diag.bounds, [2, 2, 5, 5]);
    assert_eq!(diag.signal_dn, 270.0);
    // the U's centre: mean of its pixels' centres
    let ub = d.blobs.iter().find(|b| b.area_px == 9).unwrap();
    assert!(
        (ub.centre[0] - 12.5).abs() < 1e-12
            && (ub.centre[1] - (2.5 * 2.0 + 3.5 * 2.0 + 4.5 * 5.0) / 9.0).abs() < 1e-12
    );
}

#[test]
fn small_large_elongated_and_crowded_blobs_are_rejected() {
    let s = Sensor::machine_vision(200, 120);
    let r = Renderer::<u8>::new(&s).unwrap();
    let mut smeared = Emitter::new([60.0, 30.0], 1.2, 30_000.0);
    smeared.motion_px = [10.0, 4.0];
    let scene = Scene {
        emitters: vec![
            Emitter::new([20.0, 20.0], 1.2, 30_000.0), // a light
            Emitter::new([150.0, 60.0], 12.0, 1e7),    // a lamp
            smeared,                                   // a light moving
            Emitter::new([40.0, 90.0], 1.2, 30_000.0), // two lights 6 px apart
            Emitter::new([46.0, 90.0], 1.2, 30_000.0),
        ],
        occluders: vec![],
    };
    let mut f = r.render(&scene, 4).unwrap();
    f.put_pixel(100, 100, image::Luma([200])); // a hot pixel
    let d = Detector::new(
        200,
        120,
        DetectorParams {
            max_area_px: 200,
            ..DetectorParams::default()
        },
    )
    .unwrap()
    .detect(&f)
    .unwrap();
    assert_eq!(d.blobs.len(), 1, "{d:?}");
    assert!((d.blobs[0].centre[0] - 20.0).abs() < 0.1);
    let why = |x: f64, y: f64| {
        d.rejected
            .iter()
            .filter(|(b, _)| (b.centre[0] - x).abs() < 8.0 && (b.centre[1] - y).abs() < 8.0)
            .map(|(_, r)| *r)
            .collect::<Vec<_>>()
    };
    assert_eq!(why(100.5, 100.5), vec![Rejection::TooSmall]);
    assert_eq!(why(150.0, 60.0), vec![Rejection::TooLarge]);
    assert_eq!(why(60.0, 30.0), vec![Rejection::Elongated]);
    // the pair: either one merged blob (elongated) or two whose windows meet
    let pair = why(43.0, 90.0);
    assert!(
        pair == vec![Rejection::Elongated] || pair == vec![Rejection::Crowded, Rejection::Crowded],
        "{pair:?}"
    );
}

#[test]
fn a_saturated_light_is_found_and_flagged() {
    let s = Sensor::machine_vision(64, 64);
    let f = Renderer::<u8>::new(&s)
        .unwrap()
        .render(
            &Scene {
                emitters: vec![Emitter::new([30.4, 33.3], 1.5, 2e5)],
                occluders: vec![],
            },
            1,
        )
        .unwrap();
    let d = Detector::new(64, 64, DetectorParams::default())
        .unwrap()
        .detect(&f)
        .unwrap();
    assert_eq!(d.blobs.len(), 1);
    let b = &d.blobs[0];
    assert!(b.saturated && b.peak_dn == 255);
    // a symmetric clip leaves the centre where it was
    assert!(
        (b.centre[0] - 30.4).abs() < 0.05 && (b.centre[1] - 33.3).abs() < 0.05,
        "{b:?}"
    );
}

#[test]
fn bad_frames_and_parameters_are_refused() {
    assert!(matches!(
        Detector::new(0, 5, DetectorParams::default()),
        Err(VisionError::EmptyFrame { .. })
    ));
    let d = Detector::new(8, 4, DetectorParams::default()).unwrap();
    assert!(matches!(
        d.detect_samples::<u8>(8, 4, &[]),
        Err(VisionError::EmptyFrame { .. })
    ));
    assert!(matches!(
        d.detect_samples(8, 4, &[0u8; 31]),
        Err(VisionError::WrongSize { got_len: 31, .. })
    ));
    assert!(matches!(
        d.detect(&Frame::<u16>::new(4, 8)),
        Err(VisionError::WrongSize { .. })
    ));
    assert!(d
        .detect_samples(8, 4, &[0u16; 32])
        .unwrap()
        .blobs
        .is_empty());
    for p in [
        DetectorParams {
            threshold_sigmas: f64::NAN,
            ..DetectorParams::default()
        },
        DetectorParams {
            min_threshold_dn: -1.0,
            ..DetectorParams::default()
        },
        DetectorParams {
            min_area_px: 0,
            ..DetectorParams::default()
        },
        DetectorParams {
            min_area_px: 10,
            max_area_px: 5,
            ..DetectorParams::default()
        },
        DetectorParams {
            max_elongation: 0.5,
            ..DetectorParams::default()
        },
        known(f64::NAN),
        DetectorParams {
            background: BackgroundLevel::Known {
                level_dn: 1.0,
                noise_dn: f64::INFINITY,
            },
            ..DetectorParams::default()
        },
    ] {
        assert!(
            matches!(
                Detector::new(8, 4, p.clone()),
                Err(VisionError::Parameter { .. })
            ),
            "{p:?}"
        );
    }
}

#[test]
fn a_bright_frame_is_one_large_blob_not_a_failure() {
    // every pixel above a known dark level: one component, too large
    let f = flat(64, 48, 200, &[], 0);
    let d = Detector::new(64, 48, known(10.0))
        .unwrap()
        .detect(&f)
        .unwrap();
    assert!(d.blobs.is_empty());
    assert_eq!(d.rejected.len(), 1);
    assert_eq!(d.rejected[0].1, Rejection::TooLarge);
    assert_eq!(d.rejected[0].0.area_px, 64 * 48);
}
