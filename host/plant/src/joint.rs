//! One pneumatic joint: servo drive unit (12-bit command, saturation, first-order pressure
//! lag), rate-independent asymmetric hysteresis, and second-order dynamics.
//!
//! **Hysteresis model: Prandtl-Ishlinskii with asymmetric play operators.** The static map
//! from pressure difference to equilibrium angle is a weighted sum of a linear term and
//! `PLAYS` play (backlash) operators of graded radii. It was chosen over Preisach (a 2-D
//! density to identify, costly to evaluate) and Maxwell-slip (equivalent to PI for a
//! rate-independent loop, but parameterised by forces): PI is rate independent, has nested
//! minor loops as Fig. 8.2's tubes show, its loop width is one parameter (the sum of the
//! operators' contributions), and width 0 collapses it to a single-valued curve.
//! `hysteresis_asymmetry` `a`: each play operator lags by `(1 + a) r` on the way up and
//! `(1 - a) r` on the way down. That is a symmetric play operator of radius `r` whose output
//! is shifted by `-a r` (`y + a r` stays within `r` of the input), so the "asymmetry" only
//! moves the whole loop by a constant: its two branches remain mirror images of each other,
//! and a learned pressure absorbs the offset. (Branches of really different shape are the
//! realistic plant's business.) A static `tanh` shaping after the operators makes the
//! pressure-angle relation nonlinear, as the rubber tubes' is.

use super::config::JointConfig;

/// Play operators per joint.
pub const PLAYS: usize = 6;
const SHAPE: f64 = 1.1;

/// `SHAPE.tanh()`, computed once by the same libm call (a literal could differ from this
/// platform's `tanh` in the last bit: the runs' figures are reproduced bit for bit).
fn tanh_shape() -> f64 {
    static T: std::sync::OnceLock<f64> = std::sync::OnceLock::new();
    *T.get_or_init(|| SHAPE.tanh())
}

/// `(-dt / tau).exp()`, the creep's decay over one step: the same every step of a joint, so
/// the last one is kept (per thread) and the call made only when `dt` or `tau` changes.
fn creep_decay(dt: f64, tau: f64) -> f64 {
    use std::cell::Cell;
    type Last = Cell<Option<(u64, u64, f64)>>;
    thread_local!(static LAST: Last = const { Cell::new(None) });
    let key = (dt.to_bits(), tau.to_bits());
    LAST.with(|last| match last.get() {
        Some((d, t, v)) if (d, t) == key => v,
        _ => {
            let v = (-dt / tau).exp();
            last.set(Some((key.0, key.1, v)));
            v
        }
    })
}

/// The 12-bit servo command for a normalised pressure difference.
pub fn raw_of(p: f64) -> u16 {
    (((p.clamp(-1.0, 1.0) + 1.0) * 0.5 * 4095.0).round() as u16).min(4095)
}

/// The normalised pressure difference of a 12-bit value.
pub fn pressure_of(raw: u16) -> f64 {
    raw.min(4095) as f64 / 4095.0 * 2.0 - 1.0
}

/// A joint's state.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Joint {
    cfg: JointConfig,
    /// Commanded pressure after saturation (normalised).
    command: f64,
    /// Pressure in the tubes (normalised), lagging the command.
    pressure: f64,
    /// Play operator outputs.
    plays: [f64; PLAYS],
    radii: [f64; PLAYS],
    weight_linear: f64,
    weight_play: f64,
    /// Joint angle and velocity (radians, rad/s).
    angle: f64,
    velocity: f64,
    /// Cumulative travel (radians), for wear.
    pub travel: f64,
    /// Extra offset (radians) from drift and wear, set by the plant.
    pub offset: f64,
    /// Gain factor from wear, set by the plant.
    pub gain: f64,
    /// Effects of the real arm ([`crate::RealismConfig`]), set by the plant.
    pub effects: JointEffects,
    /// Slow part of the equilibrium still to arrive (creep, radians).
    creep: f64,
    /// The equilibrium of the previous step (for the creep).
    eq_last: f64,
}

