//! Study files: a study described in TOML (`studies/compare.toml`, `studies/sweep.toml`, or
//! a researcher's own), turned into a [`Study`].
//!
//! ```toml
//! name = "hysteresis"             # the study's name (its run folder, its JSON)
//! table = "sweep"                 # the table: compare (the default) or sweep
//! seeds = { first = 100, count = 5 }   # or a list: seeds = [100, 103, 107]
//!
//! [base]                          # what every configuration starts from
//! plant = "ideal"                 # a built-in plant or a sim.toml file (relative to this file)
//! trials = 300                    # the evaluation's size: trials, eval_targets, grasps,
//! eval_targets = 100              # fine_moves, snapshot_every, snapshot_targets,
//! grasps = 50                     # snapshot_grasps, learn_trials
//!
//! [[row]]                         # the table's rows (none: one row, the base)
//! name = "project"                # its name in the table
//! key = "project"                 # for --configs (default: the name as a file name)
//! preset = "project"              # preset, ablation, law, and any key of [base]
//! set = { "realism.load_width_gain" = 0.0 }   # plant keys: any key of sim.toml
//! controller = { "*.map_step" = 0.7 }  # controller keys: any field of the configuration
//! copy = { from = "realistic", keys = ["realism.creep_fraction"] }  # keys of another plant
//!
//! [[axis]]                        # a grid axis: every row is crossed with every value
//! key = "joints.*.hysteresis_width"   # a plant key, `controller.` and a controller key,
//!                                     # or preset, ablation, law, plant, trials...
//! values = [0.05, 0.15, 0.25]
//! ```
//!
//! A plant key is a dotted path into sim.toml: a table's key (`realism.load_width_gain`),
//! an element of a list by its index (`joints.1.damping_ratio`) or every element (`*`). A
//! configuration's layers apply in order (base, row, then each axis): a later plant name
//! replaces the plant, then every `copy` and every `set` applies in that order; the result
//! is validated by the simulator's own validation ([`SimConfig::validate`]), and an error
//! names the configuration and the key.
//!
//! A controller key is a dotted path into the controller's configuration as the profile
//! (preset, ablation, law) builds it for the plant's images (`trn_controller::Config`:
//! `stage1.trial_secant`, `stage2.j.eps`; `*` for every entry that has the rest of the path:
//! `*.map_step` sets both stages). A configuration with controller keys runs in process on
//! that configuration (a tuning run: no checkpoints or tables), recorded in its report's
//! specification.

use std::path::{Path, PathBuf};

use serde::Deserialize;
use toml::Value;
use trn_bench::spec::ControllerChoice;
use trn_controller::presets::{Ablation, Preset};
use trn_plant::SimConfig;

use super::keys::{get, set, CONTROLLER, PLANT};
use super::{slug, PlantFile, Row, Study, Table};
use trn_bench::spec::{Command, RunSpec};
use trn_bench::{io, LabError, Result};

/// A study file as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudyFile {
    /// The study's name.
    pub name: String,
    /// Its table.
    #[serde(default)]
    pub table: Table,
    /// Its seeds.
    pub seeds: Seeds,
    /// What every configuration starts from.
    #[serde(default)]
    pub base: Settings,
    /// The rows.
    #[serde(default, rename = "row")]
    pub rows: Vec<Settings>,
    /// The grid's axes.
    #[serde(default, rename = "axis")]
    pub axes: Vec<Axis>,
}

/// The seeds of a study.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(untagged)]
pub enum Seeds {
    /// `first .. first + count`.
    Range {
        /// The first seed.
        first: u64,
        /// How many.
        count: u64,
    },
    /// These seeds.
    List(Vec<u64>),
}

impl Seeds {
    /// The seeds, in order.
    pub fn list(&self) -> Vec<u64> {
        match self {
            Seeds::Range { first, count } => (*first..first.saturating_add(*count)).collect(),
            Seeds::List(l) => l.clone(),
        }
    }
}

