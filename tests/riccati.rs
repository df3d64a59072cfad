//! The Riccati recursion against an independent solve of the whole KKT matrix: random
//! stage-structured problems are assembled as one sparse matrix (sprs), whose solution
//! (dense LU) and inertia (dense symmetric eigenvalues) the recursion must reproduce —
//! the step and the multipliers to 1e-9, and "factorised" exactly when the KKT matrix has
//! as many positive eigenvalues as variables and as many negative ones as constraints.

use ghm::solve::riccati::{Riccati, Stage, Terminal};
use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sprs::TriMat;

/// A random problem: stage sizes `nz[k]`, `nv[k]`; symmetric Hessians whose diagonal is
/// shifted by `curvature` (negative values make indefinite blocks likely).
fn random_problem(rng: &mut ChaCha8Rng, nz: &[usize], nv: &[usize], curvature: f64) -> Riccati {
    let n = nv.len();
    let symmetric = |size: usize, rng: &mut ChaCha8Rng| {
        let m = DMatrix::from_fn(size, size, |_, _| rng.random_range(-1.0..1.0));
        let mut h = (&m + m.transpose()) * 0.5;
        for i in 0..size {
            h[(i, i)] += curvature;
        }
        h
    };
    let stages = (0..n)
        .map(|k| {
            let mut s = Stage::zeros(nz[k], nv[k], nz[k + 1]);
            s.h = symmetric(nz[k] + nv[k], rng);
            s.q = DVector::from_fn(nz[k] + nv[k], |_, _| rng.random_range(-1.0..1.0));
            s.a = DMatrix::from_fn(nz[k + 1], nz[k], |_, _| rng.random_range(-1.0..1.0));
            s.b = DMatrix::from_fn(nz[k + 1], nv[k], |_, _| rng.random_range(-1.0..1.0));
            s.c = DVector::from_fn(nz[k + 1], |_, _| rng.random_range(-1.0..1.0));
            s
        })
        .collect();
    let mut terminal = Terminal::zeros(nz[n]);
    terminal.h = symmetric(nz[n], rng);
    terminal.q = DVector::from_fn(nz[n], |_, _| rng.random_range(-1.0..1.0));
    Riccati::new(stages, terminal)
}

/// The KKT matrix of the problem with `δ · shift` on the Hessian (and `control_deltas[k] ·
/// shift` on stage `k`'s controls), over the variables `[z_0 v_0 z_1 v_1 … z_N]` and the
/// constraints `z_0 = 0` and the dynamics (as `z_{k+1} − A z_k − B v_k = c_k`), assembled
/// with sprs; and its right-hand side.
fn assemble(
    r: &Riccati,
    delta: f64,
    control_deltas: &[f64],
) -> (DMatrix<f64>, DVector<f64>, Vec<usize>, usize) {
    let n = r.horizon();
    let mut offsets = Vec::new();
    let mut at = 0;
    for s in &r.stages {
        offsets.push(at);
        at += s.nz() + s.nv();
    }
    offsets.push(at);
    let n_vars = at + r.terminal.h.nrows();
    let n_cons = r.stages[0].nz() + r.stages.iter().map(|s| s.c.len()).sum::<usize>();
    let size = n_vars + n_cons;
    let mut kkt = TriMat::new((size, size));
    let mut rhs = DVector::zeros(size);
    let hessian = |o: usize,
                   h: &DMatrix<f64>,
                   shift: &DVector<f64>,
                   controls: (usize, f64),
                   kkt: &mut TriMat<f64>| {
        for i in 0..h.nrows() {
            for j in 0..h.ncols() {
                let own = if i >= controls.0 { controls.1 } else { 0.0 };
                let v = h[(i, j)]
                    + if i == j {
                        (delta + own) * shift[i]
                    } else {
                        0.0
                    };
                kkt.add_triplet(o + i, o + j, v);
            }
        }
    };
    for (k, s) in r.stages.iter().enumerate() {
        let controls = (s.nz(), control_deltas.get(k).copied().unwrap_or(0.0));
        hessian(offsets[k], &s.h, &s.shift, controls, &mut kkt);
        for i in 0..s.q.len() {
            rhs[offsets[k] + i] = -s.q[i];
        }
    }
    let no_controls = (r.terminal.h.nrows(), 0.0);
    hessian(
        offsets[n],
        &r.terminal.h,
        &r.terminal.shift,
        no_controls,
        &mut kkt,
    );
    for i in 0..r.terminal.q.len() {
        rhs[offsets[n] + i] = -r.terminal.q[i];
    }
    let mut row = n_vars;
    let constraint = |kkt: &mut TriMat<f64>, col: usize, v: f64, row: usize| {
        kkt.add_triplet(row, col, v);
        kkt.add_triplet(col, row, v);
    };
    for i in 0..r.stages[0].nz() {
        constraint(&mut kkt, offsets[0] + i, 1.0, row);
        row += 1;
    }
    let mut dynamics_rows = Vec::new();
    for (k, s) in r.stages.iter().enumerate() {
        dynamics_rows.push(row);
        for i in 0..s.c.len() {
            constraint(&mut kkt, offsets[k + 1] + i, 1.0, row + i);
            for j in 0..s.nz() {
                constraint(&mut kkt, offsets[k] + j, -s.a[(i, j)], row + i);
            }
            for j in 0..s.nv() {
                constraint(&mut kkt, offsets[k] + s.nz() + j, -s.b[(i, j)], row + i);
            }
            rhs[row + i] = s.c[i];
        }
        row += s.c.len();
    }
    let csc = kkt.to_csc::<usize>();
    let mut dense = DMatrix::zeros(size, size);
    for (v, (i, j)) in csc.iter() {
        dense[(i, j)] += *v;
    }
    (dense, rhs, offsets, n_vars)
}

