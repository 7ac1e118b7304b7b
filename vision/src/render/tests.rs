use super::*;
use crate::random::normal_cdf;

fn sensor(w: u32, h: u32) -> Sensor {
    Sensor::machine_vision(w, h)
}

fn stats(v: impl Iterator<Item = f64>) -> (f64, f64, usize) {
    let v: Vec<f64> = v.collect();
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, var.sqrt(), v.len())
}

/// Mean and deviation of a background pixel from the tabulated distribution.
fn table_stats(r: &Renderer<u8>) -> (f64, f64) {
    let (mut m, mut mm, mut total) = (0.0, 0.0, 0.0);
    for (d, p) in r.background_distribution() {
        m += p * d as f64;
        mm += p * (d as f64).powi(2);
        total += p;
    }
    assert!((total - 1.0).abs() < 1e-12);
    (m, (mm - m * m).sqrt())
}

#[test]
fn a_frame_is_a_function_of_its_scene_and_seed() {
    let r = Renderer::<u8>::new(&sensor(64, 48)).unwrap();
    let scene = Scene {
        emitters: vec![Emitter::new([20.3, 30.6], 1.2, 8_000.0)],
        occluders: vec![],
    };
    let a = r.render(&scene, 5).unwrap();
    assert_eq!(a, r.render(&scene, 5).unwrap());
    assert_ne!(a, r.render(&scene, 6).unwrap());
}

#[test]
fn the_background_has_the_sensors_noise() {
    let s = sensor(256, 256);
    let r = Renderer::<u8>::new(&s).unwrap();
    let f = r.render(&Scene::default(), 1).unwrap();
    let (m, sd, _) = stats(f.as_raw().iter().map(|&v| v as f64));
    // mean: offset + g stray = 12.5 DN; variance: g^2 (stray + read^2) + 1/12 rounding
    let want_sd =
        (s.gain_dn_per_e.powi(2) * (s.stray_e + s.read_noise_e.powi(2)) + 1.0 / 12.0).sqrt();
    assert!((m - s.mean_dn(s.stray_e)).abs() < 0.02, "{m}");
    assert!((sd / want_sd - 1.0).abs() < 0.05, "{sd} {want_sd}");
    // and the table agrees with the frame
    let (tm, tsd) = table_stats(&r);
    assert!(
        (tm - m).abs() < 0.01 && (tsd / sd - 1.0).abs() < 0.02,
        "{tm} {tsd}"
    );
}

#[test]
fn a_spots_neighbourhood_is_drawn_like_the_background_where_it_is_dark() {
    // an emitter without electrons: its neighbourhood goes through the per-pixel path
    let r = Renderer::<u8>::new(&sensor(64, 64)).unwrap();
    let scene = Scene {
        emitters: (0..4)
            .map(|i| Emitter::new([12.0 + 13.0 * i as f64, 32.0], 2.0, 0.0))
            .collect(),
        occluders: vec![],
    };
    let (mut all, mut n) = (Vec::new(), 0);
    for seed in 0..40 {
        let f = r.render(&scene, seed).unwrap();
        all.extend(f.as_raw().iter().map(|&v| v as f64));
        n += 1;
    }
    let (m, sd, _) = stats(all.into_iter());
    let (tm, tsd) = table_stats(&r);
    assert!(
        n == 40 && (m - tm).abs() < 0.01 && (sd / tsd - 1.0).abs() < 0.02,
        "{m} {sd}"
    );
}

