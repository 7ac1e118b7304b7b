//! Small 3-vector maths (mm, unit vectors) for the kinematics, cameras and occlusion.

/// A 3-vector (mm, or a unit direction).
pub type V3 = [f64; 3];

/// `a - b`.
pub fn sub(a: &V3, b: &V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `a + b`.
pub fn add(a: &V3, b: &V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// `s a`.
pub fn scale(a: &V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// `a . b`.
pub fn dot(a: &V3, b: &V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `a x b`.
pub fn cross(a: &V3, b: &V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `|a|`.
pub fn norm(a: &V3) -> f64 {
    dot(a, a).sqrt()
}

/// `a / |a|`.
pub fn unit(a: &V3) -> V3 {
    scale(a, 1.0 / norm(a))
}

/// The angle between `a` and `b` (degrees).
pub fn angle_deg(a: &V3, b: &V3) -> f64 {
    (dot(a, b) / (norm(a) * norm(b)))
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees()
}

/// Distance from point `p` to the segment `a`-`b`.
pub fn segment_distance(p: &V3, a: &V3, b: &V3) -> f64 {
    let ab = sub(b, a);
    let t = (dot(&sub(p, a), &ab) / dot(&ab, &ab)).clamp(0.0, 1.0);
    norm(&sub(p, &add(a, &scale(&ab, t))))
}

/// Closest distance between segments `p0`-`p1` and `q0`-`q1` (sampled along the first at 41
/// points; the links are short against the cameras' distance).
pub fn segments_distance(p0: &V3, p1: &V3, q0: &V3, q1: &V3) -> f64 {
    let mut best = f64::INFINITY;
    for i in 0..=40 {
        let t = i as f64 / 40.0;
        let p = add(p0, &scale(&sub(p1, p0), t));
        best = best.min(segment_distance(&p, q0, q1));
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn by_hand() {
        assert_eq!(cross(&[1.0, 0.0, 0.0], &[0.0, 1.0, 0.0]), [0.0, 0.0, 1.0]);
        assert!((angle_deg(&[1.0, 0.0, 0.0], &[1.0, 1.0, 0.0]) - 45.0).abs() < 1e-9);
        assert!(
            (segment_distance(&[0.0, 1.0, 0.0], &[-1.0, 0.0, 0.0], &[1.0, 0.0, 0.0]) - 1.0).abs()
                < 1e-12
        );
        // beyond the end: distance to the end point
        assert!(
            (segment_distance(&[3.0, 0.0, 0.0], &[-1.0, 0.0, 0.0], &[1.0, 0.0, 0.0]) - 2.0).abs()
                < 1e-12
        );
        let d = segments_distance(
            &[0.0, -1.0, 1.0],
            &[0.0, 1.0, 1.0],
            &[-1.0, 0.0, 0.0],
            &[1.0, 0.0, 0.0],
        );
        assert!((d - 1.0).abs() < 1e-12, "{d}");
    }
}