fn check(seed: u64, nz: &[usize], nv: &[usize], curvature: f64, delta: f64) -> bool {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut r = random_problem(&mut rng, nz, nv, curvature);
    assert!(r.is_consistent());
    let (kkt, rhs, offsets, n_vars) = assemble(&r, delta, &[]);
    let (positive, negative) = inertia(&kkt);
    let right_inertia = positive == n_vars && negative == kkt.nrows() - n_vars;
    let factored = r.factor(delta).is_ok();
    assert_eq!(
        factored,
        right_inertia,
        "seed {seed}: inertia ({positive}, {negative}) of {} × {}",
        kkt.nrows(),
        kkt.ncols()
    );
    if !factored {
        return false;
    }
    assert!(r.solve());
    matches_kkt_solve(&r, &kkt, &rhs, &offsets, n_vars);
    true
}

/// Positive and negative eigenvalues of a symmetric matrix.
fn inertia(kkt: &DMatrix<f64>) -> (usize, usize) {
    let eigen = kkt.clone().symmetric_eigen().eigenvalues;
    let positive = eigen.iter().filter(|&&l| l > 1e-10).count();
    let negative = eigen.iter().filter(|&&l| l < -1e-10).count();
    (positive, negative)
}

/// The solved recursion's step and multipliers against the assembled system's, to 1e-9.
fn matches_kkt_solve(
    r: &Riccati,
    kkt: &DMatrix<f64>,
    rhs: &DVector<f64>,
    offsets: &[usize],
    n_vars: usize,
) {
    let solution = kkt
        .clone()
        .lu()
        .solve(rhs)
        .expect("the KKT matrix is regular");
    let tolerance = 1e-9 * solution.amax().max(1.0);
    for (k, s) in r.stages.iter().enumerate() {
        for i in 0..s.nz() {
            assert!(
                (r.z[k][i] - solution[offsets[k] + i]).abs() <= tolerance,
                "z"
            );
        }
        for i in 0..s.nv() {
            assert!(
                (r.v[k][i] - solution[offsets[k] + s.nz() + i]).abs() <= tolerance,
                "v"
            );
        }
    }
    let n = r.horizon();
    for i in 0..r.terminal.h.nrows() {
        assert!(
            (r.z[n][i] - solution[offsets[n] + i]).abs() <= tolerance,
            "z_N"
        );
    }
    // The dynamics multipliers: the sparse system's, whose rows are written
    // `z_{k+1} − A z − B v = c`, are the Riccati's `−μ`.
    let mut row = n_vars + r.stages[0].nz();
    for (k, s) in r.stages.iter().enumerate() {
        for i in 0..s.c.len() {
            assert!((r.mu[k][i] + solution[row + i]).abs() <= tolerance, "μ");
        }
        row += s.c.len();
    }
}

