//! `trn decode LOG`: every frame of a candump log as the message it carries (or the part of
//! a segmented message it is, or why it carries none), by the receivers' own decoder
//! (`trn_protocol::decode`), then `N frames, M messages, K undecoded`.

use std::io::{BufRead, BufReader, Write};
use std::path::Path;

use trn_protocol::candump;
use trn_protocol::decode::{LogDecoder, Outcome, Summary};

use crate::{CliError, Result};

/// Decodes `log` and prints every frame to `out` (only the counts when `summary_only`).
pub fn decode(log: &Path, summary_only: bool, out: &mut impl Write) -> Result<Summary> {
    let io = |e: std::io::Error| CliError::Lab(trn_bench::io(log)(e));
    let file = trn_plant::input::open(log).map_err(io)?;
    let mut dec = LogDecoder::new();
    let mut bad_lines = 0usize;
    for (n, line) in BufReader::new(file).lines().enumerate() {
        let line = line.map_err(io)?;
        if line.trim().is_empty() {
            continue;
        }
        let rec = match candump::parse_line(&line) {
            Ok(r) => r,
            Err(e) => {
                bad_lines += 1;
                if !summary_only {
                    writeln!(
                        out,
                        "line {}: not a frame of this protocol ({e}): {line}",
                        n + 1
                    )
                    .map_err(io)?;
                }
                continue;
            }
        };
        let d = dec.push(&rec.frame, rec.timestamp_us);
        if summary_only {
            continue;
        }
        let what = match d.outcome {
            Outcome::Message(env) => format!("{:?} {:?}", env.node, env.msg),
            Outcome::Segment {
                kind,
                index,
                count,
                transfer,
            } => format!(
                "segment {}/{count} of {kind:?} (transfer {transfer})",
                index + 1
            ),
            Outcome::Error(e) => format!("undecoded: {e}"),
        };
        writeln!(out, "{}  {what}", line.trim()).map_err(io)?;
    }
    let mut s = dec.finish();
    // a line that is no frame of this protocol (an extended id, a remote frame) is a frame
    // not decoded as well
    s.frames += bad_lines;
    s.undecoded += bad_lines;
    writeln!(
        out,
        "{} frames, {} messages, {} undecoded",
        s.frames, s.messages, s.undecoded
    )
    .map_err(io)?;
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use trn_protocol::{BusMode, Encoder, Envelope, NodeId, Stage2Target};

    #[test]
    fn a_log_with_segments_decodes_whole_and_counts_its_lines() {
        let dir = std::env::temp_dir().join(format!("trn-decode-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let log = dir.join("bus.log");
        let env = Envelope::new(
            NodeId::Controller,
            Stage2Target {
                trial: 9,
                learn: false,
                grasp: false,
                fine_moves: 2,
                c: [1.0, 2.0, 3.0, 4.0],
            }
            .into(),
        );
        let mut text = String::new();
        for (i, f) in Encoder::new(BusMode::Classic)
            .encode(&env)
            .unwrap()
            .iter()
            .enumerate()
        {
            text.push_str(&candump::format_line(1_000 + i as u64, "vcan0", f).unwrap());
            text.push('\n');
        }
        text.push_str("(0.000001) vcan0 12345678#00\n");
        std::fs::write(&log, text).unwrap();
        let mut out = Vec::new();
        let s = decode(&log, false, &mut out).unwrap();
        let out = String::from_utf8(out).unwrap();
        assert_eq!((s.frames, s.messages, s.undecoded), (5, 1, 1), "{out}");
        assert!(out.contains("segment 1/4 of Stage2Target"), "{out}");
        assert!(out.contains("trial: 9"), "{out}");
        assert!(
            out.ends_with("5 frames, 1 messages, 1 undecoded\n"),
            "{out}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
