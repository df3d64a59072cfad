//! `ghm._ghm`: the Rust half of the Python package.
//!
//! It exposes ghm's reinforcement-learning environment ([`ghm::rl::Env`]), a model's
//! declarations, and seasons and controllers of ghm's job layer ([`controllers`]) to
//! Python; the Gymnasium classes around them live in
//! `python/python/ghm/__init__.py`. Arrays cross the boundary as NumPy `float64` arrays.
//! Every error becomes a Python exception carrying ghm's own message (a bad model's
//! diagnostics with file, line and column): [`ModelError`] for a model that does not
//! check, `ValueError` for bad arguments and data, [`DivergedError`] (a `RuntimeError`) for a step whose state diverged.

mod controllers;

use ghm::agent::observation::ObservationLayout;
use ghm::model::Plant;
use ghm::rl::{Env, RlError};
use ghm::sim::season::{UncertaintyDraw, MAX_SEASON_STEPS};
use ghm::sim::weather_source::{season_weather, WeatherSource};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::{Path, PathBuf};
use std::sync::Arc;

create_exception!(
    _ghm,
    ModelError,
    pyo3::exceptions::PyValueError,
    "A .ghm model that does not check; the message holds ghm's diagnostics."
);

create_exception!(
    _ghm,
    DivergedError,
    pyo3::exceptions::PyRuntimeError,
    "A step whose state is no longer a finite number: the episode is over (`Env.step` ends it)."
);

/// Loads and checks a model, its diagnostics rendered into the exception's message.
fn load_plant(path: &Path) -> PyResult<Arc<Plant>> {
    let model = ghm::lang::load(path).map_err(|e| ModelError::new_err(e.render()))?;
    Ok(Arc::new(Plant::new(model)))
}

/// An environment error as the Python exception that says what it is.
fn rl_error(e: RlError) -> PyErr {
    match e {
        RlError::Diverged { .. } => DivergedError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// The season length in steps of `days` days of `plant`'s sample period.
fn season_steps(plant: &Plant, days: f64) -> PyResult<usize> {
    let steps = (days * 86400.0 / plant.model.sample_period).round();
    // Refused before anything is allocated, with the command line's limit.
    if !(1.0..=MAX_SEASON_STEPS as f64).contains(&steps) {
        return Err(PyValueError::new_err(format!(
            "days = {days} gives {steps} steps of {} s; a season needs 1 to {MAX_SEASON_STEPS} steps",
            plant.model.sample_period
        )));
    }
    Ok(steps as usize)
}

/// One environment of the model at `model`, built from the Python arguments (shared by
/// `RawEnv` and `RawVecEnv`).
#[allow(clippy::too_many_arguments)]
fn build_env(
    model: &Path,
    weather: Option<PathBuf>,
    start_row: usize,
    days: f64,
    uncertainty: f64,
    seed: u64,
    weather_seed: u64,
    forecast_rows: usize,
) -> PyResult<Env> {
    if !(0.0..1.0).contains(&uncertainty) {
        return Err(PyValueError::new_err(format!(
            "uncertainty = {uncertainty}: the relative parameter spread must be in [0, 1)"
        )));
    }
    if forecast_rows > ObservationLayout::MAX_FORECAST_ROWS {
        return Err(PyValueError::new_err(format!(
            "forecast_rows = {forecast_rows}: an observation holds at most {} rows of forecast",
            ObservationLayout::MAX_FORECAST_ROWS
        )));
    }
    let plant = load_plant(model)?;
    let steps = season_steps(&plant, days)?;
    let source = match weather {
        Some(path) => WeatherSource::Csv(path),
        None => WeatherSource::Builtin { seed: weather_seed },
    };
    // The rows past the season's end that its last observations read, as a season of
    // the job layer loads them.
    let weather = season_weather(&plant.model, &source, start_row, steps + forecast_rows)
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let draw = (uncertainty > 0.0).then_some(UncertaintyDraw {
        delta: uncertainty,
        seed,
    });
    let mut env = Env::new(plant, weather, steps, draw)
        .map_err(rl_error)?
        .observing(ObservationLayout::with_forecast(forecast_rows));
    env.reseed(seed);
    Ok(env)
}

/// One episodic environment over a `.ghm` model (see `ghm.Env` for the Gymnasium class).
#[pyclass(module = "ghm._ghm")]
struct RawEnv {
    env: Env,
}

#[pymethods]
impl RawEnv {
    #[new]
    #[pyo3(signature = (model, weather=None, start_row=0, days=40.0, uncertainty=0.0, seed=0, weather_seed=2014, forecast_rows=0))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        model: PathBuf,
        weather: Option<PathBuf>,
        start_row: usize,
        days: f64,
        uncertainty: f64,
        seed: u64,
        weather_seed: u64,
        forecast_rows: usize,
    ) -> PyResult<RawEnv> {
        let env = build_env(
            &model,
            weather,
            start_row,
            days,
            uncertainty,
            seed,
            weather_seed,
            forecast_rows,
        )?;
        Ok(RawEnv { env })
    }

    /// Restarts the environment's random stream as a new environment with `seed` would.
    fn reseed(&mut self, seed: u64) {
        self.env.reseed(seed);
    }

    /// Starts an episode; returns the first observation.
    fn reset<'py>(&mut self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.env.reset().to_vec().into_pyarray(py)
    }

    /// Applies `action` (in [-1, 1] per input); returns
    /// `(observation, reward, economic, done, input)`.
    #[allow(clippy::type_complexity)]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        action: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<(
        Bound<'py, PyArray1<f64>>,
        f64,
        f64,
        bool,
        Bound<'py, PyArray1<f64>>,
    )> {
        let action = action.as_slice()?;
        let t = self.env.step(action).map_err(rl_error)?;
        Ok((
            t.observation.to_vec().into_pyarray(py),
            t.reward,
            t.economic,
            t.done,
            t.input.to_vec().into_pyarray(py),
        ))
    }

    #[getter]
    fn observation_names(&self) -> Vec<String> {
        self.env.observation_names()
    }

    #[getter]
    fn action_names(&self) -> Vec<String> {
        self.env.action_names()
    }

    #[getter]
    fn episode_len(&self) -> usize {
        self.env.episode_len()
    }

    #[getter]
    fn state<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.env.state().to_vec().into_pyarray(py)
    }

    #[getter]
    fn step_index(&self) -> usize {
        self.env.step_index()
    }
}

