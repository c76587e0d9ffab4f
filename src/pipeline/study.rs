//! Studies: one scenario over a grid of record lengths × sample intervals × sensor noise
//! levels × seeds, every method on the same samples of each item, one row of results per
//! item and method (docs/studies.md). Items are independent and their seeds derive from the study's seed
//! and the item alone, so any split into shards gives the same rows; each item's rows are
//! written atomically into its own file, so a re-run skips what is done and `merge` can
//! gather the files of any set of shards.

use super::source::Input;
use super::{identify, Options, PipelineError};
use crate::ident::Arenas;
use crate::report::{Outcome, Report};
use crate::scenario::{Method, Scenario, ScenarioError};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub use crate::report::study_rows::{
    paired, summarize, Configuration, Item, Paired, ParameterSummary, Row, RowParameter, RowSelection,
    SelectionSummary, Summary,
};

/// A study file (TOML).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudyFile {
    /// The scenario, relative to the study file.
    pub scenario: PathBuf,
    /// Seeds per configuration.
    pub seeds: usize,
    /// The study's seed: every item's simulation seed derives from it and the item.
    #[serde(default)]
    pub seed: u64,
    /// Record lengths per trajectory (s); default the scenario's.
    #[serde(default)]
    pub record_lengths: Vec<f64>,
    /// Sample intervals (s); default the scenario's.
    #[serde(default)]
    pub sample_intervals: Vec<f64>,
    /// Sensor noise levels: the noise's std as a fraction of each channel's std, added to
    /// every displacement and velocity the log holds (`[measurement]` with relative noise,
    /// docs/measurement.md); every level of an item has the same motion, so the levels
    /// compare on the same samples. Default: the scenario's own measurement.
    #[serde(default)]
    pub noise_levels: Vec<f64>,
    /// Methods run on every item's samples; default the scenario's.
    #[serde(default)]
    pub methods: Vec<Method>,
    /// Overrides applied to the scenario first (`KEY=VALUE`, as `--set`).
    #[serde(default)]
    pub set: Vec<String>,
    /// The unmeasured disturbance's level, for a scenario with `[identify.disturbance]`
    /// (0 removes it; as `sweep` sets it).
    #[serde(default)]
    pub disturbance_level: Option<f64>,
    /// A method every other method is compared with on the same samples: per parameter the
    /// mean and spread of `(θ̂_method − θ̂_reference)`, in units of the reference's spread
    /// over the seeds (how far a method moves from the reference, e.g. an iteration from
    /// its step 0).
    #[serde(default)]
    pub reference: Option<String>,
    /// Estimate the integrator's bias on every item (docs/methods.md, "The integrator's
    /// bias"): each item simulated again at half the step on the same Brownian paths and
    /// identified alike; the rows carry every parameter's bias.
    #[serde(default)]
    pub integrator_bias: bool,
}

/// A study: the scenario with its base overrides, and the grid.
#[derive(Debug, Clone)]
pub struct Study {
    pub name: String,
    pub file: StudyFile,
    pub scenario: Scenario,
    /// SHA-256 of the study's keys (but the scenario's path) and the scenario's text: rows
    /// of another study are refused, whatever path spelling or comments either used.
    pub fingerprint: String,
    /// The large tables of an identification (lattices, cell arenas, the samples an item
    /// simulated in memory keeps for its later passes), handed from item to item: items of
    /// one study have the same size, and fresh pages cost a tenth of an item's time.
    arenas: Arc<Arenas>,
}

#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    #[error("{path}: {message}")]
    File { path: String, message: String },
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
}

