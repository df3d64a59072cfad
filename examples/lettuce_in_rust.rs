//! The lettuce greenhouse of `models/lettuce.ghm`, written in Rust: the same declarations,
//! units, sources and equations, line for line, as the `.ghm` file says them.
//! `tests/builder.rs` checks that `lettuce()` equals the file's model to 1e-12 in value,
//! Jacobian and Hessian over a season.
//!
//! Run: `cargo run --release --example lettuce_in_rust` (steps both for a day and prints
//! how far apart they end).

use ghm::prelude::*;
use ghm::sim::weather::builtin_season;
use std::path::Path;

/// Van Henten's lettuce greenhouse with the paper's economic objective. Kept in the layout
/// of the `.ghm` file, one declaration a line (hence `rustfmt::skip`).
#[rustfmt::skip]
pub fn lettuce() -> Result<Model, BuildError> {
    let b = ModelBuilder::new("lettuce");
    b.describe("Van Henten lettuce greenhouse, 30-minute economic control (paper variant)");

    // ---- time: a constant is a plain number ----------------------------------------------
    let step_s = 1800.0; // [s] control period: 30 minutes
    b.sample(step_s, 4); // RK4 in 4 sub-steps

    // ---- states ------------------------------------------------------------------------------
    let dry_weight = b.state("dry_weight", 0.0035).unit("kg m^-2")
        .describe("crop dry weight, structural + non-structural (x1)");
    let co2_air = b.state("co2_air", 0.001).unit("kg m^-3").describe("indoor CO2 density (x2)");
    let temp_air = b.state("temp_air", 15.0).unit("°C").describe("indoor air temperature (x3)");
    let hum_air = b.state("hum_air", 0.008).unit("kg m^-3")
        .describe("indoor absolute humidity, water-vapour density (x4)");

    // ---- inputs: bounds, rate limits (10 % of the range per step), value before step 0 -------
    let co2_supply = b.input("co2_supply").unit("mg m^-2 s^-1")
        .bounds(0.0, 1.2).rate(0.12).start(0.0).describe("CO2 injection rate (u1)");
    let ventilation = b.input("ventilation").unit("mm s^-1")
        .bounds(0.0, 7.5).rate(0.75).start(0.0).describe("ventilation rate (u2)");
    let heating = b.input("heating").unit("W m^-2")
        .bounds(0.0, 150.0).rate(15.0).start(50.0).describe("heating power (u3)");

    // ---- weather (columns of the Venlo CSV and of ghm's built-in season) ---------------------
    let radiation = b.disturbance("radiation").unit("W m^-2").column("rad_Wm2")
        .describe("outdoor global radiation (d1)");
    let co2_out = b.disturbance("co2_out").unit("kg m^-3").column("co2_out_kgm3")
        .describe("outdoor CO2 density (d2)");
    let temp_out = b.disturbance("temp_out").unit("°C").column("temp_out_C")
        .describe("outdoor temperature (d3)");
    let hum_out = b.disturbance("hum_out").unit("kg m^-3").column("vapdens_out_kgm3")
        .describe("outdoor absolute humidity (d4)");

    // ---- physical parameters (van Henten 1994), uncertain -------------------------------------
    let vh = |name, value, unit, text, number: u32| {
        b.param(name, value).unit(unit).uncertain().describe(text)
            .source(&format!("van Henten 1994, p#{number}"))
    };
    let c_alpha_beta = vh("c_alpha_beta", 0.544, "-", "yield factor, CO2 to dry matter", 1);
    let c_resp_d = vh("c_resp_d", 2.65e-7, "s^-1", "maintenance respiration rate (dry-matter loss)", 2);
    let c_lai = vh("c_lai", 53.0, "m^2 kg^-1", "effective canopy surface per dry weight", 3);
    let c_light = vh("c_light", 3.55e-9, "kg J^-1", "light-use efficiency", 4);
    let c_co2_1 = vh("c_co2_1", 5.11e-6, "m s^-1 °C^-2", "temperature effect on CO2 conductance, quadratic", 5);
    let c_co2_2 = vh("c_co2_2", 2.3e-4, "m s^-1 °C^-1", "temperature effect on CO2 conductance, linear", 6);
    let c_co2_3 = vh("c_co2_3", 6.29e-4, "m s^-1", "temperature effect on CO2 conductance, constant", 7);
    let c_gamma = vh("c_gamma", 5.2e-5, "kg m^-3", "CO2 compensation point", 8);
    let c_cap_c = vh("c_cap_c", 4.1, "m^3 m^-2", "CO2 capacity of the greenhouse air", 9);
    let c_resp_c = vh("c_resp_c", 4.87e-7, "s^-1", "CO2 release by respiration", 10);
    let c_leak = b.param("c_leak", 7.5e-6).unit("m s^-1").uncertain()
        .describe("leakage through the cover (the paper's code; van Henten: 0.75e-4)")
        .source("paper code SHARED/params.py, p#11");
    let c_cap_q = vh("c_cap_q", 3.0e4, "J m^-2 °C^-1", "heat capacity of the greenhouse air", 12);
    let c_cap_v = vh("c_cap_v", 1290.0, "J m^-3 °C^-1", "volumetric heat capacity of ventilated air", 13);
    let c_cover = vh("c_cover", 6.1, "W m^-2 °C^-1", "heat transfer through the cover", 14);
    let c_rad = vh("c_rad", 0.2, "-", "solar heat-load coefficient", 15);
    let c_cap_h = vh("c_cap_h", 4.1, "m^3 m^-2", "vapour capacity of the greenhouse air", 16);
    let c_evap = vh("c_evap", 3.6e-3, "m s^-1", "leaf-air vapour transfer coefficient", 17);
    let c_sat_1 = vh("c_sat_1", 9348.0, "J m^-3", "saturation-vapour parameter", 18);
    let c_gas_kmol = vh("c_gas_kmol", 8314.0, "J K^-1 kmol^-1", "gas constant, kmol form", 19);
    let c_kelvin = vh("c_kelvin", 273.15, "K", "°C to K offset used in the ODE", 20);
    let c_sat_2 = vh("c_sat_2", 17.4, "-", "saturation-vapour parameter", 21);
    let c_sat_3 = vh("c_sat_3", 239.0, "°C", "saturation-vapour parameter", 22);

    // ---- constants of the output map: plain parameters, perturbed only under `params = all` --
    let map = |name, value, unit, text| {
        b.param(name, value).unit(unit).describe(text).source("paper code, output map")
    };
    let gas_const = map("gas_const", 8.3144598, "J mol^-1 K^-1", "molar gas constant");
    let kelvin = map("kelvin", 273.15, "K", "°C to K offset, output map");
    let pressure = map("pressure", 101325.0, "Pa", "air pressure");
    let molar_co2 = map("molar_co2", 0.04401, "kg mol^-1", "molar mass of CO2");
    let magnus_a = map("magnus_a", 17.2694, "-", "Magnus coefficient");
    let magnus_b = map("magnus_b", 238.3, "°C", "Magnus coefficient");
    let p_sat_0 = 610.78; // [Pa] saturation vapour pressure at 0 °C (Magnus)
    let molar_water = 18.01528e-3; // [kg mol^-1] molar mass of water

    // ---- prices (paper, Table 2): constants, never perturbed --------------------------------
    let price_crop = 20.93; // [EUR kg^-1] lettuce price per kg dry weight
    let price_co2 = 0.1906; // [EUR kg^-1] CO2 price
    let price_heat = 0.1281; // [EUR kWh^-1] heating energy price

    // ---- dynamics -----------------------------------------------------------------------------
    let canopy = 1.0 - (-c_lai * dry_weight).exp();
    let conductance = (-c_co2_1 * temp_air.powi(2) + c_co2_2 * temp_air - c_co2_3) * (co2_air - c_gamma);
    let photosynthesis = canopy * (c_light * radiation * conductance) / (c_light * radiation + conductance);
    let respiration = dry_weight * b.constant(2.0).pow(0.1 * temp_air - 2.5);
    let air_exchange = ventilation * 1e-3 + c_leak;
    let sat_vapour = c_sat_1 / (c_gas_kmol * (temp_air + c_kelvin))
        * (c_sat_2 * temp_air / (temp_air + c_sat_3)).exp();

    b.der(dry_weight, c_alpha_beta * photosynthesis - c_resp_d * respiration);
    b.der(co2_air, (-photosynthesis + c_resp_c * respiration + co2_supply * 1e-6
        - air_exchange * (co2_air - co2_out)) / c_cap_c);
    b.der(temp_air, (heating - (c_cap_v * ventilation * 1e-3 + c_cover) * (temp_air - temp_out)
        + c_rad * radiation) / c_cap_q);
    b.der(hum_air, (c_evap * canopy * (sat_vapour - hum_air) - air_exchange * (hum_air - hum_out))
        / c_cap_h);

    // ---- outputs ------------------------------------------------------------------------------
    b.output("crop", dry_weight).unit("kg m^-2").describe("crop dry weight (y1)");
    let co2_ppm = b.output("co2_ppm", 1e6 * gas_const * (temp_air + kelvin) * co2_air / (pressure * molar_co2))
        .unit("ppm").describe("indoor CO2 concentration (y2)");
    let temp = b.output("temp", temp_air).unit("°C").describe("indoor temperature (y3)");
    let saturation = molar_water * p_sat_0 * (magnus_a * temp_air / (temp_air + magnus_b)).exp();
    let rh = 100.0 * gas_const * (temp_air + kelvin) * hum_air / saturation;
    let rh_pct = b.output("rh_pct", b.constant(100.0).min(rh)).unit("%")
        .describe("indoor relative humidity, capped at 100 (y4)");

    // ---- objective: economic stage reward (EUR m^-2 per step) -------------------------------
    b.reward("crop_growth", price_crop * (dry_weight.next() - dry_weight))
        .unit("EUR m^-2").describe("value of the dry weight gained");
    b.cost("co2_cost", price_co2 * 1e-6 * step_s * co2_supply).unit("EUR m^-2").describe("CO2 dosed");
    b.cost("heat_cost", price_heat * step_s / 3.6e6 * heating).unit("EUR m^-2").describe("heating energy");

    // ---- soft bands on the outputs after the step (penalty in EUR per unit outside) ---------
    co2_ppm.band(500.0, 1600.0).weight(5e-5).describe("CO2 band");
    temp.band(10.0, 20.0).weight(5e-3).describe("temperature band");
    rh_pct.at_most(80.0).weight(7e-4).plan(f64::NEG_INFINITY, 78.0)
        .describe("humidity ceiling; the stochastic MPC plans with 78 %");

    // ---- parametric uncertainty: the 22 physical parameters, once per season, ±δ ------------
    b.uncertainty(Uncertainty { redraw: Redraw::Season, spread: 1.0, all_params: false });
    b.build()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let in_rust = Plant::new(lettuce()?);
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/lettuce.ghm");
    let from_file = Plant::new(ghm::lang::load(&file)?);
    let steps = 48; // a day of 30-minute steps
    let columns = in_rust.model.weather_columns();
    let weather =
        builtin_season(steps, in_rust.model.sample_period, 2014).select(&columns, 0, steps)?;
    let p = in_rust.model.nominal_params();
    let (mut a, mut b) = (
        in_rust.model.initial_state(),
        from_file.model.initial_state(),
    );
    let mut largest = 0.0f64;
    for k in 0..steps {
        let u = [0.6, 1.0, if k % 2 == 0 { 100.0 } else { 20.0 }];
        let d = weather.at(k);
        let (sa, sb) = (in_rust.step(&a, &u, d, &p), from_file.step(&b, &u, d, &p));
        for (x, y) in sa.next_state.iter().zip(&sb.next_state) {
            largest = largest.max((x - y).abs() / x.abs().max(1e-300));
        }
        (a, b) = (sa.next_state, sb.next_state);
    }
    println!("a day of the lettuce greenhouse, built in Rust and read from models/lettuce.ghm:");
    println!("  dry weight {:.6} kg/m2 and {:.6} kg/m2", a[0], b[0]);
    println!("  largest relative difference of a state over the day: {largest:.1e}");
    Ok(())
}
