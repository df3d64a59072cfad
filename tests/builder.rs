//! A plant built in Rust equals the same plant written in `.ghm`: every example plant
//! (`examples/custom_plant.rs`, `examples/lettuce_in_rust.rs`) and the CSTR, in what the
//! model declares and in the value, Jacobian and Hessian of its step; and the builder
//! refuses what the language refuses.

use ghm::lang::model::Info;
use ghm::model::{BuildError, ModelBuilder, Output, Plant, State, StepDerivatives};
use ghm::prelude::{if_else, Model, Uncertainty};
use ghm::sim::weather::builtin_season;

#[path = "../examples/custom_plant.rs"]
#[allow(dead_code)]
mod custom_plant;
#[path = "../examples/lettuce_in_rust.rs"]
#[allow(dead_code)]
mod lettuce_in_rust;

const ROOM_GHM: &str = r#"
model room "a heated room, 15-minute control"
state temp [°C] = 15 "room air"
input heat [W] in [0, 2000] rate 250 start 0 "heater power"
disturbance outside [°C] value 5
param capacity [J °C^-1] = 2e5 uncertain
param conductance [W °C^-1] = 40 uncertain
param price [EUR J^-1] = 0.3 / 3.6e6
der temp = (heat - conductance * (temp - outside)) / capacity
output room_temp [°C] = temp
cost energy [EUR] = price * heat * 900
soft room_temp in [19, 23] weight 0.01 "comfort band"
sample 900 [s] integrator rk4 substeps 2
"#;

fn load(path: &str) -> Model {
    ghm::lang::load(std::path::Path::new(path)).unwrap_or_else(|e| panic!("{}", e.render()))
}

/// Name, unit, description and source; where it was written is the file's business.
fn said(i: &Info) -> [String; 4] {
    [&i.name, &i.unit, &i.description, &i.source].map(|s| s.to_string())
}

/// Everything a model declares, but the graph: equal for a file and its Rust twin.
fn assert_same_declarations(file: &Model, code: &Model) {
    assert_eq!(
        (&file.name, &file.description),
        (&code.name, &code.description)
    );
    assert_eq!(file.layout(), code.layout());
    for (a, b) in file.states.iter().zip(&code.states) {
        assert_eq!((said(&a.info), a.initial), (said(&b.info), b.initial));
    }
    for (a, b) in file.inputs.iter().zip(&code.inputs) {
        let view = |u: &ghm::lang::model::InputDecl| {
            (
                said(&u.info),
                u.lower,
                u.upper,
                u.rate,
                u.start,
                u.rule.is_some(),
            )
        };
        assert_eq!(view(a), view(b));
    }
    for (a, b) in file.disturbances.iter().zip(&code.disturbances) {
        let view = |d: &ghm::lang::model::DisturbanceDecl| {
            (said(&d.info), d.column.clone(), d.value, d.clock)
        };
        assert_eq!(view(a), view(b));
    }
    for (a, b) in file.params.iter().zip(&code.params) {
        assert_eq!(
            (said(&a.info), a.value, a.kind),
            (said(&b.info), b.value, b.kind)
        );
    }
    let outputs = |m: &Model| m.outputs.iter().map(|o| said(&o.info)).collect::<Vec<_>>();
    assert_eq!(outputs(file), outputs(code));
    let terms = |m: &Model| {
        m.terms
            .iter()
            .map(|t| (said(&t.info), t.kind))
            .collect::<Vec<_>>()
    };
    assert_eq!(terms(file), terms(code));
    assert_eq!(file.soft, code.soft);
    assert_eq!(
        (file.sample_period, file.integrator, file.substeps),
        (code.sample_period, code.integrator, code.substeps)
    );
    assert_eq!(file.uncertainty, code.uncertainty);
}

/// `a` and `b` agree to 1e-12, entry by entry, relative to the larger of the two or to
/// 1e-12 of the array's largest entry, whichever is larger (as `tests/derivatives_casadi.rs`
/// measures): the two graphs number their nodes differently, so a Hessian entry that is a
/// sum of terms cancelling to 1e-16 of the largest is summed in another order.
fn assert_close(what: &str, a: &[f64], b: &[f64]) {
    assert_eq!(a.len(), b.len(), "{what}");
    let largest = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        let scale = x.abs().max(y.abs()).max(1e-12 * largest).max(1e-300);
        assert!((x - y).abs() <= 1e-12 * scale, "{what}[{i}]: {x} vs {y}");
    }
}

