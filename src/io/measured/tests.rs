//! Reading records: interleaved rows, gaps, derivatives.

use super::*;
use crate::io::table::Table;

/// Records interleaved row by row, one split at a gap: each record's samples come out
/// in time order with their time from the record's start, and the derived velocity and
/// acceleration are the differences of the whole record (central, one-sided at its
/// ends, where the stencil would reach past them), computed here directly.
#[test]
fn interleaved_records_stream_with_their_derivatives() {
    // The shipped SDOF model, reading the displacement only and deriving the rest.
    let text = include_str!("../../../models/sdof_duffing.toml")
        .replace("[data]\n", "[data]\nderive = true\nsplit_gaps = true\n")
        .replace("v_m1 = \"v_m1\"\n", "");
    let model = crate::Scenario::parse(&text, "m.toml", "m").unwrap();
    let h = 0.5;
    let x = |r: f64, s: f64| (0.3 * s + r).sin() + 0.01 * s * s;
    // Record 2: 40 samples, then a gap, then 3; record 1: 25 samples (its rows after
    // record 2's while both run).
    let mut rows: Vec<[f64; 3]> = Vec::new();
    for s in 0..45 {
        if !(40..=41).contains(&s) {
            rows.push([2.0, s as f64 * h, x(2.0, s as f64)]);
        }
        if s < 25 {
            rows.push([1.0, s as f64 * h, x(1.0, s as f64)]);
        }
    }
    let table = Table {
        path: "t".into(),
        names: vec!["trajectory".into(), "t".into(), "x_m1".into()],
        columns: (0..3).map(|c| rows.iter().map(|r| r[c]).collect()).collect(),
        record_labels: None,
    };
    let data = measured(&model, vec![table.into()]).unwrap();
    assert_eq!(data.lengths, [25, 40, 3]);
    assert!(data
        .notes
        .iter()
        .any(|n| n.contains("record 2 split at 1 time gap(s) into 2 records")));
    let layout = crate::Model::new(&model).columns();
    // The stencil each step chose (the exact central difference of a higher order where
    // the sampling is coarse, as here), the central difference where it would reach
    // past a record's ends.
    let diff = |f: &[f64], step: &Step| -> Vec<f64> {
        let n = f.len();
        let w = differentiate::stencil(step.half, step.exact);
        (0..n)
            .map(|s| {
                if s >= step.half && s + step.half < n {
                    return w
                        .iter()
                        .enumerate()
                        .map(|(k, wk)| wk * (f[s + k + 1] - f[s - k - 1]))
                        .sum::<f64>()
                        / h;
                }
                let (a, b) = (s.saturating_sub(1), (s + 1).min(n - 1));
                (f[b] - f[a]) / ((b - a) as f64 * h)
            })
            .collect()
    };
    for (j, (id, from)) in [(1.0, 0), (2.0, 0), (2.0, 42)].into_iter().enumerate() {
        let (times, samples) = data.record(j as u32).unwrap();
        let n = data.lengths[j];
        let xs: Vec<f64> = (0..n).map(|s| x(id, (from + s) as f64)).collect();
        let v = diff(&xs, &data.derive[0]);
        let a = diff(&v, &data.derive[1]);
        assert_eq!(times, (1..=n).map(|s| s as f64 * h).collect::<Vec<_>>());
        for s in 0..n {
            let row = &samples[s * data.width..(s + 1) * data.width];
            assert_eq!(row[layout.x(0)], xs[s]);
            assert_eq!(row[layout.v(0)], v[s], "record {j}, sample {s}");
            assert_eq!(row[layout.a(0)], a[s], "record {j}, sample {s}");
        }
    }
}
