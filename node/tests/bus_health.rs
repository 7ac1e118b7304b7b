//! The CAN controller's health policy (`trn_node::health`), driven as a board drives it: a
//! reading of its controller's registers each turn, on a simulated clock.

use trn_node::codes::{BUS_COUNTS, BUS_STATE};
use trn_node::health::{HOLD_OFF_MAX_MS, HOLD_OFF_MS, REPORT_GAP_MS, STABLE_MS};
use trn_node::{BusAction, BusHealth, BusReading, BusState, ControllerNode, NodeConfig, Outbox};
use trn_protocol::{Message, NodeId};

fn reading(state: BusState, tec: u8, rec: u8) -> BusReading {
    BusReading {
        state,
        tec,
        rec,
        overruns: 0,
    }
}

const ACTIVE: BusReading = BusReading {
    state: BusState::ErrorActive,
    tec: 0,
    rec: 0,
    overruns: 0,
};
const OFF: BusReading = BusReading {
    state: BusState::BusOff,
    tec: 255,
    rec: 0,
    overruns: 0,
};

/// The health reports in `out`: (code, detail), each from the controller.
fn reports(out: &Outbox) -> Vec<(u16, u32)> {
    out.iter()
        .filter_map(|e| match e.msg {
            Message::ErrorReport(r) if r.code == BUS_STATE || r.code == BUS_COUNTS => {
                assert_eq!(e.node, NodeId::Controller);
                Some((r.code, r.detail))
            }
            _ => None,
        })
        .collect()
}

/// Turns every `step` ms from `from` while `r` is read, until `until`: the times of the
/// restarts asked for and every report sent.
fn turns(
    n: &mut ControllerNode,
    h: &mut BusHealth,
    r: BusReading,
    from: u32,
    until: u32,
    step: u32,
) -> (Vec<u32>, Vec<(u16, u32)>) {
    let mut restarts = vec![];
    let mut sent = vec![];
    let mut now = from;
    while now < until {
        let mut out = Outbox::new();
        if n.bus_health(h, &r, now, &mut out) == BusAction::Restart {
            restarts.push(now);
        }
        sent.extend(reports(&out));
        now += step;
    }
    (restarts, sent)
}

#[test]
fn a_healthy_bus_sends_nothing_and_counts_nothing() {
    let mut n = ControllerNode::new(NodeConfig::DEFAULT);
    let mut h = BusHealth::new();
    let (restarts, sent) = turns(
        &mut n,
        &mut h,
        reading(BusState::ErrorActive, 5, 3),
        0,
        5_000,
        10,
    );
    assert!(restarts.is_empty());
    assert!(sent.is_empty(), "{sent:?}");
    let c = n.stats().bus;
    assert_eq!((c.tec, c.rec, c.state), (5, 3, BusState::ErrorActive));
    assert_eq!(
        (c.bus_offs, c.restarts, c.passives, c.overruns, c.reports),
        (0, 0, 0, 0, 0)
    );
}

#[test]
fn a_bus_off_restarts_after_its_hold_off_and_is_reported_once_back() {
    let mut n = ControllerNode::new(NodeConfig::DEFAULT);
    let mut h = BusHealth::new();
    turns(&mut n, &mut h, ACTIVE, 0, 1_000, 10);
    // bus-off from 1000 ms: no restart before the hold-off, one at it, nothing sent meanwhile
    let (restarts, sent) = turns(&mut n, &mut h, OFF, 1_000, 1_000 + HOLD_OFF_MS + 5, 10);
    assert_eq!(restarts, vec![1_000 + HOLD_OFF_MS]);
    assert!(sent.is_empty(), "reports while bus-off: {sent:?}");
    assert_eq!(n.stats().bus.bus_offs, 1);
    assert_eq!(n.stats().bus.restarts, 1);
    // back on the bus: the pair of reports, the bus-off in the counts
    let mut out = Outbox::new();
    let back = reading(BusState::ErrorActive, 0, 0);
    assert_eq!(
        n.bus_health(&mut h, &back, 1_200, &mut out),
        BusAction::None
    );
    assert_eq!(reports(&out), vec![(BUS_STATE, 0), (BUS_COUNTS, 1 << 16)]);
    assert_eq!(n.stats().bus.reports, 1);
    // and nothing more while nothing changes
    let (_, sent) = turns(&mut n, &mut h, back, 1_210, 10_000, 10);
    assert!(sent.is_empty(), "{sent:?}");
}

#[test]
fn a_bus_off_that_lasts_is_restarted_once_per_hold_off() {
    let mut n = ControllerNode::new(NodeConfig::DEFAULT);
    let mut h = BusHealth::new();
    let (restarts, _) = turns(&mut n, &mut h, OFF, 0, 10 * HOLD_OFF_MS + 1, 10);
    let expected: Vec<u32> = (1..=10).map(|k| k * HOLD_OFF_MS).collect();
    assert_eq!(restarts, expected);
    // one bus-off, however many restarts it took
    assert_eq!(n.stats().bus.bus_offs, 1);
    assert_eq!(n.stats().bus.restarts, 10);
}

