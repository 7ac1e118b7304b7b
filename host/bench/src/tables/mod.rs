//! A controller's learned tables over the bus, from the runner's side (protocol/SPEC.md 3.4
//! and 3.5): their status ([`status`]), the guard's nonces ([`nonce`]), reading the
//! checkpoint image out ([`read`]) and writing one in ([`write`](fn@write)), and what the controller's
//! refusals mean in words. Every request is repeated after the run's reply timeout when no
//! answer comes, and a transfer resumes where the controller says it stands, so a lost,
//! duplicated, reordered or corrupted frame costs a repeat, never a wrong table.
//!
//! [`opening`] decides, from the controller's status and the run's options, how a session
//! begins on a controller that may hold learned tables.

pub mod opening;
mod read;
mod write;

#[cfg(test)]
mod tests;

use crate::spec::{ControllerChoice, Profile};
use embedded_can::blocking::Can;
use trn_controller::presets::{Ablation, ImageSize, Preset};
use trn_node::codes::{self, table_op};
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{
    CanFrame, GuardNonce, GuardOp, GuardRequest, Message, NodeId, ProtocolVersion, StoreCommand,
    StoreOp, TablesEvent, TablesStatus,
};

pub use read::read;
pub use write::write;

use crate::error::{LabError, Result};
use crate::rig::Event;
pub use crate::runner::guard_refusal;
use crate::runner::Runner;
pub use trn_transport::board::tables_failure;

/// How many requests of a transfer (chunks read, chunks written) are in flight at once: a
/// round trip per eight chunks instead of one per chunk, few enough for a board's receive
/// queue.
pub const WINDOW: usize = 8;

/// Sends `msg` to the controller, again after every reply timeout without an answer, until
/// `answer` makes something of a message the controller sends (`Some(Ok)`: the answer;
/// `Some(Err)`: a refusal that ends the request); after the run's repeats, a failure naming
/// `what`.
pub(crate) fn request<P, T>(
    runner: &mut Runner<P>,
    msg: Message,
    what: &str,
    answer: impl FnMut(&Message) -> Option<Result<T>>,
) -> Result<T>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    let tries = runner.timing().retries + 1;
    request_tries(runner, msg, what, tries, answer)
}

/// [`request`] with `tries` sends at most.
fn request_tries<P, T>(
    runner: &mut Runner<P>,
    msg: Message,
    what: &str,
    tries: u32,
    mut answer: impl FnMut(&Message) -> Option<Result<T>>,
) -> Result<T>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    let timing = runner.timing();
    for attempt in 0..tries.max(1) {
        if attempt > 0 {
            runner.stats_mut().table_repeats += 1;
        }
        runner.rig_mut().send(NodeId::Controller, msg)?;
        let since = runner.rig().now();
        loop {
            let wait = timing.reply.saturating_sub(runner.rig().now() - since);
            match runner.rig_mut().next_event(wait, timing.silence)? {
                None => break,
                Some(Event::Controller(m)) => {
                    if let Some(r) = answer(&m) {
                        return r;
                    }
                }
                Some(_) => {}
            }
        }
    }
    Err(LabError::Controller(format!(
        "did not answer {what} after {} tries",
        tries.max(1)
    )))
}

/// The controller's tables: `StoreCommand{Status}` until `TablesStatus{Status}` comes.
pub fn status<P>(runner: &mut Runner<P>) -> Result<TablesStatus>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    let ask = StoreCommand {
        op: StoreOp::Status,
        nonce: 0,
    };
    request(
        runner,
        ask.into(),
        "a request for its tables' status",
        |m| match m {
            Message::TablesStatus(s) if s.event == TablesEvent::Status => Some(Ok(*s)),
            _ => None,
        },
    )
}

/// The protocol version a controller speaks, as its answer to the status request says
/// (SPEC.md "Versions").
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Spoken {
    /// Version 4: it answered `StoreCommand{Status}`, with this status.
    V4(TablesStatus),
    /// Version 3: alive (heard within the heartbeat supervision's timeout) all along, it
    /// never answered the status request, a kind version 3 does not have.
    V3,
}

impl Spoken {
    /// The version.
    pub fn version(&self) -> ProtocolVersion {
        match self {
            Spoken::V4(_) => ProtocolVersion::V4,
            Spoken::V3 => ProtocolVersion::V3,
        }
    }
}

/// Which protocol version the controller speaks: `StoreCommand{Status}` until
/// `TablesStatus{Status}` comes (version 4); after the run's repeats without one, version 3
/// if the controller was heard within the heartbeat supervision's timeout (its heartbeats),
/// a failure otherwise. The rig serves the controller in its version from then on.
pub fn probe<P>(runner: &mut Runner<P>) -> Result<Spoken>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    let spoken = match status(runner) {
        Ok(s) => Spoken::V4(s),
        Err(LabError::Controller(_)) if runner.rig().since_heard() <= runner.timing().alive => {
            Spoken::V3
        }
        Err(e) => return Err(e),
    };
    runner.rig_mut().serve_version(spoken.version());
    Ok(spoken)
}

