//! Segment distances and angles of 3-vectors (mm, or unit directions) for the kinematics,
//! the cameras and occlusion: what `nalgebra::Vector3` has no method for in this form.

use nalgebra::Vector3;

/// `a / |a|`, as `a * (1 / |a|)`: the one reciprocal times each component (not
/// `Vector3::normalize`, which divides each component, rounding otherwise).
pub fn unit(a: &Vector3<f64>) -> Vector3<f64> {
    a * (1.0 / a.norm())
}

/// The angle between `a` and `b` (degrees).
pub fn angle_deg(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    (a.dot(b) / (a.norm() * b.norm()))
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees()
}

/// Distance from point `p` to the segment `a`-`b`.
pub fn segment_distance(p: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    let ab = b - a;
    let t = ((p - a).dot(&ab) / ab.dot(&ab)).clamp(0.0, 1.0);
    (p - (a + ab * t)).norm()
}

/// Closest distance between segments `p0`-`p1` and `q0`-`q1` (sampled along the first at 41
/// points; the links are short against the cameras' distance).
pub fn segments_distance(
    p0: &Vector3<f64>,
    p1: &Vector3<f64>,
    q0: &Vector3<f64>,
    q1: &Vector3<f64>,
) -> f64 {
    let mut best = f64::INFINITY;
    for i in 0..=40 {
        let t = i as f64 / 40.0;
        let p = p0 + (p1 - p0) * t;
        best = best.min(segment_distance(&p, q0, q1));
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn by_hand() {
        let v = Vector3::new;
        assert!((angle_deg(&v(1.0, 0.0, 0.0), &v(1.0, 1.0, 0.0)) - 45.0).abs() < 1e-9);
        assert!(
            (segment_distance(&v(0.0, 1.0, 0.0), &v(-1.0, 0.0, 0.0), &v(1.0, 0.0, 0.0)) - 1.0)
                .abs()
                < 1e-12
        );
        // beyond the end: distance to the end point
        assert!(
            (segment_distance(&v(3.0, 0.0, 0.0), &v(-1.0, 0.0, 0.0), &v(1.0, 0.0, 0.0)) - 2.0)
                .abs()
                < 1e-12
        );
        let d = segments_distance(
            &v(0.0, -1.0, 1.0),
            &v(0.0, 1.0, 1.0),
            &v(-1.0, 0.0, 0.0),
            &v(1.0, 0.0, 0.0),
        );
        assert!((d - 1.0).abs() < 1e-12, "{d}");
        // the reciprocal times each component, as the plant has always computed it
        let a = v(3.0, 7.0, 11.0);
        let r = 1.0 / (3.0f64 * 3.0 + 7.0 * 7.0 + 11.0 * 11.0).sqrt();
        assert_eq!(unit(&a), v(3.0 * r, 7.0 * r, 11.0 * r));
    }

    /// The plant's figures are bit for bit those of the hand-written formulas nalgebra's
    /// operations replaced: the same operations in the same order (a newer nalgebra that
    /// sums a dot product otherwise fails here, not in the golden curves).
    #[test]
    fn nalgebra_computes_as_the_hand_written_formulas() {
        use rand_core::SeedableRng;
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(11);
        let mut draw = || {
            Vector3::from_fn(|_, _| {
                crate::uniform(&mut rng, -1.0, 1.0)
                    * 10f64.powi(crate::uniform(&mut rng, -3.0, 4.0) as i32)
            })
        };
        for _ in 0..10_000 {
            let (a, b, s) = (draw(), draw(), draw()[0]);
            let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
            assert_eq!(a.dot(&b).to_bits(), dot.to_bits());
            let sq = a[0] * a[0] + a[1] * a[1] + a[2] * a[2];
            assert_eq!(a.norm().to_bits(), sq.sqrt().to_bits());
            let cross = [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ];
            let same =
                |v: Vector3<f64>, w: [f64; 3]| (0..3).all(|i| v[i].to_bits() == w[i].to_bits());
            assert!(same(a.cross(&b), cross));
            assert!(same(a + b, [a[0] + b[0], a[1] + b[1], a[2] + b[2]]));
            assert!(same(a - b, [a[0] - b[0], a[1] - b[1], a[2] - b[2]]));
            assert!(same(a * s, [a[0] * s, a[1] * s, a[2] * s]));
            assert!(same(a / s, [a[0] / s, a[1] / s, a[2] / s]));
        }
    }
}
