//! Writes a candump log of real encoded traffic and the expected DBC signal values:
//!
//! ```text
//! cargo run -p trn-protocol --features std --example gen_candump -- OUT.log OUT.expected.jsonl
//! ```
//! `tools/check_dbc.sh` decodes the log with cantools and compares.

#[path = "../tests/common/dbc_traffic.rs"]
mod dbc_traffic;

fn main() -> std::io::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 3 {
        eprintln!("usage: gen_candump OUT.log OUT.expected.jsonl");
        std::process::exit(2);
    }
    let (log, expected) = dbc_traffic::render();
    std::fs::write(&args[1], log)?;
    std::fs::write(&args[2], expected)?;
    Ok(())
}
