//! The crate's single error type.

use core::fmt;

use crate::kind::MessageKind;

/// Every failure the protocol crate can report.
///
/// One flat enum: framing, decoding, reassembly, transport and log parsing errors.
/// Receivers turn every malformed, lost, duplicated, reordered, truncated, corrupt or
/// stale input into one of these variants; nothing in the crate panics on bad input.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum Error {
    /// An identifier that is not an 11-bit standard id (> 0x7FF, or an extended id).
    InvalidId(u32),
    /// The 7-bit kind field of a CAN id names no message kind.
    UnknownKind(u8),
    /// The 4-bit node field names no node (or a servo joint index is out of range).
    InvalidNode(u8),
    /// This message kind may not be addressed to / sent from that node.
    NodeNotAllowed {
        /// The message kind.
        kind: MessageKind,
        /// The raw 4-bit node field.
        node: u8,
    },
    /// A frame payload length that the frame type cannot carry
    /// (classical > 8 bytes, FD > 64 bytes or not a valid FD DLC length).
    InvalidFrameLength(usize),
    /// A frame payload length differs from what its kind and position require
    /// (truncated or padded frame).
    WrongLength {
        /// The length the layout requires.
        expected: usize,
        /// The length received.
        got: usize,
    },
    /// An FD frame was required or supplied where the bus / kind does not allow it.
    FrameFormat,
    /// The payload bytes do not decode as the kind's layout.
    Decode,
    /// Serialising a message failed (buffer too small: a bug in the size table).
    Encode,
    /// A decoded field is outside its documented range (e.g. raw > 4095, NaN).
    OutOfRange(&'static str),
    /// FD padding bytes were not zero.
    BadPadding,
    /// The CRC-32 over a multi-frame (or FD) message does not match.
    Checksum {
        /// CRC carried in the message.
        received: u32,
        /// CRC computed over the received bytes.
        computed: u32,
    },
    /// A segment header is malformed (index beyond the segment count, bad length byte).
    BadSegmentHeader,
    /// A segment arrived out of sequence: one or more segments were lost or reordered.
    /// The transfer is discarded.
    SequenceGap {
        /// The segment index expected next.
        expected: u8,
        /// The segment index received.
        got: u8,
    },
    /// The same segment arrived twice; the copy was ignored and the transfer continues.
    DuplicateSegment {
        /// Index of the duplicated segment.
        index: u8,
    },
    /// A continuation segment arrived with no transfer in progress for its id
    /// (its first segment was lost, or it was reordered after a gap).
    OrphanSegment,
    /// A first segment arrived while a previous transfer on the same id was still
    /// incomplete; the previous transfer is discarded (its tail was lost) and the new
    /// one is started.
    TransferAborted,
    /// A continuation segment belongs to another transfer than the one in progress.
    TransferMismatch,
    /// A transfer was not completed within the stale timeout and was discarded.
    Stale,
    /// Every reassembly slot is busy with a fresh transfer; the first segment was dropped.
    NoFreeSlot,
    /// The bus is in the bus-off state (fault injection) and cannot transmit.
    BusOff,
    /// A candump log line could not be parsed.
    CandumpSyntax,
    /// The named SocketCAN interface does not exist.
    InterfaceNotFound(heapless::String<16>),
    /// The named interface exists but takes no CAN socket (not a CAN device, or no CAN
    /// support in this kernel).
    NotCanInterface(heapless::String<16>),
    /// An operating-system I/O error (SocketCAN, files).
    #[cfg(feature = "std")]
    Io(std::io::ErrorKind),
}

/// The crate's result type.
pub type Result<T> = core::result::Result<T, Error>;

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::InvalidId(id) => write!(f, "invalid CAN id {id:#x}: not an 11-bit standard id"),
            Error::UnknownKind(k) => write!(f, "unknown message kind {k:#04x}"),
            Error::InvalidNode(n) => write!(f, "invalid node id {n}"),
            Error::NodeNotAllowed { kind, node } => {
                write!(f, "message kind {kind:?} not allowed for node {node}")
            }
            Error::InvalidFrameLength(l) => write!(f, "invalid frame payload length {l}"),
            Error::WrongLength { expected, got } => {
                write!(f, "wrong payload length: expected {expected}, got {got}")
            }
            Error::FrameFormat => write!(f, "frame format (classical/FD) not allowed here"),
            Error::Decode => write!(f, "payload does not decode"),
            Error::Encode => write!(f, "message could not be encoded"),
            Error::OutOfRange(field) => write!(f, "field `{field}` out of range"),
            Error::BadPadding => write!(f, "non-zero FD padding"),
            Error::Checksum { received, computed } => write!(
                f,
                "checksum mismatch: received {received:#010x}, computed {computed:#010x}"
            ),
            Error::BadSegmentHeader => write!(f, "malformed segment header"),
            Error::SequenceGap { expected, got } => {
                write!(f, "segment sequence gap: expected {expected}, got {got}")
            }
            Error::DuplicateSegment { index } => write!(f, "duplicate segment {index}"),
            Error::OrphanSegment => write!(f, "continuation segment without a transfer"),
            Error::TransferAborted => write!(f, "incomplete transfer replaced by a new one"),
            Error::TransferMismatch => write!(f, "segment belongs to another transfer"),
            Error::Stale => write!(f, "stale transfer discarded"),
            Error::NoFreeSlot => write!(f, "no free reassembly slot"),
            Error::BusOff => write!(f, "bus off"),
            Error::CandumpSyntax => write!(f, "malformed candump line"),
            Error::InterfaceNotFound(name) => write!(f, "CAN interface `{name}` does not exist"),
            Error::NotCanInterface(name) => write!(
                f,
                "`{name}` is not a CAN interface (or this kernel has no CAN support)"
            ),
            #[cfg(feature = "std")]
            Error::Io(kind) => write!(f, "I/O error: {kind}"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for Error {}

#[cfg(feature = "std")]
impl From<std::io::Error> for Error {
    fn from(e: std::io::Error) -> Self {
        Error::Io(e.kind())
    }
}

impl embedded_can::Error for Error {
    fn kind(&self) -> embedded_can::ErrorKind {
        embedded_can::ErrorKind::Other
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::string::ToString;

    #[test]
    fn display_names_the_problem() {
        assert!(Error::OutOfRange("raw").to_string().contains("raw"));
        assert!(Error::SequenceGap {
            expected: 2,
            got: 4
        }
        .to_string()
        .contains("expected 2"));
    }
}
