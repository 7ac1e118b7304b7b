//! The valid range of every simulator configuration value, checked at load with the key
//! named: finite numbers, positive where physical, sizes bounded, and a physics step and
//! settle time such that a move costs a bounded number of steps. Owns
//! [`SimConfig::validate`], which the loaders and [`Plant::new`](crate::Plant::new) call.

use super::camera::Camera;
use super::config::SimConfig;
use crate::PlantError as Error;

/// Most physics steps one camera reading may cost (`settle_s / dt_s`).
pub const MAX_STEPS_PER_MOVE: f64 = 100_000.0;

struct Check<'a> {
    key: &'a str,
}

fn err(key: &str, range: &str) -> Error {
    Error::Config(format!("{key} must be {range}"))
}

impl Check<'_> {
    /// `lo < x <= hi` (`open_lo`) or `lo <= x <= hi`, and finite.
    fn within(&self, x: f64, lo: f64, hi: f64, open_lo: bool) -> Result<(), Error> {
        let ok = x.is_finite() && (if open_lo { x > lo } else { x >= lo }) && x <= hi;
        if ok {
            Ok(())
        } else {
            let b = if open_lo { "(" } else { "[" };
            Err(err(
                self.key,
                &format!("a number in {b}{lo}, {hi}] (got {x})"),
            ))
        }
    }
}

fn positive(key: &str, x: f64, hi: f64) -> Result<(), Error> {
    Check { key }.within(x, 0.0, hi, true)
}

fn at_least_zero(key: &str, x: f64, hi: f64) -> Result<(), Error> {
    Check { key }.within(x, 0.0, hi, false)
}

fn between(key: &str, x: f64, lo: f64, hi: f64) -> Result<(), Error> {
    Check { key }.within(x, lo, hi, false)
}

impl SimConfig {
    /// Rejects configurations that cannot work, naming the key and its valid range
    /// (`validate.rs` has every range).
    pub fn validate(&self) -> Result<(), Error> {
        validate(self)
    }
}

