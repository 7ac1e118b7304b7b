//! The simulator's half of a checkpoint: the state of the plant (every joint's hysteresis,
//! creep, drift and wear, the camera noise generator, the simulated time), the runner's
//! sequence (training targets' generator, trial number) and how many training trials per
//! network are done and were planned, and the learning curve so far, at the end of training
//! (or where an interrupt stopped it). With the controller's checkpoint (tables and
//! learning-step counters) it lets a run continue exactly where it stopped: a long run
//! interrupted and continued gives the same curve as one that never stopped
//! (`trn train --checkpoint-in C --continue`).
//!
//! File `C.sim` beside checkpoint `C`, written durably like it
//! ([`crate::fsio::write_durably`]):
//!
//! | bytes | content |
//! |---|---|
//! | 4 | magic `TRNS` |
//! | varies | postcard: [`SimState`] (format version first) |
//! | 4 | CRC-32 (ISO-HDLC) over everything before it |

use std::io::Read;
use std::path::{Path, PathBuf};

use rand_xoshiro::Xoshiro256PlusPlus;
use serde::{Deserialize, Serialize};

use crate::error::{io, LabError as Error, Result};
use crate::fsio::write_durably;
use trn_plant::{Plant, SimConfig};

/// The format version this build writes and reads.
pub const VERSION: u16 = 3;
const MAGIC: [u8; 4] = *b"TRNS";
const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);
/// Far more than any state (a plant is a few kilobytes, the training curve ten bytes a
/// trial): a longer file is refused unread.
const MAX_SIZE: u64 = 64 << 20;

/// The simulator's state at the end of a run's training.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SimState {
    /// Format version.
    pub version: u16,
    /// The run's seed.
    pub seed: u64,
    /// Training trials per network done.
    pub trials_done: usize,
    /// Training trials per network the run was planned for (an interrupted run has some
    /// left: `--continue` without `--trials` runs them).
    pub trials_planned: usize,
    /// The training curve and the snapshots so far (a continued run reports them whole).
    pub history: crate::history::History,
    /// The runner's generator of training targets and start poses.
    pub runner_rng: Xoshiro256PlusPlus,
    /// The runner's next trial number.
    pub runner_trial: u32,
    /// The CRC of the controller checkpoint saved with it ([`super::checkpoint_file::crc_of`]):
    /// a pair from different moments (a kill between the two writes) is refused.
    pub checkpoint_crc: u32,
    /// The plant (its configuration included).
    pub plant: Plant,
}

/// The simulator checkpoint that goes with controller checkpoint `checkpoint`.
pub fn path_beside(checkpoint: &Path) -> PathBuf {
    let mut name = checkpoint.as_os_str().to_owned();
    name.push(".sim");
    PathBuf::from(name)
}

/// Where a save keeps the `.sim` of the pair on disk until its new checkpoint is written
/// (`C.sim.prev`; [`crate::checkpoint_file::save_image_with_state`]).
pub fn previous_beside(checkpoint: &Path) -> PathBuf {
    let mut name = path_beside(checkpoint).into_os_string();
    name.push(".prev");
    PathBuf::from(name)
}

/// The CRC of the controller checkpoint the state at `path` was saved with, if it reads.
pub fn paired_crc(path: &Path) -> Option<u32> {
    read(path).ok().map(|s| s.checkpoint_crc)
}

/// [`load`] of the state that pairs with the controller checkpoint `checkpoint` (CRC
/// `checkpoint_crc`): the `.sim` beside it, or, when a save was killed between its two
/// writes, the `.sim` it kept (`C.sim.prev`). Errors are those of the `.sim` beside it.
pub fn load_beside(
    checkpoint: &Path,
    seed: u64,
    cfg: &SimConfig,
    checkpoint_crc: u32,
) -> Result<SimState> {
    let sim = path_beside(checkpoint);
    let prev = previous_beside(checkpoint);
    match load(&sim, seed, cfg, checkpoint_crc) {
        Ok(state) => Ok(state),
        Err(e) => match prev.exists() {
            true => load(&prev, seed, cfg, checkpoint_crc).map_err(|_| e),
            false => Err(e),
        },
    }
}

fn bad(path: &Path, what: &str) -> Error {
    Error::Usage(format!("simulator checkpoint {}: {what}", path.display()))
}

/// The file's bytes.
pub fn encode(state: &SimState) -> Vec<u8> {
    let mut out = MAGIC.to_vec();
    // a plant is plain numbers: encoding into a growable buffer cannot fail
    out.extend(postcard::to_allocvec(state).unwrap_or_default());
    let crc = CRC.checksum(&out);
    out.extend(crc.to_le_bytes());
    out
}

