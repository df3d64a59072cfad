//! The `.ghm` front end against hostile but realistic input (issue 16): long chains of
//! `let`s on a small stack, size limits counted on tokens, byte-order marks, line endings,
//! invisible characters, non-ASCII names, files that are not UTF-8, and sample periods out
//! of range. Each case is a clear error at `file:line:column` or a model that loads, never a
//! crash.

use ghm::lang::{load, load_str, CheckFailure, Model};
use ghm::model::{verify::verify_step_derivatives, Plant};
use std::path::PathBuf;

/// Lets in the long chains: the issue asks that the stack survive 100 000.
const CHAIN: usize = 100_000;

/// Runs `f` on a thread with the default 2 MiB test stack: any recursion as deep as the
/// chain overflows it.
fn on_small_stack<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
    std::thread::Builder::new()
        .stack_size(2 << 20)
        .spawn(f)
        .expect("spawn a thread")
        .join()
        .expect("the thread did not panic")
}

fn loads(text: &str) -> Model {
    load_str("m.ghm", text).unwrap_or_else(|e| panic!("{}", e.render()))
}

fn fails(text: &str) -> CheckFailure {
    match load_str("bad.ghm", text) {
        Ok(_) => panic!("the model loaded, but it should not have:\n{text}"),
        Err(f) => f,
    }
}

/// The one error of a failure: its code, `file:line:col` and message.
fn only_error(f: &CheckFailure) -> (&'static str, String, String) {
    let errors: Vec<_> = f.diagnostics.iter().filter(|d| d.is_error()).collect();
    assert_eq!(errors.len(), 1, "{}", f.render());
    let e = errors[0];
    (e.code, f.sources.location(e.span), e.message.clone())
}

// ---- item 1: no recursion as deep as the input -----------------------------------------

/// `let a0 = k * x`, `let a1 = a0 + 1e-6`, ... and `der x = -a{last}`: the derivative
/// reaches the whole chain, which is lowered, discretised, evaluated and differentiated.
#[test]
fn a_long_let_chain_loads_evaluates_and_differentiates() {
    on_small_stack(|| {
        let mut text = String::from("sample 1 [s]\nstate x = 1\nparam k = 0.5\nlet a0 = k * x\n");
        for i in 1..CHAIN {
            text.push_str(&format!("let a{i} = a{} + 1e-6\n", i - 1));
        }
        text.push_str(&format!("der x = -a{}\n", CHAIN - 1));
        let model = loads(&text);
        assert!(model.warnings.is_empty(), "{:?}", &model.warnings[..1]);
        let plant = Plant::new(model);
        let out = plant.step(&[1.0], &[], &[], &[0.5]);
        // dx/dt = -(0.5 x + 0.099999): x(1) = 1.2 e^-0.5 - 0.2 after one second from x = 1.
        assert!((out.next_state[0] - 0.5278).abs() < 1e-3, "{out:?}");
        let report = verify_step_derivatives(&plant, &[vec![1.0, 0.5]]);
        assert!(report.max() < 1e-5, "{report:?}");
    });
}

/// A chain nothing uses, written from its end (`let a0 = a1 + 1`, `let a1 = a2 + 1`, ...):
/// lowering the unused `a0` reaches every other let.
#[test]
fn an_unused_let_chain_written_backwards_loads() {
    on_small_stack(|| {
        let mut text = String::from("sample 1 [s]\nstate x = 1\nder x = -x\n");
        for i in 0..CHAIN {
            text.push_str(&format!("let a{i} = a{} + 1\n", i + 1));
        }
        text.push_str(&format!("let a{CHAIN} = x\n"));
        let model = loads(&text);
        // Only the head of the chain is unused.
        assert_eq!(model.warnings.len(), 1, "{:?}", &model.warnings[..2]);
        assert_eq!(model.warnings[0].message, "let `a0` is never used");
    });
}

