use super::*;
use crate::detect::{Detector, DetectorParams};
use crate::render::{Renderer, Sensor, Shape};

#[test]
fn protocols_give_distinct_codes_of_one_weight() {
    let s = CaptureProtocol::sequential(3).unwrap();
    assert_eq!((s.frames(), s.lights()), (3, 3));
    assert_eq!([s.code(0), s.code(1), s.code(2)], [1, 2, 4]);
    assert_eq!(s.lit(1), vec![1]);
    let g = CaptureProtocol::constant_weight(5, 4, 2).unwrap();
    assert_eq!(
        (0..5).map(|l| g.code(l)).collect::<Vec<_>>(),
        vec![3, 5, 6, 9, 10]
    );
    assert_eq!(g.lit(0), vec![0, 1, 3]);
    assert_eq!(g.lit(3), vec![3, 4]);
    assert_eq!(g.code(5), 0);
    assert!(g.lit(4).is_empty());
    // 4 frames of weight 2 tell 6 lights apart, not 7
    assert!(CaptureProtocol::constant_weight(6, 4, 2).is_ok());
    assert!(matches!(
        CaptureProtocol::constant_weight(7, 4, 2),
        Err(VisionError::Protocol(_))
    ));
    for (l, f, w) in [(0, 3, 1), (3, 0, 1), (3, 33, 1), (3, 3, 0), (3, 3, 4)] {
        assert!(
            CaptureProtocol::constant_weight(l, f, w).is_err(),
            "{l} {f} {w}"
        );
    }
    assert_eq!(
        CaptureProtocol::constant_weight(1, 32, 32).unwrap().code(0),
        u32::MAX
    );
}

struct Rig {
    renderer: Renderer<u8>,
    detector: Detector,
    identifier: Identifier,
}

impl Rig {
    fn new(protocol: CaptureProtocol) -> Rig {
        let s = Sensor::machine_vision(1024, 768);
        Rig {
            renderer: Renderer::new(&s).unwrap(),
            detector: Detector::new(s.width, s.height, DetectorParams::default()).unwrap(),
            identifier: Identifier::new(protocol, 3.0).unwrap(),
        }
    }

    /// Detections of each frame of `scenes`.
    fn detect(&self, scenes: &[Scene], seed: u64) -> Vec<Detection> {
        scenes
            .iter()
            .enumerate()
            .map(|(f, sc)| {
                let frame = self.renderer.render(sc, seed * 100 + f as u64).unwrap();
                self.detector.detect(&frame).unwrap()
            })
            .collect()
    }

    fn capture(&self, lights: &[Emitter], seed: u64) -> Vec<Identified> {
        let scenes = self.identifier.protocol().scenes(lights, &[]).unwrap();
        self.identifier
            .identify(&self.detect(&scenes, seed))
            .unwrap()
    }
}

fn five_lights(seed: u64) -> Vec<Emitter> {
    // five lights 40 to 80 px apart, as the gripper's at 2 m, placed per seed
    let (x0, y0) = (
        200.0 + 37.3 * seed as f64 % 600.0,
        150.0 + 23.9 * seed as f64 % 400.0,
    );
    [
        [0.0, 0.0],
        [40.0, 5.0],
        [80.0, 0.0],
        [20.0, 45.0],
        [60.0, 50.0],
    ]
    .iter()
    .map(|d| Emitter::new([x0 + d[0] + 0.37, y0 + d[1] + 0.71], 1.3, 30_000.0))
    .collect()
}

#[test]
fn every_light_is_identified_at_its_centre_and_never_swapped() {
    for protocol in [
        CaptureProtocol::sequential(5).unwrap(),
        CaptureProtocol::constant_weight(5, 4, 2).unwrap(),
    ] {
        let rig = Rig::new(protocol);
        for seed in 0..6 {
            let lights = five_lights(seed);
            let found = rig.capture(&lights, seed);
            for (l, (id, e)) in found.iter().zip(&lights).enumerate() {
                assert_eq!(id.status, LightStatus::Valid, "light {l}, seed {seed}");
                let c = id.centre.unwrap();
                assert!(
                    (c[0] - e.centre[0]).hypot(c[1] - e.centre[1]) < 0.1,
                    "light {l} at {c:?}, not {:?}",
                    e.centre
                );
            }
        }
    }
}

