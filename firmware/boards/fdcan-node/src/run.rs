//! The node's loop on a board: a turn of `service`, then sleep until a frame arrives or the
//! node's next timeout, with embassy-time's clock as the node's milliseconds.

use embassy_futures::select::{select, Either};
use embassy_stm32::rng::{self, Rng};
use embassy_time::{with_timeout, Duration, Instant, Timer};
use trn_controller::persist::StoredCopy;
use trn_controller::Control;
use trn_node::{
    reset_cause, seed_from_draws, BusAction, BusHealth, BusState, ControllerNode, NodeConfig,
    ResetFlags, SEED_DRAWS,
};
use trn_protocol::{BusMode, Encoder, Reassembler, DEFAULT_STALE_MS};

use crate::fdcan::Fdcan;
use crate::health;
use crate::port::FdcanPort;

/// The node's state beside the controller: the node, the frame encoder (CAN 2.0 until a
/// `SessionConfig` asks for FD) and the reassembler. `const`, all in static RAM
/// (`static_cell::ConstStaticCell`), none of it on the stack.
pub struct NodeState {
    node: ControllerNode,
    enc: Encoder,
    rx: Reassembler,
}

impl NodeState {
    /// A node in mode `Idle` with the firmware's timing ([`NodeConfig::DEFAULT`]: heartbeats
    /// every 100 ms, a request repeated up to 8 times, 200 ms apart; no saves by learning
    /// steps).
    pub const fn new() -> Self {
        Self::with_config(NodeConfig::DEFAULT)
    }

    /// A node in mode `Idle` with `cfg` (a board with a flash store sets
    /// `save_every_steps` from its flash's endurance).
    pub const fn with_config(cfg: NodeConfig) -> Self {
        NodeState {
            node: ControllerNode::new(cfg),
            enc: Encoder::new(BusMode::Classic),
            rx: Reassembler::new(DEFAULT_STALE_MS),
        }
    }

    /// At boot, before [`run`]: why the part last reset, from its reset `flags` (read from
    /// the clock controller and cleared by the board) and the record of the panic or
    /// hard-fault handler ([`crate::recover::take_record`]), logged and announced on the bus
    /// at the node's first turn, before its first heartbeat (`ErrorReport{RESET_CAUSE}`,
    /// `ControllerNode::announce_reset`); then the guard of the learned tables
    /// seeded from the part's hardware RNG ([`rng_draws`], `trn_node::seed_from_draws`), so
    /// the node issues the nonces that re-seeding, writing in and erasing tables over the bus
    /// need (`trn ... --reset-tables`, `StoreCommand{Erase}`). An RNG that gives no seed is
    /// logged, and the node refuses those operations (`GUARD_REFUSED` reason 5).
    pub async fn boot<T: rng::Instance>(&mut self, flags: ResetFlags, rng: &mut Rng<'_, T>) {
        let (cause, detail) = reset_cause(flags, crate::recover::take_record(flags.power_on));
        self.node.announce_reset(cause, detail);
        defmt::info!(
            "reset cause {} (detail 0x{:x}; 1 power-on, 2 pin, 3 watchdog, 4 panic at line, 5 hard fault at pc, 6 software)",
            cause as u8,
            detail
        );
        match seed_from_draws(rng_draws(rng).await) {
            Ok(seed) => {
                self.node.seed_guard(seed);
                defmt::info!("guard seeded from the RNG");
            }
            Err(e) => defmt::error!(
                "the RNG gave no seed ({} draws failed, {} repeated): tables cannot be replaced or erased over the bus",
                e.failed,
                e.repeated
            ),
        }
    }

    /// Tells the node what the board restored at boot (`None`: nothing): it announces it
    /// with `TablesStatus{Restored | NotRestored}` at its first turn
    /// ([`ControllerNode::tables_restored`]). Call it once, before [`run`].
    pub fn tables_restored<C: Control + ?Sized>(&mut self, ctrl: &mut C, copy: Option<StoredCopy>) {
        self.node.tables_restored(ctrl, copy);
    }
}

impl Default for NodeState {
    fn default() -> Self {
        Self::new()
    }
}

/// [`SEED_DRAWS`] words drawn from the part's RNG (embassy's driver), each bounded by
/// 10 ms: `None` for a draw that failed (a seed or clock error of the RNG, or no word in
/// time).
pub async fn rng_draws<T: rng::Instance>(rng: &mut Rng<'_, T>) -> [Option<u32>; SEED_DRAWS] {
    let mut draws = [None; SEED_DRAWS];
    for draw in &mut draws {
        let mut word = [0u8; 4];
        if let Ok(Ok(())) =
            with_timeout(Duration::from_millis(10), rng.async_fill_bytes(&mut word)).await
        {
            *draw = Some(u32::from_le_bytes(word));
        }
    }
    draws
}

/// The node's clock: milliseconds since boot, wrapping after 49.7 days (the node compares
/// its times with `wrapping_sub`).
pub fn now_ms() -> u32 {
    Instant::now().as_millis() as u32
}

/// When a node time `at_ms` falls: now if it has passed (or is now).
fn instant_of(at_ms: u32) -> Instant {
    let now = Instant::now();
    let ahead = at_ms.wrapping_sub(now.as_millis() as u32);
    if ahead == 0 || ahead > u32::MAX / 2 {
        now
    } else {
        now + Duration::from_millis(u64::from(ahead))
    }
}

