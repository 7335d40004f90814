#!/usr/bin/python3
"""The RGB MLP of fit/mlp.c in PyTorch, for bench/mlp_bench.c's comparison.

Same network (2 inputs, 5 hidden ReLU layers of 20, 3 outputs z standing
for log(1 + f)), He-uniform weights, inputs mapped to [-1, 1], the loss
mean((log(1 + expm1(z) c) - log(1 + f c))^2) with z clamped to [-30, 60],
Adam(lr 2e-3, betas 0.9/0.999, eps 1e-8), float64, 15 % held out, shuffled
mini-batches and the held-out loss every epoch, one thread.

usage: mlp_torch.py DATA.csv EPOCHS BATCH  ->  prints "us_per_epoch X"
"""
import csv
import math
import sys
import time

try:
    import torch
except ImportError:
    print("PyTorch     not installed (apt-get install python3-torch)")
    sys.exit(3)


def main():
    path, epochs, batch = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    torch.set_num_threads(1)
    torch.manual_seed(1)
    rows = []
    with open(path) as fp:
        for r in csv.DictReader(fp):
            rows.append([float(r[k]) for k in ("theta_i", "theta_r", "r", "g", "b")])
    data = torch.tensor(rows, dtype=torch.float64)
    u, f = data[:, :2], data[:, 2:]
    c = torch.cos(u[:, 0] * math.pi / 180).unsqueeze(1)
    lo, hi = u.min(0).values, u.max(0).values
    x = (u - 0.5 * (lo + hi)) * (2 / (hi - lo))
    t = torch.log1p(f * c)
    n = len(rows)
    n_val = int(math.floor(0.15 * n + 0.5))
    perm = torch.randperm(n)
    val, tr = perm[:n_val], perm[n_val:]

    layers = []
    widths = [2, 20, 20, 20, 20, 20, 3]
    for i in range(len(widths) - 1):
        lin = torch.nn.Linear(widths[i], widths[i + 1]).double()
        torch.nn.init.kaiming_uniform_(lin.weight, nonlinearity="relu")
        torch.nn.init.zeros_(lin.bias)
        layers.append(lin)
        if i + 2 < len(widths):
            layers.append(torch.nn.ReLU())
    net = torch.nn.Sequential(*layers)
    opt = torch.optim.Adam(net.parameters(), lr=2e-3, betas=(0.9, 0.999), eps=1e-8)

    def loss_of(idx):
        z = torch.clamp(net(x[idx]), -30.0, 60.0)
        p = torch.log1p(torch.expm1(z) * c[idx])
        return torch.mean((p - t[idx]) ** 2)

    start = time.perf_counter()
    for _ in range(epochs):
        order = tr[torch.randperm(len(tr))]
        for s in range(0, len(order), batch):
            opt.zero_grad()
            loss = loss_of(order[s:s + batch])
            loss.backward()
            opt.step()
        with torch.no_grad():
            loss_of(val)
    elapsed = time.perf_counter() - start
    with torch.no_grad():
        print("            PyTorch loss after training %.3g (train rows)" % loss_of(tr).item())
    print("us_per_epoch %.3f" % (1e6 * elapsed / epochs))


if __name__ == "__main__":
    main()
