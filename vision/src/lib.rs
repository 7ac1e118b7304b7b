//! The camera processor on pixels: frames of LEDs rendered as a camera sees them, and the
//! lights found, measured and identified in them. Usable on its own: it knows nothing of the
//! simulator, only images, image coordinates and a capture protocol.
//!
//! - [`render`]: a [`Renderer`] draws 8- or 16-bit grayscale [`Frame`]s of a [`Scene`] of
//!   Gaussian [`Emitter`]s (sub-pixel centre, blur, electrons, motion during the exposure)
//!   partly or wholly hidden by [`Occluder`]s (capsules, polygons), on a [`Sensor`] with stray
//!   light, shot noise, read noise, gain, black level and saturation. Seeded: the same scene
//!   and seed give the same frame.
//! - [`detect`]: a [`Detector`] thresholds a frame above its background, finds the connected
//!   components, measures their background-subtracted intensity-weighted centroids and
//!   rejects blobs too small, too large, crowded or elongated.
//! - [`identify`]: an [`Identifier`] tells the lights apart over the frames of a capture.
//! - [`accuracy`]: the centroid's error on rendered frames against the Cramér-Rao bound.
//!
//! ```
//! use trn_vision::{CaptureProtocol, Detector, DetectorParams, Emitter, Identifier, LightStatus,
//!                  Renderer, Sensor};
//!
//! let sensor = Sensor::machine_vision(1024, 768);
//! let renderer = Renderer::<u8>::new(&sensor)?;
//! let detector = Detector::new(1024, 768, DetectorParams::default())?;
//! // three lights, each lit in two of three frames
//! let protocol = CaptureProtocol::constant_weight(3, 3, 2)?;
//! let lights: Vec<Emitter> = [[400.3, 300.8], [450.1, 302.2], [425.6, 340.5]]
//!     .iter()
//!     .map(|&c| Emitter::new(c, 1.3, 30_000.0))
//!     .collect();
//! let mut detections = Vec::new();
//! for (f, scene) in protocol.scenes(&lights, &[])?.iter().enumerate() {
//!     let frame = renderer.render(scene, f as u64)?;
//!     detections.push(detector.detect(&frame)?);
//! }
//! let found = Identifier::new(protocol, 3.0)?.identify(&detections)?;
//! for (light, id) in lights.iter().zip(&found) {
//!     assert_eq!(id.status, LightStatus::Valid);
//!     let c = id.centre.unwrap();
//!     assert!((c[0] - light.centre[0]).hypot(c[1] - light.centre[1]) < 0.1);
//! }
//! # Ok::<(), trn_vision::VisionError>(())
//! ```
//!
//! Coordinates: x to the right, y down; pixel `(i, j)` covers `[i, i + 1) x [j, j + 1)`, its
//! centre at `(i + 0.5, j + 0.5)`.
//!
//! # The capture protocol
//!
//! A *capture* of the lights is a sequence of `F` frames taken in a row by each camera, the
//! lights switched between frames in step with the exposures. Each light has a code: the set
//! of the `F` frames in which it is lit. All codes have the same number `w` of frames (the
//! weight) and differ from each other; light `i` gets the `i`-th code of weight `w` in
//! increasing binary order, frame `f` being bit `f`.
//!
//! - Sequential (`w = 1`, `F` = the number of lights): light `i` is lit alone in frame `i`.
//! - Grouped (`w > 1`): for example the gripper's three lights p, q, c in 3 frames of weight
//!   2 (codes 011, 101, 110: frame 0 shows p and q, frame 1 p and c, frame 2 q and c), each
//!   light measured twice; or five lights in 4 frames of weight 2.
//!
//! The camera processor detects the blobs of each frame, follows them through the capture
//! (a blob within the gate, 3 px by default, of a track's mean joins it) and reads each
//! track's code from the frames it appears in. A light whose code belongs to exactly one
//! clean track is valid, at the mean of that track's centres. Any other light is refused:
//! *missing* (hidden or too faint in one of its frames, merged with another light or with a
//! reflection: the code read then has another weight than `w`, so it is no light's code and
//! never another light's) or *ambiguous* (two blobs in one frame of a track, a blob between
//! two tracks, a blob the detector rejected, or two tracks with the same code). Requirements:
//! the lights move less than the gate during a capture, and lie more than twice the gate
//! apart on the image.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod accuracy;
pub mod detect;
mod error;
mod frame;
pub mod identify;
mod random;
pub mod render;

pub use detect::{Blob, Centroid, Detection, Detector, DetectorParams, Rejection};
pub use error::VisionError;
pub use frame::{Frame, Sample};
pub use identify::{CaptureProtocol, Identified, Identifier, LightStatus};
pub use render::{Emitter, Occluder, Renderer, Scene, Sensor, Shape};
