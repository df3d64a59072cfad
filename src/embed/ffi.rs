//! The C ABI of a compiled controller: `ghm_controller_from_bundle` (or the
//! `ghm_controller_new` that `ghm compile` generates beside the bundle), `_decide`,
//! `_plant_step`, the sizes and names, `_free`, and `ghm_last_error` for the message behind
//! any status other than `GHM_STATUS_OK`. cbindgen generates `ghm_controller.h` from this
//! file (`cbindgen --config src/embed/cbindgen.toml src/embed/ffi.rs`; a test checks the
//! committed header is its output).
//!
//! Every function checks its pointers and sizes, never unwinds into C (a panic becomes
//! `GHM_STATUS_PANIC`), and reports errors as a status with a message.

use super::{Bundle, EmbedError, EmbeddedController, Quantity};
use std::cell::RefCell;
use std::ffi::{c_char, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};

/// The outcome of a call.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GhmStatus {
    /// The call did what it was asked.
    Ok = 0,
    /// A pointer was null, a size was wrong, or a number was not finite.
    InvalidArgument = 1,
    /// The bundle could not be read, or the controller it describes not built.
    InvalidBundle = 2,
    /// The controller failed at this step and decided no input.
    ControllerFailed = 3,
    /// ghm failed inside (a bug): the message says where.
    Panic = 4,
}

/// The kinds of quantity a controller names.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GhmQuantity {
    /// A state, in the order of the state arrays.
    State = 0,
    /// An input, in the order of the input arrays.
    Input = 1,
    /// A disturbance, by the weather column it is read from, in the order of a forecast row.
    Disturbance = 2,
}

/// The sizes of a controller's arguments.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GhmSizes {
    /// Numbers in a state.
    pub states: usize,
    /// Numbers in an input.
    pub inputs: usize,
    /// Numbers in a forecast row (the weather's disturbances).
    pub disturbances: usize,
    /// The model's outputs.
    pub outputs: usize,
    /// Forecast rows a decision needs at least (its horizon; 1 without one).
    pub forecast_rows: usize,
    /// The control period, in seconds.
    pub sample_period_s: f64,
}

/// How a decision was found.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GhmDecision {
    /// Solver iterations, over every attempt at this step (0 without a solver).
    pub iterations: usize,
    /// Iterations whose Hessian had to be corrected.
    pub inertia_corrections: usize,
    /// Wall time of the decision, in seconds.
    pub solve_time_s: f64,
    /// Whether the solver (if any) reached its tolerance.
    pub solved: bool,
    /// Whether a fallback (cold start, simulation model, shorter horizon, shifted plan,
    /// guide, held input) gave the input.
    pub fallback: bool,
}

/// A controller built from a bundle; opaque to C.
pub struct GhmController {
    inner: EmbeddedController,
    names: [Vec<CString>; 3],
}

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

fn set_error(message: &str) {
    let text = CString::new(message.replace('\0', " ")).unwrap_or_default();
    LAST_ERROR.with(|e| *e.borrow_mut() = text);
}

fn status_of(e: &EmbedError) -> GhmStatus {
    match e {
        EmbedError::Argument(_) => GhmStatus::InvalidArgument,
        EmbedError::Controller { .. } => GhmStatus::ControllerFailed,
        EmbedError::Job(_) | EmbedError::Bundle(_) | EmbedError::Package(_) => {
            GhmStatus::InvalidBundle
        }
    }
}

/// Runs `body`, turning its error or panic into a status and the thread's last error.
fn guarded(body: impl FnOnce() -> Result<(), EmbedError>) -> GhmStatus {
    match catch_unwind(AssertUnwindSafe(body)) {
        Ok(Ok(())) => GhmStatus::Ok,
        Ok(Err(e)) => {
            set_error(&e.to_string());
            status_of(&e)
        }
        Err(panic) => {
            let what = panic
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| panic.downcast_ref::<&str>().copied())
                .unwrap_or("unknown");
            set_error(&format!("ghm failed inside (please report it): {what}"));
            GhmStatus::Panic
        }
    }
}