/// The step's values, Jacobian and Hessian (of a weighted sum of everything it returns)
/// with respect to every base input `(x, u, d, p)`, equal at each point `(x, u, d)`.
fn assert_same_step(file: &Plant, code: &Plant, points: &[Vec<f64>]) {
    let p = file.model.nominal_params();
    assert_eq!(p, code.model.nominal_params());
    let n = file.model.layout().n_base();
    let wrt: Vec<usize> = (0..n).collect();
    let (mut da, mut db) = (
        StepDerivatives::new(file, &wrt),
        StepDerivatives::new(code, &wrt),
    );
    for (k, point) in points.iter().enumerate() {
        let mut z = point.clone();
        z.extend(&p);
        let ea = da.jacobian(file, &z).clone();
        let weights: Vec<f64> = (0..ea.values.len())
            .map(|i| 1.0 + ((i + k) % 5) as f64)
            .collect();
        let ea = da.hessian(file, &z, &weights).clone();
        let eb = db.hessian(code, &z, &weights);
        assert_close(&format!("point {k}: values"), &ea.values, &eb.values);
        assert_close(&format!("point {k}: Jacobian"), &ea.jacobian, &eb.jacobian);
        assert_close(&format!("point {k}: Hessian"), &ea.hessian, &eb.hessian);
    }
}

/// `steps` points `(x, u, d)` along a trajectory of `plant` under inputs that sweep each
/// input's range, on the weather rows `weather(k)`.
fn trajectory(plant: &Plant, steps: usize, weather: impl Fn(usize) -> Vec<f64>) -> Vec<Vec<f64>> {
    let p = plant.model.nominal_params();
    let mut x = plant.model.initial_state();
    let mut points = Vec::with_capacity(steps);
    for k in 0..steps {
        let u: Vec<f64> = plant
            .model
            .inputs
            .iter()
            .enumerate()
            .map(|(i, d)| {
                let share = ((k * (7 + 3 * i)) % 23) as f64 / 22.0;
                d.lower + share * (d.upper - d.lower)
            })
            .collect();
        let d = weather(k);
        let mut point = x.clone();
        point.extend(&u);
        point.extend(&d);
        points.push(point);
        x = plant.step(&x, &u, &d, &p).next_state;
    }
    points
}

#[test]
fn the_room_of_the_example_is_its_ghm_twin() {
    let file = Plant::new(
        ghm::lang::load_str("room.ghm", ROOM_GHM).unwrap_or_else(|e| panic!("{}", e.render())),
    );
    let code = Plant::new(custom_plant::room().expect("the room builds"));
    assert_same_declarations(&file.model, &code.model);
    let points = trajectory(&file, 200, |_| vec![5.0]);
    assert_same_step(&file, &code, &points);
}

/// The lettuce greenhouse written in Rust is `models/lettuce.ghm`, over a 40-day season of
/// the built-in weather (1920 steps of 30 minutes).
#[test]
fn the_lettuce_in_rust_is_models_lettuce_ghm_over_a_season() {
    let file = Plant::new(load("models/lettuce.ghm"));
    let code = Plant::new(lettuce_in_rust::lettuce().expect("the lettuce builds"));
    assert_same_declarations(&file.model, &code.model);
    let steps = 40 * 48;
    let columns = file.model.weather_columns();
    let weather = builtin_season(steps, file.model.sample_period, 2014)
        .select(&columns, 0, steps)
        .expect("the built-in season has the lettuce's columns");
    let points = trajectory(&file, steps, |k| weather.at(k).to_vec());
    assert_same_step(&file, &code, &points);
}

/// The CSTR of `models/cstr.ghm`, as the physics reads.
fn cstr_in_code() -> Result<Model, BuildError> {
    let b = ModelBuilder::new("cstr");
    b.describe("exothermic A -> B CSTR (Henson & Seborg), 6-second set-point tracking of the unstable steady state");
    let (min_s, ca_sp, tc_ss, ca_scale, tc_scale) = (60.0, 0.5, 300.0, 0.01, 10.0);
    let ca = b.state("ca", 0.8772569);
    let temp = b.state("temp", 324.47544);
    let tc = b.input("tc").bounds(250.0, 350.0).rate(3.0).start(300.0);
    let [q, vol, caf, tf, rho, cp, dh, e_r, k0, ua] = [
        ("q", 100.0),
        ("vol", 100.0),
        ("caf", 1.0),
        ("tf", 350.0),
        ("rho", 1000.0),
        ("cp", 0.239),
        ("dh", -5e4),
        ("e_r", 8750.0),
        ("k0", 7.2e10),
        ("ua", 5e4),
    ]
    .map(|(name, value)| b.param(name, value));
    let reaction = k0 * (-e_r / temp).exp() * ca;
    b.der(ca, (q / vol * (caf - ca) - reaction) / min_s);
    b.der(
        temp,
        (q / vol * (tf - temp) - dh / (rho * cp) * reaction + ua / (vol * rho * cp) * (tc - temp))
            / min_s,
    );
    b.output("conc", ca);
    let t_reactor = b.output("t_reactor", temp);
    b.cost("tracking", ((ca.next() - ca_sp) / ca_scale).powi(2));
    b.cost("effort", 0.01 * ((tc - tc_ss) / tc_scale).powi(2));
    t_reactor
        .at_most(355.0)
        .weight(100.0)
        .plan(f64::NEG_INFINITY, 352.0);
    b.sample(6.0, 20);
    b.build()
}

