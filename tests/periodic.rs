//! Measured records that repeat one realisation of a periodic excitation (docs/data.md,
//! "Periodic records"): found and averaged period by period before the reading.

use fpkbench::io::table::{measured, read_table};
use fpkbench::pipeline::{identify, Input, Options};
use fpkbench::Scenario;

use crate::common;

/// The model file of the Silverbox twin's table: one mass, one ground link with stiffness
/// powers 1–3 and a linear damper, the force `u` read as its equivalent white noise, the
/// `[identify]` `methods` line and the `[data]` section's body given.
fn twin_model(methods: &str, data: &str) -> String {
    format!(
        r#"
name = "twin-table"
[[mass]]
name = "m1"
value = 1.0
[[link]]
ends = ["ground", "m1"]
[[excitation]]
name = "u"
kind = "white"
acts_on = ["m1"]
[identify]
{methods}
equivalent_white = ["u"]
[identify.links.ground-m1]
stiffness = [1, 2, 3]
damping = [1]
[data]
{data}"#
    )
}

/// A multisine rig measured period by period, each period a record: the twin of
/// scenarios/silverbox_twin.toml, two realisations of three periods, the displacement with
/// sensor noise at 5 % of its spread (new in every period). The records of one realisation
/// are found and averaged period by period (docs/data.md, "Periodic records"): the
/// identification reads two records, and gives bit for bit what it gives on the periods
/// averaged by hand.
#[test]
fn periods_of_one_realisation_are_found_and_averaged() {
    use fpkbench::io::table::Table;
    let dir = tempfile::tempdir().unwrap();
    let twin = std::fs::read_to_string("scenarios/silverbox_twin.toml").unwrap();
    let mut s = Scenario::parse(&twin, "silverbox_twin.toml", "twin").unwrap();
    let (periods, n) = (3usize, 8192usize);
    s.simulation.record_length = periods as f64 * 13.4217728;
    s.simulation.trajectories = 2;
    let log = dir.path().join("run.mcap");
    common::fresh_log(&s, &log);
    let file = dir.path().join("run.npy");
    common::export(&log, "npy", &file);
    let t = read_table(&file, &[]).unwrap();
    // The log holds the trajectories' samples in blocks, interleaved: each in time order.
    let col = |name: &str| &t.columns[t.names.iter().position(|c| c == name).unwrap()];
    let mut order: Vec<usize> = (0..t.rows()).collect();
    order.sort_by(|&a, &b| col("trajectory")[a].total_cmp(&col("trajectory")[b]));
    let sorted = |name: &str| -> Vec<f64> { order.iter().map(|&k| col(name)[k]).collect() };
    let (x, u) = (&sorted("x_m1"), &sorted("p_u"));
    assert_eq!(x.len(), 2 * periods * n);
    let spread = (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt();
    // Gaussian noise (Box–Muller on a xorshift stream), new in every sample.
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    let y: Vec<f64> = x
        .iter()
        .map(|v| v + 0.05 * spread * (-2.0 * uniform().ln()).sqrt() * (2.0 * std::f64::consts::PI * uniform()).cos())
        .collect();
    let time: Vec<f64> = (0..x.len()).map(|k| (k % n + 1) as f64 * 1.6384e-3).collect();
    let names = ["record", "t", "p_u", "y"].map(String::from).to_vec();
    let periods_table = Table {
        path: "periods.csv".into(),
        names: names.clone(),
        columns: vec![
            (0..x.len()).map(|k| (k / n) as f64).collect(),
            time.clone(),
            u.clone(),
            y.clone(),
        ],
        record_labels: None,
    };
    // By hand: each realisation's periods averaged, sample by sample, in the table's order.
    let weight = 1.0 / periods as f64;
    let averaged = |v: &[f64]| -> Vec<f64> {
        (0..2 * n)
            .map(|k| {
                let (r, k) = (k / n, k % n);
                (0..periods).fold(0.0, |s, p| s + weight * v[(r * periods + p) * n + k])
            })
            .collect()
    };
    let by_hand = Table {
        path: "averaged.csv".into(),
        names,
        columns: vec![
            (0..2 * n).map(|k| ((k / n) * periods) as f64).collect(),
            time[..2 * n].to_vec(),
            averaged(u),
            averaged(&y),
        ],
        record_labels: None,
    };
    let model_text = twin_model(
        r#"methods = ["weak", "force-regression"]"#,
        r#"
time = "t"
record = "record"
derive = true
[data.columns]
x_m1 = "y"
p_u = "p_u"
"#,
    );
    let model = Scenario::parse(&model_text, "model.toml", "m").unwrap();
    let found = measured(&model, vec![periods_table.into()]).unwrap();
    assert_eq!(found.lengths, vec![n, n], "two realisations of one period each");
    let note = found
        .notes
        .iter()
        .find(|n| n.starts_with("periodic records"))
        .expect("a note");
    assert!(note.contains("records 1–3; 4–6"), "{note}");
    let plain = measured(&model, vec![by_hand.into()]).unwrap();
    assert!(plain.notes.iter().all(|n| !n.starts_with("periodic records")));
    let options = Options {
        validate: false,
        methods: vec![
            fpkbench::scenario::Method::Weak,
            fpkbench::scenario::Method::ForceRegression,
        ],
        ..Options::default()
    };
    let a = identify(&Input::tables(model.clone(), found), &options).unwrap();
    let b = identify(&Input::tables(model, plain), &options).unwrap();
    for (ma, mb) in a.methods.iter().zip(&b.methods) {
        let (ea, eb) = (
            ma.parameters
                .iter()
                .map(|p| (p.estimate, p.std_error))
                .collect::<Vec<_>>(),
            mb.parameters
                .iter()
                .map(|p| (p.estimate, p.std_error))
                .collect::<Vec<_>>(),
        );
        assert_eq!(ea, eb, "{}", ma.method);
    }
}

/// A multisine's records are the jackknife's units (docs/methods.md, "Standard errors"):
/// its stretches share a realisation's line phases, and its whole periods hold the
/// equations exactly where parts of one do not. The Silverbox twin simulated (ten
/// realisations of one period) takes its standard errors from 8 groups of whole records
/// and says so; its export read as a measured table takes them from 32 batches of
/// stretches, unless the model file says `[data] independent = "records"`; and a value
/// that is neither is refused, naming the key.
#[test]
fn a_multisines_records_are_the_jackknifes_units() {
    let dir = tempfile::tempdir().unwrap();
    let twin = std::fs::read_to_string("scenarios/silverbox_twin.toml").unwrap();
    let s = Scenario::parse(&twin, "silverbox_twin.toml", "twin").unwrap();
    let options = Options {
        validate: false,
        plots: false,
        methods: vec![fpkbench::scenario::Method::Weak],
        ..Options::default()
    };
    let batches = |r: &fpkbench::report::Report| -> (bool, bool) {
        let json = serde_json::to_string(r).unwrap();
        (
            json.contains("jackknife over 8 batches"),
            r.data_notes.iter().any(|n| n.contains("8 groups of whole records")),
        )
    };
    let simulated = identify(&Input::simulation(s.clone()), &options).unwrap();
    assert_eq!(batches(&simulated), (true, true), "{:?}", simulated.data_notes);
    let log = dir.path().join("run.mcap");
    common::fresh_log(&s, &log);
    let file = dir.path().join("run.npy");
    common::export(&log, "npy", &file);
    let model_text = |independent: &str| {
        twin_model(
            r#"methods = ["weak"]"#,
            &format!(
                r#"
time = "t"
record = "trajectory"
{independent}
[data.columns]
x_m1 = "x_m1"
v_m1 = "v_m1"
p_u = "p_u"
"#
            ),
        )
    };
    let read = |independent: &str| {
        let model = Scenario::parse(&model_text(independent), "model.toml", "m").unwrap();
        let table = read_table(&file, &[]).unwrap();
        let m = measured(&model, vec![table.into()]).unwrap();
        identify(&Input::tables(model, m), &options).unwrap()
    };
    let stretches = read("");
    assert_eq!(batches(&stretches), (false, false), "{:?}", stretches.data_notes);
    let records = read("independent = \"records\"");
    assert_eq!(batches(&records), (true, true), "{:?}", records.data_notes);
    // Over the groups of records the force's level, read from the same groups, is taken
    // out of each replicate with its records; over stretches it is held.
    let own_level =
        |r: &fpkbench::report::Report| serde_json::to_string(r).unwrap().contains("and its own force level");
    assert!(own_level(&records) && !own_level(&stretches));
    // The estimates are the same; only their standard errors' units differ.
    let estimates =
        |r: &fpkbench::report::Report| -> Vec<f64> { r.methods[0].parameters.iter().map(|p| p.estimate).collect() };
    assert_eq!(estimates(&stretches), estimates(&records));
    assert_eq!(batches(&read("independent = \"stretches\"")), (false, false));
    let e = Scenario::parse(&model_text("independent = \"blocks\""), "model.toml", "m")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("model.toml:") && e.contains("data.independent") && e.contains("\"records\""),
        "{e}"
    );
}