/// A cycle at the end of a long chain of outputs is still found, once, at its use.
#[test]
fn a_cycle_at_the_end_of_a_long_output_chain_is_reported_once() {
    on_small_stack(|| {
        let mut text = String::from("sample 1 [s]\nstate x = 1\nder x = -x\n");
        for i in 0..CHAIN {
            text.push_str(&format!("output y{i} = y{} + 1\n", i + 1));
        }
        text.push_str(&format!("output y{CHAIN} = y0 + x\n"));
        let f = fails(&text);
        let (code, at, message) = only_error(&f);
        assert_eq!(code, "E010");
        assert_eq!(message, "this output depends on itself");
        assert_eq!(
            at,
            format!("bad.ghm:{}:{}", CHAIN + 4, 12 + CHAIN.to_string().len())
        );
    });
}

// ---- item 2: limits counted on tokens ---------------------------------------------------

/// Brackets in a description and banner comments full of dashes are not expression tokens.
#[test]
fn limits_skip_comments_strings_and_units() {
    let text = format!(
        "sample 1 [s]\nstate x [kg m^-2] = 1 \"{}\"\n{}der x = -x\n",
        "(".repeat(70),
        format!("# {}\n", "-".repeat(90)).repeat(12),
    );
    loads(&text);
}

/// The sign of an exponent is part of its number, not an operator: 400 terms `1e-3 * x`
/// have 799 operators, not 1199.
#[test]
fn exponent_signs_are_not_operators() {
    let sum = vec!["1e-3 * x"; 400].join(" + ");
    loads(&format!("sample 1 [s]\nstate x = 1\nder x = -({sum})\n"));
}

/// Real brackets are still counted, in bounds too.
#[test]
fn real_brackets_still_count() {
    let deep = format!("{}1{}", "(".repeat(65), ")".repeat(65));
    let f = fails(&format!(
        "sample 1 [s]\nstate x = 1\nder x = -x\ninput u in [0, {deep}]\n"
    ));
    let (code, at, message) = only_error(&f);
    assert_eq!(
        (code, message.as_str()),
        ("E023", "brackets nested 66 deep (at most 64)")
    );
    assert_eq!(at, "bad.ghm:4:80");
}

// ---- item 3: the text of the file ---------------------------------------------------------

const TANK: &str = "model tank\nsample 1 [s]\nstate x = 1\nder x = -y\n";

/// A byte-order mark is not text: the model loads, and columns on line 1 are unchanged.
#[test]
fn a_byte_order_mark_is_accepted() {
    loads(&format!("\u{FEFF}{}", TANK.replace("-y", "-x")));
    let f = fails("\u{FEFF}sample 1 [s] integrator rk5\nstate x = 1\nder x = -x\n");
    let (code, at, _) = only_error(&f);
    assert_eq!((code, at.as_str()), ("E017", "bad.ghm:1:25"));
}

/// CRLF and CR-only line endings: the model loads and errors point at the right line and
/// column, and the rendered source line has no stray carriage return.
#[test]
fn crlf_and_cr_line_endings_are_handled() {
    for ending in ["\r\n", "\r"] {
        let text = TANK.replace('\n', ending);
        loads(&text.replace("-y", "-x"));
        let f = fails(&text);
        let (code, at, _) = only_error(&f);
        assert_eq!((code, at.as_str()), ("E003", "bad.ghm:4:10"), "{ending:?}");
        let rendered = f.render();
        assert!(
            rendered.contains("4 │ der x = -y\n"),
            "{ending:?}: {rendered}"
        );
        assert!(!rendered.contains('\r'), "{ending:?}: {rendered:?}");
    }
}

/// An invisible character is named, with its code point, where it stands.
#[test]
fn invisible_characters_are_named() {
    for (c, what) in [
        ('\u{200B}', "invisible character U+200B (zero width space)"),
        ('\u{00A0}', "space character U+00A0 (no-break space)"),
        ('\u{0}', "control character U+0000 (null)"),
    ] {
        // In an unused let, so that losing the statement costs nothing else.
        let f = fails(&format!(
            "sample 1 [s]\nstate x = 1\nder x = -x\nlet y ={c} 1\n"
        ));
        let (code, at, message) = only_error(&f);
        assert_eq!(code, "E001");
        assert_eq!(at, "bad.ghm:4:8");
        assert_eq!(message, format!("syntax error: unexpected {what}"));
    }
}

