//! The two sweeps every derivative of [`super::derivative`] is made of, on the tape's
//! instructions: forward on [`Lanes`] numbers, skipping lanes known to be zero, and
//! reverse (adjoint), accumulating `∂(Σ wᵢ outᵢ)/∂slot` over any [`Real`]. Both are
//! inlined wherever they are called, so that [`super::wide`] can compile them for wider
//! vector units.

use super::activity::{is_active, ActiveArgs, FIRST_ONLY, SECOND_ONLY};
use super::lanes::Lanes;
use super::{Op, Real, Tape, Workspace};

type Lane = Lanes<f64>;

/// Runs the tape on [`Lanes`] numbers whose inputs are in place in `ws`, without the
/// lanes that are known to be zero: a passive sum, difference, product or quotient
/// (`active`, from [`active_args`](super::activity::active_args)) is evaluated on
/// floats, and one with a single passive argument scales or copies the active one's lanes
/// instead of forming the dual product or sum with zero lanes. The same numbers as
/// [`Tape::run`], up to the sign of a zero lane; the passive slots written on floats keep
/// the zero lanes they had (every workspace starts with them, and only such values are
/// ever written there).
// Inlined into the functions of `wide` compiled for wider vector units.
#[inline(always)]
pub(crate) fn forward_sweep(tape: &Tape, active: &[ActiveArgs], ws: &mut Workspace<Lane>) {
    let s = &mut ws.slots;
    assert!(
        s.len() >= tape.n_slots() && active.len() == tape.instructions().len(),
        "a workspace or activity of another tape"
    );
    for (ins, &args) in tape.instructions().iter().zip(active) {
        let [a, b, c] = ins.args.map(|slot| slot as usize);
        // SAFETY: every slot an instruction reads or writes is below `n_slots`
        // (`Tape::checked`), which is at most `s.len()` (asserted above).
        let (da, db, dc) = unsafe { (s.get_unchecked(a), s.get_unchecked(b), s.get_unchecked(c)) };
        let value = match (ins.op, args) {
            // A passive value as the dual arithmetic rounds it (`a · b⁻¹` for a quotient):
            // the other ops through their dual form below, since num-dual rounds some of
            // them otherwise than floats do (`x^n` as `x^(n−3)·x·x·x`).
            (Op::Add, 0) => Lane::from(da.re + db.re),
            (Op::Sub, 0) => Lane::from(da.re - db.re),
            (Op::Mul, 0) => Lane::from(da.re * db.re),
            (Op::Div, 0) => Lane::from(da.re * db.re.recip()),
            (Op::Mul, FIRST_ONLY) => Lane::new(da.re * db.re, da.eps * db.re),
            (Op::Mul, SECOND_ONLY) => Lane::new(da.re * db.re, db.eps * da.re),
            (Op::Add, FIRST_ONLY) => Lane::new(da.re + db.re, da.eps),
            (Op::Add, SECOND_ONLY) => Lane::new(da.re + db.re, db.eps),
            (Op::Sub, FIRST_ONLY) => Lane::new(da.re - db.re, da.eps),
            (Op::Sub, SECOND_ONLY) => Lane::new(da.re - db.re, -db.eps),
            (Op::Div, FIRST_ONLY) => {
                // The rounding of the dual quotient, `(a′·b − 0·a) / b²`, without the zero.
                let inv = db.re.recip();
                Lane::new(da.re * inv, da.eps * db.re * inv * inv)
            }
            (op, _) => op.apply(*da, *db, *dc),
        };
        // SAFETY: as above.
        unsafe { *s.get_unchecked_mut(ins.out as usize) = value };
    }
}