/// A joint's share of the real arm's effects.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct JointEffects {
    /// Bulge of the generalised play operators' envelopes (see `update_plays`).
    pub skew: f64,
    /// Multiplies the loop's contribution (the load-dependent width), 1 without load.
    pub width_scale: f64,
    /// This move's random offset of the equilibrium (radians).
    pub process_offset: f64,
    /// Fraction of every equilibrium change that arrives by creep.
    pub creep_fraction: f64,
    /// Creep time constant (s).
    pub creep_tau_s: f64,
}

/// What both kinds of step keep of a joint for many steps of one length: the play
/// operators' lags, the creep's decay and the joint's range ([`Joint::kept`]).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Kept {
    /// Each play operator's lag on the way up and on the way down.
    ups: [f64; PLAYS],
    downs: [f64; PLAYS],
    /// The creep's decay over one step (0 without creep).
    creep_decay: f64,
    /// The middle of the joint's range and half its span (radians).
    mid: f64,
    half: f64,
    /// The step (s).
    dt: f64,
}

/// The constants of a joint's physics step of one length ([`Joint::step_constants`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepConstants {
    kept: Kept,
    /// The drive's pressure lag per step: `dt / pressure_tau_s`, at most 1.
    lag: f64,
    /// `wn^2` and `2 zeta wn` of the joint's dynamics.
    stiffness: f64,
    damping: f64,
}

/// The constants of a joint's exact step of one length ([`Joint::exact_constants`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExactConstants {
    kept: Kept,
    /// The drive's pressure lag over one step, `exp(-dt / pressure_tau_s)`.
    decay: f64,
    /// The unforced joint's transition over one step, `exp(A dt)`.
    phi: [[f64; 2]; 2],
    /// `2 zeta / wn`: the steady lag behind a target moving at unit rate.
    lag_per_rate: f64,
}

impl JointEffects {
    /// No effect.
    pub const NONE: JointEffects = JointEffects {
        skew: 0.0,
        width_scale: 1.0,
        process_offset: 0.0,
        creep_fraction: 0.0,
        creep_tau_s: 0.0,
    };
}

impl Joint {
    /// A joint at rest at zero pressure, on its ascending branch.
    pub fn new(cfg: &JointConfig) -> Joint {
        // Radii spread over (0, 1]; a full cycle over [-1, 1] opens each play operator by
        // 2 r (mean of both directions), so the PI output gap is
        // weight_play * sum(2 r_i) / PLAYS, and its span is 2 (weights sum to 1).
        let mut radii = [0.0; PLAYS];
        for (i, r) in radii.iter_mut().enumerate() {
            *r = (i + 1) as f64 / PLAYS as f64 * 0.5;
        }
        let mean_gap = radii.iter().map(|r| 2.0 * r).sum::<f64>() / PLAYS as f64;
        // gap of the angle as a fraction of the range: the output span is 2 (in PI units),
        // so the gap fraction is weight_play * mean_gap / 2, corrected for the tanh shaping
        // at the centre (slope SHAPE / tanh(SHAPE)).
        let slope = SHAPE / tanh_shape();
        let weight_play = (2.0 * cfg.hysteresis_width / (mean_gap * slope)).min(0.95);
        let mut j = Joint {
            cfg: cfg.clone(),
            command: 0.0,
            pressure: 0.0,
            plays: [0.0; PLAYS],
            radii,
            weight_linear: 1.0 - weight_play,
            weight_play,
            angle: 0.0,
            velocity: 0.0,
            travel: 0.0,
            offset: 0.0,
            gain: 1.0,
            effects: JointEffects::NONE,
            creep: 0.0,
            eq_last: 0.0,
        };
        j.angle = j.equilibrium();
        j.eq_last = j.angle;
        j
    }

    /// The configuration.
    pub fn config(&self) -> &JointConfig {
        &self.cfg
    }

