//! The derivative sweeps compiled once more for the wide vector units of the processor
//! they run on, chosen at run time.
//!
//! A release build targets plain x86-64, whose vectors hold two floats: one [`Lanes`]
//! number's eight derivative lanes take four instructions per operation. The same code
//! compiled for AVX2 (four floats) or AVX-512 (eight) takes two or one. The functions
//! below compile the forward and reverse sweeps for each, and pick the widest the processor
//! has (the check is one cached load). Without fused multiply-adds, which the compiler
//! never forms on its own in Rust, every result is the plain build's to the bit; only the
//! width of the registers changes.
//!
//! [`Lanes`]: super::Lanes

use super::activity::ActiveArgs;
use super::lanes::Lanes;
use super::sweep::{forward_sweep, reverse_sweep};
use super::{Tape, Workspace};

type Lane = Lanes<f64>;

/// The vector unit the sweeps run on, the widest this processor has.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
enum Width {
    Avx512,
    Avx2,
    Plain,
}

fn widest() -> Width {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            return Width::Avx512;
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            return Width::Avx2;
        }
    }
    Width::Plain
}

/// [`forward_sweep`], on the widest vector unit.
pub(crate) fn forward(tape: &Tape, active: &[ActiveArgs], ws: &mut Workspace<Lane>) {
    match widest() {
        // SAFETY: the processor has the features these were compiled for (just checked).
        #[cfg(target_arch = "x86_64")]
        Width::Avx512 => unsafe { x86::forward_avx512(tape, active, ws) },
        #[cfg(target_arch = "x86_64")]
        Width::Avx2 => unsafe { x86::forward_avx2(tape, active, ws) },
        _ => forward_sweep(tape, active, ws),
    }
}

