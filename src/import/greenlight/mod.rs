//! `ghm import greenlight`: a GreenLight model (its JSON files, resolved as GreenLight
//! 2.0.5 resolves them, [`json`]) written as a `.ghm` model ([`emit`], with the
//! expressions read by [`expr`]), and its weather CSV as a ghm weather CSV
//! ([`crate::import::weather`]). The text written is loaded with [`crate::lang::load_str`]
//! before anything is written: a model that does not load is an error with the
//! diagnostics, never a file.

pub mod emit;
pub mod expr;
pub mod json;

use crate::import::weather::{self, Table};
use crate::import::ImportError;
use crate::lang::model::Integrator;
use std::path::{Path, PathBuf};

/// The integrator an imported model is written with: GreenLight's models are stiff.
pub const DEFAULT_INTEGRATOR: &str = "radau5";

/// The five controls of Katzin 2021 that act (the other `u*` are constant 0 or copies).
pub const DEFAULT_INPUTS: [&str; 5] = ["uBoil", "uRoof", "uThScr", "uLamp", "uExtCo2"];

/// The licence line every imported file carries.
pub const LICENCE: &str = "Derived from GreenLight model files, © 2025 David Katzin, Wageningen Research Foundation, The Clear BSD License (BSD-3-Clause-Clear)";

/// What to import and how.
#[derive(Debug, Clone)]
pub struct Options {
    /// The main model file (e.g. `main_katzin_2021.json`).
    pub model: PathBuf,
    /// The weather CSV; `None`: the last `.csv` its `processing_order` names, if any.
    pub weather: Option<PathBuf>,
    /// The controls to make inputs; `None`: [`DEFAULT_INPUTS`], those the model has.
    pub inputs: Option<Vec<String>>,
    /// `sample … integrator NAME` (passed through; the language checks it).
    pub integrator: String,
    /// The sample period in seconds.
    pub step_s: f64,
    /// `substeps N`; `None`: 4 per 300 s for an implicit integrator (steps of 75 s, which
    /// meet issue 34's open-loop tolerances against GreenLight with a margin of 30 %:
    /// `tests/greenlight_openloop.rs`), 72 per 300 s for `rk4` and `euler` (steps of about
    /// 4.2 s, the stiff model's limit for explicit RK4).
    pub substeps: Option<usize>,
    /// The command line, for the file's header.
    pub command: Option<String>,
}

impl Options {
    /// Defaults for `model`: Katzin's five controls, [`DEFAULT_INTEGRATOR`], 300 s.
    pub fn new(model: impl Into<PathBuf>) -> Options {
        Options {
            model: model.into(),
            weather: None,
            inputs: None,
            integrator: DEFAULT_INTEGRATOR.into(),
            step_s: 300.0,
            substeps: None,
            command: None,
        }
    }
}

/// An imported model, checked, not yet written.
#[derive(Debug, Clone)]
pub struct Imported {
    /// The model's name (`main_katzin_2021.json` → `katzin_2021`).
    pub name: String,
    /// The `.ghm` text.
    pub text: String,
    /// The checked model.
    pub model: crate::lang::Model,
    /// The resolved GreenLight variables.
    pub resolved: json::Resolved,
    /// Statement counts.
    pub counts: emit::Counts,
    /// The weather file read, and its table.
    pub weather: Option<(PathBuf, Table)>,
    /// Things a user should know (renamings, columns taken, skipped entries).
    pub notes: Vec<String>,
}