/// How long a save may take: a board programs its flash (some seconds for 227 KB).
const SAVE_PATIENCE: std::time::Duration = std::time::Duration::from_secs(60);

/// Asks the controller to keep its tables in its store (`StoreCommand{Save}`) and waits
/// until they are (`TablesStatus{Saved}`; at once when nothing changed since the last
/// save). `Ok(Some(why))` when it keeps none: it has no store, or the save failed.
pub fn save<P>(runner: &mut Runner<P>) -> Result<Option<String>>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    let ask = StoreCommand {
        op: StoreOp::Save,
        nonce: 0,
    };
    let reply = runner
        .timing()
        .reply
        .max(std::time::Duration::from_millis(1));
    let tries = (SAVE_PATIENCE.as_millis() / reply.as_millis()).clamp(1, 1000) as u32;
    request_tries(
        runner,
        ask.into(),
        "a request to save its tables",
        tries,
        |m| match m {
            Message::TablesStatus(s) if s.event == TablesEvent::Saved => Some(Ok(None)),
            _ => failed(m, table_op::SAVE).map(|d| Ok(Some(tables_failure(d)))),
        },
    )
}

/// A nonce of the guard for `op`: `GuardRequest{op}` until `GuardNonce{op}` comes. A
/// controller that cannot issue nonces says so (`GUARD_REFUSED`, reason 5).
pub fn nonce<P>(runner: &mut Runner<P>, op: GuardOp) -> Result<GuardNonce>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    let op_code = trn_node::op_code(op);
    request(
        runner,
        GuardRequest { op }.into(),
        "a request for a nonce",
        |m| match m {
            Message::GuardNonce(n) if n.op == op && n.nonce != 0 => Some(Ok(*n)),
            Message::ErrorReport(e)
                if e.code == codes::GUARD_REFUSED && e.detail >> 8 == op_code =>
            {
                Some(Err(LabError::Controller(format!(
                    "gave no nonce: {}",
                    guard_refusal(e.detail)
                ))))
            }
            _ => None,
        },
    )
}

/// True for the guard's refusals that a new nonce may cure: stale, used, wrong (a nonce
/// that crossed a repeat of the request voided it).
pub(crate) fn retry_with_new_nonce(detail: u32) -> bool {
    matches!(
        detail & 0xFF,
        r if r == trn_node::Refusal::Stale as u32
            || r == trn_node::Refusal::Used as u32
            || r == trn_node::Refusal::Wrong as u32
    )
}

/// The named configuration (preset, ablation, law) whose fingerprint is `fingerprint` for
/// images of `image`, if one is.
pub fn configuration_named(fingerprint: u32, image: ImageSize) -> Option<String> {
    for &law in ControllerChoice::ALL {
        for &preset in Preset::ALL {
            for &ablation in Ablation::ALL {
                let profile = Profile {
                    preset,
                    ablation,
                    law,
                };
                if profile.fingerprint_of(&profile.config(image)) == fingerprint {
                    let mut s = format!("--preset {}", preset.name());
                    if ablation != Ablation::None {
                        s += &format!(" --ablation {}", ablation.name());
                    }
                    if law != ControllerChoice::Trn {
                        s += &format!(" --controller {}", law.name());
                    }
                    return Some(s);
                }
            }
        }
    }
    None
}

/// True when the tables a status describes learned (what the guard protects).
pub fn learned(s: &TablesStatus) -> bool {
    s.steps1 > 0 || s.steps2 > 0
}

/// What a status says the controller holds, in words: the learning steps and the
/// configuration they were learned under (named when a preset of `image` gives it).
pub fn describe(s: &TablesStatus, image: ImageSize) -> String {
    let under = match configuration_named(s.fingerprint, image) {
        Some(named) => format!("learned under {named}"),
        None => format!(
            "learned under a configuration no preset gives for {}x{} images (fingerprint {:#010x})",
            image.width, image.height, s.fingerprint
        ),
    };
    let stored = match s.stored_sequence {
        0 => "no stored copy".to_string(),
        n => format!("stored copy {n}"),
    };
    format!(
        "{} stage-1 and {} stage-2 learning steps, {under}; {} bytes; {stored}",
        s.steps1, s.steps2, s.image_len
    )
}

/// A `TABLES_FAILED` error report of operation `op`, if `m` is one: its detail.
pub(crate) fn failed(m: &Message, op: u32) -> Option<u32> {
    match m {
        Message::ErrorReport(e)
            if e.code == codes::TABLES_FAILED && (e.detail >> 8) & 0xFF == op =>
        {
            Some(e.detail)
        }
        _ => None,
    }
}
