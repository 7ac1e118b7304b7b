//! Writing a checkpoint image into a controller (SPEC 3.5): `TableWriteBegin` (with a nonce
//! of the guard when its tables learned) until acknowledged with the chunk it expects, the
//! chunks from there, [`WINDOW`] in flight and back to the one it expects when an
//! acknowledgement says a chunk went missing (go-back-N), then `TableWriteEnd` until it
//! applied the image. Whatever is lost, the controller's acknowledgement says where to go
//! on: a writer resumes there, and so does a new writer that repeats the same begin.

use embedded_can::blocking::Can;
use trn_controller::checkpoint;
use trn_node::codes::{self, table_op, table_reason};
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{
    chunk_count, CanFrame, ChunkData, GuardOp, Message, NodeId, TableWriteBegin, TableWriteChunk,
    TableWriteEnd, TablesEvent, TablesStatus, CHUNK,
};

use super::{failed, guard_refusal, nonce, request, retry_with_new_nonce, tables_failure, WINDOW};
use crate::error::{LabError, Result};
use crate::observe::Observer;
use crate::rig::Event;
use crate::runner::Runner;

/// How many times a write begins again (a new nonce, a controller that lost the transfer).
const BEGINS: usize = 5;

/// Where a phase of the write left it.
enum Next {
    /// Send the chunks from this one.
    Chunks(u16),
    /// Every chunk was acknowledged: end the transfer.
    End,
    /// Begin again (with a new nonce if the tables learned).
    Begin,
}

/// Writes `image` (a verified checkpoint) into the controller and waits until it applied
/// it; `guarded`: its tables learned, so the begin carries a nonce of the guard. Returns
/// the controller's `TablesStatus{Applied}`.
///
/// A controller whose store keeps compact images only (a part with little flash: its slots
/// hold half an f32 image) refuses the begin of an f32 image as out of range; the image is
/// then written again in the compact encoding (checkpoint format 3: the values rounded to
/// the compact tables' steps, as such a controller rounds them anyway), and a notice says so.
pub fn write<P>(
    runner: &mut Runner<P>,
    image: &[u8],
    guarded: bool,
    observer: &mut dyn Observer,
) -> Result<TablesStatus>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    let header = checkpoint::verify(image)
        .map_err(|e| LabError::Usage(format!("the image to write is not a checkpoint: {e}")))?;
    let (from, compact) = (header.encoding(), checkpoint::Encoding::Compact);
    // its status gives the length of its tables' read-out, in format 2 whatever was written
    let read_len = from.len_as(image.len(), checkpoint::Encoding::F32) as u32;
    match write_image(runner, image, &header, guarded, read_len)? {
        Written::Applied(s) => Ok(s),
        Written::TooLarge(d) if from == compact => Err(LabError::Controller(tables_failure(d))),
        Written::TooLarge(_) => {
            let mut buf = vec![0u8; compact.max_size()];
            let n = checkpoint::transcode(image, compact, &mut buf).map_err(|e| {
                LabError::Usage(format!("the image could not be made compact: {e}"))
            })?;
            observer.notice(&format!(
                "the controller's store takes compact tables only: writing them in checkpoint format {} ({n} bytes, the values rounded to its steps)",
                compact.version()
            ));
            // the same learning steps and fingerprint: only the values' encoding differs
            match write_image(runner, &buf[..n], &header, guarded, read_len)? {
                Written::Applied(s) => Ok(s),
                Written::TooLarge(d) => Err(LabError::Controller(tables_failure(d))),
            }
        }
    }
}

/// How a write ended.
enum Written {
    /// Applied: the controller's status.
    Applied(TablesStatus),
    /// The begin was refused as out of range (the `TABLES_FAILED` detail): the image is
    /// larger than the controller's store takes.
    TooLarge(u32),
}

/// Writes `image` (verified: its `header`) in; the controller's status after it must name
/// the header's learning steps and fingerprint, and `read_len` (the length of the tables'
/// read-out).
fn write_image<P>(
    runner: &mut Runner<P>,
    image: &[u8],
    header: &checkpoint::Header,
    guarded: bool,
    read_len: u32,
) -> Result<Written>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    let len = image.len() as u32;
    let crc = crate::checkpoint_file::crc_of(image);
    let count = chunk_count(len);
    if count > u16::MAX as u32 {
        return Err(LabError::Usage(format!(
            "an image of {len} bytes has too many chunks"
        )));
    }
    let mut guarded = guarded;
    let mut begins = 0;
    let mut next = Next::Begin;
    loop {
        next = match next {
            Next::Begin => {
                begins += 1;
                if begins > BEGINS {
                    return Err(LabError::Controller(format!(
                        "did not take the tables after {BEGINS} tries to write them in"
                    )));
                }
                let nonce = if guarded {
                    nonce(runner, GuardOp::TableWrite)?.nonce
                } else {
                    0
                };
                let begin = TableWriteBegin {
                    nonce,
                    image_len: len,
                    image_crc: crc,
                    fingerprint: header.config_fingerprint,
                };
                match begin_write(runner, begin)? {
                    Begun::At(n) if n as u32 >= count => Next::End,
                    Begun::At(n) => Next::Chunks(n),
                    Begun::Guard(d) if d & 0xFF == trn_node::Refusal::NoNonce as u32 => {
                        // its tables learned since the status was read
                        guarded = true;
                        Next::Begin
                    }
                    Begun::Guard(d) if retry_with_new_nonce(d) => Next::Begin,
                    Begun::Guard(d) => return Err(LabError::Controller(guard_refusal(d))),
                    Begun::TooLarge(d) => return Ok(Written::TooLarge(d)),
                }
            }
            Next::Chunks(from) => chunks(runner, image, from, count as u16, crc)?,
            Next::End => match end(runner, crc, count)? {
                Ended::Applied(s) => {
                    if (s.steps1, s.steps2, s.fingerprint, s.image_len)
                        != (header.t1, header.t2, header.config_fingerprint, read_len)
                    {
                        return Err(LabError::Controller(format!(
                            "applied tables other than those written in: its status {s:?}"
                        )));
                    }
                    return Ok(Written::Applied(s));
                }
                Ended::Resume(n) => Next::Chunks(n),
                Ended::Lost => Next::Begin,
            },
        }
    }
}

