//! GreenLight's files for the tests that need them: its model folder (the installed
//! `greenlight==2.0.5` package's `models` folder, which `GHM_GREENLIGHT_MODELS` names)
//! and `ghm import greenlight` of its Katzin 2021 model with the Bleiswijk weather. The
//! repository cannot ship them; `.ci/run` installs GreenLight and sets the variable.

use std::io::Write;
use std::path::PathBuf;

/// GreenLight's `models` folder, where it holds Katzin 2021; `None` otherwise.
pub fn models() -> Option<PathBuf> {
    let path = PathBuf::from(std::env::var_os("GHM_GREENLIGHT_MODELS")?);
    path.join("katzin_2021/definition/main_katzin_2021.json")
        .is_file()
        .then_some(path)
}

/// GreenLight's `models` folder, or `None` after saying on standard error that `test`
/// skipped for want of it.
pub fn models_or_skip(test: &str) -> Option<PathBuf> {
    let found = models();
    if found.is_none() {
        let _ = writeln!(
            std::io::stderr(),
            "{test} skipped: needs GreenLight's model files and weather (pip install \
             greenlight==2.0.5; GHM_GREENLIGHT_MODELS); .ci/run provides them"
        );
    }
    found
}

/// `ghm import greenlight` of Katzin 2021 with its weather into a fresh folder.
#[cfg(feature = "cli")]
pub fn import(models: &std::path::Path, folder: &str, extra: &[&str]) -> PathBuf {
    let out = super::bin::temp_dir(folder);
    let imported = std::process::Command::new(env!("CARGO_BIN_EXE_ghm"))
        .args(["import", "greenlight"])
        .arg(models.join("katzin_2021/definition/main_katzin_2021.json"))
        .arg("--weather")
        .arg(models.join("katzin_2021/input_data/test_data/Bleiswijk_from_20091020.csv"))
        .arg("--out")
        .arg(&out)
        .args(extra)
        .output()
        .unwrap();
    assert!(
        imported.status.success(),
        "ghm import failed:\n{}",
        String::from_utf8_lossy(&imported.stderr)
    );
    out
}

/// The Bleiswijk weather of GreenLight's Katzin 2021, imported into a fresh folder
/// (`folder`), or `None` after saying that `test` skipped for want of GreenLight's files.
#[cfg(feature = "cli")]
pub fn weather_or_skip(test: &str, folder: &str) -> Option<PathBuf> {
    let models = models_or_skip(test)?;
    Some(import(&models, folder, &[]).join("weather.csv"))
}