/// SplitMix64: the item's seed from the study's seed and the item's coordinates.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl Study {
    pub fn from_file(path: &Path) -> Result<Study, StudyError> {
        let text = std::fs::read_to_string(path).map_err(|e| StudyError::File {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("study");
        Study::from_text(&text, path, name, path.parent().unwrap_or(Path::new(".")))
    }

    /// A study from its TOML `text` (`label` names it in errors; the scenario is relative
    /// to `base`): a file's, or the one `fpkbench study --scenario …` writes from its flags.
    pub fn from_text(text: &str, label: &Path, name: &str, base: &Path) -> Result<Study, StudyError> {
        let label = label.display().to_string();
        let fail = |message: String| StudyError::File {
            path: label.clone(),
            message,
        };
        let file: StudyFile = toml::from_str(text).map_err(|e| {
            let line = e.span().map_or(0, |s| text[..s.start].matches('\n').count() + 1);
            fail(format!("line {line}: {}", e.message()))
        })?;
        if file.seeds == 0 {
            return Err(fail("`seeds`: at least 1".into()));
        }
        if let Some(l) = file.disturbance_level {
            if !(l.is_finite() && l >= 0.0) {
                return Err(fail(format!("`disturbance_level`: {l} is not a level >= 0")));
            }
        }
        for (key, v) in [
            ("record_lengths", &file.record_lengths),
            ("sample_intervals", &file.sample_intervals),
        ] {
            if let Some(x) = v.iter().find(|x| !(x.is_finite() && **x > 0.0)) {
                return Err(fail(format!("`{key}`: {x} is not a positive number of seconds")));
            }
        }
        if let Some(x) = file
            .noise_levels
            .iter()
            .find(|x| !(x.is_finite() && (0.0..=10.0).contains(*x)))
        {
            return Err(fail(format!(
                "`noise_levels`: {x} is not a noise level in 0..=10 (the noise's std over the channel's: 0.1 = 10 %)"
            )));
        }
        let scenario_path = base.join(&file.scenario);
        let scenario = crate::io::scenario_file(&scenario_path, &file.set)?;
        let methods = if file.methods.is_empty() {
            scenario.identify.methods.clone()
        } else {
            file.methods.clone()
        };
        // Every configuration must be a valid scenario: checked before any work.
        let mut study = Study {
            name: name.to_string(),
            file: StudyFile { methods, ..file },
            scenario,
            fingerprint: String::new(),
            arenas: Arc::default(),
        };
        for item in study.items().iter().filter(|i| i.seed_index == 0) {
            study.scenario_of(item)?;
        }
        // From the content, not the spelling: the study's keys but the scenario's path
        // (sorted, comments and layout dropped) and the scenario's text.
        let mut keys: toml::Table = toml::from_str(text).map_err(|e| fail(e.message().to_string()))?;
        keys.remove("scenario");
        let canonical = toml::to_string(&keys).map_err(|e| fail(e.to_string()))?;
        use sha2::Digest;
        let mut h = sha2::Sha256::new();
        h.update(canonical.as_bytes());
        h.update([0]);
        h.update(study.scenario.source.as_bytes());
        study.fingerprint = h.finalize().iter().take(8).map(|b| format!("{b:02x}")).collect();
        Ok(study)
    }

    /// Every item, in a fixed order.
    pub fn items(&self) -> Vec<Item> {
        let sim = &self.scenario.simulation;
        let lengths = if self.file.record_lengths.is_empty() {
            vec![sim.record_length]
        } else {
            self.file.record_lengths.clone()
        };
        let intervals = if self.file.sample_intervals.is_empty() {
            vec![sim.sample_interval]
        } else {
            self.file.sample_intervals.clone()
        };
        let levels: Vec<Option<f64>> = if self.file.noise_levels.is_empty() {
            vec![None]
        } else {
            self.file.noise_levels.iter().copied().map(Some).collect()
        };
        let mut out = Vec::new();
        for &t in &lengths {
            for &h in &intervals {
                for &sensor_noise in &levels {
                    for s in 0..self.file.seeds {
                        // 63 bits: a scenario's seed is a TOML integer. Not of the noise
                        // level: every level measures the same motion.
                        let seed = mix(mix(mix(self.file.seed ^ t.to_bits()) ^ h.to_bits()) ^ s as u64) >> 1;
                        out.push(Item {
                            index: out.len(),
                            record_length: t,
                            sample_interval: h,
                            sensor_noise,
                            seed_index: s,
                            seed,
                            of: 0,
                        });
                    }
                }
            }
        }
        let n = out.len();
        for i in &mut out {
            i.of = n;
        }
        out
    }

    /// The scenario of one item (validated like `--set` overrides).
    pub fn scenario_of(&self, item: &Item) -> Result<Scenario, ScenarioError> {
        // Applied as overrides: the same checks as the file's (the interval a whole number of
        // steps, …), and the log records them.
        let name = &self.scenario.name;
        let mut sets = vec![
            format!("simulation.record_length={}", item.record_length),
            format!("simulation.sample_interval={}", item.sample_interval),
            format!("simulation.seed={}", item.seed),
        ];
        if let Some(level) = item.sensor_noise {
            sets.extend([
                "measurement.noise=\"relative\"".to_string(),
                format!("measurement.displacement={level:?}"),
                format!("measurement.velocity={level:?}"),
            ]);
        }
        let text = crate::scenario::overrides::apply(name, &self.scenario.source, &sets)?;
        let mut s = Scenario::parse(&text, &format!("{name} (item {})", item.key()), name)?;
        s.adopt_recordings(&self.scenario);
        Ok(match self.file.disturbance_level {
            Some(level) => s.with_disturbance_level(level),
            None => s,
        })
    }

    /// Run one item: simulate (into a log under `logs` if given, else straight into the
    /// estimators, twice) and identify with every method; its rows.
    pub fn run_item(&self, item: &Item, logs: Option<&Path>) -> Result<Vec<Row>, PipelineError> {
        let s = self
            .scenario_of(item)
            .map_err(|e| PipelineError::Study(e.to_string()))?;
        let options = Options {
            methods: self.file.methods.clone(),
            validate: false,
            plots: false,
            arenas: self.arenas.clone(),
            ..Options::default()
        };
        let start = std::time::Instant::now();
        let (report, simulate_s) = match logs {
            Some(dir) => {
                let log = dir.join(format!("{}.mcap", item.key()));
                let sim = super::simulate_log(&s, &log, Default::default(), &|_| {})?;
                (super::identify_log(&sim.log, &options)?, sim.seconds)
            }
            None => (
                identify(&Input::simulation_in(s.clone(), self.arenas.clone()), &options)?,
                0.0,
            ),
        };
        let mut report = report;
        if self.file.integrator_bias {
            report.integrator_bias = Some(super::integrator_bias(&s, &options, &report)?);
        }
        let total = start.elapsed().as_secs_f64();
        Ok(rows_of(&self.fingerprint, item, &report, simulate_s, total))
    }
}

fn rows_of(study: &str, item: &Item, r: &Report, simulate_s: f64, item_s: f64) -> Vec<Row> {
    r.methods
        .iter()
        .map(|m| Row {
            study: study.to_string(),
            item: *item,
            method: m.method.name(),
            outcome: m.outcome.kind(),
            samples: r.samples,
            error: m.outcome.error().or(m.outcome.not_applicable()).map(str::to_string),
            worst_rel_error: m.outcome.error().is_none().then_some(m.worst_rel_error),
            parameters: m
                .parameters
                .iter()
                .map(|p| RowParameter {
                    integrator_bias: r
                        .integrator_bias
                        .iter()
                        .flat_map(|b| &b.methods)
                        .filter(|b| b.method == m.method)
                        .flat_map(|b| &b.parameters)
                        .find(|b| b.name == p.name.to_string())
                        .map(|b| b.bias),
                    name: p.name.to_string(),
                    true_value: p.true_value,
                    estimate: p.estimate,
                    std_error: p.std_error.is_finite().then_some(p.std_error),
                    rel_error: p.rel_error,
                    covered: p.ci95.map(|[lo, hi]| lo <= p.true_value && p.true_value <= hi),
                    cramer_rao_std: p.cramer_rao_std,
                })
                .collect(),
            simulate_s,
            identify_s: m.seconds,
            item_s,
            // The inclusion frequencies are the selection's: its own model's rows carry them, a
            // compared model's (the baseline's, the declared terms) not.
            selection: (m.selected.as_ref()).and_then(|names| {
                RowSelection::of(r, names, !matches!(m.method, crate::scenario::ReportMethod::Compare(_)))
            }),
        })
        .collect()
}

impl Study {
    /// The rows of an item that could not be run (e.g. a diverging simulation): one per
    /// method, each `failed` with the reason.
    pub fn failed_rows(&self, item: &Item, why: &str) -> Vec<Row> {
        self.file
            .methods
            .iter()
            .map(|m| Row {
                study: self.fingerprint.clone(),
                item: *item,
                method: m.name().to_string(),
                outcome: Outcome::Failed,
                samples: 0,
                error: Some(why.to_string()),
                worst_rel_error: None,
                parameters: Vec::new(),
                simulate_s: 0.0,
                identify_s: 0.0,
                item_s: 0.0,
                selection: None,
            })
            .collect()
    }
}

/// The last line of a complete item file: how many rows precede it and their SHA-256.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Complete {
    complete: CompleteMark,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct CompleteMark {
    rows: usize,
    sha256: String,
}

fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::Digest;
    sha2::Sha256::digest(bytes).iter().map(|b| format!("{b:02x}")).collect()
}

