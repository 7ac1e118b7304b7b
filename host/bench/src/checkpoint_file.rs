//! Checkpoint files: read bounded and verified into a controller, written durably.
//!
//! Writing: as every output ([`crate::output`]): a new temporary file in the target's
//! directory, the bytes, `fsync` of the file, a rename over the target, `fsync` of the
//! directory. A kill at any moment leaves the target holding the old or the new checkpoint
//! (at worst a stray temporary `.NAME.tmp-PID-N` beside it, removed by the next run that
//! writes there); no other file is touched.
//!
//! Reading: at most [`checkpoint::MAX_SIZE`] bytes of a regular file; the header must match
//! the configuration the run uses (preset, ablation, every value) unless the caller allows
//! a change.

use std::io::Read;
use std::path::Path;

use trn_controller::checkpoint::{self, Provenance};
use trn_controller::Controller;

use crate::error::{io, LabError as Error, Result};

fn checkpoint_err(path: &Path) -> impl FnOnce(trn_controller::Error) -> Error + '_ {
    move |source| Error::Checkpoint {
        path: path.to_path_buf(),
        source,
    }
}

fn mismatch(path: &Path, what: String) -> Error {
    Error::Usage(format!(
        "checkpoint {}: {what}; pass --allow-config-change to use it anyway",
        path.display()
    ))
}

/// Reads and verifies a checkpoint into `ctrl`. Its tables must have been learned with
/// `provenance` and `ctrl`'s configuration, unless `allow_change`.
pub fn load(
    ctrl: &mut Controller,
    path: &Path,
    provenance: Provenance,
    allow_change: bool,
) -> Result<()> {
    let (bytes, header) = read(path)?;
    if !allow_change {
        if header.provenance != provenance {
            return Err(mismatch(
                path,
                format!(
                    "learned with preset/ablation {:?}, this run uses {:?}",
                    (header.provenance.preset, header.provenance.ablation),
                    (provenance.preset, provenance.ablation)
                ),
            ));
        }
        if !header.config_matches(ctrl.config()) {
            return Err(mismatch(
                path,
                format!(
                    "learned under another configuration: its fingerprint {:#010x}, this run's {:#010x}",
                    header.config_fingerprint,
                    ctrl.config().fingerprint()
                ),
            ));
        }
    }
    checkpoint::restore(ctrl, &bytes).map_err(checkpoint_err(path))?;
    Ok(())
}

/// The image of the checkpoint file `path` to write into a controller that runs `cfg`
/// (preset and ablation `provenance`): read and verified; its tables must have been learned
/// under them unless `allow_change`, and then the image is relabelled as learned under the
/// run's configuration (restored into a controller of `cfg` and saved again), so that the
/// controller takes it with the run's `SessionConfig`. Returns the image, its header, and
/// the file's own bytes (to pair a simulator state with).
pub fn image_for(
    path: &Path,
    cfg: &trn_controller::Config,
    provenance: Provenance,
    allow_change: bool,
) -> Result<(Vec<u8>, checkpoint::Header, Vec<u8>)> {
    let (bytes, header) = read(path)?;
    if header.provenance == provenance && header.config_matches(cfg) {
        return Ok((bytes.clone(), header, bytes));
    }
    let mut ctrl = Box::new(Controller::new(*cfg));
    load(&mut ctrl, path, provenance, allow_change)?;
    let buf = image_of(&ctrl, provenance, path)?;
    let relabelled = checkpoint::verify(&buf).map_err(checkpoint_err(path))?;
    Ok((buf, relabelled, bytes))
}

/// Writes a checkpoint image (read out of a controller, verified) durably.
pub fn save_image(image: &[u8], path: &Path) -> Result<()> {
    checkpoint::verify(image).map_err(checkpoint_err(path))?;
    crate::fsio::write_durably(path, image)
}