/// What a layer of a configuration sets (the base, a row, an axis value); each key optional.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Settings {
    /// The row's name in the table (rows only).
    pub name: Option<String>,
    /// The row's key for `--configs` (rows only).
    pub key: Option<String>,
    /// The plant: a built-in name or a sim.toml file.
    pub plant: Option<String>,
    /// Controller preset.
    pub preset: Option<Preset>,
    /// Ablation.
    pub ablation: Option<Ablation>,
    /// Control law.
    pub law: Option<ControllerChoice>,
    /// Training trials per network.
    pub trials: Option<usize>,
    /// Held-out targets per network.
    pub eval_targets: Option<usize>,
    /// Grasps.
    pub grasps: Option<usize>,
    /// Fine moves of the fixed budget (at most 31).
    pub fine_moves: Option<u8>,
    /// A snapshot every this many training trials (0: none).
    pub snapshot_every: Option<usize>,
    /// Held-out targets per network in a snapshot.
    pub snapshot_targets: Option<usize>,
    /// Grasps in a snapshot.
    pub snapshot_grasps: Option<usize>,
    /// Learning stops after this many training trials.
    pub learn_trials: Option<usize>,
    /// Keys taken from another plant.
    pub copy: Option<CopyKeys>,
    /// Plant keys and their values.
    #[serde(default)]
    pub set: toml::Table,
    /// Controller keys and their values.
    #[serde(default)]
    pub controller: toml::Table,
}

/// Plant keys taken from another plant (`copy = { from = "realistic", keys = [...] }`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CopyKeys {
    /// The plant they come from.
    pub from: String,
    /// The keys.
    pub keys: Vec<String>,
}

/// A grid axis.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Axis {
    /// A plant key, a controller key after `controller.`, or a setting (`preset`, `ablation`,
    /// `law`, `plant`, `trials`, ...).
    pub key: String,
    /// Its name in row names (default: the key).
    pub name: Option<String>,
    /// Its values.
    pub values: Vec<Value>,
}

/// The settings an axis may name besides plant keys.
/// The most runs a study makes (configurations times seeds): far more than any study runs
/// in days, few enough that the runs' list fits in memory.
pub const MAX_RUNS: u64 = 100_000;

const SETTINGS: [&str; 12] = [
    "plant",
    "preset",
    "ablation",
    "law",
    "trials",
    "eval_targets",
    "grasps",
    "fine_moves",
    "snapshot_every",
    "snapshot_targets",
    "snapshot_grasps",
    "learn_trials",
];

/// What the command line changes in a study file.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Overrides {
    /// Only these rows (their keys, or configurations' keys).
    pub configs: Vec<String>,
    /// Seeds `first .. first + N` instead of the file's count.
    pub seeds: Option<u64>,
    /// The first seed instead of the file's: seeds `F .. F + N` (N from `seeds`, else the
    /// file's count or its list's length), so that rows tuned on some seeds are reported on
    /// others from the same file.
    pub first_seed: Option<u64>,
    /// The base's plant, trials, held-out targets and grasps.
    pub plant: Option<String>,
    /// Training trials per network of the base (rows that set their own keep theirs).
    pub trials: Option<usize>,
    /// Held-out targets per network of the base.
    pub eval_targets: Option<usize>,
    /// Grasps of the base.
    pub grasps: Option<usize>,
    /// How every run's camera processor reads the lights (the plant key `vision`, set on
    /// the base: a row that sets its own keeps it).
    pub vision: Option<trn_plant::Vision>,
}

impl StudyFile {
    /// Parses a study file's text; `origin` names it in errors.
    pub fn parse(text: &str, origin: &str) -> Result<StudyFile> {
        toml::from_str(text).map_err(|e| LabError::Usage(format!("study {origin}: {e}")))
    }

    /// Reads a study file.
    pub fn read(path: &Path) -> Result<StudyFile> {
        let mut text = String::new();
        std::io::Read::read_to_string(
            &mut trn_plant::input::open(path).map_err(io(path))?,
            &mut text,
        )
        .map_err(io(path))?;
        StudyFile::parse(&text, &path.display().to_string())
    }

    /// The study, with `over` applied; plant files named in it are relative to `dir`. A
    /// configuration whose plant no built-in name or file describes (keys set or copied),
    /// and with the sweep's table every configuration, has its plant named
    /// `plants/KEY.toml` (the runs name that file; [`Study::write_plants`] writes it, as
    /// running the study does), so each row can be run again alone with `--config`.
    pub fn study(&self, dir: &Path, over: &Overrides, plants: Option<&Path>) -> Result<Study> {
        self.study_unless(dir, over, plants, &|| false)
    }

