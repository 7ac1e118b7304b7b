//! The rule every file the tools write follows (stated in [`crate::output`]), as a leaf
//! below the files that use it: the check of an output path (rule 1), the durable write
//! through a temporary file beside the target (rule 2) and the checkpoint's lock (rule 3).

use std::fs::{self, File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{io, LabError, Result};

/// The kinds of output and the extensions each takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A JSON report or result file.
    Json,
    /// A picture.
    Plot,
    /// A candump log.
    Candump,
    /// A table of rows.
    Csv,
    /// A checkpoint (any name but another kind's extension).
    Checkpoint,
    /// A recording of a live view.
    Recording,
    /// The simulator's state beside a checkpoint (`NAME.sim`).
    SimState,
}

impl Kind {
    fn extensions(self) -> &'static [&'static str] {
        match self {
            Kind::Json => &["json"],
            Kind::Plot => &["png", "svg"],
            Kind::Candump => &["log"],
            Kind::Csv => &["csv"],
            Kind::Recording => &["rrd"],
            Kind::SimState => &["sim"],
            Kind::Checkpoint => &[],
        }
    }

    /// What a file of this kind is, in a message.
    pub fn what(self) -> &'static str {
        match self {
            Kind::Json => "this report",
            Kind::Plot => "this plot",
            Kind::Candump => "this candump log",
            Kind::Csv => "this CSV",
            Kind::Recording => "this recording",
            Kind::Checkpoint => "this checkpoint",
            Kind::SimState => "this simulator state",
        }
    }

    pub(crate) fn option(self) -> &'static str {
        match self {
            Kind::Json => "--report",
            Kind::Plot => "--plot",
            Kind::Candump => "--candump",
            Kind::Csv => "--csv",
            Kind::Recording => "--rerun-save",
            Kind::Checkpoint => "--checkpoint-out",
            Kind::SimState => "--checkpoint-out's .sim",
        }
    }
}

/// Extensions no checkpoint may have (they belong to another kind of file).
const NOT_A_CHECKPOINT: [&str; 8] = ["json", "png", "svg", "log", "csv", "sim", "toml", "rrd"];

pub(crate) fn usage(path: &Path, what: &str) -> LabError {
    LabError::Usage(format!("{}: {what}", path.display()))
}

/// What tells two paths apart: the file itself (device and inode) when it exists, so a
/// hard link is the same file; else the canonical directory joined with the name.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Identity {
    File(u64, u64),
    Path(PathBuf),
}

pub(crate) fn identity(path: &Path) -> Identity {
    #[cfg(unix)]
    if let Ok(m) = fs::metadata(path) {
        use std::os::unix::fs::MetadataExt;
        return Identity::File(m.dev(), m.ino());
    }
    if let Ok(p) = fs::canonicalize(path) {
        return Identity::Path(p);
    }
    let dir = parent(path);
    let name = path.file_name().map(PathBuf::from).unwrap_or_default();
    Identity::Path(fs::canonicalize(&dir).unwrap_or(dir).join(name))
}