    /// Servo drive input: a 12-bit command. Returns (raw pressure now, saturated).
    pub fn command_raw(&mut self, raw: u16) -> (u16, bool) {
        let p = pressure_of(raw);
        let lim = self.cfg.servo_limit;
        let saturated = p.abs() > lim;
        self.command = p.clamp(-lim, lim);
        (raw_of(self.pressure), saturated)
    }

    /// The command in force (normalised, after saturation).
    pub fn commanded(&self) -> f64 {
        self.command
    }

    /// The pressure in the tubes (normalised).
    pub fn pressure(&self) -> f64 {
        self.pressure
    }

    /// The joint angle (radians).
    pub fn angle(&self) -> f64 {
        self.angle
    }

    /// The joint's angular velocity (rad/s).
    pub fn velocity(&self) -> f64 {
        self.velocity
    }

    /// The joint angle (degrees).
    pub fn angle_deg(&self) -> f64 {
        self.angle.to_degrees()
    }

    fn update_plays(&mut self) {
        let (ups, downs) = self.play_lags();
        self.update_plays_with(&ups, &downs);
    }

    /// Each play operator's lag on the way up, `(1 + a) r`, and on the way down, `(1 - a) r`.
    fn play_lags(&self) -> ([f64; PLAYS], [f64; PLAYS]) {
        let a = self.cfg.hysteresis_asymmetry;
        let (mut ups, mut downs) = ([0.0; PLAYS], [0.0; PLAYS]);
        for ((up, down), r) in ups.iter_mut().zip(downs.iter_mut()).zip(self.radii.iter()) {
            *up = r * (1.0 + a);
            *down = r * (1.0 - a);
        }
        (ups, downs)
    }

    fn update_plays_with(&mut self, ups: &[f64; PLAYS], downs: &[f64; PLAYS]) {
        let x = self.pressure;
        // generalised play operators (Al Janaideh, Rakheja and Su, 2009): the ascending and
        // the descending branch follow different envelopes, x - b(x) and x + b(x), with a
        // bulge b >= 0 that is largest on the positive side, so the loop is wider there and
        // its branches are not mirror images; skew 0 gives the classical operator
        let b = if self.effects.skew == 0.0 {
            0.0
        } else {
            self.effects.skew * (1.0 - x * x).max(0.0) * (1.0 + x) / 2.0
        };
        let (up_env, down_env) = (x - b, x + b);
        for ((y, up), down) in self.plays.iter_mut().zip(ups).zip(downs) {
            if up_env - up > *y {
                *y = up_env - up;
            } else if down_env + down < *y {
                *y = down_env + down;
            }
        }
    }

    /// The equilibrium angle for the current play states (radians).
    pub fn equilibrium(&self) -> f64 {
        let (mid, half) = self.mid_half();
        self.equilibrium_about(mid, half)
    }

    /// The middle of the joint's range and half its span (radians).
    fn mid_half(&self) -> (f64, f64) {
        let (lo, hi) = (self.cfg.min_deg.to_radians(), self.cfg.max_deg.to_radians());
        (0.5 * (lo + hi), 0.5 * (hi - lo))
    }

    /// [`Joint::equilibrium`] with the range's middle and half span given.
    fn equilibrium_about(&self, mid: f64, half: f64) -> f64 {
        let play: f64 = self.plays.iter().sum::<f64>() / PLAYS as f64;
        let y = if self.effects.width_scale == 1.0 {
            self.weight_linear * self.pressure + self.weight_play * play
        } else {
            // a wider loop: the play operators' part grows, the linear part takes the rest
            let wp = (self.weight_play * self.effects.width_scale).min(0.95);
            (1.0 - wp) * self.pressure + wp * play
        };
        let s = (SHAPE * y).tanh() / tanh_shape();
        mid + self.gain * half * s + self.offset + self.effects.process_offset
    }