/// An item file's text: one JSON row per line, then the completeness mark (the rows'
/// count and checksum), so a file cut short or edited is never taken as done.
pub fn item_text(rows: &[Row]) -> Result<String, serde_json::Error> {
    let mut text = String::new();
    for r in rows {
        text += &serde_json::to_string(r)?;
        text.push('\n');
    }
    let mark = Complete {
        complete: CompleteMark {
            rows: rows.len(),
            sha256: sha256_hex(text.as_bytes()),
        },
    };
    text += &serde_json::to_string(&mark)?;
    text.push('\n');
    Ok(text)
}

/// The rows of an item file, if it is complete: it ends with its completeness mark, whose
/// count and checksum match the rows before it. The error says what is wrong with it.
pub fn read_item(path: &Path) -> Result<Vec<Row>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("reading {}: {e}", path.display()))?;
    let body_end = text.trim_end_matches('\n').rfind('\n').map_or(0, |i| i + 1);
    let (body, last) = text.split_at(body_end);
    let mark: Complete = serde_json::from_str(last.trim()).map_err(|_| {
        format!(
            "{}: incomplete item file (no completeness mark at its end{})",
            path.display(),
            if text.is_empty() { "; it is empty" } else { "" }
        )
    })?;
    if sha256_hex(body.as_bytes()) != mark.complete.sha256 {
        return Err(format!(
            "{}: damaged item file (its rows do not match their checksum)",
            path.display()
        ));
    }
    let mut rows = Vec::new();
    for (n, line) in body.lines().enumerate().filter(|(_, l)| !l.trim().is_empty()) {
        rows.push(
            serde_json::from_str::<Row>(line)
                .map_err(|e| format!("{}: line {}: not a study row: {e}", path.display(), n + 1))?,
        );
    }
    if rows.len() != mark.complete.rows {
        return Err(format!(
            "{}: damaged item file ({} rows where its mark says {})",
            path.display(),
            rows.len(),
            mark.complete.rows
        ));
    }
    Ok(rows)
}