/// The same CSTR with the explicit calls of the first builder (now thin wrappers).
fn cstr_in_explicit_calls() -> Model {
    use ghm::graph::Op;
    let b = ModelBuilder::new("cstr");
    let ca = b.state("ca", 0.8772569);
    let temp = b.state("temp", 324.47544);
    let tc = b.input("tc").bounds(250.0, 350.0).rate(3.0).start(300.0);
    let q = b.param("q", 100.0);
    let vol = b.param("vol", 100.0);
    let caf = b.param("caf", 1.0);
    let tf = b.param("tf", 350.0);
    let rho = b.param("rho", 1000.0);
    let cp = b.param("cp", 0.239);
    let dh = b.param("dh", -5e4);
    let e_r = b.param("e_r", 8750.0);
    let k0 = b.param("k0", 7.2e10);
    let ua = b.param("ua", 5e4);
    let min_s = b.constant(60.0);
    let ratio = b.div(e_r, temp);
    let minus = b.neg(ratio);
    let arrhenius = b.apply(Op::Exp, &[minus]);
    let rate = b.mul(k0, arrhenius);
    let reaction = b.mul(rate, ca);
    let dilution = b.div(q, vol);
    let feed_gap = b.sub(caf, ca);
    let inflow = b.mul(dilution, feed_gap);
    let net = b.sub(inflow, reaction);
    let dca = b.div(net, min_s);
    b.der(ca, dca);
    let tf_gap = b.sub(tf, temp);
    let feed_heat = b.mul(dilution, tf_gap);
    let rho_cp = b.mul(rho, cp);
    let dh_rcp = b.div(dh, rho_cp);
    let heat_release = b.mul(dh_rcp, reaction);
    let v_rho_cp = b.mul(vol, rho_cp);
    let jacket_coefficient = b.div(ua, v_rho_cp);
    let tc_gap = b.sub(tc, temp);
    let jacket = b.mul(jacket_coefficient, tc_gap);
    let sum = b.sub(feed_heat, heat_release);
    let sum = b.add(sum, jacket);
    let dtemp = b.div(sum, min_s);
    b.der(temp, dtemp);
    b.output("conc", ca);
    let y_t = b.output("t_reactor", temp);
    let two = b.constant(2.0);
    let ca_next = b.next(ca);
    let sp = b.constant(0.5);
    let dev = b.sub(ca_next, sp);
    let scale = b.constant(0.01);
    let dev = b.div(dev, scale);
    let tracking = b.pow(dev, two);
    b.cost("tracking", tracking);
    let tc_ss = b.constant(300.0);
    let move_ = b.sub(tc, tc_ss);
    let ten = b.constant(10.0);
    let move_ = b.div(move_, ten);
    let sq = b.pow(move_, two);
    let weight = b.constant(0.01);
    let effort = b.mul(weight, sq);
    b.cost("effort", effort);
    b.soft(y_t, f64::NEG_INFINITY, 355.0, 0.0, 100.0);
    assert!(
        !b.plan(f64::NEG_INFINITY, 360.0),
        "a planning bound outside the band"
    );
    assert!(b.plan(f64::NEG_INFINITY, 352.0));
    b.sample(6.0, 20);
    b.build().expect("complete CSTR")
}

#[test]
fn the_cstr_in_operators_in_explicit_calls_and_in_its_file_agree_to_1e12() {
    let file = Plant::new(load("models/cstr.ghm"));
    let code = Plant::new(cstr_in_code().expect("the CSTR builds"));
    let explicit = Plant::new(cstr_in_explicit_calls());
    let points = trajectory(&file, 300, |_| vec![]);
    assert_same_step(&file, &code, &points);
    assert_same_step(&file, &explicit, &points);
    let mut band = file.model.soft[0].clone();
    band.description = String::new(); // not said in Rust
    assert_eq!(code.model.soft, [band.clone()]);
    band.weight_below = 0.0; // the explicit call names both weights
    assert_eq!(explicit.model.soft, [band]);
    let sizes = |p: &Plant| (p.model.graph.len(), p.model.params.len());
    assert_eq!(
        sizes(&code),
        sizes(&explicit),
        "the same graph, node for node"
    );
}

