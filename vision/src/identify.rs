//! Which blob is which light: the capture protocol and the identifier.
//!
//! A capture is a short sequence of `frames` exposures. Light `i` has a *code*: the set of
//! frames in which it is lit (bit `f` of [`CaptureProtocol::code`]). Every code has the same
//! number of frames (`weight`), and no two lights share a code:
//! - [`CaptureProtocol::sequential`]: one light per frame (weight 1, as many frames as
//!   lights), as strobed marker systems do;
//! - [`CaptureProtocol::constant_weight`]: groups of lights per frame, each light in
//!   `weight` frames of `frames` (for example 4 frames of weight 2 tell 6 lights apart, each
//!   measured twice).
//!
//! The identifier follows the blobs through the sequence: a blob within `gate_px` of a
//! track's mean position joins it, any other starts a new track. A track's code is the set
//! of frames it was seen in. A light is **Valid** when exactly one track has its code and that
//! track is clean (one blob per frame, near no other track, no unmeasurable blob in it); its
//! centre is the mean of the track's blobs. Because every code has the same weight, a blob
//! missing from one frame (hidden, too faint) or an extra one (a reflection near the light)
//! gives a code of another weight, which is no light's: the light is **Missing**, never taken
//! for another. Two lights within the gate of each other fall into one track whose code is no
//! light's (both Missing), or make a track with two blobs in one frame or a blob near two
//! tracks (**Ambiguous**); a merged blob that joins the track of one of its lights carries
//! about twice that light's signal, and a track whose blobs' signals differ by more than
//! [`MAX_SIGNAL_RATIO`] is not clean (**Ambiguous**). Blobs the detector rejected as too large, crowded, empty or
//! elongated count as seen but make their track ambiguous; blobs too small to be lights are
//! ignored.
//!
//! The lights must move less than the gate between the first and the last frame of a
//! capture, and two lights must be more than twice the gate apart on the image to be told
//! apart.

use crate::detect::{Detection, Rejection};
use crate::error::{check, VisionError};
use crate::render::{Emitter, Occluder, Scene};

/// The most frames a capture may have.
pub const MAX_FRAMES: usize = 32;

/// Which lights are lit in which frame of a capture.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CaptureProtocol {
    frames: usize,
    codes: Vec<u32>,
}

impl CaptureProtocol {
    /// `lights` frames, light `i` lit alone in frame `i` (1 to 32 lights).
    pub fn sequential(lights: usize) -> Result<CaptureProtocol, VisionError> {
        CaptureProtocol::constant_weight(lights, lights, 1)
    }

    /// `frames` frames (1 to 32), each light lit in `weight` of them: the codes of that
    /// weight in increasing order, the first `lights` of them.
    pub fn constant_weight(
        lights: usize,
        frames: usize,
        weight: usize,
    ) -> Result<CaptureProtocol, VisionError> {
        if lights == 0 || frames == 0 || frames > MAX_FRAMES || weight == 0 || weight > frames {
            return Err(VisionError::Protocol(format!(
                "{lights} lights in {frames} frames of weight {weight}: need at least one light, \
                 1 to {MAX_FRAMES} frames and a weight from 1 to the number of frames"
            )));
        }
        // the codes of `weight` ones among `frames` bits in increasing order (Gosper's
        // next-permutation of bits), at most `lights` of them
        let mut codes = Vec::with_capacity(lights);
        let mut code = u64::MAX >> (64 - weight);
        while code < 1u64 << frames && codes.len() < lights {
            codes.push(code as u32);
            let low = code & code.wrapping_neg();
            let ripple = code + low;
            code = ripple | (((code ^ ripple) >> 2) / low);
        }
        if codes.len() < lights {
            return Err(VisionError::Protocol(format!(
                "{frames} frames of weight {weight} tell only {} lights apart, not {lights}",
                codes.len()
            )));
        }
        Ok(CaptureProtocol { frames, codes })
    }

    /// Frames in a capture.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Lights.
    pub fn lights(&self) -> usize {
        self.codes.len()
    }

    /// The frames light `light` is lit in (bit `f` for frame `f`); 0 for no such light.
    pub fn code(&self, light: usize) -> u32 {
        self.codes.get(light).copied().unwrap_or(0)
    }

    /// The scene of each frame of a capture of `lights` (one emitter per light of the
    /// protocol, in order), each frame showing the lights lit in it.
    pub fn scenes(
        &self,
        lights: &[Emitter],
        occluders: &[Occluder],
    ) -> Result<Vec<Scene>, VisionError> {
        if lights.len() != self.codes.len() {
            return Err(VisionError::Protocol(format!(
                "{} lights where the protocol has {}",
                lights.len(),
                self.codes.len()
            )));
        }
        Ok((0..self.frames)
            .map(|f| Scene {
                emitters: self.lit(f).into_iter().map(|l| lights[l].clone()).collect(),
                occluders: occluders.to_vec(),
            })
            .collect())
    }

