//! [`ArmVec`]: `n` simulated arms stepped in one call, on rayon's pool with the GIL
//! released (the native vector environment's core), with each arm's next episode built
//! ahead of its reset on a thread of the lowest priority.
//!
//! An episode's reset is the costliest thing an arm does (the plant built, the target's twin
//! moved along its path, the start move: about four moves' time), and a vector step waits
//! for its slowest arm: an arm that resets holds the other arms' threads idle for most of
//! the step. When the next episode's seed is known ahead ([`ArmVec::prepare`]) and the arm
//! does not carry its plant over (`persistent`), that episode is built at once, on a thread
//! of its own at the lowest priority, from an untouched copy of the arm: the cores' idle
//! time (the Python layer between steps, the arms that finish early) builds it, and the
//! reset takes it ready. An arm built from a copy is the arm the reset would build, bit for
//! bit: a reset that does not carry the plant over keeps nothing of the episode before.

use std::sync::atomic::{AtomicU64, Ordering};
use std::thread::JoinHandle;

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyByteArray, PyDict, PyList};
use rayon::prelude::*;

use crate::arm::{resolve, value_err, Options, Sim};

/// `n` arms of one configuration stepped together: every call runs the arms on a thread
/// pool with the GIL released (rayon's, as many threads as cores). Arm `i` is reset or
/// stepped exactly as an [`crate::arm::Arm`] would be with the same seeds and actions.
#[pyclass(module = "trn_softarm._native")]
pub struct ArmVec {
    sims: Vec<Sim>,
    /// An arm as built, not reset: what each episode built ahead starts from.
    blank: Sim,
    /// Each arm's next episode, being built (see the module).
    ahead: Vec<Option<Ahead>>,
    /// Resets that took an episode built ahead.
    taken: AtomicU64,
}

/// An episode built ahead: its seed and the thread building it.
struct Ahead {
    seed: u64,
    job: JoinHandle<Result<Sim, String>>,
}

/// What one arm of an [`ArmVec`] does in a call.
enum Work {
    /// A reset, with the episode built ahead for this seed if there is one.
    Reset(u64, Option<Ahead>),
    Step(Vec<f32>),
}

/// Runs `f` on every arm whose `work` is `Some`, in parallel, and returns the first error
/// (`work` has one entry an arm).
fn run_all<W: Send>(
    py: Python<'_>,
    sims: &mut [Sim],
    work: Vec<Option<W>>,
    f: impl Fn(&mut Sim, W) -> Result<(), String> + Sync,
) -> PyResult<()> {
    py.detach(|| {
        sims.par_iter_mut()
            .zip(work.into_par_iter())
            .map(|(s, w)| match w {
                Some(w) => f(s, w),
                None => Ok(()),
            })
            .collect::<Result<Vec<()>, String>>()
    })
    .map(|_| ())
    .map_err(value_err)
}

/// Lowers the calling thread's priority to the least (nice 19; on Linux a thread's nice
/// value is its own), so that building ahead takes mostly what the arms and the Python layer
/// leave idle. (The idle scheduling class, `SCHED_IDLE`, measured no faster.)
fn lowest_priority() {
    #[cfg(target_os = "linux")]
    // SAFETY: setpriority reads no memory of ours; `who = 0` is the calling thread. A
    // failure leaves the priority as it was, which is harmless.
    unsafe {
        libc::setpriority(libc::PRIO_PROCESS, 0, 19);
    }
}

