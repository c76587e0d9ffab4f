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
    // the sampling is coarse, as here), the central difference where it would reach past a
    // record's ends.
    for (j, (id, from)) in [(1.0, 0), (2.0, 0), (2.0, 42)].into_iter().enumerate() {
        let (times, samples) = data.record(j as u32).unwrap();
        let n = data.lengths[j];
        let xs: Vec<f64> = (0..n).map(|s| x(id, (from + s) as f64)).collect();
        let v = direct(&xs, &xs, &data.derive[0], h);
        let a = match data.derive[1].second {
            Some(_) => direct(&xs, &v, &data.derive[1], h),
            None => direct(&v, &v, &data.derive[1], h),
        };
        assert_eq!(times, (1..=n).map(|s| s as f64 * h).collect::<Vec<_>>());
        for s in 0..n {
            let row = &samples[s * data.width..(s + 1) * data.width];
            assert_eq!(row[layout.x(0)], xs[s]);
            assert_eq!(row[layout.v(0)], v[s], "record {j}, sample {s}");
            assert_eq!(row[layout.a(0)], a[s], "record {j}, sample {s}");
        }
    }
}

/// The derivative `step` makes of `f` (`near_ends` differenced centrally where the stencil
/// would reach past the ends: `f` itself, or for a second derivative the velocity),
/// computed directly.
fn direct(f: &[f64], near_ends: &[f64], step: &Step, h: f64) -> Vec<f64> {
    let n = f.len();
    let w = differentiate::stencil(step.half, step.exact, step.second.is_some());
    (0..n)
        .map(|s| {
            if s >= step.half && s + step.half < n {
                return match step.second {
                    Some(_) => (1..=step.half).fold(w[0] * f[s], |a, k| a + w[k] * (f[s + k] + f[s - k])) / (h * h),
                    None => {
                        w.iter()
                            .enumerate()
                            .fold(0.0, |v, (k, wk)| v + wk * (f[s + k + 1] - f[s - k - 1]))
                            / h
                    }
                };
            }
            let (a, b) = (s.saturating_sub(1), (s + 1).min(n - 1));
            (near_ends[b] - near_ends[a]) / ((b - a) as f64 * h)
        })
        .collect()
}

/// A displacement whose motion reaches 0.7 of the Nyquist frequency (`ω·h` up to 2.2), as a
/// shaker's band does at a third of the sampling rate: the acceleration is its exact second
/// difference, of the order that holds the band edge, streamed as computed directly, and
/// within 0.5 % of the true second derivative.
#[test]
fn an_acceleration_from_a_band_limited_displacement_is_its_second_difference() {
    let text = include_str!("../../../models/sdof_duffing.toml")
        .replace("[data]\n", "[data]\nderive = true\n")
        .replace("v_m1 = \"v_m1\"\n", "");
    let model = crate::Scenario::parse(&text, "m.toml", "m").unwrap();
    let h = 0.01;
    let lines = [(0.7, 1.0), (1.3, 0.3), (2.2, 0.05)];
    let x = |s: f64| lines.iter().map(|(w, c)| c * (w * s).sin()).sum::<f64>();
    let a_true = |s: f64| {
        lines
            .iter()
            .map(|(w, c)| -c * w * w / (h * h) * (w * s).sin())
            .sum::<f64>()
    };
    let n = 2000;
    let table = Table {
        path: "t".into(),
        names: vec!["trajectory".into(), "t".into(), "x_m1".into()],
        columns: vec![
            vec![1.0; n],
            (0..n).map(|s| s as f64 * h).collect(),
            (0..n).map(|s| x(s as f64)).collect(),
        ],
        record_labels: None,
    };
    let data = measured(&model, vec![table.into()]).unwrap();
    let step = data.derive[1];
    assert!(
        step.second.is_some() && step.exact && step.half > 5,
        "{step:?}: {:?}",
        data.notes
    );
    let layout = crate::Model::new(&model).columns();
    let (_, samples) = data.record(0).unwrap();
    let xs: Vec<f64> = (0..n).map(|s| x(s as f64)).collect();
    let v = direct(&xs, &xs, &data.derive[0], h);
    let a = direct(&xs, &v, &step, h);
    for s in 0..n {
        let row = &samples[s * data.width..(s + 1) * data.width];
        assert_eq!(row[layout.a(0)], a[s], "sample {s}");
        if s >= step.half && s + step.half < n {
            let scale = lines.iter().map(|(w, c)| c * w * w / (h * h)).sum::<f64>();
            assert!(
                (a[s] - a_true(s as f64)).abs() < 5e-3 * scale,
                "sample {s}: {} for {}",
                a[s],
                a_true(s as f64)
            );
        }
    }
}

/// The scan keeps each record's first values of the compared column as a pass of their own
/// reads them (what the searches for periodic records look at): the same records in the
/// same order, with the same first values and lengths, on interleaved records of unequal
/// length.
#[test]
fn the_scans_heads_are_the_records_read_anew() {
    let model = crate::Scenario::parse(include_str!("../../../models/sdof_duffing.toml"), "m.toml", "m").unwrap();
    let d = model.data.as_ref().unwrap();
    let mut rows: Vec<[f64; 4]> = Vec::new();
    for s in 0..5000 {
        for (r, n) in [(7.0, 5000), (3.0, 4200), (5.0, 300)] {
            if s < n {
                let x = (0.37 * s as f64 + r).sin();
                rows.push([r, s as f64 * 0.1, x, 0.5 * x]);
            }
        }
    }
    let table = Table {
        path: "t".into(),
        names: ["trajectory", "t", "x_m1", "v_m1"].map(String::from).to_vec(),
        columns: (0..4).map(|c| rows.iter().map(|r| r[c]).collect()).collect(),
        record_labels: None,
    };
    let sources = vec![Source::from(table)];
    let (column, n) = periods::compared_head(d).unwrap();
    assert_eq!(n, 4096, "no force: the heads this module compares");
    let j = d.columns.iter().position(|(_, c)| c == column).unwrap();
    let names = crate::model::Model::new(&model).column_names();
    let c = Columns::of(&sources[0], d, &names).unwrap();
    let mut scans = vec![scan(&sources[0], &c, d, Some((j, n))).unwrap()];
    let heads = periods::heads_of(&mut scans);
    let anew = periods::records(&sources, d, column, n).unwrap();
    let summary = |r: &[periods::Record]| -> Vec<(usize, u64, Vec<f64>, usize)> {
        r.iter().map(|r| (r.source, r.key, r.head.clone(), r.rows)).collect()
    };
    assert_eq!(summary(&heads), summary(&anew));
    assert_eq!(
        heads.iter().map(|r| (r.head.len(), r.rows)).collect::<Vec<_>>(),
        [(4096, 5000), (4096, 4200), (300, 300)]
    );
}
