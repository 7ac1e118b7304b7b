//! `trn decode LOG`: every frame of a candump log as the message it carries (or the part of
//! a segmented message it is, or why it carries none), by the receivers' own decoder
//! (`trn_protocol::decode`), then `N frames, M messages, K undecoded`. As text (each line of
//! the log, then what it is), as JSON Lines (an object a frame: its time, id, data, what it
//! is, the message's fields) or as CSV (a row a frame, the message's fields as JSON in its
//! last column); with JSON and CSV the counts go to standard error, so standard output is
//! the table alone.

use std::io::{BufRead, BufReader, Write};
use std::path::Path;

use serde::Serialize;
use trn_protocol::candump;
use trn_protocol::decode::{LogDecoder, Outcome, Summary};

use crate::{CliError, Result};

/// How `trn decode` prints the frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Format {
    /// Each line of the log, then what it carries; the counts last.
    #[default]
    Text,
    /// JSON Lines: one object a frame.
    Json,
    /// CSV with a header: one row a frame.
    Csv,
}

/// One frame of the log as JSON and CSV give it.
#[derive(Debug, Default, Serialize)]
struct Row {
    /// The log's line (from 1).
    line: usize,
    /// The frame's time stamp (s), absent for a line that is no frame.
    time_s: Option<f64>,
    iface: Option<String>,
    /// The CAN id, `0x381`.
    id: Option<String>,
    fd: Option<bool>,
    /// The payload, hex.
    data: Option<String>,
    /// `message`, `segment` or `undecoded`.
    outcome: &'static str,
    node: Option<String>,
    /// The message kind (of the message, or of the segmented message a segment is part of).
    kind: Option<String>,
    /// A segment's place, `2/4`.
    segment: Option<String>,
    transfer: Option<u8>,
    /// Why a frame carries no message.
    error: Option<String>,
    /// The message's fields.
    message: Option<serde_json::Value>,
}

/// The CSV columns, in [`Row`]'s order.
const CSV_HEADER: &str =
    "line,time_s,iface,id,fd,data,outcome,node,kind,segment,transfer,error,message";

impl Row {
    fn csv(&self) -> String {
        use trn_bench::trial_csv::csv_field;
        let o = |v: &Option<String>| csv_field(v.as_deref().unwrap_or(""));
        [
            self.line.to_string(),
            self.time_s.map_or(String::new(), |t| format!("{t:.6}")),
            o(&self.iface),
            o(&self.id),
            self.fd.map_or(String::new(), |f| f.to_string()),
            o(&self.data),
            self.outcome.to_string(),
            o(&self.node),
            o(&self.kind),
            o(&self.segment),
            self.transfer.map_or(String::new(), |t| t.to_string()),
            o(&self.error),
            csv_field(
                &self
                    .message
                    .as_ref()
                    .map_or(String::new(), |m| m.to_string()),
            ),
        ]
        .join(",")
    }
}

/// Decodes `log` and prints every frame to `out` (only the counts when `summary_only`) as
/// text.
pub fn decode(log: &Path, summary_only: bool, out: &mut impl Write) -> Result<Summary> {
    decode_as(log, summary_only, Format::Text, out, &mut std::io::sink())
}

/// Decodes `log` and prints every frame to `out` in `format` (only the counts when
/// `summary_only`); the counts go to `out` as text, to `counts` as JSON and CSV.
pub fn decode_as(
    log: &Path,
    summary_only: bool,
    format: Format,
    out: &mut impl Write,
    counts: &mut impl Write,
) -> Result<Summary> {
    let io = |e: std::io::Error| CliError::Lab(trn_bench::io(log)(e));
    let file = trn_plant::input::open(log).map_err(io)?;
    let mut dec = LogDecoder::new();
    let mut bad_lines = 0usize;
    if format == Format::Csv && !summary_only {
        writeln!(out, "{CSV_HEADER}").map_err(io)?;
    }
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
                    let why = format!("not a frame of this protocol ({e})");
                    match format {
                        Format::Text => {
                            writeln!(out, "line {}: {why}: {line}", n + 1).map_err(io)?
                        }
                        _ => {
                            let row = Row {
                                line: n + 1,
                                outcome: "undecoded",
                                error: Some(why),
                                ..Row::default()
                            };
                            write_row(out, format, &row).map_err(io)?;
                        }
                    }
                }
                continue;
            }
        };
        let d = dec.push(&rec.frame, rec.timestamp_us);
        if summary_only {
            continue;
        }
        if format != Format::Text {
            write_row(out, format, &row_of(n + 1, &rec, &d.outcome)).map_err(io)?;
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
    let line = format!(
        "{} frames, {} messages, {} undecoded",
        s.frames, s.messages, s.undecoded
    );
    match format {
        Format::Text => writeln!(out, "{line}"),
        _ if summary_only => writeln!(out, "{line}"),
        _ => writeln!(counts, "{line}"),
    }
    .map_err(io)?;
    Ok(s)
}

