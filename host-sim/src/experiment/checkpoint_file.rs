//! Checkpoint files: reading and verifying one into a controller, writing one atomically.

use std::fs;
use std::path::Path;

use trn_controller::{checkpoint, Controller};

use crate::error::{io, Error, Result};

fn checkpoint_err(path: &Path) -> impl FnOnce(trn_controller::Error) -> Error + '_ {
    move |source| Error::Checkpoint {
        path: path.to_path_buf(),
        source,
    }
}

/// Reads and verifies a checkpoint into `ctrl`.
pub fn load(ctrl: &mut Controller, path: &Path) -> Result<()> {
    let bytes = fs::read(path).map_err(io(path))?;
    checkpoint::restore(ctrl, &bytes).map_err(checkpoint_err(path))?;
    Ok(())
}

/// Writes a checkpoint atomically: a temporary file beside the target, then a rename, so an
/// interrupted run never leaves a torn checkpoint.
pub fn save(ctrl: &Controller, path: &Path) -> Result<()> {
    let mut buf = vec![0u8; checkpoint::MAX_SIZE];
    let n = checkpoint::save(ctrl, &mut buf).map_err(checkpoint_err(path))?;
    let tmp = path.with_extension("tmp");
    fs::write(&tmp, &buf[..n]).map_err(io(&tmp))?;
    fs::rename(&tmp, path).map_err(io(path))?;
    Ok(())
}
