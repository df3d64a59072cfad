"""CasADi's compiled stage derivatives of the lettuce step, timed in C: the peer beside
`cargo bench --bench lettuce_step -- "lettuce step"` (run both with
`benches/stage_derivatives_side_by_side.sh`).

The step is the shared peer's (`../shared/peers/greenhouse.py`: RK4, four sub-steps of
450 s), its outputs those of ghm's step tape: x⁺ (4), the stage terms (crop growth, CO₂
and heat cost) and y(x⁺) (4). At the bench's point (the model's initial state,
u = (0.6, 1, 40), d = (120, 8.633e-4, 5.6, 5.498e-3), weights 0.5 + 0.1 i) CasADi's code
generator writes three functions, each what ghm's bench times:

  F  the outputs;
  J  the outputs and their Jacobian with respect to (x, u);
  H  the outputs, that Jacobian, and the gradient and Hessian of Σ λᵢ outᵢ;

and `H only`, the Hessian alone (CasADi's least work). A C driver calls each in a loop,
without Python between the calls, and prints the median time per call over batches. Both
the peers' flags (`gcc -O2`, as `run_casadi_jit.py`) and `-O3 -march=native` are timed.

  python3 benches/casadi_stage_derivatives.py [--shared ../shared] [--calls 200000]

Needs casadi (tested: 3.8.2) and gcc.
"""
import argparse
import os
import subprocess
import sys
import tempfile

DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "stage.h"

typedef int (*eval_t)(const casadi_real**, casadi_real**, casadi_int*, casadi_real*, int);
typedef int (*work_t)(casadi_int*, casadi_int*, casadi_int*, casadi_int*);

static double now(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

static int by_value(const void* a, const void* b) {
  double x = *(const double*)a, y = *(const double*)b;
  return (x > y) - (x < y);
}

static double sink = 0.0;

static void time_one(const char* name, eval_t f, work_t work, long calls) {
  casadi_int n_arg, n_res, n_iw, n_w;
  work(&n_arg, &n_res, &n_iw, &n_w);
  static const casadi_real x[4] = {0.0035, 1.0e-3, 15.0, 0.008};
  static const casadi_real u[3] = {0.6, 1.0, 40.0};
  static const casadi_real d[4] = {120.0, 8.633266287531026e-4, 5.6, 5.49814522601458e-3};
  casadi_real lam[11];
  for (int i = 0; i < 11; ++i) lam[i] = 0.5 + 0.1 * i;
  const casadi_real** arg = calloc(n_arg + 4, sizeof(casadi_real*));
  casadi_real** res = calloc(n_res, sizeof(casadi_real*));
  for (int k = 0; k < n_res; ++k) res[k] = calloc(LARGEST_OUTPUT, sizeof(casadi_real));
  arg[0] = x; arg[1] = u; arg[2] = d; arg[3] = lam;
  casadi_int* iw = calloc(n_iw + 1, sizeof(casadi_int));
  casadi_real* w = calloc(n_w + 1, sizeof(casadi_real));
  enum { BATCHES = 31 };
  double per_call[BATCHES];
  long batch = calls / BATCHES;
  for (long i = 0; i < batch; ++i) f(arg, res, iw, w, 0);  /* warm-up */
  for (int b = 0; b < BATCHES; ++b) {
    double t0 = now();
    for (long i = 0; i < batch; ++i) {
      f(arg, res, iw, w, 0);
      sink += res[n_res - 1][0];
    }
    per_call[b] = (now() - t0) / batch;
  }
  qsort(per_call, BATCHES, sizeof(double), by_value);
  printf("%-8s %8.3f us  (batches %.3f .. %.3f)  out[0] = %.17g\n", name,
         1e6 * per_call[BATCHES / 2], 1e6 * per_call[0], 1e6 * per_call[BATCHES - 1],
         res[0][0]);
}

int main(int argc, char** argv) {
  long calls = argc > 1 ? atol(argv[1]) : 200000;
  time_one("F", F, F_work, calls);
  time_one("J", J, J_work, calls);
  time_one("H", H, H_work, calls / 2);
  time_one("H only", H_only, H_only_work, calls / 2);
  return sink == 12345.0;
}
"""


def functions(gh, ca):
    x, u, d = ca.SX.sym("x", 4), ca.SX.sym("u", 3), ca.SX.sym("d", 4)
    lam = ca.SX.sym("lam", 11)
    x_next = gh.rk4(x, u, d)
    variant = gh.get_variant("thesis")
    terms = ca.vertcat(
        variant.r_let * (x_next[0] - x[0]), gh.R_CO2 * u[0], gh.R_HEAT * u[2]
    )
    out = ca.vertcat(x_next, terms, gh.output(x_next))
    z = ca.vertcat(x, u)
    weighted = ca.dot(lam, out)
    jac = ca.jacobian(out, z)
    hess, grad = ca.hessian(weighted, z)
    return [
        ca.Function("F", [x, u, d], [out]),
        ca.Function("J", [x, u, d], [out, jac]),
        ca.Function("H", [x, u, d, lam], [out, jac, grad, hess]),
        ca.Function("H_only", [x, u, d, lam], [hess]),
    ]


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shared", default=os.path.join(here, "..", "..", "shared"))
    parser.add_argument("--calls", type=int, default=200000)
    args = parser.parse_args()
    peers = os.path.join(args.shared, "peers")
    if not os.path.exists(os.path.join(peers, "greenhouse.py")):
        sys.exit(f"no greenhouse.py under {peers}: pass --shared, the folder holding peers/")
    sys.path.insert(0, peers)
    import casadi as ca
    import greenhouse as gh

    with tempfile.TemporaryDirectory() as work:
        generator = ca.CodeGenerator("stage.c", {"with_header": True})
        generated = functions(gh, ca)
        for f in generated:
            generator.add(f)
        generator.generate(work + os.sep)
        # Each result buffer holds the largest output's non-zeros (the Jacobian's 52).
        largest = max(f.nnz_out(k) for f in generated for k in range(f.n_out()))
        with open(os.path.join(work, "driver.c"), "w") as f:
            f.write(f"#define LARGEST_OUTPUT {largest}\n" + DRIVER)
        for flags in (["-O2"], ["-O3", "-march=native"]):
            exe = os.path.join(work, "driver")
            subprocess.run(
                ["gcc", *flags, "-o", exe, "driver.c", "stage.c", "-lm"], cwd=work, check=True
            )
            print(f"CasADi {ca.__version__}, compiled with gcc {' '.join(flags)}:", flush=True)
            subprocess.run([exe, str(args.calls)], check=True)


if __name__ == "__main__":
    main()