    /// The angles (radians) this joint reaches at rest on the loop's centre line with drive
    /// pressures within `[-limit, limit]`, in its present state of drift and wear: the range
    /// the targets' poses come from when `limit` is the joint's `target_limit`.
    pub fn angle_range(&self, limit: f64) -> (f64, f64) {
        let s = (SHAPE * limit).tanh() / tanh_shape();
        let (lo, hi) = (self.cfg.min_deg.to_radians(), self.cfg.max_deg.to_radians());
        let mid = 0.5 * (lo + hi) + self.offset;
        let half = 0.5 * (hi - lo) * self.gain * s;
        (mid - half, mid + half)
    }

    /// One physics step of `dt` seconds: pressure lag, hysteresis, dynamics
    /// (semi-implicit Euler).
    pub fn step(&mut self, dt: f64) {
        let c = self.step_constants(dt);
        self.step_with(&c);
    }

    /// What [`Joint::step`] of `dt` works out from the configuration and the effects that
    /// stay the same from step to step (the drive's lag, the play operators' lags, the
    /// creep's decay, the dynamics' coefficients, the range), for many steps at once
    /// ([`crate::Plant::advance`]). Only `gain`, `offset` and the effects' `width_scale`
    /// and `process_offset` may change between the steps that use them.
    pub fn step_constants(&self, dt: f64) -> StepConstants {
        let wn = 2.0 * std::f64::consts::PI * self.cfg.natural_freq_hz;
        StepConstants {
            kept: self.kept(dt),
            lag: (dt / self.cfg.pressure_tau_s).min(1.0),
            stiffness: wn * wn,
            damping: 2.0 * self.cfg.damping_ratio * wn,
        }
    }

    /// What both kinds of step keep for steps of `dt`.
    fn kept(&self, dt: f64) -> Kept {
        let (ups, downs) = self.play_lags();
        let (mid, half) = self.mid_half();
        Kept {
            ups,
            downs,
            creep_decay: if self.effects.creep_fraction > 0.0 {
                creep_decay(dt, self.effects.creep_tau_s)
            } else {
                0.0
            },
            mid,
            half,
            dt,
        }
    }

    /// The play operators updated to the drive's pressure, and the joint's target there:
    /// the loop's equilibrium with the creep still to arrive (both kinds of step).
    fn target_after_plays(&mut self, k: &Kept) -> f64 {
        self.update_plays_with(&k.ups, &k.downs);
        let mut target = self.equilibrium_about(k.mid, k.half);
        let fraction = self.effects.creep_fraction;
        if fraction > 0.0 {
            // viscoelastic creep: a fraction of every change of the equilibrium arrives with
            // the time constant creep_tau_s
            self.creep -= fraction * (target - self.eq_last);
            self.eq_last = target;
            self.creep *= k.creep_decay;
            target += self.creep;
        }
        target
    }

    /// One physics step with constants from [`Joint::step_constants`]: each operation as
    /// [`Joint::step`] does it, so the result is the same bit for bit.
    pub fn step_with(&mut self, c: &StepConstants) {
        self.pressure += (self.command - self.pressure) * c.lag;
        let target = self.target_after_plays(&c.kept);
        let dt = c.kept.dt;
        let acc = c.stiffness * (target - self.angle) - c.damping * self.velocity;
        self.velocity += acc * dt;
        let d = self.velocity * dt;
        self.angle += d;
        self.travel += d.abs();
    }

