//! Which arguments of each instruction depend on the inputs being differentiated.
//!
//! A slot computed from constants and from inputs outside the chosen set (a plant's
//! weather and parameters) is *passive*: no derivative depends on its adjoint. A plant's
//! step is almost all active, but about half of its instructions mix one active argument
//! with a passive one (a coefficient times a state, a state plus a constant: 528 of the
//! 1024 in the thesis lettuce step). The reverse sweep of [`super::derivative`] gives the
//! passive argument no adjoint, and multiplies the active one's by a float where the
//! partial is passive (`∂(a·b)/∂a = b`): the dual product without its zero lanes. What
//! remains is the same arithmetic, operation for operation, so the derivatives keep every
//! bit (up to the sign of a zero).

use super::Tape;

/// One bit per argument of an instruction: bit `k` is set when argument `k` is active.
/// Zero: the instruction itself is passive.
pub(crate) type ActiveArgs = u8;

/// Only the first argument of a binary instruction is active.
pub(crate) const FIRST_ONLY: ActiveArgs = 0b01;
/// Only the second argument of a binary instruction is active.
pub(crate) const SECOND_ONLY: ActiveArgs = 0b10;

/// Whether argument `k` is active in `args`.
#[inline]
pub(crate) fn is_active(args: ActiveArgs, k: usize) -> bool {
    args & (1 << k) != 0
}

/// The active arguments of every instruction of `tape`, in tape order, when the inputs
/// `wrt` are the ones differentiated against.
pub(crate) fn active_args(tape: &Tape, wrt: &[usize]) -> Vec<ActiveArgs> {
    let mut active = vec![false; tape.n_slots()];
    for &i in wrt {
        active[i] = true;
    }
    tape.instructions()
        .iter()
        .map(|ins| {
            let args = (0..ins.op.arity())
                .filter(|&k| active[ins.args[k] as usize])
                .fold(0, |bits, k| bits | 1 << k);
            active[ins.out as usize] = args != 0;
            args
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::graph::Graph;

    #[test]
    fn activity_follows_the_chosen_inputs_through_the_tape() {
        // Inputs (x, y, p): differentiate against x and y only.
        let mut g = Graph::new();
        let (x, y, p) = (g.var(0), g.var(1), g.var(2));
        let p2 = g.mul(p, p); // passive
        let xp = g.mul(x, p2); // first only
        let two_y = g.scale(2.0, y); // a passive constant times an active input
        let sum = g.add(xp, two_y); // both
        let tape = g.compile(&[sum], 3);
        let args = active_args(&tape, &[0, 1]);
        assert_eq!(args.len(), tape.instructions().len());
        let by_op: Vec<(crate::graph::Op, ActiveArgs)> = tape
            .instructions()
            .iter()
            .map(|ins| ins.op)
            .zip(args.iter().copied())
            .collect();
        assert_eq!(
            by_op.iter().filter(|(_, a)| *a == 0).count(),
            1,
            "{by_op:?}"
        );
        assert_eq!(by_op.last().map(|(_, a)| *a), Some(0b11), "{by_op:?}");
        let mixed = by_op
            .iter()
            .filter(|(_, a)| *a == FIRST_ONLY || *a == SECOND_ONLY)
            .count();
        assert_eq!(mixed, 2, "{by_op:?}");
        // With every input chosen, nothing but the constants is passive.
        let all = active_args(&tape, &[0, 1, 2]);
        assert!(all.iter().all(|&a| a != 0));
    }
}