/// Whether the item file at `path` holds this study's item done: complete, of this study,
/// a row for every method, none failed. Otherwise why not (the item is run again).
pub fn item_done(study: &Study, path: &Path) -> Result<(), String> {
    if !path.exists() {
        return Err("not run yet".into());
    }
    let rows = read_item(path)?;
    if let Some(r) = rows.iter().find(|r| r.study != study.fingerprint) {
        return Err(format!("{}: rows of another study ({})", path.display(), r.study));
    }
    for m in &study.file.methods {
        match rows.iter().find(|r| r.method == m.name()) {
            None => return Err(format!("{}: no row for method {m}", path.display())),
            Some(r) if r.outcome == Outcome::Failed => {
                return Err(format!(
                    "{}: failed before ({})",
                    path.display(),
                    r.error.as_deref().unwrap_or("no reason")
                ))
            }
            Some(_) => {}
        }
    }
    Ok(())
}

/// The shard `(index, count)` from the flags or the scheduler's environment, refused
/// before any work when it cannot be known for sure:
/// - `--shard I/N` (resubmitting one piece by hand);
/// - a Slurm job array: the task's `SLURM_ARRAY_TASK_ID` is the index; the count is
///   `--shard-count N` if given (which keeps a resubmitted task, `sbatch --array=5`, shard
///   5 of N), else the array's size when it is `0-(N−1)` with step 1 (other shapes, such
///   as `0-4:2` or `0,1,5`, need `--shard-count`);
/// - a Kubernetes Indexed Job (`JOB_COMPLETION_INDEX`, with `--shard-count`);
/// - else `(0, 1)`, or `(0, N)` with `--shard-count N` alone refused as ambiguous.
pub fn shard_from(
    flag: Option<(usize, usize)>,
    count: Option<usize>,
    env: impl Fn(&str) -> Option<String>,
) -> Result<(usize, usize), String> {
    let num = |k: &str| -> Result<Option<usize>, String> {
        env(k)
            .map(|v| {
                v.parse::<usize>()
                    .map_err(|_| format!("{k}={v:?} is not a whole number"))
            })
            .transpose()
    };
    let (i, n) = if let Some(f) = flag {
        f
    } else if let Some(id) = num("SLURM_ARRAY_TASK_ID")? {
        let n = match count {
            Some(n) => n,
            None => {
                let min = num("SLURM_ARRAY_TASK_MIN")?;
                let max = num("SLURM_ARRAY_TASK_MAX")?;
                let tasks = num("SLURM_ARRAY_TASK_COUNT")?;
                let step = num("SLURM_ARRAY_TASK_STEP")?.unwrap_or(1);
                match (min, max, tasks) {
                    (Some(0), Some(max), Some(tasks)) if step == 1 && tasks == max + 1 => tasks,
                    _ => {
                        return Err(format!(
                            "the job array (tasks {}-{}, {} of them, step {step}) is not 0-(N-1) with step 1, so                              the study's shard count cannot be known from it (a resubmitted task, or an array with                              gaps): give --shard-count N, the count of the whole study's array",
                            min.map_or("?".into(), |v| v.to_string()),
                            max.map_or("?".into(), |v| v.to_string()),
                            tasks.map_or("?".into(), |v| v.to_string()),
                        ))
                    }
                }
            }
        };
        (id, n)
    } else if let Some(id) = num("JOB_COMPLETION_INDEX")? {
        let n = count.ok_or("JOB_COMPLETION_INDEX is set: give the job's completions with --shard-count")?;
        (id, n)
    } else if let Some(n) = count {
        return Err(format!(
            "--shard-count {n} without a scheduler's index (SLURM_ARRAY_TASK_ID or JOB_COMPLETION_INDEX):              give --shard I/{n} to run one shard by hand"
        ));
    } else {
        (0, 1)
    };
    if n == 0 || i >= n {
        return Err(format!("shard {i} of {n}: the index must be below the count"));
    }
    Ok((i, n))
}

