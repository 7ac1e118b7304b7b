//! Configuration files a user gets wrong: each refused with the key or the file named, and a
//! message of readable length.

use std::path::Path;
use trn_plant::SimConfig;

fn default_toml() -> String {
    toml::to_string(&SimConfig::default()).unwrap()
}

/// A list longer (or shorter) than the value's size is refused: a parser that reads the
/// first values of a longer list would take `[1024, 768, 3]` for a resolution.
#[test]
fn lists_of_the_wrong_length_are_refused() {
    for (from, to) in [
        ("resolution = [1024, 768]", "resolution = [1024, 768, 3]"),
        ("resolution = [1024, 768]", "resolution = [1024]"),
        ("distortion = [", "distortion = [0.0, "),
    ] {
        let text = default_toml().replacen(from, to, 1);
        assert_ne!(text, default_toml(), "{from} not found");
        let e = SimConfig::from_toml_str(&text).unwrap_err().to_string();
        assert!(e.contains("expected a list of"), "{to}: {e}");
    }
}

/// A huge one-line garbage file is refused before it is parsed, and a parse error quotes
/// only a few hundred characters of the input.
#[test]
fn huge_and_garbage_files_give_short_errors() {
    let scratch = tempfile::Builder::new()
        .prefix("trn-config-")
        .tempdir()
        .expect("a temporary folder");
    let dir = scratch.path();
    let huge = dir.join("huge.toml");
    std::fs::write(&huge, vec![b'x'; 3 << 20]).unwrap();
    let e = SimConfig::load(&huge).unwrap_err().to_string();
    assert!(e.contains("huge.toml") && e.contains("larger than"), "{e}");
    assert!(e.len() < 300, "{} characters", e.len());
    let garbage = dir.join("garbage.toml");
    std::fs::write(&garbage, vec![b'q'; 500_000]).unwrap();
    let e = SimConfig::load(&garbage).unwrap_err().to_string();
    assert!(e.contains("garbage.toml"), "{e}");
    assert!(e.len() < 1000, "{} characters", e.len());
    // a name that is neither a file nor built in lists the built-in names
    let e = SimConfig::resolve(Some(&dir.join("none.toml")))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("none.toml") && e.contains("ideal, realistic, aging, realistic-aging"),
        "{e}"
    );
    assert!(SimConfig::resolve(Some(Path::new("realistic"))).is_ok());
}
