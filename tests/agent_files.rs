//! Policy and value files checked completely on load by the `ghm` binary: a broken file is
//! an error that names the file and the field, never a panic, and a file made for another
//! model's observation or state is refused.

mod common;

use common::bin::{ghm, temp_dir};
use serde_json::{json, Value};
use std::path::Path;

fn shipped(file: &str) -> Value {
    let text = std::fs::read_to_string(Path::new("models/agents/lettuce").join(file))
        .expect("shipped agent");
    serde_json::from_str(&text).expect("JSON")
}

fn write(path: &Path, value: &Value) -> String {
    std::fs::write(path, value.to_string()).expect("write");
    path.to_str().expect("utf-8").to_string()
}

/// `ghm command` on the shipped agent file `file` changed by `edit` (passed with `option`):
/// fails, naming the file and `field`.
fn refused(
    dir: &Path,
    command: &[&str],
    option: &str,
    file: &str,
    edit: &dyn Fn(&mut Value),
    field: &str,
) {
    let mut value = shipped(file);
    edit(&mut value);
    let path = write(&dir.join(file), &value);
    let out = dir.join("run");
    let mut args = command.to_vec();
    args.extend([
        option,
        &path,
        "--steps",
        "2",
        "--out",
        out.to_str().expect("utf-8"),
    ]);
    let (ok, err) = ghm(&args);
    assert!(!ok, "{field}: accepted");
    assert!(err.contains(&path) && err.contains(field), "{field}: {err}");
}

/// [`refused`] for `ghm policy --agent`.
fn refused_policy(dir: &Path, edit: impl Fn(&mut Value), field: &str) {
    let command = ["policy", "models/lettuce.ghm"];
    refused(dir, &command, "--agent", "policy.json", &edit, field);
}

/// [`refused`] for `ghm rlmpc --guide expert --value`.
fn refused_value(dir: &Path, edit: impl Fn(&mut Value), field: &str) {
    let command = ["rlmpc", "models/lettuce.ghm", "--guide", "expert"];
    refused(dir, &command, "--value", "value-expert.json", &edit, field);
}

#[test]
fn broken_policy_files_are_refused_naming_the_field() {
    let dir = temp_dir("agent-policy");
    std::fs::create_dir_all(&dir).expect("temp dir");
    // No layers at all, and a weight list shorter than the declared shape: both panicked.
    refused_policy(
        &dir,
        |p| p["actor"]["layers"] = json!([]),
        "\"layers\" is empty",
    );
    refused_policy(
        &dir,
        |p| {
            let w = p["actor"]["layers"][1]["weight"].as_array_mut().unwrap();
            w.truncate(10);
        },
        "layers[1]",
    );
    // Declared sizes that disagree with the weights ran.
    refused_policy(
        &dir,
        |p| p["actor"]["layers"][2]["inputs"] = json!(64),
        "layers[2]",
    );
    // Trained on another observation (names and order must be the model's).
    refused_policy(
        &dir,
        |p| p["observation_names"][2] = json!("temperature"),
        "observation_names",
    );
    refused_policy(
        &dir,
        |p| p["action_names"] = json!(["heating", "ventilation", "co2_supply"]),
        "inputs",
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_corrupt_shipped_policy_is_not_reported_as_missing() {
    let dir = temp_dir("agent-shipped");
    std::fs::create_dir_all(&dir).expect("temp dir");
    let model = dir.join("lettuce.ghm");
    std::fs::copy("models/lettuce.ghm", &model).expect("copy the model");
    let agents = dir.join("agents").join("lettuce");
    std::fs::create_dir_all(agents.join("builtin")).expect("agents folder");
    let mut policy = shipped("policy.json");
    policy["actor"]["layers"] = json!([]);
    let path = write(&agents.join("builtin").join("policy.json"), &policy);
    let out = dir.join("run");
    let (ok, err) = ghm(&[
        "policy",
        model.to_str().expect("utf-8"),
        "--steps",
        "2",
        "--out",
        out.to_str().expect("utf-8"),
    ]);
    assert!(!ok);
    assert!(!err.contains("no agent shipped"), "{err}");
    assert!(err.contains(&path) && err.contains("\"layers\""), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn broken_value_files_are_refused_naming_the_field() {
    let dir = temp_dir("agent-value");
    std::fs::create_dir_all(&dir).expect("temp dir");
    refused_value(
        &dir,
        |v| v["function"]["net"]["layers"] = json!([]),
        "\"layers\" is empty",
    );
    refused_value(
        &dir,
        |v| {
            let w = v["function"]["net"]["layers"][0]["weight"]
                .as_array_mut()
                .unwrap();
            w.pop();
        },
        "layers[0]",
    );
    refused_value(
        &dir,
        |v| v["function"]["input_upper"] = json!([1.0]),
        "input_upper",
    );
    refused_value(&dir, |v| v["state_index"] = json!(99), "state_index");
    refused_value(&dir, |v| v["state_name"] = json!("temp"), "state_name");
    let _ = std::fs::remove_dir_all(&dir);
}
