#!/usr/bin/env python3
"""PyTorch reference of the S2D decoder (the authors' network, written from
shared/notes/s2d-reference.md), for comparison with
`cargo bench -p sinew-host --bench s2d_decode` (single frame) and
`cargo bench -p sinew-host --bench s2d_train_step` (`--train`); results in docs/BENCHMARKS.md
and docs/results/S2D.md.

Same shapes as the Rust benchmarks: levels of 5023/1256/314/79/20 vertices (+ one dummy each),
spirals [15, 14, 9, 9, 7] with random indices, up-sampling U with three random barycentric
parents per vertex (torch sparse COO, multiplied with torch.sparse.mm as the reference does),
FC 204 -> 21*128, stages 64/32/32/16 with ELU and the dummy row zeroed, output conv to 3:
666,083 parameters. `--ict` uses the ICT-FaceKit face region's level sizes and spiral lengths
instead (9409/2353/589/148/37, [12, 14, 9, 10, 9]; 1,118,675 parameters), the partner of the
Rust benchmark's `core_decode_ict_synthetic`. Random values: the cost does not depend on them.
Run on demand:

    python3 scripts/bench_torch_s2d_decode.py [--threads 1] [--iters 200] [--train] [--ict]
"""
import argparse
import time

import torch

SIZES = [5023, 1256, 314, 79, 20]
SPIRALS = [15, 14, 9, 9, 7]
ICT_SIZES = [9409, 2353, 589, 148, 37]
ICT_SPIRALS = [12, 14, 9, 10, 9]
FILTERS = [64, 32, 32, 16]


def hierarchy(gen):
    spirals, ups = [], []
    for n, length in zip(SIZES, SPIRALS):
        s = torch.randint(0, n + 1, (n + 1, length), generator=gen)
        s[:, 0] = torch.arange(n + 1)
        s[n, :] = n
        spirals.append(s)
    for fine, coarse in zip(SIZES[:-1], SIZES[1:]):
        rows = torch.arange(fine).repeat_interleave(3)
        cols = torch.randint(0, coarse, (3 * fine,), generator=gen)
        w = torch.rand(fine, 3, generator=gen)
        w = (w / w.sum(1, keepdim=True)).reshape(-1)
        rows = torch.cat([rows, torch.tensor([fine])])
        cols = torch.cat([cols, torch.tensor([coarse])])
        w = torch.cat([w, torch.tensor([1.0])])
        ups.append(torch.sparse_coo_tensor(torch.stack([rows, cols]), w, (fine + 1, coarse + 1)).coalesce())
    return spirals, ups


class SpiralConv(torch.nn.Module):
    def __init__(self, cin, cout, spiral, activation):
        super().__init__()
        self.spiral = spiral
        self.linear = torch.nn.Linear(cin * spiral.shape[1], cout)
        self.activation = activation

    def forward(self, x):
        b, n, f = x.shape
        g = x.index_select(1, self.spiral.reshape(-1)).reshape(b, n, -1)
        y = self.linear(g)
        if self.activation:
            y = torch.nn.functional.elu(y)
        mask = torch.ones(1, n, 1)
        mask[0, -1, 0] = 0.0
        return y * mask


class Decoder(torch.nn.Module):
    def __init__(self, spirals, ups):
        super().__init__()
        self.ups = ups
        self.fc = torch.nn.Linear(204, (SIZES[-1] + 1) * 128)
        convs, width = [], 128
        for stage, f in enumerate(FILTERS):
            level = len(SIZES) - 2 - stage
            convs.append(SpiralConv(width, f, spirals[level], True))
            width = f
        convs.append(SpiralConv(width, 3, spirals[0], False))
        self.convs = torch.nn.ModuleList(convs)

    def pool(self, x, u):
        b, n, f = x.shape
        y = torch.sparse.mm(u, x.permute(1, 0, 2).reshape(n, -1))
        return y.reshape(u.shape[0], b, f).permute(1, 0, 2)

    def forward(self, x):
        h = self.fc(x).reshape(x.shape[0], SIZES[-1] + 1, 128)
        for stage in range(len(FILTERS)):
            h = self.pool(h, self.ups[len(SIZES) - 2 - stage])
            h = self.convs[stage](h)
        return self.convs[-1](h)[:, :-1]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--iters", type=int, default=200)
    ap.add_argument("--train", action="store_true", help="time a batch-16 Adam step instead")
    ap.add_argument("--ict", action="store_true", help="the ICT face region's sizes instead of FLAME's")
    args = ap.parse_args()
    if args.ict:
        SIZES[:] = ICT_SIZES
        SPIRALS[:] = ICT_SPIRALS
    torch.set_num_threads(args.threads)
    gen = torch.Generator().manual_seed(1)
    torch.manual_seed(1)
    spirals, ups = hierarchy(gen)
    net = Decoder(spirals, ups)
    params = sum(p.numel() for p in net.parameters())
    print(f"parameters: {params}")
    if args.train:
        opt = torch.optim.Adam(net.parameters(), lr=1e-3, weight_decay=5e-5)
        x = torch.rand(16, 204) * 0.1 - 0.05
        gt = torch.rand(16, SIZES[0], 3) * 0.02 - 0.01
        w = torch.rand(1, SIZES[0], 1)

        def step():
            opt.zero_grad()
            e = (net(x) - gt).abs()
            loss = (e * w).sum() / (16 * 3) + 0.1 * e.mean()
            loss.backward()
            opt.step()
            return loss.item()

        for _ in range(3):
            step()
        times = []
        for _ in range(args.iters):
            t = time.perf_counter()
            step()
            times.append(time.perf_counter() - t)
        times.sort()
        print(f"train step batch 16, {args.threads} thread(s): median {1e3 * times[len(times) // 2]:.1f} ms")
        return
    x = torch.rand(1, 204) * 0.1 - 0.05
    with torch.inference_mode():
        for _ in range(10):
            net(x)
        times = []
        for _ in range(args.iters):
            t = time.perf_counter()
            net(x)
            times.append(time.perf_counter() - t)
    times.sort()
    print(f"decode batch 1 ({SIZES[0]} vertices), {args.threads} thread(s): median {1e6 * times[len(times) // 2]:.0f} us, "
          f"min {1e6 * times[0]:.0f} us")


if __name__ == "__main__":
    main()