fn null(what: &str) -> EmbedError {
    EmbedError::Argument(format!("{what} is a null pointer"))
}

/// `len` numbers at `ptr` (an empty slice for `len` 0, whatever `ptr` is).
///
/// # Safety
/// Where `len > 0`, `ptr` must be null or point to `len` readable doubles.
unsafe fn numbers<'a>(ptr: *const f64, len: usize, what: &str) -> Result<&'a [f64], EmbedError> {
    if len == 0 {
        return Ok(&[]);
    }
    if ptr.is_null() {
        return Err(null(what));
    }
    // SAFETY: non-null, and the caller promises `len` readable doubles.
    Ok(unsafe { std::slice::from_raw_parts(ptr, len) })
}

/// Copies `values` to `out`, which must hold exactly as many.
///
/// # Safety
/// `out` must be null or point to `len` writable doubles.
unsafe fn write_numbers(
    values: &[f64],
    out: *mut f64,
    len: usize,
    what: &str,
) -> Result<(), EmbedError> {
    if len != values.len() {
        return Err(EmbedError::Argument(format!(
            "{what} has room for {len} numbers; {} are written",
            values.len()
        )));
    }
    if len == 0 {
        return Ok(());
    }
    if out.is_null() {
        return Err(null(what));
    }
    // SAFETY: non-null, and the caller promises `len` writable doubles.
    unsafe { std::slice::from_raw_parts_mut(out, len) }.copy_from_slice(values);
    Ok(())
}

/// The controller behind a handle.
///
/// # Safety
/// `controller` must be null or a handle from `ghm_controller_from_bundle` not yet freed.
unsafe fn handle<'a>(controller: *mut GhmController) -> Result<&'a mut GhmController, EmbedError> {
    // SAFETY: the caller promises a live handle or null.
    unsafe { controller.as_mut() }.ok_or_else(|| null("the controller"))
}

/// Builds the controller a bundle describes (the bytes `ghm compile` carries in its
/// library; `ghm_controller_new` passes them). On success `*out` is the new controller,
/// to be freed with `ghm_controller_free`.
///
/// # Safety
/// `bundle` must point to `len` readable bytes and `out` to a writable pointer.
#[no_mangle]
pub unsafe extern "C" fn ghm_controller_from_bundle(
    bundle: *const u8,
    len: usize,
    out: *mut *mut GhmController,
) -> GhmStatus {
    guarded(|| {
        if out.is_null() {
            return Err(null("out"));
        }
        if bundle.is_null() {
            return Err(null("the bundle"));
        }
        // SAFETY: non-null, and the caller promises `len` readable bytes.
        let bytes = unsafe { std::slice::from_raw_parts(bundle, len) };
        let inner = Bundle::from_bytes(bytes)?.controller()?;
        let names = [Quantity::State, Quantity::Input, Quantity::Disturbance].map(|kind| {
            inner
                .names(kind)
                .into_iter()
                .map(|n| CString::new(n).unwrap_or_default())
                .collect()
        });
        let controller = Box::new(GhmController { inner, names });
        // SAFETY: `out` is non-null and the caller promises it is writable.
        unsafe { *out = Box::into_raw(controller) };
        Ok(())
    })
}

/// Frees a controller; null is ignored.
///
/// # Safety
/// `controller` must be null or a handle from `ghm_controller_from_bundle`, freed once.
#[no_mangle]
pub unsafe extern "C" fn ghm_controller_free(controller: *mut GhmController) {
    if !controller.is_null() {
        // SAFETY: the caller promises a live handle from `Box::into_raw`, freed once.
        drop(unsafe { Box::from_raw(controller) });
    }
}

