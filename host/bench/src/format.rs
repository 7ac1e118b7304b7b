//! How the lab writes a figure in its tables and lines (the studies' tables, the summary the
//! command line prints): text, never printed here.

use crate::report::Report;

/// A figure with two decimals, `n/a` for no number.
pub fn px(x: f32) -> String {
    if x.is_finite() {
        format!("{x:.2}")
    } else {
        "n/a".into()
    }
}

/// What the summary says of the controller's protocol version: nothing for the current one;
/// for version 3, that it speaks it and that its tables were not read.
pub fn protocol_line(r: &Report) -> Option<String> {
    match r.controller_protocol {
        Some(v) if v < trn_protocol::ProtocolVersion::CURRENT.number() => Some(format!(
            "the controller speaks protocol v{v}: its tables were not read, checked or saved (tables over the bus came with v4)"
        )),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_number_prints_as_such() {
        assert_eq!(px(f32::NAN), "n/a");
        assert_eq!(px(1.234), "1.23");
    }
}
