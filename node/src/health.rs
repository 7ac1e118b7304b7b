//! The CAN controller's health, without I/O: what a board reads from its CAN controller each
//! turn goes in ([`BusReading`]), and out come what the board must do (restart after a
//! bus-off, once its hold-off has passed: [`BusAction`]), the counters of the node's
//! statistics ([`BusCounters`], in [`crate::NodeStats::bus`]) and the reports on the bus
//! (`ErrorReport{BUS_STATE}` and `ErrorReport{BUS_COUNTS}`, protocol/SPEC.md section 7).
//!
//! The policy (the anchors: candleLight's 100 ms bus-off restart delay, CANopen's
//! emergency on error-passive and bus-off):
//! - **bus-off**: counted; the board keeps the controller off the bus (it does not recover on
//!   its own) and drops what the node sends meanwhile; after a hold-off of
//!   [`HOLD_OFF_MS`] the board is told to restart (frames still pending in the controller
//!   aborted, then the bus rejoined). A bus-off within [`STABLE_MS`] of the previous one
//!   doubles the hold-off, up to [`HOLD_OFF_MAX_MS`]: a node that cannot stay on the bus
//!   (a wrong bit rate, a shorted pair) rejoins ever less often instead of disturbing it ten
//!   times a second.
//! - **error-passive** entries and **receive overruns** are counted.
//! - **reports**: when the state differs from the last one reported, or the bus-offs or
//!   overruns grew, the node sends both reports with the counters, at most one pair per
//!   [`REPORT_GAP_MS`] (a state that flaps is reported at its latest), and never while
//!   the bus is off (the pair waits until the node is back on the bus).

use trn_protocol::{ErrorReport, NodeId};

use crate::codes;
use crate::outbox::{push, Outbox};

/// The fault confinement state of a CAN controller (ISO 11898-1), best first.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord)]
pub enum BusState {
    /// Both error counters below 96.
    #[default]
    ErrorActive = 0,
    /// An error counter at 96 or above (the controller's warning flag).
    ErrorWarning = 1,
    /// An error counter above 127: the node sends only passive error flags.
    ErrorPassive = 2,
    /// The transmit error counter passed 255: the node is off the bus.
    BusOff = 3,
}

/// What a board read from its CAN controller at the start of a turn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BusReading {
    /// The fault confinement state.
    pub state: BusState,
    /// The transmit error counter.
    pub tec: u8,
    /// The receive error counter.
    pub rec: u8,
    /// Receive overruns seen since the last reading (each at least one frame lost).
    pub overruns: u32,
}

/// The CAN controller's counters, in the node's statistics.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BusCounters {
    /// The state last read.
    pub state: BusState,
    /// The transmit error counter last read.
    pub tec: u8,
    /// The receive error counter last read.
    pub rec: u8,
    /// Times the controller went bus-off.
    pub bus_offs: u32,
    /// Restarts after a bus-off (each after its hold-off).
    pub restarts: u32,
    /// Times the controller became error-passive (from a better state).
    pub passives: u32,
    /// Receive overruns (each at least one frame lost).
    pub overruns: u32,
    /// Pairs of health reports sent.
    pub reports: u32,
}

impl BusCounters {
    /// The zero counters, error-active.
    pub const ZERO: BusCounters = BusCounters {
        state: BusState::ErrorActive,
        tec: 0,
        rec: 0,
        bus_offs: 0,
        restarts: 0,
        passives: 0,
        overruns: 0,
        reports: 0,
    };

    /// `ErrorReport{BUS_STATE}`'s detail: `state << 16 | tec << 8 | rec`.
    pub fn state_detail(&self) -> u32 {
        (self.state as u32) << 16 | u32::from(self.tec) << 8 | u32::from(self.rec)
    }

    /// `ErrorReport{BUS_COUNTS}`'s detail: `bus-offs << 16 | overruns`, each saturating at
    /// 0xFFFF.
    pub fn counts_detail(&self) -> u32 {
        self.bus_offs.min(0xFFFF) << 16 | self.overruns.min(0xFFFF)
    }
}

/// What the board must do after a reading.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BusAction {
    /// Nothing.
    None,
    /// The controller is bus-off and the hold-off has passed: abort the frames pending in
    /// the controller, then let it rejoin the bus (on an FDCAN, clear CCCR.INIT).
    Restart,
}

