//! How a session begins on a controller that may hold learned tables (SPEC 3.2, 3.4, 3.5):
//! the runner asks for the tables' status first, then
//!
//! | the run wants | the controller's tables never learned | they learned |
//! |---|---|---|
//! | new tables ([`Want::New`]: `trn train`, the conformance suite) | `SessionConfig{keep_tables: false}` | refused before anything changes, unless the user allowed it (`--reset-tables`): then said what is erased, and re-seeded with the guard's nonce (`ConfirmedSessionConfig`) |
//! | the tables it holds ([`Want::Held`]: `trn eval`, `trn grasp`, `trn train --keep-tables`) | kept if their configuration is the run's; else (and always for `trn train --keep-tables`) new ones seeded under the run's, whose fingerprint the controller must then announce ([`confirm`]) | kept (`keep_tables: true`) if learned under the run's configuration; refused otherwise, naming theirs |
//! | a checkpoint's tables ([`Want::Image`]: `--checkpoint-in`) | written in, then kept | written in with the guard's nonce if allowed (`--reset-tables`; said what is replaced), refused otherwise |
//!
//! Nothing destructive is sent before the check that allows it.
//!
//! A controller that speaks protocol version 3 (it never answers the status request, SPEC.md
//! "Versions") has no tables over the bus: its session begins with the run's
//! `SessionConfig` alone (new tables, or `keep_tables` for `trn eval` and `trn grasp`, which
//! the controller checks against its own), and a run that needs the tables read, written,
//! kept or erased (the options in [`Opening::needs_tables`], `--keep-tables`,
//! `--reset-tables`, a checkpoint) is refused before anything is sent, naming the version.

use embedded_can::blocking::Can;
use trn_controller::presets::ImageSize;
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{
    CanFrame, ConfirmedSessionConfig, GuardOp, ProtocolVersion, SessionConfig, TablesStatus,
};

use super::{
    configuration_named, describe, learned, nonce, probe, retry_with_new_nonce, write, Spoken,
};
use crate::error::{LabError, Result};
use crate::observe::Observer;
use crate::runner::{Refused, Runner};

/// What the run wants the controller's tables to be when its session begins.
#[derive(Debug, Clone, PartialEq)]
pub enum Want {
    /// New tables, seeded with the session's seed.
    New,
    /// The tables the controller holds, under the run's configuration; `or_new`: new ones
    /// when those never learned (`trn train --keep-tables`).
    Held {
        /// Seed new tables when the held ones never learned.
        or_new: bool,
    },
    /// A checkpoint's image, written in.
    Image(Vec<u8>),
}

/// The start of a session: what is wanted and allowed, and the run's configuration.
#[derive(Debug, Clone)]
pub struct Opening {
    /// What the run wants.
    pub want: Want,
    /// The user allowed erasing or replacing learned tables (`--reset-tables`).
    pub reset: bool,
    /// The run's session configuration (`keep_tables` is set here).
    pub session: SessionConfig,
    /// Its configuration fingerprint.
    pub fingerprint: u32,
    /// The cameras' image size (to name a configuration).
    pub image: ImageSize,
    /// The run's options beyond `want` and `reset` that need the tables over the bus
    /// (`--tables`, `--checkpoint-out`): a version-3 controller is refused with them.
    pub needs_tables: Vec<&'static str>,
}

/// How the session began.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Opened {
    /// The protocol version the controller speaks.
    pub version: ProtocolVersion,
    /// What the controller held before (none from a version-3 controller: it does not say).
    pub before: Option<TablesStatus>,
    /// The stage-1 learning steps of the tables the session runs on, when it keeps the
    /// tables the controller held (the schedule goes on from there).
    pub kept_steps: Option<u32>,
}

impl Opening {
    fn with_keep(&self, keep_tables: bool) -> SessionConfig {
        SessionConfig {
            keep_tables,
            ..self.session
        }
    }

    fn held(&self, s: &TablesStatus) -> String {
        format!("holds learned tables ({})", describe(s, self.image))
    }

    /// The options of the run that need the tables over the bus: the run's own, then
    /// `--keep-tables`, a checkpoint written in, `--reset-tables`.
    pub fn tables_needed_by(&self) -> Vec<&'static str> {
        let mut needs = self.needs_tables.clone();
        match self.want {
            Want::Held { or_new: true } => needs.push("--keep-tables"),
            Want::Image(_) => needs.push("--checkpoint-in"),
            _ => {}
        }
        if self.reset {
            needs.push("--reset-tables");
        }
        needs
    }

    /// Refused when the run needs the tables over the bus from a version-3 controller.
    pub fn check_v3(&self) -> Result<()> {
        let needs = self.tables_needed_by();
        if needs.is_empty() {
            return Ok(());
        }
        Err(LabError::Controller(format!(
            "speaks protocol v3, which has no tables over the bus (they came with v4: SPEC.md, Versions): {} {} a v4 controller",
            needs.join(", "),
            if needs.len() == 1 { "needs" } else { "need" }
        )))
    }
}

/// What the user is told about a version-3 controller's tables.
pub const V3_NOTICE: &str = "the controller speaks protocol v3: its tables are not read, checked or saved (tables over the bus came with v4)";

