//! The model's own rules as a controller (`control::Rules`): an input without a rule is
//! named, and the rules read the state, this step's weather and the nominal parameters.

use ghm::control::{Controller, Observation, Rules};
use ghm::model::Plant;
use std::sync::Arc;

fn plant(text: &str) -> Arc<Plant> {
    Arc::new(Plant::new(ghm::lang::load_str("m.ghm", text).unwrap()))
}

#[test]
fn an_input_without_a_rule_is_named() {
    let p = plant(
        "model m\nstate x [-] = 1\ninput a [-] in [0, 1] rule 1 - x\ninput b [-] in [0, 1]\n\
         der x = a + b\nsample 1 [s]\n",
    );
    let e = Rules::new(p).unwrap_err();
    assert!(e.to_string().contains("these have none: b"), "{e}");
}

#[test]
fn rules_read_the_state_the_weather_and_the_parameters() {
    let p = plant(
        "model m\nparam k [-] = 2\nstate x [-] = 1\ndisturbance w [-] column \"w\"\n\
         input a [-] in [0, 10] rule k * x + w\nder x = a - x\nsample 1 [s]\n",
    );
    let mut rules = Rules::new(p).unwrap();
    let seen = Observation {
        step: 3,
        state: &[1.5],
        outputs: &[],
        previous_input: &[9.0],
        forecast: &[0.25, 7.0],
    };
    assert_eq!(rules.decide(&seen).unwrap().input, [3.25]);
    let short = Observation {
        forecast: &[],
        ..seen
    };
    assert!(rules.decide(&short).is_err());
}
