//! The detector's centroid on the nominal blob is within 1.5x the Cramér-Rao bound (median
//! distance error), and the measurement tells a worse centroid apart: neither the
//! unweighted mean of the lit pixels nor the weighted mean without the background's
//! subtraction comes within it.

use trn_vision::accuracy::{measure, Blob};
use trn_vision::{Centroid, Sensor};

const FRAMES: usize = 1_000;

#[test]
fn the_detectors_centroid_is_within_one_and_a_half_times_the_bound() {
    let sensor = Sensor::machine_vision(1024, 768);
    let a = measure(&sensor, &Blob::nominal(), Centroid::Weighted, FRAMES, 11).unwrap();
    assert_eq!(a.missed, 0);
    // the bound: 0.009 px per axis, so an estimator at it has a median distance error of
    // 0.0106 px; the detector is at 1.3x (docs/results/vision.md)
    assert!((a.bound_px - 0.009).abs() < 0.0005, "{}", a.bound_px);
    assert!(a.p50_ratio() < 1.5, "{a:?}");
    // no estimator beats the bound by much: a measurement below it is a broken measurement
    assert!(a.p50_ratio() > 0.9, "{a:?}");
    assert!(a.p95_px > a.p50_px);
}

#[test]
fn an_unweighted_or_unsubtracted_centroid_fails_the_bound() {
    let sensor = Sensor::machine_vision(1024, 768);
    for c in [Centroid::Unweighted, Centroid::WeightedRaw] {
        let a = measure(&sensor, &Blob::nominal(), c, FRAMES, 11).unwrap();
        assert!(a.p50_ratio() > 3.0, "{c:?}: {a:?}");
    }
}
