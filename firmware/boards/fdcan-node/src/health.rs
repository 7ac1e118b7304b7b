//! FDCAN1's health read each turn, and its restart after a bus-off: the registers the node's
//! policy ([`trn_node::health`]) is fed from and acts through.
//!
//! The peripheral is started without embassy's automatic bus-off recovery, so a bus-off
//! leaves it in its initialisation state (CCCR.INIT, set by the hardware) until the policy's
//! hold-off has passed and [`restart`] lets it rejoin.

use embassy_stm32::pac;
use trn_node::{BusReading, BusState};

/// FDCAN1's protocol status (fault confinement state), error counters and receive FIFO
/// message-lost flags, the flags cleared. Reading PSR clears its last error codes (LEC,
/// DLEC), which embassy's receive interrupt reports as bus errors: those few go unreported.
pub fn read() -> BusReading {
    let regs = pac::FDCAN1;
    let psr = regs.psr().read();
    let ecr = regs.ecr().read();
    let ir = regs.ir().read();
    let lost = [ir.rfl(0), ir.rfl(1)];
    if lost.contains(&true) {
        // write-1-to-clear: only the flags seen set
        regs.ir().write(|w| {
            w.set_rfl(0, lost[0]);
            w.set_rfl(1, lost[1]);
        });
    }
    let state = if psr.bo() {
        BusState::BusOff
    } else if psr.ep() {
        BusState::ErrorPassive
    } else if psr.ew() {
        BusState::ErrorWarning
    } else {
        BusState::ErrorActive
    };
    BusReading {
        state,
        tec: ecr.tec(),
        rec: ecr.rec(),
        overruns: lost.iter().filter(|l| **l).count() as u32,
    }
}

/// After a bus-off's hold-off: the transmissions still pending in the peripheral's buffers
/// cancelled (TXBCR), then CCCR.INIT cleared, so the FDCAN waits for 129 times 11 recessive
/// bits and rejoins the bus error-active.
pub fn restart() {
    let regs = pac::FDCAN1;
    let pending = regs.txbrp().read().0;
    regs.txbcr().write(|w| w.0 = pending);
    regs.cccr().modify(|w| w.set_init(false));
}
