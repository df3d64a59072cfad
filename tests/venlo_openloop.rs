//! Open-loop and replay checks of the lettuce plant against the reference figures.
//! These tests read the Venlo weather in the data folder (`common::data`).

mod common;

use common::START_ROW;
use ghm::model::Plant;
use ghm::sim::weather::load_csv;
use std::path::Path;

fn plant(file: &str) -> Plant {
    let model = ghm::lang::load(Path::new(file)).unwrap_or_else(|e| panic!("{}", e.render()));
    Plant::new(model)
}

fn venlo(plant: &Plant, steps: usize) -> ghm::sim::weather::Weather {
    let columns = plant.model.weather_columns();
    load_csv(&common::data_dir().join(common::VENLO), &columns, 1800.0)
        .and_then(|f| f.select(&columns, START_ROW, steps))
        .expect("Venlo weather (the data folder) must be readable")
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

/// spec/openloop-check.md: constant input (0.6, 1, 40), no rate limit, 1920 steps.
#[test]
fn venlo_openloop_check_matches_reference_to_1e9() {
    let Some(_) = common::data(
        common::VENLO,
        "venlo_openloop_check_matches_reference_to_1e9",
    ) else {
        return;
    };
    let plant = plant("models/lettuce-thesis.ghm");
    let weather = venlo(&plant, 1920);
    let p = plant.model.nominal_params();
    let u = [0.6, 1.0, 40.0];
    let mut x = plant.model.initial_state();
    let reference: &[(usize, [f64; 6])] = &[
        (
            48,
            [
                0.004171100577344981,
                0.0014443815181642355,
                11.67093876906229,
                0.006827797660804532,
                767.0433217725188,
                65.61326691585006,
            ],
        ),
        (
            480,
            [
                0.03183636036398575,
                0.0014791241010947908,
                12.573871438296377,
                0.008535329873643041,
                787.9836321072959,
                77.54835876283802,
            ],
        ),
        (
            960,
            [
                0.09185588187081926,
                0.001519973471917198,
                11.147556844653261,
                0.008049504277480331,
                805.7033932342391,
                79.92504670765699,
            ],
        ),
        (
            1919,
            [
                0.24490445349302256,
                0.0015160540538312881,
                14.180427303075842,
                0.00966714115399893,
                812.1988339219558,
                79.57087638806301,
            ],
        ),
        (
            1920,
            [
                0.24484917829202626,
                0.0015065861278059567,
                14.227807783165797,
                0.009699522532929272,
                807.2596562617761,
                79.6067499089733,
            ],
        ),
    ];
    let y0 = plant.outputs(&x, &u, weather.at(0), &p);
    assert!(rel(y0[1], 537.2602140856554) < 1e-12 && rel(y0[3], 62.64395005307951) < 1e-12);
    let (mut epi, mut penalties) = (0.0, 0.0);
    let mut checked = 0;
    for k in 0..1920 {
        let out = plant.step(&x, &u, weather.at(k), &p);
        epi += out.economic();
        penalties += plant
            .penalties(&out.next_outputs)
            .iter()
            .map(|q| q.value)
            .sum::<f64>();
        x = out.next_state.clone();
        if let Some((_, r)) = reference.iter().find(|(s, _)| *s == k + 1) {
            for i in 0..4 {
                assert!(
                    rel(x[i], r[i]) < 1e-9,
                    "x{} at {}: {} vs {}",
                    i + 1,
                    k + 1,
                    x[i],
                    r[i]
                );
            }
            assert!(rel(out.next_outputs[1], r[4]) < 1e-9);
            assert!(rel(out.next_outputs[3], r[5]) < 1e-9);
            checked += 1;
        }
    }
    assert_eq!(checked, reference.len());
    assert!(rel(epi, 0.06422844688509066) < 1e-9, "EPI {epi}");
    assert!(
        rel(penalties, 8.959506691466732) < 1e-9,
        "penalties {penalties}"
    );
}

/// reference-numbers.md §5: the first three steps of the published 1-hour MPC run.
#[test]
fn venlo_replay_of_published_run() {
    let Some(_) = common::data(common::VENLO, "venlo_replay_of_published_run") else {
        return;
    };
    let plant = plant("models/lettuce-thesis.ghm");
    let weather = venlo(&plant, 3);
    let p = plant.model.nominal_params();
    let inputs = [
        [
            7.339561633812476e-06,
            0.7457469868761796,
            35.000019396590794,
        ],
        [
            7.430673388223649e-06,
            0.34256528200739356,
            20.000038795156822,
        ],
        [
            0.00018881399198409748,
            2.357199490755261e-06,
            6.322409584151112,
        ],
    ];
    let expected_y = [
        [
            0.003499211171069725,
            513.9945950833155,
            13.465106449200471,
            67.46759908944385,
        ],
        [
            0.0034985034151620575,
            503.1477838192489,
            11.871793355548602,
            74.62454487749261,
        ],
        [
            0.0034978698887696814,
            500.40246238319935,
            10.267178544433783,
            84.01505388067037,
        ],
    ];
    let cumulative = [
        -2.259332911723e-03,
        -3.556110374740e-03,
        -3.975243701754471e-03,
    ];
    let d1 = weather.at(1);
    assert!(rel(d1[1], 8.542051660512895e-04) < 1e-12);
    let mut x = plant.model.initial_state();
    let mut total = 0.0;
    for k in 0..3 {
        let out = plant.step(&x, &inputs[k], weather.at(k), &p);
        total += out.economic()
            - plant
                .penalties(&out.next_outputs)
                .iter()
                .map(|q| q.value)
                .sum::<f64>();
        for (i, (got, want)) in out.next_outputs.iter().zip(&expected_y[k]).enumerate() {
            assert!(rel(*got, *want) < 1e-9, "y{} after step {k}", i + 1);
        }
        assert!(
            rel(total, cumulative[k]) < 1e-9,
            "cumulative reward after step {}: {total}",
            k + 1
        );
        x = out.next_state;
    }
}
