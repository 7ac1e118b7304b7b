//! The protocol's decoder for Python: frames, or the lines of a candump log, through
//! `trn_protocol::decode::LogDecoder` (the receivers' own reassembly), as JSON that the
//! Python layer loads: one entry a frame, and the counts.

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use serde_json::{json, Value};
use trn_protocol::candump;
use trn_protocol::decode::{LogDecoder, Outcome};
use trn_protocol::CanFrame;

/// One frame's entry.
fn entry(dec: &mut LogDecoder, frame: &CanFrame, timestamp_us: u64, line: Option<usize>) -> Value {
    let d = dec.push(frame, timestamp_us);
    let data: String = frame.payload().iter().map(|b| format!("{b:02X}")).collect();
    let mut e = json!({
        "index": d.index,
        "timestamp_us": timestamp_us,
        "id": frame.raw_id(),
        "fd": frame.is_fd(),
        "data": data,
    });
    if let Some(l) = line {
        e["line"] = json!(l);
    }
    match d.outcome {
        Outcome::Message(env) => {
            let kind = format!("{:?}", env.msg.kind());
            let debug = format!("{:?}", env.msg);
            let fields = crate::fields::from_debug(&debug).unwrap_or(Value::String(debug));
            e["what"] = json!("message");
            e["message"] =
                json!({"kind": kind, "node": format!("{:?}", env.node), "fields": fields});
        }
        Outcome::Segment {
            kind,
            index,
            count,
            transfer,
        } => {
            e["what"] = json!("segment");
            e["segment"] = json!({"kind": format!("{kind:?}"), "index": index, "count": count, "transfer": transfer});
        }
        Outcome::Error(err) => {
            e["what"] = json!("undecoded");
            e["error"] = json!(err.to_string());
        }
    }
    e
}

fn result(entries: Vec<Value>, dec: LogDecoder, bad_lines: Vec<Value>) -> String {
    let s = dec.finish();
    json!({
        "frames": entries,
        "bad_lines": bad_lines,
        "summary": {"frames": s.frames, "messages": s.messages, "undecoded": s.undecoded},
    })
    .to_string()
}

/// Decodes frames given as `(id, data, fd, timestamp_us)`, in order; JSON.
#[pyfunction]
pub fn decode_frames(frames: Vec<(u16, Vec<u8>, bool, u64)>) -> PyResult<String> {
    let mut dec = LogDecoder::new();
    let mut entries = Vec::with_capacity(frames.len());
    for (id, data, fd, t) in frames {
        let frame = CanFrame::new_checked(id, &data, fd)
            .map_err(|e| PyValueError::new_err(format!("frame {id:#05x}: {e}")))?;
        entries.push(entry(&mut dec, &frame, t, None));
    }
    Ok(result(entries, dec, Vec::new()))
}

/// Decodes the text of a candump log (blank lines skipped); a line that is not a frame of
/// this protocol's kind (an extended id, a syntax error) is listed in `bad_lines`. JSON.
#[pyfunction]
pub fn decode_candump(text: &str) -> String {
    let mut dec = LogDecoder::new();
    let mut entries = Vec::new();
    let mut bad = Vec::new();
    for (n, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        match candump::parse_line(line) {
            Ok(r) => entries.push(entry(&mut dec, &r.frame, r.timestamp_us, Some(n + 1))),
            Err(e) => bad.push(json!({"line": n + 1, "text": line, "error": e.to_string()})),
        }
    }
    result(entries, dec, bad)
}

/// A decoder fed one frame at a time, as frames arrive on a bus (python-can's listeners):
/// it keeps the segments of a message between calls.
#[pyclass(module = "trn_softarm._native")]
pub struct StreamDecoder {
    dec: LogDecoder,
}

#[pymethods]
impl StreamDecoder {
    #[new]
    fn new() -> StreamDecoder {
        StreamDecoder {
            dec: LogDecoder::new(),
        }
    }

    /// The next frame received (`id`, `data`, `fd`, `timestamp_us`): its entry, JSON, as
    /// `decode_frames` gives each.
    fn push(&mut self, id: u16, data: Vec<u8>, fd: bool, timestamp_us: u64) -> PyResult<String> {
        let frame = CanFrame::new_checked(id, &data, fd)
            .map_err(|e| PyValueError::new_err(format!("frame {id:#05x}: {e}")))?;
        Ok(entry(&mut self.dec, &frame, timestamp_us, None).to_string())
    }

    /// The counts so far: `(frames, messages, undecoded)` (a message still missing segments
    /// counts its frames as undecoded).
    fn counts(&self) -> (usize, usize, usize) {
        let s = self.dec.clone().finish();
        (s.frames, s.messages, s.undecoded)
    }
}
