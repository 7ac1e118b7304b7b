//! The reset cause a board announces at boot (`trn_node::reset`): the record its panic and
//! hard-fault handlers leave, read back only when intact, and the reset flags.

use trn_node::codes::RESET_CAUSE;
use trn_node::reset::{record, recorded};
use trn_node::{reset_cause, reset_report, ResetCause, ResetFlags};

const SOFTWARE: ResetFlags = ResetFlags {
    power_on: false,
    pin: false,
    watchdog: false,
    software: true,
};

#[test]
fn a_handlers_record_is_read_back_and_names_the_reset() {
    let panic = record(ResetCause::Panic, 417);
    assert_eq!(recorded(&panic), Some((ResetCause::Panic, 417)));
    assert_eq!(
        reset_cause(SOFTWARE, recorded(&panic)),
        (ResetCause::Panic, 417)
    );
    let fault = record(ResetCause::HardFault, 0x0800_1234);
    assert_eq!(
        reset_cause(SOFTWARE, recorded(&fault)),
        (ResetCause::HardFault, 0x0800_1234)
    );
    let r = reset_report(ResetCause::HardFault, 0x0800_1234);
    assert_eq!((r.code, r.detail), (RESET_CAUSE, 5 << 24 | 0x00_1234));
    assert_eq!(reset_report(ResetCause::Panic, 417).detail, 4 << 24 | 417);
}

#[test]
fn ram_that_is_not_a_record_is_ignored() {
    let good = record(ResetCause::Panic, 9);
    // each word changed in turn: marker, cause, detail, check
    for i in 0..4 {
        let mut r = good;
        r[i] ^= 1 << 5;
        assert_eq!(recorded(&r), None, "word {i} changed");
    }
    // a consistent record of a cause no handler records
    assert_eq!(recorded(&record(ResetCause::Pin, 0)), None);
    assert_eq!(recorded(&record(ResetCause::Software, 0)), None);
    // a watchdog's warning (a part without reset flags of its own) is one
    assert_eq!(
        recorded(&record(ResetCause::Watchdog, 0)),
        Some((ResetCause::Watchdog, 0))
    );
    assert_eq!(recorded(&[0; 4]), None);
    assert_eq!(recorded(&[u32::MAX; 4]), None);
}

#[test]
fn without_a_record_the_flags_tell_the_cause() {
    let f = |power_on, pin, watchdog, software| ResetFlags {
        power_on,
        pin,
        watchdog,
        software,
    };
    assert_eq!(
        reset_cause(f(true, true, false, false), None).0,
        ResetCause::PowerOn
    );
    assert_eq!(
        reset_cause(f(false, true, true, false), None).0,
        ResetCause::Watchdog
    );
    assert_eq!(
        reset_cause(f(false, true, false, false), None).0,
        ResetCause::Pin
    );
    assert_eq!(
        reset_cause(f(false, false, false, true), None).0,
        ResetCause::Software
    );
    assert_eq!(
        reset_cause(f(false, false, false, false), None).0,
        ResetCause::Unknown
    );
    // a record is believed only after a software reset (the handler's own), not after a
    // power-on (RAM then holds nothing a handler wrote this time)
    let panic = recorded(&record(ResetCause::Panic, 3));
    assert_eq!(
        reset_cause(f(true, true, false, true), panic).0,
        ResetCause::PowerOn
    );
    assert_eq!(
        reset_cause(f(false, true, true, false), panic).0,
        ResetCause::Watchdog
    );
    assert_eq!(reset_report(ResetCause::Watchdog, 0).detail, 3 << 24);
}

/// The node announces the cause at its first poll, before its first heartbeat, once.
#[test]
fn the_node_announces_the_cause_before_its_first_heartbeat() {
    use trn_controller::{Config, Controller};
    use trn_node::{ControllerNode, NodeConfig, Outbox};
    use trn_protocol::Message;
    let mut ctrl = Box::new(Controller::new(Config::project_default()));
    let mut n = ControllerNode::new(NodeConfig::DEFAULT);
    n.announce_reset(ResetCause::Watchdog, 0);
    let mut out = Outbox::new();
    n.poll(&mut ctrl, 0, &mut out);
    let kinds: Vec<&Message> = out.iter().map(|e| &e.msg).collect();
    assert!(
        matches!(kinds[..], [Message::ErrorReport(r), Message::Heartbeat(_)]
            if r.code == RESET_CAUSE && r.detail == 3 << 24),
        "{kinds:?}"
    );
    let mut again = Outbox::new();
    n.poll(&mut ctrl, 100, &mut again);
    assert!(
        again
            .iter()
            .all(|e| !matches!(e.msg, Message::ErrorReport(_))),
        "announced once"
    );
}