/// A plant without disturbances runs a season on a constant (empty) weather.
#[test]
fn plant_without_disturbances_runs_a_season() {
    let b = ModelBuilder::new("decay");
    let x = b.state("x", 1.0);
    let k = b.param("k", 0.1);
    b.der(x, -k * x);
    b.sample(1.0, 1);
    let plant = Plant::new(b.build().expect("complete model"));
    let weather = ghm::sim::weather::Weather::constant(vec![], &[], 10, 1.0);
    assert_eq!(weather.len(), 10);
    let config = ghm::sim::season::SeasonConfig {
        steps: 10,
        enforce_limits: true,
        uncertainty: None,
    };
    let mut none = ghm::control::ConstantInput(vec![]);
    let r = ghm::sim::season::run_season(
        &plant,
        &weather,
        &mut none,
        &config,
        &mut |_: &ghm::sim::season::StepLog| {},
    )
    .expect("season");
    assert!(r.final_state[0] < 1.0 && r.final_state[0] > 0.3);
}

/// What `build` refuses, one mistake at a time, each with the error that says what to do.
#[test]
fn the_builder_refuses_what_the_language_refuses() {
    // A builder with a state `x`, an input `u`, an output `y`; `mistake` adds one error.
    fn refused(mistake: impl Fn(&ModelBuilder)) -> BuildError {
        let b = ModelBuilder::new("m");
        let x = b.state("x", 1.0);
        let u = b.input("u").bounds(0.0, 1.0);
        b.der(x, u - x);
        b.output("y", x);
        b.sample(1.0, 1);
        mistake(&b);
        b.build().expect_err("a mistake")
    }
    // A second state `z` with an output of the same name.
    fn e(b: &ModelBuilder) -> (State<'_>, Output<'_>) {
        (b.state("z", 0.0), b.output("z", 0.0))
    }
    assert_eq!(
        refused(|b| {
            b.state("s", 1.0);
        }),
        BuildError::MissingDerivative("s".into())
    );
    assert_eq!(refused(|b| b.sample(0.0, 1)), BuildError::NoSamplePeriod);
    assert_eq!(
        refused(|b| {
            b.param("x", 1.0);
        }),
        BuildError::Duplicate("x".into())
    );
    assert_eq!(
        refused(|b| {
            let (z, _) = e(b);
            b.der(z, 1.0);
            b.der(z, 2.0);
        }),
        BuildError::Duplicate("der z".into())
    );
    assert_eq!(
        refused(|b| {
            b.param("two words", 1.0);
        }),
        BuildError::BadName("two words".into())
    );
    assert_eq!(
        refused(|b| {
            b.input("v").bounds(2.0, 1.0);
        }),
        BuildError::InputBounds {
            input: "v".into(),
            lower: 2.0,
            upper: 1.0
        }
    );
    assert_eq!(
        refused(|b| {
            b.input("v").rate(-1.0);
        }),
        BuildError::InputRate {
            input: "v".into(),
            rate: -1.0
        }
    );
    assert_eq!(
        refused(|b| {
            b.input("v").bounds(1.0, 2.0).start(3.0);
        }),
        BuildError::InputStart {
            input: "v".into(),
            start: 3.0,
            lower: 1.0,
            upper: 2.0
        }
    );
    assert_eq!(
        refused(|b| {
            let v = b.input("v");
            v.rule(v * 2.0);
        }),
        BuildError::RuleReadsInput("v".into())
    );
    assert_eq!(
        refused(|b| {
            let (z, _) = e(b);
            b.der(z, z.next());
        }),
        BuildError::NextOutsideStageTerm("der z".into())
    );
    assert_eq!(
        refused(|b| {
            let (z, _) = e(b);
            b.der(z, 0.0);
            b.terminal("value", z.next());
        }),
        BuildError::NextOutsideStageTerm("terminal value".into())
    );
    assert_eq!(
        refused(|b| {
            let (z, _) = e(b);
            let weather = b.disturbance("weather");
            b.der(z, 0.0);
            b.terminal("value", z + weather);
        }),
        BuildError::TerminalReadsControl("value".into())
    );
    assert_eq!(
        refused(|b| {
            b.disturbance("t1").clock();
            b.disturbance("t2").clock();
        }),
        BuildError::SecondClock("t1".into(), "t2".into())
    );
    assert_eq!(
        refused(|b| {
            let (z, y) = e(b);
            b.der(z, 0.0);
            y.band(0.0, 1.0);
        }),
        BuildError::BandWithoutWeight("z".into())
    );
    assert_eq!(
        refused(|b| {
            let (z, y) = e(b);
            b.der(z, 0.0);
            y.band(0.0, 1.0).weights(1.0, -1.0);
        }),
        BuildError::BandWeight {
            output: "z".into(),
            weight: -1.0
        }
    );
    assert_eq!(
        refused(|b| {
            let (z, y) = e(b);
            b.der(z, 0.0);
            y.band(1.0, 0.0).weight(1.0);
        }),
        BuildError::BandLimits {
            output: "z".into(),
            lower: 1.0,
            upper: 0.0
        }
    );
    assert_eq!(
        refused(|b| {
            let (z, y) = e(b);
            b.der(z, 0.0);
            y.band(0.0, 1.0).weight(1.0).plan(2.0, 3.0);
        }),
        BuildError::EmptyPlan("z".into())
    );
    assert_eq!(
        refused(|b| {
            let (z, y) = e(b);
            b.der(z, 0.0);
            y.at_most(1.0).weight(1.0);
            y.at_least(0.0).weight(1.0);
        }),
        BuildError::Duplicate("soft z".into())
    );
    assert_eq!(
        refused(|b| {
            let x = b.constant(1.0);
            b.apply(ghm::graph::Op::Exp, &[x, x]);
        }),
        BuildError::Arity {
            op: "Exp".into(),
            expected: 1,
            given: 2
        }
    );
    // A handle of another builder, given to this one.
    let other = ModelBuilder::new("other");
    let foreign = other.state("f", 0.0);
    assert_eq!(
        refused(|b| {
            b.output("f", foreign);
        }),
        BuildError::ForeignExpression {
            model: "m".into(),
            other: "other".into()
        }
    );
}