fn write_row(out: &mut impl Write, format: Format, row: &Row) -> std::io::Result<()> {
    match format {
        Format::Csv => writeln!(out, "{}", row.csv()),
        _ => {
            serde_json::to_writer(&mut *out, row)?;
            writeln!(out)
        }
    }
}

/// A decoded frame as a [`Row`].
fn row_of(line: usize, rec: &candump::Record, outcome: &Outcome) -> Row {
    let f = &rec.frame;
    let mut row = Row {
        line,
        time_s: Some(rec.timestamp_us as f64 / 1e6),
        iface: Some(rec.iface.to_string()),
        id: Some(format!("0x{:03X}", f.raw_id())),
        fd: Some(f.is_fd()),
        data: Some(f.payload().iter().map(|b| format!("{b:02X}")).collect()),
        outcome: "undecoded",
        ..Row::default()
    };
    match outcome {
        Outcome::Message(env) => {
            row.outcome = "message";
            row.node = Some(format!("{:?}", env.node));
            row.kind = Some(format!("{:?}", env.msg.kind()));
            row.message = serde_json::to_value(env.msg).ok();
        }
        Outcome::Segment {
            kind,
            index,
            count,
            transfer,
        } => {
            row.outcome = "segment";
            row.kind = Some(format!("{kind:?}"));
            row.segment = Some(format!("{}/{count}", index + 1));
            row.transfer = Some(*transfer);
        }
        Outcome::Error(e) => row.error = Some(e.to_string()),
    }
    row
}

#[cfg(test)]
mod tests {
    use super::*;
    use trn_protocol::{BusMode, Encoder, Envelope, NodeId, Stage2Target};

    /// A log in a folder of its own (`name`): a Stage2Target in 4 segments, then a line
    /// that is no frame of this protocol (an extended id).
    fn log(name: &str) -> (std::path::PathBuf, std::path::PathBuf) {
        let dir = std::env::temp_dir().join(format!("trn-decode-{name}-{}", std::process::id()));
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
        (dir, log)
    }

    #[test]
    fn a_log_with_segments_decodes_whole_and_counts_its_lines() {
        let (dir, log) = log("text");
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

    /// Fails if a JSON line does not parse, a message's integers show as bytes, a frame's
    /// place is lost, the counts are not on their own writer, or a CSV row has another
    /// number of columns than the header.
    #[test]
    fn json_and_csv_give_a_record_a_frame_and_the_counts_apart() {
        let (dir, log) = log("formats");
        let (mut out, mut counts) = (Vec::new(), Vec::new());
        decode_as(&log, false, Format::Json, &mut out, &mut counts).unwrap();
        let out = String::from_utf8(out).unwrap();
        let rows: Vec<serde_json::Value> = out
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        assert_eq!(rows.len(), 5, "{out}");
        assert_eq!(rows[1]["segment"], "2/4");
        assert_eq!(rows[3]["outcome"], "message");
        assert_eq!(rows[3]["kind"], "Stage2Target");
        assert_eq!(
            rows[3]["message"]["Stage2Target"]["trial"], 9,
            "{}",
            rows[3]
        );
        assert_eq!(rows[3]["time_s"], 0.001003);
        assert_eq!(rows[4]["outcome"], "undecoded");
        assert!(rows[4]["time_s"].is_null());
        assert_eq!(
            String::from_utf8(counts).unwrap(),
            "5 frames, 1 messages, 1 undecoded\n"
        );
        let (mut out, mut counts) = (Vec::new(), Vec::new());
        decode_as(&log, false, Format::Csv, &mut out, &mut counts).unwrap();
        let out = String::from_utf8(out).unwrap();
        let lines: Vec<&str> = out.lines().collect();
        assert_eq!(lines[0], CSV_HEADER);
        assert_eq!(lines.len(), 6, "{out}");
        let columns = |l: &str| {
            // commas outside quotes, plus one
            let mut quoted = false;
            1 + l
                .chars()
                .filter(|&c| {
                    if c == '"' {
                        quoted = !quoted;
                    }
                    c == ',' && !quoted
                })
                .count()
        };
        for l in &lines {
            assert_eq!(columns(l), 13, "{l}");
        }
        assert!(lines[4].contains("\"\"trial\"\":9"), "{}", lines[4]);
        assert!(!counts.is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
