//! Checks a [`DecideRequest`] against the served model before anything is decided: the
//! session's name, the step, the length of every vector, every value finite, the forecast
//! long enough, the previous input within its bounds, and the units where the request names
//! them. Each refusal is a 422 whose message names the field, the entry and what to send.

use super::api::{ApiError, DecideRequest, ModelInfo, Quantity};
use crate::sim::season::MAX_SEASON_STEPS;

/// The longest session name.
pub const MAX_SESSION_LEN: usize = 64;

/// A request that fits the model: plain numbers, the forecast row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct Checked {
    /// The session.
    pub session: String,
    /// The step.
    pub step: usize,
    /// `x(k)`.
    pub state: Vec<f64>,
    /// `u(k−1)`.
    pub previous_input: Vec<f64>,
    /// The measured outputs, if sent.
    pub outputs: Option<Vec<f64>>,
    /// `d(k), d(k+1), …`, row-major.
    pub forecast: Vec<f64>,
}

/// Checks `request` against the model `info` describes.
pub fn check(request: &DecideRequest, info: &ModelInfo) -> Result<Checked, ApiError> {
    check_session(&request.session)?;
    let step = usize::try_from(request.step)
        .ok()
        .filter(|s| *s < MAX_SEASON_STEPS)
        .ok_or_else(|| {
            ApiError::unprocessable(format!(
                "step {} is beyond the longest season ({MAX_SEASON_STEPS} steps)",
                request.step
            ))
        })?;
    let state = values("state", &request.state, &info.states)?;
    let previous_input = values("previous_input", &request.previous_input, &info.inputs)?;
    check_bounds(&previous_input, &info.inputs)?;
    let outputs = match &request.outputs {
        Some(y) => Some(values("outputs", y, &info.outputs)?),
        None => None,
    };
    let needed = info.forecast_rows;
    if request.forecast.len() < needed {
        return Err(ApiError::unprocessable(format!(
            "forecast has {} row{}; the controller needs {needed} (its horizon), one per {} s from \
             the current step on",
            request.forecast.len(),
            if request.forecast.len() == 1 { "" } else { "s" },
            info.sample_period_s
        )));
    }
    let nd = info.disturbances.len();
    let mut forecast = Vec::with_capacity(request.forecast.len() * nd);
    for (r, row) in request.forecast.iter().enumerate() {
        forecast.extend(values(&format!("forecast[{r}]"), row, &info.disturbances)?);
    }
    if let Some(units) = &request.units {
        check_units("state", units.state.as_deref(), &info.states)?;
        check_units(
            "previous_input",
            units.previous_input.as_deref(),
            &info.inputs,
        )?;
        check_units("outputs", units.outputs.as_deref(), &info.outputs)?;
        check_units("forecast", units.forecast.as_deref(), &info.disturbances)?;
    }
    Ok(Checked {
        session: request.session.clone(),
        step,
        state,
        previous_input,
        outputs,
        forecast,
    })
}

/// A session name: 1 to [`MAX_SESSION_LEN`] letters, digits, `-`, `_` or `.`.
fn check_session(name: &str) -> Result<(), ApiError> {
    let fine = !name.is_empty()
        && name.len() <= MAX_SESSION_LEN
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'));
    if fine {
        Ok(())
    } else {
        Err(ApiError::unprocessable(format!(
            "session {name:?}: a session is named by 1 to {MAX_SESSION_LEN} letters, digits, '-', \
             '_' or '.'"
        )))
    }
}

