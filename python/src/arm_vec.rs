//! [`ArmVec`]: `n` simulated arms stepped in one call by a [`Crew`] with the GIL released
//! (the native vector environment's core), with each arm's next episode built ahead of its
//! reset ([`crate::ahead`]).

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyByteArray, PyBytes, PyDict};

use crate::ahead::Ahead;
use crate::arm::{
    resolve, value_err, Bounds, ObservationArrays, ObservationBytes, Options, Outcome, Sim,
};
use trn_crew::Crew;

/// `n` arms of one configuration stepped together: every call runs the arms on a [`Crew`]
/// (the caller and a thread for each other core) with the GIL released. Arm `i` is reset
/// or stepped exactly as an [`crate::arm::Arm`] would be with the same seeds and actions.
#[pyclass(module = "trn_softarm._native")]
pub struct ArmVec {
    /// Each arm, locked by the thread that runs it (never contended: a call's threads take
    /// distinct arms, and Python's borrow of the `ArmVec` keeps calls apart).
    sims: Arc<Vec<Mutex<Sim>>>,
    crew: Crew,
    /// An arm as built, not reset: what each episode built ahead starts from.
    blank: Sim,
    /// Each arm's next episode, being built (see the module).
    ahead: Vec<Option<Ahead<Sim>>>,
    /// Resets that took an episode built ahead.
    taken: Arc<AtomicU64>,
}

/// What one arm of an [`ArmVec`] does in a call.
enum Work {
    /// A reset, with the episode built ahead for this seed if there is one.
    Reset(u64, Option<Ahead<Sim>>),
    Step(Vec<f32>),
}

/// What [`ArmVec::step_batch`] returns: the observation's three buffers, the info's four
/// (as `info_batch`), the rewards and the ends.
type StepArrays<'py> = (
    Bound<'py, PyByteArray>,
    Bound<'py, PyByteArray>,
    Bound<'py, PyByteArray>,
    Bound<'py, PyByteArray>,
    Bound<'py, PyByteArray>,
    Bound<'py, PyByteArray>,
    Bound<'py, PyBytes>,
    Bound<'py, PyByteArray>,
    Bound<'py, PyByteArray>,
);

/// Arm `i`, locked (a lock an arm's panic left poisoned still holds the arm).
fn arm(sims: &[Mutex<Sim>], i: usize) -> MutexGuard<'_, Sim> {
    sims[i].lock().unwrap_or_else(|p| p.into_inner())
}

#[pymethods]
impl ArmVec {
    /// `n` arms, each as `Arm(config, stage, dt_s, persistent, randomise)`.
    #[new]
    #[pyo3(signature = (n, config = "realistic", stage = 1, dt_s = None, persistent = false, randomise = 0.0))]
    fn new(
        n: usize,
        config: &str,
        stage: u8,
        dt_s: Option<f64>,
        persistent: bool,
        randomise: f64,
    ) -> PyResult<ArmVec> {
        if n == 0 {
            return Err(PyValueError::new_err("at least one arm"));
        }
        let options = Options {
            dt_s,
            persistent,
            randomise,
        };
        let sim = Sim::new(resolve(config)?, stage, options).map_err(value_err)?;
        Ok(ArmVec {
            sims: Arc::new((0..n).map(|_| Mutex::new(sim.clone())).collect()),
            crew: Crew::for_jobs(n),
            blank: sim,
            ahead: (0..n).map(|_| None).collect(),
            taken: Arc::new(AtomicU64::new(0)),
        })
    }

    /// Number of arms.
    fn __len__(&self) -> usize {
        self.sims.len()
    }

    /// Resets arm `i` from `seeds[i]` and steps it by `actions[i]` where given (`None`
    /// leaves it as it is; an arm given both is reset). All at once, in parallel.
    fn run(
        &mut self,
        py: Python<'_>,
        seeds: Vec<Option<u64>>,
        actions: Vec<Option<Vec<f32>>>,
    ) -> PyResult<()> {
        if seeds.len() != self.sims.len() || actions.len() != self.sims.len() {
            return Err(PyValueError::new_err(format!(
                "{} arms: one seed or None and one action or None an arm, {} seeds and {} \
                 actions given",
                self.sims.len(),
                seeds.len(),
                actions.len()
            )));
        }
        self.run_work(py, seeds, actions)
    }

