//! `sim-pictures` writes both PNGs.

#[test]
fn sim_pictures_writes_both_pngs() {
    let scratch = tempfile::Builder::new()
        .prefix("trn-pictures-")
        .tempdir()
        .expect("a temporary folder");
    let dir = scratch.path().join("pictures");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_sim-pictures"))
        .args(["--out", dir.to_str().unwrap(), "--seed", "2"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for f in ["hysteresis.png", "arm.png"] {
        let bytes = std::fs::read(dir.join(f)).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        assert!(bytes.len() > 10_000, "{f} is {} bytes", bytes.len());
    }
}