    /// The lights lit in frame `frame`.
    pub fn lit(&self, frame: usize) -> Vec<usize> {
        (0..self.codes.len())
            .filter(|&l| frame < self.frames && self.codes[l] & (1 << frame) != 0)
            .collect()
    }
}

/// What the identifier says of a light.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LightStatus {
    /// Found, its centre measured.
    Valid,
    /// No track has its code: hidden (in some or all of its frames), too faint, merged with
    /// another light or with a reflection.
    Missing,
    /// Its track is not clean, or several tracks have its code.
    Ambiguous,
}

/// One light of a capture.
#[derive(Debug, Clone, PartialEq)]
pub struct Identified {
    /// What became of it.
    pub status: LightStatus,
    /// Its centre (pixels) when valid.
    pub centre: Option<[f64; 2]>,
}

/// Tells the lights apart over the frames of a capture.
#[derive(Debug, Clone, PartialEq)]
pub struct Identifier {
    protocol: CaptureProtocol,
    gate_px: f64,
}

/// The most a track's blobs' signals may differ (the largest over the smallest): one light's
/// blobs carry the same signal in every frame; a blob of two merged lights carries about
/// twice, a light partly hidden in one frame less.
pub const MAX_SIGNAL_RATIO: f64 = 1.5;

#[derive(Debug, Clone)]
struct Track {
    sum: [f64; 2],
    n: f64,
    measured: usize,
    frames: u32,
    clean: bool,
    /// The smallest and largest signal of its measured blobs.
    signal: [f64; 2],
}

impl Track {
    fn mean(&self) -> [f64; 2] {
        [self.sum[0] / self.n, self.sum[1] / self.n]
    }
}

impl Identifier {
    /// An identifier for `protocol`; blobs within `gate_px` (> 0) of a track join it.
    pub fn new(protocol: CaptureProtocol, gate_px: f64) -> Result<Identifier, VisionError> {
        check("gate_px", gate_px, "> 0", |v| v > 0.0)?;
        Ok(Identifier { protocol, gate_px })
    }

    /// The protocol.
    pub fn protocol(&self) -> &CaptureProtocol {
        &self.protocol
    }

    /// Each light of the protocol, in order, from the detections of a capture's frames (in
    /// the protocol's order).
    pub fn identify(&self, frames: &[Detection]) -> Result<Vec<Identified>, VisionError> {
        if frames.len() != self.protocol.frames {
            return Err(VisionError::Protocol(format!(
                "a capture of {} frames where the protocol has {}",
                frames.len(),
                self.protocol.frames
            )));
        }
        let mut tracks: Vec<Track> = Vec::new();
        for (f, d) in frames.iter().enumerate() {
            let bit = 1u32 << f;
            let seen = d.blobs.iter().map(|b| (b, true)).chain(
                d.rejected
                    .iter()
                    .filter(|(_, r)| *r != Rejection::TooSmall)
                    .map(|(b, _)| (b, false)),
            );
            for (b, measured) in seen {
                let c = b.centre;
                let signal = if measured {
                    [b.signal_dn, b.signal_dn]
                } else {
                    [f64::INFINITY, f64::NEG_INFINITY]
                };
                if !c.iter().all(|v| v.is_finite()) {
                    continue;
                }
                let near: Vec<(usize, f64)> = tracks
                    .iter()
                    .enumerate()
                    .map(|(i, t)| {
                        let m = t.mean();
                        (i, (m[0] - c[0]).hypot(m[1] - c[1]))
                    })
                    .filter(|(_, d)| *d <= self.gate_px)
                    .collect();
                let Some(&(nearest, _)) = near.iter().min_by(|a, b| a.1.total_cmp(&b.1)) else {
                    tracks.push(Track {
                        sum: c,
                        n: 1.0,
                        measured: measured as usize,
                        frames: bit,
                        clean: measured,
                        signal,
                    });
                    continue;
                };
                if near.len() > 1 {
                    near.iter().for_each(|(i, _)| tracks[*i].clean = false);
                }
                let t = &mut tracks[nearest];
                if t.frames & bit != 0 || !measured {
                    t.clean = false;
                }
                t.frames |= bit;
                t.sum = [t.sum[0] + c[0], t.sum[1] + c[1]];
                t.n += 1.0;
                t.measured += measured as usize;
                t.signal = [t.signal[0].min(signal[0]), t.signal[1].max(signal[1])];
                if t.signal[1] > MAX_SIGNAL_RATIO * t.signal[0] {
                    t.clean = false;
                }
            }
        }
        Ok(self
            .protocol
            .codes
            .iter()
            .map(|&code| {
                let mut with_code = tracks.iter().filter(|t| t.frames == code);
                match (with_code.next(), with_code.next()) {
                    (Some(t), None) if t.clean && t.measured > 0 => Identified {
                        status: LightStatus::Valid,
                        centre: Some(t.mean()),
                    },
                    (None, _) => Identified {
                        status: LightStatus::Missing,
                        centre: None,
                    },
                    _ => Identified {
                        status: LightStatus::Ambiguous,
                        centre: None,
                    },
                }
            })
            .collect())
    }
}

#[cfg(test)]
mod tests;