/// Begins the session on the controller (see the module): its status, then what the run
/// wants and allows; `observer` is told what is erased or replaced before it is.
pub fn open<P>(runner: &mut Runner<P>, o: &Opening, observer: &mut dyn Observer) -> Result<Opened>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    let before = match probe(runner)? {
        Spoken::V4(s) => s,
        Spoken::V3 => {
            o.check_v3()?;
            observer.notice(V3_NOTICE);
            // `trn eval`, `trn grasp`: the tables it holds, which it checks against the
            // configuration itself (CONFIG_REJECTED detail 2)
            let keep = matches!(o.want, Want::Held { .. });
            runner.configure(o.with_keep(keep))?;
            return Ok(Opened {
                version: ProtocolVersion::V3,
                before: None,
                kept_steps: None,
            });
        }
    };
    let mut kept_steps = None;
    match &o.want {
        Want::Held { or_new } if *or_new && !learned(&before) => {
            observer.notice("the controller's tables never learned: training new ones");
            runner.configure(o.with_keep(false))?;
            confirm(runner, o)?;
        }
        Want::Held { .. } if !learned(&before) && before.fingerprint != o.fingerprint => {
            // nothing learned to keep: its configuration (a reset one, or none yet) does not
            // matter; new tables under the run's, and then the fingerprint it announces for
            // the configuration it accepted must be that configuration's
            observer.notice(&format!(
                "the controller's tables never learned and were seeded under another configuration (its fingerprint {:#010x}, this run's {:#010x}): new ones seeded under this run's",
                before.fingerprint, o.fingerprint
            ));
            runner.configure(o.with_keep(false))?;
            confirm(runner, o)?;
        }
        Want::Held { .. } => {
            if before.fingerprint != o.fingerprint {
                let theirs = configuration_named(before.fingerprint, o.image)
                    .map(|named| format!(": run with {named} to use them"))
                    .unwrap_or_default();
                return Err(LabError::Controller(format!(
                    "holds tables learned under another configuration than this run's: its fingerprint {:#010x}, this run's {:#010x} (SPEC.md 3.2.1 gives the formula; {}){theirs}",
                    before.fingerprint,
                    o.fingerprint,
                    describe(&before, o.image)
                )));
            }
            if !learned(&before) {
                observer.notice("the controller's tables never learned");
            }
            runner.configure(o.with_keep(true))?;
            kept_steps = Some(before.steps1);
        }
        Want::New => {
            clear(runner, o, &before, observer)?;
            runner.configure(o.with_keep(false))?;
        }
        Want::Image(bytes) => {
            let guarded = learned(&before);
            if guarded && !o.reset {
                return Err(LabError::Controller(format!(
                    "{}: pass --reset-tables to replace them with the checkpoint, or keep them",
                    o.held(&before)
                )));
            }
            if guarded {
                observer.notice(&format!(
                    "replacing the controller's learned tables ({}) with the checkpoint",
                    describe(&before, o.image)
                ));
            }
            write(runner, bytes, guarded, observer)?;
            runner.configure(o.with_keep(true))?;
        }
    }
    Ok(Opened {
        version: ProtocolVersion::V4,
        before: Some(before),
        kept_steps,
    })
}

/// Checks that the configuration the controller accepted (it echoed the run's
/// `SessionConfig`) is the one it announces: its status's fingerprint must be the one SPEC.md
/// 3.2.1 gives for the run's configuration, else the run is refused naming both numbers.
pub fn confirm<P>(runner: &mut Runner<P>, o: &Opening) -> Result<()>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    let now = super::status(runner)?;
    if now.fingerprint == o.fingerprint {
        return Ok(());
    }
    let run = configuration_named(o.fingerprint, o.image).unwrap_or_else(|| {
        format!(
            "this run's configuration for {}x{} images",
            o.image.width, o.image.height
        )
    });
    Err(LabError::Controller(format!(
        "accepted the configuration of this run ({run}) but announces fingerprint {:#010x} for it, where SPEC.md 3.2.1 gives {:#010x}: its formula or its constants are not the spec's, so its tables could not be told apart from those of another configuration",
        now.fingerprint, o.fingerprint
    )))
}

/// Makes way for new tables: nothing to do on tables that never learned; learned tables
/// are refused unless the user allowed erasing them, then said and re-seeded through the
/// guard (the session's configuration with `keep_tables = false` is in force afterwards).
pub fn clear<P>(
    runner: &mut Runner<P>,
    o: &Opening,
    before: &TablesStatus,
    observer: &mut dyn Observer,
) -> Result<()>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    if !learned(before) {
        return Ok(());
    }
    if !o.reset {
        return Err(LabError::Controller(format!(
            "{}: pass --reset-tables to erase them, or keep them (trn train --keep-tables trains them on)",
            o.held(before)
        )));
    }
    observer.notice(&format!(
        "erasing the controller's learned tables ({})",
        describe(before, o.image)
    ));
    reseed(runner, o.with_keep(false))
}

/// Re-seeds learned tables with `session` (`keep_tables = false`) through the guard: a nonce
/// for the re-seed, then `ConfirmedSessionConfig` until echoed. A nonce refused as stale,
/// used or wrong (one that crossed a repeat of the request) is asked for again.
pub fn reseed<P>(runner: &mut Runner<P>, session: SessionConfig) -> Result<()>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    let mut last = None;
    for _ in 0..4 {
        let n = nonce(runner, GuardOp::Reseed)?;
        let confirmed = ConfirmedSessionConfig {
            config: session,
            nonce: n.nonce,
        };
        match runner.acknowledge(confirmed.into(), session.into())? {
            Ok(()) => return Ok(()),
            Err(Refused::Guard(d)) if retry_with_new_nonce(d) => last = Some(Refused::Guard(d)),
            Err(r) => {
                return Err(LabError::Controller(
                    r.describe("the re-seed of its learned tables"),
                ))
            }
        }
    }
    Err(LabError::Controller(
        last.map(|r| r.describe("the re-seed of its learned tables"))
            .unwrap_or_default(),
    ))
}