#[test]
fn bus_offs_in_a_row_double_the_hold_off_up_to_its_bound() {
    let mut n = ControllerNode::new(NodeConfig::DEFAULT);
    let mut h = BusHealth::new();
    let mut now = 0;
    let mut holds = vec![];
    for _ in 0..7 {
        // off until restarted, then back on the bus for 50 ms
        let start = now;
        loop {
            let mut out = Outbox::new();
            let restarted = n.bus_health(&mut h, &OFF, now, &mut out) == BusAction::Restart;
            now += 10;
            if restarted {
                holds.push(now - 10 - start);
                break;
            }
        }
        let (_, _) = turns(&mut n, &mut h, ACTIVE, now, now + 50, 10);
        now += 50;
    }
    let first = HOLD_OFF_MS;
    assert_eq!(
        holds,
        vec![
            first,
            2 * first,
            4 * first,
            8 * first,
            16 * first,
            16 * first,
            16 * first
        ]
    );
    assert_eq!(HOLD_OFF_MAX_MS, 16 * first);
    assert_eq!(n.stats().bus.bus_offs, 7);
    // a bus-off long after the last one starts from the first hold-off again
    let later = now + STABLE_MS;
    let (restarts, _) = turns(&mut n, &mut h, OFF, later, later + 2 * first, 10);
    assert_eq!(restarts.first(), Some(&(later + first)));
}

#[test]
fn error_passive_and_overruns_are_counted_and_reported_at_most_once_a_second() {
    let mut n = ControllerNode::new(NodeConfig::DEFAULT);
    let mut h = BusHealth::new();
    let mut out = Outbox::new();
    let passive = reading(BusState::ErrorPassive, 136, 7);
    assert_eq!(n.bus_health(&mut h, &passive, 0, &mut out), BusAction::None);
    assert_eq!(
        reports(&out),
        vec![(BUS_STATE, 2 << 16 | 136 << 8 | 7), (BUS_COUNTS, 0)]
    );
    // an overrun 10 ms later: counted, reported only once the gap has passed
    let mut lost = passive;
    lost.overruns = 3;
    let mut out = Outbox::new();
    n.bus_health(&mut h, &lost, 10, &mut out);
    assert!(reports(&out).is_empty());
    assert_eq!(n.stats().bus.overruns, 3);
    let (_, sent) = turns(&mut n, &mut h, passive, 20, REPORT_GAP_MS + 5, 10);
    assert_eq!(
        sent,
        vec![(BUS_STATE, 2 << 16 | 136 << 8 | 7), (BUS_COUNTS, 3)]
    );
    // a state that flaps is reported at its latest, once per gap
    let mut sent = vec![];
    for k in 0..200u32 {
        let state = if k % 2 == 0 {
            BusState::ErrorWarning
        } else {
            BusState::ErrorPassive
        };
        let mut out = Outbox::new();
        n.bus_health(
            &mut h,
            &reading(state, 100 + (k % 2) as u8 * 30, 0),
            2_000 + 10 * k,
            &mut out,
        );
        sent.extend(reports(&out));
    }
    assert_eq!(sent.len(), 2 * 2, "two pairs in two seconds: {sent:?}");
    let c = n.stats().bus;
    assert_eq!(c.passives, 1 + 100, "each entry into error-passive");
    assert_eq!(c.reports, 1 + 1 + 2);
}

#[test]
fn the_counts_saturate_in_the_report() {
    let mut n = ControllerNode::new(NodeConfig::DEFAULT);
    let mut h = BusHealth::new();
    let mut out = Outbox::new();
    let mut r = ACTIVE;
    r.overruns = u32::MAX;
    n.bus_health(&mut h, &r, 0, &mut out);
    assert_eq!(reports(&out), vec![(BUS_STATE, 0), (BUS_COUNTS, 0xFFFF)]);
    let mut out = Outbox::new();
    n.bus_health(&mut h, &r, 10, &mut out);
    assert_eq!(n.stats().bus.overruns, u32::MAX, "saturates, never wraps");
}

#[test]
fn the_reports_are_framed_for_the_bus() {
    use trn_protocol::{BusMode, Encoder, Reassembler};
    let mut n = ControllerNode::new(NodeConfig::DEFAULT);
    let mut h = BusHealth::new();
    let mut enc = Encoder::new(BusMode::Classic);
    let mut frames = vec![];
    let passive = reading(BusState::ErrorPassive, 130, 0);
    let action = n
        .bus_health_frames(&mut h, &passive, &mut enc, 0, &mut |f| frames.push(*f))
        .unwrap();
    assert_eq!(action, BusAction::None);
    let mut rx: Reassembler = Reassembler::new(1_000);
    let got: Vec<_> = frames
        .iter()
        .filter_map(|f| rx.push(f, 0).unwrap())
        .map(|e| e.msg)
        .collect();
    assert_eq!(got.len(), 2);
    assert!(
        matches!(got[0], Message::ErrorReport(r) if r.code == BUS_STATE && r.detail == 2 << 16 | 130 << 8)
    );
    assert!(matches!(got[1], Message::ErrorReport(r) if r.code == BUS_COUNTS && r.detail == 0));
}

#[test]
fn the_status_reports_end_no_trial() {
    use trn_node::codes::{aborts_trial, RESET_CAUSE};
    for code in [BUS_STATE, BUS_COUNTS, RESET_CAUSE] {
        assert!(!aborts_trial(code), "{code:#x}");
    }
    // and they are codes of their own
    let all = [
        BUS_STATE,
        BUS_COUNTS,
        RESET_CAUSE,
        trn_node::codes::TABLES_FAILED,
    ];
    for (i, a) in all.iter().enumerate() {
        assert!(all[i + 1..].iter().all(|b| b != a));
    }
}
