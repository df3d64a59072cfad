//! Exact derivatives of the lettuce step against an independent symbolic tool (CasADi SX;
//! the fixture `tests/fixtures/lettuce-derivative-check.json`, its provenance in
//! `tests/fixtures/README.md`): tighter than finite differences can be.

use ghm::graph::Derivatives;
use ghm::model::Plant;
use serde_json::Value;

const FIXTURE: &str = "tests/fixtures/lettuce-derivative-check.json";

fn vector(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

fn matrix(v: &Value) -> Vec<Vec<f64>> {
    v.as_array().expect("array").iter().map(vector).collect()
}

/// Largest error relative to the larger of the entry and 1e-12 of the matrix's scale.
fn max_rel(got: &[f64], want: &[f64]) -> f64 {
    let scale = want.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    got.iter()
        .zip(want)
        .map(|(g, w)| (g - w).abs() / w.abs().max(1e-12 * scale).max(1e-300))
        .fold(0.0, f64::max)
}

#[test]
fn step_derivatives_match_symbolic_reference() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(FIXTURE);
    let text = std::fs::read_to_string(path).expect(FIXTURE);
    let spec: Value = serde_json::from_str(&text).expect("valid JSON");
    let model = ghm::lang::load(std::path::Path::new("models/lettuce-thesis.ghm"))
        .unwrap_or_else(|e| panic!("{}", e.render()));
    let plant = Plant::new(model);
    let tape = plant.step_tape();
    let out_tape = plant.output_tape();
    let wrt: Vec<usize> = (0..7).collect();
    let mut step_der = Derivatives::new(tape, &wrt);
    let mut out_der = Derivatives::new(out_tape, &[0, 1, 2, 3]);
    let points = spec["points"].as_array().expect("points");
    assert!(points.len() >= 4);
    for point in points {
        let mut z = vector(&point["x"]);
        z.extend(vector(&point["u"]));
        z.extend(vector(&point["d"]));
        z.extend(plant.model.nominal_params());
        let lambda = vector(&point["lambda"]);
        let mut weights = vec![0.0; tape.n_outputs()];
        weights[..4].copy_from_slice(&lambda);
        let r = step_der.hessian(tape, &z, &weights);
        assert!(
            max_rel(&r.values[..4], &vector(&point["F"])) < 1e-12,
            "F at k = {}",
            point["k"]
        );
        let jac_ref: Vec<f64> = matrix(&point["dF_dxu"]).concat();
        assert!(
            max_rel(&r.jacobian[..28], &jac_ref) < 1e-10,
            "dF/d(x,u) at k = {}: {:e}",
            point["k"],
            max_rel(&r.jacobian[..28], &jac_ref)
        );
        let hess_ref: Vec<f64> = matrix(&point["hess_lambdaF_xu"]).concat();
        assert!(
            max_rel(&r.hessian, &hess_ref) < 1e-9,
            "Hessian at k = {}: {:e}",
            point["k"],
            max_rel(&r.hessian, &hess_ref)
        );
        // Exact Hessians are symmetric.
        for i in 0..7 {
            for j in 0..i {
                let (a, b) = (r.hessian[i * 7 + j], r.hessian[j * 7 + i]);
                assert!((a - b).abs() <= 1e-12 * a.abs().max(b.abs()).max(1e-300));
            }
        }
        let y = out_der.jacobian(out_tape, &z);
        assert!(max_rel(&y.values, &vector(&point["y"])) < 1e-12);
        let dy_ref: Vec<f64> = matrix(&point["dy_dx"]).concat();
        assert!(
            max_rel(&y.jacobian, &dy_ref) < 1e-10,
            "dy/dx at k = {}",
            point["k"]
        );
    }
}
