use super::*;

/// A folder of the test's own, named after it, removed when the test ends, passed or failed.
fn scratch(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix(&format!("trn-camera-{name}-"))
        .tempdir()
        .expect("a temporary folder")
}

fn recorded() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/recording")
}

/// A folder with a 32 x 24 8-bit frame `a.png` and the manifest `text`.
fn folder(name: &str, text: &str) -> tempfile::TempDir {
    let d = scratch(name);
    image::GrayImage::new(32, 24)
        .save(d.path().join("a.png"))
        .unwrap();
    std::fs::write(d.path().join(MANIFEST), text).unwrap();
    d
}

const ONE: &str = r#"format = "trn-camera-recording/1"
gate_px = 3.0
[[captures]]
what = "GripperCentre"
frames = 1
weight = 1
cam0 = ["a.png"]
cam1 = ["a.png"]
"#;

/// Fails if the recording is not served in order, a request of another kind than the next
/// capture's is not refused naming both, the end is not an error, or looping does not start
/// again.
#[test]
fn a_recording_is_served_in_order_each_capture_for_its_kind() {
    let mut r = Recording::open(&recorded()).unwrap();
    let kinds: Vec<CaptureKind> = r.manifest().captures.iter().map(|c| c.what).collect();
    assert_eq!(kinds[0], CaptureKind::GripperLights);
    let e = r
        .capture(CaptureKind::GripperCentre)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("GripperCentre") && e.contains("capture 0 is GripperLights"),
        "{e}"
    );
    for &k in &kinds[1..] {
        let c = r.capture(k).unwrap();
        assert_eq!(c.what, k);
        assert_eq!(c.cameras[0].len(), c.protocol.frames());
        assert_eq!(c.cameras[1].len(), c.protocol.frames());
    }
    let e = r.capture(kinds[0]).unwrap_err().to_string();
    assert!(e.contains("were all served"), "{e}");
    let mut r = r.looping();
    assert_eq!(r.capture(kinds[0]).unwrap().what, kinds[0]);
    assert_eq!(r.served(), 1);
}

/// Fails if a manifest that is not one is taken, or refused without saying what is wrong.
#[test]
fn manifests_that_are_not_one_are_refused_saying_why() {
    assert!(Recording::open(folder("good", ONE).path()).is_ok());
    let cases: &[(&str, &str, &str)] = &[
        ("format", "trn-camera-recording/1\"", "format"),
        ("gate", "gate_px = 3.0", "gate_px"),
        ("count", "frames = 1", "cam0 lists 1 frames"),
        ("name", "cam1 = [\"a.png\"]", "is not a file name"),
        ("missing", "cam1 = [\"a.png\"]", "b.png"),
        ("weight", "weight = 1", "capture 0"),
        ("key", "weight = 1", "unknown field"),
        ("truth", "weight = 1", "truth points"),
        ("kind", "\"GripperCentre\"", "unknown variant"),
    ];
    let replaced = [
        "trn-camera-recording/2\"",
        "gate_px = 0.0",
        "frames = 2",
        "cam1 = [\"../a.png\"]",
        "cam1 = [\"b.png\"]",
        "weight = 2",
        "weight = 1\nexposure = 3",
        "weight = 1\ntruth = [{ x = 1.0, y = 2.0, status = \"Valid\" }]",
        "\"GripperLeft\"",
    ];
    for ((name, from, says), to) in cases.iter().zip(replaced) {
        let d = folder(name, &ONE.replace(from, to));
        let e = Recording::open(d.path()).unwrap_err().to_string();
        assert!(e.contains(says) && e.contains(MANIFEST), "{name}: {e}");
    }
    let d = folder("calibration", ONE);
    let camera = "[[calibration.cameras]]\nresolution = [32, 24]\nfocal_px = 50.0\nposition_mm = [0.0, 0.0, 0.0]\nlook_at_mm = [1.0, 0.0, 0.0]\ndistortion = [0.0, 0.0]\n";
    let text = ONE.replace(
        "[[captures]]",
        &format!("[calibration]\npixel_noise_px = 0.3\n{camera}[[captures]]"),
    );
    std::fs::write(d.path().join(MANIFEST), text).unwrap();
    let e = Recording::open(d.path()).unwrap_err().to_string();
    assert!(e.contains("1 cameras, not 2"), "{e}");
}

/// Fails if a frame that is not an 8- or 16-bit grayscale PNG, or one of another size than
/// its camera's calibration, is read as a frame, or if a 16-bit frame is not.
#[test]
fn frames_that_are_not_grayscale_or_not_their_cameras_size_are_refused() {
    let d = folder("frames", ONE);
    let f = d.path().join("a.png");
    image::RgbImage::new(32, 24).save(&f).unwrap();
    let e = read_frame(&f).unwrap_err().to_string();
    assert!(e.contains("not 8- or 16-bit grayscale"), "{e}");
    std::fs::write(&f, b"P5 32 24 255\n").unwrap();
    let e = read_frame(&f).unwrap_err().to_string();
    assert!(e.contains("not a PNG image"), "{e}");
    image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::new(32, 24)
        .save(&f)
        .unwrap();
    assert!(matches!(read_frame(&f).unwrap(), AnyFrame::U16(_)));
    // the recording's calibration says 512 x 384: a frame of 32 x 24 in its place is refused
    let r = Recording::open(&recorded()).unwrap();
    let d = scratch("size");
    for e in std::fs::read_dir(recorded()).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), d.path().join(e.file_name())).unwrap();
    }
    let name = &r.manifest().captures[0].cam1[1];
    image::GrayImage::new(32, 24)
        .save(d.path().join(name))
        .unwrap();
    let e = Recording::open(d.path())
        .unwrap()
        .frames(0)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains(name.as_str()) && e.contains("camera 1 is calibrated for 512 x 384"),
        "{e}"
    );
}
