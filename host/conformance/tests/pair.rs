//! The conformance suite on the simulated clock against a scripted peer, taking no wall
//! time waiting.

use std::rc::Rc;
use std::time::Duration;

use embedded_can::blocking::Can;
use trn_bench::ports::ControllerPort;
use trn_bench::rig::Rig;
use trn_bench::runner::{Runner, Timing};
use trn_bench::suite::{Patience, Suite};
use trn_plant::{Plant, SimConfig};
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{BusMode, CanFrame, Encoder, Envelope, Heartbeat, NodeId, NodeState};
use trn_transport::{Clock, SimClock};

/// A controller that only beats: a heartbeat every 100 ms of the simulated clock, nothing
/// else, whatever it is sent.
struct HeartbeatsOnly {
    clock: SimClock,
    next_beat: Duration,
    counter: u8,
}

impl Can for HeartbeatsOnly {
    type Frame = CanFrame;
    type Error = trn_protocol::Error;
    fn transmit(&mut self, _: &CanFrame) -> Result<(), trn_protocol::Error> {
        Ok(())
    }
    fn receive(&mut self) -> Result<CanFrame, trn_protocol::Error> {
        unreachable!("the rig waits with a timeout")
    }
}

impl ReceiveTimeout for HeartbeatsOnly {
    fn receive_timeout(&mut self, t: Duration) -> Result<Option<CanFrame>, trn_protocol::Error> {
        let end = self.clock.now() + t;
        if self.next_beat > end {
            self.clock.advance_to(end);
            return Ok(None);
        }
        self.clock.advance_to(self.next_beat);
        self.next_beat += Duration::from_millis(100);
        self.counter = self.counter.wrapping_add(1);
        let hb = Heartbeat {
            counter: self.counter,
            state: NodeState::Operational,
        };
        let mut enc = Encoder::new(BusMode::Classic);
        let env = Envelope::new(NodeId::Controller, hb.into());
        Ok(enc.encode(&env).unwrap().to_vec().into_iter().next())
    }
}

impl ControllerPort for HeartbeatsOnly {}

/// The conformance suite against a controller that sends only heartbeats ends with a
/// typed error after one sequence's patience, not after every check's.
#[test]
fn conformance_against_heartbeats_only_ends_after_one_patience() {
    let clock = SimClock::new();
    let port = HeartbeatsOnly {
        clock: clock.clone(),
        next_beat: Duration::ZERO,
        counter: 0,
    };
    let plant = Plant::new(&SimConfig::ideal(), 5).unwrap();
    let rig = Rig::new(
        port,
        Rc::new(clock.clone()),
        plant,
        BusMode::Classic,
        Default::default(),
    );
    let timing = Timing {
        alive: Duration::from_millis(500),
        ..Timing::new(Duration::from_millis(60), Duration::from_secs(10))
    };
    let mut r = Runner::new(rig, 5, timing);
    let patience = Patience {
        answer: Duration::from_secs(20),
        quiet: Duration::from_millis(600),
        alive: Duration::from_millis(500),
    };
    let session = trn_bench::RunSpec::new(trn_bench::Command::Conformance, 1).session_config(false);
    // a controller that beats and never answers the status request speaks version 3 (SPEC.md
    // "Versions"): the suite's v3 profile
    let e = trn_conformance::Conformance
        .run(&mut r, session, patience, trn_bench::tables::Spoken::V3)
        .unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("only heartbeats"), "{msg}");
    // one check's patience (the first of the v3 profile, the session configuration)
    assert!(clock.now() < Duration::from_secs(25), "{:?}", clock.now());
}
