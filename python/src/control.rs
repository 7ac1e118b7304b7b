//! [`Ctrl`]: the project's controller (the TRN, or the Broyden servo it is compared with) on
//! plain lists of floats, as the CAN node drives it: a target starts a trial, each reading
//! after a move gives the next command, until the trial is done. The learning-free
//! references of the comparison run behind the same calls ([`trn_references`]): the
//! calibrated model (built from the arm's configuration) and the oracle (handed the arm's
//! plant before each decision).

use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use trn_controller::presets::{Ablation, ImageSize, Preset, Profile};
use trn_controller::{
    Command, Control, Controller, FineMoves, Law, Observation, ObserveKind, StageOutcome, Task,
};
use trn_plant::Plant;
use trn_references::{NominalIk, Oracle};

use crate::arm::Arm;

/// The controller behind a [`Ctrl`].
enum Inner {
    /// The TRN or the Broyden servo (the core's laws). Its 230 KB of tables live on the heap.
    Core(Box<Controller>),
    /// The calibrated model of the arm's configuration.
    Model(Box<NominalIk>),
    /// The oracle, on a copy of the arm's plant taken before each decision.
    Oracle(Box<Oracle<Plant>>),
}

impl Inner {
    fn control(&mut self) -> &mut dyn Control {
        match self {
            Inner::Core(c) => c.as_mut(),
            Inner::Model(c) => c.as_mut(),
            Inner::Oracle(c) => c.as_mut(),
        }
    }

    fn control_ref(&self) -> &dyn Control {
        match self {
            Inner::Core(c) => c.as_ref(),
            Inner::Model(c) => c.as_ref(),
            Inner::Oracle(c) => c.as_ref(),
        }
    }

    /// The oracle sees `arm`'s plant as it is now; the others need no arm.
    fn look(&mut self, arm: Option<&PyRef<'_, Arm>>) -> PyResult<()> {
        if let Inner::Oracle(o) = self {
            let arm = arm.ok_or_else(|| {
                PyValueError::new_err("the oracle solves on the arm's plant: pass arm=")
            })?;
            o.model_mut().plant = arm.plant().clone();
        }
        Ok(())
    }
}

/// A controller (see the module).
#[pyclass(module = "trn_softarm._native")]
pub struct Ctrl {
    ctrl: Inner,
    /// The law's name.
    law: &'static str,
    /// The reading the last move asked for.
    expect: Option<ObserveKind>,
}

fn err(e: trn_controller::Error) -> PyErr {
    PyRuntimeError::new_err(format!("controller: {e}"))
}

fn array<const N: usize>(v: &[f32], what: &str) -> PyResult<[f32; N]> {
    let a: [f32; N] = v.try_into().map_err(|_| {
        PyValueError::new_err(format!("{what}: {N} values expected, got {}", v.len()))
    })?;
    if a.iter().any(|x| !x.is_finite()) {
        return Err(PyValueError::new_err(format!("{what}: not finite: {a:?}")));
    }
    Ok(a)
}

/// A command for Python: `("move", pressures, joints)` or `("done", outcome)`.
fn command<'py>(py: Python<'py>, c: Command) -> PyResult<(String, Bound<'py, PyAny>)> {
    match c {
        Command::Move {
            pressures, joints, ..
        } => {
            let p: Vec<f32> = pressures[..joints as usize].to_vec();
            Ok(("move".into(), p.into_pyobject(py)?.into_any()))
        }
        Command::Done(o) => {
            let d = PyDict::new(py);
            for (name, s) in [("stage1", o.stage1), ("stage2", o.stage2)] {
                d.set_item(name, s.map(|s| outcome(py, &s)).transpose()?)?;
            }
            d.set_item("close_gripper", o.close_gripper)?;
            Ok(("done".into(), d.into_any()))
        }
    }
}

fn outcome<'py>(py: Python<'py>, s: &StageOutcome) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("learned", s.learned)?;
    d.set_item("supervised", s.supervised)?;
    d.set_item("coarse_error_px", s.coarse_error)?;
    d.set_item("final_error_px", s.final_error)?;
    d.set_item("fine_moves", s.fine_moves)?;
    d.set_item("cap_hit", s.cap_hit)?;
    d.set_item("tolerance_px", s.tolerance)?;
    d.set_item("learning_step", s.t)?;
    Ok(d)
}