    /// [`StudyFile::study`], asking `stop` before each configuration is made (a study of
    /// 100,000 takes seconds to build): when it says stop, [`LabError::Interrupted`].
    pub fn study_unless(
        &self,
        dir: &Path,
        over: &Overrides,
        plants: Option<&Path>,
        stop: &dyn Fn() -> bool,
    ) -> Result<Study> {
        let mut base = self.base.clone();
        base.plant = over.plant.clone().or(base.plant);
        base.trials = over.trials.or(base.trials);
        base.eval_targets = over.eval_targets.or(base.eval_targets);
        base.grasps = over.grasps.or(base.grasps);
        if let Some(v) = over.vision {
            let v = toml::Value::try_from(v).map_err(|e| LabError::Usage(e.to_string()))?;
            base.set.insert("vision".into(), v);
        }
        if slug(&self.name).is_empty() {
            return Err(LabError::Usage(format!(
                "study name {:?}: a study's name needs a letter or digit (it names the run \
                 folder and the files)",
                self.name
            )));
        }
        let configs = self.configurations(over, stop)?;
        // counted before any seed or run is made: a huge count is refused, not allocated
        let seed_count = match (&self.seeds, over.seeds) {
            (Seeds::Range { .. }, Some(n)) => n,
            (Seeds::List(l), Some(n)) => n.min(l.len() as u64),
            (Seeds::Range { count, .. }, None) => *count,
            (Seeds::List(l), None) => l.len() as u64,
        };
        let run_count = seed_count.saturating_mul(configs.len() as u64);
        if run_count > MAX_RUNS {
            return Err(LabError::Usage(format!(
                "study {}: {} configurations x {seed_count} seeds is {run_count} runs, more \
                 than a study runs ({MAX_RUNS} at most): fewer seeds or configurations",
                self.name,
                configs.len()
            )));
        }
        if let Some(first) = over.first_seed {
            if first.checked_add(seed_count).is_none() {
                return Err(LabError::Usage(format!(
                    "study {}: {seed_count} seeds from {first} pass the largest seed ({})",
                    self.name,
                    u64::MAX
                )));
            }
        }
        let seeds = match (&self.seeds, over.seeds, over.first_seed) {
            (_, _, Some(first)) => Seeds::Range {
                first,
                count: seed_count,
            }
            .list(),
            (Seeds::Range { first, .. }, Some(n), None) => Seeds::Range {
                first: *first,
                count: n,
            }
            .list(),
            (Seeds::List(l), Some(n), None) => l.iter().copied().take(n as usize).collect(),
            (s, None, None) => s.list(),
        };
        let mut runs = vec![];
        let mut files = vec![];
        for c in configs {
            if stop() {
                return Err(LabError::Interrupted("the study was being built"));
            }
            let mut layers = vec![&base];
            layers.extend(c.layers.iter());
            let (mut spec, changed) = resolve(&layers, dir).map_err(|e| {
                LabError::Usage(format!("study {}, {}: {e}", self.name, c.row.name))
            })?;
            if let Some(out) = plants.filter(|_| changed || self.table == Table::Sweep) {
                let path = out.join(format!("{}.toml", slug(&c.row.name)));
                spec.plant_name = Some(path.display().to_string());
                files.push(PlantFile {
                    path,
                    plant: spec.plant.clone(),
                });
            }
            for &seed in &seeds {
                runs.push((
                    c.row.clone(),
                    RunSpec {
                        seed,
                        ..spec.clone()
                    },
                ));
            }
        }
        let mut study = Study::new(&self.name, self.table, None, runs);
        study.plants = files;
        Ok(study)
    }