/// Five lights in 4 frames of weight 2: the rig, the lights and the capture's scenes.
fn grouped(seed: u64) -> (Rig, Vec<Emitter>, Vec<Scene>) {
    let protocol = CaptureProtocol::constant_weight(5, 4, 2).unwrap();
    let lights = five_lights(seed);
    let scenes = protocol.scenes(&lights, &[]).unwrap();
    (Rig::new(protocol), lights, scenes)
}

#[test]
fn a_light_hidden_in_one_frame_is_missing_not_another() {
    let (rig, lights, mut scenes) = grouped(1);
    // a link passes in front of light 1 in frame 2 only (light 1's code is 0101: frames 0, 2)
    let c = lights[1].centre;
    scenes[2].occluders.push(Occluder::in_front(Shape::Capsule {
        a: [c[0] - 30.0, c[1] - 30.0],
        b: [c[0] + 30.0, c[1] + 30.0],
        radius: 8.0,
    }));
    let found = rig.identifier.identify(&rig.detect(&scenes, 1)).unwrap();
    let status: Vec<LightStatus> = found.iter().map(|i| i.status).collect();
    use LightStatus::*;
    assert_eq!(status, vec![Valid, Missing, Valid, Valid, Valid]);
}

#[test]
fn a_reflection_beside_a_light_refuses_it_rather_than_swapping() {
    let (rig, lights, mut scenes) = grouped(2);
    // a reflection 1 px from light 0 in frame 2, where light 0 (code 0011) is dark: light 0's
    // track then reads 0111, weight 3, which is no light's code
    let mut glint = lights[0].clone();
    glint.centre[0] += 1.0;
    scenes[2].emitters.push(glint);
    let found = rig.identifier.identify(&rig.detect(&scenes, 2)).unwrap();
    assert_eq!(found[0].status, LightStatus::Missing);
    assert!(found[1..].iter().all(|i| i.status == LightStatus::Valid));
}

#[test]
fn two_lights_too_close_to_tell_apart_are_both_refused() {
    let protocol = CaptureProtocol::sequential(3).unwrap();
    let rig = Rig::new(protocol);
    let mut lights = five_lights(3);
    lights.truncate(3);
    // light 1 within the gate of light 0: their blobs join one track of code 011
    lights[1].centre = [lights[0].centre[0] + 2.0, lights[0].centre[1]];
    let found = rig.capture(&lights, 3);
    assert_eq!(found[0].status, LightStatus::Missing);
    assert_eq!(found[1].status, LightStatus::Missing);
    assert_eq!(found[2].status, LightStatus::Valid);
}

#[test]
fn a_blob_seen_twice_in_one_frame_makes_its_track_ambiguous() {
    let protocol = CaptureProtocol::sequential(2).unwrap();
    let rig = Rig::new(protocol);
    let mut lights = five_lights(4);
    lights.truncate(2);
    let scenes = rig.identifier.protocol().scenes(&lights, &[]).unwrap();
    let mut detections = rig.detect(&scenes, 4);
    // the detector reports light 0's blob twice in frame 0 (as a double exposure would)
    let twin = detections[0].blobs[0].clone();
    let mut moved = twin.clone();
    moved.centre[0] += 1.5;
    detections[0].blobs.push(moved);
    let found = rig.identifier.identify(&detections).unwrap();
    assert_eq!(found[0].status, LightStatus::Ambiguous);
    assert_eq!(found[1].status, LightStatus::Valid);
}

#[test]
fn bad_captures_are_refused() {
    let p = CaptureProtocol::sequential(3).unwrap();
    assert!(matches!(
        Identifier::new(p.clone(), f64::NAN),
        Err(VisionError::Parameter { .. })
    ));
    assert!(Identifier::new(p.clone(), 0.0).is_err());
    let id = Identifier::new(p.clone(), 3.0).unwrap();
    assert!(matches!(id.identify(&[]), Err(VisionError::Protocol(_))));
    assert!(matches!(
        p.scenes(&five_lights(0), &[]),
        Err(VisionError::Protocol(_))
    ));
}