/// Checks one output path against rule 1 (its inputs aside): what it is now, its extension,
/// its directory.
pub fn check_path(path: &Path, kind: Kind) -> Result<()> {
    match fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => {
            return Err(usage(
                path,
                "is a symbolic link: give the path of the file itself",
            ))
        }
        Ok(m) if m.is_dir() => return Err(usage(path, "is a directory, not a file")),
        Ok(m) if !m.is_file() => {
            return Err(usage(
                path,
                "is not a regular file (a device, FIFO or socket): outputs are files",
            ))
        }
        Ok(m) if m.permissions().readonly() => {
            return Err(usage(path, "is read-only"));
        }
        _ => {}
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match (kind, ext.as_deref()) {
        (Kind::Checkpoint, Some(e)) if NOT_A_CHECKPOINT.contains(&e) => {
            return Err(usage(
                path,
                &format!(
                    "a checkpoint is not a .{e} file (that extension belongs to another output)"
                ),
            ))
        }
        (Kind::Checkpoint, _) => {}
        (k, Some(e)) if k.extensions().contains(&e) => {}
        (k, _) => {
            return Err(usage(
                path,
                &format!(
                    "{} writes a {} file",
                    k.option(),
                    k.extensions()
                        .iter()
                        .map(|e| format!(".{e}"))
                        .collect::<Vec<_>>()
                        .join(" or ")
                ),
            ))
        }
    }
    clean_stale_temporaries(path);
    // the directory exists and takes a new file
    let (tmp, file) = temp_beside(path).map_err(|e| match e {
        LabError::Io { source, .. } => LabError::Io {
            path: path.to_path_buf(),
            source,
        },
        other => other,
    })?;
    drop(file);
    let _ = fs::remove_file(&tmp);
    Ok(())
}

/// Writes `value` as pretty JSON to `path` (rule 2).
pub fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<()> {
    let json = serde_json::to_vec_pretty(value).map_err(|e| LabError::Io {
        path: path.to_path_buf(),
        source: e.into(),
    })?;
    write_durably(path, &json)
}

/// A file being written: a temporary file beside its target until [`PendingFile::commit`]
/// renames it over the target; dropped uncommitted, it is removed and the target is as it
/// was. Write errors name the target.
#[derive(Debug)]
pub struct PendingFile {
    target: PathBuf,
    tmp: PathBuf,
    file: Option<BufWriter<File>>,
    /// The first write error (a full disk), kept for the error that names the target.
    error: Option<std::io::ErrorKind>,
}

impl PendingFile {
    /// Starts writing `target`.
    pub fn create(target: &Path) -> Result<PendingFile> {
        let (tmp, file) = temp_beside(target).map_err(|e| match e {
            LabError::Io { source, .. } => io(target)(source),
            other => other,
        })?;
        Ok(PendingFile {
            target: target.to_path_buf(),
            tmp,
            file: Some(BufWriter::new(file)),
            error: None,
        })
    }

    /// The first write error, if a write failed.
    pub fn write_error(&self) -> Option<std::io::ErrorKind> {
        self.error
    }

    /// The temporary file's path (for writers that need a path, e.g. a plotting library:
    /// it has the target's extension).
    pub fn temporary_path(&self) -> &Path {
        &self.tmp
    }

    /// The target.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Flushes, syncs and renames over the target; the directory is synced.
    pub fn commit(mut self) -> Result<()> {
        let target = self.target.clone();
        let file = self.file.take();
        let done = match file {
            Some(w) => w
                .into_inner()
                .map_err(|e| e.into_error())
                .and_then(|f| f.sync_all()),
            None => Ok(()),
        };
        done.and_then(|_| fs::rename(&self.tmp, &target))
            .map_err(io(&target))?;
        sync_dir(&target)
    }
}

impl Write for PendingFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let r = match &mut self.file {
            Some(f) => f.write(buf),
            None => Err(std::io::ErrorKind::BrokenPipe.into()),
        };
        self.note(r)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        let r = match &mut self.file {
            Some(f) => f.flush(),
            None => Ok(()),
        };
        self.note(r)
    }
}

impl PendingFile {
    fn note<T>(&mut self, r: std::io::Result<T>) -> std::io::Result<T> {
        if let Err(e) = &r {
            self.error.get_or_insert(e.kind());
        }
        r
    }
}

impl Drop for PendingFile {
    fn drop(&mut self) {
        if self.file.is_some() || self.tmp.exists() {
            self.file = None;
            let _ = fs::remove_file(&self.tmp);
        }
    }
}

static TEMP: AtomicU64 = AtomicU64::new(0);

/// The prefix of a temporary file of `path`'s (`.NAME.tmp-`).
fn temp_prefix(path: &Path) -> String {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    format!(".{name}.tmp-")
}

