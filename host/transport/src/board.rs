//! The host's stand-in for a board: the project's controller with a store of its learned
//! tables ([`trn_store::FlashStore`]) in memory or in a file, booted as a board's firmware
//! boots it (the tables restored from the newest intact stored copy, the guard seeded, the
//! restore announced). The in-process controller and `controller-node` run on it.
//!
//! A tables file (`controller-node --tables FILE`, `trn --tables FILE`) is the board's
//! flash: two slots of [`FlashStore::slot_size_needed`] bytes, the memory in RAM and every
//! program and erase written through to the file, so that the tables survive a restart.
//! The header write that commits a copy is preceded and followed by an `fsync`, so even a
//! machine that loses power keeps the previous copy or the new one.

use std::fs::File;
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use embedded_storage::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};
use trn_controller::checkpoint::Encoding;
use trn_controller::persist::StoredCopy;
use trn_controller::WithStore;
use trn_controller::{Config, Controller};
use trn_node::{ControllerNode, NodeConfig};
use trn_store::{FlashStore, RamFlash, RamFlashError, RestoreError};

use trn_node::codes::{table_op, table_reason};

/// What a host board's store refused: the tables file cannot be used (another controller
/// holds it, or it is not a tables file of this build), or its I/O failed.
#[derive(Debug, thiserror::Error)]
pub enum BoardError {
    /// The tables file cannot be used, in words.
    #[error("{0}")]
    Usage(String),
    /// The tables file's I/O failed.
    #[error("{path}: {source}")]
    Io {
        /// The tables file.
        path: PathBuf,
        /// What failed.
        source: std::io::Error,
    },
}

/// The board's result.
pub type Result<T> = std::result::Result<T, BoardError>;

/// An I/O error on `path` as a [`BoardError`].
fn io(path: &Path) -> impl FnOnce(std::io::Error) -> BoardError + '_ {
    move |source| BoardError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Bytes of a program unit of the host's flash.
const WRITE: usize = 8;
/// Bytes of an erase page.
const ERASE: usize = 4096;

/// What the host's flash refused: the memory's refusal, or the file's I/O error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BoardFlashError {
    /// Misaligned or beyond the flash.
    Memory(RamFlashError),
    /// The tables file could not be written.
    Io(std::io::ErrorKind),
}

impl NorFlashError for BoardFlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            BoardFlashError::Memory(e) => e.kind(),
            BoardFlashError::Io(_) => NorFlashErrorKind::Other,
        }
    }
}

/// The host's flash: memory, written through to a file if it has one.
#[derive(Debug)]
pub struct BoardFlash {
    mem: RamFlash<Vec<u8>, WRITE, ERASE>,
    file: Option<(File, PathBuf)>,
    slot_size: u32,
}

impl BoardFlash {
    fn write_through(&mut self, at: u32, len: usize) -> std::result::Result<(), BoardFlashError> {
        let Some((file, _)) = &mut self.file else {
            return Ok(());
        };
        let bytes = &self.mem.memory()[at as usize..at as usize + len];
        let io = |e: std::io::Error| BoardFlashError::Io(e.kind());
        // a slot's first bytes are its header, the commit record: the image reaches the
        // disk before it, and it before anything else
        let commit = at.is_multiple_of(self.slot_size);
        if commit {
            file.sync_data().map_err(io)?;
        }
        file.seek(SeekFrom::Start(at as u64)).map_err(io)?;
        file.write_all(bytes).map_err(io)?;
        if commit {
            file.sync_data().map_err(io)?;
        }
        Ok(())
    }
}

impl ErrorType for BoardFlash {
    type Error = BoardFlashError;
}

impl ReadNorFlash for BoardFlash {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> std::result::Result<(), Self::Error> {
        self.mem
            .read(offset, bytes)
            .map_err(BoardFlashError::Memory)
    }

    fn capacity(&self) -> usize {
        self.mem.capacity()
    }
}

impl NorFlash for BoardFlash {
    const WRITE_SIZE: usize = WRITE;
    const ERASE_SIZE: usize = ERASE;