/// Imports without writing anything.
pub fn convert(opts: &Options) -> Result<Imported, ImportError> {
    if !(opts.step_s.is_finite() && opts.step_s > 0.0) {
        return Err(ImportError::Argument(format!(
            "--step {} must be a positive number of seconds",
            opts.step_s
        )));
    }
    let resolved = json::resolve(&opts.model)?;
    let mut notes = Vec::new();
    for s in &resolved.ignored {
        notes.push(format!("processing_order entry `{s}` ignored (not a .json or .csv file), as GreenLight ignores it"));
    }
    let weather_path = opts
        .weather
        .clone()
        .or_else(|| resolved.csv_files.last().cloned());
    if opts.weather.is_none() {
        if let Some(p) = &weather_path {
            notes.push(format!(
                "weather: {} (named in the model's processing_order)",
                p.display()
            ));
        }
    }
    let table = match &weather_path {
        Some(p) => Some(weather::read(p)?.every(opts.step_s, p)?),
        None => None,
    };
    let inputs: Vec<String> = match &opts.inputs {
        Some(list) => list.clone(),
        None => {
            let have: Vec<String> = DEFAULT_INPUTS
                .iter()
                .filter(|n| resolved.get(n).is_some())
                .map(|n| n.to_string())
                .collect();
            if have.len() < DEFAULT_INPUTS.len() {
                notes.push(format!(
                    "the model has {} of the default inputs {} (give --inputs to choose others, --inputs none for none)",
                    if have.is_empty() { "none".to_string() } else { have.join(", ") },
                    DEFAULT_INPUTS.join(", ")
                ));
            }
            have
        }
    };
    let substeps = match opts.substeps {
        Some(n) => n,
        None => {
            let implicit =
                Integrator::from_name(&opts.integrator).is_none_or(Integrator::is_implicit);
            let per_300_s = if implicit { 4.0 } else { 72.0 };
            ((opts.step_s * per_300_s / 300.0).ceil() as usize).clamp(1, 1000)
        }
    };
    let name = model_name(&opts.model);
    let header = header(opts, &resolved, weather_path.as_deref());
    let mut emit_opts = emit::EmitOptions {
        model_name: name.clone(),
        inputs,
        weather_columns: table.as_ref().map(Table::data_columns).unwrap_or_default(),
        integrator: opts.integrator.clone(),
        step_s: opts.step_s,
        substeps,
        header,
        unused: Vec::new(),
    };
    let file = format!("{name}.ghm");
    // Emitted, loaded, and emitted again without the constants and lets the model does not
    // use (each leaving out may leave another unused), so that every run of the model is
    // not preceded by a page of warnings; they are listed at the end of the file.
    let (emitted, model) = loop {
        let emitted = emit::emit(&resolved, &emit_opts)?;
        let model =
            crate::lang::load_str(&file, &emitted.text).map_err(|f| ImportError::Check {
                file: file.clone(),
                report: f.render(),
            })?;
        let unused = unused_definitions(&model, &emitted);
        if unused.is_empty() || emit_opts.unused.len() > resolved.vars.len() {
            break (emitted, model);
        }
        emit_opts.unused.extend(unused);
        emit_opts.unused.sort();
    };
    for (from, to) in &emitted.renamed {
        notes.push(format!(
            "`{from}` renamed `{to}` (reserved in the .ghm language)"
        ));
    }
    for c in &emitted.columns_taken {
        notes.push(format!("`{c}` is a weather column: written as a disturbance, as GreenLight replaces it by the data"));
    }
    if let Some(t) = &table {
        let declared: Vec<&str> = resolved.vars.iter().map(|v| v.name.as_str()).collect();
        for c in t.data_columns() {
            if !declared.contains(&c.as_str()) {
                notes.push(format!(
                    "weather column `{c}` is no variable of the model (copied, unused)"
                ));
            }
        }
    }
    Ok(Imported {
        name,
        text: emitted.text,
        model,
        resolved,
        counts: emitted.counts,
        weather: weather_path.zip(table),
        notes,
    })
}

/// The constants and lets (GreenLight names) that `model`, loaded from `emitted`, warns
/// are never used (W001).
fn unused_definitions(model: &crate::lang::Model, emitted: &emit::Emitted) -> Vec<String> {
    model
        .warnings
        .iter()
        .filter(|d| {
            d.code == "W001"
                && (d.message.starts_with("constant ") || d.message.starts_with("let "))
        })
        .filter_map(|d| emitted.text.get(d.span.start..d.span.end))
        .map(|written| {
            emitted
                .renamed
                .iter()
                .find(|(_, to)| to == written)
                .map_or(written.to_string(), |(from, _)| from.clone())
        })
        .collect()
}

