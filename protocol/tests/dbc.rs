//! The DBC matches the crate, and the interop log decodes back to the traffic.

#[path = "common/dbc_traffic.rs"]
mod dbc_traffic;

use std::collections::BTreeMap;

use trn_protocol::*;

/// (name, start bit, length in bits)
type Signal = (String, usize, usize);
/// id -> (DLC, signals)
type Dbc = BTreeMap<u16, (usize, Vec<Signal>)>;

/// `BO_ <id> <name>: <dlc> <tx>` and its `SG_ <name> : <start>|<len>@1+` lines.
fn parse_dbc() -> Dbc {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/trn.dbc")).unwrap();
    let mut out = BTreeMap::new();
    let mut current = None;
    for line in text.lines() {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.first() {
            Some(&"BO_") => {
                let id: u16 = words[1].parse().unwrap();
                let dlc: usize = words[3].parse().unwrap();
                out.insert(id, (dlc, Vec::new()));
                current = Some(id);
            }
            Some(&"SG_") => {
                let (pos, rest) = words[3].split_once('|').unwrap();
                let len = rest.split_once('@').unwrap().0;
                assert!(rest.ends_with("@1+"), "little endian unsigned: {line}");
                out.get_mut(&current.unwrap()).unwrap().1.push((
                    words[1].to_owned(),
                    pos.parse().unwrap(),
                    len.parse().unwrap(),
                ));
            }
            _ => {}
        }
    }
    out
}

#[test]
fn dbc_describes_exactly_the_single_frame_ids() {
    let dbc = parse_dbc();
    let mut expected = Vec::new();
    for raw in 0..=MAX_STANDARD_ID {
        if let Ok(id) = CanId::from_raw(raw) {
            if id.kind.is_single_frame() {
                expected.push(raw);
                let (dlc, sigs) = &dbc[&raw];
                assert_eq!(*dlc, id.kind.wire_len(), "{:?}", id.kind);
                // Signals tile the payload exactly, in order.
                let mut at = 0;
                for (_, start, len) in sigs {
                    assert_eq!(*start, at, "{:?}", id.kind);
                    at += len;
                }
                assert_eq!(at, dlc * 8, "{:?}", id.kind);
            }
        }
    }
    assert_eq!(dbc.keys().copied().collect::<Vec<_>>(), expected);
}

#[test]
fn dbc_signals_decode_the_encoded_bytes() {
    // Decode each single frame of the interop traffic with the DBC layout, in Rust.
    let dbc = parse_dbc();
    let mut enc = Encoder::new(BusMode::Classic);
    let mut checked = 0;
    for env in dbc_traffic::traffic() {
        if !env.msg.kind().is_single_frame() {
            continue;
        }
        let frames = enc.encode(&env).unwrap();
        let data = frames[0].payload();
        let (_, sigs) = &dbc[&frames[0].raw_id()];
        let want = dbc_traffic::signals(&env.msg);
        assert_eq!(sigs.len(), want.len());
        for ((name, start, len), (wname, wval)) in sigs.iter().zip(&want) {
            assert_eq!(name, wname);
            let mut v = 0u64;
            for i in (0..len / 8).rev() {
                v = v << 8 | data[start / 8 + i] as u64;
            }
            assert_eq!(v, *wval, "{name} of {env:?}");
            checked += 1;
        }
    }
    assert!(checked > 200);
}

#[test]
fn interop_log_round_trips() {
    let (log, expected) = dbc_traffic::render();
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    std::fs::write(dir.join("trn-interop.log"), &log).unwrap();
    std::fs::write(dir.join("trn-interop.expected.jsonl"), &expected).unwrap();
    let records = candump::read_log(log.as_bytes()).unwrap();
    let mut rx: Reassembler = Reassembler::new(DEFAULT_STALE_MS);
    let got: Vec<Envelope> = records
        .iter()
        .filter_map(|r| rx.push(&r.frame, 0).unwrap())
        .collect();
    assert_eq!(got, dbc_traffic::traffic());
}

/// The DBC declares every segmented id (network attribute `TrnSegmented`) with its kind,
/// payload length and CAN 2.0 segment count, so a tool reading the DBC knows which frames
/// it cannot decode alone, and which decoder to use.
#[test]
fn dbc_declares_exactly_the_segmented_ids() {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/trn.dbc")).unwrap();
    let line = text
        .lines()
        .find(|l| l.starts_with("BA_ \"TrnSegmented\""))
        .expect("BA_ \"TrnSegmented\" in trn.dbc");
    let list = line.split('"').nth(3).unwrap();
    let mut declared = Vec::new();
    for entry in list.split(';') {
        let w: Vec<&str> = entry.split_whitespace().collect();
        let raw = u16::from_str_radix(w[0].trim_start_matches("0x"), 16).unwrap();
        let id = CanId::from_raw(raw).unwrap();
        assert_eq!(w[1], format!("{:?}", id.kind));
        assert_eq!(w[2].parse::<usize>().unwrap(), id.kind.wire_len());
        assert_eq!(w[3].parse::<usize>().unwrap(), segment_count(id.kind));
        declared.push(raw);
    }
    let long: Vec<u16> = (0..=MAX_STANDARD_ID)
        .filter(|&raw| CanId::from_raw(raw).is_ok_and(|id| !id.kind.is_single_frame()))
        .collect();
    assert_eq!(declared, long);
}