/// Names are ASCII; a letter outside ASCII in a name says so (docs/language.md).
#[test]
fn non_ascii_names_are_refused_with_a_reason() {
    for (text, at, letter) in [
        ("let Δw = 1\n", "bad.ghm:4:5", "`Δ` (U+0394)"),
        ("let température = 1\n", "bad.ghm:4:9", "`é` (U+00E9)"),
    ] {
        let f = fails(&format!("sample 1 [s]\nstate x = 1\nder x = -x\n{text}"));
        let (code, place, message) = only_error(&f);
        assert_eq!((code, place.as_str()), ("E001", at));
        assert_eq!(
            message,
            format!("syntax error: unexpected non-ASCII letter {letter}: names must be ASCII")
        );
    }
}

/// A fresh folder for one test's files.
fn scratch(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join("ghm-frontend").join(test);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create a temporary folder");
    dir
}

/// A file in Latin-1: the error gives the byte and its line and column; the rest of the
/// file is still checked (the bad byte sits in a unit, harmless once replaced).
#[test]
fn a_file_that_is_not_utf8_gets_the_byte_position() {
    let dir = scratch("not_utf8");
    let path = dir.join("latin1.ghm");
    let mut bytes = b"sample 1 [s]\r\nstate temp [".to_vec();
    bytes.push(0xB0); // `°` in Latin-1
    bytes.extend_from_slice(b"C] = 1\r\nder temp = -temp\r\n");
    std::fs::write(&path, &bytes).expect("write the model");
    let f = load(&path).expect_err("not UTF-8");
    let (code, at, message) = only_error(&f);
    assert_eq!(code, "E024");
    assert_eq!(at, format!("{}:2:13", path.display()));
    assert_eq!(
        message,
        format!(
            "`{}` is not UTF-8 text: byte 26 (0xB0) is not UTF-8",
            path.display()
        )
    );
    let _ = std::fs::remove_dir_all(&dir);
}

// ---- item 4: the sample period ----------------------------------------------------------

#[test]
fn sample_periods_out_of_range_are_errors() {
    for (period, value) in [
        ("1e-300 [s]", "1e-300"),
        ("1e300 [s]", "1e300"),
        ("1e9 [h]", "3.6e12"),
        ("0.01", "0.01"),
    ] {
        let f = fails(&format!("state x = 1\nder x = -x\nsample {period}\n"));
        let (code, at, message) = only_error(&f);
        assert_eq!((code, at.as_str()), ("E017", "bad.ghm:3:8"), "{period}");
        assert_eq!(
            message,
            format!("the sample period is {value} s; it must be from 0.1 s to 86400 s (one day)")
        );
    }
    for period in ["0.1 [s]", "1440 [min]", "24 [h]"] {
        loads(&format!("state x = 1\nder x = -x\nsample {period}\n"));
    }
}

// ---- solver hints ----------------------------------------------------------------------

#[test]
fn the_last_objective_scale_is_the_one_every_solver_is_asked_for() {
    use ghm::nlp::{Nlp, Ocp};
    let text = "state x = 1\ninput u in [0, 1]\nder x = -x + u\nsample 60\ncost c = u\n";
    assert_eq!(loads(text).solver.objective_scale, 1.0);
    let scaled = loads(&format!(
        "{text}solver objective_scale = 10\nsolver objective_scale = 1e3\n"
    ));
    assert_eq!(scaled.solver.objective_scale, 1000.0);
    let plant = std::sync::Arc::new(ghm::model::Plant::new(scaled));
    let ocp = Ocp::new(plant, 3).unwrap();
    assert_eq!(ocp.objective_scaling(), 1000.0);
}

#[test]
fn a_rollout_push_is_a_number_between_0_and_half_a_bound() {
    let text = "state x = 1\ninput u in [0, 1]\nder x = -x + u\nsample 60\ncost c = u\n";
    assert_eq!(loads(text).solver.rollout_push, None);
    let pushed = loads(&format!(
        "{text}solver objective_scale = 10, rollout_push = 1e-4\n"
    ));
    assert_eq!(pushed.solver.rollout_push, Some(1e-4));
    assert_eq!(pushed.solver.objective_scale, 10.0);
    for bad in ["0", "0.5", "2"] {
        let failure = ghm::lang::load_str("m.ghm", &format!("{text}solver rollout_push = {bad}\n"))
            .expect_err(bad)
            .render();
        assert!(
            failure.contains("E030") && failure.contains("between 0 and 0.5"),
            "{failure}"
        );
    }
}
