//! Where a capture's frames come from.
//!
//! A [`FrameSource`] hands the camera processor one capture at a time: in each camera, the
//! `F` frames exposed in a row with the lights switched in step (protocol/SPEC.md section 3,
//! "The capture sequence of a camera processor that reads frames"), and the capture protocol
//! that says which light is lit in which frame.
//!
//! A [`Recording`] is a folder of 8- or 16-bit grayscale PNG frames and a manifest,
//! [`MANIFEST`], listing the captures in order:
//!
//! ```toml
//! format = "trn-camera-recording/1"
//! gate_px = 3.0                 # the identifier's gate
//!
//! [calibration]                 # optional: without it the cameras are not checked
//! pixel_noise_px = 0.05         # the centroids' noise: the stereo check's tolerance is 1 px + 6 x this
//! [[calibration.cameras]]       # camera 0, then camera 1 (the simulator's camera model)
//! resolution = [1024, 768]
//! focal_px = 800.0
//! position_mm = [1800.0, 600.0, 500.0]
//! look_at_mm = [300.0, 0.0, 300.0]
//! distortion = [0.0, 0.0]
//! # [[calibration.cameras]] ...
//!
//! [[captures]]
//! what = "GripperLights"        # or "GripperCentre": the request it answers
//! frames = 2                    # F
//! weight = 1                    # w: each light lit in w of the F frames
//! cam0 = ["0000-cam0-f0.png", "0000-cam0-f1.png"]
//! cam1 = ["0000-cam1-f0.png", "0000-cam1-f1.png"]
//! # optional, never read by the node: where the lights truly project (the Observation's
//! # order), for tests of a recording made where the truth is known
//! truth = [{ x = 512.3, y = 300.1, status = "Valid" }, ...]
//! ```
//!
//! The frame files are plain names inside the folder. The captures are served in order,
//! one per request, each for the kind of request it names; [`Recording::looping`] starts
//! again after the last.

use std::io::Read;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use trn_plant::config::CameraConfig;
use trn_protocol::{CaptureKind, PointStatus};
use trn_vision::{CaptureProtocol, Detection, Detector, Frame, VisionError};

use crate::CameraError;

/// The manifest's file name in a recording's folder.
pub const MANIFEST: &str = "recording.toml";

/// The manifest's format, its first key.
pub const FORMAT: &str = "trn-camera-recording/1";

/// The largest manifest read (bytes).
const MAX_MANIFEST: u64 = 16 << 20;

/// The largest frame file read (bytes): a 16-bit 4096 x 4096 frame, uncompressed.
const MAX_FRAME_FILE: u64 = 32 << 20;

/// The most captures a recording lists.
pub const MAX_CAPTURES: usize = 100_000;

/// One frame: 8- or 16-bit grayscale.
#[derive(Debug, Clone, PartialEq)]
pub enum AnyFrame {
    /// 8 bits per sample.
    U8(Frame<u8>),
    /// 16 bits per sample (a 10- to 16-bit sensor).
    U16(Frame<u16>),
}

impl AnyFrame {
    /// Width and height (pixels).
    pub fn dimensions(&self) -> (u32, u32) {
        match self {
            AnyFrame::U8(f) => f.dimensions(),
            AnyFrame::U16(f) => f.dimensions(),
        }
    }

    /// The blobs `detector` finds in it.
    pub fn detect(&self, detector: &Detector) -> Result<Detection, VisionError> {
        match self {
            AnyFrame::U8(f) => detector.detect(f),
            AnyFrame::U16(f) => detector.detect(f),
        }
    }
}

/// The frames of one capture.
#[derive(Debug, Clone)]
pub struct CaptureFrames {
    /// What was captured.
    pub what: CaptureKind,
    /// Which light is lit in which frame.
    pub protocol: CaptureProtocol,
    /// Each camera's frames, in the protocol's order.
    pub cameras: [Vec<AnyFrame>; 2],
}

/// Where the camera processor's captures come from.
pub trait FrameSource {
    /// The next capture of `what` in both cameras. An error (nothing left, a capture of
    /// another kind, an unreadable frame) is the capture's alone: the node reports its
    /// lights not detected and goes on.
    fn capture(&mut self, what: CaptureKind) -> Result<CaptureFrames, CameraError>;
}

/// The lights of a capture of `what`: p and q, or the centre light c.
pub fn lights_of(what: CaptureKind) -> usize {
    match what {
        CaptureKind::GripperLights => 2,
        CaptureKind::GripperCentre => 1,
    }
}

/// A recording's manifest ([`MANIFEST`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// [`FORMAT`].
    pub format: String,
    /// The identifier's gate (pixels).
    pub gate_px: f64,
    /// The cameras' calibration, for the stereo check.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration: Option<CalibrationConfig>,
    /// The captures, in the order they are served.
    pub captures: Vec<RecordedCapture>,
}