/// The first hold-off after a bus-off before the restart (ms).
pub const HOLD_OFF_MS: u32 = 100;
/// The longest hold-off (ms): the first one doubled four times.
pub const HOLD_OFF_MAX_MS: u32 = HOLD_OFF_MS << 4;
/// A bus-off this long after the previous one starts again from [`HOLD_OFF_MS`] (ms).
pub const STABLE_MS: u32 = 10_000;
/// The shortest time between two pairs of reports (ms).
pub const REPORT_GAP_MS: u32 = 1_000;

/// What the last pair of reports said.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Reported {
    state: BusState,
    bus_offs: u32,
    overruns: u32,
}

/// The policy's state beside the counters (the counters are the node's,
/// [`crate::NodeStats::bus`]): the board keeps it beside the node, so a build that reads no
/// CAN controller (the QEMU firmware, the host) spends no RAM on it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BusHealth {
    /// When the bus-off in progress began, or its last restart.
    off_since: Option<u32>,
    /// When the last bus-off began.
    last_off: Option<u32>,
    /// Bus-offs in a row, each within [`STABLE_MS`] of the one before (capped at 4).
    streak: u8,
    reported: Reported,
    last_report: Option<u32>,
}

impl Default for BusHealth {
    fn default() -> Self {
        Self::new()
    }
}

impl BusHealth {
    /// No bus-off seen, nothing reported (an error-active controller with no counts is
    /// what the first report would say, so it is not sent).
    pub const fn new() -> Self {
        BusHealth {
            off_since: None,
            last_off: None,
            streak: 0,
            reported: Reported {
                state: BusState::ErrorActive,
                bus_offs: 0,
                overruns: 0,
            },
            last_report: None,
        }
    }

    /// The hold-off of the bus-off in progress (ms).
    fn hold_off(&self) -> u32 {
        HOLD_OFF_MS << self.streak
    }

    /// Takes a reading into `c` and says what the board must do.
    pub(crate) fn update(&mut self, c: &mut BusCounters, r: &BusReading, now_ms: u32) -> BusAction {
        let was = c.state;
        c.state = r.state;
        c.tec = r.tec;
        c.rec = r.rec;
        c.overruns = c.overruns.saturating_add(r.overruns);
        if r.state == BusState::ErrorPassive && was < BusState::ErrorPassive {
            c.passives = c.passives.saturating_add(1);
        }
        if r.state != BusState::BusOff {
            self.off_since = None;
            return BusAction::None;
        }
        if was != BusState::BusOff {
            c.bus_offs = c.bus_offs.saturating_add(1);
            let again = self
                .last_off
                .is_some_and(|t| now_ms.wrapping_sub(t) < STABLE_MS);
            self.streak = if again { (self.streak + 1).min(4) } else { 0 };
            self.last_off = Some(now_ms);
            self.off_since = Some(now_ms);
        }
        let since = self.off_since.unwrap_or(now_ms);
        if now_ms.wrapping_sub(since) >= self.hold_off() {
            c.restarts = c.restarts.saturating_add(1);
            self.off_since = Some(now_ms);
            return BusAction::Restart;
        }
        BusAction::None
    }

    /// Pushes the pair of reports into `out` when it is due (see the module's policy).
    pub(crate) fn report(&mut self, c: &mut BusCounters, now_ms: u32, out: &mut Outbox) {
        if c.state == BusState::BusOff {
            return;
        }
        let now = Reported {
            state: c.state,
            bus_offs: c.bus_offs,
            overruns: c.overruns,
        };
        if now == self.reported {
            return;
        }
        if self
            .last_report
            .is_some_and(|t| now_ms.wrapping_sub(t) < REPORT_GAP_MS)
        {
            return;
        }
        for (code, detail) in [
            (codes::BUS_STATE, c.state_detail()),
            (codes::BUS_COUNTS, c.counts_detail()),
        ] {
            push(out, NodeId::Controller, ErrorReport { code, detail }.into());
        }
        c.reports = c.reports.saturating_add(1);
        self.reported = now;
        self.last_report = Some(now_ms);
    }
}