/// The sizes of the controller's arguments.
///
/// # Safety
/// `controller` must be a live handle (or null: an error) and `out` writable (or null).
#[no_mangle]
pub unsafe extern "C" fn ghm_controller_sizes(
    controller: *mut GhmController,
    out: *mut GhmSizes,
) -> GhmStatus {
    guarded(|| {
        // SAFETY: the caller promises a live handle or null.
        let c = unsafe { handle(controller) }?;
        // SAFETY: the caller promises `out` is writable where non-null.
        let out = unsafe { out.as_mut() }.ok_or_else(|| null("out"))?;
        *out = c.inner.sizes();
        Ok(())
    })
}

/// The name of the `index`-th quantity of `kind` (a `GhmQuantity`): a NUL-terminated
/// string owned by the controller, valid until it is freed; null where there is none.
///
/// # Safety
/// `controller` must be a live handle or null.
#[no_mangle]
pub unsafe extern "C" fn ghm_controller_name(
    controller: *mut GhmController,
    kind: u32,
    index: usize,
) -> *const c_char {
    // SAFETY: the caller promises a live handle or null.
    let names = unsafe { controller.as_ref() }
        .and_then(|c| c.names.get(usize::try_from(kind).ok()?))
        .and_then(|names| names.get(index));
    names.map_or(std::ptr::null(), |n| n.as_ptr())
}

/// The model's initial state (`states` numbers) and start input (`inputs` numbers): where a
/// season begins, and the input to pass as the previous one at step 0.
///
/// # Safety
/// `controller` must be a live handle; `state_out` and `input_out` must hold `n_state` and
/// `n_input` writable doubles.
#[no_mangle]
pub unsafe extern "C" fn ghm_controller_start(
    controller: *mut GhmController,
    state_out: *mut f64,
    n_state: usize,
    input_out: *mut f64,
    n_input: usize,
) -> GhmStatus {
    guarded(|| {
        // SAFETY: the caller promises a live handle or null.
        let c = unsafe { handle(controller) }?;
        let model = &c.inner.plant().model;
        // SAFETY: the caller promises the sizes of the buffers.
        unsafe {
            write_numbers(&model.initial_state(), state_out, n_state, "state_out")?;
            write_numbers(&model.start_input(), input_out, n_input, "input_out")
        }
    })
}

/// Decides the input to apply at season step `step` (counted from 0) from the measured
/// state, the input applied at the step before and the forecast rows `d(step), d(step+1),
/// …` (row-major, `n_forecast` numbers: at least `forecast_rows` rows). Writes the input,
/// clipped to its bounds and rate limits, to `input_out`, and how it was found to
/// `decision_out` where that is not null. Steps must be asked in order: the controller
/// restarts each from the last one's solution.
///
/// # Safety
/// `controller` must be a live handle; each array must hold as many doubles as its size
/// says; `decision_out` must be null or writable.
#[no_mangle]
pub unsafe extern "C" fn ghm_controller_decide(
    controller: *mut GhmController,
    step: u64,
    state: *const f64,
    n_state: usize,
    previous_input: *const f64,
    n_input: usize,
    forecast: *const f64,
    n_forecast: usize,
    input_out: *mut f64,
    n_input_out: usize,
    decision_out: *mut GhmDecision,
) -> GhmStatus {
    guarded(|| {
        // SAFETY: the caller promises a live handle and the sizes of the arrays.
        let c = unsafe { handle(controller) }?;
        let (state, previous, forecast) = unsafe {
            (
                numbers(state, n_state, "state")?,
                numbers(previous_input, n_input, "previous_input")?,
                numbers(forecast, n_forecast, "forecast")?,
            )
        };
        let input = c.inner.decide(step, state, previous, forecast)?;
        // SAFETY: the caller promises `n_input_out` writable doubles.
        unsafe { write_numbers(&input, input_out, n_input_out, "input_out") }?;
        // SAFETY: the caller promises `decision_out` is writable where non-null.
        if let (Some(out), Some(r)) = (unsafe { decision_out.as_mut() }, c.inner.last_record()) {
            *out = GhmDecision {
                iterations: r.iterations,
                inertia_corrections: r.inertia_corrections,
                solve_time_s: r.solve_time_s,
                solved: !r.solve_failed(),
                fallback: r.fallback.is_some(),
            };
        }
        Ok(())
    })
}

