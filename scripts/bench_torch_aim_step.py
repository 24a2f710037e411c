#!/usr/bin/env python3
"""PyTorch reference of one AIM training step, for comparison with
`cargo bench -p sinew-host --bench aim_train_step` (docs/BENCHMARKS.md).

Same work: five SIRENs 3->256->256->256->{3,1,3,1,57} (omega0 = 30, SIREN init), batch 4096
(point, shape) samples, the skin position loss through the 6D-rotation jaw LBS, the anatomy,
thickness, symmetry (512 points) and forehead (512 points) terms, Adam, on a template of 9,409
points (the ICT face region). Random data of the same shapes: the step's cost does not depend on
the values. `--distinct` runs the networks once per distinct point of the batch, as Sinew does
(about 3,300 of the 4,096 on 9,409 points). `--shapes-per-point K` draws the batch as
4,096 / K points with K different shapes each (Sinew's default `shapes_per_point` is 2; with
`--distinct`, about 1,850 distinct points). `--jaw-term` adds L_J on 512 more points (K(c) = 1 over
the jaw, on by default in Sinew). Sinew's default step is therefore
`--distinct --shapes-per-point 2 --jaw-term`. Run on demand (not in CI):

    python3 scripts/bench_torch_aim_step.py [--threads 2] [--steps 50] [--distinct]
        [--shapes-per-point K] [--jaw-term]
"""
import argparse
import time

import torch


def siren(widths, omega0=30.0):
    layers = []
    for i, (a, b) in enumerate(zip(widths[:-1], widths[1:])):
        lin = torch.nn.Linear(a, b)
        bound = 1.0 / a if i == 0 else (6.0 / a) ** 0.5 / omega0
        torch.nn.init.uniform_(lin.weight, -bound, bound)
        layers.append(lin)
    return torch.nn.ModuleList(layers)


def forward(net, x, omega0=30.0):
    for i, lin in enumerate(net):
        x = lin(x)
        if i + 1 < len(net):
            x = torch.sin(omega0 * x)
    return x


def rotate_6d(r6, v):
    b1 = torch.nn.functional.normalize(r6[:, 0:3], dim=1)
    a2 = r6[:, 3:6]
    b2 = torch.nn.functional.normalize(a2 - (b1 * a2).sum(1, keepdim=True) * b1, dim=1)
    b3 = torch.cross(b1, b2, dim=1)
    return b1 * v[:, 0:1] + b2 * v[:, 1:2] + b3 * v[:, 2:3]


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--steps", type=int, default=50)
    p.add_argument("--distinct", action="store_true")
    p.add_argument("--shapes-per-point", type=int, default=1)
    p.add_argument("--jaw-term", action="store_true")
    args = p.parse_args()
    torch.set_num_threads(args.threads)
    torch.manual_seed(0)
    shapes, verts, batch, aux = 20, 9409, 4096, 512
    m = shapes - 1
    nets = [siren([3, 256, 256, 256, o]) for o in (3, 1, 3, 1, 3 * m)]
    jaw = torch.nn.Parameter(torch.tensor([[1.0, 0, 0, 0, 1, 0, 0, 0, 0]]).repeat(m, 1))
    params = [q for n in nets for q in n.parameters()] + [jaw]
    opt = torch.optim.Adam(params, lr=1e-4)
    tpl = torch.rand(verts, 3) * 2 - 1
    gt = torch.rand(shapes, verts, 3)
    bone_t, thick_t, normal_t = torch.rand(verts, 3), torch.rand(verts, 1), torch.rand(verts, 3)
    mask = (torch.rand(verts, 1) < 0.3).float()
    mirror = torch.diag(torch.tensor([-1.0, 1.0, 1.0]))
    pivot = torch.zeros(1, 3)

    def step():
        per = args.shapes_per_point
        if per == 1:
            v = torch.randint(0, verts, (batch,))
            s = torch.randint(0, shapes, (batch,))
        else:
            v = torch.randint(0, verts, (batch // per,)).repeat_interleave(per)
            s = torch.rand(batch // per, shapes).argsort(1)[:, :per].flatten()
        if args.distinct:
            u, slot = torch.unique(v, return_inverse=True)
        else:
            u, slot = v, torch.arange(batch)
        x = tpl[u]
        b = (x + forward(nets[0], x))[slot]
        d = forward(nets[1], x)[slot]
        n = torch.nn.functional.normalize(forward(nets[2], x), dim=1)[slot]
        s0 = b + d * n
        k = forward(nets[3], x)[slot]
        e = forward(nets[4], x)[slot].reshape(batch, m, 3)
        table = torch.cat([torch.tensor([[1.0, 0, 0, 0, 1, 0, 0, 0, 0]]), jaw], 0)[s]
        moved = rotate_6d(table[:, :6], s0 - pivot) + pivot + table[:, 6:]
        skinned = k * moved + (1 - k) * s0
        e_all = torch.cat([torch.zeros(batch, 1, 3), e], 1)
        pred = skinned + e_all[torch.arange(batch), s]
        loss = ((pred - gt[s, v]) ** 2).sum(1).mean()
        mk = mask[v]
        loss = loss + (mk * (((b - bone_t[v]) ** 2).sum(1, keepdim=True) + (d - thick_t[v]) ** 2
                             + ((n - normal_t[v]) ** 2).sum(1, keepdim=True))).sum() / mk.sum().clamp(min=1)
        loss = loss + 7.5e-4 * (d ** 2).mean()
        xs = tpl[torch.randint(0, verts, (aux,))]
        xm = xs @ mirror
        sym = (xm + forward(nets[0], xm)) - (xs + forward(nets[0], xs)) @ mirror
        loss = loss + 1e-4 * (sym ** 2).sum(1).mean()
        xf = tpl[torch.randint(0, verts, (aux,))]
        loss = loss + 1e2 * (forward(nets[3], xf) ** 2).mean()
        if args.jaw_term:
            xj = tpl[torch.randint(0, verts, (aux,))]
            loss = loss + ((forward(nets[3], xj) - 1) ** 2).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
        return loss.item()

    for _ in range(5):
        step()
    times = []
    for _ in range(args.steps):
        t = time.perf_counter()
        step()
        times.append(time.perf_counter() - t)
    times.sort()
    what = (", distinct points" if args.distinct else "") + f", {args.shapes_per_point} shapes per point" \
        + (", L_J" if args.jaw_term else "")
    print(f"torch {torch.__version__}, {args.threads} threads{what}: median {1e3 * times[len(times) // 2]:.1f} ms/step, "
          f"min {1e3 * times[0]:.1f} ms over {args.steps} steps")


if __name__ == "__main__":
    main()
