//! A node's tables over the bus: the stored copy (status, save, erase) and the checkpoint
//! image read out and written in by chunks (SPEC.md 3.5).

use postcard::experimental::max_size::MaxSize;
use serde::{Deserialize, Serialize};

/// Bytes of the checkpoint image in one chunk: 48, so that a chunk message (50 bytes) is no
/// larger than an `Observation` and every node's messages keep their size in RAM (8 segments
/// on CAN 2.0, 6 image bytes a frame, as many as 56 would carry in 9).
pub const CHUNK: usize = 48;

/// The chunk index past the last one of an image of `len` bytes (the number of chunks).
pub const fn chunk_count(len: u32) -> u32 {
    len.div_ceil(CHUNK as u32)
}

/// What to do with the stored copy.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize)]
pub enum StoreOp {
    /// Report the tables and the stored copy (`TablesStatus{Status}`).
    Status,
    /// Save the tables now (`TablesStatus{Saved}` when done).
    Save,
    /// Erase the stored copies (guarded: the nonce of a `GuardNonce{StoreErase}`).
    Erase,
}

/// A command about the stored copy (runner → controller).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct StoreCommand {
    /// What to do.
    pub op: StoreOp,
    /// For `Erase`, the nonce of a `GuardNonce{StoreErase}`; ignored otherwise (send 0).
    #[serde(with = "super::fixint")]
    pub nonce: u32,
}

/// Why a [`TablesStatus`] is sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize)]
pub enum TablesEvent {
    /// The answer to `StoreCommand{Status}`.
    Status,
    /// At boot: the stored copy `stored_sequence` was restored (the tables below).
    Restored,
    /// At boot: nothing was restored (no copy, or none this build takes); the tables are
    /// the reset ones.
    NotRestored,
    /// A save completed: the tables below are the stored copy `stored_sequence`.
    Saved,
    /// An image written in was verified, applied and stored as copy `stored_sequence`.
    Applied,
    /// The stored copies were erased.
    Erased,
}

/// The controller's tables and its stored copy (controller report).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct TablesStatus {
    /// Why it is sent.
    pub event: TablesEvent,
    /// Length of the tables' checkpoint image in bytes (what a reader reads); 0 for a
    /// controller without tables.
    #[serde(with = "super::fixint")]
    pub image_len: u32,
    /// Configuration fingerprint the tables were learned (or seeded) under.
    #[serde(with = "super::fixint")]
    pub fingerprint: u32,
    /// Stage-1 learning steps of the tables (0: never trained).
    #[serde(with = "super::fixint")]
    pub steps1: u32,
    /// Stage-2 learning steps.
    #[serde(with = "super::fixint")]
    pub steps2: u32,
    /// Sequence number of the newest stored copy; 0 when none is stored (or no store).
    #[serde(with = "super::fixint")]
    pub stored_sequence: u32,
}

/// 48 bytes of a checkpoint image (serde handles arrays of up to 32 elements: six rows of
/// eight, the same bytes in order on the wire).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct ChunkData([[u8; 8]; 6]);

impl ChunkData {
    /// `bytes`, zero-padded to [`CHUNK`] (at most [`CHUNK`] are taken).
    pub fn new(bytes: &[u8]) -> ChunkData {
        let mut rows = [[0u8; 8]; 6];
        for (i, b) in bytes.iter().take(CHUNK).enumerate() {
            rows[i / 8][i % 8] = *b;
        }
        ChunkData(rows)
    }

    /// The bytes.
    pub fn bytes(&self) -> [u8; CHUNK] {
        let mut out = [0u8; CHUNK];
        out.copy_from_slice(self.0.as_flattened());
        out
    }
}

/// Asks for chunk `index` of the controller's checkpoint image (reader → controller),
/// repeated when no chunk comes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct TableReadRequest {
    /// The chunk: image bytes `48 * index ..`.
    #[serde(with = "super::fixint")]
    pub index: u16,
}

/// Chunk `index` of the controller's checkpoint image (controller report): bytes `48 *
/// index ..`, zero beyond the image's end.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct TableReadChunk {
    /// The chunk.
    #[serde(with = "super::fixint")]
    pub index: u16,
    /// Its bytes.
    pub data: ChunkData,
}

/// Starts writing an image into the controller (writer → controller; guarded when its
/// tables learned): what the image is, checked before anything is applied.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct TableWriteBegin {
    /// The nonce of a `GuardNonce{TableWrite}` (any value when the tables never learned).
    #[serde(with = "super::fixint")]
    pub nonce: u32,
    /// The image's length in bytes.
    #[serde(with = "super::fixint")]
    pub image_len: u32,
    /// The image's CRC-32 (its last four bytes).
    #[serde(with = "super::fixint")]
    pub image_crc: u32,
    /// The configuration fingerprint in its header.
    #[serde(with = "super::fixint")]
    pub fingerprint: u32,
}

/// Chunk `index` of the image being written in (writer → controller), sent until
/// acknowledged; the last chunk's bytes beyond the image's end are zero.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct TableWriteChunk {
    /// The chunk.
    #[serde(with = "super::fixint")]
    pub index: u16,
    /// Its bytes.
    pub data: ChunkData,
}

/// The controller has every chunk before `next` of the image `image_crc` (controller
/// report): the answer to `TableWriteBegin` (`next` 0) and to every chunk, the one the writer
/// sends next.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct TableWriteAck {
    /// The next chunk expected (the chunk count once all came).
    #[serde(with = "super::fixint")]
    pub next: u16,
    /// The transfer's image CRC.
    #[serde(with = "super::fixint")]
    pub image_crc: u32,
}

/// Every chunk was sent: verify the image and apply it (writer → controller), repeated
/// until `TablesStatus{Applied}` or an error comes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct TableWriteEnd {
    /// The transfer's image CRC.
    #[serde(with = "super::fixint")]
    pub image_crc: u32,
}
