//! One camera frame of the plant at its resolution (1024 x 768), five lights: rendering,
//! detection, and both. `cargo bench -p trn-vision --bench frame`

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use trn_vision::accuracy::Blob;
use trn_vision::{Detector, DetectorParams, Emitter, Renderer, Scene, Sensor};

fn frame(c: &mut Criterion) {
    let sensor = Sensor::machine_vision(1024, 768);
    let blob = Blob::nominal();
    let scene = Scene {
        emitters: [
            [300.3, 200.7],
            [340.6, 205.2],
            [380.1, 199.9],
            [320.4, 245.5],
            [360.8, 250.3],
        ]
        .iter()
        .map(|&c| Emitter::new(c, blob.sigma_px, blob.electrons))
        .collect(),
        occluders: vec![],
    };
    let renderer = Renderer::<u8>::new(&sensor).unwrap();
    let detector = Detector::new(sensor.width, sensor.height, DetectorParams::default()).unwrap();
    let frame = renderer.render(&scene, 1).unwrap();
    assert_eq!(detector.detect(&frame).unwrap().blobs.len(), 5);
    let mut g = c.benchmark_group("vision 1024x768, 5 lights");
    g.throughput(Throughput::Elements(1));
    g.bench_function("detect", |b| b.iter(|| detector.detect(&frame).unwrap()));
    let mut seed = 0;
    g.bench_function("render", |b| {
        b.iter(|| {
            seed += 1;
            renderer.render(&scene, seed).unwrap()
        })
    });
    g.bench_function("render + detect", |b| {
        b.iter(|| {
            seed += 1;
            detector
                .detect(&renderer.render(&scene, seed).unwrap())
                .unwrap()
        })
    });
    g.finish();
}

criterion_group!(benches, frame);
criterion_main!(benches);
