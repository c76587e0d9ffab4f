//! `[data]` of a model file: the mapping of a measured table onto the model's quantities
//! (docs/data.md).

use super::*;
use std::collections::BTreeMap;

/// `[data]`: every mapped column a quantity of the model, every factor finite and non-zero.
pub(crate) fn check_data(
    loc: &Locator,
    raw: &RawScenario,
    masses: &[Mass],
    excitations: &[Excitation],
) -> Result<Option<DataMapping>, ScenarioError> {
    let Some(d) = &raw.data else {
        return Ok(None);
    };
    let mass_names: Vec<String> = masses.iter().map(|m| m.name.clone()).collect();
    let excitation_names: Vec<String> = excitations.iter().map(|e| e.name.clone()).collect();
    let allowed = crate::model::Columns::new(masses.len(), excitations.len()).names(&mass_names, &excitation_names);
    let mut columns = Vec::new();
    for (k, v) in d.get_ref().columns.get_ref() {
        if !allowed.contains(k) {
            return Err(loc.at(
                v.span(),
                format!("data.columns.{k}"),
                format!(
                    "{k:?} is not a quantity of this model: allowed are {}",
                    allowed.join(", ")
                ),
            ));
        }
        columns.push((k.clone(), v.get_ref().clone()));
    }
    let d = d.get_ref();
    let sample_interval = match &d.sample_interval {
        Some(v) => Some(finite_positive(loc, v, "data.sample_interval", "s")?),
        None => None,
    };
    if d.time.is_none() && sample_interval.is_none() {
        return Err(loc.at(
            raw.data.as_ref().expect("some").span(),
            "data",
            "give the time column (`time = \"t\"`) or the sample interval (`sample_interval = 0.01`, s)",
        ));
    }
    let split_gaps = match &d.split_gaps {
        Some(v) if *v.get_ref() && d.time.is_none() => {
            return Err(loc.at(
                v.span(),
                "data.split_gaps",
                "splitting records at time gaps needs the time column (`time = \"t\"`)",
            ))
        }
        Some(v) => *v.get_ref(),
        None => false,
    };
    let mut scale = BTreeMap::new();
    for (k, v) in d.scale.iter().flatten() {
        let f = *v.get_ref();
        if !(f.is_finite() && f != 0.0) {
            return Err(loc.at(
                v.span(),
                format!("data.scale.{k}"),
                format!("must be a finite, non-zero factor, got {f}"),
            ));
        }
        // A factor on a column nothing reads would leave the data unscaled without a word
        // (`Phi` for `phi`: the angle stays in degrees).
        let time = d.time.as_ref().map(|t| t.get_ref().as_str());
        if !columns.iter().any(|(_, c)| c == k) && time != Some(k.as_str()) {
            let mut read: Vec<&str> = columns.iter().map(|(_, c)| c.as_str()).chain(time).collect();
            read.sort_unstable();
            read.dedup();
            return Err(loc.at(
                v.span(),
                format!("data.scale.{k}"),
                format!(
                    "{k:?} is not a column the model reads: the scaled columns must be among {} (the table's \
                     names, as [data.columns] maps them)",
                    read.iter().map(|c| format!("{c:?}")).collect::<Vec<_>>().join(", ")
                ),
            ));
        }
        scale.insert(k.clone(), f);
    }
    let remove_mean = check_remove_mean(loc, d, &columns)?;
    let delimiter = match &d.delimiter {
        None => None,
        Some(v) => match v.get_ref().as_str() {
            "," => Some(b','),
            ";" => Some(b';'),
            "\t" => Some(b'\t'),
            "|" => Some(b'|'),
            other => {
                return Err(loc.at(
                    v.span(),
                    "data.delimiter",
                    format!("{other:?}: the delimiters are \",\", \";\", \"\\t\" (tab) and \"|\"; leave it out to take the header's own"),
                ))
            }
        },
    };
    let decimal_comma = match &d.decimal {
        None => false,
        Some(v) => match v.get_ref().as_str() {
            "." => false,
            "," if delimiter == Some(b',') => {
                return Err(loc.at(
                    v.span(),
                    "data.decimal",
                    "a decimal comma needs another delimiter (delimiter = \";\", as spreadsheets write it)",
                ))
            }
            "," => true,
            other => {
                return Err(loc.at(
                    v.span(),
                    "data.decimal",
                    format!("{other:?}: the decimal mark is \".\" or \",\""),
                ))
            }
        },
    };
    let drift_period = match &d.drift_period {
        Some(v) => Some(finite_positive(loc, v, "data.drift_period", "s")?),
        None => None,
    };
    let acceleration_samples = acceleration_samples(loc, d)?;
    let independent = independent(loc, d)?;
    Ok(Some(DataMapping {
        independent,
        drift_period,
        acceleration_samples,
        time: d.time.as_ref().map(|t| t.get_ref().clone()),
        sample_interval,
        record: d.record.as_ref().map(|t| t.get_ref().clone()),
        columns,
        scale,
        remove_mean,
        npy_columns: d.npy_columns.iter().flatten().map(|c| c.get_ref().clone()).collect(),
        topic: d.topic.as_ref().map(|t| t.get_ref().clone()),
        derive: d.derive.unwrap_or(false),
        split_gaps,
        delimiter,
        decimal_comma,
    }))
}