#[test]
fn a_spot_holds_its_electrons_peaks_at_its_centre_and_saturates() {
    let s = sensor(64, 64);
    let r = Renderer::<u8>::new(&s).unwrap();
    let c = [30.5, 20.5];
    let scene = Scene {
        emitters: vec![Emitter::new(c, 1.3, 20_000.0)],
        occluders: vec![],
    };
    let f = r.render(&scene, 3).unwrap();
    let bg = s.mean_dn(s.stray_e);
    let signal: f64 = f.as_raw().iter().map(|&v| v as f64 - bg).sum();
    // 20,000 e- at 0.05 DN/e-: 1000 DN, give or take the noise of 4096 pixels (about 35 DN)
    assert!((signal - 1000.0).abs() < 60.0, "{signal}");
    let brightest = f.enumerate_pixels().max_by_key(|p| p.2 .0[0]).unwrap();
    assert_eq!((brightest.0, brightest.1), (30, 20));
    // the peak: 20,000 e- times the central pixel's mass
    let mass = (normal_cdf(0.5 / 1.3) - normal_cdf(-0.5 / 1.3)).powi(2);
    let peak = s.mean_dn(20_000.0 * mass + s.stray_e);
    assert!((brightest.2 .0[0] as f64 - peak).abs() < 5.0, "{peak}");
    // with_peak inverts that
    let e = Emitter::with_peak(c, 1.3, 20_000.0 * mass);
    assert!((e.electrons / 20_000.0 - 1.0).abs() < 1e-12);

    // saturation: an 8-bit frame clips at 255, a 16-bit one at the full well
    let bright = Scene {
        emitters: vec![Emitter::new(c, 1.3, 1e6)],
        occluders: vec![],
    };
    let f8 = r.render(&bright, 3).unwrap();
    assert_eq!(f8.get_pixel(30, 20).0[0], 255);
    let s16 = Sensor {
        gain_dn_per_e: 1.0,
        ..s.clone()
    };
    let f16 = Renderer::<u16>::new(&s16)
        .unwrap()
        .render(&bright, 3)
        .unwrap();
    let top = f16.get_pixel(30, 20).0[0] as f64;
    let clip = s16.mean_dn(s16.full_well_e);
    assert!((top - clip).abs() < 4.0 * s16.read_noise_e, "{top} {clip}");
    assert!(f16.as_raw().iter().all(|&v| (v as f64) < clip + 30.0));
}

/// Intensity-weighted mean and variance along x and y of the frame less its background.
fn moments(f: &Frame<u16>, bg: f64) -> ([f64; 2], [f64; 2]) {
    let (mut m0, mut m1, mut m2) = (0.0, [0.0; 2], [0.0; 2]);
    for (x, y, p) in f.enumerate_pixels() {
        let w = p.0[0] as f64 - bg;
        let c = [x as f64 + 0.5, y as f64 + 0.5];
        m0 += w;
        for k in 0..2 {
            m1[k] += w * c[k];
            m2[k] += w * c[k] * c[k];
        }
    }
    let m = [m1[0] / m0, m1[1] / m0];
    (m, [m2[0] / m0 - m[0] * m[0], m2[1] / m0 - m[1] * m[1]])
}

/// A 16-bit 64 x 64 sensor with little noise and no saturation, so that moments and sums
/// are exact to a few hundredths.
fn quiet() -> Sensor {
    Sensor {
        gain_dn_per_e: 1.0,
        read_noise_e: 1.0,
        stray_e: 0.0,
        full_well_e: 1e9,
        ..sensor(64, 64)
    }
}

#[test]
fn motion_smears_a_spot_along_its_path() {
    let s = quiet();
    let r = Renderer::<u16>::new(&s).unwrap();
    let mut e = Emitter::new([32.2, 31.7], 1.5, 1e6);
    e.motion_px = [8.0, 0.0];
    let f = r
        .render(
            &Scene {
                emitters: vec![e],
                occluders: vec![],
            },
            1,
        )
        .unwrap();
    let (m, v) = moments(&f, s.offset_dn);
    assert!(
        (m[0] - 32.2).abs() < 0.02 && (m[1] - 31.7).abs() < 0.02,
        "{m:?}"
    );
    // a uniform smear of length L adds L^2 / 12 to the variance; pixels add 1/12
    let (sx, sy) = (2.25 + 64.0 / 12.0 + 1.0 / 12.0, 2.25 + 1.0 / 12.0);
    assert!((v[0] - sx).abs() < 0.1 && (v[1] - sy).abs() < 0.05, "{v:?}");
}