#[pymethods]
impl Ctrl {
    /// A controller of `law` configured by `preset` and `ablation` for cameras of `image`
    /// size: `trn` or `broyden`, its tables seeded from `seed`; or a learning-free reference
    /// of the arm `arm` (with the TRN's stop rule): `model`, the calibrated model of its
    /// configuration, or `oracle`, which solves on its plant as it is at each decision
    /// (`begin` and `observe` are then given the arm too).
    #[new]
    #[pyo3(signature = (law = "trn", preset = "project", ablation = "none", seed = 0, image = (1024, 768), arm = None))]
    fn new(
        law: &str,
        preset: &str,
        ablation: &str,
        seed: u64,
        image: (u16, u16),
        arm: Option<PyRef<'_, Arm>>,
    ) -> PyResult<Ctrl> {
        let bad = |what: &str, name: &str| PyValueError::new_err(format!("no {what} {name:?}"));
        let serves = "this binding serves \"trn\", \"broyden\", \"model\" and \"oracle\"";
        let preset = Preset::from_name(preset).ok_or_else(|| bad("preset", preset))?;
        let ablation = Ablation::from_name(ablation).ok_or_else(|| bad("ablation", ablation))?;
        let image = ImageSize {
            width: image.0,
            height: image.1,
        };
        let config = |law| {
            Profile {
                preset,
                ablation,
                law,
            }
            .config(image)
        };
        let needs_arm = || {
            PyValueError::new_err(format!(
                "law {law:?} is a model of the arm: pass the environment's arm (arm=)"
            ))
        };
        // an allow-list: a law added to the controller later is refused here until this
        // binding can serve it
        let (ctrl, name) = match (Law::from_name(law), law) {
            (Some(l @ (Law::Trn | Law::Broyden)), _) => {
                let mut ctrl = Box::new(Controller::new(config(l)));
                ctrl.init_random(seed);
                (Inner::Core(ctrl), l.name())
            }
            (None, "model") => {
                let arm = arm.as_ref().ok_or_else(needs_arm)?;
                let model = NominalIk::new(arm.sim_config(), config(Law::Trn))
                    .map_err(|e| PyValueError::new_err(format!("model: {e}")))?;
                (Inner::Model(Box::new(model)), "model")
            }
            (None, "oracle") => {
                let arm = arm.as_ref().ok_or_else(needs_arm)?;
                let oracle = Oracle::new(arm.plant().clone(), config(Law::Trn));
                (Inner::Oracle(Box::new(oracle)), "oracle")
            }
            _ => {
                return Err(PyValueError::new_err(format!(
                    "no law {law:?} in this binding: {serves}"
                )))
            }
        };
        Ok(Ctrl {
            ctrl,
            law: name,
            expect: None,
        })
    }

    /// Starts a trial of `stage` (1: target lights p, q, 8 values; 2: the gripper centre, 4)
    /// learning from it when `learn`; `fine_moves` exactly that many fine moves (None: the
    /// controller's own stop rule); `supervised` the target's pressures (priming, stage 1);
    /// `arm` the arm (the oracle's plant).
    #[pyo3(signature = (stage, target, learn = true, fine_moves = None, supervised = None, arm = None))]
    #[allow(clippy::too_many_arguments)]
    fn begin<'py>(
        &mut self,
        py: Python<'py>,
        stage: u8,
        target: Vec<f32>,
        learn: bool,
        fine_moves: Option<u8>,
        supervised: Option<Vec<f32>>,
        arm: Option<PyRef<'_, Arm>>,
    ) -> PyResult<(String, Bound<'py, PyAny>)> {
        if self.ctrl.control_ref().busy() {
            self.ctrl.control().abort();
        }
        let supervised = supervised
            .map(|p| array::<5>(&p, "supervised"))
            .transpose()?;
        let task = match stage {
            1 => Task::Stage1 {
                v: array(&target, "target")?,
                supervised,
                learn,
            },
            2 => Task::Stage2 {
                c: array(&target, "target")?,
                learn,
            },
            _ => return Err(PyValueError::new_err("stage is 1 or 2")),
        };
        let fine = fine_moves.map_or(FineMoves::Policy, FineMoves::Exactly);
        self.ctrl.look(arm.as_ref())?;
        let c = self.ctrl.control().begin_with(task, fine).map_err(err)?;
        self.note(&c);
        command(py, c)
    }

    /// The reading after the last move (8 or 4 values, as the move asked); the next command.
    /// `arm`: the arm (the oracle's plant).
    #[pyo3(signature = (reading, arm = None))]
    fn observe<'py>(
        &mut self,
        py: Python<'py>,
        reading: Vec<f32>,
        arm: Option<PyRef<'_, Arm>>,
    ) -> PyResult<(String, Bound<'py, PyAny>)> {
        let obs = match self.expect {
            Some(ObserveKind::Lights) => Observation::Lights(array(&reading, "reading")?),
            Some(ObserveKind::Centre) => Observation::Centre(array(&reading, "reading")?),
            None => return Err(PyRuntimeError::new_err("no trial is running")),
        };
        self.ctrl.look(arm.as_ref())?;
        let c = self.ctrl.control().observe(obs).map_err(err)?;
        self.note(&c);
        command(py, c)
    }

    /// Abandons the running trial (nothing is learned from its last move).
    fn abort(&mut self) {
        self.ctrl.control().abort();
        self.expect = None;
    }

    /// True while a trial runs.
    #[getter]
    fn busy(&self) -> bool {
        self.ctrl.control_ref().busy()
    }

    /// The control law's name.
    #[getter]
    fn law(&self) -> &'static str {
        self.law
    }

    /// The tolerance (pixels) at which a trial of `stage` (1 or 2) that does not learn
    /// stops: the configuration's mature tolerance.
    fn mature_tolerance_px(&self, stage: u8) -> PyResult<f32> {
        let cfg = self.ctrl.control_ref().config();
        match stage {
            1 => Ok(cfg.stage1.mature_tolerance),
            2 => Ok(cfg.stage2.mature_tolerance),
            _ => Err(PyValueError::new_err(format!("stage {stage}: 1 or 2"))),
        }
    }
}

impl Ctrl {
    fn note(&mut self, c: &Command) {
        self.expect = match c {
            Command::Move { observe, .. } => Some(*observe),
            Command::Done(_) => None,
        };
    }
}
