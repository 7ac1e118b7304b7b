//! The session configuration over the bus (SPEC.md 3.2): a `SessionConfig` or a
//! `ConfirmedSessionConfig` checked, applied to the controller (new tables seeded, or the tables
//! held checked against it), and acknowledged by its echo.

use trn_controller::checkpoint::Provenance;
use trn_controller::presets::{Ablation, ImageSize, Preset, SessionProfile};
use trn_controller::{Control, Error as CtrlError};
use trn_protocol::{BusMode, GuardOp, Mode, NodeId, SessionConfig};

use super::tables::learned;
use super::{error, ControllerNode};
use crate::codes;
use crate::outbox::{push, Outbox};

impl ControllerNode {
    /// Applies a session's run parameters (SPEC.md 3.2): in `Idle` with no trial in progress,
    /// a new configuration and tables seeded from `seed` (or, with `keep_tables`, a check that
    /// the tables held were learned under this configuration); acknowledged by the echo to
    /// `Broadcast`. A repeat of the configuration in force is acknowledged again without
    /// re-seeding. Re-seeding tables that learned needs the guard's nonce (`nonce`, from a
    /// `ConfirmedSessionConfig`; 0 from a plain one), unless the node allows unguarded
    /// resets. A refusal on tables that learned leaves trials refused until a session is
    /// accepted. Not inlined: the `Config` built here stays out of the callers' frames.
    #[inline(never)]
    pub(super) fn on_session_config<C: Control + ?Sized>(
        &mut self,
        ctrl: &mut C,
        c: &SessionConfig,
        nonce: u32,
        now_ms: u32,
        out: &mut Outbox,
    ) {
        if self.session == Some(*c) {
            self.session_required = false;
            push(out, NodeId::Broadcast, (*c).into());
            return;
        }
        let learned = learned(ctrl);
        let refuse = |node: &mut Self, detail: u32, out: &mut Outbox| {
            node.session_required |= learned;
            error(out, codes::CONFIG_REJECTED, detail)
        };
        if self.mode != Mode::Idle || self.trial.is_some() {
            return refuse(self, codes::CONFIG_NOT_IDLE, out);
        }
        // the codes were range-checked on decode (`Message::validate`); a law the controller
        // does not run (a host-side law's code to the core) is unsupported, not invalid
        let (Some(preset), Some(ablation)) =
            (Preset::from_code(c.preset), Ablation::from_code(c.ablation))
        else {
            return refuse(self, codes::CONFIG_INVALID, out);
        };
        let image = ImageSize {
            width: c.image_width,
            height: c.image_height,
        };
        let rejected = |e: CtrlError| match e {
            CtrlError::UnsupportedLaw => codes::CONFIG_UNSUPPORTED,
            _ => codes::CONFIG_INVALID,
        };
        let asked = SessionProfile {
            preset,
            ablation,
            law: c.law,
            image,
        };
        let (cfg, fingerprint) = match ctrl.session_config(asked) {
            Ok(given) => given,
            Err(e) => return refuse(self, rejected(e), out),
        };
        if c.keep_tables {
            if self.tables_fingerprint(ctrl) != fingerprint {
                return refuse(self, codes::CONFIG_MISMATCH, out);
            }
            if *ctrl.config() != cfg {
                if let Err(e) = ctrl.set_config(cfg) {
                    return refuse(self, rejected(e), out);
                }
            }
        } else {
            if learned
                && !(self.cfg.allow_unguarded_reset || self.cfg.v3())
                && !self.guard_allows(GuardOp::Reseed, nonce, now_ms, out)
            {
                self.session_required = true;
                return;
            }
            if let Err(e) = ctrl.set_config(cfg) {
                return refuse(self, rejected(e), out);
            }
            ctrl.init_random(c.seed);
            self.tables_changed(ctrl, false);
            self.tables.fingerprint = Some(fingerprint);
        }
        self.tables.provenance = Provenance {
            preset: c.preset,
            ablation: c.ablation,
        };
        self.session = Some(*c);
        self.session_required = false;
        self.forget_trials();
        self.bus_mode = Some(if c.fd { BusMode::Fd } else { BusMode::Classic });
        push(out, NodeId::Broadcast, (*c).into());
    }
}
