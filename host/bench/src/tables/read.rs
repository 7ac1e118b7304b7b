//! Reading a controller's tables out: the checkpoint image chunk by chunk
//! (`TableReadRequest{k}` answered by `TableReadChunk{k}`), [`WINDOW`] requests in flight,
//! each repeated after the reply timeout while its chunk has not come; then the whole
//! checked as a checkpoint and against the status it was read for.

use embedded_can::blocking::Can;
use trn_controller::checkpoint;
use trn_node::codes::{table_op, table_reason};
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{chunk_count, CanFrame, Message, NodeId, TableReadRequest, TablesStatus, CHUNK};

use super::{failed, status, tables_failure, WINDOW};
use crate::error::{LabError, Result};
use crate::rig::Event;
use crate::runner::Runner;

/// How often a read whose image does not check (the tables learned between two chunks) is
/// started again.
const READS: usize = 3;

/// The checkpoint image of the controller's tables, read out for `status` (its length,
/// learning steps and configuration) and checked: `checkpoint::verify` and the header
/// against the status. An image that does not check is read again (with a new status) up
/// to three times. Read between trials, in `Idle` or `Mature` (nothing learns then).
pub fn read<P>(runner: &mut Runner<P>, status_now: &TablesStatus) -> Result<Vec<u8>>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    let mut st = *status_now;
    let mut problem = String::new();
    for attempt in 0..READS {
        if attempt > 0 {
            st = status(runner)?;
        }
        if st.image_len == 0 {
            return Err(LabError::Controller(
                "holds no TRN tables (its status gives an image of 0 bytes)".into(),
            ));
        }
        if st.image_len as usize > checkpoint::MAX_SIZE {
            return Err(LabError::Controller(format!(
                "announces an image of {} bytes, more than any checkpoint ({})",
                st.image_len,
                checkpoint::MAX_SIZE
            )));
        }
        let bytes = read_once(runner, st.image_len)?;
        problem = match checkpoint::verify(&bytes) {
            Ok(h)
                if (h.t1, h.t2, h.config_fingerprint)
                    == (st.steps1, st.steps2, st.fingerprint) =>
            {
                return Ok(bytes)
            }
            Ok(h) => format!(
                "the image's header ({} and {} learning steps, fingerprint {:#010x}) is not what its status says ({} and {}, {:#010x})",
                h.t1, h.t2, h.config_fingerprint, st.steps1, st.steps2, st.fingerprint
            ),
            Err(e) => format!("the image read out is not a checkpoint: {e}"),
        };
    }
    Err(LabError::Controller(format!(
        "gave no consistent image of its tables in {READS} reads: {problem}"
    )))
}

/// Every chunk of an image of `len` bytes, once.
fn read_once<P>(runner: &mut Runner<P>, len: u32) -> Result<Vec<u8>>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    let count = chunk_count(len) as usize;
    let mut bytes = vec![0u8; count * CHUNK];
    let mut have = vec![false; count];
    let mut received = 0;
    let mut next = 0;
    let mut asked: Vec<u16> = Vec::with_capacity(WINDOW);
    let timing = runner.timing();
    let mut stalls = 0;
    let mut since = runner.rig().now();
    // the last chunk that came (or the start)
    let mut progress = since;
    let ask = |runner: &mut Runner<P>, index: u16| -> Result<()> {
        let req = TableReadRequest { index };
        runner.rig_mut().send(NodeId::Controller, req.into())
    };
    while received < count {
        while asked.len() < WINDOW && next < count {
            if !have[next] {
                ask(runner, next as u16)?;
                asked.push(next as u16);
            }
            next += 1;
        }
        let wait = runner.patience().wait(stalls);
        let wait = wait.saturating_sub(runner.rig().now() - since);
        let event = runner.rig_mut().next_event(wait, timing.silence)?;
        let msg = match event {
            None => {
                // no chunk within the reply timeout: ask again for every one missing
                stalls += 1;
                let quiet = runner.rig().now() - progress;
                if runner
                    .patience()
                    .exhausted(stalls, quiet, timing.retries + 1)
                {
                    return Err(LabError::Controller(format!(
                        "stopped answering requests for its tables' chunks ({received} of {count} read)"
                    )));
                }
                for &i in &asked {
                    ask(runner, i)?;
                    runner.stats_mut().table_repeats += 1;
                }
                since = runner.rig().now();
                continue;
            }
            Some(Event::Controller(m)) => m,
            Some(_) => continue,
        };
        if let Message::TableReadChunk(c) = msg {
            let i = c.index as usize;
            if i < count && !have[i] {
                bytes[i * CHUNK..(i + 1) * CHUNK].copy_from_slice(&c.data.bytes());
                have[i] = true;
                received += 1;
                asked.retain(|&a| a != c.index);
                stalls = 0;
                since = runner.rig().now();
                progress = since;
            }
        } else if let Some(detail) = failed(&msg, table_op::READ) {
            // beyond the image: a request corrupted on its way (a repeat asks again)
            if detail & 0xFF != table_reason::OUT_OF_RANGE {
                return Err(LabError::Controller(tables_failure(detail)));
            }
        }
    }
    bytes.truncate(len as usize);
    Ok(bytes)
}