/// Writes `DIR/<name>.ghm` and, with weather, `DIR/weather.csv`; returns the paths.
pub fn write(imported: &Imported, dir: &Path) -> Result<Vec<PathBuf>, ImportError> {
    let err = |path: &Path| {
        let path = path.to_path_buf();
        move |source| ImportError::Write { path, source }
    };
    std::fs::create_dir_all(dir).map_err(err(dir))?;
    let mut written = Vec::new();
    let model = dir.join(format!("{}.ghm", imported.name));
    std::fs::write(&model, &imported.text).map_err(err(&model))?;
    written.push(model);
    if let Some((_, table)) = &imported.weather {
        let path = dir.join("weather.csv");
        std::fs::write(&path, table.to_ghm_csv()).map_err(err(&path))?;
        written.push(path);
    }
    Ok(written)
}

/// `main_katzin_2021.json` → `katzin_2021`: the file's stem without `main_`, as a name.
pub fn model_name(path: &Path) -> String {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().to_string())
        .unwrap_or_default();
    let stem = stem.strip_prefix("main_").unwrap_or(&stem);
    let mut name: String = stem
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if !name.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_') {
        name.insert_str(0, "m_");
    }
    if crate::lang::parse::is_reserved(&name) {
        name.push_str("_gl");
    }
    name
}

/// The GreenLight version, read from the `greenlight-X.dist-info` folder next to the
/// package that holds `path`, if there is one.
fn greenlight_version(path: &Path) -> Option<String> {
    let path = path.canonicalize().ok()?;
    let package = path
        .ancestors()
        .find(|a| a.file_name().is_some_and(|n| n == "greenlight"))?;
    let site = package.parent()?;
    let mut found = None;
    for entry in std::fs::read_dir(site).ok()?.flatten() {
        let n = entry.file_name().to_string_lossy().to_string();
        if let Some(v) = n
            .strip_prefix("greenlight-")
            .and_then(|r| r.strip_suffix(".dist-info"))
        {
            found = Some(v.to_string());
        }
    }
    found
}

/// A path as shown in the header: from the `greenlight` package folder on, else as given.
fn shown(path: &Path) -> String {
    let parts: Vec<String> = path
        .components()
        .map(|c| c.as_os_str().to_string_lossy().to_string())
        .collect();
    match parts.iter().rposition(|p| p == "greenlight") {
        Some(i) => parts[i..].join("/"),
        None => path.display().to_string(),
    }
}

