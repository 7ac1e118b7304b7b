//! Processor-in-the-loop: the controller node (`trn-node`, the code the host runs) on CAN
//! frames carried as SLCAN lines over UART0; the simulator bridges them onto its bus
//! (host-sim `slcan:qemu`). The UART is an `embedded-can` port ([`SlcanPort`]) and the loop
//! is [`ControllerNode::service`], the same seam and the same code path as the host's.
//! Exits through semihosting after the runner's `ModeChange{Idle}`.

use cortex_m_semihosting::debug;
use trn_controller::Controller;
use trn_node::{ControllerNode, NodeConfig};
use trn_protocol::slcan::SlcanPort;
use trn_protocol::{BusMode, Encoder, Reassembler, DEFAULT_STALE_MS};

use crate::count::Clock;
use crate::uart::Uart;

/// The node's state, in static RAM rather than on the 8 KiB stack.
struct State {
    node: ControllerNode,
    enc: Encoder,
    rx: Reassembler,
    port: SlcanPort<Uart>,
}

static mut STATE: State = State {
    node: ControllerNode::new(NodeConfig::DEFAULT),
    enc: Encoder::new(BusMode::Classic),
    rx: Reassembler::new(DEFAULT_STALE_MS),
    port: SlcanPort::new(Uart::UART0),
};

/// Runs the node until the runner ends the session.
pub fn run(ctrl: &mut Controller, mut clock: Clock) -> ! {
    // SAFETY: the only access to STATE, taken once; single-threaded firmware, no interrupts.
    #[allow(unsafe_code)]
    let state: &'static mut State = unsafe { &mut *core::ptr::addr_of_mut!(STATE) };
    let State {
        node,
        enc,
        rx,
        port,
    } = state;
    port.link_mut().enable();
    loop {
        // a transport error of the UART cannot happen (polled registers); a bad frame is
        // dropped and counted by the node, as on the host
        let _ = node.service(ctrl, rx, enc, port, clock.now_ms());
        if node.idle_requested() {
            let stack = crate::count::stack_high_water_mark();
            cortex_m_semihosting::hprintln!(
                "trn-firmware pil: stack high-water mark: {} bytes",
                stack
            );
            debug::exit(debug::EXIT_SUCCESS);
        }
    }
}
