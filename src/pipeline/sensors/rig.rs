//! A simulated rig identified through its sensors (docs/measurement.md, "A rig's
//! sensors"): where `[measurement] sensors` leaves a mass without its displacement or its
//! velocity, the identification reads only the channels the sensors give, as measured data
//! on the scenario taken as a model file, and rebuilds the motion as it does for a lab's
//! table — integrated from accelerations with the drift removed, or differenced from
//! displacements — with the sensors' noise estimated and taken out. The log's other columns
//! are the clean states, kept for diagnostics; the identification never reads them. The
//! model keeps the scenario's values, so the report grades the estimates against them.

use crate::io::table::{measured, LogColumns, Source, Table};
use crate::pipeline::{Input, PipelineError};
use crate::scenario::{AccelerationSamples, DataMapping, Scenario};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;

/// `input`'s sensor channels as measured data on its scenario, when the scenario's rig
/// does not give every mass's whole state; `None` when it does (or `input` is measured
/// data already).
pub(crate) fn through_sensors(input: &Input) -> Result<Option<Input>, PipelineError> {
    let s = &input.info.scenario;
    let Some(rig) = &s.simulation.sensors.rig else {
        return Ok(None);
    };
    if s.data.is_some() || rig.iter().all(|m| m.whole_state()) {
        return Ok(None);
    }
    let model = crate::model::Model::new(s);
    let (layout, names) = (model.columns(), model.column_names());
    let mut wanted = Vec::new();
    for (i, m) in rig.iter().enumerate() {
        for (on, column) in [
            (m.displacement, layout.x(i)),
            (m.velocity, layout.v(i)),
            (m.acceleration, layout.a(i)),
        ] {
            if on {
                wanted.push(column);
            }
        }
        for (e, _) in s
            .excitations
            .iter()
            .enumerate()
            .filter(|(_, e)| m.force && e.acts_on.contains(&i))
        {
            if !wanted.contains(&layout.force(e)) {
                wanted.push(layout.force(e));
            }
        }
    }
    let channels: Vec<String> = wanted.iter().map(|&c| names[c].clone()).collect();
    let table_names: Vec<String> = ["trajectory", "t"]
        .iter()
        .map(|n| n.to_string())
        .chain(channels.iter().cloned())
        .collect();
    // A log is read again on every pass, in bounded memory; samples in memory (a run
    // simulated straight into the estimators) are copied: 8 bytes per value, two more per
    // sample for the record and the time.
    let source = if input.source.is_log_file() {
        Source::Log(Arc::new(LogColumns {
            info: input.info.clone(),
            columns: wanted,
            names: table_names,
        }))
    } else {
        let expected = input.expected_samples() as usize;
        let mut columns: Vec<Vec<f64>> = (0..wanted.len() + 2).map(|_| Vec::with_capacity(expected)).collect();
        input.for_each_sample(|trajectory, t, row| {
            columns[0].push(trajectory as f64);
            columns[1].push(t);
            for (k, &c) in wanted.iter().enumerate() {
                columns[k + 2].push(row[c]);
            }
        })?;
        Source::Memory(Table {
            path: PathBuf::from(format!("<{}: the rig's sensors>", s.name)),
            names: table_names,
            columns,
            record_labels: None,
        })
    };
    // Unfiltered, a white-forced mass's logged acceleration is its velocity's change over
    // the interval; an anti-alias or bandwidth filter's output is a value at the instant,
    // and so is the force balance the lab scheme logs without white noise (sim::lab).
    let filtered = s.simulation.sensors.anti_alias.is_some() || s.simulation.sensors.bandwidth.is_some();
    let acceleration_samples = if filtered || crate::sim::lab::logs_instant_accelerations(&model) {
        AccelerationSamples::Instants
    } else {
        AccelerationSamples::IntervalMeans
    };
    let mut m: Scenario = s.clone();
    m.data = Some(DataMapping {
        time: Some("t".into()),
        sample_interval: None,
        record: Some("trajectory".into()),
        columns: channels.iter().map(|c| (c.clone(), c.clone())).collect(),
        scale: BTreeMap::new(),
        remove_mean: Vec::new(),
        npy_columns: Vec::new(),
        topic: None,
        derive: true,
        drift_period: None,
        acceleration_samples,
        split_gaps: false,
        delimiter: None,
        decimal_comma: false,
        independent: None,
    });
    // The filters shaped the samples already; measured data are read as they come.
    let sensors = &mut m.simulation.sensors;
    sensors.anti_alias = None;
    sensors.bandwidth = None;
    sensors.rig = None;
    let data = measured(&m, vec![source])?;
    Ok(Some(Input::tables(m, data)))
}
