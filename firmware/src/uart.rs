//! The CMSDK APB UART0 of the MPS2 boards (register level, polled): QEMU connects it to
//! `-serial`. A [`ByteLink`] for the SLCAN port.

use trn_protocol::slcan::ByteLink;

const BASE: usize = 0x4000_4000;
const DATA: usize = BASE;
const STATE: usize = BASE + 0x04;
const CTRL: usize = BASE + 0x08;
const BAUDDIV: usize = BASE + 0x10;
const TX_FULL: u32 = 1;
const RX_FULL: u32 = 2;

/// UART0.
pub struct Uart(());

#[allow(unsafe_code)]
fn read(reg: usize) -> u32 {
    // SAFETY: a device register of the CMSDK UART at its fixed address.
    unsafe { core::ptr::read_volatile(reg as *const u32) }
}

#[allow(unsafe_code)]
fn write(reg: usize, v: u32) {
    // SAFETY: a device register of the CMSDK UART at its fixed address.
    unsafe { core::ptr::write_volatile(reg as *mut u32, v) }
}

impl Uart {
    /// UART0, not yet enabled.
    pub const UART0: Uart = Uart(());

    /// Enables transmit and receive.
    pub fn enable(&mut self) {
        write(BAUDDIV, 16);
        write(CTRL, 0b11);
    }
}

impl ByteLink for Uart {
    /// Sends bytes, waiting while the transmit buffer is full.
    fn write_all(&mut self, bytes: &[u8]) -> trn_protocol::Result<()> {
        for &b in bytes {
            while read(STATE) & TX_FULL != 0 {}
            write(DATA, b as u32);
        }
        Ok(())
    }

    /// A received byte, if any.
    fn read_byte(&mut self) -> trn_protocol::Result<Option<u8>> {
        Ok(if read(STATE) & RX_FULL != 0 {
            Some(read(DATA) as u8)
        } else {
            None
        })
    }
}
