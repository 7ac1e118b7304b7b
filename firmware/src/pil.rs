//! Processor-in-the-loop: the controller node (`trn-node`, the code the host runs) on CAN
//! frames carried as SLCAN lines over UART0; the simulator bridges them onto its bus
//! (host-sim `slcan:qemu`). Exits through semihosting after the runner's `ModeChange{Idle}`.

use cortex_m_semihosting::debug;
use trn_controller::Controller;
use trn_node::{ControllerNode, NodeConfig};
use trn_protocol::slcan::{self, MAX_LINE};
use trn_protocol::{BusMode, CanFrame, Encoder, Reassembler, DEFAULT_STALE_MS};

use crate::count::Clock;
use crate::uart::Uart;

fn send(uart: &mut Uart, f: &CanFrame) {
    let mut line = [0u8; MAX_LINE];
    let n = slcan::encode(f, &mut line);
    uart.write_all(&line[..n]);
}

/// The node's state, in static RAM rather than on the 8 KiB stack.
struct State {
    node: ControllerNode,
    enc: Encoder,
    rx: Reassembler,
    line: [u8; MAX_LINE],
}

static mut STATE: State = State {
    node: ControllerNode::new(NodeConfig {
        heartbeat_period_ms: 100,
        observation_timeout_ms: 2000,
        capture_retries: 2,
    }),
    enc: Encoder::new(BusMode::Classic),
    rx: Reassembler::new(DEFAULT_STALE_MS),
    line: [0; MAX_LINE],
};

// `poll` and `receive` are not inlined into `run`: their frames (message decoding and
// encoding) then share the same stack instead of adding up in `run`'s frame.

/// The node's timers (heartbeat, observation timeout, captures).
#[inline(never)]
fn poll(
    node: &mut ControllerNode,
    ctrl: &mut Controller,
    enc: &mut Encoder,
    now: u32,
    uart: &mut Uart,
) {
    // frame errors are counted by nobody here: a bad frame is dropped, as on the host
    let _ = node.poll_frames(ctrl, enc, now, &mut |f| send(uart, f));
}

/// One received frame.
#[inline(never)]
fn receive(
    node: &mut ControllerNode,
    ctrl: &mut Controller,
    rx: &mut Reassembler,
    enc: &mut Encoder,
    frame: &CanFrame,
    now: u32,
    uart: &mut Uart,
) {
    let _ = node.on_frame(ctrl, rx, enc, frame, now, &mut |f| send(uart, f));
}

/// Runs the node until the runner ends the session.
pub fn run(ctrl: &mut Controller, mut clock: Clock) -> ! {
    let mut uart = Uart::new();
    // SAFETY: the only access to STATE, taken once; single-threaded firmware, no interrupts.
    #[allow(unsafe_code)]
    let state: &'static mut State = unsafe { &mut *core::ptr::addr_of_mut!(STATE) };
    let State {
        node,
        enc,
        rx,
        line,
    } = state;
    let mut len = 0usize;
    loop {
        let now = clock.now_ms();
        poll(node, ctrl, enc, now, &mut uart);
        while let Some(b) = uart.read_byte() {
            if b == b'\r' || b == b'\n' {
                if len > 0 {
                    if let Ok(frame) = slcan::decode(&line[..len]) {
                        let now = clock.now_ms();
                        receive(node, ctrl, rx, enc, &frame, now, &mut uart);
                    }
                    len = 0;
                }
                if node.idle_requested() {
                    let stack = crate::count::stack_high_water_mark();
                    cortex_m_semihosting::hprintln!(
                        "trn-firmware pil: stack high-water mark: {} bytes",
                        stack
                    );
                    debug::exit(debug::EXIT_SUCCESS);
                }
            } else if len < MAX_LINE {
                line[len] = b;
                len += 1;
            } else {
                len = 0; // an overlong line is noise: drop it
            }
        }
    }
}