/// Checks every value of `c` (see the module).
pub fn validate(c: &SimConfig) -> Result<(), Error> {
    positive("dt_s", c.dt_s, 0.01)?;
    between("settle_s", c.settle_s, c.dt_s, 60.0)?;
    if c.settle_s / c.dt_s > MAX_STEPS_PER_MOVE {
        return Err(err(
            "settle_s",
            &format!("at most {MAX_STEPS_PER_MOVE} physics steps of dt_s"),
        ));
    }
    for (k, v, hi) in [
        ("shoulder_height_mm", c.shoulder_height_mm, 5000.0),
        ("upper_arm_mm", c.upper_arm_mm, 5000.0),
        ("forearm_mm", c.forearm_mm, 5000.0),
        ("hand_mm", c.hand_mm, 2000.0),
        ("light_offset_mm", c.light_offset_mm, 1000.0),
        ("approach_mm", c.approach_mm, 2000.0),
        ("cylinder_radius_mm", c.cylinder_radius_mm, 1000.0),
        ("cylinder_length_mm", c.cylinder_length_mm, 5000.0),
        ("grasp_distance_mm", c.grasp_distance_mm, 1000.0),
        ("grasp_angle_deg", c.grasp_angle_deg, 90.0),
    ] {
        positive(k, v, hi)?;
    }
    // 0 turns occlusion off; negative or NaN is not a radius
    at_least_zero("link_radius_mm", c.link_radius_mm, 1000.0)?;
    at_least_zero("pixel_noise_px", c.pixel_noise_px, 100.0)?;
    if c.joints.len() != 5 {
        return Err(err("joints", "a list of exactly 5 joints"));
    }
    for (i, j) in c.joints.iter().enumerate() {
        let key = |f: &str| format!("joints[{i}].{f}");
        between(&key("min_deg"), j.min_deg, -360.0, 360.0)?;
        between(&key("max_deg"), j.max_deg, -360.0, 360.0)?;
        if j.max_deg <= j.min_deg {
            return Err(err(&key("max_deg"), "greater than min_deg"));
        }
        positive(&key("target_limit"), j.target_limit, 1.0)?;
        positive(&key("servo_limit"), j.servo_limit, 1.0)?;
        at_least_zero(&key("hysteresis_width"), j.hysteresis_width, 0.5)?;
        between(
            &key("hysteresis_asymmetry"),
            j.hysteresis_asymmetry,
            0.0,
            0.99,
        )?;
        positive(&key("natural_freq_hz"), j.natural_freq_hz, 100.0)?;
        positive(&key("damping_ratio"), j.damping_ratio, 10.0)?;
        positive(&key("pressure_tau_s"), j.pressure_tau_s, 10.0)?;
        if 2.0 * std::f64::consts::PI * j.natural_freq_hz * c.dt_s > 0.2 {
            return Err(err(
                &key("natural_freq_hz"),
                "low enough for dt_s (2 pi f dt <= 0.2)",
            ));
        }
    }
    if c.cameras.len() != 2 {
        return Err(err("cameras", "a list of exactly 2 cameras"));
    }
    for (i, cam) in c.cameras.iter().enumerate() {
        let key = |f: &str| format!("cameras[{i}].{f}");
        for r in cam.resolution {
            if !(16..=16384).contains(&r) {
                return Err(err(
                    &key("resolution"),
                    &format!("16 to 16384 pixels a side (got {r})"),
                ));
            }
        }
        positive(&key("focal_px"), cam.focal_px, 100_000.0)?;
        for k in 0..3 {
            between(&key("position_mm"), cam.position_mm[k], -1e5, 1e5)?;
            between(&key("look_at_mm"), cam.look_at_mm[k], -1e5, 1e5)?;
        }
        for k in cam.distortion {
            between(&key("distortion"), k, -10.0, 10.0)?;
        }
        let d: f64 = (0..3)
            .map(|k| (cam.look_at_mm[k] - cam.position_mm[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        if d <= 1.0 {
            return Err(err(&key("look_at_mm"), "different from position_mm"));
        }
        // the camera must see the middle of the workspace
        let mid = crate::Vector3::new(
            c.upper_arm_mm * 0.9,
            0.0,
            c.shoulder_height_mm + 0.2 * c.upper_arm_mm,
        );
        if Camera::new(cam).project(&mid).is_none() {
            return Err(Error::Config(format!(
                "{} makes the camera see nothing of the workspace",
                key("look_at_mm")
            )));
        }
    }
    let d = &c.drift;
    at_least_zero(
        "drift.temperature_amplitude_deg",
        d.temperature_amplitude_deg,
        90.0,
    )?;
    positive("drift.temperature_period_s", d.temperature_period_s, 1e9)?;
    at_least_zero("drift.wear_gain_per_rad", d.wear_gain_per_rad, 1.0)?;
    between(
        "drift.wear_offset_deg_per_rad",
        d.wear_offset_deg_per_rad,
        -10.0,
        10.0,
    )?;
    between("drift.wear_gain_max", d.wear_gain_max, 0.0, 0.9)?;
    at_least_zero("drift.wear_offset_max_deg", d.wear_offset_max_deg, 1e6)?;
    let r = &c.realism;
    at_least_zero("realism.sag_shoulder_deg", r.sag_shoulder_deg, 30.0)?;
    at_least_zero("realism.sag_elbow_deg", r.sag_elbow_deg, 30.0)?;
    at_least_zero("realism.load_width_gain", r.load_width_gain, 5.0)?;
    at_least_zero("realism.process_noise_deg", r.process_noise_deg, 10.0)?;
    between("realism.creep_fraction", r.creep_fraction, 0.0, 0.5)?;
    if r.creep_fraction > 0.0 {
        positive("realism.creep_tau_s", r.creep_tau_s, 3600.0)?;
    } else {
        at_least_zero("realism.creep_tau_s", r.creep_tau_s, 3600.0)?;
    }
    between("realism.hysteresis_skew", r.hysteresis_skew, 0.0, 1.0)?;
    between("realism.outlier_rate", r.outlier_rate, 0.0, 0.5)?;
    between("realism.dropout_rate", r.dropout_rate, 0.0, 0.5)?;
    let x = &c.pixels;
    positive("pixels.exposure_ms", x.exposure_ms, 1000.0)?;
    at_least_zero("pixels.led_electrons_per_ms", x.led_electrons_per_ms, 1e6)?;
    at_least_zero("pixels.led_diameter_mm", x.led_diameter_mm, 100.0)?;
    between("pixels.blur_px", x.blur_px, 0.1, 20.0)?;
    at_least_zero("pixels.read_noise_e", x.read_noise_e, 1000.0)?;
    at_least_zero(
        "pixels.stray_electrons_per_ms",
        x.stray_electrons_per_ms,
        1e4,
    )?;
    positive("pixels.gate_px", x.gate_px, 50.0)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every number of the default configuration, with its key path.
    fn numbers(v: &toml::Value, path: String, out: &mut Vec<String>) {
        match v {
            toml::Value::Table(t) => {
                for (k, x) in t {
                    let p = if path.is_empty() {
                        k.clone()
                    } else {
                        format!("{path}.{k}")
                    };
                    numbers(x, p, out);
                }
            }
            toml::Value::Array(a) => {
                for (i, x) in a.iter().enumerate() {
                    numbers(x, format!("{path}[{i}]"), out);
                }
            }
            toml::Value::Float(_) | toml::Value::Integer(_) => out.push(path),
            _ => {}
        }
    }

    fn set(v: &mut toml::Value, path: &str, x: toml::Value) {
        let mut cur = v;
        for part in path.split('.') {
            let (name, idx) = match part.split_once('[') {
                Some((n, rest)) => (
                    n,
                    Some(rest.trim_end_matches(']').parse::<usize>().unwrap()),
                ),
                None => (part, None),
            };
            cur = cur.get_mut(name).unwrap();
            if let Some(i) = idx {
                cur = cur.get_mut(i).unwrap();
            }
        }
        *cur = x;
    }

    /// NaN, infinity, a negative and a huge value in every numeric field: each is rejected
    /// with an error naming the field, or (for the few fields where such a value is
    /// meaningful) accepted; nothing is accepted silently that the simulator cannot use.
    #[test]
    fn every_field_rejects_meaningless_values_by_name() {
        let base = toml::Value::try_from(SimConfig::default()).unwrap();
        let mut keys = vec![];
        numbers(&base, String::new(), &mut keys);
        assert!(keys.len() > 60, "{} numeric fields", keys.len());
        // fields where a negative value has a meaning (angles, coordinates, coefficients)
        let signed = [
            "min_deg",
            "max_deg",
            "position_mm",
            "look_at_mm",
            "distortion",
            "wear_offset_deg_per_rad",
        ];
        for key in &keys {
            let field = key.rsplit('.').next().unwrap();
            let name = field.split('[').next().unwrap();
            for (bad, label) in [
                (toml::Value::Float(f64::NAN), "nan"),
                (toml::Value::Float(f64::INFINITY), "inf"),
                (toml::Value::Float(-1.0), "-1"),
                (toml::Value::Float(1e300), "1e300"),
            ] {
                if label == "-1" && signed.contains(&name) {
                    continue;
                }
                let mut v = base.clone();
                // integer fields (resolution) get integer values
                let bad = match (&bad, base_is_int(&base, key)) {
                    (_, true) => match label {
                        "-1" => toml::Value::Integer(-1),
                        "1e300" | "inf" => toml::Value::Integer(i64::MAX),
                        _ => toml::Value::Integer(0),
                    },
                    _ => bad,
                };
                set(&mut v, key, bad);
                let text = toml::to_string(&v).unwrap();
                let err = SimConfig::from_toml_str(&text)
                    .err()
                    .unwrap_or_else(|| panic!("{key} = {label} was accepted"))
                    .to_string();
                let short = key.split('[').next().unwrap();
                assert!(
                    err.contains(name) || err.contains(short),
                    "{key} = {label}: the error does not name it: {err}"
                );
            }
        }
    }

    /// True when the default value at `key` is an integer.
    fn base_is_int(base: &toml::Value, key: &str) -> bool {
        let mut cur = base;
        for part in key.split('.') {
            let (name, idx) = match part.split_once('[') {
                Some((n, rest)) => (
                    n,
                    Some(rest.trim_end_matches(']').parse::<usize>().unwrap()),
                ),
                None => (part, None),
            };
            cur = cur.get(name).unwrap();
            if let Some(i) = idx {
                cur = cur.get(i).unwrap();
            }
        }
        matches!(cur, toml::Value::Integer(_))
    }

    #[test]
    fn a_move_costs_a_bounded_number_of_steps() {
        let c = SimConfig {
            dt_s: 1e-9,
            ..Default::default()
        };
        assert!(validate(&c).unwrap_err().to_string().contains("settle_s"));
        let c = SimConfig {
            settle_s: 1e7,
            ..Default::default()
        };
        assert!(validate(&c).unwrap_err().to_string().contains("settle_s"));
        assert!(validate(&SimConfig::default()).is_ok());
    }
}
