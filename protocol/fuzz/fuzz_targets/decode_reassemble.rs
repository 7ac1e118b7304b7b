//! Fuzz frame decoding, reassembly and candump parsing.
//!
//! The input is a sequence of frames `[flags, id_lo, id_hi, len, data...]`
//! (flags bit 0 = FD, bits 1..=7 = milliseconds since the previous frame). Frames are
//! mostly steered onto valid ids of long kinds so the reassembler's state machine is
//! exercised. Invariants: no panic; the slot count stays bounded; every decoded message
//! validates and re-encodes to frames that decode to the same message.
#![no_main]

use libfuzzer_sys::fuzz_target;
use trn_protocol::*;

const SLOTS: usize = 4;

fn check_round_trip(env: &Envelope) {
    env.msg.validate().expect("decoded message must validate");
    for mode in [BusMode::Classic, BusMode::Fd] {
        let frames = Encoder::new(mode).encode(env).expect("decoded message must encode");
        let mut rx: Reassembler = Reassembler::new(DEFAULT_STALE_MS);
        let mut got = None;
        for f in &frames {
            got = rx.push(f, 0).expect("re-encoded frames must decode");
        }
        assert_eq!(got.as_ref(), Some(env));
    }
}

fuzz_target!(|data: &[u8]| {
    if let Ok(s) = core::str::from_utf8(data) {
        if let Ok(r) = candump::parse_line(s) {
            let line = candump::format_line(r.timestamp_us, &r.iface, &r.frame).unwrap();
            assert_eq!(candump::parse_line(&line).unwrap(), r);
        }
    }
    let mut rx: Reassembler<SLOTS> = Reassembler::new(20);
    let mut now = 0u32;
    let mut rest = data;
    while rest.len() >= 4 {
        let flags = rest[0];
        let mut id = u16::from_le_bytes([rest[1], rest[2]]);
        // Steer 3 of 4 ids onto the long kinds (0x11, 0x20..0x22, 0x28) of valid nodes.
        if id & 0xC000 != 0 {
            let kinds = [0x11u16, 0x20, 0x21, 0x22, 0x28];
            let kind = kinds[(id as usize >> 4) % kinds.len()];
            let node = if kind == 0x11 { 8 } else { 1 };
            id = kind << 4 | node;
        } else {
            id &= 0x7FF;
        }
        let fd = flags & 1 == 1;
        let len = rest[3] as usize % if fd { 65 } else { 9 };
        let take = len.min(rest.len() - 4);
        let payload = &rest[4..4 + take];
        rest = &rest[4 + take..];
        now = now.wrapping_add((flags >> 1) as u32);
        let Ok(frame) = CanFrame::new_checked(id, payload, fd) else {
            continue;
        };
        if let Ok(Some(env)) = rx.push(&frame, now) {
            check_round_trip(&env);
        }
        assert!(rx.in_progress() <= SLOTS);
    }
});