/// The values of `field`, one per quantity, each a finite number.
fn values(field: &str, given: &[Option<f64>], of: &[Quantity]) -> Result<Vec<f64>, ApiError> {
    if given.len() != of.len() {
        return Err(ApiError::unprocessable(format!(
            "{field} has {} value{}; the model has {} ({})",
            given.len(),
            if given.len() == 1 { "" } else { "s" },
            of.len(),
            of.iter()
                .map(|q| q.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    given
        .iter()
        .zip(of)
        .enumerate()
        .map(|(i, (v, q))| match v {
            Some(v) if v.is_finite() => Ok(*v),
            _ => Err(ApiError::unprocessable(format!(
                "{field}[{i}] ({} [{}]) is {}: every value must be a finite number (JSON has no \
                 NaN; null stands for a missing or NaN measurement)",
                q.name,
                q.unit,
                v.map_or("null".to_string(), |v| v.to_string())
            ))),
        })
        .collect()
}

/// The previous input within the inputs' bounds: a value far outside them is most likely in
/// another unit.
fn check_bounds(input: &[f64], of: &[Quantity]) -> Result<(), ApiError> {
    for (i, (v, q)) in input.iter().zip(of).enumerate() {
        let (Some(lo), Some(hi)) = (q.lower, q.upper) else {
            continue;
        };
        let tolerance = 1e-9 * (1.0 + lo.abs().max(hi.abs()));
        if *v < lo - tolerance || *v > hi + tolerance {
            return Err(ApiError::unprocessable(format!(
                "previous_input[{i}] ({}) is {v}, outside its bounds [{lo}, {hi}] {}: send the \
                 input applied, in the model's unit",
                q.name, q.unit
            )));
        }
    }
    Ok(())
}

/// The units a request names for `field`, which must be the model's.
fn check_units(field: &str, units: Option<&[String]>, of: &[Quantity]) -> Result<(), ApiError> {
    let Some(units) = units else {
        return Ok(());
    };
    if units.len() != of.len() {
        return Err(ApiError::unprocessable(format!(
            "units.{field} names {} units; the model has {} quantities there",
            units.len(),
            of.len()
        )));
    }
    for (i, (unit, q)) in units.iter().zip(of).enumerate() {
        if normalise(unit) != normalise(&q.unit) {
            return Err(ApiError::unprocessable(format!(
                "units.{field}[{i}] is \"{unit}\"; the model's {} is in \"{}\": convert to the \
                 model's units (GET /model lists them)",
                q.name, q.unit
            )));
        }
    }
    Ok(())
}

/// A unit with its blanks collapsed: `W  m^-2` is `W m^-2`.
fn normalise(unit: &str) -> String {
    unit.split_whitespace().collect::<Vec<_>>().join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::{ControllerSpec, RunSpec};
    use crate::serve::api::Units;

    fn q(name: &str, unit: &str, bounds: Option<(f64, f64)>) -> Quantity {
        Quantity {
            name: name.into(),
            unit: unit.into(),
            lower: bounds.map(|b| b.0),
            upper: bounds.map(|b| b.1),
        }
    }

    fn info() -> ModelInfo {
        ModelInfo {
            model: "tank".into(),
            model_sha256: String::new(),
            controller: "expert".into(),
            spec: RunSpec {
                model: "tank.ghm".into(),
                weather: Default::default(),
                plant: Default::default(),
                controller: ControllerSpec::Expert,
            },
            sample_period_s: 60.0,
            forecast_rows: 2,
            states: vec![q("level", "m", None)],
            inputs: vec![q("inflow", "m s^-1", Some((0.0, 0.01)))],
            disturbances: vec![q("rain", "mm", None), q("temp", "°C", None)],
            outputs: vec![q("h", "m", None)],
        }
    }

    fn request() -> DecideRequest {
        DecideRequest {
            session: "house-1".into(),
            step: 3,
            state: vec![Some(1.0)],
            previous_input: vec![Some(0.005)],
            outputs: None,
            forecast: vec![vec![Some(0.0), Some(10.0)], vec![Some(0.5), Some(11.0)]],
            units: None,
        }
    }

    fn refused(r: &DecideRequest) -> String {
        let e = check(r, &info()).unwrap_err();
        assert_eq!(e.status.as_u16(), 422, "{}", e.message);
        e.message
    }

    #[test]
    fn a_request_that_fits_reads_as_plain_numbers() {
        let c = check(&request(), &info()).unwrap();
        assert_eq!(c.step, 3);
        assert_eq!(c.forecast, [0.0, 10.0, 0.5, 11.0]);
        assert_eq!(c.outputs, None);
    }

    #[test]
    fn each_misfit_is_named() {
        let mut r = request();
        r.state.push(Some(2.0));
        assert!(refused(&r).starts_with("state has 2 values; the model has 1 (level)"));

        let mut r = request();
        r.forecast[1][0] = None;
        assert!(refused(&r).starts_with("forecast[1][0] (rain [mm]) is null"));

        let mut r = request();
        r.previous_input[0] = Some(f64::NAN);
        assert!(refused(&r).contains("is NaN"));

        let mut r = request();
        r.forecast.pop();
        assert!(refused(&r).starts_with("forecast has 1 row; the controller needs 2"));

        let mut r = request();
        r.forecast[0].pop();
        assert!(refused(&r).starts_with("forecast[0] has 1 value; the model has 2"));

        let mut r = request();
        r.previous_input[0] = Some(5.0);
        assert!(refused(&r).contains("outside its bounds [0, 0.01] m s^-1"));

        let mut r = request();
        r.session = "a/b".into();
        assert!(refused(&r).starts_with("session \"a/b\""));

        let mut r = request();
        r.step = u64::MAX;
        assert!(refused(&r).contains("beyond the longest season"));

        let mut r = request();
        r.outputs = Some(vec![]);
        assert!(refused(&r).starts_with("outputs has 0 values"));
    }

    #[test]
    fn units_named_must_be_the_models() {
        let mut r = request();
        r.units = Some(Units {
            state: Some(vec!["m".into()]),
            previous_input: None,
            outputs: None,
            forecast: Some(vec!["mm".into(), "K".into()]),
        });
        assert!(
            refused(&r).starts_with("units.forecast[1] is \"K\"; the model's temp is in \"°C\"")
        );
        r.units = Some(Units {
            state: Some(vec!["m".into()]),
            previous_input: Some(vec!["m  s^-1".into()]),
            outputs: None,
            forecast: None,
        });
        assert!(check(&r, &info()).is_ok());
    }
}
