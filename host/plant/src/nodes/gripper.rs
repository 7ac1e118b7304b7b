//! The gripper as a sans-IO node: `GripperCommand` in, `GripperStatus` out.

use trn_protocol::{Envelope, GripperStatus, Message, NodeId};

use super::Outbox;

/// The gripper.
#[derive(Debug, Clone, Default)]
pub struct Gripper {
    closed: bool,
}

impl Gripper {
    /// An open gripper.
    pub fn new() -> Self {
        Self::default()
    }

    /// True when closed.
    pub fn is_closed(&self) -> bool {
        self.closed
    }

    /// Opens it without a command (the runner, between trials).
    pub fn open(&mut self) {
        self.closed = false;
    }

    /// A received message: a `GripperCommand` is applied and answered; returns the new
    /// state (`Some(true)`: closed now).
    pub fn on_message(&mut self, env: &Envelope, out: &mut Outbox) -> Option<bool> {
        let (NodeId::Gripper, Message::GripperCommand(g)) = (env.node, env.msg) else {
            return None;
        };
        self.closed = g.close;
        out.push(Envelope::new(
            NodeId::Gripper,
            GripperStatus { closed: g.close }.into(),
        ));
        Some(g.close)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use trn_protocol::GripperCommand;

    #[test]
    fn closes_and_says_so() {
        let mut g = Gripper::new();
        let mut out = Outbox::new();
        let cmd = |close| Envelope::new(NodeId::Gripper, GripperCommand { close }.into());
        assert_eq!(g.on_message(&cmd(true), &mut out), Some(true));
        assert!(g.is_closed());
        assert_eq!(
            out[0].msg,
            Message::GripperStatus(GripperStatus { closed: true })
        );
        let status = Envelope::new(NodeId::Gripper, GripperStatus { closed: true }.into());
        assert_eq!(
            g.on_message(&status, &mut out),
            None,
            "its own report is not a command"
        );
        g.open();
        assert!(!g.is_closed());
    }
}