/// Many environments of one model stepped together: one call steps them all, and an
/// environment whose episode ended starts the next one at once (the observation returned
/// for it is the new episode's first).
#[pyclass(module = "ghm._ghm")]
struct RawVecEnv {
    envs: Vec<Env>,
    obs_len: usize,
    nu: usize,
}

#[pymethods]
impl RawVecEnv {
    #[new]
    #[pyo3(signature = (model, count, weather=None, start_row=0, days=40.0, uncertainty=0.0, seed=0, weather_seed=2014, forecast_rows=0))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        model: PathBuf,
        count: usize,
        weather: Option<PathBuf>,
        start_row: usize,
        days: f64,
        uncertainty: f64,
        seed: u64,
        weather_seed: u64,
        forecast_rows: usize,
    ) -> PyResult<RawVecEnv> {
        if !(1..=65536).contains(&count) {
            return Err(PyValueError::new_err(format!(
                "count = {count}: a vector of environments holds 1 to 65 536"
            )));
        }
        let first = build_env(
            &model,
            weather,
            start_row,
            days,
            uncertainty,
            seed,
            weather_seed,
            forecast_rows,
        )?;
        let (obs_len, nu) = (first.observation_len(), first.action_len());
        // Environment i draws its parameters from seed + i.
        let envs = (0..count as u64)
            .map(|i| {
                let mut env = first.clone();
                env.reseed(seed.wrapping_add(i));
                env
            })
            .collect();
        Ok(RawVecEnv { envs, obs_len, nu })
    }

    /// Reseeds environment i with `seed + i`.
    fn reseed(&mut self, seed: u64) {
        for (i, env) in self.envs.iter_mut().enumerate() {
            env.reseed(seed.wrapping_add(i as u64));
        }
    }

    /// Starts every episode; returns the observations, one row per environment.
    fn reset<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let mut rows = Vec::with_capacity(self.envs.len() * self.obs_len);
        for env in &mut self.envs {
            rows.extend_from_slice(env.reset());
        }
        numpy::ndarray::Array2::from_shape_vec((self.envs.len(), self.obs_len), rows)
            .map(|a| a.into_pyarray(py))
            .map_err(|e| PyValueError::new_err(e.to_string()))
    }

    /// Steps every environment with its row of `actions`; returns
    /// `(observations, rewards, dones)` (an ended episode is reset in the same call).
    #[allow(clippy::type_complexity)]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        actions: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<(
        Bound<'py, PyArray2<f64>>,
        Bound<'py, PyArray1<f64>>,
        Bound<'py, PyArray1<bool>>,
    )> {
        let actions = actions.as_array();
        if actions.dim() != (self.envs.len(), self.nu) {
            return Err(PyValueError::new_err(format!(
                "actions of shape {:?}; expected ({}, {})",
                actions.dim(),
                self.envs.len(),
                self.nu
            )));
        }
        let n = self.envs.len();
        let mut observations = Vec::with_capacity(n * self.obs_len);
        let mut rewards = Vec::with_capacity(n);
        let mut dones = Vec::with_capacity(n);
        let mut action = vec![0.0; self.nu];
        for (env, row) in self.envs.iter_mut().zip(actions.rows()) {
            for (a, &v) in action.iter_mut().zip(row.iter()) {
                *a = v;
            }
            // A season whose state diverged ends here, as one that ran out: done, with no
            // reward for the step that could not be taken, and reset.
            let (reward, done) = match env.step(&action) {
                Ok(t) => (t.reward, t.done),
                Err(RlError::Diverged { .. }) => (0.0, true),
                Err(e) => return Err(rl_error(e)),
            };
            rewards.push(reward);
            dones.push(done);
            if done {
                observations.extend_from_slice(env.reset());
            } else {
                observations.extend_from_slice(env.observation());
            }
        }
        let observations = numpy::ndarray::Array2::from_shape_vec((n, self.obs_len), observations)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok((
            observations.into_pyarray(py),
            rewards.into_pyarray(py),
            dones.into_pyarray(py),
        ))
    }

    #[getter]
    fn count(&self) -> usize {
        self.envs.len()
    }
}