/// The reset of `sim` to `seed`: the episode built ahead for it when its thread has
/// finished, else the reset here (a thread of the lowest priority may wait long for a core
/// on a busy machine; it ends on its own).
fn reset(sim: &mut Sim, seed: u64, ahead: Option<Ahead>, taken: &AtomicU64) -> Result<(), String> {
    if let Some(a) = ahead.filter(|a| a.job.is_finished()) {
        if let Ok(Ok(ready)) = a.job.join() {
            *sim = ready;
            taken.fetch_add(1, Ordering::Relaxed);
            return Ok(());
        }
    }
    // none, not ready, or its thread failed (it panicked, or the reset is an error that
    // this one reports)
    sim.reset(seed)
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
            sims: vec![sim.clone(); n],
            blank: sim,
            ahead: (0..n).map(|_| None).collect(),
            taken: AtomicU64::new(0),
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
        let work: Vec<Option<Work>> = seeds
            .into_iter()
            .zip(actions)
            .enumerate()
            .map(|(i, (s, a))| match (s, a) {
                (Some(seed), _) => {
                    // an episode built ahead for another seed is not this one: dropped
                    // (its thread ends on its own)
                    let ahead = self.ahead.get_mut(i).and_then(|a| a.take());
                    let ahead = ahead.filter(|a| a.seed == seed);
                    Some(Work::Reset(seed, ahead))
                }
                (None, Some(a)) => Some(Work::Step(a)),
                (None, None) => None,
            })
            .collect();
        let taken = &self.taken;
        run_all(py, &mut self.sims, work, |sim, w| match w {
            Work::Reset(seed, ahead) => reset(sim, seed, ahead, taken),
            Work::Step(a) => sim.step(&a),
        })
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
        if !self.blank.resets_afresh() || matches!(slot, Some(a) if a.seed == seed) {
            return Ok(());
        }
        let mut sim = self.blank.clone();
        let job = std::thread::Builder::new()
            .name(format!("trn-arm-{i}-ahead"))
            .spawn(move || {
                lowest_priority();
                sim.reset(seed).map(|()| sim)
            });
        // a thread that cannot be had builds nothing ahead: the reset builds the episode
        *slot = job.ok().map(|job| Ahead { seed, job });
        Ok(())
    }

    /// Arms whose next episode is built and waiting for their reset.
    #[getter]
    fn ready_ahead(&self) -> usize {
        self.ahead
            .iter()
            .flatten()
            .filter(|a| a.job.is_finished())
            .count()
    }

    /// Resets so far that took an episode built ahead.
    #[getter]
    fn resets_built_ahead(&self) -> u64 {
        self.taken.load(Ordering::Relaxed)
    }

    /// Every arm's last reading, as `Arm.observation()` gives one, concatenated as
    /// native-endian bytes: pixels (float32), status codes (uint8), targets (float32). One call for the vector
    /// environment's step, which makes its observation with numpy's `frombuffer`.
    fn observation_batch<'py>(
        &self,
        py: Python<'py>,
    ) -> (
        Bound<'py, PyByteArray>,
        Bound<'py, PyByteArray>,
        Bound<'py, PyByteArray>,
    ) {
        let (mut xy, mut st, mut tg) = (Vec::new(), Vec::new(), Vec::new());
        for s in &self.sims {
            let (lights, status, target) = s.observation();
            xy.extend(lights.iter().flat_map(|&x| (x as f32).to_ne_bytes()));
            st.extend_from_slice(status);
            tg.extend(target.iter().flat_map(|&x| (x as f32).to_ne_bytes()));
        }
        (
            PyByteArray::new(py, &xy),
            PyByteArray::new(py, &st),
            PyByteArray::new(py, &tg),
        )
    }

    /// Every arm's info, key by key in the info's order: `(key, kind, data, first_none)`,
    /// `data` the arms' values one after the other as native-endian bytes (`"float"`,
    /// `"floats"`, `"points"`: float64, `"maybe"`: float64 with NaN for None, `"flags"`:
    /// bool, `"count"`: int64), `first_none` whether the first arm's value is None. One
    /// call for the vector environment's step, which makes Gymnasium's batched infos of
    /// it with numpy's `frombuffer` (`trn_softarm.env._Layout.batch_infos`).
    fn info_batch<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        use crate::arm::InfoValue::*;
        let arms: Vec<_> = self.sims.iter().map(|s| s.info_values()).collect();
        let out = PyList::empty(py);
        for (k, (key, first)) in arms[0].iter().enumerate() {
            let kind = match first {
                Scalar(_) => "float",
                Maybe(_) => "maybe",
                Floats(_) => "floats",
                Points(_) => "points",
                Flags(_) => "flags",
                Count(_) => "count",
            };
            let mut data = Vec::new();
            for arm in &arms {
                match &arm[k].1 {
                    Scalar(x) => data.extend(x.to_ne_bytes()),
                    Maybe(x) => data.extend(x.unwrap_or(f64::NAN).to_ne_bytes()),
                    Floats(v) | Points(v) => v.iter().for_each(|x| data.extend(x.to_ne_bytes())),
                    Flags(v) => data.extend(v.iter().map(|&b| u8::from(b))),
                    Count(n) => data.extend((*n as i64).to_ne_bytes()),
                }
            }
            let first_none = matches!(first, Maybe(None));
            out.append((*key, kind, PyByteArray::new(py, &data), first_none))?;
        }
        Ok(out)
    }

    /// Arm `i`'s info, as `Arm.info()` gives it.
    fn info<'py>(&self, py: Python<'py>, i: usize) -> PyResult<Bound<'py, PyDict>> {
        self.sims
            .get(i)
            .ok_or_else(|| PyValueError::new_err(format!("no arm {i}")))?
            .info(py)
    }
}
