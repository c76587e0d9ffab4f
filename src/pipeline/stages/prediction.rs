//! Stage "prediction" (`identify --predict TABLE`): every identified model driven by the
//! measured forces of held-out records and its displacements compared with theirs, sample
//! by sample — the free-run simulation error by which a system-identification benchmark
//! scores a model (docs/methods.md, "Prediction"). Each record starts from its own first
//! measured state (displacement, and the velocity as read or derived).

use super::super::grading::coefficients_of;
use super::super::validation::identified_model;
use super::super::PipelineError;
use super::Identification;
use crate::io::table::Measured;
use crate::model::Model;
use crate::report::{PredictionReport, PredictionRow};
use crate::sim::driven::free_run;
use rayon::prelude::*;

pub(crate) fn run(id: &mut Identification) -> Result<(), PipelineError> {
    crate::interrupt::check()?;
    let Some(test) = id.options.predict.clone() else {
        return Ok(());
    };
    let s = &id.input.info.scenario;
    let reported = id.reported.as_ref().expect("the rows stage sets it");
    let coef_of = coefficients_of(reported);
    let shape = Model::new(s);
    let records = Records::read(&test, &shape)?;
    let names = shape.column_names();
    let columns: Vec<(String, f64)> = records
        .compared
        .iter()
        .map(|&(i, _)| (names[shape.columns().x(i)].clone(), records.spread(i)))
        .collect();
    let substeps = test.steps_per_sample();
    let rows = id
        .estimates
        .par_iter()
        .map(|(method, values)| {
            let model = identified_model(s, reported, &coef_of, values);
            records.score(method.clone(), &model, test.sample_interval, substeps)
        })
        .collect();
    id.prediction = Some(PredictionReport {
        files: test.files.iter().map(|f| f.display().to_string()).collect(),
        records: records.x0.len(),
        samples: test.samples(),
        sample_interval_s: test.sample_interval,
        substeps,
        columns,
        rows,
    });
    Ok(())
}

/// The held-out records as the free run needs them.
struct Records {
    /// Per record, per mass: the external force at each sample.
    forces: Vec<Vec<Vec<f64>>>,
    /// Per record: the first state.
    x0: Vec<Vec<f64>>,
    v0: Vec<Vec<f64>>,
    /// The measured displacements compared: (mass, per record its samples).
    compared: Vec<(usize, Vec<Vec<f64>>)>,
}

impl Records {
    /// One pass over `test`: every mass's force (the sum of the measured excitations on
    /// it), first state and measured displacement.
    fn read(test: &Measured, m: &Model) -> Result<Records, PipelineError> {
        let (n, c) = (m.masses(), m.columns());
        let count = test.lengths.len();
        let measured: Vec<usize> = (0..n)
            .filter(|&i| test.present[c.x(i)] && !test.derived(c.x(i)))
            .collect();
        let mut r = Records {
            forces: vec![vec![Vec::new(); n]; count],
            x0: vec![vec![0.0; n]; count],
            v0: vec![vec![0.0; n]; count],
            compared: measured.iter().map(|&i| (i, vec![Vec::new(); count])).collect(),
        };
        test.for_each_sample(&mut |j, _, row| {
            let j = j as usize;
            let first = r.forces[j][0].is_empty();
            for i in 0..n {
                let f: f64 = (0..m.excitations.len())
                    .filter(|&e| m.excitations[e].targets.contains(&i))
                    .map(|e| row[c.force(e)])
                    .filter(|p| p.is_finite())
                    .sum();
                r.forces[j][i].push(f);
                if first {
                    let known = |v: f64| if v.is_finite() { v } else { 0.0 };
                    r.x0[j][i] = known(row[c.x(i)]);
                    r.v0[j][i] = known(row[c.v(i)]);
                }
            }
            for (i, xs) in &mut r.compared {
                xs[j].push(row[c.x(*i)]);
            }
        })?;
        Ok(r)
    }

    /// The RMS of mass `i`'s measured displacement about its mean, over every record.
    fn spread(&self, i: usize) -> f64 {
        let xs = &self.compared.iter().find(|(k, _)| *k == i).expect("a compared mass").1;
        let all = || xs.iter().flatten();
        let n = all().count() as f64;
        let mean = all().sum::<f64>() / n;
        (all().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt()
    }

    /// `model` driven by every record's forces: its RMS and mean error per compared mass.
    fn score(&self, method: crate::scenario::ReportMethod, model: &Model, h: f64, substeps: usize) -> PredictionRow {
        let k = self.compared.len();
        let (mut sq, mut sum, mut count) = (vec![0.0; k], vec![0.0; k], 0usize);
        for (j, forces) in self.forces.iter().enumerate() {
            let run = match free_run(model, forces, h, substeps, &self.x0[j], &self.v0[j]) {
                Ok(run) => run,
                Err(e) => {
                    return PredictionRow {
                        method,
                        rms_error: vec![f64::NAN; k],
                        mean_error: vec![f64::NAN; k],
                        error: Some(format!("record {}: {e}", j + 1)),
                    }
                }
            };
            for (q, (i, xs)) in self.compared.iter().enumerate() {
                for (sim, data) in run.displacement(*i).zip(&xs[j]) {
                    sq[q] += (sim - data).powi(2);
                    sum[q] += sim - data;
                }
            }
            count += forces[0].len();
        }
        let count = count as f64;
        PredictionRow {
            method,
            rms_error: sq.iter().map(|s| (s / count).sqrt()).collect(),
            mean_error: sum.iter().map(|s| s / count).collect(),
            error: None,
        }
    }
}