    /// The configurations: every row (of `over.configs`) crossed with every axis value.
    fn configurations(
        &self,
        over: &Overrides,
        stop: &dyn Fn() -> bool,
    ) -> Result<Vec<Configuration>> {
        let implicit = [Settings::default()];
        let rows: &[Settings] = if self.rows.is_empty() {
            &implicit
        } else {
            &self.rows
        };
        let mut configs: Vec<Configuration> = rows
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let name =
                    r.name
                        .clone()
                        .or(r.key.clone())
                        .unwrap_or_else(|| match self.rows.len() {
                            0 => String::new(),
                            _ => format!("row {}", i + 1),
                        });
                let key = r.key.clone().unwrap_or_else(|| slug(&name));
                Configuration {
                    row: Row { name, key },
                    layers: vec![r.clone()],
                }
            })
            .collect();
        for axis in &self.axes {
            let label = axis.name.clone().unwrap_or_else(|| axis.key.clone());
            let grid = (configs.len() as u64).saturating_mul(axis.values.len() as u64);
            if grid > MAX_RUNS {
                return Err(LabError::Usage(format!(
                    "study {}: axis {} makes {grid} configurations, more than a study runs \
                     ({MAX_RUNS} runs at most)",
                    self.name, axis.key
                )));
            }
            let mut next = vec![];
            for c in &configs {
                if stop() {
                    return Err(LabError::Interrupted("the study was being built"));
                }
                for v in &axis.values {
                    let layer = axis_layer(&axis.key, v).map_err(|e| {
                        LabError::Usage(format!("study {}: axis {}: {e}", self.name, axis.key))
                    })?;
                    let shown = match v {
                        Value::String(s) => s.clone(),
                        other => other.to_string(),
                    };
                    let part = format!("{label} {shown}");
                    let mut c = c.clone();
                    c.row.name = [c.row.name.as_str(), part.as_str()]
                        .into_iter()
                        .filter(|s| !s.is_empty())
                        .collect::<Vec<_>>()
                        .join(", ");
                    c.row.key = slug(&format!("{} {} {}", c.row.key, slug(&label), shown));
                    c.layers.push(layer);
                    next.push(c);
                }
            }
            configs = next;
        }
        for c in &mut configs {
            if c.row.name.is_empty() {
                c.row.name = self.name.clone();
                c.row.key = slug(&self.name);
            }
        }
        self.distinct(&configs)?;
        if over.configs.is_empty() {
            return Ok(configs);
        }
        let mut rows: Vec<&str> = configs
            .iter()
            .map(|c| c.row.key.as_str())
            .take(20)
            .collect();
        if configs.len() > rows.len() {
            rows.push("...");
        }
        if let Some(bad) = over.configs.iter().find(|k| {
            !configs
                .iter()
                .any(|c| &c.row.key == *k || c.layers[0].key.as_deref() == Some(k.as_str()))
        }) {
            return Err(LabError::Usage(format!(
                "--configs: study {} has no configuration {bad:?} (its rows: {})",
                self.name,
                rows.join(", ")
            )));
        }
        configs.retain(|c| {
            over.configs
                .iter()
                .any(|k| &c.row.key == k || c.layers[0].key.as_deref() == Some(k.as_str()))
        });
        Ok(configs)
    }
}

/// What of a configuration must differ from every other's.
type Label = fn(&Configuration) -> String;

impl StudyFile {
    /// Refuses two configurations with the same name, key or plant file name (their
    /// results would be pooled into one table row, one plant file written for both), naming
    /// both (rows by number, or grid configurations by number when the study has axes).
    fn distinct(&self, configs: &[Configuration]) -> Result<()> {
        let what = if self.axes.is_empty() {
            "rows"
        } else {
            "configurations"
        };
        let checks: [(&str, Label); 3] = [
            ("name", |c| c.row.name.clone()),
            ("key", |c| c.row.key.clone()),
            ("plant file name", |c| format!("{}.toml", slug(&c.row.name))),
        ];
        for (label, of) in checks {
            let mut seen = std::collections::HashMap::new();
            for (i, c) in configs.iter().enumerate() {
                if let Some(first) = seen.insert(of(c), i) {
                    return Err(LabError::Usage(format!(
                        "study {}: {what} {} ({:?}) and {} ({:?}) have the same {label} {:?}: \
                         give each its own",
                        self.name,
                        first + 1,
                        configs[first].row.name,
                        i + 1,
                        c.row.name,
                        of(c)
                    )));
                }
            }
        }
        Ok(())
    }
}

/// A row crossed with axis values: its name and key, and its layers (row, then axes).
#[derive(Debug, Clone)]
struct Configuration {
    row: Row,
    layers: Vec<Settings>,
}

/// One axis value as a layer: a setting, a controller key (`controller.` first) or a plant
/// key.
fn axis_layer(key: &str, value: &Value) -> std::result::Result<Settings, String> {
    if let Some(key) = key.strip_prefix("controller.") {
        let mut controller = toml::Table::new();
        controller.insert(key.to_string(), value.clone());
        Ok(Settings {
            controller,
            ..Settings::default()
        })
    } else if SETTINGS.contains(&key) {
        let mut t = toml::Table::new();
        t.insert(key.to_string(), value.clone());
        Value::Table(t)
            .try_into()
            .map_err(|e: toml::de::Error| e.message().to_string())
    } else {
        let mut set = toml::Table::new();
        set.insert(key.to_string(), value.clone());
        Ok(Settings {
            set,
            ..Settings::default()
        })
    }
}

