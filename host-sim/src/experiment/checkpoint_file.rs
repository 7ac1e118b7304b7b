//! Checkpoint files: read bounded and verified into a controller, written durably.
//!
//! Writing: a new temporary file in the target's directory (a name of its own, never an
//! existing file), the bytes, `fsync` of the file, a rename over the target, `fsync` of the
//! directory. A kill at any moment leaves the target holding the old or the new checkpoint
//! (at worst a stray temporary `.NAME.tmp-PID-N` beside it); no other file is touched.
//!
//! Reading: at most [`checkpoint::MAX_SIZE`] bytes of a regular file; the header must match
//! the configuration the run uses (preset, ablation, every value) unless the caller allows
//! a change.

use std::fs::{self, File, OpenOptions};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use trn_controller::checkpoint::{self, Provenance};
use trn_controller::Controller;

use crate::error::{io, Error, Result};

fn checkpoint_err(path: &Path) -> impl FnOnce(trn_controller::Error) -> Error + '_ {
    move |source| Error::Checkpoint {
        path: path.to_path_buf(),
        source,
    }
}

fn mismatch(path: &Path, what: String) -> Error {
    Error::Config(format!(
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
                "learned under another configuration (fingerprint differs)".into(),
            ));
        }
    }
    checkpoint::restore(ctrl, &bytes).map_err(checkpoint_err(path))?;
    Ok(())
}

/// Reads and verifies a checkpoint file (length, CRC, magic, version, shapes, values):
/// its bytes and header.
pub fn read(path: &Path) -> Result<(Vec<u8>, checkpoint::Header)> {
    let file = File::open(path).map_err(io(path))?;
    let meta = file.metadata().map_err(io(path))?;
    if !meta.is_file() {
        return Err(Error::Config(format!(
            "checkpoint {}: not a regular file",
            path.display()
        )));
    }
    let mut bytes = Vec::new();
    // bounded: one byte more than any checkpoint tells a too-long file without reading it all
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

static TEMP: AtomicU64 = AtomicU64::new(0);

/// A fresh temporary name beside `path` (never an existing file: created with `create_new`).
fn temp_beside(path: &Path) -> Result<(PathBuf, File)> {
    let dir = parent(path);
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    loop {
        let n = TEMP.fetch_add(1, Ordering::Relaxed);
        let tmp = dir.join(format!(".{name}.tmp-{}-{n}", std::process::id()));
        match OpenOptions::new().write(true).create_new(true).open(&tmp) {
            Ok(f) => return Ok((tmp, f)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(io(&tmp)(e)),
        }
    }
}

fn parent(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Checks before a run that `path` can take an output file: not a directory, in an
/// existing directory that can be written to (a file is created there and removed).
pub fn check_writable(path: &Path) -> Result<()> {
    if path.is_dir() {
        return Err(Error::Config(format!(
            "{}: is a directory, not a file",
            path.display()
        )));
    }
    let (tmp, file) = temp_beside(path)?;
    drop(file);
    fs::remove_file(&tmp).map_err(io(&tmp))
}

/// Writes a checkpoint of `ctrl` durably (see the module).
pub fn save(ctrl: &Controller, provenance: Provenance, path: &Path) -> Result<()> {
    let mut buf = vec![0u8; checkpoint::MAX_SIZE];
    let n = checkpoint::save(ctrl, provenance, &mut buf).map_err(checkpoint_err(path))?;
    write_durably(path, &buf[..n])
}

/// The write of [`save`] for any bytes.
pub fn write_durably(path: &Path, bytes: &[u8]) -> Result<()> {
    if path.is_dir() {
        return Err(Error::Config(format!(
            "{}: is a directory, not a file",
            path.display()
        )));
    }
    let (tmp, mut file) = temp_beside(path)?;
    let written = file
        .write_all(bytes)
        .and_then(|_| file.sync_all())
        .map_err(io(&tmp));
    drop(file);
    if let Err(e) = written.and_then(|_| fs::rename(&tmp, path).map_err(io(path))) {
        let _ = fs::remove_file(&tmp);
        return Err(e);
    }
    // the rename itself is durable once the directory is
    let dir = parent(path);
    File::open(&dir)
        .and_then(|d| d.sync_all())
        .map_err(io(&dir))
}