/// [`reverse_sweep`] on [`Lanes`] numbers, on the widest vector unit.
pub(crate) fn reverse(
    tape: &Tape,
    active: &[ActiveArgs],
    ws: &Workspace<Lane>,
    weights: &[f64],
    adjoint: &mut [Lane],
    live: &mut [bool],
) {
    match widest() {
        // SAFETY: as in `forward`.
        #[cfg(target_arch = "x86_64")]
        Width::Avx512 => unsafe { x86::reverse_avx512(tape, active, ws, weights, adjoint, live) },
        #[cfg(target_arch = "x86_64")]
        Width::Avx2 => unsafe { x86::reverse_avx2(tape, active, ws, weights, adjoint, live) },
        _ => reverse_sweep(tape, active, ws, weights, adjoint, live),
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    //! The sweeps inlined into functions compiled for AVX2 and AVX-512.
    use super::*;

    /// The two sweeps compiled with target feature `$feature`, as `$forward` and `$reverse`.
    macro_rules! sweeps_for {
        ($feature:literal, $forward:ident, $reverse:ident) => {
            #[target_feature(enable = $feature)]
            pub(super) fn $forward(tape: &Tape, active: &[ActiveArgs], ws: &mut Workspace<Lane>) {
                forward_sweep(tape, active, ws)
            }

            #[target_feature(enable = $feature)]
            pub(super) fn $reverse(
                tape: &Tape,
                active: &[ActiveArgs],
                ws: &Workspace<Lane>,
                weights: &[f64],
                adjoint: &mut [Lane],
                live: &mut [bool],
            ) {
                reverse_sweep(tape, active, ws, weights, adjoint, live)
            }
        };
    }

    sweeps_for!("avx512f", forward_avx512, reverse_avx512);
    sweeps_for!("avx2", forward_avx2, reverse_avx2);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::graph::activity::active_args;
    use crate::graph::{Graph, Op, LANES};

    /// Every path of the sweeps: passive arithmetic and functions, each arithmetic op with
    /// one passive argument on either side, and the smooth and choosing functions on
    /// active values. Inputs `(x0, x1, x2)` are differentiated, `(p0, p1)` are not.
    fn every_path() -> Tape {
        let mut g = Graph::new();
        let [x0, x1, x2, p0, p1] = [0, 1, 2, 3, 4].map(|i| g.var(i));
        let passive = [
            g.mul(p0, p1),
            g.div(p0, p1),
            g.add(p0, p1),
            g.sub(p0, p1),
            g.apply(Op::Exp, &[p0]),
            g.power(p1, 1.7),
        ];
        let p = passive.into_iter().fold(p0, |acc, v| g.add(acc, v));
        let x0x1 = g.mul(x0, x1);
        let mixed = [
            g.mul(x0, p),
            g.mul(p, x1),
            g.div(x2, p),
            g.div(p, x1),
            g.add(x0, p),
            g.sub(p, x1),
            g.sub(x2, p1),
        ];
        let lt = g.apply(Op::Lt, &[x0, x2]);
        let smooth = [
            g.apply(Op::Exp, &[x0x1]),
            g.apply(Op::Sin, &[x2]),
            g.apply(Op::Tanh, &[x0]),
            g.apply(Op::Log, &[x1]),
            g.power(x2, 0.5),
            g.power(x0, 2.5),
            g.power(x1, 3.0),
            g.apply(Op::Pow, &[x0, x1]),
            g.apply(Op::Min, &[x0, x2]),
            g.apply(Op::Max, &[x0x1, p1]),
            g.apply(Op::Select, &[lt, x1, x2]),
            g.apply(Op::Abs, &[x0]),
        ];
        let outputs: Vec<_> = mixed
            .chunks(2)
            .chain(smooth.chunks(3))
            .map(|group| group.iter().fold(x2, |acc, &v| g.mul(acc, v)))
            .collect();
        g.compile(&outputs, 5)
    }

    /// The sweeps of [`Derivatives`](super::super::Derivatives), on the widest unit and
    /// skipping zero lanes, give the numbers of the plain interpreter on dual numbers (up
    /// to the sign of a zero).
    #[test]
    fn the_wide_sweeps_give_the_dual_numbers_of_the_plain_interpreter() {
        let tape = every_path();
        let z = [0.3, 1.7, 0.9, 2.5, 0.8];
        let wrt = [0, 1, 2];
        let active = active_args(&tape, &wrt);
        let weights: Vec<f64> = (0..tape.n_outputs())
            .map(|i| 0.5 - 0.1 * i as f64)
            .collect();
        let sweeps = |wide: bool| {
            let mut ws = tape.workspace::<Lane>();
            for (i, &v) in z.iter().enumerate() {
                ws.slots[i] = Lane::from(v);
            }
            for (l, &i) in wrt.iter().enumerate() {
                ws.slots[i] = ws.slots[i].derivative(l);
                ws.slots[i].eps.0[LANES - 1] = 0.25 * (i + 1) as f64;
            }
            let mut adjoint = vec![Lane::from(0.0); tape.n_slots()];
            let mut live = vec![false; tape.n_slots()];
            if wide {
                forward(&tape, &active, &mut ws);
                reverse(&tape, &active, &ws, &weights, &mut adjoint, &mut live);
            } else {
                tape.run(&mut ws);
                reverse_sweep(&tape, &active, &ws, &weights, &mut adjoint, &mut live);
            }
            let numbers = |d: &Lane| [d.re].into_iter().chain(d.eps.0);
            let outputs = tape
                .outputs
                .iter()
                .flat_map(|&s| numbers(&ws.slots[s as usize]));
            let adjoints = wrt.iter().flat_map(|&i| numbers(&adjoint[i]));
            outputs.chain(adjoints).collect::<Vec<f64>>()
        };
        let (wide, plain) = (sweeps(true), sweeps(false));
        assert_eq!(wide.len(), (tape.n_outputs() + wrt.len()) * (LANES + 1));
        // Lanes 3 to 6 are seeded with zeros; the others must carry something to compare.
        assert!(plain.iter().all(|v| v.is_finite()));
        assert!(plain.iter().filter(|&&v| v != 0.0).count() > plain.len() / 3);
        assert_eq!(wide, plain);
        if widest() == Width::Plain {
            eprintln!("no AVX2 or AVX-512 here: the wide sweeps are the plain ones");
        }
    }
}