    /// What [`Joint::step_exact`] of `dt` works out once for many steps, as
    /// [`Joint::step_constants`] does for the lab's step.
    pub fn exact_constants(&self, dt: f64) -> ExactConstants {
        let wn = 2.0 * std::f64::consts::PI * self.cfg.natural_freq_hz;
        let zeta = self.cfg.damping_ratio;
        // the error from the target, e = angle - target, and its rate obey
        // (e, e')' = A (e, e'), A = [[0, 1], [-wn^2, -2 zeta wn]] (plus the target's own
        // rate, see step_exact); exp(A dt) = exp(-zeta wn dt) ((c + zeta wn s) I + s A),
        // with c and s of the damped frequency (cos and sin / w below critical damping,
        // cosh and sinh / q above it, 1 and dt at it)
        let sigma = zeta * wn;
        let (c, s) = if zeta < 1.0 {
            let w = wn * (1.0 - zeta * zeta).sqrt();
            ((w * dt).cos(), (w * dt).sin() / w)
        } else if zeta > 1.0 {
            let q = wn * (zeta * zeta - 1.0).sqrt();
            ((q * dt).cosh(), (q * dt).sinh() / q)
        } else {
            (1.0, dt)
        };
        let decay = (-sigma * dt).exp();
        let phi = [
            [decay * (c + sigma * s), decay * s],
            [-decay * s * wn * wn, decay * (c - sigma * s)],
        ];
        ExactConstants {
            kept: self.kept(dt),
            decay: (-dt / self.cfg.pressure_tau_s).exp(),
            phi,
            lag_per_rate: 2.0 * zeta / wn,
        }
    }

    /// One physics step of `dt` with the dynamics solved exactly instead of by Euler's rule
    /// (the Python environment's coarser steps, `dt_s`): the drive's pressure follows its
    /// exponential lag to the step's end, the play operators are updated there (the
    /// pressure moves one way within a step, so a play operator's output is its value at
    /// the end), the creep decays by its exponential, and the joint's second-order dynamics
    /// are solved in closed form for a target that moves linearly over the step, from its
    /// value at the step's start to its value at the end. At steps of 10 ms and more the
    /// result is far closer to the lab's 1 ms steps than Euler's rule at the same step.
    pub fn step_exact(&mut self, c: &ExactConstants) {
        // the target now, in the joint's state and the plant's effects of this step
        let start = self.equilibrium_about(c.kept.mid, c.kept.half) + self.creep;
        self.pressure = self.command + (self.pressure - self.command) * c.decay;
        let end = self.target_after_plays(&c.kept);
        // a target moving at rate s: e = angle - target has the steady lag -2 zeta s / wn,
        // and the rest of (e, e' ) decays as the unforced joint does
        let rate = (end - start) / c.kept.dt;
        let lag = -c.lag_per_rate * rate;
        let (e, de) = (self.angle - start - lag, self.velocity - rate);
        let e1 = c.phi[0][0] * e + c.phi[0][1] * de;
        let de1 = c.phi[1][0] * e + c.phi[1][1] * de;
        let angle = end + lag + e1;
        self.travel += (angle - self.angle).abs();
        self.angle = angle;
        self.velocity = de1 + rate;
    }

