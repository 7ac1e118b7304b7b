//! Writes seed inputs for the fuzz target (`fuzz/run.sh` calls it when the corpus is
//! empty): the frames of the interop traffic, one message per file, in the target's input
//! format `[flags, id_lo, id_hi, len, data...]` (flags bit 0 = FD).
//!
//! ```text
//! cargo run -p trn-protocol --features std --example fuzz_seeds -- DIR
//! ```

#[path = "../tests/common/dbc_traffic.rs"]
mod dbc_traffic;

use trn_protocol::{BusMode, Encoder};

fn main() -> std::io::Result<()> {
    let dir = std::env::args().nth(1).expect("usage: fuzz_seeds DIR");
    std::fs::create_dir_all(&dir)?;
    let mut n = 0;
    for mode in [BusMode::Classic, BusMode::Fd] {
        let mut enc = Encoder::new(mode);
        for (i, env) in dbc_traffic::traffic().iter().enumerate() {
            // All long messages, a sample of the single frames.
            if env.msg.kind().is_single_frame() && i % 7 != 0 {
                continue;
            }
            let mut bytes = Vec::new();
            for f in &enc.encode(env).expect("traffic encodes") {
                bytes.push(f.is_fd() as u8);
                bytes.extend_from_slice(&f.raw_id().to_le_bytes());
                bytes.push(f.len() as u8);
                bytes.extend_from_slice(f.payload());
            }
            std::fs::write(format!("{dir}/seed-{n:04}"), bytes)?;
            n += 1;
        }
    }
    println!("{n} seeds written to {dir}");
    Ok(())
}