/// [`save_with_state`] for an image read out of a controller. The pair is written so that a
/// kill at any moment leaves one that continues: the `.sim` of the pair on disk is kept as
/// `C.sim.prev` (a rename), the new `.sim` is written, then the checkpoint, then the kept
/// one is removed; until the checkpoint is replaced, the kept `.sim` is the one that pairs
/// with it ([`crate::sim_state::load_beside`] takes whichever of the two does).
pub fn save_image_with_state(
    image: &[u8],
    path: &Path,
    mut state: crate::sim_state::SimState,
) -> Result<()> {
    checkpoint::verify(image).map_err(checkpoint_err(path))?;
    let sim = crate::sim_state::path_beside(path);
    let prev = crate::sim_state::previous_beside(path);
    // keep the `.sim` that pairs with the checkpoint on disk; after a save that was killed
    // before its checkpoint, that is the one it kept, not the newer one beside it
    let on_disk = read(path).ok().map(|(bytes, _)| crc_of(&bytes));
    if on_disk.is_some() && crate::sim_state::paired_crc(&sim) == on_disk {
        std::fs::rename(&sim, &prev).map_err(io(&sim))?;
    }
    state.checkpoint_crc = crc_of(image);
    crate::sim_state::save(&state, &sim)?;
    crate::fsio::write_durably(path, image)?;
    let _ = std::fs::remove_file(&prev);
    Ok(())
}

/// Reads and verifies a checkpoint file (length, CRC, magic, version, shapes, values):
/// its bytes and header.
pub fn read(path: &Path) -> Result<(Vec<u8>, checkpoint::Header)> {
    let file = trn_plant::input::open(path).map_err(io(path))?;
    let meta = file.metadata().map_err(io(path))?;
    if !meta.is_file() {
        return Err(Error::Usage(format!(
            "checkpoint {}: not a regular file",
            path.display()
        )));
    }
    if meta.len() > checkpoint::MAX_SIZE as u64 {
        return Err(Error::Usage(format!(
            "checkpoint {}: {} bytes, more than any checkpoint ({} bytes at most): not a checkpoint",
            path.display(),
            meta.len(),
            checkpoint::MAX_SIZE
        )));
    }
    let mut bytes = Vec::new();
    // bounded: one byte more than any checkpoint tells a too-long file without reading it all
    // (it may have grown since)
    file.take(checkpoint::MAX_SIZE as u64 + 1)
        .read_to_end(&mut bytes)
        .map_err(io(path))?;
    let header = checkpoint::verify(&bytes).map_err(checkpoint_err(path))?;
    Ok((bytes, header))
}

/// The CRC a verified checkpoint file ends with: what a simulator checkpoint records to
/// be paired with it.
pub fn crc_of(bytes: &[u8]) -> u32 {
    let n = bytes.len();
    u32::from_le_bytes([bytes[n - 4], bytes[n - 3], bytes[n - 2], bytes[n - 1]])
}

/// Writes a checkpoint of `ctrl` durably (see the module).
pub fn save(ctrl: &Controller, provenance: Provenance, path: &Path) -> Result<()> {
    crate::fsio::write_durably(path, &image_of(ctrl, provenance, path)?)
}

/// Writes the pair a run continues from: the controller's checkpoint at `path` and the
/// simulator's `state` beside it (`path.sim`) with the checkpoint's CRC, each durably, a kill
/// at any moment leaving a pair that continues ([`save_image_with_state`]).
pub fn save_with_state(
    ctrl: &Controller,
    provenance: Provenance,
    path: &Path,
    state: crate::sim_state::SimState,
) -> Result<()> {
    save_image_with_state(&image_of(ctrl, provenance, path)?, path, state)
}

/// The checkpoint image of `ctrl` (errors named by `path`, where it goes).
fn image_of(ctrl: &Controller, provenance: Provenance, path: &Path) -> Result<Vec<u8>> {
    let mut buf = vec![0u8; checkpoint::MAX_SIZE];
    let n = checkpoint::save(ctrl, provenance, &mut buf).map_err(checkpoint_err(path))?;
    buf.truncate(n);
    Ok(buf)
}
