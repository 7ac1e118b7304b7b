//! `camera-node`: the camera processor as a CAN node of its own process, reading frames
//! instead of the simulator's geometry.

use clap::Parser;
use std::path::PathBuf;
use std::process::ExitCode;

/// `camera-node`: the camera processor on a SocketCAN interface or a serial SLCAN adapter.
/// Each `CaptureRequest` takes the next capture of the recording (in each camera, the frames
/// of protocol/SPEC.md's capture sequence), finds and identifies the lights in them, checks
/// the two cameras against each other when the recording has their calibration, and answers
/// an `Observation`. It runs until SIGINT or SIGTERM and then prints its counters.
#[derive(Debug, Parser)]
#[command(name = "camera-node", version)]
struct Args {
    /// The recording's folder: its frames and their manifest, recording.toml.
    #[arg(long, value_name = "DIR")]
    recording: PathBuf,
    /// Serve the recording again from its first capture after its last (otherwise a
    /// request after the last is answered with its lights not detected).
    #[arg(long = "loop")]
    looping: bool,
    #[command(flatten)]
    bus: trn_transport::node_bus::NodeBusArgs,
}

fn run(a: &Args) -> Result<(), String> {
    use std::sync::atomic::AtomicBool;
    use std::sync::Arc;
    use trn_camera::node::Served;
    use trn_camera::{run, CameraNode, Processor, Recording};
    let mut recording = Recording::open(&a.recording).map_err(|e| e.to_string())?;
    if a.looping {
        recording = recording.looping();
    }
    let m = recording.manifest();
    let processor = Processor::for_recording(m).map_err(|e| e.to_string())?;
    eprintln!(
        "camera-node: {} captures from {}{}",
        m.captures.len(),
        a.recording.display(),
        if processor.calibration().is_some() {
            ", the cameras checked against each other"
        } else {
            ", no calibration: the cameras are not checked against each other"
        }
    );
    let clock = trn_transport::WallClock::start();
    let mut node = CameraNode::new(recording, processor, 0);
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, stop.clone()).map_err(|e| e.to_string())?;
    }
    let mut log = |s: &Served| {
        if let Served::Failed(why) = s {
            eprintln!("camera-node: a capture answered with its lights not detected: {why}");
        }
    };
    let port = a.bus.open()?;
    let ran = run::run(port, &mut node, &clock, &stop, &mut log);
    let s = node.stats();
    eprintln!(
        "camera-node: {} captures ({} failed, {} repeated, {} stale), {} valid points, {} lights refused by the stereo check",
        s.captures + s.failed,
        s.failed,
        s.repeats,
        s.stale,
        s.valid_points,
        s.inconsistent
    );
    let l = ran.map_err(|e| e.to_string())?;
    eprintln!(
        "camera-node: {} frames in, {} out, {} frame errors",
        l.frames_in, l.frames_out, l.frame_errors
    );
    Ok(())
}

fn main() -> ExitCode {
    let a = Args::parse();
    match run(&a) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("camera-node: error: {e}");
            ExitCode::FAILURE
        }
    }
}