#[test]
fn occluders_hide_what_is_behind_them() {
    let s = quiet();
    let r = Renderer::<u16>::new(&s).unwrap();
    let signal = |occluders: Vec<Occluder>, depth: f64| {
        let mut e = Emitter::new([30.0, 30.0], 1.5, 1e5);
        e.depth = depth;
        let f = r
            .render(
                &Scene {
                    emitters: vec![e],
                    occluders,
                },
                2,
            )
            .unwrap();
        f.as_raw()
            .iter()
            .map(|&v| v as f64 - s.offset_dn)
            .sum::<f64>()
    };
    let full = signal(vec![], 1.0);
    assert!((full / 1e5 - 1.0).abs() < 0.01, "{full}");
    // a link across the whole spot
    let link = Shape::Capsule {
        a: [0.0, 30.0],
        b: [64.0, 30.0],
        radius: 12.0,
    };
    assert!(signal(vec![Occluder::in_front(link.clone())], 1.0).abs() < 200.0);
    // behind the light it hides nothing
    let behind = Occluder {
        shape: link,
        depth: 2.0,
    };
    assert!((signal(vec![behind], 1.0) / full - 1.0).abs() < 0.01);
    // a polygon over the left half hides half the spot
    let half = Shape::Polygon(vec![[-5.0, -5.0], [30.0, -5.0], [30.0, 70.0], [-5.0, 70.0]]);
    let left = signal(vec![Occluder::in_front(half)], 1.0);
    assert!((left / full - 0.5).abs() < 0.01, "{left} {full}");
}

#[test]
fn shapes_contain_their_inside() {
    let cap = Shape::Capsule {
        a: [0.0, 0.0],
        b: [10.0, 0.0],
        radius: 2.0,
    };
    assert!(cap.contains([5.0, 1.9]) && cap.contains([11.9, 0.0]) && cap.contains([-1.0, 1.0]));
    assert!(!cap.contains([5.0, 2.1]) && !cap.contains([12.1, 0.0]));
    // a concave L
    let l = Shape::Polygon(vec![
        [0.0, 0.0],
        [4.0, 0.0],
        [4.0, 1.0],
        [1.0, 1.0],
        [1.0, 4.0],
        [0.0, 4.0],
    ]);
    assert!(l.contains([0.5, 3.0]) && l.contains([3.0, 0.5]));
    assert!(!l.contains([3.0, 3.0]) && !l.contains([-0.1, 0.5]));
}

