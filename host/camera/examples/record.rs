//! Records a sequence of captures from the simulated arm as a camera node reads them: each
//! capture's frames rendered whole, as PNG files, with a manifest that holds the cameras'
//! calibration and where each light truly projects.
//!
//! `cargo run --release -p trn-camera --example record -- OUT_DIR [--captures N] [--seed S]
//! [--width W]`: the realistic plant at `N` (default 6) arbitrarily chosen arm positions, the
//! gripper's lights p and q in most captures, its centre light in every third; each camera's
//! frame the middle `W` pixels across (default 512) of the plant's image, through the
//! plant's lens: a smaller recording, in which a light can fall outside the frame.
//! The test suite's recording (host/camera/tests/recording) is this command's output with
//! `--seed 2` (six captures; of their 20 lights in a camera, 3 outside the frame, 1 hidden
//! and 1 hidden in part by a link, the rest in clear view).

use std::path::PathBuf;

use rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use trn_camera::source::{
    lights_of, CalibrationConfig, Manifest, RecordedCapture, TruthPoint, FORMAT, MANIFEST,
};
use trn_plant::pixels::PixelVision;
use trn_plant::{kinematics, Plant, SimConfig};
use trn_protocol::{CaptureKind, PointStatus};
use trn_vision::{CaptureProtocol, Emitter};

fn main() -> Result<(), String> {
    let mut args = std::env::args().skip(1);
    let mut out: Option<PathBuf> = None;
    let (mut captures, mut seed, mut width) = (6usize, 1u64, 512u32);
    while let Some(a) = args.next() {
        let mut value = |name: &str| {
            args.next()
                .ok_or(format!("{name} needs a value"))?
                .parse::<u64>()
                .map_err(|e| format!("{name}: {e}"))
        };
        match a.as_str() {
            "--captures" => captures = value("--captures")? as usize,
            "--seed" => seed = value("--seed")?,
            "--width" => width = value("--width")? as u32,
            _ if out.is_none() && !a.starts_with("--") => out = Some(a.into()),
            _ => return Err(format!("unknown argument {a}")),
        }
    }
    let out = out.ok_or("usage: record OUT_DIR [--captures N] [--seed S] [--width W]")?;
    if !(1..=1000).contains(&captures) || !(64..=4096).contains(&width) {
        return Err("--captures 1 to 1000, --width 64 to 4096".into());
    }
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;

    let mut cfg = SimConfig::realistic();
    for c in &mut cfg.cameras {
        // the middle of the plant's image (a sensor's region of interest): the same lens,
        // fewer pixels, the lights as far apart on the image as the plant's cameras see them
        let height = (c.resolution[1] as u64 * width as u64 / c.resolution[0] as u64) as u32;
        c.resolution = [width, height];
    }
    let mut plant = Plant::new(&cfg, seed).map_err(|e| e.to_string())?;
    let vision = PixelVision::from_config(&cfg.pixels);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut manifest = Manifest {
        format: FORMAT.into(),
        gate_px: vision.gate_px,
        calibration: Some(CalibrationConfig {
            pixel_noise_px: cfg.pixel_noise_px,
            cameras: cfg.cameras.clone(),
        }),
        captures: Vec::new(),
    };
    for i in 0..captures {
        plant.move_to_random_joints(&mut rng, 5);
        let pose = plant.gripper_pose();
        let (what, lights) = if i % 3 == 2 {
            (CaptureKind::GripperCentre, vec![pose.centre_mm])
        } else {
            (
                CaptureKind::GripperLights,
                kinematics::lights(&cfg, &pose).to_vec(),
            )
        };
        // each light in camera 0, then camera 1: the Observation's order
        let truth: Vec<TruthPoint> = (0..lights.len())
            .flat_map(|l| (0..2).map(move |cam| (l, cam)))
            .map(|(l, cam)| {
                let (emitters, occluders) = plant.pixel_scene(cam, &lights, &vision);
                truth_of(emitters[l].as_ref(), &occluders)
            })
            .collect();
        let protocol = CaptureProtocol::sequential(lights_of(what)).map_err(|e| e.to_string())?;
        let mut names: [Vec<String>; 2] = [vec![], vec![]];
        for (cam, names) in names.iter_mut().enumerate() {
            let frame_seed = seed
                .wrapping_mul(1_000_003)
                .wrapping_add((i * 64 + cam * 8) as u64);
            let frames = plant
                .capture_frames(cam, &lights, &protocol, &vision, frame_seed)
                .map_err(|e| e.to_string())?;
            for (f, frame) in frames.iter().enumerate() {
                let name = format!("{i:04}-cam{cam}-f{f}.png");
                save_png(frame, &out.join(&name)).map_err(|e| format!("{name}: {e}"))?;
                names.push(name);
            }
        }
        let [cam0, cam1] = names;
        manifest.captures.push(RecordedCapture {
            what,
            frames: protocol.frames(),
            weight: 1,
            cam0,
            cam1,
            truth: truth.clone(),
        });
        let valid = truth
            .iter()
            .filter(|r| r.status == PointStatus::Valid)
            .count();
        eprintln!(
            "capture {i}: {what:?}, {valid} of {} points in view and not hidden",
            truth.len()
        );
    }
    let text = toml::to_string(&manifest).map_err(|e| e.to_string())?;
    std::fs::write(out.join(MANIFEST), text).map_err(|e| e.to_string())?;
    eprintln!("{} captures in {}", captures, out.display());
    Ok(())
}

/// Where a light projects and whether the frames show it: `OutOfView` outside the frame,
/// `Occluded` when something nearer the camera covers its centre or a point two deviations
/// of its spot from it (hidden in part or whole), `Valid` otherwise.
fn truth_of(e: Option<&Emitter>, occluders: &[trn_vision::Occluder]) -> TruthPoint {
    let Some(e) = e else {
        return TruthPoint {
            x: 0.0,
            y: 0.0,
            status: PointStatus::OutOfView,
        };
    };
    let r = 2.0 * e.sigma_px;
    let [x, y] = e.centre;
    let around = (0..8).map(|k| {
        let a = k as f64 * std::f64::consts::FRAC_PI_4;
        [x + r * a.cos(), y + r * a.sin()]
    });
    let covered = std::iter::once([x, y]).chain(around).any(|p| {
        occluders
            .iter()
            .any(|o| o.depth < e.depth && o.shape.contains(p))
    });
    TruthPoint {
        x,
        y,
        status: if covered {
            PointStatus::Occluded
        } else {
            PointStatus::Valid
        },
    }
}

/// `frame` as a PNG file, compressed hard: no filter (the background is noise, which a
/// filter's prediction only widens) and deflate's best.
fn save_png(frame: &trn_vision::Frame<u8>, path: &std::path::Path) -> Result<(), String> {
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    use image::ImageEncoder;
    let file = std::fs::File::create(path).map_err(|e| e.to_string())?;
    PngEncoder::new_with_quality(
        std::io::BufWriter::new(file),
        CompressionType::Best,
        FilterType::NoFilter,
    )
    .write_image(
        frame.as_raw(),
        frame.width(),
        frame.height(),
        image::ColorType::L8,
    )
    .map_err(|e| e.to_string())
}