/// What the handles say reaches the model as the language would put it: defaults too.
#[test]
fn declarations_say_what_the_language_says() {
    let b = ModelBuilder::new("m");
    b.describe("a model");
    let time = b.disturbance("time").unit("s").clock();
    let sun = b.disturbance("sun").column("rad_Wm2").value(0.0);
    let x = b.state("x", 1.0).unit("kg").describe("mass");
    let free = b.input("free");
    let heat = b
        .input("heat")
        .bounds(2.0, 5.0)
        .rule(if_else(x.lt(1.0), 5.0, 2.0));
    let k = b.param("k", 0.5).uncertain().source("a book");
    let plain = b.param("plain", 2.0);
    b.der(x, -k * x + free + heat + sun * 0.0 + time * 0.0 - plain);
    b.terminal("worth", 3.0 * x).unit("EUR");
    b.uncertainty(Uncertainty {
        spread: 0.5,
        ..Uncertainty::default()
    });
    b.sample(60.0, 3);
    b.integrator(ghm::prelude::Integrator::Radau5);
    let m = b.build().expect("complete");
    assert_eq!(m.description, "a model");
    assert_eq!(m.clock(), Some(0));
    assert_eq!(m.weather_columns(), ["time", "rad_Wm2"]);
    assert_eq!(m.disturbances[1].value, Some(0.0));
    assert_eq!(said(&m.states[0].info), ["x", "kg", "mass", ""]);
    let bounds = |i: usize| (m.inputs[i].lower, m.inputs[i].upper, m.inputs[i].start);
    assert_eq!(bounds(0), (f64::NEG_INFINITY, f64::INFINITY, 0.0));
    assert_eq!(
        bounds(1),
        (2.0, 5.0, 2.0),
        "start: 0 clipped into the bounds"
    );
    let rule = m.inputs[1].rule.expect("a rule");
    // The rule over (x, u, d, p) = (x, free, heat, time, sun, k, plain).
    let at = |x: f64| {
        m.graph
            .eval_f64(&[rule], &[x, 0.0, 0.0, 0.0, 0.0, 0.5, 2.0])[0]
    };
    assert_eq!((at(0.5), at(1.5)), (5.0, 2.0));
    use ghm::lang::ast::ParamKind;
    assert_eq!(
        (m.params[0].kind, m.params[1].kind),
        (ParamKind::Uncertain, ParamKind::Plain)
    );
    assert_eq!(m.params[0].info.source, "a book");
    assert_eq!(m.terms[0].kind, ghm::lang::ast::TermKind::Terminal);
    assert_eq!(m.objective_unit(), "EUR");
    assert_eq!(m.uncertainty.spread, 0.5);
    assert_eq!(
        (m.integrator, m.substeps),
        (ghm::prelude::Integrator::Radau5, 3)
    );
}
