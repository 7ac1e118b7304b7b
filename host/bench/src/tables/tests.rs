//! The tables over the bus on the simulated clock: a runner against the project's node on
//! the in-process bus, with its store in memory. Each test checks one rule: a read-out is
//! the controller's checkpoint byte for byte, a write applies exactly the image, a lost
//! frame costs a repeat, a writer resumes where the node stands, learned tables are
//! replaced only through the guard and only when allowed.

use std::rc::Rc;
use std::time::Duration;

use trn_controller::checkpoint::{self, Provenance};
use trn_controller::persist::TableStore;
use trn_controller::{Command as Cmd, Config, Controller, Observation, Task};
use trn_node::NodeConfig;
use trn_plant::{Plant, SimConfig};
use trn_protocol::bus::FaultConfig;
use trn_protocol::{BusMode, Message, NodeId, TableWriteBegin, TableWriteChunk};
use trn_transport::inproc::SimulatedBus;

use super::opening::{open, Opening, Want};
use super::{read, status, write};
use crate::observe::Observer;
use crate::rig::Rig;
use crate::runner::{Runner, Timing};
use trn_transport::board::{self, Board};

type Bus = SimulatedBus<Board>;

/// The project preset for the default cameras, the configuration the tables learn under.
fn cfg() -> Config {
    use trn_controller::presets::{configure, Ablation, ImageSize, Preset};
    configure(Preset::Project, Ablation::None, ImageSize::DEFAULT)
}

const PROVENANCE: Provenance = Provenance {
    preset: 0,
    ablation: 0,
};

/// Tables seeded with `seed` that learned from `trials` stage-1 trials (0: never learned).
fn tables(seed: u64, trials: u32) -> Box<Controller> {
    let mut c = Box::new(Controller::new(cfg()));
    c.init_random(seed);
    for t in 0..trials {
        let v = [300.0, 200.0, 310.0, 210.0, 320.0, 220.0, 330.0, 230.0].map(|x| x + t as f32);
        let task = Task::Stage1 {
            v,
            supervised: None,
            learn: true,
        };
        let mut cmd = c.begin(task).unwrap();
        while let Cmd::Move { .. } = cmd {
            let mut seen = v;
            seen[0] += 3.0;
            cmd = c.observe(Observation::Lights(seen)).unwrap();
        }
    }
    c
}

fn image(c: &Controller) -> Vec<u8> {
    let mut buf = vec![0u8; checkpoint::MAX_SIZE];
    let n = checkpoint::save(c, PROVENANCE, &mut buf).unwrap();
    buf.truncate(n);
    buf
}

/// `c`'s tables as a compact image (checkpoint format 3).
fn compact_image(c: &Controller) -> Vec<u8> {
    let compact = checkpoint::Encoding::Compact;
    let mut buf = vec![0u8; compact.max_size()];
    let n = checkpoint::save_as(c, PROVENANCE, compact, &mut buf).unwrap();
    buf.truncate(n);
    buf
}

/// A board holding `ctrl`'s tables as its stored copy, restored at boot (a board that
/// learned them and was reset), on the in-process bus with `faults`.
fn bus(ctrl: Box<Controller>, mode: BusMode, faults: Option<FaultConfig>) -> Bus {
    bus_with(ctrl, mode, faults, board::memory_store())
}

/// [`bus`] with the board's store `store`.
fn bus_with(
    ctrl: Box<Controller>,
    mode: BusMode,
    faults: Option<FaultConfig>,
    store: board::BoardStore,
) -> Bus {
    let mut b = Board { ctrl, store };
    b.store.save_begin(&b.ctrl, PROVENANCE).unwrap();
    let copy = loop {
        if let Some(c) = b.store.save_step(&b.ctrl).unwrap() {
            break c;
        }
    };
    let node = board::node(&mut b, Some(copy), board::guard_seed(3), NodeConfig::HOST);
    SimulatedBus::with_node(mode, 3, faults, Box::new(b), node)
}

fn runner(bus: Bus, mode: BusMode) -> Runner<Bus> {
    let clock = Rc::new(bus.clock());
    let plant = Plant::new(&SimConfig::ideal(), 3).unwrap();
    let rig = Rig::new(bus, clock, plant, mode, Default::default());
    // the in-process profile's patience: under heavy loss a request may need many repeats
    let timing = Timing {
        retries: 150,
        ..Timing::new(Duration::from_millis(60), Duration::from_secs(10))
    };
    Runner::new(rig, 3, timing)
}

/// The board's tables now, as a checkpoint image.
fn held(r: &Runner<Bus>) -> Vec<u8> {
    image(&r.rig().port().controller().ctrl)
}

/// Writes `theirs` into a board holding `mine`, reads the board's tables out: both are the
/// images byte for byte. Returns the runner (for its counters).
fn round_trip(mode: BusMode, faults: Option<FaultConfig>) -> Runner<Bus> {
    let (mine, theirs) = (tables(1, 0), tables(2, 3));
    let mut r = runner(bus(mine, mode, faults), mode);
    let before = status(&mut r).unwrap();
    assert_eq!((before.steps1, before.steps2), (0, 0));
    let applied = write(&mut r, &image(&theirs), false, &mut Told::default()).unwrap();
    assert_eq!(applied.steps1, 3);
    assert_eq!(held(&r), image(&theirs), "the tables written in");
    let now = status(&mut r).unwrap();
    let out = read(&mut r, &now).unwrap();
    assert_eq!(out, image(&theirs), "the tables read out");
    r
}