/// The cameras' calibration in a manifest.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrationConfig {
    /// The centroids' noise (pixels): two readings of a light agree within 1 px + 6 x this.
    pub pixel_noise_px: f64,
    /// Camera 0 and camera 1.
    pub cameras: Vec<CameraConfig>,
}

/// One capture of a recording.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecordedCapture {
    /// The request it answers.
    pub what: CaptureKind,
    /// Frames per camera (`F`).
    pub frames: usize,
    /// Frames each light is lit in (`w`).
    pub weight: usize,
    /// Camera 0's frame files, in order.
    pub cam0: Vec<String>,
    /// Camera 1's frame files, in order.
    pub cam1: Vec<String>,
    /// Where the lights truly project, in the Observation's order (not read by the node).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub truth: Vec<TruthPoint>,
}

/// A light's true projection in one camera.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TruthPoint {
    /// Column where it projects (pixels; 0 outside the image).
    pub x: f64,
    /// Row where it projects (pixels; 0 outside the image).
    pub y: f64,
    /// `Valid` in clear view, `Occluded` hidden in part or whole, `OutOfView`.
    pub status: PointStatus,
}

impl RecordedCapture {
    /// Its capture protocol.
    pub fn protocol(&self) -> Result<CaptureProtocol, VisionError> {
        CaptureProtocol::constant_weight(lights_of(self.what), self.frames, self.weight)
    }
}

/// A folder of recorded captures, served in order.
#[derive(Debug, Clone)]
pub struct Recording {
    dir: PathBuf,
    manifest: Manifest,
    next: usize,
    looping: bool,
}

impl Recording {
    /// Opens the recording in `dir`: its manifest read and checked, every frame file found.
    /// The frames are read when their capture is served.
    pub fn open(dir: &Path) -> Result<Recording, CameraError> {
        let path = dir.join(MANIFEST);
        let bytes = read_bounded(&path, MAX_MANIFEST)?;
        let bad = |why: String| CameraError::Manifest {
            path: path.clone(),
            why,
        };
        let text = String::from_utf8(bytes).map_err(|_| bad("not UTF-8 text".into()))?;
        let manifest: Manifest = toml::from_str(&text).map_err(|e| bad(e.to_string()))?;
        check_manifest(&manifest).map_err(bad)?;
        for (i, c) in manifest.captures.iter().enumerate() {
            for name in c.cam0.iter().chain(&c.cam1) {
                let f = dir.join(name);
                match std::fs::metadata(&f) {
                    Ok(m) if m.is_file() => {}
                    Ok(_) => return Err(bad(format!("capture {i}: {name} is not a regular file"))),
                    Err(e) => return Err(bad(format!("capture {i}: {name}: {e}"))),
                }
            }
        }
        Ok(Recording {
            dir: dir.to_path_buf(),
            manifest,
            next: 0,
            looping: false,
        })
    }

    /// The same recording served again from its first capture after its last.
    pub fn looping(mut self) -> Recording {
        self.looping = true;
        self
    }

    /// The manifest.
    pub fn manifest(&self) -> &Manifest {
        &self.manifest
    }

    /// The captures served so far (in this pass).
    pub fn served(&self) -> usize {
        self.next
    }

    /// Capture `i`'s frames, read from their files.
    pub fn frames(&self, i: usize) -> Result<CaptureFrames, CameraError> {
        let c = self
            .manifest
            .captures
            .get(i)
            .ok_or_else(|| CameraError::Source(format!("the recording has no capture {i}")))?;
        let sizes = self
            .manifest
            .calibration
            .as_ref()
            .map(|k| [k.cameras[0].resolution, k.cameras[1].resolution]);
        let mut cameras: [Vec<AnyFrame>; 2] = [Vec::new(), Vec::new()];
        for (cam, names) in [&c.cam0, &c.cam1].into_iter().enumerate() {
            for name in names {
                let f = read_frame(&self.dir.join(name))?;
                if let Some(s) = sizes {
                    let (w, h) = f.dimensions();
                    if [w, h] != s[cam] {
                        return Err(CameraError::Frame {
                            path: self.dir.join(name),
                            why: format!(
                                "{w} x {h} pixels where camera {cam} is calibrated for {} x {}",
                                s[cam][0], s[cam][1]
                            ),
                        });
                    }
                }
                cameras[cam].push(f);
            }
        }
        Ok(CaptureFrames {
            what: c.what,
            protocol: c.protocol()?,
            cameras,
        })
    }
}