    /// Sets the tubes' pressure at once and lets the joint settle fully (tests, pictures).
    pub fn settle_at(&mut self, p: f64) {
        self.command = p;
        self.pressure = p;
        self.update_plays();
        self.angle = self.equilibrium();
        self.eq_last = self.angle;
        self.creep = 0.0;
        self.velocity = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::SimConfig;

    fn sweep(j: &mut Joint, from: f64, to: f64, n: usize) -> Vec<(f64, f64)> {
        (0..=n)
            .map(|i| {
                let p = from + (to - from) * i as f64 / n as f64;
                j.settle_at(p);
                (p, j.angle_deg())
            })
            .collect()
    }

    fn loop_gap(width: f64, asym: f64) -> f64 {
        let mut cfg = SimConfig::default().joints[1].clone();
        cfg.hysteresis_width = width;
        cfg.hysteresis_asymmetry = asym;
        let mut j = Joint::new(&cfg);
        sweep(&mut j, 0.0, -1.0, 50);
        let up = sweep(&mut j, -1.0, 1.0, 200);
        let down = sweep(&mut j, 1.0, -1.0, 200);
        // gap at zero pressure between the descending and the ascending branch
        let at0 = |b: &[(f64, f64)]| {
            b.iter()
                .min_by(|a, b| a.0.abs().total_cmp(&b.0.abs()))
                .unwrap()
                .1
        };
        (at0(&down) - at0(&up)) / (cfg.max_deg - cfg.min_deg)
    }

    #[test]
    fn loop_width_matches_the_configuration() {
        for w in [0.05, 0.10, 0.20] {
            let gap = loop_gap(w, 0.3);
            assert!((gap - w).abs() <= 0.1 * w, "configured {w}, measured {gap}");
        }
    }

    #[test]
    fn zero_width_gives_one_curve() {
        assert!(loop_gap(0.0, 0.3).abs() < 1e-12);
    }

    /// What `hysteresis_asymmetry` is: the same loop moved by a constant. Fails if the
    /// branches ever differ in shape (then this doc and sim.toml must say so).
    #[test]
    fn asymmetry_is_an_offset_of_a_symmetric_loop() {
        let loop_of = |asym: f64| {
            let mut cfg = SimConfig::default().joints[1].clone();
            cfg.hysteresis_asymmetry = asym;
            let mut j = Joint::new(&cfg);
            sweep(&mut j, 0.0, -1.0, 50);
            let mut pts = sweep(&mut j, -1.0, 1.0, 100);
            pts.extend(sweep(&mut j, 1.0, -1.0, 100));
            pts.iter().map(|p| p.1).collect::<Vec<_>>()
        };
        let (sym, asym) = (loop_of(0.0), loop_of(0.5));
        // away from the ends (where the offset pushes into the tanh's saturation) the
        // difference between the two loops is one constant on both branches
        let d: Vec<f64> = sym.iter().zip(&asym).map(|(a, b)| b - a).collect();
        let (up, down) = (&d[40..60], &d[141..161]);
        let spread = |v: &[f64]| {
            v.iter().cloned().fold(f64::MIN, f64::max) - v.iter().cloned().fold(f64::MAX, f64::min)
        };
        println!(
            "offset {:.3} deg, spread up {:.4} down {:.4}",
            up[0],
            spread(up),
            spread(down)
        );
        assert!(up[0].abs() > 1.0, "the asymmetry moves the loop: {}", up[0]);
        assert!(
            spread(up) < 0.15 && spread(down) < 0.15,
            "up {up:?} down {down:?}"
        );
    }

    #[test]
    fn the_loop_is_shifted_by_the_asymmetry() {
        let mut cfg = SimConfig::default().joints[1].clone();
        cfg.hysteresis_asymmetry = 0.5;
        let mut j = Joint::new(&cfg);
        sweep(&mut j, 0.0, -1.0, 50);
        let up = sweep(&mut j, -1.0, 1.0, 100);
        let down = sweep(&mut j, 1.0, -1.0, 100);
        let mid = 0.5 * (cfg.min_deg + cfg.max_deg);
        // the ascending branch lies further from the centre line than the descending one
        let lag_up = mid - up[50].1;
        let lag_down = down[50].1 - mid;
        assert!(lag_up > lag_down * 1.2, "up {lag_up}, down {lag_down}");
    }

    #[test]
    fn a_step_overshoots_and_settles() {
        let cfg = SimConfig::default().joints[1].clone();
        let mut j = Joint::new(&cfg);
        j.settle_at(0.0);
        let start = j.angle();
        j.command_raw(raw_of(0.5));
        let mut peak = start;
        for _ in 0..5000 {
            j.step(0.001);
            peak = peak.max(j.angle());
        }
        let end = j.angle();
        assert!((end - j.equilibrium()).abs() < 1e-4, "settled");
        assert!(
            peak > end + 0.05 * (end - start),
            "overshoot: peak {peak}, final {end}"
        );
    }

    /// The physics step as it was written before its constants were worked out once for
    /// many steps: every operation in the same order.
    fn step_as_written(j: &mut Joint, dt: f64) {
        let k = dt / j.cfg.pressure_tau_s;
        j.pressure += (j.command - j.pressure) * k.min(1.0);
        let (a, x) = (j.cfg.hysteresis_asymmetry, j.pressure);
        let b = if j.effects.skew == 0.0 {
            0.0
        } else {
            j.effects.skew * (1.0 - x * x).max(0.0) * (1.0 + x) / 2.0
        };
        let (up_env, down_env) = (x - b, x + b);
        for (y, r) in j.plays.iter_mut().zip(j.radii.iter()) {
            let up = r * (1.0 + a);
            let down = r * (1.0 - a);
            if up_env - up > *y {
                *y = up_env - up;
            } else if down_env + down < *y {
                *y = down_env + down;
            }
        }
        let play: f64 = j.plays.iter().sum::<f64>() / PLAYS as f64;
        let y = if j.effects.width_scale == 1.0 {
            j.weight_linear * j.pressure + j.weight_play * play
        } else {
            let wp = (j.weight_play * j.effects.width_scale).min(0.95);
            (1.0 - wp) * j.pressure + wp * play
        };
        let s = (SHAPE * y).tanh() / SHAPE.tanh();
        let (lo, hi) = (j.cfg.min_deg.to_radians(), j.cfg.max_deg.to_radians());
        let mid = 0.5 * (lo + hi);
        let half = 0.5 * (hi - lo);
        let mut target = mid + j.gain * half * s + j.offset + j.effects.process_offset;
        let fraction = j.effects.creep_fraction;
        if fraction > 0.0 {
            j.creep -= fraction * (target - j.eq_last);
            j.eq_last = target;
            j.creep *= (-dt / j.effects.creep_tau_s).exp();
            target += j.creep;
        }
        let wn = 2.0 * std::f64::consts::PI * j.cfg.natural_freq_hz;
        let acc = wn * wn * (target - j.angle) - 2.0 * j.cfg.damping_ratio * wn * j.velocity;
        j.velocity += acc * dt;
        let d = j.velocity * dt;
        j.angle += d;
        j.travel += d.abs();
    }

    /// Steps with constants worked out once ([`Joint::step_constants`], as the plant's
    /// `advance` does) are the steps as written, bit for bit, with a skewed loop, creep, a
    /// load-dependent width and drift changing between the steps: the runs' figures and
    /// golden curves do not move.
    #[test]
    fn steps_with_kept_constants_are_the_steps_as_written() {
        let cfg = SimConfig::realistic();
        for (i, jc) in cfg.joints.iter().enumerate() {
            let mut a = Joint::new(jc);
            a.effects = JointEffects {
                skew: cfg.realism.hysteresis_skew,
                creep_fraction: cfg.realism.creep_fraction,
                creep_tau_s: cfg.realism.creep_tau_s,
                ..JointEffects::NONE
            };
            let mut b = a.clone();
            for (m, p) in [0.7, -0.4, 0.35, -0.9, 0.1].into_iter().enumerate() {
                a.command_raw(raw_of(p));
                b.command_raw(raw_of(p));
                let c = a.step_constants(0.001);
                for n in 0..800 {
                    let t = (m * 800 + n) as f64;
                    for j in [&mut a, &mut b] {
                        j.gain = 1.0 - 1e-5 * t;
                        j.offset = 1e-4 * (t * 0.01 + i as f64).sin();
                        // the load's width: at times exactly 1 (the narrow loop's branch)
                        j.effects.width_scale = 1.0 + (0.25 * (t * 0.003).cos()).max(0.0);
                        j.effects.process_offset = 1e-3 * m as f64;
                    }
                    a.step_with(&c);
                    step_as_written(&mut b, 0.001);
                    assert_eq!(a, b, "joint {i}, move {m}, step {n}");
                }
            }
        }
    }

    /// A joint of the realistic plant through five moves of 1.2 s each, stepped by `step`;
    /// its angle at the end of each move (radians).
    fn settled_angles(jc: &JointConfig, step: &dyn Fn(&mut Joint) -> usize) -> Vec<f64> {
        let cfg = SimConfig::realistic();
        let mut j = Joint::new(jc);
        j.effects = JointEffects {
            skew: cfg.realism.hysteresis_skew,
            creep_fraction: cfg.realism.creep_fraction,
            creep_tau_s: cfg.realism.creep_tau_s,
            ..JointEffects::NONE
        };
        [0.7, -0.4, 0.35, -0.9, 0.1]
            .iter()
            .map(|&p| {
                j.command_raw(raw_of(p));
                step(&mut j);
                j.angle()
            })
            .collect()
    }

    /// The exact step at 10 and 50 ms ends each move much nearer the dynamics' own solution
    /// (Euler's rule at 10 us) than Euler's rule at 10 ms does, for joints below, at and
    /// above critical damping.
    #[test]
    fn the_exact_step_is_close_to_the_dynamics_at_coarse_steps() {
        let euler = |dt: f64| {
            move |j: &mut Joint| {
                let c = j.step_constants(dt);
                let n = (1.2 / dt).round() as usize;
                (0..n).for_each(|_| j.step_with(&c));
                n
            }
        };
        let exact = |dt: f64| {
            move |j: &mut Joint| {
                let c = j.exact_constants(dt);
                let n = (1.2 / dt).round() as usize;
                (0..n).for_each(|_| j.step_exact(&c));
                n
            }
        };
        let worst = |a: &[f64], b: &[f64]| {
            a.iter()
                .zip(b)
                .map(|(x, y)| (x - y).abs().to_degrees())
                .fold(0.0, f64::max)
        };
        for zeta in [0.3, 1.0, 1.5] {
            for jc in &SimConfig::realistic().joints {
                let jc = JointConfig {
                    damping_ratio: zeta,
                    ..jc.clone()
                };
                let truth = settled_angles(&jc, &euler(1e-5));
                let lab = worst(&settled_angles(&jc, &euler(1e-3)), &truth);
                let coarse = worst(&settled_angles(&jc, &euler(1e-2)), &truth);
                let exact10 = worst(&settled_angles(&jc, &exact(1e-2)), &truth);
                let exact50 = worst(&settled_angles(&jc, &exact(5e-2)), &truth);
                // measured: Euler's rule 0.0003-0.010 degrees off at 1 ms, 0.003-0.12 at
                // 10 ms; the exact step 0.0005-0.0017 at 10 ms, 0.0012-0.011 at 50 ms
                let what = format!(
                    "{} zeta {zeta}: Euler 1 ms {lab:.5} deg, 10 ms {coarse:.5}; exact 10 ms \
                     {exact10:.5}, 50 ms {exact50:.5}",
                    jc.name
                );
                assert!(exact10 < 0.002 && exact10 < 0.5 * coarse, "{what}");
                assert!(exact50 < 0.012, "{what}");
            }
        }
    }

    /// The kept values are the libm calls' own, also when dt or tau change back and forth.
    #[test]
    fn kept_values_are_the_calls_results() {
        assert_eq!(tanh_shape().to_bits(), SHAPE.tanh().to_bits());
        for (dt, tau) in [
            (0.001, 3.0),
            (0.001, 2.0),
            (0.01, 2.0),
            (0.001, 3.0),
            (0.001, 3.0),
        ] {
            assert_eq!(
                creep_decay(dt, tau).to_bits(),
                (-dt / tau).exp().to_bits(),
                "dt {dt} tau {tau}"
            );
        }
    }

    #[test]
    fn servo_saturates_and_quantises() {
        let mut cfg = SimConfig::default().joints[0].clone();
        cfg.servo_limit = 0.8;
        let mut j = Joint::new(&cfg);
        assert!(j.command_raw(raw_of(0.9)).1);
        assert!(!j.command_raw(raw_of(0.5)).1);
        assert_eq!(raw_of(-1.0), 0);
        assert_eq!(raw_of(1.0), 4095);
        assert!((pressure_of(raw_of(0.123)) - 0.123).abs() < 1.0 / 4095.0);
    }
}
