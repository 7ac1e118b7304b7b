//! Prints the default simulator configuration as TOML (the source of `host/sim.toml`).
fn main() {
    print!(
        "{}",
        toml::to_string(&trn_plant::SimConfig::default()).expect("serialisable")
    );
}