/// The run (seed 0) a configuration's layers describe, and whether its plant was changed by
/// keys (so no name describes it).
fn resolve(layers: &[&Settings], dir: &Path) -> std::result::Result<(RunSpec, bool), String> {
    let mut spec = RunSpec::new(Command::Train, 0);
    let last = |f: &dyn Fn(&Settings) -> Option<usize>| layers.iter().rev().find_map(|l| f(l));
    if let Some(name) = layers.iter().rev().find_map(|l| l.plant.as_deref()) {
        let (path, named) = plant_path(name, dir);
        spec.plant = SimConfig::resolve(Some(&path)).map_err(|e| e.to_string())?;
        spec.plant_name = Some(named);
    }
    let mut tree = Value::try_from(&spec.plant).map_err(|e| e.to_string())?;
    let mut changed = false;
    for l in layers {
        if let Some(c) = &l.copy {
            let (path, _) = plant_path(&c.from, dir);
            let from = SimConfig::resolve(Some(&path)).map_err(|e| e.to_string())?;
            let from = Value::try_from(&from).map_err(|e| e.to_string())?;
            for key in &c.keys {
                let v = get(&from, key)?;
                set(&mut tree, PLANT, key, &v)?;
                changed = true;
            }
        }
    }
    for l in layers {
        for (key, v) in &l.set {
            set(&mut tree, PLANT, key, v)?;
            changed = true;
        }
    }
    if changed {
        let plant: SimConfig = tree
            .try_into()
            .map_err(|e: toml::de::Error| format!("plant keys: {}", e.message()))?;
        plant.validate().map_err(|e| e.to_string())?;
        spec.plant = plant;
    }
    for l in layers {
        spec.profile.preset = l.preset.unwrap_or(spec.profile.preset);
        spec.profile.ablation = l.ablation.unwrap_or(spec.profile.ablation);
        spec.profile.law = l.law.unwrap_or(spec.profile.law);
        spec.plan.fine_moves = l.fine_moves.unwrap_or(spec.plan.fine_moves);
        spec.plan.learn_trials = l.learn_trials.or(spec.plan.learn_trials);
    }
    if layers.iter().any(|l| !l.controller.is_empty()) {
        let mut tree = Value::try_from(spec.profile_config()).map_err(|e| e.to_string())?;
        for (key, v) in layers.iter().flat_map(|l| &l.controller) {
            set(&mut tree, CONTROLLER, key, v)?;
        }
        let config: trn_controller::Config = tree
            .try_into()
            .map_err(|e: toml::de::Error| format!("controller keys: {}", e.message()))?;
        spec.controller_override = Some(config);
    }
    let p = &mut spec.plan;
    p.trials = last(&|l| l.trials).unwrap_or(p.trials);
    p.eval_targets = last(&|l| l.eval_targets).unwrap_or(p.eval_targets);
    p.grasps = last(&|l| l.grasps).unwrap_or(p.grasps);
    p.snapshot_every = last(&|l| l.snapshot_every).unwrap_or(p.snapshot_every);
    p.snapshot_targets = last(&|l| l.snapshot_targets).unwrap_or(p.snapshot_targets);
    p.snapshot_grasps = last(&|l| l.snapshot_grasps).unwrap_or(p.snapshot_grasps);
    if let Some(n) = last(&|l| l.snapshot_targets).filter(|&n| n > p.eval_targets) {
        return Err(format!(
            "snapshot_targets {n} is more than eval_targets {} (a snapshot evaluates the first of the held-out targets)",
            p.eval_targets
        ));
    }
    if p.fine_moves > 31 {
        return Err(format!("fine_moves {} (at most 31)", p.fine_moves));
    }
    spec.check().map_err(|e| e.to_string())?;
    Ok((spec, changed))
}

/// Where a plant name points: a file beside the study file if there is one, else the name
/// as `--config` takes it (a built-in name, or a path).
fn plant_path(name: &str, dir: &Path) -> (PathBuf, String) {
    let beside = dir.join(name);
    if Path::new(name).is_relative() && beside.exists() {
        let shown = beside.display().to_string();
        return (beside, shown);
    }
    (PathBuf::from(name), name.to_string())
}