#[test]
fn tables_round_trip_bit_for_bit_on_can_2_0_and_fd() {
    for mode in [BusMode::Classic, BusMode::Fd] {
        let r = round_trip(mode, None);
        assert_eq!(
            r.stats().table_repeats,
            0,
            "{mode:?}: nothing lost, nothing repeated"
        );
    }
}

/// A board whose store keeps compact images only (an STM32G474's) refuses an f32 image as
/// too large; the writer says so and writes it compact: the board holds the tables rounded
/// to the compact steps, as its newest stored copy.
#[test]
fn tables_written_into_a_compact_store_go_compact() {
    use checkpoint::Encoding;
    let (mine, theirs) = (tables(1, 0), tables(2, 3));
    let mode = BusMode::Fd;
    let store = board::memory_store_as(Encoding::Compact);
    let mut r = runner(bus_with(mine, mode, None, store), mode);
    let mut told = Told::default();
    let applied = write(&mut r, &image(&theirs), false, &mut told).unwrap();
    assert_eq!(applied.steps1, 3);
    assert!(
        told.0.iter().any(|t| t.contains("compact tables only")),
        "{:?}",
        told.0
    );
    let compact = compact_image(&theirs);
    assert_eq!(
        compact_image(&r.rig().port().controller().ctrl),
        compact,
        "the tables, rounded to the steps"
    );
    assert_eq!(
        applied.stored_sequence, 2,
        "applied as the newest stored copy"
    );
    assert_eq!(
        applied.image_len as usize,
        image(&theirs).len(),
        "the read-out's length"
    );
}

/// A compact image (a G474's tables, read out of its store) written into a board that keeps
/// f32 images applies: the board's status names the length of its tables' read-out (format
/// 2), which the writer expects, not the compact image's.
#[test]
fn a_compact_image_written_into_an_f32_board_applies() {
    let (mine, theirs) = (tables(1, 0), tables(2, 3));
    let mode = BusMode::Classic;
    let mut r = runner(bus(mine, mode, None), mode);
    let compact = compact_image(&theirs);
    let mut told = Told::default();
    let applied = write(&mut r, &compact, false, &mut told).unwrap();
    assert!(told.0.is_empty(), "{:?}", told.0);
    assert_eq!(applied.image_len as usize, image(&theirs).len());
    assert_eq!(
        compact_image(&r.rig().port().controller().ctrl),
        compact,
        "the compact tables, applied"
    );
}

/// A lost frame costs a repeat, never a wrong byte: 5 % of the frames dropped, duplicated,
/// reordered or corrupted, on both framings.
#[test]
fn lost_and_spoiled_frames_cost_repeats_only() {
    for fault in ["drop=0.05", "dup=0.05", "reorder=0.05", "corrupt=0.05"] {
        for mode in [BusMode::Classic, BusMode::Fd] {
            let f: FaultConfig = fault.parse().unwrap();
            let r = round_trip(mode, Some(f));
            let injected = r.rig().port().bus_stats();
            assert!(
                injected.dropped + injected.duplicated + injected.delayed + injected.corrupted > 0,
                "{fault} {mode:?}: nothing injected"
            );
            if fault.starts_with("drop") {
                assert!(r.stats().table_repeats > 0, "{fault} {mode:?}: no repeat");
            }
        }
    }
}

/// A writer that stopped half way (a runner that restarted) begins the same transfer again:
/// the node acknowledges the chunk it reached and the writer sends from there only.
#[test]
fn a_new_writer_resumes_where_the_node_stands() {
    let mode = BusMode::Classic;
    let theirs = image(&tables(2, 3));
    let full = {
        let mut r = runner(bus(tables(1, 0), mode, None), mode);
        write(&mut r, &theirs, false, &mut Told::default()).unwrap();
        r.rig().port().bus_stats().sent
    };
    let mut r = runner(bus(tables(1, 0), mode, None), mode);
    // the first writer: the begin and 3000 chunks, then it is gone
    let begin = TableWriteBegin {
        nonce: 0,
        image_len: theirs.len() as u32,
        image_crc: crate::checkpoint_file::crc_of(&theirs),
        fingerprint: checkpoint::verify(&theirs).unwrap().config_fingerprint,
    };
    let rig = r.rig_mut();
    rig.send(NodeId::Controller, begin.into()).unwrap();
    for (k, piece) in theirs.chunks(trn_protocol::CHUNK).take(3000).enumerate() {
        let data = trn_protocol::ChunkData::new(piece);
        let chunk = TableWriteChunk {
            index: k as u16,
            data,
        };
        rig.send(NodeId::Controller, chunk.into()).unwrap();
    }
    while rig
        .next_event(Duration::from_millis(5), Duration::from_secs(10))
        .unwrap()
        .is_some()
    {}
    let sent_before = r.rig().port().bus_stats().sent;
    write(&mut r, &theirs, false, &mut Told::default()).unwrap();
    let resumed = r.rig().port().bus_stats().sent - sent_before;
    assert_eq!(held(&r), theirs);
    assert!(
        resumed < full / 2,
        "the second writer sent {resumed} frames, a whole write {full}"
    );
}

