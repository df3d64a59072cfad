//! `ghm import greenlight` on GreenLight's own Katzin 2021 model, when the GreenLight
//! package is installed: the imported model loads, has the expected states, inputs and
//! disturbances, and its state derivatives at the initial state (weather row 0, controls
//! at 0) equal GreenLight's own (`tests/greenlight/katzin_2021_derivatives.json`, made by
//! `tests/greenlight/make_derivative_fixture.py`) within 1e-9 relative.
//!
//! The GreenLight model folder is found by `tests/common/greenlight.rs`; without it the
//! tests print that they skipped and why.

mod common;

use ghm::import::greenlight::{convert, Options, DEFAULT_INPUTS};
use std::path::PathBuf;

/// GreenLight's model folder, or `None` (with the reason printed).
fn models() -> Option<PathBuf> {
    common::greenlight::models_or_skip("the GreenLight import test")
}

#[derive(serde::Deserialize)]
struct Fixture {
    greenlight: String,
    states: Vec<String>,
    initial: Vec<f64>,
    derivative: Vec<f64>,
}

#[test]
fn katzin_2021_imports_and_its_derivatives_match_greenlight() {
    let Some(dir) = models() else { return };
    let mut opts = Options::new(dir.join("katzin_2021/definition/main_katzin_2021.json"));
    opts.weather = Some(dir.join("katzin_2021/input_data/test_data/Bleiswijk_from_20091020.csv"));
    let imported = convert(&opts).unwrap_or_else(|e| panic!("{e}"));
    let m = &imported.model;
    assert_eq!(imported.name, "katzin_2021");
    assert_eq!(imported.resolved.vars.len(), 630);

    // 27 physical states and time_state.
    assert_eq!(m.states.len(), 28);
    assert!(m.states.iter().any(|s| s.info.name == "time_state"));
    let inputs: Vec<&str> = m.inputs.iter().map(|u| u.info.name.as_str()).collect();
    let mut sorted = inputs.clone();
    sorted.sort_unstable();
    let mut want = DEFAULT_INPUTS.to_vec();
    want.sort_unstable();
    assert_eq!(sorted, want);
    assert!(m.inputs.iter().all(|u| (u.lower, u.upper) == (0.0, 1.0)));
    let mut columns = m.weather_columns();
    columns.sort();
    let mut expected = [
        "tOut",
        "vpOut",
        "co2Out",
        "wind",
        "tSky",
        "tSoOut",
        "iGlob",
        "dayRadSum",
        "isDay",
        "isDaySmooth",
        "hElevation",
    ];
    expected.sort_unstable();
    assert_eq!(columns, expected);
    // Every input carries GreenLight's rule; the outputs are the seven readings a grower
    // looks at.
    assert!(m.inputs.iter().all(|u| u.rule.is_some()));
    let outputs: Vec<&str> = m.outputs.iter().map(|o| o.info.name.as_str()).collect();
    assert_eq!(
        outputs,
        [
            "air_temperature",
            "relative_humidity",
            "co2_concentration",
            "heating_power",
            "lamp_power",
            "fruit_dry_matter",
            "harvest_rate"
        ]
    );
    let c = &imported.counts;
    assert_eq!((c.states, c.inputs, c.disturbances), (28, 5, 11));
    assert_eq!(c.functions + c.builtin_functions, 15);
    assert_eq!(
        c.consts + c.lets_from_const + c.unused_consts + 1,
        266,
        "every const but hElevation"
    );
    assert_eq!(c.lets_from_aux + c.unused_auxes + c.inputs, 310);
    // Those the model does not use are left out, and listed: no run begins with warnings.
    assert_eq!((c.unused_consts, c.unused_auxes), (10, 3));
    assert!(imported.model.warnings.is_empty());
    assert!(imported
        .text
        .contains("Derived from GreenLight model files, © 2025 David Katzin"));

    // The derivatives at the initial state, weather row 0, controls 0.
    let fixture: Fixture =
        serde_json::from_str(include_str!("greenlight/katzin_2021_derivatives.json")).unwrap();
    assert_eq!(fixture.greenlight, "2.0.5");
    let (_, table) = imported.weather.as_ref().expect("the weather was read");
    let l = m.layout();
    let mut vars = vec![0.0; l.n_base()];
    for (i, s) in m.states.iter().enumerate() {
        vars[l.x(i)] = s.initial;
        let k = fixture
            .states
            .iter()
            .position(|n| *n == s.info.name)
            .unwrap();
        assert_eq!(s.initial, fixture.initial[k], "initial {}", s.info.name);
    }
    for (i, col) in m.weather_columns().iter().enumerate() {
        vars[l.d(i)] = table.value(0, col).unwrap();
    }
    for (i, p) in m.params.iter().enumerate() {
        vars[l.p(i)] = p.value;
    }
    let dx = m.graph.eval_f64(&m.derivatives, &vars);
    let mut worst = (0.0f64, String::new());
    for (i, s) in m.states.iter().enumerate() {
        let k = fixture
            .states
            .iter()
            .position(|n| *n == s.info.name)
            .unwrap();
        let (ours, theirs) = (dx[i], fixture.derivative[k]);
        assert!(ours.is_finite(), "{}: {ours}", s.info.name);
        let rel = (ours - theirs).abs() / theirs.abs().max(1e-300);
        let rel = if ours == theirs { 0.0 } else { rel };
        if rel > worst.0 {
            worst = (rel, s.info.name.clone());
        }
        assert!(
            rel <= 1e-9,
            "d{}/dt: ghm {ours:e}, GreenLight {theirs:e} (relative {rel:e})",
            s.info.name
        );
    }
    eprintln!("largest relative difference: {:e} ({})", worst.0, worst.1);
}

#[test]
fn van_henten_2003_imports_or_says_why_not() {
    let Some(dir) = models() else { return };
    let main = dir.join("van_henten_2003/definition/main_evh2003_setpoint_control.json");
    if !main.is_file() {
        eprintln!("SKIPPED: {} not found", main.display());
        return;
    }
    // Its processing_order names the weather with Windows separators (`..\\input_data\\…`).
    let mut opts = Options::new(&main);
    opts.inputs = Some(Vec::new());
    match convert(&opts) {
        Ok(imported) => {
            let m = &imported.model;
            let states: Vec<&str> = m.states.iter().map(|s| s.info.name.as_str()).collect();
            assert_eq!(states, ["X_d", "X_c", "X_T", "X_h"]);
            assert!(
                imported.weather.is_some(),
                "the CSV of the processing_order is read"
            );
            let mut cols = m.weather_columns();
            cols.sort();
            assert_eq!(cols, ["V_T", "V_c", "V_h", "V_rad"]);
        }
        Err(e) => {
            let text = e.to_string();
            assert!(
                text.contains("main_evh2003") || text.contains("evh2003"),
                "{text}"
            );
            panic!("van Henten 2003 does not import: {text}");
        }
    }
}