/// Accumulates adjoints `∂(Σ wᵢ outᵢ)/∂slot` over `T`, from the values left in `ws` by a
/// forward run. An input's adjoint is its derivative, zero where nothing weighted depends
/// on it; any other slot's holds its own where `live[s]` and is left as it was elsewhere.
///
/// Only slots that reach an output of non-zero weight through the branches taken are
/// visited (`live`, one flag per slot): the untaken branch of an `if`, `min` or `max`
/// ([`Op::passed_on`]) and everything only it uses get no adjoint at all. Multiplying
/// their zero adjoint by their partials would not be zero where the branch is not defined
/// (`sqrt(-1)`: 0 · NaN = NaN), and `if(x > 0, x, sqrt(-x - 1))` would poison every
/// derivative with the branch it does not take. The forward pass needs no such care:
/// `Select` passes on the taken dual whole.
///
/// Passive slots (`active`, from [`active_args`](super::activity::active_args)) get no
/// adjoint either: nothing chosen depends on them. A product or quotient with a passive
/// argument passes the adjoint on scaled by a float, which is the dual product with zero
/// lanes, without them.
// Inlined into the functions of `wide` compiled for wider vector units.
#[inline(always)]
pub(crate) fn reverse_sweep<T: Real>(
    tape: &Tape,
    active: &[ActiveArgs],
    ws: &Workspace<T>,
    weights: &[f64],
    adjoint: &mut [T],
    live: &mut [bool],
) {
    let n_slots = tape.n_slots();
    assert!(
        adjoint.len() >= n_slots && live.len() >= n_slots && ws.slots.len() >= n_slots,
        "adjoints or a workspace too small for their tape"
    );
    // An adjoint is written before it is read (its slot's users come after it on the
    // tape), so none is zeroed first: the first increment of a slot sets it, and `live`
    // says which hold one. Zeroing every adjoint was a twelfth of a Hessian.
    live.fill(false);
    // SAFETY (every `unchecked` below): every slot is below `n_slots` (`Tape::checked`),
    // which is at most the lengths asserted above.
    let accumulate = |adjoint: &mut [T], live: &mut [bool], slot: usize, increment: T| unsafe {
        if *live.get_unchecked(slot) {
            *adjoint.get_unchecked_mut(slot) += increment;
        } else {
            *adjoint.get_unchecked_mut(slot) = increment;
            *live.get_unchecked_mut(slot) = true;
        }
    };
    for (&s, &w) in tape.outputs.iter().zip(weights) {
        if w != 0.0 {
            accumulate(adjoint, live, s as usize, T::from(w));
        }
    }
    let v = &ws.slots;
    for (ins, &args) in tape.instructions().iter().zip(active).rev() {
        let out = ins.out as usize;
        if args == 0 || !unsafe { *live.get_unchecked(out) } {
            continue;
        }
        // No skipping on `g == 0` beyond `live`: duals compare by real part only, and a
        // zero real part can carry non-zero second-order lanes.
        let g = unsafe { *adjoint.get_unchecked(out) };
        let [a, b, c] = ins.args.map(|slot| slot as usize);
        let (da, db, dc) = unsafe { (v.get_unchecked(a), v.get_unchecked(b), v.get_unchecked(c)) };
        let (va, vb, vc) = (da.re(), db.re(), dc.re());
        let mut pass = |k: usize, increment: T| {
            if is_active(args, k) {
                accumulate(adjoint, live, ins.args[k] as usize, increment);
            }
        };
        // The linear ops pass the adjoint on as it is: no product of duals needed.
        match (ins.op, args) {
            (Op::Add, _) => {
                pass(0, g);
                pass(1, g);
                continue;
            }
            (Op::Sub, _) => {
                pass(0, g);
                pass(1, -g);
                continue;
            }
            (Op::Neg, _) => {
                pass(0, -g);
                continue;
            }
            (Op::Mul, FIRST_ONLY) => {
                pass(0, g * vb);
                continue;
            }
            (Op::Mul, SECOND_ONLY) => {
                pass(1, g * va);
                continue;
            }
            (Op::Div, FIRST_ONLY) => {
                pass(0, g * vb.recip());
                continue;
            }
            _ => {}
        }
        if let Some(k) = ins.op.passed_on(va, vb, vc) {
            // ∂/∂taken = 1; nothing else (an `if`'s condition is piecewise constant).
            pass(k, g);
            continue;
        }
        let p = ins
            .op
            .partials(*da, *db, *dc, unsafe { *v.get_unchecked(out) });
        // Unrolled, not a loop over `p`: the loop read the partials back from memory in
        // pieces other than those they were written in, and stalled on every read.
        let [p0, p1, p2] = p;
        let arity = ins.op.arity();
        pass(0, g * p0);
        if arity > 1 {
            pass(1, g * p1);
        }
        if arity > 2 {
            pass(2, g * p2);
        }
    }
    // No instruction reads an input's adjoint, so the unset ones are zeroed here, once,
    // rather than checked by every caller.
    for (a, &is_live) in adjoint[..tape.n_inputs]
        .iter_mut()
        .zip(&live[..tape.n_inputs])
    {
        if !is_live {
            *a = T::zero();
        }
    }
}