/// A model's declarations as a dictionary: `name`, `sample_period_s`, and `states`,
/// `inputs`, `disturbances`, `outputs`, `params`, each a list of dictionaries with `name`,
/// `unit` and `description` (and bounds, initial or nominal values where they have them).
#[pyfunction]
fn load<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyDict>> {
    let plant = load_plant(&path)?;
    let model = &plant.model;
    let info = |info: &ghm::lang::model::Info| -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("name", &info.name)?;
        d.set_item("unit", &info.unit)?;
        d.set_item("description", &info.description)?;
        Ok(d)
    };
    let out = PyDict::new(py);
    out.set_item("name", &model.name)?;
    out.set_item("description", &model.description)?;
    out.set_item("sample_period_s", model.sample_period)?;
    let mut states = Vec::new();
    for s in &model.states {
        let d = info(&s.info)?;
        d.set_item("initial", s.initial)?;
        states.push(d);
    }
    out.set_item("states", states)?;
    let mut inputs = Vec::new();
    for u in &model.inputs {
        let d = info(&u.info)?;
        d.set_item("lower", u.lower)?;
        d.set_item("upper", u.upper)?;
        d.set_item("rate", u.rate)?;
        d.set_item("start", u.start)?;
        inputs.push(d);
    }
    out.set_item("inputs", inputs)?;
    let mut disturbances = Vec::new();
    for w in &model.disturbances {
        let d = info(&w.info)?;
        d.set_item("column", w.column.clone())?;
        d.set_item("value", w.value)?;
        disturbances.push(d);
    }
    out.set_item("disturbances", disturbances)?;
    let mut outputs = Vec::new();
    for y in &model.outputs {
        outputs.push(info(&y.info)?);
    }
    out.set_item("outputs", outputs)?;
    let mut params = Vec::new();
    for p in &model.params {
        let d = info(&p.info)?;
        d.set_item("value", p.value)?;
        params.push(d);
    }
    out.set_item("params", params)?;
    Ok(out)
}

#[pymodule]
fn _ghm(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<RawEnv>()?;
    m.add_class::<RawVecEnv>()?;
    m.add_class::<controllers::RawController>()?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(controllers::season, m)?)?;
    m.add_function(wrap_pyfunction!(controllers::controller_defaults, m)?)?;
    m.add("ModelError", m.py().get_type::<ModelError>())?;
    m.add("DivergedError", m.py().get_type::<DivergedError>())?;
    Ok(())
}