/// The answer to a begin.
enum Begun {
    /// Acknowledged: the chunk the controller expects.
    At(u16),
    /// Refused by the guard (the detail).
    Guard(u32),
    /// Refused as out of range (the detail): larger than the store takes.
    TooLarge(u32),
}

fn begin_write<P>(runner: &mut Runner<P>, begin: TableWriteBegin) -> Result<Begun>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    request(
        runner,
        begin.into(),
        "the begin of a table write",
        |m| match m {
            Message::TableWriteAck(a) if a.image_crc == begin.image_crc => {
                Some(Ok(Begun::At(a.next)))
            }
            Message::ErrorReport(e) if e.code == codes::GUARD_REFUSED && e.detail >> 8 == 2 => {
                Some(Ok(Begun::Guard(e.detail)))
            }
            _ => failed(m, table_op::WRITE_BEGIN).map(|d| {
                if d & 0xFF == table_reason::OUT_OF_RANGE {
                    Ok(Begun::TooLarge(d))
                } else {
                    Err(LabError::Controller(tables_failure(d)))
                }
            }),
        },
    )
}

/// Sends the chunks `from..count`, [`WINDOW`] unacknowledged at most; back to the chunk the
/// controller expects after a reply timeout, or when a whole window's acknowledgements
/// named it again (a chunk in between was lost or came out of order).
fn chunks<P>(runner: &mut Runner<P>, image: &[u8], from: u16, count: u16, crc: u32) -> Result<Next>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    let timing = runner.timing();
    let (mut base, mut sent) = (from, from);
    let (mut stalls, mut same) = (0, 0);
    let mut since = runner.rig().now();
    // the last acknowledgement that moved the window (or the start)
    let mut progress = since;
    while base < count {
        while sent < count && ((sent - base) as usize) < WINDOW {
            let at = sent as usize * CHUNK;
            let data = ChunkData::new(&image[at..image.len().min(at + CHUNK)]);
            let chunk = TableWriteChunk { index: sent, data };
            runner.rig_mut().send(NodeId::Controller, chunk.into())?;
            sent += 1;
        }
        let wait = runner.patience().wait(stalls);
        let wait = wait.saturating_sub(runner.rig().now() - since);
        let msg = match runner.rig_mut().next_event(wait, timing.silence)? {
            None => {
                stalls += 1;
                let quiet = runner.rig().now() - progress;
                if runner
                    .patience()
                    .exhausted(stalls, quiet, timing.retries + 1)
                {
                    // the controller stopped taking chunks: begin again, it says where it is
                    return Ok(Next::Begin);
                }
                runner.stats_mut().table_repeats += (sent - base) as u32;
                sent = base;
                since = runner.rig().now();
                continue;
            }
            Some(Event::Controller(m)) => m,
            Some(_) => continue,
        };
        match msg {
            Message::TableWriteAck(a) if a.image_crc == crc => {
                if a.next > base && a.next <= count {
                    base = a.next;
                    sent = sent.max(base);
                    (stalls, same) = (0, 0);
                    since = runner.rig().now();
                    progress = since;
                } else if a.next == base {
                    same += 1;
                    if same >= WINDOW {
                        runner.stats_mut().table_repeats += (sent - base) as u32;
                        (sent, same) = (base, 0);
                    }
                }
            }
            m => {
                if let Some(d) = failed(&m, table_op::WRITE_CHUNK) {
                    return Err(LabError::Controller(tables_failure(d)));
                }
            }
        }
    }
    Ok(Next::End)
}

/// The answer to an end.
enum Ended {
    /// Applied: the controller's status.
    Applied(TablesStatus),
    /// Not every chunk came: the one it expects.
    Resume(u16),
    /// It holds no transfer of this image (it lost it, or a corrupted end named another):
    /// begin again.
    Lost,
}

fn end<P>(runner: &mut Runner<P>, crc: u32, count: u32) -> Result<Ended>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    let end = TableWriteEnd { image_crc: crc };
    request(
        runner,
        end.into(),
        "the end of a table write",
        |m| match m {
            Message::TablesStatus(s) if s.event == TablesEvent::Applied => {
                Some(Ok(Ended::Applied(*s)))
            }
            Message::TableWriteAck(a) if a.image_crc == crc && (a.next as u32) < count => {
                Some(Ok(Ended::Resume(a.next)))
            }
            _ => failed(m, table_op::APPLY).map(|d| {
                if d & 0xFF == table_reason::NOT_STARTED {
                    Ok(Ended::Lost)
                } else {
                    Err(LabError::Controller(format!(
                        "did not take the tables written in: {}",
                        tables_failure(d)
                    )))
                }
            }),
        },
    )
}