    fn erase(&mut self, from: u32, to: u32) -> std::result::Result<(), Self::Error> {
        self.mem.erase(from, to).map_err(BoardFlashError::Memory)?;
        self.write_through(from, (to - from) as usize)
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> std::result::Result<(), Self::Error> {
        self.mem
            .write(offset, bytes)
            .map_err(BoardFlashError::Memory)?;
        self.write_through(offset, bytes.len())
    }
}

/// The store of a host board.
pub type BoardStore = FlashStore<BoardFlash>;

/// A controller and its store, as a board holds them.
pub type Board = WithStore<Box<Controller>, BoardStore>;

/// The size of a tables file: both slots.
pub fn tables_file_len() -> u64 {
    2 * BoardStore::slot_size_needed() as u64
}

/// A store in memory (the in-process controller without a tables file): empty at start.
pub fn memory_store() -> BoardStore {
    memory_store_as(Encoding::F32)
}

/// A store in memory that saves images in `encoding`, with slots of that encoding's size:
/// [`Encoding::Compact`] stands for a board whose flash holds compact images only (an
/// STM32G474's).
pub fn memory_store_as(encoding: Encoding) -> BoardStore {
    let slot = BoardStore::slot_size_needed_as(encoding);
    let flash = BoardFlash {
        mem: RamFlash::new(vec![0; 2 * slot as usize]),
        file: None,
        slot_size: slot,
    };
    // cannot fail: the layout is the one the store asks for
    FlashStore::new_as(flash, 0, slot, encoding).expect("the store's own layout")
}

/// The store in the tables file `path`: created erased if no file of that name exists,
/// refused if it is not a regular file (a device, FIFO or socket is never written), not a
/// tables file of this build (its size; an existing empty file is not a new one), or another
/// process holds it.
pub fn file_store(path: &Path) -> Result<BoardStore> {
    let slot = BoardStore::slot_size_needed();
    let len = tables_file_len();
    match std::fs::metadata(path) {
        Ok(m) => check_tables_file(path, &m, len)?,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => create_erased(path, len)?,
        Err(e) => return Err(io(path)(e)),
    }
    // never created here: only the file checked above (or made whole by `create_erased`)
    let mut file = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(path)
        .map_err(io(path))?;
    match file.try_lock() {
        Ok(()) => {}
        Err(std::fs::TryLockError::WouldBlock) => {
            return Err(BoardError::Usage(format!(
                "tables file {}: another controller holds it",
                path.display()
            )))
        }
        Err(std::fs::TryLockError::Error(e)) => return Err(io(path)(e)),
    }
    // what was opened, should the path have been replaced since the check
    check_tables_file(path, &file.metadata().map_err(io(path))?, len)?;
    let mut mem = Vec::with_capacity(len as usize);
    (&mut file)
        .take(len + 1)
        .read_to_end(&mut mem)
        .map_err(io(path))?;
    if mem.len() as u64 != len {
        return Err(BoardError::Usage(format!(
            "tables file {}: changed while being read",
            path.display()
        )));
    }
    let flash = BoardFlash {
        mem: RamFlash::keeping(mem),
        file: Some((file, path.to_path_buf())),
        slot_size: slot,
    };
    Ok(FlashStore::new(flash, 0, slot).expect("the store's own layout"))
}

/// Refuses an existing `path` that is not a regular tables file of `len` bytes.
fn check_tables_file(path: &Path, meta: &std::fs::Metadata, len: u64) -> Result<()> {
    let usage = |what: String| {
        Err(BoardError::Usage(format!(
            "tables file {}: {what}",
            path.display()
        )))
    };
    if !meta.is_file() {
        return usage(
            "is not a regular file (a device, FIFO, socket or directory): a tables file is a \
             regular file, made where none exists"
                .into(),
        );
    }
    match meta.len() {
        found if found == len => Ok(()),
        0 => usage(format!(
            "is empty, not a tables file ({len} bytes): a new one is made only where no file \
             exists (remove it or give another path)"
        )),
        found => usage(format!(
            "{found} bytes, not a tables file of this build ({len} bytes): remove it or give \
             another path"
        )),
    }
}

/// Makes a new tables file at `path`, erased, whole or not at all: written and synced beside
/// it, then linked into place (if another process made one meanwhile, that one is kept).
fn create_erased(path: &Path, len: u64) -> Result<()> {
    let name = path.file_name().ok_or_else(|| {
        BoardError::Usage(format!("tables file {}: not a file name", path.display()))
    })?;
    let tmp = path.with_file_name(format!(
        ".{}.tmp-{}",
        name.to_string_lossy(),
        std::process::id()
    ));
    let made = (|| {
        let mut f = std::fs::OpenOptions::new()
            .write(true)
            .create(true)
            .truncate(true)
            .open(&tmp)?;
        f.write_all(&vec![0xFF; len as usize])?;
        f.sync_all()?;
        match std::fs::hard_link(&tmp, path) {
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Ok(()),
            other => other,
        }
    })();
    let _ = std::fs::remove_file(&tmp);
    made.map_err(io(path))
}

/// A board as it comes out of reset: the controller configured with `cfg` (zeroed tables,
/// as a board's RAM: a session seeds them), its store in `tables` (a file) or in memory, and
/// the newest intact stored copy restored into it. What the restore gave: the copy, or why
/// nothing was restored (the tables stay as they were).
pub fn boot(
    cfg: Config,
    tables: Option<&Path>,
) -> Result<(Board, std::result::Result<StoredCopy, RestoreError>)> {
    let store = match tables {
        Some(p) => file_store(p)?,
        None => memory_store(),
    };
    let mut board = WithStore {
        ctrl: Box::new(Controller::new(cfg)),
        store,
    };
    let restored = board.store.restore(&mut board.ctrl, None);
    Ok((board, restored))
}

/// Why a boot restored nothing, in words (`None`: nothing was stored, which is no news).
pub fn restore_problem(e: &RestoreError) -> Option<String> {
    match e {
        RestoreError::NothingStored => None,
        RestoreError::AllCorrupt => Some("no intact copy of the tables is stored".into()),
        RestoreError::Format { found } => Some(format!(
            "the stored tables are in store format {found}, which this build does not read"
        )),
        RestoreError::Image(e) => Some(format!("the stored tables are refused: {e}")),
        RestoreError::Fingerprint { .. } | RestoreError::Busy | RestoreError::Flash(_) => {
            Some(format!("the stored tables could not be restored ({e:?})"))
        }
    }
}

/// The guard's seed of a host node from a number (the in-process controller: the run's
/// guard sub-seed, so a run is reproducible), spread by SplitMix64 so that no seed gives the
/// all-zero state an unseeded guard has.
pub fn guard_seed(seed: u64) -> [u8; 16] {
    let mut x = seed;
    let mut next = || {
        x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = x;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    };
    let (a, b) = (next(), next() | 1);
    let mut s = [0u8; 16];
    s[..8].copy_from_slice(&a.to_le_bytes());
    s[8..].copy_from_slice(&b.to_le_bytes());
    s
}

/// A node for a host board: the host's timing, the guard seeded with `guard`, told what the
/// boot restored (announced at its first poll; trials refused until a session when the
/// restored tables learned).
pub fn node(
    board: &mut Board,
    restored: Option<StoredCopy>,
    guard: [u8; 16],
    cfg: NodeConfig,
) -> ControllerNode {
    let mut node = ControllerNode::new(cfg);
    node.seed_guard(guard);
    node.tables_restored(board, restored);
    node
}

/// Keeps the tables in the store now, as the node does when a runner asks
/// (`StoreCommand{Save}`): at once when nothing changed since the last save, else through
/// the save's steps. For an embedding about to end (a process at SIGTERM). `Err`: why
/// nothing was kept (no store, the flash failed).
pub fn save_now<C: trn_controller::Control + ?Sized>(
    node: &mut ControllerNode,
    ctrl: &mut C,
    clock: &dyn crate::Clock,
) -> std::result::Result<(), String> {
    use trn_protocol::{Envelope, Message, NodeId, StoreCommand, StoreOp, TablesEvent};
    let now = || crate::clock::millis(clock.now());
    let save = StoreCommand {
        op: StoreOp::Save,
        nonce: 0,
    };
    let mut out = trn_node::Outbox::new();
    node.on_message(
        ctrl,
        &Envelope::new(NodeId::Controller, save.into()),
        now(),
        &mut out,
    );
    // a save is a few hundred steps at most; bounded in case a flash never finishes
    for _ in 0..100_000 {
        for e in out.iter() {
            match e.msg {
                Message::TablesStatus(s) if s.event == TablesEvent::Saved => return Ok(()),
                Message::ErrorReport(r) if r.code == trn_node::codes::TABLES_FAILED => {
                    return Err(tables_failure(r.detail))
                }
                _ => {}
            }
        }
        out.clear();
        node.poll(ctrl, now(), &mut out);
    }
    Err("the save did not end".into())
}

/// A `TABLES_FAILED` detail in words.
pub fn tables_failure(detail: u32) -> String {
    let op = match (detail >> 8) & 0xFF {
        table_op::READ => "reading a chunk",
        table_op::WRITE_BEGIN => "beginning a write",
        table_op::WRITE_CHUNK => "writing a chunk",
        table_op::APPLY => "applying the image written in",
        table_op::SAVE => "saving",
        table_op::ERASE => "erasing",
        _ => "an operation on its tables",
    };
    let extra = detail >> 16;
    let why = match detail & 0xFF {
        table_reason::NO_TABLES => "it holds no TRN tables".to_string(),
        table_reason::NO_STORE => "it has no store for its tables".to_string(),
        table_reason::BUSY => "it is busy (not Idle, or a trial runs)".to_string(),
        table_reason::OUT_OF_RANGE => "out of range".to_string(),
        table_reason::NOT_STARTED => "no write in progress".to_string(),
        table_reason::INCOMPLETE => "not every chunk came".to_string(),
        table_reason::CRC_MISMATCH => "the image's CRC is not the one announced".to_string(),
        table_reason::FINGERPRINT_MISMATCH => {
            "the image's configuration is not the one announced".to_string()
        }
        table_reason::IMAGE => format!(
            "it refused the image ({})",
            match extra {
                0 => "length",
                1 => "magic",
                2 => "format version",
                3 => "network shapes",
                4 => "CRC",
                5 => "contents: learning steps or values beyond what it holds",
                6 => "changed while read",
                _ => "another reason",
            }
        ),
        table_reason::FLASH => format!("its flash failed (code {extra})"),
        table_reason::CHANGED => "the tables changed during the save".to_string(),
        r => format!("reason {r}"),
    };
    format!("{op} failed: {why}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use trn_controller::checkpoint::Provenance;
    use trn_controller::persist::TableStore;

    fn learned() -> Box<Controller> {
        let mut c = Box::new(Controller::new(Config::project_default()));
        c.init_random(9);
        c
    }

    fn save(board: &mut Board) -> StoredCopy {
        board
            .store
            .save_begin(&board.ctrl, Provenance::CUSTOM)
            .unwrap();
        loop {
            if let Some(c) = board.store.save_step(&board.ctrl).unwrap() {
                return c;
            }
        }
    }

    /// Tables saved into a tables file come back after a "restart" (the file opened again
    /// by a new board); a second board cannot open a file in use; a file of another size is
    /// refused. Fails if the file is not written through or not read back.
    #[test]
    fn a_tables_file_keeps_the_tables_across_a_restart() {
        let dir = std::env::temp_dir().join(format!("trn-board-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("tables.bin");
        let _ = std::fs::remove_file(&path);
        let cfg = Config::project_default();
        let copy = {
            let (mut b, restored) = boot(cfg, Some(&path)).unwrap();
            assert_eq!(restored, Err(RestoreError::NothingStored));
            assert!(
                matches!(file_store(&path), Err(BoardError::Usage(m)) if m.contains("holds it"))
            );
            b.ctrl = learned();
            save(&mut b)
        };
        assert_eq!(std::fs::metadata(&path).unwrap().len(), tables_file_len());
        let (b, restored) = boot(cfg, Some(&path)).unwrap();
        assert_eq!(restored, Ok(copy));
        let image = |c: &Controller| {
            let mut buf = vec![0; trn_controller::checkpoint::MAX_SIZE];
            let n = trn_controller::checkpoint::save(c, Provenance::CUSTOM, &mut buf).unwrap();
            buf.truncate(n);
            buf
        };
        assert_eq!(image(&b.ctrl), image(&learned()));
        drop(b);
        std::fs::write(&path, b"not tables").unwrap();
        let e = boot(cfg, Some(&path)).err().unwrap().to_string();
        assert!(e.contains("not a tables file"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A tables path that is not a regular file (a device, a FIFO) or an existing empty
    /// file is refused before anything is written: no path is taken for a new file unless
    /// nothing exists there. Fails if any of them is opened as a tables file (a device's or
    /// an empty file's length reads 0, which was taken for "new" and written over).
    #[test]
    fn a_device_fifo_or_empty_file_is_never_taken_for_a_new_tables_file() {
        let dir = std::env::temp_dir().join(format!("trn-board-dev-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let refused = |p: &Path, what: &str| match file_store(p) {
            Err(BoardError::Usage(m)) => assert!(m.contains(what), "{}: {m}", p.display()),
            other => panic!("{}: {:?}", p.display(), other.map(|_| ())),
        };
        refused(Path::new("/dev/null"), "not a regular file");
        refused(&dir, "not a regular file");
        #[cfg(unix)]
        {
            let fifo = dir.join("fifo.bin");
            assert!(std::process::Command::new("mkfifo")
                .arg(&fifo)
                .status()
                .unwrap()
                .success());
            refused(&fifo, "not a regular file");
        }
        let empty = dir.join("empty.bin");
        std::fs::write(&empty, b"").unwrap();
        refused(&empty, "is empty");
        assert_eq!(std::fs::metadata(&empty).unwrap().len(), 0);
        // a path where nothing exists is a new file, made whole, with no temporary left
        let new = dir.join("new.bin");
        assert!(file_store(&new).is_ok());
        assert_eq!(std::fs::metadata(&new).unwrap().len(), tables_file_len());
        let names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .flatten()
            .map(|e| e.file_name())
            .collect();
        assert!(
            names.iter().all(|n| !n.to_string_lossy().contains(".tmp-")),
            "{names:?}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn guard_seeds_differ_by_seed_and_are_never_all_zero() {
        assert_ne!(guard_seed(1), guard_seed(2));
        for s in [0, 1, u64::MAX] {
            assert_ne!(guard_seed(s), [0; 16]);
        }
    }
}