/// Runs the controller node on `can` for ever. Its first turn announces why the part reset
/// (when the board called [`NodeState::boot`]). Each turn hands every received frame to the
/// node and runs its timers ([`ControllerNode::service`], the code path of the host and the
/// QEMU firmware); then the task sleeps until the receive interrupt brings a frame or the
/// node's [`ControllerNode::poll_timeout`] (its next heartbeat, or the repeat or give-up of
/// the request it waits on). Port errors (bus errors, a full transmit buffer) are logged and
/// counted; the node's own repeats recover what they cost.
///
/// Each turn first reads FDCAN1's health ([`health::read`]) into the node
/// ([`ControllerNode::bus_health_frames`]: its counters in the node's statistics, its
/// `BUS_STATE`/`BUS_COUNTS` reports sent when the state changes): while the peripheral is
/// bus-off the node's frames are dropped, and once the node's hold-off has passed the
/// peripheral is restarted ([`health::restart`]). A bus-off is seen within a turn (at most a
/// heartbeat period, 100 ms).
///
/// `feed` feeds the board's independent watchdog: called once a turn, and a turn comes at
/// least every heartbeat period (100 ms), so a loop that stops turning (a hang, a lost
/// interrupt) lets the watchdog reset the part. The watchdog's period must exceed the
/// longest turn (a store's erase of all its sectors on a `StoreCommand{Erase}`).
///
/// `ctrl` is the controller (`&mut Controller`: tables in RAM only) or the controller with
/// its flash store (`trn_controller::WithStore`): the node then saves the tables on a
/// `StoreCommand`, on entering `Mature` and every `NodeConfig::save_every_steps` learning
/// steps, a step of the save per turn (its turns come at once while a save runs).
pub async fn run<const TX: usize, const RX: usize, C: Control + ?Sized>(
    can: Fdcan<TX, RX>,
    ctrl: &mut C,
    state: &mut NodeState,
    mut feed: impl FnMut(),
) -> ! {
    let NodeState { node, enc, rx } = state;
    let mut port = FdcanPort::new(can.reader(), can.writer());
    let mut port_errors: u32 = 0;
    let mut trials = 0;
    let mut bus = BusState::ErrorActive;
    let mut health = BusHealth::new();
    loop {
        feed();
        bus_turn(node, &mut health, enc, &mut port, &mut bus);
        if let Err(e) = node.service(ctrl, rx, enc, &mut port, now_ms()) {
            port_errors = port_errors.wrapping_add(1);
            defmt::warn!("CAN port: {} ({} so far)", e, port_errors);
        }
        if node.stats().trials != trials {
            trials = node.stats().trials;
            defmt::info!(
                "trial {} (trials {}, aborted {}, frame errors {}, retries {}; stack high-water mark {} B)",
                node.trial(),
                trials,
                node.stats().aborted,
                node.stats().frame_errors,
                node.stats().retries,
                crate::stack::stack_high_water_mark()
            );
        }
        // the first turn ran the timers: there is always a next timeout (a heartbeat)
        let wake = node.poll_timeout().map_or_else(Instant::now, instant_of);
        if let Either::First(received) = select(port.reader().receive(), Timer::at(wake)).await {
            if let Err(e) = port.put_back(received) {
                port_errors = port_errors.wrapping_add(1);
                defmt::warn!("CAN bus error: {} ({} so far)", e, port_errors);
            }
        }
    }
}

/// A turn's reading of FDCAN1's health handed to the node; its reports queued, a restart
/// made when the node says so, the port kept from queueing frames while the bus is off.
fn bus_turn(
    node: &mut ControllerNode,
    health: &mut BusHealth,
    enc: &mut Encoder,
    port: &mut FdcanPort,
    last: &mut BusState,
) {
    use embedded_can::nb::Can;
    let reading = health::read();
    let mut off = reading.state == BusState::BusOff;
    port.set_off_bus(false);
    let action = node.bus_health_frames(health, &reading, enc, now_ms(), &mut |f| {
        // reports are sent only when the bus is not off; a full buffer drops them as any
        // frame (the next change is reported again)
        let _ = port.transmit(f);
    });
    if reading.state != *last {
        let c = node.stats().bus;
        defmt::warn!(
            "CAN {}: TEC {}, REC {} (bus-offs {}, error-passive {}, receive overruns {}, frames dropped while off {})",
            state_name(reading.state),
            reading.tec,
            reading.rec,
            c.bus_offs,
            c.passives,
            c.overruns,
            port.dropped_off_bus()
        );
        *last = reading.state;
    }
    if let Ok(BusAction::Restart) = action {
        health::restart();
        off = false;
        defmt::warn!(
            "CAN bus-off: restart {} after its hold-off, pending frames aborted",
            node.stats().bus.restarts
        );
    }
    port.set_off_bus(off);
}

fn state_name(s: BusState) -> &'static str {
    match s {
        BusState::ErrorActive => "error-active",
        BusState::ErrorWarning => "error-warning",
        BusState::ErrorPassive => "error-passive",
        BusState::BusOff => "bus-off",
    }
}