/// The state one control period after `state` under `input` and the weather row
/// `disturbance`, by the controller's (nominal) model: a plant to run the controller
/// against in a test or an example.
///
/// # Safety
/// `controller` must be a live handle; each array must hold as many doubles as its size says.
#[no_mangle]
pub unsafe extern "C" fn ghm_controller_plant_step(
    controller: *mut GhmController,
    state: *const f64,
    n_state: usize,
    input: *const f64,
    n_input: usize,
    disturbance: *const f64,
    n_disturbance: usize,
    next_state_out: *mut f64,
    n_next_state: usize,
) -> GhmStatus {
    guarded(|| {
        // SAFETY: the caller promises a live handle and the sizes of the arrays.
        let c = unsafe { handle(controller) }?;
        let next = unsafe {
            c.inner.plant_step(
                numbers(state, n_state, "state")?,
                numbers(input, n_input, "input")?,
                numbers(disturbance, n_disturbance, "disturbance")?,
            )?
        };
        // SAFETY: the caller promises `n_next_state` writable doubles.
        unsafe { write_numbers(&next, next_state_out, n_next_state, "next_state_out") }
    })
}

/// The message of the last call on this thread that did not return `GHM_STATUS_OK`
/// (NUL-terminated, valid until the next failing call on this thread; empty before any).
#[no_mangle]
pub extern "C" fn ghm_last_error() -> *const c_char {
    LAST_ERROR.with(|e| e.borrow().as_ptr())
}