/// Notices, kept for the assertions.
#[derive(Default)]
struct Told(Vec<String>);

impl Observer for Told {
    fn notice(&mut self, text: &str) {
        self.0.push(text.to_string());
    }
}

fn opening(want: Want, reset: bool) -> Opening {
    let session = trn_protocol::SessionConfig {
        seed: 9,
        preset: 0,
        ablation: 0,
        image_width: 1024,
        image_height: 768,
        fd: false,
        keep_tables: false,
        law: 0,
    };
    Opening {
        want,
        reset,
        session,
        fingerprint: cfg().fingerprint(),
        image: trn_controller::presets::ImageSize::DEFAULT,
        needs_tables: Vec::new(),
    }
}

/// On a board that learned, a run that wants new tables or a checkpoint's is refused with
/// what the board holds and how to go on, and the tables stay bit for bit; allowed
/// (`--reset-tables`), it says what it erases and goes through the guard.
#[test]
fn learned_tables_are_erased_or_replaced_only_when_allowed() {
    let mode = BusMode::Classic;
    let learned = image(&tables(4, 5));
    let other = image(&tables(5, 2));
    for want in [Want::New, Want::Image(other.clone())] {
        let mut r = runner(bus(tables(4, 5), mode, None), mode);
        let mut told = Told::default();
        let e = open(&mut r, &opening(want.clone(), false), &mut told)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("holds learned tables (5 stage-1") && e.contains("--reset-tables"),
            "{e}"
        );
        assert!(told.0.is_empty());
        assert_eq!(held(&r), learned, "nothing changed");
        // trials are refused: the board restored learned tables and no session is in force
        assert!(r.rig().port().node().session_required());
        let opened = open(&mut r, &opening(want.clone(), true), &mut told).unwrap();
        assert_eq!(opened.before.map(|b| b.steps1), Some(5));
        assert_eq!(told.0.len(), 1, "{:?}", told.0);
        assert!(told.0[0].contains("5 stage-1 and 0 stage-2 learning steps"));
        assert!(!r.rig().port().node().session_required());
        let now = status(&mut r).unwrap();
        match want {
            Want::New => assert_eq!((now.steps1, now.steps2), (0, 0), "re-seeded"),
            _ => assert_eq!(held(&r), other, "replaced"),
        }
    }
}

/// The tables a board holds are kept, and the run goes on from their learning steps, when
/// they were learned under the run's configuration; under another one the run is refused
/// with the options that name theirs.
#[test]
fn held_tables_are_kept_under_their_configuration_only() {
    let mode = BusMode::Classic;
    let mut r = runner(bus(tables(4, 5), mode, None), mode);
    let opened = open(
        &mut r,
        &opening(Want::Held { or_new: false }, false),
        &mut Told::default(),
    )
    .unwrap();
    assert_eq!(opened.kept_steps, Some(5));
    assert_eq!(held(&r), image(&tables(4, 5)));
    let mut paper = opening(Want::Held { or_new: false }, true);
    paper.session.preset = 1;
    paper.fingerprint = trn_controller::presets::configure(
        trn_controller::presets::Preset::Paper,
        trn_controller::presets::Ablation::None,
        trn_controller::presets::ImageSize::DEFAULT,
    )
    .fingerprint();
    let mut r = runner(bus(tables(4, 5), mode, None), mode);
    let e = open(&mut r, &paper, &mut Told::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("run with --preset project"), "{e}");
    // both numbers, for a controller that computed its own
    let fingerprints = format!(
        "its fingerprint {:#010x}, this run's {:#010x}",
        cfg().fingerprint(),
        paper.fingerprint
    );
    assert!(e.contains(&fingerprints), "{e}");
}

/// A write into learned tables without a nonce is refused by the node (`GUARD_REFUSED`, no
/// nonce); the writer then asks for one and the write goes through.
#[test]
fn a_write_refused_for_want_of_a_nonce_asks_for_one() {
    let mode = BusMode::Fd;
    let mut r = runner(bus(tables(4, 5), mode, None), mode);
    r.rig_mut().start_journal();
    let theirs = image(&tables(6, 1));
    write(&mut r, &theirs, false, &mut Told::default()).unwrap();
    assert_eq!(held(&r), theirs);
    let j = r.rig().journal();
    let nonces = j
        .iter()
        .filter(|e| matches!(e.msg, Message::GuardNonce(_)))
        .count();
    let refused = crate::journal::errors(j)
        .iter()
        .filter(|e| e.code == trn_node::codes::GUARD_REFUSED && e.detail == 0x201)
        .count();
    assert_eq!(
        (refused, nonces),
        (1, 1),
        "refused once for want of a nonce, then one asked for"
    );
}