/// A fresh temporary file beside `path` (never an existing file: created with
/// `create_new`), with `path`'s extension.
fn temp_beside(path: &Path) -> Result<(PathBuf, File)> {
    let dir = parent(path);
    let prefix = temp_prefix(path);
    let ext = path
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    loop {
        let n = TEMP.fetch_add(1, Ordering::Relaxed);
        let tmp = dir.join(format!("{prefix}{}-{n}{ext}", std::process::id()));
        match OpenOptions::new().write(true).create_new(true).open(&tmp) {
            Ok(f) => return Ok((tmp, f)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(io(&tmp)(e)),
        }
    }
}

/// Removes temporary files of `path` left by writers whose process is gone.
fn clean_stale_temporaries(path: &Path) {
    let prefix = temp_prefix(path);
    let Ok(entries) = fs::read_dir(parent(path)) else {
        return;
    };
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let Some(rest) = name.strip_prefix(&prefix) else {
            continue;
        };
        let Some(pid) = rest.split('-').next().and_then(|p| p.parse::<u32>().ok()) else {
            continue;
        };
        if pid != std::process::id() && !process_alive(pid) {
            let _ = fs::remove_file(e.path());
        }
    }
}

#[cfg(target_os = "linux")]
fn process_alive(pid: u32) -> bool {
    Path::new(&format!("/proc/{pid}")).exists()
}

#[cfg(not(target_os = "linux"))]
fn process_alive(_: u32) -> bool {
    true // unknown: keep the file
}

/// Takes the exclusive lock `.NAME.lock` beside `path`, held while the returned file lives
/// (rule 3): a second run writing the same output is refused at once, naming `what` it
/// would write, instead of the last writer's file winning.
pub fn lock_beside(path: &Path, what: &str) -> Result<File> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let lock = parent(path).join(format!(".{name}.lock"));
    let file = OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&lock)
        .map_err(io(&lock))?;
    match file.try_lock() {
        Ok(()) => Ok(file),
        Err(fs::TryLockError::WouldBlock) => Err(usage(
            path,
            &format!(
                "another run is writing {what} (its lock {} is held): wait for it or choose another path",
                lock.display()
            ),
        )),
        Err(fs::TryLockError::Error(e)) => Err(io(&lock)(e)),
    }
}

/// Makes the folder `dir` (and the folders above it) for outputs that go into a folder (a
/// study's runs and tables, a sweep's plants). A part of the path that is a file, not a
/// folder, is refused by name, where `create_dir_all` would say only "Not a directory" or
/// "File exists".
pub fn create_folder(dir: &Path) -> Result<()> {
    for above in dir.ancestors().filter(|a| !a.as_os_str().is_empty()) {
        match fs::metadata(above) {
            Ok(m) if m.is_dir() => break,
            Ok(_) if above == dir => {
                return Err(usage(
                    dir,
                    "is a file, not a folder: these outputs go into a folder",
                ))
            }
            Ok(_) => {
                return Err(usage(
                    above,
                    &format!(
                        "is a file, not a folder: the outputs go into the folder {}",
                        dir.display()
                    ),
                ))
            }
            Err(_) => {}
        }
    }
    fs::create_dir_all(dir).map_err(io(dir))
}

/// The directory of a file (`.` for a bare name).
pub fn parent(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

fn sync_dir(path: &Path) -> Result<()> {
    let dir = parent(path);
    File::open(&dir)
        .and_then(|d| d.sync_all())
        .map_err(io(&dir))
}

/// Writes `bytes` to `path` whole or not at all (rule 2).
pub fn write_durably(path: &Path, bytes: &[u8]) -> Result<()> {
    if path.is_dir() {
        return Err(usage(path, "is a directory, not a file"));
    }
    let mut f = PendingFile::create(path)?;
    f.write_all(bytes).map_err(io(path))?;
    f.commit()
}