fn header(opts: &Options, resolved: &json::Resolved, weather: Option<&Path>) -> Vec<String> {
    let version = greenlight_version(&opts.model)
        .map(|v| format!("GreenLight {v}"))
        .unwrap_or_else(|| "GreenLight (version not found next to the files)".into());
    let mut h = vec![format!(
        "Imported by `ghm import greenlight` from the model files of {version}:"
    )];
    for f in &resolved.files {
        h.push(format!("- {}", shown(f)));
    }
    if let Some(w) = weather {
        h.push(format!(
            "Weather columns from {} (disturbances read from weather.csv)",
            shown(w)
        ));
    }
    if let Some(c) = &opts.command {
        h.push(format!("Command: {c}"));
    }
    h.push(String::new());
    h.push(LICENCE.to_string());
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Writes `json` as `main_<name>.json` in a fresh folder; returns its path.
    fn model(name: &str, json: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("ghm-import-gl-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        let p = d.join(format!("main_{name}.json"));
        std::fs::write(&p, json).unwrap();
        p
    }

    const SMALL: &str = r#"{
      "States": {
        "temp": {"type": "state", "definition": "(heat - loss * (temp - tOut)) / cap", "init": "15", "unit": "°C", "description": "air \"temperature\"", "reference": "Book, Eq. 1"},
        "value": {"type": "state", "definition": "ifElse(temp > 20, 1, 0) + ifElse(heat, 2, 3) + logical_and(heat, temp < 30)", "init": "0", "unit": "W m**-2"}
      },
      "Parameters": {
        "loss": {"type": "const", "definition": "6.1", "reference": "Table 1"},
        "cap": {"type": "const", "definition": "hAir * 1.2e3"},
        "hAir": {"type": "const", "definition": "4 * elev0"},
        "elev0": {"type": "const", "definition": "2"},
        "airDens": {"type": "const", "definition": "1.2 * exp(-hElevation / 8000)"},
        "hElevation": {"type": "const", "definition": "0", "unit": "m"}
      },
      "Controls": {"heat": {"type": "aux", "definition": "max(0, 20 - temp) * airDens", "unit": "-"},
                   "power": {"type": "aux", "definition": "100 * heat", "unit": "W m**-2"}},
      "Functions": {
        "ifElse(condition, ifTrue, ifFalse)": {"type": "function", "definition": "condition*ifTrue + (1-condition)*ifFalse"},
        "max(a,b)": {"type": "function", "definition": "(a>b)*a + (b>=a)*b"}
      },
      "Inputs": {"tOut": {"type": "input", "definition": "10", "unit": "°C"}},
      "Time": {"type": "time", "unit": "s"}
    }"#;

    #[test]
    fn a_small_model_becomes_a_checked_ghm_file() {
        let main = model("small", SMALL);
        let weather = main.with_file_name("w.csv");
        std::fs::write(&weather, "Time,tOut,hElevation\nTime since start,outdoor temperature,elevation\ns,\u{b0}C,m\n0,5,-5\n300,6,-5\n").unwrap();
        let mut opts = Options::new(&main);
        opts.weather = Some(weather);
        opts.inputs = Some(vec!["heat".into()]);
        let imp = convert(&opts).unwrap();
        let t = &imp.text;
        assert_eq!(imp.name, "small");
        assert!(t.contains(LICENCE));
        assert!(
            t.contains("sample 300 [s] integrator radau5 substeps 4"),
            "{t}"
        );
        assert!(t.contains("# Book, Eq. 1\nstate temp [°C] = 15 \"air 'temperature'\"\nder temp = (heat - loss * (temp - tOut)) / cap\n"), "{t}");
        // A reserved name is renamed, ifElse of a comparison is `if`, of anything else
        // GreenLight's formula; logical_and reads numpy's truth.
        assert!(t.contains("state value_gl [W m^-2] = 0"), "{t}");
        assert!(t.contains("der value_gl = if(temp > 20, 1, 0) + (heat * 2 + (1 - heat) * 3) + (heat != 0 and temp < 30)"), "{t}");
        assert!(t.contains("const loss = 6.1 source \"Table 1\""), "{t}");
        assert!(t.contains("const cap = hAir * 1.2e3"), "{t}");
        // A const reading a weather column is a let; the column itself a disturbance.
        assert!(
            t.contains("let airDens = 1.2 * exp(-hElevation / 8000)"),
            "{t}"
        );
        assert!(
            t.contains("disturbance hElevation [m] column \"hElevation\" value 0"),
            "{t}"
        );
        assert!(
            t.contains("disturbance tOut [°C] column \"tOut\" value 10"),
            "{t}"
        );
        assert!(
            t.contains(
                "input heat [-] in [0, 1] start 0.5\n    rule max(0, 20 - temp) * airDens\n"
            ),
            "{t}"
        );
        assert!(t.contains("# Time: GreenLight's time axis"), "{t}");
        assert!(!t.contains("fn "), "ifElse and max are built-ins: {t}");
        let c = &imp.counts;
        assert_eq!(
            (
                c.states,
                c.inputs,
                c.disturbances,
                c.consts,
                c.lets_from_const
            ),
            (2, 1, 2, 4, 1)
        );
        assert_eq!((c.builtin_functions, c.skipped, c.outputs), (2, 1, 0));
        let m = &imp.model;
        assert_eq!(m.weather_columns(), ["hElevation", "tOut"]);
        assert_eq!(m.initial_state(), [15.0, 0.0]);
        assert!(
            imp.notes
                .iter()
                .any(|n| n.contains("value") && n.contains("value_gl")),
            "{:?}",
            imp.notes
        );

        // Closed loop: no inputs, the rule stays a let.
        opts.inputs = Some(Vec::new());
        let imp = convert(&opts).unwrap();
        assert!(
            imp.text
                .contains("let heat [-] = max(0, 20 - temp) * airDens"),
            "{}",
            imp.text
        );
        assert!(imp.model.inputs.is_empty());
        let closed = imp;

        // A control with a unit gets no bounds.
        opts.inputs = Some(vec!["power".into()]);
        let imp = convert(&opts).unwrap();
        assert!(imp.text.contains("input power [W m^-2]\n"), "{}", imp.text);
        assert_eq!(imp.model.inputs[0].upper, f64::INFINITY);
        let imp = closed;

        // Written: the model and the weather.
        let out = main.with_file_name("out");
        let written = write(&imp, &out).unwrap();
        assert_eq!(written, [out.join("small.ghm"), out.join("weather.csv")]);
        let csv = std::fs::read_to_string(out.join("weather.csv")).unwrap();
        assert_eq!(csv, "time_s,tOut,hElevation\n0,5,-5\n300,6,-5\n");
        crate::lang::load(&out.join("small.ghm")).unwrap();
        std::fs::remove_dir_all(main.parent().unwrap()).unwrap();
    }

    #[test]
    fn refusals_name_the_file_the_variable_and_the_construct() {
        let cases = [
            (
                r#"{"a": {"type": "aux", "definition": "b % 2"}, "b": {"type": "const", "definition": "1"}}"#,
                "variable `a`: definition `b % 2`: the operator `%`",
            ),
            (
                r#"{"a": {"type": "aux", "definition": "np.exp(1)"}}"#,
                "variable `a`: definition `np.exp(1)`: attribute access",
            ),
            (
                r#"{"a": {"type": "aux", "definition": "foo(1)"}}"#,
                "variable `a`: definition `foo(1)`: unknown function `foo`",
            ),
            (
                r#"{"a": {"type": "aux", "definition": "arcsin(1)"}}"#,
                "`arcsin` has no equivalent",
            ),
            (
                r#"{"a": {"type": "aux", "definition": "exp(1, 2)"}}"#,
                "`exp` takes 1 argument(s), given 2",
            ),
            (
                r#"{"a": {"type": "aux", "definition": "nope + 1"}}"#,
                "variable `a`: definition `nope + 1`: `nope` is not declared",
            ),
            (
                r#"{"x": {"type": "state", "definition": "1", "init": "x0 x1"}}"#,
                "variable `x`: init `x0 x1`",
            ),
            (
                r#"{"x": {"type": "state", "definition": "1"}}"#,
                "variable `x`: a state needs an `init`",
            ),
            (
                r#"{"a": {"type": "aux", "definition": "Time"}, "Time": {"type": "time"}}"#,
                "time axis",
            ),
        ];
        for (i, (json, needle)) in cases.iter().enumerate() {
            let main = model(&format!("refuse{i}"), json);
            let e = convert(&Options::new(&main)).unwrap_err().to_string();
            assert!(e.contains(needle), "{json}\n{e}");
            assert!(
                e.contains(&format!("main_refuse{i}.json")),
                "the file is named: {e}"
            );
            std::fs::remove_dir_all(main.parent().unwrap()).unwrap();
        }
        let main = model("inputs", SMALL);
        let mut opts = Options::new(&main);
        opts.inputs = Some(vec!["nope".into()]);
        let e = convert(&opts).unwrap_err().to_string();
        assert!(e.starts_with("--inputs: `nope` is not a variable"), "{e}");
        opts.inputs = Some(vec!["temp".into()]);
        let e = convert(&opts).unwrap_err().to_string();
        assert!(e.contains("`temp` is a state"), "{e}");
        opts.inputs = None;
        opts.step_s = -1.0;
        assert!(convert(&opts).unwrap_err().to_string().contains("--step"));
        // An integrator the language does not know: the load fails, nothing is written.
        opts.step_s = 300.0;
        opts.integrator = "magic".into();
        let e = convert(&opts).unwrap_err().to_string();
        assert!(e.contains("does not load") && e.contains("magic"), "{e}");
        std::fs::remove_dir_all(main.parent().unwrap()).unwrap();
    }

    #[test]
    fn names_of_models() {
        assert_eq!(
            model_name(Path::new("a/main_katzin_2021.json")),
            "katzin_2021"
        );
        assert_eq!(model_name(Path::new("evh-2003.json")), "evh_2003");
        assert_eq!(model_name(Path::new("2003.json")), "m_2003");
    }
}