/// Rows gathered from item files: duplicates of one item and method must agree exactly
/// (the same study run twice); a conflict or a row of another study is refused.
/// The items of the study that `rows` lack: the study's item count and the missing
/// items' numbers; `None` where the rows do not record the count (written before it was).
pub fn missing_items(rows: &[Row]) -> Option<(usize, Vec<usize>)> {
    let of = rows.iter().map(|r| r.item.of).max().filter(|&n| n > 0)?;
    let mut present = vec![false; of];
    for r in rows.iter().filter(|r| r.item.index < of) {
        present[r.item.index] = true;
    }
    Some((of, (0..of).filter(|&i| !present[i]).collect()))
}

/// `missing` item numbers as a short list: the first ten, then how many more.
pub fn item_list(missing: &[usize]) -> String {
    let shown: Vec<String> = missing.iter().take(10).map(|i| i.to_string()).collect();
    match missing.len() {
        n if n > 10 => format!("{}, … ({} more)", shown.join(", "), n - 10),
        _ => shown.join(", "),
    }
}

pub fn gather(files: &[PathBuf]) -> Result<Vec<Row>, String> {
    let mut rows: Vec<Row> = Vec::new();
    let mut study: Option<String> = None;
    let mut files_of: Vec<(String, &PathBuf)> = Vec::new();
    for f in files {
        for (n, row) in read_item(f)?.into_iter().enumerate() {
            if !files_of.iter().any(|(k, _)| *k == row.item.key()) {
                files_of.push((row.item.key(), f));
            }
            match &study {
                Some(s) if *s != row.study => {
                    return Err(format!(
                        "{}: line {}: a row of study {} among rows of study {s}: merge the shards of one study only",
                        f.display(),
                        n + 1,
                        row.study
                    ))
                }
                None => study = Some(row.study.clone()),
                _ => {}
            }
            match rows
                .iter()
                .find(|r| r.item.key() == row.item.key() && r.method == row.method)
            {
                Some(prev)
                    if prev.item != row.item
                        || prev.parameters != row.parameters
                        || prev.outcome != row.outcome
                        || prev.error != row.error =>
                {
                    return Err(format!(
                        "{}: line {}: item {} method {} conflicts with another file's row for it",
                        f.display(),
                        n + 1,
                        row.item.key(),
                        row.method
                    ))
                }
                Some(_) => {}
                None => rows.push(row),
            }
        }
    }
    // Every item has a row for every method any item has: a file without one is damaged
    // (a study's summary would silently count fewer items for that method).
    let mut methods: Vec<&str> = rows.iter().map(|r| r.method.as_str()).collect();
    methods.sort_unstable();
    methods.dedup();
    for (key, file) in &files_of {
        for m in &methods {
            if !rows.iter().any(|r| &r.item.key() == key && r.method == *m) {
                return Err(format!(
                    "{}: item {key} has no row for method {m}, which other items have: run the study again to redo it",
                    file.display()
                ));
            }
        }
    }
    rows.sort_by_key(|r| r.item.index);
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(index: usize, method: &str, estimate: f64, covered: bool) -> Row {
        Row {
            study: "s".into(),
            item: Item {
                index,
                record_length: 10.0,
                sample_interval: 0.1,
                sensor_noise: None,
                seed_index: index,
                seed: index as u64,
                of: 0,
            },
            method: method.into(),
            outcome: Outcome::Estimated,
            samples: 100,
            error: None,
            worst_rel_error: Some((estimate - 2.0).abs() / 2.0),
            parameters: vec![RowParameter {
                name: "k1".into(),
                true_value: 2.0,
                estimate,
                std_error: Some(0.1),
                rel_error: (estimate - 2.0).abs() / 2.0,
                covered: Some(covered),
                cramer_rao_std: Some(0.05),
                integrator_bias: None,
            }],
            simulate_s: 0.0,
            identify_s: 0.0,
            item_s: 1.0,
            selection: None,
        }
    }

    #[test]
    fn summary_and_paired_differences_by_hand() {
        // Reference estimates 1.9, 2.0, 2.1 (sd 0.1); the other method adds 0.05, 0.10, 0.15.
        let mut rows = Vec::new();
        for (i, (r, d)) in [(1.9, 0.05), (2.0, 0.10), (2.1, 0.15)].into_iter().enumerate() {
            rows.push(row(i, "step-0", r, true));
            rows.push(row(i, "final", r + d, i != 2));
        }
        let s = summarize(&rows);
        let fin = s.iter().find(|x| x.method == "final").unwrap();
        // Worst errors 0.025, 0.05, 0.125: mean 0.0667, sd 0.0520.
        assert!((fin.worst_mean - 0.2 / 3.0).abs() < 1e-12);
        assert!((fin.worst_sd - 0.052_041_65).abs() < 1e-7, "{}", fin.worst_sd);
        assert_eq!(fin.coverage, Some(2.0 / 3.0));
        // step-0's estimates spread by sd 0.1 over the seeds; each standard error is 0.1
        // and each bound 0.05: the ratio 1, the efficiency 0.05²/0.1² = 0.25.
        let reference = &s.iter().find(|x| x.method == "step-0").unwrap().parameters[0];
        assert!((reference.std_error_ratio.unwrap() - 1.0).abs() < 1e-9, "{reference:?}");
        assert!((reference.efficiency.unwrap() - 0.25).abs() < 1e-9, "{reference:?}");
        let p = paired(&rows, "step-0");
        assert_eq!(p.len(), 1);
        let p = &p[0];
        assert_eq!((p.method.as_str(), p.parameter.as_str()), ("final", "k1"));
        assert!((p.reference_sd - 0.1).abs() < 1e-12);
        // Differences 0.5, 1.0, 1.5 reference sds: mean 1, sd 0.5, largest 1.5.
        assert!((p.mean - 1.0).abs() < 1e-9 && (p.sd - 0.5).abs() < 1e-9 && (p.max_abs - 1.5).abs() < 1e-9);
    }

    #[test]
    fn the_integrators_bias_is_set_beside_the_standard_errors() {
        // Standard errors 0.1 on every item; Richardson biases 0.02, 0.03, 0.04: their mean
        // is 0.3 of the standard error, above the quarter the markdown marks.
        let mut rows: Vec<Row> = (0..3).map(|i| row(i, "weak", 2.0, true)).collect();
        for (r, b) in rows.iter_mut().zip([0.02, 0.03, 0.04]) {
            r.parameters[0].integrator_bias = Some(b);
        }
        let s = summarize(&rows);
        let share = s[0].parameters[0].integrator_bias_share.unwrap();
        assert!((share - 0.3).abs() < 1e-12, "{share}");
        let md = crate::report::study::study_markdown("t", rows.len(), &s, &[]);
        assert!(
            md.contains("integrator bias / std. error") && md.contains("**+0.30**"),
            "{md}"
        );
        // Without the estimate, no column.
        for r in rows.iter_mut() {
            r.parameters[0].integrator_bias = None;
        }
        let s = summarize(&rows);
        assert_eq!(s[0].parameters[0].integrator_bias_share, None);
        assert!(!crate::report::study::study_markdown("t", rows.len(), &s, &[]).contains("integrator bias"));
    }

    #[test]
    fn refusals_are_counted_beside_the_estimates() {
        let mut rows: Vec<Row> = (0..4).map(|i| row(i, "strong", 2.1, true)).collect();
        for (r, o) in rows
            .iter_mut()
            .zip([Outcome::Refused, Outcome::Refused, Outcome::NotApplicable])
        {
            r.outcome = o;
            r.error = Some("why".into());
            r.parameters.clear();
            r.worst_rel_error = None;
        }
        let s = summarize(&rows);
        assert_eq!(s.len(), 1);
        assert_eq!(
            (s[0].items, s[0].refused, s[0].not_applicable, s[0].failed),
            (1, 2, 1, 0)
        );
        assert!((s[0].worst_median - 0.05).abs() < 1e-12);
    }

    #[test]
    fn an_item_file_is_done_only_when_whole() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("item.jsonl");
        let rows = vec![row(0, "weak", 2.1, true), row(0, "strong", 1.9, true)];
        let text = item_text(&rows).unwrap();
        std::fs::write(&path, &text).unwrap();
        assert_eq!(read_item(&path).unwrap(), rows);
        // Empty, cut before its mark, a row removed, a value edited: each named, none read.
        let lines: Vec<&str> = text.lines().collect();
        let cases = [
            (String::new(), "it is empty"),
            (format!("{}\n{}\n", lines[0], lines[1]), "no completeness mark"),
            (format!("{}\n{}\n", lines[0], lines[2]), "checksum"),
            (text.replace("2.1", "2.2"), "checksum"),
        ];
        for (damaged, says) in cases {
            std::fs::write(&path, &damaged).unwrap();
            let e = read_item(&path).unwrap_err();
            assert!(e.contains("item.jsonl") && e.contains(says), "{e}");
        }
    }
}