/// `[data] remove_mean`: columns the model reads, each once.
fn check_remove_mean(loc: &Locator, d: &RawData, columns: &[(String, String)]) -> Result<Vec<String>, ScenarioError> {
    let mut remove_mean = Vec::new();
    for c in d.remove_mean.iter().flatten() {
        let name = c.get_ref();
        if !columns.iter().any(|(_, m)| m == name) {
            let mut read: Vec<&str> = columns.iter().map(|(_, m)| m.as_str()).collect();
            read.sort_unstable();
            return Err(loc.at(
                c.span(),
                "data.remove_mean",
                format!(
                    "{name:?} is not a column the model reads: the columns whose mean is taken out must be among {}",
                    read.iter().map(|c| format!("{c:?}")).collect::<Vec<_>>().join(", ")
                ),
            ));
        }
        if remove_mean.contains(name) {
            return Err(loc.at(c.span(), "data.remove_mean", format!("{name:?} is listed twice")));
        }
        remove_mean.push(name.clone());
    }
    Ok(remove_mean)
}

/// `[data] independent`: `"records"` or `"stretches"` (unset: chosen from the data).
fn independent(loc: &Locator, d: &RawData) -> Result<Option<Independent>, ScenarioError> {
    let Some(v) = &d.independent else { return Ok(None) };
    match v.get_ref().as_str() {
        "records" => Ok(Some(Independent::Records)),
        "stretches" => Ok(Some(Independent::Stretches)),
        other => Err(loc.at(
            v.span(),
            "data.independent",
            format!(
                "{other:?}: \"records\" (each record its own realisation, e.g. a multisine's blocks: the standard \
                 errors come from whole records) or \"stretches\" (stretches of the records are independent draws, \
                 as under stationary random excitation); unset, fpkbench chooses (docs/data.md, \"Independent \
                 records\")"
            ),
        )),
    }
}

/// `[data] acceleration_samples`: `"instants"` (the default) or `"interval_means"`.
fn acceleration_samples(loc: &Locator, d: &RawData) -> Result<AccelerationSamples, ScenarioError> {
    Ok(match &d.acceleration_samples {
        None => AccelerationSamples::Instants,
        Some(v) => match v.get_ref().as_str() {
            "instants" => AccelerationSamples::Instants,
            "interval_means" => AccelerationSamples::IntervalMeans,
            other => {
                return Err(loc.at(
                    v.span(),
                    "data.acceleration_samples",
                    format!(
                        "{other:?}: \"instants\" (an accelerometer's values at the sample times, the default) or \
                         \"interval_means\" (each the mean over the interval ending at its time, (v_k − v_(k−1))/h, \
                         as fpkbench's own logs and exports hold them)"
                    ),
                ))
            }
        },
    })
}