#[test]
fn positive_definite_problems_match_the_assembled_kkt_solve() {
    for seed in 0..20 {
        assert!(check(seed, &[0, 3, 4, 2, 3], &[2, 3, 1, 2], 4.0, 0.0));
    }
}

#[test]
fn indefinite_blocks_with_a_positive_reduced_hessian_are_solved_as_they_are() {
    // Indefinite stage blocks: the recursion must accept exactly those problems whose
    // KKT matrix has the inertia of a minimum, and solve them without any shift.
    let (mut accepted, mut refused) = (0, 0);
    for seed in 0..200 {
        if check(seed, &[0, 2, 3, 2], &[3, 2, 3], 0.6, 0.0) {
            accepted += 1;
        } else {
            refused += 1;
        }
    }
    // Both cases occur, so both branches of the inertia test were compared.
    assert!(
        accepted >= 5 && refused >= 5,
        "{accepted} accepted, {refused} refused"
    );
}

#[test]
fn a_shift_restores_the_inertia() {
    for seed in 0..20 {
        let nz = [1, 2, 2];
        let nv = [2, 2];
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut r = random_problem(&mut rng, &nz, &nv, -3.0);
        assert!(
            r.factor(0.0).is_err(),
            "seed {seed}: negative curvature everywhere"
        );
        // A large enough shift always cures it, and the cured system matches its KKT solve.
        assert!(check(seed, &nz, &nv, -3.0, 50.0));
    }
}

#[test]
fn the_stage_wise_correction_is_the_newton_step_of_a_hessian_corrected_only_in_failing_controls() {
    let (nz, nv) = ([1, 2, 3, 2], [2, 2, 3]);
    let mut corrected_stages = 0;
    for seed in 0..40 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut r = random_problem(&mut rng, &nz, &nv, -1.0);
        for s in &mut r.stages {
            // Unequal shifts: the correction must respect the metric it is given.
            for (i, d) in s.shift.iter_mut().enumerate() {
                *d = 0.5 + 0.25 * i as f64;
            }
        }
        let uncorrected = r.factor(0.0).is_ok();
        let count = r
            .factor_corrected()
            .expect("a positive shift on every control");
        assert_eq!(count == 0, uncorrected, "seed {seed}");
        let deltas = r.corrections().to_vec();
        assert_eq!(
            deltas.iter().filter(|&&d| d > 0.0).count(),
            count,
            "seed {seed}"
        );
        corrected_stages += count;
        assert!(r.solve());
        // The assembled KKT matrix with exactly these control shifts (no state, no
        // terminal shift) has the inertia of a minimum, and its solution is the step.
        let (kkt, rhs, offsets, n_vars) = assemble(&r, 0.0, &deltas);
        let (positive, negative) = inertia(&kkt);
        assert_eq!(
            (positive, negative),
            (n_vars, kkt.nrows() - n_vars),
            "seed {seed}"
        );
        matches_kkt_solve(&r, &kkt, &rhs, &offsets, n_vars);
        // Each correction is near its least: four fifths of it leave that stage's
        // reduced Hessian, and so the whole KKT matrix, with the wrong inertia.
        for k in 0..deltas.len() {
            if deltas[k] == 0.0 {
                continue;
            }
            let mut smaller = deltas.clone();
            smaller[k] *= 0.8;
            let (kkt, _, _, n_vars) = assemble(&r, 0.0, &smaller);
            let (positive, _) = inertia(&kkt);
            assert!(
                positive < n_vars,
                "seed {seed}, stage {k}: δ_k is not near its least"
            );
        }
    }
    assert!(
        corrected_stages >= 20,
        "only {corrected_stages} corrected stages"
    );
}