#[test]
fn bad_scenes_and_sensors_are_refused() {
    let s = sensor(32, 32);
    let r = Renderer::<u8>::new(&s).unwrap();
    let bad_emitters = [
        Emitter::new([f64::NAN, 1.0], 1.0, 1.0),
        Emitter::new([1.0, 1.0], 0.0, 1.0),
        Emitter::new([1.0, 1.0], 1.0, -1.0),
        Emitter::new([1.0, 1.0], 1.0, f64::INFINITY),
        Emitter {
            motion_px: [f64::NAN, 0.0],
            ..Emitter::new([1.0, 1.0], 1.0, 1.0)
        },
        Emitter {
            depth: f64::NAN,
            ..Emitter::new([1.0, 1.0], 1.0, 1.0)
        },
    ];
    for e in bad_emitters {
        let scene = Scene {
            emitters: vec![e.clone()],
            occluders: vec![],
        };
        assert!(
            matches!(r.render(&scene, 1), Err(VisionError::Parameter { .. })),
            "{e:?}"
        );
    }
    for o in [
        Occluder::in_front(Shape::Polygon(vec![[0.0, 0.0], [1.0, 1.0]])),
        Occluder::in_front(Shape::Capsule {
            a: [0.0, 0.0],
            b: [1.0, f64::NAN],
            radius: 1.0,
        }),
        Occluder::in_front(Shape::Capsule {
            a: [0.0, 0.0],
            b: [1.0, 1.0],
            radius: -1.0,
        }),
        Occluder {
            shape: Shape::Polygon(vec![[0.0, 0.0], [1.0, 1.0], [0.0, 1.0]]),
            depth: f64::NAN,
        },
    ] {
        let scene = Scene {
            emitters: vec![],
            occluders: vec![o],
        };
        assert!(matches!(
            r.render(&scene, 1),
            Err(VisionError::Parameter { .. })
        ));
    }
    assert!(matches!(
        Renderer::<u8>::new(&sensor(0, 10)),
        Err(VisionError::EmptyFrame { .. })
    ));
    for bad in [
        Sensor {
            gain_dn_per_e: f64::NAN,
            ..s.clone()
        },
        Sensor {
            read_noise_e: -1.0,
            ..s.clone()
        },
        Sensor {
            full_well_e: 0.0,
            ..s.clone()
        },
        sensor(1 << 15, 1 << 15),
    ] {
        assert!(matches!(
            Renderer::<u8>::new(&bad),
            Err(VisionError::Parameter { .. })
        ));
    }
    let mut small = Frame::<u8>::new(16, 16);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
    assert!(matches!(
        r.render_into(&Scene::default(), &mut rng, &mut small),
        Err(VisionError::WrongSize { .. })
    ));
}

#[test]
fn spots_off_the_frame_and_overlapping_spots_render() {
    let r = Renderer::<u8>::new(&sensor(40, 30)).unwrap();
    let scene = Scene {
        emitters: vec![
            Emitter::new([-50.0, 10.0], 1.0, 1e4),
            Emitter::new([39.9, 29.9], 1.0, 1e4),
            Emitter::new([10.0, 10.0], 2.0, 1e4),
            Emitter::new([13.0, 11.0], 2.0, 1e4),
        ],
        occluders: vec![],
    };
    let f = r.render(&scene, 1).unwrap();
    // the corner pixel holds 12.6 % of the spot at the frame's edge: 63 DN above 12.5
    assert!(f.get_pixel(39, 29).0[0] > 60);
    // both overlapping spots are there: the pixel between them holds 285 e- of each (28.5
    // DN above 12.5 in all, 14 of one alone)
    assert!(
        f.get_pixel(11, 10).0[0] > 35,
        "{}",
        f.get_pixel(11, 10).0[0]
    );
}

#[test]
fn a_long_smear_keeps_its_electrons_and_a_longer_one_is_refused() {
    let s = Sensor {
        width: 1024,
        ..quiet()
    };
    let r = Renderer::<u16>::new(&s).unwrap();
    let mut e = Emitter::new([512.0, 32.0], 0.5, 2e5);
    e.motion_px = [900.0, 10.0];
    let f = r
        .render(
            &Scene {
                emitters: vec![e.clone()],
                occluders: vec![],
            },
            1,
        )
        .unwrap();
    let signal: f64 = f.as_raw().iter().map(|&v| v as f64 - s.offset_dn).sum();
    // shot noise sqrt(2e5) = 450 e-, read noise 1 e- over 65,536 pixels: 256 e-
    assert!((signal - 2e5).abs() < 3_000.0, "{signal}");
    // the smear runs from x = 62 to 962: both ends lit, beyond them dark
    assert!(f.get_pixel(70, 27).0[0] > 100 && f.get_pixel(955, 36).0[0] > 100);
    assert!(f.get_pixel(40, 27).0[0] < 20 && f.get_pixel(990, 36).0[0] < 20);
    e.motion_px = [2_000.0, 0.0];
    let scene = Scene {
        emitters: vec![e],
        occluders: vec![],
    };
    assert!(matches!(
        r.render(&scene, 1),
        Err(VisionError::Parameter { .. })
    ));
}