impl FrameSource for Recording {
    fn capture(&mut self, what: CaptureKind) -> Result<CaptureFrames, CameraError> {
        let n = self.manifest.captures.len();
        if self.next == n {
            if !self.looping {
                return Err(CameraError::Source(format!(
                    "the recording's {n} captures were all served"
                )));
            }
            self.next = 0;
        }
        let i = self.next;
        self.next += 1;
        let recorded = self.manifest.captures[i].what;
        if recorded != what {
            return Err(CameraError::Source(format!(
                "asked for {what:?}, the recording's capture {i} is {recorded:?}"
            )));
        }
        self.frames(i)
    }
}

/// What is wrong with a manifest, if anything.
fn check_manifest(m: &Manifest) -> Result<(), String> {
    if m.format != FORMAT {
        return Err(format!("format {:?}, not {FORMAT:?}", m.format));
    }
    if !(m.gate_px.is_finite() && m.gate_px > 0.0) {
        return Err(format!("gate_px {} is not a positive number", m.gate_px));
    }
    if let Some(k) = &m.calibration {
        if !(k.pixel_noise_px.is_finite() && k.pixel_noise_px >= 0.0) {
            return Err(format!(
                "calibration.pixel_noise_px {} is not a number >= 0",
                k.pixel_noise_px
            ));
        }
        if k.cameras.len() != 2 {
            return Err(format!(
                "calibration has {} cameras, not 2",
                k.cameras.len()
            ));
        }
        for (i, c) in k.cameras.iter().enumerate() {
            let mut finite = c
                .position_mm
                .iter()
                .chain(&c.look_at_mm)
                .chain(&c.distortion);
            if !(c.focal_px.is_finite() && c.focal_px > 0.0)
                || c.resolution.contains(&0)
                || !finite.all(|v| v.is_finite())
            {
                return Err(format!(
                    "calibration camera {i}: a focal length > 0, a resolution of at least 1 x 1 and finite positions and distortion"
                ));
            }
        }
    }
    if m.captures.is_empty() || m.captures.len() > MAX_CAPTURES {
        return Err(format!(
            "{} captures: 1 to {MAX_CAPTURES}",
            m.captures.len()
        ));
    }
    for (i, c) in m.captures.iter().enumerate() {
        c.protocol().map_err(|e| format!("capture {i}: {e}"))?;
        for (cam, names) in [&c.cam0, &c.cam1].into_iter().enumerate() {
            if names.len() != c.frames {
                return Err(format!(
                    "capture {i}: cam{cam} lists {} frames, the capture has {}",
                    names.len(),
                    c.frames
                ));
            }
            if let Some(name) = names.iter().find(|n| !plain_name(n)) {
                return Err(format!(
                    "capture {i}: {name:?} is not a file name in the recording's folder"
                ));
            }
        }
        let lights = lights_of(c.what);
        if !c.truth.is_empty() && c.truth.len() != 2 * lights {
            return Err(format!(
                "capture {i}: {} truth points where {:?} has {}",
                c.truth.len(),
                c.what,
                2 * lights
            ));
        }
    }
    Ok(())
}

/// A name of a file in the folder itself: no separator, not `.` or `..`, not empty.
fn plain_name(n: &str) -> bool {
    !n.is_empty() && n != "." && n != ".." && !n.contains(['/', '\\', '\0'])
}

/// The bytes of the regular file `path`, refused beyond `limit`.
fn read_bounded(path: &Path, limit: u64) -> Result<Vec<u8>, CameraError> {
    let err = |source| CameraError::Read {
        path: path.to_path_buf(),
        source,
    };
    let file = std::fs::File::open(path).map_err(err)?;
    let meta = file.metadata().map_err(err)?;
    if !meta.is_file() {
        return Err(err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a regular file",
        )));
    }
    let mut bytes = Vec::new();
    file.take(limit + 1).read_to_end(&mut bytes).map_err(err)?;
    if bytes.len() as u64 > limit {
        return Err(err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("longer than {limit} bytes"),
        )));
    }
    Ok(bytes)
}

/// A grayscale PNG frame.
pub fn read_frame(path: &Path) -> Result<AnyFrame, CameraError> {
    let bytes = read_bounded(path, MAX_FRAME_FILE)?;
    let bad = |why: String| CameraError::Frame {
        path: path.to_path_buf(),
        why,
    };
    let img = image::load_from_memory_with_format(&bytes, image::ImageFormat::Png)
        .map_err(|e| bad(format!("not a PNG image: {e}")))?;
    let (w, h) = (img.width(), img.height());
    if w == 0 || h == 0 {
        return Err(bad(format!("an empty frame ({w} x {h})")));
    }
    match img {
        image::DynamicImage::ImageLuma8(f) => Ok(AnyFrame::U8(f)),
        image::DynamicImage::ImageLuma16(f) => Ok(AnyFrame::U16(f)),
        other => Err(bad(format!(
            "a {:?} image, not 8- or 16-bit grayscale",
            other.color()
        ))),
    }
}

#[cfg(test)]
mod tests;
