"""The value fit of `ghm value` in PyTorch, on the points ghm fitted, to time beside it.

`ghm value … --save-data --out DIR` writes the points (`value_data.csv`) and the fit's
settings and input box (`summary.json`); this script fits the same network to the same
points the same way and prints its time and losses:

* inputs `(x, k)` mapped from the box `[lower, upper]` onto [-5, 5] (`nn::scaled`), targets
  standardised (mean 0, variance 1), losses reported back in squared return units;
* a tanh perceptron 2 -> hidden -> 1, Xavier-uniform weights, zero biases, float32;
* Adam (0.9, 0.999, 1e-8) on the mean squared error, its rate decaying linearly to zero
  over all batches; batches drawn by shuffling the training part each epoch; a random
  fifth of the points held out for validation (ghm draws its split and shuffles with
  another generator, so the losses agree in size, not to the digit).

    python benches/value_fit_torch.py DIR [--threads 1] [--seed S]

`benches/value_fit_side_by_side.sh` runs both on one core, one after the other.
"""

import argparse
import json
import sys
import time

import numpy as np
import torch

INPUT_HALF_RANGE = 5.0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", help="a `ghm value --save-data` run folder")
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--seed", type=int, help="seed of the split, shuffles and weights (default: the fit's)")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)

    with open(f"{args.run}/summary.json") as f:
        summary = json.load(f)
    fit = summary["fit"]
    lower = np.array(summary["input_box"]["lower"])
    upper = np.array(summary["input_box"]["upper"])
    data = np.loadtxt(f"{args.run}/value_data.csv", delimiter=",", skiprows=1)
    features, returns = data[:, :2], data[:, 2]
    n = len(returns)

    z = (features - lower) * (2.0 * INPUT_HALF_RANGE / (upper - lower)) - INPUT_HALF_RANGE
    mean, var = returns.mean(), returns.var()
    y = (returns - mean) / max(np.sqrt(var), 1e-12)
    z = torch.tensor(z, dtype=torch.float32)
    y = torch.tensor(y, dtype=torch.float32).unsqueeze(1)

    seed = fit["seed"] if args.seed is None else args.seed
    generator = torch.Generator().manual_seed(seed)
    order = torch.randperm(n, generator=generator)
    n_val = min(round(n * fit["validation"]), n - 1)
    validation, train = order[:n_val], order[n_val:]

    torch.manual_seed(seed)
    widths = [2, *fit["hidden"], 1]
    layers = []
    for i, (a, b) in enumerate(zip(widths, widths[1:])):
        linear = torch.nn.Linear(a, b)
        torch.nn.init.xavier_uniform_(linear.weight)
        torch.nn.init.zeros_(linear.bias)
        layers.append(linear)
        if i < len(widths) - 2:
            layers.append(torch.nn.Tanh())
    net = torch.nn.Sequential(*layers)

    batch, epochs = fit["batch_size"], fit["epochs"]
    batches_per_epoch = -(-len(train) // batch)
    total = batches_per_epoch * epochs
    optimiser = torch.optim.Adam(net.parameters(), lr=fit["learning_rate"], eps=1e-8)
    schedule = torch.optim.lr_scheduler.LambdaLR(optimiser, lambda step: 1.0 - step / total)
    loss_fn = torch.nn.MSELoss()

    started = time.perf_counter()
    for epoch in range(1, epochs + 1):
        shuffled = train[torch.randperm(len(train), generator=generator)]
        train_sum = 0.0
        for rows in shuffled.split(batch):
            optimiser.zero_grad(set_to_none=True)
            loss = loss_fn(net(z[rows]), y[rows])
            loss.backward()
            optimiser.step()
            schedule.step()
            train_sum += loss.item() * len(rows)
        with torch.no_grad():
            val = sum(
                ((net(z[rows]) - y[rows]) ** 2).sum().item() for rows in validation.split(8192)
            )
        train_mse, val_mse = train_sum / len(train) * var, val / n_val * var
        if epoch % 10 == 0 or epoch == epochs:
            elapsed = time.perf_counter() - started
            print(f"epoch {epoch:4}: train {train_mse:.3e}, validation {val_mse:.3e} ({elapsed:.0f} s)")
    fit_s = time.perf_counter() - started
    print(
        f"torch {torch.__version__}, {args.threads} thread(s): {n} points, {epochs} epochs "
        f"in {fit_s:.1f} s; final MSE train {train_mse:.3e}, validation {val_mse:.3e}"
    )
    print(
        f"ghm (summary.json): {summary['fit_s']:.1f} s; final MSE train "
        f"{summary['train_loss']:.3e}, validation {summary['validation_loss']:.3e}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