/// Checks magic, CRC and version and decodes (`path` names the file in errors).
pub fn decode(bytes: &[u8], path: &Path) -> Result<SimState> {
    if bytes.len() < 8 || bytes[..4] != MAGIC {
        return Err(bad(path, "not a simulator checkpoint (magic TRNS)"));
    }
    let (body, crc) = bytes.split_at(bytes.len() - 4);
    if CRC.checksum(body).to_le_bytes() != crc {
        return Err(bad(path, "CRC mismatch (corrupt or truncated)"));
    }
    // the version first, so that a state of another format is named as such rather than
    // reported undecodable (version 3: the plant's configuration gained its vision model)
    if let Ok((version, _)) = postcard::take_from_bytes::<u16>(&body[4..]) {
        if version != VERSION {
            return Err(bad(
                path,
                &format!("format version {version} (this build reads {VERSION})"),
            ));
        }
    }
    let state: SimState =
        postcard::from_bytes(&body[4..]).map_err(|e| bad(path, &format!("undecodable: {e}")))?;
    if state.version != VERSION {
        return Err(bad(
            path,
            &format!(
                "format version {} (this build reads {VERSION})",
                state.version
            ),
        ));
    }
    Ok(state)
}

/// The plant configuration of the state at `path` (any seed, any checkpoint): which plant a
/// checkpoint beside it was trained on.
pub fn read_plant_config(path: &Path) -> Result<SimConfig> {
    Ok(read(path)?.plant.config().clone())
}

/// The state at `path`, read bounded (a longer file is refused unread) and decoded; not yet
/// checked against a run.
fn read(path: &Path) -> Result<SimState> {
    let mut bytes = vec![];
    trn_plant::input::open(path)
        .map_err(io(path))?
        .take(MAX_SIZE + 1)
        .read_to_end(&mut bytes)
        .map_err(io(path))?;
    if bytes.len() as u64 > MAX_SIZE {
        return Err(bad(path, "too long"));
    }
    decode(&bytes, path)
}

/// Writes `state` durably to `path`.
pub fn save(state: &SimState, path: &Path) -> Result<()> {
    write_durably(path, &encode(state))
}

/// Reads and verifies the state at `path` for a run with seed `seed` on configuration `cfg`,
/// saved with the controller checkpoint whose CRC is `checkpoint_crc`.
pub fn load(path: &Path, seed: u64, cfg: &SimConfig, checkpoint_crc: u32) -> Result<SimState> {
    let state = read(path)?;
    if state.seed != seed {
        return Err(bad(
            path,
            &format!(
                "saved by a run with seed {}, this run has {seed}",
                state.seed
            ),
        ));
    }
    if state.checkpoint_crc != checkpoint_crc {
        return Err(bad(
            path,
            "saved with another controller checkpoint than the one beside it",
        ));
    }
    if state.plant.config() != cfg {
        return Err(bad(
            path,
            "saved with another simulator configuration (--config)",
        ));
    }
    Ok(state)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_core::SeedableRng;

    fn state() -> SimState {
        let mut plant = Plant::new(&SimConfig::aging(), 7).unwrap();
        plant.command(&[0.3, -0.2, 0.5, 0.1, -0.4]);
        plant.settle();
        SimState {
            version: VERSION,
            seed: 7,
            trials_done: 12,
            trials_planned: 20,
            history: Default::default(),
            runner_rng: Xoshiro256PlusPlus::seed_from_u64(3),
            runner_trial: 40,
            checkpoint_crc: 0,
            plant,
        }
    }

    /// The plant comes back exactly: the same readings and the same future.
    #[test]
    fn round_trip_is_exact() {
        let s = state();
        let mut back = decode(&encode(&s), Path::new("x")).unwrap();
        let mut orig = s.plant.clone();
        assert_eq!(back.plant.joint_angles(), orig.joint_angles());
        for p in [[0.1f32, 0.2, -0.3, 0.0, 0.5], [-0.6, 0.1, 0.2, 0.3, -0.1]] {
            orig.command(&p);
            orig.settle();
            back.plant.command(&p);
            back.plant.settle();
            assert_eq!(back.plant.joint_angles(), orig.joint_angles());
            assert_eq!(
                back.plant.observe_gripper_lights().to_vector::<8>(),
                orig.observe_gripper_lights().to_vector()
            );
        }
        assert_eq!((back.trials_done, back.runner_trial), (12, 40));
    }

    /// A state of another format version is named as such, even when the rest of it (a
    /// plant of an earlier build, here only its version and a few bytes) does not decode.
    #[test]
    fn another_version_is_named() {
        let mut body = MAGIC.to_vec();
        body.extend(postcard::to_allocvec(&(VERSION - 1)).unwrap());
        body.extend([0xff; 6]);
        let crc = CRC.checksum(&body).to_le_bytes();
        body.extend(crc);
        let err = decode(&body, Path::new("old.sim")).unwrap_err().to_string();
        assert!(
            err.contains(&format!(
                "format version {} (this build reads {VERSION})",
                VERSION - 1
            )),
            "{err}"
        );
    }

    /// Every single-bit flip and every truncation is refused with an error, never a panic
    /// or a silently different plant.
    #[test]
    fn corruption_is_refused() {
        let bytes = encode(&state());
        for i in (0..bytes.len()).step_by(7) {
            let mut b = bytes.clone();
            b[i] ^= 0x10;
            assert!(decode(&b, Path::new("x")).is_err(), "flip at {i}");
        }
        for n in [0, 3, 8, bytes.len() / 2, bytes.len() - 1] {
            assert!(decode(&bytes[..n], Path::new("x")).is_err(), "cut at {n}");
        }
    }
}
