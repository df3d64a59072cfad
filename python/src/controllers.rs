//! Seasons and controllers from Python. The Python classes (`ghm.Mpc`, `ghm.RlMpc`,
//! `ghm.Policy`, `ghm.simulate`, ...) write a job spec of ghm's job layer as JSON; a
//! season of it runs in memory ([`season`]: the same season as the command with the same
//! settings), or its controller is driven step by step ([`RawController`]).

use crate::ModelError;
use ghm::control::{LimitPolicy, StepRequest, SteppedController, Stepper};
use ghm::job::output::{numeric_fields, text_fields, trajectory_header, TEXT_COLUMNS};
use ghm::job::{
    build_controller, run_season_logs, Choice, ControllerKind, ControllerSpec, JobError, RunSpec,
    SeasonLogs, StandaloneController,
};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A job error as the Python exception that says what it is.
fn job_error(e: JobError) -> PyErr {
    match e {
        JobError::Model(text) => ModelError::new_err(text),
        JobError::Simulation(_) | JobError::NoSolveSucceeded(_) => {
            PyRuntimeError::new_err(e.to_string())
        }
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// The settings of a controller of `kind` (`"mpc"`, `"rlmpc"`, ...) at ghm's defaults, as
/// JSON: the Python classes start from these, so every default is the one ghm states.
#[pyfunction]
pub fn controller_defaults(kind: &str) -> PyResult<String> {
    let kind = ControllerKind::from_name(kind).ok_or_else(|| {
        let kinds: Vec<&str> = ControllerKind::ALL.iter().map(|k| k.name()).collect();
        PyValueError::new_err(format!(
            "no controller kind `{kind}` (one of {})",
            kinds.join(", ")
        ))
    })?;
    serde_json::to_string(&ControllerSpec::default_of(kind))
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))
}

/// The spec the Python classes wrote.
fn parse_spec(json: &str) -> PyResult<RunSpec> {
    serde_json::from_str(json).map_err(|e| PyValueError::new_err(format!("ghm settings: {e}")))
}

/// Numeric column names, their values, the text columns, the metrics (JSON).
type SeasonArrays<'py> = (
    Vec<String>,
    Bound<'py, PyArray2<f64>>,
    Vec<Vec<String>>,
    String,
);

/// One season of the spec `spec` (JSON), in memory: the names of the numeric columns of
/// `trajectory.csv`, their values (steps × columns), the text columns (`status`,
/// `fallback`, `terminal_region`, one list each) and the season's metrics (JSON, as in
/// `summary.json`). The interpreter is free while the season runs.
#[pyfunction]
pub fn season<'py>(py: Python<'py>, spec: &str) -> PyResult<SeasonArrays<'py>> {
    let spec = parse_spec(spec)?;
    let SeasonLogs {
        plant,
        logs,
        metrics,
    } = py.detach(|| run_season_logs(&spec)).map_err(job_error)?;
    let header = trajectory_header(&plant);
    let names: Vec<String> = header[..header.len() - TEXT_COLUMNS.len()].to_vec();
    let period_h = plant.model.sample_period / 3600.0;
    let mut data = Vec::with_capacity(logs.len() * names.len());
    let mut texts = vec![Vec::with_capacity(logs.len()); TEXT_COLUMNS.len()];
    for log in &logs {
        data.extend(numeric_fields(log, period_h));
        for (column, text) in texts.iter_mut().zip(text_fields(log)) {
            column.push(text.to_string());
        }
    }
    let array = numpy::ndarray::Array2::from_shape_vec((logs.len(), names.len()), data)
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    let metrics =
        serde_json::to_string(&metrics).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    Ok((names, array.into_pyarray(py), texts, metrics))
}

/// A controller of the spec (JSON), driven one step at a time; it keeps its warm start
/// between calls, as in a season.
#[pyclass(module = "ghm._ghm", unsendable)]
pub struct RawController {
    spec: RunSpec,
    /// The controller with its plant and Python's stepper (the input clipped to its limits;
    /// a short forecast is the controller's to pad, as MPC repeats its last row).
    held: SteppedController,
    forecast_rows: usize,
}

#[pymethods]
impl RawController {
    #[new]
    fn new(spec: &str) -> PyResult<Self> {
        let spec = parse_spec(spec)?;
        let StandaloneController {
            plant,
            controller,
            forecast_rows,
        } = build_controller(&spec).map_err(job_error)?;
        Ok(RawController {
            spec,
            held: SteppedController::new(plant, controller, Stepper::new(LimitPolicy::Clip)),
            forecast_rows,
        })
    }

    /// Forgets the past (warm starts, plans): as built.
    fn reset(&mut self) -> PyResult<()> {
        let fresh = build_controller(&self.spec).map_err(job_error)?.controller;
        self.held.replace_controller(fresh);
        Ok(())
    }

    /// Rows of weather forecast the controller reads ahead (its horizon; 0 for a policy).
    fn forecast_rows(&self) -> usize {
        self.forecast_rows
    }

    /// The controller's name in reports.
    fn name(&self) -> String {
        self.held.controller().name()
    }

    /// The input for step `step` at `state`, after `previous_input`, with the weather rows
    /// `forecast` (rows × the model's disturbances, row 0 = now); and how it was found.
    fn decide<'py>(
        &mut self,
        py: Python<'py>,
        step: usize,
        state: PyReadonlyArray1<'py, f64>,
        previous_input: PyReadonlyArray1<'py, f64>,
        forecast: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyDict>)> {
        let nd = self.held.plant().layout.nd;
        let forecast_view = forecast.as_array();
        let (rows, columns) = forecast_view.dim();
        if columns != nd {
            return Err(PyValueError::new_err(format!(
                "each forecast row has {columns} values; the model has {nd}"
            )));
        }
        if rows == 0 {
            return Err(PyValueError::new_err(
                "forecast has no row: it needs at least the weather now (row 0)",
            ));
        }
        let forecast: Vec<f64> = forecast_view.iter().copied().collect();
        let request = StepRequest {
            step,
            state: state.as_slice()?,
            measured_outputs: None,
            previous_input: previous_input.as_slice()?,
            forecast: &forecast,
        };
        // The controller is not `Send` (its solver is a trait object), so the interpreter is
        // held while it decides.
        let decision = self.held.decide(&request).map_err(|e| {
            if e.is_bad_request() {
                PyValueError::new_err(e.to_string())
            } else {
                PyRuntimeError::new_err(e.to_string())
            }
        })?;
        let record = PyDict::new(py);
        let r = &decision.record;
        record.set_item("solve_ms", r.solve_time_s * 1e3)?;
        record.set_item("iterations", r.iterations)?;
        record.set_item("inertia_corrections", r.inertia_corrections)?;
        record.set_item("status", r.status_name())?;
        record.set_item("fallback", r.fallback_name())?;
        record.set_item("terminal_region", r.terminal_region.clone())?;
        Ok((decision.input.into_pyarray(py), record))
    }
}
