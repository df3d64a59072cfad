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

/// The KKT matrix of the problem with `δ · shift` on the Hessian, over the variables
/// `[z_0 v_0 z_1 v_1 … z_N]` and the constraints `z_0 = 0` and the dynamics (as
/// `z_{k+1} − A z_k − B v_k = c_k`), assembled with sprs; and its right-hand side.
fn assemble(r: &Riccati, delta: f64) -> (DMatrix<f64>, DVector<f64>, Vec<usize>, usize) {
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
    let hessian = |o: usize, h: &DMatrix<f64>, shift: &DVector<f64>, kkt: &mut TriMat<f64>| {
        for i in 0..h.nrows() {
            for j in 0..h.ncols() {
                let v = h[(i, j)] + if i == j { delta * shift[i] } else { 0.0 };
                kkt.add_triplet(o + i, o + j, v);
            }
        }
    };
    for (k, s) in r.stages.iter().enumerate() {
        hessian(offsets[k], &s.h, &s.shift, &mut kkt);
        for i in 0..s.q.len() {
            rhs[offsets[k] + i] = -s.q[i];
        }
    }
    hessian(offsets[n], &r.terminal.h, &r.terminal.shift, &mut kkt);
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
    let (kkt, rhs, offsets, n_vars) = assemble(&r, delta);
    let eigen = kkt.clone().symmetric_eigen().eigenvalues;
    let positive = eigen.iter().filter(|&&l| l > 1e-10).count();
    let negative = eigen.iter().filter(|&&l| l < -1e-10).count();
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
    let solution = kkt.lu().solve(&rhs).expect("the KKT matrix is regular");
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
    true
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