/// The version of ghm the library was built from (NUL-terminated, static).
#[no_mangle]
pub extern "C" fn ghm_version() -> *const c_char {
    concat!(env!("CARGO_PKG_VERSION"), "\0").as_ptr().cast()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::{ControllerSpec, RunSpec};
    use std::ffi::CStr;
    use std::path::PathBuf;

    fn last_error() -> String {
        // SAFETY: `ghm_last_error` returns a valid NUL-terminated string.
        unsafe { CStr::from_ptr(ghm_last_error()) }
            .to_string_lossy()
            .into_owned()
    }

    fn expert_bundle() -> Vec<u8> {
        let spec = RunSpec {
            model: PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("models/lettuce.ghm"),
            weather: Default::default(),
            plant: Default::default(),
            controller: ControllerSpec::Expert,
        };
        Bundle::from_spec(&spec).unwrap().to_bytes()
    }

    #[test]
    fn a_bad_bundle_is_an_error_with_a_message_not_a_crash() {
        let mut out = std::ptr::null_mut();
        let junk = b"{not json";
        // SAFETY: a valid buffer and out pointer.
        let status = unsafe { ghm_controller_from_bundle(junk.as_ptr(), junk.len(), &mut out) };
        assert_eq!(status, GhmStatus::InvalidBundle);
        assert!(out.is_null());
        assert!(
            last_error().contains("bundle is unreadable"),
            "{}",
            last_error()
        );
        // SAFETY: null pointers are checked.
        let status = unsafe { ghm_controller_from_bundle(std::ptr::null(), 0, &mut out) };
        assert_eq!(status, GhmStatus::InvalidArgument);
        assert!(last_error().contains("null"), "{}", last_error());
    }

    #[test]
    fn decide_checks_sizes_finiteness_and_the_forecast() {
        let bundle = expert_bundle();
        let mut c = std::ptr::null_mut();
        // SAFETY: a valid buffer and out pointer.
        let status = unsafe { ghm_controller_from_bundle(bundle.as_ptr(), bundle.len(), &mut c) };
        assert_eq!(status, GhmStatus::Ok, "{}", last_error());
        let mut sizes = GhmSizes {
            states: 0,
            inputs: 0,
            disturbances: 0,
            outputs: 0,
            forecast_rows: 0,
            sample_period_s: 0.0,
        };
        // SAFETY: a live handle and a writable struct.
        assert_eq!(
            unsafe { ghm_controller_sizes(c, &mut sizes) },
            GhmStatus::Ok
        );
        assert_eq!((sizes.states, sizes.inputs, sizes.disturbances), (4, 3, 4));
        assert_eq!((sizes.forecast_rows, sizes.sample_period_s), (1, 1800.0));
        // SAFETY: a live handle; the name is owned by it.
        let name =
            unsafe { CStr::from_ptr(ghm_controller_name(c, GhmQuantity::Disturbance as u32, 0)) };
        assert_eq!(name.to_str().unwrap(), "rad_Wm2");
        // SAFETY: as above.
        assert!(unsafe { ghm_controller_name(c, GhmQuantity::State as u32, 4) }.is_null());
        let (mut x, mut u) = ([0.0; 4], [0.0; 3]);
        // SAFETY: buffers of the sizes given.
        let status = unsafe { ghm_controller_start(c, x.as_mut_ptr(), 4, u.as_mut_ptr(), 3) };
        assert_eq!(status, GhmStatus::Ok);
        assert_eq!(x[2], 15.0);
        let d = [0.0, 0.0008, 10.0, 0.006];
        let mut input = [0.0; 3];
        let mut decide = |x: &[f64], n_x: usize, forecast: &[f64], n_out: usize| {
            // SAFETY: each array holds at least the count given.
            unsafe {
                ghm_controller_decide(
                    c,
                    0,
                    x.as_ptr(),
                    n_x,
                    u.as_ptr(),
                    3,
                    forecast.as_ptr(),
                    forecast.len(),
                    input.as_mut_ptr(),
                    n_out,
                    std::ptr::null_mut(),
                )
            }
        };
        assert_eq!(decide(&x, 4, &d, 3), GhmStatus::Ok, "{}", last_error());
        assert_eq!(decide(&x, 3, &d, 3), GhmStatus::InvalidArgument);
        assert!(last_error().contains("state has 3 numbers; the model has 4"));
        assert_eq!(decide(&x, 4, &d[..3], 3), GhmStatus::InvalidArgument);
        assert!(last_error().contains("not a whole number of rows"));
        assert_eq!(decide(&x, 4, &[], 3), GhmStatus::InvalidArgument);
        assert!(last_error().contains("the forecast has 0 rows"));
        assert_eq!(decide(&x, 4, &d, 2), GhmStatus::InvalidArgument);
        assert!(last_error().contains("input_out has room for 2"));
        let bad = [f64::NAN, 0.001, 15.0, 0.008];
        assert_eq!(decide(&bad, 4, &d, 3), GhmStatus::InvalidArgument);
        assert!(
            last_error().contains("dry_weight = NaN"),
            "{}",
            last_error()
        );
        let mut next = [0.0; 4];
        // SAFETY: buffers of the sizes given.
        let status = unsafe {
            ghm_controller_plant_step(
                c,
                x.as_ptr(),
                4,
                input.as_ptr(),
                3,
                d.as_ptr(),
                4,
                next.as_mut_ptr(),
                4,
            )
        };
        assert_eq!(status, GhmStatus::Ok, "{}", last_error());
        assert!(next[0] > 0.0 && next[0] != x[0]);
        // SAFETY: null is refused, not dereferenced.
        let status = unsafe { ghm_controller_sizes(std::ptr::null_mut(), &mut sizes) };
        assert_eq!(status, GhmStatus::InvalidArgument);
        // SAFETY: freed once.
        unsafe { ghm_controller_free(c) };
    }
}
