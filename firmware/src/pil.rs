//! Processor-in-the-loop: the controller node (`trn-node`, the code the host runs) on CAN
//! frames carried as SLCAN lines over UART0; the simulator bridges them onto its bus
//! (the host's `--bus slcan:qemu`). The UART is an `embedded-can` port ([`SlcanPort`]) and the loop
//! is [`ControllerNode::service`], the same seam and the same code path as the host's.
//!
//! The node boots as a board's does: its guard seeded (`store::entropy`), what the store of
//! its tables holds announced ([`store`], in emulated flash, erased at boot; compact images
//! in the compact build). It runs across sessions, as a board does: after each session's
//! `ModeChange{Idle}` it prints its stack's high-water mark over semihosting; the simulator
//! ends QEMU when its run is over, and the firmware exits by itself when nothing came over
//! the UART for a minute of its clock (a simulator that died).

use cortex_m_semihosting::{debug, hprintln};
use trn_controller::Controller;
use trn_node::{ControllerNode, NodeConfig};
use trn_protocol::slcan::SlcanPort;
use trn_protocol::{BusMode, CanFrame, Encoder, Reassembler, DEFAULT_STALE_MS};

use crate::count::Clock;
use crate::store;
use crate::uart::Uart;
use crate::watchdog;

/// Without a frame for this long (ms of the firmware's clock) the firmware exits: about ten
/// minutes of wall time under QEMU's instruction counting, far beyond any pause of a run.
const ORPHANED_MS: u32 = 60_000;

/// The port, remembering whether a frame came in.
struct Port {
    inner: SlcanPort<Uart>,
    received: bool,
}

impl embedded_can::nb::Can for Port {
    type Frame = CanFrame;
    type Error = trn_protocol::Error;

    fn transmit(&mut self, frame: &CanFrame) -> nb::Result<Option<CanFrame>, Self::Error> {
        self.inner.transmit(frame)
    }

    fn receive(&mut self) -> nb::Result<CanFrame, Self::Error> {
        let f = self.inner.receive()?;
        self.received = true;
        Ok(f)
    }
}

/// The node's state, in static RAM rather than on the 8 KiB stack.
struct State {
    node: ControllerNode,
    enc: Encoder,
    rx: Reassembler,
    port: Port,
}

static mut STATE: State = State {
    node: ControllerNode::new(NodeConfig::DEFAULT),
    enc: Encoder::new(BusMode::Classic),
    rx: Reassembler::new(DEFAULT_STALE_MS),
    port: Port {
        inner: SlcanPort::new(Uart::UART0),
        received: false,
    },
};

/// The store of the tables, made at boot.
static mut STORE: Option<store::Store> = None;

/// Runs the node until the simulator ends QEMU (or stops sending for [`ORPHANED_MS`]).
pub fn run(ctrl: &'static mut Controller, mut clock: Clock) -> ! {
    // SAFETY: the only access to STATE, taken once; single-threaded firmware, no interrupts.
    #[allow(unsafe_code)]
    let state: &'static mut State = unsafe { &mut *core::ptr::addr_of_mut!(STATE) };
    let State {
        node,
        enc,
        rx,
        port,
    } = state;
    // the cause of the last reset, then the watchdog armed (fed once a turn below)
    let (cause, detail) = watchdog::take_cause();
    hprintln!(
        "trn-firmware pil: reset cause {} (1 power-on, 3 watchdog)",
        cause as u32
    );
    watchdog::start();
    #[cfg(feature = "watchdog-test")]
    watchdog_test(cause);
    node.seed_guard(store::entropy());
    // the emulated flash is erased at every boot (QEMU keeps nothing between runs): there is
    // nothing to restore, and the node announces so
    // SAFETY: the only access to STORE, taken once; single-threaded firmware, no interrupts.
    // In static RAM (as a board's is, in its executor's task), not on the stack.
    #[allow(unsafe_code)]
    let stored: &'static mut Option<store::Store> = unsafe { &mut *core::ptr::addr_of_mut!(STORE) };
    let mut board = trn_controller::WithStore {
        ctrl,
        store: stored.insert(store::store()),
    };
    node.tables_restored(&mut board, None);
    let ctrl: &mut dyn trn_controller::Control = &mut board;
    // announced at the node's first turn, before its first heartbeat, as a board announces it
    node.announce_reset(cause, detail);
    port.inner.link_mut().enable();
    let mut idle = false;
    let mut heard_ms = clock.now_ms();
    loop {
        watchdog::feed();
        let now = clock.now_ms();
        // a transport error of the UART cannot happen (polled registers); a bad frame is
        // dropped and counted by the node, as on the host
        let _ = node.service(ctrl, rx, enc, port, now);
        if core::mem::take(&mut port.received) {
            heard_ms = now;
        } else if now.wrapping_sub(heard_ms) > ORPHANED_MS {
            hprintln!("trn-firmware pil: no frame for a minute of its clock: exiting");
            debug::exit(debug::EXIT_SUCCESS);
        }
        if node.idle_requested() && !idle {
            let stack = crate::count::stack_high_water_mark();
            hprintln!("trn-firmware pil: stack high-water mark: {} bytes", stack);
        }
        idle = node.idle_requested();
    }
}

/// The watchdog's test image (`--features pil,watchdog-test`): after a power-on it stops
/// feeding the watchdog and spins, so the watchdog's NMI records its cause and its second
/// time-out resets the machine; the boot after that reads the record, says so and exits.
#[cfg(feature = "watchdog-test")]
fn watchdog_test(cause: trn_node::ResetCause) {
    if cause == trn_node::ResetCause::Watchdog {
        hprintln!(
            "trn-firmware watchdog-test: reset by the watchdog, its cause read from the record"
        );
        debug::exit(debug::EXIT_SUCCESS);
    }
    hprintln!("trn-firmware watchdog-test: no longer feeding the watchdog");
    loop {
        core::hint::spin_loop();
    }
}