    /// The vector environment's step in one call: arm `i` reset from `seeds[i]` where one
    /// is given (`seeds` None: none is), else moved by its row of `actions` (native-endian
    /// float32, one row of the stage's joints an arm; a reset arm's row is not used), all
    /// at once as [`ArmVec::run`] does; then what `observation_batch(bounds)` and
    /// `info_batch()` give, and each arm's outcome by `tolerance_px`, `max_moves` and
    /// `diagonal` (as `Arm.outcome` scores a move): `rewards` (float64) and `ends` (bool,
    /// the arms' terminated then their truncated), an arm reset here 0, False and False.
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (seeds, actions, bounds, tolerance_px, max_moves, diagonal))]
    fn step_batch<'py>(
        &mut self,
        py: Python<'py>,
        seeds: Option<Vec<Option<u64>>>,
        actions: &[u8],
        bounds: [f32; 4],
        tolerance_px: f64,
        max_moves: u64,
        diagonal: f64,
    ) -> PyResult<StepArrays<'py>> {
        let n = self.sims.len();
        let joints = self.blank.joints();
        let seeds = seeds.unwrap_or_else(|| vec![None; n]);
        if seeds.len() != n || actions.len() != n * joints * 4 {
            return Err(PyValueError::new_err(format!(
                "{n} arms of {joints} joints: {n} seeds (or None) and {} bytes of float32 \
                 actions, {} seeds and {} bytes given",
                n * joints * 4,
                seeds.len(),
                actions.len()
            )));
        }
        let rows = actions.chunks_exact(joints * 4).map(|row| {
            row.chunks_exact(4)
                .map(|b| f32::from_ne_bytes([b[0], b[1], b[2], b[3]]))
                .collect()
        });
        let acts: Vec<Option<Vec<f32>>> = seeds
            .iter()
            .zip(rows)
            .map(|(s, row)| s.is_none().then_some(row))
            .collect();
        let reset: Vec<bool> = seeds.iter().map(Option::is_some).collect();
        self.run_work(py, seeds, acts)?;
        let rule = Outcome {
            tolerance_px,
            max_moves,
            diagonal,
        };
        let (mut rewards, mut terminated, mut truncated) = (Vec::new(), Vec::new(), Vec::new());
        for (i, &reset) in reset.iter().enumerate() {
            let (r, te, tr) = match reset {
                true => (0.0, false, false),
                false => arm(&self.sims, i).outcome(&rule),
            };
            rewards.extend(r.to_ne_bytes());
            terminated.push(u8::from(te));
            truncated.push(u8::from(tr));
        }
        terminated.extend(truncated);
        let (lights, status, target) = self.observation_batch(py, bounds);
        let (floats, flags, counts, first_none) = self.info_batch(py);
        Ok((
            lights,
            status,
            target,
            floats,
            flags,
            counts,
            first_none,
            PyByteArray::new(py, &rewards),
            PyByteArray::new(py, &terminated),
        ))
    }

    /// Threads that run the arms beside the caller's (one for each other core, at most one
    /// for each other arm).
    #[getter]
    fn crew_threads(&self) -> usize {
        self.crew.threads()
    }

    /// Starts building arm `i`'s next episode, the one `seed` gives, on a thread of its own
    /// at the lowest priority (see the module): the reset of arm `i` to `seed` takes it. A
    /// persistent arm's next episode depends on this one: nothing is built for it.
    fn prepare(&mut self, i: usize, seed: u64) -> PyResult<()> {
        let n = self.sims.len();
        let slot = self
            .ahead
            .get_mut(i)
            .ok_or_else(|| PyValueError::new_err(format!("no arm {i} of {n}")))?;
        Ahead::prepare(slot, seed, || {
            self.blank.build_ahead(seed, format!("trn-arm-{i}-ahead"))
        });
        Ok(())
    }

    /// Arms whose next episode is built and waiting for their reset.
    #[getter]
    fn ready_ahead(&self) -> usize {
        self.ahead.iter().flatten().filter(|a| a.is_ready()).count()
    }

    /// Resets so far that took an episode built ahead.
    #[getter]
    fn resets_built_ahead(&self) -> u64 {
        self.taken.load(Ordering::Relaxed)
    }

    /// Every arm's last reading as `Arm.observation_clipped(bounds)` gives one, arm after
    /// arm in each of the three. One call for the vector environment's step, which makes
    /// its observation with numpy's `frombuffer`.
    fn observation_batch<'py>(&self, py: Python<'py>, bounds: [f32; 4]) -> ObservationArrays<'py> {
        let mut obs = ObservationBytes::default();
        for i in 0..self.sims.len() {
            arm(&self.sims, i).observation_into(&Bounds(bounds), &mut obs);
        }
        obs.into_py(py)
    }

    /// The info's keys in order, each with its kind and the values it has an arm: `(key,
    /// kind, values)`, the kinds as [`ArmVec::info_batch`] lays them out. The same for
    /// every step of an `ArmVec`.
    fn info_layout(&self) -> Vec<(&'static str, &'static str, usize)> {
        use crate::arm::InfoValue::*;
        arm(&self.sims, 0)
            .info_values()
            .into_iter()
            .map(|(key, v)| match v {
                Scalar(_) => (key, "float", 1),
                Maybe(_) => (key, "maybe", 1),
                Floats(v) => (key, "floats", v.len()),
                Points(v) => (key, "points", v.len()),
                Flags(v) => (key, "flags", v.len()),
                Count(_) => (key, "count", 1),
            })
            .collect()
    }

    /// Every arm's info, in three native-endian buffers and the Nones: `(floats, flags,
    /// counts, first_none)`. Key by key in the info's order (`info_layout`), each key's
    /// values arm after arm go to the buffer of its kind: `"float"`, `"floats"`, `"points"`
    /// and `"maybe"` (NaN for None) to `floats` (float64), `"flags"` to `flags` (bool),
    /// `"count"` to `counts` (int64); `first_none` has a byte a key, 1 where the first arm's
    /// value is None. One call for the vector environment's step, which makes Gymnasium's
    /// batched infos of it with numpy's `frombuffer` (`trn_softarm.env._InfoBatch`).
    fn info_batch<'py>(
        &self,
        py: Python<'py>,
    ) -> (
        Bound<'py, PyByteArray>,
        Bound<'py, PyByteArray>,
        Bound<'py, PyByteArray>,
        Bound<'py, PyBytes>,
    ) {
        use crate::arm::InfoValue::*;
        let arms: Vec<_> = (0..self.sims.len())
            .map(|i| arm(&self.sims, i).info_values())
            .collect();
        let (mut floats, mut flags, mut counts, mut nones) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for (k, (_, first)) in arms[0].iter().enumerate() {
            for arm in &arms {
                match &arm[k].1 {
                    Scalar(x) => floats.extend(x.to_ne_bytes()),
                    Maybe(x) => floats.extend(x.unwrap_or(f64::NAN).to_ne_bytes()),
                    Floats(v) | Points(v) => v.iter().for_each(|x| floats.extend(x.to_ne_bytes())),
                    Flags(v) => flags.extend(v.iter().map(|&b| u8::from(b))),
                    Count(n) => counts.extend((*n as i64).to_ne_bytes()),
                }
            }
            nones.push(u8::from(matches!(first, Maybe(None))));
        }
        (
            PyByteArray::new(py, &floats),
            PyByteArray::new(py, &flags),
            PyByteArray::new(py, &counts),
            PyBytes::new(py, &nones),
        )
    }

    /// Arm `i`'s info, as `Arm.info()` gives it.
    fn info<'py>(&self, py: Python<'py>, i: usize) -> PyResult<Bound<'py, PyDict>> {
        if i >= self.sims.len() {
            return Err(PyValueError::new_err(format!("no arm {i}")));
        }
        let sim = arm(&self.sims, i);
        sim.info(py)
    }
}

