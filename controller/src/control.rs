//! The seam between a control law and the CAN node: what a node asks of a controller. The
//! project's [`Controller`] (the TRN or the Broyden servo) implements it, and so can a
//! controller outside this crate (the simulator's model-based reference), so that every
//! controller runs in the same node, over every bus.

use crate::config::{Config, Law};
use crate::controller::{Command, Controller, Observation, Task};
use crate::error::Result;
use crate::persist::TableStore;
use crate::presets::{Profile, SessionProfile};
use crate::trial::FineMoves;

/// A controller as the node drives it: tasks and observations in, commands out.
pub trait Control {
    /// Starts a task; its first command.
    fn begin_with(&mut self, task: Task, fine: FineMoves) -> Result<Command>;
    /// The observation after the last move; the next command.
    fn observe(&mut self, obs: Observation) -> Result<Command>;
    /// Abandons the running task.
    fn abort(&mut self);
    /// True while a task runs.
    fn busy(&self) -> bool;
    /// The configuration in force.
    fn config(&self) -> &Config;
    /// Replaces the configuration between tasks.
    fn set_config(&mut self, cfg: Config) -> Result<()>;
    /// New initial tables (or whatever the law starts from) from `seed`.
    fn init_random(&mut self, seed: u64);
    /// The configuration a session's profile gives this controller, and its fingerprint
    /// (SPEC.md 3.2, 3.2.1), with the session's law byte. The default serves this
    /// crate's laws ([`Law::decode`]: a host-side law's code is
    /// [`crate::Error::UnsupportedLaw`]); a host-side controller serves its own code.
    fn session_config(&self, asked: SessionProfile) -> Result<(Config, u32)> {
        let cfg = Profile {
            preset: asked.preset,
            ablation: asked.ablation,
            law: Law::decode(asked.law)?,
        }
        .config(asked.image);
        Ok((cfg, cfg.fingerprint()))
    }
    /// The fingerprint of the configuration in force (SPEC.md 3.2.1): a host-side law's is
    /// taken with its own law code ([`Config::fingerprint_as`]).
    fn fingerprint(&self) -> u32 {
        self.config().fingerprint()
    }
    /// The TRN tables this controller holds and the store that keeps them, for a node that
    /// reads them out, writes them in, saves them and guards them; `None` for a controller
    /// without such tables (the default: nothing of it to read, write or lose).
    fn tables(&mut self) -> Option<Tables<'_>> {
        None
    }
    /// The project's controller this is or holds, for a reader of its tables (a host that
    /// checkpoints them while a run goes on); `None` for another controller (the default).
    fn controller(&self) -> Option<&Controller> {
        None
    }
}

impl Control for Controller {
    fn begin_with(&mut self, task: Task, fine: FineMoves) -> Result<Command> {
        Controller::begin_with(self, task, fine)
    }

    fn observe(&mut self, obs: Observation) -> Result<Command> {
        Controller::observe(self, obs)
    }

    fn abort(&mut self) {
        Controller::abort(self)
    }

    fn busy(&self) -> bool {
        Controller::busy(self)
    }

    fn config(&self) -> &Config {
        Controller::config(self)
    }

    fn set_config(&mut self, cfg: Config) -> Result<()> {
        Controller::set_config(self, cfg)
    }

    fn init_random(&mut self, seed: u64) {
        Controller::init_random(self, seed)
    }

    fn tables(&mut self) -> Option<Tables<'_>> {
        Some(Tables {
            ctrl: self,
            store: None,
        })
    }

    fn controller(&self) -> Option<&Controller> {
        Some(self)
    }
}

/// A boxed controller is a controller (the host keeps the 230 KB of tables on the heap).
#[cfg(any(test, feature = "std"))]
impl<C: Control + ?Sized> Control for std::boxed::Box<C> {
    fn begin_with(&mut self, task: Task, fine: FineMoves) -> Result<Command> {
        (**self).begin_with(task, fine)
    }

    fn observe(&mut self, obs: Observation) -> Result<Command> {
        (**self).observe(obs)
    }

    fn abort(&mut self) {
        (**self).abort()
    }

    fn busy(&self) -> bool {
        (**self).busy()
    }

    fn config(&self) -> &Config {
        (**self).config()
    }

    fn set_config(&mut self, cfg: Config) -> Result<()> {
        (**self).set_config(cfg)
    }

    fn init_random(&mut self, seed: u64) {
        (**self).init_random(seed)
    }

    fn session_config(&self, asked: SessionProfile) -> Result<(Config, u32)> {
        (**self).session_config(asked)
    }

    fn fingerprint(&self) -> u32 {
        (**self).fingerprint()
    }

    fn tables(&mut self) -> Option<Tables<'_>> {
        (**self).tables()
    }

    fn controller(&self) -> Option<&Controller> {
        (**self).controller()
    }
}

/// A controller's tables and, if it has one, the store that keeps them: what
/// [`Control::tables`] gives a node.
pub struct Tables<'a> {
    /// The controller whose tables these are.
    pub ctrl: &'a mut Controller,
    /// Where they are kept, if anywhere.
    pub store: Option<&'a mut dyn TableStore>,
}

/// A controller and the store of its tables, driven by a node as one [`Control`]: the
/// firmware passes `WithStore { ctrl: &mut CONTROLLER, store: &mut flash_store }`, a host
/// `WithStore { ctrl: Box<Controller>, store }`.
pub struct WithStore<C, S> {
    /// The controller (`&mut Controller`, `Box<Controller>`).
    pub ctrl: C,
    /// Its store.
    pub store: S,
}

impl<C, S> Control for WithStore<C, S>
where
    C: core::ops::DerefMut<Target = Controller>,
    S: TableStore,
{
    fn begin_with(&mut self, task: Task, fine: FineMoves) -> Result<Command> {
        self.ctrl.begin_with(task, fine)
    }
    fn observe(&mut self, obs: Observation) -> Result<Command> {
        self.ctrl.observe(obs)
    }
    fn abort(&mut self) {
        self.ctrl.abort()
    }
    fn busy(&self) -> bool {
        self.ctrl.busy()
    }
    fn config(&self) -> &Config {
        self.ctrl.config()
    }
    fn set_config(&mut self, cfg: Config) -> Result<()> {
        self.ctrl.set_config(cfg)
    }
    fn init_random(&mut self, seed: u64) {
        self.ctrl.init_random(seed)
    }
    fn tables(&mut self) -> Option<Tables<'_>> {
        Some(Tables {
            ctrl: &mut self.ctrl,
            store: Some(&mut self.store),
        })
    }
    fn controller(&self) -> Option<&Controller> {
        Some(&self.ctrl)
    }
}