impl ArmVec {
    /// Arm `i` reset from `seeds[i]` (taking the episode built ahead for it) or moved by
    /// `actions[i]`, every arm at once on the crew with the GIL released (`seeds` and
    /// `actions` one an arm).
    fn run_work(
        &mut self,
        py: Python<'_>,
        seeds: Vec<Option<u64>>,
        actions: Vec<Option<Vec<f32>>>,
    ) -> PyResult<()> {
        let work: Vec<Mutex<Option<Work>>> = seeds
            .into_iter()
            .zip(actions)
            .enumerate()
            .map(|(i, (s, a))| match (s, a) {
                (Some(seed), _) => {
                    // an episode built ahead for another seed is not this one: dropped
                    // (its thread ends on its own)
                    let ahead = self.ahead.get_mut(i).and_then(|a| a.take());
                    Some(Work::Reset(seed, ahead))
                }
                (None, Some(a)) => Some(Work::Step(a)),
                (None, None) => None,
            })
            .map(Mutex::new)
            .collect();
        let (sims, taken) = (self.sims.clone(), self.taken.clone());
        let n = sims.len();
        let task = Arc::new(move |i: usize| {
            let w = work[i].lock().unwrap_or_else(|p| p.into_inner()).take();
            match w {
                Some(Work::Reset(seed, ahead)) => {
                    let took = arm(&sims, i).reset_taking(seed, ahead)?;
                    taken.fetch_add(u64::from(took), Ordering::Relaxed);
                    Ok(())
                }
                Some(Work::Step(a)) => arm(&sims, i).step(&a),
                None => Ok(()),
            }
        });
        let crew = &mut self.crew;
        py.detach(|| crew.run(n, task)).map_err(value_err)
    }
}
